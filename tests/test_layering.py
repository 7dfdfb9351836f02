"""The architecture as a test: imports point only downward, and nobody reaches into private names.

Layers, bottom to top (a module may import its own layer and the ones below):

  1. errors, io, version   2. core   3. solvers   4. models   5. analysis   6. scenes
  7. verification   8. testing, lab   9. cli, __main__

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
    "errors": 1,
    "signals": 1,  # where an interrupt may be raised: stdlib only, imported by the entry first
    "io": 1,
    "version": 1,
    "core": 2,
    "solvers": 3,
    "models": 4,
    "analysis": 5,
    "scenes": 6,
    "verification": 7,
    "testing": 8,
    "lab": 8,  # what users bring from the bench: builds on verification (the reference, scores)
    "explore": 8,  # the browser's views and the JSON API: built on the public computations
    "cli": 9,
    "__main__": 9,
}

# Tests that check the internals of ONE module on purpose: file -> (that module, why).
# Private names of that module only; every other import of the file must be public.
INTERNALS_ALLOWED: dict[str, tuple[str, str]] = {
    "analysis/test_grazing.py": (
        "precise_impact.solvers.heyoka.variational",
        "drives the variational integrator's impact recorder and grazing depth "
        "(_SaltationRecorder, _Depth) directly: a dropped impact and a 1e18-scaled tangent "
        "cannot be provoked through the API",
    ),
    "test_signals.py": (
        "precise_impact.analysis.scan",
        "drives the pool worker's signal handler (_worker_sigint, _BUSY, _STOPPED) from a frame "
        "of a chosen file: a signal landing inside an import cannot be timed from outside",
    ),
    "verification/test_reproduce_report.py": (
        "precise_impact.verification.reproduce",
        "checks the main job's attractor section (_attractors, _attractor_md) on one figure's "
        "runs (_figure_models): the whole job takes 1-2 minutes (its slow test covers it)",
    ),
}


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
    tops = {p.relative_to(PKG).parts[0].removesuffix(".py") for p in _package_files()} - {
        "__init__"
    }
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
    """Private names (imported, or reached as ``alias._name``) stay inside their subpackage."""
    bad = []
    for path in _package_files():
        name = _module_name(path)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for mod, priv in _private_uses(tree, name, path.name == "__init__.py"):
            if mod.split(".")[:2] != name.split(".")[:2]:
                bad.append(f"{name} uses {mod}: {priv}")
    assert not bad, "\n".join(bad)


def _private(names) -> list[str]:
    return [n for n in names if n.startswith("_") and not (n.startswith("__") and n.endswith("__"))]


def _private_uses(tree: ast.AST, modname: str, is_pkg: bool = False) -> list[tuple[str, str]]:
    """(module, private name) for every private name of ``precise_impact`` a file reaches.

    Three ways: ``from precise_impact.x import _name``; a private module
    (``precise_impact._x``); and attribute access ``alias._name`` where ``alias`` is
    bound by an import from ``precise_impact`` (a module, class or function).
    """
    found, bound = [], {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] == "precise_impact":
                    bound[a.asname or a.name.split(".")[0]] = (
                        a.name if a.asname else "precise_impact"
                    )
        elif (
            isinstance(node, ast.ImportFrom)
            and (node.module or "").split(".")[0] == "precise_impact"
        ):
            for a in node.names:
                bound[a.asname or a.name] = f"{node.module}.{a.name}"
    for mod, names in _imports(tree, modname, is_pkg):
        if mod.split(".")[0] != "precise_impact":
            continue
        found += [(mod, n) for n in _private(names)]
        found += [(mod, mod) for p in mod.split(".")[1:] if _private([p])]
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in bound
        ):
            if _private([node.attr]):
                found.append((bound[node.value.id], node.attr))
    return found


def _is_or_within(target: str, module: str) -> bool:
    """``target`` is ``module`` or a name defined in it (``module.Name``)."""
    return target == module or target.rsplit(".", 1)[0] == module


@pytest.mark.parametrize("folder", [TESTS, BENCHMARKS], ids=["tests", "benchmarks"])
def test_tests_and_benchmarks_use_public_names(folder):
    if not folder.is_dir():
        pytest.skip(f"{folder} is not part of this installation")
    bad = []
    for path in sorted(folder.rglob("*.py")):
        allowed = INTERNALS_ALLOWED.get(path.relative_to(folder).as_posix(), (None, ""))[0]
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for mod, name in _private_uses(tree, path.stem):
            if allowed and _is_or_within(mod, allowed):
                continue
            bad.append(f"{path.relative_to(folder)}: {mod}: {name}")
    assert not bad, "private names of precise_impact used:\n" + "\n".join(bad)


def test_the_internals_whitelist_is_needed():
    """Each whitelisted file really reaches into its module (a stale entry is an error)."""
    for name, (module, why) in INTERNALS_ALLOWED.items():
        path = TESTS / name
        if not path.exists():
            pytest.skip(f"{path} is not part of this installation")
        uses = _private_uses(ast.parse(path.read_text(encoding="utf-8")), path.stem)
        assert any(_is_or_within(m, module) for m, _ in uses), (
            f"{name} no longer needs its exception"
        )
        assert len(why) > 20, name


def test_the_private_name_checker_catches_each_way_in():
    code = (
        "import precise_impact as pi\n"
        "from precise_impact.solvers import heyoka as h\n"
        "from precise_impact.core.params import _helper\n"
        "from precise_impact._old import thing\n"
        "h._CACHE.clear(); pi.__version__; pi.Params\n"
    )
    uses = _private_uses(ast.parse(code), "t")
    assert sorted(uses) == sorted(
        [
            ("precise_impact.core.params", "_helper"),
            ("precise_impact._old", "precise_impact._old"),
            ("precise_impact.solvers.heyoka", "_CACHE"),
        ]
    )


#: The engines' libraries: only ``solvers/`` (and ``models/``, which builds its circuit
#: integrators) may import them; ``analysis/`` holds algorithms that call the engines.
ENGINE_LIBRARIES = ("heyoka", "numba", "llvmlite")
#: Attributes of an engine library that ``analysis/`` may read: versions, for a result's identity.
ENGINE_READ_ONLY = {"__version__"}


def _engine_uses(tree: ast.AST) -> list[str]:
    """Every use of an engine library in ``tree`` other than reading its ``__version__``.

    An import binds a name; each reference to that name must be ``name.__version__``.
    ``from heyoka import ...`` is always a use (it takes the engine's objects).
    """
    bound, found = {}, []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] in ENGINE_LIBRARIES:
                    bound[a.asname or a.name.split(".")[0]] = a.name
        elif isinstance(node, ast.ImportFrom) and not node.level:
            if (node.module or "").split(".")[0] in ENGINE_LIBRARIES:
                found.append(f"from {node.module} import {', '.join(a.name for a in node.names)}")
    ok = set()
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in bound
            and node.attr in ENGINE_READ_ONLY
        ):
            ok.add(id(node.value))
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and node.id in bound and id(node) not in ok:
            found.append(f"{bound[node.id]} ({node.id} at line {node.lineno})")
    return found


def test_analysis_builds_no_integrator_or_compiled_kernel():
    """``analysis/`` keeps the algorithms; heyoka integrators and numba kernels are built in
    ``solvers/`` (issue 23: engines filed by arithmetic).  Reading a version is allowed."""
    bad = []
    for path in _package_files():
        name = _module_name(path)
        if name.split(".")[:2] != ["precise_impact", "analysis"]:
            continue
        bad += [f"{name}: {u}" for u in _engine_uses(ast.parse(path.read_text(encoding="utf-8")))]
    assert not bad, "analysis/ uses an engine library:\n" + "\n".join(bad)


def test_the_engine_checker_sees_each_way_in():
    code = (
        "import heyoka as hy\n"
        "import numba\n"
        "from numba import njit\n"
        "v = hy.__version__\n"
        "ta = hy.taylor_adaptive([], [])\n"
        "k = numba.__version__\n"
    )
    uses = _engine_uses(ast.parse(code))
    assert uses == ["from numba import njit", "heyoka (hy at line 5)"], uses
    assert _engine_uses(ast.parse("import heyoka\nx = heyoka.__version__\n")) == []


def test_the_checker_sees_an_upward_import(tmp_path):
    """The layering check must be able to fail: a core module importing analysis is caught."""
    tree = ast.parse("from precise_impact.analysis.lyapunov import lyapunov\n")
    found = [(m, _layer(m)) for m, _ in _imports(tree, "precise_impact.core.flow", False)]
    assert (
        found == [("precise_impact.analysis.lyapunov", 5)]
        and _layer("precise_impact.core.flow") == 2
    )


# lab/ in sub-layers, bottom to top (a lab module imports only lab modules of a lower or its own
# sub-layer): how a capture is written (the instruments' layouts, for any object with a
# capture's fields), what a capture IS (the data type, its checks and noise measures), how files
# become captures (readers), how a capture is made (the measurement model), what is
# computed from captures (scores, estimators), what is computed from a netlist's run.
LAB_LAYERS = {
    "precise_impact.lab": 0,
    "precise_impact.lab.scope_writers": 1,
    "precise_impact.lab.capture": 2,
    "precise_impact.lab.scope_files": 3,
    "precise_impact.lab.synth": 4,
    "precise_impact.lab.attractor": 5,
    "precise_impact.lab.budget": 6,
    "precise_impact.lab.netlist": 6,
    "precise_impact.lab.identify": 6,
    "precise_impact.lab.predict": 7,
    "precise_impact.lab.diagnose": 7,
}
# Upward edges still there, each a function-local import with its reason (module -> module).
# (none: Capture.save and scope_files.write_capture share lab.scope_writers, below capture)
LAB_UPWARD_KNOWN: dict[tuple[str, str], str] = {}


def _lab_edges(pkg: Path = PKG) -> set[tuple[str, str]]:
    """Every (lab module, lab module it imports), inside functions too."""
    edges = set()
    for path in sorted((pkg / "lab").glob("*.py")):
        name = _module_name(path) if pkg == PKG else "precise_impact.lab." + path.stem
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for mod, names in _imports(tree, name, path.name == "__init__.py"):
            if mod == "precise_impact.lab":  # from precise_impact.lab import module
                targets = [f"{mod}.{n}" for n in names]
            elif mod.startswith("precise_impact.lab."):
                targets = [mod]
            else:
                continue
            edges |= {(name, t) for t in targets if t != name}
    return edges


def _lab_upward(edges) -> list[str]:
    return [
        f"{a} (lab sub-layer {LAB_LAYERS.get(a)}) imports {b} (sub-layer {LAB_LAYERS.get(b)})"
        for a, b in sorted(edges)
        if (a, b) not in LAB_UPWARD_KNOWN
        and (a not in LAB_LAYERS or b not in LAB_LAYERS or LAB_LAYERS[b] > LAB_LAYERS[a])
    ]


def _cycle(edges) -> list[str] | None:
    """One import cycle among ``edges`` (as the list of its modules), or ``None``."""
    graph: dict[str, set[str]] = {}
    for a, b in edges:
        graph.setdefault(a, set()).add(b)
    state: dict[str, int] = {}

    def visit(n: str, path: list[str]) -> list[str] | None:
        state[n] = 1
        for m in sorted(graph.get(n, ())):
            if state.get(m) == 1:
                return path[path.index(m) :] + [m] if m in path else [n, m]
            if not state.get(m):
                found = visit(m, [*path, m])
                if found:
                    return found
        state[n] = 2
        return None

    for n in sorted(graph):
        if not state.get(n):
            found = visit(n, [n])
            if found:
                return found
    return None


def test_lab_modules_have_a_sub_layer_and_import_only_downward():
    edges = _lab_edges()
    names = {a for a, _ in edges} | {b for _, b in edges}
    assert names <= set(LAB_LAYERS), f"lab modules without a sub-layer: {names - set(LAB_LAYERS)}"
    assert not _lab_upward(edges), "upward imports inside lab/:\n" + "\n".join(_lab_upward(edges))
    assert set(LAB_UPWARD_KNOWN) <= edges, "LAB_UPWARD_KNOWN names an edge that is gone"


def test_lab_has_no_import_cycle():
    edges = _lab_edges() - set(LAB_UPWARD_KNOWN)
    assert _cycle(edges) is None, "import cycle inside lab/: " + " -> ".join(_cycle(edges))


def test_the_lab_checker_sees_a_cycle_and_an_upward_import(tmp_path):
    lab = tmp_path / "lab"
    lab.mkdir()
    (lab / "capture.py").write_text("def f():\n    from precise_impact.lab import synth\n")
    (lab / "synth.py").write_text("from precise_impact.lab.capture import f\n")
    edges = _lab_edges(tmp_path)
    assert _cycle(edges) == ["precise_impact.lab.capture", "precise_impact.lab.synth"] + [
        "precise_impact.lab.capture"
    ]
    assert len(_lab_upward(edges)) == 1 and "capture (lab sub-layer 2)" in _lab_upward(edges)[0]
