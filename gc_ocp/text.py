"""Reading the text files a user gives (manifests, marker sets, the JSON documents the package
wrote: fit.json, diagnosis.json): one encoding rule, one reader of a JSON file; and the one
writer of the JSON documents the package writes (:func:`json_text`: strict JSON, no NaN)."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from gc_ocp.errors import InputError, require_file


def read_utf8(path: str | Path, what: str) -> str:
    """The text of ``path`` (UTF-8, a byte-order mark allowed), or an :class:`InputError` naming
    the file and the fix when it is in another encoding (a spreadsheet's CSV saved as Latin-1)."""
    try:
        return Path(path).read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as e:
        raise InputError(
            f"{what} {path} is not UTF-8 text (byte {e.object[e.start]:#04x} at position "
            f"{e.start}); save it as UTF-8 (in a spreadsheet: CSV UTF-8)."
        ) from None


def read_json_file(path: str | Path, what: str, document: str, fix: str):
    """The parsed JSON of the file ``path``: ``what`` names the file in a missing-file message
    (``"Fit file"``), ``document`` what it should be (``"a fit.json"``) and ``fix`` what to
    give; a missing file, a folder, text not in UTF-8 or not JSON is an :class:`InputError`
    that says so."""
    path = Path(path)
    require_file(path, what, fix)
    try:
        return json.loads(read_utf8(path, what))
    except json.JSONDecodeError as e:
        raise InputError(f"{path} is not {document} ({e}); {fix}") from None


def check_document(
    doc, where: str, document: str, known: int, needed: tuple[str, ...], fix: str
) -> None:
    """Refuse a JSON document the package wrote (``document``, e.g. ``"fit.json"``) that this
    version cannot read, with one :class:`InputError` naming ``where`` (the file), the version
    that wrote it (its ``"gc_ocp_version"``, or its provenance's), this version and the ``fix``:

    * its ``"format"`` is not one this version knows (1 to ``known``): a later layout;
    * it lacks a key of ``needed`` (what the reader takes): a layout this version does not
      read (an older one, or an edited file).

    A document without ``"format"`` was written before the field: read as today's when it has
    the ``needed`` keys."""
    from gc_ocp._version import __version__

    if not isinstance(doc, dict):
        return  # not a document at all: the reader says so
    prov = doc.get("provenance")  # diagnosis.json keeps the version in its provenance
    wrote = doc.get("gc_ocp_version") or (
        prov.get("gc_ocp_version") if isinstance(prov, dict) else None
    )
    wrote = wrote or "an unknown version"
    fmt = doc.get("format")
    here = f"this gc_ocp {__version__} reads {document} format 1 to {known}"
    if fmt is not None and not (type(fmt) is int and 1 <= fmt <= known):
        raise InputError(
            f"{where} is a {document} of format {fmt!r}, written by gc_ocp {wrote}; {here}: "
            f"{fix}, or read it with the gc_ocp that wrote it"
        )
    missing = [k for k in needed if k not in doc]
    if missing:
        written = f"format {fmt}" if fmt is not None else "no format number (written before it)"
        raise InputError(
            f"{where} has no {', '.join(map(repr, missing))}, which this gc_ocp {__version__} "
            f"reads: a {document} of another layout (written by gc_ocp {wrote}, {written}) or "
            f"an edited one; {fix}"
        )


def json_text(obj, indent: int | None = 2, default=None) -> str:
    """``obj`` as strict JSON (RFC 8259), the text of every JSON file the package writes.

    JSON has no NaN or infinity; Python's ``json`` writes them as the bare words ``NaN`` and
    ``Infinity``, which JavaScript's ``JSON.parse``, ``jq`` and R's ``jsonlite`` refuse. A number
    that is not finite (the standard error of a unit that is not identified, the RMS of a foot
    with no sample) is written ``null``, JSON's "no value", which MATLAB's ``jsondecode`` reads as
    NaN in a numeric array; the package's readers take it back as NaN where a number belongs
    (:func:`nan_for_null`). numpy scalars and arrays are written as numbers and lists.
    ``default``: as :func:`json.dumps`'s, for other objects."""
    return json.dumps(_finite_or_null(obj), indent=indent, allow_nan=False, default=default)


def _finite_or_null(obj):
    if isinstance(obj, bool | np.bool_):
        return bool(obj)
    if isinstance(obj, float | np.floating):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.ndarray):
        return _finite_or_null(obj.tolist())
    if isinstance(obj, dict):
        return {k: _finite_or_null(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_finite_or_null(v) for v in obj]
    return obj


def nan_for_null(obj):
    """The part of a document :func:`json_text` wrote whose leaves are all numbers (or text), with
    each ``null`` back as NaN: what was not finite when written. Only for such parts: elsewhere a
    ``null`` may mean "not given" (an option, a covariance not kept)."""
    if obj is None:
        return math.nan
    if isinstance(obj, dict):
        return {k: nan_for_null(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [nan_for_null(v) for v in obj]
    return obj


def float_fields(cls, d: dict) -> dict:
    """``d``, the JSON of the dataclass ``cls``, with each field typed ``float`` (not
    ``float | None``, whose ``null`` means "no value") that :func:`json_text` wrote ``null``
    back as NaN."""
    floats = {f.name for f in dataclasses.fields(cls) if f.type in ("float", float)}
    return {k: math.nan if v is None and k in floats else v for k, v in d.items()}
