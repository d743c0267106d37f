"""Solve an :class:`EstimationProblem` with Ipopt and decode the result."""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from gc_ocp.contact.channels import TABLE_KEYS, channel_rms_pct
from gc_ocp.errors import SolveError
from gc_ocp.estimation.components import ContactLaw, PoseCorrection, SoleCorrection
from gc_ocp.estimation.problem import EstimationProblem
from gc_ocp.foot import UNITS
from gc_ocp.trial import SIDES
from gc_ocp.wrench import cop_from_wrench


@dataclass(frozen=True)
class IpoptOptions:
    """Ipopt settings. ``tol``: NLP tolerance; ``max_iter``; ``print_level`` 0-12.

    hessian: ``"exact"`` (default): the exact Hessian, assembled from per-frame SX Hessians
    (``sum_t A^T H_t A``, see :mod:`gc_ocp.estimation.problem`); ``"gauss-newton"``: ``J_r^T J_r``
    (drops the second-order residual term; converges slowly on real data with its large residuals).
    """

    tol: float = 1e-8
    acceptable_tol: float = 1e-4
    acceptable_obj_change_tol: float = 1e-6
    acceptable_iter: int = 5
    max_iter: int = 1000
    print_level: int = 0
    linear_solver: str = "mumps"
    hessian: str = "exact"

    def as_dict(self) -> dict:
        return {
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


@dataclass
class EstimationResult:
    """Estimated parameters, their standard errors, corrections, fit quality and solver stats.

    params: ``{"left": {"PL": {"k": .., "k_se": .., "f_ref": .., "f_ref_se": ..}, ...}, "right": ...,
    "shared": {"n": .., "n_se": ..}}`` (per-foot parameters appear under each side); ``f_ref`` [N]
    is the unit's force at the reference depth ``ContactLaw.reference_depth`` (5 mm), far better
    determined than k because k and n are strongly correlated; sole_corrections_mm: ``{side: {unit: [dx,dy,dz]}}``
    in the foot frame [mm]; pose_correction_rms: ``{side: {"mm": .., "deg": ..}}``;
    rms: per side, per channel RMS (% BW, % BW·H with the trial's BW and height);
    cop_rms_mm: per side, COP error where measured Fz > 10 % BW; stance_fits: per stance arrays.
    """

    x: np.ndarray
    status: str
    success: bool
    iterations: int
    seconds: float
    objective: float
    params: dict
    sole_corrections_mm: dict
    pose_correction_rms: dict
    rms: dict
    cop_rms_mm: dict
    stance_fits: list = field(default_factory=list)
    belt_speed: dict = field(default_factory=dict)
    covariance: np.ndarray | None = None
    problem: EstimationProblem | None = None

    def summary(self) -> str:
        lines = [
            f"Ipopt: {self.status} in {self.iterations} iterations, {self.seconds:.2f} s; objective {self.objective:.4g}"
        ]
        for side in SIDES:
            if side not in self.rms:
                continue
            p = self.params.get(side, {})
            ks = ", ".join(f"{u} {p[u]['k']:.3g}±{p[u]['k_se']:.2g}" for u in UNITS if u in p)
            if ks:
                lines.append(f"{side:>5} k [N/m^n]: {ks}")
                fs = ", ".join(
                    f"{u} {p[u]['f_ref']:.0f}±{p[u]['f_ref_se']:.2g}"
                    for u in UNITS
                    if "f_ref" in p.get(u, {})
                )
                lines.append(f"{side:>5} force at the reference depth [N]: {fs}")
            r = self.rms[side]
            lines.append(
                f"{side:>5} RMS: "
                + ", ".join(f"{c.split('_')[0]} {r[c]:.2f}" for c in r)
                + f"; COP {self.cop_rms_mm.get(side, float('nan')):.1f} mm"
            )
            if side in self.pose_correction_rms:
                pc = self.pose_correction_rms[side]
                lines.append(
                    f"{side:>5} pose correction RMS: {pc['mm']:.2f} mm, {pc['deg']:.2f} deg"
                )
        for trial, v in self.belt_speed.items():
            lines.append(
                f"belt speed ({trial}): {v['value']:.3f} ± {v['se']:.3f} m/s (given {v['nominal']:.3f})"
            )
        for k, v in self.params.get("shared", {}).items():
            if not k.endswith("_se"):
                lines.append(
                    f"shared {k} = {v:.4g} ± {self.params['shared'].get(k + '_se', float('nan')):.2g}"
                )
        return "\n".join(lines)

    def to_json(self) -> dict:
        return {
            "params": self.params,
            "sole_corrections_mm": self.sole_corrections_mm,
            "pose_correction_rms": self.pose_correction_rms,
            "rms": self.rms,
            "cop_rms_mm": self.cop_rms_mm,
            "solver": {
                "status": self.status,
                "iterations": self.iterations,
                "seconds": self.seconds,
            },
            **({"belt_speed_m_s": self.belt_speed} if self.belt_speed else {}),
        }


def gauss_newton_hessian(problem: EstimationProblem) -> ca.Function:
    """Ipopt's ``hess_lag`` callback: upper triangle of ``lam_f * J_r^T J_r`` (no constraints)."""
    Jr = ca.jacobian(problem.residuals, problem.x)
    H = ca.triu(ca.mtimes(Jr.T, Jr))
    lam_f = ca.MX.sym("lam_f")
    lam_g = ca.MX.sym("lam_g", 0, 1)
    p = ca.MX.sym("p", 0, 1)
    return ca.Function(
        "nlp_hess_l",
        [problem.x, p, lam_f, lam_g],
        [lam_f * H],
        ["x", "p", "lam_f", "lam_g"],
        ["triu_hess_gamma_x_x"],
    )


def _covariance(problem: EstimationProblem, x: np.ndarray) -> np.ndarray:
    """Gauss-Newton covariance of the decision vector, scaled by the residual variance."""
    r, Jd = problem.data_jacobian(x)
    n_data = problem.n_data
    dof = max(n_data - x.size, 1)
    s2 = float(r @ r) / dof  # a-posteriori variance factor of the data
    # data part scaled by s2, priors are exact (their Jacobian is diag(prior weights))
    Hs = (Jd.T @ Jd).toarray() / s2 + np.diag(problem.prior_weights**2)
    try:
        return np.linalg.inv(Hs)
    except np.linalg.LinAlgError:
        return np.linalg.pinv(Hs)  # same scaling as the regular case


def _add_reference_force(
    params: dict, law: ContactLaw, b, x: np.ndarray, cov: np.ndarray | None
) -> None:
    """Add ``f_ref`` / ``f_ref_se`` to every unit: its force at the reference penetration without
    damping, ``k * d_ref**n`` [N] (``ContactLaw.reference_depth``).

    k [N/m^n] and n are strongly correlated (``ln k_ref = ln k + n ln d_ref`` with
    ``ln 0.005 = -5.3``: a 1 % change of n = 1.5 moves k by 8 % at the same force), so k's standard
    error is large even where the unit's force-depth curve is well determined; f_ref's is not.
    Its standard error follows by the delta method from the covariance of (log k, n)."""
    L = float(np.log(law.reference_depth))
    for side in SIDES:
        for u in UNITS:
            entry = params.get(side, {}).get(u)
            if entry is None or "k" not in entry:
                continue
            n_val = params[side]["n"] if "n" in params.get(side, {}) else params["shared"].get("n")
            if n_val is None:
                n_val = law.n.value_for(side)
            entry["f_ref"] = float(entry["k"] * law.reference_depth**n_val)
            ik = b._index.get((law.name, "k", side, u))
            in_ = b._index.get((law.name, "n", side)) or b._index.get((law.name, "n"))
            if cov is None or ik is None:
                entry["f_ref_se"] = float("nan") if ik is not None else 0.0
                continue
            g = np.zeros(x.size)
            g[ik.start] = 1.0  # d ln f_ref / d ln k
            if in_ is not None:
                g[in_.start] = L  # d ln f_ref / d n
            var = float(g @ cov @ g) if in_ is not None else float(cov[ik.start, ik.start])
            entry["f_ref_se"] = float(entry["f_ref"] * np.sqrt(max(var, 0.0)))


def decode(problem: EstimationProblem, x: np.ndarray, cov: np.ndarray | None = None) -> dict:
    """Physical parameters, corrections and per-stance fits at decision vector ``x``."""
    b = problem.builder
    var = np.diag(cov) if cov is not None else np.full(x.size, np.nan)
    params: dict = {s: {} for s in SIDES}
    params["shared"] = {}
    law = problem.component(ContactLaw)
    sole = problem.component(SoleCorrection)
    pose = problem.component(PoseCorrection)
    for spec in b.specs:
        key = spec["key"]
        if key[0] != law.name:
            continue
        sl = b._index[key]
        z = float(x[sl][0])
        sd = float(np.sqrt(max(var[sl][0], 0.0)))
        val = np.exp(z) if spec["log"] else z * spec["scale"]
        se = val * sd if spec["log"] else sd * spec["scale"]
        pname, rest = key[1], key[2:]
        if len(rest) == 2:
            params[rest[0]].setdefault(rest[1], {})[pname] = val
            params[rest[0]][rest[1]][pname + "_se"] = se
        elif len(rest) == 1:
            params[rest[0]][pname] = val
            params[rest[0]][pname + "_se"] = se
        else:
            params["shared"][pname] = val
            params["shared"][pname + "_se"] = se
    for side in SIDES:  # fixed parameters, reported with zero standard error
        for pname in ("k", "n", "c", "mu"):
            p = getattr(law, pname)
            if p.scope != "fixed":
                continue
            if pname == "k":
                for u in UNITS:
                    params[side].setdefault(u, {})["k"] = p.value_for(side, u)
                    params[side][u]["k_se"] = 0.0
            else:
                params[side][pname] = p.value_for(side)
                params[side][pname + "_se"] = 0.0
    _add_reference_force(params, law, b, x, cov)
    belt_speed: dict = {}
    for st in problem.stances:
        key = ("belt", st.trial)
        if b.has(key) and st.trial not in belt_speed:
            sl = b._index[key]
            spec = next(s_ for s_ in b.specs if s_["key"] == key)
            belt_speed[st.trial] = {
                "value": float(-st.belt_velocity[0] + x[sl][0] * spec["scale"]),
                "se": float(np.sqrt(max(var[sl][0], 0.0)) * spec["scale"]),
                "nominal": float(-st.belt_velocity[0]),
            }
    sole_mm: dict = {}
    if sole is not None:
        for side in SIDES:
            if sole.fixed is not None:
                sole_mm[side] = {
                    u: list(map(float, np.asarray(sole.fixed[side])[i] * 1e3))
                    for i, u in enumerate(UNITS)
                }
            else:
                sole_mm[side] = {
                    u: list(map(float, x[b._index[(sole.name, side, u)]] * sole.sigma * 1e3))
                    for u in UNITS
                }
    fn = ca.Function("out", [problem.x], problem.stance_outputs + problem.stance_points)
    outs = fn(x)
    ns = len(problem.stances)
    fits = []
    pose_sq: dict = {s: [[], []] for s in SIDES}
    for i, st in enumerate(problem.stances):
        model_w = np.asarray(outs[i]).T
        pts = np.asarray(outs[ns + i]).reshape(5, 3)
        fit = {
            "label": st.label,
            "side": st.side,
            "time": st.time,
            "measured": st.measured,
            "model": model_w,
            "in_contact": st.in_contact,
            "points_local": pts,
        }
        if pose is not None:
            d, th, _, _ = pose.trajectories(b, i)
            f2 = ca.Function("p", [problem.x], [d, th])
            dv, tv = (np.asarray(a) for a in f2(x))
            fit["pose_translation"] = dv.T
            fit["pose_rotation"] = tv.T
            pose_sq[st.side][0].append(np.sum(dv**2, axis=0))
            pose_sq[st.side][1].append(np.sum(tv**2, axis=0))
        fits.append(fit)
    pose_rms = {
        s: {
            "mm": float(np.sqrt(np.mean(np.concatenate(v[0])))) * 1e3,
            "deg": float(np.rad2deg(np.sqrt(np.mean(np.concatenate(v[1]))))),
        }
        for s, v in pose_sq.items()
        if v[0]
    }
    return {
        "params": {k: v for k, v in params.items() if v},
        "sole_corrections_mm": sole_mm,
        "belt_speed": belt_speed,
        "pose_correction_rms": pose_rms,
        "stance_fits": fits,
    }


def fit_quality(fits: list, stances) -> tuple[dict, dict]:
    """Per-side channel RMS (% BW, % BW·H over in-contact frames) and COP RMS [mm] (Fz > 10 % BW)."""
    rms: dict = {}
    cop: dict = {}
    for side in SIDES:
        idx = [i for i, f in enumerate(fits) if f["side"] == side]
        if not idx:
            continue
        meas = np.vstack([fits[i]["measured"][fits[i]["in_contact"]] for i in idx])
        mod = np.vstack([fits[i]["model"][fits[i]["in_contact"]] for i in idx])
        st0 = stances[idx[0]]
        pct = channel_rms_pct(meas, mod, st0.body_weight, st0.body_weight * st0.height)
        rms[side] = {TABLE_KEYS[c]: v for c, v in pct.items()}
        errs = []
        for i in idx:
            st = stances[i]
            m, f = fits[i]["measured"], fits[i]["model"]
            c_meas = cop_from_wrench(
                m[:, :3], m[:, 3:], st.reference_point, st.ground_height, 0.10 * st.body_weight
            )
            c_mod = cop_from_wrench(f[:, :3], f[:, 3:], st.reference_point, st.ground_height, 1e-6)
            ok = np.isfinite(c_meas[:, 0]) & np.isfinite(c_mod[:, 0])
            errs.append(np.linalg.norm((c_meas - c_mod)[ok, :2], axis=1))
        e = np.concatenate(errs)
        cop[side] = float(np.sqrt(np.mean(e**2)) * 1e3) if e.size else float("nan")
    return rms, cop


def make_solver(problem: EstimationProblem, options: IpoptOptions | None = None) -> ca.Function:
    """The Ipopt solver (a ``casadi.Function``) with our gradient and structured Hessian callbacks."""
    options = options or IpoptOptions()
    nlp = {"x": problem.x, "f": problem.objective}
    opts = options.as_dict()
    p = ca.MX.sym("p", 0, 1)
    opts["grad_f"] = ca.Function(
        "nlp_grad_f",
        [problem.x, p],
        [problem.objective, problem.gradient],
        ["x", "p"],
        ["f", "grad_f_x"],
    )
    if options.hessian == "gauss-newton":
        opts["hess_lag"] = gauss_newton_hessian(problem)
    elif options.hessian == "exact":
        lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", 0, 1)
        opts["hess_lag"] = ca.Function(
            "nlp_hess_l",
            [problem.x, p, lam_f, lam_g],
            [lam_f * ca.triu(problem.hessian)],
            ["x", "p", "lam_f", "lam_g"],
            ["triu_hess_gamma_x_x"],
        )
    else:
        raise ValueError(
            f'IpoptOptions.hessian must be "exact" or "gauss-newton", but got "{options.hessian}"'
        )
    solver = ca.nlpsol("gc_ocp_fit", "ipopt", nlp, opts)
    return solver


def solve(
    problem: EstimationProblem,
    options: IpoptOptions | None = None,
    x0: np.ndarray | None = None,
    raise_on_failure: bool = True,
) -> EstimationResult:
    """Solve with Ipopt (exact CasADi derivatives). Raises :class:`SolveError` carrying the
    result when Ipopt does not converge (unless ``raise_on_failure=False``)."""
    options = options or IpoptOptions()
    solver = make_solver(problem, options)
    x_init = problem.x0 if x0 is None else x0
    t0 = _time.perf_counter()
    sol = solver(x0=x_init, lbx=problem.lbx, ubx=problem.ubx)
    seconds = _time.perf_counter() - t0
    stats = solver.stats()
    x = np.asarray(sol["x"]).ravel()
    status = str(stats.get("return_status", "unknown"))
    success = bool(stats.get("success", False)) or status in (
        "Solve_Succeeded",
        "Solved_To_Acceptable_Level",
    )
    cov = _covariance(problem, x) if np.all(np.isfinite(x)) else None
    dec = decode(problem, x, cov)
    rms, cop = fit_quality(dec["stance_fits"], problem.stances)
    result = EstimationResult(
        x=x,
        status=status,
        success=success,
        iterations=int(stats.get("iter_count", -1)),
        seconds=seconds,
        objective=float(sol["f"]),
        params=dec["params"],
        sole_corrections_mm=dec["sole_corrections_mm"],
        pose_correction_rms=dec["pose_correction_rms"],
        rms=rms,
        cop_rms_mm=cop,
        stance_fits=dec["stance_fits"],
        covariance=cov,
        problem=problem,
        belt_speed=dec["belt_speed"],
    )
    if not success and raise_on_failure:
        raise SolveError(
            f"Ipopt did not converge: {status} after {result.iterations} iterations", result
        )
    return result


__all__ = ["IpoptOptions", "EstimationResult", "make_solver", "solve", "decode", "fit_quality"]
