"""The master-slave pair on the compiled closed-form engine (float64, numba).

The slave is the master plus the closed-form difference ``e = y - x``; both walls are searched
with the single engine's proofs (``docs/numerics.rst``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from precise_impact.solvers.fast.crossing import (
    JIT,
    PHASE_ERROR,
    coefficients,
    flight_bounds,
    no_crossing,
    phi,
    phi_damped,
    refine_crossing,
)
from precise_impact.solvers.fast.single import (
    STATUS_BUDGET,
    STATUS_CONTACT,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_SLOW_IMPACT,
    sample_time,
)

__all__ = ["FORM_IDS", "error_coefficients", "coupled_strobe", "STATUS_UNSUPPORTED"]

#: The forms the engine knows, by number (the compiled code's ``form`` argument).
FORM_IDS = {"first-order": 0, "paper": 1, "reduced": 2}

#: ``e'' + c1 e' + c0 e = 0`` is not underdamped (``c0 <= c1^2 / 4``): heyoka's job.
STATUS_UNSUPPORTED = 5


def error_coefficients(form: str, zeta: float, k: float) -> tuple[float, float]:
    """``(c1, c0)`` of ``e'' + c1 e' + c0 e = 0`` for ``form`` (module docstring).

    Parameters
    ----------
    form : str
        ``'first-order'``, ``'paper'`` or ``'reduced'``.
    zeta, k : float
        Damping ratio and coupling.

    Returns
    -------
    tuple of float
    """
    if form == "paper":
        return 2 * zeta + k * (1 + 2 * zeta), 1 + 2 * k
    return 2 * zeta + 2 * k, 1 + 2 * zeta * k + k * k


@numba.njit(**JIT)
def _slave_w(form, k, e, yd):
    """The slave's velocity variable from ``e = y - x`` and ``y'``."""
    return yd + k * e if form == 0 else yd


@numba.njit(**JIT)
def _slave_yd(form, k, e, w_):
    """``y'`` from ``e = y - x`` and the slave's velocity variable."""
    return w_ - k * e if form == 0 else w_


@numba.njit(**JIT)
def _slave_reset(form, R, k, x, xw, w_):
    """:func:`~precise_impact.solvers.heyoka.coupled.slave_reset` (compiled copy)."""
    if form == 2:
        shift = k * (x - xw)
        return -R * (w_ - shift) + shift
    return -R * w_


@numba.njit(**JIT)
def _state(tau, t, eta, zeta, w, P, Q, y0, u0, al, wd, c0, e0, ep0):
    """``x, v, e, e'`` at ``t`` (``tau = t - anchor``) from the anchor's homogeneous states."""
    p00, p01, p10, p11 = phi(tau, zeta, w)
    c, s = math.cos(eta * t), math.sin(eta * t)
    x = P * c + Q * s + p00 * y0 + p01 * u0
    v = eta * (Q * c - P * s) + p10 * y0 + p11 * u0
    q00, q01, q10, q11 = phi_damped(tau, al, wd, c0)
    return x, v, q00 * e0 + q01 * ep0, q10 * e0 + q11 * ep0, c


@numba.njit(**JIT)
def _cflight(
    t0, x0, v0, e0, ep0, t1, eta, zeta, a, xw, P, Q, w, S, al, wd, c0, err_scale, h_max, touch
):
    """The pair from the anchor ``(x0, v0, e0, e'0)`` at ``t0`` to the first impact in
    ``(t0, t1]`` or to ``t1``.  Returns ``(status, hit, t, x, v, e, e')``: ``hit`` 0 (none:
    the state at ``t1``), 1 master, 2 slave, 3 both; the state just before the impact."""
    cl, sl = math.cos(eta * t0), math.sin(eta * t0)
    y0, u0 = x0 - (P * cl + Q * sl), v0 - eta * (Q * cl - P * sl)
    ay, M, J, J4 = flight_bounds(y0, u0, zeta, w, eta, S)
    Ae = math.sqrt(e0 * e0 + ((ep0 + al * e0) / wd) ** 2)  # amplitude of e (decays)
    Ms, Js, J4s = M + Ae * c0, J + Ae * c0 * math.sqrt(c0), J4 + Ae * c0 * c0
    # evaluation errors of the gaps: the terms and the rounded forcing phase (eps eta |t|)
    t_far = max(abs(t0), abs(t1))
    err_m = err_scale * (abs(xw) + S + ay + 1.0) + PHASE_ERROR * S * eta * t_far
    err_s = err_m + err_scale * Ae
    h_min = 64.0 * 2.220446049250313e-16 * max(1.0, abs(t1))
    lo = t0
    x, v, e, ep = x0, v0, e0, ep0
    acc = a * cl - 2.0 * zeta * v0 - x0
    exact_start = True
    h = min(h_max, t1 - t0)
    while lo < t1:
        hi = lo + h
        if hi > t1:
            hi = t1
            h = t1 - lo
        xh, vh, eh, eph, ch = _state(hi - t0, hi, eta, zeta, w, P, Q, y0, u0, al, wd, c0, e0, ep0)
        acc_s = acc + (-2.0 * al * ep - c0 * e)
        # the slave's gap as (x - x_w) + e: zero exactly right after a slave impact
        # (e = x_w - x there, and fl(x - x_w) = -fl(x_w - x))
        gm_lo, gm_hi = x - xw, xh - xw
        gs_lo, gs_hi = gm_lo + e, gm_hi + eh
        pm = no_crossing(gm_lo, v, acc, gm_hi, vh, h, J, J4, err_m, exact_start)
        ps = no_crossing(gs_lo, v + ep, acc_s, gs_hi, vh + eph, h, Js, J4s, err_s, exact_start)
        if pm and ps:
            lo, x, v, e, ep = hi, xh, vh, eh, eph
            acc = a * ch - 2.0 * zeta * v - x
            exact_start = False
            h = min(2.0 * h, h_max)
            continue
        bm = not pm and gm_hi > err_m and v - M * h > 0.0 and gm_lo < 0.0
        bs = not ps and gs_hi > err_s and v + ep - Ms * h > 0.0 and gs_lo < 0.0
        if (pm or bm) and (ps or bs):
            tc = math.inf
            hit = 0
            for which in (1, 2):
                if (which == 1 and not bm) or (which == 2 and not bs):
                    continue
                if which == 1:
                    g_lo, gp_lo, g_hi, gp_hi = gm_lo, v, gm_hi, vh
                else:
                    g_lo, gp_lo, g_hi, gp_hi = gs_lo, v + ep, gs_hi, vh + eph
                tr = refine_crossing(
                    lo,
                    hi,
                    g_lo,
                    gp_lo,
                    g_hi,
                    gp_hi,
                    t0,
                    eta,
                    zeta,
                    w,
                    P,
                    Q,
                    y0,
                    u0,
                    xw,
                    which == 2,
                    al,
                    wd,
                    c0,
                    e0,
                    ep0,
                )[0]
                if tr < tc:
                    tc, hit = tr, which
            xc, vc, ec, epc, _c = _state(
                tc - t0, tc, eta, zeta, w, P, Q, y0, u0, al, wd, c0, e0, ep0
            )
            # the other oscillator at the wall (within a few ulps, or within the evaluation
            # error of its gap: at t ~ 500 the rounded forcing phase alone gives 1e-13) and
            # moving into it: both
            if hit == 1 and (xc - xw) + ec >= -max(touch, err_s) and vc + epc > 0.0:
                hit = 3
            elif hit == 2 and xc - xw >= -max(touch, err_m) and vc > 0.0:
                hit = 3
            return STATUS_OK, hit, tc, xc, vc, ec, epc
        if h <= h_min or lo + 0.5 * h <= lo:
            if not (np.isfinite(gm_hi) and np.isfinite(gs_hi)):
                return STATUS_NONFINITE, 0, lo, x, v, e, ep
            return STATUS_CONTACT, 0, lo, x, v, e, ep
        h = 0.5 * h
    return STATUS_OK, 0, lo, x, v, e, ep


@numba.njit(**JIT)
def coupled_strobe(
    eta,
    zeta,
    a,
    xw,
    R,
    k,
    form,
    c1,
    c0,
    t0,
    x0,
    v0,
    y0,
    w0,
    n,
    step,
    max_impacts,
    xs,
    vs,
    ys,
    ws,
    ts,
    m_imp,
    s_imp,
):
    """Samples at ``t0 + k (2 pi / eta) / step`` (``k = 0..n``) of the pair, and every impact.

    ``xs, vs, ys, ws, ts`` (length ``n + 1``) are filled; ``m_imp`` rows ``(t, v-, v+)`` and
    ``s_imp`` rows ``(t, w-, w+, x)`` up to their capacity.  Returns ``(status, master
    impacts, slave impacts, simultaneous, samples done)``; an impact count above a
    capacity means the caller retries with more.
    """
    al = 0.5 * c1
    if not c0 > al * al or not 0.0 <= zeta < 1.0:
        return STATUS_UNSUPPORTED, 0, 0, 0, 0
    wd = math.sqrt(c0 - al * al)
    P, Q, w = coefficients(eta, zeta, a)
    S = math.sqrt(P * P + Q * Q)
    err_scale = 64.0 * 2.220446049250313e-16
    h_max = 0.25 * min(2.0 * math.pi / eta, 2.0 * math.pi / max(1.0, math.sqrt(c0)))
    v_floor = 1e-9 * max(1.0, abs(a), abs(xw))
    touch = 64.0 * 2.220446049250313e-16 * (1.0 + abs(xw))
    T = 2.0 * math.pi / eta
    t, x, v = t0, x0, v0
    e, ep = y0 - x0, _slave_yd(form, k, y0 - x0, w0) - v0
    xs[0], vs[0], ys[0], ws[0], ts[0] = x0, v0, y0, w0, t0
    nm = ns = nb = 0
    cap_m, cap_s = m_imp.shape[0], s_imp.shape[0]
    for kk in range(1, n + 1):
        t1 = sample_time(t0, T, step, kk)
        while True:
            st, hit, tc, xc, vc, ec, epc = _cflight(
                t,
                x,
                v,
                e,
                ep,
                t1,
                eta,
                zeta,
                a,
                xw,
                P,
                Q,
                w,
                S,
                al,
                wd,
                c0,
                err_scale,
                h_max,
                touch,
            )
            if st != STATUS_OK:
                return st, nm, ns, nb, kk - 1
            if hit == 0:
                t, x, v, e, ep = t1, xc, vc, ec, epc
                break
            yd = vc + epc
            if hit & 1:  # the master first (the slave's reduced rule sees x = x_w)
                if vc < v_floor:
                    return STATUS_SLOW_IMPACT, nm, ns, nb, kk - 1
                va = -R * vc
                if nm < cap_m:
                    m_imp[nm, 0], m_imp[nm, 1], m_imp[nm, 2] = tc, vc, va
                nm += 1
                ec = (xc - xw) + ec  # the slave's position is continuous; x becomes x_w exactly
                xc, vc = xw, va
            if hit & 2:
                if yd < v_floor:
                    return STATUS_SLOW_IMPACT, nm, ns, nb, kk - 1
                ec = xw - xc
                wb = _slave_w(form, k, ec, yd)
                wa = _slave_reset(form, R, k, xc, xw, wb)
                if ns < cap_s:
                    s_imp[ns, 0], s_imp[ns, 1], s_imp[ns, 2], s_imp[ns, 3] = tc, wb, wa, xc
                ns += 1
                yd = _slave_yd(form, k, ec, wa)
            if hit == 3:
                nb += 1
            if nm + ns >= max_impacts:
                return STATUS_BUDGET, nm, ns, nb, kk - 1
            t, x, v, e, ep = tc, xc, vc, ec, yd - vc
            if tc >= t1:
                break
        y = x + e
        xs[kk], vs[kk], ys[kk], ws[kk], ts[kk] = x, v, y, _slave_w(form, k, e, v + ep), t1
    return STATUS_OK, nm, ns, nb, n
