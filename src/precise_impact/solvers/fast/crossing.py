"""The fast engine's crossing kit (numba, float64): flight kernels, bounds, proofs, Newton.

Compiled copies of :mod:`precise_impact.core.flight` (``tests/core/test_flight.py`` pins them)
shared by the single oscillator and the pair; the proofs are in ``docs/numerics.rst``.
"""

from __future__ import annotations

import math
from typing import Any

import numba

#: The compile options of every kernel: cached on disk, IEEE arithmetic, numpy's error model, and
#: the GIL released (a kernel runs in a helper thread while the main thread waits for signals:
#: :mod:`precise_impact.solvers.fast.control`).
JIT: dict[str, Any] = dict(cache=True, fastmath=False, error_model="numpy", nogil=True)

__all__ = [
    "JIT",
    "PHASE_ERROR",
    "STEP_LEVELS",
    "NEWTON_RTOL",
    "coefficients",
    "phi_damped",
    "phi",
    "mul2",
    "flight_bounds",
    "no_crossing",
    "newton_start",
    "gap",
    "refine_crossing",
]


@numba.njit(**JIT)
def coefficients(eta, zeta, a):
    """``(P, Q, w)``: particular solution ``P cos + Q sin`` and the damped frequency."""
    d = (1.0 - eta * eta) ** 2 + 4.0 * zeta * zeta * eta * eta
    return a * (1.0 - eta * eta) / d, 2.0 * zeta * eta * a / d, math.sqrt(1.0 - zeta * zeta)


@numba.njit(**JIT)
def phi_damped(tau, alpha, wd, c0):
    """The 2x2 flow of ``e'' + 2 alpha e' + c0 e = 0`` over ``tau`` in ``(e, e')``, underdamped
    (``wd = sqrt(c0 - alpha^2) > 0``); also the tangent flow."""
    e = math.exp(-alpha * tau)
    c, s = math.cos(wd * tau), math.sin(wd * tau)
    sw = s / wd
    return e * (c + alpha * sw), e * sw, -c0 * e * sw, e * (c - alpha * sw)


@numba.njit(**JIT)
def phi(tau, zeta, w):
    """The 2x2 flow of ``y'' + 2 zeta y' + y = 0`` over ``tau`` (also the tangent flow)."""
    return phi_damped(tau, zeta, w, 1.0)


@numba.njit(**JIT)
def mul2(a00, a01, a10, a11, b00, b01, b10, b11):
    """The 2x2 product ``A B`` (entries row by row)."""
    return (
        a00 * b00 + a01 * b10,
        a00 * b01 + a01 * b11,
        a10 * b00 + a11 * b10,
        a10 * b01 + a11 * b11,
    )


#: ``cos``/``sin(eta t)`` are evaluated at ``eta t`` rounded (relative error ``eps / 2``): an
#: absolute phase error ``eps eta |t| / 2`` and a gap error up to ``sqrt(P^2 + Q^2)`` times
#: that; bounded with a factor 8 to spare as ``PHASE_ERROR sqrt(P^2 + Q^2) eta |t|``.
PHASE_ERROR = 4.0 * 2.220446049250313e-16

#: Cached step sizes: ``h_max / 2^k``, ``k = 0..STEP_LEVELS - 1`` (halving and doubling stay
#: on them).
STEP_LEVELS = 40


@numba.njit(**JIT)
def no_crossing(g_lo, gp_lo, acc_lo, g_hi, gp_hi, h, J, J4, err, exact_start):
    """Proof that ``g = x - x_w`` stays below ``-err`` on ``(lo, lo + h]`` (no crossing).

    ``g_lo, gp_lo, acc_lo``: ``g, g', g''`` at ``lo``; ``g_hi, gp_hi`` at ``lo + h``; ``J``,
    ``J4`` bounds on ``|g'''|``, ``|g''''|`` over the flight; ``err`` the evaluation error of
    ``g``; ``exact_start``: ``g_lo`` is exact (the flight's start, on or below the wall).
    Proof 0 (moving away): ``g' <= g'(lo) + g''(lo) s + J s^2/2 < 0`` on the whole step (the
    bound is convex in ``s``: its ends suffice), so no upward crossing, wherever ``g`` is
    (a state a rounding error beyond the wall and moving away, left by an impact of the
    other oscillator of a coupled pair, is cleared here).
    Proof 1 (Taylor from lo): ``g(lo + s) <= q(s) = g + g' s + g'' s^2/2 + J s^3/6``, whose
    maximum on ``[0, h]`` is at an end or at the smaller root of ``q'`` (``q'`` is convex).
    Proof 2 (both ends): the cubic Hermite interpolant ``H`` of ``g, g'`` at ``lo`` and
    ``lo + h``, with ``|g - H| <= max|g''''| s^2 (h - s)^2 / 24 <= J4 h^4 / 384``.
    ``err`` bounds the evaluation error of ``g'`` as well (same scale).
    """
    if gp_lo < -err and gp_lo + h * (acc_lo + 0.5 * h * J) < -err:
        return True
    q_end = g_lo + h * (gp_lo + h * (0.5 * acc_lo + h * J / 6.0))
    q_max = q_end
    disc = acc_lo * acc_lo - 2.0 * J * gp_lo
    if disc >= 0.0 and J > 0.0:
        sm = (-acc_lo - math.sqrt(disc)) / J
        if 0.0 < sm < h:
            q_max = max(q_max, g_lo + sm * (gp_lo + sm * (0.5 * acc_lo + sm * J / 6.0)))
    start_ok = (g_lo < -err) or (exact_start and g_lo <= 0.0 and gp_lo < 0.0 and q_end < 0.0)
    if start_ok and q_max < -err:
        return True
    if not (g_lo < -err and g_hi < -err):
        return False
    c2, c3 = _hermite(g_lo, gp_lo, g_hi, gp_hi, h)
    h_max_val = max(g_lo, g_hi)
    # H'(s) = gp_lo + 2 c2 s + 3 c3 s^2 = 0
    if c3 != 0.0:
        d2 = c2 * c2 - 3.0 * c3 * gp_lo
        if d2 >= 0.0:
            r = math.sqrt(d2)
            for sc in ((-c2 - r) / (3.0 * c3), (-c2 + r) / (3.0 * c3)):
                if 0.0 < sc < h:
                    h_max_val = max(h_max_val, g_lo + sc * (gp_lo + sc * (c2 + sc * c3)))
    elif c2 != 0.0:
        sc = -gp_lo / (2.0 * c2)
        if 0.0 < sc < h:
            h_max_val = max(h_max_val, g_lo + sc * (gp_lo + sc * c2))
    return h_max_val + J4 * h * h * h * h / 384.0 < -err


@numba.njit(**JIT)
def _hermite(g_lo, gp_lo, g_hi, gp_hi, h):
    """``(c2, c3)`` of the cubic Hermite interpolant ``H(s) = g_lo + gp_lo s + c2 s^2 + c3 s^3``."""
    dg = (g_hi - g_lo) / h
    return (3.0 * dg - 2.0 * gp_lo - gp_hi) / h, (gp_lo + gp_hi - 2.0 * dg) / (h * h)


@numba.njit(**JIT)
def newton_start(g_lo, gp_lo, g_hi, gp_hi, h):
    """Offset in ``[0, h]`` of the root of the Hermite cubic of a bracketed crossing (a few
    Newton steps on the polynomial from the secant's root): the closed-form Newton's start."""
    c2, c3 = _hermite(g_lo, gp_lo, g_hi, gp_hi, h)
    sr = -g_lo / (g_hi - g_lo) * h
    for _ in range(4):
        hd = gp_lo + sr * (2.0 * c2 + 3.0 * sr * c3)
        if hd > 0.0:
            sr = min(max(sr - (g_lo + sr * (gp_lo + sr * (c2 + sr * c3))) / hd, 0.0), h)
    return sr


#: Newton on a crossing stops once its step, or the bracket, is below this times ``|t|``
#: (rounding level: stopping earlier, on Newton's own error bound, made the samples 5x less
#: accurate against mp:128 than heyoka float64; this way 0.75x).
NEWTON_RTOL = 4e-16


@numba.njit(**JIT)
def flight_bounds(y0, u0, zeta, w, eta, S):
    """``(A, M, J, J4)`` for the flight with homogeneous start ``(y0, u0)``: the amplitude of
    ``y`` and bounds of ``|x''|``, ``|x'''|``, ``|x''''|`` over the whole flight (the compiled
    :func:`precise_impact.core.flight.homogeneous_amplitudes` with ``c0 = 1``, where ``y`` and
    ``y'`` have the same amplitude; ``S = sqrt(P^2 + Q^2)`` bounds the steady state)."""
    ay = math.sqrt(y0 * y0 + ((u0 + zeta * y0) / w) ** 2)
    av = math.sqrt(u0 * u0 + ((y0 + zeta * u0) / w) ** 2)
    My = ay + 2.0 * zeta * av  # bound of |y''| on the whole flight
    Jy = 2.0 * zeta * My + av  # of the third derivative (y3 = -2 zeta y2 - y1)
    M = My + eta * eta * S  # of |x''|
    J = Jy + eta * eta * eta * S  # of the third derivative of x (x_p3 = -eta^2 x_p1)
    J4 = 2.0 * zeta * Jy + My + eta * eta * eta * eta * S  # of the fourth
    return ay, M, J, J4


@numba.njit(**JIT)
def gap(t, t0, eta, zeta, w, P, Q, y0, u0, xw, slave, al, wd, c0, e0, ep0):
    """``(g, g', g'', Phi)`` at ``t`` for the wall gap of a flight anchored at ``t0``: ``x - x_w``
    (the master, or the single oscillator; ``g''`` and ``Phi(t - t0)`` are the flight's), or
    with ``slave`` the slave's ``(x - x_w) + e`` (``e`` the pair's error, flowing by
    ``phi_damped(al, wd, c0)`` from ``(e0, e0')``)."""
    p00, p01, p10, p11 = phi(t - t0, zeta, w)
    c, s = math.cos(eta * t), math.sin(eta * t)
    xp = P * c + Q * s
    y, u = p00 * y0 + p01 * u0, p10 * y0 + p11 * u0
    g = xp + y - xw
    gp = eta * (Q * c - P * s) + u
    acc = -eta * eta * xp - 2.0 * zeta * u - y
    if slave:
        q00, q01, q10, q11 = phi_damped(t - t0, al, wd, c0)
        g += q00 * e0 + q01 * ep0
        gp += q10 * e0 + q11 * ep0
    return g, gp, acc, p00, p01, p10, p11


@numba.njit(**JIT)
def refine_crossing(
    lo, hi, g_lo, gp_lo, g_hi, gp_hi, t0, eta, zeta, w, P, Q, y0, u0, xw, slave, al, wd, c0, e0, ep0
):
    """The crossing in ``[lo, hi]`` (a sign change with ``g' > 0`` proven on the bracket: one
    root) by safeguarded Newton on the closed-form :func:`gap`, started at the Hermite cubic's
    root; the bracket shrinks with every evaluation and a step leaving it bisects.

    Returns ``(t, tc, g'(tc), g''(tc), Phi(tc - t0))``: the root and the last evaluation (the
    root is one Newton step, below rounding, from ``tc``: a caller corrects to first order)."""
    a_, b_ = lo, hi
    tr = lo + newton_start(g_lo, gp_lo, g_hi, gp_hi, hi - lo)
    tc, gp, acc, p00, p01, p10, p11 = tr, gp_lo, 0.0, 1.0, 0.0, 0.0, 1.0
    for _ in range(100):
        if not (a_ < tr < b_):
            tr = 0.5 * (a_ + b_)
        tc = tr
        g, gp, acc, p00, p01, p10, p11 = gap(
            tc, t0, eta, zeta, w, P, Q, y0, u0, xw, slave, al, wd, c0, e0, ep0
        )
        if g > 0.0:
            b_ = tc
        else:
            a_ = tc
        tn = tc - g / gp
        if abs(tn - tc) <= NEWTON_RTOL * abs(tc) or b_ - a_ <= NEWTON_RTOL * abs(tc):
            if a_ <= tn <= b_:
                tr = tn
            break
        tr = tn
    return tr, tc, gp, acc, p00, p01, p10, p11
