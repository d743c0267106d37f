"""The markers' error measured per trial, and the pose noise it leaves modelled in the estimator
(``gc_ocp/marker_noise.py``, ``docs/quality.md``)."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from conftest import synthetic_stances

from gc_ocp.geometry import kabsch
from gc_ocp.kinematics.filtering import lowpass
from gc_ocp.marker_noise import (
    MIN_UNIT_NOISE_M,
    pose_covariance,
    unit_noise_sd,
    white_noise,
)

RATE = 100.0


def _walking_like(rng, n=3000, m=4):
    """``(n, m, 3)`` [m] smooth marker paths (gait-like harmonics up to 5 Hz, 0.3 m)."""
    t = np.arange(n) / RATE
    out = np.zeros((n, m, 3))
    for h in range(1, 6):
        amp = rng.normal(0, 0.3 / h**2, (m, 3))
        ph = rng.uniform(0, 2 * np.pi, (m, 3))
        out += amp * np.sin(2 * np.pi * h * 0.9 * t[:, None, None] + ph)
    return out


def test_white_noise_recovers_the_noise_of_moving_markers():
    rng = np.random.default_rng(0)
    x = _walking_like(rng)
    sig = np.array([0.2e-3, 0.5e-3, 1.0e-3, 2.0e-3])
    est = white_noise(x + rng.normal(0, 1, x.shape) * sig[None, :, None], RATE)
    # the MAD of ~9000 Gaussian samples has a relative standard error of about
    # 1.1/sqrt(9000) ~ 1.2 %; the movement's leak above 20 Hz adds a little: 10 % is 8 such errors
    np.testing.assert_allclose(est, sig, rtol=0.10)


def test_markers_low_passed_before_export_show_almost_no_noise():
    rng = np.random.default_rng(1)
    x = _walking_like(rng) + rng.normal(0, 0.5e-3, (3000, 4, 3))
    est = white_noise(lowpass(x, RATE, 6.0), RATE)
    # a 6 Hz 4th-order low-pass leaves < 1e-3 of the noise's power above 20 Hz
    assert np.all(est < 0.05 * 0.5e-3)


def test_pose_covariance_is_that_of_a_rigid_fit_of_noisy_markers():
    rng = np.random.default_rng(2)
    mk = np.array(
        [[-0.07, 0.0, -0.03], [0.16, 0.0, -0.04], [0.0, -0.04, 0.0], [0.1, -0.045, -0.04]]
    )
    sigma, n = 1e-3, 4000
    obs = mk[None] + rng.normal(0, sigma, (n, 4, 3))
    R, o = kabsch(mk, obs)
    rot = np.stack([[r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]] for r in R]) / 2
    emp = np.cov(np.hstack([o, rot]).T)
    cov = pose_covariance(mk, sigma)
    # first-order theory against 4000 fits: each diagonal element's sampling error is
    # sqrt(2/4000) = 2.2 %; 12 % is five such errors
    np.testing.assert_allclose(np.diag(emp), np.diag(cov), rtol=0.12)
    assert pose_covariance(mk[:2], sigma) is None  # two markers do not fix a pose


def test_the_pipeline_measures_each_foot_and_models_the_noise_only_where_it_matters():
    sts, _ = synthetic_stances(np.random.default_rng(3), 0.5e-3)
    foot = sts[0].foot
    # measured from the raw virtual markers, not handed over: within 15 % of the 0.5 mm
    # (4 markers x 65 frames: a few % of MAD error per stance)
    assert foot.pose_noise.sigma_marker == pytest.approx(0.5e-3, rel=0.15)
    assert unit_noise_sd(foot.pose_noise, foot.points_in_hindfoot()) > MIN_UNIT_NOISE_M
    from gc_ocp.estimation import PoseCorrection
    from gc_ocp.estimation.problem import declare

    keys = [s.key for s in declare(sts[:1], (PoseCorrection(),))[2].specs]
    assert ("pose", sts[0].label, "noise") in keys
    quiet = dataclasses.replace(
        foot, pose_noise=dataclasses.replace(foot.pose_noise, cov=foot.pose_noise.cov * 1e-4)
    )
    st = dataclasses.replace(sts[0], foot=quiet)
    keys = [s.key for s in declare([st], (PoseCorrection(),))[2].specs]
    assert ("pose", st.label, "noise") not in keys


def test_modelling_the_measured_noise_removes_the_friction_bias():
    """0.5 mm of marker noise biased mu by -0.056 (40 draws, spread 0.010) before; with the noise
    part one draw's error is within 4 spreads of 0 and smaller than without it."""
    from gc_ocp.estimation import build_estimation
    from gc_ocp.estimation.solve import IpoptOptions, solve
    from gc_ocp.estimation.synthetic import recovery_model

    sts, truth = synthetic_stances(np.random.default_rng(4), 0.5e-3)
    err = {}
    for on in (True, False):
        model = recovery_model(marker_noise=on)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = solve(build_estimation(sts, model), IpoptOptions())
        err[on] = res.params["shared"]["mu"] - truth["mu"]
    assert abs(err[True]) < 0.03  # 4 x the 0.007 spread of benchmarks/coverage_output.md
    assert abs(err[True]) < abs(err[False])


def test_the_fit_corrects_the_bias_by_default_only_where_the_markers_noise_attenuates_mu():
    from gc_ocp.workflow.fitting import bias_replicates

    # 1 mm of marker noise moves the units by ~0.35 mm after the 6 Hz low-pass (mu -0.016 on
    # these stances, about two SEs): corrected by default, one note per foot
    noisy, _ = synthetic_stances(np.random.default_rng(3), 1e-3)
    n, notes = bias_replicates(None, noisy)
    assert n == 16 and len(notes) == 2 and all("16 simulated replicates" in m for m in notes)
    assert {m.split(" foot's")[0].split("the ")[-1] for m in notes} == {"left", "right"}
    mm = float(notes[0].split("units by ")[1].split(" mm")[0])
    assert 0.25 < mm < 0.45  # 1 mm through the 4-marker Kabsch fit and the 6 Hz filter
    # turned off, the notes say how to ask for it; a number given is kept
    n, notes = bias_replicates(0, noisy)
    assert n == 0 and all("--bias-correction 16" in m for m in notes)
    assert bias_replicates(4, noisy)[0] == 4
    # 0.2 mm of marker noise (~0.07 mm at the units) needs none, and nothing is said
    quiet, _ = synthetic_stances(np.random.default_rng(3), 0.2e-3)
    assert bias_replicates(None, quiet) == (0, [])
    assert bias_replicates(8, quiet) == (8, [])


@pytest.fixture(scope="module")
def noisy_bundled():
    """The bundled trial with 1 mm of white noise on every marker (0.57-0.62 mm at the contact
    units through its three-marker feet) and its kinematics."""
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = load_trial()
        m = np.array(t.markers, float)
        m += np.random.default_rng(0).normal(0, 1e-3, m.shape)
        t = dataclasses.replace(t, markers=m)
        return t, compute_kinematics(t)


def test_a_fit_of_noisy_markers_is_corrected_by_default_and_says_so(noisy_bundled):
    """``fit`` with its defaults makes the 16 replicates, names the feet in its checks and
    records the correction in ``fit.json``."""
    from gc_ocp.workflow.fitting import fit

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rep = fit([noisy_bundled])
    assert rep.bias is not None and rep.bias.replicates + rep.bias.failed == 16
    advice = [c for c in rep.checks if "16 simulated replicates" in c]
    assert len(advice) == 2  # one per foot
    d = rep.to_json()
    assert d["bias_correction"]["replicates"] == rep.bias.replicates
    assert d["bias_correction"]["seed"] == 0  # recorded: the same data give the same replicates
    assert set(d["bias_correction"]["linearised_se"]) >= {"n", "c", "mu"}


def test_a_failed_correction_keeps_the_converged_fit_and_flags_it(noisy_bundled, monkeypatch):
    """The replicates' refits failing (simulated: ``bias_corrected`` raising as it does when
    fewer than two converge) must not lose the fit: it is kept uncorrected, with its linearised
    SEs, flagged, and ``fit.json`` says why no correction was made."""
    import gc_ocp.workflow.fitting as fitting
    from gc_ocp.errors import SolveError

    def failing(*args, **kwargs):
        raise SolveError("bias correction: 15 of 16 replicate refits failed")

    monkeypatch.setattr(fitting, "bias_corrected", failing)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rep = fitting.fit([noisy_bundled], bias_correction=4)
    assert rep.bias is None and rep.result.success
    [flag] = [f for f in rep.result.flags if f["code"] == "bias_correction_failed"]
    assert "15 of 16" in flag["message"] and "uncorrected" in flag["message"]
    shared = rep.result.params["shared"]
    assert all(np.isfinite(shared[p + "_se"]) and shared[p + "_se"] > 0 for p in ("n", "mu"))
    assert rep.to_json()["bias_correction"] == {
        "replicates": 0,
        "message": "not made: failed (see the flags)",
    }


def test_a_noisy_marker_is_named_and_every_trial_reports_its_markers_noise():
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics
    from gc_ocp.workflow.fitting import marker_notes

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = load_trial()
        j = t.marker_names.index("LTOE")
        m = np.array(t.markers, float)
        m[:, j] += np.random.default_rng(5).normal(0, 3e-3, m[:, j].shape)  # a loose marker
        notes = marker_notes(t.source, compute_kinematics(dataclasses.replace(t, markers=m)))
    assert "markers' white noise [mm] per segment" in notes[0] and "left:" in notes[0]
    named = [n for n in notes[1:] if "marker LTOE" in n]
    # measured 3 mm within 15 % (one marker, ~300 frames), far above its segment's ~0.005 mm
    assert len(named) == 1 and len(notes) == 2
    mm = float(named[0].split("white noise ")[1].split(" mm")[0])
    assert mm == pytest.approx(3.0, rel=0.15)


def test_a_noisy_marker_is_named_in_a_class_of_one_or_two():
    """The marker itself is left out of the median it is compared with: a Davis / Helen Hayes
    foot's two markers, or a segment's only marker, could never exceed three times a median
    they make half or all of (the check never fired there)."""
    from gc_ocp.kinematics.marker_error import MarkerError

    classes = {"LHEE": "hindfoot_l", "LTOE": "hindfoot_l", "LTIB": "shank_l"}
    classes |= {f"P{i}": "pelvis" for i in range(4)}
    quiet = {n: 0.1 for n in classes}
    assert MarkerError(quiet, classes, 20.0).outliers() == []
    for loose in ("LHEE", "LTIB"):  # one of a foot's two markers; a segment's only marker
        err = MarkerError(quiet | {loose: 3.0}, classes, 20.0)
        [named] = err.outliers()
        assert named.startswith(f"marker {loose} (") and "white noise 3.00 mm, 30.0x" in named
    # below OUTLIER_MM nothing is named, whatever the ratio; a class of two both loose is named
    # by neither (each is the other's reference) but shows in its class's figure
    assert MarkerError(quiet | {"LHEE": 0.9}, classes, 20.0).outliers() == []
    both = MarkerError(quiet | {"LHEE": 3.0, "LTOE": 3.0}, classes, 20.0)
    assert both.outliers() == [] and both.per_class()["hindfoot_l"] == 3.0


def test_a_helen_hayes_foots_noisy_marker_is_named():
    """On a real Helen Hayes trial (two markers on each foot, the ankle on the shank) a loose
    heel marker is named by the kinematics (``marker_error``, in ``fit.json``)."""
    from conftest import DATA, _need_data

    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics

    _need_data()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = load_trial(DATA / "c3dorg_helenhayes_types/type-2a.c3d", mass=55.0)
        j = t.marker_names.index("LHEE")
        m = np.array(t.markers, float)
        m[:, j] += np.random.default_rng(5).normal(0, 3e-3, m[:, j].shape)
        err = compute_kinematics(dataclasses.replace(t, markers=m)).info["marker_error"]
    assert [o.split(" (")[0] for o in err["outliers"]] == ["marker LHEE"]
    assert "hindfoot_l" in err["outliers"][0]


def test_a_foot_marker_missing_from_the_stances_does_not_fix_the_pose_noise():
    """The pose noise is that of the rigid fit of the foot markers seen where the foot is
    fitted: the BTS trials lose both metatarsal markers in every right stance, and a foot
    posed there from two landmarks has no modelled noise (``_foot_noise``'s rule), not the
    four-marker fit's. Here the bundled trial's LTOE is taken out of its left stance (the left
    foot keeps LHEE and LANK there); a short dropout of it keeps the noise modelled."""
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics
    from gc_ocp.workflow.fitting import marker_notes

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = load_trial()
        [left] = [s for s in t.stances if s.side == "left"]
        tt = np.asarray(t.marker_time)
        stance = (tt >= left.t_on) & (tt <= left.t_off)
        j = t.marker_names.index("LTOE")
        m = np.array(t.markers, float)
        m[stance, j] = np.nan
        kin = compute_kinematics(dataclasses.replace(t, markers=m))
        short = np.array(t.markers, float)
        short[np.flatnonzero(stance)[:20], j] = np.nan  # 20 of the stance's 68 frames
        kin_short = compute_kinematics(dataclasses.replace(t, markers=short))
    assert kin.feet["left"].pose_noise is None and kin.info["foot_pose_noise"]["left"] is None
    assert kin.feet["right"].pose_noise is not None
    assert (
        "left: not (fewer than 3 foot markers seen in its stances" in marker_notes(t.source, kin)[0]
    )
    assert kin_short.feet["left"].pose_noise is not None


def test_the_samples_the_loader_interpolated_are_not_measured_as_noise(tmp_path):
    """The loader fills gaps of up to 0.1 s with a spline (``Trial.marker_filled``); those
    smooth stretches are no camera's samples, and left in they lowered the noise's MAD (to
    0.60 +- 0.03 of it here over 8 draws, 27 % of the frames filled; 0.98 +- 0.05 without
    them). A TRC of the Rajagopal trial whose R.Toe carries 1 mm of noise and 8-frame gaps
    every 30 frames: measured within 20 % (4 of those spreads) of 1 mm."""
    import shutil

    from conftest import RAJ, rajagopal_trial

    from gc_ocp.export.opensim_files import write_trc
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics

    t = rajagopal_trial()
    j = t.marker_names.index("R.Toe")
    m = np.array(t.markers, float)
    m[:, j] += np.random.default_rng(9).normal(0, 1e-3, m[:, j].shape)
    for a in range(30, len(m) - 10, 30):
        m[a : a + 8, j] = np.nan
    write_trc(tmp_path / "walk.trc", t.marker_names, m, np.asarray(t.marker_time))
    shutil.copy(RAJ / "grf_walk.mot", tmp_path / "walk_grf.mot")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gappy = load_trial(tmp_path / "walk.trc", grf=tmp_path / "walk_grf.mot", mass=t.mass)
        err = compute_kinematics(gappy).info["marker_error"]
    assert err["white_mm"]["R.Toe"] == pytest.approx(1.0, rel=0.2)
    assert gappy.marker_filled[:, j].sum() == 8 * len(range(30, len(m) - 10, 30))


def test_the_report_names_the_band_the_noise_was_read_in():
    """At a 50 Hz camera the noise is read above 15 Hz (0.3 of the rate, so the band keeps some
    width below Nyquist), and the kinematics' info (fit.json) says 15 Hz, not the 20 Hz of a
    faster camera (it always said 20)."""
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics
    from gc_ocp.marker_noise import NOISE_BAND_HZ, noise_band_hz

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = load_trial()
        slow = dataclasses.replace(
            t, markers=np.asarray(t.markers)[::2], marker_time=np.asarray(t.marker_time)[::2]
        )
        info = {r: compute_kinematics(x).info["marker_error"] for r, x in (("t", t), ("s", slow))}
    assert slow.marker_rate == pytest.approx(t.marker_rate / 2)
    assert noise_band_hz(slow.marker_rate) == pytest.approx(15.0)
    assert "above 15 Hz" in info["s"]["method"]
    assert f"above {NOISE_BAND_HZ:g} Hz" in info["t"]["method"]  # the bundled trial: 100 Hz


@pytest.mark.parametrize("drift_mm", [0.0, 4.0])
def test_the_pose_width_follows_the_kinematic_error_in_the_data(drift_mm):
    """Type-II ML of the pose correction's smooth width (gc_ocp/estimation/pose_scale.py): with
    exact kinematics the data ask for less than the guessed 2 mm / 1 deg; with a 4 mm
    soft-tissue drift, for more (the direction is the check; the sizes depend on the draw)."""
    from gc_ocp.diagnosis.mismatch import drift
    from gc_ocp.estimation import build_estimation
    from gc_ocp.estimation.pose_scale import estimate_pose_scale
    from gc_ocp.estimation.solve import IpoptOptions, solve
    from gc_ocp.estimation.synthetic import recovery_model

    rng = np.random.default_rng(6)
    sts, _ = synthetic_stances(rng, 0.0)
    if drift_mm:
        sts = drift(sts, drift_mm * 1e-3, 0.25 * drift_mm, rng)
    model = recovery_model()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = solve(build_estimation(sts, model), IpoptOptions())
        _, res2, scale = estimate_pose_scale(sts, model, res)
    mm = np.mean(scale.sigma_mm)
    # the refit's pose block records the widths it used (the reports print them)
    assert res2.blocks["pose"]["prior_mm"] == pytest.approx(np.broadcast_to(scale.sigma_mm, 3))
    # only the last round's refit computes the covariance, and the fit returned carries it
    assert res2.covariance is not None and np.all(np.isfinite(np.diag(res2.covariance)))
    if drift_mm:
        assert mm > 2.0
        # a wider prior makes the same correction cheaper: the refit ends lower
        assert res2.objective < res.objective
    else:
        assert mm < 2.0 and np.mean(scale.sigma_deg) < 1.0


def test_the_diagnosis_refuses_an_unknown_pose_width():
    from gc_ocp.diagnosis import diagnose_stances
    from gc_ocp.errors import ModelError

    sts, _ = synthetic_stances(np.random.default_rng(7), 0.0)
    with pytest.raises(ModelError, match="pose_width"):
        diagnose_stances(sts, pose_width="guessed")


def test_a_width_at_its_limit_says_what_to_do_where_it_is_read():
    """A fit's width at the soft tissue's limit sends the user to the diagnosis; inside a
    diagnosis (its notes) the same line points to the candidates instead."""
    from gc_ocp.estimation.pose_scale import PLAUSIBLE_MM, PoseScale

    scale = PoseScale((PLAUSIBLE_MM, 1.0, 1.0), (1.0, 1.0, 1.0), (1.0,), 6, [], 3)
    assert not scale.plausible
    assert "run the diagnosis" in scale.message()
    inside = scale.message("the diagnosis's candidates test the unmodelled effects")
    assert "run the diagnosis" not in inside and "diagnosis's candidates" in inside
    assert "candidates" not in PoseScale((1.0,) * 3, (1.0,) * 3, (1.0,), 6, [], 3).message(
        "candidates"
    )


def test_the_sole_width_never_goes_below_the_models_own_prior():
    """The rounds widen the sole's prior and never narrow it: the floor is the prior the model
    came with (here 8 mm, not the default 5), on stances whose units sit where the fitter puts
    them (the data ask for less)."""
    import dataclasses

    from gc_ocp.estimation import build_estimation
    from gc_ocp.estimation.components.sole import SoleCorrection
    from gc_ocp.estimation.pose_scale import estimate_pose_scale
    from gc_ocp.estimation.solve import IpoptOptions, solve
    from gc_ocp.estimation.synthetic import recovery_model

    sts, _ = synthetic_stances(np.random.default_rng(8), 0.0)
    model = tuple(
        dataclasses.replace(c, sigma=0.008) if isinstance(c, SoleCorrection) else c
        for c in recovery_model(marker_noise=False)
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = solve(build_estimation(sts, model), IpoptOptions())
        _, _, scale = estimate_pose_scale(sts, model, res, sole=True)
    assert scale.sole_mm == pytest.approx((8.0, 8.0, 8.0))
    assert scale.sole_floor_mm == pytest.approx((8.0, 8.0, 8.0))


def test_a_sole_width_at_the_limit_is_flagged_unless_it_is_the_users_prior():
    """``PoseScale.plausible``: a sole width the data pushed to the 10 mm limit is flagged; a
    user's prior at or above the limit (the floor the rounds started from) is not."""
    from gc_ocp.estimation.pose_scale import SOLE_PLAUSIBLE_MM, PoseScale

    def scale(sole_mm, floor):
        return PoseScale((1.0,) * 3, (1.0,) * 3, (1.0,), 6, [], 3, sole_mm, (1.0,) * 3, floor)

    lim = SOLE_PLAUSIBLE_MM
    assert not scale((lim, 5.0, 5.0), (5.0, 5.0, 5.0)).plausible
    assert scale((9.0, 5.0, 5.0), (5.0, 5.0, 5.0)).plausible
    assert scale((20.0, 20.0, 20.0), (20.0, 20.0, 20.0)).plausible
    assert not scale((lim, 5.0, 5.0), None).plausible  # no floor recorded: the limit counts
    # fit.json carries what the verdicts read: the floor and the last round's move
    doc = scale((20.0, 20.0, 20.0), (20.0, 20.0, 20.0)).to_json()
    assert doc["sole_floor_mm"] == [20.0, 20.0, 20.0] and doc["plausible"]
    assert doc["last_change"] == 0.0 and doc["converged"]
    assert "sole_floor_mm" not in scale((9.0, 5.0, 5.0), None).to_json()


@pytest.mark.parametrize("offset_mm", [0.0, 8.0])
def test_the_sole_width_follows_the_units_misplacement_in_the_data(offset_mm):
    """Type-II ML of the sole correction's width (``estimate_pose_scale(..., sole=True)``): the
    fitter's unit points moved off the truth's by offsets of SD ``offset_mm`` per axis (one
    draw per unit and side); with none the data ask for less than the prior's 5 mm, where the
    widths stop (the floor), with 8 mm for more on some axis (the direction is the check).
    The pose widths
    are estimated in the same rounds, and a refit with the wider sole prior ends lower."""
    from gc_ocp.estimation import build_estimation
    from gc_ocp.estimation.pose_scale import SOLE_MIN_MM, estimate_pose_scale
    from gc_ocp.estimation.solve import IpoptOptions, solve
    from gc_ocp.estimation.synthetic import recovery_model

    rng = np.random.default_rng(8)
    sts, _ = synthetic_stances(rng, 0.0)
    off = {
        side: rng.normal(0.0, offset_mm * 1e-3, sts[0].foot.points_local.shape)
        for side in ("left", "right")
    }
    sts = [st.with_foot(st.foot.with_points(st.foot.points_local + off[st.side])) for st in sts]
    model = recovery_model(marker_noise=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = solve(build_estimation(sts, model), IpoptOptions())
        _, res2, scale = estimate_pose_scale(sts, model, res, sole=True)
    assert scale.sole_mm is not None and scale.to_json()["sole_mm"] == list(scale.sole_mm)
    assert len(scale.sole_mm) == 3  # one per foot-frame axis
    # ten units give a rough estimate per axis: at least one axis is widened (here the
    # forward one, 9 mm; the others stay at the prior)
    if offset_mm:
        assert max(scale.sole_mm) > 5.0
        assert res2.objective < res.objective
    else:  # the data ask for less: each width stays at the prior, its floor (SOLE_MIN_MM)
        assert scale.sole_mm == pytest.approx((SOLE_MIN_MM,) * 3)
    assert res2.blocks["sole"]["prior_mm"] == pytest.approx(scale.sole_mm)


def test_the_units_lever_arms_are_in_the_hindfoot_frame_a_toe_unit_too(bundled_stances):
    """The hindfoot pose's error moves a toe unit through its distance from the hindfoot's
    origin, not from the toes' (where ``points_local`` holds it): the toe unit's row is its
    toes-frame position carried through the toes' placement at the middle frame."""
    foot = bundled_stances[0].foot
    P = foot.points_in_hindfoot()
    k = foot.time.shape[0] // 2
    for i, parent in enumerate(foot.layout.parents):
        if parent == "hindfoot":  # its own frame: unchanged (round-off of one rigid transform)
            np.testing.assert_allclose(P[i], foot.points_local[i], atol=1e-12)
        else:
            rel = np.linalg.inv(foot.hindfoot_pose[k]) @ foot.toes_pose[k]
            want = rel[:3, :3] @ foot.points_local[i] + rel[:3, 3]
            np.testing.assert_allclose(P[i], want, atol=1e-12)
            # farther from the hindfoot's origin than from the toes': the longer lever arm
            assert np.linalg.norm(P[i]) > np.linalg.norm(foot.points_local[i])
