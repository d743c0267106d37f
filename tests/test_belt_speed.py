"""belt_speed: the treadmill belt's speed correction, its sign and what it changes.

The lab's walking direction is +X (:func:`gc_ocp.io.orientation.walking_rotation`), so a belt
running at ``s`` m/s under the subject moves along -X (:func:`gc_ocp.trial.belt_velocity`). A
correction ``dv`` > 0 means the belt ran faster than the nominal speed: the model must equal the
nominal one evaluated with the belt at ``s + dv`` exactly (the correction only enters the sliding
velocity ``v - v_belt`` of the friction law), and a foot carried by the belt at its true speed
does not slide.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from gc_ocp.bench import recovery
from gc_ocp.estimation.components.belt import BeltSpeed
from gc_ocp.estimation.problem import build_estimation
from gc_ocp.trial import belt_velocity


def _with_belt(truth, dv: float, trial: str) -> tuple:
    """The truth with its belt component's correction of ``trial`` fixed at ``dv`` [m/s]."""
    return tuple(BeltSpeed(fixed={trial: dv}) if isinstance(c, BeltSpeed) else c for c in truth)


def _wrenches(stances, model):
    pb = build_estimation(list(stances), model)
    return pb.stance_wrenches(np.zeros(pb.x0.size))


def test_a_positive_correction_is_a_faster_belt():
    stances, truth = recovery.bundled_base_truth()
    st = stances[0]
    nominal, dv = 1.2, 0.15  # [m/s]
    on_belt = replace(st, belt_velocity=belt_velocity(nominal))
    faster = replace(st, belt_velocity=belt_velocity(nominal + dv))
    (corrected,) = _wrenches([on_belt], _with_belt(truth, dv, st.trial))
    (reference,) = _wrenches([faster], truth)
    # the same expression evaluated with -1.2 - 0.15 and -1.35: round-off of the sliding speed
    # (1e-16 m/s) times the friction's slope mu F_n / v_eps, far below 1e-9 of the largest force
    np.testing.assert_allclose(corrected, reference, rtol=0, atol=1e-9 * np.abs(reference).max())


def test_a_foot_carried_by_the_belt_does_not_slide():
    """The stance's foot moved rigidly with a belt at 1.2 m/s (every unit's velocity plus the
    belt's): with the belt speed right, the wrench is the overground one (the sliding velocity
    ``v - v_belt`` is the overground foot's); a correction of 0.1 m/s there makes the feet slide
    and changes the shear force."""
    stances, truth = recovery.bundled_base_truth()
    st = stances[0]
    vb = belt_velocity(1.2)
    f = st.foot
    moving = replace(
        f,
        hindfoot_twist=f.hindfoot_twist + np.r_[vb, 0, 0, 0],
        toes_twist=f.toes_twist + np.r_[vb, 0, 0, 0],
        positions=None,
        velocities=None,
    )
    on_belt = replace(st, foot=moving, belt_velocity=vb)
    (overground,) = _wrenches([st], truth)
    (carried,) = _wrenches([on_belt], truth)
    # only v_x changed, by the belt speed, and back by the same: round-off of 1.2 m/s (3e-16)
    # times the friction slope mu F_n / v_eps (< 1e5 N per m/s)
    np.testing.assert_allclose(carried, overground, rtol=0, atol=1e-9 * np.abs(overground).max())
    (wrong,) = _wrenches([on_belt], _with_belt(truth, 0.1, st.trial))
    assert np.abs(wrong[:, 0] - overground[:, 0]).max() > 10.0  # [N]
