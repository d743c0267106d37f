"""Which unmodelled effect causes the gap, and how far it shrinks: ranking, forward selection,
confounding (see ``docs/diagnosis.md``).

1. The base model is fitted and scored on held-out stances (:mod:`.compare`).
2. Every candidate effect (a registered component not already in the base) is added alone,
   refitted (warm-started from the base's fits, fold by fold) and scored the same way: its
   held-out reduction with a 95 % bootstrap interval, and its in-sample reduction for reference.
3. **Decision rule** ("none" is a possible answer): an effect passes when its held-out reduction
   is at least :data:`MIN_REDUCTION_PCT` *and* the lower end of its interval is above 0 *and*
   it reduces the in-sample objective by at least :data:`MIN_REDUCTION_PCT` too (a held-out gain
   without an in-sample one comes from how the model extrapolates per-unit stiffnesses from few
   training stances: the false answers of the withheld-effect benchmark,
   ``docs/diagnosis.md (withheld-effect benchmark)``). The held-out score already charges extra parameters that only fit noise (they do not predict the
   held-out stance) and the nuisance for the freedom it uses (Occam term); the threshold guards
   against the noise of the score itself (calibrated on the withheld-effect benchmark's "none"
   cases).
4. **Forward selection**: the best passing effect is added, the others are re-ranked on top of it,
   and so on until none passes. The waterfall lists the held-out RMS after each step.
5. **Confounding**: two candidates are named confounded when their changes of the held-out
   residual are alike (cosine similarity of the weighted residual changes above
   :data:`CONFOUND_COSINE`, both reducing the score), or their changes of the in-sample
   residual are, with comparable sizes (both reducing the in-sample objective by the
   threshold: they explain the same part of the gap on the fitted stances, even if only one
   carries over to held-out ones), or when one stops passing once the other
   is in the model (its gain falls by more than half: the gains are not additive), or with the
   base's per-stance nuisance (``kinematic_correction``) when its gain comes mostly from a
   smaller nuisance cost rather than a better fit of the data (:data:`NUISANCE_SHARE`), or
   when both pass and the paired bootstrap of their difference does not order them (a tie).
   The result says so instead of guessing which one it is.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence

import numpy as np

from gc_ocp.diagnosis.compare import (
    Evaluation,
    describe,
    evaluate,
    evaluate_on,
    fold_plan,
    heldout_quality,
    insample_reduction,
    reduction,
    score,
    superior_rms,
    weighted_residuals,
)
from gc_ocp.diagnosis.where import where
from gc_ocp.errors import ModelError
from gc_ocp.estimation.components import (
    EFFECTS,
    REGISTRY,
    bare_seed_model,
    base_model,
    full_model,
    model_from_names,
)
from gc_ocp.estimation.problem import Weights
from gc_ocp.estimation.solve import IpoptOptions
from gc_ocp.stance import StanceData

MIN_REDUCTION_PCT = 2.0
"""Smallest held-out reduction [%] of the combined score that counts as an effect."""

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

BASES: dict[str, Callable[[], tuple]] = {
    "seed": bare_seed_model,
    "registered": base_model,
    "full": full_model,
}
"""Named bases: ``seed`` (the seed's law alone), ``registered`` (the default: the seed's law with
a fitted friction coefficient, sole and pose registration, belt speed), ``full`` (today's model:
``registered`` with damping and stiffness exponent in the law)."""


def candidate_names(base: tuple, candidates: Sequence[str] | None = None) -> list[str]:
    """The effects to try on ``base``: ``candidates`` (default: every effect of the library,
    :data:`EFFECTS`) minus those the base already has."""
    names = list(EFFECTS if candidates is None else candidates)
    unknown = [n for n in names if n not in REGISTRY]
    if unknown:
        raise ModelError(f"Unknown effect(s) {unknown}; choose from {list(EFFECTS)}")
    return [n for n in names if not REGISTRY[n].present_in(base)]


def resolve_base(base: str | tuple) -> tuple[str, tuple]:
    """``(label, model)`` of a base given by name (:data:`BASES`) or as a model tuple."""
    if isinstance(base, str):
        if base not in BASES:
            raise ModelError(f'Unknown base "{base}"; choose one of {sorted(BASES)}')
        return base, BASES[base]()
    return "custom", tuple(base)


@dataclasses.dataclass
class Diagnosis:
    """The result of :func:`diagnose`: plain data plus the evaluations behind it.

    ranking: every candidate against the base (round 1), best first; rounds: the ranking of every
    forward-selection round; selected: effects added, in order; waterfall: held-out RMS after each
    step; where: the residual map of the base (held-out stances) and of the final model;
    evaluations: ``{label: Evaluation}`` (fits; not written to JSON)."""

    base: str
    base_components: list[str]
    candidates: list[str]
    ranking: list[dict]
    rounds: list[list[dict]]
    selected: list[str]
    waterfall: list[dict]
    where: dict
    folds: dict
    seconds: float
    threshold_pct: float
    evaluations: dict = dataclasses.field(default_factory=dict, repr=False)
    notes: list[str] = dataclasses.field(default_factory=list)
    max_effects: int | None = None

    @property
    def inconclusive(self) -> list[str]:
        """Candidates of the last round that fail the rule yet reduce the score both in-sample
        (by at least the threshold) and on held-out stances, without a margin the data support
        (below the threshold, or an interval reaching 0): with more stances they might pass. When
        nothing is selected, "none" is then a weak answer, and the result says so."""
        return [r["effect"] for r in (self.rounds[-1] if self.rounds else []) if r["inconclusive"]]

    @property
    def base_evaluation(self) -> Evaluation:
        return self.evaluations["base"]

    @property
    def final_evaluation(self) -> Evaluation:
        return self.evaluations[self.waterfall[-1]["label"]]

    def to_json(self) -> dict:
        """``diagnosis.json`` (schema in ``docs/diagnosis.md``)."""
        b = self.waterfall[0]  # the base's step: its held-out numbers
        return {
            "base": {
                "name": self.base,
                "model": self.base_components,
                "heldout_rms": b["heldout_rms"],
                "heldout_superior_force_pct_bw": b["heldout_superior_force_pct_bw"],
                "score": b["score"],
            },
            "candidates": self.candidates,
            "ranking": self.ranking,
            "rounds": self.rounds,
            "selected": self.selected,
            "inconclusive": self.inconclusive,
            "waterfall": [_public(w) for w in self.waterfall],
            "where": self.where,
            "folds": self.folds,
            "threshold_pct": self.threshold_pct,
            "max_effects": self.max_effects,
            "score": (
                "held-out combined score: sqrt(2 E / n), E = data cost + nuisance prior cost + "
                "1/2 log det of the nuisance Hessian (all six channels, in units of the error "
                "scale); reduction = 1 - S_model / S_parent"
            ),
            "notes": self.notes,
            "seconds": self.seconds,
        }

    @classmethod
    def from_json(cls, d: dict) -> Diagnosis:
        """The diagnosis written by :meth:`to_json` (``diagnosis.json``), without its
        evaluations (the fits): enough for its summary, JSON, report page (given the final
        fit) and the figures that need no fit (ranking, waterfall, heat maps)."""
        selected = list(d["selected"])
        waterfall = [
            {"label": "+".join(["base", *selected[:k]]), **w} for k, w in enumerate(d["waterfall"])
        ]
        return cls(
            base=d["base"]["name"],
            base_components=list(d["base"]["model"]),
            candidates=list(d["candidates"]),
            ranking=[dict(r) for r in d["ranking"]],
            rounds=[[dict(r) for r in rows] for rows in d["rounds"]],
            selected=selected,
            waterfall=waterfall,
            where=d["where"],
            folds=d["folds"],
            seconds=d["seconds"],
            threshold_pct=d["threshold_pct"],
            notes=list(d["notes"]),
            max_effects=d["max_effects"],
        )

    @property
    def _scored(self) -> str:
        """ "held-out", or "in-sample" when no stance could be held out (the JSON keys keep
        their names; ``folds.kind`` says which)."""
        return "held-out" if self.folds["n"] else "in-sample"

    def summary(self) -> str:
        f = self.folds
        lines = [
            f"Diagnosis on base '{self.base}' ({', '.join(self.base_components)}); "
            f"{f['kind']}, {f['n']} held-out stance(s); {self.seconds:.0f} s",
            f"base {self._scored} superior-force RMS "
            f"{self.waterfall[0]['heldout_superior_force_pct_bw']:.2f} % BW",
            f"ranking ({self._scored} reduction of the combined score, 95 % interval; in-sample):",
        ]
        for r in self.ranking:
            mark = "PASS" if r["passes"] else "    "
            conf = (
                f"  confounded with {', '.join(r['confounded_with'])}"
                if r["confounded_with"]
                else ""
            )
            lines.append(
                f"  {mark} {r['effect']:<20} {r['heldout_rms_reduction_pct']:+6.1f} % "
                f"[{r['heldout_rms_reduction_ci'][0]:+.1f}, {r['heldout_rms_reduction_ci'][1]:+.1f}]"
                f"  in-sample {r['insample_rms_reduction_pct']:+6.1f} %  ({r['n_params']} params){conf}"
            )
        for k, rows in enumerate(self.rounds[1:], 2):
            lines.append(
                f"round {k} (on top of {' + '.join(['base', *self.selected[: k - 1]])}): "
                + "; ".join(_row_text(r) for r in rows)
            )
        lines.append(
            "selected: "
            + (", ".join(self.selected) if self.selected else "none (no effect passes)")
        )
        if self.inconclusive:
            lines.append(
                f"inconclusive: {', '.join(self.inconclusive)} (reduce the score in-sample and "
                "held out, without a clear margin: more stances would decide)"
            )
        lines.append(f"waterfall ({self._scored} superior-force RMS, % BW):")
        for w in self.waterfall:
            lines.append(f"  {w['model']:<28} {w['heldout_superior_force_pct_bw']:.2f}")
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)

    # --- figures ---------------------------------------------------------------------------
    def heatmap(self, which: str = "base"):
        """Heat map of where the residual lies (``which``: ``"base"`` or ``"final"``)."""
        from gc_ocp.diagnosis.where import heatmap_figure

        return heatmap_figure(self.where[which], title=f"Where the residual lies ({which} model)")

    def residual_figure(self, which: str = "base", **kw):
        """Residual over time of the held-out stances, phases shaded."""
        from gc_ocp.diagnosis.where import residual_figure

        ev = self.base_evaluation if which == "base" else self.final_evaluation
        return residual_figure(ev.heldout_fits if ev.folds else ev.full.stance_fits, **kw)

    def ranking_figure(self):
        """Held-out reduction per candidate with its 95 % interval and the threshold."""
        import matplotlib.pyplot as plt

        r = self.ranking
        fig, ax = plt.subplots(figsize=(7.0, 0.35 * len(r) + 1.4))
        y = np.arange(len(r))[::-1]
        v = np.array([e["heldout_rms_reduction_pct"] for e in r])
        ci = np.array([e["heldout_rms_reduction_ci"] for e in r]).reshape(-1, 2)
        colors = ["tab:green" if e["passes"] else "tab:gray" for e in r]
        ax.barh(y, v, color=colors)
        ax.errorbar(v, y, xerr=[v - ci[:, 0], ci[:, 1] - v], fmt="none", ecolor="k", capsize=3)
        ax.axvline(self.threshold_pct, color="tab:red", ls="--", lw=1, label="threshold")
        ax.axvline(0.0, color="k", lw=0.6)
        ax.set_yticks(y, [e["effect"] + (" *" if e["confounded_with"] else "") for e in r])
        ax.set_xlabel("held-out reduction of the combined score [%]  (* confounded)")
        ax.legend(fontsize=8)
        fig.tight_layout()
        return fig

    def waterfall_figure(self):
        """Held-out RMS per channel after each added effect."""
        import matplotlib.pyplot as plt

        from gc_ocp.contact.channels import TABLE_KEYS

        fig, ax = plt.subplots(figsize=(7.0, 3.6))
        labels = [w["model"] for w in self.waterfall]
        x = np.arange(len(labels))
        ax.plot(
            x,
            [w["heldout_superior_force_pct_bw"] for w in self.waterfall],
            "o-",
            lw=2.2,
            color="k",
            label="superior force (both feet)",
        )
        for ch in TABLE_KEYS.values():
            if ch == "superior_force_pct_bw":
                continue
            vals = [
                np.nanmean([w["heldout_rms"][s][ch] for s in w["heldout_rms"]])
                for w in self.waterfall
            ]
            ax.plot(x, vals, ".--", lw=1, label=ch.replace("_pct_bwh", "").replace("_pct_bw", ""))
        ax.set_xticks(x, labels, rotation=15)
        ax.set_ylabel("held-out RMS [% BW, % BW×H]")
        ax.set_ylim(bottom=0)
        ax.legend(fontsize=7, ncol=2)
        ax.set_title("How far the gap shrinks")
        fig.tight_layout()
        return fig


def _row_text(r: dict) -> str:
    """One later-round row in a line: ``effect +x.x % [lo, hi]`` (or its in-sample screen)."""
    if r["heldout_rms_reduction_pct"] is None:
        return f"{r['effect']} in-sample {r['insample_rms_reduction_pct']:+.1f} % (screened)"
    lo, hi = r["heldout_rms_reduction_ci"]
    mark = " PASS" if r["passes"] else ""
    return f"{r['effect']} {r['heldout_rms_reduction_pct']:+.1f} % [{lo:+.1f}, {hi:+.1f}]{mark}"


def _step(label: str, ev: Evaluation) -> dict:
    return {
        "label": label,
        "model": "base" if label == "base" else label,
        "heldout_superior_force_pct_bw": superior_rms(ev),
        "heldout_rms": heldout_quality(ev),
        "score": score(ev),
    }


def _public(step: dict) -> dict:
    """A waterfall step as written to JSON: without its evaluation ``label`` (an internal key)."""
    return {k: v for k, v in step.items() if k != "label"}


def _n_params(child: Evaluation, parent: Evaluation) -> int:
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


def _rank(parent, evs: dict, threshold, n_boot, seed, rate) -> list[dict]:
    rows = []
    base_r = weighted_residuals(parent)
    deltas = {}
    pd, pn = _terms(parent)
    for name, ev in evs.items():
        if ev.screened:
            rows.append(_screened_row(name, ev, parent))
            continue
        red = reduction(parent, ev, n_boot=n_boot, seed=seed, frame_rate=rate)
        d = base_r - weighted_residuals(ev)
        deltas[name] = d
        cd, cn = _terms(ev)
        gain = (pd + pn) - (cd + cn)
        # the share is only meaningful for a gain that counts (near 0 it is a ratio of noise)
        meaningful = gain > 0 and red["pct"] >= threshold
        from_nuisance = (pn - cn) / gain if meaningful else None
        relieves = [
            n
            for n in _nuisance_names(parent.model)
            if meaningful and from_nuisance > NUISANCE_SHARE
        ]
        # an in-sample gain too: a held-out gain without one comes from how the model
        # extrapolates unit stiffnesses between stances, not from explaining the misfit
        passes = bool(
            red["pct"] >= threshold and red["ci"][0] > 0.0 and red["insample_pct"] >= threshold
        )
        rows.append(
            {
                "effect": name,
                "heldout_rms_reduction_pct": red["pct"],
                "heldout_rms_reduction_ci": red["ci"],
                "heldout_superior_force_reduction_pct": red["superior_pct"],
                "insample_rms_reduction_pct": red["insample_pct"],
                "per_stance_reduction_pct": red["per_stance"],
                "n_params": _n_params(ev, parent),
                "passes": passes,
                "screened": False,
                # gains in-sample and on held-out stances, without a margin the data support
                "inconclusive": bool(
                    not passes and red["pct"] > 0.0 and red["insample_pct"] >= threshold
                ),
                "gain_from_nuisance": None if from_nuisance is None else float(from_nuisance),
                "confounded_with": relieves,
                "flags": [f["code"] for f in ev.full.flags],
            }
        )
    held = [r for r in rows if r["heldout_rms_reduction_pct"] is not None]
    _flag_alike(held, deltas, lambda r: r["heldout_rms_reduction_pct"] > 0)
    # in-sample: every candidate (screened ones too) against the fits on all stances
    base_in = weighted_residuals(parent, insample=True)
    ins = {n: base_in - weighted_residuals(ev, insample=True) for n, ev in evs.items()}
    _flag_alike(rows, ins, lambda r: r["insample_rms_reduction_pct"] >= threshold, comparable=True)
    # held out first (best first), then the screened ones (by their in-sample reduction)
    rows.sort(
        key=lambda r: (
            r["heldout_rms_reduction_pct"] is None,
            -(
                r["insample_rms_reduction_pct"]
                if r["heldout_rms_reduction_pct"] is None
                else r["heldout_rms_reduction_pct"]
            ),
        )
    )
    _flag_ties(rows, evs, n_boot, seed, rate)
    return rows


def _flag_alike(
    rows: list[dict], deltas: dict, gains: Callable[[dict], bool], comparable: bool = False
) -> None:
    """Name confounded the pairs of ``rows`` that both satisfy ``gains`` and whose residual
    changes (``deltas``: effect -> vector) have a cosine similarity above
    :data:`CONFOUND_COSINE`; with ``comparable``, only when the smaller change is at least
    :data:`COMPARABLE_FRACTION` of the larger (either could stand in for the other)."""
    for a in rows:
        for b in rows:
            if a is b or not (gains(a) and gains(b)) or b["effect"] in a["confounded_with"]:
                continue
            da, db = deltas[a["effect"]], deltas[b["effect"]]
            na, nb = np.linalg.norm(da), np.linalg.norm(db)
            if na == 0 or nb == 0 or float(da @ db) / (na * nb) <= CONFOUND_COSINE:
                continue
            if not comparable or min(na, nb) >= COMPARABLE_FRACTION * max(na, nb):
                a["confounded_with"].append(b["effect"])


def _screened_row(name: str, ev: Evaluation, parent: Evaluation) -> dict:
    """The ranking row of a candidate screened out on its in-sample reduction (not held out)."""
    return {
        "effect": name,
        "heldout_rms_reduction_pct": None,
        "heldout_rms_reduction_ci": [None, None],
        "heldout_superior_force_reduction_pct": None,
        "insample_rms_reduction_pct": insample_reduction(parent.full, ev.full),
        "per_stance_reduction_pct": {},
        "n_params": _n_params(ev, parent),
        "passes": False,
        "screened": True,
        "inconclusive": False,
        "gain_from_nuisance": None,
        "confounded_with": [],
        "flags": [f["code"] for f in ev.full.flags],
    }


def _flag_ties(rows: list[dict], evs: dict, n_boot, seed, rate) -> None:
    """Passing candidates whose held-out scores do not differ significantly (the 95 % interval
    of their paired difference, the same block bootstrap, reaches 0) are named confounded with
    each other: the data do not order them, so which one comes first is not an answer."""
    passing = [r for r in rows if r["passes"]]
    for i, a in enumerate(passing):
        for b in passing[i + 1 :]:
            hi = reduction(evs[a["effect"]], evs[b["effect"]], n_boot, seed, rate)["ci"][1]
            if hi >= 0.0:  # b is not significantly worse than a
                for x, y in ((a, b), (b, a)):
                    if y["effect"] not in x["confounded_with"]:
                        x["confounded_with"].append(y["effect"])


_SHARED: dict = {}
"""What every task of a round reads (stances, fold plan, parent, weights, options, screen, the
jobs), set before the worker processes are forked so that it is inherited, not pickled per task."""


def _task(name: str) -> Evaluation:
    sh = _SHARED
    label, model, names = sh["jobs"][name]
    return evaluate(
        sh["stances"],
        model,
        label,
        names,
        sh["plan"],
        sh["parent"],
        sh["weights"],
        sh["options"],
        screen_pct=sh["screen"],
    )


def _evaluate_all(
    stances, jobs, plan, parent, weights, options, workers, say, screen, hint=None
) -> dict:
    """``{name: Evaluation}`` of every job ``{name: (label, model, names)}``, one task per
    candidate on ``workers`` forked processes (the compiled per-frame functions are loaded from
    the disk cache once per process and configuration), the dearest first (``hint``: ``{name:
    seconds}`` of the candidates in the previous round). ``screen``: the in-sample screen of
    :func:`~gc_ocp.diagnosis.compare.evaluate`.

    One task per *fit* (a candidate's folds spread over the processes) was tried and measured
    slower before the Hessian regrouping (bundled trial 63.6 s against 49.5 s; three BTS trials
    149.5 s against 149.6 s): every process then derives and loads every configuration's
    functions, and the results travel between processes."""
    if workers <= 1 or len(jobs) <= 1:
        return {
            n: evaluate(
                stances,
                model,
                label,
                names,
                plan,
                parent,
                weights=weights,
                options=options,
                progress=say,
                screen_pct=screen,
            )
            for n, (label, model, names) in jobs.items()
        }
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, as_completed

    _SHARED.update(
        stances=stances,
        jobs=jobs,
        plan=plan,
        parent=parent,
        weights=weights,
        options=options,
        screen=screen,
    )
    out: dict = {}
    try:
        with ProcessPoolExecutor(workers, mp_context=mp.get_context("fork")) as pool:
            order = sorted(jobs, key=lambda n: -(hint or {}).get(n, 0.0))
            futures = {pool.submit(_task, n): n for n in order}
            for fut in as_completed(futures):
                ev = fut.result()
                out[futures[fut]] = ev
                say(f"  {ev.label}: {describe(ev)} ({ev.seconds:.1f} s)")
    finally:
        _SHARED.clear()
    return {n: out[n] for n in jobs}


def default_workers() -> int:
    """Processes for the candidates of a round: the CPU cores this process may use, at most
    :data:`MAX_WORKERS` (each worker holds its own compiled functions and fits)."""
    import os

    n = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return max(1, min(MAX_WORKERS, n or 1))


MAX_WORKERS = 4


def diagnose_stances(
    stances: list[StanceData],
    base: str | tuple = "registered",
    candidates: Sequence[str] | None = None,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    threshold_pct: float = MIN_REDUCTION_PCT,
    max_effects: int | None = None,
    n_boot: int = 2000,
    seed: int = 0,
    progress: Callable[[str], None] | None = None,
    workers: int | None = None,
) -> Diagnosis:
    """The diagnosis of ``stances`` (one subject; see the module doc). ``max_effects``: stop the
    forward selection after that many effects (``0``: rank only; ``1``: rank and add the best
    passing effect, as the withheld-effect benchmark does). ``workers``: processes that evaluate
    a round's candidates in parallel (default :func:`default_workers`; 1: in this process)."""
    say = progress or (lambda s: None)
    workers = default_workers() if workers is None else int(workers)
    t0 = time.perf_counter()
    base_label, base_model_ = resolve_base(base)
    names = candidate_names(base_model_, candidates)
    plan = fold_plan(stances)
    rate = 1.0 / float(np.median(np.diff(stances[0].time)))
    notes = []
    if not plan:
        notes.append(
            "No stance could be held out (every foot has a single stance): effects are scored "
            "in-sample with a BIC penalty; give more stances or trials of the subject for a "
            "held-out diagnosis."
        )
    folds = {
        "kind": "leave-one-stance-out" if plan else "in-sample (BIC penalty)",
        "n": len(plan),
        "heldout": [stances[i].label for i in plan],
        "stances": [st.label for st in stances],
    }
    say(f"fitting the base ({base_label}) on {len(stances)} stances, {len(plan)} folds")
    kw = {"weights": weights, "options": options, "progress": say}
    current = evaluate(stances, base_model_, "base", (), plan, **kw)
    evaluations = {"base": current}
    waterfall = [_step("base", current)]
    selected: list[str] = []
    remaining = list(names)
    rounds: list[list[dict]] = []
    hint: dict = {}
    limit = len(names) if max_effects is None else max_effects
    while remaining:
        say(f"round {len(rounds) + 1}: {len(remaining)} candidate(s) on top of {current.label}")
        jobs = {
            n: (
                "+".join(["base", *selected, n]),
                model_from_names([*selected, n], base=base_model_),
                (*selected, n),
            )
            for n in remaining
        }
        # round 1 ranks every candidate on held-out stances (the ranking the user reads); later
        # rounds only decide the selection, so a candidate whose in-sample reduction is below
        # the threshold (it cannot pass) is not held out there (``screened``)
        screen = threshold_pct if rounds and plan else None
        evs = _evaluate_all(
            stances, jobs, plan, current, weights, options, workers, say, screen, hint
        )
        hint = {n: ev.seconds for n, ev in evs.items()}
        evaluations.update({ev.label: ev for ev in evs.values()})
        rows = _rank(current, evs, threshold_pct, n_boot, seed, rate)
        rounds.append(rows)
        best = next((r for r in rows if r["passes"]), None)  # rows are sorted, best first
        if best is None or len(selected) >= limit:
            break
        selected.append(best["effect"])
        remaining.remove(best["effect"])
        current = evs[best["effect"]]
        waterfall.append(_step(f"+{best['effect']}", current))
        waterfall[-1]["label"] = current.label
        if len(selected) >= limit:
            break
    ranking = [dict(r) for r in rounds[0]] if rounds else []
    # non-additivity: a passing effect that stops passing once another is in the model
    for k in range(1, len(rounds)):
        added = selected[k - 1]
        later = {r["effect"]: r for r in rounds[k]}
        for r in ranking:
            e = r["effect"]
            if e in later and r["passes"] and e != added:
                g0, g1 = r["heldout_rms_reduction_pct"], later[e]["heldout_rms_reduction_pct"]
                # screened (g1 None): its in-sample gain fell below the threshold: it stopped
                # passing once the other effect was in the model
                if g1 is None or g1 < NON_ADDITIVE_FRACTION * g0:
                    for a, b in ((r, added), (next(x for x in ranking if x["effect"] == added), e)):
                        if b not in a["confounded_with"]:
                            a["confounded_with"].append(b)
    final = current
    wh = {
        "base": where(evaluations["base"].heldout_fits or evaluations["base"].full.stance_fits),
        "final": where(final.heldout_fits or final.full.stance_fits),
    }
    return Diagnosis(
        base=base_label,
        base_components=[c.name for c in base_model_],
        candidates=names,
        ranking=ranking,
        rounds=rounds,
        selected=selected,
        waterfall=waterfall,
        where=wh,
        folds=folds,
        seconds=time.perf_counter() - t0,
        threshold_pct=threshold_pct,
        evaluations=evaluations,
        notes=notes,
        max_effects=max_effects,
    )


def diagnose(
    trials: list,
    base: str | tuple = "registered",
    candidates: Sequence[str] | None = None,
    progress: Callable[[str], None] | None = None,
    **kw,
) -> Diagnosis:
    """Diagnose the gap between ``base`` and the force plates on ``trials`` (``[(Trial,
    TrialKinematics), ...]`` of one subject: they share contact parameters; pose corrections are
    per stance). Keyword arguments go to :func:`diagnose_stances`."""
    from gc_ocp.estimation.fit import fit_data

    _, data, notes = fit_data(trials, progress=progress)
    d = diagnose_stances(data, base, candidates, progress=progress, **kw)
    d.notes = [*notes, *d.notes]
    return d


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
    step has no reductions)."""
    say = progress or (lambda s: None)
    _, base_model_ = resolve_base(base)
    unknown = [n for n in selected if n not in REGISTRY]
    if unknown:
        raise ModelError(f"Unknown effect(s) {unknown}; choose from {list(EFFECTS)}")
    if not test:
        raise ModelError(
            "No stance to confirm on: give stances or trials the diagnosis did not use"
        )
    rate = 1.0 / float(np.median(np.diff(test[0].time)))
    kw = {"weights": weights, "options": options, "progress": say}
    say(f"confirming on {len(test)} new stance(s), trained on {len(train)}")
    first = parent = evaluate_on(train, test, base_model_, "base", **kw)
    steps = [_public(_step("base", first))]
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
                **_public(_step(f"+{names[-1]}", ev)),
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
    from gc_ocp.estimation.fit import fit_data

    _, train, _ = fit_data(trials, progress=progress)
    _, test, _ = fit_data(new_trials, progress=progress)
    clash = {st.label for st in train} & {st.label for st in test}
    if clash:
        raise ModelError(
            f"Stances {sorted(clash)} are in both the diagnosed and the new trials: confirm on "
            "trials the diagnosis did not use"
        )
    return confirm_stances(train, test, selected, base, progress=progress, **kw)


__all__ = [
    "BASES",
    "CONFOUND_COSINE",
    "Diagnosis",
    "MIN_REDUCTION_PCT",
    "candidate_names",
    "confirm",
    "confirm_stances",
    "diagnose",
    "diagnose_stances",
    "resolve_base",
]
