"""The refit null (opt-in: ``diagnose(..., null_fits="refit")``, ``--null-fits refit``): the
calibrated test of :mod:`.null` with the statistic the ranking shows, every replicate scored by
refitting every model's folds as the observed data were.

**Why.** The default null scores a replicate by one Gauss-Newton step per fit from the point
where each model is linearised (:mod:`.onestep`), and so must the observed data be scored, or
the pair would not hold the test's rate. On real walking with two or three stances per foot a
fold's refit lies far from that point, and the one step sees a fraction of a candidate's refit
gain (the bundled trial's damping: +1.9 % one step, +8.7 % refit; ``docs/diagnosis.md``, "Why
the one step misses on real walking"): the test is exact about its false-claim rate and loses
power there. Here the statistic is the refit's held-out reduction itself, the ranking's, for the
data and for every replicate alike.

**A draw** (one task, :func:`draw_refits`):

1. the data the debiased parent makes with a draw of the mismatch family (as the one-step null's,
   :func:`~gc_ocp.diagnosis.draws.draw_data`);
2. one replicate: those data plus the observed residual with the sign of each block flipped
   (:func:`~gc_ocp.diagnosis.null.wild_residuals`), zeroed again below the plate's threshold;
3. the parent, then every candidate, trained on each fold's stances and scored on its held-out
   stances exactly as on the observed data (:func:`~gc_ocp.diagnosis.compare.fit_fold`), each
   fold's training started from the same model's fit of the same fold on the observed data (the
   nearest problem), a candidate's kept at or below its parent's (the nesting check);
4. each candidate's held-out reduction and each held-out stance's share of it.

One replicate per draw: a replicate costs a round of fold fits, not a few matrix products, so
the noise and the mismatch are drawn together, and the spread between draws is all of the
null's spread. Its split into the part every held-out stance shares (which more stances do not
shrink) and the stances' own (:func:`~gc_ocp.diagnosis.null.systematic_sd`) still applies: the
noise of a replicate is each stance's own. The decision, the stop for futility and the steps
that would decide are the one-step null's (:func:`~gc_ocp.diagnosis.null.decide`), on these
replicates.

**Cost.** A draw is one round of fold fits of every model (no fit on all stances): on the
bundled trial (3 stances, 2 folds, 7 candidates) about the round's own evaluation time less its
fits on all stances, so 32 draws are tens of minutes on one core, against about 1.5 minutes for
the one-step null. The adjusted p-value's resolution is ``1 / (draws + 1)``: 32 draws can name
a candidate at 5 % only when its statistic is above every replicate's largest. Meant for few
stances, where the one step misses most; the stop for futility ends most rounds early.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from gc_ocp.diagnosis.compare import Evaluation, first_fold, fit_fold, fit_model
from gc_ocp.diagnosis.draws import DrawNull, NullInputs, draw_data, draw_null
from gc_ocp.diagnosis.mismatch import thresholded
from gc_ocp.diagnosis.null import perturbed, wild_residuals
from gc_ocp.diagnosis.onestep import per_stance_sd, reductions
from gc_ocp.errors import SolveError
from gc_ocp.estimation.problem import Weights
from gc_ocp.stance import StanceData

NULL_FITS = ("one-step", "refit")
"""How the calibrated null scores a replicate (``diagnose(..., null_fits=...)``): one
Gauss-Newton step per fit (:mod:`.onestep`, the default) or every fold refitted (this module)."""


@dataclasses.dataclass(frozen=True)
class RefitInputs:
    """What every draw of a round's refit null shares (plain data, picklable): ``null``, the
    one-step null's inputs (the observed stances, the parent's law and fit, the replicates'
    truth, the parent linearised for its residual's blocks, the plan, the weights and options;
    its ``children`` unused); ``parent`` and ``children``, the round's evaluations on the
    observed data (their fold fits are the replicates' starts)."""

    null: NullInputs
    parent: Evaluation
    children: Mapping[str, Evaluation]

    @property
    def stances(self) -> tuple[StanceData, ...]:
        return self.null.stances

    @property
    def model(self) -> tuple:
        return self.null.model

    @property
    def n_wild(self) -> int:
        return 1  # one replicate per draw (module doc)

    units_off = True
    """The draws keep the units off the layout: the one-step null leaves them out because its
    one step would keep their second-order terms (:func:`~gc_ocp.diagnosis.null._null_draw`);
    refitted, every model meets them as the observed fit met the data's."""


def fold_energies(ev: Evaluation) -> np.ndarray:
    """``(held-out stances, 1)``: each held-out stance's energy (data, nuisance prior, Occam;
    :class:`~gc_ocp.diagnosis.compare.Fold`), or, without folds, one row: the fit on all
    stances' objective with its BIC penalty. Their sums give the ranking's combined score
    (:func:`~gc_ocp.diagnosis.compare.score`), so :func:`~.onestep.reductions` of them is the
    ranking's held-out reduction."""
    if ev.folds:
        return np.array([[f.energy] for f in ev.folds])
    full = ev.full
    return np.array([[full.objective + 0.5 * full.n_param * np.log(full.n_data)]])


def observed_refit(
    parent: Evaluation, children: Mapping[str, Evaluation]
) -> tuple[dict[str, float], dict[str, float | None]]:
    """Each candidate's held-out reduction [%] on the observed data (the ranking's) and the
    spread of its per-stance reductions: the refit null's statistic."""
    E = {"parent": fold_energies(parent), **{n: fold_energies(ev) for n, ev in children.items()}}
    return {n: float(v[0]) for n, v in reductions(E).items()}, per_stance_sd(E)


def _refitted(
    data: list[StanceData],
    observed: Evaluation,
    plan: Sequence[Sequence[int]],
    parent: Evaluation | None,
    weights: Weights | None,
    options,
) -> Evaluation:
    """``observed``'s model fitted on the replicate ``data`` as it was on the observed data:
    every fold (its training warm from the observed fold's), or, without folds, on all
    stances (warm from the observed fit). ``parent``: the parent's evaluation on ``data``."""
    w = weights or Weights()
    if not plan:
        full = fit_model(data, observed.model, observed.full, w, options, covariance=False)
        return Evaluation(observed.label, observed.names, observed.model, full, [], weights=w)
    folds = [
        fold
        for j in range(len(plan))
        for fold in fit_fold(
            data,
            observed.model,
            plan,
            j,
            observed.folds[first_fold(plan, j)].train,
            parent,
            w,
            options,
        )
    ]
    return Evaluation(
        observed.label, observed.names, observed.model, observed.full, folds, weights=w
    )


def draw_replicate(inputs: RefitInputs, draw, rng: np.random.Generator) -> list[StanceData]:
    """Steps 1-2 (module doc): the draw's data plus one wild-residual replicate, zeroed again
    below each stance's plate threshold."""
    base = inputs.null
    data = draw_data(base, draw, rng)
    u = wild_residuals(base.parent, base.full.stance_fits, 1, rng, base.frame_rate)[:, 0]
    rep = perturbed(data, u, base.weights or Weights())
    return [
        thresholded(r, r.censor_below) if r.censor_below > 0 else r
        for r in rep  # (the wrench a plate zeroed stays zero: no noise where it recorded none)
    ]


def draw_refits(inputs: RefitInputs, draw, seed: int) -> DrawNull | str:
    """The task: the :class:`~gc_ocp.diagnosis.draws.DrawNull` of one draw's replicate (module
    doc), or the reason the draw is left out (a refit failed)."""
    rng = np.random.default_rng(seed)
    data = draw_replicate(inputs, draw, rng)
    base = inputs.null
    try:
        parent = _refitted(data, inputs.parent, base.plan, None, base.weights, base.options)
        kids = {
            n: _refitted(data, ev, base.plan, parent, base.weights, base.options)
            for n, ev in inputs.children.items()
        }
    except SolveError as e:
        return f"a refit did not converge ({e})"
    E = {"parent": fold_energies(parent), **{n: fold_energies(ev) for n, ev in kids.items()}}
    return draw_null(E)  # one replicate: no spread within the draw


__all__ = (
    "NULL_FITS",
    "RefitInputs",
    "draw_refits",
    "fold_energies",
    "observed_refit",
    "draw_replicate",
)
