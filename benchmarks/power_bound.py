"""How far can the calibrated test's power grow with more stances? The bound of the mismatch
null, read from withheld-effect benchmark runs (``gc-ocp benchmark-diagnosis --mismatch 1``).

    .venv/bin/python benchmarks/power_bound.py NAME=FOLDER[+FOLDER...] ...

The null's spread has a part between the mismatch draws, ``s_b``, that more stances do not
shrink (``gc_ocp.diagnosis.null``, module doc): however many stances, a candidate is named only
when its one-step held-out gain ``T`` exceeds the null's mean ``m`` by more than
``z_crit s_b``. For every case whose truth is an effect, this prints the truth's own row: its
one-step gain (the test's statistic) beside its refit's held-out gain (the ranking's), the
null's mean and between-draw spread, the *decidable gain* ``m + z_crit s_b`` (what a
true effect must exceed at any number of stances), the adjusted p-value and the further stances
the result says would decide it (0: named; None: no number would). For the "none" cases it
prints, per candidate, the median decidable gain: the size of effect the mismatch family hides.

Writes Markdown to stdout.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from gc_ocp.bench.summary import merge


def _load(folders: str) -> list[dict]:
    parts = [json.loads((Path(f) / "confusion.json").read_text()) for f in folders.split("+")]
    return (merge(parts) if len(parts) > 1 else parts[0])["cases"]


def _bound(c: dict) -> float | None:
    """``m + z_crit s``, ``s`` the part of the null's spread more stances do not shrink: the part
    every held-out stance shares when the run has it (since 2026-11-28), else all of the
    spread between mismatch draws."""
    if not c or c.get("null_sd_mismatch_pct") is None:
        return None
    s = c.get("null_sd_systematic_pct")
    return c["null_mean_pct"] + c["z_critical"] * (c["null_sd_mismatch_pct"] if s is None else s)


def main(args: list[str]) -> None:
    print("# The calibrated test's bound: the gain a true effect must exceed at any size\n")
    for a in args:
        name, folders = a.split("=", 1)
        cases = sorted(_load(folders), key=lambda c: (c["truth"], c["magnitude"], c["seed"]))
        effects = [c for c in cases if c["truth"] != "none"]
        nones = [c for c in cases if c["truth"] == "none"]
        print(f"## {name}\n")
        if effects:
            print(
                "| truth | magnitude | seed | answer | gain T [%] | refit's gain [%] | "
                "null mean [%] | between-draw SD [%] | decidable gain [%] | p | more stances |"
            )
            print("|---|---|---|---|---|---|---|---|---|---|---|")
            for c in effects:
                row = next((r for r in c["ranking"] if r["effect"] == c["truth"]), None)
                t = (row or {}).get("calibrated")
                if not t:
                    print(
                        f"| {c['truth']} | {c['magnitude']} | {c['seed']} | {c['answer']} |"
                        " - | - | - | - | - | - | - |"
                    )
                    continue
                b = _bound(t)
                refit = row.get("heldout_rms_reduction_pct")
                print(
                    f"| {c['truth']} | {c['magnitude']} | {c['seed']} | {c['answer']} | "
                    f"{t['observed_pct']:+.2f} | {'-' if refit is None else f'{refit:+.2f}'} | "
                    f"{t['null_mean_pct']:+.2f} | "
                    f"{t.get('null_sd_mismatch_pct', float('nan')):.2f} | "
                    f"{'-' if b is None else f'{b:+.2f}'} | {t['p_adjusted']:.3f} | "
                    f"{t['more_stances']} |"
                )
            print()
        if nones:
            per: dict[str, list[float]] = {}
            for c in nones:
                for r in c["ranking"]:
                    b = _bound(r.get("calibrated"))
                    if b is not None:
                        per.setdefault(r["effect"], []).append(b)
            print(
                f'Decidable gain on the {len(nones)} "none" cases, per candidate (median, range):\n'
            )
            print("| candidate | median [%] | range [%] |\n|---|---|---|")
            for eff, v in sorted(per.items()):
                print(f"| {eff} | {np.median(v):+.2f} | {min(v):+.2f} to {max(v):+.2f} |")
            print()


if __name__ == "__main__":
    main(sys.argv[1:])
