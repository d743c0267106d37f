"""Which unmodelled effect causes the gap, and how far it shrinks: the diagnosis's orchestration
(see ``docs/diagnosis.md``).

1. The base model (:data:`BASES`) is fitted and scored on held-out stances (:mod:`.compare`).
2. Every candidate effect (a registered component not already in the base,
   :func:`candidate_names`) is added alone, refitted (warm-started from the base's fits, fold by
   fold) and scored the same way, one task per candidate on an executor (:mod:`.execution`).
3. The round's rows are ranked and the decision rule applied (:mod:`.selection`); the best
   passing effect is added, the others are re-ranked on top of it, and so on until none passes.
4. The non-additive pairs are named, the residual maps of the base and of the final model drawn
   (:mod:`.where`), and everything returned as a :class:`~gc_ocp.diagnosis.result.Diagnosis`.

Confirmation on new stances is :mod:`.confirm`; the HTML page, :mod:`.report`.
"""

from __future__ import annotations

import dataclasses
import inspect
import numbers
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Executor
from types import MappingProxyType

import numpy as np

from gc_ocp.diagnosis.compare import MAX_FOLDS, Evaluation, fold_plan, held_out
from gc_ocp.diagnosis.draws import NullInputs, debiased, mismatch_null
from gc_ocp.diagnosis.execution import (
    Job,
    NotEvaluable,
    RoundInputs,
    candidate_executor,
    evaluate_base,
    evaluate_round,
)
from gc_ocp.diagnosis.mismatch import MismatchFamily
from gc_ocp.diagnosis.null import (
    ALPHA,
    DEFAULT_FAMILY,
    DRAWS_PER_LOOK,
    MISMATCH_DRAWS,
    N_REPLICATES,
    calibrate,
    decide,
    fewest_draws,
    null_looks,
    observed_reductions,
    prior_step,
    step_miss,
)
from gc_ocp.diagnosis.onestep import fold_prior_means, linearize_parent
from gc_ocp.diagnosis.refits import NULL_FITS, RefitInputs, draw_refits, observed_refit
from gc_ocp.diagnosis.result import NOT_TESTED_WHY, Diagnosis, RankRow, WaterfallStep
from gc_ocp.diagnosis.selection import (
    MIN_REDUCTION_PCT,
    best_passing,
    contenders,
    flag_non_additive,
    rank,
    within_reach,
)
from gc_ocp.diagnosis.where import where
from gc_ocp.errors import InputError, ModelError, UnknownNameError, names_of
from gc_ocp.estimation.components import (
    REGISTRY,
    bare_seed_model,
    base_model,
    candidate_effects,
    full_model,
    model_from_names,
)
from gc_ocp.estimation.measurement import measurement_of
from gc_ocp.estimation.pose_scale import with_estimated_width
from gc_ocp.estimation.problem import Weights
from gc_ocp.estimation.solve import IpoptOptions, require_settings
from gc_ocp.estimation.starts import with_lls_start
from gc_ocp.stance import StanceData, require_stance_list
from gc_ocp.values import is_count
from gc_ocp.workflow.fitting import fit_data

POSE_WIDTH = "estimated"
"""The base's pose-correction width unless a diagnosis says otherwise (``pose_width`` of
:func:`diagnose_stances`; the command line's ``--pose-width`` and the withheld-effect
benchmark follow it): estimated on every stance first; ``"prior"``, the component's guessed
2 mm / 1 deg, was the default until 2026-11-28 (``docs/diagnosis.md``, *The nuisance's size,
estimated*)."""

BASES: MappingProxyType[str, Callable[[], tuple]] = MappingProxyType(
    {"seed": bare_seed_model, "registered": base_model, "full": full_model}
)
"""Named bases: ``seed`` (the seed's law alone), ``registered`` (the default: the seed's law with
a fitted friction coefficient, sole and pose registration, belt speed), ``full`` (today's model:
``registered`` with damping and stiffness exponent in the law)."""


def sized_base(
    stances: Sequence[StanceData],
    model: tuple,
    pose_width: str = POSE_WIDTH,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    progress: Callable[[str], None] | None = None,
) -> tuple[tuple, str | None]:
    """``(model, note)``: the base with its pose-correction width as ``pose_width`` says,
    ``"estimated"`` on ``stances`` (:func:`~gc_ocp.estimation.pose_scale.with_estimated_width`;
    the note reports it) or ``"prior"`` (the model as given, no note). One definition for the
    diagnosis and its confirmation on new stances, so that both compare models on one nuisance."""
    if pose_width not in ("prior", "estimated"):
        raise ModelError(f'pose_width must be "prior" or "estimated", but got {pose_width!r}')
    if pose_width == "prior":
        return model, None
    (progress or (lambda s: None))(
        "estimating the pose correction's width on every stance (the nuisance's size)"
    )
    model, scale = with_estimated_width(list(stances), model, weights, options, progress)
    if scale is None:
        return model, None
    return model, scale.message(
        "the diagnosis's candidates test the unmodelled effects; every model and fold gets this "
        "width, so the comparison stays fair, but a wide nuisance can absorb part of an effect"
    )


def effect_names(names, what: str = "effects") -> list[str]:
    """``names`` (one string is one name) as effects of the library, each once, in the order
    given; an unknown one is an :class:`~gc_ocp.errors.UnknownNameError` naming the choices."""
    names = list(dict.fromkeys(names_of(names, what)))  # an effect named twice is one
    unknown = [n for n in names if n not in REGISTRY]
    if unknown:
        raise UnknownNameError(
            f"Unknown effect(s) {unknown}; choose from {list(candidate_effects())}"
        )
    return names


def candidate_names(base: tuple, candidates: Sequence[str] | None = None) -> list[str]:
    """The effects to try on ``base``: ``candidates`` (default: every effect of the library,
    :data:`EFFECTS`) minus those the base already has."""
    names = candidate_effects() if candidates is None else candidates
    return [n for n in effect_names(names, "candidates") if not REGISTRY[n].present_in(base)]


def resolve_base(base: str | tuple) -> tuple[str, tuple]:
    """``(label, model)`` of a base given by name (:data:`BASES`) or as a model tuple."""
    if isinstance(base, str):
        if base not in BASES:
            raise UnknownNameError(f'Unknown base "{base}"; choose one of {sorted(BASES)}')
        return base, BASES[base]()
    return "custom", tuple(base)


def diagnose_stances(
    stances: list[StanceData],
    base: str | tuple = "registered",
    candidates: Sequence[str] | None = None,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    alpha: float = ALPHA,
    max_effects: int | None = None,
    n_boot: int = 2000,
    seed: int = 0,
    progress: Callable[[str], None] | None = None,
    workers: int | None = None,
    executor: Executor | None = None,
    n_replicates: int = N_REPLICATES,
    mismatch: MismatchFamily | None = DEFAULT_FAMILY,
    max_folds: int = MAX_FOLDS,
    mismatch_draws: int = MISMATCH_DRAWS,
    pose_width: str = POSE_WIDTH,
    stop_early: bool = True,
    null_fits: str = "one-step",
) -> Diagnosis:
    """The diagnosis of ``stances`` (one subject; see the module doc). ``alpha``: the
    family-wise rate of a false claim per round (:mod:`.null`); ``n_replicates``: the null's
    replicates per round; ``mismatch``: the family of model mismatch the null allows
    (:mod:`.mismatch`; None: noise only), ``mismatch_draws`` of it per round, each a refit of
    the parent (:mod:`.draws`). ``max_effects``: stop the forward selection after
    that many effects (``0``: rank only; ``1``: rank and add the best passing effect, as the
    withheld-effect benchmark does). ``workers``: processes of a local Dask cluster that
    evaluate the base's fits, a round's candidates and null draws in parallel (default
    :func:`~gc_ocp.diagnosis.execution.default_workers`; 1: in this process). ``executor``: a
    :class:`concurrent.futures.Executor` to run them on instead (e.g. a
    ``dask.distributed.Client(...).get_executor()``; ``workers`` is then ignored).
    ``max_folds``: most training fits per model; more stances to hold out are held out in that
    many groups (:func:`~gc_ocp.diagnosis.compare.fold_plan`). ``pose_width``: the base's
    pose-correction width, ``"estimated"`` on every stance first (:data:`POSE_WIDTH`;
    :func:`~gc_ocp.estimation.pose_scale.with_estimated_width`; the nuisance of every model
    and fold then has that size) or ``"prior"`` (its component's guessed 2 mm / 1 deg).
    ``stop_early``: a round's null draws stop once no candidate could be named (:func:`~gc_ocp.diagnosis.null.cannot_name`; False: all
    ``mismatch_draws`` are made, to check that the stop costs no claim). ``null_fits``: how the
    null scores a replicate, ``"one-step"`` (one Gauss-Newton step per fit, :mod:`.onestep`)
    or ``"refit"`` (every fold of every model refitted, the ranking's own statistic, each
    mismatch draw one replicate: :mod:`.refits`; tens of times the null's cost, for few
    stances, where the one step misses gains the refit shows; every round then holds out every
    candidate).

    Returns a :class:`~gc_ocp.diagnosis.result.Diagnosis`.

    >>> import gc_ocp
    >>> # skipped: minutes of Ipopt fits (tests/test_diagnosis.py runs small diagnoses)
    >>> trial = gc_ocp.load_trial(); kin = gc_ocp.compute_kinematics(trial)  # doctest: +SKIP
    >>> stances = gc_ocp.trial_stances(trial, kin, margin=0.03)             # doctest: +SKIP
    >>> d = gc_ocp.diagnose_stances(stances, candidates=["damping", "friction"])  # doctest: +SKIP
    """
    stances = require_stance_list(stances, "diagnose_stances")
    require_settings(weights, options)
    if not stances:  # was an IndexError (the frame rate of the first stance)
        raise InputError("no stances to diagnose: give the StanceData of one subject's trials")
    if null_fits not in NULL_FITS:
        raise InputError(f"null_fits must be one of {', '.join(NULL_FITS)}, but got {null_fits!r}")
    if workers is not None and not (is_count(workers) and workers >= 1):
        raise InputError(f"workers must be 1 or more (None: the cores), but got {workers!r}")
    if not (is_count(mismatch_draws) and mismatch_draws >= 0):
        raise InputError(
            f"mismatch_draws must be a whole number, 0 or more ({MISMATCH_DRAWS} is the default), "
            f"but got {mismatch_draws!r}"
        )
    # checked before any fit: each was an error deep inside the first round (n_boot 0: the
    # interval of no draws; alpha 0: a division by it) or a null of no replicates (NaN)
    if not (is_count(n_boot) and n_boot >= 1):
        raise InputError(f"n_boot must be 1 or more (2000 is the default), but got {n_boot!r}")
    if not (is_count(n_replicates) and n_replicates >= 1):
        raise InputError(
            f"n_replicates must be 1 or more ({N_REPLICATES} is the default), but got "
            f"{n_replicates!r}"
        )
    if not (isinstance(alpha, numbers.Real) and 0.0 < alpha < 1.0):
        raise InputError(
            f"alpha must be between 0 and 1 ({ALPHA} is the default), but got {alpha!r}"
        )
    noise_only = null_fits == "one-step" and (
        mismatch_draws == 0 or not draws_made(mismatch, null_fits)
    )
    if noise_only and n_replicates < fewest_draws(alpha):
        # its p-value counts the replicates: 1 / (B + 1) at the least, which must be under
        # alpha (the mismatch null's critical value is that of at least 32 draws)
        raise InputError(
            f"a noise-only null (no mismatch draws) of {n_replicates} replicates cannot name "
            f"any effect: its smallest p-value is 1/{n_replicates + 1}, not under alpha "
            f"{alpha:g}; give n_replicates {fewest_draws(alpha)} or more ({N_REPLICATES} is the "
            "default)"
        )
    if null_fits == "refit" and mismatch_draws < 1:
        raise InputError(
            f"null_fits='refit' makes one replicate per mismatch draw, but mismatch_draws is "
            f"{mismatch_draws}: give 32 or more (--null-draws), or the one-step null"
        )
    say = progress or (lambda s: None)
    t0 = time.perf_counter()
    base_label, base_model_ = resolve_base(base)
    names = candidate_names(base_model_, candidates)
    plan = fold_plan(stances, max_folds)
    rate = 1.0 / float(np.median(np.diff(stances[0].time)))
    notes = []
    if draws_made(mismatch, null_fits) and 0 < mismatch_draws < fewest_draws(alpha):
        notes.append(
            f"{mismatch_draws} mismatch draws per round: the adjusted p-value counts draws, so "
            f"its smallest value is 1/{mismatch_draws + 1}, not under alpha {alpha:g}: no "
            f"candidate can be named; give at least {fewest_draws(alpha)} draws "
            f"({MISMATCH_DRAWS} is the default)"
        )
    base_model_, width_note = sized_base(stances, base_model_, pose_width, weights, options, say)
    if width_note:
        notes.append(width_note)
    if not plan:
        notes.append(
            "No stance could be held out (every foot has a single stance): effects are scored "
            "in-sample with a BIC penalty (the calibrated test on the in-sample fit); give more "
            "stances or trials of the subject for a held-out diagnosis."
        )
    held = held_out(plan)
    grouped = any(len(g) > 1 for g in plan)
    folds = {
        "kind": (
            f"{len(plan)} groups of held-out stances"
            if grouped
            else "leave-one-stance-out"
            if plan
            else "in-sample (BIC penalty)"
        ),
        "n": len(held),
        "heldout": [stances[i].label for i in held],
        "stances": [st.label for st in stances],
        **({"groups": [[stances[i].label for i in g] for g in plan]} if grouped else {}),
    }
    selected: list[str] = []
    remaining = list(names)
    rounds: list[list[RankRow]] = []
    calibration: list[dict] = []
    # the order a round hands its candidates to the workers, the dearest first: round 1 by
    # their declared relative cost, later rounds by the time each took in the round before
    hint: dict = {n: REGISTRY[n].relative_cost for n in names if n in REGISTRY}
    limit = len(names) if max_effects is None else max_effects
    with candidate_executor(workers, executor) as pool:
        say(f"fitting the base ({base_label}) on {len(stances)} stances, {len(plan)} folds")
        current = evaluate_base(stances, base_model_, plan, pool, weights, options, say)
        evaluations = {"base": current}
        waterfall = [WaterfallStep.of("base", current)]
        while remaining:
            say(f"round {len(rounds) + 1}: {len(remaining)} candidate(s) on top of {current.label}")
            parent_lin = linearize_parent(stances, current.model, current.full, weights)
            jobs = [
                Job(
                    name=n,
                    label="+".join(["base", *selected, n]),
                    model=model_from_names([*selected, n], base=base_model_),
                    names=(*selected, n),
                )
                for n in remaining
            ]
            # round 1 ranks every candidate on held-out stances (the ranking the user reads);
            # later rounds only decide the selection, so only the candidates the calibrated
            # test names are held out there (the others are ``screened``)
            # (the refit null scores every candidate by its refitted folds: all held out)
            first = not rounds or not plan or null_fits == "refit"
            inputs = RoundInputs(
                tuple(stances), tuple(plan), current, weights, options, first, parent_lin.r
            )
            evs = evaluate_round(jobs, inputs, pool, say, hint)
            hint = {n: ev.seconds for n, ev in evs.items()}
            failed = {n: ev for n, ev in evs.items() if isinstance(ev, NotEvaluable)}
            notes += [f"{n} is not evaluable on these data: {e.message}" for n, e in failed.items()]
            remaining = [n for n in remaining if n not in failed]  # not retried in later rounds
            ok = {n: ev for n, ev in evs.items() if n not in failed}
            able, known = contenders(current, ok, n_boot, seed, rate)
            # a later round's hold-outs: folds fitted, no linearisation for the null (:func:`hold_out`)
            again = RoundInputs(tuple(stances), tuple(plan), current, weights, options)
            if not first and stop_early:
                # a screened candidate the floor cannot yet rule out (its in-sample gain clears
                # it) keeps the null's draws going, and would be held out if the test named it:
                # hold it out now, so that a held-out gain under the floor stops the draws at
                # their first look instead of after all of them (the test and its claims are
                # unchanged: the floor is the null's business only through ``able``)
                early = [j for j in jobs if j.name in able and ok[j.name].screened]
                hold_out(early, ok, evs, again, pool, say)
                able, known = contenders(current, ok, n_boot, seed, rate)
            spare = (
                not first
                and stop_early
                and not first_look_names(mismatch, null_fits, mismatch_draws, alpha)
            )
            if spare and not within_reach(able, known):
                # no candidate clears the floor, nor would with more stances, and the null
                # would stop at its first look, whose p-values cannot fall under alpha: no
                # draw could name one or tell how many steps would (its rows: "not tested")
                tests, info = {}, _not_tested(mismatch_draws)
                say(f"  no null: {NOT_TESTED_WHY}")
            else:
                tests, info = _calibrated(
                    stances,
                    current,
                    parent_lin,
                    ok,
                    plan,
                    weights,
                    options,
                    rate,
                    mismatch,
                    mismatch_draws,
                    n_replicates,
                    seed,
                    alpha,
                    say,
                    pool,
                    able if stop_early else None,
                    null_fits,
                )
            calibration.append(info)
            if not first:
                named = [
                    j
                    for j in jobs
                    if j.name in tests and tests[j.name].p_adjusted < alpha and ok[j.name].screened
                ]
                hold_out(named, ok, evs, again, pool, say)
            evaluations.update({ev.label: ev for ev in ok.values()})
            rows = rank(current, evs, tests, n_boot, seed, rate, alpha, known)
            rounds.append(rows)
            if (note := step_note(rows, info, current.label, len(rounds))) is not None:
                notes.append(note)
            best = best_passing(rows)
            if best is None or len(selected) >= limit:
                break
            selected.append(best.effect)
            remaining.remove(best.effect)
            current = evs[best.effect]
            waterfall.append(WaterfallStep.of(f"+{best.effect}", current))
            if len(selected) >= limit:
                break
    if rounds:  # round 1 is the ranking; it names the non-additive pairs too
        rounds[0] = flag_non_additive(rounds[0], rounds, selected)
    wh = {
        # in the units of the error scale the fits minimised (the caller's weights)
        "base": where(evaluations["base"].scored_fits, evaluations["base"].weights),
        "final": where(current.scored_fits, current.weights),
    }
    drawn = drawn_family(mismatch, mismatch_draws)
    notes += plate_note(selected, drawn)
    notes += unconverged_notes(evaluations)
    return Diagnosis(
        base=base_label,
        base_components=[c.name for c in base_model_],
        candidates=names,
        ranking=list(rounds[0]) if rounds else [],
        rounds=rounds,
        selected=selected,
        waterfall=waterfall,
        where=wh,
        folds=folds,
        seconds=time.perf_counter() - t0,
        alpha=alpha,
        calibration=calibration,
        measurement=measurement_of(stances),
        evaluations=evaluations,
        notes=notes,
        max_effects=max_effects,
        floor_pct=MIN_REDUCTION_PCT,
        mismatch_family=None if drawn is None else drawn.to_json(),
    )


def hold_out(jobs: Sequence[Job], ok: dict, evs: dict, inputs: RoundInputs, pool, say) -> None:
    """Hold out the screened candidates of ``jobs`` (a later round's): their folds fitted from
    their fits on all stances, which they keep, as does their linearisation; ``ok`` and ``evs``
    updated in place (a fold that raises leaves the screened evaluation)."""
    if not jobs:
        return
    held = evaluate_round(
        [dataclasses.replace(j, full=ok[j.name].full) for j in jobs], inputs, pool, say
    )
    for n, ev in held.items():
        if not isinstance(ev, NotEvaluable):
            ev.linear = ok[n].linear
            ok[n] = evs[n] = ev


def draws_made(family: MismatchFamily | None, null_fits: str) -> bool:
    """Whether a round's null is made of mismatch draws (its p-value then counts draws): with a
    family of non-zero scale, or with the refit null (one replicate per draw, noise only when no
    family). Otherwise the null is the noise-only one-step null, whose p-value counts its
    wild-bootstrap replicates."""
    return null_fits == "refit" or drawn_family(family, 1) is not None


def first_look_names(
    family: MismatchFamily | None, null_fits: str, n_draws: int, alpha: float
) -> bool:
    """Whether a later round's null, stopped at its first look (no candidate the floor leaves:
    :func:`~gc_ocp.diagnosis.null.cannot_name`), could still name a candidate: its p-value
    counts the draws made (at most :data:`~gc_ocp.diagnosis.null.DRAWS_PER_LOOK`), so it
    cannot unless they reach :func:`~gc_ocp.diagnosis.null.fewest_draws`; a noise-only null
    (no draws) counts its replicates and can. A candidate the test names under the floor is
    held out when screened and, with a held-out gain above 0, *inconclusive*
    (:func:`~gc_ocp.diagnosis.selection.rank`): a round whose null could name one is tested
    even when every candidate is out of the floor's reach."""
    if not draws_made(family, null_fits) or n_draws <= 0:
        return True
    return min(DRAWS_PER_LOOK, n_draws) >= fewest_draws(alpha)


def unconverged_notes(evaluations: Mapping[str, Evaluation]) -> list[str]:
    """A note per model some of whose held-out solves (the frozen model's fit of a held-out
    stance's nuisance) did not converge, even solved again from where they stopped
    (:func:`~gc_ocp.estimation.solve.retry_from_stop`): its held-out score counts them as they
    stopped."""
    out = []
    for label, ev in evaluations.items():
        bad = [f.label for f in ev.folds if not f.heldout.success]
        if bad:
            out.append(
                f"{label}: the held-out solve of {len(bad)} of {len(ev.folds)} stance(s) did not "
                f"converge, also solved again from where it stopped ({', '.join(bad)}); its held-out "
                f"score counts them where they stopped"
            )
    return out


def _not_tested(n_draws: int) -> dict:
    """The calibration record of a later round that makes no null: every candidate is out of
    the effect-size floor's reach (:func:`~gc_ocp.diagnosis.selection.within_reach`), so the
    test cannot change its answer (round 1, the ranking the user reads, is always tested)."""
    return {
        "replicates": 0,
        "mismatch_draws": 0,
        "mismatch_draws_left_out": 0,
        "mismatch_draws_planned": n_draws,
        "null_stopped_early": False,
        "not_tested": True,
        "null_looks": [],
        "floor_leaves": [],
        "z_critical": None,
        "one_step_miss": None,
        "seconds": 0.0,
    }


def _calibrated(
    stances,
    parent,
    parent_lin,
    evs,
    plan,
    weights,
    options,
    rate,
    family,
    n_draws,
    n_replicates,
    seed,
    alpha,
    say,
    executor,
    among=None,
    null_fits="one-step",
) -> tuple[dict, dict]:
    """The calibrated tests of a round's evaluated candidates and what the round's null was
    (replicates, mismatch draws, critical value, seconds). ``among``: the candidates the
    effect-size floor leaves (:func:`~gc_ocp.diagnosis.selection.contenders`); given, the
    null's draws stop once none of them could be named
    (:func:`~gc_ocp.diagnosis.null.cannot_name`; None: every draw is made). ``null_fits``:
    ``"refit"`` scores the data and every replicate by refitted folds (:mod:`.refits`)."""
    t0 = time.perf_counter()
    lins = {n: ev.linear for n, ev in evs.items() if ev.linear is not None}
    # the held-out fits' Occam terms; none without folds (the in-sample fallback: the test's
    # statistic is then the in-sample reduction, for the data and the null alike)
    occam = {"parent": np.array([f.occam for f in parent.folds])} if plan else {}
    occam.update({n: np.array([f.occam for f in ev.folds]) for n, ev in evs.items() if ev.folds})
    means = fold_prior_means(stances, parent.model, plan)
    null, draw, skipped, looks, shares = None, None, 0, [], None
    refit = null_fits == "refit"
    if refit:
        observed = observed_refit(parent, evs)
        family = family if family is not None else MismatchFamily(scale=0.0)  # noise only
    else:
        observed = observed_reductions(parent_lin, lins, plan, occam, means) if lins else None
    if not ((lins or refit) and evs and draws_made(family, null_fits)) or n_draws <= 0:
        n_draws = 0
    else:
        law = with_lls_start(parent.model, stances)  # the law prior of every fit
        truth = debiased(stances, law, parent.full, -prior_step(parent_lin), weights)
        inputs = NullInputs(
            stances=tuple(stances),
            model=law,
            full=parent.full,
            truth=truth,
            children={n: (with_lls_start(evs[n].model, stances), evs[n].full) for n in lins},
            parent=parent_lin,
            plan=tuple(plan),
            occam=occam,
            fold_means=tuple(means),
            n_wild=max(1, -(-n_replicates // n_draws)),
            frame_rate=rate,
            weights=weights,
            options=options,
        )
        stop = None if among is None else observed[0]
        if refit:  # one replicate per draw, every fold of every model refitted (.refits)
            source, task = RefitInputs(inputs, parent, evs), draw_refits
            say(
                f"  refit null: {n_draws} replicates, each every fold of {parent.label} and "
                f"its {len(evs)} candidates refitted"
            )
            told = lambda k, n: say(f"  refit null: replicate {k} of up to {n}")  # noqa: E731
        else:
            source, task, told = inputs, None, None
            say(
                f"  calibrated null: up to {n_draws} mismatch draws (they stop once no "
                f"candidate can be named), each a refit of {parent.label}"
            )
        null, draw, skipped, shares = mismatch_null(
            source, family, n_draws, seed, executor, stop, alpha, among, task, told
        )
        looks = null_looks(observed[0], null, draw, n_draws, among)
    if refit:  # the statistic is the refit's: no one-step null stands in for it
        n_held = len(held_out(plan))  # 0 in sample: no steps (null.more_stances)
        obs, sd = observed
        # a noise-only family (scale 0) has no spread between draws: each replicate is its own
        # draw, and none of the spread is a mismatch's that more stances would not shrink
        noise_only = family.scale == 0
        tests = (
            decide(
                obs,
                null,
                sd,
                n_held,
                alpha,
                None if noise_only else draw,
                None if noise_only else shares,
                n_draws,
            )
            if null
            else {}
        )
    else:
        tests = calibrate(
            parent_lin,
            parent.full.stance_fits,
            lins,
            plan,
            occam,
            null,
            n_replicates,
            seed,
            rate,
            alpha,
            means,
            draw,
            observed,
            shares,
            n_draws or None,
        )
    crit = next(iter(tests.values())).z_critical if tests else None
    miss = None
    if plan and parent.folds:
        whole, per = step_miss(
            parent_lin, np.array([f.energy for f in parent.folds]), plan, occam["parent"], means
        )
        worst = int(np.argmax(np.abs(per)))
        miss = {
            "pct": whole,
            "worst_stance": parent.folds[worst].label,
            "worst_stance_pct": float(per[worst]),
        }
    seconds = time.perf_counter() - t0
    n_rep = n_replicates if null is None else int(next(iter(null.values())).size)
    z = "n/a" if crit is None else f"{crit:.3g}"
    say(f"  calibrated null: {n_rep} replicates, z_crit {z}, {seconds:.1f} s")
    made = 0 if draw is None else int(np.unique(draw).size) + skipped
    info = {
        "replicates": n_rep,
        "mismatch_draws": made - skipped,
        "mismatch_draws_left_out": skipped,
        "mismatch_draws_planned": n_draws,
        "null_stopped_early": made < n_draws,
        "null_looks": looks,
        "floor_leaves": None if among is None else sorted(among),
        "z_critical": crit,
        **({"null_fits": "refit"} if refit else {}),
        "one_step_miss": miss,
        "seconds": seconds,
    }
    return tests, info


def drawn_family(mismatch: MismatchFamily | None, draws: int) -> MismatchFamily | None:
    """The family the null's draws came from: ``mismatch``, or None where it drew none (no
    family, no draws, or a family at scale 0: a noise-only null, which draws no plate errors
    either, whatever the family says)."""
    return mismatch if mismatch is not None and mismatch.scale > 0 and draws > 0 else None


def plate_note(selected: Sequence[str], family: MismatchFamily | None) -> list[str]:
    """A note on the named effects that plate calibration errors mimic
    (:attr:`~gc_ocp.estimation.components.base.Component.plate_mimicked`) when the null's
    family did not draw them: such a claim holds for calibrated plates; where they were not
    calibrated in situ, the same diagnosis with them in the null checks it."""
    if family is not None and family.plate_calibration:
        return []
    named = [n for n in selected if n in REGISTRY and REGISTRY[n].plate_mimicked]
    if not named:
        return []
    return [
        f"{', '.join(named)} named under a null without plate calibration errors; plates a "
        "few millimetres off or a percent or two mis-scaled give gains of this kind. If the "
        "lab's plates were not calibrated in situ, check the claim with the plate errors in "
        "the null (gc-ocp diagnose --plate-calibration; docs/diagnosis.md, 'Mismatch family')."
    ]


def unseen_gains(rows: Sequence[RankRow]) -> list[RankRow]:
    """The rows not named whose refit gains more than the rule's effect-size floor and more than
    their one step (the calibrated test's statistic) by more than that floor: gains the test
    could not weigh (:func:`step_note`)."""
    return [
        r
        for r in rows
        if r.calibrated is not None
        and not r.passes
        and r.heldout_rms_reduction_pct is not None
        and r.heldout_rms_reduction_pct > MIN_REDUCTION_PCT
        and r.heldout_rms_reduction_pct - r.calibrated.observed_pct > MIN_REDUCTION_PCT
    ]


def step_note(rows: Sequence[RankRow], info: dict, parent: str, k: int) -> str | None:
    """A note on round ``k`` when the test's one step sees much less than the refit: candidates
    not named whose refit gains more than their one step by more than the rule's effect-size
    floor, and the parent's own miss when beyond it (``info["one_step_miss"]``,
    :func:`~gc_ocp.diagnosis.null.step_miss`). The refit's gain then needs the other parameters
    moved far from the fit on all stances (each fold's own fits), which one step from there does
    not follow: the test keeps its false-claim rate (its null is scored the same way) but can
    miss such a gain (``docs/diagnosis.md``, "Why the one step misses on real walking"). None
    for a round of the refit null (``info["null_fits"]``), whose test takes no one step."""
    if info.get("null_fits") == "refit":
        return None
    gaps = [
        f"{r.effect} (refit {r.heldout_rms_reduction_pct:+.1f} %, one step "
        f"{r.calibrated.observed_pct:+.1f} %)"
        for r in unseen_gains(rows)
    ]
    miss = info.get("one_step_miss")
    parent_off = miss is not None and abs(miss["pct"]) > MIN_REDUCTION_PCT
    if not gaps and not parent_off:
        return None
    parts = []
    if gaps:
        parts.append(
            f"for {', '.join(gaps)}, the refit gains more than the calibrated test's one step "
            f"from {parent}'s fit sees, by more than the rule's {MIN_REDUCTION_PCT} % floor"
        )
    if parent_off:
        parts.append(
            f"the one step puts {parent}'s own held-out score {miss['pct']:+.1f} % from its "
            f"refitted folds' (held-out stance {miss['worst_stance']}: "
            f"{miss['worst_stance_pct']:+.1f} %)"
        )
    return (
        f"round {k}: {'; '.join(parts)}. Such a gain needs the other parameters moved far from "
        "the fit on all stances (each fold's own fit), which one step from there does not "
        "follow: the test keeps its false-claim rate (its null is scored the same way) but can "
        "miss it. More stances per foot bring the folds' fits closer; a null of refitted folds "
        "weighs such a gain itself (null_fits='refit', --null-fits refit: tens of times the "
        "cost; docs/diagnosis.md, 'Why the one step misses on real walking')."
    )


_CLI_NAMES = MappingProxyType(
    {
        "null_draws": "--null-draws: here mismatch_draws=",
        "effects": "--effects: here candidates=",
        "plate_calibration": (
            "--plate-calibration: here mismatch=gc_ocp.diagnosis.null.DEFAULT_FAMILY"
            ".with_plate_calibration()"
        ),
    }
)
"""The CLI's names of :func:`diagnose`'s keywords where they differ (the README's words, so
a user's first guess in Python), each with the keyword to give instead."""


def diagnose(
    trials: list,
    base: str | tuple = "registered",
    candidates: Sequence[str] | None = None,
    progress: Callable[[str], None] | None = None,
    **kw,
) -> Diagnosis:
    """Diagnose the gap between ``base`` and the force plates on ``trials`` (``[(Trial,
    TrialKinematics), ...]`` of one subject: they share contact parameters; pose corrections are
    per stance). ``base``: ``"registered"`` (default), ``"seed"``, ``"full"`` or a tuple of
    components; ``candidates``: effect names (default: every effect of ``gc_ocp.EFFECTS`` the
    base lacks). Keyword arguments (``workers``, ``executor``, ...) go to
    :func:`diagnose_stances`.

    Returns a :class:`~gc_ocp.diagnosis.result.Diagnosis` (``.summary()``, ``.selected``,
    ``.ranking``, ``.to_json()``).

    >>> import gc_ocp
    >>> trial = gc_ocp.load_trial(); kin = gc_ocp.compute_kinematics(trial)
    >>> # skipped: minutes of Ipopt fits on the bundled trial
    >>> d = gc_ocp.diagnose([(trial, kin)], candidates=["damping", "ground_offset"])  # doctest: +SKIP
    >>> print(d.summary())                                                  # doctest: +SKIP

    A keyword it does not take is refused at once, naming those it takes:

    >>> d = gc_ocp.diagnose([(trial, kin)], worker=2)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    gc_ocp.errors.InputError: diagnose got unknown keyword argument(s) ['worker']; it takes base, ...
    """
    known = [k for k in inspect.signature(diagnose_stances).parameters if k != "stances"]
    unknown = sorted(set(kw) - set(known))
    if unknown:  # was diagnose_stances()'s TypeError, naming a function the caller never called
        cli = [f"{k}= is the command line's {_CLI_NAMES[k]}" for k in unknown if k in _CLI_NAMES]
        raise InputError(
            f"diagnose got unknown keyword argument(s) {unknown}; "
            + (f"{'; '.join(cli)}; " if cli else "")
            + f"it takes {', '.join(known)} (help(gc_ocp.diagnose_stances))"
        )
    _, data, notes = fit_data(trials, progress=progress)
    d = diagnose_stances(data, base, candidates, progress=progress, **kw)
    d.notes = [*notes, *d.notes]
    return d


__all__ = (
    "BASES",
    "POSE_WIDTH",
    "candidate_names",
    "diagnose",
    "diagnose_stances",
    "resolve_base",
    "sized_base",
)
