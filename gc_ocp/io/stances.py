"""Stance detection on force plates, side assignment from foot markers, exclusions.

* Contact: vertical force above ``threshold`` (default :data:`DEFAULT_THRESHOLD` = 20 N, about
  3 % of body weight for a 65 kg subject and well above plate noise (< 2 N)). Hysteresis in
  time: above-threshold runs separated by less than :data:`MERGE_GAP` are one contact (a COP
  flicker near the threshold does not split a stance); contacts shorter than
  :data:`MIN_DURATION` are dropped. ``t_on``/``t_off`` are the threshold crossings, linearly
  interpolated between samples.
* Side: the foot (left/right) whose heel/ankle/toe markers are horizontally nearest the COP at
  mid-stance.
* Exclusions (warning + :class:`~gc_ocp.trial.ExcludedStance`): clipped by the file ends
  (force above threshold at the first/last sample, or markers not covering the stance); the foot
  leaving the plate (COP, while Fz > 20 % BW, or the stance foot's markers that are low enough to
  touch the floor, outside the plate outline by more than :data:`EDGE_TOL`; only when corners
  are known); two feet on one plate (the other foot's markers on the plate, low and still, for more than
  50 ms while loaded; only when corners are known, i.e. not for per-foot MOT channels).
"""

from __future__ import annotations

import numpy as np

from gc_ocp.io._common import foot_markers, warn
from gc_ocp.trial import ExcludedStance, Plate, Stance

DEFAULT_THRESHOLD = 20.0
"""Default contact threshold on the vertical force, in [N]."""
MIN_DURATION = 0.1
"""Shortest contact kept, in [s]."""
MERGE_GAP = 0.02
"""Above-threshold runs closer than this [s] are merged into one contact."""
EDGE_TOL = 0.01
"""Tolerance [m] for the COP / foot markers outside the plate outline."""
LOW_MARKER = 0.08
"""A foot marker below surface + this [m] is taken as able to touch the plate."""
PLANTED_SPEED = 0.3
"""Horizontal speed [m/s] below which a low foot marker is taken as planted."""


def contact_windows(plate: Plate, threshold: float) -> list[tuple[int, int, float, float]]:
    """Runs where ``Fz > threshold``: ``(i_on, i_off, t_on, t_off)``, ``i_off`` exclusive."""
    fz = plate.force[:, 2]
    t = plate.time
    above = fz > threshold
    d = np.diff(np.concatenate([[0], above.astype(int), [0]]))
    starts, ends = list(np.flatnonzero(d == 1)), list(np.flatnonzero(d == -1))
    runs: list[list[int]] = []
    for a, b in zip(starts, ends, strict=True):
        if runs and t[a] - t[runs[-1][1] - 1] < MERGE_GAP:
            runs[-1][1] = b
        else:
            runs.append([a, b])
    out = []
    for a, b in runs:
        t_on = _crossing(t, fz, a - 1, a, threshold) if a > 0 else float(t[0])
        t_off = _crossing(t, fz, b - 1, b, threshold) if b < len(t) else float(t[-1])
        if t_off - t_on >= MIN_DURATION:
            out.append((a, b, t_on, t_off))
    return out


def _crossing(t, f, i, j, level) -> float:
    if f[j] == f[i]:
        return float(t[j])
    return float(t[i] + (level - f[i]) * (t[j] - t[i]) / (f[j] - f[i]))


def _inside(points_xy: np.ndarray, corners: np.ndarray, tol: float) -> np.ndarray:
    """True where a point is within ``tol`` of the (convex, axis-agnostic) plate outline."""
    c = corners[:, :2]
    centre = c.mean(axis=0)
    ok = np.ones(points_xy.shape[0], dtype=bool)
    for k in range(4):
        a, b = c[k], c[(k + 1) % 4]
        edge = b - a
        normal = np.array([edge[1], -edge[0]]) / np.linalg.norm(edge)
        if np.dot(centre - a, normal) > 0:
            normal = -normal  # outward
        ok &= (points_xy - a) @ normal <= tol
    return ok


def _markers_at(markers, marker_time, idx, times):
    """Marker positions ``(len(times), len(idx), 3)`` interpolated at ``times``; NaN outside."""
    out = np.full((len(times), len(idx), 3), np.nan)
    for k, j in enumerate(idx):
        for a in range(3):
            out[:, k, a] = np.interp(
                times, marker_time, markers[:, j, a], left=np.nan, right=np.nan
            )
    return out


def detect_stances(
    plates,
    marker_names,
    markers,
    marker_time,
    body_weight: float | None,
    threshold: float = DEFAULT_THRESHOLD,
    source: str = "",
) -> tuple[list[Stance], list[ExcludedStance], list[str]]:
    """Stances on every plate; returns (usable stances, excluded ones, side-check notes)."""
    feet = {s: foot_markers(marker_names, s) for s in ("left", "right")}
    stances: list[Stance] = []
    excluded: list[ExcludedStance] = []
    notes: list[str] = []
    for ip, plate in enumerate(plates):
        cop = plate.cop(min_vertical=threshold)
        for a, b, t_on, t_off in contact_windows(plate, threshold):
            t_mid = 0.5 * (t_on + t_off)
            i_mid = int(np.argmin(np.abs(plate.time - t_mid)))
            # side: nearest foot marker to the COP at mid-stance (skip frames with NaN COP)
            window = np.arange(a, b)
            valid = window[np.all(np.isfinite(cop[window]), axis=1)]
            if valid.size:
                i_mid = valid[np.argmin(np.abs(plate.time[valid] - t_mid))]
            dist = {}
            for s, idx in feet.items():
                if not idx:
                    continue
                m = _markers_at(markers, marker_time, idx, plate.time[[i_mid]])[0]
                d = np.linalg.norm(m[:, :2] - cop[i_mid, :2], axis=1)
                if np.isfinite(d).any():
                    dist[s] = float(np.nanmin(d))
            if dist:
                side = min(dist, key=dist.get)
            elif plate.name.endswith(("_left", "_right")):
                side = plate.name.rsplit("_", 1)[1]
            else:
                side = "unknown"
            if plate.name in ("grf_left", "grf_right") and side != plate.name[4:] and dist:
                notes.append(
                    f"{plate.name} at {t_on:.3f}-{t_off:.3f} s: the {side} foot markers are "
                    f"nearest the COP ({dist}), contradicting the column names"
                )
                warn(f"{source}: {notes[-1]}; check the GRF column sides.")
            reason = _exclusion(
                plate,
                a,
                b,
                t_on,
                t_off,
                side,
                cop,
                feet,
                marker_names,
                markers,
                marker_time,
                body_weight,
                threshold,
            )
            if reason:
                warn(
                    f"{source}: stance {side} on {plate.name} {t_on:.3f}-{t_off:.3f} s "
                    f"excluded: {reason}"
                )
                excluded.append(ExcludedStance(side, ip, t_on, t_off, reason))
                continue
            if plate.reference_kind in ("electrical_center", "surface_center"):
                ref, kind = plate.reference_point, plate.reference_kind
            else:
                loaded = window[np.all(np.isfinite(cop[window]), axis=1)]
                w = plate.force[loaded, 2]
                ref = np.average(cop[loaded], axis=0, weights=w)
                ref[2] = plate.surface_height
                kind = "floor_under_mean_cop"
            stances.append(Stance(side, ip, t_on, t_off, ref, kind))
    stances.sort(key=lambda s: s.t_on)
    excluded.sort(key=lambda s: s.t_on)
    return stances, excluded, notes


def _exclusion(plate, a, b, t_on, t_off, side, cop, feet, names, markers, mtime, bw, thr):
    n = len(plate.time)
    if a == 0:
        return "clipped: force already above threshold at the first sample of the file"
    if b >= n:
        return "clipped: force still above threshold at the last sample of the file"
    if t_on < mtime[0] or t_off > mtime[-1]:
        return "clipped: marker data do not cover the stance"
    times = plate.time[a:b]
    if side in feet and feet[side]:
        m = _markers_at(markers, mtime, feet[side], times)
        if np.all(np.isnan(m).any(axis=2), axis=1).any():
            return "markers: no foot marker of the stance foot during part of the stance"
    if plate.corners is None:
        return ""
    heavy = plate.force[a:b, 2] > (0.2 * bw if bw else 100.0)
    c = cop[a:b][heavy]
    c = c[np.all(np.isfinite(c), axis=1)]
    if c.size and not _inside(c[:, :2], plate.corners, EDGE_TOL).all():
        return f"COP leaves {plate.name} (outside its corners by > {EDGE_TOL * 100:.0f} cm)"
    if side in feet and feet[side]:
        m = _markers_at(markers, mtime, feet[side], times).reshape(-1, 3)
        low = np.isfinite(m[:, 2]) & (m[:, 2] < plate.surface_height + LOW_MARKER)
        if low.any() and not _inside(m[low, :2], plate.corners, EDGE_TOL).all():
            return f"foot off {plate.name}: a low {side} foot marker is outside its corners"
    other = "left" if side == "right" else "right"
    if other in feet and feet[other]:
        m = _markers_at(markers, mtime, feet[other], times)
        speed = np.linalg.norm(np.gradient(m[..., :2], times, axis=0), axis=2)
        # planted = low and (nearly) still: a swing foot passing low over the plate is not on it
        low = np.isfinite(m[..., 2]) & (m[..., 2] < plate.surface_height + LOW_MARKER)
        low &= speed < PLANTED_SPEED
        on = np.zeros(m.shape[:2], dtype=bool)
        on[low] = _inside(m[low][:, :2], plate.corners, -EDGE_TOL)
        dt = float(np.median(np.diff(plate.time)))
        if on.any(axis=1).sum() * dt > 0.05:
            return f"two feet on {plate.name}: the {other} foot is also on it while loaded"
    return ""
