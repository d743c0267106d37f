"""The code a newcomer copies from README.md and docs/ is current: every ```python block parses,
every gc_ocp name it imports or reaches (``gc_ocp.export.opensim``) exists, and the blocks that
need no trial run as written. A walk through the docs as a new user (2026-12-03) found no stale
name; this keeps it so (a renamed function otherwise breaks only the reader's copy)."""

from __future__ import annotations

import ast
import importlib
import re
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)

# blocks that need no trial, fit or cluster: run as written (file name, first line)
RUNNABLE = {
    ("architecture.md", "from gc_ocp.estimation import ContactLaw"),
    ("effects.md", "from gc_ocp.estimation import base_model"),
}


def _blocks():
    for page in PAGES:
        for k, m in enumerate(BLOCK.finditer(page.read_text(encoding="utf-8"))):
            yield pytest.param(page.name, textwrap.dedent(m.group(1)), id=f"{page.name}-{k}")


def _resolve(dotted: str):
    """``gc_ocp.a.b.c``: import the longest module prefix, then getattr the rest."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError:
            continue
        for name in parts[i:]:
            obj = getattr(obj, name)
        return obj
    raise ModuleNotFoundError(dotted)


def _names(tree: ast.AST) -> set[str]:
    """Every gc_ocp name the code imports (``from gc_ocp.x import y``: ``gc_ocp.x.y``) or
    reaches by attribute (``gc_ocp.x.y(...)``), or through a name it imported from gc_ocp."""
    alias: dict[str, str] = {"gc_ocp": "gc_ocp"}  # a block may lean on an earlier one's import
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("gc_ocp"):
            for a in node.names:
                out.add(f"{node.module}.{a.name}")
                alias[a.asname or a.name] = f"{node.module}.{a.name}"
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("gc_ocp"):
                    out.add(a.name)
                    alias[a.asname or a.name.split(".")[0]] = a.asname and a.name or "gc_ocp"
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            chain, cur = [], node
            while isinstance(cur, ast.Attribute):
                chain.append(cur.attr)
                cur = cur.value
            if isinstance(cur, ast.Name) and cur.id in alias:
                out.add(".".join([alias[cur.id], *reversed(chain)]))
    return out


def test_a_stale_name_is_caught():
    """The check itself: a name gc_ocp lacks fails, through an import or an attribute."""
    for code in ("gc_ocp.no_such_function()", "from gc_ocp.diagnosis import no_such"):
        [dotted] = [n for n in _names(ast.parse(code)) if "no_such" in n]
        with pytest.raises((AttributeError, ImportError)):
            _resolve(dotted)


@pytest.mark.parametrize("page, code", list(_blocks()))
def test_a_doc_example_names_only_what_exists(page, code):
    if code.lstrip().startswith("register("):  # a line of components/__init__.py, shown
        code = "from gc_ocp.estimation.components import register\n" + code
    tree = ast.parse(code)
    for dotted in sorted(_names(tree)):
        # an attribute of a result (``report.result``) is not reached here: only gc_ocp's names
        try:
            _resolve(dotted)
        except (AttributeError, ModuleNotFoundError) as e:  # the stale name, said
            raise AssertionError(f"{page}: {dotted} does not exist ({e})") from None
    first = code.strip().splitlines()[0]
    if any(page == p and first.startswith(s) for p, s in RUNNABLE):
        exec(compile(tree, f"<{page}>", "exec"), {})


def test_the_runnable_doc_examples_are_found():
    """Each block named in RUNNABLE is still in its page (so a rewrite does not skip it)."""
    found = {(p, c.strip().splitlines()[0]) for p, c in (x.values for x in _blocks())}
    for page, start in RUNNABLE:
        assert any(p == page and line.startswith(start) for p, line in found), (page, start)


CONFLICT = re.compile(r"^(<{7} |={7}$|>{7} )", re.M)


def test_no_page_or_source_keeps_a_merge_conflict():
    """A merge's conflict markers were committed in docs/data_formats.md (found 2026-12-03):
    both versions of a table row shown to the reader. Every tracked text file of the repository
    is free of them."""
    import subprocess

    files = subprocess.run(
        ["git", "ls-files", "*.md", "*.py", "*.toml", "*.ipynb", "*.cfg", "Makefile"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    assert files  # the listing worked (a clone, not an export without .git)
    kept = [f for f in files if CONFLICT.search((ROOT / f).read_text(encoding="utf-8"))]
    assert not kept, kept
