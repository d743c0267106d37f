"""The result of an estimation: plain data (picklable, JSON round trip), no CasADi object.

``EstimationResult.blocks`` holds each component's decoded block by the component's name
(``"contact"``: parameters and standard errors, ``"sole"``: sole-point corrections, ``"pose"``:
foot-pose corrections, ``"belt"``: belt speeds, ...). Fit quality is reported as the seed does:
forces in % body weight, torques in % body weight x height, each stance normalised by its own
subject's body weight and height before stances are pooled.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gc_ocp._version import __version__
from gc_ocp.contact.channels import TABLE_KEYS, channel_rms_pct
from gc_ocp.errors import InputError, read_document
from gc_ocp.estimation.components import describe_block
from gc_ocp.estimation.components.contact import ContactLaw, with_unit
from gc_ocp.estimation.flags import (
    at_bound_names,
    k_at_bound,
    law_at_bound,
    row_at_bound,
    undecided_names,
    variable_key,
)
from gc_ocp.estimation.measurement import fit_error
from gc_ocp.estimation.variables import VariableSpec
from gc_ocp.text import check_document, nan_for_null, read_json_file
from gc_ocp.trial import SIDES
from gc_ocp.values import BOUND_TEXT, MINIMUM_TEXT, se_text
from gc_ocp.wrench import cop_from_wrench

COP_MIN_FRACTION_BW = 0.10
"""The measured COP is compared only where the measured vertical force exceeds 10 % BW (below,
the COP of a plate is dominated by its noise)."""

FIT_FORMAT = 1
"""The layout of ``fit.json`` this version writes (its ``"format"``) and the latest it reads; one
more when a change would make an older reader misread the file (``docs/export.md``)."""

FIT_KEYS = (
    "x",
    "solver",
    "costs",
    "counts",
    "blocks",
    "components",
    "rms",
    "cop_rms_mm",
    "stance_fits",
    "variables",
)
"""The keys of ``fit.json`` :meth:`EstimationResult.from_json` reads."""

FIT_FIX = "refit with this version (gc-ocp fit, or gc_ocp.fit) to get a fit.json it reads"


def check_fit_document(doc, where: str, needed: tuple[str, ...] = FIT_KEYS) -> None:
    """A ``fit.json`` (parsed) this version can read, or one :class:`InputError` naming
    ``where``, the version that wrote it, this version and the fix (a refit):
    :func:`gc_ocp.text.check_document` with :data:`FIT_FORMAT` and ``needed`` (what the
    reader takes: default :data:`FIT_KEYS`)."""
    check_document(doc, where, "fit.json", FIT_FORMAT, needed, FIT_FIX)


_ARRAY_FIT_KEYS = (
    "time",
    "measured",
    "model",
    "in_contact",
    "points_local",
    "nominal_points",
    "toes_offset",
    "reference_point",
)


@dataclass
class EstimationResult:
    """Estimated parameters, their uncertainty, corrections, fit quality and solver statistics.

    x: decision vector; variables: its blocks (:class:`VariableSpec`); covariance: of ``x``
    (Gauss-Newton, scaled by the residual variance) or None; status, success: Ipopt's on the
    solve that returned ``x``; iterations, seconds: Ipopt's, totals over every solve of a fit
    (:func:`~gc_ocp.estimation.starts.best_of`'s starts and stages, the widths' rounds; not a bias
    correction's replicates, which its own block reports); objective = data_cost + prior_cost
    (``1/2`` squared weighted residuals); n_data:
    number of data residuals; n_free: number of estimated scalars (``x.size``); n_param: those
    without a prior (physical parameters); blocks: ``{component name: block}``; components:
    ``{component name: class name}``; rms: ``{side: {channel: RMS}}`` in % BW or % BW x H over
    in-contact frames; cop_rms_mm: ``{side: COP RMS [mm]}``; stance_fits: per stance
    ``{"label", "side", "trial", "time", "measured", "model", "in_contact", "points_local",
    "nominal_points", "toes_offset", "reference_point", "ground_height", "body_weight", "height",
    "units"}`` (arrays time-first, SI); flags: plausibility flags ``{"code", "what", "message"}``
    (:mod:`gc_ocp.estimation.flags`): what should not be taken at face value.

    Returned by :func:`~gc_ocp.estimation.solve.solve`, by ``gc_ocp.fit(...).result``, and read
    back from a fit.json by :meth:`from_json`.

    >>> import gc_ocp
    >>> trial = gc_ocp.load_trial(); kin = gc_ocp.compute_kinematics(trial)
    >>> problem = gc_ocp.build_estimation(gc_ocp.trial_stances(trial, kin), gc_ocp.seed_model())
    >>> result = gc_ocp.solve(problem)        # or gc_ocp.fit(...).result, from_json(path)
    >>> print(result.summary())               # doctest: +ELLIPSIS
    Ipopt: Solve_Succeeded in ... iterations, ... s; objective ...
     left k [N/m^n]: PL ...
    ...
    >>> sorted(result.blocks["contact"])      # the contact law's parameters with their SEs
    ['left', 'right']
    """

    x: np.ndarray
    status: str
    success: bool
    iterations: int
    seconds: float
    objective: float
    data_cost: float
    prior_cost: float
    n_data: int
    n_free: int
    n_param: int
    blocks: dict
    components: dict
    rms: dict
    cop_rms_mm: dict
    stance_fits: list = field(default_factory=list)
    variables: list = field(default_factory=list)
    covariance: np.ndarray | None = None
    flags: list = field(default_factory=list)
    contact_law: dict = field(default_factory=dict)
    """The contact law's fixed settings (:meth:`ContactLaw.settings`: smoothings, their forms,
    the reference depth); ``{}``: a ``fit.json`` written before they were recorded (2026-12-02),
    whose law had the defaults (the only law those versions could write back)."""

    @property
    def law(self) -> ContactLaw:
        """A contact law of the fit's settings (its parameters the class's defaults: the fitted
        ones are in :attr:`params`)."""
        return ContactLaw.of_settings(self.contact_law)

    # --- views of the usual blocks ------------------------------------------------------------
    @property
    def params(self) -> dict:
        """The contact law's block: ``{side: {unit: {"k", "k_se", "f_ref", "f_ref_se"}, ...},
        "shared": {...}}`` (see :meth:`ContactLaw.decode`)."""
        return self.blocks.get("contact", {})

    @property
    def at_bound(self) -> frozenset[str]:
        """The variables flagged ``at_bound`` (``"contact/n"``, ``"contact/k/left/PM"``): their
        value is not an estimate and their SE means nothing; the tables say so in place of it."""
        return at_bound_names(self.flags)

    @property
    def undecided(self) -> frozenset[str]:
        """The variables a ``minimum_undecided`` flag names: another minimum the plates do not
        prefer lies beyond their SE; the tables say so after it."""
        return undecided_names(self.flags)

    @property
    def sole_corrections_mm(self) -> dict:
        return self.blocks.get("sole", {}).get("offsets_mm", {})

    @property
    def pose_correction_rms(self) -> dict:
        return self.blocks.get("pose", {}).get("rms", {})

    @property
    def pose_shared_fraction(self) -> dict:
        """``{side: rho}``: the share of the pose correction a foot's stances have in common
        (``PoseCorrection.shared``; feet with two or more stances)."""
        return self.blocks.get("pose", {}).get("shared_fraction", {})

    @property
    def belt_speed(self) -> dict:
        return self.blocks.get("belt", {})

    def spec(self, key: tuple) -> VariableSpec:
        return next(s for s in self.variables if s.key == tuple(key))

    def block_rows(self) -> dict[str, list]:
        """``{block name: [SummaryRow(label, value, se, unit), ...]}`` of every component block
        that its component describes (``Component.describe``: an effect's own parameters, e.g.
        damping's ``c``), in model order; blocks without rows are left out. Works on a result
        read back from ``fit.json`` (the class is found by the name in :attr:`components`)."""
        out = {}
        for name, class_name in self.components.items():
            rows = describe_block(class_name, self.blocks.get(name, {}))
            if rows:
                out[name] = rows
        return out

    # --- text ---------------------------------------------------------------------------------
    def scale_text(self) -> str:
        """The body weight [N] and height [m] the RMS in % BW and % BW x height are relative
        to (each stance's subject's, from :attr:`stance_fits`): one line; "" without stance
        fits (a ``fit.json`` cut short)."""
        scales: dict = {}
        for f in self.stance_fits:
            scales.setdefault((f.get("body_weight"), f.get("height")), []).append(f.get("trial"))
        scales.pop((None, None), None)
        if not scales:
            return ""

        def text(bw, h) -> str:
            return f"{bw:.0f} N and height " + ("unknown" if h is None else f"{h:.2f} m")

        if len(scales) == 1:
            return f"% BW, % BW x height: of the subject's body weight {text(*next(iter(scales)))}"
        each = "; ".join(
            f"{text(bw, h)} ({', '.join(dict.fromkeys(str(t) for t in trials))})"
            for (bw, h), trials in scales.items()
        )
        return f"% BW, % BW x height: of each stance's subject's body weight: {each}"

    def summary(self) -> str:
        lines = [
            f"Ipopt: {self.status} in {self.iterations} iterations, {self.seconds:.2f} s; objective "
            f"{self.objective:.4g} (data {self.data_cost:.4g}, prior {self.prior_cost:.4g}; "
            f"{self.n_data} residuals, {self.n_free} free variables)"
        ]
        scale = self.scale_text()
        if scale:
            lines.append(scale)
        fixed = law_fixed(self.params)
        if fixed:  # a held-out fit's frozen law: its values are the training fit's, printed there
            lines.append(f"contact law: fixed, not estimated in this fit ({fixed})")
        for side in SIDES:
            if side not in self.rms:
                continue
            p = self.params.get(side, {})
            units = [u for u, e in p.items() if isinstance(e, dict)]
            if units and not fixed:
                bound = {u for u in units if k_at_bound(self.at_bound, side, u)}
                lines.append(
                    f"{side:>5} k [N/m^n]: "
                    + ", ".join(_shown(p, u, "k", ".3g", u in bound) for u in units)
                )
                lines.append(
                    f"{side:>5} force at the {1e3 * self.law.reference_depth:g} mm reference depth [N]: "
                    + ", ".join(_shown(p, u, "f_ref", ".0f", u in bound) for u in units)
                )
            r = self.rms[side]
            lines.append(
                f"{side:>5} RMS [% BW; torques % BW x height]: "
                + ", ".join(f"{c.split('_')[0]} {r[c]:.2f}" for c in r)
                + f"; COP {self.cop_rms_mm.get(side, float('nan')):.1f} mm"
            )
            if side in self.pose_correction_rms:
                pc = self.pose_correction_rms[side]
                rho = self.pose_shared_fraction.get(side)
                lines.append(
                    f"{side:>5} pose correction RMS: {pc['mm']:.2f} mm, {pc['deg']:.2f} deg"
                    + ("" if rho is None else f"; {rho:.0%} of it shared by the foot's stances")
                )
        for trial, v in self.belt_speed.items():
            at = variable_key("belt", trial) in self.at_bound  # its SE means nothing there
            lines.append(
                f"belt speed ({trial}): {v['value']:.3f} "
                + (f"m/s {BOUND_TEXT}" if at else f"± {v['se']:.3f} m/s")
                + f" (from {v['nominal']:.3f} m/s: given, or measured from the stance feet)"
            )
        shared = {} if fixed else self.params.get("shared", {})
        for k, v in shared.items():
            if not k.endswith("_se"):
                se = shared.get(k + "_se", float("nan"))
                lines.append(
                    f"shared {with_unit(k)} = {v:.4g} "
                    + (
                        BOUND_TEXT
                        if law_at_bound(self.at_bound, k)
                        else f"± {se_text(se, f'{v:.4g}')}"
                        + (f" {MINIMUM_TEXT}" if law_at_bound(self.undecided, k) else "")
                    )
                )
        bound = self.at_bound
        for name, rows in self.block_rows().items():
            lines += [f"{name} {r.text(row_at_bound(bound, name, r))}" for r in rows]
        if self.flags:
            lines.append(f"FLAGS ({len(self.flags)}): what not to take at face value")
            lines += [f"  ! {f['message']}" for f in self.flags]
        else:
            lines.append(
                "flags: none (no parameter at a bound, no correction beyond 3 sigma, every unit identified)"
            )
        return "\n".join(lines)

    # --- plain data ---------------------------------------------------------------------------
    def to_json(self, covariance: bool = False) -> dict:
        """A JSON-ready dict (``fit.json``); :meth:`from_json` gives the result back.

        covariance: include the full covariance of ``x`` (``n_free``^2 numbers: 1 MB of text for
        the bundled trial's 235 variables, so off by default; the standard errors are always in
        the blocks)."""
        fits = [
            {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in f.items()}
            for f in self.stance_fits
        ]
        return {
            "gc_ocp_version": __version__,
            "format": FIT_FORMAT,
            "params": self.params,
            "sole_corrections_mm": self.sole_corrections_mm,
            "pose_correction_rms": self.pose_correction_rms,
            "rms": self.rms,
            "cop_rms_mm": self.cop_rms_mm,
            "solver": {
                "status": self.status,
                "success": self.success,
                "iterations": self.iterations,
                "seconds": self.seconds,
            },
            **({"belt_speed_m_s": self.belt_speed} if self.belt_speed else {}),
            "costs": {
                "objective": self.objective,
                "data": self.data_cost,
                "prior": self.prior_cost,
            },
            "counts": {"data": self.n_data, "free": self.n_free, "param": self.n_param},
            "components": self.components,
            "contact_law": self.contact_law,
            "blocks": self.blocks,
            "x": self.x.tolist(),
            "variables": [s.to_json() for s in self.variables],
            "covariance": self.covariance.tolist()
            if covariance and self.covariance is not None
            else None,
            "stance_fits": fits,
            "flags": self.flags,
        }

    @classmethod
    def from_json(cls, d: dict | str) -> EstimationResult:
        """The result written by :meth:`to_json` (a dict, or a path / text of ``fit.json``); a
        file or document that is not one is an :class:`~gc_ocp.errors.InputError` naming it."""
        what = "the fit document"
        if isinstance(d, str) and not d.lstrip().startswith("{") or hasattr(d, "read_text"):
            what = str(d)
            d = read_json_file(
                d, "Fit file", "a gc-ocp fit.json", "give the fit.json gc-ocp fit wrote."
            )
        not_one = (f"{what} is not a gc-ocp fit.json", "give the file gc-ocp fit wrote, unedited.")
        if isinstance(d, str):
            d = read_document(lambda: json.loads(d), *not_one)
        # a later format, or a layout without the keys read here: one error saying so (it was
        # a KeyError's "not a gc-ocp fit.json" at best)
        check_fit_document(d, what)
        return read_document(lambda: cls._from_document(d), *not_one)

    @classmethod
    def _from_document(cls, d: Mapping) -> EstimationResult:
        """:meth:`from_json` of a parsed document (what it reads, unchecked)."""
        # every leaf of these parts (and of the stance fits) is a number or text: a null in them
        # was a NaN (json_text)
        fits = []
        for f in d["stance_fits"]:
            f = nan_for_null(dict(f))
            for k in _ARRAY_FIT_KEYS:
                if k in f:
                    f[k] = np.asarray(f[k], bool if k == "in_contact" else float)
            fits.append(f)
        s = d["solver"]
        return cls(
            x=np.asarray(d["x"], float),
            status=s["status"],
            success=bool(s["success"]),
            iterations=int(s["iterations"]),
            seconds=float(s["seconds"]),
            objective=float(d["costs"]["objective"]),
            data_cost=float(d["costs"]["data"]),
            prior_cost=float(d["costs"]["prior"]),
            n_data=int(d["counts"]["data"]),
            n_free=int(d["counts"]["free"]),
            n_param=int(d["counts"]["param"]),
            blocks=nan_for_null(d["blocks"]),
            components=d["components"],
            rms=nan_for_null(d["rms"]),
            cop_rms_mm=nan_for_null(d["cop_rms_mm"]),
            stance_fits=fits,
            variables=[VariableSpec.from_json(v) for v in d["variables"]],
            covariance=None if d.get("covariance") is None else np.asarray(d["covariance"], float),
            flags=list(d.get("flags", [])),
            contact_law=dict(d.get("contact_law", {})),
        )


def as_result(fit) -> EstimationResult:
    """The :class:`EstimationResult` of ``fit``: itself, a ``FitReport``'s (what
    :func:`gc_ocp.fit` returns), or read from a ``fit.json`` (a dict, its text or its path)."""
    if isinstance(fit, EstimationResult):
        return fit
    if isinstance(getattr(fit, "result", None), EstimationResult):  # a FitReport
        return fit.result
    if isinstance(fit, dict | str | Path):
        return EstimationResult.from_json(fit)
    raise InputError(
        f"expected a fit (what gc_ocp.fit returns), its .result or its fit.json, but got "
        f"{type(fit).__name__}"
    )


def law_fixed(params: dict) -> str:
    """What of the contact block ``params`` (:attr:`EstimationResult.params`) is fixed when
    every parameter of it is (all SEs zero: a held-out fit's frozen law,
    :func:`~gc_ocp.estimation.starts.frozen_model`), e.g. ``"k of PL, PM, AL, AM, TT; n, c,
    mu"``; "" when any is estimated (or there is no block)."""
    units: dict = {}
    scalars: dict = {}
    ses = []
    for per in params.values():
        if not isinstance(per, dict):
            continue
        for key, v in per.items():
            if isinstance(v, dict):
                units[key] = None
                ses += [v.get("k_se"), v.get("f_ref_se")]
            elif key.endswith("_se"):
                ses.append(v)
            else:
                scalars[key] = None
    if not ses or any(se is None or se != 0 for se in ses):
        return ""
    return "; ".join(
        part for part in (f"k of {', '.join(units)}" if units else "", ", ".join(scalars)) if part
    )


def _shown(p: dict, unit: str, key: str, fmt: str, bound: bool = False) -> str:
    """``unit``'s ``key`` with its SE; ``bound``: its k is flagged ``at_bound`` (k and the
    force at the reference depth, a function of it, are then no estimates: no SE)."""
    e = p[unit]
    if not e.get("identified", True):
        return f"{unit} not identified"
    if bound:
        return f"{unit} {e[key]:{fmt}} {BOUND_TEXT}"
    se = e.get(key + "_se")
    if not se:  # fixed (a held-out stance's frozen law): no uncertainty of its own here
        return f"{unit} {e[key]:{fmt}} (fixed)"
    value = f"{e[key]:{fmt}}"
    return f"{unit} {value}±{se_text(se, value)}"


def fit_quality(fits: list) -> tuple[dict, dict]:
    """Per-side channel RMS (% BW, % BW·H over in-contact frames, each stance normalised by its
    own body weight and height) and COP RMS [mm] (in-contact frames where measured Fz > 10 % BW)."""
    rms: dict = {}
    cop: dict = {}
    for side in SIDES:
        mine = [f for f in fits if f["side"] == side]
        if not mine:
            continue
        # normalise per stance, then pool: channel_rms_pct of (0, error / BW) with BW = 1; the
        # error is the measurement model's (a censored sample counts only for a force above
        # the plate's threshold, :mod:`gc_ocp.estimation.measurement`)
        err = np.vstack([_per_bw(f, fit_error(f)) for f in mine])
        pct = channel_rms_pct(np.zeros_like(err), err, 1.0, 1.0)
        rms[side] = {TABLE_KEYS[c]: v for c, v in pct.items()}
        errs = []
        for f in mine:
            m, w = f["measured"], f["model"]
            ref, gh, bw = f["reference_point"], f["ground_height"], f["body_weight"]
            c_meas = cop_from_wrench(m[:, :3], m[:, 3:], ref, gh, COP_MIN_FRACTION_BW * bw)
            c_mod = cop_from_wrench(w[:, :3], w[:, 3:], ref, gh, 1e-6)
            # in-contact frames only, as the channel RMS: a loaded frame of the margin (a plate
            # that crosses its threshold twice at toe-off) has a model force near 0 whose COP is
            # meaningless (one such frame gave 177 mm on a 26 mm stance)
            ok = np.isfinite(c_meas[:, 0]) & np.isfinite(c_mod[:, 0]) & np.asarray(f["in_contact"])
            errs.append(np.linalg.norm((c_meas - c_mod)[ok, :2], axis=1))
        e = np.concatenate(errs)
        cop[side] = float(np.sqrt(np.mean(e**2)) * 1e3) if e.size else float("nan")
    return rms, cop


def _per_bw(fit: dict, wrench: np.ndarray) -> np.ndarray:
    """In-contact frames of ``wrench`` in units of BW (forces) and BW x H (torques)."""
    bw, h = fit["body_weight"], fit["height"]
    return np.asarray(wrench)[np.asarray(fit["in_contact"])] / np.array(
        [bw, bw, bw, bw * h, bw * h, bw * h]
    )


__all__ = [
    "FIT_FORMAT",
    "FIT_KEYS",
    "EstimationResult",
    "as_result",
    "check_fit_document",
    "fit_quality",
]
