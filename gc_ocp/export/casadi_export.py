"""The calibrated contact model as a ``casadi.Function``: foot poses and velocities in, each
foot's wrench and each unit's force out, every fitted parameter baked in; for a user's own
optimal-control problem (bioptim, PredSim-like scripts), with exact derivatives.

The function is the fit's own per-frame model (:mod:`gc_ocp.estimation.frame`, the same SX
expressions the estimator differentiates) with the frame's fixed inputs (the law's parameters,
the units' fitted points, the floor height and belt velocity of the fit) replaced by their
values. Signature of :func:`casadi_function` (``s`` = ``left``, ``right``; all SI, ``lab``
frame: X forward, Y left, Z up)::

    inputs   s_hindfoot_R (3x3)  hindfoot rotation, segment -> lab
             s_hindfoot_p (3)    its origin [m]
             s_hindfoot_v (3)    its origin's velocity [m/s]
             s_hindfoot_w (3)    its angular velocity [rad/s]
             s_toes_R, s_toes_p, s_toes_v, s_toes_w: the same for the toes segment
             reference (3)       the point the moments are taken about [m]
    outputs  s_wrench (6)        force [N] and moment about ``reference`` [N m] on the foot
             s_unit_forces (3x5) each unit's force [N] (columns PL, PM, AL, AM, TT)

The segment frames are the package's body model's (``gc_ocp.model``; its OpenSim export,
``gc_ocp.export.opensim_export``, has the same bodies): a user whose model has other foot
frames places them with one constant transform per segment. The velocities are the segment
origin's linear velocity and the angular velocity, both in ``lab``, as
``pinocchio.getFrameVelocity(..., LOCAL_WORLD_ALIGNED)`` gives them.
"""

from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np

from gc_ocp.errors import InputError
from gc_ocp.export.calibrated import CalibratedContact
from gc_ocp.foot import SEED_LAYOUT, FootKinematics
from gc_ocp.stance import StanceData

KINEMATIC_INPUTS = (
    "hindfoot_R",
    "hindfoot_p",
    "hindfoot_v",
    "hindfoot_w",
    "toes_R",
    "toes_p",
    "toes_v",
    "toes_w",
)
"""Each foot's inputs, in order (module doc)."""
FRAME_DATA = {
    "hindfoot_R": "hindfoot_R",
    "hindfoot_o": "hindfoot_p",
    "hindfoot_v": "hindfoot_v",
    "hindfoot_w": "hindfoot_w",
    "toes_R": "toes_R",
    "toes_o": "toes_p",
    "toes_v": "toes_v",
    "toes_w": "toes_w",
}
"""The per-frame data (:data:`gc_ocp.estimation.frame.BASE_DATA`) each input fills."""


def _one_frame(side: str, cal: CalibratedContact) -> StanceData:
    """A one-frame stance of ``side`` (identity poses) to build the frame model on."""
    pose = np.eye(4)[None]
    twist = np.zeros((1, 6))
    foot = FootKinematics(
        side, np.zeros(1), pose, pose, twist, twist, np.asarray(cal.points[side], float)
    )
    return StanceData(
        side=side,
        label=f"export:{side}",
        foot=foot,
        measured=np.zeros((1, 6)),
        reference_point=np.zeros(3),
        ground_height=cal.ground_height,
        belt_velocity=cal.belt_velocity,
        body_weight=cal.body_weight,
        height=cal.height,
    )


def _foot_expressions(side: str, cal: CalibratedContact, reference: ca.SX):
    """``(inputs, wrench, unit_forces)`` of one foot: SX symbols and expressions."""
    from gc_ocp.estimation import build_estimation

    pb = build_estimation([_one_frame(side, cal)], cal.model(), compile=False)
    block = pb.blocks[0]
    y = ca.DM(block.Y(np.zeros(pb.x0.size))[:, 0])
    fm = block.fm
    inputs = {}
    for name in KINEMATIC_INPUTS:
        shape = (3, 3) if name.endswith("_R") else (3, 1)
        inputs[f"{side}_{name}"] = ca.SX.sym(f"{side}_{name}", *shape)
    parts = []
    for name, (start, size) in fm.data.index.items():
        if name in FRAME_DATA:
            parts.append(
                ca.reshape(inputs[f"{side}_{FRAME_DATA[name]}"], size, 1)
            )  # R: column-major, as the frame reads it
        elif name == "reference":
            parts.append(reference)
        else:  # fixed data of the fit (floor, belt) or unused by the wrench (measured, weights)
            parts.append(ca.DM(block.D[start : start + size, 0]))
    D = ca.vertcat(*parts)
    out = fm.frame(D, y)
    return inputs, out[1], out[3]


def casadi_function(
    fit,
    sides: tuple[str, ...] | None = None,
    name: str = "gc_ocp_contact",
    trial: str | None = None,
):
    """The calibrated contact model of ``fit`` (a ``FitReport``, an ``EstimationResult``, a
    ``fit.json`` dict or path) as a ``casadi.Function`` (signature: module doc); ``sides``:
    the feet (default both the fit has); ``trial``: the fit's trial whose unit points are baked
    in (a fit of several trials: each trial's kinematics place the points; default the first)."""
    cal = CalibratedContact.from_fit(fit, trial=trial)
    sides = (sides,) if isinstance(sides, str) else tuple(sides or sorted(cal.points))
    unknown = [s for s in sides if s not in cal.points]
    if unknown:
        raise InputError(f"the fit has no {unknown} foot; it has {sorted(cal.points)}")
    reference = ca.SX.sym("reference", 3)
    names_in, syms_in, names_out, exprs = [], [], [], []
    for side in sides:
        inputs, wrench, forces = _foot_expressions(side, cal, reference)
        names_in += list(inputs)
        syms_in += list(inputs.values())
        names_out += [f"{side}_wrench", f"{side}_unit_forces"]
        exprs += [wrench, forces]
    return ca.Function(name, [*syms_in, reference], exprs, [*names_in, "reference"], names_out)


def write_casadi(
    fit, path: str | Path, sides: tuple[str, ...] | None = None, trial: str | None = None
) -> Path:
    """Save :func:`casadi_function` of ``fit`` to ``path`` (``.casadi``; complete or absent):
    ``casadi.Function.load(path)`` gives it back, in any CasADi of the same major version.
    ``fit`` may also be that function, made already (``sides`` and ``trial`` are then its)."""
    from gc_ocp.outputs import atomic_write

    f = fit if isinstance(fit, ca.Function) else casadi_function(fit, sides, trial=trial)
    # the file mode follows the umask, as every other output's (mkstemp alone gives 0600)
    return atomic_write(path, lambda tmp: f.save(str(tmp)))


def evaluate(
    f: ca.Function, kin, side: str, reference=(0.0, 0.0, 0.0)
) -> tuple[np.ndarray, np.ndarray]:
    """``f`` (:func:`casadi_function`) on every frame of ``kin``'s ``side`` foot: ``(wrench
    (n, 6), unit forces (n, 3, 5))``."""
    foot: FootKinematics = kin.feet[side]
    n = foot.time.size
    fm = f.map(n)
    args = {}
    for seg, pose, twist in (
        ("hindfoot", foot.hindfoot_pose, foot.hindfoot_twist),
        ("toes", foot.toes_pose, foot.toes_twist),
    ):
        args[f"{side}_{seg}_R"] = pose[:, :3, :3].transpose(1, 0, 2).reshape(3, 3 * n)
        args[f"{side}_{seg}_p"] = pose[:, :3, 3].T
        args[f"{side}_{seg}_v"] = twist[:, :3].T
        args[f"{side}_{seg}_w"] = twist[:, 3:].T
    args["reference"] = np.tile(np.asarray(reference, float)[:, None], (1, n))
    for other in f.name_in():
        args.setdefault(other, np.zeros((f.size1_in(other), f.size2_in(other) * n)))
    res = fm(**args)
    wrench = np.asarray(res[f"{side}_wrench"]).T
    forces = np.asarray(res[f"{side}_unit_forces"]).reshape(3, n, len(SEED_LAYOUT.units))
    return wrench, forces.transpose(1, 0, 2)


__all__ = ("KINEMATIC_INPUTS", "casadi_function", "evaluate", "write_casadi")
