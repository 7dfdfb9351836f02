"""The fast engine: the closed-form flight compiled with numba (float64).

* :mod:`~precise_impact.solvers.fast.single` — :class:`FastSolver` and the LLE kernels.
* :mod:`~precise_impact.solvers.fast.coupled` — the master-slave pair.
"""

from precise_impact.solvers.fast.single import FastSolver

__all__ = ["FastSolver"]
