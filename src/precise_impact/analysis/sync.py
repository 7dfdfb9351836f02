"""Complete synchronisation of master-slave impact oscillators and its coupling threshold.

For diagonal coupling the synchronous state is stable iff ``k > lambda_max`` (Pikovsky,
Rosenblum & Kurths, *Synchronization*, 2001, sec. 13.1); :func:`sync_scan` measures the
synchronised fraction against ``k`` and records on-off intermittency (``docs/numerics.rst``).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
import time as _time
from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.analysis.lyapunov import lyapunov
from precise_impact.analysis.scan import check_axis, check_workers, resolve_model, run_scan
from precise_impact.core.budget import enforce_max_time
from precise_impact.core.params import (
    Params,
    as_params,
    check_count,
    decimal_str,
    exact,
    exact_grid,
)
from precise_impact.core.precision import Precision
from precise_impact.core.result import ResultMixin, columns, record_columns
from precise_impact.errors import ParameterError
from precise_impact.io.atomic import atomic_write
from precise_impact.io.figures import (
    finish,
    legend_outside,
    new_figure,
    plot_differences,
    plot_units,
    save_figure,
    wrap_title,
)
from precise_impact.io.progress import ProgressArg, check_progress, say, wanted
from precise_impact.solvers.heyoka.coupled import CoupledTrajectory, check_form, check_k
from precise_impact.solvers.simulate import simulate_coupled

#: Most slave starts per coupling value (one stated range for the CLI and the API).
MAX_ENSEMBLE = 10_000

__all__ = [
    "MAX_ENSEMBLE",
    "SyncRun",
    "SyncResult",
    "sync_scan",
    "classify",
    "plot_fig7",
    "plot_sync_fraction",
    "ensemble_y0",
]

_PLOT_FORMATS = {".png": "png", ".pdf": "pdf", ".svg": "svg"}


# ------------------------------------------------------------------ per run
@dataclasses.dataclass
class SyncRun(ResultMixin):
    """Outcome of one master-slave run.

    Attributes
    ----------
    y0 : tuple[Fraction, Fraction]
        Slave initial condition (in the form's own variables).
    synchronised : bool
        ``|x - y| < threshold`` at every checked sample of the tail.
    intermittent : bool
        ``|x - y|`` fell below ``threshold`` at some sample but the run is not
        synchronised over the whole tail.
    burst : bool
        After first falling below ``threshold`` it rose above it again (on-off
        intermittency proper; a run that merely arrives late is not a burst).
        Synchronised runs near the threshold usually have bursts too, before the
        tail: the finite-time transverse exponent fluctuates strongly.
    final : float
        ``|x - y|`` at the last sample.
    minimum : float
        Smallest ``|x - y|`` over the run.
    rate : float
        Least-squares slope of ``ln |x - y|`` against ``t`` over the second half of
        the run, using only samples above the round-off floor ``1e3 eps``; NaN if
        fewer than two periods of samples remain (e.g. it reached the floor before
        mid-run).  For the first-order form it estimates ``lambda_max - k`` while
        ``|x - y|`` is small; a run saturated at the attractor size gives ~0.
    collapsed : bool
        ``|x - y|`` is exactly 0 at the end: the slave has become the master bit for
        bit.  In floating point this state is absorbing (on the diagonal every
        coupling term is exactly 0, see :mod:`precise_impact.solvers.heyoka.coupled`), so a run
        that a fluctuation brings down to round-off stays synchronised for ever even
        slightly *below* the threshold, where a real (noisy) pair would desynchronise.
    """

    y0: tuple
    synchronised: bool
    intermittent: bool
    burst: bool
    final: float
    minimum: float
    rate: float
    collapsed: bool = False

    def to_dict(self) -> dict:
        return {
            "y0": [decimal_str(q) for q in self.y0],
            "synchronised": self.synchronised,
            "intermittent": self.intermittent,
            "burst": self.burst,
            "final": self.final,
            "minimum": self.minimum,
            "rate": None if math.isnan(self.rate) else self.rate,
            "collapsed": self.collapsed,
        }


def classify(traj: CoupledTrajectory, tail: float, threshold: float) -> SyncRun:
    """Classify one run with dense output (see :class:`SyncRun`).

    The tail is the last ``ceil(tail * periods)`` periods; every dense sample in it
    (which includes the stroboscopic ones) must lie below ``threshold``.
    """
    if traj.dense_t is None:
        raise ParameterError("per_period", 0, "classification needs dense output: per_period >= 1")
    t, d = traj.difference(dense=True)
    n = traj.periods
    per = (len(t) - 1) // max(n, 1)
    n_tail = min(n, max(1, math.ceil(tail * n)))
    tail_d = d[(n - n_tail) * per :]
    synchronised = bool(np.all(tail_d < threshold))
    below = d < threshold
    reached = bool(below.any())
    burst = False
    if reached:
        first = int(np.argmax(below))
        burst = bool(np.any(~below[first:]))
    floor = 1e3 * traj.precision.eps_float
    half = t >= t[0] + (t[-1] - t[0]) / 2
    use = half & (d > floor)
    rate = math.nan
    if np.count_nonzero(use) >= 2 * per and np.count_nonzero(use) >= 3:
        rate = float(np.polyfit(t[use], np.log(d[use]), 1)[0])
    return SyncRun(
        y0=traj.y0,
        synchronised=synchronised,
        intermittent=reached and not synchronised,
        burst=burst,
        final=float(d[-1]),
        minimum=float(d.min()),
        rate=rate,
        collapsed=bool(d[-1] == 0.0),
    )


def ensemble_y0(
    params: Params, ensemble: int, seed: int, spread: Fraction = Fraction(1)
) -> list[tuple[Fraction, Fraction]]:
    """Deterministic slave initial conditions around the master's ``(x0, v0)``.

    ``y0 = (x0 + spread u1, v0 + spread u2)`` with ``u`` on the grid ``j / 10**6``,
    ``j`` uniform in ``[-10**6, 10**6]`` from ``numpy.random.default_rng(seed)``
    (exact rationals); a position beyond the wall is reflected about it.
    """
    rng = np.random.default_rng(seed)
    draws = rng.integers(-(10**6), 10**6, size=(ensemble, 2), endpoint=True)
    out = []
    for j1, j2 in draws:
        yp = params.x0 + spread * Fraction(int(j1), 10**6)
        if yp > params.x_w:
            yp = 2 * params.x_w - yp
        out.append((yp, params.v0 + spread * Fraction(int(j2), 10**6)))
    return out


# ------------------------------------------------------------------ the scan
@dataclasses.dataclass
class SyncResult(ResultMixin):
    """Result of :func:`sync_scan`.

    Attributes
    ----------
    params : Params
    form : str
    k_values : list[Fraction]
        Couplings, ascending, exact.
    periods, ensemble, seed, per_period : int
    tail, threshold : float
    fraction_synchronised, fraction_intermittent, fraction_burst, fraction_collapsed : numpy arrays
        Per ``k``: fraction of the ensemble synchronised / intermittent / bursting /
        collapsed onto the master bit for bit (see :class:`SyncRun`).
    mean_rate : numpy array
        Per ``k``: mean of the runs' finite ``rate`` (NaN if none).
    runs : list[list[SyncRun]]
        ``runs[i][j]``: member ``j`` at ``k_values[i]``.
    k_star, k_star_err : float
        Coupling where the synchronised fraction first crosses 1/2 upwards (linear
        interpolation between grid points) and the half-width of the bracketing
        grid interval; NaN if there is no crossing in range (see ``message``).
    message : str
        How ``k_star`` was obtained (or why not).
    lle, lle_stderr : float
        Variational LLE of the single oscillator (:func:`variational_spectrum`)
        with its batch-means standard error; NaN if ``lle_periods = 0``.
    lle_periods : int
    elapsed_s : float
        Wall time of the whole scan (LLE included).

    See Also
    --------
    precise_impact.analysis.sync.sync_scan : returns it.
    precise_impact.solvers.simulate.simulate_coupled : one run of the scan.
    """

    params: Params
    form: str
    k_values: list
    periods: int
    ensemble: int
    seed: int
    per_period: int
    tail: float
    threshold: float
    fraction_synchronised: np.ndarray
    fraction_intermittent: np.ndarray
    fraction_burst: np.ndarray
    fraction_collapsed: np.ndarray
    mean_rate: np.ndarray
    runs: list
    k_star: float
    k_star_err: float
    message: str
    lle: float
    lle_stderr: float
    lle_periods: int
    elapsed_s: float

    def plot(self, path: str | os.PathLike | None = None):
        """The synchronised and intermittent fractions against ``k`` with the LLE band and
        ``k*`` (:func:`sync_fraction_figure`).

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf``, ``.svg``, atomically).

        Returns
        -------
        matplotlib.figure.Figure
        """
        return finish(sync_fraction_figure(self), path, dpi=150)

    def _tables(self) -> dict:
        """``to_dataframe()`` tables: ``k`` (default: one row per coupling) and ``runs`` (one
        row per run)."""
        k = [float(x) for x in self.k_values]

        def runs() -> dict:
            rows = [
                {
                    "k": k[i],
                    "member": j,
                    "y0_0": float(r.y0[0]),
                    "y0_1": float(r.y0[1]),
                    **{f.name: getattr(r, f.name) for f in dataclasses.fields(r) if f.name != "y0"},
                }
                for i, member in enumerate(self.runs)
                for j, r in enumerate(member)
            ]
            return record_columns(rows)

        return {
            "k": lambda: columns(
                ("k", "1", k),
                *(
                    (n, None, np.asarray(getattr(self, n), dtype=float))
                    for n in (
                        "fraction_synchronised",
                        "fraction_intermittent",
                        "fraction_burst",
                        "fraction_collapsed",
                    )
                ),
                ("mean_rate", "1/tau", self.mean_rate),
            ),
            "runs": runs,
        }

    def to_dict(self) -> dict:
        def num(x):
            return None if x is None or (isinstance(x, float) and math.isnan(x)) else float(x)

        return {
            "params": self.params.decimal(),
            "form": self.form,
            "k_values": [decimal_str(k) for k in self.k_values],
            "periods": self.periods,
            "ensemble": self.ensemble,
            "seed": self.seed,
            "per_period": self.per_period,
            "tail": self.tail,
            "threshold": self.threshold,
            "fraction_synchronised": [float(f) for f in self.fraction_synchronised],
            "fraction_intermittent": [float(f) for f in self.fraction_intermittent],
            "fraction_burst": [float(f) for f in self.fraction_burst],
            "fraction_collapsed": [float(f) for f in self.fraction_collapsed],
            "mean_rate": [num(r) for r in self.mean_rate],
            "k_star": num(self.k_star),
            "k_star_err": num(self.k_star_err),
            "message": self.message,
            "lle": num(self.lle),
            "lle_stderr": num(self.lle_stderr),
            "lle_periods": self.lle_periods,
            "runs": [[r.to_dict() for r in row] for row in self.runs],
            "elapsed_s": self.elapsed_s,
        }


def half_crossing(k: Sequence[float], frac: Sequence[float]) -> tuple[float, float, str]:
    """First upward crossing of 1/2 by ``frac(k)``: ``(k*, half-width, message)``.

    Linear interpolation between the bracketing grid points ``k_i < k_{i+1}``
    with ``frac_i < 1/2 <= frac_{i+1}``; the error is ``(k_{i+1} - k_i) / 2``.
    """
    k = [float(v) for v in k]
    f = [float(v) for v in frac]
    if not k:
        return math.nan, math.nan, "no k values"
    if f[0] >= 0.5:
        return (
            math.nan,
            math.nan,
            f"no crossing in range: fraction >= 1/2 already at the lowest k = {k[0]:g}",
        )
    for i in range(len(k) - 1):
        if f[i] < 0.5 <= f[i + 1]:
            ks = k[i] + (0.5 - f[i]) * (k[i + 1] - k[i]) / (f[i + 1] - f[i])
            msg = f"fraction crosses 1/2 between k = {k[i]:g} and {k[i + 1]:g}"
            later = [j for j in range(i + 1, len(k)) if f[j] < 0.5]
            if later:
                again = ", ".join(f"{k[j]:g}" for j in later)
                msg += f"; not monotone: below 1/2 again at k = {again}"
            return ks, (k[i + 1] - k[i]) / 2, msg
    return (
        math.nan,
        math.nan,
        f"no crossing in range: fraction < 1/2 up to the highest k = {k[-1]:g}",
    )


def _sync_rows(
    params, ks, form, periods, y0s, per_period, P, engine, tail, threshold, lo, hi
) -> list[tuple[list[SyncRun], float]]:
    """The runner's job: the ensemble at ``ks[lo:hi]``, each row with its wall time."""
    out = []
    for k in ks[lo:hi]:
        t_k = _time.perf_counter()
        row = []
        for y0 in y0s:
            tr = simulate_coupled(
                params, k, form, periods, y0=y0, per_period=per_period, precision=P, model=engine
            )
            row.append(classify(tr, tail, threshold))
        out.append((row, _time.perf_counter() - t_k))
    return out


def _check_k_values(k_values: Sequence[Any]) -> list[Fraction]:
    """``k_values`` (a sequence, or an axis tuple ``('k', start, stop, n)``) as exact couplings,
    sorted and distinct."""
    if (
        not isinstance(k_values, (str, bytes))
        and isinstance(k_values, Sequence)
        and len(k_values) == 4
        and k_values[0] == "k"
    ):
        _, lo, hi, n = check_axis(k_values, "k", "k_values")
        k_values = exact_grid(lo, hi, n, "k")
    if (
        isinstance(k_values, (str, bytes))
        or not isinstance(k_values, Sequence)
        or len(k_values) == 0
    ):
        raise ParameterError("k_values", k_values, "a non-empty sequence of couplings k >= 0")
    ks = sorted(check_k(k, "k_values") for k in k_values)
    if len(set(ks)) != len(ks):
        raise ParameterError("k_values", [decimal_str(k) for k in ks], "couplings must be distinct")
    return ks


def _check_counts(
    periods: Any,
    ensemble: Any,
    seed: Any,
    tail: Any,
    threshold: Any,
    per_period: Any,
    spread: Any,
    lle_periods: Any,
    lle_transient: Any,
) -> tuple[int, int, int, Fraction, Fraction, int, Fraction, int, int]:
    """:func:`sync_scan`'s counts and levels, checked in that order (``tail``, ``threshold``
    and ``spread`` exact)."""
    periods = check_count(periods, "periods")
    if periods < 1:
        raise ParameterError("periods", periods, "an integer with 1 <= periods <= 100000000")
    ensemble = check_count(ensemble, "ensemble", MAX_ENSEMBLE, minimum=1)
    seed = check_count(seed, "seed", 2**63 - 1)
    tq = exact("tail", tail)
    if not 0 < tq <= 1:
        raise ParameterError("tail", tail, "fraction of the run with 0 < tail <= 1")
    thr = exact("threshold", threshold)
    if not thr > 0:
        raise ParameterError("threshold", threshold, "a finite |x - y| level > 0")
    per_period = check_count(per_period, "per_period", 100_000)
    if per_period < 1:
        raise ParameterError("per_period", per_period, "an integer with 1 <= per_period <= 100000")
    sq = exact("spread", spread)
    # the slaves start at x0 + spread j / 10**6 (|j| <= 10**6, ensemble_y0): every start must
    # be a state the pair accepts (0, or 1e-100 <= |y| <= 1e100; spread 1.8e-100 gave a start
    # of 1.2e-104, refused naming y0[1] instead of spread)
    if not Fraction(1, 10**94) <= sq <= 10**94:
        raise ParameterError(
            "spread", spread, "half-width of the initial-condition box, 1e-94 <= spread <= 1e94"
        )
    lle_periods = check_count(lle_periods, "lle_periods")
    if 0 < lle_periods < 4:  # the variational estimate runs 4 initial conditions
        raise ParameterError(
            "lle_periods",
            lle_periods,
            "0 (no LLE) or an integer with 4 <= lle_periods <= 100000000",
        )
    lle_transient = check_count(lle_transient, "lle_transient")
    return periods, ensemble, seed, tq, thr, per_period, sq, lle_periods, lle_transient


def _report_row(
    ks: list[Fraction], form: str, ensemble: int, progress: ProgressArg, i: int, rows: list
) -> None:
    """One progress line for ``ks[i]``, as its row finishes (the runner's ``on_tile``)."""
    row, seconds = rows[0]
    ns = sum(r.synchronised for r in row)
    ni = sum(r.intermittent for r in row)
    say(
        f"  sync {form} k={decimal_str(ks[i])}: {ns}/{ensemble} synchronised, "
        f"{ni} intermittent ({seconds:.2f} s)",
        progress,
    )


def _fractions(
    runs: list[list[SyncRun]],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per ``k``: fractions synchronised, intermittent, bursting, collapsed; mean finite rate."""
    fs = np.array([np.mean([r.synchronised for r in row]) for row in runs])
    fi = np.array([np.mean([r.intermittent for r in row]) for row in runs])
    fb = np.array([np.mean([r.burst for r in row]) for row in runs])
    fc = np.array([np.mean([r.collapsed for r in row]) for row in runs])
    mr = np.array(
        [
            float(np.mean(finite))
            if (finite := [r.rate for r in row if math.isfinite(r.rate)])
            else math.nan
            for row in runs
        ]
    )
    return fs, fi, fb, fc, mr


def _single_lle(
    params: Params, engine: str, lle_periods: int, lle_transient: int
) -> tuple[float, float]:
    """The single oscillator's variational LLE and its standard error (NaN, NaN if
    ``lle_periods = 0``)."""
    lle = lle_se = math.nan
    if lle_periods > 0:
        lr = lyapunov(
            params,
            "variational",
            model="fast" if engine == "fast" else "heyoka",
            periods=lle_periods,
            transient=lle_transient,
        )
        lle, lle_se = float(lr.lle), float(lr.lle_stderr)
    return lle, lle_se


def sync_scan(
    params: Params,
    form: str,
    k_values: Sequence[Any],
    periods: int = 500,
    ensemble: int = 8,
    seed: int = 0,
    tail: float = 0.1,
    threshold: float = 1e-8,
    progress: ProgressArg = False,
    per_period: int = 20,
    spread: Any = 1,
    lle_periods: int = 20000,
    lle_transient: int = 1000,
    precision: str | Precision = "float64",
    engine: str | None = None,
    *,
    model: str | None = None,
    workers: int | None = 1,
    max_time: Any = None,
) -> SyncResult:
    """Fraction of synchronised master-slave runs against the coupling ``k``.

    Parameters
    ----------
    params : Params
        System and the master's initial condition (every run starts the master there).
    form : str
        One of :data:`~precise_impact.solvers.heyoka.coupled.COUPLED_FORMS`.
    k_values : sequence of decimals, or an axis tuple ``('k', start, stop, n)``
        Couplings ``>= 0`` (exact; sorted ascending; no duplicates), or ``n`` evenly
        spaced exact values from ``start`` to ``stop`` (both included).
    periods : int, default 500
        Forcing periods per run (the paper's Fig. 7); ``>= 1``.
    ensemble : int, default 8
        Runs per ``k``, slave initial conditions from :func:`ensemble_y0`; ``>= 1``.
    seed : int, default 0
        Seed of those initial conditions (the same ensemble at every ``k``).
    tail : float, default 0.1
        Fraction of the run (``0 < tail <= 1``) over which a synchronised run must
        stay below ``threshold`` (at least one period).
    threshold : float, default 1e-8
        ``|x - y|`` below which the pair counts as synchronised; ``> 0``.
    progress : bool, None or callable, default ``False``
        :data:`~precise_impact.io.progress.ProgressArg`: one line per ``k`` on stderr
        (``None``: only on a terminal), or ``progress(k_done, k_total)``.
    per_period : int, default 20
        Dense samples per period checked in the tail (stroboscopic ones included); ``>= 1``.
    spread : decimal, default 1
        Half-width of the slave initial-condition box around ``(x0, v0)``;
        ``1e-94 <= spread <= 1e94`` (every start ``x0 + spread j / 10**6`` stays a state the
        pair accepts).
    lle_periods : int, default 20000
        Periods for the single oscillator's LLE (:func:`~precise_impact.analysis.lyapunov.lyapunov`,
        method ``'variational'``, ``model='fast'`` with the fast engine, heyoka otherwise); 0 skips
        it.
    lle_transient : int, default 1000
        Transient periods discarded before the LLE.
    precision : str, default ``'float64'``
        Precision of the coupled runs.
    engine : str or None, default ``None``
        Deprecated spelling of ``model`` (a :class:`DeprecationWarning`).
    model : str or None, default ``None``
        ``'fast'`` (compiled closed forms, :mod:`~precise_impact.solvers.fast.coupled`, and the
        LLE by ``model='fast'``), ``'heyoka'``, or ``None``: ``'fast'`` in float64, heyoka
        otherwise.
    workers : int or None, default 1
        Worker processes over the k-grid (``None``: every core); the numbers do not
        depend on it.
    max_time : decimal or None, default ``None``
        Time budget in seconds (``1 <= max_time <= 604800``): the estimated cost of the
        coupled runs (:func:`~precise_impact.core.budget.estimate_cost`, job ``'sync'``) is
        checked against it before any work (:class:`~precise_impact.errors.OverBudgetError`);
        ``None``: no budget.

    Returns
    -------
    SyncResult
        Per-``k`` fractions (synchronised, intermittent, collapsed), ``k*`` where the
        synchronised fraction crosses 1/2, the LLE with its standard error.

    Raises
    ------
    ParameterError
        Bad input, before any work.

    See Also
    --------
    precise_impact.solvers.simulate.simulate_coupled : one master-slave run.
    precise_impact.solvers.certified.coupled.certify_coupled : a certified master-slave run.
    precise_impact.analysis.sync.SyncResult : the scan's fields.

    References
    ----------
    .. [1] V. Denysenko, M. Balcerzak, A. Dabrowski, "Electronic equivalent of a
           mechanical impact oscillator", eqs. (10)-(12) and Fig. 7.
    .. [2] A. Pikovsky, M. Rosenblum, J. Kurths, *Synchronization* (2001), ch. 13.
    .. [3] J. F. Heagy, N. Platt, S. M. Hammel, PRE 49 (1994) 1140 (on-off
           intermittency at the threshold).

    Examples
    --------
    >>> import precise_impact as pi
    >>> r = pi.sync_scan(pi.Params.make(eta="0.74"), "first-order", ["0", "0.1"], periods=50,
    ...                   ensemble=2, lle_periods=0)
    >>> [str(k) for k in r.k_values], r.ensemble
    (['0', '1/10'], 2)
    """

    params = as_params(params)
    form = check_form(form)
    ks = _check_k_values(k_values)
    periods, ensemble, seed, tq, thr, per_period, sq, lle_periods, lle_transient = _check_counts(
        periods, ensemble, seed, tail, threshold, per_period, spread, lle_periods, lle_transient
    )
    P = Precision.parse(precision)
    engine = resolve_model(model, engine, "sync_scan", default=None, precision=P)
    if engine is None:
        engine = "fast" if P.kind == "float64" else "heyoka"
    progress = check_progress(progress)
    workers = check_workers(workers)
    enforce_max_time(
        max_time,
        "sync",
        periods=periods,
        per_period=per_period,
        precision=P,
        model=engine,
        runs=len(ks) * ensemble,
    )

    start = _time.perf_counter()
    y0s = ensemble_y0(params, ensemble, seed, sq)
    tail_f, thr_f = float(tq), float(thr)

    report = functools.partial(_report_row, ks, form, ensemble, progress)
    job = functools.partial(
        _sync_rows, params, ks, form, periods, y0s, per_period, P, engine, tail_f, thr_f
    )
    run = run_scan(
        job,
        len(ks),
        workers=workers,
        progress=progress if callable(progress) else False,
        on_tile=report if wanted(progress) else None,
    )
    runs: list[list[SyncRun]] = [row for tile in run.values for row, _ in tile]
    fs, fi, fb, fc, mr = _fractions(runs)
    k_star, k_err, msg = half_crossing([float(k) for k in ks], fs)
    lle, lle_se = _single_lle(params, engine, lle_periods, lle_transient)
    return SyncResult(
        params=params,
        form=form,
        k_values=ks,
        periods=periods,
        ensemble=ensemble,
        seed=seed,
        per_period=per_period,
        tail=tail_f,
        threshold=thr_f,
        fraction_synchronised=fs,
        fraction_intermittent=fi,
        fraction_burst=fb,
        fraction_collapsed=fc,
        mean_rate=mr,
        runs=runs,
        k_star=k_star,
        k_star_err=k_err,
        message=msg,
        lle=lle,
        lle_stderr=lle_se,
        lle_periods=lle_periods,
        elapsed_s=_time.perf_counter() - start,
    )


# ------------------------------------------------------------------ plots
def _check_plot_path(path: Any) -> tuple[Path, str]:
    p = Path(path)
    fmt = _PLOT_FORMATS.get(p.suffix.lower())
    if fmt is None:
        raise ParameterError("path", str(path), "a plot file ending in " + ", ".join(_PLOT_FORMATS))
    return p, fmt


def _save(fig, path: Path, fmt: str) -> None:
    atomic_write(path, lambda fh: fig.savefig(fh, format=fmt, dpi=150), binary=True)


def _figure(nrows: int, ncols: int, size: tuple[float, float]):
    return new_figure(nrows, ncols, figsize=size)


def plot_fig7(
    params: Params,
    form: str,
    k_low: Any,
    k_high: Any,
    periods: int,
    path: Any,
    y0: Sequence[Any] | None = None,
    per_period: int = 20,
    threshold: float | None = 1e-8,
    units: str = "dimensionless",
    components: Any = None,
) -> tuple[CoupledTrajectory, CoupledTrajectory]:
    """The paper's Fig. 7: ``|x - y|`` against time (log scale) for two couplings, each panel
    titled with its verdict (synchronised or not, :func:`classify` over the last 10 %).

    Parameters
    ----------
    params : Params
        System and the master's initial condition.
    form : str
        One of :data:`~precise_impact.solvers.heyoka.coupled.COUPLED_FORMS`.
    k_low, k_high : decimal
        Couplings of panels (a) and (b) (the paper: 0.031 and 0.032).
    periods : int
        Forcing periods (the paper: 500).
    path : str or Path
        Output file, ``.png``, ``.pdf`` or ``.svg``; written atomically.
    y0 : pair or None, default ``None``
        Slave initial condition in the form's variables; ``None`` means
        ``(x0 - 1/2, v0 + 1/2)`` (the paper does not state its own).
    per_period : int, default 20
        Plotted samples per period.
    threshold : float or None, default 1e-8
        Drawn as a dashed horizontal line and used for the verdicts (``None``: neither).
    units : {'dimensionless', 'circuit'}, default ``'dimensionless'``
        ``'circuit'``: ``t`` in seconds and ``|V_s1 - V_s2|`` in volts of ``components``
        (default: the nominal design of ``params``); see
        :func:`precise_impact.io.figures.plot_units`.
    components : Components or None
        The design for ``units='circuit'``.

    Returns
    -------
    tuple of CoupledTrajectory
        The runs of panels (a) and (b).

    Notes
    -----
    Samples where ``|x - y|`` is exactly 0 (the slave has collapsed onto the master
    bit for bit) cannot be shown on a log axis; the panel notes from when.

    References
    ----------
    .. [1] V. Denysenko, M. Balcerzak, A. Dabrowski, "Electronic equivalent of a
           mechanical impact oscillator", Fig. 7.
    """
    p, fmt = _check_plot_path(path)

    params = as_params(params)
    plot_units(units, params=params, components=components)  # a bad unit before any run
    form = check_form(form)
    kl, kh = check_k(k_low, "k_low"), check_k(k_high, "k_high")
    periods = check_count(periods, "periods")
    per_period = check_count(per_period, "per_period", 100_000)
    if per_period < 1:
        raise ParameterError("per_period", per_period, "an integer with 1 <= per_period <= 100000")
    if y0 is None:
        y0 = (params.x0 - Fraction(1, 2), params.v0 + Fraction(1, 2))
    trajs = [
        simulate_coupled(params, k, form, periods, y0=y0, per_period=per_period) for k in (kl, kh)
    ]
    save_figure(fig7_figure(trajs, threshold, units=units, components=components), p, fmt, 150)
    return trajs[0], trajs[1]


def fig7_figure(
    trajs: Sequence[CoupledTrajectory],
    threshold: float | None = 1e-8,
    tail: float = 0.1,
    units: str = "dimensionless",
    components: Any = None,
):
    """The figure of :func:`plot_fig7` from its runs: each panel's title gives the verdict of
    :func:`classify` (synchronised: ``|x - y| < threshold`` over the last ``tail`` of the run),
    the figure's title both.

    Returns
    -------
    matplotlib.figure.Figure
    """
    u = plot_units(units, params=trajs[0].params, components=components)
    panels, verdicts = [], []
    for tr, label in zip(trajs, "abcdefgh", strict=False):
        t, d = tr.difference(dense=tr.dense_t is not None)
        pos = d > 0
        note = ""
        if len(d) > 1 and d[-1] == 0 and pos.any():
            end = int(np.flatnonzero(pos)[-1]) + 1  # 0 exactly (off the log axis) from here on
            unit = " s" if u.name == "circuit" else ""
            note = f"; |x - y| = 0 exactly from t = {float(u.t(t[end])):.4g}{unit}"
        if threshold is not None and tr.dense_t is not None:
            run = classify(tr, tail, threshold)
            word = (
                "synchronised"
                if run.synchronised
                else "intermittent (reaches the threshold, not synchronised)"
                if run.intermittent
                else "not synchronised"
            )
            verdicts.append(run.synchronised)
        else:
            word = f"final |x - y| = {float(d[-1]):.2g}"
        panels.append((t, d, f"{label}) {tr.form}, k = {decimal_str(tr.k)}: {word}{note}"))
    tail_words = f"below {threshold:g} over the last {tail:.0%} of {trajs[0].periods} periods"
    if verdicts:
        n_sync = sum(verdicts)
        head = (
            "both runs synchronise"
            if n_sync == len(verdicts)
            else "neither run synchronises"
            if n_sync == 0
            else ", ".join(
                f"{lab}) {'synchronises' if v else 'does not synchronise'}"
                for lab, v in zip("abcdefgh", verdicts, strict=False)
            )
        )
        title = f"Fig. 7 equivalent: {head} (synchronised: |x - y| {tail_words})"
    else:
        title = "Fig. 7 equivalent: |x - y| of master and slave"
    return plot_differences(panels, u, title, threshold=threshold)


def plot_sync_fraction(result: SyncResult, path: Any) -> Path:
    """Synchronised (and intermittent) fraction against ``k``, with the LLE marked; written
    to ``path`` (``.png``, ``.pdf`` or ``.svg``, atomically).  :meth:`SyncResult.plot` draws
    the same figure and returns it.

    Parameters
    ----------
    result : SyncResult
        From :func:`sync_scan`.
    path : str or Path
        Output file.
    """
    p, fmt = _check_plot_path(path)
    if not isinstance(result, SyncResult):
        raise ParameterError("result", type(result).__name__, "a SyncResult from sync_scan")
    save_figure(sync_fraction_figure(result), p, fmt, 150)
    return p


def sync_fraction_figure(result: SyncResult):
    """The figure of :func:`plot_sync_fraction`: the legend beside the axes (never over the
    data or the ``k*`` marker).

    Returns
    -------
    matplotlib.figure.Figure
    """
    k = np.array([float(v) for v in result.k_values])
    fig, axes = _figure(1, 1, (8.5, 4.0))
    ax = axes[0, 0]
    if math.isfinite(result.lle):
        se = result.lle_stderr if math.isfinite(result.lle_stderr) else 0.0
        ax.axvspan(
            result.lle - se,
            result.lle + se,
            color="0.8",
            label=f"LLE = {result.lle:.4f} ± {se:.4f}",
        )
        ax.axvline(result.lle, color="0.4", lw=0.8)
    ax.plot(k, result.fraction_synchronised, "o-", color="C0", label="synchronised")
    ax.plot(k, result.fraction_intermittent, "s--", color="C1", ms=4, label="intermittent")
    if math.isfinite(result.k_star):
        ax.errorbar(
            [result.k_star],
            [0.5],
            xerr=[result.k_star_err],
            fmt="D",
            color="C3",
            capsize=3,
            label=f"k* = {result.k_star:.4f} ± {result.k_star_err:.4f}",
        )
    ax.set_xlabel("coupling k (per unit time tau)")
    ax.set_ylabel(f"fraction of {result.ensemble} runs")
    ax.set_ylim(-0.05, 1.05)
    verdict = (
        f"k* = {result.k_star:.4f}"
        if math.isfinite(result.k_star)
        else "synchronised fraction never crosses 1/2"
    )
    ax.set_title(
        wrap_title(
            f"{result.form}: {verdict}; {result.periods} periods, tail {result.tail:g}, "
            f"threshold {result.threshold:g}",
            fig,
        ),
        fontsize=10,
    )
    legend_outside(ax)
    ax.grid(True, lw=0.3)
    return fig


# 0.1.0 name, kept for one release.
SyncResult.to_json_dict = SyncResult.to_dict  # type: ignore[attr-defined]
SyncRun.to_json_dict = SyncRun.to_dict  # type: ignore[attr-defined]
