"""Marker recognition by anatomical landmark: any lab's labels -> a :class:`MarkerSet`.

The vocabulary and the classification of one label are :mod:`gc_ocp.model.landmarks`. The vocabulary (``gc_ocp/data/landmarks.toml``) lists anatomical landmarks (calcaneus, metatarsal
heads, malleoli, epicondyles, ASIS ...), the names the major conventions give them (Plug-in Gait,
Helen Hayes, CAST/Visual3D, BTS, IOR/Rizzoli, Oxford foot, OpenSim, OpenCap, Camargo) and where
they sit on the gait model; also tracking clusters and patterns of computed (virtual) points.

A label is split into side and core: ``LHEE``, ``L.Heel``, ``l_heel``, ``Left Heel``, ``Heel_L``,
``HeelL`` all give (left, ``heel``); the core is compared ignoring case and the separators
``. _ - space``. Rules, in order (full text in ``docs/data_formats.md``):

1. Empty columns (never visible) are ignored.
2. A label whose core is a landmark name (sided landmarks need a side, midline ones none) is
   that landmark; a cluster name or pattern makes a tracking marker (``cluster=True``); a label
   matching a virtual pattern (joint centres, model outputs, ``*3``, ``HeelGround``) is never a
   marker; anything else is ignored as unknown.
3. One label on two distinct points (duplicate labels): if the landmark has a medial
   counterpart not otherwise labelled (knee, ankle, 5th/1st metatarsal head), the point farther
   from the pelvis mid-line is the lateral landmark, the other the medial one; otherwise the
   point visible in more frames is kept. Both cases are noted.
4. Two different labels for one landmark and side: the one visible in more frames is kept, the
   other ignored, with a warning naming both.
5. Each foot must be trackable: >= 3 non-collinear foot landmarks, or 2 foot landmarks plus a
   malleolus (the tracked shank then fixes the 2-DOF ankle). Otherwise :class:`MarkerError`
   names the file, the markers found and what is missing.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gc_ocp.errors import MarkerError
from gc_ocp.geometry import off_line
from gc_ocp.model.landmarks import (
    MIN_FOOT_LEVER,
    TOES_IN_HINDFOOT,
    Landmark,
    classify,
    vocabulary,
)
from gc_ocp.model.markerdefs import MarkerDef, MarkerSet


@dataclass(frozen=True)
class LandmarkMatch:
    """One trial column used as a marker: ``key`` (unique marker-set key: the label, or
    ``label#k`` for the k-th column carrying the same label), ``landmark`` (vocabulary key,
    ``cluster:<segment>`` for a tracking marker), model ``segment``, foot ``role``, ``note``."""

    label: str
    column: int
    key: str
    landmark: str
    side: str | None
    segment: str
    role: str
    cluster: bool
    note: str = ""

    def to_json(self) -> dict:
        return {
            "label": self.label,
            "column": self.column,
            "marker": self.key,
            "landmark": self.landmark,
            "side": self.side,
            "segment": self.segment,
            "role": self.role,
            "cluster": self.cluster,
            "note": self.note,
        }


@dataclass(frozen=True)
class Recognition:
    """What :func:`recognise_landmarks` found: the matches, the ignored columns
    ``(label, column, reason)``, notes (decisions) and warnings (ambiguities)."""

    source: str
    matches: tuple[LandmarkMatch, ...]
    ignored: tuple[tuple[str, int, str], ...]
    notes: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    markerset_name: str = "landmarks"

    def foot(self, side: str) -> list[LandmarkMatch]:
        v = vocabulary()
        return [
            m
            for m in self.matches
            if m.side == side and not m.cluster and v.landmarks[m.landmark].is_foot
        ]

    def to_json(self) -> dict:
        """Plain data: label -> landmark -> segment, the ignored labels and the decisions."""
        return {
            "source": self.source,
            "markerset": self.markerset_name,
            "markers": [m.to_json() for m in self.matches],
            "ignored": [{"label": a, "column": c, "reason": r} for a, c, r in self.ignored],
            "notes": list(self.notes),
            "warnings": list(self.warnings),
        }


def label_key(labels, col: int) -> str:
    """The name of column ``col`` among ``labels``: its label for the label's first column, and
    ``label#k`` for its k-th (a file that uses one label twice: ``LANK``, ``LANK#2``)."""
    k = list(labels[:col]).count(labels[col])
    return labels[col] if k == 0 else f"{labels[col]}#{k + 1}"


def format_mapping(mapping: dict) -> str:
    """A readable table of a :meth:`Recognition.to_json` mapping (for the CLI)."""
    lines = [f"markers of {mapping['source']} (marker set: {mapping['markerset']}):"]
    for m in mapping["markers"]:
        what = "cluster" if m["cluster"] else (m["landmark"] or "-")
        extra = f"  [{m['note']}]" if m["note"] else ""
        lines.append(f"  {m['marker']:<16} -> {what:<20} on {m['segment']}{extra}")
    ign = mapping["ignored"]
    if ign:
        reasons: dict[str, list[str]] = {}
        for d in ign:
            reasons.setdefault(d["reason"].split(":")[0], []).append(d["label"])
        for r, labels in reasons.items():
            shown = ", ".join(labels[:12]) + (f" ... ({len(labels)})" if len(labels) > 12 else "")
            lines.append(f"  ignored ({r}): {shown}")
    lines += [f"  note: {n}" for n in mapping["notes"]]
    lines += [f"  warning: {w}" for w in mapping["warnings"]]
    return "\n".join(lines)


def _present(markers: np.ndarray | None, column: int) -> int:
    """Number of frames in which column ``column`` is visible (all if no data)."""
    if markers is None:
        return 1
    return int(np.isfinite(markers[:, column]).all(axis=1).sum())


def _midline(
    markers: np.ndarray | None, chosen: dict[tuple[str, str | None], int]
) -> tuple[np.ndarray, np.ndarray] | None:
    """Per-frame pelvis mid-point and unit left direction ``(n, 3)`` from a left/right pair of
    ASIS (else PSIS), or ``None``."""
    if markers is None:
        return None
    for key in ("asis", "psis"):
        if (key, "left") in chosen and (key, "right") in chosen:
            a = markers[:, chosen[(key, "left")]]
            b = markers[:, chosen[(key, "right")]]
            d = a - b
            n = np.linalg.norm(d, axis=1, keepdims=True)
            with np.errstate(invalid="ignore", divide="ignore"):
                return 0.5 * (a + b), d / n
    return None


def _lateral_offset(
    markers: np.ndarray, column: int, mid: tuple[np.ndarray, np.ndarray], side: str
) -> float:
    """Median distance [m] of a point to the lab's pelvis mid-plane, positive towards ``side``."""
    c, e = mid
    d = np.einsum("ij,ij->i", markers[:, column] - c, e) * (1.0 if side == "left" else -1.0)
    d = d[np.isfinite(d)]
    return float(np.median(d)) if d.size else float("nan")


def recognise_landmarks(
    labels,
    markers: np.ndarray | None = None,
    source: str | Path = "the trial",
    *,
    require_feet: bool = True,
) -> Recognition:
    """Recognise the anatomical landmarks among a trial's marker ``labels``.

    labels: the trial's marker labels (duplicates allowed); markers: ``(n, m, 3)`` positions [m]
    in the same column order (NaN = missing), used to drop empty columns and to resolve
    duplicate labels (``None``: names only); source: file named in messages.
    require_feet: raise :class:`MarkerError` if a foot cannot be tracked (see the module rules).
    Issues a ``UserWarning`` for each ambiguity (two labels for one landmark).
    """
    v = vocabulary()
    labels = [str(x) for x in labels]
    ignored: list[tuple[str, int, str]] = []
    notes: list[str] = []
    warns: list[str] = []
    groups: dict[tuple[str, str | None], list[int]] = {}
    clusters: list[tuple[int, str, str | None]] = []
    for i, lab in enumerate(labels):
        if markers is not None and _present(markers, i) == 0:
            ignored.append((lab, i, "empty: no frame with this marker"))
            continue
        kind, key, side = classify(lab, v)
        if kind == "landmark":
            groups.setdefault((key, side), []).append(i)
        elif kind == "cluster":
            clusters.append((i, key, side))
        elif kind == "virtual":
            ignored.append((lab, i, "virtual: a computed point or model output, not a marker"))
        else:
            ignored.append((lab, i, "unknown: not in the landmark vocabulary"))

    chosen: dict[tuple[str, str | None], int] = {}
    why: dict[int, str] = {}
    # 1. unique matches first (the pelvis pair is needed to resolve duplicates)
    for g, cols in groups.items():
        if len(cols) == 1:
            chosen[g] = cols[0]
    mid = _midline(markers, chosen)
    # 2. one label on several points
    for (key, side), cols in groups.items():
        if len(cols) == 1:
            continue
        same = len({labels[c] for c in cols}) == 1
        medial = v.landmarks[key].medial
        if (
            same
            and len(cols) == 2
            and medial
            and (medial, side) not in groups
            and mid is not None
            and side is not None
        ):
            off = [_lateral_offset(markers, c, mid, side) for c in cols]
            if all(np.isfinite(off)):
                lat, med = (cols[0], cols[1]) if off[0] >= off[1] else (cols[1], cols[0])
                chosen[(key, side)] = lat
                chosen[(medial, side)] = med
                k = [cols.index(lat) + 1, cols.index(med) + 1]
                msg = (
                    f'label "{labels[cols[0]]}" is on two points: occurrence {k[0]} '
                    f"({max(off) * 1e3:.0f} mm from the pelvis mid-line) taken as {key}, "
                    f"occurrence {k[1]} ({min(off) * 1e3:.0f} mm) as {medial}"
                )
                notes.append(msg)
                why[lat] = why[med] = "duplicate label: lateral/medial by distance to the mid-line"
                continue
        # keep the most visible one
        best = max(cols, key=lambda c: (_present(markers, c), -c))
        chosen[(key, side)] = best
        rest = [c for c in cols if c != best]
        names = [f'"{labels[c]}" (column {c})' for c in cols]
        if same:
            msg = (
                f'label "{labels[best]}" appears {len(cols)} times for {key}: kept column {best} '
                f"(visible in the most frames), ignored columns {rest}"
            )
            notes.append(msg)
        else:
            msg = (
                f"{len(cols)} labels for the {side + ' ' if side else ''}{key}: "
                f'{", ".join(names)}; kept "{labels[best]}" (visible in the most frames). '
                "Pass a marker set (--markerset FILE) to choose otherwise."
            )
            warns.append(msg)
            warnings.warn(f"{source}: {msg}", UserWarning, stacklevel=2)
        for c in rest:
            ignored.append((labels[c], c, f"conflict: another label was kept for {key}"))

    def key_of(col: int) -> str:
        return label_key(labels, col)

    matches = []
    for (key, side), col in chosen.items():
        lm = v.landmarks[key]
        matches.append(
            LandmarkMatch(
                labels[col],
                col,
                key_of(col),
                key,
                side,
                lm.side_segment(side),
                lm.role,
                False,
                why.get(col, ""),
            )
        )
    for col, key, side in clusters:
        lm = v.landmarks[key]
        matches.append(
            LandmarkMatch(labels[col], col, key_of(col), key, side, lm.side_segment(side), "", True)
        )
    matches.sort(key=lambda m: m.column)
    ignored.sort(key=lambda x: x[1])
    rec = Recognition(str(source), tuple(matches), tuple(ignored), tuple(notes), tuple(warns))
    if require_feet:
        for side in ("left", "right"):
            problem = foot_problem(rec, side)
            if problem:
                found = [f"{m.label}={m.landmark}" for m in rec.matches if m.side == side]
                empty = [
                    lab
                    for lab, _, why in ignored
                    if why.startswith("empty") and _foot_landmark_of(lab, side, v)
                ]
                if empty:
                    problem += (
                        f" (the file has {', '.join(empty)} but no position of them in any "
                        f"frame: empty columns)"
                    )
                raise MarkerError(
                    f"Cannot track the {side} foot of {source}: {problem}. {side.capitalize()} "
                    f"markers recognised: {found or 'none'}; all labels: {labels[:40]}"
                    f"{' ...' if len(labels) > 40 else ''}. Each foot needs 3 non-collinear "
                    "foot landmarks (heel/calcaneus, 1st/2nd/5th metatarsal head, toe tip, "
                    "midfoot), or 2 of them plus the lateral or medial malleolus. Label them in "
                    "the file, or give a marker-set TOML (--markerset FILE, docs/markersets.md)."
                )
    return rec


def _foot_landmark_of(label: str, side: str, v) -> bool:
    """Whether ``label`` names a landmark of the ``side`` foot (or its malleoli)."""
    kind, key, lab_side = classify(label, v)
    if kind != "landmark" or lab_side != side:
        return False
    lm = v.landmarks[key]
    return lm.is_foot or bool(lm.role)


def _foot_point(lm: Landmark) -> np.ndarray:
    p = np.array(lm.position, dtype=float)
    return p + TOES_IN_HINDFOOT if lm.segment == "toes" else p


def foot_problem(rec: Recognition, side: str) -> str:
    """Why the ``side`` foot cannot be tracked from the recognised landmarks ("" if it can)."""
    v = vocabulary()
    foot = rec.foot(side)
    pts = np.array([_foot_point(v.landmarks[m.landmark]) for m in foot]).reshape(-1, 3)
    ankle = [m for m in rec.matches if m.side == side and m.role.startswith("ankle")]
    if len(foot) >= 3 and off_line(pts) >= MIN_FOOT_LEVER:
        return ""
    if len(foot) >= 2 and ankle:
        return ""
    have = [m.landmark for m in foot]
    if not foot:
        return "no foot landmark found"
    if len(foot) < 2:
        return f"only one foot landmark ({have[0]})" + ("" if ankle else " and no malleolus")
    return f"the foot landmarks {have} are collinear and there is no malleolus"


def markerset_from_recognition(rec: Recognition) -> MarkerSet:
    """The marker set built from recognised landmarks: keys = marker keys (``label`` or
    ``label#k``), ``columns`` = their trial columns, ``recognition`` = the mapping."""
    v = vocabulary()
    markers = {}
    columns = {}
    for m in rec.matches:
        lm = v.landmarks[m.landmark]
        pos = lm.side_position(m.side)
        pos.setflags(write=False)
        markers[m.key] = MarkerDef(m.key, m.segment, pos, lm.weight, lm.role, lm.cluster)
        columns[m.key] = m.column
    return MarkerSet(
        "landmarks",
        v.source,
        v.reference_height,
        markers,
        columns=columns,
        recognition=rec.to_json(),
    )


def shipped_mapping(ms: MarkerSet, labels, markers: np.ndarray | None, source) -> dict:
    """The mapping (as :meth:`Recognition.to_json`) of a TOML marker set on a trial's labels:
    each set marker present, its landmark by the vocabulary (``""`` if not in it)."""
    v = vocabulary()
    labels = list(labels)
    out, ignored = [], []
    for i, lab in enumerate(labels):
        d = ms.markers.get(lab)
        if d is None or labels.index(lab) != i:
            ignored.append((lab, i, f'not in marker set "{ms.name}"'))
            continue
        kind, key, side = classify(lab, v)
        out.append(
            LandmarkMatch(
                lab,
                i,
                lab,
                key if kind in ("landmark", "cluster") else "",
                d.side,
                d.segment,
                d.role,
                d.cluster,
            )
        )
    rec = Recognition(str(source), tuple(out), tuple(ignored), markerset_name=ms.name)
    return rec.to_json()
