"""Is the calibrated test's null faithful to the mismatch family? A full parametric bootstrap of one
"none" case against the one-step null the diagnosis uses.

    .venv/bin/python benchmarks/null_fidelity.py [--motion bundled|bts] [--seed 21] [--replicates 16]

The case is the mismatch benchmark's "none" case of that seed (``gc-ocp benchmark-diagnosis
--effects none --mismatch 1``). Its diagnosis (round 1, three candidates) gives each candidate's
observed one-step reduction and its p-value under the one-step null (replicates = the fitted base's
prediction + wild residuals + one of 64 mismatch perturbations). The full bootstrap instead makes
each replicate as the benchmark makes data: the fitted base, frozen, walks the case's motion and
differs from the model by a fresh draw of the family (``mismatch.simulate_mismatched``, the
members the null uses: law forms, hum, the seen motion low-passed), with 0.5 % BW plate noise and
the benchmark's 20 N threshold; the replicate is then
diagnosed like the case (censoring detected, round 1), and its one-step reductions (the test's
statistic) and refitted held-out reductions are recorded. The share of replicates whose one-step
reduction reaches the case's is that candidate's full-bootstrap p-value (not adjusted across
candidates).

Writes ``benchmarks/null_fidelity_output.md`` (appends a section per run).
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

from gc_ocp.bench import withheld as W
from gc_ocp.bench.truth import Realism
from gc_ocp.diagnosis import null
from gc_ocp.diagnosis.diagnose import diagnose_stances
from gc_ocp.diagnosis.mismatch import MismatchFamily, simulate_mismatched, thresholded
from gc_ocp.estimation.starts import frozen_model, with_lls_start
from gc_ocp.workflow.fitting import with_detected_censoring

HERE = Path(__file__).parent
BTS = tuple(
    str(HERE.parent.parent / "shared" / "data" / "bts_unipd_5trials" / f"Walking{i}.c3d")
    for i in (1, 2, 3)
)
CANDIDATES = ("friction", "time_offset", "damping")


def case_data(seed: int, files):
    """The mismatch benchmark's "none" case of ``seed``: its data and mismatch draw."""
    case = {"truth": "none", "magnitude": "-", "seed": seed}
    data, draw, _ = W.case_data(case, realism=Realism(mismatch=MismatchFamily(1.0)), files=files)
    return data, draw


def one_step(diagnosis) -> dict:
    return {
        r.effect: (r.calibrated.observed_pct, r.calibrated.p_adjusted, r.heldout_rms_reduction_pct)
        for r in diagnosis.ranking
        if r.calibrated is not None
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--motion", choices=("bundled", "bts"), default="bundled")
    ap.add_argument("--seed", type=int, default=21)
    ap.add_argument("--replicates", type=int, default=16)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    t0 = time.perf_counter()
    files = BTS if args.motion == "bts" else None
    data, draw = case_data(args.seed, files)
    d = diagnose_stances(data, max_effects=0, n_boot=200, candidates=list(CANDIDATES))
    observed = one_step(d)
    parent = d.evaluations["base"]
    frozen = frozen_model(with_lls_start(parent.model, data), parent.full)
    rng = np.random.default_rng(1000 + args.seed)
    reps = []
    for b in range(args.replicates):
        dk = null.null_draw(null.DEFAULT_FAMILY, rng, data[0].layout, parent.model)
        rep = simulate_mismatched(data, frozen, dk, rng)
        # the benchmark's own plate threshold, then the fitter's detection, as for the case
        rep = with_detected_censoring([thresholded(r, Realism().force_threshold) for r in rep])
        dr = diagnose_stances(
            rep, max_effects=0, n_boot=100, candidates=list(CANDIDATES), n_replicates=100
        )
        reps.append((dk, one_step(dr)))
        print(f"replicate {b + 1}/{args.replicates} ({time.perf_counter() - t0:.0f} s)", flush=True)
    lines = [
        f"## {args.motion}, none case seed {args.seed}",
        "",
        f"Case draw: slip x{draw.slip_factor:.2f} ({draw.slip_form or 'default'}), penetration "
        f"x{draw.depth_factor:.2f} ({draw.depth_form or 'default'}), markers {draw.cutoff_hz:.1f} "
        f"Hz, threshold {draw.threshold_n:.0f} N. {args.replicates} full-bootstrap replicates.",
        "",
        "| candidate | case: one-step [%] | one-step null p (family-wise) | case: refit held-out "
        "[%] | replicates: one-step mean, SD [%] | share reaching the case | replicates: "
        "refit held-out mean [%] |",
        "|---|---|---|---|---|---|---|",
    ]
    for n in CANDIDATES:
        if n not in observed:
            continue
        t, p, h = observed[n]
        v = np.array([r[n][0] for _, r in reps if n in r])
        hv = np.array([r[n][2] for _, r in reps if n in r and r[n][2] is not None])
        lines.append(
            f"| {n} | {t:+.2f} | {p:.3f} | {h:+.2f} | {v.mean():+.2f}, {v.std(ddof=1):.2f} | "
            f"{np.mean(v >= t):.2f} | {hv.mean():+.2f} |"
        )
    lines += ["", "Per replicate (draw: slip factor, form, cutoff; one-step reductions):", ""]
    for dk, r in reps:
        lines.append(
            f"* slip x{dk.slip_factor:.2f} {dk.slip_form or 'default'}, {dk.cutoff_hz:.1f} Hz: "
            + ", ".join(f"{n} {v[0]:+.2f}" for n, v in r.items())
        )
    lines += ["", f"Run time {time.perf_counter() - t0:.0f} s.", ""]
    out = HERE / "null_fidelity_output.md"
    old = out.read_text() if out.exists() else "# Null fidelity (`benchmarks/null_fidelity.py`)\n\n"
    out.write_text(old + "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
