"""The calibrated test of the diagnosis (``gc_ocp.diagnosis.null``): the max-statistic decision
holds its family-wise rate, the one-step fits respect the bounds, the steps-needed formula."""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest
import scipy.optimize as so
import scipy.sparse as sp

from gc_ocp.diagnosis import null, onestep


def _null_draws(rng, n_cand=5, B=500):
    """Correlated null reductions of ``n_cand`` candidates with unlike means and spreads (as a
    round's: a damping whose null spreads wide, a toe hinge whose null barely moves)."""
    mean = np.array([-0.5, 0.2, 0.0, 1.0, -2.0])[:n_cand]
    sd = np.array([2.0, 0.5, 0.02, 1.0, 3.0])[:n_cand]
    C = 0.5 * np.ones((n_cand, n_cand)) + 0.5 * np.eye(n_cand)
    L = np.linalg.cholesky(C)

    def draw(n):
        return mean[:, None] + sd[:, None] * (L @ rng.normal(size=(n_cand, n)))

    return draw


def test_the_max_statistic_holds_the_family_wise_rate_and_names_a_clear_effect():
    rng = np.random.default_rng(0)
    draw = _null_draws(rng)
    names = [f"e{k}" for k in range(5)]
    nulls = dict(zip(names, draw(500), strict=True))
    trials = 1000
    obs = draw(trials)
    claims = 0
    for t in range(trials):
        tests = null.decide(dict(zip(names, obs[:, t], strict=True)), nulls, {}, 6)
        claims += any(x.p_adjusted < null.ALPHA for x in tests.values())
    # observed drawn from the null itself: the rate of any claim is alpha up to the binomial
    # error of 1000 trials (SD 0.007) and the null's own sampling error (500 replicates: the
    # 95 % quantile of the max is off by about +-0.01 in probability): +-0.03 is > 3 SD
    assert abs(claims / trials - null.ALPHA) < 0.03
    # a gain 6 null SDs above the null mean of one candidate is named, the others not
    o = {n: float(np.mean(v)) for n, v in nulls.items()}
    o["e1"] += 6 * float(np.std(nulls["e1"]))
    tests = null.decide(o, nulls, {}, 6)
    assert tests["e1"].p_adjusted < null.ALPHA and tests["e1"].more_stances == 0
    assert all(tests[n].p_adjusted > null.ALPHA for n in names if n != "e1")


def test_a_candidate_the_data_do_not_move_is_left_out_of_the_max_statistic():
    """A candidate whose observed and null reductions are all round-off (a toe hinge that never
    bends: 1e-9 % in the stored benchmarks) is not tested: its row is marked inert, with p = 1
    and no steps, although its own studentised round-off is far out in its tail; the other
    candidates get exactly the decision they would get without it."""
    rng = np.random.default_rng(3)
    names = ["e0", "e1", "e2"]
    nulls = dict(zip(names, _null_draws(rng, 3)(500), strict=True))
    obs = {n: float(np.mean(v) + 2.0 * np.std(v)) for n, v in nulls.items()}
    hinge = 1e-9 + 1e-10 * rng.standard_t(2, size=500)  # heavy-tailed round-off
    with_hinge = null.decide({**obs, "hinge": 5e-9}, {**nulls, "hinge": hinge}, {}, 6)
    without = null.decide(obs, nulls, {}, 6)
    h = with_hinge["hinge"]
    assert (h.observed_pct - float(np.mean(hinge))) / float(np.std(hinge)) > 3  # round-off's z
    assert h.inert and h.p_adjusted == 1.0 and h.more_stances is None
    assert h.to_json()["inert"] is True and "inert" not in without["e0"].to_json()
    assert null.NullTest(**h.to_json()) == h
    for n in names:
        assert with_hinge[n] == without[n]
    assert h.z_critical == without["e0"].z_critical
    # a gain above the resolution is tested as any other, its null's spread never taken
    # below the resolution (round-off would studentise 2e-4 % to thousands): twice the
    # resolution is z = 2, twenty times it is named
    moved = null.decide({**obs, "hinge": 2e-4}, {**nulls, "hinge": hinge}, {}, 6)
    assert not moved["hinge"].inert and moved["hinge"].z == pytest.approx(2.0, rel=1e-3)
    clear = null.decide({**obs, "hinge": 2e-3}, {**nulls, "hinge": hinge}, {}, 6)
    assert clear["hinge"].p_adjusted < null.ALPHA
    # nothing to test at all: no critical value
    alone = null.decide({"hinge": 5e-9}, {"hinge": hinge}, {}, 6)
    assert alone["hinge"].inert and alone["hinge"].z_critical is None


def test_the_steps_that_would_decide_follow_the_power_calculation():
    """Noise only: the smallest n with z_crit s sqrt(f) + 0.84 sigma sqrt(1 + f) <= T - m
    (f = n0 / n, sigma = sd / sqrt(n0)), checked at it and one below; and what it means, by
    simulation: a study of n0 + more stances, whose true gain is uncertain about the observed T
    by sigma and whose own estimate scatters by sigma sqrt(f) about it, names the candidate
    (its gain over the null's threshold z_crit s sqrt(f)) in 80 % of draws (assurance). The
    simulation's tolerance: 200 000 draws give a fraction's SE of 0.0009; 0.01 is over 10 SE,
    and one stance fewer falls short of 80 % by more than that here."""
    n0, crit, m, s, sd = 6, 2.5, 0.2, 0.5, 0.6
    t = 1.0
    sigma = sd / np.sqrt(n0)

    def needed(n):
        f = n0 / n
        return crit * s * np.sqrt(f) + null.POWER_Z * sigma * np.sqrt(1 + f)

    more = null.more_stances(t, m, s, sd, n0, crit, False)
    assert needed(n0 + more) <= t - m < needed(n0 + more - 1)
    rng = np.random.default_rng(0)

    def assurance(n):
        f = n0 / n
        true = t + sigma * rng.normal(size=200_000)
        seen = true + sigma * np.sqrt(f) * rng.normal(size=true.size)
        return np.mean(seen - m > crit * s * np.sqrt(f))

    assert assurance(n0 + more) >= 0.8 - 0.01  # at least 80 %, to the simulation's error
    assert assurance(n0 + more - 1) < 0.8
    # a larger gain needs fewer steps; a decided one none; one within the null mean cannot be
    # decided by more steps of the same kind, nor one whose own uncertainty reaches that far
    more = [null.more_stances(x, m, s, sd, n0, crit, False) for x in (0.5, 1.0, 2.0, 4.0)]
    assert more == sorted(more, reverse=True) and more[0] > more[-1]
    assert null.more_stances(t, m, s, sd, n0, crit, True) == 0
    assert null.more_stances(m - 0.1, m, s, sd, n0, crit, False) is None
    assert null.more_stances(m + 0.8 * null.POWER_Z * sigma, m, s, sd, n0, crit, False) is None


def test_the_spread_between_mismatch_draws_is_told_from_the_noise_within_them():
    """``between_draw_sd``: on replicates made as the mismatch null makes them (K draws, each a
    systematic offset of SD ``s_b``, with ``n_wild`` noise replicates of SD ``s_w`` around it)
    the one-way analysis of variance recovers ``s_b``. Tolerance: with K = 400 draws the
    estimate of a variance has a relative SD of about sqrt(2 / K) = 7 %, so 20 % on the SD is
    more than 5 of its SDs; without groups, or one draw, there is no between part."""
    rng = np.random.default_rng(3)
    K, n_wild, s_b, s_w = 400, 16, 0.8, 1.5
    draws = np.repeat(np.arange(K), n_wild)
    values = 0.3 + s_b * rng.normal(size=K)[draws] + s_w * rng.normal(size=draws.size)
    assert null.between_draw_sd(values, draws) == pytest.approx(s_b, rel=0.2)
    # noise alone (no systematic part): at most a fraction of the noise's SD
    noise = s_w * rng.normal(size=draws.size)
    assert null.between_draw_sd(noise, draws) < 0.2 * s_w
    assert null.between_draw_sd(values, None) == 0.0
    assert null.between_draw_sd(values, np.zeros(draws.size, int)) == 0.0


def test_a_gain_the_mismatch_alone_can_give_is_not_decided_by_more_steps():
    """The null's spread between mismatch draws does not shrink with more stances: a gain
    within ``z_crit s_b`` of the null's mean is undecidable (None) however large the study; a
    larger one needs more steps than the noise-only calculation says, and the number returned
    is the smallest that meets the power condition (checked at it and one below)."""
    n0, crit, m, s, sd = 6, 2.5, 0.2, 1.0, 0.6
    t = 2.0  # gap 1.8
    noise_only = null.more_stances(t, m, s, sd, n0, crit, False)
    assert null.more_stances(t, m, s, sd, n0, crit, False, s_between=0.8) is None  # 2.0 > 1.8
    s_b = 0.5  # crit s_b + 0.84 sigma = 1.46 < 1.8: decidable, later than without the mismatch
    more = null.more_stances(t, m, s, sd, n0, crit, False, s_between=s_b)
    assert more is not None and more > noise_only

    def needed(n):
        f = n0 / n
        sigma = sd / np.sqrt(n0)  # the observed gain's SE, uncertain by it (assurance)
        return crit * np.sqrt(s_b**2 + (s**2 - s_b**2) * f) + null.POWER_Z * sigma * np.sqrt(1 + f)

    assert needed(n0 + more) <= t - m < needed(n0 + more - 1)


def _single_stance(J, at_lower=(), at_upper=(), prior_idx=(), pw=(), r=None) -> onestep.Linear:
    """A one-stance linearised model on the dense Jacobian ``J`` (no nuisance), nested, with
    the given variables at their bounds and priors of weights ``pw`` (prior residual 0)."""
    n, nx = J.shape
    return onestep.Linear(
        r=np.zeros(n) if r is None else r,
        J=sp.csr_matrix(J),
        prior_idx=np.asarray(prior_idx, int),
        pw=np.asarray(pw, float),
        p0=np.zeros(len(pw)),
        rows=(slice(0, n),),
        nuisance=(np.zeros(0, int),),
        at_lower=np.asarray(at_lower, int),
        at_upper=np.asarray(at_upper, int),
        nested=True,
        x0=np.zeros(nx),
        keys={},
    )


def test_a_variable_at_its_bound_stays_there_in_the_one_step_fit():
    """The damping of a candidate starts at its neutral value 0, its lower bound: on replicates
    whose step would make it negative it stays at 0 and the others are fitted without it (the
    constrained least squares, checked against scipy's bounded solver)."""
    rng = np.random.default_rng(1)
    n, nx = 60, 4
    J = rng.normal(size=(n, nx))
    R = rng.normal(size=(n, 40))
    lin = _single_stance(J, at_lower=[2])
    d = onestep.step(J.T @ J, J.T @ R, lin)
    assert (d[2] >= -1e-12).all()
    crossed = 0
    for b in range(R.shape[1]):
        ref = so.lsq_linear(J, -R[:, b], bounds=([-np.inf, -np.inf, 0, -np.inf], np.inf))
        # the constrained optimum, to the solver's tolerance (lsq_linear's default 1e-10)
        np.testing.assert_allclose(d[:, b], ref.x, atol=1e-7)
        crossed += ref.active_mask[2] != 0
    assert 5 < crossed < 35  # both cases occur in the draw


def test_the_bounded_step_with_several_variables_at_bounds_is_the_constrained_optimum():
    """Three variables at bounds (two lower, one upper) with priors on some columns: every face
    is solved from one factorisation (``step``'s doc); each replicate's step is the bounded
    least-squares optimum (scipy's bounded solver on the stacked data and prior rows)."""
    rng = np.random.default_rng(4)
    n, nx = 80, 7
    J = rng.normal(size=(n, nx))
    pw = np.array([0.5, 2.0])
    prior = np.array([1, 5])
    R = rng.normal(size=(n, 60))
    lin = _single_stance(J, at_lower=[0, 3], at_upper=[5], prior_idx=prior, pw=pw)
    P = np.zeros((2, nx))
    P[[0, 1], prior] = pw
    d = onestep.step(J.T @ J + P.T @ P, J.T @ R, lin)
    lo = np.full(nx, -np.inf)
    hi = np.full(nx, np.inf)
    lo[[0, 3]] = 0.0
    hi[5] = 0.0
    A = np.vstack([J, P])
    active = 0
    for b in range(R.shape[1]):
        ref = so.lsq_linear(A, -np.concatenate([R[:, b], np.zeros(2)]), bounds=(lo, hi))
        # the constrained optimum, to the solver's tolerance (lsq_linear's default 1e-10)
        np.testing.assert_allclose(d[:, b], ref.x, atol=1e-7)
        active += np.count_nonzero(ref.active_mask)
    assert active > 20  # faces with one, two and three bounds active all occur in the draw


def test_a_variable_fixed_by_equal_bounds_stays_fixed_in_the_bounded_step():
    """A variable with ``lb == ub`` is at both bounds: it stays at 0 on every face, and the
    others are the bounded optimum without it (scipy's bounded solver on the other columns)."""
    rng = np.random.default_rng(5)
    n, nx = 50, 5
    J = rng.normal(size=(n, nx))
    R = rng.normal(size=(n, 30))
    lin = _single_stance(J, at_lower=[1, 3], at_upper=[3])
    d = onestep.step(J.T @ J, J.T @ R, lin)
    np.testing.assert_array_equal(d[3], 0.0)
    keep = [0, 1, 2, 4]
    for b in range(R.shape[1]):
        ref = so.lsq_linear(J[:, keep], -R[:, b], bounds=([-np.inf, 0, -np.inf, -np.inf], np.inf))
        # to the solver's tolerance (lsq_linear's default 1e-10)
        np.testing.assert_allclose(d[keep, b], ref.x, atol=1e-7)


def test_the_bounded_step_with_many_variables_at_bounds_is_the_constrained_optimum():
    """Beyond ``MAX_ACTIVE_SET`` bounded variables the step is the primal active-set method: on
    nine variables at bounds (six lower, three upper), each replicate's step is the bounded
    least-squares optimum (scipy's bounded solver), faces of many active bounds included."""
    rng = np.random.default_rng(7)
    n, nx = 90, 12
    J = rng.normal(size=(n, nx))
    R = rng.normal(size=(n, 40))
    lower, upper = [0, 1, 2, 4, 6, 8], [3, 9, 10]
    assert len(lower) + len(upper) > onestep.MAX_ACTIVE_SET
    lin = _single_stance(J, at_lower=lower, at_upper=upper)
    d = onestep.step(J.T @ J, J.T @ R, lin)
    lo, hi = np.full(nx, -np.inf), np.full(nx, np.inf)
    lo[lower], hi[upper] = 0.0, 0.0
    active = []
    for b in range(R.shape[1]):
        ref = so.lsq_linear(J, -R[:, b], bounds=(lo, hi))
        # the constrained optimum, to the solver's tolerance (lsq_linear's default 1e-10)
        np.testing.assert_allclose(d[:, b], ref.x, atol=1e-7)
        active.append(np.count_nonzero(ref.active_mask))
    assert max(active) >= 4 and min(active) < max(active)  # many faces occur in the draw


def _stance_blocks(rng, n_st: int, T6: int, n_shared: int, n_z: int):
    """A random Jacobian of ``n_st`` stances of ``T6`` rows: ``n_shared`` columns every stance
    sees and ``n_z`` nuisance columns per stance; with each stance's rows and nuisance."""
    nx = n_shared + n_st * n_z
    rows = tuple(slice(k * T6, (k + 1) * T6) for k in range(n_st))
    nuis = tuple(np.arange(n_shared + k * n_z, n_shared + (k + 1) * n_z) for k in range(n_st))
    J = np.zeros((n_st * T6, nx))
    for k in range(n_st):
        J[rows[k], :n_shared] = rng.normal(size=(T6, n_shared))
        J[rows[k], nuis[k]] = rng.normal(size=(T6, n_z))
    return J, rows, nuis


def test_a_held_out_nuisance_at_its_bound_stays_on_its_side():
    """The held-out stance's re-estimated nuisance keeps a column at a bound at the point on its
    side of it, as the training step does: the held-out energy is the bounded least-squares
    optimum (scipy's bounded solver on the data and prior rows), never below it."""
    rng = np.random.default_rng(8)
    n_st, T6, n_shared, n_z = 3, 30, 3, 2
    J, rows, nuis = _stance_blocks(rng, n_st, T6, n_shared, n_z)
    nx = J.shape[1]
    bound_col = int(nuis[0][0])  # stance 0's first nuisance column at its lower bound
    lin, P, pos = _linear_with_priors(rng, J, rows, nuis, at_lower=np.array([bound_col]))
    R0 = rng.normal(size=(n_st * T6, 30))
    E = onestep.heldout_energy(lin, R0, [(0,)])
    keep = np.arange(rows[1].start, rows[2].stop)
    kz = [pos[c] for c in nuis[0]]
    crossed = 0
    for b in range(R0.shape[1]):
        r = R0[:, b]
        Jd = J.copy()
        train_lo = np.full(nx, -np.inf)
        train_lo[bound_col] = 0.0
        A = np.vstack([Jd[keep], P])
        d = so.lsq_linear(A, -np.concatenate([r[keep], lin.p0]), bounds=(train_lo, np.inf)).x
        d[nuis[0]] = 0.0
        Ji = J[rows[0]]
        a = r[rows[0]] + Ji @ d
        Az = np.vstack([Ji[:, nuis[0]], np.diag(lin.pw[kz])])
        ref = so.lsq_linear(Az, -np.concatenate([a, lin.p0[kz]]), bounds=([0.0, -np.inf], np.inf))
        want = 0.5 * np.sum((Az @ ref.x + np.concatenate([a, lin.p0[kz]])) ** 2)
        # the bounded optimum, to the solver's tolerance (lsq_linear's default 1e-10)
        assert E[0, b] == pytest.approx(want, rel=1e-8)
        crossed += ref.active_mask[0] != 0
    assert 3 < crossed < 27  # the bound is active on some replicates, not on all


def test_a_null_test_round_trips_through_json():
    t = null.NullTest(1.2, 0.1, 0.4, 2.75, 0.01, 2.4, 0, 6)
    assert null.NullTest(**t.to_json()) == t
    late = dataclasses.replace(t, p_adjusted=0.3, more_stances=14)
    assert late.practical and not dataclasses.replace(late, more_stances=40).practical


@pytest.mark.parametrize("T", [7, 50])
def test_the_wild_bootstrap_keeps_the_residual_size_and_skips_censored_samples(T):
    rng = np.random.default_rng(2)
    e = rng.normal(size=6 * T)
    lin = _single_stance(np.zeros((6 * T, 1)), r=e)
    measured = np.full((T, 6), 100.0)
    measured[: T // 3, 2] = 0.0  # zeroed below a 20 N threshold
    fit = {"measured": measured, "censor_below": 20.0, "time": np.arange(T) / 100.0}
    U = null.wild_residuals(lin, [fit], 300, rng, 100.0)
    Ur = U.reshape(T, 6, -1)
    np.testing.assert_array_equal(Ur[: T // 3], 0.0)
    # every other sample is the residual with a sign: same size, both signs
    np.testing.assert_allclose(
        np.abs(Ur[T // 3 :]), np.abs(e.reshape(T, 6)[T // 3 :, :, None]) + 0 * Ur[T // 3 :]
    )
    signs = np.sign(Ur[T // 3 :, 0, :] * e.reshape(T, 6)[T // 3 :, :1])
    assert 0.4 < (signs > 0).mean() < 0.6


def test_the_wild_bootstrap_blocks_last_the_same_time_at_each_stances_own_rate():
    """Two trials of one subject recorded at 100 and 200 Hz: a sign block is 0.1 s of each
    stance, 10 and 20 frames (it was 10 frames on both, the first stance's rate: 0.05 s at
    200 Hz, which understates the residuals' autocorrelation there). Every sign change in a
    stance lies a whole number of blocks after the one before it."""
    rng = np.random.default_rng(4)
    T1, T2 = 80, 160  # 0.8 s each
    n1, n2 = 6 * T1, 6 * T2
    lin = onestep.Linear(
        r=np.ones(n1 + n2),
        J=sp.csr_matrix((n1 + n2, 1)),
        prior_idx=np.zeros(0, int),
        pw=np.zeros(0),
        p0=np.zeros(0),
        rows=(slice(0, n1), slice(n1, n1 + n2)),
        nuisance=(np.zeros(0, int), np.zeros(0, int)),
        at_lower=np.zeros(0, int),
        at_upper=np.zeros(0, int),
        nested=True,
        x0=np.zeros(1),
        keys={},
    )
    fits = [
        {"measured": np.full((T, 6), 100.0), "time": 0.3 + np.arange(T) / rate}
        for T, rate in ((T1, 100.0), (T2, 200.0))
    ]
    U = null.wild_residuals(lin, fits, 200, rng, 100.0)
    for rows, T, block in ((slice(0, n1), T1, 10), (slice(n1, n1 + n2), T2, 20)):
        s = U[rows].reshape(T, 6, -1)[:, 0, :]  # channel 0: the sign of each frame
        gaps = np.concatenate([np.diff(np.flatnonzero(np.diff(c) != 0)) for c in s.T])
        assert gaps.size > 100 and np.all(gaps % block == 0)
        assert np.any(gaps == block)  # the blocks are not longer either


def _linear_with_priors(rng, J, rows, nuis, **kw) -> tuple[onestep.Linear, np.ndarray, dict]:
    """A nested linearised model on the dense Jacobian ``J`` (stances ``rows``, nuisance
    ``nuis``) with a random prior on every variable but the first; and, for
    :func:`_direct_heldout`, the prior rows ``P`` and each prior column's position."""
    nx = J.shape[1]
    prior_idx = np.arange(1, nx)
    pw = rng.uniform(0.5, 2.0, prior_idx.size)
    p0 = rng.normal(0.0, 0.3, prior_idx.size)
    lin = onestep.Linear(
        r=np.zeros(J.shape[0]),
        J=sp.csr_matrix(J),
        prior_idx=prior_idx,
        pw=pw,
        p0=p0,
        rows=rows,
        nuisance=nuis,
        nested=True,
        x0=np.zeros(nx),
        keys={},
        **{"at_lower": np.zeros(0, int), "at_upper": np.zeros(0, int), **kw},
    )
    P = np.zeros((prior_idx.size, nx))
    P[np.arange(prior_idx.size), prior_idx] = pw
    return lin, P, {c: k for k, c in enumerate(prior_idx)}


def _direct_heldout(lin, P, pos, keep, i, z, r) -> float:
    """The held-out energy of stance ``i`` solved directly by ``lstsq``: the training fit on the
    rows ``keep`` with every prior stacked as rows, then the columns ``z`` re-fitted on stance
    ``i`` from the point under their prior; ``r``: the residual at the point (one column)."""
    J = lin.J.toarray()
    d = np.linalg.lstsq(np.vstack([J[keep], P]), -np.concatenate([r[keep], lin.p0]), rcond=None)[0]
    d[z] = 0.0
    Ji = J[lin.rows[i]]
    a = r[lin.rows[i]] + Ji @ d
    kz = [pos[c] for c in z]
    Az = np.vstack([Ji[:, z], np.diag(lin.pw[kz])])
    dz = np.linalg.lstsq(Az, -np.concatenate([a, lin.p0[kz]]), rcond=None)[0]
    return 0.5 * (np.sum((a + Ji[:, z] @ dz) ** 2) + np.sum((lin.p0[kz] + lin.pw[kz] * dz) ** 2))


def test_grouped_folds_train_without_the_whole_group_and_score_each_stance():
    """The one-step held-out energy of a group of stances held out together, against a direct
    least-squares solution on a random linear model: the training fit without every row of
    the group (shared variables and priors, stacked as rows, solved by ``lstsq``), then each
    held-out stance with its own nuisance re-fitted from the point under its prior. Singletons
    are the leave-one-stance-out case."""
    rng = np.random.default_rng(4)
    n_st, T6, n_shared, n_z = 5, 30, 4, 2
    J, rows, nuis = _stance_blocks(rng, n_st, T6, n_shared, n_z)
    lin, P, pos = _linear_with_priors(rng, J, rows, nuis)
    R0 = rng.normal(size=(n_st * T6, 3))
    plan = [(0, 3), (1,), (2, 4)]
    E = onestep.heldout_energy(lin, R0, plan)
    j = 0
    for group in plan:
        keep = np.concatenate(
            [np.arange(rows[k].start, rows[k].stop) for k in range(n_st) if k not in group]
        )
        for b in range(R0.shape[1]):
            for i in group:
                want = _direct_heldout(lin, P, pos, keep, i, nuis[i], R0[:, b])
                assert E[j + group.index(i), b] == pytest.approx(want, rel=1e-9)
        j += len(group)
    assert E.shape == (5, 3)


def test_the_decision_carries_the_mismatch_part_of_the_null_into_its_steps():
    """``decide`` with the replicates' draw index: each test reports the between-draw spread,
    and a candidate whose gain only the between-draw spread could reach is undecidable, while
    without the draw index (every replicate its own draw, as a noise-only null) the same gain
    would be promised a finite number of steps."""
    rng = np.random.default_rng(5)
    K, n_wild = 64, 8
    draws = np.repeat(np.arange(K), n_wild)
    systematic = 1.0 * rng.normal(size=K)[draws]  # what the mismatch gives: does not shrink
    nulls = {
        "a": systematic + 0.3 * rng.normal(size=draws.size),
        "b": 0.5 * rng.normal(size=draws.size),
    }
    # "a" observed 1.8 SDs above its mean: not named at the family-wise 5 %, and within
    # z_crit times its between-draw spread
    obs = {"a": float(np.mean(nulls["a"]) + 1.8 * np.std(nulls["a"])), "b": 0.0}
    grouped = null.decide(obs, nulls, {}, 6, draws=draws)
    plain = null.decide(obs, nulls, {}, 6)
    a = grouped["a"]
    assert a.p_adjusted > null.ALPHA
    assert a.null_sd_mismatch_pct == pytest.approx(null.between_draw_sd(nulls["a"], draws))
    assert a.observed_pct - a.null_mean_pct <= a.z_critical * a.null_sd_mismatch_pct
    assert a.more_stances is None
    assert plain["a"].null_sd_mismatch_pct == 0.0 and plain["a"].more_stances > 0


def _shared_and_own(rng, n_draws, w, s_a, s_e):
    """Each draw's stance shares as :func:`~gc_ocp.diagnosis.onestep.stance_shares` gives
    them, made from a part every stance shares (SD ``s_a``) and each stance's own (``s_e``):
    ``w_s (a + e_s)``."""
    a = s_a * rng.normal(size=(n_draws, 1))
    e = s_e * rng.normal(size=(n_draws, w.size))
    return w * (a + e)


W4 = np.array([0.1, 0.2, 0.3, 0.4])


@pytest.mark.parametrize(("s_a", "s_e"), [(1.0, 0.0), (0.0, 1.0), (0.6, 1.2)])
def test_the_shared_fraction_of_the_spread_between_draws_is_recovered(s_a, s_e):
    """``shared_fraction``: on draws whose stance shares are ``w_s (a + e_s)`` the fraction
    ``var(a) / (var(a) + sum w_s^2 var(e))`` of the variance of their sum is recovered, with
    unequal weights. Tolerance: with 20000 draws the fraction's sampling SD is about 0.01 (the
    covariances' relative SD 1/sqrt(20000), over 1 - sum w^2 = 0.7); 0.03 is three of them."""
    rng = np.random.default_rng(7)
    shares = _shared_and_own(rng, 20000, W4, s_a, s_e)
    expect = s_a**2 / (s_a**2 + np.sum(W4**2) * s_e**2)
    assert null.shared_fraction(shares, W4) == pytest.approx(expect, abs=0.03)


def test_the_split_takes_off_the_noise_each_draw_s_mean_carries():
    """A draw's shares are the mean of its ``n_wild`` wild replicates: their noise, independent
    between stances, inflates the variance of the sum and not the covariances between stances,
    so uncorrected a wholly shared spread looks partly the stances' own (the error that would
    promise decisions); the mean within-draw covariance over ``n_wild`` takes it off.
    Tolerance as above (20000 draws)."""
    rng = np.random.default_rng(8)
    n_draws, n_wild, noise = 20000, 4, 2.0  # within-draw SD twice the draws' shared SD
    means = _shared_and_own(rng, n_draws, W4, 1.0, 0.0)
    means = means + W4 * noise * rng.normal(size=means.shape) / np.sqrt(n_wild)
    within = np.diag((W4 * noise) ** 2)
    raw = null.shared_fraction(means, W4)
    assert raw < 0.85  # the noise alone makes the shared spread look partly own
    assert null.shared_fraction(means, W4, within, n_wild) == pytest.approx(1.0, abs=0.03)


def test_the_split_is_not_made_where_it_cannot_be_trusted():
    """``systematic_sd``: None (all of the spread counted as shared, as before the split) with
    one held-out stance, fewer than ``MIN_SPLIT_DRAWS`` draws, no spread or values not finite;
    made, it lies between the point estimate's value and the whole spread (its upper 80 %
    bootstrap limit: towards more steps)."""
    rng = np.random.default_rng(9)
    shares = _shared_and_own(rng, 32, W4, 0.6, 1.2)
    s_b = float(np.std(shares.sum(axis=1), ddof=1))
    made = null.systematic_sd(s_b, shares, W4)
    point = s_b * np.sqrt(null.shared_fraction(shares, W4))
    assert point <= made <= s_b
    assert made < s_b  # the comparison can fail: a shared part well under all of it
    assert null.systematic_sd(s_b, shares[:, :1], W4[:1]) is None
    assert null.systematic_sd(s_b, shares[: null.MIN_SPLIT_DRAWS - 1], W4) is None
    assert null.systematic_sd(0.0, shares, W4) is None
    bad = shares.copy()
    bad[3, 1] = np.nan
    assert null.systematic_sd(s_b, bad, W4) is None
    assert null.systematic_sd(s_b, np.zeros_like(shares), W4) is None


def test_steps_follow_only_the_shared_part_of_the_spread_between_draws():
    """A gain within ``z_crit`` times the whole spread between draws, but whose draws' spread is
    the stances' own, is no longer called undecidable: more stances shrink that part, and the
    decision reports both spreads; with every stance sharing the draws' spread it stays
    undecidable. 200 draws: the split's bootstrap limit then sits near its value."""
    rng = np.random.default_rng(11)
    K, n_wild, rows = 200, 8, 6
    draws = np.repeat(np.arange(K), n_wild)
    w = np.full(rows, 1.0 / rows)
    own = _shared_and_own(rng, K, w, 0.0, 2.5)  # sums: SD about 1, all of it the stances' own
    shared = _shared_and_own(rng, K, w, 1.0, 0.0)  # sums: SD 1, all of it shared
    for shares, decidable in ((own, True), (shared, False)):
        nulls = {"a": shares.sum(axis=1)[draws] + 0.3 * rng.normal(size=draws.size)}
        # 0.9 z_crit whole between-draw spreads above the null's mean: not named, and within
        # what the spread between draws alone gives (z_crit does not depend on the observed)
        crit = null.decide({"a": 0.0}, nulls, {}, rows, draws=draws)["a"].z_critical
        s_b = null.between_draw_sd(nulls["a"], draws)
        obs = {"a": float(np.mean(nulls["a"]) + 0.9 * crit * s_b)}
        split = null.StanceShares({"a": shares}, w)
        t = null.decide(obs, nulls, {}, rows, draws=draws, shares=split)["a"]
        whole = null.decide(obs, nulls, {}, rows, draws=draws)["a"]
        assert t.p_adjusted > null.ALPHA
        assert whole.more_stances is None and whole.null_sd_systematic_pct is None
        assert t.null_sd_mismatch_pct == whole.null_sd_mismatch_pct
        assert (t.more_stances is not None) == decidable, t
        assert (t.null_sd_systematic_pct < 0.5 * t.null_sd_mismatch_pct) == decidable
        assert null.NullTest(**t.to_json()) == t


def test_stance_shares_sum_to_the_reduction_to_first_order():
    """``stance_shares``: each stance's share of the combined reduction sums to it up to the
    second-order term of ``100 (1 - sqrt(1 - x))`` (``12.5 x^2``), and the weights to 1."""
    E = {"parent": np.array([[10.0, 8.0], [20.0, 30.0]]), "c": np.array([[9.5, 7.0], [19.4, 29.5]])}
    shares, weights = onestep.stance_shares(E)
    red = onestep.reductions(E)["c"]
    x = 1.0 - E["c"].sum(axis=0) / E["parent"].sum(axis=0)
    np.testing.assert_allclose(shares["c"].sum(axis=0), red, atol=float(np.max(13 * x**2)))
    assert np.abs(shares["c"].sum(axis=0) - red).max() > 0  # the comparison can fail
    np.testing.assert_allclose(weights.sum(axis=0), 1.0, rtol=1e-12)


def _mixture_null(rng, n_draws, n_wild, names, between, within):
    """A round's null as the draws make it: per draw a shift of every candidate's reduction
    (the mismatch: ``between`` SD, correlated across candidates) plus per replicate noise
    (``within`` SD); the draw index of every replicate."""
    k = len(names)
    C = 0.5 * np.ones((k, k)) + 0.5 * np.eye(k)
    L = np.linalg.cholesky(C)
    shift = between[:, None] * (L @ rng.normal(size=(k, n_draws)))
    noise = within[:, None, None] * rng.normal(size=(k, n_draws, n_wild))
    vals = (shift[:, :, None] + noise).reshape(k, -1)
    return dict(zip(names, vals, strict=True)), np.repeat(np.arange(n_draws), n_wild)


def test_stopping_the_draws_early_loses_no_claim_the_full_null_makes():
    """The stop for futility (``cannot_name``, looked at after every ``DRAWS_PER_LOOK`` draws
    of ``MISMATCH_DRAWS``) can only turn a claim into no claim; what it could cost is a claim
    the full null makes. Rounds whose observed statistics range from the null's own (no effect)
    to 5 null SDs on one candidate, the null a mixture over draws as the package's: no round
    the full null names is stopped, and the stop is taken in most rounds without a claim (the
    time it saves)."""
    rng = np.random.default_rng(3)
    names = ["a", "b", "c", "d"]
    between = np.array([1.0, 0.3, 2.0, 0.1])
    within = np.array([0.5, 0.3, 1.0, 0.2])
    K, W, L = null.MISMATCH_DRAWS, 16, null.DRAWS_PER_LOOK
    lost = stopped_none = rounds_none = claims = 0
    for t in range(400):
        nulls, draws = _mixture_null(rng, K, W, names, between, within)
        obs_null, _ = _mixture_null(rng, 1, 1, names, between, within)
        obs = {n: float(v[0]) for n, v in obs_null.items()}
        sd = {n: float(np.std(v)) for n, v in nulls.items()}
        obs["a"] += (t % 6) * sd["a"]  # 0, 1, ..., 5 null SDs
        full = null.decide(obs, nulls, {}, 6, draws=draws)
        named = any(x.p_adjusted < null.ALPHA for x in full.values())
        stop = any(  # as the package looks: the p-value counts draws
            null.cannot_name(
                obs, {n: v[draws < k] for n, v in nulls.items()}, K, draws=draws[draws < k]
            )
            for k in range(L, K, L)
        )
        claims += named
        lost += named and stop
        rounds_none += not named
        stopped_none += stop and not named
    assert claims > 50  # the strong rounds are named: the check has claims to lose
    assert lost == 0
    assert stopped_none > 0.5 * rounds_none


def test_the_stop_weighs_only_the_candidates_the_floor_leaves():
    """``final_p_bound(among=...)``: the bound is the smallest over the candidates that could
    still be named (the floor rules the others out), with the max statistic still taken over
    every candidate; none left: nothing can be named (bound 1, the draws may stop)."""
    rng = np.random.default_rng(1)
    names = ["a", "b", "c"]
    nulls, _ = _mixture_null(rng, 8, 16, names, np.array([1.0, 1.0, 1.0]), np.full(3, 0.5))
    sd = {n: float(np.std(v)) for n, v in nulls.items()}
    obs = {"a": 6 * sd["a"], "b": 0.0, "c": -1.0}  # a is far out, b and c within the null
    n_final = 32 * 16
    every = null.final_p_bound(obs, nulls, n_final)
    assert every == pytest.approx(1 / (n_final + 1))  # a: no replicate reaches it
    assert not null.cannot_name(obs, nulls, n_final)
    without_a = null.final_p_bound(obs, nulls, n_final, among={"b", "c"})
    assert without_a > null.FUTILITY_FACTOR * null.ALPHA
    assert null.cannot_name(obs, nulls, n_final, among={"b", "c"})
    assert null.final_p_bound(obs, nulls, n_final, among=set()) == 1.0


def test_a_held_out_stance_of_an_unseen_trial_re_estimates_its_trial_s_variables():
    """A trial-scope variable (a clock offset) of a held-out stance whose trial has no stance in
    the fold's training is re-estimated with the stance's nuisance, as a refit of the frozen
    model does (it estimates what it was not given): checked against a direct least-squares
    solution on a random linear model; a stance whose trial the training has keeps the trained
    value. ``charge``: the Occam part of such a column, ``1/2 log det`` of the held-out
    Hessian in prior-sigma units with it minus without it, is added, on those stances only."""
    rng = np.random.default_rng(5)
    trials = ("a", "a", "b", "c")
    n_st, T6, n_shared, n_z = len(trials), 30, 3, 2
    t_col = {t: n_shared + k for k, t in enumerate(dict.fromkeys(trials))}
    first_z = n_shared + len(t_col)
    nx = first_z + n_st * n_z
    rows = tuple(slice(k * T6, (k + 1) * T6) for k in range(n_st))
    nuis = tuple(np.arange(first_z + k * n_z, first_z + (k + 1) * n_z) for k in range(n_st))
    J = np.zeros((n_st * T6, nx))
    for k, t in enumerate(trials):
        J[rows[k], :n_shared] = rng.normal(size=(T6, n_shared))
        J[rows[k], t_col[t]] = rng.normal(size=T6)
        J[rows[k], nuis[k]] = rng.normal(size=(T6, n_z))
    lin, P, pos = _linear_with_priors(
        rng, J, rows, nuis, trials=trials, trial_cols=tuple(np.array([t_col[t]]) for t in trials)
    )
    R0 = rng.normal(size=(n_st * T6, 2))
    plan = [(0,), (2,), (3,)]
    E = onestep.heldout_energy(lin, R0, plan)
    charged = onestep.heldout_energy(lin, R0, plan, charge=np.array(list(t_col.values())))
    for j, (i,) in enumerate(plan):
        keep = np.concatenate(
            [np.arange(rows[k].start, rows[k].stop) for k in range(n_st) if k != i]
        )
        unseen = trials[i] not in {t for k, t in enumerate(trials) if k != i}
        assert unseen == (i != 0)
        z = np.r_[nuis[i], [t_col[trials[i]]]] if unseen else nuis[i]
        kz = [pos[c] for c in z]
        Jz = J[rows[i]][:, z]
        Hs = (Jz.T @ Jz + np.diag(lin.pw[kz] ** 2)) / np.outer(lin.pw[kz], lin.pw[kz])
        occam_part = 0.5 * (np.linalg.slogdet(Hs)[1] - np.linalg.slogdet(Hs[:-1, :-1])[1])
        for b in range(R0.shape[1]):
            want = _direct_heldout(lin, P, pos, keep, i, z, R0[:, b])
            assert E[j, b] == pytest.approx(want, rel=1e-9)
            extra = occam_part if unseen else 0.0
            assert charged[j, b] == pytest.approx(want + extra, rel=1e-9)


def test_occam_terms_of_the_wrong_size_are_refused():
    """Occam terms come one per held-out stance or one for all; any other size would broadcast
    the energies away (the folds' empty terms in a diagnosis without folds once made every
    statistic 100 %), so ``energies`` refuses it."""
    rng = np.random.default_rng(5)
    n_st, T6, n_shared, n_z = 2, 30, 3, 2
    nx = n_shared + n_st * n_z
    rows = tuple(slice(k * T6, (k + 1) * T6) for k in range(n_st))
    nuis = tuple(np.arange(n_shared + k * n_z, n_shared + (k + 1) * n_z) for k in range(n_st))
    J = rng.normal(size=(n_st * T6, nx))
    lin, _, _ = _linear_with_priors(rng, J, rows, nuis)
    U = rng.normal(size=(n_st * T6, 2))
    E = onestep.energies(lin, {}, U, [], {"parent": np.array([1.5])})
    assert E["parent"].shape == (1, 2)
    with pytest.raises(ValueError, match="0 Occam terms for 1 held-out energies"):
        onestep.energies(lin, {}, U, [], {"parent": np.zeros(0)})
    with pytest.raises(ValueError, match="3 Occam terms for 2 held-out energies"):
        onestep.energies(lin, {}, U, [(0,), (1,)], {"parent": np.zeros(3)})


def test_the_p_value_counts_draws_so_a_mismatch_dominated_null_keeps_its_rate():
    """A draw's replicates share its mismatch shift, so the observed statistic (itself a draw
    plus its own noise, under the null) is exchangeable with a draw, not with each replicate.
    Counted per replicate, a null the mismatch dominates names a candidate above the second
    largest of 32 draws: 2 / 33 = 6.1 % of the time. Counted per draw the rate holds. 4000
    rounds: the rate's binomial SD at 5 % is 0.34 %; the limit 5.7 % is two of them above."""
    rng = np.random.default_rng(11)
    K, W, rounds = null.MISMATCH_DRAWS, 16, 4000
    draws = np.repeat(np.arange(K), W)
    named = named_per_replicate = 0
    for _ in range(rounds):
        shift = rng.normal(size=K + 1)
        noise = 0.1 * rng.normal(size=(K + 1, W))
        nulls = {"a": (shift[:K, None] + noise[:K]).ravel()}
        obs = {"a": float(shift[K] + noise[K, 0])}
        t = null.decide(obs, nulls, {}, 6, draws=draws)["a"]
        named += t.p_adjusted < null.ALPHA
        per_rep = (1 + np.sum(nulls["a"] >= obs["a"])) / (K * W + 1)  # the former count
        named_per_replicate += per_rep < null.ALPHA
    assert named / rounds <= 0.057
    assert named_per_replicate / rounds > 0.057  # the former count breaks it: the check can fail


def test_the_critical_value_is_the_p_value_rule_s_threshold():
    """``z_critical`` (what the steps are computed with) is where the rule's p-value crosses
    alpha: a statistic above it is named, one at or below it is not, with draws of unequal
    replicates too; fewer draws than can reach alpha give none."""
    rng = np.random.default_rng(5)
    sizes = rng.integers(10, 20, size=32)
    draws = np.repeat(np.arange(32), sizes)
    nulls = {"a": rng.normal(size=draws.size) + np.repeat(rng.normal(size=32), sizes)}
    base = null.decide({"a": 0.0}, nulls, {}, 6, draws=draws)["a"]
    crit, m, s = base.z_critical, base.null_mean_pct, base.null_sd_pct
    for dz in (-1e-6, 1e-6):
        t = null.decide({"a": m + (crit + dz) * s}, nulls, {}, 6, draws=draws)["a"]
        assert (t.p_adjusted < null.ALPHA) == (dz > 0)
    # a null of 8 draws names nothing (p >= 1/9), but its critical value, and so its steps,
    # are the default null's (32 draws): what a rerun with more stances would face
    few = np.repeat(np.arange(8), 16)
    t = null.decide({"a": 100.0}, {"a": rng.normal(size=128)}, {}, 6, draws=few)["a"]
    assert t.p_adjusted == pytest.approx(1 / 9) and t.z_critical is not None
    assert t.more_stances is not None


def test_a_replicate_that_is_not_finite_names_no_candidate():
    """One NaN replicate (a fit that failed inside a draw) made every candidate's largest
    studentised reduction NaN, and every comparison with it false: every candidate named at
    the smallest p-value. It is left out instead, for every candidate."""
    rng = np.random.default_rng(2)
    nulls = {"a": rng.normal(size=512), "b": rng.normal(size=512)}
    clean = null.decide({"a": 0.5, "b": 0.3}, nulls, {}, 6)
    nulls["b"][7] = np.nan
    t = null.decide({"a": 0.5, "b": 0.3}, nulls, {}, 6)
    assert all(x.p_adjusted > 0.2 for x in t.values())
    assert t["a"].p_adjusted == pytest.approx(clean["a"].p_adjusted, abs=0.01)
    assert null.final_p_bound({"a": 0.5, "b": 0.3}, nulls, 512) > 0.2


def test_steps_are_found_however_many_are_needed_below_the_cap():
    """A gain that needs about 350 000 stances gets that number, not "no number decides": a
    gain of 0.0034 over the null's mean with a null SD of 1 and a critical value of 2 (one
    held-out stance; its own SE 1e-6, so the noise's threshold 2 sqrt(1 / n) decides alone:
    n about (2 / 0.0034)^2)."""
    n = null.more_stances(1.0, 0.0, 1.0, None, 1, 2.0, False, 0.0)
    need = [2.0 * math.sqrt(1 / k) + null.power_shift(1.0, 1 / k) for k in (n, n + 1)]
    assert need[0] > 1.0 >= need[1]  # the smallest k = 1 + n that decides
    big = null.more_stances(0.0034, 0.0, 1.0, 1e-6, 1, 2.0, False, 0.0)
    assert big is not None and 3e5 < big < null.MAX_STANCES


def test_the_held_out_bootstrap_draws_every_frame_equally_often():
    """Blocks that stop at a stance's ends drew its first and last frames (heel strike and
    toe-off, where damping and the clock offset act) half as often as mid-stance, shifting the
    interval of an effect of the edges down; circular blocks draw each frame equally often."""
    from gc_ocp.diagnosis.compare import circular_blocks

    rng = np.random.default_rng(0)
    n, L, B = 72, 10, 4000
    counts = np.zeros(n)
    for _ in range(B):
        np.add.at(counts, circular_blocks(n, L, rng), 1.0)
    # each frame is drawn once per draw on average (the blocks covering it: binomial, 8 blocks
    # of 10 / 72 each, variance ~0.96), so its mean count over 4000 draws has an SD of 1.5 %:
    # 10 % is over six of them (the ends' former 0.47 fails it)
    np.testing.assert_allclose(counts / B, 1.0, rtol=0.1)
    assert circular_blocks(5, 10, rng).size == 5  # a block longer than the stance: one block


def test_the_in_sample_fallback_predicts_no_steps():
    """With no stance held out (every foot has one stance) the test weighs the in-sample fit's
    one step: there is no held-out stance to count the steps from, and one stance more on a
    foot makes the diagnosis a held-out one, whose statistic these scores do not predict. The
    row records 0 held-out stances and no number (it recorded 1 held-out stance, which did not
    exist, and the steps that one would need)."""
    rng = np.random.default_rng(4)
    draws = np.repeat(np.arange(32), 16)
    nulls = {e: 0.2 + 0.3 * rng.normal(size=draws.size) for e in "ab"}
    observed = ({"a": 0.2 + 1.5 * 0.3, "b": 0.0}, {"a": None, "b": None})
    kw = {"null": nulls, "observed": observed, "draws": draws, "n_final": 32}
    held = null.calibrate(None, [], dict.fromkeys("ab"), [(0,)], **kw)["a"]
    assert held.n_heldout == 1 and held.p_adjusted >= null.ALPHA and held.more_stances > 0
    fallback = null.calibrate(None, [], dict.fromkeys("ab"), [], **kw)["a"]
    assert fallback.p_adjusted == held.p_adjusted  # the test itself is unchanged
    assert fallback.n_heldout == 0 and fallback.more_stances is None


def test_a_null_without_a_spread_predicts_no_steps():
    """A null of one replicate (the refit null with one draw) has no spread: its SD, its
    studentised statistics and its critical value are not numbers, and every comparison with
    them false. The steps came out as the search's first value, "about 1 more step would
    decide", for every candidate above the null; no number is given instead."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the SD of one value
        tests = null.decide(
            {"a": 2.0, "b": 0.5},
            {"a": np.array([0.3]), "b": np.array([0.1])},
            {"a": 0.5, "b": 0.4},
            4,
            draws=np.array([0]),
            n_final=1,
        )
    assert all(t.more_stances is None for t in tests.values())
    assert null.more_stances(2.0, 0.3, np.nan, 0.5, 4, np.nan, False) is None
    assert null.more_stances(2.0, 0.3, 0.5, np.nan, 4, 2.4, False) is None
