"""The seed's linear least squares for the unit stiffnesses.

With the exponent n and damping c fixed (the seed: n = 1, c = 0) every unit force is k times a
known function of the motion: F_n = k * x (x > 0) and F_t = -mu * k * x * v_s / sqrt(|v_s|^2 +
v_eps^2). The equivalent wrench (Eqs 4-9) is therefore linear in the ten stiffnesses (five units
per foot). All frames of all stances and all six channels are stacked into one system
``A k = b`` (rows scaled by BW for forces and BW*H for torques, so that all channels weigh
alike), solved in the least-squares sense.

Friction: the seed fitted the shear channels too and its noisy-synthetic anterior force error is
non-zero, so friction was on, with an unreported coefficient. We use ``mu = 0.5``
(:data:`DEFAULT_MU`, a typical shoe-floor dynamic friction coefficient) with the regularised
Coulomb law of :mod:`gc_ocp.contact.laws` (``v_eps = 0.05 m/s``); change it via ``law``.

Rank: the system is solved only if ``A`` has full column rank. The numerical rank uses the
singular values of the scaled ``A`` with NumPy's ``matrix_rank`` tolerance
``s_max * max(A.shape) * eps_machine`` (Press et al., Numerical Recipes, §2.6), unless
``rank_tol`` (relative to ``s_max``) is given. Columns that are identically zero (a unit never
below the ground in any stance) are reported by name.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from gc_ocp.contact.channels import CHANNELS, channel_rms_pct, wrench_scale
from gc_ocp.contact.equivalent_wrench import LawParams, model_wrench, wrench_per_unit_stiffness
from gc_ocp.errors import InputError, RankError
from gc_ocp.stance import StanceData, trial_stances
from gc_ocp.trial import SIDES

DEFAULT_MU = 0.5
"""Friction coefficient used by the seed reproduction (the seed's value is not reported)."""

SEED_LAW = LawParams(n=1.0, c=0.0, mu=DEFAULT_MU, smooth=False)
"""The seed's law: n = 1, c = 0, exact penetration, friction mu = 0.5."""


def _units_by_side(stances) -> dict[str, tuple[str, ...]]:
    """``{side: unit names}`` of the stances' sole layouts (one layout per side)."""
    out: dict[str, tuple[str, ...]] = {}
    for st in stances:
        if out.setdefault(st.side, st.layout.units) != st.layout.units:
            raise InputError(
                f"Stances of the {st.side} foot have different sole layouts ({st.label})"
            )
    return out


def stances_from_trial(trial, kinematics) -> list[StanceData]:
    """Measured stances of a :class:`~gc_ocp.trial.Trial` with its ``TrialKinematics``, cut at
    the kinematic frames inside ``[t_on, t_off]`` (:func:`gc_ocp.stance.trial_stances`)."""
    return trial_stances(trial, kinematics)


@dataclass(frozen=True)
class LLSResult:
    """Result of :func:`fit_stiffness_lls`.

    unknowns: ``(side, unit)`` per column; k_vector: stiffnesses [N/m] in that order;
    k: ``{side: {unit: k}}``; fitted / measured: ``(n, 6)`` wrench per stance;
    rms_pct: ``{channel: RMS}`` in % BW / % BW*H over all frames of all stances;
    rank, singular_values (of the scaled matrix), condition_number; law: the law used.
    """

    unknowns: tuple[tuple[str, str], ...]
    k_vector: np.ndarray
    k: dict[str, dict[str, float]]
    stances: tuple[StanceData, ...]
    fitted: tuple[np.ndarray, ...]
    rms_pct: dict[str, float]
    rank: int
    singular_values: np.ndarray
    condition_number: float
    body_weight: float
    bw_height: float
    law: LawParams

    def summary(self) -> str:
        lines = [
            f"LLS stiffness fit: {len(self.stances)} stances, "
            f"{sum(len(s.time) for s in self.stances)} frames, rank {self.rank}/"
            f"{len(self.unknowns)}, condition {self.condition_number:.3g}"
        ]
        for side, ks in self.k.items():
            lines.append(f"  {side:5s} " + "  ".join(f"{u}={v:10.1f}" for u, v in ks.items()))
        lines.append("  RMS: " + ", ".join(f"{c}={self.rms_pct[c]:.3g}" for c in CHANNELS))
        return "\n".join(lines)


def build_lls_system(
    stances: Sequence[StanceData],
    body_weight: float,
    bw_height: float,
    law: LawParams = SEED_LAW,
    sides: Sequence[str] | None = None,
) -> tuple[np.ndarray, np.ndarray, tuple[tuple[str, str], ...]]:
    """Scaled system ``A (rows, 5*n_sides)``, ``b (rows,)`` and the unknowns ``(side, unit)``.

    Rows are frame-major, then the six ``lab`` wrench columns, each divided by BW (forces) or
    BW*H (torques). ``sides`` defaults to the sides present in ``stances`` (in ``SIDES`` order).
    """
    if not stances:
        raise InputError("No stance to fit; the trial needs at least one usable stance")
    if not body_weight > 0 or not bw_height > 0:
        raise InputError(
            f"body_weight and bw_height must be > 0, but got {body_weight}, {bw_height}"
        )
    if sides is None:
        sides = [s for s in SIDES if any(st.side == s for st in stances)]
    units = _units_by_side(stances)
    unknowns = tuple((s, u) for s in sides for u in units.get(s, ()))
    scale = wrench_scale(body_weight, bw_height)
    blocks_a, blocks_b = [], []
    for st in stances:
        if st.side not in sides:
            raise InputError(f"Stance {st.label!r} is on side {st.side!r}, not in {list(sides)}")
        reg = wrench_per_unit_stiffness(
            st.positions, st.velocities, st.reference_point, law, st.ground_height, st.belt_velocity
        )  # (n, 6, 5)
        a = np.zeros((reg.shape[0], 6, len(unknowns)))
        cols = [unknowns.index((st.side, u)) for u in st.layout.units]
        a[:, :, cols] = reg / scale[None, :, None]
        blocks_a.append(a.reshape(-1, len(unknowns)))
        blocks_b.append((st.measured / scale).reshape(-1))
    return np.vstack(blocks_a), np.concatenate(blocks_b), unknowns


def fit_stiffness_lls(
    stances: Sequence[StanceData],
    body_weight: float,
    bw_height: float,
    law: LawParams = SEED_LAW,
    sides: Sequence[str] | None = None,
    rank_tol: float | None = None,
) -> LLSResult:
    """Fit one stiffness per unit per foot to the measured wrenches (seed's LLS).

    stances: see :class:`StanceData`; body_weight [N] and bw_height [N·m] scale the rows;
    law: n, c, mu (k enters linearly for any fixed n, c); rank_tol: relative singular-value
    tolerance (default ``max(A.shape) * eps``). Raises :class:`~gc_ocp.errors.RankError` naming
    the units that never touch the ground, or the combination that is not identifiable.
    """
    A, b, unknowns = build_lls_system(stances, body_weight, bw_height, law, sides)
    names = [f"{s}/{u}" for s, u in unknowns]
    dead = [names[j] for j in range(A.shape[1]) if not np.any(A[:, j])]
    if dead:
        raise RankError(
            f"Units {dead} are never in contact (no penetration below the ground in any stance), "
            "so their stiffness is not identifiable. Check the ground height / sole point "
            "placement, add stances where these units touch the plate, or fix their k."
        )
    s = np.linalg.svd(A, compute_uv=False)
    tol = s[0] * (rank_tol if rank_tol is not None else max(A.shape) * np.finfo(float).eps)
    rank = int(np.sum(s > tol))
    if rank < A.shape[1]:
        _, _, vt = np.linalg.svd(A, full_matrices=False)
        null = vt[-1]
        involved = [names[j] for j in np.argsort(-np.abs(null)) if abs(null[j]) > 0.1]
        raise RankError(
            f"The stiffness system has rank {rank} < {A.shape[1]} unknowns (tolerance "
            f"{tol:.3g} on singular values {np.array2string(s, precision=3)}); the stiffnesses of "
            f"{involved} cannot be separated (their unit forces are proportional in every frame). "
            "Add stances with different foot orientations or merge these units."
        )
    k, *_ = np.linalg.lstsq(A, b, rcond=None)
    fitted = tuple(
        model_wrench(
            st.positions,
            st.velocities,
            k[[unknowns.index((st.side, u)) for u in st.layout.units]],
            st.reference_point,
            law,
            st.ground_height,
            st.belt_velocity,
        )
        for st in stances
    )
    meas = np.vstack([st.measured for st in stances])
    rms = channel_rms_pct(meas, np.vstack(fitted), body_weight, bw_height)
    kd: dict[str, dict[str, float]] = {}
    for (side, unit), v in zip(unknowns, k, strict=True):
        kd.setdefault(side, {})[unit] = float(v)
    return LLSResult(
        unknowns,
        k,
        kd,
        tuple(stances),
        fitted,
        rms,
        rank,
        s,
        float(s[0] / s[-1]),
        float(body_weight),
        float(bw_height),
        law,
    )


def k_dict_to_vector(k: Mapping[str, Mapping[str, float]], unknowns) -> np.ndarray:
    """Stiffness vector in the order of ``unknowns`` ``((side, unit), ...)``."""
    return np.array([k[s][u] for s, u in unknowns], dtype=float)
