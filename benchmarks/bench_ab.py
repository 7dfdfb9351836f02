"""Same jobs, two source trees, one run: the time of a refactoring, as ratios.

Each job runs in a fresh subprocess per tree (``PYTHONPATH=<tree>/src``), trees alternating
round by round so that both see the same machine; a job's time is the best of ``--repeat``
calls after a warm-up call (numba compiles, heyoka builds its integrator).  The jobs use only
API calls both trees have (the 0.2 spellings), so any two revisions can be compared.

Run:  python benchmarks/bench_ab.py BEFORE_TREE AFTER_TREE [--rounds 3] [--out FILE.md]
(a tree is a checkout or ``git worktree add /tmp/before <rev>``).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

JOBS = {
    "fast simulate, 2000 periods": (
        "pi.simulate(p, 2000, model='fast')",
        5,
    ),
    "fast LLE (4 starts x 6000 periods)": (
        "pi.lyapunov(p, 'fast', periods=24000, transient=1000)",
        5,
    ),
    "closed form float64, 300 periods": ("pi.simulate(p, 300, model='analytical')", 3),
    "closed form mp:128, 50 periods": (
        "pi.simulate(p, 50, model='analytical', precision='mp:128')",
        3,
    ),
    "certify, 300 periods (auto bits)": ("pi.certify(p, 300)", 3),
    "certify_coupled, 50 periods": ("pi.certify_coupled(p, '0.1', periods=50)", 3),
}

CHILD = r"""
import json, sys, time, warnings
warnings.simplefilter("ignore")
import precise_impact as pi
p = pi.Params.make(eta="0.712")
stmt, repeat = sys.argv[1], int(sys.argv[2])
f = eval("lambda: " + stmt, {"pi": pi, "p": p})
f()
ts = []
for _ in range(repeat):
    t = time.perf_counter(); f(); ts.append(time.perf_counter() - t)
print(json.dumps(min(ts)))
"""


def _time(tree: Path, stmt: str, repeat: int) -> float:
    env = dict(os.environ, PYTHONPATH=str(tree / "src"))
    out = subprocess.run(
        [sys.executable, "-c", CHILD, stmt, str(repeat)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return float(json.loads(out.stdout.strip().splitlines()[-1]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", type=Path, default=None)
    ns = ap.parse_args()
    rows = []
    for name, (stmt, repeat) in JOBS.items():
        t = {"before": [], "after": []}
        for r in range(ns.rounds):
            order = ("before", "after") if r % 2 == 0 else ("after", "before")
            for which in order:
                t[which].append(_time(getattr(ns, which), stmt, repeat))
        b, a = min(t["before"]), min(t["after"])
        spread = (
            max(statistics.pstdev(t[w]) / min(t[w]) for w in ("before", "after") if len(t[w]) > 1)
            if ns.rounds > 1
            else float("nan")
        )
        rows.append((name, b, a, a / b, spread))
        print(f"{name:40s} before {b * 1e3:9.2f} ms  after {a * 1e3:9.2f} ms  ratio {a / b:5.2f}")
    if ns.out:
        lines = [
            f"# Before / after: `{ns.before}` vs `{ns.after}`",
            "",
            f"Best of each job's repeats, best over {ns.rounds} alternating rounds (fresh "
            "process per tree and round); spread = the larger relative standard deviation "
            "over rounds.",
            "",
            "| job | before (ms) | after (ms) | after / before | spread |",
            "|---|---:|---:|---:|---:|",
        ]
        lines += [
            f"| {n} | {b * 1e3:.2f} | {a * 1e3:.2f} | {q:.2f} | {s:.2f} |" for n, b, a, q, s in rows
        ]
        ns.out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
