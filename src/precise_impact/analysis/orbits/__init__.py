"""Periodic orbits: Newton, closed forms, Floquet multipliers, continuation and proofs."""

from precise_impact.analysis.orbits.branch import (
    Bifurcation,
    Branch,
    ContinuationResult,
    brute_force_diagram,
)
from precise_impact.analysis.orbits.continuation import continue_orbit
from precise_impact.analysis.orbits.newton import ConvergenceError, find_orbit
from precise_impact.analysis.orbits.one_impact import one_impact_orbits
from precise_impact.analysis.orbits.proof import ProvenOrbit, prove_orbit
from precise_impact.analysis.orbits.proof_landmarks import (
    ProvenLandmark,
    locate_landmark,
    prove_landmark,
)
from precise_impact.analysis.orbits.result import PeriodicOrbit

__all__ = [
    "find_orbit",
    "one_impact_orbits",
    "PeriodicOrbit",
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
]
