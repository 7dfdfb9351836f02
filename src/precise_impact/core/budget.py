"""What a run will cost, estimated before any work, and the budgets it is checked against.

A too-large request is refused before the first step.  The cost model (measured, rounded up) is
in ``benchmarks/results/cost_model.md`` and ``docs/numerics.rst``.
:func:`estimate_cost` prices a whole job; the API functions take ``max_time=`` and refuse through
:func:`enforce_max_time`; the CLI's ``--max-time`` passes through to them.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
import warnings
from typing import Any

from precise_impact.core.params import exact
from precise_impact.core.precision import Precision
from precise_impact.errors import BudgetExceededError, OverBudgetError, ParameterError

__all__ = [
    "Cost",
    "format_duration",
    "JOBS",
    "estimate_cost",
    "run_cost",
    "check_cost",
    "check_work",
    "enforce_max_time",
    "parse_max_time",
    "DEFAULT_MAX_TIME",
    "MAX_TIME",
    "Deadline",
    "certify_seconds_per_period",
]

#: Default time budget of one CLI run or scene, seconds (raise it with ``--max-time``).
DEFAULT_MAX_TIME = 3600.0
#: The largest ``--max-time`` accepted (one week).
MAX_TIME = 7 * 86400.0


@dataclasses.dataclass(frozen=True)
class Cost:
    """An estimate: wall time ``seconds`` and peak memory ``bytes`` of the samples."""

    seconds: float
    bytes: float
    what: str

    def describe(self) -> str:
        return f"{self.what}: estimated ~{_duration(self.seconds)} and ~{_size(self.bytes)}"


def format_duration(s: float) -> str:
    """``s`` seconds in words (``'12 s'``, ``'3.5 min'``, ``'2.1 h'``, ``'1.5 days'``)."""
    for unit, scale in (("days", 86400), ("h", 3600), ("min", 60)):
        if s >= scale:
            return f"{s / scale:.3g} {unit}"
    return f"{s:.2g} s"


_duration = format_duration


def _size(b: float) -> str:
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if b >= scale:
            return f"{b / scale:.3g} {unit}"
    return f"{b / 1e3:.3g} kB"


def _per_period(precision) -> tuple[float, float, float]:
    kind, bits = precision.kind, precision.bits
    if kind == "float64":
        return 1e-5, 1e-6, 200.0
    if kind == "longdouble":
        return 6e-5, 1.2e-5, 200.0
    if kind == "float128":
        return 6e-4, 2e-5, 200.0
    return 1.2e-3 * max(1.0, bits / 128) ** 2.7, 2e-5, 3 * (120 + bits / 8)


def certify_seconds_per_period(bits: int) -> float:
    """Seconds per forcing period of a certified (ball arithmetic) run at ``bits``.

    Measured (python-flint 0.x, this project's 2-core CI machine under load, default system
    eta = 0.712 and eta = 0.74, 40-300 periods): 128 bits 0.6-1.0 ms, 256 bits 1.1-1.5 ms,
    512 bits 1.8 ms, 1024 bits 3.9-4.7 ms, 2048 bits 7.4 ms, 4096 bits 17-23 ms, 8192 bits
    52 ms per period.  ``1.2 ms x (bits / 256)^1.1`` (never below 1.2 ms) bounds these within
    ~25% (8192 bits: 54 ms); the in-run deadline (:class:`Deadline`) catches the rest.
    """
    return 1.2e-3 * max(1.0, bits / 256) ** 1.1


#: The jobs :func:`estimate_cost` prices.
JOBS = ("simulate", "scene", "lle", "bifurcation", "sync", "certify", "sweep")

#: Cost of one period of the fast engine's LLE kernel relative to a plain heyoka float64
#: period (``benchmarks/results/fast.md``: 4 x 6000 periods in 10.2 ms on 2 cores, and a
#: sweep's 674 points of 3000 periods per second per core, ~4.9e-7 s a period; priced at
#: 6.7e-7 s, 1.4x over).
FAST_FACTOR = 2 / 30
#: A sweep point on heyoka's SIMD batch variational integrator (8.1 points of 3000 periods
#: per second per core, ``benchmarks/results/fast.md``: ~4.1e-5 s a period; priced at 4e-5).
HEYOKA_SWEEP_FACTOR = 4.0


def estimate_cost(
    job: Any,
    *args: Any,
    periods: int = 0,
    transient: int = 0,
    per_period: int = 0,
    precision: Any = "float64",
    model: str | None = None,
    runs: int | None = None,
    coupled: bool = False,
    **kwargs: Any,
) -> Cost:
    """Estimated cost of one job of the API or the CLI, before any work.

    Parameters
    ----------
    job : str
        One of :data:`JOBS`: ``'simulate'`` (one trajectory, samples kept),
        ``'scene'`` (:func:`~precise_impact.scenes.run.run_scene`: circuit and coupled
        systems integrate 2-4x the states, factor 4), ``'lle'`` (``runs`` starting
        conditions, default 4, variational: factor 2; ``model='fast'``: 2/30, the compiled
        engine's measured cost relative to heyoka, :data:`FAST_FACTOR`), ``'bifurcation'``
        (``runs`` values of eta, one variational run each: factor 2; ``model='fast'``:
        2/30), ``'sync'`` (``runs`` = couplings x ensemble master-slave runs of 4 states:
        factor 4 in heyoka, 4/5 with ``model='fast'``), ``'certify'`` (one certified run at
        ``precision='mp:BITS'``, :func:`certify_seconds_per_period`; ``coupled=True``: the
        master-slave pair off the diagonal, factor 5), ``'sweep'`` (``runs`` grid points:
        2/30 on the fast engine, the default, 4 with ``model='heyoka'``, the SIMD batch).
        Times are for one core: a job on ``w`` workers is checked against ``w`` times the
        budget (:func:`enforce_max_time`'s ``scale``).
    *args
        Deprecated: the 0.x low-level form ``estimate_cost(precision, periods, ...)``,
        now :func:`run_cost` (a ``DeprecationWarning``).
    periods : int, default 0
        Measured forcing periods per run.
    transient : int, default 0
        Discarded periods per run (priced like measured ones).
    per_period : int, default 0
        Output points per period (0: one stroboscopic sample).
    precision : str or Precision, default ``'float64'``
        Working precision of the runs.
    model : str or None, default ``None``
        The engine or method where it changes the cost (``'fast'``, ``'heyoka'``,
        ``'variational'``, ...; for ``'scene'`` the scene's model).
    runs : int or None, default ``None``
        Independent runs (starting conditions, values of eta, couplings x ensemble);
        ``None``: the job's default (4 starting conditions for ``'lle'``, else 1).
    coupled : bool, default ``False``
        For ``'scene'``: the scene is a coupled (master-slave) system; for ``'certify'``:
        the pair off the diagonal (the slave integrated on its own).
    **kwargs
        Deprecated low-level keywords (``factor``, ``stored``), with ``*args``.

    Returns
    -------
    Cost
        Seconds and bytes, with a one-line description for the refusal message.

    Raises
    ------
    ParameterError
        ``job`` is not one of :data:`JOBS`.

    See Also
    --------
    run_cost : The cost of plain heyoka runs that every job is priced from.
    check_cost : Refuse a cost over a budget.

    Examples
    --------
    >>> from precise_impact.core.budget import estimate_cost
    >>> # 4 x (2 x 21000 x 1e-5 s + samples)
    >>> c = estimate_cost("lle", periods=20000, transient=1000)
    >>> round(c.seconds, 3), c.what
    (1.764, '4 x 21000 periods in float64')
    """
    if isinstance(job, Precision):  # the 0.x signature (precision, periods, per_period, ...)
        warnings.warn(
            "estimate_cost(precision, periods, ...) is deprecated: use run_cost(precision, "
            "periods, ...) for plain runs, or estimate_cost(job, ...) for a job",
            DeprecationWarning,
            stacklevel=2,
        )
        return run_cost(job, *args, **kwargs)
    if args or kwargs:
        raise TypeError(f"estimate_cost(job, ...) takes keywords only, not {args or kwargs}")
    length = periods + transient
    if job == "certify":
        return _certify_cost(length, precision, coupled)
    P = Precision.parse(precision)
    return _job_cost(job, P, length, per_period, model, runs, coupled)


def _certify_cost(length: int, precision: Any, coupled: bool) -> Cost:
    """The cost of a ``'certify'`` job: ``length`` periods in ball arithmetic."""
    # ball arithmetic: the precision is 'mp:BITS' (python-flint), priced per period;
    # the pair off the diagonal walks master, slave and their error flow: measured (k = 0.5,
    # x0 = 0.1, y0 = (0.2, 0), eta = 0.712 and 0.74) 2.7-3.0 ms against 0.6-1.0 ms per period
    # at 256 bits, 4.9-5.0 ms against 1.0-2.3 ms at 1024 bits: x5 bounds them
    bits = int(str(precision)[3:]) if str(precision).startswith("mp:") else 128
    seconds = length * certify_seconds_per_period(bits) * (5.0 if coupled else 1.0)
    return Cost(seconds, 0.0, f"{length} certified periods at {bits} bits")


def _job_cost(
    job: Any,
    P: Precision,
    length: int,
    per_period: int,
    model: str | None,
    runs: int | None,
    coupled: bool,
) -> Cost:
    """The cost of a job priced from plain heyoka runs (every job but ``'certify'``)."""
    n = 1 if runs is None else runs
    if job == "simulate":
        return run_cost(P, length, per_period)
    if job == "scene":
        # circuits and coupled systems integrate 2-4x the states of the mechanical model
        factor = 1.0 if not coupled and model in (None, "heyoka", "analytical") else 4.0
        return run_cost(P, length, per_period, factor=factor)
    if job == "lle":
        # four starting conditions; the variational equations cost about twice a trajectory;
        # the compiled engine ~1/30 of heyoka's variational run (benchmarks/results/fast.md)
        factor = FAST_FACTOR if model == "fast" else 2
        return run_cost(P, length, runs=4 if runs is None else runs, factor=factor, stored=False)
    if job == "bifurcation":
        # one variational run per value (x2), or the compiled kernel (model='fast')
        factor = FAST_FACTOR if model == "fast" else 2
        return run_cost(P, length, runs=n, factor=factor, stored=False)
    if job == "sweep":
        # ``runs`` grid points; the fast kernel, or heyoka's SIMD batch (model='heyoka')
        factor = HEYOKA_SWEEP_FACTOR if model == "heyoka" else FAST_FACTOR
        return run_cost(P, length, runs=n, factor=factor, stored=False)
    if job == "sync":
        # master + slave (4 states, x4) for every k and ensemble member
        factor = 4 if model == "heyoka" else 4 / 5
        return run_cost(P, length, per_period, runs=n, factor=factor, stored=False)
    raise ParameterError("job", job, "one of " + ", ".join(JOBS))


def run_cost(
    precision,
    periods: int,
    per_period: int = 0,
    runs: int = 1,
    factor: float = 1.0,
    stored: bool = True,
) -> Cost:
    """Estimated cost of ``runs`` heyoka runs of ``periods`` forcing periods.

    Parameters
    ----------
    precision : Precision
        The working precision.
    periods : int
        Forcing periods per run (transient included).
    per_period : int, default 0
        Dense output points per period (0: one stroboscopic sample per period).
    runs : int, default 1
        Independent runs (starting conditions, parameter values, ensemble members).
    factor : float, default 1.0
        Cost of one period relative to a plain trajectory (2 for the variational
        equations of the Lyapunov exponent, ~4 for the coupled system).
    stored : bool, default ``True``
        The samples are kept (a trajectory); ``False`` for jobs that reduce them on the
        fly (Lyapunov exponents): no memory estimate.

    Returns
    -------
    Cost
        Seconds and bytes (the samples of one run are held at a time).

    See Also
    --------
    estimate_cost : A whole job priced from these runs.
    """
    t_period, t_sample, b_sample = _per_period(precision)
    samples = periods * max(per_period, 1) + 1
    seconds = runs * (periods * t_period * factor + samples * t_sample)
    what = (
        (f"{runs} x " if runs > 1 else "")
        + f"{periods} periods"
        + (f" x {per_period} points" if per_period else "")
        + f" in {precision.name}"
    )
    return Cost(seconds, samples * b_sample if stored else 0.0, what)


def _memory() -> float | None:
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return None


def check_cost(
    cost: Cost,
    max_time: float | None = DEFAULT_MAX_TIME,
    flag: str = "max_time",
    size: str = "periods",
) -> None:
    """Refuse a run whose estimate exceeds the time budget or half the machine's memory.

    Parameters
    ----------
    cost : Cost
        The estimate.
    max_time : float or None, default :data:`DEFAULT_MAX_TIME`
        Seconds; ``None``: only the memory is checked.
    flag : str, default ``'max_time'``
        The budget's parameter (named in the time refusal: ``--max-time``).
    size : str, default ``'periods'``
        The parameter that sets the size (named in the memory refusal: ask for fewer).

    Raises
    ------
    OverBudgetError
        A :class:`~precise_impact.errors.ParameterError` naming ``flag`` (time) or ``size``
        (memory), with the estimate; before any work.
    """
    mem = _memory()
    if mem is not None and cost.bytes > mem / 2:
        raise OverBudgetError(
            size,
            cost.what,
            f"a run whose samples fit in half this machine's memory "
            f"({_size(mem)}): {cost.describe()}; fewer {size.replace('_', ' ')}",
        )
    if max_time is not None and cost.seconds > max_time:
        raise OverBudgetError(
            flag,
            f"{max_time:g} s",
            f"a budget above the estimate ({cost.describe()}); "
            f"raise --{flag.replace('_', '-')} (at most {MAX_TIME:g} s) or ask for less",
        )


def check_work(
    what: str,
    units: float,
    seconds_each: float,
    bytes_each: float,
    max_time: Any,
    size: str,
    scale: float = 1.0,
) -> Cost:
    """Price ``units`` of work (grid points, events, continuation points) and refuse it over
    budget, before any work: the one refusal of the commands that take a grid, a count or a
    record.

    Parameters
    ----------
    what : str
        The work, for the message (e.g. ``'10000000000 basin points x 200 periods'``).
    units : float
        How many units (a float: a product of counts may be huge).
    seconds_each, bytes_each : float
        Measured cost of one unit (each caller states its figure) and the bytes it holds.
    max_time : decimal or None
        Seconds (``1 <= max_time <=`` :data:`MAX_TIME`); ``None``: only the memory is checked
        (half this machine's memory, as :func:`check_cost`).
    size : str
        The parameter that sets ``units`` (named when the memory is over).
    scale : float, default 1.0
        The budget is ``max_time * scale`` (worker processes).

    Returns
    -------
    Cost
        The estimate (within the budget).

    Raises
    ------
    OverBudgetError
        Over the time budget (naming ``max_time``) or the memory (naming ``size``).
    """
    cost = Cost(units * seconds_each, units * bytes_each, what)
    budget = None if max_time is None else parse_max_time(max_time) * scale
    check_cost(cost, budget, size=size)
    return cost


def parse_max_time(value) -> float:
    """``--max-time`` as seconds: a decimal with ``1 <= value <= MAX_TIME``."""
    q = exact("max_time", value, max_exponent=10)
    if not 1 <= q <= MAX_TIME:
        raise ParameterError("max_time", value, f"seconds with 1 <= max_time <= {MAX_TIME:g}")
    return float(q)


def enforce_max_time(max_time: Any, job: str, scale: float = 1.0, **job_args: Any) -> None:
    """The API's ``max_time=``: refuse ``job`` before any work when its estimate is over it.

    Parameters
    ----------
    max_time : decimal or None
        Seconds, ``1 <= max_time <=`` :data:`MAX_TIME`; ``None``: no budget (nothing checked).
    job : str
        One of :data:`JOBS`.
    scale : float, default 1.0
        The budget is ``max_time * scale`` (the worker processes of a parallel job).
    **job_args
        The job's size, as :func:`estimate_cost` takes it.

    Raises
    ------
    OverBudgetError
        Naming ``max_time`` (or ``periods`` for memory), with the estimate.
    ParameterError
        ``max_time`` out of range.
    """
    if max_time is None:
        return
    check_cost(estimate_cost(job, **job_args), parse_max_time(max_time) * scale)


class Deadline:
    """The budget of a run enforced while it works: :meth:`check` between periods, and
    :meth:`admit` for work decided on mid-run (a fallback engine), admitted only if its
    estimate fits in what is left.

    Parameters
    ----------
    max_time : float or None
        Seconds from now; ``None``: no deadline (:meth:`check` does nothing).
    what : str
        The job, for the message (e.g. ``'certify'``).
    """

    def __init__(self, max_time: float | None, what: str) -> None:
        self.max_time = max_time
        self.what = what
        self.start = time.monotonic()
        self.end = None if max_time is None else self.start + max_time

    def left(self) -> float:
        """Seconds left (``inf`` without a deadline)."""
        return math.inf if self.end is None else self.end - time.monotonic()

    def check(self, where: str) -> None:
        """Raise :class:`~precise_impact.errors.BudgetExceededError` (one line: the job,
        ``where`` it stopped, the budget) once the deadline has passed."""
        if self.end is not None and time.monotonic() > self.end:
            raise BudgetExceededError(
                f"{self.what}: max_time = {self.max_time:g} s ran out after "
                f"{time.monotonic() - self.start:.1f} s ({where}); raise --max-time "
                f"(at most {MAX_TIME:g} s) or ask for less"
            )

    def admit(self, cost: Cost, what: str) -> None:
        """Refuse ``cost`` if it does not fit in what is left.

        Parameters
        ----------
        cost : Cost
            The estimate of the work about to start.
        what : str
            What would run (the message's subject, e.g. ``'... heyoka'``).

        Raises
        ------
        BudgetExceededError
            The estimate is over the time left (the CLI: one line, exit status 3).
        """
        left = self.left()
        if cost.seconds > left:
            raise BudgetExceededError(
                f"{what} would take ~{_duration(cost.seconds)} ({cost.what}), more than the "
                f"{_duration(max(left, 0.0))} left of max_time = {self.max_time:g} s; raise "
                f"--max-time (at most {MAX_TIME:g} s) or ask for fewer periods"
            )
