"""C3D fuzzing of gc_ocp: realistic damage / lab variations of real C3D files
(``docs/quality.md``, *C3D files: damaged, relabelled and from other set-ups*; written by a
helper session on 2026-11-30, output ``benchmarks/c3d_fuzz_output.md`` from ``summary``).

Usage (always one process at a time, OPENBLAS_NUM_THREADS=1):
    python benchmarks/c3d_fuzz.py list        # the cases
    python benchmarks/c3d_fuzz.py summary     # results.jsonl's last info per case, markdown
    python benchmarks/c3d_fuzz.py gen NAME... # only write cases/NAME.c3d
    python benchmarks/c3d_fuzz.py run all     # gen + `gc_ocp.cli info` (+ API comparison vs clean)
    python benchmarks/c3d_fuzz.py fit NAME... # gen + `gc_ocp.cli fit` (+ fit.json numbers)
Results are appended to results.jsonl in GC_OCP_FUZZ_DIR (default: a folder in the temporary
directory; one JSON line per run).

Each case is ``NAME: (generator, source, kwargs)``; a generator is a plain function
``gen_xxx(src, out, **kw)`` that reads ``src`` (ezc3d, or raw bytes for parameter patches),
applies ONE damage/variation and writes ``out``. Reproduce one case by hand, e.g.:
    python -c "import c3d_fuzz as f; f.gen_units_m(f.SRC['small'], '/tmp/x.c3d', plates=True)"
"""

from __future__ import annotations

import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import ezc3d
import numpy as np

REPO = Path(__file__).resolve().parents[1]
HERE = Path(os.environ.get("GC_OCP_FUZZ_DIR", Path(tempfile.gettempdir()) / "gc_ocp_c3d_fuzz"))
"""Where the cases, fits and ``results.jsonl`` go (the damaged files are not committed)."""
CASES_DIR = HERE / "cases"
FITS_DIR = HERE / "fits"
PY = sys.executable
ENV = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(REPO))
D = str(REPO.parent / "shared" / "data")
SRC = {
    "small": f"{D}/plugingait_overground/test_small.c3d",  # Vicon, float, 4 type-2 plates, Z up
    "pig": f"{D}/vicon_plugingait_btk/PiG_Motion3_FF.c3d",  # Vicon, float, 3 type-2 plates
    "gait": f"{D}/motionanalysis_helenhayes/Gait.c3d",  # DEC int, 2 type-4 plates, no mass
    "t2a": f"{D}/c3dorg_helenhayes_types/type-2a.c3d",  # DEC int, type 2, no mass
    "t4a": f"{D}/c3dorg_helenhayes_types/type-4a.c3d",  # DEC int, type 4, no mass
    "bts": f"{D}/bts_unipd_5trials/Walking1.c3d",  # BTS, float, type 1, Y up, no mass
    "fw": f"{D}/vicon_plugingait_clusters/FunctionalWalk.c3d",  # float, unsigned analog
}


# ------------------------------------------------------------------------------------------
# helpers (ezc3d)
# ------------------------------------------------------------------------------------------
def load(src):
    return ezc3d.c3d(str(src))


def save(c, out):
    c.write(str(out))
    return out


def labels(c):
    return [str(s).strip() for s in c["parameters"]["POINT"]["LABELS"]["value"]]


def idx(c, name):
    return labels(c).index(name)


def fp(c, key):
    return np.array(c["parameters"]["FORCE_PLATFORM"][key]["value"])


def set_param(c, group, name, value):
    c["parameters"][group][name]["value"] = value


def plate_channels(c, plate):
    """0-based analog channel indices of a plate."""
    return fp(c, "CHANNEL")[:, plate].astype(int) - 1


def select_points(c, keep):
    """Keep only the point indices ``keep`` (labels, data, residuals, masks)."""
    lab = c["parameters"]["POINT"]["LABELS"]["value"]
    c["parameters"]["POINT"]["LABELS"]["value"] = [lab[i] for i in keep]
    c["data"]["points"] = c["data"]["points"][:, keep, :]
    mp = c["data"]["meta_points"]
    mp["residuals"] = mp["residuals"][:, keep, :]
    mp["camera_masks"] = mp["camera_masks"][:, keep, :]
    if "DESCRIPTIONS" in c["parameters"]["POINT"]:
        d = c["parameters"]["POINT"]["DESCRIPTIONS"]["value"]
        if len(d) == len(lab):
            c["parameters"]["POINT"]["DESCRIPTIONS"]["value"] = [d[i] for i in keep]


def select_frames(c, sl_frames):
    """Keep marker frames ``sl_frames`` (a slice with step 1) and the analog samples with them."""
    n = c["data"]["points"].shape[2]
    na = c["data"]["analogs"].shape[2]
    ratio = na // n
    a, b, _ = sl_frames.indices(n)
    c["data"]["points"] = c["data"]["points"][:, :, a:b]
    mp = c["data"]["meta_points"]
    mp["residuals"] = mp["residuals"][:, :, a:b]
    mp["camera_masks"] = mp["camera_masks"][:, :, a:b]
    c["data"]["analogs"] = c["data"]["analogs"][:, :, a * ratio : b * ratio]


# ------------------------------------------------------------------------------------------
# helpers (raw parameter patching: for what ezc3d's writer abstracts away, SCALE/OFFSET)
# ------------------------------------------------------------------------------------------
def _dec_to_float(b):
    return struct.unpack("<f", b[2:4] + b[0:2])[0] / 4.0


def _float_to_dec(x):
    b = struct.pack("<f", x * 4.0)
    return b[2:4] + b[0:2]


def raw_params(data: bytes):
    """{(GROUP, PARAM): dict(type, dims, offset)} of a C3D's parameter section; 'proc'."""
    start = (data[0] - 1) * 512
    proc = data[start + 3]
    big = proc == 86
    i16 = ">h" if big else "<h"
    groups, params = {}, {}
    pos = start + 4
    while True:
        nchar = struct.unpack("b", data[pos : pos + 1])[0]
        if nchar == 0:
            break
        gid = struct.unpack("b", data[pos + 1 : pos + 2])[0]
        n = abs(nchar)
        name = data[pos + 2 : pos + 2 + n].decode("latin-1").upper()
        opos = pos + 2 + n
        nxt = struct.unpack(i16, data[opos : opos + 2])[0]
        if gid < 0:
            groups[-gid] = name
        else:
            t = struct.unpack("b", data[opos + 2 : opos + 3])[0]
            nd = data[opos + 3]
            dims = list(data[opos + 4 : opos + 4 + nd])
            params[(gid, name)] = dict(type=t, dims=dims, offset=opos + 4 + nd)
        if nxt == 0:
            break
        pos = opos + nxt
    out = {(groups.get(g, str(g)), n): v for (g, n), v in params.items()}
    return out, proc


def raw_set(data: bytearray, group, name, index, value):
    """Overwrite element ``index`` of a numeric parameter in place (same storage type)."""
    params, proc = raw_params(bytes(data))
    p = params[(group, name)]
    t, off = p["type"], p["offset"]
    big = proc == 86
    if t == 4:
        o = off + 4 * index
        if proc == 85:
            data[o : o + 4] = _float_to_dec(value)
        else:
            data[o : o + 4] = struct.pack(">f" if big else "<f", value)
    elif t == 2:
        o = off + 2 * index
        data[o : o + 2] = struct.pack(">h" if big else "<h", int(value))
    elif t == 1:
        data[off + index] = int(value) & 0xFF
    else:
        raise ValueError(f"{group}:{name} is not numeric (type {t})")


def raw_get(data: bytes, group, name, index):
    params, proc = raw_params(bytes(data))
    p = params[(group, name)]
    t, off = p["type"], p["offset"]
    big = proc == 86
    if t == 4:
        b = data[off + 4 * index : off + 4 * index + 4]
        return _dec_to_float(b) if proc == 85 else struct.unpack(">f" if big else "<f", b)[0]
    if t == 2:
        return struct.unpack(">h" if big else "<h", data[off + 2 * index : off + 2 * index + 2])[0]
    return data[off + index]


def header_scale_set(data: bytearray, value):
    proc = data[(data[0] - 1) * 512 + 3]
    if proc == 85:
        data[12:16] = _float_to_dec(value)
    else:
        data[12:16] = struct.pack(">f" if proc == 86 else "<f", value)


# ------------------------------------------------------------------------------------------
# generators: ONE damage or variation each
# ------------------------------------------------------------------------------------------
def gen_identity(src, out):
    """ezc3d read + write, nothing changed (the writer's own effect; baseline for fits)."""
    return save(load(src), out)


def gen_copy(src, out):
    """Byte copy of the original."""
    shutil.copy(src, out)
    return out


# 1. units ------------------------------------------------------------------------------
def gen_units_m(src, out, plates=True, values=True):
    """POINT:UNITS 'm'. values: coordinates /1000; plates: CORNERS/ORIGIN /1000 too."""
    c = load(src)
    set_param(c, "POINT", "UNITS", ["m"])
    if values:
        c["data"]["points"][:3] /= 1000.0
    if plates:
        set_param(c, "FORCE_PLATFORM", "CORNERS", fp(c, "CORNERS") / 1000.0)
        set_param(c, "FORCE_PLATFORM", "ORIGIN", fp(c, "ORIGIN") / 1000.0)
    return save(c, out)


def gen_units_label(src, out, unit="mm", factor=1.0):
    """POINT:UNITS set to ``unit`` and coordinates x ``factor`` (plates unchanged)."""
    c = load(src)
    set_param(c, "POINT", "UNITS", [unit])
    c["data"]["points"][:3] *= factor
    return save(c, out)


# 2. POINT:SCALE (raw patch) --------------------------------------------------------------
def gen_point_scale(src, out, factor=-1.0, header=True):
    """POINT:SCALE multiplied by ``factor`` in the raw parameter (and the header copy)."""
    data = bytearray(Path(src).read_bytes())
    s = raw_get(data, "POINT", "SCALE", 0)
    raw_set(data, "POINT", "SCALE", 0, s * factor)
    if header:
        header_scale_set(data, s * factor)
    Path(out).write_bytes(bytes(data))
    return out


# 3. analog rate --------------------------------------------------------------------------
def gen_analog_ratio(src, out, ratio_factor=2.0):
    """Analogs resampled to ratio x ``ratio_factor`` samples per frame (repeat or decimate)."""
    c = load(src)
    a = c["data"]["analogs"]
    n = c["data"]["points"].shape[2]
    r = a.shape[2] // n
    new_r = int(round(r * ratio_factor))
    if ratio_factor >= 1:
        a2 = np.repeat(a, int(round(ratio_factor)), axis=2)
    else:
        step = int(round(1 / ratio_factor))
        a2 = a[:, :, ::step]
    c["data"]["analogs"] = a2[:, :, : n * new_r]
    rate = float(c["parameters"]["POINT"]["RATE"]["value"][0])
    set_param(c, "ANALOG", "RATE", np.array([rate * new_r]))
    return save(c, out)


# 4. corners/origin ------------------------------------------------------------------------
def gen_corners(src, out, order=(3, 0, 1, 2), plates=None):
    """FORCE_PLATFORM:CORNERS re-ordered: new corner j = old corner order[j]."""
    c = load(src)
    cor = fp(c, "CORNERS")
    plates = range(cor.shape[2]) if plates is None else plates
    for p in plates:
        cor[:, :, p] = cor[:, list(order), p]
    set_param(c, "FORCE_PLATFORM", "CORNERS", cor)
    return save(c, out)


def gen_origin(src, out, sign=(-1, -1, -1), plates=None):
    """FORCE_PLATFORM:ORIGIN components multiplied by ``sign``."""
    c = load(src)
    o = fp(c, "ORIGIN").astype(float)
    plates = range(o.shape[1]) if plates is None else plates
    for p in plates:
        o[:, p] *= np.asarray(sign, float)
    set_param(c, "FORCE_PLATFORM", "ORIGIN", o)
    return save(c, out)


# 5. plate type ------------------------------------------------------------------------------
def gen_type2_to_4(src, out, gains=(2.0, 2.0, 4.0, 100.0, 100.0, 50.0)):
    """Type-2 plates stored as type 4: channels = wrench / gain, CAL_MATRIX = diag(gain)
    (consistent: the same wrench)."""
    c = load(src)
    t = fp(c, "TYPE")
    n = len(t)
    g = np.asarray(gains, float)
    cal = np.zeros((6, 6, n))
    for p in range(n):
        if t[p] != 2:
            continue
        ch = plate_channels(c, p)
        c["data"]["analogs"][0, ch, :] /= g[:, None]
        cal[:, :, p] = np.diag(g)
    set_param(c, "FORCE_PLATFORM", "TYPE", np.where(t == 2, 4, t))
    c.add_parameter("FORCE_PLATFORM", "CAL_MATRIX", cal)
    return save(c, out)


def gen_type4_to_2(src, out):
    """Type-4 plates stored as type 2: channels = CAL @ raw (consistent)."""
    c = load(src)
    t = fp(c, "TYPE")
    cal = fp(c, "CAL_MATRIX")
    for p in range(len(t)):
        if t[p] != 4:
            continue
        ch = plate_channels(c, p)
        raw = c["data"]["analogs"][0, ch, :]
        c["data"]["analogs"][0, ch, :] = cal[:, :, p] @ raw
    set_param(c, "FORCE_PLATFORM", "TYPE", np.where(t == 4, 2, t))
    del c["parameters"]["FORCE_PLATFORM"]["CAL_MATRIX"]
    return save(c, out)


def gen_type_label(src, out, new_type=4, drop_cal=False, plates=None):
    """FORCE_PLATFORM:TYPE relabelled (data untouched): damage."""
    c = load(src)
    t = fp(c, "TYPE").copy()
    plates = range(len(t)) if plates is None else plates
    for p in plates:
        t[p] = new_type
    set_param(c, "FORCE_PLATFORM", "TYPE", t)
    if drop_cal and "CAL_MATRIX" in c["parameters"]["FORCE_PLATFORM"]:
        del c["parameters"]["FORCE_PLATFORM"]["CAL_MATRIX"]
    return save(c, out)


# 6. analog gains ----------------------------------------------------------------------------
def gen_channel_gain(src, out, plate=0, comp=2, factor=-1.0):
    """One plate channel (comp 0..5 = Fx..Mz) x ``factor`` in the data (what a wrong ANALOG:SCALE
    does; ezc3d's writer cannot store a changed SCALE for float data)."""
    c = load(src)
    ch = plate_channels(c, plate)[comp]
    c["data"]["analogs"][0, ch, :] *= factor
    return save(c, out)


def gen_channel_offset(src, out, plate=0, comp=2, offset=200.0):
    """A constant offset on one plate channel (unzeroed amplifier / nonzero ANALOG:OFFSET)."""
    c = load(src)
    ch = plate_channels(c, plate)[comp]
    c["data"]["analogs"][0, ch, :] += offset
    return save(c, out)


def gen_raw_analog(src, out, param="SCALE", index=2, factor=None, value=None):
    """Raw patch of ANALOG:SCALE/OFFSET/GEN_SCALE element ``index`` (x factor or = value)."""
    data = bytearray(Path(src).read_bytes())
    v = raw_get(data, "ANALOG", param, index)
    raw_set(data, "ANALOG", param, index, v * factor if factor is not None else value)
    Path(out).write_bytes(bytes(data))
    return out


# 7. plate set-up -------------------------------------------------------------------------------
def gen_no_fp_group(src, out):
    c = load(src)
    del c["parameters"]["FORCE_PLATFORM"]
    return save(c, out)


def gen_fp_used(src, out, used=0):
    c = load(src)
    set_param(c, "FORCE_PLATFORM", "USED", np.array([used]))
    return save(c, out)


def gen_channel_swap(src, out, plate=0, a=0, b=1):
    """FORCE_PLATFORM:CHANNEL entries a and b of one plate swapped (e.g. Fx<->Fy)."""
    c = load(src)
    ch = fp(c, "CHANNEL").copy()
    ch[a, plate], ch[b, plate] = ch[b, plate], ch[a, plate]
    set_param(c, "FORCE_PLATFORM", "CHANNEL", ch)
    return save(c, out)


def gen_channel_set(src, out, plate=0, values=None, copy_from=None):
    """FORCE_PLATFORM:CHANNEL of one plate set to ``values`` (1-based) or another plate's."""
    c = load(src)
    ch = fp(c, "CHANNEL").copy()
    ch[:, plate] = ch[:, copy_from] if copy_from is not None else values
    set_param(c, "FORCE_PLATFORM", "CHANNEL", ch)
    return save(c, out)


def gen_same_corners(src, out, plate=1, like=0, origin_too=True):
    """Plate ``plate`` given the CORNERS (and ORIGIN) of plate ``like`` (copy-paste error)."""
    c = load(src)
    cor = fp(c, "CORNERS")
    cor[:, :, plate] = cor[:, :, like]
    set_param(c, "FORCE_PLATFORM", "CORNERS", cor)
    if origin_too:
        o = fp(c, "ORIGIN").astype(float)
        o[:, plate] = o[:, like]
        set_param(c, "FORCE_PLATFORM", "ORIGIN", o)
    return save(c, out)


def gen_swap_plate_positions(src, out, a=0, b=1):
    """CORNERS and ORIGIN of plates a and b swapped (the forces appear under the other foot)."""
    c = load(src)
    cor = fp(c, "CORNERS")
    cor[:, :, [a, b]] = cor[:, :, [b, a]]
    set_param(c, "FORCE_PLATFORM", "CORNERS", cor)
    o = fp(c, "ORIGIN").astype(float)
    o[:, [a, b]] = o[:, [b, a]]
    set_param(c, "FORCE_PLATFORM", "ORIGIN", o)
    return save(c, out)


# 8. markers ------------------------------------------------------------------------------------
def gen_labels(src, out, how="prefix", arg="Bob:"):
    """Rename every POINT label: prefix / lower / lead (leading spaces) / suffix."""
    c = load(src)
    lab = [str(s).strip() for s in c["parameters"]["POINT"]["LABELS"]["value"]]
    f = {
        "prefix": lambda s: arg + s,
        "lower": lambda s: s.lower(),
        "lead": lambda s: "  " + s,
        "suffix": lambda s: s + arg,
    }[how]
    c["parameters"]["POINT"]["LABELS"]["value"] = [f(s) for s in lab]
    return save(c, out)


def gen_rename(src, out, mapping=None):
    """Rename individual labels (e.g. swap LHEE<->RHEE)."""
    c = load(src)
    lab = [str(s).strip() for s in c["parameters"]["POINT"]["LABELS"]["value"]]
    c["parameters"]["POINT"]["LABELS"]["value"] = [mapping.get(s, s) for s in lab]
    return save(c, out)


def gen_drop_marker(src, out, names=("LHEE",)):
    c = load(src)
    lab = labels(c)
    keep = [i for i, s in enumerate(lab) if s not in names]
    select_points(c, keep)
    return save(c, out)


def gen_marker_zero(src, out, names=("LHEE",), residual=-1.0, frames=None):
    """Markers set to (0,0,0) with residual ``residual`` (Vicon gap convention) in ``frames``
    (slice; None = all)."""
    c = load(src)
    sl = slice(None) if frames is None else frames
    for nm in names:
        for i in [i for i, s in enumerate(labels(c)) if s == nm]:
            c["data"]["points"][:3, i, sl] = 0.0
            c["data"]["meta_points"]["residuals"][0, i, sl] = residual
    return save(c, out)


def gen_marker_nan(src, out, names=None, frames=None):
    """Markers set to NaN (residual kept): names None = every marker."""
    c = load(src)
    sl = slice(None) if frames is None else frames
    ids = (
        range(len(labels(c)))
        if names is None
        else [i for i, s in enumerate(labels(c)) if s in names]
    )
    for i in ids:
        c["data"]["points"][:3, i, sl] = np.nan
    return save(c, out)


def gen_marker_offset(src, out, names=("RHEE",), delta=(0.0, 0.0, 100.0)):
    """A constant offset [file units] on markers (a marker stuck on the wrong place)."""
    c = load(src)
    for nm in names:
        i = idx(c, nm)
        c["data"]["points"][:3, i, :] += np.asarray(delta, float)[:, None]
    return save(c, out)


# 9. frames --------------------------------------------------------------------------------------
def gen_truncate(src, out, n=20, start=0):
    c = load(src)
    select_frames(c, slice(start, start + n))
    return save(c, out)


def gen_plate_zero(src, out, plate=0, t0=None, t1=None, frac=(0.4, 0.6)):
    """All channels of one plate set to 0 for analog samples [t0, t1) s (None: a fraction of the
    file ``frac``)."""
    c = load(src)
    ch = plate_channels(c, plate)
    a = c["data"]["analogs"]
    rate = float(c["header"]["analogs"]["frame_rate"])
    n = a.shape[2]
    i0 = int(t0 * rate) if t0 is not None else int(frac[0] * n)
    i1 = int(t1 * rate) if t1 is not None else int(frac[1] * n)
    a[0, ch, i0:i1] = 0.0
    return save(c, out)


def gen_first_frame(src, out, first=1000, asf=True):
    """Header first frame moved (and TRIAL:ACTUAL_START_FIELD with it if ``asf``)."""
    c = load(src)
    c["header"]["points"]["first_frame"] = first
    if asf and "TRIAL" in c["parameters"] and "ACTUAL_START_FIELD" in c["parameters"]["TRIAL"]:
        set_param(c, "TRIAL", "ACTUAL_START_FIELD", np.array([first + 1, 0]))
    return save(c, out)


def gen_trial_asf(src, out, value=5000):
    """Only TRIAL:ACTUAL_START_FIELD changed (disagrees with the header)."""
    c = load(src)
    if "TRIAL" not in c["parameters"]:
        c.add_parameter("TRIAL", "ACTUAL_START_FIELD", np.array([value, 0]))
    else:
        set_param(c, "TRIAL", "ACTUAL_START_FIELD", np.array([value, 0]))
    return save(c, out)


# 10. lab rotation --------------------------------------------------------------------------------
def _rot(axis, deg):
    a = np.deg2rad(deg)
    c, s = np.cos(a), np.sin(a)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def gen_rotate_lab(src, out, axis="x", deg=-90.0, screen=None, shift=(0.0, 0.0, 0.0)):
    """The whole lab rotated: markers and plate corners (ORIGIN and analog channels are in plate
    axes, which follow the corners). Rx(-90): Z up -> Y up. ``shift``: also translate [file units].
    ``screen``: (X_SCREEN, Y_SCREEN) to store, None = leave as is."""
    c = load(src)
    R = np.round(_rot(axis, deg), 12)
    p = c["data"]["points"]
    p[:3] = np.einsum("ij,jkl->ikl", R, p[:3]) + np.asarray(shift, float)[:, None, None]
    # zeros (occluded) must stay zeros: rotation keeps 0 -> 0 but the shift does not
    if np.any(shift):
        z = np.all(c["data"]["points"][:3] == np.asarray(shift, float)[:, None, None], axis=0)
        c["data"]["points"][:3, z] = 0.0
    cor = fp(c, "CORNERS")
    cor = np.einsum("ij,jkl->ikl", R, cor) + np.asarray(shift, float)[:, None, None]
    set_param(c, "FORCE_PLATFORM", "CORNERS", cor)
    if screen is not None:
        set_param(c, "POINT", "X_SCREEN", [screen[0]])
        set_param(c, "POINT", "Y_SCREEN", [screen[1]])
    return save(c, out)


def gen_mirror_lab(src, out, axis=1):
    """Lab mirrored (a left-handed file: one axis negated in markers and corners)."""
    c = load(src)
    c["data"]["points"][axis] *= -1
    cor = fp(c, "CORNERS")
    cor[axis] *= -1
    set_param(c, "FORCE_PLATFORM", "CORNERS", cor)
    return save(c, out)


# misc ----------------------------------------------------------------------------------------------
def gen_mass(src, out, value=140.0, key="Bodymass", group="PROCESSING"):
    c = load(src)
    if group in c["parameters"] and key in c["parameters"][group]:
        set_param(c, group, key, np.array([value]))
    else:
        c.add_parameter(group, key, np.array([value]))
    return save(c, out)


def gen_point_rate(src, out, rate=120.0):
    """POINT:RATE (and ANALOG:RATE with it) mislabelled; data untouched."""
    c = load(src)
    old = float(c["parameters"]["POINT"]["RATE"]["value"][0])
    set_param(c, "POINT", "RATE", np.array([rate]))
    ar = float(c["parameters"]["ANALOG"]["RATE"]["value"][0])
    set_param(c, "ANALOG", "RATE", np.array([ar * rate / old]))
    return save(c, out)


def gen_analog_units(src, out, unit="Nm", plate=None, factor=1.0, metres=False):
    """ANALOG:UNITS of moment channels set to ``unit``, their data x ``factor`` (1: untouched).
    metres: also POINT:UNITS 'm' with coordinates, CORNERS and ORIGIN /1000 (a fully SI file)."""
    c = load(src)
    if metres:
        set_param(c, "POINT", "UNITS", ["m"])
        c["data"]["points"][:3] /= 1000.0
        set_param(c, "FORCE_PLATFORM", "CORNERS", fp(c, "CORNERS") / 1000.0)
        set_param(c, "FORCE_PLATFORM", "ORIGIN", fp(c, "ORIGIN") / 1000.0)
    u = list(c["parameters"]["ANALOG"]["UNITS"]["value"])
    t = fp(c, "TYPE")
    plates = range(len(t)) if plate is None else [plate]
    for p in plates:
        for j in plate_channels(c, p)[3:6]:
            u[j] = unit
            c["data"]["analogs"][0, j, :] *= factor
    c["parameters"]["ANALOG"]["UNITS"]["value"] = u
    return save(c, out)


# ------------------------------------------------------------------------------------------
# the cases
# ------------------------------------------------------------------------------------------
R = "right"
CASES = {}


def case(name, gen, src, fit=False, **kw):
    CASES[name] = dict(gen=gen, src=src, kw=kw, fit=fit)


for s in SRC:
    case(f"{s}__identity", gen_identity, s, fit=s in ("small", "pig", "gait", "bts", "t2a"))
# 1
case("small__units_m", gen_units_m, "small", fit=True)
case("gait__units_m", gen_units_m, "gait")
case("bts__units_m", gen_units_m, "bts", fit=True)
case("small__units_m_markers_only", gen_units_m, "small", plates=False)
case("small__units_m_label_only", gen_units_m, "small", plates=False, values=False)
case("small__units_m_label_plates_scaled", gen_units_m, "small", plates=True, values=False)
case("small__units_mm_values_m", gen_units_label, "small", unit="mm", factor=0.001)
case("small__units_cm", gen_units_label, "small", unit="cm", factor=0.1)
case("small__units_millimeters", gen_units_label, "small", unit="millimeters")
case("small__units_blank", gen_units_label, "small", unit="")
# 2
case("small__pscale_mag", gen_point_scale, "small", factor=100.0)
case("small__pscale_sign", gen_point_scale, "small", factor=-1.0)
case("gait__pscale_x10", gen_point_scale, "gait", factor=10.0)
case("gait__pscale_sign", gen_point_scale, "gait", factor=-1.0)
case("gait__pscale_sign_param_only", gen_point_scale, "gait", factor=-1.0, header=False)
# 3
case("small__analog_x2", gen_analog_ratio, "small", ratio_factor=2.0, fit=True)
case("small__analog_half", gen_analog_ratio, "small", ratio_factor=0.5)
case("small__analog_ratio1", gen_analog_ratio, "small", ratio_factor=0.1)
case("pig__analog_half", gen_analog_ratio, "pig", ratio_factor=0.5)
case("t2a__analog_x2", gen_analog_ratio, "t2a", ratio_factor=2.0)
case("bts__analog_x2", gen_analog_ratio, "bts", ratio_factor=2.0)
# 4
case("small__corners_rot", gen_corners, "small", order=(3, 0, 1, 2), fit=True)
case("small__corners_rot_back", gen_corners, "small", order=(1, 2, 3, 0))
case("small__corners_mirror", gen_corners, "small", order=(3, 2, 1, 0), fit=True)
case("small__corners_mirror2", gen_corners, "small", order=(1, 0, 3, 2))
case("pig__corners_rot", gen_corners, "pig", order=(3, 0, 1, 2))
case("t2a__corners_mirror", gen_corners, "t2a", order=(3, 2, 1, 0))
case("bts__corners_rot", gen_corners, "bts", order=(3, 0, 1, 2))
case("bts__corners_mirror", gen_corners, "bts", order=(3, 2, 1, 0))
case("small__origin_neg", gen_origin, "small", sign=(-1, -1, -1), fit=True)
case("small__origin_negz", gen_origin, "small", sign=(1, 1, -1))
case("pig__origin_neg", gen_origin, "pig", sign=(-1, -1, -1))
case("t2a__origin_neg", gen_origin, "t2a", sign=(-1, -1, -1))
case("gait__origin_neg", gen_origin, "gait", sign=(-1, -1, -1))
case("t4a__origin_neg", gen_origin, "t4a", sign=(-1, -1, -1))
# 5
case("small__type2to4", gen_type2_to_4, "small", fit=True)
case("pig__type2to4", gen_type2_to_4, "pig")
case("t4a__type4to2", gen_type4_to_2, "t4a")
case("gait__type4to2", gen_type4_to_2, "gait")
case("small__type_label4_nocal", gen_type_label, "small", new_type=4, drop_cal=True)
case("t2a__type_label4", gen_type_label, "t2a", new_type=4)  # t2a has a CAL_MATRIX
case("t4a__type_label2", gen_type_label, "t4a", new_type=2)
case("small__type_label1", gen_type_label, "small", new_type=1)
case("small__type_label3", gen_type_label, "small", new_type=3)
case("bts__type_label2", gen_type_label, "bts", new_type=2)
case("small__type_label5", gen_type_label, "small", new_type=5)
# 6
case("small__fz_neg", gen_channel_gain, "small", plate=0, comp=2, factor=-1.0, fit=True)
case("small__fz_x10", gen_channel_gain, "small", plate=0, comp=2, factor=10.0)
case("small__fx_neg", gen_channel_gain, "small", plate=0, comp=0, factor=-1.0, fit=True)
case("small__mx_x10", gen_channel_gain, "small", plate=0, comp=3, factor=10.0)
case("gait__fz_x10", gen_channel_gain, "gait", plate=1, comp=2, factor=10.0)
case("gait__fz_neg", gen_channel_gain, "gait", plate=1, comp=2, factor=-1.0)
case("bts__fz_neg", gen_channel_gain, "bts", plate=0, comp=2, factor=-1.0)
case("small__fz_offset", gen_channel_offset, "small", plate=0, comp=2, offset=200.0)
case("t2a__raw_scale_neg_fz", gen_raw_analog, "t2a", param="SCALE", index=2, factor=-1.0)
case("t2a__raw_scale_x10_fz", gen_raw_analog, "t2a", param="SCALE", index=2, factor=10.0)
case("t2a__raw_offset", gen_raw_analog, "t2a", param="OFFSET", index=2, value=1900)
case("t2a__raw_genscale", gen_raw_analog, "t2a", param="GEN_SCALE", index=0, value=10.0)
case("gait__raw_genscale_neg", gen_raw_analog, "gait", param="GEN_SCALE", index=0, value=-1.0)
case("small__raw_scale_neg_fz", gen_raw_analog, "small", param="SCALE", index=2, factor=-1.0)
case("small__raw_genscale", gen_raw_analog, "small", param="GEN_SCALE", index=0, value=10.0)
case("small__moment_units_Nm", gen_analog_units, "small", unit="Nm")
case("small__moment_units_V", gen_analog_units, "small", unit="V")
case("small__moment_Nm_values", gen_analog_units, "small", unit="Nm", factor=0.001)
case("small__si_m_Nm", gen_analog_units, "small", unit="Nm", factor=0.001, metres=True, fit=True)
case("pig__units_m", gen_units_m, "pig")
# 7
case("small__no_fp_group", gen_no_fp_group, "small")
case("small__fp_used0", gen_fp_used, "small", used=0)
case("small__fp_used9", gen_fp_used, "small", used=9)
case("small__chan_swap_fxfy", gen_channel_swap, "small", plate=0, a=0, b=1, fit=True)
case("small__chan_swap_fzmz", gen_channel_swap, "small", plate=0, a=2, b=5)
case("small__chan_copy_p2", gen_channel_set, "small", plate=0, copy_from=1)
case(
    "small__chan_out_of_range",
    gen_channel_set,
    "small",
    plate=0,
    values=[97, 98, 99, 100, 101, 102],
)
case("small__chan_zero", gen_channel_set, "small", plate=0, values=[0, 0, 0, 0, 0, 0])
case("bts__chan_out_of_range", gen_channel_set, "bts", plate=0, values=[97, 98, 99, 100, 101, 102])
case("small__same_corners", gen_same_corners, "small", plate=1, like=0, fit=True)
case("pig__same_corners", gen_same_corners, "pig", plate=1, like=0)
case("small__swap_plate_pos", gen_swap_plate_positions, "small", a=0, b=1, fit=True)
case("pig__swap_plate_pos", gen_swap_plate_positions, "pig", a=0, b=1)
# 8
case("small__labels_prefix", gen_labels, "small", how="prefix", arg="Bob:", fit=True)
case("pig__labels_prefix", gen_labels, "pig", how="prefix", arg="Subject01:")
case("small__labels_lower", gen_labels, "small", how="lower")
case("gait__labels_lower", gen_labels, "gait", how="lower")
case("small__labels_lead", gen_labels, "small", how="lead")
case("small__labels_suffix_dot", gen_labels, "small", how="suffix", arg="_1")
case("bts__labels_prefix", gen_labels, "bts", how="prefix", arg="Bob:")
case("small__swap_heel_labels", gen_rename, "small", mapping={"LHEE": "RHEE", "RHEE": "LHEE"})
case(
    "small__swap_LR_foot",
    gen_rename,
    "small",
    mapping={
        "LHEE": "RHEE",
        "RHEE": "LHEE",
        "LTOE": "RTOE",
        "RTOE": "LTOE",
        "LANK": "RANK",
        "RANK": "LANK",
    },
    fit=True,
)
case("small__drop_LHEE", gen_drop_marker, "small", names=("LHEE",), fit=True)
case("small__drop_LTOE", gen_drop_marker, "small", names=("LTOE",))
case("small__drop_Lfoot", gen_drop_marker, "small", names=("LHEE", "LTOE", "LANK"))
case("bts__drop_RCA", gen_drop_marker, "bts", names=("RCA",))
case("small__zero_LHEE", gen_marker_zero, "small", names=("LHEE",), residual=-1.0)
case("small__zero_LHEE_res0", gen_marker_zero, "small", names=("LHEE",), residual=0.0)
case(
    "small__zero_LHEE_stance",
    gen_marker_zero,
    "small",
    names=("LHEE",),
    residual=-1.0,
    frames=slice(100, 150),
)
case("small__nan_all", gen_marker_nan, "small")
case("small__nan_LHEE", gen_marker_nan, "small", names=("LHEE",))
case(
    "small__nan_Lfoot_stance",
    gen_marker_nan,
    "small",
    names=("LHEE", "LTOE", "LANK"),
    frames=slice(100, 150),
)
case("small__rhee_up100", gen_marker_offset, "small", names=("RHEE",), delta=(0, 0, 100))
# 9
case("small__trunc20", gen_truncate, "small", n=20)
case("small__trunc20_stance", gen_truncate, "small", n=20, start=60)
case("small__trunc_1stance", gen_truncate, "small", n=130, start=20)
case("bts__trunc20", gen_truncate, "bts", n=20, start=150)
case("small__plate_zero_stance", gen_plate_zero, "small", plate=0, t0=0.6, t1=0.8, fit=True)
case("small__plate_zero_all", gen_plate_zero, "small", plate=0, frac=(0.0, 1.0))
case("small__plates_zero_all", gen_plate_zero, "small", plate=slice(0, 24), frac=(0.0, 1.0))
case("small__first_frame", gen_first_frame, "small", first=1000)
case("small__asf_only", gen_trial_asf, "small", value=5000)
case("gait__first_frame", gen_first_frame, "gait", first=500)
# 10
case("small__yup", gen_rotate_lab, "small", axis="x", deg=-90, fit=True)
case("small__yup_screen", gen_rotate_lab, "small", axis="x", deg=-90, screen=("+X", "+Y"))
case("small__xup", gen_rotate_lab, "small", axis="y", deg=90)
case("small__zdown", gen_rotate_lab, "small", axis="x", deg=180)
case("small__yaw30_shift", gen_rotate_lab, "small", axis="z", deg=30, shift=(2000, -500, 0))
case("small__lift_floor", gen_rotate_lab, "small", axis="z", deg=0, shift=(0, 0, 50))
case("pig__yup", gen_rotate_lab, "pig", axis="x", deg=-90)
case("gait__yup", gen_rotate_lab, "gait", axis="x", deg=-90)
case("bts__zup", gen_rotate_lab, "bts", axis="x", deg=90, fit=True)
case("t2a__yup", gen_rotate_lab, "t2a", axis="x", deg=-90)
case("small__mirror_y", gen_mirror_lab, "small", axis=1)
# misc
case("small__mass_lbs", gen_mass, "small", value=140.2)
case("small__mass_g", gen_mass, "small", value=63600.0)
case("small__mass_zero", gen_mass, "small", value=0.0)
case("small__mass_wrong", gen_mass, "small", value=95.0, fit=True)
case("gait__mass_given", gen_mass, "gait", value=64.5)
case("small__point_rate", gen_point_rate, "small", rate=120.0)


def _gen_plate_zero_multi(src, out, plate=slice(0, 24), frac=(0.0, 1.0)):  # an unused alias
    return gen_plate_zero(src, out, plate, frac=frac)


# ------------------------------------------------------------------------------------------
# running
# ------------------------------------------------------------------------------------------
def generate(name):
    spec = CASES[name]
    out = CASES_DIR / f"{name}.c3d"
    CASES_DIR.mkdir(parents=True, exist_ok=True)
    src = SRC[spec["src"]]
    kw = spec["kw"]
    if spec["gen"] is gen_plate_zero and isinstance(kw.get("plate"), slice):
        c = load(src)
        n = fp(c, "CHANNEL").shape[1]
        # zero every plate
        tmp = src
        for p in range(n):
            gen_plate_zero(tmp, out, plate=p, frac=kw.get("frac", (0, 1)))
            tmp = out
        return out
    spec["gen"](src, out, **kw)
    return out


def cli(args, timeout=900):
    t = time.time()
    r = subprocess.run(
        [PY, "-m", "gc_ocp.cli", *args],
        capture_output=True,
        text=True,
        env=ENV,
        timeout=timeout,
        cwd=str(HERE),
    )
    return r, time.time() - t


def tail(text, n=3):
    lines = [ln for ln in text.strip().splitlines() if ln.strip()]
    return lines[-n:]


def api_summary(path):
    """Trial numbers through the API (load only): mass, stances with peak Fz, mean shear and the
    COP relative to the foot-marker centroid during mid-stance (lab frame)."""
    sys.path.insert(0, str(REPO))
    import warnings

    from gc_ocp.io import load_trial
    from gc_ocp.io._common import foot_markers

    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        tr = load_trial(path)
    out = dict(mass=round(tr.mass, 2), warnings=[str(x.message)[:200] for x in w], stances=[])
    for s in tr.stances:
        p = tr.plates[s.plate]
        sel = (p.time >= s.t_on) & (p.time <= s.t_off)
        F = p.force[sel]
        cop = p.cop()[sel]
        mid = F[:, 2] > 0.5 * F[:, 2].max()
        fm = foot_markers(list(tr.marker_names), s.side)
        tm = p.time[sel][mid]
        mk = np.stack(
            [
                np.array([np.interp(tm, tr.marker_time, tr.markers[:, j, k]) for k in range(3)]).T
                for j in fm
            ],
            axis=1,
        )
        foot = np.nanmean(mk, axis=1)[:, :2]
        rel = np.nanmean(cop[mid, :2] - foot, axis=0)
        out["stances"].append(
            dict(
                label=s.label,
                plate=p.name,
                t_on=round(s.t_on, 3),
                t_off=round(s.t_off, 3),
                peak_fz=round(float(F[:, 2].max()), 1),
                mean_fx=round(float(F[mid, 0].mean()), 1),
                mean_fy=round(float(F[mid, 1].mean()), 1),
                cop_rel_foot_mm=[round(float(v) * 1000, 1) for v in rel],
                cop_on_plate=_on_plate(cop[mid], p.corners),
            )
        )
    out["excluded"] = [f"{e.side}@{e.t_on:.3f}: {e.reason[:120]}" for e in tr.excluded_stances]
    return out


def _on_plate(cop, corners):
    if corners is None:
        return None
    lo, hi = corners[:, :2].min(0) - 0.01, corners[:, :2].max(0) + 0.01
    ok = np.all((cop[:, :2] >= lo) & (cop[:, :2] <= hi), axis=1)
    return round(float(np.mean(ok[np.isfinite(cop[:, 0])])), 3)


def record(d):
    with open(HERE / "results.jsonl", "a") as fh:
        fh.write(json.dumps(d) + "\n")


MASS = {"gait": 64.5, "t2a": 44.7, "t4a": 44.6, "bts": 83.5}
"""Clean-file mass estimates, passed with --mass by ``infom`` (sources without a stored mass)."""


def _run(name, command, mass, *args):
    """Generate case ``name``, run ``gc-ocp COMMAND case ARGS`` (with the clean file's mass
    when ``mass`` and its source stores none): the record's common fields and the result."""
    path = generate(name)
    extra = ["--mass", str(MASS[CASES[name]["src"]])] if mass and CASES[name]["src"] in MASS else []
    r, dt = cli([command, str(path), *args, *extra])
    d = dict(
        case=name,
        src=CASES[name]["src"],
        cmd=command + ("+mass" if extra else ""),
        rc=r.returncode,
        secs=round(dt, 1),
        stderr_tail=tail(r.stderr, 4),
    )
    return path, r, dt, d


def run_info(name, api=True, mass=False):
    path, r, dt, d = _run(name, "info", mass)
    d["stdout_head"] = r.stdout[:4000]
    if api and r.returncode == 0:
        try:
            d["api"] = api_summary(path)
        except Exception as e:  # noqa: BLE001
            d["api_error"] = repr(e)[:300]
    record(d)
    print(
        f"{name:40s} {d['cmd']} rc={r.returncode} {dt:5.1f}s | "
        + " / ".join(tail(r.stderr, 2))[:300]
    )
    return d


def fit_numbers(out_dir):
    f = Path(out_dir) / "fit.json"
    if not f.exists():
        return None
    d = json.loads(f.read_text())
    tr = d["provenance"]["trials"][0]
    sh = d["params"]["shared"]
    return dict(
        mass=round(tr["mass_kg"], 2),
        stances=tr["stances_used"],
        excluded=tr["stances_excluded"],
        n=round(sh["n"], 3),
        c=round(sh["c"], 3),
        mu=round(sh["mu"], 4),
        sup_rms={k: round(v["superior_force_pct_bw"], 2) for k, v in d["rms"].items()},
        ant_rms={k: round(v["anterior_force_pct_bw"], 2) for k, v in d["rms"].items()},
        cop_rms=d["cop_rms_mm"],
        flags=[f["code"] + ":" + f["what"] for f in d["flags"]],
        solver=d["solver"]["status"],
    )


def run_fit(name, mass=False):
    out = FITS_DIR / name
    if out.exists():
        shutil.rmtree(out)
    _, r, dt, d = _run(name, "fit", mass, "--out", str(out))
    d["stdout_tail"] = tail(r.stdout, 30)
    d["fit"] = fit_numbers(out)
    record(d)
    print(
        f"{name:40s} FIT rc={r.returncode} {dt:5.1f}s | {d['fit']} | "
        + " / ".join(tail(r.stderr, 2))[:300]
    )
    return d


def summary() -> None:
    """Print the exit codes of the last ``info`` of every case and each case's outcome."""
    last = {}
    for line in open(HERE / "results.jsonl"):
        r = json.loads(line)
        if r.get("cmd") == "info":
            last[r["case"]] = r
    codes: dict[int, int] = {}
    for r in last.values():
        codes[r["rc"]] = codes.get(r["rc"], 0) + 1
    print(f"# C3D fuzz: {len(last)} cases through `gc-ocp info`\n")
    print("| exit | cases |\n|---|---|")
    for k in sorted(codes):
        print(f"| {k} | {codes[k]} |")
    print("\n| case | exit | stances used | what the package said (last line) |\n|---|---|---|---|")
    for k, r in sorted(last.items()):
        used = len(r["api"]["stances"]) if r.get("api") else "-"
        said = [ln for ln in r["stderr_tail"] if "error" in ln or "excluded" in ln]
        said = (said or r["stderr_tail"] or [""])[-1].replace("|", "/")
        said = said.replace(str(HERE), "").replace(D, "")
        print(f"| {k} | {r['rc']} | {used} | {said[:160]} |")


def main(argv):
    if not argv or argv[0] == "list":
        for k, v in CASES.items():
            print(k, v["src"], v["kw"], "FIT" if v["fit"] else "")
        return
    cmd, names = argv[0], argv[1:]
    if cmd == "summary":  # the last `info` of every case in results.jsonl, as markdown
        summary()
        return
    if names == ["all"] or not names:
        names = list(CASES)
    for n in names:
        if cmd == "gen":
            print(generate(n))
        elif cmd == "run":
            try:
                run_info(n)
            except Exception as e:  # generator failure: ezc3d could not write it
                record(dict(case=n, cmd="gen", error=repr(e)[:300]))
                print(f"{n:40s} GENERATOR FAILED: {e!r}"[:300])
        elif cmd == "infom":  # info with --mass (sources without a stored mass)
            run_info(n, api=False, mass=True)
        elif cmd == "fit":
            run_fit(n)
        elif cmd == "fitm":  # fit with --mass (sources without a stored mass)
            run_fit(n, mass=True)


# ------------------------------------------------------------------------------------------
# structural damage (added after the first pass: looking for crashes)
# ------------------------------------------------------------------------------------------
def gen_analog_nan(src, out, plate=0, t0=0.6, t1=0.8, comps=None):
    """NaN in one plate's channels for [t0, t1) s (float exporters write NaN for dropouts)."""
    c = load(src)
    ch = plate_channels(c, plate)
    if comps is not None:
        ch = ch[list(comps)]
    rate = float(c["header"]["analogs"]["frame_rate"])
    c["data"]["analogs"][0, ch, int(t0 * rate) : int(t1 * rate)] = np.nan
    return save(c, out)


def gen_corners_degenerate(src, out, plate=0, how="collinear"):
    """One plate's CORNERS degenerate: 'collinear' (all on a line), 'zero', 'nan', 'dup' (c3 = c1)."""
    c = load(src)
    cor = fp(c, "CORNERS").astype(float)
    if how == "collinear":
        cor[:, 2, plate] = cor[:, 0, plate] + 2 * (cor[:, 1, plate] - cor[:, 0, plate])
        cor[:, 3, plate] = cor[:, 0, plate] + 3 * (cor[:, 1, plate] - cor[:, 0, plate])
    elif how == "zero":
        cor[:, :, plate] = 0.0
    elif how == "nan":
        cor[:, :, plate] = np.nan
    elif how == "dup":
        cor[:, 3, plate] = cor[:, 0, plate]
    set_param(c, "FORCE_PLATFORM", "CORNERS", cor)
    return save(c, out)


def gen_param_shape(src, out, key="CORNERS", keep_plates=1):
    """A FORCE_PLATFORM parameter stored for fewer plates than USED."""
    c = load(src)
    v = fp(c, key)
    set_param(c, "FORCE_PLATFORM", key, v[..., :keep_plates])
    return save(c, out)


def gen_drop_param(src, out, group="FORCE_PLATFORM", key="ORIGIN"):
    c = load(src)
    del c["parameters"][group][key]
    return save(c, out)


def gen_cal_singular(src, out, plate=0, how="zero"):
    """Type-4 CAL_MATRIX of one plate zero / NaN."""
    c = load(src)
    cal = fp(c, "CAL_MATRIX").astype(float)
    cal[:, :, plate] = 0.0 if how == "zero" else np.nan
    set_param(c, "FORCE_PLATFORM", "CAL_MATRIX", cal)
    return save(c, out)


def gen_marker_inf(src, out, names=("LHEE",), frames=slice(100, 105)):
    c = load(src)
    for nm in names:
        c["data"]["points"][:3, idx(c, nm), frames] = np.inf
    return save(c, out)


def gen_marker_spike(src, out, names=("LHEE",), frame=120, delta=(0, 0, 5000.0)):
    """A single-frame marker spike (a mislabelled ghost marker) of 5 m."""
    c = load(src)
    for nm in names:
        c["data"]["points"][:3, idx(c, nm), frame] += np.asarray(delta, float)
    return save(c, out)


def gen_one_frame(src, out):
    c = load(src)
    select_frames(c, slice(0, 1))
    return save(c, out)


def gen_empty_labels(src, out, names=("LHEE",)):
    """Labels blanked (an exporter writing '' for unnamed points)."""
    c = load(src)
    lab = [str(s).strip() for s in c["parameters"]["POINT"]["LABELS"]["value"]]
    c["parameters"]["POINT"]["LABELS"]["value"] = ["" if s in names else s for s in lab]
    return save(c, out)


def gen_dup_labels(src, out, src_name="RHEE", new_name="LHEE"):
    """Label ``src_name`` renamed to ``new_name``: two points named ``new_name``."""
    return gen_rename(src, out, mapping={src_name: new_name})


def gen_subject_param(src, out, group="PROCESSING", key="Bodymass", value="63.6 kg", height=None):
    c = load(src)
    if group in c["parameters"] and key in c["parameters"][group]:
        del c["parameters"][group][key]
    c.add_parameter(group, key, [value] if isinstance(value, str) else np.array([value]))
    if height is not None:
        if "Height" in c["parameters"][group]:
            del c["parameters"][group]["Height"]
        c.add_parameter(group, "Height", np.array([height]))
    return save(c, out)


case("small__fz_nan_stance", gen_analog_nan, "small", plate=0, t0=0.6, t1=0.8, fit=True)
case("small__fz_nan_unloaded", gen_analog_nan, "small", plate=0, t0=2.0, t1=2.2)
case("small__fx_nan_stance", gen_analog_nan, "small", plate=0, t0=0.6, t1=0.8, comps=(0,))
case("bts__fz_nan_stance", gen_analog_nan, "bts", plate=0, t0=2.7, t1=2.8)
case("small__corners_collinear", gen_corners_degenerate, "small", plate=0, how="collinear")
case("small__corners_zero", gen_corners_degenerate, "small", plate=0, how="zero")
case("small__corners_nan", gen_corners_degenerate, "small", plate=0, how="nan")
case("small__corners_dup", gen_corners_degenerate, "small", plate=0, how="dup")
case("bts__corners_collinear", gen_corners_degenerate, "bts", plate=0, how="collinear")
case("small__corners_1plate", gen_param_shape, "small", key="CORNERS", keep_plates=1)
case("small__origin_1plate", gen_param_shape, "small", key="ORIGIN", keep_plates=1)
case("small__channel_1plate", gen_param_shape, "small", key="CHANNEL", keep_plates=1)
case("small__type_1plate", gen_param_shape, "small", key="TYPE", keep_plates=1)
case("small__no_origin", gen_drop_param, "small", key="ORIGIN")
case("small__no_corners", gen_drop_param, "small", key="CORNERS")
case("small__no_channel", gen_drop_param, "small", key="CHANNEL")
case("small__no_type", gen_drop_param, "small", key="TYPE")
case("bts__no_origin", gen_drop_param, "bts", key="ORIGIN")
case("t4a__cal_zero", gen_cal_singular, "t4a", plate=0, how="zero")
case("t4a__cal_nan", gen_cal_singular, "t4a", plate=0, how="nan")
case("t4a__cal_1plate", gen_param_shape, "t4a", key="CAL_MATRIX", keep_plates=1)
case("small__marker_inf", gen_marker_inf, "small")
case("small__marker_spike", gen_marker_spike, "small")
case("small__one_frame", gen_one_frame, "small")
case("small__empty_label_LHEE", gen_empty_labels, "small")
case("small__dup_label_LHEE", gen_dup_labels, "small")
case("small__mass_text", gen_subject_param, "small", value="63.6 kg")
case("small__height_cm", gen_subject_param, "small", value=63.6, height=158.0)
case("small__no_point_rate", gen_drop_param, "small", group="POINT", key="RATE")
case("small__no_analog_units", gen_drop_param, "small", group="ANALOG", key="UNITS")
case("small__no_point_units", gen_drop_param, "small", group="POINT", key="UNITS")


if __name__ == "__main__":
    main(sys.argv[1:])
