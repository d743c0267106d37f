"""One-off probe of the bias correction (issue 23); see README.md beside it.

``smooth_probe.py DRAWS [shared|fitted] [nowhite] [indep] [NOISE_MM]``: the replicates as ``bias_corrected``
makes them (``white``) against replicates whose seen motion also gets a smooth error drawn from
the fit's estimated widths, independent per stance (default) or, with ``shared``, sharing the
measured fraction ``rho`` of it across a foot's stances (``PoseCorrection.shared``), or, with
``fitted``, each stance's own fitted correction with a random sign (:func:`fitted_error`);
``nowhite``: only that kind. ``indep``:
the data's drift is each stance's own (``coverage.py --drift-independent``) instead of a
pattern a foot's strides share; ``NOISE_MM``: the markers' white noise (default 1)."""

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
from gc_ocp.estimation.pose_scale import estimate_pose_scale, mackay_update
from gc_ocp.estimation.solve import IpoptOptions, solve
from gc_ocp.estimation.starts import rescaled_start
from gc_ocp.estimation.synthetic import default_truth, recovery_model, with_pose_error

GRID = 64  # a shared pattern's coefficients, placed on each stance's knots by normalised time


def smooth_error(rep, pose, rho, r):
    """``rep`` with each stance's seen motion moved by a draw of the pose correction's prior;
    ``rho``: ``{side: share}`` of it common to the foot's stances (empty: independent)."""
    common = {s: (r.normal(0, 1, (GRID, 3)), r.normal(0, 1, (GRID, 3))) for s in rho}
    out = []
    for st in rep:
        B, _ = pose.basis(st.time)
        K = B.shape[1]
        a = rho.get(st.side, 0.0)
        gt, gr = common.get(st.side, (np.zeros((GRID, 3)), np.zeros((GRID, 3))))
        idx = np.round(np.linspace(0, GRID - 1, K)).astype(int)  # same place of the stance
        zt = np.sqrt(1 - a) * r.normal(0, 1, (K, 3)) + np.sqrt(a) * gt[idx]
        zr = np.sqrt(1 - a) * r.normal(0, 1, (K, 3)) + np.sqrt(a) * gr[idx]
        d = B @ (zt * np.asarray(pose.sigma_mm) * 1e-3)
        th = B @ (zr * np.deg2rad(np.asarray(pose.sigma_deg)))
        R = st.foot.hindfoot_pose[:, :3, :3]
        f = with_pose_error(st.foot, np.einsum("nji,nj->ni", R, th), d)
        out.append(st.with_foot(dataclasses.replace(f, pose_noise=st.foot.pose_noise)))
    return out


def fitted_error(rep, pb, pose, x, r):
    """``rep`` with each stance's seen motion moved by its own *fitted* smooth correction, its
    sign drawn per stance and each axis inflated by ``sqrt(n / gamma)`` (the shrinkage of a
    posterior mean undone, as a leverage-corrected residual): a drift of the spectrum the fit
    found, not the prior's."""
    _, _, gam, n = mackay_update(pb, x, pose)
    infl = np.sqrt(n / np.maximum(np.asarray(gam), 1.0))
    spec = {s.key: s for s in pb.variables.specs}
    wt = np.broadcast_to(np.asarray(pose.sigma_mm, float), 3) * 1e-3 * infl[:3]
    wr = np.deg2rad(np.broadcast_to(np.asarray(pose.sigma_deg, float), 3)) * infl[3:]
    out = []
    for st in rep:
        B, _ = pose.basis(st.time)
        zt = x[spec[("pose", st.label, "trans")].slice].reshape(-1, 3)
        zr = x[spec[("pose", st.label, "rot")].slice].reshape(-1, 3)
        sg = r.choice([-1.0, 1.0])
        d, th = sg * B @ (zt * wt), sg * B @ (zr * wr)
        R = st.foot.hindfoot_pose[:, :3, :3]
        f = with_pose_error(st.foot, np.einsum("nji,nj->ni", R, th), d)
        out.append(st.with_foot(dataclasses.replace(f, pose_noise=st.foot.pose_noise)))
    return out


truth = default_truth()
disp = cv.sole_displacement()
mode = next((m for m in ("shared", "fitted") if m in sys.argv[2:]), "smooth")
kinds = (mode,) if "nowhite" in sys.argv[2:] else ("white", mode)
indep = "indep" in sys.argv[2:]
noise = next((float(a) for a in sys.argv[2:] if a[0].isdigit()), 1.0) * 1e-3
for i in [int(a) for a in sys.argv[1].split(",")]:
    rng = np.random.default_rng(100 + i)
    data, seen = cv.draw(rng, truth, disp, 0.9, noise, 3.0, 0.75, indep)
    model = recovery_model()
    res = solve(build_estimation(data, model), IpoptOptions())
    fitted, res, sc = estimate_pose_scale(data, model, res, sole=True)
    pose = next(c for c in fitted if isinstance(c, PoseCorrection))
    rho = res.blocks["pose"]["shared_fraction"] if mode == "shared" else {}
    tr = recorded_truth(data, fitted, res)
    r = np.random.default_rng(7)
    out = {}
    pb = build_estimation(data, fitted)
    for m in kinds:
        ch = []
        for _ in range(16):
            rep = replicate_data(data, fitted, res, r, truth=tr, drift=False)
            if m == "fitted":
                rep = fitted_error(rep, pb, pose, res.x, r)
            elif m != "white":
                rep = smooth_error(rep, pose, rho, r)
            pr = build_estimation(rep, fitted)
            rr = solve(pr, IpoptOptions(), x0=rescaled_start(res, pr), covariance=False)
            ch.append([rr.params["shared"][p] - res.params["shared"][p] for p in ("n", "mu")])
        out[m] = (np.mean(ch, axis=0), np.std(ch, axis=0, ddof=1))
    err = [res.params["shared"][p] - truth[p] for p in ("n", "mu")]
    print(
        f"draw {i}: err n {err[0]:+.4f} mu {err[1]:+.4f}, se n {res.params['shared']['n_se']:.4f} "
        f"mu {res.params['shared']['mu_se']:.4f}, widths {np.round(pose.sigma_mm, 2)} "
        f"{np.round(pose.sigma_deg, 2)}, rho {rho}"
        + "".join(
            f" | {k}: bias n {b[0][0]:+.4f} mu {b[0][1]:+.4f} sd n {b[1][0]:.4f} mu {b[1][1]:.4f}"
            for k, b in out.items()
        ),
        flush=True,
    )
