"""Identification of the paper's datasheet circuit run by ngspice (issue 38), results in
benchmarks/results/identify_circuit.{json,md}.

Run:  python benchmarks/bench_identify_circuit.py [--records N] [--workers W] [--model M]

Each record: ``synth_capture`` of the ``fig5-chaotic-datasheet`` scene (160 ohm switches,
comparator and flip-flop delays, break-before-make, charge injection, 1 % / 5 % parts) run by
ngspice (``model='spice'``; ``--model switched-capacitor`` runs the package's own model of the
same circuit) through the issue's scope model (8 bits, 1 % noise, 100 samples per forcing
period, 200 periods), each seed its own stretch of the attractor.  ``identify`` under both
impact laws; each estimate against the circuit's own effective system (``effective_system``:
the exact rational matrix of the circuit between switchings, not a fit): ``eta`` and ``zeta``
(the drawn zeta is 0.05; the switches' on-resistance makes it 0.0659), ``R`` against 1.

Then the period-3 window, in forcing frequency: where the circuit puts it (the package's
switched-capacitor model swept by continuation, ``lab.predict.period3_window``, its two ends
confirmed by ngspice continued from the model's orbit across each end) and where each
identified system puts it (the same sweep of the closed form under the identified impact law,
``affine_runner``; under the restitution law with R = 1, as ``predict`` does).

The circuit as the model itself simulates it between impacts, a second reference beside
``effective_system``: a free decay of the model (forcing off, from ``x = 1``, no impacts)
fitted with a damped sinusoid (``free_decay``).  ngspice's differs from the effective system
by its op-amp U2 (a 3 MHz pole, there for the slew) and its integration error at TMAX 10 us.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from fractions import Fraction
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

from precise_impact.core.result import to_jsonable
from precise_impact.io.atomic import atomic_write
from precise_impact.lab.identify import IMPACT_LAWS, identify
from precise_impact.lab.predict import (
    affine_runner,
    circuit_runner,
    period3_window,
    strobe_period,
)
from precise_impact.lab.synth import synth_capture
from precise_impact.models.circuit.spice import SpiceSolver
from precise_impact.models.circuit.switched import SwitchedCapacitorSolver, effective_system
from precise_impact.scenes.scene import load_scene
from precise_impact.verification.metrics import scene_for_model

OUT = Path(__file__).resolve().parent / "results"
SCENE = "fig5-chaotic-datasheet"
SHOWN = ("eta", "zeta", "a", "x_w", "R", "kappa")
DRAWN_ETA = Fraction("0.712")


def _solver(sc, model: str):
    if model == "spice":
        return SpiceSolver(effects=scene_for_model(sc, "spice")[0].effects)
    return SwitchedCapacitorSolver(effects=sc.effects)


def free_decay(model: str, periods: int = 12) -> dict:
    """``{'eta', 'zeta', 'rms'}`` of the model's linear dynamics between impacts: its run with
    the forcing off from ``x = 1`` (below the wall: no impacts), every accepted time point,
    fitted with ``exp(-zeta w t) (A cos(w_d t) + B sin(w_d t))`` (``eta`` is the drawn
    forcing's ``Omega`` over the fitted ``w``)."""
    sc = load_scene(SCENE)
    design = dataclasses.replace(sc.design(), V_A=Fraction(0))
    tr = _solver(sc, model).solve(design, periods, per_period=200, x0="1", v0="0", t0="0")
    t, x = np.asarray(tr.dense_t, float), np.asarray(tr.dense_x, float)

    def residual(p):
        w, z, a, b = p
        wd = w * math.sqrt(1 - z * z)
        return np.exp(-z * w * t) * (a * np.cos(wd * t) + b * np.sin(wd * t)) - x

    fit = least_squares(residual, [1.0, 0.05, 1.0, 0.0], x_scale=[1e-3, 1e-3, 1.0, 1.0])
    w, z = fit.x[:2]
    return {"eta": float(DRAWN_ETA) / float(w), "zeta": float(z), "rms": float(np.std(fit.fun))}


def one(seed: int, model: str, own: dict) -> dict:
    sc = load_scene(SCENE)
    eff = effective_system(sc.design(), sc.effects)
    truth = {"eta": float(eff["eta"]), "zeta": float(eff["zeta"]), "R": 1.0}
    t0 = time.perf_counter()
    cap = synth_capture(sc, model=model, bits=8, noise=0.01, periods=200, seed=seed,
                        transient=100 + seed * 250)  # fmt: skip
    row = {"seed": seed, "model": model, "synth_s": time.perf_counter() - t0, "truth": truth}
    for law in IMPACT_LAWS:
        t0 = time.perf_counter()
        r = identify(cap, sc, impact_law=law)
        row[law] = {
            "seconds": time.perf_counter() - t0,
            "value": {k: r.value(k) for k in SHOWN if k in r.parameters},
            "stderr": {k: r.stderr(k) for k in SHOWN if k in r.parameters},
            "z": {k: (r.value(k) - v) / r.stderr(k) for k, v in truth.items()},
            "z_own": {k: (r.value(k) - own[k]) / r.stderr(k) for k in ("eta", "zeta")},
            "ratio_x": r.noise["ratio_x"],
            "ratio_v": r.noise["ratio_v"],
            "impacts": r.impacts["total"],
            "left_out": len(r.impacts["segments_left_out"]),
            "window_hz": _identified_window(r, law),
            "Omega_rad_s": r.record["Omega_rad_s"],
        }
    return row


def _identified_window(r, law: str) -> list | None:
    """The identified system's period-3 window [Hz]: its eta ends times the measured forcing's
    ``Omega / eta`` (the identified natural frequency)."""
    v = {k: r.value(k) for k in ("zeta", "a", "x_w")}
    v.update(R=r.value("R"), kappa=r.value("kappa")) if law == "affine" else v.update(R=1.0)
    w = period3_window(affine_runner(v))
    hz = r.record["Omega_rad_s"] / r.value("eta") / (2 * math.pi)
    return None if w is None else [w["low"] * hz, w["high"] * hz]


def circuit_window() -> dict:
    """The circuit's window: the switched-capacitor model's sweep [drawn eta], then ngspice
    continued from the model's orbit two steps inside each end, to two steps outside it."""
    sc = load_scene(SCENE)
    design = sc.design()
    run, omega = circuit_runner(_solver(sc, "switched-capacitor"), design, DRAWN_ETA)
    w = period3_window(run)
    spice, _ = circuit_runner(_solver(sc, "spice"), design, DRAWN_ETA)
    checks = {}
    for end, sign in (("low", -1), ("high", 1)):
        inside = w[end] - sign * 2.5 * w["step"]
        outside = w[end] + sign * 1.5 * w["step"]
        xs, state = _orbit_state(run, w, inside)
        xs_in, state = spice(inside, state, 150)
        xs_out, _ = spice(outside, state, 150)
        checks[end] = {"inside_eta": inside, "inside_period": strobe_period(xs_in),
                       "outside_eta": outside, "outside_period": strobe_period(xs_out)}  # fmt: skip
    hz = omega / (2 * math.pi)
    return {"drawn_eta": w, "hz": [w["low"] * hz, w["high"] * hz], "ngspice": checks}


def _orbit_state(run, w: dict, eta: float):
    """The model's period-3 state at ``eta`` (inside the window), by continuation from its
    middle (started from rest there)."""
    mid = 0.5 * (w["low"] + w["high"])
    xs, state = run(mid, (0.0, 0.0), 400)
    n = int(round(abs(eta - mid) / w["step"]))
    for k in range(1, n + 1):
        xs, state = run(mid + (eta - mid) * k / n, state, 150)
    return xs, state


def markdown(res: dict) -> str:
    rows, eff = res["rows"], res["rows"][0]["truth"]
    lines = [
        "# Identification of the datasheet circuit (issue 38)",
        "",
        f"{len(rows)} records of `{SCENE}` run by {res['model']}, 200 periods, 8 bits, 1 % "
        "noise, 100 samples per period.  The circuit's effective system (`effective_system`): "
        f"eta {eff['eta']:.5f}, zeta {eff['zeta']:.5f}, R 1.  z = (estimate - effective) / "
        "standard error; the 95 % interval holds the effective value where |z| <= 1.96.",
        "",
        "| seed | law | eta | z | zeta | z | R | z | kappa | residuals x / v |",
        "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        for law in IMPACT_LAWS:
            d = r[law]
            v, s, z = d["value"], d["stderr"], d["z"]
            kappa = f"{v['kappa']:.4f} +- {s['kappa']:.4f}" if "kappa" in v else "-"
            lines.append(
                f"| {r['seed']} | {law} | {v['eta']:.5f} +- {s['eta']:.5f} | {z['eta']:+.1f} | "
                f"{v['zeta']:.5f} +- {s['zeta']:.5f} | {z['zeta']:+.1f} | "
                f"{v['R']:.4f} +- {s['R']:.4f} | {z['R']:+.1f} | {kappa} | "
                f"{d['ratio_x']:.3f} / {d['ratio_v']:.3f} |"
            )
    lines += ["", "| law | " + " | ".join(f"{k} covered / mean z" for k in ("eta", "zeta", "R"))
              + " |", "|---|---:|---:|---:|"]  # fmt: skip
    for law in IMPACT_LAWS:
        cells = []
        for k in ("eta", "zeta", "R"):
            z = np.array([r[law]["z"][k] for r in rows])
            cells.append(f"{int(np.sum(np.abs(z) <= 1.96))} of {len(z)} / {np.mean(z):+.2f}")
        lines.append(f"| {law} | " + " | ".join(cells) + " |")
    own = res["free_decay"]
    lines += [
        "",
        f"The circuit as {res['model']} simulates it between impacts (its free decay, fitted: "
        f"eta {own['eta']:.6f}, zeta {own['zeta']:.6f}; the effective system: eta "
        f"{eff['eta']:.6f}, zeta {eff['zeta']:.6f}); z against it:",
        "",
        "| law | eta covered / mean z | zeta covered / mean z |",
        "|---|---:|---:|",
    ]
    for law in IMPACT_LAWS:
        cells = []
        for k in ("eta", "zeta"):
            z = np.array([r[law]["z_own"][k] for r in rows])
            cells.append(f"{int(np.sum(np.abs(z) <= 1.96))} of {len(z)} / {np.mean(z):+.2f}")
        lines.append(f"| {law} | " + " | ".join(cells) + " |")
    w = res["window"]
    lines += [
        "",
        "The period-3 window [Hz of the forcing]:",
        "",
        "| where | low | high |",
        "|---|---:|---:|",
        f"| the circuit (switched-capacitor model swept, steps of {w['drawn_eta']['step']} in "
        f"drawn eta) | {w['hz'][0]:.2f} | {w['hz'][1]:.2f} |",
    ]
    for law in IMPACT_LAWS:
        ends = np.array([r[law]["window_hz"] for r in rows if r[law]["window_hz"]])
        if len(ends):
            m, sd = ends.mean(axis=0), ends.std(axis=0, ddof=1) if len(ends) > 1 else [0, 0]
            lines.append(f"| identified, {law} law (mean +- sd of {len(ends)} records) | "
                         f"{m[0]:.2f} +- {sd[0]:.2f} | {m[1]:.2f} +- {sd[1]:.2f} |")  # fmt: skip
    for end, c in w["ngspice"].items():
        lines.append(
            f"\nngspice across the {end} end: period {c['inside_period']} at drawn eta "
            f"{c['inside_eta']:.5f}, period {c['outside_period'] or 'none (not 1-3)'} at "
            f"{c['outside_eta']:.5f}."
        )
    lines += ["", f"Synthesis {np.median([r['synth_s'] for r in rows]):.0f} s per record "
              f"(median); {res['seconds']:.0f} s in all."]  # fmt: skip
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--records", type=int, default=5)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--model", default="spice", choices=("spice", "switched-capacitor"))
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    own = free_decay(a.model)
    with ProcessPoolExecutor(a.workers) as ex:
        futures = [ex.submit(one, s, a.model, own) for s in range(a.records)]
        for k, _ in enumerate(as_completed(futures), 1):  # progress: one line per record
            print(f"{k}/{a.records} records, {time.perf_counter() - t0:.0f} s", file=sys.stderr)
        rows = [f.result() for f in futures]
    print("the circuit's window ...", file=sys.stderr)
    window = circuit_window()
    res = {"model": a.model, "rows": rows, "window": window, "free_decay": own,
           "seconds": time.perf_counter() - t0}  # fmt: skip
    OUT.mkdir(exist_ok=True)
    stem = "identify_circuit" if a.model == "spice" else "identify_switched"
    text = json.dumps(to_jsonable(res), indent=1) + "\n"
    atomic_write(OUT / f"{stem}.json", lambda fh: fh.write(text), binary=False)
    md = markdown(res)
    atomic_write(OUT / f"{stem}.md", lambda fh: fh.write(md), binary=False)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
