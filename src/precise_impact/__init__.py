"""precise_impact: a verification suite for the piecewise-linear impact oscillator.

    x'' + 2 zeta x' + x = a cos(eta t)  for x < x_w,    x'(t+) = -R x'(t-)  at x = x_w

and its electronic equivalent (Denysenko, Balcerzak & Dabrowski): references with demonstrated
or proven accuracy, Lyapunov exponents, periodic orbits, model scores and their cost.  The
names below are the public API; the layering is described in ``docs/design.rst``.
"""

from precise_impact.analysis.bifurcation import BifurcationResult, bifurcation
from precise_impact.analysis.impact_surface.basins import BasinsResult, basins
from precise_impact.analysis.impact_surface.impact_map import (
    ImpactMapResult,
    impact_map,
    impact_map_jacobian,
    impact_map_orbit,
)
from precise_impact.analysis.impact_surface.response import ResponseCurve, response_curve
from precise_impact.analysis.impact_surface.singularity import SingularityResult, singularity_set
from precise_impact.analysis.lyapunov import (
    LYAPUNOV_ENGINES,
    LYAPUNOV_METHODS,
    Attractor,
    LyapunovResult,
    StartEstimate,
    lyapunov,
)
from precise_impact.analysis.lyapunov.finite_time import finite_time_lle
from precise_impact.analysis.lyapunov.timeseries import TimeSeriesLLE, timeseries_lle
from precise_impact.analysis.orbits import (
    Bifurcation,
    Branch,
    ContinuationResult,
    ConvergenceError,
    PeriodicOrbit,
    ProvenLandmark,
    ProvenOrbit,
    brute_force_diagram,
    continue_orbit,
    find_orbit,
    locate_landmark,
    one_impact_orbits,
    prove_landmark,
    prove_orbit,
)
from precise_impact.analysis.periodicity import detect_period
from precise_impact.analysis.sweep import SweepResult, SweepSpec, load_sweep, run_sweep
from precise_impact.analysis.sync import SyncResult, sync_scan
from precise_impact.core.flow import SteadyState, acceleration, grazing_frequencies, steady_state
from precise_impact.core.impact import (
    impact_at_start,
    oscillator_saltation,
    reset_velocity,
    saltation_matrix,
)
from precise_impact.core.params import PARAM_NAMES, RUNTIME_PARAMS, Params
from precise_impact.core.precision import Precision
from precise_impact.core.result import ResultMixin
from precise_impact.core.trajectory import Trajectory
from precise_impact.errors import (
    BudgetExceededError,
    IntegrationError,
    Interrupted,
    MissedImpactError,
    NgspiceNotFoundError,
    OptionalDependencyError,
    OverBudgetError,
    ParameterError,
    PreciseImpactError,
    ReferenceDataError,
    SpiceError,
)
from precise_impact.lab.attractor import (
    CaptureScore,
    MeasuredBifurcation,
    measured_bifurcation,
    score_capture,
)
from precise_impact.lab.budget import ToleranceBudget, tolerance_budget
from precise_impact.lab.capture import Capture
from precise_impact.lab.netlist import NetlistScoreResult, read_raw, score_netlist
from precise_impact.lab.scope_files import read_capture, write_capture
from precise_impact.lab.synth import Measurement, synth_capture
from precise_impact.models.circuit.components import Components, nominal_components
from precise_impact.models.circuit.coupled import CoupledCircuitTrajectory, simulate_coupled_circuit
from precise_impact.models.circuit.effects.catalogue import EFFECTS
from precise_impact.models.circuit.opamp import CircuitSolver
from precise_impact.models.circuit.spice import SpiceSolver
from precise_impact.models.circuit.switched import SwitchedCapacitorSolver
from precise_impact.scenes.run import run_scene
from precise_impact.scenes.scene import Scene, builtin_scenes, load_scene
from precise_impact.solvers.base import MODEL_ALIASES, MODELS, Solver, make_solver
from precise_impact.solvers.certified.coupled import CertifiedCoupledTrajectory, certify_coupled
from precise_impact.solvers.certified.single import (
    CertificationError,
    CertifiedSolver,
    CertifiedTrajectory,
    certify,
)
from precise_impact.solvers.closed_form import AnalyticalSolver
from precise_impact.solvers.heyoka.coupled import COUPLED_FORMS, CoupledTrajectory, simulate_coupled
from precise_impact.solvers.heyoka.single import HeyokaSolver
from precise_impact.solvers.simulate import simulate
from precise_impact.verification.accuracy import AccuracyResult, accuracy_table
from precise_impact.verification.compare import CompareResult, compare
from precise_impact.verification.reference import generate as generate_reference
from precise_impact.verification.reference import verify as verify_reference
from precise_impact.verification.reproduce import ReproduceResult, reproduce
from precise_impact.verification.scores import score
from precise_impact.verification.workprecision import WorkPrecisionResult, work_precision
from precise_impact.version import __version__

__all__ = [
    # errors
    "BudgetExceededError",
    "IntegrationError",
    "Interrupted",
    "MissedImpactError",
    "NgspiceNotFoundError",
    "OptionalDependencyError",
    "OverBudgetError",
    "ParameterError",
    "PreciseImpactError",
    "ReferenceDataError",
    "SpiceError",
    # core
    "PARAM_NAMES",
    "RUNTIME_PARAMS",
    "Params",
    "Precision",
    "SteadyState",
    "acceleration",
    "grazing_frequencies",
    "steady_state",
    "impact_at_start",
    "oscillator_saltation",
    "reset_velocity",
    "saltation_matrix",
    "ResultMixin",
    "Trajectory",
    # solvers
    "MODELS",
    "MODEL_ALIASES",
    "Solver",
    "make_solver",
    "simulate",
    "HeyokaSolver",
    "AnalyticalSolver",
    "certify",
    "CertifiedTrajectory",
    "CertificationError",
    "CertifiedSolver",
    # models
    "COUPLED_FORMS",
    "CoupledTrajectory",
    "simulate_coupled",
    "certify_coupled",
    "CertifiedCoupledTrajectory",
    "Components",
    "nominal_components",
    "EFFECTS",
    "CircuitSolver",
    "SwitchedCapacitorSolver",
    "SpiceSolver",
    "CoupledCircuitTrajectory",
    "simulate_coupled_circuit",
    # analysis
    "LYAPUNOV_METHODS",
    "LYAPUNOV_ENGINES",
    "LyapunovResult",
    "Attractor",
    "StartEstimate",
    "lyapunov",
    "detect_period",
    "SyncResult",
    "sync_scan",
    "BifurcationResult",
    "bifurcation",
    "SweepSpec",
    "SweepResult",
    "load_sweep",
    "run_sweep",
    "PeriodicOrbit",
    "find_orbit",
    "one_impact_orbits",
    "ConvergenceError",
    "continue_orbit",
    "Branch",
    "Bifurcation",
    "ContinuationResult",
    "brute_force_diagram",
    "prove_orbit",
    "ProvenOrbit",
    "locate_landmark",
    "prove_landmark",
    "ProvenLandmark",
    "timeseries_lle",
    "TimeSeriesLLE",
    "finite_time_lle",
    "impact_map",
    "impact_map_jacobian",
    "impact_map_orbit",
    "ImpactMapResult",
    "singularity_set",
    "SingularityResult",
    "basins",
    "BasinsResult",
    "response_curve",
    "ResponseCurve",
    # scenes
    "Scene",
    "builtin_scenes",
    "load_scene",
    "run_scene",
    # verification
    "AccuracyResult",
    "accuracy_table",
    "score",
    "CompareResult",
    "compare",
    "generate_reference",
    "verify_reference",
    "WorkPrecisionResult",
    "work_precision",
    "ReproduceResult",
    "reproduce",
    # lab: what users bring from the bench
    "score_netlist",
    "NetlistScoreResult",
    "read_raw",
    "Capture",
    "read_capture",
    "write_capture",
    "Measurement",
    "synth_capture",
    "score_capture",
    "CaptureScore",
    "measured_bifurcation",
    "MeasuredBifurcation",
    "tolerance_budget",
    "ToleranceBudget",
    "__version__",
]
