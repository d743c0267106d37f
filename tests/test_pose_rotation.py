"""The pose correction's rotation (``gc_ocp.geometry.correction_offset``): a rigid motion at
any size, the same in the fit's CasADi function and in the export's NumPy placement."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pinocchio as pin

from gc_ocp.geometry import correction_motion, correction_offset, correction_rotation


def test_the_correction_is_a_rotation_equal_to_the_first_order_form_when_small():
    rng = np.random.default_rng(0)
    for size in (1e-4, 0.05, 0.25, 1.0):  # up to 57 deg
        theta = size * rng.normal(size=3) / np.sqrt(3)
        R = correction_rotation(theta)
        # orthonormal with determinant 1 to round-off (1e-12 of terms of order 1)
        assert np.allclose(R @ R.T, np.eye(3), atol=1e-12) and np.isclose(np.linalg.det(R), 1.0)
        # a rotation by 2 atan(|theta| / 2) about theta: the Cayley map of theta / 2
        angle = 2 * np.arctan(np.linalg.norm(theta) / 2)
        assert np.allclose(R, pin.exp3(theta / np.linalg.norm(theta) * angle), atol=1e-12)
    # first order: theta x r, up to the second-order term theta x (theta x r) / 2, at most
    # |theta|^2 |r| / 2 (3e-9 m here), and that term is what is left
    theta, r = np.array([1e-4, -2e-4, 5e-5]), np.array([0.1, 0.05, -0.03])
    bound = np.dot(theta, theta) * np.linalg.norm(r) / 2
    off = correction_offset(theta, r)
    assert np.linalg.norm(off - np.cross(theta, r)) <= bound
    second = np.cross(theta, np.cross(theta, r)) / 2
    assert np.linalg.norm(off - np.cross(theta, r) - second) < 1e-3 * bound


def test_casadi_and_numpy_give_the_same_points_and_rates():
    """The fit's per-frame expression (``cross=ca.cross``) against NumPy, and its rate against
    a central difference along a path ``theta(t), r(t)`` (step 1e-6 s: the difference's error,
    ``h^2 / 6`` of the third derivative, is far below the 1e-8 tolerance)."""
    th, r = ca.SX.sym("th", 3), ca.SX.sym("r", 3)
    thd, rd = ca.SX.sym("thd", 3), ca.SX.sym("rd", 3)
    f = ca.Function("f", [th, r], [correction_offset(th, r, ca.cross)])
    g = ca.Function("g", [th, thd, r, rd], list(correction_motion(th, thd, r, rd, ca.cross)))
    theta0, dtheta = np.array([0.2, -0.1, 0.15]), np.array([0.5, 0.3, -0.4])
    r0, dr = np.array([0.12, 0.04, -0.02]), np.array([0.3, -0.2, 0.1])
    assert np.allclose(np.asarray(f(theta0, r0)).ravel(), correction_offset(theta0, r0))
    offset, rate = (np.asarray(v).ravel() for v in g(theta0, dtheta, r0, dr))
    assert np.allclose(offset, correction_offset(theta0, r0))
    h = 1e-6
    fd = (
        correction_offset(theta0 + h * dtheta, r0 + h * dr)
        - correction_offset(theta0 - h * dtheta, r0 - h * dr)
    ) / (2 * h)
    assert np.allclose(rate, fd, atol=1e-8)
    assert np.allclose(rate, correction_motion(theta0, dtheta, r0, dr)[1])
