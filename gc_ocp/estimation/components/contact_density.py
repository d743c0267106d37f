"""Contact density: a denser sole whose unit stiffnesses follow a smooth low-dimensional field."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import ClassVar

import casadi as ca
import numpy as np

from gc_ocp.errors import ModelError
from gc_ocp.estimation.components.base import Component, DecodeContext, SummaryRow, per_axis
from gc_ocp.estimation.components.contact import _layouts
from gc_ocp.foot import SEED_LAYOUT, SoleLayout
from gc_ocp.trial import SIDES

NOMINAL = SEED_LAYOUT.units  # PL, PM, AL, AM, TT
BASIS = ("1", "xi", "eta", "xi^2")
"""The stiffness field's basis over normalised foot coordinates: xi from the heel row (-1) to the
toe tip (+1), eta from the lateral (-1) to the medial (+1) edge."""


def dense_design(n_long: int = 4, n_lat: int = 3, toe_rows: tuple = (0.5,)):
    """The dense sole as interpolation weights of the five nominal units.

    Returns ``(W, layout)``: ``W`` ``(m, 5)`` weights (rows sum to 1) of the nominal points
    ``PL, PM, AL, AM, TT`` (all in the hindfoot frame) for each dense unit, and its
    :class:`SoleLayout`. Hindfoot units: a bilinear ``n_long x n_lat`` grid between the
    posterior pair (PL, PM) and the anterior pair (AL, AM), which sit under the metatarsal heads
    on the MTP line. Toes units: for each fraction ``s`` in ``toe_rows``, ``n_lat`` units on the
    way ``s`` from the anterior edge to TT (the triangle AL-TT-AM), then TT itself."""
    rows, parents = [], []

    def w(pl, pm, al, am, tt):
        return [pl, pm, al, am, tt]

    for a in np.linspace(0.0, 1.0, n_long):
        for u in np.linspace(0.0, 1.0, n_lat):
            rows.append(w((1 - a) * (1 - u), (1 - a) * u, a * (1 - u), a * u, 0.0))
            parents.append("hindfoot")
    for s in toe_rows:
        for u in np.linspace(0.0, 1.0, n_lat):
            rows.append(w(0.0, 0.0, (1 - s) * (1 - u), (1 - s) * u, s))
            parents.append("toes")
    rows.append(w(0, 0, 0, 0, 1.0))
    parents.append("toes")
    units = tuple(f"D{i:02d}" for i in range(len(rows)))
    return np.array(rows, float), SoleLayout(units, tuple(parents))


def _toes_relative(foot) -> tuple[np.ndarray, np.ndarray]:
    """``(R, o)``: the toes frame in the hindfoot frame on the stance's first frame (the toes are
    welded in the recorded kinematics; with a toe joint this is the configuration the sole
    outline is drawn in)."""
    H, Tt = foot.hindfoot_pose[0], foot.toes_pose[0]
    Rh = H[:3, :3]
    return Rh.T @ Tt[:3, :3], Rh.T @ (Tt[:3, 3] - H[:3, 3])


def _check_nominal(layout: SoleLayout, what: str) -> None:
    if layout != SEED_LAYOUT:
        raise ModelError(
            f"contact_density interpolates the seed's five units {SEED_LAYOUT.units}, but {what} "
            f"has the layout {layout.units}"
        )


def _in_hindfoot(points: np.ndarray, layout: SoleLayout, R: np.ndarray, o: np.ndarray):
    """``(m, 3)`` unit points (each in its parent frame) in the hindfoot frame."""
    out = np.array(points, float)
    for i in layout.on("toes"):
        out[i] = o + R @ out[i]
    return out


def _offset_map(W: np.ndarray, layout: SoleLayout, R: np.ndarray) -> np.ndarray:
    """``(3 m, 15)``: dense units' offsets (each in its parent frame, stacked x, y, z per unit)
    from the nominal units' offsets (each in its parent frame, same stacking): the same
    interpolation weights as the points. Offsets are directions: only the rotation enters."""
    m = W.shape[0]
    to_h = [np.eye(3)] * 4 + [R]  # nominal offset -> hindfoot frame (TT is on the toes)
    M = np.zeros((3 * m, 15))
    for j in range(m):
        back = R.T if layout.parents[j] == "toes" else np.eye(3)
        for i in range(5):
            M[3 * j : 3 * j + 3, 3 * i : 3 * i + 3] = W[j, i] * back @ to_h[i]
    return M


def field_basis(foot) -> np.ndarray:
    """``(m, 4)`` values of :data:`BASIS` at the dense units of ``foot`` (coordinates in the
    hindfoot frame, normalised over the dense units' extent; eta positive medially on either
    foot, from the posterior pair's lateral-to-medial direction)."""
    layout = foot.layout
    R, o = _toes_relative(foot)
    p = _in_hindfoot(foot.points_local, layout, R, o)
    x, y = p[:, 0], p[:, 1]
    xi = (2 * x - (x.max() + x.min())) / (x.max() - x.min())
    medial = np.sign(p[2, 1] - p[0, 1])  # dense unit 0 is PL, unit 2 (n_lat = 3) is PM
    eta = medial * (2 * y - (y.max() + y.min())) / (y.max() - y.min())
    return np.column_stack([np.ones_like(xi), xi, eta, xi**2])


@dataclass(frozen=True)
class DenseSoleCorrection(Component):
    """The sole correction of the five nominal units, carried to a dense sole.

    The same variables, prior and bounds as :class:`SoleCorrection` (one 3-D offset per nominal
    unit, in its parent frame, N(0, sigma^2), +-bound [m]); each dense unit moves by the same
    interpolation weights that place it (:func:`dense_design`), so the dense sole is the nominal
    outline, corrected. Result block as :class:`SoleCorrection`'s (nominal units), so that
    ``SoleCorrection.frozen`` reads it. Built by :meth:`SoleCorrection.for_layout` when
    :meth:`ContactDensity.configure` asks for the dense sole.
    """

    W: tuple = ()
    sigma: float | tuple[float, float, float] = 0.005  # one width, or per foot-frame axis
    bound: float = 0.025
    fixed: dict | None = None
    name: str = "sole"
    neutral_at_zero = True
    width_fields = ("sigma",)  # the bound is kept

    def declare(self, variables, stances) -> None:
        if self.fixed is None:
            for side in SIDES:
                for u in NOMINAL:
                    variables.prior_variable((self.name, side, u), 3, self.sigma, self.bound)

    def slot_sizes(self, layout) -> dict[str, int]:
        return {"points_local": 3 * layout.n}

    def slots(self, variables, index, stance) -> dict:
        R, _ = _toes_relative(stance.foot)
        M = ca.DM(_offset_map(np.array(self.W), stance.layout, R))
        if self.fixed is not None:
            return {"points_local": M @ ca.DM(np.asarray(self.fixed[stance.side], float).ravel())}
        off = ca.vertcat(*(variables.get((self.name, stance.side, u)) for u in NOMINAL))
        return {"points_local": ca.mtimes(M, off)}

    def signature(self) -> tuple:
        return ("DenseSoleCorrection",)

    def decode(self, ctx: DecodeContext) -> dict:
        """``{"offsets_mm": {side: {unit: [dx, dy, dz]}}, "se_mm": ...}`` of the nominal units."""
        out: dict = {}
        se: dict = {}
        for side in _layouts(ctx.stances):
            if self.fixed is not None:
                off = np.asarray(self.fixed[side], float) * 1e3
                out[side] = {u: off[i].tolist() for i, u in enumerate(NOMINAL)}
                se[side] = {u: [0.0, 0.0, 0.0] for u in NOMINAL}
                continue
            out[side], se[side] = {}, {}
            for u in NOMINAL:
                v, s = ctx.values((self.name, side, u))
                out[side][u] = (v * 1e3).tolist()
                se[side][u] = (s * 1e3).tolist()
        block = {"offsets_mm": out, "se_mm": se}
        if self.fixed is None:  # as SoleCorrection's block
            block["prior_mm"] = (per_axis(self.sigma) * 1e3).tolist()
        return block

    def frozen(self, block: dict) -> DenseSoleCorrection:
        fixed = {
            s: np.array(list(units.values())) * 1e-3 for s, units in block["offsets_mm"].items()
        }
        return replace(self, fixed=fixed)


@dataclass(frozen=True)
class ContactDensity(Component):
    """A denser sole: ``m >= 15`` contact units over the outline of the five nominal units, with
    stiffnesses from a smooth field of a few parameters per foot.

    Geometry (:meth:`prepare`): every stance's five nominal units (PL, PM, AL, AM on the
    hindfoot, TT on the toes) are replaced by :func:`dense_design`'s units (default 16: a 4 x 3
    hindfoot grid, 3 toe units half way to TT, and TT), interpolated inside their polygon; toes
    units are expressed in the toes frame. The sole correction then moves the nominal points and
    the dense units follow by the same weights (:meth:`configure` asks every component for the
    dense sole, :meth:`Component.for_layout`; the sole correction becomes
    :class:`DenseSoleCorrection`: 15 variables per foot, not 3 per dense unit).

    Stiffness field: ``log k_i = sum_j theta_j b_j(xi_i, eta_i)`` with the basis
    :data:`BASIS` = (1, xi, eta, xi^2) over normalised foot coordinates (:func:`field_basis`);
    ``theta`` is per foot (4 parameters), linear in x. :meth:`configure` fixes the contact law's
    own per-unit k at 1 N/m^n (log k = 0), so that the law's ``log_k`` slot is exactly this field;
    the law reports per-unit k and ``f_ref`` from that slot.

    Variables (per foot, SI): ``theta_0`` = log of the stiffness [N/m^n] at the field's centre,
    started at ``k0`` with the base law's weak prior (sigma 2 in log units, bounds 1e2..1e9
    N/m^n); ``theta_xi``, ``theta_eta``, ``theta_xi2`` [-] (log-units over the half-length or
    half-width), prior N(0, sigma_shape^2) (default 1: a factor e^2 = 7.4 between heel and toe at
    one sd, beyond the spread of plantar tissue stiffness), bounds +-bound_shape.
    ``fixed``: ``{side: (4,) theta}`` to apply a known field. Not neutral at zero (theta = 0 is k
    = 1 N/m^n): a constant field ``(log k0, 0, 0, 0)`` is the uniform dense sole.
    """

    relative_cost: ClassVar[float] = 6.0  # its 16 units and the usual starts (BTS Walking1-3)
    # a plate a few millimetres off moves the COP along the sole as a stiffness field does: with
    # plate errors in the null a strong field at 2 per foot went from 21 to 66 more steps
    plate_mimicked: ClassVar[bool] = True

    n_long: int = 4
    n_lat: int = 3
    toe_rows: tuple = (0.5,)
    k0: float = 1.0e4
    sigma_shape: float = 1.0
    bound_shape: float = 4.0
    fixed: dict | None = None
    name: str = "contact_density"
    candidate = True
    benchmark_values = {
        "small": 1.5,
        "moderate": 2.0,
        "strong": 3.0,
    }  # heel/toe stiffness ratio [-]

    @classmethod
    def inject(cls, base, value, stances, rng) -> tuple:
        """The base plus a field with the heel ``value`` times stiffer than the toe (``theta_xi
        = -ln(value) / 2``), centred on the base law's median unit stiffness spread over the
        16 units (``x 5/16``), no lateral or quadratic term."""
        law = next(c for c in base if c.name == "contact")
        sides = sorted({st.side for st in stances})
        theta = {
            s: [
                float(np.log(np.median(list(law.k.value[s].values())) * 5 / 16)),
                -np.log(value) / 2,
                0.0,
                0.0,
            ]
            for s in sides
        }
        return (*base, cls(fixed=theta))

    def __post_init__(self) -> None:
        if self.n_lat != 3:
            raise ModelError("contact_density needs n_lat = 3 (field_basis reads PL and PM there)")

    def design(self):
        return dense_design(self.n_long, self.n_lat, tuple(self.toe_rows))

    def configure(self, model: tuple) -> tuple:
        """The contact law's own k fixed at 1 N/m^n (the field gives ``log k``) and every
        component that follows the nominal units carried to the dense sole (the sole correction
        becomes :class:`DenseSoleCorrection`), through their hooks."""
        W, layout = self.design()
        return tuple(c.with_law_fixed("k", 1.0).for_layout(layout, W) for c in model)

    def prepare(self, stances):
        W, layout = self.design()
        out = []
        for st in stances:
            if st.layout == layout:
                out.append(st)
                continue
            _check_nominal(st.layout, f"stance {st.label}")
            R, o = _toes_relative(st.foot)
            P = _in_hindfoot(st.foot.points_local, st.layout, R, o)
            dense = W @ P
            for i in layout.on("toes"):
                dense[i] = R.T @ (dense[i] - o)
            out.append(st.with_foot(st.foot.with_points(dense, layout)))
        return out

    def declare(self, variables, stances) -> None:
        if self.fixed is not None:
            return
        for side in SIDES:
            variables.parameter(
                (self.name, side, "1"), float(np.log(self.k0)), np.log(1e2), np.log(1e9), False, 2.0,
                shown=(1.0, 0.0, " (ln k, k in N/m^n)"),
            )  # fmt: skip
            for b in BASIS[1:]:
                variables.parameter(
                    (self.name, side, b), 0.0, -self.bound_shape, self.bound_shape, False,
                    self.sigma_shape,
                )  # fmt: skip

    def slot_sizes(self, layout) -> dict[str, int]:
        return {"log_k": layout.n}

    def theta(self, variables, side: str):
        if self.fixed is not None:
            return ca.DM(np.asarray(self.fixed[side], float))
        return ca.vertcat(*(variables.get((self.name, side, b)) for b in BASIS))

    def slots(self, variables, index, stance) -> dict:
        Phi = ca.DM(field_basis(stance.foot))
        return {"log_k": ca.mtimes(Phi, ca.MX(self.theta(variables, stance.side)))}

    def signature(self) -> tuple:
        return ("ContactDensity",)  # the geometry enters through the layout, the field by slots

    def decode(self, ctx: DecodeContext) -> dict:
        """``{side: {"theta": [4], "theta_se": [4], "basis": BASIS, "units": {unit: {"xi",
        "eta", "log_k"}}, "heel_to_toe": k(xi = -1) / k(xi = +1) along eta = 0}}``; the per-unit
        k and f_ref with SEs are in the contact law's block."""
        out: dict = {}
        first: dict = {}
        for i, st in enumerate(ctx.stances):
            first.setdefault(st.side, i)
        for side, i in first.items():
            if self.fixed is not None:
                th = np.asarray(self.fixed[side], float)
                se = np.zeros(4)
            else:
                th = np.array([ctx.values((self.name, side, b))[0][0] for b in BASIS])
                se = np.array([ctx.values((self.name, side, b))[1][0] for b in BASIS])
            st = ctx.stances[i]
            Phi = field_basis(st.foot)
            out[side] = {
                "theta": th.tolist(),
                "theta_se": se.tolist(),
                "basis": list(BASIS),
                "units": {
                    u: {
                        "xi": float(Phi[j, 1]),
                        "eta": float(Phi[j, 2]),
                        "log_k": float(Phi[j] @ th),
                    }
                    for j, u in enumerate(st.layout.units)
                },
                "heel_to_toe": float(np.exp(-2 * th[1])),
            }
        return out

    @classmethod
    def describe(cls, block: dict) -> list[SummaryRow]:
        """Per side: the field's coefficients (``theta[1]`` = log k [N/m^n] at the centre) and
        the heel-to-toe stiffness ratio (its SE by the delta method from ``theta[xi]``'s)."""
        rows = []
        for side, e in block.items():
            for b, v, se in zip(e["basis"], e["theta"], e["theta_se"], strict=True):
                rows.append(
                    SummaryRow(f"{side} theta[{b}]", v, se, "ln N/m^n" if b == "1" else "-")
                )
            ratio = e["heel_to_toe"]
            rows.append(
                SummaryRow(f"{side} heel/toe stiffness", ratio, 2 * ratio * e["theta_se"][1], "-")
            )
        return rows

    def frozen(self, block: dict) -> ContactDensity:
        return replace(self, fixed={s: list(v["theta"]) for s, v in block.items()})


__all__ = ["BASIS", "ContactDensity", "DenseSoleCorrection", "dense_design", "field_basis"]
