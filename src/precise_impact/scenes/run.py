"""Run a scene on its model (or another one) and report it like ``simulate --json``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from precise_impact.core.budget import DEFAULT_MAX_TIME, check_cost, estimate_cost
from precise_impact.core.params import decimal_str
from precise_impact.core.trajectory import Trajectory
from precise_impact.io.figures import plot_differences, plot_trajectory, plot_units, save_figure
from precise_impact.io.jsonout import write_json
from precise_impact.models.circuit.coupled import simulate_coupled_circuit
from precise_impact.models.circuit.effects.catalogue import CIRCUIT_MODELS
from precise_impact.models.circuit.effects.tolerance import actual_components
from precise_impact.models.circuit.opamp import CircuitSolver
from precise_impact.models.circuit.spice import run_spice
from precise_impact.models.circuit.switched import SwitchedCapacitorSolver
from precise_impact.scenes.scene import Scene
from precise_impact.solvers.base import make_solver
from precise_impact.solvers.simulate import simulate_coupled

__all__ = ["run_scene", "scene_json"]


def run_scene(scene: Scene, model: str | None = None, max_time: float | None = None):
    """Simulate ``scene`` (optionally with another model).

    Parameters
    ----------
    scene : Scene
        A loaded scene (:func:`~precise_impact.scenes.scene.load_scene`).
    model : str or None, default ``None``
        Another model to run the scene on (effects re-validated for it).
    max_time : float or None, default ``None``
        Time budget in seconds (``None``: :data:`~precise_impact.core.budget.DEFAULT_MAX_TIME`):
        the scene's estimated cost
        (:func:`~precise_impact.core.budget.estimate_cost`) is checked against it before
        any work (:class:`~precise_impact.errors.ParameterError` naming ``max_time``, or
        ``periods`` when the samples would not fit in half the machine's memory).

    Returns
    -------
    Trajectory, CoupledTrajectory or CoupledCircuitTrajectory
        By the scene's system and model.

    See Also
    --------
    precise_impact.scenes.scene.load_scene : the scene to run.
    precise_impact.solvers.simulate.simulate : the same with explicit parameters.
    precise_impact.verification.compare.compare : score several models on the scene.

    Examples
    --------
    >>> import precise_impact as pi
    >>> tr = pi.run_scene(pi.load_scene("fig6-period3-ideal"))
    >>> tr.model, tr.periods
    ('circuit', 200)
    """
    if model is not None and model != scene.model:
        scene = scene.with_model(model)
    P = scene.precision

    cost = estimate_cost(
        "scene",
        periods=scene.periods,
        per_period=scene.per_period,
        precision=P,
        model=scene.model,
        coupled=scene.kind == "coupled",
    )
    check_cost(cost, DEFAULT_MAX_TIME if max_time is None else max_time)
    if scene.kind == "coupled":
        y0 = (scene.params.x0 + 1, scene.params.v0)  # the slave starts one unit away (paper Fig. 7)
        if scene.model == "circuit":
            design = scene.design()
            actual = actual_components(design, scene.effects)
            return simulate_coupled_circuit(
                design,
                scene.k,
                scene.periods,
                x0=scene.params.x0,
                v0=scene.params.v0,
                y0=y0,
                t0=scene.params.t0,
                per_period=scene.per_period,
                precision=P.name,
                actual=actual,
            )
        return simulate_coupled(
            scene.params,
            scene.k,
            scene.form,
            scene.periods,
            y0=y0,
            per_period=scene.per_period,
            precision=P.name,
            model=scene.model,
        )
    if scene.model not in CIRCUIT_MODELS:  # a model of the mechanics, by the registry
        solver = make_solver(scene.model, P, scene.tol)
        return solver.solve(scene.params, scene.periods, per_period=scene.per_period)
    if scene.model == "circuit":
        s = CircuitSolver(P, scene.tol, scene.effects)
    elif scene.model == "switched-capacitor":
        s = SwitchedCapacitorSolver(P, scene.tol, scene.effects)
    else:
        p = scene.params
        kw = {} if scene.tmax is None else {"tmax": float(scene.tmax)}
        res = run_spice(
            scene.design(),
            scene.effects,
            scene.periods,
            x0=p.x0,
            v0=p.v0,
            t0=p.t0,
            dense=scene.per_period > 0,
            **kw,
        )
        return res.to_trajectory()
    p = scene.params
    return s.solve(
        scene.design(), scene.periods, x0=p.x0, v0=p.v0, t0=p.t0, per_period=scene.per_period
    )


def scene_json(scene: Scene, result, model: str | None = None) -> dict[str, Any]:
    """``{"scene", "model", "effects", "samples", "impacts", "elapsed_s", ...}``."""
    model = model or scene.model
    effects = (
        sorted(scene.with_model(model).effects) if model != scene.model else sorted(scene.effects)
    )
    if isinstance(result, Trajectory):
        d = result.to_dict()
        return {
            "scene": scene.name,
            "model": model,
            "effects": effects,
            "precision": d["precision"],
            "params": d["params"],
            "digits": d["digits"],
            "samples": d["samples"],
            "impacts": d["impacts"],
            "elapsed_s": d["elapsed_s"],
        }
    P = result["precision"]
    s = P.to_str
    claim = result.claimed_digits() if hasattr(result, "claimed_digits") else None
    comps = claim.components() if claim is not None else {}
    return {
        "scene": scene.name,
        "model": model,
        "effects": effects,
        "precision": P.name,
        "params": result["params"].decimal(),
        "form": scene.form if model != "circuit" else "paper",
        "k": decimal_str(scene.k),
        **({"digits": claim.summary()} if claim is not None else {}),
        "samples": [
            {
                "period": i,
                "t": s(t),
                "x": s(x),
                "v": s(v),
                "y": s(y),
                "w": s(w),
                **{f"{n}_digits": int(c[i]) for n, c in comps.items()},
            }
            for i, (t, x, v, y, w) in enumerate(
                zip(result["t"], result["x"], result["v"], result["y"], result["w"], strict=True)
            )
        ],
        "impacts": {
            "master": [s(t) for t in result["master_impacts_t"]],
            "slave": [s(t) for t in result["slave_impacts_t"]],
        },
        "elapsed_s": result["elapsed_s"],
    }


def save_scene_outputs(
    scene: Scene, result, out: str | Path, model: str | None = None, units: str = "dimensionless"
) -> list[Path]:
    """Write ``<scene>.json`` and a phase-portrait (or |x - y|) PNG into ``out``.

    ``units='circuit'`` draws seconds and the volts of the scene's design
    (:func:`precise_impact.io.figures.plot_units`).
    """
    out = Path(out)
    scene_units(scene, units)  # a bad unit before anything is written
    obj = scene_json(scene, result, model)
    stem = f"{scene.name}_{obj['model']}"
    write_json(out / f"{stem}.json", obj, indent=None)
    fig = scene_figure(scene, result, obj, units)
    png = out / f"{stem}.png"
    save_figure(fig, png, fmt="png", dpi=110)
    return [out / f"{stem}.json", png]


def scene_units(scene: Scene, units: str):
    """The plot units of ``scene``: ``'circuit'`` from its design (components section)."""
    if units == "circuit":
        return plot_units(units, components=scene.design())
    return plot_units(units)


def scene_figure(scene: Scene, result, obj: dict, units: str = "dimensionless"):
    """A scene run's figure: a single oscillator's phase portrait and ``x(t)``, or the coupled
    pair's ``|x - y|`` against time; the title (wrapped to fit) names the scene, model and
    effects."""
    effects = ", ".join(obj["effects"]) or "none"
    title = f"{scene.name}: {obj['model']}, effects: {effects}"
    if isinstance(result, Trajectory):
        comps = scene.design() if units == "circuit" else None
        return plot_trajectory(result, units=units, components=comps, title=title)
    P = result["precision"]
    t = np.array([P.to_float(v) for v in result["t"]])
    d = np.array(
        [abs(P.to_float(x) - P.to_float(y)) for x, y in zip(result["x"], result["y"], strict=True)]
    )
    u = scene_units(scene, units)
    name, unit = u.d_label.split(" (")[0], " V" if u.name == "circuit" else ""
    head = f"k = {decimal_str(scene.k)}: final {name} = {float(u.d(d[-1])):.3g}{unit}"
    return plot_differences([(t, d, head)], u, title + " (|x - y| at t0 + kT)")
