"""Round 1 of the BTS subject's diagnosis (Walking1-3) with the refit null."""

import json
import sys
import time
import warnings
from pathlib import Path


def main():
    from gc_ocp.diagnosis import diagnose
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics

    files = [f"/work/shared/data/bts_unipd_5trials/Walking{k}.c3d" for k in (1, 2, 3)]
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    null_fits = sys.argv[2] if len(sys.argv) > 2 else "refit"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pairs = []
        for f in files:
            t = load_trial(f)
            pairs.append((t, compute_kinematics(t)))
        t0 = time.time()
        d = diagnose(pairs, max_effects=1, null_fits=null_fits, workers=2, progress=print)
    (out / "diagnosis.json").write_text(json.dumps(d.to_json(), indent=1, default=str))
    (out / "summary.txt").write_text(d.summary() + f"\nwall {time.time() - t0:.0f} s\n")
    print(d.summary())


if __name__ == "__main__":
    main()
