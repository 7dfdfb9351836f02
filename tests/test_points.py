"""Bifurcation-point scores: the black-box locators must find the points of a system whose
points are known independently (closed form, continuation), including a system shifted away
from the reference, and compare must report them."""

import json
import math
import subprocess
import sys
from fractions import Fraction

import pytest

import precise_impact as pi
from precise_impact.verification.points import mechanical_points, model_grazing, model_period_doubling


def _fast(params, periods, per_period):
    return pi.simulate(params, periods, per_period=per_period, model="fast")


@pytest.mark.parametrize("zeta,R", [("0.05", "1"), ("0.06", "0.9")])
def test_locators_find_known_points_of_a_shifted_system(zeta, R):
    """The 'model' is the mechanics with other zeta and R: its grazing frequency is a closed form,
    its period-doubling point the continuation's (mu = -1 to rounding).  Starting from the paper's
    points, the locators must land on the shifted system's own."""
    paper = mechanical_points(pi.Params.make())
    p = pi.Params.make(zeta=zeta, R=R)
    exact_g = float(pi.grazing_frequencies(p)[0])
    g = model_grazing(_fast, p, paper["grazing"])
    # the margin is measured to ~1e-11 (cubic through 7 dense samples, transient e^(-zeta 64 T)
    # < 1e-10) and |d margin / d eta| ~ 5: the root to ~1e-10; 1e-8 leaves room
    assert g["how"] == "root" and abs(g["eta"] - exact_g) < 1e-8, (g["eta"], exact_g)
    own = mechanical_points(p)
    d = model_period_doubling(_fast, p, paper["period-doubling"], paper["pd_state"])
    # the +-1e-3 fits cancel the quadratic terms: the multipliers to ~1e-8, the point to ~1e-8
    assert d["how"] == "root" and abs(d["eta"] - own["period-doubling"]) < 1e-7, (d["eta"], own["period-doubling"])
    if zeta != "0.05":
        assert abs(own["period-doubling"] - paper["period-doubling"]) > 1e-3  # really shifted


def test_mechanical_period_doubling_is_a_multiplier_minus_one():
    m = mechanical_points(pi.Params.make())
    o = pi.find_orbit(pi.Params.make(eta=Fraction(m["period-doubling"])), 1, guess=m["pd_state"], impacts=1)
    assert min(abs(mu + 1) for mu in o.multipliers) < 1e-10


def test_compare_points_cli(tmp_path):
    out = tmp_path / "cmp"
    r = subprocess.run([sys.executable, "-m", "precise_impact", "compare", "fig4-periodic-ideal", "--models",
                        "heyoka,circuit", "--periods", "20", "--points", "--out", str(out)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert "grazing eta" in r.stdout and "written:" in r.stdout
    d = json.loads((out / "scores.json").read_text())
    assert d["reference"]["points"]["grazing"] == float(pi.grazing_frequencies(pi.Params.make())[0])
    for m in ("heyoka", "circuit"):
        pts = d["models"][m]["points"]
        # the ideal circuit realises the mechanics: both shifts at the locators' resolution
        assert abs(pts["grazing"]["shift"]) < 1e-8 and abs(pts["period-doubling"]["shift"]) < 1e-7, (m, pts)
    assert "## Bifurcation points along eta" in (out / "report.md").read_text()
    assert math.isfinite(d["models"]["circuit"]["points"]["period-doubling"]["fit_residual"])
