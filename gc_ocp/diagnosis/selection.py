"""The decision rule: how a round's evaluations become ranked rows, which effect is selected, and
when two effects are named confounded (see ``docs/diagnosis.md``).

**Ranking** (:func:`rank`): every candidate of a round against the round's parent model (the
base, then the base plus the effects selected so far): its held-out reduction of the combined
score with a 95 % bootstrap interval, and its in-sample reduction for reference
(:func:`~gc_ocp.diagnosis.compare.reduction`); rows best first, screened candidates last.

**Decision rule** ("none" is a possible answer): an effect passes when the calibrated test of
:mod:`.null` names it (its one-step held-out reduction exceeds what the parent model, slightly
wrong in ways that are not candidates, gives on replicates of the subject's own data, with a
family-wise rate of a false claim among the round's candidates of at most ``alpha``) *and*,
fully refitted, it does reduce the held-out score (in-sample when no stance can be held out).
*and* a small effect-size floor holds too: a held-out reduction of at least
:data:`MIN_REDUCTION_PCT`, the lower end of its interval above 0, an in-sample reduction of at
least :data:`MIN_REDUCTION_PCT`. The test alone does not hold its rate on one kind of null:
clean data of a truth inside the model but far from its priors (the registered truth, sole
offsets 4-5 prior sigmas), where the fitted base misfits the truth systematically and damping
absorbs +0.14-0.18 % of it while on replicates of the fitted base it does not; the floor
rejects those. It was 2 %, an effect-size rule under which a real gain of 1 % is never named
however many stances there are; it is now the smallest floor that rejects the "none" cases of
one benchmark motion, chosen there and scored on the other (``docs/diagnosis.md``, Decision
rule; ``benchmarks/rule_variants_output.md``). The result gives, for every
candidate that does not pass, the further stances that would decide the test and those after
which its held-out interval would clear the floor (:func:`floor_stances`; the rule's number is
the larger, ``RankRow.more_stances``). A candidate
that fails, yet whose one-step reduction is above the null's mean and a practical number of
stances would decide it, or that the test names below the floor, is *inconclusive*.

**Forward selection**: the best passing effect (:func:`best_passing`) is added, the others are
re-ranked on top of it, and so on until none passes (the loop is :mod:`.diagnose`'s).

**Confounding**: two candidates are named confounded when their changes of the held-out residual
are alike (cosine similarity of the weighted residual changes above :data:`CONFOUND_COSINE`, both
reducing the score), or their changes of the in-sample residual are, with comparable sizes
(:data:`COMPARABLE_FRACTION`; both with evidence of a gain, passing or inconclusive: they
explain the same part of the gap on the fitted stances, even if only one carries over to held-out
ones) (:func:`flag_alike`), or when one stops passing once the other is in the model (its gain
falls below :data:`NON_ADDITIVE_FRACTION`: the gains are not additive, :func:`flag_non_additive`),
or with the base's per-stance nuisance (``kinematic_correction``) when its gain comes mostly from
a smaller nuisance cost rather than a better fit of the data (:data:`NUISANCE_SHARE`), or when
both pass and the paired bootstrap of their difference does not order them (a tie,
:func:`flag_ties`). The result says so instead of guessing which one it is.

Rows are immutable (:class:`~gc_ocp.diagnosis.result.RankRow`): each flagging step returns new
rows.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from gc_ocp.diagnosis.compare import (
    Evaluation,
    insample_reduction,
    reduction,
    weighted_residuals,
)
from gc_ocp.diagnosis.execution import NotEvaluable
from gc_ocp.diagnosis.null import ALPHA, NullTest, fewest_stances, power_shift, practical
from gc_ocp.diagnosis.result import MIN_REDUCTION_PCT, RankRow
from gc_ocp.estimation.components import REGISTRY

CONFOUND_COSINE = 0.5
"""Cosine similarity of two effects' residual changes (held-out, or in-sample) above which they
explain the same part of the gap. On the withheld-effect benchmark, in-sample changes of
unrelated effects stay below 0.35, those of effects that can play each other reach 0.7-0.99
(damping and clock offset 0.69; sole offsets, ground offset and pose correction 0.85-0.99)."""

COMPARABLE_FRACTION = 0.5
"""In-sample confounding also needs the two residual changes to be of comparable size (the
smaller at least this fraction of the larger): an effect that repairs a sliver of the misfit
another repairs in full does not stand in for it. On the seed base, where nearly every
candidate repairs a little of the missing registration, this keeps the flag specific."""


NON_ADDITIVE_FRACTION = 0.5
"""An effect whose gain on top of another falls below this fraction of its gain alone is
confounded with it."""

NUISANCE_SHARE = 0.5
"""An effect whose held-out gain comes mostly (more than this fraction) from a smaller nuisance
cost (the pose correction moves less, or more cheaply) rather than from a better fit of the data
does what the base's per-stance nuisance already does: it is named confounded with it."""


def n_params(child: Evaluation, parent: Evaluation) -> int:
    """Scalars the added effect estimates (its own variables, summed over the stances for a
    per-stance effect). Not the change of ``n_free``: an effect may also fix variables of the
    model (``contact_density`` replaces the five per-unit stiffnesses by a 4-parameter field)."""
    names = {c.name for c in child.model} - {c.name for c in parent.model}
    return int(sum(s.size for s in child.full.variables if s.key[0] in names))


def _terms(ev: Evaluation) -> tuple[float, float]:
    """(data cost, nuisance cost = prior + Occam) summed over the held-out stances."""
    if not ev.folds:
        return ev.full.data_cost, ev.full.prior_cost
    return (
        sum(f.heldout.data_cost for f in ev.folds),
        sum(f.heldout.prior_cost + f.occam for f in ev.folds),
    )


def _nuisance_names(model: tuple) -> list[str]:
    """Registry names of the model's stance-scope components (the per-stance nuisance)."""
    names = {cls: n for n, cls in REGISTRY.items()}
    return [names.get(type(c), c.name) for c in model if c.scope == "stance"]


def rank(
    parent: Evaluation,
    evs: Mapping[str, Evaluation],
    tests: Mapping[str, NullTest],
    n_boot: int,
    seed: int,
    rate: float,
    alpha: float = ALPHA,
    known: Mapping[str, tuple[Evaluation, dict]] | None = None,
) -> list[RankRow]:
    """The rows of one round: every candidate of ``evs`` (``{effect: Evaluation}``) against
    ``parent``, with the decision rule applied (``tests``: the calibrated test of each, from
    :func:`~gc_ocp.diagnosis.null.calibrate`; family-wise rate ``alpha``) and the confounding
    within the round named; held out first (best first), then the screened ones (by their
    one-step reduction). ``n_boot``, ``seed``: the bootstrap of the intervals; ``rate``: frame
    rate [Hz]; ``known``: reductions already made (:func:`contenders`)."""
    rows = []
    base_r = weighted_residuals(parent)
    deltas = {}
    pd, pn = _terms(parent)
    failed = [_not_evaluable_row(n, ev) for n, ev in evs.items() if isinstance(ev, NotEvaluable)]
    evs = {n: ev for n, ev in evs.items() if not isinstance(ev, NotEvaluable)}
    for name, ev in evs.items():
        test = tests.get(name)
        named = test is not None and test.p_adjusted < alpha
        if ev.screened:
            rows.append(_screened_row(name, ev, parent, test))
            continue
        red = held_out_reduction(parent, name, ev, n_boot, seed, rate, known)
        deltas[name] = base_r - weighted_residuals(ev)
        cd, cn = _terms(ev)
        gain = (pd + pn) - (cd + cn)
        big = floor_holds(red)
        passes = bool(named and big)
        # the floor's further stances: none counted in the in-sample fallback (no fold)
        floor = floor_stances(red, len(red["per_stance"]) if ev.folds else 0)
        # the share is only meaningful for a gain that counts (near 0 it is a ratio of noise)
        from_nuisance = (pn - cn) / gain if passes and gain > 0 else None
        relieves = [
            n
            for n in _nuisance_names(parent.model)
            if from_nuisance is not None and from_nuisance > NUISANCE_SHARE
        ]
        rows.append(
            RankRow(
                effect=name,
                heldout_rms_reduction_pct=red["pct"],
                heldout_rms_reduction_ci=tuple(red["ci"]),
                heldout_superior_force_reduction_pct=red["superior_pct"],
                insample_rms_reduction_pct=red["insample_pct"],
                per_stance_reduction_pct=red["per_stance"],
                n_params=n_params(ev, parent),
                passes=passes,
                screened=False,
                inconclusive=bool(
                    red["pct"] > 0.0 and (_inconclusive(passes, test, floor) or (named and not big))
                ),
                gain_from_nuisance=None if from_nuisance is None else float(from_nuisance),
                confounded_with=tuple(relieves),
                flags=tuple(f["code"] for f in ev.full.flags),
                calibrated=test,
                floor_stances=floor,
            )
        )
    held = [r for r in rows if r.heldout_rms_reduction_pct is not None]
    flagged = {
        r.effect: r for r in flag_alike(held, deltas, lambda r: r.heldout_rms_reduction_pct > 0)
    }
    rows = [flagged.get(r.effect, r) for r in rows]
    # in-sample: every candidate (screened ones too) against the fits on all stances
    base_in = weighted_residuals(parent, insample=True)
    ins = {n: base_in - weighted_residuals(ev, insample=True) for n, ev in evs.items()}
    rows = flag_alike(
        rows,
        ins,
        lambda r: r.insample_rms_reduction_pct > 0 and (r.passes or r.inconclusive),
        comparable=True,
    )
    # held out first (best first), then the screened ones (by their one-step reduction)
    rows.sort(
        key=lambda r: (
            r.heldout_rms_reduction_pct is None,
            -(
                (r.calibrated.observed_pct if r.calibrated else r.insample_rms_reduction_pct)
                if r.heldout_rms_reduction_pct is None
                else r.heldout_rms_reduction_pct
            ),
        )
    )
    return [*flag_ties(rows, evs, n_boot, seed, rate), *failed]  # the not evaluable ones last


def floor_holds(red: Mapping) -> bool:
    """The rule's effect-size floor (module doc) on a held-out reduction of
    :func:`~gc_ocp.diagnosis.compare.reduction`."""
    return bool(
        red["pct"] >= MIN_REDUCTION_PCT
        and red["ci"][0] > 0.0
        and red["insample_pct"] >= MIN_REDUCTION_PCT
    )


Z_95 = 1.959964
"""The standard normal quantile of the held-out reduction's two-sided 95 % interval: its
half-width is that many standard errors (:func:`floor_stances`)."""


def floor_stances(red: Mapping, n_heldout: int) -> int | None:
    """Further held-out stances after which a held-out reduction ``red``
    (:func:`~gc_ocp.diagnosis.compare.reduction`, on ``n_heldout`` stances) would clear the
    effect-size floor at its observed size: 0 when it does (:func:`floor_holds`); None when
    its held-out or its in-sample reduction is under :data:`MIN_REDUCTION_PCT` (more stances
    estimate a gain better, they do not raise it), or when no number of stances is likely to
    (below). Otherwise the lower end of its interval, ``pct - h`` on ``n0`` stances, reaches 0;
    its standard error is ``sigma = h / 1.96``, and a study of ``n`` stances would give an
    interval of half-width ``1.96 sigma sqrt(n0 / n)`` (the bootstrap's interval narrows as a
    mean's) about the gain it observes. With the same 80 % assurance as the test's steps
    (:func:`~gc_ocp.diagnosis.null.power_shift`: that gain scatters about ``pct`` by ``sigma
    sqrt(1 + n0 / n)``), the smallest ``n`` with ``1.96 sigma sqrt(n0 / n) + 0.84 sigma sqrt(1
    + n0 / n) < pct``, less ``n0``; none when ``pct <= 0.84 sigma`` (until 2026-12-03 the
    observed gain was taken as the true one, ``(1.96 + 0.84) sigma sqrt(n0 / n) < pct``).
    ``n_heldout`` 0 (the in-sample fallback, whose interval is the in-sample fit's): 0, not
    measured, unless the floor rules the reduction out (None); one stance more on a foot makes
    the diagnosis a held-out one, which these scores do not predict."""
    pct, lo = red["pct"], red["ci"][0]
    if pct < MIN_REDUCTION_PCT or red["insample_pct"] < MIN_REDUCTION_PCT:
        return None
    if floor_holds(red) or n_heldout < 1:
        return 0
    n0 = int(n_heldout)
    sigma = (pct - lo) / Z_95

    def clears(n: int) -> bool:  # strictly above, as floor_holds asks; the margin needed
        f = n0 / n  # falls with n, to 0.84 sigma
        return Z_95 * sigma * math.sqrt(f) + power_shift(sigma, f) < pct

    return fewest_stances(n0, clears)


def held_out_reduction(
    parent: Evaluation,
    name: str,
    ev: Evaluation,
    n_boot: int,
    seed: int,
    rate: float,
    known: Mapping[str, tuple[Evaluation, dict]] | None = None,
) -> dict:
    """:func:`~gc_ocp.diagnosis.compare.reduction` of ``ev`` (candidate ``name``) over
    ``parent``, or the one ``known`` holds for this very evaluation (its bootstrap is not made
    twice)."""
    have = (known or {}).get(name)
    if have is not None and have[0] is ev:
        return have[1]
    return reduction(parent, ev, n_boot=n_boot, seed=seed, frame_rate=rate)


def contenders(
    parent: Evaluation, evs: Mapping[str, Evaluation], n_boot: int, seed: int, rate: float
) -> tuple[set[str], dict[str, tuple[Evaluation, dict]]]:
    """The candidates of a round that the effect-size floor does not already rule out (only
    these can be named, whatever the calibrated test says: the null's draws may stop once none
    of them can, :func:`~gc_ocp.diagnosis.null.cannot_name`), and the held-out reductions made
    to tell (for :func:`rank`). A screened candidate (not held out yet) is ruled out only by its
    in-sample reduction."""
    out, known = set(), {}
    for name, ev in evs.items():
        if ev.screened:
            if insample_reduction(parent.full, ev.full) >= MIN_REDUCTION_PCT:
                out.add(name)
            continue
        red = reduction(parent, ev, n_boot=n_boot, seed=seed, frame_rate=rate)
        known[name] = (ev, red)
        if floor_holds(red):
            out.add(name)
    return out, known


def within_reach(able: set[str], known: Mapping[str, tuple[Evaluation, dict]]) -> set[str]:
    """The candidates of a round that clear the effect-size floor now or would with more
    stances: those it leaves (``able``, from :func:`contenders`, whose ``known`` held-out
    reductions these are) and the held-out ones that :func:`floor_stances` gives a number of
    further stances. None of the others can be named whatever the calibrated test says, nor
    become nameable with more steps: more stances estimate a gain better, they do not raise
    it."""
    return able | {
        name
        for name, (_, red) in known.items()
        if floor_stances(red, len(red["per_stance"])) is not None
    }


def _inconclusive(passes: bool, test: NullTest | None, floor: int | None = 0) -> bool:
    """Not named, but a practical number of further stances would decide it: the rule's
    (:meth:`~gc_ocp.diagnosis.result.RankRow.rule_stances`, the larger of the test's and the
    effect-size floor's ``floor``, as its row reports them) within
    :data:`~gc_ocp.diagnosis.null.PRACTICAL_FACTOR` times the held-out stances it had."""
    if passes or test is None:
        return False
    rule = RankRow.rule_stances(test.more_stances, floor)
    return practical(rule, test.n_heldout)


def _screened_row(
    name: str, ev: Evaluation, parent: Evaluation, test: NullTest | None = None
) -> RankRow:
    """The ranking row of a candidate screened out by the calibrated test (not held out: it
    cannot pass). Its effect-size floor's number is not measured (0) unless its in-sample
    reduction is under the floor: then no number of further stances clears it (None, as
    :func:`floor_stances` says of a held-out row), and its row must not promise one."""
    insample = insample_reduction(parent.full, ev.full)
    floor = None if insample < MIN_REDUCTION_PCT else 0
    return RankRow(
        effect=name,
        heldout_rms_reduction_pct=None,
        heldout_rms_reduction_ci=(None, None),
        heldout_superior_force_reduction_pct=None,
        insample_rms_reduction_pct=insample,
        per_stance_reduction_pct={},
        n_params=n_params(ev, parent),
        passes=False,
        screened=True,
        inconclusive=_inconclusive(False, test, floor),
        gain_from_nuisance=None,
        confounded_with=(),
        flags=tuple(f["code"] for f in ev.full.flags),
        calibrated=test,
        floor_stances=floor,
    )


def _not_evaluable_row(name: str, failed: NotEvaluable) -> RankRow:
    """The ranking row of a candidate that could not be evaluated on these data (its fit raised
    an input or model error, the message in ``not_evaluable``): no figures, does not pass."""
    return RankRow(
        effect=name,
        heldout_rms_reduction_pct=None,
        heldout_rms_reduction_ci=(None, None),
        heldout_superior_force_reduction_pct=None,
        insample_rms_reduction_pct=None,
        per_stance_reduction_pct={},
        n_params=0,
        passes=False,
        screened=False,
        inconclusive=False,
        gain_from_nuisance=None,
        confounded_with=(),
        flags=(),
        not_evaluable=failed.message,
    )


def _linked(rows: Sequence[RankRow], links: Mapping[str, list[str]]) -> list[RankRow]:
    """``rows`` naming, each, the effects of ``links[effect]`` confounded with it (in order)."""
    return [r.confounded(*links[r.effect]) for r in rows]


def flag_alike(
    rows: Sequence[RankRow],
    deltas: Mapping[str, np.ndarray],
    gains: Callable[[RankRow], bool],
    comparable: bool = False,
) -> list[RankRow]:
    """``rows`` with the pairs that both satisfy ``gains`` and whose residual changes
    (``deltas``: effect -> vector) have a cosine similarity above :data:`CONFOUND_COSINE` named
    confounded; with ``comparable``, only when the smaller change is at least
    :data:`COMPARABLE_FRACTION` of the larger (either could stand in for the other)."""
    links = {r.effect: list(r.confounded_with) for r in rows}
    for a in rows:
        for b in rows:
            if a is b or not (gains(a) and gains(b)) or b.effect in links[a.effect]:
                continue
            da, db = deltas[a.effect], deltas[b.effect]
            na, nb = np.linalg.norm(da), np.linalg.norm(db)
            if na == 0 or nb == 0 or float(da @ db) / (na * nb) <= CONFOUND_COSINE:
                continue
            if not comparable or min(na, nb) >= COMPARABLE_FRACTION * max(na, nb):
                links[a.effect].append(b.effect)
    return _linked(rows, links)


def flag_ties(
    rows: Sequence[RankRow], evs: Mapping[str, Evaluation], n_boot: int, seed: int, rate: float
) -> list[RankRow]:
    """``rows`` with the passing candidates whose held-out scores do not differ significantly
    (the 95 % interval of their paired difference, the same block bootstrap, reaches 0) named
    confounded with each other: the data do not order them, so which one comes first is not an
    answer."""
    links = {r.effect: list(r.confounded_with) for r in rows}
    passing = [r for r in rows if r.passes]
    for i, a in enumerate(passing):
        for b in passing[i + 1 :]:
            hi = reduction(evs[a.effect], evs[b.effect], n_boot, seed, rate)["ci"][1]
            if hi >= 0.0:  # b is not significantly worse than a
                for x, y in ((a, b), (b, a)):
                    if y.effect not in links[x.effect]:
                        links[x.effect].append(y.effect)
    return _linked(rows, links)


def best_passing(rows: Sequence[RankRow]) -> RankRow | None:
    """The effect a round adds: the first passing row (rows are sorted, best first), if any."""
    return next((r for r in rows if r.passes), None)


def flag_non_additive(
    ranking: Sequence[RankRow], rounds: Sequence[Sequence[RankRow]], selected: Sequence[str]
) -> list[RankRow]:
    """``ranking`` (round 1) with the non-additive pairs named confounded: a passing effect
    that stops passing once another (``selected[k - 1]``, added before round ``k + 1``) is in
    the model, its gain falling below :data:`NON_ADDITIVE_FRACTION` of its gain alone (or
    screened out: the calibrated test no longer names it)."""
    links = {r.effect: list(r.confounded_with) for r in ranking}
    for k in range(1, len(rounds)):
        added = selected[k - 1]
        later = {r.effect: r for r in rounds[k]}
        for r in ranking:
            e = r.effect
            if e in later and r.passes and e != added and later[e].not_evaluable is None:
                g0, g1 = r.heldout_rms_reduction_pct, later[e].heldout_rms_reduction_pct
                if g1 is None or g1 < NON_ADDITIVE_FRACTION * g0:
                    for a, b in ((e, added), (added, e)):
                        if b not in links[a]:
                            links[a].append(b)
    return _linked(ranking, links)


__all__ = (
    "COMPARABLE_FRACTION",
    "CONFOUND_COSINE",
    "MIN_REDUCTION_PCT",
    "NON_ADDITIVE_FRACTION",
    "NUISANCE_SHARE",
    "best_passing",
    "contenders",
    "flag_alike",
    "flag_non_additive",
    "flag_ties",
    "floor_holds",
    "held_out_reduction",
    "n_params",
    "rank",
    "within_reach",
)
