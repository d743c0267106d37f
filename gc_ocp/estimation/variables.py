"""Decision variables of the estimator: named blocks with scaling, bounds and Gaussian priors.

Every variable block has a key (a tuple such as ``("contact", "k", "left", "PL")`` or
``("pose", "walk:right@0.41s", "trans")``) and is *scaled* so that O(1) is a typical magnitude:

* ``parameter``: a physical parameter, optimised as its value or (``log=True``) its logarithm,
  with an optional Gaussian prior around its initial value;
* ``prior``: a vector with prior N(0, sigma^2), stored in units of sigma (the prior term is
  ``0.5 |z|^2``).

:class:`Variables` collects them in two passes (components declare, then the builder finalises
the symbolic vector and components read their blocks back). :class:`VariableSpec` is the plain
data describing one block: results carry a list of them, so that a decision vector can be
decoded, or used as a warm start of another model, without any CasADi object.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass

import casadi as ca
import numpy as np

from gc_ocp.errors import InputError, ModelError


@dataclass(frozen=True)
class VariableSpec:
    """One block of the decision vector (plain data).

    key: its name; start, size: its slice of the decision vector; kind: ``"param"`` or
    ``"prior"``; log: stored as log(value); scale: ``(size,)`` physical units per stored unit
    (prior variables: their sigma); x0, lb, ub: ``(size,)`` initial value and bounds (stored
    units); prior_weight, prior_mean: ``(size,)`` prior residual ``w (z - m)`` (0: no prior);
    shown: ``(factor, offset, unit)``, how a person reads a physical value ``v`` of the block
    (``factor * v + offset`` in ``unit``: the stiffness exponent's stored ``n - 1`` as ``n``, an
    angle's radians in degrees), for messages that quote it (:mod:`~gc_ocp.estimation.flags`).
    """

    key: tuple
    start: int
    size: int
    kind: str
    log: bool
    scale: np.ndarray
    x0: np.ndarray
    lb: np.ndarray
    ub: np.ndarray
    prior_weight: np.ndarray
    prior_mean: np.ndarray
    shown: tuple = (1.0, 0.0, "")

    @property
    def slice(self) -> slice:
        return slice(self.start, self.start + self.size)

    def physical(self, z: np.ndarray) -> np.ndarray:
        """Physical values of the stored values ``z`` of this block."""
        z = np.asarray(z, float)
        return np.exp(z) if self.log else z * self.scale

    def reading(self, v: float) -> str:
        """The physical value ``v`` as a person reads it (:attr:`shown`), e.g. ``"1.35"``."""
        factor, offset, unit = self.shown
        return f"{factor * float(v) + offset:.4g}{unit}"

    def to_json(self) -> dict:
        return {
            "key": list(self.key),
            "start": self.start,
            "size": self.size,
            "kind": self.kind,
            "log": self.log,
            **{
                f: getattr(self, f).tolist()
                for f in ("scale", "x0", "lb", "ub", "prior_weight", "prior_mean")
            },
            "shown": list(self.shown),
        }

    @classmethod
    def from_json(cls, d: dict) -> VariableSpec:
        arrays = {
            f: np.asarray(d[f], float)
            for f in ("scale", "x0", "lb", "ub", "prior_weight", "prior_mean")
        }
        shown = d.get("shown", (1.0, 0.0, ""))  # a fit.json of before 2026-12-02: as stored
        return cls(
            tuple(d["key"]),
            int(d["start"]),
            int(d["size"]),
            d["kind"],
            bool(d["log"]),
            **arrays,
            shown=(float(shown[0]), float(shown[1]), str(shown[2])),
        )


def require_start_within(
    name: str, value, lower: float, upper: float, read=repr, fix: str = ""
) -> None:
    """The rule for every estimated parameter's start, in one place: a real number within
    ``[lower, upper]``, else one :class:`InputError` naming ``name``, the start and the bounds
    as ``read`` shows a value, and the fix (``fix``: where the start was given). Ipopt moved a
    start outside its bounds inside silently (its bound_push): a fit from a start the user did
    not get, under a prior still centred outside. :class:`ContactLaw` checks its ``Param``\\ s
    when made (the error at the user's line), :meth:`Variables.parameter` every component's."""
    if not (isinstance(value, numbers.Real) and lower <= value <= upper):
        raise InputError(
            f"the start of {name}, {read(value)}, lies outside its bounds "
            f"[{read(lower)}, {read(upper)}]: give a start within them{fix}, or widen its bounds"
        )


class Variables:
    """The registry of decision variables (declare pass, then :meth:`finalize`, then use pass)."""

    def __init__(self) -> None:
        self._specs: dict[tuple, VariableSpec] = {}
        self._n = 0
        self.x: ca.MX | None = None

    # --- declaration pass ---------------------------------------------------------------------
    def _add(
        self,
        key,
        size,
        x0,
        lb,
        ub,
        kind,
        scale,
        log,
        prior_weight=0.0,
        prior_mean=0.0,
        shown=(1.0, 0.0, ""),
    ) -> None:
        key = tuple(key)
        if self.x is not None:
            raise ModelError(f"Variable {key} declared after the variables were finalised")
        if key in self._specs:
            raise ModelError(
                f"Variable {key} declared twice; two components claim the same parameter."
            )

        def vec(v):
            return np.array(np.broadcast_to(np.asarray(v, float), size), float)

        self._specs[key] = VariableSpec(
            key,
            self._n,
            size,
            kind,
            log,
            vec(scale),
            vec(x0),
            vec(lb),
            vec(ub),
            vec(prior_weight),
            vec(prior_mean),
            tuple(shown),
        )
        self._n += size

    def parameter(
        self,
        key: tuple,
        value: float,
        lower: float,
        upper: float,
        log: bool = False,
        prior_sigma: float | None = None,
        shown: tuple = (1.0, 0.0, ""),
    ) -> None:
        """A physical parameter. ``log``: optimise log(value) (value > 0). ``prior_sigma``: optional
        Gaussian prior centred on ``value``, in the optimised units (log units when ``log``).
        ``shown``: how a person reads it (:attr:`VariableSpec.shown`).

        ``value``, the start, lies within ``[lower, upper]``: one outside is an
        :class:`InputError` naming the parameter (a component's ``value`` a person gave, e.g.
        ``Damping(value=20)`` with the bounds [0, 10] s/m; Ipopt moved it inside silently). A
        start the package computes is clipped into the bounds before it gets here
        (:meth:`~gc_ocp.estimation.components.contact.ContactLaw.with_initial_k`,
        :func:`~gc_ocp.estimation.starts.rescaled_start`)."""
        factor, offset, unit = shown
        require_start_within(
            "/".join(map(str, key)),
            value,
            lower,
            upper,
            read=lambda v: f"{factor * v + offset:g}{unit}",
            fix=" (the component's value)",
        )
        w = 0.0 if prior_sigma is None else 1.0 / prior_sigma
        if log:
            z0 = np.log(value)
            lo = np.log(max(lower, 1e-300))
            self._add(key, 1, z0, lo, np.log(upper), "param", 1.0, True, w, z0, shown)
        else:
            self._add(key, 1, value, lower, upper, "param", 1.0, False, w, value, shown)

    def prior_variable(self, key: tuple, size: int, sigma, bound) -> None:
        """A vector with Gaussian prior N(0, sigma^2), stored in units of sigma, bounded by +-bound.
        ``sigma`` and ``bound``: scalars, or arrays of length ``size`` (one per entry)."""
        sig = np.broadcast_to(np.asarray(sigma, float), size)
        if not np.all(np.isfinite(sig) & (sig > 0)):  # its bounds were 0/0: Ipopt's assertion
            raise InputError(
                f"the prior width of {'/'.join(map(str, key))} must be a number > 0, but got "
                f"{np.asarray(sigma).tolist()} [SI]: a correction of width 0 is none; leave its "
                "component out of the model instead"
            )
        b = np.broadcast_to(np.asarray(bound, float), size) / sig
        self._add(key, size, 0.0, -b, b, "prior", sig, False, 1.0, 0.0)

    def finalize(self) -> ca.MX:
        self.x = ca.MX.sym("x", self._n)
        return self.x

    # --- use pass -----------------------------------------------------------------------------
    def get(self, key: tuple, raw: bool = False):
        """Symbolic physical value of a declared block; ``raw``: log value for log variables."""
        if self.x is None:
            raise ModelError("Variables.get() before finalize()")
        spec = self.spec(key)
        z = self.x[spec.slice]
        if spec.log:
            return z if raw else ca.exp(z)
        scale = spec.scale
        return z * (float(scale[0]) if np.all(scale == scale[0]) else ca.DM(scale))

    def has(self, key: tuple) -> bool:
        return tuple(key) in self._specs

    def spec(self, key: tuple) -> VariableSpec:
        try:
            return self._specs[tuple(key)]
        except KeyError:
            raise ModelError(
                f"No variable {tuple(key)}; declared: {list(self._specs)[:10]} ..."
            ) from None

    @property
    def specs(self) -> list[VariableSpec]:
        return list(self._specs.values())

    @property
    def size(self) -> int:
        return self._n

    def vector(self, field_: str) -> np.ndarray:
        return (
            np.concatenate([getattr(s, field_) for s in self._specs.values()])
            if self._specs
            else np.zeros(0)
        )


def spec_index(specs: list[VariableSpec]) -> dict[tuple, VariableSpec]:
    return {s.key: s for s in specs}


def block_values(specs: list[VariableSpec], x: np.ndarray, cov: np.ndarray | None, key: tuple):
    """Physical values and standard errors of block ``key`` at ``x`` (delta method for log blocks)."""
    s = spec_index(specs)[tuple(key)]
    z = np.asarray(x, float)[s.slice]
    val = s.physical(z)
    if cov is None:
        se = np.full(s.size, np.nan)
    else:
        sd = np.sqrt(np.maximum(np.diag(cov)[s.slice], 0.0))
        se = val * sd if s.log else sd * s.scale
    return val, se


__all__ = ["Variables", "VariableSpec", "block_values", "spec_index"]
