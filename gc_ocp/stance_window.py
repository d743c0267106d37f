"""Cut one stance out of a trial: the foot's kinematics and the measured wrench on the same
frames. The single place that knows how a stance window is taken; the seed's linear least
squares (:mod:`gc_ocp.contact.lls`) and the joint estimator (:mod:`gc_ocp.estimation.data`) both
build their own view of a stance from it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gc_ocp.errors import InputError
from gc_ocp.sole import FootKinematics, TrialKinematics
from gc_ocp.trial import Stance, Trial


@dataclass(frozen=True)
class StanceWindow:
    """foot: kinematics on the kept frames; measured: ``(n, 6)`` wrench about ``reference_point``
    (``lab``, [N], [N·m]); in_contact: ``(n,)`` frames inside ``[t_on, t_off]`` (the others are
    margin frames); ground_height [m]; belt_velocity ``(3,)`` [m/s]."""

    foot: FootKinematics
    measured: np.ndarray
    in_contact: np.ndarray
    reference_point: np.ndarray
    ground_height: float
    belt_velocity: np.ndarray


def cut_stance(
    trial: Trial, kin: TrialKinematics, stance: Stance, margin: float = 0.0, min_frames: int = 1
) -> StanceWindow:
    """Frames of ``kin.feet[stance.side]`` within ``[t_on - margin, t_off + margin]`` [s], with the
    measured wrench there. Frames with non-finite kinematics or plate data are dropped; fewer than
    ``min_frames`` left is an :class:`InputError` naming the stance and the likely cause."""
    if stance.side not in kin.feet:
        raise InputError(
            f"Stance {stance.label} is on the {stance.side} foot but the kinematics have "
            f"feet {sorted(kin.feet)}"
        )
    foot = kin.feet[stance.side]
    t = foot.time
    sel = (t >= stance.t_on - margin - 1e-9) & (t <= stance.t_off + margin + 1e-9)
    idx = np.flatnonzero(sel)
    if idx.size:
        w = foot.window(t[idx[0]], t[idx[-1]])
        meas = trial.stance_wrench(stance, w.time)
        ok = (
            np.isfinite(w.positions).all(axis=(1, 2))
            & np.isfinite(w.velocities).all(axis=(1, 2))
            & np.isfinite(meas).all(axis=1)
        )
    if idx.size == 0 or ok.sum() < min_frames:
        raise InputError(
            f"{trial.source}: stance {stance.label} [{stance.t_on:.3f}, {stance.t_off:.3f}] s has "
            f"{0 if idx.size == 0 else int(ok.sum())} usable kinematic frames (need {min_frames}); "
            "check marker gaps, the plate channels and that the kinematics cover the stance."
        )
    if not ok.all():
        w = FootKinematics(
            w.side,
            w.time[ok],
            w.hindfoot_pose[ok],
            w.toes_pose[ok],
            w.hindfoot_twist[ok],
            w.toes_twist[ok],
            w.points_local,
            w.positions[ok],
            w.velocities[ok],
        )
        meas = meas[ok]
    return StanceWindow(
        foot=w,
        measured=meas,
        in_contact=(w.time >= stance.t_on - 1e-9) & (w.time <= stance.t_off + 1e-9),
        reference_point=np.asarray(stance.reference_point, float),
        ground_height=float(trial.plates[stance.plate].surface_height),
        belt_velocity=np.asarray(trial.belt_velocity, float),
    )
