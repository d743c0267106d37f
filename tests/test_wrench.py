"""Wrench algebra against independent per-component formulas (seeded random wrenches)."""

import numpy as np

from gc_ocp.wrench import cop_from_wrench, free_moment, transport_moment

RNG = np.random.default_rng(0)
# Values are O(1e3) N and O(1) m; float64 round-off on sums of a few such products is ~1e-12
# relative, so 1e-9 absolute on N·m is a round-off tolerance, not a modelling one.
ATOL = 1e-9


def _cross_by_components(r, f):
    return np.column_stack(
        [
            r[:, 1] * f[:, 2] - r[:, 2] * f[:, 1],
            r[:, 2] * f[:, 0] - r[:, 0] * f[:, 2],
            r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0],
        ]
    )


def test_transport_matches_componentwise_formula_and_round_trips():
    n = 200
    f = RNG.normal(0, 500, (n, 3))
    m = RNG.normal(0, 50, (n, 3))
    a = RNG.normal(0, 1, 3)
    b = RNG.normal(0, 1, (n, 3))  # a moving reference point
    mb = transport_moment(f, m, a, b)
    expected = m + _cross_by_components(np.broadcast_to(a, (n, 3)) - b, f)
    np.testing.assert_allclose(mb, expected, rtol=0, atol=ATOL)
    np.testing.assert_allclose(transport_moment(f, mb, b, a), m, rtol=0, atol=ATOL)


def test_cop_and_free_moment_recovered_from_a_wrench_about_another_point():
    n = 50
    cop = np.column_stack([RNG.uniform(-0.3, 0.3, n), RNG.uniform(-0.2, 0.2, n), np.full(n, 0.01)])
    f = np.column_stack([RNG.normal(0, 80, n), RNG.normal(0, 40, n), RNG.uniform(100, 900, n)])
    tz = RNG.normal(0, 5, n)
    m_at_cop = np.column_stack([np.zeros(n), np.zeros(n), tz])  # pure free moment at the COP
    ref = np.array([0.2, -0.1, -0.04])  # e.g. an electrical centre below the surface
    m_ref = transport_moment(f, m_at_cop, cop, ref)
    np.testing.assert_allclose(cop_from_wrench(f, m_ref, ref, 0.01), cop, rtol=0, atol=1e-12)
    np.testing.assert_allclose(free_moment(f, m_ref, ref, 0.01), tz, rtol=0, atol=ATOL)


def test_cop_is_nan_below_min_vertical():
    f = np.array([[0.0, 0.0, 5.0], [0.0, 0.0, 500.0]])
    cop = cop_from_wrench(f, np.zeros((2, 3)), np.zeros(3), 0.0, min_vertical=20.0)
    assert np.isnan(cop[0]).all() and np.isfinite(cop[1]).all()
