"""Input sanity ("no silent wrong answer"): damaged copies (in tmp_path) of the shared real files
end in a clear error or in an excluded stance with its reason; never in a silent wrong result."""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from gc_ocp.errors import InputError, UnitsError
from gc_ocp.io import load_static, load_trial
from gc_ocp.io.c3d import header_frames
from gc_ocp.io.checks import stance_gaps

DATA = (Path(__file__).parents[1] / "../shared/data").resolve()
pytestmark = pytest.mark.skipif(
    not DATA.is_dir(), reason=f"shared real datasets not found at {DATA} (repo checked out alone)"
)
SMALL = DATA / "plugingait_overground" / "test_small.c3d"
RAJ = DATA / "opensim_rajagopal_overground"


def _load(*args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return load_trial(*args, **kw)


# 1. a walking trial given as the static trial --------------------------------------------------
def test_walking_trial_as_static_is_refused():
    walk = _load(RAJ / "motion_capture_walk.trc", RAJ / "grf_walk.mot", mass=85.07)
    with pytest.raises(InputError, match="is not static.*walking trial.*standing"):
        load_static(RAJ / "motion_capture_walk.trc", walk)
    with pytest.raises(InputError, match="test_small.c3d is not static"):
        load_static(SMALL, _load(SMALL))
    # treadmill: the body centre stays put, the feet swing
    tm = DATA / "opensim_gait2392_treadmill"
    walk2 = _load(tm / "subject01_walk1.trc", tm / "subject01_walk1_grf.mot", mass=72.6)
    with pytest.raises(InputError, match="foot markers 2\\d\\d mm"):
        load_static(tm / "subject01_walk1.trc", walk2)
    # real static trials pass
    static = load_static(RAJ / "static_walk_1.trc", walk)
    assert static.stances == ()
    assert load_static(tm / "subject01_static.trc", walk2).stances == ()
    # the static trial says which of its own samples were filled, not the walking trial's
    assert static.marker_filled is not None
    assert static.marker_filled.shape == static.markers.shape[:2]


# 2. a long foot-marker gap inside a stance ----------------------------------------------------
def _trc_with_gap(src: Path, dst: Path, markers: list[str], t0: float, t1: float) -> None:
    lines = src.read_text().splitlines()
    names = [n.strip() for n in lines[3].split("\t")[2:] if n.strip()]
    cols = [2 + 3 * names.index(m) + k for m in markers for k in range(3)]
    for i in range(5, len(lines)):
        cells = lines[i].split("\t")
        if len(cells) > 2 and cells[1].strip() and t0 <= float(cells[1]) <= t1:
            for c in cols:
                cells[c] = ""
            lines[i] = "\t".join(cells)
    dst.write_text("\n".join(lines) + "\n")


def test_foot_marker_gap_in_stance_excludes_or_is_bridged(tmp_path):
    mot = RAJ / "grf_walk.mot"
    # right stance 0.268-1.023 s; a 0.3 s gap of the heel marker in mid-stance
    bridged = tmp_path / "heel_gap.trc"
    _trc_with_gap(RAJ / "motion_capture_walk.trc", bridged, ["R.Heel"], 0.50, 0.79)
    t = _load(bridged, mot, mass=85.07)
    assert [s.label for s in t.stances] == ["right@0.268s", "left@0.836s", "right@1.412s"]
    note = next(n for n in t.load_notes if "R.Heel" in n)
    assert "0.300 s" in note and "bridged by the other right foot markers" in note
    assert "R.MT5" in note and "R.Ankle" in note
    assert stance_gaps(t) == {}

    # heel and ankle missing: toe and MT5 alone (2 markers) do not fix the foot -> excluded
    lost = tmp_path / "heel_ankle_gap.trc"
    _trc_with_gap(RAJ / "motion_capture_walk.trc", lost, ["R.Heel", "R.Ankle"], 0.50, 0.79)
    with pytest.warns(UserWarning, match="right@0.268s excluded"):
        t = load_trial(lost, mot, mass=85.07)
    assert [s.label for s in t.stances] == ["left@0.836s", "right@1.412s"]
    (ex,) = [e for e in t.excluded_stances if e.side == "right"]
    assert '"R.Heel" missing for 0.300 s' in ex.reason and "do not fix the foot" in ex.reason
    assert "0.1 s filled automatically" in ex.reason

    # the function check_for_fit calls sees the gap on a trial whose stances were not filtered
    import dataclasses

    full = dataclasses.replace(
        t, stances=_load(RAJ / "motion_capture_walk.trc", mot, mass=85.07).stances
    )
    assert list(stance_gaps(full)) == ["right@0.268s"]
    # the same gap with the markerset's foot markers given explicitly
    feet = {"right": ["R.Heel", "R.MT5", "R.Toe", "R.Ankle"], "left": []}
    assert list(stance_gaps(full, feet)) == ["right@0.268s"]


def test_real_gap_bridged_in_bts():
    """BTS: RVMH and RIMH are missing during the right stance; RCA, RLM, RMM, RIIT fix the foot."""
    t = _load(DATA / "bts_unipd_5trials" / "Walking1.c3d", mass=95.0)
    assert [s.label for s in t.stances] == ["right@2.432s", "left@3.017s"]
    note = next(n for n in t.load_notes if "RVMH" in n)
    assert "bridged" in note and "RCA" in note and "RIIT" in note


# 3. a truncated C3D ----------------------------------------------------------------------------
@pytest.mark.parametrize("fraction", [0.1, 0.3, 0.99])
def test_truncated_c3d(tmp_path, fraction):
    data = SMALL.read_bytes()
    bad = tmp_path / "truncated.c3d"
    bad.write_bytes(data[: int(len(data) * fraction)])
    assert header_frames(SMALL) == 337
    with pytest.raises(InputError, match=r"announces 337 marker frames but only \d+ .*truncated"):
        load_trial(bad)


def test_cut_in_header_is_clear(tmp_path):
    bad = tmp_path / "cut.c3d"
    bad.write_bytes(SMALL.read_bytes()[:700])
    with pytest.raises(InputError, match="cut.c3d"):
        load_trial(bad)


# 4. metres declared as millimetres -------------------------------------------------------------
def test_metres_declared_as_mm(tmp_path):
    ezc3d = pytest.importorskip("ezc3d")
    c = ezc3d.c3d(str(SMALL))
    c["data"]["points"][:3] /= 1000.0  # values in metres, POINT:UNITS still "mm"
    bad = tmp_path / "metres_as_mm.c3d"
    c.write(str(bad))
    with pytest.raises(UnitsError, match=r"declared in 'mm'.*span only.*metres.*POINT:UNITS"):
        load_trial(bad)


def test_metres_declared_as_mm_trc(tmp_path):
    src = RAJ / "motion_capture_walk.trc"
    lines = src.read_text().splitlines()
    for i in range(5, len(lines)):
        cells = lines[i].split("\t")
        if len(cells) > 2:
            lines[i] = "\t".join(
                cells[:2] + [f"{float(c) / 1000:.6f}" if c.strip() else c for c in cells[2:]]
            )
    bad = tmp_path / "m_as_mm.trc"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(UnitsError, match="TRC Units"):
        load_trial(bad, RAJ / "grf_walk.mot", mass=85.07)


# 5. a Y-up C3D ---------------------------------------------------------------------------------
def test_y_up_c3d_loads(tmp_path):
    src = DATA / "bts_unipd_5trials" / "Walking1.c3d"
    copy = tmp_path / "w.c3d"
    shutil.copy(src, copy)
    t = _load(copy, mass=95.0)
    assert any("vertical axis of w.c3d is +Y, not +Z" in n for n in t.load_notes)
    # README: plate 0 RIGHT 2.433-3.126 s, plate 1 LEFT 3.019-3.714 s
    assert [(s.side, s.plate) for s in t.stances] == [("right", 0), ("left", 1)]
    assert abs(t.stances[0].t_on - 2.433) < 0.01 and abs(t.stances[1].t_off - 3.714) < 0.01
    for s in t.stances:
        p = t.plates[s.plate]
        fz = p.force[(p.time > s.t_on) & (p.time < s.t_off), 2]
        assert 0.8 * t.body_weight < fz.max() < 1.3 * t.body_weight  # vertical = lab Z, upward
    # markers above the floor, head at about body height
    assert np.nanmin(t.markers[..., 2]) > -0.02
    assert 1.3 < np.nanmax(t.markers[..., 2]) < 2.0
    # a Z-up file is untouched
    assert np.array_equal(_load(SMALL).lab_rotation, _load(SMALL).lab_rotation)
    assert not any("vertical axis" in n for n in _load(SMALL).load_notes)
