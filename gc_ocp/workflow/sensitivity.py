"""How much do the headline parameters depend on processing choices a user makes?

A standard error measures the noise of one analysis; it says nothing about the choices made
before it. :func:`sensitivity` refits the same trials with each alternative choice (the marker
low-pass cutoff; the unloaded margin kept around each stance) and reports, for the shared law
parameters and each unit's force at the reference depth, the value per choice, the spread
across choices, and the ratio of that spread to the reported SE. A ratio well above 1 means the
processing, not the noise, limits what the fit says.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from gc_ocp.errors import InputError, SolveError
from gc_ocp.kinematics import compute_kinematics as default_kin
from gc_ocp.kinematics.filtering import DEFAULT_CUTOFF_HZ
from gc_ocp.workflow.fitting import MARGIN, fit

DEFAULT_CUTOFFS = (4.0, 6.0, 8.0)
DEFAULT_MARGINS = (0.03, 0.06)
SENSITIVE_RATIO = 2.0
"""A parameter whose values across the processing choices spread over more than this many of
its SEs is flagged (``processing_sensitive``): the refits see the same data, so their spread is
not noise, and at twice the SE the choices, not the noise, set how well it is known."""


@dataclasses.dataclass
class SensitivityReport:
    """choices: labels; values: ``{parameter: [value per choice]}``; se: ``{parameter: SE of the
    reference choice}``; reference: the label of the default choice; failed: ``{choice: why}``
    of the refits that did not converge or were refused (their values NaN)."""

    choices: list
    values: dict
    se: dict
    reference: str
    failed: dict = dataclasses.field(default_factory=dict)

    def spread(self, p: str) -> float:
        v = np.asarray(self.values[p], float)
        return float(np.nanmax(v) - np.nanmin(v))

    def ratio(self, p: str) -> float:
        """The spread of ``p`` across the choices in units of its SE (NaN without an SE)."""
        se = self.se.get(p, float("nan"))
        return self.spread(p) / se if se and np.isfinite(se) and se > 0 else float("nan")

    def rows(self) -> list[tuple[str, list, float, float]]:
        """``(parameter, value per choice, spread, spread / SE)`` per parameter."""
        return [(p, list(v), self.spread(p), self.ratio(p)) for p, v in self.values.items()]

    def flags(self) -> list[dict]:
        """A ``processing_sensitive`` flag per parameter beyond :data:`SENSITIVE_RATIO`; a
        ``sensitivity_refit_failed`` flag per choice whose refit failed."""
        failed = [
            {
                "code": "sensitivity_refit_failed",
                "what": c,
                "message": f"the refit at {c} failed ({why}): the spreads are over the other "
                "settings only",
            }
            for c, why in self.failed.items()
        ]
        return failed + [
            {
                "code": "processing_sensitive",
                "what": p,
                "message": f"{p} moves {r:.1f} SE across {len(self.choices)} processing "
                f"settings ({', '.join(self.choices)}): its SE understates what the "
                "processing adds",
            }
            for p, _, _, r in self.rows()
            if r > SENSITIVE_RATIO
        ]

    def summary(self) -> str:
        head = " | ".join(self.choices)
        lines = [
            f"| parameter | {head} | spread | spread / SE |",
            "|---|" + "---|" * (len(self.choices) + 2),
        ]
        for p, vals, spread, ratio in self.rows():
            lines.append(
                f"| {p} | "
                + " | ".join(f"{v:.4g}" for v in vals)
                + f" | {spread:.3g} | {ratio:.1f} |"
            )
        return "\n".join(lines)

    def with_se(self, result) -> SensitivityReport:
        """The same values measured against ``result``'s SEs (the fit the user reports: its
        hold-out, widths and options), where it has them."""
        _, se = _headline(result)
        return dataclasses.replace(self, se={k: se.get(k, v) for k, v in self.se.items()})

    def to_json(self) -> dict:
        return dataclasses.asdict(self)


def _headline(result) -> tuple[dict, dict]:
    vals, ses = {}, {}
    p = result.params
    for k, v in p.get("shared", {}).items():
        if not k.endswith("_se"):
            vals[k], ses[k] = v, p["shared"].get(k + "_se", float("nan"))
    for side, units in p.items():
        if side == "shared":
            continue
        for u, e in units.items():
            if isinstance(e, dict):
                vals[f"f_ref {side} {u}"], ses[f"f_ref {side} {u}"] = e["f_ref"], e["f_ref_se"]
    return vals, ses


def sensitivity(
    trials,
    model: tuple | None = None,
    cutoffs=DEFAULT_CUTOFFS,
    margins=DEFAULT_MARGINS,
    compute_kinematics: Callable | None = None,
    progress: Callable[[str], None] | None = None,
    bias_correction: int | None = 0,
    reference_cutoff: float = DEFAULT_CUTOFF_HZ,
    fit_options: dict | None = None,
) -> SensitivityReport:
    """Refit ``trials`` (a list of :class:`~gc_ocp.trial.Trial`) once per marker cutoff [Hz] and
    once per stance margin [s] (the margins at the reference cutoff); the reference choice is
    ``reference_cutoff`` (the default 6 Hz; added to ``cutoffs`` when not among them) with the
    default margin (0.03 s). ``fit_options``: the reported fit's other options
    (:func:`~gc_ocp.workflow.fitting.fit`'s ``holdout``, ``pose_scale``, ``sole_scale``,
    ``pose_correlation``, ``extends``, ...), given to every refit, so that the reference refit is
    the fit reported and the others differ from it by their choice alone.
    ``bias_correction``: as :func:`~gc_ocp.workflow.fitting.fit`'s; by default none, so that the
    differences are the choices' own (the correction's replicates would add their Monte Carlo
    spread, and the markers' noise at the units, which decides it by default, changes with the
    cutoff)."""
    kin_fn = compute_kinematics or default_kin
    say = progress or (lambda s: None)
    fit_options = dict(fit_options or {})
    ref_cut = float(reference_cutoff)
    cuts = [float(c) for c in cutoffs]
    if ref_cut not in cuts:
        cuts = sorted({*cuts, ref_cut})
    ref_label = f"{ref_cut:g} Hz, {MARGIN * 1e3:.0f} ms"
    runs: list[tuple[str, dict, dict]] = []
    failed: dict = {}
    kin_cache: dict = {}
    for cut in cuts:
        for margin in margins if cut == ref_cut else (MARGIN,):
            label = f"{cut:g} Hz, {margin * 1e3:.0f} ms"
            say(f"sensitivity: {label}")
            try:  # a choice that fails is recorded: the fit reported stands without it
                if cut not in kin_cache:
                    kin_cache[cut] = [kin_fn(t, cutoff_hz=cut) for t in trials]
                rep = fit(
                    list(zip(trials, kin_cache[cut], strict=True)),
                    model=model,
                    margin=margin,
                    bias_correction=bias_correction,
                    **fit_options,
                )
            except (InputError, SolveError) as e:
                failed[label] = " ".join(str(e).split())
                say(f"sensitivity: {label}: failed ({failed[label]})")
                runs.append((label, {}, {}))
                continue
            vals, ses = _headline(rep.result)
            runs.append((label, vals, ses))
    made = [r for r in runs if r[0] not in failed] or runs
    ref = next((r for r in made if r[0] == ref_label), made[0])
    keys = list(dict.fromkeys(k for r in made for k in r[1]))
    return SensitivityReport(
        choices=[r[0] for r in runs],
        values={k: [r[1].get(k, float("nan")) for r in runs] for k in keys},
        se={k: ref[2].get(k, float("nan")) for k in keys},
        reference=ref[0],
        failed=failed,
    )


__all__ = ["SENSITIVE_RATIO", "SensitivityReport", "sensitivity"]
