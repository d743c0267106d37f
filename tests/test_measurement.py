"""The measurement model (``gc_ocp.estimation.measurement``): one residual for both backends,
censored samples below the plate's threshold."""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest

from gc_ocp.bench.truth import Realism, base_truth, generate, motion
from gc_ocp.errors import InputError
from gc_ocp.estimation.measurement import CASADI, censored, residual, stance_residuals
from gc_ocp.estimation.problem import build_estimation


def test_the_casadi_and_numpy_residuals_are_one_definition():
    rng = np.random.default_rng(0)
    T = 50
    wrench = rng.normal(0, 100, (T, 6))
    measured = rng.normal(0, 100, (T, 6))
    measured[:20, 2] = 0.0  # zeroed samples
    measured[20:30, 2] = rng.uniform(0, 30, 10)  # resampled edge values below the threshold
    inv = rng.uniform(0.5, 2, 6)
    w, m, s, x = (ca.SX.sym(n, k) for n, k in (("w", 6), ("m", 6), ("s", 6), ("x", 1)))
    f = ca.Function("r", [w, m, s, x], [ca.vertcat(*residual(w, m, s, x, CASADI))])
    for thr in (0.0, 25.0):
        ref = stance_residuals(wrench, measured, inv, thr)
        got = np.array([np.asarray(f(wrench[t], measured[t], inv, thr)).ravel() for t in range(T)])
        np.testing.assert_allclose(got, ref, rtol=1e-14, atol=1e-12)  # same arithmetic
    plain = stance_residuals(wrench, measured, inv, 0.0)
    np.testing.assert_array_equal(plain, (wrench - measured) * inv)  # no threshold: unchanged
    c = censored(measured, 25.0)
    cens = stance_residuals(wrench, measured, inv, 25.0)
    assert c.sum() >= 20
    zero = measured[:, 2] == 0.0  # a recorded zero: wholly censored
    np.testing.assert_array_equal(cens[zero][:, [0, 1, 3, 4, 5]], 0.0)
    np.testing.assert_array_equal(cens[zero][:, 2], np.maximum(wrench[zero, 2] - 25.0, 0) * inv[2])
    np.testing.assert_array_equal(cens[~c], plain[~c])  # at or above the threshold: data
    # between 0 and the threshold (resampled): the smoothstep blend of the two
    mid = c & ~zero
    u = np.clip(measured[mid, 2] / 25.0, 0.0, 1.0)  # below 0 (noise): wholly censored
    sw = (u * u * (3 - 2 * u))[:, None]
    above = np.zeros((mid.sum(), 6))
    d = wrench[mid, 2] - 25.0
    eps = sw[:, 0] * 25.0
    ramp = np.where(eps > 0, 0.5 * (d + np.sqrt(d * d + eps * eps)), np.maximum(d, 0))
    above[:, 2] = ramp * inv[2]
    np.testing.assert_allclose(cens[mid], sw * plain[mid] + (1 - sw) * above, rtol=1e-12)


def test_a_partly_censored_cost_has_no_kink_in_the_model_force():
    """On a resampled sample between 0 and the threshold, the cost's slope in the model's
    vertical force does not jump where that force crosses the threshold (a jump there stalled
    Ipopt); on a wholly censored sample the ramp is exact (0 below the threshold)."""
    fz = np.linspace(20.0, 60.0, 40001)  # the model force sweeps across X = 40 N
    model = np.zeros((fz.size, 6))
    model[:, 2] = fz
    for m_z in (10.0, 25.0, 39.0):  # partly censored measurements
        measured = np.zeros((fz.size, 6))
        measured[:, 2] = m_z
        cost = 0.5 * np.sum(stance_residuals(model, measured, np.ones(6), 40.0) ** 2, axis=1)
        slope = np.diff(cost) / np.diff(fz)
        # the slope changes by at most (max curvature ~ 1 + 1 / eps) x step: < 1e-2 per 1 mN
        assert np.abs(np.diff(slope)).max() < 1e-2, m_z
    measured = np.zeros((fz.size, 6))  # a recorded zero: wholly censored, exact ramp
    r = stance_residuals(model, measured, np.ones(6), 40.0)
    np.testing.assert_array_equal(r[:, 2], np.maximum(fz - 40.0, 0.0))


def test_the_censored_residual_is_continuous_in_the_measurement():
    """A clock offset moves a resampled measurement across the threshold: the residual and its
    slope must not jump there (a jump left Ipopt cycling, see the module doc). Checked by
    finite differences over a fine sweep of the measured vertical force through 0 and X."""
    wrench = np.array([3.0, -2.0, 60.0, 0.5, -0.4, 0.1])
    inv = np.ones(6)
    fz = np.linspace(-5.0, 45.0, 50001)  # step 1e-3 N
    measured = np.tile([1.0, 1.0, 0.0, 0.2, 0.2, 0.0], (fz.size, 1))
    measured[:, 2] = fz
    r = stance_residuals(np.tile(wrench, (fz.size, 1)), measured, inv, 40.0)
    jump = np.abs(np.diff(r, axis=0)).max()
    # the largest slope of the blend is ~1.5 x (plain - censored) / X per N, here < 10 N / N:
    # a step of 1e-3 N moves the residual by < 1e-2; a switch would move it by ~60 at once
    assert jump < 1e-2
    slope = np.diff(r, axis=0) / 1e-3
    assert np.abs(np.diff(slope, axis=0)).max() < 1e-1  # C1: no kink either


def test_thresholded_plates_are_reproduced_exactly_by_the_truth_under_censoring():
    """Noiseless data of a known truth with the plate zeroed below 40 N: under the measurement
    model the truth has no data cost at all (every zeroed sample is a force the truth keeps below
    the threshold); compared as plain zeros, the rising and falling edges cost it."""
    stances = motion("registered")
    truth = base_truth("registered")
    data = generate(
        stances,
        truth,
        np.random.default_rng(0),
        Realism(plate_noise_pct_bw=0.0, force_threshold=40.0),
    )
    assert any(censored(d.measured, 40.0)[d.in_contact].any() for d in data)  # edges are cut
    costs = {}
    for thr in (0.0, 40.0):
        d = [dataclasses.replace(s, censor_below=thr) for s in data]
        pb = build_estimation(d, truth)
        costs[thr] = pb.costs(np.zeros(pb.x0.size))[0]
    # round-off of the per-frame wrench against the simulated one (same functions): ~1e-20
    assert costs[40.0] < 1e-12
    assert costs[0.0] > 1.0  # tens of N at a 2 % BW error scale, on several frames


def test_a_negative_threshold_is_refused():
    st = motion("registered")[0]
    with pytest.raises(InputError, match="censor_below"):
        dataclasses.replace(st, censor_below=-1.0)
