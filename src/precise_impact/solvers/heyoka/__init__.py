"""heyoka's Taylor integrators: the reference engine in every precision.

:mod:`~precise_impact.solvers.heyoka.single` (:class:`HeyokaSolver`), ``coupled`` (the pair,
:func:`simulate_coupled`), ``variational`` (tangents + saltation) and ``batch`` (its SIMD twin
for sweeps), ``cache`` (compiled once, a private copy per caller), ``events`` (the one impact
recorder of every heyoka engine).
"""

from precise_impact.solvers.heyoka.single import HeyokaSolver

__all__ = ["HeyokaSolver"]
