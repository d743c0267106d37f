"""The withheld-effect benchmark's results: the confusion table, rates, figure and report text
(:mod:`gc_ocp.bench.withheld` runs the cases)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from gc_ocp.bench.truth import NONE
from gc_ocp.errors import InputError


def summarize(cases: list[dict], labels: Sequence[str]) -> dict:
    """Confusion matrix (rows: truth, columns: answer; ``labels`` then any other answer),
    top-1 accuracy on the effect cases, the "none" correct-rejection rate, overall accuracy and
    the accuracy counting a confusion flagged as ambiguous (the truth among the answer's
    ``confounded_with``, or among the ``inconclusive`` candidates of a "none") as not wrong."""
    truths = [t for t in labels if any(c["truth"] == t for c in cases)]
    answers = list(labels) + sorted({c["answer"] for c in cases} - set(labels))
    m = np.zeros((len(truths), len(answers)), int)
    for c in cases:
        m[truths.index(c["truth"]), answers.index(c["answer"])] += 1
    eff = [c for c in cases if c["truth"] != NONE]
    non = [c for c in cases if c["truth"] == NONE]

    def rate(cs, ok=lambda c: c["correct"]):
        return float(np.mean([ok(c) for c in cs])) if cs else None

    def flagged(c) -> bool:
        """Right, or the truth named by the answer: among the selected effect's
        ``confounded_with``, or (answer "none") among the ``inconclusive`` candidates."""
        return (
            c["correct"]
            or c["truth"] in c["confounded_with"]
            or (c["answer"] == NONE and c["truth"] in c.get("inconclusive", []))
        )

    per = {
        t: {
            mag: rate([c for c in cases if c["truth"] == t and c["magnitude"] == mag])
            for mag in sorted({c["magnitude"] for c in cases if c["truth"] == t})
        }
        for t in truths
    }
    return {
        "truths": truths,
        "answers": answers,
        "matrix": m.tolist(),
        "n_cases": len(cases),
        "top1_accuracy": rate(eff),
        "none_correct_rejection": rate(non),
        "overall_accuracy": rate(cases),
        "top1_accuracy_ambiguity_flagged_ok": rate(eff, flagged),
        "per_truth_and_magnitude": per,
    }


def merge(results: Sequence[dict]) -> dict:
    """Runs of the same base with other seeds as one result (cases keyed by truth, magnitude and
    seed; a later result's case replaces an earlier one; the summary recomputed)."""
    first = results[0]
    by_key: dict = {}
    for r in results:
        if r["settings"]["base"] != first["settings"]["base"]:
            raise InputError("merge: results of different bases")
        for c in r["cases"]:
            by_key[(c["truth"], c["magnitude"], c["seed"])] = c
    cases = list(by_key.values())
    settings = {
        **first["settings"],
        "seeds": sorted({c["seed"] for c in cases if c["truth"] != NONE}),
    }
    return {
        "settings": settings,
        "summary": summarize(cases, [*settings["candidates"], NONE]),
        "cases": cases,
        "seconds": {
            "wall_this_run": None,
            "cases_total": sum(c["seconds_generate"] + c["seconds_diagnose"] for c in cases),
        },
    }


def confusion_figure(result: dict):
    """The confusion matrix (counts; rows truth, columns answer) as a matplotlib figure."""
    from matplotlib.figure import Figure

    s = result["summary"]
    m = np.asarray(s["matrix"], float)
    size = (1.0 + 0.62 * len(s["answers"]), 1.2 + 0.5 * len(s["truths"]))
    fig = Figure(figsize=size, layout="constrained")
    ax = fig.subplots()
    share = m / np.maximum(m.sum(axis=1, keepdims=True), 1)
    ax.imshow(share, cmap="Blues", vmin=0, vmax=1)
    for i in range(m.shape[0]):
        for j in range(m.shape[1]):
            if m[i, j]:
                ax.text(
                    j,
                    i,
                    int(m[i, j]),
                    ha="center",
                    va="center",
                    color="white" if share[i, j] > 0.6 else "black",
                )
    ax.set_xticks(range(len(s["answers"])), s["answers"], rotation=40, ha="right")
    ax.set_yticks(range(len(s["truths"])), s["truths"])
    ax.set_xlabel("diagnosis (top-1)")
    ax.set_ylabel("withheld truth")
    acc, rej = s["top1_accuracy"], s["none_correct_rejection"]
    ax.set_title(
        f"base '{result['settings']['base']}': top-1 "
        f"{'-' if acc is None else f'{100 * acc:.0f} %'}, none rejected "
        f"{'-' if rej is None else f'{100 * rej:.0f} %'} ({s['n_cases']} cases)",
        fontsize=10,
    )
    return fig


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.0f} %"


def _json(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(type(o).__name__)


def report(result: dict) -> str:
    """The summary lines printed by the CLI."""
    s = result["summary"]
    return "\n".join(
        [
            f"withheld-effect benchmark, base '{result['settings']['base']}': {s['n_cases']} cases",
            f"top-1 accuracy (effect cases): {_pct(s['top1_accuracy'])}",
            f'"none" correct rejection: {_pct(s["none_correct_rejection"])}',
            f"overall: {_pct(s['overall_accuracy'])}; effect cases right or flagged ambiguous: "
            f"{_pct(s['top1_accuracy_ambiguity_flagged_ok'])}",
        ]
    )


def markdown(result: dict) -> str:
    """The confusion matrix and rates of a result as Markdown (rows truth, columns answer)."""
    s, st = result["summary"], result["settings"]
    short = {a: a.replace("_", " ") for a in s["answers"]}
    lines = [
        f"**base `{st['base']}`** ({', '.join(st['base_components'])}); candidates: "
        f"{', '.join(st['candidates'])}; {s['n_cases']} cases, "
        f"{result['seconds']['cases_total'] / 60:.0f} min of case time",
        "",
        "| truth \\ answer | " + " | ".join(short[a] for a in s["answers"]) + " |",
        "|---|" + "---|" * len(s["answers"]),
    ]
    for t, row in zip(s["truths"], s["matrix"], strict=True):
        cells = [
            f"**{v}**" if a == t and v else (str(v) if v else ".")
            for a, v in zip(s["answers"], row, strict=True)
        ]
        lines.append(f"| {t} | " + " | ".join(cells) + " |")
    lines += [
        "",
        f"top-1 accuracy (effect cases): **{_pct(s['top1_accuracy'])}**; "
        f'"none" correctly rejected: **{_pct(s["none_correct_rejection"])}**; overall '
        f"{_pct(s['overall_accuracy'])}; effect cases right or flagged ambiguous (truth among "
        f'the answer\'s `confounded_with`, or among the `inconclusive` of a "none"): '
        f"{_pct(s['top1_accuracy_ambiguity_flagged_ok'])}",
    ]
    return "\n".join(lines)
