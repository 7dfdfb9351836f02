"""``precise-impact reference generate|verify``: the reference datasets from the command line."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from precise_impact.cli.args import add_out
from precise_impact.errors import ParameterError
from precise_impact.verification.reference import (
    CASES,
    REFERENCE_ENV,
    default_root,
    generate,
    verify,
)

#: What ``default_root()`` resolves to, in the words of an installed package.
DEFAULT_ROOT_HELP = (
    f"${REFERENCE_ENV} if set, else the datasets installed with the package, "
    "precise_impact/data/reference"
)

__all__ = ["register", "run"]

EXIT_MISMATCH = 1
EXIT_BAD_INPUT = 2


def register(sub) -> argparse.ArgumentParser:
    """Add ``reference`` (with ``generate`` and ``verify``) to ``sub`` (from ``add_subparsers``)."""
    p = sub.add_parser(
        "reference",
        help="generate or verify the reference datasets (shipped in the package: "
        "precise_impact/data/reference)",
    )
    rsub = p.add_subparsers(dest="reference_command", metavar="{generate,verify}")
    rsub.required = True
    g = rsub.add_parser(
        "generate", help="generate datasets (skips cases whose manifest and checksums verify)"
    )
    which = g.add_mutually_exclusive_group()
    which.add_argument(
        "--case",
        action="append",
        metavar="NAME",
        choices=list(CASES),
        help="case to generate (repeatable): " + ", ".join(CASES),
    )
    which.add_argument("--all", action="store_true", help="every case (the default)")
    # generation resumes in its directory (complete cases are skipped); --force regenerates
    add_out(g, "resume", "output directory (default: " + DEFAULT_ROOT_HELP + ")")
    g.add_argument(
        "--force", action="store_true", help="regenerate cases that are already complete"
    )
    g.add_argument("--quiet", action="store_true", help="no progress on stderr")
    v = rsub.add_parser(
        "verify", help="check checksums and recompute a cheap subset; exit 1 on any problem"
    )
    v.add_argument(
        "--root",
        default=None,
        metavar="DIR",
        help="dataset directory (default: " + DEFAULT_ROOT_HELP + ")",
    )
    v.add_argument(
        "--case",
        action="append",
        metavar="NAME",
        choices=list(CASES),
        help="only this case (repeatable)",
    )
    v.add_argument("--no-recompute", action="store_true", help="checksums only")
    p.set_defaults(run=run)
    return p


def run(ns: argparse.Namespace) -> int:
    """Execute a parsed ``reference`` command; return the exit status."""
    if ns.reference_command == "generate":
        out = Path(ns.out) if ns.out else default_root()
        res = generate(
            None if ns.all or not ns.case else ns.case,
            out=out,
            progress=not ns.quiet,
            force=ns.force,
        )
        for case, m in res.items():
            state = "up to date" if m.get("skipped") else "written"
            size = sum(f["bytes"] for f in m["files"].values())
            print(f"{case}: {state} ({size / 1024:.0f} KiB) in {out / case}")
        return 0
    if ns.reference_command == "verify":
        root = Path(ns.root) if ns.root else default_root()
        problems = verify(root, cases=ns.case, recompute=not ns.no_recompute)
        for p in problems:
            print(f"MISMATCH: {p}")
        if problems:
            print(f"{len(problems)} problem(s) in {root}", file=sys.stderr)
            return EXIT_MISMATCH
        print(f"ok: every case in {root} verifies")
        return 0
    raise ParameterError("reference", ns.reference_command, "one of generate, verify")
