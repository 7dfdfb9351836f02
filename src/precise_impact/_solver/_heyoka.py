"""Ground truth: heyoka's adaptive Taylor integrator with event detection.

The flow is :func:`precise_impact._system.acceleration` built from heyoka
expressions; the impact is a terminal event on ``x - x_w`` (positive direction)
whose callback applies :func:`precise_impact._impact.reset_velocity`.  Every
parameter a sweep varies (``eta, zeta, a, R, x_w``) is a heyoka runtime parameter,
so changing it does not recompile; compiled integrators are cached per
(precision, tolerance, mode) and reused within a process.
"""

from __future__ import annotations

import threading
import time as _time
from fractions import Fraction
from typing import Any

import numpy as np

from .._errors import BudgetExceededError, ParameterError
from .._impact import impact_at_start, reset_velocity
from .._params import RUNTIME_PARAMS, Params, check_count, exact
from .._precision import Precision
from .._result import Trajectory
from .._system import acceleration

__all__ = ["HeyokaSolver", "build_integrator"]

_IDX = {name: i for i, name in enumerate(RUNTIME_PARAMS)}


class _ImpactRecorder:
    """Terminal-event callback: applies the impact map and records the impact.

    heyoka deep-copies the callback into the integrator, so results are read back
    from ``ta.t_events[0].callback`` (the integrator's copy), never from the object
    passed to the constructor.
    """

    def __init__(self) -> None:
        self.reset(10**6)

    def reset(self, max_impacts: int) -> None:
        self.t: list = []
        self.v_before: list = []
        self.v_after: list = []
        self.max_impacts = max_impacts
        self.exceeded = False

    def __call__(self, ta, d_sgn) -> bool:
        st = ta.state
        pars = ta.pars
        vb = st[1]
        va = reset_velocity(vb, pars[_IDX["R"]])
        st[1] = va
        # The event fixes the impact instant; the position there is the wall by
        # definition (eq. 2b).  The root finder leaves x within O(eps) of x_w.
        st[0] = pars[_IDX["x_w"]]
        self.t.append(ta.time)
        self.v_before.append(vb)
        self.v_after.append(va)
        if len(self.t) >= self.max_impacts:
            self.exceeded = True
            return False
        return True


_CACHE: dict[tuple, Any] = {}
_LOCK = threading.Lock()


def build_integrator(precision: Precision, tol: Any = None, high_accuracy: bool = False, compact_mode: bool = False):
    """Compile (or fetch from the cache) a heyoka integrator for the oscillator.

    The integrator's runtime parameters are ordered as ``RUNTIME_PARAMS`` =
    ``(eta, zeta, a, R, x_w)``.  Returns the cached object itself: callers reset
    time, state, parameters and the callback before each use.
    """
    import heyoka as hy

    key = (precision.name, None if tol is None else precision.to_str(tol), high_accuracy, compact_mode)
    with _LOCK:
        ta = _CACHE.get(key)
        if ta is not None:
            return ta
        x, v = hy.make_vars("x", "v")
        p = {name: hy.par[i] for i, name in enumerate(RUNTIME_PARAMS)}
        rhs = acceleration(hy.time, x, v, p["eta"], p["zeta"], p["a"], hy.cos)
        kw = precision.heyoka_kwargs
        ev = hy.t_event(
            x - p["x_w"],
            callback=_ImpactRecorder(),
            direction=hy.event_direction.positive,
            fp_type=kw["fp_type"],
        )
        zero = precision.from_fraction(Fraction(0))
        extra = {}
        if tol is not None:
            extra["tol"] = tol
        ta = hy.taylor_adaptive(
            [(x, v), (v, rhs)],
            [zero, zero],
            pars=[zero] * len(RUNTIME_PARAMS),
            t_events=[ev],
            high_accuracy=high_accuracy,
            compact_mode=compact_mode,
            **extra,
            **kw,
        )
        _CACHE[key] = ta
        return ta


def _check_tol(tol: Any, precision: Precision) -> Fraction | None:
    if tol is None:
        return None
    q = exact("tol", tol)
    if not (0 < q < 1):
        raise ParameterError("tol", str(tol), "tolerance must satisfy 0 < tol < 1")
    return q


class HeyokaSolver:
    """heyoka Taylor integrator with impact events: the reference solver.

    Keywords
    --------
    precision : str or Precision, default ``'float64'``
        ``'float64'``, ``'longdouble'``, ``'float128'`` or ``'mp:BITS'`` (BITS >= 64).
    tol : decimal string / Fraction / number or None, default ``None``
        Relative and absolute tolerance of the Taylor method; ``None`` means the
        precision's epsilon (heyoka's default; Biscani & Izzo, MNRAS 504, 2021,
        sec. 3: order and step chosen so the truncation error is below ``tol``).
    high_accuracy : bool, default ``False``
        heyoka's compensated-summation mode for very long integrations.
    compact_mode : bool or None, default ``None``
        heyoka's compact mode (much faster compilation, somewhat slower run);
        ``None`` means on for ``mp:BITS`` (measured: 256-bit unrolled compilation
        takes minutes, compact 0.3 s) and off otherwise.
    max_impacts : int, default ``10**6``
        Budget: more impacts than this raises :class:`BudgetExceededError`
        (a Zeno impact sequence would otherwise never finish).
    """

    model_name = "heyoka"

    def __init__(
        self,
        precision: str | Precision = "float64",
        tol: Any = None,
        high_accuracy: bool = False,
        compact_mode: bool | None = None,
        max_impacts: int = 10**6,
    ) -> None:
        self.precision = Precision.parse(precision)
        self.tol_exact = _check_tol(tol, self.precision)
        self.tol = None if self.tol_exact is None else self.precision.from_fraction(self.tol_exact)
        if isinstance(max_impacts, bool) or not isinstance(max_impacts, int) or max_impacts < 1:
            raise ParameterError("max_impacts", max_impacts, "impact budget must be an integer >= 1")
        self.high_accuracy = bool(high_accuracy)
        # Multiprecision Taylor orders are high (~90 at 256 bits); unrolled code
        # then takes minutes to compile, compact mode a fraction of a second.
        self.compact_mode = (self.precision.kind == "mp") if compact_mode is None else bool(compact_mode)
        self.max_impacts = max_impacts

    def integrator(self):
        """The compiled (cached) heyoka integrator this solver uses."""
        return build_integrator(self.precision, self.tol, self.high_accuracy, self.compact_mode)

    def _prepare(self, params: Params):
        """Reset the cached integrator to ``params``' initial condition."""
        P = self.precision
        ta = self.integrator()
        conv = P.from_fraction
        ta.pars[:] = P.array([conv(getattr(params, n)) for n in RUNTIME_PARAMS])
        x0, v0 = conv(params.x0), conv(params.v0)
        ta.time = conv(params.t0)
        rec = ta.t_events[0].callback
        rec.reset(self.max_impacts)
        if impact_at_start(params.x0, params.v0, params.x_w, params.R):
            # Starting on the wall moving into it is an impact at t0.
            va = reset_velocity(v0, conv(params.R))
            rec.t.append(ta.time)
            rec.v_before.append(v0)
            rec.v_after.append(va)
            v0 = va
        ta.state[:] = P.array([x0, v0])
        ta.reset_cooldowns()
        return ta, rec

    def solve(self, params: Params, periods: int, per_period: int = 0) -> Trajectory:
        """Integrate ``periods`` forcing periods from ``(params.x0, params.v0)`` at ``params.t0``.

        Returns stroboscopic samples at ``t0 + k T`` (``k = 0..periods``), every
        impact, and ``per_period`` dense points per period if ``per_period > 0``.
        An impact that lands exactly on a sample time is applied before the sample
        (samples are right-continuous).
        """
        periods = check_count(periods, "periods")
        per_period = check_count(per_period, "per_period", 100_000)
        P = self.precision
        step = max(per_period, 1)
        grid = P.sample_times(params.t0, params.eta, periods, step)
        ta, rec = self._prepare(params)
        grid_arr = P.array(grid)
        t_start = _time.perf_counter()
        res = ta.propagate_grid(grid_arr)
        elapsed = _time.perf_counter() - t_start
        outcome, n_steps, states = res[0], res[3], res[-1]
        import heyoka as hy

        if rec.exceeded:
            raise BudgetExceededError(
                f"impact budget max_impacts={self.max_impacts} exhausted at t={P.to_str(ta.time)} "
                "(chattering/Zeno sequence?); raise max_impacts or check the parameters"
            )
        if outcome != hy.taylor_outcome.time_limit:
            raise RuntimeError(f"heyoka stopped early with outcome {outcome} at t={P.to_str(ta.time)}")
        states = np.asarray(states)
        xs, vs = states[:, 0], states[:, 1]
        traj = Trajectory(
            params=params,
            model=self.model_name,
            precision=P,
            tol=self.tol if self.tol is not None else P.eps,
            t=grid_arr[::step],
            x=xs[::step].copy(),
            v=vs[::step].copy(),
            impacts_t=P.array(rec.t),
            impacts_v_before=P.array(rec.v_before),
            impacts_v_after=P.array(rec.v_after),
            elapsed_s=elapsed,
            stats={"steps": int(n_steps)},
        )
        if per_period > 0:
            traj.dense_t, traj.dense_x, traj.dense_v = grid_arr, xs.copy(), vs.copy()
        return traj
