"""The withheld-effect benchmark with the mismatch family on, at 2, 4 and 8 stances per foot, on
both motions (issue 22): top-1 and "none" per size, per effect and magnitude; what stops the
effects that are not found (the bound per effect); and the steps-needed prediction checked.

Runs (each a ``gc-ocp benchmark-diagnosis`` folder; ``--resume`` continues one)::

    gc-ocp benchmark-diagnosis --seeds 3 --mismatch 1 --stances-per-foot N --pose-width prior \\
        --out benchmarks/withheld_mismatch/bundled_N
    gc-ocp benchmark-diagnosis --seeds 3 --mismatch 1 --stances-per-foot N --pose-width prior \\
        --trial ../shared/data/bts_unipd_5trials/Walking1.c3d (... Walking2, Walking3) \\
        --out benchmarks/withheld_mismatch/bts_N

(the guessed pose width, the diagnosis's default until 2026-11-28; the same command without
``--pose-width prior`` and with ``--out .../{motion}_N_width`` is the rerun on the estimated
width, the default since, which :func:`widths` sets beside it case by case). Then
``python benchmarks/withheld_sizes.py [ROOT ...]`` writes the Markdown to stdout from every
``ROOT/{motion}_{N}/confusion.json`` present (ROOTs: ``benchmarks/withheld_mismatch`` and
``benchmarks/withheld_steps``, the steps-needed screens and reruns; partial runs included, their
case counts shown; the base-width comparison reads the first ROOT only).

**What stops an effect** (per case whose truth is not the answer): ``test`` (the calibrated
test does not name the truth), ``floor`` (it does, but the refitted held-out or in-sample
reduction is below the rule's floor or its interval reaches 0), ``outranked`` (the truth passes
but another passing candidate comes first), ``error`` (the case's diagnosis stopped).

**Steps needed, checked**: a case whose truth's row is inconclusive at N stances per foot
predicts the rule's further held-out stances (:func:`rule_stances`: the test's for 80 % power
and the effect-size floor's, the larger); the same truth and seed at the smallest larger size
with at least that many held-out stances is a rerun of the kind the prediction speaks of (new
draws of the noise and mismatch, the same effect): it *decides* when the rule names the truth
there (the calibrated test names it and its held-out gain passes the floor); the test's part
alone is shown beside it.
"""

from __future__ import annotations

import json
import re
from collections import Counter, defaultdict
from pathlib import Path
from statistics import median

from gc_ocp.bench.truth import MAGNITUDES
from gc_ocp.diagnosis.null import ALPHA
from gc_ocp.diagnosis.result import RankRow
from gc_ocp.diagnosis.selection import floor_stances

HERE = Path(__file__).parent / "withheld_mismatch"
STEPS = Path(__file__).parent / "withheld_steps"
"""The steps-needed reruns and the screens they come from (read beside :data:`HERE`)."""


def load(*roots: Path) -> dict[tuple[str, int], dict]:
    """``{(motion and base, stances per foot): run}``: ``{motion}_{N}`` is a run on the guessed
    pose width, ``{motion}_{N}_width`` on the estimated one (the default since 2026-11-28); the
    two bases are kept apart, so that sizes and the steps-needed check compare like with like.
    A ``..._seed{K}`` folder holds further seeds of the same motion, base and size (a run with
    ``--first-seed K``), a ``..._part{X}`` folder a part of a run split over processes (other
    ``--effects``): their cases join that size's, a case (truth, magnitude, seed) counted
    once. Other suffixes (``_own_fit``: a rerun of single cases on a later version) are not
    read."""
    out: dict[tuple[str, int], dict] = {}
    for p in [p for root in roots or (HERE,) for p in sorted(root.glob("*_*/confusion.json"))]:
        m = re.fullmatch(r"(.+)_(\d+)(_width)?(_seed\d+)?(_part\w+)?", p.parent.name)
        if not m:
            continue
        base = "estimated width" if m.group(3) else "guessed width"
        key = (f"{m.group(1)}, {base}", int(m.group(2)))
        run = json.loads(p.read_text())
        run["steps"] = p.parent.parent.resolve() == STEPS.resolve()
        if key not in out:
            out[key] = run
            continue
        out[key]["steps"] |= run["steps"]
        have = {case_key(c) for c in out[key]["cases"]}
        out[key]["cases"] += [c for c in run["cases"] if case_key(c) not in have]
        out[key]["seconds"]["cases_total"] += run["seconds"]["cases_total"]
    return out


def case_key(case: dict) -> tuple:
    """What makes a benchmark case the same case in another run: truth, magnitude, seed."""
    return case["truth"], case["magnitude"], case["seed"]


def _pct(k: int, n: int) -> str:
    return "-" if not n else f"{100 * k / n:.0f} % ({k}/{n})"


def truth_row(case: dict) -> dict | None:
    """The ranking row of the case's truth, None when it was not ranked."""
    return next((r for r in case["ranking"] if r["effect"] == case["truth"]), None)


def stopped_by(case: dict) -> str:
    if case["answer"] == "error":
        return "error"
    row = truth_row(case)
    if row is None:
        return "not ranked"
    c = row.get("calibrated")
    if not c or c["p_adjusted"] >= ALPHA:
        return "test"
    if not row["passes"]:
        return "floor"
    return "outranked"


def rule_stances(row: dict) -> int | None:
    """The rule's further held-out stances of a ranking row (``RankRow.more_stances``): the
    larger of the test's (``calibrated.more_stances``) and the effect-size floor's
    (:func:`~gc_ocp.diagnosis.selection.floor_stances`, recomputed from the row: rows written
    before 2026-11-28 do not carry it, and a row's own is written only when not 0);
    :meth:`RankRow.rule_stances`."""
    test = row["calibrated"]["more_stances"]
    pct = row["heldout_rms_reduction_pct"]
    if pct is None:
        return None
    red = {
        "pct": pct,
        "ci": row["heldout_rms_reduction_ci"],
        "insample_pct": row["insample_rms_reduction_pct"],
    }
    return RankRow.rule_stances(test, floor_stances(red, row["calibrated"]["n_heldout"]))


def main(*roots: Path) -> None:
    runs = load(*roots)
    motions = sorted({m for m, _ in runs})
    print("# Withheld-effect benchmark with the mismatch family, by stances per foot\n")
    print(
        "Truth: the registered base fitted to the motion's real stances, plus one effect (or "
        "none) and one draw of the mismatch family (scale 1); data with the benchmark's realism "
        "(marker noise, soft-tissue drift, plate noise, 20 N threshold). Blind "
        "`diagnose_stances(max_effects=1)`. Strides beyond a motion's own are its real strides "
        "repeated as further trials with their own noise and draws (`bench.truth.per_foot`).\n"
    )
    print(
        "| motion | stances per foot | cases | "
        + " | ".join(f"top-1, {m}" for m in MAGNITUDES)
        + ' | "none" rejected | time [min]: all cases, median case |'
    )
    print("|---|---|---|" + "---|" * len(MAGNITUDES) + "---|---|")
    print_note = any(r["steps"] for r in runs.values())
    for (motion, n), res in sorted(runs.items()):
        cs = res["cases"]
        by = [[c for c in cs if c["magnitude"] == m] for m in MAGNITUDES]
        non = [c for c in cs if c["truth"] == "none"]
        print(
            f"| {motion} | {n}{' (s)' if res['steps'] else ''} | {len(cs)} | "
            + " | ".join(_pct(sum(c["correct"] for c in g), len(g)) for g in by)
            + f" | {_pct(sum(c['correct'] for c in non), len(non))} | "
            f"{res['seconds']['cases_total'] / 60:.0f}, "
            f"{median(c['seconds_generate'] + c['seconds_diagnose'] for c in cs) / 60:.1f} |"
        )
    if print_note:
        print(
            "\n(s): the size holds cases of `withheld_steps`: the steps-needed check's screens "
            "(further seeds at 2 per foot) and its reruns of the truths those left inconclusive, "
            "at the size predicted (cases chosen for being inconclusive, not a sample of the "
            "effects: *Steps needed, checked*), and the estimated width's cases at 8 per foot."
        )
    for motion in motions:
        sizes = sorted(n for m, n in runs if m == motion)
        print(f"\n## {motion}: per effect (right / cases; what stopped the others)\n")
        print("| truth | magnitude | " + " | ".join(f"{n} per foot" for n in sizes) + " |")
        print("|---|---|" + "---|" * len(sizes))
        truths = sorted({c["truth"] for n in sizes for c in runs[(motion, n)]["cases"]})
        present = {c["magnitude"] for n in sizes for c in runs[(motion, n)]["cases"]}
        for t in truths:
            for mag in [m for m in MAGNITUDES if m in present] if t != "none" else ("-",):
                cells = []
                for n in sizes:
                    cs = [
                        c
                        for c in runs[(motion, n)]["cases"]
                        if c["truth"] == t and c["magnitude"] == mag
                    ]
                    if not cs:
                        cells.append("")
                        continue
                    ok = sum(c["correct"] for c in cs)
                    if t == "none":
                        why = Counter(c["answer"] for c in cs if not c["correct"])
                    else:
                        why = Counter(stopped_by(c) for c in cs if not c["correct"])
                    gains = sorted(
                        r["heldout_rms_reduction_pct"]
                        for c in cs
                        for r in c["ranking"]
                        if r["effect"] == t and r["heldout_rms_reduction_pct"] is not None
                    )
                    med = (
                        f"; truth's held-out gain median {gains[len(gains) // 2]:+.1f} %"
                        if gains
                        else ""
                    )
                    cells.append(
                        f"{ok}/{len(cs)}"
                        + (f" ({', '.join(f'{k} {v}' for k, v in why.items())})" if why else "")
                        + med
                    )
                print(f"| {t} | {mag} | " + " | ".join(cells) + " |")
    print("\n## Steps needed, checked\n")
    checked = defaultdict(list)
    for (motion, n), res in sorted(runs.items()):
        larger = sorted(k for m, k in runs if m == motion and k > n)
        for c in res["cases"]:
            if c["truth"] == "none" or c["answer"] == "error":
                continue
            row = truth_row(c)
            if row is None or not row.get("inconclusive") or not row.get("calibrated"):
                continue
            need = rule_stances(row)
            have = row["calibrated"]["n_heldout"]
            if not need:
                continue
            # held-out stances at k per foot: 2k (every stance of a foot with two or more)
            target = next((k for k in larger if 2 * k >= have + need), None)
            if target is None:
                checked[motion].append((c, n, need, None, None, None))
                continue
            again = next(
                (d for d in runs[(motion, target)]["cases"] if case_key(d) == case_key(c)),
                None,
            )
            if again is None:
                checked[motion].append((c, n, need, target, None, None))
                continue
            r2 = truth_row(again)  # the same truth
            named = bool(r2 and r2.get("calibrated") and r2["calibrated"]["p_adjusted"] < ALPHA)
            checked[motion].append((c, n, need, target, named, named and r2["passes"]))
    print(
        "| motion | inconclusive truths | rerun available | named by the test at the "
        "predicted size | named by the rule (test and floor): decided |"
    )
    print("|---|---|---|---|---|")
    for motion, items in checked.items():
        avail = [i for i in items if i[4] is not None]
        print(
            f"| {motion} | {len(items)} | {len(avail)} | "
            f"{_pct(sum(bool(i[4]) for i in avail), len(avail))} | "
            f"{_pct(sum(bool(i[5]) for i in avail), len(avail))} |"
        )
    for motion, items in checked.items():
        for c, n, need, target, named, _ in items:
            print(
                f"* {motion}: {c['truth']} ({c['magnitude']}, seed {c['seed']}) at {n} per foot: "
                f"{need} more stances predicted; "
                + (
                    "no larger size holds that many"
                    if target is None
                    else f"at {target} per foot: "
                    + ("not run" if named is None else "named" if named else "not named")
                )
            )


def _truth_cell(case: dict) -> str:
    """The answer, and the truth's calibrated p and held-out gain, of one case."""
    row = truth_row(case)
    head = f"{case['answer']} ({'ok' if case['correct'] else 'wrong'})"
    if row is None:
        return head
    c = row.get("calibrated") or {}
    p = f"p {c['p_adjusted']:.3f}" if "p_adjusted" in c else "p -"
    g = row.get("heldout_rms_reduction_pct")
    return head + f"; {p}, held out {g:+.1f} %" if g is not None else head + f"; {p}"


def widths(root: Path = HERE) -> None:
    """Each ``{motion}_{N}`` run beside its ``{motion}_{N}_width`` rerun on the estimated-pose-
    width base (``--pose-width estimated``, issue 23), case by case (same truths and seeds)."""
    pairs = []
    for p in sorted(root.glob("*_*_width/confusion.json")):
        m = re.fullmatch(r"(.+)_(\d+)_width", p.parent.name)
        before = root / f"{m.group(1)}_{m.group(2)}" / "confusion.json" if m else None
        if before is not None and before.exists():
            pairs.append((p.parent.name, json.loads(before.read_text()), json.loads(p.read_text())))
    if not pairs:
        return
    print("\n## The base's pose width: the guessed prior against the estimated width\n")
    print(
        "The same cases (truth, magnitude, seed, data) diagnosed on the base with the pose "
        "correction's prior width (2 mm / 1 deg) and with its width estimated on every stance "
        "first (`--pose-width estimated`).\n"
    )
    for name, a, b in pairs:
        done = {case_key(c): c for c in b["cases"]}
        print(f"### {name}\n")
        print(
            "| truth | magnitude | seed | prior width | estimated width | minutes (prior, estimated) |"
        )
        print("|---|---|---|---|---|---|")
        both = [(c, done[case_key(c)]) for c in a["cases"] if case_key(c) in done]
        for c, d in both:
            mins = [(x["seconds_generate"] + x["seconds_diagnose"]) / 60 for x in (c, d)]
            print(
                f"| {c['truth']} | {c['magnitude']} | {c['seed']} | {_truth_cell(c)} | "
                f"{_truth_cell(d)} | {mins[0]:.0f}, {mins[1]:.0f} |"
            )
        for label, i in (("prior width", 0), ("estimated width", 1)):
            cs = [x[i] for x in both]
            mod = [c for c in cs if c["truth"] != "none"]
            non = [c for c in cs if c["truth"] == "none"]
            print(
                f"\n{label}: top-1 {_pct(sum(c['correct'] for c in mod), len(mod))} of the "
                f'effects, "none" right {_pct(sum(c["correct"] for c in non), len(non))}'
                + (f" ({len(both)} of {len(a['cases'])} cases rerun)" if i else "")
            )


if __name__ == "__main__":
    import sys

    roots = [Path(a) for a in sys.argv[1:]] or [HERE, STEPS]
    main(*roots)
    widths(roots[0])
