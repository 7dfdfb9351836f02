"""``precise-impact bench work-precision``: error and wall time of every method."""

from __future__ import annotations

import argparse

from precise_impact.cli.args import add_json, add_out
from precise_impact.io.jsonout import print_json
from precise_impact.verification.workprecision import format_table, work_precision

__all__ = ["register", "run"]


def register(sub) -> argparse.ArgumentParser:
    """Add ``bench`` (with sub-subcommand ``work-precision``) to ``sub``."""
    b = sub.add_parser(
        "bench", help="benchmarks: error and wall time of every method (work-precision)"
    )
    bsub = b.add_subparsers(dest="bench_command", required=True)
    wp = bsub.add_parser(
        "work-precision",
        help="error vs wall time of heyoka, analytical, scipy solve_ivp and ngspice; "
        "the cost of chaos",
    )
    wp.add_argument("--quick", action="store_true", help="fewer tolerances and methods")
    add_out(
        wp,
        "dir",
        "write work_precision.json/.csv/.png and chaos_cost.png into DIR",
        writes=("work_precision.*", "chaos_cost.png"),
    )
    add_json(wp, "print exactly one JSON object")
    b.set_defaults(run=run)
    return b


def run(ns: argparse.Namespace) -> int:
    """Run the ``bench`` subcommand; returns the exit status."""
    result = work_precision(quick=ns.quick, out=ns.out, progress=not ns.json)
    if ns.json:
        print_json(result.to_dict())
    else:
        print(format_table(result))
    return 0
