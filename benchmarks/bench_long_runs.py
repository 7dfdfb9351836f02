"""The compiled engine at every length: ``lle --model fast`` over 10^6, 10^7 and 10^8 periods.

Side by side in one run, each in a fresh process exactly as a user types it
(``precise-impact lle --model fast --eta 0.712 --periods N --json``; the periods are shared by
the four starts), the kernel's own time (``elapsed_s``) and the wall time of the process:

* the cost per period of each length, and its ratio to the 10^6-period run's (issue 35: within
  1.3x);
* the flights the kernel refined in double-double (near-tangential contacts float64 cannot
  decide), per 10^8 periods;
* the LLE with its error bar at each length.

Before (issue 35, the landed main of 2026-11): 10^6 periods 0.5 s, 10^7 periods 220 s (every
start went back to heyoka after a tangential contact), 10^8 refused after 2 s (exit 3:
"heyoka would take ~2.33 h").

Results: ``benchmarks/results/long_runs.{json,md}``.

Run:  python benchmarks/bench_long_runs.py [--lengths 1e6 1e7 1e8]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

OUT = Path(__file__).resolve().parent / "results"


def _cli() -> list[str]:
    exe = shutil.which("precise-impact")
    return [exe] if exe else [sys.executable, "-m", "precise_impact"]


def run_length(periods: int) -> dict:
    """One ``lle`` run of ``periods`` in a fresh process: its JSON and the wall time."""
    cmd = _cli() + ["lle", "--model", "fast", "--eta", "0.712"]
    cmd += ["--periods", str(periods), "--json", "--max-time", "7200"]
    t0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True, check=True, env=dict(os.environ))
    wall = time.perf_counter() - t0
    r = json.loads(out.stdout)
    return {
        "periods": periods,
        "wall_s": wall,
        "kernel_s": r["elapsed_s"],
        "lle": r["lle"],
        "stderr": r["lle_stderr"],
        "impacts": r["n_impacts"],
        "engine": r["stats"]["engine"],
        "refined_flights": r["stats"].get("refined_flights"),
    }


def markdown(rows: list[dict]) -> str:
    base = rows[0]
    per0 = base["kernel_s"] / base["periods"]
    lines = [
        "# The compiled engine at every length: `lle --model fast --eta 0.712`",
        "",
        f"{os.cpu_count()} cores; one fresh process per length (numba's on-disk cache warm); the",
        "periods are shared by the four starts.  cost = the kernel's time (`elapsed_s`) per",
        f"period; ratio = cost / cost of the {base['periods']:.0e}-period run.",
        "",
        "| periods | engine | wall | kernel | cost per period | ratio | refined flights"
        " | per 1e8 periods | LLE |",
        "|---:|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        per = r["kernel_s"] / r["periods"]
        rate = r["refined_flights"] * 1e8 / r["periods"]
        lines.append(
            f"| {r['periods']:.0e} | {r['engine']} | {r['wall_s']:.1f} s | {r['kernel_s']:.1f} s"
            f" | {per * 1e9:.0f} ns | {per / per0:.2f}x | {r['refined_flights']} | {rate:.1f}"
            f" | {r['lle']:.6f} +- {r['stderr']:.6f} |"
        )
    lines += [
        "",
        "Before (issue 35, on the landed main): 1e6 periods 0.5 s, 1e7 periods 220 s (the",
        "starts went back to heyoka after a tangential contact), 1e8 refused after 2 s (exit 3,",
        '"heyoka would take ~2.33 h").  The contacts came from the absolute clock: the',
        "forcing's phase eta t rounded to ~eps eta t (1e-8 after 1e7 periods) left the gap",
        "undecided within that error; the kernels now keep a local clock (whole periods moved",
        "out exactly) and decide what float64 still cannot in double-double.",
        "",
        "Run: `python benchmarks/bench_long_runs.py`",
    ]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lengths", nargs="+", type=float, default=[1e6, 1e7, 1e8])
    ap.add_argument("--out", type=Path, default=OUT)
    ns = ap.parse_args(argv)
    run_length(10_000)  # the compile cache, once
    rows = []
    for n in ns.lengths:
        rows.append(run_length(int(n)))
        print(json.dumps(rows[-1]), flush=True)
    ns.out.mkdir(parents=True, exist_ok=True)
    (ns.out / "long_runs.json").write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")
    (ns.out / "long_runs.md").write_text(markdown(rows), encoding="utf-8")
    print(markdown(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
