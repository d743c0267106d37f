"""Does the null's spread between mismatch draws shrink with more held-out stances? (issue 22,
the steps that would decide.)

The steps-needed calculation (``gc_ocp.diagnosis.null.more_stances``) takes the part of the
null's spread that lies between mismatch draws as what more stances of the same kind do not
shrink. Until 2026-11-28 that was the whole between-draw spread ``s_b``; since then only the
part every held-out stance shares (``null_sd_systematic_pct``, ``null.systematic_sd``), the
rest shrinking as ``1/sqrt(n)``. This script reads benchmark runs of the same cases (truth,
magnitude, seed) at two sizes (``withheld_sizes.load``: ``{motion}_{N}[_width][_seedK]``
folders) and, per candidate, sets the between-draw spread at the larger size beside the
smaller's:

* the ratio ``s_b(n2) / s_b(n1)``: 1 if all of it were shared, ``sqrt(n1 / n2)`` if all of it
  were the stances' own;
* where the smaller size's rows carry the split, its prediction ``sqrt(s_sys^2 + (s_b^2 -
  s_sys^2) n1 / n2)`` against the observed ``s_b(n2)``, and the former prediction (``s_b``
  itself) beside it.

The two sizes' cases share truth, magnitude and seed, but not their data: the larger size's
strides are the motion's repeated with new noise and a new mismatch draw (``bench.truth.
per_foot``), so a pair's ratio carries that draw's own spread too; medians over the pairs.

    python benchmarks/between_draw_scaling.py [ROOT]   # ROOT: benchmarks/withheld_mismatch
"""

from __future__ import annotations

import math
import sys
from collections import defaultdict
from pathlib import Path
from statistics import median

from withheld_sizes import HERE, case_key, load  # isort: skip (a script beside this one)


def _rows(case: dict) -> dict[str, dict]:
    return {r["effect"]: r["calibrated"] for r in case["ranking"] if r.get("calibrated")}


def pairs(root: Path) -> list[tuple[str, int, int, str, dict, dict]]:
    """``(motion, n1, n2, candidate, test at n1, test at n2)`` for every candidate of every case
    run at two sizes (held-out stances ``n1 < n2``)."""
    runs = load(root)
    out = []
    for (motion, k1), r1 in runs.items():
        for (m2, k2), r2 in runs.items():
            if m2 != motion or k2 <= k1:
                continue
            later = {case_key(c): c for c in r2["cases"]}
            for c in r1["cases"]:
                d = later.get(case_key(c))
                if d is None or "error" in (c["answer"], d["answer"]):
                    continue
                a, b = _rows(c), _rows(d)
                for e in a.keys() & b.keys():
                    if a[e]["null_sd_mismatch_pct"] > 1e-6:  # a candidate the draws move
                        out.append((motion, a[e]["n_heldout"], b[e]["n_heldout"], e, a[e], b[e]))
    return out


def predicted(t: dict, n2: int) -> float | None:
    """The between-draw spread at ``n2`` held-out stances the split of ``t`` predicts, None
    when ``t`` has no split."""
    s_b, s_sys = t["null_sd_mismatch_pct"], t.get("null_sd_systematic_pct")
    if s_sys is None:
        return None
    return math.sqrt(s_sys**2 + (s_b**2 - s_sys**2) * t["n_heldout"] / n2)


def main(root: Path = HERE) -> None:
    groups = defaultdict(list)
    for motion, n1, n2, e, a, b in pairs(root):
        groups[(motion, n1, n2, e)].append((a, b))
    print(f"# The null's spread between mismatch draws at two sizes (`{root.name}`)\n")
    print(
        "| motion | held-out stances | candidate | pairs | s_b(n2)/s_b(n1), median (range) "
        "| all own would give | split's prediction / observed, median | former (s_b) / observed |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for (motion, n1, n2, e), items in sorted(groups.items()):
        ratio = [b["null_sd_mismatch_pct"] / a["null_sd_mismatch_pct"] for a, b in items]
        obs = [b["null_sd_mismatch_pct"] for _, b in items]
        pred = [predicted(a, n2) for a, _ in items]
        split = [p / o for p, o in zip(pred, obs, strict=True) if p is not None and o > 1e-6]
        former = [
            a["null_sd_mismatch_pct"] / o for (a, _), o in zip(items, obs, strict=True) if o > 1e-6
        ]
        print(
            f"| {motion} | {n1} -> {n2} | {e} | {len(items)} | {median(ratio):.2f} "
            f"({min(ratio):.2f}-{max(ratio):.2f}) | {math.sqrt(n1 / n2):.2f} | "
            + (f"{median(split):.2f} ({len(split)})" if split else "-")
            + (f" | {median(former):.2f} |" if former else " | - |")
        )


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE)
