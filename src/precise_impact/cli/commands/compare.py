"""``precise-impact compare SCENE --models m1,m2 [--periods N] [--json] [--out DIR]``."""

from __future__ import annotations

import argparse

import heyoka

from precise_impact.cli.args import add_json, add_out, add_periods, add_units
from precise_impact.core.params import check_count
from precise_impact.io.jsonout import print_json
from precise_impact.solvers.base import MODELS
from precise_impact.verification.compare import check_models, compare, format_scores
from precise_impact.verification.metrics import max_reference_periods

__all__ = ["register", "run"]


def register(sub) -> argparse.ArgumentParser:
    """Add ``compare`` to ``sub`` (the object returned by ``add_subparsers``)."""
    c = sub.add_parser(
        "compare", help="score models of a scene against a demonstrated heyoka reference"
    )
    c.add_argument("scene", help="built-in scene name or FILE.toml")
    c.add_argument("--models", required=True, help="comma-separated: " + ",".join(MODELS))
    add_periods(c, None, "forcing periods", metavar=None, default_text="default: the scene's")
    c.add_argument(
        "--points",
        action="store_true",
        help="also score the grazing and period-doubling points along eta against the mechanics",
    )
    add_json(c, "print one JSON object")
    add_out(
        c,
        "dir",
        "write report.md, scores.json, phase_portraits.png and separation.png here",
        writes=("report.md", "scores.json", "phase_portraits.png", "separation.png"),
    )
    add_units(c)
    c.set_defaults(run=run)
    return c


def run(ns: argparse.Namespace) -> int:
    """Run ``compare``; returns the exit status."""
    models = check_models(ns.models)
    periods = None
    if ns.periods is not None:
        # a demonstrated chaotic reference needs mp:BITS <= MAX_MP_BITS
        periods = check_count(ns.periods, "periods", max_reference_periods(), minimum=1)
    if ns.json:
        heyoka.set_logger_level_error()
    result = compare(
        ns.scene,
        models,
        out=ns.out,
        periods=periods,
        progress=not ns.json,
        points=ns.points,
        units=ns.units,
    )
    if ns.json:
        print_json(result.to_dict())
    else:
        print(format_scores(result))
        if ns.out is not None:
            print("written: " + ", ".join(result.files or []))
    return 0
