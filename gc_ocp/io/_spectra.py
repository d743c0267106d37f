"""Band power spectra of sampled signals and the roll-off of a low-pass filter in them: the pure
numerics behind :mod:`gc_ocp.io.processing` (NumPy/SciPy only).

A spectrum here is the Welch power spectral density of a signal's stretches, **prewhitened**: the
PSD of the second difference, divided by the difference's gain ``|2 sin(pi f / rate)|^4``. A
walking force or marker trajectory has 10^6-10^12 times more power at the stride frequency than
near Nyquist; the Hann window leaks a fraction of it (falling as f^-6) into every band, which
hides a noise floor or a filter's stop band. The difference removes that dynamic range before
the window, the division puts it back after. Bins are then collected in bands of
1/:data:`BANDS_PER_DECADE` decade (median over the band's bins: robust to mains lines).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import signal

BANDS_PER_DECADE = 8
"""Bands per decade of frequency (each band spans 33 %): fine enough to place a knee, coarse
enough that a band holds several Welch bins above the lowest decade."""
PREWHITEN = 2
"""Order of the difference applied before the Welch window (see the module docstring)."""
TOP_BAND = (0.5, 0.95)
"""The top of the spectrum, as fractions of Nyquist, where a raw sensor shows its noise floor.
The last 5 % are left out: a digital filter's response, and that of the decimation behind some
exports, is forced to zero there."""
SIX_DB = float(np.log10(4.0))
"""A zero-lag (forward-backward) Butterworth filter passes 1/4 of the power (-6 dB) at its design
cutoff, whatever its order: the cutoff is read where a spectrum falls that far below its
reference."""


@dataclass(frozen=True)
class BandSpectrum:
    """``freq``: band centres [Hz] (geometric mean of the band's bins); ``log_psd``: log10 of the
    PSD [unit^2/Hz]; ``rate``: sampling rate [Hz]; ``n_windows``: Welch windows averaged."""

    freq: np.ndarray
    log_psd: np.ndarray
    rate: float
    n_windows: int

    @property
    def nyquist(self) -> float:
        return self.rate / 2.0

    def top(self) -> np.ndarray:
        """Mask of the bands in :data:`TOP_BAND`."""
        return (self.freq >= TOP_BAND[0] * self.nyquist) & (self.freq <= TOP_BAND[1] * self.nyquist)

    def top_level(self) -> float:
        """Median log10 PSD over the top of the spectrum."""
        return float(np.median(self.log_psd[self.top()]))

    def top_fall(self) -> float:
        """How many decades the PSD falls across the top of the spectrum (least-squares line
        over its bands, in log-log): ~0 for a white floor, several for a filter's stop band."""
        m = self.top()
        if m.sum() < 2:
            return 0.0
        u = np.log10(self.freq[m])
        slope = np.polyfit(u, self.log_psd[m], 1)[0]
        return float(-slope * (u[-1] - u[0]))


def window_length(rate: float, seconds: float) -> int:
    """Welch window [samples]: the power of two nearest ``seconds`` x ``rate``, at least 16."""
    return max(16, int(2 ** np.round(np.log2(max(seconds * rate, 16.0)))))


def band_spectrum(
    segments: Sequence[np.ndarray], rate: float, nperseg: int, prewhiten: int = PREWHITEN
) -> BandSpectrum | None:
    """Welch spectrum of the stretches ``segments`` (each 1-D, sampled at ``rate`` [Hz]),
    averaged over all their windows of ``nperseg`` samples (half overlap, linear trend removed);
    stretches shorter than one window are skipped. ``prewhiten``: order of the difference taken
    first (module docstring); 0 for a signal that is already white (noise), whose difference
    would be blue and leak its top into the lowest bins instead. ``None`` when no stretch is long
    enough."""
    acc, n_win = 0.0, 0
    f = np.zeros(0)
    for x in segments:
        x = np.asarray(x, dtype=float)
        if x.size < nperseg + prewhiten:
            continue
        y = np.diff(x, prewhiten)
        f, p = signal.welch(
            y, fs=rate, window="hann", nperseg=nperseg, noverlap=nperseg // 2, detrend="linear"
        )
        k = 1 + (y.size - nperseg) // (nperseg // 2)
        acc, n_win = acc + p * k, n_win + k
    if n_win == 0:
        return None
    f, p = f[1:], (acc / n_win)[1:]  # the first bin (DC) holds the removed mean only
    p = p / (2.0 * np.sin(np.pi * f / rate)) ** (2 * prewhiten)
    edges = 10.0 ** np.arange(np.log10(f[0]) - 1e-9, np.log10(rate / 2.0), 1.0 / BANDS_PER_DECADE)
    edges = np.append(edges, rate)  # the last band runs to Nyquist
    idx = np.digitize(f, edges) - 1
    freq, level = [], []
    for b in np.unique(idx):
        m = idx == b
        freq.append(float(np.exp(np.mean(np.log(f[m])))))
        level.append(float(np.log10(max(np.median(p[m]), 1e-300))))
    return BandSpectrum(np.array(freq), np.array(level), float(rate), n_win)


def median_spectrum(spectra: Sequence[BandSpectrum]) -> BandSpectrum | None:
    """Band-wise median of the log PSDs of several channels sampled alike (same rate and window:
    same bands), e.g. every marker coordinate: robust to a few odd channels (gap-filled or
    computed points)."""
    spectra = [s for s in spectra if s is not None]
    if not spectra:
        return None
    n = min(s.freq.size for s in spectra)
    levels = np.array([s.log_psd[:n] for s in spectra])
    return BandSpectrum(
        spectra[0].freq[:n],
        np.median(levels, axis=0),
        spectra[0].rate,
        sum(s.n_windows for s in spectra),
    )


def white_std(log_level: float, rate: float) -> float:
    """Standard deviation of white noise whose one-sided PSD is ``10**log_level`` over
    [0, rate/2] (same units as the signal)."""
    return float(np.sqrt(10.0**log_level * rate / 2.0))


def plateau_cutoff(spec: BandSpectrum, persist: int = 2) -> float | None:
    """Cutoff [Hz] of a low-passed **white** noise: where its PSD falls :data:`SIX_DB` below the
    plateau (median of its lowest half decade) and stays there for ``persist`` more bands
    (crossing interpolated in log-frequency). ``None`` when it never does (white to Nyquist)."""
    u = np.log10(spec.freq)
    ref = float(np.median(spec.log_psd[u <= u[0] + 0.5]))
    below = spec.log_psd <= ref - SIX_DB
    for i in range(1, u.size):
        if below[i : i + persist + 1].all() and below[i:].mean() > 0.9:
            d0, d1 = ref - spec.log_psd[i - 1], ref - spec.log_psd[i]
            w = float(np.clip((SIX_DB - d0) / (d1 - d0), 0.0, 1.0)) if d1 > d0 else 1.0
            return float(10.0 ** (u[i - 1] + w * (u[i] - u[i - 1])))
    return None


def trend_cutoff(spec: BandSpectrum, slope: float, persist: int = 2) -> float | None:
    """Cutoff [Hz] of a low-pass applied to a signal whose unfiltered spectrum falls no faster
    than ``f^-slope``: the spectrum is tilted by ``f^slope`` (flat for such a signal, rising where
    it falls more slowly) and the cutoff is where the tilted spectrum falls :data:`SIX_DB` below
    its maximum and stays there for ``persist`` more bands (crossing interpolated in
    log-frequency). Bands within one decade of the lowest level, at the top, are left out
    (rounding, not signal). ``None`` when it never falls that far.

    Exact for a zero-lag Butterworth of any order on a signal of slope ``-slope``. On a signal
    whose own slope ``s`` is shallower the reading is late, by the factor ``v`` solving
    ``(slope - s) log10(v / v0) = 2 log10((1 + v^2n) / (1 + v0^2n)) - SIX_DB`` with
    ``v0^2n = (slope - s) / (4n - slope + s)`` (x1.4 for order n = 2 and ``slope - s = 2``,
    x1.1 for n = 4): a trend at least as steep as the signal errs late, never early."""
    keep = spec.log_psd > spec.log_psd.min() + 1.0
    n = int(np.flatnonzero(keep)[-1]) + 1 if keep.any() else 0
    if n < persist + 2:
        return None
    u, y = np.log10(spec.freq[:n]), spec.log_psd[:n] + slope * np.log10(spec.freq[:n])
    k = int(np.argmax(y))
    below = y <= y[k] - SIX_DB
    for i in range(k + 1, n):
        if below[i : i + persist + 1].all():
            d0, d1 = y[k] - y[i - 1], y[k] - y[i]
            w = float(np.clip((SIX_DB - d0) / (d1 - d0), 0.0, 1.0)) if d1 > d0 else 1.0
            return float(10.0 ** (u[i - 1] + w * (u[i] - u[i - 1])))
    return None


def butter_gain(freq: np.ndarray, cutoff: float, order: int, rate: float) -> np.ndarray:
    """log10 power gain of a zero-lag digital Butterworth low-pass (order ``order`` applied
    forward and backward, ``scipy.signal.filtfilt``) with design cutoff ``cutoff`` [Hz]."""
    t = np.tan(np.pi * np.minimum(freq, 0.4999 * rate) / rate) / np.tan(np.pi * cutoff / rate)
    return -2.0 * np.log10(1.0 + t ** (2 * order))
