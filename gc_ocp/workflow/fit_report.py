"""A fit as one self-contained HTML page (``report.html`` beside ``fit.json``), in the style of
the diagnosis report: the inputs and the checks, the flags, the parameters with their standard
errors (and each treadmill trial's belt speed), the fit channel by channel (RMS table and
figures), the held-out stance and the provenance. The markup is
``gc_ocp/html/templates/fit_report.html.j2``; this module prepares what it shows."""

from __future__ import annotations

from gc_ocp.estimation.components.contact import with_unit
from gc_ocp.html import data_uri, environment, provenance_context
from gc_ocp.html.fit_tables import (
    model_tables,
    pose_prior_text,
    rms_table,
    shared_pm,
)
from gc_ocp.workflow.fitting import FitReport

TEMPLATE = "fit_report.html.j2"


def _flags(report: FitReport) -> list[dict]:
    rows = [{"fit": "all stances", **f} for f in report.result.flags]
    if report.heldout is not None:
        rows += [{"fit": f"held out {report.heldout_label}", **f} for f in report.heldout.flags]
    return rows


def fit_report_html(
    report: FitReport, provenance: dict | None, pngs: dict[str, bytes], sensitivity=None
) -> str:
    """The page of ``report`` (module doc); ``provenance`` as ``fit.json`` records it (None:
    version and date only); ``pngs``: the fit's figures as PNG bytes by file name
    (:func:`gc_ocp.workflow.fit_files.fit_figures`, rendered); ``sensitivity``: its
    :class:`~gc_ocp.workflow.sensitivity.SensitivityReport` or None."""
    from gc_ocp.workflow.sensitivity import SENSITIVE_RATIO

    res, held = report.result, report.heldout
    shared = res.params.get("shared", {})
    names = [p for p in ("n", "c", "mu") if p in shared]
    trials = (provenance or {}).get("trials", [])
    title = "Fit: " + (", ".join(t["name"] for t in trials) if trials else "contact model")
    context = {
        "title": title,
        "res": res,
        "held": held,
        "held_label": report.heldout_label,
        "lead": {
            "insample": [(s, res.rms[s]["superior_force_pct_bw"]) for s in res.rms],
            "heldout": None
            if held is None
            else next(iter(held.rms.values()))["superior_force_pct_bw"],
            "shared": [
                (with_unit(p), shared_pm(shared, p, res.at_bound, res.undecided)) for p in names
            ],
        },
        "checks": list(report.checks),
        "pose_scale": None if report.pose_scale is None else report.pose_scale.message(),
        "bias": None if report.bias is None else report.bias.message(),
        "bias_skipped": report.bias_skipped,
        "flags": _flags(report),
        **model_tables(res, provenance),
        "held_pose_prior": None if held is None else pose_prior_text(held.blocks.get("pose") or {}),
        "rms": rms_table(res, None if held is None else held.rms | _cop(held)),
        "figures": {name: data_uri(png) for name, png in pngs.items()},
        "provenance": provenance_context(provenance),
        "sensitivity": None
        if sensitivity is None
        else {
            "choices": sensitivity.choices,
            "reference": sensitivity.reference,
            "rows": sensitivity.rows(),
            "limit": SENSITIVE_RATIO,
        },
    }
    return environment().get_template(TEMPLATE).render(context)


def _cop(held) -> dict:
    """The held-out stance's COP RMS in the RMS table's layout (``{side: {"cop_mm": mm}}``)."""
    return {s: {**held.rms.get(s, {}), "cop_mm": v} for s, v in held.cop_rms_mm.items()}


__all__ = ("TEMPLATE", "fit_report_html")
