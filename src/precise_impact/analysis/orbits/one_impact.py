"""The 1:1 and 1:n impacting orbits in closed form: one impact per n forcing periods.

The impact phase solves ``A_c cos(eta t*) + A_s sin(eta t*) = C1 x_w`` (two candidates, kept
when admissible); the multipliers follow in closed form (derivation: ``docs/numerics.rst``).
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

import mpmath

from precise_impact.analysis.orbits.result import PeriodicOrbit, area_preserving, classify
from precise_impact.core import flight
from precise_impact.core.flow import steady_state
from precise_impact.core.impact import oscillator_saltation
from precise_impact.core.params import check_count, params_or_values
from precise_impact.errors import ParameterError

__all__ = ["one_impact_orbits", "flow_matrix"]


def _q(f: Fraction) -> mpmath.mpf:
    return mpmath.mpf(f.numerator) / f.denominator


def _phi(tau, zeta, w):
    """``Phi(tau)`` in mpmath at the current working precision
    (:func:`precise_impact.core.flight.flow_matrix`)."""
    return flight.flow_matrix(tau, zeta, w, flight.MPMATH)


def flow_matrix(tau, zeta, w) -> mpmath.matrix:
    """The homogeneous flow (and tangent flow) ``Phi(tau)`` of the free flight as an mpmath
    matrix, ``w = sqrt(1 - zeta^2)``."""
    p00, p01, p10, p11 = _phi(tau, zeta, w)
    return mpmath.matrix([[p00, p01], [p10, p11]])


def one_impact_orbits(
    params: Any = None, dps: int = 50, grid: int = 2000, *, period: int = 1, **param_values: Any
) -> list[PeriodicOrbit]:
    """Every 1:1 (or 1:n) impacting orbit of ``params``, in closed form (module docstring).

    Parameters
    ----------
    params : Params, mapping or None, default ``None``
        The system (``0 <= zeta < 1``, ``0 <= R <= 1``: at ``R = 0`` the orbits that leave the
        wall after the impact, not those that stick); ``t0`` is the stroboscopic phase of the
        returned points.
    dps : int, default 50
        Decimal digits of the mpmath evaluation (``15 <= dps <= 10000``).
    grid : int, default 2000
        Points per forcing period on which the free flight is checked to stay below the wall.
    period : int, default 1
        ``n``: one impact per ``n`` forcing periods (``1 <= n <= 1000``); the orbit's
        period is ``n T``.
    **param_values
        Parameter values replacing those of ``params``.

    Returns
    -------
    list of PeriodicOrbit
        ``method = 'closed form'``, ``precision = 'mp:BITS'``, ``period = n``, ``impacts = 1``;
        ``x``, ``v`` (at ``t0``) and the multipliers are mpmath numbers; ``stats``-free.
        ``stability`` is ``'elliptic'`` for a complex pair when ``zeta = 0`` and ``R = 1``.
        Empty when there is none.

    Raises
    ------
    ParameterError
        Bad input.

    See Also
    --------
    precise_impact.analysis.orbits.newton.find_orbit : any period by Newton's method.
    precise_impact.analysis.orbits.proof.prove_orbit : prove one of the orbits.
    precise_impact.analysis.orbits.continuation.continue_orbit : follow an orbit in a parameter.

    Examples
    --------
    >>> import precise_impact as pi
    >>> orbits = pi.one_impact_orbits(pi.Params.make(R="0.8", eta="1"), dps=20)
    >>> [(o.period, o.impacts) for o in orbits]
    [(1, 1)]
    >>> round(float(orbits[0].x), 6)
    1.686569
    """
    params = params_or_values(params, param_values)
    dps = check_count(dps, "dps", 10_000, minimum=15)
    grid = check_count(grid, "grid", 10**6, minimum=10)
    n = check_count(period, "period", 1000, minimum=1)
    if not (0 <= params.zeta < 1) or not (0 <= params.R <= 1):
        raise ParameterError(
            "params", params.decimal(), "0 <= zeta < 1 and 0 <= R <= 1 for the closed form"
        )
    ss = steady_state(params)
    out = []
    with mpmath.workdps(dps):
        eta, zeta, a, xw, R = (_q(getattr(params, n)) for n in ("eta", "zeta", "a", "x_w", "R"))
        P, Q = _q(ss.P), _q(ss.Q)
        T = 2 * mpmath.pi / eta
        nT = n * T
        w = flight.damped_frequency(zeta, flight.MPMATH)
        e, c, s, half = _decay_cos_sin(params, n, nT, w)
        sw = s / w
        p00, p01, p10, p11 = e * (c + zeta * sw), e * sw, -e * sw, e * (c - zeta * sw)
        # The impact phase t* and velocity v solve the two flight equations (land on the wall
        # after n T with the velocity v that the impact reverses):
        #   (E1)  (p00 - 1) (x_w - X) - p01 (R v + V) = 0
        #   (E2)  (1 + p11 R) v = V (1 - p11) + p10 (x_w - X)
        # X, V: the steady state at t*.  Eliminating v gives C1 (x_w - X) + C2 V = 0 with
        # C1 = 1 - R e^2 - (1 - R) e c - (1 + R) e zeta s / w (det Phi = e^2) and
        # C2 = (1 + R) p01; for zeta = 0, C1 = 2 (1 - R) sin^2(w n T / 2) without cancellation.
        if params.zeta == 0:
            C1 = 2 * (1 - R) * half * half
        else:
            C1 = 1 - R * e * e - (1 - R) * e * c - (1 + R) * e * zeta * sw
        C2 = p01 * (1 + R)
        # v from E1 and E2 together (least squares of two consistent equations): E1 alone
        # divides by p01 R, which vanishes at the resonances w n T = k pi (eta = 2n/k at
        # zeta = 0, sin = 0 exactly) and at R = 0; E2 alone by 1 + p11 R, which vanishes at
        # zeta = 0, R = 1, cos = -1.  a1^2 + a2^2 = 0 only when all of those hold at once.
        a1, a2 = p01 * R, 1 + p11 * R
        norm = a1 * a1 + a2 * a2
        Ac, As = C1 * P - C2 * eta * Q, C1 * Q + C2 * eta * P
        rho, psi = mpmath.hypot(Ac, As), mpmath.atan2(As, Ac)
        if norm == 0 or rho == 0:
            _degenerate(params, ss, norm)
            return []
        if abs(C1 * xw / rho) > 1:
            return []
        delta = mpmath.acos(C1 * xw / rho)
        for theta in (psi + delta, psi - delta):
            ts = mpmath.fmod(theta / eta, T)
            if ts < 0:
                ts += T
            X = P * mpmath.cos(eta * ts) + Q * mpmath.sin(eta * ts)
            V = eta * (Q * mpmath.cos(eta * ts) - P * mpmath.sin(eta * ts))
            b1 = (p00 - 1) * (xw - X) - p01 * V
            b2 = V * (1 - p11) + p10 * (xw - X)
            v = (a1 * b1 + a2 * b2) / norm
            if not v > 0:
                continue
            if params.R == 0 and _sticks(eta, a, xw, ts):
                continue  # a plastic impact that the force holds on the wall: not a flight
            y0, u0 = xw - X, -R * v - V

            def x_at(t, ts=ts, y0=y0, u0=u0):
                f00, f01, _, _ = _phi(t - ts, zeta, w)
                return P * mpmath.cos(eta * t) + Q * mpmath.sin(eta * t) + f00 * y0 + f01 * u0

            if any(x_at(ts + nT * j / (n * grid)) >= xw for j in range(1, n * grid)):
                continue  # the flight would cross the wall: not a 1:n orbit
            t0 = _q(params.t0)
            tau = mpmath.fmod(t0 - ts, nT)
            if tau < 0:
                tau += nT
            f00, f01, f10, f11 = _phi(tau, zeta, w)
            t_s = ts + tau
            x0 = P * mpmath.cos(eta * t_s) + Q * mpmath.sin(eta * t_s) + f00 * y0 + f01 * u0
            v0 = eta * (Q * mpmath.cos(eta * t_s) - P * mpmath.sin(eta * t_s)) + f10 * y0 + f11 * u0
            S = oscillator_saltation(ts, v, eta, zeta, a, xw, R, mpmath.cos)
            M = mpmath.matrix(S) * mpmath.matrix([[p00, p01], [p10, p11]])  # S Phi(nT)
            mu = sorted(mpmath.eig(M)[0], key=lambda m: -abs(m))
            kind = classify(mu, area_preserving(params.zeta, params.R, 1))
            lle = 0.0 if kind == "elliptic" else float(mpmath.log(abs(mu[0])) / nT)
            out.append(
                PeriodicOrbit(
                    params=params,
                    period=n,
                    impacts=1,
                    t=float(t0),
                    x=x0,
                    v=v0,
                    multipliers=list(mu),
                    stable=kind == "stable",
                    lle=lle,
                    residual=_residual(P, Q, eta, zeta, w, R, xw, t0, x0, v0, ts, nT),
                    iterations=0,
                    method="closed form",
                    precision=f"mp:{mpmath.mp.prec}",
                    stability=kind,
                )
            )
    return out


def _decay_cos_sin(params: Any, n: int, nT: Any, w: Any) -> tuple:
    """``(e^(-zeta n T), cos(w n T), sin(w n T), sin(w n T / 2))`` at the working precision;
    exact at the resonances ``zeta = 0``, ``n T = k pi`` (``eta = 2n / k``), where the rounded
    ``pi`` would leave ``sin ~ 10^-dps`` and the closed form would divide by it."""
    if params.zeta == 0:
        k = Fraction(2 * n) / params.eta  # n T / pi
        if k.denominator == 1:
            sign = -1 if k.numerator % 2 else 1
            return (
                mpmath.mpf(1),
                mpmath.mpf(sign),
                mpmath.mpf(0),
                mpmath.mpf(1 if sign == -1 else 0),
            )
    e = mpmath.exp(-_q(params.zeta) * nT)
    c, s = mpmath.cos_sin(w * nT)
    return e, c, s, mpmath.sin(w * nT / 2)


def _sticks(eta: Any, a: Any, xw: Any, ts: Any) -> bool:
    """At rest on the wall after a plastic impact (``R = 0``) the mass leaves only if
    ``x'' = a cos(eta t*) - x_w < 0``; where ``x''`` is zero to rounding (``2^16`` units of the
    working precision of the terms), the next derivative ``-a eta sin(eta t*)`` decides."""
    acc = a * mpmath.cos(eta * ts) - xw
    if abs(acc) <= mpmath.ldexp(abs(a) + abs(xw), 16 - mpmath.mp.prec):
        return not -a * eta * mpmath.sin(eta * ts) < 0
    return acc >= 0


def _degenerate(params: Any, ss: Any, norm: Any) -> None:
    """Both flight equations vanish identically (``C1 = C2 = 0``) or lose ``v``
    (``a1 = a2 = 0``): at ``zeta = 0`` with ``sin(n T) = 0``.  ``Phi(n T) = I``: the impact
    velocity would be 0 (no impacting orbit).  ``Phi(n T) = -I`` with ``R = 1``: the steady
    state must touch the wall at rest (``x_w = +-`` its amplitude), and then every impact
    velocity gives an orbit: a continuum, refused; otherwise there is none.  ``a = 0``
    (no forcing): no impacting orbit.  Returns when there is none."""
    if norm == 0 and params.x_w**2 == ss.amplitude_squared and ss.amplitude_squared > 0:
        raise ParameterError(
            "x_w",
            str(params.x_w),
            "not the steady state's extreme at the resonance zeta = 0, R = 1, eta = 2n/k "
            "(k odd): there every impact velocity gives a 1:n orbit (a continuum, no "
            "isolated orbit to list)",
        )


def _residual(P, Q, eta, zeta, w, R, xw, t0, x0, v0, ts, nT) -> float:
    """``max |P^n(z) - z|`` and the miss of the wall at the impact, by the flight equations
    evaluated once more from the returned point ``z = (x0, v0)`` at ``t0`` (an honest residual:
    a wrong phase or velocity shows here)."""
    ops = flight.MPMATH
    t_imp = ts + nT * mpmath.ceil((t0 - ts) / nT)  # the next impact at or after t0
    if t_imp == t0:
        t_imp += nT
    x1, v1 = flight.Flight(P, Q, eta, zeta, w, ops, t0, x0, v0).at(t_imp)
    x2, v2 = flight.Flight(P, Q, eta, zeta, w, ops, t_imp, xw, -R * v1).at(t0 + nT)
    return float(max(abs(x1 - xw), abs(x2 - x0), abs(v2 - v0)))
