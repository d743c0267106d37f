"""Plausibility of a fit: what in a result should not be taken at face value.

Every result carries ``flags``: a list of ``{"code", "what", "message"}`` (plain data; in
``.summary()``, in ``fit.json`` and on the command line). The checks and their thresholds:

* ``at_bound`` — a physical parameter (a variable without prior) within 0.1 % of its range of a
  bound: the optimum lies beyond what the bounds allow, so the value and its standard error are
  not estimates (a Gaussian SE assumes an interior optimum).
* ``prior_exceeded`` — a correction (a variable with a Gaussian prior) beyond 3 sigma of its prior
  (probability 0.3 % under the prior): the data pull the correction much further than the
  marker-registration uncertainty it stands for, e.g. a foot placed centimetres off its markers.
  One flag per variable block, with its largest |z|. A correction on its bound is flagged
  ``at_bound`` instead: an estimated prior width can put the bound inside 3 sigma (the sole's
  25 mm is 2.5 sigma of a 10 mm width), where no ``prior_exceeded`` would fire.
* component checks (:meth:`Component.flags`), e.g. a contact unit that is not identified (SE
  above its value, or a force at the reference depth above 2 BW), a belt speed the data do not
  inform;
* ``minimum_undecided`` (added by :func:`gc_ocp.fit`, :func:`~gc_ocp.estimation.starts.undecided_minimum`)
  — another minimum of the objective, reached from another start, fits the plates as well or
  better (its data cost not above the kept one's by 2 SD of the difference's sampling spread)
  and lies more than 2 SE away in the physical parameters it names: their SEs do not cover
  which minimum the fit is in. Only values reported with an SE are named (:func:`without_se`).
* ``poor_fit`` — superior-force RMS above 10 % BW or COP RMS above 50 mm: converged fits of real
  walking with today's model give 1-3 % BW and 5-20 mm (``docs/estimation.md``); beyond those a
  fit describes something else (wrong plate, wrong trial, wrong units).
"""

from __future__ import annotations

import numpy as np

BOUND_FRACTION = 1e-3
PRIOR_Z = 3.0
POOR_SUPERIOR_PCT_BW = 10.0
POOR_COP_MM = 50.0


def variable_key(*parts) -> str:
    """A variable block's name in the flags and the tables that look them up: its key's parts
    joined by "/" (``"contact/n"``, ``"contact/k/left/PM"``, ``"contact/mu/right"``)."""
    return "/".join(map(str, parts))


def at_bound_names(flags) -> frozenset[str]:
    """The variables ``flags`` (a fit's, or ``fit.json``'s) flag ``at_bound``: their value is the
    bound, not an estimate, and their SE means nothing."""
    return frozenset(f["what"] for f in flags if f.get("code") == "at_bound")


def without_se(flags, name: str) -> bool:
    """Whether a fit with ``flags`` reports variable ``name`` (a :func:`variable_key`) without a
    standard error: at a bound (:func:`at_bound_names`) or the stiffness of a contact unit the
    data do not identify (``unit_not_identified``, whose ``what`` is ``"side/unit"``: the
    summary shows "not identified" in place of its number)."""
    return name in at_bound_names(flags) or any(
        f.get("code") == "unit_not_identified" and name.endswith("/k/" + str(f.get("what")))
        for f in flags
    )


def undecided_names(flags) -> frozenset[str]:
    """The variables ``flags`` (a fit's, or ``fit.json``'s) name in a ``minimum_undecided``
    flag: another minimum the plates do not prefer lies beyond their SE."""
    return frozenset(
        name
        for f in flags
        if f.get("code") == "minimum_undecided"
        for name in str(f.get("what", "")).split(", ")
        if name
    )


LAW_GIVERS: dict[str, str] = {}
"""``{block name: law parameter}`` of the components that give the contact law a parameter
(:attr:`~gc_ocp.estimation.components.base.Component.law_parameter`: damping's ``"c"``, the
exponent's ``"n"``), filled as each such class is defined (``Component.__init_subclass__``; the
components import this module, so it cannot import them)."""


def law_at_bound(bound, param: str, side: str | None = None) -> bool:
    """The contact law's ``param`` (``"n"``, ``"mu"``) is among ``bound``
    (:func:`at_bound_names`), shared or, with ``side``, that foot's own: the law's own variable
    (``"contact/n"``) or the one of a component that gives the law that parameter (damping's
    ``"damping/c"``, the exponent's ``"stiffness_exponent/n"``: their values are the law's).
    Only those blocks: a trial named like a law parameter (``c.c3d``) keys its clock offset or
    belt ``"time_offset/c"``, which is not the law's ``c``."""
    tails = {(param,)} | ({(param, side)} if side is not None else set())
    blocks = {"contact"} | {b for b, p in LAW_GIVERS.items() if p == param}
    return any(b.split("/")[0] in blocks and tuple(b.split("/")[1:]) in tails for b in bound)


def row_at_bound(bound, block: str, row) -> bool:
    """A component's row of its block ``block`` (a ``SummaryRow``, :meth:`Component.describe`)
    is one variable among ``bound`` (:func:`at_bound_names`): its value is not an estimate."""
    return bool(row.key) and variable_key(block, *row.key) in bound


def k_at_bound(bound, side: str, unit: str) -> bool:
    """The stiffness of ``side``'s ``unit`` is among ``bound`` (:func:`at_bound_names`): its own
    ``k``, or a ``k`` of a wider scope (the foot's, or one for all units)."""
    return law_at_bound(bound, "k", side) or variable_key("contact", "k", side, unit) in bound


def flag(code: str, what: str, message: str) -> dict:
    return {"code": code, "what": what, "message": message}


def _at_bound(s, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(at the lower bound, at the upper bound) per entry of block ``s`` at stored values ``z``:
    within :data:`BOUND_FRACTION` of the range (of the value, for a one-sided range)."""
    span = np.where(np.isfinite(s.ub - s.lb), s.ub - s.lb, np.maximum(np.abs(z), 1.0))
    lo = np.isfinite(s.lb) & (z - s.lb <= BOUND_FRACTION * span)
    hi = np.isfinite(s.ub) & (s.ub - z <= BOUND_FRACTION * span)
    return lo, hi


def variable_flags(specs, x: np.ndarray) -> list[dict]:
    """``at_bound`` and ``prior_exceeded`` flags from the variable blocks at ``x``."""
    out = []
    for s in specs:
        z = np.asarray(x[s.slice], float)
        key = variable_key(*s.key)
        lo, hi = _at_bound(s, z)
        if s.kind == "param":
            for j in np.flatnonzero(lo | hi):
                which, b = ("lower", s.lb[j]) if lo[j] else ("upper", s.ub[j])
                val = s.physical(z)[j]
                bval = float(np.exp(b)) if s.log else float(b * s.scale[j])
                out.append(
                    flag(
                        "at_bound",
                        key,
                        f"{key} = {s.reading(val)} is at its {which} bound {s.reading(bval)}: "
                        "not identified "
                        "(the data push it beyond the allowed range; its SE is not meaningful)",
                    )
                )
        elif s.kind == "prior" and z.size and (lo | hi).any():
            j = int(np.flatnonzero(lo | hi)[0])
            out.append(
                flag(
                    "at_bound",
                    key,
                    f"{key}: correction on its bound ({abs(float(s.lb[j] if lo[j] else s.ub[j])):.2g} "
                    "sigma of its prior): the data push it beyond the allowed range; its SE is not "
                    "meaningful",
                )
            )
        elif s.kind == "prior" and z.size:
            zmax = float(np.max(np.abs(z)))
            if zmax > PRIOR_Z:
                out.append(
                    flag(
                        "prior_exceeded",
                        key,
                        f"{key}: correction at {zmax:.1f} sigma of its prior (> {PRIOR_Z:g}): the data "
                        "pull it far beyond the registration uncertainty it models",
                    )
                )
    return out


def fit_flags(rms: dict, cop_rms_mm: dict) -> list[dict]:
    out = []
    for side, r in rms.items():
        sup = r.get("superior_force_pct_bw", 0.0)
        if not sup <= POOR_SUPERIOR_PCT_BW:  # (a NaN RMS, a model or data not a number, too)
            out.append(
                flag(
                    "poor_fit",
                    side,
                    f"{side} superior-force RMS {sup:.1f} % BW > {POOR_SUPERIOR_PCT_BW:g} % BW"
                    if np.isfinite(sup)
                    else f"{side} superior-force RMS is not a number: the model or the plate "
                    "data are not finite on a fitted frame",
                )
            )
        cop = cop_rms_mm.get(side, 0.0)
        if np.isfinite(cop) and cop > POOR_COP_MM:
            out.append(flag("poor_fit", side, f"{side} COP RMS {cop:.0f} mm > {POOR_COP_MM:g} mm"))
    return out


__all__ = ["flag", "fit_flags", "variable_flags"]
