"""Model components: each carries its own variables, its per-frame physics and its result block.

A model is a tuple of components (see :mod:`.base` for the protocol). Presets:

>>> seed = seed_model()        # the seed report: k per unit, n = 1, c = 0, fixed friction
>>> full = full_model()        # contact law with n, c, mu free; sole, pose and belt corrections

:data:`REGISTRY` maps a component's name to its class: the vocabulary of model names
(``model_from_names(["contact", "sole", "pose"])``). A new component is one file in this folder
plus one line here.
"""

from __future__ import annotations

from gc_ocp.errors import ModelError
from gc_ocp.estimation.components.base import Component, DecodeContext, Scope
from gc_ocp.estimation.components.belt import BeltSpeed
from gc_ocp.estimation.components.contact import ContactLaw, Param
from gc_ocp.estimation.components.pose import PoseCorrection
from gc_ocp.estimation.components.sole import SoleCorrection

REGISTRY: dict[str, type[Component]] = {
    "contact": ContactLaw,
    "sole": SoleCorrection,
    "pose": PoseCorrection,
    "belt": BeltSpeed,
}
"""Component classes by name (the default ``name`` of each)."""


def register(name: str, cls: type[Component]) -> None:
    """Add a component class to :data:`REGISTRY` under ``name``."""
    if name in REGISTRY and REGISTRY[name] is not cls:
        raise ModelError(
            f'A component named "{name}" is already registered ({REGISTRY[name].__name__})'
        )
    REGISTRY[name] = cls


def model_from_names(names) -> tuple[Component, ...]:
    """A model of the registered components ``names``, each with its default settings."""
    unknown = [n for n in names if n not in REGISTRY]
    if unknown:
        raise ModelError(f"Unknown component(s) {unknown}; choose from {sorted(REGISTRY)}")
    return tuple(REGISTRY[n]() for n in names)


def seed_model(mu: float = 0.0) -> tuple[Component, ...]:
    """The seed report's configuration: contact law only, n = 1, c = 0, fixed points."""
    return (ContactLaw.seed(mu),)


def full_model() -> tuple[Component, ...]:
    """Today's model: contact law with k per unit, shared n, c, mu; sole and pose corrections;
    belt-speed correction (treadmill trials only)."""
    return (ContactLaw(), SoleCorrection(), PoseCorrection(), BeltSpeed())


__all__ = [
    "REGISTRY",
    "BeltSpeed",
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
