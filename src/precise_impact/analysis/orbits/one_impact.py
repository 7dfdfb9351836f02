"""The 1:1 and 1:n impacting orbits in closed form: one impact per n forcing periods.

The impact phase solves ``A_c cos(eta t*) + A_s sin(eta t*) = C1 x_w`` (two candidates, kept
when admissible); the multipliers follow in closed form (derivation: ``docs/numerics.rst``).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from fractions import Fraction
from types import SimpleNamespace
from typing import Any

import mpmath

from precise_impact.analysis.orbits.result import PeriodicOrbit, area_preserving, classify
from precise_impact.core import flight
from precise_impact.core.flow import steady_state
from precise_impact.core.impact import oscillator_saltation
from precise_impact.core.mpcontext import mp_export
from precise_impact.core.params import check_count, params_or_values
from precise_impact.errors import ParameterError

__all__ = ["one_impact_orbits", "flow_matrix"]


def _q(f: Fraction, ctx: Any = mpmath.mp) -> Any:
    return ctx.mpf(f.numerator) / f.denominator


def _phi(tau, zeta, w, ops: Any = flight.MPMATH):
    """``Phi(tau)`` in mpmath (:func:`precise_impact.core.flight.flow_matrix`): in ``ops``'s
    context, by default at the module-level working precision."""
    return flight.flow_matrix(tau, zeta, w, ops)


def flow_matrix(tau, zeta, w, ops: Any = None) -> Any:
    """The homogeneous flow (and tangent flow) ``Phi(tau)`` of the free flight as an mpmath
    matrix, ``w = sqrt(1 - zeta^2)``: of ``ops.ctx`` (a
    :class:`~precise_impact.core.flight.MpmathOps`, thread-safe), or without ``ops`` at the
    module-level working precision (``mpmath.workprec``; not thread-safe)."""
    p00, p01, p10, p11 = _phi(tau, zeta, w, flight.MPMATH if ops is None else ops)
    return (mpmath.matrix if ops is None else ops.ctx.matrix)([[p00, p01], [p10, p11]])


@contextlib.contextmanager
def _own_context(dps: int) -> Iterator[tuple[flight.MpmathOps, Any]]:
    """``(ops, ctx)``: an mpmath context of this computation's own at ``dps`` digits (mpmath's
    module-level precision, which ``workdps`` sets, is shared by every thread)."""
    ops = flight.MpmathOps(dps=dps)
    yield ops, ops.ctx


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
    with _own_context(dps) as (ops, mp):
        k = _coefficients(params, ss, n, ops, mp)
        Ac, As = k.C1 * k.P - k.C2 * k.eta * k.Q, k.C1 * k.Q + k.C2 * k.eta * k.P
        rho, psi = mp.hypot(Ac, As), mp.atan2(As, Ac)
        if k.norm == 0 or rho == 0:
            _degenerate(params, ss, k.norm)
            return []
        if abs(k.C1 * k.xw / rho) > 1:
            return []
        delta = mp.acos(k.C1 * k.xw / rho)
        for theta in (psi + delta, psi - delta):
            impact = _impact(params, k, theta, n, grid, ops, mp)
            if impact is not None:
                out.append(_orbit(params, k, n, impact, ops, mp))
    return out


def _coefficients(params: Any, ss: Any, n: int, ops: Any, mp: Any) -> SimpleNamespace:
    """The parameters, steady state, ``Phi(n T)`` and ``C1, C2`` at the working precision."""
    eta, zeta, a, xw, R = (_q(getattr(params, n), mp) for n in ("eta", "zeta", "a", "x_w", "R"))
    P, Q = _q(ss.P, mp), _q(ss.Q, mp)
    T = 2 * mp.pi / eta
    nT = n * T
    w = flight.damped_frequency(zeta, ops)
    e, c, s, half = _decay_cos_sin(params, n, nT, w, mp)
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
    return SimpleNamespace(
        eta=eta,
        zeta=zeta,
        a=a,
        xw=xw,
        R=R,
        P=P,
        Q=Q,
        T=T,
        nT=nT,
        w=w,
        p00=p00,
        p01=p01,
        p10=p10,
        p11=p11,
        C1=C1,
        C2=C2,
        a1=a1,
        a2=a2,
        norm=norm,
    )


def _impact(params: Any, k: SimpleNamespace, theta: Any, n: int, grid: int, ops: Any, mp: Any):
    """``(t*, v, y0, u0)`` of the candidate phase ``theta``, or None when not a 1:n orbit."""
    eta, zeta, a, xw, R, P, Q, T, nT, w = (k.eta, k.zeta, k.a, k.xw, k.R, k.P, k.Q, k.T, k.nT, k.w)
    ts = mp.fmod(theta / eta, T)
    if ts < 0:
        ts += T
    X = P * mp.cos(eta * ts) + Q * mp.sin(eta * ts)
    V = eta * (Q * mp.cos(eta * ts) - P * mp.sin(eta * ts))
    b1 = (k.p00 - 1) * (xw - X) - k.p01 * V
    b2 = V * (1 - k.p11) + k.p10 * (xw - X)
    v = (k.a1 * b1 + k.a2 * b2) / k.norm
    if not v > 0:
        return None
    if params.R == 0 and _sticks(eta, a, xw, ts, mp):
        return None  # a plastic impact that the force holds on the wall: not a flight
    y0, u0 = xw - X, -R * v - V

    def x_at(t, ts=ts, y0=y0, u0=u0):
        f00, f01, _, _ = _phi(t - ts, zeta, w, ops)
        return P * mp.cos(eta * t) + Q * mp.sin(eta * t) + f00 * y0 + f01 * u0

    if any(x_at(ts + nT * j / (n * grid)) >= xw for j in range(1, n * grid)):
        return None  # the flight would cross the wall: not a 1:n orbit
    return ts, v, y0, u0


def _orbit(params: Any, k: SimpleNamespace, n: int, impact: tuple, ops: Any, mp: Any):
    """The :class:`PeriodicOrbit` through the impact ``(t*, v, y0, u0)``: point at ``t0``,
    multipliers of ``S Phi(n T)``, residual."""
    eta, zeta, a, xw, R, P, Q, nT, w = k.eta, k.zeta, k.a, k.xw, k.R, k.P, k.Q, k.nT, k.w
    ts, v, y0, u0 = impact
    t0 = _q(params.t0, mp)
    tau = mp.fmod(t0 - ts, nT)
    if tau < 0:
        tau += nT
    f00, f01, f10, f11 = _phi(tau, zeta, w, ops)
    t_s = ts + tau
    x0 = P * mp.cos(eta * t_s) + Q * mp.sin(eta * t_s) + f00 * y0 + f01 * u0
    v0 = eta * (Q * mp.cos(eta * t_s) - P * mp.sin(eta * t_s)) + f10 * y0 + f11 * u0
    S = oscillator_saltation(ts, v, eta, zeta, a, xw, R, mp.cos)
    M = mp.matrix(S) * mp.matrix([[k.p00, k.p01], [k.p10, k.p11]])  # S Phi(nT)
    mu = sorted(mp.eig(M)[0], key=lambda m: -abs(m))
    kind = classify(mu, area_preserving(params.zeta, params.R, 1))
    lle = 0.0 if kind == "elliptic" else float(mp.log(abs(mu[0])) / nT)
    return PeriodicOrbit(
        params=params,
        period=n,
        impacts=1,
        t=float(t0),
        x=mp_export(x0),
        v=mp_export(v0),
        multipliers=[mp_export(m) for m in mu],
        stable=kind == "stable",
        lle=lle,
        residual=_residual(P, Q, eta, zeta, w, R, xw, t0, x0, v0, ts, nT, ops),
        iterations=0,
        method="closed form",
        precision=f"mp:{mp.prec}",
        stability=kind,
    )


def _decay_cos_sin(params: Any, n: int, nT: Any, w: Any, mp: Any) -> tuple:
    """``(e^(-zeta n T), cos(w n T), sin(w n T), sin(w n T / 2))`` at the working precision;
    exact at the resonances ``zeta = 0``, ``n T = k pi`` (``eta = 2n / k``), where the rounded
    ``pi`` would leave ``sin ~ 10^-dps`` and the closed form would divide by it."""
    if params.zeta == 0:
        k = Fraction(2 * n) / params.eta  # n T / pi
        if k.denominator == 1:
            sign = -1 if k.numerator % 2 else 1
            return (
                mp.mpf(1),
                mp.mpf(sign),
                mp.mpf(0),
                mp.mpf(1 if sign == -1 else 0),
            )
    e = mp.exp(-_q(params.zeta, mp) * nT)
    c, s = mp.cos_sin(w * nT)
    return e, c, s, mp.sin(w * nT / 2)


def _sticks(eta: Any, a: Any, xw: Any, ts: Any, mp: Any) -> bool:
    """At rest on the wall after a plastic impact (``R = 0``) the mass leaves only if
    ``x'' = a cos(eta t*) - x_w < 0``; where ``x''`` is zero to rounding (``2^16`` units of the
    working precision of the terms), the next derivative ``-a eta sin(eta t*)`` decides."""
    acc = a * mp.cos(eta * ts) - xw
    if abs(acc) <= mp.ldexp(abs(a) + abs(xw), 16 - mp.prec):
        return not -a * eta * mp.sin(eta * ts) < 0
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


def _residual(P, Q, eta, zeta, w, R, xw, t0, x0, v0, ts, nT, ops) -> float:
    """``max |P^n(z) - z|`` and the miss of the wall at the impact, by the flight equations
    evaluated once more from the returned point ``z = (x0, v0)`` at ``t0`` (an honest residual:
    a wrong phase or velocity shows here)."""
    t_imp = ts + nT * ops.ctx.ceil((t0 - ts) / nT)  # the next impact at or after t0
    if t_imp == t0:
        t_imp += nT
    x1, v1 = flight.Flight(P, Q, eta, zeta, w, ops, t0, x0, v0).at(t_imp)
    x2, v2 = flight.Flight(P, Q, eta, zeta, w, ops, t_imp, xw, -R * v1).at(t0 + nT)
    return float(max(abs(x1 - xw), abs(x2 - x0), abs(v2 - v0)))
