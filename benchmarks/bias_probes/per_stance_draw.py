"""The fit the per-stance-drift probes start from (``cluster_probe.py``, ``jackknife_probe.py``,
``knot_corr_probe.py``): coverage.py's draw ``i`` with a drift per stance (3 mm / 0.75 deg)
and ``noise`` [m] of marker noise, fitted as gc_ocp.fit does (the pose and sole widths
estimated)."""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
import coverage as cv

from gc_ocp.estimation import build_estimation
from gc_ocp.estimation.pose_scale import estimate_pose_scale
from gc_ocp.estimation.solve import IpoptOptions, solve
from gc_ocp.estimation.synthetic import default_truth, recovery_model

TRUTH = default_truth()


def fitted_draw(i: int, noise: float):
    """``(data, fitted model, its fit, the widths' estimate)`` of draw ``i``."""
    rng = np.random.default_rng(100 + i)
    data, _ = cv.draw(rng, TRUTH, cv.sole_displacement(), 0.9, noise, 3.0, 0.75, True)
    model = recovery_model()
    res = solve(build_estimation(data, model), IpoptOptions())
    fitted, res, sc = estimate_pose_scale(data, model, res, sole=True)
    return data, fitted, res, sc


def draws_and_noise(default_mm: float) -> tuple[list[int], float]:
    """The probes' arguments: ``DRAWS`` (comma-separated) and ``[NOISE_MM]``."""
    noise = (float(sys.argv[2]) if len(sys.argv) > 2 else default_mm) * 1e-3
    return [int(a) for a in sys.argv[1].split(",")], noise
