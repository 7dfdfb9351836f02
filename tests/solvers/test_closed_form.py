"""Tests of the closed-form solver (src/precise_impact/_solver/_analytical.py).

Every reference is independent of the impact finder under test: mpmath numerical
differentiation for the ODE, the exact steady state of ``_system.steady_state``,
mpmath root finding on the closed form for the grazing construction, and
cross-checks between finders / backends.  Tolerances are derived from the unit
roundoff of the arithmetic involved; each one says why.
"""

from __future__ import annotations

from fractions import Fraction
from itertools import pairwise

import heyoka as hy
import mpmath
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from precise_impact.core.flow import steady_state
from precise_impact.core.params import Params
from precise_impact.core.precision import Precision
from precise_impact.errors import BudgetExceededError, ParameterError
from precise_impact.solvers.closed_form import AnalyticalSolver

EPS64 = 2.0**-52


def mpq(q: Fraction) -> mpmath.mpf:
    """Exact rational as an mpf with 400 bits (independent of the current mpmath precision)."""
    with mpmath.workprec(400):
        return mpmath.mpf(q.numerator) / q.denominator


# ----------------------------------------------------------------------------- closed form
def test_closed_form_satisfies_ode():
    """x'' + 2 zeta x' + x - a cos(eta t) = 0 along a segment, by mpmath.diff at 50 dps.

    The closed form is built at 200 digits so that mpmath.diff, which evaluates at
    (n + 1) times the target precision, differentiates a function that is smooth at
    that precision.  Residual tolerance 1e-40: the finite-difference derivatives
    are accurate to ~1e-50 at 50 dps; 1e-40 leaves 10 digits for cancellation.
    """
    p = Params.make(eta="0.712")
    solver = AnalyticalSolver(precision="mp:668")
    cf = solver.closed_form(p, Fraction(3), Fraction(1, 2), Fraction(-1, 3))
    zeta, a, eta = mpq(p.zeta), mpq(p.a), mpq(p.eta)
    with mpmath.workdps(50):
        for t in [mpmath.mpf(3) + k * mpmath.mpf("0.7") for k in range(1, 12)]:
            x = cf.x(t)
            x1 = mpmath.diff(cf.x, t, 1)
            x2 = mpmath.diff(cf.x, t, 2)
            res = x2 + 2 * zeta * x1 + x - a * mpmath.cos(eta * t)
            assert abs(res) < mpmath.mpf("1e-40"), (t, res)
            # the velocity of the closed form is the derivative of its position
            assert abs(x1 - cf.v(t)) < mpmath.mpf("1e-40")
        # initial condition, approached through the formula (not the stored start)
        h = mpmath.mpf("1e-45")
        assert abs(cf.x(3 + h) - mpmath.mpf(1) / 2) < mpmath.mpf("1e-40")
        assert abs(cf.v(3 + h) + mpmath.mpf(1) / 3) < mpmath.mpf("1e-40")


def test_segments_continuous_and_samples_on_closed_form():
    """Rebuild each segment from its impact and check the next impact and the samples.

    At 60 digits (unit roundoff ~1e-61) one segment evaluation is accurate to
    ~1e-58 for |t| <= 200; the recorded values are rounded to 200 bits (~6e-61
    relative).  Tolerance 1e-50 leaves margin for the ~1e3 amplification of
    rounding errors over one segment near a low-velocity impact.
    Also check, on a grid, that no segment goes beyond the wall (no missed impact).
    """
    p = Params.make(eta="0.712")
    solver = AnalyticalSolver(precision="mp:203")
    tr = solver.solve(p, 25)
    imps = tr.impacts_mpf()
    assert len(imps) >= 15
    xw = mpq(p.x_w)
    tol = mpmath.mpf("1e-50")
    with mpmath.workdps(60):
        for (t_a, _, va), (t_b, vb, _) in pairwise(imps):
            cf = solver.closed_form(p, t_a, xw, va)
            x_end, v_end = cf(t_b)
            assert abs(x_end - xw) < tol
            assert abs(v_end - vb) < tol and vb > 0
            grid = [t_a + (t_b - t_a) * k / 400 for k in range(1, 400)]
            assert max(cf.x(t) for t in grid) < xw
        # every sample lies on the segment that contains it
        for k in range(tr.periods + 1):
            t, x, v = tr.state_mpf(k)
            prev = [i for i in imps if i[0] <= t]
            if prev:
                cf = solver.closed_form(p, prev[-1][0], xw, prev[-1][2])
            else:
                cf = solver.closed_form(p, p.t0, p.x0, p.v0)
            xc, vc = cf(t)
            assert abs(xc - x) < tol and abs(vc - v) < tol


def test_result_types_and_precision():
    p = Params.make(eta="0.74")
    tr = AnalyticalSolver().solve(p, 3, per_period=8)
    assert (
        tr.model == "analytical" and tr.precision == Precision.parse("float64") and tr.tol is None
    )
    assert tr.x.dtype == np.float64 and len(tr.t) == 4 and len(tr.dense_t) == 3 * 8 + 1
    # the dense grid contains the samples
    np.testing.assert_array_equal(tr.dense_x[::8], tr.x)
    trp = AnalyticalSolver(finder="paper").solve(p, 1)
    assert trp.model == "analytical-paper" and trp.dense_t is None
    trm = AnalyticalSolver(precision="mp:203").solve(p, 2)
    # the bits mpmath really uses at 60 digits (203), not ceil(60 log2 10) = 200
    assert trm.precision == Precision.parse(f"mp:{mpmath.libmp.dps_to_prec(60)}")
    assert all(isinstance(z, hy.real) for z in list(trm.x) + list(trm.impacts_t))
    assert trm.stats["impacts"] == trm.n_impacts and trm.elapsed_s > 0


def test_start_on_wall_is_an_impact_and_samples_are_right_continuous():
    """x0 = x_w, v0 > 0: impact at t0; sample 0 holds the state after the reset (exactly)."""
    p = Params.make(x0="2", v0="1", R="0.5")
    for solver in (AnalyticalSolver(), AnalyticalSolver(precision="mp:103")):
        tr = solver.solve(p, 2)
        t, vb, va = tr.impacts_mpf()[0]
        assert t == 0 and vb == 1 and va == mpmath.mpf(-0.5)
        t0, x0, v0 = tr.state_mpf(0)
        assert x0 == 2 and v0 == mpmath.mpf(-0.5)


# ----------------------------------------------------------------------------- steady state
def test_non_impacting_converges_to_steady_state():
    """eta = 0.70, wall far away: at period 600 the state is (P, eta Q) to < 1e-40.

    The transient decays like exp(-zeta t) = exp(-0.05 * 5385) ~ 1e-117, and the
    60-digit evaluation at t ~ 5e3 is accurate to ~1e-56, so 1e-40 is loose.
    """
    p = Params.make(eta="0.70", x_w="100")
    tr = AnalyticalSolver(precision="mp:203").solve(p, 600)
    assert tr.n_impacts == 0 and tr.stats["envelope_exit_t"] is not None
    ss = steady_state(p)
    _, x, v = tr.state_mpf(600)
    with mpmath.workdps(60):
        assert abs(x - mpq(ss.P)) < mpmath.mpf("1e-40")
        assert abs(v - mpq(ss.eta) * mpq(ss.Q)) < mpmath.mpf("1e-40")


# ----------------------------------------------------------------------------- finders agree
def test_robust_and_paper_agree_away_from_grazing():
    """eta = 0.74 (period-3): both finders locate the same impacts.

    Both refine to float64 working precision (~1e-16 relative, ~1e-14 absolute at
    t ~ 100); the period-3 orbit is stable, so errors do not grow: 1e-11.
    """
    p = Params.make(eta="0.74")
    r = AnalyticalSolver(finder="robust").solve(p, 60)
    q = AnalyticalSolver(finder="paper").solve(p, 60)
    assert r.n_impacts == q.n_impacts >= 30
    np.testing.assert_allclose(r.impacts_t, q.impacts_t, rtol=0, atol=1e-11)
    np.testing.assert_allclose(r.impacts_v_before, q.impacts_v_before, rtol=0, atol=1e-11)
    np.testing.assert_allclose(r.x, q.x, rtol=0, atol=1e-11)


def test_mpmath_and_float64_agree_in_the_chaotic_regime():
    """eta = 0.712: float64 vs 60-digit impact times, first 10 impacts, to 1e-10.

    float64 impact times carry ~eps * |t| ~ 2e-14 (|t| < 110) rounding errors; the
    chaotic flow (LLE ~ 0.03 per unit time) and the 1 / v- factor of the saltation
    matrix at low-velocity impacts amplify them by up to ~1e3 over the first 10
    impacts (measured difference ~1e-13).  1e-10 leaves a factor 1000.
    """
    p = Params.make(eta="0.712")
    f = AnalyticalSolver(precision="float64").solve(p, 15)
    m = AnalyticalSolver(precision="mp:203").solve(p, 15)
    fi, mi = f.impacts_mpf(), m.impacts_mpf()
    assert len(fi) >= 10 and len(mi) >= 10
    for (tf, vf, _), (tm, vm, _) in zip(fi[:10], mi[:10], strict=True):
        assert abs(tf - tm) < 1e-10
        assert abs(vf - vm) < 1e-10


# ----------------------------------------------------------------------------- grazing
# From rest at t0 = 0 with eta = 0.74 the first arc peaks at t ~ 2.2885, x ~ 1.0962893690.
# A wall 9e-9 below that maximum is crossed for only ~2.4e-4 time units (< 1e-3 T ~ 8.5e-3).
GRAZE = dict(eta="0.74", x_w="1.09628936")


def _excursion(p: Params):
    """(t_in, t_out, t_max) of the first arc's excursion beyond the wall, from mpmath roots."""
    cf = AnalyticalSolver(precision="mp:169").closed_form(p, p.t0, p.x0, p.v0)
    xw = mpq(p.x_w)
    with mpmath.workdps(50):
        # bracketing solver, then a secant polish; check the residuals
        def root(g, a, b):
            r = mpmath.findroot(g, (a, b), solver="anderson")
            r = mpmath.findroot(g, r, tol=mpmath.mpf(10) ** -90)
            assert a < r < b and abs(g(r)) < mpmath.mpf("1e-48")
            return r

        t_max = root(cf.v, mpmath.mpf(2), mpmath.mpf("2.6"))
        t_in = root(lambda t: cf.x(t) - xw, mpmath.mpf(2), t_max)
        t_out = root(lambda t: cf.x(t) - xw, t_max, mpmath.mpf("2.6"))
        return t_in, t_out, t_max, cf


def test_paper_finder_misses_a_grazing_impact_that_robust_finds():
    p = Params.make(**GRAZE)
    t_in, t_out, t_max, cf = _excursion(p)
    with mpmath.workdps(50):
        T = 2 * mpmath.pi / mpq(p.eta)
        delta = T / 1000
        # Preconditions of the construction: a real excursion beyond the wall, shorter
        # than one scan step, with no scan point (k * delta from t0 = 0) inside it.
        assert cf.x(t_max) > mpq(p.x_w)
        assert 0 < t_out - t_in < delta
        assert mpmath.floor(t_in / delta) == mpmath.floor(t_out / delta)
    robust = AnalyticalSolver(finder="robust").solve(p, 4)
    paper = AnalyticalSolver(finder="paper").solve(p, 4)
    # robust: first impact at the entry of the excursion; float64 root to ~eps * t
    # (divided by the crossing slope ~3e-4, hence ~1e-12 relative error budget)
    assert abs(robust.impacts_t[0] - float(t_in)) < 1e-11
    assert robust.impacts_v_before[0] > 0
    with mpmath.workdps(50):
        # independent: the closed form is on the wall at that time, moving into it
        x, v = cf(mpmath.mpf(robust.impacts_t[0]))
        assert abs(x - mpq(p.x_w)) < 1e-14 and v > 0
    # paper: misses it, its first impact is at the next (high) arc
    assert paper.impacts_t[0] > float(t_out) + 1
    assert robust.impacts_t[0] < paper.impacts_t[0]
    # same with the 60-digit robust finder
    rm = AnalyticalSolver(precision="mp:203").solve(p, 1)
    with mpmath.workdps(50):
        assert abs(rm.impacts_mpf()[0][0] - t_in) < mpmath.mpf("1e-45")
    # heyoka's event detection (an independent method) finds it too: in float64
    # to ~1e-11 like the float64 finder, in 256-bit to the 50-digit root's accuracy.
    from precise_impact import HeyokaSolver

    h64 = HeyokaSolver("float64").solve(p, 4)
    assert abs(h64.impacts_t[0] - float(t_in)) < 1e-11
    assert h64.n_impacts == robust.n_impacts
    hmp = HeyokaSolver("mp:256").solve(p, 1)
    with mpmath.workdps(50):
        assert abs(hmp.impacts_mpf()[0][0] - t_in) < mpmath.mpf("1e-45")


def test_exact_grazing_is_a_tangency_not_an_impact():
    """Wall at the first maximum (to float64 rounding): no impact, no hang, counted as grazing."""
    t_in, t_out, t_max, cf = _excursion(Params.make(**GRAZE))
    with mpmath.workdps(50):
        x_max = cf.x(t_max)
    p = Params.make(eta="0.74", x_w=Fraction(float(x_max)))
    tr = AnalyticalSolver().solve(p, 4)
    assert tr.stats["grazing"] == 1
    assert tr.impacts_t[0] > 3
    # wall just above the maximum: neither an impact nor a tangency
    tr2 = AnalyticalSolver().solve(p.replace(x_w=p.x_w + Fraction(1, 10**6)), 4)
    assert tr2.stats["grazing"] == 0 and tr2.impacts_t[0] > 3


@settings(
    max_examples=40, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(
    eta=st.fractions(min_value=Fraction(1, 2), max_value=Fraction(3, 2), max_denominator=1000),
    zeta=st.fractions(min_value=0, max_value=Fraction(1, 5), max_denominator=100),
    x_w=st.fractions(min_value=Fraction(1, 2), max_value=3, max_denominator=1000),
    R=st.fractions(min_value=Fraction(1, 2), max_value=1, max_denominator=10),
)
def test_robust_never_goes_through_the_wall(eta, zeta, x_w, R):
    """On a dense grid no state lies beyond the wall (a missed impact would show there).

    Position errors of float64 closed-form evaluation are ~eps * (|t| + 10) < 1e-12.
    The box contains sticking orbits (e.g. eta = 1/2, zeta = 1/5, x_w = 1/2, R = 1/2, which
    other hypothesis versions draw): there the solver must refuse by name, never pass the wall.
    """
    assume(not (zeta == 0 and eta == 1))  # undamped resonance: refused by Params (tested below)
    p = Params.make(eta=eta, zeta=zeta, x_w=x_w, R=R)
    try:
        tr = AnalyticalSolver().solve(p, 6, per_period=400)
    except BudgetExceededError as e:
        assert "sticking" in str(e)
        return
    assert np.max(tr.dense_x) <= float(p.x_w) + 1e-12
    # impacts strictly ordered in time, each with v_before > 0
    assert np.all(np.diff(tr.impacts_t) >= 0) and np.all(tr.impacts_v_before > 0)


# ----------------------------------------------------------------------------- errors
@pytest.mark.parametrize("values", [dict(zeta="1"), dict(zeta="2.5"), dict(zeta="0", eta="1")])
def test_parameter_errors(values):
    p = Params.make(**values)
    for solver in (AnalyticalSolver(), AnalyticalSolver(precision="mp:203")):
        with pytest.raises(ParameterError) as e:
            solver.solve(p, 10**9)  # raised before any work (this would never finish)
        assert e.value.name == "zeta"


def test_bad_options():
    with pytest.raises(ParameterError):
        AnalyticalSolver(finder="bisect")
    with pytest.raises(ParameterError):
        AnalyticalSolver(backend="float32")
    with pytest.raises(ParameterError):
        AnalyticalSolver(backend="float64", dps=30)
    with pytest.raises(ParameterError):
        AnalyticalSolver(precision="mp:20")
    with pytest.raises(ParameterError):
        AnalyticalSolver(scan_fraction=0)
    with pytest.raises(ParameterError):
        AnalyticalSolver().solve(Params.make(), -1)


def test_budgets_terminate():
    # R = 0 with a > x_w: the mass is pushed into the wall at zero velocity (sticking)
    with pytest.raises(BudgetExceededError):
        AnalyticalSolver().solve(Params.make(R="0", a="3", x_w="1"), 5)
    # equilibrium beyond the wall: an endless chattering sequence hits max_impacts
    with pytest.raises(BudgetExceededError):
        AnalyticalSolver(max_impacts=100).solve(Params.make(a="0", x0="-1", x_w="-1/2"), 50)
    # evaluation budget
    with pytest.raises(BudgetExceededError):
        AnalyticalSolver(finder="paper", max_evals=500).solve(Params.make(), 5)
