"""The withheld-effect benchmark's truths as they were built before the effects said how they
are injected (``gc_ocp/bench/withheld.py`` at commit b9e69bc: its ``VALUES`` table, the
``truth_model`` if-chain, ``motion``'s toe-joint case and ``run_case``'s kinematic error),
kept verbatim as the reference the registry-driven benchmark must reproduce exactly
(``tests/test_benchmark_diagnosis.py``). Not used by the package."""

from __future__ import annotations

import dataclasses

import numpy as np

from gc_ocp.bench.withheld import _source
from gc_ocp.errors import InputError
from gc_ocp.stance import StanceData

EFFECTS = (
    "damping",
    "stiffness_exponent",
    "sole_geometry",
    "kinematic_correction",
    "contact_density",
    "toe_joint",
    "ground_offset",
    "time_offset",
    "friction",
)
NONE = "none"

VALUES: dict[str, dict[str, object]] = {
    "damping": {"moderate": 0.5, "strong": 1.0},  # c [s/m]
    "stiffness_exponent": {"moderate": 1.25, "strong": 1.5},  # n [-]
    "sole_geometry": {"moderate": 2e-3, "strong": 4e-3},  # half-range of U per axis [m]
    "kinematic_correction": {  # marker noise [m], drift [m], drift [deg]
        "moderate": (0.5e-3, 2e-3, 0.5),
        "strong": (1.0e-3, 4e-3, 1.0),
    },
    "contact_density": {"moderate": 2.0, "strong": 3.0},  # heel/toe stiffness ratio
    "toe_joint": {"moderate": 10.0, "strong": 15.0},  # toe dorsiflexion at toe-off [deg]
    "ground_offset": {"moderate": (2e-3, 0.5), "strong": (4e-3, 1.0)},  # [m], [deg]
    "time_offset": {"moderate": 0.010, "strong": 0.020},  # plate late [s]
    "friction": {"moderate": (0.15, 0.4), "strong": (0.3, 0.75)},  # mu_s - mu_d, b [s/m]
}


def motion(base: str, effect: str = NONE, files: tuple[str, ...] | None = None) -> list[StanceData]:
    """The true motion of the cases: the stances of the motion source (``files``; None: the
    bundled trial). For the ``seed`` base the sole
    points are the registered fit's (nominal + fitted offsets; TT at its nominal point for
    ``toe_joint``, see :func:`truth_model`): a bare law on the nominal points of real kinematics
    leaves heel units of a stance that never touch the ground, so a truth fitted that way has
    per-unit stiffnesses no other stance can predict, and every held-out score is dominated by
    that, not by the effect."""
    stances = list(_source(files)[0])
    if base != "seed":
        return stances
    sole = next(c for c in _source(files)[1] if c.name == "sole")
    out = []
    for st in stances:
        off = np.array(sole.fixed[st.side], float)
        if effect == "toe_joint":
            off[list(st.layout.units).index("TT")] = 0.0
        out.append(st.with_foot(st.foot.with_points(st.foot.points_local + off)))
    return out


def _law(truth: tuple):
    return next(c for c in truth if c.name == "contact")


def _replace_law(truth: tuple, law) -> tuple:
    return tuple(law if c.name == "contact" else c for c in truth)


def _toe_angles(stances, peak_deg: float) -> dict:
    """Spline coefficients [rad] of a toe angle: 0 until 55 % of the stance, then a smooth step
    to ``peak_deg`` at toe-off (as ``tests/test_effect_toe_joint.py``)."""
    from gc_ocp.estimation.components.toe_joint import ToeJoint

    tj, fixed = ToeJoint(drive="spline"), {}
    for st in stances:
        t = st.time
        t_on, t_off = t[st.in_contact][[0, -1]]
        t_a = t_on + 0.55 * (t_off - t_on)
        s = np.clip((t - t_a) / (t_off - t_a), 0, 1)
        B, _ = tj.basis(t)
        fixed[st.label] = np.linalg.lstsq(B, np.deg2rad(peak_deg) * s * s * (3 - 2 * s))[0]
    return fixed


def truth_model(effect: str, magnitude: str, base: tuple, stances, rng) -> tuple:
    """``base`` (a frozen base fit) plus ``effect`` at ``magnitude`` (:data:`VALUES`); random
    signs and patterns from ``rng``. ``kinematic_correction`` and ``none`` return ``base``
    (the kinematic error is applied to the data, :func:`generate`)."""
    from gc_ocp.estimation.components import (
        ContactDensity,
        Damping,
        GroundOffset,
        Param,
        SoleCorrection,
        StiffnessExponent,
        StribeckFriction,
        TimeOffset,
        ToeJoint,
    )

    if effect in (NONE, "kinematic_correction"):
        return base
    v = VALUES[effect][magnitude]
    law = _law(base)
    sides = sorted({st.side for st in stances})
    if effect == "damping":
        return (*base, Damping(fixed=float(v)))
    if effect == "stiffness_exponent":
        # k rescaled per unit to keep the force at the 5 mm reference depth
        d = law.reference_depth
        k = {s: {u: kv * d ** (1 - v) for u, kv in ks.items()} for s, ks in law.k.value.items()}
        law = dataclasses.replace(law, k=Param("fixed", k))
        return (*_replace_law(base, law), StiffnessExponent(fixed=float(v)))
    if effect == "sole_geometry":
        offsets = {s: rng.uniform(-v, v, (5, 3)) for s in sides}
        have = next((c for c in base if c.name == "sole"), None)
        if have is not None:
            offsets = {s: np.asarray(have.fixed[s]) + offsets[s] for s in sides}
            return tuple(SoleCorrection(fixed=offsets) if c is have else c for c in base)
        return (*base, SoleCorrection(fixed=offsets))
    if effect == "contact_density":
        theta = {
            s: [
                float(np.log(np.median(list(law.k.value[s].values())) * 5 / 16)),
                -np.log(v) / 2,
                0.0,
                0.0,
            ]
            for s in sides
        }
        return (*base, ContactDensity(fixed=theta))
    if effect == "toe_joint":
        # TT at its nominal point, the other units as fitted: the base fit moves TT 20-25 mm
        # back, nearly under the MTP axis, where a hinge barely changes its depth (see
        # tests/test_effect_toe_joint.py, which zeroes the whole sole)
        def nominal_tt(c):
            fixed = {}
            for side, o in c.fixed.items():
                o = np.array(o, float)
                o[list(stances[0].layout.units).index("TT")] = 0.0
                fixed[side] = o
            return dataclasses.replace(c, fixed=fixed)

        base = tuple(nominal_tt(c) if c.name == "sole" else c for c in base)
        return (*base, ToeJoint(drive="spline", fixed=_toe_angles(stances, float(v))))
    if effect == "ground_offset":
        dz, tilt = v
        fixed = {
            st.label: (
                dz * rng.choice([-1.0, 1.0]),
                np.deg2rad(tilt) * rng.choice([-1.0, 1.0]),
                np.deg2rad(tilt) * rng.choice([-1.0, 1.0]),
            )
            for st in stances
        }
        return (*base, GroundOffset(fixed=fixed))
    if effect == "time_offset":
        return (*base, TimeOffset(fixed={st.trial: float(v) for st in stances}))
    if effect == "friction":
        excess, viscous = v
        return (*base, StribeckFriction(fixed={"static_excess": excess, "viscous": viscous}))
    raise InputError(f'Unknown effect "{effect}"; choose from {[*EFFECTS, NONE]}')


def kinematic_error(truth_name, mag, base_model_, realism):
    """``run_case``'s choice of the kinematic error the fitter sees."""
    has_pose = any(c.name == "pose" for c in base_model_)
    if truth_name == "kinematic_correction":
        kin_err = VALUES[truth_name][mag]
    elif has_pose:
        kin_err = (realism.marker_noise, realism.drift_translation, realism.drift_rotation_deg)
    else:
        kin_err = None
    return kin_err
