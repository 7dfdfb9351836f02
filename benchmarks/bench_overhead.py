"""Python overhead of the float64 heyoka path: this tree against a baseline commit, side by side.

Times, in ONE run and interleaved (baseline, current, baseline, current ...), medians of
repeated calls after compilation:

* ``simulate``: 200 chaotic periods (eta = 0.712) in float64 with the public
  ``simulate(params, 200, precision="float64")`` (a new solver per call: in this tree
  that includes the private copy of the compiled integrator, ~0.6 ms);
* ``solve``: the same with one ``HeyokaSolver("float64")`` reused for every call;
* ``lle``: the variational LLE, 4 x 2000 periods after 500 (eta = 0.712).

The baseline is a ``git worktree`` of ``--baseline`` (default 399e653, the commit before the
real-package work) run in a subprocess with ``PYTHONPATH`` pointing at its ``src``; both use
the same interpreter and heyoka.  Results (ratios baseline/current) go to
``benchmarks/results/overhead.{json,md}``.

Run:  python benchmarks/bench_overhead.py [--baseline REV] [--rounds 5]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
OUT = HERE / "results"

# One measurement in a fresh interpreter: compile, warm up, then time N calls.
PROBE = r"""
import json, sys, time
import precise_impact as pi
job, n = sys.argv[1], int(sys.argv[2])
p = pi.Params.make(eta="0.712")
if job == "simulate":
    run = lambda: pi.simulate(p, 200, precision="float64")
elif job == "solve":
    s = pi.HeyokaSolver("float64")
    run = lambda: s.solve(p, 200)
else:
    try:
        from precise_impact.analysis.lyapunov import lyapunov
    except ImportError:  # the 0.1.0 layout
        from precise_impact._lyapunov import lyapunov
    run = lambda: lyapunov(p, periods=2000, transient=500)
run(); run()
ts = []
for _ in range(n):
    t = time.perf_counter(); r = run(); ts.append(time.perf_counter() - t)
check = r.lle if job == "lle" else float(r.x[-1])
print(json.dumps({"times": ts, "check": check}))
"""


def probe(src: Path | None, job: str, n: int) -> dict:
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = str(src)
    r = subprocess.run([sys.executable, "-c", PROBE, job, str(n)], capture_output=True, text=True, env=env,
                       cwd=tempfile.gettempdir(), check=True)
    return json.loads(r.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default="399e653")
    ap.add_argument("--rounds", type=int, default=5)
    ns = ap.parse_args()
    wt = Path(tempfile.mkdtemp()) / "baseline"
    subprocess.run(["git", "-C", str(REPO), "worktree", "add", "-q", "--detach", str(wt), ns.baseline], check=True)
    try:
        rows = []
        for job, n in (("simulate", 30), ("solve", 30), ("lle", 3)):
            base, cur, checks = [], [], {}
            for _ in range(ns.rounds):
                b = probe(wt / "src", job, n)
                c = probe(None, job, n)
                base += b["times"]
                cur += c["times"]
                checks = {"baseline": b["check"], "current": c["check"]}
            mb, mc = statistics.median(base), statistics.median(cur)
            rows.append({"job": job, "baseline_s": mb, "current_s": mc, "ratio": mb / mc, "checks": checks,
                         "same_answer": checks["baseline"] == checks["current"]})
            print(f"{job:9s} baseline {mb * 1e3:8.2f} ms   current {mc * 1e3:8.2f} ms   ratio {mb / mc:5.2f}x   "
                  f"(same answer: {checks})")
    finally:
        subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(wt)], check=False)
    OUT.mkdir(exist_ok=True)
    (OUT / "overhead.json").write_text(json.dumps({"baseline": ns.baseline, "rows": rows}, indent=1) + "\n")
    lines = [f"# Python overhead of the float64 heyoka path (baseline {ns.baseline} vs this tree)", "",
             "Same interpreter and heyoka, interleaved runs in fresh processes, medians after compilation.", "",
             "| job | baseline | current | ratio | same answer |", "|---|---:|---:|---:|:---:|"]
    for r in rows:
        lines.append(f"| {r['job']} | {r['baseline_s'] * 1e3:.2f} ms | {r['current_s'] * 1e3:.2f} ms | "
                     f"{r['ratio']:.2f}x | {'yes' if r['same_answer'] else 'NO'} |")
    lines += ["", "simulate: `simulate(Params.make(eta='0.712'), 200, precision='float64')` (a new solver, "
              "hence a private integrator copy, per call); solve: the same 200 periods with one reused "
              "`HeyokaSolver('float64')`; lle: variational, 4 x 2000 periods after 500. "
              "same answer: the last sample (simulate, solve) or the LLE bit-identical."]
    (OUT / "overhead.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
