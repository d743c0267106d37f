"""Marker recognition by anatomical landmark (gc_ocp.model.landmarks) and the foot-marker rules:
conventions, side/separator variants, clusters and virtual points, duplicates, ambiguity,
the untrackable-foot error, rigid-body gap fill, and kinematics on other labs' files."""

from __future__ import annotations

import functools
import json
import warnings

import numpy as np
import pytest
from conftest import DATA, G23, _need_data, c3d_trial, gait2392_trial

from gc_ocp.errors import InputError, MarkerError
from gc_ocp.gaps import fill_rigid_gaps
from gc_ocp.model.landmarks import classify, split_side
from gc_ocp.model.markerset import detect_markerset
from gc_ocp.model.recognition import markerset_from_recognition, recognise_landmarks

CONVENTIONS = {
    "plug-in gait": {
        "LHEE": "heel",
        "LTOE": "metatarsal_2",
        "LANK": "ankle_lateral",
        "LKNE": "knee_lateral",
        "LASI": "asis",
        "RPSI": "psis",
        "SACR": "sacrum",
        "LKNEin": "knee_medial",
        "RANKin": "ankle_medial",
        "C7": "c7",
        "CLAV": "jugular_notch",
    },
    "cgm2": {  # the Conventional Gait Model 2's medial markers (pyCGM2)
        "LKNM": "knee_medial",
        "RKNM": "knee_medial",
        "LMED": "ankle_medial",
        "RMED": "ankle_medial",
        "LMMA": "ankle_medial",
    },
    "helen hayes": {
        "RHEE": "heel",
        "RTOE": "metatarsal_2",
        "RANK": "ankle_lateral",
        "RKNE": "knee_lateral",
        "VSAC": "sacrum",
        "IJ": "jugular_notch",
        "PX": "xiphoid",
    },
    "cast / visual3d": {
        "RCAL": "heel",
        "RFCC": "heel",
        "RFM1": "metatarsal_1",
        "RFM2": "metatarsal_2",
        "RFM5": "metatarsal_5",
        "RLM": "ankle_lateral",
        "RMM": "ankle_medial",
        "RLE": "knee_lateral",
        "RME": "knee_medial",
        "RASIS": "asis",
        "RPSIS": "psis",
    },
    "bts": {
        "RCA": "heel",
        "RLM": "ankle_lateral",
        "RMM": "ankle_medial",
        "RVMH": "metatarsal_5",
        "RIMH": "metatarsal_1",
        "RIIT": "toe_tip",
        "RGT": "greater_trochanter",
        "RHF": "fibula_head",
        "RTT": "tibial_tuberosity",
        "L5": "lumbar5",
        "LCA": "heel",
    },
    "ior / rizzoli": {
        "RFMH": "metatarsal_1",
        "RSMH": "metatarsal_2",
        "RVMH": "metatarsal_5",
        "RST": "calcaneus_medial",
        "RPT": "calcaneus_lateral",
        "RHLX": "toe_tip",
        "RNT": "midfoot_medial",
    },
    "oxford foot": {
        "RD1M": "metatarsal_1",
        "RD5M": "metatarsal_5",
        "RP1M": "midfoot_medial",
        "RP5M": "midfoot_lateral",
        "RLCA": "calcaneus_lateral",
        "RSTL": "calcaneus_medial",
        "RPCA": "heel",
        "RHLX": "toe_tip",
    },
    "opensim": {
        "R.Heel": "heel",
        "R.MT5": "metatarsal_5",
        "R.Toe": "metatarsal_2",
        "R.Ankle": "ankle_lateral",
        "R.MAnkle": "ankle_medial",
        "R.Midfoot.Sup": "midfoot_superior",
        "R.Midfoot.Lat": "midfoot_lateral",
        "R.Toe.Tip": "toe_tip",
        "R.Toe.Lat": "metatarsal_5",
        "R.Toe.Med": "metatarsal_1",
        "R.Knee": "knee_lateral",
        "R.MKnee": "knee_medial",
        "V.Sacral": "sacrum",
        "S2": "sacrum",
    },
    "opencap": {
        "r_calc_study": "heel",
        "r_toe_study": "metatarsal_2",
        "r_5meta_study": "metatarsal_5",
        "r_ankle_study": "ankle_lateral",
        "r_mankle_study": "ankle_medial",
        "r_knee_study": "knee_lateral",
        "r_mknee_study": "knee_medial",
        "r.ASIS_study": "asis",
        "L.PSIS_study": "psis",
    },
    "camargo": {
        "R_Heel": "heel",
        "R_Toe_Tip": "toe_tip",
        "R_Toe_Lat": "metatarsal_5",
        "R_Toe_Med": "metatarsal_1",
        "R_Ankle_Lat": "ankle_lateral",
        "R_Knee_Lat": "knee_lateral",
        "R_ASIS": "asis",
    },
}


@pytest.mark.parametrize("convention", sorted(CONVENTIONS))
def test_recognises_each_convention(convention):
    for label, landmark in CONVENTIONS[convention].items():
        kind, key, side = classify(label)
        assert (kind, key) == ("landmark", landmark), (convention, label, kind, key)
        midline = key in ("sacrum", "lumbar5", "c7", "jugular_notch", "xiphoid")
        expected_side = None if midline else ("left" if label[0] in "lL" else "right")
        assert side == expected_side, (label, side)


@pytest.mark.parametrize(
    ("right", "left"),
    [
        ("RHEE", "LHEE"),
        ("R.Heel", "L.Heel"),
        ("r_heel", "l_heel"),
        ("R heel", "L heel"),
        ("Right Heel", "Left Heel"),
        ("RightHeel", "LeftHeel"),
        ("right_heel", "left_heel"),
        ("Heel_R", "Heel_L"),
        ("heel.r", "heel.l"),
        ("HeelR", "HeelL"),
        ("rheel", "lheel"),
        ("R-HEEL", "L-HEEL"),
        ("RHeel", "LHeel"),
        ("Heel Right", "Heel Left"),
    ],
)
def test_side_and_separator_variants(right, left):
    assert classify(right) == ("landmark", "heel", "right")
    assert classify(left) == ("landmark", "heel", "left")


def test_split_side_keeps_midline_reading_last():
    assert split_side("L5")[-1] == (None, "L5")
    assert classify("L5") == ("landmark", "lumbar5", None)  # not a left "5"


@pytest.mark.parametrize(
    ("label", "segment"),
    [
        ("RTH1", "thigh"),
        ("R.TH4", "thigh"),
        ("R_Thigh_Upper", "thigh"),
        ("LF01", "thigh"),
        ("RTHI", "thigh"),
        ("RT03", "shank"),
        ("R.SH2", "shank"),
        ("L_Shank_Front", "shank"),
        ("RTIB", "shank"),
        ("LSHA", "shank"),
        ("R.Bicep", "upper_arm"),
    ],
)
def test_clusters_are_tracking_markers(label, segment):
    kind, key, side = classify(label)
    assert kind == "cluster" and key == f"cluster:{segment}", (label, kind, key)
    rec = recognise_landmarks([label], require_feet=False)
    assert rec.matches[0].cluster


@pytest.mark.parametrize(
    "label",
    [
        "*3",
        "*10",
        "#",
        "RightHipCenter",
        "LeftHipCenterGamage",
        "L.HeelGround",
        "R.ToeGround",
        "R_HJC",
        "MidASIS",
        "LKneeAngles",
        "LHipAnglesV",
        "RGroundReactionForce",
        "CentreOfMass",
        "RFEO",
        "LTIA",
        "R.AnkleJoint",
        "RAnklePower",
    ],
)
def test_virtual_points_are_never_landmarks(label):
    assert classify(label)[0] == "virtual", label


def test_unknown_labels_are_ignored_with_the_reason():
    rec = recognise_landmarks(["XYZ", "RHEE"], require_feet=False)
    assert [m.label for m in rec.matches] == ["RHEE"]
    assert rec.ignored[0][0] == "XYZ" and rec.ignored[0][2].startswith("unknown")


def _pelvis_and_legs(n=20, seed=0):
    """Synthetic standing subject (lab: X forward, Y left, Z up) with Helen Hayes labels;
    returns labels, markers (n, m, 3) and the true lateral/medial knee positions."""
    rng = np.random.default_rng(seed)
    pts = {
        "RASI": [0.05, -0.12, 0.95],
        "LASI": [0.05, 0.12, 0.95],
        "VSAC": [-0.12, 0.0, 0.97],
        "RHEE": [-0.07, -0.09, 0.04],
        "RTOE": [0.13, -0.09, 0.04],
        "RANK": [0.0, -0.13, 0.08],
        "LHEE": [-0.07, 0.09, 0.04],
        "LTOE": [0.13, 0.09, 0.04],
        "LANK": [0.0, 0.13, 0.08],
    }
    labels = list(pts)
    xyz = [pts[k] for k in labels]
    # one label on two points: the medial knee first, the lateral one second
    labels += ["RKNE", "RKNE"]
    xyz += [[0.0, -0.04, 0.5], [0.0, -0.14, 0.5]]
    m = np.array(xyz)[None] + 0.002 * rng.standard_normal((n, len(labels), 3))
    return labels, m


def test_duplicate_label_split_into_lateral_and_medial():
    labels, m = _pelvis_and_legs()
    rec = recognise_landmarks(labels, m, "synthetic.c3d")
    got = {(x.key, x.column): x.landmark for x in rec.matches}
    assert got[("RKNE", 9)] == "knee_medial"  # the first column is 4 cm from the mid-line
    assert got[("RKNE#2", 10)] == "knee_lateral"
    assert any("RKNE" in n and "knee_lateral" in n for n in rec.notes)
    ms = markerset_from_recognition(rec)
    assert ms.columns["RKNE#2"] == 10 and ms.markers["RKNE#2"].segment == "thigh_r"


def test_duplicate_label_empty_copy_is_dropped():
    labels, m = _pelvis_and_legs()
    m = m.copy()
    m[:, 9] = np.nan  # the first RKNE is never visible
    rec = recognise_landmarks(labels, m, "synthetic.c3d")
    knee = [x for x in rec.matches if x.label == "RKNE"]
    assert [(x.column, x.landmark) for x in knee] == [(10, "knee_lateral")]
    assert ("RKNE", 9, "empty: no frame with this marker") in rec.ignored


def test_two_labels_for_one_landmark_warn_naming_both():
    labels, m = _pelvis_and_legs()
    labels, m = labels[:9] + ["R.Heel"], np.concatenate([m[:, :9], m[:, 3:4]], axis=1)
    m[:5, 3] = np.nan  # RHEE is visible in fewer frames than R.Heel
    with pytest.warns(UserWarning, match=r'"RHEE".*"R\.Heel"'):
        rec = recognise_landmarks(labels, m, "synthetic.c3d")
    heel = [x for x in rec.matches if x.landmark == "heel" and x.side == "right"]
    assert [x.label for x in heel] == ["R.Heel"]
    assert any(r.startswith("conflict") for lab, _, r in rec.ignored if lab == "RHEE")


def test_untrackable_foot_error_names_file_markers_and_what_is_missing():
    labels = ["RASI", "LASI", "SACR", "RKNE", "LKNE", "LHEE", "LTOE", "LANK", "RTHI"]
    with pytest.raises(MarkerError) as e:
        recognise_landmarks(labels, None, "lab/walk01.c3d")
    msg = str(e.value)
    assert "lab/walk01.c3d" in msg and "right foot" in msg
    assert "no foot landmark" in msg and "RKNE=knee_lateral" in msg and "heel" in msg
    # one foot landmark and no malleolus
    with pytest.raises(MarkerError, match="only one foot landmark"):
        recognise_landmarks(labels + ["RHEE"], None, "lab/walk01.c3d")


def test_two_foot_landmarks_need_a_malleolus():
    base = ["RASI", "LASI", "SACR", "LHEE", "LTOE", "LANK"]
    rec = recognise_landmarks([*base, "RHEE", "RTOE", "RANK"], None, "hh.c3d")
    assert [m.landmark for m in rec.foot("right")] == ["heel", "metatarsal_2"]
    ms = markerset_from_recognition(rec)
    assert ms.markers["RANK"].segment == "shank_r"
    ms.select([*base, "RHEE", "RTOE", "RANK"], "hh.c3d")  # accepted: the shank fixes the ankle
    with pytest.raises(MarkerError, match="collinear and there is no malleolus"):
        recognise_landmarks([*base, "RHEE", "RTOE"], None, "hh.c3d")


def test_shipped_sets_take_precedence_on_an_exact_match():
    trial = c3d_trial()
    ms = detect_markerset(trial.marker_names, trial.markers, trial.source)
    assert ms.name == "plugingait" and ms.columns is None
    assert ms.recognition["markerset"] == "plugingait"
    assert {m["label"]: m["landmark"] for m in ms.recognition["markers"]}["LHEE"] == "heel"
    # one recognised label outside the set -> the set is built from the landmarks
    names = [*trial.marker_names, "RKNEin"]
    m = np.concatenate([trial.markers, trial.markers[:, :1]], axis=1)
    assert detect_markerset(names, m, "x").name == "landmarks"


def test_rigid_fill_is_exact_for_a_rigid_body():
    rng = np.random.default_rng(1)
    local = rng.uniform(-0.1, 0.1, (5, 3))
    n = 60
    t = np.linspace(0, 1, n)
    x = np.empty((n, 5, 3))
    for k, tk in enumerate(t):
        a = 0.8 * tk
        R = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
        x[k] = local @ R.T + [tk, 0.1 * tk**2, 0.02 * np.sin(6 * tk)]
    cut = x.copy()
    cut[20:45, 2] = np.nan  # 25 frames, far longer than a spline fill would bridge
    out, done = fill_rigid_gaps(cut, [[0, 1, 2, 3, 4]])
    assert np.allclose(out, x, atol=1e-12)
    assert done == [(2, 20, 45, [0, 1, 3, 4])]


def test_rigid_fill_needs_three_noncollinear_donors():
    x = np.zeros((10, 3, 3))
    x[:, :, 0] = [0.0, 0.1, 0.2]
    x[3:6, 2] = np.nan
    out, done = fill_rigid_gaps(x, [[0, 1, 2]])
    assert np.isnan(out[3:6, 2]).all() and done == []


def test_rigid_fill_bridges_a_cut_gap_in_a_real_stance():
    """gait2392 right foot: cut R.Toe.Med over the last 0.35 s of the right stance (heel rise
    and push-off, the foot rotating by tens of degrees); the fill from the other foot markers
    stays within skin and marker noise of the true marker, far better than an interpolation."""
    trial = gait2392_trial()
    names = list(trial.marker_names)
    foot = [
        names.index(n)
        for n in ("R.Heel", "R.Midfoot.Sup", "R.Midfoot.Lat", "R.Toe.Lat", "R.Toe.Med")
    ]
    st = next(s for s in trial.stances if s.side == "right")
    t = trial.marker_time
    gap = np.flatnonzero((t >= st.t_off - 0.35) & (t <= st.t_off))  # heel rise to toe-off
    x = np.asarray(trial.markers)[:, foot].copy()
    truth = x[gap, 4].copy()
    x[gap, 4] = np.nan
    out, done = fill_rigid_gaps(x, [list(range(5))])
    err = np.linalg.norm(out[gap, 4] - truth, axis=1)
    lin = np.array(
        [
            np.interp(t[gap], t[~np.isnan(x[:, 4, 0])], x[~np.isnan(x[:, 4, 0]), 4, c])
            for c in range(3)
        ]
    ).T
    err_lin = np.linalg.norm(lin - truth, axis=1)
    # measured: fill max 5.3 mm (median 2.9), linear interpolation max 45 mm (median 31)
    assert done and err.max() < 0.008 and np.median(err) < 0.004, err
    assert err.max() < 0.25 * err_lin.max(), (err.max(), err_lin.max())


@functools.cache
def _helen_hayes():
    from gc_ocp.io import load_trial

    _need_data()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_trial(DATA / "motionanalysis_helenhayes/Gait.c3d", mass=80.0)


def test_helen_hayes_two_foot_markers_and_duplicates_give_kinematics():
    from gc_ocp.kinematics import compute_kinematics

    trial = _helen_hayes()
    kin = compute_kinematics(trial)
    lm = kin.info["landmarks"]
    assert lm["markerset"] == "landmarks"
    got = {m["marker"]: m["landmark"] for m in lm["markers"]}
    assert got["RKNE"] == "knee_lateral" and got["RKNE#2"] == "knee_medial"
    assert got["RANK"] == "ankle_lateral" and got["RANK#2"] == "ankle_medial"
    assert len(lm["notes"]) == 4  # the four duplicated labels, each explained
    json.dumps(lm)  # plain data
    r = kin.info["residuals"]
    for name in ("RHEE", "RTOE", "LHEE", "LTOE"):
        i = kin.marker_names.index(name)
        assert np.nanmedian(r[:, i]) < 0.01, name


def test_two_foot_markers_and_the_shank_fix_the_foot():
    """BTS Walking1, left stance: with LVMH and LIMH removed (as the right foot of every BTS
    trial), the foot posed by the remaining LCA, LIIT and the shank puts the model's LVMH
    within 2 cm of the true marker."""
    import dataclasses

    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics

    _need_data()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        trial = load_trial(DATA / "bts_unipd_5trials/Walking1.c3d", mass=95.0)
    names = list(trial.marker_names)
    st = next(s for s in trial.stances if s.side == "left")
    t = trial.marker_time
    win = np.flatnonzero((t >= st.t_on + 0.1 * st.duration) & (t <= st.t_off - 0.1 * st.duration))
    m = np.array(trial.markers)
    truth = m[win, names.index("LVMH")].copy()
    m[win[0] : win[-1] + 1, [names.index("LVMH"), names.index("LIMH")]] = np.nan
    cut = dataclasses.replace(trial, markers=m)
    kin = compute_kinematics(cut)
    mm = kin.info["marker_model"]
    model = mm.positions(kin.q[win])[:, list(mm.names).index("LVMH")]
    err = np.linalg.norm(model - truth, axis=1)
    assert np.median(err) < 0.02, np.median(err)


def test_a_first_metatarsal_marker_alone_places_the_medial_unit():
    """A Davis-like foot (BTS Walking1 without the fifth-metatarsal and toe-tip markers: heel
    and first metatarsal head left): the first metatarsal head is medial, so the medial
    anterior unit sits at it and the lateral one a foot width lateral. Checked in the lab
    against the full-marker layout (both metatarsal heads) over the left stance's foot-flat
    (20-60 % of stance): each anterior unit within 2 cm (the Davis foot's roll about the
    heel-metatarsal line is levelled while the full-marker foot rolls 4-9 deg in a stance,
    ~5 mm at a unit; the foot-width ratio against this subject's metatarsal spacing). Taking the marker as the mid-line put them ~5 cm off. (The
    right foot's metatarsal markers have gaps in its stances, so its full-marker pose is
    itself chain-posed there.)"""
    import dataclasses

    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics

    _need_data()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        trial = load_trial(DATA / "bts_unipd_5trials/Walking1.c3d")
        drop = {"RVMH", "LVMH", "RIIT", "LIIT"}
        keep = [i for i, n in enumerate(trial.marker_names) if n not in drop]
        davis = dataclasses.replace(
            trial,
            marker_names=tuple(trial.marker_names[i] for i in keep),
            markers=np.asarray(trial.markers)[:, keep],
        )
        full, cut = compute_kinematics(trial), compute_kinematics(davis, foot_roll="level")
        chain = compute_kinematics(davis)
    st = next(s for s in trial.stances if s.side == "left")
    a, b = full.feet["left"], cut.feet["left"]
    w = np.flatnonzero(
        (a.time >= st.t_on + 0.2 * st.duration) & (a.time <= st.t_off - 0.4 * st.duration)
    )

    # AL, AM (units 2, 3) in the lab over the window
    err = np.median(np.linalg.norm(b.positions[w, 2:4] - a.positions[w, 2:4], axis=2), axis=0)
    assert np.all(err < 0.02), err
    # foot_roll="level": the two-landmark foot's Y axis horizontal on every frame of the window
    # (round-off of the rotation: 1e-9); the default poses it through the chain, and the
    # full-marker foot by its markers: neither is level (> 3 deg somewhere in the window)
    assert np.abs(b.hindfoot_pose[w, 2, 1]).max() < 1e-9
    assert np.abs(chain.feet["left"].hindfoot_pose[w, 2, 1]).max() > 0.05
    assert np.abs(a.hindfoot_pose[w, 2, 1]).max() > 0.05
    assert cut.info["foot_roll"] == {"left": "level", "right": "level"}
    assert chain.info["foot_roll"] == {"left": "chain", "right": "chain"}
    assert full.info["foot_roll"] == {"left": "markers", "right": "markers"}
    with pytest.raises(InputError, match="foot_roll"):
        compute_kinematics(davis, foot_roll="sideways")


def test_level_roll_undoes_a_roll_about_the_landmarks_and_keeps_them():
    """A foot rolled by a known angle about the line through its two landmarks comes back level
    (hindfoot Y horizontal), the landmarks where they were and the toes welded to it; the
    angle taken is the smallest (the roll undone, not the level pose turned over)."""
    from scipy.spatial.transform import Rotation

    from gc_ocp.kinematics.pipeline import level_roll

    rng = np.random.default_rng(3)
    n = 7
    yaw, pitch = rng.uniform(-1.0, 1.0, n), rng.uniform(-0.4, 0.4, n)  # any heading, toe up/down
    R0 = Rotation.from_euler("ZY", np.c_[yaw, pitch]).as_matrix()  # level: Y horizontal
    p0 = rng.normal(size=(n, 3))
    heel, met = np.array([-0.05, 0.0, -0.03]), np.array([0.15, -0.03, -0.02])  # in the foot
    a, b = p0 + R0 @ heel, p0 + R0 @ met
    u = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
    psi = np.deg2rad(rng.uniform(-25, 25, n))
    Rr = Rotation.from_rotvec(u * psi[:, None]).as_matrix()
    toes_in_hind = np.eye(4)
    toes_in_hind[:3, 3] = [0.12, 0.0, 0.01]

    def pose(R, p):
        M = np.tile(np.eye(4), (n, 1, 1))
        M[:, :3, :3], M[:, :3, 3] = R, p
        return M

    rolled = pose(Rr @ R0, a + np.einsum("tij,tj->ti", Rr, p0 - a))
    out = level_roll({"hindfoot": rolled, "toes": rolled @ toes_in_hind}, a, b)
    H = out["hindfoot"]
    assert np.abs(H[:, 2, 1]).max() < 1e-12  # Y horizontal
    np.testing.assert_allclose(H[:, :3, :3], R0, atol=1e-12)  # the smallest angle: psi undone
    np.testing.assert_allclose(H[:, :3, 3] + H[:, :3, :3] @ heel, a, atol=1e-12)
    np.testing.assert_allclose(H[:, :3, 3] + H[:, :3, :3] @ met, b, atol=1e-12)
    np.testing.assert_allclose(
        np.linalg.inv(H) @ out["toes"], np.tile(toes_in_hind, (n, 1, 1)), atol=1e-12
    )


def test_cli_kinematics_writes_and_prints_landmarks(tmp_path, capsys):
    from gc_ocp.cli import main

    _need_data()
    g = G23
    assert (
        main(
            [
                "kinematics",
                str(g / "subject01_walk1.trc"),
                "--grf",
                str(g / "subject01_walk1_grf.mot"),
                "--mass",
                "72.6",
                "--out",
                str(tmp_path),
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "R.Toe.Tip" in out and "toe_tip" in out
    lm = json.loads((tmp_path / "landmarks.json").read_text())
    assert lm["markerset"] == "gait2392"
    assert {m["label"]: m["segment"] for m in lm["markers"]}["R.Heel"] == "hindfoot_r"


WALKING_FILES = {
    # file (in ../shared/data), grf, mass given (not recorded in most files), expected set, the
    # right foot's landmarks
    "plugingait_overground/test_small.c3d": (None, None, "plugingait", None),
    "opensim_rajagopal_overground/motion_capture_walk.trc": (
        "opensim_rajagopal_overground/grf_walk.mot",
        85.07,
        "rajagopal",
        None,
    ),
    "opensim_gait2392_treadmill/subject01_walk1.trc": (
        "opensim_gait2392_treadmill/subject01_walk1_grf.mot",
        72.6,
        "gait2392",
        None,
    ),
    "vicon_plugingait_btk/PiG_Motion3_FF.c3d": (None, None, "plugingait", None),
    "vicon_plugingait_clusters/FunctionalWalk.c3d": (
        None,
        None,
        "landmarks",
        ["heel", "metatarsal_2"],
    ),
    "motionanalysis_helenhayes/Gait.c3d": (None, 80.0, "landmarks", ["heel", "metatarsal_2"]),
    "c3dorg_helenhayes_types/type-2a.c3d": (None, 55.0, "landmarks", ["heel", "metatarsal_2"]),
    "c3dorg_helenhayes_types/type-4a.c3d": (None, 55.0, "landmarks", ["heel", "metatarsal_2"]),
    **{
        f"bts_unipd_5trials/Walking{i}.c3d": (
            None,
            95.0,
            "landmarks",
            ["heel", "metatarsal_5", "metatarsal_1", "toe_tip"],
        )
        for i in range(1, 6)
    },
    "camargo_opensim_circuit/levelground_ccw_fast_01_01.trc": (
        "camargo_opensim_circuit/levelground_ccw_fast_01_01_grf.mot",
        70.0,
        "landmarks",
        ["heel", "metatarsal_5", "metatarsal_1", "toe_tip"],
    ),
}


@functools.cache
def _walking(name: str):
    from gc_ocp.io import load_trial

    _need_data()
    grf, mass, _, _ = WALKING_FILES[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_trial(DATA / name, grf=DATA / grf if grf else None, mass=mass)


@pytest.mark.parametrize("name", sorted(WALKING_FILES))
def test_every_walking_file_gets_its_landmarks(name):
    trial = _walking(name)
    _, _, expected, right_foot = WALKING_FILES[name]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no ambiguity in any of these files
        ms = detect_markerset(trial.marker_names, trial.markers, trial.source)
    assert ms.name == expected
    if right_foot is not None:
        rec = ms.recognition
        got = [m["landmark"] for m in rec["markers"] if m["segment"] in ("hindfoot_r", "toes_r")]
        assert sorted(got) == sorted(right_foot)
        shank = {m["landmark"] for m in rec["markers"] if m["segment"] == "shank_r"}
        assert "ankle_lateral" in shank


@pytest.mark.parametrize(
    "name",
    [
        "vicon_plugingait_clusters/FunctionalWalk.c3d",  # clusters, empty medial markers
        "c3dorg_helenhayes_types/type-2a.c3d",  # no usable left stance: excluded-stance sole
        "camargo_opensim_circuit/levelground_ccw_fast_01_01.trc",  # gaps in stance, metres
    ],
)
def test_kinematics_without_a_markerset_file(name):
    from gc_ocp.kinematics import compute_kinematics

    kin = compute_kinematics(_walking(name))
    assert kin.info["markerset"] == "landmarks"
    assert np.nanmedian(kin.marker_rms) < 0.012
    # every frame with markers is posed; type-2a's frames without any marker (230 of 360) are not
    posed = np.isfinite(kin.marker_rms)
    assert posed.mean() > 0.3
    for side in ("left", "right"):
        pos = kin.feet[side].positions
        assert np.isfinite(pos[posed]).all() and not np.isfinite(pos[~posed]).any()


def test_a_markerset_given_overrides_recognition():
    from gc_ocp.kinematics import compute_kinematics

    trial = _walking("vicon_plugingait_clusters/FunctionalWalk.c3d")
    kin = compute_kinematics(trial, markerset="plugingait")
    assert kin.info["markerset"] == "plugingait" and "LF01" not in kin.marker_names
    lm = kin.info["landmarks"]
    assert lm["markerset"] == "plugingait"
    assert {m["label"]: m["segment"] for m in lm["markers"]}["LANK"] == "hindfoot_l"


def test_a_foot_whose_markers_are_empty_columns_says_so():
    """Labels present but never a position (a file exported with the foot's markers blank):
    the message names them as empty, not as missing."""
    from gc_ocp.model.recognition import recognise_landmarks

    labels = ["LHEE", "LTOE", "LANK", "RHEE", "RTOE", "RANK", "RMT5"]
    markers = np.random.default_rng(0).normal(size=(10, len(labels), 3))
    markers[:, :3] = np.nan
    with pytest.raises(MarkerError, match=r"left foot .*LHEE, LTOE, LANK but no position"):
        recognise_landmarks(labels, markers, "x.c3d")
