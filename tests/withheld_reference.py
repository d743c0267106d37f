"""The withheld-effect benchmark's truths as they were built before the effects said how they
are injected (``gc_ocp/bench/withheld.py`` at commit b9e69bc: its ``VALUES`` table, the
``truth_model`` if-chain, ``motion``'s toe-joint case and ``run_case``'s kinematic error),
kept verbatim as the reference the registry-driven benchmark must reproduce exactly
(``tests/test_benchmark_diagnosis.py``); and its data generator before the mismatch family
(:func:`generate`, ``tests/test_mismatch.py``). Not used by the package."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from gc_ocp.bench.truth import DEFAULT_REALISM, Realism, _source
from gc_ocp.errors import InputError
from gc_ocp.estimation.problem import build_estimation
from gc_ocp.estimation.synthetic import noisy_pose, plate_signal, with_pose_error
from gc_ocp.stance import StanceData

EFFECTS = (
    "damping",
    "stiffness_exponent",
    "sole_geometry",
    "kinematic_correction",
    "contact_density",
    "toe_joint",
    "ground_offset",
    "time_offset",
    "friction",
)
NONE = "none"

VALUES: dict[str, dict[str, object]] = {
    "damping": {"moderate": 0.5, "strong": 1.0},  # c [s/m]
    "stiffness_exponent": {"moderate": 1.25, "strong": 1.5},  # n [-]
    "sole_geometry": {"moderate": 2e-3, "strong": 4e-3},  # half-range of U per axis [m]
    "kinematic_correction": {  # marker noise [m], drift [m], drift [deg]
        "moderate": (0.5e-3, 2e-3, 0.5),
        "strong": (1.0e-3, 4e-3, 1.0),
    },
    "contact_density": {"moderate": 2.0, "strong": 3.0},  # heel/toe stiffness ratio
    "toe_joint": {"moderate": 10.0, "strong": 15.0},  # toe dorsiflexion at toe-off [deg]
    "ground_offset": {"moderate": (2e-3, 0.5), "strong": (4e-3, 1.0)},  # [m], [deg]
    "time_offset": {"moderate": 0.010, "strong": 0.020},  # plate late [s]
    "friction": {"moderate": (0.15, 0.4), "strong": (0.3, 0.75)},  # mu_s - mu_d, b [s/m]
}


def motion(base: str, effect: str = NONE, files: tuple[str, ...] | None = None) -> list[StanceData]:
    """The true motion of the cases: the stances of the motion source (``files``; None: the
    bundled trial). For the ``seed`` base the sole
    points are the registered fit's (nominal + fitted offsets; TT at its nominal point for
    ``toe_joint``, see :func:`truth_model`): a bare law on the nominal points of real kinematics
    leaves heel units of a stance that never touch the ground, so a truth fitted that way has
    per-unit stiffnesses no other stance can predict, and every held-out score is dominated by
    that, not by the effect."""
    stances = list(_source(files)[0])
    if base != "seed":
        return stances
    sole = next(c for c in _source(files)[1] if c.name == "sole")
    out = []
    for st in stances:
        off = np.array(sole.fixed[st.side], float)
        if effect == "toe_joint":
            off[list(st.layout.units).index("TT")] = 0.0
        out.append(st.with_foot(st.foot.with_points(st.foot.points_local + off)))
    return out


def _law(truth: tuple):
    return next(c for c in truth if c.name == "contact")


def _replace_law(truth: tuple, law) -> tuple:
    return tuple(law if c.name == "contact" else c for c in truth)


def _toe_angles(stances, peak_deg: float) -> dict:
    """Spline coefficients [rad] of a toe angle: 0 until 55 % of the stance, then a smooth step
    to ``peak_deg`` at toe-off (as ``tests/test_effect_toe_joint.py``)."""
    from gc_ocp.estimation.components.toe_joint import ToeJoint

    tj, fixed = ToeJoint(drive="spline"), {}
    for st in stances:
        t = st.time
        t_on, t_off = t[st.in_contact][[0, -1]]
        t_a = t_on + 0.55 * (t_off - t_on)
        s = np.clip((t - t_a) / (t_off - t_a), 0, 1)
        B, _ = tj.basis(t)
        fixed[st.label] = np.linalg.lstsq(B, np.deg2rad(peak_deg) * s * s * (3 - 2 * s))[0]
    return fixed


def truth_model(effect: str, magnitude: str, base: tuple, stances, rng) -> tuple:
    """``base`` (a frozen base fit) plus ``effect`` at ``magnitude`` (:data:`VALUES`); random
    signs and patterns from ``rng``. ``kinematic_correction`` and ``none`` return ``base``
    (the kinematic error is applied to the data, :func:`generate`)."""
    from gc_ocp.estimation.components import (
        ContactDensity,
        Damping,
        GroundOffset,
        Param,
        SoleCorrection,
        StiffnessExponent,
        StribeckFriction,
        TimeOffset,
        ToeJoint,
    )

    if effect in (NONE, "kinematic_correction"):
        return base
    v = VALUES[effect][magnitude]
    law = _law(base)
    sides = sorted({st.side for st in stances})
    if effect == "damping":
        return (*base, Damping(fixed=float(v)))
    if effect == "stiffness_exponent":
        # k rescaled per unit to keep the force at the 5 mm reference depth
        d = law.reference_depth
        k = {s: {u: kv * d ** (1 - v) for u, kv in ks.items()} for s, ks in law.k.value.items()}
        law = dataclasses.replace(law, k=Param("fixed", k))
        return (*_replace_law(base, law), StiffnessExponent(fixed=float(v)))
    if effect == "sole_geometry":
        offsets = {s: rng.uniform(-v, v, (5, 3)) for s in sides}
        have = next((c for c in base if c.name == "sole"), None)
        if have is not None:
            offsets = {s: np.asarray(have.fixed[s]) + offsets[s] for s in sides}
            return tuple(SoleCorrection(fixed=offsets) if c is have else c for c in base)
        return (*base, SoleCorrection(fixed=offsets))
    if effect == "contact_density":
        theta = {
            s: [
                float(np.log(np.median(list(law.k.value[s].values())) * 5 / 16)),
                -np.log(v) / 2,
                0.0,
                0.0,
            ]
            for s in sides
        }
        return (*base, ContactDensity(fixed=theta))
    if effect == "toe_joint":
        # TT at its nominal point, the other units as fitted: the base fit moves TT 20-25 mm
        # back, nearly under the MTP axis, where a hinge barely changes its depth (see
        # tests/test_effect_toe_joint.py, which zeroes the whole sole)
        def nominal_tt(c):
            fixed = {}
            for side, o in c.fixed.items():
                o = np.array(o, float)
                o[list(stances[0].layout.units).index("TT")] = 0.0
                fixed[side] = o
            return dataclasses.replace(c, fixed=fixed)

        base = tuple(nominal_tt(c) if c.name == "sole" else c for c in base)
        return (*base, ToeJoint(drive="spline", fixed=_toe_angles(stances, float(v))))
    if effect == "ground_offset":
        dz, tilt = v
        fixed = {
            st.label: (
                dz * rng.choice([-1.0, 1.0]),
                np.deg2rad(tilt) * rng.choice([-1.0, 1.0]),
                np.deg2rad(tilt) * rng.choice([-1.0, 1.0]),
            )
            for st in stances
        }
        return (*base, GroundOffset(fixed=fixed))
    if effect == "time_offset":
        return (*base, TimeOffset(fixed={st.trial: float(v) for st in stances}))
    if effect == "friction":
        excess, viscous = v
        return (*base, StribeckFriction(fixed={"static_excess": excess, "viscous": viscous}))
    raise InputError(f'Unknown effect "{effect}"; choose from {[*EFFECTS, NONE]}')


def kinematic_error(truth_name, mag, base_model_, realism):
    """``run_case``'s choice of the kinematic error the fitter sees."""
    has_pose = any(c.name == "pose" for c in base_model_)
    if truth_name == "kinematic_correction":
        kin_err = VALUES[truth_name][mag]
    elif has_pose:
        kin_err = (realism.marker_noise, realism.drift_translation, realism.drift_rotation_deg)
    else:
        kin_err = None
    return kin_err


# --- the data generator before the mismatch family (gc_ocp/bench/truth.py at commit a750d22),
# verbatim: a case without a mismatch must stay bit for bit what it was
# (tests/test_mismatch.py); and simulate as it was in gc_ocp/bench/recovery.py

PLATE_NOISE_PCT_BW = 0.5
TORQUE_NOISE_LENGTH = 0.02  # [m]


def simulate(
    stances: Sequence[StanceData],
    truth: tuple,
    rng: np.random.Generator,
    plate_noise_pct_bw: float = PLATE_NOISE_PCT_BW,
    marker_noise: float = 0.0,
) -> list[StanceData]:
    """``stances`` with the plate data the ``truth`` model (components with fixed values; any
    stance-scope component at zero) predicts on their motion, plus white plate noise; with
    ``marker_noise`` [m] > 0 the foot kinematics the fitter sees are re-estimated from noisy
    virtual markers. Each truth component may change how the plate records the wrench
    (:meth:`Component.observe`, e.g. a clock offset)."""
    stances = list(stances)
    pb = build_estimation(stances, truth)
    wrenches = pb.stance_wrenches(np.zeros(pb.x0.size) if pb.x0.size else pb.x0)
    out = []
    for st, w in zip(stances, wrenches, strict=True):
        sd = plate_noise_pct_bw / 100 * st.body_weight
        noise = rng.normal(0.0, 1.0, w.shape) * np.array(
            [sd, sd, sd, *(3 * [sd * TORQUE_NOISE_LENGTH])]
        )
        obs = st.with_measured(w)
        obs = _with_plate_signal(obs, *plate_signal(st.time, w))
        for c in truth:
            obs = c.observe(obs, w)
        obs = obs.with_measured(obs.measured + noise)
        if obs.plate_wrench is not None and obs.plate_time is not None:
            pn = rng.normal(0.0, 1.0, obs.plate_wrench.shape) * np.array(
                [sd, sd, sd, *(3 * [sd * TORQUE_NOISE_LENGTH])]
            )
            obs = _with_plate_signal(obs, obs.plate_time, obs.plate_wrench + pn)
        if marker_noise > 0:
            obs = obs.with_foot(noisy_pose(obs.foot, marker_noise, rng))
        out.append(obs)
    return out


def _with_plate_signal(st: StanceData, time: np.ndarray, wrench: np.ndarray) -> StanceData:

    return dataclasses.replace(
        st, plate_time=np.asarray(time, float), plate_wrench=np.asarray(wrench, float)
    )


def drift(
    stances: Sequence[StanceData],
    translation: float,
    rotation_deg: float,
    rng,
    stride_variation: float = 0.25,
) -> list[StanceData]:
    """``stances`` with a slow rigid soft-tissue drift of the foot: per axis an offset plus a
    linear trend over the stance, RMS ~``translation`` [m] and ``rotation_deg`` per axis. The
    pattern is the foot's (soft-tissue artefacts repeat from stride to stride of a subject and
    task, Leardini et al. 2005), and each stance varies it by ``stride_variation`` of its size."""

    def coefficients(sd):
        return rng.normal(0.0, sd / np.sqrt(2), (2, 3))

    pattern = {
        side: (coefficients(translation), coefficients(np.deg2rad(rotation_deg)))
        for side in sorted({st.side for st in stances})
    }
    out = []
    for st in stances:
        t = st.time
        s = (2 * (t - t[0]) / (t[-1] - t[0]) - 1)[:, None] * np.sqrt(3)  # unit RMS over stance
        tr, rot = pattern[st.side]
        tr = tr + stride_variation * coefficients(translation)
        rot = rot + stride_variation * coefficients(np.deg2rad(rotation_deg))
        out.append(st.with_foot(with_pose_error(st.foot, rot[0] + rot[1] * s, tr[0] + tr[1] * s)))
    return out


def _thresholded(st: StanceData, threshold: float) -> StanceData:
    """The plate wrench zeroed where its vertical force is below ``threshold`` [N]."""

    def cut(w):
        w = np.array(w, float)
        w[w[:, 2] < threshold] = 0.0
        return w

    st = st.with_measured(cut(st.measured))
    if st.plate_wrench is not None:
        st = dataclasses.replace(st, plate_wrench=cut(st.plate_wrench))
    return st


def generate(
    stances: Sequence[StanceData],
    truth: tuple,
    rng: np.random.Generator,
    realism: Realism = DEFAULT_REALISM,
    kinematic_error: tuple[float, float, float] | None = None,
) -> list[StanceData]:
    """What the fitter gets: the plate data ``truth`` predicts on ``stances`` (the true motion),
    with plate noise and thresholding, and the foot kinematics seen through ``kinematic_error``
    = (marker noise [m], drift [m], drift [deg]) (None: exact kinematics)."""
    law = _law(truth)
    changes = {
        k: v
        for k, v in (
            ("depth_smoothing", realism.truth_depth_smoothing),
            ("slip_smoothing", realism.truth_slip_smoothing),
        )
        if v is not None
    }
    if changes:
        truth = _replace_law(truth, dataclasses.replace(law, **changes))
    data = simulate(list(stances), truth, rng, plate_noise_pct_bw=realism.plate_noise_pct_bw)
    data = [_thresholded(st, realism.force_threshold) for st in data]
    if kinematic_error is None:
        return data
    noise, d_m, d_deg = kinematic_error
    data = drift(data, d_m, d_deg, rng, realism.stride_variation)
    if noise > 0:
        data = [st.with_foot(noisy_pose(st.foot, noise, rng)) for st in data]
    return data
