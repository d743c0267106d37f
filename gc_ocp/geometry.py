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
