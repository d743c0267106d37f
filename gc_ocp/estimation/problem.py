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
from gc_ocp.foot import SEED_LAYOUT, UNITS
from gc_ocp.stance import StanceData


@dataclass(frozen=True)
class Weights:
    """Residual scaling. force_sigma: force error scale as a fraction of BW [-];
    torque_length: torque error scale = force scale x this length [m]."""

    force_sigma: float = 0.02
    torque_length: float = 0.25

    def inverse_sigmas(self, body_weight: float) -> np.ndarray:
        sf = self.force_sigma * body_weight
        return 1.0 / np.array(
            [sf, sf, sf, sf * self.torque_length, sf * self.torque_length, sf * self.torque_length]
        )


N_Y = 36
"""Per-frame model inputs that depend on the decision vector (all *linearly*):
dp, dth, ddp, ddth (12, pose correction and its rate), unit positions in their parent frames
(15, column-major 3 x 5), log k (5), n, c, mu, belt-speed correction (1, [m/s])."""
N_D = 55
"""Per-frame numeric data: Rh(9, column-major), oh, vh, wh, Rt(9), ot, vt, wt, measured wrench (6),
inverse sigmas (6), ground height (1), belt velocity (3), reference point (3)."""


def frame_data(st: StanceData, weights: Weights) -> np.ndarray:
    """``(N_D, n)`` numeric per-frame inputs of one stance (time in columns)."""
    f = st.foot
    T = st.n
    Rh = f.hindfoot_pose[:, :3, :3].transpose(0, 2, 1).reshape(T, 9)  # column-major R
    Rt = f.toes_pose[:, :3, :3].transpose(0, 2, 1).reshape(T, 9)
    const = np.concatenate(
        [
            weights.inverse_sigmas(st.body_weight),
            [st.ground_height],
            st.belt_velocity,
            st.reference_point,
        ]
    )
    return np.hstack(
        [
            Rh,
            f.hindfoot_pose[:, :3, 3],
            f.hindfoot_twist,
            Rt,
            f.toes_pose[:, :3, 3],
            f.toes_twist,
            st.measured,
            np.tile(const, (T, 1)),
        ]
    ).T


def _contact_frame_function(depth_smoothing: float, slip_smoothing: float) -> ca.Function:
    """Per-frame weighted residual and model wrench of one foot, ``(D, y) -> (res, wrench)``.

    SX, so that it can be mapped over frames and differentiated cheaply (see :data:`N_D`, :data:`N_Y`).
    """
    from gc_ocp.contact.laws import DEFAULT_SMOOTHING
    from gc_ocp.contact.wrench_model import wrench_function

    D = ca.SX.sym("D", N_D)
    y = ca.SX.sym("y", N_Y)
    Rhm, oh, vh, wh = ca.reshape(D[0:9], 3, 3), D[9:12], D[12:15], D[15:18]
    Rtm, ot, vt, wt = ca.reshape(D[18:27], 3, 3), D[27:30], D[30:33], D[33:36]
    meas, wts, ground, belt, ref = D[36:42], D[42:48], D[48], D[49:52], D[52:55]
    dp, dth, ddp, ddth = y[0:3], y[3:6], y[6:9], y[9:12]
    loc = ca.reshape(y[12:27], 3, 5)
    k = ca.exp(y[27:32])
    n, c, mu = y[32], y[33], y[34]
    belt = belt - ca.vertcat(y[35], 0, 0)  # the belt runs along -X: a faster belt is more negative
    P, V = [], []
    for i, u in enumerate(UNITS):
        if SEED_LAYOUT.parent(u) == "hindfoot":
            R, o, v, w = Rhm, oh, vh, wh
        else:
            R, o, v, w = Rtm, ot, vt, wt
        r_loc = R @ loc[:, i]
        p = o + r_loc
        vel = v + ca.cross(w, r_loc)
        # small pose correction about the hindfoot origin (first order in the rotation)
        r = p - oh
        rdot = vel - vh
        P.append(p + dp + ca.cross(dth, r))
        V.append(vel + ddp + ca.cross(ddth, r) + ca.cross(dth, rdot))
    # the same equivalent-wrench Function (Eqs 4-9) as the seed study, smooth variant
    wrench = wrench_function(True, len(UNITS))(
        ca.horzcat(*P),
        ca.horzcat(*V),
        k,
        n,
        c,
        mu,
        ground,
        belt,
        ref,
        depth_smoothing,
        DEFAULT_SMOOTHING.eps_damping,
        slip_smoothing,
    )
    res = (wrench - meas) * wts
    return ca.Function("foot_frame", [D, y], [res, wrench], ["D", "y"], ["res", "wrench"])


def _frame_cost_derivatives(frame_fn: ca.Function) -> tuple[ca.Function, ca.Function]:
    """Per-frame exact gradient and Hessian in ``y`` of ``phi = 1/2 ||res||^2`` (two SX functions,
    so that Ipopt's gradient evaluations do not pay for the Hessian)."""
    D = ca.SX.sym("D", N_D)
    y = ca.SX.sym("y", N_Y)
    res = frame_fn(D, y)[0]
    phi = 0.5 * ca.sumsqr(res)
    H, g = ca.hessian(phi, y)
    return ca.Function("frame_grad", [D, y], [g]), ca.Function("frame_hess", [D, y], [H])


def _assemble_hessian(As: list[ca.DM], BDs: list[ca.MX], nx: int) -> ca.MX:
    """``sum_s A_s^T BD_s A_s`` assembled in time linear in the number of stances.

    Summing ``S`` global ``nx x nx`` matrices costs O(S * nnz). Instead, the variables are split
    into *shared* ones (used by several stances: contact parameters, sole corrections) and each
    stance's *own* ones (its pose correction); the Hessian has an arrow structure
    ``[[H_SS, H_S1, H_S2, ...], [H_1S, H_11, 0, ...], ...]`` whose small shared block is the only
    sum, and it is permuted back to the decision-vector order by one constant product.
    """
    cols = [np.unique(np.asarray(A.sparsity().get_col(), dtype=int)) for A in As]
    count = np.zeros(nx, dtype=int)
    for c in cols:
        count[c] += 1
    shared = np.flatnonzero(count >= 2)
    pos_shared = {v: i for i, v in enumerate(shared)}
    own = [c[count[c] == 1] for c in cols]
    unused = np.flatnonzero(count == 0)
    nS = shared.size
    HSS = ca.MX(nS, nS)
    HSO, HOO = [], []
    for A, BD, c, o in zip(As, BDs, cols, own, strict=True):
        sc = c[count[c] >= 2]
        E = ca.DM(nS, sc.size)
        for j, v in enumerate(sc):
            E[pos_shared[v], j] = 1.0
        AS, AO = A[:, sc.tolist()], A[:, o.tolist()]
        BA_S, BA_O = ca.mtimes(BD, AS), ca.mtimes(BD, AO)
        HSS = HSS + ca.mtimes(E, ca.mtimes(ca.mtimes(AS.T, BA_S), E.T))
        HSO.append(ca.mtimes(E, ca.mtimes(AS.T, BA_O)))
        HOO.append(ca.mtimes(AO.T, BA_O))
    sizes = [o.size for o in own]
    n_own = sum(sizes)
    rows = [ca.horzcat(HSS, *HSO, ca.MX(nS, unused.size))]
    before = 0
    for hso, hoo, n in zip(HSO, HOO, sizes, strict=True):
        rows.append(
            ca.horzcat(hso.T, ca.MX(n, before), hoo, ca.MX(n, n_own - before - n + unused.size))
        )
        before += n
    rows.append(ca.MX(unused.size, nx))
    Hp = ca.vertcat(*rows)
    order = np.concatenate([shared, *own, unused]).astype(int)
    Pm = ca.DM(ca.Sparsity.triplet(nx, nx, list(range(nx)), order.tolist()), 1.0)  # x_perm = Pm x
    return ca.mtimes(Pm.T, ca.mtimes(Hp, Pm))


class Builder:
    """Collects decision variables from the model components (two passes: declare, then use)."""

    def __init__(self, stances: list[StanceData]) -> None:
        self.stances = stances
        self._specs: list[dict] = []
        self._index: dict[tuple, slice] = {}
        self.x: ca.MX | None = None

    # --- declaration pass -------------------------------------------------------------------
    def _add(
        self,
        key: tuple,
        size: int,
        x0,
        lb,
        ub,
        kind: str,
        scale,
        log: bool,
        prior_weight: float = 0.0,
        prior_mean: float = 0.0,
    ) -> None:
        if key in self._index:
            raise ModelError(
                f"Variable {key} declared twice; two components claim the same parameter."
            )
        start = sum(s["size"] for s in self._specs)
        self._index[key] = slice(start, start + size)
        self._specs.append(
            dict(
                key=key,
                size=size,
                x0=np.broadcast_to(x0, size).astype(float),
                lb=np.broadcast_to(lb, size).astype(float),
                ub=np.broadcast_to(ub, size).astype(float),
                kind=kind,
                scale=scale,
                log=log,
                prior_weight=np.full(size, float(prior_weight)),
                prior_mean=np.full(size, float(prior_mean)),
            )
        )

    def parameter(
        self,
        key: tuple,
        value: float,
        lower: float,
        upper: float,
        log: bool = False,
        prior_sigma: float | None = None,
    ) -> None:
        """A physical parameter. ``log``: optimise log(value) (value > 0). ``prior_sigma``: optional
        Gaussian prior centred on ``value``, in the optimised units (log units when ``log``)."""
        w = 0.0 if prior_sigma is None else 1.0 / prior_sigma
        if log:
            z0 = np.log(value)
            self._add(
                key, 1, z0, np.log(max(lower, 1e-300)), np.log(upper), "param", 1.0, True, w, z0
            )
        else:
            self._add(key, 1, value, lower, upper, "param", 1.0, False, w, value)

    def prior_variable(self, key: tuple, size: int, sigma, bound) -> None:
        """A vector with Gaussian prior N(0, sigma^2), stored in units of sigma, bounded by +-bound.
        ``sigma`` and ``bound``: scalars, or arrays of length ``size`` (one per entry)."""
        sig = np.broadcast_to(np.asarray(sigma, float), size)
        b = np.broadcast_to(np.asarray(bound, float), size) / sig
        scale = float(sig[0]) if np.all(sig == sig[0]) else sig.copy()
        self._add(key, size, 0.0, -b, b, "prior", scale, False, 1.0, 0.0)

    def finalize(self) -> None:
        n = sum(s["size"] for s in self._specs)
        self.x = ca.MX.sym("x", n)

    # --- use pass ---------------------------------------------------------------------------
    def get(self, key: tuple, raw: bool = False):
        """Physical value of a declared variable (symbolic); ``raw``: log value for log variables."""
        if self.x is None:
            raise RuntimeError("Builder.get() before finalize()")
        sl = self._index[key]
        spec = next(s for s in self._specs if s["key"] == key)
        z = self.x[sl]
        if spec["log"]:
            return z if raw else ca.exp(z)
        return z * (spec["scale"] if np.isscalar(spec["scale"]) else ca.DM(spec["scale"]))

    def has(self, key: tuple) -> bool:
        return key in self._index

    @property
    def specs(self) -> list[dict]:
        return self._specs

    def vector(self, field_: str) -> np.ndarray:
        return np.concatenate([s[field_] for s in self._specs]) if self._specs else np.zeros(0)


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
    stance_points: list[ca.MX] = field(
        default_factory=list
    )  # per stance: (5*3, 1) corrected local points
    gradient: ca.MX | None = None  # exact gradient of the objective
    hessian: ca.MX | None = None  # exact Hessian of the objective (structured assembly)
    frame_blocks: list = field(default_factory=list)  # per stance (A, y0, D, T): y = A x + y0
    frame_jacobian: ca.Function | None = None  # (D, y) -> (res, d res / d y), one frame
    prior_weights: np.ndarray | None = None
    prior_means: np.ndarray | None = None

    def objective_function(self) -> ca.Function:
        return ca.Function("J", [self.x], [self.objective])

    def evaluate(self, x: np.ndarray) -> float:
        """Objective at a given decision vector (no solve)."""
        return float(self.objective_function()(x))

    def component(self, cls):
        return next((m for m in self.model if isinstance(m, cls)), None)

    def data_jacobian(self, x: np.ndarray):
        """Weighted data residuals ``r`` (n_data,) and their Jacobian in ``x`` (scipy CSR,
        n_data x nx) at ``x``, from the per-frame Jacobians (``J_t A_t``): no symbolic Jacobian
        of the whole graph is built. Rows are in the order of :attr:`residuals`."""
        import scipy.sparse as sp

        rs, Js = [], []
        for A, y0, D, T in self.frame_blocks:
            A_sp = A.sparse() if hasattr(A, "sparse") else sp.csc_matrix(np.asarray(A))
            Y = (A_sp @ x + np.asarray(y0).ravel()).reshape(T, N_Y).T
            res, jac = (np.asarray(a) for a in self.frame_jacobian.map(T)(D, Y))
            rs.append(res.T.ravel())
            blocks = jac.reshape(6, T, N_Y).transpose(1, 0, 2)  # (T, 6, N_Y)
            Js.append(sp.block_diag(list(blocks), format="csr") @ A_sp)
        return np.concatenate(rs), sp.vstack(Js, format="csr")


def build_estimation(
    stances: list[StanceData], model: tuple, weights: Weights | None = None
) -> EstimationProblem:
    """Build the NLP for ``stances`` under ``model`` (a tuple of components)."""
    from gc_ocp.estimation.components import BeltSpeed, ContactLaw, PoseCorrection, SoleCorrection

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
    belt = next((m for m in model if isinstance(m, BeltSpeed)), None)

    from gc_ocp.estimation.compiled import frame_functions

    frame_fn, grad_fn, hess_fn = frame_functions(law.depth_smoothing, law.slip_smoothing)
    residuals, outputs, points, blocks = [], [], [], []
    n_data = 0
    x = b.x
    for i, st in enumerate(stances):
        f = st.foot
        T = st.n
        par = law.values(b, st.side, log_k=True)
        loc = ca.MX(np.asarray(f.points_local, float).T)  # 3 x 5
        if sole is not None:
            off = sole.offsets(b, st.side)
            loc = loc + (ca.horzcat(*off) if not isinstance(off, np.ndarray) else ca.MX(off.T))
        points.append(ca.vec(loc))
        if pose is not None:
            dp, dth, ddp, ddth = pose.trajectories(b, i)
        else:
            dp = dth = ddp = ddth = ca.MX.zeros(3, T)
        dv = belt.correction(b, st.trial) if belt is not None else 0.0
        shared = ca.vertcat(ca.vec(loc), *par["k"], par["n"], par["c"], par["mu"], dv)
        Y = ca.vertcat(dp, dth, ddp, ddth, ca.repmat(shared, 1, T))  # N_Y x T, linear in x
        # Y = reshape(A x + y0): A is constant because every component maps x linearly
        A = ca.Function("A", [x], [ca.jacobian(ca.vec(Y), x)])(np.zeros(x.shape[0]))
        y0 = ca.Function("y0", [x], [ca.vec(Y)])(np.zeros(x.shape[0]))
        A = ca.DM(A)
        Yl = ca.reshape(ca.mtimes(A, x) + ca.DM(y0), N_Y, T)
        D = frame_data(st, weights)
        res, wrench = frame_fn.map(T)(D, Yl)
        blocks.append((A, ca.DM(y0), D, T))
        residuals.append(ca.vec(res))
        outputs.append(wrench)
        n_data += 6 * T
    pw, pm = b.vector("prior_weight"), b.vector("prior_mean")
    prior_idx = np.flatnonzero(pw > 0)
    prior_res = (
        pw[prior_idx] * (x[prior_idx.tolist()] - pm[prior_idx])
        if prior_idx.size
        else ca.MX.zeros(0)
    )
    r_all = ca.vertcat(*residuals, prior_res)
    # objective, gradient and exact Hessian assembled from per-frame SX derivatives:
    # J = sum_t phi(D_t, y_t) + 1/2 |W (x - m)|^2 = 1/2 |r_all|^2 with y = A x + y0, so
    # grad = sum A^T g_t + W^2 (x - m) and Hess = sum A^T blockdiag(H_t) A + W^2 (W: prior weights).
    J = 0.5 * ca.sumsqr(r_all)
    grad = ca.DM(pw**2) * (x - pm) if pw.size else ca.MX.zeros(x.shape[0])
    gs, hs = [], []
    for A, y0, D, T in blocks:
        Yl = ca.reshape(ca.mtimes(A, x) + y0, N_Y, T)
        gs.append(ca.mtimes(A.T, ca.vec(grad_fn.map(T)(D, Yl))))
        hs.append(ca.diagcat(*ca.horzsplit(hess_fn.map(T)(D, Yl), N_Y)))
    grad = grad + ca.sum2(ca.horzcat(*gs)) if gs else grad
    # the prior term as a *sparse* diagonal (a DM built from a dense array would make H dense)
    hess = _assemble_hessian([blk[0] for blk in blocks], hs, x.shape[0]) + ca.DM(
        ca.Sparsity.diag(x.shape[0]), pw**2
    )
    Dsym, ysym = ca.SX.sym("D", N_D), ca.SX.sym("y", N_Y)
    res_sym = frame_fn(Dsym, ysym)[0]
    jac_fn = ca.Function("frame_jac", [Dsym, ysym], [res_sym, ca.jacobian(res_sym, ysym)])
    return EstimationProblem(
        stances=stances,
        model=model,
        weights=weights,
        builder=b,
        x=b.x,
        objective=J,
        residuals=r_all,
        n_data=n_data,
        x0=b.vector("x0"),
        lbx=b.vector("lb"),
        ubx=b.vector("ub"),
        stance_outputs=outputs,
        stance_points=points,
        gradient=grad,
        hessian=hess,
        frame_blocks=blocks,
        frame_jacobian=jac_fn,
        prior_weights=pw,
        prior_means=pm,
    )
