"""Figures of an estimation result (returned, never shown or saved)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from gc_ocp.contact.plots import keep_texts_inside, plot_sole, plot_wrench_fit
from gc_ocp.errors import InputError
from gc_ocp.estimation.result import as_result
from gc_ocp.foot import SoleLayout


def _fitted(result):
    """``result`` (:func:`as_result`) with its stance fits, which every figure draws: a
    ``fit.json`` whose ``stance_fits`` list is empty (edited, or cut short) is refused so."""
    result = as_result(result)
    if not result.stance_fits:
        raise InputError(
            'the fit has no stance fits (its fit.json\'s "stance_fits" is empty): there is '
            "nothing to draw; give the fit.json gc-ocp fit wrote, or the fit itself"
        )
    return result


def plot_fit(result, title: str = "measured (solid) vs fitted (dashed)") -> Figure:
    """Measured vs fitted six channels per foot, every stance, in % BW (forces) and % BW x
    height (torques) of each stance's subject, the unit of every RMS the fit prints;
    ``result``: a fit (what :func:`gc_ocp.fit` returns), its result or its ``fit.json``
    (:func:`as_result`). Returns the Matplotlib figure, not shown (``fig.savefig("fit.png")``).

    >>> import gc_ocp
    >>> trial = gc_ocp.load_trial(); kin = gc_ocp.compute_kinematics(trial)
    >>> problem = gc_ocp.build_estimation(gc_ocp.trial_stances(trial, kin), gc_ocp.seed_model())
    >>> fig = gc_ocp.plot_fit(gc_ocp.solve(problem))  # or plot_fit(report), plot_fit("out/fit.json")
    >>> len(fig.axes)                         # six channels, two feet
    12
    """
    f = _fitted(result).stance_fits
    return plot_wrench_fit(
        [s["time"] for s in f],
        [s["measured"] for s in f],
        [s["model"] for s in f],
        sides=[s["side"] for s in f],
        labels=[s["label"].split(":")[-1] for s in f],
        title=title,
        normalisers=[(s["body_weight"], s["body_weight"] * s["height"]) for s in f],
    )


def plot_sole_fit(result) -> Figure:
    """Each sole from above: corrected units (filled, sized and labelled by their force at the
    law's reference depth, the quantity the fit identifies: k [N/m^n] alone means nothing
    across exponents; a unit not identified is labelled so, unscaled) and nominal ones (x);
    ``result`` as for :func:`plot_fit`."""
    result = _fitted(result)
    pts, nominal, toes, units = {}, {}, {}, {}
    for fit in result.stance_fits:
        if fit["side"] in pts:
            continue
        pts[fit["side"]] = fit["points_local"]
        nominal[fit["side"]] = np.asarray(fit["nominal_points"])
        toes[fit["side"]] = np.asarray(fit["toes_offset"])
        units[fit["side"]] = fit["units"]
    # a unit not identified (ContactLaw.flags) has no force to show: drawn unscaled, saying so
    # (its absurd force, 24 BW at 5 mm, was the largest label and shrank every other unit)
    unknown = {
        s: {u for u in units[s] if not result.params.get(s, {}).get(u, {}).get("identified", True)}
        for s in pts
    }
    f_ref = {
        s: {u: None if u in unknown[s] else result.params[s][u].get("f_ref") for u in units[s]}
        for s in pts
        if s in result.params
    }
    layout = SoleLayout(
        tuple(result.stance_fits[0]["units"]), tuple(result.stance_fits[0]["parents"])
    )
    fig = plot_sole(
        pts,
        k=f_ref,
        toes_offset=toes,
        title=f"sole units: nominal (x) and corrected (o); force at {1e3 * result.law.reference_depth:g} mm",
        layout=layout,
        label=lambda f: f"{f:.0f} N",
    )
    for ax, side in zip(fig.axes, pts, strict=False):
        for text in ax.texts:
            if text.get_text() in unknown[side]:
                text.set_text(f"{text.get_text()}\nnot identified")
        nom = nominal[side].copy()
        nom[list(layout.on("toes"))] += toes[side]
        ax.autoscale()  # the limits plot_sole set for its labels, set again with these points
        ax.scatter(nom[:, 1] * 100, nom[:, 0] * 100, marker="x", color="C3", zorder=4)
        ax.margins(0.15)  # room for the labels (the title names the markers: no legend over them)
    keep_texts_inside(fig)  # the labels, "not identified" ones longer now, inside the frame
    return fig


def plot_pose_corrections(result) -> Figure:
    """Foot-pose corrections over time: translation [mm] and rotation [deg] per stance;
    ``result`` as for :func:`plot_fit`."""
    result = _fitted(result)
    fig = Figure(figsize=(9, 5), layout="constrained")
    ax_t, ax_r = fig.subplots(2, 1, sharex=True)
    pose = result.blocks.get("pose", {}).get("stances", {})
    styles = dict(zip("xyz", ("-", "--", ":"), strict=True))
    stances = []  # (label, colour): one colour per stance, one line style per axis
    for fit in result.stance_fits:
        if fit["label"] not in pose:
            continue
        colour = f"C{len(stances) % 10}"
        stances.append((fit["label"].split(":")[-1], colour))
        d = np.asarray(pose[fit["label"]]["translation_m"])
        th = np.asarray(pose[fit["label"]]["rotation_rad"])
        for j, axis in enumerate("xyz"):
            kw = {"color": colour, "linestyle": styles[axis]}
            ax_t.plot(fit["time"], d[:, j] * 1e3, **kw)
            ax_r.plot(fit["time"], np.rad2deg(th[:, j]), **kw)
    ax_t.set_ylabel("translation [mm]")
    ax_r.set_ylabel("rotation [deg]")
    ax_r.set_xlabel("time [s]")
    ax_t.set_title("foot-pose corrections (lab axes, about the hindfoot origin)")
    # a key on each panel, in the text's size, beside the plot (it covered the curves, in 6 pt
    # on the translation panel only): the stances by colour, the axes by line style
    handles = [Line2D([], [], color=c, label=lab) for lab, c in stances]
    handles += [Line2D([], [], color="0.3", linestyle=ls, label=a) for a, ls in styles.items()]
    for ax in (ax_t, ax_r):
        ax.grid(alpha=0.3)
        if stances:
            ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    return fig
