"""Where work runs: the cores this process may use, and a Dask client (a local cluster of worker
processes, a running scheduler, or the caller's own client).

A task the package sends out is a plain function of picklable plain data (a subject of a study,
:func:`gc_ocp.batch.subject.process_subject`; a candidate's fits or a null draw of the
diagnosis, :mod:`gc_ocp.diagnosis.execution`), so it runs on any
:class:`concurrent.futures.Executor`, a Dask client's (``client.get_executor()``) included.

Workers are processes with one thread each: a fit is compiled code and Ipopt, threads would only
contend. A study's local cluster (:mod:`gc_ocp.batch`) *spawns* its workers (Dask's default: a
fresh interpreter each), so a Python script that starts one needs the
``if __name__ == "__main__":`` guard; a notebook and the ``gc-ocp`` command do not. With
``fork=True`` the workers are forked where the platform can (Linux): they start with the
parent's modules and compiled per-frame functions loaded (0.3 s to the first tasks against
16.9 s spawned, ``benchmarks/dask_start.py``), but a fork from a process that runs other
threads (a Jupyter kernel) can deadlock, so nothing in the package forks by default
(``docs/batch.md``, *The diagnosis on Dask*).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
from collections.abc import Iterator


def available_cores() -> int:
    """The CPU cores this process may use (its affinity where the platform tells it)."""
    n = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return max(1, n or 1)


@contextlib.contextmanager
def dask_client(
    workers: int | None = None, scheduler: str | None = None, client=None, fork: bool = False
) -> Iterator:
    """A ``distributed.Client`` for the ``with`` block: ``client`` as it is (the caller's; left
    open), else one connected to ``scheduler`` (an address such as ``tcp://host:8786``), else a
    ``LocalCluster`` of ``workers`` single-threaded processes (default: :func:`available_cores`)
    started here, forked from this process with ``fork`` where the platform can (module doc);
    what is started here is closed at the end of the block."""
    if client is not None:
        yield client
        return
    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        with Client(scheduler) as c:
            yield c
        return
    method = "fork" if fork and "fork" in multiprocessing.get_all_start_methods() else None
    config = {} if method is None else {"distributed.worker.multiprocessing-method": method}
    with (
        dask.config.set(config),
        LocalCluster(
            n_workers=workers or available_cores(),
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # a free port: no clash with another cluster's 8787
        ) as cluster,
        Client(cluster) as c,
    ):
        yield c


__all__ = ("available_cores", "dask_client")
