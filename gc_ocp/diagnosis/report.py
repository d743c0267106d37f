"""The diagnosis as one self-contained HTML page a researcher reads without Python.

>>> from gc_ocp.diagnosis.report import write_report     # doctest: +SKIP
>>> write_report(diagnosis, "report.html")                # doctest: +SKIP

The page holds: where the gap is (heat map, residual over time, the worst cells in words), the
ranked effects (held-out reduction with its 95 % interval, in-sample reduction, parameters
added, pass/fail, confounded effects in plain words), the waterfall (figure and table per
channel), the final model's fit and parameters, the decision rule and fold scheme, the notes and
flags, and the provenance. Figures are embedded as base64 PNG (``data:`` URIs); the CSS is inline;
there is no script and no link to anything outside the file, so it can be mailed or archived as
is.
"""

from __future__ import annotations

import base64
import datetime
import html
import io
import math
import os
from pathlib import Path

from gc_ocp.contact.channels import CHANNELS, TABLE_KEYS
from gc_ocp.trial import SIDES

FIGURE_DPI = 100

_CORE_BLOCKS = ("contact", "sole", "pose", "belt")
"""Blocks of the registered base shown in their own tables; any other block is an effect's."""

_CSS = """
body { font-family: -apple-system, "Segoe UI", Helvetica, Arial, sans-serif; margin: 2em auto;
       max-width: 60em; padding: 0 1em; color: #222; line-height: 1.45; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc;
     padding-bottom: 0.2em; margin-top: 2em; } h3 { margin-bottom: 0.3em; }
.lead { font-size: 1.1em; background: #f4f6f8; padding: 0.7em 1em; border-left: 4px solid #567; }
table { border-collapse: collapse; margin: 0.6em 0 1em; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.55em; text-align: right; }
th { background: #eef1f4; } td.l, th.l { text-align: left; }
tr.pass td { background: #e9f6e9; } .fail { color: #777; }
.warn { background: #fff6e0; border-left: 4px solid #d90; padding: 0.4em 0.8em; margin: 0.5em 0; }
figure { margin: 1em 0; } figure img { max-width: 100%; height: auto; }
figcaption { font-size: 0.88em; color: #555; } code { font-size: 0.92em; }
.small { font-size: 0.85em; color: #555; }
"""


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _num(v, fmt: str = ".2f") -> str:
    if v is None:
        return "–"
    try:
        v = float(v)
    except (TypeError, ValueError):
        return _e(v)
    return "–" if not math.isfinite(v) else format(v, fmt)


def _short(key: str) -> str:
    """``superior_force_pct_bw`` -> ``superior force``."""
    if key == "cop_mm":
        return "COP"
    return key.replace("_pct_bwh", "").replace("_pct_bw", "").replace("_", " ")


def _unit(key: str) -> str:
    if key == "cop_mm":
        return "mm"
    return "% BW×H" if key.endswith("_pct_bwh") else "% BW"


CHANNEL_KEYS = (*(TABLE_KEYS[c] for c in CHANNELS), "cop_mm")
"""The six ``fit.json`` channel keys and the COP, in the order the tables show them."""


# --- figures ---------------------------------------------------------------------------------
def report_figures(diagnosis) -> dict:
    """The report's figures as matplotlib figures: ``heatmap`` (base, held-out), ``residuals``
    (base, held-out, over time), ``ranking``, ``waterfall`` and, when an effect was selected,
    ``heatmap_final``. The caller closes them."""
    figs = {
        "heatmap": diagnosis.heatmap("base"),
        "residuals": diagnosis.residual_figure("base"),
        "ranking": diagnosis.ranking_figure(),
        "waterfall": diagnosis.waterfall_figure(),
    }
    if diagnosis.selected:
        figs["heatmap_final"] = diagnosis.heatmap("final")
    return figs


def report_pngs(diagnosis, dpi: int = FIGURE_DPI) -> dict[str, bytes]:
    """:func:`report_figures` rendered as PNG bytes (the figures are closed): what the page
    embeds and what the CLI writes beside it."""
    import matplotlib.pyplot as plt

    figs = report_figures(diagnosis)
    try:
        out = {}
        for name, fig in figs.items():
            buf = io.BytesIO()
            fig.savefig(buf, format="png", dpi=dpi)
            out[name] = buf.getvalue()
        return out
    finally:
        for fig in figs.values():
            plt.close(fig)


def _data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def _figure(fig, alt: str, caption: str) -> str:
    return (
        f'<figure><img alt="{_e(alt)}" src="{_data_uri(fig)}">'
        f"<figcaption>{caption}</figcaption></figure>"
    )


# --- text pieces -----------------------------------------------------------------------------
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


def _where_text(where: dict) -> str:
    w = worst_cells(where)
    items = []
    for side in (s for s in w if s != "cop"):
        if not w[side]:
            continue
        parts = [
            f"{100 * share:.0f} % in the {_e(_short(key))} during {_e(ph.replace('_', ' '))} "
            f"(RMS {_num(rms)} {_unit(key)})"
            for key, ph, share, rms in w[side]
        ]
        cop = w["cop"].get(side)
        cop_s = (
            f"; its centre of pressure is furthest off in {_e(cop[0].replace('_', ' '))} "
            f"({_num(cop[1], '.1f')} mm RMS)"
            if cop
            else ""
        )
        items.append(
            f"<li><b>{_e(side)} foot</b>: of its weighted misfit, "
            + ", ".join(parts)
            + cop_s
            + ".</li>"
        )
    missing = [s for s in SIDES if s not in where.get("share", {})]
    if missing:
        items.append(
            f"<li>The {' and '.join(missing)} foot has no held-out stance (a single stance: "
            "it is fitted, never held out), so it is not mapped here.</li>"
        )
    if not items:
        return "<p>No held-out residual to map.</p>"
    methods = where.get("phase_method", {})
    fallback = [lab for lab, m in methods.items() if m != "force"]
    phases = (
        "Phases (loading response, mid-stance, terminal stance, pre-swing) are cut at the peaks "
        "and valley of each stance's measured vertical force"
        + (
            f", except for {_e(', '.join(fallback))} (no clear double hump: Perry's average "
            "fractions of stance)."
            if fallback
            else "."
        )
    )
    return (
        "<p>The cells that hold most of the held-out misfit (share of the foot's weighted squared "
        "residual, the quantity the fit minimises):</p><ul>"
        + "".join(items)
        + f"</ul><p class=small>{phases}</p>"
    )


def confounded_groups(ranking: list) -> list[list[str]]:
    """The candidate effects flagged as confounded with each other, as groups in which every
    two are flagged (so a group can be read as "any one of these"; an effect may sit in two
    groups), each group and the groups in ranking order. A confounding with a part of the base
    (its per-stance nuisance) is not a group: :func:`_nuisance_text` says it."""
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


def _and(names: list[str]) -> str:
    b = [f"<b>{_e(n)}</b>" for n in names]
    return b[0] if len(b) == 1 else ", ".join(b[:-1]) + " and " + b[-1]


def _verdict(r: dict, threshold: float) -> str:
    """The decision rule's outcome for a ranking row, with the condition that failed."""
    if r.passes:
        return "pass"
    if r.heldout_rms_reduction_pct is None:
        return f"fail (in-sample below {threshold:g} %: not held out)"
    if r.heldout_rms_reduction_pct < threshold:
        return f"fail (below {threshold:g} %)"
    if r.heldout_rms_reduction_ci[0] <= 0.0:
        return "fail (interval reaches 0)"
    return f"fail (in-sample below {threshold:g} %)"


def _ranking_table(rows: list, threshold: float) -> str:
    head = (
        "<tr><th>#</th><th class=l>effect</th><th>held-out reduction [%]</th>"
        "<th>95 % interval [%]</th><th>in-sample reduction [%]</th><th>parameters added</th>"
        "<th class=l>decision</th><th class=l>confounded with</th><th class=l>fit flags</th></tr>"
    )
    body = []
    for i, r in enumerate(rows, 1):
        lo, hi = r.heldout_rms_reduction_ci
        flags = sorted(set(r.flags))
        body.append(
            f'<tr class="{"pass" if r.passes else "fail"}"><td>{i}</td>'
            f"<td class=l><b>{_e(r.effect)}</b></td>"
            f"<td>{_num(r.heldout_rms_reduction_pct, '+.1f')}</td>"
            f"<td>[{_num(lo, '+.1f')}, {_num(hi, '+.1f')}]</td>"
            f"<td>{_num(r.insample_rms_reduction_pct, '+.1f')}</td>"
            f"<td>{int(r.n_params)}</td><td class=l>{_e(_verdict(r, threshold))}</td>"
            f"<td class=l>{_e(', '.join(r.confounded_with) or '–')}</td>"
            f"<td class=l>{_e(', '.join(flags) or '–')}</td></tr>"
        )
    return "<table>" + head + "".join(body) + "</table>"


def _nuisance_text(ranking: list) -> list[str]:
    """Effects confounded with a part of the base (not a candidate): the base's per-stance
    nuisance, when the effect's held-out gain comes mostly from a cheaper nuisance."""
    names = {r.effect for r in ranking}
    items = []
    for r in ranking:
        parts = [c for c in r.confounded_with if c not in names]
        if not parts:
            continue
        share = r.gain_from_nuisance
        why = (
            f"{100 * share:.0f} % of its held-out gain"
            if share is not None
            else "its held-out gain"
        )
        items.append(
            f"<b>{_e(r.effect)}</b> and the base's {_and(parts)} (the per-stance correction "
            "the base already has) explain the same part of the gap: the data cannot tell them "
            f"apart ({why} comes from the correction moving less, not from a better fit of the "
            "plates)."
        )
    return items


def _confounding_text(ranking: list, selected: list[str]) -> str:
    groups = confounded_groups(ranking)
    nuisance = _nuisance_text(ranking)
    if not groups and not nuisance:
        return (
            "<p>No two candidates explain the same part of the gap (no confounded pair).</p>"
            if len(ranking) > 1
            else ""
        )
    items = []
    for g in groups:
        s = (
            f"{_and(g)} explain the same part of the gap: the data cannot tell "
            f"{'them' if len(g) == 2 else 'these'} apart."
        )
        chosen = [x for x in g if x in selected]
        if len(chosen) == 1:
            others = " or ".join(x for x in g if x != chosen[0])
            s += (
                f" The selection added {_e(chosen[0])}; read it as "
                f"&ldquo;{_e(chosen[0])} or {_e(others)}&rdquo;."
            )
        elif not chosen and not any(r.passes for r in ranking if r.effect in g):
            s += " None of them passes on its own."
        items.append(f"<li>{s}</li>")
    items += [f"<li>{s}</li>" for s in nuisance]
    return '<div class="warn"><b>Ambiguous effects.</b><ul>' + "".join(items) + "</ul></div>"


def _waterfall_table(waterfall: list) -> str:
    sides = list(waterfall[0].heldout_rms) if waterfall else []
    head = "<tr><th class=l>foot</th><th class=l>channel</th>" + "".join(
        f"<th>{_e(w.model)}</th>" for w in waterfall
    )
    head += "<th>change [%]</th></tr>" if len(waterfall) > 1 else "</tr>"

    def change(a, b) -> str:
        if len(waterfall) < 2:
            return ""
        ok = all(isinstance(v, (int, float)) and math.isfinite(v) for v in (a, b)) and a > 0
        pct = _num(100 * (b - a) / a, "+.0f") if ok else "–"
        return f"<td>{'0' if pct in ('+0', '-0') else pct}</td>"

    rows = []
    sup = [w.heldout_superior_force_pct_bw for w in waterfall]
    rows.append(
        "<tr><td class=l>both</td><td class=l>superior force [% BW]</td>"
        + "".join(f"<td><b>{_num(v)}</b></td>" for v in sup)
        + change(sup[0], sup[-1])
        + "</tr>"
    )
    for side in sides:
        for key in CHANNEL_KEYS:
            vals = [w.heldout_rms.get(side, {}).get(key, float("nan")) for w in waterfall]
            rows.append(
                f"<tr><td class=l>{_e(side)}</td><td class=l>{_e(_short(key))} [{_unit(key)}]</td>"
                + "".join(f"<td>{_num(v)}</td>" for v in vals)
                + change(vals[0], vals[-1])
                + "</tr>"
            )
    return "<table>" + head + "".join(rows) + "</table>"


def _rms_table(res, heldout: dict | None) -> str:
    sides = list(res.rms)
    head = "<tr><th class=l>channel</th>" + "".join(
        f"<th>{_e(s)} in-sample</th>" + (f"<th>{_e(s)} held-out</th>" if heldout else "")
        for s in sides
    )
    rows = []
    for key in CHANNEL_KEYS:
        cells = []
        for s in sides:
            v = res.cop_rms_mm.get(s) if key == "cop_mm" else res.rms[s].get(key)
            cells.append(f"<td>{_num(v)}</td>")
            if heldout:
                cells.append(f"<td>{_num(heldout.get(s, {}).get(key, float('nan')))}</td>")
        rows.append(
            f"<tr><td class=l>{_e(_short(key))} [{_unit(key)}]</td>" + "".join(cells) + "</tr>"
        )
    return "<table>" + head + "</tr>" + "".join(rows) + "</table>"


def _pm(d: dict, key: str, fmt: str = ".4g") -> str:
    """``value ± SE`` of ``d[key]`` (``d[key + "_se"]``); a zero SE marks a fixed value."""
    se = d.get(key + "_se", d.get("se_" + key))  # both namings occur (time_offset: se_ms)
    if se is None:
        return _num(d[key], fmt)
    return _num(d[key], fmt) + (" (fixed)" if se == 0 else f" ± {_num(se, '.2g')}")


def _contact_tables(params: dict) -> str:
    rows, extra = [], []
    for side, per in params.items():
        if side == "shared" or not isinstance(per, dict):
            continue
        for unit, e in per.items():
            if isinstance(e, dict) and "k" in e:
                ident = e.get("identified", True)
                rows.append(
                    f"<tr><td class=l>{_e(side)}</td><td class=l>{_e(unit)}</td>"
                    f"<td>{_pm(e, 'k', '.4g')}</td><td>{_pm(e, 'f_ref', '.0f')}</td>"
                    f"<td class=l>{'yes' if ident else '<b>no</b>'}</td></tr>"
                )
        scalars = {
            k: v for k, v in per.items() if not isinstance(v, dict) and not k.endswith("_se")
        }
        if scalars:
            extra.append(
                f"<li>{_e(side)} foot: "
                + ", ".join(f"{_e(k)} = {_pm(per, k)}" for k in scalars)
                + "</li>"
            )
    out = (
        "<h3>Contact units</h3><table><tr><th class=l>foot</th><th class=l>unit</th>"
        "<th>k [N/m<sup>n</sup>] ± SE</th><th>force at 5 mm [N] ± SE</th>"
        "<th class=l>identified</th></tr>" + "".join(rows) + "</table>"
    )
    if extra:
        out += "<p>Per-foot law parameters:</p><ul>"
        out += "".join(extra) + "</ul>"
    shared = params.get("shared", {})
    if shared:
        out += "<h3>Shared parameters</h3><table><tr><th class=l>parameter</th><th>value ± SE</th></tr>"
        out += "".join(
            f"<tr><td class=l>{_e(k)}</td><td>{_pm(shared, k)}</td></tr>"
            for k in shared
            if not k.endswith("_se")
        )
        out += "</table>"
    return out


def _sole_table(sole: dict) -> str:
    off, se = sole.get("offsets_mm", {}), sole.get("se_mm", {})
    if not off:
        return ""
    rows = []
    for side, units in off.items():
        for unit, v in units.items():
            s = se.get(side, {}).get(unit, [float("nan")] * 3)
            rows.append(
                f"<tr><td class=l>{_e(side)}</td><td class=l>{_e(unit)}</td>"
                + "".join(
                    f"<td>{_num(a, '+.1f')} ± {_num(b, '.1f')}</td>"
                    for a, b in zip(v, s, strict=True)
                )
                + "</tr>"
            )
    return (
        "<h3>Sole-point corrections [mm] (foot frame; prior 5 mm)</h3><table><tr>"
        "<th class=l>foot</th><th class=l>unit</th><th>x</th><th>y</th><th>z</th></tr>"
        + "".join(rows)
        + "</table>"
    )


def _flatten(block, prefix: str = "", depth: int = 0) -> list[tuple[str, str]]:
    """Scalar leaves of an effect block as ``(name, "value ± SE")``; long arrays summarised."""
    out: list[tuple[str, str]] = []
    if isinstance(block, dict):
        for k, v in block.items():
            paired = str(k).startswith("se_") and str(k)[3:] in block  # shown with its value
            if str(k).endswith("_se") or paired or depth > 4:
                continue
            name = f"{prefix}{k}"
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                out.append((name, _pm(block, k)))
            else:
                out += _flatten(v, name + " / ", depth + 1)
    elif isinstance(block, (list, tuple)):
        flat = block
        if all(isinstance(x, (int, float)) for x in flat) and len(flat) <= 6:
            out.append((prefix.rstrip(" /"), "[" + ", ".join(_num(x, ".4g") for x in flat) + "]"))
        else:
            out.append((prefix.rstrip(" /"), f"({len(flat)} values)"))
    elif isinstance(block, (str, bool)):
        out.append((prefix.rstrip(" /"), _e(block)))
    return out


def _effect_blocks(res) -> str:
    parts = []
    for name, block in res.blocks.items():
        if name in _CORE_BLOCKS:
            continue
        leaves = _flatten(block)
        rows = "".join(f"<tr><td class=l>{_e(k)}</td><td>{v}</td></tr>" for k, v in leaves)
        parts.append(
            f"<h3>Effect block <code>{_e(name)}</code> ({_e(res.components.get(name, ''))})</h3>"
            + (f"<table><tr><th class=l>parameter</th><th>value ± SE</th></tr>{rows}</table>")
        )
    return "".join(parts)


def _method(d) -> str:
    """The decision rule, the interval and the confounding criteria as the code applies them
    (every number from the constants of :mod:`.selection` and :mod:`.compare`)."""
    from gc_ocp.diagnosis.compare import BLOCK_SECONDS, MIN_CLUSTERS, resamples_stances
    from gc_ocp.diagnosis.selection import (
        COMPARABLE_FRACTION,
        CONFOUND_COSINE,
        NON_ADDITIVE_FRACTION,
        NUISANCE_SHARE,
    )

    f = d.folds
    t = f"{d.threshold_pct:g} %"
    if f.get("n"):
        folds = (
            f"Leave one stance out: each of the {f['n']} stance(s) whose foot has another stance "
            f"({_e(', '.join(f['heldout']))}) is held out once; the model is fitted on the "
            "others, then frozen on the held-out stance with only its pose correction (and any "
            "stance-scope effect) re-estimated under its prior. A foot with a single stance is "
            "never held out."
        )
    else:
        folds = (
            "No stance could be held out (every foot has a single stance): the models are "
            "compared in-sample with a BIC penalty, which is weaker evidence."
        )
    # the stances the bootstrap draws from: the held-out ones, or all of them in-sample
    n_scored = len(f.get("heldout", []) if f.get("n") else f.get("stances", []))
    which = "held-out " if f.get("n") else ""
    block = f"{BLOCK_SECONDS * 1000:.0f} ms blocks"
    boot = (
        f"the {which}stances resampled, then {block} within each"
        if resamples_stances(n_scored)
        else f"{block} resampled within each {which}stance; with {n_scored} {which}stance(s) "
        f"(fewer than {MIN_CLUSTERS}) the stances themselves are not resampled, so the interval says "
        "whether a gain exceeds the frame-to-frame noise of these steps, not whether another "
        "step would show it: read the per-stance reductions beside it"
    )
    return (
        f"<p>{folds} Each model is scored by the held-out combined score "
        f"<i>S</i> = &radic;(2 <i>E</i> / <i>n</i>) over all six channels in units of the "
        "error scale (2 % BW for forces, 2 % BW × 0.25 m for torques), where <i>E</i> adds "
        "the data cost, the cost of the nuisance corrections under their prior and an Occam "
        "term for the freedom they use; a reduction is 1 − <i>S</i><sub>model</sub> / "
        "<i>S</i><sub>parent</sub>. The 95 % interval comes from a paired bootstrap "
        f"({boot}).</p>"
        f"<p><b>Decision rule:</b> an effect passes when its held-out reduction is at least {t}, "
        f"the lower end of its interval is above 0, <i>and</i> it reduces the in-sample "
        f"objective by at least {t} too (a held-out gain without an in-sample one comes from "
        "how a model extrapolates between few stances, not from explaining the misfit). The "
        "best passing effect is added and the others are re-ranked on top of it, until none "
        "passes (&ldquo;none&rdquo; is a possible answer). From the second round on, a "
        f"candidate whose in-sample reduction is below {t} cannot pass and is not held out "
        "(&ldquo;screened&rdquo;). A candidate that gains in-sample (at least "
        f"{t}) and on the held-out stances, but without a supported margin, is listed as "
        "<i>inconclusive</i>: the data neither show it nor rule it out.</p>"
        "<p><b>Confounded</b> effects (the data cannot tell them apart) are named when "
        f"(1) their changes of the held-out residual are alike (cosine above "
        f"{CONFOUND_COSINE:g}, both reducing the score); (2) their changes of the in-sample "
        f"residual are alike (cosine above {CONFOUND_COSINE:g}, both reducing the in-sample "
        f"objective by at least {t}, the smaller change at least "
        f"{100 * COMPARABLE_FRACTION:.0f} % of the larger); (3) one keeps less than "
        f"{100 * NON_ADDITIVE_FRACTION:.0f} % of its gain once the other is in the model; "
        f"(4) more than {100 * NUISANCE_SHARE:.0f} % of an effect's held-out gain comes from a "
        "cheaper pose correction rather than a better fit of the plates (it is then named "
        "confounded with the base's <code>kinematic_correction</code>); or (5) both pass and "
        "the paired bootstrap of their difference does not order them. The in-sample reduction "
        "alone never ranks effects: extra parameters always fit the fitted stances better.</p>"
    )


def _provenance(prov: dict | None, d) -> str:
    if not prov:
        from gc_ocp import __version__

        now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
        return (
            f"<p>gc_ocp {_e(__version__)}, report written {_e(now)}; stances "
            f"{_e(', '.join(d.folds.get('stances', [])))}.</p>"
        )
    rows = []
    for t in prov.get("trials", []):
        files = "<br>".join(
            f"<code>{_e(f['path'])}</code> <span class=small>sha256 {_e(f['sha256'][:16])}…</span>"
            for f in t.get("files", [])
        )
        excl = "; ".join(
            f"{e['side']} {e['t_on']:.2f}-{e['t_off']:.2f} s: {e['reason']}"
            for e in t.get("stances_excluded", [])
        )
        rows.append(
            f"<tr><td class=l>{_e(t['name'])}</td><td class=l>{files}</td>"
            f"<td>{_num(t.get('mass_kg'), '.1f')} <span class=small>"
            f"({_e(t.get('mass_source', ''))})</span></td>"
            f"<td>{_num(t.get('height_m'), '.3f')} <span class=small>"
            f"({_e(t.get('height_source', ''))})</span></td>"
            f"<td class=l>{_e(', '.join(t.get('stances_used', [])))}"
            + (f"<br><span class=small>excluded: {_e(excl)}</span>" if excl else "")
            + "</td></tr>"
        )
    opts = ", ".join(
        f"{k}={v}" for k, v in prov.get("options", {}).items() if v not in (None, [], False)
    )
    return (
        f"<p>gc_ocp {_e(prov.get('gc_ocp_version', ''))} (Python {_e(prov.get('python', ''))}), "
        f"{_e(prov.get('date', ''))}; command <code>{_e(prov.get('command', ''))}</code> with "
        f"<code>{_e(opts)}</code>.</p>"
        "<table><tr><th class=l>trial</th><th class=l>files</th><th>mass [kg]</th>"
        "<th>height [m]</th><th class=l>stances</th></tr>" + "".join(rows) + "</table>"
    )


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
    return _page(
        diagnosis, provenance, figs, diagnosis.final_evaluation.full if final is None else final
    )


def _page(d, prov: dict | None, figs: dict, res) -> str:
    wf = d.waterfall
    base_sup, final_sup = (
        wf[0].heldout_superior_force_pct_bw,
        wf[-1].heldout_superior_force_pct_bw,
    )
    held = "held-out" if d.folds.get("n") else "in-sample"
    if d.selected:
        steps = []
        for k, name in enumerate(d.selected):
            r = next(x for x in d.rounds[k] if x.effect == name)
            lo, hi = r.heldout_rms_reduction_ci
            steps.append(
                f"<b>{_e(name)}</b> ({_num(r.heldout_rms_reduction_pct, '.1f')} % "
                f"[{_num(lo, '.1f')}, {_num(hi, '.1f')}])"
            )
        verdict = (
            f"Adding {', then '.join(steps)} to the <i>{_e(d.base)}</i> model reduces its "
            f"{held} combined score by the percentage shown (95 % interval); the {held} "
            f"superior-force RMS goes from {_num(base_sup)} to {_num(final_sup)} % BW."
        )
    else:
        verdict = (
            f"<b>No candidate effect passes the decision rule</b>: none of "
            f"{_e(', '.join(d.candidates)) or '(no candidates)'} predicts the held-out stances "
            f"clearly better than the <i>{_e(d.base)}</i> model ({held} superior-force RMS "
            f"{_num(base_sup)} % BW)."
        )
    if d.inconclusive:
        verdict += (
            f" <b>Inconclusive:</b> {_and(d.inconclusive)} reduce"
            f"{'s' if len(d.inconclusive) == 1 else ''} the score in-sample (by at least "
            f"{d.threshold_pct:g} %) and on held-out stances, but without a margin these data "
            "support (below the threshold, or an interval reaching 0); more stances or trials "
            "of the subject would decide."
        )
    ambiguous = confounded_groups(d.ranking) or _nuisance_text(d.ranking)
    if ambiguous:
        verdict += " Some effects are confounded (see below)."
    title = f"Diagnosis: {d.base} model vs the force plates"
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{_e(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{_e(title)}</h1>",
        f"<p class=small>Base <i>{_e(d.base)}</i> ({_e(', '.join(d.base_components))}); "
        f"{_e(d.folds.get('kind', ''))}, {d.folds.get('n', 0)} held-out stance(s) of "
        f"{len(d.folds.get('stances', []))}; {len(d.candidates)} candidate effect(s); "
        f"{d.seconds:.0f} s.</p>",
        f'<p class="lead">{verdict}</p>',
        # 1. where
        "<h2>1. Where the gap is</h2>",
        _where_text(d.where["base"]),
        _figure(
            figs["heatmap"],
            "heat map of the held-out residual by foot, channel and gait phase",
            "Held-out residual of the base model by foot × channel × gait phase. Colour: RMS in "
            "units of the error scale (comparable across channels; COP / 20 mm); numbers: RMS in "
            "% BW, % BW×H or mm.",
        ),
        _figure(
            figs["residuals"],
            "residual over time of the held-out stances",
            "Residual (model − measured) over time of each held-out stance, base model; the "
            "four stance phases shaded.",
        ),
        # 2. ranking
        "<h2>2. Which effect explains it</h2>",
        "<p>Every candidate added alone to the base, fitted and scored on the held-out "
        "stances. <i>Held-out reduction</i>: how much better it predicts stances it was not "
        "fitted on (the ranking criterion); <i>in-sample</i>: how much better it fits the "
        "stances it was fitted on (for reference: extra parameters always fit better).</p>",
        _ranking_table(d.ranking, d.threshold_pct)
        if d.ranking
        else "<p>No candidate was tried.</p>",
        _confounding_text(d.ranking, d.selected),
        _figure(
            figs["ranking"],
            "held-out reduction per candidate effect with 95 % intervals",
            f"Held-out reduction per candidate with its 95 % interval; dashed: the "
            f"{d.threshold_pct:g} % threshold; green: passes; * confounded.",
        ),
    ]
    for k, rows in enumerate(d.rounds[1:], 2):
        on_top = " + ".join(["base", *d.selected[: k - 1]])
        parts += [
            f"<h3>Round {k}: candidates on top of {_e(on_top)}</h3>",
            _ranking_table(rows, d.threshold_pct),
        ]
    # 3. waterfall
    parts += [
        "<h2>3. How far the gap shrinks</h2>",
        "<p>Held-out RMS after each added effect ("
        + (
            "selected: " + _e(", ".join(d.selected))
            if d.selected
            else "no effect selected: the base only"
        )
        + ").</p>",
        _figure(
            figs["waterfall"],
            "waterfall of the held-out RMS per channel after each added effect",
            "Held-out RMS per channel (mean of the feet) after each step; bold: superior force.",
        ),
        _waterfall_table(wf),
    ]
    if "heatmap_final" in figs:
        parts.append(
            _figure(
                figs["heatmap_final"],
                "heat map of the held-out residual of the final model",
                "Where the residual lies once the selected effects are in the model.",
            )
        )
    # 4. final model
    flags = list(res.flags)
    parts += [
        "<h2>4. The final model</h2>",
        f"<p><b>{_e(' + '.join(['base', *d.selected]))}</b>: components "
        f"{_e(', '.join(res.components))}; fitted on all {len(d.folds.get('stances', []))} "
        f"stances: Ipopt {_e(res.status)}, {res.iterations} iterations; {res.n_data} residuals, "
        f"{res.n_free} free variables ({res.n_param} physical parameters).</p>",
        "<h3>Fit quality (RMS)</h3>",
        _rms_table(res, wf[-1].heldout_rms if d.folds.get("n") else None),
        _contact_tables(res.params),
        _sole_table(res.blocks.get("sole", {})),
    ]
    pose = res.pose_correction_rms
    if pose:
        parts.append(
            "<p>Foot-pose correction RMS (prior 2 mm / 1 deg): "
            + "; ".join(
                f"{_e(s)} {_num(v['mm'])} mm, {_num(v['deg'])} deg" for s, v in pose.items()
            )
            + ".</p>"
        )
    for trial, v in res.belt_speed.items():
        parts.append(
            f"<p>Belt speed ({_e(trial)}): {_pm(v, 'value', '.3f')} m/s "
            f"(given {_num(v.get('nominal'), '.3f')}).</p>"
        )
    parts.append(_effect_blocks(res))
    # 5. method
    parts += ["<h2>5. How the effects were judged</h2>", _method(d)]
    # 6. notes and flags
    parts.append("<h2>6. Notes and flags</h2>")
    if d.notes:
        parts.append("<ul>" + "".join(f"<li>{_e(n)}</li>" for n in d.notes) + "</ul>")
    if flags:
        parts.append(
            f"<p>The final model's fit carries {len(flags)} flag(s): what not to take at face "
            "value.</p><ul>" + "".join(f"<li>{_e(f['message'])}</li>" for f in flags) + "</ul>"
        )
    if not d.notes and not flags:
        parts.append("<p>No notes and no flags.</p>")
    # 7. provenance
    parts += ["<h2>7. Provenance</h2>", _provenance(prov, d), "</body></html>"]
    return "\n".join(parts) + "\n"


def write_report(
    diagnosis,
    path: str | os.PathLike,
    provenance: dict | None = None,
    pngs: dict | None = None,
) -> Path:
    """Write :func:`report_html` of ``diagnosis`` to ``path`` atomically; returns the path."""
    from gc_ocp.outputs import atomic_write_text

    return atomic_write_text(path, report_html(diagnosis, provenance, pngs))


__all__ = (
    "CHANNEL_KEYS",
    "confounded_groups",
    "report_figures",
    "report_html",
    "report_pngs",
    "worst_cells",
    "write_report",
)
