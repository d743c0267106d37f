"""ground_offset: each stance's contact surface offset in height and tilted.

* exactness: at zero the component leaves the base model's wrench bit for bit; a pure height
  offset equals the same shift of the stance's ``ground_height``; a tilted surface matches an
  independent NumPy evaluation of the unit law on per-unit ground heights;
* recovery on real motion (bundled trial, 3 stances): the truth is the base model fitted to the
  trial plus +3 mm and 0.8 deg of pitch under the first stance; base + ground_offset recovers the
  offsets of all three stances within 3 SE, base alone leaves a larger RMS.

Identifiability (see the component's docstring): a constant offset and tilt of the surface are
nearly the same as a constant translation and rotation of the foot, which the pose and sole
corrections also provide; the split rests on the priors, and the standard errors (Gauss-Newton
covariance with the priors) say how well the data and priors together place it.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import pytest

from gc_ocp.bench import recovery
from gc_ocp.contact.laws import DEFAULT_SMOOTHING, unit_force_function
from gc_ocp.estimation.components import base_model
from gc_ocp.estimation.components.ground_offset import GroundOffset
from gc_ocp.estimation.problem import build_estimation

DZ, TILT_Y = 0.003, np.deg2rad(0.8)
TRUE_STANCE = 0


def _motion():
    return recovery.bundled_base_truth()[0]


def _truth():
    return recovery.bundled_base_truth()[1]


def _wrenches(stances, model):
    pb = build_estimation(list(stances), model)
    return pb.stance_wrenches(np.zeros(pb.x0.size))


def _offsets(values: dict) -> GroundOffset:
    return GroundOffset(
        fixed={st.label: values.get(i, (0.0, 0.0, 0.0)) for i, st in enumerate(_motion())}
    )


def test_zero_offset_is_the_base_model_exactly():
    """Fixed at zero and free at zero: the same wrench as the base model, bit for bit (the
    surface height gets ``+ 0 + 0 * (y - y_ref) - 0 * (x - x_ref)``, exact in floating point)."""
    truth = _truth()
    ref = _wrenches(_motion(), truth)
    for comp in (_offsets({}), GroundOffset()):
        for a, b in zip(_wrenches(_motion(), (*truth, comp)), ref, strict=True):
            np.testing.assert_array_equal(a, b)


def test_height_offset_equals_a_shifted_plate():
    """dz alone = the stance's ground_height raised by dz: the same sum ``h + dz`` in the same
    order, so bit for bit up to the exact zero-tilt terms."""
    truth = _truth()
    sts = _motion()
    shifted = [dataclasses.replace(st, ground_height=st.ground_height + DZ) for st in sts]
    a = _wrenches(sts, (*truth, _offsets(dict.fromkeys(range(len(sts)), (DZ, 0.0, 0.0)))))
    b = _wrenches(shifted, truth)
    for wa, wb in zip(a, b, strict=True):
        np.testing.assert_array_equal(wa, wb)


def test_tilt_matches_numpy_unit_law():
    """A tilted surface (both axes) against the unit law evaluated numerically per unit on the
    plane heights ``h + dz + tilt_x (y - y_ref) - tilt_y (x - x_ref)`` and summed about the
    reference point in NumPy. Tolerance 1e-9 of the largest force: the two paths place the units
    with different (equally exact) arithmetic, round-off ~1e-15 amplified by stiffness x depth."""
    truth = _truth()
    law, sole = truth[0], truth[1]
    st = _motion()[TRUE_STANCE]
    dz, ax, ay = 0.002, np.deg2rad(-0.6), np.deg2rad(0.9)
    (w_model,) = _wrenches([st], (*truth, GroundOffset(fixed={st.label: (dz, ax, ay)})))
    P, V = st.foot.unit_trajectories(st.foot.points_local + sole.fixed[st.side])
    f = unit_force_function(True)
    eps = (law.depth_smoothing, DEFAULT_SMOOTHING.eps_damping, law.slip_smoothing)
    mu = law.mu.value
    r0 = st.reference_point
    w = np.zeros((P.shape[0], 6))
    for i, u in enumerate(st.layout.units):
        h = st.ground_height + dz + ax * (P[:, i, 1] - r0[1]) - ay * (P[:, i, 0] - r0[0])
        k = law.k.value[st.side][u]
        F = np.array(
            [
                np.asarray(
                    f(P[t, i], V[t, i], k, 1.0, 0.0, mu, h[t], st.belt_velocity, *eps)
                ).ravel()
                for t in range(P.shape[0])
            ]
        )
        w[:, :3] += F
        w[:, 3:] += np.cross(P[:, i] - r0, F)
    np.testing.assert_allclose(w_model, w, rtol=0, atol=1e-9 * np.abs(w).max())
    # the tilt matters: the same offset without it differs by much more than the tolerance
    (w_flat,) = _wrenches([st], (*truth, GroundOffset(fixed={st.label: (dz, 0.0, 0.0)})))
    assert np.abs(w_flat - w).max() > 1e-3 * np.abs(w).max()


@pytest.mark.slow
def test_recovery_on_real_motion():
    t0 = time.perf_counter()
    sts, truth = _motion(), _truth()
    true = _offsets({TRUE_STANCE: (DZ, 0.0, TILT_Y)})
    rng = np.random.default_rng(20240611)
    # no marker noise: recovery.simulate's marker path (virtual markers, Kabsch, 6 Hz low-pass)
    # changes the kinematics by itself: with marker_noise = 1e-6 m (no noise to speak of) the true
    # model fitted back leaves 1.8 % BW vertical RMS on the left foot and ~+7 mm of spurious
    # offset under every stance; that is the marker pipeline, not this effect
    data = recovery.simulate(sts, (*truth, true), rng, plate_noise_pct_bw=0.5, marker_noise=0.0)
    with_effect = recovery.fit_model(
        data, recovery.started_from_truth((*base_model(), GroundOffset()), truth)
    )
    base_only = recovery.fit_model(data, recovery.started_from_truth(base_model(), truth))
    assert with_effect.success and base_only.success
    blk = with_effect.blocks["ground_offset"]
    print(f"\nground_offset recovery ({time.perf_counter() - t0:.1f} s)")
    zs = []
    for label, e_true in true.fixed.items():
        e = blk[label]
        for j, key in enumerate(("dz", "tilt_x", "tilt_y")):
            unit, f = ("mm", 1e3) if key == "dz" else ("deg", np.rad2deg(1.0))
            z = (e[key] - e_true[j]) / e[key + "_se"]
            zs.append(z)
            print(
                f"  {label} {key}: true {e_true[j] * f:+.3f} est {e[key] * f:+.3f} "
                f"SE {e[key + '_se'] * f:.3f} {unit}  z = {z:+.2f}"
            )
    print(f"  RMS base + ground_offset (% BW): {recovery.rms_line(with_effect)}")
    print(f"  RMS base only            (% BW): {recovery.rms_line(base_only)}")
    print("  plate noise 0.5 % BW (forces), 0.5 % BW x 20 mm (moments)")
    assert np.all(np.abs(zs) < 3.0), zs
    # what base alone leaves depends on whether its per-stance pose correction absorbs the
    # offset: a 3 mm / 0.8 deg surface under one stance is within that correction's prior, and on
    # this trial it is absorbed completely (base alone 0.48 % BW vertical, at the plate noise; an
    # earlier run stuck in another local minimum left 1.14): the force data fix the foot relative
    # to the surface, not which of the two moved (docs/effects.md: confounded with
    # kinematic_correction). The effect's fit is never worse than the base's:
    side = _motion()[TRUE_STANCE].side
    eff, base = with_effect.rms[side], base_only.rms[side]
    for ch in ("superior_force_pct_bw", "anteroposterior_torque_pct_bwh"):
        assert eff[ch] <= base[ch] + 0.02, (ch, eff[ch], base[ch])
