"""An effect is one file plus one line: a tenth effect, a constant tilt of the ground
(``tests/data/ground_tilt.py``), is added to a copy of the package as exactly that, and the
command line fits it, offers it to the diagnosis and injects it in the withheld-effect benchmark.

The copy is made in ``tmp_path`` and run in subprocesses (``PYTHONPATH`` = the copy), so the
package itself never has the effect. Each command runs at the smallest settings its options
allow (bundled example; one candidate; benchmark on the bare seed base, one seed, one
magnitude).
"""

from __future__ import annotations

import filecmp
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import gc_ocp

PACKAGE = Path(gc_ocp.__file__).resolve().parent
EFFECT_FILE = Path(__file__).resolve().parent / "data" / "ground_tilt.py"
NEW_FILE = "estimation/components/ground_tilt.py"
REGISTRY_FILE = "estimation/components/__init__.py"
LINE = 'register("ground_tilt", "gc_ocp.estimation.components.ground_tilt:GroundTilt")'
"""The one registration line (docs/effects.md, "Adding an effect")."""


def _files(root: Path) -> set[str]:
    """Paths of the package's files under ``root`` (symlinks followed; no bytecode)."""
    out = set()
    for folder, dirs, files in os.walk(root, followlinks=True):
        dirs[:] = [d for d in dirs if d != "__pycache__"]
        out |= {str((Path(folder) / f).relative_to(root)) for f in files if not f.endswith(".pyc")}
    return out


def _run(copy: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(copy), "MPLBACKEND": "Agg"}
    r = subprocess.run(
        [sys.executable, *args], cwd=copy, env=env, capture_output=True, text=True, timeout=600
    )
    assert r.returncode == 0, f"{args}\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
    return r


@pytest.fixture(scope="module")
def copy(tmp_path_factory) -> Path:
    """A copy of the package with the effect's file and its one registration line."""
    root = tmp_path_factory.mktemp("one_file_effect")
    pkg = root / "gc_ocp"
    shutil.copytree(PACKAGE, pkg, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    shutil.copyfile(EFFECT_FILE, pkg / NEW_FILE)
    init = pkg / REGISTRY_FILE
    text = init.read_text()
    assert text.endswith("\n")
    init.write_text(text + LINE + "\n")
    return root


def test_the_copy_differs_in_exactly_the_file_and_the_line(copy):
    pkg = copy / "gc_ocp"
    ours, theirs = _files(PACKAGE), _files(pkg)
    assert theirs - ours == {NEW_FILE} and not ours - theirs
    changed = {f for f in ours if not filecmp.cmp(PACKAGE / f, pkg / f, shallow=False)}
    assert changed == {REGISTRY_FILE}
    before = (PACKAGE / REGISTRY_FILE).read_text().splitlines()
    assert (pkg / REGISTRY_FILE).read_text().splitlines() == [*before, LINE]
    r = _run(copy, "-c", "import gc_ocp; print(gc_ocp.__file__)")
    assert Path(r.stdout.strip()).resolve() == (pkg / "__init__.py").resolve()


@pytest.mark.slow
def test_the_new_effect_is_fitted_diagnosed_and_injected(copy, tmp_path):
    # it is an effect: last in EFFECTS (registry order), with its benchmark values
    r = _run(
        copy,
        "-c",
        "import json; from gc_ocp.estimation import EFFECTS; "
        "from gc_ocp.bench.withheld import injected_values; "
        "print(json.dumps([EFFECTS, injected_values()['ground_tilt']]))",
    )
    effects, values = json.loads(r.stdout)
    assert effects[-1] == "ground_tilt" and effects[:-1] == list(gc_ocp.estimation.EFFECTS)
    assert values == {"moderate": 0.5, "strong": 1.0}

    # fitted: gc-ocp fit --effects ground_tilt; its block in fit.json, its rows in the summary
    out = tmp_path / "fit"
    r = _run(copy, "-m", "gc_ocp.cli", "fit", "--effects", "ground_tilt", "--out", str(out))
    fit = json.loads((out / "fit.json").read_text())
    assert fit["components"]["ground_tilt"] == "GroundTilt"
    assert fit["provenance"]["options"]["effects"] == "ground_tilt"
    [(trial, block)] = fit["blocks"]["ground_tilt"].items()
    for key in ("tilt_x", "tilt_y"):
        shown = f"ground_tilt {trial} {key} = {block[key + '_deg']:.4g} ± "
        assert shown in r.stdout, r.stdout

    # shown in the report: the pages show a fit's effect blocks by the component's own rows
    r = _run(
        copy,
        "-c",
        "import json; from gc_ocp.estimation.result import EstimationResult; "
        "from gc_ocp.html.fit_tables import effect_blocks; "
        f"print(json.dumps(effect_blocks(EstimationResult.from_json({str(out / 'fit.json')!r}))))",
    )
    [shown_block] = [b for b in json.loads(r.stdout) if b["name"] == "ground_tilt"]
    assert shown_block["description"] == "GroundTilt"
    assert [label for label, _ in shown_block["rows"]] == [f"{trial} tilt_x", f"{trial} tilt_y"]
    assert all(text.endswith(" deg") for _, text in shown_block["rows"])

    # offered: gc-ocp diagnose --effects ground_tilt ranks it
    out = tmp_path / "diagnosis"
    _run(
        copy,
        "-m",
        "gc_ocp.cli",
        "diagnose",
        "--effects",
        "ground_tilt",
        "--null-draws",
        "4",
        "--out",
        str(out),
    )
    d = json.loads((out / "diagnosis.json").read_text())
    assert [row["effect"] for row in d["ranking"]] == ["ground_tilt"]
    assert "<b>ground_tilt</b>" in (out / "report.html").read_text(encoding="utf-8")

    # injected: gc-ocp benchmark-diagnosis --effects ground_tilt, the smallest run; its truth
    out = tmp_path / "benchmark"
    _run(
        copy,
        *("-m", "gc_ocp.cli", "benchmark-diagnosis", "--effects", "ground_tilt"),
        *("--base", "seed", "--seeds", "1", "--magnitude", "moderate"),
        *("--candidates", "ground_tilt", "--out", str(out)),
    )
    res = json.loads((out / "confusion.json").read_text())
    assert res["settings"]["values"] == {"ground_tilt": {"moderate": 0.5, "strong": 1.0}}
    [case] = res["cases"]
    assert (case["truth"], case["magnitude"], case["value"]) == ("ground_tilt", "moderate", 0.5)
    [row] = case["ranking"]
    # the data were generated with the tilt and the candidate is that tilt: it must shrink the
    # held-out error (any sign of a broken injection, e.g. the truth without it, fails here)
    assert row["effect"] == "ground_tilt" and row["heldout_rms_reduction_pct"] > 0, row
    r = _run(
        copy,
        "-c",
        "import json, numpy as np; from gc_ocp.bench import withheld as w; "
        "t = w.truth_model('ground_tilt', 'moderate', w.base_truth('seed'), "
        "w.motion('seed', 'ground_tilt'), np.random.default_rng(0)); "
        "print(json.dumps([[type(c).__name__ for c in t], "
        "[list(map(float, v)) for v in t[-1].fixed.values()]]))",
    )
    types, tilts = json.loads(r.stdout)
    assert types == ["ContactLaw", "GroundTilt"]
    assert sorted(abs(a) for v in tilts for a in v) == pytest.approx(
        [0.5 * 3.141592653589793 / 180] * 2, rel=1e-12
    )  # both angles of the one trial at 0.5 deg (degrees to radians, round-off only)
