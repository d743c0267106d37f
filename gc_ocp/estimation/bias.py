"""The bias the markers' noise gives the fitted parameters, estimated by simulation and removed
(a parametric bootstrap bias correction; issue 23, ``docs/quality.md``).

**Why there is one.** The friction law makes the shear force the product of the friction
coefficient and a function of the units' sliding velocity, and the fit takes that velocity from
the markers. Their noise, low-passed, is a velocity error of ~10 mm/s at 1 mm of marker noise;
the pose correction's noise part (:class:`~gc_ocp.estimation.components.pose.PoseCorrection`)
takes back only part of it (on the synthetic stances at 2 mm: from 14 to 12.5 mm/s RMS). What
it leaves costs the fit ``mu^2`` times its square, so the fit lowers ``mu`` and makes up the
shear with a smooth correction that speeds the foot up (there: the corrected velocities 1.2
times the true ones) -- the attenuation of a regression slope by errors in its regressor, in a
nonlinear law. Measured with no drift at all, only marker noise: mu -0.002 at 0.5 mm, -0.016 at
1 mm, -0.051 at 2 mm (truth 0.8), whatever the noise part's width (x0.5 to x2 changes nothing)
and larger with a wider smooth correction; a soft-tissue drift of 3 mm adds none
(``docs/quality.md``, 'The friction coefficient under marker noise').

**What is done.** Simulate the fit's own situation and see what the fit does to it, ``B`` times
(:func:`replicate_data`): the fitted model, frozen, walks the *recorded* motion (its pose
correction at zero: the recorded motion is a motion like the truth's, with the velocity scale
the markers gave, not the one the biased fit inflated) and makes the plate data, plus the fit's
own residual with the sign of each 0.1-s block flipped (the plate noise and misfit, their
autocorrelation kept), recorded with the stance's plate threshold; the fitter sees that motion
with a fresh draw of the markers' noise (:func:`draw_pose_noise`, from the noise measured on the
trial's markers, low-passed as the pipeline did) and of the smooth pose error the pose correction
stands for (:func:`draw_pose_drift`: its fitted widths, a foot's stances sharing the measured
fraction of it). A soft-tissue drift slides the foot as the noise does and attenuates mu the
same way: at 1 mm of noise with a 3 mm drift per stance, replicates of the white noise alone
found -0.015 of a bias of -0.022, these -0.023 (``benchmarks/bias_probes/README.md``). The
model is refitted to each replicate, warm from the fit (its widths kept). The mean change of
every shared parameter is the bias; it is subtracted, and each stance's correction is
re-estimated at the corrected values (:func:`bias_corrected`). The corrected values'
covariance is the fit's (HAC), each shared variable's standard deviation raised to the
replicates' spread where that is larger (the variance the nonlinear law's errors in variables
add, which a covariance made at the fit cannot see; :func:`replicate_covariance`), plus the
replicates' covariance over ``B`` (the Monte Carlo error of the bias). Checked by simulation:
the replicates' mean change reproduces the fit's error (mu -0.019 against -0.018 at 1 mm,
-0.053 against a mean error of -0.051 at 2 mm), and ``benchmarks/coverage.py
--bias-correction`` scores the intervals.

What it does not remove: an error the replicates do not have -- a lab's processing the stance
does not record, a drift whose shape the pose correction's prior does not describe. Nor does
the covariance take in more of the drift's variance than the prior's linearisation gives
(``docs/quality.md``, *Coverage under a drift per stance*). It costs ``B`` warm
refits (~3 s each on the synthetic stances). A fit makes it by default where the markers' noise
moves the contact units by 0.15 mm or more after the low-pass
(:func:`gc_ocp.workflow.fitting.bias_replicates`; no shared lab's file comes near), and on
request (``fit(..., bias_correction=B)``, ``gc-ocp fit --bias-correction B``; 0: never).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence

import numpy as np

from gc_ocp.errors import InputError, SolveError
from gc_ocp.estimation.components import describe_block
from gc_ocp.estimation.components.pose import PoseCorrection
from gc_ocp.estimation.measurement import censored
from gc_ocp.estimation.pose_scale import widths_plausible
from gc_ocp.estimation.problem import Weights, build_estimation
from gc_ocp.estimation.result import EstimationResult
from gc_ocp.estimation.solve import IpoptOptions, _covariance, decode, result_at, solve
from gc_ocp.estimation.starts import frozen_model, rescaled_start
from gc_ocp.estimation.synthetic import plate_signal, simulate, with_pose_error
from gc_ocp.foot import FootKinematics
from gc_ocp.marker_noise import filter_kernel
from gc_ocp.stance import StanceData
from gc_ocp.trial import SIDES
from gc_ocp.values import is_count, se_text

REPLICATES = 16
"""Replicates of :func:`bias_corrected` unless told otherwise: the bias's Monte Carlo error is
the replicates' spread over 4 (mu at 1 mm of marker noise: 0.012 / 4 = 0.003, under a quarter
of mu's standard error), added to the reported covariance."""

BLOCK_SECONDS = 0.1
"""Block length of every bootstrap of the residuals [s] (these replicates', the diagnosis's
held-out intervals and its null): the residuals' autocorrelation time after the 6 Hz filtering
of the kinematics (the HAC bandwidth of ``solve.hac_bandwidth`` is 5-12 frames at 100 Hz)."""


def check_replicates(replicates: int | None) -> None:
    """Raise :class:`~gc_ocp.errors.InputError` unless ``replicates`` is None (the fit
    decides: :func:`gc_ocp.workflow.fitting.bias_replicates`), 0 (no correction) or at least 2
    (a mean change and its spread)."""
    if replicates is None:
        return
    if not is_count(replicates):
        raise InputError(
            f"bias_correction={replicates!r}: give the number of replicates ({REPLICATES} is a "
            "good choice), 0 for none, or None to let the fit decide from the markers' noise."
        )
    if replicates < 0 or replicates == 1:
        raise InputError(
            f"bias_correction={replicates}: give the number of replicates, at least 2 "
            f"({REPLICATES} is a good choice; --bias-correction {REPLICATES}), 0 for none, or "
            "None (the default) to let the "
            "fit decide from the markers' noise."
        )


def block_signs(T: int, L: int, n: int, rng: np.random.Generator) -> np.ndarray:
    """``(T, n)`` random signs, constant over blocks of ``L`` frames with a random phase per
    column (no fixed block edges): the wild bootstrap of autocorrelated residuals."""
    nb = int(np.ceil(T / L))
    offset = rng.integers(0, L, n)
    signs = rng.choice([-1.0, 1.0], size=(nb + 1, n))
    blk = (np.arange(T)[:, None] + offset[None, :]) // L
    return np.take_along_axis(signs, blk, axis=0)


def draw_pose_noise(foot: FootKinematics, rng: np.random.Generator) -> FootKinematics:
    """``foot`` seen through a fresh draw of its markers' noise (its
    :attr:`~gc_ocp.foot.FootKinematics.pose_noise`: the per-frame pose covariance before the
    low-pass, in hindfoot axes), low-passed as the pipeline did (its zero-lag Butterworth's
    impulse response, :func:`gc_ocp.marker_noise.filter_kernel`); ``foot`` itself when no
    noise was measured.

    The pipeline filtered the whole trial, so the noise a stance keeps is as large at its ends
    as in its middle. Filtering the stance's window alone would not be: ``filtfilt`` leaves
    10 times the position variance and 17 times the velocity variance at its first frame (6 Hz
    at 100 Hz), on the frames of heel strike, where the sliding velocity's noise is what biases
    mu. So the draw is longer by the response's length and convolved with it (``"valid"``):
    every frame of the stance is an interior one."""
    pn = foot.pose_noise
    if pn is None:
        return foot
    T = foot.time.size
    if pn.cutoff_hz < pn.rate / 2:
        h = filter_kernel(float(pn.rate), float(pn.cutoff_hz), int(pn.order))
        e = rng.multivariate_normal(np.zeros(6), pn.cov, T + h.size - 1)
        w = np.stack([np.convolve(e[:, j], h, mode="valid") for j in range(6)], axis=1)
    else:  # no low-pass below Nyquist: the noise as drawn
        w = rng.multivariate_normal(np.zeros(6), pn.cov, T)
    R = foot.hindfoot_pose[:, :3, :3]
    seen = with_pose_error(foot, w[:, 3:], np.einsum("nij,nj->ni", R, w[:, :3]))
    return dataclasses.replace(seen, pose_noise=pn)


def _pose(model: tuple) -> PoseCorrection | None:
    return next((c for c in model if isinstance(c, PoseCorrection)), None)


def draws_drift(model: tuple) -> bool:
    """Whether the replicates draw a smooth pose error (:func:`draw_pose_drift`): the model has
    a pose correction and its widths are within what soft tissue does. A width stopped at that
    limit measures the contact model's misfit more than the markers' error
    (:mod:`gc_ocp.estimation.pose_scale`), and simulating a drift of that size would make a
    bias of an error the markers may not have: the replicates then draw the markers' noise
    only, and the correction says so."""
    pose = _pose(model)
    return pose is not None and widths_plausible(pose.sigma_mm, pose.sigma_deg)


def no_drift_reason(model: tuple) -> str:
    """Why :func:`draws_drift` is False for ``model`` ("" when it is True)."""
    if draws_drift(model):
        return ""
    if _pose(model) is None:
        return "the model has no pose correction"
    return (
        "the pose correction's width is at or above what soft tissue moves a foot (where the "
        "width rounds stop it, it measures the contact model's misfit more than a drift)"
    )


def draw_pose_drift(
    data: Sequence[StanceData], model: tuple, result: EstimationResult, rng: np.random.Generator
) -> list[StanceData]:
    """``data`` seen through a fresh draw of the smooth pose error that ``model``'s
    :class:`~gc_ocp.estimation.components.pose.PoseCorrection` stands for: its widths (as fitted
    by :mod:`gc_ocp.estimation.pose_scale`, or as declared), a foot's stances sharing the
    fraction of it that ``result`` measured (:meth:`PoseCorrection.draw`); ``data`` itself
    without one (:func:`draws_drift`)."""
    pose = _pose(model)
    if not draws_drift(model):
        return list(data)
    rho = result.blocks.get(pose.name, {}).get("shared_fraction", {})
    out = []
    for st, (d, th) in zip(data, pose.draw(list(data), rho, rng), strict=True):
        R = st.foot.hindfoot_pose[:, :3, :3]  # the rotation about the origin, in hindfoot axes
        seen = with_pose_error(st.foot, np.einsum("nji,nj->ni", R, th), d)
        out.append(st.with_foot(dataclasses.replace(seen, pose_noise=st.foot.pose_noise)))
    return out


def _stance_columns(problem) -> np.ndarray:
    """Every stance's columns of ``problem``'s per-stance variables, together."""
    return np.concatenate([np.zeros(0, int), *problem.stance_columns()])


def recorded_truth(
    data: Sequence[StanceData], model: tuple, result: EstimationResult
) -> tuple[tuple, EstimationResult]:
    """The replicates' truth: ``model`` frozen at ``result``, and the point its per-stance
    variables take there: every one as fitted (a stance's ground offset, its toe hinge's
    course) except the pose correction's, at zero (the motion as recorded)."""
    problem = build_estimation(list(data), model, compile=False)
    x = np.asarray(result.x, float).copy()
    pose = _pose(model)
    if pose is not None:
        for s in problem.variables.specs:
            if s.key[0] == pose.name:
                x[s.start : s.start + s.size] = 0.0
    at = result_at(problem, x, covariance=False)
    return frozen_model(model, at), at


def replicate_data(
    data: Sequence[StanceData],
    model: tuple,
    result: EstimationResult,
    rng: np.random.Generator,
    truth: tuple[tuple, EstimationResult] | None = None,
    drift: bool = True,
) -> list[StanceData]:
    """One replicate (module doc): the fitted model frozen, on the recorded motion, its plate
    data plus the fit's residual in sign-flipped blocks, censored as recorded, seen through a
    fresh draw of the markers' noise and (``drift``) of the smooth pose error
    (:func:`draw_pose_drift`; ``truth``: :func:`recorded_truth`, when already made)."""
    truth, at = recorded_truth(data, model, result) if truth is None else truth
    sim = simulate(list(data), truth, rng, plate_noise_pct_bw=0.0, at=at)
    seen = draw_pose_drift(data, model, result, rng) if drift else list(data)
    out = []
    for st, s, f, v in zip(data, sim, result.stance_fits, seen, strict=True):
        e = np.asarray(f["measured"], float) - np.asarray(f["model"], float)
        keep = ~censored(f["measured"], f.get("censor_below", 0.0))
        rate = 1.0 / float(np.median(np.diff(st.time)))
        sg = block_signs(e.shape[0], max(1, round(BLOCK_SECONDS * rate)), 1, rng)[:, 0]
        m = s.measured + e * (sg * keep)[:, None]
        if st.censor_below > 0:
            m = np.where(censored(m, st.censor_below)[:, None], 0.0, m)
        pt, pw = plate_signal(st.time, m)
        rep = s.with_measured(m).with_foot(draw_pose_noise(v.foot, rng))
        out.append(
            dataclasses.replace(rep, plate_time=pt, plate_wrench=pw, censor_below=st.censor_below)
        )
    return out


@dataclasses.dataclass(frozen=True)
class BiasCorrection:
    """What :func:`bias_corrected` did: the replicates made and lost, the shared parameters
    as fitted, their estimated bias and its Monte Carlo error (``{name: value}``), seconds, and
    the parameters left uncorrected because the fit put them at a bound or the correction
    would have crossed one; ``drift``: the replicates drew the smooth pose error too
    (:func:`draws_drift`)."""

    replicates: int
    failed: int
    as_fitted: dict
    bias: dict
    bias_se: dict
    seconds: float
    at_bound: list = dataclasses.field(default_factory=list)
    drift: bool = True
    spread: dict = dataclasses.field(default_factory=dict)
    linearised_se: dict = dataclasses.field(default_factory=dict)
    seed: int = 0
    """The replicates' random seed (the same seed and data: the same replicates)."""
    no_drift_reason: str = ""
    """Why the replicates drew no smooth pose error (``drift`` False): :func:`no_drift_reason`."""
    moves: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)
    """The replicates' changes of the shared decision variables, ``(B, shared)`` (not in
    :meth:`to_json`: a benchmark's, to score covariance rules)."""

    def se_raised(self) -> dict:
        """``{name: factor}``: the shared parameters whose SE the replicates' spread raised
        above the linearised one (:func:`replicate_covariance`), and the factor: the spread
        over the linearised SE (the reported SE adds the bias's Monte Carlo part on top, a
        factor ``sqrt(1 + 1/B)``)."""
        return {
            k: self.spread[k] / s
            for k, s in self.linearised_se.items()
            if k in self.spread and s > 0 and self.spread[k] > s
        }

    def message(self) -> str:
        parts = [
            f"{k} {self.bias[k]:+.3g} (+- {se_text(self.bias_se[k], f'{self.bias[k]:+.3g}')})"
            for k in self.bias
            if k not in self.at_bound
        ]
        s = (
            f"bias correction ({self.replicates} replicates"
            + (f", {self.failed} failed" if self.failed else "")
            + f", {self.seconds:.0f} s): the markers' "
            + ("noise and drift" if self.drift else "noise")
            + " moved the fit by "
            + (", ".join(parts) or "nothing it could correct")
            + "; removed"
        )
        if not self.drift:
            s += " (the replicates drew the markers' noise only: " + self.no_drift_reason + ")"
        up = self.se_raised()
        if up:
            s += "; SE from the replicates' spread, larger than the linearised one: " + ", ".join(
                f"{k} x{f:.2g}" for k, f in up.items()
            )
        if self.at_bound:
            s += "; left uncorrected (at a bound, or the correction would cross one): " + ", ".join(
                f"{k} ({self.bias[k]:+.3g})" for k in self.at_bound
            )
        return s

    def to_json(self) -> dict:
        d = dataclasses.asdict(self)
        d.pop("moves")
        return {**d, "message": self.message()}


def estimates(
    blocks: dict, components: dict, shared_keys: set[tuple]
) -> dict[str, tuple[float, float]]:
    """``{name: (value, se)}`` of every scalar parameter the fit reports that the bias
    correction moves (its variable is not a stance's: ``shared_keys``, the keys of the
    problem's shared variables), as the summary shows it: the law's shared ``n``, ``c``,
    ``mu``; a per-foot law parameter as ``"mu (left)"``; an effect's own parameters by its
    block and row (``"damping/c"``, ``"stiffness_exponent/n"``, ``"friction/b"``). The units'
    stiffnesses are left out (fit.json's unit table has them, corrected)."""
    out = {}
    law = blocks.get("contact", {})
    for k, v in law.get("shared", {}).items():
        if not k.endswith("_se") and np.isscalar(v):
            out[k] = (float(v), float(law["shared"].get(k + "_se", np.nan)))
    for side in SIDES:
        for k, v in law.get(side, {}).items():
            if np.isscalar(v) and not k.endswith("_se") and ("contact", k, side) in shared_keys:
                out[f"{k} ({side})"] = (float(v), float(law[side].get(k + "_se", np.nan)))
    for name, class_name in components.items():
        for r in describe_block(class_name, blocks.get(name, {})):
            if r.key and (name, *r.key) in shared_keys:
                out[f"{name}/{r.label}"] = (float(r.value), float(r.se))
    return out


def _shared_keys(problem) -> set[tuple]:
    """The keys of ``problem``'s variables that are not a stance's (the correction's)."""
    stance = set(_stance_columns(problem).tolist())
    return {s.key for s in problem.variables.specs if s.start not in stance}


def replicate_covariance(
    cov: np.ndarray | None,
    S: np.ndarray,
    shared: np.ndarray,
    B: int,
    corrected: np.ndarray | None = None,
) -> np.ndarray | None:
    """The covariance of the bias-corrected estimate: the linearised (HAC) covariance ``cov``
    with every shared variable's standard deviation raised, where smaller (and positive: a
    variable the covariance holds fixed stays so), to the replicates' spread (``S``: their
    covariance over ``shared``), plus ``S / B``, the Monte Carlo error of the bias subtracted,
    on the variables it was subtracted from (``corrected``: a mask over ``shared``, default
    all) whose covariance is not held at zero.

    Why the larger of the two: both estimate the same sampling variance, each missing something.
    The linearised covariance is exact for a law linear in the data's errors, and the friction
    law is not: the markers' noise enters the sliding velocity, and the variance it gives mu
    through that nonlinearity (the errors-in-variables part) is not in a covariance made at the
    fit (mu's SE about 1.3 times short at 0.5 mm of marker noise, ``docs/quality.md``). The
    replicates refit the nonlinear law through fresh draws of that noise, so their spread has
    it; but they draw only the errors the replicate model has (their plate error is the fit's
    residual in sign-flipped 0.1 s blocks), where the HAC covariance reads the residuals'
    autocorrelation itself. Each variable keeps the larger; the linearised correlations are
    kept (a congruence ``F C F`` with ``F`` diagonal, so the result stays positive
    semi-definite). With few replicates ``S`` is noisy and the rule errs wide, never narrow."""
    if cov is None:
        return None
    c = np.diag(cov)[shared]
    s = np.diag(S)
    f = np.ones(cov.shape[0])
    f[shared] = np.sqrt(np.maximum(1.0, np.divide(s, c, out=np.ones_like(s), where=c > 0)))
    out = cov * f[:, None] * f[None, :]
    m = c > 0 if corrected is None else (c > 0) & np.asarray(corrected, bool)
    out[np.ix_(shared[m], shared[m])] += S[np.ix_(m, m)] / B
    return out


def bias_corrected(
    data: Sequence[StanceData],
    model: tuple,
    result: EstimationResult,
    replicates: int = REPLICATES,
    seed: int = 0,
    weights: Weights | None = None,
    options: IpoptOptions | None = None,
    progress: Callable[[str], None] | None = None,
) -> tuple[EstimationResult, BiasCorrection]:
    """``result`` (the fit of ``model`` on ``data``) with the markers' noise's bias removed
    (module doc), and what was done. Replicates whose refit fails are left out and counted;
    with fewer than two left, :class:`~gc_ocp.errors.SolveError`."""
    say = progress or (lambda s: None)
    t0 = time.perf_counter()
    problem = build_estimation(list(data), model, weights)
    stance = _stance_columns(problem)
    shared = np.setdiff1d(np.arange(problem.x0.size), stance)
    rng = np.random.default_rng(seed)
    truth = recorded_truth(data, model, result)
    moved, failed = [], 0
    for b in range(replicates):
        rep = replicate_data(data, model, result, rng, truth=truth)
        try:
            pr = build_estimation(rep, model, weights)
            rr = solve(pr, options, x0=rescaled_start(result, pr), covariance=False)
        except SolveError:
            failed += 1
            continue
        moved.append(rr.x[shared] - result.x[shared])
        say(f"bias replicate {b + 1}/{replicates}")
    if len(moved) < 2:
        raise SolveError(
            f"bias correction: {failed} of {replicates} replicate refits failed; the fit "
            "itself is kept uncorrected (refit with more replicates, or without the correction)."
        )
    D = np.asarray(moved)
    B = D.shape[0]
    x = np.asarray(result.x, float).copy()
    # a variable the fit left at a bound (within Ipopt's interior-point margin, 1e-6 of its
    # range) is not corrected, nor one the correction would push through a bound: its
    # replicates can move one way only, so their mean change is no estimate of a bias
    lo, hi = problem.lbx[shared], problem.ubx[shared]
    margin = 1e-6 * np.maximum(np.where(np.isfinite(hi - lo), hi - lo, 1.0), 1.0)
    xs, step = x[shared], D.mean(axis=0)
    free = (xs - lo > margin) & (hi - xs > margin) & (xs - step > lo) & (xs - step < hi)
    x[shared] = np.where(free, xs - step, xs)
    # each stance's correction re-estimated at the corrected shared values (a held-out fit's
    # problem: the shared components frozen)
    at = result_at(problem, x, covariance=False)
    fz = frozen_model(model, at)
    pf = build_estimation(list(data), fz, weights)
    rf = solve(pf, options, x0=rescaled_start(at, pf), covariance=False)
    keys = {s.key: s for s in pf.variables.specs}
    for s in problem.variables.specs:
        if s.key in keys:
            k = keys[s.key]
            x[s.start : s.start + s.size] = rf.x[k.start : k.start + k.size]
    S = np.cov(D, rowvar=False).reshape(shared.size, shared.size)
    linearised = _covariance(problem, x) if np.all(np.isfinite(x)) else None
    cov = replicate_covariance(linearised, S, shared, B, corrected=free)
    # the result made from the corrected covariance: its SEs, and the flags that read them
    # (a unit whose SE now exceeds its value is not identified)
    corrected = result_at(
        problem,
        x,
        status=result.status,
        success=result.success,
        iterations=result.iterations,
        seconds=result.seconds,
        covariance=False if cov is None else cov,
    )
    # the bias of each shared parameter in its own units, from the replicates' parameters
    shared_keys = _shared_keys(problem)

    def values(r: EstimationResult) -> dict:
        return {k: v for k, (v, _) in estimates(r.blocks, r.components, shared_keys).items()}

    before, after = values(result), values(corrected)
    reps = []
    for d in moved:
        xr = np.asarray(result.x, float).copy()
        xr[shared] += d
        reps.append(values(result_at(problem, xr, covariance=False)))
    bias = {k: float(np.mean([r[k] for r in reps]) - before[k]) for k in before if k in after}
    spread = {k: float(np.std([r[k] for r in reps], ddof=1)) for k in bias}
    se = {k: v / np.sqrt(B) for k, v in spread.items()}
    at_bound = [k for k in bias if after[k] == before[k] and bias[k] != 0.0]
    # the SEs the linearised covariance alone gives, to say what the replicates' spread raised
    lin_se = {}
    if linearised is not None:
        lin = estimates(decode(problem, x, linearised)[0], result.components, shared_keys)
        lin_se = {k: lin[k][1] for k in bias if k in lin and np.isfinite(lin[k][1])}
    info = BiasCorrection(
        B,
        failed,
        before,
        bias,
        se,
        time.perf_counter() - t0,
        at_bound,
        draws_drift(model),
        spread=spread,
        linearised_se=lin_se,
        seed=seed,
        no_drift_reason=no_drift_reason(model),
        moves=D,
    )
    say(info.message())
    return corrected, info


__all__ = [
    "BLOCK_SECONDS",
    "REPLICATES",
    "BiasCorrection",
    "bias_corrected",
    "block_signs",
    "check_replicates",
    "no_drift_reason",
    "recorded_truth",
    "replicate_covariance",
    "draw_pose_drift",
    "draws_drift",
    "draw_pose_noise",
    "estimates",
    "replicate_data",
]
