"""One Gauss-Newton step per fit: the linearised models of the calibrated test (:mod:`.null`)
and their held-out scores on any number of replicates at once.

Each model (the parent, every candidate) is linearised once:
its weighted residual ``r`` and Jacobian ``J`` at the parent's solution, with the candidate's
own variables at their neutral value (where the candidate *is* the parent; a candidate that
cannot reproduce the parent, such as the contact density, which replaces the five stiffnesses by
a smooth field, is linearised at its own fit instead, as is one whose class declares
:attr:`~gc_ocp.estimation.components.base.Component.one_step_from_own_fit`, the clock offset,
whose response is too curved at its neutral value for one step from there). On a replicate the
residual at that
point is ``r - r_parent - u`` (``u`` the replicate's weighted perturbation), and every fit of the
leave-one-stance-out scoring is the linear least-squares step from there, with the priors: the
training fit in all variables, then the held-out stance's nuisance under its prior (with its
trial's trial-scope variables when its trial has no training stance, as a refit). A variable
at a bound (a damping of 0) stays there when the step would cross it. So the null's held-out
reductions of all replicates cost a few matrix products, not thousands of fits;
``benchmarks/null_check.py`` compares them with full refits.

Groups of stances held out together (:func:`~gc_ocp.diagnosis.compare.fold_plan`) get one
training step per group and one nuisance step per held-out stance.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from gc_ocp.diagnosis.compare import held_out
from gc_ocp.estimation.components import REGISTRY
from gc_ocp.estimation.problem import Weights, build_estimation, declare
from gc_ocp.estimation.result import EstimationResult
from gc_ocp.estimation.starts import neutral_points, rescaled_start, with_lls_start
from gc_ocp.stance import StanceData

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
    columns at a bound; nested: linearised at the parent's point (else at its own fit); trials,
    trial_cols: per stance, its trial and the columns of its trial's trial-scope variables with a
    prior (a
    clock offset, a belt speed: re-estimated on a held-out stance whose trial has no training
    stance, as a refit does, :func:`heldout_energy`)."""

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
    trials: tuple[str, ...] = ()  # per stance, its trial
    trial_cols: tuple[np.ndarray, ...] = ()  # per stance, its trial's trial-scope columns

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


def linearize(problem, x: np.ndarray, nested: bool = True) -> Linear:
    """``problem`` (an :class:`~gc_ocp.estimation.problem.EstimationProblem`) linearised at
    ``x``; ``nested``: at the parent's point (module doc)."""
    r, J = problem.data_jacobian(x)
    pw_all = np.asarray(problem.prior_weights, float)
    has_prior = pw_all > 0  # (a held-out stance re-estimates only variables with a prior)
    idx = np.flatnonzero(has_prior)
    p0 = pw_all[idx] * (x[idx] - np.asarray(problem.prior_means, float)[idx])
    rows, start = [], 0
    for b in problem.blocks:
        rows.append(slice(start, start + 6 * b.T))
        start += 6 * b.T
    nuisance = problem.stance_columns()
    trial_cols = tuple(c[has_prior[c]] for c in problem.trial_columns())
    width = problem.ubx - problem.lbx  # a one-sided bound: the value's own scale instead
    span = np.where(np.isfinite(width), np.maximum(width, 1.0), np.maximum(np.abs(x), 1.0))
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
        trials=tuple(st.trial for st in problem.stances),
        trial_cols=trial_cols,
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
        _, _, v = declare(list(sts), with_lls_start(model, list(sts), quiet=True))
        pm, pw = v.vector("prior_mean"), v.vector("prior_weight")
        return {s.key: pm[s.slice] for s in v.specs if (pw[s.slice] > 0).any()}

    full = means(stances)
    out = []
    for group in plan:
        fold = means([st for k, st in enumerate(stances) if k not in group])
        diff = {k: v for k, v in fold.items() if k in full and not np.array_equal(v, full[k])}
        out += [diff] * len(group)  # per held-out stance, as the folds' scores
    return out


def _problem(stances, model, weights):
    return build_estimation(list(stances), with_lls_start(model, list(stances)), weights)


def linearize_parent(
    stances: Sequence[StanceData],
    model: tuple,
    full: EstimationResult,
    weights: Weights | None,
) -> Linear:
    """The round's parent linearised at its own fit on all stances ``full``."""
    problem = _problem(stances, model, weights)
    return linearize(problem, np.asarray(full.x, float), nested=True)


def nested_point(problem, parent: EstimationResult, parent_r: np.ndarray) -> np.ndarray | None:
    """The point of a candidate's ``problem`` that reproduces the parent's residual
    ``parent_r`` at the parent's solution ``parent`` (the candidate's own variables neutral:
    stored 0, else their initial values), None when neither does (module doc)."""
    scale = max(float(np.linalg.norm(parent_r)), 1e-300)
    for x0 in neutral_points(parent, problem):
        r = problem.data_residuals(x0)
        if r.shape == parent_r.shape and np.linalg.norm(r - parent_r) <= NESTED_RTOL * scale:
            return x0
    return None


def from_own_fit(name: str) -> bool:
    """Whether the candidate effect ``name`` is linearised at its own fit whether or not it
    can reproduce its parent (its class's
    :attr:`~gc_ocp.estimation.components.base.Component.one_step_from_own_fit`)."""
    cls = REGISTRY.get(name)
    return bool(cls is not None and cls.one_step_from_own_fit)


def linearize_child(
    stances: Sequence[StanceData],
    model: tuple,
    parent: EstimationResult,
    parent_r: np.ndarray,
    own: EstimationResult,
    weights: Weights | None,
    own_fit: bool = False,
) -> Linear:
    """A candidate linearised at the parent's solution ``parent`` with its own variables
    neutral (:func:`nested_point`); at its own fit ``own`` when it cannot reproduce the
    parent or when ``own_fit`` (:func:`from_own_fit`) (module doc)."""
    problem = _problem(stances, model, weights)
    x0 = None if own_fit else nested_point(problem, parent, parent_r)
    if x0 is not None:
        return linearize(problem, x0, nested=True)
    return linearize(problem, rescaled_start(own, problem), nested=False)


def _solve(G: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """``(G + eps I)^-1 rhs`` for a symmetric positive semi-definite ``G`` (a Gauss-Newton
    matrix with priors): Cholesky (half an LU's work; these solves are most of a null draw's
    scoring), LU where round-off leaves the factor undefined."""
    eps = 1e-10 * max(float(np.trace(G)) / max(G.shape[0], 1), 1e-300)
    Ge = G + eps * np.eye(G.shape[0])
    try:
        return sla.cho_solve(sla.cho_factor(Ge, check_finite=False), rhs, check_finite=False)
    except np.linalg.LinAlgError:
        return np.linalg.solve(Ge, rhs)


MAX_ACTIVE_SET = 6
"""Variables at a bound up to which :func:`step` solves the bounded step by visiting every face
(``2^k`` of them, all replicates at once); beyond, by a primal active-set method per replicate."""


def step(G: np.ndarray, rhs: np.ndarray, lin: Linear) -> np.ndarray:
    """:func:`bounded_step` with the bounds of ``lin`` (the variables at a bound at the point)."""
    return bounded_step(G, rhs, lin.at_lower, lin.at_upper)


def bounded_step(
    G: np.ndarray, rhs: np.ndarray, at_lower: np.ndarray, at_upper: np.ndarray
) -> np.ndarray:
    """``argmin_d 1/2 d^T G d + rhs^T d`` for every column of ``rhs``, with the variables
    ``at_lower`` (``at_upper``), at their lower (upper) bound at the point, kept on their side
    of it (a convex QP: its optimum is the lowest of the feasible stationary points of the faces,
    each face fixing a subset of those variables at their bound).

    One factorisation serves every face: with ``d0 = -G^-1 rhs`` and ``W = G^-1 E`` (``E`` the
    unit columns of the ``k`` bounded variables), fixing a subset ``F`` at 0 gives
    ``d = d0 - W_F mu`` with ``(G^-1)_FF mu = d0_F`` (the Lagrange multipliers of ``d_F = 0``),
    and raises the objective by ``1/2 d0_F^T mu``: a ``|F|``-sized solve per face instead of an
    ``n``-sized one (the same optimum to round-off). A variable at both bounds (``lb == ub``) is
    fixed on every face."""
    at_lower, at_upper = np.asarray(at_lower, int), np.asarray(at_upper, int)
    pinned = np.intersect1d(at_lower, at_upper)  # lb == ub: fixed on every face
    lo, hi = np.setdiff1d(at_lower, pinned), np.setdiff1d(at_upper, pinned)
    bounded = np.concatenate([lo, hi, pinned]).astype(int)
    if not bounded.size:
        return -_solve(G, rhs)
    sign = np.concatenate([np.ones(lo.size), -np.ones(hi.size)])  # side: sign * d >= 0
    k, B = lo.size + hi.size, rhs.shape[1]  # the faces: subsets of the first k
    E = np.zeros((G.shape[0], bounded.size))
    E[bounded, np.arange(bounded.size)] = 1.0
    sol = _solve(G, np.hstack([rhs, E]))
    d0, W = -sol[:, :B], sol[:, B:]
    S = W[bounded]  # (G^-1) restricted to the bounded variables
    always = np.r_[np.zeros(k, bool), np.ones(pinned.size, bool)]

    def face(free_fixed: np.ndarray, cols=slice(None)) -> tuple[np.ndarray, np.ndarray]:
        """The stationary point of the face fixing ``free_fixed`` (of the first ``k``) and the
        pinned variables, and its objective raise, for the columns ``cols``."""
        fixed = always.copy()
        fixed[:k] = free_fixed
        a = d0[:, cols]
        if not fixed.any():
            return a, np.zeros(a.shape[1])
        mu = np.linalg.solve(S[np.ix_(fixed, fixed)], a[bounded[fixed]])
        d = a - W[:, fixed] @ mu
        d[bounded[fixed]] = 0.0
        return d, 0.5 * np.sum(a[bounded[fixed]] * mu, axis=0)

    bounded_k = bounded[:k]
    if k > MAX_ACTIVE_SET:
        return np.column_stack(
            [_active_set(G, rhs[:, j], face, bounded_k, sign, j) for j in range(B)]
        )
    best = np.full(B, np.inf)
    out = np.zeros_like(d0)
    for mask in range(2**k):
        fixed = np.array([(mask >> b) & 1 for b in range(k)], bool)
        dd, raise_ = face(fixed)
        ok = np.all(sign[~fixed, None] * dd[bounded_k[~fixed]] >= -1e-12, axis=0)
        take = ok & (raise_ < best)
        out[:, take] = dd[:, take]
        best[take] = raise_[take]
    return out


def _active_set(G, g0, face, bounded_k, sign, j) -> np.ndarray:
    """Column ``j`` of :func:`bounded_step` by the primal active-set method for a convex QP
    (Nocedal and Wright 2006, algorithm 16.3): from ``d = 0`` (feasible: every bounded variable
    at its bound), with all of them fixed; step towards the stationary point of the current face,
    stopping at the first bound crossed (which is then fixed); at a face's stationary point,
    free the fixed variable whose multiplier has the wrong sign (the objective falls when it
    leaves its bound), or stop: every multiplier has its sign, the optimum. Finite: the
    objective falls at every change of the face, and no face is visited twice."""
    k = bounded_k.size
    fixed = np.ones(k, bool)
    d = np.zeros(G.shape[0])
    for _ in range(10 * k + 10):  # each face at most once; a safeguard against round-off
        target = face(fixed, slice(j, j + 1))[0][:, 0]
        p = target - d
        if np.max(np.abs(p), initial=0.0) <= 1e-12 * (1.0 + np.max(np.abs(d), initial=0.0)):
            grad = G @ d + g0  # at a bound, sign * grad >= 0: leaving it raises the objective
            m = sign * grad[bounded_k]
            m[~fixed] = np.inf
            i = int(np.argmin(m))
            if m[i] >= -1e-12 * (1.0 + np.max(np.abs(grad))):
                return d
            fixed[i] = False
            continue
        sp = sign * p[bounded_k]
        blocking = (~fixed) & (sp < 0)
        alpha, hit = 1.0, -1
        if blocking.any():
            ratios = np.full(k, np.inf)
            ratios[blocking] = (sign * d[bounded_k])[blocking] / -sp[blocking]
            hit = int(np.argmin(ratios))
            alpha = min(1.0, float(ratios[hit]))
        d = d + alpha * p
        if alpha < 1.0:
            fixed[hit] = True
            d[bounded_k[hit]] = 0.0
    return d


def heldout_energy(
    lin: Linear,
    R0: np.ndarray,
    plan: Sequence[Sequence[int]],
    fold_means: Sequence[Mapping[tuple, np.ndarray]] | None = None,
    charge: np.ndarray | None = None,
) -> np.ndarray:
    """``(held-out stances, B)``: the held-out energy (data + nuisance prior) of the linearised
    model on every held-out stance of ``plan`` (groups held out together,
    :func:`~.compare.fold_plan`; one training step per group), for every column of ``R0`` (``(rows, B)``
    residuals at the point) (module doc). Without folds (one stance per foot), one row: the
    in-sample energy of the fit on all stances. ``fold_means``: per fold, the prior means of its
    training fit (:func:`fold_prior_means`).

    A held-out stance whose trial has no stance in its fold's training re-estimates its trial's
    trial-scope variables with its nuisance, as a refit of it does (a frozen model estimates
    what it was not given). ``charge``: columns whose Occam term is not in the constants of
    :func:`energies` (a nested candidate's own, where the parent's terms stand for its): when such
    a column is re-estimated so, its part of ``1/2 log det H_z`` (in units of the prior sigma) is
    added, so that the step scores it as the refit's Occam term does."""
    J = lin.J
    nx = J.shape[1]
    JTJ = (J.T @ J).toarray()
    JTR = np.asarray(J.T @ R0)
    P2 = np.zeros(nx)
    P2[lin.prior_idx] = lin.pw**2
    Pp0 = np.zeros(nx)
    Pp0[lin.prior_idx] = lin.pw * lin.p0
    if not plan:
        d = step(JTJ + np.diag(P2), JTR + Pp0[:, None], lin)
        res = R0 + np.asarray(J @ d)
        p = lin.p0[:, None] + lin.pw[:, None] * d[lin.prior_idx]
        return (0.5 * (np.sum(res**2, axis=0) + np.sum(p**2, axis=0)))[None, :]
    prior_pos = {c: k for k, c in enumerate(lin.prior_idx)}
    E = np.zeros((len(held_out(plan)), R0.shape[1]))
    j = 0  # row of E: held-out stances group by group, as the folds' scores
    for group in plan:
        seen = {t for k, t in enumerate(lin.trials) if k not in group}
        rows = np.concatenate([np.arange(lin.rows[i].start, lin.rows[i].stop) for i in group])
        Jg = J[rows]
        G = JTJ - (Jg.T @ Jg).toarray() + np.diag(P2)
        Pp = np.zeros(nx)
        Pp[lin.prior_idx] = lin.pw * lin.prior_residual(fold_means[j] if fold_means else None)
        rhs = JTR - np.asarray(Jg.T @ R0[rows]) + Pp[:, None]
        d_train = step(G, rhs, lin)
        for i in group:
            unseen = bool(lin.trials) and lin.trials[i] not in seen
            extra = lin.trial_cols[i] if unseen else np.zeros(0, int)
            E[j] = _heldout_stance(lin, J, R0, i, d_train, prior_pos, extra, charge)
            j += 1
    return E


def _heldout_stance(
    lin: Linear, J, R0: np.ndarray, i: int, d_train, prior_pos, extra=None, charge=None
) -> np.ndarray:
    """``(B,)``: the held-out energy of stance ``i`` at the training step ``d_train``, its
    nuisance (and the columns ``extra``) re-estimated from the point; plus the Occam part of the
    re-estimated columns in ``charge`` (:func:`heldout_energy`)."""
    rows = lin.rows[i]
    Jh = J[rows]
    d = d_train.copy()
    extra = np.zeros(0, int) if extra is None else extra
    z = np.concatenate([lin.nuisance[i], extra]).astype(int)
    d[z] = 0.0  # the held-out stance's nuisance is re-estimated below, from the point
    a = R0[rows] + np.asarray(Jh @ d)
    Jz = Jh[:, z].toarray()
    kz = np.array([prior_pos[c] for c in z], int)
    pwz, p0z = lin.pw[kz], lin.p0[kz]
    Hz = Jz.T @ Jz + np.diag(pwz**2)
    # a nuisance column at a bound at the point (a ground offset, a clock offset at its
    # limit) stays on its side of it, as in the training step
    dz = bounded_step(
        Hz,
        Jz.T @ a + (pwz * p0z)[:, None],
        np.flatnonzero(np.isin(z, lin.at_lower)),
        np.flatnonzero(np.isin(z, lin.at_upper)),
    )
    res = a + Jz @ dz
    pz = p0z[:, None] + pwz[:, None] * dz
    energy = 0.5 * (np.sum(res**2, axis=0) + np.sum(pz**2, axis=0))
    # every charged column the stance re-estimates: a nested child's own trial-scope columns
    # (``extra``) and its own per-stance ones (a ground offset's, among the nuisance)
    charged = np.isin(z, charge if charge is not None else [])
    if charged.any():  # 1/2 log det H_z (prior-sigma units) gained by the charged columns
        Hs = Hz / np.outer(pwz, pwz)
        keep = ~charged
        energy = energy + 0.5 * (_logdet(Hs) - _logdet(Hs[np.ix_(keep, keep)]))
    return energy


def _logdet(H: np.ndarray) -> float:
    return float(np.linalg.slogdet(H)[1]) if H.size else 0.0


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
    n_rows = max(len(held_out(plan)), 1)  # held-out stances (one row in sample)

    def terms(value) -> np.ndarray:
        """Occam terms as a column, one per held-out stance or one for all: any other size
        would broadcast the energies away (an empty array wiped every energy once)."""
        col = np.asarray(value, float).reshape(-1, 1)
        if col.shape[0] not in (1, n_rows):
            raise ValueError(f"{col.shape[0]} Occam terms for {n_rows} held-out energies")
        return col

    base = terms(occam.get("parent", 0.0))
    out = {"parent": heldout_energy(parent, R0p, plan, fold_means) + base}
    for name, lin in children.items():
        shift = (lin.r - parent.r)[:, None]
        own = base if lin.nested else terms(occam.get(name, base))
        # a nested child's Occam terms are the parent's: its own columns are charged here
        charge = _own_columns(lin, parent) if lin.nested else None
        out[name] = heldout_energy(lin, shift + R0p, plan, fold_means, charge) + own
    return out


def _own_columns(child: Linear, parent: Linear) -> np.ndarray:
    """The columns of ``child``'s variables that ``parent`` does not have."""
    cols = [np.arange(sl.start, sl.stop) for k, sl in child.keys.items() if k not in parent.keys]
    return np.concatenate(cols) if cols else np.zeros(0, int)


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


def stance_shares(E: Mapping[str, np.ndarray]) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """``({child: (rows, B) each held-out stance's share of the combined reduction [%]}, (rows,
    B) each stance's weight)``: ``50 (E_parent,s - E_child,s) / sum_s E_parent,s``, whose sum
    over the stances is the reduction of :func:`reductions` to first order (``100 (1 - sqrt(1 -
    x))`` is ``50 x`` for small ``x``), and the weight ``E_parent,s / sum_s E_parent,s`` with
    which a stance's own reduction enters it. What the null's steps-needed calculation splits
    its spread between mismatch draws with (:func:`~gc_ocp.diagnosis.null.systematic_sd`)."""
    ep = E["parent"]
    tot = np.maximum(ep.sum(axis=0, keepdims=True), 1e-300)
    shares = {n: 50.0 * (ep - e) / tot for n, e in E.items() if n != "parent"}
    return shares, ep / tot


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


__all__ = (
    "MAX_ACTIVE_SET",
    "NESTED_RTOL",
    "Linear",
    "energies",
    "fold_prior_means",
    "from_own_fit",
    "heldout_energy",
    "linearize",
    "linearize_child",
    "linearize_parent",
    "nested_point",
    "per_stance_sd",
    "reductions",
    "stance_shares",
    "bounded_step",
    "step",
)
