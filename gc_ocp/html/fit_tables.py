"""The final model's numbers as the pages show them: RMS per channel, the contact law's tables,
sole offsets, each effect's block (``Component.describe`` rows), and the number formats.

Plain data for a template (:mod:`gc_ocp.diagnosis.report` uses it for the diagnosis page; any
page that shows a fit can).
"""

from __future__ import annotations

import math

import numpy as np

from gc_ocp.contact.channels import CHANNELS, TABLE_KEYS, channel_name, channel_unit
from gc_ocp.estimation.components.base import per_axis
from gc_ocp.estimation.components.contact import ContactLaw, with_unit
from gc_ocp.estimation.flags import k_at_bound, law_at_bound, row_at_bound, variable_key
from gc_ocp.values import BOUND_TEXT, MINIMUM_TEXT, se_text

CORE_BLOCKS = ("contact", "sole", "pose", "belt")
"""Blocks of the registered base shown in their own tables; any other block is an effect's."""

CHANNEL_KEYS = (*(TABLE_KEYS[c] for c in CHANNELS), "cop_mm")
"""The six ``fit.json`` channel keys and the COP, in the order the tables show them."""


def fmt_num(v, fmt: str = ".2f") -> str:
    """``v`` formatted with ``fmt``; "–" for a missing or non-finite number."""
    if v is None:
        return "–"
    try:
        v = float(v)
    except (TypeError, ValueError):
        return str(v)
    return "–" if not math.isfinite(v) else format(v, fmt)


def rms_table(res, heldout: dict | None) -> dict:
    """The final model's RMS table: per channel, per foot in-sample (and held-out)."""
    sides = list(res.rms)
    rows = []
    for key in CHANNEL_KEYS:
        cells = []
        for s in sides:
            cells.append(res.cop_rms_mm.get(s) if key == "cop_mm" else res.rms[s].get(key))
            if heldout:
                cells.append(heldout.get(s, {}).get(key, float("nan")))
        rows.append({"channel": f"{channel_name(key)} [{channel_unit(key)}]", "cells": cells})
    return {"sides": sides, "heldout": bool(heldout), "rows": rows}


def pm(d: dict, key: str, fmt: str = ".4g", bound: bool = False) -> str:
    """``value ± SE`` of ``d[key]`` (``d[key + "_se"]``); a zero SE marks a fixed value;
    ``bound``: the parameter is flagged at its bound (:data:`~gc_ocp.values.BOUND_TEXT` in place
    of the SE)."""
    return pm_value(d[key], d.get(key + "_se"), fmt, bound=bound)


def pm_value(
    value: float, se: float | None, fmt: str = ".4g", unit: str = "", bound: bool = False
) -> str:
    """``value ± SE unit``; no SE: the value alone; a zero SE marks a fixed value; no value
    (a failed fit's empty cell): "–"; ``bound``: the parameter is flagged at its bound
    (:data:`~gc_ocp.values.BOUND_TEXT` in place of the SE, which assumes an interior optimum)."""
    unit = "" if unit in ("", "-") else f" {unit}"
    if bound:
        return f"{fmt_num(value, fmt)}{unit} {BOUND_TEXT}"
    if fmt_num(value) == "–":
        return "–"
    if se is None:
        return fmt_num(value, fmt) + unit
    if se == 0:
        return fmt_num(value, fmt) + unit + " (fixed)"
    text = fmt_num(value, fmt)
    return f"{text} ± {se_text(se, text)}{unit}"


def body_weights(res, provenance: dict | None = None) -> dict[str, float]:
    """``{side: body weight [N]}`` of a fit's feet, as its flags divide a unit's force by it
    (:meth:`ContactLaw.flags <gc_ocp.estimation.components.contact.ContactLaw.flags>`: each
    foot's stances' subject): from ``res.stance_fits``; without them (a ``fit.json`` cut short)
    from ``provenance``'s trials when they give one mass (one subject); else ``{}``."""
    out = {f["side"]: float(f["body_weight"]) for f in res.stance_fits if f.get("body_weight")}
    if out:
        return out
    masses = {t.get("mass_kg") for t in (provenance or {}).get("trials", [])}
    if len(masses) != 1 or None in masses:
        return {}
    from gc_ocp.trial import GRAVITY

    bw = float(masses.pop()) * GRAVITY
    return {side: bw for side in res.params if side != "shared"}


def contact_tables(
    params: dict,
    at_bound: frozenset[str] = frozenset(),
    reference_depth: float | None = None,
    body_weight: dict[str, float] | None = None,
    undecided: frozenset[str] = frozenset(),
) -> dict:
    """The contact law's block as tables: per unit k and force at the reference depth
    (``reference_depth`` [m], the fit's law's, :attr:`EstimationResult.law
    <gc_ocp.estimation.result.EstimationResult.law>`; None: the default law's), also in % of
    the foot's ``body_weight`` [N] (``{side: N}``, :func:`body_weights`; "–" where unknown:
    the flags say "22 BW" of a unit the table gave in N alone), per-foot
    scalars, shared parameters (each ``value ± SE``; a parameter of ``at_bound``, the fit's
    :attr:`~gc_ocp.estimation.result.EstimationResult.at_bound`, says so instead; one of
    ``undecided``, its :attr:`~gc_ocp.estimation.result.EstimationResult.undecided`, adds
    :data:`~gc_ocp.values.MINIMUM_TEXT` after it)."""
    if reference_depth is None:
        reference_depth = ContactLaw.reference_depth
    body_weight = body_weight or {}
    units, per_foot = [], []
    for side, per in params.items():
        if side == "shared" or not isinstance(per, dict):
            continue
        for unit, e in per.items():
            if isinstance(e, dict) and "k" in e:
                bound = k_at_bound(at_bound, side, unit)  # f_ref = k d^n: pinned by it too
                units.append(
                    {
                        "side": side,
                        "unit": unit,
                        "k": pm(e, "k", ".4g", bound),
                        "f_ref": pm(e, "f_ref", ".0f", bound),
                        "f_ref_pct_bw": fmt_num(
                            100 * e["f_ref"] / body_weight[side] if side in body_weight else None,
                            ".0f",
                        ),
                        "identified": e.get("identified", True),
                    }
                )
        scalars = [k for k, v in per.items() if not isinstance(v, dict) and not k.endswith("_se")]
        if scalars:
            per_foot.append(
                {
                    "side": side,
                    "values": [
                        (with_unit(k), pm(per, k, bound=law_at_bound(at_bound, k, side)))
                        for k in scalars
                    ],
                }
            )
    shared = params.get("shared", {})
    return {
        "reference_mm": f"{reference_depth * 1e3:g}",
        "units": units,
        "per_foot": per_foot,
        "shared": [
            (with_unit(k), shared_pm(shared, k, at_bound, undecided))
            for k in shared
            if not k.endswith("_se")
        ],
    }


def shared_pm(
    shared: dict, key: str, at_bound: frozenset[str], undecided: frozenset[str] = frozenset()
) -> str:
    """A shared law parameter's ``value ± SE`` as the tables show it: at its bound, the bound's
    text instead of the SE; named by a ``minimum_undecided`` flag, :data:`MINIMUM_TEXT` after."""
    if law_at_bound(at_bound, key):
        return pm(shared, key, bound=True)
    return pm(shared, key) + (f" {MINIMUM_TEXT}" if law_at_bound(undecided, key) else "")


def belt_rows(res) -> list[tuple[str, str, float | None]]:
    """``[(trial, "value ± SE m/s", nominal)]`` of each treadmill trial's fitted belt speed
    (``res.belt_speed``: ``{trial: {"value", "se", "nominal"}}``, [m/s]); a speed flagged at its
    bound has :data:`~gc_ocp.values.BOUND_TEXT` in place of its SE."""
    return [
        (
            trial,
            pm_value(
                v["value"], v.get("se"), ".3f", "m/s", variable_key("belt", trial) in res.at_bound
            ),
            v.get("nominal"),
        )
        for trial, v in res.belt_speed.items()
    ]


def sole_table(sole: dict, at_bound: frozenset[str] = frozenset()) -> list[dict]:
    """Sole-point corrections per foot and unit: ``[(offset, SE) x, y, z]`` [mm]; a unit whose
    correction is among ``at_bound`` (the fit's
    :attr:`~gc_ocp.estimation.result.EstimationResult.at_bound`, ``"sole/right/TT"``) has no SEs
    (None: they assume an interior optimum) and ``"bound"`` True."""
    off, se = sole.get("offsets_mm", {}), sole.get("se_mm", {})
    rows = []
    for side, units in off.items():
        for unit, v in units.items():
            bound = variable_key("sole", side, unit) in at_bound
            errs = [None] * 3 if bound else se.get(side, {}).get(unit, [float("nan")] * 3)
            rows.append(
                {"side": side, "unit": unit, "bound": bound, "xyz": list(zip(v, errs, strict=True))}
            )
    return rows


def axes_text(values, default, unit: str) -> str:
    """A prior's widths as a report prints them: ``"5 mm"``, or per foot-frame or ``lab``
    axis where they differ (an estimated width, :mod:`gc_ocp.estimation.pose_scale`):
    ``"x 5, y 7.25, z 10 mm"``. ``values``: a scalar or one per axis (None: ``default``)."""
    v = per_axis(values if values is not None else default)
    if np.allclose(v, v[0], rtol=1e-3):
        return f"{v[0]:.3g} {unit}"
    return ", ".join(f"{a} {x:.3g}" for a, x in zip("xyz", v, strict=True)) + f" {unit}"


def sole_prior_text(sole: dict) -> str:
    """The sole correction's prior width the fit used, per foot-frame axis where they differ
    (its block's ``prior_mm``; a ``fit.json`` written before the width was recorded had the
    component's default, one written before 2026-11-30 one width for every axis)."""
    from gc_ocp.estimation.components.sole import SoleCorrection

    return axes_text(sole.get("prior_mm"), SoleCorrection.sigma * 1e3, "mm")


def pose_prior_text(pose: dict) -> str:
    """The pose correction's prior widths the fit used, as a report prints them: ``"2 mm / 1
    deg"``, or per ``lab`` axis where they differ (:func:`axes_text`). From its block's
    ``prior_mm`` / ``prior_deg``; a ``fit.json`` written before the widths were recorded had
    the component's defaults."""
    from gc_ocp.estimation.components.pose import PoseCorrection

    mm = axes_text(pose.get("prior_mm"), PoseCorrection.sigma_mm, "mm")
    deg = axes_text(pose.get("prior_deg"), PoseCorrection.sigma_deg, "deg")
    return f"{mm} / {deg}"


def flatten_block(block, prefix: str = "", depth: int = 0) -> list[tuple[str, str]]:
    """Scalar leaves of an effect block as ``(name, "value ± SE")``; long arrays summarised."""
    out: list[tuple[str, str]] = []
    if isinstance(block, dict):
        for k, v in block.items():
            if str(k).endswith("_se") or depth > 4:  # an SE is shown with its value
                continue
            name = f"{prefix}{k}"
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                out.append((name, pm(block, k)))
            else:
                out += flatten_block(v, name + " / ", depth + 1)
    elif isinstance(block, (list, tuple)):
        flat = block
        if all(isinstance(x, (int, float)) for x in flat) and len(flat) <= 6:
            out.append(
                (prefix.rstrip(" /"), "[" + ", ".join(fmt_num(x, ".4g") for x in flat) + "]")
            )
        else:
            out.append((prefix.rstrip(" /"), f"({len(flat)} values)"))
    elif isinstance(block, (str, bool)):
        out.append((prefix.rstrip(" /"), str(block)))
    return out


def model_tables(res, provenance: dict | None = None) -> dict:
    """The fitted model's tables as a page's template reads them (``contact``, ``sole``,
    ``sole_prior``, ``pose_prior``, ``belt``, ``effects``): one place for the section the fit's and
    the diagnosis's pages share."""
    return {
        "contact": contact_tables(
            res.params,
            res.at_bound,
            res.law.reference_depth,
            body_weights(res, provenance),
            res.undecided,
        ),
        "sole": sole_table(res.blocks.get("sole", {}), res.at_bound),
        "sole_prior": sole_prior_text(res.blocks.get("sole") or {}),
        "pose_prior": pose_prior_text(res.blocks.get("pose") or {}),
        "belt": belt_rows(res),
        "effects": effect_blocks(res),
    }


def effect_blocks(res) -> list[dict]:
    """The blocks of the final model's effects (not the base's): the rows each component gives
    of its block (``Component.describe``: label, value ± SE with its unit), or, for a component
    that gives none, the block's scalar leaves."""
    described = res.block_rows()
    bound = res.at_bound
    out = []
    for name, block in res.blocks.items():
        if name in CORE_BLOCKS:
            continue
        rows = [
            (r.label, pm_value(r.value, r.se, unit=r.unit, bound=row_at_bound(bound, name, r)))
            for r in described.get(name, [])
        ]
        out.append(
            {
                "name": name,
                "description": res.components.get(name, ""),
                "rows": rows or flatten_block(block),
            }
        )
    return out
