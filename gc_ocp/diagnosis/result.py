"""What a diagnosis returns: the :class:`Diagnosis` and its rows, its JSON, summary and figures.

Plain data, typed: a ranking row is a :class:`RankRow`, a waterfall step a :class:`WaterfallStep`
(frozen dataclasses whose fields are the keys of ``diagnosis.json``, in its order; schema in
``docs/diagnosis.md``); readers use their attributes. The evaluations behind a diagnosis (the
fits, :class:`~gc_ocp.diagnosis.compare.Evaluation`) ride along in ``Diagnosis.evaluations`` and
are not written to JSON. How the rows are computed is :mod:`.selection`; the HTML page,
:mod:`.report`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from gc_ocp.contact.channels import TABLE_KEYS, channel_name
from gc_ocp.diagnosis.compare import Evaluation, heldout_quality, score, superior_rms
from gc_ocp.diagnosis.null import (
    MISMATCH_DRAWS,
    RESOLUTION_PCT,
    NullTest,
    fewest_draws,
    practical,
)
from gc_ocp.diagnosis.where import heatmap_figure, residual_figure
from gc_ocp.errors import InputError, names_of, read_document
from gc_ocp.text import check_document, float_fields, nan_for_null, read_json_file

SCORE_TEXT = (
    "held-out combined score: sqrt(2 E / n), E = data cost + nuisance prior cost + "
    "1/2 log det of the nuisance Hessian (all six channels, in units of the error "
    "scale); reduction = 1 - S_model / S_parent"
)
"""What ``diagnosis.json`` says its ``score`` is."""

OFF_SCALE = 2.0
"""The ranking figure's axis reaches this many times the largest gain below 0; a candidate's
loss beyond it is written at the edge (:meth:`Diagnosis.ranking_figure`)."""

MIN_REDUCTION_PCT = 0.5
"""Effect-size floor [%] of the held-out and in-sample reductions a named effect also needs
(the rule, :mod:`gc_ocp.diagnosis.selection`; here for the verdicts' words): the smallest of 0,
0.5, 1, ... % that rejects at least 95 % of the "none" cases (mismatch and prior-biased) of one
benchmark motion, the same chosen on either motion and scored on the other
(``benchmarks/rule_variants.py``). The gains it rejects there are 0.14-0.18 %; the 2 % it
replaces left moderate damping (+1.0 % held out, p = 0.01) unnamed."""

SESSION_STEPS = 1000
"""A verdict names the further steps that would decide up to this many; beyond it, it says
"more than" this many. About 500 per foot: eight minutes of treadmill walking, more than any
overground session; and near the bound that mismatch sets, the number grows as fast as the
inverse square of a small margin, so a figure of 10^4-10^5 (seen on real trials) is precise only
in its order. ``diagnosis.json`` keeps the number itself (``calibrated.more_stances``)."""


NOT_TESTED_WHY = (
    "no candidate of the round clears the rule's effect-size floor, nor would with more stances "
    "(more stances estimate a gain better, they do not raise it), so no draw of the null could "
    "name one: none was made and its candidates are not tested"
)
"""Why a later round of the diagnosis makes no null (``diagnose._not_tested``): its summary
line."""


def _about(n: int, exact: bool = False) -> str:
    """``n`` further steps in a verdict's words (:data:`SESSION_STEPS`; ``exact``: the number
    however large, for an *inconclusive* row, whose number is within a practical follow-up of
    its own data by definition, :data:`~gc_ocp.diagnosis.null.PRACTICAL_FACTOR`)."""
    if exact or n <= SESSION_STEPS:
        return f"about {n} more step{'' if n == 1 else 's'}"
    return f"more than {SESSION_STEPS} more steps (beyond one session)"


@dataclasses.dataclass(frozen=True)
class RankRow:
    """One candidate effect in a round: its reductions over the round's parent model and what
    the decision rule made of them (:mod:`.selection`).

    Reductions in [%] of the combined score (held out; ``None`` when ``screened``: fitted on all
    stances only, the calibrated test not naming it in a later round), with the 95 % interval
    ``(lo, hi)``; ``per_stance_reduction_pct``: ``{stance label: %}``; ``n_params``: scalars the
    effect estimates; ``gain_from_nuisance``: the share of its held-out gain that comes from a
    cheaper nuisance (``None`` unless the gain counts); ``confounded_with``: the candidates (or
    parts of the base) the data cannot tell it from; ``flags``: codes of its fit's flags."""

    effect: str
    heldout_rms_reduction_pct: float | None
    heldout_rms_reduction_ci: tuple[float | None, float | None]
    heldout_superior_force_reduction_pct: float | None
    insample_rms_reduction_pct: float
    per_stance_reduction_pct: Mapping[str, float]
    n_params: int
    passes: bool
    screened: bool
    inconclusive: bool
    gain_from_nuisance: float | None
    confounded_with: tuple[str, ...]
    flags: tuple[str, ...]
    not_evaluable: str | None = None
    """Why the candidate could not be evaluated on these data (its fit raised an input or model
    error, e.g. a clock offset on a recording that starts inside a stance's margin), or None.
    Such a row has no figures, never passes, comes last; written to JSON only when set."""
    calibrated: NullTest | None = None
    """The calibrated test of the candidate (:mod:`.null`): its one-step reduction, the null's
    mean and spread, the family-wise adjusted p-value and the further stances that would decide
    it (None: not tested, e.g. not evaluable)."""
    floor_stances: int | None = 0
    """Further held-out stances after which the refit's held-out reduction would clear the
    rule's effect-size floor at its observed size (the lower end of its interval above 0, the
    interval narrowing as 1/sqrt(n); :func:`~gc_ocp.diagnosis.selection.floor_stances`): 0 when
    it does, or when not measured (a screened row; a ``diagnosis.json`` written before it was);
    None when no number would (its held-out or in-sample reduction is under the floor: more
    stances estimate a gain better, they do not raise it). Written to JSON only when not 0."""

    @property
    def more_stances(self) -> int | None:
        """Further held-out stances that would decide the *rule* at the observed gains: the
        calibrated test's number (``calibrated.more_stances``) and the effect-size floor's
        (:attr:`floor_stances`), the larger of the two; 0 for a row that passes; None when
        either says no number would, or the row was not tested."""
        if self.passes:
            return 0
        if self.calibrated is None:
            return None
        return self.rule_stances(self.calibrated.more_stances, self.floor_stances)

    @staticmethod
    def rule_stances(test: int | None, floor: int | None) -> int | None:
        """The rule's further held-out stances from its two parts' (the test's and the
        effect-size floor's): the larger, None when either is None."""
        return None if test is None or floor is None else max(test, floor)

    def confounded(self, *others: str) -> RankRow:
        """This row also naming ``others`` confounded with it (each once, in the given order)."""
        names = list(self.confounded_with)
        names += [o for o in dict.fromkeys(others) if o not in names]
        return dataclasses.replace(self, confounded_with=tuple(names))

    def to_json(self) -> dict:
        """The row as ``diagnosis.json`` has it (tuples as lists)."""
        fields = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        if self.not_evaluable is None:
            del fields["not_evaluable"]
        if self.floor_stances == 0:  # the default, read back when absent (older files too)
            del fields["floor_stances"]
        return {
            **fields,  # in the order of the fields, the values below replaced in place
            "heldout_rms_reduction_ci": list(self.heldout_rms_reduction_ci),
            "per_stance_reduction_pct": dict(self.per_stance_reduction_pct),
            "confounded_with": list(self.confounded_with),
            "flags": list(self.flags),
            "calibrated": None if self.calibrated is None else self.calibrated.to_json(),
        }

    @classmethod
    def from_json(cls, d: Mapping) -> RankRow:
        calibrated = d.get("calibrated")
        return cls(
            **{
                **float_fields(cls, d),
                "heldout_rms_reduction_ci": tuple(d["heldout_rms_reduction_ci"]),
                "per_stance_reduction_pct": nan_for_null(dict(d["per_stance_reduction_pct"])),
                "confounded_with": tuple(d["confounded_with"]),
                "flags": tuple(d["flags"]),
                "calibrated": None
                if calibrated is None
                else NullTest(**float_fields(NullTest, calibrated)),
            }
        )

    def verdict(self, draws: int | None = None) -> str:
        """What the calibrated test says, in words: ``"named (p = 0.004)"``, ``"inconclusive;
        about 14 more steps would decide"``, ``"not decidable by more steps: within what model
        mismatch gives"``, ``"no gain"`` (with the refit's gain when only the refit has one).

        draws: the mismatch draws per round the steps assume, said beside them; given by a
        diagnosis that ran with fewer (:attr:`Diagnosis.draws_too_few`): its null could name
        nothing, and its steps are those of a run with the default draws (:func:`~gc_ocp.
        diagnosis.null.decide`), which more steps alone would not give."""
        c = self.calibrated
        # every number of steps is said with this verb, and so with the draws it assumes
        decide = "would decide" + (
            "" if draws is None else f" with {draws} mismatch draws per round"
        )
        if self.not_evaluable is not None:
            return "not evaluable"
        # the floor stops a row (floor_stances None) when its held-out or its in-sample gain is
        # under it: the smaller of the two is then under it, and the verdict names that one
        held, ins = self.heldout_rms_reduction_pct, self.insample_rms_reduction_pct
        # (a screened row has only its in-sample gain)
        which = "in-sample" if held is None or ins < held else "held-out"
        gains = [g for g in (held, ins) if g is not None]
        under = (
            f"its {which} gain is under the rule's effect-size floor, which more steps do not raise"
            if min(gains, default=0.0) < MIN_REDUCTION_PCT
            # both over the floor, and no number of stances likely (80 %) to put the held-out
            # interval's lower end above 0 (selection.floor_stances): the gain is that uncertain
            else "its held-out gain is too uncertain to say how many more steps would clear the "
            "rule's effect-size floor"
        )
        if c is None:
            # a later round whose every candidate the floor stops makes no null (diagnose)
            return f"not tested; {under}" if self.floor_stances is None else "not tested"
        if c.inert:
            return (
                "no gain: these stances do not move it (its reductions, observed and null, are "
                f"under {RESOLUTION_PCT:g} %); not tested"
            )
        p = f"p = {c.p_adjusted:.3g}"
        if self.passes:
            return f"named ({p})"
        more = self.more_stances
        if c.more_stances == 0:
            # named by the test, stopped by the floor: "inconclusive" only when the row is (a
            # held-out loss is not, :func:`~gc_ocp.diagnosis.selection.rank`), so that the
            # verdict and the row's ``inconclusive`` (the summary's, the JSON's) agree
            head = (
                "inconclusive: named by the test"
                if self.inconclusive
                else "not named: the test names it"
            )
            if more:
                # said as it is only when a practical follow-up: a row the test names is
                # inconclusive whatever the floor's number (selection.rank)
                exact = self.inconclusive and practical(more, c.n_heldout)
                return (
                    f"{head} ({p}), but its held-out interval still "
                    f"reaches 0; {_about(more, exact)} {decide}"
                )
            if self.floor_stances is None:
                return f"{head} ({p}), but {under}"
            # floor_stances 0 on a row that does not pass: in sample (no number counted), or
            # written before the floor's number
            return f"{head} ({p}), below the rule's effect-size floor"
        if self.inconclusive:
            if more is None and c.more_stances:
                return (
                    f"inconclusive ({p}); {_about(c.more_stances, True)} {decide} the "
                    f"test, but {under}"
                )
            if more is None:  # a row read back without its number
                return f"inconclusive ({p})"
            return f"inconclusive ({p}); {_about(more, True)} {decide}"
        if c.more_stances:
            if more is None:
                return (
                    f"not named ({p}); {_about(c.more_stances)} {decide} the test "
                    f"at this gain, but {under}"
                )
            return f"not named ({p}); {_about(more)} {decide} at this gain"
        if c.n_heldout == 0 and c.observed_pct > 0:
            # the in-sample fallback: no held-out stance to count from (null.more_stances)
            return (
                f"not named ({p}); scored in-sample (no stance held out): no number of further "
                "steps is predicted, a second stance on a foot makes the diagnosis a held-out one"
            )
        if c.observed_pct > 0 and (c.within_mismatch or c.observed_pct <= c.null_mean_pct):
            return (
                f"not named ({p}); its gain is within what noise and model mismatch give: "
                "more steps would not decide"
            )
        if c.observed_pct > 0:  # over that bound, but not by enough for its own uncertainty
            held_out = f"{c.n_heldout} held-out stance" + ("s" if c.n_heldout != 1 else "")
            return (
                f"not named ({p}); its gain is too uncertain on {held_out} to say how many more "
                "steps would decide (it may be within what model mismatch gives)"
            )
        refit = self.heldout_rms_reduction_pct
        if refit is not None and refit > 0:
            # the refit gains but one step from the parent's solution does not: a gain reached
            # only by moving the other parameters far (docs/diagnosis.md, "Like for like")
            return (
                f"not named ({p}): no gain one step from the parent's solution (the test's "
                f"statistic, {c.observed_pct:+.1f} %), although the refit gains {refit:+.1f} %"
            )
        return f"no gain ({p})"

    def line(self, draws: int | None = None) -> str:
        """The row in a line: ``effect +x.x % [lo, hi]`` (or its in-sample screen); ``draws``
        as in :meth:`verdict`."""
        if self.not_evaluable is not None:
            return f"{self.effect} not evaluable"
        if self.heldout_rms_reduction_pct is None:
            return (
                f"{self.effect} in-sample {self.insample_rms_reduction_pct:+.1f} % (not held out;"
                f" {self.verdict(draws)})"
            )
        lo, hi = self.heldout_rms_reduction_ci
        mark = " PASS" if self.passes else ""
        return (
            f"{self.effect} {self.heldout_rms_reduction_pct:+.1f} % [{lo:+.1f}, {hi:+.1f}]{mark}"
            f" ({self.verdict(draws)})"
        )


@dataclasses.dataclass(frozen=True)
class WaterfallStep:
    """The model after a step of the forward selection (``"base"``, ``"+effect"``): its held-out
    superior-force RMS [% BW] (both feet pooled), ``{side: {channel key: RMS}}`` and combined
    score. ``label``: the label of its evaluation (``"base+a+b"``; not written to JSON)."""

    model: str
    heldout_superior_force_pct_bw: float
    heldout_rms: Mapping[str, Mapping[str, float]]
    score: float
    label: str

    @classmethod
    def of(cls, model: str, ev: Evaluation) -> WaterfallStep:
        """The step ``model`` whose evaluation is ``ev``."""
        return cls(model, superior_rms(ev), heldout_quality(ev), score(ev), ev.label)

    def to_json(self) -> dict:
        return {
            "model": self.model,
            "heldout_superior_force_pct_bw": self.heldout_superior_force_pct_bw,
            "heldout_rms": self.heldout_rms,
            "score": self.score,
        }


DIAGNOSIS_FORMAT = 1
"""The layout of ``diagnosis.json`` this version writes (its ``"format"``; a file without one was
written before the field, read as this layout when it has the keys). Raise it with a change
of the layout that a reader of the former one would misread; :meth:`Diagnosis.from_json`
refuses a later one (:func:`gc_ocp.text.check_document`)."""

DIAGNOSIS_FIX = "run gc-ocp diagnose again with this version"

FORMER_FLOOR_PCT = 2.0
"""The effect-size floor [%] of the versions whose ``diagnosis.json`` has no ``floor_pct``."""


def _which(which: str) -> str:
    """``which`` model a figure shows: ``"base"`` or ``"final"``, else :class:`InputError`."""
    if which not in ("base", "final"):
        raise InputError(f'which={which!r}: the figure is of the "base" or the "final" model')
    return which


@dataclasses.dataclass
class Diagnosis:
    """The result of :func:`~gc_ocp.diagnosis.diagnose`: plain data plus the evaluations behind it.

    ranking: every candidate against the base (round 1), best first; rounds: the ranking of every
    forward-selection round; selected: effects added, in order; waterfall: held-out RMS after each
    step; where: the residual map of the base (held-out stances) and of the final model;
    alpha, floor_pct: the rule's family-wise rate and effect-size floor [%] as this diagnosis
    applied them; mismatch_family: the family the null drew from as plain data
    (:meth:`~gc_ocp.diagnosis.mismatch.MismatchFamily.to_json`; None, and absent from the
    JSON: no mismatch draws (a noise-only null: no family, ``mismatch_draws=0`` or a family at
    scale 0), or a diagnosis.json written before it was recorded, 2026-12-01); evaluations:
    ``{label: Evaluation}`` (fits; not written to JSON)."""

    base: str
    base_components: list[str]
    candidates: list[str]
    ranking: list[RankRow]
    rounds: list[list[RankRow]]
    selected: list[str]
    waterfall: list[WaterfallStep]
    where: dict
    folds: dict
    seconds: float
    alpha: float
    calibration: list = dataclasses.field(default_factory=list)
    measurement: dict = dataclasses.field(default_factory=dict)
    evaluations: dict = dataclasses.field(default_factory=dict, repr=False)
    notes: list[str] = dataclasses.field(default_factory=list)
    max_effects: int | None = None
    floor_pct: float = FORMER_FLOOR_PCT
    mismatch_family: dict | None = None

    @property
    def inconclusive(self) -> list[str]:
        """Candidates of the last round that fail the rule yet a follow-up of a few times their
        data would decide (their rows say about how many), or that the test names below the
        effect-size floor (:func:`~gc_ocp.diagnosis.selection.rank`). When nothing is
        selected, "none" is then a weak answer, and the result says so."""
        return [r.effect for r in (self.rounds[-1] if self.rounds else []) if r.inconclusive]

    @property
    def inconclusive_before(self) -> str | None:
        """The effect the last round selected when the selection stopped there (``max_effects``
        reached, or no candidate left): its rows, and so :attr:`inconclusive` and their steps,
        were measured on the model before that effect was added, not on the final one (no
        round ran on top of it). None when the last round selected nothing (the usual end)."""
        if self.selected and len(self.rounds) == len(self.selected):
            return self.selected[-1]
        return None

    def _evaluation(self, label: str) -> Evaluation:
        if label not in self.evaluations:
            raise InputError(
                f"this diagnosis has no fits ({label!r}'s evaluation): diagnosis.json does not "
                "keep them (Diagnosis.from_json); use the Diagnosis diagnose() returned, or "
                "rerun gc-ocp diagnose"
            )
        return self.evaluations[label]

    @property
    def base_evaluation(self) -> Evaluation:
        return self._evaluation("base")

    @property
    def final_evaluation(self) -> Evaluation:
        return self._evaluation(self.waterfall[-1].label)

    def to_json(self) -> dict:
        """``diagnosis.json`` (schema in ``docs/diagnosis.md``)."""
        b = self.waterfall[0]  # the base's step: its held-out numbers
        return {
            "format": DIAGNOSIS_FORMAT,
            "base": {
                "name": self.base,
                "model": self.base_components,
                "heldout_rms": b.heldout_rms,
                "heldout_superior_force_pct_bw": b.heldout_superior_force_pct_bw,
                "score": b.score,
            },
            "candidates": self.candidates,
            "ranking": [r.to_json() for r in self.ranking],
            "rounds": [[r.to_json() for r in rows] for rows in self.rounds],
            "selected": self.selected,
            "inconclusive": self.inconclusive,
            "waterfall": [w.to_json() for w in self.waterfall],
            "where": self.where,
            "folds": self.folds,
            "alpha": self.alpha,
            "floor_pct": self.floor_pct,
            "calibration": self.calibration,
            "measurement": self.measurement,
            "max_effects": self.max_effects,
            # absent when None (noise only), as in the files written before it was recorded
            **({} if self.mismatch_family is None else {"mismatch_family": self.mismatch_family}),
            "score": SCORE_TEXT,
            "notes": self.notes,
            "seconds": self.seconds,
        }

    @classmethod
    def from_json(cls, d: Mapping) -> Diagnosis:
        """The diagnosis written by :meth:`to_json` (``diagnosis.json``), without its
        evaluations (the fits): enough for its summary, JSON, report page (given the final
        fit) and the figures that need no fit (ranking, waterfall, heat maps). A
        ``diagnosis.json`` of the former threshold rule (before the calibrated test: no
        ``alpha``) is refused with what to do; so is a document that is not a diagnosis.json
        (an :class:`~gc_ocp.errors.InputError` naming what is wrong). ``d`` may also be the
        file's path."""
        where = "the diagnosis"
        if isinstance(d, str | Path):
            where = str(d)
            d = read_json_file(
                d,
                "Diagnosis file",
                "a diagnosis.json",
                "give the diagnosis.json gc-ocp diagnose wrote.",
            )
        if not isinstance(d, Mapping) or "ranking" not in d or "waterfall" not in d:
            raise InputError(
                f"not a diagnosis.json (a {type(d).__name__}"
                + (f" with keys {sorted(d)[:6]}" if isinstance(d, Mapping) else "")
                + "); give the file gc-ocp diagnose wrote."
            )
        check_document(d, where, "diagnosis.json", DIAGNOSIS_FORMAT, ("ranking",), DIAGNOSIS_FIX)
        return read_document(
            lambda: cls._from_document(d),
            "the diagnosis.json is incomplete or edited",
            "give the file gc-ocp diagnose wrote, unedited.",
        )

    @classmethod
    def _from_document(cls, d: Mapping) -> Diagnosis:
        """:meth:`from_json` of a diagnosis document (what it reads, unchecked)."""
        if "alpha" not in d:
            raise InputError(
                "This diagnosis.json was written by an earlier gc_ocp, whose decision rule was a "
                "2 % threshold (it has 'threshold_pct', no 'alpha'); its verdicts cannot be shown "
                "as the calibrated test's. Run `gc-ocp diagnose` again on the trials."
            )
        selected = names_of(d["selected"], "selected")
        waterfall = [
            WaterfallStep(
                **{**float_fields(WaterfallStep, w), "heldout_rms": nan_for_null(w["heldout_rms"])},
                label="+".join(["base", *selected[:k]]),
            )
            for k, w in enumerate(d["waterfall"])
        ]
        return cls(
            base=d["base"]["name"],
            base_components=list(d["base"]["model"]),
            candidates=list(d["candidates"]),
            ranking=[RankRow.from_json(r) for r in d["ranking"]],
            rounds=[[RankRow.from_json(r) for r in rows] for rows in d["rounds"]],
            selected=selected,
            waterfall=waterfall,
            where=d["where"],
            folds=d["folds"],
            seconds=d["seconds"],
            alpha=d["alpha"],
            calibration=list(d.get("calibration", [])),
            measurement=dict(d.get("measurement", {})),
            notes=list(d["notes"]),
            max_effects=d["max_effects"],
            floor_pct=d.get("floor_pct", FORMER_FLOOR_PCT),
            mismatch_family=d.get("mismatch_family"),
        )

    @property
    def passing_unselected(self) -> list[str]:
        """The effects that pass the rule although nothing is selected: the selection was
        stopped before them (``max_effects=0``: rank only); empty when something is selected."""
        if self.selected or not self.rounds:
            return []
        return [r.effect for r in self.rounds[-1] if r.passes]

    @property
    def draws_too_few(self) -> int | None:
        """The fewest mismatch draws per round that can name an effect at ``alpha``
        (:func:`~gc_ocp.diagnosis.null.fewest_draws`) when round 1's null was given fewer (and
        some): its p-value counts draws, so nothing could be named whatever the data; None
        otherwise. The summary and the page say so first: the "none" of a small run (e.g.
        ``mismatch_draws=8``) read as the data's answer, its reason last among the notes."""
        planned = self.calibration[0].get("mismatch_draws_planned", 0) if self.calibration else 0
        need = fewest_draws(self.alpha)
        return need if 0 < planned < need else None

    @property
    def steps_draws(self) -> int | None:
        """The mismatch draws the verdicts' steps assume, to be said beside them
        (:meth:`RankRow.verdict`): the default when this run had too few to name anything
        (:attr:`draws_too_few`; a small run's "about 28 more steps would decide" read as if more
        steps alone would); None otherwise."""
        return MISMATCH_DRAWS if self.draws_too_few is not None else None

    def _none_why(self) -> str:
        """Why nothing is selected, in the summary's words: no effect passes, or some do but the
        selection was stopped before it (``max_effects=0``: rank only), or none could pass
        (:attr:`draws_too_few`)."""
        passing = self.passing_unselected
        need = self.draws_too_few
        if not passing and need is not None:
            planned = self.calibration[0]["mismatch_draws_planned"]
            return (
                f"none (none could be: {planned} mismatch draws per round cannot give a p-value "
                f"under alpha {self.alpha:g}; give at least {need}, the default "
                f"{MISMATCH_DRAWS}: mismatch_draws=, gc-ocp diagnose --null-draws)"
            )
        if not passing:
            return "none (no effect passes)"
        return (
            f"none (max_effects={self.max_effects}: ranked only, not selected; "
            f"{', '.join(passing)} pass{'es' if len(passing) == 1 else ''} the rule)"
        )

    @property
    def scored(self) -> str:
        """ "held-out", or "in-sample" when no stance could be held out (the JSON keys keep
        their names; ``folds.kind`` says which)."""
        return "held-out" if self.folds["n"] else "in-sample"

    def summary(self) -> str:
        f = self.folds
        draws = self.steps_draws
        lines = [
            f"Diagnosis on base '{self.base}' ({', '.join(self.base_components)}); "
            f"{f['kind']}, {f['n']} held-out stance(s); {self.seconds:.0f} s",
            f"base {self.scored} superior-force RMS "
            f"{self.waterfall[0].heldout_superior_force_pct_bw:.2f} % BW",
            f"ranking ({self.scored} reduction of the combined score, 95 % interval; in-sample):",
        ]
        for r in self.ranking:
            if r.not_evaluable is not None:
                lines.append(f"       {r.effect:<20} not evaluable on these data (see the notes)")
                continue
            mark = "PASS" if r.passes else "    "
            conf = f"  confounded with {', '.join(r.confounded_with)}" if r.confounded_with else ""
            lo, hi = r.heldout_rms_reduction_ci
            lines.append(
                f"  {mark} {r.effect:<20} {r.heldout_rms_reduction_pct:+6.1f} % [{lo:+.1f}, {hi:+.1f}]"
                f"  in-sample {r.insample_rms_reduction_pct:+6.1f} %  ({r.n_params} params)"
                f"  {r.verdict(draws)}{conf}"
            )
        for k, rows in enumerate(self.rounds[1:], 2):
            lines.append(
                f"round {k} (on top of {' + '.join(['base', *self.selected[: k - 1]])}): "
                + "; ".join(r.line(draws) for r in rows)
            )
        lines.append("selected: " + (", ".join(self.selected) or self._none_why()))
        last = {r.effect: r for r in (self.rounds[-1] if self.rounds else [])}
        for e in self.inconclusive:
            lines.append(f"{e}: {last[e].verdict(draws)}")
        if self.inconclusive and self.inconclusive_before:
            lines.append(
                f"(measured before {self.inconclusive_before} was added: the selection stopped "
                "there, no round ran on top of it)"
            )
        if any(c.get("null_fits") == "refit" for c in self.calibration):
            lines.append(
                "the calibrated null refitted every fold of every model on each replicate "
                "(null_fits='refit'): the test weighs the held-out reductions shown"
            )
        for k, c in enumerate(self.calibration, 1):
            if c.get("not_tested"):
                lines.append(f"round {k} made no null draws: {NOT_TESTED_WHY}")
            if c.get("null_stopped_early"):
                lines.append(
                    f"round {k}'s null stopped after {c['mismatch_draws']} of "
                    f"{c.get('mismatch_draws_planned', '?')} mismatch draws (no candidate the "
                    "effect-size floor leaves could be named): its p-values are from those"
                )
            if c.get("mismatch_draws_left_out"):
                lines.append(
                    f"round {k}'s null left out {c['mismatch_draws_left_out']} mismatch draw(s) "
                    "whose refit did not converge: the draws that move the parent furthest may "
                    "be among them, so its p-values may be a little low"
                )
        lines.append(f"waterfall ({self.scored} superior-force RMS, % BW):")
        for w in self.waterfall:
            lines.append(f"  {w.model:<28} {w.heldout_superior_force_pct_bw:.2f}")
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)

    # --- figures ---------------------------------------------------------------------------
    def heatmap(self, which: str = "base"):
        """Heat map of where the residual lies (``which``: ``"base"`` or ``"final"``)."""
        _which(which)
        return heatmap_figure(self.where[which], title=f"Where the residual lies ({which} model)")

    def residual_figure(self, which: str = "base", **kw):
        """Residual over time of the held-out stances, phases shaded (needs the evaluations;
        ``which``: ``"base"`` or ``"final"``)."""
        ev = self.base_evaluation if _which(which) == "base" else self.final_evaluation
        return residual_figure(ev.scored_fits, **{"weights": ev.weights, **kw})

    def ranking_figure(self):
        """Held-out reduction per candidate with its 95 % interval (named ones in green)."""
        from matplotlib.figure import Figure

        r = [e for e in self.ranking if e.not_evaluable is None]
        fig = Figure(figsize=(7.0, 0.35 * len(r) + 1.4), layout="constrained")
        ax = fig.subplots()
        y = np.arange(len(r))[::-1]
        v = np.array([e.heldout_rms_reduction_pct for e in r])
        ci = np.array([e.heldout_rms_reduction_ci for e in r]).reshape(-1, 2)
        colors = ["tab:green" if e.passes else "tab:gray" for e in r]
        ax.barh(y, v, color=colors)
        ax.errorbar(v, y, xerr=[v - ci[:, 0], ci[:, 1] - v], fmt="none", ecolor="k", capsize=3)
        ax.axvline(0.0, color="k", lw=0.6)
        # a loss far beyond the largest gain (a candidate that misfits, -160 % beside gains of
        # +5 %) would squash every gain to a sliver: the axis stops at OFF_SCALE times the
        # largest gain, and a row beyond it says its value at the edge
        # (nan-aware: a row without an interval; no gain at all: nothing to keep readable)
        top = max(np.nanmax(ci[:, 1], initial=-np.inf), np.nanmax(v, initial=-np.inf))
        if top > 0.0:
            edge = -OFF_SCALE * max(float(top), 1.0)
            if min(np.nanmin(ci[:, 0], initial=np.inf), np.nanmin(v, initial=np.inf)) < edge:
                ax.set_xlim(edge, 1.05 * max(float(top), 1.0))
                for yi, vi, (lo, hi) in zip(y, v, ci, strict=True):
                    if min(vi, lo) < edge:
                        ax.text(
                            edge,
                            yi,
                            f" \u25c0 {vi:+.3g} % [{lo:+.3g}, {hi:+.3g}]",
                            va="center",
                            fontsize=8,
                            bbox={"facecolor": "white", "edgecolor": "none", "pad": 1.0},
                        )
        ax.set_yticks(y, [e.effect + (" *" if e.confounded_with else "") for e in r])
        ax.set_xlabel("held-out reduction of the combined score [%]  (green: named; * confounded)")
        return fig

    def waterfall_figure(self):
        """Held-out RMS per channel after each added effect."""
        from matplotlib.figure import Figure

        fig = Figure(figsize=(7.0, 3.6), layout="constrained")
        ax = fig.subplots()
        labels = [w.model for w in self.waterfall]
        x = np.arange(len(labels))
        ax.plot(
            x,
            [w.heldout_superior_force_pct_bw for w in self.waterfall],
            "o-",
            lw=2.2,
            color="k",
            label="superior force (all held-out stances)",
        )
        for ch in TABLE_KEYS.values():
            if ch == "superior_force_pct_bw":
                continue
            vals = [
                np.nanmean([w.heldout_rms[s][ch] for s in w.heldout_rms]) for w in self.waterfall
            ]
            ax.plot(x, vals, ".--", lw=1, label=channel_name(ch))
        ax.set_xticks(x, labels, rotation=15)
        ax.set_ylabel("held-out RMS [% BW, % BW×H]")
        ax.set_ylim(bottom=0)
        # beside the axes, not over them: with one step (nothing named) every point is in one
        # column, and a legend inside covered the superior force's point
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
        ax.set_title("How far the gap shrinks")
        return fig


__all__ = ("NOT_TESTED_WHY", "SCORE_TEXT", "Diagnosis", "RankRow", "WaterfallStep")
