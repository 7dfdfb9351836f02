"""Help texts state only what is true of the installed package (issue 27).

``reproduce --help`` said ``--quick`` takes "about a minute" (9-16 s measured on a quiet
machine, 83 s on a loaded one: not a property of the flag), ``bench work-precision --quick``
the same, ``accuracy`` "every model and precision" (4 of the 8 models), and ``reference
verify --help`` named "the checkout's reference_data/", which an installed package does not
have.  Here every help text of every command is read from the parser itself and:

* states no duration or speed ratio (those depend on the machine: benchmarks/results has
  them, with the machine they were measured on);
* every ``(default N)`` it prints is the default the parser or the function behind it uses;
* every number of ``reproduce --quick`` is the configuration the job runs (``RUNS``);
* names only paths the installed package has.
"""

from __future__ import annotations

import argparse
import inspect
import re
from fractions import Fraction

import pytest

from precise_impact.analysis.sweep import MAX_WORK
from precise_impact.cli.args import PARAM_FLAGS
from precise_impact.cli.main import build_parser
from precise_impact.core.budget import DEFAULT_MAX_TIME
from precise_impact.core.params import Params
from precise_impact.solvers.certified.single import certify
from precise_impact.verification.reference import shipped_root
from precise_impact.verification.reproduce import RUNS


def _parsers():
    """(command words, parser) of the top level and every subcommand, recursively."""
    out = []

    def walk(parser, name):
        out.append((name, parser))
        for a in parser._actions:
            if isinstance(a, argparse._SubParsersAction):
                for n, sp in a.choices.items():
                    walk(sp, f"{name} {n}")

    walk(build_parser(), "precise-impact")
    return out


PARSERS = _parsers()
IDS = [name for name, _ in PARSERS]

#: A duration or a speed ratio in prose: "about a minute", "~14 s", "10 s", "3.5x".
DURATION = re.compile(
    r"about an? (minute|hour|second)|\b\d+(\.\d+)?\s*(ms|s|sec|seconds?|min|minutes?|h|hours?)\b"
    r"|~\s*\d|\b\d+(\.\d+)?x\b",
    re.I,
)

#: Defaults a flag resolves when its parser default is None: the function's own.
PARAMS = Params.make()
RESOLVED = {dest: getattr(PARAMS, dest) for _, dest, _ in PARAM_FLAGS} | {
    "max_time": DEFAULT_MAX_TIME,
    "max_work": MAX_WORK,
    "target": inspect.signature(certify).parameters["target_radius"].default,
}


def _help_of(parser) -> str:
    return " ".join(parser.format_help().split())


@pytest.mark.parametrize("name, parser", PARSERS, ids=IDS)
def test_help_states_no_duration(name, parser):
    text = _help_of(parser)
    hits = [m.group(0) for m in DURATION.finditer(text)]
    assert not hits, f"{name} --help states {hits}"


@pytest.mark.parametrize("name, parser", PARSERS, ids=IDS)
def test_help_defaults_are_the_defaults(name, parser):
    """``(default N)`` in a flag's help equals the default the command uses."""
    checked = 0
    for a in parser._actions:
        for m in re.finditer(r"default:? (-?\d[\d.e+-]*)\b", a.help or ""):
            claimed = Fraction(m.group(1).rstrip("."))
            if isinstance(a.default, (list, tuple)):  # e.g. sync --k FROM TO N
                assert claimed in [Fraction(str(d)) for d in a.default], (name, a.dest)
                checked += 1
                continue
            if a.default is not None and not isinstance(a.default, bool):
                used = a.default
            else:
                assert a.dest in RESOLVED, f"{name} {a.option_strings}: default {claimed}?"
                used = RESOLVED[a.dest]
            # the (x0: min(0, x_w)) orbit default is a rule, its number the plain default
            assert Fraction(str(used)) == claimed, (name, a.option_strings, claimed, used)
            checked += 1
    if name.endswith(("simulate", "lle", "orbit")):
        assert checked >= 8  # the parameter flags at least


def test_reproduce_quick_help_is_the_quick_configuration():
    rp = dict(PARSERS)["precise-impact reproduce"]
    (quick,) = [a for a in rp._actions if "--quick" in a.option_strings]
    nums = [int(n) for n in re.findall(r"\d+", quick.help)]
    q, f = RUNS[True], RUNS[False]
    expect = [q["periods"], f["periods"], q["sync_periods"], f["sync_periods"], 7]
    expect += [q["ensemble"], f["ensemble"]]
    assert nums == expect, quick.help  # "Fig. 7" is the 7


@pytest.mark.parametrize("name, parser", PARSERS, ids=IDS)
def test_help_names_paths_the_installed_package_has(name, parser):
    text = _help_of(parser)
    assert "checkout" not in text, f"{name} --help names the checkout"
    if "data/reference" in text:
        assert "precise_impact/data/reference" in text
        root = shipped_root()  # installed: that directory; a checkout: reference_data/
        assert root.is_dir() and (
            root.parts[-3:] == ("precise_impact", "data", "reference")
            or root.name == "reference_data"
        )
    assert "reference_data/" not in text, f"{name} --help names the checkout's reference_data/"


def test_accuracy_help_names_what_it_scores():
    from precise_impact.verification.accuracy import CANDIDATES

    help_text = _help_of(dict(PARSERS)["precise-impact"])
    line = help_text[help_text.index("accuracy the paper") :]
    for model, precision in CANDIDATES:
        assert model in line and (precision == "float64" or precision in line)
    assert "every model" not in help_text
