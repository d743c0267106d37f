"""Cramér-Rao bounds at the truth for the synthetic-recovery designs: what limits k?

F = J^T J of all weighted residuals (data with the true sigma, and priors) at the TRUE decision
vector (log k, n, c, mu, sole displacement / sigma, pose corrections 0); no solve. The covariance
of the shared parameters (contact + sole) comes from a Schur complement over the per-stance
pose blocks. Same truth as ``synthetic_recovery.py`` (displacement draw seed 100, styles seed
200, sink 10 mm, 5 N plate noise, torque length 0.05 m) and the same pose prior (per-axis sd of
the pose error of the simulated 1 mm marker pipeline, 30 ms knots).

Designs: A (3 stances/foot, pose correction), B (A without pose correction: kinematics known),
C (pose knots 80 ms), D<n> (n stances/foot varied +-30 %; D<n>i identical), F* (sensitivities:
sink depth, roll, pitch, torque weight, plate noise, prior widths). Each also with the sole
correction restricted to z ("sole z only": x, y known). Design A also prints the correlations
of each log k and the share of its variance due to each group of nuisance parameters.

Run: PYTHONPATH=. python benchmarks/crb_design.py A B C D3 D10 D20   (A ~40 s, D20 ~1 min)
Output of that run: benchmarks/crb_design_output.txt.
"""

from __future__ import annotations

import sys
import time

import numpy as np
import scipy.sparse as sp
from synthetic_recovery import (  # same folder; run as a script
    estimator_law,
    pose_error_sd,
    sole_displacements,
    stance_styles,
)

from gc_ocp.estimation.components import (
    BeltSpeed,
    PoseCorrection,
    SoleCorrection,
)
from gc_ocp.estimation.problem import Weights, build_estimation
from gc_ocp.estimation.synthetic import default_truth, nominal_points, synthetic_stance
from gc_ocp.foot import UNITS

SIDES = ("left", "right")
TRUTH = default_truth()
BW = 700.0


DISP = sole_displacements()
_S_MM, _S_DEG = pose_error_sd(0.001, 0.03)
POSE_A = PoseCorrection(knot_spacing=0.03, sigma_mm=_S_MM, sigma_deg=_S_DEG)


def build(
    stances=3,
    vary=0.0,
    pose=POSE_A,
    sink=0.010,
    torque_length=0.05,
    force_noise=5.0,
    style_scale=None,
    sole=None,
):
    sole = sole or SoleCorrection()
    model = tuple(m for m in (estimator_law(), sole, pose, BeltSpeed()) if m is not None)
    weights = Weights(force_sigma=force_noise / BW, torque_length=torque_length)
    styles = stance_styles(stances, vary)
    if style_scale is not None:
        styles = {key: v * np.asarray(style_scale) for key, v in styles.items()}
    sts = [
        synthetic_stance(
            side,
            TRUTH,
            nominal_points(side) + DISP[side],
            t0=1.1 * j + 0.55 * i,
            sink=sink,
            rng=np.random.default_rng(0),
            force_noise=0.0,
            body_weight=BW,
            style=styles[(side, j)],
        )
        for i, side in enumerate(SIDES)
        for j in range(stances)
    ]
    prob = build_estimation(sts, model, weights)
    v = prob.variables
    x = np.zeros(prob.x.shape[0])
    for s in SIDES:
        for iu, u in enumerate(UNITS):
            x[v.spec(("contact", "k", s, u)).slice] = np.log(TRUTH["k"][iu])
            if v.has(("sole", s, u)):
                x[v.spec(("sole", s, u)).slice] = DISP[s][iu] / sole.sigma
    for p in ("n", "c", "mu"):
        x[v.spec(("contact", p)).slice] = TRUTH[p]
    return prob, x


def names_of(specs):
    """``(key, j)`` of every entry of the decision vector, from the variable specs."""
    names = [None] * sum(s.size for s in specs)
    for s in specs:
        for j in range(s.size):
            names[s.start + j] = (s.key, j)
    return names


def sparse_jacobian(prob, x):
    """All weighted residuals' Jacobian (data rows from per-frame Jacobians, then prior rows)."""
    _, Jd = prob.data_jacobian(x)
    pw = prob.prior_weights
    idx = np.flatnonzero(pw > 0)
    Jp = sp.csr_matrix((pw[idx], (np.arange(idx.size), idx)), shape=(idx.size, x.size))
    return sp.vstack([Jd, Jp], format="csc")


def analyse(prob, x, fix=(), dense=False):
    """Return dict: name -> sd of shared params (k as log k, sole in mm). ``fix``: predicate on a
    (key, j) name; those columns are deleted (parameter known exactly)."""
    names = names_of(prob.variables.specs)
    J = sparse_jacobian(prob, x)
    keep = np.array([not any(f(nm) for f in fix) for nm in names])
    kidx = np.flatnonzero(keep)
    J = J[:, kidx]
    names = [names[i] for i in kidx]
    F = (J.T @ J).tocsc()
    is_pose = np.array([nm[0][0] == "pose" for nm in names])
    S = np.flatnonzero(~is_pose)
    FSS = F[S][:, S].toarray()
    if dense:
        cov = np.linalg.inv(F.toarray())
        covS = cov[np.ix_(S, S)]
    else:
        cov = None
        stances = sorted({nm[0][1] for nm in names if nm[0][0] == "pose"})
        for i in stances:
            P = np.flatnonzero([nm[0][0] == "pose" and nm[0][1] == i for nm in names])
            FPP = F[P][:, P].toarray()
            FSP = F[S][:, P].toarray()
            FSS -= FSP @ np.linalg.solve(FPP, FSP.T)
        covS = np.linalg.inv(FSS)
    snames = [names[i] for i in S]
    sd = np.sqrt(np.diag(covS))
    return dict(sd=sd, names=snames, cov=cov, all_names=names, covS=covS)


def summarise(label, r, sole_sigma=0.005):
    out = {}
    names, sd = r["names"], r["sd"]
    get = {nm: s for nm, s in zip(names, sd, strict=True)}
    k = np.array([get[(("contact", "k", s, u), 0)] for s in SIDES for u in UNITS])
    out["k_med"], out["k_max"] = np.median(k) * 100, k.max() * 100
    out["n"] = get.get((("contact", "n"), 0), np.nan) / TRUTH["n"] * 100
    out["c"] = get.get((("contact", "c"), 0), np.nan) / TRUTH["c"] * 100
    out["mu"] = get.get((("contact", "mu"), 0), np.nan) / TRUTH["mu"] * 100
    for a, ax in enumerate("xyz"):
        v = (
            np.array([get.get((("sole", s, u), a), np.nan) for s in SIDES for u in UNITS])
            * sole_sigma
            * 1e3
        )
        out[f"d{ax}_med"], out[f"d{ax}_max"] = (
            (np.median(v), v.max()) if np.all(np.isfinite(v)) else (np.nan, np.nan)
        )
    out["k_units"] = k * 100
    line = (
        f"{label:<38} k med {out['k_med']:6.2f}% max {out['k_max']:6.2f}% | n {out['n']:5.2f}% c {out['c']:5.2f}% "
        f"mu {out['mu']:5.2f}% | dx {out['dx_med']:.2f}/{out['dx_max']:.2f} dy {out['dy_med']:.2f}/{out['dy_max']:.2f} "
        f"dz {out['dz_med']:.2f}/{out['dz_max']:.2f} mm"
    )
    print(line, flush=True)
    ni = names.index((("contact", "n"), 0)) if (("contact", "n"), 0) in names else None
    if ni is not None:
        V = r["covS"]
        f5, dopt, fopt = [], [], []
        for s in SIDES:
            for u in UNITS:
                ki = names.index((("contact", "k", s, u), 0))
                L = np.log(0.005)
                f5.append(np.sqrt(V[ki, ki] + 2 * L * V[ki, ni] + L * L * V[ni, ni]) * 100)
                Lo = -V[ki, ni] / V[ni, ni]
                dopt.append(np.exp(Lo) * 1e3)
                fopt.append(np.sqrt(V[ki, ki] - V[ki, ni] ** 2 / V[ni, ni]) * 100)
        out["F5_med"], out["F5_max"] = np.median(f5), np.max(f5)
        print(
            f"    force at 5 mm depth, k*d^n: sd med {np.median(f5):.2f}% max {np.max(f5):.2f}%; "
            f"best-determined depth per unit [mm] "
            + " ".join(f"{d:.1f}" for d in dopt)
            + f" (sd there med {np.median(fopt):.2f}% max {np.max(fopt):.2f}%)",
            flush=True,
        )
    print(
        "    k per unit [%]: "
        + " ".join(
            f"{s[0]}{u}:{v:.2f}"
            for (s, u), v in zip(
                [(s, u) for s in SIDES for u in UNITS], out["k_units"], strict=True
            )
        ),
        flush=True,
    )
    return out


def fix_xy(nm):
    return nm[0][0] == "sole" and nm[1] in (0, 1)


def fix_group(group):
    def f(nm):
        key, j = nm
        if group == "pose":
            return key[0] == "pose"
        if group == "pose_trans":
            return key[0] == "pose" and key[2] == "trans"
        if group == "pose_rot":
            return key[0] == "pose" and key[2] == "rot"
        if group == "sole":
            return key[0] == "sole"
        if group == "sole_z":
            return key[0] == "sole" and j == 2
        if group == "sole_xy":
            return key[0] == "sole" and j in (0, 1)
        if group == "ncmu":
            return key[0] == "contact" and key[1] in ("n", "c", "mu")
        if group == "n":
            return key[0] == "contact" and key[1] == "n"
        if group == "c":
            return key[0] == "contact" and key[1] == "c"
        if group == "mu":
            return key[0] == "contact" and key[1] == "mu"
        return False

    return f


def fmt(nm):
    key, j = nm
    if key[0] == "pose":
        return f"pose[stance{key[1]}].{key[2]}[{'xyz'[j % 3]},knot{j // 3}]"
    if key[0] == "sole":
        return f"sole.{key[1]}.{key[2]}.d{'xyz'[j]}"
    return ".".join(str(p) for p in key)


def correlations(r, top=5):
    cov, names = r["cov"], r["all_names"]
    sd = np.sqrt(np.diag(cov))
    C = cov / np.outer(sd, sd)
    print("\nCorrelations of log k with other variables (design A, full inverse Fisher):")
    for s in SIDES:
        for u in UNITS:
            i = names.index((("contact", "k", s, u), 0))
            c = C[i].copy()
            c[i] = 0
            o = np.argsort(-np.abs(c))[:top]
            print(f"  {s}.k_{u}: " + ", ".join(f"{fmt(names[j])} {c[j]:+.2f}" for j in o))
            # strongest per group (best single variable per key)
            best = {}
            for j, nm in enumerate(names):
                if j == i:
                    continue
                g = (
                    nm[0][0]
                    if nm[0][0] != "contact"
                    else "contact."
                    + nm[0][1]
                    + ("" if len(nm[0]) == 2 else f".{nm[0][2]}.{nm[0][3]}")
                )
                if g not in best or abs(c[j]) > abs(c[best[g]]):
                    best[g] = j
            # multiple correlation R^2 of log k with each group (fraction of var explained)
    return C


def multiple_r2(r, i_name, group_pred):
    """R^2 of one variable on a group of others (Gaussian, from cov): 1 - var(i | group)/var(i)."""
    cov, names = r["cov"], r["all_names"]
    i = names.index(i_name)
    G = [j for j, nm in enumerate(names) if group_pred(nm) and j != i]
    cig = cov[i, G]
    cgg = cov[np.ix_(G, G)]
    return float(cig @ np.linalg.solve(cgg, cig) / cov[i, i])


if __name__ == "__main__":
    which = sys.argv[1:] or ["A"]
    t0 = time.perf_counter()
    results = {}
    for d in which:
        t = time.perf_counter()
        if d == "A":
            prob, x = build()
            r = analyse(prob, x, dense=True)
            results[d] = summarise("A  3 st/foot, pose 30 ms", r)
            r2 = analyse(prob, x)
            print(
                "    (Schur vs dense max rel diff {:.1e})".format(
                    np.max(np.abs(r2["sd"] / r["sd"] - 1))
                )
            )
            C = correlations(r)
            print(
                "\n  R^2 of each log k on a group (share of its variance due to that group's uncertainty is ~ R^2):"
            )
            grp = {
                "other k": lambda nm: nm[0][:2] == ("contact", "k"),
                "n,c,mu": fix_group("ncmu"),
                "sole all": fix_group("sole"),
                "sole z": fix_group("sole_z"),
                "sole xy": fix_group("sole_xy"),
                "pose all": fix_group("pose"),
                "pose trans": fix_group("pose_trans"),
                "pose rot": fix_group("pose_rot"),
            }
            for s in SIDES:
                for u in UNITS:
                    nm = (("contact", "k", s, u), 0)
                    print(
                        f"  {s}.k_{u}: "
                        + ", ".join(f"{g} {multiple_r2(r, nm, p):.2f}" for g, p in grp.items())
                    )
            print("\n  k CRB with one group fixed at truth (design A):")
            for g in (
                "ncmu",
                "n",
                "c",
                "mu",
                "sole",
                "sole_z",
                "sole_xy",
                "pose",
                "pose_trans",
                "pose_rot",
            ):
                summarise(f"A, {g} known", analyse(prob, x, fix=(fix_group(g),)))
            summarise("E  A + sole z only (x,y known)", analyse(prob, x, fix=(fix_xy,)))
        elif d == "B":
            prob, x = build(pose=None)
            results[d] = summarise("B  A without PoseCorrection", analyse(prob, x))
            summarise("B+E  no pose, sole z only", analyse(prob, x, fix=(fix_xy,)))
        elif d == "C":
            prob, x = build(
                pose=PoseCorrection(knot_spacing=0.08, sigma_mm=_S_MM, sigma_deg=_S_DEG)
            )
            results[d] = summarise("C  pose knots 80 ms", analyse(prob, x))
            summarise("C+E  pose 80 ms, sole z only", analyse(prob, x, fix=(fix_xy,)))
        elif d.startswith("D"):  # D3, D10, D20 ; D3s = identical stances with n stances
            n = int(d[1:].rstrip("i"))
            vary = 0.0 if d.endswith("i") else 0.3
            prob, x = build(stances=n, vary=vary)
            lab = f"D  {n} st/foot, vary {vary}"
            results[d] = summarise(lab, analyse(prob, x))
            summarise("E  " + lab + ", sole z only", analyse(prob, x, fix=(fix_xy,)))
        elif d.startswith("F"):
            opts = {
                "Fsink15": dict(sink=0.015),
                "Fsink6": dict(sink=0.006),
                "Froll2": dict(style_scale=[1, 1, 2, 1]),
                "Froll0": dict(style_scale=[1, 1, 1e-3, 1]),
                "Fpitch": dict(style_scale=[1.5, 1.5, 1, 1]),
                "Ftl25": dict(torque_length=0.25),
                "Ftl01": dict(torque_length=0.01),
                "Fnoise2": dict(force_noise=2.0),
                "Fpose_wide": dict(
                    pose=PoseCorrection(knot_spacing=0.03, sigma_mm=1.0, sigma_deg=1.0)
                ),
                "Fpose_narrow": dict(
                    pose=PoseCorrection(knot_spacing=0.03, sigma_mm=0.1, sigma_deg=0.1)
                ),
                "Fsole2": dict(sole=SoleCorrection(sigma=0.002)),  # noqa: B008
                "Fsole10": dict(sole=SoleCorrection(sigma=0.010)),
            }[d]
            prob, x = build(**opts)
            sig = opts.get("sole", SoleCorrection()).sigma
            results[d] = summarise(
                f"{d} {opts if 'pose' not in opts and 'sole' not in opts else d}",
                analyse(prob, x),
                sole_sigma=sig,
            )
            summarise(f"{d} + sole z only", analyse(prob, x, fix=(fix_xy,)), sole_sigma=sig)
        print(f"  [{d}: {time.perf_counter() - t:.0f} s]", flush=True)
    print(f"total {time.perf_counter() - t0:.0f} s")
