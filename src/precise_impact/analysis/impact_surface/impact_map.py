"""The impact map ``P: (phase, v) -> (next phase, next v)`` on the impact surface, its Jacobian
and its orbits.

Each impact point starts an engine exactly on the wall (``Params(x0=x_w, v0=v, t0=t)``);
chattering and sticking are reported as such, never as ordinary points
(``docs/guide/impact_map.rst``).
"""

from __future__ import annotations

import dataclasses
import functools
import gc
import time
from fractions import Fraction
from typing import Any

import mpmath
import numpy as np
from mpmath import libmp

from precise_impact.core import flight
from precise_impact.core.budget import check_work
from precise_impact.core.flow import acceleration
from precise_impact.core.impact import oscillator_saltation
from precise_impact.core.params import Params, as_params, exact
from precise_impact.core.result import ResultMixin
from precise_impact.errors import BudgetExceededError, CertificationError, ParameterError
from precise_impact.io.figures import finish, new_figure
from precise_impact.io.progress import Progress
from precise_impact.solvers.certified.single import certify
from precise_impact.solvers.simulate import simulate

__all__ = [
    "ENGINES",
    "ImpactEvent",
    "ImpactMapResult",
    "impact_map",
    "impact_map_jacobian",
    "impact_map_orbit",
]

#: Engine names -> (model, precision) of :func:`~precise_impact.solvers.simulate.simulate`.
ENGINES = {
    "closed-form": ("analytical", "mp:200"),
    "fast": ("fast", "float64"),
    "heyoka": ("heyoka", "float64"),
    "certified": ("certified", "mp:192"),
}

#: Seconds per event of each engine, measured on this project's 2-core machine (eta = 0.74,
#: start (0.3, 1.0), warm): closed-form 1000 in 34 s (34 ms; 20 in 0.84 s, 42 ms), certified
#: 5 in 0.40 s (79 ms); the compiled path (benchmarks/results/impact_map.md, loaded machine):
#: fast 74,600 events/s (13 us), heyoka 9,500/s (0.1 ms); priced rounded up.  The bits of the
#: mp engines scale it (priced as at their default).
SECONDS_PER_EVENT = {"closed-form": 0.05, "fast": 2e-5, "heyoka": 2e-4, "certified": 0.1}
#: Bytes held per event (an :class:`ImpactEvent`, its fractions and the result's columns).
BYTES_PER_EVENT = 2000.0

#: Event kinds.
IMPACT, CHATTER, STICKING = "impact", "chatter", "sticking"


@dataclasses.dataclass(frozen=True)
class ImpactEvent:
    """One event on the impact surface after a start.

    ``kind`` is ``'impact'`` (an ordinary impact at ``t`` with incoming speed ``v``),
    ``'chatter'`` (a chattering sequence from its first impact ``(t, v)`` accumulating at
    ``t_end``; ``count`` impacts resolved) or ``'sticking'`` (at rest on the wall from ``t`` to
    ``t_end``, ``None`` if never released).

    See Also
    --------
    precise_impact.analysis.impact_surface.impact_map.impact_map : returns them.

    Examples
    --------
    >>> from precise_impact.analysis.impact_surface.impact_map import ImpactEvent
    >>> ImpactEvent("impact", 1.0, 0.5, 0.1).kind
    'impact'
    """

    kind: str
    t: Any
    v: Any
    phase: Any
    t_end: Any = None
    count: int = 1


@functools.lru_cache(maxsize=16)
def _context(prec: int) -> mpmath.MPContext:
    """An mpmath context of ``prec`` bits, made once (a new context costs ~10 ms: it wraps
    every special function), never changed after."""
    ctx = mpmath.MPContext()
    ctx.prec = prec
    return ctx


def _phase(t: Any, eta: Any, two_pi: Any) -> Any:
    p = eta * t / two_pi
    if isinstance(p, float):
        return p - np.floor(p)
    return p - p.context.floor(p)


def _exact(x: Any) -> Fraction:
    """A float or an mpf as the exact rational it is."""
    if hasattr(x, "_mpf_"):
        p, q = libmp.to_rational(x._mpf_)
        return Fraction(p, q)
    return Fraction(float(x))


def _check(params: Any, phase: Any, v: Any, n: int, engine: str) -> Params:
    params = as_params(params)
    for name, x in (("phase", phase), ("v", v)):
        if not hasattr(x, "_mpf_"):  # an mpf is taken as it is
            exact(name, x)  # a number, or refused by name
    if not isinstance(engine, str) or engine not in ENGINES:
        raise ParameterError("engine", engine, "one of " + ", ".join(ENGINES))
    if not 0 <= float(phase) < 1:
        raise ParameterError("phase", phase, "0 <= phase < 1")
    if not float(v) > 0:
        raise ParameterError("v", v, "an incoming impact velocity v > 0")
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 10**6:
        raise ParameterError("n", n, "an integer 1 <= n <= 1000000")
    return params


def _no_contact_rule(engine: str, e: Exception) -> BudgetExceededError:
    """The closed form and the certified engine stop where the mass comes to rest on the wall
    (the end of a chattering sequence, sticking): they have no contact rule."""
    return BudgetExceededError(
        f"engine {engine!r} stops at a chattering sequence or sticking (it has no contact "
        f"rule): use engine='heyoka' or 'fast'; the engine said: {e}"
    )


def _run(params: Params, engine: str, t: Fraction, v: Fraction, periods: int, bits: int | None):
    """Events after the impact ``(t, v)`` over ``periods`` forcing periods (start excluded)."""
    model, precision = ENGINES[engine]
    if bits is not None and precision.startswith("mp:"):
        precision = f"mp:{bits}"
    start = params.replace(x0=params.x_w, v0=v, t0=t)
    mp_bits = int(precision[3:]) if precision.startswith("mp:") else None
    ctx = _context(mp_bits or 53)

    def conv(q: Fraction) -> Any:
        return float(q) if mp_bits is None else ctx.mpf(q.numerator) / q.denominator

    if engine == "certified":
        times, vels = _certified_impacts(start, periods, precision, ctx)
        stats: dict = {}
        to_fraction = None
    else:
        times, vels, stats, to_fraction = _engine_impacts(
            start, engine, model, precision, periods, mp_bits, conv
        )
    # the start is the first recorded impact
    # the engines record the start (an impact at t0) first
    times, vels = times[1:], vels[1:]
    two_pi = 2 * np.pi if mp_bits is None else 2 * ctx.pi
    return _events(times, vels, stats, to_fraction, conv, conv(params.eta), two_pi)


def _certified_impacts(start: Params, periods: int, precision: str, ctx: Any) -> tuple:
    """The certified engine's impact times and incoming speeds, the balls' midpoints."""
    try:
        ct = certify(start, periods, precision=precision)
    except CertificationError as e:
        raise _no_contact_rule("certified", e) from e
    digits = ctx.dps + 10
    times = [ctx.mpf(i[0].mid().str(digits, radius=False)) for i in ct.impacts]
    vels = [ctx.mpf(i[1].mid().str(digits, radius=False)) for i in ct.impacts]
    return times, vels


def _engine_impacts(
    start: Params, engine: str, model: str, precision: str, periods: int, mp_bits, conv
) -> tuple:
    """A simulated run's impact times, incoming speeds, stats and exact-value converter."""
    try:
        tr = simulate(start, periods, model=model, precision=precision)
    except BudgetExceededError as e:
        if engine != "closed-form":
            raise
        raise _no_contact_rule(engine, e) from e
    fr = tr.precision.to_fraction
    if mp_bits is None and tr.precision.kind == "float64":  # floats already: exact
        times = np.asarray(tr.impacts_t, dtype=float).tolist()
        vels = np.asarray(tr.impacts_v_before, dtype=float).tolist()
    else:
        times = [conv(fr(x)) for x in tr.impacts_t]
        vels = [conv(fr(x)) for x in tr.impacts_v_before]
    return times, vels, tr.stats, fr


def _events(times: list, vels: list, stats: dict, to_fraction, conv, eta_n, two_pi) -> list:
    """The impacts as events: chattering runs and sticking intervals as such, time-ordered."""
    events: list[ImpactEvent] = []
    chat = sorted(stats.get("chattering") or [], key=lambda c: float(c["t_accumulation"]))
    stick = sorted(stats.get("sticking") or [], key=lambda s: float(s[0]))
    used = [False] * len(times)
    for c in chat:
        ta = conv(to_fraction(c["t_accumulation"]))
        # the geometric run the accumulation was extrapolated from (not the episode: every
        # impact since the chunk began or the mass left the wall, long flights too)
        k = int(c.get("run_impacts") or c.get("episode_impacts") or 1)
        idx = [i for i in range(len(times)) if times[i] <= ta]
        idx = idx[-k:]
        if not idx:
            continue
        for i in idx:
            used[i] = True
        i0 = idx[0]
        events.append(
            ImpactEvent(
                CHATTER, times[i0], vels[i0], _phase(times[i0], eta_n, two_pi), ta, len(idx)
            )
        )
    for s0, s1 in stick:
        s0 = conv(to_fraction(s0))
        s1 = None if s1 is None else conv(to_fraction(s1))
        events.append(ImpactEvent(STICKING, s0, 0 * s0, _phase(s0, eta_n, two_pi), s1))
    for i in range(len(times)):
        if not used[i]:
            events.append(ImpactEvent(IMPACT, times[i], vels[i], _phase(times[i], eta_n, two_pi)))
    events.sort(key=lambda e: float(e.t))
    return events


def impact_map(
    params: Any,
    phase: Any,
    v: Any,
    n: int = 1,
    *,
    engine: str = "closed-form",
    bits: int | None = None,
    chunk: int = 8,
    max_periods: int = 10_000,
    max_time: float | None = None,
    progress: Any = False,
) -> list[ImpactEvent]:
    """The next ``n`` events of the impact map from the impact point ``(phase, v)``.

    Parameters
    ----------
    params : Params or mapping
        The system (its initial state is ignored: the start is the impact).
    phase : number
        ``(eta t / (2 pi)) mod 1`` of the impact, ``0 <= phase < 1``.
    v : number
        Incoming velocity at the wall, ``v > 0``.
    n : int, default 1
        Events wanted.
    engine : str, default ``'closed-form'``
        One of :data:`ENGINES`: ``'closed-form'`` (mpmath, ``bits`` bits, default 200),
        ``'fast'`` and ``'heyoka'`` (float64), ``'certified'`` (ball midpoints).
    bits : int or None
        Precision of the mp engines.
    chunk : int, default 8
        Forcing periods run at a time.
    max_periods : int, default 10000
        Give up (:class:`~precise_impact.errors.BudgetExceededError`) past this many periods.
    max_time : float or None
        Wall-time budget in seconds: ``n`` events priced at the engine's
        :data:`SECONDS_PER_EVENT` over it are refused before any work
        (:class:`~precise_impact.errors.OverBudgetError`), and it is checked between chunks
        (:class:`~precise_impact.errors.BudgetExceededError` past it).
    progress : bool, None or callable, default ``False``
        Report the events found on stderr (:class:`~precise_impact.io.progress.Progress`).

    Returns
    -------
    list of ImpactEvent
        ``n`` events in time order: ordinary impacts, chattering sequences, sticking intervals.

    Raises
    ------
    ParameterError
        Bad input, before any work.

    See Also
    --------
    precise_impact.analysis.impact_surface.impact_map.impact_map_jacobian : its derivative.
    precise_impact.analysis.impact_surface.impact_map.impact_map_orbit : many iterates at once.
    precise_impact.solvers.simulate.simulate : the engines behind it.

    Examples
    --------
    >>> from precise_impact.analysis.impact_surface.impact_map import impact_map
    >>> import precise_impact as pi
    >>> ev = impact_map(pi.Params.make(eta="0.74"), 0.3, 1.0, 2, engine="heyoka")
    >>> [e.kind for e in ev]
    ['impact', 'impact']
    """
    cols = _iterate(
        params,
        phase,
        v,
        n,
        engine=engine,
        bits=bits,
        chunk=chunk,
        max_periods=max_periods,
        max_time=max_time,
        progress=progress,
    )
    return cols.events()


_NEW = object.__new__


@dataclasses.dataclass
class _Columns:
    """Events as columns (one list per :class:`ImpactEvent` field): the compiled kernel's
    arrays are appended without an object per impact."""

    kind: list = dataclasses.field(default_factory=list)
    t: list = dataclasses.field(default_factory=list)
    v: list = dataclasses.field(default_factory=list)
    phase: list = dataclasses.field(default_factory=list)
    t_end: list = dataclasses.field(default_factory=list)
    count: list = dataclasses.field(default_factory=list)

    def __len__(self) -> int:
        return len(self.kind)

    def add_events(self, events: list[ImpactEvent]) -> None:
        for e in events:
            self.kind.append(e.kind)
            self.t.append(e.t)
            self.v.append(e.v)
            self.phase.append(e.phase)
            self.t_end.append(e.t_end)
            self.count.append(e.count)

    def add_impacts(self, t: np.ndarray, v: np.ndarray, phase: np.ndarray) -> None:
        m = len(t)
        self.kind.extend([IMPACT] * m)
        self.t.extend(t.tolist())
        self.v.extend(v.tolist())
        self.phase.extend(phase.tolist())
        self.t_end.extend([None] * m)
        self.count.extend([1] * m)

    def events(self) -> list[ImpactEvent]:
        """The events as :class:`ImpactEvent` objects, an ordinary impact's fields put in its
        ``__dict__`` directly (a frozen dataclass's ``__init__`` sets each field through
        ``object.__setattr__``: measured 3.0 us per event against 1.3 us), the cyclic garbage
        collector paused meanwhile (the events hold no cycles; its passes over every live
        object took ~40% of the time for 100,000 events)."""
        paused = gc.isenabled()
        gc.disable()
        try:
            out = [_NEW(ImpactEvent) for _ in self.kind]
            rows = zip(
                out, self.kind, self.t, self.v, self.phase, self.t_end, self.count, strict=True
            )
            for i, (e, k, t, v, p, te, c) in enumerate(rows):
                if k == IMPACT and te is None and c == 1:
                    e.__dict__.update(kind=k, t=t, v=v, phase=p, t_end=None, count=1)
                else:
                    out[i] = ImpactEvent(k, t, v, p, te, c)
        finally:
            if paused:
                gc.enable()
        return out

    def cut(self, n: int) -> _Columns:
        return _Columns(*(getattr(self, f.name)[:n] for f in dataclasses.fields(self)))


def _fast_supported(params: Params) -> bool:
    """The compiled kernel's closed form: underdamped, not the undamped resonance
    (:class:`~precise_impact.solvers.fast.single.FastSolver`)."""
    return params.zeta < 1 and not (params.zeta == 0 and params.eta == 1)


#: Impacts of one compiled call (~0.1 s): ``max_time`` and the progress are looked at between.
FAST_BLOCK = 1 << 17


def _run_fast(
    params: Params, t: Fraction, v: Fraction, n: int, periods_left: int, cols: _Columns, clock
) -> tuple[str, Fraction, Fraction, int]:
    """Up to ``n`` ordinary impacts after the impact ``(t, v)`` by the compiled kernel
    (:func:`~precise_impact.solvers.fast.surface.impact_orbit`), appended to ``cols``.

    Returns ``(end, t, v, periods)``: ``(t, v)`` the last ordinary impact (the start if
    none), ``periods`` the whole forcing periods from the start to it; ``end`` is ``'done'``,
    ``'budget'`` (no crossing within ``periods_left`` forcing periods) or ``'handover'``:
    what follows (a run of short flights into the wall: chattering, sticking; a contact the
    kernel cannot decide) is for the contact rule of the heyoka path.  ``clock(found)`` checks
    ``max_time`` and shows the progress between blocks of :data:`FAST_BLOCK` impacts.
    """
    # numba loads only when the compiled engine is used (not on import precise_impact)
    from precise_impact.solvers.fast import surface  # noqa: PLC0415 -- heavy: numba, loaded on first use

    eta, zeta, a, x_w, R = (float(getattr(params, k)) for k in ("eta", "zeta", "a", "x_w", "R"))
    period = 2 * np.pi / eta
    t_loc, base = surface.local_start(eta, t)
    t_abs, vf = float(t), float(v)
    t0_abs, used, left = t_abs, 0, n
    while left > 0:
        clock(len(cols))
        m = min(left, FAST_BLOCK)
        status, ph, ts, vs, imps, keep, t_loc, base = surface.run_impact_orbit(
            (eta, zeta, a, x_w, R), t_loc, base, vf, m, max(1, periods_left - used)
        )
        cols.add_impacts(ts[:keep], vs[:keep], ph[:keep])
        left -= keep
        if keep:
            t_abs, vf = float(ts[keep - 1]), float(vs[keep - 1])
            used = int((t_abs - t0_abs) // period)
        if status != surface.STATUS_OK or keep < imps:
            budget = status == surface.STATUS_BUDGET and keep == imps
            return "budget" if budget else "handover", Fraction(t_abs), Fraction(vf), used
    return "done", Fraction(t_abs), Fraction(vf), used


def _start(params: Params, phase: Any, v: Any, engine: str, bits: int | None) -> tuple:
    """The start impact ``(t, v)`` as Fractions: ``t = 2 pi phase / eta`` to the engine's
    precision (float engines: rounded once)."""
    ph = Fraction(str(phase)) if isinstance(phase, (float, str)) else _exact(phase)
    mp_bits = bits or (
        int(ENGINES[engine][1][3:]) if engine in ("closed-form", "certified") else 53
    )
    ctx = _context(mp_bits + 64)
    t_mp = 2 * ctx.pi * (ctx.mpf(ph.numerator) / ph.denominator)
    t_mp = t_mp / (ctx.mpf(params.eta.numerator) / params.eta.denominator)
    t = _exact(t_mp) if engine in ("closed-form", "certified") else Fraction(float(t_mp))
    vv = Fraction(str(v)) if isinstance(v, (float, str)) else _exact(v)
    return t, vv


def _iterate(
    params: Any,
    phase: Any,
    v: Any,
    n: int,
    *,
    engine: str = "closed-form",
    bits: int | None = None,
    chunk: int = 8,
    max_periods: int = 10_000,
    max_time: float | None = None,
    progress: Any = False,
) -> _Columns:
    """The events of :func:`impact_map` as columns (priced before any work)."""
    params = _check(params, phase, v, n, engine)
    check_work(f"impact-map: {n} events on {engine}", n, SECONDS_PER_EVENT[engine],
               BYTES_PER_EVENT, max_time, "n")  # fmt: skip
    t, vv = _start(params, phase, v, engine, bits)
    t_start = time.monotonic()
    bar = Progress(n, "impact-map events", enabled=progress)

    def clock(found: int) -> None:
        bar.update(found)
        if max_time is not None and time.monotonic() - t_start > float(max_time):
            bar.close()
            raise BudgetExceededError(
                f"max_time = {max_time} s reached after {found} of {n} impact-map events"
            )

    out = _Columns()
    done = 0
    periods = chunk
    # the fast engine: ordinary impacts in the compiled kernel; what it leaves (a run of short
    # flights into the wall: chattering, sticking) one chunk of the heyoka path, then back
    kernel = engine == "fast" and _fast_supported(params)
    while len(out) < n:
        if kernel:
            end, t, vv, used = _run_fast(
                params, t, vv, n - len(out), max_periods - done, out, clock
            )
            done += used
            if end == "budget":  # the flight after the last impact found no crossing
                raise BudgetExceededError(
                    f"no ordinary impact within {max_periods} forcing periods"
                )
            if len(out) >= n:
                break
            kernel = False
        clock(len(out))
        events = _run(params, engine, t, vv, periods, bits)
        last_imp = max((i for i, e in enumerate(events) if e.kind == IMPACT), default=None)
        if last_imp is None:
            done_more = periods
            if done + done_more > max_periods:
                raise BudgetExceededError(
                    f"no ordinary impact within {max_periods} forcing periods"
                )
            periods *= 2
            if len(events) >= n - len(out):
                out.add_events(events[: n - len(out)])
            continue
        out.add_events(events[: last_imp + 1])
        done += periods
        if done > max_periods and len(out) < n:
            raise BudgetExceededError(f"{len(out)} of {n} events within {max_periods} periods")
        e = events[last_imp]
        t, vv = _exact(e.t), _exact(e.v)
        if engine in ("fast", "heyoka"):
            periods = max(periods, min(4 * periods, 512))  # float engines: longer chunks
        kernel = engine == "fast" and _fast_supported(params)
    bar.update(n)
    bar.close()
    return out.cut(n)


def impact_map_orbit(params: Any, phase: Any, v: Any, n: int, **options: Any) -> ImpactMapResult:
    """An orbit of the impact map: ``n`` events from ``(phase, v)`` as an :class:`ImpactMapResult`.

    Parameters
    ----------
    params, phase, v, n
        As :func:`impact_map`.
    **options
        Passed to :func:`impact_map` (``engine``, ``bits``, ...).

    Returns
    -------
    ImpactMapResult
        The events and their plot.

    See Also
    --------
    precise_impact.analysis.impact_surface.impact_map.impact_map : the events.

    Examples
    --------
    >>> from precise_impact.analysis.impact_surface.impact_map import impact_map_orbit
    >>> r = impact_map_orbit({"eta": "0.74"}, 0.3, 1.0, 4, engine="heyoka")
    >>> len(r.phase)
    4
    """
    params = as_params(params)
    engine = options.get("engine", "closed-form")
    cols = _iterate(params, phase, v, n, **options)
    if engine in ("fast", "heyoka"):  # floats already: no conversion per event
        t, ph, vv = cols.t, cols.phase, cols.v
    else:
        t, ph, vv = ([float(x) for x in c] for c in (cols.t, cols.phase, cols.v))
    return ImpactMapResult(
        params=params,
        engine=engine,
        kind=cols.kind,
        t=t,
        phase=ph,
        v=vv,
        t_end=[None if x is None else float(x) for x in cols.t_end],
    )


@dataclasses.dataclass
class ImpactMapResult(ResultMixin):
    """Events of an impact-map orbit (floats for plotting and JSON).

    Attributes
    ----------
    params : Params
    engine : str
    kind, t, phase, v, t_end : list
        One entry per event (:class:`ImpactEvent`).

    See Also
    --------
    precise_impact.analysis.impact_surface.impact_map.impact_map_orbit : returns it.
    precise_impact.analysis.impact_surface.singularity.SingularityResult : drawn over its plot.

    Examples
    --------
    >>> from precise_impact.analysis.impact_surface.impact_map import impact_map_orbit
    >>> r = impact_map_orbit({"eta": "0.74"}, 0.3, 1.0, 3, engine="heyoka")
    >>> r.kind
    ['impact', 'impact', 'impact']
    """

    params: Params
    engine: str
    kind: list
    t: list
    phase: list
    v: list
    t_end: list

    def to_dict(self) -> dict:
        return {
            "params": self.params.decimal(),
            "engine": self.engine,
            "events": [
                {"kind": k, "t": t, "phase": p, "v": v, "t_end": te}
                for k, t, p, v, te in zip(
                    self.kind, self.t, self.phase, self.v, self.t_end, strict=True
                )
            ],
        }

    def _tables(self) -> dict:
        return {
            "events": lambda: {
                "kind": self.kind,
                "t": self.t,
                "phase": self.phase,
                "v": self.v,
                "t_end": self.t_end,
            }
        }

    def plot(self, path: Any = None, *, ax: Any = None, singularity: Any = None):
        """Scatter plot of the impact surface (phase on [0, 1), v >= 0); chatter and sticking
        with their own symbols; ``singularity`` (a SingularityResult) drawn over it."""
        fig = None
        if ax is None:
            fig, axes = new_figure(figsize=(7.0, 4.5))
            ax = axes[0, 0]
        k = np.array(self.kind)
        ph, vv = np.array(self.phase), np.array(self.v)
        m = k == IMPACT
        ax.plot(ph[m], vv[m], ".", ms=2, color="0.15", label=f"impacts ({int(m.sum())})")
        m = k == CHATTER
        if m.any():
            ax.plot(ph[m], vv[m], "^", ms=5, color="tab:orange", label=f"chatter ({int(m.sum())})")
        m = k == STICKING
        if m.any():
            ax.plot(ph[m], vv[m], "s", ms=5, color="tab:red", label=f"sticking ({int(m.sum())})")
        if singularity is not None:
            singularity.draw(ax)
        ax.set_xlim(0, 1)
        ax.set_ylim(bottom=0)
        ax.set_xlabel("impact phase  eta t / 2 pi  mod 1")
        ax.set_ylabel("impact velocity v")
        p = self.params
        ax.set_title(
            f"impact surface: zeta={p.decimal()['zeta']}, eta={p.decimal()['eta']}, "
            f"x_w={p.decimal()['x_w']}, R={p.decimal()['R']} ({self.engine})"
        )
        ax.legend(loc="best", fontsize=8)
        return finish(fig if fig is not None else ax.figure, path)


# --------------------------------------------------------------------------- the Jacobian
def _ops_for(x: Any) -> Any:
    if hasattr(x, "_mpf_"):
        return flight.MpmathOps(bits=x.context.prec)
    return flight.FLOAT


def impact_map_jacobian(
    params: Any, phase: Any, v: Any, *, flight_time: Any = None, v_next: Any = None
):
    """The 2x2 derivative of one application of the impact map at ``(phase, v)``.

    ``J = D_out Phi(tau) S D_in``: ``D_in`` maps ``(d phase, d v)`` to the pre-impact state
    perturbation at fixed time (``(-v c d phase, d v - acc- c d phase)``, ``c = 2 pi / eta``),
    ``S`` is the saltation matrix, ``Phi`` the flight's flow over ``tau = t' - t`` and
    ``D_out = [[-1 / (v' c), 0], [-acc'- / v', 1]]`` the projection onto the next impact.  So
    ``det J = R^2 exp(-2 zeta tau) v / v'`` exactly.  Generic in the number type: floats give
    floats, mpmath numbers (``phase`` and ``v`` as mpf) give mpf at their context's precision.

    Parameters
    ----------
    params : Params or mapping
    phase, v : float or mpf
        The impact point.
    flight_time, v_next : number or None
        The flight to the next impact and its incoming speed; ``None``: found by
        :func:`impact_map` (closed form at the precision of mpmath numbers, heyoka for floats).

    Returns
    -------
    (J, flight_time, v_next)
        ``J`` as a list of two rows.

    See Also
    --------
    precise_impact.core.flight.flow_and_decay : ``Phi``.
    precise_impact.core.impact.oscillator_saltation : ``S``.

    Examples
    --------
    >>> from precise_impact.analysis.impact_surface.impact_map import impact_map_jacobian
    >>> J, t1, v1 = impact_map_jacobian({"eta": "0.74"}, 0.3, 1.0)
    >>> len(J), len(J[0])
    (2, 2)
    """
    params = as_params(params)
    ops = _ops_for(v)
    mp = isinstance(ops, flight.MpmathOps)
    num = ops.num if mp else float
    eta, zeta, a, x_w, R = (num(getattr(params, k)) for k in ("eta", "zeta", "a", "x_w", "R"))
    if mp:
        phase, v = ops.mpf(phase), ops.mpf(v)
    two_pi = 2 * ops.pi
    c = two_pi / eta
    t = phase * c
    if flight_time is None:
        ev = impact_map(
            params,
            phase,
            v,
            1,
            engine="closed-form" if mp else "heyoka",
            bits=ops.prec if mp else None,
        )[0]
        if ev.kind != IMPACT:
            raise ParameterError("phase", phase, "an impact whose next event is an ordinary impact")
        # impact_map starts at t = 2 pi phase / eta: its times share this origin
        flight_time = (ops.mpf(ev.t) if mp else float(ev.t)) - t
        v_next = ops.mpf(ev.v) if mp else float(ev.v)
    tau = flight_time
    t_next = t + tau
    wd = flight.damped_frequency(zeta, ops)
    (p00, p01, p10, p11), _ = flight.flow_and_decay(tau, zeta, wd, ops)
    cos = ops.cos
    S = oscillator_saltation(t, v, eta, zeta, a, x_w, R, cos)
    acc_in = acceleration(t, x_w, v, eta, zeta, a, cos)
    acc_out = acceleration(t_next, x_w, v_next, eta, zeta, a, cos)
    Din = ((-v * c, 0 * v), (-acc_in * c, 0 * v + 1))
    Dout = ((-1 / (v_next * c), 0 * v), (-acc_out / v_next, 0 * v + 1))

    def mul(A, B):
        return tuple(
            tuple(A[i][0] * B[0][j] + A[i][1] * B[1][j] for j in range(2)) for i in range(2)
        )

    J = mul(Dout, mul(((p00, p01), (p10, p11)), mul(S, Din)))
    return [list(J[0]), list(J[1])], tau, v_next
