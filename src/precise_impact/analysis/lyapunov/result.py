"""Result of a Lyapunov-exponent computation, shared by every method."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from precise_impact.core.params import Params
from precise_impact.core.result import ResultMixin, to_jsonable

__all__ = ["LyapunovResult", "block_stderr", "means_stderr"]


@dataclasses.dataclass
class LyapunovResult(ResultMixin):
    """Largest Lyapunov exponent (per unit dimensionless time) with its error bar.

    Attributes
    ----------
    params : Params
    method : str
        ``'variational'`` or ``'two-trajectory'``.
    precision : str
    lle : float
        Largest exponent (per unit time tau, the unit of the coupling k in eqs. 10-12).
    spectrum : tuple[float, float] or None
        Both exponents (variational method only).
    stderr : float
        Standard error from independent segments (see :func:`block_stderr`).
    periods, transient : int
        Measured periods and discarded transient periods.
    impacts : int
        Impacts during the measured periods.
    running : numpy.ndarray
        Running estimate of the LLE after each measured period (convergence record).
    segments : numpy.ndarray
        LLE estimate of each independent segment.
    elapsed_s : float
    initial_conditions : int
        Number of initial conditions the periods were spread over.
    strobe_x, strobe_v : numpy.ndarray or None
        Stroboscopic samples (float64) of the first initial condition's measured
        periods, where the method records them (for bifurcation diagrams).
    stats : dict
        Method diagnostics (variational: impacts, grazing contacts, guard checks,
        missed impacts ...; two-trajectory: straddled boundaries, grazing misses,
        collapses, the separation ``d0`` used).
    """

    params: Params
    method: str
    precision: str
    lle: float
    spectrum: tuple[float, float] | None
    stderr: float
    periods: int
    transient: int
    impacts: int
    running: np.ndarray
    segments: np.ndarray
    elapsed_s: float
    initial_conditions: int = 1
    strobe_x: np.ndarray | None = None
    strobe_v: np.ndarray | None = None
    stats: dict = dataclasses.field(default_factory=dict)

    def to_dict(self) -> dict:
        """The ``precise-impact lle --json`` object."""
        return {
            "params": self.params.decimal(),
            "method": self.method,
            "lle": self.lle,
            # JSON has no infinity: a -inf exponent (plastic impacts, R = 0) is null
            "spectrum": [v if math.isfinite(v) else None for v in self.spectrum]
            if self.spectrum is not None
            else None,
            "stderr": self.stderr,
            "periods": self.periods,
            "impacts": self.impacts,
            "elapsed_s": self.elapsed_s,
            "stats": to_jsonable(self.stats),
        }


def means_stderr(blocks: Sequence[float]) -> float:
    """Standard error of the mean of independent block estimates, ``std(ddof=1) / sqrt(n)``
    (batch means; NaN for fewer than two blocks): written once for every Lyapunov method."""
    b = np.asarray(blocks, dtype=float).ravel()
    return float(np.std(b, ddof=1) / math.sqrt(len(b))) if len(b) > 1 else math.nan


def block_stderr(
    log_growth: Sequence[float], dt: Sequence[float], n_blocks: int
) -> tuple[np.ndarray, float]:
    """Split per-period log-growths into ``n_blocks`` contiguous blocks.

    Returns the per-block exponent estimates and the standard error of their mean,
    ``std(blocks, ddof=1) / sqrt(n_blocks)`` (batch means; Flyvbjerg & Petersen,
    J. Chem. Phys. 91, 461 (1989)).  Blocks must be long compared with the
    correlation time of the local growth rates (tens of periods here).
    """
    g = np.asarray(log_growth, dtype=float)
    t = np.asarray(dt, dtype=float)
    n_blocks = max(1, min(n_blocks, len(g)))
    idx = np.array_split(np.arange(len(g)), n_blocks)
    blocks = np.array([g[i].sum() / t[i].sum() for i in idx if len(i)])
    return blocks, means_stderr(blocks)


# 0.1.0 name, kept for one release.
LyapunovResult.to_json_dict = LyapunovResult.to_dict  # type: ignore[attr-defined]
