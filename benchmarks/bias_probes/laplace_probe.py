"""One-off probe (issue 23; README.md beside it): is mu's bias under a wide pose prior and the
markers' noise the joint MAP's incidental-parameter bias (Neyman and Scott 1948)? The fit
maximises the joint posterior of the contact parameters and every stance's pose correction;
the number of pose coefficients grows with the data, and the joint mode of the shared
parameters is then biased by the latent variables' own uncertainty. Integrating them out
(Laplace, as TMB does for random effects: Kristensen et al. 2016) adds
``1/2 log det H_zz(theta)`` to the objective, ``H_zz`` the pose coefficients' (Gauss-Newton)
precision, block-diagonal by stance. One Newton step of that marginal objective from the fit:
``d theta = -Cov_theta * grad_theta (1/2 log det H_zz)``, the gradient taken along the fit's
path ``z_hat(theta)`` (central differences, ``dz/dtheta = -H_zz^-1 H_z theta``).

``laplace_probe.py VARIANT SEEDS [MM DEG]``: ``sources_probe.py``'s data; per seed mu's and
n's error before and after the step, and the step's size."""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from sources_probe_data import FLAGS, fitted, make  # noqa: E402

from gc_ocp.estimation import build_estimation  # noqa: E402
from gc_ocp.estimation.solve import decode  # noqa: E402
from gc_ocp.estimation.synthetic import recovery_model  # noqa: E402


def half_logdet(pb, x, groups, s2):
    """``1/2 log det H_zz`` at ``x``: the sum over the stances' pose blocks (the data's
    residuals of variance ``s2``)."""
    _, J = pb.data_jacobian(x)
    pw = np.asarray(pb.prior_weights, float)
    out = 0.0
    for cols in groups:
        Jz = J[:, cols].toarray()
        H = Jz.T @ Jz / s2 + np.diag(pw[cols] ** 2)
        out += 0.5 * np.linalg.slogdet(H)[1]
    return out


def laplace_step(pb, x, h=1e-4, scaled=True):
    """The step; ``scaled``: the data's residual variance estimated at the fit (the objective
    weighs them with a guessed 2 % BW), else taken as 1."""
    groups = [c for c in pb.stance_columns() if c.size]
    z = np.concatenate(groups)
    theta = np.setdiff1d(np.arange(x.size), z)
    free = theta[(x[theta] > pb.lbx[theta] + 1e-9) & (x[theta] < pb.ubx[theta] - 1e-9)]
    r, J = pb.data_jacobian(x)
    s2 = float(r @ r) / r.size if scaled else 1.0
    pw = np.asarray(pb.prior_weights, float)
    H = (J.T @ J).toarray() / s2 + np.diag(pw**2)
    Hzz, Hzt = H[np.ix_(z, z)], H[np.ix_(z, free)]
    dz = -np.linalg.solve(Hzz, Hzt)  # (nz, n_free): z_hat's derivative in theta
    g = np.zeros(free.size)
    for j, col in enumerate(free):
        step = np.zeros(x.size)
        step[col] = h
        step[z] = h * dz[:, j]
        g[j] = (half_logdet(pb, x + step, groups, s2) - half_logdet(pb, x - step, groups, s2)) / (
            2 * h
        )
    Hi = np.linalg.inv(H)
    d_theta = -Hi[np.ix_(free, free)] @ g
    x_new = x.copy()
    x_new[free] += d_theta
    x_new[z] += dz @ d_theta
    return x_new


if __name__ == "__main__":
    variant = sys.argv[1]
    fixed = [float(a) for a in sys.argv[3:5]] if len(sys.argv) > 4 else None
    for seed in [int(a) for a in sys.argv[2].split(",")]:
        data = make(seed, *FLAGS[variant])
        model, res = fitted(data, recovery_model(), fixed)
        pb = build_estimation(data, model)
        x1 = laplace_step(pb, res.x)
        after = decode(pb, x1)[0]["contact"]["shared"]
        x2 = laplace_step(pb, res.x, scaled=False)
        raw = decode(pb, x2)[0]["contact"]["shared"]
        before = res.params["shared"]
        print(
            f"{variant} {seed}: mu err {before['mu'] - 0.8:+.4f} -> {after['mu'] - 0.8:+.4f} "
            f"(unscaled {raw['mu'] - 0.8:+.4f}) "
            f"(SE {before['mu_se']:.4f}); n err {before['n'] - 1.5:+.4f} -> {after['n'] - 1.5:+.4f}; "
            f"c err {before['c'] - 1.0:+.4f} -> {after['c'] - 1.0:+.4f}",
            flush=True,
        )
