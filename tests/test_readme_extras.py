"""The README's set-up installs what its examples use (issue 35 item 7a).

``pip install -e .`` then ``precise-impact budget`` exited 2 ("needs SALib"): the set-up line's
extras must cover every optional package a README example needs.  Fast: the set-up line and the
examples are read from README.md (test_readme_sequence's parser), the extras from pyproject.toml.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from test_readme_sequence import readme_commands

ROOT = Path(__file__).resolve().parents[1]

#: The optional packages a command needs (its OptionalDependencyError: lab/budget.py SALib,
#: lab/attractor.py -> analysis/lyapunov/timeseries.py scipy, lab/netlist.py spicelib for .raw).
NEEDS = {
    "budget": {"SALib"},
    "capture score": {"scipy"},
    "spice score": {"spicelib"},
}


def _setup_extras() -> set[str]:
    """The extras named by the README's ``pip install -e .[...]`` set-up command."""
    pips = [c for c in readme_commands() if c.startswith("pip install -e")]
    assert len(pips) == 1, pips
    m = re.search(r"\.\[([^\]]*)\]", pips[0])
    return {e.strip() for e in m.group(1).split(",")} if m else set()


def _packages(extras: set[str]) -> set[str]:
    deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    deps = deps["optional-dependencies"]
    out = set()
    for e in extras:
        out |= {re.split(r"[<>=\[ ;]", d, maxsplit=1)[0] for d in deps[e]}
    return out


def test_readme_setup_installs_what_its_examples_use():
    have = _packages(_setup_extras())
    used = [c for c in readme_commands() if c.startswith("precise-impact ")]
    missing = {
        cmd: NEEDS[key] - have
        for cmd in used
        for key in NEEDS
        if cmd.startswith(f"precise-impact {key} ") and NEEDS[key] - have
    }
    assert not missing, f"README examples need packages its set-up does not install: {missing}"


def test_the_needs_are_readme_examples():
    used = [c for c in readme_commands() if c.startswith("precise-impact ")]
    for key in NEEDS:
        assert any(c.startswith(f"precise-impact {key} ") for c in used), key
