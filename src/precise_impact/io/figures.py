"""Figures without pyplot: the one place the package makes, styles and saves plots.

Agg canvases only, so a plot never changes the backend or the rcParams of the user's session.
Every result type with samples or rows has a ``plot(path=None, units="dimensionless", ...)``
returning the Figure (also written atomically to ``path``, format by suffix); the convention,
the unit modes and the list of types: ``docs/design.rst``, :mod:`precise_impact.io.figures`.
"""

from __future__ import annotations

import dataclasses
import itertools
import os
import textwrap
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.errors import ParameterError
from precise_impact.io.atomic import atomic_write

__all__ = [
    "figure",
    "new_figure",
    "save_figure",
    "finish",
    "PlotUnits",
    "plot_units",
    "UNITS",
    "impact_path",
    "draw_phase_portrait",
    "draw_wall",
    "legend_outside",
    "series_styles",
    "period_colormap",
    "PLOT_FORMATS",
    "check_plot_path",
    "trajectory_floats",
    "phase_portrait_panels",
    "time_series",
    "wrap_title",
    "plot_trajectory",
    "plot_differences",
    "register_circuit_units",
    "plot_coupled",
    "CoupledPlotMixin",
    "plot_certified",
    "figure_legend",
    "draw_density",
]

#: The unit modes of phase portraits and time series.
UNITS = ("dimensionless", "circuit")

#: Image formats by file suffix.
PLOT_FORMATS = {".png": "png", ".pdf": "pdf", ".svg": "svg"}


def figure(figsize: tuple[float, float] = (7.0, 4.5), layout: str | None = None):
    """An empty :class:`~matplotlib.figure.Figure` with an Agg canvas of its own (no pyplot).

    Parameters
    ----------
    figsize : (float, float), default ``(7.0, 4.5)``
        Size in inches.
    layout : str or None, default ``None``
        Matplotlib layout engine (``'constrained'``, ``'tight'`` or ``None``).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: PLC0415 -- heavy: matplotlib ~0.3 s, loaded on first plot
    from matplotlib.figure import Figure  # noqa: PLC0415 -- heavy: matplotlib ~0.3 s, loaded on first plot

    fig = Figure(figsize=figsize, layout=layout)
    FigureCanvasAgg(fig)
    return fig


def new_figure(
    nrows: int = 1,
    ncols: int = 1,
    figsize: tuple[float, float] = (7.0, 4.5),
    layout: str | None = "constrained",
    **subplots_kw: Any,
):
    """A new figure and its axes, drawn by an Agg canvas of its own.

    Parameters
    ----------
    nrows, ncols : int, default 1
        Grid of axes.
    figsize : (float, float), default ``(7.0, 4.5)``
        Size in inches.
    layout : str or None, default ``'constrained'``
        Matplotlib layout engine.
    **subplots_kw
        Passed to :meth:`matplotlib.figure.Figure.subplots` (``sharex``, ``gridspec_kw`` ...).

    Returns
    -------
    fig : matplotlib.figure.Figure
    axes : numpy.ndarray of Axes, shape ``(nrows, ncols)``
    """
    fig = figure(figsize, layout)
    axes = fig.subplots(nrows, ncols, squeeze=False, **subplots_kw)
    return fig, axes


def save_figure(fig, path: str | os.PathLike, fmt: str | None = None, dpi: int = 150) -> Path:
    """Save ``fig`` to ``path`` atomically (format from the suffix unless ``fmt``).

    Returns
    -------
    pathlib.Path
        The file written.
    """
    path = Path(path)
    fmt = fmt or path.suffix.lstrip(".").lower() or "png"
    atomic_write(path, lambda fh: fig.savefig(fh, format=fmt, dpi=dpi), binary=True)
    return path


def check_plot_path(path: Any) -> Path | None:
    """``path`` as a Path if it ends in a known image suffix (``None`` stays ``None``), else a
    :class:`~precise_impact.errors.ParameterError` before any drawing."""
    if path is None:
        return None
    p = Path(path)
    if p.suffix.lower() not in PLOT_FORMATS:
        raise ParameterError("path", str(path), "a plot file ending in " + ", ".join(PLOT_FORMATS))
    return p


def finish(fig, path: Any = None, dpi: int = 120):
    """The end of every ``plot()``: write ``fig`` to ``path`` if one is given (atomically,
    format by suffix) and return ``fig``."""
    p = check_plot_path(path)
    if p is not None:
        save_figure(fig, p, fmt=PLOT_FORMATS[p.suffix.lower()], dpi=dpi)
    return fig


# ----------------------------------------------------------------------------- units
@dataclasses.dataclass(frozen=True)
class PlotUnits:
    """Scale factors and axis labels of one unit mode (:func:`plot_units`).

    ``t``, ``x``, ``v`` (and ``d`` for differences ``|x - y|``) multiply dimensionless
    values into the plotted ones; the ``*_label`` strings name the axes with their units.
    """

    name: str
    t_scale: float = 1.0
    x_scale: float = 1.0
    v_scale: float = 1.0
    t_label: str = "tau = omega t (dimensionless)"
    x_label: str = "x (dimensionless)"
    v_label: str = "x' = dx/dtau (dimensionless)"
    d_label: str = "|x - y| (dimensionless)"
    wall_name: str = "wall x = x_w"
    note: str = ""

    def t(self, a: Any) -> np.ndarray:
        return np.asarray(a, dtype=float) * self.t_scale

    def x(self, a: Any) -> np.ndarray:
        return np.asarray(a, dtype=float) * self.x_scale

    def v(self, a: Any) -> np.ndarray:
        return np.asarray(a, dtype=float) * self.v_scale

    def d(self, a: Any) -> np.ndarray:
        """A distance ``|x - y|`` (always >= 0)."""
        return np.asarray(a, dtype=float) * abs(self.x_scale)


def plot_units(units: str = "dimensionless", params: Any = None, components: Any = None):
    """The :class:`PlotUnits` of ``units``.

    Parameters
    ----------
    units : {'dimensionless', 'circuit'}
        ``'circuit'``: ``t`` in seconds, ``x`` as the integrator voltage ``V_s = -V_unit x``
        and ``x'`` as ``V_q = omega R8 C1 V_unit x'`` in volts
        (:func:`~precise_impact.models.circuit.components.circuit_scales`).
    params : Params or None
        For ``'circuit'`` without ``components``: the nominal design realising them
        (:func:`~precise_impact.models.circuit.components.nominal_components`, 10 kOhm,
        100 nF, 1 V per unit).
    components : Components or None
        The design (a scene's ``design()``); takes precedence over ``params``.

    Raises
    ------
    ParameterError
        Another ``units``, or ``'circuit'`` with neither ``params`` nor ``components``.
    """
    if units not in UNITS:
        raise ParameterError("units", units, "'dimensionless' or 'circuit'")
    if units == "dimensionless":
        return PlotUnits("dimensionless")
    # registered by precise_impact.models.circuit.components, which the package's __init__
    # imports before any submodule can be used
    nominal_components, circuit_scales = _CIRCUIT["nominal"], _CIRCUIT["scales"]
    if components is None:
        if params is None:
            raise ParameterError("units", units, "'circuit' needs the params or the components")
        # the seconds and volts of the nominal design; its realisability checks (R = 1 and
        # zeta > 0 for a circuit) do not concern the scales: a mechanical run at R = 0.8 is
        # drawn in the units of the circuit that would realise it at R = 1
        realisable = params.replace(R=1, zeta=params.zeta or Fraction(1, 20))
        components = nominal_components(realisable)
    if not all(hasattr(components, n) for n in ("R8", "C1")):
        raise ParameterError("components", type(components).__name__, "a Components object")
    s = circuit_scales(components)
    return PlotUnits(
        "circuit",
        t_scale=s.seconds_per_tau,
        x_scale=s.volts_per_x,
        v_scale=s.volts_per_v,
        t_label="t (s)",
        x_label=f"V_s (V) = {s.volts_per_x:g} V * x",
        v_label=f"V_q (V) = {s.volts_per_v:.4g} V * x'",
        d_label="|V_s1 - V_s2| (V)",
        wall_name="wall V_s = V_wall",
        note=f"omega = {s.omega:.6g} rad/s",
    )


#: The circuit's design and mapping, registered by the circuit models (a layer above io):
#: ``{"nominal": nominal_components, "scales": circuit_scales}``.
_CIRCUIT: dict[str, Any] = {}


def register_circuit_units(nominal_components: Any, circuit_scales: Any) -> None:
    """Called once by :mod:`precise_impact.models.circuit.components`: the functions
    :func:`plot_units` uses for ``units='circuit'``."""
    _CIRCUIT["nominal"] = nominal_components
    _CIRCUIT["scales"] = circuit_scales


# ------------------------------------------------------------------- phase portraits
def impact_path(
    t: Any,
    x: Any,
    v: Any,
    impacts_t: Any,
    v_before: Any,
    v_after: Any,
    x_w: float,
) -> tuple[np.ndarray, np.ndarray]:
    """A sampled phase curve with each impact drawn as a vertical jump at the wall.

    Between the samples that bracket an impact at ``t_k`` the path runs to ``(x_w, v_before)``,
    up or down to ``(x_w, v_after)`` and on, instead of a chord across the reversal.  An impact
    whose velocities are not recorded (NaN) leaves a gap (a NaN break), never a chord.

    Parameters
    ----------
    t, x, v : array_like
        Samples in time order (float).
    impacts_t, v_before, v_after : array_like
        The impacts in time order (float; NaN where a model records none).
    x_w : float
        The wall.

    Returns
    -------
    x, v : numpy.ndarray
        The path to draw (longer than the samples by two points per impact).
    """
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    v = np.asarray(v, dtype=float)
    ti = np.asarray(impacts_t, dtype=float)
    vb = np.asarray(v_before, dtype=float)
    va = np.asarray(v_after, dtype=float)
    if len(t) == 0 or len(ti) == 0:
        return x, v
    inside = (ti > t[0]) & (ti <= t[-1])
    ti, vb, va = ti[inside], vb[inside], va[inside]
    # an impact at t_k goes after the last sample with t_i < t_k (a sample at the impact
    # instant itself is drawn after the jump)
    pos = np.searchsorted(t, ti, side="left")
    ins_x = np.repeat(float(x_w), 2 * len(ti))
    ins_v = np.column_stack([vb, va]).ravel()
    known = np.isfinite(ins_v)
    ins_x = np.where(known, ins_x, np.nan)
    ins_v = np.where(known, ins_v, np.nan)
    idx = np.repeat(pos, 2)
    return np.insert(x, idx, ins_x), np.insert(v, idx, ins_v)


def draw_wall(ax: Any, x_w: float, units: PlotUnits, vertical: bool = True) -> None:
    """The wall as a labelled red line (``label`` in the legend and its value on the axis)."""
    pos = float(units.x(x_w))
    name = f"{units.wall_name} = {pos:g}" + (" V" if units.name == "circuit" else "")
    if vertical:
        ax.axvline(pos, color="tab:red", lw=1.0, label=name, zorder=1.5)
    else:
        ax.axhline(pos, color="tab:red", lw=1.0, label=name, zorder=1.5)


def draw_phase_portrait(
    ax: Any,
    f: dict,
    x_w: float,
    units: PlotUnits,
    t_from: float | None = None,
    dense: tuple | None = None,
    label: str | None = None,
    color: str = "tab:blue",
    lw: float = 0.6,
    strobe: bool = True,
    **kw: Any,
) -> None:
    """A trajectory's phase portrait: the dense curve with impacts as vertical jumps and the
    stroboscopic samples as black dots.

    Parameters
    ----------
    ax : Axes
    f : dict
        Float64 samples and impacts (:meth:`~precise_impact.core.trajectory.Trajectory.as_float64`).
    x_w : float
        The wall (dimensionless).
    units : PlotUnits
    t_from : float or None
        Draw from this (dimensionless) time on.
    dense : (t, x, v) or None
        Dense samples (float64); without them the stroboscopic samples are the curve.
    label, color, lw
        Style of the curve.
    strobe : bool, default True
        Also draw the stroboscopic samples ``x, x'`` at ``t0 + kT``.
    **kw
        Passed to the curve's ``plot``.
    """
    t, x, v = dense if dense is not None else (f["t"], f["x"], f["v"])
    t, x, v = (np.asarray(a, dtype=float) for a in (t, x, v))
    it, ivb, iva = f["impacts_t"], f["impacts_v_before"], f["impacts_v_after"]
    if t_from is not None:
        sel = t >= t_from
        t, x, v = t[sel], x[sel], v[sel]
        isel = np.asarray(it) >= t_from
        it, ivb, iva = np.asarray(it)[isel], np.asarray(ivb)[isel], np.asarray(iva)[isel]
    if dense is not None:
        px, pv = impact_path(t, x, v, it, ivb, iva, x_w)
        ax.plot(units.x(px), units.v(pv), lw=lw, color=color, label=label, **kw)
    if strobe:
        st, sx, sv = (np.asarray(f[k], dtype=float) for k in ("t", "x", "v"))
        if t_from is not None:
            keep = st >= t_from
            sx, sv = sx[keep], sv[keep]
        ax.plot(
            units.x(sx),
            units.v(sv),
            ".",
            ms=3,
            color="k",
            label="samples at t0 + kT" if dense is not None else label,
            zorder=5,
        )
    ax.set_xlabel(units.x_label)
    ax.set_ylabel(units.v_label)


# ------------------------------------------------------------------------ styles
def draw_density(
    ax: Any, values: Any, x: Any, rows: int = 360, ink: str = "black", zorder: float = 0
) -> None:
    """A bifurcation diagram as an image: each parameter value's samples ``x[j]`` binned into
    ``rows`` pixel rows, every row holding a sample inked and rows holding a larger share
    darker (drawing millions of markers instead took ~40 s for 400 x 200000 samples).
    ``rows`` stays below the axes' height in pixels at the usual sizes, so that no inked row
    is lost when the image is resampled."""
    from matplotlib.colors import LinearSegmentedColormap  # noqa: PLC0415 -- heavy: matplotlib ~0.3 s, loaded on first plot

    eta = np.asarray(values, dtype=float)
    x = np.asarray(x, dtype=float)
    order = np.argsort(eta, kind="stable")  # a diagram may run downwards (1 -> 0.9)
    eta, x = eta[order], x[order]
    if x.size == 0 or not np.isfinite(x).any():
        return
    lo, hi = float(np.nanmin(x)), float(np.nanmax(x))
    pad = 0.02 * (hi - lo) if hi > lo else 0.5
    lo, hi = lo - pad, hi + pad
    img = np.zeros((rows, len(eta)))
    for j in range(len(eta)):
        col = x[j][np.isfinite(x[j])]
        if len(col):
            idx = np.minimum(((col - lo) / (hi - lo) * rows).astype(np.int64), rows - 1)
            share = np.bincount(idx, minlength=rows) / len(col)
            # any sample inks its pixel (>= 0.35 grey), fuller rows darker
            img[:, j] = np.where(share > 0, 0.35 + 0.65 * np.minimum(1.0, np.sqrt(share) / 0.3), 0)
    if len(eta) > 1:
        d = (eta[-1] - eta[0]) / (len(eta) - 1) / 2
    else:
        d = 0.5e-3
    cmap = LinearSegmentedColormap.from_list("ink", ["white", ink])
    ax.imshow(
        np.ma.masked_equal(img, 0.0),
        origin="lower",
        aspect="auto",
        extent=(eta[0] - d, eta[-1] + d, lo, hi),
        cmap=cmap.with_extremes(bad="white"),
        vmin=0.0,
        vmax=1.0,
        interpolation="antialiased",  # never drop a one-row orbit
        rasterized=True,
        zorder=zorder,
    )


def figure_legend(fig: Any, axes: Any, ncol: Any = 4, fontsize: float = 8):
    """One legend for the whole figure beneath its axes (outside every panel), each label once."""
    handles: dict = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(lab, h)
    if not handles:
        return None
    n = len(handles) if ncol is None else ncol
    return fig.legend(
        list(handles.values()),
        list(handles),
        loc="outside lower center",
        ncol=max(1, min(int(n), len(handles))),
        fontsize=fontsize,
    )


def legend_outside(ax: Any, where: str = "right", fontsize: float = 8, **kw: Any):
    """A legend beside the axes (``'right'``) or beneath them (``'below'``), never over data."""
    if where == "right":
        return ax.legend(
            loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=fontsize, **kw
        )
    return ax.legend(
        loc="upper center",
        bbox_to_anchor=(0.5, -0.15),
        borderaxespad=0.0,
        fontsize=fontsize,
        ncol=kw.pop("ncol", 2),
        **kw,
    )


_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")
_MARKERS = ("o", "s", "^", "D", "v", "P", "X")
_LINES = ("-", "--", ":", "-.")


def series_styles(n: int) -> list[dict[str, str]]:
    """``n`` distinct ``{color, marker, ls}`` styles: colour, marker and line style cycle with
    coprime lengths (6, 7, 4), so the first 168 are pairwise different in all three and no two
    series share a colour-marker pair before 42."""
    col, mk, ls = (itertools.cycle(c) for c in (_COLORS, _MARKERS, _LINES))
    return [{"color": next(col), "marker": next(mk), "ls": next(ls)} for _ in range(n)]


def period_colormap(period: Any, max_period: int = 32):
    """A discrete colour map for whole periods: one colour per category present in ``period``.

    The categories are the periods ``1..max_period`` found, ``0`` (no period found up to
    ``max_period``, white) and negative codes (refused, dark grey); NaN is left blank.

    Parameters
    ----------
    period : array_like
        Detected periods (0: none found, < 0: refused).
    max_period : int, default 32
        The largest period the detection looks for.

    Returns
    -------
    index : numpy.ndarray of float
        ``period`` as category indices ``0..n-1`` (NaN stays NaN): draw this.
    cmap : matplotlib.colors.ListedColormap
        ``n`` colours.
    norm : matplotlib.colors.BoundaryNorm
        Bins ``[-0.5, 0.5, ..., n - 0.5]``, one colour each (no interpolation between periods).
    labels : list of str
        The category names, by index (a colour bar's tick labels at ``0..n-1``).
    """
    import matplotlib  # noqa: PLC0415 -- heavy: matplotlib ~0.3 s, loaded on first plot
    from matplotlib.colors import BoundaryNorm, ListedColormap  # noqa: PLC0415 -- heavy: matplotlib ~0.3 s, loaded on first plot

    per = np.asarray(period, dtype=float)
    finite = per[np.isfinite(per)]
    cats = sorted({int(c) for c in finite}) or [0]
    base = list(matplotlib.colormaps["tab20"].colors) + list(matplotlib.colormaps["tab20b"].colors)
    colours, labels = [], []
    for c in cats:
        if c < 0:
            colours.append("0.3")
            labels.append("refused" if c == -1 else f"refused ({-c})")
        elif c == 0:
            colours.append("white")
            labels.append(f"none <= {max_period}")
        else:
            colours.append(base[(c - 1) % len(base)])
            labels.append(str(c))
    index = np.full(per.shape, np.nan)
    ok = np.isfinite(per)
    index[ok] = np.searchsorted(cats, per[ok].astype(int))
    cmap = ListedColormap(colours, name="periods")
    norm = BoundaryNorm(np.arange(-0.5, len(cats), 1.0), cmap.N)
    return index, cmap, norm, labels


# ------------------------------------------------------------- trajectory figures
def trajectory_floats(tr: Any) -> tuple[dict, tuple | None]:
    """``(samples and impacts as float64, (dense t, x, v) or None)`` of a trajectory-like
    result (``as_float64()``, ``precision``, ``dense_t/x/v``)."""
    with np.errstate(invalid="ignore"):
        f = tr.as_float64()
    dense = None
    if getattr(tr, "dense_t", None) is not None and len(tr.dense_t):
        conv = tr.precision.floats
        dense = (conv(tr.dense_t), conv(tr.dense_x), conv(tr.dense_v))
    return f, dense


def phase_portrait_panels(
    panels: list,
    x_w: float,
    units: PlotUnits,
    title: str,
    reference: Any = None,
    t_from: float | None = None,
    verdicts: dict | None = None,
    panel_size: tuple[float, float] = (4.2, 4.0),
):
    """Side-by-side phase portraits, one per ``(label, trajectory)``, sharing axes.

    Each panel: the dense curve (impacts as vertical jumps at the labelled wall), the model's
    samples at ``t0 + kT`` (black dots) and, when ``reference`` is given, the reference's
    samples (red rings) over them; ``verdicts[label]`` is added to the panel's title.  One
    legend beneath the panels.

    Returns
    -------
    matplotlib.figure.Figure
    """
    n = len(panels)
    fig = figure(figsize=(panel_size[0] * n, panel_size[1] + 0.9), layout="constrained")
    axes = fig.subplots(1, n, sharex=True, sharey=True, squeeze=False)[0]
    ref_f = None
    if reference is not None:
        ref_f, _ = trajectory_floats(reference)
    for j, (ax, (label, tr)) in enumerate(zip(axes, panels, strict=True)):
        f, dense = trajectory_floats(tr)
        draw_phase_portrait(ax, f, x_w, units, t_from=t_from, dense=dense, label="trajectory")
        if ref_f is not None and tr is not reference:
            keep = ref_f["t"] >= (t_from if t_from is not None else -np.inf)
            ax.plot(
                units.x(ref_f["x"][keep]),
                units.v(ref_f["v"][keep]),
                "o",
                ms=5,
                mfc="none",
                mec="tab:red",
                mew=0.8,
                label="reference samples",
                zorder=6,
            )
        draw_wall(ax, x_w, units)
        head = label if not verdicts or label not in verdicts else f"{label}\n{verdicts[label]}"
        # the axes take ~80 % of the panel; DejaVu Sans is ~0.6 em per character
        chars = max(20, int(panel_size[0] * 72 * 0.8 / (0.6 * 8.5)))
        ax.set_title(
            "\n".join(textwrap.fill(line, chars) for line in head.split("\n")), fontsize=8.5
        )
        if j:
            ax.set_ylabel("")
        ax.grid(True, lw=0.3, alpha=0.5)
    figure_legend(fig, axes, ncol=4)
    suffix = f" [{units.note}]" if units.note else ""
    fig.suptitle(wrap_title(title + suffix, fig), fontsize=10)
    return fig


def wrap_title(text: str, fig: Any, fontsize: float = 10) -> str:
    """``text`` broken into lines that fit the figure's width (about 0.6 fontsize wide per
    character), so a title is never clipped."""
    width_pt = fig.get_figwidth() * 72 * 0.95
    chars = max(30, int(width_pt / (0.6 * fontsize)))
    return "\n".join(textwrap.wrap(text, chars)) if len(text) > chars else text


def time_series(
    ax: Any,
    f: dict,
    dense: tuple | None,
    x_w: float,
    units: PlotUnits,
    label: str = "trajectory",
    color: str = "tab:blue",
    t_from: float | None = None,
) -> None:
    """``x`` against time (dense when available) with the samples at ``t0 + kT`` and the
    labelled wall; from the (dimensionless) time ``t_from`` on if given."""
    if t_from is not None:
        keep = np.asarray(f["t"]) >= t_from
        ik = np.asarray(f["impacts_t"]) >= t_from
        imp = ("impacts_t", "impacts_v_before", "impacts_v_after")
        f = {
            **{k: np.asarray(f[k])[keep] for k in ("t", "x", "v")},
            **{k: np.asarray(f[k])[ik] for k in imp},
        }
        if dense is not None:
            dk = np.asarray(dense[0]) >= t_from
            dense = tuple(np.asarray(a)[dk] for a in dense)
    if dense is not None:
        ax.plot(units.t(dense[0]), units.x(dense[1]), lw=0.6, color=color, label=label)
    ax.plot(
        units.t(f["t"]),
        units.x(f["x"]),
        ".",
        ms=3,
        color="k",
        label="samples at t0 + kT",
        zorder=5,
    )
    if len(f["impacts_t"]):
        ax.plot(
            units.t(f["impacts_t"]),
            units.x(np.full(len(f["impacts_t"]), x_w)),
            "|",
            ms=8,
            color="tab:red",
            label="impacts",
        )
    draw_wall(ax, x_w, units, vertical=False)
    ax.set_xlabel(units.t_label)
    ax.set_ylabel(units.x_label)


def plot_trajectory(
    tr: Any,
    path: Any = None,
    units: str = "dimensionless",
    components: Any = None,
    title: str | None = None,
    last: int | None = None,
):
    """A trajectory's phase portrait (impacts as vertical jumps) beside ``x`` against time.

    Parameters
    ----------
    tr : Trajectory
        Any trajectory-like result (``as_float64``, ``params``, optional dense output).
    path : str, os.PathLike or None
        Also write the figure there (``.png``, ``.pdf``, ``.svg``).
    units : {'dimensionless', 'circuit'}
        See :func:`plot_units`; ``components`` as there (default: the nominal design of
        ``tr.params``).
    title : str or None
        The figure's title (default: model, precision, eta, periods, impacts).
    last : int or None
        Draw only the last ``last`` forcing periods (``None``: all; a long run's ``x(t)``
        is otherwise a solid band).

    Returns
    -------
    matplotlib.figure.Figure
    """
    check_plot_path(path)
    u = plot_units(units, params=tr.params, components=components)
    f, dense = trajectory_floats(tr)
    x_w = float(tr.params.x_w)
    n = len(f["t"]) - 1
    if last is not None and not (isinstance(last, int) and 1 <= last):
        raise ParameterError("last", last, "an integer >= 1 (periods drawn) or None")
    t_from = None if last is None or last >= n else float(f["t"][n - last])
    fig = figure(figsize=(11, 4.6), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1, 1.5]})
    draw_phase_portrait(ax1, f, x_w, u, t_from=t_from, dense=dense, label="trajectory")
    draw_wall(ax1, x_w, u)
    window = "" if t_from is None else f", the last {last} periods"
    ax1.set_title("phase portrait" + window, fontsize=9)
    time_series(ax2, f, dense, x_w, u, t_from=t_from)
    ax2.set_title("x against time" + window, fontsize=9)
    for ax in (ax1, ax2):
        ax.grid(True, lw=0.3, alpha=0.5)
    figure_legend(fig, (ax1, ax2), ncol=5)
    n_imp = len(f["impacts_t"])
    head = title or (
        f"{getattr(tr, 'model', type(tr).__name__)} {getattr(tr.precision, 'name', '')}: "
        f"eta = {tr.params.decimal()['eta']}, {len(f['t']) - 1} periods, {n_imp} impacts"
    )
    if u.note:
        head += f" [{u.note}]"
    fig.suptitle(wrap_title(head, fig), fontsize=10)
    return finish(fig, path)


def plot_differences(
    panels: list,
    units: PlotUnits,
    title: str,
    threshold: float | None = None,
    path: Any = None,
):
    """``|x - y|`` against time (log scale), one panel per ``(t, d, heading)``.

    ``t`` and ``d`` are dimensionless (float64); samples where ``d`` is exactly 0 (the slave
    collapsed onto the master bit for bit) cannot be shown on a log axis and are marked in
    the heading by the caller.  The threshold (dashed) and the legend sit beneath the panels.

    Returns
    -------
    matplotlib.figure.Figure
    """
    check_plot_path(path)
    fig = figure(figsize=(8.5, 2.2 + 2.4 * len(panels)), layout="constrained")
    axes = fig.subplots(len(panels), 1, squeeze=False, sharex=True)[:, 0]
    for ax, (t, d, heading) in zip(axes, panels, strict=True):
        t, d = np.asarray(t, dtype=float), np.asarray(d, dtype=float)
        pos = d > 0
        ax.semilogy(
            units.t(t[pos]), units.d(d[pos]), lw=0.6, color="C0", label=units.d_label.split(" (")[0]
        )
        if not pos.any():
            ax.text(
                0.5,
                0.5,
                "|x - y| = 0 at every sample (the runs are identical): nothing on a log axis",
                transform=ax.transAxes,
                ha="center",
                fontsize=9,
            )
        if threshold is not None:
            ax.axhline(
                float(units.d(threshold)),
                ls="--",
                lw=0.9,
                color="C3",
                label=f"threshold {float(units.d(threshold)):g}"
                + (" V" if units.name == "circuit" else ""),
            )
        ax.set_title(heading, fontsize=9.5, loc="left")
        ax.set_ylabel(units.d_label)
        ax.grid(True, which="major", lw=0.3)
    axes[-1].set_xlabel(units.t_label)
    h, lab = axes[0].get_legend_handles_labels()
    fig.legend(h, lab, loc="outside lower center", ncol=len(lab) or 1, fontsize=8)
    suffix = f" [{units.note}]" if units.note else ""
    fig.suptitle(wrap_title(title + suffix, fig, 10.5), fontsize=10.5)
    return finish(fig, path, dpi=150)


def plot_coupled(
    tr: Any,
    path: Any = None,
    units: str = "dimensionless",
    components: Any = None,
    threshold: float | None = None,
):
    """``|x - y|`` of a master-slave run against time (log scale), the facts in the title.

    Parameters
    ----------
    tr : CoupledTrajectory, CoupledCircuitTrajectory or CertifiedCoupledTrajectory
    path, units, components
        As in :func:`plot_trajectory` (``'circuit'``: ``|V_s1 - V_s2|`` in volts, ``t`` in s).
    threshold : float or None
        A dashed line (dimensionless).

    Returns
    -------
    matplotlib.figure.Figure
    """
    check_plot_path(path)
    u = plot_units(units, params=tr.params, components=components)
    if hasattr(tr, "difference"):
        t, d = tr.difference(dense=getattr(tr, "dense_t", None) is not None)
    else:  # stroboscopic samples: the difference in the working precision, then rounded
        P = tr.precision
        t = np.array([P.to_float(a) for a in tr.t])
        d = np.array([abs(P.to_float(a - b)) for a, b in zip(tr.x, tr.y, strict=True)])
    d = np.asarray(d, dtype=float)
    unit = " V" if u.name == "circuit" else ""
    parts = []
    if getattr(tr, "form", None):
        parts.append(str(tr.form))
    k = getattr(tr, "k", None)
    if k is not None:
        parts.append(f"k = {float(k):g}")
    for r in ("R31", "R32"):  # the circuit pair's coupling resistors
        if getattr(tr, r, None) is not None:
            parts.append(f"{r} = {float(getattr(tr, r)):g} ohm")
    head = (
        f"{', '.join(parts)}: final {u.d_label.split(' (')[0]} = {float(u.d(d[-1])):.3g}{unit}, "
        f"smallest {float(u.d(d.min())):.3g}{unit}"
    )
    title = f"{type(tr).__name__}: master-slave difference over {len(tr.t) - 1} periods"
    return finish(plot_differences([(t, d, head)], u, title, threshold=threshold), path, dpi=150)


class CoupledPlotMixin:
    """The ``plot`` of the master-slave results (``CoupledTrajectory``,
    ``CertifiedCoupledTrajectory``, ``CoupledCircuitTrajectory``): :func:`plot_coupled`."""

    def plot(
        self,
        path: str | os.PathLike | None = None,
        units: str = "dimensionless",
        components: Any = None,
        threshold: float | None = None,
    ):
        """``|x - y|`` against time on a log axis (:func:`precise_impact.io.figures.plot_coupled`).

        Parameters
        ----------
        path : str, os.PathLike or None, default ``None``
            Also write the figure there (``.png``, ``.pdf``, ``.svg``, atomically).
        units : {'dimensionless', 'circuit'}, default ``'dimensionless'``
            ``'circuit'``: seconds and ``|V_s1 - V_s2|`` in volts of ``components`` (default:
            the nominal design of :attr:`params`).
        components : Components or None
            The design for ``units='circuit'``.
        threshold : float or None
            Drawn as a dashed line.

        Returns
        -------
        matplotlib.figure.Figure
        """
        return plot_coupled(self, path, units=units, components=components, threshold=threshold)


def plot_certified(tr: Any, path: Any = None, units: str = "dimensionless", components: Any = None):
    """A certified trajectory: the enclosures' midpoints at ``t0 + kT`` in the phase plane
    (impacts at the labelled wall) beside ``log10`` of each enclosure's radius.

    Returns
    -------
    matplotlib.figure.Figure
    """
    check_plot_path(path)
    u = plot_units(units, params=tr.params, components=components)
    mids = np.array([[float(s[i].mid()) for i in (1, 2, 3)] for s in tr.samples])
    fig = figure(figsize=(11, 4.4), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    ax1.plot(u.x(mids[:, 1]), u.v(mids[:, 2]), ".", ms=4, color="k", label="midpoints at t0 + kT")
    draw_wall(ax1, float(tr.params.x_w), u)
    ax1.set_xlabel(u.x_label)
    ax1.set_ylabel(u.v_label)
    ax1.set_title("stroboscopic samples (enclosure midpoints)", fontsize=9)
    rad = np.asarray(tr.log10_radii(), dtype=float)
    ax2.plot(np.arange(len(rad)), rad, "o-", ms=3, lw=0.8, color="tab:blue", label="log10 radius")
    ax2.set_xlabel("forcing period k")
    ax2.set_ylabel("log10 max(rad x, rad x') (dimensionless)")
    ax2.set_title("enclosure radius (proven error bound)", fontsize=9)
    for ax in (ax1, ax2):
        ax.grid(True, lw=0.3, alpha=0.5)
    figure_legend(fig, (ax1, ax2), ncol=3)
    head = (
        f"certified, {tr.bits} bits: eta = {tr.params.decimal()['eta']}, {tr.periods} periods, "
        f"{len(tr.impacts)} impacts; largest radius 10^{np.nanmax(rad):.1f}"
    )
    if u.note:
        head += f" [{u.note}]"
    fig.suptitle(wrap_title(head, fig), fontsize=10)
    return finish(fig, path)
