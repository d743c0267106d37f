"""Which way the subject walks: the rotation about Z (a multiple of 90 degrees) that turns the
walking direction of a trial to lab +X."""

from __future__ import annotations

import math
import warnings

import numpy as np

from gc_ocp.io._common import heel_toe, rotation_z, warn

MIN_OVERGROUND_SPEED = 0.3
"""Centroid speed [m/s] above which a trial is taken as overground (direction from the centroid);
below it (treadmill), the walking direction is the mean heel -> toe direction of the feet."""


def walking_rotation(names, markers: np.ndarray, time: np.ndarray) -> tuple[np.ndarray, str]:
    """Rotation about Z (multiple of 90 degrees) turning the walking direction to +X.

    Direction: the mean horizontal velocity of the marker centroid (least-squares slope) when
    faster than :data:`MIN_OVERGROUND_SPEED`; otherwise (treadmill: the body stays put) the mean
    heel -> toe vector of both feet. Returns the 3x3 rotation and a one-line description.
    """
    with warnings.catch_warnings():  # frames without any marker give NaN, not a warning
        warnings.simplefilter("ignore", RuntimeWarning)
        centroid = np.nanmean(markers, axis=1)[:, :2] if markers.size else np.zeros((0, 2))
    ok = np.all(np.isfinite(centroid), axis=1)
    direction = None
    how = ""
    if ok.sum() >= 3:
        vel = np.polyfit(time[ok], centroid[ok], 1)[0]
        if np.linalg.norm(vel) > MIN_OVERGROUND_SPEED:
            direction, how = vel, f"marker-centroid velocity {np.linalg.norm(vel):.2f} m/s"
    if direction is None:
        vecs = []
        for side in ("left", "right"):
            h, t = heel_toe(names, side)
            d = markers[:, t, :2] - markers[:, h, :2] if h is not None and t is not None else None
            if d is not None and np.isfinite(d).all(axis=1).any():
                vecs.append(np.nanmean(d, axis=0))
        if vecs and np.linalg.norm(np.mean(vecs, axis=0)) > 0.03:
            direction, how = np.mean(vecs, axis=0), "heel->toe direction (treadmill-like trial)"
    if direction is None:
        warn(
            "Could not detect the walking direction (no motion, no heel/toe markers): "
            "the file's X axis is kept as the walking direction."
        )
        return np.eye(3), "walking direction unknown: file X kept"
    angle = math.degrees(math.atan2(direction[1], direction[0]))
    k = int(round(angle / 90.0))
    if abs(angle - 90.0 * k) > 20.0:
        warn(
            f"Walking direction is {angle:.0f} deg from the file X axis, not close to a multiple "
            f"of 90 deg; rotated by {90 * k} deg only."
        )
    rot = rotation_z(-k)
    return (
        rot,
        f"walking direction {angle:.0f} deg in file axes from {how}; rotated {-90 * k} deg about Z",
    )
