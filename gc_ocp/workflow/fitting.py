"""Fitting trials: check them, cut their stances, fit a model, evaluate a held-out stance.

The layer above the estimator (:mod:`gc_ocp.estimation`, which knows stances, never files): it
takes ``[(Trial, TrialKinematics), ...]`` of one subject, runs the input checks
(:func:`gc_ocp.io.consistency.check_for_fit`), and fits with the estimator's one start path
(:func:`gc_ocp.estimation.starts.with_lls_start` on the stances it fits).

Held-out protocol (``holdout``): the contact parameters and sole corrections are estimated on
all other stances, *started from those stances only*. On the held-out stance they are then
*fixed*, and only the foot-pose correction is re-estimated under its prior (the kinematic
nuisance: marker-to-sole registration changes from stance to stance). The RMS errors on that
stance are reported as ``heldout_rms``.
"""

from __future__ import annotations

import dataclasses
import os
import warnings
from collections.abc import Callable, Iterator, Sequence

import numpy as np

from gc_ocp.antialias import PASS_FRACTION, needs_filter, sample_rate
from gc_ocp.errors import InputError, SolveError
from gc_ocp.estimation.bias import REPLICATES, BiasCorrection, bias_corrected, check_replicates
from gc_ocp.estimation.components import PoseCorrection, full_model
from gc_ocp.estimation.components.base import require_model
from gc_ocp.estimation.pose_scale import PoseScale, lowest_with_widths, widths_plausible
from gc_ocp.estimation.problem import Weights, build_estimation
from gc_ocp.estimation.result import EstimationResult, as_result
from gc_ocp.estimation.solve import (
    IpoptOptions,
    require_settings,
    result_at,
    retry_from_stop,
    solve,
)
from gc_ocp.estimation.starts import STRATEGIES, best_of, frozen_model, with_lls_start
from gc_ocp.foot import TrialKinematics
from gc_ocp.io.checks import require_stances
from gc_ocp.io.consistency import check_for_fit
from gc_ocp.io.processing import censor_threshold, detect_processing, stance_censor_threshold
from gc_ocp.marker_noise import ATTENUATING_UNIT_NOISE_M, noise_modelled, unit_noise_sd
from gc_ocp.stance import StanceData, fit_stances, frame_wrench, quiet_margins, trial_names
from gc_ocp.trial import ESTIMATED, Trial
from gc_ocp.values import given, number

MARGIN = 0.03
"""Unloaded frames kept each side of a stance [s]: the model must predict no force there."""


@dataclasses.dataclass
class FitReport:
    """A fit and (optionally) its held-out evaluation; ``to_json()`` is the CLI's ``fit.json``.

    result: the fit (:class:`~gc_ocp.estimation.result.EstimationResult`: parameters with SEs
    in ``result.blocks``, RMS per channel, flags); heldout, heldout_label: the held-out
    stance's evaluation and label (None without ``holdout``); checks: the input checks' notes;
    pose_scale, bias: the estimated pose width and the bias correction, when made.
    ``print(report.summary())`` shows it all; ``gc_ocp.plot_fit(report)`` draws it.
    """

    result: EstimationResult
    heldout: EstimationResult | None = None
    heldout_label: str | None = None
    checks: list = dataclasses.field(default_factory=list)
    pose_scale: PoseScale | None = None
    bias: BiasCorrection | None = None
    bias_skipped: str | None = None
    """Why no bias correction was made (:func:`bias_replicates`), when none was."""

    def to_json(self) -> dict:
        d = self.result.to_json()
        if self.pose_scale is not None:
            d["pose_scale"] = self.pose_scale.to_json()
        if self.bias is not None:
            d["bias_correction"] = self.bias.to_json()
        elif self.bias_skipped is not None:
            d["bias_correction"] = {"replicates": 0, "message": self.bias_skipped}
        if self.heldout is not None:
            d["heldout_rms"] = self.heldout.rms
            d["heldout_cop_rms_mm"] = self.heldout.cop_rms_mm
            d["heldout_stance"] = self.heldout_label
            d["heldout_pose_correction_rms"] = self.heldout.pose_correction_rms
            d["heldout_flags"] = self.heldout.flags
            # the held-out stance's own fit (frozen contact, its pose re-estimated): what an
            # export places that stance's foot with
            d["heldout"] = self.heldout.to_json()
        d["checks"] = list(self.checks)
        return d

    def summary(self) -> str:
        s = self.result.summary()
        if self.checks:
            s = "input checks:\n" + "\n".join(f"  - {c}" for c in self.checks) + "\n" + s
        if self.pose_scale is not None and self.pose_scale.plausible:
            # an implausible width is one of the flags above, with this same message
            s += "\n" + self.pose_scale.message() + "\n"
        if self.bias is not None:  # on its own line, whatever the text above ended with
            s = s.rstrip("\n") + "\n" + self.bias.message() + "\n"
        if self.heldout is not None:
            s += (
                f"\nheld-out stance {self.heldout_label} (the contact law and the sole "
                "corrections fixed at the values above, its pose re-estimated):\n"
                + self.heldout.summary()
            )
        return s


def with_height(trial: Trial, kin: TrialKinematics, warn: bool = True) -> Trial:
    """The trial with the height the kinematics used, when the files gave none (with a warning
    unless ``warn`` is False: the provenance of a fit that has warned already)."""
    if trial.height is not None or kin.info.get("height") is None:
        return trial
    h = float(kin.info["height"])
    if warn:
        warnings.warn(
            f"{trial.source}: no subject height given; using {h:.3f} m estimated from the "
            "markers by the kinematics (pass height=... / --height M to override).",
            stacklevel=3,
        )
    return dataclasses.replace(trial, height=h, height_source=f"{ESTIMATED} from the markers")


def with_detected_censoring(stances: Sequence[StanceData]) -> list[StanceData]:
    """``stances`` with each one's zero threshold found in its own plate signal where none was
    set (:func:`gc_ocp.io.processing.stance_censor_threshold`): for stances not cut from trials
    by :func:`fit_data` (which finds it on the whole plate recording), e.g. simulated ones."""
    return [
        st
        if st.censor_below > 0
        else dataclasses.replace(st, censor_below=stance_censor_threshold(st.plate_wrench))
        for st in stances
    ]


def _holdout_index(holdout: str, labels: Sequence[str]) -> int:
    """The one stance of ``labels`` that ``holdout`` names: its label exactly, else the one
    label of which it is a part (an exact label wins over the labels that contain it:
    ``walk:right@0.410s`` names that stance beside ``fastwalk:right@0.410s``). A blank one
    names none (it is a part of every label)."""
    if not holdout.strip():
        raise InputError(
            f'holdout "{holdout}" (--holdout) is blank: it names no stance; give a stance label '
            f'or a unique part of it, one of {list(labels)}, or "auto" (or leave --holdout out).'
        )
    exact = [i for i, label in enumerate(labels) if label == holdout]
    if len(exact) == 1:
        return exact[0]
    matches = [i for i, label in enumerate(labels) if holdout in label]
    if len(matches) != 1:
        raise InputError(
            f'holdout "{holdout}" (--holdout) matches {len(matches)} stances; choose one of '
            f"{list(labels)}."
        )
    return matches[0]


def check_holdout(holdout: str | None, trials: Sequence[Trial]) -> None:
    """Before the kinematics: raise the error :func:`fit` would raise when ``holdout`` names
    none of the stances of ``trials``, so that a typo is not found minutes later. Only the
    case that cannot change is caught here: the fit's labels (``name:side@t_on``) name a trial
    by an end of its path (:func:`~gc_ocp.stance.trial_names`, over the trials the fit keeps),
    so a part of one is a part of the label with the whole path; which one stance it names
    is checked by the fit itself."""
    if holdout is None or holdout == "auto" or "#" in holdout:
        return  # "name#k" numbers the trials the fit keeps: only the fit can tell
    shown, every = [], []
    for i, (t, name) in enumerate(
        zip(trials, trial_names([t.source for t in trials]), strict=True)
    ):
        path = os.path.splitext(os.path.abspath(t.source))[0].replace(os.sep, "/")
        for st in t.stances:
            shown.append(f"{name}:{st.label}")
            every += [f"{path}:{st.label}", f"{t.name}#{i + 1}:{st.label}"]
    if not holdout.strip() or not any(holdout in label for label in every):
        _holdout_index(holdout, shown)


def auto_holdout(data: Sequence[StanceData]) -> str | None:
    """The stance a study holds out when none is named: the last of the foot with the most
    stances (in the order of ``data``: trials in order, stances in time), the right foot on a
    tie, when that foot has at least two; else None (a foot needs a stance left to fit)."""
    counts = {side: sum(d.side == side for d in data) for side in ("right", "left")}
    side = max(counts, key=lambda s: counts[s])  # dicts keep order: "right" wins a tie
    if counts[side] < 2:
        return None
    return [d for d in data if d.side == side][-1].label


def _require_pairs(trials) -> list:
    """``trials`` as a list of ``(Trial, TrialKinematics)`` pairs (an iterator of them read
    once), else :class:`InputError` (``fit([trial])`` or ``fit(trial, kin)`` are the usual
    slips)."""
    how = (
        "give a list of (trial, kinematics) pairs: kin = gc_ocp.compute_kinematics(trial); "
        "gc_ocp.fit([(trial, kin)]) (several trials of one subject: one pair each)"
    )
    if isinstance(trials, tuple) and len(trials) == 2 and isinstance(trials[0], Trial):
        raise InputError(f"got one (trial, kinematics) pair, not a list of them; {how}.")
    if isinstance(trials, Trial):  # fit(trial, kin): the kinematics went to model=
        raise InputError(f"got a Trial on its own, not a list of (trial, kinematics) pairs; {how}.")
    if isinstance(trials, Iterator):  # a generator or zip(...): its pairs, once
        trials = list(trials)
    if isinstance(trials, str | os.PathLike):  # a file: it was told "got an empty list"
        raise InputError(
            f"got {given(trials)}, not a list of (trial, kinematics) pairs; load it first, "
            f"trial = gc_ocp.load_trial(path), then {how}."
        )
    if not isinstance(trials, Sequence) or not trials:
        got = "an empty list" if isinstance(trials, Sequence) else type(trials).__name__
        raise InputError(f"got {got}, not a list of (trial, kinematics) pairs; {how}.")
    for i, item in enumerate(trials):
        ok = (
            isinstance(item, tuple | list)
            and len(item) == 2
            and isinstance(item[0], Trial)
            and isinstance(item[1], TrialKinematics)
        )
        if ok:
            continue
        if isinstance(item, Trial):
            got = "a Trial without its kinematics"
        elif isinstance(item, tuple | list):
            got = f"{type(item).__name__} of ({', '.join(type(x).__name__ for x in item)})"
        else:
            got = type(item).__name__
        raise InputError(f"item {i} of the trials is {got}; {how}.")
    return list(trials)


def fit_data(
    trials: list[tuple[Trial, TrialKinematics]],
    margin: float = MARGIN,
    progress: Callable[[str], None] | None = None,
    names: list[str] | None = None,
) -> tuple[list, list[StanceData], list[str]]:
    """The checked trials (:func:`gc_ocp.io.consistency.check_for_fit`; a height estimated
    from the markers when the files gave none), every stance of them with ``margin`` unloaded
    seconds each side, and the checks' notes (each also warned and reported to ``progress``).
    Stances are labelled ``trial:side@t_on`` with the trials named by
    :func:`gc_ocp.stance.trial_names` (``names``: one per trial instead)."""
    say = progress or (lambda s: None)
    trials = _require_pairs(trials)
    for t, _ in trials:
        require_stances(t)
    trials, notes = check_for_fit([(with_height(t, k), k) for t, k in trials])
    for note in notes:
        warnings.warn(note, stacklevel=3)
        say(f"check: {note}")
    processing = [detect_processing(t) for t, _ in trials]
    thresholds = [
        {i: censor_threshold(proc.plates.get(p.name)) for i, p in enumerate(t.plates)}
        for (t, _), proc in zip(trials, processing, strict=True)
    ]
    for (t, _), thr in zip(trials, thresholds, strict=True):
        for i, x in thr.items():
            if x > 0:
                note = (
                    f"{t.source}: plate {t.plates[i].name} was zeroed below {x:.1f} N by the lab: "
                    "its samples below that are censored (not errors) in every fit"
                )
                share = x / t.body_weight
                if share > HIGH_CENSOR_SHARE:
                    note += (
                        f". That is {share:.0%} of body weight: the start and end of every "
                        "stance on it are not measured, and the fit's errors, over the samples "
                        "above it, are not comparable with those of a plate zeroed lower"
                    )
                notes.append(note)
                say(f"check: {note}")
    for t, _ in trials:
        for st in t.stances:
            for reason in quiet_margins(t, st, margin)[2]:
                note = f"{t.source}: stance {st.label}: {reason}"
                notes.append(note)
                say(f"check: {note}")
    for t, k in trials:
        for note in band_notes(t, k):
            notes.append(note)
            say(f"check: {note}")
        for note in marker_notes(t.source, k):
            notes.append(note)
            say(f"check: {note}")
    data = fit_stances(trials, margin=margin, min_frames=5, names=names, censor_below=thresholds)
    return trials, data, notes


HIGH_CENSOR_SHARE = 0.10
"""A lab's zero threshold above this share of body weight is noted as such (:func:`fit_data`):
labs zero at 10-50 N (2-7 % of a 70 kg body weight, ``docs/data_formats.md``); above ~10 % the
censored edges hold a good part of the loading response and of pre-swing, and a review found a
fit of a plate zeroed at 120 N reading 1.45 % BW against 1.93 % for the same data zeroed at 0,
while it predicted the unzeroed force worse (3.65 % BW)."""


def band_notes(trial: Trial, kin: TrialKinematics) -> list[str]:
    """What reading the plates at the frames through their anti-alias low-pass does
    (:mod:`gc_ocp.antialias`), per plate faster than the frames: the pass band, and the RMS
    of the vertical force it removes from the point samples over the trial's stances, in %
    BW (what would otherwise alias into the band the fit compares)."""
    times = {side: foot.time for side, foot in kin.feet.items() if foot.time.size > 1}
    out = []
    for i, plate in enumerate(trial.plates):
        removed = []
        for st in trial.stances:
            t = times.get(st.side)
            if st.plate != i or t is None:
                continue
            rate = sample_rate(t)
            if not needs_filter(sample_rate(plate.time), rate):
                continue
            t = t[(t >= st.t_on) & (t <= st.t_off)]
            # the filter's part alone: both readings with the other loads zeroed
            d = frame_wrench(trial, st, t, None) - frame_wrench(trial, st, t, rate)
            removed.append(d[np.isfinite(d[:, 2]), 2] / trial.body_weight)
        if not removed:
            continue
        r = np.concatenate(removed)
        rms = 100 * float(np.sqrt(np.mean(r**2))) if r.size else float("nan")
        out.append(
            f"{trial.source}: plate {plate.name} ({sample_rate(plate.time):.0f} Hz) is read at the "
            f"{rate:.0f} Hz frames through an anti-alias low-pass (flat to "
            f"{PASS_FRACTION * rate:.0f} Hz, stopped from {rate / 2:.0f} Hz): it removes "
            f"{rms:.2f} % BW RMS of vertical force from the point samples over its stances "
            "(the heel-strike transient, hum, noise), which would alias into the fitted band"
        )
    return out


def marker_notes(source, kin: TrialKinematics) -> list[str]:
    """What the markers' measured error is (per segment) and where the estimator models what it
    leaves in the foot's pose (:mod:`gc_ocp.marker_noise`); the markers far above
    their segment's noise, named."""
    err = kin.info.get("marker_error")
    if not err:
        return []
    per = ", ".join(f"{c} {v:.3f}" for c, v in err["white_mm_per_class"].items())
    modelled = []
    for side, foot in kin.feet.items():
        if foot.pose_noise is None:
            modelled.append(
                f"{side}: not (fewer than 3 foot markers seen in its stances, or none measured)"
            )
            continue
        points = foot.points_in_hindfoot()
        sd = unit_noise_sd(foot.pose_noise, points) * 1e3
        verdict = "modelled" if noise_modelled(foot.pose_noise, points) else "too small to model"
        modelled.append(f"{side}: {sd:.3f} mm at the contact units, {verdict}")
    return [
        f"{source}: markers' white noise [mm] per segment: {per}; the foot pose noise it leaves "
        f"(after the {kin.cutoff_hz:g} Hz low-pass): " + "; ".join(modelled),
        *(f"{source}: {o}" for o in err["outliers"]),
    ]


def attenuating_feet(data: list[StanceData]) -> dict:
    """``{(trial, side): sd}``: the feet whose markers' noise moves a contact unit by at least
    :data:`~gc_ocp.marker_noise.ATTENUATING_UNIT_NOISE_M` after the low-pass (the largest
    ``sd`` [m] over the foot's stances)."""
    worst: dict = {}
    for st in data:
        pn = st.foot.pose_noise
        if pn is not None:
            sd = unit_noise_sd(pn, st.foot.points_in_hindfoot())
            if sd >= ATTENUATING_UNIT_NOISE_M and sd > worst.get((st.trial, st.side), 0.0):
                worst[(st.trial, st.side)] = sd
    return worst


def bias_replicates(bias_correction: int | None, data: list[StanceData]) -> tuple[int, list]:
    """The bias correction's replicates for a fit of ``data`` and what to say about it:
    ``bias_correction`` as given when it is a number (0: none); None (the default): 16
    (:data:`~gc_ocp.estimation.bias.REPLICATES`) where some foot's markers' noise attenuates
    the friction coefficient (:func:`attenuating_feet`), else 0. The notes name those feet, and
    say to ask for the correction where it was turned off."""
    feet = attenuating_feet(data)
    n = (REPLICATES if feet else 0) if bias_correction is None else int(bias_correction)
    what = (
        f"the fit removes that bias with {n} simulated replicates and takes their spread into the "
        "SEs (--bias-correction 0, or bias_correction=0, skips it)"
        if n
        else f"refit with --bias-correction {REPLICATES} (or bias_correction={REPLICATES}) to "
        "remove it"
    )
    notes = [
        f"{trial}: the {side} foot's markers' noise moves its contact units by {sd * 1e3:.2f} mm "
        "after the low-pass; its sliding velocity's noise makes the friction coefficient "
        "come out low, with an SE too small (on synthetic stances: -0.016 at 0.35 mm, growing "
        f"with its square; docs/quality.md): {what}"
        for (trial, side), sd in feet.items()
    ]
    return n, notes


def check_options(
    pose_scale: bool = True,
    sole_scale: bool | None = None,
    pose_correlation: bool = False,
    bias_correction: int | None = None,
) -> bool:
    """:func:`fit`'s options checked together (:class:`InputError` with the fix; the command
    line checks them before the kinematics); the sole width's estimation they ask for."""
    if pose_correlation and not pose_scale:
        raise InputError(
            "The pose correction's knot correlation is estimated in the pose width's rounds: "
            "keep pose_scale=True (drop --fixed-pose-width) to estimate it."
        )
    if sole_scale is None:
        sole_scale = pose_scale
    if sole_scale and not pose_scale:
        raise InputError(
            "The sole correction's width is estimated in the pose width's rounds: keep "
            "pose_scale=True (drop --fixed-pose-width) to estimate it."
        )
    check_replicates(bias_correction)
    return bool(sole_scale)


def fit(
    trials: list[tuple[Trial, TrialKinematics]],
    model: tuple | None = None,
    weights: Weights | None = None,
    holdout: str | None = None,
    options: IpoptOptions | None = None,
    progress: Callable[[str], None] | None = None,
    strategies: tuple[tuple[float, ...], ...] = STRATEGIES,
    margin: float = MARGIN,
    start: EstimationResult | None = None,
    extends: tuple | None = None,
    pose_scale: bool = True,
    sole_scale: bool | None = None,
    bias_correction: int | None = None,
    pose_correlation: bool = False,
) -> FitReport:
    """Fit ``model`` (default :func:`full_model`) to every stance of ``trials`` (one subject).

    trials: ``[(Trial, TrialKinematics), ...]``, the trials of one subject, each with its
    :func:`~gc_ocp.kinematics.compute_kinematics` (they share the contact parameters).
    model: a tuple of components (:func:`full_model`, :func:`seed_model`,
    :func:`model_from_names`). weights: the residuals' scales (:class:`Weights`, default
    2 % BW). options: Ipopt's settings (:class:`IpoptOptions`). progress: called with
    status lines (e.g. ``print``).
    holdout: label (or unique prefix/substring) of a stance to hold out, see the module doc;
    ``"auto"``: the last stance of the foot with the most stances (of the right foot on a tie),
    when that foot has at least two (else none: :func:`auto_holdout`).
    strategies: the prior-width continuation schedules tried as starts
    (:data:`~gc_ocp.estimation.starts.STRATEGIES`), each from the seed's LLS start, with one
    more start after a few trust-region steps (:func:`~gc_ocp.estimation.starts.trust_region_point`);
    ``()``: ``start`` alone.
    margin: unloaded frames kept each side of a stance [s] (:data:`MARGIN`).
    start: a fit of a model this one extends, tried as one more start (:func:`best_of`): what
    :func:`fit` returns, its ``.result`` or its ``fit.json`` (:func:`as_result`).
    extends: a model this one extends (e.g. :func:`full_model` for the full model plus effects),
    fitted first on the same stances when no ``start`` is given; its optimum is then that start,
    so that the problem's non-convexity cannot leave the extended model above it.
    pose_scale: estimate the pose correction's smooth width from the fitted stances
    (:mod:`gc_ocp.estimation.pose_scale`; the held-out stance then uses it too); False keeps the
    component's prior. A pose correction's own prior (``sigma_mm``, ``sigma_deg``) is where the
    estimate starts, not a bound: it stays within what soft tissue moves a foot (5 mm, 5 deg,
    :data:`~gc_ocp.estimation.pose_scale.PLAUSIBLE_MM`; a width stopped there is flagged),
    whatever the start; to impose a wider width, give it with ``pose_scale=False``.
    sole_scale: estimate the sole correction's widths (one per foot-frame
    axis, widened from the 5 mm prior where the stances ask for more) in the same rounds
    (:func:`~gc_ocp.estimation.pose_scale.sole_update`); None (default): whenever the pose
    width is estimated; False: the component's 5 mm prior (``docs/quality.md``, 'The sole
    correction's width'). pose_correlation: estimate the pose coefficients' knot-to-knot
    correlation in the same rounds too (an option: better on synthetic drifts, worse on the
    shared labs' files, where it measures the contact model's misfit; ``docs/quality.md``, *The
    lead: a pose prior whose variance sits in the low frequencies*).
    bias_correction: replicates of the markers' noise's bias correction
    (:mod:`gc_ocp.estimation.bias`); None (default): 16 where the markers' noise moves a
    contact unit by 0.15 mm or more after the low-pass, none elsewhere
    (:func:`bias_replicates`; the shared labs' files are all far below); 0: none.

    Returns a :class:`FitReport`; a failed solve raises :class:`~gc_ocp.errors.SolveError`
    carrying its result. The seed's model (seconds of Ipopt; the default model is
    :mod:`gc_ocp.workflow`'s example), the first right stance held out:

    >>> import gc_ocp
    >>> trial = gc_ocp.load_trial()
    >>> kin = gc_ocp.compute_kinematics(trial)
    >>> report = gc_ocp.fit([(trial, kin)], model=gc_ocp.seed_model(), holdout="right@0.407")
    >>> print(report.summary())               # doctest: +ELLIPSIS
    input checks:
    ...
    Ipopt: Solve_Succeeded in ...
    held-out stance test_small:right@0.407s (the contact law and the sole corrections fixed at the values above, its pose re-estimated):
    ...
    >>> sorted(report.result.blocks["contact"])  # the parameters and their SEs, as data
    ['left', 'right']
    """
    say = progress or (lambda s: None)
    if isinstance(trials, Trial):  # fit(trial, kin): told its model= (the kinematics) was no model
        _require_pairs(trials)
    require_model(model, "model")
    require_model(extends, "extends")
    require_settings(weights, options)
    margin = number(margin, "margin", "s")
    start = None if start is None else as_result(start)
    if holdout is not None and not isinstance(holdout, str):
        raise InputError(
            f"holdout={holdout!r}: give a stance's label or a part of it, e.g. "
            '"right@0.407" (gc-ocp info lists them), or "auto".'
        )
    sole_scale = check_options(pose_scale, sole_scale, pose_correlation, bias_correction)
    model = model or full_model()
    trials, data, notes = fit_data(trials, margin, say)
    held = None
    if holdout == "auto":
        holdout = auto_holdout(data)
        if holdout is None:  # asked for, so said: no held-out score, and why
            counts = ", ".join(
                f"{side} {sum(d.side == side for d in data)}" for side in ("right", "left")
            )
            note = (
                f"holdout auto: no stance held out (no held-out score): no foot has two "
                f"stances to keep one to fit (stances: {counts}); give more trials of the "
                "subject for a held-out evaluation"
            )
            notes.append(note)
            say(f"check: {note}")
    if holdout is not None:
        held = data[_holdout_index(holdout, [d.label for d in data])]
        data = [d for d in data if d is not held]
        if not any(d.side == held.side for d in data):
            raise InputError(
                f"Held-out stance {held.label} leaves no other stance of the {held.side} foot to fit; "
                "hold out a foot that has at least two stances."
            )
    # the bias correction decided on the stances fitted (never the held-out one)
    asked = bias_correction
    bias_correction, advice = bias_replicates(bias_correction, data)
    for note in advice:
        notes.append(note)
        say(f"check: {note}")
    # the one start path: the seed's linear least squares on the stances fitted (never the
    # held-out one)
    say("initialising stiffness from the seed's linear least squares")
    model = with_lls_start(model, data)
    if extends is not None and start is None:
        say("fitting the model it extends first (its optimum is one more start)")
        base = with_lls_start(extends, data)
        start = best_of(
            data,
            base,
            weights,
            options,
            strategies,
            progress=say,
            covariance=False,
            trust_region=bool(strategies),
        )
    say(f"solving with Ipopt: {len(data)} stances, {sum(d.n for d in data)} frames")
    # only the returned fit's covariance is computed: the width rounds compute it at their end,
    # the bias correction at the corrected point (none before either)
    rounds = pose_scale and any(isinstance(c, PoseCorrection) for c in model)
    others: list = []  # the starts that lost, compared again at the estimated widths
    res = best_of(
        data,
        model,
        weights,
        options,
        strategies,
        progress=say,
        start=start,
        covariance=not (rounds or bias_correction),
        others=others,
        trust_region=bool(strategies),  # strategies=(): a caller's own start alone
    )
    say(f"fit: {res.status}, {res.iterations} iterations, {res.seconds:.1f} s")
    scale = None
    minima_flags: list = []
    if pose_scale:
        model, res, scale, minima_notes, minima_flags = lowest_with_widths(
            data,
            model,
            res,
            others,
            weights,
            options,
            say,
            sole=sole_scale,
            covariance=not bias_correction,
            correlation=pose_correlation,
        )
        for note in minima_notes:
            notes.append(note)
            say(f"check: {note}")
    bias = None
    if bias_correction:
        say(f"bias correction: {bias_correction} replicates")
        try:
            res, bias = bias_corrected(
                data,
                model,
                res,
                bias_correction,
                seed=0,
                weights=weights,
                options=options,
                progress=say,
            )  # seed 0: a fit of the same data is the same fit (fit.json records the seed)
        except SolveError as e:
            # the fit converged; only its correction did not: kept uncorrected, with its
            # linearised covariance, and flagged
            res = result_at(
                build_estimation(data, model, weights),
                res.x,
                status=res.status,
                success=res.success,
                iterations=res.iterations,
                seconds=res.seconds,
            )
            res.flags.append(
                {
                    "code": "bias_correction_failed",
                    "what": "bias correction",
                    "message": f"{e} (the parameters are as fitted, uncorrected)",
                }
            )
    skipped = None
    if bias is None:
        skipped = (
            "not made: turned off (bias_correction=0)"
            if asked == 0
            else "not made: failed (see the flags)"
            if bias_correction
            else "not made: the markers' noise moves no contact unit by "
            f"{ATTENUATING_UNIT_NOISE_M * 1e3:g} mm or more after the low-pass"
        )
    res.flags.extend(minima_flags)  # after the bias correction, which makes a new result
    if scale is not None and not scale.plausible:
        res.flags.append(
            {
                "code": "pose_width_at_limit",
                "what": "sole correction"  # the pose's widths plausible: the sole's stopped
                if widths_plausible(scale.sigma_mm, scale.sigma_deg)
                else "pose correction",
                "message": scale.message(),
            }
        )
    if scale is not None and not scale.converged:
        res.flags.append(
            {
                "code": "pose_width_not_converged",
                "what": "pose correction",
                "message": scale.message(),
            }
        )
    report = FitReport(res, checks=notes, pose_scale=scale, bias=bias, bias_skipped=skipped)
    if held is not None:
        hp = build_estimation([held], frozen_model(model, res), weights)
        # a held-out solve that does not converge keeps the fit (it is the fitted stances'):
        # its score is reported with a flag, never in place of the fit
        hres = retry_from_stop(hp, solve(hp, options, raise_on_failure=False), options)
        if not hres.success:
            hres.flags.append(
                {
                    "code": "heldout_not_converged",
                    "what": held.label,
                    "message": f"the held-out stance's solve (the contact model frozen) did not "
                    f"converge ({hres.status}), also solved again from where it stopped: its "
                    "score is not a prediction to rely on; hold out another stance (--holdout)",
                }
            )
        report.heldout = hres
        report.heldout_label = held.label
        say(
            f"held-out {held.label}: superior force RMS {hres.rms[held.side]['superior_force_pct_bw']:.2f} % BW"
        )
    return report


__all__ = [
    "MARGIN",
    "FitReport",
    "attenuating_feet",
    "auto_holdout",
    "bias_replicates",
    "check_holdout",
    "check_options",
    "fit",
    "fit_data",
]
