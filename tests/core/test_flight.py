"""The closed-form flight (core/flight.py), the one formula every engine evaluates.

Independent references: the same formula in three arithmetics (float64, mpmath at 60 digits,
python-flint balls at 256 bits), the ODE itself (derivatives by mpmath's numerical
differentiation at 60 digits), the semigroup and determinant identities of the flow, and the
numba copies of the fast engine pinned to it.
"""

from __future__ import annotations

import math
import random
from fractions import Fraction

import flint
import mpmath
import pytest

from precise_impact.core import flight
from precise_impact.core.flow import acceleration, steady_state
from precise_impact.core.params import Params

EPS = 2.0**-52
RNG = random.Random(23)


def _cases(n=25):
    """Random flights: zeta in [0, 0.9), eta in [0.1, 3], a, x, v in [-2, 2], times in [0, 30]."""
    for _ in range(n):
        yield (
            RNG.uniform(0.1, 3),
            RNG.uniform(0, 0.9),
            RNG.uniform(-2, 2),
            RNG.uniform(0, 30),
            RNG.uniform(-2, 2),
            RNG.uniform(-2, 2),
            RNG.uniform(0, 30),
        )


def _mp(x):
    return mpmath.mpf(x)


def test_steady_coefficients_are_exact_for_rationals():
    P, Q = flight.steady_coefficients(Fraction(7, 10), Fraction(1, 20), Fraction(1))
    assert (P, Q) == (Fraction(102, 53), Fraction(14, 53))
    ss = steady_state(Params.make(eta="0.70"))
    assert (ss.P, ss.Q) == (P, Q)


@pytest.mark.parametrize("case", list(_cases()))
def test_one_formula_in_three_arithmetics(case):
    """float64 against mpmath (60 digits) and balls (256 bits): the float64 flight is within a
    few hundred eps of the exact value (~20 roundings, each amplified by at most |terms| <= ~30
    here: 1e3 eps), and the 256-bit ball contains the 60-digit value."""
    eta, zeta, a, s, x, v, t = case
    P, Q = flight.steady_coefficients(eta, zeta, a)
    w = flight.damped_frequency(zeta, flight.FLOAT)
    xf, vf = flight.Flight(P, Q, eta, zeta, w, flight.FLOAT, s, x, v).at(s + t)
    with mpmath.workdps(60):
        Pm, Qm = flight.steady_coefficients(_mp(eta), _mp(zeta), _mp(a))
        wm = flight.damped_frequency(_mp(zeta), flight.MPMATH)
        fm = flight.Flight(Pm, Qm, _mp(eta), _mp(zeta), wm, flight.MPMATH, _mp(s), _mp(x), _mp(v))
        xm, vm = fm.at(_mp(s) + _mp(t))
        scale = 1 + abs(Pm) + abs(Qm) + abs(x) + abs(v) + abs(fm.y) + abs(fm.u)
        assert abs(xf - xm) <= 1e3 * EPS * scale and abs(vf - vm) <= 1e3 * EPS * scale
    old = flint.ctx.prec
    flint.ctx.prec = 256
    try:
        B = [flint.arb(q) for q in (eta, zeta, a, s, x, v, t)]
        Pb, Qb = flight.steady_coefficients(B[0], B[1], B[2])
        wb = flight.damped_frequency(B[1], flight.ARB)
        xb, vb = flight.Flight(Pb, Qb, B[0], B[1], wb, flight.ARB, B[3], B[4], B[5]).at(B[3] + B[6])
        for ball, value in ((xb, xm), (vb, vm)):
            with mpmath.workdps(60):
                mid = mpmath.mpf(ball.mid().str(70, radius=False))
                rad = mpmath.mpf(ball.rad().str(5, radius=False))
                # the 60-digit value is within the ball, widened by its own rounding (1e-58)
                assert abs(mid - value) <= rad + mpmath.mpf(10) ** -55 * scale
    finally:
        flint.ctx.prec = old


@pytest.mark.parametrize("c0", [1, Fraction(37, 10)])
def test_flow_semigroup_and_determinant(c0):
    """Phi(t1 + t2) = Phi(t1) Phi(t2) and det Phi = exp(-2 alpha tau), at 50 digits (to 1e-45)."""
    with mpmath.workdps(50):
        c0m = mpmath.mpf(c0.numerator) / c0.denominator if isinstance(c0, Fraction) else c0
        for _ in range(10):
            alpha = _mp(RNG.uniform(0, 0.9))
            wd = flight.damped_frequency(alpha, flight.MPMATH, c0m)
            t1, t2 = _mp(RNG.uniform(0, 20)), _mp(RNG.uniform(0, 20))
            A = mpmath.matrix(2, 2)
            a00, a01, a10, a11 = flight.flow_matrix(t1, alpha, wd, flight.MPMATH, c0m)
            b00, b01, b10, b11 = flight.flow_matrix(t2, alpha, wd, flight.MPMATH, c0m)
            c = flight.flow_matrix(t1 + t2, alpha, wd, flight.MPMATH, c0m)
            A = (
                a00 * b00 + a01 * b10,
                a00 * b01 + a01 * b11,
                a10 * b00 + a11 * b10,
                a10 * b01 + a11 * b11,
            )
            assert max(abs(p - q) for p, q in zip(A, c, strict=True)) < mpmath.mpf(10) ** -45
            det = c[0] * c[3] - c[1] * c[2]
            assert abs(det - mpmath.exp(-2 * alpha * (t1 + t2))) < mpmath.mpf(10) ** -45


@pytest.mark.parametrize("case", list(_cases(10)))
def test_the_flight_solves_the_equation(case):
    """x' = v and v' = a cos(eta t) - 2 zeta v - x (core/flow.acceleration), by 60-digit
    numerical differentiation (error ~1e-40 with mpmath's default step): to 1e-30."""
    eta, zeta, a, s, x, v, t = case
    with mpmath.workdps(60):
        e, z, am = _mp(eta), _mp(zeta), _mp(a)
        P, Q = flight.steady_coefficients(e, z, am)
        w = flight.damped_frequency(z, flight.MPMATH)
        f = flight.Flight(P, Q, e, z, w, flight.MPMATH, _mp(s), _mp(x), _mp(v))
        tt = _mp(s) + _mp(t)
        xt, vt = f.at(tt)
        dx = mpmath.diff(lambda q: f.at(q)[0], tt)
        dv = mpmath.diff(lambda q: f.at(q)[1], tt)
        assert abs(dx - vt) < mpmath.mpf(10) ** -30
        assert abs(dv - acceleration(tt, xt, vt, e, z, am, mpmath.cos)) < mpmath.mpf(10) ** -30


@pytest.mark.parametrize("case", list(_cases(10)))
def test_the_acceleration_bound_holds(case):
    """max |x''| on 4000 points of 60 time units is below Flight.acceleration_bound (exact-
    arithmetic bound: compared in mpmath at 30 digits)."""
    eta, zeta, a, s, x, v, _ = case
    with mpmath.workdps(30):
        e, z, am = _mp(eta), _mp(zeta), _mp(a)
        P, Q = flight.steady_coefficients(e, z, am)
        w = flight.damped_frequency(z, flight.MPMATH)
        f = flight.Flight(P, Q, e, z, w, flight.MPMATH, _mp(s), _mp(x), _mp(v))
        bound = f.acceleration_bound()
        worst = 0
        for k in range(4000):
            tt = _mp(s) + _mp(k) * 60 / 4000
            xt, vt = f.at(tt)
            worst = max(worst, abs(acceleration(tt, xt, vt, e, z, am, mpmath.cos)))
        assert worst <= bound
        assert bound < 3 * (worst + 1)  # a bound, not a wild one


def test_the_numba_copies_are_the_core_formulas():
    """solvers/fast keeps compiled copies (numba cannot call the generic Python): the flow
    matrix is the same expression (equal to the last bit); the steady-state coefficients are
    computed with a different association (4 zeta^2 eta^2): within 4 ulps."""
    from precise_impact.solvers.fast.crossing import coefficients, phi, phi_damped

    for _ in range(200):
        tau, alpha = RNG.uniform(0, 40), RNG.uniform(0, 0.9)
        c0 = RNG.choice([1.0, RNG.uniform(alpha * alpha + 0.01, 5)])
        wd = math.sqrt(c0 - alpha * alpha)
        assert phi_damped(tau, alpha, wd, c0) == flight.flow_matrix(
            tau, alpha, wd, flight.FLOAT, c0
        )
        if c0 == 1.0:
            assert phi(tau, alpha, wd) == flight.flow_matrix(tau, alpha, wd, flight.FLOAT)
        eta, a = RNG.uniform(0.1, 3), RNG.uniform(-2, 2)
        Pf, Qf, wf = coefficients(eta, alpha, a)
        P, Q = flight.steady_coefficients(eta, alpha, a)
        assert abs(Pf - P) <= 4 * EPS * abs(P) and abs(Qf - Q) <= 4 * EPS * abs(Q)
        assert wf == flight.damped_frequency(alpha, flight.FLOAT)


def test_the_compiled_bounds_and_gap_are_the_core_ones():
    """crossing.flight_bounds' amplitude is core.flight.homogeneous_amplitudes (c0 = 1: y and y'
    share it, within 2 ulps of the differently associated core expression), its |x''| bound is
    the core Flight.acceleration_bound, and crossing.gap is the core Flight's x - x_w, x'
    (same terms; a few ulps of the largest term apart)."""
    from precise_impact.solvers.fast.crossing import flight_bounds, gap

    for _ in range(200):
        eta, zeta, a = RNG.uniform(0.1, 3), RNG.uniform(0, 0.9), RNG.uniform(-2, 2)
        s, x, v, xw = (RNG.uniform(-2, 30) for _ in range(4))
        t = s + RNG.uniform(0, 30)  # flights run forward: the homogeneous part decays
        P, Q = flight.steady_coefficients(eta, zeta, a)
        w = flight.damped_frequency(zeta, flight.FLOAT)
        f = flight.Flight(P, Q, eta, zeta, w, flight.FLOAT, s, x, v)
        ay, au = flight.homogeneous_amplitudes(f.y, f.u, zeta, w, flight.FLOAT)
        A, M, _, _ = flight_bounds(f.y, f.u, zeta, w, eta, math.sqrt(P * P + Q * Q))
        assert abs(A - ay) <= 2 * EPS * ay and abs(ay - au) <= 8 * EPS * ay
        assert abs(M - f.acceleration_bound()) <= 8 * EPS * M
        g, gp = gap(t, s, eta, zeta, w, P, Q, f.y, f.u, xw, False, 0.0, 1.0, 1.0, 0.0, 0.0)[:2]
        xt, vt = f.at(t)
        scale = abs(P) + abs(Q) + abs(f.y) + abs(f.u) + abs(xw)
        assert abs(g - (xt - xw)) <= 8 * EPS * scale and abs(gp - vt) <= 8 * EPS * scale


def test_the_amplitude_form_is_the_flow_form():
    """state_from_coefficients (the closed form's hot loop) and Flight.at (the flow matrix
    applied to (y, u)) are two writings of one flight: float64 within a few ulps of the
    state's scale (each is ~10 roundings of terms bounded by |x_p| + A), 200-bit mpmath to 1e-55."""
    import math

    for ops, tol in ((flight.FLOAT, 64 * 2.0**-52), (flight.MpmathOps(bits=200), 1e-55)):
        with ops.context():
            P, Q, eta, zeta = ops.num(0.3), ops.num(-0.7), ops.num(0.712), ops.num(0.05)
            wd = flight.damped_frequency(zeta, ops)
            y, u, s = ops.num(0.4), ops.num(-1.1), ops.num(2.5)
            k = flight.trig_coefficients(y, u, zeta, wd)
            xp, vp = flight.forced_response(s, P, Q, eta, ops)
            fl = flight.Flight(P, Q, eta, zeta, wd, ops, s, xp + y, vp + u)
            for j in range(40):
                t = s + ops.num(j) / 7
                a = flight.state_from_coefficients(t, s, k, P, Q, eta, zeta, wd, ops)
                b = fl.at(t)
                assert all(abs(p - q) <= tol * 4 for p, q in zip(a[:2], b, strict=True)), (j, a, b)
                assert a[2] == ops.exp(-zeta * (t - s))  # the decay factor
            assert k[2] == u and not math.isnan(float(k[3]))


def test_precision_carries_the_flights_arithmetic():
    """Precision.ops: float64 -> math, mp:BITS -> mpmath at BITS in a context of its own (numbers
    of ops.num compute at BITS whatever mpmath's process-global precision is, and the ops never
    change that), long double / float128 refused (only heyoka computes in them)."""
    import mpmath
    import pytest

    from precise_impact.core.precision import Precision
    from precise_impact.errors import ParameterError

    assert Precision.parse("float64").ops is flight.FLOAT
    ops = Precision.parse("mp:300").ops
    before = mpmath.mp.prec
    with ops.context(), mpmath.workprec(53):
        third = ops.num(Fraction(1, 3))
        # 2^-250 survives the sum at 300 bits, not at mpmath's global 53 bits
        tiny = third * 3 + ops.num(Fraction(1, 2**250)) - 1
        assert mpmath.mp.prec == 53 and 2**-251 < tiny < 2**-249
        assert ops.exp(third).context is ops.ctx and ops.pi.context is ops.ctx
    assert mpmath.mp.prec == before
    for name in ("longdouble", "float128"):
        with pytest.raises(ParameterError, match="^precision = "):
            _ = Precision.parse(name).ops
