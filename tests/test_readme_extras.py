"""The README's set-up installs what its examples use (issue 35 item 7a).

``pip install -e .`` then ``precise-impact budget`` exited 2 ("needs SALib"): the set-up line's
extras must cover every optional package a README example needs.  Fast: the set-up line and the
examples are read from README.md (test_readme_sequence's parser), the extras from pyproject.toml.
"""

from __future__ import annotations

from test_readme_sequence import _extra_packages, _readme_extras, readme_commands

#: The optional packages a command needs (its OptionalDependencyError: lab/budget.py SALib,
#: lab/attractor.py -> analysis/lyapunov/timeseries.py scipy, lab/netlist.py spicelib for .raw).
NEEDS = {
    "budget": {"salib"},
    "capture score": {"scipy"},
    "spice score": {"spicelib"},
}


def test_readme_setup_installs_what_its_examples_use():
    have = _extra_packages(_readme_extras())
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
