"""What the lab's processing did (``gc_ocp/io/processing.py``): zeroing below a threshold,
low-pass filtering, resampling, offsets and the COP's valid load, detected on synthetic plates and
markers whose processing is known, and checked for consistency on the real files of
``../shared/data`` (``docs/data_formats.md``, "What the lab's processing did")."""

from __future__ import annotations

import functools
import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy import interpolate, optimize, signal

from gc_ocp.io import load_trial
from gc_ocp.io._resampling import interpolation_factor
from gc_ocp.io._spectra import BANDS_PER_DECADE, SIX_DB
from gc_ocp.io.processing import (
    COP_NOISE_FACTOR,
    FORCE_SLOPE,
    MARKER_SLOPE,
    censor_threshold,
    detect_marker_processing,
    detect_plate_processing,
    detect_processing,
)
from gc_ocp.trial import Plate, Trial

DATA = (Path(__file__).parents[1] / "../shared/data").resolve()
needs_data = pytest.mark.skipif(
    not DATA.is_dir(), reason=f"shared real datasets not found at {DATA} (repo checked out alone)"
)

RATE = 1000.0  # [Hz] plate rate of the synthetic plates
SIGMA = 1.5  # [N] white noise of the synthetic plate channels
THRESHOLD = 20.0  # [N] the synthetic lab's zeroing threshold
BAND = 10.0 ** (1.0 / BANDS_PER_DECADE)
"""Ratio of neighbouring band centres of the spectra (1.33): the resolution a cutoff is read at."""


# --- synthetic signals --------------------------------------------------------------------------


def _stance(tau: np.ndarray, strike: bool = True) -> np.ndarray:
    """Vertical force of one stance in body weights, ``tau`` in [0, 1]: the double hump, plus
    (``strike``) a heel-strike transient, a 0.3 BW half-sine over the first 4 %."""
    force = 1.05 * np.sin(np.pi * tau) + 0.25 * np.sin(3 * np.pi * tau)
    if strike:
        force = force + np.where(tau < 0.04, 0.3 * np.sin(np.pi * tau / 0.04), 0.0)
    return np.where((tau > 0) & (tau < 1), force, 0.0)


def _plate_signal(seed: int = 0, strike: bool = True):
    """Times [s], noise-free Fz [N] (three 0.65 s stances of a 700 N subject in 4 s at
    :data:`RATE`) and white noise ``(n, 6)`` of :data:`SIGMA` [N] (moments: x 0.05 m)."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(4.0 * RATE)) / RATE
    fz = sum(700.0 * _stance((t - t0) / 0.65, strike) for t0 in (0.5, 1.7, 2.9))
    noise = SIGMA * rng.standard_normal((t.size, 6))
    noise[:, 3:] *= 0.05
    return t, fz, noise


def _plate(t, fz, other, name="plate1") -> Plate:
    """A plate whose Fz is ``fz`` and whose other five channels are ``other[:, [0, 1, 3, 4, 5]]``."""
    force = np.column_stack([other[:, 0], other[:, 1], fz])
    return Plate(name, t, force, other[:, 3:], np.zeros(3), "lab_origin")


def _zeroed(fz, other, threshold=THRESHOLD):
    """All six channels set to exactly 0 where |Fz| < ``threshold``, as exporters do."""
    low = np.abs(fz) < threshold
    fz, other = fz.copy(), other.copy()
    fz[low], other[low] = 0.0, 0.0
    return fz, other


def _filtered(x, cutoff, order, rate=RATE):
    """Zero-lag Butterworth low-pass (``order`` applied forward and backward), along time."""
    return signal.filtfilt(*signal.butter(order, cutoff, fs=rate), x, axis=0)


def _crossing_rise(fz, threshold=THRESHOLD) -> float:
    """Smallest change [N] between the two samples around a crossing of ``threshold`` by |Fz|.
    Each crossing leaves a kept sample next to a zeroed one, within its crossing's change of the
    threshold; the smallest such sample is thus within the smallest change of it."""
    above = np.abs(fz) >= threshold
    i = np.flatnonzero(above[1:] != above[:-1])
    return float(np.min(np.abs(fz[i + 1] - fz[i])))


def _late_factor(order: int, excess: float) -> float:
    """How late ``trend_cutoff`` reads a zero-lag Butterworth of ``order`` on a signal whose
    spectral slope is shallower than the trend by ``excess`` (docstring of
    ``gc_ocp.io._spectra.trend_cutoff``), solved here independently: the tilted spectrum
    ``excess log10 v - 2 log10(1 + v^2n)`` peaks at ``v0^2n = excess / (4n - excess)`` and the
    reading is where it has fallen SIX_DB below that peak."""
    n = order

    def tilted(v):
        return excess * np.log10(v) - 2.0 * np.log10(1.0 + v ** (2 * n))

    v0 = (excess / (4 * n - excess)) ** (1.0 / (2 * n))
    return optimize.brentq(lambda v: tilted(v) - tilted(v0) + SIX_DB, v0, 100.0)


def _markers(seed: int = 0, sigma: float = 3e-4, rate: float = 100.0):
    """Four foot markers over 6 s at ``rate`` [Hz]: still in stance, a swing whose velocity is
    ``sin(pi s)`` (the acceleration jumps at toe-off and heel strike), stride times varying by
    5 %; plus white noise ``sigma`` [m]. Returns times, noise-free and noisy ``(n, 4, 3)``."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(6.0 * rate)) / rate
    out = []
    for j in range(4):
        edges = [-1.1 * rng.uniform()]
        while edges[-1] < t[-1]:
            edges.append(edges[-1] + 1.1 * (1 + 0.05 * rng.standard_normal()))
        x, z = np.zeros_like(t), np.zeros_like(t)
        for k in range(len(edges) - 1):
            m = (t >= edges[k]) & (t < edges[k + 1])
            s = np.clip(((t[m] - edges[k]) / (edges[k + 1] - edges[k]) - 0.6) / 0.4, 0, None)
            x[m] = 1.4 * k + 0.7 * (1 - np.cos(np.pi * s))
            z[m] = 0.12 * np.sin(np.pi * s) ** 2
        y = 0.1 * j + 0.01 * np.sin(2 * np.pi * t / 1.1 + j)
        out.append(np.column_stack([x, y, z + 0.05 * j]))
    clean = np.stack(out, axis=1)
    return t, clean, clean + sigma * rng.standard_normal(clean.shape)


# --- plates ---------------------------------------------------------------------------------------


def test_raw_plate_has_no_threshold_no_lowpass_and_its_noise():
    t, fz, noise = _plate_signal()
    p = detect_plate_processing(_plate(t, fz + noise[:, 2], noise))
    assert p.zero_threshold is None and p.zero_edges == ""
    assert not p.filtered and p.lowpass_hz is None
    assert not p.resampled and p.native_rate_hz is None
    # median of the std of ~4 unloaded stretches of ~500 samples: relative standard error
    # 1 / sqrt(2 x 500) = 3 %; 10 % is three of them
    assert p.noise_std == pytest.approx(SIGMA, rel=0.10)
    assert p.cop_min_load == pytest.approx(COP_NOISE_FACTOR * p.noise_std)
    assert p.unloaded_offsets == ()


def test_zeroed_plate_gives_the_threshold():
    t, fz, noise = _plate_signal()
    raw = fz + noise[:, 2]
    p = detect_plate_processing(_plate(t, *_zeroed(raw, noise)))
    # every kept sample has |Fz| >= 20 N (exact lower bound); each crossing of 20 N leaves a kept
    # sample next to a zero run, within that crossing's change of 20 N (upper bound)
    assert THRESHOLD <= p.zero_threshold <= THRESHOLD + _crossing_rise(raw)
    assert p.zero_edges == "step"
    assert not p.filtered and p.lowpass_hz is None  # zeroing is not filtering: noise in stance
    assert p.cop_min_load >= p.zero_threshold
    assert 0.3 < p.zeroed_fraction < 0.7  # three 0.65 s stances in 4 s leave ~half unloaded


def test_zeros_without_a_threshold_step_are_continuous():
    """Zeroed at 0 N: exact zeros where unloaded, the force leaves them at its own rate. The
    reported value is the smallest kept sample, below one sample's rise, and the edges are not
    steps (documented choice: a small value, flagged "continuous", not None)."""
    t, fz, noise = _plate_signal(strike=False)
    other = np.where(fz[:, None] > 0, noise, 0.0)
    p = detect_plate_processing(_plate(t, fz, other))
    assert p.zero_edges == "continuous"
    assert 0.0 < p.zero_threshold <= _crossing_rise(fz, threshold=1e-9)


@pytest.mark.parametrize("order", [2, 4])
def test_filtered_plate_cutoff_from_unloaded_noise(order):
    cutoff = 15.0
    t, fz, noise = _plate_signal()
    x = _filtered(np.column_stack([fz + noise[:, 2], noise]), cutoff, order)
    p = detect_plate_processing(_plate(t, x[:, 0], x[:, 1:]))
    assert p.filtered and p.lowpass_basis == "unloaded noise"
    # the -6 dB crossing of the noise plateau is interpolated between bands; band levels scatter
    # ~0.1 decade (8 Welch windows), moving the crossing by 0.1 / 2n decade on the filter's
    # slope of 2n decades/decade at its cutoff (<= 6 %), and the 0.26 s Hann window's main lobe
    # (2 bins of 3.9 Hz) smears the knee over about half a band (<= 15 %): 20 %
    assert p.lowpass_hz == pytest.approx(cutoff, rel=0.20)
    assert p.zero_threshold is None


@pytest.mark.parametrize("order", [2, 4])
def test_filtered_then_zeroed_plate_cutoff_from_the_force_spectrum(order):
    cutoff = 15.0
    t, fz, noise = _plate_signal()
    x = _filtered(np.column_stack([fz + noise[:, 2], noise]), cutoff, order)
    p = detect_plate_processing(_plate(t, *_zeroed(x[:, 0], x[:, 1:])))
    assert THRESHOLD <= p.zero_threshold <= THRESHOLD + _crossing_rise(x[:, 0])
    assert p.filtered and p.lowpass_basis == "force spectrum"
    assert p.noise_std is None  # no unloaded noise left, and the filter removed the floor
    # read against an f^-6 trend on a force falling as f^-4 (its slope jumps at contact and at
    # the heel-strike transient): late by _late_factor(order, 2) in theory, never early; plus
    # one band either way for the window's smearing and one for the band the maximum is read on
    late = _late_factor(order, FORCE_SLOPE - 4.0)
    assert cutoff / BAND <= p.lowpass_hz <= cutoff * late * BAND**2


def test_zeroed_then_filtered_plate_shows_the_filter_tail():
    """Zeroing first, then a recursive low-pass: its response decays into the zero runs until
    float32 storage underflows to exact zeros (as in exports filtered after thresholding)."""
    t, fz, noise = _plate_signal()
    z, other = _zeroed(fz + noise[:, 2], noise)
    x = _filtered(np.column_stack([z, other]), 100.0, 2).astype(np.float32).astype(float)
    p = detect_plate_processing(_plate(t, x[:, 0], x[:, 1:]))
    assert p.zero_edges == "filter tail" and p.filtered
    assert p.zero_threshold < 1e-3  # below any plate's resolution: arithmetic, not a load
    # the unloaded stretches hold the filter's response to the zeroing, not noise (the zeroing
    # removed it): no "exact" cutoff or noise level read on them (before: 106 Hz, 0.71 N)
    assert p.lowpass_basis != "unloaded noise" and p.noise_std is None


def test_exact_zeros_inside_a_load_are_not_a_threshold_of_hundreds_of_newtons():
    """A raw plate that lost its signal for 20 ms mid-stance (all six channels exactly 0, the
    "plate dropout" of the stance rules): the run's edges read ~560 N, but the plate keeps
    samples of ~0 N all along, so it was not zeroed below 560 N (before, the smallest edge was
    the threshold: every stance on the plate was censored below 562 N). On a zeroed plate the
    same dropout leaves the lab's threshold."""
    t, fz, noise = _plate_signal()
    drop = (t >= 2.0) & (t < 2.02)
    raw, other = fz + noise[:, 2], noise.copy()
    raw[drop], other[drop] = 0.0, 0.0
    p = detect_plate_processing(_plate(t, raw, other))
    assert p.zero_threshold is not None and p.zero_threshold < SIGMA
    assert censor_threshold(p) < SIGMA
    z, o = _zeroed(fz + noise[:, 2], noise)
    z[drop], o[drop] = 0.0, 0.0
    p = detect_plate_processing(_plate(t, z, o))
    assert THRESHOLD <= p.zero_threshold <= THRESHOLD + _crossing_rise(fz + noise[:, 2])


@pytest.mark.parametrize("gap", ["ends", "inside a zero run"])
def test_missing_samples_next_to_the_zero_runs_leave_the_threshold(gap):
    """A zeroed plate whose recording is padded with NaN (a MOT's blank cells) or misses samples
    inside an unloaded stretch: a run bordered by a missing sample has no edge there (before,
    the NaN was taken as an edge: the threshold read NaN, and the fit refused the censoring, or
    the extra non-step edge turned the verdict "continuous" and nothing was censored)."""
    t, fz, noise = _plate_signal()
    raw = fz + noise[:, 2]
    z, other = _zeroed(raw, noise)
    gone = (t < 0.1) | (t > 3.9) if gap == "ends" else (t >= 1.4) & (t < 1.45)
    z[gone], other[gone] = np.nan, np.nan
    p = detect_plate_processing(_plate(t, z, other))
    assert p.zero_edges == "step"
    assert THRESHOLD <= p.zero_threshold <= THRESHOLD + _crossing_rise(raw)
    assert censor_threshold(p) == p.zero_threshold


def test_plate_zeroed_on_its_vertical_channel_only_gives_the_threshold():
    """A lab that sets only Fz to 0 below the threshold and keeps the other five channels: Fz is
    censored all the same, so the threshold is found as for a six-channel zeroing (before, no
    threshold was found and the zeros were fitted as measured forces)."""
    t, fz, noise = _plate_signal()
    raw = fz + noise[:, 2]
    z = np.where(np.abs(raw) < THRESHOLD, 0.0, raw)
    p = detect_plate_processing(_plate(t, z, noise))
    assert THRESHOLD <= p.zero_threshold <= THRESHOLD + _crossing_rise(raw)  # as six channels
    assert p.zero_edges == "step"
    assert not p.resampled  # the exact zeros are not the knots of an interpolation
    assert censor_threshold(p) == p.zero_threshold
    # the raw plate's Fz reads exactly 0 in single samples only (float noise): nothing found
    assert detect_plate_processing(_plate(t, raw, noise)).zero_threshold is None


def test_plate_zeroed_then_offset_gives_the_threshold_and_its_level():
    """A lab that removes an unloaded offset after the zeroing (every sample minus 1.5 N): the
    zeros read exactly -1.5 N, not 0. A run of 30 and more exactly equal samples near 0 is no
    plate's noise, so it is a zeroing all the same: the threshold is found (in the stored
    values, 1.5 N lower), its level reported, and the held samples censored (before, no
    threshold was found: the held level was fitted as a measured force, and a MOT so made read
    "raw: a noise floor reaches Nyquist"). Held at a foot's load instead (a stuck signal), it
    is not a zeroing."""
    t, fz, noise = _plate_signal()
    raw = fz + noise[:, 2]
    z = np.where(np.abs(raw) < THRESHOLD, 0.0, raw) - 1.5
    p = detect_plate_processing(_plate(t, z, noise))
    assert THRESHOLD - 1.5 <= p.zero_threshold <= THRESHOLD - 1.5 + _crossing_rise(raw)
    assert p.zero_edges == "step" and p.zero_level == -1.5
    assert censor_threshold(p) == p.zero_threshold
    assert "the zeroed Fz reads -1.5 N, not 0: an offset removed after the zeroing" in (
        p.findings()
    )
    stuck = np.where(np.abs(raw) < THRESHOLD, 300.0, raw)
    assert detect_plate_processing(_plate(t, stuck, noise)).zero_threshold is None


def test_coarse_raw_plate_held_at_a_lower_rate_is_not_zeroed():
    """A raw Fz quantised to 2 N steps (1.5 N noise: exactly 0 in ~half the samples) and held
    from 100 Hz to 1000 Hz repeats each of its zeros 10 times: runs of 30 samples are then 3
    native samples, not evidence of a zeroing (FZ_ZERO_RUN_TIME)."""
    t, fz, noise = _plate_signal()
    held = np.repeat((np.round((fz + noise[:, 2]) / 2.0) * 2.0)[::10], 10)[: t.size]
    p = detect_plate_processing(_plate(t, held, np.repeat(noise[::10], 10, axis=0)[: t.size]))
    assert p.zero_threshold is None and p.zero_edges == ""
    assert p.interpolation == "hold" and p.native_rate_hz == pytest.approx(100.0)


def test_smooth_signal_with_a_few_non_vanishing_differences_is_not_interpolated():
    """A signal so smooth that its higher differences vanish at float32 resolution everywhere
    but at one sharp peak (a plate low-passed at 10 Hz: 3 of 3938 differences) is no
    interpolation: those few are not at every knot (MIN_KNOT_SHARE; before: cubic, factor 32)."""
    t = np.arange(4000) / RATE
    x = (700.0 * np.sin(2 * np.pi * 0.5 * t)).astype(np.float32).astype(float)
    for bump in (5e-4, 1e-3):  # 2 and 3 differences above the float32 step of 700 N
        y = x.copy()
        y[2001] += bump
        assert interpolation_factor([(0, y)]) is None


def test_zeroed_then_causally_filtered_plate_shows_the_filter_tail():
    """Zeroing, then a causal (one-pass) low-pass: its tail decays into the zero run after each
    load only, while the force before a load rises from 0 by the filter's first coefficient.
    Not a threshold step of ~1e-45 N (before: "step", censored at that value, or "continuous",
    zeroed at ~0 N). At 100 Hz the tail underflows float32 within ~0.25 s, inside the 0.55 s
    between the stances."""
    t, fz, noise = _plate_signal()
    z, other = _zeroed(fz + noise[:, 2], noise)
    b, a = signal.butter(2, 100.0, fs=RATE)
    x = signal.lfilter(b, a, np.column_stack([z, other]), axis=0).astype(np.float32).astype(float)
    p = detect_plate_processing(_plate(t, x[:, 0], x[:, 1:]))
    assert p.zero_edges == "filter tail" and p.filtered
    assert p.zero_threshold < 1e-3  # below any plate's resolution: arithmetic, not a load
    assert censor_threshold(p) == 0.0


def test_stance_edge_on_a_noisy_plate_is_not_an_unloaded_offset():
    """A 3 N mains hum raises the quiet limit of the 50 ms windows (3 x the quietest std, ~8 N)
    above the std of the window where a stance's force tapers to 0 (the toe leaving the plate:
    20 N to 0 over 45 ms, std ~6 N): that window's mean (~9 N) is a load, not an offset of the
    unloaded plate."""
    t, fz, noise = _plate_signal()
    hum = 3.0 * np.sin(2 * np.pi * 50.0 * t)
    end = 0.5 + 0.65  # the first stance ends on a window boundary (1150 samples = 23 windows)
    toe = np.where((t >= end) & (t < end + 0.045), 20.0 * (1.0 - (t - end) / 0.045), 0.0)
    p = detect_plate_processing(_plate(t, fz + toe + noise[:, 2] + hum, noise))
    assert p.unloaded_offsets == ()


@pytest.mark.parametrize("kind", ["linear", "cubic"])
def test_interpolated_plate_gives_its_native_rate(kind):
    """A 600 Hz export interpolated from 60 Hz samples and written with 6 decimals (text)."""
    rate0 = 60.0
    t0 = np.arange(int(4.0 * rate0)) / rate0
    _, fz, noise = _plate_signal()
    coarse = np.column_stack([fz + noise[:, 2], noise])[:: int(RATE / rate0)][: t0.size]
    t = np.arange(int(3.9 * 600.0)) / 600.0
    if kind == "linear":
        x = np.column_stack([np.interp(t, t0, c) for c in coarse.T])
    else:
        x = interpolate.CubicSpline(t0, coarse)(t)
    x = np.round(x, 6)
    p = detect_plate_processing(_plate(t, x[:, 0], x[:, 1:]))
    assert p.interpolation == kind and p.resampled
    assert p.native_rate_hz == pytest.approx(rate0, rel=1e-6)


def test_raw_plate_at_marker_rate_is_flagged():
    """A plate stored at the cameras' rate below 500 Hz was down-sampled (plates sample at
    >= 500 Hz); at 1000 Hz beside 1000 Hz cameras it may be at its own rate (before, it was
    reported "down-sampled" and ``resampled``)."""
    t, fz, noise = _plate_signal()
    plate = _plate(t, fz + noise[:, 2], noise)
    low = _plate(t[::5], (fz + noise[:, 2])[::5], noise[::5])  # 200 Hz
    assert detect_plate_processing(low, marker_rate=200.0).at_marker_rate
    assert not detect_plate_processing(plate, marker_rate=RATE).resampled
    assert not detect_plate_processing(plate, marker_rate=100.0).resampled


def test_unloaded_offset_left_after_load_is_flagged():
    t, fz, noise = _plate_signal()
    drift = np.where(t >= 3.6, 8.0, 0.0)  # the plate reads 8 N after the last stance
    p = detect_plate_processing(_plate(t, fz + noise[:, 2] + drift, noise))
    (t0, t1, level), *rest = p.unloaded_offsets
    assert not rest
    assert t0 == pytest.approx(3.6, abs=0.05) and t1 == pytest.approx(4.0, abs=0.05)  # windows
    # mean of 400 samples of 1.5 N noise: standard error 0.075 N; 0.5 N is > 6 of them
    assert level == pytest.approx(8.0, abs=0.5)


def test_cop_held_below_a_load_sets_the_cop_limit():
    """An export zeroed below 5 N whose COP below 50 N was replaced by the nearest valid one
    (as OpenSim MOT files are read: ``gc_ocp.io.opensim``)."""
    hold = 50.0
    t, fz, noise = _plate_signal(strike=False)
    raw, other = _zeroed(fz + noise[:, 2], noise, threshold=5.0)
    cop = np.column_stack([0.2 * np.sin(t), 0.05 * np.cos(t), np.zeros_like(t)])
    good = np.flatnonzero(raw > hold)
    nearest = good[np.clip(np.searchsorted(good, np.arange(t.size)), 0, good.size - 1)]
    force = np.column_stack([other[:, 0], other[:, 1], raw])
    plate = Plate("grf_right", t, force, np.cross(cop[nearest], force), np.zeros(3), "lab_origin")
    p = detect_plate_processing(plate)
    # the largest held load is a sample just below 50 N next to a crossing of 50 N: within that
    # crossing's change of 50 N, at most the largest such change
    above = raw >= hold
    i = np.flatnonzero(above[1:] != above[:-1])
    assert hold - np.max(np.abs(raw[i + 1] - raw[i])) <= p.cop_held_below <= hold
    assert p.cop_min_load >= p.cop_held_below
    raw_plate = _plate(t, *_zeroed(fz + noise[:, 2], noise, threshold=5.0))
    assert detect_plate_processing(raw_plate).cop_held_below is None  # a measured COP moves


# --- markers --------------------------------------------------------------------------------------


def test_raw_markers_have_a_white_floor():
    sigma = 3e-4
    t, _, raw = _markers(sigma=sigma)
    m = detect_marker_processing(raw, t)
    assert not m.filtered and m.lowpass_hz is None and m.native_rate_hz is None
    # the floor is the median, over the top bands, of Welch estimates averaged over ~8 windows:
    # the median of such an estimate is ~5 % below its mean; 15 % leaves room for band scatter
    assert m.noise_std == pytest.approx(sigma, rel=0.15)
    assert m.n_channels == 12


@pytest.mark.parametrize("order", [2, 4])
def test_markers_filtered_at_6_hz(order):
    cutoff = 6.0
    t, _, raw = _markers()
    m = detect_marker_processing(_filtered(raw, cutoff, order, rate=100.0), t)
    assert m.filtered and m.lowpass_basis == "marker spectrum"
    # read against an f^-7 trend on trajectories falling as f^-6: late by _late_factor(order, 1)
    # (1.2 for order 2); the stride's harmonics below ~8 Hz fall faster than any power law and
    # read early: one and a half bands either way (10^(1.5/8) = 1.54)
    assert _late_factor(order, MARKER_SLOPE - 6.0) < BAND**1.5
    assert cutoff / BAND**1.5 <= m.lowpass_hz <= cutoff * BAND**1.5


# --- the trial-level result -----------------------------------------------------------------------


def test_processing_to_json_and_summary():
    t, fz, noise = _plate_signal()
    tm, _, markers = _markers()
    trial = Trial(
        source=Path("synthetic.c3d"),
        marker_names=tuple(f"M{i}" for i in range(markers.shape[1])),
        markers=markers,
        marker_time=tm,
        plates=(_plate(t, *_zeroed(fz + noise[:, 2], noise)),),
        mass=70.0,
        height=None,
        stances=(),
    )
    proc = detect_processing(trial)
    data = json.loads(json.dumps(proc.to_json()))  # plain data, JSON round trip
    plate = data["plates"]["plate1"]
    assert plate["zero_threshold"] == float(f"{proc.plates['plate1'].zero_threshold:.4g}")
    assert plate["resampled"] is False and data["markers"]["filtered"] is False
    lines = proc.summary().splitlines()
    assert any("plate plate1: zeroed below" in s for s in lines)
    assert any(s.startswith("  markers: raw") for s in lines)
    assert len(lines) == 1 + len(proc.plates["plate1"].findings()) + len(proc.markers.findings())


# --- the real files -------------------------------------------------------------------------------


@functools.cache
def _real(marker: str, grf: str | None = None, mass: float | None = None) -> Trial:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return load_trial(DATA / marker, DATA / grf if grf else None, mass=mass)


@needs_data
@pytest.mark.parametrize(
    "marker, grf, mass",
    [
        (
            "opensim_rajagopal_overground/motion_capture_walk.trc",
            "opensim_rajagopal_overground/grf_walk.mot",
            85.07,
        ),
        (
            "opensim_gait2392_treadmill/subject01_walk1.trc",
            "opensim_gait2392_treadmill/subject01_walk1_grf.mot",
            72.6,
        ),
    ],
)
def test_opensim_mot_files_are_thresholded(marker, grf, mass):
    """The data README: the OpenSim MOT files are thresholded, exact zeros in swing."""
    proc = detect_processing(_real(marker, grf, mass))
    for p in proc.plates.values():
        assert p.zero_threshold is not None and p.zero_edges == "step"
        assert p.zero_threshold < 20.0  # below the stance threshold: stances are kept whole
        assert p.zero_offset is None  # nothing removed on load from a MOT


@needs_data
def test_unzeroed_c3d_plates_carry_their_removed_offset():
    """The data README: test_small plates 3 and 4 (our plate3, plate4) are not zeroed: they read
    -31.6 and -15.6 N unloaded, an offset the loader removes."""
    trial = _real("plugingait_overground/test_small.c3d")
    proc = detect_processing(trial)
    for plate in trial.plates[2:]:
        p = proc.plates[plate.name]
        assert p.zero_threshold is None
        assert p.zero_offset == tuple(plate.zero_offset)
        assert not p.filtered and p.noise_std is not None


@needs_data
def test_same_lab_same_verdicts():
    """One lab's processing is the same for every trial and plate: the five BTS repeats, and the
    two calibrations of the same c3d.org recording, get the same verdicts."""
    bts = [detect_processing(_real(f"bts_unipd_5trials/Walking{i}.c3d")) for i in range(1, 6)]
    verdicts = {
        (p.zero_threshold is None, p.zero_edges, p.filtered, p.resampled)
        for b in bts
        for p in b.plates.values()
    }
    assert len(verdicts) == 1
    assert {b.markers.filtered for b in bts} == {bts[0].markers.filtered}
    two = [detect_processing(_real(f"c3dorg_helenhayes_types/type-{k}a.c3d")) for k in (2, 4)]
    for name in two[0].plates:
        a, b = two[0].plates[name], two[1].plates[name]
        assert (a.zero_threshold, a.filtered) == (b.zero_threshold, b.filtered)


def _walking_files() -> list[tuple[Path, Path | None]]:
    """Every walking trial of ../shared/data: each C3D, each TRC with the MOT beside it (the
    static trials, named so by the data README, are left out: they have no stances)."""
    from gc_ocp.io.pairing import find_grf

    out = []
    for f in sorted(DATA.rglob("*")):
        if "static" in f.stem.lower() or f.suffix.lower() not in (".c3d", ".trc"):
            continue
        out.append((f, find_grf(f)[0] if f.suffix.lower() == ".trc" else None))
    return out


@needs_data
def test_every_shared_trial_gives_consistent_findings():
    """On every walking trial: the findings are plain data, and hang together (a cutoff below
    Nyquist; a raw verdict has a noise level; the COP limit covers the threshold)."""
    files = _walking_files()
    assert len(files) >= 10
    for marker, grf in files:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            trial = load_trial(marker, grf)
        proc = detect_processing(trial)
        json.dumps(proc.to_json())
        assert set(proc.plates) == {p.name for p in trial.plates}
        for p in [*proc.plates.values(), proc.markers]:
            if p.lowpass_hz is not None:
                assert p.filtered and 0 < p.lowpass_hz < p.rate_hz / 2
            assert p.filtered or p.noise_std is not None, (marker, p)
        for p in proc.plates.values():
            if p.zero_edges == "step":
                assert p.cop_min_load >= p.zero_threshold


def test_a_threshold_that_hides_much_of_the_stance_is_noted():
    """A lab threshold above a tenth of body weight is censored as any other, and the fit's
    notes say what it costs (a review: the bundled trial's plates zeroed at 120 N fitted at
    1.45 % BW against 1.93 % unzeroed, while predicting the unzeroed force worse); a threshold
    of a few per cent of body weight, as labs use, gets the plain note."""
    import dataclasses

    import gc_ocp
    from gc_ocp.workflow.fitting import HIGH_CENSOR_SHARE, fit_data

    trial = gc_ocp.load_trial()
    kin = gc_ocp.compute_kinematics(trial)
    for share, long in ((0.04, False), (1.5 * HIGH_CENSOR_SHARE, True)):
        x = share * trial.body_weight
        plates = []
        for p in trial.plates:
            low = (p.force[:, 2] < x)[:, None]
            plates.append(
                dataclasses.replace(
                    p, force=np.where(low, 0.0, p.force), moment=np.where(low, 0.0, p.moment)
                )
            )
        zeroed = dataclasses.replace(trial, plates=tuple(plates))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _, _, notes = fit_data([(zeroed, kin)])
        said = [n for n in notes if "was zeroed below" in n]
        assert said, notes  # every loaded plate's threshold is read and noted
        assert all(("of body weight" in n) == long for n in said)
