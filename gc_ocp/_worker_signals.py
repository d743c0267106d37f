"""Loaded by each worker process of a local cluster that gc_ocp starts (Dask's worker preload,
:func:`gc_ocp.execution.dask_client`), never by a user's process: the worker ignores Ctrl-C.

A terminal's Ctrl-C reaches every process of its group: the command, which stops with one line
and closes its cluster (its workers with it), and each worker, which printed a traceback of its
own (four in an interruption review of ``gc-ocp diagnose --workers 2``, ~100 lines before the
command's one). A worker has nothing to clean up that its cluster's closing does not."""

from __future__ import annotations

import signal
import threading


def dask_setup(worker=None) -> None:
    """Dask's preload hook: ignore SIGINT in this worker process (only the main thread may set
    a handler; elsewhere nothing is changed)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
