"""The mismatch family (``gc_ocp.diagnosis.mismatch``): small truth-model differences that are
not candidate effects, and their use by the withheld-effect benchmark (``Realism.mismatch``).

* scale 0 is the model exactly; draws are reproducible, paired across scales, JSON round trip;
* the second law forms have the first's limits and another shape; the form is part of the
  law's cache key and reaches the Stribeck friction;
* every kind of mismatch changes the bundled truth's wrench, within a bound that follows from
  its definition (the law variants also against a plain NumPy reference of the law);
* the benchmark without a mismatch is bit for bit what it was (``withheld_reference``), with
  one its cases are paired with those without and record their draw.

The sizes of every member against the candidate effects' injections are measured by
``benchmarks/mismatch_sizes.py`` (``docs/diagnosis.md``, "Mismatch family")."""

from __future__ import annotations

import dataclasses
import json
import warnings
from pathlib import Path
from types import SimpleNamespace

import casadi as ca
import numpy as np
import pytest

from gc_ocp.bench import truth as bench_truth
from gc_ocp.bench import withheld
from gc_ocp.bench.recovery import bundled_base_truth
from gc_ocp.contact.laws import (
    DEFAULT_SMOOTHING,
    friction_force_function,
    normal_force_function,
    slip_direction,
    smooth_penetration,
)
from gc_ocp.diagnosis import mismatch as mm
from gc_ocp.errors import InputError, ModelError
from gc_ocp.estimation.components import (
    ContactLaw,
    StribeckFriction,
    bare_seed_model,
    base_model,
)
from gc_ocp.estimation.problem import build_estimation
from gc_ocp.estimation.starts import estimate, with_lls_start
from gc_ocp.estimation.synthetic import default_truth, simulate, synthetic_stance

import withheld_reference as reference  # isort: skip (a test helper beside this file)

EPS_D = DEFAULT_SMOOTHING.eps_damping
D_S = 0.5 * (1 + np.sqrt(1 + EPS_D**2))  # the smooth damping clamp at c = 0 (laws module doc)


@pytest.fixture(scope="module")
def bundled():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return bundled_base_truth()


def _clean(stances, truth):
    """The truth's plate data on ``stances`` without plate noise."""
    return simulate(stances, truth, np.random.default_rng(0), plate_noise_pct_bw=0.0)


def _rms_pct_bw(a, b) -> float:
    """RMS [% BW] of the force change between two stance lists (3 channels, all frames)."""
    d = np.concatenate([x.measured[:, :3] - y.measured[:, :3] for x, y in zip(a, b, strict=True)])
    return float(np.sqrt(np.mean(d**2)) / a[0].body_weight * 100)


ZERO = mm.MismatchFamily(scale=0.0).draw(np.random.default_rng(0))


def _only(**members) -> mm.MismatchDraw:
    """A draw with only ``members`` different from the model."""
    return dataclasses.replace(ZERO, **members)


# --- the family and its draws -------------------------------------------------------------------


def test_scale_zero_reproduces_the_model(bundled):
    """A draw at scale 0 changes nothing: the truth variant is the truth, the true and the seen
    motion are the stances, and the simulated data are the plain simulation's, bit for bit (the
    same random plate noise: the zero members draw nothing)."""
    stances, truth = bundled
    zero = mm.MismatchFamily(scale=0.0).draw(np.random.default_rng(3))
    assert (zero.depth_factor, zero.slip_factor, zero.depth_form, zero.slip_form) == (
        1,
        1,
        None,
        None,
    )
    assert (zero.threshold_n, zero.hum_amplitude_n, zero.cutoff_hz, zero.marker_noise) == (
        0,
        0,
        None,
        0,
    )
    assert mm.truth_variant(truth, zero) == truth
    assert all(a is b for a, b in zip(mm.true_motion(stances, zero), stances, strict=True))
    rng = np.random.default_rng(9)
    got = mm.simulate_mismatched(stances, truth, zero, rng)
    want = simulate(stances, truth, np.random.default_rng(9))
    for g, w in zip(got, want, strict=True):
        assert np.array_equal(g.measured, w.measured)
        assert np.array_equal(g.plate_wrench, w.plate_wrench)
        assert g.foot is w.foot or np.array_equal(g.foot.positions, w.foot.positions)
    # the comparison can fail: a draw at scale 1 changes the wrench
    one = mm.MismatchFamily().draw(np.random.default_rng(3))
    other = mm.simulate_mismatched(stances, truth, one, np.random.default_rng(9))
    assert _rms_pct_bw(other, want) > 0.1


def test_draws_are_reproducible_paired_across_scales_and_round_trip_json():
    fam = mm.MismatchFamily()
    a, b = fam.draw(np.random.default_rng(4)), fam.draw(np.random.default_rng(4))
    assert a == b
    assert a != fam.draw(np.random.default_rng(5))
    back = mm.MismatchDraw.from_json(json.loads(json.dumps(a.to_json())))
    assert back == a
    # the same random numbers at another scale: sizes shrink linearly, factors as a power,
    # the cutoff grows as 1/scale; the form is the same or the model's
    h = dataclasses.replace(fam, scale=0.5).draw(np.random.default_rng(4))
    assert h.depth_factor == pytest.approx(a.depth_factor**0.5, rel=1e-12)
    assert h.slip_factor == pytest.approx(a.slip_factor**0.5, rel=1e-12)
    assert h.cutoff_hz == pytest.approx(2 * a.cutoff_hz, rel=1e-12)
    assert h.hum_amplitude_n == pytest.approx(0.5 * a.hum_amplitude_n, rel=1e-12)
    assert h.threshold_n == pytest.approx(0.5 * a.threshold_n, rel=1e-12)
    for side in a.unit_offsets:
        np.testing.assert_allclose(
            np.array(h.unit_offsets[side]), 0.5 * np.array(a.unit_offsets[side]), rtol=1e-12
        )
    assert h.depth_form in (None, a.depth_form) and h.slip_form in (None, a.slip_form)
    # the documented ranges hold over many draws (scale 1)
    draws = [fam.draw(np.random.default_rng(s)) for s in range(200)]
    assert all(0.5 <= d.depth_factor <= 2.0 and 0.5 <= d.slip_factor <= 2.0 for d in draws)
    assert all(4.0 <= d.cutoff_hz <= 10.0 for d in draws)
    assert all(d.threshold_n == 0.0 or 5.0 <= d.threshold_n <= 40.0 for d in draws)
    assert {d.hum_frequency_hz for d in draws} == {50.0, 60.0}
    assert {d.depth_form for d in draws} == {None, "softplus"}
    assert {d.slip_form for d in draws} == {None, "tanh"}
    # iid N(0, 2 mm): the pooled SD of 200 draws x 2 sides x 5 units x 3 axes (6000 values) is
    # within 4 % of it (4 standard errors of an SD estimate, 1 / sqrt(2 n) = 0.9 %)
    off = np.array([d.unit_offsets[s] for d in draws for s in d.unit_offsets])
    assert np.std(off) == pytest.approx(2e-3, rel=0.04)


def test_family_rejects_what_is_not_a_family():
    with pytest.raises(InputError, match="scale must be >= 0"):
        mm.MismatchFamily(scale=-1)
    with pytest.raises(InputError, match="cutoff_hz must be a range"):
        mm.MismatchFamily(cutoff_hz=(10.0, 4.0))
    with pytest.raises(InputError, match="choose from|other forms"):
        mm.MismatchFamily(depth_forms=("hyperbola",))  # the model's own form is no mismatch
    with pytest.raises(InputError, match="probability"):
        mm.MismatchFamily(p_threshold=1.5)


def test_for_model_leaves_out_what_is_a_candidate_of_the_fitter():
    """Against the bare seed base, units off the layout are ``sole_geometry`` and kinematic
    errors are ``kinematic_correction``: both are left out; the registered base keeps them."""
    d = mm.MismatchFamily().draw(np.random.default_rng(1))
    assert d.for_model(base_model()) == d
    s = d.for_model(bare_seed_model())
    assert s.off == ("kinematics", "unit_offsets")
    assert s.cutoff_hz is None and s.marker_noise == 0.0 and s.drift_translation == 0.0
    assert not np.any([s.unit_offsets[side] for side in s.unit_offsets])
    assert (s.depth_factor, s.slip_factor, s.hum_amplitude_n) == (
        d.depth_factor,
        d.slip_factor,
        d.hum_amplitude_n,
    )
    assert mm.MismatchDraw.from_json(json.loads(json.dumps(s.to_json()))) == s


# --- the second law forms --------------------------------------------------------------------


def test_the_second_penetration_form_has_the_same_limits_and_another_shape():
    k, eps = 3.0e4, 5e-4  # N/m, m (the law's default width)
    hyp, soft = normal_force_function(True), normal_force_function(True, "softplus")

    def force(fn, x):
        return float(fn(x, 0.0, k, 1.0, 0.0, eps, EPS_D))

    # the default is the documented hyperbola, unchanged
    for x in (-2e-3, 0.0, 3e-4, 5e-3):
        assert force(hyp, x) == pytest.approx(k * 0.5 * (x + np.hypot(x, eps)) * D_S, rel=1e-14)
    # large penetration: both k x; the hyperbola's excess is eps^2 / (4 x) (relative
    # eps^2 / (4 x^2) = 6e-4 at 10 mm), the softplus's w exp(-x / w) (1e-12 here)
    x = 0.01
    assert force(soft, x) == pytest.approx(k * x * D_S, rel=1e-11)
    assert force(hyp, x) == pytest.approx(k * x * D_S, rel=1.01 * eps**2 / (4 * x**2))
    # at contact: the same value k eps / 2 (the width is defined so)
    assert force(soft, 0.0) == pytest.approx(force(hyp, 0.0), rel=1e-14)
    assert force(hyp, 0.0) == pytest.approx(k * eps / 2 * D_S, rel=1e-14)
    # in the air (5 mm): ~0, both under the hyperbola's algebraic tail k eps^2 / (4 |x|)
    x = -5e-3
    assert 0.0 < force(soft, x) < 1e-3 * force(hyp, x)
    assert force(hyp, x) <= k * eps**2 / (4 * abs(x)) * D_S * (1 + 1e-12)
    # another shape in between: at x = eps they differ by 3.8 % (1.207 eps against 1.161 eps)
    assert force(soft, eps) / force(hyp, eps) == pytest.approx(1.1609 / 1.2071, rel=1e-3)
    # the slope at contact is 1/2 in both (a finite difference: step 1e-9 m, error ~ step x
    # curvature ~ 1e-6)
    h = 1e-9
    for fn in (hyp, soft):
        slope = (force(fn, h) - force(fn, -h)) / (2 * h) / (k * D_S)
        assert slope == pytest.approx(0.5, abs=1e-5)
    with pytest.raises(InputError, match="softplus"):
        normal_force_function(True, "cubic")


def test_the_second_friction_form_has_the_same_limits_and_another_shape():
    fn_n, v_eps = 100.0, 0.05  # N, m/s
    alg, tanh = friction_force_function(), friction_force_function("tanh")

    def fx(fn, v):
        return float(fn(fn_n, [v, 0.0, 0.0], [0.0, 0.0, 0.0], 1.0, v_eps)[0])

    # zero sliding: the same slope -mu F_n / v_eps (next terms relative (v / v_eps)^2 = 4e-10,
    # the tanh form's speed floor 1e-6 / 3)
    v = 1e-6
    for fn in (alg, tanh):
        assert fx(fn, v) == pytest.approx(-fn_n * v / v_eps, rel=1e-6)
    # fast sliding (100 v_eps): both -mu F_n (the algebraic form within 1 / (2 100^2) = 5e-5)
    # (the tanh form within its speed floor's (1e-3 v_eps)^2 / (2 v^2) = 5e-11)
    assert fx(tanh, 100 * v_eps) == pytest.approx(-fn_n, rel=1e-10)
    assert fx(alg, 100 * v_eps) == pytest.approx(-fn_n, rel=5.1e-5)
    # another shape: at v_eps tanh(1) = 0.762 against 1 / sqrt(2) = 0.707
    assert fx(tanh, v_eps) == pytest.approx(-fn_n * np.tanh(1.0), rel=1e-6)
    assert fx(alg, v_eps) == pytest.approx(-fn_n / np.sqrt(2), rel=1e-12)
    # smooth through zero sliding: the Jacobian at v = 0 is finite, the slope above
    vs = ca.SX.sym("vs", 2)
    jac = ca.Function("j", [vs], [ca.jacobian(slip_direction(vs, v_eps, "tanh"), vs)])
    np.testing.assert_allclose(np.asarray(jac([0.0, 0.0])), np.eye(2) / v_eps, rtol=1e-6)


def test_the_law_s_form_is_in_its_cache_key_and_reaches_the_stribeck_friction():
    st = synthetic_stance("right", default_truth())
    law = ContactLaw.seed(mu=0.6).with_law_fixed("k", 3.0e5)  # N/m, the synthetic foot's scale
    assert law.signature()[-2:] == ("hyperbola", "algebraic")  # the default, unchanged
    var = law.with_law_smoothing(2.0, 0.5, "softplus", "tanh")
    assert var.depth_smoothing == 2 * law.depth_smoothing
    assert var.slip_smoothing == 0.5 * law.slip_smoothing
    assert var.signature() != law.signature()
    fm = build_estimation([st], (law,), compile=False).blocks[0].fm
    fm_var = build_estimation([st], (var,), compile=False).blocks[0].fm
    assert fm is not fm_var  # another per-frame function, cached per form
    assert build_estimation([st], (var,), compile=False).blocks[0].fm is fm_var
    with pytest.raises(ModelError, match="tanh"):
        ContactLaw(slip_form="coulomb")
    # the Stribeck friction at its neutral value regularises as the law does
    tanh_law = dataclasses.replace(law, slip_form="tanh")
    neutral = StribeckFriction(fixed={"static_excess": 0.0, "viscous": 0.0})
    w = _clean([st], (tanh_law,))[0].measured
    np.testing.assert_allclose(_clean([st], (tanh_law, neutral))[0].measured, w, atol=1e-9)
    assert np.abs(_clean([st], (law, neutral))[0].measured - w).max() > 1.0  # [N]


# --- every kind changes the bundled truth's wrench, within its bound ---------------------


def _reference_forces(st, law, sole, depth_eps, depth_form, slip_eps, slip_form):
    """Plain NumPy reference of the truth's unit forces ``(T, m, 3)`` (n = 1, c = 0, Coulomb
    friction), and the units' penetrations ``(T, m)``."""
    pts = st.foot.points_local + np.asarray(sole.fixed[st.side])
    pos, vel = st.foot.unit_trajectories(pts)
    x = st.ground_height - pos[..., 2]
    if depth_form == "softplus":
        w = depth_eps / (2 * np.log(2))
        xs = np.maximum(x, 0) + w * np.log1p(np.exp(-np.abs(x) / w))
    else:
        xs = 0.5 * (x + np.sqrt(x**2 + depth_eps**2))
    k = np.array([law.k.value[st.side][u] for u in st.layout.units])
    fn = k * xs * D_S
    vs = vel[..., :2] - st.belt_velocity[:2]
    if slip_form == "tanh":
        s = np.sqrt(np.sum(vs**2, -1) + (1e-3 * slip_eps) ** 2)
        direction = vs * (np.tanh(s / slip_eps) / s)[..., None]
    else:
        direction = vs / np.sqrt(np.sum(vs**2, -1) + slip_eps**2)[..., None]
    ft = -law.mu.value * fn[..., None] * direction
    return np.concatenate([ft, fn[..., None]], axis=-1), x


@pytest.mark.parametrize(
    "members",
    [
        {"depth_factor": 2.0},
        {"depth_factor": 0.5, "depth_form": "softplus"},
        {"slip_factor": 2.0},
        {"slip_factor": 0.5, "slip_form": "tanh"},
    ],
)
def test_law_variants_are_the_documented_law_and_change_the_wrench_within_their_bound(
    bundled, members
):
    """The truth variant's forces equal a NumPy reference of the law with the drawn width and
    form (1e-9 relative: round-off of sums of ~1e3 N), and the change of the wrench is above the
    visible (0.01 % BW, a twentieth of a 64 kg subject's 1 N plate resolution) and below the
    bound the law gives: both smoothed penetrations lie in [max(x, 0), max(x, 0) + x_s(0)], so
    a unit's normal force moves by at most k x_s-excess and its friction by mu times that; a
    friction form moves the shear by at most mu F_n max|direction change|."""
    stances, truth = bundled
    law, sole = truth[0], truth[1]
    assert (law.n.value, law.c.value) == (1.0, 0.0)  # the reference's law
    draw = _only(**members)
    base = _clean(stances, truth)
    var = _clean(stances, mm.truth_variant(truth, draw))
    eps0, v0 = law.depth_smoothing, law.slip_smoothing
    eps1, v1 = eps0 * draw.depth_factor, v0 * draw.slip_factor
    form_d, form_s = draw.depth_form or "hyperbola", draw.slip_form or "algebraic"
    mu = law.mu.value
    bounds = []
    for st, b, v in zip(stances, base, var, strict=True):
        f1, x = _reference_forces(st, law, sole, eps1, form_d, v1, form_s)
        np.testing.assert_allclose(v.measured[:, :3], f1.sum(axis=1), rtol=1e-9, atol=1e-9)
        f0, _ = _reference_forces(st, law, sole, eps0, "hyperbola", v0, "algebraic")
        np.testing.assert_allclose(b.measured[:, :3], f0.sum(axis=1), rtol=1e-9, atol=1e-9)
        k = np.array([law.k.value[st.side][u] for u in st.layout.units])
        m = np.maximum(x, 0)
        if "depth_factor" in members:
            excess = [
                np.abs(np.asarray(smooth_penetration(ca.DM(x.ravel()), e, f)).reshape(x.shape) - m)
                for e, f in ((eps0, "hyperbola"), (eps1, form_d))
            ]
            bound = np.sqrt(1 + mu**2) * D_S * (k * np.maximum(*excess)).sum(axis=1)
        else:
            v = np.linspace(0.0, 50 * max(v0, v1), 20001)  # beyond 50 widths both ~ 1
            d0 = v / np.sqrt(v**2 + v0**2)
            s1 = np.sqrt(v**2 + (1e-3 * v1) ** 2)
            d1 = np.tanh(s1 / v1) * v / s1 if form_s == "tanh" else v / np.sqrt(v**2 + v1**2)
            delta = np.max(np.abs(d1 - d0))
            bound = mu * f0[..., 2].sum(axis=1) * (delta + 1e-3)  # + the grid's step
        bounds.append(bound)
    change = _rms_pct_bw(var, base)
    bw = stances[0].body_weight
    limit = float(np.sqrt(np.mean(np.concatenate(bounds) ** 2) / 3) / bw * 100)
    print(members, f"change {change:.3f} % BW, bound {limit:.3f} % BW")
    assert 0.01 < change <= limit


def test_units_off_the_layout_change_the_wrench_and_the_base_registers_them(bundled):
    """Units moved by the drawn offsets change the truth's wrench by several % BW (a 2 mm
    vertical move is a large part of a unit's 2-6 mm penetration), and a refit of the registered
    base, whose sole correction (prior 5 mm) models exactly such offsets, takes them back: its
    in-sample force RMS is within 25 % of its fit to the unmoved truth's data (a non-convex fit,
    and a prior that pulls the 30 offsets towards 0 by ~(2 / 5)^2 of their cost)."""
    stances, truth = bundled
    draw = _only(unit_offsets=mm.MismatchFamily().draw(np.random.default_rng(2)).unit_offsets)
    base = _clean(stances, truth)
    moved = _clean(mm.true_motion(stances, draw), truth)
    for m_, st in zip(moved, stances, strict=True):
        assert not np.array_equal(m_.foot.points_local, st.foot.points_local)
    assert _rms_pct_bw(moved, base) > 2.0
    data = [d.with_foot(s.foot) for d, s in zip(moved, stances, strict=True)]  # nominal layout

    def force_rms(sts):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = estimate(sts, with_lls_start(base_model(), sts), covariance=False)
        d = np.concatenate([f["model"][:, :3] - f["measured"][:, :3] for f in r.stance_fits])
        return float(np.sqrt(np.mean(d**2)))

    assert force_rms(data) == pytest.approx(force_rms(base), rel=0.25)


def test_plate_hum_and_threshold_are_what_they_say(bundled):
    stances, truth = bundled
    base = _clean(stances, truth)
    amp, f = 3.0, 50.0  # N, Hz
    hummed = mm.plate_processing(
        base, _only(hum_amplitude_n=amp, hum_frequency_hz=f), np.random.default_rng(0)
    )
    for h, b in zip(hummed, base, strict=True):
        d = h.plate_wrench - b.plate_wrench
        # a sinusoid: RMS amp / sqrt(2) up to the window's partial cycle, whose share of the
        # mean square is at most 1 / (4 pi f L) for a window of L seconds
        L = b.plate_time[-1] - b.plate_time[0]
        ms = np.mean(d[:, :3] ** 2, axis=0)
        np.testing.assert_allclose(ms, amp**2 / 2, atol=amp**2 / (4 * np.pi * f * L))
        am = amp * 0.02  # the moments' hum: amp x 20 mm
        np.testing.assert_allclose(
            np.mean(d[:, 3:] ** 2, axis=0), am**2 / 2, atol=am**2 / (4 * np.pi * f * L)
        )
        # the frames read the same sinusoid at their times (aliased at 100 Hz)
        dm = h.measured - b.measured
        t_in = np.isin(b.plate_time, b.time)
        if t_in.any():
            idx = np.searchsorted(b.time, b.plate_time[t_in])
            np.testing.assert_allclose(dm[idx], d[t_in], atol=1e-9)
    cut = mm.plate_processing(base, _only(threshold_n=40.0), np.random.default_rng(0))
    for c, b in zip(cut, base, strict=True):
        low = b.measured[:, 2] < 40.0
        assert low.any() and np.all(c.measured[low] == 0.0)
        assert np.array_equal(c.measured[~low], b.measured[~low])
        lowp = b.plate_wrench[:, 2] < 40.0
        assert np.all(c.plate_wrench[lowp] == 0.0)
    # the change: only the frames under 40 N, whose force is under 40 N (1 + mu) in norm
    bw = stances[0].body_weight
    assert 0.0 < _rms_pct_bw(cut, base) < 40.0 * 1.3 / bw * 100


def test_plate_calibration_is_what_it_says_and_off_by_default(bundled):
    """The opt-in plate calibration member: each stance's plate 2-5 mm off horizontally (its
    COP moved by that vector) and its channels within +-2 % of the truth, the same error on the
    frames and the plate's own samples; off (the default), the family's draws and every other
    member's random numbers are what they were."""
    stances, truth = bundled
    base = _clean(stances, truth)
    on = mm.MismatchFamily().with_plate_calibration()
    assert (on.plate_offset, on.plate_gain) == ((2e-3, 5e-3), 0.02)  # the documented sizes
    assert mm.MismatchFamily.from_json(json.loads(json.dumps(on.to_json()))) == on
    draw = on.draw(np.random.default_rng(3))
    assert draw.plate_seed != 0 and draw.plate_offset == (2e-3, 5e-3)
    assert mm.MismatchDraw.from_json(json.loads(json.dumps(draw.to_json()))) == draw
    got = mm.plate_processing(base, _only(**{k: getattr(draw, k) for k in PLATE}), None)
    for g, b in zip(got, base, strict=True):
        for w_g, w_b in ((g.measured, b.measured), (g.plate_wrench, b.plate_wrench)):
            loaded = w_b[:, 2] > 0.2 * b.body_weight
            ratio = w_g[loaded, :3] / w_b[loaded, :3]
            # one gain per channel, within +-2 % (a channel near 0 has no readable ratio)
            big = np.abs(w_b[loaded, :3]) > 1.0
            for j in range(3):
                r = ratio[big[:, j], j]
                assert np.ptp(r) < 1e-9 and abs(r[0] - 1) <= 0.02
            # the COP (moment about the reference point over the vertical force) moves by the
            # plate's horizontal offset, 2-5 mm, after the gains' own share
            cop = lambda w: np.stack([-w[:, 4] / w[:, 2], w[:, 3] / w[:, 2]], 1)  # noqa: E731
            shift = np.median(cop(w_g[loaded]) - cop(w_b[loaded]), axis=0)
            assert 1e-3 < np.linalg.norm(shift) < 6e-3
    # off by default: no seed drawn, the same numbers as a family without the member
    off = mm.MismatchFamily()
    assert not off.plate_calibration
    a, b = off.draw(np.random.default_rng(3)), draw
    assert a.plate_seed == 0 and a.plate_gain == 0.0
    assert dataclasses.replace(b, plate_offset=(0.0, 0.0), plate_gain=0.0, plate_seed=0) == a
    # paired: a stream of draws, as the null makes them, keeps every other member with it on
    # (the member's seed from a child generator; before, it took one number of the stream and
    # redrew 30-31 of 32 draws' other members)
    strip = dict(plate_offset=(0.0, 0.0), plate_gain=0.0, plate_seed=0)
    on = off.with_plate_calibration()
    r_off, r_on = np.random.default_rng(7), np.random.default_rng(7)
    for _ in range(8):
        d_on = on.draw(r_on)
        assert d_on.plate_seed > 0
        assert dataclasses.replace(d_on, **strip) == off.draw(r_off)
    assert r_on.uniform() == r_off.uniform()
    same = mm.plate_processing(base, _only(), np.random.default_rng(0))  # every member off
    assert all(np.array_equal(x.measured, y.measured) for x, y in zip(same, base, strict=True))
    with pytest.raises(InputError, match="plate_gain"):
        mm.MismatchFamily(plate_gain=1.5)


PLATE = ("plate_offset", "plate_gain", "plate_seed")


def test_a_run_made_before_the_plate_member_can_be_resumed():
    """A benchmark's settings keep the plate calibration member only when it is on, so a run
    made before it existed (this one: the leak-free strong effects of 2026-11-30, the family at
    scale 1) reads the same settings and ``--resume`` goes on (``settings_differ`` is empty)."""
    stored = Path(__file__).resolve().parents[1] / (
        "benchmarks/withheld_mismatch/bundled_2_leakfree_strong/confusion.json"
    )
    old = json.loads(stored.read_text())["settings"]["realism"]
    realism = dataclasses.replace(bench_truth.DEFAULT_REALISM, mismatch=mm.MismatchFamily())
    assert (
        withheld.settings_differ(
            {"realism": old}, {"realism": json.loads(json.dumps(realism.settings()))}
        )
        == []
    )
    on = dataclasses.replace(realism, mismatch=mm.MismatchFamily(plate_gain=0.02))
    assert on.settings()["mismatch"]["plate_gain"] == 0.02


def test_the_seen_low_pass_keeps_slow_motion_and_removes_fast_motion():
    """A reference: a foot translating slowly (0.5 Hz, 50 mm) with a 20 Hz, 1 mm wobble, seen
    at 6 Hz. In the interior (a fifth of the window from each end) the wobble falls to the
    4th-order Butterworth gain 1 / (1 + (20 / 6)^4) = 0.80 % (8.0 um) and the slow motion loses
    1 - 1 / (1 + (0.5 / 6)^4) of itself (2.4 um): 10.4 um, allowed 15 um for the end transient
    decaying into the interior. The ends keep their values (the odd extension)."""
    st = synthetic_stance("right", default_truth())
    foot = st.foot
    t = foot.time
    slow = 0.05 * np.sin(2 * np.pi * 0.5 * t)
    wobble = 1e-3 * np.sin(2 * np.pi * 20.0 * t)
    P = np.repeat(np.eye(4)[None], t.size, axis=0)
    P[:, 0, 3] = slow + wobble
    tw = np.zeros((t.size, 6))
    f = dataclasses.replace(foot, hindfoot_pose=P, toes_pose=P, hindfoot_twist=tw, toes_twist=tw)
    f = f.with_points(foot.points_local)
    seen = mm.lowpassed(f, 6.0)
    inner = slice(t.size // 5, -(t.size // 5))
    err = seen.hindfoot_pose[inner, 0, 3] - slow[inner]
    assert np.max(np.abs(err)) < 15e-6
    np.testing.assert_allclose(seen.hindfoot_pose[[0, -1], 0, 3], P[[0, -1], 0, 3], atol=1e-12)
    np.testing.assert_allclose(seen.hindfoot_pose[:, :3, :3], P[:, :3, :3], atol=1e-12)
    assert mm.lowpassed(f, 60.0) is f  # above Nyquist (50 Hz): nothing to do


def test_the_seen_kinematics_move_the_foot_by_millimetres(bundled):
    """Low-pass (4 Hz, the family's lowest), drift and noise (the family's largest) move the
    units the fitter sees by millimetres (median 0.1-10 mm: the size of skin-marker artefacts),
    the true motion is untouched, and members at zero draw nothing from the generator."""
    stances, _ = bundled
    for members in (
        {"cutoff_hz": 4.0},
        {"marker_noise": 1e-3, "drift_translation": 4e-3, "drift_rotation_deg": 1.0},
    ):
        rng = np.random.default_rng(0)
        seen = mm.seen_motion(stances, _only(**members), rng)
        for s, st in zip(seen, stances, strict=True):
            moved = np.linalg.norm(s.foot.positions - st.foot.positions, axis=2)
            assert 1e-4 < np.median(moved) < 1e-2, members
    rng = np.random.default_rng(0)
    state = rng.bit_generator.state
    mm.seen_motion(stances, _only(cutoff_hz=8.0), rng)
    mm.plate_processing(stances, ZERO, rng)
    assert rng.bit_generator.state == state


# --- the benchmark -------------------------------------------------------------------------


def _same_data(a, b) -> bool:
    return all(
        np.array_equal(x.measured, y.measured)
        and np.array_equal(x.plate_wrench, y.plate_wrench)
        and np.array_equal(x.foot.hindfoot_pose, y.foot.hindfoot_pose)
        and np.array_equal(x.foot.positions, y.foot.positions)
        for x, y in zip(a, b, strict=True)
    )


@pytest.mark.parametrize("base", ["registered", "seed"])
def test_the_benchmark_without_a_mismatch_is_what_it_was(base):
    """``generate`` without a mismatch: bit for bit the generator before the family (kept
    verbatim in ``withheld_reference``), the same draws from the generator; and a mismatch at
    scale 0 too (its draw comes from a child stream: the case's own draws are untouched)."""
    stances = bench_truth.motion(base)
    truth = bench_truth.truth_model(
        "damping", "moderate", bench_truth.base_truth(base), stances, np.random.default_rng(0)
    )
    _, model = withheld.resolve_base(base)
    kin = withheld.kinematic_error("damping", "moderate", model)
    realism = bench_truth.Realism()
    r1, r2, r3 = (np.random.default_rng(7) for _ in range(3))
    new = bench_truth.generate(stances, truth, r1, realism, kin, model)
    old = reference.generate(stances, truth, r2, realism, kin)
    assert _same_data(new, old)
    assert r1.bit_generator.state == r2.bit_generator.state
    zero = dataclasses.replace(realism, mismatch=mm.MismatchFamily(scale=0.0))
    paired, draw = bench_truth.generate_case(stances, truth, r3, zero, kin, model)
    assert _same_data(paired, old) and draw is not None
    assert r3.bit_generator.state == r2.bit_generator.state
    # the settings a run writes: as before, without a "mismatch" key
    assert "mismatch" not in realism.settings() and "mismatch" in zero.settings()


def test_a_case_with_a_mismatch_applies_and_records_its_draw(bundled, monkeypatch):
    """``run_case`` with ``Realism.mismatch``: the data differ from the case without, the draw
    is restricted to the base (its kinematic members are the realism's: no noise or drift of
    its own) and is in the case's row as JSON; a case without keeps its old keys."""
    fake = SimpleNamespace(
        selected=[],
        ranking=[],
        inconclusive=[],
        waterfall=[SimpleNamespace(heldout_superior_force_pct_bw=1.0)],
        seconds=0.0,
        calibration=[],
    )
    seen = {}

    def diagnose_stances(data, **kw):
        seen["data"] = data
        return fake

    monkeypatch.setattr(withheld, "diagnose_stances", diagnose_stances)
    case = {"truth": "none", "magnitude": "-", "seed": 0}
    realism = bench_truth.Realism(mismatch=mm.MismatchFamily())
    row = withheld.run_case(case, "registered", realism=realism)
    with_mismatch = seen["data"]
    plain = withheld.run_case(case, "registered")
    assert "mismatch" not in plain and set(row) == set(plain) | {"mismatch"}
    draw = mm.MismatchDraw.from_json(json.loads(json.dumps(row["mismatch"])))
    assert draw.marker_noise == 0.0 and draw.drift_translation == 0.0 and draw.off == ()
    assert draw.cutoff_hz is not None and draw.depth_factor != 1.0
    assert _rms_pct_bw(with_mismatch, seen["data"]) > 0.1
    # against the bare seed base the moved units and the seen low-pass are left out
    row = withheld.run_case(case, "seed", realism=realism)
    assert row["mismatch"]["off"] == ["kinematics", "unit_offsets"]
    stances = bench_truth.motion("seed")
    for d, st in zip(seen["data"], stances, strict=True):
        assert np.array_equal(d.foot.positions, st.foot.positions)  # exact kinematics
