"""Trial loading on the three shared real datasets, plus synthetic and bad-input cases."""

from __future__ import annotations

import dataclasses
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from gc_ocp.errors import InputError, MarkerError, PlateError, UnitsError
from gc_ocp.gaps import fill_short_gaps
from gc_ocp.io import (
    bundled_example_path,
    describe_trial,
    estimate_belt_speed,
    load_trial,
    require_markers,
    stride_body_weight,
    walking_rotation,
)
from gc_ocp.io._common import rotation_z
from gc_ocp.io.c3d import unloaded_baseline
from gc_ocp.trial import GRAVITY
from gc_ocp.wrench import cop_from_wrench

DATA = (Path(__file__).parents[1] / "../shared/data").resolve()
needs_data = pytest.mark.skipif(
    not DATA.is_dir(), reason=f"shared real datasets not found at {DATA} (repo checked out alone)"
)
C3D = DATA / "plugingait_overground/test_small.c3d"
RAJ = (
    DATA / "opensim_rajagopal_overground/motion_capture_walk.trc",
    DATA / "opensim_rajagopal_overground/grf_walk.mot",
)
G2392 = (
    DATA / "opensim_gait2392_treadmill/subject01_walk1.trc",
    DATA / "opensim_gait2392_treadmill/subject01_walk1_grf.mot",
)
RAJ_MASS, G2392_MASS = 85.07, 72.6  # OpenSim scale setups (not in the files), README

# README stance lists: (side, plate index, t_on, t_off, peak Fz [N])
EXPECTED = {
    "c3d": [
        ("right", 0, 0.406, 1.065, 669),
        ("left", 1, 0.939, 1.616, 658),
        ("right", 3, 1.490, 2.139, 654),
    ],
    "raj": [
        ("right", 0, 0.268, 1.023, 943),
        ("left", 1, 0.837, 1.589, 931),
        ("right", 0, 1.412, 2.167, 941),
    ],
    "g2392": [("right", 0, 0.618, 1.408, 769), ("left", 1, 1.247, 2.017, 811)],
}
# 20 ms: the README times were read by eye/at another threshold; a different threshold in the
# 10-50 N range moves a crossing by a few ms at heel strike but up to ~15 ms at the slow
# toe-off ramp (C3D plate 4 ends 2.123 vs 2.139 s).
TIME_TOL = 0.020


def _load(key):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # expected exclusion warnings are tested separately
        if key == "c3d":
            return load_trial(C3D)
        if key == "raj":
            return load_trial(*RAJ, mass=RAJ_MASS)
        return load_trial(*G2392, mass=G2392_MASS)


@pytest.fixture(scope="module")
def trials():
    if not DATA.is_dir():
        pytest.skip(f"shared real datasets not found at {DATA}")
    return {k: _load(k) for k in EXPECTED}


def _crossings(t, fz, level):
    """Independent reference: first/last sample above ``level`` in each above-level run."""
    above = fz > level
    edges = np.flatnonzero(np.diff(above.astype(int)))
    on = [t[i + 1] for i in edges if not above[i]]
    off = [t[i] for i in edges if above[i]]
    return on, off


@needs_data
@pytest.mark.parametrize("key", list(EXPECTED))
def test_stances_match_readme_and_direct_threshold_crossings(trials, key):
    trial = trials[key]
    got = [(s.side, s.plate, s.t_on, s.t_off) for s in trial.stances]
    assert len(got) == len(EXPECTED[key]), describe_trial(trial)
    for (side, plate, on, off), (e_side, e_plate, e_on, e_off, _) in zip(
        got, EXPECTED[key], strict=True
    ):
        assert (side, plate) == (e_side, e_plate)
        assert abs(on - e_on) < TIME_TOL and abs(off - e_off) < TIME_TOL, (on, off, e_on, e_off)
    for s in trial.stances:  # agreement with a plain threshold crossing: within one sample
        p = trial.plates[s.plate]
        on, off = _crossings(p.time, p.force[:, 2], 20.0)
        dt = 1.0 / p.rate
        assert min(abs(np.array(on) - s.t_on)) <= dt + 1e-9
        assert min(abs(np.array(off) - s.t_off)) <= dt + 1e-9
    assert [s.t_on for s in trial.stances] == sorted(s.t_on for s in trial.stances)


@needs_data
@pytest.mark.parametrize("key", list(EXPECTED))
def test_peak_forces_match_readme(trials, key):
    trial = trials[key]
    for s, (*_, peak) in zip(trial.stances, EXPECTED[key], strict=True):
        p = trial.plates[s.plate]
        sel = (p.time >= s.t_on) & (p.time <= s.t_off)
        assert p.force[sel, 2].max() == pytest.approx(peak, rel=0.02)  # README rounds to 1 N


@needs_data
def test_treadmill_clipped_stances_are_excluded_with_a_reason():
    with pytest.warns(UserWarning, match="clipped"):
        trial = load_trial(*G2392, mass=G2392_MASS)
    assert len(trial.excluded_stances) == 3
    assert all(e.reason.startswith("clipped") for e in trial.excluded_stances)
    assert trial.plates[0].surface_height == pytest.approx(-0.0075, abs=1e-6)  # py column
    speed, text = estimate_belt_speed(trial)
    assert speed == pytest.approx(1.1, abs=0.1) and "ESTIMATE" in text  # README: ~1.1 m/s
    assert not np.any(trial.belt_velocity)  # never applied silently
    t2 = load_trial(*G2392, mass=G2392_MASS, belt_speed=1.1)
    np.testing.assert_array_equal(t2.belt_velocity, [-1.1, 0.0, 0.0])


@needs_data
@pytest.mark.parametrize("key, mass", [("c3d", 63.6), ("raj", RAJ_MASS), ("g2392", G2392_MASS)])
def test_body_weight_matches_stride_impulse(trials, key, mass):
    trial = trials[key]
    assert trial.mass == pytest.approx(mass, abs=1e-4)  # C3D: PROCESSING:Bodymass
    value, t0, t1 = stride_body_weight(trial)
    # 5 %: a real stride is not exactly periodic (speed changes by a few % per stride), the
    # README's own figure for the C3D is 604 N vs 624 N (3 %).
    assert value == pytest.approx(mass * GRAVITY, rel=0.05)
    assert t1 - t0 > 0.8


@needs_data
def test_c3d_subject_units_markers_and_offsets(trials):
    trial = trials["c3d"]
    assert trial.height == pytest.approx(1.58)
    assert "LHEE" in trial.marker_names and "RTOE" in trial.marker_names
    assert not any(n.endswith(("Angles", "Force", "Moment", "Power")) for n in trial.marker_names)
    assert "CentreOfMass" not in trial.marker_names and "PELO" not in trial.marker_names
    assert np.isfinite(trial.markers).all()  # README: no gaps in the real markers
    assert 0.5 < np.nanmax(trial.marker("LFHD")[:, 2]) < 2.0  # metres, not mm
    # plate 3 (index 2) is never loaded and read -31.6 N before the offset removal
    f = trial.plates[2].force
    assert np.linalg.norm(f.mean(axis=0)) < 1.0
    assert np.mean(np.abs(f[:, 2])) < 1.0  # noise std is 0.4 N
    # plate 4 (index 3) read -15.6 N unloaded: check its quiet start too
    assert abs(np.median(trial.plates[3].force[:500, 2])) < 1.0


@needs_data
def test_c3d_plate_reference_is_electrical_centre_below_surface_and_cop_matches_ezc3d(trials):
    import ezc3d

    trial = trials["c3d"]
    c = ezc3d.c3d(str(C3D), extract_forceplat_data=True)
    for i, plate in enumerate(trial.plates):
        pf = c["data"]["platform"][i]
        centre = pf["corners"].T.mean(axis=0) / 1000
        assert plate.reference_kind == "electrical_center"
        assert plate.surface_height == pytest.approx(centre[2])
        # ORIGIN z is 22-43 mm: electrical centre below the surface, under its centre
        depth = plate.surface_height - plate.reference_point[2]
        assert 0.02 < depth < 0.05
        assert np.linalg.norm(plate.reference_point[:2] - centre[:2]) < 0.002
        # ezc3d's moment is about the surface centre: the COP it reports equals the COP from
        # its (force, moment) about the mean corner point (round-off)...
        f_e, m_e = pf["force"].T, pf["moment"].T / 1000
        loaded = f_e[:, 2] > 100
        if not loaded.any():
            continue
        cop_e = pf["center_of_pressure"].T / 1000
        np.testing.assert_allclose(
            cop_from_wrench(f_e, m_e, centre, centre[2])[loaded], cop_e[loaded], atol=1e-9
        )
        # ...and our wrench about the electrical centre gives, on the surface plane, the COP of
        # ezc3d's wrench minus the same unloaded baseline (zero on the zeroed plates 1-2), to
        # round-off. With the opposite ORIGIN sign E would be 4 cm *above* the surface (caught
        # above) and the COP would move by ~ 2 x 43 mm x Fx/Fz (cm), far above 1e-9 m.
        base, _ = unloaded_baseline(np.hstack([f_e, m_e]), 1000.0)
        ref_cop = cop_from_wrench(f_e - base[:3], m_e - base[3:], centre, centre[2], 100.0)
        np.testing.assert_allclose(plate.cop(100.0), ref_cop, atol=1e-9)
        if i in (0, 1):
            assert not base.any()
            np.testing.assert_allclose(plate.cop(100.0)[loaded], cop_e[loaded], atol=1e-9)


@needs_data
def test_opensim_plates_and_frames(trials):
    trial = trials["raj"]
    assert trial.height is None
    assert [p.name for p in trial.plates] == ["grf_right", "grf_left"]
    assert trial.plates[0].reference_kind == "lab_origin"
    np.testing.assert_allclose(
        trial.lab_rotation, [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=0
    )  # Y-up file, already walking +X
    heel = trial.marker("R.Heel")
    assert np.nanmin(heel[:, 2]) > -0.02 and np.nanmin(heel[:, 2]) < 0.1  # Z up, metres
    # COP of a stance is under the stance foot (markers within a foot length)
    s = trial.stances[0]
    assert s.reference_kind == "floor_under_mean_cop"
    assert s.reference_point[2] == pytest.approx(trial.plates[0].surface_height)
    i = np.argmin(abs(trial.marker_time - 0.5 * (s.t_on + s.t_off)))
    assert np.linalg.norm(trial.marker("R.Heel")[i, :2] - s.reference_point[:2]) < 0.3
    # stance_wrench about the stance reference point has (almost) no horizontal moment:
    # it is the floor point under the mean COP, so the moment is the COP excursion x Fz
    w = trial.stance_wrench(s, np.linspace(s.t_on, s.t_off, 50))
    assert np.all(np.isfinite(w))


def _synthetic_walk(direction_deg: float, treadmill: bool):
    t = np.arange(0, 2, 0.01)
    u = np.array([np.cos(np.radians(direction_deg)), np.sin(np.radians(direction_deg))])
    speed = 0.0 if treadmill else 1.2
    names = ["LHEE", "LTOE", "RHEE", "RTOE", "C7"]
    base = np.array([[-0.1, 0.1], [0.1, 0.1], [-0.1, -0.1], [0.1, -0.1], [0.0, 0.0]])
    n = np.array([-u[1], u[0]])
    xy = (speed * t)[:, None, None] * u + base[:, 0, None] * u + base[:, 1, None] * n
    z = np.broadcast_to(np.array([0.05, 0.03, 0.05, 0.03, 1.4]), (len(t), 5))
    return names, np.concatenate([xy.reshape(len(t), 5, 2), z[..., None]], axis=2), t


@pytest.mark.parametrize("treadmill", [False, True])
@pytest.mark.parametrize("direction, turns", [(0, 0), (180, 2), (90, 1), (-90, -1), (85, 1)])
def test_walking_rotation_turns_the_walk_to_plus_x(direction, turns, treadmill):
    names, markers, t = _synthetic_walk(direction, treadmill)
    rot, text = walking_rotation(names, markers, t)
    np.testing.assert_array_equal(rot, rotation_z(-turns))
    heading = rot[:2, :2] @ np.array([np.cos(np.radians(direction)), np.sin(np.radians(direction))])
    assert heading[0] > 0.99 and ("heel->toe" in text) == treadmill


@needs_data
def _mot_table(path: Path) -> tuple[list[str], int, list[str], np.ndarray]:
    """A MOT file's lines, the index of its ``endheader`` line, its column names and its data."""
    lines = path.read_text().splitlines()
    end = lines.index("endheader")
    return lines, end, lines[end + 1].split("\t"), np.loadtxt(path, skiprows=end + 2)


def _write_mot(path: Path, head: list[str], data: np.ndarray) -> None:
    """A MOT of the header lines ``head`` (through the column names) and ``data``."""
    body = "\n".join("\t".join(f"{v:.6f}" for v in row) for row in data)
    path.write_text("\n".join(head) + "\n" + body + "\n")


def test_rotated_trc_mot_pair_is_turned_back(tmp_path):
    """End-to-end: the Rajagopal files turned 90 deg about the vertical load like the originals."""
    ref = _load("raj")
    trc_lines = RAJ[0].read_text().splitlines()
    out = trc_lines[:5]
    for line in trc_lines[5:]:
        cells = line.split("\t")
        if len(cells) < 5:
            out.append(line)
            continue
        v = [float(c) if c.strip() else np.nan for c in cells[2:]]
        v += [np.nan] * (-len(v) % 3)
        xyz = np.array(v).reshape(-1, 3)
        xyz = np.column_stack([-xyz[:, 2], xyz[:, 1], xyz[:, 0]])  # walk toward file -Z (lab +Y)
        out.append("\t".join(cells[:2] + [f"{x:.3f}" for x in xyz.ravel()]))
    (tmp_path / "rot.trc").write_text("\n".join(out) + "\n")
    lines, end, cols, data = _mot_table(RAJ[1])
    for c, col in enumerate(cols):
        if col.endswith(("vx", "px", "_x")):
            x, z = data[:, c].copy(), data[:, c + 2].copy()
            data[:, c], data[:, c + 2] = -z, x
    _write_mot(tmp_path / "rot.mot", lines[: end + 2], data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rot = load_trial(tmp_path / "rot.trc", tmp_path / "rot.mot", mass=RAJ_MASS)
    assert not np.allclose(rot.lab_rotation, ref.lab_rotation)
    np.testing.assert_allclose(rot.markers, ref.markers, atol=1e-6, equal_nan=True)
    for a, b in zip(rot.stances, ref.stances, strict=True):
        assert (a.side, a.plate) == (b.side, b.plate)
        assert a.t_on == pytest.approx(b.t_on, abs=1e-6)
        np.testing.assert_allclose(a.reference_point, b.reference_point, atol=1e-6)


def test_a_trc_gap_written_as_zeros_is_a_gap(tmp_path):
    """OpenSim's TRC writers fill a lost marker with 0.000 in all three coordinates: the heel
    so written for 0.3 s of a stance loads as the same gap as the cells left blank (before,
    the heel sat on the lab origin there and the fit used it: the exponent 2.1 against 1.7)."""
    lines = RAJ[0].read_text().splitlines()
    names = [c.strip() for c in lines[3].split("\t")[2:] if c.strip()]
    m = names.index("R.Heel")
    copies = {}
    for fill in ("0.000", ""):
        out = lines[:5]
        for line in lines[5:]:
            cells = line.split("\t")
            if len(cells) > 5 and 0.45 <= float(cells[1]) <= 0.75:
                cells[2 + 3 * m : 5 + 3 * m] = [fill] * 3
            out.append("\t".join(cells))
        path = tmp_path / f"gap{len(copies)}.trc"
        path.write_text("\n".join(out) + "\n")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            copies[fill] = load_trial(path, RAJ[1], mass=RAJ_MASS)
    zeros, blank = copies["0.000"], copies[""]
    j = zeros.marker_names.index("R.Heel")
    t = zeros.marker_time
    assert np.isnan(blank.markers[(t > 0.5) & (t < 0.7), j]).all()  # the gap is long: not filled
    np.testing.assert_array_equal(zeros.markers, blank.markers)
    assert zeros.load_notes == blank.load_notes and any("R.Heel" in n for n in zeros.load_notes)


def test_a_mot_without_torque_columns_says_the_free_moment_is_taken_as_zero(tmp_path):
    """The Rajagopal MOT with its torques named ``ground_moment_*`` (not OpenSim's
    ``ground_torque_*``): the sets are read without a free moment, and a note says so and names
    the columns not read as one (it was silent: the fit compared the vertical torque with 0).
    The original file has no such note."""
    text = RAJ[1].read_text().replace("ground_torque_", "ground_moment_")
    (tmp_path / "moment.mot").write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        renamed = load_trial(RAJ[0], tmp_path / "moment.mot", mass=RAJ_MASS)
        clean = load_trial(*RAJ, mass=RAJ_MASS)
    (note,) = [n for n in renamed.load_notes if "no torque columns" in n]
    assert "free moment is taken as 0" in note and "ground_moment_r_x" in note
    assert not any("no torque columns" in n for n in clean.load_notes)
    assert [s.label for s in renamed.stances] == [s.label for s in clean.stances]


def test_a_force_set_that_sums_both_feet_is_not_one_stance(tmp_path):
    """The Rajagopal MOT written as one force set (both feet summed, the centre of pressure of
    the sum): the 'stance' it makes covers several steps, its centre of pressure travelling far
    more than a foot is long. It is excluded with that reason (it was fitted at exit 0: 34 % BW
    of vertical error and mu at 0)."""
    lines, end, cols, data = _mot_table(RAJ[1])
    c = {n: k for k, n in enumerate(cols)}
    F = np.zeros((len(data), 3))
    M = np.zeros((len(data), 3))  # about the origin (OpenSim: Y up)
    for side in "rl":
        f = data[:, [c[f"ground_force_{side}_v{a}"] for a in "xyz"]]
        p = data[:, [c[f"ground_force_{side}_p{a}"] for a in "xyz"]]
        t = data[:, [c[f"ground_torque_{side}_{a}"] for a in "xyz"]]
        F += f
        M += np.cross(p, f) + t
    fy = np.where(np.abs(F[:, 1]) > 1.0, F[:, 1], np.inf)
    P = np.column_stack([M[:, 2] / fy, np.zeros(len(data)), -M[:, 0] / fy])  # on y = 0
    T = M - np.cross(P, F)
    out = np.column_stack([data[:, c["time"]], F, P, T])
    head = "\t".join(
        ["time", *(f"ground_force_v{a}" for a in "xyz"), *(f"ground_force_p{a}" for a in "xyz")]
        + [f"ground_torque_{a}" for a in "xyz"]
    )
    _write_mot(tmp_path / "both.mot", [*lines[: end + 1], head], out)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = load_trial(RAJ[0], tmp_path / "both.mot", mass=RAJ_MASS)
    assert t.stances == ()
    assert any(
        "more than a foot is long" in e.reason and "two feet" in e.reason
        for e in t.excluded_stances
    )


def test_a_mot_of_another_clock_is_refused_naming_both_ranges(tmp_path):
    """The Rajagopal TRC with its time column shifted by 5 s beside its MOT at 0 s: no sample
    in common. Refused naming both files' ranges (it said the mass could not be estimated,
    or, with a mass, that every stance was clipped)."""
    lines = RAJ[0].read_text().splitlines()
    out = lines[:5]
    for line in lines[5:]:
        cells = line.split("\t")
        if len(cells) > 2 and cells[1].strip():
            cells[1] = f"{float(cells[1]) + 5.0:.5f}"
        out.append("\t".join(cells))
    (tmp_path / "late.trc").write_text("\n".join(out) + "\n")
    with pytest.raises(InputError, match=r"covers 5\.\d+-7\.\d+ s and .* 0\.\d+-2\.\d+ s"):
        load_trial(tmp_path / "late.trc", RAJ[1], mass=RAJ_MASS)


def test_a_mot_with_its_centre_of_pressure_in_millimetres_says_what_to_do(tmp_path):
    """A MOT has no unit header: the refusal of COP columns in mm says to divide them by 1000
    (it told the user to fix a header the file does not have)."""
    lines, end, cols, data = _mot_table(RAJ[1])
    for k, c in enumerate(cols):
        if c.endswith(("_px", "_py", "_pz")):
            data[:, k] *= 1000.0
    _write_mot(tmp_path / "mm.mot", lines[: end + 2], data)
    with pytest.raises(InputError, match="no unit header.*divide them by 1000"):
        load_trial(RAJ[0], tmp_path / "mm.mot", mass=RAJ_MASS)


def test_a_mot_written_z_up_is_refused_naming_the_axis(tmp_path):
    """The Rajagopal MOT turned Z-up ((x, y, z) -> (x, -z, y) in every vector): its ground
    reaction points along Z. Refused, naming the axis and the convention (it said that the
    height, estimated from a body lying on its side, was not in metres)."""
    lines, end, cols, data = _mot_table(RAJ[1])
    for k, c in enumerate(cols):
        if c.endswith(("vx", "px", "_x")):
            y, z = data[:, k + 1].copy(), data[:, k + 2].copy()
            data[:, k + 1], data[:, k + 2] = -z, y
    _write_mot(tmp_path / "zup.mot", lines[: end + 2], data)
    with pytest.raises(InputError, match="points mostly along Z.*written Z-up"):
        load_trial(RAJ[0], tmp_path / "zup.mot", mass=RAJ_MASS)


def test_bundled_example_loads_without_arguments():
    assert bundled_example_path().is_file()
    assert (bundled_example_path().parent / "LICENSE_test_small.txt").is_file()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the bundled example loads cleanly
        trial = load_trial()
    assert [s.side for s in trial.stances] == ["right", "left", "right"]
    text = describe_trial(trial)
    assert "% BW" in text and "PROCESSING:Bodymass" in text and "check:" in text
    assert "missing" not in text  # no marker gap in this file
    # a heel lost within the first stance, and a head marker lost elsewhere: the foot's gap is
    # named apart from the markers that do not pose the feet
    m = trial.markers.copy()
    st, t = trial.stances[0], trial.marker_time
    heel, head = trial.marker_names.index("RHEE"), trial.marker_names.index("LFHD")
    m[(t > st.t_on + 0.1) & (t < st.t_on + 0.3), heel] = np.nan
    m[:30, head] = np.nan
    text = describe_trial(dataclasses.replace(trial, markers=m))
    assert "foot markers missing within a stance (gaps > 0.1 s, not filled): ['RHEE']" in text
    assert "1 other markers missing in some frames" in text and ": LFHD" in text


def test_short_gaps_filled_long_gaps_left():
    t = np.arange(0, 1, 0.01)
    m = np.stack([np.sin(t), np.cos(t), t], axis=1)[:, None, :].repeat(2, axis=1)
    m[40:45, 0] = np.nan  # 0.05 s gap: filled
    m[10:40, 1] = np.nan  # 0.3 s gap: kept
    filled, left = fill_short_gaps(m, t)
    np.testing.assert_allclose(filled[40:45, 0, 0], np.sin(t[40:45]), atol=1e-6)  # smooth signal
    assert np.isnan(filled[10:40, 1]).all() and left == [(1, t[10], t[39])]


@pytest.mark.parametrize("g, filled_expected", [(10, True), (11, False)])
def test_gap_length_rule_is_missing_samples_over_rate(g, filled_expected):
    """One rule for the loaders and the low-pass: g missing samples last g / rate seconds."""
    from gc_ocp.kinematics.filtering import lowpass

    t = np.arange(200) / 100.0
    x = np.stack([np.sin(t), np.cos(t), t], axis=1)[:, None, :]
    x[50 : 50 + g] = np.nan  # g missing samples at 100 Hz: 0.1 s fills, 0.11 s does not
    filled, left = fill_short_gaps(x, t, max_gap=0.1)
    assert np.isfinite(filled).all() == filled_expected and (left == []) == filled_expected
    assert np.isfinite(lowpass(x, 100.0, 6.0, time=t)).all() == filled_expected
    x = np.asfortranarray(np.repeat(x, 2, axis=1))  # a non-contiguous selection is filled too
    assert np.isfinite(lowpass(x, 100.0, 6.0, time=t)).all() == filled_expected


# --- bad input -------------------------------------------------------------------------------


def test_missing_file():
    with pytest.raises(InputError, match="nope.c3d does not exist"):
        load_trial("nope.c3d")


@needs_data
def test_missing_mass_is_estimated_with_a_warning_naming_file_basis_and_option():
    with pytest.warns(UserWarning, match=r"grf_walk\.mot: ESTIMATED 8\d\.\d kg.*stride.*--mass KG"):
        trial = load_trial(*RAJ)
    assert trial.mass == pytest.approx(RAJ_MASS, rel=0.02)  # OpenSim scale set-up: 85.07 kg
    assert trial.mass_source.startswith("ESTIMATE") and "stride" in trial.mass_source


@needs_data
def test_missing_mass_without_a_basis_names_file_and_option(tmp_path):
    """One stance only: neither a stride nor quiet standing to estimate the mass from."""
    lines = RAJ[1].read_text().splitlines()
    end = next(i for i, ln in enumerate(lines) if ln.strip().lower() == "endheader")
    cols = lines[end + 1].split("\t")
    data = np.loadtxt(RAJ[1], skiprows=end + 2)
    data = data[data[:, 0] < 1.2]  # the first right stance and the left one, cut: no step pair
    data[data[:, 0] > 0.7, 1:] = 0.0
    mot = tmp_path / "one_stance.mot"
    body = "\n".join("\t".join(f"{v:.6f}" for v in row) for row in data)
    mot.write_text("\n".join(lines[: end + 1] + ["\t".join(cols)]) + "\n" + body + "\n")
    with pytest.raises(InputError, match=r"one_stance\.mot.*neither quiet standing.*--mass KG"):
        load_trial(RAJ[0], mot)


@needs_data
def test_millimetres_declared_as_metres(tmp_path):
    lines = RAJ[0].read_text().splitlines()
    lines[2] = lines[2].replace("mm", "m")
    bad = tmp_path / "bad_units.trc"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(UnitsError, match=r"bad_units\.trc.*millimetres.*Units"):
        load_trial(bad, RAJ[1], mass=RAJ_MASS)


def test_c3d_without_plates(tmp_path):
    import ezc3d

    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [100]
    c["parameters"]["POINT"]["LABELS"]["value"] = ("LHEE", "RHEE")
    pts = np.ones((4, 2, 20))
    pts[:3] = np.random.default_rng(1).random((3, 2, 20)) * 1000
    c["data"]["points"] = pts
    path = tmp_path / "noplates.c3d"
    c.write(str(path))
    with pytest.raises(PlateError, match=r"noplates\.c3d has no force plates.*ground reactions"):
        load_trial(path, mass=70)


def test_require_markers_on_a_gap_and_a_missing_marker():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        trial = load_trial()
    m = np.array(trial.markers)
    j = trial.marker_names.index("LHEE")
    m[100:130, j] = np.nan  # 0.3 s
    gappy = dataclasses.replace(trial, markers=m)
    require_markers(gappy, ["RHEE"])
    with pytest.raises(MarkerError, match=r'"LHEE" in .*test_small\.c3d.*0\.300 s.*fill the gap'):
        require_markers(gappy, ["RHEE", "LHEE"])
    with pytest.raises(MarkerError, match=r'"LMT5" is not in .*test_small\.c3d'):
        require_markers(trial, ["LMT5"])


def _synthetic_plate_case(cop_x_end: float, left_y: float):
    """One 0.5 m square plate, a 0.6 s right stance with the COP going from x=0.25 to
    ``cop_x_end``; feet markers static (right on the plate, left at y=``left_y``)."""
    from gc_ocp.trial import Plate
    from gc_ocp.wrench import transport_moment

    t = np.arange(0, 1.0, 0.001)
    fz = np.where((t > 0.2) & (t < 0.8), 600 * np.sin(np.pi * (t - 0.2) / 0.6), 0.0)
    f = np.column_stack([np.zeros_like(t), np.zeros_like(t), fz])
    cop = np.column_stack(
        [np.interp(t, [0.2, 0.8], [0.25, cop_x_end]), np.full_like(t, 0.25), np.zeros_like(t)]
    )
    e = np.array([0.25, 0.25, -0.04])
    m = transport_moment(f, np.zeros_like(f), cop, e)
    corners = np.array([[0.5, 0.5, 0], [0, 0.5, 0], [0, 0, 0], [0.5, 0, 0]], float)
    plate = Plate("plate1", t, f, m, e, "electrical_center", corners, 0.0)
    names = ["RHEE", "RTOE", "LHEE", "LTOE", "C7", "T10", "SACR", "LASI", "RASI"]
    mt = np.arange(0, 1.0, 0.01)
    pos = np.array(
        [[0.15, 0.25, 0.03], [0.35, 0.25, 0.03], [0.1, left_y, 0.03], [0.3, left_y, 0.03]]
        + [[0.0, 0.0, 1.4], [0.0, 0.0, 1.2], [0.0, 0.0, 1.0], [0.0, 0.1, 1.0], [0.0, -0.1, 1.0]]
    )
    markers = np.broadcast_to(pos, (len(mt), 9, 3)).copy()
    markers[:, 4:, 0] += 1.2 * mt[:, None]  # the body walks at 1.2 m/s over the planted feet
    return [plate], names, markers, mt


@pytest.mark.parametrize(
    "cop_x_end, left_y, reason",
    [(0.3, -0.5, ""), (0.7, -0.5, "COP outside plate1"), (0.3, 0.4, "two feet on plate1")],
)
def test_stance_exclusions_on_a_synthetic_plate(cop_x_end, left_y, reason):
    from gc_ocp.io.stances import detect_stances

    plates, names, markers, mt = _synthetic_plate_case(cop_x_end, left_y)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        stances, excluded, _ = detect_stances(plates, names, markers, mt, 600.0, 20.0, "syn")
    if not reason:
        assert len(stances) == 1 and not excluded and not caught
        assert stances[0].side == "right"
        assert stances[0].t_on == pytest.approx(0.2 + 0.6 / np.pi * np.arcsin(20 / 600), abs=1e-3)
    else:
        assert not stances and excluded[0].reason.startswith(reason)
        assert any(reason in str(w.message) for w in caught)


def test_floor_height_is_the_mean_plate_surface():
    trial = load_trial()
    expected = np.mean([p.surface_height for p in trial.plates])
    assert trial.floor_height == pytest.approx(expected, abs=1e-15)
    assert dataclasses.replace(trial, plates=(), stances=(), excluded_stances=()).floor_height == 0


@needs_data
def test_non_numeric_mot_cell_names_file_line_and_column(tmp_path):
    lines = RAJ[1].read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.strip().lower() == "endheader") + 3
    names = lines[k - 2].split("\t")
    cells = lines[k].split("\t")
    cells[1] = "n/a"
    lines[k] = "\t".join(cells)
    mot = tmp_path / "damaged.mot"
    mot.write_text("\n".join(lines) + "\n")
    with pytest.raises(
        InputError, match=rf'damaged.mot, line {k + 1}: column "{names[1]}" is "n/a"'
    ):
        load_trial(RAJ[0], grf=mot, mass=RAJ_MASS)


def _relabelled(tmp_path, rename):
    """The bundled C3D with every marker label passed through ``rename(label, column)``."""
    import ezc3d

    from gc_ocp.io.load import bundled_example_path

    c = ezc3d.c3d(str(bundled_example_path()))
    labels = list(c["parameters"]["POINT"]["LABELS"]["value"])
    c["parameters"]["POINT"]["LABELS"]["value"] = [rename(s, i) for i, s in enumerate(labels)]
    out = tmp_path / "relabelled.c3d"
    c.write(str(out))
    return out


def test_a_vicon_subject_prefix_is_dropped_and_the_trial_reads_as_without_it(tmp_path):
    """Vicon Nexus labels a subject's markers ``Subject:LHEE``. Before, the shipped Plug-in Gait
    set did not match them, recognition put LANK on the shank instead of the hindfoot, and the
    fit changed (mu 0.244 -> 0.196 on the bundled trial) without a word."""
    from gc_ocp.io.c3d import read_c3d
    from gc_ocp.io.load import bundled_example_path
    from gc_ocp.model.markerset import detect_markerset

    clean = read_c3d(bundled_example_path())
    raw = read_c3d(_relabelled(tmp_path, lambda s, i: "Bob:" + s))
    assert raw.marker_names == clean.marker_names
    np.testing.assert_array_equal(np.isnan(raw.markers), np.isnan(clean.markers))
    assert any('prefix "Bob:"' in n for n in raw.notes)
    a = detect_markerset(clean.marker_names, clean.markers)
    b = detect_markerset(raw.marker_names, raw.markers)
    assert a.name == b.name


def test_markers_of_two_subjects_in_one_file_are_an_error_naming_them(tmp_path):
    from gc_ocp.io.c3d import read_c3d

    path = _relabelled(tmp_path, lambda s, i: ("Ann:" if i % 2 else "Bob:") + s)
    with pytest.raises(MarkerError, match=r"several subjects .*Ann:, Bob:"):
        read_c3d(path)


def test_a_ghost_marker_is_removed_as_a_gap_and_named(tmp_path):
    """A heel marker that is 5 m away for one frame (a ghost, or another point's label) and
    back: before, the stance under it was excluded as 'force not under this foot'. Now the
    frame is a gap, filled from its neighbours, and the note names the marker and the time."""
    from gc_ocp.io.load import bundled_example_path

    clean = load_trial(bundled_example_path())
    j = clean.marker_names.index("LHEE")
    k = len(clean.marker_time) // 2
    import ezc3d

    c = ezc3d.c3d(str(bundled_example_path()))
    labels = [str(s).strip() for s in c["parameters"]["POINT"]["LABELS"]["value"]]
    c["data"]["points"][:3, labels.index("LHEE"), k] += 5000.0  # mm
    out = tmp_path / "ghost.c3d"
    c.write(str(out))
    t = load_trial(out)
    assert [s.label for s in t.stances] == [s.label for s in clean.stances]
    notes = [n for n in t.load_notes if n.startswith("marker LHEE")]
    assert len(notes) == 1 and f"{clean.marker_time[k]:.3f}" in notes[0]
    # the filled frame: a cubic spline through neighbours 10 ms apart, within a millimetre
    # of the recorded position (the heel moves ~1-10 mm per frame)
    assert np.linalg.norm(t.markers[k, j] - clean.markers[k, j]) < 1e-3
    untouched = np.ones(len(t.marker_time), bool)
    untouched[k] = False
    np.testing.assert_array_equal(t.markers[untouched], clean.markers[untouched])


def test_marker_spikes_keep_fast_real_motion_and_a_marker_that_moves_away():
    """What is not a spike: a foot in swing at 6 m/s, and a marker that jumps and stays (a
    relabelling for the rest of the trial is not a short excursion: left for the checks)."""
    from gc_ocp.gaps import marker_spikes

    t = np.arange(200) / 100.0
    x = np.zeros((200, 2, 3))
    x[:, 0, 0] = 6.0 * t  # 6 m/s
    x[:, 1, 0] = np.where(t < 1.0, 0.0, 0.5)  # one jump of 0.5 m, no return
    out, found = marker_spikes(x, t)
    assert found == []
    np.testing.assert_array_equal(out, x)
    x[50:53, 1, 2] = 3.0  # three frames away and back: removed
    out, found = marker_spikes(x, t)
    assert found == [(1, t[50], t[52])]
    assert (
        np.isnan(out[50:53, 1]).all() and np.isfinite(np.delete(out[:, 1], [50, 51, 52], 0)).all()
    )
    x[50:53, 1, 2] = 0.0
    x[80:83, 1] = np.nan  # a gap, then a ghost on the sample after it
    x[83, 1, 2] = 3.0
    out, found = marker_spikes(x, t)
    assert found == [(1, t[83], t[83])]


def test_provenance_lists_the_stances_the_fit_uses():
    """A stance the checks before a fit exclude (here: its force is under the other foot) is in
    ``stances_excluded`` with the reason, not in ``stances_used`` (before, the provenance was
    taken from the trial as loaded and listed it as used)."""
    import types

    from gc_ocp.kinematics import compute_kinematics
    from gc_ocp.workflow.provenance import provenance

    trial = load_trial()
    kin = compute_kinematics(trial)
    s0 = trial.stances[0]
    other = "left" if s0.side == "right" else "right"
    wrong = dataclasses.replace(s0, side=other, label=f"{other}@{s0.t_on:.3f}s")
    swapped = dataclasses.replace(trial, stances=(wrong,) + trial.stances[1:])
    prov = provenance(types.SimpleNamespace(command="fit"), [(swapped, kin)])
    t = prov["trials"][0]
    assert wrong.label not in t["stances_used"]
    assert [s.label for s in trial.stances[1:]] == t["stances_used"]
    excluded = [e for e in t["stances_excluded"] if e["t_on"] == s0.t_on]
    assert len(excluded) == 1 and "not under this foot" in excluded[0]["reason"]


@needs_data
def test_a_subject_prefix_does_not_turn_model_outputs_into_markers(tmp_path):
    """Plug-in Gait's outputs (``LAnkleAnglesV``...) are listed in POINT:ANGLES without the
    prefix the labels carry: they stay model outputs (before: 12 angle 'markers' were kept and
    the body's speed, a median over markers, read 0.08 m/s: a stance excluded as standing)."""
    import ezc3d

    from gc_ocp.io.c3d import read_c3d

    src = DATA / "vicon_plugingait_btk" / "PiG_Motion3_FF.c3d"
    c = ezc3d.c3d(str(src))
    labels = list(c["parameters"]["POINT"]["LABELS"]["value"])
    c["parameters"]["POINT"]["LABELS"]["value"] = ["Bob:" + s for s in labels]
    out = tmp_path / "prefixed.c3d"
    c.write(str(out))
    assert read_c3d(out).marker_names == read_c3d(src).marker_names
    assert len(load_trial(out).stances) == len(load_trial(src).stances)


def _swap(pairs):
    def rename(s, i):
        for a, b in pairs:
            if s.strip() == a:
                return b
            if s.strip() == b:
                return a
        return s

    return rename


def test_left_and_right_foot_labels_exchanged_are_an_error(tmp_path):
    """Before, a trial whose foot markers carried the other side's labels was fitted without a
    word (n at its bound, superior RMS 3.7 % BW against 1.1)."""
    path = _relabelled(tmp_path, _swap([("LHEE", "RHEE"), ("LTOE", "RTOE"), ("LANK", "RANK")]))
    with pytest.raises(MarkerError, match=r"left-side leg markers lie to the subject's right"):
        load_trial(path)


def test_a_mirrored_file_is_an_error(tmp_path):
    """Every marker's lateral coordinate negated (left-handed axes): left lies right."""
    import ezc3d

    from gc_ocp.io.load import bundled_example_path

    c = ezc3d.c3d(str(bundled_example_path()))
    c["data"]["points"][1] *= -1.0
    out = tmp_path / "mirrored.c3d"
    c.write(str(out))
    with pytest.raises(MarkerError, match=r"swapped, by the labels or by mirrored"):
        load_trial(out)


def test_exchanged_shoulder_labels_are_noted_not_refused(tmp_path):
    """A swap off the legs (as the BTS Walking3 file's acromion markers) does not pose the feet:
    the trial loads, and the note says which labels are exchanged."""
    t = load_trial(_relabelled(tmp_path, _swap([("LSHO", "RSHO")])))
    assert any("LSHO/RSHO" in n and "exchanged" in n for n in t.load_notes)
    assert len(t.stances) == 3


def test_a_crossover_gait_is_not_taken_for_swapped_sides(tmp_path):
    """Tandem walking brings the feet a few cm the wrong way round (here heel and toe pairs,
    3 cm crossed) while the knees stay a knee width apart: not a swap."""
    from gc_ocp.io.load import bundled_example_path

    clean = load_trial(bundled_example_path())
    import ezc3d

    c = ezc3d.c3d(str(bundled_example_path()))
    labels = [str(s).strip() for s in c["parameters"]["POINT"]["LABELS"]["value"]]
    pts = c["data"]["points"]
    for name in ("HEE", "TOE"):  # +y is the subject's left in this file
        left, right = labels.index("L" + name), labels.index("R" + name)
        mid = 0.5 * (pts[1, left] + pts[1, right])
        pts[1, left], pts[1, right] = mid - 15.0, mid + 15.0  # mm: 3 cm crossed
    out = tmp_path / "tandem.c3d"
    c.write(str(out))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = load_trial(out)
    assert t.marker_names == clean.marker_names
    from gc_ocp.io.orientation import mirrored_pairs

    crossed = mirrored_pairs(t.marker_names, t.markers, t.marker_time)
    assert {(a, b) for a, b, _, _ in crossed} == {("LHEE", "RHEE"), ("LTOE", "RTOE")}


def test_the_side_check_falls_back_to_the_body_s_motion_without_feet():
    """Heel and toe labels present but empty: forward is the body's velocity (+x here), and a
    mirrored pair is still found."""
    from gc_ocp.io.orientation import mirrored_pairs

    t = np.arange(100) / 100.0
    names = ["LHEE", "RHEE", "LTOE", "RTOE", "LKNE", "RKNE", "LASI", "RASI"]
    x = np.full((100, len(names), 3), np.nan)
    where = [(-0.1, 0.5), (0.1, 0.5), (-0.12, 0.9), (0.12, 0.9)]
    for j, (y, z) in zip(range(4, 8), where, strict=True):
        x[:, j] = np.column_stack([1.2 * t, np.full(100, y), np.full(100, z)])  # L on the right
    found = mirrored_pairs(names, x, t)
    assert {(a, b) for a, b, _, _ in found} == {("LKNE", "RKNE"), ("LASI", "RASI")}


def test_a_standing_trial_given_as_a_walking_one_is_named_static():
    """A walking command given a static trial ended in "no mass" or "no plate is loaded";
    the message now says the markers stand still and where the trial belongs (--static)."""
    import dataclasses

    from gc_ocp.errors import PlateError
    from gc_ocp.io.checks import require_stances, static_hint

    t = load_trial()
    assert static_hint(t.marker_names, t.markers) == ""  # walking: no hint
    rng = np.random.default_rng(0)
    still = t.markers[100:101].repeat(200, axis=0) + rng.normal(
        0, 1e-3, (200, *t.markers.shape[1:])
    )
    hint = static_hint(t.marker_names, still)
    assert "looks like a static (standing) trial; give it with --static FILE" in hint
    standing = dataclasses.replace(t, markers=still, marker_time=np.arange(200) / 100, stances=())
    with pytest.raises(PlateError, match="no usable stance .* looks like a static"):
        require_stances(standing)


def test_a_label_the_file_uses_twice_is_shown_as_the_fit_names_it():
    """Helen Hayes type-2a labels two markers LANK (and two RANK); info listed ['LANK', ...,
    'LANK'] while the fit named the second LANK#2."""
    from conftest import DATA, _need_data

    _need_data()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        text = describe_trial(load_trial(DATA / "c3dorg_helenhayes_types" / "type-2a.c3d"))
    assert "'LANK#2'] (the file labels two markers LANK)" in text
    assert "missing within a stance (gaps > 0.1 s, not filled): ['RANK#2', 'LANK#2']" in text


@pytest.mark.parametrize("stored, unit", [(1580.0, "mm"), (158.0, "cm"), (1.58, "m")])
def test_c3d_subject_height_in_mm_cm_or_m(tmp_path, stored, unit):
    """PROCESSING:Height in cm (158) was divided by 1000 as if in mm: 0.158 m, then an
    implausible-height error blaming the user. A person is 0.5-2.6 m tall, so 3-300 can only be
    cm (the rule the subject JSON and OpenSim set-ups use). Tolerance: float32 storage."""
    import ezc3d

    from gc_ocp.io.c3d import read_c3d

    c = ezc3d.c3d(str(bundled_example_path()))
    c["parameters"]["PROCESSING"]["Height"]["value"] = np.array([stored])
    path = tmp_path / f"height_{unit}.c3d"
    c.write(str(path))
    assert read_c3d(path).height == pytest.approx(1.58, abs=1e-6)


def _trc_and_mot(
    folder: Path,
    cop_unit: float = 1.0,
    force_sign: float = 1.0,
    torque_unit: float = 1.0,
    header: str = "",
):
    """A 2 s TRC (three markers, mm) and a MOT of three plates, plate 1 loaded 0.5-1.1 s
    (600 N peak, COP 1.0-1.2 m forward, 0.3 m across, free moment 2 N m) and zero elsewhere, as
    a thresholded export is: COP multiplied by ``cop_unit``, force and torque by
    ``force_sign``, torque by ``torque_unit``; ``header``: extra header lines."""
    t = np.arange(200) / 100.0
    trc = folder / "walk.trc"
    rows = [f"{i + 1}\t{ti:.2f}\t0\t100\t0\t0\t1000\t0\t300\t900\t100" for i, ti in enumerate(t)]
    trc.write_text(
        "PathFileType\t4\t(X/Y/Z)\twalk.trc\n"
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\n"
        "100\t100\t200\t3\tmm\n"
        "Frame#\tTime\tRHEE\t\t\tC7\t\t\tLHEE\n"
        "\t\tX1\tY1\tZ1\tX2\tY2\tZ2\tX3\tY3\tZ3\n" + "\n".join(rows) + "\n"
    )
    cols = ["time"]
    for k in (1, 2, 3):
        cols += [f"ground_force_{k}_v{a}" for a in "xyz"] + [
            f"ground_force_{k}_p{a}" for a in "xyz"
        ]
        cols += [f"ground_torque_{k}_{a}" for a in "xyz"]
    data = np.zeros((len(t), len(cols)))
    data[:, 0] = t
    on = (t > 0.5) & (t < 1.1)
    data[on, 1] = force_sign * 100 * np.sin(np.pi * (t[on] - 0.5) / 0.6)  # plate 1 Fx [N]
    data[on, 2] = force_sign * 600 * np.sin(np.pi * (t[on] - 0.5) / 0.6)  # vertical (Y) [N]
    data[on, 4] = cop_unit * np.interp(t[on], [0.5, 1.1], [1.0, 1.2])  # COP x
    data[on, 6] = cop_unit * 0.3  # COP z
    data[on, 8] = force_sign * torque_unit * 2.0  # free moment about Y [N m]
    mot = folder / "walk_grf.mot"
    mot.write_text(
        f"walk_grf.mot\nversion=1\nnRows=200\nnColumns=28\ninDegrees=no\n{header}endheader\n"
        + "\t".join(cols)
        + "\n"
        + "\n".join("\t".join(f"{v:.6f}" for v in row) for row in data)
        + "\n"
    )
    return trc, mot


def test_mot_cop_in_millimetres_is_refused_though_most_samples_are_zero(tmp_path):
    """A MOT of several plates, each stepped on once, is zero (thresholded) in most samples: the
    unit check took the median over all COP values, 0, and a COP in mm passed as metres (the
    stances were then excluded as 'two feet on one force set', 160 m of COP travel). The check
    now reads the horizontal COP while loaded (here 1000-1200 mm: far above the 50 m limit)."""
    from gc_ocp.io.opensim import read_opensim

    trc, mot = _trc_and_mot(tmp_path, cop_unit=1000.0)
    with pytest.raises(UnitsError, match=r"COP columns in .*walk_grf\.mot .* millimetres"):
        read_opensim(trc, mot)


def test_mot_storing_the_force_on_the_plate_is_negated_with_a_note(tmp_path):
    """A MOT whose force sets all read a negative vertical force while loaded stores the force
    on the plate (as some C3D writers do, which the C3D reader negates with a note): it read
    as no contact at all ('no plate is loaded above the contact threshold', or no mass
    estimate). Negated, it gives the wrench of the same file written as ground reactions
    (exactly: the same numbers with the opposite sign)."""
    from gc_ocp.io.opensim import read_opensim

    (tmp_path / "neg").mkdir()
    ref = read_opensim(*_trc_and_mot(tmp_path))
    neg = read_opensim(*_trc_and_mot(tmp_path / "neg", force_sign=-1.0))
    for p, q in zip(ref.plates, neg.plates, strict=True):
        np.testing.assert_array_equal(q.force, p.force)
        np.testing.assert_array_equal(q.moment, p.moment)
    assert neg.plates[0].force[:, 2].max() == pytest.approx(600.0, rel=0.01)
    assert any("force on the plate" in n and "negated" in n for n in neg.notes)


def _scaled_torques(mot: Path, out: Path, factor: float) -> Path:
    """``mot`` with its ``*torque*`` columns multiplied by ``factor``, every value written to
    full precision (``repr``): the torques differ from the original's by one rounding."""
    lines, end, cols, data = _mot_table(mot)
    for k, c in enumerate(cols):
        if "torque" in c:
            data[:, k] *= factor
    body = "\n".join("\t".join(repr(float(v)) for v in row) for row in data)
    out.write_text("\n".join(lines[: end + 2]) + "\n" + body + "\n")
    return out


def _mot_cases(tmp_path: Path) -> dict[str, tuple[Path, Path]]:
    """(TRC, MOT) pairs: the synthetic free moment of :func:`_trc_and_mot` (2 N m about the
    COP), and the Rajagopal files when the shared data are there."""
    cases = {"synthetic": _trc_and_mot(tmp_path)}
    if DATA.is_dir():
        cases["rajagopal"] = RAJ
    return cases


def test_mot_torques_in_newton_millimetres_are_converted_with_a_note(tmp_path):
    """A MOT's torque columns in N mm (1000x the N m values; a MOT has no unit header) read
    1000x too large, silently. The median lever arm |T| / |F| while loaded tells them apart:
    a free moment's is mm in N m (synthetic 4 mm, Rajagopal 3.9 and 1.6 mm) and "m" in N mm.
    Now divided by 1000 with a note naming the columns: the same plates as the original.
    rtol 1e-13: the torque differs by two roundings (x1000, x1e-3), ~1e-16 of itself, and the
    moment about the origin adds p x F, unchanged, of the same order (hundreds of N m)."""
    from gc_ocp.io.opensim import read_opensim

    for name, (trc, mot) in _mot_cases(tmp_path).items():
        ref = read_opensim(trc, _scaled_torques(mot, tmp_path / f"{name}_nm.mot", 1.0))
        nmm = read_opensim(trc, _scaled_torques(mot, tmp_path / f"{name}_nmm.mot", 1000.0))
        for p, q in zip(ref.plates, nmm.plates, strict=True):
            np.testing.assert_allclose(q.moment, p.moment, rtol=1e-13, atol=1e-12, err_msg=name)
            np.testing.assert_array_equal(q.force, p.force)
        notes = [n for n in nmm.notes if "N mm" in n]
        # one per loaded set: plate 1 of the synthetic file (2 and 3 are never loaded), both feet
        assert len(notes) == {"synthetic": 1, "rajagopal": 2}[name], notes
        assert all("divided by 1000" in n and "torque_" in n for n in notes), notes
        assert not any("N mm" in n for n in ref.notes)


def test_mot_torque_unit_declared_in_the_header_is_honoured(tmp_path):
    """A header line ``torque_units=...`` (any key naming a unit whose value is a force times a
    length) gives the torques' unit: N mm and N cm read as the N m original, without an
    inference note (the N cm file, 100x, is one the inference cannot tell from N mm: it would
    read it 10x too small). A declared N m contradicted by the values (torques 1000x) is refused naming
    the header line and the columns (before, every header unit was ignored)."""
    from gc_ocp.io.opensim import read_opensim

    ref = read_opensim(*_trc_and_mot(tmp_path))
    for unit, factor in (("N*mm", 1000.0), ("N.cm", 100.0), ("Nm", 1.0)):
        folder = tmp_path / str(factor)
        folder.mkdir()
        got = read_opensim(
            *_trc_and_mot(folder, torque_unit=factor, header=f"torque_units={unit}\n")
        )
        # the written cells are exact decimals (2000.000000); x1e-3 rounds once: rtol 1e-13
        np.testing.assert_allclose(got.plates[0].moment, ref.plates[0].moment, rtol=1e-13)
        assert not any("N mm" in n for n in got.notes)
    (tmp_path / "bad").mkdir()
    with pytest.raises(UnitsError, match=r'"torque_units=N\*m".*ground_torque_1_x.*header'):
        read_opensim(
            *_trc_and_mot(tmp_path / "bad", torque_unit=1000.0, header="torque_units=N*m\n")
        )


def test_mot_torques_fitting_no_unit_are_refused_naming_the_columns(tmp_path):
    """Torques 1e6x (a lever arm of km in N m, of m for a free moment in N mm) fit neither unit:
    refused naming the columns and the fix (before, read as given: a free moment of MN m). So
    is the synthetic free moment 30x: 0.13 m, above the 0.1 m bound of N m but within 3x of it,
    where its N mm reading (0.13 mm, a free moment of 0.06 N m) is no more plausible."""
    from gc_ocp.io.opensim import read_opensim

    for name, (trc, mot) in _mot_cases(tmp_path).items():
        bad = _scaled_torques(mot, tmp_path / f"{name}_1e6.mot", 1e6)
        with pytest.raises(
            UnitsError, match=r"torque columns \S*ground_torque_.*neither N m nor N mm"
        ):
            read_opensim(trc, bad)
    (tmp_path / "x30").mkdir()
    with pytest.raises(UnitsError, match=r"ground_torque_1_x.*too close to it to be N mm"):
        read_opensim(*_trc_and_mot(tmp_path / "x30", torque_unit=30.0))


@needs_data
def test_every_shared_mot_torque_reads_in_newton_metres_as_before():
    """The torque unit rule on every shared MOT: each set's torque comes back unchanged and
    without a note (the files are in N m), and the same torque x1000 comes back divided by 1000
    with one. Camargo's ``ground_force_<n>_m{x,y,z}`` (not read as torques: about a point of the
    lab, lever arms 0.06-0.50 m with the COPs up to 6.6 m from the origin) are put through the
    rule too, for its case of a torque about a point. rtol 1e-13: two roundings."""
    from gc_ocp.io._common import Y_UP_TO_LAB
    from gc_ocp.io.opensim import COP_MIN_FORCE, _torque_in_newton_metres, grf_sets, read_mot

    mots = sorted(DATA.rglob("*.mot"))
    assert len(mots) >= 3
    checked = 0
    for mot in mots:
        cols, data, _ = read_mot(mot)
        cols = [re.sub(r"^(.*)force(.*)_m([xyz])$", r"\1torque\2_\3", c) for c in cols]
        for s in grf_sets(cols):
            if s["torque"] is None:
                continue
            f, p, tq = (data[:, s[k]] @ Y_UP_TO_LAB.T for k in ("force", "point", "torque"))
            names = [cols[i] for i in s["torque"]]
            same, note = _torque_in_newton_metres(mot, names, None, f, p, tq, COP_MIN_FORCE)
            assert note is None and np.array_equal(same, tq), (mot.name, names)
            back, note = _torque_in_newton_metres(mot, names, None, f, p, tq * 1e3, COP_MIN_FORCE)
            np.testing.assert_allclose(back, tq, rtol=1e-13, atol=1e-12)
            assert note and "divided by 1000" in note
            checked += 1
    assert checked >= 10  # Rajagopal 2, Gait2392 2, Camargo 6


def test_a_static_c3d_recorded_without_force_plates_loads(tmp_path):
    """A static trial needs no plates (load_static reads its markers only), but a C3D without
    any (FORCE_PLATFORM:USED = 0, as labs record standing trials) raised "has no force plates".
    Its markers, in file axes, take the walking trial's lab rotation: the walking trial's frame
    50 held still comes back as that frame (exactly: same numbers, same rotation)."""
    import ezc3d

    from gc_ocp.io.load import load_static

    c = ezc3d.c3d(str(bundled_example_path()))
    pts = c["data"]["points"]
    pts[:, :, :] = pts[:, :, 50:51]
    c["data"]["points"] = pts
    fp = c["parameters"]["FORCE_PLATFORM"]
    fp["USED"]["value"] = np.array([0])
    fp["TYPE"]["value"] = np.array([], dtype=int)
    path = tmp_path / "static_no_plates.c3d"
    c.write(str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        walking = load_trial()
    static = load_static(path, walking)
    assert static.marker_names == walking.marker_names
    np.testing.assert_allclose(static.markers[0], walking.markers[50], atol=1e-12)


@pytest.mark.parametrize("up", ["+Y", "+Z", "-Y"])
def test_a_trc_not_written_y_up_is_refused_naming_its_axis(tmp_path, up):
    """OpenSim TRC files are Y-up; one written Z-up (or upside down) was read with the body
    lying on its side and its stances kept (a Y-up MOT beside it gave three). The feet lie
    below the other markers: 0.95 m here along the file's up axis, 0.1 m at most along the
    others (FEET_BELOW = 0.3 m between them)."""
    from gc_ocp.io.opensim import read_trc

    y_up = {  # [mm], Y up: heels on the floor, the pelvis and C7 above them
        "RHEE": (0, 50, 100),
        "LHEE": (200, 50, -100),
        "RASI": (100, 1000, 120),
        "LASI": (100, 1000, -120),
        "C7": (50, 1400, 0),
    }
    to_file = {"+Y": lambda x, y, z: (x, y, z), "+Z": lambda x, y, z: (x, -z, y)}
    to_file["-Y"] = lambda x, y, z: (x, -y, -z)
    rows = []
    for i in range(20):
        xyz = [c for p in y_up.values() for c in to_file[up](p[0] + 12 * i, p[1], p[2])]
        rows.append("\t".join([str(i + 1), f"{i / 100:.2f}", *map(str, xyz)]))
    trc = tmp_path / "walk.trc"
    trc.write_text(
        "PathFileType\t4\t(X/Y/Z)\twalk.trc\n"
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\n"
        "100\t100\t20\t5\tmm\n"
        "Frame#\tTime\t" + "\t\t\t".join(y_up) + "\n"
        "\t\t"
        + "\t".join(f"{a}{k + 1}" for k in range(5) for a in "XYZ")
        + "\n"
        + "\n".join(rows)
        + "\n"
    )
    if up == "+Y":
        _, xyz, _ = read_trc(trc)
        assert np.all(xyz[:, 4, 2] > xyz[:, 0, 2])  # C7 above the heel in the lab (Z up)
    else:
        with pytest.raises(
            InputError, match=rf"walk\.trc: the foot markers lie 0\.95 m below .* along \{up}"
        ):
            read_trc(trc)


@pytest.mark.parametrize(
    "unit, metres",
    [("millimetres", 1e-3), ("millimeter", 1e-3), ("centimetres", 1e-2), ("metre", 1.0)],
)
def test_a_length_unit_spelt_out_is_read(unit, metres):
    """'meters', 'metres' and 'millimeters' were read but 'millimetres', 'millimeter',
    'centimetres' or 'metre' (TRC Units, C3D POINT:UNITS) stopped the load as an unknown
    unit."""
    from gc_ocp.io._common import unit_scale

    assert unit_scale(unit, Path("walk.trc"), "TRC Units") == metres
