"""One step against refit, fold by fold, on the bundled real trial: the held-out energy (data +
nuisance prior) of each fold's training fit, refitted (the ranking's) and one Gauss-Newton step
from a linearisation point (the calibrated test's statistic): for the base from its own full
fit, for damping and the clock offset from the base's point (nested) and from their own fit.

    PYTHONPATH=. .venv/bin/python benchmarks/onestep_folds.py

Prints the figures quoted in ``docs/diagnosis.md`` ("Still open").
"""

import warnings

import numpy as np

from gc_ocp.diagnosis.compare import evaluate, fold_plan
from gc_ocp.diagnosis.onestep import (
    _problem,
    fold_prior_means,
    heldout_energy,
    linearize,
    linearize_child,
    linearize_parent,
)
from gc_ocp.estimation.components import base_model, model_from_names
from gc_ocp.estimation.starts import rescaled_start
from gc_ocp.io import load_trial
from gc_ocp.kinematics import compute_kinematics
from gc_ocp.workflow.fitting import fit_data

warnings.simplefilter("ignore")

trial = load_trial()
_, data, _ = fit_data([(trial, compute_kinematics(trial))])
plan = fold_plan(data)
means = fold_prior_means(data, base_model(), plan)
base = evaluate(data, base_model(), "base", (), plan)
lp = linearize_parent(data, base.model, base.full, None)
Ep = heldout_energy(lp, lp.r[:, None], plan, means)[:, 0]
print(
    "parent refit held-out energy per fold:",
    [round(f.heldout.data_cost + f.heldout.prior_cost, 2) for f in base.folds],
    "occam",
    [round(f.occam, 2) for f in base.folds],
)
print("parent one-step held-out energy:", np.round(Ep, 2))
for name in ("damping", "time_offset"):
    m = model_from_names([name], base=base.model)
    ev = evaluate(data, m, f"base+{name}", (name,), plan, parent=base)
    ln = linearize_child(data, ev.model, base.full, lp.r, ev.full, None)
    pr = _problem(data, ev.model, None)
    lo = linearize(pr, rescaled_start(ev.full, pr), nested=False)
    En = heldout_energy(ln, (ln.r - lp.r)[:, None] + lp.r[:, None], plan, means)[:, 0]
    Eo = heldout_energy(lo, (lo.r - lp.r)[:, None] + lp.r[:, None], plan, means)[:, 0]
    print(name, "nested?", ln.nested)
    print(
        "  refit held-out energy per fold:",
        [round(f.heldout.data_cost + f.heldout.prior_cost, 2) for f in ev.folds],
        "occam",
        [round(f.occam, 2) for f in ev.folds],
    )
    print("  one-step nested:", np.round(En, 2), " one-step own fit:", np.round(Eo, 2))
