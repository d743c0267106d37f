"""Cases diagnosed before and after the clock offset's one step moved to its own fit, side by
side: the answer, the clock offset's one-step gain and family-wise p, and the smallest p of any
candidate (the max statistic is over every candidate, so its null moves the others' too).

    PYTHONPATH=. .venv/bin/python benchmarks/own_fit_compare.py NAME=BEFORE:AFTER ...

BEFORE and AFTER are benchmark folders (``confusion.json``; several joined by ``+``); cases
are paired by truth,
magnitude and seed (the same data). Writes Markdown to stdout (``docs/diagnosis.md``, *Where the
clock offset's step starts*).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def _cases(folders: str) -> dict:
    """The cases of one folder or several joined by ``+`` (runs of other seeds)."""
    out = {}
    for folder in folders.split("+"):
        for c in json.loads((Path(folder) / "confusion.json").read_text())["cases"]:
            out[(c["truth"], c["magnitude"], c["seed"])] = c
    return out


def _row(c: dict) -> tuple[str, str, str]:
    to = next((r for r in c["ranking"] if r["effect"] == "time_offset"), None)
    cal = (to or {}).get("calibrated") or {}
    gain = f"{cal['observed_pct']:+.2f} %, p {cal['p_adjusted']:.3f}" if cal else "-"
    ps = [(r["calibrated"]["p_adjusted"], r["effect"]) for r in c["ranking"] if r.get("calibrated")]
    low = f"{min(ps)[1]} {min(ps)[0]:.3f}" if ps else "-"
    return c["answer"], gain, low


def main(args: list[str]) -> None:
    for arg in args:
        name, _, pair = arg.partition("=")
        before, after = (_cases(f) for f in pair.split(":"))
        print(f"### {name}\n")
        print(
            "| truth | seed | answer before / after | clock offset one step, p: before | after "
            "| smallest p: before | after | refit's gain held out |"
        )
        print("|---|---|---|---|---|---|---|---|")
        for key in sorted(set(before) & set(after), key=lambda k: (k[0], k[1], int(k[2]))):
            b, a = _row(before[key]), _row(after[key])
            to = next(r for r in after[key]["ranking"] if r["effect"] == "time_offset")
            print(
                f"| {key[0]} | {key[2]} | {b[0]} / {a[0]} | {b[1]} | {a[1]} | {b[2]} | {a[2]} "
                f"| {to['heldout_rms_reduction_pct']:+.2f} % |"
            )
        named = [k for k in after if after[k]["answer"] not in ("none", k[0])]
        print(
            f"after: {len(after)} cases, {sum(after[k]['answer'] != 'none' for k in after)} "
            f"answered with an effect ({len(named)} not the truth)\n"
        )


if __name__ == "__main__":
    main(sys.argv[1:])
