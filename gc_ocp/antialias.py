"""The plate's signal as the frames can carry it: an anti-alias low-pass before sampling.

A fit compares the model's wrench with the plate's on the kinematic frames (60-200 Hz), while the
plates record at 600-2000 Hz. Read at the frame times directly, the plate's content above the
frames' Nyquist frequency (half their rate) does not vanish: it *aliases* into the band the fit
compares. In walking that content is the heel-strike transient (3-4 % BW RMS over the first
fifth of stance, 20-100 Hz, on the raw plates of ``../shared/data``), mains hum and plate noise.
A model driven by kinematics low-passed at 4-10 Hz cannot produce it, and where the frames
happen to fall on the transient decides what the fit is asked to explain: on the BTS trials (60
Hz frames, 1020 Hz plates) the point samples differ from the band-limited signal by 0.8-2.1 %
BW RMS over a stance, and the damping the fit found was 40 % higher with them (it chased the
sampled transient; ``docs/estimation.md``, *The plates, band-limited to the frames*).

So, as any decimation does, the plate's samples are low-passed before they are read at the
frames (:func:`band_limited`): a zero-phase linear-phase FIR (Kaiser window, applied forward and
backward), flat (power within 0.3 %) up to :data:`PASS_FRACTION` of the frame rate and at least
:data:`STOP_DB` down from the frames' Nyquist frequency on. Walking's ground reaction keeps
99 % of its power below 10-15 Hz (Antonsson & Mann 1985, J. Biomech. 18:39), inside the pass
band of any frame rate a gait lab uses (18 Hz at 60 Hz frames, 30 Hz at 100 Hz). Plates stored
at the frame rate (or slower) are read as they are.

A plate zeroed below a threshold is filtered with its zeros: near a stance's edges a frame then
mixes zeros with loaded samples and reads between 0 and the threshold, which the measurement
model treats as partly censored (:mod:`gc_ocp.estimation.measurement`); the threshold itself is
found on the raw samples (:mod:`gc_ocp.io.processing`). Missing samples (NaN) are bridged
linearly for the filter and stay missing; so does every filtered sample that draws more than
:data:`BRIDGE_SHARE` of its filter's weight from the bridge (a frame next to a lone missing
sample, as without the filter; a few frames more on each side of a longer dropout): the bridge
is a guess, and a frame read through it would carry that guess as data (a frame next to a 25 ms
dropout in a heel strike read 59 N off).

The plate's rate is its samples over its duration (:func:`sample_rate`), not the median step: a
600 Hz OpenSim ``.mot`` written to 0.1 ms has steps of 1.6 and 1.7 ms, whose median made it
588 Hz, and the filter designed for that was only 88 dB down at the 60 Hz frames' Nyquist
frequency instead of 120.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy import signal

PASS_FRACTION = 0.3
"""The pass band's edge as a fraction of the frame rate (0.6 of the frames' Nyquist frequency)."""
STOP_DB = 60.0
"""Attenuation of one pass [dB] from the frames' Nyquist frequency on; forward and backward
give twice that (a 1 kN transient leaves < 1 mN aliased)."""
BRIDGE_SHARE = 0.01
"""A filtered sample drawing more than this share of its filter's absolute weight from bridged
(missing) samples is missing (module doc): its error is at most this share of the bridge's."""


def sample_rate(time: np.ndarray) -> float:
    """The rate [Hz] of samples at ``time`` [s]: samples over duration, robust to a time column
    rounded to fewer digits than its step (as :func:`gc_ocp.io.processing.mean_rate`; module
    doc). NaN for fewer than two samples."""
    time = np.asarray(time, float)
    if time.size < 2 or not time[-1] > time[0]:
        return float("nan")
    return float((time.size - 1) / (time[-1] - time[0]))


@functools.lru_cache(maxsize=64)
def _taps(plate_rate: float, frame_rate: float) -> np.ndarray:
    """The FIR's taps for a plate at ``plate_rate`` read at ``frame_rate`` [Hz] (module doc)."""
    nyq = plate_rate / 2
    width = (0.5 - PASS_FRACTION) * frame_rate / nyq  # transition band, fraction of Nyquist
    numtaps, beta = signal.kaiserord(STOP_DB, width)
    cutoff = (PASS_FRACTION + 0.5) / 2 * frame_rate  # the transition band's middle
    taps = signal.firwin(numtaps | 1, cutoff, window=("kaiser", beta), fs=plate_rate)
    taps.setflags(write=False)
    return taps


def needs_filter(plate_rate: float, frame_rate: float | None) -> bool:
    """Whether a plate at ``plate_rate`` read at ``frame_rate`` [Hz] is low-passed first: only
    when the plate is faster than the frames by more than 1 % (a plate stored at the frame rate
    is already sampled as the frames are)."""
    return frame_rate is not None and np.isfinite(frame_rate) and plate_rate > 1.01 * frame_rate


def reach(plate_rate: float, frame_rate: float) -> float:
    """How far [s] from a frame the plate's samples change its band-limited value: the taps
    twice over (the forward and the backward pass) and the forward-backward filter's padding
    beyond them. A window of the recording that extends this far past the frames gives them
    the values the whole recording would."""
    return 5.0 * _taps(round(plate_rate, 6), round(float(frame_rate), 6)).size / plate_rate


def band_limited(time: np.ndarray, channels: np.ndarray, frame_rate: float) -> np.ndarray:
    """``channels`` ``(n, k)`` sampled at ``time`` [s], low-passed for reading at
    ``frame_rate`` [Hz] (module doc), on the same samples. Unchanged when
    :func:`needs_filter` says no. NaN samples stay NaN (a frame read next to one is missing,
    as without the filter; module doc)."""
    time = np.asarray(time, float)
    x = np.asarray(channels, float)
    if time.size < 2:
        return x.copy()
    plate_rate = sample_rate(time)
    if not needs_filter(plate_rate, frame_rate):
        return x.copy()
    taps = _taps(round(plate_rate, 6), round(float(frame_rate), 6))
    bad = ~np.isfinite(x).all(axis=1)
    filled = x.copy()
    if bad.any():
        good = ~bad
        if not good.any():
            return x.copy()
        for c in range(x.shape[1]):
            filled[bad, c] = np.interp(time[bad], time[good], x[good, c])
    if time.size <= 3 * taps.size:  # filtfilt needs a signal longer than its padding
        padlen = time.size - 1
    else:
        padlen = 3 * taps.size
    out = signal.filtfilt(taps, [1.0], filled, axis=0, padlen=padlen)
    if bad.any():
        # the forward-backward filter's response: the taps with themselves (symmetric taps)
        h = np.abs(np.convolve(taps, taps))
        share = signal.convolve(bad.astype(float), h / h.sum(), mode="same")
        out[bad | (share > BRIDGE_SHARE)] = np.nan
    return out


__all__ = [
    "BRIDGE_SHARE",
    "PASS_FRACTION",
    "STOP_DB",
    "band_limited",
    "needs_filter",
    "reach",
    "sample_rate",
]
