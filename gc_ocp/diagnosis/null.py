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

**One Gauss-Newton step per fit.** Each model (the parent, every candidate) is linearised once:
its weighted residual ``r`` and Jacobian ``J`` at the parent's solution, with the candidate's
own variables at their neutral value (where the candidate *is* the parent; a candidate that
cannot reproduce the parent, such as the contact density, which replaces the five stiffnesses by
a smooth field, is linearised at its own fit instead). On a replicate the residual at that
point is ``r - r_parent - u`` (``u`` the replicate's weighted perturbation), and every fit of the
leave-one-stance-out scoring is the linear least-squares step from there, with the priors: the
training fit in all variables, then the held-out stance's nuisance under its prior. A variable
at a bound (a damping of 0) stays there when the step would cross it. So the null's held-out
reductions of all replicates cost a few matrix products, not thousands of fits;
``benchmarks/null_check.py`` compares them with full refits.

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
import warnings
from collections.abc import Mapping, Sequence

import numpy as np
import scipy.sparse as sp

from gc_ocp.diagnosis.compare import BLOCK_SECONDS
from gc_ocp.diagnosis.mismatch import (
    MismatchDraw,
    MismatchFamily,
    plate_processing,
    seen_motion,
    true_motion,
    truth_variant,
)
from gc_ocp.estimation.measurement import censored
from gc_ocp.estimation.problem import Weights, build_estimation, declare, frame_data
from gc_ocp.estimation.result import EstimationResult
from gc_ocp.estimation.starts import frozen_model, rescaled_start, with_lls_start
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

NESTED_RTOL = 1e-8
"""A candidate reproduces its parent when its residual at the parent's point (its own variables
neutral) differs from the parent's by less than this, relative to the residual's norm (round-off
of the per-frame functions: ~1e-14)."""


@dataclasses.dataclass(frozen=True)
class Linear:
    """One model linearised for the null (module doc).

    r: ``(n,)`` weighted data residual at the point, on the observed data; J: ``(n, nx)`` its
    Jacobian (CSR); prior_idx, pw, p0: the variables with a prior, their weights and the prior
    residual at the point; rows: per stance, its rows of ``r``; nuisance: per stance, the
    columns it re-estimates when held out (its stance-scope variables); at_lower / at_upper: the
    columns at a bound; nested: linearised at the parent's point (else at its own fit)."""

    r: np.ndarray
    J: sp.csr_matrix
    prior_idx: np.ndarray
    pw: np.ndarray
    p0: np.ndarray
    rows: tuple[slice, ...]
    nuisance: tuple[np.ndarray, ...]
    at_lower: np.ndarray
    at_upper: np.ndarray
    nested: bool
    x0: np.ndarray
    keys: dict  # {variable key: slice of x}

    def prior_residual(self, means: Mapping[tuple, np.ndarray] | None = None) -> np.ndarray:
        """The prior residual at the point, with the prior means of ``means`` (``{key:
        values}``, e.g. a fold's, whose law prior is centred on its training stances) in place
        of the model's."""
        if not means:
            return self.p0
        pm = self.x0[self.prior_idx] - self.p0 / self.pw
        pos = {c: k for k, c in enumerate(self.prior_idx)}
        pm = pm.copy()
        for key, v in means.items():
            sl = self.keys.get(key)
            if sl is None:
                continue
            for c, val in zip(range(sl.start, sl.stop), np.ravel(v), strict=True):
                if c in pos:
                    pm[pos[c]] = val
        return self.pw * (self.x0[self.prior_idx] - pm)


def _linear(problem, x: np.ndarray, nested: bool) -> Linear:
    r, J = problem.data_jacobian(x)
    pw_all = np.asarray(problem.prior_weights, float)
    idx = np.flatnonzero(pw_all > 0)
    p0 = pw_all[idx] * (x[idx] - np.asarray(problem.prior_means, float)[idx])
    rows, start = [], 0
    for b in problem.blocks:
        rows.append(slice(start, start + 6 * b.T))
        start += 6 * b.T
    stance_scope = {c.name for c in problem.model if c.scope == "stance"}
    nuisance = []
    for st in problem.stances:
        cols = [
            np.arange(s.start, s.start + s.size)
            for s in problem.variables.specs
            if s.key[0] in stance_scope and len(s.key) > 1 and s.key[1] == st.label
        ]
        nuisance.append(np.concatenate(cols) if cols else np.zeros(0, int))
    span = np.maximum(problem.ubx - problem.lbx, 1.0)
    tol = 1e-9 * span
    return Linear(
        r=np.asarray(r, float),
        J=J.tocsr(),
        prior_idx=idx,
        pw=pw_all[idx],
        p0=p0,
        rows=tuple(rows),
        nuisance=tuple(nuisance),
        at_lower=np.flatnonzero(np.isfinite(problem.lbx) & (x - problem.lbx <= tol)),
        at_upper=np.flatnonzero(np.isfinite(problem.ubx) & (problem.ubx - x <= tol)),
        nested=nested,
        x0=np.asarray(x, float),
        keys={s.key: s.slice for s in problem.variables.specs},
    )


def fold_prior_means(
    stances: Sequence[StanceData], model: tuple, plan: Sequence[Sequence[int]]
) -> list[dict[tuple, np.ndarray]]:
    """Per held-out stance of ``plan`` (groups of stances, :func:`~.compare.fold_plan`), the
    prior means of the model fitted on its training stances that
    differ from those on all stances (``{key: values}``): the contact law's prior is centred on
    the seed's linear least squares of the stances fitted (``with_lls_start``), so each fold's
    training fit has its own (the one-step fits of :func:`heldout_energy` use it)."""

    def means(sts):
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="LLS initialisation not possible")
            _, _, v = declare(list(sts), with_lls_start(model, list(sts)))
        pm, pw = v.vector("prior_mean"), v.vector("prior_weight")
        return {s.key: pm[s.slice] for s in v.specs if (pw[s.slice] > 0).any()}

    full = means(stances)
    out = []
    for group in plan:
        fold = means([st for k, st in enumerate(stances) if k not in group])
        diff = {k: v for k, v in fold.items() if k in full and not np.array_equal(v, full[k])}
        out += [diff] * len(group)  # per held-out stance, as the folds' scores
    return out


def linearize_parent(
    stances: Sequence[StanceData], model: tuple, full: EstimationResult, weights: Weights | None
) -> Linear:
    """The round's parent linearised at its own fit on all stances ``full``."""
    problem = build_estimation(list(stances), with_lls_start(model, list(stances)), weights)
    return _linear(problem, np.asarray(full.x, float), nested=True)


def linearize_child(
    stances: Sequence[StanceData],
    model: tuple,
    parent: EstimationResult,
    parent_r: np.ndarray,
    own: EstimationResult,
    weights: Weights | None,
) -> Linear:
    """A candidate linearised at the parent's solution ``parent`` with its own variables
    neutral (stored 0, else their initial values), when either reproduces the parent's residual
    ``parent_r``; at its own fit ``own`` otherwise (module doc)."""
    problem = build_estimation(list(stances), with_lls_start(model, list(stances)), weights)
    x = rescaled_start(parent, problem)
    old = {s.key for s in parent.variables}
    new = [s for s in problem.variables.specs if s.key not in old]
    scale = max(float(np.linalg.norm(parent_r)), 1e-300)
    candidates = [x.copy()]
    zero = x.copy()
    for s in new:
        zero[s.slice] = np.clip(0.0, s.lb, s.ub)
    candidates.insert(0, zero)
    for x0 in candidates:
        r, _ = problem.data_jacobian(x0)
        if r.shape == parent_r.shape and np.linalg.norm(r - parent_r) <= NESTED_RTOL * scale:
            return _linear(problem, x0, nested=True)
    return _linear(problem, rescaled_start(own, problem), nested=False)


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
        d = _null_draw(family.draw(rng, stances[0].layout).for_model(model), model)
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
    d0 = _step((J.T @ J).toarray() + np.diag(P2), Pp0[:, None], lin)[:, 0]
    return -np.asarray(J @ d0).ravel()


def _solve(G: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    eps = 1e-10 * max(float(np.trace(G)) / max(G.shape[0], 1), 1e-300)
    return np.linalg.solve(G + eps * np.eye(G.shape[0]), rhs)


MAX_ACTIVE_SET = 6
"""Variables at a bound up to which :func:`_step` solves the bounded step exactly (every face,
``2^k`` solves); beyond, those whose step crosses their bound are fixed in one pass."""


def _step(G: np.ndarray, rhs: np.ndarray, lin: Linear) -> np.ndarray:
    """``argmin_d 1/2 d^T G d + rhs^T d`` for every column of ``rhs``, with the variables at a
    bound at the point kept on their side of it (a convex QP: its optimum is the lowest of the
    feasible stationary points of the faces, each face fixing a subset of those variables at
    their bound)."""
    lo, hi = lin.at_lower, lin.at_upper
    bounded = np.concatenate([lo, hi])
    sign = np.concatenate([np.ones(lo.size), -np.ones(hi.size)])  # side: sign * d >= 0
    d = -_solve(G, rhs)
    if not bounded.size:
        return d
    if bounded.size > MAX_ACTIVE_SET:
        bad = (sign[:, None] * d[bounded]) < 0
        for j in np.flatnonzero(bad.any(axis=0)):
            free = np.setdiff1d(np.arange(G.shape[0]), bounded[bad[:, j]])
            d[:, j] = 0.0
            d[free, j] = -_solve(G[np.ix_(free, free)], rhs[free, j : j + 1])[:, 0]
        return d
    best = np.full(rhs.shape[1], np.inf)
    out = np.zeros_like(d)
    n = G.shape[0]
    for mask in range(2**bounded.size):
        fixed = np.array([(mask >> k) & 1 for k in range(bounded.size)], bool)
        free = np.setdiff1d(np.arange(n), bounded[fixed])
        dd = np.zeros_like(d)
        dd[free] = d[free] if not fixed.any() else -_solve(G[np.ix_(free, free)], rhs[free])
        ok = np.all(sign[~fixed, None] * dd[bounded[~fixed]] >= -1e-12, axis=0)
        q = 0.5 * np.sum(dd * (G @ dd), axis=0) + np.sum(rhs * dd, axis=0)
        take = ok & (q < best)
        out[:, take] = dd[:, take]
        best[take] = q[take]
    return out


def heldout_energy(
    lin: Linear,
    R0: np.ndarray,
    plan: Sequence[Sequence[int]],
    fold_means: Sequence[Mapping[tuple, np.ndarray]] | None = None,
) -> np.ndarray:
    """``(held-out stances, B)``: the held-out energy (data + nuisance prior) of the linearised
    model on every held-out stance of ``plan`` (groups held out together,
    :func:`~.compare.fold_plan`; one training step per group), for every column of ``R0`` (``(rows, B)``
    residuals at the point) (module doc). Without folds (one stance per foot), one row: the
    in-sample energy of the fit on all stances. ``fold_means``: per fold, the prior means of its
    training fit (:func:`fold_prior_means`)."""
    J = lin.J
    nx = J.shape[1]
    JTJ = (J.T @ J).toarray()
    JTR = np.asarray(J.T @ R0)
    P2 = np.zeros(nx)
    P2[lin.prior_idx] = lin.pw**2
    Pp0 = np.zeros(nx)
    Pp0[lin.prior_idx] = lin.pw * lin.p0
    if not plan:
        d = _step(JTJ + np.diag(P2), JTR + Pp0[:, None], lin)
        res = R0 + np.asarray(J @ d)
        p = lin.p0[:, None] + lin.pw[:, None] * d[lin.prior_idx]
        return (0.5 * (np.sum(res**2, axis=0) + np.sum(p**2, axis=0)))[None, :]
    prior_pos = {c: k for k, c in enumerate(lin.prior_idx)}
    E = np.zeros((sum(len(g) for g in plan), R0.shape[1]))
    j = 0  # row of E: held-out stances group by group, as the folds' scores
    for group in plan:
        rows = np.concatenate([np.arange(lin.rows[i].start, lin.rows[i].stop) for i in group])
        Jg = J[rows]
        G = JTJ - (Jg.T @ Jg).toarray() + np.diag(P2)
        Pp = np.zeros(nx)
        Pp[lin.prior_idx] = lin.pw * lin.prior_residual(fold_means[j] if fold_means else None)
        rhs = JTR - np.asarray(Jg.T @ R0[rows]) + Pp[:, None]
        d_train = _step(G, rhs, lin)
        for i in group:
            E[j] = _heldout_stance(lin, J, R0, i, d_train, prior_pos)
            j += 1
    return E


def _heldout_stance(lin: Linear, J, R0: np.ndarray, i: int, d_train, prior_pos) -> np.ndarray:
    """``(B,)``: the held-out energy of stance ``i`` at the training step ``d_train``, its
    nuisance re-estimated from the point (:func:`heldout_energy`)."""
    rows = lin.rows[i]
    Jh = J[rows]
    d = d_train.copy()
    z = lin.nuisance[i]
    d[z] = 0.0  # the held-out stance's nuisance is re-estimated below, from the point
    a = R0[rows] + np.asarray(Jh @ d)
    Jz = Jh[:, z].toarray()
    kz = np.array([prior_pos[c] for c in z], int)
    pwz, p0z = lin.pw[kz], lin.p0[kz]
    Hz = Jz.T @ Jz + np.diag(pwz**2)
    dz = -_solve(Hz, Jz.T @ a + (pwz * p0z)[:, None])
    res = a + Jz @ dz
    pz = p0z[:, None] + pwz[:, None] * dz
    return 0.5 * (np.sum(res**2, axis=0) + np.sum(pz**2, axis=0))


def energies(
    parent: Linear,
    children: Mapping[str, Linear],
    perturbations: np.ndarray,
    plan: Sequence[Sequence[int]],
    occam: Mapping[str, np.ndarray] | None = None,
    fold_means: Sequence[Mapping[tuple, np.ndarray]] | None = None,
) -> dict[str, np.ndarray]:
    """``{"parent" and every child: (folds, B) held-out energies}`` on the replicates whose
    weighted perturbations are the columns of ``perturbations`` (module doc; the observed data
    are ``perturbations = -parent.r``). ``occam``: per model, the Occam term of each held-out
    fit (``"parent"``; a nested child's is the parent's: at the neutral point it *is* the
    parent), a constant of the linearisation."""
    occam = occam or {}
    R0p = -perturbations
    base = np.asarray(occam.get("parent", 0.0), float).reshape(-1, 1)
    out = {"parent": heldout_energy(parent, R0p, plan, fold_means) + base}
    for name, lin in children.items():
        shift = (lin.r - parent.r)[:, None]
        own = base if lin.nested else np.asarray(occam.get(name, base), float).reshape(-1, 1)
        out[name] = heldout_energy(lin, shift + R0p, plan, fold_means) + own
    return out


def reductions(E: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``{child: (B,) reduction [%] of the combined score over the parent}`` from
    :func:`energies` (``1 - sqrt(E_child / E_parent)``, summed over the folds, as
    :func:`~gc_ocp.diagnosis.compare.score`)."""
    ep = np.maximum(E["parent"].sum(axis=0), 1e-300)
    return {
        n: 100.0 * (1.0 - np.sqrt(np.maximum(e.sum(axis=0), 0.0) / ep))
        for n, e in E.items()
        if n != "parent"
    }


def per_stance_sd(E: Mapping[str, np.ndarray]) -> dict[str, float | None]:
    """Spread [%] of the per-fold reductions of the observed data (``E`` of one column), None
    with fewer than two folds."""
    ep = E["parent"][:, 0]
    out: dict[str, float | None] = {}
    for n, e in E.items():
        if n == "parent":
            continue
        per = 100.0 * (1.0 - np.sqrt(np.maximum(e[:, 0], 0.0) / np.maximum(ep, 1e-300)))
        out[n] = float(np.std(per, ddof=1)) if per.size >= 2 else None
    return out


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
    n_held = max(sum(len(g) for g in plan), 1)
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
    "Linear",
    "NullTest",
    "calibrate",
    "decide",
    "energies",
    "fold_prior_means",
    "heldout_energy",
    "linearize_child",
    "linearize_parent",
    "mismatch_perturbations",
    "per_stance_sd",
    "prior_pull",
    "reductions",
    "replicate",
    "wild_residuals",
)
