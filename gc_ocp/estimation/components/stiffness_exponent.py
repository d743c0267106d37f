"""Penetration exponent: the ``n`` of the contact law's ``F_n = k d^n``, estimated."""

from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from gc_ocp.estimation.components.base import Component, DecodeContext, SummaryRow


@dataclass(frozen=True)
class StiffnessExponent(Component):
    """Nonlinear force-depth curve of every contact unit, ``F_n = k d^n`` with ``n`` estimated.

    What it models: a sole stiffens as it is compressed (the heel pad and a foam midsole
    compact; a rounded heel or forefoot widens its contact patch, Hertz: n = 1.5). The base law
    is linear (n = 1): with n > 1 the force rises later and more steeply in each unit, which the
    base model can only mimic by moving the centre of pressure and the unit stiffnesses.

    Variable: ``m = n - 1`` [-], one shared by both feet and all units, keyed ``(name, "n")``;
    stored as ``m`` so that the stored value 0 means n = 1 (the base law). It enters the contact
    law's slot ``"law_n"`` (slots of the same name are summed); :meth:`configure` fixes the law's
    own exponent at 1, so the law contributes 1 and this component ``n - 1``.

    Units of k: k [N/m^n] changes units with n, and ``ln f = ln k + n ln d`` makes k and n
    strongly correlated. While n is estimated, the component also adds ``-(n - 1) ln d_p`` to
    the law's slot ``"log_k"`` (``d_p = pivot_depth``, 5 mm, the typical unit penetration of
    ``gc_ocp.estimation.starts.TYPICAL_DEPTH``): the law's stiffness *variable* is then
    ``k_1 = f(d_p) / d_p`` [N/m], the force at the pivot depth per metre, whatever n; the
    physical stiffness is ``k = k_1 d_p^(1 - n)`` [N/m^n] (the slot, which the contact block
    reports, with ``f_ref``). Changing n then keeps each unit's force at 5 mm, the problem is
    better conditioned, and the law's log-k prior (centred on an n = 1 stiffness) does not pull n
    back to 1. A frozen component (``fixed``) adds nothing to ``"log_k"``: a frozen contact law
    holds the physical k.

    Bounds: n in ``[lower, upper] = [1, 3]``, no prior. n < 1 would make a unit infinitely stiff
    at touch-down (a concave force-depth curve, which no compressed solid has); n = 3 is already
    the steep end of foams and soft tissue; inside these bounds the shape of the force rise and
    fall on three stances determines n to a few hundredths, so no prior is needed (the optional
    ``prior_sigma`` [-] is a Gaussian prior on n centred on ``value``).

    value: initial n [-]. fixed: n applied without estimating it (as set by :meth:`frozen`).
    pivot_depth: depth [m] at which the law's stiffness variable is defined (see above).

    Neutral value: n = 1 (stored 0) leaves the base model (``ContactLaw.base``, n fixed at 1)
    exactly as it is. ``neutral_at_zero`` is nevertheless False: the component *replaces* the
    law's own exponent, so with a law whose n is free (``full_model``, the contract test's law)
    the model at n = 1 differs from the model without this component.
    """

    value: float = 1.2
    lower: float = 1.0
    upper: float = 3.0
    prior_sigma: float | None = None
    fixed: float | None = None
    pivot_depth: float = 0.005
    name: str = "stiffness_exponent"
    candidate = True
    law_parameter = "n"
    benchmark_values = {"small": 1.125, "moderate": 1.25, "strong": 1.5}  # n [-]

    @classmethod
    def inject(cls, base, value, stances, rng) -> tuple:
        """The base plus ``n = value``, the base law's per-unit k rescaled to keep each unit's
        force at the law's reference depth (5 mm)."""
        law = next(c for c in base if c.name == "contact")
        d = law.reference_depth
        k = {s: {u: kv * d ** (1 - value) for u, kv in ks.items()} for s, ks in law.k.value.items()}
        return (*(c.with_law_fixed("k", k) for c in base), cls(fixed=float(value)))

    # --- configuration ------------------------------------------------------------------------
    @classmethod
    def present_in(cls, model: tuple) -> bool:
        """Also present when the model's contact law estimates its own ``n`` (``full_model``)."""
        return super().present_in(model) or any(c.law_estimates("n") for c in model)

    def configure(self, model: tuple) -> tuple:
        """The contact law's own exponent fixed at 1: this component gives ``n - 1``."""
        return tuple(c.with_law_fixed("n", 1.0) for c in model)

    # --- variables ----------------------------------------------------------------------------
    @property
    def _key(self) -> tuple:
        return (self.name, "n")

    def declare(self, variables, stances) -> None:
        if self.fixed is None:
            variables.parameter(
                self._key,
                self.value - 1.0,
                self.lower - 1.0,
                self.upper - 1.0,
                prior_sigma=self.prior_sigma,
                shown=(1.0, 1.0, ""),  # stored n - 1, read as n
            )

    # --- per-frame inputs ---------------------------------------------------------------------
    def slot_sizes(self, layout) -> dict[str, int]:
        return {"law_n": 1, "log_k": layout.n}

    def slots(self, variables, index, stance) -> dict:
        if self.fixed is not None:
            return {"law_n": ca.MX(1, 1) + (float(self.fixed) - 1.0)}
        m = variables.get(self._key)
        shift = -float(np.log(self.pivot_depth)) * m
        return {"law_n": m, "log_k": ca.repmat(shift, stance.layout.n, 1)}

    def signature(self) -> tuple:
        return ("StiffnessExponent",)  # its value only enters through the law_n / log_k slots

    # --- results ------------------------------------------------------------------------------
    def decode(self, ctx: DecodeContext) -> dict:
        """``{"n": .., "n_se": ..}`` [-] (fixed: SE 0). The unit stiffnesses k [N/m^n] and
        their forces at the reference depth are in the contact law's block."""
        if self.fixed is not None:
            return {"n": float(self.fixed), "n_se": 0.0}
        v, s = ctx.values(self._key)
        return {"n": 1.0 + float(v[0]), "n_se": float(s[0])}

    @classmethod
    def describe(cls, block: dict) -> list[SummaryRow]:
        return [SummaryRow("n", block["n"], block["n_se"], "-", ("n",))]

    def frozen(self, block: dict) -> StiffnessExponent:
        return replace(self, fixed=float(block["n"]))


__all__ = ["StiffnessExponent"]
