"""Gait phases of a stance, defined from its timing and its measured vertical force.

A stance (initial contact to toe-off of one foot) is split into Perry's four stance phases:

* ``loading_response``: initial contact to the first peak of the vertical force (weight
  acceptance; ends near the opposite foot's toe-off);
* ``mid_stance``: first peak to the valley between the two peaks (the body passes over the foot);
* ``terminal_stance``: valley to the second peak (heel rise, push-off builds up);
* ``pre_swing``: second peak to toe-off (unloading; the opposite foot is down).

The peaks and the valley are found on the measured vertical force over the in-contact frames:
the first peak is the maximum over the first half of the stance, the second the maximum over
the second half, the valley the minimum between them. The force shape is accepted when the first
peak lies in 5-45 % of the stance, the second in 55-95 %, and the valley is at least 5 % below
the lower peak. Otherwise (a flat or single-humped force: slow walking, a shuffling step, a
truncated stance) the phases fall back to Perry's average fractions of stance, 0-17-50-83-100 %
(loading response 0-10 % of the gait cycle, mid-stance 10-30 %, terminal stance 30-50 %,
pre-swing 50-60 %, with stance = 60 % of the cycle). The method used is reported per stance.
"""

from __future__ import annotations

import numpy as np

PHASES: tuple[str, ...] = ("loading_response", "mid_stance", "terminal_stance", "pre_swing")
"""The four stance phases, in time order."""

PERRY_STANCE_FRACTIONS = (0.0, 0.17, 0.50, 0.83, 1.0)
"""Phase boundaries as fractions of stance when the force shape gives none (Perry & Burnfield:
0-10-30-50-60 % of the gait cycle, divided by the 60 % of stance)."""

PEAK_WINDOWS = ((0.05, 0.45), (0.55, 0.95))
"""Where in the stance (fraction) the first and second force peaks must lie to be accepted."""

VALLEY_DEPTH = 0.05
"""The valley must lie at least this fraction below the lower of the two peaks."""


def phase_bounds(
    time: np.ndarray, fz: np.ndarray, in_contact: np.ndarray
) -> tuple[np.ndarray, str]:
    """Boundaries ``[t_on, t_1, t_2, t_3, t_off]`` [s] of the four phases of one stance and the
    method: ``"force"`` (peaks and valley of ``fz``) or ``"fractions"`` (Perry's fractions)."""
    time = np.asarray(time, float)
    idx = np.flatnonzero(np.asarray(in_contact, bool))
    if idx.size == 0:
        idx = np.arange(time.size)
    t, f = time[idx], np.asarray(fz, float)[idx]
    t_on, t_off = float(t[0]), float(t[-1])
    dur = t_off - t_on
    if dur <= 0:
        return np.full(5, t_on), "fractions"
    u = (t - t_on) / dur
    first, second = np.flatnonzero(u <= 0.5), np.flatnonzero(u > 0.5)
    if first.size >= 3 and second.size >= 3:
        i1 = first[np.argmax(f[first])]
        i2 = second[np.argmax(f[second])]
        if i2 - i1 >= 2:
            iv = i1 + 1 + int(np.argmin(f[i1 + 1 : i2]))
            ok = (
                PEAK_WINDOWS[0][0] < u[i1] < PEAK_WINDOWS[0][1]
                and PEAK_WINDOWS[1][0] < u[i2] < PEAK_WINDOWS[1][1]
                and f[iv] < (1.0 - VALLEY_DEPTH) * min(f[i1], f[i2])
            )
            if ok:
                return np.array([t_on, t[i1], t[iv], t[i2], t_off]), "force"
    return t_on + dur * np.asarray(PERRY_STANCE_FRACTIONS), "fractions"


def phase_index(time: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """Phase of every frame (index into :data:`PHASES`; -1 outside ``[t_on, t_off]``)."""
    time = np.asarray(time, float)
    out = np.searchsorted(bounds[1:-1], time, side="right")
    out[(time < bounds[0]) | (time > bounds[-1])] = -1
    return out


__all__ = (
    "PHASES",
    "PERRY_STANCE_FRACTIONS",
    "phase_bounds",
    "phase_index",
)
