"""One-off probe (issue 23; README.md beside it): does a delete-one-stance jackknife give mu
the spread its fits show under a drift per stance, where the cluster-robust sandwich
(``cluster_probe.py``) did not? The jackknife refits, so it follows the friction law's
saturation, and it does not shrink with a stance's leverage as the sandwich's sum of scores
does.

``jackknife_probe.py DRAWS [NOISE_MM]``: per draw (coverage.py's draws, drift per stance), the
fit (widths estimated, as gc_ocp.fit), then each stance left out in turn (the fitted widths
kept, warm-started from the fit), and the jackknife SE ``sqrt((G-1)/G sum (t_-s - mean)^2)``
of mu and n beside the reported SE; covered: the t interval of G - 1 degrees of freedom."""

import sys
from pathlib import Path

import numpy as np
from scipy.stats import t as t_dist

sys.path.insert(0, str(Path(__file__).resolve().parent))
from per_stance_draw import TRUTH, draws_and_noise, fitted_draw  # noqa: E402

from gc_ocp.estimation import build_estimation  # noqa: E402
from gc_ocp.estimation.solve import IpoptOptions, solve  # noqa: E402
from gc_ocp.estimation.starts import rescaled_start  # noqa: E402

draws, noise = draws_and_noise(0.5)
for i in draws:
    data, fitted, res, _ = fitted_draw(i, noise)
    G = len(data)
    loo = []
    for s in range(G):
        sub = [d for j, d in enumerate(data) if j != s]
        pb = build_estimation(sub, fitted)
        r = solve(pb, IpoptOptions(), x0=rescaled_start(res, pb), covariance=False)
        loo.append([r.params["shared"][p] for p in ("mu", "n")])
    loo = np.array(loo)
    se_j = np.sqrt((G - 1) / G * np.sum((loo - loo.mean(axis=0)) ** 2, axis=0))
    q = float(t_dist.ppf(0.975, G - 1))
    out = []
    for j, p in enumerate(("mu", "n")):
        err = res.params["shared"][p] - TRUTH[p]
        se = res.params["shared"][p + "_se"]
        out.append(
            f"{p} err {err:+.4f} SE {se:.4f} jackknife {se_j[j]:.4f} "
            f"(t{G - 1} covers: {abs(err) <= q * se_j[j]}; leave-one-out "
            + " ".join(f"{v - res.params['shared'][p]:+.4f}" for v in loo[:, j])
            + ")"
        )
    print(f"draw {i}: " + "; ".join(out), flush=True)
