"""Hunt-Crossley dissipation: the damping ``c`` of the contact law, estimated."""

from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca

from gc_ocp.estimation.components.base import Component, DecodeContext, SummaryRow
from gc_ocp.trial import SIDES


@dataclass(frozen=True)
class Damping(Component):
    """Hunt-Crossley dissipation of every contact unit, ``F_n = k d^n (1 + c d_dot)``.

    What it models: the sole (heel pad, shoe midsole) pushes back harder while it is being
    compressed than while it recovers; in the Hunt-Crossley form the viscous term is proportional
    to the elastic force, so the force stays continuous at touch-down whatever the impact speed.
    It loads the force-rise at heel strike and unloads the push-off, mostly in the vertical force
    and the sagittal moment.

    Variable: ``c`` [s/m], one shared by both feet (``per_foot=True``: one per foot, keyed
    ``(name, "c", side)``); it is stored as itself (scale 1: typical values are O(1)), so the
    stored value 0 means no damping. It enters the contact law's slot ``"law_c"`` (slots of the
    same name are summed); :meth:`configure` fixes the contact law's own ``c`` at 0 so that the
    damping is not estimated twice, and this component owns it.

    Bounds ``[lower, upper] = [0, 10]`` s/m, no prior (``prior_sigma=None``). ``c < 0`` would
    make a compressing sole push back *less* than a recovering one (energy created in every
    step); the upper bound is generous: with penetration rates of 0.05-0.3 m/s during loading,
    c = 10 s/m would double or quadruple the force, far beyond the 0.5-2 s/m reported for
    heel pads and shoe soles (e.g. the values used with OpenSim's Hunt-Crossley contact). Inside
    the bounds the data (the force's asymmetry between loading and unloading at equal depth)
    determine c on three stances to a few hundredths of a s/m, so no prior is needed; one can be
    given (``prior_sigma`` [s/m], Gaussian, centred on ``value``) when the plate is noisy.

    value: initial value [s/m] (float, or ``{side: float}`` with ``per_foot``).
    fixed: ``c`` [s/m] applied without estimating it (float, or ``{side: float}``), as set by
    :meth:`frozen`.

    Neutral value: ``c = 0`` (the stored variable at 0) leaves the base model (``ContactLaw.base``,
    c fixed at 0) exactly as it is. ``neutral_at_zero`` is nevertheless False: the component
    *replaces* the law's own damping, so with a law whose ``c`` is free (``full_model``, the
    contract test's law) the model at c = 0 differs from the model without this component.
    """

    per_foot: bool = False
    value: float | dict = 0.5
    lower: float = 0.0
    upper: float = 10.0
    prior_sigma: float | None = None
    fixed: float | dict | None = None
    name: str = "damping"
    candidate = True
    law_parameter = "c"
    benchmark_values = {"small": 0.25, "moderate": 0.5, "strong": 1.0}  # c [s/m]

    @classmethod
    def inject(cls, base, value, stances, rng) -> tuple:
        """The base plus a shared ``c = value`` [s/m]."""
        return (*base, cls(fixed=float(value)))

    # --- configuration ------------------------------------------------------------------------
    @classmethod
    def present_in(cls, model: tuple) -> bool:
        """Also present when the model's contact law estimates its own ``c`` (``full_model``)."""
        return super().present_in(model) or any(c.law_estimates("c") for c in model)

    def configure(self, model: tuple) -> tuple:
        """The contact law's own damping fixed at 0: this component gives the whole of ``c``."""
        return tuple(c.with_law_fixed("c", 0.0) for c in model)

    # --- variables ----------------------------------------------------------------------------
    def _key(self, side: str) -> tuple:
        return (self.name, "c", side) if self.per_foot else (self.name, "c")

    def _at(self, v, side: str) -> float:
        return float(v[side]) if isinstance(v, dict) else float(v)

    def declare(self, variables, stances) -> None:
        if self.fixed is not None:
            return
        for side in SIDES if self.per_foot else SIDES[:1]:
            variables.parameter(
                self._key(side),
                self._at(self.value, side),
                self.lower,
                self.upper,
                prior_sigma=self.prior_sigma,
            )

    # --- per-frame inputs ---------------------------------------------------------------------
    def slot_sizes(self, layout) -> dict[str, int]:
        return {"law_c": 1}

    def slots(self, variables, index, stance) -> dict:
        if self.fixed is not None:
            return {"law_c": ca.MX(1, 1) + self._at(self.fixed, stance.side)}
        return {"law_c": variables.get(self._key(stance.side))}

    def signature(self) -> tuple:
        return ("Damping",)  # its value only enters through the law_c slot

    # --- results ------------------------------------------------------------------------------
    def decode(self, ctx: DecodeContext) -> dict:
        """``{"c": .., "c_se": ..}`` [s/m]; with ``per_foot`` each is ``{side: ..}``. Fixed
        values have SE 0."""
        sides = SIDES if self.per_foot else SIDES[:1]
        val, se = {}, {}
        for side in sides:
            if self.fixed is not None:
                val[side], se[side] = self._at(self.fixed, side), 0.0
            else:
                v, s = ctx.values(self._key(side))
                val[side], se[side] = float(v[0]), float(s[0])
        if self.per_foot:
            return {"c": val, "c_se": se}
        return {"c": val[SIDES[0]], "c_se": se[SIDES[0]]}

    @classmethod
    def describe(cls, block: dict) -> list[SummaryRow]:
        """``c`` [s/m] (per foot: one row per side)."""
        if isinstance(block["c"], dict):
            return [
                SummaryRow(f"c ({s})", v, block["c_se"][s], "s/m", ("c", s))
                for s, v in block["c"].items()
            ]
        return [SummaryRow("c", block["c"], block["c_se"], "s/m", ("c",))]

    def frozen(self, block: dict) -> Damping:
        c = block["c"]
        return replace(self, fixed=dict(c) if isinstance(c, dict) else float(c))


__all__ = ["Damping"]
