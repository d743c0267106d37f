"""The bundled trial diagnosed with a chosen null: python bundled_trial.py CANDIDATES|all DRAWS one-step|refit WORKERS (max_effects=1; prints the ranking with each test)."""

import json
import sys
import time
import warnings

from gc_ocp.diagnosis import diagnose_stances
from gc_ocp.io import load_trial
from gc_ocp.kinematics import compute_kinematics
from gc_ocp.workflow.fitting import fit_data


def main():
    trial = load_trial()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, data, _ = fit_data([(trial, compute_kinematics(trial))])
        t0 = time.time()
        cands = sys.argv[1].split(",") if len(sys.argv) > 1 and sys.argv[1] != "all" else None
        draws = int(sys.argv[2]) if len(sys.argv) > 2 else 4
        d = diagnose_stances(
            data,
            candidates=cands,
            n_boot=200,
            mismatch_draws=draws,
            null_fits=sys.argv[3] if len(sys.argv) > 3 else "refit",
            workers=int(sys.argv[4]) if len(sys.argv) > 4 else 1,
            max_effects=1,
            progress=print,
        )
    print("seconds", time.time() - t0)
    for r in d.ranking:
        c = r.calibrated
        print(
            r.effect,
            round(r.heldout_rms_reduction_pct, 3),
            c
            and (
                round(c.observed_pct, 3),
                round(c.null_mean_pct, 3),
                round(c.null_sd_pct, 3),
                c.p_adjusted,
                c.more_stances,
            ),
        )
    print(d.selected, json.dumps(d.calibration, default=str)[:800])


if __name__ == "__main__":
    main()
