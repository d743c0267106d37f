"""The data of ``sources_probe.py`` and ``laplace_probe.py``: the coverage benchmark's six
stances, each error source (``drift``, ``marker``, ``plate``) from its own random stream, so a
source's draw is the same whichever others are on."""

import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
import coverage as cv

from gc_ocp.diagnosis.mismatch import drift
from gc_ocp.estimation import build_estimation
from gc_ocp.estimation.pose_scale import estimate_pose_scale
from gc_ocp.estimation.solve import IpoptOptions, solve
from gc_ocp.estimation.synthetic import default_truth, noisy_pose

SIDES = cv.SIDES
truth = default_truth()
disp = cv.sole_displacement()


def make(seed, use_drift, use_marker, use_plate):
    r_d, r_m, r_p = (np.random.default_rng([seed, k]) for k in range(3))
    sts = cv.true_stances(r_m, truth, disp)
    if use_drift:
        pattern = {s: (np.zeros((2, 3)), np.zeros((2, 3))) for s in SIDES}
        sts = drift(sts, 3e-3, 0.75, r_d, 1.0, pattern=pattern)
    if use_marker:
        sts = [st.with_foot(noisy_pose(st.foot, 0.5e-3, r_m)) for st in sts]
    out = []
    for st in sts:
        sd = 0.01 * st.body_weight
        noise = cv.ar1(r_p, st.n, 0.9, 1.0, (6,)) * np.array([sd, sd, sd, *(3 * [sd * 0.02])])
        out.append(st.with_measured(st.measured + (noise if use_plate else 0)))
    return out


FLAGS = {  # variant: (drift, markers' noise, plate noise)
    "drift": (1, 0, 0),
    "marker": (0, 1, 0),
    "plate": (0, 0, 1),
    "all": (1, 1, 1),
    "drift+marker": (1, 1, 0),
}


def with_pose(model: tuple, **changes) -> tuple:
    """``model`` with its pose correction's fields ``changes`` replaced."""
    return tuple(dataclasses.replace(c, **changes) if c.name == "pose" else c for c in model)


def fitted(data, model: tuple, fixed=None) -> tuple:
    """``(model, fit)``: the pose and sole widths estimated as gc_ocp.fit does, or with
    ``fixed`` ``(mm, deg)`` the pose widths fixed there (the sole's 5 mm prior)."""
    if fixed is not None:
        model = with_pose(model, sigma_mm=fixed[0], sigma_deg=fixed[1])
    res = solve(build_estimation(data, model), IpoptOptions())
    if fixed is None:
        model, res, _ = estimate_pose_scale(data, model, res, sole=True)
    return model, res
