"""The 1:n closed form at its resonant and degenerate limits (issue 28, item 1).

Each orbit is checked against an independent Newton solve of the two flight equations (the
flight written here from scratch) and, at ``zeta = 0``, against the Budd-Dux formulas
``(1 - R) sin(nT/2) (x_w - X) + (1 + R) cos(nT/2) V = 0`` and ``v = 2 V / (1 - R)``
(C. J. Budd, F. Dux, Phil. Trans. R. Soc. A 347 (1994) 365-389).
"""

from __future__ import annotations

import mpmath
import pytest

import precise_impact as pi
from precise_impact.errors import ParameterError

DPS = 30
# agreement of two 30-digit evaluations of the same orbit: a few hundred units of 10^-30
# (phase from acos, then one flight); 1e-25 leaves five decades of margin and is still
# 20 decades below the errors it guards against (0.07 .. 0.7 before the fix)
TOL = mpmath.mpf("1e-25")


def _mp(q):
    return mpmath.mpf(q.numerator) / q.denominator


def _flight(p, ts, v, t):
    """State at ``t`` of the flight leaving the wall at ``ts`` with ``-R v`` (from scratch)."""
    eta, zeta, a, xw, R = (_mp(getattr(p, k)) for k in ("eta", "zeta", "a", "x_w", "R"))
    D = (1 - eta**2) ** 2 + (2 * zeta * eta) ** 2
    P, Q = a * (1 - eta**2) / D, 2 * zeta * eta * a / D

    def xp(t):
        return P * mpmath.cos(eta * t) + Q * mpmath.sin(eta * t)

    def vp(t):
        return eta * (Q * mpmath.cos(eta * t) - P * mpmath.sin(eta * t))

    w = mpmath.sqrt(1 - zeta**2)
    y0, u0 = xw - xp(ts), -R * v - vp(ts)
    A, B = y0, (u0 + zeta * y0) / w
    tau = t - ts
    e = mpmath.exp(-zeta * tau)
    y = e * (A * mpmath.cos(w * tau) + B * mpmath.sin(w * tau))
    dy = -zeta * y + e * w * (-A * mpmath.sin(w * tau) + B * mpmath.cos(w * tau))
    return xp(t) + y, vp(t) + dy


def _newton(p, n, ts0, v0):
    """Newton (mpmath.findroot) on ``x(ts + nT) = x_w``, ``v(ts + nT) = v``."""
    nT = n * 2 * mpmath.pi / _mp(p.eta)
    xw = _mp(p.x_w)

    def eqs(ts, v):
        x1, v1 = _flight(p, ts, v, ts + nT)
        return [x1 - xw, v1 - v]

    return mpmath.findroot(eqs, (ts0, v0))


def _budd_dux(p, n):
    """The zeta = 0 impact phase and velocity (R < 1): X(ts) = x_w + ... solved from a grid
    sign change by bisection, v = 2 V / (1 - R); every root with v > 0."""
    eta, a, xw, R = (_mp(getattr(p, k)) for k in ("eta", "a", "x_w", "R"))
    P = a / (1 - eta**2)
    half = n * mpmath.pi / eta  # nT / 2

    def f(ts):
        X, V = P * mpmath.cos(eta * ts), -eta * P * mpmath.sin(eta * ts)
        return (1 - R) * mpmath.sin(half) * (xw - X) + (1 + R) * mpmath.cos(half) * V

    T = 2 * mpmath.pi / eta
    grid = [T * k / 400 for k in range(401)]
    out = []
    for lo, hi in zip(grid[:-1], grid[1:], strict=True):
        if f(lo) * f(hi) < 0:
            ts = mpmath.findroot(f, (lo, hi), solver="anderson")
            v = 2 * (-eta * P * mpmath.sin(eta * ts)) / (1 - R)
            if v > 0:
                out.append((ts, v))
    return out


def _state_at_t0(p, n, ts, v):
    """The orbit's state at t0 from its impact (ts, v): the flight from the last impact."""
    nT = n * 2 * mpmath.pi / _mp(p.eta)
    t0 = _mp(p.t0)
    last = ts + nT * mpmath.floor((t0 - ts) / nT)
    return _flight(p, last, v, t0)


RESONANT = [  # eta = 2n / k with k odd, zeta = 0: sin(nT) = 0 exactly
    ({"eta": "2", "R": "0.8", "x_w": "0"}, 1),
    ({"eta": "2", "R": "0.8", "x_w": "0.2"}, 1),
    ({"eta": "6", "R": "0.8", "x_w": "0"}, 3),
    ({"eta": "4", "R": "0.8", "x_w": "0.05"}, 2),
]


@pytest.mark.parametrize(("values", "n"), RESONANT)
def test_resonant_closed_form_matches_budd_dux_and_newton(values, n):
    p = pi.Params.make(zeta="0", **values)
    orbits = pi.one_impact_orbits(p, dps=DPS, period=n)
    with mpmath.workdps(DPS):
        bd = _budd_dux(p, n)
        assert len(orbits) == len(bd) == 1  # one phase has V > 0 (the other would need v < 0)
        ts, v = bd[0]
        # at the resonance the phase condition is X(ts) = x_w exactly, v = 2 V / (1 - R)
        eta, xw = _mp(p.eta), _mp(p.x_w)
        assert abs(_mp(pi.steady_state(p).P) * mpmath.cos(eta * ts) - xw) < TOL
        ts_n, v_n = _newton(p, n, ts + mpmath.mpf("0.01"), v * mpmath.mpf("1.01"))
        assert abs(ts_n - ts) < TOL and abs(v_n - v) < TOL
        x0, v0 = _state_at_t0(p, n, ts, v)
        o = orbits[0]
        assert abs(o.x - x0) < TOL and abs(o.v - v0) < TOL
        assert o.residual < TOL  # honest: the map evaluated once more, not set to 0
    f = pi.find_orbit(p, n, guess=(float(x0), float(v0)))
    assert f.impacts == 1
    # find_orbit is float64 Newton: its point agrees to ~1e-15 relative (condition ~10)
    assert abs(f.x - float(x0)) < 1e-12 and abs(f.v - float(v0)) < 1e-12


@pytest.mark.parametrize(
    ("values", "n"),
    [
        ({"eta": "2.5", "R": "0", "x_w": "0", "zeta": "0.05"}, 1),  # plastic impact
        ({"eta": "3", "R": "0", "x_w": "0.05", "zeta": "0"}, 1),  # plastic, undamped
        ({"eta": "2", "R": "0", "x_w": "0", "zeta": "0"}, 1),  # plastic at the resonance
        ({"eta": "2.0000001", "R": "1", "x_w": "0", "zeta": "0"}, 1),  # next to R = 1's pole
        ({"eta": "1", "R": "0.8", "zeta": "0.05"}, 1),  # generic
    ],
)
def test_limits_match_newton_on_the_flight_equations(values, n):
    p = pi.Params.make(**values)
    orbits = pi.one_impact_orbits(p, dps=DPS, period=n)
    assert orbits
    nT = n * 2 * mpmath.pi / _mp(p.eta)
    with mpmath.workdps(DPS):
        for o in orbits:
            # the impact (ts, v) found from the returned point, then Newton from 1% off it
            ts, v = _impact_from(p, n, o.x, o.v)
            ts_n, v_n = _newton(p, n, ts + nT / 100, v * mpmath.mpf("1.01"))
            x0, v0 = _state_at_t0(p, n, ts_n, v_n)
            scale = 1 + abs(v_n)
            assert abs(o.x - x0) < TOL * scale and abs(o.v - v0) < TOL * scale
            assert o.residual < float(TOL * scale)
            if p.R == 0:  # the mass leaves the wall: x'' < 0 at rest there (or x'' = 0, x''' < 0)
                acc = _mp(p.a) * mpmath.cos(_mp(p.eta) * ts_n) - _mp(p.x_w)
                assert acc < TOL or -_mp(p.a) * _mp(p.eta) * mpmath.sin(_mp(p.eta) * ts_n) < 0
            if p.zeta == 0 and p.R < 1:  # Budd-Dux: v = 2 V / (1 - R)
                bd = _budd_dux(p, n)
                assert min(abs(v_n - b[1]) for b in bd) < TOL * scale


def _impact_from(p, n, x, v):
    """The first impact after t0 from the state (x, v) at t0, by a scan and bisection of the
    flight written here (independent of the package)."""
    eta, zeta, a, xw = (_mp(getattr(p, k)) for k in ("eta", "zeta", "a", "x_w"))
    t0 = _mp(p.t0)
    nT = n * 2 * mpmath.pi / eta
    D = (1 - eta**2) ** 2 + (2 * zeta * eta) ** 2
    P, Q = a * (1 - eta**2) / D, 2 * zeta * eta * a / D
    w = mpmath.sqrt(1 - zeta**2)
    y0 = x - (P * mpmath.cos(eta * t0) + Q * mpmath.sin(eta * t0))
    u0 = v - eta * (Q * mpmath.cos(eta * t0) - P * mpmath.sin(eta * t0))

    def xt(t):
        tau = t - t0
        e = mpmath.exp(-zeta * tau)
        A, B = y0, (u0 + zeta * y0) / w
        y = e * (A * mpmath.cos(w * tau) + B * mpmath.sin(w * tau))
        dy = -zeta * y + e * w * (-A * mpmath.sin(w * tau) + B * mpmath.cos(w * tau))
        return (
            P * mpmath.cos(eta * t) + Q * mpmath.sin(eta * t) + y - xw,
            eta * (Q * mpmath.cos(eta * t) - P * mpmath.sin(eta * t)) + dy,
        )

    grid = [t0 + nT * k / 4000 for k in range(1, 4001)]
    prev = t0
    for t in grid:
        if xt(t)[0] >= 0:
            ts = mpmath.findroot(lambda s: xt(s)[0], (prev, t), solver="anderson")
            return ts, xt(ts)[1]
        prev = t
    raise AssertionError("no impact within n T")


def test_resonance_with_r_1_has_no_orbit_or_a_continuum():
    # zeta = 0, R = 1, eta = 2: the equations need X = x_w and V = 0 at the impact.
    # x_w = 0: impossible, no orbit (before: one at x = -3.9e30 with residual 0)
    assert pi.one_impact_orbits(pi.Params.make(zeta="0", R="1", eta="2", x_w="0"), dps=DPS) == []
    # x_w = +-1/3 (the steady amplitude): every impact velocity works, refused by name
    for xw in ("1/3", "-1/3"):
        with pytest.raises(ParameterError, match="continuum"):
            pi.one_impact_orbits(pi.Params.make(zeta="0", R="1", eta="2", x_w=xw, x0="-1"))


def test_phi_identity_resonance_has_no_impacting_orbit():
    # eta = 1/2, n = 1: nT = 4 pi, Phi = I: the impact velocity would be 0
    for R in ("0.5", "1"):
        assert pi.one_impact_orbits(pi.Params.make(zeta="0", R=R, eta="0.5", x_w="0")) == []
