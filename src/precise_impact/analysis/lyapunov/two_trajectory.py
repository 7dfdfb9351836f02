"""Largest Lyapunov exponent from two nearby trajectories (Benettin's method).

Fiducial and perturbed orbits on the heyoka reference integrator, renormalised every period,
measured only when both have had the same impacts, on a local periodic clock (Benettin et al.,
Meccanica 15 (1980) 9-20; details in ``docs/numerics.rst``).
"""

from __future__ import annotations

import copy
import math
import time as _time
import warnings
from fractions import Fraction
from typing import Any

import mpmath
import numpy as np

from precise_impact.analysis.lyapunov.attractors import MAX_PERIOD, attribute
from precise_impact.analysis.lyapunov.result import LyapunovResult, block_stderr
from precise_impact.core.clock import local_clock
from precise_impact.core.flow import tangent_qr_interval
from precise_impact.core.mpcontext import mp_context, mp_import
from precise_impact.core.params import RUNTIME_PARAMS, Params, as_params, exact
from precise_impact.core.precision import Precision
from precise_impact.errors import ParameterError
from precise_impact.io.progress import Progress
from precise_impact.solvers.heyoka.single import OrbitStepper, build_integrator

__all__ = ["two_trajectory_lle"]

_MAX_PERIODS = 10**8
#: Impact budget between two measurements (about one forcing period); more is a
#: chattering / Zeno sequence, reported as BudgetExceededError.
_IMPACT_BUDGET = 10**5
#: How far past a period boundary the two trajectories may be integrated to bring
#: their impact counts level (a fraction of the forcing period).
_SYNC_FRACTION = Fraction(1, 8)
_D0_MAX = Fraction(1, 1000)
#: Smallest accepted d0, in units of the precision's epsilon: below ~100 ulps of the
#: O(1) state the measured separation is dominated by round-off.
_D0_MIN_EPS = 100


# --------------------------------------------------------------------- validation
def _check_int(name: str, value: Any, minimum: int, maximum: int) -> int:
    allowed = f"an integer with {minimum} <= {name} <= {maximum}"
    if isinstance(value, str):
        try:
            value = int(value.strip())
        except ValueError:
            raise ParameterError(name, value, allowed) from None
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, np.integer))
        or not minimum <= value <= maximum
    ):
        raise ParameterError(name, value, allowed)
    return int(value)


def _check_d0(d0: Any, P: Precision) -> Fraction:
    lo = _D0_MIN_EPS * P.eps_fraction
    allowed = f"0 < d0 <= 1e-3 and d0 >= {_D0_MIN_EPS} eps = {float(lo):.3g} for precision {P.name}"
    if d0 is None:
        return default_d0(P)
    q = exact("d0", d0)
    if not (0 < q <= _D0_MAX) or q < lo:
        raise ParameterError("d0", d0, allowed)
    return q


def default_d0(precision: str | Precision = "float64") -> Fraction:
    """Default initial separation: ``1e-2 sqrt(eps)`` of the precision (as a Fraction).

    ``sqrt(eps)`` balances the two errors of a finite separation: the
    nonlinear (truncation) error grows like ``d0`` and the round-off in the
    difference of two O(1) states like ``eps / d0``.  The extra factor ``1e-2``
    is a margin for near-grazing impacts, where the saltation matrix has a
    ``1/v`` factor and the linearisation holds only while ``d0 << v^2``.
    float64: 1.5e-10 (round-off noise in ``ln d``: measured ~3e-6 per period);
    float128: 1.4e-19; mp:256: 2e-41.
    """
    P = Precision.parse(precision)
    e = P.eps_fraction
    ctx = mp_context(64)  # this thread's own (mpmath's global precision is shared)
    return _mpf_to_fraction(ctx.sqrt(ctx.mpf(e.numerator) / e.denominator) / 100)


def _mpf_to_fraction(m: mpmath.mpf) -> Fraction:
    sign, man, exp, _ = m._mpf_
    q = Fraction(man) * Fraction(2) ** exp
    return -q if sign else q


# ------------------------------------------------------------- number handling
class _Arith:
    """Separation, its logarithm and the rescaled perturbation in one precision.

    float64 / longdouble use native arithmetic (fast path, ~1 us per period);
    float128 / MPFR go through exact mpmath values at ``bits + 32`` bits.
    """

    def __init__(self, P: Precision, d0: Fraction) -> None:
        self.P = P
        self.native = P.kind in ("float64", "longdouble")
        self.d0 = P.from_fraction(d0)
        self.prec = P.bits + 32
        # a context of its own (mpmath's global precision is shared by every thread); the
        # measurements run in the thread that made this object
        self.ctx = ctx = mpmath.MPContext()
        ctx.prec = self.prec
        self.d0m = ctx.mpf(d0.numerator) / d0.denominator

    def measure(self, dx: Any, dv: Any) -> tuple[float, Any, Any] | None:
        """``(ln(d / d0), dx * d0 / d, dv * d0 / d)``, or ``None`` if ``d == 0``."""
        if self.native:
            d = np.sqrt(dx * dx + dv * dv)
            if d == 0:
                return None
            s = self.d0 / d
            return float(np.log(d / self.d0)), dx * s, dv * s
        P, ctx = self.P, self.ctx
        dxm, dvm = mp_import(ctx, P.to_mpf(dx)), mp_import(ctx, P.to_mpf(dv))
        d = ctx.sqrt(dxm * dxm + dvm * dvm)
        if d == 0:
            return None
        s = self.d0m / d
        return float(ctx.log(d / self.d0m)), P.from_mpf(dxm * s), P.from_mpf(dvm * s)

    def along_diagonal(self) -> tuple[Any, Any]:
        """``d0 (1, 1) / sqrt(2)``: the initial perturbation."""
        c = self.P.from_mpf(self.d0m / self.ctx.sqrt(2))
        return c, c


# ------------------------------------------------------------- integration
def _synchronise(fid: OrbitStepper, per: OrbitStepper, t_limit: Any, P: Precision) -> bool:
    """Bring both orbits to one time at which they have had equally many impacts.

    Called at a period boundary where the impact counts differ: one orbit has hit
    the wall and the other is about to (they straddle the boundary).  The lagging
    orbit is stepped to its next impact (heyoka stops exactly at the event), the
    leading one propagated to that instant; repeat until the counts agree or
    ``t_limit`` is reached.  Returns ``True`` if the counts agree at the common
    time; ``False`` means one orbit missed an impact the other made (a grazing
    impact: the separation is then genuinely O(sqrt(d0)), not spurious) and both
    stand at ``t_limit``.
    """
    while fid.count != per.count:
        lag, lead = (fid, per) if fid.count < per.count else (per, fid)
        if lag.ta.time >= t_limit:
            lead.propagate_until(t_limit, P)
            return fid.count == per.count
        lag.step_to_impact(t_limit, P)
        lead.propagate_until(lag.ta.time, P)
    return True


def _local_clock(P: Precision, t0: Fraction, eta: Fraction) -> tuple[Any, Any, Any]:
    """``(L0, L1, W)``: one forcing period ``[L0, L1]`` of the local clock, and ``T/8``
    (:func:`precise_impact.core.clock.local_clock`).  Every period is integrated from
    ``L0`` to ``L1`` and the clock set back to ``L0``, so time never grows beyond
    ``T + T/8`` (see the module docstring for why)."""
    return local_clock(P, t0, eta, _SYNC_FRACTION)


# ------------------------------------------------------------------ the steps
def _check_inputs(
    params: Any,
    periods: Any,
    transient: Any,
    precision: str | Precision,
    d0: Any,
    segments: Any,
    progress: Any,
    attractors: Any,
) -> tuple[Params, int, int, int, Precision, Fraction]:
    """:func:`two_trajectory_lle`'s arguments checked (before any work):
    ``(params, periods, transient, segments, P, d0)``."""

    params = as_params(params)
    periods = _check_int("periods", periods, 1, _MAX_PERIODS)
    transient = _check_int("transient", transient, 0, _MAX_PERIODS)
    segments = _check_int("segments", segments, 2, _MAX_PERIODS)
    P = Precision.parse(precision)
    d0q = _check_d0(d0, P)
    if not isinstance(progress, (bool, np.bool_)):
        raise ParameterError("progress", progress, "True or False")
    if not isinstance(attractors, (bool, np.bool_)):
        raise ParameterError("attractors", attractors, "True or False")
    return params, periods, transient, segments, P, d0q


def _start_orbits(
    params: Params, P: Precision, transient: int, L0: Any, L1: Any, x_w: Any, R: Any
) -> tuple[OrbitStepper, OrbitStepper]:
    """The fiducial orbit after ``transient`` periods and its copy for the perturbed one.

    The fiducial runs on a private copy of the cached compiled integrator; the perturbed
    one on a deep copy of it (own callback copy, no recompilation); both cleared.
    """
    conv = P.from_fraction
    ta = copy.deepcopy(build_integrator(P, compact_mode=(P.kind == "mp")))
    ta.pars[:] = P.array([conv(getattr(params, n)) for n in RUNTIME_PARAMS])
    ta.time = L0
    fid = OrbitStepper(ta, _IMPACT_BUDGET)
    fid.clear()
    fid.set_state(conv(params.x0), conv(params.v0), x_w, R)
    for _ in range(transient):
        fid.propagate_until(L1, P)
        fid.ta.time = L0
        fid.clear()
    per = OrbitStepper(copy.deepcopy(fid.ta), _IMPACT_BUDGET)
    fid.clear()
    per.clear()
    return fid, per


def _place(fid: OrbitStepper, per: OrbitStepper, dx: Any, dv: Any, x_w: Any, R: Any) -> int:
    """Set the perturbed orbit at ``fiducial + (dx, dv)``, or at ``fiducial - (dx, dv)`` if
    that lies inside the wall; 1 if it was flipped, else 0."""
    xf, vf = fid.ta.state[0], fid.ta.state[1]
    xp = xf + dx
    vp = vf + dv
    flipped = 0
    if xp > x_w:  # inside the wall: use the opposite tangent direction
        xp, vp = xf - dx, vf - dv
        flipped = 1
    per.set_state(xp, vp, x_w, R)
    return flipped


def _measure_periods(
    fid: OrbitStepper,
    per: OrbitStepper,
    arith: _Arith,
    P: Precision,
    periods: int,
    clock: tuple[Any, Any, Any],
    d0q: Fraction,
    wall: tuple[Any, Any],
    progress: bool,
    zeta: Any = 0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, dict[str, int]]:
    """Benettin's loop over the measured periods (``clock = (L0, L1, t_limit)``,
    ``wall = (x_w, R)``).

    Returns ``(log_growth, dts, strobe, impacts, counts)``: per period ``ln(d/d0)``, the
    elapsed time and the fiducial's stroboscopic sample; the fiducial's impacts; and the
    counters ``straddles``, ``grazing_misses``, ``collapses``, ``flips``.
    """
    L0, L1, t_limit = clock
    x_w, R = wall
    flips = _place(fid, per, *arith.along_diagonal(), x_w, R)
    # a long period is cut into steps: over a step the separation may shrink by at most ~e^-1
    # (core.flow.tangent_qr_interval / 8: far below d0 it is the rounding of the two states),
    # and below eta = 0.1 a step is at most 2.5 time units: the slow forced response lets
    # heyoka take steps that resolve it but not the separation (a frequency-1 oscillation
    # ~1e-10 of the state that its error control does not see).  Measured, non-impacting,
    # eta = 0.005: one renormalisation per period -0.0040, steps of 20 -0.04933, of 10
    # -0.04949, of 2.5 -0.0499999970 for -zeta = -0.05; eta >= 0.1 exact with the e^-1 rule.
    T = float(L1 - L0)
    step = tangent_qr_interval(zeta) / 8
    if T > 20 * math.pi:
        step = min(step, 2.5)
    m = max(1, math.ceil(T / step))
    subs = [L0 + (L1 - L0) * i / m for i in range(1, m)]
    log_growth = np.empty(periods)
    dts = np.empty(periods)
    strobe = np.empty((periods, 2))  # the fiducial's stroboscopic samples (the attractor test)
    impacts = 0
    straddles = grazing_misses = collapses = 0
    bar = Progress(periods, "two-trajectory LLE", bool(progress))
    for j in range(periods):
        t_begin = fid.ta.time
        sub_log = 0.0
        for target in subs:
            fid.propagate_until(target, P)
            per.propagate_until(target, P)
            if fid.count != per.count:
                continue  # an impact between the two: measured at the period's end
            m_sub = arith.measure(
                per.ta.state[0] - fid.ta.state[0], per.ta.state[1] - fid.ta.state[1]
            )
            if m_sub is not None:
                sub_log += m_sub[0]
                flips += _place(fid, per, m_sub[1], m_sub[2], x_w, R)
        fid.propagate_until(L1, P)
        per.propagate_until(L1, P)
        if fid.count != per.count:
            straddles += 1
            if not _synchronise(fid, per, t_limit, P):
                grazing_misses += 1
        t_now = fid.ta.time
        dts[j] = float(t_now - t_begin)
        # Next period on the local clock: t_now - L1 is exact (Sterbenz), and both
        # orbits get the identical clock value.
        t_next = L0 + (t_now - L1)
        fid.ta.time = t_next
        per.ta.time = t_next
        xf, vf = fid.ta.state[0], fid.ta.state[1]
        strobe[j] = float(xf), float(vf)
        m = arith.measure(per.ta.state[0] - xf, per.ta.state[1] - vf)
        if m is None:
            collapses += 1
            floor = P.eps_float * max(1.0, abs(float(xf)), abs(float(vf)))
            log_growth[j] = math.log(floor / float(d0q))
            dx, dv = arith.along_diagonal()
        else:
            log_growth[j], dx, dv = m
        log_growth[j] += sub_log
        impacts += fid.count
        fid.clear()
        per.clear()
        flips += _place(fid, per, dx, dv, x_w, R)
        if progress:
            bar.update(j + 1, f"lle ~ {log_growth[: j + 1].sum() / dts[: j + 1].sum():.6g}")
    counts = dict(
        straddles=straddles, grazing_misses=grazing_misses, collapses=collapses, flips=flips
    )
    return log_growth, dts, strobe, impacts, counts


def _attribute_strobe(
    result: LyapunovResult, strobe: np.ndarray, blocks: Any, P: Precision, periods: int
) -> None:
    """Identify the fiducial orbit's attractor from its last stroboscopic samples
    (:func:`~precise_impact.analysis.lyapunov.attractors.attribute`)."""
    tail = strobe[-3 * MAX_PERIOD :]
    attribute(
        result,
        [(tail[:, 0], tail[:, 1])],
        [(result.lle, math.nan, blocks)],
        P.name if P.kind in ("float64", "mp") else "float64",
        periods=[periods],
    )


# ------------------------------------------------------------------ main entry
def two_trajectory_lle(
    params: Params,
    periods: int = 20000,
    transient: int = 1000,
    precision: str | Precision = "float64",
    d0: Any = None,
    segments: int = 20,
    progress: bool = False,
    attractors: bool = True,
) -> LyapunovResult:
    """Largest Lyapunov exponent by Benettin's two-trajectory method.

    The exponent ``lambda`` (per unit of dimensionless time) is measured from a
    fiducial and a perturbed trajectory evolved together with the heyoka reference
    integrator; after every forcing period ``T = 2 pi / eta`` the perturbed one is
    rescaled back to distance ``d0`` along the separation [1]_.

    Parameters
    ----------
    params : Params
        System; the orbit starts at ``(x0, v0)`` at time ``t0``.
    periods : int, default 20000
        Forcing periods over which the exponent is measured; ``>= 1``.
    transient : int, default 1000
        Forcing periods integrated first and discarded, so the fiducial orbit is on
        the attractor; ``>= 0``.
    precision : str or Precision, default ``'float64'``
        ``'float64'``, ``'longdouble'``, ``'float128'`` or ``'mp:BITS'``; both
        trajectories, the rescaling and the sample times use it.
    d0 : decimal or None, default ``None``
        Initial and rescaling distance in the Euclidean ``(x, v)`` norm; ``None`` means
        ``1e-2 sqrt(eps)`` of the precision (float64: 1.5e-10, float128: 1.4e-19; see
        :func:`default_d0`).  Allowed: ``100 eps <= d0 <= 1e-3`` (below ``100 eps``
        round-off of the O(1) state dominates the separation).  Decimal strings and
        Fractions are accepted.
    segments : int, default 20
        Contiguous blocks for the batch-means standard error
        (:func:`~precise_impact.analysis.lyapunov.result.block_stderr`); ``>= 2``.  The
        error bar is NaN when ``periods < 2``.
    progress : bool, default ``False``
        Report the count and the running estimate on stderr
        (:class:`~precise_impact.io.progress.Progress`: throttled, the last one always).
    attractors : bool, default ``True``
        Identify the fiducial orbit's attractor from its last stroboscopic samples; on a
        periodic one report the exact Floquet LLE of the Newton-refined orbit
        (:func:`~precise_impact.analysis.lyapunov.attractors.attribute`; ``stats['lle_source']``,
        the finite-time estimate in ``stats['finite_time']``).

    Returns
    -------
    LyapunovResult
        ``method='two-trajectory'``, ``spectrum=None``, ``running`` the estimate after
        each measured period, ``segments`` the per-block estimates, ``stderr`` their
        standard error, ``impacts`` the fiducial orbit's impacts during the measured
        periods and ``elapsed_s`` the wall time (transient included); ``stats['attractors']``
        and ``stats['lle_source']`` as the variational method's, ``stats['per_start']`` the
        one start's ``lle``, ``stderr``, ``impact_rate`` and ``attractor``.

    Raises
    ------
    ParameterError
        Bad input (validated before any work), naming the parameter and its range.

    Warns
    -----
    RuntimeWarning
        The separation collapsed to exactly zero and was re-seeded (see Notes).

    Notes
    -----
    After the transient the perturbed state is ``x + d0 (1, 1)/sqrt(2)``.  Each
    period both are propagated to the next period boundary, the distance ``d`` is
    measured, ``ln(d/d0)`` accumulated and the perturbed state replaced by
    ``fiducial + (d0/d)(perturbed - fiducial)``.  Then
    ``lambda = sum ln(d_k/d0) / sum dt_k`` (time, not periods, in the denominator).

    *Local clock.*  Every period is integrated over the same interval
    ``[L0, L1]``, ``L0 = fl(t0 mod T)``, ``L1 = fl(L0 + T)`` (each rounded once, as
    :meth:`~precise_impact.Precision.sample_times`), and the clock is set back by one
    period afterwards; the forcing is ``T``-periodic, so this is the stroboscopic map,
    but the time never exceeds ``~T`` and the rounding of ``t`` inside ``cos(eta t)``
    stays ``eps T`` instead of ``eps t``.  With absolute time that rounding, different
    in the two trajectories' adaptive steps, adds separation noise ``~0.3 eps t`` per
    period and biases the exponent for small ``d0`` and long runs (module docstring).

    *Choice of d0.*  A finite separation has two errors: nonlinearity, growing
    like ``c d0`` (``c ~ 50`` per period at the near-grazing impacts of
    eta = 0.712, where the saltation matrix has a ``1/v`` factor; it grows like
    ``1/v^2`` closer to grazing), and round-off, zero-mean noise in ``ln d`` of
    ``~5e-16/d0`` per period in float64, whose bias on ``lambda`` is only second
    order.  ``sqrt(eps)`` balances the two; the factor ``1e-2`` errs on the
    harmless (round-off) side to keep grazing impacts linear.  Measured at
    eta = 0.712, float64, 20000 periods on one fiducial orbit: d0 = 1e-13 ...
    1e-6 agree to 4e-6 (stderr 4e-4); d0 = 1e-4 and 1e-3 move the estimate by
    ~3e-4 and cause straddles and grazing misses.

    *Impacts straddling a boundary.*  Measurement happens only when both orbits
    have had the same number of impacts since the last rescaling.  If at ``t_k``
    the counts differ (one orbit hit the wall, the other is ``O(d0/v)`` away from
    it), the lagging orbit is stepped exactly to its impact and the leading one to
    the same instant, and the separation is measured there (both post-impact;
    never more than ``T/8`` past the boundary).  The next interval then starts at
    that instant, so every ``dt_k`` is the true elapsed time.  If the counts cannot
    be levelled within ``T/8`` (a grazing impact made by one orbit only), the
    separation is measured at ``t_k + T/8``: it is then a genuine effect of the
    grazing discontinuity, not an artefact.  A rescaled perturbed state that would
    lie inside the wall (``x > x_w``) is placed on the other side,
    ``fiducial - (d0/d)(perturbed - fiducial)``; the sign of the tangent vector
    does not affect the exponent.

    *Collapse.*  If the separation is exactly zero (possible only when impacts
    with ``R = 0`` stick both orbits to the wall), the period contributes
    ``ln(eps max(1, |x|, |v|) / d0)`` (the separation is below one ulp of the
    state, so this bounds the true growth from above), the perturbation is
    re-seeded along ``(1, 1)/sqrt(2)`` and a :class:`RuntimeWarning` is issued.

    References
    ----------
    .. [1] G. Benettin, L. Galgani, A. Giorgilli, J.-M. Strelcyn, "Lyapunov
           characteristic exponents for smooth dynamical systems and for Hamiltonian
           systems; a method for computing all of them", Meccanica 15 (1980) 9-20
           (part 1: theory, part 2: numerical application).
    .. [2] F. Biscani, D. Izzo, "Revisiting high-order Taylor methods for
           astrodynamics and celestial mechanics", MNRAS 504 (2021) (heyoka).
    """
    params, periods, transient, segments, P, d0q = _check_inputs(
        params, periods, transient, precision, d0, segments, progress, attractors
    )
    t_start = _time.perf_counter()
    conv = P.from_fraction
    arith = _Arith(P, d0q)
    x_w, R = conv(params.x_w), conv(params.R)
    L0, L1, sync_window = _local_clock(P, params.t0, params.eta)
    fid, per = _start_orbits(params, P, transient, L0, L1, x_w, R)
    log_growth, dts, strobe, impacts, counts = _measure_periods(
        fid,
        per,
        arith,
        P,
        periods,
        (L0, L1, L1 + sync_window),
        d0q,
        (x_w, R),
        progress,
        zeta=params.zeta,
    )
    collapses = counts["collapses"]
    if collapses:
        warnings.warn(
            f"two_trajectory_lle: the separation collapsed to exactly zero in {collapses} of "
            f"{periods} periods (sticking impacts?); those periods contribute an upper bound "
            "ln(eps/d0) and the estimate is biased upwards",
            RuntimeWarning,
            stacklevel=2,
        )
    running = np.cumsum(log_growth) / np.cumsum(dts)
    blocks, stderr = block_stderr(log_growth, dts, segments)
    elapsed = _time.perf_counter() - t_start
    result = LyapunovResult(
        params=params,
        method="two-trajectory",
        precision=P.name,
        lle=float(log_growth.sum() / dts.sum()),
        spectrum=None,
        lle_stderr=stderr,
        periods=periods,
        transient=transient,
        n_impacts=impacts,
        running=running,
        segments=blocks,
        elapsed_s=elapsed,
        stats=dict(**counts, d0=d0q),
    )
    if attractors:
        _attribute_strobe(result, strobe, blocks, P, periods)
    return result
