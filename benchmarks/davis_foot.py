"""A Davis-protocol foot (heel and first metatarsal head on the foot, the shank's markers above)
against the full-marker foot of the same trial (issue 23): the five BTS walking trials with the
fifth-metatarsal and toe-tip markers removed; contact parameters of ``gc_ocp.fit`` (the joint
estimator), in-sample superior-force and COP RMS of the Davis foot, side by side.

    PYTHONPATH=. .venv/bin/python benchmarks/davis_foot.py > benchmarks/davis_foot_output.md
    PYTHONPATH=. .venv/bin/python benchmarks/davis_foot.py --subject > benchmarks/davis_foot_subject_output.md

Only the *left* foot is replaced: in every right stance of these trials both metatarsal markers
are missing (occluded), so the full-marker right foot is itself posed from two landmarks there
and is no reference. Per trial: the full-marker fit; the left foot made a Davis foot with its
roll about the heel-metatarsal line as the body chain poses it (``foot_roll="chain"``, the
default) and levelled on every frame (``foot_roll="level"``; a third way, tried and removed, in
``davis_foot_flat_output.md``). Then the hindfoot's roll against the full-marker
pose in the left stance of each (mean and peak to peak about the foot's long axis).
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

import gc_ocp
from gc_ocp.foot import FOOT_ROLLS
from gc_ocp.io import load_trial
from gc_ocp.kinematics import compute_kinematics

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
DROPPED = ("RVMH", "LVMH", "RIIT", "LIIT")  # fifth metatarsal heads and toe tips


def params(r) -> str:
    """The shared law's n, c, mu of fit result ``r`` with their SE, as table cells."""
    sh = r.params["shared"]
    return " | ".join(
        f"{sh[q]:.3f} +- {sh.get(q + '_se', float('nan')):.3f}" for q in ("n", "c", "mu")
    )


def davis_trial(trial):
    """``trial`` without the markers of :data:`DROPPED`."""
    keep = [i for i, n in enumerate(trial.marker_names) if n not in DROPPED]
    return dataclasses.replace(
        trial,
        marker_names=tuple(trial.marker_names[i] for i in keep),
        markers=np.asarray(trial.markers)[:, keep],
    )


def roll(a, b, stance) -> tuple[float, float]:
    """Mean and peak to peak [deg] of the rotation of hindfoot ``b`` against ``a`` about the
    hindfoot's X (long) axis over ``stance``."""
    w = (a.time >= stance.t_on) & (a.time <= stance.t_off)
    Ra, Rb = a.hindfoot_pose[w, :3, :3], b.hindfoot_pose[w, :3, :3]
    rel = np.rad2deg(Rotation.from_matrix(np.einsum("tji,tjk->tik", Ra, Rb)).as_rotvec())
    return float(rel[:, 0].mean()), float(np.ptp(rel[:, 0]))


def main() -> None:
    warnings.simplefilter("ignore")
    print("# A Davis-protocol foot against the full-marker foot (BTS, five trials)\n")
    print(
        f"Removed: {', '.join(DROPPED)} (the left foot replaced; the right stances have no "
        "metatarsal markers in these files). `gc_ocp.fit` (the joint estimator), one fit each; "
        "RMS and COP of the left foot, in-sample.\n"
    )
    print(
        "| trial | left foot | n | c [s/m] | mu | superior RMS % BW | COP mm | roll vs full: mean, p-p [deg] |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for k in range(1, 6):
        trial = load_trial(DATA / "bts_unipd_5trials" / f"Walking{k}.c3d")
        cut = davis_trial(trial)
        full = compute_kinematics(trial)
        st = next(s for s in trial.stances if s.side == "left")
        rows = [("full markers", full, "")]
        for how in FOOT_ROLLS:
            kin = compute_kinematics(cut, foot_roll=how)
            feet = dict(full.feet)
            feet["left"] = kin.feet["left"]
            m, p = roll(full.feet["left"], kin.feet["left"], st)
            rows.append(
                (f"Davis, {how}", dataclasses.replace(full, feet=feet), f"{m:+.1f}, {p:.1f}")
            )
        for name, kin, rl in rows:
            r = gc_ocp.fit([(trial, kin)]).result
            print(
                f"| Walking{k} | {name} | {params(r)} | {r.rms['left']['superior_force_pct_bw']:.2f} "
                f"| {r.cop_rms_mm['left']:.0f} | {rl} |",
                flush=True,
            )


def subject() -> None:
    """The five trials fitted together (one subject: the law shared by every stance, as the
    diagnosis fits a subject), with the full-marker left foot and the two Davis feet; the
    trial-to-trial spread of the single-trial fits above is then averaged, and the SE is the
    subject's."""
    warnings.simplefilter("ignore")
    print("\n## The five trials together (one subject)\n")
    print(
        "`gc_ocp.fit` on Walking1-5 at once (10 stances; the law n, c, mu shared by all): the "
        "left foot full-marker or Davis in every trial; RMS and COP of the left foot, in-sample, "
        "over all its stances.\n"
    )
    print("| left foot | n | c [s/m] | mu | superior RMS % BW | COP mm |")
    print("|---|---|---|---|---|---|")
    trials = [load_trial(DATA / "bts_unipd_5trials" / f"Walking{k}.c3d") for k in range(1, 6)]
    full = [compute_kinematics(t) for t in trials]
    ways = [("full markers", full)]
    for how in FOOT_ROLLS:
        kins = []
        for t, f in zip(trials, full, strict=True):
            feet = dict(f.feet)
            feet["left"] = compute_kinematics(davis_trial(t), foot_roll=how).feet["left"]
            kins.append(dataclasses.replace(f, feet=feet))
        ways.append((f"Davis, {how}", kins))
    for name, kins in ways:
        r = gc_ocp.fit(list(zip(trials, kins, strict=True))).result
        print(
            f"| {name} | {params(r)} | {r.rms['left']['superior_force_pct_bw']:.2f} "
            f"| {r.cop_rms_mm['left']:.0f} |",
            flush=True,
        )


LABS = (
    "vicon_plugingait_clusters/FunctionalWalk.c3d",
    "motionanalysis_helenhayes/Gait.c3d",
    "c3dorg_helenhayes_types/type-2a.c3d",
)
"""The shared files whose feet have two landmarks (heel and a second-metatarsal toe marker)."""


def other_labs() -> None:
    """The files of :data:`LABS` (no reference foot: in-sample quality and the flags only)."""
    from gc_ocp.io.pairing import pair_trials

    print("\n## Two-landmark feet of other labs: chain-posed against levelled\n")
    print(
        "No full-marker reference here: in-sample superior RMS and COP RMS per foot, the "
        "shared parameters, and the number of flagged variables of `gc_ocp.fit`.\n"
    )
    print(
        "| file | foot roll | n | c [s/m] | mu | superior RMS % BW (L, R) | COP mm (L, R) | flags |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name in LABS:
        [files] = pair_trials([DATA / name])
        trial = load_trial(files.trial, files.grf)
        for how in FOOT_ROLLS:
            r = gc_ocp.fit([(trial, compute_kinematics(trial, foot_roll=how))]).result
            rms = ", ".join(f"{r.rms[s]['superior_force_pct_bw']:.2f}" for s in ("left", "right"))
            cop = ", ".join(f"{r.cop_rms_mm[s]:.0f}" for s in ("left", "right"))
            print(f"| {name} | {how} | {params(r)} | {rms} | {cop} | {len(r.flags)} |", flush=True)


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--subject", action="store_true", help="only the five trials fitted together (~10 min)"
    )
    if ap.parse_args().subject:
        subject()
    else:
        main()
        other_labs()
