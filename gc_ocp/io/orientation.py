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


def body_velocity(markers: np.ndarray, time: np.ndarray) -> np.ndarray:
    """Horizontal velocity of the body ``(n, 2)`` [m/s]: per frame, the median over the markers
    of each marker's velocity (a marker appearing or vanishing does not move it, unlike the
    centroid of the visible markers). NaN where no marker is seen in consecutive frames."""
    if markers.shape[0] < 2 or markers.shape[1] == 0:
        return np.full((markers.shape[0], 2), np.nan)
    v = np.gradient(markers[..., :2], time, axis=0)
    seen = np.isfinite(v).all(axis=2).any(axis=1)
    out = np.full((markers.shape[0], 2), np.nan)
    if seen.any():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # frames with few markers
            out[seen] = np.nanmedian(v[seen], axis=1)
    return out


def walking_rotation(
    names, markers: np.ndarray, time: np.ndarray, loaded: np.ndarray | None = None
) -> tuple[np.ndarray, str]:
    """Rotation about Z (multiple of 90 degrees) turning the walking direction to +X.

    Direction: the mean horizontal velocity of the marker centroid (least-squares slope) when
    faster than :data:`MIN_OVERGROUND_SPEED`; else, when the body moves that fast while the plates
    are loaded (``loaded``: boolean per marker frame; a walk with turns, e.g. a circuit, whose
    mean velocity cancels), the body velocity (:func:`body_velocity`) over those frames;
    otherwise (treadmill: the body stays put) the mean heel -> toe vector of both feet. With
    turns, the most frequent direction (to the nearest 90 degrees) of the loaded walking frames is
    taken: each stance then has its own heading (``Stance.heading``). Returns
    the 3x3 rotation and a one-line description.
    """
    if markers.size and np.isfinite(markers).any():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # frames without any marker
            centroid = np.nanmean(markers, axis=1)[:, :2]
    else:
        centroid = np.zeros((len(time), 2)) * np.nan
    ok = np.all(np.isfinite(centroid), axis=1)
    direction = None
    how = ""
    if ok.sum() >= 3:
        vel = np.polyfit(time[ok], centroid[ok], 1)[0]
        if np.linalg.norm(vel) > MIN_OVERGROUND_SPEED:
            direction, how = vel, f"marker-centroid velocity {np.linalg.norm(vel):.2f} m/s"
    if direction is None and loaded is not None and np.any(loaded):
        v = body_velocity(markers, time)[np.asarray(loaded, bool)]
        v = v[np.isfinite(v).all(axis=1)]
        v = v[np.linalg.norm(v, axis=1) > MIN_OVERGROUND_SPEED]
        if len(v):
            quarter = np.round(np.degrees(np.arctan2(v[:, 1], v[:, 0])) / 90.0).astype(int) % 4
            counts = np.bincount(quarter, minlength=4)
            k = int(np.argmax(counts))
            along = v[quarter == k]
            direction = along.mean(axis=0)
            how = (
                f"body velocity while the plates are loaded (the path turns; walking within "
                f"45 deg of this direction {counts[k] / len(v):.0%} of the loaded walking time)"
            )
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
