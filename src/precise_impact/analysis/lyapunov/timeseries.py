"""The largest Lyapunov exponent from a measured time series (Rosenstein's and Kantz's
estimators), with neighbours searched at equal forcing phase.

Details and error bars: docs/guide/captures.rst, "The time-series LLE estimators".
References: Rosenstein et al., Physica D 65 (1993) 117; Kantz, Phys. Lett. A 185 (1994) 77;
Theiler, Phys. Rev. A 34 (1986) 2427 (the Theiler window).
"""

from __future__ import annotations

import dataclasses
import math
import os
import textwrap
from typing import Any

import numpy as np

from precise_impact.core.result import ResultMixin
from precise_impact.errors import OptionalDependencyError, ParameterError, check_type
from precise_impact.io.figures import finish, new_figure

__all__ = [
    "TIMESERIES_METHODS",
    "TimeSeriesLLE",
    "apply_correction",
    "table_bias",
    "delay_embed",
    "student_t975",
    "timeseries_lle",
]

#: The estimators (``method=``).
TIMESERIES_METHODS = ("rosenstein", "kantz")

#: The automatic low-pass cutoff, in forcing harmonics (``lowpass='auto'`` with ``period``).
AUTO_LOWPASS_HARMONIC = 4.0

#: The truth table's correction of each estimator (``fit='floor'``, defaults), measured by
#: ``benchmarks/bench_timeseries_lle.py`` on synthetic captures of the ideal circuit at
#: eta = 0.712, each record its own stretch of the attractor and scored against that stretch's
#: own finite-time variational exponent (:func:`~precise_impact.finite_time_lle`): the
#: relative bias is linear in the curve's noise floor (``stats['noise_floor']``, the log
#: distance the noise sets: noise flattens the start of the curve and lowers the slope),
#: ``bias + bias_per_floor (noise_floor - TRUTH_TABLE_FLOOR)``; ``scatter_record`` is the rms
#: scatter of corrected single records about their stretch's exponent, ``scatter`` about the
#: attractor's (asymptotic) exponent, both for :data:`TRUTH_TABLE_PERIODS`-period records
#: (scaled by ``sqrt(TRUTH_TABLE_PERIODS / periods)``).  ``correct=True`` divides by
#: ``1 + bias(noise_floor)`` and puts ``scatter`` in the error bar, inside
#: :data:`TRUTH_TABLE_DOMAIN` only.
TRUTH_TABLE_BIAS = {
    "rosenstein": {
        "bias": -0.101,
        "bias_per_floor": -0.045,
        "scatter_record": 0.141,
        "scatter": 0.168,
    },
    "kantz": {"bias": -0.056, "bias_per_floor": -0.056, "scatter_record": 0.124, "scatter": 0.145},
}
#: The noise floor the biases of :data:`TRUTH_TABLE_BIAS` refer to (the done-when capture's,
#: 8 bits and 1 % noise: ~-4.0).
TRUTH_TABLE_FLOOR = -4.0
#: The record length (forcing periods) the scatters of :data:`TRUTH_TABLE_BIAS` refer to.
TRUTH_TABLE_PERIODS = 200
#: Where the table was measured: at least this many samples per period (raw), a rise of the
#: divergence curve of at least this many e-folds and a noise floor inside this range (the
#: records' own).
TRUTH_TABLE_DOMAIN = {"samples_per_period": 25, "rise": 2.0, "noise_floor": (-6.0, -2.5)}


def table_bias(method: str, noise_floor: float) -> float:
    """The truth table's relative bias of ``method`` at a divergence curve's ``noise_floor``."""
    c = TRUTH_TABLE_BIAS[method]
    return float(c["bias"] + c["bias_per_floor"] * (noise_floor - TRUTH_TABLE_FLOOR))


#: Reasons a divergence curve gives no exponent (``TimeSeriesLLE.status``).
_FLAT = "flat"
_UNFIT = "unfit"
_UNCERTAIN = "uncertain"
#: A phase-grid drift (fraction of a period per period) beyond which the forcing period is
#: called wrong.
_DRIFT_LIMIT = 0.005


@dataclasses.dataclass(frozen=True, repr=False)
class TimeSeriesLLE(ResultMixin):
    """A largest-Lyapunov-exponent estimate from a time series (:func:`timeseries_lle`).

    Attributes
    ----------
    lle : float
        The exponent in inverse units of ``dt``, bias-corrected by default (NaN when
        ``status`` is ``'flat'`` or ``'unfit'``).
    lle_stderr : float
        Its error bar (``stats['error_bar']`` says what it contains): the jackknife error
        over blocks and, in quadrature, the truth table's record-to-record scatter
        (corrected estimate) or the fit-range systematic (raw estimate).
    stat_stderr, fit_systematic : float
        The two parts of ``lle_stderr`` (``fit_systematic``: the table's scatter when
        corrected).
    method : str
        ``'rosenstein'`` or ``'kantz'``.
    status : str
        ``'ok'``; ``'uncertain'`` (the number is kept, :attr:`reason` says why it is not to
        be trusted: its 95 % interval is wider than the estimate itself, or the phase grid
        drifts -- neighbours at "equal phase" are not, the forcing period given is off);
        ``'unfit'`` (the fit gave no finite slope or error: ``lle`` NaN); ``'flat'`` (the
        curve neither rose nor fell by ``min_rise`` e-folds: neighbours stay at the noise
        floor, as on a periodic attractor; no exponent).
    reason : str
        Why, in words, when ``status != 'ok'`` (else empty).
    lags : numpy.ndarray
        Times the pairs were followed (units of ``dt``).
    divergence : numpy.ndarray
        ``S(t)``, the mean log distance at each lag.
    divergence_stderr : numpy.ndarray
        Its batch-means error at each lag.
    fit_range : (float, float)
        The times ``[t_lo, t_hi]`` fitted.
    intercept : float
        The fitted line's value at ``t = 0``.
    saturation : float
        Mean log distance of random pairs (at equal phase): where ``S`` levels off.
    block_slopes : numpy.ndarray
        The jackknife slopes: the fit with each block of references left out in turn.
    n_references : int
        Reference points used.
    stats : dict
        Settings and counts (samples per period, Theiler window, radius, neighbours...).

    See Also
    --------
    precise_impact.analysis.lyapunov.timeseries.timeseries_lle : the estimate.
    precise_impact.analysis.lyapunov.result.LyapunovResult : the variational exponent.
    """

    lle: float
    lle_stderr: float
    stat_stderr: float
    fit_systematic: float
    method: str
    status: str
    reason: str
    lags: np.ndarray
    divergence: np.ndarray
    divergence_stderr: np.ndarray
    fit_range: tuple[float, float]
    intercept: float
    saturation: float
    block_slopes: np.ndarray
    n_references: int
    stats: dict

    def __repr__(self) -> str:
        return (
            f"TimeSeriesLLE(method={self.method!r}, lle={self.lle:.6g}, "
            f"lle_stderr={self.lle_stderr:.3g}, status={self.status!r}, "
            f"fit_range=({self.fit_range[0]:.4g}, {self.fit_range[1]:.4g}), "
            f"n_references={self.n_references})"
        )

    def to_dict(self) -> dict[str, Any]:
        """The fields as plain JSON types, with :attr:`ci95` (strict JSON: NaN is ``null``)."""
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        d["ci95"] = list(self.ci95)
        return d

    @property
    def ci95(self) -> tuple[float, float]:
        """The 95 % interval: ``lle -+ t_{0.975, n_blocks - 1} lle_stderr`` (Student's t on
        the batch means; 2.26 for 10 blocks)."""
        k = student_t975(len(self.block_slopes))
        return (self.lle - k * self.lle_stderr, self.lle + k * self.lle_stderr)

    def covers(self, value: float) -> bool:
        """Whether ``value`` lies in :attr:`ci95` (never, without an exponent)."""
        lo, hi = self.ci95
        return self.status in ("ok", _UNCERTAIN) and lo <= value <= hi

    def _tables(self) -> dict:
        """``to_dataframe()`` table ``divergence``: the mean log distance ``S`` and its error
        at each lag (lags in the units of ``dt``)."""
        return {
            "divergence": lambda: {
                "lag": np.asarray(self.lags, dtype=float),
                "S": np.asarray(self.divergence, dtype=float),
                "S_stderr": np.asarray(self.divergence_stderr, dtype=float),
            }
        }

    def plot(self, path: str | os.PathLike | None = None, truth: float | None = None):
        """The divergence curve ``S(t)`` with its error band, the fit range and the fitted
        line (and, if given, a line of slope ``truth`` through the same point).

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf``, ``.svg``, atomically).
        truth : float or None, default ``None``
            A reference exponent (e.g. the variational one) drawn for comparison.

        Returns
        -------
        matplotlib.figure.Figure
        """
        fig, axes = new_figure(1, 1, figsize=(7.5, 4.6))
        ax = axes[0][0] if isinstance(axes, np.ndarray) or isinstance(axes, list) else axes
        t = np.asarray(self.lags, dtype=float)
        s = np.asarray(self.divergence, dtype=float)
        e = np.nan_to_num(np.asarray(self.divergence_stderr, dtype=float))
        ax.fill_between(t, s - e, s + e, color="0.85", lw=0, label="S(t) +- stderr")
        ax.plot(t, s, "k.-", ms=2.5, lw=0.8, label=f"S(t), {self.method}")
        lo, hi = self.fit_range
        if self.status == "ok":
            ax.axvspan(lo, hi, color="tab:blue", alpha=0.08, label="fit range")
        ax.axhline(self.saturation, color="0.5", ls=":", lw=0.8, label="random pairs")
        if self.status == "ok":
            tt = np.linspace(lo, hi, 50)
            line = self.intercept + self.lle * tt
            floor = self.stats.get("noise_floor")
            if floor is not None and math.isfinite(floor):
                ax.plot(tt, 0.5 * np.logaddexp(2 * line, 2 * floor), color="tab:orange",
                        lw=1.2, label="fitted: exponential through the noise floor")  # fmt: skip
                ax.axhline(floor, color="tab:orange", ls=":", lw=0.8, label="noise floor")
            ax.plot(
                tt,
                line,
                color="tab:red",
                lw=1.6,
                label=f"slope {self.lle:.4g} +- {self.lle_stderr:.2g}",
            )
            if truth is not None:
                mid = 0.5 * (lo + hi)
                y_mid = self.intercept + self.lle * mid
                ax.plot(
                    tt,
                    y_mid + truth * (tt - mid),
                    color="tab:green",
                    ls="--",
                    lw=1.2,
                    label=f"reference slope {truth:.4g}",
                )
        else:
            ax.set_title("\n".join(textwrap.wrap("no exponent: " + self.reason, 100)), fontsize=8)
        ax.set_xlabel("time followed")
        ax.set_ylabel("mean ln distance")
        ax.grid(True, lw=0.3, alpha=0.5)
        ax.legend(fontsize=8, loc="lower right")
        return finish(fig, path)


def delay_embed(series: Any, dim: int, lag: int = 1) -> np.ndarray:
    """Delay vectors ``(s_n, s_{n+lag}, ..., s_{n+(dim-1) lag})`` of a scalar series (Takens),
    for a channel without its partner; shape ``(len(series) - (dim - 1) lag, dim)``.

    Parameters
    ----------
    series : array_like
        One channel, uniformly sampled.
    dim : int
        Embedding dimension, ``>= 1``.
    lag : int, default 1
        Delay in samples, ``>= 1``.

    Returns
    -------
    numpy.ndarray
        The delay vectors, one per row.

    See Also
    --------
    precise_impact.analysis.lyapunov.timeseries.timeseries_lle : takes the vectors as states.

    Examples
    --------
    >>> from precise_impact.analysis.lyapunov.timeseries import delay_embed
    >>> delay_embed([0.0, 1.0, 2.0, 3.0], 2).tolist()
    [[0.0, 1.0], [1.0, 2.0], [2.0, 3.0]]
    """
    s = np.asarray(series, dtype=float).ravel()
    if not (isinstance(dim, (int, np.integer)) and dim >= 1):
        raise ParameterError("dim", dim, "an integer >= 1")
    if not (isinstance(lag, (int, np.integer)) and lag >= 1):
        raise ParameterError("lag", lag, "an integer >= 1")
    n = len(s) - (dim - 1) * lag
    if n < 1:
        raise ParameterError(
            "series", f"{len(s)} samples", f"more than (dim-1) lag = {(dim - 1) * lag}"
        )
    return np.stack([s[k * lag : k * lag + n] for k in range(dim)], axis=1)


def _check_positive(name: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):  # OverflowError: an int past 1e308
        raise ParameterError(name, value, "a finite number > 0") from None
    if not (math.isfinite(v) and v > 0):
        raise ParameterError(name, value, "a finite number > 0")
    return v


def _phase_grid(y: np.ndarray, dt: float, period: float, phase0: float, per_period: int):
    """``y`` resampled at ``per_period`` samples per forcing period, phase 0 first, whole
    periods only: array ``(M * per_period, d)``."""
    n = len(y)
    cycles = np.arange(n) * (dt / period) + phase0 / (2 * math.pi)  # forcing cycles
    k0 = math.ceil(cycles[0] - 1e-12)
    k1 = math.floor(cycles[-1] + 1e-12)
    m = k1 - k0
    if m < 1:
        return np.empty((0, y.shape[1])), 0
    g = k0 + np.arange(m * per_period) / per_period
    out = np.empty((len(g), y.shape[1]))
    for c in range(y.shape[1]):
        out[:, c] = np.interp(g, cycles, y[:, c])
    return out, m


def _cutoff(lowpass: Any, period: Any, dt: float) -> float | None:
    """The low-pass cutoff frequency (cycles per unit of ``dt``) or ``None`` (no filter)."""
    if lowpass is None:
        return None
    if isinstance(lowpass, str) and lowpass == "auto":
        if period is None:
            return None
        fc = AUTO_LOWPASS_HARMONIC / float(period)
        return fc if fc * 2 * dt < 0.8 else None  # too few samples per period to filter
    fc = _check_positive("lowpass", lowpass)
    if not fc * 2 * dt < 1:
        raise ParameterError("lowpass", lowpass, f"below the Nyquist frequency {0.5 / dt:.6g}")
    return fc


def _select(t: np.ndarray, s: np.ndarray, lo: float, hi: float):
    sel = (t >= lo - 1e-12) & (t <= hi + 1e-12) & np.isfinite(s)
    sel[0] = False  # lag 0: the neighbour was chosen for its small (noisy) distance
    return t[sel], s[sel]


def _filtered_noise(resid: np.ndarray, wn: float) -> np.ndarray:
    """Standard deviation of white noise left in each low-passed component, from the part the
    filter removed: a robust (median absolute deviation) scale of the residual, divided by
    the residual's share of white noise and multiplied by the passed share.  The shares are
    those of the filter run forwards and backwards, ``|H|^2 = 1 / (1 + (f / f_c)^8)``, over
    the band up to Nyquist (``wn = f_c / f_Nyquist``)."""
    f = np.linspace(0.0, 1.0, 4001)
    h2 = 1.0 / (1.0 + (f / wn) ** 8)
    passed, removed = float(np.mean(h2**2)), float(np.mean((1 - h2) ** 2))
    mad = np.median(np.abs(resid - np.median(resid, axis=0)), axis=0) * 1.482602218505602
    return mad * math.sqrt(passed / removed)


def _noise_floor(noise_sd: np.ndarray) -> float:
    """``E[ln |n1 - n2|]`` for two independent noise vectors of component deviations
    ``noise_sd``: ``ln s + (digamma(d / 2) + ln 2) / 2`` with ``s^2 = 2 mean(sd^2)`` (exact for
    equal deviations: ``|n1 - n2| / s`` is chi-distributed with ``d`` degrees of freedom)."""
    from scipy.special import digamma  # noqa: PLC0415 -- optional: loaded on first use

    d = len(noise_sd)
    s2 = 2.0 * float(np.mean(np.square(noise_sd)))
    if s2 <= 0:
        return -math.inf
    return 0.5 * math.log(s2) + 0.5 * (float(digamma(d / 2)) + math.log(2.0))


def _fit_linear(
    t: np.ndarray, s: np.ndarray, lo: float, hi: float, floor: float | None = None
) -> tuple[float, float, float]:
    """Least-squares line over ``[lo, hi]``: ``(slope, intercept, nan)``."""
    tt, ss = _select(t, s, lo, hi)
    if len(tt) < 2:
        return math.nan, math.nan, math.nan
    slope, icpt = np.polyfit(tt, ss, 1)
    return float(slope), float(icpt), math.nan


def _fit_floor(
    t: np.ndarray, s: np.ndarray, lo: float, hi: float, floor: float | None = None
) -> tuple[float, float, float]:
    """``S(t) = ln sqrt(exp(2 (a + lambda t)) + exp(2 b))`` over ``[lo, hi]``: an exponential
    separation seen through a noise floor ``b`` (the measured distance of a pair is the
    true one and the noise's in quadrature).  ``(lambda, a, b)``."""
    from scipy.optimize import least_squares  # noqa: PLC0415 -- optional: loaded on first use

    tt, ss = _select(t, s, lo, hi)
    if len(tt) < 4:
        return math.nan, math.nan, math.nan
    lam0, a0 = np.polyfit(tt, ss, 1)
    if floor is not None:  # the floor measured from the noise: two parameters
        if not math.isfinite(floor):
            return float(lam0), float(a0), floor

        def resid2(p: np.ndarray) -> np.ndarray:
            return 0.5 * np.logaddexp(2 * (p[0] + p[1] * tt), 2 * floor) - ss

        a_start = max(float(a0), float(ss[0]) - 1.0)
        try:
            sol = least_squares(resid2, [a_start, float(lam0)], method="lm")
        except (ValueError, np.linalg.LinAlgError):
            return math.nan, math.nan, math.nan
        if not sol.success or not np.all(np.isfinite(sol.x)):
            return math.nan, math.nan, math.nan
        return float(sol.x[1]), float(sol.x[0]), floor
    b0 = float(ss[0]) - 1.0

    def resid(p: np.ndarray) -> np.ndarray:
        return 0.5 * np.logaddexp(2 * (p[0] + p[1] * tt), 2 * p[2]) - ss

    try:
        sol = least_squares(resid, [a0, lam0, b0], method="lm")
    except (ValueError, np.linalg.LinAlgError):
        return math.nan, math.nan, math.nan
    if not sol.success or not np.all(np.isfinite(sol.x)):
        return math.nan, math.nan, math.nan
    a, lam, b = (float(v) for v in sol.x)
    return lam, a, b


#: The fitted models of the divergence curve (``fit=``).
_FITS = {"floor": _fit_floor, "linear": _fit_linear}
#: Their default fit ranges, as fractions of the rise (``fit_fractions=None``).
_FIT_FRACTIONS = {"floor": (0.0, 0.5), "linear": (0.2, 0.6)}


def _window(t: np.ndarray, s: np.ndarray, y0: float, delta: float, f_lo: float, f_hi: float):
    """First times the curve has moved ``f_lo`` and ``f_hi`` of ``delta`` from ``y0``."""
    prog = (s - y0) / delta
    prog = np.maximum.accumulate(np.nan_to_num(prog, nan=-np.inf))
    i_lo = int(np.searchsorted(prog, f_lo))
    i_hi = int(np.searchsorted(prog, f_hi))
    i_lo = min(i_lo, len(t) - 1)
    i_hi = min(max(i_hi, i_lo + 2), len(t) - 1)
    i_lo = min(i_lo, i_hi - 2) if i_hi >= 2 else 0
    return float(t[max(i_lo, 0)]), float(t[i_hi])


def timeseries_lle(
    states: Any,
    dt: Any,
    *,
    method: str = "kantz",
    period: Any = None,
    phase0: float = 0.0,
    per_period: int | None = None,
    theiler: Any = None,
    max_lag: Any = None,
    lag_step: int | None = None,
    fit: str = "floor",
    fit_range: tuple[float, float] | None = None,
    fit_fractions: tuple[float, float] | None = None,
    fit_shift: float = 0.1,
    radius: float | None = None,
    max_neighbors: int = 4,
    min_rise: float = 1.0,
    n_blocks: int = 10,
    scale: bool = True,
    lowpass: Any = "auto",
    floor_from_noise: bool = True,
    correct: bool = True,
) -> TimeSeriesLLE:
    """Largest Lyapunov exponent of a uniformly sampled record (Rosenstein or Kantz).

    Parameters
    ----------
    states : array_like, shape ``(N,)`` or ``(N, d)``
        The record, one row per sample, one column per state component (any dimension;
        e.g. ``(x, v)`` or a capture's ``(V_s, V_q)``; a scalar channel can be embedded
        first with :func:`delay_embed`).
    dt : float
        Sample interval (the exponent comes out in its inverse units).
    method : str, default ``'kantz'``
        One of :data:`TIMESERIES_METHODS` (Kantz: the smaller scatter and bias in the truth
        table, 12.4 % against 14.1 % rms about a 200-period record's own exponent).
    period : float or None, default ``None``
        Forcing period in the units of ``dt``.  Given: neighbours are searched at equal
        forcing phase (module docstring); ``None``: an autonomous record.
    phase0 : float, default 0
        Forcing phase (radians) at the first sample; phase ``0`` is the first grid point.
    per_period : int or None, default ``None``
        Samples per period of the phase grid (``>= 4``); ``None``: ``round(period / dt)``.
    theiler : float or None, default ``None``
        Theiler window, in units of ``dt``: neighbours closer than this in time are not
        used.  ``None``: two forcing periods (with ``period``), else ``N // 50`` samples.
    max_lag : float or None, default ``None``
        Longest time pairs are followed.  ``None``: a quarter of the record, at most 50
        forcing periods (with ``period``) or ``N // 4`` samples.
    lag_step : int or None, default ``None``
        Lag spacing in (grid) samples; ``None``: an eighth of a period (with ``period``),
        else ``max(1, max_lag / 200)``.
    fit : str, default ``'floor'``
        The model fitted to ``S(t)``: ``'floor'``, an exponential seen through a noise
        floor, ``S = ln sqrt(exp(2 (a + lambda t)) + exp(2 b))`` (the measured distance of a
        pair is the true one and the noise's in quadrature: the slow start of a noisy
        curve is modelled, not fitted as a low slope); ``'linear'``, Rosenstein's straight
        line.
    fit_range : (float, float) or None, default ``None``
        Times to fit.  ``None``: the curve's own rising part, from where it has risen
        ``fit_fractions[0]`` of the way from its start ``S(t_1)`` (the first lag: at lag 0
        the neighbours were chosen for their small noisy distance) to the random-pair level
        to where it has risen ``fit_fractions[1]`` (falls, towards its lowest value, for a
        falling curve).
    fit_fractions : (float, float) or None, default ``None``
        The automatic fit range (``0 <= lo < hi <= 1``); ``None``: ``(0, 0.5)`` for
        ``fit='floor'`` (the floor is part of the model; saturation is not, so the range
        stops half-way up), ``(0.2, 0.6)`` for ``'linear'``.
    fit_shift : float, default 0.1
        The fit range is also moved by this fraction of the rise each way; the largest
        change of the slope is the fit-range systematic.
    radius : float or None, default ``None``
        Kantz's neighbourhood radius (in the scaled units); ``None``: twice the median
        nearest-neighbour distance.
    max_neighbors : int, default 4
        Kantz: at most this many nearest neighbours within ``radius`` per reference.
    min_rise : float, default 1.0
        A curve that moves less than this many e-folds from ``S(0)`` over the followed
        lags gives no exponent (``status='flat'``): the neighbours stay at the noise floor.
    n_blocks : int, default 10
        Blocks of references for the jackknife error (``>= 2``).
    scale : bool, default ``True``
        Divide each component by its standard deviation first.
    lowpass : float, ``'auto'`` or None, default ``'auto'``
        Zero-phase low-pass (4th-order Butterworth run forwards and backwards) applied to
        every component before anything else, cutoff in cycles per unit time.  A linear
        time-invariant filter applied to both members of a pair filters their difference,
        so it changes ``S`` by a constant, not its slope, while white noise drops by
        ``sqrt(Nyquist / cutoff)``.  ``'auto'``: the :data:`AUTO_LOWPASS_HARMONIC`-th
        forcing harmonic when ``period`` is given and the record has the samples for it,
        else no filter; ``None``: no filter.
    floor_from_noise : bool, default ``True``
        With the low-pass, ``fit='floor'`` takes the floor from the noise the filter removed
        (its median absolute deviation, scaled to the passed band: ``stats['noise_sd']``)
        instead of fitting it, for a rising curve that starts above it.
    correct : bool, default ``True``
        Divide by ``1 + bias`` of the truth table at the curve's noise floor
        (:data:`TRUTH_TABLE_BIAS`: -5.6 % for Kantz at the issue's capture) where the record is
        inside :data:`TRUTH_TABLE_DOMAIN`; the error bar is then the jackknife error and the
        table's record-to-record scatter about the attractor's exponent (14.5 % for Kantz at
        200 periods, scaled by ``sqrt(200 / periods)``) in quadrature (the fit-range
        systematic, a proxy for it, is left out).
        ``stats['correction']`` says whether and why, ``stats['bias']`` the bias divided out,
        ``stats['error_bar']`` what the bar contains, ``stats['raw_lle']`` the uncorrected
        value.  ``False``: the raw estimate, with the fit-range systematic in the bar.

    Returns
    -------
    TimeSeriesLLE
        The exponent with its error bar and 95 % interval, the divergence curve, the fit
        range; ``status`` ``'ok'``, ``'uncertain'`` (the number kept, with the reason: a 95 %
        interval wider than the estimate, or a phase grid that drifts -- a wrong forcing
        period), ``'unfit'`` (no finite slope or error: NaN) or ``'flat'`` (no exponent).

    Raises
    ------
    ParameterError
        Bad input (non-finite samples, too short a record, a constant component...).
    OptionalDependencyError
        scipy is not installed (``pip install 'precise_impact[lab]'``).

    See Also
    --------
    precise_impact.analysis.lyapunov.lyapunov : the variational exponent of the model.
    precise_impact.analysis.lyapunov.timeseries.delay_embed : states from one channel.

    References
    ----------
    .. [1] M. T. Rosenstein, J. J. Collins, C. J. De Luca, Physica D 65 (1993) 117-134.
    .. [2] H. Kantz, Phys. Lett. A 185 (1994) 77-87.

    Examples
    --------
    A map whose every small separation grows by 1.8 per step (exponent ``ln 1.8``), and
    white noise (no exponent):

    >>> import numpy as np
    >>> from precise_impact.analysis.lyapunov.timeseries import timeseries_lle
    >>> x = [0.3123]
    >>> for _ in range(5999):
    ...     x.append(1.8 * min(x[-1], 1 - x[-1]))
    >>> r = timeseries_lle(x, 1.0, theiler=10, max_lag=30, lag_step=1)
    >>> r.status, round(r.lle, 2), round(float(np.log(1.8)), 2)
    ('ok', 0.59, 0.59)
    >>> rng = np.random.default_rng(1)
    >>> timeseries_lle(rng.normal(size=(4000, 2)), 0.01, max_lag=2.0).status
    'flat'
    """
    y, dt, lo_f, hi_f, period = _check_inputs(
        states, dt, method, period, fit, fit_fractions, n_blocks, max_neighbors
    )
    y, cutoff, noise_sd = _condition(y, dt, period, lowpass, scale)
    g = _lag_grid(y, dt, period, phase0, per_period, theiler, max_lag, lag_step, n_blocks)
    spp, yg, n_periods, theiler_n = g.spp, g.yg, g.n_periods, g.theiler_n
    step_t, lag_idx = g.step_t, g.lag_idx
    n_ref = len(yg) - g.L  # references (and neighbours) that can be followed for every lag
    refs, nbrs, w, r0 = _neighbours(
        yg, n_ref, spp if period is not None else 0, theiler_n, method, radius, max_neighbors
    )
    if len(refs) < 2 * n_blocks:
        raise ParameterError(
            "states", f"{len(refs)} reference points with a neighbour", f">= {2 * n_blocks}"
        )
    sums, counts = _divergence_sums(yg, refs, nbrs, w, lag_idx, n_ref, n_blocks)
    t = lag_idx * step_t
    with np.errstate(invalid="ignore", divide="ignore"):
        curve = sums.sum(0) / counts.sum(0)
        per_block = sums / counts
    be = per_block.std(axis=0, ddof=1) / math.sqrt(n_blocks)

    sat = _saturation(yg, n_ref, spp if period is not None else 0)
    # S at lag 0 is low by construction (each neighbour was chosen for its small noisy
    # distance); the curve starts at the first lag, where the noise is independent again
    y0 = float(curve[1])
    tail = curve[1:][np.isfinite(curve[1:])]
    rise = float(np.max(tail) - y0)
    fall = float(y0 - np.min(tail))
    stats = _curve_stats(g, period, dt, cutoff, t, w, method, r0, fit, lo_f, hi_f, refs, counts)
    stats["rise"] = rise
    stats["fall"] = fall
    if max(rise, fall) < min_rise and fit_range is None:
        reason = (
            f"the divergence curve moves {max(rise, fall):.2f} e-folds (< min_rise = {min_rise}) "
            "over the lags followed: neighbours stay at the noise floor (periodic or "
            "quasi-periodic data, or too much noise); no exponent"
        )
        nan = math.nan
        return TimeSeriesLLE(
            nan, nan, nan, nan, method, _FLAT, reason, t, curve, be, (0.0, float(t[-1])),
            nan, sat, np.full(n_blocks, nan), len(refs), stats,
        )  # fmt: skip
    sign = 1.0 if rise >= fall else -1.0  # falling: a stable orbit approached
    lo, hi, shifted = _fit_ranges(
        t, curve, tail, sat, y0, fall, sign, fit_range, fit_fractions=(lo_f, hi_f),
        fit_shift=fit_shift,
    )  # fmt: skip
    fixed_floor = _fixed_floor(fit, floor_from_noise, noise_sd, sign, y0, stats)

    def model(t: np.ndarray, s: np.ndarray, lo: float, hi: float) -> tuple[float, float, float]:
        return _FITS[fit](t, s, lo, hi, fixed_floor)

    slope, icpt, floor = model(t, curve, lo, hi)
    slopes_b, stat, syst = _jackknife(model, t, curve, sums, counts, lo, hi, shifted, slope)
    stats["noise_floor"] = floor
    err = math.hypot(stat, syst)
    stats["raw_lle"], stats["raw_stderr"] = slope, err
    stats["bias"] = 0.0
    stats["error_bar"] = (
        f"jackknife over {n_blocks} blocks ({stat:.2g}) and the fit-range systematic "
        f"({syst:.2g}, range moved by {fit_shift:g} of the rise) in quadrature; "
        "bias not corrected"
    )
    applied, why = (False, "not requested (correct=False)")
    if correct:
        applied, why = _correctable(method, fit, sign, period, stats)
    stats["correction"] = why
    if applied and math.isfinite(slope):
        slope, icpt, err, slopes_b, stat, syst = _corrected(
            method, slope, icpt, stat, slopes_b, n_periods, floor, n_blocks, stats
        )
    status, reason, slope, err = _judge(slope, err, slopes_b, lo, hi, rise)
    if period is not None:
        status, reason = _check_phase_grid(yg, spp, theiler_n, n_periods, status, reason, stats)
    return TimeSeriesLLE(
        slope, err, stat, syst, method, status, reason, t, curve, be,
        (lo, hi), icpt, sat, slopes_b, len(refs), stats,
    )  # fmt: skip


def _curve_stats(g, period, dt, cutoff, t, w, method, r0, fit, lo_f, hi_f, refs, counts) -> dict:
    """The result's ``stats``: the grid, the filter, the window, the neighbours, the fit."""
    spp, n_periods, step_t, ls = g.spp, g.n_periods, g.step_t, g.ls
    return {
        "samples_per_period": spp if period is not None else None,
        "raw_samples_per_period": None if period is None else float(period) / dt,
        "periods": n_periods if period is not None else None,
        "lowpass": cutoff,
        "theiler": g.theiler_n * step_t,
        "max_lag": float(t[-1]),
        "lag_step": ls * step_t,
        "neighbours_per_reference": float(np.mean((w > 0).sum(axis=1))),
        "radius": None if method == "rosenstein" else r0,
        "fit": fit,
        "fit_fractions": (lo_f, hi_f),
        "zero_distances": int(len(refs) * len(g.lag_idx) - counts.sum()),
    }


def _fixed_floor(fit, floor_from_noise, noise_sd, sign, y0, stats):
    """The noise floor the fit holds fixed (measured from the filtered-out noise), or None."""
    fixed_floor = None
    if fit == "floor" and floor_from_noise and noise_sd is not None:
        stats["noise_sd"] = [float(v) for v in noise_sd]
        measured = _noise_floor(noise_sd)
        # the noise floor is where a rising curve starts from; a falling curve (a stable
        # orbit approached) goes below it, and a floor above the start is not a floor
        if sign > 0 and measured < y0:
            fixed_floor = measured
    return fixed_floor


def _check_inputs(states, dt, method, period, fit, fit_fractions, n_blocks, max_neighbors):
    """``(y, dt, lo_f, hi_f, period)``: the record as an ``(N, d)`` float array, every
    argument checked (ParameterError, or OptionalDependencyError without scipy)."""
    if method not in TIMESERIES_METHODS:
        raise ParameterError("method", method, "one of " + ", ".join(TIMESERIES_METHODS))
    try:
        import scipy  # noqa: F401, PLC0415 -- optional: loaded on first use (KD-trees, filters, fits)
    except ImportError:
        raise OptionalDependencyError(
            "scipy", "pip install 'precise_impact[lab]'", "timeseries_lle"
        ) from None
    dt = _check_positive("dt", dt)
    wanted = "an array of shape (N,) or (N, d) of numbers"
    check_type(states, (np.ndarray, list, tuple), "states", wanted)
    try:
        y = np.asarray(states, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError("states", "not numbers", wanted) from None
    if y.ndim == 1:
        y = y[:, None]
    if y.ndim != 2 or y.shape[1] < 1:
        raise ParameterError("states", f"shape {y.shape}", "an array of shape (N,) or (N, d)")
    if not np.all(np.isfinite(y)):
        raise ParameterError("states", "non-finite samples", "finite numbers only")
    if not math.isfinite(dt * len(y)):  # the lags are multiples of it
        raise ParameterError("dt", dt, f"a record length N dt = {len(y)} dt below 1e308")
    if fit not in _FITS:
        raise ParameterError("fit", fit, "one of " + ", ".join(_FITS))
    if fit_fractions is None:
        fit_fractions = _FIT_FRACTIONS[fit]
    lo_f, hi_f = (float(v) for v in fit_fractions)
    if not 0 <= lo_f < hi_f <= 1:
        raise ParameterError("fit_fractions", fit_fractions, "0 <= lo < hi <= 1")
    if not (isinstance(n_blocks, (int, np.integer)) and n_blocks >= 2):
        raise ParameterError("n_blocks", n_blocks, "an integer >= 2")
    if not (isinstance(max_neighbors, (int, np.integer)) and max_neighbors >= 1):
        raise ParameterError("max_neighbors", max_neighbors, "an integer >= 1")
    if period is not None:
        period = _check_positive("period", period)
    return y, dt, lo_f, hi_f, period


def _condition(y, dt, period, lowpass, scale):
    """``(y, cutoff, noise_sd)``: the record low-passed (zero phase) and scaled to unit
    variance per component, with the noise the filter removed."""
    cutoff = _cutoff(lowpass, period, dt)
    if cutoff is not None:
        from scipy.signal import butter, sosfiltfilt  # noqa: PLC0415 -- optional: loaded on first use

        sos = butter(4, cutoff * 2 * dt, output="sos")
        y_raw = y
        y = sosfiltfilt(sos, y, axis=0)
        noise_sd = _filtered_noise(y_raw - y, cutoff * 2 * dt)
    else:
        noise_sd = None
    if scale:
        sd = y.std(axis=0)
        if np.any(sd == 0):
            raise ParameterError("states", "a constant component", "every component varying")
        y = (y - y.mean(axis=0)) / sd
        if noise_sd is not None:
            noise_sd = noise_sd / sd
    return y, cutoff, noise_sd


@dataclasses.dataclass
class _Grid:
    """The embedding's time grid: samples per period, the gridded record, the lags."""

    spp: int
    yg: np.ndarray
    n_periods: int
    step_t: float
    theiler_n: int
    ls: int
    L: int
    lag_idx: np.ndarray


def _lag_grid(y, dt, period, phase0, per_period, theiler, max_lag, lag_step, n_blocks) -> _Grid:
    """The embedding: the record on a phase grid (forced data) or as sampled, the Theiler
    window and the lags to follow, checked against the record's length."""
    if period is not None:
        # after the low-pass, 64 grid points per period keep every harmonic it passes
        spp = per_period if per_period is not None else max(4, min(64, round(period / dt)))
        if not (isinstance(spp, (int, np.integer)) and spp >= 4):
            raise ParameterError("per_period", per_period, "an integer >= 4")
        yg, n_periods = _phase_grid(y, dt, period, float(phase0), int(spp))
        step_t = period / spp
        theiler_n = int(math.ceil((2 * period if theiler is None else float(theiler)) / step_t))
        if max_lag is None:
            max_lag = min(n_periods // 4, 50) * period
        ls = max(1, spp // 8) if lag_step is None else int(lag_step)
    else:
        spp, yg, n_periods, step_t = 1, y, 0, dt
        theiler_n = int(math.ceil(float(theiler) / dt)) if theiler is not None else len(y) // 50
        if max_lag is None:
            max_lag = (len(y) // 4) * dt
        ls = max(1, int(float(max_lag) / dt) // 200) if lag_step is None else int(lag_step)
    if ls < 1:
        raise ParameterError("lag_step", lag_step, "an integer >= 1")
    n = len(yg)
    L = int(float(max_lag) / step_t)
    lag_idx = np.arange(0, L + 1, ls)
    if L < 2 * ls or n - L < 2 * theiler_n + 4 * n_blocks:
        raise ParameterError(
            "states",
            f"{len(y)} samples",
            "a record long enough to follow pairs for max_lag past the Theiler window "
            f"(max_lag = {float(max_lag):.4g}, Theiler window {theiler_n * step_t:.4g}, "
            f"{n_periods} whole periods)",
        )
    return _Grid(spp, yg, n_periods, step_t, theiler_n, ls, L, lag_idx)


def _divergence_sums(yg, refs, nbrs, w, lag_idx, n_ref, n_blocks):
    """``(sums, counts)`` per block and lag of the log distances of the pairs followed."""
    block_of = np.minimum((refs * n_blocks) // n_ref, n_blocks - 1)
    sums = np.zeros((n_blocks, len(lag_idx)))
    counts = np.zeros((n_blocks, len(lag_idx)))
    chunk = max(1, 2_000_000 // (len(lag_idx) * yg.shape[1] * nbrs.shape[1]))
    for a in range(0, len(refs), chunk):
        r = refs[a : a + chunk]
        yi = yg[r[:, None] + lag_idx[None, :]]  # (c, l, d)
        dist = np.zeros((len(r), len(lag_idx)))
        for k in range(nbrs.shape[1]):
            jk = nbrs[a : a + chunk, k]
            yj = yg[jk[:, None] + lag_idx[None, :]]
            dist += w[a : a + chunk, k, None] * np.sqrt(((yi - yj) ** 2).sum(axis=2))
        with np.errstate(divide="ignore"):
            ld = np.log(dist)
        ok = np.isfinite(ld)
        b = block_of[a : a + chunk]
        np.add.at(sums, b, np.where(ok, ld, 0.0))
        np.add.at(counts, b, ok)
    return sums, counts


def _fit_ranges(t, curve, tail, sat, y0, fall, sign, fit_range, fit_fractions, fit_shift):
    """``(lo, hi, shifted)``: the times fitted and the two ranges moved by ``fit_shift``."""
    lo_f, hi_f = fit_fractions
    if fit_range is not None:
        lo, hi = (float(v) for v in fit_range)
        if not 0 <= lo < hi:
            raise ParameterError("fit_range", fit_range, "0 <= t_lo < t_hi")
        width = hi - lo
        shifted = [(max(0.0, lo + d * width), hi + d * width) for d in (-fit_shift, fit_shift)]
    else:
        # rising: towards the random-pair level (or the curve's top); falling: its bottom
        top = max(sat, float(np.max(tail))) if math.isfinite(sat) else float(np.max(tail))
        delta = top - y0 if sign > 0 else fall
        sc = sign * curve
        lo, hi = _window(t, sc, sign * y0, delta, lo_f, hi_f)
        shifted = [
            _window(t, sc, sign * y0, delta, max(0.0, lo_f + d * (lo_f > 0)), min(1.0, hi_f + d))
            for d in (-fit_shift, fit_shift)
        ]
    return lo, hi, shifted


def _jackknife(model, t, curve, sums, counts, lo, hi, shifted, slope):
    """``(block slopes, statistical error, fit-range systematic)`` of the fitted slope."""
    n_blocks = len(sums)
    # delete-one-block jackknife of the whole fit (Efron & Stein 1981): each block left out
    # in turn, the curve of the other blocks fitted over the same range; a nonlinear fit of
    # one block's own noisy curve would inflate the spread
    tot_s, tot_c = sums.sum(0), counts.sum(0)
    with np.errstate(invalid="ignore", divide="ignore"):
        slopes_b = np.array(
            [model(t, (tot_s - sums[b]) / (tot_c - counts[b]), lo, hi)[0] for b in range(n_blocks)]
        )
    good = np.isfinite(slopes_b)
    nb = int(good.sum())
    stat = (
        float(math.sqrt((nb - 1) / nb * np.sum((slopes_b[good] - slopes_b[good].mean()) ** 2)))
        if nb >= 2
        else math.inf
    )
    syst = max((abs(model(t, curve, a, b)[0] - slope) for a, b in shifted), default=0.0)
    syst = 0.0 if not math.isfinite(syst) else syst
    return slopes_b, stat, syst


def _corrected(method, slope, icpt, stat, slopes_b, n_periods, floor, n_blocks, stats):
    """The estimate divided by the truth table's bias, its error bar the table's scatter
    (``(slope, intercept, error, block slopes, stat, syst)``; ``stats`` says so)."""
    # the truth table measured the estimator's error on records whose exponent is known:
    # its mean bias, and the scatter of single records about it (over its conditions and
    # over independent stretches of the attractor); that scatter replaces the fit-range
    # proxy (benchmarks/results/timeseries_lle.md)
    b = table_bias(method, floor)
    sb = TRUTH_TABLE_BIAS[method]["scatter"]
    slope, stat_c, syst_c = apply_correction(method, slope, stat, n_periods, floor)
    icpt = icpt / (1 + b)
    err = math.hypot(stat_c, syst_c)
    slopes_b = slopes_b / (1 + b)
    stats["bias"] = b
    stats["error_bar"] = (
        f"jackknife over {n_blocks} blocks ({stat_c:.2g}) and the truth table's scatter of "
        f"single {TRUTH_TABLE_PERIODS}-period records about the attractor's exponent "
        f"({sb:.1%} of the estimate, x sqrt({TRUTH_TABLE_PERIODS}/{n_periods}) periods: "
        f"{syst_c:.2g}) in quadrature; raw estimate divided by 1 {b:+.3f} (the table's bias "
        f"at a noise floor of {floor:.2f})"
    )
    return slope, icpt, err, slopes_b, stat_c, syst_c


def _judge(slope, err, slopes_b, lo, hi, rise):
    """``(status, reason, slope, err)``: unfit (no finite slope or error: NaN), uncertain
    (the 95 % interval wider than the estimate) or ok."""
    status, reason = "ok", ""
    if not (math.isfinite(slope) and math.isfinite(err)):
        status = _UNFIT
        reason = (
            f"the fit of the divergence curve over t = [{lo:.4g}, {hi:.4g}] gave slope {slope:.3g} "
            f"+- {err:.3g} (rise {rise:.2f} e-folds): no exponent"
        )
        slope = err = math.nan
    else:
        k = student_t975(len(slopes_b))
        if 2 * k * err > abs(slope):
            status = _UNCERTAIN
            reason = (
                f"the 95 % interval ({slope - k * err:.3g}, {slope + k * err:.3g}) is wider than "
                f"the estimate {slope:.3g} itself: no reliable exponent (too short or noisy a "
                "record, or a wrong forcing period)"
            )
    return status, reason, slope, err


def _check_phase_grid(yg, spp, theiler_n, n_periods, status, reason, stats):
    """``(status, reason)`` with the phase grid's drift checked (a forcing period off)."""
    drift = _phase_drift(yg, int(spp), theiler_n)
    stats["phase_drift"] = drift
    limit = max(_DRIFT_LIMIT, 1.0 / max(n_periods, 1))  # resolution: 1/4 period per record
    if drift is not None and abs(drift) > limit:
        if status == "ok":
            status = _UNCERTAIN
        reason += ("; " if reason else "") + (
            f"neighbours at 'equal phase' are not: the phase grid drifts by {drift:+.2%} of a "
            f"period per period (the forcing period given is ~{drift:+.1%} off; the "
            "exponent assumes the right one)"
        )
    return status, reason


def apply_correction(
    method: str, raw: float, stat: float, periods: float, noise_floor: float
) -> tuple[float, float, float]:
    """The truth table's correction of a raw estimate with jackknife error ``stat`` from a
    record of ``periods`` forcing periods whose divergence curve has ``noise_floor``:
    ``(lle, stat part, table part)`` of the default result (the table's record-to-record
    scatter falls as ``periods^-1/2``, a finite-time exponent's)."""
    b = table_bias(method, noise_floor)
    lle = raw / (1 + b)
    sb = TRUTH_TABLE_BIAS[method]["scatter"]
    return lle, stat / (1 + b), abs(lle) * sb * math.sqrt(TRUTH_TABLE_PERIODS / max(periods, 1))


def student_t975(n_blocks: int) -> float:
    """Student's ``t_{0.975}`` with ``n_blocks - 1`` degrees of freedom."""
    from scipy.stats import t as student  # noqa: PLC0415 -- optional: loaded on first use

    return float(student.ppf(0.975, max(1, n_blocks - 1)))


def _correctable(method: str, fit: str, sign: float, period: Any, stats: dict) -> tuple[bool, str]:
    """Whether the truth table's bias correction applies to this estimate, and why (not)."""
    lo_spp, lo_rise = TRUTH_TABLE_DOMAIN["samples_per_period"], TRUTH_TABLE_DOMAIN["rise"]
    lo_fl, hi_fl = TRUTH_TABLE_DOMAIN["noise_floor"]
    if fit != "floor" or sign < 0 or period is None:
        return False, "not applied: the table covers rising curves of forced records, fit='floor'"
    if stats["raw_samples_per_period"] < lo_spp:
        return False, f"not applied: fewer than {lo_spp} samples per period"
    if stats["rise"] < lo_rise:
        return False, f"not applied: the curve rises {stats['rise']:.2f} < {lo_rise} e-folds"
    floor = stats.get("noise_floor")
    if floor is None or not lo_fl <= floor <= hi_fl:
        return False, f"not applied: a noise floor outside the table's {lo_fl}..{hi_fl}"
    b = table_bias(method, floor)
    sb = TRUTH_TABLE_BIAS[method]["scatter"]
    return (
        True,
        f"divided by 1 {b:+.3f} (the table's bias at this noise floor; +- {sb:.3f} in the bar)",
    )


def _neighbours(y, n_ref, spp, theiler_n, method, radius, max_neighbors):
    """Reference indices, their neighbours ``(n, k)`` and weights ``(n, k)`` (Rosenstein: one
    neighbour, weight 1; Kantz: up to ``max_neighbors`` within ``radius``, weights
    ``1 / count``).  With ``spp > 0`` the search is within each phase section."""
    from scipy.spatial import cKDTree  # noqa: PLC0415 -- optional: loaded on first use

    k_query = max_neighbors if method == "kantz" else 1
    k_ask = k_query + 2 * (theiler_n // max(spp, 1)) + 2 if spp else k_query + 2 * theiler_n + 2
    groups = [np.arange(p, n_ref, spp) for p in range(spp)] if spp else [np.arange(n_ref)]
    all_r, all_j, all_d = [], [], []
    for g in groups:
        if len(g) < 2:
            continue
        tree = cKDTree(y[g])
        kk = min(k_ask, len(g))
        d, ix = tree.query(y[g], k=kk)
        d = d.reshape(len(g), kk)
        ix = ix.reshape(len(g), kk)
        j = g[ix]
        far = np.abs(j - g[:, None]) > theiler_n
        d = np.where(far, d, np.inf)
        order = np.argsort(d, axis=1, kind="stable")[:, :k_query]
        all_r.append(g)
        all_j.append(np.take_along_axis(j, order, 1))
        all_d.append(np.take_along_axis(d, order, 1))
    refs = np.concatenate(all_r)
    nb = np.concatenate(all_j)
    dd = np.concatenate(all_d)
    if method == "kantz":
        r0 = float(np.median(dd[np.isfinite(dd[:, 0]), 0])) * 2 if radius is None else float(radius)
        inside = dd <= r0
    else:
        r0 = math.nan
        inside = np.isfinite(dd)
    has = inside[:, 0]
    refs, nb, inside = refs[has], nb[has], inside[has]
    w = inside / inside.sum(axis=1, keepdims=True)
    nb = np.where(inside, nb, refs[:, None])
    order = np.argsort(refs, kind="stable")
    return refs[order], nb[order], w[order], r0


def _saturation(y, n_ref, spp):
    """Mean log distance of pairs half the record apart (equal phase with ``spp``)."""
    half = (n_ref // 2 // spp) * spp if spp else n_ref // 2
    half = max(half, 1)
    a = y[: len(y) - half]
    b = y[half:]
    d = np.sqrt(((a - b) ** 2).sum(axis=1))
    d = d[d > 0]
    return float(np.mean(np.log(d))) if len(d) else math.nan


def _phase_drift(y: np.ndarray, spp: int, theiler_n: int, max_refs: int = 20000) -> float | None:
    """How far the phase grid drifts per period, from neighbours searched at *every* phase.

    On a forced record two states close in ``(x, v)`` are mostly at equal forcing phase.
    With the right period their grid phases differ by ~0 whatever their distance in time;
    with a period off by ``delta`` (relative), a pair ``n`` periods apart is at equal true
    phase when its grid phases differ by ``-n delta``.  ``delta`` is the maximiser of the
    phase coherence ``|< exp(2 pi i (phi + n delta)) >|`` over ``|delta| <= 0.1``; ``None``
    when the neighbours carry no phase information (coherence at the maximum < 0.2)."""
    from scipy.spatial import cKDTree  # noqa: PLC0415 -- optional: loaded on first use

    n = len(y)
    if n < 4 * spp or spp < 4:
        return None
    step = max(1, n // max_refs)
    idx = np.arange(0, n, step)
    tree = cKDTree(y)
    k = min(n, 2 * theiler_n + 4) if 2 * theiler_n + 4 < 64 else 64
    d, ix = tree.query(y[idx], k=k)
    far = np.abs(ix - idx[:, None]) > theiler_n
    first = np.argmax(far, axis=1)
    has = far[np.arange(len(idx)), first]
    if has.sum() < 50:
        return None
    i = idx[has]
    j = ix[has, first[has]]
    gap = (j - i).astype(float)
    periods_apart = gap / spp
    phi = gap / spp - np.round(gap / spp)  # grid phase difference, in periods
    n_per = n / spp
    deltas = np.arange(-0.1, 0.1 + 1e-12, 0.25 / n_per)
    coh = np.abs(np.exp(2j * np.pi * (phi[None, :] + np.outer(deltas, periods_apart))).mean(axis=1))
    best = int(np.argmax(coh))
    if coh[best] < 0.2:
        return None
    return float(deltas[best])
