"""``precise-impact scenes``: the built-in scenes, one line each."""

from __future__ import annotations

import argparse

from precise_impact.core.params import decimal_str
from precise_impact.scenes.scene import builtin_scenes, load_scene


def register(sub) -> argparse.ArgumentParser:
    """Add ``scenes`` to ``sub``."""
    sc = sub.add_parser("scenes", help="list the built-in scenes, one line each")
    sc.set_defaults(run=run)
    return sc


def run(ns: argparse.Namespace) -> int:
    """Run ``scenes``; returns the exit status."""
    for name, path in sorted(builtin_scenes().items()):
        sc = load_scene(path)
        extra = f" k={decimal_str(sc.k)} form={sc.form}" if sc.kind == "coupled" else ""
        eta = sc.params.decimal()["eta"]
        print(f"{name:28s} {sc.model:18s} eta={eta:<6s}{extra}  {sc.description}")
    return 0
