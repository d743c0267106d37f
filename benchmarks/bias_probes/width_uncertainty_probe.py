"""Do the intervals of f_ref and the sole offsets fall short because they take the estimated
pose and sole widths as known? (issue 23; ``docs/quality.md``, *What is left, split by an
oracle*). A probe, not adopted: the answer was no.

The widths are type-II ML estimates (``gc_ocp/estimation/pose_scale.py``); the fit's covariance
is conditional on them. Kass & Steffey's (1989) first-order correction adds their sampling
variance: ``Cov(x) + D Var(theta) D^T`` with ``theta`` the log widths, ``D = dx/dtheta`` and
``Var(theta_a) = 1 / (2 gamma_a)`` (MacKay 1992: the error bar of a type-II ML precision from
``gamma_a`` well-determined coefficients). In stored units (a prior variable in units of its
width) the optimum's physical response to a width is ``D[:, a] = 2 H^-1 (x restricted to the
group a)`` (Gauss-Newton ``H``, variables at a bound held; a width at its limit is a decision,
not an estimate, and adds nothing). Checked against refits with one width moved 5 %: the
predicted change of the contact and sole variables correlates 0.96 with the refit's, at
0.88-0.93 of its size.

Run from the repository root:
    .venv/bin/python benchmarks/bias_probes/width_uncertainty_probe.py [--draws 20]
The coverage benchmark's draws (``../coverage.py``: seeds 100 + i, 1 mm of marker noise, a
3 mm / 0.75 deg drift whose pattern a foot's strides share), its default estimator.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from coverage import draw, sole_displacement, values  # noqa: E402

from gc_ocp.estimation import build_estimation  # noqa: E402
from gc_ocp.estimation import pose_scale as ps  # noqa: E402
from gc_ocp.estimation.solve import IpoptOptions, decode, solve  # noqa: E402
from gc_ocp.estimation.synthetic import default_truth, recovery_model  # noqa: E402


def width_covariance(problem, x: np.ndarray, scale: ps.PoseScale) -> np.ndarray:
    """``D Var(theta) D^T`` (module doc) in stored units, ``(nx, nx)``."""
    r, J = problem.data_jacobian(x)
    pw = np.asarray(problem.prior_weights, float)
    tol = 1e-9 * np.maximum(1.0, np.abs(x))
    free = ~((x - problem.lbx <= tol) | (problem.ubx - x <= tol))
    Hi = np.linalg.inv(((J.T @ J).toarray() + np.diag(pw**2))[np.ix_(free, free)])
    groups = [c for kind in ("trans", "rot") for c in ps._axis_columns(problem, "pose", kind)]
    widths = [*scale.sigma_mm, *scale.sigma_deg]
    limits = [(ps.MIN_MM, ps.PLAUSIBLE_MM)] * 3 + [(ps.MIN_DEG, ps.PLAUSIBLE_DEG)] * 3
    gammas = list(scale.gamma[:6])
    if scale.sole_mm is not None:
        specs = [s for s in problem.variables.specs if s.key[0] == "sole"]
        cols = np.concatenate([np.arange(s.start, s.start + s.size) for s in specs])
        floor = scale.sole_floor_mm or (ps.SOLE_MIN_MM,) * 3
        for a in range(3):  # one width per foot-frame axis (a unit's block: x, y, z)
            groups.append(cols[a::3])
            widths.append(scale.sole_mm[a])
            limits.append((floor[a], max(ps.SOLE_PLAUSIBLE_MM, floor[a])))
            gammas.append(scale.sole_gamma[a])
    D, var = [], []
    for cols, w, (lo, hi), g in zip(groups, widths, limits, gammas, strict=True):
        if not (lo * 1.001 < w < hi * 0.999) or g < ps.MIN_GAMMA:
            continue
        xa = np.zeros(x.size)
        xa[cols] = x[cols]
        D.append(2.0 * Hi @ xa[free])
        var.append(1.0 / (2.0 * g))
    out = np.zeros((x.size, x.size))
    if D:
        Dm = np.array(D).T
        out[np.ix_(free, free)] = Dm @ np.diag(var) @ Dm.T
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--draws", type=int, default=20)
    args = ap.parse_args()
    truth, disp, model = default_truth(), sole_displacement(), recovery_model()
    hits: dict = {}
    ratio: dict = {}
    for i in range(args.draws):
        rng = np.random.default_rng(100 + i)
        data, seen = draw(rng, truth, disp, 0.9, 1e-3, 3.0, 0.75)
        res = solve(build_estimation(data, model), IpoptOptions())
        fitted, res, scale = ps.estimate_pose_scale(data, model, res, sole=True)
        pb = build_estimation(data, fitted)
        extra = width_covariance(pb, res.x, scale)
        for label, cov in (("reported", res.covariance), ("+ widths", res.covariance + extra)):
            blocks, _ = decode(pb, res.x, cov)
            for name, est, se, tv in values(blocks, truth, seen):
                key = "sole (30)" if name.startswith("sole") else name.split(" ")[0]
                hits.setdefault((key, label), []).append(abs(est - tv) <= 1.96 * se)
                if label == "+ widths":
                    ratio.setdefault(key, []).append(se)
                else:
                    ratio.setdefault(key + " before", []).append(se)
        print(f"draw {i + 1}/{args.draws}", file=sys.stderr, flush=True)
    print(f"{args.draws} draws, 1 mm + 3 mm / 0.75 deg shared drift\n")
    print("| parameter | reported | + the widths' uncertainty | SE ratio (median) |")
    print("|---|---|---|---|")
    for key in dict.fromkeys(k for k, _ in hits):
        a, b = (np.mean(hits[(key, c)]) for c in ("reported", "+ widths"))
        q = np.median(np.array(ratio[key]) / np.array(ratio[key + " before"]))
        print(f"| {key} | {a:.0%} | {b:.0%} | {q:.3f} |")


if __name__ == "__main__":
    main()
