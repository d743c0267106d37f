"""Prototype for issue 22's next step: the calibrated test's null with the parent refitted and
every model relinearised per mismatch draw, against the one-step null linearised once.

    .venv/bin/python benchmarks/null_relinearised.py [--motion bundled|bts] [--seed 21] [--draws 16]

On the mismatch benchmark's "none" case of that seed (as ``null_fidelity.py``): for each draw of
the family, the fitted base (frozen) makes noise-free data with that draw
(``mismatch.simulate_mismatched``, no plate noise; the benchmark's 20 N threshold), the base is
refitted to them from its fit (warm start), and the base and every candidate are linearised
*there*; the draw's systematic perturbation is that refit's residual. A replicate is the draw's
point and perturbation plus the observed residual's sign-flipped 0.1 s blocks (as the package's
null), scored by one Gauss-Newton step at the draw's own point. Each candidate's studentised
one-step reduction is compared with the max over candidates, as ``null.decide`` does. Prints
the p-values of both nulls and the time per draw.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from null_fidelity import BTS, CANDIDATES, case_data  # noqa: E402

from gc_ocp.bench.truth import Realism  # noqa: E402
from gc_ocp.diagnosis import null, onestep  # noqa: E402
from gc_ocp.diagnosis.compare import fold_plan  # noqa: E402
from gc_ocp.diagnosis.diagnose import diagnose_stances  # noqa: E402
from gc_ocp.diagnosis.mismatch import simulate_mismatched, thresholded  # noqa: E402
from gc_ocp.estimation.components import model_from_names  # noqa: E402
from gc_ocp.estimation.starts import best_of, frozen_model, with_lls_start  # noqa: E402
from gc_ocp.workflow.fitting import with_detected_censoring  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--motion", choices=("bundled", "bts"), default="bundled")
    ap.add_argument("--seed", type=int, default=21)
    ap.add_argument("--draws", type=int, default=16)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    files = BTS if args.motion == "bts" else None
    data, _ = case_data(args.seed, files)
    d = diagnose_stances(data, max_effects=0, n_boot=200, candidates=list(CANDIDATES))
    print(
        "one-step null (package):",
        {
            r.effect: (round(r.calibrated.observed_pct, 2), round(r.calibrated.p_adjusted, 3))
            for r in d.ranking
            if r.calibrated
        },
        flush=True,
    )
    parent = d.evaluations["base"]
    model = parent.model
    plan = fold_plan(data)
    rate = 1.0 / float(np.median(np.diff(data[0].time)))
    pl = onestep.linearize_parent(data, model, parent.full, None)
    kids = {n: model_from_names([n], base=model) for n in CANDIDATES}
    evs = {n: d.evaluations[f"base+{n}"] for n in CANDIDATES}
    lins = {n: evs[n].linear for n in CANDIDATES}
    occam = {"parent": np.array([f.occam for f in parent.folds])}
    occam.update({n: np.array([f.occam for f in evs[n].folds]) for n in CANDIDATES})
    means = onestep.fold_prior_means(data, model, plan)
    E_obs = onestep.energies(pl, lins, -pl.r[:, None], plan, occam, means)
    observed = {n: float(v[0]) for n, v in onestep.reductions(E_obs).items()}
    frozen = frozen_model(with_lls_start(model, data), parent.full)
    rng = np.random.default_rng(2000 + args.seed)
    per_draw = max(1, null.N_REPLICATES // args.draws)
    cols: dict[str, list] = {n: [] for n in CANDIDATES}
    t0 = time.perf_counter()
    for k in range(args.draws):
        dk = null.null_draw(null.DEFAULT_FAMILY, rng, data[0].layout, model)
        rep = simulate_mismatched(data, frozen, dk, rng, plate_noise_pct_bw=0.0)
        rep = with_detected_censoring([thresholded(r, Realism().force_threshold) for r in rep])
        fk = best_of(
            rep,
            with_lls_start(model, data),
            None,
            None,
            strategies=(),
            start=parent.full,
            covariance=False,
        )
        plk = onestep.linearize_parent(rep, model, fk, None)
        lk = {n: onestep.linearize_child(rep, kids[n], fk, plk.r, None, None) for n in CANDIDATES}
        U = null.wild_residuals(pl, parent.full.stance_fits, per_draw, rng, rate)
        E = onestep.energies(plk, lk, U - plk.r[:, None], plan, occam, means)
        for n, v in onestep.reductions(E).items():
            cols[n].append(v)
        print(
            f"draw {k + 1}: slip x{dk.slip_factor:.2f} {dk.slip_form}, {dk.cutoff_hz:.1f} Hz: "
            + ", ".join(f"{n} {np.mean(cols[n][-1]):+.2f}" for n in CANDIDATES)
            + f" ({time.perf_counter() - t0:.0f} s)",
            flush=True,
        )
    nulls = {n: np.concatenate(v) for n, v in cols.items()}
    tests = null.decide(
        observed, nulls, onestep.per_stance_sd(E_obs), max(len(plan), 1), null.ALPHA
    )
    print(
        "relinearised null:",
        {
            n: (
                round(t.observed_pct, 2),
                round(t.null_mean_pct, 2),
                round(t.null_sd_pct, 2),
                round(t.p_adjusted, 3),
            )
            for n, t in tests.items()
        },
    )
    print(f"{(time.perf_counter() - t0) / args.draws:.1f} s per draw")


if __name__ == "__main__":
    main()
