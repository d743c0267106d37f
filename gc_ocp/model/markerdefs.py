"""Marker-set data types: :class:`MarkerDef` (one marker on a segment) and :class:`MarkerSet`.

Shared by the TOML marker sets (:mod:`gc_ocp.model.markerset`) and the sets built from
recognised anatomical landmarks (:mod:`gc_ocp.model.landmarks`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gc_ocp.errors import MarkerError

FOOT_SEGMENTS = ("hindfoot", "toes")
MARKER_SEGMENTS = ("pelvis", "torso") + tuple(
    f"{seg}_{side}"
    for seg in ("thigh", "shank", "hindfoot", "toes", "upper_arm", "forearm")
    for side in "lr"
)
"""The model segments a marker may sit on (``docs/markersets.md``); the model's other frames
(joints, sole points) move with these and are no marker's."""


@dataclass(frozen=True)
class MarkerDef:
    """One marker: ``segment`` frame name, ``position`` [m] in it (reference height), IK ``weight``,
    optional foot ``role`` (``heel``, ``toe``, ``metatarsal_lateral``...), ``cluster`` (a tracking
    marker with no anatomical meaning: its nominal position is a guess, registered before use)."""

    name: str
    segment: str
    position: np.ndarray
    weight: float = 1.0
    role: str = ""
    cluster: bool = False

    @property
    def side(self) -> str | None:
        if self.segment.endswith("_l"):
            return "left"
        if self.segment.endswith("_r"):
            return "right"
        return None

    @property
    def is_foot(self) -> bool:
        return self.segment.rsplit("_", 1)[0] in FOOT_SEGMENTS


@dataclass(frozen=True)
class MarkerSet:
    """A loaded marker set; ``markers`` keyed by label, positions for ``reference_height`` [m].

    columns: for a set built from a trial's labels (:mod:`gc_ocp.model.landmarks`), the trial
    column of each marker key (keys ``label#k`` address the k-th column of a duplicated label);
    ``None``: markers are found by label. recognition: the label -> landmark -> segment mapping
    as plain data (:meth:`gc_ocp.model.recognition.Recognition.to_json`), or ``None``.
    """

    name: str
    source: Path
    reference_height: float
    markers: dict[str, MarkerDef]
    columns: dict[str, int] | None = None
    recognition: dict | None = field(default=None, compare=False)

    def positions(self, height: float | None = None) -> dict[str, np.ndarray]:
        """Nominal positions [m] scaled to a subject of ``height`` [m] (unscaled if ``None``)."""
        k = 1.0 if height is None else height / self.reference_height
        return {n: k * m.position for n, m in self.markers.items()}

    def foot_markers(self, side: str) -> list[MarkerDef]:
        return [m for m in self.markers.values() if m.is_foot and m.side == side]

    def by_role(self, side: str, role: str) -> MarkerDef | None:
        for m in self.markers.values():
            if m.side == side and m.role == role:
                return m
        return None

    def select(self, marker_names, source: str | Path = "the trial") -> list[str]:
        """Markers of the set present in ``marker_names`` (others of the trial are ignored).

        Raises :class:`MarkerError` if a foot marker of the set is missing from the trial or if a
        foot cannot be tracked: it needs >= 3 non-collinear hindfoot markers, or 2 foot markers
        plus a malleolus on the shank (role ``ankle_*``; the tracked shank then fixes the 2-DOF
        ankle of the model).
        """
        present = set(marker_names)
        if self.columns is not None:
            present |= set(self.columns)
        for side in ("left", "right"):
            feet = self.foot_markers(side)
            missing = [m.name for m in feet if m.name not in present]
            if missing:
                raise MarkerError(
                    f'Foot marker "{missing[0]}" of marker set "{self.name}" ({self.source}) is missing '
                    f"from {source} (missing: {missing}). Foot markers define the sole kinematics: "
                    f"label it in the file, or pass a marker set without it (copy {self.source} and "
                    "remove the line), keeping >= 3 non-collinear hindfoot markers per foot (or 2 "
                    "and a malleolus on the shank)."
                )
            hf = np.array([m.position for m in feet if m.segment.startswith("hindfoot")])
            ankle = [
                m
                for m in self.markers.values()
                if m.side == side and m.role.startswith("ankle") and not m.is_foot
            ]
            if len(feet) >= 2 and ankle:
                continue
            if len(hf) < 3 or np.linalg.matrix_rank(hf[1:] - hf[0], tol=1e-3) < 2:
                raise MarkerError(
                    f'Marker set "{self.name}" ({self.source}) has fewer than 3 non-collinear markers on '
                    f"the {side} hindfoot: {[m.name for m in feet]}; add one (e.g. the lateral malleolus "
                    "attached to the hindfoot), or a malleolus on the shank with 2 foot markers."
                )
        return [n for n in self.markers if n in set(marker_names)]

    def select_columns(
        self, marker_names, source: str | Path = "the trial", markers=None
    ) -> tuple[list[str], list[int]]:
        """Marker keys of the set in the trial and their columns in ``marker_names`` (the
        ``columns`` of a recognised set; else the first column with the label). Checks the feet
        as :meth:`select`; with the trial's ``markers`` ``(n, m, 3)``, also that no foot marker's
        column is empty (no position in any frame: the foot would be posed without it)."""
        names = list(marker_names)
        self.select(names, source)
        if markers is not None and self.columns is None:
            seen = np.isfinite(np.asarray(markers, dtype=float)).all(axis=2).any(axis=0)
            empty = [
                m.name
                for side in ("left", "right")
                for m in self.foot_markers(side)
                if m.name in names and not seen[names.index(m.name)]
            ]
            if empty:
                raise MarkerError(
                    f'Foot marker "{empty[0]}" of marker set "{self.name}" ({self.source}) has no '
                    f"position in any frame of {source} (empty columns: {empty}): the foot would "
                    "be posed without it. Check its labelling in the file, or pass a marker set "
                    f"without it (copy {self.source} and remove the line), keeping >= 3 "
                    "non-collinear hindfoot markers per foot (or 2 and a malleolus on the shank)."
                )
        if self.columns is None:
            keys = [n for n in self.markers if n in set(names)]
            return keys, [names.index(n) for n in keys]
        keys = [n for n in self.markers if n in self.columns]
        return keys, [self.columns[n] for n in keys]
