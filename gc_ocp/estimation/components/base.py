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
* states what it does to the per-frame function (:meth:`signature`, part of the cache key).

The problem builder knows no component by type: a new effect is one new file with one class,
plus one line in :data:`gc_ocp.estimation.components.REGISTRY`.
"""

from __future__ import annotations

from dataclasses import astuple, dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np

from gc_ocp.errors import ModelError

if TYPE_CHECKING:  # pragma: no cover
    from gc_ocp.estimation.frame import Frame
    from gc_ocp.estimation.variables import Variables
    from gc_ocp.foot import SoleLayout
    from gc_ocp.stance import StanceData

Scope = Literal["global", "trial", "stance"]


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
        from gc_ocp.estimation.variables import block_values

        return block_values(self.specs, self.x, self.cov, key)


def unique_labels(name: str, stances) -> None:
    """Stance-scope variables are keyed by stance label (so that a result can warm-start a fit
    on a subset of its stances, e.g. a cross-validation fold): the labels must be unique."""
    labels = [st.label for st in stances]
    if len(set(labels)) != len(labels):
        raise ModelError(f"{name}: stance labels must be unique, but got {labels}")


class Component:
    """Base class: every hook is a no-op, so a component implements only what it does."""

    name: str = "component"
    scope: Scope = "global"
    neutral_at_zero: bool = False
    """True when all its decision variables at zero leave the model as if it were absent."""

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
        law's own damping at zero, so that it is not estimated twice). Default: unchanged."""
        return model

    def prepare(self, stances: list[StanceData]) -> list[StanceData]:
        """The stances this component's model is fitted on (e.g. a denser sole layout).
        Default: unchanged."""
        return stances

    def observe(self, stance: StanceData, wrench: np.ndarray) -> StanceData:
        """Synthetic data: ``stance`` as the plate would record the model ``wrench`` ``(T, 6)``
        if this component were the truth (e.g. a clock offset delays it). Default: measured =
        wrench. Used by :func:`gc_ocp.bench.recovery.simulate`."""
        return stance

    # --- variables ----------------------------------------------------------------------------
    def declare(self, variables: Variables, stances: list[StanceData]) -> None:
        """Declare this component's decision variables."""

    # --- per-frame inputs ---------------------------------------------------------------------
    def slot_sizes(self, layout: SoleLayout) -> dict[str, int]:
        """``{slot: size}`` of the per-frame inputs this component gives (linear in x)."""
        return {}

    def slots(self, variables: Variables, index: int, stance: StanceData) -> dict:
        """``{slot: MX (size, 1) or (size, T)}`` for stance ``index``; linear in ``variables.x``."""
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

    def with_prior_scale(self, factor: float) -> Component:
        """The component with its prior widths multiplied by ``factor`` (fit's continuation)."""
        return self

    @property
    def has_prior_scale(self) -> bool:
        return type(self).with_prior_scale is not Component.with_prior_scale


__all__ = ["Component", "DecodeContext", "Scope"]
