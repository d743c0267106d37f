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
form, filter cutoffs, marker drift, unit positions). Censored samples (below the plate's
threshold) carry neither: the plate recorded nothing there.

**One Gauss-Newton step per fit** (:mod:`.onestep`): every model is linearised once and every fit
of the held-out scoring of a replicate is a linear least-squares step from there, so the null's
held-out reductions of all replicates cost a few matrix products, not thousands of fits.

**Decision.** For every candidate, its null reductions give a mean ``m`` and spread ``s``; the
observed reduction is studentised, ``z = (T - m) / s``, and compared with the distribution of
the *largest* studentised null reduction over the round's candidates (Westfall and Young's
max statistic), so that the family-wise rate of a false claim among all candidates is at most
``alpha``: the adjusted p-value is the share of replicates whose largest ``z`` reaches the
observed one.

**Steps that would decide.** With ``n`` held-out stances the null's spread and the observed
reduction's sampling error both shrink as ``1/sqrt(n)``, its mean (what mismatch alone gives)
does not. A candidate whose reduction ``T`` exceeds ``m`` is decided (80 % power) once
``sqrt(n / n0) >= (z_crit s + 0.84 sigma) / (T - m)``; one whose reduction does not exceed
``m`` cannot be told from the mismatch by more steps of the same kind.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from gc_ocp.diagnosis.compare import BLOCK_SECONDS, held_out
from gc_ocp.diagnosis.mismatch import (
    MismatchDraw,
    MismatchFamily,
    plate_processing,
    seen_motion,
    true_motion,
    truth_variant,
)
from gc_ocp.diagnosis.onestep import Linear, energies, per_stance_sd, reductions, step
from gc_ocp.estimation.measurement import censored
from gc_ocp.estimation.problem import Weights, build_estimation, declare, frame_data
from gc_ocp.estimation.result import EstimationResult
from gc_ocp.estimation.starts import frozen_model, with_lls_start
from gc_ocp.estimation.synthetic import plate_signal
from gc_ocp.stance import StanceData

ALPHA = 0.05
"""Family-wise rate of a false claim among a round's candidates."""

N_REPLICATES = 500
"""Null replicates per round (the adjusted p-value's resolution is 1/(B+1))."""

PRACTICAL_FACTOR = 4
"""A candidate is called *inconclusive* (listed in the summary's verdict) when the further
stances that would decide it are at most this many times the held-out stances it has: a
follow-up of at most five times the data. Beyond, its row still gives the number."""

POWER_Z = 0.8416
"""Standard normal quantile of the 80 % power of the steps-needed calculation."""


def wild_residuals(
    parent: Linear,
    fits: Sequence[dict],
    n: int,
    rng: np.random.Generator,
    frame_rate: float,
) -> np.ndarray:
    """``(rows, n)`` perturbations: the parent's residual with the sign of each block of
    :data:`BLOCK_SECONDS` flipped at random (module doc); zero on censored samples (``fits``:
    the parent's stance fits, for their measured wrench and threshold)."""
    L = max(1, int(round(BLOCK_SECONDS * frame_rate)))
    out = np.zeros((parent.r.size, n))
    for rows, f in zip(parent.rows, fits, strict=True):
        e = parent.r[rows].reshape(-1, 6)  # (T, 6) frame-major
        T = e.shape[0]
        keep = ~censored(f["measured"], f.get("censor_below", 0.0))
        nb = int(np.ceil(T / L))
        offset = rng.integers(0, L, n)  # random block phase: no fixed block edges
        signs = rng.choice([-1.0, 1.0], size=(nb + 1, n))
        blk = (np.arange(T)[:, None] + offset[None, :]) // L  # (T, n)
        s = np.take_along_axis(signs, blk, axis=0)  # (T, n)
        pert = e[:, :, None] * (s * keep[:, None])[:, None, :]  # (T, 6, n)
        out[rows] = pert.reshape(6 * T, n)
    return out


def replicate(
    stances: Sequence[StanceData], fits: Sequence[dict], perturbation: np.ndarray, weights: Weights
) -> list[StanceData]:
    """The replicate whose weighted perturbation is ``perturbation`` (``(rows,)``, a column of
    :func:`wild_residuals`) as stances a full fit can take: the parent's wrench (``fits``, its
    stance fits) plus the perturbation in N and N m, and the plate signal made from it (what a
    clock-offset model resamples): to check the one-step null against full refits."""
    out, start = [], 0
    for st, f in zip(stances, fits, strict=True):
        n = 6 * st.n
        u = perturbation[start : start + n].reshape(st.n, 6) / weights.inverse_sigmas(
            st.body_weight
        )
        start += n
        m = np.asarray(f["model"], float) + u
        pt, pw = plate_signal(st.time, m)
        out.append(dataclasses.replace(st.with_measured(m), plate_time=pt, plate_wrench=pw))
    return out


MISMATCH_DRAWS = 64
"""Draws of the mismatch family per round: replicate ``b`` adds draw ``b mod K`` (each draw a
systematic pattern; the wild residuals vary around it). The null is a mixture over the draws,
so its tail at ``alpha`` is resolved by the draws, not by the replicates: with 16 draws the 5 %
tail holds less than one draw, and whether a strong member (a friction regularisation twice as
wide) is among them decides the p-value. Measured on a "none" case of three BTS trials whose
draw widened the friction regularisation 1.65 times: friction's family-wise p was 0.036, 0.088
and 0.092 with three sets of 16 draws, 0.113 / 0.142 with 64, 0.119 / 0.076 with 128. 64 draws
put about three in the tail; each costs one wrench evaluation of the stances (~0.1 s per
stance)."""

DEFAULT_FAMILY = MismatchFamily()
"""The mismatch family the null allows unless told otherwise (``docs/diagnosis.md``)."""


def null_draw(
    family: MismatchFamily, rng: np.random.Generator, layout, model: tuple
) -> MismatchDraw:
    """A draw of ``family`` (sole ``layout``) as a replicate of the null for ``model`` takes it:
    restricted to the model (:meth:`MismatchDraw.for_model`) and to the members the null adds
    (:func:`_null_draw`)."""
    return _null_draw(family.draw(rng, layout).for_model(model), model)


def _null_draw(d: MismatchDraw, model: tuple) -> MismatchDraw:
    """The members of draw ``d`` a replicate of the null adds (:func:`mismatch_perturbations`):
    the law's smoothing and friction forms, the plate's hum and the markers' low-pass. Left out:
    the plate threshold (the measurement model finds it in the data and censors it), the marker
    noise and soft-tissue drift (the wild residuals are the observed data's own, kinematic noise
    included, and the pose correction absorbs a rigid per-stance drift), and, for a model with
    sole registration, the units off the layout (the sole correction has exactly that freedom: a
    truth with moved units is the parent with other sole offsets). The last two are large
    changes of the force (units 2 mm off: 8-87 % BW) that a refit absorbs almost entirely
    (``docs/diagnosis.md``, mismatch family): one Gauss-Newton step would leave their
    second-order terms, an artefact of the step, not a mismatch."""
    d = dataclasses.replace(d.without_pose_error(), threshold_n=0.0)
    return d.without_unit_offsets() if any(c.name == "sole" for c in model) else d


def mismatch_perturbations(
    stances: Sequence[StanceData],
    model: tuple,
    full: EstimationResult,
    weights: Weights | None,
    family: MismatchFamily,
    rng: np.random.Generator,
    n_draws: int = MISMATCH_DRAWS,
) -> np.ndarray:
    """``(rows, n_draws)`` weighted perturbations of mismatch-family draws (module doc): for
    each draw, how the plate data of the fitted parent (``model`` frozen at ``full``) walking
    the subject's motion differ from what the parent predicts from the kinematics a fitter would
    see, ``W (m_mismatched - F_parent(seen))``: the law's drawn smoothing and friction forms and
    the plate's hum, against the parent on the low-passed kinematics (the members of
    :func:`_null_draw`). Zero on censored samples. Members that are a candidate of the parent's
    model are left out (:meth:`MismatchDraw.for_model`)."""
    weights = weights or Weights()
    stances = list(stances)
    truth = frozen_model(with_lls_start(model, stances), full)
    # the parent on other kinematics of the same frames: only the per-frame data change
    ps = build_estimation(stances, truth, weights, compile=False)
    Y0 = [b.Y(np.zeros(ps.x0.size)) for b in ps.blocks]
    cols = []
    for _ in range(n_draws):
        d = null_draw(family, rng, stances[0].layout, model)
        true = true_motion(stances, d)
        pb = build_estimation(true, truth_variant(truth, d), weights, compile=False)
        w_true = pb.stance_wrenches(np.zeros(pb.x0.size))
        recorded = plate_processing(
            [st.with_measured(w) for st, w in zip(stances, w_true, strict=True)], d, rng
        )
        configured, seen, _ = declare(seen_motion(stances, d, rng), truth)
        w_seen = [
            np.asarray(b.fm.frame.map(b.T)(frame_data(st, weights, b.fm, configured), y)[1]).T
            for b, st, y in zip(ps.blocks, seen, Y0, strict=True)
        ]
        col = []
        for st, rec, ws in zip(stances, recorded, w_seen, strict=True):
            u = (rec.measured - ws) * weights.inverse_sigmas(st.body_weight)
            u[censored(st.measured, st.censor_below)] = 0.0
            col.append(u.ravel())
        cols.append(np.concatenate(col))
    return np.column_stack(cols)


def prior_pull(lin: Linear) -> np.ndarray:
    """``(rows,)`` the weighted perturbation that makes the replicates' truth the parent
    *debiased* for its priors (module doc): refitted to its own noise-free prediction, the parent
    moves on by ``d0`` (its priors pull it further, as they pulled the fit of the observed data
    away from the truth that made them); the replicates are made from ``x_hat - d0`` instead of
    ``x_hat``, so that their fits carry the priors' bias as the observed fit does (a
    bias-corrected parametric bootstrap). Without it, a candidate that absorbs the misfit a
    prior leaves (damping, under the sole prior, on a truth whose sole offsets are 4-5 prior
    sigmas) gains on the observed data and not on the replicates: on eight noise-only datasets
    of the bundled motion damping was named in five."""
    J = lin.J
    nx = J.shape[1]
    P2 = np.zeros(nx)
    P2[lin.prior_idx] = lin.pw**2
    Pp0 = np.zeros(nx)
    Pp0[lin.prior_idx] = lin.pw * lin.p0
    d0 = step((J.T @ J).toarray() + np.diag(P2), Pp0[:, None], lin)[:, 0]
    return -np.asarray(J @ d0).ravel()


def calibrate(
    parent: Linear,
    parent_fits: Sequence[dict],
    children: Mapping[str, Linear],
    plan: Sequence[Sequence[int]],
    occam: Mapping[str, np.ndarray] | None = None,
    mismatch: np.ndarray | None = None,
    n_replicates: int = N_REPLICATES,
    seed: int = 0,
    frame_rate: float = 100.0,
    alpha: float = ALPHA,
    fold_means: Sequence[Mapping[tuple, np.ndarray]] | None = None,
) -> dict[str, NullTest]:
    """The calibrated decision of a round (module doc): ``{candidate: NullTest}``.
    ``parent_fits``: the parent's stance fits (censored samples); ``mismatch``: ``(rows, K)``
    weighted perturbations of mismatch-family draws (:mod:`.mismatch`), replicate ``b`` adding
    column ``b mod K`` (None: noise only); ``fold_means``: :func:`fold_prior_means`."""
    if not children:
        return {}
    rng = np.random.default_rng(seed)
    U = wild_residuals(parent, parent_fits, n_replicates, rng, frame_rate)
    U = U + prior_pull(parent)[:, None]
    if mismatch is not None and mismatch.size:
        U = U + mismatch[:, np.arange(n_replicates) % mismatch.shape[1]]
    # the observed data are one more column (perturbation -r): one pass of the linear algebra
    E = energies(parent, children, np.column_stack([U, -parent.r]), plan, occam, fold_means)
    null = reductions({n: e[:, :-1] for n, e in E.items()})
    E_obs = {n: e[:, -1:] for n, e in E.items()}
    observed = {n: float(v[0]) for n, v in reductions(E_obs).items()}
    n_held = max(len(held_out(plan)), 1)
    return decide(observed, null, per_stance_sd(E_obs), n_held, alpha)


@dataclasses.dataclass(frozen=True)
class NullTest:
    """The calibrated decision of one candidate (module doc): observed reduction [%], the null's
    mean and spread [%], the studentised statistic, the family-wise adjusted p-value, the
    critical studentised value of the round, and the further held-out stances that would decide
    it at 80 % power (0: decided; None: more steps of the same kind would not)."""

    observed_pct: float
    null_mean_pct: float
    null_sd_pct: float
    z: float
    p_adjusted: float
    z_critical: float
    more_stances: int | None
    n_heldout: int = 0

    @property
    def practical(self) -> bool:
        """The further stances that would decide it are within :data:`PRACTICAL_FACTOR` times
        the held-out stances it had."""
        return bool(self.more_stances) and self.more_stances <= PRACTICAL_FACTOR * max(
            self.n_heldout, 1
        )

    def to_json(self) -> dict:
        return dataclasses.asdict(self)


def decide(
    observed: Mapping[str, float],
    null: Mapping[str, np.ndarray],
    per_stance_sd: Mapping[str, float | None],
    n_heldout: int,
    alpha: float = ALPHA,
) -> dict[str, NullTest]:
    """The max-statistic decision over the round's candidates (module doc). ``observed``:
    ``{candidate: held-out reduction [%]}``; ``null``: their null reductions (same replicates
    for all); ``per_stance_sd``: the spread of a candidate's per-stance reductions (the
    sampling error of the observed one is ``sd / sqrt(n_heldout)``; None: the null's spread is
    used)."""
    names = [n for n in observed if n in null]
    if not names:
        return {}
    m = {n: float(np.mean(null[n])) for n in names}
    s = {n: max(float(np.std(null[n], ddof=1)), 1e-12) for n in names}
    zmax = np.max(np.vstack([(null[n] - m[n]) / s[n] for n in names]), axis=0)
    crit = float(np.quantile(zmax, 1.0 - alpha))
    out = {}
    for n in names:
        z = (observed[n] - m[n]) / s[n]
        p = float((1 + np.sum(zmax >= z)) / (zmax.size + 1))
        out[n] = NullTest(
            observed_pct=float(observed[n]),
            null_mean_pct=m[n],
            null_sd_pct=s[n],
            z=float(z),
            p_adjusted=p,
            z_critical=crit,
            more_stances=_more_stances(
                observed[n], m[n], s[n], per_stance_sd.get(n), n_heldout, crit, p < alpha
            ),
            n_heldout=n_heldout,
        )
    return out


def _more_stances(
    t: float, m: float, s: float, sd: float | None, n0: int, crit: float, decided: bool
) -> int | None:
    """Further held-out stances that decide a candidate at 80 % power (module doc)."""
    if decided:
        return 0
    if t <= m or n0 < 1:
        return None
    sigma = s if sd is None else sd / math.sqrt(n0)
    n = n0 * ((crit * s + POWER_Z * sigma) / (t - m)) ** 2
    return max(1, math.ceil(n - n0))


__all__ = (
    "ALPHA",
    "DEFAULT_FAMILY",
    "MISMATCH_DRAWS",
    "N_REPLICATES",
    "PRACTICAL_FACTOR",
    "NullTest",
    "calibrate",
    "decide",
    "mismatch_perturbations",
    "null_draw",
    "prior_pull",
    "replicate",
    "wild_residuals",
)
