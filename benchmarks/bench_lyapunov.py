"""Lyapunov benchmarks (issue 3), results in benchmarks/results/lyapunov.{json,md}.

Run:  python benchmarks/bench_lyapunov.py [--quick] [--only-bifurcation]

``--only-bifurcation`` times the diagram again (median of 3 runs after a warm-up) and keeps the
LLE rows of the stored lyapunov.json (the diagram's engine changed: heyoka -> fast).

* LLE at eta = 0.712 to +-0.0005 in float64, both methods (median of runs after a
  warm-up that compiles the integrators; compile time excluded).
* A 400-value bifurcation diagram with LLE, 1000 transient + 2000 measured periods
  each, on all cores (target < 20 s on 2 cores).
* float128 and multiprecision LLE cost per period, side by side with float64.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

from precise_impact import Params, bifurcation, lyapunov
from precise_impact.io.atomic import atomic_write

OUT = Path(__file__).resolve().parent / "results"


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--only-bifurcation", action="store_true")
    args = ap.parse_args()
    p = Params.make(eta="0.712")
    rows = []
    if args.only_bifurcation:
        rows = json.loads((OUT / "lyapunov.json").read_text())["lle"]
    for method in () if args.only_bifurcation else ("variational", "two-trajectory"):
        lyapunov(p, method, periods=100, transient=10)  # compile
        times, res = [], None
        for _ in range(2 if args.quick else 5):
            t0 = time.perf_counter()
            res = lyapunov(p, method)
            times.append(time.perf_counter() - t0)
        rows.append(
            {
                "what": f"LLE eta=0.712 float64, {method}, default run",
                "lle": res.lle,
                "stderr": res.stderr,
                "periods": res.periods + res.transient * getattr(res, "initial_conditions", 1),
                "median_s": statistics.median(times),
            }
        )
        print(rows[-1], file=sys.stderr)
    base_per_period = rows[0]["median_s"] / rows[0]["periods"]
    for prec, periods, transient in (
        ()
        if args.only_bifurcation
        else (
            ("longdouble", 2000, 100),
            ("float128", 400, 50),
            ("mp:128", 100, 20),
            ("mp:256", 100, 20),
        )
    ):
        lyapunov(
            p, "variational", periods=4, transient=1, initial_conditions=1, precision=prec
        )  # compile
        t0 = time.perf_counter()
        res = lyapunov(
            p,
            "variational",
            periods=periods,
            transient=transient,
            initial_conditions=1,
            precision=prec,
        )
        el = time.perf_counter() - t0
        rows.append(
            {
                "what": f"LLE variational {prec}",
                "lle": res.lle,
                "stderr": res.stderr,
                "periods": periods + transient,
                "median_s": el,
                "per_period_vs_float64": (el / (periods + transient)) / base_per_period,
            }
        )
        print(rows[-1], file=sys.stderr)
    n = 100 if args.quick else 400
    bif_times = []
    for _ in range(4 if args.only_bifurcation else 1):  # the first of 4: a warm-up
        t0 = time.perf_counter()
        bif = bifurcation(
            Params.make(), "0.68", "0.82", n, periods=2000, transient=1000, progress=False
        )
        bif_times.append(time.perf_counter() - t0)
    bif_s = statistics.median(bif_times[1:]) if args.only_bifurcation else bif_times[0]
    result = {
        "lle": rows,
        "bifurcation": {
            "values": n,
            "periods": 2000,
            "transient": 1000,
            "workers": bif.workers,
            "wall_s": bif_s,
            "runs_s": bif_times,
        },
        "targets": {
            "LLE +-0.0005 float64 < 0.5 s": rows[0]["median_s"] < 0.5
            and rows[0]["stderr"] <= 0.0005,
            "400-value bifurcation < 20 s on 2 cores": (n == 400 and bif_s < 20.0)
            if n == 400
            else None,
        },
        "cpus": os.cpu_count(),
    }
    OUT.mkdir(parents=True, exist_ok=True)
    text = json.dumps(result, indent=2)
    atomic_write(OUT / "lyapunov.json", lambda fh: fh.write(text), binary=False)
    md = [
        "# Lyapunov benchmarks (eta = 0.712)",
        "",
        "| run | LLE | stderr | periods | time | per period vs float64 |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        md.append(
            f"| {r['what']} | {r['lle']:.5f} | {r['stderr']:.5f} | {r['periods']} | "
            f"{r['median_s']:.3f} s | {r.get('per_period_vs_float64', 1.0):.1f}x |"
        )
    md += [
        "",
        f"Bifurcation diagram, {n} values x (1000 + 2000) periods with LLE, {bif.workers} workers: "
        f"{bif_s:.1f} s",
        "",
    ]
    md += [
        f"- {k}: {'met' if v else ('MISSED' if v is not None else 'n/a (quick)')}"
        for k, v in result["targets"].items()
    ]
    atomic_write(OUT / "lyapunov.md", lambda fh: fh.write("\n".join(md) + "\n"), binary=False)
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    sys.exit(main())
