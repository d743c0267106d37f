"""The ``>>>`` examples of gc_ocp's docstrings run and print what they show.

Every module of the package whose source holds ``>>>`` is found by walking the package (no
list to keep up to date: a new module with examples is tested as it lands). Each module's
examples run with :class:`doctest.DocTestRunner` and no option flags beyond the examples' own
directives, so they pass under plain ``python -m doctest`` and ``pytest --doctest-modules``
alike. doctest's finder reads the module's docstring and, recursively, those of the classes,
functions and methods the module defines (not those it imports: each docstring runs once, in
its own module); :func:`test_every_docstring_example_is_collected_once` checks both against the
sources. An example marked ``# doctest: +SKIP`` (external data, minutes of fits) follows a
``>>> # skipped: <why>`` line and is still compiled, so it at least stays valid Python.

Each docstring's examples run in their own namespace, so an example needing a trial loads the
bundled one and computes its kinematics (3 s); fits use the seed's model where the example is
not about the model. The whole module takes about 75 s on the 2-core dev machine, no module's
examples more than 15 s.
"""

from __future__ import annotations

import ast
import doctest
import importlib
import io
import pkgutil
from pathlib import Path

import pytest

import gc_ocp


def _modules_with_examples() -> list[tuple[str, Path]]:
    """(module name, file) of every gc_ocp module whose source holds ``>>>``; walked without
    importing anything (collection stays cheap on every xdist worker)."""
    found = []

    def walk(path: list[str], prefix: str) -> None:
        for info in pkgutil.iter_modules(path, prefix):
            spec = info.module_finder.find_spec(info.name)
            origin = Path(spec.origin)
            if origin.suffix == ".py" and ">>>" in origin.read_text(encoding="utf-8"):
                found.append((info.name, origin))
            if info.ispkg:
                walk(list(spec.submodule_search_locations), info.name + ".")

    found_top = Path(gc_ocp.__file__)
    if ">>>" in found_top.read_text(encoding="utf-8"):
        found.append(("gc_ocp", found_top))
    walk(list(gc_ocp.__path__), "gc_ocp.")
    return sorted(found)


MODULES = _modules_with_examples()


def test_modules_with_examples_are_found():
    # guards the walk itself: an empty list would turn the test below into one skipped test
    names = [name for name, _ in MODULES]
    assert "gc_ocp.geometry" in names, names
    assert "gc_ocp.io.processing" in names, names  # a module of a subpackage
    assert "gc_ocp.io" in names, names  # a package's __init__


def _docstrings_with_examples(name: str, path: Path) -> dict[str, int]:
    """{the name doctest gives it: line} of every docstring of ``path`` that holds ``>>>``: the
    module's, its classes', functions' and methods' (at any depth), and also those doctest
    cannot reach (a nested function's, an attribute's string after an assignment), so that the
    test below names them instead of letting their examples never run."""
    found = {}

    def visit(node, qual: str) -> None:
        body = getattr(node, "body", [])
        for i, child in enumerate(body):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                sub = f"{qual}.{child.name}"
                doc = ast.get_docstring(child, clean=False)
                if doc and ">>>" in doc:
                    found[sub] = child.lineno
                visit(child, sub)
            elif (
                i > 0
                and isinstance(child, ast.Expr)
                and isinstance(child.value, ast.Constant)
                and isinstance(child.value.value, str)
                and ">>>" in child.value.value
            ):
                found[f"{qual} (the string after line {body[i - 1].lineno})"] = child.lineno

    tree = ast.parse(path.read_text(encoding="utf-8"))
    doc = ast.get_docstring(tree, clean=False)
    if doc and ">>>" in doc:
        found[name] = 1
    visit(tree, name)
    return found


def test_every_docstring_example_is_collected_once():
    # DocTestFinder recurses into a module's own functions and classes (and their methods) and
    # skips what the module imported (``_from_module``), so a package's __init__ re-exporting a
    # function does not run its examples a second time; both are checked here against the
    # sources, which is what a reader of help() sees
    where: dict[tuple, list[str]] = {}
    for name, path in MODULES:
        module = importlib.import_module(name)
        tests = doctest.DocTestFinder(exclude_empty=True).find(module, name)
        collected = {t.name for t in tests}
        missing = sorted(set(_docstrings_with_examples(name, path)) - collected)
        assert not missing, (
            f"{path}: doctest never reaches the examples of {missing}; move them into a "
            "docstring of the module, or of one of its top-level classes or functions"
        )
        for t in tests:
            # a property has no line number: its text tells it apart
            where.setdefault((t.filename, t.lineno, t.docstring), []).append(t.name)
    twice = [v for v in where.values() if len(v) > 1]
    assert not twice, f"docstrings collected more than once: {twice}"
    names = {n for v in where.values() for n in v}
    # a class's and a function's examples, found in the module that defines them (Weights is
    # also in gc_ocp.estimation's namespace, which must not collect it a second time)
    assert {"gc_ocp.estimation.problem.Weights", "gc_ocp.stance.trial_stances"} <= names


@pytest.mark.parametrize(("name", "path"), MODULES, ids=[name for name, _ in MODULES])
def test_docstring_examples(name, path, tmp_path, monkeypatch):
    module = importlib.import_module(name)
    tests = doctest.DocTestFinder(exclude_empty=True).find(module, name)
    n_examples = sum(len(t.examples) for t in tests)
    assert n_examples, (
        f"{path} holds '>>>' but doctest finds no example in it: an example doctest cannot "
        "reach (a nested function, a comment, an object imported from elsewhere) never runs; "
        "move it into a module, class or function docstring of this module"
    )
    for t in tests:
        for ex in t.examples:
            if ex.options.get(doctest.SKIP):
                where = f"{path}, line {(t.lineno or 0) + ex.lineno + 1}"
                try:
                    compile(ex.source, where, "single")
                except SyntaxError as e:
                    pytest.fail(f"skipped example at {where} is not valid Python: {e}\n{ex.source}")
                # a comment line is no example to doctest: it is read from the docstring
                above = t.docstring.splitlines()[: ex.lineno]
                if not any(line.strip().startswith(">>> # skipped: ") for line in above):
                    pytest.fail(
                        f"skipped example at {where} does not say why: put a line "
                        "'>>> # skipped: <why>' before it\n" + ex.source
                    )
    monkeypatch.chdir(tmp_path)  # an example that writes a file writes it here
    report = io.StringIO()
    runner = doctest.DocTestRunner(verbose=False)
    failed = attempted = 0
    for t in tests:
        r = runner.run(t, out=report.write)
        failed, attempted = failed + r.failed, attempted + r.attempted
    if failed:
        pytest.fail(
            f"{failed} of {attempted} docstring examples of {name} ({path}) "
            "failed; fix the example (or the code, if the example shows a bug). Rerun one "
            f"module with: python -m pytest --doctest-modules {path} -n 0\n\n" + report.getvalue(),
            pytrace=False,
        )
