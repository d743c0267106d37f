"""The ``damping`` effect (:class:`gc_ocp.estimation.components.damping.Damping`): Hunt-Crossley
dissipation ``c`` [s/m] added to the diagnosis's base model.

* exactness: c = 0 (frozen, or the free variable at 0) reproduces the base model's wrench
  bit for bit; the component takes over the law's own damping (``configure``);
* synthetic recovery on the bundled trial's real motion: truth = the base model fitted to the
  trial, plus c = 1 s/m; plate noise 0.5 % BW and 0.1 mm marker noise. Fitted back with base +
  damping, c is recovered within 3 standard errors; the base alone leaves the vertical force
  above the plate noise (1.3-2x) and the sagittal moment far above it (~10x).
"""

from __future__ import annotations

import numpy as np
import pytest

from gc_ocp.bench.recovery import (
    PLATE_NOISE_PCT_BW,
    TORQUE_NOISE_LENGTH,
    bundled_base_truth,
    fit_model,
    simulate,
)
from gc_ocp.estimation import (
    ContactLaw,
    SoleCorrection,
    base_model,
    build_estimation,
    full_model,
    model_from_names,
)
from gc_ocp.estimation.components.damping import Damping
from gc_ocp.estimation.starts import lls_k0

TRUE_C = 1.0  # [s/m], mid-range of the 0.5-2 s/m reported for heel pads and shoe soles
MARKER_NOISE = 1e-4  # [m]; 0.5 mm swamps every law effect on this stiff trial (see corrections)


def _motion():
    return bundled_base_truth()[0]


def _truth():
    return bundled_base_truth()[1]


def test_registered_under_its_name():
    assert model_from_names(["damping"], base=base_model())[-1].name == "damping"


def test_zero_damping_is_the_base_model():
    """c = 0, frozen or free at 0, gives the base model's wrench exactly: the law's slot
    ``law_c`` is the sum 0 (law, fixed) + 0 (damping), the same number the base model has, fed
    to the same expression graph, so no tolerance is needed (bitwise equality)."""
    stances = _motion()
    base = build_estimation(stances, base_model())
    ref = base.stance_wrenches(base.x0)
    frozen = build_estimation(stances, (*base_model(), Damping(fixed=0.0)))
    assert frozen.x0.size == base.x0.size
    for a, b in zip(frozen.stance_wrenches(frozen.x0), ref, strict=True):
        np.testing.assert_array_equal(a, b)
    for per_foot in (False, True):
        pb = build_estimation(stances, (*base_model(), Damping(per_foot=per_foot)))
        x = pb.x0.copy()
        for s in pb.variables.specs:
            x[s.slice] = 0.0 if s.key[0] == "damping" else base.x0[base.variables.spec(s.key).slice]
        for a, b in zip(pb.stance_wrenches(x), ref, strict=True):
            np.testing.assert_array_equal(a, b)


def test_configure_takes_over_the_laws_damping():
    """With a law whose c is free (``full_model``) the law's c is fixed at 0 and the damping
    component owns the one c variable; the contact block reports the same c."""
    stances = _motion()[:1]
    pb = build_estimation(stances, model_from_names(["damping"], base=full_model()))
    law = next(c for c in pb.model if isinstance(c, ContactLaw))
    assert law.c.scope == "fixed" and law.c.value == 0.0
    keys = [s.key for s in pb.variables.specs]
    assert ("contact", "c") not in keys and ("damping", "c") in keys


def _channels(res, height: float) -> dict:
    """``{channel: [left, right]}`` RMS and the plate noise on that channel (same units)."""
    noise_f = PLATE_NOISE_PCT_BW
    noise_t = PLATE_NOISE_PCT_BW * TORQUE_NOISE_LENGTH / height
    out = {}
    for ch in res.rms["left"]:
        noise = noise_t if "torque" in ch else noise_f
        out[ch] = ([res.rms[s][ch] for s in ("left", "right")], noise)
    return out


def _print_rms(label, res, height):
    print(f"  {label}:")
    for ch, (v, noise) in _channels(res, height).items():
        print(f"    {ch:32s} L {v[0]:.3f}  R {v[1]:.3f}   (plate noise {noise:.3f})")


def test_damping_is_recovered_on_real_motion():
    """Fitted back with the truth's sole geometry (the base model's sole correction fixed at
    the truth's offsets; law k, mu, pose and belt corrections free), c is recovered within 3 SE.

    With the sole corrections free under their default 5 mm prior, c comes out 12-20 % high
    (z = 3.5-5.5 over seeds 0-3): the truth's offsets (the base fit to the trial) reach 25 mm,
    4-5 prior sigmas, which the prior shrinks, and the law compensates. That bias is the sole
    prior's, not the damping's: with a 20 mm sole prior c is recovered (checked below)."""
    stances, truth = _motion(), _truth()
    rng = np.random.default_rng(2024)
    data = simulate(stances, (*truth, Damping(fixed=TRUE_C)), rng, marker_noise=MARKER_NOISE)
    k0 = lls_k0(data, 1.0)  # as fit() starts: the seed's LLS stiffness (also the k prior centre)
    law, _, pose, belt = base_model()
    law = law.with_initial_k(k0)
    sole_true = truth[1]
    with_effect = fit_model(data, (law, sole_true, pose, belt, Damping()))
    base_only = fit_model(data, (law, sole_true, pose, belt))
    wide = fit_model(data, (law, SoleCorrection(sigma=0.02, bound=0.05), pose, belt, Damping()))
    narrow = fit_model(data, (law, SoleCorrection(), pose, belt, Damping()))

    H = stances[0].height
    print(f"\ndamping: true c = {TRUE_C} s/m")
    for label, res in (
        ("sole at truth", with_effect),
        ("sole free, 20 mm prior", wide),
        ("sole free, 5 mm prior (base default)", narrow),
    ):
        b = res.blocks["damping"]
        z = (b["c"] - TRUE_C) / b["c_se"]
        print(f"  {label:38s} c = {b['c']:.3f} +- {b['c_se']:.3f} s/m, z = {z:+.2f}")
    _print_rms("RMS base + damping (sole at truth)", with_effect, H)
    _print_rms("RMS base alone (sole at truth)", base_only, H)
    sup = _channels(base_only, H)["superior_force_pct_bw"][0]
    excess = [np.sqrt(max(v**2 - PLATE_NOISE_PCT_BW**2, 0.0)) for v in sup]
    print(f"  base alone, superior force above the noise: L {excess[0]:.2f} R {excess[1]:.2f} % BW")

    for res in (with_effect, wide):
        b = res.blocks["damping"]
        assert abs(b["c"] - TRUE_C) < 3 * b["c_se"]  # efficient estimator, exact model: z ~ N(0,1)
        assert b["c_se"] < 0.1  # determined to a tenth of its value by three stances
    assert narrow.blocks["damping"]["c"] == pytest.approx(TRUE_C, rel=0.3)  # biased: see above

    rms_e, rms_b = _channels(with_effect, H), _channels(base_only, H)
    sup_e, noise_f = rms_e["superior_force_pct_bw"]
    sup_b, _ = rms_b["superior_force_pct_bw"]
    sag_e, noise_t = rms_e["mediolateral_torque_pct_bwh"]
    sag_b, _ = rms_b["mediolateral_torque_pct_bwh"]
    # with the effect the residual is the plate noise (+ the 0.1 mm marker noise's share)
    assert max(sup_e) < 1.25 * noise_f
    # without it the vertical force is above the noise on both feet (c x penetration rate is
    # 10-20 % of the force while loading and unloading; the per-unit stiffnesses absorb most of
    # it, so the RMS, which also counts the unloaded margins, exceeds the noise by only 1.3-2x:
    # a systematic part sqrt(RMS^2 - noise^2) of ~0.4-0.5 % BW) ...
    assert min(sup_b) > 1.2 * noise_f
    assert all(b > 1.2 * e for b, e in zip(sup_b, sup_e, strict=True))
    # ... and the sagittal moment is far above it (loading at the heel and unloading at the
    # forefoot shift the COP: ~10x the plate's torque noise, 20 mm x 0.5 % BW)
    assert min(sag_b) > 5 * noise_t and min(sag_b) > 3 * max(sag_e)
