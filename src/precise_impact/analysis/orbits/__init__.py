"""Periodic orbits: Newton's method on the stroboscopic map, closed forms, Floquet multipliers.

* :func:`~precise_impact.analysis.orbits.newton.find_orbit` - any period, stable or unstable;
* :func:`~precise_impact.analysis.orbits.one_impact.one_impact_orbits` - the 1:1 impacting
  orbits in closed form;
* :class:`~precise_impact.analysis.orbits.result.PeriodicOrbit` - what both return.
"""

from precise_impact.analysis.orbits.newton import ConvergenceError, find_orbit
from precise_impact.analysis.orbits.one_impact import one_impact_orbits
from precise_impact.analysis.orbits.result import PeriodicOrbit

__all__ = ["find_orbit", "one_impact_orbits", "PeriodicOrbit", "ConvergenceError"]
