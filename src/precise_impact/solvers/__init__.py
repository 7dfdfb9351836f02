"""Solvers of the single oscillator and the model registry.

* :mod:`~precise_impact.solvers.base` — the :class:`Solver` protocol, :data:`MODELS`, :func:`make_solver`.
* :mod:`~precise_impact.solvers.heyoka.cache` — the one cache of compiled heyoka integrators (a private copy per caller).
* :mod:`~precise_impact.solvers.heyoka.single` — :class:`HeyokaSolver`, the reference (every precision).
* :mod:`~precise_impact.solvers.closed_form` — :class:`AnalyticalSolver`, closed-form segments.
* :mod:`~precise_impact.solvers.simulate` — :func:`simulate`, one entry point for every model.
"""

from precise_impact.solvers.base import MODEL_ALIASES, MODELS, Solver, make_solver
from precise_impact.solvers.closed_form import AnalyticalSolver
from precise_impact.solvers.heyoka.single import HeyokaSolver
from precise_impact.solvers.simulate import simulate

__all__ = [
    "MODELS",
    "MODEL_ALIASES",
    "Solver",
    "make_solver",
    "simulate",
    "HeyokaSolver",
    "AnalyticalSolver",
]
