"""One-off probe of the bias correction (issue 23); see README.md beside it.

``denoised_probe.py NOISE_M DRAWS [B]``: the replicates' truth walking the recorded motion (as
``bias_corrected`` does) against the recorded motion with the fit's *noise part* removed (the
pose correction's marker-noise part, its posterior mean of the filtered noise; the smooth part,
which the attenuation biases, left out). Prints per draw the fit's error, both replicate biases,
and how far each motion is from the true one at the contact units."""

import dataclasses
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
from gc_ocp.estimation.synthetic import default_truth, recovery_model, with_pose_error


def denoised(data, model, res):
    """``data`` with each stance's fitted marker-noise part applied as a pose correction."""
    pose = next(c for c in model if c.name == "pose")
    spec = {s.key: s for s in res.variables}
    out = []
    for st in data:
        nb = pose.noise_basis(st)
        key = (pose.name, st.label, "noise")
        if nb is None or key not in spec:
            out.append(st)
            continue
        Phi, _, M = nb
        z = np.asarray(res.x[spec[key].start : spec[key].start + spec[key].size], float)
        e = M @ z.reshape((6, Phi.shape[1]), order="F") @ Phi.T  # (6, T), as trajectories()
        d, th = e[:3].T, e[3:].T
        R = st.foot.hindfoot_pose[:, :3, :3]
        foot = with_pose_error(st.foot, np.einsum("nji,nj->ni", R, th), d)
        out.append(st.with_foot(dataclasses.replace(foot, pose_noise=st.foot.pose_noise)))
    return out


def unit_rms(a, b):
    """RMS distance [mm] of the units (nominal points) between two views of the stances."""
    sq = []
    for x, y in zip(a, b, strict=True):
        P, Q = x.foot.hindfoot_pose, y.foot.hindfoot_pose
        p = np.asarray(x.foot.points_local, float)
        pa = np.einsum("nij,mj->nmi", P[:, :3, :3], p) + P[:, None, :3, 3]
        pb = np.einsum("nij,mj->nmi", Q[:, :3, :3], p) + Q[:, None, :3, 3]
        sq.append(((pa - pb) ** 2).sum(-1).ravel())
    return 1e3 * float(np.sqrt(np.mean(np.concatenate(sq))))


noise, draws = float(sys.argv[1]), int(sys.argv[2])
B = int(sys.argv[3]) if len(sys.argv) > 3 else 12
truth, disp = default_truth(), cv.sole_displacement()
rows = []
for i in range(draws):
    rng = np.random.default_rng(100 + i)
    data, _ = cv.draw(rng, truth, disp, 0.9, noise, 0.0, 0.0, False)
    true_sts = cv.true_stances(np.random.default_rng(100 + i), truth, disp)
    model = recovery_model()
    res = solve(build_estimation(data, model), IpoptOptions())
    fitted, res, _ = estimate_pose_scale(data, model, res, sole=True)
    err = res.params["shared"]["mu"] - truth["mu"]
    den = denoised(data, fitted, res)
    _, a = bias_corrected(data, fitted, res, B, seed=i)
    _, b = bias_corrected(den, fitted, res, B, seed=i)
    rows.append((err, a.bias["mu"], b.bias["mu"]))
    print(
        f"draw {i}: fit error mu {err:+.4f} | replicates on the recorded motion {a.bias['mu']:+.4f}"
        f" | on the denoised motion {b.bias['mu']:+.4f} | units from the truth: recorded "
        f"{unit_rms(data, true_sts):.3f} mm, denoised {unit_rms(den, true_sts):.3f} mm",
        flush=True,
    )
r = np.array(rows)
print(
    f"mean over {draws} draws: fit error {r[:, 0].mean():+.4f}, recorded-motion bias "
    f"{r[:, 1].mean():+.4f}, denoised-motion bias {r[:, 2].mean():+.4f}"
)
