"""Subject mass and height: from metadata written beside a trial, or ESTIMATED from the plates.

Where the mass comes from, in order (:func:`gc_ocp.io.load_trial`): ``mass=`` / ``--mass``;
the trial file (C3D ``PROCESSING:Bodymass`` and the like); subject metadata that common
pipelines write beside trials (:func:`read_subject_metadata`); an estimate from the force data
(:func:`estimate_body_weight`), with a warning stating the estimate and its basis. The source
is kept in ``Trial.mass_source``.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from gc_ocp.trial import GRAVITY, Plate, Stance

_MASS_KEYS = ("masskg", "mass_kg", "mass", "bodymass", "body_mass", "weightkg", "weight_kg")
_HEIGHT_KEYS = ("heightm", "height_m", "height", "bodyheight", "body_height")
MAX_METADATA_BYTES = 1_000_000
QUIET_MIN_DURATION = 1.0
"""Shortest quiet-standing stretch [s] used for the body weight."""
QUIET_MAX_CV = 0.02
"""Largest coefficient of variation of the total vertical force in a quiet-standing window:
postural sway moves the vertical force by well under 1 % of body weight; walking by 100 %."""
STANDING_VS_PEAK = 0.6
"""A standing level below this fraction of the walking stances' median peak force is one foot
off the plates (a walking peak is ~1.1-1.2 BW, so half the body weight is ~0.45 peak)."""


def _height_m(v: float) -> float:
    """A height in [m] from a value in m, cm or mm (a person is 0.5-2.6 m)."""
    return v / 1000.0 if v > 300 else v / 100.0 if v > 3.0 else v


def _metadata_files(paths: list[Path]) -> list[Path]:
    """Candidate subject files beside the trial: JSON files named ``*subject*`` and XML files,
    in the trial's folder and its parent (AddBiomechanics keeps ``_subject.json`` at the
    subject folder, trials below it)."""
    out: list[Path] = []
    for folder in dict.fromkeys(d for p in paths for d in (p.parent, p.parent.parent)):
        if not folder.is_dir():
            continue
        for f in sorted(folder.iterdir()):
            if not f.is_file() or f.stat().st_size > MAX_METADATA_BYTES:
                continue
            name = f.name.lower()
            if (name.endswith(".json") and "subject" in name) or name.endswith(".xml"):
                out.append(f)
    return out


def _from_json(f: Path) -> tuple[float | None, float | None]:
    try:
        data = json.loads(f.read_text(errors="replace"))
    except (json.JSONDecodeError, OSError):
        return None, None
    if not isinstance(data, dict):
        return None, None
    low = {str(k).lower(): v for k, v in data.items()}
    mass = height = None
    for k in _MASS_KEYS:
        if isinstance(low.get(k), (int, float)) and low[k] > 0:
            mass = float(low[k])
            break
    for k in _HEIGHT_KEYS:
        if isinstance(low.get(k), (int, float)) and low[k] > 0:
            height = _height_m(float(low[k]))
            break
    return mass, height


def _from_scale_setup(f: Path) -> tuple[float | None, float | None]:
    """OpenSim ScaleTool set-up: ``<ScaleTool><mass>`` [kg], ``<height>`` [mm; -1 unknown]."""
    try:
        head = f.read_text(errors="replace")
    except OSError:
        return None, None
    if "<ScaleTool" not in head:
        return None, None
    try:
        root = ET.fromstring(head)
    except ET.ParseError:
        return None, None
    tool = root if root.tag == "ScaleTool" else root.find(".//ScaleTool")
    if tool is None:
        return None, None

    def number(tag: str) -> float | None:
        el = tool.find(tag)
        try:
            v = float(el.text) if el is not None and el.text else None
        except ValueError:
            return None
        return v if v is not None and v > 0 else None

    h = number("height")
    return number("mass"), None if h is None else _height_m(h)


def read_subject_metadata(paths: list[Path]) -> dict:
    """Mass [kg] and height [m] from subject files written beside ``paths`` (the trial files):
    a JSON ``*subject*.json`` with ``massKg``/``mass``/``bodyMass`` and ``heightM``/``height``
    keys (AddBiomechanics ``_subject.json``), or an OpenSim ScaleTool set-up XML with
    ``<mass>`` and ``<height>``. Returns ``{"mass": (value, source), "height": ...}`` for what
    was found (the first file that has it, in name order)."""
    found: dict = {}
    for f in _metadata_files([Path(p) for p in paths]):
        mass, height = _from_json(f) if f.suffix.lower() == ".json" else _from_scale_setup(f)
        if mass is not None and "mass" not in found:
            found["mass"] = (mass, f"subject metadata {f}")
        if height is not None and "height" not in found:
            found["height"] = (height, f"subject metadata {f}")
    return found


def _total_vertical(plates: list[Plate]) -> tuple[np.ndarray, np.ndarray]:
    t = plates[0].time
    fz = np.zeros_like(t)
    for p in plates:
        fz += np.interp(t, p.time, p.force[:, 2], left=0.0, right=0.0)
    return t, fz


def _integral(t: np.ndarray, f: np.ndarray, t0: float, t1: float) -> float:
    sel = (t >= t0) & (t <= t1)
    return float(np.trapezoid(f[sel], t[sel])) if sel.sum() > 1 else 0.0


def quiet_standing(plates: list[Plate], stances: list[Stance]) -> tuple[float, str] | None:
    """Body weight [N] from the longest quiet-standing stretch of the summed plates: windows of
    :data:`QUIET_MIN_DURATION` whose total vertical force varies by less than
    :data:`QUIET_MAX_CV`, above :data:`STANDING_VS_PEAK` x the walking stances' median peak
    (both feet on the plates). ``None`` without one."""
    t, fz = _total_vertical(plates)
    dt = float(np.median(np.diff(t)))
    n = int(round(QUIET_MIN_DURATION / dt))
    if n < 2 or len(t) < n:
        return None
    peaks = [
        float(np.max(fz[(t >= s.t_on) & (t <= s.t_off)], initial=0.0))
        for s in stances
        if ((t >= s.t_on) & (t <= s.t_off)).any()
    ]
    floor = STANDING_VS_PEAK * float(np.median(peaks)) if peaks else 200.0
    nw = len(t) // n
    w = fz[: nw * n].reshape(nw, n)
    mean, std = w.mean(axis=1), w.std(axis=1)
    quiet = (mean > max(floor, 200.0)) & (std < QUIET_MAX_CV * np.abs(mean))
    if not quiet.any():
        return None
    level = float(np.median(w[quiet]))
    return level, (
        f"quiet standing: median total vertical plate force {level:.0f} N over "
        f"{quiet.sum() * n * dt:.1f} s with both feet on the plates (windows of "
        f"{QUIET_MIN_DURATION:.0f} s varying < {QUIET_MAX_CV:.0%})"
    )


def walking_body_weight(plates: list[Plate], stances: list[Stance]) -> tuple[float, str] | None:
    """Body weight [N] from walking: over whole gait cycles the mean vertical force equals the
    body weight (the vertical momentum returns to its value).

    With two stances of one foot and the other foot's stance between them measured too (three
    consecutive stances in double support): the impulses of one stance of each foot / the
    stride time (by periodicity, the other foot's stance sticking out of the stride equals the
    part of its previous stance inside it). Otherwise, with consecutive
    stances of alternating feet (overlapping in double support): the mean stance impulse / the
    mean step time (one stance per step). ``None`` with fewer than two stances."""
    st = sorted(stances, key=lambda s: s.t_on)
    if len(st) < 2:
        return None

    def impulse(s: Stance) -> float:
        p = plates[s.plate]
        return _integral(p.time, p.force[:, 2], s.t_on, s.t_off)

    for a, m, b in zip(st, st[1:], st[2:], strict=False):
        # a stride: a and b of one foot, m of the other in double support with both
        if a.side == b.side != m.side and m.t_on < a.t_off and b.t_on < m.t_off:
            T = b.t_on - a.t_on
            bw = (impulse(a) + impulse(m)) / T
            return bw, (
                f"walking: vertical impulse of one {a.side} and one {m.side} stance "
                f"{impulse(a) + impulse(m):.0f} N s over the stride {a.t_on:.3f}-{b.t_on:.3f} s "
                f"= {bw:.0f} N"
            )
    chain = [st[0]]
    for s in st[1:]:
        prev = chain[-1]
        if s.side != prev.side and s.t_on < prev.t_off:  # double support: the next step
            chain.append(s)
        elif len(chain) < 2:
            chain = [s]
        else:
            break
    if len(chain) < 2:
        return None
    impulses = []
    for s in chain:
        impulses.append(impulse(s))
    step = (chain[-1].t_on - chain[0].t_on) / (len(chain) - 1)
    bw = float(np.mean(impulses)) / step
    return bw, (
        f"walking: mean stance impulse {np.mean(impulses):.0f} N s / mean step time "
        f"{step:.3f} s over {len(chain)} consecutive stances (one stance per step; assumes "
        f"a steady, symmetric gait: a few per cent)"
    )


def estimate_body_weight(plates: list[Plate], stances: list[Stance]) -> tuple[float, str] | None:
    """ESTIMATE of the body weight [N] from the plates: quiet standing when the trial has it
    (:func:`quiet_standing`), else whole gait cycles (:func:`walking_body_weight`). Returns
    ``(weight, basis)`` or ``None``."""
    stand = quiet_standing(plates, stances)
    walk = walking_body_weight(plates, stances)
    if stand is None and walk is None:
        return None
    bw, basis = stand if stand is not None else walk
    if stand is not None and walk is not None:
        basis += f"; for comparison, walking gives {walk[0] / GRAVITY:.1f} kg ({walk[1]})"
    return bw, basis
