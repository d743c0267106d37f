"""Toe joint: the toes hinged at the metatarsophalangeal (MTP) line instead of welded."""

from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from gc_ocp.estimation.components.base import Component, DecodeContext, unique_labels
from gc_ocp.estimation.components.pose import PoseCorrection
from gc_ocp.estimation.frame import Segment

TOE_SLOTS = ("toe_phi", "toe_phidot")


def _skew(a: ca.SX) -> ca.SX:
    return ca.vertcat(
        ca.horzcat(0, -a[2], a[1]),
        ca.horzcat(a[2], 0, -a[0]),
        ca.horzcat(-a[1], a[0], 0),
    )


def mtp_axis(hindfoot_R) -> ca.SX:
    """The hinge axis in ``lab``: minus the hindfoot frame's 2nd axis.

    The foot frames of the body model have x forward, z up and y to the subject's left on both
    feet, so a rotation by +phi about -y lifts a point ahead of the axis: positive phi is
    dorsiflexion (toes up) on either foot."""
    return -hindfoot_R[:, 1]


def hinged_toes(hind: Segment, toes: Segment, phi, phidot) -> Segment:
    """The toes segment rotated by ``phi`` [rad] about the MTP axis through its origin.

    ``R' = Rot(a, phi) R``, written as ``R + M R`` with ``M = Rot - I = sin(phi) K + (1 -
    cos(phi)) K^2`` (Rodrigues, ``K = [a]x``) so that ``phi = 0`` gives the welded toes bit for
    bit. The origin lies on the axis and the axis is fixed in the hindfoot, so the origin and its
    velocity are unchanged; the angular velocity is ``w' = w_toes + phidot a + M (w_toes -
    w_hind)`` (exact for any relative motion of the recorded segments; ``w_toes + phidot a`` when
    they are welded)."""
    a = mtp_axis(hind.R)
    K = _skew(a)
    M = ca.sin(phi) * K + (1 - ca.cos(phi)) * (K @ K)
    R = toes.R + M @ toes.R
    w = toes.w + phidot * a + M @ (toes.w - hind.w)
    return Segment(R, toes.o, toes.v, w)


@dataclass(frozen=True)
class ToeJoint(Component):
    """Toes hinged at the MTP line with a smooth toe angle over each stance.

    The marker sets place the foot as one rigid body (hindfoot and toes welded); a real foot
    dorsiflexes its toes during push-off, so the toe units' lever about the MTP line and their
    depth below the ground are wrong exactly when they carry load. This component rotates the
    ``toes`` segment about the MTP axis (the hindfoot frame's lateral axis, through the toes
    origin, which lies on the MTP line) by the toe angle ``phi(t)`` [rad], positive =
    dorsiflexion (toes up); every unit whose parent is ``toes`` (the seed layout's ``TT``) moves
    with it (:func:`hinged_toes`).

    Variables: per stance, the coefficients [rad] of a cubic B-spline in time (knots every
    ``knot_spacing`` [s], the basis of :meth:`PoseCorrection.basis`); ``phi_dot`` is the spline's
    time derivative. Prior N(0, sigma_deg^2) per coefficient: no toe marker fixes the angle, so the
    prior keeps the recorded (welded) toes wherever the force data are silent (the toe units carry
    no load during most of the stance); a few degrees is the size of a welded model's error before
    heel rise. Bounds +-bound_deg: the MTP joint reaches 30-50 deg of dorsiflexion at toe-off, and
    B-spline values are convex combinations of the coefficients, so ``|phi| <= bound_deg``.

    What the force data determine: the toe units' load during push-off (their depth below the
    ground, and so the force they carry, depends on ``phi``); where they are unloaded the angle
    only has to keep them off the ground and is the prior's. The constant part of ``phi`` trades
    with the toe units' sole offsets and stiffness. Scope ``"stance"`` (re-estimated on a
    held-out stance, like the pose correction). ``fixed``: ``{stance label: (K,) coefficients
    [rad]}`` for stances whose angle is known (a synthetic truth); the others are free.
    Neutral value: ``phi = 0`` (the welded toes, exactly).
    """

    sigma_deg: float = 5.0
    bound_deg: float = 45.0
    knot_spacing: float = 0.1
    fixed: dict | None = None
    name: str = "toe_joint"
    scope = "stance"
    neutral_at_zero = True

    def with_prior_scale(self, factor: float) -> ToeJoint:
        """The same component with its prior width multiplied by ``factor`` (the bound is kept)."""
        return replace(self, sigma_deg=self.sigma_deg * factor)

    def basis(self, time: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """B-spline design matrices ``(T, K)`` of ``phi`` and ``phi_dot`` on ``time`` [s]."""
        return PoseCorrection(knot_spacing=self.knot_spacing).basis(np.asarray(time, float))

    def _fixed(self, stance):
        return None if self.fixed is None else self.fixed.get(stance.label)

    def declare(self, variables, stances) -> None:
        sigma = np.deg2rad(self.sigma_deg)
        bound = np.deg2rad(self.bound_deg)
        unique_labels(self.name, stances)
        for st in stances:
            if self._fixed(st) is None:
                K = self.basis(st.time)[0].shape[1]
                variables.prior_variable((self.name, st.label), K, sigma, bound)

    def slot_sizes(self, layout) -> dict[str, int]:
        return {s: 1 for s in TOE_SLOTS}

    def slots(self, variables, index, stance) -> dict:
        B, dB = self.basis(stance.time)
        coef = self._fixed(stance)
        if coef is None:
            c = variables.get((self.name, stance.label))
        else:
            c = ca.MX(ca.DM(np.asarray(coef, float)))
        return {"toe_phi": ca.mtimes(ca.DM(B), c).T, "toe_phidot": ca.mtimes(ca.DM(dB), c).T}

    def edit_segments(self, frame) -> None:
        seg = frame.segments
        seg["toes"] = hinged_toes(
            seg["hindfoot"], seg["toes"], frame.slot("toe_phi"), frame.slot("toe_phidot")
        )

    def signature(self) -> tuple:
        return ("ToeJoint",)  # its values, prior and knots only enter through its slots

    def decode(self, ctx: DecodeContext) -> dict:
        """``{"stances": {label: {"phi_deg": (T,), "phi_se_deg": (T,), "coef_deg",
        "coef_se_deg"}}, "max_deg": {label: float}}``: the toe angle per stance with standard
        errors by the delta method (0 where fixed)."""
        index = ctx.index()
        per: dict = {}
        peak: dict = {}
        for st in ctx.stances:
            B, _ = self.basis(st.time)
            key = (self.name, st.label)
            if key in index:
                spec = index[key]
                coef, coef_se = ctx.values(key)
                se = np.full(st.n, np.nan)
                if ctx.cov is not None:
                    G = B * spec.scale  # d phi / d z
                    C = ctx.cov[spec.slice, spec.slice]
                    se = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", G, C, G), 0.0))
            else:
                coef = np.asarray(self._fixed(st), float)
                coef_se, se = np.zeros_like(coef), np.zeros(st.n)
            phi = B @ coef
            per[st.label] = {
                "phi_deg": np.rad2deg(phi).tolist(),
                "phi_se_deg": np.rad2deg(se).tolist(),
                "coef_deg": np.rad2deg(coef).tolist(),
                "coef_se_deg": np.rad2deg(coef_se).tolist(),
            }
            peak[st.label] = float(np.rad2deg(phi[np.argmax(np.abs(phi))]))
        return {"stances": per, "max_deg": peak}

    def frozen(self, block: dict) -> ToeJoint:
        """Itself: the toe angle has scope ``"stance"`` and is re-estimated on a held-out stance
        (as the pose correction is)."""
        return self


__all__ = ["ToeJoint", "hinged_toes", "mtp_axis"]
