"""The cost model of ``precise_impact.core.budget`` against measured run times.

For each precision: one warm-up solve (compilation), then the median of ``--rounds``
solves of N chaotic periods (eta = 0.712) with and without 100 dense points per period,
beside the estimate of :func:`~precise_impact.core.budget.estimate_cost`.  The budget is
useful when estimate / measured stays within ~0.3-5 (it is meant to err on the high side).
Results: ``benchmarks/results/cost_model.{json,md}``.

Run:  python benchmarks/bench_cost_model.py [--rounds 3]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

from precise_impact import Params, Precision
from precise_impact.core.budget import estimate_cost
from precise_impact.solvers.heyoka.single import HeyokaSolver

OUT = Path(__file__).resolve().parent / "results"
CASES = [
    ("float64", 2000),
    ("longdouble", 500),
    ("float128", 100),
    ("mp:128", 100),
    ("mp:320", 40),
    ("mp:640", 10),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    p = Params.make(eta="0.712")
    rows = []
    for prec, n in CASES:
        P = Precision.parse(prec)
        s = HeyokaSolver(precision=P)
        s.solve(p, 2)
        for dense in (0, 100):
            times = []
            for _ in range(args.rounds):
                t = time.perf_counter()
                s.solve(p, n, per_period=dense)
                times.append(time.perf_counter() - t)
            measured = statistics.median(times)
            est = estimate_cost(P, n, dense).seconds
            rows.append(
                {
                    "precision": prec,
                    "periods": n,
                    "per_period": dense,
                    "measured_s": measured,
                    "estimate_s": est,
                    "ratio": est / measured,
                }
            )
            print(
                f"{prec:>10} {n:5d} periods x {dense:3d}: measured {measured:.4f} s, estimate "
                f"{est:.4f} s, ratio {est / measured:.2f}",
                flush=True,
            )
    OUT.mkdir(exist_ok=True)
    (OUT / "cost_model.json").write_text(json.dumps(rows, indent=1) + "\n")
    lines = [
        "# Cost model (core/budget.py) against measured heyoka runs",
        "",
        f"eta = 0.712 (chaotic), median of {args.rounds}, after compilation; ratio = estimate / "
        "measured.",
        "",
        "| precision | periods | dense/period | measured s | estimate s | ratio |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    lines += [
        f"| {r['precision']} | {r['periods']} | {r['per_period']} | {r['measured_s']:.4f} | "
        f"{r['estimate_s']:.4f} | {r['ratio']:.2f} |"
        for r in rows
    ]
    (OUT / "cost_model.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
