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
    np.testing.assert_array_equal(cens[c][:, [0, 1, 3, 4, 5]], 0.0)
    np.testing.assert_array_equal(cens[c][:, 2], np.maximum(wrench[c, 2] - 25.0, 0) * inv[2])
    np.testing.assert_array_equal(cens[~c], plain[~c])


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
