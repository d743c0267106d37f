"""Per-stance data handed to the estimator: numeric, time-first, SI, ``lab`` frame."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gc_ocp.errors import InputError
from gc_ocp.sole import FootKinematics, TrialKinematics
from gc_ocp.stance_window import cut_stance
from gc_ocp.trial import Stance, Trial


@dataclass(frozen=True)
class StanceData:
    """Everything the estimator needs about one stance.

    time: ``(n,)`` [s]; foot: the foot's kinematics on those frames (nominal sole points);
    measured: ``(n, 6)`` measured wrench (force [N], moment [N·m] about ``reference_point``);
    in_contact: ``(n,)`` bool, frames inside the detected stance window (others are margin
    frames where the plate is unloaded and the model must predict no force);
    ground_height: plate surface height [m]; belt_velocity: ``(3,)`` [m/s];
    body_weight [N], height [m]: the subject's, for reporting; label: e.g. ``"trial:right@0.41s"``.
    """

    trial: str
    side: str
    label: str
    time: np.ndarray
    foot: FootKinematics
    measured: np.ndarray
    in_contact: np.ndarray
    reference_point: np.ndarray
    ground_height: float
    belt_velocity: np.ndarray
    body_weight: float
    height: float

    @property
    def n(self) -> int:
        return int(self.time.shape[0])


def stance_data(
    trial: Trial, kin: TrialKinematics, stance: Stance, margin: float = 0.03
) -> StanceData:
    """Cut one stance (plus ``margin`` [s] of unloaded frames each side) out of a trial."""
    if trial.height is None:
        raise InputError(
            f"{trial.source}: subject height unknown; pass height=... (CLI: --height M) so that "
            "torques can be reported in % BW x height."
        )
    w = cut_stance(trial, kin, stance, margin, min_frames=5)
    return StanceData(
        trial=trial.name,
        side=stance.side,
        label=f"{trial.name}:{stance.label}",
        time=w.foot.time,
        foot=w.foot,
        measured=w.measured,
        in_contact=w.in_contact,
        reference_point=w.reference_point,
        ground_height=w.ground_height,
        belt_velocity=w.belt_velocity,
        body_weight=trial.body_weight,
        height=float(trial.height),
    )


def all_stance_data(trial: Trial, kin: TrialKinematics, margin: float = 0.03) -> list[StanceData]:
    return [stance_data(trial, kin, s, margin) for s in trial.stances]
