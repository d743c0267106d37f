"""Synthetic recovery and efficiency of the joint estimator (Monte Carlo vs Cramér-Rao bound).

Run:  python benchmarks/synthetic_recovery.py [--draws 20] [--stances 3] [--marker-noise 0.001]

Truth: per-unit k (0.6-1.4 x 3e5 N/m^1.5), n = 1.5, c = 1 s/m, mu = 0.8; every sole point displaced
by up to 8 mm (one fixed draw); a rigid foot rolling heel-to-toe (``rolling_foot``), ``--stances``
stances per foot. Each Monte-Carlo draw adds plate noise (``--force-noise`` N, and 5 % of it
in N·m on the moments) and marker noise (``--marker-noise`` m on 4 virtual foot markers, pose
re-estimated by Kabsch and low-passed at 6 Hz, as a lab pipeline would).

Estimator: the full model (k per unit, shared n, c, mu, sole corrections, pose corrections). The
force weight is the true plate noise; with marker noise the pose-correction prior is set to the
resulting pose error (0.3 mm / 0.25 deg per 1 mm of marker noise, measured on this motion) with
knots every 30 ms, so that the model of the kinematic error is right.

Printed: bias and spread (sd over draws) of each estimate, and the ratio of that spread to the
Cramér-Rao bound, sqrt(diag(F^-1)) with F the Fisher information (Gauss-Newton, data + priors)
evaluated at each draw's estimate with the known noise level and averaged over draws.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from gc_ocp.estimation.components import (
    BeltSpeed,
    ContactLaw,
    Param,
    PoseCorrection,
    SoleCorrection,
)
from gc_ocp.estimation.problem import Weights, build_estimation
from gc_ocp.estimation.solve import solve
from gc_ocp.estimation.synthetic import default_truth, nominal_points, synthetic_stance
from gc_ocp.foot import UNITS

SIDES = ("left", "right")
X_REF = 0.005
"""Reference depth [m] for k_ref = k * X_REF**n, the unit's force at 5 mm penetration [N]."""
LN_XREF = float(np.log(X_REF))


def fisher_inverse(problem, x: np.ndarray) -> np.ndarray:
    """(J^T J)^-1 of all weighted residuals (data with the true sigma, and priors) at ``x``."""
    _, Jd = problem.data_jacobian(x)  # data rows; the prior rows are diag(prior weights)
    return np.linalg.inv((Jd.T @ Jd).toarray() + np.diag(problem.prior_weights**2))


def sole_displacements() -> dict:
    """The truth's sole-point displacements ``{side: (5, 3)}`` [m]: random directions, lengths
    U(0, 8 mm), one fixed draw (seed 100) shared by every run and by ``crb_design.py``."""
    g = np.random.default_rng(100)
    disp = {}
    for side in SIDES:
        d = g.normal(size=(5, 3))
        d *= (g.uniform(0, 0.008, 5) / np.linalg.norm(d, axis=1))[:, None]
        disp[side] = d
    return disp


def estimator_law() -> ContactLaw:
    """The estimated contact law: k per unit, shared n, c, mu, started away from the truth."""
    return ContactLaw(
        k=Param("unit", 2e5, 1e2, 1e9),
        n=Param("shared", 1.2, 1, 3),
        c=Param("shared", 0.3, 0, 10),
        mu=Param("shared", 0.5, 0, 1.5),
    )


def stance_styles(stances: int, vary: float) -> dict:
    """Per-stance motion factors ``{(side, j): (4,)}``, 1 + U(-vary, vary) (seed 200)."""
    gs = np.random.default_rng(200)
    return {(side, j): 1.0 + gs.uniform(-vary, vary, 4) for side in SIDES for j in range(stances)}


def _pipeline_coefficients(
    marker_noise: float, knot_spacing: float, samples: int = 40
) -> list[np.ndarray]:
    """B-spline coefficients ``(K, 6)`` (translation [m], rotation [rad], lab axes) that best fit the
    foot-pose error of the simulated marker pipeline (``noisy_pose``: 4 markers, Kabsch, 6 Hz
    low-pass), one array per simulated stance. Seeds 10000+ (not the draws')."""
    from scipy.spatial.transform import Rotation

    from gc_ocp.estimation.synthetic import noisy_pose, rolling_foot

    pc = PoseCorrection(knot_spacing=knot_spacing)
    out = []
    for i in range(samples):
        f = rolling_foot("left", sink=0.010)
        g = noisy_pose(f, marker_noise, np.random.default_rng(10_000 + i))
        d = g.hindfoot_pose[:, :3, 3] - f.hindfoot_pose[:, :3, 3]
        th = Rotation.from_matrix(
            np.einsum("nij,nkj->nik", g.hindfoot_pose[:, :3, :3], f.hindfoot_pose[:, :3, :3])
        ).as_rotvec()  # lab axes
        B, _ = pc.basis(f.time)
        out.append(np.linalg.lstsq(B, np.hstack([d, th]), rcond=None)[0])
    return out


def pose_error_sd(
    marker_noise: float, knot_spacing: float, samples: int = 40
) -> tuple[tuple, tuple]:
    """Per-axis sd of the pipeline's pose-error spline coefficients (translation [mm], rotation
    [deg]) — the right prior width for the pose correction when the only kinematic error is marker
    noise."""
    c = np.concatenate(_pipeline_coefficients(marker_noise, knot_spacing, samples))
    sd = np.sqrt(np.mean(c**2, axis=0))
    return tuple(map(float, sd[:3] * 1e3)), tuple(map(float, np.rad2deg(sd[3:])))


def knot_correlation(
    marker_noise: float, knot_spacing: float, samples: int = 40
) -> tuple[float, ...]:
    """Correlation of the pipeline's pose-error spline coefficients at lags 0, 1, 2, ... knots (mean
    over the 6 axes and the simulated stances), cut where it first drops below 0.05."""
    num, den = np.zeros(8), 0.0
    for c in _pipeline_coefficients(marker_noise, knot_spacing, samples):
        c = c / c.std(axis=0)
        den += np.mean(c * c)
        num += [np.mean(c[: c.shape[0] - lag] * c[lag:]) for lag in range(8)]
    rho = num / den
    cut = int(np.argmax(rho < 0.05)) if np.any(rho < 0.05) else rho.size
    return tuple(float(r) for r in rho[:cut] / rho[0])


def spline_pose_error(st, pose: PoseCorrection, rng: np.random.Generator):
    """``st`` with its foot pose perturbed by a pose error drawn from ``pose``'s own prior (a
    B-spline with independent Gaussian coefficients), so that the estimator's kinematic-error model
    is exactly right (``--pose-noise spline``: a diagnostic, not a lab pipeline)."""
    import dataclasses

    from scipy.spatial.transform import Rotation

    from gc_ocp.foot import FootKinematics

    f = st.foot
    B, dB = pose.basis(f.time)
    K = B.shape[1]
    s_t = np.broadcast_to(np.asarray(pose.sigma_mm, float), 3) * 1e-3
    s_r = np.deg2rad(np.broadcast_to(np.asarray(pose.sigma_deg, float), 3))
    L = pose.correlation_factor(K)
    ct, cr = L @ rng.normal(size=(K, 3)) * s_t, L @ rng.normal(size=(K, 3)) * s_r
    d, dd, th, dth = B @ ct, dB @ ct, B @ cr, dB @ cr
    # the estimator corrects p -> p + d + th x (p - o_h): apply the inverse to the foot
    Rm = Rotation.from_rotvec(-th).as_matrix()
    poses = []
    for P in (f.hindfoot_pose, f.toes_pose):
        Q = P.copy()
        Q[:, :3, :3] = np.einsum("nij,njk->nik", Rm, P[:, :3, :3])
        Q[:, :3, 3] = (
            f.hindfoot_pose[:, :3, 3]
            - d
            + np.einsum("nij,nj->ni", Rm, P[:, :3, 3] - f.hindfoot_pose[:, :3, 3])
        )
        poses.append(Q)
    tw = []
    for P, T in ((f.hindfoot_pose, f.hindfoot_twist), (f.toes_pose, f.toes_twist)):
        r = P[:, :3, 3] - f.hindfoot_pose[:, :3, 3]
        v = T[:, :3] - dd - np.cross(dth, r) - np.cross(th, T[:, :3] - f.hindfoot_twist[:, :3])
        # omega' = exp(-th) omega - th_dot (to first order), so that the estimator's first-order
        # velocity correction (d_dot + th_dot x r + th x r_dot) restores the true unit velocities
        tw.append(np.hstack([v, T[:, 3:] - dth - np.cross(th, T[:, 3:])]))
    foot = FootKinematics(f.side, f.time, poses[0], poses[1], tw[0], tw[1], f.points_local)
    return dataclasses.replace(st, foot=foot)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--draws", type=int, default=20)
    ap.add_argument("--stances", type=int, default=3, help="stances per foot")
    ap.add_argument("--force-noise", type=float, default=5.0, help="plate force noise sd [N]")
    ap.add_argument("--marker-noise", type=float, default=0.0, help="marker noise sd [m]")
    ap.add_argument(
        "--vary",
        type=float,
        default=0.0,
        help="stance-to-stance variation of the motion: each stance's strike/push-off pitch, "
        "roll and sink are scaled by U(1 - vary, 1 + vary) (0: identical stances)",
    )
    ap.add_argument(
        "--knots",
        type=float,
        default=0.03,
        help="pose-correction knot spacing [s] with marker noise",
    )
    ap.add_argument(
        "--starts",
        choices=("single", "best"),
        default="single",
        help="single: one Ipopt solve from the generic start; best: fit()'s two starts "
        "(direct + prior-width continuation), lower objective kept (~3x slower)",
    )
    ap.add_argument(
        "--pose-prior",
        choices=("independent", "correlated"),
        default="independent",
        help="pose-correction prior: independent coefficients, or with the pipeline's knot-to-knot correlation",
    )
    ap.add_argument(
        "--pose-noise",
        choices=("pipeline", "spline"),
        default="pipeline",
        help="kinematic error: 'pipeline' = marker noise through Kabsch + 6 Hz filter; 'spline' "
        "= drawn from the estimator's own pose prior (diagnostic: the error model is exact)",
    )
    args = ap.parse_args()

    truth = default_truth()
    disp = sole_displacements()
    mn = args.marker_noise
    if mn > 0:
        s_mm, s_deg = pose_error_sd(mn, args.knots)
        rho = knot_correlation(mn, args.knots) if args.pose_prior == "correlated" else None
        pose = PoseCorrection(
            knot_spacing=args.knots, sigma_mm=s_mm, sigma_deg=s_deg, knot_correlation=rho
        )
        print(
            f"pose prior from the simulated marker pipeline ({args.knots * 1e3:.0f} ms knots): "
            f"translation {np.round(s_mm, 3)} mm, rotation {np.round(s_deg, 3)} deg (lab x, y, z); "
            f"knot correlation {None if rho is None else np.round(rho, 3)}"
        )
    else:
        pose = PoseCorrection()
    model = (estimator_law(), SoleCorrection(), pose, BeltSpeed())
    bw = 700.0
    weights = Weights(force_sigma=args.force_noise / bw, torque_length=0.05)
    names = (
        [f"{s}.k_{u}" for s in SIDES for u in UNITS]
        + ["n", "c", "mu"]
        + [f"{s}.{u}.d{a}" for s in SIDES for u in UNITS for a in "xyz"]
    )
    truth_vec = np.concatenate(
        [
            np.log(np.tile(truth["k"], 2)),
            [truth["n"], truth["c"], truth["mu"]],
            np.concatenate([disp[s].ravel() * 1e3 for s in SIDES]),
        ]
    )
    styles = stance_styles(args.stances, args.vary)
    est, sd_crb, corr_kn = [], [], []
    names += [f"{s}.kref_{u}" for s in SIDES for u in UNITS]
    truth_vec = np.concatenate([truth_vec, truth_vec[:10] + truth["n"] * LN_XREF])
    t_start = time.perf_counter()
    for draw in range(args.draws):
        rng = np.random.default_rng(draw)
        sts = [
            synthetic_stance(
                side,
                truth,
                nominal_points(side) + disp[side],
                t0=1.1 * j + 0.55 * i,
                sink=0.010,
                rng=rng,
                force_noise=args.force_noise,
                marker_noise=mn if args.pose_noise == "pipeline" else 0.0,
                body_weight=bw,
                style=styles[(side, j)],
            )
            for i, side in enumerate(SIDES)
            for j in range(args.stances)
        ]
        if args.pose_noise == "spline" and mn > 0:
            sts = [spline_pose_error(st, pose, rng) for st in sts]
        prob = build_estimation(sts, model, weights)
        if (
            args.starts == "best"
        ):  # the product's path: direct + prior continuation, lower objective kept
            from gc_ocp.estimation.starts import best_of

            # its result is a start's last stage (prior scale 1): the variables of ``prob``
            res = best_of(sts, model, weights)
            assert [(s.key, s.start) for s in res.variables] == [
                (s.key, s.start) for s in prob.variables.specs
            ]
        else:
            res = solve(prob, raise_on_failure=False)
        v = prob.variables
        idx = (
            [v.spec(("contact", "k", s, u)).start for s in SIDES for u in UNITS]
            + [v.spec(("contact", p)).start for p in ("n", "c", "mu")]
            + [v.spec(("sole", s, u)).start + a for s in SIDES for u in UNITS for a in range(3)]
        )
        scale = np.array([1.0] * 13 + [SoleCorrection().sigma * 1e3] * 30)  # sole in mm
        # log k at the reference depth: log k_ref = log k + n ln(x_ref) (the force-depth level)
        e = res.x[idx] * scale
        est.append(np.concatenate([e, e[:10] + e[10] * LN_XREF]))
        cov = fisher_inverse(prob, res.x)[np.ix_(idx, idx)] * np.outer(scale, scale)
        G = np.zeros((10, 43))  # Jacobian of log k_ref in (log k, n, ...)
        G[np.arange(10), np.arange(10)] = 1.0
        G[:, 10] = LN_XREF
        var = np.concatenate([np.diag(cov), np.diag(G @ cov @ G.T)])
        sd_crb.append(np.sqrt(var))
        corr_kn.append(cov[:10, 10] / np.sqrt(cov[10, 10] * np.diag(cov)[:10]))
        print(
            f"draw {draw + 1}/{args.draws}: {res.status}, {res.iterations} it, {res.seconds:.1f} s",
            flush=True,
        )
    est, sd_crb = np.array(est), np.array(sd_crb)
    bias = est.mean(0) - truth_vec
    spread = est.std(0, ddof=1)
    crb = np.sqrt(np.mean(sd_crb**2, axis=0))
    print(
        f"\n{args.draws} draws, {args.stances} stances/foot, force noise {args.force_noise} N, "
        f"marker noise {mn * 1e3:.1f} mm, stance variation {args.vary}, {time.perf_counter() - t_start:.0f} s"
    )
    print("k as log k (so bias/spread are relative errors); sole corrections in mm")
    print(
        f"{'parameter':>14} {'truth':>9} {'bias':>9} {'spread':>9} {'CRB sd':>9} {'spread/CRB':>10}"
    )
    for i, nm in enumerate(names):
        print(
            f"{nm:>14} {truth_vec[i]:9.3f} {bias[i]:9.4f} {spread[i]:9.4f} {crb[i]:9.4f} {spread[i] / crb[i]:10.2f}"
        )
    groups = {
        "log k": slice(0, 10),
        "n, c, mu": slice(10, 13),
        "sole": slice(13, 43),
        "log k_ref": slice(43, 53),
    }
    for gname, sl in groups.items():
        r = spread[sl] / crb[sl]
        print(
            f"spread/CRB {gname}: median {np.median(r):.2f}, max {r.max():.2f}; "
            f"max |bias| {np.abs(bias[sl]).max():.4f}, max |error| {np.abs(est[:, sl] - truth_vec[sl]).max():.4f}"
        )
    corr = np.mean(corr_kn, axis=0)
    print(
        f"correlation of log k with n (inverse Fisher, mean over draws): median {np.median(corr):.3f}, "
        f"min {corr.min():.3f}, max {corr.max():.3f}"
    )

    def rel(sl):
        return np.abs(np.exp(est[:, sl] - truth_vec[sl]) - 1), np.abs(np.exp(bias[sl]) - 1)

    err = est - truth_vec
    print("\nrecovery (per draw: every estimate of every draw; bias: mean over draws - truth):")
    for label, (e_, b_) in (
        ("k [N/m^n]", rel(slice(0, 10))),
        ("k_ref = k x_ref^n, force at 5 mm", rel(slice(43, 53))),
    ):
        print(
            f"  {label:>34}: per draw median {np.median(e_):.1%}, max {e_.max():.1%}; |bias| max {b_.max():.1%}"
        )
    for j, nm in ((10, "n"), (11, "c")):
        e_ = np.abs(est[:, j] / truth_vec[j] - 1)
        print(
            f"  {nm:>34}: per draw median {np.median(e_):.1%}, max {e_.max():.1%}; |bias| {abs(bias[j] / truth_vec[j]):.1%}"
        )
    for a, ax in enumerate("xyz"):
        sl = slice(13 + a, 43, 3)
        e_ = np.abs(err[:, sl])
        print(
            f"  {'sole d' + ax + ' [mm]':>34}: per draw median {np.median(e_):.2f}, max {e_.max():.2f};"
            f" |bias| max {np.abs(bias[sl]).max():.2f}; CRB sd median {np.median(crb[sl]):.2f}, max {crb[sl].max():.2f}"
        )


if __name__ == "__main__":
    main()
