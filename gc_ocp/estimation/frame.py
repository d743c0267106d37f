"""The per-frame model of one foot, composed from the components of a model.

The estimator evaluates one small SX function per frame: ``(D, y) -> (res, wrench)``.

* ``D`` holds the frame's numeric data, by name (:data:`BASE_DATA`, then the columns that
  components add): both foot segments' placement and twist, the measured wrench, its inverse
  sigmas, the ground height, the belt velocity and the reference point.
* ``y`` holds the frame's inputs that depend on the decision vector, by name (*slots*). Every
  slot is *linear* in the decision vector (``y = A x + y0``), so that the gradient and Hessian in
  ``x`` follow from the small per-frame ones in ``y`` and the Hessian keeps its arrow structure.
  A slot that several contributors name is their sum (the builder contributes the nominal sole
  points to ``points_local``; a sole correction adds its offsets to the same slot).

A :class:`Frame` is the symbolic context the components edit, in four stages, in model order::

    edit_segments  (segment placements: e.g. a toe hinge)
    -> the units are placed in lab from their parent segment and ``points_local``
    edit_points    (unit positions / velocities in lab: e.g. a pose correction)
    edit_contact   (force law and its parameters, ground, belt: e.g. the contact law, belt speed)
    -> unit forces summed into the equivalent wrench about the reference point (seed Eqs 4-9)
    edit_measured  (the measured wrench: e.g. a clock offset)

:func:`frame_functions` composes the function for a model and caches it (in memory by the
components' signatures, on disk by the hash of the generated C code: :mod:`.compiled`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import casadi as ca

from gc_ocp.errors import ModelError
from gc_ocp.estimation.compiled import compiled
from gc_ocp.estimation.measurement import CASADI, residual
from gc_ocp.foot import SEGMENTS, SoleLayout

BASE_DATA: tuple[tuple[str, int], ...] = (
    ("hindfoot_R", 9),  # column-major rotation, segment to lab
    ("hindfoot_o", 3),  # origin in lab [m]
    ("hindfoot_v", 3),  # origin velocity in lab [m/s]
    ("hindfoot_w", 3),  # angular velocity in lab [rad/s]
    ("toes_R", 9),
    ("toes_o", 3),
    ("toes_v", 3),
    ("toes_w", 3),
    ("measured", 6),  # measured wrench about the reference point [N, N m]
    ("inv_sigma", 6),  # residual weights [1/N, 1/(N m)]
    ("ground_height", 1),  # [m]
    ("belt_velocity", 3),  # [m/s]
    ("reference", 3),  # [m]
    ("censor_below", 1),  # plate zero threshold [N] (0: none; see .measurement)
)
"""Per-frame numeric data every model has (name, size), in this order in ``D``."""


@dataclass
class Segment:
    """Placement of a foot segment in one frame (SX): rotation to lab, origin, velocities."""

    R: ca.SX
    o: ca.SX
    v: ca.SX
    w: ca.SX


class Layout:
    """Named sub-vectors of a flat vector: ``{name: (start, size)}`` in declaration order."""

    def __init__(self, entries: list[tuple[str, int]]) -> None:
        self.index: dict[str, tuple[int, int]] = {}
        n = 0
        for name, size in entries:
            if name in self.index:
                if self.index[name][1] != size:
                    raise ModelError(
                        f'slot "{name}" declared with sizes {self.index[name][1]} and {size}'
                    )
                continue
            self.index[name] = (n, size)
            n += size
        self.size = n

    def get(self, v, name: str):
        start, size = self.index[name]
        return v[start : start + size]

    def __contains__(self, name: str) -> bool:
        return name in self.index

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.index)


class Frame:
    """Symbolic context of one frame of one foot, edited by the components (see module doc).

    segments: ``{"hindfoot": Segment, "toes": Segment}``; local: ``3 x m`` unit points in their
    parent frames [m]; points, velocities: lists of ``m`` lab 3-vectors (after placement);
    law: law parameters by name (``"k"`` a list of m, ``"n"``, ``"c"``, ``"mu"``, ...);
    unit_force: ``(frame, i) -> F_i`` lab force on unit ``i`` [N] (set by the contact law);
    unit_ground: ``{i: height}`` ground height under unit ``i`` where it differs from
    ``ground_height`` (a tilted or offset plate), read through :meth:`ground`;
    tangential: ``(frame, i, F_n) -> F_t`` (3,) tangential force law replacing the contact law's
    Coulomb friction, or None;
    ground_height, belt_velocity, reference, measured, inv_sigma, censor_below: as in
    :data:`BASE_DATA`.
    """

    def __init__(self, layout: SoleLayout, D: ca.SX, y: ca.SX, data: Layout, slots: Layout) -> None:
        self.layout = layout
        self._D, self._y, self._data, self._slots = D, y, data, slots
        self.segments = {
            s: Segment(
                ca.reshape(self.data(f"{s}_R"), 3, 3), *(self.data(f"{s}_{c}") for c in "ovw")
            )
            for s in SEGMENTS
        }
        self.local = ca.reshape(self.slot("points_local"), 3, layout.n)
        self.points: list[ca.SX] = []
        self.velocities: list[ca.SX] = []
        self.law: dict = {}
        self.unit_force: Callable[[Frame, int], ca.SX] | None = None
        self.unit_forces: list[ca.SX] = []  # each unit's force, set by :meth:`wrench`
        self.unit_ground: dict[int, ca.SX] = {}
        self.tangential: Callable[[Frame, int, ca.SX], ca.SX] | None = None
        self.ground_height = self.data("ground_height")
        self.belt_velocity = self.data("belt_velocity")
        self.reference = self.data("reference")
        self.measured = self.data("measured")
        self.inv_sigma = self.data("inv_sigma")
        self.censor_below = self.data("censor_below")

    def slot(self, name: str) -> ca.SX:
        """The per-frame input ``name`` (SX column)."""
        return self._slots.get(self._y, name)

    def data(self, name: str) -> ca.SX:
        """The per-frame numeric column ``name`` (SX column)."""
        return self._data.get(self._D, name)

    def ground(self, i: int) -> ca.SX:
        """Ground height under unit ``i`` [m]."""
        return self.unit_ground.get(i, self.ground_height)

    def place_units(self) -> None:
        """Unit positions and velocities in lab from their parent segments (rigid points)."""
        for i, parent in enumerate(self.layout.parents):
            s = self.segments[parent]
            r = s.R @ self.local[:, i]
            self.points.append(s.o + r)
            self.velocities.append(s.v + ca.cross(s.w, r))

    def wrench(self) -> ca.SX:
        """Equivalent wrench ``(6,)`` of the unit forces about the reference point (seed Eqs 4-9)."""
        if self.unit_force is None:
            raise ModelError("no component set the unit force law (the model needs a contact law)")
        force = ca.SX.zeros(3)
        moment = ca.SX.zeros(3)
        self.unit_forces = []  # each call composes them anew
        for i in range(self.layout.n):
            fi = self.unit_force(self, i)
            self.unit_forces.append(fi)
            force += fi
            moment += ca.cross(self.points[i] - self.reference, fi)
        return ca.vertcat(force, moment)


@dataclass(frozen=True)
class FrameModel:
    """The composed per-frame functions of one model and the layouts of their inputs.

    frame: ``(D, y) -> (res, wrench, measured, unit_forces)`` (SX; ``measured``: what the wrench
    is compared with, after every ``edit_measured``; ``unit_forces``: ``3 x n``, each unit's
    force in ``lab``); grad, hess: gradient and Hessian in ``y`` of
    ``1/2 |res|^2`` (compiled to C when possible); jac: ``(D, y) -> (res, d res / d y)`` (SX);
    data, slots: the named layouts of ``D`` and ``y``.
    """

    frame: ca.Function
    grad: ca.Function
    hess: ca.Function
    jac: ca.Function
    data: Layout
    slots: Layout


def _compose(layout: SoleLayout, components: tuple, data_entries, slot_entries) -> ca.Function:
    data, slots = Layout(list(data_entries)), Layout(list(slot_entries))
    D = ca.SX.sym("D", data.size)
    y = ca.SX.sym("y", slots.size)
    f = Frame(layout, D, y, data, slots)
    for c in components:
        c.edit_segments(f)
    f.place_units()
    for c in components:
        c.edit_points(f)
    for c in components:
        c.edit_contact(f)
    wrench = f.wrench()
    for c in components:
        c.edit_measured(f)
    res = ca.vertcat(*residual(wrench, f.measured, f.inv_sigma, f.censor_below, CASADI))
    return ca.Function(
        "foot_frame",
        [D, y],
        [res, wrench, f.measured, ca.horzcat(*f.unit_forces)],
        ["D", "y"],
        ["res", "wrench", "measured", "unit_forces"],
    )


def _derivatives(
    frame_fn: ca.Function, nd: int, ny: int
) -> tuple[ca.Function, ca.Function, ca.Function]:
    D = ca.SX.sym("D", nd)
    y = ca.SX.sym("y", ny)
    res = frame_fn(D, y)[0]
    phi = 0.5 * ca.sumsqr(res)
    H, g = ca.hessian(phi, y)
    return (
        ca.Function("frame_grad", [D, y], [g]),
        ca.Function("frame_hess", [D, y], [H]),
        ca.Function("frame_jac", [D, y], [res, ca.jacobian(res, y)]),
    )


@functools.lru_cache(maxsize=32)
def _frame_model(
    key: tuple, layout: SoleLayout, components: tuple, data_entries, slot_entries, compile_: bool
) -> FrameModel:
    frame_fn = _compose(layout, components, data_entries, slot_entries)
    nd = sum(s for _, s in data_entries)
    ny = Layout(list(slot_entries)).size
    g, h, j = _derivatives(frame_fn, nd, ny)
    # the residual stays an SX function (small; CasADi differentiates it when the NLP is built);
    # its gradient and Hessian, which Ipopt evaluates through callbacks, are compiled
    if compile_:
        g, h = compiled([g, h], "gc_ocp_frame")
    return FrameModel(frame_fn, g, h, j, Layout(list(data_entries)), Layout(list(slot_entries)))


def frame_model(
    layout: SoleLayout, components: tuple, data_entries, slot_entries, compile: bool = True
) -> FrameModel:
    """The per-frame functions of ``components`` on ``layout``, built once per process for each
    distinct key: the layout, every component's :meth:`signature` (what it does to the frame),
    and the named data and slot layouts. ``compile=False``: the gradient and Hessian stay SX
    functions (equal to round-off, slower to evaluate, no C compilation): for a model that is
    only evaluated, e.g. a simulated truth whose physics no fit uses."""
    data_entries, slot_entries = tuple(data_entries), tuple(slot_entries)
    key = (layout, tuple(c.signature() for c in components), data_entries, slot_entries)
    return _frame_model(
        key, layout, _KeyedComponents(components, key), data_entries, slot_entries, compile
    )


class _KeyedComponents(tuple):
    """The components, hashed and compared by the cache key only (their values are irrelevant)."""

    def __new__(cls, components, key):
        obj = super().__new__(cls, components)
        obj._key = key
        return obj

    def __hash__(self) -> int:
        return hash(self._key)

    def __eq__(self, other) -> bool:
        return isinstance(other, _KeyedComponents) and self._key == other._key


__all__ = ["BASE_DATA", "Frame", "FrameModel", "Layout", "Segment", "frame_model"]
