"""Tried for speed, not kept (``docs/diagnosis.md``, *Speed*): the denser sole in the calibrated
null linearised at its observed fit shifted by the parent's move on each draw (no solve),
against the package's refit per draw.

Usage::

    PYTHONPATH=. python benchmarks/null_denser_sole_shift.py [TRIAL ...]   # default: bundled

A diagnosis (candidates ``contact_density`` and ``damping``, 12 mismatch draws, one worker) whose
draw task is replaced by one that computes the null both ways on the same replicates; prints one
JSON line per draw (the denser sole's null reductions: mean and SD each way, the largest
difference, the seconds each way) and, at the end, the spread of the draw means both ways and
their correlation. Output of the run cited in the docs: ``null_denser_sole_shift_output.txt``.
"""

from __future__ import annotations

import json
import sys
import time
import warnings

import numpy as np

import gc_ocp
from gc_ocp.diagnosis import diagnose, draws
from gc_ocp.diagnosis.null import wild_residuals
from gc_ocp.diagnosis.onestep import energies, linearize, nested_point, reductions
from gc_ocp.estimation.problem import build_estimation
from gc_ocp.estimation.starts import rescaled_start

ROWS: list[dict] = []


def both_ways(inputs, draw, seed):
    """:func:`gc_ocp.diagnosis.draws.draw_reductions`, the non-nested children also linearised
    at their observed fit with the shared variables moved as the parent's refit moved them."""
    rng = np.random.default_rng(seed)
    data = draws.draw_data(inputs, draw, rng)
    w = inputs.weights
    problem = build_estimation(data, inputs.model, w)
    fk = draws._refit(problem, inputs.full, inputs.options)
    pk = linearize(problem, fk.x)
    refit, shifted, t_refit, t_shift = {}, {}, 0.0, 0.0
    move = {s.key: fk.x[s.slice] - inputs.full.x[s.slice] for s in fk.variables}
    for name, (model, own) in inputs.children.items():
        child = build_estimation(data, model, w)
        x0 = nested_point(child, fk, pk.r)
        if x0 is not None:
            refit[name] = shifted[name] = linearize(child, x0)
            continue
        t = time.perf_counter()
        refit[name] = linearize(child, draws._refit(child, own, inputs.options).x, nested=False)
        t_refit += time.perf_counter() - t
        t = time.perf_counter()
        xs = rescaled_start(own, child)
        for s in child.variables.specs:
            if s.key in move and move[s.key].size == s.size:
                xs[s.slice] = np.clip(xs[s.slice] + move[s.key], s.lb, s.ub)
        shifted[name] = linearize(child, xs, nested=False)
        t_shift += time.perf_counter() - t
    U = wild_residuals(
        inputs.parent, inputs.full.stance_fits, inputs.n_wild, rng, inputs.frame_rate
    )
    args = (U - pk.r[:, None], inputs.plan, inputs.occam, inputs.fold_means)
    a = reductions(energies(pk, refit, *args))
    b = reductions(energies(pk, shifted, *args))
    for n in a:
        if refit[n] is not shifted[n]:
            row = {
                "effect": n,
                "refit_mean": float(a[n].mean()),
                "refit_sd": float(a[n].std()),
                "shifted_mean": float(b[n].mean()),
                "shifted_sd": float(b[n].std()),
                "max_abs_diff": float(np.max(np.abs(a[n] - b[n]))),
                "seconds_refit": t_refit,
                "seconds_shifted": t_shift,
            }
            ROWS.append(row)
            print(json.dumps(row), flush=True)
    return a


def main() -> None:
    warnings.simplefilter("ignore")
    draws.draw_reductions = both_ways  # mismatch_null looks the task up at call time
    pairs = []
    for p in sys.argv[1:] or [None]:
        t = gc_ocp.load_trial(p) if p else gc_ocp.load_trial()
        pairs.append((t, gc_ocp.compute_kinematics(t)))
    diagnose(pairs, workers=1, candidates=["contact_density", "damping"], mismatch_draws=12)
    A = np.array([[r["refit_mean"], r["shifted_mean"]] for r in ROWS])
    print("per-draw means [%]: refit", A[:, 0].round(2), "shifted", A[:, 1].round(2))
    print(
        f"SD of the draw means: refit {A[:, 0].std():.2f}, shifted {A[:, 1].std():.2f}; "
        f"correlation {np.corrcoef(A.T)[0, 1]:.3f}; mean shifted - refit "
        f"{np.mean(A[:, 1] - A[:, 0]):+.2f}; mean |difference| {np.mean(np.abs(A[:, 1] - A[:, 0])):.2f}"
    )


if __name__ == "__main__":
    main()
