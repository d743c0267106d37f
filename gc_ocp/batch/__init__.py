"""Studies, not trials: fit (and diagnose) many subjects on Dask, resumable, with progress and a
summary table (``docs/batch.md``).

>>> from gc_ocp import batch
>>> # skipped: it needs a study's manifest and trial files, and fits every subject (minutes)
>>> result = batch.run("study.csv", "out/", workers=2)  # doctest: +SKIP
>>> result.counts()  # subjects per status; out/summary.csv, out/summary.parquet  # doctest: +SKIP
{'done': 2}
"""

from gc_ocp.batch.manifest import Subject, TrialSpec, read_manifest
from gc_ocp.batch.run import BatchResult, run
from gc_ocp.batch.subject import Settings, process_subject

__all__ = (
    "BatchResult",
    "Settings",
    "Subject",
    "TrialSpec",
    "process_subject",
    "read_manifest",
    "run",
)
