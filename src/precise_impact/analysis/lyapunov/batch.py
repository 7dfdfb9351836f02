"""SIMD batch variational LLE (float64): many parameter points in one heyoka batch integrator.

The flow, impact map and saltation matrix of :mod:`~precise_impact.analysis.lyapunov.variational`
in ``taylor_adaptive_batch`` lanes (each with its own steps, events and periods), so that sweeps
pay no per-point Python overhead; the hard cases are treated as there (``docs/numerics.rst``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from precise_impact.analysis.lyapunov.result import means_stderr
from precise_impact.analysis.lyapunov.variational import GUARD_FACTOR, MissedImpactError
from precise_impact.analysis.periodicity import detect_period
from precise_impact.core.clock import local_clock
from precise_impact.core.flow import acceleration
from precise_impact.core.impact import (
    GRAZING_SAFETY,
    grazing_depth,
    impact_at_start,
    is_contact,
    oscillator_saltation,
    reset_velocity,
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
    Params,
    check_count,
)
from precise_impact.errors import BudgetExceededError, IntegrationError, ParameterError
from precise_impact.solvers.heyoka.cache import IntegratorCache
from precise_impact.solvers.heyoka.events import ImpactRecorder

__all__ = ["batch_lle", "detect_period", "default_batch_size"]


_COEF64 = (
    GRAZING_SAFETY * 2.0**-53
)  # grazing_depth_coefficient(float64), exactly (a power of two times 16)


def _depth(t: float, pr, i: int, amp: float) -> float:
    """Grazing depth of lane ``i`` at local time ``t``, ``amp`` its steady amplitude (the one formula,
    :func:`~precise_impact.core.impact.grazing_depth`, with float64's coefficient)."""
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
        # QR at once (module docstring of the variational method): the logs carry the growth.
        st[2, i], st[4, i], st[3, i], st[5, i], r11, r22 = gram_schmidt2(a0, a1, b0, b1)
        self.log1[i] += math.log(r11)
        if r22 > 0:
            self.log2[i] += math.log(r22)
        else:  # plastic impact (R = 0): lambda2 = -inf (the second column was re-seeded)
            self.log2[i] = -math.inf
        st[1, i] = reset_velocity(vb, R)
        st[0, i] = x_w
        return self.lanes[i].record(t)


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
    import heyoka as hy

    return max(1, int(hy.recommended_simd_size()))


def _integrator(batch_size: int):
    import heyoka as hy

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


def batch_lle(
    points: Sequence[Params],
    periods: int = 2000,
    transient: int = 1000,
    segments: int = 10,
    batch_size: int | None = None,
    max_period: int = 32,
    max_impacts: int = 10**7,
) -> list[dict]:
    """LLE (variational, saltation), its error bar, the period and impacts per period for each point.

    Parameters
    ----------
    points : sequence of Params
        One parameter point (with its own initial condition) per entry.
    periods : int, default 2000
        Measured periods per point (>= 1).
    transient : int, default 1000
        Discarded periods per point.
    segments : int, default 10
        Batch-means blocks for the standard error (>= 2).
    batch_size : int or None, default ``None`` (:func:`default_batch_size`)
        SIMD lanes per heyoka batch integrator; points are processed in groups of
        this size (the last group padded with copies of its first point).
    max_period : int, default 32
        Longest period :func:`detect_period` looks for.
    max_impacts : int, default 10**7
        Impact budget per lane.

    Returns one dict per point: ``lle``, ``lambda2``, ``stderr``, ``period``,
    ``impacts_per_period``, ``x_last``/``v_last`` (the last stroboscopic sample) and
    ``grazing`` (tangential contacts over the whole run, transient included: events
    within the grazing depth of the wall, not impacts; see :mod:`precise_impact.analysis.lyapunov.variational`).
    Raises :class:`~precise_impact.errors.MissedImpactError` if a lane's maximum of ``x``
    lies beyond the wall by more than 4 grazing depths (an impact heyoka missed).
    Each lane is integrated exactly as it would be alone (per-lane steps, events and
    period boundaries), so a point's result does not depend on its batch neighbours.
    References as :func:`~precise_impact.analysis.lyapunov.variational.variational_spectrum`.
    """
    periods = check_count(periods, "periods")
    if periods < 1:
        raise ParameterError("periods", periods, "an integer >= 1")
    transient = check_count(transient, "transient")
    segments = check_count(segments, "segments", 10**6)
    if segments < 2:
        raise ParameterError("segments", segments, "an integer >= 2")
    B = default_batch_size() if batch_size is None else check_count(batch_size, "batch_size", 64)
    if B < 1:
        raise ParameterError("batch_size", batch_size, "an integer with 1 <= batch_size <= 64")
    points = list(points)
    out: list[dict] = []
    for lo in range(0, len(points), B):
        group = points[lo : lo + B]
        out.extend(
            _run_group(
                group + [group[0]] * (B - len(group)),
                B,
                periods,
                transient,
                segments,
                max_period,
                max_impacts,
            )[: len(group)]
        )
    return out


def _run_group(group, B, periods, transient, segments, max_period, max_impacts):
    import heyoka as hy

    from precise_impact.core.precision import Precision

    ta = _integrator(B)
    rec = ta.t_events[0].callback
    amp = np.array([steady_amplitude(p) for p in group])
    rec.reset(B, max_impacts, amp)
    grd = ta.nt_events[0].callback
    grd.reset(B, amp)
    ta.pars[:] = np.array([[float(getattr(p, n)) for p in group] for n in RUNTIME_PARAMS])
    st = np.zeros((6, B))
    for i, p in enumerate(group):
        v0 = float(p.v0)
        if impact_at_start(p.x0, p.v0, p.x_w, p.R):
            v0 = reset_velocity(v0, float(p.R))
        st[:, i] = (float(p.x0), v0, 1.0, 0.0, 0.0, 1.0)
    ta.state[:] = st
    P64 = Precision.parse("float64")
    clocks = [local_clock(P64, p.t0, p.eta) for p in group]
    L0 = np.array([c[0] for c in clocks])
    L1 = np.array([c[1] for c in clocks])
    T = L1 - L0  # the period each lane integrates (the local clock's)
    ta.set_time(L0)
    ta.reset_cooldowns()
    total = transient + periods
    l1 = np.zeros((periods, B))
    l2 = np.zeros((periods, B))
    xs = np.zeros((periods, B))
    vs = np.zeros((periods, B))
    imp0 = None
    for k in range(1, total + 1):
        ta.propagate_until(L1)
        if rec.exceeded:
            raise BudgetExceededError(
                f"impact budget max_impacts={max_impacts} exhausted in a batch lane"
            )
        if any(r[0] != hy.taylor_outcome.time_limit for r in ta.propagate_res):
            raise IntegrationError(
                f"heyoka batch stopped early: {[r[0] for r in ta.propagate_res]}"
            )
        if grd.first_miss is not None:
            i, t_m, over = grd.first_miss
            raise MissedImpactError(
                f"batch lane {i} ({group[i]}): a maximum of x lies {over:.3g} beyond the wall at local time "
                f"{t_m:.17g} with no impact event: heyoka's event detection missed an impact"
            )
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
            xs[j], vs[j] = s[0], s[1]
    if imp0 is None:  # transient == 0
        imp0 = np.zeros(B, dtype=np.int64)
    counts = rec.count
    results = []
    nb = min(segments, periods)
    for i in range(B):
        blocks = np.array([blk.sum() for blk in np.array_split(l1[:, i], nb)]) / np.array(
            [len(blk) * T[i] for blk in np.array_split(l1[:, i], nb)]
        )
        tot = periods * T[i]
        results.append(
            {
                "lle": float(l1[:, i].sum() / tot),
                "lambda2": float(l2[:, i].sum() / tot),
                "stderr": means_stderr(blocks),
                "period": detect_period(xs[:, i], vs[:, i], max_period),
                "impacts_per_period": float((counts[i] - imp0[i]) / periods),
                "x_last": float(xs[-1, i]),
                "v_last": float(vs[-1, i]),
                "grazing": int(rec.grazing[i]),
            }
        )
    return results
