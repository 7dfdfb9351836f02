"""heyoka's Taylor integrators: the reference engine in every precision.

* :mod:`~precise_impact.solvers.heyoka.single` — :class:`HeyokaSolver`, the single oscillator.
* :mod:`~precise_impact.solvers.heyoka.coupled` — the master-slave pair (:func:`simulate_coupled`).
* :mod:`~precise_impact.solvers.heyoka.variational` — the variational (tangent + saltation)
  integrator.
* :mod:`~precise_impact.solvers.heyoka.batch` — its SIMD batch twin for parameter sweeps.
* :mod:`~precise_impact.solvers.heyoka.cache` — compiled integrators, a private copy per caller.
* :mod:`~precise_impact.solvers.heyoka.events` — the one impact recorder of every heyoka engine.
"""

from precise_impact.solvers.heyoka.single import HeyokaSolver

__all__ = ["HeyokaSolver"]
