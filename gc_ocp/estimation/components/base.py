"""The component protocol: what a model extension provides to the estimator.

A model is a tuple of components. Each component

* declares its decision variables (:meth:`Component.declare`, named keys, scaled, with priors and
  bounds; :mod:`gc_ocp.estimation.variables`);
* names the per-frame inputs it needs and gives them as expressions *linear* in the decision
  vector (:meth:`slot_sizes`, :meth:`slots`), and any extra numeric per-frame columns
  (:meth:`data_sizes`, :meth:`data`);
* edits the symbolic frame (:class:`gc_ocp.estimation.frame.Frame`) in the stage it belongs to
  (:meth:`edit_segments`, :meth:`edit_points`, :meth:`edit_contact`, :meth:`edit_measured`);
* decodes its own block of the result (:meth:`decode`, plain data keyed by :attr:`name`);
* returns itself with its values fixed at a result's block for a held-out evaluation
  (:meth:`frozen`; ``scope`` says what a held-out stance re-estimates);
* states what it does to the per-frame function (:meth:`signature`, part of the cache key);
* says how its block reads (:meth:`describe`: rows of label, value, SE, unit; used by
  ``EstimationResult.summary`` and the report for every block that has rows).

A component that is a candidate effect of the diagnosis also says so and how the withheld-effect
benchmark (:mod:`gc_ocp.bench.withheld`) injects it into a truth:

* :attr:`candidate` (True: in :data:`~gc_ocp.estimation.components.EFFECTS`, offered by the
  diagnosis, ``--effects``);
* :attr:`benchmark_values` (``{"moderate": v, "strong": v}``) and :meth:`inject` (a frozen base
  plus the effect at ``v``); an effect of the *data* rather than of the model (a kinematic
  error) says so with :meth:`benchmark_kinematic_error` instead; units whose fitted sole
  offsets the truth must leave at nominal: :attr:`benchmark_nominal_units`.

A component that changes another one asks it through a hook of the component being changed
(no-op by default), never by its type: :meth:`law_estimates` / :meth:`with_law_fixed` (the
contact law's own parameters, e.g. damping owns ``c``), :meth:`for_layout` (a denser sole).

The problem builder, the diagnosis and the benchmark know no component by type: a new effect is
one new file with one class, plus one line in :data:`gc_ocp.estimation.components.REGISTRY`
(``docs/effects.md``).
"""

from __future__ import annotations

from dataclasses import astuple, dataclass, replace
from typing import TYPE_CHECKING, Any, ClassVar, Literal, NamedTuple

import numpy as np

from gc_ocp.errors import InputError, ModelError
from gc_ocp.estimation.flags import LAW_GIVERS
from gc_ocp.estimation.variables import block_values
from gc_ocp.values import BOUND_TEXT, se_text

if TYPE_CHECKING:  # pragma: no cover
    from gc_ocp.estimation.frame import Frame
    from gc_ocp.estimation.variables import Variables
    from gc_ocp.foot import SoleLayout
    from gc_ocp.stance import StanceData

Scope = Literal["global", "trial", "stance"]


class SummaryRow(NamedTuple):
    """One line of a component's block as it is shown (:meth:`Component.describe`).

    label: what it is (``"c"``, ``"left onset"``, ``"test_small:right@0.407s dz"``); value and
    se: in ``unit`` (se 0 for a fixed value, NaN when unknown); unit: ``"s/m"``, ``"mm"``,
    ``"deg"``, ``"-"`` (dimensionless); key: the row's variable after its block's name
    (``("c",)``, ``("onset", "left")``), as the fit's flags name it (``"damping/c"``), so that a
    value at its bound is shown as one; ``()``: not one variable."""

    label: str
    value: float
    se: float
    unit: str
    key: tuple = ()

    def text(self, bound: bool = False) -> str:
        """``"label = value ± se unit"`` (4 and 2 significant digits); ``bound``: the variable is
        flagged at its bound (:data:`~gc_ocp.values.BOUND_TEXT` in place of the SE)."""
        unit = "" if self.unit in ("", "-") else f" {self.unit}"
        value = f"{self.value:.4g}"
        if bound:
            return f"{self.label} = {value}{unit} {BOUND_TEXT}"
        return f"{self.label} = {value} ± {se_text(self.se, value)}{unit}"


@dataclass
class DecodeContext:
    """What :meth:`Component.decode` may read (all plain NumPy).

    specs: the variable blocks; x: the decision vector; cov: its covariance (or None); stances;
    slot_values: ``slot_values(i, name) -> (T_i, size)`` per-frame value of a slot on stance i;
    slot_rows: ``slot_rows(i, name) -> (size, nx)`` its derivative in x on the first frame
    (slots are linear in x: the rows of ``A``), for standard errors by the delta method.
    """

    specs: list
    x: np.ndarray
    cov: np.ndarray | None
    stances: list
    slot_values: object
    slot_rows: object = None

    def slot_value_se(self, i: int, name: str) -> tuple[np.ndarray, np.ndarray]:
        """Value (first frame) and standard error of every entry of slot ``name`` on stance i."""
        val = np.asarray(self.slot_values(i, name))[0]
        if self.cov is None or self.slot_rows is None:
            return val, np.full(val.shape, np.nan)
        rows = np.asarray(self.slot_rows(i, name))
        var = np.einsum("ij,jk,ik->i", rows, self.cov, rows)
        return val, np.sqrt(np.maximum(var, 0.0))

    def index(self):
        return {s.key: s for s in self.specs}

    def values(self, key: tuple):
        """Physical values and standard errors of the block ``key``."""
        return block_values(self.specs, self.x, self.cov, key)


def per_axis(width) -> np.ndarray:
    """A prior width given as one value or one per axis (x, y, z), as the three values
    ``(3,)`` (read-only)."""
    return np.broadcast_to(np.asarray(width, float), 3)


def unique_labels(name: str, stances) -> None:
    """Stance-scope variables are keyed by stance label (so that a result can warm-start a fit
    on a subset of its stances, e.g. a cross-validation fold): the labels must be unique."""
    labels = [st.label for st in stances]
    if len(set(labels)) != len(labels):
        raise ModelError(f"{name}: stance labels must be unique, but got {labels}")


class Component:
    """Base class: every hook is a no-op, so a component implements only what it does.

    A model is a tuple of components (``gc_ocp.full_model()``); the builder composes them
    through their hooks and never tests a component's type (``docs/architecture.md``, *The
    component protocol*, lists the hooks). A new effect is one frozen-dataclass subclass in one
    file and one :func:`~gc_ocp.estimation.components.register` line: take
    :class:`~gc_ocp.estimation.components.damping.Damping` (``components/damping.py``: one
    variable in one slot of the contact law) as the template and ``docs/effects.md``, *Adding an
    effect*, as the checklist.

    >>> from dataclasses import dataclass
    >>> import gc_ocp
    >>> @dataclass(frozen=True)
    ... class GroundTilt(gc_ocp.Component):
    ...     name: str = "ground_tilt"
    ...     candidate = True  # offered by the diagnosis, listed in gc_ocp.EFFECTS
    ...     # declare, slot_sizes, slots, edit_contact, decode, frozen, signature: as damping.py
    >>> [c.name for c in (*gc_ocp.base_model(), GroundTilt())]
    ['contact', 'sole', 'pose', 'belt', 'ground_tilt']

    Registered, it is a name of the vocabulary:

    >>> # skipped: the registry is the process's (the tests would all see ground_tilt)
    >>> gc_ocp.register("ground_tilt", GroundTilt)  # doctest: +SKIP
    <class '__main__.GroundTilt'>
    >>> model = gc_ocp.model_from_names(["ground_tilt"], base=gc_ocp.base_model())  # doctest: +SKIP
    """

    name: str = "component"
    scope: Scope = "global"
    neutral_at_zero: bool = False
    """True when all its decision variables at zero leave the model as if it were absent."""

    # --- as a candidate effect of the diagnosis and of the withheld-effect benchmark ------------
    candidate: ClassVar[bool] = False
    """True when the diagnosis offers it as a candidate effect: its registered name is then in
    :data:`~gc_ocp.estimation.components.EFFECTS` (in registry order) and accepted by
    ``--effects``."""

    one_step_from_own_fit: ClassVar[bool] = False
    """True when the diagnosis's calibrated test takes its one Gauss-Newton step from this
    effect's own fit (refitted on every draw of the null) instead of from the parent's solution
    with this effect's variables neutral (:mod:`gc_ocp.diagnosis.onestep`): for an effect whose
    response is so curved at its neutral value that one step from there misses most of what its
    refit gains. Default False (the neutral point is exact for the null and costs no refit)."""

    law_parameter: ClassVar[str | None] = None
    """The contact law's parameter this component gives (damping's ``"c"``, the exponent's
    ``"n"``): the law's own variable of it is then fixed and this component's value is the
    law's, so a flag of this component's variable at its bound is the law's
    (:func:`~gc_ocp.estimation.flags.law_at_bound`, which reads it from
    :data:`~gc_ocp.estimation.flags.LAW_GIVERS`, filled by :meth:`__init_subclass__`)."""

    def __init_subclass__(cls, **kwargs) -> None:
        super().__init_subclass__(**kwargs)
        if cls.law_parameter is not None:  # ``name``: the class's default block name
            LAW_GIVERS[cls.name] = cls.law_parameter

    plate_mimicked: ClassVar[bool] = False
    """True when plates a few millimetres off or a percent or two mis-scaled (the mismatch
    family's opt-in plate calibration member) give this effect gains of its kind: the diagnosis
    then notes a claim of it made under a null without that member, with how to check it
    (:func:`gc_ocp.diagnosis.diagnose.plate_note`). Measured, not guessed: with the member in
    the null the effect's spread grew, or without it such plate errors alone had it named
    (``benchmarks/plate_member_power/README.md``)."""

    relative_cost: ClassVar[float] = 1.0
    """About how many times a fit with this effect added costs a fit of the base: the order in
    which the diagnosis's first round hands its candidates to the workers, the dearest first, so
    that the longest does not start last (later rounds order by the time each took in the
    round before). Scheduling only: no result depends on it."""

    benchmark_values: ClassVar[dict[str, Any] | None] = None
    """The withheld-effect benchmark's injected value per magnitude, ``{"small": v, "moderate":
    v, "strong": v}`` (physical units, the effect's own; ``small`` half the moderate's departure
    from neutral, ``strong`` about twice it: :data:`gc_ocp.bench.truth.MAGNITUDES`;
    :func:`gc_ocp.bench.truth.injected_values` is made of these), given to :meth:`inject`. None:
    the benchmark cannot inject it."""

    benchmark_nominal_units: ClassVar[tuple[str, ...]] = ()
    """Sole units the benchmark's truth keeps at their nominal point when this effect is
    injected (the base fit's offsets of these units are reset to zero), e.g. the toe tip under a
    toe joint."""

    @classmethod
    def inject(cls, base: tuple, value: Any, stances: list, rng: np.random.Generator) -> tuple:
        """The withheld-effect benchmark's truth: ``base`` (a frozen base fit) plus this effect
        at ``value`` (one of :attr:`benchmark_values`) on ``stances`` (the true motion); random
        signs or patterns drawn from ``rng``. Default: refused (no injection declared)."""
        raise ModelError(
            f"{cls.__name__} declares no benchmark injection (benchmark_values and inject)"
        )

    @classmethod
    def benchmark_kinematic_error(cls, value: Any) -> tuple[float, float, float] | None:
        """For an effect of the *data* rather than of the model: the kinematic error
        ``(marker noise [m], drift [m], drift [deg])`` through which the benchmark's fitter sees
        the foot when this effect at ``value`` is the truth (it replaces the realism's). Default
        None: the effect is in the truth model (:meth:`inject`)."""
        return None

    # --- configuration ------------------------------------------------------------------------
    @classmethod
    def present_in(cls, model: tuple) -> bool:
        """True when ``model`` already has this component's physics, so that the diagnosis does
        not offer it as a candidate. Default: a component of this class is in ``model``."""
        return any(isinstance(c, cls) for c in model)

    @classmethod
    def for_model(cls, model: tuple) -> Component:
        """This component with the default settings for a model whose other components are
        ``model`` (what :func:`model_from_names` adds). Default: ``cls()``."""
        return cls()

    def configure(self, model: tuple) -> tuple:
        """The model this component needs around it (e.g. a damping effect fixes the contact
        law's own damping at zero, so that it is not estimated twice), asked of the other
        components through their hooks (:meth:`with_law_fixed`, :meth:`for_layout`), never by
        their type. Default: unchanged."""
        return model

    # --- hooks other components call (no-ops unless the component has what is asked for) -------
    def law_estimates(self, param: str) -> bool:
        """True when this component is a contact law that estimates its own parameter ``param``
        (``"k"``, ``"n"``, ``"c"``, ``"mu"``). Default: False."""
        return False

    def with_law_fixed(self, param: str, value: float | dict) -> Component:
        """This component with the contact-law parameter ``param`` fixed at ``value`` (SI; a
        float or per side/unit dict), if it is a contact law. Default: unchanged."""
        return self

    def with_law_smoothing(
        self,
        depth_factor: float = 1.0,
        slip_factor: float = 1.0,
        depth_form: str | None = None,
        slip_form: str | None = None,
    ) -> Component:
        """This component with its penetration and slip smoothing widths scaled by the factors
        and their forms replaced (``None``: its own), if it is a contact law (the mismatch
        family's truth variant, :mod:`gc_ocp.diagnosis.mismatch`). Default: unchanged."""
        return self

    def for_layout(self, layout: SoleLayout, weights: np.ndarray) -> Component:
        """This component for a sole of the units ``layout``, each a convex combination
        (``weights``, ``(m, n_nominal)``, rows sum to 1) of the nominal units, if it depends on
        the nominal units (the sole correction moves the dense units by the same weights).
        Default: unchanged."""
        return self

    def prepare(self, stances: list[StanceData]) -> list[StanceData]:
        """The stances this component's model is fitted on (e.g. a denser sole layout).
        Default: unchanged."""
        return stances

    def observe(self, stance: StanceData, wrench: np.ndarray) -> StanceData:
        """Synthetic data: ``stance`` as the plate would record the model ``wrench`` ``(T, 6)``
        if this component were the truth (e.g. a clock offset delays it). Default: measured =
        wrench. Used by :func:`gc_ocp.estimation.synthetic.simulate`."""
        return stance

    # --- variables ----------------------------------------------------------------------------
    def declare(self, variables: Variables, stances: list[StanceData]) -> None:
        """Declare this component's decision variables."""

    # --- per-frame inputs ---------------------------------------------------------------------
    def slot_sizes(self, layout: SoleLayout) -> dict[str, int]:
        """``{slot: size}`` of the per-frame inputs this component gives (linear in x)."""
        return {}

    def slots(self, variables: Variables, index: int, stance: StanceData) -> dict:
        """``{slot: MX (size, 1) or (size, T)}`` for stance ``index``; linear in ``variables.x``.
        Never from the plate's data: they enter through :meth:`data` (the slots' linear maps
        are cached by their expression, :data:`~gc_ocp.estimation.problem.SLOT_MAP_CACHE`, so
        slots that read less are shared by more problems)."""
        return {}

    def data_sizes(self, layout: SoleLayout) -> dict[str, int]:
        """``{column: size}`` of the extra numeric per-frame data this component needs."""
        return {}

    def data(self, stance: StanceData) -> dict[str, np.ndarray]:
        """``{column: (T, size)}`` numeric per-frame data for ``stance``."""
        return {}

    # --- the per-frame model (SX), in stage order ---------------------------------------------
    def edit_segments(self, frame: Frame) -> None:
        """Edit segment placements (before the units are placed)."""

    def edit_points(self, frame: Frame) -> None:
        """Edit unit positions and velocities in lab."""

    def edit_contact(self, frame: Frame) -> None:
        """Set the force law, its parameters, the ground and the belt."""

    def edit_measured(self, frame: Frame) -> None:
        """Edit the measured wrench the model is compared with."""

    # --- results ------------------------------------------------------------------------------
    def decode(self, ctx: DecodeContext) -> dict:
        """This component's block of the result (plain data: dicts, lists, floats)."""
        return {}

    @classmethod
    def describe(cls, block: dict) -> list[SummaryRow]:
        """Rows of ``block`` (this component's decoded block) to show: its own parameters with
        standard errors and units. Reads the block only (a result read back from ``fit.json``
        is described the same way). Default: none (the contact law, sole, pose and belt blocks are
        laid out per side by ``EstimationResult.summary`` itself)."""
        return []

    def prior_covariance(self, specs: list, stances: list, x: np.ndarray) -> list[tuple]:
        """``[(cols, C), ...]``: where the true values of this component's prior variables
        ``cols`` (columns of the decision vector, stored units) are *not* the independent
        ``N(0, I)`` draws their prior declares, their covariance ``C`` as estimated at the
        solution ``x`` (e.g. a pose error that the stances of a foot share). The covariance's
        sandwich uses it for the prior's part (:func:`~gc_ocp.estimation.solve._covariance`).
        Default: none (independent)."""
        return []

    def flags(self, block: dict, stances: list) -> list[dict]:
        """Plausibility flags of this component's block (``gc_ocp.estimation.flags.flag``)."""
        return []

    def frozen(self, block: dict) -> Component:
        """The component with its values fixed at ``block`` (held-out evaluation)."""
        return self

    def signature(self) -> tuple:
        """What this component does to the per-frame function (cache key): by default its class
        and its fields (a component whose values only enter through slots should override this
        with the fields that change the expression graph)."""
        return (type(self).__name__, astuple(self) if hasattr(self, "__dataclass_fields__") else ())

    width_fields: ClassVar[tuple[str, ...]] = ()
    """The fields that are prior widths and nothing else: no slot or per-frame function reads
    them. Where they set the ``sigma`` of prior variables (stored in units of it,
    :meth:`~gc_ocp.estimation.variables.Variables.prior_variable`; their bounds may follow),
    two models that differ only there are one problem with its columns rescaled
    (:meth:`~gc_ocp.estimation.problem.EstimationProblem.rescaled`: the continuation's stages
    and the widths' rounds share one solver); where they set a parameter's prior weight (the toe
    hinge's pitch drive), the weights differ and the problem is built again.
    ``tests/test_components.py`` checks every component that has them."""

    def with_prior_scale(self, factor: float) -> Component:
        """The component with its prior widths (:attr:`width_fields`; a scalar or a tuple
        each) multiplied by ``factor`` (fit's continuation)."""

        def scaled(v):
            return v * factor if np.isscalar(v) else tuple(float(a) * factor for a in v)

        if not self.width_fields:
            return self
        return replace(self, **{f: scaled(getattr(self, f)) for f in self.width_fields})

    @property
    def has_prior_scale(self) -> bool:
        return bool(self.width_fields)


def require_model(model, name: str) -> None:
    """``model`` is None or a tuple of components, else :class:`InputError` with the fix."""
    if model is None or (
        isinstance(model, tuple | list) and model and all(isinstance(c, Component) for c in model)
    ):
        return
    raise InputError(
        f"{name}={model!r}: give a tuple of components, e.g. gc_ocp.full_model(); to add "
        "effects by name: gc_ocp.model_from_names(['friction'], "
        "base=gc_ocp.full_model())."
    )


__all__ = ["Component", "DecodeContext", "Scope", "SummaryRow", "require_model"]
