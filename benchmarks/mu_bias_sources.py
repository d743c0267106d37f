"""Where does the friction coefficient's bias under marker noise come from? (issue 23)

Usage::

    PYTHONPATH=. python benchmarks/mu_bias_sources.py [--draws 4] > benchmarks/mu_bias_sources_output.md

The synthetic stances of ``benchmarks/coverage.py`` (6 stances, 3 per foot, the same truth,
sole displacement and AR(1) plate errors), fitted by one Ipopt solve of the recovery model with
the pose correction's guessed width (2 mm, 1 deg; the estimated width changes none of the
readings, ``coverage_output.md``), under one kinematic error at a time:

* marker noise alone at 0.5, 1 and 2 mm (Kabsch of four virtual markers, 6 Hz low-pass);
* 1 mm of noise plus a 3 mm soft-tissue error on one axis, either an offset or a linear trend
  over the stance (a constant apparent sliding velocity), its sign per foot;
* 1 mm of noise with the noise part's width scaled x0.5 and x2 (is the noise part too narrow?);
* 1 mm of noise with a wider smooth correction (5 and 20 mm per knot).

Prints the mean error of n, c and mu over the draws (truth 1.5, 1.0, 0.8) and mu's spread.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import coverage as cv  # noqa: E402  (the coverage benchmark's draws)

from gc_ocp.estimation import build_estimation  # noqa: E402
from gc_ocp.estimation.components.pose import PoseCorrection  # noqa: E402
from gc_ocp.estimation.solve import IpoptOptions, solve  # noqa: E402
from gc_ocp.estimation.synthetic import (  # noqa: E402
    default_truth,
    noisy_pose,
    recovery_model,
    with_pose_error,
)

CASES = (
    ("noise 0.5 mm", dict(noise=0.5e-3)),
    ("noise 1 mm", dict(noise=1e-3)),
    ("noise 2 mm", dict(noise=2e-3)),
    ("1 mm + offset x 3 mm", dict(noise=1e-3, axis=0, kind="offset")),
    ("1 mm + offset y 3 mm", dict(noise=1e-3, axis=1, kind="offset")),
    ("1 mm + trend x 3 mm", dict(noise=1e-3, axis=0, kind="trend")),
    ("1 mm + trend y 3 mm", dict(noise=1e-3, axis=1, kind="trend")),
    ("1 mm + trend z 3 mm", dict(noise=1e-3, axis=2, kind="trend")),
    ("1 mm, noise part x0.5", dict(noise=1e-3, noise_scale=0.5)),
    ("1 mm, noise part x2", dict(noise=1e-3, noise_scale=2.0)),
    ("1 mm, smooth width 5 mm", dict(noise=1e-3, width=5.0)),
    ("1 mm, smooth width 20 mm", dict(noise=1e-3, width=20.0)),
)


def stances(rng, truth, disp, noise, axis=None, kind=None, noise_scale=1.0):
    out = []
    sign = {s: rng.choice([-1.0, 1.0]) for s in cv.SIDES}
    # synthetic_stance draws nothing without noise: the stream's order is the loop's below
    for st in cv.true_stances(rng, truth, disp):
        t = st.time
        if axis is not None:
            s = (2 * (t - t[0]) / (t[-1] - t[0]) - 1) * np.sqrt(3)  # unit RMS
            tr = np.zeros((t.size, 3))
            tr[:, axis] = 3e-3 * sign[st.side] * (s if kind == "trend" else 1.0)
            st = st.with_foot(with_pose_error(st.foot, np.zeros((t.size, 3)), tr))
        st = st.with_foot(noisy_pose(st.foot, noise, rng))
        if noise_scale != 1.0:
            pn = st.foot.pose_noise
            pn = dataclasses.replace(
                pn, cov=pn.cov * noise_scale**2, sigma_marker=pn.sigma_marker * noise_scale
            )
            st = st.with_foot(dataclasses.replace(st.foot, pose_noise=pn))
        sd = 0.01 * st.body_weight
        e = cv.ar1(rng, st.n, 0.9, 1.0, (6,)) * np.array([sd, sd, sd, *(3 * [sd * 0.02])])
        out.append(st.with_measured(st.measured + e))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--draws", type=int, default=4)
    args = ap.parse_args()
    truth = default_truth()
    disp = cv.sole_displacement()
    print(
        f"# The friction coefficient's bias: one kinematic error at a time ({args.draws} draws)\n"
    )
    print("| kinematic error | n error | c error | mu error | mu spread |")
    print("|---|---|---|---|---|")
    for name, case in CASES:
        case = dict(case)
        width = case.pop("width", None)
        model = recovery_model()
        if width is not None:
            model = tuple(
                dataclasses.replace(c, sigma_mm=width, sigma_deg=width / 2)
                if isinstance(c, PoseCorrection)
                else c
                for c in model
            )
        errs = []
        for i in range(args.draws):
            data = stances(np.random.default_rng(100 + i), truth, disp, **case)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = solve(build_estimation(data, model), IpoptOptions())
            p = res.params["shared"]
            errs.append([p["n"] - truth["n"], p["c"] - truth["c"], p["mu"] - truth["mu"]])
        e = np.array(errs)
        m = e.mean(axis=0)
        print(f"| {name} | {m[0]:+.3f} | {m[1]:+.3f} | {m[2]:+.4f} | {e[:, 2].std():.4f} |")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
