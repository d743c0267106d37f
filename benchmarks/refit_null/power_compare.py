"""The refit null's power beside the one-step null's, case by case, on the same withheld-effect
cases (issue 22: the opt-in refit null's power was not measured).

Usage: ``python power_compare.py ONE_STEP_DIR REFIT_DIR`` where each folder holds a
``gc-ocp benchmark-diagnosis`` run's ``confusion.json`` made with the same motion, seeds,
magnitude and mismatch scale (``--null-fits one-step`` and ``--null-fits refit``). Cases are
matched by (truth, magnitude, seed); the data of a matched pair are the same draw (checked: the
base's held-out RMS must agree to 1e-6 % BW, else the pair is reported as not comparable).
Prints a markdown table: each run's answer, the truth's held-out gain (the refit's, the same in
both runs), its family-wise p and the steps the verdict predicts, and each run's top-1.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

SAME_DATA_PCT_BW = 1e-6
"""[% BW] Two runs' base held-out RMS closer than this come from the same data (the fits are
deterministic; a different draw moves it by far more)."""


def _cases(folder: Path) -> dict:
    doc = json.loads((folder / "confusion.json").read_text())
    return {(c["truth"], c["magnitude"], c["seed"]): c for c in doc["cases"]}


def _truth_row(case: dict) -> dict | None:
    return next((r for r in case["ranking"] if r["effect"] == case["truth"]), None)


def _fmt_p(row: dict | None) -> str:
    cal = (row or {}).get("calibrated") or {}
    p = cal.get("p_adjusted")
    if p is None:
        return "-"
    more = cal.get("more_stances")
    steps = "" if more in (None, 0) else f", {more} more"
    return f"{p:.3f}{steps}"


def compare(one_step: Path, refit: Path) -> str:
    a, b = _cases(one_step), _cases(refit)
    keys = [k for k in b if k in a]
    lines = [
        "| truth | seed | held-out gain of the truth's refit | one-step: answer, p (steps) "
        "| refit null: answer, p (steps) | minutes (one-step, refit) |",
        "|---|---|---|---|---|---|",
    ]
    right = {"one-step": 0, "refit": 0}
    scored = 0
    for k in keys:
        ca, cb = a[k], b[k]
        if abs(ca["base_heldout_superior_pct_bw"] - cb["base_heldout_superior_pct_bw"]) > (
            SAME_DATA_PCT_BW
        ):
            lines.append(f"| {k[0]} | {k[2]} | not comparable: other data | | | |")
            continue
        ra, rb = _truth_row(ca), _truth_row(cb)
        gain = "-" if rb is None else f"{rb['heldout_rms_reduction_pct']:+.2f} %"
        if k[0] != "none":
            scored += 1
            right["one-step"] += ca["answer"] == k[0]
            right["refit"] += cb["answer"] == k[0]
        lines.append(
            f"| {k[0]} | {k[2]} | {gain} | {ca['answer']}, {_fmt_p(ra)} | {cb['answer']}, "
            f"{_fmt_p(rb)} | {ca['seconds_diagnose'] / 60:.0f}, "
            f"{cb['seconds_diagnose'] / 60:.0f} |"
        )
    lines.append("")
    lines.append(
        f"top-1 of {scored} effect cases: one-step {right['one-step']}, refit null {right['refit']}"
    )
    return "\n".join(lines)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    print(compare(Path(sys.argv[1]), Path(sys.argv[2])))
