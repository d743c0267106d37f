"""Wrench channels, their names and the seed's normalisation (one place for all layers).

Our ``lab`` frame is Z up, X anterior, Y left. The seed's labels map to it as:
anterior force = F_x, superior force = F_z, lateral force = F_y; anteroposterior torque = M_x,
longitudinal torque = M_z (about the vertical), mediolateral torque = M_y.
Wrench arrays are ordered ``[F_x, F_y, F_z, M_x, M_y, M_z]``.
"""

from __future__ import annotations

import numpy as np

# (report key, column in [Fx, Fy, Fz, Mx, My, Mz], kind)
CHANNELS: tuple[tuple[str, int, str], ...] = (
    ("anterior_force_pct_bw", 0, "force"),
    ("superior_force_pct_bw", 2, "force"),
    ("lateral_force_pct_bw", 1, "force"),
    ("anteroposterior_torque_pct_bwh", 3, "torque"),
    ("longitudinal_torque_pct_bwh", 5, "torque"),
    ("mediolateral_torque_pct_bwh", 4, "torque"),
)

SEED_BODY_WEIGHT = 689.0
"""Seed subject's body weight [N]."""
SEED_BW_HEIGHT = 1173.0
"""Seed subject's body weight x height [N·m] (as printed in the report)."""
SEED_UNIFORM_K = 11974.0
"""Seed's uniform synthetic stiffness [N/m]."""


def rms_report(error: np.ndarray, body_weight: float, bw_height_or_height: float, *, is_product: bool = False) -> dict:
    """Per-channel RMS of a wrench error ``(n, 6)`` in % BW (forces) and % BW·H (torques).

    ``bw_height_or_height`` is the subject height [m] (``is_product=False``) or directly BW·H [N·m].
    """
    e = np.asarray(error, float)
    bwh = bw_height_or_height if is_product else body_weight * bw_height_or_height
    out = {}
    for key, col, kind in CHANNELS:
        norm = body_weight if kind == "force" else bwh
        out[key] = float(np.sqrt(np.mean(e[:, col] ** 2)) / norm * 100.0)
    return out
