"""Exact rigid-body wrench algebra (NumPy): moment transport and centre of pressure.

A wrench (F, M_A) about point A equals (F, M_B) about B with ``M_B = M_A + (A - B) x F``.
"""

from __future__ import annotations

import numpy as np


def transport_moment(
    force: np.ndarray, moment: np.ndarray, from_point: np.ndarray, to_point: np.ndarray
) -> np.ndarray:
    """Moment about ``to_point`` of a wrench given about ``from_point``.

    force, moment: ``(n, 3)`` [N], [N·m]; points ``(3,)`` or ``(n, 3)`` [m], same frame.
    Returns ``(n, 3)`` [N·m]: ``M_to = M_from + (from - to) x F``.
    """
    force = np.asarray(force, dtype=float)
    moment = np.asarray(moment, dtype=float)
    r = np.asarray(from_point, dtype=float) - np.asarray(to_point, dtype=float)
    return moment + np.cross(np.broadcast_to(r, force.shape), force)


def transport_wrench(
    wrench: np.ndarray, from_point: np.ndarray, to_point: np.ndarray
) -> np.ndarray:
    """A wrench ``(n, 6)`` (force, moment about ``from_point``) with its moment moved to
    ``to_point`` (:func:`transport_moment`)."""
    wrench = np.asarray(wrench, dtype=float)
    f = wrench[:, :3]
    return np.c_[f, transport_moment(f, wrench[:, 3:], from_point, to_point)]


def cop_from_wrench(
    force: np.ndarray,
    moment: np.ndarray,
    reference_point: np.ndarray,
    surface_height: float = 0.0,
    min_vertical: float = 20.0,
) -> np.ndarray:
    """Centre of pressure on the horizontal plane z = ``surface_height`` (``lab``, Z up) [m].

    The COP is the point P on that plane where the moment of the wrench has no horizontal
    component. Rows with vertical force below ``min_vertical`` [N] are NaN.
    """
    force = np.atleast_2d(np.asarray(force, dtype=float))
    ref = np.asarray(reference_point, dtype=float)
    on_plane = np.broadcast_to(ref, force.shape).copy()
    on_plane[:, 2] = surface_height
    m = transport_moment(force, moment, ref, on_plane)  # moment about a point on the plane
    fz = force[:, 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        dx = -m[:, 1] / fz
        dy = m[:, 0] / fz
    cop = on_plane.copy()
    cop[:, 0] += dx
    cop[:, 1] += dy
    cop[fz < min_vertical] = np.nan
    return cop


def free_moment(
    force: np.ndarray, moment: np.ndarray, reference_point: np.ndarray, surface_height: float = 0.0
) -> np.ndarray:
    """Vertical free moment about the COP [N·m], ``(n,)``; NaN where the COP is undefined."""
    cop = cop_from_wrench(force, moment, reference_point, surface_height, min_vertical=1e-9)
    return transport_moment(force, moment, reference_point, cop)[:, 2]
