"""Summarise the mismatch benchmark's "none" cases (``gc-ocp benchmark-diagnosis --effects none
--mismatch 1``): how often the diagnosis names an effect (a false claim: the truth differs from
the model only by a draw of the mismatch family), and how often each of the rule's two filters
alone would (the calibrated test without the effect-size floor; the floor without the test).

    .venv/bin/python benchmarks/mismatch_none_summary.py NAME=FOLDER[+FOLDER...] ... [paired:A:B]

A run of several folders (runs of other seeds, ``--first-seed``) is merged into one row.
``paired:A:B``: the cases of runs A and B with the same seed (the same data) where either named
an effect, side by side (e.g. the same cases under two versions of the null).

Writes the Markdown to stdout.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from rule_variants import clears_floor, named

from gc_ocp.bench.summary import merge


def _share(k: int, n: int) -> str:
    return f"{k} ({100 * k / n:.0f} %)" if n else "-"


def _draw(m: dict | None) -> str:
    if not m:
        return "-"
    return (
        f"penetration x{m['depth_factor']:.2f} {m['depth_form'] or 'default form'}, "
        f"slip x{m['slip_factor']:.2f} {m['slip_form'] or 'default form'}, "
        f"markers low-passed {m['cutoff_hz']:.1f} Hz, threshold {m['threshold_n']:.0f} N, "
        f"hum {m['hum_amplitude_n']:.1f} N"
    )


def _median_case(cases: list[dict]) -> str:
    """The median time of a case (data made and diagnosed) [s], "-" where the runs lack it."""
    t = [c["seconds_generate"] + c["seconds_diagnose"] for c in cases if "seconds_diagnose" in c]
    return f"{sorted(t)[len(t) // 2]:.0f}" if t else "-"


def main(args: list[str]) -> None:
    print('# Mismatch benchmark: "none" truths that differ from the model by the mismatch family\n')
    print(
        "| run | cases | effect named by the rule (false claims) | by the calibrated test alone "
        "| by the effect-size floor alone | errors | run time [min] | median case [s] |"
    )
    print("|---|---|---|---|---|---|---|---|")
    details = []
    runs = {}
    pairs = [a.split(":")[1:] for a in args if a.startswith("paired:")]
    for a in args:
        if a.startswith("paired:"):
            continue
        name, folders = a.split("=", 1)
        parts = [json.loads((Path(f) / "confusion.json").read_text()) for f in folders.split("+")]
        d = merge(parts) if len(parts) > 1 else parts[0]
        cases = sorted(d["cases"], key=lambda c: c["seed"])
        runs[name] = {c["seed"]: c for c in cases}
        n = len(cases)
        claims = [c for c in cases if c["answer"] not in ("none", "error")]
        errors = [c for c in cases if c["answer"] == "error"]
        alone = [c for c in cases if any(named(r) for r in c["ranking"])]
        floor = [c for c in cases if any(clears_floor(r) for r in c["ranking"])]
        print(
            f"| {name} | {n} | {_share(len(claims), n)} | {_share(len(alone), n)} | "
            f"{_share(len(floor), n)} | {len(errors)} | {d['seconds']['cases_total'] / 60:.0f} | "
            f"{_median_case(cases)} |"
        )
        details += [(name, c) for c in claims]
    print(
        "\nFalse claims (the effect named: family-wise p, refitted held-out reduction; the draw):\n"
    )
    for name, c in details:
        r = next(r for r in c["ranking"] if r["effect"] == c["answer"])
        print(
            f"* {name} seed {c['seed']}: **{c['answer']}**, p = {r['calibrated']['p_adjusted']:.3f}, "
            f"{r['heldout_rms_reduction_pct']:+.2f} % held out; draw: {_draw(c.get('mismatch'))}"
        )
    for a, b in pairs:
        print(
            f"\nPaired (the same data): {a} against {b}, the seeds where either named an effect:\n"
        )
        print(f"| seed | {a} | {b} |\n|---|---|---|")
        for seed in sorted(set(runs[a]) & set(runs[b])):
            ca, cb = runs[a][seed], runs[b][seed]
            if ca["answer"] == "none" and cb["answer"] == "none":
                continue
            print(f"| {seed} | {_answer(ca)} | {_answer(cb)} |")


def _answer(c: dict) -> str:
    """The case's answer with the named effect's p (or the top-ranked row's, for "none")."""
    rows = [r for r in c["ranking"] if r.get("calibrated")]
    if c["answer"] not in ("none", "error"):
        r = next(r for r in rows if r["effect"] == c["answer"])
    elif rows:
        r = min(rows, key=lambda r: r["calibrated"]["p_adjusted"])
    else:
        return c["answer"]
    return f"{c['answer']} (lowest p: {r['effect']} {r['calibrated']['p_adjusted']:.3f})"


if __name__ == "__main__":
    main(sys.argv[1:])
