"""How much of the default base's benchmark misses is the kinematic error: a dose-response.

    python benchmarks/diagnosis_noise.py --level 0      # exact kinematics
    python benchmarks/diagnosis_noise.py --level 0.5    # half the default marker noise and drift
    python benchmarks/diagnosis_noise.py --report-only  # write diagnosis_noise_output.md

The withheld-effect benchmark of the registered base (``benchmarks/diagnosis_blind.py``) misses
weak effects (every miss answers "none"). This reruns the same cases (same seeds, so the same
truth values and plate noise: a paired comparison) with the kinematic error the fitter sees
scaled by ``level`` (marker noise, soft-tissue drift), everything else unchanged (plate noise
0.5 % BW, 20 N threshold, truth law differences). If accuracy rises towards the target as the
kinematic error falls, the misses are an identifiability limit of the data (errors in
variables: the effect's signature is smaller than what marker noise and drift do to the
predicted wrench on a held-out stance), not of the decision rule. Level 1 is the main run,
read from ``diagnosis_blind/registered``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from gc_ocp.bench import withheld as benchmark

HERE = Path(__file__).parent
OUT = HERE / "diagnosis_blind"
MAIN = OUT / "registered" / "confusion.json"


def _dir(level: float) -> Path:
    return OUT / f"noise_{level:g}".replace(".", "p")


def _rates(cases: list[dict], truths: list[str]) -> dict:
    """Per truth: (right, cases); and the effect cases' top-1 over ``truths``."""
    out = {}
    for t in [*truths, benchmark.NONE]:
        cs = [c for c in cases if c["truth"] == t]
        out[t] = (sum(c["correct"] for c in cs), len(cs))
    eff = [c for c in cases if c["truth"] in truths]
    out["effects"] = (sum(c["correct"] for c in eff), len(eff))
    return out


def report() -> str:
    main = json.loads(MAIN.read_text())
    runs = {1.0: main}
    for p in sorted(OUT.glob("noise_*/confusion.json")):
        r = json.loads(p.read_text())
        level = r["settings"]["realism"]["marker_noise"] / benchmark.Realism().marker_noise
        runs[round(level, 3)] = r
    levels = sorted(runs)
    truths = [t for t in main["settings"]["candidates"]]
    # only the truths every level ran (the ablation runs a subset)
    ran = set.intersection(*({c["truth"] for c in r["cases"]} for r in runs.values()))
    truths = [t for t in truths if t in ran]
    rates = {lv: _rates(runs[lv]["cases"], truths) for lv in levels}
    base = main["settings"]["realism"]
    lines = [
        "# Kinematic error and the default base's misses (`benchmarks/diagnosis_noise.py`)",
        "",
        "The registered base's withheld-effect cases rerun with the fitter's kinematic error "
        f"scaled (level 1 = the benchmark's: marker noise {base['marker_noise'] * 1e3:g} mm, "
        f"drift {base['drift_translation'] * 1e3:g} mm / {base['drift_rotation_deg']:g} deg "
        "per axis); same case seeds, so the same truths and plate noise. Right / cases:",
        "",
        "| truth | " + " | ".join(f"level {lv:g}" for lv in levels) + " |",
        "|---|" + "---|" * len(levels),
    ]
    for t in [*truths, benchmark.NONE, "effects"]:
        cells = []
        for lv in levels:
            k, n = rates[lv][t]
            cells.append(f"{k}/{n}" + (f" ({100 * k / n:.0f} %)" if n else ""))
        name = "**effect cases**" if t == "effects" else t
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines += ["", "Truth's held-out reduction [95 % CI] per case and level:", ""]
    lines += [
        "| truth | magnitude | seed | " + " | ".join(f"level {lv:g}" for lv in levels) + " |",
        "|---|---|---|" + "---|" * len(levels),
    ]
    by = {
        lv: {(c["truth"], c["magnitude"], c["seed"]): c for c in runs[lv]["cases"]} for lv in levels
    }
    for key in sorted(by[levels[0]]):
        if key[0] not in truths:
            continue
        cells = []
        for lv in levels:
            c = by[lv].get(key)
            row = c and next((r for r in c["ranking"] if r["effect"] == key[0]), None)
            if row is None:
                cells.append("-")
                continue
            lo, hi = row["heldout_rms_reduction_ci"]
            mark = "" if c["correct"] else " ✗"
            cells.append(f"{row['heldout_rms_reduction_pct']:+.1f} [{lo:+.1f}, {hi:+.1f}]{mark}")
        lines.append(f"| {key[0]} | {key[1]} | {key[2]} | " + " | ".join(cells) + " |")
    lines += ["", "✗: the case's answer was wrong."]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--level", type=float, default=0.0)
    ap.add_argument(
        "--effects",
        default="damping,toe_joint,ground_offset,time_offset,friction,none",
        help="truths to rerun (default: those the main run missed, and none)",
    )
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--report-only", action="store_true")
    a = ap.parse_args(argv)
    if not a.report_only:
        r0 = benchmark.Realism()
        realism = dataclasses.replace(
            r0,
            marker_noise=r0.marker_noise * a.level,
            drift_translation=r0.drift_translation * a.level,
            drift_rotation_deg=r0.drift_rotation_deg * a.level,
        )
        out = _dir(a.level)
        res = benchmark.run_benchmark(
            out,
            base="registered",
            effects=a.effects.split(","),
            seeds=a.seeds,
            realism=realism,
            resume=a.resume,
            progress=lambda s: print(s, flush=True),
            workers=1,
        )
        print(f"level {a.level:g}: top-1 {res['summary']['top1_accuracy']}")
    text = report()
    (HERE / "diagnosis_noise_output.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
