"""Body model: URDF structure, Pinocchio placements against a hand-built NumPy chain, marker sets."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest

from gc_ocp.errors import MarkerError
from gc_ocp.foot import UNITS
from gc_ocp.model import BodyModel, generate_urdf
from gc_ocp.model.markerset import available_markersets, detect_markerset, load_markerset
from gc_ocp.model.urdf import SEED_SUBJECT, SEED_URDF

H, M = 1.70, 689.0 / 9.81
SEGMENTS = ["pelvis", "torso"] + [
    f"{s}_{x}" for x in "lr" for s in ("thigh", "shank", "hindfoot", "toes", "upper_arm", "forearm")
]


@pytest.fixture(scope="module")
def body():
    return BodyModel.from_subject(H, M)


def test_urdf_structure(body):
    m = body.model
    assert m.nq == m.nv == 27
    massive = [m.names[i] for i in range(1, m.njoints) if m.inertias[i].mass > 0]
    # 14 segments with mass: 12 on moving joints, the toes carried by the hindfoot joints
    # (Pinocchio merges a fixed-joint child's inertia into its parent joint).
    root = ET.fromstring(generate_urdf(H, M))
    masses = {
        ln.get("name"): float(ln.find("inertial/mass").get("value"))
        for ln in root.findall("link")
        if ln.find("inertial") is not None
    }
    assert sorted(masses) == sorted(SEGMENTS)
    assert all(v > 0 for v in masses.values())
    assert len(massive) == 12
    # total mass equals the input (Pinocchio sums the URDF's 12-significant-digit masses)
    assert body.mass == pytest.approx(M, rel=1e-10)
    joints = {j.get("name"): j.get("type") for j in root.findall("joint")}
    assert joints["mtp_l"] == joints["mtp_r"] == "fixed"
    assert sum(t in ("revolute", "prismatic") for t in joints.values()) == 27
    for side in ("left", "right"):
        assert set(body.unit_frames(side)) == set(UNITS)
        assert set(body.foot_frames(side)) == {"hindfoot", "toes"}
    assert np.all(body.lower_limits < 0) and np.all(body.upper_limits > 0)


def test_seed_urdf_is_generated():
    assert SEED_URDF.read_text() == generate_urdf(
        SEED_SUBJECT["height"], SEED_SUBJECT["mass"], name="gc_ocp_seed_subject"
    )


def _rodrigues(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _numpy_placement(root, link, qd):
    """Link-to-world 4x4 transform by walking the URDF joints up to the root (independent of Pinocchio)."""
    by_child = {j.find("child").get("link"): j for j in root.findall("joint")}
    T = np.eye(4)
    while link in by_child:
        j = by_child[link]
        o = np.array(j.find("origin").get("xyz").split(), float)
        A = np.eye(4)
        A[:3, 3] = o
        B = np.eye(4)
        if j.get("type") == "revolute":
            B[:3, :3] = _rodrigues(
                np.array(j.find("axis").get("xyz").split(), float), qd[j.get("name")]
            )
        elif j.get("type") == "prismatic":
            B[:3, 3] = np.array(j.find("axis").get("xyz").split(), float) * qd[j.get("name")]
        T = A @ B @ T
        link = j.find("parent").get("link")
    return T


def test_foot_placements_match_numpy_chain(body):
    root = ET.fromstring(body.urdf)
    rng = np.random.default_rng(0)
    data = body.create_data()
    frames = [f"{n}_{s}" for s in "lr" for n in ("hindfoot", "toes", *UNITS)] + [
        "torso",
        "forearm_l",
    ]
    for _ in range(5):
        q = rng.uniform(np.maximum(body.lower_limits, -1.0), np.minimum(body.upper_limits, 1.0))
        qd = {n: q[body.q_index(n)] for n in body.joint_names}
        pin.framesForwardKinematics(body.model, data, q)
        for f in frames:
            T = _numpy_placement(root, f, qd)
            # round-off only: ~10 products of O(1) matrices and metre-sized offsets
            np.testing.assert_allclose(data.oMf[body.frame_id(f)].homogeneous, T, atol=1e-12)


def test_neutral_pose_geometry(body):
    """q = 0 is standing: sole points on z = -(hip height) relative to the pelvis origin, left foot lateral +Y."""
    data = body.create_data()
    pin.framesForwardKinematics(body.model, data, body.neutral())
    from gc_ocp.kinematics.scaling import hip_height_ratio

    for u in ("PL", "PM", "AL", "AM"):
        assert data.oMf[body.frame_id(f"{u}_l")].translation[2] == pytest.approx(
            -hip_height_ratio() * H
        )
    assert (
        data.oMf[body.frame_id("AL_l")].translation[1]
        > data.oMf[body.frame_id("AM_l")].translation[1]
    )
    assert (
        data.oMf[body.frame_id("AL_r")].translation[1]
        < data.oMf[body.frame_id("AM_r")].translation[1]
    )
    assert (
        data.oMf[body.frame_id("TT_l")].translation[0]
        > data.oMf[body.frame_id("AL_l")].translation[0]
    )


@pytest.mark.parametrize("sex", ["male", "female"])
def test_segment_inertias_follow_the_shape_of_the_body(sex):
    """de Leva's (1996) sagittal radius of gyration is about the antero-posterior axis and the
    transverse one about the medio-lateral axis: his upper trunk's 71.6 % and 45.4 % of 170.7 mm
    are those of a box 0.4 m wide (shoulders) and 0.2 m deep (12.5 and 7.6 cm). So a trunk,
    wider than deep, turns harder about X (forward) than about Y (left), and a foot, wider than
    tall, harder about Z (up) than about Y. Read from the Pinocchio model (q = 0: every segment's
    axes are lab's), so the URDF carries it too. The differences are 16-25 % of the smaller
    inertia for the trunk segments (hence the 5 % margin) and 6-10 % for the foot; the swapped
    axes reversed every one of them."""
    body = BodyModel.from_subject(H, M, sex=sex)
    inertia = {
        body.model.names[j]: body.model.inertias[j].inertia for j in range(1, body.model.njoints)
    }
    for joint in ("lumbar_rotation", "pelvis_ry"):  # torso (with the head), pelvis
        ixx, iyy = inertia[joint][0, 0], inertia[joint][1, 1]
        assert ixx > 1.05 * iyy, (joint, ixx, iyy)
    for s in "lr":
        foot = inertia[f"subtalar_{s}"]  # hindfoot with the welded toes merged in
        assert foot[2, 2] > foot[1, 1] > foot[0, 0], foot


@pytest.mark.parametrize("name", ["plugingait", "rajagopal", "gait2392"])
def test_markersets_load(name, body):
    ms = load_markerset(name)
    assert ms.name == name
    for m in ms.markers.values():
        body.frame_id(m.segment)  # every segment exists in the model
    for side in ("left", "right"):
        assert ms.by_role(side, "heel") is not None
        assert len([m for m in ms.foot_markers(side) if m.segment.startswith("hindfoot")]) >= 3


def test_markerset_unknown_name_lists_choices():
    with pytest.raises(MarkerError) as e:
        load_markerset("nosuchset")
    for n in available_markersets():
        assert n in str(e.value)


@pytest.mark.parametrize(
    "change, words",
    [
        (
            lambda t: t.replace("reference_height = 1.70", "reference_height = 170"),
            ["170", "metres"],
        ),
        (
            lambda t: t.replace("[markers]", '[markers]\nXTRA = "hindfoot_l"'),
            ["XTRA", "not a table"],
        ),
        (lambda t: t.replace("weight = 2.0", 'weight = "x"', 1), ["weight must be a number"]),
        (lambda t: "# caf\u00e9\n" + t, ["not UTF-8"]),
        (lambda t: t.replace('"hindfoot_l"', '"heel_l"', 1), ["heel_l", "not a segment"]),
        (lambda t: t.replace('"thigh_l"', '"knee_l"', 1), ["knee_l", "not a segment"]),
        (  # one marker's position in mm: the IK pulled the foot 70 m off, silently
            lambda t: t.replace(
                "position = [-0.070, 0.000, -0.035]", "position = [-70, 0, -35]", 1
            ),
            ["LHEE", "metres"],
        ),
        (  # a negative weight made the IK's sqrt(weight) NaN: no frame moved, silently
            lambda t: t.replace("weight = 5.0", "weight = -5.0", 1),
            ["weight", "-5", ">= 0"],
        ),
    ],
)
def test_a_marker_set_file_with_a_wrong_value_names_it(tmp_path, change, words):
    """A reference height in cm (it scaled every marker 100 times, fitted at exit 0), a marker
    given as a string, a weight that is not a number, a file not in UTF-8: each a MarkerError
    naming the file and what to fix (they were status 3 or silent)."""
    from gc_ocp.errors import InputError

    src = load_markerset("plugingait").source
    text = change(src.read_text())
    f = tmp_path / "ms.toml"
    f.write_bytes(text.encode("latin-1" if "not UTF-8" in words else "utf-8"))
    with pytest.raises(InputError) as e:
        load_markerset(f)
    assert str(f) in str(e.value)
    for w in words:
        assert w in str(e.value)


def test_a_marker_set_file_with_an_upper_case_suffix_loads(tmp_path):
    src = load_markerset("plugingait").source
    f = tmp_path / "ms.TOML"
    f.write_text(src.read_text())
    assert load_markerset(f).markers.keys() == load_markerset("plugingait").markers.keys()


def test_missing_foot_marker_is_named():
    ms = load_markerset("plugingait")
    names = [n for n in ms.markers if n != "LHEE"]
    with pytest.raises(MarkerError, match="LHEE"):
        ms.select(names, "trial.c3d")
    # a missing non-foot marker is ignored, extra trial markers too
    names = [n for n in ms.markers if n != "LFIN"] + ["CentreOfMass"]
    assert "LFIN" not in ms.select(names) and "CentreOfMass" not in ms.select(names)


def test_detect_markerset():
    for name in ("plugingait", "rajagopal", "gait2392"):
        assert detect_markerset(list(load_markerset(name).markers)).name == name
