"""Data types shared by every layer: a walking trial, its force plates and stances.

Conventions (README, *Conventions and decisions*):

* SI units inside the code (m, s, N, N·m, kg).
* Arrays are time-first: markers ``(n_frames, n_markers, 3)``, plate force ``(n_samples, 3)``.
* The ``lab`` frame is right-handed with **Z up** and **X the walking (anterior) direction**,
  Y pointing to the subject's left. Files in other conventions (OpenSim Y-up) are rotated on load.
* Plate forces are the ground reaction *on the subject* (vertical component positive), expressed
  in ``lab``; moments are about the plate's reference point (``Plate.reference_point``), in ``lab``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gc_ocp.errors import MarkerError
from gc_ocp.wrench import cop_from_wrench, transport_moment

GRAVITY = 9.81
"""Standard gravity used for body weight, in [m/s^2]."""

SIDES = ("left", "right")

ESTIMATED = "ESTIMATE"
"""How ``Trial.mass_source`` / ``height_source`` begin when the package estimated the value
(from the plates or the markers) rather than read it from a file or an argument: the one test
of "estimated" (:attr:`Trial.mass_estimated`, :attr:`Trial.height_estimated`)."""


def _estimated_text(source: str) -> str:
    """What a printed mass or height says of its ``source`` (``Trial.mass_source``,
    ``height_source``): " (estimated from the plates)" (or the markers) when the package
    estimated it (:data:`ESTIMATED`), nothing when a file or the user gave it."""
    if not source.startswith(ESTIMATED):
        return ""
    for words, what in (("force data", "the plates"), ("markers", "the markers")):
        if words in source:
            return f" (estimated from {what})"
    return " (estimated)"  # e.g. the mean of a subject's trials' estimates


def belt_velocity(speed: float) -> np.ndarray:
    """The velocity in ``lab`` [m/s] of a treadmill belt running at ``speed`` [m/s] (>= 0) under a
    subject walking along +X: ``(-speed, 0, 0)`` (zeros overground). The inverse is
    :attr:`Trial.belt_speed`."""
    return np.array([-float(speed), 0.0, 0.0])


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class Plate:
    """One force plate (or one per-side GRF channel set of an OpenSim MOT file).

    Attributes
    ----------
    name: e.g. ``"plate1"`` (C3D, 1-based like Vicon) or ``"grf_right"`` (MOT).
    time: sample times in [s], shape ``(n,)``.
    force: ground reaction on the subject in ``lab`` [N], shape ``(n, 3)``.
    moment: moment about ``reference_point`` in ``lab`` [N·m], shape ``(n, 3)``.
    reference_point: point about which ``moment`` is expressed, ``lab`` [m], shape ``(3,)``.
    reference_kind: ``"electrical_center"`` (C3D types 2/4: the transducer origin below the
        surface), ``"surface_center"`` (C3D types 1/3: the centre of the surface) or
        ``"lab_origin"`` (MOT).
    corners: plate surface corners in ``lab`` [m], shape ``(4, 3)``, or ``None`` when unknown.
    surface_height: height of the plate surface (lab Z) [m].
    plate_type: how the wrench was stored (``"C3D type 2"``, ``"MOT ground_force_1_*"``...).
    zero_offset: the unloaded offset removed on load, ``(6,)`` force [N] and moment [N·m] in
        ``lab`` (``None``: none removed).
    """

    name: str
    time: np.ndarray
    force: np.ndarray
    moment: np.ndarray
    reference_point: np.ndarray
    reference_kind: str
    corners: np.ndarray | None = None
    surface_height: float = 0.0
    plate_type: str = ""
    zero_offset: np.ndarray | None = None

    def __post_init__(self) -> None:
        for attr in ("time", "force", "moment", "reference_point"):
            object.__setattr__(self, attr, _readonly(getattr(self, attr)))
        for attr in ("corners", "zero_offset"):
            if getattr(self, attr) is not None:
                object.__setattr__(self, attr, _readonly(getattr(self, attr)))

    @property
    def rate(self) -> float:
        """Sampling rate in [Hz]."""
        return float(1.0 / np.median(np.diff(self.time)))

    def cop(self, min_vertical: float = 20.0) -> np.ndarray:
        """Centre of pressure on the plate surface in ``lab`` [m], NaN where Fz < ``min_vertical`` [N]."""
        return cop_from_wrench(
            self.force, self.moment, self.reference_point, self.surface_height, min_vertical
        )


@dataclass(frozen=True)
class Stance:
    """One foot contact on one plate.

    ``t_on``/``t_off`` in [s] are where the vertical force crosses the detection threshold.
    ``reference_point`` (``lab``, [m]) is where the measured and modelled wrenches of this stance
    are compared: the plate's electrical centre for C3D, the floor point under the stance's mean
    COP for MOT files (stated in ``reference_kind``). ``heading`` [rad]: the walking direction
    during the stance in ``lab``, counter-clockwise from +X (NaN when unknown); a path with turns
    has stances with other headings than 0.
    """

    side: str
    plate: int
    t_on: float
    t_off: float
    reference_point: np.ndarray
    reference_kind: str
    label: str = ""
    heading: float = float("nan")

    def __post_init__(self) -> None:
        object.__setattr__(self, "reference_point", _readonly(self.reference_point))
        if not self.label:
            object.__setattr__(self, "label", f"{self.side}@{self.t_on:.3f}s")

    @property
    def duration(self) -> float:
        return self.t_off - self.t_on


@dataclass(frozen=True)
class ExcludedStance:
    side: str
    plate: int
    t_on: float
    t_off: float
    reason: str


@dataclass(frozen=True, repr=False)
class Trial:
    """A walking trial: markers, force plates, subject, stances.

    Attributes
    ----------
    source: path of the marker file (C3D or TRC).
    marker_names: labels of the columns of ``markers``.
    markers: marker positions in ``lab`` [m], ``(n_frames, n_markers, 3)``; NaN where occluded.
    marker_time: frame times [s], ``(n_frames,)``.
    plates: force plates.
    mass: subject mass [kg]; ``height``: subject height [m] (``None`` if unknown).
    stances: usable stances, sorted by time; ``excluded_stances``: rejected ones with the reason.
    belt_velocity: treadmill belt velocity in ``lab`` [m/s] (zeros overground).
    lab_rotation: rotation applied on load, file axes -> ``lab`` (3x3).
    grf_source: path of the ground-reaction file (MOT/STO) when separate from ``source``.
    mass_source, height_source: where ``mass``/``height`` came from (file parameter or argument).
    load_notes: what the loader decided (offsets removed, rotation, GRF column sides...).
    contact_threshold: [N] the vertical force above which a plate counted as loaded when the
        stances were detected (below it the foot is off by that definition).
    marker_filled: ``(n_frames, n_markers)`` bool, the samples of ``markers`` the loader
        interpolated (gaps of at most :data:`gc_ocp.gaps.MAX_GAP_FILL`; not seen by the
        cameras: the markers' noise is measured without them); None: not known (also when
        ``markers`` is replaced by an array of another shape).
    """

    source: Path
    marker_names: tuple[str, ...]
    markers: np.ndarray
    marker_time: np.ndarray
    plates: tuple[Plate, ...]
    mass: float
    height: float | None
    stances: tuple[Stance, ...]
    excluded_stances: tuple[ExcludedStance, ...] = ()
    belt_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    lab_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    grf_source: Path | None = None
    mass_source: str = ""
    height_source: str = ""
    load_notes: tuple[str, ...] = ()
    contact_threshold: float = 20.0
    marker_filled: np.ndarray | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "load_notes", tuple(self.load_notes))
        for attr in ("markers", "marker_time", "belt_velocity", "lab_rotation"):
            object.__setattr__(self, attr, _readonly(getattr(self, attr)))
        filled = self.marker_filled
        if filled is not None:
            filled = np.array(filled, dtype=bool, copy=True)
            filled.setflags(write=False)
            ok = filled.shape == np.shape(self.markers)[:2]
            object.__setattr__(self, "marker_filled", filled if ok else None)
        object.__setattr__(self, "marker_names", tuple(self.marker_names))

    def __repr__(self) -> str:  # a notebook's view: what it is, not every array
        return (
            f"Trial({str(self.source)!r}, {len(self.marker_names)} markers at "
            f"{self.marker_rate:.0f} Hz, {len(self.plates)} plates, {len(self.stances)} stances "
            f"({', '.join(s.label for s in self.stances)}), mass {self.mass:.1f} kg"
            f"{_estimated_text(self.mass_source)}"
            + (
                ""
                if self.height is None
                else f", height {self.height:.2f} m{_estimated_text(self.height_source)}"
            )
            + ")"
        )

    @property
    def marker_rate(self) -> float:
        """Marker sampling rate in [Hz]."""
        return float(1.0 / np.median(np.diff(self.marker_time)))

    @property
    def floor_height(self) -> float:
        """Height of the floor in ``lab`` Z [m]: the mean ``surface_height`` of the plates, 0 without
        plates. The one floor used for sole-height calibration, height estimation and plots."""
        return float(np.mean([p.surface_height for p in self.plates])) if self.plates else 0.0

    @property
    def body_weight(self) -> float:
        """Body weight [N] = mass * g."""
        return self.mass * GRAVITY

    @property
    def belt_speed(self) -> float:
        """Treadmill belt speed [m/s] (0 overground): see :func:`belt_velocity`."""
        return float(-self.belt_velocity[0])

    @property
    def mass_estimated(self) -> bool:
        """The mass is the package's estimate (:data:`ESTIMATED`), not a file's or the user's."""
        return self.mass_source.startswith(ESTIMATED)

    @property
    def height_estimated(self) -> bool:
        """The height is the package's estimate (:data:`ESTIMATED`), not a file's or the user's."""
        return self.height_source.startswith(ESTIMATED)

    @property
    def name(self) -> str:
        return Path(self.source).stem

    def marker(self, name: str) -> np.ndarray:
        """Trajectory ``(n_frames, 3)`` of one marker, in ``lab`` [m]."""
        try:
            return self.markers[:, self.marker_names.index(name)]
        except ValueError:
            raise MarkerError(
                f'Marker "{name}" is not in {self.source}; markers found: {list(self.marker_names)}'
            ) from None

    def stance_wrench(self, stance: Stance, times: np.ndarray) -> np.ndarray:
        """Measured wrench of ``stance`` at ``times`` [s]: ``(n, 6)`` = force [N], moment [N·m]
        about ``stance.reference_point``, in ``lab``. Linear interpolation of the raw plate
        samples, at the plate's own times or where a point value is wanted; the wrench a fit
        compares at its frames (other loads zeroed, low-passed for the frames' rate) is
        :func:`gc_ocp.stance.frame_wrench`."""
        plate = self.plates[stance.plate]
        pt, wrench = plate.time, np.hstack([plate.force, plate.moment])
        times = np.asarray(times, float)
        f = np.column_stack([np.interp(times, pt, wrench[:, i]) for i in range(3)])
        m = np.column_stack([np.interp(times, pt, wrench[:, 3 + i]) for i in range(3)])
        m = transport_moment(f, m, plate.reference_point, stance.reference_point)
        return np.hstack([f, m])
