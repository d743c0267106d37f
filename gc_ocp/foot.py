"""Foot kinematics and the sole layout: the interface between the body model and the contact model.

A foot has two rigid segments, ``hindfoot`` and ``toes`` (welded in the seed model). Contact units
sit on the sole, each a point fixed in its parent segment frame; its ``lab`` trajectory follows
from the parent's placement. Which units exist and where they hang is a :class:`SoleLayout`: the
seed's five units (:data:`SEED_LAYOUT`) are posterior lateral ``PL``, posterior medial ``PM``,
anterior lateral ``AL``, anterior medial ``AM`` (on the hindfoot) and toe tip ``TT`` (on the toes).
A denser sole is another layout, not a code change.

Everything here is time-first and SI: poses ``(n, 4, 4)``, twists ``(n, 6)`` = (linear velocity of
the frame origin, angular velocity), both expressed in ``lab`` (Pinocchio's LOCAL_WORLD_ALIGNED).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from gc_ocp.errors import ModelError

SEGMENTS: tuple[str, ...] = ("hindfoot", "toes")


@dataclass(frozen=True)
class SoleLayout:
    """The contact units of a foot: their names and parent segments (``"hindfoot"``/``"toes"``).

    The unit positions are not part of the layout: they are measured per subject and foot
    (``FootKinematics.points_local``, one row per unit in this order).
    """

    units: tuple[str, ...]
    parents: tuple[str, ...]

    def __post_init__(self) -> None:
        if len(self.units) != len(self.parents) or not self.units:
            raise ModelError(
                f"SoleLayout needs one parent per unit, but got {len(self.units)} units and "
                f"{len(self.parents)} parents"
            )
        if len(set(self.units)) != len(self.units):
            raise ModelError(f"SoleLayout unit names must be unique, but got {self.units}")
        bad = [p for p in self.parents if p not in SEGMENTS]
        if bad:
            raise ModelError(f"SoleLayout parents must be in {SEGMENTS}, but got {bad}")

    @property
    def n(self) -> int:
        return len(self.units)

    def parent(self, unit: str) -> str:
        return self.parents[self.index(unit)]

    def index(self, unit: str) -> int:
        try:
            return self.units.index(unit)
        except ValueError:
            raise ModelError(f'Unit "{unit}" is not in the sole layout {self.units}') from None

    def on(self, segment: str) -> tuple[int, ...]:
        """Indices of the units carried by ``segment``."""
        return tuple(i for i, p in enumerate(self.parents) if p == segment)


FOOT_ROLLS = ("chain", "level")
"""How a foot with two landmarks is rolled about them (:func:`~gc_ocp.kinematics.compute_kinematics`'s
``foot_roll``): as the body chain poses it, or level across."""

SEED_LAYOUT = SoleLayout(
    units=("PL", "PM", "AL", "AM", "TT"),
    parents=("hindfoot", "hindfoot", "hindfoot", "hindfoot", "toes"),
)
"""The seed report's five units (four on the hindfoot, the toe tip on the toes)."""

UNITS: tuple[str, ...] = SEED_LAYOUT.units
"""Unit names of :data:`SEED_LAYOUT` (the seed study and the marker-based sole placement)."""


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
class PoseNoise:
    """What the markers' white noise leaves in a foot's pose (measured per trial, see
    :mod:`gc_ocp.marker_noise`).

    cov: ``(6, 6)`` per-frame covariance of the hindfoot pose's error *before* the low-pass
    (translation of the hindfoot origin [m], rotation vector [rad]; hindfoot axes); rate [Hz],
    cutoff_hz [Hz], order: the zero-lag low-pass the kinematics went through; sigma_marker [m]:
    the markers' measured white noise it comes from."""

    cov: np.ndarray
    rate: float
    cutoff_hz: float
    order: int
    sigma_marker: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "cov", _ro(self.cov))
        if self.cov.shape != (6, 6):
            raise ModelError(f"PoseNoise.cov must be (6, 6), but got {self.cov.shape}")


@dataclass(frozen=True)
class FootKinematics:
    """Kinematics of one foot over a trial.

    side: ``"left"`` or ``"right"``; time: ``(n,)`` [s];
    hindfoot_pose, toes_pose: ``(n, 4, 4)`` segment-to-``lab`` placements;
    hindfoot_twist, toes_twist: ``(n, 6)`` in ``lab`` at each frame origin [m/s, rad/s];
    points_local: ``(m, 3)`` unit positions in their parent frame [m], one row per unit of ``layout``;
    positions, velocities: ``(n, m, 3)`` unit trajectories in ``lab`` [m], [m/s];
    layout: the units' names and parents (default: the seed's five units);
    pose_noise: what the markers' white noise leaves in the hindfoot's pose (None: not measured,
    or the markers do not fix the pose; the estimator then has the smooth correction only).
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
    layout: SoleLayout = SEED_LAYOUT
    pose_noise: PoseNoise | None = None

    def __post_init__(self) -> None:
        if np.shape(self.points_local) != (self.layout.n, 3):
            raise ModelError(
                f"FootKinematics.points_local must have shape ({self.layout.n}, 3) for the layout "
                f"{self.layout.units}, but got {np.shape(self.points_local)}"
            )
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
        return self.hindfoot_pose if self.layout.parent(unit) == "hindfoot" else self.toes_pose

    def parent_twist(self, unit: str) -> np.ndarray:
        return self.hindfoot_twist if self.layout.parent(unit) == "hindfoot" else self.toes_twist

    def points_in_hindfoot(self) -> np.ndarray:
        """``(m, 3)`` the units' positions in the hindfoot frame [m] at the middle frame (a unit
        on the toes carried there through the toes' placement): the lever arms through which an
        error of the hindfoot's pose moves each unit (``points_local`` holds a toe unit in the
        toes' frame, where its lever arm is shorter)."""
        k = self.time.shape[0] // 2
        H = self.hindfoot_pose[k]
        return (self.positions[k] - H[:3, 3]) @ H[:3, :3]

    def unit_trajectories(self, points_local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``lab`` positions/velocities ``(n, m, 3)`` of the units placed at ``points_local`` (m, 3)."""
        n = self.time.shape[0]
        pos = np.empty((n, self.layout.n, 3))
        vel = np.empty((n, self.layout.n, 3))
        for i, u in enumerate(self.layout.units):
            p, v = points_in_lab(self.parent_pose(u), self.parent_twist(u), points_local[i : i + 1])
            pos[:, i], vel[:, i] = p[:, 0], v[:, 0]
        return pos, vel

    def with_points(
        self, points_local: np.ndarray, layout: SoleLayout | None = None
    ) -> FootKinematics:
        """The same foot motion with the units moved to ``points_local`` (m, 3) [m] (and, when
        given, another ``layout`` of units)."""
        return replace(
            self,
            points_local=points_local,
            positions=None,
            velocities=None,
            layout=layout or self.layout,
        )

    def frames(self, keep: np.ndarray) -> FootKinematics:
        """The frames selected by ``keep`` (a boolean mask or indices over time)."""
        return replace(
            self,
            time=self.time[keep],
            hindfoot_pose=self.hindfoot_pose[keep],
            toes_pose=self.toes_pose[keep],
            hindfoot_twist=self.hindfoot_twist[keep],
            toes_twist=self.toes_twist[keep],
            positions=self.positions[keep],
            velocities=self.velocities[keep],
        )

    def window(self, t0: float, t1: float) -> FootKinematics:
        """Frames with ``t0 <= time <= t1`` [s]."""
        return self.frames((self.time >= t0 - 1e-9) & (self.time <= t1 + 1e-9))


@dataclass(frozen=True, repr=False)
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

    def __repr__(self) -> str:  # a notebook's view: what it is, not every array
        span = f"{self.time[0]:.3f}-{self.time[-1]:.3f} s" if len(self.time) else "no frames"
        return (
            f"TrialKinematics({self.trial_name!r}, {len(self.time)} frames {span}, "
            f"{self.q.shape[-1]} coordinates, feet {sorted(self.feet)}, marker low-pass "
            f"{self.cutoff_hz:g} Hz)"
        )
