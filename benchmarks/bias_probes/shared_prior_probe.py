"""Probe: the pose error a foot's strides share, in the *prior of the fit* (not only in the
covariance, as ``PoseCorrection.shared`` does). Usage::

    .venv/bin/python benchmarks/bias_probes/shared_prior_probe.py DRAWS NOISE_M [DRIFT_MM]

Each draw is ``../coverage.py``'s (3 stances per foot, AR(1) plate errors, marker noise plus a
soft-tissue drift whose pattern a foot's strides share). The default estimator is fitted as
the coverage benchmark fits it (widths estimated); then, with the share ``rho`` it measured per
foot, refitted with the smooth pose coefficients of stance s written as
``sqrt(1 - rho) v_s + sqrt(rho) E_s u`` (``v_s``, ``u`` independent N(0, width^2); ``u`` one
pattern per foot on the longest stance's knots, ``E_s`` :func:`_shared_map`): the same prior
covariance as ``prior_covariance`` gives, now in the objective, and ``u`` a variable the
stances share (the Hessian keeps its arrow). Prints per draw the errors of n, c, mu both ways
and whether each interval covers, and at the end the bias, spread and coverage both ways.
"""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from coverage import SIDES, draw, sole_displacement, values  # noqa: E402

from gc_ocp.estimation import build_estimation  # noqa: E402
from gc_ocp.estimation.components.pose import (  # noqa: E402
    PoseCorrection,
    _reference_knots,
    _shared_map,
)
from gc_ocp.estimation.pose_scale import estimate_pose_scale  # noqa: E402
from gc_ocp.estimation.solve import IpoptOptions, solve  # noqa: E402
from gc_ocp.estimation.synthetic import default_truth, recovery_model  # noqa: E402


@dataclasses.dataclass(frozen=True)
class SharedPriorPose(PoseCorrection):
    """The pose correction with a per-foot shared pattern ``u`` in its prior (module doc)."""

    rho: tuple = ()  # ((side, rho), ...)
    shared: bool = False  # the prior itself is correlated: no covariance patch

    def _rho(self, side: str) -> float:
        return dict(self.rho).get(side, 0.0)

    def declare(self, variables, stances) -> None:
        super().declare(variables, stances)
        for side in SIDES:
            sts = [st for st in stances if st.side == side]
            if len(sts) < 2 or self._rho(side) <= 0:
                continue
            K = _reference_knots(self, sts)
            st_ = np.tile(np.broadcast_to(np.asarray(self.sigma_mm, float), 3) * 1e-3, K)
            sr_ = np.tile(np.deg2rad(np.broadcast_to(np.asarray(self.sigma_deg, float), 3)), K)
            variables.prior_variable(
                (self.name, side, "u_trans"), 3 * K, st_, self.bound_sigmas * st_
            )
            variables.prior_variable(
                (self.name, side, "u_rot"), 3 * K, sr_, self.bound_sigmas * sr_
            )

    def trajectories(self, variables, i, stance):
        d, th, dd, dth = super().trajectories(variables, i, stance)
        r = self._rho(stance.side)
        if r <= 0 or not variables.has((self.name, stance.side, "u_trans")):
            return d, th, dd, dth
        B, dB = self.basis(stance.time)
        K_ref = variables.spec((self.name, stance.side, "u_trans")).size // 3
        E = _shared_map(self, stance.time, K_ref)
        a, b = np.sqrt(1 - r), np.sqrt(r)
        out = []
        for part, (v, dv) in (("u_trans", (d, dd)), ("u_rot", (th, dth))):
            U = ca.reshape(variables.get((self.name, stance.side, part)), 3, K_ref)
            C = U @ ca.DM(E.T)  # 3 x K: the stance's coefficients of the shared pattern
            out.append((a * v + b * (C @ ca.DM(B.T)), a * dv + b * (C @ ca.DM(dB.T))))
        # the marker-noise part (if any) must not be scaled: only the smooth part is (no noise
        # part in these draws: their markers are filtered at 6 Hz, ``noisy_pose``)
        (d, dd), (th, dth) = out
        return d, th, dd, dth


def refit_shared(data, fitted, res, rho):
    pose = next(c for c in fitted if isinstance(c, PoseCorrection))
    sp = SharedPriorPose(**{f.name: getattr(pose, f.name) for f in dataclasses.fields(pose)},
                         rho=tuple(rho.items()))  # fmt: skip
    model = tuple(sp if c is pose else c for c in fitted)
    pb = build_estimation(data, model)
    x0 = np.zeros(pb.variables.size)
    old = {s.key: s for s in res.variables}
    for s in pb.variables.specs:
        if s.key in old:
            v = np.asarray(res.x[old[s.key].slice], float)
            if s.key[0] == "pose" and s.key[2] in ("trans", "rot"):
                v = v / np.sqrt(
                    1 - rho.get(data[[st.label for st in data].index(s.key[1])].side, 0)
                )
            x0[s.slice] = np.clip(v, s.lb, s.ub)
    return pb, solve(pb, IpoptOptions(), x0=x0)


def main() -> None:
    draws, noise = int(sys.argv[1]), float(sys.argv[2])
    drift_mm = float(sys.argv[3]) if len(sys.argv) > 3 else 3.0
    truth, disp, model = default_truth(), sole_displacement(), recovery_model()
    rows = {"default": [], "shared prior": []}
    t0 = time.perf_counter()
    for i in range(draws):
        rng = np.random.default_rng(100 + i)
        data, seen = draw(rng, truth, disp, 0.9, noise, drift_mm, 0.25 * drift_mm)
        res = solve(build_estimation(data, model), IpoptOptions())
        fitted, res, _ = estimate_pose_scale(data, model, res, sole=True)
        rho = res.pose_shared_fraction
        pb2, res2 = refit_shared(data, fitted, res, rho)
        for label, r in (("default", res), ("shared prior", res2)):
            vals = values(r.blocks, truth, seen)
            rows[label].append(vals)
        e = [
            [v[1] - v[3] for v in vals[:3]]
            for vals in (rows["default"][-1], rows["shared prior"][-1])
        ]
        print(f"draw {i} ({time.perf_counter() - t0:.0f} s) rho {rho}: n,c,mu err default "
              f"{np.round(e[0], 4)} shared {np.round(e[1], 4)}; J {res.objective:.1f} -> "
              f"{res2.objective:.1f}", flush=True)  # fmt: skip
    for label, rs in rows.items():
        print(f"\n{label}:")
        groups: dict = {}
        for vals in rs:
            for name, est, se, tv in vals:
                key = (
                    "f_ref"
                    if name.startswith("f_ref")
                    else "sole"
                    if name.startswith("sole")
                    else name
                )
                groups.setdefault(key, []).append((est - tv, se))
        for key, v in groups.items():
            a = np.array(v)
            print(f"  {key}: bias {a[:, 0].mean():+.4f} spread {a[:, 0].std():.4f} mean SE "
                  f"{a[:, 1].mean():.4f} coverage {np.mean(np.abs(a[:, 0]) <= 1.96 * a[:, 1]):.0%}")  # fmt: skip


if __name__ == "__main__":
    main()
