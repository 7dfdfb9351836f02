"""Result of a Lyapunov-exponent computation, shared by every method."""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence

import numpy as np

from precise_impact.core.compat import RenamedAttribute
from precise_impact.core.params import Params
from precise_impact.core.result import ResultMixin, columns, to_jsonable
from precise_impact.core.stats import lle_stderr, means_stderr, rounding_stderr
from precise_impact.io.figures import figure_legend, finish, new_figure, wrap_title

__all__ = [
    "Attractor",
    "LyapunovResult",
    "StartEstimate",
    "block_stderr",
    "lle_stderr",
    "means_stderr",
    "rounding_stderr",
]


@dataclasses.dataclass(frozen=True)
class Attractor:
    """One attractor the starts of a Lyapunov estimate ended on (typed view of
    ``stats['attractors']``; :func:`~precise_impact.analysis.lyapunov.attractors.attribute`).

    Attributes
    ----------
    id : int
        Index in :attr:`LyapunovResult.attractors`.
    kind : str
        ``'periodic'`` (Newton-refined, Floquet LLE) or ``'not periodic'``.
    starts : tuple[int, ...]
        The starts that ended on it.
    lle, lle_stderr : float
        Finite-time LLE over its starts and its error bar.
    impact_rate : float or None
        Impacts per forcing period.
    period, n_impacts : int or None
        Forcing periods and impacts per cycle of a periodic orbit.
    floquet_lle : float or None
        ``ln |mu_max| / (p T)`` of a periodic orbit.
    multipliers : tuple[complex, ...]
        Floquet multipliers of a periodic orbit (empty otherwise).

    See Also
    --------
    precise_impact.analysis.lyapunov.result.LyapunovResult : the result holding it.
    precise_impact.analysis.lyapunov.lyapunov : the measurement.
    """

    id: int
    kind: str
    starts: tuple[int, ...]
    lle: float
    lle_stderr: float
    impact_rate: float | None = None
    period: int | None = None
    n_impacts: int | None = None
    floquet_lle: float | None = None
    multipliers: tuple[complex, ...] = ()

    @classmethod
    def from_stats(cls, g: dict) -> Attractor:
        """From one entry of ``stats['attractors']``."""
        return cls(
            id=int(g["id"]),
            kind=str(g["kind"]),
            starts=tuple(int(j) for j in g["starts"]),
            lle=float(g["lle"]),
            lle_stderr=float(g["stderr"]),
            impact_rate=None if g.get("impact_rate") is None else float(g["impact_rate"]),
            period=g.get("period"),
            n_impacts=g.get("impacts"),
            floquet_lle=g.get("floquet_lle"),
            multipliers=tuple(complex(re, im) for re, im in g.get("multipliers", ())),
        )


@dataclasses.dataclass(frozen=True)
class StartEstimate:
    """One start's own estimate (typed view of ``stats['per_start']``).

    Attributes
    ----------
    lle, lle_stderr : float
        The start's finite-time LLE and its batch-means error bar.
    impact_rate, impact_rate_stderr : float
        Impacts per period and its error bar (``nan`` where not measured).
    periods : int
        Measured periods of this start.
    attractor : int or None
        The :attr:`Attractor.id` it ended on.

    See Also
    --------
    precise_impact.analysis.lyapunov.result.LyapunovResult : the result holding it.
    precise_impact.analysis.lyapunov.lyapunov : the measurement.
    """

    lle: float
    lle_stderr: float
    impact_rate: float
    impact_rate_stderr: float
    periods: int
    attractor: int | None

    @classmethod
    def from_stats(cls, row: dict) -> StartEstimate:
        """From one entry of ``stats['per_start']``."""
        return cls(
            lle=float(row.get("lle", math.nan)),
            lle_stderr=float(row.get("stderr", math.nan)),
            impact_rate=float(row.get("impact_rate", math.nan)),
            impact_rate_stderr=float(row.get("impact_rate_stderr", math.nan)),
            periods=int(row.get("periods", 0)),
            attractor=row.get("attractor"),
        )


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
    lle_stderr : float
        Standard error of ``lle`` from independent segments (see :func:`block_stderr`);
        ``stderr`` is its deprecated name.
    periods, transient : int
        Measured periods and discarded transient periods.
    n_impacts : int
        Impacts during the measured periods; ``impacts`` is its deprecated name.
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

    See Also
    --------
    precise_impact.analysis.lyapunov.lyapunov : returns it.
    precise_impact.analysis.lyapunov.result.Attractor : the attractor it was measured on.
    precise_impact.analysis.lyapunov.result.StartEstimate : one start's own estimate.
    """

    params: Params
    method: str
    precision: str
    lle: float
    spectrum: tuple[float, float] | None
    lle_stderr: float
    periods: int
    transient: int
    n_impacts: int
    running: np.ndarray
    segments: np.ndarray
    elapsed_s: float
    initial_conditions: int = 1
    strobe_x: np.ndarray | None = None
    strobe_v: np.ndarray | None = None
    stats: dict = dataclasses.field(default_factory=dict)

    #: Deprecated names (one release): ``lle_stderr`` and ``n_impacts``.
    stderr = RenamedAttribute("lle_stderr")
    impacts = RenamedAttribute("n_impacts")

    def _tables(self) -> dict:
        """``to_dataframe()`` tables: ``running`` (default: the estimate after each measured
        period), ``segments`` (each segment's estimate), ``strobe`` (where recorded)."""
        tab = {
            "running": lambda: columns(
                ("period", None, np.arange(1, len(self.running) + 1)),
                ("lle", "1/tau", self.running),
            ),
            "segments": lambda: columns(
                ("segment", None, np.arange(len(self.segments))), ("lle", "1/tau", self.segments)
            ),
        }
        if self.strobe_x is not None and self.strobe_v is not None:
            sx, sv = self.strobe_x, self.strobe_v
            tab["strobe"] = lambda: columns(
                ("period", None, np.arange(len(sx))), ("x", "1", sx), ("v", "1", sv)
            )
        return tab

    def order_spectrum(self) -> None:
        """Put ``spectrum`` in descending order (``lle`` its first value).

        A finite-time estimate of two equal exponents (a non-impacting or quasi-periodic
        orbit: ``-zeta`` twice) can come out with the first below the second by its O(1/t)
        offset (measured: eta = 1000, ``lambda1 = -0.050022 < lambda2 = -0.049978``);
        the two are then equal within that offset and the swap keeps their exact sum.
        """
        if self.spectrum is not None and self.spectrum[0] < self.spectrum[1]:
            self.spectrum = (self.spectrum[1], self.spectrum[0])
            self.lle = self.spectrum[0]

    @property
    def attractors(self) -> tuple[Attractor, ...]:
        """The attractors the starts ended on (empty when not attributed)."""
        return tuple(Attractor.from_stats(g) for g in self.stats.get("attractors", ()))

    @property
    def per_start(self) -> tuple[StartEstimate, ...]:
        """Each start's own estimate (empty when not recorded)."""
        rows = self.stats.get("per_start", ())
        return tuple(StartEstimate.from_stats(r) for r in rows if isinstance(r, dict))

    @property
    def lle_source(self) -> str | None:
        """``'floquet'`` (a periodic orbit's exact value) or ``'finite-time'``."""
        return self.stats.get("lle_source")

    @property
    def headline_attractor(self) -> Attractor | None:
        """The attractor whose values are :attr:`lle` and :attr:`spectrum`."""
        i = self.stats.get("headline_attractor")
        return None if i is None else self.attractors[int(i)]

    def plot(self, path: str | os.PathLike | None = None):
        """The running LLE estimate against the measured periods (its convergence) with the
        final value +- stderr, and each independent segment's estimate.

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf``, ``.svg``, atomically).

        Returns
        -------
        matplotlib.figure.Figure
        """
        fig, axes = new_figure(1, 2, figsize=(11, 4.6), gridspec_kw={"width_ratios": [2, 1]})
        ax1, ax2 = axes[0]
        run = np.asarray(self.running, dtype=float)
        se = self.lle_stderr if math.isfinite(self.lle_stderr) else 0.0
        for ax in (ax1, ax2):
            ax.axhspan(self.lle - se, self.lle + se, color="0.85", label="LLE +- stderr")
            ax.axhline(self.lle, color="k", lw=0.8, label=f"LLE = {self.lle:.5f}")
            if self.params.R == 1:  # otherwise half the sum depends on the impact rate
                ax.axhline(
                    -float(self.params.zeta),
                    color="tab:green",
                    lw=0.8,
                    ls="--",
                    label="-zeta (half the exponent sum at R = 1)",
                )
            ax.grid(True, lw=0.3, alpha=0.5)
        ax1.plot(
            np.arange(1, len(run) + 1), run, lw=0.9, color="tab:blue", label="running estimate"
        )
        ax1.set_xlabel("measured forcing periods")
        ax1.set_ylabel("LLE per unit time tau")
        ax1.set_title("convergence", fontsize=9)
        seg = np.asarray(self.segments, dtype=float)
        ax2.plot(
            np.arange(1, len(seg) + 1),
            seg,
            "o",
            ms=4,
            color="tab:orange",
            label="segment estimates",
        )
        ax2.set_xlabel("independent segment")
        ax2.set_title("segments (their spread gives the stderr)", fontsize=9)
        figure_legend(fig, (ax1, ax2), ncol=5)
        fig.suptitle(
            wrap_title(
                f"LLE of eta = {self.params.decimal()['eta']}: {self.method}, {self.precision}, "
                f"{self.transient} transient + {self.periods} periods, {self.n_impacts} impacts",
                fig,
            ),
            fontsize=10,
        )
        return finish(fig, path)

    def to_dict(self) -> dict:
        """The ``precise-impact lle --json`` object."""
        return {
            "params": self.params.decimal(),
            "method": self.method,
            "lle": self.lle,
            # a -inf exponent (plastic impacts, R = 0) is "-inf" (ResultMixin: strict JSON)
            "spectrum": None if self.spectrum is None else list(self.spectrum),
            "lle_stderr": self.lle_stderr,
            "periods": self.periods,
            "n_impacts": self.n_impacts,
            # the 0.2 keys, kept for one release beside the new ones
            "stderr": self.lle_stderr,
            "impacts": self.n_impacts,
            "elapsed_s": self.elapsed_s,
            "stats": to_jsonable(self.stats),
        }


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
