"""One-off probe of the bias correction (issue 23); see README.md beside it."""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
import coverage as cv

from gc_ocp.estimation import build_estimation
from gc_ocp.estimation.bias import bias_corrected
from gc_ocp.estimation.pose_scale import estimate_pose_scale
from gc_ocp.estimation.solve import IpoptOptions, solve
from gc_ocp.estimation.synthetic import default_truth, recovery_model

truth = default_truth()
disp = cv.sole_displacement()
noise = float(sys.argv[1])
drift = float(sys.argv[2])
for i in [int(a) for a in sys.argv[3].split(",")]:
    rng = np.random.default_rng(100 + i)
    data, seen = cv.draw(rng, truth, disp, 0.9, noise, drift, 0.25 * drift, False)
    model = recovery_model()
    res = solve(build_estimation(data, model), IpoptOptions())
    fitted, res, sc = estimate_pose_scale(data, model, res, sole=True)
    p = res.params["shared"]
    e0 = np.array([p["n"] - 1.5, p["c"] - 1, p["mu"] - 0.8])
    c1, info1 = bias_corrected(data, fitted, res, 16, seed=i)
    b1 = np.array([info1.bias[k] for k in ("n", "c", "mu")])
    c2, info2 = bias_corrected(data, fitted, c1, 16, seed=1000 + i)
    b2 = np.array([info2.bias[k] for k in ("n", "c", "mu")])
    print(
        f"draw {i}: widths {np.round(sc.sigma_mm, 2)} | fit err {np.round(e0, 4)} | b(theta_hat) {np.round(b1, 4)} | b(theta_1) {np.round(b2, 4)} | err1 {np.round(e0 - b1, 4)} err2 {np.round(e0 - b2, 4)} | mu se {c1.params['shared']['mu_se']:.4f}",
        flush=True,
    )
