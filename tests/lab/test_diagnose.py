"""Back to the components (``lab/diagnose.py``).

Independent references: the datasheet scene's own tolerance draw (the parts the synthetic
capture's circuit was built with: C2 is 4.35 % above the drawing, the others within 1 %), the
nonlinear parameter map evaluated at a part out of tolerance (the diagnosis linearises it), and
the chi-squared tail's closed form at a tabulated point.
"""

from __future__ import annotations

import dataclasses
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from precise_impact.lab import diagnose as D
from precise_impact.lab.budget import INPUTS, drawing, effective_parameters
from precise_impact.lab.identify import identify
from precise_impact.lab.scope_files import write_capture
from precise_impact.lab.synth import synth_capture
from precise_impact.models.circuit.effects.tolerance import actual_components
from precise_impact.scenes.scene import load_scene

DATASHEET = "fig6-period2-datasheet"


@pytest.fixture(scope="session")
def datasheet():
    """50 periods of the datasheet circuit (its seeded tolerance draw, the switches'
    on-resistance) through the scope model, identified against its drawing."""
    cap = synth_capture(DATASHEET, periods=50, bits=8, noise=0.01, seed=3)
    return identify(cap, DATASHEET)


def test_a_circuit_built_within_tolerance_is_explained_by_its_largest_deviation(datasheet):
    """The draw put C2 4.35 % above its drawn value (5 % capacitors; every resistor within
    1 %): the circuit is called within tolerance, C2 carries the largest share of the joint
    explanation (its posterior holds the truth within 2 standard errors), with R2 and R3 as
    the twins the measurement cannot tell it from."""
    sc = load_scene(DATASHEET)
    built = actual_components(sc.design(), sc.effects)
    truth = float(built.C2) / float(sc.design().C2) - 1
    d = D.diagnose(datasheet)
    top = d.ranked[0]
    assert d.consistent["p_all_within_tolerance"] > 0.5 and d.consistent["p_value"] > 0.05
    assert top["part"] == "C2" and top["joint_change"] > 0, d.summary()
    assert abs(top["joint_change"] - truth) < 2 * top["joint_stderr"], (top, truth)
    assert {"R2", "R3"} <= set(top["twins"])
    assert abs(sum(e["probability"] for e in d.ranked) - 1) < 1e-12


def test_a_part_out_of_tolerance_is_found_through_the_nonlinear_map(datasheet):
    """The measurement replaced by the nonlinear map's values with R7 10 % off (a 1 % part;
    errors of 1e-5 relative): not within tolerance, R7 the likeliest part out of it, its change
    within 2 standard errors of 10 % (the other parts' tolerances are the noise)."""
    comp, ron, _, _ = drawing(DATASHEET)
    c = {n: float(getattr(comp, n)) for n in INPUTS}
    c["R7"] *= 1.10
    y = effective_parameters({**c, "Omega": float(comp.Omega)}, float(ron),
                             V_unit=float(comp.V_unit))  # fmt: skip
    d = D.diagnose(_identified_as(datasheet, y, rel=1e-5))
    top = max(d.ranked, key=lambda e: e["probability"])
    assert d.consistent["p_all_within_tolerance"] < 0.05, d.summary()
    assert top["part"] == "R7" and top["probability"] > 0.3, d.summary()  # R1, V_A: 10-15 % each
    assert abs(top["change"] - 0.10) < 2 * top["stderr"], top


def _identified_as(r, y: dict, rel: float):
    """``r`` with its globals moved to realise ``(omega, zeta, a, x_w) = y`` and a covariance
    of ``rel`` relative standard errors."""
    cov = r.covariance
    names = list(cov["names"])
    g = dict(zip(names, cov["values"], strict=True))
    a_old = math.hypot(g["a_c"], g["a_s"])
    g.update(
        eta=float(r.record["Omega_rad_s"]) / y["omega"], zeta=y["zeta"], x_w=y["x_w"],
        a_c=g["a_c"] * y["a"] / a_old, a_s=g["a_s"] * y["a"] / a_old,
    )  # fmt: skip
    values = [g[n] for n in names]
    matrix = np.diag([(rel * max(abs(v), 1e-3)) ** 2 for v in values]).tolist()
    return dataclasses.replace(r, covariance={**cov, "values": values, "matrix": matrix})


def test_chi2_tail_at_a_tabulated_point():
    """chi^2 with 4 degrees of freedom: P(X > 9.4877) = 0.05 (tables)."""
    assert abs(D.chi2_sf(9.487729, 4) - 0.05) < 1e-6


def test_the_diagnosis_is_strict_json_and_a_table(datasheet):
    d = D.diagnose(datasheet)
    json.dumps(d.to_dict(), allow_nan=False)
    df = d.to_dataframe()
    assert list(df["part"])[0] == "C2" and len(df) >= 12 and "joint_change [1]" in df
    assert "C2" in d.summary()


def test_cli_diagnoses_as_strict_json(tmp_path):
    cap = synth_capture(DATASHEET, periods=40, bits=8, noise=0.01, seed=3)
    path = write_capture(cap, tmp_path / "scope.csv", "rigol")
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "precise_impact",
            "identify",
            str(path),
            "--scene",
            DATASHEET,
            "--diagnose",
            "--json",
            "--out",
            str(tmp_path / "out"),
        ],  # fmt: skip
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    d = json.loads(r.stdout)
    assert d["diagnosis"]["ranked"][0]["part"] in {"C1", "C2"}
    assert (tmp_path / "out" / "diagnose.json").exists()
