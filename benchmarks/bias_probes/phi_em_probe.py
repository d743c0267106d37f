"""One-off probe (issue 23; README.md beside it): can the pose correction's knot-to-knot
correlation be *estimated* (as its widths are), instead of fixed at 0.9 as
``coverage.py --knot-correlation 0.9`` did?

``phi_em_probe.py DRAWS [NOISE_MM] [DRIFT_MM]``: per draw (coverage.py's draws, drift per
stance; ``DRIFT_MM`` 0: the markers' noise only), rounds of: fit with the current AR(1)
correlation ``phi`` (widths estimated, as gc_ocp.fit), then the EM update of the coefficients'
second moment in their own units, ``L (z z^T + S) L^T`` averaged along its diagonals over every
stance and axis of a part (``z`` the stored coefficients, ``S`` their posterior covariance, ``L``
the prior's correlation factor), and ``phi`` <- its lag-1 correlation (pooled over translation
and rotation; the step is now the package's ``pose_scale.knot_correlation_update``, the same
sums the probe first wrote out). Prints ``phi`` per round and mu's and n's errors."""

import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
import coverage as cv

from gc_ocp.estimation import build_estimation
from gc_ocp.estimation.components.pose import PoseCorrection
from gc_ocp.estimation.pose_scale import (
    _posterior_covariance,
    ar1_knot_correlation,
    estimate_pose_scale,
    knot_correlation_update,
)
from gc_ocp.estimation.solve import IpoptOptions, solve
from gc_ocp.estimation.synthetic import default_truth, recovery_model


def with_phi(model, phi, stances):
    return tuple(
        dataclasses.replace(c, knot_correlation=ar1_knot_correlation(phi, c, stances))
        if isinstance(c, PoseCorrection)
        else c
        for c in model
    )


truth = default_truth()
disp = cv.sole_displacement()
noise = (float(sys.argv[2]) if len(sys.argv) > 2 else 0.5) * 1e-3
drift_mm = float(sys.argv[3]) if len(sys.argv) > 3 else 3.0
for i in [int(a) for a in sys.argv[1].split(",")]:
    rng = np.random.default_rng(100 + i)
    data, seen = cv.draw(rng, truth, disp, 0.9, noise, drift_mm, 0.25 * drift_mm, True)
    phi, row = 0.0, []
    for _ in range(5):
        model = with_phi(recovery_model(), phi, data)
        res = solve(build_estimation(data, model), IpoptOptions())
        fitted, res, _ = estimate_pose_scale(data, model, res, sole=True)
        pose = next(c for c in fitted if isinstance(c, PoseCorrection))
        sh = res.params["shared"]
        row.append(
            f"phi {phi:.2f}: mu {sh['mu'] - truth['mu']:+.4f} (SE {sh['mu_se']:.4f}) "
            f"n {sh['n'] - truth['n']:+.4f} (SE {sh['n_se']:.3f})"
        )
        pb = build_estimation(data, fitted)
        new = knot_correlation_update(pb, res.x, pose, _posterior_covariance(pb, res.x))
        if abs(new - phi) < 0.02:
            break
        phi = new
    print(
        f"draw {i} (noise {noise * 1e3:g} mm, drift {drift_mm:g} mm): " + " | ".join(row),
        flush=True,
    )
