"""Periodic orbits: Newton on the stroboscopic map against closed forms and long runs.

Independent references: the 1:1 orbit and its multipliers in closed form (mpmath, 50
digits; derived in ``analysis/orbits/one_impact.py``), the exact LLE of an orbit with
complex multipliers (``ln R / T - zeta``), long simulations with heyoka, and the
spectrum identity ``ln |mu1 mu2| = p (ln R^2 (impacts / p) - 2 zeta T)``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from precise_impact import ParameterError, Params, simulate
from precise_impact.analysis.orbits import ConvergenceError, find_orbit, one_impact_orbits

EPS = 2.0**-52


def test_one_impact_orbit_closed_form_equals_newton():
    """zeta = 0.05, a = 1, x_w = 2, R = 0.8, eta = 1 (the issue's case): one admissible 1:1
    orbit; Newton from the default guess (a long run) converges to it.  Newton's fixed
    point is accurate to the conditioning of M - I times the map's rounding (|M| ~ 1,
    |(M - I)^-1| ~ 1 here): 1e-12 is ~5000 eps with room for the map's ~100 roundings.
    The multipliers are complex, so the LLE is exactly ln R / T - zeta = -0.0855144."""
    p = Params.make(R="0.8", eta="1")
    (cf,) = one_impact_orbits(p)
    nw = find_orbit(p, 1)
    assert nw.impacts == cf.impacts == 1 and nw.period == 1 and nw.stable and cf.stable
    assert abs(nw.x - float(cf.x)) <= 1e-12 and abs(nw.v - float(cf.v)) <= 1e-12
    exact = math.log(0.8) / (2 * math.pi) - 0.05
    assert abs(float(cf.lle) - exact) <= 1e-15 and abs(nw.lle - exact) <= 1e-12
    assert round(exact, 7) == -0.0855144
    mu_cf = sorted((complex(m) for m in cf.multipliers), key=lambda m: m.imag)
    mu_nw = sorted(nw.multipliers, key=lambda m: m.imag)
    assert all(abs(a - b) <= 1e-12 for a, b in zip(mu_cf, mu_nw, strict=True))
    assert nw.residual <= 64 * EPS * (1 + abs(nw.x) + abs(nw.v))


def test_closed_form_is_a_fixed_point_of_the_heyoka_map():
    """The closed-form 1:1 orbit's point, run 20 periods with heyoka mp:192, comes back to
    itself: it is a periodic orbit of the mechanical model, not only of the engine."""
    p = Params.make(R="0.8", eta="1")
    (cf,) = one_impact_orbits(p, dps=60)
    q = p.replace(x0=str(cf.x), v0=str(cf.v))
    tr = simulate(q, 20, precision="mp:192")
    assert (
        abs(float(tr.x[-1]) - float(cf.x)) <= 1e-40 and abs(float(tr.v[-1]) - float(cf.v)) <= 1e-40
    )
    assert tr.n_impacts == 20


def test_period_three_orbit_equals_the_long_run_and_its_floquet_lle():
    """eta = 0.74 settles on a period-3 orbit; Newton's point equals the state of a long
    heyoka run (2000 periods: transients decay like |mu_max|^(n/3) = 0.64^666, far below
    rounding) to the run's own clock rounding, 4 eps t_end max|v| (3.5e-11; measured
    1.7e-12); its LLE ln|mu_max| / 3T equals the fast engine's finite-time estimate
    (stats['finite_time'], not r.lle, which is the Floquet value itself) within k = 3 of that
    estimate's stated error: sqrt(batch^2 + (B / t)^2 + resolution^2), B the bound on the
    never-restarted tangent basis' end effect (2.30 here; measured offset 0.18 / t).  The
    offset beyond the bias is batch noise (Student t, 19 degrees of freedom: 3 sigma is
    two-sided 0.007); measured z = -0.08 (-0.85 in units of the batch error alone)."""
    from precise_impact import lyapunov

    p = Params.make(eta="0.74")
    o = find_orbit(p, 3)
    assert o.period == 3 and o.stable and o.impacts == 2
    tr = simulate(p, 2001)
    tail = np.column_stack([np.asarray(tr.x, float), np.asarray(tr.v, float)])[-3:]
    bound = 4 * EPS * float(tr.t[-1]) * float(np.max(np.abs(np.asarray(tr.v, float))))
    assert min(np.max(np.abs(row - [o.x, o.v])) for row in tail) <= bound
    r = lyapunov(p, "variational", model="fast", periods=20000, transient=1000)
    ft = r.stats["finite_time"]
    assert r.stats["lle_source"] == "floquet" and ft["lle"] != r.lle
    assert abs(ft["lle"] - o.lle) <= 3 * ft["stderr"], (ft, o.lle)


def test_exponent_sum_of_the_floquet_multipliers():
    """det M = R^(2 n) exp(-2 zeta p T) for n impacts in p periods (det Phi = exp(-2 zeta tau),
    det S = R^2): the product of the multipliers, for a 1:1 and a period-3 orbit."""
    for p, period in ((Params.make(R="0.8", eta="1"), 1), (Params.make(eta="0.74"), 3)):
        o = find_orbit(p, period)
        T = 2 * math.pi / float(p.eta)
        det = abs(o.multipliers[0] * o.multipliers[1])
        expected = float(p.R) ** (2 * o.impacts) * math.exp(-2 * 0.05 * period * T)
        assert abs(det - expected) <= 1e-12 * expected


def test_unstable_orbit_is_found_from_the_closed_form_seed():
    """At eta = 0.712 (chaos) the 1:1 orbits are unstable: Newton, seeded with the closed
    form, converges to them anyway (quadratically, from 1e-10 away in 2-3 steps) and
    reports |mu_max| > 1 and a positive LLE; a long run could never find them."""
    p = Params.make(eta="0.712")
    orbits = one_impact_orbits(p)
    assert orbits, "the 1:1 orbits exist at eta = 0.712"
    unstable = [o for o in orbits if not o.stable]
    assert unstable
    o = unstable[0]
    nw = find_orbit(p, 1, guess=(float(o.x) + 1e-10, float(o.v) - 1e-10))
    assert not nw.stable and nw.lle > 0 and nw.iterations <= 6
    assert abs(nw.x - float(o.x)) <= 1e-11 and abs(nw.v - float(o.v)) <= 1e-11


def test_bad_input_and_no_convergence_are_named():
    p = Params.make(eta="0.74")
    with pytest.raises(ParameterError, match="period"):
        find_orbit(p, 0)
    with pytest.raises(ParameterError, match="guess"):
        find_orbit(p, 1, guess=(1.0,))
    with pytest.raises(ParameterError, match="precision"):
        find_orbit(p, 1, precision="longdouble")
    with pytest.raises(ConvergenceError, match="impacts"):
        find_orbit(p, 3, impacts=5)


def test_orbits_serialise():
    """``to_dict`` is the CLI's JSON object; a closed-form orbit keeps every digit as a
    decimal string (50 digits here, the mpmath evaluation's)."""
    import json

    import mpmath

    (cf,) = one_impact_orbits(Params.make(R="0.8", eta="1"), dps=50)
    d = json.loads(json.dumps(cf.to_dict()))
    assert d["method"] == "closed form" and d["impacts"] == 1 and d["stable"] is True
    with mpmath.workdps(50):
        assert abs(mpmath.mpf(d["state"]["x"]) - cf.x) <= mpmath.mpf(10) ** -45
    nw = find_orbit(Params.make(R="0.8", eta="1"), 1).to_dict()
    assert set(nw) >= {
        "params",
        "period",
        "impacts",
        "state",
        "multipliers",
        "stable",
        "lle",
        "residual",
    }
    assert isinstance(nw["state"]["x"], float) and len(nw["multipliers"]) == 2


def test_multiprecision_newton_reaches_the_closed_form_to_1e_40():
    """mp:192 (57 digits): Newton refines the float64 orbit quadratically (3 more steps);
    the map is the robust analytical solver in mpmath, the Jacobian the closed-form flows
    and saltation matrix.  Against the closed form at 70 digits: 1e-40 required (measured
    5e-57, the working precision), multipliers likewise."""
    import mpmath

    p = Params.make(R="0.8", eta="1")
    (cf,) = one_impact_orbits(p, dps=70)
    o = find_orbit(p, 1, precision="mp:192")
    assert o.precision == "mp:192" and o.impacts == 1 and o.residual <= 1e-50
    with mpmath.workdps(70):
        assert abs(o.x - cf.x) <= mpmath.mpf(10) ** -40 and abs(o.v - cf.v) <= mpmath.mpf(10) ** -40
        mu_o = sorted(o.multipliers, key=lambda m: mpmath.im(m))
        mu_c = sorted(cf.multipliers, key=lambda m: mpmath.im(m))
        assert all(abs(a - b) <= mpmath.mpf(10) ** -40 for a, b in zip(mu_o, mu_c, strict=True))


def test_multiprecision_period_three_orbit_has_a_working_precision_residual():
    """mp:256: residual below 2^-240 (measured 1.6e-76 = 2^-252) and the float64 orbit within
    its own rounding (1e-12)."""
    o = find_orbit(Params.make(eta="0.74"), 3, precision="mp:256")
    f = find_orbit(Params.make(eta="0.74"), 3)
    assert o.residual <= 2.0**-240 and o.impacts == f.impacts == 2
    assert abs(float(o.x) - f.x) <= 1e-12 and abs(o.lle - f.lle) <= 1e-12
