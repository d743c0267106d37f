"""The fitted kinematics as joint coordinates: the inverse kinematics with each stance's foot
moved by the fit's pose correction, the leg's joints solved so that the body carries the foot
there.

A fit moves each foot in stance by a small rigid correction about the hindfoot origin (the
marker-registration and soft-tissue error it estimates, :class:`~gc_ocp.estimation.components.
pose.PoseCorrection`): ``p' = p + dp + (R(dth) - I)(p - o)``. A simulator has no such correction; it
has coordinates. For every frame of a fitted stance, the target is the hindfoot placed with the
correction (the rotation the fit applies, :func:`gc_ocp.geometry.correction_rotation`: the
foot's points land where the fit had them), and the six leg joints (hip 3,
knee, ankle, subtalar) are solved by Gauss-Newton on the hindfoot's placement (Pinocchio's
frame Jacobian), each frame anchored to its inverse-kinematics angles (:data:`ANCHOR`: well
posed near full extension and where the leg cannot reach; as continuous as the inverse
kinematics); the pelvis and the other leg stay. Before and after each window the
correction fades to zero over :data:`RAMP_FRAMES` frames (the foot is in the air there);
other frames keep the inverse kinematics. Velocities: the coordinates' rates,
``np.gradient`` as the pipeline takes them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np
import pinocchio as pin

from gc_ocp.foot import TrialKinematics
from gc_ocp.geometry import correction_rotation

LEG_JOINTS = ("hip_flexion", "hip_adduction", "hip_rotation", "knee", "ankle", "subtalar")
"""The joints solved per side (``_l`` / ``_r``)."""
RAMP_FRAMES = 10
"""Frames over which a stance's correction fades to zero before and after its window (the
foot is in the air there): a correction of millimetres switched on in one frame would give the
rates, and the damping, a spike."""
TOLERANCE = 1e-10
"""Gauss-Newton stops when the step is below this (rad, m): exact to the solver's precision."""


@dataclasses.dataclass(frozen=True)
class FittedKinematics:
    """``kin``: the kinematics with the corrected coordinates and feet; ``frames``: how many
    frames were corrected per side; ``residual_mm`` / ``residual_deg``: the largest distance
    between the solved hindfoot and its target (0 up to round-off unless a joint limit or the
    leg's reach stopped it)."""

    kin: TrialKinematics
    frames: Mapping[str, int]
    residual_mm: float
    residual_deg: float


ANCHOR = 1e-3
"""[m per rad] Weight of the leg's joints staying near their inverse-kinematics angles: one
radian of change costs as much as a millimetre of the foot's error. It makes each frame's
solve well posed (a leg near full extension has a nearly singular Jacobian, where a free
solve jumps to another branch, and a target the leg cannot reach has no exact solution) and
keeps the solved angles as continuous as the inverse kinematics."""
MAX_STEP = 0.1
"""[rad] Largest joint step per iteration."""


def _solve(body, data, q: np.ndarray, frame: int, cols: list[int], R_t, o_t) -> np.ndarray:
    """Gauss-Newton on the hindfoot's placement error and the anchor to ``q``'s angles."""
    anchor = q[cols].copy()
    for _ in range(50):
        pin.framesForwardKinematics(body.model, data, q)
        M = data.oMf[frame]
        err = np.r_[M.translation - o_t, pin.log3(M.rotation @ R_t.T), ANCHOR * (q[cols] - anchor)]
        J = pin.computeFrameJacobian(body.model, data, q, frame, pin.LOCAL_WORLD_ALIGNED)[:, cols]
        J = np.vstack([J, ANCHOR * np.eye(len(cols))])
        step = -np.linalg.solve(J.T @ J, J.T @ err)
        big = np.max(np.abs(step))
        if big > MAX_STEP:
            step *= MAX_STEP / big
        q = q.copy()
        q[cols] += step
        if big < TOLERANCE:
            break
    return q


def _corrections(fit_doc: Mapping):
    """``(stance fit, its pose correction)`` of every stance the fit placed: the fitted ones and
    the held-out one (``fit_doc["heldout"]``, its own fit under the frozen contact model)."""
    for doc in (fit_doc, fit_doc.get("heldout") or {}):
        per_stance = ((doc.get("blocks") or {}).get("pose") or {}).get("stances") or {}
        for sf in doc.get("stance_fits", []):
            if sf["label"] in per_stance:
                yield sf, per_stance[sf["label"]]


def fitted_kinematics(
    fit_doc: Mapping, kin: TrialKinematics, points: Mapping, trial: str | None = None
) -> FittedKinematics:
    """The coordinates of ``kin`` with each fitted stance's foot (and the held-out stance's) at
    the fit's corrected pose (module doc); ``fit_doc``: the fit's JSON (``fit.json`` / ``result.to_json()``); ``points``:
    each foot's unit points (``{side: (5, 3)}``) for the new feet; ``trial``: the name the fit
    gave ``kin``'s trial (its stances' ``trial``), when the fit has several trials: only that
    trial's stances are matched to ``kin``'s frames (None: every stance, a one-trial fit)."""
    from gc_ocp.kinematics.pipeline import foot_kinematics

    body = kin.info["body"]
    q = np.array(kin.q, float, copy=True)
    data = body.create_data()
    frames: dict[str, int] = {}
    worst_mm = worst_deg = 0.0
    for sf, corr in _corrections(fit_doc):
        if trial is not None and sf.get("trial") != trial:
            continue
        side = sf["side"]
        suffix = side[0]
        cols = [body.q_index(f"{j}_{suffix}") for j in LEG_JOINTS]
        fid = body.frame_id(f"hindfoot_{suffix}")
        idx = np.searchsorted(kin.time, np.asarray(sf["time"], float))
        idx = np.clip(idx, 0, kin.time.size - 1)
        dp = np.asarray(corr["translation_m"], float)
        dth = np.asarray(corr["rotation_rad"], float)
        # the window's frames and the ramps: (frame, translation, rotation)
        plan = [(int(k), dp[j], dth[j]) for j, k in enumerate(idx)]
        for r in range(1, RAMP_FRAMES + 1):
            w = 1.0 - r / (RAMP_FRAMES + 1)
            if idx[0] - r >= 0:
                plan.insert(0, (int(idx[0]) - r, w * dp[0], w * dth[0]))
            if idx[-1] + r < kin.time.size:
                plan.append((int(idx[-1]) + r, w * dp[-1], w * dth[-1]))
        foot = kin.feet[side]
        for k, t_corr, r_corr in plan:
            H = foot.hindfoot_pose[k]
            R_t = correction_rotation(r_corr) @ H[:3, :3]
            o_t = H[:3, 3] + t_corr
            q[k] = _solve(body, data, q[k], fid, cols, R_t, o_t)
            pin.framesForwardKinematics(body.model, data, q[k])
            M = data.oMf[fid]
            worst_mm = max(worst_mm, 1e3 * float(np.linalg.norm(M.translation - o_t)))
            worst_deg = max(
                worst_deg, float(np.degrees(np.linalg.norm(pin.log3(M.rotation @ R_t.T))))
            )
        frames[side] = frames.get(side, 0) + idx.size
    if not frames:
        return FittedKinematics(kin, {}, 0.0, 0.0)
    feet = {  # a foot the fit has no points of (no stance) keeps its own: its leg did not move
        side: foot_kinematics(body, q, kin.time, side, np.asarray(points[side], float))
        if side in points
        else foot
        for side, foot in kin.feet.items()
    }
    new = dataclasses.replace(kin, q=q, feet=feet)
    return FittedKinematics(new, frames, worst_mm, worst_deg)


__all__ = ("LEG_JOINTS", "FittedKinematics", "fitted_kinematics")
