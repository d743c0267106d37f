"""Why the one-step statistic misses the refit on real walking: where each fold's training fit
lies, and a statistic linearised at each fold's own fits (a prototype, not the package's).

    PYTHONPATH=. .venv/bin/python benchmarks/onestep_fold_points.py [TRIAL ...] [--prior-width]

(default: the bundled trial; e.g. the BTS subject's ``Walking1-3.c3d`` for six stances.) The
base is the diagnosis's: its pose correction's width estimated on the stances first
(``diagnose(pose_width="estimated")``); ``--prior-width``: at its component's guessed prior.

1. The base's fold training fits: Gauss-Newton iterations (with a backtracking line search on
   the true objective) on each fold's training problem from the base's fit on all stances, the
   training objective and the *exact* held-out energy (the held-out stance's nuisance solved by
   Ipopt, as the ranking's folds) at each iterate, against Ipopt's training fit; the variables
   furthest from Ipopt's, in prior sigmas (raw units for variables without a prior).
2. The observed statistic per candidate: the refit (the ranking's), the calibrated
   test's one step (:mod:`gc_ocp.diagnosis.onestep`: every fold one Gauss-Newton step from one
   linearisation), and one step from a linearisation at each fold's *own* training fit (the
   held-out stance's nuisance starting where the fit on all stances left it), and the same with
   the held-out stance's nuisance at its held-out fit too (the step then starts at the refit's
   optimum: what is left is the linearisation's own error), and one step from the *parent's*
   fold fits with the candidate's own variables neutral (a cheaper point the null could reach:
   the parent's fold fits only). Occam terms: the refit's in all.

Output quoted in ``docs/diagnosis.md`` ("Why the one step misses on real walking").
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np

import gc_ocp
from gc_ocp.diagnosis.compare import _score_heldout, evaluate, fold_plan
from gc_ocp.diagnosis.diagnose import sized_base
from gc_ocp.diagnosis.onestep import (
    _problem,
    energies,
    fold_prior_means,
    from_own_fit,
    heldout_energy,
    linearize,
    linearize_child,
    linearize_parent,
    reductions,
    step,
)
from gc_ocp.estimation.components import base_model, model_from_names
from gc_ocp.estimation.problem import Weights, build_estimation
from gc_ocp.estimation.solve import result_at
from gc_ocp.estimation.starts import rescaled_start, with_lls_start
from gc_ocp.workflow.fitting import fit_data

CANDIDATES = (
    "damping",
    "time_offset",
    "stiffness_exponent",
    "friction",
    "ground_offset",
    "toe_joint",
    "contact_density",
)


def at(problem, full, *fits) -> np.ndarray:
    """``problem``'s point with the values of the last of ``fits`` that has the variable,
    ``full``'s elsewhere."""
    x = rescaled_start(full, problem)
    for fit in fits:
        x = rescaled_start(fit, problem, under=x)
    return x


def gauss_newton(data, plan, base, w, iterations=5) -> None:
    for j, group in enumerate(plan):
        train = [d for k, d in enumerate(data) if k not in group]
        tp = build_estimation(train, with_lls_start(base.model, train), w)
        first = sum(len(g) for g in plan[:j])
        fold = base.folds[first]
        x_ip = np.asarray(fold.train.x, float)
        names = {
            i: f"{'/'.join(map(str, s.key))}[{i - s.slice.start}]"
            for s in tp.variables.specs
            for i in range(s.slice.start, s.slice.stop)
        }
        pw = np.asarray(tp.prior_weights, float)
        unit = np.where(pw > 0, pw, 1.0)
        ho = sum(
            f.heldout.data_cost + f.heldout.prior_cost for f in base.folds[first:][: len(group)]
        )
        print(
            f"fold {j} (holds out {', '.join(data[i].label for i in group)}): Ipopt's training "
            f"objective {tp.evaluate(x_ip):.1f}, held-out energy {ho:.1f}"
        )
        x = rescaled_start(base.full, tp)
        for it in range(iterations + 1):
            tr = result_at(tp, x, covariance=False)
            e = 0.0
            for i in group:
                h = _score_heldout(data[i], train, base.model, tr, w, None).heldout
                e += h.data_cost + h.prior_cost
            dx = (x - x_ip) * unit
            far = np.argsort(-np.abs(dx))[:3]
            print(
                f"  iterate {it}: training objective {tp.evaluate(x):.1f}, exact held-out energy "
                f"{e:.1f}; furthest from Ipopt's: "
                + ", ".join(f"{names[i]} {dx[i]:+.2f}" for i in far)
            )
            lin = linearize(tp, x)
            J = lin.J
            P2 = np.zeros(J.shape[1])
            P2[lin.prior_idx] = lin.pw**2
            g = np.zeros(J.shape[1])
            g[lin.prior_idx] = lin.pw * lin.p0
            rhs = np.asarray(J.T @ lin.r)[:, None] + g[:, None]
            d = step((J.T @ J).toarray() + np.diag(P2), rhs, lin)[:, 0]
            f0, a = tp.evaluate(x), 1.0
            while a > 1e-3:
                xn = np.clip(x + a * d, tp.lbx, tp.ubx)
                if tp.evaluate(xn) < f0:
                    break
                a /= 2
            x = xn


def main() -> None:
    warnings.simplefilter("ignore")
    paths = [a for a in sys.argv[1:] if not a.startswith("--")]
    trials = [gc_ocp.load_trial(p) for p in paths] if paths else [gc_ocp.load_trial()]
    _, data, _ = fit_data([(t, gc_ocp.compute_kinematics(t)) for t in trials])
    plan = fold_plan(data)
    w = Weights()
    model = base_model()
    if "--prior-width" not in sys.argv:  # the diagnosis's default: the pose width estimated
        model = sized_base(data, model, "estimated", None, None, None)[0]
    means = fold_prior_means(data, model, plan)
    base = evaluate(data, model, "base", (), plan)
    print(f"{len(data)} stances, folds {plan}\n\n## 1. The base's fold training fits\n")
    gauss_newton(data, plan, base, w)
    lp = linearize_parent(data, base.model, base.full, None)

    def fold_points(ev, heldout: bool = False) -> np.ndarray:
        P = _problem(data, ev.model, None)
        out, k = [], 0
        for g in plan:
            fits = [ev.folds[k].train] + ([ev.folds[k].heldout] if heldout else [])
            lin = linearize(P, at(P, ev.full, *fits))
            out += list(heldout_energy(lin, lin.r[:, None], [g], [means[k]] * len(g))[:, 0])
            k += len(g)
        return np.array(out)

    def at_parent_folds(ev) -> np.ndarray | None:
        """Per held-out stance, one step from the *parent's* fold fits with the candidate's own
        variables neutral (None when that point does not reproduce the parent: a candidate
        that is not nested, such as the denser sole)."""
        P = _problem(data, ev.model, None)
        Pp = _problem(data, base.model, None)
        own = [s for s in P.variables.specs if s.key not in {q.key for q in base.full.variables}]
        out, k = [], 0
        for g in plan:
            fits = [base.folds[k].train, base.folds[k].heldout]
            x = at(P, base.full, *fits)
            for spec in own:
                x[spec.slice] = np.clip(0.0, spec.lb, spec.ub)
            xp = at(Pp, base.full, *fits)
            rp = Pp.data_residuals(xp)
            r = P.data_residuals(x)
            if r.shape != rp.shape or np.linalg.norm(r - rp) > 1e-8 * np.linalg.norm(rp):
                return None
            lin = linearize(P, x)
            out += list(heldout_energy(lin, lin.r[:, None], [g], [means[k]] * len(g))[:, 0])
            k += len(g)
        return np.array(out)

    def refit(ev) -> np.ndarray:
        return np.array([f.heldout.data_cost + f.heldout.prior_cost for f in ev.folds])

    def red(ec, ep) -> float:
        return 100.0 * (1.0 - np.sqrt(ec.sum() / ep.sum()))

    occ_p = np.array([f.occam for f in base.folds])
    Ep_fold = fold_points(base)
    Ep_both = fold_points(base, heldout=True)
    Ep_one = heldout_energy(lp, lp.r[:, None], plan, means)[:, 0]
    print(
        "\n## 2. The observed statistic: refit against one step from several points (held-out reduction of the combined score, %)\n"
    )
    print(
        f"base's held-out energy per held-out stance: refit {refit(base).round(1)}, one step "
        f"{Ep_one.round(1)}, at the folds' own fits {Ep_fold.round(1)}, and held-out fits "
        f"{Ep_both.round(1)}\n"
    )
    print(
        "| candidate | refit | one step (the test's) | at the folds' own training fits | "
        "and held-out fits | at the parent's fold fits, own variables neutral | s |"
    )
    print("|---|---|---|---|---|---|---|")
    for name in CANDIDATES:
        t0 = time.perf_counter()
        ev = evaluate(
            data,
            model_from_names([name], base=base.model),
            f"base+{name}",
            (name,),
            plan,
            parent=base,
        )
        occ = np.array([f.occam for f in ev.folds])
        ln = linearize_child(data, ev.model, base.full, lp.r, ev.full, None, from_own_fit(name))
        occam = {"parent": occ_p, **({} if ln.nested else {name: occ})}
        one = reductions(energies(lp, {name: ln}, -lp.r[:, None], plan, occam, means))[name][0]
        print(
            f"| {name} | {red(refit(ev) + occ, refit(base) + occ_p):+.2f} | {one:+.2f} | "
            f"{red(fold_points(ev) + occ, Ep_fold + occ_p):+.2f} | "
            f"{red(fold_points(ev, True) + occ, Ep_both + occ_p):+.2f} | "
            f"{'-' if (Ec := at_parent_folds(ev)) is None else f'{red(Ec + occ, Ep_both + occ_p):+.2f}'} | "
            f"{time.perf_counter() - t0:.0f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
