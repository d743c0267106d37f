"""Where the gap lies: the residual of a fit by foot x channel x gait phase, and over time.

Input: the per-stance fits of a result (``EstimationResult.stance_fits``; for a diagnosis, the
held-out stances' fits, so that the map shows what the model fails to *predict*). Every number
is over in-contact frames, each stance normalised by its own body weight (forces, % BW) and body
weight x height (torques, % BW x H), as in ``fit.json``.

* ``rms``: RMS of (model - measured) per foot, channel and phase, plus ``"all"`` over the stance;
  ``cop_mm``: COP distance RMS [mm] where the measured vertical force exceeds 10 % BW.
* ``normalised``: the same RMS in units of the estimator's error scale (:class:`Weights`: 2 % BW
  for forces, 2 % BW x 0.25 m for torques): the quantity the fit minimises, comparable across
  channels; the COP is normalised by :data:`COP_SCALE_MM`.
* ``share``: each cell's fraction of the foot's total weighted squared residual: where the
  objective's misfit sits.

Per-unit attribution: a residual wrench cannot be split between the units in general (five
units, six channels, all coupled through the foot's pose); the COP error and the sagittal-moment
residual per phase say whether the misfit sits under the heel (loading response) or the forefoot
(terminal stance, pre-swing), which is as far as the data attribute it.
"""

from __future__ import annotations

import numpy as np

from gc_ocp.contact.channels import CHANNELS, TABLE_KEYS, WRENCH_COLUMN, channel_name
from gc_ocp.diagnosis.phases import PHASES, phase_bounds, phase_index
from gc_ocp.estimation.measurement import fit_error
from gc_ocp.estimation.problem import Weights
from gc_ocp.estimation.result import COP_MIN_FRACTION_BW
from gc_ocp.trial import SIDES
from gc_ocp.wrench import cop_from_wrench

COP_SCALE_MM = 20.0
"""COP error scale [mm] of the normalised map: the COP noise of a plate at 0.5 % BW force noise
(see ``gc_ocp.bench.recovery``), the size of a typical well-fitted COP error."""

CELLS = (*PHASES, "all")


def stance_residuals(fits: list, weights: Weights | None = None) -> list[dict]:
    """Per stance: ``{"label", "side", "time", "phase", "bounds", "method", "pct", "weighted",
    "in_contact", "cop_err_mm"}``: the residual (model - measured) in % BW / % BW x H (columns
    in :data:`CHANNELS` order) and in units of the error scale, the phase of every frame and the
    COP error [mm] (NaN where not compared)."""
    weights = weights or Weights()
    cols = [WRENCH_COLUMN[c] for c in CHANNELS]
    out = []
    for f in fits:
        meas, mod = np.asarray(f["measured"]), np.asarray(f["model"])
        bw, h = f["body_weight"], f["height"]
        res = fit_error(f)
        pct = 100 * res / np.array([bw, bw, bw, bw * h, bw * h, bw * h])
        wres = weights.residuals(f)
        inc = np.asarray(f["in_contact"], bool)
        bounds, method = phase_bounds(f["time"], meas[:, 2], inc)
        ref, gh = f["reference_point"], f["ground_height"]
        c_meas = cop_from_wrench(meas[:, :3], meas[:, 3:], ref, gh, COP_MIN_FRACTION_BW * bw)
        c_mod = cop_from_wrench(mod[:, :3], mod[:, 3:], ref, gh, 1e-6)
        cop = np.linalg.norm((c_meas - c_mod)[:, :2], axis=1) * 1e3
        out.append(
            {
                "label": f["label"],
                "side": f["side"],
                "time": np.asarray(f["time"], float),
                "phase": phase_index(f["time"], bounds),
                "bounds": bounds,
                "method": method,
                "pct": pct[:, cols],
                "weighted": wres[:, cols],
                "in_contact": inc,
                "cop_err_mm": cop,
            }
        )
    return out


def _rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(a**2))) if a.size else float("nan")


def where(fits: list, weights: Weights | None = None) -> dict:
    """The residual map of ``fits`` (see the module doc): ``{"phases", "rms", "normalised",
    "share", "phase_method"}`` with ``rms[side][key][cell]`` for the six ``fit.json`` channel
    keys and ``"cop_mm"``, cells the four phases and ``"all"``."""
    per = stance_residuals(fits, weights)
    rms: dict = {}
    norm: dict = {}
    share: dict = {}
    for side in SIDES:
        mine = [r for r in per if r["side"] == side]
        if not mine:
            continue
        rms[side], norm[side], share[side] = {}, {}, {}
        total = sum(float(np.sum(r["weighted"][r["in_contact"]] ** 2)) for r in mine)
        for j, ch in enumerate(CHANNELS):
            key = TABLE_KEYS[ch]
            rms[side][key], norm[side][key], share[side][key] = {}, {}, {}
            for k, cell in enumerate(CELLS):
                sel = [
                    r["in_contact"] & ((r["phase"] == k) if cell != "all" else True) for r in mine
                ]
                p = np.concatenate([r["pct"][s, j] for r, s in zip(mine, sel, strict=True)])
                w = np.concatenate([r["weighted"][s, j] for r, s in zip(mine, sel, strict=True)])
                rms[side][key][cell] = _rms(p)
                norm[side][key][cell] = _rms(w)
                share[side][key][cell] = float(np.sum(w**2) / total) if total > 0 else 0.0
        rms[side]["cop_mm"], norm[side]["cop_mm"] = {}, {}
        for k, cell in enumerate(CELLS):
            e = np.concatenate(
                [
                    r["cop_err_mm"][
                        r["in_contact"] & ((r["phase"] == k) if cell != "all" else True)
                    ]
                    for r in mine
                ]
            )
            e = e[np.isfinite(e)]
            rms[side]["cop_mm"][cell] = _rms(e)
            norm[side]["cop_mm"][cell] = _rms(e) / COP_SCALE_MM
    return {
        "phases": list(PHASES),
        "rms": rms,
        "normalised": norm,
        "share": share,
        "phase_method": {r["label"]: r["method"] for r in per},
    }


def heatmap_figure(w: dict, title: str = "Where the residual lies"):
    """Heat map of the normalised RMS: rows foot x channel (and COP), columns the four phases
    and the whole stance; each cell annotated with its RMS in % BW, % BW x H or mm."""
    from matplotlib.figure import Figure

    rows, vals, texts = [], [], []
    for side, chans in w["normalised"].items():
        for key, cells in chans.items():
            rows.append(f"{side} {channel_name(key)}")  # words, as the page's tables
            vals.append([cells[c] for c in CELLS])
            texts.append([w["rms"][side][key][c] for c in CELLS])
    v = np.array(vals, float)
    fig = Figure(figsize=(7.5, 0.32 * len(rows) + 1.6), layout="constrained")
    ax = fig.subplots()
    im = ax.imshow(np.nan_to_num(v), aspect="auto", cmap="magma_r", vmin=0.0)
    ax.set_xticks(range(len(CELLS)), [c.replace("_", " ") for c in CELLS], rotation=20)
    ax.set_yticks(range(len(rows)), rows, fontsize=8)
    vmax = float(np.nanmax(v)) if np.isfinite(v).any() else 1.0
    for i in range(v.shape[0]):
        for j in range(v.shape[1]):
            if np.isfinite(texts[i][j]):
                ax.text(
                    j,
                    i,
                    f"{texts[i][j]:.2g}",
                    ha="center",
                    va="center",
                    fontsize=7,
                    color="white" if v[i, j] > 0.6 * vmax else "black",
                )
    fig.colorbar(im, ax=ax, label="RMS / error scale (COP: / 20 mm)")
    ax.set_title(title + "\n(cells: RMS in % BW, % BW×H, COP mm)", fontsize=10)
    return fig


def residual_figure(
    fits: list,
    channels: tuple[str, ...] = ("superior_force", "anterior_force", "mediolateral_torque"),
    weights: Weights | None = None,
    max_stances: int = 6,
):
    """Residual (model - measured) over time, one panel per stance (at most ``max_stances``),
    ``channels`` as lines (% BW or % BW x H), the four phases shaded."""
    from matplotlib.figure import Figure

    per = stance_residuals(fits, weights)[:max_stances]
    fig = Figure(figsize=(7.5, 1.9 * len(per) + 0.6), layout="constrained")
    axes = fig.subplots(len(per), 1, squeeze=False)
    shades = ("#dbe9f6", "#f6f2db", "#e3f6db", "#f6dbe6")
    for ax, r in zip(axes[:, 0], per, strict=True):
        b = r["bounds"]
        for k, name in enumerate(PHASES):
            ax.axvspan(b[k], b[k + 1], color=shades[k], label=name.replace("_", " "))
        for ch in channels:
            j = CHANNELS.index(ch)
            ax.plot(r["time"], r["pct"][:, j], lw=1.2, label=ch.replace("_", " "))
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel("model − measured\n[% BW (×H)]")
        ax.set_title(f"{r['label']} (phases from {r['method']})", fontsize=9)
    axes[-1, 0].set_xlabel("time [s]")
    # the legend above the panels, not over the first stance's residual (the constrained
    # layout makes room for it: "outside")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, ncol=4, loc="outside upper center", frameon=False)
    return fig


__all__ = (
    "COP_SCALE_MM",
    "heatmap_figure",
    "residual_figure",
    "stance_residuals",
    "where",
)
