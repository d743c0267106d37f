"""Is the one-step null right? The null replicates of the calibrated test against full refits.

The calibrated decision of the diagnosis (``gc_ocp.diagnosis.null``) scores every model on null
replicates with one Gauss-Newton step from the parent's solution instead of refitting. Here, on
a sample of replicates of one subject's motion, each replicate is made into stances
(``null.replicate``) and every model is refitted in full (the diagnosis's own
``compare.evaluate``, folds and held-out scoring included); the one-step and the full reductions
are compared, candidate by candidate, and so are the observed statistics of the case (the
one-step reduction the test uses, and the full refit's the ranking reports).

    .venv/bin/python benchmarks/null_check.py [--replicates 8] [--motion bts|bundled]

Writes ``benchmarks/null_check_output.md``.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from gc_ocp.bench.truth import DEFAULT_REALISM, base_truth, generate, motion  # noqa: E402
from gc_ocp.bench.withheld import kinematic_error  # noqa: E402
from gc_ocp.diagnosis import null, onestep  # noqa: E402
from gc_ocp.diagnosis.compare import evaluate, fold_plan, reduction  # noqa: E402
from gc_ocp.diagnosis.diagnose import resolve_base  # noqa: E402
from gc_ocp.estimation.components import model_from_names  # noqa: E402
from gc_ocp.estimation.problem import Weights  # noqa: E402

SHARED = HERE.parent.parent / "shared" / "data"
BTS = tuple(str(SHARED / "bts_unipd_5trials" / f"Walking{i}.c3d") for i in (1, 2, 3))
CANDIDATES = ("damping", "time_offset", "friction", "stiffness_exponent", "toe_joint")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--replicates", type=int, default=8)
    ap.add_argument("--motion", choices=("bts", "bundled"), default="bts")
    ap.add_argument("--out", default=str(HERE / "null_check_output.md"))
    args = ap.parse_args()
    warnings.filterwarnings("ignore", message="LLS initialisation not possible")
    t0 = time.perf_counter()
    files = BTS if args.motion == "bts" else None
    base = resolve_base("registered")[1]
    stances = motion("registered", "none", files)
    rng = np.random.default_rng(1)
    data = generate(
        stances,
        base_truth("registered", files),
        rng,
        DEFAULT_REALISM,
        kinematic_error("none", "moderate", base, DEFAULT_REALISM),
    )
    rate = 1.0 / float(np.median(np.diff(data[0].time)))
    plan = fold_plan(data)
    parent = evaluate(data, base, "base", (), plan)
    pl = onestep.linearize_parent(data, base, parent.full, None)
    means = onestep.fold_prior_means(data, base, plan)
    occam = {"parent": np.array([f.occam for f in parent.folds])}
    kids, observed = {}, {}
    for n in CANDIDATES:
        m = model_from_names([n], base=base)
        c = evaluate(data, m, n, (n,), plan, parent=parent)
        kids[n] = onestep.linearize_child(data, m, parent.full, pl.r, c.full, None)
        observed[n] = reduction(parent, c, 10, 0, rate)["pct"]
    one = onestep.reductions(onestep.energies(pl, kids, -pl.r[:, None], plan, occam, means))
    U = null.wild_residuals(pl, parent.full.stance_fits, args.replicates, rng, rate)
    lin = onestep.reductions(onestep.energies(pl, kids, U, plan, occam, means))
    full = {n: [] for n in CANDIDATES}
    for b in range(args.replicates):
        rep = null.replicate(data, parent.full.stance_fits, U[:, b], Weights())
        pb = evaluate(rep, base, "base", (), plan)
        for n in CANDIDATES:
            m = model_from_names([n], base=base)
            cb = evaluate(rep, m, n, (n,), plan, parent=pb)
            full[n].append(reduction(pb, cb, 10, 0, rate)["pct"])
        print(f"replicate {b + 1}/{args.replicates} ({time.perf_counter() - t0:.0f} s)", flush=True)
    lines = [
        "# The one-step null against full refits",
        "",
        f"Motion: {args.motion} ({len(data)} stances, {len(plan)} folds), a base-model truth "
        f"with the benchmark's realism; {args.replicates} null replicates (wild residuals), "
        "each refitted in full (every fold) for the parent and every candidate.",
        "",
        "| candidate | observed: one-step [%] | observed: full refit [%] | replicates: mean "
        "one-step [%] | mean full [%] | SD one-step | SD full | mean abs difference | "
        "correlation |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for n in CANDIDATES:
        a, f = np.asarray(lin[n]), np.asarray(full[n])
        r = float(np.corrcoef(a, f)[0, 1]) if a.std() > 0 and f.std() > 0 else float("nan")
        lines.append(
            f"| {n} | {one[n][0]:+.3f} | {observed[n]:+.3f} | {a.mean():+.3f} | {f.mean():+.3f} | "
            f"{a.std(ddof=1):.3f} | {f.std(ddof=1):.3f} | {np.abs(a - f).mean():.3f} | {r:.2f} |"
        )
    lines += ["", f"Run time {time.perf_counter() - t0:.0f} s on this machine.", ""]
    Path(args.out).write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
