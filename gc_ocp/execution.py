"""Where work runs: the cores this process may use, and a Dask client (a local cluster of worker
processes, a running scheduler, or the caller's own client). Every parallel path of the package
goes through :func:`dask_client`: a study's subjects (:mod:`gc_ocp.batch`) and a diagnosis's
candidate fits and null draws (:func:`gc_ocp.diagnosis.execution.candidate_executor`).

A task the package sends out is a plain function of picklable plain data (a subject of a study,
:func:`gc_ocp.batch.subject.process_subject`; a candidate's fits or a null draw of the
diagnosis, :mod:`gc_ocp.diagnosis.execution`), so it runs on any
:class:`concurrent.futures.Executor`, a Dask client's (``client.get_executor()``) included.

Workers are processes with one thread each: a fit is compiled code and Ipopt, threads would only
contend. How a local cluster starts its worker processes (``start``):

* ``"forkserver"`` (the default where the platform has it: Linux, macOS): each worker is forked
  from a *server* process that Python starts once per session as a fresh, single-threaded
  interpreter and that imports gc_ocp first (:data:`PRELOAD`). Workers start with the package
  loaded (what a spawned worker spends most of its start on, ``benchmarks/dask_start.py``), and
  nothing is forked from the calling process, which may run threads (a Jupyter kernel: a fork
  of it copies locks other threads hold, and deadlocked notebook 03 when Dask's workers were
  forked from it).
* ``"spawn"`` (Dask's own default; the only one on Windows): a fresh interpreter per worker.
* ``"fork"``: forked from this process: the fastest start, but unsafe where this process runs
  other threads (above); only on request.

With ``forkserver`` and ``spawn`` a worker imports the caller's main *script* again, so a
script that starts a cluster (``gc_ocp.batch.run``, a parallel ``gc_ocp.diagnose``) needs the
``if __name__ == "__main__":`` guard; a notebook and the ``gc-ocp`` command do not.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
from collections.abc import Iterator

START_METHODS = ("forkserver", "spawn", "fork")
"""How a local cluster may start its workers (module doc), the package's choice first."""

PRELOAD = ("distributed", "gc_ocp.diagnosis", "gc_ocp.batch.subject")
"""What the forkserver imports before it forks a worker: Dask's worker and the modules of the
package's tasks (the diagnosis's candidate fits and null draws, a study's subject)."""


def available_cores() -> int:
    """The CPU cores this process may use (its affinity where the platform tells it)."""
    n = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return max(1, n or 1)


def start_method(start: str | None = None) -> str:
    """The start method a local cluster uses: ``start`` (one of :data:`START_METHODS`), or the
    first of them this platform has."""
    have = multiprocessing.get_all_start_methods()
    if start is None:
        return next(m for m in START_METHODS if m in have)
    if start not in START_METHODS:
        raise ValueError(f"start={start!r}: use one of {', '.join(START_METHODS)}")
    if start not in have:
        raise ValueError(
            f"start={start!r}: this platform starts processes only by {', '.join(have)}"
        )
    return start


def _prepare(method: str) -> None:
    """Dask's multiprocessing context for ``method`` (called where Dask's
    ``multiprocessing-method`` is set to it), with the forkserver's preload extended by
    :data:`PRELOAD` (distributed sets its own list once, the first time it is asked for the
    forkserver context; the list is read when the server starts, at the first worker)."""
    from distributed.utils import get_mp_context

    ctx = get_mp_context()  # under the caller's multiprocessing-method setting
    if method == "forkserver":
        from multiprocessing import forkserver

        # distributed's list, without the user's script (``__main__``: Python's own default)
        have = getattr(forkserver._forkserver, "_preload_modules", None) or []
        keep = [m for m in have if m != "__main__"]
        ctx.set_forkserver_preload(list(dict.fromkeys([*keep, *PRELOAD])))


@contextlib.contextmanager
def dask_client(
    workers: int | None = None,
    scheduler: str | None = None,
    client=None,
    start: str | None = None,
) -> Iterator:
    """A ``distributed.Client`` for the ``with`` block: ``client`` as it is (the caller's; left
    open), else one connected to ``scheduler`` (an address such as ``tcp://host:8786``), else a
    ``LocalCluster`` of ``workers`` single-threaded processes (default: :func:`available_cores`)
    started here by ``start`` (:func:`start_method`; module doc); what is started here is closed
    at the end of the block."""
    if client is not None:
        yield client
        return
    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        from gc_ocp.errors import InputError

        try:  # only the connection: an error of the block's work is the work's
            c = Client(scheduler)
        except (ValueError, OSError) as e:  # a malformed address; none answering (timeout)
            raise InputError(
                f"--scheduler {scheduler}: cannot connect ({e}); give a running Dask "
                "scheduler's address, e.g. tcp://10.0.0.5:8786, or leave --scheduler out for a "
                "local cluster (--workers N)."
            ) from None
        with c:
            yield c
        return
    method = start_method(start)
    settings = {
        "distributed.worker.multiprocessing-method": method,
        # its workers ignore Ctrl-C: the command stops and closes the cluster (one line, not
        # one traceback per worker); added to the caller's own preloads
        "distributed.worker.preload": [
            *dask.config.get("distributed.worker.preload", []),
            "gc_ocp.signals",
        ],
    }
    with dask.config.set(settings):
        _prepare(method)
        try:
            cluster = LocalCluster(
                n_workers=workers or available_cores(),
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",  # a free port: no clash with another cluster's 8787
            )
        except RuntimeError as e:
            raise _start_error(method, e) from e
        from gc_ocp.signals import quiet_close

        quiet_close("distributed.nanny")  # its workers' nannies run here (signals.CLOSE_NOISE)
        with cluster, Client(cluster) as c:
            yield c


def _start_error(method: str, error: Exception) -> Exception:
    """What to tell when a local cluster's workers did not start: the usual cause, a script
    without the main guard (its workers import it again and start a cluster of their own), named
    with the fix; else the error with the way round it."""
    import sys

    from gc_ocp.errors import InputError

    script = getattr(sys.modules.get("__main__"), "__file__", None)
    if script and method != "fork":
        return InputError(
            f"The local cluster's worker processes did not start ({error}). Its workers import "
            f"the main script {script} again, so a script that runs a study or a parallel "
            'diagnosis must keep its code under `if __name__ == "__main__":`; or run it in '
            "this process (workers=1)."
        )
    return InputError(
        f"The local cluster's worker processes did not start ({error}); run in this process "
        "(workers=1) or give a running scheduler (docs/batch.md)."
    )


__all__ = ("PRELOAD", "START_METHODS", "available_cores", "dask_client", "start_method")
