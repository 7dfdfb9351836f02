"""Strict JSON everywhere (issue 28): every result's ``to_dict()`` and every file or line the
package writes passes ``json.dumps(..., allow_nan=False)`` / a strict parser, whatever
non-finite numbers the result holds (NaN is ``null``, an infinity ``"inf"`` / ``"-inf"``)."""

from __future__ import annotations

import dataclasses
import functools
import json
import math
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

import precise_impact as pi
from precise_impact import Params
from precise_impact.io.jsonout import dumps, print_json, write_json


def strict_loads(text: str):
    """Parse refusing the NaN / Infinity / -Infinity tokens Python's parser accepts."""

    def refuse(token):
        raise AssertionError(f"non-strict JSON token {token}")

    return json.loads(text, parse_constant=refuse)


def assert_strict(obj):
    text = json.dumps(obj, allow_nan=False)  # raises ValueError on NaN / inf
    strict_loads(text)


def test_the_writer_refuses_nothing_and_writes_no_nan(tmp_path, capsys):
    obj = {"a": math.nan, "b": [math.inf, -math.inf, 1.5], "c": (np.float64("nan"),), "d": 2}
    expect = {"a": None, "b": ["inf", "-inf", 1.5], "c": [None], "d": 2}
    assert strict_loads(dumps(obj)) == expect
    write_json(tmp_path / "o.json", obj)
    assert strict_loads((tmp_path / "o.json").read_text()) == expect
    print_json(obj)
    assert strict_loads(capsys.readouterr().out) == expect
    # a default's results are made strict too (np.float32 is not a float subclass)
    assert strict_loads(dumps({"x": np.float32("inf")}, default=lambda o: float(o))) == {"x": "inf"}


P = Params.make()


def _results():
    """(name, zero-argument callable giving a result) for every public function with one."""
    from precise_impact import (
        SwitchedCapacitorSolver,
        bifurcation,
        certify,
        certify_coupled,
        continue_orbit,
        find_orbit,
        lyapunov,
        nominal_components,
        one_impact_orbits,
        prove_orbit,
        simulate,
        simulate_coupled,
        simulate_coupled_circuit,
        sync_scan,
    )

    yield "simulate-heyoka-mp120", lambda: simulate(P, 2, precision="mp:120")
    yield "simulate-analytical", lambda: simulate(P, 2, model="analytical")
    yield "simulate-fast", lambda: simulate(P, 2, model="fast")
    yield "simulate-circuit", lambda: simulate(P, 2, model="circuit")
    # once a ValueError from to_dict, then null velocities: now V_q at the flip (issue 27)
    for prec in ("float64", "float128", "mp:120"):
        yield (
            f"switched-{prec}",
            lambda prec=prec: SwitchedCapacitorSolver(precision=prec).solve(P, 2),
        )
    yield "simulate_coupled", lambda: simulate_coupled(P, "0.05", periods=2)
    yield (
        "simulate_coupled_circuit",
        lambda: simulate_coupled_circuit(nominal_components(P), "0.05", 2),
    )
    yield "certify", lambda: certify(P, periods=2, precision="mp:128")
    yield (
        "certify_coupled",
        lambda: certify_coupled(P, "0.1", "reduced", 2, y0=("0.5", "0.1"), precision="mp:128"),
    )
    yield "lyapunov-variational", lambda: lyapunov(P, periods=20, transient=5)
    yield "lyapunov-fast", lambda: lyapunov(P, model="fast", periods=20, transient=5)
    yield "lyapunov-two", lambda: lyapunov(P, "two-trajectory", periods=20, transient=5)
    # R = 0: the second exponent is -inf (plastic impacts)
    yield "lyapunov-R0", lambda: lyapunov(Params.make(eta="0.8", R="0"), periods=50, transient=5)
    yield (
        "bifurcation",
        lambda: bifurcation(P, ("eta", "0.7", "0.72", 2), periods=5, transient=5, workers=1),
    )
    yield (
        "sync_scan",
        lambda: sync_scan(
            P, "first-order", ["0.05"], periods=5, ensemble=1, lle_periods=10, lle_transient=5
        ),
    )
    yield "find_orbit", lambda: find_orbit(Params.make(eta="0.74"), 3, transient=200)
    yield "one_impact_orbits", lambda: one_impact_orbits(Params.make(R="0.8", eta="1"), 20, 50)
    yield (
        "continue_orbit",
        lambda: continue_orbit(
            Params.make(R="0.8"), "eta", "1", "0.99", 1, max_points=4, doublings=0, transient=200
        ),
    )
    yield (
        "prove_orbit",
        lambda: prove_orbit(
            Params.make(eta="0.70"), 1, bits=128, guess=("102/53", "49/265"), impacts=0
        ),
    )

    yield "accuracy_table", lambda: pi.accuracy_table(periods=2, etas=("0.712",))
    yield (
        "compare",
        lambda: pi.compare("fig5-chaotic-ideal", ["circuit"], periods=10, transient=2),
    )
    yield (
        "run_scene",
        lambda: pi.run_scene(dataclasses.replace(pi.load_scene("fig5-chaotic-ideal"), periods=2)),
    )


RESULTS = dict(_results())


def _dicts(r):
    rs = r if isinstance(r, list) else [r]
    assert rs, "a public function returned no result to check"
    return [x.to_dict() for x in rs]


@pytest.mark.parametrize("name", list(RESULTS))
def test_every_result_to_dict_is_strict_json(name):
    for d in _dicts(RESULTS[name]()):
        assert_strict(d)


def test_a_sweep_result_is_strict_json(tmp_path):
    spec = pi.SweepSpec.make(P, [("eta", "0.7", "0.72", 2)], periods=5, transient=5)
    res = pi.run_sweep(spec, tmp_path, workers=1, progress=False)
    assert_strict(res.to_dict())
    strict_loads((tmp_path / "sweep_spec.json").read_text())


def test_non_finite_fields_of_every_result_type_are_strict_json():
    """A result holding NaN and infinities (an LLE of -inf, a NaN stderr, an infinite
    multiplier, a NaN rate): ``to_dict()`` is strict JSON and keeps the sign of infinity."""
    from precise_impact import lyapunov

    r = lyapunov(P, periods=20, transient=5)
    bad = dataclasses.replace(r, lle=-math.inf, lle_stderr=math.nan, spectrum=(-math.inf, math.inf))
    d = bad.to_dict()
    assert_strict(d)
    assert d["lle"] == "-inf" and d["lle_stderr"] is None and d["spectrum"] == ["-inf", "inf"]
    o = pi.find_orbit(Params.make(eta="0.74"), 3, transient=200)
    o2 = dataclasses.replace(o, lle=-math.inf, residual=math.nan)
    d = o2.to_dict()
    assert_strict(d)
    assert d["lle"] == "-inf" and d["residual"] is None
    b = pi.bifurcation(P, ("eta", "0.7", "0.72", 2), periods=5, transient=5, workers=1)
    b.lle[0], b.lle_stderr[1] = -np.inf, np.nan
    assert_strict(b.to_dict())


def test_r0_spectrum_keeps_its_minus_infinity():
    r = pi.lyapunov(Params.make(eta="0.8", R="0"), periods=50, transient=5)
    assert r.spectrum is not None and r.spectrum[1] == -math.inf
    assert r.to_dict()["spectrum"][1] == "-inf"


# --------------------------------------------------------------------- every --json command
#: Quick arguments of every command that has ``--json`` (``{out}``: a fresh directory).
JSON_COMMANDS = {
    "simulate": ["simulate", "--eta", "0.74", "--periods", "3", "--model", "switched-capacitor"],
    "accuracy": ["accuracy", "--periods", "2"],
    "certify": ["certify", "--periods", "2", "--precision", "mp:128"],
    "compare": ["compare", "fig5-chaotic-ideal", "--models", "switched-capacitor,certified"]
    + ["--periods", "10"],
    "continue": ["continue", "--param", "eta", "1", "0.99", "--R", "0.8", "--max-points", "4"]
    + ["--doublings", "0", "--transient", "200", "--diagram", "0"],
    "lle": ["lle", "--eta", "0.74", "--periods", "20", "--transient", "5"],
    "orbit": ["orbit", "--eta", "0.74", "--period", "3", "--transient", "200"],
    "run": ["run", "fig5-chaotic-datasheet", "--model", "switched-capacitor"],
    "sweep": ["sweep", "--axis", "eta", "0.7", "0.72", "2", "--periods", "5", "--transient", "5"]
    + ["--model", "fast", "--workers", "1", "--out", "{out}"],
    "sync": ["sync", "--k", "0.05", "0.05", "1", "--periods", "5", "--ensemble", "1"]
    + ["--fig7", "0.031", "0.032", "--model", "fast", "--out", "{out}"],
    "bench": ["bench", "work-precision", "--quick"],
    "spice": ["spice", "score", str(Path(__file__).parent / "lab/data/fig6_period3_ideal.cir")]
    + ["--x-node", "s", "--v-node", "q", "--forcing-node", "v3", "--scene", "fig6-period3-ideal"],
    "budget": ["budget", "--landmarks", "grazing", "--mc", "10", "--sobol", "0", "--lle-mc", "0"]
    + ["--no-scans", "--out", "{out}"],
    "capture": ["capture", "synth", "--out", "{out}/cap.npz", "--periods", "5", "--transient", "5"],
    "response": ["response", "--param", "x_w", "-2", "0.5", "--at", "-1", "--eta", "2.8"]
    + ["--zeta", "0", "--R", "0.8", "--max-points", "30"],
    "impact-map": ["impact-map", "--eta", "0.74", "--n", "20", "--transient", "0"],
    "singularity": ["singularity", "--eta", "0.74", "--v-max", "1", "--step", "0.05"]
    + ["--orbit", "0"],
    "basins": ["basins", "--eta", "0.74", "--phase", "0", "1", "3", "--v", "0", "2", "2"]
    + ["--transient", "20", "--out", "{out}"],
    # {tmp}/scope.csv: 30 periods of the period-3 orbit, written by the test first
    "identify": ["identify", "{tmp}/scope.csv", "--scene", "fig6-period3-ideal"],
}
#: Over ~5 s each: CI runs them in its slow step.
SLOW_JSON = {"bench", "compare", "spice"}

#: ``bench work-precision --quick`` through ``work_precision(config=...)`` (the hook the CLI's
#: function offers to shrink a run): every family, row kind and headline of the quick run
#: (heyoka float64 / longdouble / float128 / mp, the paper's and the robust closed forms and
#: mpmath, scipy's three methods, ngspice, the chaos table and its certification, the circuit
#: ratio) in one or two settings over 10 periods, so the JSON line has the same form: finite
#: errors, ints and nulls for horizons (DOP853 rtol=1e-6 and ngspice lose the chaotic orbit),
#: a null compile time outside heyoka, the float64 headline bracketed.  The quick run took 68 s,
#: 34 s of it in scipy's Radau and 8 s in the chaos table's 200-period references.
BENCH_JSON_CONFIG = {
    "cases": {
        "periodic": {"eta": "0.74", "periods": 10},
        "chaotic": {"eta": "0.712", "periods": 10},
    },
    "heyoka": {"float64": ["1e-6", None], "longdouble": [None], "float128": [None]},
    "heyoka_mp": [128],
    "analytical_paper": [Fraction(1, 100)],
    "analytical_robust": True,
    "analytical_mp_dps": [30],
    "scipy": {"DOP853": [1e-6, 1e-8], "Radau": [1e-6], "LSODA": [1e-6]},
    "spice_tmax": ["30e-6"],
    "chaos_N": [10, 20],
    "certify_N": 40,
    "budget_s": 0.1,
    "circuit": True,
}


def _json_commands() -> set[str]:
    """Every command (and sub-command) whose parser has ``--json``."""
    import argparse

    from precise_impact.cli.main import build_parser

    def subs(p):
        return next((a for a in p._actions if isinstance(a, argparse._SubParsersAction)), None)

    found = set()
    for name, p in subs(build_parser()).choices.items():
        inner = subs(p)
        for q in [p] if inner is None else inner.choices.values():
            if any("--json" in a.option_strings for a in q._actions):
                found.add(name)
    return found


def test_every_json_command_is_checked():
    assert set(JSON_COMMANDS) == _json_commands()


@pytest.mark.parametrize(
    "name",
    [pytest.param(n, marks=pytest.mark.slow) if n in SLOW_JSON else n for n in JSON_COMMANDS],
)
def test_every_json_command_prints_one_strict_json_object(name, tmp_path, monkeypatch):
    """Each command's ``--json`` prints exactly one line a strict parser loads (the switched
    capacitor's impact velocities were NaN, its compare W1 NaN)."""
    import contextlib
    import io

    from precise_impact.cli.main import main

    if name == "bench":  # the quick run's form in a smaller run: BENCH_JSON_CONFIG
        from precise_impact.cli.commands import bench

        small = functools.partial(bench.work_precision, config=BENCH_JSON_CONFIG)
        monkeypatch.setattr(bench, "work_precision", small)

    if name == "identify":
        from precise_impact.lab.scope_files import write_capture
        from precise_impact.lab.synth import synth_capture

        cap = synth_capture("fig6-period3-ideal", periods=30, seed=3)
        write_capture(cap, tmp_path / "scope.csv", "rigol")

    args = [
        a.replace("{out}", str(tmp_path / "out")).replace("{tmp}", str(tmp_path))
        for a in JSON_COMMANDS[name]
    ] + ["--json"]
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(args)
    assert code == 0, err.getvalue()[-800:]
    lines = out.getvalue().strip().splitlines()
    assert len(lines) == 1, out.getvalue()[-500:]
    obj = strict_loads(lines[0])
    assert isinstance(obj, dict) and obj
    assert "null" not in obj  # no value a model did not record (switched-capacitor: it does)
