"""``precise-impact bench work-precision [--quick] [--out DIR] [--json]``."""

from __future__ import annotations

import argparse
import json
import sys

__all__ = ["add_parser", "run"]


def add_parser(sub) -> argparse.ArgumentParser:
    """Add ``bench`` (with sub-subcommand ``work-precision``) to ``sub``."""
    b = sub.add_parser(
        "bench", help="benchmarks: error and wall time of every method (work-precision)"
    )
    bsub = b.add_subparsers(dest="bench_command", required=True)
    wp = bsub.add_parser(
        "work-precision",
        help="error vs wall time of heyoka, analytical, scipy solve_ivp and ngspice; the cost of chaos",
    )
    wp.add_argument(
        "--quick", action="store_true", help="fewer tolerances and methods (about a minute)"
    )
    wp.add_argument(
        "--out",
        default=None,
        metavar="DIR",
        help="write work_precision.json/.csv/.png and chaos_cost.png into DIR",
    )
    wp.add_argument("--json", action="store_true", help="print exactly one JSON object")
    wp.add_argument(
        "--force",
        action="store_true",
        help="write into an existing non-empty --out directory (files of the same name are replaced)",
    )
    return b


def run(ns: argparse.Namespace) -> int:
    """Run the ``bench`` subcommand; returns the exit status."""
    from precise_impact.verification.workprecision import format_table, work_precision

    if getattr(ns, "bench_command", None) != "work-precision":
        print(f"bench: unknown benchmark {getattr(ns, 'bench_command', None)!r}", file=sys.stderr)
        return 2
    result = work_precision(quick=ns.quick, out=ns.out, progress=not ns.json)
    if ns.json:
        print(json.dumps(result.to_dict()))
    else:
        print(format_table(result))
    return 0
