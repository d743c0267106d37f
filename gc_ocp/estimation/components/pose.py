"""Kinematic correction: a smooth small 6-DOF correction of the foot pose over each stance."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.interpolate import BSpline

from gc_ocp.errors import InputError
from gc_ocp.estimation.components.base import (
    Component,
    DecodeContext,
    per_axis,
    unique_labels,
)
from gc_ocp.geometry import correction_motion
from gc_ocp.marker_noise import filter_gain, noise_knot_spacing, noise_modelled
from gc_ocp.trial import SIDES

POSE_SLOTS = ("pose_dp", "pose_dth", "pose_ddp", "pose_ddth")


@functools.lru_cache(maxsize=512)
def _bspline_basis(time_bytes: bytes, knot_spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Cubic B-spline value and derivative design matrices on the times ``time_bytes`` (float64),
    clamped knots about every ``knot_spacing`` [s] from the first to the last time."""
    time = np.frombuffer(time_bytes, dtype=float)
    t0, t1 = float(time[0]), float(time[-1])
    n_int = max(1, int(np.ceil((t1 - t0) / knot_spacing)))
    inner = np.linspace(t0, t1, n_int + 1)
    deg = 3
    knots = np.concatenate([[t0] * deg, inner, [t1] * deg])
    K = len(knots) - deg - 1
    B = np.zeros((time.size, K))
    dB = np.zeros((time.size, K))
    for j in range(K):
        c = np.zeros(K)
        c[j] = 1.0
        spl = BSpline(knots, c, deg, extrapolate=False)
        B[:, j] = np.nan_to_num(spl(time))
        dB[:, j] = np.nan_to_num(spl.derivative()(time))
    B[-1, -1] = 1.0  # right end is inclusive
    B.flags.writeable = dB.flags.writeable = False
    return B, dB


@dataclass(frozen=True)
class PoseCorrection(Component):
    """Smooth small 6-DOF correction of the foot placement over each stance.

    The correction (translation d [m], rotation parameter theta [rad], both in ``lab`` about the
    hindfoot origin; a rigid motion, first order ``theta x r``:
    :func:`gc_ocp.geometry.correction_offset`) is a cubic B-spline in time with
    ``knot_spacing`` [s] between knots. Its coefficients have a Gaussian prior (``sigma_mm`` [mm],
    ``sigma_deg`` [deg]; a scalar, or one value per ``lab`` axis x, y, z) that ties the corrected
    foot to the placement IK found from the markers. Per-axis values let the prior follow the
    marker layout: markers spread along the foot but only ~4 cm across it fix the pitch better
    than the roll.

    knot_correlation: correlation of two coefficients ``0, 1, 2, ...`` knots apart (starts with 1;
    default: independent coefficients). The coefficients are then ``sigma * L z`` with ``L L^T``
    the Toeplitz correlation matrix and ``z ~ N(0, I)`` the decision variables (still linear).
    Scope ``"stance"``: a held-out stance re-estimates it. Neutral value: zero (no effect).

    marker_noise: where a stance's foot carries its measured marker noise
    (:attr:`~gc_ocp.foot.FootKinematics.pose_noise`), the correction has a second part that
    follows it: the low-passed white noise of the pose, ``M Phi(t) z`` with ``Phi`` a spline
    spanning the filter's band (:func:`gc_ocp.marker_noise.noise_knot_spacing`), ``M`` the
    Cholesky factor of the per-frame covariance (hindfoot axes at the stance's middle frame,
    turned into ``lab``) and ``z ~ N(0, I)``. The B-spline part is then the smooth error the
    markers cannot see (soft tissue). Without it, velocities of a few mm/s of filtered noise bias
    the exponent and the friction coefficient (``docs/quality.md``): the smooth part, with knots
    0.1 s apart, cannot follow a 6 Hz error. Noise too small to matter
    (:data:`~gc_ocp.marker_noise.MIN_UNIT_NOISE_M`) is left out.

    shared: the stances of a foot may share part of their pose error (a soft-tissue pattern
    that repeats stride after stride): its share of the prior's variance, ``rho``, is measured
    from the fitted corrections (:func:`shared_fraction`) and the covariance of the estimate
    takes it in (:meth:`prior_covariance`). The estimate itself does not change. False: the
    stances' errors are independent (the prior as declared).

    As the candidate effect ``kinematic_correction`` (against the bare seed base) it is an error
    of the *data*: the benchmark's fitter sees the foot through marker noise and a soft-tissue
    drift (:meth:`benchmark_kinematic_error`), the truth model is the base itself.
    """

    sigma_mm: float | tuple[float, float, float] = 2.0
    sigma_deg: float | tuple[float, float, float] = 1.0
    knot_spacing: float = 0.1
    bound_sigmas: float = 6.0
    knot_correlation: tuple[float, ...] | None = None
    marker_noise: bool = True
    shared: bool = True
    name: str = "pose"
    scope = "stance"
    neutral_at_zero = True
    candidate = True
    width_fields = ("sigma_mm", "sigma_deg")  # bounds follow (bound_sigmas)
    benchmark_values = {  # marker noise [m], drift [m], drift [deg]
        "small": (0.25e-3, 1e-3, 0.25),
        "moderate": (0.5e-3, 2e-3, 0.5),
        "strong": (1.0e-3, 4e-3, 1.0),
    }

    @classmethod
    def inject(cls, base, value, stances, rng) -> tuple:
        """The base itself: the effect is in the data (:meth:`benchmark_kinematic_error`)."""
        return base

    @classmethod
    def benchmark_kinematic_error(cls, value) -> tuple[float, float, float]:
        """``value`` = (marker noise [m], drift [m], drift [deg]) is the kinematic error."""
        return value

    def basis(self, time: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """B-spline design matrices ``(n, K)`` for value and time derivative on ``time`` [s]
        (read-only: cached, the same stance is built into many problems)."""
        t = np.ascontiguousarray(time, dtype=float)
        return _bspline_basis(t.tobytes(), float(self.knot_spacing))

    def correlation_factor(self, K: int) -> np.ndarray:
        """``L`` (K x K, lower triangular) with ``L L^T`` the coefficients' correlation matrix
        (identity without ``knot_correlation``)."""
        if self.knot_correlation is None:
            return np.eye(K)
        rho = np.zeros(K)
        r = np.asarray(self.knot_correlation, float)[:K]
        if r.size == 0 or r[0] != 1.0 or np.any(np.abs(r) > 1):
            raise InputError(
                f"knot_correlation must start with 1 and stay within [-1, 1], but got {self.knot_correlation}"
            )
        rho[: r.size] = r
        C = rho[np.abs(np.subtract.outer(np.arange(K), np.arange(K)))]
        try:
            return np.linalg.cholesky(C + 1e-9 * np.eye(K))
        except np.linalg.LinAlgError as e:
            raise InputError(
                f"knot_correlation {self.knot_correlation} is not a valid (positive definite) "
                "correlation sequence; taper its tail towards 0."
            ) from e

    def declare(self, variables, stances) -> None:
        unique_labels(self.name, stances)
        for st in stances:
            K = self.basis(st.time)[0].shape[1]
            # coefficients are stored column-major as 3 x K (x, y, z of knot 0, then knot 1, ...)
            st_ = np.tile(per_axis(self.sigma_mm) * 1e-3, K)
            sr_ = np.tile(np.deg2rad(per_axis(self.sigma_deg)), K)
            variables.prior_variable(
                (self.name, st.label, "trans"), 3 * K, st_, self.bound_sigmas * st_
            )
            variables.prior_variable(
                (self.name, st.label, "rot"), 3 * K, sr_, self.bound_sigmas * sr_
            )
            nb = self.noise_basis(st)
            if nb is not None:
                n = 6 * nb[0].shape[1]
                variables.prior_variable((self.name, st.label, "noise"), n, 1.0, self.bound_sigmas)

    def noise_basis(self, stance) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """``(Phi (T, K), dPhi/dt (T, K), M (6, 6))`` of the marker-noise part (class doc), or
        None (off, or no measured noise)."""
        noise = stance.foot.pose_noise
        if not self.marker_noise or noise is None:
            return None
        if not noise_modelled(noise, stance.foot.points_in_hindfoot()):
            return None  # too small to move anything (MIN_UNIT_NOISE_M)
        return _noise_part(stance.foot, noise)

    def slot_sizes(self, layout) -> dict[str, int]:
        return {s: 3 for s in POSE_SLOTS}

    def trajectories(self, variables, i: int, stance):
        """Symbolic ``(d, theta, d_dot, theta_dot)`` as 3 x n matrices for stance ``i``."""
        B, dB = self.basis(stance.time)
        K = B.shape[1]
        L = self.correlation_factor(K)  # coefficients = sigma * L z: fold L into the basis
        B, dB = B @ L, dB @ L
        tr = ca.reshape(variables.get((self.name, stance.label, "trans")), 3, K)
        rot = ca.reshape(variables.get((self.name, stance.label, "rot")), 3, K)
        d, th, dd, dth = tr @ B.T, rot @ B.T, tr @ dB.T, rot @ dB.T
        nb = self.noise_basis(stance)
        if nb is not None:
            Phi, dPhi, M = nb
            z = ca.reshape(variables.get((self.name, stance.label, "noise")), 6, Phi.shape[1])
            e, de = ca.DM(M) @ z @ Phi.T, ca.DM(M) @ z @ dPhi.T
            d, th, dd, dth = d + e[:3, :], th + e[3:, :], dd + de[:3, :], dth + de[3:, :]
        return d, th, dd, dth

    def slots(self, variables, index, stance) -> dict:
        return dict(zip(POSE_SLOTS, self.trajectories(variables, index, stance), strict=True))

    def edit_points(self, frame) -> None:
        """Rigid pose correction about the hindfoot origin: ``p' = p + dp + (R(dth) - I)(p -
        o)``, ``R`` the rotation of :func:`gc_ocp.geometry.correction_offset` (the same one the
        export places the foot with: ``I + [dth]_x`` to first order, a rotation at any size)."""
        dp, dth, ddp, ddth = (frame.slot(s) for s in POSE_SLOTS)
        h = frame.segments["hindfoot"]
        for i in range(frame.layout.n):
            p, vel = frame.points[i], frame.velocities[i]
            r = p - h.o
            rdot = vel - h.v
            offset, rate = correction_motion(dth, ddth, r, rdot, ca.cross)
            frame.points[i] = p + dp + offset
            frame.velocities[i] = vel + ddp + rate

    def prior_covariance(self, specs: list, stances: list, x: np.ndarray) -> list[tuple]:
        """Per foot with two or more stances and per axis of the smooth part, ``(cols, C)``
        with ``C = (1 - rho) I + rho E E^T`` (class doc; ``rho``: :func:`shared_fraction`;
        ``E``: :func:`_shared_map`): each coefficient keeps its prior's variance, and the
        coefficients of two stances at the same place in their stance share ``rho`` of it. A
        pattern every stride shares does not average out over the stances as independent
        errors do; this is how the covariance knows (``docs/quality.md``, "A pose error the
        strides share")."""
        if not self.shared:
            return []
        rho = shared_fraction(self, specs, stances, x)
        index = {s.key: s for s in specs}
        out = []
        for side, r in rho.items():
            sts = [st for st in stances if st.side == side]
            K_ref = _reference_knots(self, sts)
            E = np.vstack([_shared_map(self, st.time, K_ref) for st in sts])
            C = (1.0 - r) * np.eye(E.shape[0]) + r * (E @ E.T)
            Ks = [self.basis(st.time)[0].shape[1] for st in sts]
            for part in ("trans", "rot"):
                starts = [index[(self.name, st.label, part)].start for st in sts]
                for axis in range(3):
                    cols = np.concatenate(
                        [s0 + 3 * np.arange(K) + axis for s0, K in zip(starts, Ks, strict=True)]
                    )
                    out.append((cols, C))
        return out

    def draw(self, stances: list, rho: dict, rng: np.random.Generator) -> list[tuple]:
        """A draw of the smooth part's prior, per stance ``(translation (T, 3) [m], rotation
        (T, 3) [rad])``, both in ``lab`` about the hindfoot origin, as the correction applies
        them: each coefficient ``N(0, 1)`` in units of its width (through ``knot_correlation``),
        the stances of a foot sharing ``rho[side]`` of the variance (:func:`shared_fraction`;
        the covariance of :meth:`prior_covariance`, drawn as ``sqrt(1 - rho) e + sqrt(rho) E
        g``). The error of the markers that the correction stands for, to simulate it
        (:func:`gc_ocp.estimation.bias.replicate_data`)."""
        widths = (
            per_axis(self.sigma_mm) * 1e-3,
            np.deg2rad(per_axis(self.sigma_deg)),
        )
        out: list = [None] * len(stances)
        for side in SIDES:
            idx = [i for i, st in enumerate(stances) if st.side == side]
            if not idx:
                continue
            r = float(rho.get(side, 0.0)) if len(idx) > 1 and self.shared else 0.0
            K_ref = _reference_knots(self, [stances[i] for i in idx])
            pattern = rng.standard_normal((2, K_ref, 3))  # translation, rotation
            for i in idx:
                B = self.basis(stances[i].time)[0]
                K = B.shape[1]
                E = _shared_map(self, stances[i].time, K_ref)
                BL = B @ self.correlation_factor(K)
                out[i] = tuple(
                    BL @ (np.sqrt(1.0 - r) * rng.standard_normal((K, 3)) + np.sqrt(r) * (E @ g)) * w
                    for g, w in zip(pattern, widths, strict=True)
                )
        return out

    def signature(self) -> tuple:
        return ("PoseCorrection",)  # values, priors and knots only enter through its slots

    def decode(self, ctx: DecodeContext) -> dict:
        """``{"rms": {side: {"mm", "deg"}}, "stances": {label: {"translation_m": (T, 3),
        "rotation_rad": (T, 3)}}, "prior_mm": [x, y, z], "prior_deg": [x, y, z]}``: the
        correction's RMS per foot, its trajectories and its prior's widths per ``lab`` axis
        (estimated ones too, :mod:`gc_ocp.estimation.pose_scale`)."""
        sq: dict = {s: ([], []) for s in SIDES}
        per: dict = {}
        for i, st in enumerate(ctx.stances):
            d, th = ctx.slot_values(i, "pose_dp"), ctx.slot_values(i, "pose_dth")
            per[st.label] = {"translation_m": d.tolist(), "rotation_rad": th.tolist()}
            sq[st.side][0].append(np.sum(d**2, axis=1))
            sq[st.side][1].append(np.sum(th**2, axis=1))
        rms = {
            s: {
                "mm": float(np.sqrt(np.mean(np.concatenate(v[0])))) * 1e3,
                "deg": float(np.rad2deg(np.sqrt(np.mean(np.concatenate(v[1]))))),
            }
            for s, v in sq.items()
            if v[0]
        }
        shared = shared_fraction(self, ctx.specs, ctx.stances, ctx.x) if self.shared else {}
        return {
            "rms": rms,
            "shared_fraction": shared,
            "stances": per,
            "prior_mm": per_axis(self.sigma_mm).tolist(),
            "prior_deg": per_axis(self.sigma_deg).tolist(),
        }


SHARED_GRID = 21
"""Points of a stance's normalised time (0 at the first frame, 1 at the last) at which the
corrections of two stances are compared (:func:`shared_fraction`): finer than the knots of any
stance (a 1.5-s stance with knots 0.1 s apart has 18)."""


def _trajectory(comp: PoseCorrection, spec_of, x: np.ndarray, stance) -> np.ndarray:
    """``(6, SHARED_GRID)``: the smooth part of ``stance``'s correction (translation, rotation;
    stored units, i.e. in units of the prior's width per axis) at :data:`SHARED_GRID` points of
    its normalised time."""
    t = np.asarray(stance.time, float)
    grid = t[0] + np.linspace(0.0, 1.0, SHARED_GRID) * (t[-1] - t[0])
    B = _bspline_basis(np.ascontiguousarray(grid).tobytes(), float(comp.knot_spacing))[0]
    rows = []
    for part in ("trans", "rot"):
        z = np.asarray(x[spec_of[(comp.name, stance.label, part)].slice], float)
        # stored column-major 3 x K; the coefficients are L z (knot_correlation)
        rows.append((comp.correlation_factor(B.shape[1]) @ z.reshape(-1, 3)).T @ B.T)
    return np.vstack(rows)


def shared_fraction(comp: PoseCorrection, specs: list, stances: list, x: np.ndarray) -> dict:
    """``{side: rho}``: the share of the pose correction's variance that the stances of a foot
    have in common, measured from the fitted corrections at ``x``: the mean product of two
    stances' corrections over the mean square of one, both at the same points of their
    normalised time (:func:`_trajectory`), pooled over the six axes in units of their widths,
    clipped to [0, 1]. Independent errors give ~0 (more so with more stances), one pattern in
    every stride 1. Only feet with two or more stances (with one, a shared pattern is that
    stance's own error). With ``knot_correlation`` the trajectories are those of the
    coefficients ``L z``, and :meth:`PoseCorrection.prior_covariance` shares ``rho`` of the
    stored (white) variables ``z``: stances of equal length then share it in the coefficients
    too (the AR(1) factor of a shorter stance is the leading block of a longer one's)."""
    spec_of = {s.key: s for s in specs}
    out = {}
    for side in SIDES:
        Z = [_trajectory(comp, spec_of, x, st) for st in stances if st.side == side]
        if len(Z) < 2:
            continue
        total = float(np.mean([np.sum(z * z) for z in Z]))
        cross = [np.sum(Z[i] * Z[j]) for i in range(len(Z)) for j in range(i + 1, len(Z))]
        out[side] = float(np.clip(np.mean(cross) / total, 0.0, 1.0)) if total > 0 else 0.0
    return out


def _reference_knots(comp: PoseCorrection, stances: list) -> int:
    """Coefficients of the shared pattern: those of the foot's longest stance."""
    return max(comp.basis(st.time)[0].shape[1] for st in stances)


def _shared_map(comp: PoseCorrection, time: np.ndarray, K_ref: int) -> np.ndarray:
    """``E`` ``(K, K_ref)``: a stance's coefficients (one axis) of a pattern whose ``K_ref``
    coefficients are independent ``N(0, 1)``: each coefficient interpolated linearly at the
    same place of the normalised knot sequence, its row scaled to unit norm so that every
    coefficient keeps its prior's variance (the identity when the stance has ``K_ref``)."""
    K = comp.basis(time)[0].shape[1]
    E = np.zeros((K, K_ref))
    if K_ref == 1:
        E[:, 0] = 1.0
        return E
    pos = np.linspace(0.0, K_ref - 1.0, K)
    lo = np.minimum(np.floor(pos).astype(int), K_ref - 2)
    w = pos - lo
    E[np.arange(K), lo] = 1.0 - w
    E[np.arange(K), lo + 1] = w
    return E / np.linalg.norm(E, axis=1, keepdims=True)


def _noise_part(foot, noise) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Phi, dPhi/dt, M) of :meth:`PoseCorrection.noise_basis`."""
    R = np.ascontiguousarray(foot.hindfoot_pose[foot.time.size // 2, :3, :3])
    return _noise_arrays(
        foot.time.tobytes(),
        R.tobytes(),
        noise.cov.tobytes(),
        noise_knot_spacing(noise),
        filter_gain(noise),
    )


@functools.lru_cache(maxsize=512)
def _noise_arrays(
    time_bytes: bytes, rotation_bytes: bytes, cov_bytes: bytes, knot_spacing: float, gain: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Phi, dPhi/dt, M) for the frame times, the hindfoot's middle-frame rotation and the
    per-frame covariance (float64 bytes; cached, read-only: the same stance is built into many
    problems)."""
    B, dB = _bspline_basis(time_bytes, knot_spacing)
    scale = np.sqrt(gain / float(np.mean(np.sum(B**2, axis=1))))
    Phi, dPhi = B * scale, dB * scale
    R = np.frombuffer(rotation_bytes, dtype=float).reshape(3, 3)
    cov = np.frombuffer(cov_bytes, dtype=float).reshape(6, 6)
    Rb = np.zeros((6, 6))
    Rb[:3, :3] = Rb[3:, 3:] = R
    M = Rb @ np.linalg.cholesky(cov + 1e-30 * np.eye(6))
    for a in (Phi, dPhi, M):
        a.flags.writeable = False
    return Phi, dPhi, M


__all__ = ["SHARED_GRID", "PoseCorrection", "shared_fraction"]
