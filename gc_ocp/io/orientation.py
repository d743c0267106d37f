"""Which way the subject walks: the rotation about Z (a multiple of 90 degrees) that turns the
walking direction of a trial to lab +X."""

from __future__ import annotations

import math
import warnings

import numpy as np

from gc_ocp.io._common import _landmark, heel_toe, rotation_z, warn
from gc_ocp.model.landmarks import vocabulary

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


SIDE_SWAP = 0.02
"""[m] A left landmark lies to the subject's left of its right counterpart: by a pelvis or knee
width, and the feet by about the step width (5-15 cm; a crossover step brings them near 0).
A median over the frames more than this far to the *right* is a swap (:func:`mirrored_pairs`)."""


FOOT_CROSSOVER = 0.05
"""[m] How far a foot landmark may lie the wrong way round of its counterpart (median over the
frames) in a crossover or tandem gait; a shank or thigh pair cannot cross."""

LEG_SEGMENTS = ("hindfoot", "toes", "shank", "thigh")
"""Segments whose landmarks pose the feet (directly, or through the chain of a two-landmark
foot): a swap there is an error (a shank or thigh pair, or a foot pair beyond
:data:`FOOT_CROSSOVER`); elsewhere (shoulders, arms, head) it is noted."""


def leg_swaps(names, markers: np.ndarray, time: np.ndarray) -> tuple[list, list]:
    """``(legs, others)``: the swapped pairs of :func:`mirrored_pairs` split into those that are
    an error and those only noted. The leg pairs are an error when any of them is a shank or
    thigh pair, or a foot pair beyond :data:`FOOT_CROSSOVER` (the feet of a crossover or tandem
    gait may lie a few cm the wrong way round; the shanks and thighs cannot); else they join the
    others. One rule for walking (:func:`gc_ocp.io.load.load_trial`) and static trials
    (:func:`gc_ocp.kinematics.pipeline.check_static_sides`)."""
    swapped = mirrored_pairs(names, markers, time)
    legs = [p for p in swapped if p[3] in LEG_SEGMENTS]
    if not any(p[3] not in ("hindfoot", "toes") or p[2] < -FOOT_CROSSOVER for p in legs):
        legs = []
    return legs, [p for p in swapped if p not in legs]


def said_pairs(pairs) -> str:
    """The first pairs of :func:`mirrored_pairs` as a message names them ("LKNE/RKNE -6 cm")."""
    return ", ".join(f"{a}/{b} {d * 100:+.0f} cm" for a, b, d, _ in pairs[:6])


SWAPPED_LEGS = (
    "the left-side leg markers lie to the subject's right of the right-side ones ({said}; the "
    "subject's left is positive, forward being the feet's heel -> toe): left and right are "
    "swapped, by the labels or by mirrored (left-handed) axes in the file"
)
"""The error of :func:`leg_swaps`'s ``legs``, for walking and static trials alike."""


def _sided_landmarks(names) -> dict[str, dict[str, int]]:
    """``{landmark: {side: column}}`` of the labels the vocabulary reads as sided landmarks."""
    sides: dict[str, dict[str, int]] = {}
    for j, name in enumerate(names):
        key, side = _landmark(name)
        if key and side:
            sides.setdefault(key, {}).setdefault(side, j)
    return sides


def mirrored_pairs(
    names, markers: np.ndarray, time: np.ndarray
) -> list[tuple[str, str, float, str]]:
    """``(left label, right label, lateral offset [m], segment)`` of each sided landmark pair
    whose left member lies, median over the frames, more than :data:`SIDE_SWAP` to the subject's
    right of the right one: left and right swapped (labels exchanged, or a file with mirrored,
    left-handed axes). The subject's forward is the heel -> toe direction of the feet (anatomy:
    it holds for walking backward and on a treadmill), else the body's velocity. ``markers``
    ``(n, m, 3)`` in ``lab`` (Z up)."""
    n = markers.shape[0]
    fwd = np.full((n, 2), np.nan)
    parts = []
    for side in ("left", "right"):
        h, t = heel_toe(list(names), side)
        if h is not None and t is not None:
            parts.append(markers[:, t, :2] - markers[:, h, :2])
    if parts:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            fwd = np.nanmean(np.stack(parts), axis=0)
    if not np.isfinite(fwd).all(axis=1).any():  # no feet, or their columns empty
        fwd = body_velocity(markers, time)
    norm = np.linalg.norm(fwd, axis=1)
    ok = np.isfinite(norm) & (norm > 1e-6)
    if not ok.any():
        return []
    left = np.full((n, 2), np.nan)
    left[ok] = np.column_stack([-fwd[ok, 1], fwd[ok, 0]]) / norm[ok, None]
    out = []
    for key, pair in _sided_landmarks(names).items():
        if len(pair) < 2:
            continue
        lj, rj = pair["left"], pair["right"]
        lateral = np.sum((markers[:, lj, :2] - markers[:, rj, :2]) * left, axis=1)
        if np.isfinite(lateral).sum() < 3:
            continue
        med = float(np.nanmedian(lateral))
        if med < -SIDE_SWAP:
            out.append((names[lj], names[rj], med, vocabulary().landmarks[key].segment))
    return out
