"""The calibrated contact model of a fit, as plain data the exports share: the law with every
parameter at its fitted value, each unit's fitted point on its segment, the ground and the
subject; read from a fit in memory (:class:`~gc_ocp.workflow.fitting.FitReport` or
:class:`~gc_ocp.estimation.result.EstimationResult`) or from its ``fit.json``.

What a simulator can take over is the contact law with its sole (the sole corrections are in
the units' points) and, on a treadmill, the belt. A fit with an effect beyond these (a clock
offset, a ground offset, a toe hinge, another friction law, a denser sole) is refused with the
reason: those change the data or the foot, not only the law, and have no OpenSim counterpart
(the CasADi export could carry them, the estimator's per-frame functions having them, but a
fit.json does not hold the components' settings to rebuild them; both exports take the same
calibrated model for now).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from gc_ocp.errors import InputError, read_document
from gc_ocp.estimation.components.contact import ContactLaw, Param
from gc_ocp.estimation.result import check_fit_document
from gc_ocp.foot import SEED_LAYOUT, TrialKinematics
from gc_ocp.text import read_json_file
from gc_ocp.trial import GRAVITY, belt_velocity

EXPORTABLE = {
    "contact": "ContactLaw",
    "sole": "SoleCorrection",
    "pose": "PoseCorrection",
    "belt": "BeltSpeed",
}
"""The components a calibrated model may have (the default fit's; the pose correction is the
per-stance registration of the markers, not part of the foot: a simulator leaves it out)."""

EXPORT_KEYS = ("components", "blocks", "stance_fits")
"""The keys of ``fit.json`` the exports read (:func:`~gc_ocp.estimation.result.check_fit_document`)."""


@dataclasses.dataclass(frozen=True)
class CalibratedContact:
    """law: the contact law, every parameter fixed at the fit; points: ``{side: (5, 3)}`` each
    unit's point in its parent segment's frame [m] (``parents``: ``{side: ("hindfoot", ...)}``)
    with the sole corrections; ground_height [m]; belt_speed [m/s] (0 overground);
    body_weight [N], height [m], mass [kg]; provenance: the fit's (which trials, settings)."""

    law: ContactLaw
    points: Mapping[str, np.ndarray]
    parents: Mapping[str, tuple[str, ...]]
    ground_height: float
    belt_speed: float
    body_weight: float
    height: float
    mass: float
    provenance: Mapping = dataclasses.field(default_factory=dict)

    @property
    def belt_velocity(self) -> np.ndarray:
        """The belt's velocity in ``lab`` [m/s] (:func:`gc_ocp.trial.belt_velocity`)."""
        return belt_velocity(self.belt_speed)

    @property
    def units(self) -> tuple[str, ...]:
        return SEED_LAYOUT.units

    def value(self, param: str, side: str, unit: str | None = None) -> float:
        """The law's ``param`` (``"k"``, ``"n"``, ``"c"``, ``"mu"``) for ``side`` (and unit)."""
        return float(getattr(self.law, param).value_for(side, unit))

    def model(self) -> tuple:
        """The components a simulation runs: the frozen law (the points are in the feet:
        :meth:`feet`)."""
        return (self.law,)

    def feet(self, kin: TrialKinematics) -> TrialKinematics:
        """``kin`` with each foot's units at the fitted points; a foot the fit has no stance of
        (no calibrated contact) is left out."""
        feet = {
            s: f.with_points(np.asarray(self.points[s]))
            for s, f in kin.feet.items()
            if s in self.points
        }
        return dataclasses.replace(kin, feet=feet)

    # --- from a fit ------------------------------------------------------------------------
    @classmethod
    def from_fit(
        cls, fit, provenance: Mapping | None = None, trial: str | None = None
    ) -> CalibratedContact:
        """From a ``FitReport``, an ``EstimationResult``, a ``fit.json`` dict or its path.
        ``trial``: the fit's name of the trial whose unit points (and, on a treadmill, fitted
        belt speed) are taken (each trial has its own kinematics, whose sole calibration places
        the points; default: the first)."""
        doc = fit_document(fit)  # checked: an object of a known format, with the keys
        solver = doc.get("solver")
        if isinstance(solver, Mapping) and solver.get("success") is False:
            raise InputError(
                f"the fit did not converge ({solver.get('status', 'unknown status')}): its "
                "parameters are where the solver stopped, not an estimate to simulate with; "
                "export a converged fit"
            )
        out = read_document(
            lambda: cls._parse(doc, provenance, trial),
            "the fit document is not a complete gc-ocp fit.json",
            "give the file gc-ocp fit wrote, unedited",
        )
        out.check()
        return out

    def check(self) -> None:
        """Refuse parameters no contact has (the exports would write them: a NaN or negative
        stiffness, a negative friction coefficient) and a body weight or height that is not a
        person's."""
        bad = []
        for side in self.points:
            for u in self.units:
                k = self.value("k", side, u)
                if not (np.isfinite(k) and k > 0):
                    bad.append(f"{side} {u} k = {k:g} (must be > 0)")
            for p, lo in (("n", 1.0), ("c", 0.0), ("mu", 0.0)):
                v = self.value(p, side)
                if not (np.isfinite(v) and v >= lo):
                    bad.append(f"{side} {p} = {v:g} (must be >= {lo:g})")
        if not (np.isfinite(self.body_weight) and self.body_weight > 0):
            bad.append(f"body weight {self.body_weight:g} N")
        if not (np.isfinite(self.height) and 0.5 <= self.height <= 2.6):
            bad.append(f"height {self.height:g} m")
        if bad:
            raise InputError(
                f"the fit's parameters are not a contact's: {'; '.join(bad[:4])}"
                f"{' and more' if len(bad) > 4 else ''}; export the fit gc-ocp fit wrote, unedited"
            )

    @classmethod
    def _parse(cls, doc: Mapping, provenance, trial) -> CalibratedContact:
        """:meth:`from_fit` on a document that has the keys (what it reads, unchecked)."""
        extra = {n: c for n, c in doc["components"].items() if EXPORTABLE.get(n) != c}
        if extra:
            raise InputError(
                f"the fit has effects the exports cannot carry yet: {extra}. Export the fit of "
                "the default model (gc-ocp fit without --effects)."
            )
        block = doc["blocks"]["contact"]
        shared = block.get("shared", {})
        sides = [s for s in ("left", "right") if s in block]
        kw = {
            "k": Param(
                "fixed", {s: {u: block[s][u]["k"] for u in SEED_LAYOUT.units} for s in sides}
            )
        }
        for p in ("n", "c", "mu"):
            if p in shared:
                kw[p] = Param("fixed", float(shared[p]))
            else:
                kw[p] = Param("fixed", {s: float(block[s][p]) for s in sides})
        # the law's settings the fit had (smoothings, their forms; the defaults in a fit.json
        # written before they were recorded), its parameters the fit's
        law = dataclasses.replace(ContactLaw.of_settings(doc.get("contact_law", {})), **kw)
        points, parents, heights = {}, {}, set()
        fits = doc["stance_fits"]
        if not fits:
            raise InputError("the fit has no stance fits: nothing to export")
        trial = fits[0]["trial"] if trial is None else trial
        fits = [sf for sf in fits if sf["trial"] == trial]
        if not fits:
            names = sorted({sf["trial"] for sf in doc["stance_fits"]})
            raise InputError(f"the fit has no trial {trial!r}; its trials are {names}")
        for sf in fits:
            side = sf["side"]
            p = np.asarray(sf["points_local"], float)
            if side in points and not np.allclose(points[side], p, atol=1e-9):
                raise InputError(
                    f"the fit's {side} stances of {trial} have different unit points: a "
                    "per-stance sole cannot be exported"
                )
            points[side] = p
            parents[side] = tuple(sf["parents"])
            heights.add(round(float(sf["ground_height"]), 6))
        if len(heights) > 1:
            raise InputError(
                f"the fit's plates are at different heights {sorted(heights)} m; a simulator has "
                "one floor"
            )
        first = fits[0]
        prov = dict(provenance or doc.get("provenance") or {})
        trials = prov.get("trials") or [{}]
        mass = trials[0].get("mass_kg") or first["body_weight"] / GRAVITY
        # the belt speed the fit used: the BeltSpeed block's fitted value per treadmill trial
        # ({trial: {"value", "se", ...}}: ``trial``'s, else the first trial's), else the
        # nominal one given
        belt = doc["blocks"].get("belt") or {}
        mine = belt.get(trial) if trial is not None else None
        fitted = [
            v["value"]
            for v in ([mine] if isinstance(mine, Mapping) else belt.values())
            if isinstance(v, Mapping) and "value" in v
        ]
        if fitted:
            speed = float(fitted[0])
        else:  # the exported trial's nominal belt (a fit may mix treadmill and floor trials)
            own = [t for t in trials if t.get("name") == first["trial"]] or trials
            v = np.asarray(own[0].get("belt_velocity_m_s", [0.0, 0.0, 0.0]), float)
            speed = float(np.linalg.norm(v))
        return cls(
            law=law,
            points=points,
            parents=parents,
            ground_height=heights.pop(),
            belt_speed=speed,
            body_weight=float(first["body_weight"]),
            height=float(first["height"]),
            mass=float(mass),
            provenance=prov,
        )


def fit_document(fit) -> dict:
    """The JSON document (``fit.json``'s) of a ``FitReport``, an ``EstimationResult``, a
    ``fit.json`` dict or its path, checked once for every reader: a JSON object of a format
    this version reads, with the keys the exports take
    (:func:`~gc_ocp.estimation.result.check_fit_document`)."""
    where = "the fit"
    if isinstance(fit, str | Path):
        fix = "give the fit.json of a fit (in the folder gc-ocp fit --out wrote)."
        doc, where = read_json_file(fit, "Fit file", "a gc-ocp fit.json", fix), str(fit)
        if not isinstance(doc, Mapping):  # valid JSON, but a list, text or number: no document
            kind = {list: "an array", str: "a string", bool: "true/false", type(None): "null"}
            raise InputError(
                f"{fit} is not a gc-ocp fit.json ({kind.get(type(doc), 'a number')}, not a "
                f"JSON object); {fix}"
            )
    elif isinstance(fit, Mapping):
        doc = dict(fit)
    elif callable(getattr(fit, "to_json", None)):
        # a FitReport's own document (its result's, plus the held-out stance's fit and the
        # checks, as fit.json has them), or an EstimationResult's
        doc = fit.to_json()
    else:
        raise InputError(
            f"the fit is a {type(fit).__name__}, not a fit: give a gc_ocp.fit(...) report, its "
            "result, a fit.json dict or the fit.json's path"
        )
    check_fit_document(doc, where, EXPORT_KEYS)  # a later format, or another layout
    return doc


__all__ = ("EXPORTABLE", "CalibratedContact", "fit_document")
