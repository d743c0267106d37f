"""Fuzzing: damaged copies of a real trial never give a traceback, and never a silent result.

``info`` runs on a seeded sample of damages (hypothesis, derandomised so CI is reproducible);
``fit`` on a few of them, since each fit takes seconds. ``benchmarks/fuzz.py`` runs a large
budget. Properties:

* the command ends with exit 0 (done), 1 (solve failed) or 2 (bad input named): never 3
  (internal error) and never a traceback;
* a ``fit`` that exits 0 on damaged data either names a problem (flags or input checks in
  ``fit.json``) or gives figures within the clean trial's own uncertainty (shared parameters
  within 3 of their standard errors and RMS within 1.5x of the clean fit's).
"""

from __future__ import annotations

import contextlib
import io
import json
import tempfile
from pathlib import Path

import pytest
from fuzz_damage import KINDS, damage

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

DATA = (
    Path(__file__).resolve().parents[1].parent / "shared" / "data" / "opensim_rajagopal_overground"
)
TRC, MOT, MASS = DATA / "motion_capture_walk.trc", DATA / "grf_walk.mot", "85.07"

pytestmark = pytest.mark.skipif(not TRC.exists(), reason="shared data not found")


def run(argv) -> tuple[int, str]:
    from gc_ocp.cli import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(argv)
    return code, err.getvalue()


def check_no_traceback(code: int, err: str, what: str) -> None:
    assert code in (0, 1, 2), f"{what}: exit {code}: {err[-400:]}"
    assert "Traceback" not in err and "internal error" not in err, f"{what}: {err[-400:]}"


damages = st.tuples(st.sampled_from(KINDS), st.tuples(*(st.floats(0, 0.999) for _ in range(3))))


@settings(
    max_examples=30,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=list(HealthCheck),
)
@given(damages)
def test_info_on_damaged_files_never_crashes(d):
    kind, u = d
    with tempfile.TemporaryDirectory() as tmp:
        trc, mot = damage(TRC, MOT, kind, u, Path(tmp))
        code, err = run(["info", str(trc), "--grf", str(mot), "--mass", MASS])
    check_no_traceback(code, err, f"info {kind} {u}")


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    out = tmp_path_factory.mktemp("clean")
    code, err = run(["fit", str(TRC), "--grf", str(MOT), "--mass", MASS, "--out", str(out)])
    assert code == 0, err
    return json.loads((out / "fit.json").read_text())


def silent_and_wrong(d: dict, clean: dict) -> bool:
    """True when a damaged fit names no problem (no input check, no flag the clean fit does not
    have) and its figures leave the clean fit's uncertainty."""
    known = {(f["code"], f["what"]) for f in clean.get("flags", [])}
    if d.get("checks") or {(f["code"], f["what"]) for f in d.get("flags", [])} - known:
        return False
    shared, ref = d["params"].get("shared", {}), clean["params"].get("shared", {})
    for p, v in ref.items():
        if p.endswith("_se") or p not in shared:
            continue
        se = max(ref.get(p + "_se", 0.0), shared.get(p + "_se", 0.0), 1e-12)
        if abs(shared[p] - v) > 3 * se:
            return True
    for side, r in clean["rms"].items():
        if (
            side in d["rms"]
            and d["rms"][side]["superior_force_pct_bw"] > 1.5 * r["superior_force_pct_bw"]
        ):
            return True
    return False


@pytest.mark.slow
@pytest.mark.parametrize(
    "kind,u",
    [
        ("shift_force_time", (0.1, 0.0, 0.0)),
        ("nan_run", (0.9, 0.5, 0.5)),
        ("scale_markers", (0.2, 0, 0)),
    ],
)
def test_fit_on_damaged_files_is_never_silently_wrong(kind, u, clean, tmp_path):
    trc, mot = damage(TRC, MOT, kind, u, tmp_path / "in")
    out = tmp_path / "out"
    code, err = run(["fit", str(trc), "--grf", str(mot), "--mass", MASS, "--out", str(out)])
    check_no_traceback(code, err, f"fit {kind} {u}")
    if code == 0:
        d = json.loads((out / "fit.json").read_text())
        assert not silent_and_wrong(d, clean), f"fit {kind} {u}: exit 0, no flag, figures off"
