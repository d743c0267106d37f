"""Model components: each contributes decision variables, priors and terms to the estimation NLP.

A model is a tuple of components. The seed model and the full model are two configurations:

>>> seed = (ContactLaw.seed(),)                                   # doctest: +SKIP
>>> full = (ContactLaw(), SoleCorrection(), PoseCorrection())     # doctest: +SKIP

Every decision variable is *scaled* so that O(1) is a typical magnitude; variables that carry a
Gaussian prior are stored in units of their prior standard deviation, so the prior term is
``0.5 * ||z||^2``. Stiffness is estimated as ``log k`` so that ``k > 0`` by construction.

The sim-to-real diagnosis adds candidate extensions (ground offset, time offset, toe hinge,
denser sole, other friction laws, ...) as further components of this kind.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Literal

import numpy as np

from gc_ocp.foot import UNITS
from gc_ocp.trial import SIDES

if TYPE_CHECKING:  # pragma: no cover
    from gc_ocp.estimation.problem import Builder

Scope = Literal["unit", "foot", "shared", "fixed"]


@dataclass(frozen=True)
class Param:
    """How one contact parameter is estimated.

    scope: ``"unit"`` (one per unit per foot; only k), ``"foot"`` (one per foot), ``"shared"``
    (one for both feet) or ``"fixed"`` (not estimated: ``value`` is used).
    value: initial (or fixed) value in SI units; a float, or ``{side: float}`` /
    ``{side: {unit: float}}`` for fixed per-foot / per-unit values.
    lower, upper: bounds in SI units.
    prior_sigma: optional Gaussian prior centred on ``value``, in the optimised units (log units
    for k: ``prior_sigma = 2`` means a factor e^2 = 7.4 at one standard deviation).
    """

    scope: Scope
    value: float | dict
    lower: float = -np.inf
    upper: float = np.inf
    prior_sigma: float | None = None

    def value_for(self, side: str, unit: str | None = None) -> float:
        v = self.value
        if isinstance(v, dict):
            v = v[side]
            if isinstance(v, dict):
                v = v[unit]
        return float(v)


@dataclass(frozen=True)
class ContactLaw:
    """Hunt-Crossley normal force with Coulomb friction, per unit.

    k: stiffness [N/m^n] (estimated as log k); n: penetration exponent [-];
    c: Hunt-Crossley damping [s/m]; mu: friction coefficient [-].
    depth_smoothing: smoothing length of the penetration [m] (see ``gc_ocp.contact.laws``).
    slip_smoothing: sliding speed below which friction is smoothed [m/s].
    reference_depth: penetration [m] at which each unit's force ``f_ref = k d^n`` is reported
    (the well-determined summary of its force-depth curve; see ``EstimationResult.params``).
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
    name: str = "contact"

    @classmethod
    def seed(cls, mu: float = 0.0) -> ContactLaw:
        """The seed report's model: k per unit, n = 1, c = 0, fixed friction ``mu``."""
        return cls(
            k=Param("unit", 1.2e4, 1.0, 1.0e9),
            n=Param("fixed", 1.0),
            c=Param("fixed", 0.0),
            mu=Param("fixed", mu),
        )

    def declare(self, b: Builder) -> None:
        for pname in ("k", "n", "c", "mu"):
            p: Param = getattr(self, pname)
            log = pname == "k"
            if p.scope == "fixed":
                continue
            keys: list[tuple[str, ...]]
            if p.scope == "unit":
                if pname != "k":
                    raise ValueError(
                        f'Param "{pname}" cannot have scope "unit"; choose foot, shared or fixed.'
                    )
                keys = [(s, u) for s in SIDES for u in UNITS]
            elif p.scope == "foot":
                keys = [(s,) for s in SIDES]
            else:
                keys = [()]
            for key in keys:
                v0 = (
                    p.value_for(*key)
                    if p.scope != "shared"
                    else p.value_for(SIDES[0], UNITS[0])
                    if isinstance(p.value, dict)
                    else float(p.value)
                )
                b.parameter(
                    (self.name, pname, *key),
                    v0,
                    p.lower,
                    p.upper,
                    log=log,
                    prior_sigma=p.prior_sigma,
                )

    def values(self, b: Builder, side: str, log_k: bool = False) -> dict:
        """Symbolic (or fixed numeric) parameter values for ``side``: k (5,), n, c, mu.
        ``log_k``: return log k instead of k (linear in the decision vector)."""
        out = {}
        for pname in ("k", "n", "c", "mu"):
            p: Param = getattr(self, pname)
            raw = log_k and pname == "k"
            if p.scope == "fixed":
                if pname == "k":
                    ks = [p.value_for(side, u) for u in UNITS]
                    out[pname] = [float(np.log(v)) for v in ks] if raw else ks
                else:
                    out[pname] = p.value_for(side)
            elif p.scope == "unit":
                out[pname] = [b.get((self.name, pname, side, u), raw=raw) for u in UNITS]
            elif p.scope == "foot":
                out[pname] = b.get((self.name, pname, side), raw=raw)
            else:
                out[pname] = b.get((self.name, pname), raw=raw)
            if pname == "k" and p.scope in ("foot", "shared"):
                out[pname] = [out[pname]] * len(UNITS)  # one stiffness for every unit
        return out


@dataclass(frozen=True)
class SoleCorrection:
    """Correction of each sole point's position in its parent (foot) frame.

    A Gaussian prior N(0, sigma^2) per component (default 5 mm: the uncertainty of locating the
    sole from skin markers over heel and metatarsals) and bounds +-bound [m].
    ``fixed``: ``{side: (5, 3) array [m]}`` to apply known corrections without estimating them.
    """

    sigma: float = 0.005
    bound: float = 0.025
    fixed: dict | None = None
    name: str = "sole"

    def with_prior_scale(self, f: float) -> SoleCorrection:
        """The same component with its prior width multiplied by ``f`` (the bound is kept)."""
        return replace(self, sigma=self.sigma * f)

    def declare(self, b: Builder) -> None:
        if self.fixed is not None:
            return
        for side in SIDES:
            for u in UNITS:
                b.prior_variable((self.name, side, u), 3, self.sigma, self.bound)

    def offsets(self, b: Builder, side: str):
        """(5, 3)-like list of symbolic offsets [m] for ``side`` (rows = units)."""
        if self.fixed is not None:
            return np.asarray(self.fixed[side], float)
        return [b.get((self.name, side, u)) for u in UNITS]


@dataclass(frozen=True)
class PoseCorrection:
    """Smooth small 6-DOF correction of the foot placement over each stance.

    The correction (translation d [m], small rotation theta [rad], both in ``lab`` about the
    hindfoot origin) is a cubic B-spline in time with ``knot_spacing`` [s] between knots. Its
    coefficients have a Gaussian prior (``sigma_mm`` [mm], ``sigma_deg`` [deg]; a scalar, or one
    value per ``lab`` axis x, y, z) that ties the corrected foot to the placement IK found from the
    markers. Per-axis values let the prior follow the marker layout: markers spread along the
    foot but only ~4 cm across it fix the pitch better than the roll.

    knot_correlation: correlation of two coefficients ``0, 1, 2, ...`` knots apart (starts with 1;
    default: independent coefficients). Filtered marker noise is correlated over ~50 ms; a prior
    with that correlation describes it better than independent coefficients. The coefficients are
    then ``sigma * L z`` with ``L L^T`` the Toeplitz correlation matrix and ``z ~ N(0, I)`` the
    decision variables (still linear, so the estimator's structure is unchanged).
    """

    sigma_mm: float | tuple[float, float, float] = 2.0
    sigma_deg: float | tuple[float, float, float] = 1.0
    knot_spacing: float = 0.1
    bound_sigmas: float = 6.0
    knot_correlation: tuple[float, ...] | None = None
    name: str = "pose"

    def with_prior_scale(self, f: float) -> PoseCorrection:
        """The same component with its prior widths multiplied by ``f`` (bounds follow)."""

        def scaled(v):
            return v * f if np.isscalar(v) else tuple(float(a) * f for a in v)

        return replace(self, sigma_mm=scaled(self.sigma_mm), sigma_deg=scaled(self.sigma_deg))

    def basis(self, time: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """B-spline design matrices ``(n, K)`` for value and time derivative on ``time`` [s]."""
        from scipy.interpolate import BSpline

        t0, t1 = float(time[0]), float(time[-1])
        n_int = max(1, int(np.ceil((t1 - t0) / self.knot_spacing)))
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
        return B, dB

    def correlation_factor(self, K: int) -> np.ndarray:
        """``L`` (K x K, lower triangular) with ``L L^T`` the coefficients' correlation matrix
        (identity without ``knot_correlation``)."""
        if self.knot_correlation is None:
            return np.eye(K)
        rho = np.zeros(K)
        r = np.asarray(self.knot_correlation, float)[:K]
        if r.size == 0 or r[0] != 1.0 or np.any(np.abs(r) > 1):
            raise ValueError(
                f"knot_correlation must start with 1 and stay within [-1, 1], got {self.knot_correlation}"
            )
        rho[: r.size] = r
        C = rho[np.abs(np.subtract.outer(np.arange(K), np.arange(K)))]
        try:
            return np.linalg.cholesky(C + 1e-9 * np.eye(K))
        except np.linalg.LinAlgError as e:
            raise ValueError(
                f"knot_correlation {self.knot_correlation} is not a valid (positive definite) "
                "correlation sequence; taper its tail towards 0."
            ) from e

    def declare(self, b: Builder) -> None:
        for i, st in enumerate(b.stances):
            K = self.basis(st.time)[0].shape[1]
            # coefficients are stored column-major as 3 x K (x, y, z of knot 0, then knot 1, ...)
            st_ = np.tile(np.broadcast_to(np.asarray(self.sigma_mm, float), 3) * 1e-3, K)
            sr_ = np.tile(np.deg2rad(np.broadcast_to(np.asarray(self.sigma_deg, float), 3)), K)
            b.prior_variable((self.name, i, "trans"), 3 * K, st_, self.bound_sigmas * st_)
            b.prior_variable((self.name, i, "rot"), 3 * K, sr_, self.bound_sigmas * sr_)

    def trajectories(self, b: Builder, i: int):
        """Symbolic ``(d, theta, d_dot, theta_dot)`` as 3 x n matrices for stance ``i``."""
        import casadi as ca

        st = b.stances[i]
        B, dB = self.basis(st.time)
        K = B.shape[1]
        L = self.correlation_factor(K)  # coefficients = sigma * L z: fold L into the basis
        B, dB = B @ L, dB @ L
        tr = ca.reshape(b.get((self.name, i, "trans")), 3, K)
        rot = ca.reshape(b.get((self.name, i, "rot")), 3, K)
        return tr @ B.T, rot @ B.T, tr @ dB.T, rot @ dB.T


@dataclass(frozen=True)
class BeltSpeed:
    """Correction of the treadmill belt speed [m/s], one per treadmill trial.

    The nominal speed (``Trial.belt_velocity``) is rarely known to better than a few cm/s, and the
    sliding velocity of every unit is taken relative to the belt: a small error turns Coulomb
    friction into a large spurious shear force. Gaussian prior N(0, sigma^2), bounds +-bound.
    Trials with no belt (overground) get no variable.
    """

    sigma: float = 0.1
    bound: float = 0.5
    name: str = "belt"

    def declare(self, b: Builder) -> None:
        for trial in dict.fromkeys(st.trial for st in b.stances if np.any(st.belt_velocity != 0)):
            b.prior_variable((self.name, trial), 1, self.sigma, self.bound)

    def correction(self, b: Builder, trial: str):
        key = (self.name, trial)
        return b.get(key) if b.has(key) else 0.0


Component = ContactLaw | SoleCorrection | PoseCorrection | BeltSpeed


def seed_model(mu: float = 0.0) -> tuple:
    """The seed report's configuration: contact law only, n = 1, c = 0, fixed points."""
    return (ContactLaw.seed(mu),)


def full_model() -> tuple:
    """Today's model: contact law with k per unit, shared n, c, mu; sole and pose corrections;
    belt-speed correction (treadmill trials only)."""
    return (ContactLaw(), SoleCorrection(), PoseCorrection(), BeltSpeed())
