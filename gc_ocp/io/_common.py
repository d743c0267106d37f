"""Pieces shared by the C3D and OpenSim readers: the raw-trial container, units, frames,
foot-marker lookup, subject prefixes and the matching of a static trial's labels to a walking
trial's. Marker gap filling is
:func:`gc_ocp.gaps.fill_short_gaps`."""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gc_ocp.errors import MarkerError, UnitsError
from gc_ocp.model.landmarks import classify, normalise, vocabulary
from gc_ocp.trial import Plate

Y_UP_TO_LAB = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
"""OpenSim (X forward, Y up, Z right) -> lab (X forward, Y left, Z up): (x, y, z) -> (x, -z, y)."""

_TO_METRE = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}
_TO_METRE |= {  # the unit spelt out, singular or plural, US or UK spelling
    f"{prefix}{stem}{plural}": v
    for prefix, v in (("milli", 1e-3), ("centi", 1e-2), ("", 1.0))
    for stem in ("meter", "metre")
    for plural in ("", "s")
}


_TO_NEWTON = {
    "n": 1.0,
    "newton": 1.0,
    "newtons": 1.0,
    "kn": 1e3,
    "dan": 10.0,
    "kgf": 9.80665,
    "lbf": 4.4482216152605,
    "lb": 4.4482216152605,  # on a force channel, a pound is the pound-force
}
_MOMENT_ARM_TO_METRE = {**_TO_METRE, "in": 0.0254}  # the lengths, and inch-pounds


def _unit_key(unit: str) -> str:
    """A unit string without case, spaces and the product signs writers use (``N.mm``,
    ``N*m``, ``N·m``, ``N-m``)."""
    return re.sub(r"[\s.\-*·]", "", str(unit).strip().lower())


def force_unit_scale(unit: str) -> float | None:
    """[N] per unit of a force channel's ANALOG:UNITS (``N``, ``kN``, ``daN``, ``kgf``,
    ``lbf``), or None when the string is no force unit (``V``: a writer that stores volts with a
    scale to newtons, or an empty or unknown unit)."""
    return _TO_NEWTON.get(_unit_key(unit))


def moment_unit_scale(unit: str) -> float | None:
    """[N m] per unit of a moment channel's ANALOG:UNITS: a force unit of
    :func:`force_unit_scale` times a length (``Nmm``, ``N.m``, ``Ncm``, ``kNm``, ``lbf*in``), or
    None when the string is no such product."""
    key = _unit_key(unit)
    for f in sorted(_TO_NEWTON, key=len, reverse=True):
        arm = _MOMENT_ARM_TO_METRE.get(key[len(f) :]) if key.startswith(f) else None
        if arm is not None:
            return _TO_NEWTON[f] * arm
    return None


@dataclass
class RawTrial:
    """What a reader returns: everything already in SI and in a Z-up frame (``lab`` up to a
    rotation about Z, decided afterwards by :func:`walking_rotation`)."""

    source: Path
    marker_names: list[str]
    markers: np.ndarray  # (n_frames, n_markers, 3) [m]
    marker_time: np.ndarray  # (n_frames,) [s]
    plates: list[Plate]
    mass: float | None = None
    height: float | None = None
    mass_source: str = ""
    height_source: str = ""
    grf_source: Path | None = None
    file_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    notes: list[str] = field(default_factory=list)


def unit_scale(unit: str, path: Path, what: str) -> float:
    """Factor converting a length given in ``unit`` to [m]."""
    key = unit.strip().lower()
    if key not in _TO_METRE:
        raise UnitsError(
            f'Unknown length unit "{unit}" for {what} in {path}; expected one of '
            f"{sorted(_TO_METRE)}. Fix the Units field of the file header."
        )
    return _TO_METRE[key]


def missing_as_nan(xyz: np.ndarray) -> np.ndarray:
    """``xyz`` ``(n_frames, n_markers, 3)`` with the writers' ways of saying "not seen" made
    NaN: all three coordinates exactly 0 (C3D writers without residuals, and OpenSim's TRC
    writers, fill gaps with zeros: a real marker never sits on the lab origin to the bit in all
    three coordinates) and any coordinate that is not finite."""
    xyz = np.array(xyz, dtype=float)
    xyz[np.all(xyz == 0.0, axis=2)] = np.nan
    xyz[~np.all(np.isfinite(xyz), axis=2)] = np.nan
    return xyz


def check_metres(
    values: np.ndarray,
    path: Path,
    what: str,
    declared: str,
    fix: str = "Fix the unit in the file header (e.g. TRC 'Units' = mm, C3D POINT:UNITS = 'mm').",
) -> None:
    """Raise :class:`UnitsError` if values said to be in metres look like millimetres.

    Marker coordinates of a walking trial are within a few metres of the lab origin; a typical
    magnitude (median of |value|) above 50 "m" means the file is in mm while saying "m".
    ``fix``: what the message tells the user to do (a file without a unit header, e.g. a MOT,
    needs another fix than a header's unit).
    """
    finite = np.abs(values[np.isfinite(values)])
    if finite.size and float(np.median(finite)) > 50.0:
        raise UnitsError(
            f"{what} in {path} are declared in {declared!r} but their typical magnitude is "
            f"{np.median(finite):.0f} (expected < 50 m for a gait lab): the file is almost "
            f"certainly in millimetres. {fix}"
        )


MIN_BODY_SPAN = 0.25
"""Smallest plausible extent [m] of a walking subject's marker cloud in one frame (largest of the
three axis extents, median over frames). Pelvis and foot markers are at least a leg length apart
(>= 0.4 m even for a child); metres declared as mm give ~2 mm, centimetres declared as mm ~0.17 m
for an adult."""
MAX_BODY_SPAN = 10.0
"""Largest plausible extent [m] of the marker cloud in one frame: a subject with arms raised is
< 2.6 m, and a gait lab's capture volume is a few metres; millimetres read as centimetres or
metres give 17-1700 m."""


def check_body_span(xyz: np.ndarray, path: Path, declared: str, field: str) -> None:
    """Raise :class:`UnitsError` if the marker cloud ``(n, m, 3)`` [m] (after applying the
    declared unit) is not the size of a person (:data:`MIN_BODY_SPAN`, :data:`MAX_BODY_SPAN`)."""
    spans = []
    for frame in xyz:
        f = frame[np.all(np.isfinite(frame), axis=1)]
        if len(f) >= 3:
            spans.append(float(np.max(np.ptp(f, axis=0))))
    if not spans:
        return
    span = float(np.median(spans))
    if MIN_BODY_SPAN <= span <= MAX_BODY_SPAN:
        return
    if span < MIN_BODY_SPAN:
        guess = "metres" if span < 0.01 else "centimetres"
        hint = f"a subject {span * 1e3:.1f} mm across is not a walking subject"
    else:
        guess = "millimetres"
        hint = f"a subject {span:.0f} m across is not a walking subject"
    raise UnitsError(
        f"Marker coordinates in {path} are declared in {declared!r} ({field}) but then the markers "
        f"span only {span:.4g} m in a frame (median; a person spans "
        f"{MIN_BODY_SPAN}-{MAX_BODY_SPAN:.0f} m): {hint}. The values are probably in {guess}: "
        f"correct {field} in the file."
    )


_UP_TO_LAB = {
    (2, 1): np.eye(3),
    (2, -1): np.diag([1.0, -1.0, -1.0]),
    (1, 1): Y_UP_TO_LAB,
    (1, -1): np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
    (0, 1): np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]),
    (0, -1): np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]),
}
AXIS_NAMES = "XYZ"


def up_to_lab(axis: int, sign: int) -> np.ndarray:
    """Proper rotation taking the file's vertical axis ``sign * e_axis`` to lab +Z (the
    OpenSim Y-up map :data:`Y_UP_TO_LAB` for +Y)."""
    return _UP_TO_LAB[(int(axis), 1 if sign > 0 else -1)].copy()


def rotation_z(quarter_turns: int) -> np.ndarray:
    """Rotation about Z by ``quarter_turns`` * 90 degrees (exact integers)."""
    c, s = [(1, 0), (0, 1), (-1, 0), (0, -1)][quarter_turns % 4]
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]], dtype=float)


# --- foot markers ---------------------------------------------------------------------------

_FOOT_PATTERNS = ("HEE", "HEEL", "ANK", "ANKLE", "TOE", "MT5", "MT1", "MIDFOOT", "MAL", "FOOT")
_FOOT_LANDMARKS = ("CA", "LM", "MM", "FM", "SM", "VM", "FMH", "SMH", "VMH", "IMH", "IIMH", "IIT")
"""Anatomical foot landmarks of the CAST / IOR convention (BTS and others), matched exactly:
calcaneus, lateral/medial malleolus, 1st/2nd/5th metatarsal heads, 2nd toe."""


def marker_side(name: str) -> str | None:
    """``"left"``/``"right"`` from a marker name prefix (``L``/``R``, ``L.``/``R.``, ``L_``,
    ``Left``), else ``None``."""
    m = re.match(r"^(left|right|l|r)[._\s-]?(.*)$", name, flags=re.IGNORECASE)
    if not m or not m.group(2):
        return None
    return "left" if m.group(1).lower().startswith("l") else "right"


def _landmark(name: str) -> tuple[str, str | None]:
    """``(landmark, side)`` of a label by the landmark vocabulary (``("", None)`` if none)."""
    kind, key, side = classify(name)
    return (key, side) if kind == "landmark" else ("", None)


_FOOT_VOCABULARY_SEGMENTS = ("hindfoot", "toes")
_TOE_ORDER = ("toe_tip", "metatarsal_2", "metatarsal_1", "metatarsal_5")


def foot_markers(names: list[str] | tuple[str, ...], side: str) -> list[int]:
    """Indices of the foot markers (heel, ankle, toe, metatarsal, midfoot) of ``side``: by the
    name patterns below, or recognised as a foot landmark or malleolus by the landmark
    vocabulary (:mod:`gc_ocp.model.landmarks`; e.g. CAST ``RFCC``, ``RFM1``)."""
    voc = vocabulary()
    out = []
    for i, n in enumerate(names):
        key, lm_side = _landmark(n)
        if key and lm_side == side:
            lm = voc.landmarks[key]
            if lm.segment in _FOOT_VOCABULARY_SEGMENTS or lm.role.startswith("ankle"):
                out.append(i)
                continue
        if marker_side(n) != side:
            continue
        rest = re.sub(r"^(left|right|l|r)[._\s-]?", "", n, flags=re.IGNORECASE).upper()
        rest = rest.replace(".", "").replace("_", "")
        if rest.startswith(_FOOT_PATTERNS) or rest in _FOOT_LANDMARKS:  # "Shank" is no ankle
            out.append(i)
    return out


def heel_toe(names: list[str] | tuple[str, ...], side: str) -> tuple[int | None, int | None]:
    """Index of the heel and of the most distal toe marker of ``side`` (``None`` if absent).

    By name (``HEE``, ``TOE``, ``TIP``); when that finds none, by the landmark vocabulary
    (calcaneus; toe tip, else 2nd, 1st, 5th metatarsal head)."""
    heel = toe = None
    feet = foot_markers(names, side)
    for i in feet:
        u = names[i].upper()
        if "HEE" in u and heel is None:
            heel = i
        if "TOE" in u and (toe is None or "TIP" in u):
            toe = i
    lms = {i: _landmark(names[i])[0] for i in feet}
    if heel is None:
        heel = next((i for i in feet if lms[i] == "heel"), None)
    if toe is None:
        for key in _TOE_ORDER:
            toe = next((i for i in feet if lms[i] == key), None)
            if toe is not None:
                break
    return heel, toe


SUBJECT_MIN_LANDMARKS = 3
"""A label prefix (``Name:``) that carries at least this many landmark labels names a subject;
fewer is a prop or a device's points (``Wand:Tip``), kept as they are."""


def without_subject_prefix(labels: list[str], path: Path) -> tuple[list[str], str]:
    """``labels`` with the subject prefix dropped, and a note saying so (``""`` if none).

    Vicon Nexus labels a subject's markers ``Subject:LHEE``; the prefix names the subject, not
    the landmark, and stands in the way of the marker sets (``LHEE``) and of a static trial
    saved without it. A prefix is a subject's when :data:`SUBJECT_MIN_LANDMARKS` of its labels
    are landmarks of the vocabulary; two such prefixes are two subjects in one file: a
    :class:`MarkerError` naming them (gc_ocp fits one subject per trial)."""
    heads: dict[str, int] = {}
    for lab in labels:
        head, sep, name = lab.rpartition(":")
        if sep and classify(name.strip())[0] == "landmark":
            heads[head.strip()] = heads.get(head.strip(), 0) + 1
    subjects = sorted(h for h, k in heads.items() if k >= SUBJECT_MIN_LANDMARKS)
    if not subjects:
        return labels, ""
    if len(subjects) > 1:
        raise MarkerError(
            f"{path} holds the markers of several subjects (label prefixes "
            f"{', '.join(h + ':' for h in subjects)}): gc_ocp fits one subject per trial. Export "
            f"one subject's markers, or remove the others from the file."
        )
    head = subjects[0]
    out = [
        lab.rpartition(":")[2].strip() if lab.rpartition(":")[0].strip() == head else lab
        for lab in labels
    ]
    return out, f'marker labels carry the subject prefix "{head}:": dropped'


# --- labels of two trials of one subject ------------------------------------------------------


@dataclass(frozen=True)
class LabelMatch:
    """What :func:`match_labels` found: ``renamed`` (label -> marker name, each with ``how``:
    ``"spelling"`` or the landmark ``"heel, left"``), the marker names with no counterpart
    (``unmatched``), the labels matched to none (``spare``) and the ambiguities
    (``conflicts``: ``"L.Heel: Heel_L or LHEEL"``), each left unmatched."""

    renamed: dict[str, str]
    how: dict[str, str]
    unmatched: tuple[str, ...]
    spare: tuple[str, ...]
    conflicts: tuple[str, ...]

    def said(self) -> str:
        """The renaming as a note: ``"Heel_L -> L.Heel (heel, left), l_th1 -> L.TH1 (spelling)"``."""
        return ", ".join(f"{a} -> {b} ({self.how[a]})" for a, b in self.renamed.items())


def match_labels(names, labels, source: Path) -> LabelMatch:
    """Match the ``labels`` of a second trial of the subject (its static trial) to the marker
    ``names`` one trial (the walking one) uses, when the two were exported in other styles.

    Labels equal to a name are that name. For each other name, a remaining label is a candidate
    when, both without a subject prefix (:func:`without_subject_prefix`), it is spelt the same
    up to case and the separators ``. _ - space`` (``L_HEE``, ``l.hee`` for ``LHEE``:
    :func:`~gc_ocp.model.landmarks.normalise`), or it is the same landmark on the same side
    (``Heel_L``, ``L.Heel`` for ``LHEE``: :func:`~gc_ocp.model.landmarks.classify`). Labels of
    opposite sides are never candidates. A name is matched only to its one candidate when that
    label is no other name's candidate: two labels for one name, or one label for two, would
    be a guess, and a wrong one registers a marker where another sits."""
    names, labels = [str(n) for n in names], [str(x) for x in labels]
    bare_names = dict(zip(names, without_subject_prefix(names, source)[0], strict=True))
    pool = [x for x in dict.fromkeys(labels) if x not in bare_names]
    bare = dict(zip(pool, without_subject_prefix(pool, source)[0], strict=True))
    wanted = [n for n in dict.fromkeys(names) if n not in set(labels)]

    def read(label: str) -> tuple[str, tuple[str, str | None] | None, str | None]:
        kind, key, side = classify(label)
        return normalise(label), ((key, side) if kind == "landmark" else None), side

    mine = {n: read(bare_names[n]) for n in wanted}
    theirs = {x: read(bare[x]) for x in pool}
    cands: dict[str, list[str]] = {}
    how: dict[tuple[str, str], str] = {}
    for n, (spelt, lm, side) in mine.items():
        for x, (x_spelt, x_lm, x_side) in theirs.items():
            if side is not None and x_side is not None and side != x_side:
                continue  # left is never right, whatever the spelling
            if spelt == x_spelt:
                how[n, x] = "spelling"
            elif lm is not None and lm == x_lm:
                how[n, x] = f"{lm[0]}, {lm[1]}" if lm[1] else lm[0]
            else:
                continue
            cands.setdefault(n, []).append(x)
    owners: dict[str, list[str]] = {}
    for n, xs in cands.items():
        for x in xs:
            owners.setdefault(x, []).append(n)
    renamed: dict[str, str] = {}
    conflicts = []
    for n, xs in cands.items():
        if len(xs) > 1:
            conflicts.append(f"{n}: {' or '.join(xs)}")
        elif len(owners[xs[0]]) > 1:
            conflicts.append(f"{xs[0]}: {' or '.join(owners[xs[0]])}")
        else:
            renamed[xs[0]] = n
    return LabelMatch(
        renamed,
        {x: how[n, x] for x, n in renamed.items()},
        tuple(n for n in wanted if n not in renamed.values()),
        tuple(x for x in pool if x not in renamed),
        tuple(dict.fromkeys(conflicts)),
    )


def warn(message: str) -> None:
    warnings.warn(message, UserWarning, stacklevel=3)
