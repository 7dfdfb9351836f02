"""Packaging claims that must stay true: Python and dependency floors, the version, progress on
stderr."""

from __future__ import annotations

import io
import re
import subprocess
import sys
import tomllib
from importlib import metadata
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.specifiers import SpecifierSet

import precise_impact
from precise_impact.io import progress as prog

CHECKOUT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((CHECKOUT / "pyproject.toml").read_text(encoding="utf-8"))
PROJECT = PYPROJECT["project"]


def _floors() -> dict[str, str]:
    """Every declared dependency (runtime, test, dask, bench extras) -> its floor."""
    reqs = list(PROJECT["dependencies"])
    for extra in ("test", "dask", "bench"):
        reqs += PROJECT["optional-dependencies"][extra]
    floors = {}
    for r in map(Requirement, reqs):
        lows = [s.version for s in r.specifier if s.operator == ">="]
        assert len(lows) == 1, f"{r}: every dependency needs exactly one floor (>=)"
        floors[r.name.lower()] = lows[0]
        if "distributed" in r.extras:  # dask[distributed]: the extra comes at the same version
            floors["distributed"] = lows[0]
    return floors


def _release(v: str) -> tuple[int, ...]:
    parts = [int(x) for x in re.findall(r"\d+", v)[:3]]
    return tuple(parts + [0] * (3 - len(parts)))


def test_lowest_constraints_pin_exactly_the_floors():
    """.ci/lowest-constraints.txt (what CI installs) pins each declared floor, no more, no less."""
    pins = {}
    for line in (CHECKOUT / ".ci" / "lowest-constraints.txt").read_text().splitlines():
        line = line.split("#")[0].strip()
        if line:
            name, _, version = line.partition("==")
            pins[name.strip().lower()] = version.strip()
    floors = _floors()
    assert set(pins) == set(floors)
    assert {n: _release(v) for n, v in pins.items()} == {n: _release(v) for n, v in floors.items()}


def test_requires_python_is_true():
    """Modules importing tomllib (3.11+) without a fallback need requires-python to exclude 3.10."""
    spec = SpecifierSet(PROJECT["requires-python"])
    src = Path(precise_impact.__file__).parent
    unguarded = [
        p.relative_to(src).as_posix()
        for p in src.rglob("*.py")
        if re.search(r"^import tomllib|^from tomllib", p.read_text(encoding="utf-8"), re.M)
    ]
    if unguarded:
        assert not spec.contains("3.10"), (unguarded, str(spec))
    assert spec.contains(".".join(map(str, sys.version_info[:2])))


def test_version_is_the_one_in_pyproject():
    assert "version" not in PROJECT.get("dynamic", [])
    assert precise_impact.__version__ == metadata.version("precise_impact") == PROJECT["version"]
    literal = re.compile(r"""__version__\s*=\s*["']\d+\.\d+""")  # a release written a second time
    src = Path(precise_impact.__file__).parent
    assert not [p for p in src.rglob("*.py") if literal.search(p.read_text(encoding="utf-8"))]


class _Stream(io.StringIO):
    def __init__(self, tty: bool):
        super().__init__()
        self._tty = tty

    def isatty(self) -> bool:
        return self._tty


def _run(monkeypatch, tty: bool, enabled, n: int = 200, interval=None) -> tuple[str, str]:
    err, out = _Stream(tty), _Stream(tty)
    monkeypatch.setattr(sys, "stderr", err)
    monkeypatch.setattr(sys, "stdout", out)
    bar = prog.Progress(n, "items", enabled, interval=interval)
    for i in range(1, n + 1):
        bar.update(i)
    bar.close()
    prog.say("a line", enabled)
    return err.getvalue(), out.getvalue()


def test_progress_silent_off_a_terminal_unless_asked(monkeypatch):
    assert _run(monkeypatch, tty=False, enabled=None) == ("", "")
    assert _run(monkeypatch, tty=True, enabled=False) == ("", "")
    err, out = _run(monkeypatch, tty=False, enabled=True)
    lines = err.splitlines()
    # asked for: whole lines, throttled (200 updates in well under LINE_INTERVAL = 5 s)
    assert out == "" and "\r" not in err
    assert lines[0] == "  items: 1/200 (0.0 s)" and lines[-1] == "a line"
    assert "200/200" in lines[-2] and len(lines) < 10


def test_progress_on_a_terminal_redraws_one_line(monkeypatch):
    err, out = _run(monkeypatch, tty=True, enabled=None)
    assert out == ""
    assert err.count("\n") == 2  # the finished bar, then the said line
    assert err.startswith("\r  items [") and "] 200/200" in err.split("\n")[0].split("\r")[-1]


def test_progress_close_shows_a_throttled_last_count(monkeypatch):
    err = _Stream(False)
    monkeypatch.setattr(sys, "stderr", err)
    bar = prog.Progress(10, "tiles", True, interval=3600.0)
    for i in range(1, 5):  # a resumed/partial run stops at 4 of 10
        bar.update(i)
    bar.close()
    assert [line.split(" (")[0] for line in err.getvalue().splitlines()] == [
        "  tiles: 1/10",
        "  tiles: 4/10",
    ]


def test_citation_names_the_same_version():
    """CITATION.cff must state a version; it has to be the one written in pyproject."""
    cff = (CHECKOUT / "CITATION.cff").read_text(encoding="utf-8")
    stated = re.findall(r"^version:\s*['\"]?([^'\"\s]+)", cff, re.M)
    assert stated == [PROJECT["version"]]


def test_the_wheel_lists_every_package_and_ships_reference_data():
    """pyproject lists the packages by hand (the data package maps the top-level reference_data/):
    the list must be exactly the packages under src/ plus that one, or a new subpackage would be
    left out of the wheel."""
    src = CHECKOUT / "src"
    if not src.is_dir():
        pytest.skip("not a checkout")
    found = {
        p.parent.relative_to(src).as_posix().replace("/", ".") for p in src.rglob("__init__.py")
    }
    listed = set(PYPROJECT["tool"]["setuptools"]["packages"])
    assert listed == found | {"precise_impact.data.reference"}
    assert (
        PYPROJECT["tool"]["setuptools"]["package-dir"]["precise_impact.data.reference"]
        == "reference_data"
    )
    assert (CHECKOUT / "reference_data" / "single-0.712" / "manifest.json").is_file()
    assert not (src / "precise_impact" / "data").exists(), (
        "one copy of the datasets, at the top level"
    )


#: What the repository's top level holds: the design card's five (pyproject.toml, src, tests,
#: reference_data, README.md), the project's papers (CHANGELOG, LICENSE, CITATION), its docs,
#: benchmarks and scripts, CI's directory and git's files.  A figure a doctest left at the root
#: was committed twice (issue 36): a new entry must be added here on purpose.
ROOT_ENTRIES = {
    "pyproject.toml",
    "src",
    "tests",
    "reference_data",
    "README.md",
    "CHANGELOG.md",
    "LICENSE",
    "CITATION.cff",
    "docs",
    "benchmarks",
    "scripts",
    ".ci",
    ".gitignore",
    ".gitattributes",
}


def test_nothing_at_the_repository_root_but_what_it_needs():
    if not (CHECKOUT / ".git").exists():
        pytest.skip("not a git checkout")
    out = subprocess.run(
        ["git", "-C", str(CHECKOUT), "ls-files"], capture_output=True, text=True, check=True
    ).stdout
    tracked = {line.split("/", 1)[0] for line in out.splitlines() if line}
    assert tracked <= ROOT_ENTRIES, sorted(tracked - ROOT_ENTRIES)
