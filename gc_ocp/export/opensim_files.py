"""OpenSim's file formats, written: markers (``.trc``), tables of coordinates or ground reactions
(``.mot`` / ``.sto``) and the ``ExternalLoads`` set that applies ground reactions to a model.

The readers are :mod:`gc_ocp.io.opensim`; both use the one frame change
:data:`~gc_ocp.io._common.Y_UP_TO_LAB` (OpenSim: X forward, Y up, Z right; ``lab``: X forward,
Y left, Z up), so a file written here is read back unchanged.

A ground reaction is written as OpenSim's tools expect it (``ExternalForce`` with
``point_expressed_in_body = ground``): per force set, the force, its point of application (the
centre of pressure on the ground plane) and the free torque about the vertical, columns
``ground_force_<s>_v{x,y,z}``, ``ground_force_<s>_p{x,y,z}``, ``ground_torque_<s>_{x,y,z}``
with ``<s>`` = ``r`` / ``l`` (the layout of OpenSim's example data). Where the
vertical force is below ``min_force`` the COP is undefined: the whole set is written as zeros
there (what a lab's thresholded plate gives), which is what inverse dynamics wants (no force,
no torque).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from gc_ocp.errors import InputError
from gc_ocp.io._common import Y_UP_TO_LAB
from gc_ocp.outputs import atomic_write_text

LAB_TO_Y_UP = Y_UP_TO_LAB.T
"""``lab`` -> OpenSim (the inverse of the readers' rotation)."""

COP_MIN_FORCE = 20.0
"""[N] Vertical force below which a set's centre of pressure is undefined and the set is written
as zeros (the readers' :data:`gc_ocp.io.opensim.COP_MIN_FORCE`, the usual plate threshold)."""


def _fmt(a: np.ndarray) -> list[str]:
    return ["\t".join(f"{v:.9g}" for v in row) for row in a]


def write_trc(
    path: str | Path, names: Sequence[str], markers: np.ndarray, time: np.ndarray
) -> Path:
    """Markers ``(n, m, 3)`` [m] in ``lab`` at ``time`` ``(n,)`` [s] as an OpenSim ``.trc``
    (Y up, millimetres; a missing sample, NaN, is an empty cell)."""
    markers = np.asarray(markers, float)
    time = np.asarray(time, float)
    n, m, _ = markers.shape
    if len(names) != m or time.shape != (n,):
        raise InputError(
            f"write_trc({path}): {len(names)} names and {time.size} times for markers of shape "
            f"{markers.shape}; give one name per marker and one time per frame."
        )
    rate = float(1.0 / np.median(np.diff(time))) if n > 1 else 0.0
    xyz = (markers @ LAB_TO_Y_UP.T) * 1e3
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{Path(path).name}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame"
        "\tOrigNumFrames",
        f"{rate:.6g}\t{rate:.6g}\t{n}\t{m}\tmm\t{rate:.6g}\t1\t{n}",
        "Frame#\tTime\t" + "\t".join(f"{s}\t\t" for s in names),
        "\t\t" + "\t".join(f"X{i + 1}\tY{i + 1}\tZ{i + 1}" for i in range(m)),
        "",
    ]
    for k in range(n):
        cells = ["" if not np.isfinite(v) else f"{v:.6f}" for v in xyz[k].ravel()]
        lines.append(f"{k + 1}\t{time[k]:.6f}\t" + "\t".join(cells))
    return atomic_write_text(Path(path), "\n".join(lines) + "\n")


def write_table(
    path: str | Path,
    columns: Sequence[str],
    data: np.ndarray,
    name: str,
    in_degrees: bool = False,
) -> Path:
    """An OpenSim table (``.mot`` / ``.sto``, version 1 header): ``columns`` (the first
    ``time``) over the rows of ``data``; ``in_degrees`` sets the header's ``inDegrees``."""
    data = np.asarray(data, float)
    if data.ndim != 2 or data.shape[1] != len(columns) or columns[0] != "time":
        raise InputError(
            f"write_table({path}): data of shape {data.shape} for {len(columns)} columns; the "
            "first column must be 'time' and every row needs one value per column."
        )
    head = [
        name,
        "version=1",
        f"nRows={data.shape[0]}",
        f"nColumns={data.shape[1]}",
        f"inDegrees={'yes' if in_degrees else 'no'}",
        "endheader",
        "\t".join(columns),
    ]
    return atomic_write_text(Path(path), "\n".join(head + _fmt(data)) + "\n")


def grf_set(
    wrench: np.ndarray, ground_height: float | np.ndarray, min_force: float = COP_MIN_FORCE
) -> np.ndarray:
    """``(n, 9)``: force, centre of pressure and free torque (OpenSim frame) of a wrench
    ``(n, 6)`` (force [N], moment [N m] about the ``lab`` origin, ``lab``) acting on the ground
    plane ``z = ground_height`` (a number, or one per row: plates at different heights); zeros
    where the vertical force is below ``min_force``.

    With the COP ``p`` on the plane and the free torque ``T`` about the vertical,
    ``M = p x F + T``: ``p_x = (h F_x - M_y) / F_z``, ``p_y = (M_x + h F_y) / F_z``,
    ``T_z = M_z - p_x F_y + p_y F_x``."""
    w = np.asarray(wrench, float)
    f, m = w[:, :3], w[:, 3:]
    h = np.broadcast_to(np.asarray(ground_height, float), (w.shape[0],))
    on = np.isfinite(w).all(axis=1) & (f[:, 2] >= min_force)
    fz = np.where(on, f[:, 2], 1.0)
    px = (h * f[:, 0] - m[:, 1]) / fz
    py = (m[:, 0] + h * f[:, 1]) / fz
    tz = m[:, 2] - px * f[:, 1] + py * f[:, 0]
    p = np.column_stack([px, py, np.full_like(px, h)])
    t = np.column_stack([np.zeros_like(tz), np.zeros_like(tz), tz])
    out = np.concatenate([f @ LAB_TO_Y_UP.T, p @ LAB_TO_Y_UP.T, t @ LAB_TO_Y_UP.T], axis=1)
    out[~on] = 0.0
    return out


def grf_columns(side: str) -> list[str]:
    """The nine columns of ``side``'s set (``ground_force_r_vx``, ..., ``ground_torque_r_z``)."""
    t = SIDE_TOKEN[side]
    return [
        *(f"ground_force_{t}_v{a}" for a in "xyz"),
        *(f"ground_force_{t}_p{a}" for a in "xyz"),
        *(f"ground_torque_{t}_{a}" for a in "xyz"),
    ]


SIDE_TOKEN = {"right": "r", "left": "l"}
"""The token of each foot in the column names (it tells the readers the side)."""


def write_grf(
    path: str | Path,
    time: np.ndarray,
    wrenches: Mapping[str, np.ndarray],
    ground_height: float | np.ndarray | Mapping[str, float | np.ndarray] = 0.0,
    min_force: float = COP_MIN_FORCE,
) -> Path:
    """Ground reactions per foot (``{side: (n, 6)}`` at ``time``, force [N] and moment [N m]
    about the ``lab`` origin) on the ground plane ``ground_height`` (per side, a number or one
    per row) as an OpenSim ``.mot`` in the external-loads layout (module doc):
    one set per foot (:func:`grf_columns`)."""
    time = np.asarray(time, float)
    heights = (
        ground_height
        if isinstance(ground_height, Mapping)
        else dict.fromkeys(wrenches, ground_height)
    )
    cols, blocks = ["time"], [time[:, None]]
    for side, w in wrenches.items():
        if side not in SIDE_TOKEN:
            raise InputError(f"write_grf({path}): side {side!r} is not one of {list(SIDE_TOKEN)}")
        if np.shape(w) != (time.size, 6):
            raise InputError(
                f"write_grf({path}): the {side} wrench has shape {np.shape(w)}, need "
                f"({time.size}, 6) (one row per time)."
            )
        cols += grf_columns(side)
        blocks.append(grf_set(w, heights[side], min_force))
    return write_table(path, cols, np.concatenate(blocks, axis=1), Path(path).stem)


def external_loads_xml(
    grf_file: str | Path, bodies: Mapping[str, str], name: str = "ground_reactions"
) -> str:
    """An OpenSim ``ExternalLoads`` document applying each foot's set of a :func:`write_grf`
    file to its body (``{side: body name}``, e.g. ``{"right": "calcn_r"}``); the file is named
    relative to the XML's folder, as OpenSim resolves it."""
    forces = []
    for side, body in bodies.items():
        t = SIDE_TOKEN[side]
        forces.append(
            f"""			<ExternalForce name="ground_{t}">
				<applied_to_body>{escape(body)}</applied_to_body>
				<force_expressed_in_body>ground</force_expressed_in_body>
				<point_expressed_in_body>ground</point_expressed_in_body>
				<force_identifier>ground_force_{t}_v</force_identifier>
				<point_identifier>ground_force_{t}_p</point_identifier>
				<torque_identifier>ground_torque_{t}_</torque_identifier>
			</ExternalForce>"""
        )
    body = "\n".join(forces)
    return f"""<?xml version="1.0" encoding="UTF-8" ?>
<OpenSimDocument Version="40000">
	<ExternalLoads name="{escape(name)}">
		<objects>
{body}
		</objects>
		<groups />
		<datafile>{escape(Path(grf_file).name)}</datafile>
	</ExternalLoads>
</OpenSimDocument>
"""


__all__ = (
    "COP_MIN_FORCE",
    "LAB_TO_Y_UP",
    "SIDE_TOKEN",
    "external_loads_xml",
    "grf_columns",
    "grf_set",
    "write_grf",
    "write_table",
    "write_trc",
)
