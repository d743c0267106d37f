"""Force plates of any lab: C3D types 1-4, Y-up/Z-up files, MOT plate naming, stances against
the data README, subject mass, and bad inputs (``docs/data_formats.md``)."""

from __future__ import annotations

import functools
import json
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from gc_ocp.errors import InputError, PlateError
from gc_ocp.io import describe_trial, load_trial
from gc_ocp.io.plates import plate_wrench, type1_wrench, type3_wrench, type4_wrench
from gc_ocp.io.report import vertical_axis_of
from gc_ocp.trial import GRAVITY, Plate
from gc_ocp.wrench import cop_from_wrench, transport_moment

DATA = (Path(__file__).parents[1] / "../shared/data").resolve()
needs_data = pytest.mark.skipif(
    not DATA.is_dir(), reason=f"shared real datasets not found at {DATA} (repo checked out alone)"
)
RNG = np.random.default_rng(11)

# --- the reference: ../shared/data/README.md, transcribed ------------------------------------
# (marker file, grf file, vertical axis of the file, plate type, mass [kg] or None = "not
#  recorded", [(side, plate name, t_on, t_off)] = the README's (full, walking) stances).
# C3D "plate k" of the README is 0-based: our plate{k+1}. MOT numbered plates keep their number.
# t_on/t_off None: the README says only "similar" (BTS Walking2-5).
_BTS_SIMILAR = [("right", "plate1", None, None), ("left", "plate2", None, None)]
README = {
    "test_small": (
        "plugingait_overground/test_small.c3d",
        None,
        "+Z",
        "C3D type 2",
        63.6,
        [
            ("right", "plate1", 0.406, 1.065),
            ("left", "plate2", 0.939, 1.616),
            ("right", "plate4", 1.490, 2.139),
        ],
    ),
    "PiG_Motion3_FF": (
        "vicon_plugingait_btk/PiG_Motion3_FF.c3d",
        None,
        "+Z",
        "C3D type 2",
        74.0,
        [
            ("left", "plate1", 0.616, 1.254),
            ("right", "plate2", 1.145, 1.795),
            ("left", "plate3", 1.694, 2.339),
        ],
    ),
    "FunctionalWalk": (
        "vicon_plugingait_clusters/FunctionalWalk.c3d",
        None,
        "+Z",
        "C3D type 2",
        60.0,
        [
            ("left", "plate3", 1.059, 1.692),
            ("right", "plate1", 1.585, 2.209),
            ("left", "plate2", 2.120, 2.753),
        ],
    ),
    "Gait": (
        "motionanalysis_helenhayes/Gait.c3d",
        None,
        "+Z",
        "C3D type 4",
        None,
        [("right", "plate2", 2.086, 2.644), ("left", "plate1", 2.570, 3.139)],
    ),
    "type-2a": (
        "c3dorg_helenhayes_types/type-2a.c3d",
        None,
        "+Z",
        "C3D type 2",
        None,
        [("left", "plate1", 1.802, 2.295), ("right", "plate2", 2.225, 2.711)],
    ),
    "type-4a": (
        "c3dorg_helenhayes_types/type-4a.c3d",
        None,
        "+Z",
        "C3D type 4",
        None,
        [("left", "plate1", 1.802, 2.295), ("right", "plate2", 2.225, 2.711)],
    ),
    "Walking1": (
        "bts_unipd_5trials/Walking1.c3d",
        None,
        "+Y",
        "C3D type 1",
        None,
        [("right", "plate1", 2.433, 3.126), ("left", "plate2", 3.019, 3.714)],
    ),
    **{
        f"Walking{i}": (
            f"bts_unipd_5trials/Walking{i}.c3d",
            None,
            "+Y",
            "C3D type 1",
            None,
            _BTS_SIMILAR,
        )
        for i in range(2, 6)
    },
    "rajagopal": (
        "opensim_rajagopal_overground/motion_capture_walk.trc",
        "opensim_rajagopal_overground/grf_walk.mot",
        "+Y",
        "MOT",
        None,  # 85.07 kg in the OpenSim scale set-up, not in the files
        [
            ("right", "grf_right", 0.268, 1.023),
            ("left", "grf_left", 0.837, 1.589),
            ("right", "grf_right", 1.412, 2.167),
        ],
    ),
    "gait2392": (
        "opensim_gait2392_treadmill/subject01_walk1.trc",
        "opensim_gait2392_treadmill/subject01_walk1_grf.mot",
        "+Y",
        "MOT",
        None,  # 72.6 kg in the OpenSim scale set-up
        [("right", "grf_right", 0.618, 1.408), ("left", "grf_left", 1.247, 2.017)],
    ),
    "camargo": (
        "camargo_opensim_circuit/levelground_ccw_fast_01_01.trc",
        "camargo_opensim_circuit/levelground_ccw_fast_01_01_grf.mot",
        "+Y",
        "MOT",
        None,
        [
            ("left", "plate2", 4.515, 5.150),
            ("right", "plate1", 5.050, 5.585),
            ("left", "plate6", 7.380, 7.920),
            ("right", "plate5", 7.850, 8.430),
            ("left", "plate4", 11.910, 12.405),
        ],
    ),
}
KNOWN_MASS = {"rajagopal": 85.07, "gait2392": 72.6, "test_small": 63.6}
"""Masses known outside the files (OpenSim scale set-ups; test_small's PROCESSING value)."""
OFF_TOL = 0.020
"""Toe-off tolerance [s] when two marker samples are less: the README's times of the added labs
match a ~50 N crossing (heel strike within 1 ms, toe-off within 8 ms), ours are at 20 N, and
the force falls slowly at toe-off (20 vs 50 N: up to 18 ms on these files)."""


@functools.cache
def _trial(key):
    marker, grf, *_ = README[key]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return load_trial(DATA / marker, DATA / grf if grf else None)


@needs_data
@pytest.mark.parametrize("key", list(README))
def test_stances_vertical_axis_and_plate_type_match_the_readme(key):
    _, _, up, kind, _, expected = README[key]
    trial = _trial(key)
    assert vertical_axis_of(trial) == up
    assert all(p.plate_type.startswith(kind) for p in trial.plates), [
        p.plate_type for p in trial.plates
    ]
    got = [(s.side, trial.plates[s.plate].name, s.t_on, s.t_off) for s in trial.stances]
    assert [g[:2] for g in got] == [e[:2] for e in expected], describe_trial(trial)
    two = 2.0 / trial.marker_rate
    for (_, _, on, off), (_, _, e_on, e_off) in zip(got, expected, strict=True):
        if e_on is None:
            continue
        assert abs(on - e_on) <= two + 1e-9, (key, on, e_on)
        assert abs(off - e_off) <= max(two, OFF_TOL) + 1e-9, (key, off, e_off)
    for e in trial.excluded_stances:  # whatever is excluded says why
        assert e.reason.startswith(("clipped", "not a walking stance")), e.reason


@needs_data
@pytest.mark.parametrize("key", list(README))
def test_mass_from_the_file_or_estimated_with_its_basis(key):
    trial = _trial(key)
    mass = README[key][4]
    if mass is not None:
        assert trial.mass == pytest.approx(mass) and "PROCESSING:Bodymass" in trial.mass_source
        return
    assert trial.mass_source.startswith("ESTIMATE") and "force data" in trial.mass_source
    if key in KNOWN_MASS:
        assert trial.mass == pytest.approx(KNOWN_MASS[key], rel=0.03)
    peak = max(p.force[:, 2].max() for p in trial.plates)
    assert 0.9 * trial.body_weight < peak < 1.8 * trial.body_weight


@needs_data
def test_mass_estimate_from_walking_matches_the_recorded_masses():
    """Where the file records the mass, the estimate from the plates is within 4 %."""
    from gc_ocp.io.subject import estimate_body_weight

    for key in ("test_small", "PiG_Motion3_FF", "FunctionalWalk"):
        trial = _trial(key)
        bw, basis = estimate_body_weight(list(trial.plates), list(trial.stances))
        assert bw / GRAVITY == pytest.approx(trial.mass, rel=0.04), (key, basis)
        assert "stride" in basis


@needs_data
def test_quiet_standing_gives_the_mass_of_the_circuit_trial():
    trial = _trial("camargo")
    assert "quiet standing" in trial.mass_source
    standing = [e for e in trial.excluded_stances if "standing" in e.reason]
    assert len(standing) >= 2  # README: plates 1-3 hold long standing periods


@needs_data
def test_circuit_stances_have_their_own_heading():
    """The Camargo circuit turns: the frame follows the first straight, later stances turn."""
    trial = _trial("camargo")
    heading = np.degrees([s.heading for s in trial.stances])
    assert abs(heading[0]) < 15 and abs(heading[1]) < 15
    assert abs(abs(heading[-1]) - 180) < 20  # back along the other side of the circuit
    text = describe_trial(trial)
    assert "path turns" in text and "heading +172 deg" in text


# --- C3D plate types -----------------------------------------------------------------------


def _readings(path):
    """(ezc3d's own platform readings, ours from the analogs) of a C3D's plates, in the file
    frame, SI: ezc3d is the independent reference (its moments converted with its own unit)."""
    import ezc3d

    from gc_ocp.io.c3d import _plate_readings

    c = ezc3d.c3d(str(path), extract_forceplat_data=True)
    own = _plate_readings(c, c["parameters"], path)
    ez = []
    for r, pf in zip(own, c["data"]["platform"], strict=True):
        mom = {"nmm": 1e-3, "nm": 1.0}[pf["unit_moment"].lower()]
        ez.append(
            {
                "type": r["type"],
                "force": np.asarray(pf["force"], float).T,
                "moment": np.asarray(pf["moment"], float).T * mom,
                "corners": np.asarray(pf["corners"], float).T
                * {"mm": 1e-3, "m": 1.0}[pf["unit_position"]],
            }
        )
    return ez, own, c


@needs_data
@pytest.mark.parametrize(
    "rel",
    [
        "c3dorg_helenhayes_types/type-2a.c3d",  # ORIGIN z < 0 (C3D convention)
        "c3dorg_helenhayes_types/type-4a.c3d",
        "plugingait_overground/test_small.c3d",  # ORIGIN z > 0 (Vicon)
        "motionanalysis_helenhayes/Gait.c3d",
    ],
)
def test_type_2_and_4_from_the_analogs_equal_ezc3d(rel):
    """Independent reference: ezc3d's type 2/4 wrench = ours from the channels (io/plates.py)."""
    ez, own, _ = _readings(DATA / rel)
    for a, b in zip(ez, own, strict=True):
        scale = np.abs(a["force"]).max()
        np.testing.assert_allclose(a["force"], b["force"], atol=1e-9 * scale)
        np.testing.assert_allclose(a["moment"], b["moment"], atol=1e-9 * scale)


@needs_data
def test_type_2a_and_4a_hold_the_same_counts_and_give_the_same_wrenches():
    """The two files store the same raw counts with two calibrations: type 2 a scale per
    channel, type 4 a 6 x 6 matrix with cross-talk terms and a diagonal 0.1 % from the type-2
    scales. So equal wrenches to 1e-6 are impossible; what is exact (1e-9) is that each file's
    wrench is its own calibration applied to the shared counts, and the processed wrenches
    then agree within the cross-talk (< 2 N, 0.4 % of the peak force)."""
    d = DATA / "c3dorg_helenhayes_types"
    ez2, _, c2 = _readings(d / "type-2a.c3d")
    ez4, _, c4 = _readings(d / "type-4a.c3d")
    s2 = np.asarray(c2["parameters"]["ANALOG"]["SCALE"]["value"], float)[:12]
    s4 = np.asarray(c4["parameters"]["ANALOG"]["SCALE"]["value"], float)[:12]
    counts2 = c2["data"]["analogs"][0][:12] / s2[:, None]
    counts4 = c4["data"]["analogs"][0][:12] / s4[:, None]
    np.testing.assert_array_equal(np.round(counts2), np.round(counts4))
    np.testing.assert_allclose(counts2, np.round(counts2), atol=1e-6)
    cal = np.asarray(c4["parameters"]["FORCE_PLATFORM"]["CAL_MATRIX"]["value"], float)
    origin = np.asarray(c4["parameters"]["FORCE_PLATFORM"]["ORIGIN"]["value"], float) * 1e-3
    from gc_ocp.io.plates import plate_axes

    for i in range(2):
        axes = plate_axes(ez2[i]["corners"])
        v2 = (counts2[6 * i : 6 * i + 6] * s2[6 * i : 6 * i + 6, None]).T.copy()
        v4 = (counts4[6 * i : 6 * i + 6] * s4[6 * i : 6 * i + 6, None]).T.copy()
        v2[:, 3:] *= 1e-3  # N mm -> N m
        f2, m2 = plate_wrench(2, v2, origin[:, i])
        w4 = v4 @ cal[:, :, i].T  # type 4: CAL_MATRIX @ signals = Fx Fy Fz Mx My Mz
        w4[:, 3:] *= 1e-3
        f4, m4 = plate_wrench(2, w4, origin[:, i])
        np.testing.assert_allclose(ez2[i]["force"], f2 @ axes.T, atol=1e-6)
        np.testing.assert_allclose(ez2[i]["moment"], m2 @ axes.T, atol=1e-6)
        np.testing.assert_allclose(ez4[i]["force"], f4 @ axes.T, atol=1e-6)
        np.testing.assert_allclose(ez4[i]["moment"], m4 @ axes.T, atol=1e-6)
    a, b = _trial("type-2a"), _trial("type-4a")
    assert [(s.side, s.plate) for s in a.stances] == [(s.side, s.plate) for s in b.stances]
    for s, u in zip(a.stances, b.stances, strict=True):
        assert abs(s.t_on - u.t_on) < 2e-3 and abs(s.t_off - u.t_off) < 2e-3
        p, q = a.plates[s.plate], b.plates[u.plate]
        sel = (p.time > s.t_on) & (p.time < s.t_off)
        assert np.abs(p.force[sel] - q.force[sel]).max() < 2.0
        assert np.abs(p.force[sel] - q.force[sel]).max() < 0.004 * p.force[sel, 2].max()
        cop_p, cop_q = p.cop(200.0)[sel], q.cop(200.0)[sel]
        ok = np.isfinite(cop_p[:, 0]) & np.isfinite(cop_q[:, 0])
        assert np.median(np.linalg.norm(cop_p[ok] - cop_q[ok], axis=1)) < 0.002


def test_type1_wrench_recovers_cop_and_free_moment():
    n = 50
    f = np.column_stack([RNG.normal(0, 50, n), RNG.normal(0, 50, n), RNG.uniform(-900, -100, n)])
    cop = RNG.uniform(-0.2, 0.2, (n, 2))
    tz = RNG.normal(0, 5, n)
    force, moment = type1_wrench(np.column_stack([f, cop, tz]))
    # independent: the moment about the centre of a force at the COP plus the free moment
    r = np.column_stack([cop, np.zeros(n)])
    expected = np.array([np.cross(r[k], f[k]) + [0, 0, tz[k]] for k in range(n)])
    np.testing.assert_allclose(moment, expected, atol=1e-9)
    # z down in plate axes: the COP on the surface plane from that wrench is the stored one
    flip = np.diag([1.0, -1.0, -1.0])  # plate axes (z down) -> z up
    back = cop_from_wrench(force @ flip, moment @ flip, np.zeros(3), 0.0, 1.0)
    np.testing.assert_allclose(back[:, :2], cop @ flip[:2, :2], atol=1e-9)


def test_type3_kistler_wrench_equals_the_sum_of_the_sensor_forces():
    """Independent reference: four point forces at the Kistler sensors (+-a, +-b, az0)."""
    a, b, az0 = 0.12, 0.2, -0.045
    n = 20
    sensors = np.array([[a, b, -az0], [-a, b, -az0], [-a, -b, -az0], [a, -b, -az0]])
    # z down: the sensor plane is |az0| below the surface (z = +|az0|)
    fx = RNG.normal(0, 20, (n, 4))
    fy = RNG.normal(0, 20, (n, 4))
    fz = RNG.uniform(-300, 0, (n, 4))
    # Kistler pairs: fx12 = x force of sensors 1+2, fx34 of 3+4, fy14 of 1+4, fy23 of 2+3; with
    # the x forces of each pair equal and the y forces of each pair equal (their split is not
    # measured; Kistler's Mz assumes it)
    fx[:, 1], fx[:, 3] = fx[:, 0], fx[:, 2]
    fy[:, 3], fy[:, 2] = fy[:, 0], fy[:, 1]
    ch = np.column_stack(
        [
            fx[:, 0] + fx[:, 1],
            fx[:, 2] + fx[:, 3],
            fy[:, 0] + fy[:, 3],
            fy[:, 1] + fy[:, 2],
            fz,
        ]
    )
    force, moment = type3_wrench(ch, np.array([a, b, az0]))
    f_each = np.stack([fx, fy, fz], axis=2)  # (n, 4, 3)
    np.testing.assert_allclose(force, f_each.sum(axis=1), atol=1e-9)
    expected = np.cross(np.broadcast_to(sensors, f_each.shape), f_each).sum(axis=1)
    np.testing.assert_allclose(moment, expected, atol=1e-9)


def test_type4_applies_the_calibration_matrix_then_type2():
    cal = np.eye(6) + RNG.normal(0, 0.01, (6, 6))
    v = RNG.normal(0, 100, (30, 6))
    origin = np.array([0.001, -0.002, -0.04])
    f4, m4 = type4_wrench(v, origin, cal)
    f2, m2 = plate_wrench(2, v @ cal.T, origin)
    np.testing.assert_allclose(f4, f2, atol=1e-12)
    np.testing.assert_allclose(m4, m2, atol=1e-12)
    # type 2: the moment about the surface centre C = transport from the origin O = C - ORIGIN
    np.testing.assert_allclose(
        m2, transport_moment(f2, (v @ cal.T)[:, 3:], -origin, np.zeros(3)), atol=1e-12
    )


@needs_data
@pytest.mark.parametrize("i", range(1, 6))
def test_bts_type1_cop_lies_under_the_stance_foot(i):
    """Type 1 (Bertec, Y-up BTS files): the COP of every stance is under its foot's markers.
    (ezc3d's type-1 moment has the opposite sign to its force: read that way, the COP was
    25-43 cm off and the second stance of Walking2-4 looked like a right foot off plate 2.)"""
    trial = _trial(f"Walking{i}")
    assert [(s.side, s.plate) for s in trial.stances] == [("right", 0), ("left", 1)]
    for s in trial.stances:
        p = trial.plates[s.plate]
        sel = (p.time > s.t_on + 0.1) & (p.time < s.t_off - 0.1)
        cop = p.cop(200.0)[sel]
        heel = {"right": "RCA", "left": "LCA"}[s.side]
        toe = {"right": "RIIT", "left": "LIIT"}[s.side]
        mid = np.argmin(abs(trial.marker_time - 0.5 * (s.t_on + s.t_off)))
        h, t = trial.marker(heel)[mid, :2], trial.marker(toe)[mid, :2]
        axis = (t - h) / np.linalg.norm(t - h)
        along = (cop[:, :2] - h) @ axis
        across = (cop[:, :2] - h) @ np.array([-axis[1], axis[0]])
        assert np.nanmedian(np.abs(across)) < 0.06  # within half a foot width of the foot axis
        assert -0.05 < np.nanmin(along) and np.nanmax(along) < np.linalg.norm(t - h) + 0.05


@needs_data
def test_y_up_c3d_detected_from_gravity_and_matches_screen_axes():
    trial = _trial("Walking1")
    assert vertical_axis_of(trial) == "+Y"
    assert not any("Y_SCREEN" in n for n in trial.load_notes)  # BTS: Y_SCREEN = +Y agrees
    assert vertical_axis_of(_trial("type-2a")) == "+Z"  # Y_SCREEN = +Z agrees too


# --- synthetic plates: rates, thresholds, exclusions ---------------------------------------


def _walk_case(plate_rate, marker_rate, cop_x=(0.15, 0.35), other_y=-0.5, heel_x=0.15):
    """One 0.5 m plate, a 0.6 s right stance, body walking at 1.2 m/s over planted feet."""
    t = np.arange(0, 1.0, 1.0 / plate_rate)
    fz = np.where((t > 0.2) & (t < 0.8), 600 * np.sin(np.pi * (t - 0.2) / 0.6), 0.0)
    f = np.column_stack([np.zeros_like(t), np.zeros_like(t), fz])
    cop = np.column_stack(
        [np.interp(t, [0.2, 0.8], cop_x), np.full_like(t, 0.25), np.zeros_like(t)]
    )
    e = np.array([0.25, 0.25, -0.04])
    m = transport_moment(f, np.zeros_like(f), cop, e)
    corners = np.array([[0.5, 0.5, 0], [0, 0.5, 0], [0, 0, 0], [0.5, 0, 0]], float)
    plate = Plate("plate1", t, f, m, e, "electrical_center", corners, 0.0, "C3D type 2")
    names = ["RHEE", "RTOE", "LHEE", "LTOE", "C7", "T10", "SACR", "LASI", "RASI"]
    mt = np.arange(0, 1.0, 1.0 / marker_rate)
    pos = np.array(
        [[heel_x, 0.25, 0.03], [0.35, 0.25, 0.03], [0.1, other_y, 0.03], [0.3, other_y, 0.03]]
        + [[0.0, 0.0, 1.4], [0.0, 0.0, 1.2], [0.0, 0.0, 1.0], [0.0, 0.1, 1.0], [0.0, -0.1, 1.0]]
    )
    markers = np.broadcast_to(pos, (len(mt), 9, 3)).copy()
    markers[:, 4:, 0] += 1.2 * mt[:, None]
    return [plate], names, markers, mt


@pytest.mark.parametrize(
    "plate_rate, marker_rate", [(1000, 100), (1080, 120), (1000, 60), (588, 60)]
)
def test_stance_times_with_any_rate_ratio(plate_rate, marker_rate):
    """Analog/marker ratios 10, 9, 16.67, 9.8: everything is resampled by time."""
    from gc_ocp.io.stances import detect_stances

    plates, names, markers, mt = _walk_case(plate_rate, marker_rate)
    stances, excluded, _ = detect_stances(plates, names, markers, mt, 600.0, 20.0, "syn")
    assert len(stances) == 1 and not excluded and stances[0].side == "right"
    exact = 0.2 + 0.6 / np.pi * np.arcsin(20 / 600)
    assert stances[0].t_on == pytest.approx(exact, abs=0.5 / plate_rate + 1e-4)
    assert abs(stances[0].heading) < 1e-6  # walking +X


@pytest.mark.parametrize(
    "case, reason",
    [
        ({"other_y": 0.4}, "two feet on plate1"),
        ({"heel_x": -0.05}, "foot partly off plate1"),
        ({"cop_x": (0.15, 0.7)}, "COP outside plate1"),
    ],
)
def test_exclusions_say_why_and_name_the_source(case, reason):
    from gc_ocp.io.stances import detect_stances

    plates, names, markers, mt = _walk_case(1000, 100, **case)
    with pytest.warns(
        UserWarning, match=rf"trial\.c3d: stance right on plate1 .* excluded: {reason}"
    ):
        stances, excluded, _ = detect_stances(plates, names, markers, mt, 600.0, 20.0, "trial.c3d")
    assert not stances and excluded[0].reason.startswith(reason)


def test_standing_is_not_a_walking_stance():
    from gc_ocp.io.stances import detect_stances

    plates, names, markers, mt = _walk_case(1000, 100)
    markers[:, 4:, 0] = 0.0  # the body does not move
    with pytest.warns(UserWarning, match="not a walking stance.*standing or stepping in place"):
        stances, excluded, _ = detect_stances(plates, names, markers, mt, 600.0, 20.0, "s")
    assert not stances and excluded[0].reason.startswith("not a walking stance")


def test_brief_cop_excursion_at_low_force_is_ignored_with_a_note():
    from gc_ocp.io.stances import detect_stances

    plates, names, markers, mt = _walk_case(1000, 100)
    p = plates[0]
    m = np.array(p.moment)
    k = np.flatnonzero((p.time > 0.26) & (p.time < 0.27))  # 10 ms spike: COP 1 m away
    m[k, 0] += p.force[k, 2] * 1.0
    plates = [Plate(p.name, p.time, p.force, m, p.reference_point, p.reference_kind, p.corners)]
    stances, excluded, notes = detect_stances(plates, names, markers, mt, 600.0, 20.0, "s")
    assert len(stances) == 1 and not excluded
    assert any("a transient, ignored" in n for n in notes)


# --- MOT plate naming ---------------------------------------------------------------------


@pytest.mark.parametrize(
    "columns, names",
    [
        (["ground_force_r", "ground_force_l"], ["grf_right", "grf_left"]),
        (["R_ground_force", "L_ground_force"], ["grf_right", "grf_left"]),
        (["ground_force", "1_ground_force"], ["grf_right", "grf_left"]),
        ([f"ground_force_{k}" for k in range(1, 4)], ["plate1", "plate2", "plate3"]),
    ],
)
def test_mot_column_sets_any_naming(columns, names):
    from gc_ocp.io.opensim import grf_sets

    cols = ["time"]
    for c in columns:
        pre, _, post = c.partition("force")
        cols += [f"{c}_v{a}" for a in "xyz"] + [f"{c}_p{a}" for a in "xyz"]
        cols += [f"{pre}torque{post}_{a}" for a in "xyz"]
    sets = grf_sets(cols)
    assert [s["name"] for s in sets] == names


# --- subject metadata ------------------------------------------------------------------------


@needs_data
@pytest.mark.parametrize("kind", ["json", "xml"])
def test_subject_metadata_beside_the_trial_gives_the_mass(tmp_path, kind):
    src = DATA / "opensim_rajagopal_overground"
    for f in ("motion_capture_walk.trc", "grf_walk.mot"):
        shutil.copy(src / f, tmp_path / f)
    if kind == "json":  # AddBiomechanics: _subject.json at the subject folder
        (tmp_path / "_subject.json").write_text(json.dumps({"massKg": 85.07, "heightM": 1.8}))
    else:
        (tmp_path / "setup_scale.xml").write_text(
            '<?xml version="1.0"?><OpenSimDocument Version="30000"><ScaleTool name="s">'
            "<mass>85.07</mass><height>1800</height></ScaleTool></OpenSimDocument>"
        )
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)  # no estimate warning
        trial = load_trial(tmp_path / "motion_capture_walk.trc", tmp_path / "grf_walk.mot")
    assert trial.mass == 85.07 and "subject metadata" in trial.mass_source
    assert trial.height == pytest.approx(1.8)
    given = load_trial(tmp_path / "motion_capture_walk.trc", tmp_path / "grf_walk.mot", mass=80)
    assert given.mass == 80 and given.mass_source == "given (mass=)"  # --mass overrides
    assert "mass 80.00 kg (given (mass=))" in describe_trial(given)


# --- bad input: one clear message, nothing written ------------------------------------------


@pytest.mark.parametrize("suffix", [".c3d", ".trc"])
def test_empty_file_names_the_file(tmp_path, suffix):
    bad = tmp_path / f"empty{suffix}"
    bad.write_bytes(b"")
    grf = None
    if suffix == ".trc":
        grf = tmp_path / "empty.mot"
        grf.write_text("")
    with pytest.raises(InputError, match=rf"empty{suffix.replace('.', '[.]')}"):
        load_trial(bad, grf)


@needs_data
def test_empty_mot_names_the_file(tmp_path):
    grf = tmp_path / "empty.mot"
    grf.write_text("")
    with pytest.raises(InputError, match=r"empty\.mot has no 'endheader'"):
        load_trial(DATA / "opensim_rajagopal_overground/motion_capture_walk.trc", grf)


@needs_data
def test_unsupported_plate_type_names_file_plate_and_fix(tmp_path):
    import ezc3d

    c = ezc3d.c3d(str(DATA / "plugingait_overground/test_small.c3d"))
    c["parameters"]["FORCE_PLATFORM"]["TYPE"]["value"] = np.array([2, 6, 2, 2])
    bad = tmp_path / "type6.c3d"
    c.write(str(bad))
    with pytest.raises(
        PlateError, match=r"Plate 2 in .*type6\.c3d is of C3D force-plate type 6.*type-2"
    ):
        load_trial(bad)


@needs_data
def test_fit_without_a_usable_stance_is_one_line_and_writes_nothing(tmp_path, capsys):
    """Two feet on every plate (the left foot markers moved onto the right stance's plate and
    vice versa): `gc-ocp fit` exits 2 with one line naming the file, the problem and the fix."""
    import ezc3d

    from gc_ocp.cli import main

    src = DATA / "plugingait_overground/test_small.c3d"
    c = ezc3d.c3d(str(src))
    labels = [s.strip() for s in c["parameters"]["POINT"]["LABELS"]["value"]]
    pts = c["data"]["points"]
    for a, b in (("LHEE", "RHEE"), ("LTOE", "RTOE"), ("LANK", "RANK")):
        i, j = labels.index(a), labels.index(b)
        pts[:3, i] = pts[:3, j] + np.array([[0.0], [120.0], [0.0]])  # beside the other foot
    c["data"]["points"] = pts
    bad = tmp_path / "two_feet.c3d"
    c.write(str(bad))
    out = tmp_path / "out"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        status = main(["fit", str(bad), "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1, err
    assert "two_feet.c3d" in err[0] and "no usable stance" in err[0] and "two feet on" in err[0]
    assert not out.exists()


@needs_data
def test_type1_file_reads_the_same_wrench_as_its_type2_original(tmp_path):
    """End to end through a C3D: plate 1 of the bundled Vicon file rewritten as type 1 (force,
    COP from the surface centre in mm, free moment in N mm, as a Bertec stores it) gives the same
    wrench as the type-2 original wherever the COP is defined."""
    import ezc3d

    from gc_ocp.io.c3d import read_c3d
    from gc_ocp.io.plates import plate_axes

    src = DATA / "plugingait_overground/test_small.c3d"
    c = ezc3d.c3d(str(src), extract_forceplat_data=True)
    pf = c["data"]["platform"][0]
    axes = plate_axes(pf["corners"].T)
    f = pf["force"].T @ axes  # lab -> plate axes
    m = pf["moment"].T @ axes  # about the surface centre [N mm]
    with np.errstate(divide="ignore", invalid="ignore"):
        dx, dy = -m[:, 1] / f[:, 2], m[:, 0] / f[:, 2]
    loaded = np.abs(f[:, 2]) > 20.0
    dx, dy = np.where(loaded, dx, 0.0), np.where(loaded, dy, 0.0)
    tz = m[:, 2] - dx * f[:, 1] + dy * f[:, 0]
    new = ezc3d.c3d(str(src))
    new["data"]["analogs"][0, :6] = np.column_stack([f, dx, dy, tz]).T
    new["parameters"]["FORCE_PLATFORM"]["TYPE"]["value"] = np.array([1, 2, 2, 2])
    out = tmp_path / "type1.c3d"
    new.write(str(out))
    a, b = read_c3d(src).plates[0], read_c3d(out).plates[0]
    assert b.plate_type == "C3D type 1" and b.reference_kind == "surface_center"
    centre = np.asarray(b.corners).mean(axis=0)
    ma = transport_moment(a.force, a.moment, a.reference_point, centre)
    mb = transport_moment(b.force, b.moment, b.reference_point, centre)
    sel = a.force[:, 2] > 20.0
    np.testing.assert_allclose(b.force, a.force, atol=1e-3)  # float32 storage
    np.testing.assert_allclose(mb[sel], ma[sel], atol=2e-3)
    np.testing.assert_allclose(b.cop(100.0), a.cop(100.0), atol=1e-4, equal_nan=True)


@needs_data
def test_screen_axis_that_disagrees_with_gravity_is_noted_and_the_data_win(tmp_path):
    import ezc3d

    c = ezc3d.c3d(str(DATA / "plugingait_overground/test_small.c3d"))
    c["parameters"]["POINT"]["Y_SCREEN"]["value"] = ["+Y"]
    bad = tmp_path / "screen.c3d"
    c.write(str(bad))
    trial = load_trial(bad)
    assert vertical_axis_of(trial) == "+Z"
    assert any("POINT:Y_SCREEN of screen.c3d says +Y" in n for n in trial.load_notes)


def _as_type3(src, out, unit: str | None = None, per: float = 1.0):
    """Plate 1 of ``src`` rewritten as a Kistler type 3 to ``out``: eight sensor channels (in
    ``unit`` when given, their values divided by ``per``), ORIGIN = a, b, az0 in mm; plate 3's
    channels hold the last two, so only two plates are used (USED = 2)."""
    import ezc3d

    from gc_ocp.io.plates import plate_axes

    pf = ezc3d.c3d(str(src), extract_forceplat_data=True)["data"]["platform"][0]
    axes = plate_axes(pf["corners"].T)
    f, m = pf["force"].T @ axes, pf["moment"].T @ axes  # plate axes; m about the centre [N mm]
    a, b, az0 = 120.0, 200.0, -45.0
    ms = m + np.cross(np.broadcast_to([0.0, 0.0, az0], f.shape), f)  # about the sensor plane
    # fz1..fz4 from Fz, Mx, My and a zero "warp" (the fourth, unmeasured combination)
    eqs = np.array([[1, 1, 1, 1], [b, b, -b, -b], [-a, a, a, -a], [1, -1, 1, -1]], float)
    rhs = np.column_stack([f[:, 2], ms[:, 0], ms[:, 1], np.zeros(len(f))])
    fz = np.linalg.solve(eqs, rhs.T).T
    fx34 = (f[:, 0] + ms[:, 2] / b) / 2
    sensors = np.column_stack([f[:, 0] - fx34, fx34, f[:, 1] / 2, f[:, 1] / 2, fz])
    c = ezc3d.c3d(str(src))
    analogs = c["data"]["analogs"]
    analogs[0, :6] = sensors[:, :6].T / per
    analogs[0, 12:14] = sensors[:, 6:].T / per  # channels of plate 3, dropped (USED = 2)
    c["data"]["analogs"] = analogs
    if unit is not None:
        units = list(c["parameters"]["ANALOG"]["UNITS"]["value"])
        for j in (0, 1, 2, 3, 4, 5, 12, 13):
            units[j] = unit
        c["parameters"]["ANALOG"]["UNITS"]["value"] = units
    fp = c["parameters"]["FORCE_PLATFORM"]
    chan = np.asarray(fp["CHANNEL"]["value"])
    chan8 = np.vstack([chan, chan[:2]])
    chan8[:, 0] = [1, 2, 3, 4, 5, 6, 13, 14]
    fp["CHANNEL"]["value"] = chan8
    fp["TYPE"]["value"] = np.array([3, 2, 2, 2])
    fp["USED"]["value"] = np.array([2])
    origin = np.asarray(fp["ORIGIN"]["value"], float).copy()
    origin[:, 0] = [a, b, az0]
    fp["ORIGIN"]["value"] = origin
    c.write(str(out))
    return out


@needs_data
def test_type3_file_reads_the_same_wrench_as_its_type2_original(tmp_path):
    """End to end through a C3D: plate 1 of the bundled file rewritten as a Kistler type 3
    (eight sensor channels, ORIGIN = a, b, az0 in mm) gives the original wrench."""
    from gc_ocp.io.c3d import read_c3d

    src = DATA / "plugingait_overground/test_small.c3d"
    raw = read_c3d(_as_type3(src, tmp_path / "type3.c3d"))
    assert len(raw.plates) == 2 and raw.plates[0].plate_type == "C3D type 3"
    p, q = read_c3d(src).plates[0], raw.plates[0]
    centre = np.asarray(q.corners).mean(axis=0)
    np.testing.assert_allclose(q.force, p.force, atol=1e-3)  # float32 storage
    np.testing.assert_allclose(
        transport_moment(q.force, q.moment, q.reference_point, centre),
        transport_moment(p.force, p.moment, p.reference_point, centre),
        atol=1e-3,
    )


# --- units of a C3D's plates: each channel in the unit the file gives it ---------------------


def _bundled_c3d():
    from gc_ocp.io.load import bundled_example_path

    return bundled_example_path()


def _moment_channels(c) -> list[int]:
    ch = np.asarray(c["parameters"]["FORCE_PLATFORM"]["CHANNEL"]["value"], int) - 1
    return [int(j) for j in ch[3:6].ravel()]


def _wrenches(path):
    from gc_ocp.io.c3d import read_c3d

    raw = read_c3d(Path(path))
    return [(p.name, p.force, p.moment, p.reference_point) for p in raw.plates]


# (force unit, N per unit), (moment unit, N mm per unit): how labs label their channels
CHANNEL_UNITS = {
    "moments_in_Nm": (None, ("Nm", 1000.0)),
    "moments_in_Ncm": (None, ("N.cm", 10.0)),
    "forces_in_kN": (("kN", 1000.0), ("kN*mm", 1000.0)),
    "forces_in_lbf": (("lbf", 4.4482216152605), ("lbf in", 112.98482902761668)),
    "forces_in_daN": (("daN", 10.0), None),
}


@pytest.mark.parametrize("variant", ["markers_in_metres", *CHANNEL_UNITS])
def test_plate_wrench_follows_each_channels_own_unit(tmp_path, variant):
    """Valid ways a lab stores the same trial: POINT:UNITS m (markers, CORNERS and ORIGIN
    in metres) with the moment channels still in N mm, or the force and moment channels in
    another unit their ANALOG:UNITS names (N m, N cm, kN, lbf with lbf in, daN). Each must give
    the clean file's plates (the values are divided by up to 1000 in float32 storage, so
    agreement is to float32's ~1e-7 of each channel's scale, checked at 1e-5 of the peak).
    ezc3d's platform wrench takes the moments' unit from POINT:UNITS and came out 1000x off
    here; the forces' unit was not read at all (a file in kN or lbf was taken as newtons)."""
    import ezc3d

    src = _bundled_c3d()
    c = ezc3d.c3d(str(src))
    if variant == "markers_in_metres":
        c["parameters"]["POINT"]["UNITS"]["value"] = ["m"]
        c["data"]["points"][:3] /= 1000.0
        fp = c["parameters"]["FORCE_PLATFORM"]
        fp["CORNERS"]["value"] = np.asarray(fp["CORNERS"]["value"]) / 1000.0
        fp["ORIGIN"]["value"] = np.asarray(fp["ORIGIN"]["value"]) / 1000.0
    else:
        units = list(c["parameters"]["ANALOG"]["UNITS"]["value"])
        ch = np.asarray(c["parameters"]["FORCE_PLATFORM"]["CHANNEL"]["value"], int) - 1
        for rows, unit in zip((ch[:3], ch[3:6]), CHANNEL_UNITS[variant], strict=True):
            for j in [] if unit is None else rows.ravel():
                units[j] = unit[0]
                c["data"]["analogs"][0, j, :] /= unit[1]
        c["parameters"]["ANALOG"]["UNITS"]["value"] = units
    out = tmp_path / "variant.c3d"
    c.write(str(out))
    clean, other = _wrenches(src), _wrenches(out)
    assert [p[0] for p in clean] == [p[0] for p in other]
    for (_, f0, m0, r0), (_, f1, m1, r1) in zip(clean, other, strict=True):
        # float32 storage of a value divided by 1000: ~1e-7 relative per sample
        np.testing.assert_allclose(f1, f0, atol=1e-5 * np.abs(f0).max() + 1e-6)
        np.testing.assert_allclose(m1, m0, atol=1e-5 * np.abs(m0).max() + 1e-6)
        np.testing.assert_allclose(r1, r0, atol=1e-6)


@pytest.mark.parametrize("which, unit", [("force", "psi"), ("moment", "kgf")])
def test_a_plate_channel_in_a_unit_that_is_not_a_force_or_moment_is_refused(tmp_path, which, unit):
    """A force channel labelled with a unit that is no force (or a moment channel with one that
    is no moment) names the file, the plate, the channel and the unit: read as newtons it would
    make every force wrong by an unknown factor."""
    from gc_ocp.errors import UnitsError
    from gc_ocp.io.c3d import read_c3d

    def change(c):
        units = list(c["parameters"]["ANALOG"]["UNITS"]["value"])
        units[_plate_channel(c, 0, 0 if which == "force" else 3)] = unit
        c["parameters"]["ANALOG"]["UNITS"]["value"] = units

    out = _variant(tmp_path, change)
    with pytest.raises(UnitsError, match=f"plate 1's {which} channel has ANALOG:UNITS '{unit}'"):
        read_c3d(out)


def test_plates_in_kilonewtons_labelled_newtons_say_so(tmp_path):
    """The force channels divided by 1000 but still labelled N (a kN recording exported with
    the wrong unit): no plate reaches the 20 N contact threshold, and the refusal says that the
    largest force, under a newton, is no person's and names the channels' unit to check."""
    from gc_ocp.errors import InputError
    from gc_ocp.io import load_trial
    from gc_ocp.io.checks import force_unit_hint, require_stances

    def change(c):
        ch = np.asarray(c["parameters"]["FORCE_PLATFORM"]["CHANNEL"]["value"], int) - 1
        for j in ch[:6].ravel():
            c["data"]["analogs"][0, j, :] /= 1000.0

    out = _variant(tmp_path, change)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        trial = load_trial(out)  # the file's mass
    with pytest.raises(InputError, match=r"largest vertical force on any plate is 0\.\d+ N"):
        require_stances(trial)
    assert "probably in kN" in force_unit_hint(trial.plates, 20.0)
    assert force_unit_hint(load_trial(_bundled_c3d()).plates, 20.0) == ""  # newtons: nothing


def _variant(tmp_path, change):
    """The bundled C3D with ``change(c)`` applied (ezc3d), written to ``tmp_path``."""
    import ezc3d

    c = ezc3d.c3d(str(_bundled_c3d()))
    change(c)
    out = tmp_path / "variant.c3d"
    c.write(str(out))
    return out


def _plate_channel(c, plate: int, comp: int) -> int:
    ch = np.asarray(c["parameters"]["FORCE_PLATFORM"]["CHANNEL"]["value"], int) - 1
    return int(ch[comp, plate])


def _most_loaded_plate() -> int:
    from gc_ocp.io.c3d import read_c3d

    raw = read_c3d(_bundled_c3d())
    return int(np.argmax([np.nanmax(p.force[:, 2]) for p in raw.plates]))


def test_plates_storing_the_force_on_the_plate_are_negated_with_a_note(tmp_path):
    """Every channel of every plate negated (a writer that stores the action on the plate):
    the same ground reactions as the clean file, and the reading says what it did."""
    from gc_ocp.io.c3d import read_c3d

    def negate_all(c):
        ch = np.asarray(c["parameters"]["FORCE_PLATFORM"]["CHANNEL"]["value"], int) - 1
        c["data"]["analogs"][0, ch.ravel(), :] *= -1.0

    clean = _wrenches(_bundled_c3d())
    raw = read_c3d(_variant(tmp_path, negate_all))
    assert any("negated" in n for n in raw.notes)
    for (_, f0, m0, _), p in zip(clean, raw.plates, strict=True):
        np.testing.assert_allclose(p.force, f0, atol=1e-9 * np.abs(f0).max())
        np.testing.assert_allclose(p.moment, m0, atol=1e-9 * np.abs(m0).max())


def test_one_plate_with_a_negative_vertical_force_is_named(tmp_path):
    """One plate's vertical channel with the wrong sign (its ANALOG:SCALE): the plates disagree.
    Before, that plate's stance silently vanished (its loaded samples were looked for among
    positive forces only) and the fit ran on the others."""
    k = _most_loaded_plate()

    def flip_fz(c):
        c["data"]["analogs"][0, _plate_channel(c, k, 2), :] *= -1.0

    with pytest.raises(PlateError, match=rf"plate{k + 1} read a negative vertical force.*CORNERS"):
        load_trial(_variant(tmp_path, flip_fz))


@pytest.mark.parametrize("how", ["collinear", "nan", "nan_first", "zero"])
def test_a_loaded_plate_with_unusable_corners_is_an_error_naming_them(tmp_path, how):
    """Before, a loaded plate whose corners do not span a surface was skipped with a note and
    its stance silently lost."""
    k = _most_loaded_plate()

    def break_corners(c):
        fp = c["parameters"]["FORCE_PLATFORM"]
        corners = np.asarray(fp["CORNERS"]["value"], float).copy()  # (3, 4, n_plates)
        if how == "nan":
            corners[:, 2, k] = np.nan
        elif how == "nan_first":  # a corner the plate's axes are built from
            corners[:, 0, k] = np.nan
        elif how == "zero":  # a plate never set up
            corners[:, :, k] = 0.0
        else:
            corners[:, 3, k] = corners[:, 0, k] + 0.5 * (corners[:, 1, k] - corners[:, 0, k])
        fp["CORNERS"]["value"] = corners

    with pytest.raises(PlateError, match=rf"Plate {k + 1} .*CORNERS"):
        load_trial(_variant(tmp_path, break_corners))


def test_a_plate_never_unloaded_keeps_its_reading(tmp_path):
    """A plate loaded for the whole file (600 N), with a stance's load changing on top of it:
    its quiet stretch at 600 N is a load, not an amplifier's zero, and is not subtracted
    (before, it was removed as an 'unloaded offset'). A plate whose reading never changes by a
    load is unloaded, and its level is its zero however large (the bundled plates 3-4 read
    -32 and -16 N unloaded)."""
    from gc_ocp.io.c3d import read_c3d
    from gc_ocp.io.plates import plate_axes

    clean = read_c3d(_bundled_c3d())
    peaks = [np.nanmax(p.force[:, 2]) for p in clean.plates]
    k, m = int(np.argmin(peaks)), int(np.argmax(peaks))  # the least and the most loaded plate
    # the channel is along the plate's z axis, which points down into it (the C3D
    # convention): a force upward on the subject is negative in the channel
    z_k = plate_axes(clean.plates[k].corners)[2, 2]
    z_m = plate_axes(clean.plates[m].corners)[2, 2]

    def load_it(c):
        fz_m = c["data"]["analogs"][0, _plate_channel(c, m, 2), :] * z_m  # upward [N]
        c["data"]["analogs"][0, _plate_channel(c, k, 2), :] += (600.0 + fz_m) / z_k

    with pytest.warns(UserWarning, match="a load, not an unloaded offset"):
        raw = read_c3d(_variant(tmp_path, load_it))
    assert raw.plates[k].zero_offset is None
    assert np.median(raw.plates[k].force[:, 2]) > 500.0


@pytest.mark.parametrize("lost", [0.0, np.nan])
def test_a_plate_dropout_inside_a_stance_is_named_not_split_into_two(tmp_path, lost):
    """200 ms of zeros (or NaN) in a loaded plate's channels mid-stance. Before, zeros split
    the stance into two 'stances' that were both fitted, and NaN made it vanish silently."""
    from gc_ocp.io.c3d import read_c3d

    clean = load_trial(_bundled_c3d())
    k = _most_loaded_plate()
    s = next(s for s in clean.stances if s.plate == k)
    rate = 1.0 / float(np.median(np.diff(read_c3d(_bundled_c3d()).plates[k].time)))
    a, b = int((s.t_on + 0.3 * s.duration) * rate), int((s.t_on + 0.3 * s.duration + 0.2) * rate)

    def drop(c):
        ch = np.asarray(c["parameters"]["FORCE_PLATFORM"]["CHANNEL"]["value"], int)[:, k] - 1
        c["data"]["analogs"][0, ch, a:b] = lost

    t = load_trial(_variant(tmp_path, drop))
    assert [x.label for x in t.stances] == [x.label for x in clean.stances if x is not s]
    gone = [e for e in t.excluded_stances if e.plate == k]
    assert len(gone) == 2 and all("dropped out" in e.reason for e in gone)


def test_more_plates_used_than_described_is_an_error(tmp_path):
    def short(c):
        fp = c["parameters"]["FORCE_PLATFORM"]
        fp["TYPE"]["value"] = np.asarray(fp["TYPE"]["value"])[:1]

    with pytest.raises(PlateError, match="USED says 4 plates but FORCE_PLATFORM:TYPE lists 1"):
        load_trial(_variant(tmp_path, short))


def test_a_plate_with_ten_times_its_gain_is_named(tmp_path):
    """Every channel of one loaded plate 10x (a wrong calibration): its stance peaks at ~6.6 kN
    against the others' ~0.66 kN. Before, the file read without a word (and, without a stored
    mass, the mass was estimated at 358 kg)."""
    k = _most_loaded_plate()

    def gain(c):
        ch = np.asarray(c["parameters"]["FORCE_PLATFORM"]["CHANNEL"]["value"], int)[:, k] - 1
        c["data"]["analogs"][0, ch, :] *= 10.0

    with pytest.raises(PlateError, match=rf"stance peaks disagree by .*plate{k + 1}"):
        load_trial(_variant(tmp_path, gain))


@pytest.mark.parametrize("order", [(3, 0, 1, 2), (1, 0, 3, 2)])  # rotated, mirrored
def test_plates_whose_corners_are_listed_in_another_order_lose_their_stances_with_the_reason(
    tmp_path, order
):
    """The corners in another order turn the plate's axes: the COP then moves across the foot
    or from toe to heel. Before, the rotated set-up was fitted silently (shear axes swapped:
    mu 0.13 against 0.24, c at its bound)."""

    def reorder(c):
        fp = c["parameters"]["FORCE_PLATFORM"]
        fp["CORNERS"]["value"] = np.asarray(fp["CORNERS"]["value"], float)[:, list(order), :]

    t = load_trial(_variant(tmp_path, reorder))
    assert not t.stances
    assert t.excluded_stances and all(
        "heel to toe" in e.reason and "CORNERS" in e.reason for e in t.excluded_stances
    )


@pytest.mark.parametrize(
    "plate, offset_n",
    [
        ("most loaded", 200.0),  # small against the ~660 N its stance adds: its zero
        ("least loaded", 80.0),  # a plate nobody steps on: flat, its level is its zero
    ],
)
def test_a_large_amplifier_offset_is_still_removed(tmp_path, plate, offset_n):
    """An amplifier not zeroed: 200 N on the most loaded plate's vertical channel, or 80 N on
    a plate nobody steps on (before the review's fix, the latter was kept as 'a load' and the
    plates then disagreed in sign). Either is the plate's zero and is removed: the ground
    reaction is the clean file's (float32 storage of the shifted channel: 1e-3 N)."""
    from gc_ocp.io.c3d import read_c3d
    from gc_ocp.io.plates import plate_axes

    clean = read_c3d(_bundled_c3d())
    peaks = [np.nanmax(p.force[:, 2]) for p in clean.plates]
    k = int(np.argmax(peaks) if plate == "most loaded" else np.argmin(peaks))
    z_up = plate_axes(clean.plates[k].corners)[2, 2]

    def offset(c):
        c["data"]["analogs"][0, _plate_channel(c, k, 2), :] += -offset_n / z_up

    raw = read_c3d(_variant(tmp_path, offset))
    assert raw.plates[k].zero_offset is not None
    np.testing.assert_allclose(raw.plates[k].force, clean.plates[k].force, atol=1e-3)


def test_a_nan_dropout_on_a_noisy_plate_reads(tmp_path):
    """A missing stretch of samples in a plate whose noise is ~3 N: the zero is found on the
    whole windows (before, one NaN made every window 'not quiet' and the reading crashed)."""
    k = _most_loaded_plate()
    rng = np.random.default_rng(0)

    def noisy_gap(c):
        ch = np.asarray(c["parameters"]["FORCE_PLATFORM"]["CHANNEL"]["value"], int)[:, k] - 1
        a = c["data"]["analogs"]
        a[0, ch, :] += rng.normal(0.0, 3.0, size=a[0, ch, :].shape)
        a[0, ch, 100:130] = np.nan

    from gc_ocp.io.c3d import read_c3d

    raw = read_c3d(_variant(tmp_path, noisy_gap))
    assert raw.plates[k].zero_offset is not None
    assert abs(raw.plates[k].zero_offset[2]) < 3.0  # the noise's mean over the quiet windows


def test_walking_backward_keeps_its_stances(tmp_path):
    """The bundled trial played backwards: the subject walks backward and each stance's COP
    rolls from toe to heel, forward in the direction of travel; no stance is taken for a plate
    with wrong axes."""

    def reverse(c):
        c["data"]["points"] = c["data"]["points"][:, :, ::-1].copy()
        c["data"]["analogs"] = c["data"]["analogs"][:, :, ::-1].copy()
        for k in ("residuals", "camera_masks"):
            c["data"]["meta_points"][k] = c["data"]["meta_points"][k][:, :, ::-1].copy()

    t = load_trial(_variant(tmp_path, reverse))
    assert len(t.stances) == len(load_trial(_bundled_c3d()).stances)
    assert not t.excluded_stances


def test_a_dropout_just_after_heel_strike_is_named(tmp_path):
    """Zeros from 50 to 150 ms into a stance leave a first part shorter than a contact (0.1 s):
    before, it was dropped as no contact and the rest kept as a stance without its loading
    response."""
    from gc_ocp.io.c3d import read_c3d

    clean = load_trial(_bundled_c3d())
    k = _most_loaded_plate()
    s = next(s for s in clean.stances if s.plate == k)
    rate = 1.0 / float(np.median(np.diff(read_c3d(_bundled_c3d()).plates[k].time)))
    a, b = int((s.t_on + 0.05) * rate), int((s.t_on + 0.15) * rate)

    def drop(c):
        ch = np.asarray(c["parameters"]["FORCE_PLATFORM"]["CHANNEL"]["value"], int)[:, k] - 1
        c["data"]["analogs"][0, ch, a:b] = 0.0

    t = load_trial(_variant(tmp_path, drop))
    assert all(x.plate != k for x in t.stances)
    assert any(e.plate == k and "dropped out" in e.reason for e in t.excluded_stances)


def test_a_static_trial_with_a_broken_plate_still_loads(tmp_path):
    """A static trial needs its markers; its plates only help find the vertical axis, so a
    plate set up wrongly there is skipped, not an error (``load_static`` reads it so)."""
    from gc_ocp.io.c3d import read_c3d

    k = _most_loaded_plate()

    def break_corners(c):
        fp = c["parameters"]["FORCE_PLATFORM"]
        corners = np.asarray(fp["CORNERS"]["value"], float).copy()
        corners[:, 0, k] = np.nan
        fp["CORNERS"]["value"] = corners

    path = _variant(tmp_path, break_corners)
    with pytest.raises(PlateError, match="CORNERS"):
        load_trial(path)
    # as load_static reads it (its own check then wants a standing subject: this file walks)
    raw = read_c3d(path, strict=False)
    assert raw.marker_names == read_c3d(_bundled_c3d()).marker_names
    assert f"plate{k + 1}: loaded but its corners are not numbers (NaN), skipped" in raw.notes
    assert all(p.name != f"plate{k + 1}" for p in raw.plates)


@needs_data
def test_type_1_cop_channels_are_read_in_their_own_unit(tmp_path):
    """A BTS (type-1) trial whose COP channels are stored in metres (ANALOG:UNITS m) with the
    markers in mm: the same plates (before, the COP was scaled by the markers' unit)."""
    import ezc3d

    from gc_ocp.io.c3d import read_c3d

    src = DATA / "bts_unipd_5trials" / "Walking1.c3d"
    c = ezc3d.c3d(str(src))
    ch = np.asarray(c["parameters"]["FORCE_PLATFORM"]["CHANNEL"]["value"], int) - 1
    units = list(c["parameters"]["ANALOG"]["UNITS"]["value"])
    for j in ch[3:5].ravel():  # Px, Py of every plate
        units[j] = "m"
        c["data"]["analogs"][0, j, :] /= 1000.0
    c["parameters"]["ANALOG"]["UNITS"]["value"] = units
    out = tmp_path / "cop_in_m.c3d"
    c.write(str(out))
    for a, b in zip(read_c3d(src).plates, read_c3d(out).plates, strict=True):
        np.testing.assert_allclose(b.moment, a.moment, atol=1e-5 * np.abs(a.moment).max())


@needs_data
@pytest.mark.parametrize("zeroed_below, offset", [(50.0, 0.0), (120.0, 0.0), (50.0, -1.5)])
def test_stance_clipped_by_the_file_start_stays_clipped_on_a_zeroed_plate(
    tmp_path, zeroed_below, offset
):
    """Gait2392's left plate reads 20.5 N at the first sample, rising 8 N per sample: a stance
    clipped by the file start (the README's "others are clipped by the file ends"). A lab zeroing
    below 50 N (or 120 N) sets its first samples to 0, which says "below 50 N", not "below the
    20 N contact threshold": the stance is still clipped (before: used by the fit). The same
    with an offset of -1.5 N removed after the zeroing, so that the zeros read -1.5 N (before
    2026-12-01 the file's first samples were then not read as zeros, and the stance was used)."""
    src = DATA / README["gait2392"][1]
    lines = src.read_text().splitlines()
    end = [x.strip() for x in lines].index("endheader")  # header lines end in tabs
    cols = lines[end + 1].split()
    data = np.loadtxt(src, skiprows=end + 2)
    for pre in ("", "1_"):
        low = data[:, cols.index(f"{pre}ground_force_vy")] < zeroed_below
        for j, c in enumerate(cols):
            if c.startswith((f"{pre}ground_force_", f"{pre}ground_torque_")):
                data[low, j] = 0.0
        data[:, cols.index(f"{pre}ground_force_vy")] += offset
    grf = tmp_path / "zeroed_grf.mot"
    body = "\n".join("\t".join(f"{v:.8g}" for v in row) for row in data)
    grf.write_text("\n".join(lines[: end + 2]) + "\n" + body + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        trial = load_trial(DATA / README["gait2392"][0], grf=grf, mass=72.6)
    used = sorted((s.side, round(s.t_on, 1)) for s in trial.stances)
    assert used == [("left", 1.3), ("right", 0.6)]  # the README's two full stances
    first = [s for s in trial.excluded_stances if s.side == "left" and s.t_on < 0.1]
    reads = "reads 0" if offset == 0.0 else f"reads {offset:g} N throughout (its zeroing level)"
    assert len(first) == 1 and first[0].reason.startswith(f"clipped: the plate {reads}")


def test_type3_sensor_channels_follow_their_force_unit(tmp_path):
    """A Kistler (type 3) plate whose eight sensor channels are in kN (ANALOG:UNITS 'kN') was
    read as newtons, 1000x too light, while types 1 and 2 followed the unit (a unit that is no
    force unit is still read as N, as before). Plate 1 of the bundled file as type 3 in N and
    the same in kN give one wrench (float32 storage of a value divided by 1000: ~1e-7 relative,
    checked at 1e-5 of the peak)."""
    from gc_ocp.io.c3d import read_c3d

    src = _bundled_c3d()
    plates = {
        unit: read_c3d(_as_type3(src, tmp_path / f"type3_{unit}.c3d", unit, per)).plates[0]
        for unit, per in (("N", 1.0), ("kN", 1000.0))
    }
    n, k = plates["N"], plates["kN"]
    assert n.plate_type == k.plate_type == "C3D type 3"
    np.testing.assert_allclose(k.force, n.force, atol=1e-5 * np.abs(n.force).max())
    np.testing.assert_allclose(k.moment, n.moment, atol=1e-5 * np.abs(n.moment).max())
