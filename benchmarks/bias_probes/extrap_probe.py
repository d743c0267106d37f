"""One-off probe of the bias correction (issue 23); see README.md beside it.

Does the replicates' bias, measured with one and with two portions of the kinematic error
(the smooth pose error and the markers' noise a replicate draws) already in the replicates'
truth motion, extrapolate to none (``2 b1 - b2``), the bias the true motion gives (``b0``, the
oracle)? Usage: ``extrap_probe.py NOISE_M DRAWS B [DRIFT_MM]`` (``DRAWS`` comma-separated; the
drift as ``coverage.py --drift-mm``, default none).
"""

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
import coverage as cv

from gc_ocp.estimation import build_estimation
from gc_ocp.estimation.bias import (
    draw_pose_drift,
    draw_pose_noise,
    recorded_truth,
    replicate_data,
)
from gc_ocp.estimation.pose_scale import estimate_pose_scale
from gc_ocp.estimation.solve import IpoptOptions, solve
from gc_ocp.estimation.starts import rescaled_start
from gc_ocp.estimation.synthetic import default_truth, recovery_model

PARAMS = ("n", "c", "mu")


def replicate_bias(motion, fitted, res, rng, B):
    """Mean change of n, c, mu over ``B`` replicates whose truth walks ``motion``."""
    tr = recorded_truth(motion, fitted, res)
    base = np.array([res.params["shared"][p] for p in PARAMS])
    ch = []
    for _ in range(B):
        rep = replicate_data(motion, fitted, res, rng, truth=tr)
        pr = build_estimation(rep, fitted)
        rr = solve(pr, IpoptOptions(), x0=rescaled_start(res, pr), covariance=False)
        ch.append(np.array([rr.params["shared"][p] for p in PARAMS]) - base)
    return np.mean(ch, axis=0), np.std(ch, axis=0, ddof=1) / np.sqrt(B)


def main():
    noise = float(sys.argv[1])
    draws = [int(s) for s in sys.argv[2].split(",")]
    B = int(sys.argv[3])
    dmm = float(sys.argv[4]) if len(sys.argv) > 4 else 0.0
    truth = default_truth()
    disp = cv.sole_displacement()
    model = recovery_model()
    tv = np.array([truth[p] for p in PARAMS])
    fmt = lambda v: "[" + " ".join(f"{x:+.4f}" for x in v) + "]"  # noqa: E731
    for i in draws:
        t0 = time.perf_counter()
        rng = np.random.default_rng(100 + i)
        data, _ = cv.draw(rng, truth, disp, 0.9, noise, dmm, 0.25 * dmm, False)
        # the true motion of the same draw: the synthetic motion is deterministic, only the
        # markers' noise is drawn (the pose-noise model of the data kept)
        true_sts = cv.true_stances(np.random.default_rng(0), truth, disp)
        res = solve(build_estimation(data, model), IpoptOptions())
        fitted, res, _ = estimate_pose_scale(data, model, res, sole=True)
        err = np.array([res.params["shared"][p] for p in PARAMS]) - tv
        r = np.random.default_rng(7 + i)
        b1, s1 = replicate_bias(data, fitted, res, r, B)
        # two portions: the truth walks the recorded motion seen once more as a replicate's
        # fitter sees it (the smooth pose error, then the markers' noise)
        motion2 = [
            d.with_foot(draw_pose_noise(v.foot, r))
            for d, v in zip(data, draw_pose_drift(data, fitted, res, r), strict=True)
        ]
        b2, s2 = replicate_bias(motion2, fitted, res, r, B)
        motion0 = [
            dataclasses.replace(d, foot=dataclasses.replace(t.foot, pose_noise=d.foot.pose_noise))
            for d, t in zip(data, true_sts, strict=True)
        ]
        b0, s0 = replicate_bias(motion0, fitted, res, r, B)
        print(
            f"draw {i}: fit err {fmt(err)} | b1 {fmt(b1)} | b2 {fmt(b2)} | 2b1-b2 "
            f"{fmt(2 * b1 - b2)} | oracle b0 {fmt(b0)} | MC se b1 {fmt(s1)} b0 {fmt(s0)} "
            f"({time.perf_counter() - t0:.0f} s)",
            flush=True,
        )


if __name__ == "__main__":
    main()
