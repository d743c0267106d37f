"""Gaps (NaN runs) in sampled signals: where they are, how long they last, and filling the short
ones. Pure numerics (NumPy/SciPy), shared by the loaders (:mod:`gc_ocp.io`) and the marker
low-pass (:mod:`gc_ocp.kinematics.filtering`).

Gap length rule (the one used everywhere in gc_ocp): a gap of ``g`` consecutive missing samples
at ``rate`` [Hz] lasts ``g / rate`` seconds, the time the ``g`` missing samples stand for. The
interval between the two valid samples that bracket it is one sample longer, ``(g + 1) / rate``.
With 100 Hz markers and ``MAX_GAP_FILL = 0.1`` s, gaps of up to 10 missing frames are filled.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from gc_ocp.geometry import kabsch, off_line

MAX_GAP_FILL = 0.1
"""Longest marker gap filled by interpolation, in [s] (``g / rate``, see the module docstring).
Longer gaps stay NaN (see :func:`gc_ocp.io.require_markers`). 0.1 s is about a tenth of a gait
cycle: a cubic spline through the neighbouring frames is then well below marker noise for foot
markers."""


MAX_MARKER_SPEED = 25.0
"""[m/s] No skin marker moves faster: in walking the swing foot peaks at ~6 m/s, a sprinter's
at ~20 m/s. A marker that leaves its path faster and comes back is a ghost or a mislabelled
point for those frames (:func:`marker_spikes`)."""

MAX_SPIKE = 0.1
"""[s] Longest excursion :func:`marker_spikes` removes (as :data:`MAX_GAP_FILL`, so that the
gap it leaves is filled); a marker that jumps and stays away longer is left as it is."""


def marker_spikes(
    x: np.ndarray, time: np.ndarray
) -> tuple[np.ndarray, list[tuple[int, float, float]]]:
    """Remove excursions no marker can make: a jump away from the marker's path faster than
    :data:`MAX_MARKER_SPEED`, then back to it within :data:`MAX_SPIKE` (a ghost point, or a
    label on a point far away for a few frames: farther than 25 m/s over the frame interval,
    25 cm at 100 Hz), measured between valid samples across gaps (a ghost next to a gap is
    caught; one on the first or last sample is not: no path on its other side). ``x``:
    ``(n, m, 3)`` [m] at ``time`` ``(n,)`` [s]. Returns a copy with those frames NaN (gaps, filled by :func:`fill_short_gaps`) and
    ``(marker, t_first, t_last)`` of each excursion removed."""
    out = np.array(x, dtype=float, copy=True)
    out[~np.isfinite(out)] = np.nan  # an infinite coordinate is a gap too
    if len(time) < 3:
        return out, []
    found: list[tuple[int, float, float]] = []
    for j in range(out.shape[1]):
        idx = np.flatnonzero(np.all(np.isfinite(out[:, j]), axis=1))  # across gaps too
        if len(idx) < 3:
            continue
        p, t = out[idx, j], time[idx]
        jump = np.linalg.norm(np.diff(p, axis=0), axis=1) > MAX_MARKER_SPEED * np.diff(t)
        starts = np.flatnonzero(jump)
        k = 0
        while k < len(starts):
            a = starts[k]  # the path's last sample before the excursion is a
            back = [
                b
                for b in starts[k + 1 :]
                if t[b] - t[a + 1] <= MAX_SPIKE + 1e-9
                and np.linalg.norm(p[b + 1] - p[a]) <= MAX_MARKER_SPEED * (t[b + 1] - t[a])
            ]
            if not back:
                k += 1
                continue
            b = back[0]  # the excursion is a + 1 .. b; the path resumes at b + 1
            out[idx[a + 1 : b + 1], j] = np.nan
            found.append((j, float(t[a + 1]), float(t[b])))
            k = int(np.searchsorted(starts, b + 1))
    return out, found


def nan_runs(valid: np.ndarray) -> list[tuple[int, int]]:
    """Half-open index ranges ``[a, b)`` where ``valid`` ``(n,)`` is False; ``b - a`` is the
    number of missing samples ``g`` of the gap."""
    bad = ~np.asarray(valid, dtype=bool)
    if not bad.any():
        return []
    d = np.diff(np.concatenate([[0], bad.astype(int), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True))


def gap_duration(time: np.ndarray, a: int, b: int, dt: float | None = None) -> float:
    """Duration [s] of the interior gap ``[a, b)`` of samples at times ``time`` ``(n,)`` [s]:
    ``g / rate`` with ``g = b - a`` missing samples, computed as the time between the bracketing
    valid samples ``time[b] - time[a - 1]`` minus one sample period ``dt`` [s] (default: the
    median step of ``time``)."""
    if dt is None:
        dt = float(np.median(np.diff(time)))
    return float(time[b] - time[a - 1] - dt)


def fill_short_gaps(
    x: np.ndarray, time: np.ndarray, max_gap: float = MAX_GAP_FILL
) -> tuple[np.ndarray, list[tuple[int, float, float]]]:
    """Fill the interior NaN gaps of at most ``max_gap`` [s] (``g / rate``, see the module
    docstring) with a cubic spline through the valid samples of each channel.

    x: ``(n, ...)`` samples at times ``time`` ``(n,)`` [s], time first. Channel ``j`` is
        ``x[:, j]`` (e.g. one marker of an ``(n, m, 3)`` marker array, one column of ``(n, k)``);
        a sample of a channel is valid when all its components are finite. ``(n,)`` is one
        channel.
    Gaps at the ends (no valid sample on one side: no extrapolation), longer gaps and every gap
    of a channel with fewer than 4 valid samples stay NaN.

    Returns the filled copy and the gaps left NaN as ``(channel, t_first, t_last)`` [s] (times of
    the first and last missing sample; a channel without 4 valid samples is reported once over
    the whole time range).
    """
    out = np.array(x, dtype=float, copy=True, order="C")  # C order: ``flat`` is a view of it
    flat = out.reshape(out.shape[0], 1, -1) if out.ndim == 1 else out.reshape(*out.shape[:2], -1)
    left: list[tuple[int, float, float]] = []
    dt = float(np.median(np.diff(time))) if len(time) > 1 else 0.0
    for j in range(flat.shape[1]):
        valid = np.all(np.isfinite(flat[:, j]), axis=1)
        runs = nan_runs(valid)
        if not runs or valid.sum() < 4:
            if runs:
                left.append((j, float(time[0]), float(time[-1])))
            continue
        spline = CubicSpline(time[valid], flat[valid, j], axis=0)
        for a, b in runs:
            interior = a > 0 and b < len(time)
            if interior and gap_duration(time, a, b, dt) <= max_gap + 1e-9:
                flat[a:b, j] = spline(time[a:b])
            else:
                left.append((j, float(time[a]), float(time[b - 1])))
    return out, left


RIGID_MIN_LEVER = 0.03
"""Smallest distance [m] of a donor marker from the line through the two farthest-apart donors
for a rigid-body fill: 3 donors within ~2 mm of a line leave the rotation about it free (as
:data:`gc_ocp.io.checks.FOOT_FIX_LEVER`)."""


def fill_rigid_gaps(
    x: np.ndarray, groups, min_lever: float = RIGID_MIN_LEVER
) -> tuple[np.ndarray, list[tuple[int, int, int, list[int]]]]:
    """Fill marker gaps by rigid-body fill from the other markers of the same rigid body.

    x: ``(n, m, 3)`` marker positions [m], time first, NaN = missing. groups: lists of marker
    indices that move as one rigid body (e.g. the markers of one foot). For each missing frame
    ``f`` of marker ``j``, the donors are the markers of its group visible in ``f`` (at least 3,
    at least ``min_lever`` off a line). The reference frames are the last frame before the gap
    and the first after it in which ``j`` and those donors are all visible; the donors' rigid
    motion from a reference frame to ``f`` (:func:`gc_ocp.geometry.kabsch`) carries ``j`` along.
    With both references the two estimates are blended linearly in time (the nearer weighs
    more), so a slowly drifting skin marker is matched at both gap ends. No length limit: the
    fill does not interpolate, it moves the marker with the visible ones. Frames without enough
    donors or without a reference stay NaN.

    Returns the filled copy and the filled runs ``(marker, first frame, end frame (exclusive),
    donors)``.
    """
    x = np.asarray(x, dtype=float)
    out = x.copy()
    done: list[tuple[int, int, int, list[int]]] = []
    for group in groups:
        group = list(group)
        ok = np.isfinite(x[:, group]).all(axis=2)  # (n, k): visible in the input
        for k, j in enumerate(group):
            for a, b in nan_runs(ok[:, k]):
                run_start, run_donors = None, None
                for f in range(a, b + 1):
                    filled = False
                    if f < b:
                        don = [q for q in range(len(group)) if q != k and ok[f, q]]
                        pts = x[f, [group[q] for q in don]]
                        if len(don) >= 3 and off_line(pts) >= min_lever:
                            ref = ok[:, k] & ok[:, don].all(axis=1)
                            before = np.flatnonzero(ref[:a])
                            after = np.flatnonzero(ref[b:]) + b
                            est, w = [], []
                            if before.size:
                                est.append(before[-1])
                            if after.size:
                                est.append(after[0])
                            dcols = [group[q] for q in don]
                            vals = []
                            for r in est:
                                R, t = kabsch(x[r, dcols], x[f, dcols])
                                vals.append(R @ x[r, j] + t)
                                w.append(1.0 / max(abs(f - r), 1))
                            if vals:
                                out[f, j] = np.average(vals, axis=0, weights=w)
                                filled = True
                                if run_start is None:
                                    run_start, run_donors = f, dcols
                    if not filled and run_start is not None:
                        done.append((j, run_start, f, run_donors))
                        run_start = None
    return out, done
