"""Lyapunov exponents: variational (saltation) and two-trajectory (Benettin) methods."""

from __future__ import annotations

from typing import Any

from precise_impact.errors import ParameterError
from precise_impact.core.params import Params
from precise_impact.analysis.lyapunov.result import LyapunovResult, block_stderr

__all__ = ["LYAPUNOV_METHODS", "lyapunov", "LyapunovResult", "block_stderr"]

LYAPUNOV_METHODS = ("variational", "two-trajectory")


def lyapunov(params: Params, method: str = "variational", **kwargs: Any) -> LyapunovResult:
    """Largest Lyapunov exponent by ``method`` (keywords passed on; see each method)."""
    if method == "variational":
        from precise_impact.analysis.lyapunov.variational import variational_spectrum

        return variational_spectrum(params, **kwargs)
    if method == "two-trajectory":
        from precise_impact.analysis.lyapunov.two_trajectory import two_trajectory_lle

        return two_trajectory_lle(params, **kwargs)
    raise ParameterError("method", method, "one of " + ", ".join(LYAPUNOV_METHODS))
