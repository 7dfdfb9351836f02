"""Solvers of the single oscillator and the model registry.

:mod:`~precise_impact.solvers.base` (:class:`Solver`, :data:`MODELS`, :func:`make_solver`),
:mod:`~precise_impact.solvers.simulate` (:func:`simulate`, :func:`simulate_coupled`),
:mod:`~precise_impact.solvers.closed_form`, and the engines by arithmetic:
:mod:`~precise_impact.solvers.heyoka` (the reference), :mod:`~precise_impact.solvers.fast`
(numba), :mod:`~precise_impact.solvers.certified` (python-flint balls).
"""

from precise_impact.solvers.base import (
    COUPLED_MODELS,
    MODEL_ALIASES,
    MODELS,
    Capabilities,
    CoupledSolver,
    Solver,
    make_coupled_solver,
    make_solver,
    with_fallback,
)
from precise_impact.solvers.closed_form import AnalyticalSolver
from precise_impact.solvers.heyoka.single import HeyokaSolver
from precise_impact.solvers.simulate import simulate, simulate_coupled

__all__ = [
    "MODELS",
    "MODEL_ALIASES",
    "Solver",
    "make_solver",
    "simulate",
    "COUPLED_MODELS",
    "CoupledSolver",
    "Capabilities",
    "make_coupled_solver",
    "simulate_coupled",
    "with_fallback",
    "HeyokaSolver",
    "AnalyticalSolver",
]
