"""Plates read at the frames: point samples (before 2026-12-03) against the anti-alias low-pass.

Each shared walking file (or set of trials of one subject) is fitted twice with ``gc_ocp.fit``'s
defaults and ``holdout="auto"``: once with the plates read at the frames through the anti-alias
low-pass (:mod:`gc_ocp.antialias`, the package's way) and once with their point samples (the
filter switched off). Each fit is scored against both readings of the plates, in sample and on
the held-out stance (superior force RMS over in-contact frames, % BW), with its law's n, c, mu.

    .venv/bin/python benchmarks/antialias.py > benchmarks/antialias_output.md
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path
from unittest import mock

import numpy as np

import gc_ocp
import gc_ocp.stance

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
SETS = {
    "Plug-in Gait (bundled), 100 / 1000 Hz": [None],
    "Plug-in Gait (btk), 100 / 1000 Hz": ["vicon_plugingait_btk/PiG_Motion3_FF.c3d"],
    "clusters, 120 / 1080 Hz": ["vicon_plugingait_clusters/FunctionalWalk.c3d"],
    "Helen Hayes (MotionAnalysis), 100 / 1000 Hz": ["motionanalysis_helenhayes/Gait.c3d"],
    "BTS Walking1-3, 60 / 1020 Hz": [f"bts_unipd_5trials/Walking{i}.c3d" for i in (1, 2, 3)],
    "BTS Walking4-5, 60 / 1020 Hz": [f"bts_unipd_5trials/Walking{i}.c3d" for i in (4, 5)],
    "Rajagopal (MOT, low-passed by the lab), 100 / 2000 Hz": [
        "opensim_rajagopal_overground/motion_capture_walk.trc"
    ],
}


def _fit(paths, filtered: bool):
    trials = [gc_ocp.load_trial(DATA / p) if p else gc_ocp.load_trial() for p in paths]
    pairs = [(t, gc_ocp.compute_kinematics(t)) for t in trials]
    off = mock.patch.object(gc_ocp.stance, "needs_filter", lambda *a: False)
    t0 = time.perf_counter()
    if filtered:
        rep = gc_ocp.fit(pairs, holdout="auto")
    else:
        with off:
            rep = gc_ocp.fit(pairs, holdout="auto")
    return rep, time.perf_counter() - t0


def _measured(rep) -> dict:
    fits = rep.result.stance_fits + (rep.heldout.stance_fits if rep.heldout else [])
    return {f["label"]: f["measured"] for f in fits}


def _superior(fits, measured: dict) -> float:
    e = [
        ((f["model"][:, 2] - measured[f["label"]][:, 2]) / f["body_weight"])[f["in_contact"]]
        for f in fits
    ]
    return 100 * float(np.sqrt(np.mean(np.concatenate(e) ** 2))) if e else float("nan")


def main() -> None:
    warnings.simplefilter("ignore")
    print("# Plates read at the frames: point samples against the anti-alias low-pass\n")
    print("`benchmarks/antialias.py` (module doc). Superior force RMS, % BW, in-contact frames;")
    print("*vs low-passed* / *vs point*: the fit's model against each reading of the plates.\n")
    print(
        "| file (frames / plates) | plates read as | n | c [s/m] | mu | in sample vs low-passed "
        "| vs point | held out vs low-passed | vs point | s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, paths in SETS.items():
        reps = {f: _fit(paths, f) for f in (False, True)}
        meas = {f: _measured(r) for f, (r, _) in reps.items()}
        for f in (False, True):
            rep, secs = reps[f]
            sh = rep.result.params["shared"]
            law = [f"{sh[k]:.3f} +- {sh[k + '_se']:.3f}" for k in ("n", "c", "mu")]
            cells = [_superior(rep.result.stance_fits, meas[g]) for g in (True, False)]
            held = (
                [_superior(rep.heldout.stance_fits, meas[g]) for g in (True, False)]
                if rep.heldout
                else [float("nan")] * 2
            )
            how = "low-passed" if f else "point samples"
            row = [name if not f else "", how, *law] + [f"{v:.2f}" for v in cells + held]
            print("| " + " | ".join(row) + f" | {secs:.0f} |", flush=True)
    print(f"\nRun {time.strftime('%Y-%m-%d')}, gc_ocp {gc_ocp.__version__}.", file=sys.stdout)


if __name__ == "__main__":
    main()
