"""The null distribution of the candidates' held-out gains: what would each candidate gain if the
round's parent model were the truth, up to the plate's noise and a model mismatch that is not a
candidate? (The calibrated decision of ``docs/diagnosis.md``.)

**Replicates.** A replicate is the data the fitted parent predicts on the subject's own motion,
plus (a) the parent's own residuals, with the sign of each block of :data:`BLOCK_SECONDS`
flipped at random (a *dependent wild bootstrap*, Shao 2010: it keeps the residuals'
autocorrelation, their size frame by frame and the correlation between channels, and has mean
zero, so that the systematic part of the residual, which an effect would explain, is not in the
null) and (b) a draw of the *mismatch family* (:mod:`.mismatch`): how the data would differ if the
truth were the parent slightly changed in ways that are not candidates (law smoothing, friction
form, plate hum, marker low-pass). Censored samples (below the plate's threshold) carry neither:
the plate recorded nothing there.

**Fits.** Every fit of a replicate's held-out scoring is one Gauss-Newton step
(:mod:`.onestep`) from a point where every model is linearised. With a mismatch family, that
point is the parent *refitted* to the draw's data, one per draw (:mod:`.draws`: a draw can move
the parent far, and the Jacobians of the observed fit then understate the candidates' gains);
the wild-residual replicates of a draw share it. Without one (noise only), it is the observed
fit. So the null's held-out reductions cost one solve per draw and a few matrix products per
replicate, not thousands of fits.

**Decision.** For every candidate, its null reductions give a mean ``m`` and spread ``s``; the
observed reduction is studentised, ``z = (T - m) / s``, and compared with the distribution of
the *largest* studentised null reduction over the round's candidates (Westfall and Young's
max statistic), so that the family-wise rate of a false claim among all candidates is at most
``alpha``: the adjusted p-value is the share of the null's *draws* whose largest ``z`` reaches
the observed one, each mismatch draw counting the share of its wild replicates that do
(:func:`decide`: a draw's replicates share its shift, so the observed statistic is exchangeable
with a draw, not with each replicate; counted per replicate, the rate was 5.6-6.3 % in
simulation where the mismatch dominates, per draw 2.5-2.9 %). A candidate the stances do not
move (every reduction under
:data:`RESOLUTION_PCT`: round-off) is not in that family (``NullTest.inert``).

**Steps that would decide.** The null's variance has two parts: the spread *between* the
mismatch draws, ``s_b``, and the spread *within* a draw, ``s_w`` (the wild residuals: noise,
which shrinks as ``1/sqrt(n)`` with ``n`` held-out stances), estimated from the replicates' draw
index by the one-way analysis of variance (``s_b^2 = var(draw means) - s_w^2 / per draw``, at
least 0). Of ``s_b``, the part every held-out stance shares, ``s_sys`` (a draw's change of the
law or the processing gives every stance the same kind of gain: more stances do not average it
away), is told from the stances' own (members drawn per stance, a refit that spreads a draw
unevenly: these shrink as ``1/sqrt(n)``) by the covariance of the draws' per-stance shares
(:func:`systematic_sd`). The observed reduction's sampling error ``sigma`` shrinks as
``1/sqrt(n)``; the null's mean ``m`` (what mismatch alone gives) does not move. A candidate
whose reduction ``T`` exceeds ``m`` is decided with 80 % assurance at the smallest ``n`` with
``z_crit sqrt(s_sys^2 + (s^2 - s_sys^2) n0 / n) + 0.84 sigma sqrt(1 + n0 / n) <= T - m``: the
gain a study of ``n`` stances observes scatters about the true gain by ``sigma sqrt(n0 / n)``,
and the true gain about ``T`` by ``sigma`` (:func:`power_shift`; until 2026-12-03 ``T`` was
taken as the true gain, ``0.84 sigma sqrt(n0 / n)``). That ``n`` exists only if ``T - m >
z_crit s_sys + 0.84 sigma``: a gain the mismatch alone can give on every stance cannot be told
from it by more steps of the same kind, however many (the bound), and a gain whose own
uncertainty reaches that bound is not likely to be (``None`` for both). Where the split is not
made (one held-out stance, fewer than :data:`MIN_SPLIT_DRAWS` draws) all of ``s_b`` counts as
shared, as it did for every null until 2026-11-28.

**Stopping early.** The draws are the null's cost (a refit each), and most rounds name nothing:
the last round of every diagnosis, and the only round of most. The draws are made in the order
of their seeds and looked at after every :data:`DRAWS_PER_LOOK`; when, with the draws so far,
no candidate's adjusted p-value could end below ``FUTILITY_FACTOR * alpha`` even if every
remaining replicate fell below every observed statistic (:func:`cannot_name`), the rest are
not made (a sequential Monte Carlo test's stop for futility, Besag and Clifford 1991). Such a
stop can only turn a claim into no claim, so the false-claim rate holds; what it could cost is
power, a claim the full null would have made: not possible for a fixed studentisation (the
bound is the final p-value's smallest value), and the factor 2 leaves room for the means and
spreads moving as draws are added. A stopped round reports the p-values, spreads and steps of
the draws it made (``calibration[].mismatch_draws``, ``null_stopped_early``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Collection, Mapping, Sequence

import numpy as np

from gc_ocp.diagnosis.compare import BLOCK_SECONDS, held_out, stance_rate
from gc_ocp.diagnosis.mismatch import (
    MismatchDraw,
    MismatchFamily,
)
from gc_ocp.diagnosis.onestep import Linear, energies, per_stance_sd, reductions, step
from gc_ocp.estimation.bias import block_signs
from gc_ocp.estimation.measurement import censored
from gc_ocp.estimation.problem import Weights
from gc_ocp.estimation.synthetic import plate_signal
from gc_ocp.stance import StanceData

ALPHA = 0.05
"""Family-wise rate of a false claim among a round's candidates."""

N_REPLICATES = 500
"""Null replicates per round (the adjusted p-value's resolution is 1/(B+1))."""

PRACTICAL_FACTOR = 4
"""A candidate is called *inconclusive* (listed in the summary's verdict) when the further
stances that would decide it are at most this many times the held-out stances it has: a
follow-up of at most five times the data. Beyond, its row still gives the number (a verdict
says it up to :data:`~gc_ocp.diagnosis.result.SESSION_STEPS` further steps, "more than" that
above; ``diagnosis.json`` keeps it)."""

POWER_Z = 0.8416
"""Standard normal quantile of the 80 % of the steps-needed calculation (:func:`power_shift`)."""

RESOLUTION_PCT = 1e-4
"""A candidate whose observed reduction and every null replicate's are smaller than this, in
absolute value [% of the held-out RMS], is *inert* on these stances: the data do not move it
(its parameters' Jacobian columns vanish there, e.g. a toe hinge that never bends, which gains
1e-10 to 1e-6 % in the stored benchmarks). 1e-4 % is a relative change of 1e-6 of the RMS, the
relative objective change at which the solver stops (``IpoptOptions.acceptable_obj_change_tol``):
below it a difference between two fits is the solver's, not the data's, and a real gain that
small would take millions of stances to decide. An inert candidate is left out of the max
statistic (it cannot be named: it is below every effect-size floor, so leaving it in would only
raise the other candidates' critical value with its round-off), and its row says so
(``NullTest.inert``) rather than report a p-value and steps of round-off."""


def wild_residuals(
    parent: Linear,
    fits: Sequence[dict],
    n: int,
    rng: np.random.Generator,
    frame_rate: float,
) -> np.ndarray:
    """``(rows, n)`` perturbations: the parent's residual with the sign of each block of
    :data:`BLOCK_SECONDS` flipped at random (module doc); zero on censored samples (``fits``:
    the parent's stance fits, for their measured wrench, threshold and time stamps: a block is
    :data:`BLOCK_SECONDS` at each stance's own rate, ``frame_rate`` only for a stance of one
    frame)."""
    out = np.zeros((parent.r.size, n))
    for rows, f in zip(parent.rows, fits, strict=True):
        e = parent.r[rows].reshape(-1, 6)  # (T, 6) frame-major
        T = e.shape[0]
        L = max(1, int(round(BLOCK_SECONDS * stance_rate(f, frame_rate))))
        keep = ~censored(f["measured"], f.get("censor_below", 0.0))
        s = block_signs(T, L, n, rng)  # (T, n)
        pert = e[:, :, None] * (s * keep[:, None])[:, None, :]  # (T, 6, n)
        out[rows] = pert.reshape(6 * T, n)
    return out


def replicate(
    stances: Sequence[StanceData], fits: Sequence[dict], perturbation: np.ndarray, weights: Weights
) -> list[StanceData]:
    """The replicate whose weighted perturbation is ``perturbation`` (``(rows,)``, a column of
    :func:`wild_residuals`) around the parent's wrench (``fits``, its stance fits), as stances a
    full fit can take (:func:`perturbed`): to check the one-step null against full refits."""
    base = [
        st.with_measured(np.asarray(f["model"], float)) for st, f in zip(stances, fits, strict=True)
    ]
    return perturbed(base, perturbation, weights)


def perturbed(
    stances: Sequence[StanceData], perturbation: np.ndarray, weights: Weights
) -> list[StanceData]:
    """``stances`` with the weighted perturbation ``perturbation`` (``(rows,)``, frame-major,
    six channels per frame, in the units of ``weights``) added to their measured wrench in N and
    N m, and the plate signal made from it (what a clock-offset model resamples)."""
    out, start = [], 0
    for st in stances:
        n = 6 * st.n
        u = perturbation[start : start + n].reshape(st.n, 6) / weights.inverse_sigmas(
            st.body_weight
        )
        start += n
        m = np.asarray(st.measured, float) + u
        pt, pw = plate_signal(st.time, m)
        out.append(dataclasses.replace(st.with_measured(m), plate_time=pt, plate_wrench=pw))
    return out


DRAWS_PER_LOOK = 8
"""The null's draws are looked at after every this many (module doc, "Stopping early"); a
multiple of the workers a round has (at most
:data:`~gc_ocp.diagnosis.execution.MAX_WORKERS`, 4), so a look waits for no half-filled batch."""

MISMATCH_DRAWS = 32
"""Draws of the mismatch family per round, each a refit of the parent and a relinearisation of
every model (:mod:`.draws`), with ``N_REPLICATES / MISMATCH_DRAWS`` wild-residual replicates
around each. The null is a mixture over the draws, so its tail at ``alpha`` is resolved by the
draws, not by the replicates: with 16 draws it holds less than one. Each draw costs a solve of
the parent and a linearisation of every candidate (~2.5 s on the bundled trial's three stances
with seven candidates, one core): 32 is the compromise between the tail's resolution and a
diagnosis of minutes (``docs/diagnosis.md``, "Cost")."""

DEFAULT_FAMILY = MismatchFamily()
"""The mismatch family the null allows unless told otherwise (``docs/diagnosis.md``)."""


def null_draw(
    family: MismatchFamily,
    rng: np.random.Generator,
    layout,
    model: tuple,
    units_off: bool = False,
) -> MismatchDraw:
    """A draw of ``family`` (sole ``layout``) as a replicate of the null for ``model`` takes it:
    restricted to the model (:meth:`MismatchDraw.for_model`) and to the members the null adds
    (:func:`_null_draw`). ``units_off``: keep the units off the layout (the refit null, whose
    full refits meet them as the observed fit did; :mod:`.refits`)."""
    return _null_draw(family.draw(rng, layout).for_model(model), model, units_off)


def _null_draw(d: MismatchDraw, model: tuple, units_off: bool = False) -> MismatchDraw:
    """The members of draw ``d`` the null's data carry (:func:`.draws.draw_data`):
    the law's smoothing and friction forms, the plate's hum and the markers' low-pass. Left out:
    the plate threshold (the measurement model finds it in the data and censors it), the marker
    noise and soft-tissue drift (the wild residuals are the observed data's own, kinematic noise
    included, and the draw's truth walks the motion as the observed fit's pose correction
    corrected it, :mod:`.draws`: the subject's own estimated kinematic error, not a drawn one),
    and, for a model with
    sole registration, the units off the layout (the sole correction has exactly that freedom: a
    truth with moved units is the parent with other sole offsets). The last two are large
    changes of the force (units 2 mm off: 8-87 % BW) that a refit absorbs almost entirely
    (``docs/diagnosis.md``, mismatch family): one Gauss-Newton step would leave their
    second-order terms, an artefact of the step, not a mismatch."""
    d = dataclasses.replace(d.without_pose_error(), threshold_n=0.0)
    drop = not units_off and any(c.name == "sole" for c in model)
    return d.without_unit_offsets() if drop else d


def prior_step(lin: Linear) -> np.ndarray:
    """``(nx,)`` the step ``d0`` by which the parent, refitted to its own noise-free
    prediction, moves on (its priors pull it further, as they pulled the fit of the observed
    data away from the truth that made them; :func:`prior_pull`)."""
    J = lin.J
    nx = J.shape[1]
    P2 = np.zeros(nx)
    P2[lin.prior_idx] = lin.pw**2
    Pp0 = np.zeros(nx)
    Pp0[lin.prior_idx] = lin.pw * lin.p0
    return step((J.T @ J).toarray() + np.diag(P2), Pp0[:, None], lin)[:, 0]


def prior_pull(lin: Linear) -> np.ndarray:
    """``(rows,)`` the weighted perturbation that makes the replicates' truth the parent
    *debiased* for its priors (module doc): refitted to its own noise-free prediction, the parent
    moves on by ``d0`` (:func:`prior_step`); the replicates are made from ``x_hat - d0`` instead
    of ``x_hat``, so that their fits carry the priors' bias as the observed fit does (a
    bias-corrected parametric bootstrap). Without it, a candidate that absorbs the misfit a
    prior leaves (damping, under the sole prior, on a truth whose sole offsets are 4-5 prior
    sigmas) gains on the observed data and not on the replicates: on eight noise-only datasets
    of the bundled motion damping was named in five."""
    return -np.asarray(lin.J @ prior_step(lin)).ravel()


def observed_reductions(
    parent: Linear,
    children: Mapping[str, Linear],
    plan: Sequence[Sequence[int]],
    occam: Mapping[str, np.ndarray] | None = None,
    fold_means: Sequence[Mapping[tuple, np.ndarray]] | None = None,
) -> tuple[dict[str, float], dict[str, float | None]]:
    """Each candidate's held-out reduction [%] on the observed data as the null scores its
    replicates (one step from the linearisation) and the spread of its per-stance reductions."""
    E = energies(parent, children, -parent.r[:, None], plan, occam, fold_means)
    return {n: float(v[0]) for n, v in reductions(E).items()}, per_stance_sd(E)


def step_miss(
    parent: Linear,
    refit_energy: np.ndarray,
    plan: Sequence[Sequence[int]],
    occam: np.ndarray | None = None,
    fold_means: Sequence[Mapping[tuple, np.ndarray]] | None = None,
) -> tuple[float, np.ndarray]:
    """How far [%] the test's one step puts the parent's held-out score from its refitted
    folds' (``refit_energy``: per held-out stance of ``plan``, the refit's energy with its Occam
    term ``occam``): ``100 (sqrt(E_step / E_refit) - 1)`` for the whole score (the sum over the
    held-out stances, as :func:`~gc_ocp.diagnosis.onestep.reductions`) and per held-out stance.
    The step starts at the fit on all stances; where a fold's fits lie far from it (a foot with
    few stances: ``docs/diagnosis.md``, "Why the one step misses on real walking") the miss is
    large, and the test can miss gains the refit shows (its null is scored the same way, so its
    rate holds)."""
    occ = np.zeros(len(refit_energy)) if occam is None else np.asarray(occam, float)
    e_step = energies(parent, {}, -parent.r[:, None], plan, {"parent": occ}, fold_means)
    e_step = e_step["parent"][:, 0]
    e_refit = np.asarray(refit_energy, float)
    whole = 100.0 * (np.sqrt(e_step.sum() / e_refit.sum()) - 1.0)
    return float(whole), 100.0 * (np.sqrt(e_step / e_refit) - 1.0)


def onestep_null(
    parent: Linear,
    parent_fits: Sequence[dict],
    children: Mapping[str, Linear],
    plan: Sequence[Sequence[int]],
    occam: Mapping[str, np.ndarray] | None = None,
    fold_means: Sequence[Mapping[tuple, np.ndarray]] | None = None,
    n_replicates: int = N_REPLICATES,
    seed: int = 0,
    frame_rate: float = 100.0,
) -> dict[str, np.ndarray]:
    """``{candidate: (n_replicates,) null reductions [%]}`` of the noise-only null: the
    parent's wild residuals around its debiased fit, every fit one step from the observed
    linearisation (module doc; with a mismatch family the draws of :mod:`.draws` replace it)."""
    rng = np.random.default_rng(seed)
    U = wild_residuals(parent, parent_fits, n_replicates, rng, frame_rate)
    U = U + prior_pull(parent)[:, None]
    return reductions(energies(parent, children, U, plan, occam, fold_means))


def calibrate(
    parent: Linear,
    parent_fits: Sequence[dict],
    children: Mapping[str, Linear],
    plan: Sequence[Sequence[int]],
    occam: Mapping[str, np.ndarray] | None = None,
    null: Mapping[str, np.ndarray] | None = None,
    n_replicates: int = N_REPLICATES,
    seed: int = 0,
    frame_rate: float = 100.0,
    alpha: float = ALPHA,
    fold_means: Sequence[Mapping[tuple, np.ndarray]] | None = None,
    draws: np.ndarray | None = None,
    observed: tuple[dict[str, float], dict[str, float | None]] | None = None,
    shares: StanceShares | None = None,
    n_final: int | None = None,
) -> dict[str, NullTest]:
    """The calibrated decision of a round (module doc): ``{candidate: NullTest}``.
    ``parent_fits``: the parent's stance fits (censored samples); ``null``: the candidates'
    null reductions when already made (the mismatch draws of :mod:`.draws`, ``draws`` the draw
    of each replicate), else the noise-only one-step null (:func:`onestep_null`);
    ``fold_means``: :func:`~.onestep.fold_prior_means`; ``observed``:
    :func:`observed_reductions` when already made (the draws' early stop needs them first);
    ``shares``: the draws' stance shares (:func:`systematic_sd`); ``n_final``: the draws the
    full null makes (:func:`decide`)."""
    if not children:
        return {}
    observed, sd = observed or observed_reductions(parent, children, plan, occam, fold_means)
    if null is None:
        null = onestep_null(
            parent, parent_fits, children, plan, occam, fold_means, n_replicates, seed, frame_rate
        )
        draws = None
    # 0 in the in-sample fallback (no fold): no held-out stance to count further ones from
    return decide(observed, null, sd, len(held_out(plan)), alpha, draws, shares, n_final)


def practical(more: int | None, n_heldout: int) -> bool:
    """``more`` further stances (None or 0: no number, or decided) are a practical follow-up:
    at most :data:`PRACTICAL_FACTOR` times the ``n_heldout`` held-out stances the data had."""
    return bool(more) and more <= PRACTICAL_FACTOR * max(n_heldout, 1)


@dataclasses.dataclass(frozen=True)
class NullTest:
    """The calibrated decision of one candidate (module doc): observed reduction [%], the null's
    mean and spread [%], the studentised statistic, the family-wise adjusted p-value, the
    critical studentised value of the round, and the further held-out stances that would decide
    it with 80 % assurance (0: decided; None: more steps of the same kind would not, or are not
    likely to (:func:`power_shift`), or, with
    ``n_heldout`` 0, the in-sample fallback, no number is predicted).
    ``null_sd_mismatch_pct``: the part of the null's spread that lies between the mismatch
    draws (module doc; 0 for a noise-only null); of it, the part every held-out stance shares
    is what more stances do not shrink (:attr:`null_sd_systematic_pct`)."""

    observed_pct: float
    null_mean_pct: float
    null_sd_pct: float
    z: float
    p_adjusted: float
    z_critical: float | None
    """The round's critical studentised value (None: no candidate of the round was tested,
    every one :attr:`inert`)."""
    more_stances: int | None
    n_heldout: int = 0
    null_sd_mismatch_pct: float = 0.0
    null_sd_systematic_pct: float | None = None
    """The part of ``null_sd_mismatch_pct`` every held-out stance shares (:func:`systematic_sd`):
    what more stances of the same kind do not shrink, and what the steps are computed with. None
    (files written before 2026-11-28; a null without stance shares or where the split is not
    made, :func:`systematic_sd`): all of the spread between draws counts as systematic. Written
    to JSON only when set."""
    inert: bool = False
    """The data do not move the candidate: its observed and null reductions are all below
    :data:`RESOLUTION_PCT`. Not in the max statistic; its p-value is 1 and no number of steps is
    given. Written to JSON only when True."""

    @property
    def practical(self) -> bool:
        """The further stances that would decide it are a practical follow-up (:func:`practical`)."""
        return practical(self.more_stances, self.n_heldout)

    @property
    def within_mismatch(self) -> bool:
        """Its gain over the null's mean is within what the mismatch alone gives on every held-out
        stance (``T - m <= z_crit s_sys``, :func:`more_stances`'s bound): no number of further
        stances of the same kind decides it. False where the round has no critical value."""
        if self.z_critical is None:
            return False
        shared = self.null_sd_systematic_pct
        shared = self.null_sd_mismatch_pct if shared is None else shared
        shared = min(max(shared, 0.0), self.null_sd_pct)
        return self.observed_pct - self.null_mean_pct <= self.z_critical * shared

    def to_json(self) -> dict:
        out = dataclasses.asdict(self)
        if self.null_sd_systematic_pct is None:  # older files read back as they were
            del out["null_sd_systematic_pct"]
        if not self.inert:
            del out["inert"]
        return out


@dataclasses.dataclass(frozen=True)
class StanceShares:
    """The mismatch draws' held-out stances: ``shares``, ``{candidate: (draws, rows)}`` each
    draw's mean share of a candidate's null reduction per held-out stance; ``weights``
    ``(rows,)`` each stance's weight in it (:func:`~gc_ocp.diagnosis.onestep.stance_shares`);
    ``within``, ``{candidate: (rows, rows)}`` the mean covariance of the shares between a
    draw's ``n_wild`` replicates (the noise each draw's means carry, over ``n_wild``)."""

    shares: Mapping[str, np.ndarray]
    weights: np.ndarray
    within: Mapping[str, np.ndarray] | None = None
    n_wild: int = 1


def decide(
    observed: Mapping[str, float],
    null: Mapping[str, np.ndarray],
    per_stance_sd: Mapping[str, float | None],
    n_heldout: int,
    alpha: float = ALPHA,
    draws: np.ndarray | None = None,
    shares: StanceShares | None = None,
    n_final: int | None = None,
) -> dict[str, NullTest]:
    """The max-statistic decision over the round's candidates (module doc). ``observed``:
    ``{candidate: held-out reduction [%]}``; ``null``: their null reductions (same replicates
    for all); ``per_stance_sd``: the spread of a candidate's per-stance reductions (the
    sampling error of the observed one is ``sd / sqrt(n_heldout)``; None: the null's spread is
    used); ``n_heldout``: the held-out stances (0: the in-sample fallback, which gives no
    steps, :func:`more_stances`); ``draws``: the mismatch draw of each replicate (None: a
    noise-only null);
    ``shares``: the draws' stance shares, which split the spread between draws into the part
    every stance shares and the stances' own (:func:`systematic_sd`; None: all of it shared);
    ``n_final``: the draws the full null makes, when these are the first of them (a null
    stopped early): the critical value (``z_critical``), and so the steps, are those of the
    full null, and of at least :data:`MISMATCH_DRAWS` draws (a null of fewer draws, a user's
    choice to save time, cannot reach ``alpha`` below 20; its steps say what the default null
    would need).

    The adjusted p-value counts *draws*, not replicates (:func:`_draw_weights`): a mismatch
    draw's replicates share its shift, so the observed statistic is exchangeable with a draw,
    not with each of its replicates; counted per replicate, a null that the mismatch dominates
    names a candidate above the second largest of 32 draws, 2 / 33 = 6.1 % of the time under
    the null. Each draw counts the share of its replicates that reach the observed statistic:
    ``p = (1 + sum_k q_k) / (K + 1)``. Replicates with a value that is not finite (a fit that
    failed inside a draw) are left out of every candidate (:func:`finite_replicates`); a
    candidate whose observed value is not finite is not tested."""
    names, inert, null, draws = _family(observed, null, draws)
    if not names and not inert:
        return {}
    out = {}
    if names:
        m, s, zmax = _studentised(null, names)
        w, K = _draw_weights(draws, zmax.size)
        # the rule's threshold with the draws the full null makes, and at least the default's
        # (what the steps assume a rerun makes: fewer than 1 / alpha - 1 draws name nothing)
        full = max(K, n_final or 0, MISMATCH_DRAWS if draws is not None else 0)
        crit = _critical(zmax, w, full, alpha)
    else:  # nothing to test: every candidate inert (no critical value exists)
        crit = None
    s_b = {n: between_draw_sd(null[n], draws) for n in names}
    s_sys = {
        n: None
        if shares is None or n not in shares.shares
        else systematic_sd(
            s_b[n],
            shares.shares[n],
            shares.weights,
            None if shares.within is None else shares.within.get(n),
            shares.n_wild,
        )
        for n in names
    }
    for n in names:
        z = (observed[n] - m[n]) / s[n]
        p = (1.0 + _exceeding(zmax, w, z)) / (K + 1.0)
        out[n] = NullTest(
            observed_pct=float(observed[n]),
            null_mean_pct=m[n],
            null_sd_pct=s[n],
            z=float(z),
            p_adjusted=p,
            z_critical=crit,
            more_stances=None
            if crit is None
            else more_stances(
                observed[n],
                m[n],
                s[n],
                per_stance_sd.get(n),
                n_heldout,
                crit,
                p < alpha,
                s_b[n] if s_sys[n] is None else s_sys[n],
            ),
            n_heldout=n_heldout,
            null_sd_mismatch_pct=s_b[n],
            null_sd_systematic_pct=s_sys[n],
        )
    for n in inert:  # out of the family (RESOLUTION_PCT); the round's critical value beside it
        out[n] = NullTest(
            observed_pct=float(observed[n]),
            null_mean_pct=float(np.mean(null[n])),
            null_sd_pct=float(np.std(null[n], ddof=1)) if null[n].size > 1 else 0.0,
            z=0.0,
            p_adjusted=1.0,
            z_critical=crit,
            more_stances=None,
            n_heldout=n_heldout,
            inert=True,
        )
    return {n: out[n] for n in observed if n in out}


def _inert(observed: float, null: np.ndarray) -> bool:
    """Whether a candidate's observed and null reductions are all below
    :data:`RESOLUTION_PCT` (the data do not move it; a value that is not finite moves it)."""
    v = np.abs(np.r_[observed, np.asarray(null, float)])
    return bool(np.all(v < RESOLUTION_PCT))


def _family(
    observed: Mapping[str, float], null: Mapping[str, np.ndarray], draws: np.ndarray | None
) -> tuple[list[str], list[str], dict[str, np.ndarray], np.ndarray | None]:
    """``(tested, inert, null, draws)``: the candidates of the max statistic's family (an
    observed value that is finite, a null; not :func:`_inert`), those the data do not move, and
    the null's replicates without those that are not finite (:func:`finite_replicates`). One
    definition for the decision (:func:`decide`) and its early stop (:func:`final_p_bound`),
    which must test the same family on the same replicates."""
    names = [n for n in observed if n in null and np.isfinite(observed[n])]
    if names:
        null, draws = finite_replicates(null, names, draws)
    inert = [n for n in names if _inert(observed[n], null[n])]
    return [n for n in names if n not in inert], inert, dict(null), draws


def finite_replicates(
    null: Mapping[str, np.ndarray], names: Sequence[str], draws: np.ndarray | None
) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
    """``null`` (and ``draws``) without the replicates whose value is not finite for some
    candidate of ``names``: one such value would make every candidate's largest studentised
    reduction NaN, and every comparison with it false (every candidate named)."""
    ok = np.all([np.isfinite(np.asarray(null[n], float)) for n in names], axis=0)
    if np.all(ok):
        return dict(null), draws
    return {n: np.asarray(v)[ok] for n, v in null.items()}, None if draws is None else draws[ok]


def _draw_weights(draws: np.ndarray | None, n: int) -> tuple[np.ndarray, int]:
    """``(w, K)``: each replicate's weight, one over its draw's replicates, and the number of
    draws ``K`` (:func:`decide`: the p-value counts draws); every replicate its own draw when
    ``draws`` is None (a noise-only null)."""
    if draws is None:
        return np.ones(n), n
    _, inv = np.unique(draws, return_inverse=True)
    return 1.0 / np.bincount(inv)[inv], int(inv.max()) + 1 if inv.size else 0


def _exceeding(zmax: np.ndarray, w: np.ndarray, z: float) -> float:
    """The draws (each counting the share of its replicates, ``w``) whose largest studentised
    reduction reaches ``z``: the ``e`` of the p-value ``(1 + e) / (K + 1)``."""
    return float(np.sum(w * (zmax >= z)))


def fewest_draws(alpha: float = ALPHA) -> int:
    """The fewest draws ``K`` whose null can name a candidate at ``alpha``: the smallest
    p-value, ``1 / (K + 1)`` (:func:`decide`), must be under it (20 at 5 %)."""
    k = max(math.ceil(1.0 / alpha) - 1, 0)
    return k if alpha * (k + 1) > 1.0 else k + 1


def _critical(zmax: np.ndarray, w: np.ndarray, K: int, alpha: float) -> float | None:
    """The critical studentised value of the p-value rule with ``K`` draws: a statistic above
    it has ``p = (1 + e) / (K + 1) < alpha``, ``e`` the draw-weighted count of the replicates
    whose largest studentised reduction reaches it, scaled from the draws at hand to ``K``
    (the full null, when these are its first). None when ``K`` draws cannot give a p-value
    under ``alpha`` (fewer than ``1 / alpha - 1``)."""
    if K < fewest_draws(alpha) or zmax.size == 0:
        return None
    e_max = alpha * (K + 1) - 1.0  # the rule: e < e_max
    order = np.argsort(-zmax, kind="stable")
    frac = np.cumsum(w[order]) / float(np.sum(w))  # share of the draws at or above each value
    below = int(np.sum(frac * K < e_max - 1e-9))  # the top values the rule may exceed
    if below >= zmax.size:
        return float(zmax[order[-1]])
    return float(zmax[order[below]])


def _studentised(
    null: Mapping[str, np.ndarray], names: Sequence[str]
) -> tuple[dict[str, float], dict[str, float], np.ndarray]:
    """Each candidate's null mean and spread, and every replicate's largest studentised
    reduction over the candidates ``names`` (the max statistic, module doc). The spread is at
    least :data:`RESOLUTION_PCT`: a null of round-off (spread 1e-7 %) would studentise a gain
    of 2e-4 % to thousands."""
    m = {n: float(np.mean(null[n])) for n in names}
    s = {n: max(float(np.std(null[n], ddof=1)), RESOLUTION_PCT) for n in names}
    zmax = np.max(np.vstack([(null[n] - m[n]) / s[n] for n in names]), axis=0)
    return m, s, zmax


def final_p_bound(
    observed: Mapping[str, float],
    null: Mapping[str, np.ndarray],
    n_final: int,
    among: Collection[str] | None = None,
    draws: np.ndarray | None = None,
) -> float:
    """The smallest adjusted p-value a candidate of ``among`` (None: every candidate) could
    still reach when the null, of which ``null`` holds the first draws (``draws``: the draw of
    each replicate; None: every replicate its own), is completed to ``n_final`` draws that all
    fall below every observed statistic (module doc, "Stopping early"): ``(1 + e) / (n_final +
    1)`` with ``e`` the draws so far whose largest studentised reduction (over every candidate)
    reaches the candidate's, each draw counting the share of its replicates that do
    (:func:`decide`), minimised over ``among``; 1 when there is none."""
    names, _, null, draws = _family(observed, null, draws)
    among = [n for n in names if among is None or n in among]
    if not among:
        return 1.0
    m, s, zmax = _studentised(null, names)
    w, K = _draw_weights(draws, zmax.size)
    e = min(_exceeding(zmax, w, (observed[n] - m[n]) / s[n]) for n in among)
    return (1.0 + e) / (max(n_final, K) + 1.0)


FUTILITY_FACTOR = 2.0
"""The null's draws stop early when no candidate's adjusted p-value could end below this many
times ``alpha`` (:func:`cannot_name`). The bound :func:`final_p_bound` holds exactly only for a
fixed studentisation; the null's means and spreads still move as draws are added, and the
factor 2 leaves that room (module doc, "Stopping early")."""


def cannot_name(
    observed: Mapping[str, float],
    null: Mapping[str, np.ndarray],
    n_final: int,
    alpha: float = ALPHA,
    among: Collection[str] | None = None,
    draws: np.ndarray | None = None,
) -> bool:
    """Whether the null so far already rules out naming any candidate of ``among`` (None:
    every candidate; the others the rule's effect-size floor rules out,
    :func:`~gc_ocp.diagnosis.selection.contenders`) however its remaining replicates fall
    (:func:`final_p_bound` at least :data:`FUTILITY_FACTOR` ``alpha``): the sequential test's
    stop for futility, which can only turn a claim into no claim, never the reverse, so the
    family-wise rate of a false claim holds whatever the rule (module doc)."""
    return final_p_bound(observed, null, n_final, among, draws) >= FUTILITY_FACTOR * alpha


def null_looks(
    observed: Mapping[str, float],
    null: Mapping[str, np.ndarray],
    draws: np.ndarray,
    n_final: int,
    among: Collection[str] | None = None,
) -> list[list[float]]:
    """``[[draws, final_p_bound], ...]`` after every :data:`DRAWS_PER_LOOK` of the null's draws
    (``draws``: the draw of each replicate): what the stop for futility saw
    (:func:`cannot_name`, of the candidates ``among``); at the last, their smallest adjusted
    p-value. With every draw made, the record that checks the stop cost no claim."""
    ks = np.unique(draws)
    out = []
    for k in range(DRAWS_PER_LOOK, ks.size + 1, DRAWS_PER_LOOK):
        keep = np.isin(draws, ks[:k])
        first = {n: v[keep] for n, v in null.items()}
        out.append([k, final_p_bound(observed, first, n_final, among, draws[keep])])
    return out


def between_draw_sd(values: np.ndarray, draws: np.ndarray | None) -> float:
    """The spread of ``values`` between the groups ``draws`` (one-way random-effects analysis
    of variance: the variance of the group means less the within-group variance each mean
    carries, at least 0); 0 without groups or with fewer than two."""
    if draws is None:
        return 0.0
    values = np.asarray(values, float)
    groups = [values[draws == k] for k in np.unique(draws)]
    groups = [g for g in groups if g.size]
    if len(groups) < 2:
        return 0.0
    means = np.array([g.mean() for g in groups])
    within = [g.var(ddof=1) for g in groups if g.size > 1]
    per = np.mean([g.size for g in groups])
    noise = float(np.mean(within)) / per if within else 0.0
    return math.sqrt(max(float(means.var(ddof=1)) - noise, 0.0))


MIN_SPLIT_DRAWS = 16
"""Fewest mismatch draws from which the spread between them is split (:func:`systematic_sd`):
the covariances of a few draws are too noisy (with 8 draws and 4 stances a ratio of 0.71
came out as 0 in one run in six, in simulation); a null stopped earlier keeps all of its
between-draw spread as shared."""

SPLIT_QUANTILE = 0.8
"""The split's shared fraction is the upper 80 % limit of its bootstrap over the draws, not its
point estimate: the steps and the bound err towards more steps and "not decidable", rather
than promise decisions the noise of 16-32 draws' covariances made."""


def shared_fraction(
    shares: np.ndarray, weights: np.ndarray, within: np.ndarray | None = None, n_wild: int = 1
) -> float | None:
    """The fraction of the variance of the draws' summed shares that every held-out stance
    shares (:func:`systematic_sd`'s model): ``var(a) / var(sum)``, ``var(a)`` the off-diagonal
    covariances of the stances' shares over the draws over ``1 - sum w_s^2``. ``shares``:
    ``(draws, rows)`` each draw's mean share per stance; ``within``: ``(rows, rows)`` the mean
    covariance of the shares between a draw's ``n_wild`` replicates, whose ``1 / n_wild`` the
    draw means carry as noise and is taken off (as :func:`between_draw_sd` does). None when it
    cannot be made (fewer than two stances or three draws, no variance, a value not finite)."""
    shares = np.asarray(shares, float)
    if shares.ndim != 2 or shares.shape[1] < 2 or shares.shape[0] < 3:
        return None
    if not np.isfinite(shares).all():
        return None
    w = np.asarray(weights, float)
    w = w / max(float(w.sum()), 1e-300)
    q = 1.0 - float(np.sum(w * w))
    C = np.cov(shares, rowvar=False)
    if within is not None:
        C = C - np.asarray(within, float) / max(int(n_wild), 1)
    total = float(C.sum())
    if not (np.isfinite(total) and total > 0.0 and q > 1e-12):
        return None
    var_a = max(total - float(np.trace(C)), 0.0) / q
    return min(var_a / total, 1.0)


def systematic_sd(
    s_between: float,
    shares: np.ndarray,
    weights: np.ndarray,
    within: np.ndarray | None = None,
    n_wild: int = 1,
) -> float | None:
    """The part of the null's spread between mismatch draws ``s_between`` that every held-out
    stance shares [%]: what more stances of the same kind do not shrink (module doc, "Steps
    that would decide"). ``shares``, ``weights``, ``within``, ``n_wild``: the draws' stance
    shares (:class:`StanceShares`, :func:`shared_fraction`).

    A draw changes the law or the processing for every stance alike (a systematic part ``a``),
    but some of its members are drawn per stance (the markers' noise and drift, the units off
    the layout enter each stance differently) and a refit spreads a draw unevenly (the stances'
    own part ``e_s``). With stance ``s``'s share ``w_s (a + e_s)``, the covariance between two
    stances' shares over the draws is ``w_s w_t var(a)`` and the variance of their sum ``var(a)
    + sum w_s^2 var(e)``: so ``var(a)`` is the sum of the off-diagonal covariances over ``1 -
    sum w_s^2``, and its fraction of the sum's variance (the upper :data:`SPLIT_QUANTILE` limit
    of its bootstrap over the draws) scales ``s_between``. Stances held out together share
    their fold's training step, so their own parts correlate and count as shared: the split
    errs towards more steps there too. Measured before it (``docs/diagnosis.md``): from 4 to 8
    held-out stances the spread between draws of the same benchmark cases fell to 0.2-0.6 of
    itself for five of the seven candidates, and did not for friction.

    None when the split is not made (fewer than :data:`MIN_SPLIT_DRAWS` draws, fewer than two
    held-out stances, no spread between draws, values not finite): all of ``s_between`` then
    counts as shared, as it did before the split."""
    shares = np.asarray(shares, float)
    if not (s_between > 0.0) or shares.ndim != 2 or shares.shape[0] < MIN_SPLIT_DRAWS:
        return None
    if shared_fraction(shares, weights, within, n_wild) is None:
        return None
    rng = np.random.default_rng(0)  # the limit is a function of the draws, not of a seed
    boot = []
    for _ in range(400):  # the 80 % limit's Monte Carlo SE is ~0.02 in its quantile
        f = shared_fraction(
            shares[rng.integers(0, shares.shape[0], shares.shape[0])], weights, within, n_wild
        )
        boot.append(1.0 if f is None else f)  # a resample without variance: all shared
    return float(s_between) * math.sqrt(float(np.quantile(boot, SPLIT_QUANTILE)))


def power_shift(sigma: float, f: float) -> float:
    """How far above a study's threshold the observed gain must lie for a study of ``n`` held-out
    stances (``f = n0 / n``, ``n0`` the stances the gain was observed on, ``sigma`` its standard
    error there) to decide it with 80 % probability, the gain's own uncertainty included: the
    gain that study observes scatters by ``sigma sqrt(f)`` about the true gain, which the
    observed one estimates to within ``sigma``, so by ``sigma sqrt(1 + f)`` about the observed
    gain (the predictive probability of success, or *assurance*, of a study designed from a
    pilot; O'Hagan, Stevens and Campbell 2005, Pharmaceutical Statistics 4: 187-201).
    ``POWER_Z`` times that. Until 2026-12-03 the observed gain was taken as the true one
    (``sigma sqrt(f)``): at the true gain such a study decides 80 % of the time, but a pilot's
    gain is a noisy guess of it, and reruns at the sizes so predicted decided 10 of 15 truths
    (``docs/diagnosis.md``, *Steps that would decide*)."""
    return POWER_Z * sigma * math.sqrt(1.0 + f)


MAX_STANCES = 10**6
"""Beyond this many held-out stances a candidate is reported undecidable (a numerical cap of
the search, not a rule: the bound ``T - m > z_crit s_sys`` decides first)."""


def more_stances(
    t: float,
    m: float,
    s: float,
    sd: float | None,
    n0: int,
    crit: float,
    decided: bool,
    s_between: float = 0.0,
) -> int | None:
    """Further held-out stances that decide a candidate with 80 % assurance (module doc,
    :func:`power_shift`): ``t`` its
    observed reduction, ``m``, ``s`` the null's mean and spread, ``s_between`` the part of ``s``
    that more stances do not shrink (the part of the spread between mismatch draws every
    held-out stance shares, :func:`systematic_sd`, or all of that spread when it is not split;
    the rest of ``s`` shrinks as ``1/sqrt(n)``), ``sd`` the spread of its per-stance reductions,
    ``n0`` its held-out stances, ``crit`` the round's critical studentised value. None: no
    number decides it, or none can be said: no held-out stance (``n0`` 0, the in-sample
    fallback: a stance more on a foot makes the diagnosis a held-out one, whose statistic the
    in-sample scores do not predict), or a null without a finite spread or critical value (a
    null of one replicate: its SD is not a number, and every comparison with it false)."""
    if decided:
        return 0
    if not all(math.isfinite(v) for v in (t, m, s, crit, s_between, 0.0 if sd is None else sd)):
        return None
    gap = t - m
    s_between = min(max(s_between, 0.0), s)
    if gap <= 0 or n0 < 1 or gap <= crit * s_between:
        return None
    s_within2 = s * s - s_between * s_between
    sigma = s if sd is None else sd / math.sqrt(n0)

    def needed(n: float) -> float:  # what the gain must exceed with n held-out stances
        f = n0 / n
        return crit * math.sqrt(s_between**2 + s_within2 * f) + power_shift(sigma, f)

    # needed falls with n, to crit * s_between + 0.84 sigma
    return fewest_stances(n0, lambda n: needed(n) <= gap)


def fewest_stances(n0: int, decides: Callable[[int], bool]) -> int | None:
    """The further held-out stances beyond ``n0`` of the smallest study of which ``decides``
    holds (a condition that, once met, holds for every larger study, and not at ``n0``); None
    when not even :data:`MAX_STANCES` does. Doubling from ``n0 + 1``, then bisection. The test's
    steps (:func:`more_stances`) and the effect-size floor's
    (:func:`~gc_ocp.diagnosis.selection.floor_stances`) both search so."""
    if not decides(MAX_STANCES):
        return None
    hi = n0 + 1
    while not decides(hi):
        hi = min(2 * hi, MAX_STANCES)
    lo = n0  # not decided with the stances it has
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if decides(mid) else (mid, hi)
    return hi - n0


__all__ = (
    "ALPHA",
    "DEFAULT_FAMILY",
    "DRAWS_PER_LOOK",
    "FUTILITY_FACTOR",
    "fewest_stances",
    "MAX_STANCES",
    "MISMATCH_DRAWS",
    "N_REPLICATES",
    "PRACTICAL_FACTOR",
    "power_shift",
    "NullTest",
    "StanceShares",
    "between_draw_sd",
    "systematic_sd",
    "calibrate",
    "cannot_name",
    "decide",
    "fewest_draws",
    "final_p_bound",
    "more_stances",
    "null_draw",
    "null_looks",
    "observed_reductions",
    "onestep_null",
    "prior_pull",
    "prior_step",
    "perturbed",
    "replicate",
    "step_miss",
    "wild_residuals",
)
