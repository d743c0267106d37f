"""URDF of the 14-segment, 27-DOF gait model (Anderson & Pandy 1999-like, as in the seed report).

Design
------
* Root: a massless ``ground`` link fixed to the world. The pelvis has six DOF built from **six
  explicit joints** (prismatic ``pelvis_tx``, ``pelvis_ty``, ``pelvis_tz`` along lab X, Y, Z, then
  revolute ``pelvis_rz`` (yaw), ``pelvis_rx`` (obliquity), ``pelvis_ry`` (tilt)) chained through
  massless intermediate links. Hence ``nq == nv == 27`` and every coordinate is an angle or a
  length with a physical meaning and a limit. A Pinocchio free-flyer would give ``nq = 28`` (unit
  quaternion) and ``nv = 27``; we prefer the explicit joints so that ``q`` can be filtered,
  differentiated and bounded component-wise. The price is the Euler singularity at a pelvis
  obliquity of +-90 deg, far outside walking.
* Segment frames have their origin at the proximal joint and axes aligned with ``lab`` (X forward,
  Y left, Z up) in the neutral standing pose (q = 0).
* Lumbar 3 (extension, bending, rotation); hip 3 (flexion, adduction, rotation); knee 1 (flexion);
  ankle 2: talocrural ``ankle_*`` about the medio-lateral axis, then ``subtalar_*`` simplified as a
  second hinge about the hindfoot antero-posterior axis (inversion/eversion; the real subtalar axis
  is inclined ~42 deg up and ~23 deg medially, not modelled); shoulder 2 (flexion, abduction);
  elbow 1. Head and neck are in the torso, the hands in the forearms.
* The toes are welded to the hindfoot by the ``fixed`` joint ``mtp_{l,r}`` at the metatarsal heads;
  making it ``revolute`` later turns on a toe hinge.
* Foot frames (massless links on fixed joints): ``PL, PM, AL, AM`` (posterior/anterior,
  lateral/medial) on the hindfoot at the sole (z = -ankle height), posterior ones near the heel,
  anterior ones at the metatarsal heads; ``TT`` on the toes at the toe tip. Lateral is +Y for the
  left foot, -Y for the right.

Signs: positive flexion/adduction/internal rotation/inversion/dorsiflexion/abduction on both sides
(the axis is mirrored for the right side where needed).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from gc_ocp.foot import SEED_LAYOUT
from gc_ocp.model.anthropometry import Anthropometry, Segment, anthropometry

SEED_SUBJECT = {"height": 1.70, "mass": 689.0 / 9.81}
"""The seed report's subject: body weight 689 N, height 1.70 m (BW*H = 1173 N m)."""

SEED_URDF = Path(__file__).resolve().parents[2] / "models" / "gc_ocp_seed_subject.urdf"

PELVIS_JOINTS = ("pelvis_tx", "pelvis_ty", "pelvis_tz", "pelvis_rz", "pelvis_rx", "pelvis_ry")
POSTERIOR_HALF_WIDTH = 0.3
"""Posterior units at +-0.3 foot widths from the foot axis (the heel is narrower than the forefoot)."""
POSTERIOR_FROM_HEEL = 0.08
"""Posterior units 0.08 foot lengths in front of the heel (centre of the heel pad)."""

_LIM_T = 20.0  # pelvis translation limit [m]
D = np.pi / 180.0


def _f(x: float) -> str:
    return f"{x:.12g}"


def _v(v) -> str:
    return " ".join(_f(float(x)) for x in v)


def _link(name: str, seg: Segment | None = None) -> str:
    if seg is None:
        return f'  <link name="{name}"/>\n'
    i = seg.inertia
    return (
        f'  <link name="{name}">\n    <inertial>\n'
        f'      <origin xyz="{_v(seg.com)}" rpy="0 0 0"/>\n'
        f'      <mass value="{_f(seg.mass)}"/>\n'
        f'      <inertia ixx="{_f(i[0, 0])}" ixy="{_f(i[0, 1])}" ixz="{_f(i[0, 2])}" '
        f'iyy="{_f(i[1, 1])}" iyz="{_f(i[1, 2])}" izz="{_f(i[2, 2])}"/>\n'
        f"    </inertial>\n  </link>\n"
    )


def _joint(name, kind, parent, child, xyz=(0, 0, 0), axis=None, lim=None) -> str:
    s = f'  <joint name="{name}" type="{kind}">\n'
    s += f'    <parent link="{parent}"/>\n    <child link="{child}"/>\n'
    s += f'    <origin xyz="{_v(xyz)}" rpy="0 0 0"/>\n'
    if axis is not None:
        s += f'    <axis xyz="{_v(axis)}"/>\n'
    if lim is not None:
        s += (
            f'    <limit lower="{_f(lim[0])}" upper="{_f(lim[1])}" effort="1000" velocity="100"/>\n'
        )
    return s + "  </joint>\n"


def _chain(parts: list[str], joints, parent: str, child: str, xyz, seg: Segment | None) -> None:
    """Consecutive revolute/prismatic joints ``(name, kind, axis, limits)`` from ``parent`` to
    ``child`` at ``xyz``; intermediate links are massless and share the joint origin."""
    prev = parent
    for k, (name, kind, axis, lim) in enumerate(joints):
        last = k == len(joints) - 1
        link = child if last else f"{name}_link"
        parts.append(_joint(name, kind, prev, link, xyz if k == 0 else (0, 0, 0), axis, lim))
        parts.append(_link(link, seg if last else None))
        prev = link


def sole_points_default(a: Anthropometry, side: str) -> dict[str, np.ndarray]:
    """Default unit positions: ``PL, PM, AL, AM`` in the hindfoot frame, ``TT`` in the toes frame [m]."""
    lat = 1.0 if side in ("l", "left") else -1.0
    z = -a.ankle_height
    xp = a.heel_x + POSTERIOR_FROM_HEEL * a.foot_length
    yp = POSTERIOR_HALF_WIDTH * a.foot_width
    ya = 0.5 * a.foot_width
    xa = a.metatarsal_x
    return {
        "PL": np.array([xp, lat * yp, z]),
        "PM": np.array([xp, -lat * yp, z]),
        "AL": np.array([xa, lat * ya, z]),
        "AM": np.array([xa, -lat * ya, z]),
        "TT": np.array([a.toe_tip_x - a.metatarsal_x, 0.0, z - a.mtp_z]),
    }


def generate_urdf(
    height_m: float, mass_kg: float, name: str = "gc_ocp_subject", sex: str = "male"
) -> str:
    """URDF text of the gait model scaled to ``height_m`` [m] and ``mass_kg`` [kg] (de Leva 1996)."""
    a = anthropometry(height_m, mass_kg, sex)
    S = a.segments
    parts = [
        '<?xml version="1.0"?>\n',
        f"<!-- gc_ocp gait model: 14 segments, 27 DOF. height {height_m} m, mass {_f(mass_kg)} kg, "
        f"de Leva (1996) {sex}. Generated by gc_ocp.model.urdf.generate_urdf; do not edit. -->\n",
        f'<robot name="{name}">\n',
        _link("ground"),
    ]
    T = _LIM_T
    _chain(
        parts,
        [
            ("pelvis_tx", "prismatic", (1, 0, 0), (-T, T)),
            ("pelvis_ty", "prismatic", (0, 1, 0), (-T, T)),
            ("pelvis_tz", "prismatic", (0, 0, 1), (-T, T)),
            ("pelvis_rz", "revolute", (0, 0, 1), (-2 * np.pi, 2 * np.pi)),
            ("pelvis_rx", "revolute", (1, 0, 0), (-80 * D, 80 * D)),
            ("pelvis_ry", "revolute", (0, 1, 0), (-80 * D, 80 * D)),
        ],
        "ground",
        "pelvis",
        (0, 0, 0),
        S["pelvis"],
    )
    _chain(
        parts,
        [
            ("lumbar_extension", "revolute", (0, -1, 0), (-90 * D, 30 * D)),
            ("lumbar_bending", "revolute", (1, 0, 0), (-40 * D, 40 * D)),
            ("lumbar_rotation", "revolute", (0, 0, 1), (-45 * D, 45 * D)),
        ],
        "pelvis",
        "torso",
        (0, 0, a.lumbar_height),
        S["torso"],
    )
    for s in ("l", "r"):
        m = 1.0 if s == "l" else -1.0  # mirror for the right side
        _chain(
            parts,
            [
                (f"hip_flexion_{s}", "revolute", (0, -1, 0), (-40 * D, 120 * D)),
                (f"hip_adduction_{s}", "revolute", (-m, 0, 0), (-50 * D, 30 * D)),
                (f"hip_rotation_{s}", "revolute", (0, 0, -m), (-45 * D, 45 * D)),
            ],
            "pelvis",
            f"thigh_{s}",
            (0, m * a.hip_width / 2, 0),
            S[f"thigh_{s}"],
        )
        _chain(
            parts,
            [(f"knee_{s}", "revolute", (0, 1, 0), (-15 * D, 140 * D))],
            f"thigh_{s}",
            f"shank_{s}",
            (0, 0, -a.thigh_length),
            S[f"shank_{s}"],
        )
        _chain(
            parts,
            [
                (f"ankle_{s}", "revolute", (0, -1, 0), (-60 * D, 45 * D)),
                (f"subtalar_{s}", "revolute", (-m, 0, 0), (-35 * D, 35 * D)),
            ],
            f"shank_{s}",
            f"hindfoot_{s}",
            (0, 0, -a.shank_length),
            S[f"hindfoot_{s}"],
        )
        parts.append(
            _joint(f"mtp_{s}", "fixed", f"hindfoot_{s}", f"toes_{s}", (a.metatarsal_x, 0, a.mtp_z))
        )
        parts.append(_link(f"toes_{s}", S[f"toes_{s}"]))
        for u, p in sole_points_default(a, s).items():
            parent = f"{SEED_LAYOUT.parent(u)}_{s}"
            parts.append(_joint(f"{u}_{s}_joint", "fixed", parent, f"{u}_{s}", p))
            parts.append(_link(f"{u}_{s}"))
        _chain(
            parts,
            [
                (f"shoulder_flexion_{s}", "revolute", (0, -1, 0), (-90 * D, 180 * D)),
                (f"shoulder_abduction_{s}", "revolute", (m, 0, 0), (-30 * D, 180 * D)),
            ],
            "torso",
            f"upper_arm_{s}",
            (0, m * a.shoulder_width / 2, a.shoulder_height),
            S[f"upper_arm_{s}"],
        )
        _chain(
            parts,
            [(f"elbow_{s}", "revolute", (0, -1, 0), (-5 * D, 160 * D))],
            f"upper_arm_{s}",
            f"forearm_{s}",
            (0, 0, -a.upper_arm_length),
            S[f"forearm_{s}"],
        )
    parts.append("</robot>\n")
    return "".join(parts)


def write_urdf(
    path: str | Path,
    height_m: float,
    mass_kg: float,
    name: str = "gc_ocp_subject",
    sex: str = "male",
) -> Path:
    """Write :func:`generate_urdf` to ``path``; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(generate_urdf(height_m, mass_kg, name, sex))
    return path


def write_seed_urdf(path: str | Path = SEED_URDF) -> Path:
    """Regenerate ``models/gc_ocp_seed_subject.urdf`` (689 N, 1.70 m)."""
    return write_urdf(
        path, SEED_SUBJECT["height"], SEED_SUBJECT["mass"], name="gc_ocp_seed_subject"
    )


if __name__ == "__main__":  # python -m gc_ocp.model.urdf
    print(write_seed_urdf())
