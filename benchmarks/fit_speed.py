"""Fit speed: our path (CasADi exact derivatives + Ipopt) vs a hand-written FD least-squares baseline.

Run:  python benchmarks/fit_speed.py [--quick]

Our path  = build_estimation + make_solver (Ipopt with CasADi gradient and the structured exact
            Hessian, no SX expansion) + Ipopt solve, exactly what
            ``gc_ocp.estimation.solve.solve`` does before its post-processing (covariance, decoding),
            which is timed separately once on the real trial.
Baseline  = scipy.optimize.least_squares(method="trf", jac="2-point") on the SAME residual vector
            (``problem.residuals`` incl. the prior terms, so J = 0.5 ||r||^2 is the same objective),
            same bounds, same start (problem.x0 clipped into the bounds), default tolerances,
            wall-time budget per run (reported if hit, with the objective reached).
See benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import statistics
import time

import casadi as ca
import numpy as np
from scipy.optimize import least_squares

from gc_ocp.estimation.components import full_model
from gc_ocp.estimation.problem import build_estimation
from gc_ocp.estimation.solve import IpoptOptions, make_solver, solve
from gc_ocp.estimation.starts import with_lls_start
from gc_ocp.estimation.synthetic import default_truth, synthetic_stance


class _Budget(Exception):
    pass


def ours(stances, model, repeats: int):
    """Build + nlpsol + Ipopt, ``repeats`` times. Returns dict of medians and the last problem."""
    rows = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        prob = build_estimation(stances, model)
        t1 = time.perf_counter()
        solver = make_solver(prob, IpoptOptions())
        t2 = time.perf_counter()
        sol = solver(x0=prob.x0, lbx=prob.lbx, ubx=prob.ubx)
        t3 = time.perf_counter()
        st = solver.stats()
        rows.append(
            dict(
                build=t1 - t0,
                nlpsol=t2 - t1,
                ipopt=t3 - t2,
                total=t3 - t0,
                iters=int(st["iter_count"]),
                status=str(st["return_status"]),
                obj=float(sol["f"]),
            )
        )
    med = {k: statistics.median(r[k] for r in rows) for k in ("build", "nlpsol", "ipopt", "total")}
    med["spread"] = (min(r["total"] for r in rows), max(r["total"] for r in rows))
    med.update(iters=rows[-1]["iters"], status=rows[-1]["status"], obj=rows[-1]["obj"], n=repeats)
    return med, prob


def baseline(prob, budget_s: float, x0: np.ndarray | None = None):
    """scipy least_squares, FD Jacobian, on the same residuals; stops at ``budget_s`` wall seconds.
    ``x0``: a warm start (default: the problem's start)."""
    rf = ca.Function("r", [prob.x], [prob.residuals])
    lb, ub = prob.lbx, prob.ubx
    x0 = np.clip(prob.x0 if x0 is None else x0, lb, ub)
    best = {"obj": np.inf, "nfev": 0, "x": x0}
    t0 = time.perf_counter()

    def fun(x):
        if time.perf_counter() - t0 > budget_s:
            raise _Budget
        r = np.asarray(rf(x)).ravel()
        best["nfev"] += 1
        o = 0.5 * float(r @ r)
        if o < best["obj"]:
            best["obj"], best["x"] = o, np.array(x)
        return r

    capped = False
    status = ""
    try:
        res = least_squares(fun, x0, jac="2-point", method="trf", bounds=(lb, ub))
        obj, x = float(res.cost), res.x
        status = f"status {res.status} ({res.message.split('.')[0]})"
    except _Budget:
        capped = True
        obj, x = best["obj"], best["x"]
        status = f"STOPPED at the {budget_s:.0f} s budget"
    return dict(
        total=time.perf_counter() - t0,
        obj=obj,
        capped=capped,
        status=status,
        nfev=best["nfev"],
        x=x,
    )


def baseline_joint(data, model, first: dict, budget_s: float) -> dict:
    """The joint estimator's own rounds (:func:`gc_ocp.estimation.pose_scale.estimate_pose_scale`:
    MacKay's update of the pose and sole widths, then a warm refit, until no width moves
    ``RTOL``) with every refit the FD baseline's, starting from the FD fit ``first`` of
    ``model``. The update itself uses the exact Jacobian (one evaluation per round; the solves
    are what FD makes dear)."""
    from gc_ocp.estimation.pose_scale import estimate_pose_scale
    from gc_ocp.estimation.solve import result_at

    counts = {"nfev": first["nfev"], "capped": first["capped"]}

    def fd_refit(prob, x0, covariance):
        b = baseline(prob, budget_s, x0=x0)
        counts["nfev"] += b["nfev"]
        counts["capped"] |= b["capped"]
        return result_at(prob, b["x"], covariance=False)

    t0 = time.perf_counter()
    start = result_at(build_estimation(data, model), first["x"], covariance=False)
    _, fitted, scale = estimate_pose_scale(data, model, start, refit=fd_refit, sole=True)
    return dict(
        total=first["total"] + time.perf_counter() - t0,
        obj=fitted.objective,
        rounds=len(scale.rounds),
        **counts,
    )


def real_trial(repeats: int, budget: float):

    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics
    from gc_ocp.stance import stance_data

    trial = load_trial()
    kin = compute_kinematics(trial)
    data = [stance_data(trial, kin, s, 0.03, 5) for s in trial.stances]
    model = with_lls_start(full_model(), data)  # as fit()
    frames = sum(d.n for d in data)
    print(
        f"\n== 1. Real trial (bundled example): {len(data)} stances "
        f"({', '.join(d.side for d in data)}), {frames} frames, full model =="
    )
    o, prob = ours(data, model, repeats)
    print(f"   {prob.x.shape[0]} variables, {prob.residuals.shape[0]} residuals")
    t = time.perf_counter()
    solve(prob)
    t_full = time.perf_counter() - t
    b = baseline(prob, budget)
    print(
        f"   ours     : {o['total']:8.2f} s  (median of {o['n']}; min {o['spread'][0]:.2f}, max {o['spread'][1]:.2f};"
        f" build {o['build']:.2f} + nlpsol {o['nlpsol']:.2f} + Ipopt {o['ipopt']:.2f})"
        f"  J = {o['obj']:.6g}  {o['iters']} it, {o['status']}"
    )
    print(
        f"   baseline : {b['total']:8.2f} s  J = {b['obj']:.6g}  {b['nfev']} residual evals, {b['status']}"
    )
    print(
        f"   ratio baseline/ours = {b['total'] / o['total']:.1f}x"
        + (
            f"  (LOWER BOUND: baseline stopped, J {b['obj'] / o['obj']:.3g}x ours)"
            if b["capped"]
            else f"  (J baseline/ours = {b['obj'] / o['obj']:.4g})"
        )
    )
    print(
        f"   ratio baseline/(Ipopt call only, excl. build+nlpsol setup) = {b['total'] / o['ipopt']:.1f}x"
    )
    print(
        f"   note: gc_ocp.estimation.solve.solve() end to end (nlpsol setup + Ipopt + covariance + decoding)"
        f" took {t_full:.2f} s"
    )
    from gc_ocp.estimation.pose_scale import lowest_with_widths
    from gc_ocp.estimation.starts import best_of

    # the fit() path and the joint estimator timed as the single solve above: the median of
    # ``repeats`` runs in this warm process (the first run, which also pays one-time costs of the
    # process such as the rounds' first problem builds, is printed beside it)
    # (as fit() runs them: the fit() path alone computes its covariance; before the width
    # rounds no covariance, the rounds compute it on their last refit)
    t_fits, t_joints = [], []
    for _ in range(repeats):
        t = time.perf_counter()
        r = best_of(data, model, trust_region=True)  # the starts fit() runs
        t_fits.append(time.perf_counter() - t)
        t = time.perf_counter()
        others: list = []  # as fit(): the other minima compared again at the estimated widths
        r0 = best_of(data, model, covariance=False, others=others, trust_region=True)
        _, rj, sc, _, _ = lowest_with_widths(data, model, r0, others, sole=True)
        t_joints.append(time.perf_counter() - t)
    t_fit, t_joint = statistics.median(t_fits), statistics.median(t_joints)
    print(
        f"   ours, fit() path (3 starts: direct, prior continuation, trust-region warm-up; best "
        f"kept): {t_fit:.2f} s "
        f"(median of {repeats}; min {min(t_fits):.2f}, max {max(t_fits):.2f}, first {t_fits[0]:.2f}), "
        f"J = {r.objective:.6g}; ratio baseline/fit() = {b['total'] / t_fit:.1f}x "
        f"(J baseline/fit() = {b['obj'] / r.objective:.4g})"
    )
    print(
        f"   joint estimator (fit() path + the pose and sole widths estimated and the other "
        f"minima compared at them, as fit() does by default; issue 23; {len(sc.rounds)} warm "
        f"refits in the last rounds): {t_joint:.2f} s (median of {repeats}; "
        f"min {min(t_joints):.2f}, max {max(t_joints):.2f}, first {t_joints[0]:.2f}) = "
        f"{t_joint / t_fit:.2f}x the fit() path, J = {rj.objective:.6g}; ratio baseline/joint = "
        f"{b['total'] / t_joint:.1f}x (first run: {b['total'] / t_joints[0]:.1f}x; this trial's "
        "markers were low-passed before export: no marker-noise part)"
    )
    bj = baseline_joint(data, model, b, budget)
    print(
        f"   baseline, joint (the same width rounds, every solve FD): {bj['total']:.2f} s, "
        f"{bj['rounds']} refits, {bj['nfev']} residual evals, J = {bj['obj']:.6g} "
        f"(J baseline/joint = {bj['obj'] / rj.objective:.4g}); ratio = {bj['total'] / t_joint:.1f}x"
        + (" (LOWER BOUND: some FD solve stopped at the budget)" if bj["capped"] else "")
    )


def scaling(sizes: list[int], fd_sizes: list[int], repeats: int, budget: float, big: int):
    truth = default_truth()
    model = full_model()
    print(
        "\n== 2. Scaling, synthetic stances (alternating left/right, 0.65 s at 100 Hz, no noise) =="
    )
    hdr = (
        f"{'stances':>7} {'frames':>6} {'vars':>5} {'build s':>8} {'nlpsol s':>8} {'Ipopt s':>8} {'total s':>8}"
        f" {'ms/frame':>8} {'iters':>5} {'ms/iter':>8} {'runs':>4} {'J ours':>10} {'FD s':>8} {'J FD':>10} {'FD/ours':>8} {'FD/Ipopt':>8}"
    )
    print(hdr)
    print("-" * len(hdr))
    F, T, It = [], [], []
    for n in sizes:
        stances = [
            synthetic_stance("left" if i % 2 == 0 else "right", truth, t0=1.0 * i) for i in range(n)
        ]
        frames = sum(s.n for s in stances)
        o, prob = ours(stances, model, repeats if n <= big else 1)
        F.append(frames)
        T.append(o["total"])
        It.append(o["ipopt"])
        fd = ""
        if n in fd_sizes:
            b = baseline(prob, budget)
            mark = ">" if b["capped"] else ""
            fd = (
                f" {b['total']:8.2f} {b['obj']:10.3g} {mark + format(b['total'] / o['total'], '.1f') + 'x':>8}"
                f" {mark + format(b['total'] / o['ipopt'], '.1f') + 'x':>8}"
            )
        print(
            f"{n:7d} {frames:6d} {prob.x.shape[0]:5d} {o['build']:8.3f} {o['nlpsol']:8.3f} {o['ipopt']:8.2f}"
            f" {o['total']:8.2f} {1e3 * o['total'] / frames:8.2f} {o['iters']:5d}"
            f" {1e3 * o['ipopt'] / max(o['iters'], 1):8.1f} {o['n']:4d} {o['obj']:10.3g}{fd}"
        )
    if len(F) >= 2:
        s_tot = np.polyfit(np.log(F), np.log(T), 1)[0]
        s_ip = np.polyfit(np.log(F), np.log(It), 1)[0]
        print(
            f"   log-log slope of time vs frames: total {s_tot:.2f}, Ipopt only {s_ip:.2f} (1 = linear)"
        )
    print(
        f"   (times: median of 'runs' runs (1 above {big} stances, to keep the run short); FD baseline once;"
        f" '>' = FD stopped at the {budget:.0f} s budget, so the ratio is a lower bound)"
    )


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--quick", action="store_true", help="smaller sizes and budgets (~1-2 min)")
    a = ap.parse_args()
    repeats = 3
    if a.quick:
        sizes, fd_sizes, budget, big = [1, 2, 4], [1, 2], 60.0, 4
    else:
        sizes, fd_sizes, budget, big = [2, 4, 8, 16, 32], [2, 4], 240.0, 4
    print(
        f"fit_speed: casadi {ca.__version__}, repeats {repeats}, FD budget {budget:.0f} s per run"
    )
    real_trial(repeats, budget)
    scaling(sizes, fd_sizes, repeats, budget, big)


if __name__ == "__main__":
    main()
