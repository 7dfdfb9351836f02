"""One entry point for every model: ``simulate(params, periods, model=..., precision=...)``."""

from __future__ import annotations

import math
from typing import Any

from precise_impact.errors import ParameterError
from precise_impact.core.params import Params, check_count
from precise_impact.core.precision import Precision
from precise_impact.core.trajectory import Trajectory
from precise_impact.solvers.analytical import AnalyticalSolver
from precise_impact.solvers.heyoka import HeyokaSolver

__all__ = ["MODELS", "make_solver", "simulate"]

#: Models ``simulate`` knows, with a one-line description each.
MODELS = {
    "heyoka": "heyoka Taylor integrator with impact events (the reference)",
    "analytical": "closed-form segments, robust impact finder (cannot miss a crossing)",
    "analytical-paper": "closed-form segments, the paper's 1e-3 T scan + bisection",
}


def make_solver(model: str = "heyoka", precision: str | Precision = "float64", tol: Any = None):
    """The solver object for ``model`` at ``precision``.

    ``heyoka`` takes every precision and a tolerance; the analytical models take
    ``float64`` (numpy/math) or ``mp:BITS`` (mpmath with ``ceil(BITS log10 2)``
    digits) and no tolerance (they refine impacts to working precision).
    """
    if model not in MODELS:
        raise ParameterError("model", model, "one of " + ", ".join(MODELS))
    prec = Precision.parse(precision)
    if model == "heyoka":
        return HeyokaSolver(prec, tol=tol)
    if tol is not None:
        raise ParameterError("tol", str(tol), f"the {model} model takes no tolerance (it works to the precision's epsilon)")
    finder = "robust" if model == "analytical" else "paper"
    if prec.kind == "float64":
        return AnalyticalSolver(finder=finder, backend="float64")
    if prec.kind == "mp":
        return AnalyticalSolver(finder=finder, backend="mpmath", dps=max(20, math.ceil(prec.bits * math.log10(2))))
    raise ParameterError("precision", prec.name, f"the {model} model runs in 'float64' or 'mp:BITS'")


def simulate(
    params: Params | None = None,
    periods: int = 200,
    *,
    model: str = "heyoka",
    precision: str | Precision = "float64",
    tol: Any = None,
    per_period: int = 0,
    **param_values: Any,
) -> Trajectory:
    """Simulate the impact oscillator.

    Keywords
    --------
    params : Params or None, default ``None``
        Exact parameters; ``None`` builds them from ``param_values`` (names as in
        :class:`Params`, defaults the paper's: zeta=0.05, a=1, eta=0.712, x_w=2, R=1).
    periods : int, default 200
        Forcing periods; samples at ``t0 + k 2 pi / eta``, ``k = 0..periods``.
    model : str, default ``'heyoka'``
        One of :data:`MODELS`.
    precision : str, default ``'float64'``
        ``'float64'``, ``'longdouble'``, ``'float128'``, ``'mp:BITS'``.
    tol : decimal or None, default ``None`` (the precision's epsilon)
        heyoka's tolerance.
    per_period : int, default 0
        Dense output points per period.

    All input is validated before any work; bad values raise :class:`ParameterError`.
    """
    if params is None:
        params = Params.make(**param_values)
    elif param_values:
        params = params.replace(**param_values)
    periods = check_count(periods, "periods")
    solver = make_solver(model, precision, tol)
    return solver.solve(params, periods, per_period=per_period)
