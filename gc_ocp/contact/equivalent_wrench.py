"""Equivalent wrench of the five units of one foot (seed Eqs 4-9).

The unit forces F_i (from :func:`gc_ocp.contact.laws.unit_force_function`) are replaced by one
wrench about the stance reference point R (the plate's electrical centre EC in the seed)::

    F   = sum_i F_i                          (Eqs 4-6)
    M_R = sum_i (p_i - R) x F_i              (Eqs 7-9)

both in ``lab`` (F [N], M [N·m]), stacked as ``(F_x, F_y, F_z, M_x, M_y, M_z)``; see
:mod:`gc_ocp.contact.channels` for the channel names. One CasADi Function defines it; NumPy
evaluation goes through the same Function mapped over frames.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cache, lru_cache

import casadi as ca
import numpy as np

from gc_ocp.contact.laws import DEFAULT_SMOOTHING, Smoothing, unit_force_function
from gc_ocp.errors import InputError
from gc_ocp.foot import UNITS
from gc_ocp.wrench import cop_from_wrench, free_moment

N_UNITS = len(UNITS)


@dataclass(frozen=True)
class LawParams:
    """Parameters shared by the units of a foot, besides their stiffness.

    n: exponent of the penetration [-]; c: Hunt-Crossley damping [s/m]; mu: friction coefficient
    [-]; smooth: use the smooth variant of the laws; smoothing: smoothing lengths.
    The seed's linear least squares uses n = 1, c = 0.
    """

    n: float = 1.0
    c: float = 0.0
    mu: float = 0.5
    smooth: bool = False
    smoothing: Smoothing = field(default_factory=lambda: DEFAULT_SMOOTHING)


@cache
def wrench_function(smooth: bool = False, n_units: int = N_UNITS) -> ca.Function:
    """Equivalent wrench of ``n_units`` units about a reference point.

    Inputs: P (3, m) unit positions [m]; V (3, m) velocities [m/s] (columns = units, ``lab``);
    k (m) [N/m^n]; n; c [s/m]; mu; ground_height [m]; belt_velocity (3) [m/s]; reference (3) [m];
    eps_x [m]; eps_damping; v_eps [m/s]. Output ``W`` (6) = (force [N], moment about reference
    [N·m]) in ``lab``.
    """
    P, V = ca.SX.sym("P", 3, n_units), ca.SX.sym("V", 3, n_units)
    k = ca.SX.sym("k", n_units)
    n, c, mu, h = (ca.SX.sym(s) for s in ("n", "c", "mu", "ground_height"))
    vb, ref = ca.SX.sym("belt_velocity", 3), ca.SX.sym("reference", 3)
    eps = [ca.SX.sym(s) for s in ("eps_x", "eps_damping", "v_eps")]
    uf = unit_force_function(smooth)
    force = ca.SX.zeros(3)
    moment = ca.SX.zeros(3)
    for i in range(n_units):
        fi = uf(P[:, i], V[:, i], k[i], n, c, mu, h, vb, *eps)
        force += fi
        moment += ca.cross(P[:, i] - ref, fi)
    return ca.Function(
        "contact_wrench_smooth" if smooth else "contact_wrench",
        [P, V, k, n, c, mu, h, vb, ref, *eps],
        [ca.vertcat(force, moment)],
        [
            "P",
            "V",
            "k",
            "n",
            "c",
            "mu",
            "ground_height",
            "belt_velocity",
            "reference",
            "eps_x",
            "eps_damping",
            "v_eps",
        ],
        ["W"],
    )


@lru_cache(maxsize=64)
def _mapped_wrench(smooth: bool, n_units: int, n: int) -> ca.Function:
    return wrench_function(smooth, n_units).map(n)


def model_wrench(
    positions: np.ndarray,
    velocities: np.ndarray,
    k,
    reference_point,
    law: LawParams = LawParams(),
    ground_height=0.0,
    belt_velocity=(0.0, 0.0, 0.0),
) -> np.ndarray:
    """Modelled wrench ``(n, 6)`` about ``reference_point`` for one foot.

    positions, velocities: ``(n, m, 3)`` unit trajectories in ``lab`` [m], [m/s];
    k: ``(m,)`` stiffnesses [N/m^n]; reference_point: ``(3,)`` or ``(n, 3)`` [m];
    ground_height: scalar or ``(n,)`` [m]; belt_velocity: ``(3,)`` [m/s].
    """
    positions = np.asarray(positions, dtype=float)
    velocities = np.asarray(velocities, dtype=float)
    if positions.ndim != 3 or positions.shape[2] != 3 or velocities.shape != positions.shape:
        raise InputError(
            "positions and velocities must have shape (n_frames, n_units, 3), "
            f"but got {positions.shape} and {velocities.shape}"
        )
    nf, m, _ = positions.shape
    k = np.asarray(k, dtype=float).reshape(-1)
    if k.shape != (m,):
        raise InputError(f"k must have one value per unit ({m},), but got {k.shape}")
    if nf == 0:
        return np.zeros((0, 6))
    ref = np.broadcast_to(np.asarray(reference_point, dtype=float), (nf, 3))
    h = np.broadcast_to(np.asarray(ground_height, dtype=float).reshape(-1), (nf,))
    fun = _mapped_wrench(law.smooth, m, nf)
    out = fun(
        positions.transpose(2, 1, 0).reshape(3, m * nf, order="F"),
        velocities.transpose(2, 1, 0).reshape(3, m * nf, order="F"),
        k.reshape(m, 1),
        law.n,
        law.c,
        law.mu,
        h.reshape(1, nf),
        np.asarray(belt_velocity, dtype=float).reshape(3, 1),
        ref.T,
        *law.smoothing.as_tuple(),
    )
    return np.asarray(out).T.copy()


def wrench_per_unit_stiffness(
    positions: np.ndarray,
    velocities: np.ndarray,
    reference_point,
    law: LawParams = LawParams(),
    ground_height=0.0,
    belt_velocity=(0.0, 0.0, 0.0),
) -> np.ndarray:
    """Regressor ``(n, 6, m)``: column j is the wrench of unit j alone with ``k_j = 1``.

    The laws are linear in k for fixed n, c, mu (F_n = k * g(x, xdot), F_t proportional to F_n),
    so ``model_wrench(..., k) == regressor @ k``. Evaluated through :func:`model_wrench` (the same
    CasADi Function) with unit vectors of stiffness.
    """
    m = np.asarray(positions).shape[1]
    cols = [
        model_wrench(
            positions, velocities, np.eye(m)[j], reference_point, law, ground_height, belt_velocity
        )
        for j in range(m)
    ]
    return np.stack(cols, axis=2)


def model_cop(
    wrench: np.ndarray, reference_point, surface_height: float = 0.0, min_vertical: float = 20.0
) -> np.ndarray:
    """Centre of pressure ``(n, 3)`` [m] of a modelled wrench on ``z = surface_height``."""
    wrench = np.asarray(wrench, dtype=float)
    return cop_from_wrench(
        wrench[:, :3], wrench[:, 3:], reference_point, surface_height, min_vertical
    )


def model_free_moment(
    wrench: np.ndarray, reference_point, surface_height: float = 0.0
) -> np.ndarray:
    """Vertical free moment ``(n,)`` [N·m] of a modelled wrench about its COP."""
    wrench = np.asarray(wrench, dtype=float)
    return free_moment(wrench[:, :3], wrench[:, 3:], reference_point, surface_height)
