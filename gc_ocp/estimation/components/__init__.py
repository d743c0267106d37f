"""Model components: each carries its own variables, its per-frame physics and its result block.

A model is a tuple of components (see :mod:`.base` for the protocol). Presets:

>>> seed = seed_model()        # the seed report: k per unit, n = 1, c = 0, fixed friction
>>> full = full_model()        # contact law with n, c, mu free; sole, pose and belt corrections
>>> [c.name for c in seed], [c.name for c in full]
(['contact'], ['contact', 'sole', 'pose', 'belt'])

:data:`REGISTRY` maps a component's name to its class: the vocabulary of model names
(``model_from_names(["damping"], base=base_model())``). A new component is one file in this folder
plus one line in :data:`REGISTRY` (an effect's class says it is a diagnosis candidate and how the
benchmark injects it, :mod:`.base`); :data:`EFFECTS` is derived from it: the diagnosis's
candidate effects, each a name :func:`model_from_names` takes.

>>> EFFECTS[:3]
('damping', 'stiffness_exponent', 'sole_geometry')
>>> [c.name for c in model_from_names([EFFECTS[0]], base=base_model())]
['contact', 'sole', 'pose', 'belt', 'damping']
"""

from __future__ import annotations

import importlib

from gc_ocp.errors import InputError, ModelError, UnknownNameError, names_of
from gc_ocp.estimation.components.base import Component, DecodeContext, Scope, SummaryRow
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
    "belt_speed": BeltSpeed,
    # the candidate effects, in the diagnosis's order (its figures list them so)
    "damping": Damping,
    "stiffness_exponent": StiffnessExponent,
    "sole_geometry": SoleCorrection,
    "kinematic_correction": PoseCorrection,
    "contact_density": ContactDensity,
    "toe_joint": ToeJoint,
    "ground_offset": GroundOffset,
    "time_offset": TimeOffset,
    "friction": StribeckFriction,
}
"""Component classes by name: the vocabulary of model configurations and of the diagnosis
(``docs/effects.md``). A component instance's ``name`` keys its variables and its result block
(``"sole"``, ``"pose"``, ``"belt"`` for the three corrections that predate the vocabulary).
Its order is the order of :data:`EFFECTS`."""


def register(name: str, cls: type[Component] | str) -> type[Component]:
    """Add a component class to :data:`REGISTRY` under ``name`` (last in its order) and derive
    :data:`EFFECTS` again; returns the class.

    ``cls`` may be given as ``"module:Class"`` (imported now), so that a component file of this
    folder is registered by one line at the end of this module::

        register("ground_tilt", "gc_ocp.estimation.components.ground_tilt:GroundTilt")

    A module that imported :data:`EFFECTS` before a run-time registration keeps the tuple it
    imported: name a component registered from user code in ``candidates=`` (the diagnosis
    accepts any registered name)."""
    global EFFECTS
    if isinstance(cls, str):
        module, _, attr = cls.partition(":")
        if not attr:
            raise ModelError(f'register("{name}", "{cls}"): give the class as "module:Class"')
        cls = getattr(importlib.import_module(module), attr)
    if not (isinstance(cls, type) and issubclass(cls, Component)):
        raise ModelError(
            f'register("{name}", ...): a Component subclass is needed, but got {cls!r}'
        )
    if name in REGISTRY and REGISTRY[name] is not cls:
        raise ModelError(
            f'A component named "{name}" is already registered ({REGISTRY[name].__name__})'
        )
    REGISTRY[name] = cls
    EFFECTS = candidate_effects()
    return cls


def candidate_effects() -> tuple[str, ...]:
    """The registered names whose class is a diagnosis candidate (``Component.candidate``), in
    registry order: :data:`EFFECTS` as the registry stands now (it also lists components
    registered at run time by :func:`register`)."""
    return tuple(name for name, cls in REGISTRY.items() if cls.candidate)


def component_class(class_name: str) -> type[Component] | None:
    """The component class called ``class_name`` (a result's ``components`` value): a registered
    class, else any imported subclass of :class:`Component` (e.g. ``DenseSoleCorrection``, which
    the contact density puts in the model); None when none is imported."""
    for cls in REGISTRY.values():
        if cls.__name__ == class_name:
            return cls
    todo = list(Component.__subclasses__())
    while todo:
        cls = todo.pop(0)
        if cls.__name__ == class_name:
            return cls
        todo += cls.__subclasses__()
    return None


def describe_block(class_name: str, block: dict) -> list[SummaryRow]:
    """The rows (:class:`SummaryRow`: label, value, se, unit) of a result block of the component
    class ``class_name`` (``Component.describe``); none when that class is not imported or shows
    no rows of its own."""
    cls = component_class(class_name)
    return [] if cls is None else list(cls.describe(block))


def model_from_names(names, base: tuple = ()) -> tuple[Component, ...]:
    """``base`` plus the registered components ``names`` (the defaults for the model they join,
    :meth:`Component.for_model`), skipping those whose class is already in ``base``.
    ``names``: a list of registry names (one name alone is one name), e.g. of
    :data:`EFFECTS`.

    >>> import gc_ocp
    >>> model = gc_ocp.model_from_names(["friction"], base=gc_ocp.full_model())
    >>> [c.name for c in model]
    ['contact', 'sole', 'pose', 'belt', 'friction']
    """
    names = names_of(names, "component names")
    unknown = [n for n in names if n not in REGISTRY]
    if unknown:
        raise UnknownNameError(f"Unknown component(s) {unknown}; choose from {sorted(REGISTRY)}")
    # a base named as diagnose() names it ("registered") was read letter by letter
    if not isinstance(base, tuple | list) or not all(isinstance(c, Component) for c in base):
        raise InputError(
            f"base={base!r}: give a tuple of components, e.g. base=base_model() (the "
            "diagnosis's 'registered' base), full_model() or seed_model()"
        )
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
    """The seed report's configuration: contact law only, k per unit, n = 1, c = 0, fixed
    points, the friction coefficient fixed at ``mu`` [-] (default 0: no friction force)."""
    return (ContactLaw.seed(mu),)


def full_model() -> tuple[Component, ...]:
    """Today's model: contact law with k per unit, shared n, c, mu; sole and pose corrections;
    belt-speed correction (treadmill trials only)."""
    return (ContactLaw(), SoleCorrection(), PoseCorrection(), BeltSpeed())


EFFECTS: tuple[str, ...] = candidate_effects()
"""The candidate model extensions of the diagnosis, by registry name: every registered class
with ``candidate = True``, in :data:`REGISTRY` order (derived again by :func:`register`; a
module that imported it before keeps its tuple, :func:`candidate_effects` is the registry now).
Each name is accepted by :func:`model_from_names` and by the diagnosis's ``candidates``
(the examples of this module's docstring and of :func:`gc_ocp.diagnose`, which run as tests:
doctest does not see this string)."""


__all__ = [
    "EFFECTS",
    "REGISTRY",
    "BeltSpeed",
    "bare_seed_model",
    "base_model",
    "candidate_effects",
    "component_class",
    "describe_block",
    "Component",
    "ContactLaw",
    "DecodeContext",
    "Param",
    "PoseCorrection",
    "Scope",
    "SoleCorrection",
    "SummaryRow",
    "full_model",
    "model_from_names",
    "register",
    "seed_model",
]
