"""One-off probe of the bias correction (issue 23); see README.md beside it."""

import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
import coverage as cv

from gc_ocp.estimation import build_estimation
from gc_ocp.estimation.bias import recorded_truth, replicate_data
from gc_ocp.estimation.components.pose import PoseCorrection
from gc_ocp.estimation.pose_scale import estimate_pose_scale
from gc_ocp.estimation.solve import IpoptOptions, solve
from gc_ocp.estimation.starts import rescaled_start
from gc_ocp.estimation.synthetic import default_truth, recovery_model, with_pose_error

truth = default_truth()
disp = cv.sole_displacement()
for i in [int(a) for a in sys.argv[1].split(",")]:
    rng = np.random.default_rng(100 + i)
    data, seen = cv.draw(rng, truth, disp, 0.9, 1e-3, 3.0, 0.75, False)
    model = recovery_model()
    res = solve(build_estimation(data, model), IpoptOptions())
    fitted, res, sc = estimate_pose_scale(data, model, res, sole=True)
    pose = next(c for c in fitted if isinstance(c, PoseCorrection))
    tr = recorded_truth(data, fitted, res)
    r = np.random.default_rng(7)
    out = {}
    for mode in ("white", "smooth"):
        ch = []
        for _ in range(16):
            rep = replicate_data(data, fitted, res, r, truth=tr)
            if mode == "smooth":
                new = []
                for st in rep:
                    B, _ = pose.basis(st.time)
                    K = B.shape[1]
                    ct = r.normal(0, 1, (K, 3)) * np.asarray(pose.sigma_mm) * 1e-3
                    cr = r.normal(0, 1, (K, 3)) * np.deg2rad(np.asarray(pose.sigma_deg))
                    d, th = B @ ct, B @ cr
                    R = st.foot.hindfoot_pose[:, :3, :3]
                    f = with_pose_error(st.foot, np.einsum("nji,nj->ni", R, th), d)
                    new.append(st.with_foot(dataclasses.replace(f, pose_noise=st.foot.pose_noise)))
                rep = new
            pr = build_estimation(rep, fitted)
            rr = solve(pr, IpoptOptions(), x0=rescaled_start(res, pr), covariance=False)
            ch.append(rr.params["shared"]["mu"] - res.params["shared"]["mu"])
        out[mode] = (np.mean(ch), np.std(ch, ddof=1))
    print(
        f"draw {i}: mu err {res.params['shared']['mu'] - 0.8:+.4f}, HAC se {res.params['shared']['mu_se']:.4f}, widths {np.round(pose.sigma_mm, 2)} {np.round(pose.sigma_deg, 2)} | white: bias {out['white'][0]:+.4f} sd {out['white'][1]:.4f} | smooth: bias {out['smooth'][0]:+.4f} sd {out['smooth'][1]:.4f}",
        flush=True,
    )
