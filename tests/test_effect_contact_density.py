"""The contact_density effect: 16 units over the nominal sole outline, log-stiffness a smooth field
of 4 parameters per foot.

Exactness: the dense units are convex combinations of the nominal ones (corners and TT coincide
with them); a constant field gives every unit the same k; on a flat foot sunk uniformly the dense
sole with all k equal carries m / 5 times the vertical force of the five nominal units with that
k; the interpolated sole correction moves the coinciding units by the nominal offsets.

Recovery on real motion: truth = the base model fitted to the bundled trial (sole offsets and mu
as fitted) on the dense sole, with a stiffness field three times stiffer at the heel than at the
toe tip (a linear gradient in xi, no lateral or curvature term).
"""

from __future__ import annotations

import time

import numpy as np

from gc_ocp.bench import recovery
from gc_ocp.estimation import Weights, build_estimation, result_at
from gc_ocp.estimation.components import (
    BeltSpeed,
    ContactLaw,
    Param,
    PoseCorrection,
    SoleCorrection,
    base_model,
    model_from_names,
)
from gc_ocp.estimation.components.contact_density import (
    BASIS,
    ContactDensity,
    DenseSoleCorrection,
    _offset_map,
    _toes_relative,
    dense_design,
)
from gc_ocp.foot import FootKinematics
from gc_ocp.trial import SIDES

WEIGHTS = Weights(force_sigma=0.005, torque_length=recovery.TORQUE_NOISE_LENGTH)
"""Residual weights equal to the simulated plate noise (0.5 % BW, x 20 mm on the moments): the
maximum-likelihood fit, whose standard errors are meaningful (the default weights down-weight the
precise moments 12-fold against the sole prior, and the truth's fitted sole offsets, up to the
25 mm bound, then bias the field by several SEs)."""
HEEL_TO_TOE = 3.0


def _stances():
    return recovery.bundled_base_truth()[0]


def _base_truth():
    return recovery.bundled_base_truth()[1]


def _true_field(law) -> dict:
    """theta per foot: the base fit's median unit stiffness spread over 16 units instead of 5 at
    the centre, log k falling linearly from heel to toe by a factor 3."""
    return {
        s: [
            float(np.log(np.median(list(law.k.value[s].values())) * 5 / 16)),
            -np.log(HEEL_TO_TOE) / 2,
            0.0,
            0.0,
        ]  # fmt: skip
        for s in SIDES
    }


# --- exactness ------------------------------------------------------------------------------


def test_dense_units_interpolate_the_nominal_outline():
    """Weights are convex (>= 0, rows sum to 1 within 1e-15); the grid's corners are PL, PM, AL,
    AM and the last unit is TT exactly; points in the toes frame come back to the nominal TT."""
    W, layout = dense_design()
    assert layout.n >= 15 and len(set(layout.units)) == layout.n
    assert np.all(W >= 0) and np.allclose(W.sum(axis=1), 1.0, atol=1e-15)
    for j, i in ((0, 0), (2, 1), (9, 2), (11, 3), (15, 4)):
        assert W[j, i] == 1.0
    st = ContactDensity().prepare(_stances()[:1])[0]
    nominal = _stances()[0].foot.points_local
    assert st.layout == layout
    np.testing.assert_allclose(st.foot.points_local[[0, 2, 9, 11, 15]], nominal, atol=1e-15)
    assert all(p == "toes" for p in layout.parents[12:])


def test_constant_field_is_a_uniform_sole():
    """theta = (log k0, 0, 0, 0): every dense unit's k is k0 (exp(log k0), round-off 1e-12)."""
    k0 = 2.5e4
    fixed = ContactDensity(fixed={s: [np.log(k0), 0, 0, 0] for s in SIDES})
    pb = build_estimation(_stances(), (*base_model(), fixed))  # the recovery's per-frame function
    res = result_at(pb, pb.x0)
    for i, st in enumerate(pb.stances):
        np.testing.assert_array_equal(pb.slot_values(pb.x0, i, "log_k"), np.log(k0))
        for u in st.layout.units:
            assert abs(res.blocks["contact"][st.side][u]["k"] / k0 - 1) < 1e-12


def test_uniform_dense_sole_on_a_flat_foot_carries_m_over_5_times_the_force():
    """A flat foot (frames = lab), nominal units all 4 mm below the plate, at rest: every dense
    unit is at the same depth (affine combinations of points at one height), so with all k equal
    the dense sole's vertical force is exactly 16/5 of the five units' (same law, same depth;
    round-off: 1e-12)."""
    st = _stances()[0]
    T = st.n
    pose_h = np.tile(np.eye(4), (T, 1, 1))
    pose_h[:, :3, 3] = [0.0, 0.2, 0.08]
    pose_t = pose_h.copy()
    pose_t[:, :3, 3] += [0.12, 0.0, -0.045]
    local = np.array(st.foot.points_local)
    local[:4, 2] = -0.084  # hindfoot units: 4 mm below the plate (z = 0)
    local[4, 2] = -0.039  # TT, in the toes frame
    z6 = np.zeros((T, 6))
    foot = FootKinematics(st.side, st.time, pose_h, pose_t, z6, z6, local)
    flat = st.with_foot(foot)
    k0 = 3.0e4
    law = ContactLaw(
        k=Param("fixed", k0), n=Param("fixed", 1.0), c=Param("fixed", 0.0), mu=Param("fixed", 0.5)
    )
    # the base model's structure with zero corrections (pose variables at 0): the per-frame
    # functions of the recovery test, no extra C compilation
    zero = (
        SoleCorrection(fixed={s: np.zeros((5, 3)) for s in SIDES}),
        PoseCorrection(),
        BeltSpeed(),
    )

    def fz(model):
        pb = build_estimation([flat], model)
        return pb.stance_wrenches(np.zeros(pb.x0.size))[0]

    five = fz((law, *zero))
    dense = fz((law, *zero, ContactDensity(fixed={s: [np.log(k0), 0, 0, 0] for s in SIDES})))
    assert five[0, 2] > 0.9 * 5 * k0 * 0.004  # the units are in contact
    np.testing.assert_allclose(dense[:, 2], 16 / 5 * five[:, 2], rtol=1e-12)


def test_sole_offsets_follow_the_interpolation():
    """The interpolated sole correction moves the dense units that coincide with nominal ones by
    exactly those units' offsets (in their own frames), and a common offset moves every unit."""
    st = _stances()[0]
    W, layout = dense_design()
    R, _ = _toes_relative(st.foot)
    M = _offset_map(W, layout, R)
    delta = np.random.default_rng(3).normal(size=(5, 3)) * 1e-3
    moved = (M @ delta.ravel()).reshape(-1, 3)
    np.testing.assert_allclose(moved[[0, 2, 9, 11, 15]], delta, atol=1e-18)
    common = (M @ np.tile([1e-3, 2e-3, 3e-3], 5)).reshape(-1, 3)
    np.testing.assert_allclose(common, np.tile([1e-3, 2e-3, 3e-3], (16, 1)), atol=1e-17)
    model = model_from_names(["contact_density"], base=base_model())
    configured = ContactDensity().configure(model)
    assert any(isinstance(c, DenseSoleCorrection) for c in configured)
    assert next(c for c in configured if isinstance(c, ContactLaw)).k == Param("fixed", 1.0)


# --- recovery -------------------------------------------------------------------------------


def test_stiffness_field_is_recovered_on_real_motion():
    t0 = time.perf_counter()
    stances = _stances()
    base_truth = _base_truth()
    theta = _true_field(base_truth[0])
    law, sole, belt = base_truth
    # a pose correction at zero (simulate evaluates at x = 0) gives the truth the fit's per-frame
    # function: one C compilation of the 16-unit model instead of two on a cold cache
    truth = (law, sole, PoseCorrection(), belt, ContactDensity(fixed=theta))
    data = recovery.simulate(stances, truth, np.random.default_rng(11))
    r1 = recovery.fit_model(data, model_from_names(["contact_density"], base=base_model()), WEIGHTS)
    r0 = recovery.fit_model(data, base_model(), WEIGHTS)
    assert r1.success and r0.success, (r1.status, r0.status)

    block = r1.blocks["contact_density"]
    for side in SIDES:
        est, se = np.array(block[side]["theta"]), np.array(block[side]["theta_se"])
        z = (est - np.array(theta[side])) / se
        for b, t, e, s, zz in zip(BASIS, theta[side], est, se, z, strict=True):
            print(f"{side} theta[{b}]: true {t:+.3f} est {e:+.3f} +- {s:.3f} (z {zz:+.1f})")
        print(f"{side} heel/toe stiffness ratio {block[side]['heel_to_toe']:.2f} (true 3)")
        assert np.all(np.abs(z) < 3.0), (side, z)

    noise = recovery.PLATE_NOISE_PCT_BW
    for side in r1.rms:
        print(side, "effect", {c: round(v, 4) for c, v in r1.rms[side].items()})
        print(side, "base  ", {c: round(v, 4) for c, v in r0.rms[side].items()})
        # with the effect: at the noise within 25 % (the truth's fitted sole offsets lie up to
        # 4-5 prior sds out; the MAP pulls them in a little, ~15 % excess on the left Fz)
        for ch in ("anterior_force_pct_bw", "superior_force_pct_bw", "lateral_force_pct_bw"):
            assert r1.rms[side][ch] < 1.25 * noise, (side, ch, r1.rms[side][ch])
        # five units cannot carry the load as sixteen do: the vertical force is off
        fz0, fz1 = (r.rms[side]["superior_force_pct_bw"] for r in (r0, r1))
        assert fz0 > 1.6 * noise and fz0 > 1.8 * fz1, (side, fz0, fz1)
    print(f"contact_density recovery: {time.perf_counter() - t0:.1f} s")
