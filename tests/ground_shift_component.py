"""A throw-away component: one constant vertical shift of the ground under each foot [m].

It exists to show (and test) that a new effect is one file plus one registration line: nothing
in the estimator knows it. Prior N(0, sigma^2) per foot, bounded by +-bound.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca

from gc_ocp.estimation.components import Component, SummaryRow


@dataclass(frozen=True)
class GroundShift(Component):
    sigma: float = 0.003
    bound: float = 0.02
    fixed: dict | None = None
    name: str = "ground_shift"
    neutral_at_zero = True

    def declare(self, variables, stances) -> None:
        if self.fixed is None:
            for side in dict.fromkeys(st.side for st in stances):
                variables.prior_variable((self.name, side), 1, self.sigma, self.bound)

    def slot_sizes(self, layout) -> dict[str, int]:
        return {"ground_shift": 1}

    def slots(self, variables, index, stance) -> dict:
        if self.fixed is not None:
            return {"ground_shift": ca.MX(1, 1) + self.fixed[stance.side]}
        return {"ground_shift": variables.get((self.name, stance.side))}

    def edit_contact(self, frame) -> None:
        frame.ground_height = frame.ground_height + frame.slot("ground_shift")

    def signature(self) -> tuple:
        return ("GroundShift",)

    def decode(self, ctx) -> dict:
        out = {}
        for side in dict.fromkeys(st.side for st in ctx.stances):
            if self.fixed is not None:
                out[side] = {"mm": self.fixed[side] * 1e3, "se_mm": 0.0}
            else:
                v, s = ctx.values((self.name, side))
                out[side] = {"mm": float(v[0]) * 1e3, "se_mm": float(s[0]) * 1e3}
        return out

    @classmethod
    def describe(cls, block: dict) -> list[SummaryRow]:
        return [SummaryRow(f"{side} shift", v["mm"], v["se_mm"], "mm") for side, v in block.items()]

    def frozen(self, block: dict) -> GroundShift:
        return replace(self, fixed={s: v["mm"] * 1e-3 for s, v in block.items()})
