"""Solvers of the single oscillator and the model registry, engines filed by arithmetic."""

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
