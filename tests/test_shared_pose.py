"""The pose error the stances of a foot share (``PoseCorrection.shared``): measured from the
fitted corrections and taken into the covariance (``docs/quality.md``, "A pose error the
strides share"). Whether the intervals then cover under a shared soft-tissue drift is scored by
``benchmarks/coverage.py --drift-mm``; these tests check the parts."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import synthetic_stances

from gc_ocp.estimation.components.pose import shared_fraction
from gc_ocp.estimation.problem import build_estimation
from gc_ocp.estimation.solve import result_at
from gc_ocp.estimation.synthetic import recovery_model


@pytest.fixture(scope="module")
def problem():
    sts, _ = synthetic_stances(np.random.default_rng(0), 0.0, per_foot=3)
    return build_estimation(sts, recovery_model(marker_noise=False))


def _pose(problem):
    comp = next(c for c in problem.model if c.name == "pose")
    specs = [s for s in problem.variables.specs if s.key[0] == "pose" and s.key[2] != "noise"]
    return comp, specs


def _independent(model: tuple) -> tuple:
    """``model`` with the pose errors of a foot's stances taken as independent."""
    return tuple(dataclasses.replace(c, shared=False) if c.name == "pose" else c for c in model)


def _with(problem, coefficients) -> np.ndarray:
    """``x0`` with each stance's smooth pose coefficients from ``coefficients(spec)``."""
    x = problem.x0.copy()
    for s in _pose(problem)[1]:
        x[s.slice] = coefficients(s)
    return x


def test_every_stance_the_same_correction_is_all_shared_and_opposite_ones_none(problem):
    comp, specs = _pose(problem)
    assert len({s.size for s in specs}) == 1  # the synthetic stances have the same knots
    pattern = np.random.default_rng(1).normal(size=specs[0].size)
    same = _with(problem, lambda s: pattern)
    rho = shared_fraction(comp, problem.variables.specs, problem.stances, same)
    assert rho == pytest.approx({"left": 1.0, "right": 1.0}, abs=1e-12)
    # stances 0 and 1 opposite, stance 2 none: the mean product is negative, clipped to 0
    sign = {"0": 1.0, "1": -1.0, "2": 0.0}
    opposite = _with(problem, lambda s: sign[s.key[1][-1]] * pattern)
    rho = shared_fraction(comp, problem.variables.specs, problem.stances, opposite)
    assert rho == {"left": 0.0, "right": 0.0}


def test_independent_corrections_share_little(problem):
    comp, _ = _pose(problem)
    rng = np.random.default_rng(2)
    rhos = [
        shared_fraction(
            comp,
            problem.variables.specs,
            problem.stances,
            _with(problem, lambda s: rng.normal(size=s.size)),
        )["left"]
        for _ in range(50)
    ]
    # the mean product of two independent standard trajectories over the mean square has mean
    # 0; clipped at 0, the measured share's mean over 50 draws stays well under 0.2 (its
    # unclipped SD is about 1 / sqrt(6 axes x knots) / sqrt(3 pairs), ~0.1 per draw)
    assert np.mean(rhos) < 0.2 and np.median(rhos) < 0.1


def test_the_covariance_of_the_true_coefficients_keeps_each_prior_and_is_valid(problem):
    comp, specs = _pose(problem)
    x = _with(problem, lambda s: np.random.default_rng(3).normal(size=s.size))
    blocks = comp.prior_covariance(problem.variables.specs, problem.stances, x)
    assert len(blocks) == 2 * 2 * 3  # per foot, translation and rotation, three axes
    rho = shared_fraction(comp, problem.variables.specs, problem.stances, x)["left"]
    cols, C = blocks[0]
    K = specs[0].size // 3
    assert C.shape == (3 * K, 3 * K) and cols.size == 3 * K
    assert np.allclose(np.diag(C), 1.0)  # every coefficient keeps its prior's variance
    assert np.linalg.eigvalsh(C).min() > -1e-12  # a covariance
    # stances with the same knots: a coefficient shares rho with the same knot of the others
    assert np.allclose(C[:K, K : 2 * K], rho * np.eye(K))


def test_one_stance_per_foot_leaves_the_covariance_as_declared():
    sts, _ = synthetic_stances(np.random.default_rng(0), 0.0, per_foot=1)
    model = recovery_model(marker_noise=False)
    pb = build_estimation(sts, model)
    x = _with(pb, lambda s: np.random.default_rng(4).normal(size=s.size))
    comp = next(c for c in model if c.name == "pose")
    assert comp.prior_covariance(pb.variables.specs, pb.stances, x) == []
    a = result_at(pb, x).covariance
    b = result_at(build_estimation(sts, _independent(model)), x).covariance
    assert np.array_equal(a, b)


def test_a_shared_correction_widens_the_exponent_and_is_reported(problem):
    """At a point where every stance of a foot carries the same correction (rho = 1), the
    exponent's SE grows: what the pose prior lets each stance absorb no longer averages out
    over the three stances."""
    pattern = np.random.default_rng(5).normal(size=_pose(problem)[1][0].size)
    x = _with(problem, lambda s: pattern)
    shared = result_at(problem, x)
    independent = result_at(build_estimation(problem.stances, _independent(problem.model)), x)
    assert shared.pose_shared_fraction == pytest.approx({"left": 1.0, "right": 1.0})
    assert independent.pose_shared_fraction == {}
    se = {r: res.params["shared"]["n_se"] for r, res in (("s", shared), ("i", independent))}
    assert se["s"] > se["i"]


def test_the_knots_correlation_is_estimated_from_the_coefficients_and_their_uncertainty(problem):
    """``pose_scale.knot_correlation_update``: the EM step's lag-1 correlation of
    ``L (z z^T + S) L^T``. Coefficients drawn from an AR(1) of 0.8 give back ~0.8, white ones
    ~0, and coefficients the data did not inform (z = 0, S = I) 0, not the posterior's
    smoothing; under a correlated prior the stored white variables map back through L."""
    from gc_ocp.estimation.pose_scale import ar1_knot_correlation, knot_correlation_update

    comp, specs = _pose(problem)
    rng = np.random.default_rng(3)
    n = problem.x0.size

    def draw(phi, pose):
        x = np.zeros(n)
        for s in specs:
            K = s.size // 3
            C = phi ** np.abs(np.subtract.outer(np.arange(K), np.arange(K)))
            c = np.linalg.cholesky(C) @ rng.standard_normal((K, 3))  # (K, 3) per axis
            x[s.slice] = np.linalg.solve(pose.correlation_factor(K), c).ravel()  # z = L^-1 c
        return x

    # 6 stances x 2 parts x 3 axes x ~8 neighbouring pairs: the lag-1 estimate's SD is
    # (1 - phi^2) / sqrt(~290), 0.06 at 0 and 0.02 at 0.8; 0.15 is over two of the larger
    zero = np.zeros((n, n))
    assert knot_correlation_update(problem, draw(0.8, comp), comp, zero) == pytest.approx(
        0.8, abs=0.15
    )
    assert knot_correlation_update(problem, draw(0.0, comp), comp, zero) == pytest.approx(
        0.0, abs=0.15
    )
    assert knot_correlation_update(problem, np.zeros(n), comp, np.eye(n)) == 0.0
    correlated = dataclasses.replace(
        comp, knot_correlation=ar1_knot_correlation(0.6, comp, problem.stances)
    )
    assert correlated.knot_correlation[:3] == pytest.approx((1.0, 0.6, 0.36))
    assert knot_correlation_update(
        problem, draw(0.8, correlated), correlated, zero
    ) == pytest.approx(0.8, abs=0.15)
    assert ar1_knot_correlation(0.0, comp, problem.stances) is None


def test_a_fit_refuses_the_knots_correlation_without_the_width_rounds():
    from gc_ocp.errors import InputError
    from gc_ocp.workflow.fitting import fit

    with pytest.raises(InputError, match="pose width's rounds"):
        fit([], pose_scale=False, sole_scale=False, pose_correlation=True)
