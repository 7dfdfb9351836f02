"""Bifurcation diagram over eta with the largest Lyapunov exponent beneath.

One run per eta value (the fast engine, or a heyoka variational run) gives both the
stroboscopic points and the LLE; the values go through the scan runner
(:func:`~precise_impact.analysis.scan.run_scan`).
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.analysis.lyapunov.fast import bounce_refusal
from precise_impact.analysis.lyapunov.variational import variational_spectrum
from precise_impact.analysis.scan import (
    PointJob,
    check_axis,
    deprecated_keyword,
    resolve_model,
    run_scan,
)
from precise_impact.core.budget import enforce_max_time
from precise_impact.core.flow import grazing_frequencies
from precise_impact.core.params import Params, as_params, check_count, decimal_str, exact_grid
from precise_impact.core.result import ResultMixin, columns
from precise_impact.core.stats import lle_stderr
from precise_impact.errors import EndlessBouncesError, IntegrationError, ParameterError
from precise_impact.io.atomic import atomic_write
from precise_impact.io.figures import (
    check_plot_path,
    draw_density,
    finish,
    legend_outside,
    new_figure,
    wrap_title,
)
from precise_impact.io.jsonout import dumps
from precise_impact.io.progress import ProgressArg, check_progress
from precise_impact.solvers.base import Unresolved, with_fallback

__all__ = ["BifurcationResult", "bifurcation", "eta_grid"]


@dataclasses.dataclass
class BifurcationResult(ResultMixin):
    """Stroboscopic x and LLE for each eta (:func:`bifurcation`).

    Attributes
    ----------
    params : Params
        The fixed parameters and initial condition (``eta`` replaced by each value).
    eta : list of Fraction
        The exact values of eta.
    x : numpy.ndarray of float, shape ``(len(eta), periods)``
        Stroboscopic x after the transient.
    lle, lle_stderr : numpy.ndarray of float
        Largest Lyapunov exponent per unit time and its standard error, per eta.
    impacts_per_period : numpy.ndarray of float
        Mean impacts per forcing period, per eta.
    status : list of str
        Per eta: ``'ok'``, or why the value was refused (an ``R = 1`` bounce sequence on the
        wall predicted to come to rest or to outrun the impact budget,
        :class:`~precise_impact.errors.EndlessBouncesError`; its ``x``, ``lle`` ... are NaN).
    grazing : list of float
        Closed-form grazing frequencies inside the range.
    periods, transient : int
        Measured and discarded periods per value.
    elapsed_s : float
        Wall time (diagnostic).
    workers : int
        Processes used (diagnostic).

    See Also
    --------
    precise_impact.analysis.bifurcation.bifurcation : returns it.
    precise_impact.analysis.orbits.branch.brute_force_diagram : the diagram along any parameter.
    """

    params: Params
    eta: list
    x: np.ndarray
    lle: np.ndarray
    lle_stderr: np.ndarray
    impacts_per_period: np.ndarray
    grazing: list
    periods: int
    transient: int
    elapsed_s: float
    workers: int
    status: list = dataclasses.field(default_factory=list)

    def _tables(self) -> dict:
        """``to_dataframe()`` tables: ``values`` (default: one row per eta) and ``samples`` (one
        row per eta and stroboscopic sample, for the diagram)."""
        eta = [float(e) for e in self.eta]
        n = self.x.shape[1] if self.x.ndim == 2 else 0
        return {
            "values": lambda: columns(
                ("eta", "1", eta),
                ("lle", "1/tau", self.lle),
                ("lle_stderr", "1/tau", self.lle_stderr),
                ("impacts_per_period", None, np.asarray(self.impacts_per_period, dtype=float)),
                ("status", None, list(self.status) or ["ok"] * len(eta)),
            ),
            "samples": lambda: columns(
                ("eta", "1", np.repeat(eta, n)),
                ("sample", None, np.tile(np.arange(n), len(eta))),
                ("x", "1", np.asarray(self.x, dtype=float).ravel()),
            ),
        }

    def save(self, path: str | os.PathLike) -> Path:
        """Write one file atomically; the suffix picks it.

        Parameters
        ----------
        path : str or os.PathLike
            ``.json`` (:meth:`to_dict`), ``.npz`` (``eta`` as floats and as exact
            decimal strings ``eta_str``, ``x``, ``lle``, ``lle_stderr``,
            ``impacts_per_period``, ``grazing`` and the rest as ``meta_json``) or
            ``.png`` (:meth:`plot`).

        Returns
        -------
        pathlib.Path
            The file written.

        Raises
        ------
        ParameterError
            Another suffix.
        """
        path = Path(path)
        if path.suffix in (".png", ".pdf", ".svg"):
            self.plot(path)
            return path
        if path.suffix != ".npz":
            return super().save(path)
        arrays = {
            "eta": np.array([float(e) for e in self.eta]),
            "eta_str": np.array([decimal_str(e) for e in self.eta]),
            "x": self.x,
            "lle": self.lle,
            "lle_stderr": self.lle_stderr,
            "impacts_per_period": self.impacts_per_period,
            "status": np.array(self.status, dtype=str),
            "grazing": np.array(self.grazing, dtype=float),
            "meta_json": np.asarray(
                dumps(
                    {
                        "params": self.params.decimal(),
                        "periods": self.periods,
                        "transient": self.transient,
                        "elapsed_s": self.elapsed_s,
                        "workers": self.workers,
                    }
                )
            ),
        }
        # uncompressed: zlib took 50 of the 90 s of a 400 x 200000 diagram (640 MB of
        # chaotic samples compress by only 37 %)
        atomic_write(path, lambda fh: np.savez(fh, **arrays), binary=True)
        return path

    def save_all(self, out: str | os.PathLike) -> dict[str, Path]:
        """Write ``bifurcation.npz`` and ``bifurcation.png`` into the directory ``out``.

        Parameters
        ----------
        out : str or os.PathLike
            The directory (created if missing).

        Returns
        -------
        dict of str to pathlib.Path
            The files under the keys ``'npz'`` and ``'png'``.
        """
        out = Path(out)
        return {
            "npz": self.save(out / "bifurcation.npz"),
            "png": self.save(out / "bifurcation.png"),
        }

    def plot(self, path: str | os.PathLike | None = None):
        """Stroboscopic x against eta with the LLE beneath.

        The points are drawn as a density image (one pixel column per eta, the share of the
        samples in each pixel row in grey), so a diagram of 400 x 200000 samples takes
        about a second, not the ~40 s of 80 million markers.  Beneath: the LLE with its
        error bars, ``0`` and half the exponent sum ``-zeta + nu ln R`` (``nu`` impacts per
        unit time): the LLE of every periodic orbit whose two Floquet multipliers are a
        complex pair, impacting or not (``-zeta`` when ``R = 1``).

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf``, ``.svg``), atomically with
            matplotlib's object API (the user's backend is never changed).

        Returns
        -------
        matplotlib.figure.Figure
        """
        check_plot_path(path)
        eta = np.array([float(e) for e in self.eta])
        fig, axes = new_figure(
            2,
            1,
            figsize=(11, 7),
            sharex=True,
            gridspec_kw={"height_ratios": [3, 2]},
        )
        ax1, ax2 = axes[:, 0]
        draw_density(ax1, eta, self.x)
        ax1.plot([], [], "s", color="0.2", ms=4, label="x at t0 + kT (grey: share of samples)")
        ax1.axhline(float(self.params.x_w), color="tab:red", lw=0.9, label="wall x = x_w")
        ax1.set_ylabel("x at t0 + kT (dimensionless)")
        ax2.errorbar(
            eta,
            self.lle,
            yerr=self.lle_stderr,
            fmt="-",
            lw=0.8,
            color="tab:blue",
            ecolor="tab:gray",
            label="LLE +- stderr",
        )
        ax2.axhline(0, color="k", lw=0.6, label="0")
        half = self.half_exponent_sum()
        r_one = self.params.R == 1
        ax2.plot(
            eta,
            half,
            color="tab:green",
            lw=0.9,
            ls="--",
            label=(
                "-zeta = half the exponent sum (R = 1):\nLLE of any periodic orbit with a "
                "complex\npair of multipliers, impacts or not"
                if r_one
                else "-zeta + nu ln R = half the exponent sum:\nLLE of a periodic orbit with "
                "a complex\npair of multipliers (nu: impacts per unit time)"
            ),
        )
        ax2.set_ylabel("LLE per unit time tau")
        ax2.set_xlabel("eta = Omega / omega")
        for g in self.grazing:
            for ax in (ax1, ax2):
                ax.axvline(g, color="tab:orange", ls=":", lw=1)
        if self.grazing:
            ax1.plot(
                [], [], color="tab:orange", ls=":", label=f"grazing eta = {self.grazing[0]:.5f}"
            )
        legend_outside(ax1)
        legend_outside(ax2)
        q = self.params
        fig.suptitle(
            wrap_title(
                f"Bifurcation diagram and LLE (zeta={decimal_str(q.zeta)}, a={decimal_str(q.a)}, "
                f"x_w={decimal_str(q.x_w)}, R={decimal_str(q.R)}; "
                f"{self.transient} transient + {self.periods} periods)",
                fig,
            ),
            fontsize=10,
        )
        return finish(fig, path, dpi=120)

    def half_exponent_sum(self) -> np.ndarray:
        """``(lambda_1 + lambda_2) / 2 = -zeta + nu ln R`` per eta, ``nu`` the measured impacts
        per unit time (each impact multiplies the Jacobian's determinant by ``R^2``, the flow
        by ``exp(-2 zeta t)``): the LLE of an orbit whose multipliers are a complex pair.
        ``R = 0`` (plastic impacts, the determinant 0): ``-inf`` where the orbit impacts."""
        nu = self.impacts_per_period * np.array([float(e) for e in self.eta]) / (2 * math.pi)
        R, zeta = float(self.params.R), float(self.params.zeta)
        if R == 1:
            return np.full(nu.shape, -zeta)
        if R == 0:  # one value per eta (a scalar here failed the plot: bifurcation --R 0)
            return np.where(nu > 0, -np.inf, -zeta)
        return -zeta + nu * math.log(R)


def eta_grid(eta_min: Any, eta_max: Any, n: Any) -> list[Fraction]:
    """``n`` exact, evenly spaced values from ``eta_min`` to ``eta_max`` (both included).

    Parameters
    ----------
    eta_min, eta_max : decimal
        Ends of the grid (decimal strings, Fractions or numbers; converted exactly).
    n : int
        Number of values, ``>= 1`` (``n = 1`` gives ``[eta_min]``).

    Returns
    -------
    list of Fraction
        The grid, exact rationals.
    """
    return exact_grid(eta_min, eta_max, n, "eta", strict=True)


def _fast_point(params: Params, periods: int, transient: int) -> tuple:
    """One eta value on the fast engine: strobe x, LLE, its error bar, impacts per period."""
    if not params.zeta < 1:
        raise Unresolved("fast", "zeta >= 1 (the closed form is underdamped only)")
    # numba is imported on first use, not with the package (0.3 s of import time)
    from precise_impact.solvers.fast.lle import kernel_inputs, lle_batch_serial  # noqa: PLC0415 -- heavy: numba, loaded on first use
    from precise_impact.solvers.fast.single import STATUS_OK  # noqa: PLC0415 -- heavy: numba, loaded on first use

    pars, starts = kernel_inputs(params, 1)
    st, l1, l2, imps, bsums, _, xt, *_ = lle_batch_serial(
        pars, starts, periods, transient, min(10, periods), 10**7, periods
    )
    why = bounce_refusal(pars[0], starts[0], st[0], l1[0], l2[0], periods + transient, 10**7)
    if why is not None:
        return _refused(periods, why)
    if st[0] != STATUS_OK:
        raise Unresolved("fast", f"status {int(st[0])}")
    T = 2 * math.pi / float(params.eta)
    nb = min(10, periods)
    bm = bsums[0] / ((periods // nb) * T)
    lle = float(l1[0] / (periods * T))
    # one log per period and per impact
    se = lle_stderr(bm, lle, periods + float(imps[0]), time=periods * T)
    return xt[0], lle, se, float(imps[0] / periods), "ok"


def _refused(periods: int, why: str) -> tuple:
    """A refused eta value (:class:`~precise_impact.errors.EndlessBouncesError`): NaN values
    and the reason as its status."""
    return np.full(periods, np.nan), math.nan, math.nan, math.nan, why


def _heyoka_point(params: Params, periods: int, transient: int) -> tuple:
    """One eta value by the heyoka variational method (the same five values)."""
    # heyoka is imported on first use, not with the package
    try:
        r = variational_spectrum(
            params, periods=periods, transient=transient, initial_conditions=1, segments=10
        )
    except EndlessBouncesError as e:
        return _refused(periods, str(e))
    except IntegrationError as e:  # e.g. a missed impact while chattering into the wall
        return _refused(periods, f"integration stopped: {e}")
    return r.strobe_x, r.lle, r.lle_stderr, r.n_impacts / r.periods, "ok"


#: Each model's point job; the fast one hands what it does not resolve to heyoka.
_POINT = {"fast": with_fallback(_fast_point, _heyoka_point), "heyoka": _heyoka_point}


def _one(args):
    params, periods, transient, model = args
    return _POINT[model](params, periods, transient)


def _eta_axis(axis: Any, eta_max: Any, n: Any, eta_min: Any) -> list[Fraction]:
    """The eta grid from an axis tuple ``('eta', start, stop, n)`` or the deprecated
    ``(eta_min, eta_max, n)`` (a :class:`DeprecationWarning` naming the axis tuple)."""
    if eta_min is not None and axis is not None:
        raise ParameterError("eta_min", eta_min, "not given with an axis")
    if eta_min is not None or isinstance(axis, (str, bytes)) or not isinstance(axis, Sequence):
        deprecated_keyword(
            "(eta_min, eta_max, n)", "an axis tuple ('eta', start, stop, n)", "bifurcation", 4
        )
        return eta_grid(axis if eta_min is None else eta_min, eta_max, n)
    for name, value in (("eta_max", eta_max), ("n", n)):
        if value is not None:
            raise ParameterError(name, value, "not given with an axis tuple")
    _, lo, hi, count = check_axis(axis, "eta")
    return eta_grid(lo, hi, count)


def bifurcation(
    params: Params,
    axis: Any = None,
    eta_max: Any = None,
    n: int | None = None,
    periods: int = 2000,
    transient: int = 1000,
    workers: int | None = None,
    progress: ProgressArg = None,
    engine: str | None = None,
    *,
    model: str | None = None,
    eta_min: Any = None,
    max_time: Any = None,
) -> BifurcationResult:
    """Stroboscopic x and the LLE for ``n`` values of eta.

    Parameters
    ----------
    params : Params
        Every parameter but eta (and the initial condition of each run).
    axis : tuple ``('eta', start, stop, n)``
        The grid (:func:`eta_grid`: exact, evenly spaced, both ends included).  The
        deprecated form ``bifurcation(params, eta_min, eta_max, n, ...)`` (positional or
        by keyword) still works with a :class:`DeprecationWarning`.
    eta_max, n : decimal, int
        Deprecated: the old range form ``(eta_min, eta_max, n)``; use
        ``axis=('eta', eta_min, eta_max, n)``.
    periods : int, default 2000
        Measured periods per value (stroboscopic points and LLE).
    transient : int, default 1000
        Discarded periods per value.
    workers : int or None, default ``None``
        Worker processes; ``None`` uses all cores (``os.cpu_count()``), 1 runs in
        this process.
    progress : bool, None or callable, default ``None``
        :data:`~precise_impact.io.progress.ProgressArg`: a progress bar on stderr
        (``None``: only when stderr is a terminal) or ``progress(done, total)``.
    engine : str
        Deprecated spelling of ``model=``.
    model : str, default ``'fast'``
        ``'fast'``: the compiled closed form (:mod:`precise_impact.solvers.fast.single`; the
        tangent basis runs on through the transient; a value it does not resolve, or
        ``zeta >= 1``, is computed by heyoka); ``'heyoka'``: one heyoka variational run
        per value.
    eta_min : decimal
        Deprecated, with ``eta_max`` and ``n``.
    max_time : decimal or None, default ``None``
        Time budget in seconds per worker (``1 <= max_time <= 604800``): the estimated
        cost of the runs (:func:`~precise_impact.core.budget.estimate_cost`, job
        ``'bifurcation'``, priced for the model) is checked against ``max_time x workers``
        before any work (:class:`~precise_impact.errors.OverBudgetError`); ``None``: no budget.

    Returns
    -------
    BifurcationResult
        ``eta``, the stroboscopic ``x`` (``n x periods``), ``lle`` with ``lle_stderr``,
        impacts per period and the closed-form grazing frequencies (``grazing``);
        ``plot(path)`` draws the diagram.

    Raises
    ------
    ParameterError
        Bad input, before any work.

    See Also
    --------
    precise_impact.analysis.orbits.branch.brute_force_diagram
        The stroboscopic x alone, on any parameter.
    precise_impact.analysis.orbits.continuation.continue_orbit
        The periodic branches, stable and unstable.
    precise_impact.analysis.sweep.run_sweep : a resumable sweep over one or two axes.

    References
    ----------
    .. [1] V. Denysenko, M. Balcerzak, A. Dabrowski, "Electronic equivalent of a
           mechanical impact oscillator" (the period-3 orbit at eta = 0.74 and the
           chaotic band near eta = 0.712).

    Examples
    --------
    >>> import precise_impact as pi
    >>> b = pi.bifurcation(pi.Params.make(), ("eta", "0.70", "0.72", 3), periods=20, transient=20,
    ...                     progress=False, workers=1)
    >>> [str(e) for e in b.eta], b.x.shape
    (['7/10', '71/100', '18/25'], (3, 20))
    """

    params = as_params(params)
    etas = _eta_axis(axis, eta_max, n, eta_min)
    periods = check_count(periods, "periods")
    if periods < 1:
        raise ParameterError("periods", periods, "an integer >= 1")
    transient = check_count(transient, "transient")
    if workers is None:
        workers = os.cpu_count() or 1
    workers = check_count(workers, "workers", 1024)
    if workers < 1:
        raise ParameterError("workers", workers, "an integer >= 1")
    model = resolve_model(model, engine, "bifurcation")
    progress = check_progress(progress)
    enforce_max_time(
        max_time,
        "bifurcation",
        scale=workers,
        periods=periods,
        transient=transient,
        runs=len(etas),
        model=model,  # the compiled kernel costs ~1/30 of a variational run
    )
    jobs = [
        (params.replace(eta=e), periods, transient, model) for e in etas
    ]  # validates every eta first
    run = run_scan(
        PointJob(_one, jobs),
        len(jobs),
        max(1, len(jobs) // (workers * 8)),
        workers=workers,
        progress=progress,
        label="bifurcation",
    )
    results = [r for tile in run.values for r in tile]
    lo_f, hi_f = float(min(etas)), float(max(etas))  # the grid may run downwards
    graz = [float(g) for g in grazing_frequencies(params) if lo_f <= float(g) <= hi_f]
    return BifurcationResult(
        params=params,
        eta=etas,
        x=np.array([r[0] for r in results]),
        lle=np.array([r[1] for r in results]),
        lle_stderr=np.array([r[2] for r in results]),
        impacts_per_period=np.array([r[3] for r in results]),
        grazing=graz,
        periods=periods,
        transient=transient,
        elapsed_s=run.elapsed_s,
        workers=workers,
        status=[r[4] for r in results],
    )
