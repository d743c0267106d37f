"""Marker sets: which skin marker sits on which model segment, where, and how much it weighs.

A marker set is a TOML file (format in ``docs/markersets.md``); the shipped ones live in
``gc_ocp/data/markersets``: ``plugingait``, ``rajagopal``,
``gait2392``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the tomli backport has the same API
    import tomli as tomllib

import dataclasses
import warnings

from gc_ocp.errors import InputError, MarkerError
from gc_ocp.model.markerdefs import FOOT_SEGMENTS, MARKER_SEGMENTS, MarkerDef, MarkerSet
from gc_ocp.model.recognition import (
    markerset_from_recognition,
    recognise_landmarks,
    shipped_mapping,
)
from gc_ocp.text import read_utf8
from gc_ocp.values import number

__all__ = [
    "FOOT_SEGMENTS",
    "MARKERSET_DIR",
    "MarkerDef",
    "MarkerSet",
    "available_markersets",
    "detect_markerset",
    "load_markerset",
]

MARKERSET_DIR = Path(__file__).resolve().parent.parent / "data" / "markersets"


def available_markersets() -> list[str]:
    """Names of the shipped marker sets."""
    return sorted(p.stem for p in MARKERSET_DIR.glob("*.toml"))


def markerset_path(name_or_path: str | Path) -> Path:
    """The file of a shipped marker set's name (``"plugingait"``) or of a TOML path (which may
    not exist)."""
    p = Path(name_or_path)
    return p if p.suffix.lower() == ".toml" else MARKERSET_DIR / f"{name_or_path}.toml"


def load_markerset(name_or_path: str | Path) -> MarkerSet:
    """Load a shipped marker set by name (``"plugingait"``...) or any TOML file by path."""
    p = markerset_path(name_or_path)
    given = Path(name_or_path)
    if not p.exists() and given.exists():  # a path, not of a .toml file: "not found" misleads
        what = "a folder" if given.is_dir() else f"a {given.suffix or 'suffix-less'} file"
        raise MarkerError(
            f'Marker set "{name_or_path}" is {what}, not a marker set; give a shipped marker '
            f"set's name {available_markersets()} or a .toml file (format: docs/markersets.md)"
            "; a static trial is given with --static."
        )
    if not p.exists():
        raise MarkerError(
            f'Marker set "{name_or_path}" not found; available marker sets: {available_markersets()} '
            f"(in {MARKERSET_DIR}), or give the path of a .toml file (format: docs/markersets.md)."
        )
    try:
        data = tomllib.loads(read_utf8(p, "Marker set file"))
    except tomllib.TOMLDecodeError as e:
        raise MarkerError(f"Marker set file {p} is not valid TOML: {e}") from None
    table = data.get("markers", {})
    if not isinstance(table, dict):
        raise MarkerError(
            f"Marker set file {p}: [markers] must be a table of marker tables, not {table!r:.40} "
            "(format: docs/markersets.md)."
        )
    markers = {}
    for label, d in table.items():
        if not isinstance(d, dict):
            raise MarkerError(
                f'Marker "{label}" in {p} is {d!r:.40}, not a table with segment and position, '
                'e.g. "LHEE" = {segment = "hindfoot_l", position = [-0.03, 0.0, 0.05]} '
                "(format: docs/markersets.md)."
            )
        try:
            pos = np.array(d["position"], dtype=float)
            seg = str(d["segment"])
            weight = number(d.get("weight", 1.0), "weight", "relative units", text=False)
        except KeyError as e:
            raise MarkerError(
                f'Marker "{label}" in {p} has no {e.args[0]}; each marker needs '
                "segment and position"
            ) from None
        except (TypeError, ValueError) as e:  # (an InputError of the weight's is a ValueError)
            raise MarkerError(
                f'Marker "{label}" in {p}: {e}; position is three numbers [m] in the segment\'s '
                "frame, weight a number (format: docs/markersets.md)."
            ) from None
        if pos.shape != (3,) or not np.isfinite(pos).all():
            raise MarkerError(
                f'Marker "{label}" in {p}: position must be 3 finite numbers [m], but got '
                f"{d['position']!r:.60}"
            )
        if weight < 0:
            raise MarkerError(
                f'Marker "{label}" in {p}: weight {weight:g} must be >= 0 (a relative IK weight; '
                "0 leaves the marker out of the IK)."
            )
        markers[label] = (seg, pos, weight, d)
    try:
        height = number(data.get("reference_height", 1.70), "reference_height", "m", text=False)
    except InputError as e:
        raise MarkerError(f"Marker set file {p}: {e}.") from None
    if not 0.5 <= height <= 2.5:
        raise MarkerError(
            f"Marker set file {p}: reference_height {height:g} is not a height in metres "
            "(0.5-2.5): the marker positions are scaled from it; give it in metres."
        )
    for label, (seg, pos, weight, d) in markers.items():
        if seg not in MARKER_SEGMENTS:
            raise MarkerError(
                f'Marker "{label}" in {p}: segment "{seg}" is not a segment of the model; '
                f"choose one of {', '.join(MARKER_SEGMENTS)} (docs/markersets.md)."
            )
        if np.linalg.norm(pos) > height:
            raise MarkerError(
                f'Marker "{label}" in {p}: position {pos.tolist()} is {np.linalg.norm(pos):g} m '
                f"from the origin of {seg}, farther than the subject is tall (reference_height "
                f"{height:g} m): give positions in metres (a file in mm: divide by 1000)."
            )
        pos.setflags(write=False)
        markers[label] = MarkerDef(
            label,
            seg,
            pos,
            weight,
            str(d.get("role", "")),
            bool(d.get("cluster", False)),
        )
    return MarkerSet(str(data.get("name", p.stem)), p, height, markers)


def detect_markerset(marker_names, markers=None, source="the trial") -> MarkerSet:
    """The marker set for a trial when none is given (``markers`` ``(n, m, 3)``: optional data,
    to ignore empty columns and resolve duplicate labels; ``source`` is named in messages).

    A shipped TOML set is used when it matches the trial exactly: all its foot markers are in the
    trial (not empty), no label is duplicated, and every label the landmark vocabulary
    recognises (landmark or cluster) is in the set (recognition would add nothing; this keeps the
    shipped sets' tuned positions, e.g. Plug-in Gait's LANK on the hindfoot). Among several, the
    one sharing the most labels. Otherwise the set is built from the recognised landmarks
    (:func:`gc_ocp.model.recognition.recognise_landmarks`), which raises :class:`MarkerError`
    (naming ``source``, the markers found and what is missing) when a foot cannot be tracked.
    The mapping used is in the returned set's ``recognition``.
    """
    labels = [str(x) for x in marker_names]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rec = recognise_landmarks(labels, markers, source, require_feet=False)
    present = {m.label for m in rec.matches}
    if markers is None:
        nonempty = set(labels)
    else:
        seen = np.isfinite(np.asarray(markers)).all(axis=2).any(axis=0)
        nonempty = {lab for lab, ok in zip(labels, seen, strict=True) if ok}
    unique = len(set(labels)) == len(labels)
    best, best_n = None, 0
    for name in available_markersets():
        ms = load_markerset(name)
        feet = [m.name for s in ("left", "right") for m in ms.foot_markers(s)]
        if not unique or not all(f in nonempty for f in feet) or not present <= set(ms.markers):
            continue
        n = len(nonempty & set(ms.markers))
        if n > best_n:
            best, best_n = ms, n
    if best is not None:
        return dataclasses.replace(best, recognition=shipped_mapping(best, labels, markers, source))
    return markerset_from_recognition(recognise_landmarks(labels, markers, source))
