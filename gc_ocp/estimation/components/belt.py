"""Treadmill belt speed: one correction per treadmill trial."""

from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from gc_ocp.estimation.components.base import Component, DecodeContext
from gc_ocp.estimation.flags import flag


@dataclass(frozen=True)
class BeltSpeed(Component):
    """Correction of the treadmill belt speed [m/s], one per treadmill trial.

    The nominal speed (``Trial.belt_velocity``) is rarely known to better than a few cm/s, and the
    sliding velocity of every unit is taken relative to the belt: a small error turns Coulomb
    friction into a large spurious shear force. Gaussian prior N(0, sigma^2), bounds +-bound.
    Trials with no belt (overground) get no variable. ``fixed``: ``{trial: correction [m/s]}``
    applied without estimating it (a held-out stance of a fitted trial). Neutral value: 0.
    """

    sigma: float = 0.1
    bound: float = 0.5
    fixed: dict | None = None
    name: str = "belt"
    scope = "trial"
    neutral_at_zero = True

    def _free(self, trial: str) -> bool:
        return self.fixed is None or trial not in self.fixed

    def declare(self, variables, stances) -> None:
        for trial in dict.fromkeys(st.trial for st in stances if np.any(st.belt_velocity != 0)):
            if self._free(trial):
                variables.prior_variable((self.name, trial), 1, self.sigma, self.bound)

    def slot_sizes(self, layout) -> dict[str, int]:
        return {"belt_correction": 1}

    def slots(self, variables, index, stance) -> dict:
        key = (self.name, stance.trial)
        if variables.has(key):
            return {"belt_correction": variables.get(key)}
        return {"belt_correction": ca.MX(1, 1) + float((self.fixed or {}).get(stance.trial, 0.0))}

    def edit_contact(self, frame) -> None:
        # the belt runs along -X: a faster belt is more negative
        frame.belt_velocity = frame.belt_velocity - ca.vertcat(frame.slot("belt_correction"), 0, 0)

    def signature(self) -> tuple:
        return ("BeltSpeed",)

    def decode(self, ctx: DecodeContext) -> dict:
        """``{trial: {"value", "se", "nominal", "correction"}}`` [m/s] for treadmill trials."""
        out: dict = {}
        index = ctx.index()
        for st in ctx.stances:
            if st.trial in out or not np.any(st.belt_velocity != 0):
                continue
            nominal = float(-st.belt_velocity[0])
            if (self.name, st.trial) in index:
                v, s = ctx.values((self.name, st.trial))
                dv, se = float(v[0]), float(s[0])
            else:
                dv, se = float((self.fixed or {}).get(st.trial, 0.0)), 0.0
            out[st.trial] = {"value": nominal + dv, "se": se, "nominal": nominal, "correction": dv}
        return out

    def flags(self, block: dict, stances: list) -> list[dict]:
        """The belt speed is *not informed* when its SE is at least 90 % of its prior sigma: the
        posterior is the prior (e.g. a belt speed given for an overground trial)."""
        return [
            flag(
                "belt_not_informed",
                trial,
                f"belt speed of {trial}: SE {v['se']:.3f} m/s ~ its prior {self.sigma:g} m/s: the data do not "
                "inform it (is this really a treadmill trial?)",
            )
            for trial, v in block.items()
            if np.isfinite(v["se"]) and v["se"] >= 0.9 * self.sigma and v["se"] > 0
        ]

    def frozen(self, block: dict) -> BeltSpeed:
        return replace(self, fixed={t: v["correction"] for t, v in block.items()})


__all__ = ["BeltSpeed"]
