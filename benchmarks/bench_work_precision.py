"""Work-precision benchmark: every method's error against a demonstrated reference vs wall time.

Run:  python benchmarks/bench_work_precision.py [--quick]
Writes benchmarks/results/work_precision.{json,csv,png} and chaos_cost.png
(precise_impact.verification.workprecision.work_precision; scipy rows need the ``bench``
extra, ngspice rows need ``apt-get install ngspice``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from precise_impact.verification.workprecision import format_table, work_precision


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent / "results"))
    ns = ap.parse_args()
    result = work_precision(quick=ns.quick, out=ns.out)
    print(format_table(result))
    print(f"total {result['elapsed_s']:.1f} s; written to {ns.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
