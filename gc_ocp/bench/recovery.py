"""Synthetic recovery on real motion: generate plate data from a known model, fit it back.

The machinery every candidate effect is verified with (and, later, the blind benchmark of the
diagnosis):

1. :func:`real_motion` -- stances of a real trial (default: the bundled example) with their
   recorded foot kinematics;
2. :func:`truth_from_fit` -- a realistic truth: the base model fitted to those stances, frozen
   (contact parameters and sole corrections at the fitted values);
3. :func:`simulate` -- the plate data the truth model (truth + an effect with known values)
   predicts on that motion, plus plate noise, and optionally marker noise on the kinematics the
   fitter sees (defined in :mod:`gc_ocp.estimation.synthetic`, where the diagnosis's mismatch
   family can use it; the same function here);
4. fit base + effect and base alone (:func:`fit_model`), compare.

Plate noise default: white, 0.5 % BW on forces and 0.5 % BW x 20 mm on moments (the residual
of a well-zeroed plate after the 6 Hz filtering of the kinematics' rate; a COP noise of ~20 mm
at 0.5 % BW). Marker noise: :func:`gc_ocp.estimation.synthetic.noisy_pose` (three virtual
markers with iid noise, Kabsch, 6 Hz low-pass).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

from gc_ocp.estimation.components import base_model
from gc_ocp.estimation.problem import Weights, build_estimation
from gc_ocp.estimation.result import EstimationResult
from gc_ocp.estimation.solve import solve
from gc_ocp.estimation.starts import estimate, frozen_model, with_lls_start
from gc_ocp.estimation.synthetic import (  # simulate lives with the core (re-exported here)
    PLATE_NOISE_PCT_BW,
    TORQUE_NOISE_LENGTH,
    simulate,
)
from gc_ocp.io import load_trial
from gc_ocp.kinematics import compute_kinematics
from gc_ocp.stance import StanceData, trial_stances


@functools.cache
def _bundled():

    t = load_trial()
    return t, compute_kinematics(t)


def real_motion(trial=None, kinematics=None, margin: float = 0.03) -> list[StanceData]:
    """Stances (recorded kinematics and plate data) of ``trial`` (default: the bundled example)."""
    if trial is None:
        trial, kinematics = _bundled()
    return trial_stances(trial, kinematics, margin=margin, min_frames=5)


def fit_model(stances: Sequence[StanceData], model: tuple, weights: Weights | None = None, x0=None):
    """One Ipopt solve of ``model`` on ``stances`` (no restarts): a :class:`EstimationResult`."""
    pb = build_estimation(list(stances), model, weights)
    return solve(pb, x0=None if x0 is None else x0(pb))


def truth_from_fit(stances: Sequence[StanceData], base: tuple) -> tuple:
    """The base model fitted to ``stances`` (initialised from the seed's LLS as ``fit`` does),
    every component frozen at its fitted block except the stance-scope ones (pose correction),
    which the truth leaves at zero: the recorded kinematics are the truth's motion."""
    model = with_lls_start(base, list(stances))
    res = estimate(list(stances), model)
    return tuple(c for c in frozen_model(model, res) if c.scope != "stance")


@functools.cache
def _bundled_base_truth() -> tuple[tuple[StanceData, ...], tuple]:

    stances = tuple(real_motion())
    return stances, truth_from_fit(list(stances), base_model())


def bundled_base_truth() -> tuple[list[StanceData], tuple]:
    """``(stances, truth)``: the bundled trial's stances (:func:`real_motion`) and the base model
    (``base_model()``) fitted to them, frozen (:func:`truth_from_fit`). The common start of the
    effect recoveries and of the withheld-effect benchmark; fitted once per process (a fresh
    list each call, the stances and components themselves are immutable)."""
    stances, truth = _bundled_base_truth()
    return list(stances), truth


def rms_line(result: EstimationResult) -> str:
    """One line of ``{side: {channel: RMS}}`` (% BW, % BW x H) of a result, for reports."""
    return "; ".join(
        f"{side}: " + ", ".join(f"{ch} {v:.2f}" for ch, v in ch_rms.items())
        for side, ch_rms in result.rms.items()
    )


def started_from_truth(model: tuple, truth: tuple) -> tuple:
    """``model`` with its contact law started at the truth law's per-unit stiffnesses (a warm
    start such as a base fit gives; the law is the component with ``with_initial_k``)."""
    law = next(c for c in truth if hasattr(c, "with_initial_k"))
    return tuple(
        c.with_initial_k(law.k.value) if hasattr(c, "with_initial_k") else c for c in model
    )


__all__ = [
    "PLATE_NOISE_PCT_BW",
    "TORQUE_NOISE_LENGTH",
    "bundled_base_truth",
    "fit_model",
    "real_motion",
    "rms_line",
    "simulate",
    "started_from_truth",
    "truth_from_fit",
]
