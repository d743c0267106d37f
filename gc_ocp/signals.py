"""Ctrl-C (SIGINT) and SIGTERM: what the package does with them, in one place.

* :func:`kept`: a block whose callee swallows the handler's exception (CasADi during an Ipopt
  solve) raises it again after the block.
* :func:`deferred`: a block that must not be cut (an output set's move into its folder) holds
  the signals and acts on the first after it.
* :func:`dask_setup`: Dask's worker preload (:func:`gc_ocp.execution.dask_client` names this
  module): a local cluster's workers ignore Ctrl-C, which their command handles.

Only handlers that run Python are touched (Ctrl-C's default one, the CLI's SIGTERM,
:class:`gc_ocp.cli.Terminated`); an ignored signal or the system's default is left as it is, and
outside the main thread (the only one Python runs handlers in, and may set them) nothing is
changed."""

from __future__ import annotations

import contextlib
import logging
import signal
import threading
from collections.abc import Callable, Iterator

SIGNALS = (signal.SIGINT, signal.SIGTERM)


def _python_handlers() -> dict[int, Callable]:
    """The Python handlers of :data:`SIGNALS` (none outside the main thread)."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    return {s: h for s in SIGNALS if callable(h := signal.getsignal(s))}


@contextlib.contextmanager
def _handled_by(previous: dict[int, Callable], handler: Callable) -> Iterator[None]:
    """``handler`` in place of each handler of ``previous`` for the block; restored after."""
    for s in previous:
        signal.signal(s, handler)
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


@contextlib.contextmanager
def kept() -> Iterator[None]:
    """Raise again, after the block, what a signal's handler raised during it. CasADi runs the
    handlers during an Ipopt solve, stops the solve and *clears* their exception: the solve
    returned as failed (``NonIpopt_Exception_Thrown``), and a multi-start went on with its other
    starts, so that ``gc-ocp fit`` ignored the Ctrl-C, wrote a result other than an
    uninterrupted run's and exited 0."""
    previous = _python_handlers()
    raised: list[BaseException] = []

    def handler(signum, frame):
        try:
            previous[signum](signum, frame)
        except BaseException as e:
            raised.append(e)
            raise

    with _handled_by(previous, handler):
        yield
    if raised:
        raise raised[0]


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """The signals wait for the block's end, then act as they would have: a set of files moved
    in one by one is never left half old, half new by an interrupt (an interruption review found
    that window by reading)."""
    previous = _python_handlers()
    held: list[tuple] = []
    try:
        with _handled_by(previous, lambda signum, frame: held.append((signum, frame))):
            yield
    finally:
        for signum, frame in held[:1]:  # the first acts (raises); the others would repeat it
            previous[signum](signum, frame)


def dask_setup(worker=None) -> None:
    """Dask's preload hook: ignore SIGINT in this worker process. A terminal's Ctrl-C reaches
    every process of its group: the command, which stops with one line and closes its cluster
    (its workers with it), and each worker, which printed a traceback of its own (four in an
    interruption review of ``gc-ocp diagnose --workers 2``, ~100 lines before the command's
    one). A worker has nothing to clean up that its cluster's closing does not.

    The closing itself made Dask's worker log what it met (:data:`CLOSE_NOISE`): a warning per
    task still running, cancelled ("... ended with CancelledError", two 300-character lines
    after the command's one), and, for a worker busy in a solve while the scheduler closed, a
    heartbeat's 30-line traceback. Those records are dropped (:class:`CloseNoise`); every other
    record of the worker is kept. Only the package's local cluster loads this preload, and its
    scheduler lives in the command's process: a worker that loses it is being closed."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    quiet_close("distributed.worker", "distributed.worker.state_machine")


CLOSE_NOISE = (
    "ended with CancelledError",  # distributed.worker.state_machine: a task cancelled at close
    "Failed to communicate with scheduler during heartbeat",  # distributed.worker: it is gone
    "Worker process still alive after",  # distributed.nanny (the command's process): killed
)
"""What Dask logs because a local cluster closes while its workers are busy, not because of a
fault (an interruption review of ``gc-ocp diagnose --workers 2``; a CI run under load)."""


class CloseNoise(logging.Filter):
    """Drops the records of :data:`CLOSE_NOISE` (:func:`dask_setup`)."""

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        return not any(m in message for m in CLOSE_NOISE)


def quiet_close(*loggers: str) -> None:
    """:class:`CloseNoise` on each of ``loggers`` (once)."""
    for name in loggers:
        log = logging.getLogger(name)
        if not any(isinstance(f, CloseNoise) for f in log.filters):
            log.addFilter(CloseNoise())
