"""Run a study on Dask: one task per subject (:func:`~gc_ocp.batch.subject.process_subject`),
on a local cluster of worker processes or on a running scheduler, with progress, and the
summary table at the end.

* **Where it runs.** ``scheduler=None``: a ``distributed.LocalCluster`` of ``workers`` processes
  (default: the cores this process may use), one thread each (a fit is compiled code and Ipopt:
  threads would only contend), started here and closed at the end. ``scheduler="tcp://host:8786"``:
  the tasks go to that cluster (its workers need gc_ocp installed and the study's files at the
  same paths, e.g. a shared file system; ``docs/batch.md``). ``client=``: a
  ``distributed.Client`` of the caller's, used as it is.
* **A worker's compiled functions** are built once per worker process: a model's per-frame
  functions are compiled to the machine's disk cache the first time (``estimation/compiled.py``)
  and kept loaded by the worker for its next subjects.
* **Resumable.** A subject whose results are complete for the same inputs and settings is
  skipped (its rows are read back); a subject whose task raised is recorded and the others go
  on; a worker that dies takes only its running subject with it (recorded as failed: rerun to
  redo it). Ctrl-C cancels what runs, closes the cluster and writes no summary; every finished
  subject stays on disk and a rerun skips it.
* **Progress** on stderr when it is a terminal (or with ``progress=``): subjects done, skipped,
  failed, running and remaining, and the estimated time left; nothing otherwise.
"""

from __future__ import annotations

import contextlib
import dataclasses
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from gc_ocp import signals
from gc_ocp.batch.manifest import Subject, TrialSpec, check_id, read_manifest
from gc_ocp.batch.page import summary_html
from gc_ocp.batch.subject import BATCH, Settings, process_subject
from gc_ocp.batch.summary import error_rows, write_summary
from gc_ocp.errors import InputError
from gc_ocp.execution import dask_client
from gc_ocp.outputs import atomic_write_text, check_writable, claim


@dataclasses.dataclass
class BatchResult:
    """A study's outcome as plain data: ``rows`` (the summary table, one dict per subject and
    foot, :data:`~gc_ocp.batch.summary.COLUMNS`), ``subjects`` (per subject: status, seconds,
    error, the peak memory of the worker process that ran it), the output folder and the wall
    time."""

    rows: list[dict]
    subjects: list[dict]
    out: Path
    seconds: float

    def counts(self) -> dict[str, int]:
        """Subjects per status (``done``, ``skipped``, ``failed``)."""
        out: dict[str, int] = {}
        for s in self.subjects:
            out[s["status"]] = out.get(s["status"], 0) + 1
        return out

    def failed(self) -> list[dict]:
        return [s for s in self.subjects if s["status"] == "failed"]


class Progress:
    """Counts of a run and the line that reports them (module doc)."""

    def __init__(self, total: int, say: Callable[[str], None] | None) -> None:
        self.total, self.say = total, say
        self.status: dict[str, int] = {}
        self.t0 = time.perf_counter()
        self.work: list[float] = []  # seconds of the subjects fitted in this run

    def update(self, outcome: dict) -> None:
        self.status[outcome["status"]] = self.status.get(outcome["status"], 0) + 1
        if outcome["status"] == "done" and outcome.get("seconds"):
            self.work.append(float(outcome["seconds"]))
        if self.say is not None:
            self.say(self.line(outcome))

    def line(self, outcome: dict) -> str:
        finished = sum(self.status.values())
        left = self.total - finished
        elapsed = time.perf_counter() - self.t0
        fitted = self.status.get("done", 0) + self.status.get("failed", 0)
        eta = ""
        if left and fitted:
            eta = f", about {_duration(elapsed / fitted * left)} left"
        what = outcome["status"]
        if outcome.get("error"):
            msg = outcome["error"]["message"]
            if len(msg) > 120:  # cut at a word, and say where the whole message is
                msg = msg[:120].rsplit(" ", 1)[0] + f"... ({outcome['subject']}/error.json)"
            what += f" ({outcome['error']['type']}: {msg})"
        return (
            f"[{finished}/{self.total}] {outcome['subject']} {what}; "
            f"done {self.status.get('done', 0)}, skipped {self.status.get('skipped', 0)}, "
            f"failed {self.status.get('failed', 0)}, remaining {left}{eta}"
        )


def _duration(s: float) -> str:
    return f"{s:.0f} s" if s < 90 else f"{s / 60:.0f} min" if s < 5400 else f"{s / 3600:.1f} h"


ROOT_OUTPUTS = ("summary.csv", "summary.parquet", "summary.html")
"""The study's own files beside the subjects' folders: no subject may be named so."""


def _subjects(manifest) -> list:
    """The subjects of ``manifest`` (a manifest file or folder, or Subject objects), each
    checked: a Subject, its id usable as a folder inside the study's (no path, none of
    :data:`ROOT_OUTPUTS`)."""
    if manifest is None:
        raise InputError("Give a manifest: a CSV or TOML file, a study folder, or Subject objects.")
    if isinstance(manifest, (str, Path)):
        subjects = read_manifest(manifest)
    else:
        subjects = list(manifest)
    for s in subjects:
        if not isinstance(s, Subject):
            raise InputError(
                f"A study's subjects are gc_ocp.batch.Subject objects (or a manifest file or "
                f"folder), not {type(s).__name__} {s!r:.60}; e.g. "
                "Subject('S1', (TrialSpec(Path('walk.c3d')),))."
            )
        if check_id(s.id, f"Subject {s.id!r}") != s.id:  # (a manifest's ids are stripped)
            raise InputError(
                f"Subject id {s.id!r} has spaces around it (its folder's name would too); give "
                f"{s.id.strip()!r}."
            )
        if s.id in ROOT_OUTPUTS:
            raise InputError(
                f"Subject id {s.id!r} is the name of one of the study's own files "
                f"({', '.join(ROOT_OUTPUTS)}); rename the subject."
            )
        bad = [t for t in s.trials if not isinstance(t, TrialSpec)]
        if bad:
            raise InputError(
                f"Subject {s.id}: trials are TrialSpec objects (TrialSpec(Path('walk.c3d'))), "
                f"not {type(bad[0]).__name__} {bad[0]!r:.60}."
            )
    return subjects


def clean_stale(out: Path, ids: Sequence[str]) -> list[Path]:
    """Remove what a killed run may have left of these subjects: the staging folders of their
    file sets (``OUT/.<id>.*``, :class:`~gc_ocp.outputs.OutputSet`) and half-written temporary
    files (``OUT/<id>/.*.tmp*``, :func:`~gc_ocp.outputs.atomic_write`). Never a finished file.
    (One run per output folder at a time: a concurrent run's staging would look stale.)"""
    import shutil

    removed = []
    for sid in ids:
        for p in out.glob(f".{sid}.*"):
            if p.is_dir():
                shutil.rmtree(p, ignore_errors=True)
                removed.append(p)
        for p in (out / sid).glob(".*.tmp*"):
            p.unlink(missing_ok=True)
            removed.append(p)
    return removed


LOCK = ".gc_ocp_batch.lock"
"""The file a running study holds locked (``flock``) in its folder: a second run on the same
folder is refused. (Both ran before: the second's start removed the first's staging folders as
stale, and its failing subject deleted the first's finished results.)"""


def _lock(out: Path):
    """``out``'s :data:`LOCK` held for this run (the open file; closing it releases the lock,
    as does the end of the process), or :class:`InputError` when another run holds it."""
    f = open(out / LOCK, "a")  # noqa: SIM115 (held until the run ends)
    try:
        import fcntl
    except ImportError:  # (Windows: no flock; one run per folder stays the user's rule)
        return f
    try:
        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        f.close()
        raise InputError(
            f"--out {out}: another gc-ocp batch is running on this folder; wait for it to end or "
            "give another folder (one run per output folder at a time)."
        ) from None
    return f


def _progress_default() -> Callable[[str], None] | None:
    if sys.stderr.isatty():
        return lambda s: print(s, file=sys.stderr, flush=True)
    return None


def _gather(client, subjects, out: Path, settings: Settings, bar, outcomes: dict, futures: dict):
    """Submit one task per subject to ``client`` and record each outcome as it arrives (a task
    that could not run, e.g. its worker died, as a failed subject); on any interruption the
    tasks still queued or running are cancelled."""
    from distributed import as_completed

    try:
        for s in subjects:
            f = client.submit(process_subject, s, str(out), settings, pure=False, retries=0)
            futures[f] = s
        for f in as_completed(futures):
            s = futures[f]
            try:
                outcome = f.result()
            except Exception as e:  # the worker died (KilledWorker) or could not run the task
                err = {
                    "type": type(e).__name__,
                    "message": str(e),
                    "fix": "the worker running it died (memory?); rerun to redo this subject",
                }
                outcome = {
                    "subject": s.id,
                    "status": "failed",
                    "rows": error_rows(s, err, float("nan")),
                    "seconds": None,
                    "error": err,
                    "peak_rss_mb": None,
                }
            outcomes[s.id] = outcome
            bar.update(outcome)
    except BaseException:
        for f in futures:
            f.cancel()
        raise


def run(
    manifest: str | Path | Sequence[Subject],
    out: str | Path,
    *,
    diagnose: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    client=None,
    settings: Settings | None = None,
    progress: Callable[[str], None] | None | str = "auto",
) -> BatchResult:
    """Fit every subject of ``manifest`` (a manifest file, a study folder or a list of
    :class:`~gc_ocp.batch.manifest.Subject`) into ``out`` (module doc) and write
    ``out/summary.csv`` and ``out/summary.parquet``. ``diagnose``: also diagnose each subject
    (the same as ``settings.diagnose``); ``settings``: how every subject is fitted.
    ``progress``: a function called with each progress line, None for silence, "auto" for
    stderr when it is a terminal."""
    subjects = _subjects(manifest)
    if not isinstance(settings, (Settings, type(None))):
        raise InputError(
            f"settings must be a gc_ocp.batch.Settings, not {type(settings).__name__}; e.g. "
            "Settings(diagnose=True)."
        )
    ids = [s.id for s in subjects]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise InputError(f"Subject id(s) {', '.join(dup)} appear twice; give each subject once.")
    # one output folder on a case-insensitive file system (macOS, Windows): the two subjects'
    # files would overwrite each other
    folders: dict[str, list[str]] = {}
    for i in ids:
        folders.setdefault(i.casefold(), []).append(i)
    same = [names for names in folders.values() if len(names) > 1]
    if same:
        raise InputError(
            f"Subject ids {' and '.join(same[0])} differ only in case: their output folders are "
            "one on a case-insensitive file system (macOS, Windows); rename one, or give each "
            "subject once."
        )
    if out is None:
        raise InputError("Give the study's output folder (out=..., --out DIR).")
    if workers is not None and workers < 1:  # before the study's folder is made and claimed
        raise InputError(f"workers must be 1 or more, but got {workers}")
    out = check_writable(out, command=BATCH)
    cluster = contextlib.ExitStack()
    # the workers (a scheduler's connection, a local cluster's start) before the study's folder
    # is made and claimed: a scheduler that did not answer left a claimed folder, lock and
    # owner files and no summary, looking like a study's
    client = cluster.enter_context(dask_client(workers, scheduler, client))
    try:
        out.mkdir(parents=True, exist_ok=True)
        lock = _lock(out)  # before anything of the study's is written or removed
    except BaseException:
        cluster.close()
        raise
    try:
        claim(out, BATCH)  # the study's folder, before any subject's
        clean_stale(out, ids)
        settings = settings or Settings()
        if diagnose:
            settings = dataclasses.replace(settings, diagnose=True)
        say = _progress_default() if progress == "auto" else progress
        t0 = time.perf_counter()
        bar = Progress(len(subjects), say)
        outcomes: dict[str, dict] = {}
        futures = {}
        _gather(client, subjects, out, settings, bar, outcomes, futures)
        cluster.close()  # its work is done (the summary's figures need no workers)
        # a worker killed midway left its subject's staging folder (the subject was redone elsewhere)
        clean_stale(out, ids)
        ordered = [outcomes[s.id] for s in subjects]
        result = BatchResult(
            rows=[r for o in ordered for r in o["rows"]],
            subjects=[
                {k: o[k] for k in ("subject", "status", "seconds", "error", "peak_rss_mb")}
                for o in ordered
            ],
            out=out,
            seconds=time.perf_counter() - t0,
        )
        # the page's figures (seconds) before any of the summary's files: an interrupt there left
        # summary.csv without summary.html (or beside an earlier run's)
        page = summary_html(result.rows, result.subjects, result.seconds)
        with signals.deferred():  # and an interrupt waits for the summary's three files
            write_summary(result.rows, out)
            atomic_write_text(out / "summary.html", page)
        return result
    finally:
        cluster.close()  # (on an error) first: a cancelled task may still write its subject
        lock.close()


__all__ = ("BatchResult", "clean_stale", "run")
