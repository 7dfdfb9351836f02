"""The safeguarded Newton iteration on the closed form (core/crossing.py), in float and mpmath.

Independent references: roots known in closed form or from mpmath's own solver at 60 digits;
the wall crossings of the closed-form flight against the heyoka reference; a function whose
plain Newton iteration leaves the bracket (the safeguard must hold it); and the two callers,
the closed-form solver and the shooting system's maxima, agreeing with an independent root.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest

import precise_impact as pi
from precise_impact.core.crossing import safeguarded_newton


def _cubic(c):
    """f(t) = t^3 + t - c: increasing, one real root."""
    return lambda t: (t * t * t + t - c, 3 * t * t + 1)


@pytest.mark.parametrize("c", [0.5, 2.0, 10.0, 1e-8])
def test_float_roots_to_the_tolerance(c):
    calls = []

    def f(t):
        calls.append(t)
        return _cubic(c)(t)

    lo, hi = 0.0, 3.0
    t, (ft, dft) = safeguarded_newton(f, lo, hi, *f(lo), 4 * 2.0**-53 * hi, 200)
    assert len(calls) <= 14  # Newton's quadratic convergence, not ~52 bisections
    with mpmath.workdps(60):
        exact = mpmath.findroot(lambda s: s**3 + s - c, 0.5)
        assert abs(mpmath.mpf(t) - exact) <= 8 * 2.0**-52 * max(1, abs(t))
    assert (ft, dft) == _cubic(c)(t)  # the evaluation handed back is the one at the root


def test_mpmath_roots_to_the_tolerance():
    with mpmath.workdps(50):
        f = _cubic(mpmath.mpf(2))
        lo, hi = mpmath.mpf(0), mpmath.mpf(3)
        t, _ = safeguarded_newton(f, lo, hi, *f(lo), mpmath.mpf(10) ** -45, 400)
        assert isinstance(t, mpmath.mpf) and abs(t**3 + t - 2) < mpmath.mpf(10) ** -44
        assert abs(t - 1) < mpmath.mpf(10) ** -44  # t^3 + t = 2 at t = 1


def test_the_bracket_holds_where_plain_newton_leaves_it():
    """atan(t - 1) on [-20, 5]: Newton from -20 jumps to ~ +590 (far out of the bracket) and
    cycles near the root when started far; the safeguard bisects and converges, never
    evaluating outside [lo, hi]."""
    seen = []

    def f(t):
        seen.append(t)
        return math.atan(t - 1), 1 / (1 + (t - 1) ** 2)

    lo, hi = -20.0, 5.0
    assert not (lo < lo - f(lo)[0] / f(lo)[1] < hi)  # plain Newton leaves the bracket
    seen.clear()
    t, _ = safeguarded_newton(f, lo, hi, *f(lo), 1e-15, 200)
    assert abs(t - 1) < 1e-14 and all(lo <= s <= hi for s in seen) and len(seen) < 60


def test_a_start_at_or_past_the_root_returns_lo_and_a_spent_budget_the_midpoint():
    f = _cubic(2.0)
    assert safeguarded_newton(f, 1.0, 2.0, *f(1.0), 1e-15, 50) == (1.0, f(1.0))
    t, _ = safeguarded_newton(f, 0.0, 3.0, *f(0.0), 0.0, 0)  # no iteration allowed
    assert t == 1.5


def test_the_closed_form_solver_finds_the_reference_impacts():
    """The closed-form solver's crossings (this Newton) against heyoka at 128 bits: the
    impact times of 30 periods at eta = 0.712, R = 0.8 agree to 1e-12."""
    p = pi.Params.make(eta="0.712", R="0.8")
    a = pi.simulate(p, 30, model="analytical")
    h = pi.simulate(p, 30, precision="mp:128")
    ta, th = np.asarray(a.impacts_t, float), np.array([float(t) for t in h.impacts_t])
    assert len(ta) == len(th) > 10 and np.max(np.abs(ta - th)) < 1e-12


def test_the_shooting_maxima_are_the_zeros_of_v():
    """The grazing margin of the period-3 orbit (``x_w`` minus its highest interior maximum,
    found by this Newton on ``v = 0``) equals the one read off the heyoka reference on a grid
    of 20000 points per period from the same orbit (the grid's error at a maximum:
    ``|x''| dt^2 / 2 < 1e-7``); a mutated Newton (a maximum off by 1e-3 in time) would not."""
    from precise_impact.analysis.orbits.shooting import ShootingSystem, from_orbit

    p = pi.Params.make(eta="0.74")
    o = pi.find_orbit(p, 3)
    base = {k: float(getattr(p, k)) for k in ("eta", "zeta", "a", "x_w", "R", "t0")}
    S = ShootingSystem(base, "eta", 3, o.impacts)
    u = from_orbit(S, p, o.x, o.v, 0.74)
    margin, _ = S.grazing_tests(u, 0.74)
    tr = pi.simulate(p.replace(x0=o.x, v0=o.v), 3, per_period=20000)
    x, v = np.asarray(tr.dense_x, float), np.asarray(tr.dense_v, float)
    peak = (v[:-1] > 0) & (v[1:] <= 0) & (x[:-1] < float(p.x_w) - 1e-3)  # not an impact
    highest = max(np.max(x[:-1][peak]), np.max(x[1:][peak]))
    assert 0.1 < margin < 1 and abs(float(p.x_w) - highest - margin) < 2e-7
