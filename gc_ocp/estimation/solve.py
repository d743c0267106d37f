"""Solve an :class:`EstimationProblem` with Ipopt and decode the result."""

from __future__ import annotations

import functools
import math
import numbers
import time as _time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from gc_ocp import signals
from gc_ocp.errors import InputError, SolveError
from gc_ocp.estimation.components.base import DecodeContext
from gc_ocp.estimation.components.contact import ContactLaw
from gc_ocp.estimation.flags import fit_flags, variable_flags
from gc_ocp.estimation.problem import EstimationProblem, Weights
from gc_ocp.estimation.result import EstimationResult, fit_quality
from gc_ocp.values import is_count, named_fields, require, require_given

HESSIANS = ("exact", "gauss-newton")
"""The Hessians :func:`make_solver` gives Ipopt (:class:`IpoptOptions`' ``hessian``)."""

LINEAR_SOLVERS = ("mumps", "spral", "ma27", "ma57", "ma77", "ma86", "ma97", "pardiso")
"""Ipopt's ``linear_solver`` settings (its option documentation, Ipopt 3.14; ``custom`` needs a
solver object CasADi cannot pass). MUMPS and SPRAL are built into CasADi's Ipopt; HSL's MA27-MA97
and Pardiso are loaded when a solve starts from their own libraries, installed separately."""


@functools.cache
def linear_solver_available(name: str) -> bool:
    """Whether this process's Ipopt can factorise with ``name`` (one of :data:`LINEAR_SOLVERS`):
    a one-variable problem solved with it, once per process (a few ms). Without its library Ipopt
    stops before its first iteration (``Invalid_Option``), which :func:`solve` reported as "did
    not converge"; a name Ipopt does not know is refused by ``nlpsol`` itself (with its option
    text on stdout), so only the names of :data:`LINEAR_SOLVERS` are tried."""
    x = ca.MX.sym("x")
    opts = {"ipopt.linear_solver": name, "ipopt.print_level": 0, "ipopt.sb": "yes"}
    probe = ca.nlpsol(
        "linear_solver_probe", "ipopt", {"x": x, "f": (x - 1) ** 2}, opts | {"print_time": False}
    )
    probe(x0=0.0)
    return bool(probe.stats()["success"])


def _linear_solvers_here() -> str:
    """The built-in linear solvers this Ipopt has, for a message. The run-time loaded ones are not
    tried: a failed load of MA86, then MA97, then Pardiso in one process crashed it (CasADi
    3.8.2's Ipopt 3.14.19, a segmentation fault)."""
    here = [n for n in LINEAR_SOLVERS[:2] if linear_solver_available(n)]
    names = ", ".join(here) or "none"
    return f"available here: {names} (ma27-ma97 with HSL's library, pardiso with Pardiso's)"


_RANGES = {
    # field: (a whole number, lowest, lowest allowed, highest), Ipopt's (its option documentation)
    "tol": (False, 0, False, math.inf),
    "acceptable_tol": (False, 0, False, math.inf),
    "acceptable_obj_change_tol": (False, 0, True, math.inf),
    "acceptable_iter": (True, 0, True, math.inf),
    "max_iter": (True, 0, True, math.inf),
    "print_level": (True, 0, True, 12),
    "warm_mu_init": (False, 0, False, math.inf),
    "warm_bound_push": (False, 0, False, 0.5),  # also Ipopt's bound_frac, at most 0.5
}


def _range_text(whole: bool, low, low_in: bool, high) -> str:
    """A range of :data:`_RANGES` as a message says it ("a whole number from 0 to 12")."""
    kind = "a whole number" if whole else "a number"
    if high == math.inf:
        return f"{kind} {'>=' if low_in else '>'} {low}"
    if whole:
        return f"{kind} from {low} to {high}"
    return f"{kind} in {'[' if low_in else '('}{low}, {high}]"


@named_fields
@dataclass(frozen=True)
class IpoptOptions:
    """Ipopt settings. ``tol``: NLP tolerance; ``max_iter``; ``print_level`` 0-12.

    hessian: ``"exact"`` (default): the exact Hessian, assembled from per-frame SX Hessians
    (``sum_t A^T H_t A``, see :mod:`gc_ocp.estimation.problem`); ``"gauss-newton"``: ``J_r^T J_r``
    (drops the second-order residual term; converges slowly on real data with its large residuals).

    warm_mu_init, warm_bound_push: the barrier's first value and the push into the bounds'
    interior for a *warm* solve (``solve(..., warm=True)``): one started from the solution of a
    nearby problem that differs only in its priors' widths (the estimation's continuation
    stages and width rounds). Ipopt's defaults (0.1 and 0.01) suit a cold start: from a
    near-optimal point they first move it away from the bounds and onto the central path of a
    large barrier, and then spend iterations coming back. With 1e-4 and 1e-6 the bundled
    trial's warm stages and rounds take about a quarter fewer iterations to the same optima
    (``docs/estimation.md``, *Warm starts*). ``None``: Ipopt's defaults there too.

    linear_solver: one of :data:`LINEAR_SOLVERS` that this Ipopt can load (``"mumps"``, built
    in, by default; HSL's ``"ma27"``-``"ma97"`` need HSL's library). A value Ipopt would refuse
    is an :class:`~gc_ocp.errors.InputError` when the options are made, naming the field and
    what it takes. Given to :func:`gc_ocp.fit` (``options=``), :func:`solve` or the diagnosis:

    >>> import gc_ocp
    >>> options = gc_ocp.IpoptOptions(max_iter=200, print_level=5)
    >>> options.max_iter, options.tol
    (200, 1e-08)
    >>> gc_ocp.IpoptOptions(print_level=20)
    Traceback (most recent call last):
    ...
    gc_ocp.errors.InputError: IpoptOptions(print_level=20): give a whole number from 0 to 12 (Ipopt's range)
    """

    tol: float = 1e-8
    acceptable_tol: float = 1e-4
    acceptable_obj_change_tol: float = 1e-6
    acceptable_iter: int = 5
    max_iter: int = 1000
    print_level: int = 0
    linear_solver: str = "mumps"
    hessian: str = "exact"
    warm_mu_init: float | None = 1e-4
    warm_bound_push: float | None = 1e-6

    def __post_init__(self) -> None:
        # Ipopt refused a value out of its range at the first solve, as CasADi's RuntimeError
        # "Invalid options were detected by Ipopt" (its option text on stdout), and cut a
        # fractional max_iter to a whole one silently
        for name, (whole, low, low_in, high) in _RANGES.items():
            v = getattr(self, name)
            warm = name.startswith("warm_")  # None: Ipopt's default
            if v is None and warm:
                continue
            if whole:
                ok = is_count(v)
            else:
                ok = isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isfinite(v)
            if not (ok and (low <= v if low_in else low < v) and v <= high):
                takes = _range_text(whole, low, low_in, high) + " (Ipopt's range)"
                takes += ", or None (Ipopt's default)" if warm else ""
                raise InputError(f"IpoptOptions({name}={v!r}): give {takes}")
        if self.hessian not in HESSIANS:
            raise InputError(
                f"IpoptOptions(hessian={self.hessian!r}): give one of "
                f"{', '.join(map(repr, HESSIANS))}"
            )
        ls = self.linear_solver
        if not (isinstance(ls, str) and ls in LINEAR_SOLVERS):
            raise InputError(
                f"IpoptOptions(linear_solver={ls!r}): not one of Ipopt's linear solvers "
                f"({', '.join(LINEAR_SOLVERS)}); {_linear_solvers_here()}"
            )
        # the default is built into every Ipopt CasADi ships: no probe solve at construction
        # (an IpoptOptions() is made at import, as a default argument)
        if ls != "mumps" and not linear_solver_available(ls):
            raise InputError(
                f"IpoptOptions(linear_solver={ls!r}): this Ipopt cannot load it (its library is "
                f"not installed); {_linear_solvers_here()}"
            )

    def as_dict(self, warm: bool = False) -> dict:
        """Ipopt's options for CasADi's ``nlpsol``; ``warm``: for a warm solve (the ``warm_*``
        settings, class doc)."""
        extra = {}
        if warm and self.warm_mu_init is not None:
            extra["ipopt.mu_init"] = self.warm_mu_init
        if warm and self.warm_bound_push is not None:
            extra["ipopt.bound_push"] = self.warm_bound_push
            extra["ipopt.bound_frac"] = self.warm_bound_push
        return extra | {
            "ipopt.tol": self.tol,
            "ipopt.max_iter": self.max_iter,
            # statistical stopping: 5 consecutive iterations with relative objective change
            # < 1e-6 (J is half a chi-square, ~1e2-1e3 on real trials: changes << 1 are noise)
            "ipopt.acceptable_tol": self.acceptable_tol,
            "ipopt.acceptable_obj_change_tol": self.acceptable_obj_change_tol,
            "ipopt.acceptable_iter": self.acceptable_iter,
            "ipopt.print_level": self.print_level,
            "ipopt.linear_solver": self.linear_solver,
            "ipopt.sb": "yes",
            "print_time": False,
        }


def require_settings(weights, options) -> None:
    """An :class:`InputError` unless ``weights`` is a :class:`Weights` and ``options`` an
    :class:`IpoptOptions` (or None, the defaults): a notebook's ``options={"max_iter": 50}``
    was a TypeError from the solver cache (an unhashable dict), ``weights={...}`` an
    AttributeError from inside the build."""
    require_given(weights, Weights, "weights")
    require_given(options, IpoptOptions, "options")


def gauss_newton_hessian(problem: EstimationProblem) -> ca.Function:
    """Ipopt's ``hess_lag`` callback: upper triangle of ``lam_f * J_r^T J_r`` (no constraints)."""
    Jr = ca.jacobian(problem.residuals, problem.x)
    H = ca.triu(ca.mtimes(Jr.T, Jr))
    lam_f = ca.MX.sym("lam_f")
    lam_g = ca.MX.sym("lam_g", 0, 1)
    p = _parameter(problem)
    return ca.Function(
        "nlp_hess_l",
        [problem.x, p, lam_f, lam_g],
        [lam_f * H],
        ["x", "p", "lam_f", "lam_g"],
        ["triu_hess_gamma_x_x"],
    )


def _parameter(problem: EstimationProblem) -> ca.MX:
    """The NLP's parameter: the column scale of a parametric problem
    (:meth:`~gc_ocp.estimation.problem.EstimationProblem.parametric`), else none."""
    return ca.MX.sym("p", 0, 1) if problem.column_scale is None else problem.column_scale


def _covariance(problem: EstimationProblem, x: np.ndarray) -> np.ndarray:
    """Covariance of the decision vector: a sandwich that holds for autocorrelated residuals.

    The estimate minimises ``1/2 |r(x)|^2 + 1/2 |W (x - m)|^2``; near the optimum its error is
    ``H^-1 (J^T e + prior part)`` with ``H = J^T J + W^2`` (Gauss-Newton). Its covariance is
    ``H^-1 S H^-1`` with ``S = Cov(J^T e) + W^2``. Real residuals are correlated over many frames
    (marker filtering at 6 Hz, soft-tissue motion, unmodelled dynamics: lag-1 correlations of
    0.9 are typical), so ``Cov(J^T e)`` is estimated from the residuals themselves, per stance,
    by Newey & West's (1987) Bartlett-weighted sum of the per-frame scores ``g_t = J_t^T r_t``
    over lags up to the stance's bandwidth L (:func:`hac_bandwidth`); stances are independent. With
    white residuals of unit variance this reduces to the usual ``H^-1``; with white residuals
    of variance s^2 to the classical ``s^2``-scaled one.

    The prior's part ``W^2`` of ``S`` is ``W Cov(z) W`` for the true values ``z`` of the prior
    variables: the identity (independent draws of the prior) unless a component says otherwise
    (:meth:`~gc_ocp.estimation.components.base.Component.prior_covariance`: the pose error the
    stances of a foot share)."""
    r, J = problem.data_jacobian(x)
    pw = np.asarray(problem.prior_weights, float)
    P = np.diag(pw**2)
    H = (J.T @ J).toarray() + P
    Hi = gauss_newton_inverse(H)
    S = P.copy()
    for comp in problem.model:
        for cols, C in comp.prior_covariance(problem.variables.specs, problem.stances, x):
            S[np.ix_(cols, cols)] = pw[cols, None] * C * pw[None, cols]
    row = 0
    for b in problem.blocks:
        n = 6 * b.T
        Jb, rb = J[row : row + n], r[row : row + n]
        g = (
            np.asarray(Jb.multiply(rb[:, None]).toarray()).reshape(b.T, 6, -1).sum(axis=1)
        )  # (T, nx)
        S += g.T @ g
        L = hac_bandwidth(rb.reshape(b.T, 6))
        for lag in range(1, L + 1):
            w = 1.0 - lag / (L + 1.0)
            C = g[lag:].T @ g[:-lag]
            S += w * (C + C.T)
        row += n
    cov = Hi @ S @ Hi
    return 0.5 * (cov + cov.T)


def gauss_newton_inverse(H: np.ndarray) -> np.ndarray:
    """``H^-1`` of a Gauss-Newton Hessian ``J^T J + W^2``; its pseudo-inverse where it is
    singular (a variable neither the data nor a prior fixes: its variance then reads 0, and the
    flags say it is not identified), so that a covariance is never a traceback."""
    try:
        return np.linalg.inv(H)
    except np.linalg.LinAlgError:
        return np.linalg.pinv(H)


def hac_bandwidth(res: np.ndarray) -> int:
    """Lags (frames) over which a stance's residuals ``(T, 6)`` are correlated: the first lag at
    which their autocorrelation (mean over channels) falls inside the white-noise band
    ``2 / sqrt(T)``, at most ``T // 3`` (beyond, too few pairs to estimate it)."""
    T = res.shape[0]
    z = res - res.mean(axis=0)
    var = np.sum(z**2, axis=0)
    ok = var > 0
    if T < 6 or not ok.any():
        return 0
    band = 2.0 / np.sqrt(T)
    for lag in range(1, T // 3 + 1):
        rho = np.sum(z[lag:, ok] * z[:-lag, ok], axis=0) / var[ok]
        if float(np.mean(rho)) < band:
            return lag
    return T // 3


def decode(
    problem: EstimationProblem, x: np.ndarray, cov: np.ndarray | None = None
) -> tuple[dict, list]:
    """Every component's block and the per-stance fits at decision vector ``x``."""
    ctx = DecodeContext(
        specs=problem.variables.specs,
        x=x,
        cov=cov,
        stances=problem.stances,
        slot_values=lambda i, name: problem.slot_values(x, i, name),
        slot_rows=problem.slot_rows,
    )
    blocks = {c.name: c.decode(ctx) for c in problem.model}
    fits = []
    measured = problem.stance_measured(x)
    for i, (st, w) in enumerate(zip(problem.stances, problem.stance_wrenches(x), strict=True)):
        f = st.foot
        fits.append(
            {
                "label": st.label,
                "side": st.side,
                "trial": st.trial,
                "units": list(st.layout.units),
                "parents": list(st.layout.parents),
                "time": np.asarray(st.time),
                "measured": measured[i],
                "model": w,
                "in_contact": np.asarray(st.in_contact),
                "points_local": problem.slot_values(x, i, "points_local")[0].reshape(-1, 3),
                "nominal_points": np.asarray(f.points_local),
                "toes_offset": (np.linalg.inv(f.hindfoot_pose[0]) @ f.toes_pose[0])[:3, 3],
                "reference_point": np.asarray(st.reference_point),
                "ground_height": st.ground_height,
                "body_weight": st.body_weight,
                "height": st.height,
                "censor_below": st.censor_below,
            }
        )
    return blocks, fits


def make_solver(
    problem: EstimationProblem, options: IpoptOptions | None = None, warm: bool = False
) -> ca.Function:
    """The Ipopt solver (a ``casadi.Function``) with our gradient and structured Hessian callbacks
    (``warm``: set up for a warm solve, :class:`IpoptOptions`)."""
    options = options or IpoptOptions()
    p = _parameter(problem)
    nlp = {"x": problem.x, "f": problem.objective}
    if problem.column_scale is not None:
        nlp["p"] = p
    opts = options.as_dict(warm)
    opts["grad_f"] = ca.Function(
        "nlp_grad_f",
        [problem.x, p],
        [problem.objective, problem.gradient],
        ["x", "p"],
        ["f", "grad_f_x"],
    )
    if options.hessian == "gauss-newton":
        opts["hess_lag"] = gauss_newton_hessian(problem)
    else:  # "exact" (IpoptOptions checks the name)
        lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", 0, 1)
        opts["hess_lag"] = ca.Function(
            "nlp_hess_l",
            [problem.x, p, lam_f, lam_g],
            [lam_f * ca.triu(problem.hessian)],
            ["x", "p", "lam_f", "lam_g"],
            ["triu_hess_gamma_x_x"],
        )
    solver = ca.nlpsol("gc_ocp_fit", "ipopt", nlp, opts)
    return solver


def solve(
    problem: EstimationProblem,
    options: IpoptOptions | None = None,
    x0: np.ndarray | None = None,
    raise_on_failure: bool = True,
    covariance: bool = True,
    warm: bool = False,
) -> EstimationResult:
    """Solve with Ipopt (exact CasADi derivatives). Raises :class:`SolveError` carrying the
    result when Ipopt does not converge (unless ``raise_on_failure=False``). ``covariance=False``
    skips the covariance (and so the standard errors) of the result: for intermediate solves
    whose uncertainty nobody reads (continuation stages, the diagnosis's fold fits). ``warm``:
    ``x0`` is the solution of the same problem with other prior widths (:class:`IpoptOptions`'
    ``warm_*`` settings); other starts from a given point (a fold, a null draw, an effect from
    its parent) keep Ipopt's defaults (``docs/estimation.md``, *Warm starts*).

    Returns an :class:`EstimationResult` (``.summary()``, ``.blocks``).

    >>> import gc_ocp
    >>> trial = gc_ocp.load_trial(); kin = gc_ocp.compute_kinematics(trial)
    >>> problem = gc_ocp.build_estimation(gc_ocp.trial_stances(trial, kin), gc_ocp.full_model())
    >>> result = gc_ocp.solve(problem, gc_ocp.IpoptOptions(max_iter=200))
    >>> result.status
    'Solve_Succeeded'

    (:func:`gc_ocp.fit` does this from the trials, with its start, continuation and widths.)"""
    require(
        problem,
        EstimationProblem,
        "solve takes a built problem",
        "problem = gc_ocp.build_estimation(stances, model); gc_ocp.solve(problem)",
    )
    require_given(options, IpoptOptions, "options")
    options = options or IpoptOptions()
    warm = warm and x0 is not None
    # every problem is solved as its anchor's parametric problem (its own at s = 1, to the bit),
    # so that the problems rescaled from it (EstimationProblem.rescaled) share the solver
    anchor = problem.anchor or problem
    scale = problem.anchor_scale if problem.anchor is not None else np.ones(problem.x0.size)
    if (options, warm) not in anchor.solvers:
        anchor.solvers[(options, warm)] = make_solver(anchor.parametric(), options, warm)
    solver = anchor.solvers[(options, warm)]
    x_init = problem.x0 if x0 is None else _checked_start(problem, x0)
    t0 = _time.perf_counter()
    with signals.kept():  # Ctrl-C during the solve interrupts the fit
        sol = solver(x0=x_init, lbx=problem.lbx, ubx=problem.ubx, p=scale)
    seconds = _time.perf_counter() - t0
    stats = solver.stats()
    # Ipopt relaxes the bounds by its bound_relax_factor (1e-8, relative): its solution can lie
    # that far outside them. Clipped back, the result is a point of the problem as declared, so a
    # warm start from it (clipped too, :func:`~gc_ocp.estimation.starts.rescaled_start`) is the
    # same point and a nested model reproduces its residual to round-off.
    x = np.clip(np.asarray(sol["x"]).ravel(), problem.lbx, problem.ubx)
    status = str(stats.get("return_status", "unknown"))
    success = bool(stats.get("success", False)) or status in (
        "Solve_Succeeded",
        "Solved_To_Acceptable_Level",
    )
    result = result_at(
        problem,
        x,
        status=status,
        success=success,
        iterations=int(stats.get("iter_count", -1)),
        seconds=seconds,
        covariance=covariance,
    )
    if not success and raise_on_failure:
        raise SolveError(
            f"Ipopt did not converge: {status} after {result.iterations} iterations", result
        )
    return result


# Ipopt relaxes every bound by its bound_relax_factor (1e-8, relative): a start that far
# outside is a point of the problem (a solution of a problem with the same bounds, clipped or not)
_START_SLACK = 1e-8


def _checked_start(problem: EstimationProblem, x0) -> np.ndarray:
    """A start ``x0`` the caller gave, as :func:`solve` takes it: the problem's size, finite, and
    within the bounds (to Ipopt's own relaxation). Anything else is an
    :class:`InputError` naming the first variable at fault: Ipopt would move a start outside
    its bounds inside silently (a different start than the caller asked for) and stop on a
    NaN without saying where it came from."""
    x = np.asarray(x0, float).ravel() if np.ndim(x0) else np.full(1, np.nan)
    how = "give problem.x0, or a result's x of the same problem (result.x)"
    if x.size != problem.x0.size:
        raise InputError(
            f"solve's x0 has {x.size} entries but the problem has {problem.x0.size} decision "
            f"variables: {how}"
        )
    slack = _START_SLACK * np.maximum(1.0, np.maximum(np.abs(problem.lbx), np.abs(problem.ubx)))
    bad = ~np.isfinite(x) | (x < problem.lbx - slack) | (x > problem.ubx + slack)
    if bad.any():
        i = int(np.argmax(bad))
        spec = next(s for s in problem.variables.specs if s.start <= i < s.start + s.size)
        name = "/".join(map(str, spec.key)) + (f"[{i - spec.start}]" if spec.size > 1 else "")
        raise InputError(
            f"solve's x0 gives {name} (entry {i} of x0; {int(bad.sum())} entries at fault) the "
            f"value {x[i]:g}, {'not a number' if not np.isfinite(x[i]) else 'outside its bounds'} "
            f"[{problem.lbx[i]:g}, {problem.ubx[i]:g}] (in the optimised units: log for log "
            f"parameters, prior widths for corrections): {how}, within the bounds"
        )
    return x  # as given: Ipopt's handling of a start within its relaxation is unchanged


def retry_from_stop(
    problem: EstimationProblem,
    stopped: EstimationResult,
    options: IpoptOptions | None = None,
    covariance: bool = True,
) -> EstimationResult:
    """``stopped``, a solve of ``problem`` that did not converge (Ipopt's iteration limit, a
    failed restoration), solved once more from where it stopped: a frozen model's held-out fit
    is then scored at its nuisance's optimum, not at a point that depends on where Ipopt gave
    up. The second solve is kept when it converges or ends lower; otherwise ``stopped`` is, and
    its caller says so (a note or a flag). A converged ``stopped`` is returned as it is."""
    if stopped.success:
        return stopped
    again = solve(problem, options, x0=stopped.x, raise_on_failure=False, covariance=covariance)
    if again.success or again.objective < stopped.objective:
        return again
    return stopped


def result_at(
    problem: EstimationProblem,
    x: np.ndarray,
    status: str = "evaluated",
    success: bool = True,
    iterations: int = 0,
    seconds: float = 0.0,
    covariance: bool | np.ndarray = True,
) -> EstimationResult:
    """The plain-data result of ``problem`` at decision vector ``x`` (covariance included unless
    ``covariance=False``: then ``covariance`` is None and standard errors are NaN; an array:
    that covariance, e.g. the bias correction's, from which the SEs and the flags that read them
    are made)."""
    x = np.asarray(x, float)
    if isinstance(covariance, np.ndarray):
        cov = covariance
    else:
        cov = _covariance(problem, x) if covariance and np.all(np.isfinite(x)) else None
    blocks, fits = decode(problem, x, cov)
    rms, cop = fit_quality(fits)
    data_cost, prior_cost = problem.costs(x)
    flags = variable_flags(problem.variables.specs, x)
    for c in problem.model:
        flags += c.flags(blocks[c.name], problem.stances)
    flags += fit_flags(rms, cop)
    specs = problem.variables.specs
    return EstimationResult(
        x=x,
        status=status,
        success=success,
        iterations=iterations,
        seconds=seconds,
        objective=data_cost + prior_cost,
        data_cost=data_cost,
        prior_cost=prior_cost,
        n_data=problem.n_data,
        n_free=int(x.size),
        n_param=int(sum(s.size for s in specs if s.kind == "param")),
        blocks=blocks,
        components={c.name: type(c).__name__ for c in problem.model},
        contact_law=next((c.settings() for c in problem.model if isinstance(c, ContactLaw)), {}),
        rms=rms,
        cop_rms_mm=cop,
        stance_fits=fits,
        variables=specs,
        covariance=cov,
        flags=flags,
    )


__all__ = [
    "IpoptOptions",
    "EstimationResult",
    "make_solver",
    "require_settings",
    "solve",
    "result_at",
    "decode",
    "fit_quality",
    "gauss_newton_inverse",
    "hac_bandwidth",
]
