"""What a run will cost, estimated before any work, and the budgets it is checked against.

A too-large request is refused before the first step.  The cost model (measured, rounded up) is
in ``benchmarks/results/cost_model.md`` and ``docs/numerics.rst``.
"""

from __future__ import annotations

import dataclasses
import os

from precise_impact.errors import ParameterError

__all__ = ["Cost", "estimate_cost", "check_cost", "DEFAULT_MAX_TIME", "MAX_TIME"]

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


def _duration(s: float) -> str:
    for unit, scale in (("days", 86400), ("h", 3600), ("min", 60)):
        if s >= scale:
            return f"{s / scale:.3g} {unit}"
    return f"{s:.2g} s"


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


def estimate_cost(
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
    cost: Cost, max_time: float | None = DEFAULT_MAX_TIME, flag: str = "max_time"
) -> None:
    """Refuse a run whose estimate exceeds the time budget or half the machine's memory.

    Raises
    ------
    ParameterError
        Naming ``flag`` (time) or ``periods`` (memory), with the estimate; before any work.
    """
    mem = _memory()
    if mem is not None and cost.bytes > mem / 2:
        raise ParameterError(
            "periods",
            cost.what,
            f"a run whose samples fit in half this machine's memory "
            f"({_size(mem)}): {cost.describe()}; fewer periods or output points",
        )
    if max_time is not None and cost.seconds > max_time:
        raise ParameterError(
            flag,
            f"{max_time:g} s",
            f"a budget above the estimate ({cost.describe()}); "
            f"raise --{flag.replace('_', '-')} (at most {MAX_TIME:g} s) or ask for less",
        )


def parse_max_time(value) -> float:
    """``--max-time`` as seconds: a decimal with ``1 <= value <= MAX_TIME``."""
    from precise_impact.core.params import exact

    q = exact("max_time", value, max_exponent=10)
    if not 1 <= q <= MAX_TIME:
        raise ParameterError("max_time", value, f"seconds with 1 <= max_time <= {MAX_TIME:g}")
    return float(q)
