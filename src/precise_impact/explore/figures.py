"""The explorer's Bokeh figures (orbit, bifurcation with the LLE, basins, proof) and the
functions that put one view's dict into them, in mechanical or circuit units."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from bokeh.models import ColumnDataSource, LinearColorMapper, Range1d, Span
from bokeh.palettes import Turbo256
from bokeh.plotting import figure

__all__ = [
    "basins_figure",
    "bifurcation_figures",
    "impact_figure",
    "orbit_figures",
    "proof_figure",
    "show_basins_tile",
    "show_bifurcation",
    "show_circuit",
    "show_impacts",
    "show_orbit",
    "show_certified",
]

_TOOLS = "pan,box_zoom,wheel_zoom,reset,save"
#: The circuit models the orbit view can overlay, and their lines' colours.
CIRCUIT_COLOURS = {"circuit": "#ff7f0e", "switched-capacitor": "#2ca02c"}


def orbit_figures() -> dict[str, Any]:
    """The phase portrait and x(t), with their sources (``curve``, ``strobe``, ``impacts``)
    and the wall's line."""
    src = {k: ColumnDataSource({"t": [], "x": [], "v": []}) for k in ("curve", "strobe")}
    src["impacts"] = ColumnDataSource({"t": [], "x": [], "v": []})
    for model in CIRCUIT_COLOURS:
        src[model] = ColumnDataSource({"t": [], "x": [], "v": []})
    phase = figure(height=320, width=420, tools=_TOOLS, title="phase portrait")
    phase.line("x", "v", source=src["curve"], line_width=1, color="#1f77b4")
    phase.scatter("x", "v", source=src["strobe"], size=7, color="#d62728", legend_label="strobe")
    xt = figure(height=320, width=620, tools=_TOOLS, title="x(t) and the wall")
    xt.line("t", "x", source=src["curve"], line_width=1, color="#1f77b4", legend_label="mechanics")
    for model, colour in CIRCUIT_COLOURS.items():  # the circuit models, when asked for
        xt.line("t", "x", source=src[model], line_width=1, color=colour, line_dash="dashed",
                legend_label=model)  # fmt: skip
        phase.line("x", "v", source=src[model], line_width=1, color=colour, line_dash="dashed")
    xt.scatter("t", "x", source=src["impacts"], size=5, color="black", legend_label="impacts")
    wall = Span(location=2.0, dimension="width", line_color="#555555", line_dash="dashed")
    xt.add_layout(wall)
    return {"phase": phase, "xt": xt, "sources": src, "wall": wall}


def show_orbit(figs: dict[str, Any], got: dict[str, Any], units: str) -> str:
    """Put the orbit view's dict into its figures, in ``units`` ('mechanical' or 'circuit':
    volts at node s and milliseconds, as the circuit model maps them); returns the axes'
    names."""
    scale_t, scale_x, tl, xl, vl = 1.0, 1.0, "t", "x", "v"
    c = got["circuit"]
    if units == "circuit" and c["available"]:
        scale_t, scale_x = 1e3 * c["seconds_per_unit_time"], c["volts_per_unit_x"]
        tl, xl, vl = "t [ms]", "V_s [V]", "v (dimensionless)"
    for name in ("curve", "strobe"):
        d = got[name]
        figs["sources"][name].data = {
            "t": _scaled(d["t"], scale_t), "x": _scaled(d["x"], scale_x), "v": _nums(d["v"]),
        }  # fmt: skip
    imp = got["impacts"]
    x_w = float(got["state"]["x_w"])
    figs["sources"]["impacts"].data = {
        "t": _scaled(imp["t"], scale_t), "x": np.full(len(imp["t"]), x_w * scale_x),
        "v": _nums(imp["v"]),
    }  # fmt: skip
    figs["wall"].location = x_w * scale_x
    figs["phase"].xaxis.axis_label, figs["phase"].yaxis.axis_label = xl, vl
    figs["xt"].xaxis.axis_label, figs["xt"].yaxis.axis_label = tl, xl
    figs["scale"] = (scale_t, scale_x)
    for model in CIRCUIT_COLOURS:  # a new orbit: the overlays of the old one go
        figs["sources"][model].data = {"t": [], "x": [], "v": []}
    return f"{xl} against {tl}"


def show_circuit(figs: dict[str, Any], got: dict[str, Any]) -> None:
    """A circuit model's curve over the mechanics', in the orbit's units."""
    scale_t, scale_x = figs.get("scale", (1.0, 1.0))
    c = got["curve"]
    figs["sources"][got["model"]].data = {
        "t": _scaled(c["t"], scale_t), "x": _scaled(c["x"], scale_x), "v": _nums(c["v"]),
    }  # fmt: skip


def _nums(values: list) -> np.ndarray:
    """Strict-JSON numbers back to a float array (null -> NaN, 'inf' -> inf): Bokeh sends an
    array to the browser as one binary buffer, a list as JSON text number by number."""
    try:
        return np.asarray(values, dtype=float)
    except (TypeError, ValueError):  # nulls or markers among them
        return np.array([math.nan if v is None else float(v) for v in values], dtype=float)


def _scaled(values: list, k: float) -> np.ndarray:
    return k * _nums(values)


def bifurcation_figures() -> dict[str, Any]:
    """The bifurcation diagram (drag to zoom: the range is recomputed; tap: pick eta) and the
    LLE beneath on the same eta axis."""
    src = ColumnDataSource({"eta": [], "x": []})
    lle_src = ColumnDataSource({"eta": [], "lle": [], "lo": [], "hi": []})
    rng = Range1d(0.68, 0.82)
    diag = figure(height=320, width=1060, x_range=rng, tools="xbox_zoom,tap,reset,save",
                  title="bifurcation diagram (drag to zoom, tap to pick eta)")  # fmt: skip
    diag.scatter("eta", "x", source=src, size=1.5, color="black")
    diag.yaxis.axis_label = "stroboscopic x"
    lle = figure(height=180, width=1060, x_range=rng, tools="tap,reset", title="LLE")
    lle.line("eta", "lle", source=lle_src, color="#d62728")
    lle.varea("eta", "lo", "hi", source=lle_src, fill_alpha=0.3, color="#d62728")
    lle.add_layout(Span(location=0, dimension="width", line_color="#888888"))
    lle.xaxis.axis_label, lle.yaxis.axis_label = "eta", "LLE"
    return {"diagram": diag, "lle": lle, "range": rng, "source": src, "lle_source": lle_src}


def show_bifurcation(figs: dict[str, Any], got: dict[str, Any]) -> None:
    """Put a bifurcation slice into the figures (and the x range on it)."""
    eta = _nums(got["eta"])
    rows = [_nums(r) for r in got["x"]]
    figs["source"].data = {
        "eta": np.repeat(eta, [len(r) for r in rows]),
        "x": np.concatenate(rows) if rows else np.array([]),
    }
    lle, err = _nums(got["lle"]), _nums(got["lle_stderr"])
    figs["lle_source"].data = {"eta": eta, "lle": lle, "lo": lle - err, "hi": lle + err}
    figs["range"].start, figs["range"].end = float(eta[0]), float(eta[-1])


def impact_figure() -> dict[str, Any]:
    """The impact map: phase against impact speed of successive impacts, with the map's
    singularity set (the impacts whose next flight grazes the wall)."""
    src = ColumnDataSource({"phase": [], "v": []})
    sing = ColumnDataSource({"xs": [], "ys": []})
    fig = figure(height=360, width=520, tools=_TOOLS, title="impact map and singularity set",
                 x_range=(0, 1))  # fmt: skip
    fig.scatter("phase", "v", source=src, size=2, color="#1f77b4", legend_label="impacts")
    fig.multi_line("xs", "ys", source=sing, color="#d62728", line_width=1.5,
                   legend_label="singularity set")  # fmt: skip
    fig.xaxis.axis_label, fig.yaxis.axis_label = "impact phase", "impact speed v"
    return {"figure": fig, "source": src, "singularity": sing}


def show_impacts(figs: dict[str, Any], got: dict[str, Any]) -> None:
    """An impact-map view's iterates and (when computed) its singularity curves."""
    figs["source"].data = {"phase": _nums(got["phase"]), "v": np.abs(_nums(got["v"]))}
    curves = got.get("singularity") or []
    figs["singularity"].data = {
        "xs": [_nums(c["phase"]) for c in curves], "ys": [_nums(c["v"]) for c in curves],
    }  # fmt: skip


def proof_figure() -> dict[str, Any]:
    """A certified trajectory's ball radii (log10) against time."""
    src = ColumnDataSource({"t": [], "log10_radius": []})
    fig = figure(height=300, width=620, tools=_TOOLS, title="certified: log10 ball radius")
    fig.line("t", "log10_radius", source=src, color="#9467bd")
    fig.scatter("t", "log10_radius", source=src, size=3, color="#9467bd")
    fig.xaxis.axis_label, fig.yaxis.axis_label = "t", "log10 radius"
    return {"figure": fig, "source": src}


def show_certified(figs: dict[str, Any], got: dict[str, Any]) -> None:
    """The radii of a certified trajectory's sample balls (the start's exact point left out)."""
    pts = [(t, r) for t, r in zip(got["t"], got["log10_radius"], strict=True) if r > -300]
    figs["source"].data = {"t": [t for t, _ in pts], "log10_radius": [r for _, r in pts]}


def basins_figure(n_phase: int, n_v: int, v_max: float) -> dict[str, Any]:
    """The domains of attraction on the impact surface, filled in as the rows arrive: a cell's
    colour is its orbit's period (1 .. 16), chatter / sticking / chaos above them, white where
    not yet computed; tap a cell for its orbit."""
    img = np.full((n_v, n_phase), np.nan)
    src = ColumnDataSource({"img": [img]})
    v_lo = v_max / (2 * n_v)
    fig = figure(height=360, width=520, tools="tap,reset,save", title="domains of attraction",
                 x_range=(0, 1), y_range=(0, v_max + v_lo))  # fmt: skip
    cmap = LinearColorMapper(palette=Turbo256, low=0, high=24, nan_color="white")
    fig.image(image="img", x=0, y=0, dw=1, dh=v_max + v_lo, source=src, color_mapper=cmap)
    fig.xaxis.axis_label, fig.yaxis.axis_label = "impact phase", "incoming speed v"
    return {"figure": fig, "source": src, "shape": (n_v, n_phase), "v_max": v_max}


#: A cell's colour value per kind of attractor (periodic cells take their period).
KIND_CODE = {2: 18.0, 3: 20.0, 4: 23.0}  # non-impacting, chatter + sticking, chaos


def show_basins_tile(figs: dict[str, Any], tile: dict[str, Any]) -> None:
    """One finished row of the map into the image."""
    img = np.array(figs["source"].data["img"][0], dtype=float)
    flat = img.reshape(-1)
    for i, kind, period in zip(
        tile["index"], _nums(tile["kind"]), _nums(tile["period"]), strict=True
    ):
        if kind == 1 and math.isfinite(period):
            flat[i] = period
        elif kind != 0:  # 0: the start is not on the section (left white)
            flat[i] = KIND_CODE.get(int(kind), 24.0)
    figs["source"].data = {"img": [img]}
