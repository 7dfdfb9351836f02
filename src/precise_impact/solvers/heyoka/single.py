"""Ground truth: heyoka's adaptive Taylor integrator with event detection.

The flow of :func:`~precise_impact.core.flow.acceleration` with the impact as a terminal event;
chattering is extrapolated to its accumulation time and sticking resolved in closed form
(Budd & Dux 1994; di Bernardo et al. 2008).  Event-detection details: ``docs/numerics.rst``.
"""

from __future__ import annotations

import bisect
import math
import threading
import time as _time
from collections.abc import Callable
from fractions import Fraction
from typing import Any

import mpmath
import numpy as np
from mpmath import libmp

from precise_impact.core.flow import acceleration
from precise_impact.core.impact import (
    GrazingDepth,
    chatter_accumulation_time,
    elastic_bounce_count,
    elastic_bounce_text,
    grazing_depth_coefficient,
    impact_at_start,
    is_contact,
    pushes_into_wall,
    release_time,
    reset_velocity,
    steady_amplitude,
    wall_acceleration,
)
from precise_impact.core.mpcontext import mp_context, mp_import
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
from precise_impact.core.precision import Precision
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import BudgetExceededError, IntegrationError, Interrupted, ParameterError
from precise_impact.solvers.heyoka.cache import IntegratorCache
from precise_impact.solvers.heyoka.events import ImpactRecorder

__all__ = ["HeyokaSolver", "build_integrator", "OrbitStepper"]


#: Forcing periods per ``propagate_grid`` call (progress, interrupt and partial results
#: happen between chunks).  Runs of up to this many periods are one call, as before.
CHUNK_PERIODS = 1000

#: Guard bits of every mpmath evaluation of the wall force, release and accumulation times.
_GUARD_BITS = 64


class _ImpactRecorder(ImpactRecorder):
    """Terminal-event callback: applies the impact map and records the impact
    (:class:`~precise_impact.solvers.heyoka.events.ImpactRecorder`).

    heyoka deep-copies the callback into the integrator, so results are read back
    from ``ta.t_events[0].callback`` (the integrator's copy), never from the object
    passed to the constructor.

    With a ``watch`` (set by :class:`HeyokaSolver`, see :meth:`reset`) the
    integration also stops at an impact that leaves the mass at rest on the wall
    (``v_after == 0``, i.e. ``R = 0``; ``stop_reason = 'rest'``) and when the watch
    reports the end of a chattering sequence (``stop_reason = 'chatter'``).  And an
    event at exactly ``contact_t``, the instant the mass was last put at rest on
    the wall, is not an impact: a free flight that starts from ``(x_w, 0)`` has a
    double root of ``x - x_w`` at its start, and heyoka reported it as an event
    with a rounding-level speed (measured: ~120 eps in float64 and at 128 bits,
    after plastic impacts) until such flights were started a rounding distance
    below the wall (see the module docstring); kept as a safeguard.  Such an
    event restores ``(x_w, 0)``, is counted in ``spurious`` (and against the
    budget) and not recorded; heyoka's cooldown then keeps it from recurring.  Without a
    watch (the default; other users of :func:`build_integrator`) the recorder is a plain
    impact recorder.
    """

    def __init__(self) -> None:
        super().__init__()
        self.reset(10**6)

    @property
    def spurious(self) -> int:
        """Events discarded at the instant the mass was put at rest (charged to the budget)."""
        return self.charged

    def reset(self, max_impacts: int, watch: _ZenoWatch | None = None) -> None:
        self.reset_log(max_impacts)
        self.watch = watch
        self.stop_reason: str | None = None
        self.contact_t: Any = None
        self.spurious_v = 0.0
        self.depth = None  # a GrazingDepth enables the contact rule (set by HeyokaSolver.solve)
        self.cos = np.cos
        self.f64 = (
            None  # float64: the runtime parameters as Python floats (set by HeyokaSolver.solve)
        )
        self.grazing = 0

    def __call__(self, ta, d_sgn) -> bool:
        st = ta.state
        f = self.f64
        if f is not None:  # float64: Python floats (numpy scalars cost several times more)
            pars = f
            vb = st.tolist()[1]
        else:
            pars = ta.pars
            vb = st[1]
        t = ta.time
        x_w = pars[I_XW]
        if self.watch is not None and t == self.contact_t and abs(float(vb)) <= self.spurious_v:
            st[0] = x_w
            st[1] = 0 * vb
            if not self.charge():
                self.stop_reason = "budget"
                return False
            return True
        if self.depth is not None:
            acc = acceleration(t, x_w, vb, pars[I_ETA], pars[I_ZETA], pars[I_A], self.cos)
            if is_contact(vb, acc, self.depth(t, pars)):
                # a tangential contact within rounding of the wall: not an impact
                # (same rule as the variational LLE and the robust analytical finder)
                self.grazing += 1
                return True
        va = reset_velocity(vb, pars[I_R])
        # The event fixes the impact instant; the position there is the wall by
        # definition (eq. 2b).  The root finder leaves x within O(eps) of x_w.
        st[1] = va
        st[0] = x_w
        if not self.record(t, vb, va):
            self.stop_reason = "budget"
            return False
        watch = self.watch
        if watch is not None:
            if va == 0:
                self.contact_t = t
                self.stop_reason = "rest"
                return False
            if watch.can_chatter and watch.observe(t, vb):
                self.stop_reason = "bounce" if watch.refusal else "chatter"
                return False
        return True


#: Compiled oscillator integrators (one per precision, tolerance and mode), copied to each caller.
INTEGRATORS = IntegratorCache("oscillator")


def build_integrator(
    precision: Precision, tol: Any = None, high_accuracy: bool = False, compact_mode: bool = False
):
    """A heyoka integrator for the oscillator, owned by the caller.

    Compiled once per ``(precision, tol, high_accuracy, compact_mode)`` and process
    (:class:`~precise_impact.solvers.heyoka.cache.IntegratorCache`); every call returns a
    private copy, so callers may reset time, state, parameters and the callback
    freely and use copies from different threads.  The integrator's runtime
    parameters are ordered as ``RUNTIME_PARAMS`` = ``(eta, zeta, a, R, x_w)``.
    """
    key = (
        precision.name,
        None if tol is None else precision.to_str(tol),
        high_accuracy,
        compact_mode,
    )

    def compile_():
        import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

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
        return hy.taylor_adaptive(
            [(x, v), (v, rhs)],
            [zero, zero],
            pars=[zero] * len(RUNTIME_PARAMS),
            t_events=[ev],
            high_accuracy=high_accuracy,
            compact_mode=compact_mode,
            **extra,
            **kw,
        )

    return INTEGRATORS.get(key, compile_)


# --------------------------------------------------------------------------- the wall
def _mpq(q: Fraction, ctx: Any) -> Any:
    """``q`` in the mpmath context ``ctx`` (one rounding at its precision)."""
    return ctx.mpf(q.numerator) / q.denominator


def _extra_bits(tm: mpmath.mpf) -> int:
    """Guard bits for evaluating trigonometric functions of ``eta t`` with ``|t| ~ tm``."""
    return _GUARD_BITS + (max(0, int(mpmath.mag(tm))) if tm else 0)


def _round_up(P: Precision, m: mpmath.mpf) -> Any:
    """The smallest number of precision ``P`` that is ``>= m`` (one directed rounding)."""
    return P._from_mpf_exact(
        mpmath.mp.make_mpf(libmp.normalize(*m._mpf_, P.bits, libmp.round_ceiling))
    )


class _Wall:
    """Sticking decision and release time for one run, in mpmath with guard bits.

    Times come in as numbers of the working precision ``P`` and are converted
    exactly (into mpmath contexts of this thread's own, :mod:`precise_impact.core.mpcontext`:
    mpmath's global precision is shared by every thread); the release time is computed at
    ``P.bits + 64`` bits plus the bits of ``|t|`` and rounded *up* to ``P``, so that the force
    at the returned instant is already ``<= 0`` (the released mass does not start inside the
    wall).
    """

    def __init__(self, P: Precision, params: Params) -> None:
        self.P = P
        self.params = params

    def prec(self, tm: mpmath.mpf) -> int:
        return self.P.bits + _extra_bits(tm)

    def sticks(self, t: Any) -> bool:
        """Does a mass at rest on the wall at ``t`` stay there (force into the wall)?"""
        p = self.params
        tm = self.P.to_mpf(t)
        return pushes_into_wall(tm, p.eta, p.a, p.x_w, ctx=mp_context(self.prec(tm)))

    def release(self, t: Any) -> Any:
        """Release time (working precision) after sticking at ``t``, or ``None`` (never)."""
        p = self.params
        tm = self.P.to_mpf(t)
        tr = release_time(tm, p.eta, p.a, p.x_w, ctx=mp_context(self.prec(tm) + 8))
        if tr is None:
            return None
        return _round_up(self.P, tr)


class _ZenoWatch:
    """Recognises a chattering (Zeno) impact sequence and extrapolates its accumulation time.

    Called by the impact callback after every impact with the impact time ``t_k``
    and speed ``v_k`` (both of the working precision).  A *run* is a sequence of
    impacts with

    * a net force into the wall, ``g = a cos(eta t_k) - x_w > 0``,
    * a short next flight, ``2 R v_k / g <= flight_fraction / max(1, eta)``,
    * impact speeds shrinking by ``R``: ``|v_k / v_{k-1} / R - 1| <= ratio_tol``.

    For each impact of a run the constant-force estimate of the accumulation
    time, ``F_k = t_k + 2 R v_k / (g(t_k) (1 - R))``, is formed in mpmath (working
    bits + 64).  Its error is a power series ``sum_{p >= 2} c_p R^(p k)`` (the
    flights shrink by ``R``, the relative error of the constant-force model is
    O(flight)), so the Richardson table ``T[k, j] = (T[k, j-1] - R^(j+1) T[k-1, j-1])
    / (1 - R^(j+1))`` removes one term per column.  With
    ``noise = tol_factor * tol * max(1, |t_k|)``
    (``tol`` = the solver's tolerance, at least eps: the impact times carry a few
    ulps of error) the estimate is *converged* when, in the lowest column where
    this happens, the last two changes from row to row are both ``<= noise``; the
    lowest column is preferred because column ``j`` amplifies the noise by
    ``(1 + R^(j+1)) / (1 - R^(j+1))``.  Measured against the exact accumulation
    time of the undamped, unforced case (``tests/test_chattering.py``): errors of
    0.1-7.4 eps * t for R = 0.5, 0.8, 0.9 in float64 ... mp:256, after
    12-72 impacts in float64 and 30-335 at 256 bits (about
    ``0.2 digits / log10(1/R)``).

    The watch asks the integration to stop (returns ``True``) when

    * the estimate has converged, the force stays positive up to it (the next
      release time is later: otherwise the chattering is incomplete and the
      integration simply goes on), and no output time lies between the last
      impact and the accumulation time (otherwise heyoka resolves more impacts
      until the window is empty); or
    * the impact speed falls below ``v_floor = sqrt(500 eps max(1, |a|, |x_w|) g) / R``,
      where heyoka's event cooldown would come within a factor 100 of the next
      flight time.  Output times left inside the window then take the
      constant-force model of the remaining flights (error ~ ``v_floor * flight``).
      For ``R = 1`` this floor is the only stop: the mass is then taken to be at
      rest (its speed is below ``v_floor``).

    ``result`` then holds the accumulation time and its diagnostics.
    """

    LEVELS = 8
    flight_fraction = 0.1
    ratio_tol = 0.25
    tol_factor = 4

    def __init__(self, P: Precision, params: Params, tol: Fraction, grid: list) -> None:
        self.P = P
        self.params = params
        self.grid = grid
        self.R = params.R
        self.Rf = float(params.R)
        self.eta_f, self.a_f, self.xw_f = float(params.eta), float(params.a), float(params.x_w)
        self.omega = max(1.0, self.eta_f)
        #: The wall force ``a cos(eta t) - x_w`` can push into the wall (``|a| > x_w``):
        #: otherwise no run can start and :meth:`observe` is never needed.
        self.can_chatter = abs(params.a) > params.x_w
        self.scale = max(1.0, abs(self.a_f), abs(self.xw_f))
        self.eps_f = P.eps_float
        self.tol_f = max(float(tol), self.eps_f)
        self.result: dict | None = None
        self.refusal: str | None = None
        #: Set by the solver: impacts left in the budget (a callable) and the budget.
        self.budget_left: Callable[[], int] | None = None
        self.max_impacts = None
        self.clear_run()

    def clear_run(self) -> None:
        self.predicted = False
        self.run_n = 0
        self.prev_v: float | None = None
        self.row: list = []
        self.diff: list = []
        self.best = None
        self.best_err = math.inf
        self.result = None

    # -- helpers --------------------------------------------------------------------
    def _prec(self, tm) -> int:
        return self.P.bits + _extra_bits(tm)

    def _richardson(self, F, noise: float, ctx: Any) -> tuple:
        """Append ``F`` as a new row of the table; return ``(estimate, change, converged)``.

        The estimate is the entry of the *lowest* column whose last two changes
        are both ``<= noise`` (converged), else the entry with the smallest last
        change (not converged).
        """
        Rm = _mpq(self.R, ctx)
        prev, prev_diff = self.row, self.diff
        row = [F]
        for j in range(1, min(len(prev), self.LEVELS) + 1):
            q = Rm ** (j + 1)
            row.append((row[j - 1] - q * prev[j - 1]) / (1 - q))
        diff = [float(abs(row[j] - prev[j])) for j in range(min(len(prev), len(row)))]
        self.row, self.diff = row, diff
        best, best_d = F, math.inf
        for j, d in enumerate(diff):
            if d <= noise and j < len(prev_diff) and prev_diff[j] <= noise:
                return row[j], max(d, prev_diff[j]), True
            if d < best_d:
                best, best_d = row[j], d
        return best, best_d, False

    def window_has_output(self, t: Any, t_inf: Any) -> bool:
        """Is there an output time ``s`` with ``t < s < t_inf``?"""
        i = bisect.bisect_right(self.grid, t)
        return i < len(self.grid) and self.grid[i] < t_inf

    def elastic_bounces(self, t: float, v: float) -> tuple[float, str]:
        """Predicted impacts of an ``R = 1`` bounce sequence on the wall from impact ``(t, v)``
        until the run's end: :func:`~precise_impact.core.impact.elastic_bounce_count`.
        Returns ``(count, what ends it)``; ``inf`` when the count passes 1e18."""
        n, end, s = elastic_bounce_count(
            t,
            v,
            float(self.grid[-1]),
            self.eta_f,
            float(self.params.zeta),
            self.a_f,
            self.xw_f,
            self.eps_f,
        )
        return n, elastic_bounce_text(end, s)

    # -- called by the impact callback ------------------------------------------------
    def observe(self, t: Any, vb: Any) -> bool:
        tf, vf = float(t), float(vb)
        g = self.a_f * math.cos(self.eta_f * tf) - self.xw_f
        if not (g > 0 and vf > 0):
            self.clear_run()
            return False
        R = self.Rf
        v_floor = math.sqrt(500.0 * self.eps_f * self.scale * g) / R
        at_floor = vf < v_floor
        if R >= 1:
            return self._observe_elastic(t, vb, tf, vf, g, at_floor)
        short = 2 * R * vf / g * self.omega <= self.flight_fraction
        if not short and not at_floor:
            self.clear_run()
            return False
        if self.prev_v is not None and abs(vf / self.prev_v / R - 1) > self.ratio_tol:
            self.clear_run()
        self.prev_v = vf
        self.run_n += 1
        return self._observe_chattering(t, vb, tf, at_floor)

    def _observe_elastic(
        self, t: Any, vb: Any, tf: float, vf: float, g: float, at_floor: bool
    ) -> bool:
        """:meth:`observe` for R >= 1: rest at the speed floor, or a refusal when the predicted
        bounces of a run of short flights exceed the impact budget."""
        if at_floor:
            self._finish(t, vb, None, at_floor=True)
            return True
        short = 2 * vf / g * self.omega <= self.flight_fraction
        if short and not self.predicted and self.budget_left is not None:
            self.predicted = True  # once per run of short bounces
            n, until = self.elastic_bounces(tf, vf)
            if n > self.budget_left():
                self.refusal = (
                    f"R = 1 with the net force into the wall from t = {tf:.6g}: the mass "
                    "bounces on the wall with speeds decaying like exp(-2 zeta t / 3) and "
                    "ever shorter flights (not Zeno: the impacts never accumulate, there is "
                    f"no sticking); reaching {until} takes ~{n:.2g} more impacts, over the "
                    f"budget max_impacts = {self.max_impacts}; raise max_impacts, shorten "
                    "the run or use R < 1"
                )
                return True
        return False

    def _observe_chattering(self, t: Any, vb: Any, tf: float, at_floor: bool) -> bool:
        """:meth:`observe` for R < 1 inside a run of short flights: the accumulation time
        extrapolated; True (episode finished) once it is converged or at the speed floor."""
        p = self.params
        P = self.P
        tm = P.to_mpf(t)
        ctx = mp_context(self._prec(tm))
        tm, vm = mp_import(ctx, tm), mp_import(ctx, P.to_mpf(vb))
        gm = wall_acceleration(
            tm, _mpq(p.eta, ctx), _mpq(p.zeta, ctx), _mpq(p.a, ctx), _mpq(p.x_w, ctx), ctx.cos
        )
        F = chatter_accumulation_time(tm, vm, _mpq(self.R, ctx), gm)
        noise = self.tol_factor * self.tol_f * max(1.0, abs(tf))
        est, err, converged = self._richardson(F, noise, ctx)
        converged = converged and self.run_n >= 3
        if self.run_n >= 3:
            self.best, self.best_err = est, err
        if not (converged or at_floor):
            return False
        t_rel = release_time(tm, p.eta, p.a, p.x_w, ctx=ctx)
        t_inf_m = self.best if self.best is not None else F
        if t_rel is not None and t_inf_m >= t_rel:
            if not at_floor:
                return False  # incomplete chattering: the force turns before t_inf
            t_inf_m = t_rel
        t_inf = P.from_mpf(t_inf_m)
        if t_inf < t:
            t_inf = t
        if not at_floor and self.window_has_output(t, t_inf):
            return False  # resolve more impacts: an output time lies in the tail
        self._finish(t, vb, gm, at_floor=at_floor, t_inf=t_inf, err=self.best_err)
        return True

    def _finish(self, t, vb, g, at_floor, t_inf=None, err=math.inf) -> None:
        self.result = {
            "t_accumulation": t if t_inf is None else t_inf,
            "t_last_impact": t,
            "v_last_impact": vb,
            "g": g,
            "run_impacts": self.run_n,
            "error_estimate": err,
            "floor": at_floor,
        }

    # -- output inside an unresolved tail ------------------------------------------------
    def tail_state(self, s: Any) -> tuple:
        """State at output time ``s`` between the last resolved impact and ``t_inf``.

        Constant-force model of the remaining flights: from ``(t_k, x_w, -R v_k)``
        each flight lasts ``2 w / g`` and the next starts with ``w R``; inside a
        flight ``x = x_w - w s + g s^2 / 2``, ``v = -w + g s``.  Used only when the
        speed floor stopped the watch (error ~ ``v_floor * flight``).
        """
        P, z = self.P, self.result
        assert z is not None  # called only after the watch stopped (result set)
        x_w = P.from_fraction(self.params.x_w)
        zero = P.from_fraction(Fraction(0))
        if z["g"] is None:  # R = 1 at the floor: taken to be at rest
            return x_w, zero
        sm = P.to_mpf(s)
        ctx = mp_context(self._prec(sm))
        sm = mp_import(ctx, sm)
        Rm, g = _mpq(self.R, ctx), mp_import(ctx, z["g"])
        w = Rm * P.to_mpf(z["v_last_impact"])
        tm = mp_import(ctx, P.to_mpf(z["t_last_impact"]))
        tiny = ctx.mpf(self.eps_f) * self.scale / 1024  # (x_w, 0) to within eps
        while w > tiny:
            tau = 2 * w / g
            if tm + tau > sm:
                break
            tm += tau
            w *= Rm
        else:
            return x_w, zero
        sig = sm - tm
        xw = _mpq(self.params.x_w, ctx)
        x = min(xw - w * sig + g * sig * sig / 2, xw)
        v = -w + g * sig
        return P.from_mpf(x), P.from_mpf(v)


def _below_wall(P: Precision, x_w: Fraction) -> Any:
    """``x_w - eps max(1, |x_w|)`` rounded down to ``P``: a rounding-level distance inside the
    allowed region."""
    ctx = mp_context(P.bits + _GUARD_BITS)
    m = mp_import(ctx, P.to_mpf(P.from_fraction(x_w)))
    m = m - ctx.mpf(P.eps_fraction.numerator) / P.eps_fraction.denominator * max(1, abs(m))
    return P._from_mpf_exact(
        mpmath.mp.make_mpf(libmp.normalize(*m._mpf_, P.bits, libmp.round_floor))
    )


def _pad_time(P: Precision, grid: list, eta: Fraction, per_period: int) -> Any:
    """An output time one output spacing after the last one (working precision).

    Integrating past the end time puts an impact that falls exactly on it inside
    a step, where heyoka detects it (at the end of the last step it does not).
    A whole spacing rather than a fraction: the step containing such an impact
    is then rarely shortened by the padding, so its computed time does not
    depend on the padding.
    """
    ctx = mp_context(P.bits + _extra_bits(P.to_mpf(grid[-1])))
    spacing = 2 * ctx.pi / _mpq(eta, ctx) / per_period
    return P.from_mpf(mp_import(ctx, P.to_mpf(grid[-1])) + spacing)


# --------------------------------------------------------------------------- solver
class HeyokaSolver:
    """heyoka Taylor integrator with impact events: the reference solver.

    Parameters
    ----------
    precision : str or Precision, default ``'float64'``
        ``'float64'``, ``'longdouble'``, ``'float128'`` or ``'mp:BITS'`` (BITS >= 64).
    tol : decimal string / Fraction / number or None, default ``None``
        Relative and absolute tolerance of the Taylor method; ``None`` means the
        precision's epsilon (heyoka's default; Biscani & Izzo, MNRAS 504, 2021,
        sec. 3: order and step chosen so the truncation error is below ``tol``).
        Also scales the convergence test of the chattering extrapolation.
    high_accuracy : bool, default ``False``
        heyoka's compensated-summation mode for very long integrations.
    compact_mode : bool or None, default ``None``
        heyoka's compact mode (much faster compilation, somewhat slower run);
        ``None`` means on for ``mp:BITS`` (measured: 256-bit unrolled compilation
        takes minutes, compact 0.3 s) and off otherwise.
    max_impacts : int, default ``10**6``
        Impact budget: the integration stops with :class:`BudgetExceededError`
        when this many impacts have been recorded (counting an impact at ``t0``).
        Chattering sequences are cut short by the accumulation-time
        extrapolation below, so they do not exhaust it.
    max_steps : int or None, default ``None``
        Step budget: more heyoka Taylor steps than this (summed over all free
        flights) raise :class:`BudgetExceededError` instead of integrating on.
        ``None`` means ``10**5 * (periods + 1) + 2 * max_impacts`` (a period
        takes ~20-300 steps; every impact ends a step).

    See Also
    --------
    precise_impact.solvers.base.Solver : the protocol it follows.
    precise_impact.solvers.closed_form.AnalyticalSolver : the closed-form model.
    precise_impact.solvers.simulate.simulate : runs it for ``model='heyoka'``.

    Notes
    -----
    Conventions:

    * Samples (and dense output) are right-continuous: an output time equal to an
      impact time holds the post-impact state; one inside a sticking interval,
      at its ends included, holds ``(x_w, 0)``.
    * A start on the wall (``x0 = x_w``) moving into it (``v0 > 0``) is an impact at
      ``t0``; at rest (``v0 = 0``) it sticks if the wall force
      ``a cos(eta t0) - x_w`` pushes into the wall (or is zero and about to), else
      flies; moving away (``v0 < 0``) it flies.
    * Chattering (``R < 1``): see the module docstring and :class:`_ZenoWatch`.  The
      impacts resolved before the jump to the accumulation time are recorded
      (finitely many); the infinitely many that follow are not.  ``stats``:

      - ``'steps'``: heyoka steps taken; ``'max_steps'``: the step budget;
      - ``'chattering'``: one dict per chattering sequence cut short:
        ``t_accumulation`` and ``t_last_impact`` (working precision),
        ``run_impacts`` (impacts of the geometric run that was extrapolated),
        ``episode_impacts`` (impacts since the free flight began),
        ``error_estimate`` (float: last change of the Richardson estimate),
        ``floor`` (``True`` if stopped by the speed floor rather than by
        convergence);
      - ``'sticking'``: list of ``(t_start, t_release)`` (working precision;
        ``t_release`` is ``None`` if the force never turns);
      - ``'tail_samples'``: output times that fell inside an unresolved
        chattering tail (model values, see :meth:`_ZenoWatch.tail_state`);
      - ``'spurious_contacts'``: events at the very instant the mass was put
        at rest on the wall, discarded (see :class:`_ImpactRecorder`).

    References
    ----------
    * C. J. Budd, F. Dux, *Chattering and related behaviour in impact
      oscillators*, Phil. Trans. R. Soc. A 347 (1994) 365-389 (chattering,
      geometric impact sequences and their accumulation time, sticking).
    * A. B. Nordmark, *Non-periodic motion caused by grazing incidence in an
      impact oscillator*, J. Sound Vib. 145 (1991) 279-297 (low-velocity impacts).
    * M. di Bernardo, C. J. Budd, A. R. Champneys, P. Kowalczyk,
      *Piecewise-smooth Dynamical Systems*, Springer 2008 (impacting hybrid
      systems, chattering, the sticking region and release).
    """

    model_name = "heyoka"

    def __init__(
        self,
        precision: str | Precision = "float64",
        tol: Any = None,
        high_accuracy: bool = False,
        compact_mode: bool | None = None,
        max_impacts: int = 10**6,
        max_steps: int | None = None,
    ) -> None:
        self.precision = Precision.parse(precision)
        self.tol_exact = self.precision.check_tol(tol)
        self.tol = None if self.tol_exact is None else self.precision.from_fraction(self.tol_exact)
        if isinstance(max_impacts, bool) or not isinstance(max_impacts, int) or max_impacts < 1:
            raise ParameterError(
                "max_impacts", max_impacts, "impact budget must be an integer >= 1"
            )
        if max_steps is not None and (
            isinstance(max_steps, bool) or not isinstance(max_steps, int) or max_steps < 1
        ):
            raise ParameterError(
                "max_steps", max_steps, "step budget must be None or an integer >= 1"
            )
        self.high_accuracy = bool(high_accuracy)
        # Multiprecision Taylor orders are high (~90 at 256 bits); unrolled code
        # then takes minutes to compile, compact mode a fraction of a second.
        self.compact_mode = (
            (self.precision.kind == "mp") if compact_mode is None else bool(compact_mode)
        )
        self.max_impacts = max_impacts
        self.max_steps = max_steps
        self._ta = None
        self._lock = threading.Lock()

    def __getstate__(self) -> dict:
        # The owned integrator and the lock stay with this process/object.
        state = self.__dict__.copy()
        state["_ta"], state["_lock"] = None, None
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()

    def integrator(self):
        """The heyoka integrator this solver owns (a private copy of the compiled one).

        Made on first use and reused by every :meth:`solve` of this object; solves of
        one object from several threads take turns (a lock), solves of different
        objects run in parallel.
        """
        if self._ta is None:
            self._ta = build_integrator(
                self.precision, self.tol, self.high_accuracy, self.compact_mode
            )
        return self._ta

    def busy(self) -> bool:
        """True while a :meth:`solve` of this object runs (in any thread)."""
        return self._lock.locked()

    def step_budget(self, periods: int) -> int:
        """The step budget of a run of ``periods`` periods (see ``max_steps``)."""
        if self.max_steps is not None:
            return self.max_steps
        return 10**5 * (periods + 1) + 2 * self.max_impacts

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
            rec.log(ta.time, v0, va)
            v0 = va
        ta.state[:] = P.array([x0, v0])
        ta.reset_cooldowns()
        return ta, rec

    def solve(
        self, params: Params, periods: int, per_period: int = 0, *, progress: Any = None
    ) -> Trajectory:
        """Integrate ``periods`` forcing periods (see :meth:`_solve`); thread-safe.

        Parameters
        ----------
        params : Params
            System and initial condition (converted once into this solver's precision).
        periods : int
            Forcing periods; stroboscopic samples at ``t0 + k 2 pi / eta``,
            ``k = 0..periods``.
        per_period : int, default 0
            Dense output points per period (0: none).
        progress : callable or None, default ``None``
            Called as ``progress(periods_done, periods)`` after every chunk of
            :data:`CHUNK_PERIODS` periods
            (e.g. :meth:`~precise_impact.io.progress.Progress.update`).

        Returns
        -------
        Trajectory
            Samples, impacts (time, velocities before and after) and ``stats``.

        Notes
        -----
        The run is integrated in chunks of :data:`CHUNK_PERIODS` forcing periods (one
        ``propagate_grid`` each; a run of up to that many periods is one call).  A
        ``KeyboardInterrupt`` (Ctrl-C, or SIGTERM through the CLI)
        raises :class:`~precise_impact.errors.Interrupted` whose ``partial`` is the
        trajectory up to the last finished chunk (``stats['partial'] = True``).

        Raises
        ------
        ParameterError
            Bad input, before any work.
        BudgetExceededError
            An impact or step budget was exhausted (e.g. a Zeno impact sequence).
        IntegrationError
            heyoka stopped with a non-finite state or an error outcome.

        References
        ----------
        .. [1] F. Biscani, D. Izzo, "Revisiting high-order Taylor methods for
               astrodynamics and celestial mechanics", MNRAS 504 (2021) 2614.
        """
        with self._lock:
            return self._solve(params, periods, per_period, progress)

    def _solve(
        self, params: Params, periods: int, per_period: int = 0, progress: Any = None
    ) -> Trajectory:
        """Integrate ``periods`` forcing periods from ``(params.x0, params.v0)`` at ``params.t0``.

        Returns stroboscopic samples at ``t0 + k T`` (``k = 0..periods``), every
        resolved impact, and ``per_period`` dense points per period if
        ``per_period > 0``.  Samples are right-continuous (an impact that lands
        exactly on a sample time is applied before the sample); see the class
        docstring for sticking, chattering and ``stats``.  Raises
        :class:`BudgetExceededError` when ``max_impacts`` or the step budget is
        exhausted.
        """
        periods = check_count(periods, "periods")
        per_period = check_count(per_period, "per_period", 100_000)
        P = self.precision
        step = max(per_period, 1)
        grid = P.sample_times(params.t0, params.eta, periods, step)
        n_out = len(grid)
        # One output time past the end, so that an impact exactly at the end time
        # lies inside a step (heyoka does not detect an event at the very end of
        # the last step); everything past t_end is discarded below.
        run_grid = grid + [_pad_time(P, grid, params.eta, step)]
        max_steps = self.step_budget(periods)
        ta, rec = self._prepare(params)
        watch = _ZenoWatch(
            P, params, self.tol_exact if self.tol_exact is not None else P.eps_fraction, run_grid
        )
        rec.watch = watch
        watch.max_impacts = rec.max_impacts
        watch.budget_left = lambda: rec.max_impacts - rec.count - rec.charged
        if params.x0 == params.x_w:
            rec.contact_t = ta.time  # a start on the wall
        rec.spurious_v = math.sqrt(P.eps_float) * max(
            1.0, abs(float(params.a)), abs(float(params.x_w))
        )
        coef, amp = grazing_depth_coefficient(P), Fraction(steady_amplitude(params))
        if P.kind == "float64":
            rec.depth, rec.cos = GrazingDepth(float(coef), float(amp)), math.cos
            rec.f64 = ta.pars.tolist()
        else:
            rec.depth, rec.cos = GrazingDepth(P.from_fraction(coef), P.from_fraction(amp)), np.cos
        t_start = _time.perf_counter()
        live: dict = {"done": 0}
        chunk = CHUNK_PERIODS * step
        if progress is not None:
            live["progress"] = lambda i: progress(min(i, n_out - 1) // step, periods)
        try:
            xs, vs, stats = self._run(
                ta, rec, watch, params, run_grid, max_steps, n_out, chunk, live
            )
        except KeyboardInterrupt as e:
            done = (min(live["done"], n_out) - 1) // step * step + 1  # whole periods only
            if done < 1 + step:
                raise
            xs, vs = live["xs"][:done], live["vs"][:done]
            stats = {"partial": True, "periods_done": (done - 1) // step, "periods_asked": periods}
            part = self._trajectory(
                params,
                grid[:done],
                xs,
                vs,
                rec,
                stats,
                step,
                per_period,
                _time.perf_counter() - t_start,
            )
            raise Interrupted(
                f"interrupted after {(done - 1) // step} of {periods} periods", part
            ) from e
        finally:
            rec.watch = None  # leave a plain recorder behind for the next solve
            rec.depth = rec.f64 = None
        stats["grazing"] = rec.grazing
        return self._trajectory(
            params,
            grid,
            xs[:n_out],
            vs[:n_out],
            rec,
            stats,
            step,
            per_period,
            _time.perf_counter() - t_start,
        )

    def _trajectory(
        self,
        params: Params,
        grid: list,
        xs: list,
        vs: list,
        rec,
        stats: dict,
        step: int,
        per_period: int,
        elapsed: float,
    ) -> Trajectory:
        """Trim the impacts to ``[t0, grid[-1]]``, make the samples right-continuous, wrap."""
        P = self.precision
        n_out, t_end = len(grid), grid[-1]
        # ---- trim to [t0, t_end] and make the output right-continuous
        k = bisect.bisect_right(rec.t, t_end)
        imp_t, imp_vb, imp_va = rec.t[:k], rec.v_before[:k], rec.v_after[:k]
        x_w = P.from_fraction(params.x_w)
        for tc, va in zip(imp_t, imp_va, strict=True):
            j = bisect.bisect_left(grid, tc)
            if j < n_out and grid[j] == tc:
                # heyoka's output at a grid time equal to an event time is the
                # pre-impact state in some precisions (longdouble, mp) and a
                # rounding-level post-impact one in others: set the post-impact state.
                xs[j], vs[j] = x_w, va
        if "chattering" in stats:
            stats["chattering"] = [z for z in stats["chattering"] if z["t_last_impact"] <= t_end]
            stats["sticking"] = [st for st in stats["sticking"] if st[0] <= t_end]
        grid_arr = P.array(grid)
        x_arr, v_arr = P.array(xs), P.array(vs)
        traj = Trajectory(
            params=params,
            model=self.model_name,
            precision=P,
            tol=self.tol if self.tol is not None else P.eps,
            t=grid_arr[::step],
            x=x_arr[::step].copy(),
            v=v_arr[::step].copy(),
            impacts_t=P.array(imp_t),
            impacts_v_before=P.array(imp_vb),
            impacts_v_after=P.array(imp_va),
            elapsed_s=elapsed,
            stats=stats,
        )
        if per_period > 0:
            traj.dense_t, traj.dense_x, traj.dense_v = grid_arr, x_arr, v_arr
        return traj

    def _run(
        self,
        ta,
        rec: _ImpactRecorder,
        watch: _ZenoWatch,
        params: Params,
        grid: list,
        max_steps: int,
        n_out: int,
        chunk: int,
        live: dict,
    ):
        """Free flights (heyoka) alternating with sticking phases (closed form).

        ``grid[:n_out]`` are the output times, ``grid[n_out:]`` the padding; a budget
        running out in the padding only ends the run.  Free flights are propagated
        over at most ``chunk`` output times at a time, ending at multiples of
        ``chunk``; ``live`` receives the sample lists and the count of finished
        samples (``'done'``) for progress and for a partial result on interrupt.
        """
        run = _Propagation(self, ta, rec, watch, params, grid, max_steps, n_out, chunk)
        live["xs"], live["vs"] = run.xs, run.vs
        report = live.get("progress")
        while run.i < run.n:
            live["done"] = run.i
            if report is not None:
                report(run.i)
            if not run.step():
                break
        live["done"] = run.i
        stats = {
            "steps": run.steps,
            "max_steps": max_steps,
            "chattering": run.chattering,
            "sticking": run.sticking,
            "tail_samples": run.tail_samples,
            "spurious_contacts": rec.spurious,
        }
        return run.xs, run.vs, stats

    def _steps_exceeded(self, max_steps: int, steps: int, ta) -> None:
        raise BudgetExceededError(
            f"step budget max_steps={max_steps} exhausted at t={self.precision.to_str(ta.time)} "
            f"after {steps} heyoka steps; raise max_steps or check the parameters"
        )


class _Propagation:
    """The state of one :meth:`HeyokaSolver._run`: the samples so far (``xs``, ``vs``, the next
    output index ``i``), the heyoka steps taken and the sticking and chattering episodes."""

    def __init__(
        self,
        solver: HeyokaSolver,
        ta,
        rec: _ImpactRecorder,
        watch: _ZenoWatch,
        params: Params,
        grid: list,
        max_steps: int,
        n_out: int,
        chunk: int,
    ) -> None:
        self.solver, self.ta, self.rec, self.watch = solver, ta, rec, watch
        self.grid, self.max_steps, self.n_out, self.chunk = grid, max_steps, n_out, chunk
        P = self.P = solver.precision
        self.wall = _Wall(P, params)
        self.x_w = P.from_fraction(params.x_w)
        self.x_below = _below_wall(P, params.x_w)
        self.zero = P.from_fraction(Fraction(0))
        self.n = n = len(grid)
        self.xs: list = [None] * n
        self.vs: list = [None] * n
        self.i = 0
        self.steps = 0
        self.sticking: list = []
        self.chattering: list = []
        self.tail_samples = 0
        self.flight_start = len(rec.t)

    def rest_on_wall(self, t: Any) -> None:
        ta = self.ta
        ta.time = t
        ta.state[:] = self.P.array([self.x_w, self.zero])
        ta.reset_cooldowns()
        self.rec.contact_t = t

    def step(self) -> bool:
        """One sticking phase or one free flight; False when the run ends."""
        ta = self.ta
        t_cur = ta.time
        # ---- at rest on the wall: stick while the force pushes into it
        if ta.state[0] == self.x_w and ta.state[1] == 0 and self.wall.sticks(t_cur):
            return self.stick(t_cur)
        return self.flight(t_cur)

    def stick(self, t_cur: Any) -> bool:
        """On the wall at rest until the release (the closed form); False if it never comes
        within the output times."""
        grid, n = self.grid, self.n
        t_rel = self.wall.release(t_cur)
        while self.i < n and (t_rel is None or grid[self.i] <= t_rel):
            self.xs[self.i], self.vs[self.i] = self.x_w, self.zero
            self.i += 1
        self.sticking.append((t_cur, t_rel))
        if t_rel is None or self.i >= n:
            return False
        self.rest_on_wall(t_rel)
        self.watch.clear_run()
        self.flight_start = len(self.rec.t)
        return True

    def flight(self, t_cur: Any) -> bool:
        """Free flight over the remaining output times (up to the end of the chunk); False when
        the run ends (a budget running out in the padding)."""
        P, ta, grid, n, i = self.P, self.ta, self.grid, self.n, self.i
        xs, vs, x_w = self.xs, self.vs, self.x_w
        if grid[i] < t_cur:
            raise RuntimeError(
                f"internal error: output time {P.to_str(grid[i])} before t={P.to_str(t_cur)}"
            )
        prepend = not (grid[i] == t_cur)  # propagate_grid must start at the current time
        remaining = self.max_steps - self.steps
        if remaining < 1 and i >= self.n_out:
            return False
        if remaining < 1:
            self.solver._steps_exceeded(self.max_steps, self.steps, ta)
        self.rec.stop_reason = None
        on_wall = ta.state[0] == x_w
        if on_wall:
            # Leaving the wall (v <= 0).  A root of x - x_w exactly at the start
            # of a fresh propagation makes heyoka miss the next root in the same
            # step (measured: x_w = 0.5, v = -0.05 went through the wall) or
            # report a spurious one; start a rounding-level distance below it.
            v_cur = ta.state[1]
            ta.state[0] = self.x_below
        # chunks end at output times k * chunk (fixed positions); a run of up to
        # CHUNK_PERIODS periods (+ the padding) stays one call
        chunk = self.chunk
        stop = n if n <= chunk + 2 else min(n, (i // chunk + 1) * chunk + 1)
        res = ta.propagate_grid(
            P.array(([t_cur] if prepend else []) + grid[i:stop]), max_steps=remaining
        )
        outcome, n_steps, states = res[0], res[3], res[-1]
        self.steps += int(n_steps)
        i_first = i
        rows = (
            states.tolist() if P.kind == "float64" else states
        )  # Python floats: exact for float64
        for row in rows[1:] if prepend else rows:
            xs[i], vs[i] = row[0], row[1]
            i += 1
        self.i = i
        if on_wall and not prepend and i > i_first:
            xs[i_first], vs[i_first] = x_w, v_cur  # the exact state at the start
        return self.after_flight(outcome)

    def after_flight(self, outcome: Any) -> bool:
        """Why the flight stopped: go on, end the run (False) or raise."""
        import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

        P, ta, rec, i, n_out = self.P, self.ta, self.rec, self.i, self.n_out
        if outcome == hy.taylor_outcome.time_limit:
            return True
        if i >= n_out and (outcome == hy.taylor_outcome.step_limit or rec.exceeded):
            return False  # every output time is done: the padding does not need finishing
        if outcome == hy.taylor_outcome.step_limit:
            self.solver._steps_exceeded(self.max_steps, self.steps, ta)
        if rec.exceeded:
            raise BudgetExceededError(
                f"impact budget max_impacts={self.solver.max_impacts} exhausted at "
                f"t={P.to_str(ta.time)} ({min(i, n_out)} of {n_out} output times done); "
                "raise max_impacts, ask for a shorter run or check the parameters "
                "(a Zeno sequence?)"
            )
        if rec.stop_reason == "bounce":
            raise BudgetExceededError(self.watch.refusal)
        if rec.stop_reason == "rest":
            return True
        if rec.stop_reason == "chatter":
            self.chatter_tail()
            return True
        raise IntegrationError(
            f"heyoka stopped early with outcome {outcome} at t={P.to_str(ta.time)}"
        )

    def chatter_tail(self) -> None:
        """The watch stopped at a converged chattering episode: the output times in its
        unresolved tail from the extrapolation, then rest on the wall at the accumulation."""
        watch, grid, n = self.watch, self.grid, self.n
        assert watch.result is not None  # the watch stopped: its result is set
        z = dict(watch.result)
        t_inf = z["t_accumulation"]
        while self.i < n and grid[self.i] < t_inf:
            self.xs[self.i], self.vs[self.i] = watch.tail_state(grid[self.i])
            self.tail_samples += 1
            self.i += 1
        z["episode_impacts"] = len(self.rec.t) - self.flight_start
        del z["g"]
        self.chattering.append(z)
        self.rest_on_wall(t_inf)
        watch.clear_run()


class OrbitStepper:
    """One heyoka integrator of :func:`build_integrator` and its impact recorder, driven
    impact by impact (the two-trajectory Lyapunov method's orbits).

    ``budget`` impacts at most between two :meth:`clear` calls (more raises
    :class:`~precise_impact.errors.BudgetExceededError`).
    """

    def __init__(self, ta, budget: int) -> None:
        self.ta = ta
        self.rec = ta.t_events[0].callback
        self.budget = budget

    @property
    def count(self) -> int:
        """Impacts since the recorder was last reset."""
        return self.rec.count

    def clear(self) -> None:
        self.rec.reset(self.budget)

    def _check(self, outcome, P: Precision) -> None:
        import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

        if self.rec.exceeded:
            raise BudgetExceededError(
                f"more than {self.budget} impacts within one forcing period at "
                f"t={P.to_str(self.ta.time)} (chattering/Zeno sequence?)"
            )
        if outcome != hy.taylor_outcome.time_limit:  # one CLI line, exit 3 (was a traceback)
            raise IntegrationError(
                f"heyoka stopped early with outcome {outcome} at t={P.to_str(self.ta.time)}"
            )

    def propagate_until(self, t: Any, P: Precision) -> None:
        res = self.ta.propagate_until(t)
        self._check(res[0], P)

    def step_to_impact(self, t_limit: Any, P: Precision) -> None:
        """Step until the next impact (inclusive) or ``t_limit``, whichever first.

        heyoka's ``step`` always stops at a terminal event, so after the loop the
        state is the post-impact state at the impact instant.
        """
        import heyoka as hy  # noqa: PLC0415 -- optional: heyoka loaded on first use (the module imports without it)

        n = self.count
        while self.count == n and self.ta.time < t_limit:
            outcome, _ = self.ta.step(max_delta_t=t_limit - self.ta.time)
            if outcome == hy.taylor_outcome.err_nf_state:
                raise RuntimeError(
                    f"heyoka step failed with outcome {outcome} at t={P.to_str(self.ta.time)}"
                )
            if self.rec.exceeded:
                self._check(hy.taylor_outcome.time_limit, P)

    def set_state(self, x: Any, v: Any, x_w: Any, R: Any) -> None:
        """Place the orbit at ``(x, v)`` at its current time; a start on the wall moving
        into it is an impact (recorded, as in ``HeyokaSolver``)."""
        if x == x_w and v > 0:
            vb, v = v, reset_velocity(v, R)
            self.rec.log(self.ta.time, vb, v)
        self.ta.state[0] = x
        self.ta.state[1] = v
        self.ta.reset_cooldowns()
