"""The two registration effects that predate the vocabulary, scored against the bare seed model
(the seed's law without corrections), on the bundled trial's real motion:

* ``sole_geometry`` (:class:`SoleCorrection`): true sole points displaced by a few millimetres;
* ``kinematic_correction`` (:class:`PoseCorrection`): the fitter sees foot poses re-estimated from
  noisy virtual markers; the correction should move them back towards the truth.
"""

from __future__ import annotations

import functools

import numpy as np

from gc_ocp.bench.recovery import fit_model, real_motion, simulate, truth_from_fit
from gc_ocp.estimation import PoseCorrection, SoleCorrection, bare_seed_model

SIDES = ("left", "right")


@functools.cache
def _truth():
    stances = real_motion()
    return stances, truth_from_fit(stances, bare_seed_model())


def _superior(res) -> float:
    return max(res.rms[s]["superior_force_pct_bw"] for s in res.rms)


def test_sole_geometry_is_recovered():
    stances, truth = _truth()
    rng = np.random.default_rng(3)
    offsets = {s: rng.uniform(-4e-3, 4e-3, (5, 3)) for s in SIDES}  # [m], within the 5 mm prior
    data = simulate(stances, (*truth, SoleCorrection(fixed=offsets)), rng)
    law = truth[0]
    fitted = fit_model(data, (law, SoleCorrection()))
    base = fit_model(data, (law,))
    z, err = [], []
    for s in SIDES:
        est = np.array(list(fitted.blocks["sole"]["offsets_mm"][s].values()))
        se = np.array(list(fitted.blocks["sole"]["se_mm"][s].values()))
        z.append((est - offsets[s] * 1e3) / se)
        err.append(est - offsets[s] * 1e3)
    z = np.concatenate(z).ravel()
    print(
        f"\nsole_geometry: |z| median {np.median(np.abs(z)):.2f}, max {np.abs(z).max():.2f}; "
        f"error RMS {np.sqrt(np.mean(np.concatenate(err) ** 2)):.2f} mm (truth RMS "
        f"{np.sqrt(np.mean(np.concatenate([offsets[s] for s in SIDES]) ** 2)) * 1e3:.2f} mm)"
    )
    print(
        f"  superior RMS [% BW]: with the effect {_superior(fitted):.2f}, base alone {_superior(base):.2f}"
    )
    # the estimator is efficient here (Gaussian plate noise, exact model): z ~ N(0, 1), so among
    # 30 offsets a |z| above 4 has probability 30 * 6e-5 = 0.2 %
    assert np.abs(z).max() < 4.0
    assert np.median(np.abs(z)) < 1.5  # N(0,1): median |z| = 0.67
    # without the effect the plate noise (0.5 % BW) is far exceeded
    assert _superior(base) > 3 * 0.5 > _superior(fitted)


def test_kinematic_correction_moves_the_foot_back():
    """Marker noise 0.5 mm (four virtual markers, Kabsch, 6 Hz): the fitter sees foot poses off by
    ~0.2 mm, which the stiff units of the real trial turn into large force errors. The pose
    correction removes them without moving the foot away from the truth."""
    stances, truth = _truth()
    rng = np.random.default_rng(4)
    data = simulate(stances, truth, rng, marker_noise=0.5e-3)
    law = truth[0]
    fitted = fit_model(data, (law, PoseCorrection()))
    base = fit_model(data, (law,))
    before, after = [], []
    for st_true, st_seen in zip(stances, data, strict=True):
        blk = fitted.blocks["pose"]["stances"][st_seen.label]
        d, th = np.asarray(blk["translation_m"]), np.asarray(blk["rotation_rad"])
        p = st_seen.foot.positions  # (T, 5, 3) nominal units on the seen kinematics
        r = p - st_seen.foot.hindfoot_pose[:, None, :3, 3]
        corrected = p + d[:, None, :] + np.cross(th[:, None, :], r)
        # units in contact in the truth: where the force sees the foot
        true_z = st_true.foot.positions[:, :, 2]
        touch = true_z < st_true.ground_height
        before.append((p[:, :, 2] - true_z)[touch])
        after.append((corrected[:, :, 2] - true_z)[touch])
    rms_b = float(np.sqrt(np.mean(np.concatenate(before) ** 2))) * 1e3
    rms_a = float(np.sqrt(np.mean(np.concatenate(after) ** 2))) * 1e3
    print(
        f"\nkinematic_correction: touching units' height error {rms_b:.3f} mm seen -> {rms_a:.3f} mm corrected"
    )
    print(
        f"  superior RMS [% BW]: with the effect {_superior(fitted):.2f}, base alone {_superior(base):.2f}"
    )
    # the force residual is what the correction removes (11 -> 1.4 % BW on this draw); the foot
    # height itself is not pinned better than the kinematic error it started from (0.18 mm here:
    # 0.13 or 0.27 mm after correction, depending on the draw): the force data fix the foot to
    # within a fraction of a millimetre, not to the truth's last tenth. Its height error stays far
    # inside its 2 mm prior:
    assert _superior(base) > 3 * _superior(fitted)
    assert rms_a < 1.0
