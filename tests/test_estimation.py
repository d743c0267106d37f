"""Joint kinematics-contact estimation: built problem, synthetic recovery, held-out protocol, CLI."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_matches_pins  # noqa: E402

from gc_ocp.errors import InputError, SolveError
from gc_ocp.estimation.components import (
    EFFECTS,
    ContactLaw,
    Param,
    PoseCorrection,
    SoleCorrection,
    full_model,
    seed_model,
)
from gc_ocp.estimation.problem import Weights, build_estimation
from gc_ocp.estimation.solve import IpoptOptions, solve
from gc_ocp.estimation.synthetic import default_truth, nominal_points, synthetic_stance
from gc_ocp.foot import UNITS

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


def _stances(rng, displacement=0.008, force_noise=0.0):
    truth = default_truth()
    disp, sts = {}, []
    for side, t_off in (("left", 0.0), ("right", 0.55)):
        d = rng.normal(size=(5, 3))
        d *= (rng.uniform(0, displacement, 5) / np.linalg.norm(d, axis=1))[:, None]
        disp[side] = d
        for t0 in (0.0, 1.1):
            sts.append(
                synthetic_stance(
                    side,
                    truth,
                    nominal_points(side) + d,
                    t0=t0 + t_off,
                    sink=0.010,
                    rng=rng,
                    force_noise=force_noise,
                )
            )
    return truth, disp, sts


def _model():
    return (
        ContactLaw(
            k=Param("unit", 2e5, 1e2, 1e9),
            n=Param("shared", 1.2, 1, 3),
            c=Param("shared", 0.3, 0, 10),
            mu=Param("shared", 0.5, 0, 1.5),
        ),
        SoleCorrection(),
        PoseCorrection(),
    )


def test_seed_and_full_model_are_configurations_of_one_builder():
    _, _, sts = _stances(np.random.default_rng(0))
    seed = build_estimation(sts, seed_model())
    full = build_estimation(sts, full_model())
    assert seed.x.shape[0] == 10  # one log k per unit per foot, nothing else
    n_pose = sum(s.size for s in full.variables.specs if s.key[0] == "pose")
    assert full.x.shape[0] == 10 + 3 + 2 * 5 * 3 + n_pose
    # objective is evaluated without running Ipopt, and equals half the squared residuals
    x = full.x0 + 0.01
    import casadi as ca

    r = np.asarray(ca.Function("r", [full.x], [full.residuals])(x)).ravel()
    assert full.evaluate(x) == pytest.approx(0.5 * r @ r, rel=1e-12)


def test_noiseless_synthetic_recovery():
    """Per-unit k, n = 1.5, c = 1 s/m, mu = 0.8, points displaced by up to 8 mm, no noise.

    The data weight is the noise model: noiseless data gets a small force sigma (0.1 % BW), so
    the 5 mm sole prior and 2 mm / 1 deg pose prior do not bias the MAP estimate noticeably.
    Tolerances: 5 % on k, n, c and 1.5 mm on the sole corrections (the issue's targets); the
    residual bias comes from the smoothing of the contact law (0.5 mm penetration smoothing)."""
    truth, disp, sts = _stances(np.random.default_rng(1))
    res = solve(build_estimation(sts, _model(), Weights(force_sigma=1e-3)))
    assert res.success
    for side in ("left", "right"):
        k = np.array([res.params[side][u]["k"] for u in UNITS])
        assert np.all(np.abs(k / truth["k"] - 1) < 0.05), (side, k, truth["k"])
        est = np.array([res.sole_corrections_mm[side][u] for u in UNITS])
        assert np.abs(est - disp[side] * 1e3).max() < 1.5
    for p in ("n", "c", "mu"):
        assert res.params["shared"][p] == pytest.approx(truth[p], rel=0.05)
    # standard errors exist and are positive for every estimated k
    assert all(res.params[s][u]["k_se"] > 0 for s in ("left", "right") for u in UNITS)
    # f_ref = k d_ref^n; k and n are positively correlated (ln f_ref = ln k + n ln d_ref with
    # ln d_ref < 0), so the force at the reference depth is better determined than k itself
    n = res.params["shared"]["n"]
    rel_k, rel_f = [], []
    for s in ("left", "right"):
        for u in UNITS:
            e = res.params[s][u]
            assert e["f_ref"] == pytest.approx(e["k"] * 0.005**n, rel=1e-12)
            rel_k.append(e["k_se"] / e["k"])
            rel_f.append(e["f_ref_se"] / e["f_ref"])
    assert np.median(rel_f) < np.median(rel_k)
    print(f"\nrelative SE median: k {np.median(rel_k):.3%}, f_ref {np.median(rel_f):.3%}")


def test_best_of_gives_the_winning_starts_covariance_as_its_own_solve_would():
    """``best_of`` solves every start without the covariance and computes it for the winner
    only: the winner's covariance and SEs are those of its point under the winner's last stage
    (a deterministic function of the problem and the point: equal to round-off), and those its
    own solve gives to the solver's tolerance (its own solve builds the stages in another order,
    so its problem equals best_of's to round-off and its optimum to Ipopt's tolerance: 1e-6 of
    the largest entry), with two continuation schedules, one of which does not end at the
    requested priors."""
    from gc_ocp.estimation.solve import result_at
    from gc_ocp.estimation.starts import best_of, estimate

    _, _, sts = _stances(np.random.default_rng(1))
    model, w = _model(), Weights(force_sigma=1e-3)
    for strategies in (((1.0,), (0.2, 1.0)), ((0.5,),)):
        r = best_of(sts, model, w, strategies=strategies)
        assert r.covariance is not None and np.all(np.isfinite(np.diag(r.covariance)))
        own = [estimate(sts, model, w, continuation=steps) for steps in strategies]
        k = min(range(len(own)), key=lambda i: own[i].objective)
        win, f = own[k], strategies[k][-1]
        assert r.objective == pytest.approx(win.objective, rel=1e-12)
        last = tuple(c.with_prior_scale(f) for c in model)
        at = result_at(build_estimation(sts, last, w), r.x)
        np.testing.assert_allclose(r.covariance, at.covariance, rtol=1e-9, atol=1e-15)
        assert r.params["shared"]["n_se"] == pytest.approx(at.params["shared"]["n_se"], rel=1e-9)
        scale = np.abs(win.covariance).max()
        np.testing.assert_allclose(r.covariance, win.covariance, rtol=0, atol=1e-6 * scale)
    assert best_of(sts, model, w, strategies=((1.0,),), covariance=False).covariance is None


def test_the_starts_that_lost_are_compared_again_on_the_problem_the_fit_returns():
    """``best_of(others=)`` hands back one start per other minimum, never the winner's: two
    identical schedules end in one minimum, so nothing is handed back. ``lowest_of`` keeps a
    start only when it ends lower on the problem given, beyond the solver's tolerance: the
    winner solved again from its own point is the same minimum (no replacement, and not listed
    as another minimum), while a point above the minimum handed as "the fit" is replaced by
    it."""
    from gc_ocp.estimation.solve import result_at
    from gc_ocp.estimation.starts import best_of, lowest_of

    _, _, sts = _stances(np.random.default_rng(3))
    model, w = _model(), Weights(force_sigma=1e-3)
    others: list = []
    best = best_of(sts, model, w, strategies=((1.0,), (1.0,)), covariance=False, others=others)
    assert others == []
    prob = build_estimation(sts, model, w)
    lower, record, (_, iterations) = lowest_of(prob, best, [("the winner", best)])
    # Ipopt's tol 1e-8 on the scaled error: the same minimum to far better than 1e-6
    assert lower is None and record == [] and iterations > 0
    poor = result_at(prob, prob.x0, covariance=False)
    assert poor.objective > 2 * best.objective  # the start, far above the minimum
    lower, record, _ = lowest_of(prob, poor, [("the winner", best)])
    assert lower is not None and lower.objective == pytest.approx(best.objective, rel=1e-6)
    assert [what for what, _ in record] == ["the winner"]


def test_the_trust_region_start_lowers_the_objective_within_the_bounds_and_is_one_more_start():
    """``trust_region_point`` takes bounded steps that lower the objective from the problem's
    start (a trust region accepts only a step that does), and ``best_of(trust_region=True)``
    keeps the lowest of its starts, that one included: never above the same starts without it
    (the added start is solved last, so on equal objectives the earlier one wins)."""
    from gc_ocp.estimation.solve import result_at
    from gc_ocp.estimation.starts import best_of, trust_region_point

    _, _, sts = _stances(np.random.default_rng(3))
    model, w = _model(), Weights(force_sigma=1e-3)
    prob = build_estimation(sts, model, w)
    x = trust_region_point(prob)
    lb, ub = np.asarray(prob.lbx).ravel(), np.asarray(prob.ubx).ravel()
    assert np.all(x >= lb) and np.all(x <= ub)
    start = result_at(prob, np.clip(np.asarray(prob.x0).ravel(), lb, ub), covariance=False)
    assert result_at(prob, x, covariance=False).objective < start.objective
    said: list = []
    plain = best_of(sts, model, w, covariance=False)
    with_tr = best_of(sts, model, w, covariance=False, trust_region=True, progress=said.append)
    assert "start: a trust-region warm-up" in said
    # and how it ended, on the next line (status, iterations, objective)
    ended = said[said.index("start: a trust-region warm-up") + 1]
    assert re.fullmatch(r"  \w+, \d+ iterations, J = [-\d.e+]+", ended), ended
    assert with_tr.objective <= plain.objective


def test_best_of_with_nothing_to_solve_says_so():
    from gc_ocp.estimation.starts import best_of

    _, _, sts = _stances(np.random.default_rng(3))
    with pytest.raises(InputError, match="nothing to solve"):
        best_of(sts, _model(), strategies=())


def test_a_minimum_the_plates_tell_apart_or_that_is_the_same_point_is_not_flagged():
    """``undecided_minimum`` flags only a point the plates do not prefer the kept one to and
    which lies more than 2 SE away: the kept point itself (no difference, no spread) and a
    point 10 SE away along the exponent (its data cost higher by several SD of the difference's
    spread: about 9 here) are not flagged."""
    from gc_ocp.estimation.solve import result_at
    from gc_ocp.estimation.starts import _frame_costs, _sum_sd, undecided_minimum

    _, _, sts = _stances(np.random.default_rng(4), force_noise=0.01)
    model, w = _model(), Weights(force_sigma=1e-3)
    prob = build_estimation(sts, model, w)
    kept = solve(prob)
    assert undecided_minimum(prob, kept, kept, "itself") is None
    spec = next(s for s in prob.variables.specs if s.key == ("contact", "n"))
    x = kept.x.copy()
    x[spec.start] += 10 * np.sqrt(kept.covariance[spec.start, spec.start])
    far = result_at(prob, x, covariance=False)
    diff = [a - b for a, b in zip(_frame_costs(prob, x), _frame_costs(prob, kept.x), strict=True)]
    assert sum(d.sum() for d in diff) > 2 * _sum_sd(diff)  # told apart by the plates
    assert undecided_minimum(prob, kept, far, "10 SE away") is None


def test_another_minimum_is_flagged_only_for_the_values_the_fit_gives_an_se():
    """Another point that fits the plates better, 2.5 SE away along one unit's stiffness, is
    flagged naming that unit; where the fit flags the unit ``unit_not_identified`` (the summary
    shows "not identified", no SE) or its stiffness at a bound, there is no SE to warn about and
    nothing is flagged (the bundled trial's other minimum is of this kind)."""
    from gc_ocp.estimation.flags import flag
    from gc_ocp.estimation.solve import result_at
    from gc_ocp.estimation.starts import undecided_minimum

    _, _, sts = _stances(np.random.default_rng(4), force_noise=0.01)
    model, w = _model(), Weights(force_sigma=1e-3)
    prob = build_estimation(sts, model, w)
    best = solve(prob)
    spec = next(s for s in prob.variables.specs if s.key == ("contact", "k", "left", "AM"))
    C, j = best.covariance, spec.start
    # the "kept" point 2.5 SE away along the unit's profile (the others follow their
    # correlation, so only this unit moves by more than 2 SE); the optimum, which fits the
    # plates better by several SD of the per-frame differences, is the other minimum
    kept = result_at(prob, best.x + 2.5 * C[:, j] / np.sqrt(C[j, j]))
    found = undecided_minimum(prob, dataclasses.replace(kept, flags=[]), best, "the optimum")
    assert found is not None and found["what"] == "contact/k/left/AM", found
    assert "fits the plates better" in found["message"]
    for f in (
        flag("unit_not_identified", "left/AM", "left unit AM not identified"),
        flag("at_bound", "contact/k/left/AM", "at its bound"),
    ):
        silent = dataclasses.replace(kept, flags=[f])
        assert undecided_minimum(prob, silent, best, "the optimum") is None, f["code"]
    # another unit not identified leaves this one's flag as it was
    other_unit = dataclasses.replace(kept, flags=[flag("unit_not_identified", "left/PM", "")])
    assert undecided_minimum(prob, other_unit, best, "the optimum") == found


def test_the_spread_of_a_sum_of_white_costs_is_their_root_sum_of_squares():
    """``_sum_sd`` (Newey-West per stance): white per-frame differences of SD 1 over 4 stances of
    400 frames give the sum's SD sqrt(1600) = 40, to the estimator's sampling error (a few %:
    the variance of 1600 squared normals is 2/1600 of their mean, and the few lags a white
    series' sample autocorrelation crosses the 2/sqrt(T) band add their Bartlett terms); an
    AR(1) series with rho = 0.9 has the long-run variance (1 + rho) / (1 - rho) = 19 times its
    variance, and the estimate is well above the white formula (the Bartlett window truncated at
    the lag the autocorrelation fades)."""
    from gc_ocp.estimation.starts import _sum_sd

    rng = np.random.default_rng(5)
    white = [rng.standard_normal(400) for _ in range(4)]
    assert _sum_sd(white) == pytest.approx(40.0, rel=0.15)
    ar = []
    for _ in range(4):
        e, z = rng.standard_normal(400), np.zeros(400)
        for t in range(1, 400):
            z[t] = 0.9 * z[t - 1] + np.sqrt(1 - 0.81) * e[t]
        ar.append(z)
    assert _sum_sd(ar) > 2.5 * 40.0  # sqrt(19) = 4.4 in the limit; a truncated window less


def test_non_converged_solve_raises_with_result():
    _, _, sts = _stances(np.random.default_rng(2))
    prob = build_estimation(sts, _model())
    with pytest.raises(SolveError) as e:
        solve(prob, IpoptOptions(max_iter=2))
    assert e.value.result is not None and e.value.result.iterations <= 2
    assert "did not converge" in str(e.value)


def test_a_start_outside_the_bounds_or_of_another_size_is_refused_naming_the_variable():
    """solve(x0=...) checks the start it is given: Ipopt moved one outside the bounds inside
    silently and stopped on a NaN without saying where it came from."""
    _, _, sts = _stances(np.random.default_rng(2))
    prob = build_estimation(sts, _model())
    spec = next(s for s in prob.variables.specs if s.kind == "param")
    name = "/".join(map(str, spec.key))
    outside = prob.x0.copy()
    outside[spec.start] = prob.ubx[spec.start] + 1.0
    with pytest.raises(InputError, match=rf"x0 gives {re.escape(name)} .*outside its bounds"):
        solve(prob, x0=outside)
    nan = prob.x0.copy()
    nan[-1] = np.nan
    with pytest.raises(InputError, match=r"entry \d+ of x0.*not a number"):
        solve(prob, x0=nan)
    with pytest.raises(
        InputError, match=rf"x0 has {prob.x0.size - 1} entries .* has {prob.x0.size}"
    ):
        solve(prob, x0=prob.x0[:-1])
    # on a bound, or within Ipopt's relaxation of it (1e-8 relative), is a start
    edge = prob.x0.copy()
    edge[spec.start] = prob.ubx[spec.start] * (1 + 1e-10) + 1e-10
    assert solve(prob, IpoptOptions(max_iter=2), x0=edge, raise_on_failure=False).iterations >= 0


def test_weights_make_cop_count_more_than_seed_normalisation():
    w = Weights()
    inv = w.inverse_sigmas(700.0)
    # a torque error of F * 10 mm at F = BW counts (10 mm / torque_length) as much as BW error
    assert inv[3] * 700 * 0.01 == pytest.approx(inv[0] * 700 * 0.01 / w.torque_length)


@pytest.fixture(scope="module")
def bundled():
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics

    t = load_trial()
    return t, compute_kinematics(t)


def test_warm_solves_reach_the_same_optimum_in_fewer_iterations(bundled):
    """A fit's warm solves (the continuation's later stages and the width rounds, ``warm=True``:
    the barrier started small, the start kept near its bounds) end at the optimum Ipopt's
    defaults reach, in fewer iterations in total (464 against 513 on the bundled trial,
    2026-11-30; one stage alone can take more: the continuation's last, 44 against 42, since
    the pose correction became rigid); with the warm settings off (``None``) a warm solve is
    Ipopt's default one."""
    import dataclasses

    from gc_ocp.estimation.components import full_model
    from gc_ocp.estimation.starts import with_lls_start
    from gc_ocp.stance import stance_data
    from gc_ocp.workflow.fitting import fit

    off = dataclasses.replace(IpoptOptions(), warm_mu_init=None, warm_bound_push=None)
    warm, cold = (fit([bundled], options=o).result for o in (IpoptOptions(), off))
    # the same optimum: Ipopt stops at its tolerance 1e-8 or after 5 iterations changing the
    # objective by < 1e-6 (relative), so two paths to one minimum agree to a few 1e-6
    assert warm.objective == pytest.approx(cold.objective, rel=1e-5)
    print(f"\nwarm solves: {warm.iterations} iterations, Ipopt's defaults {cold.iterations}")
    assert warm.iterations < cold.iterations
    trial, kin = bundled
    sts = [stance_data(trial, kin, s, 0.03, 5) for s in trial.stances]
    prob = build_estimation(sts, with_lls_start(full_model(), sts))
    same, default = (
        solve(prob, o, covariance=False, warm=w) for o, w in ((off, True), (off, False))
    )
    assert same.iterations == default.iterations and same.objective == default.objective


def test_real_trial_fit_and_holdout(bundled):
    """Bundled example: in-sample and held-out errors within the issue's targets."""
    from gc_ocp.workflow.fitting import fit

    said = []
    rep = fit([bundled], holdout="right@0.407", progress=said.append)
    assert_matches_pins("bundled_holdout", rep)
    r = rep.result
    # the solver's statistics are the whole fit's: every start and stage, then the widths'
    # rounds, the other minima's solves at the estimated widths and, where one of them is kept,
    # its own rounds (before, the last round's refit alone: "6 iterations" for a fit of 385)
    log = "\n".join(said)
    [starts] = [int(m) for m in re.findall(r"^fit: \S+, (\d+) iterations", log, re.M)]
    rounds = [int(m) for m in re.findall(r"^pose width round .*, (\d+) iterations$", log, re.M)]
    again = [int(m) for m in re.findall(r"at the estimated widths: \S+, (\d+) iterations", log)]
    assert rounds[-len(rep.pose_scale.rounds) :] == [
        row["iterations"] for row in rep.pose_scale.rounds
    ]
    assert r.iterations == starts + sum(rounds) + sum(again) > starts
    # this trial has two minima the plates do not tell apart (data costs 0.37 apart, their
    # spread 1.2), only one unit's stiffness far apart between them, a unit the data do not
    # identify: it is flagged as such and no SE is shown for it, so the minima are not flagged
    assert {"left/AM"} <= {f["what"] for f in r.flags if f["code"] == "unit_not_identified"}
    assert not [f for f in r.flags if f["code"] == "minimum_undecided"]
    for side in ("left", "right"):
        assert r.rms[side]["superior_force_pct_bw"] <= 3.0
        assert r.rms[side]["anterior_force_pct_bw"] <= 5.0
        assert r.rms[side]["lateral_force_pct_bw"] <= 3.0
        assert r.cop_rms_mm[side] <= 25.0
        assert all(r.params[side][u]["k"] > 0 for u in UNITS)
    assert rep.heldout.rms["right"]["superior_force_pct_bw"] <= 5.0
    # plain data: the report pickles (a worker process can return it) and fit.json round-trips
    import pickle

    from gc_ocp.estimation import EstimationResult

    back = pickle.loads(pickle.dumps(rep))
    assert back.result.params == r.params and back.heldout.rms == rep.heldout.rms
    again = EstimationResult.from_json(json.loads(json.dumps(rep.to_json())))
    assert again.params == r.params and again.rms == r.rms and again.cop_rms_mm == r.cop_rms_mm
    np.testing.assert_array_equal(again.x, r.x)
    assert again.covariance is None  # not written by default (n_free^2 numbers)
    assert r.covariance is not None  # fit() computes the returned fit's covariance
    with_cov = EstimationResult.from_json(json.loads(json.dumps(r.to_json(covariance=True))))
    np.testing.assert_array_equal(with_cov.covariance, r.covariance)
    assert again.objective == pytest.approx(r.data_cost + r.prior_cost, rel=1e-12)
    assert again.n_data == r.n_data == 6 * sum(f["time"].size for f in r.stance_fits)
    d = rep.to_json()
    assert set(d) >= {
        "params",
        "sole_corrections_mm",
        "pose_correction_rms",
        "rms",
        "cop_rms_mm",
        "heldout_rms",
        "solver",
    }


def test_holdout_errors(bundled):
    from gc_ocp.workflow.fitting import fit

    with pytest.raises(InputError, match="matches 0 stances"):
        fit([bundled], holdout="nonexistent")
    with pytest.raises(InputError, match="no other stance of the left foot"):
        fit([bundled], holdout="left@")


def test_a_held_out_solve_that_fails_keeps_the_fit_and_flags_the_score(bundled, monkeypatch):
    """Ipopt failing on the held-out stance (simulated: its result marked failed, also when it
    is solved again from where it stopped) must not lose the fit of the other stances: the fit
    is returned, the held-out score carries a flag."""
    import dataclasses
    import importlib

    import gc_ocp.workflow.fitting as fitting

    solve_module = importlib.import_module("gc_ocp.estimation.solve")  # (the package's
    # attribute of that name is the function)

    real = fitting.solve

    def held_out_fails(problem, *args, **kwargs):
        res = real(problem, *args, **kwargs)
        if len(problem.stances) == 1:  # the held-out stance's problem
            assert kwargs.get("raise_on_failure") is False  # else it would raise here
            return dataclasses.replace(res, success=False, status="Maximum_Iterations_Exceeded")
        return res

    monkeypatch.setattr(fitting, "solve", held_out_fails)
    monkeypatch.setattr(solve_module, "solve", held_out_fails)  # the retry's solve
    rep = fitting.fit([bundled], holdout="auto")
    assert rep.result.success and rep.heldout is not None
    [flag] = [f for f in rep.heldout.flags if f["code"] == "heldout_not_converged"]
    assert rep.heldout_label in flag["what"] and "Maximum_Iterations_Exceeded" in flag["message"]


def test_holdout_auto_that_finds_no_stance_to_hold_out_says_so(bundled):
    """``holdout="auto"`` with one stance per foot holds none out (a foot needs one left to
    fit): the report says so among its checks, where it said nothing (no held-out score, and
    no word why)."""
    import dataclasses

    from gc_ocp.workflow import fit

    trial, kin = bundled
    one_each = dataclasses.replace(trial, stances=trial.stances[:2])  # right, left
    assert sorted(s.side for s in one_each.stances) == ["left", "right"]
    rep = fit([(one_each, kin)], holdout="auto", pose_scale=False)
    assert rep.heldout is None
    assert any("holdout auto" in c and "no stance held out" in c for c in rep.checks), rep.checks


def test_an_exact_holdout_label_wins_over_the_labels_that_contain_it():
    from gc_ocp.workflow.fitting import _holdout_index

    labels = ["fastwalk:right@0.410s", "walk:right@0.410s", "walk:left@0.950s"]
    assert _holdout_index("walk:right@0.410s", labels) == 1
    assert _holdout_index("fastwalk", labels) == 0  # a part of one label still names it
    with pytest.raises(InputError, match="matches 2 stances"):
        _holdout_index("right@0.410s", labels)  # a part of two: which one is not said


def test_cli_fit(tmp_path):
    from gc_ocp.cli import main

    assert main(["fit", "--out", str(tmp_path)]) == 0
    d = json.loads((tmp_path / "fit.json").read_text())
    # converged: Ipopt's full tolerance, or its acceptable level once the objective changes by
    # < 1e-6 (relative) over 5 iterations (IpoptOptions.acceptable_obj_change_tol), the stop the
    # package asks for; anything else (iteration limit, restoration failure) is not success
    assert d["solver"]["success"] is True
    assert d["solver"]["status"] in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
    assert set(d["params"]["left"]) >= set(UNITS)
    # what was done to each foot's roll is recorded (the bundled Plug-in Gait foot has three
    # landmarks with the ankle marker: posed by its markers whatever --foot-roll says)
    prov = d["provenance"]
    assert prov["options"]["foot_roll"] == "chain"
    assert prov["trials"][0]["foot_roll"] == {"left": "markers", "right": "markers"}
    from gc_ocp.estimation import EstimationResult

    back = EstimationResult.from_json(tmp_path / "fit.json")
    assert back.params == d["params"] and back.rms == d["rms"]
    for name in ("fit_wrench.png", "fit_sole.png", "fit_pose_corrections.png"):
        assert (tmp_path / name).stat().st_size > 10_000


REAL = ["plugingait", "rajagopal", "gait2392"]


def _real(name):
    import dataclasses
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from conftest import c3d_trial, gait2392_trial, rajagopal_trial

    from gc_ocp.kinematics import compute_kinematics

    t = {"plugingait": c3d_trial, "rajagopal": rajagopal_trial, "gait2392": gait2392_trial}[name]()
    if name == "gait2392":  # treadmill: nominal belt speed from the markers, refined by the fit
        from gc_ocp.io import estimate_belt_speed

        v, _ = estimate_belt_speed(t)
        t = dataclasses.replace(t, belt_velocity=np.array([-v, 0.0, 0.0]))
    return t, compute_kinematics(t)


@pytest.mark.parametrize("name", REAL)
def test_real_trials_in_sample(name):
    """Issue targets, every foot, in-sample: superior <= 3 % BW, anterior <= 5 % BW, lateral <= 3 % BW,
    COP <= 25 mm, all k > 0 (true by construction: k = exp(z), checked anyway)."""
    from gc_ocp.workflow.fitting import fit

    with __import__("warnings").catch_warnings():
        __import__("warnings").simplefilter("ignore")  # height estimated from markers (OpenSim)
        rep = fit([_real(name)])
    assert_matches_pins(name, rep)
    r = rep.result
    for side in ("left", "right"):
        rms = r.rms[side]
        assert rms["superior_force_pct_bw"] <= 3.0, (name, side, rms)
        assert rms["anterior_force_pct_bw"] <= 5.0, (name, side, rms)
        assert rms["lateral_force_pct_bw"] <= 3.0, (name, side, rms)
        assert r.cop_rms_mm[side] <= 25.0, (name, side, r.cop_rms_mm)
        assert all(r.params[side][u]["k"] > 0 for u in UNITS)


def test_rajagopal_holdout_right():
    """The Rajagopal right foot has two full stances: hold out the second one."""
    from gc_ocp.workflow.fitting import fit

    with __import__("warnings").catch_warnings():
        __import__("warnings").simplefilter("ignore")
        rep = fit([_real("rajagopal")], holdout="right@1.4")
    assert rep.heldout.rms["right"]["superior_force_pct_bw"] <= 5.0


@pytest.mark.parametrize("which", ["full", "seed", "dense"])
def test_structured_derivatives_match_casadi_ad(which):
    """The gradient and the arrow-assembled Hessian given to Ipopt equal CasADi's own AD of the
    objective (round-off: relative 1e-10, the sums involve ~1e3 terms of magnitude ~1). Models:
    with per-frame slots (the pose spline) beside the constant ones, with constant slots only
    (the seed's law), and with the 16-unit sole (80 slots per frame, 68 of them constant)."""
    import casadi as ca

    from gc_ocp.estimation.components import model_from_names

    _, _, sts = _stances(np.random.default_rng(3))
    if which == "dense":
        # CasADi's own AD of the 16-unit model took ~3 min on four stances: two, one per
        # foot, keep every coupling the arrow assembles (shared law across stances and feet)
        sts = sts[::2]
    model = {
        "full": full_model,
        "seed": seed_model,
        "dense": lambda: model_from_names(["contact_density"], base=full_model()),
    }[which]()
    pb = build_estimation(sts, model)
    x = pb.x0 + 0.05 * np.random.default_rng(4).normal(size=pb.x0.size)
    H = np.asarray(ca.Function("h1", [pb.x], [pb.hessian])(x))
    H_ad = np.asarray(ca.Function("h2", [pb.x], [ca.hessian(pb.objective, pb.x)[0]])(x))
    g = np.asarray(ca.Function("g1", [pb.x], [pb.gradient])(x)).ravel()
    g_ad = np.asarray(ca.Function("g2", [pb.x], [ca.gradient(pb.objective, pb.x)])(x)).ravel()
    assert np.abs(H - H_ad).max() <= 1e-10 * np.abs(H_ad).max()
    assert np.abs(g - g_ad).max() <= 1e-10 * np.abs(g_ad).max()
    # the data Jacobian assembled from per-frame Jacobians (used for the covariance) equals the
    # symbolic Jacobian of the residual vector (one product J_t A_t per entry: round-off 1e-12)
    r, Jd = pb.data_jacobian(x)
    Jr, rr = (
        np.asarray(a)
        for a in ca.Function("j", [pb.x], [ca.jacobian(pb.residuals, pb.x), pb.residuals])(x)
    )
    assert np.abs(Jd.toarray() - Jr[: pb.n_data]).max() <= 1e-12 * np.abs(Jr).max()
    assert np.abs(r - rr.ravel()[: pb.n_data]).max() <= 1e-12 * np.abs(rr).max()


def test_holdout_model_fixes_contact_and_applies_the_fitted_belt_speed():
    """Held-out protocol: every component frozen at the fit's blocks leaves only the pose
    correction free; a treadmill stance of a fitted trial gets the belt speed the fit estimated
    for its trial (not the nominal one), through the frozen BeltSpeed component."""
    import dataclasses

    from gc_ocp.estimation import frozen_model, result_at

    _, _, sts = _stances(np.random.default_rng(5))
    sts = [dataclasses.replace(st, belt_velocity=np.array([-1.0, 0.0, 0.0])) for st in sts]
    pb = build_estimation(sts, full_model())
    x = pb.x0.copy()
    x[pb.variables.spec(("belt", "synthetic")).slice] = 2.0  # 2 sigma = +0.2 m/s
    fitted = result_at(pb, x)
    assert fitted.belt_speed["synthetic"]["value"] == pytest.approx(1.2)
    model = frozen_model(full_model(), fitted)
    held = build_estimation(sts[:1], model)
    assert all(s.key[0] == "pose" for s in held.variables.specs)  # nothing else is estimated
    # the frozen model predicts the same wrench as the fit at the same pose correction (zero)
    x_held = np.zeros(held.x0.size)
    x_fit = x.copy()
    for s in pb.variables.specs:
        if s.key[0] == "pose":
            x_fit[s.slice] = 0.0
    np.testing.assert_allclose(
        held.stance_wrenches(x_held)[0], pb.stance_wrenches(x_fit)[0], rtol=0, atol=1e-9 * 700
    )


def test_pose_prior_per_axis():
    """Per-axis prior widths land on the right lab axis: with every stored (unit-sigma) pose
    coefficient at 1, the correction is (sigma_x, sigma_y, sigma_z) at every frame (the cubic
    B-spline basis sums to 1), and the bounds scale with each axis' sigma."""
    import casadi as ca

    _, _, sts = _stances(np.random.default_rng(5))
    pose = PoseCorrection(sigma_mm=(1.0, 2.0, 3.0), sigma_deg=(0.5, 1.0, 1.5))
    pb = build_estimation(sts[:1], (ContactLaw(), pose))
    v = pb.variables
    x = np.zeros(pb.x0.size)
    for part in ("trans", "rot"):
        x[v.spec(("pose", sts[0].label, part)).slice] = 1.0
    d, th, _, _ = pose.trajectories(v, 0, sts[0])
    dv, tv = (np.asarray(a) for a in ca.Function("p", [pb.x], [d, th])(x))
    np.testing.assert_allclose(
        dv, np.array([[1e-3], [2e-3], [3e-3]]) * np.ones((1, sts[0].n)), rtol=1e-12
    )
    np.testing.assert_allclose(
        np.rad2deg(tv), np.array([[0.5], [1.0], [1.5]]) * np.ones((1, sts[0].n)), rtol=1e-12
    )
    sl = v.spec(("pose", sts[0].label, "trans")).slice
    np.testing.assert_allclose(pb.ubx[sl], pose.bound_sigmas)  # bound in units of each sigma
    # the prior-width continuation scales every axis
    assert pose.with_prior_scale(0.5).sigma_mm == (0.5, 1.0, 1.5)


def test_pose_prior_knot_correlation():
    """With ``knot_correlation`` the coefficients are sigma * L z: L L^T is the Toeplitz
    correlation matrix (exact to the 1e-9 jitter), and an invalid sequence is refused clearly."""
    pose = PoseCorrection(knot_correlation=(1.0, 0.7, 0.25))
    L = pose.correlation_factor(12)
    C = L @ L.T
    np.testing.assert_allclose(np.diag(C), 1.0, atol=1e-8)
    np.testing.assert_allclose(np.diag(C, 1), 0.7, atol=1e-8)
    np.testing.assert_allclose(np.diag(C, 2), 0.25, atol=1e-8)
    np.testing.assert_allclose(np.diag(C, 3), 0.0, atol=1e-8)
    np.testing.assert_array_equal(PoseCorrection().correlation_factor(4), np.eye(4))
    with pytest.raises(ValueError, match="positive definite"):
        PoseCorrection(knot_correlation=(1.0, 0.99, 0.0)).correlation_factor(10)
    with pytest.raises(ValueError, match="start with 1"):
        PoseCorrection(knot_correlation=(0.5, 0.2)).correlation_factor(10)
    # the continuation keeps the correlation
    assert pose.with_prior_scale(0.5).knot_correlation == (1.0, 0.7, 0.25)


def test_rms_is_normalised_per_stance():
    """Two stances of subjects of different weight, each with a model error of 1 % of its own BW
    on the superior force: the pooled RMS is 1 % BW (the first stance's weight would give 1.5 %
    and 0.75 % for the two)."""
    from gc_ocp.estimation.result import fit_quality

    fits = []
    for bw in (700.0, 1400.0):
        meas = np.zeros((20, 6))
        meas[:, 2] = bw
        model = meas.copy()
        model[:, 2] += 0.01 * bw
        fits.append(
            {
                "side": "left",
                "measured": meas,
                "model": model,
                "in_contact": np.ones(20, bool),
                "reference_point": np.zeros(3),
                "ground_height": 0.0,
                "body_weight": bw,
                "height": 1.7,
            }
        )
    rms, _ = fit_quality(fits)
    assert rms["left"]["superior_force_pct_bw"] == pytest.approx(1.0, rel=1e-12)


FIGS = ("fit_wrench.png", "fit_sole.png", "fit_pose_corrections.png", "heldout_wrench.png")


def test_sensitivity_to_processing_choices(bundled, tmp_path):
    """Refits with another cutoff and margin: values per choice, the reference's SE, and a
    spread/SE ratio; the reference choice reproduces the default fit."""
    from gc_ocp.workflow import fit
    from gc_ocp.workflow.sensitivity import sensitivity

    rep = sensitivity([bundled[0]], cutoffs=(6.0, 8.0), margins=(0.03,))
    assert rep.choices == ["6 Hz, 30 ms", "8 Hz, 30 ms"] and rep.reference == "6 Hz, 30 ms"
    default = fit([bundled]).result.params["shared"]["n"]
    assert rep.values["n"][0] == pytest.approx(default, rel=1e-9)
    assert rep.spread("n") > 0 and rep.se["n"] > 0
    assert "spread / SE" in rep.summary()
    # beyond SENSITIVE_RATIO SEs a parameter is flagged, in fit.json's flags and on the page
    from gc_ocp.outputs import OutputSet
    from gc_ocp.workflow.fit_files import write_fit
    from gc_ocp.workflow.sensitivity import SENSITIVE_RATIO

    flagged = {f["what"] for f in rep.flags()}
    assert flagged == {p for p, _, _, r in rep.rows() if r > SENSITIVE_RATIO}
    wide = dataclasses.replace(rep, se={**rep.se, "mu": rep.spread("mu") / 5})  # 5 SE
    assert "mu" in {f["what"] for f in wide.flags()}
    out = OutputSet(tmp_path / "fit", ("fit.json", "landmarks.json", "report.html", *FIGS), "test")
    report = fit([bundled])
    before = list(report.result.flags)
    doc = write_fit(out, report, {}, {}, wide)
    out.commit()
    assert report.result.flags == before  # the caller's report is not changed
    assert doc["sensitivity"]["choices"] == rep.choices
    assert any(f["code"] == "processing_sensitive" and f["what"] == "mu" for f in doc["flags"])
    page = (tmp_path / "fit" / "report.html").read_text(encoding="utf-8")
    assert "Sensitivity to processing choices" in page and "<b>5.0</b>" in page


def test_sensitivity_refits_are_the_reported_fit_but_for_their_choice(monkeypatch):
    """Every refit gets the reported fit's options (a fixed pose width, a held-out stance, ...)
    and the reference is the fit's own cutoff: the refits estimated the pose width the user had
    fixed, and with --cutoff 10 the reference was a 6 Hz refit the user never ran."""
    import importlib
    import types

    # (the package's attribute of that name is the function)
    sensitivity_module = importlib.import_module("gc_ocp.workflow.sensitivity")
    calls = []

    def fake_fit(pairs, **kw):
        calls.append(kw)
        cut = pairs[0][1]
        shared = {"n": 1.0 + cut / 100 + kw["margin"], "n_se": 0.01 * cut}
        return types.SimpleNamespace(result=types.SimpleNamespace(params={"shared": shared}))

    monkeypatch.setattr(sensitivity_module, "fit", fake_fit)
    options = {"holdout": "auto", "pose_scale": False, "sole_scale": False}
    rep = sensitivity_module.sensitivity(
        ["trial"],
        compute_kinematics=lambda t, cutoff_hz: cutoff_hz,
        reference_cutoff=10.0,
        fit_options=options,
    )
    assert rep.choices == [
        "4 Hz, 30 ms",
        "6 Hz, 30 ms",
        "8 Hz, 30 ms",
        "10 Hz, 30 ms",
        "10 Hz, 60 ms",
    ]
    assert rep.reference == "10 Hz, 30 ms" and rep.se["n"] == pytest.approx(0.1)
    assert all(all(c[k] == v for k, v in options.items()) for c in calls)
    assert all(c["bias_correction"] == 0 for c in calls)


def test_a_sensitivity_refit_that_fails_is_recorded_not_the_end_of_the_fit(monkeypatch):
    """A refit at another choice that does not converge (or whose checks refuse it) raised out
    of ``gc-ocp fit --sensitivity``: the fit itself, converged and printed, was discarded and
    the run said 'solve failed'. The choice is recorded as failed (its values NaN) and flagged."""
    import importlib
    import math
    import types

    from gc_ocp.errors import SolveError

    sensitivity_module = importlib.import_module("gc_ocp.workflow.sensitivity")

    def fake_fit(pairs, **kw):
        if pairs[0][1] == 8.0:
            raise SolveError("Ipopt did not converge: Maximum_Iterations_Exceeded")
        shared = {"n": 1.0 + pairs[0][1] / 100 + kw["margin"], "n_se": 0.01}
        return types.SimpleNamespace(result=types.SimpleNamespace(params={"shared": shared}))

    monkeypatch.setattr(sensitivity_module, "fit", fake_fit)
    rep = sensitivity_module.sensitivity(
        ["trial"], compute_kinematics=lambda t, cutoff_hz: cutoff_hz
    )
    assert rep.choices == ["4 Hz, 30 ms", "6 Hz, 30 ms", "6 Hz, 60 ms", "8 Hz, 30 ms"]
    assert rep.reference == "6 Hz, 30 ms" and math.isnan(rep.values["n"][3])
    assert rep.spread("n") == pytest.approx(0.05)  # over the refits made
    assert "Maximum_Iterations_Exceeded" in rep.failed["8 Hz, 30 ms"]
    [flag] = [f for f in rep.flags() if f["code"] == "sensitivity_refit_failed"]
    assert flag["what"] == "8 Hz, 30 ms" and "8 Hz, 30 ms" in rep.summary()


def test_extended_model_started_from_the_base_never_ends_higher():
    """base + time_offset contains the base (zero delay); started also from the base's solution
    it ends at or below the base's objective (without that start, gait2392 ended at 380 vs 361).
    Tolerance: Ipopt moves the start inside the bounds (bound_push) and stops at a relative
    objective change of 1e-6 over 5 iterations; 1e-4 of J covers both. The pose width is kept
    fixed (``pose_scale=False``): estimated per model, the two objectives would carry different
    priors and not compare."""
    import warnings

    from gc_ocp.estimation import base_model, model_from_names
    from gc_ocp.workflow import fit

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tk = _real("gait2392")
        base = fit([tk], model=base_model(), pose_scale=False).result
        ext = fit(
            [tk],
            model=model_from_names(["time_offset"], base=base_model()),
            start=base,
            pose_scale=False,
        ).result
    assert ext.objective <= base.objective * (1 + 1e-4), (ext.objective, base.objective)
    # the same from fit(extends=...): the model it extends fitted first on the same stances
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ext2 = fit(
            [tk],
            model=model_from_names(["time_offset"], base=base_model()),
            extends=base_model(),
            pose_scale=False,
        ).result
    assert ext2.objective == pytest.approx(ext.objective, rel=1e-12)  # the same start and solves


@pytest.mark.parametrize("effect", [None, *EFFECTS])
def test_problems_that_differ_only_in_plate_data_share_their_slot_maps(bundled, effect):
    """The linear maps ``Y = A x + y0`` are cached per stance by the slots' expression
    (``SLOT_MAP_CACHE``): a stance's slots never read the plate's data. For the base and the
    base with every candidate effect, a build on other plate data (measured wrench, plate
    signal, threshold changed) reuses every stance's map and equals a build without the cache
    exactly; slots that change (the sole's nominal points moved) do not hit it."""
    import dataclasses
    import warnings

    from gc_ocp.estimation import problem as pm
    from gc_ocp.estimation.components import base_model, model_from_names
    from gc_ocp.estimation.starts import with_lls_start
    from gc_ocp.workflow.fitting import fit_data

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the fit's notes are tested elsewhere
        _, data, _ = fit_data([bundled])
    model = base_model() if effect is None else model_from_names([effect], base_model())
    model = with_lls_start(model, data)
    other = [
        dataclasses.replace(
            st,
            measured=1.1 * st.measured + 3.0,
            plate_wrench=None if st.plate_wrench is None else 0.9 * st.plate_wrench,
            censor_below=15.0,
        )
        for st in data
    ]
    first = pm.build_estimation(data, model)
    hits = len(pm._SLOT_MAPS)
    cached = pm.build_estimation(other, model)
    assert len(pm._SLOT_MAPS) == hits  # reused, not added
    assert all(a.map is b.map for a, b in zip(first.blocks, cached.blocks, strict=True))
    pm._SLOT_MAPS.clear()
    fresh = pm.build_estimation(other, model)
    n = len(pm._SLOT_MAPS)
    assert 1 <= n <= len(data)
    for a, b in zip(cached.blocks, fresh.blocks, strict=True):
        assert (a.map.A_csr != b.map.A_csr).nnz == 0
        np.testing.assert_array_equal(a.map.y0_array, b.map.y0_array)
        np.testing.assert_array_equal(a.D, b.D)
    x = fresh.x0
    np.testing.assert_array_equal(cached.data_residuals(x), fresh.data_residuals(x))
    moved = [
        st.with_foot(st.foot.with_points(st.foot.points_local + 1e-3, st.layout)) for st in data
    ]
    pm.build_estimation(moved, model)
    assert len(pm._SLOT_MAPS) == 2 * n  # other slots: new entries


def test_a_warm_start_laid_over_another_point_keeps_what_the_result_lacks():
    """``rescaled_start(prev, problem, under=x)``: the variables ``prev`` has come from it (prior
    variables rescaled to ``problem``'s widths, as without ``under``), the others keep ``x``'s
    values (not ``problem``'s start): how several fits are laid over one another."""
    from gc_ocp.estimation import model_from_names
    from gc_ocp.estimation.solve import result_at
    from gc_ocp.estimation.starts import rescaled_start

    _, _, sts = _stances(np.random.default_rng(3))
    small = build_estimation(sts, _model())
    big = build_estimation(sts, model_from_names(["damping"], base=_model()))
    rng = np.random.default_rng(4)
    prev = result_at(
        small,
        np.clip(small.x0 + 0.1 * rng.standard_normal(small.x0.size), small.lbx, small.ubx),
        covariance=False,
    )
    under = np.clip(big.x0 + rng.standard_normal(big.x0.size), big.lbx, big.ubx)
    plain, laid = rescaled_start(prev, big), rescaled_start(prev, big, under=under)
    had = np.zeros(big.x0.size, bool)
    keys = {s.key: s for s in prev.variables}
    for spec in big.variables.specs:
        if spec.key in keys and keys[spec.key].size == spec.size:
            had[spec.slice] = True
    assert had.any() and (~had).any()  # the test needs both kinds of variable
    np.testing.assert_array_equal(laid[had], plain[had])
    np.testing.assert_array_equal(laid[~had], under[~had])


def test_ctrl_c_during_a_solve_raises_keyboard_interrupt(monkeypatch):
    """CasADi catches Ctrl-C (SIGINT) during an Ipopt solve, stops it and clears Python's
    KeyboardInterrupt: the solve came back as an ordinary failure (NonIpopt_Exception_Thrown),
    and ``gc-ocp fit`` went on with its other starts, wrote another result than an
    uninterrupted run's and exited 0. The signal is sent 0.2 s after the solver is called, on a
    solve that cannot end by itself before (tol 1e-30, no acceptable stop), so it arrives inside
    Ipopt; the solve's end is bounded by max_iter should the interrupt be lost."""
    import importlib
    import os
    import signal
    import threading

    solve_module = importlib.import_module("gc_ocp.estimation.solve")  # not the function
    make = solve_module.make_solver

    def interrupted(*a, **kw):
        real = make(*a, **kw)

        class Solver:
            def __call__(self, **args):
                threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGINT)).start()
                return real(**args)

            def stats(self):
                return real.stats()

        return Solver()

    monkeypatch.setattr(solve_module, "make_solver", interrupted)
    _, _, sts = _stances(np.random.default_rng(2))
    prob = build_estimation(sts, _model())
    # Python's own Ctrl-C handler, as in a command line run: a pytest-xdist worker ignores
    # SIGINT (its controller stops it), and the solve then ran to max_iter (CI hung on it)
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            # the interrupt comes after ~16 of this problem's 12 ms iterations; 2000 (~25 s)
            # make a lost interrupt fail the test instead of hanging it
            solve(prob, IpoptOptions(tol=1e-30, acceptable_iter=0, max_iter=2000))
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # restored
    finally:
        signal.signal(signal.SIGINT, before)
