"""Zero-lag low-pass filtering of marker trajectories."""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, filtfilt

DEFAULT_CUTOFF_HZ = 6.0
"""Default marker low-pass cutoff [Hz]: the usual choice for walking kinematics (Winter's residual
analysis gives 4-7 Hz for lower-limb markers in walking). Override with ``cutoff_hz``."""

MAX_GAP_S = 0.1
"""Gaps up to this duration [s] are filled by cubic interpolation before filtering; longer gaps stay NaN."""


def fill_gaps(x: np.ndarray, time: np.ndarray, max_gap: float = MAX_GAP_S) -> np.ndarray:
    """Fill NaN runs shorter than ``max_gap`` [s] in each column of ``x`` ``(n, ...)``; returns a copy."""
    from scipy.interpolate import CubicSpline

    x = np.array(x, dtype=float, copy=True)
    flat = x.reshape(x.shape[0], -1)
    for j in range(flat.shape[1]):
        c = flat[:, j]
        bad = np.isnan(c)
        if not bad.any() or bad.all() or (~bad).sum() < 4:
            continue
        good = ~bad
        spl = CubicSpline(time[good], c[good])
        # runs of NaN
        idx = np.flatnonzero(np.diff(np.r_[0, bad.astype(int), 0]))
        for a, b in zip(idx[::2], idx[1::2], strict=True):
            if a == 0 or b == len(c):
                continue  # do not extrapolate at the ends
            if time[b] - time[a - 1] <= max_gap + 1e-9:
                c[a:b] = spl(time[a:b])
    return flat.reshape(x.shape)


def lowpass(
    x: np.ndarray,
    rate: float,
    cutoff_hz: float = DEFAULT_CUTOFF_HZ,
    order: int = 4,
    time: np.ndarray | None = None,
) -> np.ndarray:
    """Zero-lag Butterworth low-pass along axis 0 (``filtfilt`` of an ``order/2`` design, so the
    effective order is ``order``, 4 by default), NaN-aware.

    x: ``(n, ...)`` samples at ``rate`` [Hz]; cutoff_hz [Hz]. Short gaps (``MAX_GAP_S``) are
    interpolated first; each remaining NaN-free run is filtered separately and NaNs stay NaN.
    """
    if not 0 < cutoff_hz < rate / 2:
        from gc_ocp.errors import InputError

        raise InputError(
            f"cutoff_hz must be in (0, {rate / 2}) Hz for a {rate} Hz signal, but got {cutoff_hz}"
        )
    if time is None:
        time = np.arange(x.shape[0]) / rate
    x = fill_gaps(x, time)
    b, a = butter(order // 2, cutoff_hz / (rate / 2))
    out = np.full_like(x, np.nan)
    flat, fout = x.reshape(x.shape[0], -1), out.reshape(x.shape[0], -1)
    padlen = 3 * max(len(a), len(b))
    for j in range(flat.shape[1]):
        c = flat[:, j]
        good = ~np.isnan(c)
        idx = np.flatnonzero(np.diff(np.r_[0, good.astype(int), 0]))
        for s, e in zip(idx[::2], idx[1::2], strict=True):
            if e - s > padlen:
                fout[s:e, j] = filtfilt(b, a, c[s:e])
            else:
                fout[s:e, j] = c[s:e]  # too short to filter: keep raw
    return out
