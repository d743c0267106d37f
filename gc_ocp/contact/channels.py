"""The six ground-reaction channels: names, order, mapping to ``lab`` and normalisation.

The seed report's lab frame was Y up (x anterior, y superior, z lateral). Our ``lab`` is Z up,
X anterior, Y left. Its labels map to our wrench columns (``wrench[:, 0:3]`` = force x, y, z;
``wrench[:, 3:6]`` = moment about x, y, z) as follows:

==========================  =====================  ==================  ==========
channel (seed label)        our ``lab`` component  wrench column       normaliser
==========================  =====================  ==================  ==========
``anterior_force``          F_x (anterior)         0                   BW
``superior_force``          F_z (vertical)         2                   BW
``lateral_force``           F_y (left)             1                   BW
``anteroposterior_torque``  M_x (about x)          3                   BW*H
``longitudinal_torque``     M_z (about vertical)   5                   BW*H
``mediolateral_torque``     M_y (about y)          4                   BW*H
==========================  =====================  ==================  ==========

:data:`CHANNELS` is in the seed's Table 1 order; every table, plot and result uses it.
Forces are normalised by body weight BW [N], torques by BW times height H [N·m]; RMS errors
are reported in percent of these.
"""

from __future__ import annotations

import numpy as np

CHANNELS: tuple[str, ...] = (
    "anterior_force",
    "superior_force",
    "lateral_force",
    "anteroposterior_torque",
    "longitudinal_torque",
    "mediolateral_torque",
)
"""Channel names in the seed's Table 1 order."""

WRENCH_COLUMN: dict[str, int] = {
    "anterior_force": 0,
    "lateral_force": 1,
    "superior_force": 2,
    "anteroposterior_torque": 3,
    "mediolateral_torque": 4,
    "longitudinal_torque": 5,
}
"""Column of each channel in a ``lab`` wrench ``(n, 6)`` = (F_x, F_y, F_z, M_x, M_y, M_z)."""

CHANNEL_COLUMNS: tuple[int, ...] = tuple(WRENCH_COLUMN[c] for c in CHANNELS)

IS_FORCE: dict[str, bool] = {c: c.endswith("_force") for c in CHANNELS}

CHANNEL_UNITS: dict[str, str] = {c: ("% BW" if IS_FORCE[c] else "% BW*H") for c in CHANNELS}

TABLE_KEYS: dict[str, str] = {c: c + ("_pct_bw" if IS_FORCE[c] else "_pct_bwh") for c in CHANNELS}
"""Key of each channel in Table 1 rows, e.g. ``superior_force_pct_bw``."""


def channel_name(key: str) -> str:
    """A report key's words: ``superior_force_pct_bw`` -> ``superior force``, ``cop_mm`` ->
    ``COP``."""
    if key == "cop_mm":
        return "COP"
    return key.replace("_pct_bwh", "").replace("_pct_bw", "").replace("_", " ")


def channel_unit(key: str) -> str:
    """A report key's unit: ``% BW``, ``% BW×H`` (torques) or ``mm`` (the COP)."""
    if key == "cop_mm":
        return "mm"
    return "% BW×H" if key.endswith("_pct_bwh") else "% BW"


SEED_K_UNIFORM = 11974.0
"""Uniform stiffness of the seed's synthetic data [N/m]; k RMS errors are normalised by it."""
SEED_BW = 689.0
"""Body weight used by the seed to normalise forces [N]."""
SEED_BWH = 1173.0
"""Body weight times height used by the seed to normalise torques [N·m]."""


def wrench_scale(body_weight: float, bw_height: float) -> np.ndarray:
    """Per-column normaliser of a ``lab`` wrench ``(6,)``: BW for forces, BW*H for moments."""
    return np.array([body_weight] * 3 + [bw_height] * 3, dtype=float)


def channel_rms_pct(
    measured: np.ndarray, simulated: np.ndarray, body_weight: float, bw_height: float
) -> dict[str, float]:
    """RMS of ``simulated - measured`` per channel, in % BW (forces) and % BW*H (torques).

    measured, simulated: ``(n, 6)`` ``lab`` wrenches (all frames of all stances stacked).
    Returns ``{channel: pct}`` in :data:`CHANNELS` order (Table 1 keys via :data:`TABLE_KEYS`).
    """
    measured = np.asarray(measured, dtype=float)
    simulated = np.asarray(simulated, dtype=float)
    err = (simulated - measured) / wrench_scale(body_weight, bw_height)
    rms = 100.0 * np.sqrt(np.mean(err**2, axis=0))
    return {c: float(rms[WRENCH_COLUMN[c]]) for c in CHANNELS}


def k_rms_pct(k_estimated: np.ndarray, k_true: np.ndarray, k_ref: float = SEED_K_UNIFORM) -> float:
    """RMS stiffness error over all units in % of ``k_ref`` [N/m] (seed: 11,974 N/m)."""
    d = np.asarray(k_estimated, dtype=float) - np.asarray(k_true, dtype=float)
    return float(100.0 * np.sqrt(np.mean(d**2)) / k_ref)
