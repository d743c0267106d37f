"""Sole geometry: 3-D corrections of the unit positions in their parent (foot) frames."""

from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from gc_ocp.estimation.components.base import Component, DecodeContext, per_axis
from gc_ocp.estimation.components.contact import _layouts
from gc_ocp.trial import SIDES


@dataclass(frozen=True)
class SoleCorrection(Component):
    """Correction of each unit's position in its parent frame, added to ``points_local``.

    A Gaussian prior N(0, sigma^2) per component (default 5 mm: the uncertainty of locating the
    sole from skin markers over heel and metatarsals; ``sigma`` one width, or one per foot-frame
    axis x, y, z as :func:`~gc_ocp.estimation.pose_scale.estimate_pose_scale` estimates them)
    and bounds +-bound [m].
    ``fixed``: ``{side: (m, 3) array [m]}`` to apply known corrections without estimating them.
    Neutral value: zero offsets (no effect).

    As the candidate effect ``sole_geometry`` (against the bare seed base): the benchmark adds
    offsets drawn from U(-v, v) per axis and unit (``v`` = 2 mm moderate, 4 mm strong) to the
    base's fitted offsets (or applies them alone to a base without a sole correction).
    """

    sigma: float | tuple[float, float, float] = 0.005
    bound: float = 0.025
    fixed: dict | None = None
    name: str = "sole"
    neutral_at_zero = True
    width_fields = ("sigma",)  # the bound is kept
    candidate = True
    benchmark_values = {
        "small": 1e-3,
        "moderate": 2e-3,
        "strong": 4e-3,
    }  # half-range of U per axis [m]

    @classmethod
    def inject(cls, base, value, stances, rng) -> tuple:
        """Offsets U(-value, value) per axis and unit (one draw per side, sides sorted), added to
        the fitted offsets of a base sole correction (or a new one)."""
        sides = sorted({st.side for st in stances})
        offsets = {s: rng.uniform(-value, value, (stances[0].layout.n, 3)) for s in sides}
        have = next((c for c in base if isinstance(c, cls)), None)
        if have is not None:
            offsets = {s: np.asarray(have.fixed[s]) + offsets[s] for s in sides}
            return tuple(cls(fixed=offsets) if c is have else c for c in base)
        return (*base, cls(fixed=offsets))

    def for_layout(self, layout, weights):
        """The same correction (variables, prior, bounds, fixed values) of the nominal units,
        carried to a dense sole whose units interpolate them by ``weights``."""
        from gc_ocp.estimation.components.contact_density import DenseSoleCorrection

        return DenseSoleCorrection(
            W=tuple(map(tuple, weights)),
            sigma=self.sigma,
            bound=self.bound,
            fixed=self.fixed,
            name=self.name,
        )

    def declare(self, variables, stances) -> None:
        if self.fixed is not None:
            return
        layouts = _layouts(stances)
        for side in SIDES:
            lay = layouts.get(side, next(iter(layouts.values())))
            for u in lay.units:
                variables.prior_variable((self.name, side, u), 3, self.sigma, self.bound)

    def slot_sizes(self, layout) -> dict[str, int]:
        return {"points_local": 3 * layout.n}

    def slots(self, variables, index, stance) -> dict:
        if self.fixed is not None:
            off = np.asarray(self.fixed[stance.side], float)
            return {"points_local": ca.MX(off.ravel())}  # row-major (m, 3) = column-major 3 x m
        return {
            "points_local": ca.vertcat(
                *(variables.get((self.name, stance.side, u)) for u in stance.layout.units)
            )
        }

    def signature(self) -> tuple:
        return ("SoleCorrection",)  # its values only enter through the points_local slot

    def decode(self, ctx: DecodeContext) -> dict:
        """``{side: {unit: [dx, dy, dz]}}`` in the foot frame [mm] (``"se"``: their SEs;
        ``"prior_mm"``: the prior's widths x, y, z)."""
        out: dict = {}
        se: dict = {}
        for side, lay in _layouts(ctx.stances).items():
            if self.fixed is not None:
                off = np.asarray(self.fixed[side], float) * 1e3
                out[side] = {u: off[i].tolist() for i, u in enumerate(lay.units)}
                se[side] = {u: [0.0, 0.0, 0.0] for u in lay.units}
                continue
            out[side], se[side] = {}, {}
            for u in lay.units:
                v, s = ctx.values((self.name, side, u))
                out[side][u] = (v * 1e3).tolist()
                se[side][u] = (s * 1e3).tolist()
        block = {"offsets_mm": out, "se_mm": se}
        if self.fixed is None:
            block["prior_mm"] = (per_axis(self.sigma) * 1e3).tolist()
        return block

    def frozen(self, block: dict) -> SoleCorrection:
        fixed = {
            s: np.array(list(units.values())) * 1e-3 for s, units in block["offsets_mm"].items()
        }
        return replace(self, fixed=fixed)


__all__ = ["SoleCorrection"]
