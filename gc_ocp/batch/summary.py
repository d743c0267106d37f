"""A study's summary table: one row per subject and foot, as plain data (a list of dicts with
the same keys, :data:`COLUMNS`), written as ``summary.csv`` and ``summary.parquet``.

Forces in % body weight, torques in % body weight x height (as the fits report them), COP in
mm; a value the subject does not have (a foot not held out, a failed subject) is empty in the
CSV and null in the Parquet file.
"""

from __future__ import annotations

import csv
import io
import math
import re
from collections.abc import Sequence
from pathlib import Path

from gc_ocp.contact.channels import CHANNELS as WRENCH_CHANNELS
from gc_ocp.contact.channels import TABLE_KEYS
from gc_ocp.estimation.flags import at_bound_names, k_at_bound, law_at_bound
from gc_ocp.foot import UNITS
from gc_ocp.outputs import atomic_write, atomic_write_text

CHANNELS = tuple(TABLE_KEYS[c] for c in WRENCH_CHANNELS)
"""The six channels' keys as ``fit.json`` has them (``superior_force_pct_bw``, ...)."""
SHARED = ("n", "c", "mu")

COLUMNS = (
    "subject",
    "foot",
    "status",
    "trials",
    "trials_skipped",
    "stances",
    "mass_kg",
    "height_m",
    *(f"{p}{s}" for p in SHARED for s in ("", "_se")),
    *(f"f_ref_{u}_N{s}" for u in UNITS for s in ("", "_se")),
    "units_not_identified",
    "params_at_bound",
    *(f"rms_{c}" for c in CHANNELS),
    "cop_rms_mm",
    "heldout_stance",
    *(f"heldout_rms_{c}" for c in CHANNELS),
    "heldout_cop_rms_mm",
    "flags",
    "flag_codes",
    "bias_replicates",
    "diagnosis_selected",
    "solver_status",
    "iterations",
    "seconds",
    "error_type",
    "error_message",
    "error_fix",
)
"""The summary's columns, in order (``f_ref``: a unit's force at the reference depth [N];
``units_not_identified``: the units whose force the data do not fix, ``"PM; AM"``, whose
``f_ref`` is a value with no meaning beside its SE: leave them out of a group's statistics;
``params_at_bound``: the parameters the fit left on a bound of their range, ``"mu; k PM"``:
their value is the bound, not an estimate, and their SE column is empty;
``bias_replicates``: the markers' noise's bias correction, 0 where none was made, e.g. a
subject whose markers are quiet enough: :func:`gc_ocp.workflow.fitting.bias_replicates`)."""

NUMERIC = frozenset(
    c
    for c in COLUMNS
    if c
    not in (
        "subject",
        "foot",
        "status",
        "units_not_identified",
        "params_at_bound",
        "heldout_stance",
        "flag_codes",
        "diagnosis_selected",
        "solver_status",
        "error_type",
        "error_message",
        "error_fix",
    )
)


def _row(**values) -> dict:
    row = dict.fromkeys(COLUMNS)
    unknown = set(values) - set(COLUMNS)
    if unknown:
        raise KeyError(f"not summary columns: {sorted(unknown)}")
    row.update(values)
    return row


_STANCE_SIDE = re.compile(r"(?:^|:)(left|right)@[-+0-9.e]+s$")
"""A stance's label (``right@0.407s``, ``walk2:right@1.200s``) and its foot."""


def _feet_of(what: str) -> set[str]:
    """The feet a flag's ``what`` names: a part of it that is a foot (``contact/k/left/PM``,
    ``left``) or a stance's label (``pose/walk:right@0.407s/trans``); none (the shared
    parameters, the bias correction): a flag of the subject, both feet's."""
    feet = set()
    for part in what.split("/"):
        if part in ("left", "right"):
            feet.add(part)
        elif m := _STANCE_SIDE.search(part):
            feet.add(m.group(1))
    return feet


def subject_rows(subject, fit_doc: dict, diagnosis: dict | None) -> list[dict]:
    """The rows of a fitted subject: ``fit_doc`` is its ``fit.json``, ``diagnosis`` its
    ``diagnosis.json`` (None: not diagnosed)."""
    trials = fit_doc["provenance"]["trials"]
    mass = trials[0]["mass_kg"] if trials else None
    height = trials[0]["height_m"] if trials else None
    shared = fit_doc["params"].get("shared", {})
    held = fit_doc.get("heldout_rms") or {}
    held_cop = fit_doc.get("heldout_cop_rms_mm") or {}
    fits = fit_doc.get("stance_fits", [])
    rows = []
    for foot in sorted(fit_doc["rms"]):
        units = fit_doc["params"].get(foot, {})
        flags = [
            f
            for f in [*fit_doc.get("flags", []), *fit_doc.get("heldout_flags", [])]
            if foot in _feet_of(str(f.get("what", ""))) or not _feet_of(str(f.get("what", "")))
        ]
        values = {
            "subject": subject.id,
            "foot": foot,
            "status": "done",
            "trials": len(trials),
            # given but not used: each one's error is in fit.json (gc_ocp.workflow.trials)
            "trials_skipped": len(fit_doc["provenance"].get("trials_skipped", [])),
            "stances": sum(f.get("side") == foot for f in fits),
            "mass_kg": mass,
            "height_m": height,
            "cop_rms_mm": fit_doc.get("cop_rms_mm", {}).get(foot),
            "heldout_stance": fit_doc.get("heldout_stance") if foot in held else None,
            "heldout_cop_rms_mm": held_cop.get(foot),
            "flags": len(flags),
            "flag_codes": "; ".join(sorted({f["code"] for f in flags})),
            # None: a fit.json written before the correction's decision was recorded
            "bias_replicates": (fit_doc.get("bias_correction") or {}).get("replicates"),
            "diagnosis_selected": None
            if diagnosis is None
            else (", ".join(diagnosis["selected"]) or "none"),
            "solver_status": fit_doc["solver"]["status"],
            "iterations": fit_doc["solver"]["iterations"],
        }
        # a parameter at its bound has no meaningful SE (the fit's flag says so): left empty
        bound = at_bound_names(fit_doc.get("flags", []))
        at_shared = [p for p in SHARED if law_at_bound(bound, p, foot)]
        at_unit = [u for u in UNITS if k_at_bound(bound, foot, u)]
        for p in SHARED:
            se = None if p in at_shared else shared.get(f"{p}_se")
            values[p], values[f"{p}_se"] = shared.get(p), se
        for u in UNITS:
            e = units.get(u, {})
            se = None if u in at_unit else e.get("f_ref_se")
            values[f"f_ref_{u}_N"], values[f"f_ref_{u}_N_se"] = e.get("f_ref"), se
        values["params_at_bound"] = "; ".join([*at_shared, *(f"k {u}" for u in at_unit)])
        values["units_not_identified"] = "; ".join(
            u for u in UNITS if units.get(u, {}).get("identified") is False
        )
        for c in CHANNELS:
            values[f"rms_{c}"] = fit_doc["rms"][foot].get(c)
            values[f"heldout_rms_{c}"] = held.get(foot, {}).get(c)
        rows.append(_row(**values))
    return rows


def error_rows(subject, error: dict, seconds: float) -> list[dict]:
    """The row of a subject that failed (one, foot empty)."""
    return [
        _row(
            subject=subject.id,
            status="failed",
            trials=len(subject.trials),
            seconds=seconds,
            error_type=error["type"],
            error_message=error["message"],
            error_fix=error["fix"],
        )
    ]


def _cell(v) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    return repr(v) if isinstance(v, float) else str(v)


def to_csv(rows: Sequence[dict]) -> str:
    """The rows as CSV text (header :data:`COLUMNS`)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    for r in rows:
        w.writerow([_cell(r.get(c)) for c in COLUMNS])
    return buf.getvalue()


def to_arrow(rows: Sequence[dict]):
    """The rows as a ``pyarrow.Table`` (numbers as float64, text as string; None, and a number
    that is not finite, as null: a resumed study's rows come from ``done.json``, which writes
    NaN as null (:func:`~gc_ocp.text.json_text`), so a fresh and a resumed run give one table,
    as their CSV's empty cell is one)."""
    import pyarrow as pa

    arrays = {}
    for c in COLUMNS:
        vals = [r.get(c) for r in rows]
        if c in NUMERIC:
            nums = [None if v is None else float(v) for v in vals]
            arrays[c] = pa.array(
                [v if v is not None and math.isfinite(v) else None for v in nums], pa.float64()
            )
        else:
            arrays[c] = pa.array([None if v is None else str(v) for v in vals], pa.string())
    return pa.table(arrays)


def write_summary(rows: Sequence[dict], folder: str | Path) -> list[Path]:
    """``summary.csv`` and ``summary.parquet`` in ``folder``, each written atomically."""
    import pyarrow.parquet as pq

    folder = Path(folder)
    table = to_arrow(rows)
    return [
        atomic_write_text(folder / "summary.csv", to_csv(rows)),
        atomic_write(folder / "summary.parquet", lambda tmp: pq.write_table(table, tmp)),
    ]


__all__ = (
    "CHANNELS",
    "COLUMNS",
    "error_rows",
    "subject_rows",
    "to_arrow",
    "to_csv",
    "write_summary",
)
