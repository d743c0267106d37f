"""Contact laws of one spring-damper unit: ONE symbolic definition, evaluated everywhere.

Each law is written once as a CasADi ``SX`` expression and wrapped in a :class:`casadi.Function`.
The same Function is called symbolically (inside an optimal-control problem) and numerically on
NumPy arrays (through ``Function.map(n)``): there is no hand-written NumPy twin.

Conventions: ``lab`` frame, Z up, SI. The ground is the horizontal plane ``z = ground_height``.

Penetration and its rate (positive when the unit is below the surface)::

    x    = ground_height - p_z          [m]
    xdot = -v_z                         [m/s]

Normal force (Hunt & Crossley, 1975)::

    F_n = k * x^n * max(1 + c * xdot, 0)    if x > 0,   else 0          [N]

k in [N/m^n], n dimensionless, c in [s/m]. Hunt & Crossley (1975, "Coefficient of restitution
interpreted as damping in vibroimpact", J. Appl. Mech. 42:440-445) make the damping term
proportional to ``x^n`` (``c * k * x^n * xdot``) instead of a constant viscous term ``b * xdot``:
the force is then zero at the instant of impact (x = 0) whatever the impact speed, so the contact
force is continuous in time, and the coefficient of restitution depends on impact speed as
observed. The clamp ``max(1 + c*xdot, 0)`` forbids a pulling (adhesive) force during fast
separation.

Tangential force: Coulomb friction opposing sliding relative to the support surface, with a
regularised direction so that it is smooth through zero sliding speed::

    v_s = (v - belt_velocity)_xy                    horizontal sliding velocity [m/s]
    F_t = -mu * F_n * v_s / sqrt(|v_s|^2 + v_eps^2)  [N]

``|F_t| < mu * F_n`` always, and ``-> mu * F_n`` when ``|v_s| >> v_eps``.

Two variants of the normal force:

* ``smooth=False`` (exact, used for the seed reproduction): ``max`` is exact and the force is
  exactly zero for x <= 0 (a ``casadi.if_else`` guard, so derivatives are zero there too).
* ``smooth=True`` (for gradient-based optimisation): the penetration is replaced by
  ``x_s = 0.5 * (x + sqrt(x^2 + eps_x^2))`` (C-infinity; ``x_s -> x`` for x >> eps_x,
  ``x_s -> eps_x^2 / (4|x|)`` for x << -eps_x, ``x_s(0) = eps_x / 2``) and the damping clamp by
  ``d_s = 0.5 * (d + sqrt(d^2 + eps_damping^2))`` with ``d = 1 + c * xdot`` (bias
  ``eps_damping^2 / 4`` at d = 1). The smooth force is strictly positive everywhere.

**Forms of the smoothing** (:data:`PENETRATION_FORMS`, :data:`SLIP_FORMS`; the first of each is
the default, and the only one the seed study uses). Another form with the same width is a
different, equally admissible smoothing of the same law, as the mismatch family of the diagnosis
needs (:mod:`gc_ocp.diagnosis.mismatch`):

* penetration ``"hyperbola"`` (above) or ``"softplus"``:
  ``x_s = max(x, 0) + w * log(1 + exp(-|x| / w))`` with ``w = eps_x / (2 ln 2)``: the same value
  ``eps_x / 2`` and slope 1/2 at x = 0 and the same limits (``x_s -> x`` for x >> eps_x, -> 0 for
  x << -eps_x), but exponential instead of algebraic tails (``x_s - x ~ w exp(-x / w)`` against
  ``eps_x^2 / (4 x)``) and a smaller curvature at 0 (``ln 2 / (2 eps_x)`` against
  ``1 / (2 eps_x)``);
* friction direction ``"algebraic"`` (``v_s / sqrt(|v_s|^2 + v_eps^2)``, above) or ``"tanh"``:
  ``tanh(|v_s| / v_eps) v_s / |v_s|`` (the tanh regularisation of smooth contact models for
  predictive simulation, e.g. OpenSim's SmoothSphereHalfSpaceForce): the same
  slope ``1 / v_eps`` at zero sliding and the same limit (unit direction) when
  ``|v_s| >> v_eps``, reached faster (76 % of ``mu F_n`` at ``v_eps`` against 71 %, 99.9 %
  against 97 % at 4 ``v_eps``). ``|v_s|`` is evaluated as ``sqrt(|v_s|^2 + (1e-3 v_eps)^2)``
  so that the form is smooth at zero sliding (relative bias below 1e-6).

Smoothing constants (:data:`DEFAULT_SMOOTHING`): ``eps_x = 0.5 mm`` (a tenth of typical sole
penetrations of a few mm; at x = 0 the smooth force is ``k * (eps_x/2)^n``, i.e. 3 N for
k = 11,974 N/m and n = 1), ``eps_damping = 0.01`` (dimensionless; relative force bias 2.5e-5 when
undamped), ``v_eps = 0.05 m/s`` (friction reaches 71 % of ``mu F_n`` at 5 cm/s and 98 % at
25 cm/s; sliding during stance is a few mm/s to cm/s, so friction is partly developed — this is
deliberate: a discontinuous Coulomb law is not usable in an NLP).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache, lru_cache

import casadi as ca
import numpy as np

from gc_ocp.errors import InputError


@dataclass(frozen=True)
class Smoothing:
    """Smoothing lengths of the contact laws.

    eps_x: penetration smoothing length [m] (smooth variant only).
    eps_damping: smoothing of the damping-factor clamp [-] (smooth variant only).
    v_eps: sliding-speed regularisation of the friction direction [m/s] (both variants).
    """

    eps_x: float = 5e-4
    eps_damping: float = 1e-2
    v_eps: float = 0.05

    def __post_init__(self) -> None:
        for name in ("eps_x", "eps_damping", "v_eps"):
            if not getattr(self, name) > 0:
                raise InputError(f"Smoothing.{name} must be > 0, but got {getattr(self, name)}")

    def as_tuple(self) -> tuple[float, float, float]:
        return (self.eps_x, self.eps_damping, self.v_eps)


DEFAULT_SMOOTHING = Smoothing()


PENETRATION_FORMS: tuple[str, ...] = ("hyperbola", "softplus")
"""Admissible forms of the smoothed penetration (module doc); the first is the default."""

SLIP_FORMS: tuple[str, ...] = ("algebraic", "tanh")
"""Admissible forms of the regularised friction direction (module doc); the first is the
default."""

_TANH_SPEED_FLOOR = 1e-3
"""``|v_s|`` of the tanh form is ``sqrt(|v_s|^2 + (1e-3 v_eps)^2)``: smooth at zero sliding; the
relative change of the force is at most ``1e-6 / 3`` there and ``5e-7`` at ``v_eps``."""


def _check_form(form: str, forms: tuple[str, ...], what: str) -> None:
    if form not in forms:
        raise InputError(f'Unknown {what} form "{form}"; choose from {forms}')


def _smooth_max0(a, eps):
    """C-infinity approximation of max(a, 0) with smoothing length ``eps``."""
    return 0.5 * (a + ca.sqrt(a * a + eps * eps))


def smooth_penetration(x, eps, form: str = PENETRATION_FORMS[0]):
    """The smoothed penetration ``x_s(x)`` [m] of width ``eps`` [m] in ``form`` (module doc):
    both forms equal ``eps / 2`` with slope 1/2 at x = 0 and tend to ``max(x, 0)`` away from it.
    CasADi expressions (or numbers)."""
    _check_form(form, PENETRATION_FORMS, "penetration")
    if form == "hyperbola":
        return _smooth_max0(x, eps)
    w = eps / (2 * np.log(2.0))
    # written so that exp never overflows: max(x, 0) + w log(1 + exp(-|x|/w)) = w log(1 + e^(x/w))
    return ca.fmax(x, 0) + w * ca.log1p(ca.exp(-ca.fabs(x) / w))


def slip_direction(vs, v_eps, form: str = SLIP_FORMS[0]):
    """The regularised direction of the horizontal sliding velocity ``vs`` (2,) [m/s] with width
    ``v_eps`` [m/s] in ``form`` (module doc): slope ``1 / v_eps`` at zero, a unit vector at
    ``|vs| >> v_eps``. CasADi expressions."""
    _check_form(form, SLIP_FORMS, "friction")
    if form == "algebraic":
        return vs / ca.sqrt(ca.sumsqr(vs) + v_eps * v_eps)
    s = ca.sqrt(ca.sumsqr(vs) + (_TANH_SPEED_FLOOR * v_eps) ** 2)
    return vs * ca.tanh(s / v_eps) / s


@cache
def penetration_function() -> ca.Function:
    """``(p(3), v(3), ground_height) -> (x, xdot)``: penetration [m] and its rate [m/s]."""
    p, v, h = ca.SX.sym("p", 3), ca.SX.sym("v", 3), ca.SX.sym("ground_height")
    return ca.Function(
        "penetration",
        [p, v, h],
        [h - p[2], -v[2]],
        ["p", "v", "ground_height"],
        ["x", "xdot"],
    )


@cache
def normal_force_function(
    smooth: bool = False, depth_form: str = PENETRATION_FORMS[0]
) -> ca.Function:
    """Hunt-Crossley normal force ``(x, xdot, k, n, c, eps_x, eps_damping) -> F_n`` [N].

    x: penetration [m]; xdot: its rate [m/s]; k [N/m^n]; n [-]; c [s/m]. The smoothing inputs are
    ignored when ``smooth`` is False (kept so both variants share one signature); ``depth_form``:
    the smoothed penetration's form (:data:`PENETRATION_FORMS`, smooth variant only).
    """
    _check_form(depth_form, PENETRATION_FORMS, "penetration")
    x, xdot = ca.SX.sym("x"), ca.SX.sym("xdot")
    k, n, c = ca.SX.sym("k"), ca.SX.sym("n"), ca.SX.sym("c")
    eps_x, eps_d = ca.SX.sym("eps_x"), ca.SX.sym("eps_damping")
    d = 1 + c * xdot
    if smooth:
        fn = k * smooth_penetration(x, eps_x, depth_form) ** n * _smooth_max0(d, eps_d)
    else:
        # fmax keeps the masked branch finite; if_else makes the force and its derivatives exactly
        # zero for x <= 0 (CasADi's if_else_zero returns 0 even if the other branch is NaN).
        fn = ca.if_else(x > 0, k * ca.fmax(x, 0) ** n * ca.fmax(d, 0), 0)
    name = "normal_force_smooth" if smooth else "normal_force"
    if smooth and depth_form != PENETRATION_FORMS[0]:
        name += "_" + depth_form
    return ca.Function(
        name,
        [x, xdot, k, n, c, eps_x, eps_d],
        [fn],
        ["x", "xdot", "k", "n", "c", "eps_x", "eps_damping"],
        ["F_n"],
    )


@cache
def friction_force_function(form: str = SLIP_FORMS[0]) -> ca.Function:
    """Regularised Coulomb friction ``(F_n, v(3), belt_velocity(3), mu, v_eps) -> F_t(3)`` [N].

    Only the horizontal (x, y) part of ``v - belt_velocity`` slides; ``F_t[2] = 0``. ``form``: the
    regularised direction's form (:data:`SLIP_FORMS`, :func:`slip_direction`).
    """
    _check_form(form, SLIP_FORMS, "friction")
    fn, v, vb = ca.SX.sym("F_n"), ca.SX.sym("v", 3), ca.SX.sym("belt_velocity", 3)
    mu, v_eps = ca.SX.sym("mu"), ca.SX.sym("v_eps")
    vs = ca.vertcat(v[0] - vb[0], v[1] - vb[1])
    direction = slip_direction(vs, v_eps, form)
    ft = ca.vertcat(-mu * fn * direction, 0)
    return ca.Function(
        "friction_force" if form == SLIP_FORMS[0] else "friction_force_" + form,
        [fn, v, vb, mu, v_eps],
        [ft],
        ["F_n", "v", "belt_velocity", "mu", "v_eps"],
        ["F_t"],
    )


UNIT_FORCE_INPUTS = (
    "p",
    "v",
    "k",
    "n",
    "c",
    "mu",
    "ground_height",
    "belt_velocity",
    "eps_x",
    "eps_damping",
    "v_eps",
)


@cache
def unit_force_function(smooth: bool = False) -> ca.Function:
    """Force of one unit on the foot, in ``lab`` [N].

    Inputs (in order, see :data:`UNIT_FORCE_INPUTS`): p(3) [m], v(3) [m/s] of the attachment
    point in ``lab``; k [N/m^n]; n [-]; c [s/m]; mu [-]; ground_height [m]; belt_velocity(3)
    [m/s]; eps_x [m]; eps_damping [-]; v_eps [m/s]. Output ``F`` (3) = normal (+z) + friction.
    Composed symbolically from :func:`penetration_function`, :func:`normal_force_function` and
    :func:`friction_force_function`.
    """
    p, v = ca.SX.sym("p", 3), ca.SX.sym("v", 3)
    k, n, c, mu, h = (ca.SX.sym(s) for s in ("k", "n", "c", "mu", "ground_height"))
    vb = ca.SX.sym("belt_velocity", 3)
    eps_x, eps_d, v_eps = ca.SX.sym("eps_x"), ca.SX.sym("eps_damping"), ca.SX.sym("v_eps")
    x, xdot = penetration_function()(p, v, h)
    fn = normal_force_function(smooth)(x, xdot, k, n, c, eps_x, eps_d)
    ft = friction_force_function()(fn, v, vb, mu, v_eps)
    f = ft + ca.vertcat(0, 0, fn)
    name = "unit_force_smooth" if smooth else "unit_force"
    return ca.Function(
        name, [p, v, k, n, c, mu, h, vb, eps_x, eps_d, v_eps], [f], list(UNIT_FORCE_INPUTS), ["F"]
    )


@lru_cache(maxsize=64)
def _mapped(fun_name: str, smooth: bool, n: int) -> ca.Function:
    base = {"unit_force": unit_force_function, "normal_force": normal_force_function}[fun_name]
    return base(smooth).map(n)


def _row(a, n: int, width: int = 1) -> np.ndarray:
    """Broadcast a scalar or ``(n,)`` / ``(n, width)`` array to CasADi's ``(width, n)`` layout."""
    a = np.asarray(a, dtype=float)
    if width == 1:
        return np.broadcast_to(a.reshape(-1), (n,)).reshape(1, n)
    return np.broadcast_to(a, (n, width)).T


def unit_forces(
    positions: np.ndarray,
    velocities: np.ndarray,
    k,
    n=1.0,
    c=0.0,
    mu=0.0,
    ground_height=0.0,
    belt_velocity=(0.0, 0.0, 0.0),
    smooth: bool = False,
    smoothing: Smoothing = DEFAULT_SMOOTHING,
) -> np.ndarray:
    """Evaluate :func:`unit_force_function` on arrays.

    positions, velocities: ``(..., 3)`` in ``lab`` [m], [m/s]; k, n, c, mu, ground_height:
    scalars or arrays broadcastable to ``positions.shape[:-1]``; belt_velocity ``(3,)`` [m/s].
    Returns forces ``(..., 3)`` [N] on the foot, in ``lab``.
    """
    positions = np.asarray(positions, dtype=float)
    velocities = np.asarray(velocities, dtype=float)
    if positions.shape[-1:] != (3,) or velocities.shape != positions.shape:
        raise InputError(
            "positions and velocities must both have shape (..., 3), "
            f"but got {positions.shape} and {velocities.shape}"
        )
    batch = positions.shape[:-1]
    m = int(np.prod(batch))
    if m == 0:
        return np.zeros(positions.shape)

    def per_point(a):
        return np.broadcast_to(np.asarray(a, dtype=float), batch).reshape(-1)

    vb = np.asarray(belt_velocity, dtype=float).reshape(3)
    args = [
        positions.reshape(m, 3).T,
        velocities.reshape(m, 3).T,
        _row(per_point(k), m),
        _row(per_point(n), m),
        _row(per_point(c), m),
        _row(per_point(mu), m),
        _row(per_point(ground_height), m),
        vb.reshape(3, 1),
        *smoothing.as_tuple(),
    ]
    out = _mapped("unit_force", smooth, m)(*args)
    return np.asarray(out).T.reshape(*batch, 3)


def normal_forces(
    x, xdot, k, n=1.0, c=0.0, smooth: bool = False, smoothing: Smoothing = DEFAULT_SMOOTHING
) -> np.ndarray:
    """Evaluate :func:`normal_force_function` elementwise on broadcastable arrays [N]."""
    x, xdot, k, n, c = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (x, xdot, k, n, c))
    )
    shape = x.shape
    if x.size == 0:  # as unit_forces: no point, no force (a mapped Function needs one)
        return np.zeros(shape)
    args = [a.reshape(1, -1) for a in (x, xdot, k, n, c)]
    out = _mapped("normal_force", smooth, x.size)(*args, smoothing.eps_x, smoothing.eps_damping)
    return np.asarray(out).reshape(shape)
