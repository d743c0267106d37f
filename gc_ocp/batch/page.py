"""A study's summary page (``OUT/summary.html``): the table of every subject and foot, each
subject's fit report linked, and the distributions across subjects (per-unit force at the
reference depth, RMS per channel, the effects the diagnoses name). Self-contained as every page
of the package (:mod:`gc_ocp.html`): CSS inline, figures embedded; the only links are to the
subjects' own reports beside it (``<subject>/report.html``)."""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence

from gc_ocp.batch.summary import CHANNELS, UNITS
from gc_ocp.html import data_uri, environment, pngs

TEMPLATE = "summary.html.j2"
SHORT = {
    "anterior_force_pct_bw": "anterior F",
    "superior_force_pct_bw": "superior F",
    "lateral_force_pct_bw": "lateral F",
    "anteroposterior_torque_pct_bwh": "AP torque",
    "longitudinal_torque_pct_bwh": "long. torque",
    "mediolateral_torque_pct_bwh": "ML torque",
}


def _finite(values) -> list[float]:
    return [float(v) for v in values if v is not None and math.isfinite(float(v))]


def _positive(values) -> list[float]:
    return [x for x in _finite(values) if x > 0]


def _not_identified(row: dict, unit: str) -> bool:
    """The summary row names ``unit`` among its ``units_not_identified`` (``"PM; AM"``)."""
    return unit in str(row.get("units_not_identified") or "").split("; ")


def summary_figures(rows: Sequence[dict]) -> dict:
    """The page's figures (matplotlib Figures, not pyplot's: nothing to close): ``units`` (each unit's force at
    the reference depth across subjects, per foot), ``rms`` (in-sample and held-out RMS per
    channel across subjects and feet) and, when any subject was diagnosed, ``effects`` (how many
    diagnoses name each effect)."""
    from matplotlib.figure import Figure

    ok = [r for r in rows if r["status"] == "done"]
    figs = {}
    fig = Figure(figsize=(8, 3.6), layout="constrained")
    ax = fig.subplots()
    plotted = False
    for j, foot in enumerate(("left", "right")):
        for i, u in enumerate(UNITS):
            feet = [r for r in ok if r["foot"] == foot]
            # a unit the fit calls not identified: its f_ref means nothing beside its SE, so it
            # is drawn (hollow) but kept out of the median, as the summary's columns advise
            free = [_not_identified(r, u) for r in feet]
            v = _positive(r[f"f_ref_{u}_N"] for r, f in zip(feet, free, strict=True) if not f)
            w = _positive(r[f"f_ref_{u}_N"] for r, f in zip(feet, free, strict=True) if f)
            x = i + (j - 0.5) * 0.3
            ax.plot([x] * len(v), v, "o", alpha=0.6, color=f"C{j}", label=foot if i == 0 else None)
            ax.plot([x] * len(w), w, "o", mfc="none", color=f"C{j}", alpha=0.6)
            plotted = plotted or bool(v or w)
            if v:
                ax.plot([x - 0.12, x + 0.12], [sorted(v)[len(v) // 2]] * 2, color="k", lw=2)
    ax.set_xticks(range(len(UNITS)), UNITS)
    if plotted:  # (no subject fitted: nothing to put on a log axis, which refuses to draw)
        ax.set_yscale("log")  # a unit its stances hardly load can sit decades above the others
    else:
        ax.text(0.5, 0.5, "no subject fitted", ha="center", va="center", transform=ax.transAxes)
    ax.set_ylabel("force at the reference depth [N]")
    ax.set_title(  # (the caption says what the bar and the hollow points are)
        "contact units across subjects" + (" (log scale)" if plotted else "")
    )
    ax.legend()
    figs["units"] = fig
    fig = Figure(figsize=(8, 3.6), layout="constrained")
    ax = fig.subplots()
    for k, (prefix, label) in enumerate((("rms_", "in-sample"), ("heldout_rms_", "held-out"))):
        data = [_finite(r[prefix + c] for r in ok) for c in CHANNELS]
        pos = [i + (k - 0.5) * 0.35 for i in range(len(CHANNELS))]
        keep = [(p, d) for p, d in zip(pos, data, strict=True) if d]
        if keep:
            bp = ax.boxplot(
                [d for _, d in keep], positions=[p for p, _ in keep], widths=0.3, patch_artist=True
            )
            for b in bp["boxes"]:
                b.set_facecolor(f"C{k}")
                b.set_alpha(0.5)
        ax.plot([], [], "s", color=f"C{k}", alpha=0.5, label=label)
    if not ok:
        ax.text(0.5, 0.5, "no subject fitted", ha="center", va="center", transform=ax.transAxes)
    ax.set_xticks(range(len(CHANNELS)), [SHORT[c] for c in CHANNELS])
    ax.set_ylabel("RMS [% BW; torques % BW x height]")
    ax.set_title("fit error across subjects and feet")
    ax.legend()
    figs["rms"] = fig
    named = _named(rows)
    if named:
        fig = Figure(figsize=(6, 0.4 * len(named) + 1.2), layout="constrained")
        ax = fig.subplots()
        names = list(named)
        ax.barh(names, [named[n] for n in names], color="C2")
        ax.invert_yaxis()
        ax.set_xlabel("subjects whose diagnosis names it")
        ax.set_title("effects named by the diagnoses")
        figs["effects"] = fig
    return figs


def _named(rows: Sequence[dict]) -> dict[str, int]:
    """How many diagnosed subjects name each effect (``none``: those that name none)."""
    per_subject = {
        r["subject"]: r["diagnosis_selected"] for r in rows if r.get("diagnosis_selected")
    }
    counts: Counter = Counter()
    for sel in per_subject.values():
        counts.update(s.strip() for s in sel.split(","))
    return dict(counts.most_common())


def summary_html(rows: Sequence[dict], subjects: Sequence[dict], seconds: float) -> str:
    """The page (module doc) of a study's ``rows`` (:data:`~gc_ocp.batch.summary.COLUMNS`) and
    per-subject outcomes (``BatchResult.subjects``)."""
    images = pngs(summary_figures(rows))
    counts = Counter(s["status"] for s in subjects)
    return (
        environment()
        .get_template(TEMPLATE)
        .render(
            title=f"Study: {len(subjects)} subjects",
            counts=dict(counts),
            seconds=seconds,
            rows=rows,
            failed=[s for s in subjects if s["status"] == "failed"],
            channels=[(c, SHORT[c]) for c in CHANNELS],
            named=_named(rows),
            figures={k: data_uri(v) for k, v in images.items()},
        )
    )


__all__ = ("TEMPLATE", "summary_figures", "summary_html")
