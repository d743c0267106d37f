"""Every walking trial of ``../shared/data``, loaded and fitted as a new user would: no marker-set
file, no per-file option, no mass where the file has none (issue 11).

Run:  PYTHONPATH=. python benchmarks/all_data.py [--data ../shared/data] [--out FILE.md]

Per file: the landmarks recognised (or the shipped marker set that matches exactly), the stances
used and excluded (with the reason), the vertical axis, the mass used and its source, and the
in-sample superior-force RMS and COP RMS of a fit of today's full model. Then the five BTS trials
of one subject fitted together as one problem, one stance of the fifth trial held out.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

WALKING = (
    "plugingait_overground/test_small.c3d",
    "opensim_rajagopal_overground/motion_capture_walk.trc",
    "opensim_gait2392_treadmill/subject01_walk1.trc",
    "vicon_plugingait_btk/PiG_Motion3_FF.c3d",
    "vicon_plugingait_clusters/FunctionalWalk.c3d",
    "motionanalysis_helenhayes/Gait.c3d",
    "c3dorg_helenhayes_types/type-2a.c3d",
    "c3dorg_helenhayes_types/type-4a.c3d",
    *(f"bts_unipd_5trials/Walking{i}.c3d" for i in range(1, 6)),
    "camargo_opensim_circuit/levelground_ccw_fast_01_01.trc",
)
"""The walking trials listed in ``../shared/data/README.md`` (static trials are not walking)."""


def _load(path: Path):
    import gc_ocp
    from gc_ocp.io.pairing import pair_trials

    [files] = pair_trials([path])
    trial = gc_ocp.load_trial(files.trial, files.grf)
    return trial, gc_ocp.compute_kinematics(trial)


def _landmarks(kin) -> str:
    lm = kin.info.get("landmarks") or {}
    markers = lm.get("markers", [])
    foot = sorted(
        {
            m["landmark"]
            for m in markers
            if m.get("segment", "").startswith(("hindfoot", "toes")) and not m.get("cluster")
        }
    )
    return f"{lm.get('markerset', '?')}: {len(markers)} markers; foot: {', '.join(foot)}"


def _up(trial) -> str:
    """The file axis that became lab +Z (the vertical detected on load)."""
    import numpy as np

    row = trial.lab_rotation[2]
    i = int(np.argmax(np.abs(row)))
    return f"{'+' if row[i] > 0 else '-'}{'XYZ'[i]}"


def _stances(trial) -> str:
    used = [f"{s.side[0].upper()} {s.t_on:.3f}-{s.t_off:.3f}" for s in trial.stances]
    out = "; ".join(used)
    if trial.excluded_stances:
        out += " / excluded: " + "; ".join(
            f"{e.side[0].upper()} {e.t_on:.3f}-{e.t_off:.3f} ({e.reason[:60]})"
            for e in trial.excluded_stances
        )
    return out


def _fit_row(pairs, holdout=None):
    import gc_ocp

    rep = gc_ocp.fit(pairs, model=gc_ocp.full_model(), holdout=holdout)
    r = rep.result
    sup = ", ".join(
        f"{s[0].upper()} {r.rms[s]['superior_force_pct_bw']:.2f}"
        for s in ("left", "right")
        if s in r.rms
    )
    cop = ", ".join(
        f"{s[0].upper()} {r.cop_rms_mm[s]:.0f}" for s in ("left", "right") if s in r.cop_rms_mm
    )
    return rep, sup, cop


def _minima(rep) -> str:
    """The parameters another minimum the plates do not tell apart has beyond 2 SE
    (``minimum_undecided`` flags: one per such minimum), or "-"."""
    found = [f["what"] for f in rep.result.flags if f["code"] == "minimum_undecided"]
    return "; ".join(found) if found else "-"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--data", type=Path, default=Path(__file__).resolve().parents[1].parent / "shared" / "data"
    )
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("all_data_output.md"))
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    rows = [
        "| file | markers | up | stances used (s) / excluded | mass (source) | superior RMS % BW | COP RMS mm | another minimum: beyond 2 SE | s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    bts = []
    for rel in WALKING:
        t0 = time.perf_counter()
        path = args.data / rel
        try:
            trial, kin = _load(path)
            rep, sup, cop = _fit_row([(trial, kin)])
            up = _up(trial)
            rows.append(
                f"| {rel} | {_landmarks(kin)} | {up} | {_stances(trial)} | "
                f"{trial.mass:.1f} ({trial.mass_source[:70]}) | {sup} | {cop} | "
                f"{_minima(rep)} | {time.perf_counter() - t0:.0f} |"
            )
            if rel.startswith("bts_"):
                bts.append((trial, kin))
        except Exception as e:  # noqa: BLE001 - the table reports every failure
            rows.append(f"| {rel} | FAILED: {type(e).__name__}: {str(e)[:200]} | | | | | | | |")
        print(rows[-1], flush=True)
    lines = ["# Every walking trial of ../shared/data, untouched", "", *rows, ""]
    if len(bts) == 5:
        t0 = time.perf_counter()
        held = bts[-1][0].stances[0]
        label = f"{bts[-1][0].source.stem}:{held.side}@"
        rep, sup, cop = _fit_row(bts, holdout=label)
        h = rep.heldout
        lines += [
            "## The five BTS trials of one subject, fitted together",
            "",
            f"{sum(len(t.stances) for t, _ in bts)} stances, shared contact parameters, "
            f"held out: {rep.heldout_label}. In-sample superior RMS {sup} % BW, COP {cop} mm; "
            f"held-out superior RMS {h.rms[held.side]['superior_force_pct_bw']:.2f} % BW, "
            f"COP {h.cop_rms_mm[held.side]:.0f} mm; another minimum the plates do not "
            f"prefer the kept one to, its parameters beyond 2 SE: {_minima(rep)}; {time.perf_counter() - t0:.0f} s.",
            "",
        ]
        print(lines[-2], flush=True)
    args.out.write_text("\n".join(lines))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
