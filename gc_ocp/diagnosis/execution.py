"""Where a round's candidates are fitted: one task per candidate, on any
:class:`concurrent.futures.Executor`.

A task is :func:`run_job`, a pure function of two picklable plain-data arguments: the
:class:`Job` (which model) and the :class:`RoundInputs` shared by every job of the round
(stances, fold plan, parent evaluation, weights, solver options, folds, the parent's
residual for the null). It returns the
:class:`~gc_ocp.diagnosis.compare.Evaluation` and the warnings the fits raised, which
:func:`evaluate_round` raises again in the calling process (under its filters, as if the fits
had run there). Nothing travels through module globals and no start method is assumed, so the
executor may be the package's local Dask cluster (:func:`candidate_executor`), the caller's
own executor of any kind (``tests/test_diagnosis.py`` runs a diagnosis on ``spawn``ed
processes), or a running cluster's (``dask.distributed.Client(...).get_executor()``; a study's
diagnoses run on the study's cluster).

A worker process derives a model's per-frame functions and loads them compiled from the disk
cache the first time it fits that model (``estimation/compiled.py``), and keeps them for its
next tasks. The local cluster's workers are forked from a server process that has imported
gc_ocp (:mod:`gc_ocp.execution`), so they start with the package loaded but derive each
model's functions once themselves.

One task per *fit* (a candidate's folds spread over the processes) was tried and measured
slower than one task per candidate (bundled trial 63.6 s against 49.5 s; three BTS trials
149.5 s against 149.6 s): every process then derives and loads every configuration's
functions, and the results travel between processes. The base is the exception
(:func:`evaluate_base`): it is fitted alone, before any round, so one task per candidate would
leave every process but one idle, and every process derives the base's functions anyway, to
refit it in the null's draws.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import Executor, as_completed

import numpy as np

from gc_ocp.diagnosis.compare import Evaluation, describe, evaluate, fit_fold, fit_model
from gc_ocp.diagnosis.onestep import from_own_fit, linearize_child
from gc_ocp.errors import InputError, ModelError, SolveError
from gc_ocp.estimation.problem import Weights
from gc_ocp.estimation.result import EstimationResult
from gc_ocp.estimation.solve import IpoptOptions
from gc_ocp.execution import available_cores, dask_client
from gc_ocp.stance import StanceData

MAX_WORKERS = 4
"""Most processes :func:`default_workers` proposes (each holds its own compiled functions and
fits)."""


@dataclasses.dataclass(frozen=True)
class Job:
    """One candidate of a round: the effect ``name`` tried, the ``model`` (components) it makes
    on top of the round's parent, that model's evaluation ``label`` (``"base+a+b"``) and the
    effects it adds to the base (``names``)."""

    name: str
    label: str
    model: tuple
    names: tuple[str, ...]
    full: EstimationResult | None = None  # its fit on all stances, when already made


@dataclasses.dataclass(frozen=True)
class RoundInputs:
    """What every job of a round shares: the ``stances`` (one subject), the fold ``plan``
    (groups of stance indices held out together, :func:`~gc_ocp.diagnosis.compare.fold_plan`),
    the ``parent`` evaluation (warm starts, screening), the weights and solver options of every
    fit; ``folds``: whether the jobs also fit and score the folds
    (else the fit on all stances only); ``parent_r``: the parent's weighted residual at its
    solution, given when every job also linearises its model for the null
    (:func:`~gc_ocp.diagnosis.onestep.linearize_child`, the evaluation's ``linear``)."""

    stances: tuple[StanceData, ...]
    plan: tuple[tuple[int, ...], ...]
    parent: Evaluation
    weights: Weights | None = None
    options: IpoptOptions | None = None
    folds: bool = True
    parent_r: np.ndarray | None = None


@dataclasses.dataclass(frozen=True)
class NotEvaluable:
    """The outcome of a job whose evaluation raised an input or model error, or whose fit did
    not converge from any start (:data:`NOT_EVALUABLE_ERRORS`; e.g. ``time_offset`` on a trial
    whose recording starts inside a stance's margin so that no clock offset fits): reported
    with the message, not ranked; the other candidates go on."""

    label: str
    message: str
    seconds: float = 0.0


NOT_EVALUABLE_ERRORS = (InputError, ModelError, SolveError)
"""Errors that make one candidate not evaluable on the data instead of stopping the diagnosis:
its model cannot be built on them, or no start of one of its fits (all stances, a fold, a
held-out stance) converged. A candidate is one question among several; an answer to the others
is still an answer (the note names the one left out). The base's own fit failing still stops
the diagnosis: every candidate is measured against it. Any other error is a bug and stops it."""

WarningRecord = tuple[str, type, str, int]
"""A warning raised in a task: ``(message, category, filename, lineno)``."""


def _evaluate(job: Job, inputs: RoundInputs, progress=None) -> Evaluation | NotEvaluable:
    t0 = time.perf_counter()
    try:
        ev = evaluate(
            list(inputs.stances),
            job.model,
            job.label,
            job.names,
            list(inputs.plan),
            inputs.parent,
            weights=inputs.weights,
            options=inputs.options,
            progress=progress,
            full=job.full,
            folds=inputs.folds,
        )
        if inputs.parent_r is not None and ev.linear is None:
            ev.linear = linearize_child(
                inputs.stances,
                job.model,
                inputs.parent.full,
                inputs.parent_r,
                ev.full,
                inputs.weights,
                from_own_fit(job.name),
            )
            ev.seconds = time.perf_counter() - t0
        return ev
    except NOT_EVALUABLE_ERRORS as e:
        why = f"its fit failed ({e})" if isinstance(e, SolveError) else str(e)
        if progress is not None:
            progress(f"  {job.label}: not evaluable on these data: {why}")
        return NotEvaluable(job.label, why, time.perf_counter() - t0)


def recorded(fn: Callable, *args) -> tuple[object, tuple[WarningRecord, ...]]:
    """``fn(*args)`` with the warnings it raised (recorded, not shown): a task of any kind."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = fn(*args)
    records = dict.fromkeys((str(w.message), w.category, w.filename, w.lineno) for w in caught)
    return out, tuple(records)


def _warn_again(caught: Sequence[WarningRecord]) -> None:
    for message, category, filename, lineno in caught:
        warnings.warn_explicit(message, category, filename, lineno)


def run_job(
    job: Job, inputs: RoundInputs
) -> tuple[Evaluation | NotEvaluable, tuple[WarningRecord, ...]]:
    """The task: ``job`` evaluated on ``inputs`` (fitted on all stances and on each fold,
    held-out stances scored), with the warnings its fits raised (recorded, not shown)."""
    return recorded(_evaluate, job, inputs)


def shared_once(executor: Executor, calls: Sequence[tuple]) -> list[tuple]:
    """``calls`` with every argument that all of them share (the same object) sent to a Dask
    executor's workers once, as a future, instead of pickled into every task: a round's or a
    null's shared inputs (the stances, fits and linearisations: 23 MB on six stances) were
    sent with each of its 7-32 tasks, the scheduler held every copy, and Dask warned of a
    large task graph. Any other executor gets ``calls`` unchanged (a process pool pickles each
    task's arguments anyway)."""
    client = getattr(executor, "_client", None)  # distributed.cfexecutor.ClientExecutor
    if client is None or len(calls) <= 1:
        return list(calls)
    first = calls[0]
    same = [k for k, a in enumerate(first) if all(c[k] is a for c in calls)]
    sent = {k: client.scatter(first[k], broadcast=True, hash=False) for k in same}
    return [tuple(sent.get(k, a) for k, a in enumerate(c)) for c in calls]


def run_tasks(
    fn: Callable,
    calls: Sequence[tuple],
    executor: Executor | None = None,
    stop: Callable[[list], bool] | None = None,
    look: int = 8,
    progress: Callable[[int, int], None] | None = None,
) -> list:
    """``[fn(*call) for call in calls]``, each call a task on ``executor`` (None: here, one
    after the other); the warnings the tasks raised are raised again here. ``fn`` and the
    calls' arguments must be picklable (a module-level function of plain data), as
    :func:`run_job`'s: e.g. the null's mismatch draws (:mod:`.draws`). Arguments every call
    shares go to a Dask cluster once (:func:`shared_once`).

    ``stop``: asked with the first ``k`` results whenever ``k`` is a multiple of ``look``
    (fewer than all); when it says True, the first ``k`` results are returned and the other
    calls are not made. The calls are then submitted ``look`` at a time, each batch after the
    look before it (no task is left running for nothing, none is cancelled mid-way), and the
    looks see the results in the calls' order whichever task ended first, so what is returned
    does not depend on the executor's timing (a sequential test's early stop,
    :func:`~gc_ocp.diagnosis.null.cannot_name`). ``progress``: told ``(done, of)`` after every
    result (long tasks: the refit null's draws, :mod:`.refits`)."""
    here = executor is None or len(calls) <= 1
    sent = calls if here else shared_once(executor, calls)
    step = len(calls) if stop is None else look
    out: list = []
    for k in range(0, len(calls), max(step, 1)):
        if here:
            for call in sent[k : k + step]:
                out.append(fn(*call))
                if progress is not None:
                    progress(len(out), len(calls))
        else:
            for fut in [executor.submit(recorded, fn, *call) for call in sent[k : k + step]]:
                value, caught = fut.result()
                _warn_again(caught)
                out.append(value)
                if progress is not None:
                    progress(len(out), len(calls))
        if stop is not None and len(out) < len(calls) and stop(out):
            break
    return out


def _base_fit(
    stances: tuple[StanceData, ...],
    model: tuple,
    plan: tuple[tuple[int, ...], ...],
    j: int | None,
    weights: Weights | None,
    options: IpoptOptions | None,
):
    """A task of :func:`evaluate_base`: the base's fit on all ``stances`` (``j`` None, with its
    covariance) or the folds of group ``j`` of ``plan``."""
    if j is None:
        return fit_model(list(stances), model, None, weights, options)
    return fit_fold(list(stances), model, plan, j, None, None, weights, options)


def evaluate_base(
    stances: Sequence[StanceData],
    model: tuple,
    plan: Sequence[Sequence[int]],
    executor: Executor | None = None,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    progress: Callable[[str], None] | None = None,
) -> Evaluation:
    """:func:`~gc_ocp.diagnosis.compare.evaluate` of the base (``model``, no parent), its fit on
    all stances and each fold's one task on ``executor`` (None: here, one after the other;
    module doc). A base fold starts from the usual starts, never from another fit
    (:func:`~gc_ocp.diagnosis.compare.fit_fold`), so its fits are independent and the result
    is the same wherever they run."""
    say = progress or (lambda s: None)
    weights = weights or Weights()
    t0 = time.perf_counter()
    st, pl = tuple(stances), tuple(tuple(g) for g in plan)
    calls = [(st, model, pl, j, weights, options) for j in (None, *range(len(pl)))]
    full, *folds = run_tasks(_base_fit, calls, executor)
    ev = Evaluation(
        "base",
        (),
        model,
        full,
        [f for fold in folds for f in fold],
        time.perf_counter() - t0,
        False,
        weights,
    )
    say(f"  base: {describe(ev)} ({ev.seconds:.1f} s)")
    return ev


def evaluate_round(
    jobs: Sequence[Job],
    inputs: RoundInputs,
    executor: Executor | None = None,
    progress: Callable[[str], None] | None = None,
    hint: Mapping[str, float] | None = None,
) -> dict[str, Evaluation | NotEvaluable]:
    """``{job name: Evaluation}`` of every job, in the order of ``jobs`` (:class:`NotEvaluable`
    for a job whose data cannot evaluate it).

    executor: where the tasks (:func:`run_job`) run, one per job, submitted the dearest first
    (``hint``: ``{name: seconds}``, e.g. of the same candidates in the previous round) so that
    the longest does not start last. ``None``, or a single job: in this process, one after the
    other (with the fits' own progress messages)."""
    say = progress or (lambda s: None)
    if executor is None or len(jobs) <= 1:
        return {job.name: _evaluate(job, inputs, say) for job in jobs}
    order = sorted(jobs, key=lambda j: -(hint or {}).get(j.name, 0.0))
    calls = shared_once(executor, [(job, inputs) for job in order])
    futures = {executor.submit(run_job, *c): job.name for c, job in zip(calls, order, strict=True)}
    out = {}
    for fut in as_completed(futures):
        ev, caught = fut.result()
        _warn_again(caught)
        out[futures[fut]] = ev
        what = "not evaluable" if isinstance(ev, NotEvaluable) else describe(ev)
        say(f"  {ev.label}: {what} ({ev.seconds:.1f} s)")
    return {job.name: out[job.name] for job in jobs}


def default_workers() -> int:
    """Processes for the candidates of a round: the CPU cores this process may use
    (:func:`gc_ocp.execution.available_cores`), at most :data:`MAX_WORKERS`."""
    return min(MAX_WORKERS, available_cores())


@contextlib.contextmanager
def candidate_executor(
    workers: int | None = None, executor: Executor | None = None
) -> Iterator[Executor | None]:
    """The executor of a diagnosis's rounds, for the ``with`` block: ``executor`` when given
    (the caller's; not shut down here); ``None`` (in this process) with ``workers=1``;
    otherwise a Dask client's executor on a local cluster of ``workers`` (default
    :func:`default_workers`) single-threaded processes (:func:`gc_ocp.execution.dask_client`:
    forked from a server that has imported gc_ocp), closed at the end of the block."""
    if executor is not None:
        yield executor
        return
    n = default_workers() if workers is None else int(workers)
    if n <= 1:
        yield None
        return
    with dask_client(workers=n) as client:
        yield client.get_executor()


__all__ = (
    "MAX_WORKERS",
    "NOT_EVALUABLE_ERRORS",
    "Job",
    "NotEvaluable",
    "RoundInputs",
    "candidate_executor",
    "default_workers",
    "evaluate_base",
    "evaluate_round",
    "recorded",
    "run_job",
    "run_tasks",
    "shared_once",
)
