"""Engine benchmark (issue 2): compile time and run time per precision, side by side.

Run:  python benchmarks/bench_engine.py [--quick]
Writes benchmarks/results/engine.json and benchmarks/results/engine.md.

Run times are medians of repeated runs after one warm-up run (compilation excluded
and reported separately, from a cleared heyoka in-memory cache).  Ratios are to
heyoka float64 measured in the same process.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import sys
import time
from pathlib import Path

import heyoka as hy

from precise_impact import AnalyticalSolver, HeyokaSolver, Params
from precise_impact.io.atomic import atomic_write
from precise_impact.solvers.heyoka.single import INTEGRATORS

OUT = Path(__file__).resolve().parent / "results"


def median_time(fn, repeats: int) -> float:
    fn()  # warm-up
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def compile_time(precision: str) -> dict:
    """First compilation in a fresh process (includes LLVM start-up) and a recompilation
    in this process after clearing precise_impact's and heyoka's in-memory caches."""
    import subprocess

    code = (
        "import time; from precise_impact import HeyokaSolver; t = time.perf_counter(); "
        f"HeyokaSolver({precision!r}).integrator(); print(time.perf_counter() - t)"
    )
    fresh = float(
        subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True
        ).stdout
    )
    INTEGRATORS.clear()
    hy.llvm_state.clear_memcache()
    t0 = time.perf_counter()
    HeyokaSolver(precision).integrator()
    return {"fresh_process_s": fresh, "recompile_s": time.perf_counter() - t0}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="fewer repeats")
    args = ap.parse_args()
    rep = 5 if args.quick else 30
    p = Params.make(eta="0.712")
    cases = [
        ("heyoka", "float64", 200, rep, lambda: HeyokaSolver("float64").solve(p, 200)),
        ("heyoka", "longdouble", 200, rep, lambda: HeyokaSolver("longdouble").solve(p, 200)),
        (
            "heyoka",
            "float128",
            200,
            max(3, rep // 5),
            lambda: HeyokaSolver("float128").solve(p, 200),
        ),
        ("heyoka", "mp:256", 300, 3, lambda: HeyokaSolver("mp:256").solve(p, 300)),
        ("analytical", "float64", 200, rep, lambda: AnalyticalSolver("robust").solve(p, 200)),
        ("analytical-paper", "float64", 200, 3, lambda: AnalyticalSolver("paper").solve(p, 200)),
        (
            "analytical",
            "mp:200 (60 digits)",
            200,
            3,
            lambda: AnalyticalSolver("robust", "mpmath", 60).solve(p, 200),
        ),
    ]
    compile_s = {
        prec: compile_time(prec) for prec in ("float64", "longdouble", "float128", "mp:256")
    }
    rows = []
    for model, prec, periods, reps, fn in cases:
        t = median_time(fn, reps)
        rows.append(
            {"model": model, "precision": prec, "periods": periods, "median_s": t, "repeats": reps}
        )
        print(
            f"{model:17s} {prec:20s} {periods:4d} periods: {t * 1e3:10.3f} ms",
            file=sys.stderr,
            flush=True,
        )
    base = rows[0]["median_s"] / rows[0]["periods"]
    for r in rows:
        r["ratio_per_period_to_heyoka_float64"] = (r["median_s"] / r["periods"]) / base
    result = {
        "case": "eta=0.712 (chaotic) from rest, paper parameters",
        "machine": {
            "python": platform.python_version(),
            "processor": platform.processor(),
            "heyoka": hy.__version__,
        },
        "compile_s": compile_s,
        "runs": rows,
        "target": "heyoka float64, 200 periods after compilation: < 5 ms",
        "target_met": rows[0]["median_s"] < 5e-3,
    }
    OUT.mkdir(parents=True, exist_ok=True)
    text = json.dumps(result, indent=2)
    atomic_write(OUT / "engine.json", lambda fh: fh.write(text), binary=False)
    md = ["# Engine benchmark (eta = 0.712, chaotic, from rest)", ""]
    md.append("| model | precision | periods | median time | per period vs heyoka float64 |")
    md.append("|---|---|---:|---:|---:|")
    for r in rows:
        md.append(
            f"| {r['model']} | {r['precision']} | {r['periods']} | {r['median_s'] * 1e3:.3f} ms | "
            f"{r['ratio_per_period_to_heyoka_float64']:.1f}x |"
        )
    md += [
        "",
        "| precision | compile, fresh process | recompile, cleared caches |",
        "|---|---:|---:|",
    ]
    md += [
        f"| {k} | {v['fresh_process_s']:.3f} s | {v['recompile_s']:.3f} s |"
        for k, v in compile_s.items()
    ]
    md.append("")
    md.append(
        "Target (heyoka float64, 200 periods < 5 ms): "
        f"{'met' if result['target_met'] else 'MISSED'}."
    )
    atomic_write(OUT / "engine.md", lambda fh: fh.write("\n".join(md) + "\n"), binary=False)
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    sys.exit(main())
