"""The forcing clock: sample times and the local (periodic) clock, each rounded once.

Times are computed from exact rationals and ``pi`` with guard bits and rounded once to the
working precision, so no ``k eps`` drift accumulates; the local clock keeps ``|t|`` small in
long Lyapunov runs.
"""

from __future__ import annotations

import math
from fractions import Fraction
from typing import Any

import mpmath
from mpmath import libmp

from precise_impact.core.mpcontext import mp_context

__all__ = ["sample_times", "local_clock", "local_grid", "period_float", "GUARD_BITS"]

#: Guard bits carried above the working precision before the one rounding.
GUARD_BITS = 64


def _mpq(q: Fraction, ctx: Any) -> Any:
    return ctx.mpf(q.numerator) / q.denominator


def _man_exp(m: mpmath.mpf) -> tuple[int, int]:
    sign, man, exp, _ = m._mpf_
    return (-man if sign else man), exp


def sample_times(
    precision: Any, t0: Fraction, eta: Fraction, periods: int, per_period: int = 1
) -> list:
    """Times ``t0 + j T / per_period``, ``T = 2 pi / eta``, ``j = 0 .. periods * per_period``.

    Parameters
    ----------
    precision : Precision
        The working precision (every time is one of its numbers).
    t0 : Fraction
        Start time (exact).
    eta : Fraction
        Forcing frequency (exact, > 0).
    periods : int
        Forcing periods.
    per_period : int, default 1
        Output times per period.

    Returns
    -------
    list
        ``periods * per_period + 1`` numbers of ``precision``.

    Notes
    -----
    Each time is computed with ``GUARD_BITS`` (64) guard bits plus the bits of the
    largest index and rounded once to ``precision``, so sample times carry no
    accumulated ``k eps`` drift.  In float64 the same values come without an mpmath
    operation per sample: with ``t0 = m0 2^e0`` and ``step = ms 2^es`` (both exact at
    the working precision), ``t0 + j step = (A + j B) 2^E`` exactly in integers, and
    ``float(int)`` rounds once, to nearest (Python's int -> float conversion is
    correctly rounded); ``ldexp`` by a power of two is exact.
    """
    n = periods * per_period
    guard = GUARD_BITS + max(n, 1).bit_length()
    ctx = mp_context(precision.bits + guard)  # thread-safe: not mpmath's global precision
    step = 2 * ctx.pi / _mpq(eta, ctx) / per_period
    t0m = _mpq(t0, ctx)
    if precision.kind != "float64":
        return [precision.from_mpf(t0m + j * step) for j in range(n + 1)]
    (m0, e0), (ms, es) = _man_exp(t0m), _man_exp(step)
    E = min(e0, es)
    A, B = m0 << (e0 - E), ms << (es - E)
    return [math.ldexp(float(A + j * B), E) for j in range(n + 1)]


def _period_and_start(t0: Fraction, eta: Fraction, ctx: Any) -> tuple[mpmath.mpf, mpmath.mpf]:
    """``T = 2 pi / eta`` and ``s0 = t0 mod T`` in ``ctx`` (at the caller's guard bits)."""
    T = 2 * ctx.pi / _mpq(eta, ctx)
    t0m = _mpq(t0, ctx)
    return T, t0m - ctx.floor(t0m / T) * T


def local_clock(
    precision: Any, t0: Fraction, eta: Fraction, window: Fraction = Fraction(0)
) -> tuple[Any, Any, Any]:
    """One forcing period ``[L0, L1]`` of the local clock, and ``window * T``.

    Parameters
    ----------
    precision : Precision
        The working precision of the three results.
    t0 : Fraction
        Start time (exact).
    eta : Fraction
        Forcing frequency (exact, > 0).
    window : Fraction, default 0
        A fraction of the period returned as the third value (the two-trajectory
        method's synchronisation window is ``T/8``).

    Returns
    -------
    L0, L1, W
        Numbers of ``precision``.

    Notes
    -----
    ``t0`` is reduced modulo ``T = 2 pi / eta`` exactly (in mpmath with
    ``GUARD_BITS`` plus the bits of ``|t0|`` and ``eta``), ``s0 = t0 - floor(t0/T) T``;
    then ``L0 = fl(s0)``, ``L1 = fl(s0 + T)`` and ``W = fl(window T)``, each rounded once.
    """
    extra = GUARD_BITS + abs(t0).__ceil__().bit_length() + abs(eta).__ceil__().bit_length()
    T, s0 = _period_and_start(t0, eta, mp_context(precision.bits + extra))
    w = T * window.numerator / window.denominator
    return precision.from_mpf(s0), precision.from_mpf(s0 + T), precision.from_mpf(w)


def local_grid(
    precision: Any, t0: Fraction, eta: Fraction, periods: int, substeps: int = 1
) -> list:
    """``periods + 1`` times ``fl(s0 + k T)``, ``k = 0..periods``, of the local clock
    (with ``substeps = m > 1``: the ``m periods + 1`` times ``fl(s0 + k T / m)``).

    Parameters
    ----------
    precision : Precision
        The working precision of the times.
    t0 : Fraction
        Start time (exact); ``s0 = t0 mod T`` as in :func:`local_clock`.
    eta : Fraction
        Forcing frequency (exact, > 0).
    periods : int
        Forcing periods the grid spans (``>= 1``).
    substeps : int, default 1
        Equal steps per period (``>= 1``); every ``m``-th time is a period boundary.

    Returns
    -------
    list
        Numbers of ``precision``, each rounded once; ``[0]`` and ``[1]`` are
        :func:`local_clock`'s ``L0`` and ``L1``.  An integration over the whole grid
        sets its clock back to ``[0]`` afterwards (the forcing is ``T``-periodic), so
        ``|t|`` stays below ``(periods + 1) T``.
    """
    extra = (
        GUARD_BITS
        + abs(t0).__ceil__().bit_length()
        + abs(eta).__ceil__().bit_length()
        + periods.bit_length()
        + (substeps.bit_length() if substeps > 1 else 0)
    )
    T, s0 = _period_and_start(t0, eta, mp_context(precision.bits + extra))
    if substeps == 1:
        return [precision.from_mpf(s0 + k * T) for k in range(periods + 1)]
    return [precision.from_mpf(s0 + k * T / substeps) for k in range(periods * substeps + 1)]


def period_float(eta: Fraction) -> float:
    """``T = 2 pi / eta`` as a Python float (computed at 30 digits, rounded once).

    Parameters
    ----------
    eta : Fraction
        Forcing frequency (exact, > 0).

    Returns
    -------
    float
    """
    ctx = mp_context(libmp.dps_to_prec(30))
    return float(2 * ctx.pi / _mpq(eta, ctx))
