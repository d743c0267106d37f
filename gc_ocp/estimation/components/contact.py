"""The contact law: Hunt-Crossley normal force with Coulomb friction on every unit.

``F_n = k d^n (1 + c d_dot)`` with penetration ``d`` below the ground (smoothed over
``depth_smoothing``), friction ``-mu F_n`` along the sliding velocity relative to the belt
(regularised below ``slip_smoothing``): the law of :mod:`gc_ocp.contact.laws`, one CasADi
definition shared with the seed study. Stiffness is estimated as ``log k`` so that ``k > 0``.
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import ClassVar

import casadi as ca
import numpy as np

from gc_ocp.contact.laws import (
    DEFAULT_SMOOTHING,
    PENETRATION_FORMS,
    SLIP_FORMS,
    friction_force_function,
    normal_force_function,
    penetration_function,
)
from gc_ocp.errors import InputError, ModelError, UnknownNameError
from gc_ocp.estimation.components.base import Component, DecodeContext
from gc_ocp.estimation.flags import flag
from gc_ocp.estimation.variables import require_start_within
from gc_ocp.trial import SIDES

PARAMS = ("k", "n", "c", "mu")
LAW_SLOTS = {"n": "law_n", "c": "law_c", "mu": "law_mu"}
PARAM_UNITS = {"k": "N/m^n", "c": "s/m"}
"""Units of the law's parameters where they have one (n and mu are pure numbers)."""


def with_unit(name: str) -> str:
    """A parameter's name as the summary and the pages print it: ``"c [s/m]"``, ``"mu"``
    (the damping's unit was nowhere beside its value: a reader could not tell s/m from ms/mm)."""
    unit = PARAM_UNITS.get(name)
    return f"{name} [{unit}]" if unit else name


@dataclass(frozen=True)
class Param:
    """How one contact parameter is estimated.

    scope: ``"unit"`` (one per unit per foot; only k), ``"foot"`` (one per foot), ``"shared"``
    (one for both feet) or ``"fixed"`` (not estimated: ``value`` is used).
    value: initial (or fixed) value in SI units; a float, or ``{side: float}`` /
    ``{side: {unit: float}}`` for per-foot / per-unit values. An estimated parameter's start
    lies within its bounds: one outside them is an :class:`~gc_ocp.errors.InputError` when the
    :class:`ContactLaw` is made (it was accepted, and Ipopt moved it inside silently). A start
    the package computes (the linear least squares' stiffnesses,
    :meth:`ContactLaw.with_initial_k`) is clipped into the bounds instead (``docs/estimation.md``).
    lower, upper: bounds in SI units, lower <= upper.
    prior_sigma: optional Gaussian prior centred on ``value``, in the optimised units (log units
    for k: ``prior_sigma = 2`` means a factor e^2 = 7.4 at one standard deviation).

    >>> import gc_ocp
    >>> law = gc_ocp.ContactLaw(mu=gc_ocp.Param("fixed", 0.8), c=gc_ocp.Param("shared", 0.3, 0, 10))
    >>> law.c
    Param(scope='shared', value=0.3, lower=0, upper=10, prior_sigma=None)
    >>> gc_ocp.Param("global", 0.8)
    Traceback (most recent call last):
    ...
    gc_ocp.errors.UnknownNameError: Param scope must be one of unit, foot, shared, fixed, but got "global"
    >>> gc_ocp.ContactLaw(c=gc_ocp.Param("shared", 20.0, 0, 10))
    Traceback (most recent call last):
    ...
    gc_ocp.errors.InputError: the start of ContactLaw(c=Param('shared', 20.0, 0, 10)), 20.0, lies outside its bounds [0, 10]: give a start within them, or widen its bounds
    """

    scope: str
    value: float | dict
    lower: float = -np.inf
    upper: float = np.inf
    prior_sigma: float | None = None

    def __post_init__(self) -> None:
        if self.scope not in ("unit", "foot", "shared", "fixed"):
            # a name the user gave: bad input (and a model that cannot be made, as before)
            raise UnknownNameError(
                f'Param scope must be one of unit, foot, shared, fixed, but got "{self.scope}"'
            )
        # reversed bounds were a CasADi RuntimeError "Ill-posed problem detected" at the solve
        lo, hi = self.lower, self.upper
        real = all(isinstance(b, numbers.Real) and not isinstance(b, bool) for b in (lo, hi))
        if not (real and lo <= hi):
            raise InputError(
                f"Param bounds must be numbers with lower <= upper (SI units), but got "
                f"lower={lo!r}, upper={hi!r}: e.g. Param('shared', 0.3, 0, 10)"
            )

    def starts(self) -> list[tuple[str, float]]:
        """Every start the value gives: ``[(where, value)]``, ``where`` ``""`` for one number,
        ``"left"`` or ``"left/PL"`` for a per-foot or per-unit value."""
        if not isinstance(self.value, dict):
            return [("", self.value)]
        out = []
        for side, v in self.value.items():
            if isinstance(v, dict):
                out += [(f"{side}/{u}", x) for u, x in v.items()]
            else:
                out.append((str(side), v))
        return out

    def value_for(self, side: str, unit: str | None = None) -> float:
        """The value for ``side`` (and ``unit``, for per-unit values); a per-foot or per-unit
        value that lacks the side or unit the model needs is an :class:`InputError` naming the
        keys it has (it was a bare KeyError at the build)."""
        v = self.value
        for key, what in ((side, "side"), (unit, "unit")):
            if not isinstance(v, dict):
                break
            if key not in v:
                raise InputError(
                    f"Param value {self.value!r} has no {what} {key!r} (it gives "
                    f"{', '.join(map(repr, v))}): give a value for each "
                    + ("foot, e.g. {'left': 0.8, 'right': 0.8}" if what == "side" else "unit")
                    + ", or one number for all"
                )
            v = v[key]
        return float(v)


def _layouts(stances) -> dict:
    """``{side: SoleLayout}`` of the sides present (one layout per side)."""
    out: dict = {}
    for st in stances:
        if out.setdefault(st.side, st.layout) != st.layout:
            raise ModelError(
                f"Stances of the {st.side} foot have different sole layouts ({st.label})"
            )
    return {s: out[s] for s in SIDES if s in out}


@dataclass(frozen=True)
class ContactLaw(Component):
    """Hunt-Crossley normal force with Coulomb friction, per unit.

    k: stiffness [N/m^n] (estimated as log k); n: penetration exponent [-];
    c: Hunt-Crossley damping [s/m]; mu: friction coefficient [-].
    depth_smoothing: smoothing length of the penetration [m] (see ``gc_ocp.contact.laws``).
    slip_smoothing: sliding speed below which friction is smoothed [m/s].
    depth_form, slip_form: the forms of those two smoothings (``gc_ocp.contact.laws``:
    :data:`~gc_ocp.contact.laws.PENETRATION_FORMS`, :data:`~gc_ocp.contact.laws.SLIP_FORMS`;
    default the first of each, the seed's). The frame's law records ``slip_form`` so that a
    tangential law replacing the Coulomb friction (``friction``) regularises the same way.
    reference_depth: penetration [m] at which each unit's force ``f_ref = k d^n`` is reported
    (the well-determined summary of its force-depth curve).
    """

    # weak log-k prior (factor 7.4 at 1 sd) around the initial value: keeps a unit whose stiffness
    # collapsed early in the iterations (no force, no gradient) from staying switched off, and
    # regularises units that hardly touch the ground; negligible where the data inform k
    k: Param = field(default_factory=lambda: Param("unit", 3.0e5, 1.0e2, 1.0e9, prior_sigma=2.0))
    n: Param = field(default_factory=lambda: Param("shared", 1.5, 1.0, 3.0))
    c: Param = field(default_factory=lambda: Param("shared", 0.5, 0.0, 10.0))
    mu: Param = field(default_factory=lambda: Param("shared", 0.5, 0.0, 1.5))
    depth_smoothing: float = 5e-4
    slip_smoothing: float = 0.05
    reference_depth: float = 0.005
    depth_form: str = PENETRATION_FORMS[0]
    slip_form: str = SLIP_FORMS[0]
    name: str = "contact"

    SETTINGS: ClassVar[tuple[str, ...]] = (
        "depth_smoothing",
        "slip_smoothing",
        "reference_depth",
        "depth_form",
        "slip_form",
    )
    """The law's fixed settings (not estimated): a fit records them (``fit.json``'s
    ``contact_law``, :meth:`settings`), so that the fit read back (an export, a page) has the law
    it was fitted with, not this class's defaults."""

    def settings(self) -> dict:
        """``{setting: value}`` of :data:`SETTINGS`."""
        return {s: getattr(self, s) for s in self.SETTINGS}

    @classmethod
    def of_settings(cls, settings: Mapping) -> ContactLaw:
        """The law of ``settings`` (:meth:`settings`; a setting not given: the default), its
        parameters the defaults."""
        return cls(**{s: settings[s] for s in cls.SETTINGS if s in settings})

    @classmethod
    def seed(cls, mu: float = 0.0) -> ContactLaw:
        """The seed report's model: k per unit, n = 1, c = 0, fixed friction ``mu``."""
        return cls(
            k=Param("unit", 1.2e4, 1.0, 1.0e9),
            n=Param("fixed", 1.0),
            c=Param("fixed", 0.0),
            mu=Param("fixed", mu),
        )

    @classmethod
    def base(cls) -> ContactLaw:
        """The diagnosis's base law: the seed's (k per unit, n = 1, c = 0) with velocity-based
        Coulomb friction and one shared fitted mu."""
        return cls(
            k=Param("unit", 3.0e4, 1.0e2, 1.0e9, prior_sigma=2.0),
            n=Param("fixed", 1.0),
            c=Param("fixed", 0.0),
            mu=Param("shared", 0.5, 0.0, 1.5),
        )

    def law_estimates(self, param: str) -> bool:
        """True when ``param`` (``"k"``, ``"n"``, ``"c"``, ``"mu"``) is estimated (not fixed)."""
        return getattr(self, param).scope != "fixed"

    def with_law_fixed(self, param: str, value: float | dict) -> ContactLaw:
        """The law with ``param`` fixed at ``value`` (an effect that owns it, e.g. damping's
        ``c``, or a stiffness field's ``k`` = 1)."""
        if param not in PARAMS:
            raise ModelError(f'Unknown contact-law parameter "{param}"; choose from {PARAMS}')
        return replace(self, **{param: Param("fixed", value)})

    def with_law_smoothing(
        self,
        depth_factor: float = 1.0,
        slip_factor: float = 1.0,
        depth_form: str | None = None,
        slip_form: str | None = None,
    ) -> ContactLaw:
        """The law with its penetration and slip smoothing widths multiplied by ``depth_factor``
        and ``slip_factor`` and, when given, their forms replaced (``None``: its own)."""
        return replace(
            self,
            depth_smoothing=self.depth_smoothing * depth_factor,
            slip_smoothing=self.slip_smoothing * slip_factor,
            depth_form=self.depth_form if depth_form is None else depth_form,
            slip_form=self.slip_form if slip_form is None else slip_form,
        )

    def __post_init__(self) -> None:
        for pname in PARAMS:  # ContactLaw(mu=0.8) was an AttributeError on its .scope
            v = getattr(self, pname)
            if not isinstance(v, Param):
                raise InputError(
                    f"ContactLaw({pname}={v!r}): give a Param, e.g. {pname}=Param('fixed', {v!r}) "
                    f"to fix it, or Param('shared', {v!r}, lower, upper) to estimate it "
                    "(gc_ocp.Param: its scope, value and bounds)"
                )
        for pname in PARAMS:  # a start outside the bounds: Ipopt moved it inside, silently
            p = getattr(self, pname)
            if p.scope == "fixed":
                continue
            law = f"ContactLaw({pname}=Param({p.scope!r}, {p.value!r}, {p.lower!r}, {p.upper!r}))"
            for where, v in p.starts():
                require_start_within(f"{law}{' at ' + where if where else ''}", v, p.lower, p.upper)
        for pname in ("n", "c", "mu"):
            if getattr(self, pname).scope == "unit":
                raise ModelError(
                    f'Param "{pname}" cannot have scope "unit"; choose foot, shared or fixed.'
                )
        for what, form, forms in (
            ("depth_form", self.depth_form, PENETRATION_FORMS),
            ("slip_form", self.slip_form, SLIP_FORMS),
        ):
            if form not in forms:
                raise ModelError(f'ContactLaw.{what} must be one of {forms}, but got "{form}"')
        for what in ("depth_smoothing", "slip_smoothing"):
            if not getattr(self, what) > 0:
                raise ModelError(
                    f"ContactLaw.{what} must be > 0 [SI], but got {getattr(self, what)}"
                )

    # --- variables ----------------------------------------------------------------------------
    def _keys(self, pname: str, layouts: dict) -> list[tuple]:
        scope = getattr(self, pname).scope
        if scope == "unit":
            return [(s, u) for s, lay in layouts.items() for u in lay.units]
        if scope == "foot":
            return [(s,) for s in layouts]
        return [()] if scope == "shared" else []

    def declare(self, variables, stances) -> None:
        layouts = _layouts(stances)
        # both sides are declared (in SIDES order) even when only one has stances: a model's
        # variables then do not depend on which feet a subset of stances covers
        layouts = {s: layouts.get(s, next(iter(layouts.values()))) for s in SIDES}
        for pname in PARAMS:
            p: Param = getattr(self, pname)
            for key in self._keys(pname, layouts):
                if p.scope == "shared" and isinstance(p.value, dict):
                    first = next(iter(layouts.values())).units[0]
                    v0 = p.value_for(SIDES[0], first)
                else:
                    v0 = p.value_for(*key) if key else float(p.value)
                variables.parameter(
                    (self.name, pname, *key),
                    v0,
                    p.lower,
                    p.upper,
                    log=pname == "k",
                    prior_sigma=p.prior_sigma,
                )

    def _value(self, variables, pname: str, side: str, unit: str | None = None, raw: bool = False):
        p: Param = getattr(self, pname)
        if p.scope == "fixed":
            v = p.value_for(side, unit)
            return float(np.log(v)) if raw else v
        key = {"unit": (side, unit), "foot": (side,), "shared": ()}[p.scope]
        return variables.get((self.name, pname, *key), raw=raw)

    # --- per-frame inputs ---------------------------------------------------------------------
    def slot_sizes(self, layout) -> dict[str, int]:
        return {"log_k": layout.n, **{s: 1 for s in LAW_SLOTS.values()}}

    def slots(self, variables, index, stance) -> dict:
        units = stance.layout.units
        log_k = [self._value(variables, "k", stance.side, u, raw=True) for u in units]
        out = {"log_k": ca.vertcat(*log_k)}
        for pname, slot in LAW_SLOTS.items():
            out[slot] = ca.MX(1, 1) + self._value(variables, pname, stance.side)
        return out

    def edit_contact(self, frame) -> None:
        k = ca.exp(frame.slot("log_k"))
        frame.law.update(k=[k[i] for i in range(frame.layout.n)])
        frame.law.update({p: frame.slot(s) for p, s in LAW_SLOTS.items()})
        frame.law.update(v_eps=self.slip_smoothing, slip_form=self.slip_form)
        penetration = penetration_function()
        normal = normal_force_function(True, self.depth_form)
        coulomb = friction_force_function(self.slip_form)
        eps_x, eps_d = self.depth_smoothing, DEFAULT_SMOOTHING.eps_damping

        def unit_force(f, i):
            # the composition of laws.unit_force_function, with the ground and the tangential
            # law as the frame has them (another component may tilt the ground or swap friction)
            p = f.law
            x, xdot = penetration(f.points[i], f.velocities[i], f.ground(i))
            fn = normal(x, xdot, p["k"][i], p["n"], p["c"], eps_x, eps_d)
            if f.tangential is None:
                ft = coulomb(fn, f.velocities[i], f.belt_velocity, p["mu"], self.slip_smoothing)
            else:
                ft = f.tangential(f, i, fn)
            return ft + ca.vertcat(0, 0, fn)

        frame.unit_force = unit_force

    def signature(self) -> tuple:
        return (
            "ContactLaw",
            self.depth_smoothing,
            self.slip_smoothing,
            DEFAULT_SMOOTHING.eps_damping,
            self.depth_form,
            self.slip_form,
        )

    # --- results ------------------------------------------------------------------------------
    def decode(self, ctx: DecodeContext) -> dict:
        """``{side: {unit: {"k", "k_se", "f_ref", "f_ref_se"}, param: .., param_se: ..},
        "shared": {param: .., param_se: ..}}``; ``f_ref`` [N] is the unit's force at
        ``reference_depth`` without damping.

        Values are read from the per-frame slots the law uses, so that whatever contributes to
        them (this law's variables, or an effect such as a stiffness exponent or a stiffness field
        over a denser sole) is reported; standard errors by the delta method from the covariance
        of x (fixed values: 0). ``f_ref = k d_ref^n`` is far better determined than k: k and n are
        strongly correlated (``ln f_ref = ln k + n ln d_ref``, ``ln 0.005 = -5.3``)."""
        layouts = _layouts(ctx.stances)
        first: dict = {}
        for i, st in enumerate(ctx.stances):
            first.setdefault(st.side, i)
        L = float(np.log(self.reference_depth))
        out: dict = {s: {} for s in layouts}
        out["shared"] = {}
        cov = ctx.cov
        for side, lay in layouts.items():
            i = first[side]
            log_k, log_k_se = ctx.slot_value_se(i, "log_k")
            n_val = float(ctx.slot_values(i, "law_n")[0, 0])
            rows_k = ctx.slot_rows(i, "log_k") if ctx.slot_rows else None
            row_n = ctx.slot_rows(i, "law_n")[0] if ctx.slot_rows else None
            for j, u in enumerate(lay.units):
                k = float(np.exp(log_k[j]))
                f_ref = float(np.exp(log_k[j] + n_val * L))
                if cov is None or rows_k is None:
                    f_se = float("nan")
                else:
                    g = rows_k[j] + L * row_n  # d ln f_ref / d x
                    f_se = f_ref * float(np.sqrt(max(g @ cov @ g, 0.0)))
                out[side][u] = {
                    "k": k,
                    "k_se": k * float(log_k_se[j]),
                    "f_ref": f_ref,
                    "f_ref_se": f_se,
                }
            for pname, slot in LAW_SLOTS.items():
                v, se = ctx.slot_value_se(i, slot)
                where = out["shared"] if getattr(self, pname).scope == "shared" else out[side]
                where.update({pname: float(v[0]), pname + "_se": float(se[0])})
        return {k: v for k, v in out.items() if v}

    def flags(self, block: dict, stances: list) -> list[dict]:
        """A unit is *not identified* when its force at the reference depth has an SE above its
        value (the data do not fix it) or exceeds 2 body weights (no unit of a walking foot
        carries that at 5 mm: a stiffness driven to absurd values by a unit that barely touches
        the ground). Its entry gets ``"identified": False``; the summary prints "not identified"
        instead of the number. The weak log-k prior is kept as it is: tightening it would bias
        the identified units; the flag is the honest answer."""
        bw = {st.side: st.body_weight for st in stances}
        out = []
        for side, units in block.items():
            if side == "shared":
                continue
            for u, e in units.items():
                if not isinstance(e, dict):
                    continue
                f, se = e["f_ref"], e["f_ref_se"]
                bad = []
                if np.isfinite(se) and se > f:
                    bad.append(f"its SE, {se:.3g} N, exceeds it")
                if f > 2 * bw[side]:
                    ratio = f / bw[side]  # over 2 BW: never rounded down to "2 BW"
                    bw_text = f"{ratio:.1f}" if ratio < 10 else f"{ratio:.0f}"
                    bad.append(f"{bw_text} BW at {self.reference_depth * 1e3:g} mm")
                e["identified"] = not bad
                if bad:
                    out.append(
                        flag(
                            "unit_not_identified",
                            f"{side}/{u}",
                            f"{side} unit {u} not identified: force at the reference depth {f:.3g} N ("
                            + "; ".join(bad)
                            + ")",
                        )
                    )
        return out

    def frozen(self, block: dict) -> ContactLaw:
        """Every parameter fixed at the values of ``block`` (a decoded contact block)."""
        sides = [s for s in SIDES if s in block]
        kw = {}
        for pname in PARAMS:
            par: Param = getattr(self, pname)
            if par.scope == "fixed":
                continue
            if pname == "k":
                val = {
                    s: {u: e["k"] for u, e in block[s].items() if isinstance(e, dict)}
                    for s in sides
                }
            elif pname in block.get("shared", {}):
                val = block["shared"][pname]
            else:  # per foot; or fixed when decoded (an effect such as damping owned it)
                val = {s: block[s][pname] for s in sides}
            kw[pname] = Param("fixed", val)
        return replace(self, **kw)

    def with_initial_k(self, k0: dict | None) -> ContactLaw:
        """The law started from per-unit stiffnesses ``{side: {unit: k}}`` (when k is per unit).

        ``k0`` is a start the package computes (the linear least squares, :func:`~gc_ocp.
        estimation.starts.lls_k0`), not one a person chose: a stiffness outside k's bounds (a
        unit the stances hardly load; an exponent started at 3, whose conversion multiplies the
        linear k by 40 000) is clipped into them. Ipopt would move it inside anyway (its
        ``bound_push``); clipped here, the start and the log-k prior's centre are the point the
        solve starts from, and the law is one :class:`Param` accepts."""
        if k0 is None or self.k.scope != "unit":
            return self
        lo, hi = self.k.lower, self.k.upper
        k0 = {s: {u: float(np.clip(v, lo, hi)) for u, v in ks.items()} for s, ks in k0.items()}
        return replace(self, k=replace(self.k, value=k0))


__all__ = ["PARAM_UNITS", "ContactLaw", "Param", "with_unit"]
