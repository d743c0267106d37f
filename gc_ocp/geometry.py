"""Pure numerics on rigid-body geometry (NumPy only: no Pinocchio, no I/O).

Arrays are time-first: a sequence of ``n`` frames of ``m`` points is ``(n, m, 3)``; positions are
in [m].
"""

from __future__ import annotations

import numpy as np


def _kabsch_one(local: np.ndarray, lab: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    cl, cw = local.mean(0), lab.mean(0)
    H = (local - cl).T @ (lab - cw)
    U, _, Vt = np.linalg.svd(H)
    d = -1.0 if np.linalg.det(Vt.T @ U.T) < 0 else 1.0  # reflection -> nearest proper rotation
    R = Vt.T @ np.diag([1, 1, d]) @ U.T
    return R, cw - R @ cl


def kabsch(local: np.ndarray, lab: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rigid fit (Kabsch): the rotation ``R`` and translation ``t`` minimising
    ``sum_i || R @ local[i] + t - lab[i] ||^2`` (unweighted least squares).

    local: ``(m, 3)`` point positions in the body frame [m], ``m >= 3`` not all collinear.
    lab: ``(m, 3)`` the same points measured in the lab frame [m], or ``(n, m, 3)`` for ``n``
        frames (time first), each frame fitted independently. NaN rows are not removed: select
        the visible points before calling.

    Returns ``R`` ``(3, 3)`` and ``t`` ``(3,)`` [m], or ``(n, 3, 3)`` and ``(n, 3)`` for an
    ``(n, m, 3)`` ``lab``. ``R`` is always a proper rotation (``det R = +1``): when the best
    orthogonal fit is a reflection (noisy, nearly coplanar points) the smallest singular
    direction is flipped, which gives the best rotation.

    >>> import numpy as np
    >>> local = np.array([[0.0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]])
    >>> Rz = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    >>> R, t = kabsch(local, local @ Rz.T + [1.0, 2.0, 0.0])
    >>> np.allclose(R, Rz), np.allclose(t, [1, 2, 0])
    (True, True)
    """
    local = np.asarray(local, dtype=float)
    lab = np.asarray(lab, dtype=float)
    if local.ndim != 2 or local.shape[1] != 3 or local.shape[0] < 3:
        raise ValueError(f"local must be (m, 3) with m >= 3 points, but got {local.shape}")
    if lab.shape[-2:] != local.shape or lab.ndim not in (2, 3):
        raise ValueError(
            f"lab must be {local.shape} or (n, {local.shape[0]}, 3) like local, but got {lab.shape}"
        )
    if lab.ndim == 2:
        return _kabsch_one(local, lab)
    R = np.empty((lab.shape[0], 3, 3))
    t = np.empty((lab.shape[0], 3))
    for k, frame in enumerate(lab):  # per frame: the same arithmetic as a single fit
        R[k], t[k] = _kabsch_one(local, frame)
    return R, t


def off_line(points: np.ndarray) -> float:
    """Largest distance [m] of ``points`` ``(k, 3)`` from the line through the two farthest apart
    (0 for fewer than three points): how well they fix a rigid body's rotation."""
    points = np.asarray(points, float)
    if len(points) < 3:
        return 0.0
    d = np.linalg.norm(points[:, None] - points[None], axis=2)
    i, j = np.unravel_index(np.argmax(d), d.shape)
    axis = (points[j] - points[i]) / max(d[i, j], 1e-12)
    rel = points - points[i]
    return float(np.linalg.norm(rel - np.outer(rel @ axis, axis), axis=1).max())


def _sq(v):
    return v[0] * v[0] + v[1] * v[1] + v[2] * v[2]


def correction_offset(theta, r, cross=np.cross):
    """``(R(theta) - I) r``: how a rigid pose correction with rotation parameter ``theta``
    ``(3,)`` [rad] moves a point at ``r`` ``(3,)`` [m] from the correction's centre.

    ``R(theta) = I + (A + A^2 / 2) / (1 + |theta|^2 / 4)``, ``A = [theta]_x``: the Cayley map of
    ``theta / 2``, a proper rotation for every ``theta`` (by ``2 atan(|theta| / 2)`` about
    ``theta``: ``|theta| - |theta|^3 / 12``, 0.06 deg short at 13 deg), and ``I + A`` to first
    order. The first-order form alone, ``r + theta x r``, is no rotation: at the 13 deg
    corrections real fits reach it moves a sole point 4 mm off its rigid place, and a simulator
    given the rigid pose felt another force than the fit's (vertical 2.5-7 % BW RMS, 23.5 at
    worst, on the bundled trial: ``docs/export.md``). Rational, so smooth with
    exact derivatives and no branch at 0. Generic in the array type: NumPy (``np.cross``) or
    CasADi (``cross=ca.cross``, the fit's per-frame function); the one definition of the
    correction's rotation (:func:`correction_rotation`, :func:`correction_motion`)."""
    _, n, d = _cayley_terms(theta, r, cross)
    return n / d


def _cayley_terms(theta, r, cross):
    """``(u, n, d)``: ``u = theta x r``, the numerator ``n = u + theta x u / 2`` and the
    denominator ``d = 1 + |theta|^2 / 4`` of :func:`correction_offset`."""
    u = cross(theta, r)
    return u, u + 0.5 * cross(theta, u), 1.0 + 0.25 * _sq(theta)


def correction_motion(theta, theta_dot, r, r_dot, cross=np.cross):
    """``(offset, rate)``: :func:`correction_offset` of ``(theta(t), r(t))`` and its time
    derivative [m/s], sharing their terms (the fit's per-frame function needs both)."""
    u, n, d = _cayley_terms(theta, r, cross)
    u_dot = cross(theta_dot, r) + cross(theta, r_dot)
    n_dot = u_dot + 0.5 * (cross(theta_dot, u) + cross(theta, u_dot))
    d_dot = 0.5 * (theta[0] * theta_dot[0] + theta[1] * theta_dot[1] + theta[2] * theta_dot[2])
    return n / d, n_dot / d - n * (d_dot / (d * d))


def correction_rotation(theta) -> np.ndarray:
    """``R(theta)`` ``(3, 3)`` of :func:`correction_offset` (NumPy)."""
    theta = np.asarray(theta, float)
    return np.eye(3) + np.column_stack([correction_offset(theta, e) for e in np.eye(3)])
