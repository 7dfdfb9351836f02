"""Solvers of the single oscillator and the model registry.

* :mod:`~precise_impact.solvers.base` — the :class:`Solver` protocol, :data:`MODELS`,
  :func:`make_solver`.
* :mod:`~precise_impact.solvers.heyoka.cache` — the one cache of compiled heyoka integrators
  (a private copy per caller).
* :mod:`~precise_impact.solvers.heyoka.single` — :class:`HeyokaSolver`, the reference (every
  precision).
* :mod:`~precise_impact.solvers.closed_form` — :class:`AnalyticalSolver`, closed-form segments.
* :mod:`~precise_impact.solvers.simulate` — :func:`simulate` and :func:`simulate_coupled`, one
  entry point for every model of the oscillator and of the pair (:data:`COUPLED_MODELS`).
* Engines by arithmetic: :mod:`~precise_impact.solvers.heyoka`, :mod:`~precise_impact.solvers.fast`,
  :mod:`~precise_impact.solvers.certified`; the fast->heyoka fallback is
  :func:`~precise_impact.solvers.base.with_fallback`.
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
