"""The plates are read at the frames through an anti-alias low-pass (gc_ocp.antialias)."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import gc_ocp
from gc_ocp.antialias import PASS_FRACTION, band_limited, needs_filter
from gc_ocp.stance import stance_data, without_other_loads
from gc_ocp.workflow.fitting import fit_data

PLATE_RATE, FRAME_RATE = 1020.0, 60.0  # BTS: a plate 17 times faster than the frames


def _signal(t):
    """A walking-like vertical force (content well inside the pass band) and a 40 Hz ripple,
    above the 60 Hz frames' Nyquist frequency (30 Hz): what a heel-strike transient or hum is."""
    slow = 600.0 * np.sin(np.pi * t / 0.6) ** 2 + 80.0 * np.sin(2 * np.pi * 5.0 * t)
    fast = 30.0 * np.sin(2 * np.pi * 40.0 * t + 0.3)
    return slow, fast


def test_content_above_the_frames_nyquist_does_not_alias_into_their_band():
    t = np.arange(0.0, 3.0, 1.0 / PLATE_RATE)
    slow, fast = _signal(t)
    x = np.column_stack([slow + fast, np.zeros_like(t)])
    frames = np.arange(1.0, 2.0, 1.0 / FRAME_RATE)  # away from the recording's ends
    read = np.interp(frames, t, band_limited(t, x, FRAME_RATE)[:, 0])
    want = np.interp(frames, t, slow)
    point = np.interp(frames, t, slow + fast)
    # the point samples carry the 40 Hz ripple as a 20 Hz alias (up to its 30 N amplitude)
    assert np.max(np.abs(point - want)) > 20.0
    # the band-limited read is the slow force: the pass band (<= 18 Hz) is flat within 0.3 %
    # of power (0.15 % of amplitude: <= 1.2 N on the 680 N of the slow part) and 40 Hz is
    # 120 dB down; 1 N more for linear interpolation of the filtered 1020 Hz samples
    assert np.max(np.abs(read - want)) < 2.2


def test_a_plate_stored_at_the_frame_rate_is_read_as_it_is():
    t = np.arange(0.0, 1.0, 1.0 / FRAME_RATE)
    x = np.column_stack([np.sin(7 * t), np.cos(3 * t)])
    assert not needs_filter(FRAME_RATE, FRAME_RATE)
    np.testing.assert_array_equal(band_limited(t, x, FRAME_RATE), x)
    assert not needs_filter(PLATE_RATE, None)  # no frames given: the raw samples


def test_a_missing_plate_sample_stays_missing():
    t = np.arange(0.0, 2.0, 1.0 / PLATE_RATE)
    x = np.column_stack([np.sin(2 * np.pi * t)] * 2)
    x[1000] = np.nan
    out = band_limited(t, x, FRAME_RATE)
    assert np.isnan(out[1000]).all()
    # the rest bridged, not lost: beyond one frame period of it (a frame next to a lone
    # missing sample is missing, as without the filter), every sample is read
    far = np.abs(t - t[1000]) > 1.0 / FRAME_RATE
    assert np.isfinite(out[far]).all()


@pytest.fixture(scope="module")
def bundled():
    trial = gc_ocp.load_trial()
    return trial, gc_ocp.compute_kinematics(trial)


def test_a_stances_frames_read_its_plate_signal(bundled):
    """The frames' measured wrench is the plate signal a clock offset resamples, read at their
    times (one signal, so a clock offset of 0 changes nothing), and it is the band-limited
    one: the whole recording filtered gives the same values (the window reaches far enough)."""
    trial, kin = bundled
    stance = trial.stances[0]
    data = stance_data(trial, kin, stance, margin=0.03)
    again = np.column_stack(
        [np.interp(data.time, data.plate_time, data.plate_wrench[:, c]) for c in range(6)]
    )
    np.testing.assert_allclose(again, data.measured, rtol=0, atol=1e-9)
    t = trial.plates[stance.plate].time
    signal = without_other_loads(trial, stance, t, trial.stance_wrench(stance, t))
    whole = band_limited(t, signal, 100.0)  # the bundled trial's frames are at 100 Hz
    fz = np.interp(data.time, t, whole[:, 2])
    # the same filter on other windows of one signal: equal to round-off (1e-6 N on 600 N)
    np.testing.assert_allclose(data.measured[:, 2], fz, rtol=0, atol=1e-6)
    raw = trial.stance_wrench(stance, data.time)
    assert np.sqrt(np.mean((raw[:, 2] - data.measured[:, 2]) ** 2)) > 1.0  # it did something


def test_the_fit_says_how_the_plates_were_read(bundled):
    trial, kin = bundled
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, _, notes = fit_data([(trial, kin)])
    said = [n for n in notes if "anti-alias" in n]
    assert len(said) == len({s.plate for s in trial.stances})  # one note per plate stood on
    assert f"flat to {PASS_FRACTION * 100:.0f} Hz" in said[0] and "% BW RMS" in said[0]


def test_a_plate_at_the_frame_rate_gets_no_note(bundled):
    trial, kin = bundled
    foot = next(iter(kin.feet.values()))
    rate = 1.0 / float(np.median(np.diff(foot.time)))
    step = int(round(trial.plates[0].rate / rate))
    slow = [
        dataclasses.replace(p, time=p.time[::step], force=p.force[::step], moment=p.moment[::step])
        for p in trial.plates
    ]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, _, notes = fit_data([(dataclasses.replace(trial, plates=tuple(slow)), kin)])
    assert not [n for n in notes if "anti-alias" in n]


def test_a_time_column_rounded_to_0_1_ms_is_still_stopped_at_the_frames_nyquist():
    """A 600 Hz OpenSim .mot written to 0.1 ms (steps of 1.6 and 1.7 ms): the plate's rate is
    its samples over its duration, 600 Hz; the median step made it 588 Hz, and the filter for
    that was only 88 dB down at the 60 Hz frames' Nyquist frequency (30 Hz)."""
    true = np.arange(0.0, 6.0, 1.0 / 600.0)
    t = np.round(true, 4)
    x = np.column_stack([np.sin(2 * np.pi * 30.0 * true)] * 2)  # amplitude 1 at 30 Hz
    out = band_limited(t, x, FRAME_RATE)[t.size // 3 : 2 * t.size // 3, 0]  # off the ends
    # 120 dB by design (module doc) is 1e-6; 100 dB (1e-5) is what the median rate missed
    assert np.max(np.abs(out)) < 1e-5


def test_a_frame_near_a_dropout_reads_no_bridged_guess():
    """A 24 ms dropout (NaN) in a heel strike: the filter bridges it linearly, and a frame
    whose value draws on that guess is missing, not read off by up to 59 N (the frame at the
    last sample before the dropout, before this rule)."""
    rate, frames = 1000.0, 100.0
    t = np.arange(0.0, 3.0, 1.0 / rate)
    u = np.clip((t - 1.0) / 0.6, 0.0, 1.0)
    fz = np.where(
        (u > 0) & (u < 1),
        700 * np.sqrt(np.sin(np.pi * u)) + 300 * np.exp(-(((t - 1.03) / 0.01) ** 2)),
        0.0,
    )
    whole = np.column_stack([fz, fz])
    gappy = whole.copy()
    gappy[(t > 1.0205) & (t < 1.0445)] = np.nan
    at = np.arange(0.5, 2.0, 1.0 / frames)
    want = np.interp(at, t, band_limited(t, whole, frames)[:, 0])
    read = np.interp(at, t, band_limited(t, gappy, frames)[:, 0])
    ok = np.isfinite(read)
    # a frame read is within 1 % (BRIDGE_SHARE) of the bridge's largest error (the ~300 N
    # transient it cuts) of the dropout-free reading: 3 N
    assert np.max(np.abs(read[ok] - want[ok])) < 3.0
    # and the dropout costs frames near it only (within 0.1 s), not the stance
    assert ok[np.abs(at - 1.032) > 0.1].all()
