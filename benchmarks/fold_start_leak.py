"""Where a fold's training fit starts, and what it does to the held-out score (docs/diagnosis.md,
*Starts and local minima*).

    .venv/bin/python benchmarks/fold_start_leak.py            # the bundled trial's base
    .venv/bin/python benchmarks/fold_start_leak.py --diagnose bts out.json

The first form fits the base of every fold of the bundled trial twice: from the usual starts on
the training stances (what the diagnosis does since 2026-11-30) and from the base's fit on all
stances (the former start, which saw the held-out stance), and prints each fold's training
objective and held-out energy. The second runs a whole diagnosis (2 workers) of the bundled
trial or BTS Walking1-3 and prints its summary and time: run it on two commits to compare
(``PYTHONPATH=<worktree>``); the logs in ``benchmarks/fold_start_leak/`` are those of 2df18e3
(``old_*``, the former start) and of the leak-free start (``new_*``).
"""

from __future__ import annotations

import json
import sys
import time
import warnings

import gc_ocp
from gc_ocp.diagnosis.compare import _score_heldout, fit_model, fold_plan
from gc_ocp.diagnosis.diagnose import diagnose, resolve_base, sized_base
from gc_ocp.estimation.problem import Weights
from gc_ocp.workflow.fitting import fit_data

BTS = [f"../shared/data/bts_unipd_5trials/Walking{i}.c3d" for i in (1, 2, 3)]


def folds() -> None:
    t = gc_ocp.load_trial()
    _, stances, _ = fit_data([(t, gc_ocp.compute_kinematics(t))])
    _, base = resolve_base("registered")
    base, _ = sized_base(stances, base)
    plan = fold_plan(stances)
    w = Weights()
    full = fit_model(stances, base, None, w, None)
    print(f"bundled trial, base on all stances: J = {full.objective:.2f}")
    print(
        "| fold | training J, usual starts | training J, from the fit on all stances "
        "| held-out E, usual starts | held-out E, from the fit on all stances |"
    )
    print("|---|---|---|---|---|")
    for g in plan:
        train = [d for k, d in enumerate(stances) if k not in set(g)]
        cold = fit_model(train, base, None, w, None, covariance=False, quiet=True)
        warm = fit_model(train, base, full, w, None, covariance=False, quiet=True)
        hc = _score_heldout(stances[g[0]], train, base, cold, w, None)
        hw = _score_heldout(stances[g[0]], train, base, warm, w, None)
        print(
            f"| {g} | {cold.objective:.2f} | {warm.objective:.2f} | {hc.energy:.2f} "
            f"| {hw.energy:.2f} |"
        )


def whole(which: str, out: str) -> None:
    paths = BTS if which == "bts" else [None]
    trials = [gc_ocp.load_trial(p) if p else gc_ocp.load_trial() for p in paths]
    pairs = [(t, gc_ocp.compute_kinematics(t)) for t in trials]
    t0 = time.perf_counter()
    d = diagnose(pairs, workers=2, progress=lambda s: print(f"{time.perf_counter() - t0:7.1f} {s}"))
    print(f"time {time.perf_counter() - t0:.1f} s")
    print(d.summary())
    with open(out, "w") as f:
        json.dump(d.to_json(), f, indent=1, default=str)


if __name__ == "__main__":
    warnings.simplefilter("ignore")
    if len(sys.argv) > 1 and sys.argv[1] == "--diagnose":
        whole(sys.argv[2], sys.argv[3])
    else:
        folds()
