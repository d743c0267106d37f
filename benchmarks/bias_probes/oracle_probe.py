"""One-off probe of the bias correction (issue 23); see README.md beside it."""

import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
import coverage as cv

from gc_ocp.diagnosis.mismatch import drift
from gc_ocp.estimation import build_estimation
from gc_ocp.estimation.bias import recorded_truth, replicate_data
from gc_ocp.estimation.pose_scale import estimate_pose_scale
from gc_ocp.estimation.solve import IpoptOptions, solve
from gc_ocp.estimation.starts import rescaled_start
from gc_ocp.estimation.synthetic import (
    default_truth,
    recovery_model,
)

truth = default_truth()
disp = cv.sole_displacement()
noise, dmm, i, mode = 2e-3, 3.0, int(sys.argv[1]), sys.argv[2]
rng = np.random.default_rng(100 + i)
data, seen = cv.draw(rng, truth, disp, 0.9, noise, dmm, 0.75, False)
# the true motion of the same draw (same construction, no error)
rng2 = np.random.default_rng(100 + i)
true_sts = cv.true_stances(rng2, truth, disp)
model = recovery_model()
res = solve(build_estimation(data, model), IpoptOptions())
fitted, res, sc = estimate_pose_scale(data, model, res, sole=True)
mu0 = res.params["shared"]["mu"]
print("fit mu err", mu0 - 0.8, flush=True)
# oracle motion with the noise model of the data
motion = [
    dataclasses.replace(d, foot=dataclasses.replace(t.foot, pose_noise=d.foot.pose_noise))
    for d, t in zip(data, true_sts, strict=True)
]
tr = recorded_truth(motion, fitted, res)
r = np.random.default_rng(7)
ch = []
for _b in range(12):
    rep = replicate_data(motion, fitted, res, r, truth=tr, drift=False)  # as when run
    if mode == "drift":
        rep = drift(rep, dmm * 1e-3, 0.75, r, 0.25)
    pr = build_estimation(rep, fitted)
    rr = solve(pr, IpoptOptions(), x0=rescaled_start(res, pr), covariance=False)
    ch.append(rr.params["shared"]["mu"] - mu0)
print(mode, "oracle-motion replicate bias mu", np.mean(ch), "sd", np.std(ch))
