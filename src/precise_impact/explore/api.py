"""The explorer's computations, one function per view: a :class:`~.state.State` in, a dict of
strict-JSON values out, naming the command line and the Python call that give the same numbers
(``docs/guide/explore.rst``)."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from precise_impact.analysis.bifurcation import bifurcation as _bifurcation
from precise_impact.analysis.impact_surface.basins import basins as _basins
from precise_impact.analysis.impact_surface.impact_map import impact_map as _impact_map
from precise_impact.analysis.impact_surface.singularity import singularity_set
from precise_impact.analysis.lyapunov import lyapunov
from precise_impact.analysis.orbits import prove_orbit
from precise_impact.analysis.periodicity import detect_period
from precise_impact.errors import ParameterError
from precise_impact.explore.state import CIRCUIT_MODELS, DENSE_PER_PERIOD, State
from precise_impact.io.jsonout import finite_or_marker
from precise_impact.models.circuit.components import nominal_components
from precise_impact.solvers.certified.single import certify as _certify
from precise_impact.solvers.simulate import simulate

__all__ = [
    "CSV_VIEWS",
    "VIEW_FUNCTIONS",
    "basins",
    "bifurcation",
    "certified",
    "circuit",
    "lle",
    "orbit",
    "proof",
    "run_view",
    "view_csv",
]

#: Most stroboscopic samples a period is looked for in (the last ones of the run).
PERIOD_WINDOW = 128


def _floats(a: Any) -> list:
    """Numbers as strict-JSON floats (NaN -> null, infinities -> 'inf' / '-inf'); an all-finite
    array in one ``tolist`` (the orbit's 13,000 curve points: 50 ms one by one)."""
    arr = np.asarray(a, dtype=float).ravel()
    if np.all(np.isfinite(arr)):
        return arr.tolist()
    return [finite_or_marker(float(x)) for x in arr]


def _head(state: State, view: str, **args: Any) -> dict[str, Any]:
    """What every view's dict starts with: the view, the state, the command and the call."""
    return {
        "view": view,
        "state": state.to_query(),
        "args": args,
        "command": state.command(view, **args),
        "python": state.python(view, **args),
    }


def orbit(state: State, full: bool = True) -> dict[str, Any]:
    """The orbit at the state's parameters: the stroboscopic samples and the curves after the
    transient, the impacts, the period the samples repeat with (0: none within
    :data:`PERIOD_WINDOW`), the digits claimed, and (``full``) the run's own ``to_dict()``
    (the page asks for it only when its JSON is downloaded: the samples as exact decimals cost
    two thirds of the view's time)."""
    n = state.transient + state.periods
    traj = simulate(
        state.params, n, model=state.model, precision=state.precision,
        per_period=DENSE_PER_PERIOD,
    )  # fmt: skip
    x, v = np.asarray(traj.x, dtype=float), np.asarray(traj.v, dtype=float)
    t = np.asarray(traj.t, dtype=float)
    k = state.transient
    t_start = float(t[k])
    dense = np.asarray(traj.dense_t, dtype=float) >= t_start
    hits = np.asarray(traj.impacts_t, dtype=float) >= t_start
    if full:
        result = traj.to_dict()
        result.pop("elapsed_s", None)
        digits = result["digits"]
    else:
        result, digits = None, _digits(traj)
    out = _head(state, "orbit")
    out.update(
        strobe={"t": _floats(t[k:]), "x": _floats(x[k:]), "v": _floats(v[k:])},
        curve={
            "t": _floats(np.asarray(traj.dense_t, dtype=float)[dense]),
            "x": _floats(np.asarray(traj.dense_x, dtype=float)[dense]),
            "v": _floats(np.asarray(traj.dense_v, dtype=float)[dense]),
        },
        impacts={
            "t": _floats(np.asarray(traj.impacts_t, dtype=float)[hits]),
            "v": _floats(np.asarray(traj.impacts_v_before, dtype=float)[hits]),
        },
        period=_period(x[k:], v[k:]),
        impacts_per_period=int(hits.sum()) / state.periods,
        digits=digits,
        circuit=circuit_units(state),
    )
    if full:
        out["result"] = result
    return out


def circuit(state: State, model: str = "circuit") -> dict[str, Any]:
    """The orbit on one of the circuit models (:data:`~.state.CIRCUIT_MODELS`: the op-amp
    circuit, the switched-capacitor circuit) from the same start, its curve after the
    transient in the mechanics' units, and how far its stroboscopic samples lie from the
    mechanics' (the compiled engine's float64 run; a chaotic orbit's difference grows to O(1)
    as the two part)."""
    if model not in CIRCUIT_MODELS:
        raise ParameterError("model", model, "one of " + ", ".join(CIRCUIT_MODELS))
    n = state.transient + state.periods
    traj = simulate(state.params, n, model=model, per_period=DENSE_PER_PERIOD)
    mech = simulate(state.params, n, model="fast")
    k = state.transient
    x, v = np.asarray(traj.x, dtype=float), np.asarray(traj.v, dtype=float)
    dx = np.abs(x - np.asarray(mech.x, dtype=float))
    dense_t = np.asarray(traj.dense_t, dtype=float)
    keep = dense_t >= float(np.asarray(traj.t, dtype=float)[k])
    out = _head(state, "circuit", model=model)
    out.update(
        model=model,
        curve={
            "t": _floats(dense_t[keep]),
            "x": _floats(np.asarray(traj.dense_x, dtype=float)[keep]),
            "v": _floats(np.asarray(traj.dense_v, dtype=float)[keep]),
        },
        strobe={"x": _floats(x[k:]), "v": _floats(v[k:])},
        max_dx_transient=finite_or_marker(float(np.max(dx[: k + 1]))),
        max_dx_shown=finite_or_marker(float(np.max(dx[k:]))),
    )
    result = traj.to_dict()  # the command's --json (the samples as exact decimals)
    result.pop("elapsed_s", None)
    out["result"] = result
    return out


def _digits(traj: Any) -> dict[str, Any]:
    """The digits the run claims: the summary ``to_dict()`` puts beside the samples."""
    return traj.claimed_digits().summary()


def _period(x: np.ndarray, v: np.ndarray) -> int:
    """The period the last samples repeat with (0: none found).  ``detect_period`` compares
    the last ``2 max_period`` samples with those ``p`` before, so a short run looks for
    periods up to a third of its samples."""
    x, v = x[-PERIOD_WINDOW:], v[-PERIOD_WINDOW:]
    top = min(32, len(x) // 3)
    return int(detect_period(x, v, max_period=top)) if top >= 1 else 0


def circuit_units(state: State) -> dict[str, Any]:
    """How the orbit reads in the paper's circuit (R = 10 kOhm, C = 100 nF, 1 V per unit of
    displacement): seconds per unit of time ``1 / omega`` and the node voltage
    ``V_s = -x V_unit``, as :class:`~precise_impact.models.circuit.opamp.CircuitSolver` maps
    them; ``None`` where the design has no circuit (``zeta = 0``)."""
    if state.params.zeta <= 0:
        return {"available": False, "why": "the circuit needs zeta > 0 (R6 = R2 / (2 zeta))"}
    comp = nominal_components(state.params)
    return {
        "available": True,
        "seconds_per_unit_time": 1.0 / float(comp.omega()),
        "volts_per_unit_x": -float(comp.V_unit),
        "components": comp.decimal(),
    }


def lle(state: State) -> dict[str, Any]:
    """The largest Lyapunov exponent on the compiled engine (variational, with the saltation
    matrices) with its error bar: ``lyapunov(params, model='fast')``, the CLI's ``lle``."""
    res = lyapunov(state.params, model="fast")
    result = res.to_dict()
    result.pop("elapsed_s", None)
    out = _head(state, "lle")
    out.update(lle=finite_or_marker(res.lle), stderr=finite_or_marker(res.lle_stderr))
    out["result"] = result
    return out


def bifurcation(state: State) -> dict[str, Any]:
    """The stroboscopic x against eta over the state's range, with the LLE beneath: the
    CLI's ``bifurcation`` (compiled engine, one process)."""
    axis = ("eta", state.eta_min, state.eta_max, state.n)
    res = _bifurcation(
        state.params, axis, periods=state.bif_periods, transient=state.bif_transient,
        workers=1, progress=False,
    )  # fmt: skip
    out = _head(state, "bifurcation")
    out.update(
        eta=_floats(res.eta),
        x=[_floats(row) for row in np.asarray(res.x, dtype=float)],
        lle=_floats(res.lle),
        lle_stderr=_floats(res.lle_stderr),
    )
    return out


def impact_map(
    state: State, phase: float, v: float, n: int = 200, singularity: bool = False
) -> dict[str, Any]:
    """``n`` impacts of the orbit leaving the wall at forcing ``phase`` (in [0, 1)) with
    speed ``v``: the impact map's iterates, on the compiled engine; with ``singularity`` the
    map's singularity set too (the impacts whose next flight grazes the wall: where the map is
    discontinuous), its physical parts as curves of (phase, v)."""
    events = _impact_map(state.params, phase, v, n, engine="fast")
    args: dict[str, Any] = {"phase": phase, "v": v, "n": n}
    if singularity:
        args["singularity"] = True
    out = _head(state, "impact-map", **args)
    out.update(
        phase=_floats([e.phase for e in events]),
        v=_floats([e.v for e in events]),
        kind=[e.kind for e in events],
    )
    if singularity:
        out["singularity"] = _singularity_curves(state)
    return out


def _singularity_curves(state: State) -> list[dict[str, list]]:
    """The singularity set's physical runs of points, one curve each (a curve breaks where a
    branch leaves its physical part, and where its phase wraps from 1 to 0)."""
    curves = []
    for b in singularity_set(state.params).branches:
        run: list[tuple[float, float]] = []
        for ph, v, ok in zip(b["phase"], b["v"], b["physical"], strict=True):
            wraps = bool(run) and abs(float(ph) - run[-1][0]) > 0.5
            if run and (not ok or wraps):
                curves.append(run)
                run = []
            if ok:
                run.append((float(ph), float(v)))
        if run:
            curves.append(run)
    return [{"phase": _floats([p for p, _ in c]), "v": _floats([v for _, v in c])} for c in curves]


def certified(state: State, periods: int = 100) -> dict[str, Any]:
    """The trajectory certified by ball arithmetic for ``periods`` forcing periods (bits chosen
    for radius <= 1e-30): each sample's ball radii against time (``certify``)."""
    res = _certify(state.params, periods, progress=False)
    d = res.to_dict()
    out = _head(state, "certified", periods=periods)
    out.update(
        t=[float(s["t"]) for s in d["samples"]],
        log10_radius=[
            max(math.log10(max(float(s["x_rad"]), float(s["v_rad"]), 1e-300)), -300.0)
            for s in d["samples"]
        ],  # fmt: skip
        bits=d["bits"],
        growth_digits_per_period=d["growth_digits_per_period"],
    )
    return out


def proof(state: State, period: int) -> dict[str, Any]:
    """The period-``period`` orbit proven by the Krawczyk operator in ball arithmetic, its
    balls' radii and its proven stability (``prove_orbit``, the CLI's ``orbit --prove``)."""
    transient = max(state.transient, 500)
    res = prove_orbit(state.params, period, transient=transient)
    out = _head(state, "proof", period=period, transient=transient)
    out["result"] = res.to_dict()
    return out


#: The views the JSON API serves: name -> function of the state (and its own arguments).
VIEW_FUNCTIONS: dict[str, Callable[..., dict[str, Any]]] = {
    "orbit": orbit,
    "lle": lle,
    "circuit": circuit,
    "bifurcation": bifurcation,
    "impact-map": impact_map,
    "proof": proof,
    "certified": certified,
}


def run_view(view: str, state: State, **kwargs: Any) -> dict[str, Any]:
    """``VIEW_FUNCTIONS[view](state, **kwargs)``."""
    return VIEW_FUNCTIONS[view](state, **kwargs)


def basins(
    state: State,
    n_phase: int = 60,
    n_v: int = 40,
    v_max: float = 4.0,
    on_tile: Callable[[dict[str, Any]], None] | None = None,
    dask: str | None = None,
) -> dict[str, Any]:
    """Domains of attraction on the impact surface (phase in [0, 1), incoming speed in
    ``(0, v_max]``) on an ``n_phase x n_v`` grid, one row per tile: ``on_tile`` receives each
    row's cells (flat indices, kind, period) as it finishes; the dict holds the labels.  With
    ``dask`` (a scheduler's ``tcp://HOST:PORT``) the rows run on that cluster."""
    grid = ((0.0, 1.0, n_phase), (v_max / (2 * n_v), v_max, n_v))

    def tile(t: int, arrays: dict) -> None:
        if on_tile is not None:
            on_tile({
                "index": [int(i) for i in arrays["index"]],
                "kind": _floats(arrays["kind"]),
                "period": _floats(arrays["period"]),
            })  # fmt: skip

    res = _basins(
        state.params, grid, transient=max(state.transient, 100), tile_size=n_phase,
        progress=False, on_tile=tile, dask=dask,
    )  # fmt: skip
    out = _head(state, "basins", n_phase=n_phase, n_v=n_v, v_max=v_max)
    out.update(
        labels=[[int(x) for x in row] for row in res.labels],
        attractors=res.to_dict().get("attractors"),
        axes=res.axes,
    )
    return out


VIEW_FUNCTIONS["basins"] = basins


def _orbit_rows(got: dict[str, Any]) -> Any:
    yield ("kind", "t", "x", "v")
    for kind in ("strobe", "curve"):
        d = got[kind]
        yield from ((kind, t, x, v) for t, x, v in zip(d["t"], d["x"], d["v"], strict=True))
    imp = got["impacts"]
    x_w = got["state"]["x_w"]
    yield from (("impact", t, x_w, v) for t, v in zip(imp["t"], imp["v"], strict=True))


def _bifurcation_rows(got: dict[str, Any]) -> Any:
    yield ("eta", "x", "lle", "lle_stderr")
    for eta, xs, lle, err in zip(got["eta"], got["x"], got["lle"], got["lle_stderr"], strict=True):
        yield from ((eta, x, lle, err) for x in xs)


def _impact_map_rows(got: dict[str, Any]) -> Any:
    yield ("phase", "v", "kind")
    yield from zip(got["phase"], got["v"], got["kind"], strict=True)


def _centres(axis: list) -> list[float]:
    """An axis ``[name, lo, hi, n]``'s cell centres (as the scan computes them)."""
    _, lo, hi, n = axis
    return [lo + (i + 0.5) * (hi - lo) / n for i in range(n)]


def _basins_rows(got: dict[str, Any]) -> Any:
    yield ("phase", "v", "label")
    phases, speeds = (_centres(a) for a in got["axes"])
    for v, row in zip(speeds, got["labels"], strict=True):
        yield from ((p, v, label) for p, label in zip(phases, row, strict=True))


#: The views a page offers as CSV, and their rows (a header first).
CSV_VIEWS: dict[str, Callable[[dict[str, Any]], Any]] = {
    "orbit": _orbit_rows,
    "bifurcation": _bifurcation_rows,
    "impact-map": _impact_map_rows,
    "basins": _basins_rows,
}


def view_csv(got: dict[str, Any]) -> str:
    """A view's numbers as CSV text (a header row, then one row per point; floats as their
    shortest round-trip text, a missing value empty)."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    for row in CSV_VIEWS[got["view"]](got):
        w.writerow(["" if x is None else x for x in row])
    return out.getvalue()
