"""Summarise the mismatch benchmark's "none" cases (``gc-ocp benchmark-diagnosis --effects none
--mismatch 1``): how often the diagnosis names an effect, and how often the calibrated test alone
would (without the rule's effect-size floor).

    .venv/bin/python benchmarks/mismatch_none_summary.py benchmarks/mismatch_none/bundled ...

Writes the markdown to stdout.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def main(folders: list[str]) -> None:
    print('# Mismatch benchmark: "none" truths that differ from the model by the mismatch family\n')
    print(
        "| motion | cases | effect named (false claims) | named by the test alone | test alone and "
        "refit reduces the held-out score | run time [s] |"
    )
    print("|---|---|---|---|---|---|")
    details = []
    for folder in folders:
        d = json.loads((Path(folder) / "confusion.json").read_text())
        cases = d["cases"]
        claims = [c for c in cases if c["answer"] != "none"]
        alone, refit = [], []
        for c in cases:
            rows = [r for r in c["ranking"] if r.get("calibrated")]
            named = [r for r in rows if r["calibrated"]["p_adjusted"] < 0.05]
            if named:
                alone.append(c)
                details.append((Path(folder).name, c["seed"], named))
            if any((r["heldout_rms_reduction_pct"] or 0) > 0 for r in named):
                refit.append(c)
        n = len(cases)
        print(
            f"| {Path(folder).name} | {n} | {len(claims)} ({100 * len(claims) / n:.0f} %) | "
            f"{len(alone)} ({100 * len(alone) / n:.0f} %) | {len(refit)} ({100 * len(refit) / n:.0f} %) | "
            f"{d['seconds']['cases_total']:.0f} |"
        )
    print(
        "\nCases the test alone names (effect: family-wise p, held-out reduction of the refit):\n"
    )
    for motion, seed, named in details:
        text = ", ".join(
            f"{r['effect']}: p = {r['calibrated']['p_adjusted']:.3f}, "
            f"{r['heldout_rms_reduction_pct']:+.2f} %"
            for r in named
        )
        print(f"* {motion} seed {seed}: {text}")


if __name__ == "__main__":
    main(sys.argv[1:])
