"""The fast engine: the closed-form flight compiled with numba (float64).

* :mod:`~precise_impact.solvers.fast.single` — :class:`FastSolver`, the flight and the orbit map.
* :mod:`~precise_impact.solvers.fast.lle` — the compiled LLE kernels.
* :mod:`~precise_impact.solvers.fast.coupled` — the master-slave pair.
"""

from precise_impact.solvers.fast.single import FastSolver

__all__ = ["FastSolver"]
