"""The time_offset effect: a constant delay of the force-plate clock behind the motion clock.

Convention under test: a positive delta means the plate is late, measured(t) = true(t - delta);
the model wrench at frame t is compared with the plate signal at t + delta.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from gc_ocp.bench import recovery
from gc_ocp.errors import InputError
from gc_ocp.estimation import build_estimation
from gc_ocp.estimation.components import REGISTRY, base_model, model_from_names
from gc_ocp.estimation.components.time_offset import TimeOffset, interpolation_weights

TRUE_DELAY = 0.020  # [s]
CHANNELS = (
    "anterior_force_pct_bw",
    "superior_force_pct_bw",
    "lateral_force_pct_bw",
    "anteroposterior_torque_pct_bwh",
    "longitudinal_torque_pct_bwh",
    "mediolateral_torque_pct_bwh",
)


def _motion():
    return recovery.bundled_base_truth()


def _noiseless(delay: float, **kw):
    stances, truth = _motion()
    delayed = TimeOffset(fixed={stances[0].trial: delay}, **kw)
    return recovery.simulate(stances, truth + (delayed,), np.random.default_rng(0), 0.0), truth


def _compared(stances, model, delay):
    """Model wrench and the measured wrench it is compared with, stacked over stances, at the
    truth's values and the given delay (every component fixed: x is empty)."""
    pb = build_estimation(stances, model + (TimeOffset(fixed={stances[0].trial: delay}),))
    x = np.zeros(pb.x0.size)
    return np.vstack(pb.stance_wrenches(x)), np.vstack(pb.stance_measured(x))


def test_registered_under_its_name():
    assert REGISTRY["time_offset"] is TimeOffset
    assert TimeOffset().name == "time_offset"


def test_kernel_is_a_kronecker_delta_at_the_grid_points():
    """Normalised Lanczos weights: 1 at the grid point itself and sin(pi j) ~ 1e-16 elsewhere,
    so at an integer offset the interpolant is that grid sample to round-off."""
    for u in (0, 3, -8, 20):
        w = interpolation_weights(u, 23)
        e = np.zeros(47)
        e[23 + u] = 1.0
        assert np.abs(w - e).max() < 1e-15
    assert interpolation_weights(0.37, 23).sum() == pytest.approx(1.0, abs=1e-15)


def test_zero_delay_reproduces_the_measured_wrench():
    """delta = 0: the comparison is exactly the base model's. The only difference is the kernel's
    weights at j != 0 (|sin(pi j)| < 1e-14 for |j| <= 23) times F(t + j h) - F(t) (< 1e3 N):
    below 1e-12 of the largest measured force."""
    stances, truth = _motion()
    pb = build_estimation(stances, truth + (TimeOffset(),))
    assert pb.x0.size == 1
    x = np.zeros(1)
    got = np.vstack(pb.stance_measured(x))
    want = np.vstack([st.measured for st in stances])
    scale = np.abs(want).max()
    print(f"delta = 0: max |measured - edited| = {np.abs(got - want).max():.2e} N")
    assert np.abs(got - want).max() <= 1e-12 * scale
    base = build_estimation(stances, truth)
    for a, b in zip(pb.stance_wrenches(x), base.stance_wrenches(np.zeros(0)), strict=True):
        np.testing.assert_array_equal(a, b)


def test_sign_convention_exact_on_the_grid():
    """The plate records the model wrench 20 ms late (observe). With the low-pass switched off,
    the grid points are the plate's own samples and 20 ms is 8 grid steps: comparing at
    delta = +20 ms gives back the model wrench at the frames (the spline through the frames is
    exact at them; 1e-9 of the largest force allows for np.interp at a plate sample computed
    as t0 + k / 1000). The opposite sign does not."""
    raw = {"lowpass": 1e9}
    data, truth = _noiseless(TRUE_DELAY, **raw)
    stances = _motion()[0]
    pb = build_estimation(stances, truth)
    wrench = np.vstack(pb.stance_wrenches(np.zeros(0)))
    scale = np.abs(wrench).max()
    for delay, close in ((TRUE_DELAY, True), (-TRUE_DELAY, False), (0.0, False)):
        pbd = build_estimation(data, truth + (TimeOffset(fixed={stances[0].trial: delay}, **raw),))
        meas = np.vstack(pbd.stance_measured(np.zeros(0)))
        err = np.abs(meas - wrench).max()
        print(f"no low-pass, delta = {delay * 1e3:+.0f} ms: max |edited - model| = {err:.3g} N")
        assert (err <= 1e-9 * scale) == close


def test_low_passed_shift_is_accurate():
    """The default: only the plate signal below 50 Hz is shifted, the rest stays at its sample.
    On the noiseless delayed plate the comparison at the true delay leaves < 0.5 % BW of Fz
    (the heel-strike content above 50 Hz that stays unshifted), 10 times less than at 0 or at
    the opposite sign; at an off-grid delay (17.3 ms, 6.92 steps) the Lanczos interpolation adds
    nothing visible."""
    stances = _motion()[0]
    bw = stances[0].body_weight
    for true in (TRUE_DELAY, 0.0173):
        data, truth = _noiseless(true)
        rms = {}
        for delay in (true, 0.0, -true):
            w, m = _compared(data, truth, delay)
            rms[delay] = float(np.sqrt(np.mean((w - m)[:, 2] ** 2)) / bw * 100)
        print(f"true {true * 1e3:.1f} ms: Fz RMS [% BW] by delay {rms}")
        assert rms[true] < 0.5
        assert rms[0.0] > 10 * rms[true] and rms[-true] > 10 * rms[true]


def test_a_stance_without_plate_signal_is_refused():
    st = dataclasses.replace(_motion()[0][0], plate_time=None, plate_wrench=None)
    with pytest.raises(InputError, match=re.escape(st.label)):
        build_estimation([st], base_model() + (TimeOffset(),))


def test_frozen_keeps_a_fitted_trial_and_re_estimates_a_new_one():
    stances = _motion()[0]
    trial = stances[0].trial
    fz = TimeOffset().frozen({trial: {"ms": 12.5, "ms_se": 0.3}})
    assert fz.fixed == {trial: pytest.approx(0.0125)}
    assert not build_estimation(stances, (base_model()[0], fz)).variables.has(
        ("time_offset", trial)
    )
    other = TimeOffset().frozen({"another_trial": {"ms": 12.5, "ms_se": 0.3}})
    pb = build_estimation(stances, (base_model()[0], other))
    assert pb.variables.has(("time_offset", trial))


def _rms_line(res) -> str:
    return "; ".join(
        f"{side}: " + " ".join(f"{res.rms[side][c]:.2f}" for c in CHANNELS) for side in res.rms
    )


def _heel_strike_information(res, data, model):
    """Fisher information on delta per frame (the squared residual derivatives, from the fitted
    problem's data Jacobian): the share carried by the first 50 ms after each contact onset, the
    share of frames that is, and the SE delta would have from those frames alone and from the
    rest alone [ms] (the other parameters held: no correlations)."""
    pb = build_estimation(data, model)
    _, J = pb.data_jacobian(res.x)
    spec = pb.variables.spec(("time_offset", data[0].trial))
    d = np.asarray(J[:, spec.slice.start].todense()).ravel() / float(spec.scale[0])  # [1/s]
    s2 = 2 * res.data_cost / max(res.n_data - res.n_free, 1)
    info_hs = info_rest = 0.0
    n_hs = start = 0
    for st in data:
        rows = d[start : start + 6 * st.n].reshape(st.n, 6)  # frame-major
        start += 6 * st.n
        onset = st.time[np.flatnonzero(st.in_contact)[0]]
        hs = (st.time >= onset - 1e-9) & (st.time < onset + 0.05)
        n_hs += int(hs.sum())
        info_hs += float(np.sum(rows[hs] ** 2)) / s2
        info_rest += float(np.sum(rows[~hs] ** 2)) / s2
    share = info_hs / (info_hs + info_rest)
    frames = n_hs / sum(st.n for st in data)
    return share, frames, 1e3 / np.sqrt(info_hs), 1e3 / np.sqrt(info_rest)


def test_recovery_of_a_20_ms_delay_on_real_motion():
    """The bundled trial's real motion, the base model's fit as truth, the plate 20 ms late,
    0.5 % BW plate noise. No marker noise: a marker error at heel strike is a timing error (the
    heel descends at ~0.1-0.3 m/s, so 1 mm is several ms) that the delay absorbs and the SE,
    conditional on the kinematics, does not include; with 0.3-1 mm of marker noise (noisy_pose)
    even the base model fitted to undelayed data leaves ~1.9 % BW on Fz, and the delay is then
    biased by several ms."""
    stances, truth = _motion()
    trial = stances[0].trial
    data = recovery.simulate(
        stances, truth + (TimeOffset(fixed={trial: TRUE_DELAY}),), np.random.default_rng(7)
    )
    model = model_from_names(["time_offset"], base=base_model())
    fit = recovery.fit_model(data, model)
    base = recovery.fit_model(data, base_model())
    b = fit.blocks["time_offset"][trial]
    z = (b["ms"] - TRUE_DELAY * 1e3) / b["ms_se"]
    share, frames, se_hs, se_rest = _heel_strike_information(fit, data, model)
    print(
        f"\ndelay: true {TRUE_DELAY * 1e3:.1f} ms, estimate {b['ms']:.3f} ms, "
        f"SE {b['ms_se']:.3f} ms, z = {z:+.2f}"
    )
    print(
        f"information on delta: {share:.0%} from the first 50 ms of each stance ({frames:.0%} of "
        f"the frames); SE from those frames alone {se_hs:.3f} ms, from the rest alone "
        f"{se_rest:.3f} ms (other parameters held)"
    )
    print("RMS per channel (Fx Fz Fy [% BW], Mx Mz My [% BW x H]); plate noise 0.5 % BW")
    print(f"  base + time_offset: {_rms_line(fit)}")
    print(f"  base alone:         {_rms_line(base)}")
    assert fit.success and base.success
    assert abs(z) < 3.0
    assert b["ms"] == pytest.approx(TRUE_DELAY * 1e3, abs=2.0)
    # the heel-strike transient is the densest source of information on the delay
    assert share > 3 * frames
    # the base model absorbs much of the delay in Fz (the stance-scope pose correction shifts the
    # heel's contact in time) but not in the shear: the anterior force shows it most
    for side in fit.rms:
        fit_rms, base_rms = fit.rms[side], base.rms[side]
        assert fit_rms["superior_force_pct_bw"] < 0.7  # at the plate noise
        assert fit_rms["anterior_force_pct_bw"] < 0.7
        assert base_rms["anterior_force_pct_bw"] > 2 * fit_rms["anterior_force_pct_bw"]
        assert base_rms["anterior_force_pct_bw"] > 2 * recovery.PLATE_NOISE_PCT_BW
        assert base_rms["superior_force_pct_bw"] > 1.3 * fit_rms["superior_force_pct_bw"]
