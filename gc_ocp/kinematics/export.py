"""Write a trial's sole-point trajectories and the kinematics figure.

Files written into ``out_dir`` (each atomically: complete or absent):

* ``sole_points.csv`` (``fmt="csv"``): long format, one row per frame, foot and unit, columns
  ``time_s, side, unit, x_m, y_m, z_m, vx_m_s, vy_m_s, vz_m_s`` (``lab`` frame: Z up, X anterior,
  Y left). ``sole_points.npz`` (``fmt="npz"``): arrays ``time`` (n,), ``{side}_positions`` and
  ``{side}_velocities`` (n, 5, 3), ``{side}_points_local`` (5, 3) in the foot frames, ``units``,
  ``q`` (n, 27), ``marker_rms`` (n,).
* ``kinematics_summary.json``: marker RMS (median, 95th percentile) and mid-stance sole heights.
* ``landmarks.json``: the marker mapping used (label -> landmark -> segment, ignored labels and
  why, decisions on duplicates and ambiguities; :mod:`gc_ocp.model.landmarks`).
* ``kinematics.png``: the figure of :func:`plot_kinematics`.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from gc_ocp.errors import InputError
from gc_ocp.foot import UNITS, TrialKinematics
from gc_ocp.outputs import atomic_savefig, atomic_write, atomic_write_text
from gc_ocp.text import json_text
from gc_ocp.trial import Trial


def midstance_heights(
    trial: Trial, kin: TrialKinematics, lo: float = 0.25, hi: float = 0.5
) -> list[dict]:
    """Per stance, the units' mean height above the plate surface [mm] over [lo, hi] of stance."""
    out = []
    for st in trial.stances:
        foot = kin.feet[st.side]
        t = foot.time
        a, b = st.t_on + lo * st.duration, st.t_on + hi * st.duration
        sel = (t >= a) & (t <= b)
        if not sel.any():
            continue
        h = (foot.positions[sel, :, 2] - trial.plates[st.plate].surface_height) * 1e3
        out.append(
            {
                "stance": st.label,
                "side": st.side,
                "height_mm": {u: float(np.mean(h[:, i])) for i, u in enumerate(UNITS)},
            }
        )
    return out


def kinematics_summary(trial: Trial, kin: TrialKinematics) -> dict:
    rms = np.asarray(kin.marker_rms) * 1e3
    return {
        "trial": str(trial.source),
        "frames": int(kin.time.size),
        "cutoff_hz": kin.cutoff_hz,
        "marker_rms_mm": {
            "median": float(np.nanmedian(rms)),
            "p95": float(np.nanpercentile(rms, 95)),
        },
        "midstance_sole_heights_mm": midstance_heights(trial, kin),
    }


def plot_kinematics(trial: Trial, kin: TrialKinematics):
    """Figure: IK marker RMS [mm] over time, and each foot's sole-point heights above the plate
    surface [mm] with that foot's stance windows shaded. Returns the Figure (not shown or saved)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 8), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    axes[0].plot(kin.time, np.asarray(kin.marker_rms) * 1e3, color="k")
    axes[0].set_ylabel("marker RMS [mm]")
    axes[0].set_title(f"{trial.name}: inverse kinematics and sole points")
    floor = trial.floor_height
    for ax, side in zip(axes[1:], ("left", "right"), strict=True):
        foot = kin.feet[side]
        for i, u in enumerate(UNITS):
            ax.plot(foot.time, (foot.positions[:, i, 2] - floor) * 1e3, label=u)
        for st in trial.stances:
            if st.side == side:
                ax.axvspan(st.t_on, st.t_off, color="0.85", zorder=0)
        ax.axhline(0.0, color="k", lw=0.8)
        ax.set_ylabel(f"{side} height [mm]")
        ax.set_ylim(-30, 150)
        ax.legend(ncol=5, fontsize=8, loc="upper right")
    axes[-1].set_xlabel("time [s] (stances shaded)")
    return fig


def write_kinematics(
    trial: Trial, kin: TrialKinematics, out_dir: str | Path, fmt: str = "csv"
) -> list[Path]:
    """Write trajectories (``fmt`` = ``"csv"`` or ``"npz"``), summary JSON and figure; returns paths."""
    out_dir = Path(out_dir)
    paths = []
    if fmt == "csv":
        buf = io.StringIO()
        buf.write("time_s,side,unit,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s\n")
        for side, foot in kin.feet.items():
            for j, t in enumerate(foot.time):
                for i, u in enumerate(UNITS):
                    p, v = foot.positions[j, i], foot.velocities[j, i]
                    buf.write(
                        f"{t:.6f},{side},{u},{p[0]:.6f},{p[1]:.6f},{p[2]:.6f},{v[0]:.6f},{v[1]:.6f},{v[2]:.6f}\n"
                    )
        paths.append(atomic_write_text(out_dir / "sole_points.csv", buf.getvalue()))
    elif fmt == "npz":
        arrays = {
            "time": kin.time,
            "q": kin.q,
            "marker_rms": kin.marker_rms,
            "units": np.array(UNITS),
        }
        for side, foot in kin.feet.items():
            arrays[f"{side}_positions"] = foot.positions
            arrays[f"{side}_velocities"] = foot.velocities
            arrays[f"{side}_points_local"] = foot.points_local

        def w(tmp: Path) -> None:
            with open(tmp, "wb") as f:
                np.savez(f, **arrays)

        paths.append(atomic_write(out_dir / "sole_points.npz", w))
    else:
        raise InputError(f'Unknown output format "{fmt}"; choose "csv" or "npz".')
    paths.append(
        atomic_write_text(
            out_dir / "kinematics_summary.json",
            json_text(kinematics_summary(trial, kin), indent=2),
        )
    )
    if "landmarks" in kin.info:
        paths.append(
            atomic_write_text(
                out_dir / "landmarks.json", json_text(kin.info["landmarks"], indent=2)
            )
        )
    fig = plot_kinematics(trial, kin)
    paths.append(atomic_savefig(fig, out_dir / "kinematics.png", dpi=110))
    return paths
