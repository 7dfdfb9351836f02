"""The fast engine against the heyoka paths, side by side in one run.

Jobs (float64, eta = 0.712 chaotic unless said; medians of ``--rounds`` after warm-up):

* ``simulate``: 200 chaotic periods, ``FastSolver().solve`` against a reused
  ``HeyokaSolver`` and the public ``simulate()``;
* ``lle``: 4 x 6000 periods after 1000 (standard error ~ +-0.0005), ``method='fast'``
  against ``method='variational'``;
* ``sweep``: points per second of ``run_sweep`` on the README's 100 x 100 map
  (eta 0.68..0.82 x x_w 1.5..2.5, 2000 + 1000 periods per point) on ``--workers``
  processes: the whole map with the fast engine (end to end, and run_sweep's own rate over
  the tiles); and both engines' steady state on one core (compilation excluded) on the same
  8 tiles spread over the map (the heyoka map time extrapolated from it, and stated so;
  ``benchmarks/bench_sweep.py`` times heyoka's whole map);
* ``sync``: ``sync_scan`` over 6 couplings x 8 slave starts x 500 periods (first-order form),
  ``engine='fast'`` against ``engine='heyoka'``;
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
    subprocess.run(
        [sys.executable, "-m", "precise_impact", *args],
        check=True,
        capture_output=True,
        env=env or dict(os.environ),
    )
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    args = ap.parse_args()
    import numpy as np

    from precise_impact import HeyokaSolver, Params, SweepSpec, lyapunov, run_sweep, simulate
    from precise_impact.solvers.fast.single import FastSolver

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
    rows["simulate 200 periods"]["max_diff_to_period_50"] = float(
        np.max(np.abs(np.asarray(a.x) - np.asarray(b.x, float)))
    )
    print(rows, flush=True)
    lf = lyapunov(p, "fast", periods=24000, transient=1000)
    lv = lyapunov(p, "variational", periods=24000, transient=1000)
    rows["lle 4 x 6000 periods"] = {
        "fast_s": median_time(
            lambda: lyapunov(p, "fast", periods=24000, transient=1000), args.rounds
        ),
        "heyoka_variational_s": median_time(
            lambda: lyapunov(p, "variational", periods=24000, transient=1000), 1
        ),
        "fast_lle": lf.lle,
        "fast_stderr": lf.stderr,
        "variational_lle": lv.lle,
        "variational_stderr": lv.stderr,
    }
    print(rows, flush=True)
    base = Params.make()
    axes = [("eta", "0.68", "0.82", 100), ("x_w", "1.5", "2.5", 100)]
    with tempfile.TemporaryDirectory() as tmp:
        spec = SweepSpec.make(base, axes, engine="fast")
        runs = []
        for i in range(3):  # end to end (tiles, sweep.npz/csv, sweep.png) and the tiles' own rate
            t = time.perf_counter()
            r = run_sweep(spec, Path(tmp) / f"fast{i}", workers=args.workers, progress=False)
            runs.append((time.perf_counter() - t, r.stats["points_per_s"]))
        fast_map, fast_tiles_pps = sorted(runs)[1]
        t = time.perf_counter()
        rd = run_sweep(
            spec, Path(tmp) / "fast_dask", workers=args.workers, dask="local", progress=False
        )
        dask_map = time.perf_counter() - t
        same = bool(np.array_equal(r.lle, rd.lle, equal_nan=True))
    # Steady state, one core, the same points for both engines, after warm-up (compilation
    # excluded), in this process: every 20th tile of the map, as the sweep cuts them
    # (contiguous points, so heyoka's SIMD lanes hold neighbours, as in a sweep): 8 tiles
    # spread from eta = 0.68 to 0.80.
    from precise_impact.analysis.lyapunov.batch import batch_lle
    from precise_impact.analysis.lyapunov.fast import fast_batch

    pts = [
        spec.point(i)
        for tile in range(0, spec.n_tiles, 20)
        for i in range(tile * spec.tile_size, min(spec.n_points, (tile + 1) * spec.tile_size))
    ]
    fast_batch(pts[:2], periods=spec.periods, transient=spec.transient)
    batch_lle(pts[:4], periods=20, transient=10, batch_size=spec.batch_size)
    t = time.perf_counter()
    fr = fast_batch(pts, periods=spec.periods, transient=spec.transient)
    fast_core_pps = len(pts) / (time.perf_counter() - t)
    t = time.perf_counter()
    hr = batch_lle(pts, periods=spec.periods, transient=spec.transient, batch_size=spec.batch_size)
    hey_core_pps = len(pts) / (time.perf_counter() - t)
    same_period = sum(a["period"] == b["period"] for a, b in zip(fr, hr, strict=True))
    fast_pps = spec.n_points / fast_map
    rows["sweep 100 x 100 (2000 + 1000 periods)"] = {
        "workers": args.workers,
        "fast_map_s": fast_map,
        "fast_points_per_s": fast_pps,
        "fast_tiles_points_per_s": fast_tiles_pps,
        "sample_points": len(pts),
        "fast_points_per_s_per_core": fast_core_pps,
        "heyoka_points_per_s_per_core": hey_core_pps,
        "same_period_detected": same_period,
        "heyoka_map_s_extrapolated": spec.n_points / (hey_core_pps * args.workers),
        "fast_1000x1000_h_extrapolated": 1e6 / fast_tiles_pps / 3600,
        "complete": bool(r.complete),
        "fast_dask_local_map_s": dask_map,
        "dask_equals_processes_bit_for_bit": same,
    }
    print(rows, flush=True)
    from precise_impact.analysis.sync import sync_scan

    ks = ["0.02", "0.025", "0.03", "0.035", "0.04", "0.045"]
    scans = {}

    def scan(engine):
        scans[engine] = sync_scan(p, "first-order", ks, periods=500, ensemble=8, engine=engine)

    rows["sync scan"] = {
        "fast_s": median_time(lambda: scan("fast"), args.rounds),
        "heyoka_s": median_time(lambda: scan("heyoka"), 1),
    }
    rows["sync scan"].update(
        {
            f"{e}_fraction_synchronised": [float(f) for f in scans[e].fraction_synchronised]
            for e in scans
        }
    )
    rows["sync scan"].update({f"{e}_k_star": [scans[e].k_star, scans[e].k_star_err] for e in scans})
    print(rows, flush=True)
    cache = tempfile.mkdtemp()
    env_empty = dict(os.environ, NUMBA_CACHE_DIR=cache)
    lle_args = ["lle", "--periods", "24000", "--json"]
    rows["cli lle one-shot (fresh process)"] = {
        "fast_empty_cache_s": cli_time(lle_args + ["--method", "fast"], env_empty),
        "fast_warm_cache_s": statistics.median(
            [cli_time(lle_args + ["--method", "fast"]) for _ in range(3)]
        ),
        "variational_s": statistics.median(
            [cli_time(lle_args + ["--method", "variational"]) for _ in range(2)]
        ),
    }
    shutil.rmtree(cache, ignore_errors=True)
    print(rows, flush=True)
    OUT.mkdir(exist_ok=True)
    (OUT / "fast.json").write_text(json.dumps(rows, indent=1) + "\n")
    s, l_, sw, sy, c = (rows[k] for k in rows)
    lines = [
        "# Fast engine (compiled closed form) against heyoka, one run",
        "",
        f"{os.cpu_count()} cores; medians after warm-up; ratio = heyoka time / fast time.",
        "",
        "| job | heyoka | fast | ratio |",
        "|---|---:|---:|---:|",
        f"| simulate 200 chaotic periods (reused solver) | {1e3 * s['heyoka_solver_s']:.2f} ms | "
        f"{1e3 * s['fast_s']:.3f} ms | {s['heyoka_solver_s'] / s['fast_s']:.0f}x |",
        f"| simulate 200 chaotic periods (public simulate()) | {1e3 * s['heyoka_simulate_s']:.2f} "
        f"ms | {1e3 * s['fast_s']:.3f} ms | {s['heyoka_simulate_s'] / s['fast_s']:.0f}x |",
        f"| lle 4 x 6000 periods at eta = 0.712 | {l_['heyoka_variational_s']:.2f} s | "
        f"{1e3 * l_['fast_s']:.1f} ms | {l_['heyoka_variational_s'] / l_['fast_s']:.0f}x |",
        f"| sweep points/s per core, steady state, the same {sw['sample_points']} points (8 tiles) "
        f"of the map | {sw['heyoka_points_per_s_per_core']:.1f} | "
        f"{sw['fast_points_per_s_per_core']:.0f} | "
        f"{sw['fast_points_per_s_per_core'] / sw['heyoka_points_per_s_per_core']:.0f}x |",
        f"| the 100 x 100 map, {sw['workers']} workers: fast end to end (start-up, tiles, "
        "sweep.npz/csv/png) and over the tiles; heyoka extrapolated from its steady state | "
        f"{sw['heyoka_map_s_extrapolated']:.0f} s | {sw['fast_map_s']:.1f} s "
        f"({sw['fast_points_per_s']:.0f} points/s), tiles {sw['fast_tiles_points_per_s']:.0f} "
        f"points/s | {sw['heyoka_map_s_extrapolated'] / sw['fast_map_s']:.0f}x |",
        "| sync scan: 6 k x 8 starts x 500 periods (first-order, 20 samples per period) | "
        f"{sy['heyoka_s']:.2f} s | {sy['fast_s']:.2f} s | {sy['heyoka_s'] / sy['fast_s']:.0f}x |",
        f"| cold one-shot `lle` CLI (fresh process) | {c['variational_s']:.2f} s | "
        f"{c['fast_warm_cache_s']:.2f} s ({c['fast_empty_cache_s']:.1f} s with an empty compile "
        f"cache) | {c['variational_s'] / c['fast_warm_cache_s']:.1f}x |",
        "",
        f"* simulate: fast and heyoka agree to {s['max_diff_to_period_50']:.1e} up to period 50 "
        "(chaos).",
        f"* lle: fast {l_['fast_lle']:.5f} +- {l_['fast_stderr']:.5f}, variational "
        f"{l_['variational_lle']:.5f} +- {l_['variational_stderr']:.5f}.",
        f"* sweep: the README's 100 x 100 map in {sw['fast_map_s']:.1f} s with the fast engine on "
        f"{sw['workers']} worker processes, {sw['fast_dask_local_map_s']:.1f} s on a Dask "
        f"LocalCluster (bit-identical: {sw['dask_equals_processes_bit_for_bit']}); on the "
        f"{sw['sample_points']} sample points both engines detect the same period at "
        f"{sw['same_period_detected']}; a 1000 x 1000 map extrapolated to "
        f"{sw['fast_1000x1000_h_extrapolated']:.1f} h on these cores.",
        f"* sync: synchronised fractions fast {sy['fast_fraction_synchronised']}, heyoka "
        f"{sy['heyoka_fraction_synchronised']}; k* fast {sy['fast_k_star'][0]:.4f} +- "
        f"{sy['fast_k_star'][1]:.4f}, heyoka {sy['heyoka_k_star'][0]:.4f} +- "
        f"{sy['heyoka_k_star'][1]:.4f} (runs near the threshold are intermittent and chaotic: "
        "individual outcomes differ, the statistics agree).",
    ]
    (OUT / "fast.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
