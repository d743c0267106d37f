"""One-off probe (issue 23; README.md beside it): does the pose correction's coefficients'
*measured* correlation along a stance, put in the covariance's prior part as the shared fraction
is, give mu the spread its fits show under a drift per stance?

``knot_corr_probe.py DRAWS [NOISE_MM]``: per draw (coverage.py's draws, drift per stance), the
fit (widths estimated, as gc_ocp.fit), then the EM estimate of each part's (translation,
rotation) knot-to-knot correlation, ``mean(z z^T + S)`` along its diagonals (``z`` the fitted
coefficients in units of their widths, ``S`` their posterior covariance: under a white prior
this is the identity), and mu's SE with that Toeplitz matrix in the meat."""

import sys
from pathlib import Path

import numpy as np
from scipy.linalg import toeplitz

sys.path.insert(0, str(Path(__file__).resolve().parent))
from per_stance_draw import TRUTH, draws_and_noise, fitted_draw  # noqa: E402

from gc_ocp.estimation import build_estimation  # noqa: E402
from gc_ocp.estimation.solve import _covariance, decode  # noqa: E402

draws, noise = draws_and_noise(1.0)
for i in draws:
    data, fitted, res, sc = fitted_draw(i, noise)
    pb = build_estimation(data, fitted)
    x = res.x
    r, J = pb.data_jacobian(x)
    pw = np.asarray(pb.prior_weights, float)
    H = (J.T @ J).toarray() + np.diag(pw**2)
    Hi = np.linalg.inv(H)
    spec = {s.key: s for s in pb.variables.specs}
    blocks = {}
    corr = {}
    for part in ("trans", "rot"):
        acc, cnt = np.zeros(64), np.zeros(64)
        for st in data:
            s = spec[("pose", st.label, part)]
            for a in range(3):
                cols = s.start + a + 3 * np.arange(s.size // 3)
                M = np.outer(x[cols], x[cols]) + Hi[np.ix_(cols, cols)]
                K = cols.size
                for k in range(K):
                    acc[k] += np.trace(M, offset=k)
                    cnt[k] += K - k
                blocks.setdefault(part, []).append(cols)
        rk = acc[cnt > 0] / cnt[cnt > 0]
        corr[part] = rk / rk[0]
    base = _covariance(pb, x)
    # the meat's prior part with the measured Toeplitz correlation per stance and axis
    P = np.diag(pw**2)
    S_id = P.copy()
    S_t = P.copy()
    for part, cl in blocks.items():
        for cols in cl:
            K = cols.size
            C = toeplitz(corr[part][:K])
            w, V = np.linalg.eigh(C)
            C = (V * np.clip(w, 0, None)) @ V.T  # nearest PSD
            S_t[np.ix_(cols, cols)] = pw[cols, None] * C * pw[None, cols]
    extra = Hi @ (S_t - S_id) @ Hi
    cov_t = base + extra
    b0, _ = decode(pb, x, base)
    b1, _ = decode(pb, x, cov_t)
    s0, s1 = b0["contact"]["shared"], b1["contact"]["shared"]
    print(
        f"draw {i}: err mu {s0['mu'] - TRUTH['mu']:+.4f} n {s0['n'] - TRUTH['n']:+.4f}; "
        f"lag corr trans {np.round(corr['trans'][:6], 2)} rot {np.round(corr['rot'][:6], 2)}; "
        f"SE mu {s0['mu_se']:.4f} -> {s1['mu_se']:.4f}, n {s0['n_se']:.4f} -> {s1['n_se']:.4f}",
        flush=True,
    )
