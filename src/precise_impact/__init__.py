"""precise_impact: a verification suite for the piecewise-linear impact oscillator.

    x'' + 2 zeta x' + x = a cos(eta t)  for x < x_w,    x'(t+) = -R x'(t-)  at x = x_w

and its electronic equivalent (Denysenko, Balcerzak & Dabrowski): references with demonstrated
or proven accuracy, Lyapunov exponents, periodic orbits, model scores and their cost.  The names
below are the public API, loaded on first use (PEP 562); layering: ``docs/design.rst``.
"""

from __future__ import annotations

import importlib

#: True for type checkers only (``typing`` itself costs ~20 ms of start-up: not imported here).
TYPE_CHECKING = False

if TYPE_CHECKING:  # the names for type checkers and readers; at run time loaded on first use
    from typing import Any

    from precise_impact.analysis.bifurcation import BifurcationResult, bifurcation
    from precise_impact.analysis.impact_surface.basins import BasinsResult, basins
    from precise_impact.analysis.impact_surface.impact_map import (
        ImpactMapResult,
        impact_map,
        impact_map_jacobian,
        impact_map_orbit,
    )
    from precise_impact.analysis.impact_surface.response import ResponseCurve, response_curve
    from precise_impact.analysis.impact_surface.singularity import (
        SingularityResult,
        singularity_set,
    )
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
    from precise_impact.core.flow import (
        SteadyState,
        acceleration,
        grazing_frequencies,
        steady_state,
    )
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
    from precise_impact.lab.diagnose import Diagnosis, diagnose
    from precise_impact.lab.identify import Identification, identify
    from precise_impact.lab.netlist import NetlistScoreResult, read_raw, score_netlist
    from precise_impact.lab.predict import Prediction, predict
    from precise_impact.lab.scope_files import read_capture, write_capture
    from precise_impact.lab.synth import Measurement, synth_capture
    from precise_impact.models.circuit.components import Components, nominal_components
    from precise_impact.models.circuit.coupled import (
        CoupledCircuitTrajectory,
        simulate_coupled_circuit,
    )
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
    from precise_impact.solvers.heyoka.coupled import (
        COUPLED_FORMS,
        CoupledTrajectory,
        simulate_coupled,
    )
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

#: The public names by module (loaded on first use), and the names that differ from the
#: attribute they stand for.
_MODULES: dict[str, tuple[str, ...]] = {
    "precise_impact.analysis.bifurcation": (
        "BifurcationResult",
        "bifurcation",
    ),
    "precise_impact.analysis.impact_surface.basins": (
        "BasinsResult",
        "basins",
    ),
    "precise_impact.analysis.impact_surface.impact_map": (
        "ImpactMapResult",
        "impact_map",
        "impact_map_jacobian",
        "impact_map_orbit",
    ),
    "precise_impact.analysis.impact_surface.response": (
        "ResponseCurve",
        "response_curve",
    ),
    "precise_impact.analysis.impact_surface.singularity": (
        "SingularityResult",
        "singularity_set",
    ),
    "precise_impact.analysis.lyapunov": (
        "LYAPUNOV_ENGINES",
        "LYAPUNOV_METHODS",
        "Attractor",
        "LyapunovResult",
        "StartEstimate",
        "lyapunov",
    ),
    "precise_impact.analysis.lyapunov.finite_time": ("finite_time_lle",),
    "precise_impact.analysis.lyapunov.timeseries": (
        "TimeSeriesLLE",
        "timeseries_lle",
    ),
    "precise_impact.analysis.orbits": (
        "Bifurcation",
        "Branch",
        "ContinuationResult",
        "ConvergenceError",
        "PeriodicOrbit",
        "ProvenLandmark",
        "ProvenOrbit",
        "brute_force_diagram",
        "continue_orbit",
        "find_orbit",
        "locate_landmark",
        "one_impact_orbits",
        "prove_landmark",
        "prove_orbit",
    ),
    "precise_impact.analysis.periodicity": ("detect_period",),
    "precise_impact.analysis.sweep": (
        "SweepResult",
        "SweepSpec",
        "load_sweep",
        "run_sweep",
    ),
    "precise_impact.analysis.sync": (
        "SyncResult",
        "sync_scan",
    ),
    "precise_impact.core.flow": (
        "SteadyState",
        "acceleration",
        "grazing_frequencies",
        "steady_state",
    ),
    "precise_impact.core.impact": (
        "impact_at_start",
        "oscillator_saltation",
        "reset_velocity",
        "saltation_matrix",
    ),
    "precise_impact.core.params": (
        "PARAM_NAMES",
        "RUNTIME_PARAMS",
        "Params",
    ),
    "precise_impact.core.precision": ("Precision",),
    "precise_impact.core.result": ("ResultMixin",),
    "precise_impact.core.trajectory": ("Trajectory",),
    "precise_impact.errors": (
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
    ),
    "precise_impact.lab.attractor": (
        "CaptureScore",
        "MeasuredBifurcation",
        "measured_bifurcation",
        "score_capture",
    ),
    "precise_impact.lab.budget": (
        "ToleranceBudget",
        "tolerance_budget",
    ),
    "precise_impact.lab.capture": ("Capture",),
    "precise_impact.lab.identify": (
        "Identification",
        "identify",
    ),
    "precise_impact.lab.predict": (
        "Prediction",
        "predict",
    ),
    "precise_impact.lab.diagnose": (
        "Diagnosis",
        "diagnose",
    ),
    "precise_impact.lab.netlist": (
        "NetlistScoreResult",
        "read_raw",
        "score_netlist",
    ),
    "precise_impact.lab.scope_files": (
        "read_capture",
        "write_capture",
    ),
    "precise_impact.lab.synth": (
        "Measurement",
        "synth_capture",
    ),
    "precise_impact.models.circuit.components": (
        "Components",
        "nominal_components",
    ),
    "precise_impact.models.circuit.coupled": (
        "CoupledCircuitTrajectory",
        "simulate_coupled_circuit",
    ),
    "precise_impact.models.circuit.effects.catalogue": ("EFFECTS",),
    "precise_impact.models.circuit.opamp": ("CircuitSolver",),
    "precise_impact.models.circuit.spice": ("SpiceSolver",),
    "precise_impact.models.circuit.switched": ("SwitchedCapacitorSolver",),
    "precise_impact.scenes.run": ("run_scene",),
    "precise_impact.scenes.scene": (
        "Scene",
        "builtin_scenes",
        "load_scene",
    ),
    "precise_impact.solvers.base": (
        "MODEL_ALIASES",
        "MODELS",
        "Solver",
        "make_solver",
    ),
    "precise_impact.solvers.certified.coupled": (
        "CertifiedCoupledTrajectory",
        "certify_coupled",
    ),
    "precise_impact.solvers.certified.single": (
        "CertificationError",
        "CertifiedSolver",
        "CertifiedTrajectory",
        "certify",
    ),
    "precise_impact.solvers.closed_form": ("AnalyticalSolver",),
    "precise_impact.solvers.heyoka.coupled": (
        "COUPLED_FORMS",
        "CoupledTrajectory",
        "simulate_coupled",
    ),
    "precise_impact.solvers.heyoka.single": ("HeyokaSolver",),
    "precise_impact.solvers.simulate": ("simulate",),
    "precise_impact.verification.accuracy": (
        "AccuracyResult",
        "accuracy_table",
    ),
    "precise_impact.verification.compare": (
        "CompareResult",
        "compare",
    ),
    "precise_impact.verification.reproduce": (
        "ReproduceResult",
        "reproduce",
    ),
    "precise_impact.verification.scores": ("score",),
    "precise_impact.verification.workprecision": (
        "WorkPrecisionResult",
        "work_precision",
    ),
}
_ALIASES = {
    "generate_reference": ("precise_impact.verification.reference", "generate"),
    "verify_reference": ("precise_impact.verification.reference", "verify"),
}
_LAZY: dict[str, tuple[str, str]] = {
    **{name: (module, name) for module, names in _MODULES.items() for name in names},
    **_ALIASES,
    "__version__": ("precise_impact.version", "__version__"),  # importlib.metadata: 40 ms
}

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
    "identify",
    "Identification",
    "predict",
    "Prediction",
    "diagnose",
    "Diagnosis",
    "tolerance_budget",
    "ToleranceBudget",
    "__version__",
]


def __getattr__(name: str) -> Any:
    """A public name, imported from its module on first use (then cached in this module)."""
    try:
        module, attr = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'precise_impact' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module), attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
