"""A Davis-protocol foot (heel and first metatarsal head on the foot, the shank's markers above)
against the full-marker foot of the same trial (issue 23): BTS Walking1 with the fifth-metatarsal
and toe-tip markers removed; contact parameters of ``gc_ocp.fit`` (the joint estimator) side by
side, and what the difference is made of.

    PYTHONPATH=. .venv/bin/python benchmarks/davis_foot.py > benchmarks/davis_foot_output.md

Rows: the full-marker fit; the Davis foot; the Davis foot with its sole units moved to where the
full-marker foot has them in the lab at foot-flat (an *oracle layout*: is it the layout?); the
Davis foot with the pose correction's rotation width allowed to 15 deg (is it the rotation's
prior?); the full-marker kinematics with one foot replaced by the Davis foot's (which foot?).
Then the hindfoot's rotation against the full-marker pose, per stance.
"""

from __future__ import annotations

import dataclasses
import sys
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

import gc_ocp
import gc_ocp.estimation.pose_scale as pose_scale
from gc_ocp.io import load_trial
from gc_ocp.kinematics import compute_kinematics

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
DROPPED = ("RVMH", "LVMH", "RIIT", "LIIT")  # fifth metatarsal heads and toe tips
FOOT_FLAT = (0.2, 0.45)  # fraction of stance, as the pipeline's sole calibration


def fitted(trial, kin) -> tuple[dict, str]:
    rep = gc_ocp.fit([(trial, kin)])
    sh = rep.result.params["shared"]
    return {p: (sh[p], sh.get(p + "_se", float("nan"))) for p in ("n", "c", "mu")}, (
        rep.pose_scale.message() if rep.pose_scale else ""
    )


def oracle_layout(trial, full, davis):
    """The Davis kinematics with each hindfoot unit placed, in the Davis hindfoot frame, where the
    full-marker foot has it in the lab over the foot-flat frames (mean)."""
    feet = {}
    for side in ("left", "right"):
        a, b = full.feet[side], davis.feet[side]
        w = np.zeros(a.time.size, bool)
        for st in trial.stances:
            if st.side == side:
                w |= (a.time >= st.t_on + FOOT_FLAT[0] * st.duration) & (
                    a.time <= st.t_on + FOOT_FLAT[1] * st.duration
                )
        pts = b.points_local.copy()
        Hb = b.hindfoot_pose[w]
        for i, u in enumerate(a.layout.units):
            if a.layout.parent(u) == "hindfoot":
                lab = a.positions[w, i]  # the full-marker unit in the lab
                pts[i] = np.einsum("tji,tj->ti", Hb[:, :3, :3], lab - Hb[:, :3, 3]).mean(0)
        feet[side] = b.with_points(pts)
    return dataclasses.replace(davis, feet=feet)


def main() -> None:
    warnings.simplefilter("ignore")
    trial = load_trial(DATA / "bts_unipd_5trials" / "Walking1.c3d")
    keep = [i for i, n in enumerate(trial.marker_names) if n not in DROPPED]
    cut = dataclasses.replace(
        trial,
        marker_names=tuple(trial.marker_names[i] for i in keep),
        markers=np.asarray(trial.markers)[:, keep],
    )
    full, davis = compute_kinematics(trial), compute_kinematics(cut)
    rows = [
        ("full markers", trial, full),
        ("Davis foot", cut, davis),
        ("Davis foot, oracle layout", cut, oracle_layout(trial, full, davis)),
    ]
    for side in ("left", "right"):
        feet = dict(full.feet)
        feet[side] = davis.feet[side]
        rows.append(
            (f"full markers, Davis {side} foot", trial, dataclasses.replace(full, feet=feet))
        )
    print("# A Davis-protocol foot against the full-marker foot (BTS Walking1)\n")
    print(f"Removed: {', '.join(DROPPED)}. `gc_ocp.fit` (the joint estimator), one fit each.\n")
    print("| fit | n | c [s/m] | mu | pose widths |")
    print("|---|---|---|---|---|")

    def row(name, p, msg):
        cells = " | ".join(f"{v:.3f} +- {se:.3f}" for v, se in p.values())
        width = msg.split(": ", 1)[-1].split(";")[0] if msg else ""
        print(f"| {name} | {cells} | {width} |", flush=True)

    for name, t, k in rows:
        row(name, *fitted(t, k))
    limit = pose_scale.PLAUSIBLE_DEG
    pose_scale.PLAUSIBLE_DEG = 15.0
    try:
        row("Davis foot, rotation widths up to 15 deg", *fitted(cut, davis))
    finally:
        pose_scale.PLAUSIBLE_DEG = limit
    print("\nHindfoot rotation of the Davis foot against the full-marker foot, per stance [deg]:\n")
    print("| foot | stance at [s] | mean about x / y / z | peak to peak about x |")
    print("|---|---|---|---|")
    for side in ("left", "right"):
        a, b = full.feet[side], davis.feet[side]
        for st in trial.stances:
            if st.side != side:
                continue
            w = (a.time >= st.t_on) & (a.time <= st.t_off)
            Ra, Rb = a.hindfoot_pose[w, :3, :3], b.hindfoot_pose[w, :3, :3]
            rel = np.rad2deg(Rotation.from_matrix(np.einsum("tji,tjk->tik", Ra, Rb)).as_rotvec())
            mean = " / ".join(f"{v:+.1f}" for v in rel.mean(0))
            print(f"| {side} | {st.t_on:.2f} | {mean} | {np.ptp(rel[:, 0]):.1f} |")


if __name__ == "__main__":
    sys.exit(main())
