"""Studies, not trials: fit (and diagnose) many subjects on Dask, resumable, with progress and a
summary table (``docs/batch.md``).

>>> from gc_ocp import batch
>>> # result = batch.run("study.csv", "out/", workers=2)   # summary.csv, summary.parquet
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
