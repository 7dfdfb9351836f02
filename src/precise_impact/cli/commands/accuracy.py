"""``precise-impact accuracy``: every model and precision against a demonstrated reference."""

from __future__ import annotations

import argparse

from precise_impact.cli.args import add_json, add_out, add_periods
from precise_impact.core.params import check_count
from precise_impact.io.jsonout import print_json
from precise_impact.verification.accuracy import accuracy_table, format_table


def register(sub) -> argparse.ArgumentParser:
    """Add ``accuracy`` to ``sub``."""
    a = sub.add_parser(
        "accuracy",
        help="the paper's three frequencies: the mechanical solvers (heyoka float64, longdouble, "
        "float128; analytical; analytical-paper; fast) against a demonstrated reference",
    )
    add_periods(a, "100", "forcing periods from rest")
    add_out(
        a,
        "dir",
        "write accuracy.json and accuracy.png here",
        writes=("accuracy.json", "accuracy.png"),
    )
    add_json(a, "print the result as one JSON object")
    a.set_defaults(run=run)
    return a


def run(ns: argparse.Namespace) -> int:
    """Run ``accuracy``; returns the exit status."""
    periods = check_count(ns.periods, maximum=2000, minimum=1)
    result = accuracy_table(periods=periods, out=ns.out, progress=not ns.json)
    if ns.json:
        print_json(result.to_dict())
        return 0
    print(format_table(result))
    if ns.out is not None:
        print(f"written: {ns.out}/accuracy.json, {ns.out}/accuracy.png")
    return 0
