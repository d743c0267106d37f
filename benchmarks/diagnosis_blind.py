"""The withheld-effect benchmark of the diagnosis on both bases, and its report.

    python benchmarks/diagnosis_blind.py [--seeds 3] [--report-only]

runs ``gc-ocp benchmark-diagnosis`` for the default base (``registered``: seven candidates) and
the bare seed base (``seed``: all nine), into ``benchmarks/diagnosis_blind/{base}/`` (each
``confusion.json`` is rewritten after every case: ``--resume`` continues a run), then writes
``benchmarks/diagnosis_blind_output.md`` and ``diagnosis_blind/confusion_{base}.png`` from the
``confusion.json`` files (runs of other seeds merged). The two bases can run
as two processes (``--bases registered`` and ``--bases seed``, then ``--report-only``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from gc_ocp.diagnosis import benchmark

HERE = Path(__file__).parent
OUT = HERE / "diagnosis_blind"


def _case_lines(res: dict) -> list[str]:
    """Every wrong case: truth, answer, the answer's and the truth's held-out reductions."""
    lines = []
    for c in res["cases"]:
        if c["correct"]:
            continue
        rows = {r["effect"]: r for r in c["ranking"]}
        a, t = rows.get(c["answer"]), rows.get(c["truth"])

        def fmt(r):
            lo, hi = r["heldout_rms_reduction_ci"]
            return f"{r['heldout_rms_reduction_pct']:+.1f} % [{lo:+.1f}, {hi:+.1f}]"

        lines.append(
            f"| {c['truth']} | {c['magnitude']} | {c['seed']} | {c['answer']} | "
            f"{fmt(a) if a else '-'} | {fmt(t) if t else '-'} | "
            f"{', '.join(c['confounded_with']) or '-'} |"
        )
    return lines


RULES = {
    "current (held-out >= 2 %, CI lower bound > 0; best held-out)": (
        lambda r: r["heldout_rms_reduction_pct"] >= 2.0 and r["heldout_rms_reduction_ci"][0] > 0,
        "heldout_rms_reduction_pct",
    ),
    "current + in-sample >= 2 % (made: diagnose.py)": (
        lambda r: (
            r["heldout_rms_reduction_pct"] >= 2.0
            and r["heldout_rms_reduction_ci"][0] > 0
            and r["insample_rms_reduction_pct"] >= 2.0
        ),
        "heldout_rms_reduction_pct",
    ),
    "proposed (in-sample >= 3 % and held-out > 0; best in-sample)": (
        lambda r: r["insample_rms_reduction_pct"] >= 3.0 and r["heldout_rms_reduction_pct"] > 0,
        "insample_rms_reduction_pct",
    ),
}
"""Decision rules replayed on the stored rankings (no refit): the library's and a proposal
(``docs/diagnosis.md (withheld-effect benchmark)``: its 3 % is above the largest in-sample gain of any candidate
on the "none" cases of seeds 0-2, 2.6 %; seeds 3-4 were run after it was chosen)."""


def replay(res: dict, rule, seeds) -> tuple[int, int, int, int]:
    """(effect cases right, effect cases, none cases right, none cases) under ``rule``."""
    ok, key = rule
    ce = ne = cn = nn = 0
    for c in res["cases"]:
        if c["seed"] not in seeds and c["truth"] != benchmark.NONE:
            continue
        if c["truth"] == benchmark.NONE and c["seed"] // 2 not in seeds:
            continue
        passing = [r for r in c["ranking"] if ok(r)]
        answer = max(passing, key=lambda r: r[key])["effect"] if passing else benchmark.NONE
        if c["truth"] == benchmark.NONE:
            nn, cn = nn + 1, cn + (answer == benchmark.NONE)
        else:
            ne, ce = ne + 1, ce + (answer == c["truth"])
    return ce, ne, cn, nn


def replay_lines(results: dict[str, dict]) -> list[str]:
    out = [
        "## Decision rules replayed on the stored rankings",
        "",
        "| base | rule | seeds | top-1 | none rejected |",
        "|---|---|---|---|---|",
    ]
    for base, res in results.items():
        seeds = sorted({c["seed"] for c in res["cases"] if c["truth"] != benchmark.NONE})
        groups = [("0-2", [s for s in seeds if s < 3]), ("3-4", [s for s in seeds if s >= 3])]
        for name, rule in RULES.items():
            for label, ss in groups:
                if not ss:
                    continue
                ce, ne, cn, nn = replay(res, rule, set(ss))
                out.append(
                    f"| {base} | {name} | {label} | {ce}/{ne} = {100 * ce / max(ne, 1):.0f} % | "
                    f"{cn}/{nn} |"
                )
    return out + [""]


def report(results: dict[str, dict]) -> str:
    out = [
        "# Withheld-effect benchmark of the diagnosis (`benchmarks/diagnosis_blind.py`)",
        "",
        "Truth = the registered base fitted to the bundled trial's three real stances, frozen, plus "
        "one effect (or none) at a known value; marker noise 0.5 mm, soft-tissue drift 2 mm / "
        "0.5 deg per axis (per-foot pattern, 25 % stride-to-stride variation; registered base, "
        "and the seed base's kinematic_correction cases), plate noise 0.5 % BW, plate wrench "
        "zeroed below 20 N. `diagnose_stances(max_effects=1)` blind; top-1 = first selected "
        "effect or none. Settings and values: `gc_ocp/diagnosis/benchmark.py`; discussion: "
        "`docs/diagnosis.md (withheld-effect benchmark)`. The runs (split by seed into parallel processes, merged "
        "here) used the decision rule before the in-sample guard and the tie flag; both are "
        "replayed at the end on the stored rankings.",
        "",
    ]
    for base, res in results.items():
        out += [f"## base `{base}`", "", benchmark.markdown(res), ""]
        per = res["summary"]["per_truth_and_magnitude"]
        out += ["| truth | " + " | ".join(benchmark.MAGNITUDES) + " |", "|---|---|---|"]
        for t, m in per.items():
            cells = [
                "-" if m.get(k) is None else f"{100 * m[k]:.0f} %" for k in benchmark.MAGNITUDES
            ]
            if t == benchmark.NONE:
                cells = [f"{100 * m['-']:.0f} %", ""]
            out.append(f"| {t} | " + " | ".join(cells) + " |")
        wrong = _case_lines(res)
        out += ["", f"Wrong answers ({len(wrong)}):", ""]
        if wrong:
            out += [
                "| truth | magnitude | seed | answer | answer's reduction [95 % CI] | truth's "
                "reduction | answer confounded with |",
                "|---|---|---|---|---|---|---|",
                *wrong,
            ]
        sec = res["seconds"]
        n = max(1, res["summary"]["n_cases"])
        out += [
            "",
            f"Time: {sec['cases_total'] / 60:.0f} min of case time, {sec['cases_total'] / n:.0f} s "
            "per case (2 shared cores, other jobs running).",
            "",
        ]
    out += replay_lines(results)
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--bases", default="registered,seed")
    ap.add_argument("--report-only", action="store_true")
    ap.add_argument("--resume", action="store_true")
    a = ap.parse_args(argv)
    bases = [b for b in a.bases.split(",") if b]
    if not a.report_only:
        for base in bases:
            res = benchmark.run_benchmark(
                OUT / base,
                base=base,
                seeds=a.seeds,
                resume=a.resume,
                progress=lambda s: print(s, file=sys.stderr, flush=True),
            )
            print(benchmark.report(res))
    results = {}
    for b in ("registered", "seed"):
        # the base's folder and any split runs beside it (e.g. registered_seed2)
        found = sorted(OUT.glob(f"{b}*/confusion.json"))
        if found:
            results[b] = benchmark.merge([json.loads(f.read_text()) for f in found])
    (HERE / "diagnosis_blind_output.md").write_text(report(results))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    for b, res in results.items():
        fig = benchmark.confusion_figure(res)
        fig.savefig(OUT / f"confusion_{b}.png", dpi=120)
        plt.close(fig)
    print(f"wrote {HERE / 'diagnosis_blind_output.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
