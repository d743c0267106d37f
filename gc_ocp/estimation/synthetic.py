"""Synthetic stances for recovery tests and benchmarks: a rigid foot rolling heel-to-toe, and
the plate data a known model predicts on any stances (:func:`simulate`).

The motion is smooth and realistic in shape (heel strike at 12 deg dorsiflexion, foot flat,
heel-off and roll over the metatarsal heads to 35 deg plantarflexion), the foot sinks a few
millimetres into the ground in stance, and it slides slightly. Ground reactions are generated with
the same per-frame model function the estimator uses, with known ("true") parameters.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from scipy.signal import butter, filtfilt
from scipy.spatial.transform import Rotation

from gc_ocp.contact.equivalent_wrench import LawParams, model_wrench
from gc_ocp.contact.laws import Smoothing
from gc_ocp.estimation.components import ContactLaw, Param, PoseCorrection, SoleCorrection
from gc_ocp.estimation.problem import build_estimation
from gc_ocp.estimation.result import EstimationResult
from gc_ocp.estimation.starts import rescaled_start
from gc_ocp.foot import FootKinematics
from gc_ocp.geometry import kabsch
from gc_ocp.marker_noise import foot_pose_noise, white_noise
from gc_ocp.stance import PLATE_SIGNAL_MARGIN, StanceData
from gc_ocp.synthetic_foot import NOMINAL_POINTS, nominal_points, rolling_foot
from gc_ocp.trial import GRAVITY

PLATE_NOISE_PCT_BW = 0.5
"""Default white plate noise of :func:`simulate` [% BW] (the residual of a well-zeroed plate
after the 6 Hz filtering of the kinematics' rate)."""
TORQUE_NOISE_LENGTH = 0.02  # [m]
"""Moment noise = force noise x this length [m] (a COP noise of ~20 mm at 0.5 % BW)."""


def synthetic_stance(
    side: str,
    truth: dict,
    points_local: np.ndarray | None = None,
    body_weight: float = 700.0,
    height: float = 1.75,
    rate: float = 100.0,
    duration: float = 0.65,
    t0: float = 0.0,
    rng: np.random.Generator | None = None,
    force_noise: float = 0.0,
    marker_noise: float = 0.0,
    sink: float = 0.006,
    label: str | None = None,
    style: np.ndarray | None = None,
) -> StanceData:
    """One synthetic stance. ``truth``: ``{"k": (5,), "n", "c", "mu"}`` [SI]; ``points_local``:
    true unit positions (default nominal); ``force_noise`` [N] and ``marker_noise`` [m] standard
    deviations (marker noise perturbs the foot pose given to the fitter, through 3 virtual markers)."""
    foot = rolling_foot(side, duration, rate, t0, sink, style=style)
    true_pts = nominal_points(side) if points_local is None else np.asarray(points_local)
    true_foot = foot.with_points(true_pts)
    ref = np.array([0.6, 0.1 if side == "left" else -0.1, -0.04])
    # the estimator's smooth law (tests/test_pins.py: equal to its per-frame model to 1e-12)
    law = LawParams(
        n=truth["n"],
        c=truth["c"],
        mu=truth["mu"],
        smooth=True,
        smoothing=Smoothing(5e-4, 1e-2, 0.05),
    )
    meas = model_wrench(
        true_foot.positions, true_foot.velocities, np.asarray(truth["k"], float), ref, law
    )
    rng = rng or np.random.default_rng(0)
    if force_noise > 0:
        meas = meas + rng.normal(0, force_noise, meas.shape) * np.array([1, 1, 1, 0.05, 0.05, 0.05])
    fit_foot = true_foot.with_points(nominal_points(side))
    if marker_noise > 0:
        fit_foot = noisy_pose(fit_foot, marker_noise, rng)
    s = (foot.time >= t0) & (foot.time <= t0 + duration)
    plate_t, plate_w = plate_signal(foot.time, meas)
    return StanceData(
        trial="synthetic",
        side=side,
        label=label or f"synthetic:{side}@{t0:.2f}s",
        foot=fit_foot,
        measured=meas,
        in_contact=s,
        reference_point=ref,
        ground_height=0.0,
        belt_velocity=np.zeros(3),
        body_weight=body_weight,
        height=height,
        plate_time=plate_t,
        plate_wrench=plate_w,
    )


def plate_signal(time: np.ndarray, wrench: np.ndarray, rate: float = 1000.0):
    """A plate signal for a wrench known on frames ``time``: ``(plate_time, plate_wrench)`` at
    ``rate`` [Hz] over the frames +- ``PLATE_SIGNAL_MARGIN``, linear between frames, edge values
    held outside them (equal to ``wrench`` on the frames). What a clock-offset model resamples."""
    t = np.asarray(time, float)
    n_margin = round(PLATE_SIGNAL_MARGIN * rate)
    k = np.arange(-n_margin, round((t[-1] - t[0]) * rate) + n_margin + 1)
    pt = t[0] + k / rate
    return pt, np.column_stack([np.interp(pt, t, np.asarray(wrench)[:, c]) for c in range(6)])


def noisy_pose(foot: FootKinematics, sigma: float, rng: np.random.Generator) -> FootKinematics:
    """``foot`` as a marker pipeline would see it: the hindfoot pose re-estimated (Kabsch) from 4
    virtual markers with iid noise ``sigma`` [m], low-passed at 6 Hz; the same rigid error moves
    the toes (the toes are not tracked separately). Its ``pose_noise`` is what the pipeline
    measures from those raw markers (:mod:`gc_ocp.marker_noise`), not ``sigma``."""
    mk = np.array(
        [[-0.07, 0.0, -0.03], [0.16, 0.0, -0.04], [0.0, -0.04, 0.0], [0.10, -0.045, -0.04]]
    )
    T = foot.time.size
    P = foot.hindfoot_pose
    obs = (
        np.einsum("nij,mj->nmi", P[:, :3, :3], mk)
        + P[:, None, :3, 3]
        + rng.normal(0, sigma, (T, len(mk), 3))
    )
    Rs, os_ = kabsch(mk, obs)
    rate = 1.0 / np.median(np.diff(foot.time))
    b, a = butter(2, 6.0 / (rate / 2))
    dR = Rotation.from_matrix(np.einsum("nji,njk->nik", P[:, :3, :3], Rs)).as_rotvec()
    dR = filtfilt(b, a, dR, axis=0)
    do = filtfilt(b, a, os_ - P[:, :3, 3], axis=0)
    # what the pipeline would measure: the markers' white noise, from the raw markers
    measured = float(np.median(white_noise(obs, rate)))
    noise = foot_pose_noise(mk, measured, rate, 6.0, order=4)
    return replace(with_pose_error(foot, dR, do), pose_noise=noise)


def with_pose_error(
    foot: FootKinematics, rotation: np.ndarray, translation: np.ndarray
) -> FootKinematics:
    """``foot`` seen with a rigid error of its hindfoot pose: ``rotation`` ``(T, 3)`` [rad] a
    rotation vector in the hindfoot frame (``R' = R exp(rotation)``), ``translation`` ``(T, 3)``
    [m] of the hindfoot origin in ``lab``; the same rigid error moves the toes (the toes are not
    tracked separately), twists updated consistently. Zero error gives back the input exactly."""
    dR, do = np.asarray(rotation, float), np.asarray(translation, float)
    P = foot.hindfoot_pose
    Rn = np.einsum("nij,njk->nik", P[:, :3, :3], Rotation.from_rotvec(dR).as_matrix())
    on = P[:, :3, 3] + do
    # the same rigid error moves both segments: a lab transform D = (R_d, t_d) with
    # R_d = Rn R^T, t_d = on - R_d o, applied to hindfoot and toes poses and their twists
    # (v' = R_d v + dR_d/dt p + dt_d/dt at the moved origin, w' = R_d w + w_d): zero noise
    # gives back the input exactly
    Rd = np.einsum("nij,nkj->nik", Rn, P[:, :3, :3])
    td = on - np.einsum("nij,nj->ni", Rd, P[:, :3, 3])
    dRd = np.gradient(Rd, foot.time, axis=0)
    dtd = np.gradient(td, foot.time, axis=0)
    Wd = np.einsum("nij,nkj->nik", dRd, Rd)
    wd = (
        np.stack(
            [Wd[:, 2, 1] - Wd[:, 1, 2], Wd[:, 0, 2] - Wd[:, 2, 0], Wd[:, 1, 0] - Wd[:, 0, 1]],
            axis=1,
        )
        / 2
    )

    def moved(pose, twist):
        out = pose.copy()
        out[:, :3, :3] = np.einsum("nij,njk->nik", Rd, pose[:, :3, :3])
        out[:, :3, 3] = np.einsum("nij,nj->ni", Rd, pose[:, :3, 3]) + td
        v = (
            np.einsum("nij,nj->ni", Rd, twist[:, :3])
            + np.einsum("nij,nj->ni", dRd, pose[:, :3, 3])
            + dtd
        )
        w = np.einsum("nij,nj->ni", Rd, twist[:, 3:]) + wd
        return out, np.hstack([v, w])

    hp, ht = moved(foot.hindfoot_pose, foot.hindfoot_twist)
    tp, tt = moved(foot.toes_pose, foot.toes_twist)
    return replace(
        foot,
        hindfoot_pose=hp,
        toes_pose=tp,
        hindfoot_twist=ht,
        toes_twist=tt,
        positions=None,
        velocities=None,
    )


def simulate(
    stances: Sequence[StanceData],
    truth: tuple,
    rng: np.random.Generator,
    plate_noise_pct_bw: float = PLATE_NOISE_PCT_BW,
    marker_noise: float = 0.0,
    at: EstimationResult | None = None,
) -> list[StanceData]:
    """``stances`` with the plate data the ``truth`` model (components with fixed values; any
    stance-scope component at zero, or, with ``at``, at that result's values, matched by key:
    e.g. the per-stance pose correction a fit estimated) predicts on their motion, plus white
    plate noise; with
    ``marker_noise`` [m] > 0 the foot kinematics the fitter sees are re-estimated from noisy
    virtual markers. Each truth component may change how the plate records the wrench
    (:meth:`Component.observe`, e.g. a clock offset). The truth's per-frame functions are not
    compiled (only their values are needed: a truth variant of its own physics, such as a
    mismatch draw's law smoothing, costs no C compilation)."""
    stances = list(stances)
    pb = build_estimation(stances, truth, compile=False)
    x = np.zeros(pb.x0.size) if at is None else rescaled_start(at, pb, neutral=True)
    wrenches = pb.stance_wrenches(x)
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

    return replace(st, plate_time=np.asarray(time, float), plate_wrench=np.asarray(wrench, float))


def default_truth(seed: int = 0, body_weight: float = 700.0) -> dict:
    rng = np.random.default_rng(seed)
    return {"k": rng.uniform(0.6, 1.4, 5) * 3.0e5, "n": 1.5, "c": 1.0, "mu": 0.8}


def recovery_model(marker_noise: bool = True) -> tuple:
    """The model the synthetic recovery checks fit to :func:`default_truth`'s stances: k per
    unit (weak log prior), shared n, c, mu started away from the truth (1.3, 0.5, 0.6), sole and
    pose corrections (``marker_noise``: the pose correction's measured-noise part,
    :class:`~gc_ocp.estimation.components.pose.PoseCorrection`)."""
    law = ContactLaw(
        k=Param("unit", 2e5, 1e2, 1e9, prior_sigma=2.0),
        n=Param("shared", 1.3, 1, 3),
        c=Param("shared", 0.5, 0, 10),
        mu=Param("shared", 0.6, 0, 1.5),
    )
    return (law, SoleCorrection(), PoseCorrection(marker_noise=marker_noise))


__all__ = [
    "NOMINAL_POINTS",
    "PLATE_NOISE_PCT_BW",
    "TORQUE_NOISE_LENGTH",
    "simulate",
    "rolling_foot",
    "synthetic_stance",
    "default_truth",
    "recovery_model",
    "nominal_points",
    "noisy_pose",
    "with_pose_error",
    "GRAVITY",
]
