"""The pose and sole widths' type-II ML (``gc_ocp/estimation/pose_scale.py``): the package's
rounds of refits, one MacKay step each, against the fixed point run to its end on each refit's
local Gauss-Newton model (a try of 2026-11-29, not adopted: ``docs/quality.md``, *The pose
correction's smooth width*).

Run:  PYTHONPATH=. python benchmarks/width_fixed_point.py [--data ../shared/data] [--only SUBSTR]
      PYTHONPATH=. python benchmarks/width_fixed_point.py --trace --only FunctionalWalk

Per walking file of ``../shared/data`` (every stance, as ``fit()`` fits them: the one start path,
then the widths' rounds with the sole's width too), each way: the refits made, the widths, the
objective, the superior-force RMS in sample (mean of the feet), the rounds' time, and the
*distance from the fixed point*: the largest relative change of any width that one more plain
MacKay step would make at the returned fit (0 at the type-II ML estimate). "plain" is the
package's rounds (checked: the same widths and objective as ``estimate_pose_scale``); "settled"
runs up to 200 steps on the local model (:class:`LocalModel`) in every round.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import scipy.linalg as sla

sys.path.insert(0, str(Path(__file__).parent))
from all_data import WALKING, _load  # noqa: E402


class LocalModel:
    """The fit's Gauss-Newton model at ``x`` with the prior widths of some columns changed.

    A prior variable is stored in units of its width, so a width changed by the factor ``d``
    rescales its column: with ``D = diag(d)`` the data's residual near the fit is
    ``r0 + J (D z - x)`` in the new stored ``z``, and its prior stays ``W (z - m / d)``. The
    model's optimum and posterior variances at any widths are one linear solve,
    ``(D G D + W^2) z = D (G x - J^T r0) + W^2 m / d`` with ``G = J^T J``. At ``d = 1`` the optimum
    is the fit itself (no bound active) and the variances are the plain posterior's."""

    def __init__(self, problem, x: np.ndarray):
        r0, J = problem.data_jacobian(x)
        self.G = (J.T @ J).toarray()
        self.b = self.G @ x - J.T @ r0
        self.w2 = np.asarray(problem.prior_weights, float) ** 2
        self.m = np.asarray(problem.prior_means, float)

    def at(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        H = self.G * np.outer(d, d)
        H[np.diag_indices_from(H)] += self.w2
        L = np.linalg.cholesky(H)
        z = sla.cho_solve((L, True), d * self.b + self.w2 * self.m / d)
        Li = sla.solve_triangular(L, np.eye(L.shape[0]), lower=True)
        return z, np.sum(Li**2, axis=0)


def settle(problem, x, pose, sole, steps: int, floor=None):
    """MacKay's fixed point for the pose's six widths and the sole's three, ``steps`` steps at
    most on the fit's local model (1: the package's plain update at the fit), stopping when no
    width moves 0.1 %; ``floor``: the sole's prior the rounds started from (default
    ``sole.sigma``; :func:`gc_ocp.estimation.pose_scale.sole_update`)."""
    from gc_ocp.estimation import pose_scale

    local = LocalModel(problem, x)
    trans = pose_scale._axis_columns(problem, pose.name, "trans")
    rot = pose_scale._axis_columns(problem, pose.name, "rot")
    sole_cols = np.concatenate(
        [
            np.arange(v.start, v.start + v.size)
            for v in problem.variables.specs
            if v.key[0] == sole.name
        ]
    )
    w0 = np.r_[np.broadcast_to(pose.sigma_mm, 3), np.broadcast_to(pose.sigma_deg, 3)]
    s0 = sole.sigma
    floor = sole.sigma if floor is None else floor
    d = np.ones(x.size)
    k = 0
    while k < steps:
        k += 1
        if k == 1:  # the plain update, as the package makes it: at the fit itself
            z, sd = x, pose_scale._posterior_variances(problem, x)
        else:
            z, sd = local.at(d)
        mm, deg, _, _ = pose_scale.mackay_update(problem, z, pose, sd)
        old = np.r_[np.broadcast_to(pose.sigma_mm, 3), np.broadcast_to(pose.sigma_deg, 3)]
        w, _ = pose_scale.sole_update(problem, z, sole, sd, floor)
        w = np.asarray(w)  # one width per foot-frame axis
        change = max(
            float(np.max(np.abs(np.r_[mm, deg] / old - 1.0))),
            float(np.max(np.abs(w / np.asarray(sole.sigma) - 1))),
        )
        pose = replace(pose, sigma_mm=mm, sigma_deg=deg)
        sole = replace(sole, sigma=tuple(w))
        for a, cols in enumerate([*trans, *rot]):
            d[cols] = np.r_[mm, deg][a] / w0[a]
        for a in range(3):  # a unit's block holds its x, y, z
            d[sole_cols[a::3]] = w[a] / np.broadcast_to(s0, 3)[a]
        if change < 1e-3:
            break
    return pose, sole, k


def rounds(data, model, start, steps: int, trace=None):
    """The package's rounds (``estimate_pose_scale(..., sole=True)``: refit warm until no width
    moves :data:`RTOL`, at most :data:`MAX_ROUNDS`), each round's widths from :func:`settle`
    (``trace``: called with each round's widths and objective)."""
    from gc_ocp.estimation import build_estimation, pose_scale
    from gc_ocp.estimation.components import PoseCorrection, SoleCorrection
    from gc_ocp.estimation.solve import solve
    from gc_ocp.estimation.starts import rescaled_start

    pose = next(c for c in model if isinstance(c, PoseCorrection))
    sole = next(c for c in model if isinstance(c, SoleCorrection))
    prob, result = build_estimation(data, model), start
    floor = sole.sigma  # the sole's widths are widened from the model's prior, never narrowed
    k = 0
    while k < pose_scale.MAX_ROUNDS:
        k += 1
        old = np.r_[np.broadcast_to(pose.sigma_mm, 3), np.broadcast_to(pose.sigma_deg, 3)]
        old_sole = np.asarray(sole.sigma, float)
        pose, sole, _ = settle(prob, result.x, pose, sole, steps, floor)
        now = np.r_[pose.sigma_mm, pose.sigma_deg]
        change = max(
            float(np.max(np.abs(now / old - 1.0))),
            float(np.max(np.abs(np.asarray(sole.sigma) / old_sole - 1))),
        )
        model = tuple(
            pose if isinstance(c, PoseCorrection) else sole if isinstance(c, SoleCorrection) else c
            for c in model
        )
        prob = build_estimation(data, model)
        result = solve(prob, x0=rescaled_start(result, prob), covariance=False)
        if trace is not None:
            trace(
                np.r_[pose.sigma_mm, pose.sigma_deg, np.asarray(sole.sigma) * 1e3],
                result.objective,
            )
        if change < pose_scale.RTOL:
            break
    return model, result, k


def _start(data):
    """The model and its fit before the rounds, as ``fit()`` makes them (the one start path)."""
    from gc_ocp.estimation.components import full_model
    from gc_ocp.estimation.starts import best_of, with_lls_start

    model = with_lls_start(full_model(), data)
    return model, best_of(data, model, covariance=False)


def _one(data, model, start, steps: int) -> dict:
    from gc_ocp.estimation import build_estimation, pose_scale
    from gc_ocp.estimation.components import PoseCorrection, SoleCorrection

    t0 = time.perf_counter()
    fitted, res, refits = rounds(data, model, start, steps)
    dt = time.perf_counter() - t0
    pose = next(c for c in fitted if isinstance(c, PoseCorrection))
    sole = next(c for c in fitted if isinstance(c, SoleCorrection))
    if steps == 1:  # the plain way is the package's own rounds: checked
        _, pres, scale = pose_scale.estimate_pose_scale(
            data, model, start, sole=True, covariance=False
        )
        same = (
            np.allclose(
                np.r_[scale.sigma_mm, scale.sigma_deg, np.asarray(scale.sole_mm) * 1e-3],
                np.r_[pose.sigma_mm, pose.sigma_deg, np.broadcast_to(sole.sigma, 3)],
            )
            and np.isclose(pres.objective, res.objective)
            and len(scale.rounds) == refits
        )
        if not same:
            raise RuntimeError("the plain rounds differ from estimate_pose_scale's")
    prob = build_estimation(data, fitted)
    sd = pose_scale._posterior_variances(prob, res.x)
    mm, deg, _, _ = pose_scale.mackay_update(prob, res.x, pose, sd)
    sw, _ = pose_scale.sole_update(prob, res.x, sole, sd)
    now = np.r_[pose.sigma_mm, pose.sigma_deg, sole.sigma]
    step = np.r_[mm, deg, sw]
    sup = [v["superior_force_pct_bw"] for v in res.rms.values()]
    return {
        "refits": refits,
        "widths": now,
        "J": res.objective,
        "sup": float(np.mean(sup)),
        "s": dt,
        "off": float(np.max(np.abs(step / now - 1.0))),
    }


def check_local_model(data, model, start) -> str:
    """:class:`LocalModel` at new widths against the problem rebuilt with them, linearised at
    the same physical point, and one Gauss-Newton step from there (the same quadratic: they
    agree to round-off)."""
    from gc_ocp.estimation import build_estimation
    from gc_ocp.estimation.components import PoseCorrection, SoleCorrection

    prob = build_estimation(data, model)
    x = start.x
    wider = tuple(
        replace(c, sigma_mm=(3.0, 1.5, 4.0), sigma_deg=(0.5, 2.0, 1.0))
        if isinstance(c, PoseCorrection)
        else replace(c, sigma=0.008)
        if isinstance(c, SoleCorrection)
        else c
        for c in model
    )
    prob2 = build_estimation(data, wider)
    d = np.ones(x.size)
    for a, b in zip(prob.variables.specs, prob2.variables.specs, strict=True):
        d[a.slice] = b.scale / a.scale if a.kind == "prior" else 1.0
    z, v = LocalModel(prob, x).at(d)
    x2 = x / d
    r, J = prob2.data_jacobian(x2)
    w2 = prob2.prior_weights**2
    H = (J.T @ J).toarray() + np.diag(w2)
    g = J.T @ r + w2 * (x2 - prob2.prior_means)
    dz = np.max(np.abs(z - (x2 - np.linalg.solve(H, g)))) / np.max(np.abs(z))
    dv = np.max(np.abs(v / np.diag(np.linalg.inv(H)) - 1.0))
    return (
        f"Check of the local model (the first file, widths 3/1.5/4 mm, 0.5/2/1 deg, sole 8 mm): "
        f"its optimum and variances against the rebuilt problem's Gauss-Newton step differ by "
        f"{dz:.1e} and {dv:.1e} (relative)."
    )


def trace(data, model, start) -> None:
    """Each way's rounds (widths and objective per refit), then four warm restarts of Ipopt at
    the final widths from the final point."""
    from gc_ocp.estimation import build_estimation
    from gc_ocp.estimation.solve import solve

    for way, steps in (("plain", 1), ("settled", 200)):

        def say(w, j, way=way):
            print(
                f"- {way}: widths "
                + "/".join(f"{v:.2f}" for v in w[:3])
                + " mm, "
                + "/".join(f"{v:.2f}" for v in w[3:6])
                + f" deg, sole {w[6]:.2f} mm: J = {j:.1f}",
                flush=True,
            )

        fitted, res, _ = rounds(data, model, start, steps, trace=say)
        prob = build_estimation(data, fitted)
        js = []
        for _ in range(4):
            res = solve(prob, x0=res.x, covariance=False)
            js.append(f"{res.objective:.1f}")
        sup = ", ".join(f"{s} {v['superior_force_pct_bw']:.2f}" for s, v in res.rms.items())
        print(f"- {way}: four warm restarts: J = {', '.join(js)}; superior RMS % BW {sup}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--data", default=str(Path(__file__).parents[1] / ".." / "shared" / "data"))
    ap.add_argument("--only", default=None)
    ap.add_argument(
        "--trace", action="store_true", help="each round and four restarts, per file (--only)"
    )
    args = ap.parse_args()
    from gc_ocp.workflow.fitting import fit_data

    if not args.trace:
        print(
            "| file | way | refits | widths: mm x/y/z, deg x/y/z, sole mm | J | superior RMS % BW "
            "| rounds s | off the fixed point |"
        )
        print("|---|---|---|---|---|---|---|---|")
    checked = None
    for rel in WALKING:
        if args.only and args.only not in rel:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _, data, _ = fit_data([_load(Path(args.data) / rel)])
            model, start = _start(data)
            if args.trace:
                print(f"\n{rel}:\n")
                trace(data, model, start)
                continue
            checked = checked or check_local_model(data, model, start)
            rows = {w: _one(data, model, start, k) for w, k in (("plain", 1), ("settled", 200))}
        for way, r in rows.items():
            w = r["widths"]
            print(
                f"| {rel} | {way} | {r['refits']} | "
                + "/".join(f"{v:.2f}" for v in w[:3])
                + ", "
                + "/".join(f"{v:.2f}" for v in w[3:6])
                + f", {w[6] * 1e3:.1f} | {r['J']:.1f} | {r['sup']:.2f} | {r['s']:.1f} | "
                f"{100 * r['off']:.1f} % |",
                flush=True,
            )
    if checked:
        print(f"\n{checked}")


if __name__ == "__main__":
    main()
