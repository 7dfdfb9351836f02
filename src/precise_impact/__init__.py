"""precise_impact: verification suite for the piecewise-linear impact oscillator.

Public API (the private modules ``_params``, ``_precision``, ``_system``,
``_impact``, ``_solver`` ... are implementation detail):

* :class:`Params` - exact parameters; :class:`Precision` - working precisions.
* :func:`simulate`, :class:`HeyokaSolver` (the reference), :class:`AnalyticalSolver`.
* :class:`Trajectory` - what solvers return.
* :func:`reset_velocity`, :func:`saltation_matrix`, :func:`oscillator_saltation` - the impact.
* :func:`acceleration`, :func:`steady_state`, :func:`grazing_frequencies` - the smooth flow.
"""

from precise_impact.errors import BudgetExceededError, ParameterError
from precise_impact.core.impact import impact_at_start, oscillator_saltation, reset_velocity, saltation_matrix
from precise_impact.core.params import PARAM_NAMES, RUNTIME_PARAMS, Params
from precise_impact.core.precision import Precision
from precise_impact.core.trajectory import Trajectory
from precise_impact.solvers.simulate import MODELS, make_solver, simulate
from precise_impact.solvers.analytical import AnalyticalSolver
from precise_impact.solvers.heyoka import HeyokaSolver
from precise_impact.core.flow import SteadyState, acceleration, grazing_frequencies, steady_state

__version__ = "0.1.0"

__all__ = [
    "AnalyticalSolver",
    "BudgetExceededError",
    "HeyokaSolver",
    "MODELS",
    "PARAM_NAMES",
    "ParameterError",
    "Params",
    "Precision",
    "RUNTIME_PARAMS",
    "SteadyState",
    "Trajectory",
    "acceleration",
    "grazing_frequencies",
    "impact_at_start",
    "make_solver",
    "oscillator_saltation",
    "reset_velocity",
    "saltation_matrix",
    "simulate",
    "steady_state",
]
