"""OpenSim's contact forces against gc_ocp's (issue 25), on the bundled trial and two shared
trials.

Usage::

    PYTHONPATH=. python benchmarks/export_opensim.py [--out DIR]

For each trial: the default fit (``gc_ocp.fit``, no held-out stance), exported with
``gc_ocp.export.opensim_export.export_opensim`` (each unit's law mapped onto OpenSim's
``SmoothSphereHalfSpaceForce``, radius 5 mm); then the same model refitted with the exponent
fixed at Hertz's 1.5 (``--hertz``) and exported. OpenSim computes its contact forces on the
trial's coordinates (its own process, the real ``opensim`` package); the table gives the RMS of
OpenSim's minus gc_ocp's wrench per channel over the trial's stances (% BW, % BW x H), the
fitted exponent, the median curve mismatch of the mapping (% of the unit's force) and, for
the refit, its in-sample RMS against the free exponent's (the price of Hertz's exponent).
The figures (``DIR/<trial>_<fit>.png``) show the vertical and anterior forces.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
TRIALS = (
    ("bundled (PiG overground)", None, None, None),
    ("BTK PiG", DATA / "vicon_plugingait_btk/PiG_Motion3_FF.c3d", None, None),
    (
        "Rajagopal (OpenSim TRC + MOT)",
        DATA / "opensim_rajagopal_overground/motion_capture_walk.trc",
        DATA / "opensim_rajagopal_overground/grf_walk.mot",
        85.07,
    ),
)


def main() -> None:
    from gc_ocp.contact.channels import CHANNELS, TABLE_KEYS

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "export_opensim")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    from gc_ocp.export.calibrated import CalibratedContact
    from gc_ocp.export.opensim_export import export_opensim, hertz_refit
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics
    from gc_ocp.workflow.fitting import fit

    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name, path, grf, mass in TRIALS:
        t0 = time.perf_counter()
        trial = load_trial(path, grf, mass=mass)
        kin = compute_kinematics(trial)
        pairs = [(trial, kin)]
        fits = {"fitted exponent": fit(pairs, holdout=None), "Hertz 1.5 (--hertz)": None}
        fits["Hertz 1.5 (--hertz)"] = hertz_refit(pairs)
        for label, rep in fits.items():
            cal = CalibratedContact.from_fit(rep)
            with tempfile.TemporaryDirectory() as tmp:
                ex = export_opensim(rep, Path(tmp) / "x", pairs=pairs)
                stem = name.split()[0].lower() + ("_hertz" if "Hertz" in label else "_fitted")
                shutil.copy(Path(tmp) / "x" / "opensim_vs_gc_ocp.png", args.out / f"{stem}.png")
            curve = np.nanmedian([m.curve_rms_pct for m in ex.mapping])
            fit_rms = np.mean([v["superior_force_pct_bw"] for v in rep.result.rms.values()])
            rows.append((name, label, cal.value("n", "left"), curve, fit_rms, ex.rms["all"]))
        print(f"{name}: {time.perf_counter() - t0:.0f} s", flush=True)
    print("\n# OpenSim's contact forces against gc_ocp's (`benchmarks/export_opensim.py`)\n")
    print(
        "RMS of OpenSim's minus gc_ocp's wrench over the trial's stances, both on the fitted "
        "coordinates (each stance's foot where the fit's pose correction put it). Sphere radius 5 mm.\n"
    )
    head = " | ".join(CHANNELS)
    print(f"| trial | fit | n | curve mismatch [%] | fit's vertical RMS [% BW] | {head} |")
    print("|---" * (5 + len(CHANNELS)) + "|")
    for name, label, n, curve, fit_rms, rms in rows:
        vals = " | ".join(f"{rms[TABLE_KEYS[c]]:.2f}" for c in CHANNELS)
        print(f"| {name} | {label} | {n:.2f} | {curve:.1f} | {fit_rms:.2f} | {vals} |")
    print(
        "\nForces in % BW, torques in % BW x H. Curve mismatch: per unit, the RMS difference "
        "between OpenSim's Hertzian curve and the fitted k d^n over the penetrations the unit "
        "visits in stance, over the fitted curve's RMS (median over units). Fit's vertical "
        "RMS: the fit's own in-sample vertical RMS against the plates (mean of the feet)."
    )


if __name__ == "__main__":
    main()
