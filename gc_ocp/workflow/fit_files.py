"""The files of a fit: ``fit.json``, ``landmarks.json``, its figures and ``report.html`` (the
same figures embedded in one self-contained page, :mod:`gc_ocp.workflow.fit_report`), written into an
:class:`~gc_ocp.outputs.OutputSet` (complete or not at all). One definition for ``gc-ocp fit``
and for every subject of ``gc-ocp batch``."""

from __future__ import annotations

import dataclasses

from gc_ocp.html import FIGURE_DPI, pngs
from gc_ocp.outputs import OutputSet, atomic_write
from gc_ocp.text import json_text
from gc_ocp.workflow.fitting import FitReport

FIT_OUTPUTS = (
    "fit.json",
    "report.html",
    "landmarks.json",
    "fit_failed.json",
    "fit_wrench.png",
    "fit_sole.png",
    "fit_pose_corrections.png",
    "heldout_wrench.png",
    "sensitivity.json",
    "sensitivity.md",
)
"""Every file a fit may write (one set, replaced as a whole)."""


def fit_figures(report: FitReport) -> dict:
    """``{file name: matplotlib figure}`` of a fit: the wrench, sole and pose-correction plots,
    and the held-out stance's wrench when there is one."""
    from gc_ocp.estimation.plots import plot_fit, plot_pose_corrections, plot_sole_fit

    figs = {
        "fit_wrench.png": plot_fit(report.result),
        "fit_sole.png": plot_sole_fit(report.result),
        "fit_pose_corrections.png": plot_pose_corrections(report.result),
    }
    if report.heldout is not None:
        figs["heldout_wrench.png"] = plot_fit(
            report.heldout, title=f"held-out {report.heldout_label}"
        )
    return figs


def write_fit(
    out: OutputSet, report: FitReport, provenance: dict, landmarks: dict, sensitivity=None
) -> dict:
    """Stage ``fit.json`` (the report with its ``provenance``), ``landmarks.json``, the figures
    and ``report.html`` in ``out`` (the caller commits); returns the JSON written as
    ``fit.json``. ``sensitivity``: the fit's
    :class:`~gc_ocp.workflow.sensitivity.SensitivityReport` (``gc-ocp fit --sensitivity``), in
    ``fit.json``, its flags among the fit's, and a table of the page."""
    from gc_ocp.workflow.fit_report import fit_report_html

    if sensitivity is not None:  # its flags join the fit's (the caller's report is not changed)
        result = dataclasses.replace(
            report.result, flags=[*report.result.flags, *sensitivity.flags()]
        )
        report = dataclasses.replace(report, result=result)
    doc = {**report.to_json(), "provenance": provenance}
    if sensitivity is not None:
        doc["sensitivity"] = sensitivity.to_json()
    out.text("fit.json", json_text(doc, indent=2))
    out.text("landmarks.json", json_text(landmarks, indent=2))
    images = pngs(fit_figures(report), FIGURE_DPI)
    for name, png in images.items():
        atomic_write(out.path(name), lambda tmp, png=png: tmp.write_bytes(png))
    out.text("report.html", fit_report_html(report, provenance, images, sensitivity))
    return doc


__all__ = ("FIT_OUTPUTS", "fit_figures", "write_fit")
