"""Zero-lag low-pass filtering of marker trajectories."""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, filtfilt

from gc_ocp.errors import InputError
from gc_ocp.gaps import MAX_GAP_FILL, fill_short_gaps

DEFAULT_CUTOFF_HZ = 6.0
"""Default marker low-pass cutoff [Hz]: the usual choice for walking kinematics (Winter's residual
analysis gives 4-7 Hz for lower-limb markers in walking). Override with ``cutoff_hz``."""


def lowpass(
    x: np.ndarray,
    rate: float,
    cutoff_hz: float = DEFAULT_CUTOFF_HZ,
    order: int = 4,
    time: np.ndarray | None = None,
) -> np.ndarray:
    """Zero-lag Butterworth low-pass along axis 0 (``filtfilt`` of an ``order/2`` design, so the
    effective order is ``order``, 4 by default), NaN-aware.

    x: ``(n, ...)`` samples at ``rate`` [Hz]; cutoff_hz [Hz]. Gaps of at most ``MAX_GAP_FILL`` [s]
    (``g / rate`` for ``g`` missing samples, :mod:`gc_ocp.gaps`) are interpolated first (per
    ``x[:, j]``: a marker of ``(n, m, 3)`` markers); each remaining NaN-free run is filtered separately and NaNs stay NaN.
    """
    if not 0 < cutoff_hz < rate / 2:
        raise InputError(
            f"cutoff_hz must be in (0, {rate / 2:.4g}) Hz for a {rate:.4g} Hz signal, but got {cutoff_hz:g}"
        )
    if time is None:
        time = np.arange(x.shape[0]) / rate
    x, _ = fill_short_gaps(x, time, MAX_GAP_FILL)
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
