"""Confirmation: do the effects a diagnosis selected still shrink the gap on stances it never saw?

The base and the base plus each selected effect (cumulatively, in order) are fitted on the
stances the diagnosis used and scored on new stances or trials of the same subject, frozen with
their nuisance re-estimated, as a fold's held-out stance is
(:func:`~gc_ocp.diagnosis.compare.evaluate_on`). The answer is plain data (a dict, written as is
by ``benchmarks/diagnosis_real.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from gc_ocp.diagnosis.compare import check_trained_feet, evaluate_on, reduction
from gc_ocp.diagnosis.diagnose import POSE_WIDTH, effect_names, resolve_base, sized_base
from gc_ocp.diagnosis.result import WaterfallStep
from gc_ocp.errors import ModelError
from gc_ocp.estimation.components import model_from_names
from gc_ocp.estimation.problem import Weights
from gc_ocp.estimation.solve import IpoptOptions
from gc_ocp.io.consistency import same_motion
from gc_ocp.stance import StanceData, trial_names
from gc_ocp.workflow.fitting import fit_data


def confirm_stances(
    train: list[StanceData],
    test: list[StanceData],
    selected: Sequence[str],
    base: str | tuple = "registered",
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    n_boot: int = 2000,
    seed: int = 0,
    progress: Callable[[str], None] | None = None,
    pose_width: str = POSE_WIDTH,
) -> dict:
    """Do the effects a diagnosis selected still shrink the gap on stances it never saw?

    ``base`` and ``base`` + each of ``selected`` (cumulatively, in order) are fitted on all of
    ``train`` (the stances the diagnosis used) and scored on every stance of ``test`` (other
    stances or trials of the subject), frozen with their nuisance re-estimated, as a fold's
    held-out stance is (:func:`~gc_ocp.diagnosis.compare.evaluate_on`). Returns ``{"train",
    "test": stance labels, "selected", "steps": [{"model", "heldout_superior_force_pct_bw",
    "heldout_rms", "score", "step_reduction_pct", "step_reduction_ci", "total_reduction_pct",
    "total_reduction_ci", "per_stance_total_pct"}, ...]}`` (reductions of the combined score
    over the previous step and over the base, 95 % paired block bootstrap intervals; the base
    step has no reductions), ``"pose_width"`` and ``"notes"``. ``pose_width``: the base's
    pose-correction width as the diagnosis takes it (:func:`~gc_ocp.diagnosis.diagnose.sized_base`),
    estimated on ``train`` only (the new stances inform no choice made before they are scored)."""
    say = progress or (lambda s: None)
    _, base_model_ = resolve_base(base)
    selected = effect_names(selected, "selected")
    if not test:
        raise ModelError(
            "No stance to confirm on: give stances or trials the diagnosis did not use"
        )
    check_trained_feet(train, test)
    base_model_, note = sized_base(train, base_model_, pose_width, weights, options, say)
    rate = 1.0 / float(np.median(np.diff(test[0].time)))
    kw = {"weights": weights, "options": options, "progress": say}
    say(f"confirming on {len(test)} new stance(s), trained on {len(train)}")
    first = parent = evaluate_on(train, test, base_model_, "base", **kw)
    steps = [WaterfallStep.of("base", first).to_json()]
    for j in range(len(selected)):
        names = tuple(selected[: j + 1])
        ev = evaluate_on(
            train,
            test,
            model_from_names(list(names), base=base_model_),
            "+".join(["base", *names]),
            names,
            parent=parent,
            **kw,
        )
        r_step = reduction(parent, ev, n_boot=n_boot, seed=seed, frame_rate=rate)
        r_total = reduction(first, ev, n_boot=n_boot, seed=seed, frame_rate=rate)
        steps.append(
            {
                **WaterfallStep.of(f"+{names[-1]}", ev).to_json(),
                "step_reduction_pct": r_step["pct"],
                "step_reduction_ci": r_step["ci"],
                "total_reduction_pct": r_total["pct"],
                "total_reduction_ci": r_total["ci"],
                "per_stance_total_pct": r_total["per_stance"],
            }
        )
        parent = ev
    return {
        "train": [st.label for st in train],
        "test": [st.label for st in test],
        "selected": list(selected),
        "steps": steps,
        "pose_width": pose_width,
        "notes": [note] if note else [],
    }


def confirm(
    trials: list,
    new_trials: list,
    selected: Sequence[str],
    base: str | tuple = "registered",
    progress: Callable[[str], None] | None = None,
    **kw,
) -> dict:
    """:func:`confirm_stances` on trials: ``trials`` those the diagnosis used, ``new_trials``
    other trials of the same subject (``[(Trial, TrialKinematics), ...]`` each). Keyword
    arguments go to :func:`confirm_stances`."""
    # named together, so that a new trial is never taken for a diagnosed one because the two
    # files share a name (walking1/markers.trc, walking2/markers.trc); the same file keeps its name
    names = trial_names([t.source for t, _ in [*trials, *new_trials]])
    _, train, _ = fit_data(trials, progress=progress, names=names[: len(trials)])
    _, test, _ = fit_data(new_trials, progress=progress, names=names[len(trials) :])
    clash = sorted({st.label for st in train} & {st.label for st in test})
    same = same_motion([t for t, _ in trials], [t for t, _ in new_trials])
    if clash or same:
        what = [f"stances {clash} are in both the diagnosed and the new trials"] if clash else []
        what += [
            f"{b} holds the same motion as the diagnosed {a} (identical markers)" for a, b in same
        ]
        raise ModelError(
            f"The new trials repeat diagnosed ones: {'; '.join(what)}. Confirm on trials the "
            "diagnosis did not use."
        )
    return confirm_stances(train, test, selected, base, progress=progress, **kw)


__all__ = ("confirm", "confirm_stances")
