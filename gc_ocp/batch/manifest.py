"""What a study is: subjects, each with its walking trials and what the files lack.

Three forms, all read by :func:`read_manifest` into a list of :class:`Subject`:

* **CSV** (``.csv``), one row per walking trial, a header naming the columns. ``subject`` and
  ``trial`` are required; optional: ``grf`` (the MOT/STO of a TRC trial; default: found beside
  it as ``gc-ocp fit`` finds it), and the subject's ``static``, ``mass`` [kg], ``height`` [m],
  ``belt_speed`` [m/s], ``markerset``, ``cutoff`` [Hz], ``foot_roll`` (``chain`` or ``level``:
  a two-landmark foot's roll, ``docs/data_formats.md``), ``holdout``. A subject value may stand
  on any of the subject's rows (empty cells are "not given"); two rows that give it differently
  are an error naming both rows.
* **TOML** (``.toml``): ``[[subject]]`` tables with ``id``, ``trials`` (a list of paths, or of
  ``{trial = ..., grf = ...}`` tables) and the same optional keys.
* **A folder**: one subject per subfolder (its name is the id), its trials every ``.c3d`` and
  ``.trc`` file directly inside. A file whose markers stand still (:func:`is_static`) is the
  subject's static trial (a folder with several of them is an error: name one in a manifest);
  the ground reactions of a TRC are found as ``gc-ocp fit`` finds them.

Paths are relative to the manifest's folder (or absolute). Every problem is an
:class:`~gc_ocp.errors.InputError` that names the file, the row or subject, and the fix.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from gc_ocp.errors import InputError
from gc_ocp.foot import FOOT_ROLLS
from gc_ocp.text import read_utf8
from gc_ocp.values import number

TRIAL_SUFFIXES = (".c3d", ".trc")
STATIC_SPEED = 0.3
"""[m/s] A trial is a static (standing) trial when the 90th percentile over its markers of each
marker's RMS speed is below this: walking, overground or on a treadmill, the feet swing at
several m/s and the foot markers' RMS speed is above 1 m/s (1.5-2.3 m/s on every walking file
of ``../shared/data``); standing, every marker moves by sway alone (0.01-0.05 m/s on its static
files)."""

SUBJECT_KEYS = (
    "static",
    "mass",
    "height",
    "belt_speed",
    "markerset",
    "cutoff",
    "foot_roll",
    "holdout",
)
"""Optional per-subject settings of a manifest (the ``gc-ocp fit`` options of the same names)."""
_NUMBERS = {"mass": "kg", "height": "m", "belt_speed": "m/s", "cutoff": "Hz"}
_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


@dataclasses.dataclass(frozen=True)
class TrialSpec:
    """One walking trial: its file and, for a TRC, its ground reactions (None: found beside)."""

    path: Path
    grf: Path | None = None


@dataclasses.dataclass(frozen=True)
class Subject:
    """One subject of a study: ``id`` (its output folder's name), its walking ``trials``
    (fitted together: shared contact parameters) and what the files may lack."""

    id: str
    trials: tuple[TrialSpec, ...]
    static: Path | None = None
    mass: float | None = None
    height: float | None = None
    belt_speed: float | None = None
    markerset: str | None = None
    cutoff: float | None = None
    foot_roll: str = "chain"
    holdout: str | None = "auto"

    def files(self) -> list[Path]:
        """Every input file (trials, ground reactions, static): what the results depend on."""
        out = [p for t in self.trials for p in (t.path, t.grf) if p is not None]
        return out + ([self.static] if self.static is not None else [])


def read_manifest(path: str | Path) -> list[Subject]:
    """The subjects of a manifest file (CSV or TOML) or a folder (module doc)."""
    path = Path(path)
    if path.is_dir():
        return _from_folder(path)
    if not path.is_file():
        raise InputError(
            f"Manifest {path} does not exist; give a CSV or TOML manifest, or a folder with one "
            "subfolder per subject."
        )
    suffix = path.suffix.lower()
    if suffix == ".csv":
        subjects = _from_csv(path)
    elif suffix == ".toml":
        subjects = _from_toml(path)
    else:
        raise InputError(
            f'Manifest {path}: unsupported type "{suffix}"; give a .csv or .toml manifest or a '
            "folder (docs/batch.md)."
        )
    if not subjects:
        raise InputError(f"Manifest {path} lists no subject; add at least one trial.")
    for s in subjects:
        for f in s.files():
            if not f.is_file():
                raise InputError(
                    f"Manifest {path}, subject {s.id}: {f} does not exist; fix the path "
                    "(relative paths are relative to the manifest's folder)."
                )
    return subjects


def check_id(value: str, where: str) -> str:
    value = str(value).strip()
    if not _ID.match(value):
        raise InputError(
            f"{where}: subject id {value!r} is not usable as a folder name; use letters, digits, "
            "'.', '_' or '-' (starting with a letter or digit)."
        )
    return value


def _resolve(base: Path, value: str) -> Path:
    p = Path(value.strip()).expanduser()
    return p if p.is_absolute() else base / p


def _number(value, key: str, where: str) -> float:
    try:  # a number or numeric text (TOML's true is no mass: values.number)
        x = number(value, key, _NUMBERS[key])
    except InputError:
        x = math.nan
    if not x > 0:
        raise InputError(
            f"{where}: {key} {value!r} is not a positive number; give it in {_NUMBERS[key]}."
        )
    return x


def _settings(raw: Mapping, base: Path, where: str) -> dict:
    """The optional subject keys of one row/table, typed; empty values left out."""
    out = {}
    for key in SUBJECT_KEYS:
        v = raw.get(key)
        if v is None or (isinstance(v, str) and not v.strip()):
            continue
        if key in _NUMBERS:
            out[key] = _number(v, key, where)
        elif key == "static":
            out[key] = _resolve(base, str(v))
        elif key == "markerset" and (
            str(v).strip().lower().endswith(".toml") or "/" in str(v) or "\\" in str(v)
        ):  # a file (not a shipped set's name): relative to the manifest, as the trials
            out[key] = str(_resolve(base, str(v)))
        elif key == "foot_roll":
            out[key] = str(v).strip()
            if out[key] not in FOOT_ROLLS:
                raise InputError(
                    f"{where}: foot_roll {v!r} is not one of {', '.join(FOOT_ROLLS)}; give "
                    "chain (default) or level (docs/data_formats.md, rule 5)."
                )
        elif key == "holdout" and str(v).strip().lower() == "none":
            out[key] = None  # every stance fitted (an empty value is the default, auto)
        else:
            out[key] = str(v).strip()
    return out


def _from_csv(path: Path) -> list[Subject]:
    base = path.parent
    with io.StringIO(read_utf8(path, "Manifest"), newline="") as f:
        reader = csv.DictReader(f)
        header = [h.strip() for h in (reader.fieldnames or [])]
        missing = [c for c in ("subject", "trial") if c not in header]
        if missing:
            raise InputError(
                f"Manifest {path}: no {' or '.join(missing)} column in the header "
                f"({', '.join(header) or 'empty'}); the header needs subject and trial "
                "(docs/batch.md)."
            )
        unknown = [c for c in header if c not in ("subject", "trial", "grf", *SUBJECT_KEYS)]
        if unknown:
            raise InputError(
                f"Manifest {path}: unknown column(s) {', '.join(unknown)}; the columns are "
                f"subject, trial, grf, {', '.join(SUBJECT_KEYS)}."
            )
        order: dict[str, list] = {}
        given: dict[str, dict] = {}
        for row_no, row in enumerate(reader, start=2):
            where = f"Manifest {path}, row {row_no}"
            if None in row:  # csv.DictReader's key for the values beyond the header
                raise InputError(
                    f"{where}: {len(row[None])} value(s) beyond the header's {len(header)} "
                    f"columns ({', '.join(map(repr, row[None]))}); add their column to the header "
                    "or remove them."
                )
            row = {(k or "").strip(): v for k, v in row.items()}
            if not (row.get("subject") or "").strip() or not (row.get("trial") or "").strip():
                raise InputError(f"{where}: subject and trial must both be given.")
            sid = check_id(row["subject"], where)
            grf = (row.get("grf") or "").strip()
            order.setdefault(sid, []).append(
                TrialSpec(_resolve(base, row["trial"]), _resolve(base, grf) if grf else None)
            )
            for key, value in _settings(row, base, where).items():
                prev = given.setdefault(sid, {}).setdefault(key, (value, row_no))
                if prev[0] != value:
                    raise InputError(
                        f"Manifest {path}: subject {sid} has {key} {prev[0]} on row {prev[1]} "
                        f"and {value} on row {row_no}; give it once (or the same on every row)."
                    )
    return [
        Subject(
            id=sid,
            trials=tuple(trials),
            **{k: v for k, (v, _) in given.get(sid, {}).items()},
        )
        for sid, trials in order.items()
    ]


def _from_toml(path: Path) -> list[Subject]:
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib  # type: ignore[no-redef]
    try:
        doc = tomllib.loads(read_utf8(path, "Manifest"))
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"Manifest {path} is not valid TOML ({e}); fix the syntax.") from e
    base = path.parent
    tables = doc.get("subject")
    if not isinstance(tables, list):
        raise InputError(
            f"Manifest {path}: no [[subject]] tables; write one [[subject]] table per subject "
            "with id and trials (docs/batch.md)."
        )
    out, seen = [], set()
    for k, t in enumerate(tables, start=1):
        where = f"Manifest {path}, subject table {k}"
        if "id" not in t or "trials" not in t:
            raise InputError(f"{where}: needs id and trials.")
        sid = check_id(str(t["id"]), where)
        if sid in seen:
            raise InputError(f"{where}: subject {sid} is listed twice; list it once.")
        seen.add(sid)
        unknown = [key for key in t if key not in ("id", "trials", *SUBJECT_KEYS)]
        if unknown:
            raise InputError(
                f"{where}: unknown key(s) {', '.join(unknown)}; the keys are id, trials, "
                f"{', '.join(SUBJECT_KEYS)}."
            )
        trials = []
        if not isinstance(t["trials"], list):
            raise InputError(
                f"{where}: trials is a list of paths or of tables {{trial = ..., grf = ...}}, "
                f'not {t["trials"]!r}; write trials = ["walk1.c3d", ...].'
            )
        for item in t["trials"]:
            extra = (
                [k for k in item if k not in ("trial", "grf")] if isinstance(item, Mapping) else []
            )
            if extra:  # a misspelt grf: the file beside the TRC was taken silently
                raise InputError(
                    f"{where}: unknown key(s) {', '.join(extra)} in the trial table {item!r}; "
                    "a trial table has trial and, for a TRC, grf."
                )
            if isinstance(item, str):
                trials.append(TrialSpec(_resolve(base, item)))
            elif (
                isinstance(item, Mapping)
                and isinstance(item.get("trial"), str)
                and isinstance(item.get("grf", ""), str)
            ):
                grf = item.get("grf")
                trials.append(
                    TrialSpec(_resolve(base, item["trial"]), _resolve(base, grf) if grf else None)
                )
            else:
                raise InputError(
                    f"{where}: a trial is a path or a table {{trial = ..., grf = ...}}, "
                    f"not {item!r}."
                )
        if not trials:
            raise InputError(f"{where}: subject {sid} has no trial; list at least one.")
        out.append(Subject(id=sid, trials=tuple(trials), **_settings(t, base, where)))
    return out


def marker_speed(path: Path) -> float:
    """[m/s] The 90th percentile over the markers of each marker's RMS speed (gaps skipped)."""
    from gc_ocp.io.c3d import read_c3d
    from gc_ocp.io.opensim import read_trc

    if path.suffix.lower() == ".trc":
        _, markers, time = read_trc(path)
    else:
        raw = read_c3d(path)
        markers, time = raw.markers, raw.marker_time
    if len(time) < 2:
        return 0.0
    v = np.diff(markers, axis=0) / np.diff(time)[:, None, None]
    speed = np.linalg.norm(v, axis=2)  # (frames - 1, markers), NaN across gaps
    seen = np.isfinite(speed).any(axis=0)  # a marker missing throughout has no speed
    rms = np.sqrt(np.nanmean(speed[:, seen] ** 2, axis=0))
    rms = rms[np.isfinite(rms)]
    return float(np.percentile(rms, 90)) if rms.size else 0.0


def is_static(path: Path) -> bool:
    """Whether ``path``'s markers stand still (:data:`STATIC_SPEED`)."""
    return marker_speed(path) < STATIC_SPEED


def _static_or_unreadable(path: Path) -> bool | None:
    """:func:`is_static`, or None when the file cannot be read: it stays a walking trial, and
    its subject's task records the error (one bad file must not stop the study)."""
    try:
        return is_static(path)
    except InputError:
        return None


def _from_folder(folder: Path) -> list[Subject]:
    subs = sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith("."))
    if not subs:
        raise InputError(
            f"Folder {folder} has no subfolder; a study folder holds one subfolder per subject "
            "(or give a CSV/TOML manifest, docs/batch.md)."
        )
    out = []
    for sub in subs:
        files = sorted(
            p for p in sub.iterdir() if p.is_file() and p.suffix.lower() in TRIAL_SUFFIXES
        )
        if not files:
            deeper = sorted(
                p.relative_to(sub)
                for p in sub.rglob("*")
                if p.is_file() and p.suffix.lower() in TRIAL_SUFFIXES
            )
            if deeper:  # a subject's trials one level down would vanish from the study unsaid
                raise InputError(
                    f"Subject folder {sub} holds trials only in its subfolders ({deeper[0]}"
                    f"{' and more' if len(deeper) > 1 else ''}); a study folder has one "
                    "subfolder per subject with its trial files directly inside: move them up, "
                    "or list them in a CSV/TOML manifest (docs/batch.md)."
                )
            continue  # not a subject folder (e.g. an output folder beside them)
        statics = [p for p in files if _static_or_unreadable(p) is True]
        if len(statics) > 1:
            raise InputError(
                f"Subject folder {sub}: {', '.join(p.name for p in statics)} all look like static "
                "trials (markers standing still); name the one to use in a manifest's static "
                "column."
            )
        walks = [p for p in files if p not in statics]
        if not walks:
            raise InputError(
                f"Subject folder {sub}: no walking trial (every file's markers stand still)."
            )
        sid = check_id(sub.name, f"Subject folder {sub}")
        out.append(
            Subject(
                id=sid,
                trials=tuple(TrialSpec(p) for p in walks),
                static=statics[0] if statics else None,
            )
        )
    if not out:
        raise InputError(f"Folder {folder}: no subfolder holds a .c3d or .trc trial.")
    return out


__all__ = ("STATIC_SPEED", "Subject", "TrialSpec", "is_static", "marker_speed", "read_manifest")
