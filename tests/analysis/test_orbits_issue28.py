"""Periodic orbits, correct or refused (issue 28, items 2-6): LLE from logarithms when the
multipliers underflow, outward-rounded LLE enclosures, virtual orbits counted apart, a
tangential impact met by continuation, a transient of bounded memory with a budget, negative
numbers in scientific notation among a flag's values, and no refusal for an unused start."""

from __future__ import annotations

import json
import math

import mpmath
import numpy as np
import pytest

import precise_impact as pi
from precise_impact.analysis.orbits import newton
from precise_impact.analysis.orbits.shooting import ShootingSystem, from_orbit
from precise_impact.cli.main import main
from precise_impact.errors import OverBudgetError

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")


# ---- item 2: the LLE of an orbit whose multipliers underflow --------------------------------
def test_underflowed_multipliers_give_the_exact_lle():
    # zeta p T = 0.999 * 2 pi / 0.001 = 6277: exp(-6277) is 0 in float64 (LLE was -inf, JSON null)
    p = pi.Params.make(zeta="0.999", eta="0.001")
    o = pi.find_orbit(p, 1)
    assert o.impacts == 0 and max(abs(m) for m in o.multipliers) == 0
    assert o.lle == -0.999  # a non-impacting orbit: exactly -zeta
    assert json.loads(json.dumps(o.to_dict(), allow_nan=False))["lle"] == -0.999
    res = pi.continue_orbit(p, "eta", "0.001", "0.0011", 1, max_points=3, doublings=0)
    assert list(res.branches[0].lle) == [-0.999] * len(res.branches[0].lle)


def test_scaled_monodromy_lle_matches_the_closed_form():
    # the logarithm path on an impacting orbit (eta = 0.985, 1 impact per 2 periods) agrees
    # with ln|mu| / (p T) of the 50-digit closed form: float64 rounding of a 2x2 product over
    # p T = 12.8, ~10 eps relative on |mu|, so 1e-15 / (p T) ~ 1e-16 absolute; 1e-14 is safe
    p = pi.Params.make(eta="0.985")
    o = pi.find_orbit(p, 2)
    base = {k: float(getattr(p, k)) for k in ("eta", "zeta", "a", "x_w", "R", "t0")}
    system = ShootingSystem(base, "eta", 2, o.impacts)
    u = from_orbit(system, p, o.x, o.v, base["eta"])
    closed = pi.one_impact_orbits(p, dps=50, period=2)[0]
    with mpmath.workdps(50):
        exact = mpmath.log(abs(closed.multipliers[0])) / (4 * mpmath.pi / mpmath.mpf("0.985"))
    assert abs(system.floquet_lle(u, base["eta"]) - float(exact)) < 1e-14
    assert abs(o.lle - float(exact)) < 1e-14


# ---- item 3: an LLE enclosure never narrower than its rounding --------------------------------
def test_proven_lle_interval_is_rounded_outward():
    p = pi.Params.make(eta="0.985")
    lo, hi = pi.prove_orbit(p, 2).lle
    closed = pi.one_impact_orbits(p, dps=50, period=2)[0]
    with mpmath.workdps(50):
        exact = mpmath.log(abs(closed.multipliers[0])) / (4 * mpmath.pi / mpmath.mpf("0.985"))
        # before: lo == hi == the nearest float, 1.1e-19 from the value it claimed to enclose
        assert mpmath.mpf(lo) <= exact <= mpmath.mpf(hi)
    assert lo < hi and hi - lo <= 2 * math.ulp(abs(lo))  # outward: one ulp at most each side


# ---- items 4, 5 and 6: a continuation through a tangential impact, reversed range -----------
@pytest.fixture(scope="session")
def tangential():
    # R = 0.9, eta from 1.04 down to 0.95: the doubled branch's regula falsi landed on an
    # impact with v^- = 0 exactly: ZeroDivisionError from the saltation matrix (a traceback)
    return pi.continue_orbit(pi.Params.make(R="0.9"), "eta", "1.04", "0.95", 1)


def test_continuation_through_a_tangential_impact(tangential):
    res = tangential
    graze = [b for b in res.bifurcations if b.type == "grazing"]
    # located by the tangency condition v^- = 0 to rounding: the regula falsi stops at an
    # arclength bracket of 4 eps (1 + |y|), where v^- is 64 eps at most (measured: exactly 0
    # on the landed main, -1.07e-14 = 48 eps once the start's transient ran on the local
    # clock); exactly there the multipliers are undefined (NaN), beside it the larger one is
    # huge (it grows without bound towards the tangency, ~1 / v^-)
    assert graze and abs(graze[0].test) <= 64 * 2.0**-52
    mus = [
        abs(complex(*m)) if not any(map(math.isnan, m)) else math.nan for m in graze[0].multipliers
    ]
    assert all(math.isnan(m) for m in mus) or max(mus) > 1e8, mus
    json.dumps(res.to_dict(), allow_nan=False)  # strict JSON: null for the undefined values
    assert res.start > res.stop and min(res.branches[0].values) == pytest.approx(0.95)


def test_virtual_orbits_are_counted_apart(tangential, capsys):
    for b in tangential.branches:
        n = b.counts()
        assert sum(n.values()) == len(b.values)
        assert n["virtual"] == int(np.sum(~b.admissible))
        assert n["stable"] == int(np.sum(b.stable & b.admissible))
    doubled = tangential.branches[1]
    assert doubled.counts()["virtual"] > 0 and np.any(doubled.stable & ~doubled.admissible)
    code = main(["continue", "--param", "eta", "1.04", "0.95", "--R", "0.9", "--doublings", "1"])
    out = capsys.readouterr().out
    assert code == 0
    n = doubled.counts()
    assert (
        f"{n['stable']} stable, {n['unstable']} unstable, {n['virtual']} virtual"
        in out.splitlines()[1]
    )
    # the tangential point: multipliers undefined (exactly on it) or its detail (beside it)
    assert "undefined (a tangential impact" in out or "the impact becomes tangential" in out


# ---- item 5: the transient in chunks, with a budget ----------------------------------------
def test_transient_runs_in_chunks(monkeypatch):
    from precise_impact.solvers.fast.single import FastSolver

    p = pi.Params.make(eta="0.985")
    whole = pi.find_orbit(p, 2, transient=50)
    calls = []
    solve = FastSolver.solve

    def spy(self, params, periods, per_period=0):
        calls.append(periods)
        return solve(self, params, periods, per_period)

    monkeypatch.setattr(FastSolver, "solve", spy)
    monkeypatch.setattr(newton, "TRANSIENT_CHUNK", 7)
    chunked = pi.find_orbit(p, 2, transient=50)
    assert calls == [7] * 7 + [1]  # only one chunk of samples held at a time
    # the same orbit: Newton from two starting states that differ by rounding
    assert abs(chunked.x - whole.x) < 1e-12 and abs(chunked.v - whole.v) < 1e-12


def test_transient_over_budget_is_refused_before_work(capsys):
    with pytest.raises(OverBudgetError, match="max_time"):
        pi.find_orbit(pi.Params.make(x_w="5"), 1, transient=10**8, max_time=100)
    assert main(["orbit", "--transient", "100000000", "--max-time", "100"]) == 3  # a budget
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "transient of 100000000 periods" in err


# ---- item 6: negative numbers in scientific notation, an unused default start ---------------
@pytest.mark.parametrize(
    ("argv", "message"),
    [
        # parsed, then refused by the validators naming the flag (before: argparse's "expected 2
        # arguments" for the two-value flags)
        (
            [
                "continue",
                "--param",
                "eta",
                "1",
                "1.1",
                "--guess",
                "-1e-3",
                "-2E-1",
                "--max-points",
                "0",
            ],
            "max_points = ",
        ),
        (["certify", "--y0", "-1e-3", "0"], "y0 = '-1e-3 0' is not allowed: only with --k"),
        (["simulate", "--tol", "-1e-9"], "tol = '-1e-9'"),
    ],
)
def test_negative_scientific_values_are_values(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "expected" not in err


def test_negative_scientific_wall(capsys):
    assert main(["simulate", "--x_w", "-.5e-1", "--x0", "-1", "--periods", "1", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["params"]["x_w"] == "-0.05"


def test_orbit_with_a_guess_in_scientific_notation(capsys):
    assert main(["orbit", "--eta", "0.985", "--period", "2", "--guess", "-1e-3", "0"]) == 0
    assert "period-2 orbit with 1 impact(s)" in capsys.readouterr().out


def test_no_refusal_for_an_unused_default_start(capsys):
    # x_w < 0 with no --x0: the transient starts at the wall instead of refusing x0 = 0
    assert main(["orbit", "--x_w", "-0.1", "--eta", "2.5", "--R", "0.8"]) == 0
    assert "period-1 orbit with 1 impact(s)" in capsys.readouterr().out
    assert main(["orbit", "--x_w", "-0.1", "--eta", "2.5", "--R", "0.8", "--x0", "0"]) == 2
    assert "x0 = " in capsys.readouterr().err  # a start given inside the wall: still refused


def test_continuation_in_x_w_past_the_start_position():
    # the start x0 = 0 seeds the orbit at x_w = 0.5 only: x_w = -0.5 at the range's end was
    # refused for it ("x0 <= x_w = -0.5")
    res = pi.continue_orbit(
        pi.Params.make(eta="0.8"), "x_w", "0.5", "-0.5", 1, max_points=50, doublings=0
    )
    assert min(res.branches[0].values) < 0


# ---- items 2 and 3 in the Lyapunov report of a periodic orbit -------------------------------
def test_floquet_second_exponent_and_resolution_from_logarithms():
    from precise_impact.analysis.orbits.result import (
        floquet_resolution,
        floquet_second_exponent,
    )

    pT = 2 * math.pi / 0.001
    # non-impacting, mu_2 = 0 in float64: lambda_2 = -2 zeta - lambda_1 = -0.999 (was -inf)
    assert floquet_second_exponent(-0.999, 0.0, 0.999, 1.0, 0, pT) == pytest.approx(-0.999, abs=0)
    # n impacts: ln|det M| / (p T) = 2 n ln R / (p T) - 2 zeta
    lam2 = floquet_second_exponent(-0.5, 0.0, 0.3, 0.8, 2, 10.0)
    assert lam2 == pytest.approx(4 * math.log(0.8) / 10 - 0.6 + 0.5, rel=1e-15)
    assert floquet_second_exponent(-0.5, 0.0, 0.3, 0.0, 1, 10.0) == -math.inf  # plastic
    assert floquet_second_exponent(-0.5, 0.25, 0.3, 0.8, 1, 10.0) == math.log(0.25) / 10
    # the bar is 1e-12 / (p T) (unchanged, eta = 0.985) or two ulps where that is smaller
    assert floquet_resolution(-0.0263, 4 * math.pi / 0.985) == 1e-12 / (4 * math.pi / 0.985)
    assert floquet_resolution(-0.999, pT) == 2 * math.ulp(0.999) > 1e-12 / pT


@pytest.mark.slow  # ~20 s: 400 periods of 6283 time units, the heyoka fallback
def test_lyapunov_of_an_underflowing_periodic_orbit():
    r = pi.lyapunov(
        pi.Params.make(zeta="0.999", eta="0.001"), model="fast", periods=400, transient=10
    )
    assert r.lle_source == "floquet"
    assert r.lle == -0.999 and r.spectrum[1] == pytest.approx(-0.999, abs=1e-15)
    assert r.lle_stderr >= 2 * math.ulp(0.999)  # before: (-0.999, -inf), 1.4 ulps
