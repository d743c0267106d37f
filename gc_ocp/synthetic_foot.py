"""The one synthetic foot: a rigid foot rolling heel-to-toe over the ground ``z = 0``.

The motion is smooth and realistic in shape (heel strike at 12 deg dorsiflexion, foot flat,
heel-off and roll over the metatarsal heads to 20 deg plantarflexion, medio-lateral roll), the
foot sinks a few millimetres into the ground in stance, and it slides slightly. Used by the seed
study's tests, the estimator's synthetic stances and the benchmarks. Toes welded to the hindfoot
(the seed model); unit points in the hindfoot frame (:data:`NOMINAL_POINTS`).
"""

from __future__ import annotations

import numpy as np

from gc_ocp.foot import FootKinematics

# nominal unit positions in the foot frame (origin at the ankle, sole 70 mm below) [m]
NOMINAL_POINTS = np.array(
    [
        [-0.045, -0.025, -0.070],  # PL (for the left foot lateral is +y; mirrored for the right)
        [-0.045, 0.020, -0.070],  # PM
        [0.140, -0.040, -0.070],  # AL
        [0.140, 0.035, -0.070],  # AM
        [0.190, 0.000, -0.070],  # TT
    ]
)


def _rot_y(a: np.ndarray) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(a.shape + (3, 3))
    R[..., 0, 0] = c
    R[..., 0, 2] = s
    R[..., 1, 1] = 1
    R[..., 2, 0] = -s
    R[..., 2, 2] = c
    return R


def nominal_points(side: str) -> np.ndarray:
    p = NOMINAL_POINTS.copy()
    if side == "left":
        p[:, 1] *= -1.0  # lateral is +y (left) for the left foot
    return p


def rolling_foot(
    side: str,
    duration: float = 0.65,
    rate: float = 100.0,
    t0: float = 0.0,
    sink: float = 0.006,
    margin: float = 0.03,
    style: np.ndarray | None = None,
) -> FootKinematics:
    """Foot kinematics over one stance (plus ``margin`` [s] each side), ``lab`` frame, ground z = 0.

    style: optional 4 factors (strike pitch, push-off pitch, roll, sink) scaling the nominal
    motion, so that stances differ as real ones do (default: all 1)."""
    fp, fo, fr, fs = (1.0, 1.0, 1.0, 1.0) if style is None else style
    sink = sink * fs
    n = int(round((duration + 2 * margin) * rate)) + 1
    t = t0 - margin + np.arange(n) / rate
    s = np.clip((t - t0) / duration, -0.2, 1.2)  # stance phase

    # pitch: +12 deg at strike -> 0 by 15 % -> 0 until 55 % -> -35 deg at toe-off (smooth steps)
    def smooth(u):
        u = np.clip(u, 0, 1)
        return u * u * (3 - 2 * u)

    pitch = np.deg2rad(12 * fp) * (1 - smooth(s / 0.15)) - np.deg2rad(20 * fo) * smooth(
        (s - 0.55) / 0.45
    )
    # positive pitch about +y lowers the toes: heel strike has toes up -> negative rotation about y
    ang = -pitch
    # roll about the long axis: inverted 6 deg at strike, everted 4 deg in mid-stance, inverted
    # 5 deg at push-off (so medial and lateral units load differently over time)
    roll = fr * (
        np.deg2rad(6) * (1 - smooth(s / 0.2))
        - np.deg2rad(4) * np.sin(np.pi * np.clip(s, 0, 1))
        + np.deg2rad(5) * smooth((s - 0.6) / 0.4)
    )
    if side == "right":
        roll = -roll
    c_, s_ = np.cos(roll), np.sin(roll)
    Rx = np.zeros((n, 3, 3))
    Rx[:, 0, 0] = 1
    Rx[:, 1, 1] = c_
    Rx[:, 1, 2] = -s_
    Rx[:, 2, 1] = s_
    Rx[:, 2, 2] = c_
    R = np.einsum("nij,njk->nik", _rot_y(ang), Rx)
    heel = np.array([-0.045, 0.0, -0.070])
    mth = np.array([0.165, 0.0, -0.070])
    # pivot: heel before flat, metatarsal heads after heel-off; the pivot sinks by the sink profile
    depth = sink * np.sin(np.pi * np.clip(s, 0, 1)) ** 0.5 - 0.004 * (s < 0) - 0.004 * (s > 1)
    drift = 0.004 * s  # slow forward slide [m] (marker drift / slip)
    org = np.zeros((n, 3))
    for i in range(n):
        pivot_local = heel if s[i] < 0.35 else mth
        pivot_lab = np.array(
            [0.5 + drift[i] + (0 if s[i] < 0.35 else mth[0] - heel[0]), 0.0, -depth[i]]
        )
        org[i] = pivot_lab - R[i] @ pivot_local
    # continuity at the pivot switch: foot is flat there so both pivots agree in x up to drift
    org[:, 1] = 0.1 if side == "left" else -0.1
    pose = np.tile(np.eye(4), (n, 1, 1))
    pose[:, :3, :3] = R
    pose[:, :3, 3] = org
    v = np.gradient(org, t, axis=0)
    w = np.zeros((n, 3))
    dR = np.gradient(R, t, axis=0)
    W = np.einsum("nij,nkj->nik", dR, R)  # skew(omega) = dR R^T
    w[:, 0], w[:, 1], w[:, 2] = W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]
    twist = np.hstack([v, w])
    return FootKinematics(side, t, pose, pose.copy(), twist, twist.copy(), nominal_points(side))


__all__ = ["NOMINAL_POINTS", "nominal_points", "rolling_foot"]
