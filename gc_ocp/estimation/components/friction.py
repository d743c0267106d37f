"""Friction: a Stribeck + viscous tangential law in place of velocity-based Coulomb friction."""

from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca

from gc_ocp.contact.laws import SLIP_FORMS, friction_force_function
from gc_ocp.estimation.components.base import Component, DecodeContext, SummaryRow

SLOTS = ("friction_dmu", "friction_b")
ENTRIES = ("static_excess", "viscous")


@dataclass(frozen=True)
class StribeckFriction(Component):
    """Stribeck + viscous friction on every unit, shared by both feet.

    With ``v_s`` the unit's horizontal sliding velocity relative to the belt (lab x, y; zero
    overground), ``F_n`` its normal force and the contact law's regularised Coulomb direction
    (``v_eps = frame.law["v_eps"]``, the law's slip smoothing, 5 cm/s, in the law's form
    ``frame.law["slip_form"]``) ::

        mu(v_s) = mu_d + (mu_s - mu_d) * exp(-|v_s|^2 / v_stribeck^2)
        F_t     = -mu(v_s) * F_n * v_s / sqrt(|v_s|^2 + v_eps^2)  -  b * F_n * v_s

    ``mu_d`` is the contact law's own (fitted) ``mu`` (``frame.law["mu"]``), so this component
    adds only the static excess ``mu_s - mu_d`` [-] and the viscous coefficient ``b`` [s/m]. The
    viscous term is scaled by the unit's normal force: a shoe sole's shear resistance (rubber
    hysteresis, tread deformation) scales with its load and vanishes when the unit is unloaded; a
    term ``-b' v_s`` not scaled by ``F_n`` would act on units in the air (the smooth normal law is
    never exactly zero) and would need a contact switch of its own.

    Variables (global, key ``(name, "static_excess")`` and ``(name, "viscous")``, physical units):
    ``mu_s - mu_d`` with prior N(0, 0.3^2) (rubber soles on dry floors: static 0.8-1.0 against
    dynamic 0.5-0.7), bounds [0, 1]; ``b`` with prior N(0, (2 s/m)^2) (loaded units of the bundled
    walking trial slide at 1-14 cm/s, median 4 cm/s, weighted by their normal force: ``b`` = 2 s/m
    adds 0.08 F_n at 4 cm/s and 0.26 F_n at 13 cm/s, as much as the Coulomb part itself) and
    bounds [0, 20] s/m. Both are >= 0 by physics (static friction is not below the
    dynamic one; viscous drag dissipates); zero sits on the bound and the interior-point solver
    starts just inside. ``v_stribeck`` [m/s] is fixed (default 0.1 m/s, twice ``v_eps``, so that
    the law has a peak between v_eps and v_stribeck and decays to mu_d beyond ~2 v_stribeck):
    most loaded units slide below it (90 % of the normal force at < 14 cm/s), so the data hardly
    separate the decay speed from the excess (a smaller excess decaying later shapes nearly the
    same curve over 1-14 cm/s); a free ``v_stribeck`` would also make the law non-linear in a
    poorly determined variable. ``fixed``:
    ``{"static_excess", "viscous"}`` applied without estimating them.

    Neutral value: ``mu_s = mu_d`` and ``b = 0`` gives exactly the contact law's Coulomb friction
    (the same function, ``gc_ocp.contact.laws.friction_force_function``, evaluated with
    ``mu + 0 * exp(..)``, plus ``0 * F_n * v_s``).

    What the data determine: at ``|v_s| << v_eps`` all three terms are linear in ``v_s``
    (slope ``(mu_d + (mu_s - mu_d)) / v_eps + b``), so frames where the feet barely slide
    determine only that slope; ``mu_d``, the excess and ``b`` separate through the spread of the
    loaded sliding speeds around ``v_eps`` (1-14 cm/s on the bundled trial, where the marker-based
    kinematics, skin motion included, make the feet "slide"). On that motion with 0.5 % BW plate
    noise the three are recovered with SEs of 0.007 (excess), 0.03 s/m (b) and 0.005 (mu_d), but
    strongly correlated: they move together. On real data the sliding speeds are partly marker
    artefact, so the law's shape is fitted to apparent, not true, sliding.
    """

    sigma_excess: float = 0.3
    sigma_viscous: float = 2.0
    max_excess: float = 1.0
    max_viscous: float = 20.0
    v_stribeck: float = 0.1
    fixed: dict | None = None
    name: str = "friction"
    neutral_at_zero = True
    candidate = True
    benchmark_values = {
        "small": (0.075, 0.2),
        "moderate": (0.15, 0.4),
        "strong": (0.3, 0.75),
    }  # mu_s - mu_d, b [s/m]

    @classmethod
    def inject(cls, base, value, stances, rng) -> tuple:
        """The base plus ``value = (mu_s - mu_d, b [s/m])``."""
        excess, viscous = value
        return (*base, cls(fixed={"static_excess": excess, "viscous": viscous}))

    def declare(self, variables, stances) -> None:
        if self.fixed is None:
            for key, sig, hi in (
                ("static_excess", self.sigma_excess, self.max_excess),
                ("viscous", self.sigma_viscous, self.max_viscous),
            ):
                variables.parameter((self.name, key), 0.0, 0.0, hi, prior_sigma=sig)

    def slot_sizes(self, layout) -> dict[str, int]:
        return {s: 1 for s in SLOTS}

    def slots(self, variables, index, stance) -> dict:
        pairs = zip(SLOTS, ENTRIES, strict=True)
        if self.fixed is not None:
            return {s: ca.MX(1, 1) + float(self.fixed[e]) for s, e in pairs}
        return {s: variables.get((self.name, e)) for s, e in pairs}

    def edit_contact(self, frame) -> None:
        dmu, b = frame.slot(SLOTS[0]), frame.slot(SLOTS[1])
        v0sq = self.v_stribeck**2

        def tangential(f, i, fn):
            v, vb = f.velocities[i], f.belt_velocity
            vs = ca.vertcat(v[0] - vb[0], v[1] - vb[1])
            mu = f.law["mu"] + dmu * ca.exp(-ca.sumsqr(vs) / v0sq)
            coulomb = friction_force_function(f.law.get("slip_form", SLIP_FORMS[0]))
            return coulomb(fn, v, vb, mu, f.law["v_eps"]) - ca.vertcat(b * fn * vs, 0)

        frame.tangential = tangential

    def signature(self) -> tuple:
        return ("StribeckFriction", self.v_stribeck)

    def decode(self, ctx: DecodeContext) -> dict:
        """``{"static_excess", "viscous" [s/m], their "_se", "v_stribeck" [m/s]}``."""
        out: dict = {"v_stribeck": self.v_stribeck}
        for e in ENTRIES:
            if self.fixed is None:
                v, s = ctx.values((self.name, e))
                out[e], out[e + "_se"] = float(v[0]), float(s[0])
            else:
                out[e], out[e + "_se"] = float(self.fixed[e]), 0.0
        return out

    @classmethod
    def describe(cls, block: dict) -> list[SummaryRow]:
        return [
            SummaryRow(
                "mu_s - mu_d",
                block["static_excess"],
                block["static_excess_se"],
                "-",
                ("static_excess",),
            ),
            SummaryRow("b", block["viscous"], block["viscous_se"], "s/m", ("viscous",)),
        ]

    def frozen(self, block: dict) -> StribeckFriction:
        return replace(self, fixed={e: float(block[e]) for e in ENTRIES})


__all__ = ["StribeckFriction"]
