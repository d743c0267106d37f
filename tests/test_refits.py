"""The refit null (``gc_ocp.diagnosis.refits``): the data and every replicate scored by the
ranking's own statistic, the refitted folds."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from gc_ocp.errors import InputError


@pytest.fixture(scope="module")
def refit_diagnosis(bundled_stances):
    """The bundled trial, one candidate, a refit null of four draws (cheap, not a decision)."""
    from gc_ocp.diagnosis import diagnose_stances

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return diagnose_stances(
            list(bundled_stances),
            candidates=["damping"],
            n_boot=100,
            mismatch_draws=4,
            null_fits="refit",
            max_effects=0,
        )


def test_the_refit_null_tests_the_gain_the_ranking_shows(refit_diagnosis):
    """The test's statistic is the row's held-out reduction itself (the one-step null's is
    another number: on this trial's damping +1.9 % against +8.7 %); the round's record says
    the null refitted, with one replicate per draw."""
    (row,) = refit_diagnosis.ranking
    # the same sums of the same fold energies, taken two ways: equal to round-off
    assert row.calibrated.observed_pct == pytest.approx(row.heldout_rms_reduction_pct, abs=1e-9)
    (info,) = refit_diagnosis.calibration
    assert info["null_fits"] == "refit"
    assert info["replicates"] == info["mismatch_draws"] == 4
    assert 0.0 < row.calibrated.p_adjusted <= 1.0
    # a one-replicate draw has no spread within it: all of the null's spread is between draws
    assert row.calibrated.null_sd_mismatch_pct == pytest.approx(row.calibrated.null_sd_pct)
    # no note about the one step's miss: this test does not take one
    assert not any("one step" in n for n in refit_diagnosis.notes)


def test_fold_energies_sum_to_the_ranking_s_score(refit_diagnosis):
    from gc_ocp.diagnosis.compare import score
    from gc_ocp.diagnosis.refits import fold_energies

    for ev in refit_diagnosis.evaluations.values():
        E = fold_energies(ev)
        assert E.shape == (len(ev.folds), 1)
        assert np.sqrt(2 * E.sum() / ev.n_residuals) == pytest.approx(score(ev), rel=1e-12)


def test_a_replicate_is_the_draw_s_data_plus_flipped_residual_blocks_zeroed_as_recorded(
    bundled_stances,
):
    """With no mismatch, a replicate is the debiased parent's wrench plus the observed
    residual's blocks, sign-flipped: the same size frame by frame where the plate recorded,
    exactly zero where its threshold zeroed it."""
    from gc_ocp.diagnosis.compare import evaluate, fold_plan
    from gc_ocp.diagnosis.diagnose import resolve_base
    from gc_ocp.diagnosis.draws import NullInputs, debiased, draw_data
    from gc_ocp.diagnosis.mismatch import MismatchFamily, thresholded
    from gc_ocp.diagnosis.null import null_draw, prior_step
    from gc_ocp.diagnosis.onestep import linearize_parent
    from gc_ocp.diagnosis.refits import RefitInputs, draw_replicate
    from gc_ocp.estimation.problem import Weights
    from gc_ocp.estimation.starts import with_lls_start

    # the bundled plates zero nothing: recorded here as a lab zeroing below 20 N would
    stances = [
        dataclasses.replace(thresholded(st, 20.0), censor_below=20.0) for st in bundled_stances
    ]
    _, model = resolve_base("registered")
    plan = fold_plan(stances)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ev = evaluate(stances, model, "base", (), plan)
    law = with_lls_start(model, stances)
    lin = linearize_parent(stances, ev.model, ev.full, None)
    truth = debiased(stances, law, ev.full, -prior_step(lin), None)
    inputs = NullInputs(tuple(stances), law, ev.full, truth, {}, lin, tuple(plan), {}, (), 1, 100.0)
    family = MismatchFamily(scale=0.0)
    draw = null_draw(family, np.random.default_rng(0), stances[0].layout, law)
    rng_a, rng_b = np.random.default_rng(3), np.random.default_rng(3)
    rep = draw_replicate(RefitInputs(inputs, ev, {}), draw, rng_a)
    clean = draw_data(inputs, draw, rng_b)  # the same draw's data, before the residual
    w = Weights()
    for st, r, c, f in zip(stances, rep, clean, ev.full.stance_fits, strict=True):
        low = r.measured[:, 2] < st.censor_below
        assert low.any() and np.all(r.measured[low] == 0.0)  # zeroed as the lab did
        # where the plate recorded, in the draw's data and on the observed data (the wild
        # residual is zero where the observed plate recorded nothing)
        keep = ~low & (c.measured[:, 2] >= st.censor_below)
        keep &= np.asarray(f["measured"])[:, 2] >= st.censor_below
        added = (r.measured - c.measured)[keep] * w.inverse_sigmas(st.body_weight)
        e = w.residuals(f)[keep]  # the observed weighted residual
        np.testing.assert_allclose(np.abs(added), np.abs(e), rtol=1e-9, atol=1e-9)
        flipped = np.sign(added[:, 2]) != np.sign(e[:, 2])
        assert 0 < flipped.sum() < keep.sum()  # blocks flipped at random, not all or none
        # a clock-offset model resamples the plate signal: made from the replicate's wrench
        np.testing.assert_allclose(
            np.interp(st.time, r.plate_time, r.plate_wrench[:, 2]), r.measured[:, 2], atol=1e-9
        )


def test_an_unknown_null_fits_or_a_refit_null_without_draws_is_refused(bundled_stances):
    bundled = list(bundled_stances)
    from gc_ocp.diagnosis import diagnose_stances

    with pytest.raises(InputError, match="null_fits must be one of one-step, refit"):
        diagnose_stances(bundled, candidates=["damping"], null_fits="full")
    # no draws would leave the refit statistic without a null of its kind: refused, not
    # scored against the one-step null's noise-only replicates
    with pytest.raises(InputError, match="one replicate per mismatch draw"):
        diagnose_stances(bundled, candidates=["damping"], null_fits="refit", mismatch_draws=0)


def test_the_command_line_takes_the_refit_null():
    from gc_ocp.cli import build_parser

    args = build_parser().parse_args(["diagnose", "--out", "x", "--null-fits", "refit"])
    assert args.null_fits == "refit"
    args = build_parser().parse_args(["benchmark-diagnosis", "--out", "x"])
    assert args.null_fits == "one-step"


def test_the_report_and_summary_say_the_null_refitted(refit_diagnosis, tmp_path):
    """The page's method and the ranking's header describe the test that was made (refitted
    folds, not one step), as does the summary; and the JSON round trip keeps it."""
    from gc_ocp.diagnosis.report import report_html
    from gc_ocp.diagnosis.result import Diagnosis

    page = report_html(refit_diagnosis)
    assert "calibrated test: refit reduction vs its null" in page
    assert "<i>refit null</i>" in page
    assert "one Gauss&ndash;Newton step" not in page and "one-step reduction" not in page
    assert "refitted every fold of every model" in refit_diagnosis.summary()
    back = Diagnosis.from_json(refit_diagnosis.to_json())
    assert back.calibration[0]["null_fits"] == "refit"


def test_the_refit_null_s_draws_keep_the_units_off_the_layout():
    """The one-step null's draws put the units back on the layout (its one step would keep
    the offsets' second-order terms); the refit null's keep them, as a truth has them, and
    the same random numbers give the same draw otherwise."""
    import dataclasses as dc

    from gc_ocp.diagnosis.diagnose import resolve_base
    from gc_ocp.diagnosis.draws import NullInputs
    from gc_ocp.diagnosis.mismatch import MismatchFamily
    from gc_ocp.diagnosis.null import null_draw
    from gc_ocp.diagnosis.refits import RefitInputs
    from gc_ocp.foot import SEED_LAYOUT

    _, model = resolve_base("registered")  # has the sole registration
    family = MismatchFamily()
    one = null_draw(family, np.random.default_rng(7), SEED_LAYOUT, model)
    refit = null_draw(family, np.random.default_rng(7), SEED_LAYOUT, model, units_off=True)
    size = lambda d: max(abs(v) for o in d.unit_offsets.values() for u in o for v in u)  # noqa: E731
    assert size(one) == 0.0 and size(refit) > 1e-4  # a 2 mm family draws offsets of mm
    assert dc.replace(refit, unit_offsets=one.unit_offsets) == one
    assert RefitInputs.units_off and not NullInputs.units_off
