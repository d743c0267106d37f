"""The ``stiffness_exponent`` effect
(:class:`gc_ocp.estimation.components.stiffness_exponent.StiffnessExponent`): the penetration
exponent n of ``F_n = k d^n`` estimated on top of the diagnosis's base model (n = 1).

* exactness: n = 1 (frozen, or the free variable at 0) reproduces the base model's wrench bit for
  bit; while n is estimated, the law's stiffness variable is the force at the 5 mm pivot depth
  per metre, whatever n (to round-off);
* synthetic recovery on the bundled trial's real motion: truth = the base model fitted to the
  trial with n = 1.5 and each unit's k rescaled to keep its force at 5 mm
  (``k_1.5 = k_1 * 0.005**(1 - 1.5)``); plate noise 0.5 % BW, 0.1 mm marker noise. Fitted back with
  base + exponent, n and every unit's force at the reference depth (``f_ref``, 5 mm: k changes
  units with n, f_ref does not) are recovered within 3-4 standard errors; the base alone leaves
  the vertical force at twice the plate noise and the moments far above it.
"""

from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np

from gc_ocp.bench.recovery import (
    PLATE_NOISE_PCT_BW,
    TORQUE_NOISE_LENGTH,
    bundled_base_truth,
    fit_model,
    simulate,
)
from gc_ocp.estimation import (
    ContactLaw,
    Param,
    SoleCorrection,
    base_model,
    build_estimation,
    full_model,
    model_from_names,
    result_at,
)
from gc_ocp.estimation.components.stiffness_exponent import StiffnessExponent
from gc_ocp.estimation.starts import lls_k0

TRUE_N = 1.5  # Hertz contact of a rounded heel / forefoot
MARKER_NOISE = 1e-4  # [m]; 0.5 mm swamps every law effect on this stiff trial (see corrections)
D_REF = 0.005  # [m] the contact law's reference depth (f_ref) and the component's pivot depth
SIDES = ("left", "right")


def _motion():
    return bundled_base_truth()[0]


@functools.cache
def _truth():
    """The base fit's truth with n = 1.5: the law's k rescaled per unit to keep f(5 mm)."""
    law, *rest = bundled_base_truth()[1]
    k1 = law.k.value
    kn = {s: {u: v * D_REF ** (1 - TRUE_N) for u, v in ks.items()} for s, ks in k1.items()}
    f_ref = {s: {u: v * D_REF for u, v in ks.items()} for s, ks in k1.items()}  # [N]
    truth = (replace(law, k=Param("fixed", kn)), *rest, StiffnessExponent(fixed=TRUE_N))
    return truth, f_ref


def test_registered_under_its_name():
    model = model_from_names(["stiffness_exponent"], base=base_model())
    assert model[-1].name == "stiffness_exponent"


def test_unit_exponent_is_the_base_model():
    """n = 1, frozen or free at its stored value 0 (m = n - 1), gives the base model's wrench
    exactly: ``law_n`` = 1 (law, fixed) + 0 and ``log_k`` = log k + 0 * ln(5 mm), the very
    numbers of the base model fed to the same expression graph (bitwise equality)."""
    stances = _motion()
    base = build_estimation(stances, base_model())
    ref = base.stance_wrenches(base.x0)
    frozen = build_estimation(stances, (*base_model(), StiffnessExponent(fixed=1.0)))
    assert frozen.x0.size == base.x0.size
    for a, b in zip(frozen.stance_wrenches(frozen.x0), ref, strict=True):
        np.testing.assert_array_equal(a, b)
    pb = build_estimation(stances, (*base_model(), StiffnessExponent()))
    x = pb.x0.copy()
    for s in pb.variables.specs:
        own = s.key[0] == "stiffness_exponent"
        x[s.slice] = 0.0 if own else base.x0[base.variables.spec(s.key).slice]
    for a, b in zip(pb.stance_wrenches(x), ref, strict=True):
        np.testing.assert_array_equal(a, b)


def test_the_stiffness_variable_is_the_force_at_the_pivot_depth():
    """Analytic: while n is estimated the law's variable ``log k_1`` gives ``k = k_1 d_p^(1-n)``,
    so the decoded force at the reference depth (= the pivot, 5 mm) is ``k_1 * 5 mm`` for every
    n, and the decoded k is ``k_1 * 0.005**(1 - n)``. Round-off only (exp/log of O(10) numbers):
    1e-12 relative."""
    stances = _motion()
    pb = build_estimation(stances, (*base_model(), StiffnessExponent()))
    law = next(c for c in pb.model if isinstance(c, ContactLaw))
    assert law.n.scope == "fixed" and law.n.value == 1.0  # configure took over the exponent
    for n in (1.0, 1.7, 2.6):
        x = pb.x0.copy()
        x[pb.variables.spec(("stiffness_exponent", "n")).slice] = n - 1.0
        res = result_at(pb, x)
        assert res.blocks["stiffness_exponent"]["n"] == n
        blk = res.blocks["contact"]
        for side in SIDES:
            for u in stances[0].layout.units:
                k1 = float(np.exp(x[pb.variables.spec(("contact", "k", side, u)).slice][0]))
                assert abs(blk[side][u]["f_ref"] / (k1 * D_REF) - 1) < 1e-12
                assert abs(blk[side][u]["k"] / (k1 * D_REF ** (1 - n)) - 1) < 1e-12
            assert abs(blk[side]["n"] - n) < 1e-15


def test_configure_takes_over_the_laws_exponent():
    stances = _motion()[:1]
    pb = build_estimation(stances, model_from_names(["stiffness_exponent"], base=full_model()))
    law = next(c for c in pb.model if isinstance(c, ContactLaw))
    assert law.n.scope == "fixed" and law.n.value == 1.0
    keys = [s.key for s in pb.variables.specs]
    assert ("contact", "n") not in keys and ("stiffness_exponent", "n") in keys


def _channels(res, height: float) -> dict:
    """``{channel: ([left, right] RMS, plate noise on that channel)}`` (% BW, % BW x H)."""
    noise_t = PLATE_NOISE_PCT_BW * TORQUE_NOISE_LENGTH / height
    return {
        ch: (
            [res.rms[s][ch] for s in SIDES],
            noise_t if "torque" in ch else PLATE_NOISE_PCT_BW,
        )
        for ch in res.rms["left"]
    }


def _print_rms(label, res, height):
    print(f"  {label}:")
    for ch, (v, noise) in _channels(res, height).items():
        print(f"    {ch:32s} L {v[0]:.3f}  R {v[1]:.3f}   (plate noise {noise:.3f})")


def _z(res, f_ref_true):
    """z of n and of every unit's f_ref."""
    b = res.blocks["stiffness_exponent"]
    z_n = (b["n"] - TRUE_N) / b["n_se"]
    blk = res.blocks["contact"]
    z_f = {
        (s, u): (e["f_ref"] - f_ref_true[s][u]) / e["f_ref_se"]
        for s in SIDES
        for u, e in blk[s].items()
        if isinstance(e, dict)
    }
    return b, z_n, z_f


def test_exponent_is_recovered_on_real_motion():
    """Fitted back with the truth's sole geometry (law k, mu, pose and belt corrections free) and
    with the sole corrections free under the base's 5 mm prior, n and the units' f_ref are
    recovered. The sole prior's shrinkage of the truth's large offsets (up to 25 mm, 5 prior
    sigmas) biases n only a little (z_n from -0.6 to +2.0 over the seeds tried; the damping's
    z is 3.5-5.5 under the same prior)."""
    stances = _motion()
    truth, f_ref = _truth()
    rng = np.random.default_rng(2025)
    data = simulate(stances, truth, rng, marker_noise=MARKER_NOISE)
    k0 = lls_k0(data, 1.0)  # as fit() starts: the seed's LLS stiffness (also the k prior centre)
    law, _, pose, belt = base_model()
    law = law.with_initial_k(k0)
    sole_true = truth[1]
    with_effect = fit_model(data, (law, sole_true, pose, belt, StiffnessExponent()))
    base_only = fit_model(data, (law, sole_true, pose, belt))
    sole_free = fit_model(data, (law, SoleCorrection(), pose, belt, StiffnessExponent()))

    H = stances[0].height
    print(f"\nstiffness_exponent: true n = {TRUE_N}")
    for label, res in (("sole at truth", with_effect), ("sole free (5 mm prior)", sole_free)):
        b, z_n, z_f = _z(res, f_ref)
        zf = np.array(list(z_f.values()))
        print(
            f"  {label:24s} n = {b['n']:.3f} +- {b['n_se']:.3f}, z = {z_n:+.2f}; f_ref z: "
            f"max |z| {np.abs(zf).max():.2f}, median |z| {np.median(np.abs(zf)):.2f}"
        )
        for (s, u), z in z_f.items():
            e = res.blocks["contact"][s][u]
            print(
                f"    {s:5s} {u}: f_ref {e['f_ref']:7.1f} +- {e['f_ref_se']:5.1f} N "
                f"(true {f_ref[s][u]:7.1f}), z = {z:+.2f}"
            )
        assert abs(z_n) < 3.0  # efficient estimator, exact model: z ~ N(0, 1)
        assert b["n_se"] < 0.05  # three stances fix the exponent to a few hundredths
        # 10 units: a |z| above 4 has probability 10 * 6e-5 = 0.06 %
        assert np.abs(zf).max() < 4.0
    _print_rms("RMS base + exponent (sole at truth)", with_effect, H)
    _print_rms("RMS base alone (sole at truth)", base_only, H)

    rms_e, rms_b = _channels(with_effect, H), _channels(base_only, H)
    sup_e, noise_f = rms_e["superior_force_pct_bw"]
    sup_b, _ = rms_b["superior_force_pct_bw"]
    assert max(sup_e) < 1.25 * noise_f  # the plate noise (+ the marker noise's share)
    # a linear spring rises too early and falls too late in each unit: the vertical force is
    # ~2x the noise without the exponent on both feet (systematic part ~0.9 % BW) ...
    assert min(sup_b) > 1.6 * noise_f
    # ... and the moments (COP) far above the plate's torque noise
    for ch in ("anteroposterior_torque_pct_bwh", "mediolateral_torque_pct_bwh"):
        (b, noise_t), (e, _) = rms_b[ch], rms_e[ch]
        assert min(b) > 5 * noise_t and min(b) > 2 * max(e), ch


def test_the_lls_start_is_in_the_units_of_the_law_the_exponent_configures():
    """With the exponent, the law's n is fixed at 1 and its stiffness variable is k_1 [N/m]
    (the force at 5 mm per metre). The one start path converted the LLS stiffness to the
    exponent the law was *given* (``full_model``'s 1.5): a start 0.005**-0.5 = 14 times too
    stiff, and the weak log-k prior centred there (on synthetic stances the fit then ended at
    J = 81 against 24, one unit's f_ref at 2.2 kN). Same numbers, so exact equality."""
    from conftest import synthetic_stances

    from gc_ocp.estimation.starts import with_lls_start

    stances, _ = synthetic_stances(np.random.default_rng(0), 0.0, per_foot=1)
    for base in (full_model(), base_model()):
        model = with_lls_start(model_from_names(["stiffness_exponent"], base=base), stances)
        assert model[0].k.value == lls_k0(stances, 1.0)
    # without the exponent the law's own n (1.5) is the one the start converts to
    assert with_lls_start(full_model(), stances)[0].k.value == lls_k0(stances, 1.5)
