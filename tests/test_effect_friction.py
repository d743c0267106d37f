"""friction: Stribeck + viscous tangential law in place of Coulomb friction.

* exactness: ``mu_s = mu_d`` and ``b = 0`` (fixed, or free at zero) give the base model's wrench
  bit for bit; a Stribeck + viscous law matches an independent NumPy evaluation of the law;
* recovery on real motion (bundled trial, 3 stances): the truth is the base model fitted to the
  trial plus ``mu_s - mu_d = 0.3`` and ``b = 0.75 s/m`` (the viscous part is ~20 % of the Coulomb
  part at the median loaded sliding speed, 4 cm/s: ``b sqrt(v^2 + v_eps^2) / mu_d`` with
  ``mu_d = 0.24``); base + friction recovers both within 3 SE; base alone leaves a larger RMS on
  the shear forces.

What the data determine: loaded units slide at 1-14 cm/s (median 4 cm/s, force-weighted), around
``v_eps`` = 5 cm/s, so the curvature of the law is sampled but the three coefficients (the law's
``mu``, the static excess, ``b``) are strongly correlated; the SEs show how much.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from gc_ocp.bench import recovery
from gc_ocp.contact.laws import DEFAULT_SMOOTHING, normal_force_function
from gc_ocp.estimation.components import base_model
from gc_ocp.estimation.components.friction import StribeckFriction
from gc_ocp.estimation.problem import build_estimation

EXCESS, VISCOUS = 0.3, 0.75


def _motion():
    return recovery.bundled_base_truth()[0]


def _truth():
    return recovery.bundled_base_truth()[1]


def _wrenches(stances, model):
    pb = build_estimation(list(stances), model)
    return pb.stance_wrenches(np.zeros(pb.x0.size))


def test_neutral_law_is_coulomb_exactly():
    """mu_s = mu_d, b = 0: the contact law's own Coulomb function is evaluated with
    ``mu + 0 * exp(..)`` and ``0 * F_n * v_s`` is subtracted: exact in floating point, so the
    wrench equals the base model's bit for bit (fixed at zero and free at zero)."""
    truth = _truth()
    ref = _wrenches(_motion(), truth)
    for comp in (
        StribeckFriction(fixed={"static_excess": 0.0, "viscous": 0.0}),
        StribeckFriction(),
    ):
        for a, b in zip(_wrenches(_motion(), (*truth, comp)), ref, strict=True):
            np.testing.assert_array_equal(a, b)


def test_law_matches_numpy():
    """Stribeck + viscous against the law written out in NumPy per unit (normal force from the
    same smooth Hunt-Crossley function). Tolerance 1e-9 of the largest force: round-off of two
    equally exact evaluation orders, amplified by stiffness x depth."""
    truth = _truth()
    law, sole = truth[0], truth[1]
    st = _motion()[0]
    comp = StribeckFriction(fixed={"static_excess": 0.4, "viscous": 1.5}, v_stribeck=0.08)
    (w_model,) = _wrenches([st], (*truth, comp))
    P, V = st.foot.unit_trajectories(st.foot.points_local + sole.fixed[st.side])
    normal = normal_force_function(True)
    mu_d, v_eps, r0 = law.mu.value, law.slip_smoothing, st.reference_point
    w = np.zeros((P.shape[0], 6))
    for i, u in enumerate(st.layout.units):
        k = law.k.value[st.side][u]
        pen, rate = st.ground_height - P[:, i, 2], -V[:, i, 2]
        eps = (law.depth_smoothing, DEFAULT_SMOOTHING.eps_damping)
        fn = np.array([float(normal(pen[t], rate[t], k, 1.0, 0.0, *eps)) for t in range(len(pen))])
        vs = V[:, i, :2] - st.belt_velocity[:2]
        s2 = np.sum(vs**2, axis=1)
        mu = mu_d + 0.4 * np.exp(-s2 / 0.08**2)
        ft = -(mu * fn)[:, None] * vs / np.sqrt(s2 + v_eps**2)[:, None] - 1.5 * fn[:, None] * vs
        F = np.column_stack([ft, fn])
        w[:, :3] += F
        w[:, 3:] += np.cross(P[:, i] - r0, F)
    np.testing.assert_allclose(w_model, w, rtol=0, atol=1e-9 * np.abs(w).max())


@pytest.mark.slow
def test_recovery_on_real_motion():
    t0 = time.perf_counter()
    sts, truth = _motion(), _truth()
    true = StribeckFriction(fixed={"static_excess": EXCESS, "viscous": VISCOUS})
    rng = np.random.default_rng(20240612)
    # no marker noise: recovery.simulate's marker path changes the kinematics by itself (see
    # tests/test_effect_ground_offset.py), the true model fitted back then leaves ~1.8 % BW
    data = recovery.simulate(sts, (*truth, true), rng, plate_noise_pct_bw=0.5, marker_noise=0.0)
    with_effect = recovery.fit_model(
        data, recovery.started_from_truth((*base_model(), StribeckFriction()), truth)
    )
    base_only = recovery.fit_model(data, recovery.started_from_truth(base_model(), truth))
    assert with_effect.success and base_only.success
    blk = with_effect.blocks["friction"]
    mu = with_effect.blocks["contact"]["shared"]
    print(f"\nfriction recovery ({time.perf_counter() - t0:.1f} s)")
    zs = []
    for key, tv in (("static_excess", EXCESS), ("viscous", VISCOUS)):
        z = (blk[key] - tv) / blk[key + "_se"]
        zs.append(z)
        print(f"  {key}: true {tv:.3f} est {blk[key]:.3f} SE {blk[key + '_se']:.3f}  z = {z:+.2f}")
    mu_true = truth[0].mu.value
    z_mu = (mu["mu"] - mu_true) / mu["mu_se"]
    print(f"  mu_d: true {mu_true:.3f} est {mu['mu']:.3f} SE {mu['mu_se']:.3f}  z = {z_mu:+.2f}")
    print(f"  base only: mu {base_only.blocks['contact']['shared']['mu']:.3f}")
    print(f"  RMS base + friction (% BW): {recovery.rms_line(with_effect)}")
    print(f"  RMS base only       (% BW): {recovery.rms_line(base_only)}")
    print("  plate noise 0.5 % BW (forces)")
    assert np.all(np.abs([*zs, z_mu]) < 3.0), (zs, z_mu)
    for side in with_effect.rms:
        eff, base = with_effect.rms[side], base_only.rms[side]
        for ch in ("anterior_force_pct_bw", "lateral_force_pct_bw"):
            assert eff[ch] < 0.7  # the right model: plate noise, 0.5 % BW
        assert max(base["anterior_force_pct_bw"], base["lateral_force_pct_bw"]) > 2.0 * 0.5
