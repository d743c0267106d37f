"""The sim-to-real diagnosis on the shared real trials, and a nested confirmation of what it selects.

Usage::

    PYTHONPATH=. python benchmarks/diagnosis_real.py                  # every trial (~1 h on 2 cores)
    PYTHONPATH=. python benchmarks/diagnosis_real.py --trials plugingait rajagopal
    PYTHONPATH=. python benchmarks/diagnosis_real.py --report         # markdown from the cache only

For every trial that loads with the shipped marker sets (the bundled Plug-in Gait example, the
OpenSim Rajagopal and Gait2392 trials of ``../shared/data`` as the tests load them, and the two
Vicon Plug-in Gait trials of BTKData):

1. **Diagnosis**: ``gc_ocp.diagnose`` on all stances of the trial (base ``registered``, every
   candidate effect): the ranking, the forward selection and its waterfall, the held-out
   superior-force RMS of the final model. A trial whose feet have a single stance each (the
   treadmill trial) has no held-out stance: the diagnosis falls back to in-sample scores with a
   BIC penalty and says so.
2. **Nested confirmation**: the shared trials are single trials of different subjects (no
   second trial of the same subject loads with the shipped marker sets), with three stances at
   most, two of one foot. So the confirmation holds one of those two stances out of the
   *diagnosis itself*: the diagnosis is run on the other two stances (one per foot: in-sample
   with the BIC penalty, the only score two stances allow), then the base and the base plus what
   that diagnosis selected (cumulatively, in its order) are fitted on those two stances and
   scored on the stance the selection never saw by `confirm_stances` (held-out score with the nuisance prior and
   Occam terms, paired block bootstrap within the stance). Done for each of the two stances in
   turn. In-sample, nearly every effect passes, so that diagnosis stops after
   :data:`CONFIRM_MAX_EFFECTS` effects. The full diagnosis's own per-stance reductions are printed beside it, but they are not
   independent of the selection (that stance was one of its folds).

Each trial's result is cached as JSON in ``--cache`` (default ``benchmarks/diagnosis_real/``) so
the markdown (stdout) can be rebuilt (``--report``) and a trial rerun alone; a cached diagnosis is
reused (only the confirmation is redone) unless ``--fresh``. ``--no-nested`` skips step 2's
nested confirmations (each a further diagnosis per held-out stance; a compute budget), not the
BTS subject's confirmation on its other trials.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

TRIALS = (
    "plugingait",
    "rajagopal",
    "gait2392",
    "vicon_btk",
    "vicon_clusters",
    "helen_hayes",
    "type2",
    "camargo",
    "bts_subject",
)
DESCRIPTION = {
    "plugingait": "bundled example (Plug-in Gait, Vicon; 63.6 kg)",
    "rajagopal": "OpenSim Rajagopal overground (TRC + MOT; 85.07 kg)",
    "gait2392": "OpenSim Gait2392 treadmill (TRC + MOT; 72.6 kg)",
    "vicon_btk": "BTKData PiG_Motion3_FF (Plug-in Gait, Vicon Nexus; 74 kg)",
    "vicon_clusters": "BTKData FunctionalWalk (Plug-in Gait + clusters, Vicon; 60 kg)",
    "helen_hayes": "Motion Analysis Gait.c3d (Helen Hayes; mass estimated)",
    "type2": "c3d.org type-2a.c3d (Helen Hayes, type-2 plates; mass estimated; type-4a holds "
    "the same raw data)",
    "camargo": "Camargo et al. level-ground circuit (OpenSim TRC + MOT, 6 plates, turns; "
    "mass estimated)",
    "bts_subject": "BTS, one subject: diagnosis on Walking1-3 together, confirmed on "
    "Walking4-5 (anatomical markers, Y up; mass estimated)",
}
DATA = ROOT.parent / "shared" / "data"
FILES = {
    "vicon_btk": ["vicon_plugingait_btk/PiG_Motion3_FF.c3d"],
    "vicon_clusters": ["vicon_plugingait_clusters/FunctionalWalk.c3d"],
    "helen_hayes": ["motionanalysis_helenhayes/Gait.c3d"],
    "type2": ["c3dorg_helenhayes_types/type-2a.c3d"],
    "camargo": ["camargo_opensim_circuit/levelground_ccw_fast_01_01.trc"],
    "bts_subject": [f"bts_unipd_5trials/Walking{k}.c3d" for k in (1, 2, 3)],
}
"""Files of each trial (loaded with nothing but the path: landmarks recognised, plates and mass
read or estimated, a TRC paired with its MOT)."""
CONFIRM_FILES = {"bts_subject": [f"bts_unipd_5trials/Walking{k}.c3d" for k in (4, 5)]}
"""Other trials of the same subject, never used by the diagnosis: its selection is confirmed on
them (:func:`gc_ocp.diagnosis.confirm`)."""
CONFIRM_MAX_EFFECTS = 2
"""Effects the two-stance (in-sample) diagnosis of the confirmation may select: in-sample with a
BIC penalty nearly every effect passes, and the full diagnoses select one or two."""


def _pairs(files) -> list:
    """Trials loaded as ``gc-ocp`` loads them: a TRC paired with its MOT/STO (``pair_trials``)."""
    from gc_ocp.io import load_trial
    from gc_ocp.io.pairing import pair_trials
    from gc_ocp.kinematics import compute_kinematics

    out = []
    for p in pair_trials([DATA / f for f in files]):
        t = load_trial(p.trial, p.grf)
        out.append((t, compute_kinematics(t)))
    return out


def load(name: str) -> list:
    """``[(Trial, TrialKinematics), ...]`` of a named trial (several for a subject); the first
    three as the tests load them."""
    if name in ("plugingait", "rajagopal", "gait2392"):
        from test_estimation import _real

        return [_real(name)]
    return _pairs(FILES[name])


def _jsonable(o):
    if isinstance(o, dict):
        return {str(k): _jsonable(v) for k, v in o.items()}
    if isinstance(o, list | tuple):
        return [_jsonable(v) for v in o]
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return o


def confirm(stances, holdout: int, candidates, say, null: dict | None = None) -> dict:
    """Diagnose ``stances`` without ``stances[holdout]``, then score base vs base + each cumulative
    selection on that stance (trained on the others). ``null``: the diagnosis's keyword for its
    null's family (``--plate-calibration``), or none (its default)."""
    from gc_ocp.diagnosis import confirm_stances, diagnose_stances

    held = stances[holdout]
    subset = [s for k, s in enumerate(stances) if k != holdout]
    say(f"confirmation: diagnosing without {held.label} ({len(subset)} stances)")
    d = diagnose_stances(
        subset, candidates=candidates, max_effects=CONFIRM_MAX_EFFECTS, progress=say, **(null or {})
    )
    c = confirm_stances(subset, [held], d.selected, progress=say)
    return {
        "heldout": held.label,
        "diagnosed_on": [s.label for s in subset],
        "folds": d.folds["kind"],
        "selected": d.selected,
        "ranking": [
            {
                k: r.to_json()[k]
                for k in (
                    "effect",
                    "heldout_rms_reduction_pct",
                    "heldout_rms_reduction_ci",
                    "passes",
                )
            }
            for r in d.ranking
        ],
        "steps": c["steps"],
        "seconds": d.seconds,
    }


def _same_null(path: Path, diagnosis: dict, null: dict | None) -> None:
    """Refuse a cached diagnosis whose null had the plate calibration member when this run's has
    not, or the other way round (its ``mismatch_family``; absent: made without it), which would
    mix the two nulls in one study."""
    from gc_ocp.diagnosis.mismatch import MismatchFamily

    fam = diagnosis.get("mismatch_family")
    cached = fam is not None and MismatchFamily.from_json(fam).plate_calibration
    wanted = null is not None and null["mismatch"].plate_calibration
    if cached != wanted:
        raise SystemExit(
            f"{path}: its diagnosis's null was made {'with' if cached else 'without'} the plate "
            f"calibration member, this run's is {'with' if wanted else 'without'} it: give "
            "another --cache, or --fresh to rerun it."
        )


def run(
    name: str,
    cache: Path,
    candidates,
    say,
    max_effects: int | None = None,
    nested: bool = True,
    null: dict | None = None,
) -> dict:
    from gc_ocp.diagnosis import diagnose
    from gc_ocp.workflow.fitting import fit_data

    t0 = time.perf_counter()
    path = cache / f"{name}.json"
    cache.mkdir(parents=True, exist_ok=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # heights estimated from markers (OpenSim): in the notes
        tk = load(name)
        if path.exists():  # the diagnosis is reused; the confirmation is redone
            out = json.loads(path.read_text())
            _same_null(path, out["diagnosis"], null)
            say(f"== {name}: diagnosis read from {path}")
        else:
            say(f"== {name}: diagnosis on all stances")
            d = diagnose(
                tk, candidates=candidates, max_effects=max_effects, progress=say, **(null or {})
            )
            say(d.summary())
            out = {"trial": name, "description": DESCRIPTION[name], "diagnosis": d.to_json()}
            out["summary"] = d.summary()
            out["diagnosis_seconds"] = d.seconds
            out["max_effects"] = max_effects
            path.write_text(json.dumps(_jsonable(out), indent=1))
        if name in CONFIRM_FILES:  # other trials of the subject: confirm on them
            from gc_ocp.diagnosis import confirm as confirm_trials

            new = _pairs(CONFIRM_FILES[name])
            c = confirm_trials(tk, new, out["diagnosis"]["selected"], progress=say)
            out["confirmation"] = []
            out["confirmation_trials"] = c
        elif not nested:  # --no-nested: the confirmation is not run (a compute budget)
            out["confirmation"] = None
        else:
            _, stances, _ = fit_data(tk)
            sides = [s.side for s in stances]
            conf = []
            for i, s in enumerate(sides):
                if sides.count(s) >= 2:
                    conf.append(confirm(stances, i, candidates, say, null))
            out["confirmation"] = conf
    out["confirmation_seconds"] = time.perf_counter() - t0
    path.write_text(json.dumps(_jsonable(out), indent=1))
    return out


def _ci(ci) -> str:
    return f"[{ci[0]:+.1f}, {ci[1]:+.1f}]"


def _p(row: dict) -> str:
    """`` p 0.012`` for a ranking row with the calibrated test, else nothing."""
    c = row.get("calibrated")
    return f" p {c['p_adjusted']:.3f}" if c else ""


def _with_previous(results: list[dict], previous: Path):
    """``(result, earlier diagnosis)`` for every trial of ``results`` that the cache
    ``previous`` of an earlier run also has."""
    for r in results:
        path = previous / f"{r['trial']}.json"
        if path.exists():
            yield r, json.loads(path.read_text())["diagnosis"]


def changes(results: list[dict], previous: Path) -> list[str]:
    """Markdown: per trial, the answer of the run in ``previous`` (a cache of an earlier run)
    beside this one's, and this run's verdict on each effect the earlier one selected."""
    from gc_ocp.diagnosis.result import RankRow

    lines = [
        "## What changed against the earlier run",
        "",
        f"Earlier run: the cache in `{previous}`. Verdicts are this run's (round 1).",
        "",
        "| trial | earlier: selected (final superior % BW) | now: selected (final) "
        "| now, on each earlier selection |",
        "|---|---|---|---|",
    ]
    earlier = list(_with_previous(results, previous))
    for r, old in earlier:
        new = r["diagnosis"]
        rows = {x["effect"]: x for x in new["ranking"]}

        def answer(d):
            fin = d["waterfall"][-1]["heldout_superior_force_pct_bw"]
            return f"{', '.join(d['selected']) or 'none'} ({fin:.2f})"

        why = "; ".join(
            f"{e}: {RankRow.from_json(rows[e]).verdict()}" for e in old["selected"] if e in rows
        )
        lines.append(f"| {r['trial']} | {answer(old)} | {answer(new)} | {why or '-'} |")
    return lines + [""] + steps_changes(earlier)


def steps_changes(earlier: list[tuple[dict, dict]]) -> list[str]:
    """Markdown: per trial (``earlier``: this run's result and the earlier run's diagnosis, as
    :func:`_with_previous` gives them), every round-1 candidate the rule does not name in both
    runs, with the further held-out stances that would decide it (the rule's: the test's and the
    effect-size floor's, the larger; recomputed from each row as ``withheld_sizes.py`` does, so
    rows written before the floor's number read alike, under today's floor) in the earlier run
    and in this one ("named" where a run's rule named it), and
    the part of the null's between-draw spread every stance shares where this run made the
    split (``null_sd_systematic_pct`` of ``null_sd_mismatch_pct``)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from withheld_sizes import rule_stances  # isort: skip (a script beside this one)

    from gc_ocp.diagnosis.selection import MIN_REDUCTION_PCT

    def steps(row) -> str:
        if row is None or not row.get("calibrated"):
            return "-"
        if row["passes"]:
            return "named"
        need = rule_stances(row)
        return "undecidable" if need is None else f"{need} more"

    lines = [
        "### The further steps that would decide, earlier and now (round 1)",
        "",
        "Held-out stances (for a subject with more steps per foot, about as many steps). "
        "'undecidable': no number of steps would at the observed gains. Shared part: the "
        "null's between-draw SD every stance shares, of all of it (% points of reduction). "
        f"Both runs' steps under today's effect-size floor ({MIN_REDUCTION_PCT:g} %).",
        "",
        "| trial | effect | p (now) | held out (now) | earlier | now | shared part of the spread |",
        "|---|---|---|---|---|---|---|",
    ]
    for r, diagnosis in earlier:
        old = {x["effect"]: x for x in diagnosis["ranking"]}
        for row in r["diagnosis"]["ranking"]:
            c = row.get("calibrated")
            if not c or (row["passes"] and old.get(row["effect"], {}).get("passes")):
                continue
            split = c.get("null_sd_systematic_pct")
            shared = (
                "no split"
                if split is None
                else f"{split:.2f} of {c.get('null_sd_mismatch_pct', float('nan')):.2f}"
            )
            pct = row["heldout_rms_reduction_pct"]
            held = "-" if pct is None else f"{pct:+.1f} {_ci(row['heldout_rms_reduction_ci'])}"
            lines.append(
                f"| {r['trial']} | {row['effect']} | {c['p_adjusted']:.3f} | {held} "
                f"| {steps(old.get(row['effect']))} | {steps(row)} | {shared} |"
            )
    return lines + [""]


def _steps_cells(steps: list[dict]) -> tuple[str, str]:
    """A confirmation's held-out superior RMS per step (``base 2.4 → +x 2.1``) and its total
    reduction with the interval."""
    chain = " → ".join(f"{s['model']} {s['heldout_superior_force_pct_bw']:.2f}" for s in steps)
    last = steps[-1]
    tot = (
        f"{last['total_reduction_pct']:+.1f} {_ci(last['total_reduction_ci'])}"
        if "total_reduction_pct" in last
        else "(nothing selected)"
    )
    return chain, tot


def markdown(results: list[dict]) -> str:
    lines = ["# The sim-to-real diagnosis on real walking (`benchmarks/diagnosis_real.py`)", ""]
    lines += [
        "Base `registered` (seed law with k per unit and a fitted mu; sole and pose "
        "registration; belt speed on the treadmill). Reductions are of the held-out combined "
        "score (all six channels, nuisance prior and Occam terms), with the 95 % paired block "
        "bootstrap interval, and the calibrated test's family-wise adjusted p-value (`p`; a "
        "diagnosis written before the calibrated test has none). PASS (bold) = the rule of the "
        "run names it (`docs/diagnosis.md`, *Decision rule*: the calibrated test at 5 % and the "
        "effect-size floor of the run). Superior RMS: held-out superior force, both feet "
        "pooled, % BW.",
        "",
        "## Diagnosis per trial",
        "",
        "| trial | folds | top 3 (reduction %, 95 % CI, p) | selected | waterfall (superior % BW) "
        "| final |",
        "|---|---|---|---|---|---|",
    ]
    for r in results:
        d = r["diagnosis"]
        top = "; ".join(
            f"{'**' if x['passes'] else ''}{x['effect']}{'**' if x['passes'] else ''} "
            f"{x['heldout_rms_reduction_pct']:+.1f} {_ci(x['heldout_rms_reduction_ci'])}"
            + _p(x)
            + (f" (conf. {', '.join(x['confounded_with'])})" if x["confounded_with"] else "")
            for x in d["ranking"][:3]
        )
        wf = " → ".join(
            f"{w['model']} {w['heldout_superior_force_pct_bw']:.2f}" for w in d["waterfall"]
        )
        folds = f"{d['folds']['kind']}, {d['folds']['n']}"
        sel = ", ".join(d["selected"]) or "none"
        fin = d["waterfall"][-1]["heldout_superior_force_pct_bw"]
        lines.append(f"| {r['trial']} | {folds} | {top} | {sel} | {wf} | {fin:.2f} |")
    lines += ["", "Bold: passes the decision rule in round 1.", ""]
    lines += ["## Full rankings (round 1) and later rounds", ""]
    for r in results:
        d = r["diagnosis"]
        lines += [
            f"### {r['trial']}: {r['description']}",
            "",
            f"Stances {', '.join(d['folds']['stances'])}; held out in turn: "
            f"{', '.join(d['folds']['heldout']) or 'none'}; diagnosis {d['seconds']:.0f} s, "
            f"confirmation {r.get('confirmation_seconds', float('nan')):.0f} s.",
            "",
            "```text",
            r["summary"],
            "```",
            "",
        ]
        if d["ranking"] and "gain_from_nuisance" not in d["ranking"][0]:
            lines += [
                "(Run before `gain_from_nuisance` and the nuisance-confounding label existed; "
                "the ranking, intervals and selection do not depend on them.)",
                "",
            ]
        for k, rows in enumerate(d["rounds"][1:], start=2):
            lines.append(
                f"Round {k} (on top of {', '.join(d['selected'][: k - 1])}): "
                + "; ".join(
                    f"{x['effect']} in-sample {x['insample_rms_reduction_pct']:+.1f} (screened)"
                    if x["heldout_rms_reduction_pct"] is None
                    else f"{x['effect']} {x['heldout_rms_reduction_pct']:+.1f} "
                    f"{_ci(x['heldout_rms_reduction_ci'])}{' PASS' if x['passes'] else ''}"
                    for x in rows
                )
            )
            lines.append("")
        if d["ranking"] and d["folds"]["n"]:
            lines.append(
                "Round-1 reduction per held-out stance (not independent of the selection):"
            )
            lines.append("")
            for x in d["ranking"]:
                per = ", ".join(f"{k} {v:+.1f}" for k, v in x["per_stance_reduction_pct"].items())
                lines.append(f"* {x['effect']}: {per}")
            lines.append("")
    lines += ["## Nested confirmation", ""]
    lines += [
        "Diagnosis on two stances (one per foot; in-sample with the BIC penalty), then base vs "
        "base + the selected effects (cumulative) trained on those two and scored on the third "
        "stance, which the selection never saw.",
        "",
        "| trial | held out | selected without it | held-out superior % BW (base → ...) "
        "| reduction on it, total (95 % CI) |",
        "|---|---|---|---|---|",
    ]
    for r in results:
        if "confirmation_trials" in r:
            c = r["confirmation_trials"]
            steps, tot = _steps_cells(c["steps"])
            lines.append(
                f"| {r['trial']} | other trials: {len(c['test'])} stances "
                f"({', '.join(c['test'])}) | {', '.join(c['selected']) or 'none'} | {steps} "
                f"| {tot} |"
            )
            continue
        if r["confirmation"] is None:
            lines.append(f"| {r['trial']} | not run (`--no-nested`) | | | |")
            continue
        if not r["confirmation"]:
            lines.append(f"| {r['trial']} | none | not possible: one stance per foot | | |")
            continue
        for c in r["confirmation"]:
            steps, tot = _steps_cells(c["steps"])
            per_step = "; ".join(
                f"{s['model']} {s['step_reduction_pct']:+.1f} {_ci(s['step_reduction_ci'])}"
                for s in c["steps"][1:]
            )
            sel = ", ".join(c["selected"]) or "none"
            lines.append(
                f"| {r['trial']} | {c['heldout']} | {sel} | {steps} | {tot}"
                + (f" (steps: {per_step})" if len(c["steps"]) > 2 else "")
                + " |"
            )
    lines.append("")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", nargs="*", default=list(TRIALS), choices=TRIALS)
    ap.add_argument("--candidates", nargs="*", default=None, help="default: every effect")
    ap.add_argument("--cache", type=Path, default=ROOT / "benchmarks" / "diagnosis_real")
    ap.add_argument("--report", action="store_true", help="only rebuild the markdown from --cache")
    ap.add_argument(
        "--max-effects",
        type=int,
        default=None,
        help="stop the forward selection after that many effects (compute budget)",
    )
    ap.add_argument("--fresh", action="store_true", help="rerun the diagnoses found in --cache")
    ap.add_argument(
        "--no-nested",
        action="store_true",
        help="skip the nested confirmation of single trials (a diagnosis per held-out stance)",
    )
    ap.add_argument(
        "--previous",
        type=Path,
        default=None,
        help="a cache of an earlier run: also print what changed against it",
    )
    ap.add_argument(
        "--plate-calibration",
        action="store_true",
        help="the null's mismatch family with its plate calibration member (gc-ocp diagnose "
        "--plate-calibration)",
    )
    args = ap.parse_args()
    null = None
    if args.plate_calibration:
        from gc_ocp.diagnosis.null import DEFAULT_FAMILY

        null = {"mismatch": DEFAULT_FAMILY.with_plate_calibration()}

    def say(s):
        print(s, file=sys.stderr, flush=True)

    results = []
    for name in args.trials:
        path = args.cache / f"{name}.json"
        if args.report:
            if path.exists():
                results.append(json.loads(path.read_text()))
            continue
        if args.fresh and path.exists():
            path.unlink()
        results.append(
            run(name, args.cache, args.candidates, say, args.max_effects, not args.no_nested, null)
        )
    print(markdown(results))
    if args.previous is not None:
        print("\n".join(changes(results, args.previous)))


if __name__ == "__main__":
    main()
