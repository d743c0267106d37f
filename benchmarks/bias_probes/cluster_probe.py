"""One-off probe (issue 23; README.md beside it): is mu's missing spread under a drift per
stance a variance *across stances*, which a cluster-robust sandwich (stances as clusters)
would measure?

``cluster_probe.py DRAWS [NOISE_MM]``: per draw (coverage.py's draws, drift per stance), the
fit (widths estimated, as gc_ocp.fit), mu's and n's error, their reported (HAC) SE and their SE
with the scores' covariance estimated across the stances (Liang-Zeger, factor G / (G - 1)),
and whether the t interval of G - 1 degrees of freedom covers the truth."""

import sys
from pathlib import Path

import numpy as np
from scipy.stats import t as t_dist

sys.path.insert(0, str(Path(__file__).resolve().parent))
from per_stance_draw import TRUTH, draws_and_noise, fitted_draw  # noqa: E402

from gc_ocp.estimation import build_estimation  # noqa: E402
from gc_ocp.estimation.solve import decode  # noqa: E402


def stance_clustered_covariance(problem, x, by="stance"):
    """A probe: the sandwich with the scores' covariance estimated across clusters of stances
    (``by``: "stance" or "side"), the cluster-robust (Liang-Zeger) form with the small-sample
    factor G / (G - 1); its intervals use the t quantile of G - 1 degrees of freedom. A
    cluster's score is ``J_s^T r_s`` plus the prior's gradient of the variables only its
    stances touch (zero in sum at the optimum); the prior of the variables several clusters
    share keeps its part ``W^2`` as in ``_covariance``. Returns (covariance, G)."""
    r, J = problem.data_jacobian(x)
    pw = np.asarray(problem.prior_weights, float)
    pm = np.concatenate([sp_.prior_mean for sp_ in problem.variables.specs])
    prior_grad = pw**2 * (x - pm)
    H = (J.T @ J).toarray() + np.diag(pw**2)
    keys = [st.label if by == "stance" else st.side for st in problem.stances]
    groups = list(dict.fromkeys(keys))
    scores = np.zeros((len(groups), x.size))
    touched = np.zeros((len(groups), x.size), bool)
    row = 0
    for k, b in zip(keys, problem.blocks, strict=True):
        g = groups.index(k)
        Jb, rb = J[row : row + 6 * b.T], r[row : row + 6 * b.T]
        scores[g] += Jb.T @ rb
        touched[g] |= np.asarray(abs(Jb).sum(axis=0)).ravel() > 0
        row += 6 * b.T
    own = touched.sum(axis=0) == 1
    for g in range(len(groups)):
        cols = own & touched[g]
        scores[g, cols] += prior_grad[cols]
    G = len(groups)
    c = scores - scores.mean(axis=0)
    M = c.T @ c * G / max(G - 1, 1)
    shared_prior = ~own
    M[shared_prior, shared_prior] += pw[shared_prior] ** 2
    Hi = np.linalg.pinv(H)
    cov = Hi @ M @ Hi
    return 0.5 * (cov + cov.T), G


draws, noise = draws_and_noise(0.5)
for i in draws:
    data, fitted, res, _ = fitted_draw(i, noise)
    pb = build_estimation(data, fitted)
    cl, G = stance_clustered_covariance(pb, res.x)
    q = float(t_dist.ppf(0.975, G - 1))
    out = []
    for p in ("mu", "n"):
        err = res.params["shared"][p] - TRUTH[p]
        se_cl = decode(pb, res.x, cl)[0]["contact"]["shared"][p + "_se"]
        se = res.params["shared"][p + "_se"]
        out.append(
            f"{p} err {err:+.4f} SE {se:.4f} clustered {se_cl:.4f} "
            f"(t{G - 1} covers: {abs(err) <= q * se_cl})"
        )
    print(f"draw {i}: " + "; ".join(out), flush=True)
