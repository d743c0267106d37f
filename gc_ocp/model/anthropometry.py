"""Segment inertia parameters scaled to a subject's height and mass.

Source of the segment tables: P. de Leva (1996), "Adjustments to Zatsiorsky-Seluyanov's segment
inertia parameters", *Journal of Biomechanics* 29(9):1223-1230, Table 4 (mass as % of body mass,
length in mm for the reference subjects, centre of mass as % of the segment length from the
proximal landmark, sagittal / transverse / longitudinal radii of gyration as % of the segment
length). Male reference stature 1741 mm, female 1735 mm; lengths are scaled by ``height /
reference stature``. The values were transcribed by hand: check them against the paper before
relying on a digit.

Foot dimensions are not in de Leva's table in the form the contact model needs; we use the
classic proportions of Drillis & Contini (1966, as tabulated by Winter, *Biomechanics and Motor
Control of Human Movement*, Fig. 4.1): foot length 0.152 H, ankle (malleolus) height 0.039 H,
foot width 0.055 H. Positions inside the foot (heel 0.23 foot lengths behind the ankle, metatarsal
heads 0.72 foot lengths from the heel) and joint-centre offsets not given by de Leva (hip width,
lumbar and shoulder heights) are our assumptions, stated next to each constant below.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gc_ocp.errors import InputError

# name: (mass %, length mm, COM % from proximal, r_sag %, r_trans %, r_long %)
_DE_LEVA = {
    "male": {
        "stature": 1741.0,
        "head": (6.94, 203.3, 59.76, 36.2, 37.6, 31.2),
        "trunk": (43.46, 531.9, 44.86, 37.2, 34.7, 19.1),
        "upper_trunk": (15.96, 170.7, 29.99, 71.6, 45.4, 65.9),
        "middle_trunk": (16.33, 215.5, 45.02, 48.2, 38.3, 46.8),
        "lower_trunk": (11.17, 145.7, 61.15, 61.5, 55.1, 58.7),
        "upper_arm": (2.71, 281.7, 57.72, 28.5, 26.9, 15.8),
        "forearm": (1.62, 268.9, 45.74, 27.6, 26.5, 12.1),
        "hand": (0.61, 86.2, 79.00, 62.8, 51.3, 40.1),
        "thigh": (14.16, 422.2, 40.95, 32.9, 32.9, 14.9),
        "shank": (4.33, 434.0, 44.59, 25.5, 24.9, 10.3),
        "foot": (1.37, 258.1, 44.15, 25.7, 24.5, 12.4),
    },
    "female": {
        "stature": 1735.0,
        "head": (6.68, 200.2, 58.94, 33.0, 35.9, 31.8),
        "trunk": (42.57, 529.3, 41.51, 37.9, 36.1, 19.0),
        "upper_trunk": (15.45, 142.5, 20.77, 74.6, 50.2, 71.8),
        "middle_trunk": (14.65, 205.3, 45.12, 43.3, 35.4, 41.5),
        "lower_trunk": (12.47, 181.5, 49.20, 43.3, 40.2, 44.4),
        "upper_arm": (2.55, 275.1, 57.54, 27.8, 26.0, 14.8),
        "forearm": (1.38, 264.3, 45.59, 26.1, 25.7, 9.4),
        "hand": (0.56, 78.0, 74.74, 53.1, 45.4, 33.5),
        "thigh": (14.78, 368.5, 36.12, 36.9, 36.4, 16.2),
        "shank": (4.81, 432.3, 44.16, 27.1, 26.7, 9.3),
        "foot": (1.29, 228.3, 40.14, 29.9, 27.9, 13.9),
    },
}

FOOT_LENGTH_RATIO = 0.152
"""Foot length / height (Drillis & Contini 1966)."""
ANKLE_HEIGHT_RATIO = 0.039
"""Lateral malleolus height above the sole / height (Drillis & Contini 1966)."""
FOOT_WIDTH_RATIO = 0.055
"""Foot width / height (Drillis & Contini 1966)."""
HEEL_BEHIND_ANKLE = 0.23
"""Heel (posterior-most point) behind the ankle joint centre, in foot lengths (assumption)."""
METATARSAL_FROM_HEEL = 0.72
"""Metatarsal heads from the heel, in foot lengths (assumption, typical of foot-shape data)."""
MTP_HEIGHT = 0.25
"""Metatarsophalangeal joint height above the sole, in ankle heights (assumption)."""
TOES_MASS_FRACTION = 0.15
"""Part of the foot mass carried by the toes segment (assumption)."""
HIP_WIDTH_RATIO = 0.10
"""Distance between the hip joint centres / height (assumption; ~0.17 m at 1.70 m)."""
LUMBAR_HEIGHT_RATIO = 0.06
"""Lumbar (L5-S1) joint above the mid-hip point / height (assumption)."""
SHOULDER_HEIGHT_RATIO = 0.23
"""Shoulder joint centres above the lumbar joint / height (assumption)."""
SHOULDER_WIDTH_RATIO = 0.19
"""Distance between the shoulder joint centres / height (assumption)."""


@dataclass(frozen=True)
class Segment:
    """Inertia of one model segment in its own frame (origin at the proximal joint).

    mass [kg]; com [m] ``(3,)``; inertia [kg m^2] ``(3, 3)`` about the COM, axes of the segment frame.
    """

    name: str
    mass: float
    com: np.ndarray
    inertia: np.ndarray


@dataclass(frozen=True)
class Anthropometry:
    """Dimensions [m] and segment inertias of a subject of ``height`` [m] and ``mass`` [kg]."""

    height: float
    mass: float
    sex: str
    thigh_length: float
    shank_length: float
    upper_arm_length: float
    forearm_length: float
    foot_length: float
    foot_width: float
    ankle_height: float
    hip_width: float
    lumbar_height: float
    shoulder_height: float
    shoulder_width: float
    segments: dict[str, Segment]

    @property
    def heel_x(self) -> float:
        """Heel position along the hindfoot X axis [m] (negative: behind the ankle)."""
        return -HEEL_BEHIND_ANKLE * self.foot_length

    @property
    def metatarsal_x(self) -> float:
        """Metatarsal heads (MTP joint) along the hindfoot X axis [m]."""
        return self.heel_x + METATARSAL_FROM_HEEL * self.foot_length

    @property
    def toe_tip_x(self) -> float:
        """Toe tip along the hindfoot X axis [m]."""
        return self.heel_x + self.foot_length

    @property
    def mtp_z(self) -> float:
        """MTP joint height in the hindfoot frame [m] (negative: below the ankle)."""
        return -self.ankle_height * (1.0 - MTP_HEIGHT)


def _rod(
    mass: float, length: float, com_frac: float, r: tuple[float, float, float], down: bool
) -> Segment:
    """Segment along -Z (``down``) or +Z from its proximal joint; radii as fractions of length."""
    sgn = -1.0 if down else 1.0
    com = np.array([0.0, 0.0, sgn * com_frac * length])
    rs, rt, rl = (x * length for x in r)
    # de Leva's sagittal radius is about the antero-posterior (X) axis, the transverse one about
    # the medio-lateral (Y) axis (the anatomical "transverse axis"), the longitudinal about Z: his
    # upper trunk's 71.6 % and 45.4 % of 170.7 mm are those of a box 0.4 m wide and 0.2 m deep
    # (12.5 and 7.6 cm about X and Y), not of one deeper than wide.
    inertia = mass * np.diag([rs**2, rt**2, rl**2])
    return Segment("", mass, com, inertia)


def _combine(parts: list[Segment]) -> tuple[float, np.ndarray, np.ndarray]:
    """Total mass, COM and inertia about the COM (parallel axis theorem)."""
    m = sum(p.mass for p in parts)
    c = sum(p.mass * p.com for p in parts) / m
    inertia = np.zeros((3, 3))
    for p in parts:
        d = p.com - c
        inertia += p.inertia + p.mass * (d @ d * np.eye(3) - np.outer(d, d))
    return m, c, inertia


def anthropometry(height: float, mass: float, sex: str = "male") -> Anthropometry:
    """de Leva (1996) segment parameters scaled to ``height`` [m] and ``mass`` [kg].

    The 14 model segments: pelvis = lower trunk; torso = middle + upper trunk + head/neck;
    forearm = forearm + hand; thigh; shank; the foot split into hindfoot and toes
    (``TOES_MASS_FRACTION``). Segment masses sum to ``mass`` exactly.
    """
    if sex not in _DE_LEVA:
        raise InputError(f'sex "{sex}" is not one of {list(_DE_LEVA)}')
    if not (0.5 < height < 2.5):
        raise InputError(f"height must be in metres (0.5-2.5), but got {height}")
    if not (5.0 < mass < 400.0):
        raise InputError(f"mass must be in kg (5-400), but got {mass}")
    t = _DE_LEVA[sex]
    k = height / (t["stature"] / 1000.0)  # length scale

    def seg(name: str, down: bool, com_from_distal: bool = False) -> Segment:
        mp, ln, cp, rs, rt, rl = t[name]
        ln = ln / 1000.0 * k
        frac = 1.0 - cp / 100.0 if com_from_distal else cp / 100.0
        return _rod(mp / 100.0 * mass, ln, frac, (rs / 100, rt / 100, rl / 100), down)

    # Mass fractions of the model segments (de Leva percentages sum to 100.0 % here).
    foot_len = FOOT_LENGTH_RATIO * height
    ankle_h = ANKLE_HEIGHT_RATIO * height
    hip_w = HIP_WIDTH_RATIO * height
    lumbar_h = LUMBAR_HEIGHT_RATIO * height
    sh_h = SHOULDER_HEIGHT_RATIO * height
    sh_w = SHOULDER_WIDTH_RATIO * height

    segs: dict[str, Segment] = {}
    # Pelvis: lower trunk, COM above the mid-hip point (de Leva: 61.15 % from OMPH towards MIDH,
    # i.e. 38.85 % of the segment above MIDH). Frame origin at the mid-hip point.
    lt = seg("lower_trunk", down=False, com_from_distal=True)
    segs["pelvis"] = Segment("pelvis", lt.mass, lt.com, lt.inertia)
    # Torso (frame at the lumbar joint): middle trunk, upper trunk, head, stacked upwards.
    mt_len = t["middle_trunk"][1] / 1000 * k
    ut_len = t["upper_trunk"][1] / 1000 * k
    mt = seg("middle_trunk", down=False, com_from_distal=True)  # COM % is from XYPH (top)
    ut = seg("upper_trunk", down=False, com_from_distal=True)  # COM % is from CERV (top)
    hd = seg("head", down=False, com_from_distal=True)  # COM % is from the vertex (top)
    ut = Segment("", ut.mass, ut.com + [0, 0, mt_len], ut.inertia)
    hd = Segment("", hd.mass, hd.com + [0, 0, mt_len + ut_len], hd.inertia)
    m, c, i = _combine([mt, ut, hd])
    segs["torso"] = Segment("torso", m, c, i)
    for side in ("l", "r"):
        th = seg("thigh", down=True)
        segs[f"thigh_{side}"] = Segment(f"thigh_{side}", th.mass, th.com, th.inertia)
        sh = seg("shank", down=True)
        segs[f"shank_{side}"] = Segment(f"shank_{side}", sh.mass, sh.com, sh.inertia)
        ua = seg("upper_arm", down=True)
        segs[f"upper_arm_{side}"] = Segment(f"upper_arm_{side}", ua.mass, ua.com, ua.inertia)
        fa = seg("forearm", down=True)
        fa_len = t["forearm"][1] / 1000 * k
        hn = seg("hand", down=True)
        hn = Segment("", hn.mass, hn.com - [0, 0, fa_len], hn.inertia)
        m, c, i = _combine([fa, hn])
        segs[f"forearm_{side}"] = Segment(f"forearm_{side}", m, c, i)
        # Foot: de Leva's foot runs heel -> toe tip along +X; COM 44.15 % from the heel, at
        # mid-height between ankle and sole (assumption). Split into hindfoot and toes.
        mp, _, cp, rs, rt, rl = t["foot"]
        fm = mp / 100.0 * mass
        heel_x = -HEEL_BEHIND_ANKLE * foot_len
        com = np.array([heel_x + cp / 100.0 * foot_len, 0.0, -0.5 * ankle_h])
        # Foot radii (as in _rod): longitudinal about X (the foot lies along X), transverse about
        # the medio-lateral Y, sagittal about the remaining axis in the sagittal plane, Z (the
        # larger, 25.7 % against 24.5 %: a foot is wider than it is tall).
        ifoot = np.diag(
            [(rl / 100 * foot_len) ** 2, (rt / 100 * foot_len) ** 2, (rs / 100 * foot_len) ** 2]
        )
        mtoe = TOES_MASS_FRACTION * fm
        segs[f"hindfoot_{side}"] = Segment(f"hindfoot_{side}", fm - mtoe, com, (fm - mtoe) * ifoot)
        toe_len = (1 - METATARSAL_FROM_HEEL) * foot_len
        # Toes frame at the MTP joint; COM at 40 % of the toe length, at the MTP height.
        it = mtoe * np.diag([(0.2 * toe_len) ** 2, (0.3 * toe_len) ** 2, (0.3 * toe_len) ** 2])
        segs[f"toes_{side}"] = Segment(f"toes_{side}", mtoe, np.array([0.4 * toe_len, 0, 0]), it)

    # Normalise so the segment masses add up to ``mass`` exactly (de Leva's female percentages
    # add up to 99.99 %).
    total = sum(s.mass for s in segs.values())
    segs = {
        n: Segment(n, s.mass * mass / total, s.com, s.inertia * mass / total)
        for n, s in segs.items()
    }
    return Anthropometry(
        height=height,
        mass=mass,
        sex=sex,
        thigh_length=t["thigh"][1] / 1000 * k,
        shank_length=t["shank"][1] / 1000 * k,
        upper_arm_length=t["upper_arm"][1] / 1000 * k,
        forearm_length=t["forearm"][1] / 1000 * k,
        foot_length=foot_len,
        foot_width=FOOT_WIDTH_RATIO * height,
        ankle_height=ankle_h,
        hip_width=hip_w,
        lumbar_height=lumbar_h,
        shoulder_height=sh_h,
        shoulder_width=sh_w,
        segments=segs,
    )
