"""Double-double arithmetic (numba) and the flight's wall gap in it: the fast engine's refinement.

``hi + lo`` of two float64 (``|lo| <= ulp(hi) / 2``): ~106 bits from float64 operations, so the
kernel decides a near-tangential contact float64 cannot; :func:`gap_dd` is the compiled copy
of :class:`precise_impact.core.flight.Flight` (pinned to mpmath by
``tests/solvers/test_fast_refined.py``); ``docs/numerics.rst``, "Refined flights".
References: T. J. Dekker, Numer. Math. 18 (1971) 224-242; Y. Hida, X. S. Li, D. H. Bailey,
*Library for double-double and quad-double arithmetic* (QD, 2001).
"""

from __future__ import annotations

import math
from fractions import Fraction

import numba
import numpy as np

from precise_impact.core.mpcontext import mp_context
from precise_impact.solvers.fast.crossing import JIT

__all__ = [
    "DD_EPS",
    "two_sum",
    "two_prod",
    "dd_add",
    "dd_mul",
    "dd_div",
    "dd_sqrt",
    "dd_exp",
    "dd_cos_sin",
    "dd_setup",
    "dd_period",
    "gap_dd",
]

#: The unit roundoff of double-double arithmetic, ``2^-104`` (Hida, Li & Bailey).
DD_EPS = 2.0**-104
_SPLIT = 134217729.0  # 2^27 + 1 (Dekker)


def _split_constant(value: Fraction, parts: int) -> np.ndarray:
    """``value`` as ``parts`` non-overlapping float64 (each the rounded remainder)."""
    out = np.empty(parts)
    rest = value
    for i in range(parts):
        out[i] = float(rest)
        rest -= Fraction(out[i])
    return out


def _exact(z) -> Fraction:
    """An mpmath number as the Fraction of its value (exact)."""
    man, exp = z.man, z.exp
    return Fraction(man) * Fraction(2) ** exp


_CTX = mp_context(320)
#: pi/2 in three float64 (Cody-Waite reduction exact to ~1e-48 for the arguments used here)
_PIO2 = _split_constant(_exact(_CTX.pi / 2), 3)
_LN2 = _split_constant(_exact(_CTX.log(2)), 2)
#: 1/n! as double-doubles, n = 0..29 (the Taylor coefficients of exp, cos and sin)
_INV_FACT = np.array([_split_constant(Fraction(1, math.factorial(n)), 2) for n in range(30)])


# ------------------------------------------------------------------------ error-free transforms
@numba.njit(**JIT)
def two_sum(a, b):
    """``(s, e)`` with ``s = fl(a + b)`` and ``a + b = s + e`` exactly (Knuth)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@numba.njit(**JIT)
def _quick_two_sum(a, b):
    s = a + b
    return s, b - (s - a)


@numba.njit(**JIT)
def two_prod(a, b):
    """``(p, e)`` with ``p = fl(a b)`` and ``a b = p + e`` exactly (Dekker's splitting)."""
    p = a * b
    t = _SPLIT * a
    ah = t - (t - a)
    al = a - ah
    t = _SPLIT * b
    bh = t - (t - b)
    bl = b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


# ------------------------------------------------------------------------------- arithmetic
@numba.njit(**JIT)
def dd_add(ah, al, bh, bl):
    """``a + b`` (the accurate addition of QD)."""
    s, e = two_sum(ah, bh)
    t, f = two_sum(al, bl)
    e += t
    s, e = _quick_two_sum(s, e)
    e += f
    return _quick_two_sum(s, e)


@numba.njit(**JIT)
def dd_mul(ah, al, bh, bl):
    """``a b``."""
    p, e = two_prod(ah, bh)
    e += ah * bl + al * bh
    return _quick_two_sum(p, e)


@numba.njit(**JIT)
def dd_div(ah, al, bh, bl):
    """``a / b`` (long division: three quotient digits)."""
    q1 = ah / bh
    ph, pl = dd_mul(q1, 0.0, bh, bl)
    rh, rl = dd_add(ah, al, -ph, -pl)
    q2 = rh / bh
    ph, pl = dd_mul(q2, 0.0, bh, bl)
    rh, rl = dd_add(rh, rl, -ph, -pl)
    q3 = rh / bh
    qh, ql = _quick_two_sum(q1, q2)
    return dd_add(qh, ql, q3, 0.0)


@numba.njit(**JIT)
def dd_sqrt(ah, al):
    """``sqrt(a)``, ``a > 0`` (one Newton step from the float64 root)."""
    s = math.sqrt(ah)
    ph, pl = two_prod(s, s)
    rh, rl = dd_add(ah, al, -ph, -pl)
    return _quick_two_sum(s, rh / (2.0 * s))


@numba.njit(**JIT)
def _poly(xh, xl, n0, n, step):
    """``sum_k c_k x^k`` with ``c_k = 1/(n0 + step k)!`` for ``k = 0..n-1`` (Horner)."""
    rh, rl = _INV_FACT[n0 + step * (n - 1), 0], _INV_FACT[n0 + step * (n - 1), 1]
    for k in range(n - 2, -1, -1):
        rh, rl = dd_mul(rh, rl, xh, xl)
        rh, rl = dd_add(rh, rl, _INV_FACT[n0 + step * k, 0], _INV_FACT[n0 + step * k, 1])
    return rh, rl


@numba.njit(**JIT)
def dd_exp(ah, al):
    """``exp(a)`` for ``|a| < 700``: ``a = k ln 2 + r``, ``exp(r / 512)`` by Taylor (``|r| /
    512 < 7e-4``: 11 terms reach ``1e-37``), squared nine times, scaled by ``2^k``."""
    k = math.floor(ah / _LN2[0] + 0.5)
    p1, e1 = two_prod(k, _LN2[0])
    rh, rl = dd_add(ah, al, -p1, -e1)
    rh, rl = dd_add(rh, rl, -k * _LN2[1], 0.0)
    rh, rl = rh / 512.0, rl / 512.0
    # s = exp(r) - 1 = r (1 + r/2! + r^2/3! + ...), kept as s so the squarings keep its digits
    ph, pl = _poly(rh, rl, 1, 11, 1)
    sh, sl = dd_mul(ph, pl, rh, rl)
    for _ in range(9):  # (1 + s)^2 = 1 + (2 s + s^2)
        qh, ql = dd_mul(sh, sl, sh, sl)
        sh, sl = dd_add(2.0 * sh, 2.0 * sl, qh, ql)
    eh, el = dd_add(1.0, 0.0, sh, sl)
    return math.ldexp(eh, int(k)), math.ldexp(el, int(k))


@numba.njit(**JIT)
def dd_cos_sin(ah, al):
    """``(cos a, sin a)`` as double-doubles for ``|a| < 1e5``: ``a = k pi/2 + r`` (pi/2 in
    three parts), then Taylor on ``|r| <= pi/4`` (14 terms: ``(pi/4)^28 / 28! < 1e-31``)."""
    k = math.floor(ah / _PIO2[0] + 0.5)
    p1, e1 = two_prod(k, _PIO2[0])
    p2, e2 = two_prod(k, _PIO2[1])
    rh, rl = dd_add(ah, al, -p1, -e1)
    rh, rl = dd_add(rh, rl, -p2, -e2)
    rh, rl = dd_add(rh, rl, -k * _PIO2[2], 0.0)
    xh, xl = dd_mul(rh, rl, rh, rl)
    xh, xl = -xh, -xl  # -r^2: cos = sum (-r^2)^k / (2k)!, sin = r sum (-r^2)^k / (2k+1)!
    ch, cl = _poly(xh, xl, 0, 14, 2)
    sh, sl = _poly(xh, xl, 1, 14, 2)
    sh, sl = dd_mul(sh, sl, rh, rl)
    q = int(k) % 4
    if q == 0:
        return ch, cl, sh, sl
    if q == 1:
        return -sh, -sl, ch, cl
    if q == 2:
        return -ch, -cl, -sh, -sl
    return sh, sl, -ch, -cl


@numba.njit(**JIT)
def dd_period(eta):
    """The forcing period ``2 pi / eta`` as ``(T, T_lo)``: ``T`` the float64 nearest it and
    ``T_lo`` the rest (the kernels' local clock moves whole periods by both)."""
    return dd_div(4.0 * _PIO2[0], 4.0 * _PIO2[1], eta, 0.0)


# ------------------------------------------------------------------------- the flight's gap
@numba.njit(**JIT)
def dd_setup(t0, x0, v0, eta, zeta, a):
    """The flight from ``(x0, v0)`` at ``t0`` in double-double: ``(Ph, Pl, Qh, Ql, wh, wl, yh,
    yl, uh, ul)``, the steady state's coefficients (core.flight.steady_coefficients), the damped
    frequency ``sqrt(1 - zeta^2)`` and the homogeneous start ``(y0, u0)``
    (core.flight.homogeneous_start); the inputs are float64 taken as exact."""
    mh, ml = dd_add(1.0, 0.0, *two_prod(-eta, eta))  # 1 - eta^2
    nh, nl = two_prod(2.0 * zeta, eta)  # 2 zeta eta (2 zeta exact)
    dh, dl = dd_add(*dd_mul(mh, ml, mh, ml), *dd_mul(nh, nl, nh, nl))
    Ph, Pl = dd_div(*dd_mul(a, 0.0, mh, ml), dh, dl)
    Qh, Ql = dd_div(*dd_mul(a, 0.0, nh, nl), dh, dl)
    wh, wl = dd_sqrt(*dd_add(1.0, 0.0, *two_prod(-zeta, zeta)))
    ch, cl, sh, sl = dd_cos_sin(*two_prod(eta, t0))
    xph, xpl = dd_add(*dd_mul(Ph, Pl, ch, cl), *dd_mul(Qh, Ql, sh, sl))
    vph, vpl = dd_add(*dd_mul(Qh, Ql, ch, cl), *dd_mul(-Ph, -Pl, sh, sl))
    vph, vpl = dd_mul(eta, 0.0, vph, vpl)
    yh, yl = dd_add(x0, 0.0, -xph, -xpl)
    uh, ul = dd_add(v0, 0.0, -vph, -vpl)
    return Ph, Pl, Qh, Ql, wh, wl, yh, yl, uh, ul


@numba.njit(**JIT)
def gap_dd(t, t0, eta, zeta, xw, Ph, Pl, Qh, Ql, wh, wl, yh, yl, uh, ul):
    """``(g, g', g'')`` at ``t`` of the flight :func:`dd_setup` made (``g = x - x_w``), each as
    ``(hi, lo)``: the double-double twin of :func:`precise_impact.solvers.fast.crossing.gap`."""
    th, tl = two_sum(t, -t0)  # tau exactly
    eh, el = dd_exp(*dd_mul(-zeta, 0.0, th, tl))
    ch, cl, sh, sl = dd_cos_sin(*dd_mul(wh, wl, th, tl))
    swh, swl = dd_div(sh, sl, wh, wl)  # sin / w
    zsh, zsl = dd_mul(zeta, 0.0, swh, swl)
    p00h, p00l = dd_mul(eh, el, *dd_add(ch, cl, zsh, zsl))
    p01h, p01l = dd_mul(eh, el, swh, swl)
    p11h, p11l = dd_mul(eh, el, *dd_add(ch, cl, -zsh, -zsl))
    # y = p00 y0 + p01 u0, u = p10 y0 + p11 u0 with p10 = -p01
    ynh, ynl = dd_add(*dd_mul(p00h, p00l, yh, yl), *dd_mul(p01h, p01l, uh, ul))
    unh, unl = dd_add(*dd_mul(-p01h, -p01l, yh, yl), *dd_mul(p11h, p11l, uh, ul))
    fch, fcl, fsh, fsl = dd_cos_sin(*two_prod(eta, t))
    xph, xpl = dd_add(*dd_mul(Ph, Pl, fch, fcl), *dd_mul(Qh, Ql, fsh, fsl))
    vph, vpl = dd_add(*dd_mul(Qh, Ql, fch, fcl), *dd_mul(-Ph, -Pl, fsh, fsl))
    vph, vpl = dd_mul(eta, 0.0, vph, vpl)
    gh, gl = dd_add(*dd_add(xph, xpl, ynh, ynl), -xw, 0.0)
    gph, gpl = dd_add(vph, vpl, unh, unl)
    # g'' = -eta^2 x_p - 2 zeta u - y
    e2h, e2l = two_prod(eta, eta)
    ah, al = dd_mul(-e2h, -e2l, xph, xpl)
    ah, al = dd_add(ah, al, *dd_mul(-2.0 * zeta, 0.0, unh, unl))
    ah, al = dd_add(ah, al, -ynh, -ynl)
    return gh, gl, gph, gpl, ah, al
