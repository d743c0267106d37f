"""Build the joint kinematics-contact estimation NLP (CasADi), separately from solving it.

``build_estimation(stances, model, weights)`` returns an :class:`EstimationProblem` holding the
CasADi NLP (objective, decision vector, bounds, initial guess) and the functions that decode a
solution. Tests can evaluate the objective at a fixed vector without running Ipopt.

Objective (a MAP / weighted least-squares problem)::

    J(z) = 1/2 sum_frames sum_channels ((wrench_model - wrench_measured) / sigma_channel)^2
         + 1/2 ||z_prior||^2

Channel sigmas (``Weights``): forces ``force_sigma`` x BW; torques ``force_sigma`` x BW x
``torque_length``. With ``torque_length = 0.25 m`` a 10 mm COP error at 1 BW costs as much as a
4 % BW force error, so the COP counts; under the seed's BW x height normalisation (1.7 m) a 40 mm
COP error at 1 BW weighs as little as a 2.4 % BW force error.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from gc_ocp.errors import ModelError
from gc_ocp.estimation.data import StanceData
from gc_ocp.sole import UNIT_PARENT, UNITS


@dataclass(frozen=True)
class Weights:
    """Residual scaling. force_sigma: force error scale as a fraction of BW [-];
    torque_length: torque error scale = force scale x this length [m]."""

    force_sigma: float = 0.02
    torque_length: float = 0.25

    def inverse_sigmas(self, body_weight: float) -> np.ndarray:
        sf = self.force_sigma * body_weight
        return 1.0 / np.array([sf, sf, sf, sf * self.torque_length, sf * self.torque_length, sf * self.torque_length])


def _contact_frame_function(depth_smoothing: float, slip_smoothing: float) -> ca.Function:
    """Per-frame model wrench and weighted residual for one foot (SX, mapped over frames)."""
    from gc_ocp.contact.laws import DEFAULT_SMOOTHING, unit_force_function

    unit_force = unit_force_function(smooth=True)

    SX = ca.SX
    Rh, Rt = SX.sym("Rh", 9), SX.sym("Rt", 9)
    oh, vh, wh = SX.sym("oh", 3), SX.sym("vh", 3), SX.sym("wh", 3)
    ot, vt, wt = SX.sym("ot", 3), SX.sym("vt", 3), SX.sym("wt", 3)
    dp, dth, ddp, ddth = SX.sym("dp", 3), SX.sym("dth", 3), SX.sym("ddp", 3), SX.sym("ddth", 3)
    meas, wts = SX.sym("meas", 6), SX.sym("wts", 6)
    loc = SX.sym("loc", 3, 5)
    k = SX.sym("k", 5)
    n, c, mu = SX.sym("n"), SX.sym("c"), SX.sym("mu")
    ground, belt, ref = SX.sym("ground"), SX.sym("belt", 3), SX.sym("ref", 3)

    Rhm, Rtm = ca.reshape(Rh, 3, 3), ca.reshape(Rt, 3, 3)
    F = SX.zeros(3)
    M = SX.zeros(3)
    forces = []
    for i, u in enumerate(UNITS):
        if UNIT_PARENT[u] == "hindfoot":
            R, o, v, w = Rhm, oh, vh, wh
        else:
            R, o, v, w = Rtm, ot, vt, wt
        r_loc = R @ loc[:, i]
        p = o + r_loc
        vel = v + ca.cross(w, r_loc)
        # small pose correction about the hindfoot origin (first order in the rotation)
        r = p - oh
        rdot = vel - vh
        p = p + dp + ca.cross(dth, r)
        vel = vel + ddp + ca.cross(ddth, r) + ca.cross(dth, rdot)
        f = unit_force(p, vel, k[i], n, c, mu, ground, belt, depth_smoothing, DEFAULT_SMOOTHING.eps_damping, slip_smoothing)
        forces.append(f)
        F = F + f
        M = M + ca.cross(p - ref, f)
    wrench = ca.vertcat(F, M)
    res = (wrench - meas) * wts
    return ca.Function(
        "foot_frame",
        [Rh, oh, vh, wh, Rt, ot, vt, wt, dp, dth, ddp, ddth, meas, wts, loc, k, n, c, mu, ground, belt, ref],
        [res, wrench, ca.vertcat(*forces)],
    )


class Builder:
    """Collects decision variables from the model components (two passes: declare, then use)."""

    def __init__(self, stances: list[StanceData]) -> None:
        self.stances = stances
        self._specs: list[dict] = []
        self._index: dict[tuple, slice] = {}
        self.x: ca.MX | None = None

    # --- declaration pass -------------------------------------------------------------------
    def _add(self, key: tuple, size: int, x0, lb, ub, kind: str, scale, log: bool) -> None:
        if key in self._index:
            raise ModelError(f"Variable {key} declared twice; two components claim the same parameter.")
        start = sum(s["size"] for s in self._specs)
        self._index[key] = slice(start, start + size)
        self._specs.append(dict(key=key, size=size, x0=np.broadcast_to(x0, size).astype(float),
                                lb=np.broadcast_to(lb, size).astype(float),
                                ub=np.broadcast_to(ub, size).astype(float),
                                kind=kind, scale=scale, log=log))

    def parameter(self, key: tuple, value: float, lower: float, upper: float, log: bool = False) -> None:
        """A physical parameter without prior. ``log``: optimise log(value) (value > 0)."""
        if log:
            self._add(key, 1, np.log(value), np.log(max(lower, 1e-300)), np.log(upper), "param", 1.0, True)
        else:
            self._add(key, 1, value, lower, upper, "param", 1.0, False)

    def prior_variable(self, key: tuple, size: int, sigma: float, bound: float) -> None:
        """A vector with Gaussian prior N(0, sigma^2), stored in units of sigma, bounded by +-bound."""
        b = bound / sigma
        self._add(key, size, 0.0, -b, b, "prior", sigma, False)

    def finalize(self) -> None:
        n = sum(s["size"] for s in self._specs)
        self.x = ca.MX.sym("x", n)

    # --- use pass ---------------------------------------------------------------------------
    def get(self, key: tuple):
        """Physical value of a declared variable (symbolic)."""
        if self.x is None:
            raise RuntimeError("Builder.get() before finalize()")
        sl = self._index[key]
        spec = next(s for s in self._specs if s["key"] == key)
        z = self.x[sl]
        if spec["log"]:
            return ca.exp(z)
        return z * spec["scale"]

    @property
    def specs(self) -> list[dict]:
        return self._specs

    def vector(self, field_: str) -> np.ndarray:
        return np.concatenate([s[field_] for s in self._specs]) if self._specs else np.zeros(0)

    def prior_mask(self) -> np.ndarray:
        if not self._specs:
            return np.zeros(0, dtype=bool)
        return np.concatenate([np.full(s["size"], s["kind"] == "prior") for s in self._specs])


@dataclass
class EstimationProblem:
    """A built (not yet solved) estimation NLP and what is needed to decode its solution."""

    stances: list[StanceData]
    model: tuple
    weights: Weights
    builder: Builder
    x: ca.MX
    objective: ca.MX
    residuals: ca.MX  # all weighted residuals incl. priors, for Gauss-Newton / covariance
    n_data: int
    x0: np.ndarray
    lbx: np.ndarray
    ubx: np.ndarray
    stance_outputs: list[ca.MX] = field(default_factory=list)  # per stance: (6, n) model wrench
    stance_points: list[ca.MX] = field(default_factory=list)  # per stance: (5*3, 1) corrected local points

    def objective_function(self) -> ca.Function:
        return ca.Function("J", [self.x], [self.objective])

    def evaluate(self, x: np.ndarray) -> float:
        """Objective at a given decision vector (no solve)."""
        return float(self.objective_function()(x))

    def component(self, cls):
        return next((m for m in self.model if isinstance(m, cls)), None)


def build_estimation(
    stances: list[StanceData], model: tuple, weights: Weights | None = None
) -> EstimationProblem:
    """Build the NLP for ``stances`` under ``model`` (a tuple of components)."""
    from gc_ocp.estimation.components import ContactLaw, PoseCorrection, SoleCorrection

    if not stances:
        raise ModelError("No stances to fit: the trial has no usable stance (see `gc-ocp info`).")
    weights = weights or Weights()
    law = next((m for m in model if isinstance(m, ContactLaw)), None)
    if law is None:
        raise ModelError("The model needs a ContactLaw component.")
    b = Builder(stances)
    for comp in model:
        comp.declare(b)
    b.finalize()
    sole = next((m for m in model if isinstance(m, SoleCorrection)), None)
    pose = next((m for m in model if isinstance(m, PoseCorrection)), None)

    frame_fn = _contact_frame_function(law.depth_smoothing, law.slip_smoothing)
    residuals = []
    outputs = []
    points = []
    n_data = 0
    for i, st in enumerate(stances):
        f = st.foot
        T = st.n
        par = law.values(b, st.side)
        loc = ca.MX(np.asarray(f.points_local, float).T)  # 3 x 5
        if sole is not None:
            off = sole.offsets(b, st.side)
            loc = loc + (ca.horzcat(*off) if not isinstance(off, np.ndarray) else ca.MX(off.T))
        points.append(ca.vec(loc))
        if pose is not None:
            dp, dth, ddp, ddth = pose.trajectories(b, i)
        else:
            dp = dth = ddp = ddth = ca.MX.zeros(3, T)
        Rh = f.hindfoot_pose[:, :3, :3].transpose(0, 2, 1).reshape(T, 9).T  # column-major R
        Rt = f.toes_pose[:, :3, :3].transpose(0, 2, 1).reshape(T, 9).T
        inv_sig = weights.inverse_sigmas(st.body_weight)
        fmap = frame_fn.map(T)
        res, wrench, _ = fmap(
            Rh, f.hindfoot_pose[:, :3, 3].T, f.hindfoot_twist[:, :3].T, f.hindfoot_twist[:, 3:].T,
            Rt, f.toes_pose[:, :3, 3].T, f.toes_twist[:, :3].T, f.toes_twist[:, 3:].T,
            dp, dth, ddp, ddth, st.measured.T, np.tile(inv_sig[:, None], (1, T)),
            loc, ca.vertcat(*par["k"]), par["n"], par["c"], par["mu"],
            st.ground_height, st.belt_velocity, st.reference_point,
        )
        residuals.append(ca.vec(res))
        outputs.append(wrench)
        n_data += 6 * T
    pmask = b.prior_mask()
    prior_idx = np.flatnonzero(pmask)
    prior_res = b.x[prior_idx.tolist()] if prior_idx.size else ca.MX.zeros(0)
    r_all = ca.vertcat(*residuals, prior_res)
    J = 0.5 * ca.sumsqr(r_all)
    return EstimationProblem(
        stances=stances, model=model, weights=weights, builder=b, x=b.x, objective=J,
        residuals=r_all, n_data=n_data, x0=b.vector("x0"), lbx=b.vector("lb"), ubx=b.vector("ub"),
        stance_outputs=outputs, stance_points=points,
    )
