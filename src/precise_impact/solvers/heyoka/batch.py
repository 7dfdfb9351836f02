"""The SIMD batch variational integrator (float64): many parameter points in one heyoka batch.

Behind :func:`~precise_impact.analysis.lyapunov.batch.batch_lle`: ``taylor_adaptive_batch``
advances ``batch_size`` points in SIMD lanes, each with its own clock; the rest as in
:mod:`~precise_impact.solvers.heyoka.variational` (``docs/numerics.rst``, "SIMD batch (sweeps)").
"""

from __future__ import annotations

import math

import numpy as np

from precise_impact.core.clock import local_clock
from precise_impact.core.flow import acceleration
from precise_impact.core.impact import (
    BOUNCES_ENDLESS,
    BOUNCES_REST,
    GRAZING_SAFETY,
    elastic_bounce_count,
    elastic_bounce_refusal,
    grazing_depth,
    impact_at_start,
    is_contact,
    oscillator_saltation,
    reset_velocity,
    short_elastic_flight,
    steady_amplitude,
)
from precise_impact.core.linalg import gram_schmidt2
from precise_impact.core.params import (
    I_A,
    I_ETA,
    I_R,
    I_XW,
    I_ZETA,
    RUNTIME_PARAMS,
)
from precise_impact.core.precision import Precision
from precise_impact.errors import BudgetExceededError, IntegrationError, MissedImpactError
from precise_impact.solvers.heyoka.cache import IntegratorCache
from precise_impact.solvers.heyoka.events import ImpactRecorder
from precise_impact.solvers.heyoka.single import _below_wall
from precise_impact.solvers.heyoka.variational import GUARD_FACTOR, chunk_layout, released_at

__all__ = ["integrate_group", "default_batch_size"]


_COEF64 = (
    GRAZING_SAFETY * 2.0**-53
)  # grazing_depth_coefficient(float64), exactly (a power of two times 16)


#: The wall of a retired lane (a refused R = 1 bounce sequence): far beyond any orbit.
RETIRED_WALL = 1e12


def _depth(t: float, pr, i: int, amp: float) -> float:
    """Grazing depth of lane ``i`` at local time ``t``, ``amp`` its steady amplitude (the one
    formula, :func:`~precise_impact.core.impact.grazing_depth`, with float64's coefficient)."""
    return grazing_depth(_COEF64, amp, t, pr[I_XW, i], pr[I_A, i], pr[I_ETA, i])


class _BatchSaltation:
    """Batch terminal-event callback: impact map + saltation matrix + QR on one lane.

    Per lane: an :class:`~precise_impact.solvers.heyoka.events.ImpactRecorder` (count and
    budget, no log) in ``lanes``, ``grazing`` contacts, ``log1``/``log2`` the logs of
    the in-callback QR since the last period boundary.
    """

    def __init__(self, batch_size: int) -> None:
        self.reset(batch_size, 10**7, np.zeros(batch_size))

    def reset(self, batch_size: int, max_impacts: int, amp: np.ndarray) -> None:
        self.amp = np.asarray(amp, dtype=float)
        self.lanes = [
            ImpactRecorder(keep=False, max_impacts=max_impacts) for _ in range(batch_size)
        ]
        self.grazing = np.zeros(batch_size, dtype=np.int64)
        self.log1 = np.zeros(batch_size)
        self.log2 = np.zeros(batch_size)
        # R = 1 bounce sequences (core.impact.elastic_bounce_count), per lane: the run's end
        # on the local clock (set every period), whether the current one was predicted, and
        # the refusal of a lane predicted to come to rest or to outrun its budget
        self.t_end = np.full(batch_size, math.inf)
        self.predicted = [False] * batch_size
        self.refused: list[str | None] = [None] * batch_size

    @property
    def count(self) -> np.ndarray:
        """Impacts per lane since :meth:`reset`."""
        return np.array([lane.count for lane in self.lanes], dtype=np.int64)

    @property
    def exceeded(self) -> bool:
        """Has any lane exhausted its impact budget?"""
        return any(lane.exceeded for lane in self.lanes)

    def __call__(self, ta, d_sgn, i) -> bool:
        st, pr = ta.state, ta.pars
        t = float(ta.time[i])
        R, x_w = pr[I_R, i], pr[I_XW, i]
        eta, zeta, a = pr[I_ETA, i], pr[I_ZETA, i], pr[I_A, i]
        vb = float(st[1, i])
        acc = acceleration(t, x_w, vb, eta, zeta, a, math.cos)
        if is_contact(vb, acc, _depth(t, pr, i, self.amp[i])):
            self.grazing[i] += 1  # tangential contact within rounding of the wall
            return True
        S = oscillator_saltation(t, vb, eta, zeta, a, x_w, R, math.cos)
        p00, p01, p10, p11 = st[2, i], st[3, i], st[4, i], st[5, i]
        a0 = S[0][0] * p00 + S[0][1] * p10
        b0 = S[0][0] * p01 + S[0][1] * p11
        a1 = S[1][0] * p00 + S[1][1] * p10
        b1 = S[1][0] * p01 + S[1][1] * p11
        # QR at once (docs/numerics.rst, variational equations): the logs carry the growth.
        st[2, i], st[4, i], st[3, i], st[5, i], r11, r22 = gram_schmidt2(a0, a1, b0, b1)
        self.log1[i] += math.log(r11)
        if r22 > 0:
            self.log2[i] += math.log(r22)
        else:  # plastic impact (R = 0): lambda2 = -inf (the second column was re-seeded)
            self.log2[i] = -math.inf
        st[1, i] = reset_velocity(vb, R)
        st[0, i] = x_w
        if R >= 1 and self.refused[i] is None:
            self._bounces(pr, i, t, vb, float(eta), float(zeta), float(a), float(x_w))
        return self.lanes[i].record(t)

    def _bounces(self, pr, i: int, t: float, vb: float, eta, zeta, a, x_w) -> None:
        """An ``R = 1`` impact of lane ``i``: predict a bounce sequence at its first short flight;
        one that comes to rest or outruns the budget is refused and the lane retired (its wall
        moved to ``RETIRED_WALL``: it runs on without impacts, its results are discarded)."""
        if not short_elastic_flight(vb, a * math.cos(eta * t) - x_w, eta):
            self.predicted[i] = False
            return
        if self.predicted[i]:
            return
        self.predicted[i] = True
        n, end, s = elastic_bounce_count(t, vb, float(self.t_end[i]), eta, zeta, a, x_w, 2.0**-52)
        lane = self.lanes[i]
        if end in (BOUNCES_REST, BOUNCES_ENDLESS) or n > lane.max_impacts - lane.count:
            self.refused[i] = elastic_bounce_refusal(t, n, end, s, lane.max_impacts)
            pr[I_XW, i] = RETIRED_WALL


class _BatchGuard:
    """Batch non-terminal-event callback on ``v`` (negative direction): ``x`` at each maximum."""

    def __init__(self, batch_size: int) -> None:
        self.reset(batch_size, np.zeros(batch_size))

    def reset(self, batch_size: int, amp: np.ndarray) -> None:
        self.amp = np.asarray(amp, dtype=float)
        self.missed = np.zeros(batch_size, dtype=np.int64)
        self.first_miss: tuple | None = None

    def __call__(self, ta, time, d_sgn, i) -> None:
        tt = np.array(ta.time, dtype=float)
        tt[i] = time
        x = ta.update_d_output(tt)[0, i]
        over = x - ta.pars[I_XW, i]
        if over > GUARD_FACTOR * _depth(time, ta.pars, i, self.amp[i]):
            self.missed[i] += 1
            if self.first_miss is None:
                self.first_miss = (i, float(time), float(over))


_INTEGRATORS = IntegratorCache("batch-variational")  # compiled once; every caller gets its own copy


def default_batch_size() -> int:
    """heyoka's recommended SIMD width for float64 on this CPU (8 with AVX-512, 4 with AVX2)."""
    import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

    return max(1, int(hy.recommended_simd_size()))


def _integrator(batch_size: int):
    import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

    def compile_():
        x, v = hy.make_vars("x", "v")
        p = {name: hy.par[i] for i, name in enumerate(RUNTIME_PARAMS)}
        rhs = acceleration(hy.time, x, v, p["eta"], p["zeta"], p["a"], hy.cos)
        vsys = hy.var_ode_sys([(x, v), (v, rhs)], hy.var_args.vars, order=1)
        ev = hy.t_event_batch(
            x - p["x_w"],
            callback=_BatchSaltation(batch_size),
            direction=hy.event_direction.positive,
        )
        guard = hy.nt_event_batch(
            v, callback=_BatchGuard(batch_size), direction=hy.event_direction.negative
        )
        ta = hy.taylor_adaptive_batch(
            vsys,
            np.zeros((6, batch_size)),
            pars=np.zeros((len(RUNTIME_PARAMS), batch_size)),
            t_events=[ev],
            nt_events=[guard],
        )
        return ta

    return _INTEGRATORS.get(batch_size, compile_)


def _group_start(ta, group, L0: np.ndarray) -> np.ndarray:
    """Each lane's start state (tangents at the identity) set in ``ta``; the start times."""
    P64 = Precision.parse("float64")
    st = np.zeros((6, len(L0)))
    start = L0.copy()  # a lane that starts stuck on the wall starts at its release
    for i, p in enumerate(group):
        x0, v0 = float(p.x0), float(p.v0)
        if impact_at_start(p.x0, p.v0, p.x_w, p.R):
            # as the variational integrator: off the wall by a rounding-level distance
            v0, x0 = reset_velocity(v0, float(p.R)), _below_wall(P64, p.x_w)
        elif p.x0 == p.x_w and p.v0 == 0:
            t_r = released_at(P64, p, float(L0[i]))
            if t_r is not None:
                start[i], x0 = t_r, _below_wall(P64, p.x_w)
        st[:, i] = (x0, v0, 1.0, 0.0, 0.0, 1.0)
    ta.state[:] = st
    ta.set_time(start)
    ta.reset_cooldowns()
    return start


def _group_propagate(ta, rec, grd, group, target, max_impacts: int) -> None:
    """All lanes to ``target``; the budget, the outcome and the missed-impact guard checked."""
    import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

    ta.propagate_until(target)
    if rec.exceeded:
        raise BudgetExceededError(
            f"impact budget max_impacts={max_impacts} exhausted in a batch lane"
        )
    if any(r[0] != hy.taylor_outcome.time_limit for r in ta.propagate_res):
        raise IntegrationError(f"heyoka batch stopped early: {[r[0] for r in ta.propagate_res]}")
    if grd.first_miss is not None:
        i, t_m, over = grd.first_miss
        raise MissedImpactError(
            f"batch lane {i} ({group[i]}): a maximum of x lies {over:.3g} beyond the "
            f"wall at local time {t_m:.17g} with no impact event: heyoka's event "
            "detection missed an impact"
        )


def _group_inner_qr(s, moved: np.ndarray, s1: np.ndarray, s2: np.ndarray) -> None:
    """Re-orthonormalise the tangents of the lanes inside their period (``moved``); their
    logs added to ``s1``, ``s2``."""
    q0, q1, u0, u1, r11, r22 = gram_schmidt2(s[2], s[4], s[3], s[5], np.sqrt)
    s[2], s[4] = np.where(moved, q0, s[2]), np.where(moved, q1, s[4])
    s[3], s[5] = np.where(moved, u0, s[3]), np.where(moved, u1, s[5])
    with np.errstate(divide="ignore"):
        s1 += np.where(moved, np.log(r11), 0.0)
        s2 += np.where(moved, np.log(r22), 0.0)


def _group_period(ta, rec, grd, group, k: int, targets: list, m, start, max_impacts: int):
    """Period ``k`` of every lane in ``len(targets)`` steps; the inner QRs' summed logs."""
    B, M = len(group), len(targets)
    s1 = np.zeros(B)
    s2 = np.zeros(B)
    for j, target in enumerate(targets, start=1):
        if k == 1:  # never back before a released lane's start
            target = np.maximum(target, start)
        _group_propagate(ta, rec, grd, group, target, max_impacts)
        if j == M:
            break
        # lanes inside their period (at L1 the period's own QR follows)
        _group_inner_qr(ta.state, j < m, s1, s2)
    return s1, s2


def integrate_group(group, B: int, periods: int, transient: int, max_impacts: int):
    """Integrate ``B`` points (one SIMD lane each) for ``transient + periods`` periods.

    Returns ``(l1, l2, xs, vs, T, impacts, grazing, refused)``: per measured period and lane the
    logs ``ln r11``, ``ln r22`` (in-callback QRs of the impacts included) and the
    stroboscopic samples (arrays ``(periods, B)``), each lane's period ``T`` on its local
    clock, the impacts in the measured periods, the tangential contacts of the whole run, and
    per lane ``None`` or why it was refused (an ``R = 1`` bounce sequence without end).
    """
    ta = _integrator(B)
    rec = ta.t_events[0].callback
    amp = np.array([steady_amplitude(p) for p in group])
    rec.reset(B, max_impacts, amp)
    grd = ta.nt_events[0].callback
    grd.reset(B, amp)
    ta.pars[:] = np.array([[float(getattr(p, n)) for p in group] for n in RUNTIME_PARAMS])
    P64 = Precision.parse("float64")
    clocks = [local_clock(P64, p.t0, p.eta) for p in group]
    L0 = np.array([c[0] for c in clocks])
    L1 = np.array([c[1] for c in clocks])
    T = L1 - L0  # the period each lane integrates (the local clock's)
    start = _group_start(ta, group, L0)
    total = transient + periods
    l1 = np.zeros((periods, B))
    l2 = np.zeros((periods, B))
    xs = np.zeros((periods, B))
    vs = np.zeros((periods, B))
    imp0 = None
    # QR steps per period and lane: a period longer than the tangents' QR interval is cut
    # into equal steps, each lane as it would be alone (solvers.heyoka.variational.chunk_layout)
    m = np.array([chunk_layout(float(T[i]), p.zeta)[1] for i, p in enumerate(group)])
    M = int(m.max())
    targets = [np.where(j < m, L0 + (L1 - L0) * j / m, L1) for j in range(1, M)] + [L1]
    for k in range(1, total + 1):
        rec.t_end = L0 + (total - k + 1) * T
        s1, s2 = _group_period(ta, rec, grd, group, k, targets, m, start, max_impacts)
        ta.set_time(L0)  # the forcing is T-periodic: set every lane's clock back one period
        s = ta.state
        q0, q1, u0, u1, r11, r22 = gram_schmidt2(s[2], s[4], s[3], s[5], np.sqrt)
        s[2], s[4], s[3], s[5] = q0, q1, u0, u1
        c1_log, c2_log = rec.log1.copy(), rec.log2.copy()  # in-callback QR logs of this period
        rec.log1[:] = 0.0
        rec.log2[:] = 0.0
        if k == transient:  # the transient's logs are dropped, not its basis (no 1/t restart bias)
            imp0 = rec.count
        elif k > transient:
            j = k - transient - 1
            with np.errstate(divide="ignore"):
                l1[j], l2[j] = np.log(r11) + c1_log, np.log(r22) + c2_log
                if M > 1:
                    l1[j], l2[j] = l1[j] + s1, l2[j] + s2
            xs[j], vs[j] = s[0], s[1]
    if imp0 is None:  # transient == 0
        imp0 = np.zeros(B, dtype=np.int64)
    impacts = rec.count - imp0
    return l1, l2, xs, vs, T, impacts, rec.grazing.copy(), list(rec.refused)
