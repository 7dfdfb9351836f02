"""The README's command list and the docs' command reference are the parser's, not hand-written."""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

from precise_impact.cli.commands import COMMANDS
from precise_impact.cli.main import build_parser
from precise_impact.cli.synopsis import (
    BEGIN,
    END,
    commands,
    reference_rst,
    replace_between_markers,
    synopsis,
)

CHECKOUT = Path(__file__).resolve().parents[2]
README = CHECKOUT / "README.md"
REFERENCE = CHECKOUT / "docs" / "guide" / "cli_commands.inc"


def test_readme_synopsis_is_generated_from_the_parser():
    text = README.read_text(encoding="utf-8")
    assert replace_between_markers(text, synopsis()) == text, (
        "README.md's command synopsis is stale: run python scripts/gen-synopsis.py"
    )


def test_docs_reference_is_generated_from_the_parser():
    assert REFERENCE.read_text(encoding="utf-8") == reference_rst(), (
        "docs/guide/cli_commands.inc is stale: run python scripts/gen-synopsis.py"
    )
    assert "cli_commands.inc" in (CHECKOUT / "docs" / "guide" / "cli.rst").read_text()


def test_synopsis_has_one_line_per_command():
    lines = synopsis().splitlines()[1:-1]  # inside the fence
    names = [name for name, _, _ in commands()]
    assert len(names) >= len(COMMANDS)  # reference and bench have sub-commands
    for name, helptext, _ in commands():
        (line,) = [ln for ln in lines if ln.startswith(f"precise-impact {name} ")]
        assert line.endswith(helptext)
    # required arguments are shown; a flag added to a command appears in the reference
    assert any(
        ln.startswith("precise-impact sweep --axis NAME MIN MAX N --out DIR") for ln in lines
    )
    assert "``--max-time S``" in reference_rst()


def test_a_changed_parser_changes_the_synopsis():
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    extra = sub.add_parser("frobnicate", help="a command the README does not list")
    extra.add_argument("--level", required=True, metavar="L", help="how much")
    text = README.read_text(encoding="utf-8")
    changed = synopsis(parser)
    assert "precise-impact frobnicate --level L" in changed
    assert replace_between_markers(text, changed) != text
    assert "``--level L (required)``" in reference_rst(parser)


def test_markers_are_required_once():
    with pytest.raises(ValueError, match="synopsis"):
        replace_between_markers("no markers here", "x")
    with pytest.raises(ValueError):
        replace_between_markers(f"{END}\n{BEGIN}\n", "x")
    assert replace_between_markers(f"a\n{BEGIN}\nold\n{END}\nb", "new\n") == (
        f"a\n{BEGIN}\nnew\n{END}\nb"
    )


def test_gen_synopsis_script_checks():
    spec = importlib.util.spec_from_file_location("gen", CHECKOUT / "scripts" / "gen-synopsis.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    assert gen.main(["--check"]) == 0


def test_every_command_module_registers_and_runs():
    """COMMANDS is the one list: each module adds one command dispatching to its own run."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert len(sub.choices) == len(COMMANDS)
    for module, (name, p) in zip(COMMANDS, sub.choices.items(), strict=True):
        assert p.get_default("run") is module.run, name
    ns = parser.parse_args(["reference", "verify"])
    assert (
        ns.run
        is COMMANDS[
            [m.__name__ for m in COMMANDS].index("precise_impact.cli.commands.reference")
        ].run
    )


def test_the_command_table_names_what_each_module_registers():
    """``MODULES`` maps each command to the module that registers it, in ``--help`` order."""
    from precise_impact.cli.commands import MODULES

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    assert list(sub.choices) == list(MODULES)
    for name in MODULES:
        alone = build_parser([name, "--json"])
        only = next(a for a in alone._actions if isinstance(a, argparse._SubParsersAction))
        assert list(only.choices) == [name]
        assert only.choices[name].get_default("run") is sub.choices[name].get_default("run")
    for argv in ([], ["--help"], ["--version"], ["no-such-command"]):  # help and errors: all
        every = next(
            a for a in build_parser(argv)._actions if isinstance(a, argparse._SubParsersAction)
        )
        assert list(every.choices) == list(MODULES)


def test_a_run_imports_its_own_command_only():
    """``precise-impact scenes`` imports the scenes command, not the other 21 (their imports
    cost 0.3-0.9 s per run: the analysis, verification and lab layers)."""
    program = (
        "import sys\n"
        "from precise_impact.cli.main import main\n"
        "assert main(['scenes']) == 0\n"
        "print(sorted(m for m in sys.modules if m.startswith('precise_impact.')))\n"
    )
    r = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-800:]
    loaded = r.stdout.strip().splitlines()[-1]
    assert "precise_impact.cli.commands.scenes" in loaded
    for other in (
        "commands.accuracy",
        "commands.budget",
        "precise_impact.lab.",
        "precise_impact.verification.compare",
    ):
        assert other not in loaded, other
