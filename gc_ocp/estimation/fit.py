"""High-level fitting: initialise from the seed's linear least squares, solve the joint
kinematics-contact NLP, and evaluate on a held-out stance.

Held-out protocol (``holdout``): the contact parameters and sole corrections are estimated on
all other stances. On the held-out stance they are then *fixed*, and only the foot-pose
correction is re-estimated under its prior (the kinematic nuisance: marker-to-sole registration
changes from stance to stance). The RMS errors on that stance are reported as ``heldout_rms``.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable

import numpy as np

from gc_ocp.errors import InputError, RankError, SolveError
from gc_ocp.estimation.components import full_model
from gc_ocp.estimation.problem import Weights, build_estimation
from gc_ocp.estimation.solve import EstimationResult, IpoptOptions, solve
from gc_ocp.foot import TrialKinematics
from gc_ocp.stance import StanceData, fit_stances
from gc_ocp.trial import SIDES, Trial

MARGIN = 0.03
"""Unloaded frames kept each side of a stance [s]: the model must predict no force there."""

TYPICAL_DEPTH = 0.005
"""Typical unit penetration [m] used to convert the LLS stiffness (n = 1) to the initial
stiffness of an exponent-n law: k_n = k_1 * TYPICAL_DEPTH**(1 - n) (equal force at that depth)."""


def lls_initial_k(trials: list[tuple[Trial, TrialKinematics]], n0: float) -> dict | None:
    """Initial per-unit stiffness from the seed's linear least squares on every stance of
    ``trials`` (see :func:`lls_k0`)."""
    from gc_ocp.contact.lls import stances_from_trial

    return lls_k0([s for t, k in trials for s in stances_from_trial(t, k)], n0)


def lls_k0(stances: list, n0: float) -> dict | None:
    """Initial per-unit stiffness of an exponent-``n0`` law from the seed's linear least squares
    on ``stances``: negative or tiny LLS stiffnesses are raised to a floor (10 % of the median
    positive one, at least 1e3 N/m), then converted with :data:`TYPICAL_DEPTH`. ``None`` (with a
    warning) when the LLS is rank deficient. A foot without stances gets the floor (the model
    declares both feet)."""
    from gc_ocp.contact.lls import fit_stiffness_lls

    st0 = stances[0]
    try:
        res = fit_stiffness_lls(
            list(stances), st0.body_weight, st0.body_weight * (st0.height or 1.7)
        )
    except RankError as e:
        warnings.warn(
            f"LLS initialisation not possible ({e}); starting from a uniform stiffness.",
            stacklevel=2,
        )
        return None
    out = {}
    k_all = np.array([v for s in res.k.values() for v in s.values()])
    floor = max(np.median(k_all[k_all > 0]) * 0.1, 1e3) if np.any(k_all > 0) else 1e4
    units = {st.side: st.layout.units for st in stances}
    for side in SIDES:
        out[side] = {
            u: float(max(res.k.get(side, {}).get(u, floor), floor) * TYPICAL_DEPTH ** (1 - n0))
            for u in units.get(side, next(iter(units.values())))
        }
    return out


def with_lls_start(model: tuple, stances: list) -> tuple:
    """``model`` with its contact law (the component with ``with_initial_k``) started at the
    seed's linear least squares on ``stances`` (:func:`lls_k0`)."""
    law = next((c for c in model if hasattr(c, "with_initial_k")), None)
    if law is None:
        return model
    k0 = lls_k0(stances, float(law.n.value_for(SIDES[0])))
    return tuple(c.with_initial_k(k0) if c is law else c for c in model)


CONTINUATION = (0.2, 0.5, 1.0)
"""Prior-width continuation: the sole and pose priors first 0.2x, then 0.5x, then 1x their width,
each stage warm-started from the previous one (trusting the markers more at first)."""

STRATEGIES = ((1.0,), CONTINUATION)
"""Starts tried by :func:`fit`; the lowest objective wins. The problem is not convex: on the
bundled example a single solve from the LLS start ends at J = 655 and the continuation at 599; on
the Rajagopal trial the single solve ends at 530 and the continuation at 682."""


def rescaled_start(prev: EstimationResult, prob) -> np.ndarray:
    """Warm start for ``prob`` from the result ``prev``, matching variables by key (prior
    variables are stored in units of their sigma, so they are rescaled)."""
    x0 = prob.x0.copy()
    old = {s.key: s for s in prev.variables}
    for spec in prob.variables.specs:
        o = old.get(spec.key)
        if o is None or o.size != spec.size:
            continue
        z = prev.x[o.slice]
        if spec.kind == "prior":
            z = z * o.scale / spec.scale
        x0[spec.slice] = np.clip(z, spec.lb, spec.ub)
    return x0


def estimate(
    data: list[StanceData],
    model: tuple,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    continuation: tuple[float, ...] = CONTINUATION,
    progress: Callable[[str], None] | None = None,
    covariance: bool = True,
) -> EstimationResult:
    """Solve ``model`` on ``data`` with prior-width continuation (see :data:`CONTINUATION`).

    The returned result is the last stage's (the requested priors); its ``seconds`` and
    ``iterations`` are the totals over all stages. The covariance is computed for the last stage
    only, and not at all with ``covariance=False``.
    """
    say = progress or (lambda s: None)
    steps = continuation if any(c.has_prior_scale for c in model) else (1.0,)
    prev = None
    total_s, total_it = 0.0, 0
    res = None
    for f in steps:
        m = tuple(
            c.with_prior_scale(f) if hasattr(c, "with_prior_scale") and f != 1.0 else c
            for c in model
        )
        prob = build_estimation(data, m, weights)
        x0 = rescaled_start(prev, prob) if prev is not None else None
        last = f == steps[-1]
        res = solve(prob, options, x0=x0, raise_on_failure=last, covariance=covariance and last)
        total_s += res.seconds
        total_it += res.iterations
        say(
            f"  prior scale {f:g}: {res.status}, {res.iterations} iterations, J = {res.objective:.1f}"
        )
        prev = res
    res.seconds, res.iterations = total_s, total_it
    return res


def best_of(
    data: list[StanceData],
    model: tuple,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    strategies: tuple[tuple[float, ...], ...] = STRATEGIES,
    progress: Callable[[str], None] | None = None,
    start: EstimationResult | None = None,
    covariance: bool = True,
) -> EstimationResult:
    """Run :func:`estimate` once per continuation schedule in ``strategies`` and keep the result
    with the lowest objective (``seconds``/``iterations`` are totals over every start). A start
    that fails is skipped; if all fail, the last error is raised.

    start: a result of a model this one extends (e.g. the base, for base + an effect): one more
    start from its solution (variables matched by key, the new ones at their initial values,
    which for an effect is its neutral value), so that the extended model ends at least as low
    as the model it extends whenever that start converges."""
    say = progress or (lambda s: None)
    best, total_s, total_it, err = None, 0.0, 0, None
    if start is not None:
        say("start: from the given result")
        try:
            prob = build_estimation(data, model, weights)
            r = solve(prob, options, x0=rescaled_start(start, prob), covariance=covariance)
            total_s += r.seconds
            total_it += r.iterations
            best = r
        except SolveError as e:
            err = e
    for steps in strategies:
        say(f"start: prior scales {steps}")
        try:
            r = estimate(data, model, weights, options, steps, progress=say, covariance=covariance)
        except SolveError as e:
            err = e
            if e.result is not None:
                total_s += e.result.seconds
            continue
        total_s += r.seconds
        total_it += r.iterations
        if best is None or r.objective < best.objective:
            best = r
    if best is None:
        raise err
    best.seconds, best.iterations = total_s, total_it
    return best


@dataclasses.dataclass
class FitReport:
    """A fit and (optionally) its held-out evaluation; ``to_json()`` is the CLI's ``fit.json``."""

    result: EstimationResult
    heldout: EstimationResult | None = None
    heldout_label: str | None = None
    checks: list = dataclasses.field(default_factory=list)

    def to_json(self) -> dict:
        d = self.result.to_json()
        if self.heldout is not None:
            d["heldout_rms"] = self.heldout.rms
            d["heldout_cop_rms_mm"] = self.heldout.cop_rms_mm
            d["heldout_stance"] = self.heldout_label
            d["heldout_pose_correction_rms"] = self.heldout.pose_correction_rms
            d["heldout_flags"] = self.heldout.flags
        d["checks"] = list(self.checks)
        return d

    def summary(self) -> str:
        s = self.result.summary()
        if self.checks:
            s = "input checks:\n" + "\n".join(f"  - {c}" for c in self.checks) + "\n" + s
        if self.heldout is not None:
            s += f"\nheld-out stance {self.heldout_label}:\n" + self.heldout.summary()
        return s


def _with_height(trial: Trial, kin: TrialKinematics) -> Trial:
    """The trial with the height the kinematics used, when the files gave none (with a warning)."""
    if trial.height is not None or kin.info.get("height") is None:
        return trial
    h = float(kin.info["height"])
    warnings.warn(
        f"{trial.source}: no subject height given; using {h:.3f} m estimated from the markers "
        "by the kinematics (pass height=... / --height M to override).",
        stacklevel=3,
    )
    return dataclasses.replace(trial, height=h, height_source="estimated from markers")


def frozen_model(model: tuple, result: EstimationResult) -> tuple:
    """The model with every component frozen at ``result``'s blocks (held-out evaluation): the
    contact law and sole corrections fixed, the belt speed fixed for the fitted trials, the
    pose correction (scope ``"stance"``) left free."""
    return tuple(c.frozen(result.blocks[c.name]) if c.name in result.blocks else c for c in model)


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
    from gc_ocp.io.consistency import check_for_fit

    say = progress or (lambda s: None)
    trials, notes = check_for_fit([(_with_height(t, k), k) for t, k in trials])
    for note in notes:
        warnings.warn(note, stacklevel=3)
        say(f"check: {note}")
    data = fit_stances(trials, margin=margin, min_frames=5, names=names)
    return trials, data, notes


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
) -> FitReport:
    """Fit ``model`` (default :func:`full_model`) to every stance of ``trials`` (one subject).

    holdout: label (or unique prefix/substring) of a stance to hold out, see the module doc.
    margin: unloaded frames kept each side of a stance [s] (:data:`MARGIN`).
    start: a fit of a model this one extends, tried as one more start (:func:`best_of`).
    """
    say = progress or (lambda s: None)
    model = model or full_model()
    trials, data, notes = fit_data(trials, margin, say)
    held = None
    if holdout is not None:
        matches = [d for d in data if d.label == holdout or holdout in d.label]
        if len(matches) != 1:
            raise InputError(
                f'--holdout "{holdout}" matches {len(matches)} stances; choose one of {[d.label for d in data]}.'
            )
        held = matches[0]
        data = [d for d in data if d is not held]
        if not any(d.side == held.side for d in data):
            raise InputError(
                f"Held-out stance {held.label} leaves no other stance of the {held.side} foot to fit; "
                "hold out a foot that has at least two stances."
            )
    law = next((c for c in model if hasattr(c, "with_initial_k")), None)
    if law is not None:  # the contact law starts from the seed's linear least squares
        say("initialising stiffness from the seed's linear least squares")
        k0 = lls_initial_k(trials, float(law.n.value_for(SIDES[0])))
        model = tuple(c.with_initial_k(k0) if c is law else c for c in model)
    say(f"solving with Ipopt: {len(data)} stances, {sum(d.n for d in data)} frames")
    res = best_of(data, model, weights, options, strategies, progress=say, start=start)
    say(f"fit: {res.status}, {res.iterations} iterations, {res.seconds:.1f} s")
    report = FitReport(res, checks=notes)
    if held is not None:
        hp = build_estimation([held], frozen_model(model, res), weights)
        hres = solve(hp, options)
        report.heldout = hres
        report.heldout_label = held.label
        say(
            f"held-out {held.label}: superior force RMS {hres.rms[held.side]['superior_force_pct_bw']:.2f} % BW"
        )
    return report


__all__ = [
    "fit",
    "fit_data",
    "FitReport",
    "frozen_model",
    "lls_initial_k",
    "lls_k0",
    "with_lls_start",
    "estimate",
    "best_of",
]
