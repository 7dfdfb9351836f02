"""Sweep benchmark (issue 8), results in benchmarks/results/sweep.{json,md}.

Run:  python benchmarks/bench_sweep.py [--quick]

A 100 x 100 map over (eta, x_w) with 1000 transient + 2000 measured periods per
point, on all local cores, three ways in one run:
* SIMD batch tiles on local worker processes (``precise-impact sweep``);
* the same tiles on a Dask LocalCluster (one single-threaded worker per core);
* a plain per-point Python loop over the scalar variational method (timed on a
  subset of points, reported as points per second).
Peak resident memory of the driver and of the worker processes is reported.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path

from precise_impact import Params, SweepSpec, run_sweep
from precise_impact.analysis.lyapunov.variational import variational_spectrum
from precise_impact.io.atomic import atomic_write

OUT = Path(__file__).resolve().parent / "results"


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="a 20 x 20 map instead of 100 x 100")
    args = ap.parse_args()
    n = 20 if args.quick else 100
    spec = SweepSpec.make(
        Params.make(),
        [("eta", "0.68", "0.82", n), ("x_w", "1.5", "2.5", n)],
        periods=2000,
        transient=1000,
        tile_size=64,
    )
    cpus = os.cpu_count() or 1
    rows = {}
    tmp = Path(tempfile.mkdtemp())
    try:
        for backend in ("processes", "dask"):
            t0 = time.perf_counter()
            s = run_sweep(
                spec,
                tmp / backend,
                workers=cpus,
                dask="local" if backend == "dask" else None,
                progress=True,
            )
            wall = time.perf_counter() - t0
            rows[backend] = {
                "points": spec.n_points,
                "wall_s": wall,
                "points_per_s": spec.n_points / wall,
                "workers": s.stats["workers"],
            }
            print(backend, rows[backend], file=sys.stderr, flush=True)
        if (tmp / "processes" / "sweep.png").exists():
            shutil.copy(tmp / "processes" / "sweep.png", OUT / "sweep_map.png")
        # plain per-point loop (one process), on a subset spread over the grid
        subset = list(range(0, spec.n_points, max(1, spec.n_points // 100)))
        variational_spectrum(
            spec.point(0), periods=10, transient=1, initial_conditions=1
        )  # compile
        t0 = time.perf_counter()
        for k in subset:
            variational_spectrum(
                spec.point(k), periods=2000, transient=1000, initial_conditions=1, segments=10
            )
        wall = time.perf_counter() - t0
        rows["plain loop (1 process)"] = {
            "points": len(subset),
            "wall_s": wall,
            "points_per_s": len(subset) / wall,
            "workers": 1,
        }
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    mem = {
        "driver_peak_rss_MiB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "largest_child_peak_rss_MiB": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,
    }
    base = rows["plain loop (1 process)"]["points_per_s"]
    result = {
        "grid": [n, n],
        "periods": 2000,
        "transient": 1000,
        "cpus": cpus,
        "runs": rows,
        "memory": mem,
    }
    OUT.mkdir(parents=True, exist_ok=True)
    text = json.dumps(result, indent=2)
    atomic_write(OUT / "sweep.json", lambda fh: fh.write(text), binary=False)
    md = [
        f"# Sweep benchmark: {n} x {n} map, 1000 + 2000 periods per point, {cpus} cores",
        "",
        "| backend | points timed | wall | points/s | vs plain loop |",
        "|---|---:|---:|---:|---:|",
    ]
    for name, r in rows.items():
        md.append(
            f"| {name} | {r['points']} | {r['wall_s']:.1f} s | {r['points_per_s']:.1f} | "
            f"{r['points_per_s'] / base:.1f}x |"
        )
    md += [
        "",
        f"Peak RSS: driver {mem['driver_peak_rss_MiB']:.0f} MiB, largest worker "
        f"{mem['largest_child_peak_rss_MiB']:.0f} MiB.",
    ]
    atomic_write(OUT / "sweep.md", lambda fh: fh.write("\n".join(md) + "\n"), binary=False)
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    sys.exit(main())
