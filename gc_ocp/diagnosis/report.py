"""The diagnosis as one self-contained HTML page a researcher reads without Python.

>>> from gc_ocp.diagnosis.report import write_report
>>> # skipped: it needs a diagnosis with its final fit (gc_ocp.diagnose: minutes of fits)
>>> path = write_report(diagnosis, "report.html")         # doctest: +SKIP

The page holds: where the gap is (heat map, residual over time, the worst cells in words), the
ranked effects (held-out reduction with its 95 % interval, in-sample reduction, parameters
added, pass/fail, confounded effects in plain words), the waterfall (figure and table per
channel), the final model's fit and parameters, the decision rule and fold scheme, the notes and
flags, and the provenance. Figures are embedded as base64 PNG (``data:`` URIs); the CSS is inline;
there is no script and no link to anything outside the file, so it can be mailed or archived as
is.

The markup is the jinja2 template ``templates/report.html.j2`` (autoescaped); this module
prepares what it shows (:func:`page_context`: numbers, groups, verdicts, figures) and formats
numbers (the template's ``num`` filter).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from gc_ocp.contact.channels import channel_name, channel_unit
from gc_ocp.diagnosis import selection
from gc_ocp.diagnosis.compare import BLOCK_SECONDS, MIN_CLUSTERS, resamples_stances
from gc_ocp.diagnosis.mismatch import MismatchFamily
from gc_ocp.diagnosis.null import DRAWS_PER_LOOK, MISMATCH_DRAWS, PRACTICAL_FACTOR
from gc_ocp.html import FIGURE_DPI, data_uri, environment, pngs, provenance_context
from gc_ocp.html.fit_tables import (
    CHANNEL_KEYS,
    fmt_num,
    model_tables,
    rms_table,
)
from gc_ocp.outputs import atomic_write_text
from gc_ocp.trial import SIDES

TEMPLATE = "report.html.j2"
"""The page's template, in ``gc_ocp/diagnosis/templates``."""


# --- figures ---------------------------------------------------------------------------------
def report_figures(diagnosis) -> dict:
    """The report's figures as matplotlib figures: ``heatmap`` (base, held-out), ``residuals``
    (base, held-out, over time), ``ranking``, ``waterfall`` and, when an effect was selected,
    ``heatmap_final`` (not pyplot's: nothing to close). A diagnosis read back from ``diagnosis.json``
    (:meth:`~gc_ocp.diagnosis.result.Diagnosis.from_json`) has no fits: no ``residuals``
    (the page says so)."""
    figs = {
        "heatmap": diagnosis.heatmap("base"),
        "ranking": diagnosis.ranking_figure(),
        "waterfall": diagnosis.waterfall_figure(),
    }
    if "base" in diagnosis.evaluations:
        figs["residuals"] = diagnosis.residual_figure("base")
    if diagnosis.selected:
        figs["heatmap_final"] = diagnosis.heatmap("final")
    return figs


def report_pngs(diagnosis, dpi: int = FIGURE_DPI) -> dict[str, bytes]:
    """:func:`report_figures` rendered as PNG bytes: what the page
    embeds and what the CLI writes beside it."""
    return pngs(report_figures(diagnosis), dpi)


# --- what the page says, as data -------------------------------------------------------------
def worst_cells(where: dict, n: int = 3) -> dict:
    """Per foot, the ``n`` (channel, phase) cells holding the largest share of the foot's
    weighted squared residual: ``{side: [(channel key, phase, share, rms), ...]}``, and the
    phase with the largest COP error: ``{side: ... , "cop": {side: (phase, mm)}}``."""
    out: dict = {"cop": {}}
    for side, chans in where.get("share", {}).items():
        cells = [
            (key, ph, share, where["rms"][side][key][ph])
            for key, by_phase in chans.items()
            for ph, share in by_phase.items()
            if ph != "all"
        ]
        cells.sort(key=lambda c: -c[2])
        out[side] = cells[:n]
        cop = where["rms"][side].get("cop_mm", {})
        finite = [(ph, v) for ph, v in cop.items() if ph != "all" and math.isfinite(v)]
        if finite:
            out["cop"][side] = max(finite, key=lambda c: c[1])
    return out


def _where(where: dict) -> dict:
    """Section 1 in words: per mapped foot its worst cells and COP phase, the feet not mapped,
    the stances whose phases fell back to Perry's fractions."""
    w = worst_cells(where)
    feet = [
        {
            "side": side,
            "cells": [
                {
                    "share": share,
                    "channel": channel_name(key),
                    "phase": ph.replace("_", " "),
                    "rms": rms,
                    "unit": channel_unit(key),
                }
                for key, ph, share, rms in w[side]
            ],
            "cop": w["cop"].get(side),
        }
        for side in w
        if side != "cop" and w[side]
    ]
    methods = where.get("phase_method", {})
    return {
        "feet": feet,
        "missing": [s for s in SIDES if s not in where.get("share", {})],
        "fallback": [lab for lab, m in methods.items() if m != "force"],
    }


def confounded_groups(ranking: list) -> list[list[str]]:
    """The candidate effects flagged as confounded with each other, as groups in which every
    two are flagged (so a group can be read as "any one of these"; an effect may sit in two
    groups), each group and the groups in ranking order. A confounding with a part of the base
    (its per-stance nuisance) is not a group: :func:`_nuisance` says it."""
    order = [r.effect for r in ranking]
    linked = set()
    for r in ranking:
        for other in r.confounded_with:
            if other in order and other != r.effect:
                linked.add(frozenset((r.effect, other)))
    edges = sorted(linked, key=lambda e: sorted(order.index(x) for x in e))
    groups: list[list[str]] = []
    covered: set = set()
    for edge in edges:
        if edge in covered:
            continue
        group = sorted(edge, key=order.index)
        for c in order:
            if c not in group and all(frozenset((c, g)) in linked for g in group):
                group.append(c)
        group.sort(key=order.index)
        covered |= {frozenset((a, b)) for a in group for b in group if a != b}
        groups.append(group)
    return groups


def _groups(ranking: list, selected: list[str]) -> list[dict]:
    """Each confounded group, with what the selection made of it: ``chosen`` (the one selected
    member, if exactly one), ``others`` (the rest, for "chosen or others"), ``none_passes``."""
    out = []
    for g in confounded_groups(ranking):
        chosen = [x for x in g if x in selected]
        one = chosen[0] if len(chosen) == 1 else None
        out.append(
            {
                "effects": g,
                "chosen": one,
                "others": " or ".join(x for x in g if x != one),
                "none_passes": not chosen and not any(r.passes for r in ranking if r.effect in g),
            }
        )
    return out


def _nuisance(ranking: list) -> list[dict]:
    """Effects confounded with a part of the base (not a candidate): the base's per-stance
    nuisance, when the effect's held-out gain comes mostly from a cheaper nuisance."""
    names = {r.effect for r in ranking}
    items = []
    for r in ranking:
        parts = [c for c in r.confounded_with if c not in names]
        if parts:
            items.append({"effect": r.effect, "parts": parts, "share": r.gain_from_nuisance})
    return items


def _verdict(r, draws: int | None = None) -> str:
    """The decision rule's outcome for a ranking row, in words (the row's own verdict; ``draws``:
    :attr:`~gc_ocp.diagnosis.result.Diagnosis.steps_draws`)."""
    if r.not_evaluable is not None:
        return f"not evaluable on these data: {r.not_evaluable}"
    return r.verdict(draws)


def _table(rows: list, draws: int | None) -> list[dict]:
    """A round's rows as the ranking table shows them."""
    return [{"row": r, "verdict": _verdict(r, draws), "flags": sorted(set(r.flags))} for r in rows]


def _change(a, b) -> str:
    """Relative change [%] from ``a`` to ``b``, rounded; "0" for a signed zero."""
    ok = all(isinstance(v, (int, float)) and math.isfinite(v) for v in (a, b)) and a > 0
    pct = fmt_num(100 * (b - a) / a, "+.0f") if ok else "–"
    return "0" if pct in ("+0", "-0") else pct


def _waterfall(waterfall: list) -> list[dict]:
    """The waterfall table's rows: both feet's superior force, then each foot's channels."""
    sup = [w.heldout_superior_force_pct_bw for w in waterfall]
    rows = [{"foot": "both", "channel": "superior force [% BW]", "values": sup, "bold": True}]
    for side in waterfall[0].heldout_rms if waterfall else []:
        for key in CHANNEL_KEYS:
            vals = [w.heldout_rms.get(side, {}).get(key, float("nan")) for w in waterfall]
            channel = f"{channel_name(key)} [{channel_unit(key)}]"
            rows.append({"foot": side, "channel": channel, "values": vals, "bold": False})
    for row in rows:
        row["change"] = _change(row["values"][0], row["values"][-1])
    return rows


def _draws(calibration: list) -> str:
    """How many mismatch draws a round's null has: those made (every round's the same), or up
    to those planned when a round stopped early."""
    if any(c.get("null_stopped_early") for c in calibration):
        return f"up to {max(c.get('mismatch_draws_planned', 0) for c in calibration)}"
    return str(calibration[0]["mismatch_draws"])


def _plates(family: dict | None) -> str:
    """The method's words on the family's opt-in plate calibration member, when it was on."""
    f = None if family is None else MismatchFamily.from_json(family)
    if f is None or not f.plate_calibration:
        return ""
    lo, hi = (1e3 * f.scale * v for v in f.plate_offset)  # [mm], as drawn (MismatchFamily.draw)
    return (
        f", every stance also recorded by a plate {lo:g}-{hi:g} mm off with its channels within "
        f"\u00b1{100 * f.scale * f.plate_gain:g} %: the family's plate calibration member"
    )


def _stopped(calibration: list) -> str:
    """The method's sentence on the rounds whose null draws stopped early or were not made
    (none: empty)."""
    made = [c.get("mismatch_draws") for c in calibration]
    out = ""
    if any(c.get("null_stopped_early") for c in calibration):
        out += (
            f"; a round's draws stop early, a look every {DRAWS_PER_LOOK}, once no candidate the "
            "effect-size floor leaves could be named whatever the rest would give (draws made per "
            f"round: {', '.join(str(m) for m in made)}): a stopped round's p-values are from the "
            "draws made"
        )
    skipped = [str(k) for k, c in enumerate(calibration, 1) if c.get("not_tested")]
    if skipped:
        out += (
            f"; round {', '.join(skipped)} made no draws: none of its candidates clears the "
            "effect-size floor, nor would with more stances, so no draw could name one (they "
            "are not tested)"
        )
    return out


def _method(d) -> dict:
    """The numbers of the method section: the rule, the bootstrap and the confounding criteria
    as the code applies them (the constants of :mod:`.selection` and :mod:`.compare`)."""
    f = d.folds
    # the stances the bootstrap draws from: the held-out ones, or all of them in-sample
    n_scored = len(f.get("heldout", []) if f.get("n") else f.get("stances", []))
    refit = any(c.get("null_fits") == "refit" for c in d.calibration)
    return {
        "refit": refit,
        "statistic": "refit" if refit else "one-step",
        "alpha": f"{d.alpha:g}",
        "floor": f"{d.floor_pct:g} %",
        "replicates": d.calibration[0]["replicates"] if d.calibration else "–",
        "mismatch": (
            f", plus one of {_draws(d.calibration)} draws of the mismatch family "
            "(the parent slightly changed in ways that are not candidates"
            + _plates(d.mismatch_family)
            + "; "
            + (
                "each replicate is one draw's data with its own residual blocks)"
                if refit
                else "for each draw the parent is refitted to the data it makes, and the draw's "
                "replicates are scored from that refit)"
            )
            + _stopped(d.calibration)
            if d.calibration and d.calibration[0].get("mismatch_draws")
            else ""
        ),
        "block": f"{BLOCK_SECONDS * 1000:.0f} ms blocks",
        "block_ms": f"{BLOCK_SECONDS * 1000:.0f} ms",
        "which": "held-out " if f.get("n") else "",
        "n_scored": n_scored,
        "resamples": resamples_stances(n_scored),
        "min_clusters": MIN_CLUSTERS,
        "cosine": f"{selection.CONFOUND_COSINE:g}",
        "comparable_pct": f"{100 * selection.COMPARABLE_FRACTION:.0f}",
        "non_additive_pct": f"{100 * selection.NON_ADDITIVE_FRACTION:.0f}",
        "nuisance_pct": f"{100 * selection.NUISANCE_SHARE:.0f}",
        # a follow-up of at most this many times the data: inconclusive (null.PRACTICAL_FACTOR)
        "follow_up": PRACTICAL_FACTOR + 1,
    }


def page_context(d, res, provenance: dict | None, pngs: dict) -> dict:
    """Everything the template shows, prepared: ``d`` a
    :class:`~gc_ocp.diagnosis.result.Diagnosis`, ``res`` its final model's fit on all stances,
    ``provenance`` the CLI's record (or ``None``), ``pngs`` the figures as PNG bytes."""
    wf = d.waterfall
    steps = []
    for k, name in enumerate(d.selected):
        steps.append(next(x for x in d.rounds[k] if x.effect == name))
    return {
        "d": d,
        "title": f"Diagnosis: {d.base} model vs the force plates",
        "held": "held-out" if d.folds.get("n") else "in-sample",
        "steps": steps,
        "passing": d.passing_unselected,
        "default_draws": MISMATCH_DRAWS,  # said beside d.draws_too_few
        "base_sup": wf[0].heldout_superior_force_pct_bw,
        "final_sup": wf[-1].heldout_superior_force_pct_bw,
        "groups": _groups(d.ranking, d.selected),
        "nuisance": _nuisance(d.ranking),
        "where": _where(d.where["base"]),
        "ranking": _table(d.ranking, d.steps_draws),
        "inconclusive": [
            r for r in (d.rounds[-1] if d.rounds else []) if r.effect in d.inconclusive
        ],
        "later_rounds": [
            (" + ".join(["base", *d.selected[: k - 1]]), _table(rows, d.steps_draws))
            for k, rows in enumerate(d.rounds[1:], 2)
        ],
        "waterfall": _waterfall(wf),
        "figures": {name: data_uri(png) for name, png in pngs.items()},
        "res": res,
        "rms": rms_table(res, wf[-1].heldout_rms if d.folds.get("n") else None),
        **model_tables(res, provenance),
        "method": _method(d),
        "provenance": provenance_context(provenance),
    }


def _environment():
    """The page's jinja2 environment (:func:`gc_ocp.html.environment`)."""
    return environment("gc_ocp.diagnosis")


# --- the page --------------------------------------------------------------------------------
def report_html(
    diagnosis, provenance: dict | None = None, pngs: dict | None = None, final=None
) -> str:
    """The report of ``diagnosis`` (a :class:`~gc_ocp.diagnosis.Diagnosis`) as one
    self-contained HTML page (module doc). provenance: what the CLI records in
    ``diagnosis.json`` (inputs, options, date); pngs: :func:`report_pngs` of the diagnosis
    when already rendered (otherwise they are rendered here); final: the final model's fit on
    all stances (default: the diagnosis's own, ``final_evaluation.full``; give it for a
    diagnosis read back from JSON, with ``final_fit.json``)."""
    figs = report_pngs(diagnosis) if pngs is None else pngs
    res = diagnosis.final_evaluation.full if final is None else final
    context = page_context(diagnosis, res, provenance, figs)
    return _environment().get_template(TEMPLATE).render(context)


def write_report(
    diagnosis,
    path: str | os.PathLike,
    provenance: dict | None = None,
    pngs: dict | None = None,
) -> Path:
    """Write :func:`report_html` of ``diagnosis`` to ``path`` atomically; returns the path."""
    return atomic_write_text(path, report_html(diagnosis, provenance, pngs))


__all__ = (
    "CHANNEL_KEYS",
    "TEMPLATE",
    "confounded_groups",
    "page_context",
    "report_figures",
    "report_html",
    "report_pngs",
    "worst_cells",
    "write_report",
)
