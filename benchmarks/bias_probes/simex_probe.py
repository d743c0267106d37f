"""One-off probe of the bias correction (issue 23); see README.md beside it."""

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
import coverage as cv

from gc_ocp.estimation import build_estimation
from gc_ocp.estimation.bias import draw_pose_noise
from gc_ocp.estimation.pose_scale import estimate_pose_scale
from gc_ocp.estimation.solve import IpoptOptions, solve
from gc_ocp.estimation.starts import rescaled_start
from gc_ocp.estimation.synthetic import default_truth, recovery_model

truth = default_truth()
disp = cv.sole_displacement()
noise = float(sys.argv[1])
dmm = float(sys.argv[2])
draws = [int(a) for a in sys.argv[3].split(",")]
LAMS = (0.5, 1.0, 1.5, 2.0)
R = int(sys.argv[4]) if len(sys.argv) > 4 else 4
for i in draws:
    rng = np.random.default_rng(100 + i)
    data, seen = cv.draw(rng, truth, disp, 0.9, noise, dmm, 0.25 * dmm, False)
    model = recovery_model()
    res = solve(build_estimation(data, model), IpoptOptions())
    fitted, res, sc = estimate_pose_scale(data, model, res, sole=True)
    th0 = np.array([res.params["shared"][k] for k in ("n", "c", "mu")])
    r = np.random.default_rng(7 + i)
    means = []
    t0 = time.time()
    for lam in LAMS:
        vals = []
        for k in range(R):
            rep = []
            for st in data:
                pn = st.foot.pose_noise
                extra = dataclasses.replace(
                    st.foot, pose_noise=dataclasses.replace(pn, cov=pn.cov * lam)
                )
                f = draw_pose_noise(extra, r)
                f = dataclasses.replace(
                    f,
                    pose_noise=dataclasses.replace(
                        pn, cov=pn.cov * (1 + lam), sigma_marker=pn.sigma_marker * np.sqrt(1 + lam)
                    ),
                )
                rep.append(st.with_foot(f))
            pr = build_estimation(rep, fitted)
            rr = solve(pr, IpoptOptions(), x0=rescaled_start(res, pr), covariance=False)
            vals.append([rr.params["shared"][k] for k in ("n", "c", "mu")])
        means.append(np.mean(vals, axis=0))
    L = np.r_[0.0, LAMS]
    Y = np.vstack([th0, means])
    A = np.vstack([np.ones_like(L), L, L**2]).T
    coef = np.linalg.lstsq(A, Y, rcond=None)[0]
    simex = coef[0] - coef[1] + coef[2]
    lin = np.linalg.lstsq(A[:, :2], Y, rcond=None)[0]
    simex_lin = lin[0] - lin[1]
    tv = np.array([1.5, 1.0, 0.8])
    print(
        f"draw {i}: fit err {np.round(th0 - tv, 4)} | theta(lam) mu {np.round(Y[:, 2] - 0.8, 4)} | simex quad err {np.round(simex - tv, 4)} lin {np.round(simex_lin - tv, 4)} ({time.time() - t0:.0f}s)",
        flush=True,
    )
