"""The ``>>>`` examples of gc_ocp's docstrings run and print what they show.

Every module of the package whose source holds ``>>>`` is found by walking the package (no
list to keep up to date: a new module with examples is tested as it lands). Each module's
examples run with :class:`doctest.DocTestRunner` and no option flags beyond the examples' own
directives, so they pass under plain ``python -m doctest`` and ``pytest --doctest-modules``
alike. An example marked ``# doctest: +SKIP`` (external data, minutes of fits; the reason is a
comment beside it) is still compiled, so it at least stays valid Python.
"""

from __future__ import annotations

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
