"""Predictions from identified captures against the model-free estimators (issue 38), results in
benchmarks/results/predict.{json,md}.

Run:  python benchmarks/bench_predict.py [--records N] [--workers W]

Each record: the identification benchmark's chaotic capture at eta = 0.712 (``synth_capture`` of
the ideal circuit, 8 bits, 1 % noise, 100 samples per forcing period, 200 periods, seed k its own
stretch of the attractor).  On it, in one run: ``identify`` then ``predict`` (the model-based
LLE: the identified system's exponent, its uncertainty sampled from the fit's covariance), and
``timeseries_lle`` with the Kantz and Rosenstein methods on the same samples (mapped back to the
oscillator's variables with the true forcing).  Truth: the variational LLE of the true system
(``lyapunov(model='fast')``, 200,000 periods) and the paper's 0.0302; the issue's bar: within
10 % of it in >= 9 of 10 records.  The landmarks' 95 % intervals against the true system's
landmarks (``lab.budget.landmark_at`` at zeta = 0.05, a = 1, x_w = 2).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

import precise_impact as pi
from precise_impact.analysis.lyapunov.timeseries import timeseries_lle
from precise_impact.core.result import to_jsonable
from precise_impact.io.atomic import atomic_write
from precise_impact.lab.budget import landmark_at
from precise_impact.lab.identify import identify
from precise_impact.lab.predict import PREDICTED_LANDMARKS, predict
from precise_impact.lab.synth import synth_capture

OUT = Path(__file__).resolve().parent / "results"
SCENE = "fig5-chaotic-ideal"
ETA = 0.712
PAPER_LLE = 0.0302
PERIODS = 200


def capture(seed: int):
    f_hz = 1000.0 * ETA / (2 * math.pi)
    return synth_capture(SCENE, bits=8, noise=0.01, periods=PERIODS, seed=seed,
                         sample_rate=100 * f_hz, transient=100 + seed * (PERIODS + 50))  # fmt: skip


def one(seed: int) -> dict:
    cap = capture(seed)
    t0 = time.perf_counter()
    r = identify(cap, SCENE)
    t1 = time.perf_counter()
    p = predict(r, seed=seed)
    t2 = time.perf_counter()
    tr = cap.source["truth"]
    m = cap.to_mechanical(SCENE, tr["forcing_omega_rad_s"], tr["forcing_phase0_rad"])
    states = np.column_stack([m.x, m.v])
    free = {}
    for method in ("kantz", "rosenstein"):
        e = timeseries_lle(states, cap.sample_interval * m.omega, period=2 * math.pi / m.eta,
                           phase0=float(m.phase[0]), method=method)  # fmt: skip
        free[method] = {"lle": e.lle, "ci95": list(e.ci95), "status": e.status}
    return {
        "seed": seed,
        "identify_s": t1 - t0,
        "predict_s": t2 - t1,
        "lle": p.lle,
        "attractor": p.attractor,
        "landmarks": p.landmarks,
        "record_lle": tr.get("lle_record"),
        "free": free,
        "notes": p.notes,
    }


def truths() -> dict:
    r = pi.lyapunov(pi.Params.make(eta=str(ETA)), model="fast", periods=200_000, transient=1000)
    marks = {k: float(landmark_at(k, (0.05, 1.0, 2.0)).eta) for k in PREDICTED_LANDMARKS}
    return {"lle": float(r.lle), "lle_stderr": float(r.lle_stderr), "landmarks": marks}


def _within(v, truth: float, tol: float = 0.10) -> bool:
    return v is not None and math.isfinite(v) and abs(v - truth) <= tol * truth


def summary(rows: list, truth: dict) -> dict:
    lle = truth["lle"]
    out = {
        "records": len(rows),
        "model_within_10pct": sum(_within(r["lle"]["value"], lle) for r in rows),
        "model_covers": sum(r["lle"]["ci95"][0] <= lle <= r["lle"]["ci95"][1] for r in rows),
        "landmarks_cover": {
            k: sum(
                "ci95" in r["landmarks"].get(k, {})
                and r["landmarks"][k]["ci95"][0] <= v <= r["landmarks"][k]["ci95"][1]
                for r in rows
            )
            for k, v in truth["landmarks"].items()
        },
    }
    for method in ("kantz", "rosenstein"):
        out[f"{method}_within_10pct"] = sum(_within(r["free"][method]["lle"], lle) for r in rows)
    return out


def markdown(res: dict) -> str:
    t, s = res["truth"], res["summary"]
    n = s["records"]
    lines = [
        "# Predictions from identified captures (issue 38)",
        "",
        f"{n} chaotic records at eta = 0.712 ({PERIODS} periods, 8 bits, 1 % noise, 100 samples "
        "per period); truth: the true system's variational LLE "
        f"{t['lle']:.5f} +- {t['lle_stderr']:.1g} (200,000 periods; the paper: {PAPER_LLE}).",
        "",
        "| | within 10 % of the truth | 95 % interval covers it |",
        "|---|---:|---:|",
        f"| model-based (identify + predict) | {s['model_within_10pct']} / {n} | "
        f"{s['model_covers']} / {n} |",
        f"| Kantz (model-free) | {s['kantz_within_10pct']} / {n} | |",
        f"| Rosenstein (model-free) | {s['rosenstein_within_10pct']} / {n} | |",
        "",
        "Landmarks' 95 % intervals holding the true system's landmark: "
        + ", ".join(
            f"{k} ({t['landmarks'][k]:.6f}) {v} / {n}" for k, v in s["landmarks_cover"].items()
        ),
        "",
        "| seed | model LLE | 95 % | Kantz | Rosenstein | record's own LLE | identify [s] | "
        "predict [s] |",
        "|---:|---:|---|---:|---:|---:|---:|---:|",
    ]
    for r in res["rows"]:
        e, f = r["lle"], r["free"]
        own = r["record_lle"]
        lines.append(
            f"| {r['seed']} | {e['value']:.5f} | {e['ci95'][0]:.5f} .. {e['ci95'][1]:.5f} | "
            f"{f['kantz']['lle']:.5f} | {f['rosenstein']['lle']:.5f} | "
            f"{own if own is None else f'{own:.5f}'} | {r['identify_s']:.0f} | "
            f"{r['predict_s']:.0f} |"
        )
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--records", type=int, default=10)
    ap.add_argument("--workers", type=int, default=2)
    ns = ap.parse_args(argv)
    truth = truths()
    with ProcessPoolExecutor(ns.workers) as ex:
        rows = sorted(ex.map(one, range(ns.records)), key=lambda r: r["seed"])
    res = {"truth": truth, "rows": rows, "summary": summary(rows, truth)}
    text = json.dumps(to_jsonable(res), indent=1, allow_nan=False)
    atomic_write(OUT / "predict.json", lambda fh: fh.write(text), binary=False)
    atomic_write(OUT / "predict.md", lambda fh: fh.write(markdown(res)), binary=False)
    print(markdown(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
