"""C3D force-plate types: the wrench of one plate from its analog channels.

Every function here works in **plate axes** (C3D corner order: x = c1 - c2, y = c1 - c4,
z = x cross y; for AMTI/Bertec/Kistler plates z points down into the plate) and returns the
force and the moment **about the geometric centre of the plate surface** (the mean of the four
corners), in the channels' units (N; moments in N x length unit). The caller rotates them to the
lab and re-expresses the moment about its reference point (:mod:`gc_ocp.io.c3d`).

C3D FORCE_PLATFORM:TYPE (C3D User Guide, "Force platforms"):

* **1**: six channels ``Fx Fy Fz Px Py Tz``: force, centre of pressure (Px, Py) on the surface
  measured from the centre of the surface, and the free moment Tz about the vertical through it.
* **2**: six channels ``Fx Fy Fz Mx My Mz``: force and moment about the plate origin O (the
  transducer origin, below the surface). ``ORIGIN`` = the vector from O to the surface centre,
  in plate axes (its z is negative: the surface is above O and z points down; Vicon stores
  the opposite sign, which is undone).
* **3**: eight Kistler channels ``fx12 fx34 fy14 fy23 fz1 fz2 fz3 fz4``; ``ORIGIN`` =
  ``(a, b, az0)``: the sensors' offsets from the centre along x and y, and the height of the
  sensor plane relative to the surface (negative: the surface is above it, z down).
* **4**: as type 2, but the six channels are raw signals and ``CAL_MATRIX`` (6 x 6) turns them
  into ``Fx Fy Fz Mx My Mz``: ``wrench = CAL @ channels``.

Types 5-7 (type 2 or 3 stored with an 8 x 6 matrix, uncommon) are refused with the fix.
"""

from __future__ import annotations

import numpy as np

SUPPORTED_TYPES = (1, 2, 3, 4)
N_CHANNELS = {1: 6, 2: 6, 3: 8, 4: 6}


def type1_wrench(
    channels: np.ndarray, length_per_unit: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """Type 1: ``channels (n, 6)`` = Fx Fy Fz [N], Px Py [length], Tz [N x length].

    Returns force ``(n, 3)`` and moment ``(n, 3)`` about the surface centre (the origin of Px,
    Py): ``M = (Px, Py, 0) x F + (0, 0, Tz)``. ``length_per_unit`` converts Px, Py to the unit of
    the moment's length (1 when both are in mm)."""
    ch = np.asarray(channels, dtype=float)
    force = ch[:, :3]
    d = np.zeros_like(force)
    d[:, :2] = ch[:, 3:5] * length_per_unit
    moment = np.cross(d, force)
    moment[:, 2] += ch[:, 5]
    return force, moment


def type2_wrench(channels: np.ndarray, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Type 2: ``channels (n, 6)`` = force and moment about the plate origin O; ``origin`` (3,)
    = ORIGIN, the vector from O to the surface centre C (plate axes, the moment's length unit).

    Returns force and moment about C: ``M_C = M_O + (O - C) x F = M_O - ORIGIN x F``. A positive
    ORIGIN z (some writers store the vector C -> O) is negated: O lies below the surface, as
    ezc3d and BTK also assume."""
    ch = np.asarray(channels, dtype=float)
    force = ch[:, :3]
    origin = np.asarray(origin, dtype=float)
    if origin[2] > 0:  # stored with the opposite sign (Vicon): O is below the surface
        origin = -origin
    r = np.broadcast_to(-origin, force.shape)
    return force, ch[:, 3:6] + np.cross(r, force)


def type4_wrench(
    channels: np.ndarray, origin: np.ndarray, cal_matrix: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Type 4: ``wrench = cal_matrix @ channels`` (rows Fx Fy Fz Mx My Mz), then as type 2."""
    cal = np.asarray(cal_matrix, dtype=float)
    if cal.shape != (6, 6):
        raise ValueError(f"a type-4 plate needs a 6 x 6 CAL_MATRIX, but got {cal.shape}")
    return type2_wrench(np.asarray(channels, dtype=float) @ cal.T, origin)


def type3_wrench(channels: np.ndarray, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Type 3 (Kistler): ``channels (n, 8)`` = fx12 fx34 fy14 fy23 fz1 fz2 fz3 fz4 [N];
    ``origin`` = (a, b, az0) [length].

    Kistler's formulae (sensor 1 at (+a, +b), 2 at (-a, +b), 3 at (-a, -b), 4 at (+a, -b)):
    ``Mx = b (fz1 + fz2 - fz3 - fz4)``, ``My = a (-fz1 + fz2 + fz3 - fz4)``,
    ``Mz = b (-fx12 + fx34) + a (fy14 - fy23)`` about the centre S of the sensor plane; about
    the surface centre C (``C - S = (0, 0, az0)``): ``M_C = M_S + (S - C) x F``, i.e. Kistler's
    ``Mx' = Mx + az0 Fy``, ``My' = My - az0 Fx``."""
    ch = np.asarray(channels, dtype=float)
    a, b, az0 = (float(v) for v in np.asarray(origin, dtype=float)[:3])
    az0 = -abs(az0)  # the surface is above the sensor plane (z down), whatever the sign stored
    fx12, fx34, fy14, fy23, fz1, fz2, fz3, fz4 = ch.T
    force = np.column_stack([fx12 + fx34, fy14 + fy23, fz1 + fz2 + fz3 + fz4])
    m_s = np.column_stack(
        [
            b * (fz1 + fz2 - fz3 - fz4),
            a * (-fz1 + fz2 + fz3 - fz4),
            b * (-fx12 + fx34) + a * (fy14 - fy23),
        ]
    )
    r = np.broadcast_to(np.array([0.0, 0.0, -az0]), force.shape)
    return force, m_s + np.cross(r, force)


def plate_axes(corners: np.ndarray) -> np.ndarray:
    """Columns = plate x, y, z axes in the frame of ``corners (4, 3)`` (C3D corner order:
    x = c1 - c2, y = c1 - c4, z = x cross y; y re-orthogonalised)."""
    x = corners[0] - corners[1]
    y = corners[0] - corners[3]
    z = np.cross(x, y)
    y = np.cross(z, x)
    return np.column_stack([v / np.linalg.norm(v) for v in (x, y, z)])


def plate_wrench(
    kind: int,
    channels: np.ndarray,
    origin: np.ndarray,
    cal_matrix: np.ndarray | None = None,
    cop_length_per_unit: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Force and moment about the surface centre, plate axes, for C3D plate ``kind`` (1-4)."""
    if kind == 1:
        return type1_wrench(channels, cop_length_per_unit)
    if kind == 2:
        return type2_wrench(channels, origin)
    if kind == 3:
        return type3_wrench(channels, origin)
    if kind == 4:
        if cal_matrix is None:
            raise ValueError("a type-4 plate needs its CAL_MATRIX")
        return type4_wrench(channels, origin, cal_matrix)
    raise ValueError(f"C3D force-plate type {kind} is not one of {SUPPORTED_TYPES}")
