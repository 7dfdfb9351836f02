"""One entry point for every model: ``simulate(params, periods, model=..., precision=...)``."""

from __future__ import annotations

import threading
from typing import Any

from precise_impact.core.budget import enforce_max_time
from precise_impact.core.params import Params, check_count, params_or_values
from precise_impact.core.precision import Precision
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import ParameterError
from precise_impact.solvers.base import MODELS, Solver, make_solver, register_model
from precise_impact.solvers.closed_form import AnalyticalSolver
from precise_impact.solvers.heyoka.single import HeyokaSolver

__all__ = ["MODELS", "make_solver", "simulate"]


def _heyoka(prec: Precision, tol: Any, **options: Any) -> Solver:
    return HeyokaSolver(prec, tol=tol, **options)


def _analytical(finder: str):
    def factory(prec: Precision, tol: Any, **options: Any) -> Solver:
        model = "analytical" if finder == "robust" else "analytical-paper"
        if tol is not None:
            raise ParameterError(
                "tol",
                str(tol),
                f"the {model} model takes no tolerance (it works to the precision's epsilon)",
            )
        if prec.kind == "float64":
            return AnalyticalSolver(finder=finder, backend="float64", **options)
        if prec.kind == "mp":
            return AnalyticalSolver(finder=finder, backend="mpmath", bits=prec.bits, **options)
        raise ParameterError(
            "precision", prec.name, f"the {model} model runs in 'float64' or 'mp:BITS'"
        )

    return factory


def _fast(prec: Precision, tol: Any, **options: Any) -> Solver:
    if prec.kind != "float64":
        raise ParameterError(
            "precision", prec.name, "'float64' for the fast model (heyoka for other precisions)"
        )
    if tol is not None:
        raise ParameterError(
            "tol", str(tol), "the fast model takes no tolerance (closed forms to float64 rounding)"
        )
    from precise_impact.solvers.fast.single import (
        FastSolver,
    )  # numba is imported only when asked for

    return FastSolver(**options)


def _certified(prec: Precision, tol: Any, **options: Any) -> Solver:
    if prec.kind != "mp":
        raise ParameterError(
            "precision", prec.name, "'mp:BITS' for the certified model (ball arithmetic at BITS)"
        )
    if tol is not None:
        raise ParameterError(
            "tol", str(tol), "the certified model takes no tolerance (proven enclosures at BITS)"
        )
    from precise_impact.solvers.certified.single import (
        CertifiedSolver,
    )  # python-flint is imported only when asked for

    return CertifiedSolver(prec.bits, **options)


register_model(
    "heyoka", "heyoka Taylor integrator with impact events (the mechanical reference)", _heyoka
)
register_model(
    "analytical",
    "closed-form segments, robust impact finder (cannot miss a crossing)",
    _analytical("robust"),
)
register_model(
    "analytical-paper",
    "closed-form segments, the paper's 1e-3 T scan + bisection",
    _analytical("paper"),
)
register_model(
    "fast",
    "compiled closed form (numba, float64): cannot miss a crossing; heyoka for contacts",
    _fast,
)
register_model(
    "certified",
    "ball arithmetic on the closed form (python-flint, mp:BITS): proven enclosures",
    _certified,
)


_PER_THREAD = threading.local()
#: heyoka solvers kept per thread by :func:`simulate` (distinct precisions/tolerances).
_KEEP = 8


def _solver(model: Any, precision: Any, tol: Any) -> Solver:
    """``make_solver(model, precision, tol)``, reusing this thread's heyoka solver.

    A :class:`HeyokaSolver` owns a private copy of the compiled integrator, and making
    that copy costs ~0.6 ms in float64 (a third of a 200-period run).  Each thread
    keeps its own solvers, per setting, so nothing is shared across threads (a
    compiled integrator is mutable state); one that is busy (re-entered from inside
    a run, e.g. by a signal handler) is not reused.  Every solve resets
    the integrator's time, state, parameters and callback, so a reused solver gives
    the same bits as a new one (``tests/test_threads.py``).
    """
    new = make_solver(model, precision, tol)  # validates; cheap (no integrator yet)
    if type(new) is not HeyokaSolver:
        return new
    key = (
        new.precision.name,
        new.tol_exact,
        new.high_accuracy,
        new.compact_mode,
        new.max_impacts,
        new.max_steps,
    )
    kept = _PER_THREAD.__dict__.setdefault("solvers", {})
    old = kept.get(key)
    if old is not None and not old.busy():
        return old
    if len(kept) >= _KEEP:
        kept.pop(next(iter(kept)))
    kept[key] = new
    return new


def simulate(
    params: Params | None = None,
    periods: int = 200,
    *,
    model: str = "heyoka",
    precision: str | Precision = "float64",
    tol: Any = None,
    per_period: int = 0,
    max_time: Any = None,
    **param_values: Any,
) -> Trajectory:
    """Simulate the impact oscillator with any model.

    Parameters
    ----------
    params : Params, mapping or None, default ``None``
        Exact parameters; ``None`` builds them from ``param_values`` (names as in
        :class:`Params`, defaults the paper's: zeta=0.05, a=1, eta=0.712, x_w=2, R=1).
    periods : int, default 200
        Forcing periods; samples at ``t0 + k 2 pi / eta``, ``k = 0..periods``.
    model : str, default ``'heyoka'``
        One of :data:`~precise_impact.solvers.base.MODELS` (``'mechanical'`` is accepted
        for ``'heyoka'``): the heyoka reference, the closed forms, the circuit models.
    precision : str, default ``'float64'``
        ``'float64'``, ``'longdouble'``, ``'float128'``, ``'mp:BITS'``.
    tol : decimal or None, default ``None`` (the precision's epsilon)
        heyoka's tolerance.
    per_period : int, default 0
        Dense output points per period.
    max_time : decimal or None, default ``None``
        Time budget in seconds (``1 <= max_time <= 604800``): the run's estimated cost
        (:func:`~precise_impact.core.budget.estimate_cost`) is checked against it before
        any work (:class:`~precise_impact.errors.OverBudgetError`); ``None``: no budget.
    **param_values
        Parameter values (exact decimals) replacing those of ``params``.

    Returns
    -------
    Trajectory
        Stroboscopic samples, impacts, and dense output if asked for.

    Raises
    ------
    ParameterError
        Bad input, before any work.
    OverBudgetError
        The estimated cost is over ``max_time`` (a ``ParameterError`` and a
        ``BudgetExceededError``), before any work.
    BudgetExceededError
        An impact or step budget was exhausted (e.g. a Zeno impact sequence).

    References
    ----------
    .. [1] V. Denysenko, M. Balcerzak, A. Dabrowski, "Electronic equivalent of a
       mechanical impact oscillator" (the system and its parameters).
    .. [2] F. Biscani, D. Izzo, "Revisiting high-order Taylor methods for astrodynamics
       and celestial mechanics", MNRAS 504 (2021) (heyoka, the reference integrator).
    """
    params = params_or_values(params, param_values)  # a Params (validated), a mapping, or None
    periods = check_count(periods, "periods")
    solver = _solver(model, precision, tol)
    if max_time is not None:
        per_period = check_count(per_period, "per_period", 100_000)
        prec = getattr(solver, "precision", None) or precision
        enforce_max_time(
            max_time, "simulate", periods=periods, per_period=per_period, precision=prec
        )
    return solver.solve(params, periods, per_period=per_period)
