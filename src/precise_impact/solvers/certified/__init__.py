"""Certified engines: the closed-form flight in python-flint arb balls.

* :mod:`~precise_impact.solvers.certified.single` — :func:`certify`, :class:`CertifiedSolver`.
* :mod:`~precise_impact.solvers.certified.coupled` — :func:`certify_coupled`, the pair.
"""

from precise_impact.solvers.certified.single import (
    CertificationError,
    CertifiedSolver,
    CertifiedTrajectory,
    certify,
)

__all__ = ["CertificationError", "CertifiedSolver", "CertifiedTrajectory", "certify"]
