"""Figures of an estimation result (returned, never shown or saved)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from gc_ocp.contact.plots import plot_sole, plot_wrench_fit
from gc_ocp.estimation.result import EstimationResult
from gc_ocp.foot import SoleLayout


def plot_fit(
    result: EstimationResult, title: str = "measured (solid) vs fitted (dashed)"
) -> Figure:
    """Measured vs fitted six channels per foot, every stance."""
    f = result.stance_fits
    return plot_wrench_fit(
        [s["time"] for s in f],
        [s["measured"] for s in f],
        [s["model"] for s in f],
        sides=[s["side"] for s in f],
        labels=[s["label"].split(":")[-1] for s in f],
        title=title,
    )


def plot_sole_fit(result: EstimationResult) -> Figure:
    """Each sole from above: corrected units (filled, labelled with k) and nominal ones (x)."""
    pts, nominal, toes, units = {}, {}, {}, {}
    for fit in result.stance_fits:
        if fit["side"] in pts:
            continue
        pts[fit["side"]] = fit["points_local"]
        nominal[fit["side"]] = np.asarray(fit["nominal_points"])
        toes[fit["side"]] = np.asarray(fit["toes_offset"])
        units[fit["side"]] = fit["units"]
    k = {s: {u: result.params[s][u]["k"] for u in units[s]} for s in pts if s in result.params}
    layout = SoleLayout(
        tuple(result.stance_fits[0]["units"]), tuple(result.stance_fits[0]["parents"])
    )
    fig = plot_sole(
        pts, k=k, toes_offset=toes, title="sole units: nominal (x) and corrected (o)", layout=layout
    )
    for ax, side in zip(fig.axes, pts, strict=False):
        nom = nominal[side].copy()
        nom[list(layout.on("toes"))] += toes[side]
        ax.scatter(
            nom[:, 1] * 100, nom[:, 0] * 100, marker="x", color="C3", zorder=4, label="nominal"
        )
        ax.legend(fontsize=7, loc="lower right")
    return fig


def plot_pose_corrections(result: EstimationResult) -> Figure:
    """Foot-pose corrections over time: translation [mm] and rotation [deg] per stance."""
    fig = Figure(figsize=(9, 5), layout="constrained")
    ax_t, ax_r = fig.subplots(2, 1, sharex=True)
    pose = result.blocks.get("pose", {}).get("stances", {})
    for fit in result.stance_fits:
        if fit["label"] not in pose:
            continue
        lab = fit["label"].split(":")[-1]
        d = np.asarray(pose[fit["label"]]["translation_m"])
        th = np.asarray(pose[fit["label"]]["rotation_rad"])
        for j, axis in enumerate("xyz"):
            ax_t.plot(fit["time"], d[:, j] * 1e3, label=f"{lab} {axis}")
            ax_r.plot(fit["time"], np.rad2deg(th[:, j]), label=f"{lab} {axis}")
    ax_t.set_ylabel("translation [mm]")
    ax_r.set_ylabel("rotation [deg]")
    ax_r.set_xlabel("time [s]")
    ax_t.set_title("foot-pose corrections (lab axes, about the hindfoot origin)")
    for ax in (ax_t, ax_r):
        ax.grid(alpha=0.3)
    ax_t.legend(fontsize=6, ncol=3)
    return fig
