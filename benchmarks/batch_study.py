"""A study on Dask against a loop of ``gc-ocp fit`` commands (issue 24): every usable trial of
``../shared/data``, one subject per folder.

Usage::

    PYTHONPATH=. python benchmarks/batch_study.py [--work DIR] [--skip-loop]

1. **The manifest** (``DIR/study.csv``, printed): one subject per data folder, every walking
   trial of the folder (the BTS subject's five together, with its static trial; type-4a left
   out: it holds type-2a's data), with what the files lack: the OpenSim subjects' mass (their
   README) and a treadmill's belt speed (a folder whose stance feet move back faster than
   :data:`TREADMILL_SPEED`, measured from its markers by :func:`gc_ocp.io.estimate_belt_speed`,
   as a user would read it off the treadmill).
2. **The batch** with 1 and with 2 workers (``gc_ocp.batch.run``, a local cluster), each into a
   fresh output folder (no kinematics cached): wall time, the time per subject, the peak memory
   of each worker process.
3. **The loop**: one ``gc-ocp fit`` command per subject, one after the other (a fresh process
   each, as a shell loop runs them), with the same trials and values: wall time.

The same fits in all three (default settings, the held-out stance chosen as the batch chooses
it, ``holdout=auto``). Each measurement is one run on this machine: read the ratios.
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
MASS = {"opensim_rajagopal_overground": 85.07, "opensim_gait2392_treadmill": 72.6}
"""[kg] Masses the OpenSim files do not carry (the data README: their scale set-ups)."""
TREADMILL_SPEED = 0.3
"""[m/s] A stance foot moving back faster than this (mid-stance mean) walks on a belt."""
LEAVE_OUT = {"type-4a.c3d": "the same raw data as type-2a.c3d (type-4 plates)"}


def manifest(path: Path) -> list[dict]:
    """Write the study's CSV manifest (module doc) and return its rows."""
    from gc_ocp.batch.manifest import TRIAL_SUFFIXES, is_static
    from gc_ocp.io import estimate_belt_speed, load_trial
    from gc_ocp.io.pairing import pair_trials

    rows = []
    for folder in sorted(p for p in DATA.iterdir() if p.is_dir()):
        files = sorted(
            p
            for p in folder.iterdir()
            if p.suffix.lower() in TRIAL_SUFFIXES and p.name not in LEAVE_OUT
        )
        statics = [p for p in files if is_static(p)]
        walks = [p for p in files if p not in statics]
        if not walks:
            continue
        sid = folder.name
        pair = pair_trials(walks[:1])[0]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            speed, _ = estimate_belt_speed(load_trial(pair.trial, pair.grf, mass=MASS.get(sid)))
        # the stance foot stands still overground and moves back with a belt
        belt = speed if speed > TREADMILL_SPEED else None
        for k, w in enumerate(walks):
            rows.append(
                {
                    "subject": sid,
                    "trial": str(w),
                    "static": str(statics[0]) if statics and k == 0 else "",
                    "mass": MASS.get(sid, "") if k == 0 else "",
                    "belt_speed": f"{belt:.3f}" if belt is not None and k == 0 else "",
                }
            )
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return rows


def batch(study: Path, out: Path, workers: int) -> dict:
    from gc_ocp.batch import run

    t0 = time.perf_counter()
    res = run(study, out, workers=workers, progress=lambda s: print(s, file=sys.stderr))
    wall = time.perf_counter() - t0
    return {
        "wall": wall,
        "subjects": res.subjects,
        "counts": res.counts(),
        "peak_mb": max((s["peak_rss_mb"] or 0.0) for s in res.subjects),
    }


def loop(study: Path, out: Path) -> dict:
    """One ``gc-ocp fit`` per subject, the manifest's values as options."""
    from gc_ocp.batch.manifest import read_manifest

    t0 = time.perf_counter()
    per = {}
    for s in read_manifest(study):
        cmd = [sys.executable, "-m", "gc_ocp.cli", "fit", *(str(t.path) for t in s.trials)]
        for opt, v in (
            ("--static", s.static),
            ("--mass", s.mass),
            ("--height", s.height),
            ("--belt-speed", s.belt_speed),
        ):
            if v is not None:
                cmd += [opt, str(v)]
        cmd += ["--out", str(out / s.id)]
        t = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True)
        per[s.id] = (time.perf_counter() - t, r.returncode)
    return {"wall": time.perf_counter() - t0, "per": per}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", type=Path, default=None, help="working folder (default: a temp)")
    ap.add_argument("--skip-loop", action="store_true")
    args = ap.parse_args()
    work = args.work or Path(tempfile.mkdtemp(prefix="gc_ocp_batch_bench_"))
    work.mkdir(parents=True, exist_ok=True)
    study = work / "study.csv"
    rows = manifest(study)
    print(f"# A study on Dask (`benchmarks/batch_study.py`)\n\nManifest ({work / 'study.csv'}):\n")
    print("```text\n" + study.read_text() + "```\n")
    n_sub = len({r["subject"] for r in rows})
    runs = {w: batch(study, work / f"out_{w}", w) for w in (1, 2)}
    lp = None if args.skip_loop else loop(study, work / "loop")
    print(f"{n_sub} subjects, {len(rows)} trials.\n")
    print("| run | wall time [s] | per subject [s] | peak memory of a worker [MB] | subjects |")
    print("|---|---|---|---|---|")
    for w, r in runs.items():
        print(
            f"| batch, {w} worker(s) | {r['wall']:.0f} | {r['wall'] / n_sub:.1f} | "
            f"{r['peak_mb']:.0f} | {r['counts']} |"
        )
    if lp is not None:
        ok = sum(code == 0 for _, code in lp["per"].values())
        print(
            f"| loop of `gc-ocp fit` | {lp['wall']:.0f} | {lp['wall'] / n_sub:.1f} | - | "
            f"{ok} of {n_sub} exit 0 |"
        )
        print(
            f"\nBatch with 2 workers against the loop: {lp['wall'] / runs[2]['wall']:.2f}x; "
            f"2 workers against 1: {runs[1]['wall'] / runs[2]['wall']:.2f}x."
        )
    print("\nPer subject (batch, 2 workers): seconds and status")
    for s in runs[2]["subjects"]:
        e = f" ({s['error']['type']}: {s['error']['message'][:100]})" if s["error"] else ""
        loop_s = "" if lp is None else f"; loop {lp['per'][s['subject']][0]:.0f} s"
        print(f"* {s['subject']}: {s['status']}, {s['seconds'] or 0:.0f} s{loop_s}{e}")


if __name__ == "__main__":
    main()
