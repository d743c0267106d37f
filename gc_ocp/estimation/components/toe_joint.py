"""Toe joint: the toes hinged at the metatarsophalangeal (MTP) line instead of welded, the toe
angle driven by the hindfoot's pitch (predictive) or a per-stance spline."""

from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from gc_ocp.errors import ModelError
from gc_ocp.estimation.components.base import (
    Component,
    DecodeContext,
    SummaryRow,
    unique_labels,
)
from gc_ocp.estimation.components.pose import PoseCorrection
from gc_ocp.estimation.frame import Segment
from gc_ocp.trial import SIDES

TOE_SLOTS = ("toe_phi", "toe_phidot")
PITCH_SLOTS = ("toe_onset", "toe_gain")
DRIVES = ("pitch", "spline")


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


def hindfoot_pitch(R, w) -> tuple:
    """The hindfoot's heel-up pitch relative to the ground [rad] and its rate [rad/s] (SX).

    ``lab`` has z up; the foot frames have x forward (:func:`mtp_axis`), so the lab-vertical
    component of the hindfoot's forward axis ``e = R[:, 0]`` is ``e_z = -sin(pitch)``: the pitch
    is positive when the heel is above the forefoot (heel rise), independent of the walking
    direction and of the frame's roll about its own x. Its rate is the exact time derivative
    along the recorded rotation, ``e_dot = w x e``: ``pitch_dot = -(w x e)_z / sqrt(1 - e_z^2)``
    (``w`` the hindfoot's angular velocity in lab)."""
    e = R[:, 0]
    ez = e[2]
    pitch = -ca.asin(ez)
    ez_dot = w[0] * e[1] - w[1] * e[0]
    return pitch, -ez_dot / ca.sqrt(1 - ez * ez)


def pitch_numpy(hindfoot_pose: np.ndarray) -> np.ndarray:
    """:func:`hindfoot_pitch` of the recorded placements ``(n, 4, 4)`` [rad] (NumPy)."""
    return -np.arcsin(np.clip(np.asarray(hindfoot_pose)[:, 2, 0], -1.0, 1.0))


def pitch_drive(pitch, pitch_dot, onset, gain, smooth) -> tuple:
    """``phi = gain * s * softplus((pitch - onset) / s)`` and its exact time derivative
    ``phi_dot = gain * sigmoid((pitch - onset) / s) * pitch_dot`` (``s = smooth`` [rad]). Works
    on SX and on NumPy arrays; ``gain = 0`` gives ``phi = phi_dot = 0`` exactly (the arguments
    of ``exp`` stay far below overflow for any physical pitch: ``|pitch - onset| / s < 100``)."""
    x = (pitch - onset) / smooth
    if isinstance(x, (ca.SX, ca.MX, ca.DM)):
        sp, sg = ca.log1p(ca.exp(x)), 1 / (1 + ca.exp(-x))
    else:
        sp, sg = np.logaddexp(0.0, x), 0.5 * (1 + np.tanh(x / 2))
    return gain * smooth * sp, gain * sg * pitch_dot


def _flat_pitch(stances, side: str) -> float:
    """The hindfoot's pitch at foot flat [rad]: the median over the frames between 20 % and 50 %
    of each contact of ``side``'s stances (all stances when the side has none; 0 without any).
    It is the marker set's (and the skin's) tilt of the foot frame when the sole is flat on the
    ground; the pitch drive counts the onset from each stance's own value."""
    sts = [st for st in stances if st.side == side] or list(stances)
    vals = []
    for st in sts:
        idx = np.flatnonzero(st.in_contact)
        if idx.size < 3:
            continue
        a, b = idx[0] + int(0.2 * idx.size), idx[0] + int(0.5 * idx.size)
        vals.append(pitch_numpy(st.foot.hindfoot_pose)[a : max(b, a + 1)])
    return float(np.median(np.concatenate(vals))) if vals else 0.0


@dataclass(frozen=True)
class ToeJoint(Component):
    """Toes hinged at the MTP line, the toe angle driven by the hindfoot pitch or a spline.

    The marker sets place the foot as one rigid body (hindfoot and toes welded); a real foot
    dorsiflexes its toes during push-off, so the toe units' lever about the MTP line and their
    depth below the ground are wrong exactly when they carry load. This component rotates the
    ``toes`` segment about the MTP axis (the hindfoot frame's lateral axis, through the toes
    origin, which lies on the MTP line) by the toe angle ``phi(t)`` [rad], positive =
    dorsiflexion (toes up); every unit whose parent is ``toes`` (the seed layout's ``TT``) moves
    with it (:func:`hinged_toes`). ``drive`` says where ``phi`` comes from.

    ``drive="pitch"`` (default; what the diagnosis adds): a *predictive* hinge. During heel rise
    the toes stay flat on the ground while the hindfoot pitches heel-up about the MTP line, so
    the MTP dorsiflexion follows the hindfoot's pitch relative to the ground
    (:func:`hindfoot_pitch`, from the recorded hindfoot rotation)::

        phi = gain * s * softplus((pitch - onset) / s),  phi_dot = gain * sigmoid(.) * pitch_dot

    ``onset``: the pitch at which the toes start to bend (the heel leaves the ground), counted
    from the stance's own pitch at foot flat (:func:`_flat_pitch` of that stance alone): the
    foot frame's tilt at foot flat is the marker set's and the skin's, and differs from stance to
    stance by a few degrees, so a new stance is predicted from its own foot flat, with no
    variable of its own; ``s = smooth_deg`` (2 deg, fixed)
    rounds the kink; ``gain``: 1 = the toes stay flat on the ground after heel rise, 0 = welded
    toes, between = the toes follow part of the hindfoot's pitch (they lift or roll over the tip).
    Variables (scope ``"global"``, frozen on a held-out stance, which thus pays nothing extra):
    ``gain`` [-], one shared by both feet, prior N(gain_mean, gain_sigma^2) = N(0.5, 0.5^2)
    (half-way between welded and flat toes; both within one sigma), bounds [0, gain_max = 1.2]
    (a toe does not dorsiflex faster than the hindfoot pitches by much more than its roll-off);
    ``onset`` [rad] above the stance's foot flat, per side, prior N(centre, (onset_sigma_deg = 10
    deg)^2) and bounds centre +- onset_bound_deg (30 deg), centre = ``onset_deg[side]`` or 0 (the
    toes start bending as the heel leaves foot flat). Why a shared gain and per-side onsets: the
    two feet of one subject roll off alike (the gain is the foot's physics), but each foot has
    its own markers and its own heel-rise pattern.
    Identifiability: the toe unit's load during push-off fixes mostly the product of gain and
    the pitch above onset; onset and gain are correlated (a later onset with a larger gain gives
    a similar angle at toe-off), the onset's prior and the timing of the toe load separate them.
    ``pitch_fixed``: ``{"gain": float, "onset": {side: rad above foot flat}}`` applied without
    estimating them (a frozen result, a synthetic truth).

    ``drive="spline"``: per stance, the coefficients [rad] of a cubic B-spline in time (knots
    every ``knot_spacing`` [s], the basis of :meth:`PoseCorrection.basis`); ``phi_dot`` is the
    spline's time derivative. Prior N(0, sigma_deg^2) per coefficient: no toe marker fixes the
    angle, so the prior keeps the recorded (welded) toes wherever the force data are silent (the
    toe units carry no load during most of the stance); a few degrees is the size of a welded
    model's error before heel rise. Bounds +-bound_deg: the MTP joint reaches 30-50 deg of
    dorsiflexion at toe-off, and B-spline values are convex combinations of the coefficients, so
    ``|phi| <= bound_deg``. Scope ``"stance"`` (re-estimated on a held-out stance, like the pose
    correction), so it cannot predict a new stance. ``fixed``: ``{stance label: (K,)
    coefficients [rad]}`` for stances whose angle is known (a synthetic truth); the others are
    free. What the force data determine (either drive): the toe units' load during push-off;
    where they are unloaded the angle only has to keep them off the ground. The constant part of
    ``phi`` trades with the toe units' sole offsets and stiffness.

    Neutral value: ``phi = 0`` (the welded toes, exactly): the spline's coefficients at 0, or
    ``gain = 0`` (the stored gain is the physical one, so the decision vector at 0 has it).
    """

    drive: str = "pitch"
    sigma_deg: float = 5.0
    bound_deg: float = 45.0
    knot_spacing: float = 0.1
    fixed: dict | None = None
    gain_mean: float = 0.5
    gain_sigma: float = 0.5
    gain_max: float = 1.2
    onset_deg: dict | None = None
    onset_sigma_deg: float = 10.0
    onset_bound_deg: float = 30.0
    smooth_deg: float = 2.0
    pitch_fixed: dict | None = None
    name: str = "toe_joint"
    neutral_at_zero = True
    width_fields = ("sigma_deg", "gain_sigma", "onset_sigma_deg")  # each drive reads its own
    candidate = True
    benchmark_values = {
        "small": 5.0,
        "moderate": 10.0,
        "strong": 15.0,
    }  # toe dorsiflexion at toe-off [deg]
    # TT at its nominal point in the truth, the other units as fitted: the base fit moves TT
    # 20-25 mm back, nearly under the MTP axis, where a hinge barely changes its depth (see
    # tests/test_effect_toe_joint.py, which zeroes the whole sole)
    benchmark_nominal_units = ("TT",)

    @classmethod
    def inject(cls, base, value, stances, rng) -> tuple:
        """The base plus a spline-driven toe angle per stance: 0 until 55 % of the contact,
        then a smooth step to ``value`` [deg] at toe-off (:func:`smooth_step_angles`)."""
        return (*base, cls(drive="spline", fixed=smooth_step_angles(stances, float(value))))

    def __post_init__(self) -> None:
        if self.drive not in DRIVES:
            raise ModelError(f'ToeJoint drive must be one of {DRIVES}, but got "{self.drive}"')

    @property
    def scope(self) -> str:
        """``"stance"`` for the per-stance spline, ``"global"`` for the pitch drive."""
        return "stance" if self.drive == "spline" else "global"

    @classmethod
    def for_model(cls, model: tuple) -> ToeJoint:
        """The pitch drive when ``model`` has a per-stance nuisance (a component of scope
        ``"stance"``, e.g. the pose correction), the spline drive otherwise. With the pose
        correction, a per-stance toe angle duplicates freedom the base already has (it pays the
        Occam charge on every held-out stance and is absorbed), so only a toe hinge that
        *predicts* a new stance can show; on a bare model (the seed base) the held-out stance has
        no per-stance unknown, and the toe angle, which no marker measures, is re-estimated
        there as the ``kinematic_correction`` candidate's pose is: like for like."""
        stance_scoped = any(c.scope == "stance" for c in model)
        return cls(drive="pitch" if stance_scoped else "spline")

    def basis(self, time: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """B-spline design matrices ``(T, K)`` of ``phi`` and ``phi_dot`` on ``time`` [s]."""
        return PoseCorrection(knot_spacing=self.knot_spacing).basis(np.asarray(time, float))

    def _fixed(self, stance):
        return None if self.fixed is None else self.fixed.get(stance.label)

    @property
    def _smooth(self) -> float:
        return float(np.deg2rad(self.smooth_deg))

    def _gain_key(self) -> tuple:
        return (self.name, "gain")

    def _onset_key(self, side: str) -> tuple:
        return (self.name, "onset", side)

    def declare(self, variables, stances) -> None:
        if self.drive == "pitch":
            if self.pitch_fixed is not None:
                return
            variables.parameter(
                self._gain_key(),
                self.gain_mean,
                0.0,
                self.gain_max,
                prior_sigma=self.gain_sigma,
            )
            sig, bound = np.deg2rad(self.onset_sigma_deg), np.deg2rad(self.onset_bound_deg)
            for side in SIDES:
                c = 0.0
                if self.onset_deg is not None and side in self.onset_deg:
                    c = float(np.deg2rad(self.onset_deg[side]))
                variables.parameter(
                    self._onset_key(side),
                    c,
                    c - bound,
                    c + bound,
                    prior_sigma=sig,
                    shown=(float(np.rad2deg(1.0)), 0.0, " deg"),
                )
            return
        sigma = np.deg2rad(self.sigma_deg)
        bound = np.deg2rad(self.bound_deg)
        unique_labels(self.name, stances)
        for st in stances:
            if self._fixed(st) is None:
                K = self.basis(st.time)[0].shape[1]
                variables.prior_variable((self.name, st.label), K, sigma, bound)

    def slot_sizes(self, layout) -> dict[str, int]:
        return {s: 1 for s in (PITCH_SLOTS if self.drive == "pitch" else TOE_SLOTS)}

    def slots(self, variables, index, stance) -> dict:
        if self.drive == "pitch":
            flat = _flat_pitch([stance], stance.side)  # the slot is the absolute onset
            if self.pitch_fixed is not None:
                onset = float(self.pitch_fixed["onset"][stance.side])
                gain = float(self.pitch_fixed["gain"])
                return {"toe_onset": ca.MX(1, 1) + (flat + onset), "toe_gain": ca.MX(1, 1) + gain}
            return {
                "toe_onset": variables.get(self._onset_key(stance.side)) + flat,
                "toe_gain": variables.get(self._gain_key()),
            }
        B, dB = self.basis(stance.time)
        coef = self._fixed(stance)
        if coef is None:
            c = variables.get((self.name, stance.label))
        else:
            c = ca.MX(ca.DM(np.asarray(coef, float)))
        return {"toe_phi": ca.mtimes(ca.DM(B), c).T, "toe_phidot": ca.mtimes(ca.DM(dB), c).T}

    def edit_segments(self, frame) -> None:
        seg = frame.segments
        hind = seg["hindfoot"]
        if self.drive == "pitch":
            pitch, pitch_dot = hindfoot_pitch(hind.R, hind.w)
            phi, phidot = pitch_drive(
                pitch, pitch_dot, frame.slot("toe_onset"), frame.slot("toe_gain"), self._smooth
            )
        else:
            phi, phidot = frame.slot("toe_phi"), frame.slot("toe_phidot")
        seg["toes"] = hinged_toes(hind, seg["toes"], phi, phidot)

    def signature(self) -> tuple:
        # the values, priors and knots only enter through the slots; the drive (and the pitch
        # drive's smoothing) change the per-frame expression graph
        if self.drive == "pitch":
            return ("ToeJoint", "pitch", float(self.smooth_deg))
        return ("ToeJoint", "spline")

    def decode(self, ctx: DecodeContext) -> dict:
        """``{"drive", "stances": {label: {"phi_deg": (T,), "phi_se_deg": (T,), ...}},
        "max_deg": {label: float}}``: the toe angle per stance with standard errors by the delta
        method (0 where fixed). Spline: each stance also has ``"coef_deg"``, ``"coef_se_deg"``.
        Pitch: each stance also has ``"pitch_deg"`` (the hindfoot pitch); the block has
        ``"gain"``, ``"gain_se"``, ``"onset"`` ``{side: rad above each stance's foot flat}``, ``"onset_deg"``,
        ``"onset_se_deg"`` and ``"gain_onset_corr"`` ``{side: float}``."""
        if self.drive == "pitch":
            return self._decode_pitch(ctx)
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
        return {"drive": "spline", "stances": per, "max_deg": peak}

    def _decode_pitch(self, ctx: DecodeContext) -> dict:
        s = self._smooth
        free = self.pitch_fixed is None
        index = ctx.index()
        onset, onset_se, corr = {}, {}, {}
        if free:
            gv, gs = ctx.values(self._gain_key())
            gain, gain_se = float(gv[0]), float(gs[0])
            for side in SIDES:
                v, e = ctx.values(self._onset_key(side))
                onset[side], onset_se[side] = float(v[0]), float(e[0])
        else:
            gain, gain_se = float(self.pitch_fixed["gain"]), 0.0
            for side, v in self.pitch_fixed["onset"].items():
                onset[side], onset_se[side] = float(v), 0.0
        per: dict = {}
        peak: dict = {}
        for st in ctx.stances:
            pitch = pitch_numpy(st.foot.hindfoot_pose)
            flat = _flat_pitch([st], st.side)
            o = onset[st.side] + flat
            phi, _ = pitch_drive(pitch, 0.0, o, gain, s)
            se = np.zeros(st.n)
            if free:
                se = np.full(st.n, np.nan)
                if ctx.cov is not None:
                    gspec, ospec = index[self._gain_key()], index[self._onset_key(st.side)]
                    # d phi / d (stored gain, stored onset), from the drive itself: phi is
                    # linear in the gain, and d phi / d onset = -(phi_dot at pitch_dot = 1)
                    dgain = pitch_drive(pitch, 0.0, o, 1.0, s)[0]
                    donset = -pitch_drive(pitch, 1.0, o, gain, s)[1]
                    G = np.column_stack([dgain * gspec.scale[0], donset * ospec.scale[0]])
                    i = [gspec.start, ospec.start]
                    C = ctx.cov[np.ix_(i, i)]
                    se = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", G, C, G), 0.0))
                    d = np.sqrt(max(C[0, 0] * C[1, 1], 1e-300))
                    corr[st.side] = float(C[0, 1] / d)
            per[st.label] = {
                "phi_deg": np.rad2deg(phi).tolist(),
                "phi_se_deg": np.rad2deg(se).tolist(),
                "pitch_deg": np.rad2deg(pitch).tolist(),
                "flat_pitch_deg": float(np.rad2deg(flat)),
            }
            peak[st.label] = float(np.rad2deg(phi[np.argmax(np.abs(phi))]))
        return {
            "drive": "pitch",
            "gain": gain,
            "gain_se": gain_se,
            "onset": onset,
            "onset_deg": {k: float(np.rad2deg(v)) for k, v in onset.items()},
            "onset_se_deg": {k: float(np.rad2deg(v)) for k, v in onset_se.items()},
            "gain_onset_corr": corr,
            "stances": per,
            "max_deg": peak,
        }

    @classmethod
    def describe(cls, block: dict) -> list[SummaryRow]:
        """Pitch drive: ``gain`` [-] and the onset per side [deg above the stance's foot flat].
        Spline drive: each stance's largest toe angle [deg] (its SE is in the block, per frame)."""
        if block["drive"] == "pitch":
            rows = [SummaryRow("gain", block["gain"], block["gain_se"], "-", ("gain",))]
            for side, v in block["onset_deg"].items():
                rows.append(
                    SummaryRow(
                        f"{side} onset", v, block["onset_se_deg"][side], "deg", ("onset", side)
                    )
                )
            return rows
        return [
            SummaryRow(f"{label} largest angle", v, float("nan"), "deg")
            for label, v in block["max_deg"].items()
        ]

    def frozen(self, block: dict) -> ToeJoint:
        """Spline: itself (scope ``"stance"``: the toe angle is re-estimated on a held-out stance,
        as the pose correction is). Pitch: gain and onsets fixed at ``block`` (scope
        ``"global"``: a held-out stance is predicted, with no variable of its own)."""
        if self.drive == "spline":
            return self
        fixed = {
            "gain": float(block["gain"]),
            "onset": {k: float(v) for k, v in block["onset"].items()},
        }
        return replace(self, pitch_fixed=fixed)


def smooth_step_angles(stances, peak_deg: float) -> dict:
    """``{stance label: spline coefficients [rad]}`` of a toe angle that is 0 until 55 % of the
    stance's contact, then rises in a smooth step (``3 s^2 - 2 s^3``) to ``peak_deg`` at toe-off
    (the withheld-effect benchmark's toe joint, and ``tests/test_effect_toe_joint.py``'s)."""
    tj, fixed = ToeJoint(drive="spline"), {}
    for st in stances:
        t = st.time
        t_on, t_off = t[st.in_contact][[0, -1]]
        t_a = t_on + 0.55 * (t_off - t_on)
        s = np.clip((t - t_a) / (t_off - t_a), 0, 1)
        B, _ = tj.basis(t)
        fixed[st.label] = np.linalg.lstsq(B, np.deg2rad(peak_deg) * s * s * (3 - 2 * s))[0]
    return fixed


__all__ = [
    "ToeJoint",
    "hindfoot_pitch",
    "hinged_toes",
    "mtp_axis",
    "pitch_drive",
    "smooth_step_angles",
]
