"""Kinematics: filtering, IK on synthetic and real markers, sole-point heights in mid-stance."""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import c3d_trial, gait2392_static, gait2392_trial, rajagopal_static, rajagopal_trial

from gc_ocp.foot import UNITS
from gc_ocp.geometry import kabsch
from gc_ocp.kinematics import compute_kinematics, lowpass, solve_ik
from gc_ocp.kinematics.scaling import build_marker_model
from gc_ocp.model import BodyModel
from gc_ocp.model.markerset import load_markerset


def test_lowpass_zero_lag_and_gaps():
    rate = 100.0
    t = np.arange(300) / rate
    x = np.sin(2 * np.pi * 1.0 * t) + 0.2 * np.sin(2 * np.pi * 30 * t)
    x[100:105] = np.nan  # 50 ms gap: filled
    y = lowpass(x[:, None], rate, 6.0)[:, 0]
    core = np.r_[30:85, 120:270]  # away from the filtfilt edge transients and the filled gap
    # 1 Hz passes with |H|^2 = 1/(1+(1/6)^8) ~ 1 - 6e-7 and no phase lag; 30 Hz is cut by ~(30/6)^-4
    np.testing.assert_allclose(y[core], np.sin(2 * np.pi * t[core]), atol=5e-3)
    # near the gap the spline fill through the 30 Hz ripple leaves < 0.1 of error, but no NaN
    assert (
        np.all(np.isfinite(y)) and np.max(np.abs(y[85:120] - np.sin(2 * np.pi * t[85:120]))) < 0.1
    )
    x[150:200] = np.nan  # 0.5 s gap: too long to fill, stays NaN
    y = lowpass(x[:, None], rate, 6.0)[:, 0]
    assert np.all(np.isnan(y[150:200])) and np.all(np.isfinite(y[:150]))


def test_kabsch_recovers_pose_batched_and_never_reflects():
    rng = np.random.default_rng(3)
    local = rng.normal(0, 0.1, (5, 3))
    R_true = np.stack([pin.exp3(rng.normal(0, 1, 3)) for _ in range(4)])
    t_true = rng.normal(0, 1, (4, 3))
    lab = np.einsum("nij,mj->nmi", R_true, local) + t_true[:, None]
    R, t = kabsch(local, lab)  # time-first batch
    np.testing.assert_allclose(R, R_true, atol=1e-12)
    np.testing.assert_allclose(t, t_true, atol=1e-12)
    R0, t0 = kabsch(local, lab[0])  # one frame: the same numbers as the batch's first frame
    np.testing.assert_array_equal(R0, R[0])
    np.testing.assert_array_equal(t0, t[0])
    # mirrored points: the best orthogonal fit is a reflection; kabsch returns a rotation
    R, _ = kabsch(local, local * [1.0, 1.0, -1.0])
    assert np.linalg.det(R) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="but got"):
        kabsch(local, lab[:, :4])


@functools.cache
def _synthetic():
    body = BodyModel.from_subject(1.70, 70.0)
    ms = load_markerset("plugingait")
    mm = build_marker_model(body, ms, list(ms.markers), 1.70)
    rng = np.random.default_rng(1)
    n = 30
    q = np.zeros((n, body.nq))
    base = rng.uniform(-0.3, 0.3, body.nq)
    base[[body.q_index(j) for j in ("pelvis_tx", "pelvis_ty", "pelvis_tz")]] = [0.2, -0.1, 0.95]
    for k in range(n):  # smooth motion
        q[k] = base + 0.2 * np.sin(0.1 * k + np.arange(body.nq))
    q = np.clip(q, body.lower_limits, body.upper_limits)
    return mm, q, mm.positions(q)


def test_ik_recovers_synthetic_configuration():
    mm, q_true, markers = _synthetic()
    res = solve_ik(mm, markers)
    # exact data: the marker RMS goes to the solver tolerance (well below 0.1 mm)
    assert np.max(res.marker_rms) < 1e-4
    # joints seen by >= 3 markers are recovered; tolerance 1e-3 rad because arm and shank joints are
    # weakly observable with Plug-in Gait's single lateral markers (LM converges slowly there)
    legs = [
        mm.body.q_index(j) for j in mm.body.joint_names if not j.startswith(("shoulder", "elbow"))
    ]
    np.testing.assert_allclose(res.q[:, legs], q_true[:, legs], atol=1e-3)


def test_ik_respects_limits():
    mm, q_true, markers = _synthetic()
    bad = markers.copy()
    bad[:, :, 2] += np.linspace(0, 3, len(bad))[:, None]  # unreachable: limits must hold
    res = solve_ik(mm, bad[:5])
    assert np.all(res.q >= mm.body.lower_limits - 1e-12) and np.all(
        res.q <= mm.body.upper_limits + 1e-12
    )


DATASETS = {
    "plugingait": (c3d_trial, None),
    "rajagopal": (rajagopal_trial, None),
    "rajagopal+static": (rajagopal_trial, rajagopal_static),
    "gait2392": (gait2392_trial, None),
    "gait2392+static": (gait2392_trial, gait2392_static),
}


@functools.cache
def _kin(name):
    tf, sf = DATASETS[name]
    return tf(), compute_kinematics(tf(), static=sf() if sf else None)


def _heights(trial, kin, lo, hi):
    """Unit heights above the stance's plate surface [mm] for lo..hi fractions of each stance."""
    out = []
    for st in trial.stances:
        f = kin.feet[st.side]
        sel = (f.time >= st.t_on + lo * st.duration) & (f.time <= st.t_on + hi * st.duration)
        out.append((f.positions[sel, :, 2] - trial.plates[st.plate].surface_height) * 1e3)
    return np.concatenate(out)


@pytest.mark.parametrize("name", list(DATASETS))
def test_real_marker_rms(name):
    trial, kin = _kin(name)
    med, p95 = 1e3 * np.median(kin.marker_rms), 1e3 * np.percentile(kin.marker_rms, 95)
    print(
        f"\n{name}: marker RMS median {med:.1f} mm, p95 {p95:.1f} mm, IK {kin.info['ik_seconds']:.1f} s"
    )
    # Skin-marker soft-tissue artefact is 10-30 mm on the thigh and 5-15 mm on the shank/foot
    # (Leardini et al. 2005, Gait Posture 21:212); a rigid-segment model cannot fit it, so the
    # per-frame RMS of a good fit is ~5-15 mm. Median < 15 mm, 95th percentile < 25 mm.
    assert med < 15.0
    assert p95 < 25.0
    assert kin.q.shape == (len(trial.marker_time), 27)
    assert kin.info["ik_seconds"] < 30  # seconds per trial, not minutes


@pytest.mark.parametrize("name", list(DATASETS))
def test_mid_stance_sole_heights(name):
    trial, kin = _kin(name)
    early = _heights(trial, kin, 0.25, 0.50)
    late = _heights(trial, kin, 0.50, 0.75)
    i = {u: k for k, u in enumerate(UNITS)}
    for u in UNITS:
        print(
            f"\n{name} {u}: 25-50% [{early[:, i[u]].min():.1f}, {early[:, i[u]].max():.1f}] mm, "
            f"50-75% [{late[:, i[u]].min():.1f}, {late[:, i[u]].max():.1f}] mm",
            end="",
        )
    # Foot-flat (25-50 % of stance): the whole sole is on the floor. 50-75 %: heel-off has
    # started (heel rises, here up to ~25 mm) and the foot rolls over the metatarsal heads, so only
    # the anterior hindfoot units must stay on the floor; the welded toe tip then dips below it
    # (the real toes dorsiflex), which is a model limitation, not asserted. 15 mm is the bound of the
    # brief: about the soft-tissue artefact of foot markers plus heel-pad compression (~10 mm).
    assert np.all(np.abs(early[:, [i["PL"], i["PM"], i["AL"], i["AM"], i["TT"]]]) <= 15.0)
    assert np.all(np.abs(late[:, [i["AL"], i["AM"]]]) <= 15.0)


def test_twists_match_finite_differences():
    trial, kin = _kin("plugingait")
    f = kin.feet["left"]
    dt = np.gradient(f.time)
    v_fd = np.gradient(f.positions, f.time, axis=0)
    # q-dot is np.gradient(q): positions are smooth at 6 Hz, so the chain-rule velocity and the
    # finite difference of the positions agree to O(dt^2 * jerk) ~ a few cm/s at most.
    err = np.abs(f.velocities - v_fd)[2:-2]
    assert np.median(err) < 0.01 and np.max(err) < 0.1
    assert dt.min() > 0
    # pose consistency: TT position equals toes pose applied to its local point
    p = f.toes_pose[:, :3, :3] @ f.points_local[4] + f.toes_pose[:, :3, 3]
    np.testing.assert_allclose(p, f.positions[:, 4], atol=1e-12)
    # LOCAL_WORLD_ALIGNED convention: recompute one twist by hand from Pinocchio
    body = kin.info["body"]
    data = body.create_data()
    k = len(f.time) // 2
    v = np.gradient(kin.q, kin.time, axis=0)[k]
    pin.forwardKinematics(body.model, data, kin.q[k], v)
    pin.updateFramePlacements(body.model, data)
    fid = body.foot_frames("left")["hindfoot"]
    tw = pin.getFrameVelocity(body.model, data, fid, pin.LOCAL_WORLD_ALIGNED)
    np.testing.assert_allclose(f.hindfoot_twist[k], np.r_[tw.linear, tw.angular], atol=1e-12)


def test_io_height_estimate_is_the_pipelines():
    from gc_ocp.io import estimate_height_from_markers

    trial, kin = _kin("rajagopal")
    assert trial.height is None  # so the pipeline estimated it
    height, how = estimate_height_from_markers(trial)
    assert height == kin.info["height"] and "pelvis" in how


def test_frames_without_any_marker_pose_nothing():
    """Frames in which no marker is seen (the subject outside the capture volume: the c3d.org
    Helen Hayes files have markers in 130 of 360 frames) had finite feet made up by the IK (the
    pelvis at the lab origin, the feet 0.8 m under the floor, or the last pose held), and the
    first frame with markers a foot speed of 30 m/s from the central difference across the edge.
    They are NaN now (dropped by the stance cut, as a marker gap), and the frames with markers
    keep the velocities they have without the empty frames."""
    from dataclasses import replace

    trial, kin = _kin("plugingait")
    k0 = 25  # before the first stance (0.406 s at 100 Hz)
    markers = np.array(trial.markers, float, copy=True)
    markers[:k0] = np.nan
    kin2 = compute_kinematics(replace(trial, markers=markers))
    assert np.all(np.isnan(kin2.q[:k0])) and np.all(np.isfinite(kin2.q[k0:]))
    for side in ("left", "right"):
        f, g = kin.feet[side], kin2.feet[side]
        assert not np.isfinite(g.positions[:k0]).any() and not np.isfinite(g.velocities[:k0]).any()
        assert np.isfinite(g.velocities[k0:]).all()
        # the first seen frames: a one-sided difference, not one across the empty frames
        np.testing.assert_allclose(g.velocities[k0 : k0 + 3], f.velocities[k0 : k0 + 3], atol=0.3)


def _static_without(marker, keep_frames=()):
    """The Rajagopal static trial with ``marker``'s column emptied except ``keep_frames``."""
    import dataclasses

    st = rajagopal_static()
    m = np.array(st.markers)
    j = st.marker_names.index(marker)
    keep = m[list(keep_frames), j]
    m[:, j] = np.nan
    m[list(keep_frames), j] = keep
    return dataclasses.replace(st, markers=m)


def test_a_foot_marker_the_static_hardly_shows_is_registered_on_the_walking_trial():
    # A static trial's foot marker seen on few or none of its frames (an empty column; the BTS
    # static's RIMH: a ghost 7 mm from the lateral malleolus in 1 frame of 107) was registered
    # from those frames (none: its nominal position) and then held there for the whole trial.
    # It is registered on the walking frames instead, as a marker the static lacks.
    trial = rajagopal_trial()
    walk = _kin("rajagopal")[1].info["marker_local"]["R.Heel"]
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # no All-NaN slice from the foot check
        kin = compute_kinematics(trial, static=_static_without("R.Heel"))
    # The full static's registration of R.Heel is 5.9 mm from the walking one's (skin over the
    # heel pad moves between standing and walking); the old nominal position was 20.9 mm off.
    assert np.linalg.norm(kin.info["marker_local"]["R.Heel"] - walk) < 0.010


def test_the_bts_static_ghost_of_a_metatarsal_marker_is_not_registered():
    from conftest import DATA, _quiet

    from gc_ocp.io import load_static, load_trial

    bts = DATA / "bts_unipd_5trials"
    if not bts.is_dir():
        pytest.skip(f"{bts} not found")
    trial = _quiet(load_trial, bts / "Walking1.c3d")
    static = _quiet(load_static, bts / "Static1.c3d", trial)
    walk = compute_kinematics(trial).info["marker_local"]["RIMH"]
    got = compute_kinematics(trial, static=static).info["marker_local"]["RIMH"]
    # 9.6 mm from the walking trial's registration (which rests on the 16 % of the walking
    # frames that show RIMH); the ghost frame put it 45 mm away (33 mm short of the MTP line).
    assert np.linalg.norm(got - walk) < 0.015


def test_a_given_marker_sets_foot_marker_with_an_empty_column_is_an_error():
    # --markerset plugingait on a file whose LTOE column is empty (labelled, never seen) posed
    # the left foot from LHEE and LANK alone, its roll about them free, and reported it as
    # "posed by its markers"; detection refuses the same file (recognition: one foot landmark)
    import dataclasses

    from gc_ocp.errors import MarkerError

    t = c3d_trial()
    m = np.array(t.markers)
    m[:, t.marker_names.index("LTOE")] = np.nan
    with pytest.raises(MarkerError, match='"LTOE" of marker set "plugingait".*no position in any'):
        compute_kinematics(dataclasses.replace(t, markers=m), markerset="plugingait")


def test_a_static_trial_with_left_and_right_swapped_is_refused():
    # the Rajagopal static with every L./R. label exchanged was used as given: each leg's
    # markers registered on the other leg, walking marker RMS 42 mm (7 mm) and sole points
    # 0.2 m under the foot; a walking trial so swapped is refused by load_trial
    import dataclasses

    from gc_ocp.errors import InputError

    st = rajagopal_static()
    other = {"L": "R", "R": "L"}
    names = tuple(other.get(n[0], n[0]) + n[1:] for n in st.marker_names)
    with pytest.raises(InputError, match=r"static trial .*L\.Knee/R\.Knee -36 cm.*swapped"):
        compute_kinematics(rajagopal_trial(), static=dataclasses.replace(st, marker_names=names))


def _restyled(label: str, side_of=None) -> str:
    """A Rajagopal static label (``L.Heel``) as another lab's export spells it: a subject
    prefix, a landmark's side as a suffix (``Subject:Heel_L``), other labels in lower case with
    underscores (``Subject:l_th1``, ``Subject:s2``); ``side_of`` changes the side written."""
    from gc_ocp.model.landmarks import classify

    if label[:2] in ("L.", "R."):
        side = (side_of or {}).get(label[0], label[0])
        if classify(label)[0] == "landmark":
            return f"Subject:{label[2:]}_{side}"
        return f"Subject:{side.lower()}_{label[2:].lower()}"
    return f"Subject:{label.lower()}"


def test_a_static_trial_labelled_in_another_style_is_matched_to_the_walking_markers():
    # A static exported with other label spellings than the walking trial (a subject prefix,
    # side suffixes, lower case) was refused ("lacks foot markers"); its labels are now matched
    # by spelling up to case and separators, or by landmark and side, and renamed, so the
    # kinematics are those of the static as labelled like the walking trial.
    import dataclasses

    st = rajagopal_static()
    restyled = dataclasses.replace(st, marker_names=tuple(_restyled(n) for n in st.marker_names))
    said = []
    kin = compute_kinematics(rajagopal_trial(), static=restyled, progress=said.append)
    ref = _kin("rajagopal+static")[1]
    # The same columns reach the registration and IK in the same order: the same numbers
    # through the same operations, equal up to the last bits (1e-12 m is 1e-8 of the 0.1 mm a
    # camera resolves).
    for n, p in ref.info["marker_local"].items():
        np.testing.assert_allclose(kin.info["marker_local"][n], p, atol=1e-12, err_msg=n)
    np.testing.assert_allclose(kin.q, ref.q, atol=1e-12)
    note = next(m for m in said if m.startswith("static trial: labels matched"))
    assert "Subject:Heel_L -> L.Heel (heel, left)" in note
    assert "Subject:r_th1 -> R.TH1 (spelling)" in note
    assert kin.info["static_labels"]["Subject:Toe_R"] == "R.Toe"
    assert ref.info["static_labels"] == {}  # labels alike: nothing renamed


def test_two_static_labels_for_one_walking_marker_are_refused_by_name():
    # L.Heel spelt Heel_L and, on a second column, LHEEL: either could be the walking trial's
    # L.Heel; a guess registers the heel where another point sits, so it is refused, both named
    import dataclasses

    from gc_ocp.errors import InputError

    st = rajagopal_static()
    j = st.marker_names.index("L.Heel")
    names = tuple("Heel_L" if n == "L.Heel" else n for n in st.marker_names) + ("LHEEL",)
    m = np.concatenate([st.markers, st.markers[:, j : j + 1]], axis=1)
    two = dataclasses.replace(st, marker_names=names, markers=m)
    with pytest.raises(
        InputError, match=r"lacks foot markers \['L\.Heel'\].*L\.Heel: Heel_L or LHEEL"
    ):
        compute_kinematics(rajagopal_trial(), static=two)


def test_a_static_label_of_the_other_side_is_never_matched():
    # the left foot's labels spelt with a right side (Heel_R for L.Heel): the same landmark,
    # the other foot; never the walking trial's left marker, whatever else is missing
    import dataclasses

    from gc_ocp.errors import InputError

    st = rajagopal_static()
    foot = ("L.Heel", "L.Toe", "L.MT5", "L.Ankle")
    names = tuple(
        _restyled(n, {"L": "R"})[len("Subject:") :] if n in foot else n for n in st.marker_names
    )
    with pytest.raises(
        InputError, match=r"lacks foot markers .*L\.Heel.*matched to none: .*Heel_R"
    ):
        compute_kinematics(rajagopal_trial(), static=dataclasses.replace(st, marker_names=names))
    from gc_ocp.io._common import match_labels

    got = match_labels(["LHEE", "RTOE", "LKNE"], ["Heel_R", "l_toe", "L_KNE"], st.source)
    assert got.renamed == {"L_KNE": "LKNE"}  # the spelling, on the same side
    assert got.unmatched == ("LHEE", "RTOE") and got.spare == ("Heel_R", "l_toe")
