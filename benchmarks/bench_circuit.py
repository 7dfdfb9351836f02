"""Circuit benchmark (issue 4), results in benchmarks/results/circuit.{json,md}.

Run:  python benchmarks/bench_circuit.py

Side by side in one process, medians after a warm-up (compilation excluded):
* mechanical heyoka vs the ideal circuit model vs the ideal switched-capacitor
  model, 200 chaotic periods (target: an effect that is off costs nothing, within 10 %);
* the datasheet-parts switched-capacitor model;
* the op-amp gain-bandwidth effect: quasi-static reduction vs dynamic single-pole
  states (the stiffness cost for a Taylor integrator), per period.
"""

from __future__ import annotations

import json
import statistics
import sys
import time
from pathlib import Path

from precise_impact import (
    CircuitSolver,
    HeyokaSolver,
    Params,
    SwitchedCapacitorSolver,
    load_scene,
    nominal_components,
)
from precise_impact.io.atomic import atomic_write

OUT = Path(__file__).resolve().parent / "results"


def median(fn, n=15):
    fn()
    ts = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts)


def main() -> int:
    p = Params.make(eta="0.712")
    c = nominal_components(p)
    ds = load_scene("fig5-chaotic-datasheet")
    rows = [
        ("mechanical (heyoka)", 200, median(lambda: HeyokaSolver().solve(p, 200))),
        ("circuit, no effects", 200, median(lambda: CircuitSolver().solve(c, 200))),
        (
            "switched-capacitor, no effects",
            200,
            median(lambda: SwitchedCapacitorSolver().solve(c, 200)),
        ),
        (
            "switched-capacitor, datasheet parts",
            200,
            median(lambda: SwitchedCapacitorSolver(effects=ds.effects).solve(ds.design(), 200)),
        ),
        (
            "circuit, GBW quasi-static",
            200,
            median(lambda: CircuitSolver(effects={"opamp_gbw": {}}).solve(c, 200)),
        ),
        (
            "circuit, GBW dynamic (6 states)",
            2,
            median(
                lambda: CircuitSolver(effects={"opamp_gbw": {"mode": "dynamic"}}).solve(c, 2), 3
            ),
        ),
    ]
    steps_dyn = (
        CircuitSolver(effects={"opamp_gbw": {"mode": "dynamic"}}).solve(c, 2).stats["steps"] / 2
    )
    steps_mech = HeyokaSolver().solve(p, 200).stats["steps"] / 200
    base = rows[0][2] / rows[0][1]
    table = [
        {"run": n, "periods": k, "median_s": t, "per_period_vs_mechanical": (t / k) / base}
        for n, k, t in rows
    ]
    res = {
        "rows": table,
        "taylor_steps_per_period": {"mechanical": steps_mech, "gbw_dynamic": steps_dyn},
        "no_effect_overhead": table[1]["per_period_vs_mechanical"] - 1,
    }
    OUT.mkdir(parents=True, exist_ok=True)
    text = json.dumps(res, indent=2)
    atomic_write(OUT / "circuit.json", lambda fh: fh.write(text), binary=False)
    md = [
        "# Circuit models (eta = 0.712, float64)",
        "",
        "| run | periods | median | per period vs mechanical |",
        "|---|---:|---:|---:|",
    ]
    md += [
        f"| {r['run']} | {r['periods']} | {r['median_s'] * 1e3:.3f} ms | "
        f"{r['per_period_vs_mechanical']:.2f}x |"
        for r in table
    ]
    md += [
        "",
        f"Taylor steps per period: mechanical {steps_mech:.1f}, dynamic GBW {steps_dyn:.0f} "
        f"({steps_dyn / steps_mech:.0f}x: the closed-loop op-amp poles near GBW / noise gain).",
        f"Ideal circuit overhead over the mechanical model: {100 * res['no_effect_overhead']:+.1f} "
        "% (target within 10 %).",
    ]
    atomic_write(OUT / "circuit.md", lambda fh: fh.write("\n".join(md) + "\n"), binary=False)
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    sys.exit(main())
