"""The markers' noise's bias estimated by simulation and removed (``gc_ocp/estimation/bias.py``,
``docs/quality.md``). Whether it removes the bias over many draws is scored by
``benchmarks/coverage.py --bias-correction``; these tests check its parts."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from conftest import synthetic_stances

from gc_ocp.errors import InputError
from gc_ocp.estimation.bias import (
    BiasCorrection,
    bias_corrected,
    block_signs,
    draw_pose_noise,
    draws_drift,
    no_drift_reason,
    replicate_covariance,
    replicate_data,
)
from gc_ocp.estimation.pose_scale import PLAUSIBLE_MM
from gc_ocp.foot import PoseNoise
from gc_ocp.marker_noise import filter_gain


def test_block_signs_are_constant_within_blocks_and_balanced():
    rng = np.random.default_rng(0)
    s = block_signs(1000, 10, 400, rng)
    assert s.shape == (1000, 400) and set(np.unique(s)) == {-1.0, 1.0}
    # a sign changes at most once per 10 frames in every column (blocks of 10 with a random
    # phase), and changes somewhere (the blocks are independent)
    changes = np.abs(np.diff(s, axis=0)) > 0
    for j in range(s.shape[1]):
        idx = np.flatnonzero(changes[:, j])
        assert idx.size > 0 and np.all(np.diff(idx) % 10 == 0)
    # balanced: 400 x 100 blocks, the mean sign's SD is 1 / sqrt(40 000) = 0.005
    assert abs(s.mean()) < 0.02


def test_a_fresh_draw_of_the_pose_noise_has_the_measured_size_after_the_low_pass():
    from gc_ocp.synthetic_foot import rolling_foot

    foot = rolling_foot("left", duration=40.0)  # 4000 frames
    assert draw_pose_noise(foot, np.random.default_rng(0)) is foot  # nothing measured
    sd = np.array([0.4e-3, 0.3e-3, 0.5e-3, 0.004, 0.002, 0.003])
    noise = PoseNoise(np.diag(sd**2), 100.0, 6.0, 4, 1e-3)
    foot = dataclasses.replace(foot, pose_noise=noise)
    seen = draw_pose_noise(foot, np.random.default_rng(1))
    assert seen.pose_noise is noise
    d = seen.hindfoot_pose[:, :3, 3] - foot.hindfoot_pose[:, :3, 3]  # lab
    R = foot.hindfoot_pose[:, :3, :3]
    d_local = np.einsum("nji,nj->ni", R, d)
    # the low-pass keeps filter_gain of the white variance; 4000 frames correlated over ~10
    # give ~400 independent samples: a variance's relative SE sqrt(2 / 400) = 7 %, so 30 %
    # is over four of them
    np.testing.assert_allclose(d_local.var(axis=0), filter_gain(noise) * sd[:3] ** 2, rtol=0.3)
    # and the twists follow the moved poses (velocity = rate of the moved origin, to the
    # product rule of two central differences at 100 Hz: 0.4 mm/s here, against a noise
    # velocity of ~10 mm/s that must not be missing)
    v = np.gradient(seen.hindfoot_pose[:, :3, 3], seen.time, axis=0)
    np.testing.assert_allclose(seen.hindfoot_twist[:, :3], v, atol=1e-3)
    assert np.abs(seen.hindfoot_twist[:, :3] - foot.hindfoot_twist[:, :3]).max() > 5e-3


def test_the_drawn_noise_is_as_large_at_a_stance_s_ends_as_in_its_middle():
    """The pipeline low-passed the whole trial, so a stance's first frame is an interior one of
    the filter: the drawn noise must not be larger there (``filtfilt`` over the stance's window
    alone gives ten times the variance at its ends)."""
    from gc_ocp.synthetic_foot import rolling_foot

    foot = rolling_foot("left", duration=0.75)  # one stance, 75 frames
    noise = PoseNoise(np.diag(np.r_[np.full(3, 1e-6), np.full(3, 1e-4)]), 100.0, 6.0, 4, 1e-3)
    foot = dataclasses.replace(foot, pose_noise=noise)
    rng = np.random.default_rng(2)
    d = np.array(
        [draw_pose_noise(foot, rng).hindfoot_pose[:, 0, 3] - foot.hindfoot_pose[:, 0, 3]
         for _ in range(400)]
    )  # fmt: skip
    var = d.var(axis=0) / (filter_gain(noise) * 1e-6)  # 1 where the low-passed noise is right
    # 400 draws: a variance's relative SE sqrt(2 / 400) = 7 %; 30 % is over four of them (the
    # window's own filtfilt is 10x at frame 0)
    np.testing.assert_allclose(var[[0, 37, -1]], 1.0, rtol=0.3)


def test_a_replicate_walks_the_recorded_motion_seen_through_new_noise():
    from gc_ocp.estimation import build_estimation
    from gc_ocp.estimation.solve import IpoptOptions, result_at, solve
    from gc_ocp.estimation.synthetic import recovery_model

    sts, _ = synthetic_stances(np.random.default_rng(5), 1e-3, per_foot=2)
    sts[0] = dataclasses.replace(sts[0], censor_below=20.0)
    model = recovery_model()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = solve(build_estimation(sts, model), IpoptOptions())
    rep = replicate_data(sts, model, res, np.random.default_rng(0), drift=False)
    pb = build_estimation(sts, model)
    x0 = res.x.copy()
    for s in pb.variables.specs:
        if s.key[0] == "pose":
            x0[s.start : s.start + s.size] = 0.0
    recorded = result_at(pb, x0, covariance=False).stance_fits
    for st, r, f, f0 in zip(sts, rep, res.stance_fits, recorded, strict=True):
        assert r.label == st.label and r.censor_below == st.censor_below
        # the same motion seen through new noise of the measured size: the poses differ from
        # the recorded ones by a fraction of a millimetre, not by nothing
        dp = np.abs(r.foot.hindfoot_pose[:, :3, 3] - st.foot.hindfoot_pose[:, :3, 3])
        assert 1e-6 < dp.max() < 5e-3
        # recorded as the lab did: below its threshold the plate reads exactly zero
        assert np.isfinite(r.measured).all() and r.measured.shape == st.measured.shape
        if st.censor_below > 0:
            low = r.measured[:, 2] < st.censor_below
            assert low.any() and np.all(r.measured[low] == 0.0)
        # the plate data are the fitted model's wrench on the recorded motion (its pose
        # correction at zero; here evaluated by the fit's own decoding, not the simulator) plus
        # the fit's residual with each block's sign flipped: the same size frame by frame
        e_fit = np.asarray(f["measured"]) - np.asarray(f["model"])
        e_rep = r.measured - np.asarray(f0["model"])
        m = r.measured[:, 2] != 0.0
        np.testing.assert_allclose(np.abs(e_rep[m]), np.abs(e_fit[m]), rtol=1e-6, atol=1e-6)
        flipped = np.sign(e_rep[m, 2]) != np.sign(e_fit[m, 2])
        assert 0 < flipped.sum() < m.sum()


def test_a_drawn_smooth_pose_error_has_the_widths_and_the_shared_fraction_of_the_prior():
    from gc_ocp.estimation.components.pose import PoseCorrection
    from gc_ocp.stance import StanceData
    from gc_ocp.synthetic_foot import rolling_foot

    foot = rolling_foot("left", duration=0.6)
    T = foot.time.size
    st = [StanceData("left", f"s{j}", foot, np.zeros((T, 6)), np.zeros(3)) for j in range(2)]
    pose = PoseCorrection(sigma_mm=(1.0, 2.0, 3.0), sigma_deg=(0.5, 1.0, 1.5))
    B = pose.basis(foot.time)[0]
    rng = np.random.default_rng(0)
    for rho in (0.0, 0.6):
        draws = [pose.draw(st, {"left": rho}, rng) for _ in range(1500)]
        d0 = np.array([d[0][0] for d in draws])  # (draws, T, 3): stance 0's translation
        d1 = np.array([d[1][0] for d in draws])
        r0 = np.array([d[0][1] for d in draws])
        # each coefficient N(0, width^2): the variance at frame t is width^2 (B B^T)_tt; 1500
        # draws give a variance's relative SE of sqrt(2 / 1500) = 3.7 %; 15 % is four of them
        expect = np.einsum("tk,tk->t", B, B)
        for axis, (w_mm, w_deg) in enumerate(zip(pose.sigma_mm, pose.sigma_deg, strict=True)):
            got = d0[:, :, axis].var(axis=0).mean() / expect.mean()
            assert got == pytest.approx((w_mm * 1e-3) ** 2, rel=0.15)
            got = r0[:, :, axis].var(axis=0).mean() / expect.mean()
            assert got == pytest.approx(np.deg2rad(w_deg) ** 2, rel=0.15)
        # two stances of the foot (same length: the shared map is the identity) share rho of
        # the variance; the correlation's SE over 1500 draws is under 0.03, 0.1 is over three
        c = np.corrcoef(d0[:, T // 2, 2], d1[:, T // 2, 2])[0, 1]
        assert c == pytest.approx(rho, abs=0.1)


def test_a_replicate_also_draws_the_smooth_pose_error_of_the_fitted_widths():
    from gc_ocp.estimation import build_estimation
    from gc_ocp.estimation.solve import IpoptOptions, solve
    from gc_ocp.estimation.synthetic import recovery_model

    sts, _ = synthetic_stances(np.random.default_rng(5), 1e-3, per_foot=2)
    model = recovery_model()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = solve(build_estimation(sts, model), IpoptOptions())

    # the same generator state: with the drift the seen feet move further (a 2 mm width per
    # coefficient, against the sub-millimetre low-passed noise alone)
    def moved(drift):
        rep = replicate_data(sts, model, res, np.random.default_rng(0), drift=drift)
        return np.sqrt(
            np.mean(
                [
                    np.mean((r.foot.hindfoot_pose[:, :3, 3] - st.foot.hindfoot_pose[:, :3, 3]) ** 2)
                    for r, st in zip(rep, sts, strict=True)
                ]
            )
        )

    white, smooth = moved(False), moved(True)
    assert white < 0.5e-3 and smooth > 2 * white
    # a width stopped at soft tissue's limit measures the model's misfit: no drift is drawn,
    # and the correction says the replicates drew the noise only
    limit = tuple(
        dataclasses.replace(c, sigma_mm=(2.0, PLAUSIBLE_MM, 2.0)) if c.name == "pose" else c
        for c in model
    )
    assert draws_drift(model) and not draws_drift(limit)
    a = replicate_data(sts, limit, res, np.random.default_rng(0))
    b = replicate_data(sts, limit, res, np.random.default_rng(0), drift=False)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x.foot.hindfoot_pose, y.foot.hindfoot_pose)
    info = BiasCorrection(
        2, 0, {"mu": 0.8}, {"mu": -0.01}, {"mu": 0.002}, 1.0, drift=False,
        no_drift_reason=no_drift_reason(limit),
    )  # fmt: skip
    assert "drew the markers' noise only: the pose correction's width is at or above" in (
        info.message()
    )
    no_pose = tuple(c for c in model if c.name != "pose")
    assert no_drift_reason(no_pose) == "the model has no pose correction"
    assert no_drift_reason(model) == ""
    assert all(
        r.foot.pose_noise is st.foot.pose_noise
        for r, st in zip(
            replicate_data(sts, model, res, np.random.default_rng(0)), sts, strict=True
        )
    )


def test_the_correction_subtracts_the_replicates_mean_change_and_adds_its_error():
    from gc_ocp.estimation import build_estimation
    from gc_ocp.estimation.solve import IpoptOptions, result_at, solve
    from gc_ocp.estimation.synthetic import recovery_model

    sts, truth = synthetic_stances(np.random.default_rng(5), 1e-3, per_foot=2)
    model = recovery_model()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pb = build_estimation(sts, model)
        res = solve(pb, IpoptOptions())
        out, info = bias_corrected(sts, model, res, replicates=3, seed=0)
        again, info2 = bias_corrected(sts, model, res, replicates=3, seed=0)
    assert info.replicates == 3 and info.failed == 0
    assert info2.bias == info.bias  # seeded: the same replicates
    fitted, corrected = res.params["shared"], out.params["shared"]
    assert info.as_fitted["mu"] == fitted["mu"]
    # the correction is made on the decision variables, the bias read on the parameters: the
    # same where a parameter is linear in its variable (mu, n, c are: scaled, not logged)
    for p in ("n", "c", "mu"):
        assert corrected[p] == pytest.approx(fitted[p] - info.bias[p], abs=1e-9)
    # the reported covariance is the fit's at the corrected point with the shared variables'
    # SDs raised to the replicates' spread where larger, plus the bias's Monte Carlo part:
    # exactly replicate_covariance's rule, and no variance shrinks
    at = result_at(pb, out.x)
    hac = at.covariance
    shared = np.setdiff1d(np.arange(out.x.size), np.concatenate(pb.stance_columns()))
    S = np.cov(info.moves, rowvar=False)
    np.testing.assert_allclose(out.covariance, replicate_covariance(hac, S, shared, 3))
    assert np.all(np.diag(out.covariance) >= np.diag(hac) - 1e-15)
    assert np.any(np.diag(out.covariance) > np.diag(hac) * (1 + 1e-6))
    # the linearised SEs it reports are the fit's own at the corrected point
    assert info.linearised_se["mu"] == pytest.approx(at.params["shared"]["mu_se"])
    # the flags and the units' "identified" marks are made from the reported covariance
    left = out.params["left"]
    assert all("identified" in e for e in left.values() if isinstance(e, dict))
    assert "bias correction (3 replicates" in info.message()
    assert info.to_json()["bias"]["mu"] == info.bias["mu"]


def test_the_replicates_spread_raises_a_standard_error_never_lowers_it():
    # two shared variables (0, 2) and a stance variable (1): the replicates' spread is larger
    # than the linearised SD for variable 0, smaller for variable 2
    rng = np.random.default_rng(0)
    A = rng.normal(size=(3, 3))
    C = A @ A.T + np.eye(3)
    shared = np.array([0, 2])
    S = np.diag([4.0 * C[0, 0], 0.25 * C[2, 2]])
    out = replicate_covariance(C, S, shared, B=16)
    # variable 0: the replicates' variance plus its Monte Carlo part; 2: its own plus that part
    assert out[0, 0] == pytest.approx(4.0 * C[0, 0] * (1 + 1 / 16))
    assert out[2, 2] == pytest.approx(C[2, 2] + 0.25 * C[2, 2] / 16)
    assert out[1, 1] == C[1, 1]  # a stance variable is not the correction's
    # before the Monte Carlo part, the correlations are the linearised ones (a congruence), so
    # the result is a covariance
    core = out.copy()
    core[np.ix_(shared, shared)] -= S / 16
    corr = lambda M, i, j: M[i, j] / np.sqrt(M[i, i] * M[j, j])  # noqa: E731
    assert corr(core, 0, 1) == pytest.approx(corr(C, 0, 1))
    assert corr(core, 0, 2) == pytest.approx(corr(C, 0, 2))
    assert np.linalg.eigvalsh(out).min() > 0
    assert replicate_covariance(None, S, shared, 16) is None
    # the Monte Carlo part only on the variables the bias was subtracted from, and never on one
    # the covariance holds fixed (its variance stays 0)
    part = replicate_covariance(C, S, shared, B=16, corrected=np.array([True, False]))
    assert part[0, 0] == pytest.approx(out[0, 0]) and part[2, 2] == pytest.approx(C[2, 2])
    fixed = C.copy()
    fixed[2, :] = fixed[:, 2] = 0.0
    assert replicate_covariance(fixed, S, shared, B=16)[2, 2] == 0.0
    info = BiasCorrection(
        16, 0, {"mu": 0.8}, {"mu": -0.01}, {"mu": 0.001}, 1.0,
        spread={"mu": 0.006}, linearised_se={"mu": 0.004},
    )  # fmt: skip
    assert info.se_raised() == {"mu": pytest.approx(1.5)}
    assert "mu x1.5" in info.message() and "moves" not in info.to_json()


def test_a_fit_refuses_a_bias_correction_of_one_replicate():
    from gc_ocp.workflow.fitting import fit

    with pytest.raises(InputError, match="at least 2"):
        fit([], bias_correction=1)


def test_a_batch_refuses_a_bias_correction_of_one_replicate_before_any_subject():
    from gc_ocp.batch import Settings

    assert Settings(bias_correction=16).to_json()["bias_correction"] == 16
    with pytest.raises(InputError, match="at least 2"):
        Settings(bias_correction=1)


def test_the_correction_reports_every_parameter_it_moves_not_only_the_laws_shared_ones():
    """The bias is subtracted from every shared variable; it was reported (message, fit.json)
    for the law's shared n, c, mu only: a per-foot friction coefficient and an effect's own
    parameter (damping's c, given to the law by its component) were corrected unnamed."""
    from gc_ocp.estimation import build_estimation
    from gc_ocp.estimation.components import model_from_names
    from gc_ocp.estimation.components.contact import ContactLaw, Param
    from gc_ocp.estimation.solve import IpoptOptions, result_at, solve
    from gc_ocp.estimation.synthetic import recovery_model

    sts, _ = synthetic_stances(np.random.default_rng(5), 1e-3, per_foot=1)
    base = tuple(
        dataclasses.replace(c, mu=Param("foot", 0.5, 0.0, 1.5)) if isinstance(c, ContactLaw) else c
        for c in recovery_model()
    )
    model = model_from_names(["damping"], base)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pb = build_estimation(sts, model)
        res = solve(pb, IpoptOptions())
        out, info = bias_corrected(sts, model, res, replicates=2, seed=0)
    named = {"mu (left)", "mu (right)", "damping/c", "n"}
    assert named <= set(info.bias) and named <= set(info.linearised_se)
    for k in ("mu (left)", "mu (right)", "damping/c"):
        assert k in info.message() or k in info.at_bound
    # each value is the one the fit reports, and the corrected fit reports it less the bias
    # (linear in its variable: scaled, not logged, so exact up to the solver's rounding)
    assert info.as_fitted["mu (left)"] == res.params["left"]["mu"]
    assert info.as_fitted["damping/c"] == res.blocks["damping"]["c"]
    if "damping/c" not in info.at_bound:
        assert out.blocks["damping"]["c"] == pytest.approx(
            res.blocks["damping"]["c"] - info.bias["damping/c"], abs=1e-9
        )
    # its linearised SE is the fit's own at the corrected point
    at = result_at(pb, out.x)
    assert info.linearised_se["mu (right)"] == pytest.approx(at.params["right"]["mu_se"])
    # the units' stiffnesses are not listed (fit.json's unit table has them, corrected)
    assert not any(k.startswith("k") for k in info.bias)
