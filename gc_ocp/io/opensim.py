"""OpenSim TRC (markers) and MOT/STO (ground reactions) readers.

OpenSim files are Y up, X forward, Z right; they are mapped to a Z-up frame by
``(x, y, z) -> (x, -z, y)`` (:data:`gc_ocp.io._common.Y_UP_TO_LAB`).

GRF columns are found by pattern, for any prefix: a *set* is a force ``<p>force_v{x,y,z}``,
a point ``<p>force_p{x,y,z}`` and a torque ``<p>torque_{x,y,z}`` sharing the prefix/suffix
(Rajagopal: ``ground_force_r_vx`` / ``ground_torque_r_x``; Gait2392: ``ground_force_vx`` and
``1_ground_force_vx`` / ``ground_torque_x`` and ``1_ground_torque_x``). The side of a set is read
from an ``r``/``l`` token in its names; without a token the first set is the right foot and the
second the left (Gait2392 convention) when there are exactly two sets; more sets without a
token are plates (``ground_force_1..6_*``), named ``plate<N>``, and each of their stances
belongs to the foot whose markers are nearest its COP. :func:`gc_ocp.io.load_trial` checks
the side of a per-foot set against the foot markers and warns on a contradiction.

The torque of an OpenSim set is applied at the point ``p`` (the free moment at the COP).
Each set becomes one :class:`~gc_ocp.trial.Plate` whose reference point is the lab origin,
``moment = p x F + T``. The COP is used only where Fz is above the threshold: elsewhere ``p`` is
replaced by the nearest valid COP (files often hold garbage COPs at zero force).

Units: a MOT has no unit header. Its COP must be in metres (millimetres are refused); its torque
is read in N m or N mm, told apart by the lever arm |T| / |F| while loaded
(:func:`_torque_in_newton_metres`), unless a header line declares it (``torque_units=N*mm``).
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from gc_ocp.errors import InputError, PlateError, UnitsError
from gc_ocp.io._common import (
    Y_UP_TO_LAB,
    RawTrial,
    check_body_span,
    check_metres,
    foot_markers,
    missing_as_nan,
    moment_unit_scale,
    unit_scale,
    without_subject_prefix,
)
from gc_ocp.io.c3d import _negative_plates
from gc_ocp.trial import Plate

COP_MIN_FORCE = 20.0
"""Vertical force [N] above which an OpenSim COP column is trusted."""

FREE_MOMENT_ARM = 0.1
"""[m] Largest median lever arm |T| / |F| of a torque about the centre of pressure (the free
moment: vertical) read as N m. In walking the free moment is 0.1-15 N m at a load of hundreds
of N: the shared MOT files' median lever arms are 1.6-6.5 mm (Rajagopal 3.9 and 1.6 mm,
Gait2392 3.7 and 6.5 mm), and a median of 0.1 m would be a free moment of ~70 N m. The same
torques in N mm read 1.6-6.5 "m"; 0.1 m sits between the two, a factor ~30 from each."""
REFERENCE_MARGIN = 1.0
"""[m] How far beyond the farthest loaded COP from the lab origin a torque's reference point
may lie when the torque is not about the COP: the lab origin is within that distance by
definition, a plate's centre within its half-diagonal (< 0.7 m) and depth (< 0.1 m) of every
COP on it."""
STANCE_LOAD_FRACTION = 0.1
"""Samples whose |F| is above this fraction of the median stance load carry the torque unit
test: near contact and toe-off |F| -> 0 and |T| / |F| is noise."""
UNIT_GAP = 3.0
"""A median lever arm read as N m must exceed its bound by this factor to be read as N mm: its
N mm reading is then at least 0.3 mm for a free moment (~0.2 N m at a load of hundreds of N;
the shared files' are 1.6-6.5 mm, a free moment's lever arm hardly depends on body size) and
3 mm per metre of bound for a point. Just above the bound neither reading is plausible and
the file is refused. The shared files' torques x1000 lie 16-65 times beyond the free-moment
bound, Camargo's moments about points x1000 9-224 times beyond theirs. A file in N cm (100x) is
not told from one in N mm: the free moment's lever arm spans a factor ~40 between files, and
such a file reads 10x too small unless its header declares the unit."""


def read_trc(path: Path) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Read a TRC file: marker names, positions ``(n, m, 3)`` in [m] (Z-up frame), times [s]."""
    lines = path.read_text(errors="replace").splitlines()
    if len(lines) < 6:
        raise InputError(f"{path} is too short to be a TRC file (needs a 5-line header).")
    keys = lines[1].split()  # header cells may be separated by several tabs
    vals = lines[2].split()
    header = dict(zip(keys, vals, strict=False))
    unit = header.get("Units", "")
    if not unit:
        raise InputError(f"{path}: no 'Units' in the TRC header (line 3); add mm or m.")
    scale = unit_scale(unit, path, "TRC Units")
    names = [n.strip() for n in lines[3].split("\t")[2:] if n.strip()]
    if not names:
        raise InputError(
            f"{path}, line 4: no marker names after Frame# and Time; a TRC's line 4 names "
            "each marker (tab-separated, one name per X/Y/Z triple). Export the file again."
        )
    columns = ["Frame#", "Time"] + [f'marker "{n}" {a}' for n in names for a in "XYZ"]
    rows = []
    for lineno, line in enumerate(lines[5:], start=6):
        if not line.strip():
            continue
        cells = line.rstrip("\n").split("\t")[: len(columns)]
        row = [
            _number(c, path, lineno, col, blank=np.nan)
            for c, col in zip(cells, columns, strict=False)
        ]
        row += [np.nan] * (len(columns) - len(row))
        rows.append(row)
    if not rows:
        raise InputError(f"{path} has no data rows after its 5-line TRC header.")
    data = np.asarray(rows, dtype=float)
    time = data[:, 1]
    if not np.all(np.isfinite(time)):
        k = int(np.flatnonzero(~np.isfinite(time))[0])
        raise InputError(
            f"{path}: data row {k + 1} has no Time value; every TRC row needs its time in column 2."
        )
    _check_increasing(time, path, "TRC")
    rate = _number(header.get("DataRate", ""), path, 3, "DataRate", blank=np.nan)
    if np.isfinite(rate) and rate > 0:
        regular = time[0] + np.arange(len(time)) / rate
        if np.max(np.abs(regular - time)) < 0.5 / rate:
            time = regular  # the Time column is often rounded to 1 ms (60 Hz -> 0.017 s steps)
    xyz = missing_as_nan(data[:, 2:].reshape(len(rows), len(names), 3))
    if scale == 1.0:
        check_metres(xyz, path, "Marker coordinates", unit)
    xyz = xyz * scale
    check_body_span(xyz, path, unit, "TRC Units")
    _check_trc_y_up(path, names, xyz)
    return names, xyz @ Y_UP_TO_LAB.T, time


FEET_BELOW = 0.3
"""[m] How far the other markers lie above the foot markers (median over the frames of the
difference of their medians) for that axis to be up: 0.7-1.0 m along the up axis in the shared
TRC files (walking and static; 0.5 m for a lower-body set), under 0.06 m along the others (the
feet are under the body)."""


def _check_trc_y_up(path: Path, names: list[str], xyz: np.ndarray) -> None:
    """OpenSim's TRC files are Y-up: refuse one whose foot markers lie below the others along
    another axis (a TRC written Z-up was read with the body lying on its side, silently: its
    stances were kept), naming the axis. No conclusion without foot markers and other markers,
    or with the others less than :data:`FEET_BELOW` above the feet along every axis."""
    bare = [n.rpartition(":")[2] for n in names]
    feet = sorted(set(foot_markers(bare, "left") + foot_markers(bare, "right")))
    body = [j for j in range(len(names)) if j not in feet]
    if not feet or not body:
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # frames or markers without data
        d = np.nanmedian(
            np.nanmedian(xyz[:, body], axis=1) - np.nanmedian(xyz[:, feet], axis=1), axis=0
        )
    if not np.all(np.isfinite(d)):
        return
    k = int(np.argmax(np.abs(d)))
    if abs(d[k]) < FEET_BELOW or (k == 1 and d[k] > 0):
        return
    up = f"{'+' if d[k] > 0 else '-'}{'XYZ'[k]}"
    raise InputError(
        f"{path}: the foot markers lie {abs(d[k]):.2f} m below the other markers along {up} "
        f"(median), not along +Y: OpenSim's TRC files are Y-up, and this one is written "
        f"{up}-up. Export it Y-up (X forward, Y up), as its MOT."
    )


def _check_increasing(time: np.ndarray, path: Path, kind: str) -> None:
    """Refuse a time column that does not increase row by row (rows out of order, two exports
    joined, a row pasted twice): every reader takes the rows as samples in time order, so the
    file would be read as a motion it does not hold. Names the first data row that steps back
    (or repeats its time)."""
    back = np.flatnonzero(np.diff(time) <= 0)
    if back.size:
        k = int(back[0]) + 1  # 0-based index of the row whose time is not after its previous
        raise InputError(
            f"{path}: the time goes back at data row {k + 1} ({time[k]:.6g} s after "
            f"{time[k - 1]:.6g} s): a {kind} file's times increase row by row. Put the rows in "
            "time order (remove a repeated or pasted row), or export the file again."
        )


def read_mot(path: Path) -> tuple[list[str], np.ndarray, dict[str, str]]:
    """Read an OpenSim MOT/STO table: column names, data ``(n, k)``, header key/values."""
    lines = path.read_text(errors="replace").splitlines()
    try:
        end = next(i for i, ln in enumerate(lines) if ln.strip().lower() == "endheader")
    except StopIteration:
        raise InputError(
            f"{path} has no 'endheader' line: it is not an OpenSim MOT/STO file. Export the "
            f"ground reactions as .mot from OpenSim or your lab software."
        ) from None
    header = {}
    for ln in lines[:end]:
        if "=" in ln:
            k, v = ln.split("=", 1)
            header[k.strip()] = v.strip()
    if len(lines) < end + 3:
        raise InputError(
            f"{path} has no column names or no data after 'endheader'; export the ground "
            f"reactions again as .mot."
        )
    names = [n.strip() for n in lines[end + 1].split("\t") if n.strip()]
    rows = []
    for lineno, ln in enumerate(lines[end + 2 :], start=end + 3):
        cells = [c for c in re.split(r"[\t ]+", ln.strip()) if c]
        if not cells:
            continue
        if len(cells) < len(names):
            raise InputError(
                f"{path}, line {lineno}: {len(cells)} values for {len(names)} columns; the row "
                f"is truncated. Export the ground reactions again or remove the row."
            )
        rows.append(
            [_number(c, path, lineno, f'column "{n}"') for c, n in zip(cells, names, strict=False)]
        )
    return names, np.asarray(rows, dtype=float), header


def _number(cell: str, path: Path, lineno: int, what: str, blank: float | None = None) -> float:
    """``float(cell)``, or ``blank`` for an empty cell when given; else :class:`InputError`
    naming the file, the line and the column."""
    if blank is not None and not cell.strip():
        return blank
    try:
        return float(cell)
    except ValueError:
        raise InputError(
            f'{path}, line {lineno}: {what} is "{cell.strip()}", not a number. Fix the cell in '
            f"the file (leave a marker coordinate empty where the marker is missing)."
        ) from None


_FORCE = re.compile(r"^(?P<pre>.*?)force(?P<mid>.*?)_v(?P<ax>[xyz])(?P<post>.*)$", re.IGNORECASE)


def _side_token(name: str) -> str | None:
    tokens = re.split(r"[_.\s]+", name.lower())
    if "r" in tokens or "right" in tokens:
        return "right"
    if "l" in tokens or "left" in tokens:
        return "left"
    return None


def grf_sets(names: list[str]) -> list[dict]:
    """Find force/point/torque column triplets. Returns dicts with keys ``side`` (or ``None``),
    ``force``, ``point``, ``torque`` (lists of 3 column indices; torque may be ``None``)."""
    idx = {n.lower(): i for i, n in enumerate(names)}
    sets: dict[tuple[str, str, str], dict] = {}
    for n in names:
        m = _FORCE.match(n)
        if not m:
            continue
        key = (m["pre"].lower(), m["mid"].lower(), m["post"].lower())
        sets.setdefault(key, {})
    out = []
    for pre, mid, post in sets:
        f = [idx.get(f"{pre}force{mid}_v{a}{post}") for a in "xyz"]
        p = [idx.get(f"{pre}force{mid}_p{a}{post}") for a in "xyz"]
        t = [idx.get(f"{pre}torque{mid}_{a}{post}") for a in "xyz"]
        if None in f or None in p:
            continue
        out.append(
            {
                "side": _side_token(f"{pre}force{mid}{post}"),
                "force": f,
                "point": p,
                "torque": None if None in t else t,
                "label": f"{pre}force{mid}{post}",
            }
        )
    out.sort(key=lambda s: s["force"][0])  # file order
    unnamed = [s for s in out if s["side"] is None]
    if len(out) == 2 and len(unnamed) == 2:
        for s, side in zip(unnamed, ("right", "left"), strict=True):
            s["side"] = side  # two sets, no token: first = right, second = left (Gait2392)
            s["side_from"] = "column order (first set = right, second = left)"
            s["name"] = f"grf_{side}"
    else:  # plates, not feet: each stance's foot is the one nearest its COP
        for k, s in enumerate(unnamed):
            num = re.search(r"\d+", s["label"])
            s["name"] = f"plate{num.group(0) if num else k + 1}"
            s["side_from"] = "none: a plate; the foot of each stance is the one nearest its COP"
    for s in out:
        s.setdefault("name", f"grf_{s['side']}")
    return out


def _check_y_up(grf: Path, data: np.ndarray, sets: list[dict]) -> None:
    """OpenSim files are Y-up, and a walking subject's ground reaction points mostly up: refuse
    a MOT whose forces point mostly along another axis (a pair written Z-up, which would make
    the body lie on its side), naming the axis."""
    total = sum(np.nansum(np.abs(data[:, s["force"]]), axis=0) for s in sets)
    axis = int(np.argmax(total))
    if axis != 1 and total[axis] > 0:
        name = "XYZ"[axis]
        raise InputError(
            f"{grf}: the ground reaction points mostly along {name} ({total[axis] / total.sum():.0%}"
            f" of its size), not along Y: OpenSim's files are Y-up, and this MOT (and likely its "
            f"TRC) is written {name}-up. Export both files Y-up (X forward, Y up)."
        )


def _check_one_clock(trc: Path, marker_time: np.ndarray, grf: Path, grf_time: np.ndarray) -> None:
    """A TRC and its MOT share one clock: refuse a pair whose times do not overlap at all (a
    MOT of another trial, or a TRC whose time column was shifted), naming both ranges."""
    a0, a1 = float(np.nanmin(marker_time)), float(np.nanmax(marker_time))
    b0, b1 = float(np.nanmin(grf_time)), float(np.nanmax(grf_time))
    if min(a1, b1) <= max(a0, b0):
        raise InputError(
            f"{trc} covers {a0:.3f}-{a1:.3f} s and {grf} {b0:.3f}-{b1:.3f} s: the markers and "
            "the forces do not overlap in time, and they must share one clock. Give the MOT of "
            "this trial, or shift one file's time column to the other's."
        )


def _declared_torque_unit(grf: Path, header: dict[str, str]) -> tuple[str, float] | None:
    """The torque unit a MOT header declares, as ``(its line, N m per unit)``: a ``key=value``
    line whose key names a unit (``torque_units=N*mm``, ``units=N.m``) and whose value is a force
    times a length (:func:`~gc_ocp.io._common.moment_unit_scale`). None without one (OpenSim's
    own headers say ``inDegrees`` only; a length unit such as ``units=m`` says nothing of the
    torques). A unit key naming the torques or moments whose value is no such unit, and two
    lines that disagree, are refused naming the lines."""
    found: dict[str, float] = {}
    for key, value in header.items():
        low = key.lower()
        if "unit" not in low:
            continue
        scale = moment_unit_scale(value)
        if scale is None and ("torque" in low or "moment" in low):
            raise UnitsError(
                f'{grf}: the header line "{key}={value}" gives no torque unit the loader knows; '
                "write a force times a length (N*m, N*mm, N*cm, kN*m, lbf*in)."
            )
        if scale is not None:
            found[f"{key}={value}"] = scale
    if len(set(found.values())) > 1:
        raise UnitsError(
            f"{grf}: the header lines {', '.join(found)} declare different torque units; keep "
            "the one the torque columns are in."
        )
    return next(iter(found.items()), None)


def _torque_lever(
    f: np.ndarray, p: np.ndarray, tq: np.ndarray, threshold: float
) -> tuple[float, float, str] | None:
    """The median lever arm |T| / |F| of a set's torque over its loaded samples (|F| above
    :data:`STANCE_LOAD_FRACTION` of the median stance load), in metres if ``tq`` is in N m; the
    largest such lever arm [m] a walking lab's torque in N m has; and what the torque is about.

    A torque whose horizontal components are below its vertical one (medians) is about the
    centre of pressure, where the horizontal moment vanishes: its lever arm is the free moment's,
    mm (:data:`FREE_MOMENT_ARM`). Otherwise it is about a point (the lab origin, a plate's
    centre), whose lever arm is the COP's distance from it, tens of times its vertical part
    (|F_z| against the shear): at most the farthest loaded COP from the origin plus
    :data:`REFERENCE_MARGIN`. ``f``, ``p`` (metres), ``tq``: lab frame, Z up. None without loaded
    samples (nothing to judge by)."""
    fn = np.linalg.norm(f, axis=1)
    stance = f[:, 2] > threshold
    if not stance.any():
        return None
    loaded = stance & (fn > STANCE_LOAD_FRACTION * np.median(fn[stance]))
    loaded &= np.all(np.isfinite(tq), axis=1) & np.all(np.isfinite(p), axis=1)
    if not loaded.any():
        return None
    t = tq[loaded]
    arm = float(np.median(np.linalg.norm(t, axis=1) / fn[loaded]))
    if np.median(np.linalg.norm(t[:, :2], axis=1)) <= np.median(np.abs(t[:, 2])):
        return arm, FREE_MOMENT_ARM, "the centre of pressure (a free moment: mostly vertical)"
    reach = float(np.max(np.linalg.norm(p[loaded, :2], axis=1)))
    return (
        arm,
        reach + REFERENCE_MARGIN,
        f"a point of the lab (mostly horizontal: the COPs lie up to {reach:.2f} m from the origin)",
    )


def _torque_in_newton_metres(
    grf: Path,
    names: list[str],
    declared: tuple[str, float] | None,
    f: np.ndarray,
    p: np.ndarray,
    tq: np.ndarray,
    threshold: float,
) -> tuple[np.ndarray, str | None]:
    """A set's torque ``tq`` (lab frame) in N m, and a note when its unit was inferred.

    A MOT rarely says its torque unit; exporters write N m or N mm. The median lever arm
    |T| / |F| while loaded (:func:`_torque_lever`) tells them apart, as the COP's magnitude tells
    metres from millimetres (:func:`~gc_ocp.io._common.check_metres`): a lever arm beyond what a
    walking lab's torque in N m has, by :data:`UNIT_GAP` or more, and within it once divided by
    1000, is N mm (converted, with the note); a lever arm that fits neither unit is refused
    naming the columns. A unit the header declares (:func:`_declared_torque_unit`) is applied
    instead, and refused if the torque then does not fit N m."""
    scale = declared[1] if declared else 1.0
    lever = _torque_lever(f, p, tq, threshold)
    if lever is None:
        return tq * scale, None
    arm, bound, about = lever
    columns = ", ".join(names)
    if declared:
        if arm * scale <= bound:
            return tq * scale, None
        raise UnitsError(
            f'{grf}: the header declares "{declared[0]}", but then the torque columns {columns} '
            f"have a median lever arm |torque| / |force| of {arm * scale:.3g} m while loaded, "
            f"beyond the {bound:.3g} m a walking lab's torque about {about} has. Correct the "
            "unit in the header (or remove the line: the loader then tells N m from N mm)."
        )
    if arm <= bound:
        return tq, None
    if arm >= UNIT_GAP * bound and arm * 1e-3 <= bound:
        return tq * 1e-3, (
            f"{grf.name}: torque columns {columns} read in N mm and divided by 1000: in N m their "
            f"median lever arm |torque| / |force| while loaded would be {arm:.3g} m, beyond the "
            f"{bound:.3g} m a walking lab's torque about {about} has; in N mm it is "
            f"{arm:.3g} mm. Write the torques in N m, or declare their unit in the header "
            "(e.g. torque_units=N*mm), to read them without this inference."
        )
    fits = (
        f"{arm * 1e-3:.3g} m in N mm, also beyond it"
        if arm * 1e-3 > bound
        else f"too close to it to be N mm (a unit 1000x off lies {UNIT_GAP:g}x or more beyond)"
    )
    raise UnitsError(
        f"{grf}: the torque columns {columns} have a median lever arm |torque| / |force| of "
        f"{arm:.3g} m while loaded if in N m, beyond the {bound:.3g} m a walking lab's torque "
        f"about {about} has, and {fits}: neither N m nor N mm fits. Check that these columns "
        "hold the ground reaction's moment, and give them in N m (or declare their unit in the "
        "header, e.g. torque_units=N*mm)."
    )


def _no_torque_note(bare: list[dict], cols: list[str], grf: Path) -> str:
    """What the sets without ``<p>torque<m>_{x,y,z}`` columns are read with (no free moment),
    and the columns that may hold one under another name: a moment can be about the centre of
    pressure (OpenSim's torque) or about another point (Camargo's ``ground_force_1_mx``: about
    the lab origin, tens of N m), and the name does not say which."""
    maybe = []
    for s in bare:
        label = s["label"].lower()
        parts = [p for p in label.replace("force", "").split("_") if p]
        used = {cols[i] for i in (*s["force"], *s["point"])}
        maybe += [
            c
            for c in cols
            if c not in used
            and c not in maybe
            and any(k in c.lower() for k in ("moment", "torque", label + "_m"))
            and all(p in c.lower() for p in parts)
        ]
    labels = ", ".join(f"{s['label']}_*" for s in bare)
    found = f" Columns not read as one: {', '.join(maybe)}." if maybe else ""
    return (
        f"{grf}: no torque columns for {labels} (e.g. "
        f"{bare[0]['label'].replace('force', 'torque')}_x/_y/_z, the moment at the centre of "
        "pressure): the free moment is taken as 0, so the fit compares the model's vertical "
        f"torque with 0.{found} If those are the free moment at the centre of pressure, rename "
        "them so."
    )


def read_opensim(trc: Path, grf: Path, threshold: float = COP_MIN_FORCE) -> RawTrial:
    """Read a TRC + MOT pair into a :class:`RawTrial` (SI, Z-up)."""
    names, xyz, time = read_trc(trc)
    names, prefix_note = without_subject_prefix(names, trc)
    cols, data, header = read_mot(grf)
    if "time" not in [c.lower() for c in cols]:
        raise InputError(f"{grf} has no 'time' column; columns are {cols}.")
    t = data[:, [c.lower() for c in cols].index("time")]
    _check_increasing(t, grf, "MOT/STO")
    _check_one_clock(trc, time, grf, t)
    sets = grf_sets(cols)
    if not sets:
        raise PlateError(
            f"{grf} has no ground-reaction columns (expected e.g. ground_force_r_vx, "
            f"ground_force_r_px, ground_torque_r_x): the contact model needs measured ground "
            f"reactions. Columns found: {cols}"
        )
    _check_y_up(grf, data, sets)
    declared = _declared_torque_unit(grf, header)
    plates = []
    notes = [prefix_note] if prefix_note else []
    # every set negative while loaded: the force on the plate, as some writers store (C3D too)
    flip = _negative_plates(
        {s["name"]: (data[:, s["force"]] @ Y_UP_TO_LAB.T)[:, 2] for s in sets}, grf, strict=False
    )
    if flip:
        notes.append(
            f"the force sets of {grf.name} store the force on the plate (vertical force negative "
            f"while loaded): negated to the ground reaction on the subject"
        )
    for s in sets:
        f = data[:, s["force"]] @ Y_UP_TO_LAB.T * (-1.0 if flip else 1.0)
        p = data[:, s["point"]] @ Y_UP_TO_LAB.T
        # the horizontal COP while loaded: a thresholded file holds zeros in swing (most of
        # the samples of a plate stepped on once), whose median says nothing of the unit
        loaded = f[:, 2] > threshold
        check_metres(
            p[loaded][:, :2] if loaded.any() else p,
            grf,
            "COP columns",
            "m",
            "An OpenSim MOT has no unit header: its COP columns are in metres; divide them "
            "by 1000 (or export the forces again in metres).",
        )
        tq = np.zeros_like(f)
        if s["torque"]:
            tq, note = _torque_in_newton_metres(
                grf,
                [cols[i] for i in s["torque"]],
                declared,
                f,
                p,
                data[:, s["torque"]] @ Y_UP_TO_LAB.T * (-1.0 if flip else 1.0),
                threshold,
            )
            notes += [note] if note else []
        good = (f[:, 2] > threshold) & np.all(np.isfinite(p), axis=1)
        if good.any():
            k = np.flatnonzero(good)
            nearest = k[np.clip(np.searchsorted(k, np.arange(len(t))), 0, len(k) - 1)]
            prev = k[np.clip(np.searchsorted(k, np.arange(len(t))) - 1, 0, len(k) - 1)]
            use = np.where(
                np.abs(nearest - np.arange(len(t))) <= np.abs(prev - np.arange(len(t))),
                nearest,
                prev,
            )
            p = p[use]
            surface = float(np.median(p[good, 2]))
        else:
            p = np.zeros_like(p)
            surface = 0.0
        moment = np.cross(p, f) + tq
        plates.append(
            Plate(
                name=s["name"],
                time=t,
                force=f,
                moment=moment,
                reference_point=np.zeros(3),
                reference_kind="lab_origin",
                corners=None,
                surface_height=surface,
                plate_type=f"MOT columns {s['label']}_*",
            )
        )
        notes.append(
            f"{s['name']}: columns {s['label']}_* (side from "
            f"{s.get('side_from', 'the r/l token in the names')})"
        )
    bare = [s for s in sets if s["torque"] is None]
    if bare:
        notes.append(_no_torque_note(bare, cols, grf))
    return RawTrial(
        source=trc,
        marker_names=names,
        markers=xyz,
        marker_time=time,
        plates=plates,
        grf_source=grf,
        file_rotation=Y_UP_TO_LAB.copy(),
        notes=notes,
    )
