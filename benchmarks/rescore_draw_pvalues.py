"""Re-score stored withheld-effect and mismatch "none" benchmark runs with the adjusted p-value
counted per mismatch draw (``gc_ocp.diagnosis.null.decide``, 2026-11-30) instead of per
replicate (before).

Each round's null had ``K`` mismatch draws of ``W`` wild replicates (``W = ceil(500 / 32) = 16``
for the one-step null; the refit null has ``W = 1``, whose p-value does not change). A stored
p-value ``(1 + e) / (K W + 1)`` gives back ``e``, the replicates whose largest studentised
reduction reached the candidate's; with every draw holding ``W`` replicates, the draw-counted
p-value is ``(1 + e / W) / (K + 1)`` exactly. A row passes when it passed before (test and
effect-size floor) and its new p-value is under alpha; the top-1 answer is the first passing
row in the stored ranking (the rule's order), else "none". Stored answers are reproduced from
the old p-values first (a check of the reading).

    .venv/bin/python benchmarks/rescore_draw_pvalues.py FOLDER [FOLDER ...]

Writes Markdown to stdout. Not re-scored: the steps-needed numbers (the critical value moved,
and the null's replicates are not stored), the later rounds (top-1 reads the first).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

ALPHA = 0.05
W = math.ceil(500 / 32)


def _p_draw(p_rep: float, K: int) -> float:
    e = round(p_rep * (K * W + 1) - 1)
    return (1 + e / W) / (K + 1)


def rescore(case: dict) -> tuple[str, str, float | None, float | None, bool]:
    """``(old answer, new answer, old p, new p, reproduced)`` of the case's first round."""
    K = int(case["null"][0]["mismatch_draws"]) if case.get("null") else 0
    old_first = new_first = "none"
    old_p = new_p = None
    for r in case["ranking"]:
        cal = r.get("calibrated") or {}
        p = cal.get("p_adjusted")
        if p is None or not r.get("passes"):
            continue
        q = _p_draw(p, K) if K else p
        if old_first == "none":
            old_first, old_p = r["effect"], p
        if new_first == "none" and q < ALPHA:
            new_first, new_p = r["effect"], q
    answer = case["answer"] if isinstance(case["answer"], str) else str(case["answer"])
    return old_first, new_first, old_p, new_p, old_first == answer.split("+")[0]


def main(folders: list[str]) -> None:
    for f in folders:
        d = json.loads((Path(f) / "confusion.json").read_text())
        rows, ok = [], 0
        eff = [0, 0, 0]  # cases, right before, right now
        none = [0, 0, 0]
        for c in d["cases"]:
            old, new, po, pn, rep = rescore(c)
            ok += rep
            is_none = c["truth"] == "none"
            t = none if is_none else eff
            t[0] += 1
            t[1] += old == ("none" if is_none else c["truth"])
            t[2] += new == ("none" if is_none else c["truth"])
            fmt = lambda p: "-" if p is None else f"{p:.3f}"  # noqa: E731
            rows.append(
                f"| {c['truth']} | {c.get('magnitude', '-')} | {c['seed']} | {old} ({fmt(po)}) | "
                f"{new} ({fmt(pn)}) |"
            )
        print(f"\n## {f}\n")
        print("| truth | magnitude | seed | answer before (p) | answer now (p, per draw) |")
        print("|---|---|---|---|---|")
        print("\n".join(rows))
        print(
            f"\nstored answers reproduced from the stored p-values: {ok} of {len(d['cases'])}; "
            f"effect cases right: {eff[1]} -> {eff[2]} of {eff[0]}; "
            f'"none" cases answered none: {none[1]} -> {none[2]} of {none[0]}'
        )


if __name__ == "__main__":
    main(sys.argv[1:])
