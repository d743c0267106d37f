"""Ground tilt: the contact surface of a trial tilted by a constant small angle (a throw-away effect).

Test data of ``tests/test_one_file_effect.py``: this file, copied into
``gc_ocp/estimation/components/`` of a copy of the package, plus one registration line in
``components/__init__.py``, is a tenth effect that ``gc-ocp fit --effects``, ``gc-ocp diagnose``
and ``gc-ocp benchmark-diagnosis`` use without any other change. It is not part of the package.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from gc_ocp.estimation.components.base import Component, DecodeContext, SummaryRow

SLOT = "ground_tilt"
ENTRIES = ("tilt_x", "tilt_y")


@dataclass(frozen=True)
class GroundTilt(Component):
    """A constant tilt of the ground under every stance of a trial (a floor or treadmill deck
    not level, the same under each of its stances).

    Under stance ``s`` of trial ``r`` the surface is rotated by the small rotation vector
    ``(tilt_x, tilt_y, 0)`` of that trial about the stance's reference point (the plate
    centre), so the height under unit ``i`` at lab ``(x_i, y_i)`` is ::

        h_i = h + tilt_x * (y_i - ref_y) - tilt_y * (x_i - ref_x)

    (small angles, penetration along lab z, as ``ground_offset``'s tilts, which are per stance
    and come with a height offset; this one has two angles per trial and no offset).

    Variables ``(name, trial)``: ``(tilt_x, tilt_y)`` [rad], prior N(0, sigma^2) with
    ``sigma_deg`` = 0.5 deg (a floor levelled with a spirit level), bounds ``bound_sigmas`` = 4
    sigmas. Scope ``"trial"``: a held-out stance of a fitted trial keeps its trial's tilt.
    ``fixed``: ``{trial: (tilt_x, tilt_y)}`` [rad]. Neutral value: zero (the level plate).

    Benchmark: the moderate (0.5 deg) and strong (1 deg) tilt, both angles of every trial with
    a random sign.
    """

    sigma_deg: float = 0.5
    bound_sigmas: float = 4.0
    fixed: dict | None = None
    name: str = "ground_tilt"
    scope = "trial"
    neutral_at_zero = True
    candidate = True
    benchmark_values = {"moderate": 0.5, "strong": 1.0}  # both tilts [deg]

    @classmethod
    def inject(cls, base, value, stances, rng) -> tuple:
        """The base plus both tilts of every trial at ``value`` [deg] with random signs (two
        draws per trial, in order of first stance)."""
        a = np.deg2rad(value)
        fixed = {
            trial: (a * rng.choice([-1.0, 1.0]), a * rng.choice([-1.0, 1.0]))
            for trial in dict.fromkeys(st.trial for st in stances)
        }
        return (*base, cls(fixed=fixed))

    def _free(self, trial: str) -> bool:
        return self.fixed is None or trial not in self.fixed

    def with_prior_scale(self, factor: float) -> GroundTilt:
        return replace(self, sigma_deg=self.sigma_deg * factor)

    def declare(self, variables, stances) -> None:
        sig = np.full(2, np.deg2rad(self.sigma_deg))
        for trial in dict.fromkeys(st.trial for st in stances):
            if self._free(trial):
                variables.prior_variable((self.name, trial), 2, sig, self.bound_sigmas * sig)

    def slot_sizes(self, layout) -> dict[str, int]:
        return {SLOT: 2}

    def slots(self, variables, index, stance) -> dict:
        if self._free(stance.trial):
            return {SLOT: variables.get((self.name, stance.trial))}
        return {SLOT: ca.MX(ca.DM(np.asarray(self.fixed[stance.trial], float).reshape(2, 1)))}

    def edit_contact(self, frame) -> None:
        tilt = frame.slot(SLOT)
        ref = frame.reference
        ground = {}
        for i in range(frame.layout.n):
            p = frame.points[i]
            ground[i] = frame.ground(i) + tilt[0] * (p[1] - ref[1]) - tilt[1] * (p[0] - ref[0])
        frame.unit_ground.update(ground)

    def signature(self) -> tuple:
        return ("GroundTilt",)  # values and priors only enter through its slot

    def decode(self, ctx: DecodeContext) -> dict:
        """``{trial: {"tilt_x", "tilt_y" [rad], their "_se", and "_deg", "_se_deg"}}``."""
        out: dict = {}
        for st in ctx.stances:
            if st.trial in out:
                continue
            if self._free(st.trial):
                v, s = ctx.values((self.name, st.trial))
            else:
                v, s = np.asarray(self.fixed[st.trial], float), np.zeros(2)
            e = {}
            for j, key in enumerate(ENTRIES):
                e[key], e[key + "_se"] = float(v[j]), float(s[j])
                e[key + "_deg"], e[key + "_se_deg"] = (
                    float(np.rad2deg(v[j])),
                    float(np.rad2deg(s[j])),
                )
            out[st.trial] = e
        return out

    @classmethod
    def describe(cls, block: dict) -> list[SummaryRow]:
        return [
            SummaryRow(f"{trial} {key}", e[key + "_deg"], e[key + "_se_deg"], "deg")
            for trial, e in block.items()
            for key in ENTRIES
        ]

    def frozen(self, block: dict) -> GroundTilt:
        return replace(self, fixed={t: (e["tilt_x"], e["tilt_y"]) for t, e in block.items()})
