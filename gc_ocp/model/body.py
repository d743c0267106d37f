"""``BodyModel``: an immutable wrapper of the Pinocchio model of the gait URDF.

The wrapper holds the ``pinocchio.Model`` (never modified after construction) and the names and
ids the other layers need. Work buffers (``pinocchio.Data``) are created on demand by
:meth:`BodyModel.create_data` and owned by the caller, as in Crocoddyl's model/data split.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from gc_ocp.errors import ModelError
from gc_ocp.foot import SEED_LAYOUT, UNITS
from gc_ocp.model.urdf import SEED_SUBJECT, generate_urdf

SIDE_SUFFIX = {"left": "l", "right": "r", "l": "l", "r": "r"}


def _suffix(side: str) -> str:
    try:
        return SIDE_SUFFIX[side]
    except KeyError:
        raise ModelError(f'side "{side}" is not one of ["left", "right"]') from None


@dataclass(frozen=True, eq=False)
class BodyModel:
    """Immutable gait model.

    Attributes
    ----------
    model: the Pinocchio model (do not modify; use :meth:`create_data` for buffers).
    urdf: URDF text it was built from.
    height, mass: subject height [m] and mass [kg] when built by :meth:`from_subject`, else ``None``/total mass.
    """

    model: pin.Model
    urdf: str
    height: float | None = None
    sex: str = "male"
    _frame_ids: dict = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        ids = {f.name: i for i, f in enumerate(self.model.frames)}
        object.__setattr__(self, "_frame_ids", ids)
        for side in ("l", "r"):
            for name in ("hindfoot", "toes", *UNITS):
                if f"{name}_{side}" not in ids:
                    raise ModelError(
                        f'frame "{name}_{side}" is missing from the URDF; regenerate it '
                        "with gc_ocp.model.urdf.generate_urdf"
                    )

    # ---------------------------------------------------------------- construction
    @classmethod
    def from_urdf(cls, urdf: str | Path, height: float | None = None) -> BodyModel:
        """Build from URDF text or a path to a ``.urdf`` file."""
        text = str(urdf)
        if not text.lstrip().startswith("<"):
            p = Path(text)
            if not p.exists():
                raise ModelError(f"URDF file {p} does not exist")
            text = p.read_text()
        model = pin.buildModelFromXML(text)
        return cls(model, text, height)

    @classmethod
    def from_subject(cls, height: float, mass: float, sex: str = "male") -> BodyModel:
        """Anthropometric model (de Leva 1996) of a subject of ``height`` [m] and ``mass`` [kg]."""
        return cls(
            pin.buildModelFromXML(generate_urdf(height, mass, sex=sex)),
            generate_urdf(height, mass, sex=sex),
            height,
            sex,
        )

    @classmethod
    def seed_subject(cls) -> BodyModel:
        """The seed report's subject (689 N, 1.70 m)."""
        return cls.from_subject(SEED_SUBJECT["height"], SEED_SUBJECT["mass"])

    def create_data(self) -> pin.Data:
        """New Pinocchio work buffers for this model."""
        return self.model.createData()

    # ---------------------------------------------------------------- queries
    @property
    def nq(self) -> int:
        return int(self.model.nq)

    @property
    def nv(self) -> int:
        return int(self.model.nv)

    @property
    def mass(self) -> float:
        """Total mass [kg]."""
        return float(sum(i.mass for i in self.model.inertias))

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Names of the 1-DOF joints in ``q`` order (``q[i]`` belongs to ``joint_names[i]``)."""
        names = list(self.model.names)[1:]
        order = np.argsort([self.model.joints[i + 1].idx_q for i in range(len(names))])
        return tuple(names[i] for i in order)

    def q_index(self, joint: str) -> int:
        """Index in ``q`` of the 1-DOF joint ``joint``."""
        if not self.model.existJointName(joint):
            raise ModelError(f'Joint "{joint}" is not a model joint in {list(self.joint_names)}')
        return int(self.model.joints[self.model.getJointId(joint)].idx_q)

    @property
    def lower_limits(self) -> np.ndarray:
        """Lower position limits ``(nq,)`` [m or rad]."""
        return np.array(self.model.lowerPositionLimit)

    @property
    def upper_limits(self) -> np.ndarray:
        return np.array(self.model.upperPositionLimit)

    def frame_id(self, name: str) -> int:
        try:
            return self._frame_ids[name]
        except KeyError:
            raise ModelError(
                f'Name "{name}" is not a model frame name in {sorted(self._frame_ids)}'
            ) from None

    def foot_frames(self, side: str) -> dict[str, int]:
        """Frame ids of ``hindfoot`` and ``toes`` of ``side`` ("left"/"right")."""
        s = _suffix(side)
        return {"hindfoot": self.frame_id(f"hindfoot_{s}"), "toes": self.frame_id(f"toes_{s}")}

    def unit_frames(self, side: str) -> dict[str, int]:
        """Frame ids of the sole units ``PL, PM, AL, AM, TT`` of ``side``."""
        s = _suffix(side)
        return {u: self.frame_id(f"{u}_{s}") for u in UNITS}

    def unit_points_local(self, side: str) -> np.ndarray:
        """Default unit positions ``(5, 3)`` in their parent segment frame (``SEED_LAYOUT``) [m]."""
        s = _suffix(side)
        out = np.empty((len(UNITS), 3))
        for i, u in enumerate(UNITS):
            parent = SEED_LAYOUT.parent(u)
            Mp = self.model.frames[self.frame_id(f"{parent}_{s}")].placement
            Mu = self.model.frames[self.frame_id(f"{u}_{s}")].placement
            out[i] = (Mp.inverse() * Mu).translation
        return out

    def neutral(self) -> np.ndarray:
        """Neutral configuration (all zeros: standing, segment axes aligned with ``lab``)."""
        return np.zeros(self.nq)
