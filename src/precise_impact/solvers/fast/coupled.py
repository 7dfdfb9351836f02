"""The master-slave pair on the compiled closed-form engine (float64, numba).

The slave is the master plus the closed-form difference ``e = y - x``; both walls are searched
with the single engine's proofs (``docs/numerics.rst``).
"""

from __future__ import annotations

import math
import time as _time
from typing import Any

import numba
import numpy as np

from precise_impact.core.coupling import FORM_IDS, error_coefficients
from precise_impact.core.params import Params
from precise_impact.core.precision import Precision
from precise_impact.errors import BudgetExceededError
from precise_impact.solvers.base import Unresolved, note_fallback, with_fallback
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
from precise_impact.solvers.fast.dd import dd_period
from precise_impact.solvers.fast.single import (
    STATUS_BUDGET,
    STATUS_CONTACT,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_SLOW_IMPACT,
    STATUS_TEXT,
    sample_time,
)
from precise_impact.solvers.heyoka.coupled import (
    CoupledTrajectory,
    HeyokaCoupledSolver,
    check_inputs,
    check_max_impacts,
    coupled_start,
)

__all__ = [
    "FastCoupledSolver",
    "FORM_IDS",
    "error_coefficients",
    "coupled_strobe",
    "compiled_slave_velocity",
    "compiled_slave_derivative",
    "compiled_slave_reset",
    "STATUS_UNSUPPORTED",
]

#: ``e'' + c1 e' + c0 e = 0`` is not underdamped (``c0 <= c1^2 / 4``): heyoka's job.
STATUS_UNSUPPORTED = 5


@numba.njit(**JIT)
def compiled_slave_velocity(form, k, e, yd):
    """:func:`~precise_impact.core.coupling.slave_velocity` (compiled copy, ``form`` a
    :data:`~precise_impact.core.coupling.FORM_IDS` number)."""
    return yd + k * e if form == 0 else yd


@numba.njit(**JIT)
def compiled_slave_derivative(form, k, e, w_):
    """:func:`~precise_impact.core.coupling.slave_derivative` (compiled copy)."""
    return w_ - k * e if form == 0 else w_


@numba.njit(**JIT)
def compiled_slave_reset(form, R, k, x, xw, w_):
    """:func:`~precise_impact.core.coupling.slave_reset` (compiled copy)."""
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


# long: one compiled loop (numba): the step-halving search carries its bracket, proof bounds
# and status in locals across iterations; split into calls it would pass ~15 values per step.
@numba.njit(**JIT)
def _cflight(  # numba kernel: one compiled loop (over the AST measure only; ruff: clean)
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


# long: one compiled loop (numba) over periods and both oscillators' impacts, carrying the
# pair's state and the sample arrays in locals; the flight itself is _cflight.
@numba.njit(**JIT)
def coupled_strobe(  # numba kernel: one compiled loop (over the AST measure only; ruff: clean)
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
    T, T_lo = dd_period(eta)
    t, x, v = t0, x0, v0
    e, ep = y0 - x0, compiled_slave_derivative(form, k, y0 - x0, w0) - v0
    xs[0], vs[0], ys[0], ws[0], ts[0] = x0, v0, y0, w0, t0
    nm = ns = nb = 0
    cap_m, cap_s = m_imp.shape[0], s_imp.shape[0]
    for kk in range(1, n + 1):
        t1 = sample_time(t0, T, T_lo, step, kk)
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
                wb = compiled_slave_velocity(form, k, ec, yd)
                wa = compiled_slave_reset(form, R, k, xc, xw, wb)
                if ns < cap_s:
                    s_imp[ns, 0], s_imp[ns, 1], s_imp[ns, 2], s_imp[ns, 3] = tc, wb, wa, xc
                ns += 1
                yd = compiled_slave_derivative(form, k, ec, wa)
            if hit == 3:
                nb += 1
            if nm + ns >= max_impacts:
                return STATUS_BUDGET, nm, ns, nb, kk - 1
            t, x, v, e, ep = tc, xc, vc, ec, yd - vc
            if tc >= t1:
                break
        y = x + e
        xs[kk], vs[kk], ys[kk], ws[kk], ts[kk] = (
            x,
            v,
            y,
            compiled_slave_velocity(form, k, e, v + ep),
            t1,
        )
    return STATUS_OK, nm, ns, nb, n


class FastCoupledSolver:
    """The pair on the compiled closed forms (coupled model ``'fast'``, float64).

    Parameters
    ----------
    max_impacts : int, default ``10**7``
        Budget over both oscillators.
    fallback : bool, default ``True``
        A run the engine does not resolve (a tangential contact, chattering, an error
        equation that is not underdamped) is integrated by
        :class:`~precise_impact.solvers.heyoka.coupled.HeyokaCoupledSolver` and
        ``stats['engine']`` says so; ``False`` raises
        :class:`~precise_impact.solvers.base.Unresolved` (an ``IntegrationError``) instead.
    """

    model_name = "fast"

    def __init__(self, max_impacts: int = 10**7, fallback: bool = True) -> None:
        self.max_impacts = check_max_impacts(max_impacts)
        self.fallback = bool(fallback)
        self.precision = Precision.parse("float64")

    def solve(
        self,
        params: Params,
        k: Any,
        periods: int,
        *,
        form: str = "first-order",
        y0: Any = None,
        per_period: int = 0,
    ) -> CoupledTrajectory:
        """The pair for ``periods`` forcing periods (:func:`~precise_impact.simulate_coupled`)."""
        heyoka = HeyokaCoupledSolver(self.precision, self.max_impacts).solve
        run = with_fallback(self._solve, heyoka if self.fallback else None, note_fallback("heyoka"))
        return run(params, k, periods, form=form, y0=y0, per_period=per_period)

    def _solve(
        self, params: Params, k: Any, periods: int, *, form: str, y0: Any, per_period: int
    ) -> CoupledTrajectory:
        kq, form, periods, per_period, y0q = check_inputs(params, k, form, periods, per_period, y0)
        start_state, m0, s0 = coupled_start(params, kq, form, y0q)
        step = max(per_period, 1)
        f = float
        c1, c0 = error_coefficients(form, f(params.zeta), f(kq))
        n = periods * step
        cols = [np.empty(n + 1) for _ in range(5)]
        budget = self.max_impacts - len(m0) - len(s0)
        cap = 64 + 4 * periods
        start_t = _time.perf_counter()
        while True:
            m_imp, s_imp = np.empty((cap, 3)), np.empty((cap, 4))
            st, nm, ns, nb, _done = coupled_strobe(
                f(params.eta),
                f(params.zeta),
                f(params.a),
                f(params.x_w),
                f(params.R),
                f(kq),
                FORM_IDS[form],
                c1,
                c0,
                f(params.t0),
                *(f(q) for q in start_state),
                n,
                step,
                max(budget, 1),
                *cols,
                m_imp,
                s_imp,
            )
            if nm <= cap and ns <= cap:
                break
            cap = 2 * max(nm, ns)
        elapsed = _time.perf_counter() - start_t
        if st == STATUS_BUDGET or budget < 1:
            raise BudgetExceededError(
                f"impact budget max_impacts={self.max_impacts} exhausted "
                "(chattering/Zeno sequence?); raise max_impacts or check the parameters"
            )
        if st != STATUS_OK:
            why = (
                "the slave's difference equation is not underdamped"
                if st == STATUS_UNSUPPORTED
                else STATUS_TEXT[int(st)]
            )
            raise Unresolved("fast", why)
        m = np.concatenate([np.array([[f(c) for c in r] for r in m0]).reshape(-1, 3), m_imp[:nm]])
        sl = np.concatenate([np.array([[f(c) for c in r] for r in s0]).reshape(-1, 4), s_imp[:ns]])
        return _trajectory(params, form, kq, y0q, cols, step, per_period, m, sl, elapsed, nb)


def _trajectory(params, form, kq, y0q, cols, step, per_period, m, sl, elapsed, nb):
    """The :class:`CoupledTrajectory` of a finished compiled run (float64 arrays)."""
    ts, xs, vs, ys, ws = cols[4], cols[0], cols[1], cols[2], cols[3]
    P = Precision.parse("float64")
    traj = CoupledTrajectory(
        params=params,
        form=form,
        k=kq,
        y0=y0q,
        precision=P,
        t=ts[::step].copy(),
        x=xs[::step].copy(),
        v=vs[::step].copy(),
        y=ys[::step].copy(),
        w=ws[::step].copy(),
        master_impacts_t=m[:, 0].copy(),
        master_impacts_v_before=m[:, 1].copy(),
        master_impacts_v_after=m[:, 2].copy(),
        slave_impacts_t=sl[:, 0].copy(),
        slave_impacts_w_before=sl[:, 1].copy(),
        slave_impacts_w_after=sl[:, 2].copy(),
        slave_impacts_x=sl[:, 3].copy(),
        elapsed_s=elapsed,
        stats={"simultaneous": int(nb), "engine": "fast"},
    )
    if per_period > 0:
        traj.dense_t, traj.dense_x, traj.dense_v, traj.dense_y, traj.dense_w = (
            ts,
            xs,
            vs,
            ys,
            ws,
        )
    return traj
