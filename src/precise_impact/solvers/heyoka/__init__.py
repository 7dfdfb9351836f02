"""heyoka's Taylor integrators: the reference engine in every precision."""

from precise_impact.solvers.heyoka.single import HeyokaSolver

__all__ = ["HeyokaSolver"]
