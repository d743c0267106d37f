"""The toe_joint effect: toes hinged at the MTP line, the toe angle driven by the hindfoot's
pitch (``drive="pitch"``, the default) or a smooth per-stance spline (``drive="spline"``).

Exactness: phi = 0 is the welded model bit for bit; the hinge geometry (sign, axis, lever) and its
velocity (the angular velocity the hinge adds) against finite differences of the positions.

Recovery on real motion: the truth is the base model fitted to the bundled trial (sole at its
nominal points, see ``_base_truth``) with the toes dorsiflexing to +15 deg over the second half of
each stance. What the plate determines is the toe
unit's load during push-off, not the angle itself: a toe angle that is constant while the toe
unit is loaded is exactly a move of that unit's point (its sole offset), so the split between the
two is the priors' (the MAP angle is biased towards 0 by several of its SEs, printed). The test
asserts the determined part: the fit with the hinge explains the data to the noise, the base alone
does not, and the toe unit's vertical force is recovered.
"""

from __future__ import annotations

import dataclasses
import functools
import time

import casadi as ca
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gc_ocp.bench import recovery
from gc_ocp.estimation import Weights, build_estimation, frozen_model, result_at
from gc_ocp.estimation.components import (
    ContactLaw,
    Param,
    base_model,
)
from gc_ocp.estimation.components.toe_joint import ToeJoint, _flat_pitch
from gc_ocp.estimation.frame import BASE_DATA, Frame, Layout
from gc_ocp.estimation.variables import spec_index
from gc_ocp.foot import SEED_LAYOUT

PEAK_DEG = 15.0
WEIGHTS = Weights(force_sigma=0.005, torque_length=recovery.TORQUE_NOISE_LENGTH)
"""Residual weights equal to the simulated plate noise (0.5 % BW, x 20 mm on the moments): the
fit is then the maximum-likelihood one and its standard errors are meaningful. The default weights
(2 % BW, x 0.25 m) down-weight the very precise moments 12-fold against the priors."""


def _stances():
    return recovery.bundled_base_truth()[0]


@functools.cache
def _base_truth():
    """The base model fitted to the real stances, with the sole at its nominal points. The fit
    moves TT 20-25 mm back (to the 25 mm bound), nearly under the MTP axis: there a 15 deg hinge
    barely changes TT's depth and the base absorbs it (base-only RMS at the noise). The nominal TT,
    73 mm from the axis, is the case where the hinge matters and can be tested."""
    law, sole, *rest = recovery.bundled_base_truth()[1]
    return (law, dataclasses.replace(sole, fixed={s: 0 * v for s, v in sole.fixed.items()}), *rest)


def _true_toes(stances) -> dict:
    """Spline coefficients [rad] of phi(t): 0 until 55 % of the stance, then a smooth step to
    +15 deg at toe-off (the benchmark's definition, ``toe_joint.smooth_step_angles``)."""
    from gc_ocp.estimation.components.toe_joint import smooth_step_angles

    return smooth_step_angles(stances, PEAK_DEG)


# --- exactness ------------------------------------------------------------------------------


def _frame_points(toes_R, toes_o, hind_R, hind_o, hind_w, toes_w, toes_v, hind_v, phi, phidot):
    """Unit positions and velocities (3 x 5) of the seed layout after the hinge, numerically."""
    data = Layout(list(BASE_DATA))
    slots = Layout([("points_local", 15), ("toe_phi", 1), ("toe_phidot", 1)])
    D = ca.SX.sym("D", data.size)
    y = ca.SX.sym("y", slots.size)
    f = Frame(SEED_LAYOUT, D, y, data, slots)
    ToeJoint(drive="spline").edit_segments(f)
    f.place_units()
    fn = ca.Function("p", [D, y], [ca.horzcat(*f.points), ca.horzcat(*f.velocities)])
    d = np.zeros(data.size)
    for name, v in (
        ("hindfoot_R", hind_R.T.ravel()),
        ("hindfoot_o", hind_o),
        ("hindfoot_v", hind_v),
        ("hindfoot_w", hind_w),
        ("toes_R", toes_R.T.ravel()),
        ("toes_o", toes_o),
        ("toes_v", toes_v),
        ("toes_w", toes_w),
    ):
        s, n = data.index[name]
        d[s : s + n] = v
    local = np.array(
        [[-0.04, -0.02, -0.07], [-0.04, 0.03, -0.09], [0.11, -0.045, -0.06], [0.11, 0.04, -0.1]]
        + [[0.065, 0.0, -0.034]]
    )
    yv = np.concatenate([local.ravel(), [phi, phidot]])
    p, v = fn(d, yv)
    return np.asarray(p), np.asarray(v)


def test_sign_and_geometry_on_a_flat_foot():
    """Foot flat (frames = lab, x forward, y left, z up): +10 deg lifts the toe tip, leaves the
    hindfoot units and the toe tip's distance to the MTP axis alone, and is a rotation about -y.
    Round-off only: 1e-15 m."""
    eye, z3 = np.eye(3), np.zeros(3)
    o_h, o_t = np.array([0.0, 0.0, 0.08]), np.array([0.12, 0.0, 0.035])
    p0, _ = _frame_points(eye, o_t, eye, o_h, z3, z3, z3, z3, 0.0, 0.0)
    p1, _ = _frame_points(eye, o_t, eye, o_h, z3, z3, z3, z3, np.deg2rad(10), 0.0)
    assert p1[2, 4] > p0[2, 4] + 0.01  # toe tip up by > 10 mm (lever 73 mm, pointing forward-down)
    np.testing.assert_allclose(p1[:, :4], p0[:, :4], atol=1e-15)
    r0, r1 = p0[:, 4] - o_t, p1[:, 4] - o_t
    np.testing.assert_allclose(np.linalg.norm(r1), np.linalg.norm(r0), atol=1e-15)
    expect = Rotation.from_rotvec(np.deg2rad(10) * np.array([0, -1.0, 0])).apply(r0)
    np.testing.assert_allclose(r1, expect, atol=1e-15)


def test_velocity_is_the_time_derivative_of_the_position():
    """A tumbling hindfoot with welded toes (the recorded kinematics) and phi(t) = 0.2 + 0.7 t:
    the model's toe-tip velocity equals the central difference of its position (h = 1e-5 s, error
    ~h^2 |p'''| ~ 1e-10 m/s; 1e-8 leaves room)."""
    w = np.array([0.4, -1.1, 0.3])
    v_h = np.array([0.5, 0.1, -0.2])
    c = np.array([0.12, 0.0, -0.045])  # toes origin in the hindfoot frame

    def state(t):
        R = Rotation.from_rotvec(w * t).as_matrix() @ Rotation.from_euler("x", 0.4).as_matrix()
        o_h = np.array([0.1, 0.2, 0.07]) + v_h * t
        o_t = o_h + R @ c
        v_t = v_h + np.cross(w, R @ c)
        return _frame_points(R, o_t, R, o_h, w, w, v_t, v_h, 0.2 + 0.7 * t, 0.7)

    t, h = 0.3, 1e-5
    _, v = state(t)
    fd = (state(t + h)[0] - state(t - h)[0]) / (2 * h)
    np.testing.assert_allclose(v, fd, atol=1e-8)


@pytest.mark.parametrize("drive", ["spline", "pitch"])
def test_zero_angle_is_the_welded_model_on_real_motion(drive):
    """phi = 0 reproduces the base model's wrench on the real stances. Written as R + (Rot - I) R
    with Rot - I = sin(0) K + (1 - cos(0)) K^2 = 0 exactly, the graph evaluates to the same
    floating-point numbers: equality, not a tolerance. Spline: coefficients 0; pitch: gain 0
    (phi = 0 * s * softplus(.) = 0 and phi_dot = 0 * sigmoid(.) * pitch_dot = 0 exactly, whatever
    the onset: here the onsets at 0 too, the decision vector's zero)."""
    st = _stances()
    base = build_estimation(st, base_model())
    pb = build_estimation(st, (*base_model(), ToeJoint(drive=drive)))
    x = np.zeros(pb.x0.size)
    for s in pb.variables.specs:
        if s.key[0] != "toe_joint":
            x[s.slice] = base.x0[base.variables.spec(s.key).slice]
    for a, b in zip(pb.stance_wrenches(x), base.stance_wrenches(base.x0), strict=True):
        np.testing.assert_array_equal(a, b)


# --- recovery -------------------------------------------------------------------------------


def _toe_only(model):
    """The model with every unit but TT switched off (k = 1e-9): its wrench is TT's force."""
    out = []
    for c in model:
        if isinstance(c, ContactLaw):
            k = {
                s: {u: (v if u == "TT" else 1e-9) for u, v in ks.items()}
                for s, ks in c.k.value.items()
            }
            c = dataclasses.replace(c, k=Param("fixed", k))
        out.append(c)
    return tuple(out)


def _toe_fz(model, stances, res=None) -> list[np.ndarray]:
    """TT's vertical force [% BW] per stance: of the truth (res None) or of a fit (its stance
    variables carried over by key)."""
    pb = build_estimation(stances, _toe_only(model if res is None else frozen_model(model, res)))
    x = pb.x0.copy()
    if res is not None:
        idx = spec_index(res.variables)
        for s in pb.variables.specs:
            x[s.slice] = res.x[idx[s.key].slice]
    return [
        w[:, 2] / st.body_weight * 100 for w, st in zip(pb.stance_wrenches(x), stances, strict=True)
    ]


def test_toe_load_is_recovered_on_real_motion():
    t0 = time.perf_counter()
    stances = _stances()
    fixed = _true_toes(stances)
    truth = (*_base_truth(), ToeJoint(drive="spline", fixed=fixed))
    data = recovery.simulate(stances, truth, np.random.default_rng(7))
    m1 = (*base_model(), ToeJoint(drive="spline"))
    m0 = base_model()
    r1 = recovery.fit_model(data, m1, WEIGHTS)
    r0 = recovery.fit_model(data, m0, WEIGHTS)
    assert r1.success and r0.success, (r1.status, r0.status)

    # the angle: printed, not asserted (see the module docstring)
    tj = ToeJoint(drive="spline")
    for st in data:
        b = r1.blocks["toe_joint"]["stances"][st.label]
        true = np.rad2deg(tj.basis(st.time)[0] @ fixed[st.label])
        est, se = np.array(b["phi_deg"]), np.array(b["phi_se_deg"])
        k = st.n - 5
        print(
            f"{st.label}: phi near toe-off true {true[k]:.1f} est {est[k]:.1f} +- {se[k]:.1f} deg "
            f"(z {(est[k] - true[k]) / se[k]:+.1f}); max |z| over the stance "
            f"{np.max(np.abs((est - true) / se)):.1f}"
        )

    # RMS per channel: the hinge explains the data to the noise, the welded base does not
    noise = recovery.PLATE_NOISE_PCT_BW
    for side in r1.rms:
        print(side, "effect", {c: round(v, 4) for c, v in r1.rms[side].items()})
        print(side, "base  ", {c: round(v, 4) for c, v in r0.rms[side].items()})
    for side in r1.rms:  # with the effect: at the noise (0.5 % BW) on every force channel
        for ch in ("anterior_force_pct_bw", "superior_force_pct_bw", "lateral_force_pct_bw"):
            assert r1.rms[side][ch] < 1.15 * noise, (side, ch, r1.rms[side][ch])
    # the right foot's second stance has its toes loaded from mid-stance: the welded base cannot
    # follow them there (the left foot's single stance is absorbed by its own TT offset)
    assert r0.rms["right"]["superior_force_pct_bw"] > 1.5 * noise, r0.rms["right"]

    # what the plate determines: the toe unit's load
    ft, f1, f0 = _toe_fz(truth, data), _toe_fz(m1, data, r1), _toe_fz(m0, data, r0)
    err1, err0 = [], []
    for st, a, b, c in zip(data, ft, f1, f0, strict=True):
        loaded = a > 2.0  # frames where TT carries > 2 % BW in the truth
        err1.append(np.sqrt(np.mean((b - a)[loaded] ** 2)))
        err0.append(np.sqrt(np.mean((c - a)[loaded] ** 2)))
        print(
            f"{st.label}: TT Fz peak {a.max():.1f} % BW; RMS error effect {err1[-1]:.2f}, "
            f"base {err0[-1]:.2f} % BW"
        )
    assert max(err1) < 3.0, err1  # a few % of TT's 50-110 % BW peak
    assert max(err0) > 2 * max(err1), (err0, err1)
    print(f"toe_joint recovery: {time.perf_counter() - t0:.1f} s")


# --- the pitch drive ------------------------------------------------------------------------


def _pitch_frame_fn(gain: float, onset: float):
    """``D -> (phi, phi_dot, toe-tip position, toe-tip velocity)`` of the pitch drive through the
    component's own edit_segments, the angle and its rate read back from the hinged toes frame
    (recorded toes welded to the hindfoot)."""
    data = Layout(list(BASE_DATA))
    slots = Layout([("points_local", 15), ("toe_onset", 1), ("toe_gain", 1)])
    D = ca.SX.sym("D", data.size)
    y = ca.SX.sym("y", slots.size)
    f = Frame(SEED_LAYOUT, D, y, data, slots)
    toes0 = f.segments["toes"]
    ToeJoint().edit_segments(f)
    f.place_units()
    rel = f.segments["toes"].R @ toes0.R.T  # Rot(a, phi)
    a = -ca.reshape(f.data("hindfoot_R"), 3, 3)[:, 1]
    K = ca.vertcat(
        ca.horzcat(0, -a[2], a[1]), ca.horzcat(a[2], 0, -a[0]), ca.horzcat(-a[1], a[0], 0)
    )
    sin_phi = -0.5 * ca.trace(K @ rel)  # trace(K Rot(a, phi)) = -2 sin(phi) for a unit axis
    phidot = ca.dot(f.segments["toes"].w - toes0.w, a)  # w' - w = phi_dot a (welded toes)
    local = np.zeros((3, 5))
    local[:, 4] = [0.065, 0.0, -0.034]
    fn = ca.Function("pitch", [D, y], [ca.asin(sin_phi), phidot, f.points[4], f.velocities[4]])
    yv = np.concatenate([local.T.ravel(), [onset, gain]])
    return lambda d: [np.asarray(o, float).ravel() for o in fn(d, yv)]


def test_pitch_drive_rate_is_the_derivative_along_the_recorded_motion():
    """On every other frame of a real stance, the motion continued for +-h with the recorded
    hindfoot twist (toes welded, as recorded): the hinge's phi_dot equals the central difference
    of its phi, and the toe tip's velocity that of its position. Tolerance: h = 1e-6 s; the
    truncation error ~h^2 |d3 phi / dt3| with |d3 phi / dt3| ~ gain |pitch_dot|^3 / s^2 < 1e5
    rad/s^3 (s = 2 deg) is < 1e-7, round-off eps / h ~ 1e-10: 1e-6 (rad/s, m/s) leaves room. The
    gain 0.8 and an onset 1 deg below foot flat put the softplus knee inside the stance."""
    st = _stances()[2]
    onset = _flat_pitch([st], st.side) - np.deg2rad(1.0)
    fn = _pitch_frame_fn(0.8, onset)
    data = Layout(list(BASE_DATA))
    h = 1e-6
    foot = st.foot
    bent = 0
    for k in range(0, st.n, 2):
        Rh, oh = foot.hindfoot_pose[k, :3, :3], foot.hindfoot_pose[k, :3, 3]
        Rt, ot = foot.toes_pose[k, :3, :3], foot.toes_pose[k, :3, 3]
        vh, w = foot.hindfoot_twist[k, :3], foot.hindfoot_twist[k, 3:]

        def at(t, Rh=Rh, oh=oh, Rt=Rt, ot=ot, vh=vh, w=w):
            Q = Rotation.from_rotvec(w * t).as_matrix()  # constant angular velocity in lab
            r = Q @ (ot - oh)
            d = np.zeros(data.size)
            for name, v in (
                ("hindfoot_R", (Q @ Rh).T.ravel()),
                ("hindfoot_o", oh + vh * t),
                ("hindfoot_v", vh),
                ("hindfoot_w", w),
                ("toes_R", (Q @ Rt).T.ravel()),
                ("toes_o", oh + vh * t + r),
                ("toes_v", vh + np.cross(w, r)),
                ("toes_w", w),
            ):
                s, n = data.index[name]
                d[s : s + n] = v
            return fn(d)

        phi, phidot, _, v = at(0.0)
        fd = [(a - b) / (2 * h) for a, b in zip(at(h), at(-h), strict=True)]
        np.testing.assert_allclose(phidot, fd[0], atol=1e-6)
        np.testing.assert_allclose(v, fd[2], atol=1e-6)
        bent += phi[0] > np.deg2rad(1.0)
    assert bent >= 5  # the toes do bend on part of the stance


def test_pitch_drive_decode_matches_the_model():
    """The decoded per-stance angle (NumPy) is the model's (SX, read back from the hinged toes)
    on the recorded frames: 1e-9 deg (asin of a sine read back: round-off); fixed values: SE 0."""
    st = _stances()
    onset = {"left": 0.0, "right": np.deg2rad(1.0)}  # above each stance's foot flat
    tj = ToeJoint(pitch_fixed={"gain": 0.7, "onset": onset})
    pb = build_estimation(st, (*base_model(), tj))
    blk = result_at(pb, pb.x0).blocks["toe_joint"]
    data = Layout(list(BASE_DATA))
    for s in st:
        fn = _pitch_frame_fn(0.7, _flat_pitch([s], s.side) + onset[s.side])
        got = []
        for k in range(s.n):
            d = np.zeros(data.size)
            for name, v in (
                ("hindfoot_R", s.foot.hindfoot_pose[k, :3, :3].T.ravel()),
                ("hindfoot_w", s.foot.hindfoot_twist[k, 3:]),
                ("toes_R", s.foot.toes_pose[k, :3, :3].T.ravel()),
            ):
                i, n = data.index[name]
                d[i : i + n] = v
            got.append(np.rad2deg(fn(d)[0][0]))
        np.testing.assert_allclose(blk["stances"][s.label]["phi_deg"], got, atol=1e-9)
        assert np.max(np.abs(blk["stances"][s.label]["phi_se_deg"])) == 0.0
        assert max(got) > 10.0  # the toes bend by toe-off


PITCH_GAIN = 0.6
PITCH_ONSET_DEG = 3.0
"""The pitch truth: the toes follow 0.6 of the hindfoot's pitch beyond 3 deg past each side's
foot-flat pitch (32-39 deg at toe-off on this trial: the MTP joint's 30-50 deg in gait). At gain
0.3 (16-20 deg) the welded base with its per-stance pose correction absorbs nearly all of it
(superior RMS 0.56 vs 0.46-0.51 % BW with the hinge): recovered just as well, but not a test of
the base's misfit."""


def test_pitch_drive_is_recovered_on_real_motion():
    """Truth: the base (sole at its nominal points, ``_base_truth``) with the pitch-driven toes;
    plate noise as in the spline test. base + toe_joint (pitch) recovers the gain and both
    onsets and fits to the noise; the welded base does not."""
    t0 = time.perf_counter()
    stances = _stances()
    onset = {s: np.deg2rad(PITCH_ONSET_DEG) for s in ("left", "right")}  # above foot flat
    truth = (*_base_truth(), ToeJoint(pitch_fixed={"gain": PITCH_GAIN, "onset": onset}))
    data = recovery.simulate(stances, truth, np.random.default_rng(7))
    m1, m0 = (*base_model(), ToeJoint()), base_model()
    r1 = recovery.fit_model(data, m1, WEIGHTS)
    r0 = recovery.fit_model(data, m0, WEIGHTS)
    assert r1.success and r0.success, (r1.status, r0.status)
    b = r1.blocks["toe_joint"]
    zs = {"gain": (b["gain"] - PITCH_GAIN) / b["gain_se"]}
    print(f"gain true {PITCH_GAIN} est {b['gain']:.3f} +- {b['gain_se']:.3f} (z {zs['gain']:+.1f})")
    for side in ("left", "right"):
        true = np.rad2deg(onset[side])
        est, se = b["onset_deg"][side], b["onset_se_deg"][side]
        zs[side] = (est - true) / se
        print(
            f"{side} onset true {true:.2f} est {est:.2f} +- {se:.2f} deg (z {zs[side]:+.1f}), "
            f"corr with gain {b['gain_onset_corr'].get(side, float('nan')):+.2f}"
        )
    for st in data:
        print(st.label, "max phi", round(b["max_deg"][st.label], 1), "deg")
    # |z| < 3 for each: the estimates are MAP under weak priors (gain sigma 0.5, onset sigma
    # 10 deg, many SEs wide), so their prior bias is a small fraction of an SE and the error is
    # ~Gaussian with the printed SE; 3 SE is a 99.7 % band per parameter
    assert max(abs(z) for z in zs.values()) < 3.0, zs
    noise = recovery.PLATE_NOISE_PCT_BW
    for side in r1.rms:
        print(side, "effect", {c: round(v, 4) for c, v in r1.rms[side].items()})
        print(side, "base  ", {c: round(v, 4) for c, v in r0.rms[side].items()})
        for ch in ("anterior_force_pct_bw", "superior_force_pct_bw", "lateral_force_pct_bw"):
            assert r1.rms[side][ch] < 1.15 * noise, (side, ch, r1.rms[side][ch])
    # the welded base misfits on both feet: 1.25 x noise is > 5 SEs of an RMS of ~200 noisy
    # frames per foot (relative SE 1 / sqrt(2 n) ~ 5 %) above the noise the hinge fits to
    for side in r0.rms:
        assert r0.rms[side]["superior_force_pct_bw"] > 1.25 * noise, (side, r0.rms[side])
    print(f"toe_joint pitch recovery: {time.perf_counter() - t0:.1f} s")


def test_the_drive_follows_the_model_it_joins():
    """``model_from_names`` adds the predictive pitch drive to a model with a per-stance nuisance
    (the pose correction of the registered base) and the per-stance spline to a bare one (the
    seed base), where the held-out stance has no other per-stance unknown."""
    from gc_ocp.estimation.components import bare_seed_model, model_from_names

    def drive(model):
        return next(c for c in model if c.name == "toe_joint").drive

    assert drive(model_from_names(["toe_joint"], base=base_model())) == "pitch"
    assert drive(model_from_names(["toe_joint"], base=bare_seed_model())) == "spline"
    both = model_from_names(["kinematic_correction", "toe_joint"], base=bare_seed_model())
    assert drive(both) == "pitch"
