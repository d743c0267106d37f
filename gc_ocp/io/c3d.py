"""C3D reader (ezc3d): real markers, force plates about their electrical centre, subject.

ezc3d reads the file; every plate's wrench is computed here from its analog channels
(:func:`_plate_readings`, :mod:`gc_ocp.io.plates`). ezc3d's own platform wrench is the
independent reference of the tests; what it gives, checked numerically on the bundled Vicon file
(``tests/test_io.py``):

* ``platform[i]['force']`` is the ground reaction on the subject in the C3D global frame (N).
* ``platform[i]['moment']`` is about the **geometric centre of the plate surface** (mean of the
  four corners), not about the plate origin: ezc3d adds ``F x (-ORIGIN)`` to the analog moments
  (type 2/4). The COP rebuilt from force and moment about the mean corner point on the surface
  plane equals ezc3d's ``center_of_pressure`` to round-off.
* ``platform[i]['origin']`` is just ``-ORIGIN`` in *plate* axes, unrotated; we do not use it.

We re-express every plate wrench about the plate's **electrical centre** ``E``:
``E = C + R @ ORIGIN`` with ``C`` the mean corner point, ``R`` the plate axes in the lab (C3D
corner order: x = c1 - c2, y = c1 - c4, z = x cross y) and ORIGIN the FORCE_PLATFORM:ORIGIN
column (type-2 convention: the vector from the surface centre to the plate origin, in plate
axes). With Vicon/AMTI plates (z axis down) this puts ``E`` ~40 mm *below* the surface, as it
physically is; if a file stores the opposite sign (E would come out above the surface), the
sign is flipped so that E is below the surface. (:func:`gc_ocp.io.plates.type2_wrench` names the
opposite vector, plate origin to surface centre, and flips a stored sign to that reading: the
two readings of the one parameter put the origin at the same place.)

Unloaded offsets: see :func:`unloaded_baseline`.
"""

from __future__ import annotations

import re
from pathlib import Path

import ezc3d
import numpy as np

from gc_ocp.errors import InputError, PlateError, UnitsError
from gc_ocp.io._common import (
    AXIS_NAMES,
    RawTrial,
    check_body_span,
    check_metres,
    force_unit_scale,
    missing_as_nan,
    moment_unit_scale,
    unit_scale,
    up_to_lab,
    warn,
    without_subject_prefix,
)
from gc_ocp.io.plates import N_CHANNELS, SUPPORTED_TYPES, plate_axes, plate_wrench
from gc_ocp.io.subject import _height_m
from gc_ocp.trial import Plate
from gc_ocp.wrench import transport_moment

_MODEL_OUTPUT_GROUPS = ("ANGLES", "FORCES", "MOMENTS", "POWERS", "MODELED_MARKERS", "REACTIONS")
_MODEL_OUTPUT_NAME = re.compile(
    r"(Angles?|Force|Forces|GRF|Moment|Moments|Power|Powers|COM|CentreOfMass\w*|CenterOfMass\w*)$",
    flags=re.IGNORECASE,
)
BASELINE_WINDOW = 0.05
"""Window length [s] used to find the unloaded stretches of a plate signal."""


def _param(params: dict, group: str, name: str):
    try:
        return params[group][name]["value"]
    except KeyError:
        return None


def _first_number(value) -> float | None:
    """First element of a C3D parameter value as a float; ``None`` if empty or not numeric
    (a text subject parameter is treated as absent: the user is then asked for it)."""
    v = np.ravel(value)
    try:
        x = float(v[0]) if v.size else None
    except (TypeError, ValueError):
        return None
    if x is not None and np.isfinite(x) and float(np.float32(x)) == x:
        # C3D stores parameters as float32: 63.6 kg comes back as 63.599998474121094; the
        # shortest decimal that is the same float32 is what the lab typed
        x = float(np.format_float_positional(np.float32(x), unique=True))
    return x


def _model_outputs(params: dict, labels: list[str]) -> set[str]:
    """Labels that are software model outputs, not measured markers.

    Vicon lists them in POINT:ANGLES/FORCES/MOMENTS/POWERS/MODELED_MARKERS; we also drop names
    ending in Angle(s)/Force/Moment/Power/COM/CentreOfMass*, and Plug-in Gait "bone" points:
    four labels ``XXXO``, ``XXXA``, ``XXXL``, ``XXXP`` sharing a 3-letter segment prefix (after
    a subject prefix ``Name:``, if any).
    """
    out: set[str] = set()
    point = params.get("POINT", {})
    listed: set[str] = set()
    for g in _MODEL_OUTPUT_GROUPS:
        if g in point:
            listed.update(str(v).rpartition(":")[2].strip() for v in point[g]["value"])
    # with or without a subject prefix on either side (``Subject:LAnkleAngles``)
    out.update(lab for lab in labels if lab.rpartition(":")[2].strip() in listed)
    out.update(lab for lab in labels if _MODEL_OUTPUT_NAME.search(lab))
    # a subject prefix (Vicon Nexus: ``Subject:PELO``) kept in front of the bone points
    by_name: dict[tuple[str, str], str] = {}
    for lab in labels:
        head, _, name = lab.rpartition(":")
        by_name[(head, name)] = lab
    for head, name in list(by_name):
        if len(name) == 4 and name[3] == "O":
            bone = [(head, name[:3] + s) for s in "OALP"]
            if all(b in by_name for b in bone):
                out.update(by_name[b] for b in bone)
    return out


def unloaded_baseline(wrench: np.ndarray, rate: float) -> tuple[np.ndarray, float]:
    """Offset of an unzeroed plate, from the samples where it carries no load.

    ``wrench``: ``(n, 6)`` force [N] and moment; ``rate`` in [Hz]. The signal is cut into
    ``BASELINE_WINDOW`` windows; *quiet* windows have a vertical-force standard deviation below
    ``max(2 N, 3 x the smallest window std)``; the unloaded level is the mean Fz of the quiet
    window with the smallest |mean Fz| (an unloaded plate reads its offset, a loaded one reads
    hundreds of N); unloaded windows are the quiet ones within 5 N of that level. The baseline
    is the per-channel median over their samples (robust to spikes). Returns the ``(6,)``
    baseline and the unloaded duration [s] it rests on (0 -> no baseline found, zeros).
    """
    n = max(int(round(BASELINE_WINDOW * rate)), 2)
    nw = wrench.shape[0] // n
    if nw == 0:
        return np.zeros(6), 0.0
    w = wrench[: nw * n].reshape(nw, n, 6)
    whole = np.all(np.isfinite(w), axis=(1, 2))  # a window with a missing sample is not used
    if not whole.any():
        return np.zeros(6), 0.0
    fz_mean = np.where(whole, np.nan_to_num(w[:, :, 2]).mean(axis=1), np.nan)
    fz_std = np.where(whole, np.nan_to_num(w[:, :, 2]).std(axis=1), np.inf)
    quiet = fz_std < max(2.0, 3.0 * float(fz_std.min()))
    if not quiet.any():
        return np.zeros(6), 0.0
    level = fz_mean[quiet][np.argmin(np.abs(fz_mean[quiet]))]
    unloaded = quiet & (np.abs(fz_mean - level) < 5.0)
    samples = w[unloaded].reshape(-1, 6)
    return np.median(samples, axis=0), samples.shape[0] / rate


def _byte_order(path: Path, head: bytes) -> str:
    """NumPy byte order of a C3D file from the processor type of its parameter section
    (84 = Intel, 85 = DEC: little-endian; 86 = MIPS: big-endian)."""
    with open(path, "rb") as fh:
        fh.seek((head[0] - 1) * 512 + 3)
        proc = fh.read(1)
    return ">" if proc and proc[0] == 86 else "<"


def header_frames(path: Path) -> int | None:
    """Number of marker frames the C3D header announces (last - first + 1), read from the raw
    header bytes (ezc3d rewrites its own copy to what it could read). ``None`` when unknown
    (16-bit frame counter saturated, or an unreadable header)."""
    with open(path, "rb") as fh:
        head = fh.read(512)
    if len(head) < 12 or head[1] != 0x50:
        return None
    order = _byte_order(path, head)
    first, last = np.frombuffer(head[6:10], dtype=f"{order}u2")
    if last >= 65535 or last < first:
        return None
    return int(last) - int(first) + 1


def vertical_axis(
    forces: list[np.ndarray], corners: list[np.ndarray], markers: np.ndarray
) -> tuple[int, int, str]:
    """The file's vertical axis ``(axis, sign, how)`` from gravity and geometry.

    Axis: while a plate is loaded (|F| above half its peak), the vertical component of the ground
    reaction is about 1 body weight and the shear components below ~0.25 BW in walking, so the
    axis with the largest median |F| summed over the plates is vertical. Without a loaded plate,
    the normal of the plate surface (the corner axis with the smallest extent). Sign: the subject
    stands on the plates, so the markers (median) lie above the plate surfaces.
    """
    score = np.zeros(3)
    for f in forces:
        mag = np.linalg.norm(f, axis=1)
        ok = np.isfinite(mag)
        if not ok.any() or np.nanmax(mag) <= 0:
            continue
        loaded = ok & (mag > 0.5 * np.nanmax(mag))
        score += np.median(np.abs(f[loaded]), axis=0)
    if score.any():
        axis = int(np.argmax(score))
        how = "plate forces, median |F| while loaded summed over the plates: " + ", ".join(
            f"{a} {v:.0f} N" for a, v in zip(AXIS_NAMES, score, strict=True)
        )
    elif corners:
        axis = int(np.argmin(np.ptp(np.concatenate(corners), axis=0)))
        how = "the plate surface normal"
    else:
        return 2, 1, "no plates: Z kept"
    surface = float(np.mean([c[:, axis].mean() for c in corners])) if corners else 0.0
    finite = markers[..., axis][np.isfinite(markers[..., axis])]
    sign = 1 if not finite.size or float(np.median(finite)) >= surface else -1
    return axis, sign, how


def _screen_up(params: dict) -> str:
    """The axis POINT:Y_SCREEN declares as up on screen (e.g. ``"+Z"``), ``""`` if absent."""
    v = _param(params, "POINT", "Y_SCREEN")
    text = str(np.ravel(v)[0]).strip().upper() if v is not None and np.size(v) else ""
    return text if re.fullmatch(r"[+-][XYZ]", text) else ""


_UNSTATED = ("", "v", "volt", "volts")
"""ANALOG:UNITS that state no physical unit: volts (writers that store ANALOG:SCALE to
newtons and leave the unit ``V``) or nothing. A force channel so labelled is in N, a moment
channel in N x the point unit (the C3D convention)."""


def _channel_unit_error(path: Path, plate: int, what: str, unit: str, known: str) -> UnitsError:
    return UnitsError(
        f"{path}: plate {plate}'s {what} channel has ANALOG:UNITS {unit!r}, which is not a unit "
        f"gc_ocp can convert ({known}); fix ANALOG:UNITS for that channel in the file (or export "
        "it again with the plates in newtons)"
    )


def _force_scale(unit: str, path: Path, plate: int) -> float:
    """[N] per unit of a force channel (:func:`~gc_ocp.io._common.force_unit_scale`; an unstated
    unit, :data:`_UNSTATED`, is N)."""
    f = force_unit_scale(unit)
    if f is not None:
        return f
    if unit.strip().lower() in _UNSTATED:
        return 1.0
    raise _channel_unit_error(path, plate, "force", unit, "N, kN, daN, kgf, lbf")


def _moment_scale(unit: str, pos: float, path: Path, plate: int) -> float:
    """[N·m] per unit of a moment channel: a force unit times a length (``Nmm``, ``Nm``,
    ``Ncm``, ``kNm``, ``lbf*in``); an unstated unit (:data:`_UNSTATED`) is N x the point
    unit."""
    m = moment_unit_scale(unit)
    if m is not None:
        return m
    if unit.strip().lower() in _UNSTATED:
        return pos
    raise _channel_unit_error(path, plate, "moment", unit, "Nmm, Ncm, Nm, kNm, lbf*in")


def _length_scale(unit: str, pos: float) -> float:
    """[m] per unit of a COP channel (type 1): ``mm``, ``cm``, ``m``; anything else (``V``) is
    the point unit."""
    return {"mm": 1e-3, "cm": 1e-2, "m": 1.0}.get(unit.strip().lower(), pos)


def _plate_readings(c, params: dict, path: Path, strict: bool = True) -> list[dict]:
    """Each plate's force [N] and moment about its surface centre [N·m] in the file frame,
    corners [m], ORIGIN [m] (``None`` for types 1 and 3, whose wrench is about the centre).

    Every type is computed from its analog channels by :func:`gc_ocp.io.plates.plate_wrench`,
    each moment channel in the unit ANALOG:UNITS gives it (``Nmm``, ``Nm``; a length unit the
    file does not say is the point unit). ezc3d's own platform wrench equals ours to round-off on
    the shared type-2 and type-4 files (``tests/test_plates.py``) but takes the moments' unit from
    POINT:UNITS: a file with markers in metres and moments in N·mm (or markers in mm and moments
    in N·m), both valid C3D, came out 1000 times off (its type-1 moment also has the opposite
    sign to its force)."""
    t = _param(params, "FORCE_PLATFORM", "TYPE")
    kinds = [int(v) for v in np.ravel(t if t is not None else [])]
    used = _first_number(_param(params, "FORCE_PLATFORM", "USED"))
    if strict and used is not None and int(used) > len(kinds):
        raise PlateError(
            f"{path}: FORCE_PLATFORM:USED says {int(used)} plates but FORCE_PLATFORM:TYPE lists "
            f"{len(kinds)}: the plate set-up in the file is incomplete. Export the C3D again with "
            f"the force-plate set-up from your motion-capture software."
        )
    n = min(int(used), len(kinds)) if used is not None else len(kinds)
    point_unit = (_param(params, "POINT", "UNITS") or ["mm"])[0]
    pos = unit_scale(point_unit, path, "POINT:UNITS")
    out = []
    for i in range(n):
        kind = kinds[i]
        if kind not in SUPPORTED_TYPES:
            raise PlateError(
                f"Plate {i + 1} in {path} is of C3D force-plate type {kind}; gc_ocp reads types "
                f"{list(SUPPORTED_TYPES)}. Export the C3D again with type-2 or type-4 plates from "
                f"your motion-capture software (or give a TRC with --grf FILE.mot)."
            )
        out.append(_analog_reading(c, params, i, kind, pos, path, strict))
    return out


def _analog_reading(
    c, params: dict, i: int, kind: int, pos: float, path: Path, strict: bool = True
) -> dict:
    """One plate's reading computed from its analog channels (see :func:`_plate_readings`);
    ``{"number", "skip": why}`` for a plate whose corners are unusable and that is never loaded
    (or, not ``strict``, whatever its load)."""
    fp = params.get("FORCE_PLATFORM", {})
    try:
        channel = np.asarray(fp["CHANNEL"]["value"], dtype=int)[:, i] - 1
        corners = np.asarray(fp["CORNERS"]["value"], dtype=float)[:, :, i].T * pos
        origin = np.asarray(fp["ORIGIN"]["value"], dtype=float)[:, i] * pos
    except (KeyError, IndexError, ValueError) as exc:
        raise PlateError(
            f"Plate {i + 1} (type {kind}) in {path} lacks FORCE_PLATFORM:CHANNEL, CORNERS or "
            f"ORIGIN ({exc}): export the C3D again with the force-plate set-up from your "
            f"motion-capture software."
        ) from None
    k = N_CHANNELS[kind]
    analogs = np.asarray(c["data"]["analogs"], dtype=float)[0]
    if channel.size < k or channel[:k].max() >= analogs.shape[0] or channel[:k].min() < 0:
        raise PlateError(
            f"Plate {i + 1} (type {kind}) in {path}: FORCE_PLATFORM:CHANNEL {channel + 1} does not "
            f"name {k} of the {analogs.shape[0]} analog channels: fix the plate set-up in the file."
        )
    ch = analogs[channel[:k]].T.copy()  # (n, k), ezc3d applies ANALOG:SCALE/OFFSET/GEN_SCALE
    u = _param(params, "ANALOG", "UNITS")
    units = [str(x) for x in np.ravel(u if u is not None else [])]

    def unit_of(j: int) -> str:
        return units[channel[j]] if channel[j] < len(units) else ""

    def mom_scale(j: int) -> float:
        return _moment_scale(unit_of(j), pos, path, i + 1)

    cal = None
    if kind == 4:
        cal_all = np.asarray(fp.get("CAL_MATRIX", {}).get("value", []), dtype=float)
        if cal_all.ndim != 3 or cal_all.shape[:2] != (6, 6) or cal_all.shape[2] <= i:
            raise PlateError(
                f"Plate {i + 1} in {path} is of type 4 but FORCE_PLATFORM:CAL_MATRIX is not a "
                f"6 x 6 matrix per plate (shape {cal_all.shape}): export the C3D again."
            )
        ch = ch @ cal_all[:, :, i].T  # rows Fx Fy Fz Mx My Mz
        kind_eff = 2
    else:
        kind_eff = kind
    if kind in (1, 2):  # the forces as recorded (type 4: the calibration matrix makes them)
        for j in (0, 1, 2):
            ch[:, j] *= _force_scale(unit_of(j), path, i + 1)
    elif kind == 3:  # eight sensor forces: in a force unit when one is named, else N (as before)
        for j in range(8):
            ch[:, j] *= force_unit_scale(unit_of(j)) or 1.0
    if kind_eff == 1:
        for j in (3, 4):  # COP [m], each in its own unit
            ch[:, j] *= _length_scale(unit_of(j), pos)
        ch[:, 5] *= mom_scale(5)
    elif kind_eff == 2:
        for j in (3, 4, 5):
            ch[:, j] *= mom_scale(j)
    force, moment = plate_wrench(kind_eff, ch, origin, cal)
    bad = _corners_problem(corners)  # before the axes, which need usable corners
    if bad:
        loaded = np.nanmax(np.abs(np.nan_to_num(force[:, 2]))) > LOADED_N
        if strict and loaded:
            raise PlateError(
                f"Plate {i + 1} of {path} carries load but its FORCE_PLATFORM:CORNERS {bad}: "
                f"its forces cannot be placed in the lab. Fix the plate's corners in the file "
                f"(or export it again with the force-plate set-up)."
            )
        return {
            "number": i + 1,
            "skip": f"{'loaded' if loaded else 'never loaded'} but its corners {bad}",
        }
    axes = plate_axes(corners)
    return {
        "number": i + 1,
        "type": kind,
        "force": force @ axes.T,
        "moment": moment @ axes.T,
        "corners": corners,
        "origin": origin if kind in (2, 4) else None,
    }


LOADED_N = 50.0
"""A plate whose vertical force exceeds this [N] in absolute value carries someone (a few
per cent of an adult's weight; far above the plates' noise of ~1-5 N)."""


OFFSET_MAX_FRACTION = 0.5
"""An unloaded plate's offset (an amplifier's zero, a piezo plate's drift) is small against the
load a foot puts on it (the shared files: at most 32 N against ~600 N; a 200 N offset is still
recovered). On a plate whose reading changes by a load (:data:`LOADED_N`), a quiet stretch
whose level is more than this fraction of the largest change from it, and more than a load, is
someone standing on the plate for the whole file, not its zero: it is not subtracted (the
stance is then clipped: excluded, named). A plate whose reading never changes that much is
unloaded, and its level is its zero, however large."""


def _corners_problem(corners: np.ndarray) -> str:
    """What makes a plate's four corners unusable (``""`` if nothing): not finite, or not
    spanning a surface (coincident or collinear: the plate axes ``c1 - c2`` and ``c1 - c4``
    of :func:`~gc_ocp.io.plates.plate_axes` would not exist). A real plate is at least
    10 cm on a side, so a spanned area under 1 cm^2 is a broken set-up, not a small plate."""
    if not np.all(np.isfinite(corners)):
        return "are not numbers (NaN)"
    area = float(np.linalg.norm(np.cross(corners[0] - corners[1], corners[0] - corners[3])))
    if area < 1e-4:
        return f"do not span a surface (area {area * 1e4:.2g} cm^2: coincident or collinear)"
    return ""


def _negative_plates(fz: dict[str, np.ndarray], path: Path, strict: bool = True) -> bool:
    """Whether every loaded plate's vertical force (``fz``, by plate name) is negative while
    loaded (the file stores
    the force the subject exerts on the plate, a convention some writers use: the caller
    negates every plate). A file whose plates disagree (some negative, some positive) has a
    plate set up wrongly (a vertical channel's sign, ANALOG:SCALE, or a mirrored CORNERS
    order): an error naming the plates, since negating one plate's six channels would not
    undo a wrong sign of one of them."""
    signs = {}
    for name, f in fz.items():
        loaded = np.abs(np.nan_to_num(f)) > LOADED_N
        if loaded.any():
            signs[name] = float(np.median(f[loaded]))
    negative = [n for n, m in signs.items() if m < 0]
    if not negative or len(negative) == len(signs) or not strict:
        return bool(negative) and len(negative) == len(signs)
    positive = [n for n in signs if n not in negative]
    raise PlateError(
        f"In {path}, {', '.join(negative)} read a negative vertical force while loaded "
        f"(median {', '.join(f'{signs[n]:.0f}' for n in negative)} N) but "
        f"{', '.join(positive)} a positive one: the plates disagree, so the sign or scale of a "
        f"vertical channel (ANALOG:SCALE), its zero, or the order of FORCE_PLATFORM:CORNERS of "
        f"{', '.join(negative)} is wrong. Fix that plate's set-up in the file (or export it "
        f"again from your motion-capture software)."
    )


def read_c3d(path: Path, strict: bool = True) -> RawTrial:
    """Read markers, plates and subject data of a C3D file (SI, C3D global frame, Z up).
    ``strict=False`` (a static trial, whose plates only help find the vertical axis): a plate
    set-up that is wrong skips that plate instead of an error."""
    head = path.read_bytes()[:512]
    if len(head) == 512 and head[1] == 0x50:
        order = _byte_order(path, head)  # data-start word: a file cut before it stalls ezc3d
        start = int(np.frombuffer(head[16:18], dtype=f"{order}u2")[0])
        if start > 1 and path.stat().st_size < (start - 1) * 512 and start < 4096:
            raise InputError(
                f"{path}: the file ends ({path.stat().st_size} bytes) before its data section "
                f"(block {start}): the file is truncated or damaged. Copy or export it again "
                f"from your motion-capture software."
            )
    try:
        c = ezc3d.c3d(str(path))
    except Exception as exc:  # ezc3d raises plain RuntimeError/IOError
        raise InputError(
            f"Could not read {path} as a C3D file ({exc}); export it again as C3D from your "
            f"motion-capture software."
        ) from exc
    params = c["parameters"]
    announced = header_frames(path)
    n_read = int(np.asarray(c["data"]["points"]).shape[2])
    if announced is not None and n_read < announced:
        raise InputError(
            f"{path}: the header announces {announced} marker frames but only {n_read} could be "
            f"read: the file is truncated or damaged. Copy or export it again from your "
            f"motion-capture software."
        )

    # Markers ---------------------------------------------------------------------------
    labels = [str(s).strip() for s in (_param(params, "POINT", "LABELS") or [])]
    for extra in ("LABELS2", "LABELS3"):
        labels += [str(s).strip() for s in (_param(params, "POINT", extra) or [])]
    unit = (_param(params, "POINT", "UNITS") or ["mm"])[0]
    scale = unit_scale(unit, path, "POINT:UNITS")
    pts = np.asarray(c["data"]["points"], dtype=float)[:3]  # (3, n_points, n_frames)
    labels = labels[: pts.shape[1]]
    res = c["data"]["meta_points"]["residuals"][0] if "meta_points" in c["data"] else None
    drop = _model_outputs(params, labels)
    keep = [i for i, lab in enumerate(labels) if lab not in drop and lab]
    xyz = np.transpose(pts[:, keep, :], (2, 1, 0)).copy()  # (n_frames, n_markers, 3)
    if res is not None:
        xyz[np.asarray(res)[keep].T < 0] = np.nan  # C3D: residual < 0 = invalid point
    xyz = missing_as_nan(xyz)
    if scale == 1.0:
        check_metres(xyz, path, "Marker coordinates", unit)
    xyz *= scale
    check_body_span(xyz, path, unit, "POINT:UNITS")
    point_rate = float(c["header"]["points"]["frame_rate"])
    marker_time = np.arange(xyz.shape[0]) / point_rate
    names, prefix_note = without_subject_prefix([labels[i] for i in keep], path)

    # Plates ----------------------------------------------------------------------------
    plates: list[Plate] = []
    notes: list[str] = [prefix_note] if prefix_note else []
    analog_rate = float(c["header"]["analogs"]["frame_rate"])
    readings = []
    for r in _plate_readings(c, params, path, strict):
        if "skip" in r:
            notes.append(f"plate{r['number']}: {r['skip']}, skipped")
        else:
            readings.append(r)
    axis, sign, how = vertical_axis(
        [r["force"] for r in readings],
        [r["corners"] for r in readings],  # unusable corners were skipped
        xyz,
    )
    rot = up_to_lab(axis, sign)

    def to_lab(a: np.ndarray) -> np.ndarray:
        return a if (axis, sign) == (2, 1) else a @ rot.T

    screen = _screen_up(params)
    if (axis, sign) != (2, 1):
        xyz = to_lab(xyz)
        notes.append(
            f"the vertical axis of {path.name} is {'+' if sign > 0 else '-'}{AXIS_NAMES[axis]}, "
            f"not +Z (from {how}; markers above the plates): rotated to Z up"
        )
    if screen and screen != f"{'+' if sign > 0 else '-'}{AXIS_NAMES[axis]}":
        notes.append(
            f"POINT:Y_SCREEN of {path.name} says {screen} is up on screen, but the data say "
            f"{'+' if sign > 0 else '-'}{AXIS_NAMES[axis]} (gravity and the plates): the data win"
        )
    kept = []
    for r in readings:
        name = f"plate{r['number']}"
        force = to_lab(r["force"])
        moment_c = to_lab(r["moment"])
        corners = to_lab(r["corners"])
        if not np.isfinite(force).any():
            notes.append(f"{name}: no data, skipped")
            continue
        centre = corners.mean(axis=0)
        if r["origin"] is None:  # types 1 and 3: the wrench is given about the surface centre
            reference, kind = centre, "surface_center"
        else:
            offset = plate_axes(corners) @ r["origin"]
            if offset[2] > 0:  # electrical centre must be below the surface
                offset = -offset
            reference, kind = centre + offset, "electrical_center"
        base, t_unloaded = unloaded_baseline(np.hstack([force, moment_c]), analog_rate)
        removed = t_unloaded >= 0.1
        swing = float(np.nanmax(np.abs(force[:, 2] - base[2])))
        if (
            removed
            and swing > LOADED_N
            and abs(base[2]) > max(OFFSET_MAX_FRACTION * swing, LOADED_N)
        ):
            warn(
                f"{name} of {path}: its quietest stretch reads {base[2]:.0f} N against loads of "
                f"{swing:.0f} N above it: a load, not an unloaded offset (the plate is never "
                f"unloaded in this file); offset not removed."
            )
            removed = False
        if not removed:
            if t_unloaded < 0.1:
                warn(f"{name} of {path}: no unloaded stretch >= 0.1 s; offset not removed.")
            base = np.zeros(6)
        elif np.any(base != 0.0):  # a plate the lab zeroed reads exactly 0: nothing to say
            notes.append(
                f"{name}: removed unloaded offset (file axes) F={np.round(base[:3], 1).tolist()} N "
                f"(median over {t_unloaded:.2f} s unloaded)"
            )
        force = force - base[:3]
        moment_c = moment_c - base[3:]
        kept.append((r, name, force, moment_c, corners, centre, reference, kind, base, removed))
    flip = _negative_plates({name: f[:, 2] for _, name, f, *_ in kept}, path, strict)
    if flip:
        notes.append(
            f"the plates of {path.name} store the force on the plate (vertical force negative "
            f"while loaded): negated to the ground reaction on the subject"
        )
    for r, name, force, moment_c, corners, centre, reference, kind, base, removed in kept:
        if flip:
            force, moment_c, base = -force, -moment_c, -base
        moment_e = transport_moment(force, moment_c, centre, reference)
        plates.append(
            Plate(
                name=name,
                time=np.arange(force.shape[0]) / analog_rate,
                force=force,
                moment=moment_e,
                reference_point=reference,
                reference_kind=kind,
                corners=corners,
                surface_height=float(centre[2]),
                plate_type=f"C3D type {r['type']}",
                zero_offset=base if removed else None,
            )
        )
    if not plates and strict:  # a static trial needs none (its vertical axis: Z kept)
        raise PlateError(
            f"{path} has no force plates (FORCE_PLATFORM group empty or unusable): the contact "
            f"model is estimated from measured ground reactions, so give a trial recorded with "
            f"force plates (or a TRC with --grf FILE.mot)."
        )

    # Subject ---------------------------------------------------------------------------
    mass = height = None
    mass_source = height_source = ""
    for group in ("PROCESSING", "SUBJECTS", "SUBJECT"):
        g = params.get(group, {})
        for key in g:
            if mass is None and key.upper() in ("BODYMASS", "MASS", "WEIGHT"):
                v = _first_number(g[key]["value"])
                if v is not None and v > 0:
                    mass, mass_source = v, f"{group}:{key} in {path.name}"
            if height is None and key.upper() in ("HEIGHT", "BODYHEIGHT"):
                v = _first_number(g[key]["value"])
                if v is not None and v > 0:
                    height = _height_m(v)  # Vicon stores mm, other writers cm or m
                    height_source = f"{group}:{key} in {path.name}"
    return RawTrial(
        source=path,
        marker_names=names,
        markers=xyz,
        marker_time=marker_time,
        plates=plates,
        mass=mass,
        height=height,
        mass_source=mass_source,
        height_source=height_source,
        file_rotation=rot,
        notes=notes,
    )
