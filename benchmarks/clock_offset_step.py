"""Where should the calibrated test's one step start for a clock offset? Fold by fold, the
held-out energy (data + nuisance prior) of each fold's fit: the refit (the ranking's), one
Gauss-Newton step from the parent's point with the offset at 0 (``nested``, the path of every
candidate that reproduces its parent), and one step from the clock offset's own fit (``own
fit``, the path of a candidate that cannot, and of ``TimeOffset.one_step_from_own_fit``).

    PYTHONPATH=. .venv/bin/python benchmarks/clock_offset_step.py

Cases: the withheld-effect benchmark's moderate clock offset (10 ms; seed 0, the mismatch family
on, 2 stances per foot, the estimated pose width) on the bundled motion and on the BTS subject's
Walking1-3, as ``gc-ocp benchmark-diagnosis`` makes them. Output of the run cited in
``docs/diagnosis.md`` (*Where the clock offset's step starts*): ``clock_offset_step_output.txt``.
"""

from __future__ import annotations

import dataclasses
import time
import warnings

import numpy as np

from gc_ocp.bench.truth import DEFAULT_REALISM
from gc_ocp.bench.withheld import case_data
from gc_ocp.diagnosis.compare import evaluate, fold_plan
from gc_ocp.diagnosis.diagnose import resolve_base, sized_base
from gc_ocp.diagnosis.mismatch import MismatchFamily
from gc_ocp.diagnosis.onestep import (
    _own_columns,
    fold_prior_means,
    heldout_energy,
    linearize_child,
    linearize_parent,
)
from gc_ocp.estimation.components import model_from_names

BTS = [f"../shared/data/bts_unipd_5trials/Walking{k}.c3d" for k in (1, 2, 3)]


def _refit(ev) -> tuple[np.ndarray, np.ndarray]:
    return (
        np.array([f.heldout.data_cost + f.heldout.prior_cost for f in ev.folds]),
        np.array([f.occam for f in ev.folds]),
    )


def _reduction(child: float, parent: float) -> float:
    return 100.0 * (1.0 - np.sqrt(child / parent))


def case(name: str, files) -> None:
    t0 = time.perf_counter()
    realism = dataclasses.replace(DEFAULT_REALISM, mismatch=MismatchFamily(scale=1.0))
    spec = {"truth": "time_offset", "magnitude": "moderate", "seed": 0}
    data, _, _ = case_data(spec, "registered", realism, files, 2)
    model, _ = sized_base(data, resolve_base("registered")[1])
    plan = fold_plan(data)
    means = fold_prior_means(data, model, plan)
    base = evaluate(data, model, "base", (), plan)
    lp = linearize_parent(data, base.model, base.full, None)
    child = evaluate(
        data,
        model_from_names(["time_offset"], base=base.model),
        "base+time_offset",
        ("time_offset",),
        plan,
        parent=base,
    )
    Rp, Op = _refit(base)
    Rc, Oc = _refit(child)
    Ep = heldout_energy(lp, lp.r[:, None], plan, means)[:, 0]
    rows = {"parent refit": Rp, "parent one step": Ep, "child refit": Rc}
    red = {"refit": _reduction(Rc.sum() + Oc.sum(), Rp.sum() + Op.sum())}
    for label, own_fit in (("nested", False), ("own fit", True)):
        lin = linearize_child(data, child.model, base.full, lp.r, child.full, None, own_fit)
        charge = _own_columns(lin, lp) if lin.nested else None  # as onestep.energies does
        E = heldout_energy(lin, (lin.r - lp.r)[:, None] + lp.r[:, None], plan, means, charge)
        rows[f"child one step, {label}"] = E[:, 0]
        occam = Op if lin.nested else Oc
        red[f"one step, {label}"] = _reduction(E[:, 0].sum() + occam.sum(), Ep.sum() + Op.sum())
    print(f"## {name}: the moderate clock offset (10 ms), 2 stances per foot, seed 0\n")
    print("held-out stances: " + ", ".join(data[i].label for g in plan for i in g) + "\n")
    print("| fit | " + " | ".join(f"fold {k + 1}" for k in range(len(plan))) + " |")
    print("|---|" + "---|" * len(plan))
    for label, v in rows.items():
        print(f"| {label} | " + " | ".join(f"{x:.1f}" for x in v) + " |")
    print(
        "\nheld-out reduction of the combined score (Occam terms included): "
        + ", ".join(f"{k} {v:+.2f} %" for k, v in red.items())
        + f" ({time.perf_counter() - t0:.0f} s)\n"
    )


if __name__ == "__main__":
    warnings.simplefilter("ignore")
    case("bundled motion", None)
    case("BTS subject, Walking1-3", BTS)
