"""Two runs of the withheld-effect benchmark on the same cases, side by side: the answer, the
true effect's family-wise p-value and the further stances it would take, and the candidate with
the smallest p-value, per case (the power one null costs against another).

Usage::

    python benchmarks/plate_member_power/compare.py A/confusion.json B/confusion.json

Cases are matched by truth, magnitude and seed; a case in one run only is left out.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path


def cases(path: str) -> dict:
    """``{(truth, magnitude, seed): row}`` of a ``confusion.json``: the answer, the truth's
    p-value and steps, the smallest p-value's candidate, the diagnosis's seconds."""
    out = {}
    for c in json.loads(Path(path).read_text())["cases"]:
        tested = [r for r in c["ranking"] if r.get("calibrated")]
        truth = next((r["calibrated"] for r in tested if r["effect"] == c["truth"]), {})
        best = min(tested, key=lambda r: r["calibrated"]["p_adjusted"], default=None)
        out[c["truth"], c["magnitude"], c["seed"]] = {
            "answer": c["answer"],
            "p": truth.get("p_adjusted"),
            "more": truth.get("more_stances"),
            "best": None if best is None else (best["effect"], best["calibrated"]["p_adjusted"]),
            "seconds": c["seconds_diagnose"],
        }
    return out


def _p(x) -> str:
    return "-" if x is None else f"{x:.3f}"


def _more(x) -> str:
    return "undecidable" if x is None else str(x)


def main() -> None:
    a, b = (cases(p) for p in sys.argv[1:3])
    print("| truth | magnitude | seed | answer | truth's p | more stances | smallest p | s |")
    print("|---|---|---|---|---|---|---|---|")
    for key in (k for k in a if k in b):
        x, y = a[key], b[key]
        best = ["-" if r["best"] is None else f"{r['best'][0]} {r['best'][1]:.3f}" for r in (x, y)]
        more = "-" if key[0] == "none" else f"{_more(x['more'])} / {_more(y['more'])}"
        print(
            f"| {key[0]} | {key[1]} | {key[2]} | {x['answer']} / {y['answer']} | "
            f"{_p(x['p'])} / {_p(y['p'])} | {more} | {best[0]} / {best[1]} | "
            f"{x['seconds']:.0f} / {y['seconds']:.0f} |"
        )


if __name__ == "__main__":
    main()
