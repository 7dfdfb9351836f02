"""(1,n) response curves against the Budd-Dux closed forms (zeta = 0, r = 0.8, omega = 2.8)."""

from __future__ import annotations

import json
import subprocess
import sys
from fractions import Fraction

import mpmath
import numpy as np
import pytest

import precise_impact as pi
from precise_impact.analysis.impact_surface.response import (
    budd_dux_locate,
    budd_dux_orbit,
    budd_dux_points,
    response_curve,
)
from precise_impact.analysis.orbits.newton import find_orbit
from precise_impact.cli.main import main
from precise_impact.core import flight
from precise_impact.errors import BudgetExceededError, ConvergenceError, ParameterError

# The continuation locates a test-function zero by regula falsi to ~4 eps in arclength, then
# corrects onto the branch with residual <= 1e-10 (scaled); a fold's parameter is quadratic in
# arclength and a period-doubling's linear with O(1) slope, so both land within ~100 eps of
# the exact point: 1e-12 (the bound) holds with two orders to spare.
TOL = 1e-12


@pytest.fixture(scope="session")
def sigma_curve():
    p = pi.Params.make(zeta="0", a="1", R="0.8", eta="2.8", x_w="-1", x0="-2")
    return response_curve(p, 1, "x_w", "-2", "0.5", at="-1", max_points=400)


@pytest.fixture(scope="session")
def omega_curve():
    p = pi.Params.make(zeta="0", a="1", R="0.8", eta="2.8", x_w="-0.5", x0="-2")
    return response_curve(p, 1, "eta", "1.5", "5", at="2.8", max_points=400)


def _closed_form(kind, value):
    pts = [q for q in budd_dux_points("2.8", "0.8", dps=50) if q["type"] == kind]
    return min(pts, key=lambda q: abs(float(q["x_w"]) - value))


def test_sigma_folds_and_period_doublings_agree_with_budd_dux(sigma_curve):
    found = {"fold": 0, "period-doubling": 0, "grazing": 0}
    for b in sigma_curve.bifurcations:
        if b.type not in found or (b.type == "grazing" and abs(b.impact_v[0]) > 1e-9):
            continue  # interior grazings (a flight's maximum on the wall) have no closed form here
        ref = _closed_form(b.type, b.value)
        assert abs(b.value - float(ref["x_w"])) <= TOL, (b.type, b.value, ref["x_w"])
        # V along the curve: the fold's V is where the parameter turns (V to ~sqrt of the
        # located arclength error); the others are transversal
        assert abs(b.impact_v[0] - float(ref["V"])) <= 1e-9, (b.type, b.impact_v, ref["V"])
        found[b.type] += 1
    # the physical fold (V > 0), both period-doublings (physical and virtual), both V = 0 grazings
    assert found == {"fold": 1, "period-doubling": 2, "grazing": 2}


def test_one_impact_per_two_periods_agrees_with_budd_dux():
    # (1,2) at omega = 5.6: measured fold 9.6e-16, period-doublings 4e-17, grazings 3e-16
    p = pi.Params.make(zeta="0", a="1", R="0.8", eta="5.6", x_w="-0.3", x0="-2")
    rc = response_curve(p, 2, "x_w", "-1", "0.3", at="-0.3")
    refs = budd_dux_points("5.6", "0.8", n=2, dps=50)
    kinds = []
    for b in rc.bifurcations:
        if b.type == "grazing" and abs(b.impact_v[0]) > 1e-9:
            continue  # an interior grazing: no closed form here
        ref = min(
            (q for q in refs if q["type"] == b.type), key=lambda q: abs(float(q["x_w"]) - b.value)
        )
        assert abs(b.value - float(ref["x_w"])) <= TOL, (b.type, b.value, ref["x_w"])
        kinds.append(b.type)
    assert sorted(kinds) == ["fold", "grazing", "grazing", "period-doubling", "period-doubling"]
    assert {"stable", "unstable", "unphysical", "virtual"} <= set(rc.kind)


def test_closed_form_fold_is_a_multiplier_plus_one():
    # the turning point tan(theta) = beta omega and the multiplier test 1 - tr + det are two
    # independent closed forms: they agree at 50 digits (det M = r^2 exactly)
    for q in budd_dux_points("2.8", "0.8", dps=50):
        if q["type"] == "fold":
            assert abs(q["test"]) < mpmath.mpf(10) ** -45
        if q["type"] == "period-doubling":
            assert abs(q["test"]) < mpmath.mpf(10) ** -40
    ops = flight.MpmathOps(dps=50)
    _, _, _, det = budd_dux_orbit(
        ops.num(Fraction(1)), ops.num(Fraction(28, 10)), ops.num(Fraction(4, 5)), 1, 1, ops
    )
    assert abs(det - ops.num(Fraction(16, 25))) < mpmath.mpf(10) ** -48


def test_omega_fold_and_period_doubling_agree_with_budd_dux(omega_curve):
    kinds = []
    for b in omega_curve.bifurcations:
        if b.type not in ("fold", "period-doubling"):
            continue
        ref = budd_dux_locate(b.type, b.value, "-0.5", b.impact_v[0], "0.8", dps=50)
        assert abs(float(ref["x_w"]) + 0.5) < 1e-45 and abs(ref["test"]) < 1e-40
        assert abs(b.value - float(ref["eta"])) <= TOL, (b.type, b.value, ref["eta"])
        assert abs(b.impact_v[0] - float(ref["V"])) <= 1e-9
        kinds.append(b.type)
    assert sorted(kinds) == ["fold", "period-doubling"]


def _flight_max(sigma, V, eta=Fraction(28, 10), R=Fraction(4, 5), dps=40, samples=4000):
    """Highest point of the flight after the impact (sigma, V), sampled in mpmath (independent
    of the continuation: the steady state gamma cos(eta t) plus the free rotation)."""
    with mpmath.workdps(dps):
        e, r, s, v = (
            mpmath.mpf(Fraction(q).numerator) / Fraction(q).denominator
            for q in (eta, R, Fraction(sigma), Fraction(V))
        )
        g = 1 / (1 - e * e)
        # the impact phase from the closed forms:
        # V = -2 e g sin(th) / (1 - r), sigma = g (cos + beta e sin)
        beta = (1 + r) / (1 - r) * mpmath.cot(mpmath.pi / e)
        sn = -(1 - r) * v / (2 * e * g)
        th = mpmath.atan2(sn, s / g - beta * e * sn)
        ts = th / e
        y0 = s - g * mpmath.cos(th)
        u0 = -r * v + e * g * mpmath.sin(th)
        T = 2 * mpmath.pi / e
        best = -mpmath.inf
        for j in range(1, samples):
            t = ts + T * j / samples
            x = g * mpmath.cos(e * t) + y0 * mpmath.cos(t - ts) + u0 * mpmath.sin(t - ts)
            best = max(best, x)
        return float(best - s)


def test_unphysical_part_crosses_the_wall(sigma_curve):
    rc = sigma_curve
    kinds = np.asarray(rc.kind)
    assert {"stable", "unstable", "unphysical", "virtual"} <= set(kinds)
    i = int(np.nonzero(kinds == "unphysical")[0][len(np.nonzero(kinds == "unphysical")[0]) // 2])
    assert rc.V[i] > 0 and _flight_max(rc.values[i], rc.V[i]) > 1e-6  # the flight rises past x_w
    j = int(np.nonzero(kinds == "stable")[0][5])
    assert _flight_max(rc.values[j], rc.V[j]) < 0  # a physical orbit stays below the wall
    assert np.all(rc.V[kinds == "virtual"] < 0) and np.all(rc.V[kinds != "virtual"] >= 0)


def test_stability_agrees_with_find_orbit(sigma_curve, omega_curve):
    checked = 0
    for rc in (sigma_curve, omega_curve):
        kinds = np.asarray(rc.kind)
        for kind in ("stable", "unstable"):
            idx = np.nonzero(kinds == kind)[0]
            for i in idx[[len(idx) // 4, len(idx) // 2]]:
                p = rc.params.replace(
                    **{rc.parameter: Fraction(float(rc.values[i]))},
                    **({"x0": Fraction(-3)} if rc.parameter == "x_w" else {}),
                )
                orb = find_orbit(p, 1, guess=(float(rc.x[i]), float(rc.v[i])), impacts=1)
                assert abs(orb.x - rc.x[i]) < 1e-8 and abs(orb.v - rc.v[i]) < 1e-8
                assert orb.stable == (kind == "stable"), (
                    rc.parameter,
                    rc.values[i],
                    orb.multipliers,
                )
                checked += 1
    assert checked == 8


def test_continuation_corrector_does_not_jump_back_along_the_branch():
    # eta from 2.8 down through the fold at 2.097: the corrector used to land 3.0 away in x
    # (back on the part already traced), retracing 20 points; now no step exceeds 0.4
    p = pi.Params.make(zeta="0", a="1", R="0.8", eta="2.8", x_w="-0.5", x0="-2")
    o = pi.one_impact_orbits(p, dps=20)[0]
    res = pi.continue_orbit(
        p,
        "eta",
        "2.8",
        "1.5",
        1,
        impacts=1,
        guess=(float(o.x), float(o.v)),
        virtual="10",
        max_points=400,
        doublings=0,
        within=("1.5", "5"),
    )
    b = res.branches[0]
    pts = np.column_stack([b.values, b.x[:, 0], b.v[:, 0]])
    assert float(np.max(np.linalg.norm(np.diff(pts, axis=0), axis=1))) < 1.0
    assert b.stop_reason == "reached eta = 5"


def test_json_strict_and_counts(sigma_curve):
    d = sigma_curve.to_dict()
    json.dumps(d, allow_nan=False)
    assert sum(d["counts"].values()) == len(d["points"])
    assert {b["type"] for b in d["bifurcations"]} >= {"fold", "period-doubling", "grazing"}


def test_plot(sigma_curve, tmp_path):
    fig = sigma_curve.plot(tmp_path / "r.png")
    labels = fig.axes[0].get_legend_handles_labels()[1]
    assert {
        "stable",
        "unstable",
        "unphysical",
        "virtual",
        "fold",
        "period-doubling",
        "grazing",
    } <= set(labels)
    assert (tmp_path / "r.png").stat().st_size > 1000


def test_bad_input():
    p = pi.Params.make(zeta="0", a="1", R="0.8", eta="2.8", x_w="-1", x0="-2")
    with pytest.raises(ParameterError, match="parameter"):
        response_curve(p, 1, "zeta", "0", "0.5")
    with pytest.raises(ParameterError, match="at"):
        response_curve(p, 1, "x_w", "-2", "0.5", at="1")
    with pytest.raises(ParameterError, match="n"):
        response_curve(p, 0, "x_w", "-2", "0.5")
    with pytest.raises(ConvergenceError, match="no physical"):
        response_curve(p, 1, "x_w", "-2", "0.5")  # no orbit at x_w = -2 (outside the ellipse)
    with pytest.raises(ParameterError, match="R"):
        budd_dux_points("2.8", "1")
    with pytest.raises(BudgetExceededError, match="max_time"):
        response_curve(p, 1, "x_w", "-2", "0.5", at="-1", max_time="1e-9")


def _cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "precise_impact", "response", *args],
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_cli_json_and_bad_input(tmp_path, capsys):
    base = ("--eta", "2.8", "--zeta", "0", "--R", "0.8", "--max-points", "150")
    r = _cli("--param", "x_w", "-2", "0.5", "--at", "-1", *base, "--json", "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    obj = json.loads(r.stdout, parse_constant=lambda c: pytest.fail(f"non-JSON token {c}"))
    fold = [b for b in obj["bifurcations"] if b["type"] == "fold" and b["admissible"]]
    assert abs(fold[0]["x_w"] - -1.7802356013215904924) <= TOL
    assert (tmp_path / "response.png").exists() and (tmp_path / "response.json").exists()
    # bad input: one line naming the parameter, exit 2, before any work (in-process: fast)
    for args, word in (
        (("zeta", "0", "1"), "x_w or eta"),
        (("x_w", "-2", "0.5", "--at", "7"), "at"),
    ):
        assert main(["response", "--param", *args, *base]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and word in err


def test_elastic_undamped_orbits_impacting_at_the_section_phase():
    # zeta = 0, R = 1: the impact phase is 0 or pi, on the section t0 = 0 itself, where Newton
    # started on the wall in a tangential contact (IntegrationError, before the compiled engine
    # decided such contacts in double-double: then the section was moved by a quarter period);
    # the curve is two lines, one elliptic (neutral) and one unstable, on either section
    p = pi.Params.make(zeta="0", a="1", R="1", eta="2.8", x_w="-1", x0="-2")
    rc = response_curve(p, 1, "x_w", "-2", "0.5", at="-1", max_points=200)
    c = rc.counts()
    assert c["elliptic"] > 10 and c["unstable"] > 10 and c["stable"] == 0
    assert {"grazing", "period-doubling"} <= {b.type for b in rc.bifurcations}


def test_continue_orbit_within_is_checked_before_work():
    p = pi.Params.make(zeta="0", a="1", R="0.8", eta="2.8", x_w="-0.5", x0="-2")
    for bad in (("2", "5"), ("1.5",), ("0", "5")):
        with pytest.raises(ParameterError, match="within"):
            pi.continue_orbit(p, "eta", "2.8", "1.5", 1, within=bad)


@pytest.mark.parametrize(
    ("eta", "R", "n"),
    [("2.0", "0.8", 1), ("4.0", "0.8", 2), ("6.0", "0.8", 3), ("2.0", "0.5", 1), ("2/3", "0.8", 1)],
)
def test_no_landmark_but_grazings_at_the_half_turn_resonance(eta, R, n):
    # 2 n / omega odd: Phi(n T) = -I, so M = -S and both multipliers equal r on the whole
    # curve (1 + tr + det = (1 + r)^2, 1 - tr + det = (1 - r)^2): no fold, no period-doubling.
    # Before: a period-doubling at x_w = -1/3 with test -7.15e4 and folds at V ~ 1e-50.
    pts = budd_dux_points(eta, R, n, dps=50)
    assert sorted(p["type"] for p in pts) == ["grazing", "grazing"]
    e, r = Fraction(eta), Fraction(R)
    gamma = 1 / (1 - e * e)
    assert sorted(float(p["x_w"]) for p in pts) == sorted([float(gamma), float(-gamma)])
    ops = flight.MpmathOps(dps=50)
    args = (ops.num(e), ops.num(r), n, ops.num(1), ops)
    for theta0 in (ops.ctx.zero, ops.ctx.pi):
        # the tests a hair (1e-20) beside V = 0 and a third away agree with the closed forms
        # (1 -+ r)^2: the rounded pi's Phi_01 ~ 1e-50 times the saltation's 1 / V ~ 1e20 leaves
        # 1e-30; no limit of a multiplier +-1 anywhere near the grazings
        for d in (mpmath.mpf(10) ** -20, -(mpmath.mpf(10) ** -20), ops.num(Fraction(1, 3))):
            _, _, tr, det = budd_dux_orbit(theta0 + d, *args)
            for test, ref in ((1 - tr + det, (1 - r) ** 2), (1 + tr + det, (1 + r) ** 2)):
                assert abs(test - ops.num(ref)) < mpmath.mpf(10) ** -25, (theta0, d, test)


_WIDE = dict(zeta=0, a=1, R="0.8", eta="3.7", x_w="0.2", x0="-0.5")
# the arbiter's (independent multiprecision) grazing: the interior maximum touches the wall,
# the orbit admissible on one side only; located by regula falsi to ~100 eps (1e-10 spare)
_GRAZE = -0.0498233720452


def _landmarks(rc):
    graze = [b for b in rc.bifurcations if b.type == "grazing" and abs(b.value - _GRAZE) < 1e-3]
    pds = sorted(b.value for b in rc.bifurcations if b.type == "period-doubling")
    return graze, pds


def test_wide_range_keeps_the_interior_grazing_and_the_virtual_period_doubling():
    # over -0.5..3.5 the steps are 4x longer: before, the step from no interior maximum
    # (test +inf) to one above the wall was no sign change (grazing lost), and the virtual
    # period-doubling at +0.0613 sat in one step with the pole at the V = 0 grazing +0.0788
    rc = response_curve(pi.Params.make(**_WIDE), 2, "x_w", "-0.5", "3.5", at="0.2")
    graze, pds = _landmarks(rc)
    assert len(graze) == 1 and abs(graze[0].value - _GRAZE) < 1e-10, graze
    refs = sorted(
        float(q["x_w"]) for q in budd_dux_points("3.7", "0.8", 2) if q["type"] == "period-doubling"
    )
    assert len(pds) == 2 and max(abs(x - y) for x, y in zip(pds, refs, strict=True)) < TOL, pds


@pytest.mark.slow
def test_landmarks_do_not_depend_on_the_range():
    p = pi.Params.make(**_WIDE)
    found = []
    for stop in ("0.5", "3.5"):
        graze, pds = _landmarks(response_curve(p, 2, "x_w", "-0.5", stop, at="0.2"))
        assert len(graze) == 1 and abs(graze[0].value - _GRAZE) < 1e-10, (stop, graze)
        found.append(pds)
    assert len(found[0]) == 2 and np.allclose(found[0], found[1], rtol=0, atol=TOL), found
