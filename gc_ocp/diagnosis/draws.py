"""The mismatch draws of the calibrated null (:mod:`.null`), each with the parent refitted and
every model linearised where that draw puts them: one task per draw.

A draw of the mismatch family can move the parent a long way (a friction regularisation twice
as wide moves the friction coefficient and the damping the fit settles on); linearised once at
the observed fit, the null then scored the candidates' gains on a mismatched replicate with the
Jacobians of another point and understated them: on the mismatch benchmark's "none" cases the
one-step null gave friction p = 0.008-0.022 where a full parametric bootstrap put 2 of 16
refitted replicates above the observed gain (``docs/diagnosis.md``, "Does the test hold its
rate?"). So for each draw ``k`` (:func:`draw_reductions`):

1. the data the *truth* makes with draw ``k``: the parent, frozen at its fit debiased for its
   priors (:func:`~gc_ocp.diagnosis.null.prior_pull`), walking the subject's motion as that fit
   corrected it (its per-stance pose correction, the kinematic error the fit estimated, at the
   debiased values: the fitter sees the recorded motion, so a refit meets the same nuisance
   the observed fit met) with the draw's law smoothing and friction form, the plate's hum and
   the markers' low-pass
   (:func:`~gc_ocp.diagnosis.mismatch.simulate_mismatched`, no plate noise: the noise is the
   wild residuals'), recorded with the subject's own plate threshold;
2. the parent refitted to them, warm from its fit on the observed data (one solve);
3. the parent and every candidate linearised at that refit (a candidate that cannot reproduce
   its parent is refitted too, warm from its own observed fit, and linearised there);
4. replicates: that point plus the observed residual's sign-flipped blocks
   (:func:`~gc_ocp.diagnosis.null.wild_residuals`), each scored by one Gauss-Newton step per fit
   from the draw's own point (:mod:`.onestep`).

A draw whose refit does not converge is left out of the null and counted (``skipped``).
The tasks are plain-data functions of picklable arguments, so they run on the diagnosis's
executor (:mod:`.execution`) like its candidate fits.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Collection, Mapping, Sequence
from concurrent.futures import Executor

import numpy as np

from gc_ocp.diagnosis.execution import run_tasks
from gc_ocp.diagnosis.mismatch import MismatchDraw, MismatchFamily, simulate_mismatched, thresholded
from gc_ocp.diagnosis.null import (
    ALPHA,
    DRAWS_PER_LOOK,
    StanceShares,
    cannot_name,
    null_draw,
    wild_residuals,
)
from gc_ocp.diagnosis.onestep import (
    Linear,
    energies,
    from_own_fit,
    linearize,
    nested_point,
    reductions,
    stance_shares,
)
from gc_ocp.errors import SolveError
from gc_ocp.estimation.problem import Weights, build_estimation
from gc_ocp.estimation.result import EstimationResult
from gc_ocp.estimation.solve import IpoptOptions, result_at, solve
from gc_ocp.estimation.starts import frozen_model, rescaled_start
from gc_ocp.stance import StanceData


@dataclasses.dataclass(frozen=True)
class NullInputs:
    """What every draw of a round's null shares (plain data, picklable).

    stances: the observed stances (motion, plate thresholds); model, full: the parent, its law
    started at the observed data's linear least squares (``with_lls_start``: the law prior of
    every fit, replicates' too), and its fit on them; truth: the parent's fit debiased for its
    priors (the replicates' truth, :func:`~gc_ocp.diagnosis.null.prior_pull`); children:
    ``{name: (model started as the parent's, its fit on all stances)}``; parent: the parent
    linearised on the observed data (its residual's blocks are the replicates' noise); plan,
    occam, fold_means: the held-out scoring (:func:`~gc_ocp.diagnosis.onestep.energies`);
    n_wild: replicates per draw."""

    stances: tuple[StanceData, ...]
    model: tuple
    full: EstimationResult
    truth: EstimationResult
    children: Mapping[str, tuple[tuple, EstimationResult]]
    parent: Linear
    plan: tuple[tuple[int, ...], ...]
    occam: Mapping[str, np.ndarray]
    fold_means: tuple
    n_wild: int
    frame_rate: float
    weights: Weights | None = None
    options: IpoptOptions | None = None
    units_off = False  # the draws' units stay on the layout (:func:`~.null._null_draw`)


def draw_data(inputs: NullInputs, draw: MismatchDraw, rng: np.random.Generator) -> list:
    """Step 1 (module doc): the noise-free data the debiased parent makes with ``draw``,
    recorded with each observed stance's plate threshold."""
    stances = list(inputs.stances)
    truth = frozen_model(inputs.model, inputs.truth)
    rep = simulate_mismatched(stances, truth, draw, rng, plate_noise_pct_bw=0.0, at=inputs.truth)
    return [
        dataclasses.replace(thresholded(r, st.censor_below), censor_below=st.censor_below)
        if st.censor_below > 0
        else r
        for r, st in zip(rep, stances, strict=True)
    ]


def _refit(problem, start: EstimationResult, options: IpoptOptions | None) -> EstimationResult:
    return solve(problem, options, x0=rescaled_start(start, problem), covariance=False)


@dataclasses.dataclass(frozen=True)
class DrawNull:
    """What one draw gives the null: ``reductions``, ``{candidate: (n_wild,) one-step held-out
    reductions [%]}`` of its replicates; ``shares``, ``{candidate: (rows,)}`` each held-out
    stance's share of them and ``weights`` ``(rows,)`` each stance's weight, both the mean over
    the draw's replicates (:func:`~gc_ocp.diagnosis.onestep.stance_shares`), and
    ``share_cov``, ``{candidate: (rows, rows)}`` the covariance of the shares between them."""

    reductions: dict[str, np.ndarray]
    shares: dict[str, np.ndarray]
    weights: np.ndarray
    share_cov: dict[str, np.ndarray]


def draw_reductions(inputs: NullInputs, draw: MismatchDraw, seed: int) -> DrawNull | str:
    """The task: the :class:`DrawNull` of the replicates of ``draw`` (module doc), or the reason
    the draw is left out (a refit failed)."""
    rng = np.random.default_rng(seed)
    data = draw_data(inputs, draw, rng)
    w = inputs.weights
    try:
        problem = build_estimation(data, inputs.model, w)
        fk = _refit(problem, inputs.full, inputs.options)
        pk = linearize(problem, fk.x)
        kids = {}
        for name, (model, own) in inputs.children.items():
            child = build_estimation(data, model, w)
            x0 = None if from_own_fit(name) else nested_point(child, fk, pk.r)
            if x0 is None:  # cannot reproduce the parent (or is curved at neutral): refitted
                kids[name] = linearize(child, _refit(child, own, inputs.options).x, nested=False)
            else:
                kids[name] = linearize(child, x0)
    except SolveError as e:
        return f"a refit did not converge ({e})"
    U = wild_residuals(
        inputs.parent, inputs.full.stance_fits, inputs.n_wild, rng, inputs.frame_rate
    )
    E = energies(pk, kids, U - pk.r[:, None], inputs.plan, inputs.occam, inputs.fold_means)
    return draw_null(E)


def draw_null(E: Mapping[str, np.ndarray]) -> DrawNull:
    """The :class:`DrawNull` of a draw's held-out energies ``E`` (``{"parent" and every
    candidate: (held-out stances, replicates)}``, :func:`~gc_ocp.diagnosis.onestep.energies`
    or the refit null's fold energies): its replicates' reductions, the mean and covariance
    of their stance shares (no covariance with one replicate)."""
    shares, weights = stance_shares(E)
    return DrawNull(
        reductions(E),
        {n: v.mean(axis=1) for n, v in shares.items()},
        weights.mean(axis=1),
        {
            n: np.atleast_2d(np.cov(v)) if v.shape[1] > 1 else np.zeros((v.shape[0],) * 2)
            for n, v in shares.items()
        },
    )


def debiased(
    stances: Sequence[StanceData],
    model: tuple,
    full: EstimationResult,
    pull: np.ndarray,
    weights: Weights | None,
) -> EstimationResult:
    """The parent's fit ``full`` (of ``model`` on ``stances``, its law already started) moved
    by ``pull`` (:func:`~gc_ocp.diagnosis.null.prior_step`, negated), kept within the
    variables' bounds: the replicates' truth."""
    problem = build_estimation(list(stances), model, weights)
    x = np.clip(np.asarray(full.x, float) + pull, problem.lbx, problem.ubx)
    return result_at(problem, x, covariance=False)


def mismatch_null(
    inputs: NullInputs,
    family: MismatchFamily,
    n_draws: int,
    seed: int,
    executor: Executor | None = None,
    observed: Mapping[str, float] | None = None,
    alpha: float = ALPHA,
    among: Collection[str] | None = None,
    task: Callable | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[dict[str, np.ndarray], np.ndarray, int, StanceShares]:
    """``({candidate: null reductions [%]}, the draw of each replicate, draws left out, the
    draws' stance shares)``:
    ``n_draws`` draws of ``family`` (restricted as the null takes them,
    :func:`~gc_ocp.diagnosis.null.null_draw`), one task each on ``executor``
    (:func:`~gc_ocp.diagnosis.execution.run_tasks`; None: here). The draw index lets the
    decision tell the spread between draws (mismatch) from the spread within a draw (noise,
    which more stances shrink; :func:`~gc_ocp.diagnosis.null.decide`), and the
    stance shares tell the part of the former every held-out stance shares (systematic) from
    the part that is the stances' own (:func:`~gc_ocp.diagnosis.null.systematic_sd`).
    ``observed``: the candidates' observed one-step reductions; given, the draws stop early
    once no candidate of ``among`` (None: every one) could be named at ``alpha``
    (:func:`~gc_ocp.diagnosis.null.cannot_name`; the draws made are the first of the same
    seeded sequence). ``task``: what a draw runs (default :func:`draw_reductions`; the refit
    null's :func:`~gc_ocp.diagnosis.refits.draw_refits`); ``progress``: told ``(draws done,
    planned)`` after each."""
    task = task or draw_reductions
    rng = np.random.default_rng(seed)
    layout = inputs.stances[0].layout
    calls = [
        (inputs, null_draw(family, rng, layout, inputs.model, inputs.units_off), int(s))
        for s in rng.integers(0, 2**31, n_draws)
    ]
    stop = None
    if observed is not None:

        def stop(outs: list) -> bool:
            kept = [o for o in outs if not isinstance(o, str)]
            if not kept:
                return False
            null, draw = _pooled(kept)  # the p-value counts draws (null.decide)
            return cannot_name(observed, null, n_draws, alpha, among, draw)

    outs = run_tasks(task, calls, executor, stop, DRAWS_PER_LOOK, progress)
    kept = [o for o in outs if not isinstance(o, str)]
    if not kept:
        raise SolveError(f"no draw of the null's mismatch family could be refitted: {outs[0]}")
    null, draw = _pooled(kept)
    shares = StanceShares(
        {n: np.vstack([o.shares[n] for o in kept]) for n in kept[0].shares},
        np.mean([o.weights for o in kept], axis=0),
        {n: np.mean([o.share_cov[n] for o in kept], axis=0) for n in kept[0].shares},
        inputs.n_wild,
    )
    return null, draw, len(outs) - len(kept), shares


def _pooled(kept: Sequence[DrawNull]) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The draws' null reductions pooled, and the draw of each replicate."""
    red = [o.reductions for o in kept]
    null = {n: np.concatenate([r[n] for r in red]) for n in red[0]}
    draw = np.concatenate([np.full(next(iter(r.values())).size, k) for k, r in enumerate(red)])
    return null, draw


__all__ = (
    "DrawNull",
    "NullInputs",
    "debiased",
    "draw_data",
    "draw_null",
    "draw_reductions",
    "mismatch_null",
)
