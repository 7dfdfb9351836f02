"""The fast engine against the heyoka paths, side by side in one run.

Jobs (float64, eta = 0.712 chaotic unless said; medians of ``--rounds`` after warm-up):

* ``simulate``: 200 chaotic periods, ``FastSolver().solve`` against a reused
  ``HeyokaSolver`` and the public ``simulate()``;
* ``lle``: 4 x 6000 periods after 1000 (standard error ~ +-0.0005), ``method='fast'``
  against ``method='variational'``;
* ``sweep``: points per second of ``run_sweep`` on the README's 100 x 100 map
  (eta 0.68..0.82 x x_w 1.5..2.5, 2000 + 1000 periods per point) on ``--workers``
  processes: the whole map with the fast engine, ``--heyoka-points`` of it with the heyoka
  engine (points/s is per point: extrapolated to the map, and stated so);
* ``cli``: a cold one-shot ``precise-impact lle`` in a fresh process (numba's on-disk cache
  present, and emptied) against the same with ``--method variational``.

Results: ``benchmarks/results/fast.{json,md}``; ratios are heyoka / fast.

Run:  python benchmarks/bench_fast.py [--rounds 5] [--workers 2]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

OUT = Path(__file__).resolve().parent / "results"


def median_time(fn, rounds: int) -> float:
    fn()
    times = []
    for _ in range(rounds):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def cli_time(args: list[str], env: dict | None = None) -> float:
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "precise_impact", *args], check=True, capture_output=True,
                   env=env or dict(os.environ))
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--heyoka-points", type=int, default=128)
    args = ap.parse_args()
    import numpy as np

    from precise_impact import HeyokaSolver, Params, SweepSpec, lyapunov, run_sweep, simulate
    from precise_impact.solvers.fast import FastSolver

    p = Params.make(eta="0.712")
    rows = {}
    fast, hey = FastSolver(), HeyokaSolver("float64")
    rows["simulate 200 periods"] = {
        "fast_s": median_time(lambda: fast.solve(p, 200), args.rounds * 20),
        "heyoka_solver_s": median_time(lambda: hey.solve(p, 200), args.rounds * 4),
        "heyoka_simulate_s": median_time(lambda: simulate(p, 200), args.rounds * 4),
    }
    a = fast.solve(p, 50)
    b = hey.solve(p, 50)
    rows["simulate 200 periods"]["max_diff_to_period_50"] = float(np.max(np.abs(np.asarray(a.x) - np.asarray(b.x, float))))
    print(rows, flush=True)
    lf = lyapunov(p, "fast", periods=24000, transient=1000)
    lv = lyapunov(p, "variational", periods=24000, transient=1000)
    rows["lle 4 x 6000 periods"] = {
        "fast_s": median_time(lambda: lyapunov(p, "fast", periods=24000, transient=1000), args.rounds),
        "heyoka_variational_s": median_time(lambda: lyapunov(p, "variational", periods=24000, transient=1000), 1),
        "fast_lle": lf.lle, "fast_stderr": lf.stderr, "variational_lle": lv.lle, "variational_stderr": lv.stderr,
    }
    print(rows, flush=True)
    base = Params.make()
    axes = [("eta", "0.68", "0.82", 100), ("x_w", "1.5", "2.5", 100)]
    with tempfile.TemporaryDirectory() as tmp:
        spec = SweepSpec.make(base, axes, engine="fast")
        t = time.perf_counter()
        r = run_sweep(spec, Path(tmp) / "fast", workers=args.workers, progress=False)
        fast_map = time.perf_counter() - t
        t = time.perf_counter()
        rd = run_sweep(spec, Path(tmp) / "fast_dask", workers=args.workers, dask="local", progress=False)
        dask_map = time.perf_counter() - t
        same = bool(np.array_equal(r.lle, rd.lle, equal_nan=True))
        # heyoka on the first tiles of the same map (row-major: eta = 0.68 and up, every x_w)
        hspec = SweepSpec.make(base, axes, engine="heyoka", tile_size=args.heyoka_points // args.workers)
        t = time.perf_counter()
        run_sweep(hspec, Path(tmp) / "hey", workers=args.workers, progress=False, max_tiles=args.workers)
        hey_t = time.perf_counter() - t
    fast_pps = spec.n_points / fast_map
    hey_pps = (args.heyoka_points // args.workers) * args.workers / hey_t
    rows["sweep 100 x 100 (2000 + 1000 periods)"] = {
        "workers": args.workers, "fast_map_s": fast_map, "fast_points_per_s": fast_pps,
        "heyoka_points_per_s": hey_pps, "heyoka_points_measured": args.heyoka_points,
        "heyoka_map_s_extrapolated": spec.n_points / hey_pps,
        "fast_1000x1000_h_extrapolated": 1e6 / fast_pps / 3600, "complete": bool(r.complete),
        "fast_dask_local_map_s": dask_map, "dask_equals_processes_bit_for_bit": same,
    }
    print(rows, flush=True)
    cache = tempfile.mkdtemp()
    env_empty = dict(os.environ, NUMBA_CACHE_DIR=cache)
    lle_args = ["lle", "--periods", "24000", "--json"]
    rows["cli lle one-shot (fresh process)"] = {
        "fast_empty_cache_s": cli_time(lle_args + ["--method", "fast"], env_empty),
        "fast_warm_cache_s": statistics.median([cli_time(lle_args + ["--method", "fast"]) for _ in range(3)]),
        "variational_s": statistics.median([cli_time(lle_args + ["--method", "variational"]) for _ in range(2)]),
    }
    shutil.rmtree(cache, ignore_errors=True)
    print(rows, flush=True)
    OUT.mkdir(exist_ok=True)
    (OUT / "fast.json").write_text(json.dumps(rows, indent=1) + "\n")
    s, l_, sw, c = (rows[k] for k in rows)
    lines = [
        "# Fast engine (compiled closed form) against heyoka, one run", "",
        f"{os.cpu_count()} cores; medians after warm-up; ratio = heyoka time / fast time.", "",
        "| job | heyoka | fast | ratio |", "|---|---:|---:|---:|",
        f"| simulate 200 chaotic periods (reused solver) | {1e3 * s['heyoka_solver_s']:.2f} ms | "
        f"{1e3 * s['fast_s']:.3f} ms | {s['heyoka_solver_s'] / s['fast_s']:.0f}x |",
        f"| simulate 200 chaotic periods (public simulate()) | {1e3 * s['heyoka_simulate_s']:.2f} ms | "
        f"{1e3 * s['fast_s']:.3f} ms | {s['heyoka_simulate_s'] / s['fast_s']:.0f}x |",
        f"| lle 4 x 6000 periods at eta = 0.712 | {l_['heyoka_variational_s']:.2f} s | {1e3 * l_['fast_s']:.1f} ms | "
        f"{l_['heyoka_variational_s'] / l_['fast_s']:.0f}x |",
        f"| sweep points/s, {sw['workers']} workers | {sw['heyoka_points_per_s']:.1f} | "
        f"{sw['fast_points_per_s']:.0f} | {sw['fast_points_per_s'] / sw['heyoka_points_per_s']:.0f}x |",
        f"| cold one-shot `lle` CLI (fresh process) | {c['variational_s']:.2f} s | "
        f"{c['fast_warm_cache_s']:.2f} s ({c['fast_empty_cache_s']:.1f} s with an empty compile cache) | "
        f"{c['variational_s'] / c['fast_warm_cache_s']:.1f}x |",
        "",
        f"* simulate: fast and heyoka agree to {s['max_diff_to_period_50']:.1e} up to period 50 (chaos).",
        f"* lle: fast {l_['fast_lle']:.5f} +- {l_['fast_stderr']:.5f}, variational {l_['variational_lle']:.5f} +- "
        f"{l_['variational_stderr']:.5f}.",
        f"* sweep: the README's 100 x 100 map in {sw['fast_map_s']:.1f} s with the fast engine on "
        f"{sw['workers']} worker processes, {sw['fast_dask_local_map_s']:.1f} s on a Dask LocalCluster "
        f"(bit-identical: {sw['dask_equals_processes_bit_for_bit']}); heyoka measured on the map's first "
        f"{sw['heyoka_points_measured']} points, the whole map extrapolated to "
        f"{sw['heyoka_map_s_extrapolated'] / 60:.0f} min; a 1000 x 1000 map extrapolated to "
        f"{sw['fast_1000x1000_h_extrapolated']:.1f} h on these cores.",
    ]
    (OUT / "fast.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
