"""Marker labels -> anatomical landmarks: the vocabulary and the classification of one label.

The vocabulary (``gc_ocp/data/landmarks.toml``) lists anatomical landmarks (calcaneus, metatarsal
heads, malleoli, epicondyles, ASIS ...), the names the major conventions give them (Plug-in Gait,
Helen Hayes, CAST/Visual3D, BTS, IOR/Rizzoli, Oxford foot, OpenSim, OpenCap, Camargo) and where
they sit on the gait model; also tracking clusters and patterns of computed (virtual) points.

A label is split into side and core: ``LHEE``, ``L.Heel``, ``l_heel``, ``Left Heel``, ``Heel_L``,
``HeelL`` all give (left, ``heel``); the core is compared ignoring case and the separators
``. _ - space``. How a whole trial's labels become a marker set (duplicates, ambiguities, whether
each foot can be tracked) is :mod:`gc_ocp.model.recognition`.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib


VOCABULARY_PATH = Path(__file__).resolve().parent.parent / "data" / "landmarks.toml"
FOOT_SEGMENTS = ("hindfoot", "toes")
UNSIDED_SEGMENTS = ("pelvis", "torso")
"""Model segments without a side: a sided landmark on them (ASIS, acromion) keeps the segment
name and only mirrors its position."""
TOES_IN_HINDFOOT = np.array([0.127, 0.0, -0.045])
"""Rough position [m] of the toes frame in the hindfoot frame at the vocabulary's reference
height (only used to test foot landmarks for collinearity)."""
MIN_FOOT_LEVER = 0.03
"""Smallest distance [m] of a foot landmark (nominal position) from the line through the two
farthest apart for 3 landmarks to fix the foot (as :data:`gc_ocp.io.checks.FOOT_FIX_LEVER`)."""

_SEP = r"[\s._\-]"


@dataclass(frozen=True)
class Landmark:
    """One vocabulary entry: segment (without side), left-side ``position`` [m] at the
    vocabulary's reference height, IK ``weight``, foot ``role``, ``medial`` counterpart,
    normalised ``names``; ``cluster`` for tracking markers."""

    key: str
    segment: str
    sided: bool
    position: np.ndarray
    weight: float
    role: str = ""
    medial: str = ""
    names: tuple[str, ...] = ()
    cluster: bool = False
    patterns: tuple[re.Pattern, ...] = ()

    @property
    def is_foot(self) -> bool:
        return self.segment in FOOT_SEGMENTS

    def side_segment(self, side: str | None) -> str:
        if not self.sided or self.segment in UNSIDED_SEGMENTS:
            return self.segment
        return f"{self.segment}_{'l' if side == 'left' else 'r'}"

    def side_position(self, side: str | None) -> np.ndarray:
        p = np.array(self.position, dtype=float)
        if side == "right":
            p[1] = -p[1]
        return p


@dataclass(frozen=True)
class Vocabulary:
    """The loaded vocabulary: ``landmarks`` (clusters included, keyed ``cluster:<segment>``)."""

    source: Path
    reference_height: float
    landmarks: dict[str, Landmark]
    sided: dict[str, str]
    midline: dict[str, str]
    virtual: tuple[re.Pattern, ...]
    ignore_suffixes: tuple[str, ...]


def normalise(core: str) -> str:
    """Lower case without the separators ``. _ - space``: ``"Toe.Tip"`` -> ``"toetip"``."""
    return re.sub(_SEP, "", core).lower()


@functools.cache
def vocabulary(path: str | Path | None = None) -> Vocabulary:
    """The landmark vocabulary (default ``gc_ocp/data/landmarks.toml``)."""
    p = VOCABULARY_PATH if path is None else Path(path)
    data = tomllib.loads(p.read_text())
    lms: dict[str, Landmark] = {}
    sided: dict[str, str] = {}
    midline: dict[str, str] = {}
    for key, d in data.get("landmarks", {}).items():
        pos = np.array(d["position"], dtype=float)
        pos.setflags(write=False)
        lm = Landmark(
            key,
            d["segment"],
            bool(d.get("sided", True)),
            pos,
            float(d.get("weight", 1.0)),
            d.get("role", ""),
            d.get("medial", ""),
            tuple(normalise(n) for n in d.get("names", [])),
        )
        lms[key] = lm
        table = sided if lm.sided else midline
        for n in lm.names:
            if n in table and table[n] != key:
                raise ValueError(f'{p}: name "{n}" is given to {table[n]} and {key}')
            table[n] = key
    for seg, d in data.get("clusters", {}).items():
        key = f"cluster:{seg}"
        pos = np.array(d["position"], dtype=float)
        pos.setflags(write=False)
        lms[key] = Landmark(
            key,
            d["segment"],
            True,
            pos,
            float(d.get("weight", 1.0)),
            names=tuple(normalise(n) for n in d.get("names", [])),
            cluster=True,
            patterns=tuple(re.compile(x) for x in d.get("patterns", [])),
        )
    virtual = tuple(re.compile(x) for x in data.get("virtual", {}).get("patterns", []))
    return Vocabulary(
        p,
        float(data.get("reference_height", 1.70)),
        lms,
        sided,
        midline,
        virtual,
        tuple(data.get("ignore_suffixes", [])),
    )


def split_side(label: str) -> list[tuple[str | None, str]]:
    """Candidate ``(side, core)`` readings of ``label``, most specific first; the last one is
    ``(None, label)`` (a midline landmark)."""
    s = label.strip()
    out: list[tuple[str | None, str]] = []

    def add(side: str, core: str) -> None:
        if core:
            out.append(("left" if side.lower().startswith("l") else "right", core))

    for pattern, flags in (
        (r"^(left|right)" + _SEP + r"*(.+)$", re.IGNORECASE),  # Left Heel, RightHeel
        (r"^([lr])" + _SEP + r"+(.+)$", re.IGNORECASE),  # L.Heel, r_heel, r heel
        (r"^([LR])(.+)$", 0),  # LHEE, RHeel, RCA
    ):
        m = re.match(pattern, s, flags)
        if m:
            add(m.group(1), m.group(2))
    for pattern, flags in (
        (r"^(.+?)" + _SEP + r"+(left|right|l|r)$", re.IGNORECASE),  # Heel_R, heel.left
        (r"^(.+[a-z])(Left|Right|L|R)$", 0),  # HeelR
    ):
        m = re.match(pattern, s, flags)
        if m:
            add(m.group(2), m.group(1))
    m = re.match(r"^([lr])(.+)$", s)  # rheel, lhee
    if m:
        add(m.group(1), m.group(2))
    out.append((None, s))
    return out


def classify(label: str, vocab: Vocabulary | None = None) -> tuple[str, str, str | None]:
    """``(kind, key, side)`` of one label: kind ``"landmark"`` (key = landmark), ``"cluster"``
    (key = ``cluster:<segment>``), ``"virtual"`` or ``"unknown"`` (key ``""``)."""
    if vocab is None:
        return _classify_default(label)
    return _classify(label, vocab)


@functools.lru_cache(maxsize=8192)
def _classify_default(label: str) -> tuple[str, str, str | None]:
    return _classify(label, vocabulary())


def _classify(label: str, v: Vocabulary) -> tuple[str, str, str | None]:
    cands = split_side(label)
    for side, core in cands:
        n = normalise(core)
        for suf in v.ignore_suffixes:
            if n.endswith(suf) and len(n) > len(suf):
                n = n[: -len(suf)]
        if side is None:
            if n in v.midline:
                return "landmark", v.midline[n], None
            continue
        if n in v.sided:
            return "landmark", v.sided[n], side
        for lm in v.landmarks.values():
            if lm.cluster and (n in lm.names or any(p.fullmatch(n) for p in lm.patterns)):
                return "cluster", lm.key, side
    for _side, core in cands:
        n = normalise(core)
        if any(p.fullmatch(n) for p in v.virtual) or any(
            p.fullmatch(normalise(label)) for p in v.virtual
        ):
            return "virtual", "", None
    return "unknown", "", None
