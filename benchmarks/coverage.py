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
import sys
import time

import numpy as np

from gc_ocp.estimation import ContactLaw, Param, PoseCorrection, SoleCorrection, build_estimation
from gc_ocp.estimation.solve import IpoptOptions, decode, solve
from gc_ocp.estimation.synthetic import default_truth, nominal_points, synthetic_stance

UNITS = ("PL", "PM", "AL", "AM", "TT")
SIDES = ("left", "right")


def ar1(rng, T, rho, sd, shape):
    e = np.empty((T, *shape))
    e[0] = rng.normal(0, sd, shape)
    for t in range(1, T):
        e[t] = rho * e[t - 1] + np.sqrt(1 - rho**2) * rng.normal(0, sd, shape)
    return e


def draw(rng, truth, disp, rho, marker_noise):
    sts = []
    for side, t_off in (("left", 0.0), ("right", 0.55)):
        for j in range(3):
            st = synthetic_stance(
                side,
                truth,
                nominal_points(side) + disp[side],
                t0=1.1 * j + t_off,
                sink=0.010,
                rng=rng,
                marker_noise=marker_noise,
                label=f"syn:{side}{j}",
            )
            sd = 0.01 * st.body_weight
            noise = ar1(rng, st.n, rho, 1.0, (6,)) * np.array([sd, sd, sd, *(3 * [sd * 0.02])])
            sts.append(st.with_measured(st.measured + noise))
    return sts


def white_covariance(problem, x):
    r, J = problem.data_jacobian(x)
    s2 = float(r @ r) / max(problem.n_data - x.size, 1)
    H = (J.T @ J).toarray() / s2 + np.diag(problem.prior_weights**2)
    return np.linalg.inv(H)


def values(blocks, truth, disp):
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
    args = ap.parse_args()
    truth = default_truth()
    rng0 = np.random.default_rng(1)
    disp = {}
    for side in SIDES:
        d = rng0.normal(size=(5, 3))
        disp[side] = d * (rng0.uniform(0, 0.008, 5) / np.linalg.norm(d, axis=1))[:, None]
    model = (
        ContactLaw(
            k=Param("unit", 2e5, 1e2, 1e9, prior_sigma=2.0),
            n=Param("shared", 1.3, 1, 3),
            c=Param("shared", 0.5, 0, 10),
            mu=Param("shared", 0.6, 0, 1.5),
        ),
        SoleCorrection(),
        PoseCorrection(),
    )
    hits: dict = {}
    bias: list = []
    t0 = time.perf_counter()
    done = 0
    for i in range(args.draws):
        rng = np.random.default_rng(100 + i)
        pb = build_estimation(draw(rng, truth, disp, args.rho, args.marker_noise), model)
        try:
            res = solve(pb, IpoptOptions())
        except Exception as e:
            print(f"draw {i}: {type(e).__name__}", file=sys.stderr)
            continue
        done += 1
        bias.append([res.params["shared"][p] - truth[p] for p in ("n", "c", "mu")])
        for label, cov in (("HAC", res.covariance), ("white", white_covariance(pb, res.x))):
            blocks, _ = decode(pb, res.x, cov)
            for name, est, se, tv in values(blocks, truth, disp):
                key = name.split(" ")[0] if name.startswith("sole") else name
                if name.startswith("sole"):
                    key = "sole offsets (30)"
                elif name.startswith("f_ref"):
                    key = "f_ref per unit (10)"
                hits.setdefault((key, label), []).append(abs(est - tv) <= 1.96 * se)
        print(
            f"draw {i + 1}/{args.draws} ({time.perf_counter() - t0:.0f} s)",
            file=sys.stderr,
            flush=True,
        )
    print(
        f"# Coverage of 95 % intervals: {done} draws, AR(1) plate errors rho = {args.rho} per frame\n"
    )
    print("| parameter | HAC (reported) | white (classical) |")
    print("|---|---|---|")
    for key in dict.fromkeys(k for k, _ in hits):
        h, w = np.mean(hits[(key, "HAC")]), np.mean(hits[(key, "white")])
        print(f"| {key} | {h:.0%} | {w:.0%} |")
    b = np.array(bias)
    print(
        "\nMean error over the draws (bias, and spread): "
        + ", ".join(
            f"{p} {b[:, j].mean():+.3f} ({b[:, j].std():.3f})"
            for j, p in enumerate(("n", "c", "mu"))
        )
        + f"; truth n {truth['n']}, c {truth['c']}, mu {truth['mu']}"
    )
    print(
        f"\nBinomial spread of one coverage figure: +- {np.sqrt(0.95 * 0.05 / max(done, 1)):.1%} (one parameter)."
    )


if __name__ == "__main__":
    main()
