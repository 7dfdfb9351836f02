"""Periodic orbits: Newton's method on the stroboscopic map, closed forms, Floquet
multipliers, and continuation of branches with their bifurcations.

* :func:`~precise_impact.analysis.orbits.newton.find_orbit` - any period, stable or unstable;
* :func:`~precise_impact.analysis.orbits.one_impact.one_impact_orbits` - the 1:1 impacting
  orbits in closed form;
* :class:`~precise_impact.analysis.orbits.result.PeriodicOrbit` - what both return;
* :func:`~precise_impact.analysis.orbits.continuation.continue_orbit` - pseudo-arclength
  continuation of the impact-sequence system
  (:mod:`~precise_impact.analysis.orbits.shooting`) with grazing, period-doubling, fold and
  Neimark-Sacker points (:mod:`~precise_impact.analysis.orbits.branch` holds its results);
* :func:`~precise_impact.analysis.orbits.proof.prove_orbit` - existence, local uniqueness and
  stability proven (Krawczyk on the certified engine).
"""

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
]
