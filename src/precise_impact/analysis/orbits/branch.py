"""Result types of continuation (a branch, a located bifurcation, the whole run) and the
brute-force diagram drawn beneath them (simulated attractors through the scan runner)."""

from __future__ import annotations

import dataclasses
import functools
import math
import os
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.analysis.scan import (
    check_axis,
    check_workers,
    deprecated_keyword,
    resolve_model,
    run_scan,
)
from precise_impact.core.params import Params, check_count, decimal_str, exact
from precise_impact.core.result import ResultMixin, columns, record_columns
from precise_impact.errors import ParameterError
from precise_impact.io.figures import (
    draw_density,
    finish,
    legend_outside,
    new_figure,
    wrap_title,
)
from precise_impact.io.progress import ProgressArg
from precise_impact.solvers.base import make_solver

__all__ = ["Branch", "Bifurcation", "ContinuationResult"]


@dataclasses.dataclass
class Branch(ResultMixin):
    """One continued branch of period-``p`` orbits with ``n`` impacts.

    Attributes
    ----------
    parameter : str
        The continued parameter.
    period, impacts : int
        Forcing periods and impacts per orbit.
    origin : str
        ``'start'`` or where it was switched to (``'period-doubling of branch K at ...'``).
    values : numpy.ndarray of float, shape ``(m,)``
        The parameter along the branch (in continuation order; it turns back at folds).
    x, v : numpy.ndarray of float, shape ``(m, p)``
        The ``p`` stroboscopic states ``(x, v)`` at ``t0 + k T`` of each orbit.
    multipliers : numpy.ndarray of float, shape ``(m, 2, 2)``
        Floquet multipliers as ``[re, im]`` pairs, largest modulus first.
    stable : numpy.ndarray of bool
        Every multiplier inside the unit circle (false for an elliptic orbit).
    admissible : numpy.ndarray of bool
        The orbit is physical: every flight stays below the wall and every impact
        arrives with ``v^- >= 0`` (false past a grazing point: a *virtual* orbit).
    lle : numpy.ndarray of float
        ``ln |mu_max| / (p T)``.
    stop_reason : str
        Why the branch ended.
    stability : numpy.ndarray of str or None, default ``None``
        ``'stable'``, ``'unstable'`` or ``'elliptic'`` per point: ``'elliptic'`` (neutral)
        when ``zeta = 0`` and ``R = 1`` make ``det M = 1`` identically and the multipliers
        are a complex pair on the unit circle (then ``stable`` is false and ``lle`` is 0).
        ``None`` (a branch built by hand): derived from ``stable``.
    impact_v : numpy.ndarray of float, shape ``(m, n)``, or None, default ``None``
        Each impact's approach velocity ``v^-`` (negative: the orbit arrives from beyond
        the wall, a virtual orbit); ``None`` for a branch built by hand.
    wall_margin : numpy.ndarray of float, shape ``(m,)``, or None, default ``None``
        ``x_w`` minus the highest interior maximum of the orbit's flights (negative: a
        flight crosses the wall; ``inf``: no interior maximum); ``None`` for a branch
        built by hand.

    See Also
    --------
    precise_impact.analysis.orbits.branch.ContinuationResult : the result holding branches.
    precise_impact.analysis.orbits.branch.Bifurcation : a bifurcation on a branch.
    """

    parameter: str
    period: int
    impacts: int
    origin: str
    values: np.ndarray
    x: np.ndarray
    v: np.ndarray
    multipliers: np.ndarray
    stable: np.ndarray
    admissible: np.ndarray
    lle: np.ndarray
    stop_reason: str
    stability: np.ndarray | None = None
    impact_v: np.ndarray | None = None
    wall_margin: np.ndarray | None = None

    def _tables(self) -> dict:
        """``to_dataframe()`` table ``points``: one row per orbit of the branch, its
        stroboscopic states as ``x_0 .. x_{p-1}``, ``v_0 ..``."""
        return {"points": self._points}

    def _points(self) -> dict:
        x, v = np.asarray(self.x, dtype=float), np.asarray(self.v, dtype=float)
        p = x.shape[1] if x.ndim == 2 else 0
        return columns(
            (self.parameter, "1", np.asarray(self.values, dtype=float)),
            ("lle", "1/tau", self.lle),
            ("stable", None, self.stable),
            ("admissible", None, self.admissible),
            ("stability", None, self.stability if self.stability is not None else [""] * len(x)),
            *((f"x_{j}", "1", x[:, j]) for j in range(p)),
            *((f"v_{j}", "1", v[:, j]) for j in range(p)),
        )

    def __post_init__(self) -> None:
        if self.stability is None:
            self.stability = np.where(np.asarray(self.stable, dtype=bool), "stable", "unstable")

    def plot(self, path: str | os.PathLike | None = None):
        """This branch's ``x`` (stable solid, unstable dashed, virtual dotted grey) with its
        LLE beneath (:func:`branches_figure`).

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf``, ``.svg``, atomically).

        Returns
        -------
        matplotlib.figure.Figure
        """
        title = (
            f"Branch of period {self.period}, {self.impacts} impact(s) per orbit, along "
            f"{self.parameter} ({len(self.values)} points; stopped: {self.stop_reason})"
        )
        return finish(branches_figure([self], [], self.parameter, title), path, dpi=120)

    def counts(self) -> dict[str, int]:
        """Points by kind, each counted once: ``virtual`` (not admissible: past grazing, not a
        physical orbit whatever its multipliers), and among the admissible ones ``stable``,
        ``unstable`` and ``elliptic``; the four add up to the branch's points."""
        adm = np.asarray(self.admissible, dtype=bool)
        kinds = np.asarray(self.stability, dtype=object)
        return {
            "stable": int(np.sum(adm & (kinds == "stable"))),
            "unstable": int(np.sum(adm & (kinds == "unstable"))),
            "elliptic": int(np.sum(adm & (kinds == "elliptic"))),
            "virtual": int(np.sum(~adm)),
        }

    @classmethod
    def from_points(
        cls, parameter: str, period: int, impacts: int, origin: str, pts: list, reason: str
    ) -> Branch:
        return cls(
            parameter=parameter,
            period=period,
            impacts=impacts,
            origin=origin,
            values=np.array([p.lam for p in pts]),
            x=np.array([p.states[:, 0] for p in pts]).reshape(len(pts), period),
            v=np.array([p.states[:, 1] for p in pts]).reshape(len(pts), period),
            multipliers=np.array([[[m.real, m.imag] for m in p.mu] for p in pts]).reshape(
                len(pts), 2, 2
            ),
            stable=np.array([p.stability == "stable" for p in pts], dtype=bool),
            admissible=np.array([p.admissible for p in pts]),
            lle=np.array([p.lle for p in pts]),
            stop_reason=reason,
            stability=np.array([p.stability for p in pts], dtype=object),
            impact_v=np.array([p.impact_v for p in pts], dtype=float).reshape(len(pts), impacts),
            wall_margin=np.array([p.tests["graze_interior"] for p in pts]),
        )


@dataclasses.dataclass
class Bifurcation(ResultMixin):
    """A located bifurcation point of a branch.

    Attributes
    ----------
    type : str
        ``'grazing'``, ``'period-doubling'``, ``'fold'``, ``'branch-point'`` or
        ``'neimark-sacker'``.
    parameter : str
        The continued parameter; :meth:`to_dict` also gives the value under its name.
    value : float
        The parameter at the point (located to the precision of its test function).
    branch : int
        Index of the branch it lies on.
    period, impacts : int
        Of that branch.
    x, v : list of float
        The ``p`` stroboscopic states of the orbit at the point.
    multipliers : list of [re, im]
        Floquet multipliers at the point.
    admissible : bool
        The orbit at the point is physical (see :attr:`Branch.admissible`).
    test : float
        The test function's value at the returned point (how close to zero it got).
    detail : str
        Which grazing (interior maximum or impact velocity), or the branch switched to.
    impact_v : list of float or None, default ``None``
        The orbit's impact approach velocities ``v^-`` at the point (negative: virtual).

    See Also
    --------
    precise_impact.analysis.orbits.branch.Branch : the branch it lies on.
    precise_impact.analysis.orbits.continuation.continue_orbit : finds them.
    """

    type: str
    parameter: str
    value: float
    branch: int
    period: int
    impacts: int
    x: list
    v: list
    multipliers: list
    admissible: bool
    test: float
    detail: str = ""
    impact_v: list | None = None

    def to_dict(self) -> dict[str, Any]:
        """``{"type", NAME: value, "parameter", "value", ...}`` (NAME the continued parameter)."""
        d = super().to_dict()
        return {
            "type": self.type,
            self.parameter: self.value,
            **{k: v for k, v in d.items() if k != "type"},
        }


@dataclasses.dataclass
class ContinuationResult(ResultMixin):
    """Branches of periodic orbits and their bifurcations (:func:`continue_orbit`).

    Attributes
    ----------
    params : Params
        The system at the start of the range.
    parameter : str
        The continued parameter.
    start, stop : Fraction
        The range (exact).
    branches : list of Branch
        Branch 0 starts at ``start``; period-doubling switches add the others.
    bifurcations : list of Bifurcation
        Every located point, by branch and along the range.
    elapsed_s : float
        Wall time (diagnostic).

    See Also
    --------
    precise_impact.analysis.orbits.continuation.continue_orbit : returns it.
    precise_impact.analysis.orbits.branch.Branch : its branches.
    precise_impact.analysis.orbits.branch.Bifurcation : their bifurcations.
    """

    params: Params
    parameter: str
    start: Fraction
    stop: Fraction
    branches: list
    bifurcations: list
    elapsed_s: float

    def _tables(self) -> dict:
        """``to_dataframe()`` tables: ``points`` (default: every branch's orbits, ``branch``
        its index) and ``bifurcations``."""

        def points() -> dict:
            parts = [b._points() for b in self.branches]
            keys = list(dict.fromkeys(k for part in parts for k in part))
            out: dict = {
                "branch": np.concatenate(
                    [np.full(len(next(iter(pt.values()))), i) for i, pt in enumerate(parts)]
                )
                if parts
                else np.zeros(0, dtype=int)
            }
            for key in keys:
                out[key] = np.concatenate(
                    [
                        np.asarray(pt[key])
                        if key in pt
                        else np.full(len(next(iter(pt.values()))), np.nan)
                        for pt in parts
                    ]
                )
            return out

        def bifurcations() -> dict:
            rows = [
                {
                    f.name: getattr(b, f.name)
                    for f in dataclasses.fields(b)
                    if f.name not in ("x", "v", "multipliers")
                }
                for b in self.bifurcations
            ]
            return record_columns(rows)

        return {"points": points, "bifurcations": bifurcations}

    def to_dict(self) -> dict[str, Any]:
        """The CLI's ``--json`` object: ``params``, ``parameter``, ``from``, ``to``, ``branches``
        (each with its points) and ``bifurcations`` (``[{"type", NAME: value, ...}]``)."""
        return {
            "params": self.params.decimal(),
            "parameter": self.parameter,
            "from": decimal_str(self.start),
            "to": decimal_str(self.stop),
            "branches": [b.to_dict() for b in self.branches],
            "bifurcations": [b.to_dict() for b in self.bifurcations],
            "elapsed_s": self.elapsed_s,
        }

    def plot(self, path: str | os.PathLike | None = None, diagram: tuple | None = None):
        """Stroboscopic ``x`` of every branch (stable solid, unstable dashed, virtual dotted
        grey) with the bifurcation points, over a brute-force diagram; LLE beneath; the
        legend beside the axes.

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf``, ``.svg``), atomically with the
            object API (the user's backend is never changed).
        diagram : tuple or None, default ``None``
            ``(values, x)`` of a brute-force diagram (:func:`brute_force_diagram`) drawn
            beneath in grey dots.

        Returns
        -------
        matplotlib.figure.Figure
        """
        p = self.params
        title = (
            f"Continuation in {self.parameter} from {decimal_str(self.start)} "
            f"to {decimal_str(self.stop)} "
            f"(zeta={decimal_str(p.zeta)}, a={decimal_str(p.a)}, x_w={decimal_str(p.x_w)}, "
            f"R={decimal_str(p.R)}, eta={decimal_str(p.eta)})"
        )
        xw = float(self.params.x_w) if self.parameter != "x_w" else None
        fig = branches_figure(
            self.branches, self.bifurcations, self.parameter, title, xw=xw, diagram=diagram
        )
        return finish(fig, path, dpi=120)

    def save_all(self, out: str | os.PathLike, diagram: tuple | None = None) -> dict[str, Path]:
        """Write ``continuation.json`` and ``continuation.png`` (over a diagram) in ``out``.

        Parameters
        ----------
        out : str or os.PathLike
            Directory (created).
        diagram : tuple or None, default ``None``
            As in :meth:`plot`.

        Returns
        -------
        dict
            ``{"json": path, "png": path}``.
        """
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        files = {"json": self.save(out / "continuation.json")}
        files["png"] = out / "continuation.png"
        self.plot(files["png"], diagram=diagram)
        return files


def branches_figure(
    branches: list,
    bifurcations: list,
    parameter: str,
    title: str,
    xw: float | None = None,
    diagram: tuple | None = None,
):
    """Branches (x above, LLE beneath) with their bifurcations; the legend beside the axes."""
    fig, axes = new_figure(
        2,
        1,
        figsize=(12, 7.5),
        sharex=True,
        gridspec_kw={"height_ratios": [3, 2]},
    )
    ax1, ax2 = axes[:, 0]
    if diagram is not None:
        vals, xs = diagram
        draw_density(ax1, vals, xs, ink="0.45")
        ax1.plot([], [], "s", color="0.55", ms=4, label="brute force (simulated attractors)")
    _plot_branches(branches, ax1, ax2)
    _plot_bifurcations(branches, bifurcations, ax1)
    if xw is not None:
        ax1.axhline(xw, color="tab:red", lw=0.7, label="wall x = x_w")
    ax1.set_ylabel("x at t0 + kT (dimensionless)")
    legend_outside(ax1, fontsize=7.5)
    ax2.axhline(0, color="k", lw=0.6)
    ax2.set_ylabel("LLE = ln|mu_max| / (pT)")
    ax2.set_xlabel(parameter)
    fig.suptitle(wrap_title(title, fig), fontsize=10)
    return fig


def _plot_branches(branches: list, ax1: Any, ax2: Any) -> None:
    """Draw every branch on ``ax1`` (x) and ``ax2`` (LLE), styled by stability."""
    colors = [
        "tab:blue",
        "tab:purple",
        "tab:brown",
        "tab:cyan",
        "tab:olive",
        "tab:pink",
        "tab:green",
        "tab:gray",
    ]
    for k, b in enumerate(branches):
        c = colors[k % len(colors)]
        elliptic = np.asarray(b.stability) == "elliptic"
        kind = np.where(~b.admissible, 2, np.where(b.stable, 0, np.where(elliptic, 3, 1)))
        for lo, hi in _runs(kind):
            sl = slice(lo, min(hi + 1, len(kind)))
            style = {
                0: dict(ls="-", lw=1.6, color=c),
                1: dict(ls="--", lw=1.2, color=c),
                2: dict(ls=":", lw=0.9, color="0.6"),
                3: dict(ls="-.", lw=1.2, color=c),
            }[int(kind[lo])]
            for j in range(b.period):
                ax1.plot(b.values[sl], b.x[sl, j], **style)
            ax2.plot(b.values[sl], b.lle[sl], **style)
        ax1.plot([], [], color=c, label=f"branch {k}: period {b.period}, {b.impacts} impact(s)")


def _plot_bifurcations(branches: list, bifurcations: list, ax1: Any) -> None:
    """The style legend entries and the bifurcation points on ``ax1``."""
    ax1.plot([], [], "k-", label="stable")
    ax1.plot([], [], "k--", label="unstable")
    if any(np.any(np.asarray(b.stability) == "elliptic") for b in branches):
        ax1.plot([], [], "k-.", label="elliptic (neutral: zeta = 0, R = 1)")
    ax1.plot([], [], ":", color="0.6", label="virtual (past grazing)")
    marks = {
        "grazing": ("o", "tab:orange"),
        "period-doubling": ("s", "tab:red"),
        "fold": ("^", "tab:green"),
        "branch-point": ("v", "tab:olive"),
        "neimark-sacker": ("D", "tab:pink"),
    }
    seen = set()
    for bif in bifurcations:
        m, c = marks[bif.type]
        lab = bif.type if bif.type not in seen else None
        seen.add(bif.type)
        ax1.plot(
            [bif.value] * len(bif.x),
            bif.x,
            m,
            color=c,
            ms=6,
            mfc=c if bif.admissible else "none",
            label=lab,
            zorder=5,
        )


def _runs(kind: np.ndarray):
    """Maximal runs ``[lo, hi)`` of equal values."""
    lo = 0
    for i in range(1, len(kind) + 1):
        if i == len(kind) or kind[i] != kind[lo]:
            yield lo, i
            lo = i


def brute_force_diagram(
    params: Params,
    parameter: Any,
    start: float | None = None,
    stop: float | None = None,
    n: int | None = None,
    periods: int = 64,
    transient: int = 1000,
    *,
    model: str | None = None,
    engine: str | None = None,
    workers: int | None = 1,
    progress: ProgressArg = False,
) -> tuple:
    """Stroboscopic ``x`` of the simulated attractor at ``n`` values of a parameter.

    Parameters
    ----------
    params : Params
        The system (the parameter replaced by each value; every run starts at its ``(x0, v0)``).
    parameter : tuple ``(name, start, stop, n)``
        The axis: the varied parameter, its range (both included; the values are
        ``numpy.linspace`` of the ends in float64) and the number of values.  The
        deprecated form ``(params, name, start, stop, n=200)`` still works with a
        :class:`DeprecationWarning`.
    start, stop, n : optional
        The deprecated form's range (floats) and count (default 200).
    periods, transient : int, default 64, 1000
        Recorded and discarded periods per value.
    model : str, default ``'fast'``
        ``'fast'`` (the compiled closed form without its heyoka fallback) or
        ``'heyoka'``.
    engine : str or None, default ``None``
        Deprecated spelling of ``model`` (a :class:`DeprecationWarning`).
    workers : int or None, default 1
        Worker processes (``None``: every core).
    progress : bool, None or callable, default ``False``
        :data:`~precise_impact.io.progress.ProgressArg`.

    Returns
    -------
    tuple
        ``(values, x)``: ``x`` of shape ``(n, periods)`` (NaN where the run fails,
        e.g. chattering or sticking without a fallback, and the value is skipped).

    See Also
    --------
    precise_impact.analysis.bifurcation.bifurcation : the same diagram along eta with the LLE.
    precise_impact.analysis.orbits.continuation.continue_orbit
        The periodic branches, stable and unstable.
    precise_impact.analysis.periodicity.detect_period : the period of each column.

    Examples
    --------
    >>> import precise_impact as pi
    >>> values, xs = pi.brute_force_diagram(pi.Params.make(eta="0.74"), ("eta", "0.73", "0.75", 3),
    ...                                      periods=8, transient=20)
    >>> values.round(2).tolist(), xs.shape
    ([0.73, 0.74, 0.75], (3, 8))
    """
    if isinstance(parameter, str):
        deprecated_keyword(
            "(parameter, start, stop, n)",
            "an axis tuple (name, start, stop, n)",
            "brute_force_diagram",
        )
        name, lo, hi, count = parameter, start, stop, 200 if n is None else n
    else:
        for key, value in (("start", start), ("stop", stop), ("n", n)):
            if value is not None:
                raise ParameterError(key, value, "not given with an axis tuple")
        name, lo, hi, count = check_axis(parameter, what="parameter")
        lo, hi = float(exact(f"{name}_min", lo)), float(exact(f"{name}_max", hi))
    model = resolve_model(model, engine, "brute_force_diagram")
    count = check_count(count, "n", 1_000_000, minimum=1)
    vals = np.linspace(lo, hi, count)
    job = functools.partial(_diagram_tile, params, name, vals, periods, transient, model)
    workers = check_workers(workers)
    tile = max(1, count // (workers * 8))
    run = run_scan(
        job, count, tile, workers=workers, progress=progress, label="brute-force diagram"
    )
    return vals, np.concatenate(run.values)


def _diagram_tile(params, parameter, vals, periods, transient, model, lo, hi) -> np.ndarray:
    """The runner's job: the diagram's rows ``lo .. hi - 1``."""
    if model == "fast":
        from precise_impact.solvers.fast.single import FastSolver  # noqa: PLC0415 -- heavy: numba ~0.5 s, loaded on first use

        solver = FastSolver(fallback=False)
    else:
        solver = make_solver("heyoka")
    xs = np.full((hi - lo, periods), math.nan)
    for i in range(lo, hi):
        q = params.replace(**{parameter: Fraction(float(vals[i]))})
        try:
            tr = solver.solve(q, transient + periods, per_period=1)
        except Exception:  # chattering/sticking without a fallback: left out of the picture
            continue
        xs[i - lo] = np.asarray(tr.x[-periods:], dtype=float)
    return xs
