"""A contact model run forward on a whole trial: each foot's wrench on every frame of its
kinematics (stance and swing), as a simulator applying the calibrated model would compute it.

The model is evaluated exactly as the fit evaluates it (the same per-frame functions, built by
:func:`~gc_ocp.estimation.problem.build_estimation` without compiling), on one "stance" per foot
that spans the trial, with the ground at the trial's floor height everywhere. A stance-scope
component (the per-stance pose correction) is left at zero: the foot moves as the kinematics
say. Frames without finite kinematics (marker gaps) give NaN.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gc_ocp.errors import InputError
from gc_ocp.foot import TrialKinematics
from gc_ocp.stance import StanceData
from gc_ocp.trial import Trial


@dataclasses.dataclass(frozen=True)
class FootWrenches:
    """``time`` ``(n,)`` [s] and ``{side: (n, 6)}`` wrenches (force [N], moment [N m] about the
    ``lab`` origin, ``lab``) of a model on a trial; ``ground_height`` [m]: the plane used."""

    time: np.ndarray
    wrench: dict
    ground_height: float


def whole_trial_stances(
    trial: Trial, kin: TrialKinematics, ground_height: float | None = None
) -> tuple[np.ndarray, dict[str, np.ndarray], list[StanceData]]:
    """``(time, {side: finite frame mask}, stances)``: one :class:`StanceData` per foot over its
    finite frames, reference point at the ``lab`` origin, ground at ``ground_height`` (default:
    the trial's floor), measured wrench zero."""
    h = trial.floor_height if ground_height is None else float(ground_height)
    # the subject's height, for the problem's reporting: the file's, else the kinematics'
    # estimate (as the fit uses it)
    height = trial.height if trial.height is not None else kin.info.get("height", float("nan"))
    time = None
    masks, stances = {}, []
    for side, foot in sorted(kin.feet.items()):
        if time is None:
            time = foot.time
        elif foot.time.shape != time.shape or not np.allclose(foot.time, time):
            raise InputError(
                f"{trial.source}: the feet's kinematics have different frames; compute them "
                "together (gc_ocp.kinematics.compute_kinematics)."
            )
        ok = np.isfinite(foot.positions).all(axis=(1, 2)) & np.isfinite(foot.velocities).all(
            axis=(1, 2)
        )
        if ok.sum() < 2:
            continue
        masks[side] = ok
        f = foot.frames(ok) if not ok.all() else foot
        stances.append(
            StanceData(
                side=side,
                label=f"{trial.name}:{side} (whole trial)",
                foot=f,
                measured=np.zeros((f.time.size, 6)),
                reference_point=np.zeros(3),
                ground_height=h,
                belt_velocity=np.asarray(trial.belt_velocity, float),
                trial=trial.name,
                body_weight=trial.body_weight,
                height=float(height),
            )
        )
    if not stances:
        raise InputError(f"{trial.source}: no foot has kinematics to run the model on.")
    return np.asarray(time, float), masks, stances


def foot_wrenches(
    model: tuple, trial: Trial, kin: TrialKinematics, ground_height: float | None = None
) -> FootWrenches:
    """The wrench of ``model`` (components with every parameter fixed, e.g.
    :func:`~gc_ocp.estimation.starts.frozen_model` of a fit) on every frame of ``kin``
    (module doc)."""
    from gc_ocp.estimation import build_estimation

    time, masks, stances = whole_trial_stances(trial, kin, ground_height)
    model = tuple(c for c in model if c.scope != "stance")  # a pose correction at zero
    pb = build_estimation(stances, model, compile=False)
    free = [v.key for v in pb.variables.specs if v.kind == "param"]
    if free:
        raise InputError(
            f"foot_wrenches: the model still has free parameters {free[:3]}; freeze it at a "
            "fit first "
            "(gc_ocp.estimation.starts.frozen_model(model, result))."
        )
    out = {}
    for st, w in zip(stances, pb.stance_wrenches(np.zeros(pb.x0.size)), strict=True):
        full = np.full((time.size, 6), np.nan)
        full[masks[st.side]] = w
        out[st.side] = full
    return FootWrenches(time=time, wrench=out, ground_height=stances[0].ground_height)


__all__ = ("FootWrenches", "foot_wrenches", "whole_trial_stances")
