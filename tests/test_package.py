"""The package as a user meets it: the public API, and a module graph without import cycles."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import gc_ocp

ROOT = Path(gc_ocp.__file__).resolve().parent


@pytest.mark.parametrize("name", [n for n in gc_ocp.__all__ if n != "__version__"])
def test_public_names_resolve(name):
    assert getattr(gc_ocp, name) is not None


def _fresh(code: str) -> str:
    """What ``code`` prints in a fresh interpreter (nothing imported before it)."""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return out.stdout.strip()


def test_estimation_is_importable_as_documented():
    code = "from gc_ocp.estimation import build_estimation, solve, full_model; print('ok')"
    assert _fresh(code) == "ok"


def test_readme_examples_work_on_a_fresh_interpreter():
    """``import gc_ocp`` then any layer by attribute (the README's model_from_names example),
    without an earlier call having imported it."""
    code = (
        "import gc_ocp\n"
        "m = gc_ocp.estimation.model_from_names(['friction'], base=gc_ocp.estimation.base_model())\n"
        "print([c.name for c in m], 0 < gc_ocp.diagnosis.ALPHA < 1, gc_ocp.fit.__name__)"
    )
    assert _fresh(code) == "['contact', 'sole', 'pose', 'belt', 'friction'] True fit"


CORE = "gc_ocp.estimation"
"""The estimator's core: it knows stances, never files."""
FILE_LAYERS = ("gc_ocp.io", "gc_ocp.kinematics", "gc_ocp.workflow", "gc_ocp.diagnosis")


def _closure(graph: dict[str, set[str]], roots) -> set[str]:
    """Every module ``roots`` import, directly or not (importing ``a.b.c`` runs ``a.b`` too)."""
    seen, todo = set(), list(roots)
    while todo:
        m = todo.pop()
        if m in seen:
            continue
        seen.add(m)
        parts = m.split(".")
        todo += [".".join(parts[:k]) for k in range(2, len(parts))]
        todo += graph.get(m, ())
    return seen


def test_the_estimation_core_imports_no_io():
    """Statically (every import statement, function-level ones included) and at run time."""
    graph = _import_graph()
    core = [m for m in graph if m == CORE or m.startswith(CORE + ".")]
    assert len(core) > 10  # the core was found
    leaks = sorted(m for m in _closure(graph, core) if m.startswith(FILE_LAYERS))
    assert not leaks, f"the estimation core reaches {leaks}"
    code = (
        "import sys, importlib, pkgutil, gc_ocp.estimation as e\n"
        "for m in pkgutil.walk_packages(e.__path__, 'gc_ocp.estimation.'):\n"
        "    importlib.import_module(m.name)\n"
        f"print(sorted(m for m in sys.modules if m.startswith({FILE_LAYERS!r})))"
    )
    assert _fresh(code) == "[]"


def test_the_closure_sees_a_file_layer():
    """The check above can fail: the workflow layer does reach io."""
    graph = _import_graph()
    assert "gc_ocp.io.consistency" in _closure(graph, ["gc_ocp.workflow.fitting"])


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _import_graph() -> dict[str, set[str]]:
    """``{module: modules of gc_ocp it imports}`` from every import statement (function-level
    ones included: a cycle hidden inside a function is still a cycle)."""
    modules = {_module_name(p): p for p in ROOT.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for mod, path in modules.items():
        is_pkg = path.name == "__init__.py"
        deps = set()
        for node in ast.walk(ast.parse(path.read_text())):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    pkg = mod.split(".") if is_pkg else mod.split(".")[:-1]
                    pkg = pkg[: len(pkg) - node.level + 1]
                    base = ".".join([*pkg, base] if base else pkg)
                targets = [
                    f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base
                    for a in node.names
                ]
            for t in targets:
                while t and t not in modules:
                    t = t.rpartition(".")[0]
                if t and t != mod:
                    deps.add(t)
        graph[mod] = deps
    return graph


def test_no_import_cycle():
    """Tarjan's strongly connected components of the module graph: all of size one. (A package's
    ``__init__`` importing its submodules is an edge like any other.)"""
    graph = _import_graph()
    index, low, stack, on, cycles = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    sys.setrecursionlimit(10_000)
    for v in graph:
        if v not in index:
            visit(v)
    assert len(graph) > 30  # the graph was read, function-level and relative imports included
    assert "gc_ocp.estimation.frame" in graph["gc_ocp.estimation.problem"]
    assert not cycles, cycles


def test_shipped_marker_sets_are_files_of_the_package():
    """Not a symlink out of the package: a copied or installed tree without the link's target
    would silently fall back to landmark recognition (a different fit)."""
    from gc_ocp.model.markerset import MARKERSET_DIR, available_markersets

    assert MARKERSET_DIR.is_dir() and not MARKERSET_DIR.is_symlink()
    assert MARKERSET_DIR.resolve().is_relative_to(ROOT)
    assert available_markersets() == ["gait2392", "plugingait", "rajagopal"]


@pytest.mark.parametrize(
    "name",
    ["Component", "Weights", "IpoptOptions", "Param", "StanceData", "EstimationResult"]
    + ["InputError", "SolveError"],
)
def test_public_classes_show_an_example_with_names_that_exist(name):
    """``help(gc_ocp.X)`` of a class a user builds, receives or catches shows how (an example:
    a ``>>>`` doctest, which tests/test_docstring_examples.py runs), and every ``gc_ocp.<name>``
    the docstring uses is one the package has."""
    import re

    doc = getattr(gc_ocp, name).__doc__
    assert "\n    >>> " in doc
    used = set(re.findall(r"\bgc_ocp\.(\w+)", doc))
    assert used and all(hasattr(gc_ocp, n) for n in used), used
