"""One subject of a study, as one task: load its trials, compute (or reuse) their kinematics,
fit them together, optionally diagnose, and write everything under ``OUT/<subject>/``.

:func:`process_subject` is a pure function of picklable arguments (a
:class:`~gc_ocp.batch.manifest.Subject`, the output root, :class:`Settings`), so it runs on any
worker of the execution layer (:mod:`gc_ocp.batch.run`). What it guarantees:

* **Complete or not at all.** A subject's files are staged and moved in together
  (:class:`~gc_ocp.outputs.OutputSet`); ``done.json`` is written last, so a subject whose
  ``done.json`` exists is complete. A task killed midway leaves the previous set (or nothing).
* **Resumable.** ``done.json`` carries the subject's *key*: the SHA-256 of the package version,
  the settings, the subject's values and the *content* of every input file (a renamed or moved
  file keeps its key; an edited one does not). A later run with the same key reads the subject's
  summary rows from ``done.json`` and does nothing else.
* **A failure is a result.** Any error of the subject (a bad file, a fit that does not
  converge, a bug) is caught, written to ``OUT/<subject>/error.json`` (type, message, fix) and
  returned as the subject's rows with its status; the other subjects go on. Interrupts
  (Ctrl-C) are not caught.
* **Kinematics cached on disk** under ``OUT/.cache/kinematics/``, keyed by the trial's files'
  content and the kinematics settings: a rerun with other fit settings (or a diagnosis after a
  fit) does not recompute them.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import pickle
import sys
import time
import traceback
import types
import warnings
from pathlib import Path

from gc_ocp.batch.manifest import Subject
from gc_ocp.batch.summary import error_rows, subject_rows
from gc_ocp.errors import GcOcpError, InputError, SolveError
from gc_ocp.estimation.bias import check_replicates
from gc_ocp.outputs import OutputSet, atomic_write, atomic_write_text, owner_of
from gc_ocp.text import json_text
from gc_ocp.workflow.provenance import sha256

DONE = "done.json"
ERROR = "error.json"
BATCH = "gc-ocp batch"
"""The command that owns a study's folders (:data:`~gc_ocp.outputs.OWNER`)."""
DIAGNOSIS_OUTPUTS = ("diagnosis.json", "diagnosis_report.html")
KINEMATICS_CACHE = Path(".cache") / "kinematics"


@dataclasses.dataclass(frozen=True)
class Settings:
    """What every subject of a run is fitted with: ``diagnose`` (also run the sim-to-real
    diagnosis on the subject's trials), ``pose_scale`` (estimate the pose correction's width,
    as ``gc-ocp fit`` does by default), ``sole_scale`` (estimate the sole correction's width
    too; None: as :func:`gc_ocp.workflow.fitting.fit` decides, with ``pose_scale``),
    ``bias_correction`` (replicates of the markers' noise's bias correction, 0: none, None: as
    :func:`gc_ocp.workflow.fitting.fit` decides from the markers' noise;
    :mod:`gc_ocp.estimation.bias`), ``strict_trials`` (a trial that cannot be used fails its
    subject, instead of being skipped with its reason: :mod:`gc_ocp.workflow.trials`)."""

    diagnose: bool = False
    pose_scale: bool = True
    sole_scale: bool | None = None
    bias_correction: int | None = None
    strict_trials: bool = False

    def __post_init__(self) -> None:
        check_replicates(self.bias_correction)  # before any subject is fitted

    def to_json(self) -> dict:
        return dataclasses.asdict(self)


def _digest(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()


def subject_key(subject: Subject, settings: Settings) -> str:
    """The key of a subject's results (module doc): version, settings, values, file contents."""
    from gc_ocp import __version__

    values = {
        f.name: getattr(subject, f.name)
        for f in dataclasses.fields(subject)
        if f.name not in ("trials", "static", "id")
    }
    # the ground reactions a TRC is paired with when the manifest gives none (the file beside
    # it): its content is an input as the manifest's are. A file that is not there keys as
    # None (the trial is skipped with its reason, or fails a one-trial subject, when loaded):
    # once it is there, the key is another
    files = [[_content(f.trial), _content(f.grf)] for f in subject_files(subject)]
    static = sha256(subject.static) if subject.static else None
    return _digest(
        {
            "version": __version__,
            "settings": settings.to_json(),
            "values": values,
            "files": files,
            "static": static,
            "markerset": _markerset_content(subject),
        }
    )


def _content(path: Path | None) -> str | None:
    """The digest of a file's content; None where there is no file (not given or not there)."""
    return sha256(path) if path is not None and Path(path).is_file() else None


def _markerset_content(subject: Subject) -> str | None:
    """The digest of the subject's marker-set file: a result made with a marker set is stale
    once the file is edited, though its name is the same."""
    from gc_ocp.model.markerset import markerset_path

    if subject.markerset is None:
        return None
    p = markerset_path(subject.markerset)
    return sha256(p) if p.is_file() else None


def completed(folder: Path, key: str) -> dict | None:
    """``done.json`` of ``folder`` when it is complete and valid for ``key`` (every file it
    lists present), else None."""
    path = folder / DONE
    try:
        done = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if done.get("key") != key or not all((folder / f).is_file() for f in done.get("files", [])):
        return None
    return done


def _kinematics(trial, subject: Subject, spec, cache_root: Path):
    """The trial's kinematics, from the disk cache when the same files and settings made them."""
    from gc_ocp import __version__
    from gc_ocp.io import load_static
    from gc_ocp.kinematics import compute_kinematics

    key = _digest(
        {
            "version": __version__,
            "trial": sha256(spec.path),
            "grf": sha256(spec.grf) if spec.grf else None,
            "static": sha256(subject.static) if subject.static else None,
            "markerset": subject.markerset,
            "markerset_file": _markerset_content(subject),
            "cutoff": subject.cutoff,
            "foot_roll": subject.foot_roll,
            "mass": subject.mass,
            "height": subject.height,
            "belt_speed": subject.belt_speed,
        }
    )
    path = cache_root / f"{key}.pkl"
    try:
        cached = pickle.loads(path.read_bytes())
        # the key is the files' content: the same recording under another file name (a copy)
        # has these kinematics, under its own name
        return dataclasses.replace(cached, trial_name=trial.name)
    except (OSError, pickle.UnpicklingError, EOFError, AttributeError, TypeError):
        pass
    kw = {} if subject.cutoff is None else {"cutoff_hz": subject.cutoff}
    static = load_static(subject.static, trial) if subject.static is not None else None
    kin = compute_kinematics(
        trial, markerset=subject.markerset, static=static, foot_roll=subject.foot_roll, **kw
    )
    atomic_write(path, lambda tmp: tmp.write_bytes(pickle.dumps(kin)))
    return kin


def subject_files(subject: Subject, *, keep_going: bool = True) -> list:
    """Each trial's files (:class:`~gc_ocp.io.pairing.TrialFiles`): a TRC whose GRF file the
    manifest gives keeps it; the others are paired as ``gc-ocp fit`` pairs them (the file beside
    the TRC); a C3D carries its plates. A TRC that is not there or has no ground reactions
    carries its error (:meth:`~gc_ocp.io.pairing.TrialFiles.require`, raised when it is loaded,
    so that the subject's other trials go on, as in ``gc-ocp fit``); ``keep_going=False``
    raises it here."""
    from gc_ocp.io.pairing import TrialFiles, pair_trials

    unpaired = [t.path for t in subject.trials if t.grf is None]
    found = iter(pair_trials(unpaired, keep_going=keep_going) if unpaired else [])
    return [
        TrialFiles(t.path, t.grf, "manifest") if t.grf is not None else next(found)
        for t in subject.trials
    ]


def load_subject(subject: Subject, cache_root: Path, *, strict: bool = False) -> tuple:
    """``([(Trial, TrialKinematics), ...], [SkippedTrial, ...])`` of the subject (ground
    reactions paired as ``gc-ocp fit`` pairs them): a trial that cannot be used is skipped with
    its reason when others remain, unless ``strict`` (:mod:`gc_ocp.workflow.trials`)."""
    from gc_ocp.io import load_trial
    from gc_ocp.workflow.trials import usable_trials

    files = subject_files(subject)
    specs = dict(zip(map(id, files), subject.trials, strict=True))

    def load(f):
        return load_trial(
            f.require().trial,
            grf=f.grf,
            mass=subject.mass,
            height=subject.height,
            belt_speed=subject.belt_speed,
        )

    def pose(f, trial):
        spec = dataclasses.replace(specs[id(f)], grf=f.grf)
        return _kinematics(trial, subject, spec, cache_root)

    return usable_trials(files, load, pose, strict=strict)


def _one_thread() -> bool:
    """Whether this task runs alone in its process: in this process (no Dask worker) or on a
    worker with one thread (the local cluster's; a ``dask-worker`` may run several)."""
    try:
        from distributed import get_worker

        worker = get_worker()
    except (ImportError, ValueError):
        return True
    n = getattr(getattr(worker, "state", None), "nthreads", None)
    return (n if n is not None else getattr(worker, "nthreads", 1)) == 1


def _fix(error: BaseException) -> str:
    """What the user can do about a subject's error, by its kind."""
    if isinstance(error, FileNotFoundError):
        return (
            f"{error.filename} does not exist: fix the subject's path (or restore the file), "
            "then rerun (finished subjects are kept)"
        )
    if isinstance(error, InputError):
        return "fix the input as the message says, then rerun (finished subjects are kept)"
    if isinstance(error, SolveError):
        return (
            "the fit did not converge: look at the subject's trials (gc-ocp fit on them alone "
            "prints the checks and flags); a trial with few usable stances is the usual cause"
        )
    if isinstance(error, GcOcpError):
        return "see the message; rerun after fixing it (finished subjects are kept)"
    return "unexpected: report it with this error.json (it holds the traceback)"


def _peak_rss_mb() -> float | None:
    """[MB] The peak resident memory of this (worker) process so far; None where unknown."""
    try:
        import resource
    except ImportError:  # not on POSIX
        return None
    kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # kilobytes on Linux
    return kb / 1024.0 if sys.platform != "darwin" else kb / 2**20


def process_subject(subject: Subject, out_root: str | Path, settings: Settings) -> dict:
    """The task (module doc). Returns ``{"subject", "status" ("done", "skipped" or "failed"),
    "rows", "seconds", "error", "peak_rss_mb"}`` (the last: the worker process's peak memory
    so far, for the study's benchmark)."""
    return {**_process(subject, Path(out_root), settings), "peak_rss_mb": _peak_rss_mb()}


def _process(subject: Subject, out_root: Path, settings: Settings) -> dict:
    import matplotlib

    matplotlib.use("Agg")
    folder = out_root / subject.id
    t0 = time.perf_counter()
    try:  # an input file gone or unreadable: the subject's error, not the task's (module doc)
        key = subject_key(subject, settings)
        error = None
    except Exception as e:
        key, error = None, (e, traceback.format_exc())
    done = completed(folder, key) if key is not None else None
    if done is not None:
        return {
            "subject": subject.id,
            "status": "skipped",
            "rows": done["rows"],
            "seconds": done.get("seconds"),
            "error": None,
        }
    # a subject's warnings are recorded with it (done.json / error.json), not printed by the
    # worker into the run's console between the progress lines; the notes among them are also
    # in fit.json (its checks and provenance). Only where this task is the process's one
    # thread of work: catch_warnings swaps a process-wide hook, which tasks on other threads
    # would share. The filters stay as they are (an "error" filter still raises).
    caught: list = []
    if error is None:
        with (
            warnings.catch_warnings(record=True) if _one_thread() else contextlib.nullcontext([])
        ) as caught:
            try:
                rows, files = _fit_subject(subject, folder, out_root / KINEMATICS_CACHE, settings)
            except Exception as e:  # every error of one subject is its result (module doc)
                error = e, traceback.format_exc()
    said = list(dict.fromkeys(str(w.message) for w in caught))
    if error is not None:
        e, trace = error
        seconds = time.perf_counter() - t0
        err = {
            "type": type(e).__name__,
            "message": str(e),
            "fix": _fix(e),
            "traceback": trace,
            "warnings": said,
        }
        if not _owned_by_another_command(folder):  # (else it is not ours to write in)
            from gc_ocp.workflow.fit_files import FIT_OUTPUTS

            folder.mkdir(parents=True, exist_ok=True)
            # an earlier run's outputs of other inputs (the key changed) would sit beside this
            # failure as if they were its subject's results: removed with its done.json
            for name in (DONE, *FIT_OUTPUTS, *DIAGNOSIS_OUTPUTS):
                (folder / name).unlink(missing_ok=True)
            atomic_write_text(folder / ERROR, json_text({"key": key, **err}, indent=2))
        return {
            "subject": subject.id,
            "status": "failed",
            "rows": error_rows(subject, err, seconds),
            "seconds": seconds,
            "error": {k: err[k] for k in ("type", "message", "fix")},
        }
    seconds = time.perf_counter() - t0
    for r in rows:
        r["seconds"] = seconds
    doc = {
        "key": key,
        "subject": subject.id,
        "files": files,
        "rows": rows,
        "seconds": seconds,
        "warnings": said,
    }
    atomic_write_text(folder / DONE, json_text(doc, indent=2))
    stale = folder / ERROR
    if stale.exists():
        stale.unlink()
    return {
        "subject": subject.id,
        "status": "done",
        "rows": rows,
        "seconds": seconds,
        "error": None,
    }


def _owned_by_another_command(folder: Path) -> bool:
    """The subject's folder holds the outputs of another command than ``gc-ocp batch``
    (:data:`~gc_ocp.outputs.OWNER`): nothing of this run is written there."""
    return owner_of(folder) not in ("", BATCH)


def _fit_subject(
    subject: Subject, folder: Path, cache_root: Path, settings: Settings
) -> tuple[list[dict], list[str]]:
    """Fit (and diagnose) one subject; its files committed into ``folder``. Returns the summary
    rows and the names of the files written."""
    from gc_ocp.workflow.fit_files import FIT_OUTPUTS, write_fit
    from gc_ocp.workflow.fitting import fit
    from gc_ocp.workflow.provenance import provenance

    pairs, skipped = load_subject(subject, cache_root, strict=settings.strict_trials)
    options = types.SimpleNamespace(
        command="batch",
        subject=subject.id,
        **{k: v for k, v in dataclasses.asdict(subject).items() if k not in ("id", "trials")},
        **settings.to_json(),
    )
    prov = provenance(options, pairs, skipped)
    out = OutputSet(folder, FIT_OUTPUTS + DIAGNOSIS_OUTPUTS + (ERROR,), BATCH)
    try:
        report = fit(
            pairs,
            holdout=subject.holdout,
            pose_scale=settings.pose_scale,
            sole_scale=settings.sole_scale,
            bias_correction=settings.bias_correction,
        )
        fit_doc = write_fit(
            out, report, prov, {"trials": [kin.info.get("landmarks") for _, kin in pairs]}
        )
        diagnosis = None
        if settings.diagnose:
            from gc_ocp.diagnosis.report import report_html

            d = _diagnose(pairs)
            diagnosis = d.to_json()
            out.text("diagnosis.json", json_text({**diagnosis, "provenance": prov}, indent=2))
            out.text("diagnosis_report.html", report_html(d, provenance=prov))
        # an earlier done.json (other inputs or settings) must not stand beside the new files:
        # an interrupt between the commit and this run's done.json left it there, and a run
        # with the earlier settings took these files for its results
        (folder / DONE).unlink(missing_ok=True)
        written = [p.name for p in out.commit()]
    finally:
        out.discard()
    return subject_rows(subject, fit_doc, diagnosis), written


def _diagnose(pairs):
    """The subject's :class:`~gc_ocp.diagnosis.Diagnosis`, its candidate fits and null draws as
    tasks on the same execution layer when this runs on a Dask worker."""
    from distributed import get_worker, worker_client

    from gc_ocp.diagnosis import diagnose

    try:
        get_worker()
    except ValueError:  # not on a Dask worker: in this process
        return diagnose(pairs, workers=1)
    with worker_client() as client:  # leaves the worker's slot to the diagnosis's own tasks
        return diagnose(pairs, executor=client.get_executor())


__all__ = (
    "Settings",
    "completed",
    "load_subject",
    "process_subject",
    "subject_files",
    "subject_key",
)
