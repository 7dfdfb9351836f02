#!/usr/bin/env python3
"""Write the CLI synopsis into README.md and the command reference into docs/ from the parser.

README.md: the text between ``<!-- synopsis:begin -->`` and ``<!-- synopsis:end -->``
(:func:`precise_impact.cli.synopsis.synopsis`); docs/guide/cli_commands.inc: the reference
included by docs/guide/cli.rst (:func:`precise_impact.cli.synopsis.reference_rst`).

Usage: python scripts/gen-synopsis.py [--check]   (--check: write nothing, exit 1 if stale)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from precise_impact.cli.synopsis import reference_rst, replace_between_markers, synopsis

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
REFERENCE = ROOT / "docs" / "guide" / "cli_commands.inc"


def wanted() -> dict[Path, str]:
    """Each generated file and the text it should have."""
    readme = README.read_text(encoding="utf-8")
    return {README: replace_between_markers(readme, synopsis()), REFERENCE: reference_rst()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if a file is stale; write nothing")
    ns = ap.parse_args(argv)
    stale = [p for p, text in wanted().items() if not p.exists() or p.read_text("utf-8") != text]
    if ns.check:
        for p in stale:
            print(f"stale: {p.relative_to(ROOT)} (run: python scripts/gen-synopsis.py)")
        return 1 if stale else 0
    for p, text in wanted().items():
        if p in stale:
            p.write_text(text, encoding="utf-8")
            print(f"written: {p.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
