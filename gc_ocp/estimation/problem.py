"""Build the joint kinematics-contact estimation NLP (CasADi), separately from solving it.

``build_estimation(stances, model, weights)`` returns an :class:`EstimationProblem` holding the
CasADi NLP (objective, decision vector, bounds, initial guess, exact gradient and Hessian) and
what decodes a solution. Tests can evaluate the objective at a fixed vector without running Ipopt.

The builder knows no component by type: each component of ``model`` declares its variables and
its per-frame slots (:mod:`gc_ocp.estimation.components.base`); the builder composes the per-frame
function from them (:mod:`gc_ocp.estimation.frame`), writes every stance's slots as ``Y = A x +
y0`` (constant ``A``: every slot is linear in x) and assembles the objective, gradient and
arrow-structured Hessian from the per-frame derivatives.

Objective (a MAP / weighted least-squares problem)::

    J(z) = 1/2 sum_frames sum_channels ((wrench_model - wrench_measured) / sigma_channel)^2
         + 1/2 ||z_prior||^2

Channel sigmas (``Weights``): forces ``force_sigma`` x BW; torques ``force_sigma`` x BW x
``torque_length``. With ``torque_length = 0.25 m`` a 10 mm COP error at 1 BW costs as much as a
4 % BW force error, so the COP counts; under the seed's BW x height normalisation (1.7 m) a 40 mm
COP error at 1 BW weighs as little as a 2.4 % BW force error.
"""

from __future__ import annotations

import functools
import hashlib
import numbers
import threading
from collections import OrderedDict
from dataclasses import dataclass, field, replace

import casadi as ca
import numpy as np
import scipy.sparse as sp

from gc_ocp.errors import InputError, ModelError
from gc_ocp.estimation.components.base import require_model
from gc_ocp.estimation.frame import BASE_DATA, FrameModel, frame_model
from gc_ocp.estimation.measurement import stance_residuals
from gc_ocp.estimation.variables import Variables
from gc_ocp.stance import StanceData, require_stance_list
from gc_ocp.values import named_fields, require_given


@named_fields
@dataclass(frozen=True)
class Weights:
    """Residual scaling. force_sigma: force error scale as a fraction of BW [-] (0.02: 2 % BW);
    torque_length: torque error scale = force scale x this length [m]. Given to
    :func:`gc_ocp.fit` (``weights=``), :func:`build_estimation` or the diagnosis:

    >>> import gc_ocp
    >>> gc_ocp.Weights(force_sigma=0.01)      # 1 % BW: the plates weigh more against the priors
    Weights(force_sigma=0.01, torque_length=0.25)
    >>> gc_ocp.Weights(force_sigma=2)         # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    gc_ocp.errors.InputError: Weights(force_sigma=2): give the force error scale as a fraction of body weight, ...
    """

    force_sigma: float = 0.02
    torque_length: float = 0.25

    def __post_init__(self) -> None:
        # a percentage (force_sigma=2 for 2 % BW) weighted the plates 100 times too lightly
        # against the priors, silently
        f, m = self.force_sigma, self.torque_length
        if not (isinstance(f, numbers.Real) and 0 < f < 1):
            raise InputError(
                f"Weights(force_sigma={f!r}): give the force error scale as a fraction of body "
                "weight, between 0 and 1 (0.02 for 2 % BW)"
            )
        if not (isinstance(m, numbers.Real) and 0 < m < 2):
            raise InputError(
                f"Weights(torque_length={m!r}): give the torque error scale's length in m, "
                "between 0 and 2 (default 0.25, so that the COP counts)"
            )

    def inverse_sigmas(self, body_weight: float) -> np.ndarray:
        sf = self.force_sigma * body_weight
        return 1.0 / np.array(
            [sf, sf, sf, sf * self.torque_length, sf * self.torque_length, sf * self.torque_length]
        )

    def residuals(self, fit: dict) -> np.ndarray:
        """``(T, 6)`` weighted residuals (model - measured, in units of the error scale, censored
        samples as :mod:`gc_ocp.estimation.measurement` says) of a stance fit
        (``EstimationResult.stance_fits`` item)."""
        return stance_residuals(
            fit["model"],
            fit["measured"],
            self.inverse_sigmas(fit["body_weight"]),
            fit.get("censor_below", 0.0),
        )


def frame_data(st: StanceData, weights: Weights, fm: FrameModel, model: tuple) -> np.ndarray:
    """``(n_data, T)`` numeric per-frame inputs of one stance, in the order of ``fm.data``."""
    f = st.foot
    T = st.n
    cols = {
        "hindfoot_R": f.hindfoot_pose[:, :3, :3].transpose(0, 2, 1).reshape(T, 9),  # column-major R
        "hindfoot_o": f.hindfoot_pose[:, :3, 3],
        "hindfoot_v": f.hindfoot_twist[:, :3],
        "hindfoot_w": f.hindfoot_twist[:, 3:],
        "toes_R": f.toes_pose[:, :3, :3].transpose(0, 2, 1).reshape(T, 9),
        "toes_o": f.toes_pose[:, :3, 3],
        "toes_v": f.toes_twist[:, :3],
        "toes_w": f.toes_twist[:, 3:],
        "measured": st.measured,
        "inv_sigma": weights.inverse_sigmas(st.body_weight),
        "ground_height": st.ground_height,
        "belt_velocity": st.belt_velocity,
        "reference": st.reference_point,
        "censor_below": st.censor_below,
    }
    for c in model:
        cols.update(c.data(st))
    out = np.empty((fm.data.size, T))
    for name, (start, size) in fm.data.index.items():
        out[start : start + size] = np.broadcast_to(
            np.asarray(cols[name], float).reshape(-1, size), (T, size)
        ).T
    return out


def sparse_dm(M: sp.spmatrix | np.ndarray) -> ca.DM:
    """``M`` as a sparse CasADi DM, through its compressed columns (a dense array converted by
    ``ca.DM`` then ``sparsify`` is about 7 times slower: 7 ms for a pose spline's 840 x 80
    rows, a noticeable part of building a solver)."""
    S = sp.csc_matrix(M, dtype=float, copy=True)  # a copy: the caller's matrix is not touched
    S.sum_duplicates()  # also sorts the indices, as CasADi's compressed columns need
    S.eliminate_zeros()
    return ca.DM(
        ca.Sparsity(S.shape[0], S.shape[1], S.indptr.tolist(), S.indices.tolist()),
        S.data,
    )


class SlotMap:
    """A stance's linear map of the decision vector to its per-frame inputs, ``Y = reshape(A x +
    y0, n_y, T)``, and what is derived from it once and shared by every problem with the same
    map (:data:`SLOT_MAP_CACHE`: the calibrated null builds the same models on every draw's
    data): ``A`` as SciPy CSR and the constant and per-frame parts of the Hessian's product
    (:func:`_stance_hessian`)."""

    def __init__(self, A: ca.DM | None, y0: ca.DM, A_csr: sp.csr_matrix | None = None):
        self.y0 = y0
        if A is not None:
            self.__dict__["A"] = A
        if A_csr is not None:
            self.__dict__["A_csr"] = A_csr

    @functools.cached_property
    def A(self) -> ca.DM:
        """``A`` as a sparse CasADi DM (from :attr:`A_csr` when made from it)."""
        return sparse_dm(self.A_csr)

    @functools.cached_property
    def A_csr(self) -> sp.csr_matrix:
        """``A`` as a scipy CSR matrix (converted once: the conversion costs more than the
        product it serves)."""
        return self.A.sparse().tocsr()

    def scaled(self, s: np.ndarray) -> SlotMap:
        """The map of ``x`` whose column ``j`` is this map's column times ``s[j]``."""
        return SlotMap(None, self.y0, (self.A_csr @ sp.diags(s)).tocsr())

    @functools.cached_property
    def y0_array(self) -> np.ndarray:
        return np.asarray(self.y0, float).ravel()

    def hessian_parts(self, ny: int, T: int) -> tuple:
        """``(cols, c, p, Ac, Ap)`` of :func:`_stance_hessian` (cached per ``(ny, T)``)."""
        key = (ny, T)
        cache = self.__dict__.setdefault("_hessian_parts", {})
        if key not in cache:
            A = self.A_csr
            cols = np.unique(A.indices)
            Ad = A[:, cols].toarray().reshape(T, ny, cols.size)
            const = np.all(Ad == Ad[:1], axis=(0, 2))
            c, p = np.flatnonzero(const).tolist(), np.flatnonzero(~const).tolist()
            Ac = sparse_dm(Ad[0][c])
            Ap = sparse_dm(Ad[:, p, :].reshape(T * len(p), cols.size)) if p else None
            cache[key] = (cols, c, p, Ac, Ap)
        return cache[key]


@dataclass
class StanceBlock:
    """One stance in the NLP: its per-frame inputs ``Y = reshape(A x + y0, n_y, T)``
    (:class:`SlotMap`) and data ``D`` (``n_d x T``), and the composed per-frame functions they
    feed."""

    map: SlotMap
    D: np.ndarray
    T: int
    fm: FrameModel

    def Y(self, x: np.ndarray) -> np.ndarray:
        """Numeric ``(n_y, T)`` per-frame inputs at ``x``."""
        y = self.map.A_csr @ np.asarray(x, float) + self.map.y0_array
        return y.reshape(self.T, self.fm.slots.size).T


def _stance_hessian(b: StanceBlock, Yl: ca.MX) -> tuple[np.ndarray, ca.MX]:
    """``(cols, H)``: one stance's ``sum_t A_t^T H_t A_t`` on the decision variables it uses
    (``cols``, ascending), ``H`` a dense ``|cols| x |cols|`` MX. ``A_t`` (``n_y x nx``) are the
    stance's rows of ``A`` for frame t and ``H_t`` the per-frame Hessian in the slots.

    Most slots are the same linear map of x on every frame (contact parameters, sole points:
    their rows of ``A_t`` do not depend on t); only a few change (a pose spline). Splitting the
    slots into those constant ones ``c`` and the per-frame ones ``p``::

        sum_t A_t^T H_t A_t = A_c^T (sum_t H_t,cc) A_c + A_c^T X + X^T A_c + sum_t A_pt^T H_t,pp A_pt
        with X = sum_t H_t,cp A_pt

    the frame sum of the ``cc`` block is taken inside the mapped per-frame function, and no
    ``(n_y T)^2`` block-diagonal product remains (the 16-unit sole has n_y = 80 slots of which
    12 are per frame). Exact: the same sum, grouped differently."""
    ny, T = b.fm.slots.size, b.T
    cols, c, p, Ac, Ap = b.map.hessian_parts(ny, T)
    nd = b.D.shape[0]
    Dv, yv = ca.MX.sym("D", nd), ca.MX.sym("y", ny)
    Hf = b.fm.hess(Dv, yv)
    if not p:
        parts = ca.Function("hess_cc", [Dv, yv], [Hf[c, c]])
        Scc = parts.map(T, [False, False], [True], {})(b.D, Yl)
        return cols, ca.mtimes(Ac.T, ca.mtimes(Scc, Ac))
    parts = ca.Function("hess_parts", [Dv, yv], [Hf[c, c], Hf[c, p], Hf[p, p]])
    Scc, Hcp, Hpp = parts.map(T, [False, False], [True, False, False], {})(b.D, Yl)
    X = ca.mtimes(Hcp, Ap)  # Ap: rows (t, slot)
    cross = ca.mtimes(Ac.T, X)
    BDpp = ca.diagcat(*ca.horzsplit(Hpp, len(p)))
    H = ca.mtimes(Ac.T, ca.mtimes(Scc, Ac)) + cross + cross.T + ca.mtimes(Ap.T, ca.mtimes(BDpp, Ap))
    return cols, H


def _assemble_hessian(parts: list[tuple[np.ndarray, ca.MX]], nx: int) -> ca.MX:
    """``sum_s H_s`` of the stances' Hessians ``(cols_s, H_s)`` (:func:`_stance_hessian`),
    assembled in time linear in the number of stances.

    Summing ``S`` global ``nx x nx`` matrices costs O(S * nnz). Instead, the variables are split
    into *shared* ones (used by several stances: contact parameters, sole corrections) and each
    stance's *own* ones (its pose correction); the Hessian has an arrow structure
    ``[[H_SS, H_S1, H_S2, ...], [H_1S, H_11, 0, ...], ...]`` whose small shared block is the only
    sum, and it is permuted back to the decision-vector order by one constant product.
    """
    cols = [c for c, _ in parts]
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
    for c, H in parts:  # own variables in column order, as in ``own``
        is_shared = count[c] >= 2
        ks, ko = np.flatnonzero(is_shared).tolist(), np.flatnonzero(~is_shared).tolist()
        rows_e = [pos_shared[v] for v in c[is_shared]]
        E = ca.DM(ca.Sparsity.triplet(nS, len(ks), rows_e, list(range(len(ks)))), 1.0)
        HSS = HSS + ca.mtimes(E, ca.mtimes(H[ks, ks], E.T))
        HSO.append(ca.mtimes(E, H[ks, ko]))
        HOO.append(H[ko, ko])
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


def _stance_slots(
    model: tuple, variables: Variables, i: int, st: StanceData, fm: FrameModel
) -> ca.MX:
    """The stance's slots ``(n_y, T)``: the sum of every contribution to each named slot."""
    T = st.n
    contrib: dict[str, list] = {
        "points_local": [ca.MX(np.asarray(st.foot.points_local, float).ravel())]
    }
    for c in model:
        for name, expr in c.slots(variables, i, st).items():
            if name not in fm.slots:
                raise ModelError(
                    f'{type(c).__name__} gives slot "{name}" it did not size in slot_sizes()'
                )
            contrib.setdefault(name, []).append(expr)
    rows = []
    for name, (_, size) in fm.slots.index.items():
        const, per_frame = ca.MX.zeros(size, 1), None
        for e in contrib.get(name, []):
            if e.shape == (size, 1):
                const = const + e
            elif e.shape == (size, T):
                per_frame = e if per_frame is None else per_frame + e
            else:
                raise ModelError(
                    f'slot "{name}" must be ({size}, 1) or ({size}, {T}), but got {e.shape}'
                )
        total = ca.repmat(const, 1, T)
        rows.append(total if per_frame is None else total + per_frame)
    return ca.vertcat(*rows)


@dataclass
class EstimationProblem:
    """A built (not yet solved) estimation NLP and what is needed to decode its solution.

    model: the components; variables: the registry (``variables.specs`` is plain data);
    x: the decision vector (MX); blocks: one :class:`StanceBlock` per stance; n_data: number of
    data residuals. The symbolic ``objective``, ``gradient``, ``hessian`` (``J(x)`` and its
    exact derivatives) and ``residuals`` (every weighted residual, data then priors) are
    assembled from the blocks when first asked for (a solver needs them; a problem that is only
    evaluated or linearised through the compiled per-frame functions, e.g. the diagnosis's
    null, does not pay for their assembly).
    """

    stances: list[StanceData]
    model: tuple
    weights: Weights
    variables: Variables
    x: ca.MX
    n_data: int
    x0: np.ndarray
    lbx: np.ndarray
    ubx: np.ndarray
    blocks: list[StanceBlock] = field(default_factory=list)
    prior_weights: np.ndarray | None = None
    prior_means: np.ndarray | None = None
    column_scale: ca.MX | None = None
    """A symbolic parameter ``s`` (nx): the slots read ``s * x`` where they read ``x`` (the prior
    reads ``x``). Set by :meth:`parametric` only."""
    anchor: EstimationProblem | None = field(default=None, repr=False)
    anchor_scale: np.ndarray | None = None
    """A problem made by :meth:`rescaled` is its ``anchor``'s parametric problem at ``s =
    anchor_scale``: the solver solves it as that (one solver for every rescaling)."""
    solvers: dict = field(default_factory=dict, repr=False, compare=False)
    """Its parametric solvers, by their settings (``gc_ocp.estimation.solve``): every problem
    is solved as its anchor's (or its own) :meth:`parametric` problem."""
    inputs: list = field(default_factory=list, repr=False, compare=False)
    """The stances it was built from (before the components prepared them)."""

    @functools.cached_property
    def _x_slots(self) -> ca.MX:
        return self.x if self.column_scale is None else self.x * self.column_scale

    def _stance_inputs(self, b: StanceBlock) -> ca.MX:
        return ca.reshape(ca.mtimes(b.map.A, self._x_slots) + b.map.y0, b.fm.slots.size, b.T)

    @functools.cached_property
    def residuals(self) -> ca.MX:
        """Every weighted residual (MX): the data's, stance by stance, then the priors'."""
        x, pw, pm = self.x, self.prior_weights, self.prior_means
        data = [ca.vec(b.fm.frame.map(b.T)(b.D, self._stance_inputs(b))[0]) for b in self.blocks]
        idx = np.flatnonzero(pw > 0)
        prior = pw[idx] * (x[idx.tolist()] - pm[idx]) if idx.size else ca.MX.zeros(0)
        return ca.vertcat(*data, prior)

    @functools.cached_property
    def objective(self) -> ca.MX:
        """``J = 1/2 |residuals|^2`` (MX)."""
        return 0.5 * ca.sumsqr(self.residuals)

    @functools.cached_property
    def gradient(self) -> ca.MX:
        """``grad J = sum_t A_t^T g_t + W^2 (x - m)`` (MX) from the per-frame gradients
        (``y = A x + y0``; W: prior weights)."""
        x, pw, pm = self.x, self.prior_weights, self.prior_means
        grad = ca.DM(pw**2) * (x - pm) if pw.size else ca.MX.zeros(self.x.numel())
        gs = [
            ca.mtimes(b.map.A.T, ca.vec(b.fm.grad.map(b.T)(b.D, self._stance_inputs(b))))
            for b in self.blocks
        ]
        if not gs:
            return grad
        data = ca.sum2(ca.horzcat(*gs))
        return grad + (data if self.column_scale is None else data * self.column_scale)

    @functools.cached_property
    def hessian(self) -> ca.MX:
        """The exact ``Hess J = sum_t A_t^T H_t A_t + W^2`` (MX) from the per-frame SX
        Hessians (:func:`_stance_hessian`), the prior term as a *sparse* diagonal (a DM built
        from a dense array would make it dense)."""
        nx, pw = self.x.numel(), self.prior_weights
        hs = [_stance_hessian(b, self._stance_inputs(b)) for b in self.blocks]
        data = _assemble_hessian(hs, nx)
        if self.column_scale is not None:  # diag(s) H diag(s), sparse
            S = ca.diag(self.column_scale)
            data = ca.mtimes(S, ca.mtimes(data, S))
        return data + ca.DM(ca.Sparsity.diag(nx), pw**2)

    def parametric(self) -> EstimationProblem:
        """This problem with its slots reading ``s * x`` (:attr:`column_scale`, a parameter):
        at ``s`` = 1 the same problem, to the bit."""
        return replace(self, column_scale=ca.MX.sym("s", self.x.numel()), solvers={})

    def rescaled(
        self, stances: list[StanceData], model: tuple, weights: Weights | None = None
    ) -> EstimationProblem | None:
        """The problem of ``model`` on ``stances`` (what :func:`build_estimation` would build)
        when it differs from this one's only in prior widths (the components'
        :attr:`~gc_ocp.estimation.components.base.Component.width_fields`; the same stance
        objects and weights), else None.

        A prior variable is stored in units of its width, so a width changed from ``w`` to
        ``w'`` scales its columns of every stance's map by ``s = w' / w``: the problem is this
        one's :meth:`parametric` problem at that ``s``, with the new bounds, and is solved by
        the same solver (:attr:`anchor`; made at the first solve of either). Its maps are this
        one's scaled (no symbolic Jacobian), so it also costs far less to make than a build."""
        if self.anchor is not None:
            return self.anchor.rescaled(stances, model, weights)
        if (
            self.column_scale is not None
            or len(stances) != len(self.inputs)
            or any(a is not b for a, b in zip(stances, self.inputs, strict=True))
            or (weights or Weights()) != self.weights
        ):
            return None
        new_model, _, variables = declare(stances, model)
        if len(new_model) != len(self.model) or not all(
            _same_but_widths(a, b) for a, b in zip(self.model, new_model, strict=True)
        ):
            return None
        s = _column_scale(self.variables.specs, variables.specs)
        if s is None:
            return None
        same = bool(np.all(s == 1.0))
        blocks = [
            StanceBlock(b.map if same else b.map.scaled(s), b.D, b.T, b.fm) for b in self.blocks
        ]
        variables.finalize()
        return _assembled(
            self.stances, new_model, self.weights, variables, blocks, self.inputs, self, s
        )

    def objective_function(self) -> ca.Function:
        return ca.Function("J", [self.x], [self.objective])

    def evaluate(self, x: np.ndarray) -> float:
        """Objective at a given decision vector (no solve)."""
        return float(self.objective_function()(x))

    def costs(self, x: np.ndarray) -> tuple[float, float]:
        """``(data cost, prior cost)`` at ``x``: the two halves of the objective."""
        x = np.asarray(x, float)
        data = 0.5 * float(np.sum(self.data_residuals(x) ** 2))
        prior = 0.5 * float(np.sum(self.prior_residuals(x) ** 2))
        return data, prior

    def prior_residuals(self, x: np.ndarray) -> np.ndarray:
        """Prior residuals ``W (x - m)`` (nx,) at ``x`` (0 for a variable without prior): with
        :meth:`data_residuals`, the residuals whose half squared norm is the objective."""
        return self.prior_weights * (np.asarray(x, float) - self.prior_means)

    def stance_wrenches(self, x: np.ndarray) -> list[np.ndarray]:
        """Model wrench ``(T, 6)`` of every stance at ``x`` (``lab``, about its reference point)."""
        return [np.asarray(b.fm.frame.map(b.T)(b.D, b.Y(x))[1]).T for b in self.blocks]

    def stance_measured(self, x: np.ndarray) -> list[np.ndarray]:
        """Measured wrench ``(T, 6)`` each stance's model is compared with at ``x`` (the stance's
        ``measured`` unless a component edits it, e.g. a clock offset resamples the plate)."""
        return [np.asarray(b.fm.frame.map(b.T)(b.D, b.Y(x))[2]).T for b in self.blocks]

    def stance_columns(self) -> list[np.ndarray]:
        """Per stance, the columns of ``x`` its stance-scope components own (the per-stance
        nuisance a held-out stance re-estimates, e.g. its pose correction)."""
        return self._scope_columns("stance", lambda st: st.label)

    def trial_columns(self) -> list[np.ndarray]:
        """Per stance, the columns of ``x`` its trial's trial-scope components own (a clock
        offset, a belt speed: what a held-out stance of a trial never trained on re-estimates)."""
        return self._scope_columns("trial", lambda st: st.trial)

    def _scope_columns(self, scope: str, key_of) -> list[np.ndarray]:
        """Per stance, the columns of the variables of ``scope``-scope components keyed by
        ``key_of(stance)`` (their key's second entry)."""
        names = {c.name for c in self.model if c.scope == scope}
        out = []
        for st in self.stances:
            cols = [
                np.arange(s.start, s.start + s.size)
                for s in self.variables.specs
                if s.key[0] in names and len(s.key) > 1 and s.key[1] == key_of(st)
            ]
            out.append(np.concatenate(cols) if cols else np.zeros(0, int))
        return out

    def slot_values(self, x: np.ndarray, i: int, name: str) -> np.ndarray:
        """``(T, size)`` values of slot ``name`` on stance ``i`` at ``x``."""
        b = self.blocks[i]
        start, size = b.fm.slots.index[name]
        return b.Y(x)[start : start + size].T

    def slot_rows(self, i: int, name: str) -> np.ndarray:
        """``(size, nx)`` derivative of slot ``name`` in x on the first frame of stance ``i``."""
        b = self.blocks[i]
        start, size = b.fm.slots.index[name]
        ny = b.fm.slots.size
        rows = [start + j for j in range(size)]  # frame 0: rows 0..ny-1 of A (frame-major)
        assert max(rows) < ny
        return b.map.A_csr[rows, :].toarray()

    def data_jacobian(self, x: np.ndarray):
        """Weighted data residuals ``r`` (n_data,) and their Jacobian in ``x`` (scipy CSR,
        n_data x nx) at ``x``, from the per-frame Jacobians (``J_t A_t``): no symbolic Jacobian
        of the whole graph is built. Rows are in the order of :attr:`residuals`."""
        rs, Js = [], []
        for b in self.blocks:
            ny = b.fm.slots.size
            res, jac = (np.asarray(a) for a in b.fm.jac.map(b.T)(b.D, b.Y(x)))
            rs.append(res.T.ravel())
            blocks = jac.reshape(6, b.T, ny).transpose(1, 0, 2)  # (T, 6, n_y)
            Js.append(_block_diagonal(blocks) @ b.map.A_csr)
        return np.concatenate(rs), sp.vstack(Js, format="csr")

    def data_residuals(self, x: np.ndarray) -> np.ndarray:
        """Weighted data residuals ``r`` (n_data,) at ``x``, as :meth:`data_jacobian` gives them,
        without the Jacobian."""
        return np.concatenate(
            [np.asarray(b.fm.frame.map(b.T)(b.D, b.Y(x))[0]).T.ravel() for b in self.blocks]
        )


def _block_diagonal(blocks: np.ndarray) -> sp.csr_matrix:
    """The block-diagonal CSR matrix of ``blocks`` (T, m, n), its index arrays written directly
    (``scipy.sparse.block_diag`` of T small blocks costs about 20 times more)."""
    T, m, n = blocks.shape
    cols = np.arange(T)[:, None, None] * n + np.arange(n)[None, None, :]
    indices = np.broadcast_to(cols, (T, m, n)).ravel()
    return sp.csr_matrix(
        (blocks.ravel(), indices, np.arange(0, T * m * n + 1, n)), shape=(T * m, T * n)
    )


def _same_but_widths(a, b) -> bool:
    """Components ``a`` and ``b`` are the same but for their prior widths."""
    if type(a) is not type(b):
        return False
    try:
        return bool(a == replace(b, **{f: getattr(a, f) for f in a.width_fields}))
    except (TypeError, ValueError):  # a field without a plain equality (an array): not known
        return False


def _column_scale(old: list, new: list) -> np.ndarray | None:
    """``s`` with ``new``'s prior variables' widths over ``old``'s per column (1 elsewhere),
    when the two layouts are the same but for those widths (and bounds); else None."""
    if len(old) != len(new):
        return None
    s = np.ones(sum(o.size for o in old))
    for o, n in zip(old, new, strict=True):
        if (o.key, o.start, o.size, o.kind, o.log) != (n.key, n.start, n.size, n.kind, n.log):
            return None
        if not (
            np.array_equal(o.prior_weight, n.prior_weight)
            and np.array_equal(o.prior_mean, n.prior_mean)
            and np.array_equal(o.x0, n.x0)
        ):
            return None
        if o.kind == "prior" and not o.log:
            s[o.slice] = n.scale / o.scale
        elif not np.array_equal(o.scale, n.scale):
            return None
    return s


def _check_stances(stances: list[StanceData]) -> None:
    if not stances:
        raise InputError("No stances to fit: the trial has no usable stance (see `gc-ocp info`).")
    for st in stances:
        if not (np.isfinite(st.body_weight) and st.body_weight > 0):
            raise InputError(
                f"Stance {st.label}: body weight {st.body_weight} N is not usable; give the mass (--mass KG)."
            )
        if not (np.isfinite(st.height) and st.height > 0):
            raise InputError(
                f"Stance {st.label}: subject height unknown; pass height=... (CLI: --height M) so that "
                "torques can be reported in % BW x height."
            )


def configured(model: tuple) -> tuple:
    """``model`` after each component adjusted the others, in order
    (:meth:`Component.configure`: e.g. a stiffness exponent fixes the law's own exponent)."""
    model = tuple(model)
    for comp in tuple(model):
        model = tuple(comp.configure(model))
    return model


def declare(stances: list[StanceData], model: tuple) -> tuple[tuple, list, Variables]:
    """``(model, stances, variables)``: the model after every component adjusted the others
    (:meth:`Component.configure`), the stances as the components prepare them, and the
    variables they declare (not finalised): the first half of :func:`build_estimation`, cheap
    (no CasADi graph), e.g. for the prior a model has on some stances."""
    model = configured(model)
    stances = list(stances)
    for comp in model:
        stances = list(comp.prepare(stances))
    names = [c.name for c in model]
    if len(set(names)) != len(names):
        raise ModelError(f"Two components of the model share a name: {names}")
    variables = Variables()
    for comp in model:
        comp.declare(variables, stances)
    return model, stances, variables


SLOT_MAP_CACHE = 128
"""Stances' linear maps ``Y = A x + y0`` (:class:`SlotMap`) kept in memory (per process), keyed
by the slots' expression itself (its serialised form, every constant to the bit: the components'
slots of the stance under the problem's variables), so a map is reused only when the expression
is the same, whatever a component's slots read (an equal map built by another expression is
computed again). The calibrated null builds the parent and every candidate
again on each mismatch draw's data (:mod:`gc_ocp.diagnosis.draws`): the plate's data and the
walked motion differ, but most stances' slots do not read them (on six BTS stances 5 of 6 per
model hit, all 6 of the parent's where the stance carries no marker-noise part; the denser
sole's and the toe hinge's slots read the foot's kinematics and miss). A hit saves the
symbolic Jacobian (13-40 ms a stance) and the conversions the Hessian's parts need; the key
costs 1-5 ms a stance, and the slots' expression, which the key needs, is built on a hit too
(about 4 ms a stance). Until 2026-11-29 the key was the model and every stance's fields except the plate's:
the draws walk their own motion (the markers' low-pass of the draw), so it never hit there."""

_SLOT_MAPS: OrderedDict[bytes, SlotMap] = OrderedDict()
_SLOT_MAPS_LOCK = threading.Lock()  # builds may run in threads (an executor of threads)


def _slot_map(x: ca.MX, Y: ca.MX) -> SlotMap:
    """The :class:`SlotMap` of the slots ``Y`` (linear in ``x``), from the cache
    (:data:`SLOT_MAP_CACHE`) or computed."""
    f = ca.Function("Y", [x], [ca.vec(Y)])
    key = hashlib.blake2b(f.serialize().encode(), digest_size=20).digest()
    with _SLOT_MAPS_LOCK:
        hit = _SLOT_MAPS.get(key)
        if hit is not None:
            _SLOT_MAPS.move_to_end(key)
            return hit
    zero = np.zeros(x.numel())
    A = ca.DM(ca.Function("A", [x], [ca.jacobian(ca.vec(Y), x)])(zero))
    smap = SlotMap(A, ca.DM(f(zero)))
    with _SLOT_MAPS_LOCK:
        _SLOT_MAPS[key] = smap
        while len(_SLOT_MAPS) > SLOT_MAP_CACHE:
            _SLOT_MAPS.popitem(last=False)
    return smap


def build_estimation(
    stances: list[StanceData],
    model: tuple,
    weights: Weights | None = None,
    compile: bool = True,
    like: EstimationProblem | None = None,
) -> EstimationProblem:
    """Build the NLP for ``stances`` under ``model`` (a tuple of components). ``compile=False``:
    the per-frame derivatives are not compiled to C (:func:`~gc_ocp.estimation.frame.frame_model`;
    for a problem that is evaluated rather than solved, e.g. a simulation). ``like``: a problem
    this one may differ from only in prior widths (a continuation's stage, a widths' round): it
    is then that problem rescaled (:meth:`EstimationProblem.rescaled`), which shares its solver
    and costs a fraction of a build.

    ``stances``: a list of :class:`~gc_ocp.stance.StanceData` (:func:`gc_ocp.trial_stances`);
    ``weights``: the residuals' scales (default :class:`Weights`). Returns the problem for
    :func:`~gc_ocp.estimation.solve`.

    >>> import gc_ocp
    >>> trial = gc_ocp.load_trial(); kin = gc_ocp.compute_kinematics(trial)
    >>> problem = gc_ocp.build_estimation(gc_ocp.trial_stances(trial, kin), gc_ocp.seed_model())
    >>> len(problem.blocks), problem.x0.size  # one block per stance; k of 5 units per foot
    (3, 10)
    """
    stances = require_stance_list(stances, "build_estimation")
    require_model(model, "model")
    if model is None:
        raise InputError("build_estimation needs a model: e.g. gc_ocp.full_model().")
    require_given(weights, Weights, "weights")
    if like is not None:
        same = like.rescaled(stances, model, weights)
        if same is not None:
            return same
    _check_stances(stances)
    weights = weights or Weights()
    inputs = stances
    model, stances, variables = declare(stances, model)
    x = variables.finalize()
    models: dict = {}
    blocks: list[StanceBlock] = []
    for i, st in enumerate(stances):
        layout = st.layout
        if layout not in models:
            slot_entries = [("points_local", 3 * layout.n)]
            data_entries = list(BASE_DATA)
            for c in model:
                slot_entries += list(c.slot_sizes(layout).items())
                data_entries += list(c.data_sizes(layout).items())
            models[layout] = frame_model(layout, model, data_entries, slot_entries, compile)
        fm = models[layout]
        # Y = reshape(A x + y0): A is constant because every component maps x linearly
        smap = _slot_map(x, _stance_slots(model, variables, i, st, fm))
        blocks.append(StanceBlock(smap, frame_data(st, weights, fm, model), st.n, fm))
    return _assembled(stances, model, weights, variables, blocks, inputs)


def _assembled(
    stances, model, weights, variables, blocks, inputs, anchor=None, anchor_scale=None
) -> EstimationProblem:
    """The problem of the finalised ``variables`` and the stances' ``blocks`` (built from
    ``inputs``; ``anchor``, ``anchor_scale``: :meth:`EstimationProblem.rescaled`'s)."""
    return EstimationProblem(
        stances=list(stances),
        model=model,
        weights=weights,
        variables=variables,
        x=variables.x,
        n_data=sum(6 * b.T for b in blocks),
        x0=variables.vector("x0"),
        lbx=variables.vector("lb"),
        ubx=variables.vector("ub"),
        blocks=blocks,
        prior_weights=variables.vector("prior_weight"),
        prior_means=variables.vector("prior_mean"),
        anchor=anchor,
        anchor_scale=anchor_scale,
        inputs=list(inputs),
    )


__all__ = [
    "EstimationProblem",
    "SlotMap",
    "StanceBlock",
    "Weights",
    "build_estimation",
    "declare",
    "frame_data",
    "sparse_dm",
]
