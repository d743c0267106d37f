"""Figures of the contact model. Every function returns a :class:`matplotlib.figure.Figure`;
nothing is shown or saved here."""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from gc_ocp.contact.channels import CHANNELS, WRENCH_COLUMN
from gc_ocp.errors import InputError
from gc_ocp.foot import SEED_LAYOUT, SoleLayout

_UNIT_LABEL = {
    "anterior_force": "N",
    "superior_force": "N",
    "lateral_force": "N",
    "anteroposterior_torque": "N·m",
    "longitudinal_torque": "N·m",
    "mediolateral_torque": "N·m",
}
_PCT_LABEL = {
    ch: "% BW" if unit == "N" else "% BW×H" for ch, unit in _UNIT_LABEL.items()
}  # the same channels normalised (:func:`plot_wrench_fit`'s ``normalisers``)


def plot_wrench_fit(
    times,
    measured,
    simulated,
    sides=None,
    labels=None,
    title: str = "",
    normalisers=None,
) -> Figure:
    """Measured (solid) vs modelled (dashed) wrench, six channels (rows) per foot (columns).

    times, measured, simulated: one stance each as ``(n,)``, ``(n, 6)``, ``(n, 6)`` ``lab``
    wrenches ([s], [N], [N·m]), or sequences of these for several stances. sides: side of each
    stance (``"left"``/``"right"``), one column per side; default one column. labels: legend text
    per stance (one colour each; the legend sits below each column, off the curves).
    normalisers: per stance ``(BW [N], BW x H [N·m])``: the channels are then drawn in % BW and
    % BW x H (the package's reporting unit, as every RMS it prints); default: N and N·m.
    Channels follow :data:`~gc_ocp.contact.channels.CHANNELS`.
    """
    if np.ndim(times[0]) == 0:  # a single stance
        times, measured, simulated = [times], [measured], [simulated]
        normalisers = None if normalisers is None else [normalisers]
    n_st = len(times)
    if not (len(measured) == len(simulated) == n_st):
        raise InputError(
            f"times, measured, simulated must have the same number of stances, "
            f"but got {n_st}, {len(measured)}, {len(simulated)}"
        )
    if normalisers is not None and len(normalisers) != n_st:
        raise InputError(
            f"normalisers must give one (BW, BW x H) per stance ({n_st}), "
            f"but got {len(normalisers)}"
        )
    sides = list(sides) if sides is not None else ["foot"] * n_st
    cols = list(dict.fromkeys(sides))
    fig = Figure(figsize=(4.5 * len(cols), 11), layout="constrained")
    axes = fig.subplots(len(CHANNELS), len(cols), sharex="col", squeeze=False)
    handles: dict[int, list] = {j: [] for j in range(len(cols))}
    for s in range(n_st):
        j = cols.index(sides[s])
        t = np.asarray(times[s])
        m, q = np.asarray(measured[s], float), np.asarray(simulated[s], float)
        if normalisers is not None:
            bw, bwh = normalisers[s]
            scale = 100.0 / np.array([bw, bw, bw, bwh, bwh, bwh])
            m, q = m * scale, q * scale
        lab = labels[s] if labels is not None else f"stance {s + 1}"
        for i, ch in enumerate(CHANNELS):
            ax = axes[i, j]
            c = WRENCH_COLUMN[ch]
            (line,) = ax.plot(t, m[:, c], lw=1.5)
            ax.plot(t, q[:, c], lw=1.2, ls="--", color=line.get_color())
            if i == 0:
                handles[j].append(Line2D([], [], color=line.get_color(), lw=1.5, label=lab))
    unit = _PCT_LABEL if normalisers is not None else _UNIT_LABEL
    for j, side in enumerate(cols):
        axes[0, j].set_title(side)
        axes[-1, j].set_xlabel("time [s]")
        for i, ch in enumerate(CHANNELS):
            # two lines: "anteroposterior torque [% BW×H]" on one ran into the next row's
            axes[i, j].set_ylabel(f"{ch.replace('_', ' ')}\n[{unit[ch]}]", fontsize=8)
            axes[i, j].grid(alpha=0.3)
        # below the column, never over a curve: one entry per stance (its colour) and the key
        # to the line styles (a legend inside the axes covered the second stance's curve)
        key = [
            Line2D([], [], color="k", lw=1.5, label="measured"),
            Line2D([], [], color="k", lw=1.2, ls="--", label="model"),
        ]
        entries = handles[j] + key
        axes[-1, j].legend(
            handles=entries,
            loc="upper center",
            bbox_to_anchor=(0.5, -0.3),
            ncol=min(4, len(entries)),
            fontsize=7,
            frameon=False,
        )
    if title:
        fig.suptitle(title)
    return fig


LABEL_GAP_PT = 4.0
"""Gap [pt] between a unit's marker disk and its label in :func:`plot_sole`."""


def _kilo_newton_per_metre(k: float) -> str:
    return f"{k / 1000:.1f} kN/m"


def plot_sole(
    points_local_by_side: Mapping[str, np.ndarray],
    k: Mapping[str, Mapping[str, float]] | None = None,
    toes_offset: Mapping[str, np.ndarray] | None = None,
    title: str = "",
    layout: SoleLayout = SEED_LAYOUT,
    label: Callable[[float], str] | None = None,
) -> Figure:
    """Top view of each sole with its units, labelled with their stiffness.

    points_local_by_side: ``{side: (m, 3)}`` unit positions in their parent frame [m] (x
    anterior, y left), one row per unit of ``layout``; k: ``{side: {unit: value}}``, each
    unit's stiffness (the seed's linear k [N/m] by default) or, with ``label`` (how a value is
    printed, with its unit), another measure of it such as the force at a reference depth;
    toes_offset: ``{side: (3,)}`` toes-frame origin in the hindfoot frame [m], added to the units
    on the toes (default: drawn as given). Negative k is drawn hollow. The outline joins the
    units in angular order about their centroid.
    """
    sides = list(points_local_by_side)
    fig = Figure(figsize=(3.5 * len(sides), 5), layout="constrained")
    axes = fig.subplots(1, len(sides), squeeze=False)[0]
    for ax, side in zip(axes, sides, strict=True):
        pts = np.array(points_local_by_side[side], dtype=float)
        if pts.shape != (layout.n, 3):
            raise InputError(
                f"points_local_by_side[{side!r}] must have shape ({layout.n}, 3) for the units "
                f"{layout.units}, but got {pts.shape}"
            )
        if toes_offset is not None and side in toes_offset:
            pts[list(layout.on("toes"))] += np.asarray(toes_offset[side], dtype=float)
        c = pts[:, :2].mean(axis=0)
        order = list(np.argsort(np.arctan2(pts[:, 1] - c[1], pts[:, 0] - c[0])))
        order.append(order[0])
        ax.plot(pts[order, 1] * 100, pts[order, 0] * 100, color="0.6", lw=1)
        kk = {u: v for u, v in (k.get(side, {}) if k is not None else {}).items() if v is not None}
        kmax = max((abs(v) for v in kk.values()), default=1.0) or 1.0
        for i, u in enumerate(layout.units):
            val = kk.get(u)
            size = 60 + 240 * (abs(val) / kmax if val is not None else 0.3)
            hollow = val is not None and val < 0
            ax.scatter(
                pts[i, 1] * 100,
                pts[i, 0] * 100,
                s=size,
                facecolors="none" if hollow else "C0",
                edgecolors="C0",
                zorder=3,
            )
            text = u if val is None else f"{u}\n{(label or _kilo_newton_per_metre)(val)}"
            # beside the marker's disk, not on it: its radius [pt] (a scatter's size is its
            # area in pt^2) plus a gap; a fixed 8 pt lay over the largest markers (radius 8.7 pt)
            ax.annotate(
                text,
                (pts[i, 1] * 100, pts[i, 0] * 100),
                textcoords="offset points",
                xytext=(np.sqrt(size) / 2 + LABEL_GAP_PT, 0),
                fontsize=8,
                va="center",
            )
        ax.set_aspect("equal")
        ax.invert_xaxis()  # top view: looking down Z, x up the page, y (left) to the left
        ax.set_xlabel("y (left) [cm]")
        ax.set_ylabel("x (anterior) [cm]")
        ax.set_title(side)
        ax.grid(alpha=0.3)
    if title:
        fig.suptitle(title)
    keep_texts_inside(fig)
    return fig


def keep_texts_inside(fig: Figure, pad_px: float = 3.0, rounds: int = 6) -> None:
    """Widen each axes' limits until its texts (a unit's name and value beside its marker)
    lie inside its frame, ``pad_px`` [px] from it: a label beside a unit at the edge of the
    sole ran over the frame ("AL 704 N" on the right foot). The figure is laid out and drawn
    once per round (the texts keep their size in points while the data scale changes, so a few
    rounds settle it); axes without texts are left as they are."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.transforms import Bbox

    canvas = FigureCanvasAgg(fig)
    for _ in range(rounds):
        canvas.draw()
        renderer = canvas.get_renderer()
        moved = False
        for ax in fig.axes:
            texts = [t.get_window_extent(renderer) for t in ax.texts if t.get_text()]
            if not texts:
                continue
            box, need = ax.get_window_extent(renderer), Bbox.union(texts)
            x0, y0 = min(box.x0, need.x0 - pad_px), min(box.y0, need.y0 - pad_px)
            x1, y1 = max(box.x1, need.x1 + pad_px), max(box.y1, need.y1 + pad_px)
            if (x0, y0, x1, y1) == (box.x0, box.y0, box.x1, box.y1):
                continue
            (dx0, dy0), (dx1, dy1) = ax.transData.inverted().transform([(x0, y0), (x1, y1)])
            ax.set_xlim(dx0, dx1)  # display left to right: an inverted axis stays inverted
            ax.set_ylim(dy0, dy1)
            moved = True
        if not moved:
            return
