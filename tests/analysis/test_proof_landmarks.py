"""Proven bifurcation points (issue 26 item 2): Krawczyk on the landmarks' augmented systems."""

from __future__ import annotations

import json
import math
from fractions import Fraction

import mpmath
import numpy as np
import pytest

import precise_impact as pi
from precise_impact.analysis.orbits.landmarks import (
    BranchPoint,
    end_point,
    interval_ends,
    landmark_from_continuation,
    seed_landmark,
)
from precise_impact.analysis.orbits.proof_landmarks import (
    locate_landmark,
    prove_landmark,
)
from precise_impact.cli.main import main
from precise_impact.core import flight
from precise_impact.errors import CertificationError, ConvergenceError, ParameterError

PAPER = (0.05, 1.0, 2.0)
#: The float64 landmarks (Newton on the augmented system, stopped at |dy| <= 8 eps (1 + |y|),
#: and the continuation's secant location of the test function's zero) are the true ones to
#: their rounding: measured 0.4-2.6 ulp; a few ulps allowed (the residual's rounding, a few
#: ulps of its terms, divided by its derivative of order one in eta).
ULPS = 4


def _ulps_apart(x: float, q: Fraction) -> float:
    return float(abs(Fraction(x) - q) / Fraction(math.ulp(x)))


def _mid(pl) -> Fraction:
    return Fraction(pl.eta[0])


def _check_crossing(pl):
    signs = [s["sign"] for s in pl.sides]
    assert sorted(signs) == [-1, 1]
    for s in pl.sides:  # each enclosure of g excludes 0 (its radius below its magnitude)
        assert Fraction(s["g"][1]) < abs(Fraction(s["g"][0]))  # exactly: g ~ 1e-400 below


def test_free_grazing_contains_the_closed_form_to_1e_40():
    bp = seed_landmark("graze_free", PAPER, 0.7106)
    pl = prove_landmark(bp, "1e-40")
    assert pl.width <= 1e-40
    closed = pi.grazing_frequencies(pi.Params.make(), dps=70)[0]  # 70 digits
    assert pl.contains(mpmath.nstr(closed, 70, min_fixed=-1, max_fixed=2))
    # and not a neighbouring value: the closed form moved by 1e-45 (far above the width 4e-68)
    assert not pl.contains(Fraction(mpmath.nstr(closed, 70)) + Fraction(1, 10**45))
    assert pl.kind == "graze_free" and pl.theta["zeta"] == "0.05"
    assert pl.contraction < 1
    _check_crossing(pl)
    assert pl.sides[0]["coordinate"] == "eta"
    assert _ulps_apart(bp.eta, _mid(pl)) <= ULPS


def test_period_doubling_of_the_1_1_orbit_to_1e_30():
    bp, located = landmark_from_continuation("period-doubling", PAPER, 1.0, 0.9, 1, 1)
    pl = prove_landmark(bp, "1e-30")
    assert pl.width <= 1e-30
    assert pl.kind == "period-doubling" and (pl.period, pl.impacts) == (1, 1)
    assert abs(float(pl.eta[0]) - 0.9863) < 1e-4
    _check_crossing(pl)
    assert _ulps_apart(bp.eta, _mid(pl)) <= ULPS  # Newton-polished float64
    assert _ulps_apart(located, _mid(pl)) <= ULPS  # the continuation's own value


def test_the_two_grazings_bounding_the_fig6_period_3_window_to_1e_30():
    # as the tolerance budget finds them (lab/budget.py): the period-3 orbit at eta = 0.74,
    # the ends of its stable admissible interval, polished on the grazing system
    orbit = seed_landmark("orbit", PAPER, 0.74, 3, None)
    ends = interval_ends(orbit)
    proven = {}
    for side in ("low", "high"):
        assert ends[side][0] == "grazing"
        bp = end_point(orbit, ends[side])
        pl = prove_landmark(bp, "1e-30")
        assert pl.width <= 1e-30 and pl.kind == "graze" and pl.period == 3
        _check_crossing(pl)
        assert _ulps_apart(bp.eta, _mid(pl)) <= ULPS
        assert _ulps_apart(ends[side][1], _mid(pl)) <= ULPS  # the continuation's value
        proven[side] = _mid(pl)
    assert 0.73 < proven["low"] < 0.74 < proven["high"] < 0.78


def test_a_fold_is_proven_with_the_branch_turning_in_a_state_coordinate():
    # the period-3 orbit carried to a design where its low end is a fold (the tolerance
    # budget's case, tests/lab/test_tolerance_budget.py)
    import dataclasses

    paper = np.array(PAPER)
    theta = np.array([0.059940089850262016, 1.0001095140033414, 2.0])
    eta_d = 0.7407396303695382
    o = seed_landmark("orbit", PAPER, 0.74, 3, None)
    for t in np.linspace(0, 1, 9)[1:]:
        o = dataclasses.replace(o, eta_fixed=0.74 + t * (eta_d - 0.74)).solve(
            paper + t * (theta - paper)
        )
    end = interval_ends(o)["low"]
    bp = end_point(o, end)
    assert end[0] == "fold" and bp.kind == "fold"
    pl = prove_landmark(bp, "1e-30")
    assert pl.width <= 1e-30 and pl.test_function == "1 - tr M + det M"
    assert pl.sides[0]["coordinate"] != "eta"  # eta is extremal at a fold: a state is held
    _check_crossing(pl)
    # Newton's stopping rule |dy| <= 8 eps (1 + max |y|) (impact times ~16) bounds the float64
    # fold here (measured 10.6 ulp: the fold's augmented system is the worst conditioned)
    tol = 8 * 2.0**-52 * (1 + float(np.max(np.abs(bp.y))))
    assert abs(Fraction(bp.eta) - _mid(pl)) <= Fraction(tol)


def test_a_degenerate_grazing_is_refused():
    # zeta = 0.6 (sqrt(1 - zeta^2) = 0.8), a = 0.96, x_w = 1: the resonance peak
    # a / (2 zeta sqrt(1 - zeta^2)) = 1 touches the wall exactly, at eta^2 = 1 - 2 zeta^2 =
    # 0.28: a double root, F_y singular there, and the amplitude touches x_w without crossing
    z, a, xw = 0.6, 0.96, 1.0
    eta = math.sqrt(0.28)
    P, Q = flight.steady_coefficients(eta, z, a)
    y = np.array([P, eta * Q, math.atan2(Q, P) / eta, eta])
    bp = BranchPoint("graze_free", 1, 0, y, np.array([z, a, xw]))
    with pytest.raises(CertificationError, match="degenerate"):
        prove_landmark(bp, "1e-30")


def test_a_regular_neighbour_of_the_degenerate_grazing_is_proven():
    # the same construction with x_w = 0.99 below the peak: two simple grazings, each proven
    # (the refusal above is the degeneracy, not the construction)
    bp = seed_landmark("graze_free", (0.6, 0.96, 0.99), math.sqrt(0.28) - 0.05)
    pl = prove_landmark(bp, "1e-30")
    _check_crossing(pl)
    assert pl.width <= 1e-30


def test_bad_input_is_refused_before_work():
    bp = seed_landmark("graze_free", PAPER, 0.7106)
    for w in ("1e-3", "0", "-1e-40", "abc"):
        with pytest.raises(ParameterError, match="width"):
            prove_landmark(bp, w)
    with pytest.raises(ParameterError, match="bits"):
        prove_landmark(bp, bits=32)
    orbit = seed_landmark("orbit", PAPER, 0.74, 3, None)
    with pytest.raises(ParameterError, match="kind"):
        prove_landmark(orbit)
    with pytest.raises(ParameterError, match="side"):
        locate_landmark("fold")


def test_locate_names_what_the_end_is():
    with pytest.raises(ConvergenceError, match="period-doubling"):
        locate_landmark("fold", eta=0.99, side="low")


def test_cli_certify_point(capsys):
    assert main(["certify", "--point", "grazing", "--json"]) == 0

    def strict(token):
        raise ValueError(f"non-strict JSON token {token}")

    d = json.loads(capsys.readouterr().out, parse_constant=strict)
    assert d["kind"] == "graze_free" and d["width"] <= 1e-40
    assert d["eta_lower"].startswith("0.71068736909392")
    args = ["certify", "--point", "grazing", "--eta", "0.74", "--side", "high"]
    assert main([*args, "--orbit-period", "3", "--width", "1e-30"]) == 0
    out = capsys.readouterr().out
    assert "period 3" in out and "a crossing" in out
    assert main(["certify", "--point", "period-doubling"]) == 2  # needs --side
    assert main(["certify", "--point", "grazing", "--width", "1e-3"]) == 2
    assert main(["certify", "--width", "1e-30"]) == 2  # only with --point
    assert main(["certify", "--orbit-period", "3"]) == 2
    assert main(["certify", "--point", "grazing", "--k", "0.1"]) == 2  # a trajectory's flag


# ---- issue 35 item 2: widths below the float range --------------------------------------------
@pytest.mark.parametrize(
    ("width", "bits"), [("1e-300", 2200), ("1e-400", None), ("1e-600", 2200), ("1e-1000", 4096)]
)
def test_free_grazing_proven_below_the_float_range(width, bits):
    """A width of 1e-300 at 2200 bits ended in OverflowError (``float(scale / width)`` past
    1e308) and widths below 1e-300 were refused; now 1e-1000 <= width.  The interval holds
    the closed form at 1500 digits, its width (exact, from the decimals) is below the request,
    the float view is a bound (the smallest subnormal, never 0.0), log10_width its size."""
    w = Fraction(width)
    pl = prove_landmark(seed_landmark("graze_free", PAPER, 0.7106), width, bits=bits)
    assert pl.bits == (bits or 1329 + 96)  # log2(1e400) = 1328.8, rounded up, + 96
    exact_width = Fraction(pl.eta_upper) - Fraction(pl.eta_lower)
    assert 0 < exact_width <= w and exact_width < Fraction(1, 10**300)
    with mpmath.workdps(30):
        lg = mpmath.log10(mpmath.mpf(exact_width.numerator) / exact_width.denominator)
    assert pl.width == math.ulp(0.0) and abs(pl.log10_width - float(lg)) < 1e-12
    assert pl.log10_contraction < 0 and 0 < pl.contraction < 1
    closed = pi.grazing_frequencies(pi.Params.make(), dps=1500)[0]
    assert pl.contains(Fraction(mpmath.nstr(closed, 1500)))  # 1e-1500 far below the width
    # and not its neighbour a width away
    assert not pl.contains(Fraction(mpmath.nstr(closed, 1500)) + 2 * exact_width)
    _check_crossing(pl)
    json.loads(json.dumps(pl.to_dict(), allow_nan=False))


def test_cli_certify_point_width_1e_400(capsys):
    """``certify --point grazing --width 1e-400``: refused before (1e-300 <= width); the
    printed width and contraction from the exact decimals and the log10 (a float print was
    '5e-324' or '0'), --json strict; 0, negative and non-finite widths exit 2."""
    assert main(["certify", "--point", "grazing", "--width", "1e-400"]) == 0
    out = capsys.readouterr().out
    printed = out.split("(width ")[1].split(";")[0]
    assert printed.endswith(("e-428", "e-427")) and Fraction(printed) <= Fraction(1, 10**400)
    assert main(["certify", "--point", "grazing", "--width", "1e-400", "--json"]) == 0

    def strict(token):
        raise ValueError(f"non-strict JSON token {token}")

    d = json.loads(capsys.readouterr().out, parse_constant=strict)
    assert Fraction(d["eta_upper"]) - Fraction(d["eta_lower"]) <= Fraction(1, 10**400)
    assert d["log10_width"] < -400 and d["width"] > 0
    for bad in ("0", "-1e-400", "inf", "nan", "1e-1001"):
        assert main(["certify", "--point", "grazing", "--width", bad]) == 2, bad
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "width" in err


def test_a_box_too_small_for_the_bits_names_its_radius_below_the_float_range():
    """1e-400 at 1024 bits (rounding ~1e-308 far above the box): no proof, and the message
    states the box's radius and the contraction (it printed ``float(r)``, '0', before)."""
    bp = seed_landmark("graze_free", PAPER, 0.7106)
    with pytest.raises(CertificationError, match=r"radius 5\.00e-401 did not close") as e:
        prove_landmark(bp, "1e-400", bits=1024)
    assert "(contraction " in str(e.value) and "e+" in str(e.value).split("(contraction ")[1]
