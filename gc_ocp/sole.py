"""Sole-point kinematics: the interface between the body model and the contact model.

A foot has two rigid segments, ``hindfoot`` and ``toes`` (welded in the seed model). Five contact
units sit on the sole: posterior lateral ``PL``, posterior medial ``PM``, anterior lateral ``AL``,
anterior medial ``AM`` (on the hindfoot) and toe tip ``TT`` (on the toes). Each unit is a point
fixed in its parent segment frame; its ``lab`` trajectory follows from the parent's placement.

Everything here is time-first and SI: poses ``(n, 4, 4)``, twists ``(n, 6)`` = (linear velocity of
the frame origin, angular velocity), both expressed in ``lab`` (Pinocchio's LOCAL_WORLD_ALIGNED).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

UNITS: tuple[str, ...] = ("PL", "PM", "AL", "AM", "TT")
UNIT_PARENT: dict[str, str] = {
    "PL": "hindfoot",
    "PM": "hindfoot",
    "AL": "hindfoot",
    "AM": "hindfoot",
    "TT": "toes",
}


def _ro(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float, copy=True)
    a.setflags(write=False)
    return a


def points_in_lab(
    pose: np.ndarray, twist: np.ndarray, local: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Positions and velocities in ``lab`` of points fixed in a moving frame.

    pose: ``(n, 4, 4)`` frame-to-lab placements; twist: ``(n, 6)`` (v_origin, omega) in ``lab``;
    local: ``(m, 3)`` points in the frame [m]. Returns ``(n, m, 3)`` positions [m] and velocities [m/s].
    """
    R = pose[:, :3, :3]
    r = np.einsum("nij,mj->nmi", R, local)  # lever arms in lab
    pos = pose[:, None, :3, 3] + r
    vel = twist[:, None, :3] + np.cross(twist[:, None, 3:], r)
    return pos, vel


@dataclass(frozen=True)
class FootKinematics:
    """Kinematics of one foot over a trial.

    side: ``"left"`` or ``"right"``; time: ``(n,)`` [s];
    hindfoot_pose, toes_pose: ``(n, 4, 4)`` segment-to-``lab`` placements;
    hindfoot_twist, toes_twist: ``(n, 6)`` in ``lab`` at each frame origin [m/s, rad/s];
    points_local: ``(5, 3)`` unit positions in their parent frame (``UNIT_PARENT``) [m];
    positions, velocities: ``(n, 5, 3)`` unit trajectories in ``lab`` [m], [m/s].
    """

    side: str
    time: np.ndarray
    hindfoot_pose: np.ndarray
    toes_pose: np.ndarray
    hindfoot_twist: np.ndarray
    toes_twist: np.ndarray
    points_local: np.ndarray
    positions: np.ndarray = field(default=None)  # type: ignore[assignment]
    velocities: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        for a in (
            "time",
            "hindfoot_pose",
            "toes_pose",
            "hindfoot_twist",
            "toes_twist",
            "points_local",
        ):
            object.__setattr__(self, a, _ro(getattr(self, a)))
        if self.positions is None or self.velocities is None:
            pos, vel = self.unit_trajectories(self.points_local)
            object.__setattr__(self, "positions", pos)
            object.__setattr__(self, "velocities", vel)
        object.__setattr__(self, "positions", _ro(self.positions))
        object.__setattr__(self, "velocities", _ro(self.velocities))

    def parent_pose(self, unit: str) -> np.ndarray:
        return self.hindfoot_pose if UNIT_PARENT[unit] == "hindfoot" else self.toes_pose

    def parent_twist(self, unit: str) -> np.ndarray:
        return self.hindfoot_twist if UNIT_PARENT[unit] == "hindfoot" else self.toes_twist

    def unit_trajectories(self, points_local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``lab`` positions/velocities ``(n, 5, 3)`` of the units placed at ``points_local`` (5, 3)."""
        n = self.time.shape[0]
        pos = np.empty((n, len(UNITS), 3))
        vel = np.empty((n, len(UNITS), 3))
        for i, u in enumerate(UNITS):
            p, v = points_in_lab(self.parent_pose(u), self.parent_twist(u), points_local[i : i + 1])
            pos[:, i], vel[:, i] = p[:, 0], v[:, 0]
        return pos, vel

    def with_points(self, points_local: np.ndarray) -> FootKinematics:
        """The same foot motion with the units moved to ``points_local`` (5, 3) [m]."""
        return FootKinematics(
            self.side,
            self.time,
            self.hindfoot_pose,
            self.toes_pose,
            self.hindfoot_twist,
            self.toes_twist,
            points_local,
        )

    def window(self, t0: float, t1: float) -> FootKinematics:
        """Frames with ``t0 <= time <= t1``."""
        s = (self.time >= t0 - 1e-9) & (self.time <= t1 + 1e-9)
        return FootKinematics(
            self.side,
            self.time[s],
            self.hindfoot_pose[s],
            self.toes_pose[s],
            self.hindfoot_twist[s],
            self.toes_twist[s],
            self.points_local,
            self.positions[s],
            self.velocities[s],
        )


@dataclass(frozen=True)
class TrialKinematics:
    """Result of the kinematics pipeline for one trial.

    time: ``(n,)`` [s]; q: ``(n, nq)`` joint coordinates (see ``gc_ocp.model``);
    marker_rms: ``(n,)`` per-frame IK marker RMS [m]; feet: ``{"left": FootKinematics, "right": ...}``;
    cutoff_hz: marker low-pass cutoff used [Hz]; marker_names: markers used by IK.
    """

    trial_name: str
    time: np.ndarray
    q: np.ndarray
    marker_rms: np.ndarray
    feet: dict[str, FootKinematics]
    cutoff_hz: float
    marker_names: tuple[str, ...] = ()
    info: dict = field(default_factory=dict)
