"""The architecture as a test: imports point only downward, and nobody reaches into private names.

Layers, bottom to top (a module may import its own layer and the ones below):

  1. errors, io, version   2. core   3. solvers   4. models   5. analysis   6. scenes
  7. verification   8. testing   9. cli, __main__

``precise_impact/__init__.py`` is the facade and may import from every layer.  The
check reads the source of the *installed* package (located through
``precise_impact.__file__``), so it checks what users get, including imports inside
functions (a lazy upward import is still an upward dependency).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import precise_impact

PKG = Path(precise_impact.__file__).resolve().parent
TESTS = Path(__file__).resolve().parent
BENCHMARKS = TESTS.parent / "benchmarks"

LAYERS = {
    "errors": 1, "io": 1, "version": 1,
    "core": 2,
    "solvers": 3,
    "models": 4,
    "analysis": 5,
    "scenes": 6,
    "verification": 7,
    "testing": 8,
    "cli": 9, "__main__": 9,
}

# Tests that check the internals of one module on purpose (name: why).
INTERNALS_ALLOWED: dict[str, str] = {}


def _module_name(path: Path) -> str:
    rel = path.relative_to(PKG.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(tree: ast.AST, modname: str, is_pkg: bool):
    """Every (imported module, imported names) in ``tree``, relative imports resolved."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, []
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = modname.split(".")
                base = base if is_pkg else base[:-1]
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            yield mod, [a.name for a in node.names]


def _layer(mod: str) -> int | None:
    parts = mod.split(".")
    if parts[0] != "precise_impact":
        return None
    if len(parts) == 1:
        return 99  # the facade
    return LAYERS.get(parts[1])


def _package_files():
    return sorted(p for p in PKG.rglob("*.py"))


def test_every_subpackage_has_a_layer():
    tops = {p.relative_to(PKG).parts[0].removesuffix(".py") for p in _package_files()} - {"__init__"}
    assert tops <= set(LAYERS), f"modules outside the layer map: {sorted(tops - set(LAYERS))}"


def test_imports_point_only_downward():
    bad = []
    for path in _package_files():
        name = _module_name(path)
        own = _layer(name)
        if own == 99:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for mod, _ in _imports(tree, name, path.name == "__init__.py"):
            target = _layer(mod)
            if target is not None and target > own:
                bad.append(f"{name} (layer {own}) imports {mod} (layer {target})")
    assert not bad, "upward imports:\n" + "\n".join(bad)


def test_no_module_imports_a_private_name_of_another_subpackage():
    bad = []
    for path in _package_files():
        name = _module_name(path)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for mod, names in _imports(tree, name, path.name == "__init__.py"):
            if not mod.startswith("precise_impact"):
                continue
            same_sub = mod.split(".")[:2] == name.split(".")[:2]
            private = [n for n in names if n.startswith("_") and n != "__version__"]
            private_mod = any(p.startswith("_") and p not in ("__init__", "__main__") for p in mod.split(".")[1:])
            if (private or private_mod) and not same_sub:
                bad.append(f"{name} imports {mod}: {private or mod}")
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("folder", [TESTS, BENCHMARKS], ids=["tests", "benchmarks"])
def test_tests_and_benchmarks_use_public_names(folder):
    if not folder.is_dir():
        pytest.skip(f"{folder} is not part of this installation")
    bad = []
    for path in sorted(folder.glob("*.py")):
        if path.name in INTERNALS_ALLOWED:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for mod, names in _imports(tree, path.stem, False):
            if not mod.startswith("precise_impact"):
                continue
            private = [n for n in names if n.startswith("_") and n != "__version__"]
            private_mod = any(p.startswith("_") and p not in ("__init__", "__main__") for p in mod.split(".")[1:])
            if private or private_mod:
                bad.append(f"{path.name}: {mod} {private}")
    assert not bad, "\n".join(bad)


def test_the_checker_sees_an_upward_import(tmp_path):
    """The layering check must be able to fail: a core module importing analysis is caught."""
    tree = ast.parse("from precise_impact.analysis.lyapunov import lyapunov\n")
    found = [(m, _layer(m)) for m, _ in _imports(tree, "precise_impact.core.flow", False)]
    assert found == [("precise_impact.analysis.lyapunov", 5)] and _layer("precise_impact.core.flow") == 2
