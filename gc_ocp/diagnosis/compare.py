"""Fitting and scoring one model on held-out stances: the measurement the diagnosis ranks by.

**Folds (leave-one-stance-out).** Every stance whose foot has at least one other stance is held
out once; the model is fitted on the remaining stances (all trials of the subject together), then
frozen on the held-out stance (contact parameters, sole corrections, clock offset and belt speed
fixed at the training fit) with only the stance-scope nuisance re-estimated under its prior (the
foot-pose correction; a stance-scope effect such as the ground offset or the spline-driven toe
hinge is also re-estimated: it is a property of that stance; the pitch-driven toe hinge, the
diagnosis's default, is global and frozen). A foot with a single stance is never held out
(its contact parameters would come from nothing). When no stance can be held out at all, the
comparison falls back to in-sample scores with a BIC penalty and says so. With more than
:data:`MAX_FOLDS` stances to hold out, they are held out in that many groups (each group's
training fit scores each of its stances as above): the cost of the folds then grows linearly
with the stances instead of quadratically. A fold's training fit starts from nothing that saw
its held-out stances (:func:`fit_fold`): the base's from the usual starts, a candidate's from
its parent's fit of the same fold.

**Held-out score.** Per fold, the negative log evidence of the held-out stance given the trained
parameters, with the nuisance integrated out under its prior (Laplace approximation):

    E = data cost + nuisance prior cost + 1/2 log det(H_z)

where ``H_z`` is the Gauss-Newton Hessian of the held-out objective in the nuisance variables,
stored in units of their prior sigma (so the prior alone has ``H_z = I``, log det 0). The second
term charges a correction for moving away from the markers; the third (Occam) term charges the
nuisance for the freedom it uses. So a model whose signature the pose correction can absorb does
not win by letting it absorb more; a stance-scope effect does not win by adding freedom. The
combined held-out score is ``S = sqrt(2 sum E / n)`` over all held-out residuals (dimensionless:
residuals in units of the error scale of :class:`~gc_ocp.estimation.problem.Weights`, all six
channels) and a reduction is ``1 - S_child / S_parent`` (in %).

**Uncertainty.** A paired bootstrap, the same draw for both models: blocks of
:data:`BLOCK_SECONDS` resampled within each held-out stance (residuals are autocorrelated over
~0.1 s), and, with at least :data:`MIN_CLUSTERS` held-out stances, the stances themselves
resampled first (two-stage), so that the interval also covers stance-to-stance variability.
With fewer held-out stances a resampling of stances is meaningless (two stances give three
distinct draws), so the interval reflects the within-stance variability only; the per-stance
reductions are reported beside it. The per-stance prior and Occam terms are spread evenly over
its frames.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence

import numpy as np

from gc_ocp.errors import InputError, SolveError
from gc_ocp.estimation.bias import BLOCK_SECONDS
from gc_ocp.estimation.measurement import fit_error
from gc_ocp.estimation.problem import Weights, build_estimation
from gc_ocp.estimation.result import EstimationResult, fit_quality
from gc_ocp.estimation.solve import IpoptOptions, retry_from_stop, solve
from gc_ocp.estimation.starts import (
    STRATEGIES,
    best_of,
    frozen_model,
    neutral_points,
    rescaled_start,
    with_lls_start,
)
from gc_ocp.stance import StanceData

NESTING_RTOL = 1e-6
"""Relative slack of the nesting check of a fold fit (Ipopt's acceptable objective change)."""


MIN_CLUSTERS = 5
"""Held-out stances needed before the bootstrap also resamples the stances."""


def resamples_stances(n_stances: int) -> bool:
    """Whether the bootstrap of :func:`reduction` resamples the stances themselves (two-stage)
    or only blocks within each of ``n_stances`` scored stances."""
    return n_stances >= MIN_CLUSTERS


MAX_FOLDS = 8
"""Most training fits per model: with more stances that can be held out, they are held out in
this many groups (:func:`fold_plan`). Leave-one-stance-out costs ``n`` fits of ``n - 1``
stances per model, quadratic in the stances (16 stances: 20 times the cost of 4); in groups the
cost grows linearly, and every stance is still held out once, so the held-out evidence still
grows with the stances. Up to 8 stances (four per foot) nothing changes."""


def fold_plan(stances: list[StanceData], max_folds: int = MAX_FOLDS) -> list[tuple[int, ...]]:
    """The folds: groups of stance indices held out together, each group's model trained on all
    the other stances. Held out are the stances whose foot has another stance (the training
    keeps that foot), each once. Up to ``max_folds`` of them: one per fold
    (leave-one-stance-out). More: ``max_folds`` groups, dealt in turn from the stances ordered
    by foot, so that a foot's stances fall in different groups and every training set keeps
    each foot (:data:`MAX_FOLDS`)."""
    if max_folds < 2:
        raise InputError(
            f"max_folds={max_folds}: give 2 or more (one group would hold out every stance, and "
            "its training would keep none of the feet it scores)"
        )
    sides = [st.side for st in stances]
    held = [i for i, s in enumerate(sides) if sides.count(s) >= 2]
    if len(held) <= max_folds:
        return [(i,) for i in held]
    held.sort(key=lambda i: (sides[i], i))
    return [tuple(sorted(held[g::max_folds])) for g in range(max_folds)]


def held_out(plan: Sequence[Sequence[int]]) -> list[int]:
    """The stances of ``plan`` in the order of the folds' scores (``Evaluation.folds``): group by
    group."""
    return [i for group in plan for i in group]


def first_fold(plan: Sequence[Sequence[int]], j: int) -> int:
    """Position in ``Evaluation.folds`` of the first held-out stance of group ``j``."""
    return sum(len(g) for g in plan[:j])


@dataclasses.dataclass
class Fold:
    """One held-out stance: the training fit, the held-out fit and its score terms."""

    label: str
    train: EstimationResult
    heldout: EstimationResult
    occam: float
    frame_cost: np.ndarray  # (T,) data cost per frame of the held-out stance

    @property
    def energy(self) -> float:
        return self.heldout.data_cost + self.heldout.prior_cost + self.occam


@dataclasses.dataclass
class Evaluation:
    """A model fitted on all stances (``full``) and on each fold."""

    label: str
    names: tuple[str, ...]
    model: tuple
    full: EstimationResult
    folds: list[Fold]
    seconds: float = 0.0
    screened: bool = False  # fitted on all stances only, not held out (evaluate(folds=False))
    weights: Weights = dataclasses.field(default_factory=Weights)  # of every fit and score
    linear: object = None  # the model linearised for the null (diagnosis.onestep.Linear), if asked

    @property
    def heldout_fits(self) -> list:
        return [f.heldout.stance_fits[0] for f in self.folds]

    @property
    def scored_fits(self) -> list:
        """The stance fits that score this model: its held-out stances' fits, or, without folds
        (the in-sample fallback, a screened evaluation), its fit on all stances."""
        return self.heldout_fits if self.folds else self.full.stance_fits

    @property
    def n_residuals(self) -> int:
        return sum(f.heldout.n_data for f in self.folds) if self.folds else self.full.n_data


def _frame_cost(fit: dict, weights: Weights) -> np.ndarray:
    return 0.5 * np.sum(weights.residuals(fit) ** 2, axis=1)


def occam_term(problem, x: np.ndarray) -> float:
    """``1/2 log det(H_z)`` of the nuisance (the variables with a prior) at ``x``: ``H_z`` the
    Gauss-Newton Hessian of the objective in those variables in units of their prior sigma."""
    pw = np.asarray(problem.prior_weights, float)
    sel = pw > 0
    if not sel.any():
        return 0.0
    _, J = problem.data_jacobian(x)
    Jp = J[:, np.flatnonzero(sel)].toarray() / pw[sel]  # columns in units of the prior sigma
    H = Jp.T @ Jp + np.eye(Jp.shape[1])
    sign, logdet = np.linalg.slogdet(H)
    return 0.5 * float(logdet) if sign > 0 else float("inf")


def fit_model(
    data: list[StanceData],
    model: tuple,
    start: EstimationResult | None,
    weights: Weights | None,
    options: IpoptOptions | None,
    covariance: bool = True,
    quiet: bool = False,
) -> EstimationResult:
    """``model`` (law started at the LLS of ``data``) fitted on ``data``: from ``start`` alone
    when given (a fit of the model this one extends on the same stances, or of the same model on
    the same stances of other data), with the usual starts as a fallback if that solve fails;
    from the usual starts otherwise.

    The seed's LLS is rank deficient on many folds (a unit never loaded in the remaining
    stances); it only sets the law's start and prior centre, so its warning is given once, on
    the base's fit of all stances (``start`` None, ``quiet`` False), not once per fold and
    candidate."""
    model = with_lls_start(model, data, quiet=quiet or start is not None)
    if start is not None:
        try:
            return best_of(
                data, model, weights, options, strategies=(), start=start, covariance=covariance
            )
        except SolveError:
            pass
    return best_of(
        data, model, weights, options, strategies=STRATEGIES, start=start, covariance=covariance
    )


def fit_fold(
    data: list[StanceData],
    model: tuple,
    plan: Sequence[Sequence[int]],
    j: int,
    start: EstimationResult | None = None,
    parent: Evaluation | None = None,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
) -> list[Fold]:
    """Fold ``j`` of ``plan``: ``model`` trained on every stance but those of group ``plan[j]``
    and scored on each of those (one :class:`Fold` per held-out stance, sharing the training
    fit).

    The training fit starts as a fit on all stances does (:func:`fit_model`), from nothing that
    saw the held-out stances: from ``start`` when given (for a replicate of the refit null, the
    same fold's fit on the observed data, :mod:`.refits`); else from ``parent``'s fit of the same
    fold (the model this one extends, its effect at the neutral value); else, for the base, from
    the usual starts. (A start from the model's own fit on all stances would be cheaper and is
    a leak: the objective is not convex, and which minimum a fold fit reaches would then depend
    on the stance it is scored on.)

    A model that nests its parent (its effect at the neutral value is the parent exactly) must
    end its training fit at or below the parent's on the same stances: when it does not, it is
    solved once more from that point (:func:`parent_point`) and the lower is kept. No
    covariance for the fold fits: only their values and costs are used."""
    weights = weights or Weights()
    group = set(plan[j])
    train = [d for k, d in enumerate(data) if k not in group]
    first = first_fold(plan, j)
    ptr = parent.folds[first].train if parent is not None else None
    s0 = start if start is not None else ptr
    tr = fit_model(train, model, s0, weights, options, covariance=False, quiet=True)
    if ptr is not None and tr.objective > ptr.objective * (1.0 + NESTING_RTOL):
        at = parent_point(train, model, ptr, weights)
        if at is not None:  # a model that nests its parent: once more from the parent exactly
            alt = solve(at[0], options, x0=at[1], raise_on_failure=False, covariance=False)
            tr = alt if alt.success and alt.objective < tr.objective else tr
    return [
        _score_heldout(
            data[i],
            train,
            model,
            tr,
            weights,
            options,
            parent.folds[first + k].heldout if parent else None,
        )
        for k, i in enumerate(plan[j])
    ]


def parent_point(
    data: list[StanceData], model: tuple, parent: EstimationResult, weights: Weights
) -> tuple | None:
    """``(problem, x)``: ``model``'s problem on ``data`` and its point that has ``parent``'s
    objective (``parent``'s variables, the model's own at a neutral value,
    :func:`~gc_ocp.estimation.starts.neutral_points`): a model that nests its parent, to which
    the nesting guarantee of :func:`fit_fold` applies. None for a model that replaces a part of
    its parent (the contact density's field replaces the five stiffnesses): it may end above
    the parent, and a second start would only cost time."""
    prob = build_estimation(data, with_lls_start(model, data, quiet=True), weights)
    bound = parent.objective * (1.0 + NESTING_RTOL)
    return next(
        ((prob, x) for x in neutral_points(parent, prob) if prob.evaluate(x) <= bound), None
    )


def evaluate(
    data: list[StanceData],
    model: tuple,
    label: str,
    names: tuple[str, ...],
    plan: Sequence[Sequence[int]],
    parent: Evaluation | None = None,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    progress: Callable[[str], None] | None = None,
    full: EstimationResult | None = None,
    folds: bool = True,
) -> Evaluation:
    """Fit ``model`` on all of ``data`` and on each fold of ``plan``
    (:func:`fit_fold`), and score every held-out stance. Warm starts: from ``parent``'s fits (the
    model this one extends) when given, the folds from ``parent``'s fold fits; the base's folds
    from the usual starts (:func:`fit_fold`: never from a fit that saw the held-out stance).

    full: the model's fit on all of ``data`` when already made (not refitted); ``folds=False``:
    the fit on all stances only (the evaluation is ``screened``; the calibrated decision of the
    diagnosis's later rounds holds out only the candidates its one-step test passes)."""
    say = progress or (lambda s: None)
    weights = weights or Weights()
    t0 = time.perf_counter()
    if full is None:
        full = fit_model(data, model, parent.full if parent else None, weights, options)
    screened = not folds
    fold_fits = (
        []
        if screened
        else [
            fold
            for j in range(len(plan))
            for fold in fit_fold(data, model, plan, j, None, parent, weights, options)
        ]
    )
    ev = Evaluation(
        label, names, model, full, fold_fits, time.perf_counter() - t0, screened, weights
    )
    say(f"  {label}: {describe(ev)} ({ev.seconds:.1f} s)")
    return ev


def _score_heldout(
    held: StanceData,
    train: list[StanceData],
    model: tuple,
    tr: EstimationResult,
    weights: Weights,
    options: IpoptOptions | None,
    parent_heldout: EstimationResult | None = None,
) -> Fold:
    """``model`` trained as ``tr`` (on ``train``), frozen on the stance ``held``: only its
    stance-scope nuisance is re-estimated under its prior, from the prior mean and, when given,
    also from where a parent model's held-out fit left it (the nuisance's optimum is not unique;
    the lower objective is kept)."""
    hp = build_estimation(
        [held], frozen_model(with_lls_start(model, train, quiet=True), tr), weights
    )
    hr = solve(hp, options, raise_on_failure=False, covariance=False)
    if parent_heldout is not None:
        warm = solve(
            hp,
            options,
            x0=rescaled_start(parent_heldout, hp),
            raise_on_failure=False,
            covariance=False,
        )
        if warm.success and (not hr.success or warm.objective < hr.objective):
            hr = warm
    hr = retry_from_stop(hp, hr, options, covariance=False)
    return Fold(
        label=held.label,
        train=tr,
        heldout=hr,
        occam=occam_term(hp, hr.x) if hr.x.size else 0.0,
        frame_cost=_frame_cost(hr.stance_fits[0], weights),
    )


def check_trained_feet(train: Sequence[StanceData], test: Sequence[StanceData]) -> None:
    """Refuse test stances of a foot that no training stance has: a foot's contact parameters
    are its own, so a model trained without that foot cannot score it."""
    trained = {st.side for st in train}
    unseen = [st.label for st in test if st.side not in trained]
    if unseen:
        raise InputError(
            f"Cannot score {', '.join(unseen)}: no stance of that foot is among the training "
            f"stances ({', '.join(st.label for st in train)}), and its contact parameters are "
            "the foot's own; train on trials with a stance of each foot"
        )


def evaluate_on(
    train: list[StanceData],
    test: list[StanceData],
    model: tuple,
    label: str,
    names: tuple[str, ...] = (),
    parent: Evaluation | None = None,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    progress: Callable[[str], None] | None = None,
) -> Evaluation:
    """Fit ``model`` on all of ``train`` and score every stance of ``test`` with it (frozen, the
    nuisance re-estimated, as a fold's held-out stance): the confirmation of a diagnosis on
    stances or trials of the subject it never saw. ``parent``: the evaluation of the model this
    one extends, on the same ``train``/``test`` (warm starts). The result's ``folds`` are the
    test stances (all with the same training fit), so :func:`reduction` and :func:`score`
    apply."""
    say = progress or (lambda s: None)
    weights = weights or Weights()
    check_trained_feet(train, test)
    t0 = time.perf_counter()
    full = fit_model(train, model, parent.full if parent else None, weights, options)
    folds = [
        _score_heldout(
            held, train, model, full, weights, options, parent.folds[j].heldout if parent else None
        )
        for j, held in enumerate(test)
    ]
    ev = Evaluation(label, names, model, full, folds, time.perf_counter() - t0, False, weights)
    say(f"  {label}: {describe(ev)} ({ev.seconds:.1f} s)")
    return ev


def insample_reduction(parent: EstimationResult, child: EstimationResult) -> float:
    """In-sample reduction [%] of ``child`` over ``parent``: ``1 - sqrt(J_child / J_parent)``
    (the objectives of the fits on all stances)."""
    return float(100.0 * (1.0 - np.sqrt(child.objective / parent.objective)))


def describe(ev: Evaluation) -> str:
    if ev.screened:
        return f"in-sample J = {ev.full.objective:.1f} (screened: not held out)"
    if not ev.folds:
        return f"in-sample J = {ev.full.objective:.1f}"
    return f"held-out score {score(ev):.3f}, in-sample J = {ev.full.objective:.1f}"


def score(ev: Evaluation) -> float:
    """The combined held-out score ``S = sqrt(2 sum E / n)`` (module doc); in-sample (with the
    BIC penalty ``1/2 n_param ln n``) when there are no folds."""
    if ev.folds:
        e = sum(f.energy for f in ev.folds)
    else:
        e = ev.full.objective + 0.5 * ev.full.n_param * np.log(ev.full.n_data)
    return float(np.sqrt(2.0 * e / ev.n_residuals))


def circular_blocks(n: int, L: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` frame indices of one circular block bootstrap draw (Politis and Romano 1992):
    blocks of ``L`` frames (at least 1, at most ``n``) from random starts, wrapping past the
    last frame to the first, so that every frame is drawn equally often on average."""
    L = min(max(1, L), n)
    starts = rng.integers(0, n, int(np.ceil(n / L)))
    return ((starts[:, None] + np.arange(L)) % n).ravel()[:n]


def stance_rate(fit: dict, default: float) -> float:
    """A stance fit's frame rate [Hz] from its own time stamps (trials of one subject may come
    from systems at different rates); ``default`` where it has fewer than two frames."""
    t = np.asarray(fit["time"], float)
    return 1.0 / float(np.median(np.diff(t))) if t.size > 1 else default


def _stance_rates(ev: Evaluation, default: float) -> list[float]:
    """Per scored stance (as :func:`_stance_costs`), its frame rate [Hz] (:func:`stance_rate`)."""
    return [stance_rate(fit, default) for fit in ev.scored_fits]


def _stance_costs(ev: Evaluation) -> list[np.ndarray]:
    """Per held-out stance, the per-frame cost with its prior and Occam terms spread evenly (in
    the no-fold fallback: the in-sample fit's stances, prior and BIC penalty spread over all)."""
    if ev.folds:
        return [
            f.frame_cost + (f.heldout.prior_cost + f.occam) / f.frame_cost.size for f in ev.folds
        ]
    costs = [_frame_cost(fit, ev.weights) for fit in ev.full.stance_fits]
    n = sum(c.size for c in costs)
    extra = ev.full.prior_cost + 0.5 * ev.full.n_param * np.log(ev.full.n_data)
    return [c + extra / n for c in costs]


def reduction(
    parent: Evaluation,
    child: Evaluation,
    n_boot: int = 2000,
    seed: int = 0,
    frame_rate: float = 100.0,
) -> dict:
    """Held-out reduction of ``child`` over ``parent``: ``{"pct", "ci": [lo, hi] (95 %),
    "per_stance": {label: pct}, "insample_pct", "superior_pct"}`` (module doc); ``superior_pct``
    is None where the parent's superior-force RMS is 0 or undefined (no frame in contact).

    A paired comparison: both evaluations must score the same stances in the same order (the
    same fold plan on the same data), else the pairs would mix stances; a ValueError says so."""
    la, lb = _scored_labels(parent), _scored_labels(child)
    if la != lb:
        raise ValueError(
            f"reduction of {child.label!r} over {parent.label!r}: they score different stances "
            f"({la} against {lb}); evaluate both on the same data and fold plan"
        )
    a, b = _stance_costs(parent), _stance_costs(child)
    pct = 100.0 * (1.0 - score(child) / score(parent))
    rng = np.random.default_rng(seed)
    draws = np.empty(n_boot)
    S = len(a)
    if resamples_stances(S):
        # the stances themselves, whole: each stance's total already carries its own frames'
        # noise, so resampling blocks inside them too would count that noise twice (intervals
        # about 40 % too wide on independent frames, in simulation)
        ta = np.array([x.sum() for x in a])
        tb = np.array([x.sum() for x in b])
        pick = rng.integers(0, S, (n_boot, S))
        ea, eb = ta[pick].sum(axis=1), tb[pick].sum(axis=1)
        draws = np.where(ea > 0, 100.0 * (1.0 - np.sqrt(eb / np.where(ea > 0, ea, 1.0))), 0.0)
    else:
        # circular blocks of BLOCK_SECONDS at each stance's own frame rate: every frame is
        # drawn as often as any other (blocks that stop at the ends draw the first and last
        # frames, heel strike and toe-off, half as often as mid-stance, where an effect of the
        # stance's edges shows)
        rates = _stance_rates(parent, frame_rate)
        for k in range(n_boot):
            ea = eb = 0.0
            for s in range(S):
                n = a[s].size
                idx = circular_blocks(n, int(round(BLOCK_SECONDS * rates[s])), rng)
                ea += a[s][idx].sum()
                eb += b[s][idx].sum()
            draws[k] = 100.0 * (1.0 - np.sqrt(eb / ea)) if ea > 0 else 0.0
    lo, hi = np.percentile(draws, [2.5, 97.5])
    per = {
        lab: float(100.0 * (1.0 - np.sqrt(cb.sum() / ca.sum())))
        for lab, ca, cb in zip(la, a, b, strict=True)
    }
    ins = insample_reduction(parent.full, child.full)
    sp_, sc = superior_rms(parent), superior_rms(child)
    return {
        "pct": float(pct),
        "ci": [float(lo), float(hi)],
        "per_stance": per,
        "insample_pct": float(ins),
        "superior_pct": float(100.0 * (1.0 - sc / sp_)) if sp_ > 0 and np.isfinite(sc) else None,
    }


def _scored_labels(ev: Evaluation) -> list[str]:
    """The labels of the stances ``ev`` scores, in order: its held-out stances, or, without
    folds, the stances of its fit on all of them."""
    return [f.label for f in ev.folds] or [f["label"] for f in ev.full.stance_fits]


def weighted_residuals(ev: Evaluation, insample: bool = False) -> np.ndarray:
    """All held-out (or, without folds or with ``insample``, the fit on all stances') weighted
    residuals, flattened: the vector whose changes between models tell whether two effects
    explain the same part of the gap."""
    fits = ev.full.stance_fits if insample else ev.scored_fits
    return np.concatenate([ev.weights.residuals(f).ravel() for f in fits])


def heldout_quality(ev: Evaluation) -> dict:
    """``{side: {six fit.json channel keys, "cop_mm"}}`` of the held-out stances (pooled per
    foot; in-sample without folds)."""
    rms, cop = fit_quality(ev.scored_fits)
    return {side: {**ch, "cop_mm": cop.get(side, float("nan"))} for side, ch in rms.items()}


def superior_rms(ev: Evaluation) -> float:
    """Held-out superior-force RMS [% BW] pooled over both feet (each stance normalised by its
    own body weight)."""
    e = np.concatenate(
        [
            100 * fit_error(f)[:, 2][np.asarray(f["in_contact"])] / f["body_weight"]
            for f in ev.scored_fits
        ]
    )
    return float(np.sqrt(np.mean(e**2))) if e.size else float("nan")


__all__ = (
    "BLOCK_SECONDS",
    "MIN_CLUSTERS",
    "Evaluation",
    "Fold",
    "evaluate",
    "evaluate_on",
    "fit_fold",
    "fit_model",
    "first_fold",
    "describe",
    "MAX_FOLDS",
    "fold_plan",
    "held_out",
    "heldout_quality",
    "insample_reduction",
    "occam_term",
    "reduction",
    "parent_point",
    "resamples_stances",
    "score",
    "superior_rms",
    "weighted_residuals",
)
