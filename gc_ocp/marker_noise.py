"""The markers' white noise, measured, and what it leaves in the foot's pose (issue 23).

**White part.** A marker's white noise (camera reconstruction) is measured from its raw
trajectory above the band of walking: the residual of a zero-lag low-pass at
:data:`NOISE_BAND_HZ` holds the noise above that frequency and almost no movement (foot markers'
power above 20 Hz is the impact's, a few frames per stance, which the median ignores). For white
noise of standard deviation ``sigma`` the residual's standard deviation is ``sigma sqrt(g)``
with ``g`` the residual filter's noise gain (computed from its impulse response), so
``sigma = 1.4826 MAD / sqrt(g)`` per axis, pooled over the three axes. A lab that already
low-passed its markers shows (almost) none: its remaining error is smooth and is left to the
smooth part.

**What it leaves in the foot's pose.** The foot's pose is (to first order) the rigid fit of its
markers; marker noise ``sigma`` gives the pose a per-frame error of covariance ``sigma^2
(A^T A)^-1`` (``A`` stacks ``[I, -[m_k]x]`` over the markers' positions ``m_k`` about the
hindfoot origin), then the pipeline's low-pass correlates it in time: the error over a stance
is ``H e`` with ``H`` the zero-lag filter's operator and ``e`` white. Its Karhunen-Loeve basis
is dense in time; a spline spans the same band locally (:func:`noise_knot_spacing`). The
estimator's pose correction (:class:`~gc_ocp.estimation.components.pose.PoseCorrection`) uses
both, so that the correction can follow the error the markers allow, at its size: in the
objective this stands for the markers' own likelihood (for a linear-Gaussian marker model a
Gaussian prior on the pose error is the same quadratic; the spline's spectrum approximates the
filter's). This module reads no file (the estimation core uses it).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.signal import butter, filtfilt

from gc_ocp.foot import PoseNoise

NOISE_BAND_HZ = 20.0
"""Markers' noise is measured above this frequency (walking's movement lies below ~15 Hz;
Winter's residual analysis puts lower-limb markers at 4-7 Hz), or above 0.3 x the rate when the
rate is below 67 Hz."""

MIN_UNIT_NOISE_M = 3e-5
"""The estimator models the pose noise only where it gives some contact unit a per-frame
displacement of at least this standard deviation [m] after the low-pass
(:func:`unit_noise_sd`). Below, it moves no parameter: on the synthetic foot of
``benchmarks/coverage.py`` (4 markers, 6 Hz) marker noise of 0.1 mm gives 0.034 mm and biases
nothing without the noise part (n -0.012 +- 0.007, mu -0.000 +- 0.003 over 4 draws, as without
noise), 0.2 mm gives 0.067 mm and biases mu by -0.011 +- 0.003. Labs whose markers were
low-passed before export measure ~0.005-0.03 mm of marker noise and stay below (no cost)."""


@functools.lru_cache(maxsize=64)
def filter_kernel(rate: float, cutoff_hz: float, order: int) -> np.ndarray:
    """``h``: the zero-lag low-pass (``filtfilt`` of an ``order/2`` Butterworth, as
    :func:`gc_ocp.kinematics.filtering.lowpass`) applied to a unit impulse in the middle of
    ``8 / cutoff_hz`` seconds of samples (far enough from the ends that they do not reach it)."""
    n = int(8 * rate / cutoff_hz) | 1
    e = np.zeros(n)
    e[n // 2] = 1.0
    b, a = butter(order // 2, cutoff_hz / (rate / 2))
    h = filtfilt(b, a, e)
    h.flags.writeable = False
    return h


def _noise_gain(rate: float, cutoff_hz: float, order: int = 4) -> float:
    """``g``: the variance that ``x - lowpass(x)`` keeps of unit white noise (module doc), away
    from the ends."""
    e = -filter_kernel(rate, cutoff_hz, order)
    e[e.size // 2] += 1.0
    return float(e @ e)


def noise_band_hz(rate: float) -> float:
    """[Hz] The lower edge of the band whose residual :func:`white_noise` reads at a sample
    ``rate``: :data:`NOISE_BAND_HZ`, or 0.3 of the rate where that is lower (a 50 Hz camera:
    15 Hz), so the band keeps some width below the Nyquist frequency."""
    return min(NOISE_BAND_HZ, 0.3 * rate)


def white_noise(markers: np.ndarray, rate: float) -> np.ndarray:
    """``(m,)`` the white noise [m] of each of ``markers`` ``(n, m, 3)`` [m] at ``rate`` [Hz]
    (module doc); NaN for a marker with fewer than 20 visible frames. Gaps are skipped: every
    visible run of at least 20 frames is filtered separately."""
    x = np.asarray(markers, float)
    fh = noise_band_hz(rate)
    b, a = butter(2, fh / (rate / 2))
    g = _noise_gain(rate, fh)
    out = np.full(x.shape[1], np.nan)
    for j in range(x.shape[1]):
        res = []
        good = np.isfinite(x[:, j]).all(axis=1)
        edges = np.flatnonzero(np.diff(np.r_[0, good.astype(int), 0]))
        for s, e in zip(edges[::2], edges[1::2], strict=True):
            if e - s >= 20:
                r = x[s:e, j] - filtfilt(b, a, x[s:e, j], axis=0)
                res.append(r[5:-5])  # the filter's ends
        if res:
            r = np.concatenate(res)
            mad = np.median(np.abs(r - np.median(r, axis=0)), axis=0)
            out[j] = float(np.sqrt(np.mean((1.4826 * mad) ** 2) / g))
    return out


def pose_covariance(local: np.ndarray, sigma: float) -> np.ndarray | None:
    """``(6, 6)`` per-frame covariance of a rigid fit's pose (translation of the frame's
    origin [m], rotation vector [rad], in the frame's axes) from markers at ``local`` ``(m, 3)``
    [m] (in that frame) with white noise ``sigma`` [m]; None with fewer than three
    non-collinear markers (the fit does not fix the pose)."""
    m = np.asarray(local, float)
    if m.shape[0] < 3:
        return None
    A = np.concatenate([np.hstack([np.eye(3), -_skew(p)]) for p in m])
    AtA = A.T @ A
    if np.linalg.cond(AtA) > 1e10:
        return None
    return sigma**2 * np.linalg.inv(AtA)


def _skew(p: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])


KNOTS_PER_CYCLE = 4.0
"""Knots of the noise's spline per period of the low-pass cutoff (knot spacing ``1 / (4
cutoff)``, 42 ms at 6 Hz): a cubic spline with that spacing follows the band the filter passes."""


def noise_knot_spacing(noise: PoseNoise) -> float:
    """[s] The knot spacing of the pose noise's spline in the estimator (``1 / (KNOTS_PER_CYCLE
    cutoff)``): a cubic spline with independent N(0, 1) coefficients, scaled so that each frame
    has the variance the low-passed unit white noise has (:func:`filter_gain`), spans the band
    the filter passes with local support. Its spectrum is not the filter's, but the Hessian keeps
    banded per-stance blocks: a Karhunen-Loeve basis of the filtered noise, exact in covariance,
    couples every frame of a stance and made the fit 6x slower for the same bias
    (``docs/quality.md``)."""
    return 1.0 / (KNOTS_PER_CYCLE * float(noise.cutoff_hz))


def filter_gain(noise: PoseNoise) -> float:
    """The variance the pipeline's low-pass keeps of unit white noise (``sum_j h_j^2``)."""
    h = filter_kernel(float(noise.rate), float(noise.cutoff_hz), int(noise.order))
    return float(h @ h)


def unit_noise_sd(noise: PoseNoise, points: np.ndarray) -> float:
    """The largest per-frame standard deviation [m] (RMS over the axes) that the low-passed pose
    noise gives a contact unit at ``points`` ``(m, 3)``, in the hindfoot frame (a toe unit
    too: :meth:`~gc_ocp.foot.FootKinematics.points_in_hindfoot`)."""
    g = filter_gain(noise)
    sds = []
    for p in np.asarray(points, float):
        G = np.hstack([np.eye(3), -_skew(p)])
        sds.append(np.sqrt(g * np.trace(G @ noise.cov @ G.T) / 3.0))
    return float(max(sds))


ATTENUATING_UNIT_NOISE_M = 1.5e-4
"""A foot whose low-passed pose noise moves a contact unit by at least this standard deviation
[m] (:func:`unit_noise_sd`) gets the bias correction by default
(:mod:`gc_ocp.estimation.bias`; ``fit(bias_correction=None)``). The noise in the sliding
velocity attenuates the friction coefficient, roughly as the noise's square, and widens its
sampling spread beyond what a covariance made at the fit shows. On the synthetic stances of
``benchmarks/coverage.py`` (6 Hz, 100 Hz): at 0.18 mm at the units (0.5 mm of marker noise) the
uncorrected mu interval covers 82 % (its SE 1.3 times short), corrected 90 %; mu was off by
-0.016 and -0.051 at 0.35 and 0.70 mm (1 and 2 mm of marker noise), against SEs of
0.004-0.008; at 0.034 mm (0.1 mm) by nothing. Between 0.034 and 0.18 mm nothing was measured;
the threshold sits just under the first size where the uncorrected intervals fall short. Labs
whose markers were low-passed before export measure 0.001-0.05 mm at the units and stay below
(no cost)."""


def noise_modelled(noise: PoseNoise, points: np.ndarray) -> bool:
    """Whether the estimator models ``noise`` for a foot whose units sit at ``points`` (the
    hindfoot frame, :func:`unit_noise_sd`): it moves some unit by at least
    :data:`MIN_UNIT_NOISE_M`."""
    return unit_noise_sd(noise, points) >= MIN_UNIT_NOISE_M


def foot_pose_noise(
    local: np.ndarray, sigma: float, rate: float, cutoff_hz: float, order: int = 4
) -> PoseNoise | None:
    """The :class:`PoseNoise` of a foot tracked by markers at ``local`` ``(m, 3)`` [m] (in the
    hindfoot frame, about its origin) with white noise ``sigma`` [m], low-passed as the pipeline
    does; None when the markers do not fix the pose or the noise is not finite."""
    if not np.isfinite(sigma):
        return None
    cov = pose_covariance(local, sigma)
    if cov is None:
        return None
    return PoseNoise(cov, float(rate), float(cutoff_hz), int(order), float(sigma))


__all__ = [
    "foot_pose_noise",
    "filter_gain",
    "filter_kernel",
    "noise_knot_spacing",
    "noise_modelled",
    "unit_noise_sd",
    "pose_covariance",
    "white_noise",
]
