"""Model components: each carries its own variables, its per-frame physics and its result block.

A model is a tuple of components (see :mod:`.base` for the protocol). Presets:

>>> seed = seed_model()        # the seed report: k per unit, n = 1, c = 0, fixed friction
>>> full = full_model()        # contact law with n, c, mu free; sole, pose and belt corrections

:data:`REGISTRY` maps a component's name to its class: the vocabulary of model names
(``model_from_names(["damping"], base=base_model())``). A new component is one file in this folder
plus one line here.
"""

from __future__ import annotations

from gc_ocp.errors import ModelError
from gc_ocp.estimation.components.base import Component, DecodeContext, Scope
from gc_ocp.estimation.components.belt import BeltSpeed
from gc_ocp.estimation.components.contact import ContactLaw, Param
from gc_ocp.estimation.components.contact_density import ContactDensity
from gc_ocp.estimation.components.damping import Damping
from gc_ocp.estimation.components.friction import StribeckFriction
from gc_ocp.estimation.components.ground_offset import GroundOffset
from gc_ocp.estimation.components.pose import PoseCorrection
from gc_ocp.estimation.components.sole import SoleCorrection
from gc_ocp.estimation.components.stiffness_exponent import StiffnessExponent
from gc_ocp.estimation.components.time_offset import TimeOffset
from gc_ocp.estimation.components.toe_joint import ToeJoint

REGISTRY: dict[str, type[Component]] = {
    "contact": ContactLaw,
    "sole_geometry": SoleCorrection,
    "kinematic_correction": PoseCorrection,
    "belt_speed": BeltSpeed,
    "time_offset": TimeOffset,
    "damping": Damping,
    "stiffness_exponent": StiffnessExponent,
    "ground_offset": GroundOffset,
    "friction": StribeckFriction,
    "toe_joint": ToeJoint,
    "contact_density": ContactDensity,
}
"""Component classes by name: the vocabulary of model configurations and of the diagnosis
(``docs/effects.md``). A component instance's ``name`` keys its variables and its result block
(``"sole"``, ``"pose"``, ``"belt"`` for the three corrections that predate the vocabulary)."""

EFFECTS: tuple[str, ...] = (
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
"""The candidate model extensions of the diagnosis, by registry name."""


def register(name: str, cls: type[Component]) -> None:
    """Add a component class to :data:`REGISTRY` under ``name``."""
    if name in REGISTRY and REGISTRY[name] is not cls:
        raise ModelError(
            f'A component named "{name}" is already registered ({REGISTRY[name].__name__})'
        )
    REGISTRY[name] = cls


def model_from_names(names, base: tuple = ()) -> tuple[Component, ...]:
    """``base`` plus the registered components ``names`` (the defaults for the model they join,
    :meth:`Component.for_model`), skipping those whose class is already in ``base``."""
    unknown = [n for n in names if n not in REGISTRY]
    if unknown:
        raise ModelError(f"Unknown component(s) {unknown}; choose from {sorted(REGISTRY)}")
    model = tuple(base)
    for n in names:
        if REGISTRY[n] not in {type(c) for c in model}:
            model = (*model, REGISTRY[n].for_model(model))
    return model


def base_model() -> tuple[Component, ...]:
    """The diagnosis's base: the seed's contact law with a fitted shared mu (``ContactLaw.base``),
    plus the skin-marker registration every held-out evaluation needs (sole and pose
    corrections) and the belt speed on a treadmill. Today's full model is this base plus
    ``damping`` and ``stiffness_exponent`` (``full_model`` parametrises them in the law)."""
    return (ContactLaw.base(), SoleCorrection(), PoseCorrection(), BeltSpeed())


def bare_seed_model() -> tuple[Component, ...]:
    """The seed's law (``ContactLaw.base``) without any correction: the model against which
    ``sole_geometry`` and ``kinematic_correction`` are scored."""
    return (ContactLaw.base(),)


def seed_model(mu: float = 0.0) -> tuple[Component, ...]:
    """The seed report's configuration: contact law only, n = 1, c = 0, fixed points."""
    return (ContactLaw.seed(mu),)


def full_model() -> tuple[Component, ...]:
    """Today's model: contact law with k per unit, shared n, c, mu; sole and pose corrections;
    belt-speed correction (treadmill trials only)."""
    return (ContactLaw(), SoleCorrection(), PoseCorrection(), BeltSpeed())


__all__ = [
    "EFFECTS",
    "REGISTRY",
    "BeltSpeed",
    "bare_seed_model",
    "base_model",
    "Component",
    "ContactLaw",
    "DecodeContext",
    "Param",
    "PoseCorrection",
    "Scope",
    "SoleCorrection",
    "full_model",
    "model_from_names",
    "register",
    "seed_model",
]
