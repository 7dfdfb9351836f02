"""The package's shape as a test (issue 36): short functions, imports at the top, short module
docstrings, measured on the *installed* sources by the definitions the issue used.

- code lines: the lines a function spans after its docstring;
- complexity: 1 + the if/for/while/except/with/assert/comprehension/boolean/match/conditional
  nodes in the function's own body (nested functions and classes count for themselves);
- function-local imports of the package's own modules (``precise_impact...`` or relative);
- module-docstring lines.

ruff (``C901``, ``PLR0915``, ``PLR0912``, ``PLC0415`` in pyproject) flags each new case where it
is written, with a per-line ``noqa`` and a reason where one exists; this test bounds the totals,
so that reasons cannot pile up unseen.  By these definitions the landed main before the issue's
work read 23 functions over 80 code lines, 26 over complexity 20, 142 local package imports
and 1,415 module-docstring lines; after it 4, 3, 32 and 770 (the long and complex ones are the
compiled kernels, one loop each, marked where ruff sees them).
"""

from __future__ import annotations

import ast
import functools
import json
import subprocess
import sys
from pathlib import Path

import precise_impact

PKG = Path(precise_impact.__file__).resolve().parent

#: The issue's "done when" bounds.
MAX_LONG, MAX_COMPLEX, MAX_LOCAL_IMPORTS, MAX_DOC_LINES = 8, 10, 40, 800
LONG, COMPLEX = 80, 20

_BRANCHES = (
    ast.If,
    ast.For,
    ast.AsyncFor,
    ast.While,
    ast.ExceptHandler,
    ast.With,
    ast.AsyncWith,
    ast.Assert,
    ast.comprehension,
    ast.BoolOp,
    ast.match_case,
    ast.IfExp,
)
_SCOPES = (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef)


def _own_nodes(node: ast.AST):
    """The nodes of ``node``'s body, not descending into nested functions or classes."""
    for child in ast.iter_child_nodes(node):
        if isinstance(child, _SCOPES):
            continue
        yield child
        yield from _own_nodes(child)


def _code_lines(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    body = fn.body
    if ast.get_docstring(fn) is not None:
        body = body[1:]
    return fn.end_lineno - body[0].lineno + 1 if body else 0


def _complexity(fn: ast.AST) -> int:
    return 1 + sum(isinstance(n, _BRANCHES) for n in _own_nodes(fn))


def _is_own_import(node: ast.AST) -> bool:
    if isinstance(node, ast.ImportFrom):
        return node.level > 0 or (node.module or "").startswith("precise_impact")
    if isinstance(node, ast.Import):
        return any(a.name.startswith("precise_impact") for a in node.names)
    return False


@functools.cache
def measure(root: Path = PKG) -> dict:
    """The four measures over every module under ``root``, with the offenders named."""
    long, complex_, local, doc = [], [], [], 0
    for path in sorted(root.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        name = path.relative_to(root).as_posix()
        if ast.get_docstring(tree, clean=False) is not None:
            doc += tree.body[0].end_lineno - tree.body[0].lineno + 1
        for fn in ast.walk(tree):
            if not isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            where = f"{name}:{fn.lineno} {fn.name}"
            if (n := _code_lines(fn)) > LONG:
                long.append((n, where))
            if (c := _complexity(fn)) > COMPLEX:
                complex_.append((c, where))
            local += [f"{name}:{i.lineno}" for i in _own_nodes(fn) if _is_own_import(i)]
    return {"long": long, "complex": complex_, "local": local, "doc": doc}


def test_functions_are_short():
    long = measure()["long"]
    assert len(long) <= MAX_LONG, sorted(long, reverse=True)


def test_functions_are_simple():
    complex_ = measure()["complex"]
    assert len(complex_) <= MAX_COMPLEX, sorted(complex_, reverse=True)


def test_the_package_imports_itself_at_the_top():
    local = measure()["local"]
    assert len(local) <= MAX_LOCAL_IMPORTS, local


def test_module_docstrings_are_short():
    assert measure()["doc"] <= MAX_DOC_LINES


def test_the_measures_see_what_they_measure(tmp_path):
    """Each measure counts a planted case (a test of the test: it cannot pass by seeing nothing)."""
    body = "\n".join(f"    x{i} = {i}" for i in range(LONG + 1))
    branches = "\n".join(f"    if x == {i}:\n        return {i}" for i in range(COMPLEX))
    (tmp_path / "m.py").write_text(
        '"""One.\n\nTwo."""\n'
        f'def long():\n    """Doc."""\n{body}\n'
        f"def branchy(x):\n{branches}\n    return -1\n"
        "def lazy():\n    from precise_impact import Params\n    from . import core\n"
        "    import json\n    return Params, core, json\n"
    )
    got = measure(tmp_path)
    assert [w for _, w in got["long"]] == ["m.py:4 long"]
    assert got["long"][0][0] == LONG + 1
    assert [(c, w) for c, w in got["complex"]] == [(COMPLEX + 1, f"m.py:{LONG + 7} branchy")]
    assert len(got["local"]) == 2 and got["doc"] == 3


def test_the_durations_table_names_existing_tests():
    """``tests/durations.json`` (the long tests run first, see ``tests/conftest.py``) names
    tests that exist: its file, and a test function of that name in it (a renamed test would
    lose its place silently; ``PRECISE_IMPACT_RECORD_DURATIONS=1`` rewrites the table)."""
    tests = Path(__file__).resolve().parent
    table = json.loads((tests / "durations.json").read_text(encoding="utf-8"))
    assert table and all(isinstance(s, (int, float)) and s >= 1.0 for s in table.values())
    stale = []
    for nodeid in table:
        path, _, name = nodeid.partition("::")
        file = tests.parent / path
        func = name.split("[", 1)[0].split("::")[-1]
        if not file.is_file() or f"def {func}(" not in file.read_text(encoding="utf-8"):
            stale.append(nodeid)
    assert not stale, stale


def _collected(*args: str) -> list[str]:
    tests = Path(__file__).resolve().parent
    r = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "--collect-only", "-q",
         "--rootdir", str(tests.parent), "-c", str(tests.parent / "pyproject.toml"), *args,
         str(tests / "test_readme_sequence.py")],
        capture_output=True, text=True, timeout=120, cwd=tests.parent,
    )  # fmt: skip
    assert r.returncode == 0, r.stdout[-800:] + r.stderr[-800:]
    return [line.split("::")[-1] for line in r.stdout.splitlines() if "::" in line]


def test_a_covered_test_is_left_out_only_beside_the_test_that_covers_it():
    """``covered_by`` (tests/conftest.py): the README's quick sequence runs in the default
    suite, and is left out of a run that also runs the sequence as written."""
    default = _collected()
    both = _collected("-m", "slow or not slow")
    assert "test_readme_sequence_quick" in default and "test_readme_sequence" not in default
    assert "test_readme_sequence" in both and "test_readme_sequence_quick" not in both
    every = _collected("-m", "slow or not slow", "-k", "quick")  # the covering one deselected
    assert every == ["test_readme_sequence_quick"]


#: Module-scoped fixtures allowed: they hold a server or a browser, torn down with the module.
MODULE_FIXTURES_ALLOWED = {"explore/test_explore_browser.py"}


def test_shared_test_data_are_made_once_per_process():
    """CI runs the longest tests first, one at a time, so a worker leaves and re-enters modules
    all the time and pytest tears a module-scoped fixture down at each exit: a costly one was
    recomputed up to four times a run (docs/development.rst).  Shared data are session-scoped."""
    tests = Path(__file__).resolve().parent
    found = sorted(
        f.relative_to(tests).as_posix()
        for f in tests.rglob("*.py")
        if 'scope="module"' in f.read_text(encoding="utf-8")
    )
    assert set(found) <= MODULE_FIXTURES_ALLOWED | {"test_structure.py"}, found
