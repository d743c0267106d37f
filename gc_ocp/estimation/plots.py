"""Figures of an estimation result (returned, never shown or saved)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from gc_ocp.contact.plots import plot_sole, plot_wrench_fit
from gc_ocp.estimation.solve import EstimationResult
from gc_ocp.foot import UNITS


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


def _toes_offset(stance) -> np.ndarray:
    ph, pt = stance.foot.hindfoot_pose[0], stance.foot.toes_pose[0]
    return (np.linalg.inv(ph) @ pt)[:3, 3]


def plot_sole_fit(result: EstimationResult) -> Figure:
    """Each sole from above: corrected units (filled, labelled with k) and nominal ones (x)."""
    prob = result.problem
    pts, nominal, toes = {}, {}, {}
    for fit, st in zip(result.stance_fits, prob.stances, strict=True):
        if st.side in pts:
            continue
        pts[st.side] = fit["points_local"]
        nominal[st.side] = np.asarray(st.foot.points_local)
        toes[st.side] = _toes_offset(st)
    k = {s: {u: result.params[s][u]["k"] for u in UNITS} for s in pts if s in result.params}
    fig = plot_sole(pts, k=k, toes_offset=toes, title="sole units: nominal (x) and corrected (o)")
    for ax, side in zip(fig.axes, pts, strict=False):
        nom = nominal[side].copy()
        nom[UNITS.index("TT")] += toes[side]
        ax.scatter(
            nom[:, 1] * 100, nom[:, 0] * 100, marker="x", color="C3", zorder=4, label="nominal"
        )
        ax.legend(fontsize=7, loc="lower right")
    return fig


def plot_pose_corrections(result: EstimationResult) -> Figure:
    """Foot-pose corrections over time: translation [mm] and rotation [deg] per stance."""
    fig = Figure(figsize=(9, 5), layout="constrained")
    ax_t, ax_r = fig.subplots(2, 1, sharex=True)
    for fit in result.stance_fits:
        if "pose_translation" not in fit:
            continue
        lab = fit["label"].split(":")[-1]
        for j, axis in enumerate("xyz"):
            ax_t.plot(fit["time"], fit["pose_translation"][:, j] * 1e3, label=f"{lab} {axis}")
            ax_r.plot(fit["time"], np.rad2deg(fit["pose_rotation"][:, j]), label=f"{lab} {axis}")
    ax_t.set_ylabel("translation [mm]")
    ax_r.set_ylabel("rotation [deg]")
    ax_r.set_xlabel("time [s]")
    ax_t.set_title("foot-pose corrections (lab axes, about the hindfoot origin)")
    for ax in (ax_t, ax_r):
        ax.grid(alpha=0.3)
    ax_t.legend(fontsize=6, ncol=3)
    return fig
