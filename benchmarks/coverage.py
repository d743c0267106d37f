"""Do the standard errors tell the truth? Coverage of 95 % intervals on synthetic data whose
errors are autocorrelated, as real residuals are.

Usage::

    PYTHONPATH=. python benchmarks/coverage.py [--draws 40] [--rho 0.9]

Each draw: 6 synthetic stances (3 per foot, the rolling foot of ``gc_ocp.synthetic_foot``, true
k per unit, n = 1.5, c = 1 s/m, mu = 0.8, sole points displaced by up to 8 mm); plate errors
AR(1) with lag-one correlation ``rho`` per 10 ms frame and 1 % BW standard deviation on forces
(moments: 1 % BW x 20 mm); foot poses seen through noisy virtual markers (0.5 mm, Kabsch, 6 Hz).
Fitted with the contact law (k per unit, n, c, mu) and sole and pose corrections, one Ipopt
solve from a start away from the truth. For every parameter, the fraction of draws whose
interval estimate +- 1.96 SE contains the truth, with two covariances of the same fit:

* ``white``: the classical Gauss-Newton covariance scaled by the residual variance (what
  gc_ocp reported before), which assumes independent residuals;
* ``HAC``: the sandwich with a Newey-West estimate of the scores' covariance
  (``gc_ocp.estimation.solve._covariance``), what gc_ocp reports now.

Target: >= 90 % for every parameter. Binomial spread of a coverage estimate from N draws at
95 %: sqrt(0.95 * 0.05 / N) (3.4 % at N = 40).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time

import numpy as np
from scipy.spatial.transform import Rotation

from gc_ocp.diagnosis.mismatch import drift, drift_pattern
from gc_ocp.estimation import build_estimation
from gc_ocp.estimation.bias import _stance_columns, bias_corrected, replicate_covariance
from gc_ocp.estimation.pose_scale import ar1_knot_correlation, estimate_pose_scale
from gc_ocp.estimation.solve import IpoptOptions, _covariance, decode, solve
from gc_ocp.estimation.synthetic import (
    default_truth,
    noisy_pose,
    nominal_points,
    recovery_model,
    synthetic_stance,
)
from gc_ocp.workflow.fitting import bias_replicates

UNITS = ("PL", "PM", "AL", "AM", "TT")
SIDES = ("left", "right")


def sole_displacement() -> dict:
    """``{side: (5, 3)}`` [m] the true units' displacement from nominal: a random direction and
    up to 8 mm per unit, the same for every draw (seeded)."""
    rng = np.random.default_rng(1)
    disp = {}
    for side in SIDES:
        d = rng.normal(size=(5, 3))
        disp[side] = d * (rng.uniform(0, 0.008, 5) / np.linalg.norm(d, axis=1))[:, None]
    return disp


def ar1(rng, T, rho, sd, shape):
    e = np.empty((T, *shape))
    e[0] = rng.normal(0, sd, shape)
    for t in range(1, T):
        e[t] = rho * e[t - 1] + np.sqrt(1 - rho**2) * rng.normal(0, sd, shape)
    return e


def true_stances(rng, truth, disp, marker_noise=0.0):
    """The benchmark's six stances (three per foot) of ``truth`` with the units displaced by
    ``disp``; ``marker_noise`` [m]: the pose the fitter sees from noisy markers."""
    return [
        synthetic_stance(
            side,
            truth,
            nominal_points(side) + disp[side],
            t0=1.1 * j + t_off,
            sink=0.010,
            rng=rng,
            marker_noise=marker_noise,
            label=f"syn:{side}{j}",
        )
        for side, t_off in (("left", 0.0), ("right", 0.55))
        for j in range(3)
    ]


def draw(rng, truth, disp, rho, marker_noise, drift_mm=0.0, drift_deg=0.0, independent=False):
    sts = true_stances(rng, truth, disp, marker_noise if drift_mm == 0 else 0.0)
    seen = disp
    if drift_mm > 0:
        # soft tissue first (a smooth rigid drift of the marker cluster, the pattern shared by a
        # foot's stances), then the markers' noise on what the skin carries
        pattern = drift_pattern(SIDES, drift_mm * 1e-3, drift_deg, rng)
        variation = 0.25
        if independent:  # no pattern shared by a foot's strides: each stance its own drift
            pattern = {s: (0.0 * tr, 0.0 * rot) for s, (tr, rot) in pattern.items()}
            variation = 1.0
        seen = {s: seen_displacement(sts, s, pattern[s], disp[s]) for s in SIDES}
        sts = drift(sts, drift_mm * 1e-3, drift_deg, rng, variation, pattern=pattern)
        sts = [st.with_foot(noisy_pose(st.foot, marker_noise, rng)) for st in sts]
    out = []
    for st in sts:
        sd = 0.01 * st.body_weight
        noise = ar1(rng, st.n, rho, 1.0, (6,)) * np.array([sd, sd, sd, *(3 * [sd * 0.02])])
        out.append(st.with_measured(st.measured + noise))
    return out, seen


def seen_displacement(stances, side, pattern, disp):
    """``(5, 3)`` [m] the units' displacement from nominal in the frame the *markers* define
    (what a fit can identify): a soft-tissue offset that every stride of a foot shares (the
    pattern's row 0) moves that frame against the bone, and no data tell it from the sole's
    geometry. The pattern's trend and the stride variation average out (zero mean over a
    stance and over stances); ``R(t)`` of the in-contact frames is averaged."""
    tr0, rot0 = pattern[0][0], pattern[1][0]
    E = Rotation.from_rotvec(rot0).as_matrix()
    p = nominal_points(side) + disp
    seen = []
    for st in stances:
        if st.side != side:
            continue
        R = st.foot.hindfoot_pose[st.in_contact, :3, :3]
        seen.append(np.mean([(p - Rt.T @ tr0) @ E for Rt in R], axis=0))  # E^T (p - R^T t)
    return np.mean(seen, axis=0) - nominal_points(side)


def independent_pose(model: tuple) -> tuple:
    """``model`` with the pose errors of a foot's stances taken as independent (the
    covariance before the shared part, ``PoseCorrection.shared``)."""
    return tuple(dataclasses.replace(c, shared=False) if c.name == "pose" else c for c in model)


def white_covariance(problem, x):
    r, J = problem.data_jacobian(x)
    s2 = float(r @ r) / max(problem.n_data - x.size, 1)
    H = (J.T @ J).toarray() / s2 + np.diag(problem.prior_weights**2)
    return np.linalg.inv(H)


def values(blocks, truth, disp):  # disp: the units' displacement in the markers' frame
    """(name, estimate, SE, true value) of every reported parameter."""
    out = []
    c = blocks["contact"]
    for p in ("n", "c", "mu"):
        out.append((p, c["shared"][p], c["shared"][p + "_se"], truth[p]))
    L = np.log(0.005)
    for side in SIDES:
        for j, u in enumerate(UNITS):
            e = c[side][u]
            f_true = truth["k"][j] * np.exp(truth["n"] * L)
            out.append((f"f_ref {side} {u}", e["f_ref"], e["f_ref_se"], f_true))
            off = blocks["sole"]["offsets_mm"][side][u]
            se = blocks["sole"]["se_mm"][side][u]
            for a, ax in enumerate("xyz"):
                out.append((f"sole {ax}", off[a], se[a], disp[side][j][a] * 1e3))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--draws", type=int, default=40)
    ap.add_argument("--rho", type=float, default=0.9)
    ap.add_argument("--marker-noise", type=float, default=0.5e-3, help="[m] (0: exact kinematics)")
    ap.add_argument(
        "--drift-mm", type=float, default=0.0, help="soft-tissue drift RMS per axis [mm] (0: none)"
    )
    ap.add_argument(
        "--drift-deg", type=float, default=None, help="[deg] (default: 0.25 x drift-mm)"
    )
    ap.add_argument(
        "--drift-independent",
        action="store_true",
        help="each stance its own drift (default: a pattern shared by a foot's strides, 25 %% "
        "stride variation)",
    )
    ap.add_argument(
        "--fixed-width",
        action="store_true",
        help="keep the pose correction's guessed width (the estimator before issue 23)",
    )
    ap.add_argument(
        "--width",
        type=float,
        nargs=2,
        metavar=("MM", "DEG"),
        default=None,
        help="fix the pose correction's smooth width at MM per axis and DEG per axis, not "
        "estimated (an oracle: the drift's own size); the sole keeps its 5 mm prior",
    )
    ap.add_argument(
        "--fixed-sole-width",
        action="store_true",
        help="keep the sole correction's 5 mm prior (fit's default until 2026-11-27; runs "
        "before then had it)",
    )
    ap.add_argument(
        "--knot-correlation",
        type=float,
        default=None,
        metavar="PHI",
        help="a probe: the pose correction's coefficients correlated PHI**k k knots apart "
        "(AR(1); default: independent, as gc_ocp.fit)",
    )
    ap.add_argument(
        "--estimate-correlation",
        action="store_true",
        help="estimate the pose coefficients' knot-to-knot correlation with the widths "
        "(estimate_pose_scale(correlation=True); default: independent, as gc_ocp.fit)",
    )
    ap.add_argument(
        "--bias-correction",
        type=int,
        default=None,
        metavar="B",
        help="remove the markers' noise's bias with B replicates (gc_ocp.estimation.bias; "
        "default: as gc_ocp.fit decides, 16 where the markers' noise moves the units by "
        "0.15 mm or more, else none; 0: off)",
    )
    args = ap.parse_args()
    truth = default_truth()
    disp = sole_displacement()
    model = recovery_model()
    if args.width is not None:
        model = tuple(
            dataclasses.replace(c, sigma_mm=args.width[0], sigma_deg=args.width[1])
            if c.name == "pose"
            else c
            for c in model
        )
    drift_deg = 0.25 * args.drift_mm if args.drift_deg is None else args.drift_deg
    hits: dict = {}
    bias: list = []
    bias_moves: list = []
    shared: list = []
    phis: list = []
    t0 = time.perf_counter()
    done = 0
    for i in range(args.draws):
        rng = np.random.default_rng(100 + i)
        data, seen = draw(
            rng,
            truth,
            disp,
            args.rho,
            args.marker_noise,
            args.drift_mm,
            drift_deg,
            args.drift_independent,
        )
        if args.knot_correlation is not None:  # the AR(1) sequence as the package builds it
            model = tuple(
                dataclasses.replace(
                    c, knot_correlation=ar1_knot_correlation(args.knot_correlation, c, data)
                )
                if c.name == "pose"
                else c
                for c in model
            )
        pb = build_estimation(data, model)
        try:
            res = solve(pb, IpoptOptions())
            fitted = model
            if not args.fixed_width and args.width is None:
                sole = not args.fixed_sole_width  # as gc_ocp.fit: with the pose width
                fitted, res, sc = estimate_pose_scale(
                    data, model, res, sole=sole, correlation=args.estimate_correlation
                )
                if sc is not None and sc.knot_correlation is not None:
                    phis.append(sc.knot_correlation)
                pb = build_estimation(data, fitted)
            B = bias_replicates(args.bias_correction, data)[0]  # as gc_ocp.fit
            info = None
            if B:
                res, info = bias_corrected(data, fitted, res, B, seed=i)
                bias_moves.append(info.bias)
        except Exception as e:
            print(f"draw {i}: {type(e).__name__}", file=sys.stderr)
            continue
        done += 1
        bias.append([res.params["shared"][p] - truth[p] for p in ("n", "c", "mu")])
        shared.append(res.pose_shared_fraction)
        indep = build_estimation(data, independent_pose(fitted))
        lin, lin_indep = _covariance(pb, res.x), _covariance(indep, res.x)
        replicate_part = None
        if info is not None:  # the correction's rule applied to each linearised covariance
            sh = np.setdiff1d(np.arange(res.x.size), _stance_columns(pb))
            S = np.cov(info.moves, rowvar=False).reshape(sh.size, sh.size)
            B = info.moves.shape[0]

            def replicate_part(c, S=S, sh=sh, B=B):
                return replicate_covariance(c, S, sh, B)

            lin_plus = lin.copy()
            lin_plus[np.ix_(sh, sh)] += S / B
        covs = (
            ("HAC", res.covariance),
            (
                "independent",
                lin_indep if replicate_part is None else replicate_part(lin_indep),
            ),
            ("white", white_covariance(pb, res.x)),
            # the rule before 2026-11-30: the linearised covariance plus the bias's MC error
            ("linearised + MC", lin if replicate_part is None else lin_plus),
        )
        for label, cov in covs:
            blocks, _ = decode(pb, res.x, cov)
            for name, est, se, tv in values(blocks, truth, seen):
                key = name.split(" ")[0] if name.startswith("sole") else name
                if name.startswith("sole"):
                    key = "sole offsets (30)"
                elif name.startswith("f_ref"):
                    key = "f_ref per unit (10)"
                hits.setdefault((key, label), []).append(abs(est - tv) <= 1.96 * se)
        raised = (
            f" (linearised {info.linearised_se.get('mu', np.nan):.4f}, replicates' spread "
            f"{info.spread.get('mu', np.nan):.4f})"
            if info is not None
            else ""
        )
        print(
            f"draw {i + 1}/{args.draws} ({time.perf_counter() - t0:.0f} s): mu error "
            f"{res.params['shared']['mu'] - truth['mu']:+.4f}, SE {res.params['shared']['mu_se']:.4f}"
            + raised,
            file=sys.stderr,
            flush=True,
        )
    print(
        f"# Coverage of 95 % intervals: {done} draws, AR(1) plate errors rho = {args.rho} per frame\n"
    )
    cols = ("HAC", "independent", "white") + (("linearised + MC",) if bias_moves else ())
    print(
        "| parameter | HAC (reported) | HAC, pose errors independent | white (classical) |"
        + (" linearised HAC + the bias's MC error (no replicate spread) |" if bias_moves else "")
    )
    print("|---" * (len(cols) + 1) + "|")
    for key in dict.fromkeys(k for k, _ in hits):
        print(f"| {key} | " + " | ".join(f"{np.mean(hits[(key, c)]):.0%}" for c in cols) + " |")
    rho = [v for d in shared for v in d.values()]
    if rho:
        print(
            f"\nShared fraction of the pose error measured per foot (PoseCorrection.shared): "
            f"median {np.median(rho):.2f} ({np.min(rho):.2f}-{np.max(rho):.2f}) over "
            f"{len(rho)} feet"
        )
    if phis:
        print(
            f"\nKnots' correlation estimated per draw: median {np.median(phis):.2f} "
            f"({np.min(phis):.2f}-{np.max(phis):.2f}) over {len(phis)} draws"
        )
    b = np.array(bias)
    print(
        "\nMean error over the draws (bias, and spread): "
        + ", ".join(
            f"{p} {b[:, j].mean():+.3f} ({b[:, j].std():.3f})"
            for j, p in enumerate(("n", "c", "mu"))
        )
        + f"; truth n {truth['n']}, c {truth['c']}, mu {truth['mu']}"
    )
    if bias_moves:
        print(
            f"\nBias removed by the correction ({len(bias_moves)} of {done} draws corrected; "
            "mean over them): "
            + ", ".join(f"{p} {np.mean([m[p] for m in bias_moves]):+.4f}" for p in ("n", "c", "mu"))
        )
    print(
        f"\nBinomial spread of one coverage figure: +- {np.sqrt(0.95 * 0.05 / max(done, 1)):.1%} (one parameter)."
    )


if __name__ == "__main__":
    main()
