"""Consistency of a trial's forces with its motion and subject, checked before fitting.

Each check either raises an :class:`~gc_ocp.errors.InputError` naming the problem and the fix,
or excludes a stance / corrects a setting with a warning that is recorded in the outputs
(``fit.json``'s provenance). Thresholds come from the physics of walking:

* **Body weight vs plates** (:data:`MASS_TOLERANCE`): over a full stride the plates carry the
  body weight on average (vertical momentum returns to its value); plate calibration and the
  stride window leave a few per cent. Beyond 20 % the mass (or the plates) is wrong: error.
* **Treadmill vs overground**: on a treadmill the stance foot moves backward with the belt
  (``estimate_belt_speed``; ~0 overground). A belt speed of at least :data:`TREADMILL_SPEED`
  with none given: the estimate is used, with a warning. A belt speed given while the feet stand
  still in stance (below :data:`OVERGROUND_SPEED`), or further from their speed than the fit's
  belt correction reaches (``BeltSpeed.bound``, 0.5 m/s: the feet move at the belt's speed to
  within a few cm/s in mid-stance), is an error.
* **Force-motion**: while a plate is loaded (Fz > 20 % BW, middle half of the stance) its centre
  of pressure lies under the foot: within :data:`COP_MARGIN` of the convex hull of the foot's
  contact units (sole location from skin markers ~1-2 cm, COP noise ~1 cm). A stance whose COP
  is mostly outside is excluded; if no stance of the trial passes, markers and forces do not
  belong together: error.
* **Partly off the plate**: every unit touching the ground (within :data:`CONTACT_BAND` of the
  lowest) must lie on the plate's surface (corners known, :data:`PLATE_MARGIN`) while the plate
  is loaded; a stance with a touching unit off the plate in more than 20 % of its loaded frames
  is excluded (part of its force is not measured).
* **Unloaded plates**: outside every stance a plate should read ~0; a median unloaded |Fz| above
  :data:`DRIFT_N` means an unzeroed or drifting plate: warning (its stances are kept; the fit's
  flags will show the consequence).
* **Duplicates**: the same trial given twice (same file content or identical markers): error.
* **One subject** (:func:`one_subject`): the trials of a fit are one person's. Masses recorded
  in the files (or given) that differ by more than :data:`SUBJECT_MASS_SPREAD`, or heights by
  more than :data:`SUBJECT_HEIGHT_SPREAD`, are trials of different people: error. A mass
  ESTIMATED per trial from its plates is replaced by one value for the subject (the recorded
  mass when another trial has one, else the mean of the trials' estimates), so that every
  trial's forces are in the same % body weight; an estimate more than :data:`MASS_TOLERANCE`
  off a recorded mass, or estimates more than :data:`SUBJECT_ESTIMATE_LIMIT` apart, are two
  people or a broken plate: error. Heights estimated per trial become one the same way.
"""

from __future__ import annotations

import dataclasses
import hashlib

import numpy as np
from scipy.spatial import ConvexHull

from gc_ocp.errors import InputError, MarkerError, MassError, PlateError
from gc_ocp.io.checks import stride_body_weight
from gc_ocp.io.estimates import estimate_belt_speed
from gc_ocp.trial import ESTIMATED, ExcludedStance, Trial, belt_velocity
from gc_ocp.wrench import cop_from_wrench

MASS_TOLERANCE = 0.20
MASS_WARNING = 0.10
BMI_RANGE = (10.0, 70.0)
"""[kg/m^2] A body-mass index outside this is no person's (adults 15-60, children down to about
12): a mass *estimated* from the plates (no mass recorded) that gives one, with the trial's
height, says the plates' forces are not in newtons (a force unit not read, a wrong
ANALOG:SCALE): 18.7 kg for a 1.80 m subject whose plates were in lbf."""
TREADMILL_SPEED = 0.3  # [m/s]
OVERGROUND_SPEED = 0.15  # [m/s]
COP_MARGIN = 0.04  # [m]
PLATE_MARGIN = 0.02  # [m]
CONTACT_BAND = 0.01  # [m] units within this of the lowest one count as touching
DRIFT_N = 20.0  # [N]
LOADED_FRACTION_BW = 0.2
SUBJECT_MASS_SPREAD = 0.05
"""Largest relative difference of the masses recorded for one subject's trials: a person's mass
varies by 1-2 % from day to day, and one session's files carry one value; 74 against 63.6 kg
(16 %) are two people."""
SUBJECT_ESTIMATE_SPREAD = 0.10
"""Largest relative difference of one subject's masses ESTIMATED per trial before the fit says
so: the estimates from walking strides agree within 5 % on the five BTS trials (81.9-86.0 kg);
beyond 10 % the trials' plates disagree, or the trials are of two people (a note asking for
--mass, not an error: a trial starting from standing can estimate 15 % low, docs/data_formats.md)."""
SUBJECT_ESTIMATE_LIMIT = 0.35
"""Largest relative difference of one subject's masses ESTIMATED per trial: beyond it, an
error. A stride's estimate is within a few per cent, one from a trial starting from standing
up to 15 % low; two estimates within 15 % of one mass are at most 1.15 / 0.85 - 1 = 35 %
apart, so more is two people or a broken plate (44.7 against 83.5 kg: 87 %)."""
SUBJECT_HEIGHT_SPREAD = 0.03
"""[m] Largest difference of the heights recorded for one subject's trials (a stadiometer
reads to a centimetre; 1.76 against 1.58 m are two people)."""


def _hull_distance(points_xy: np.ndarray, p: np.ndarray) -> float:
    """Signed distance [m] of ``p`` outside the convex hull of ``points_xy`` (negative inside;
    outside: the largest edge-normal distance, a lower bound of the Euclidean one)."""
    try:
        hull = ConvexHull(points_xy)
    except Exception:  # degenerate (collinear) units: distance to the nearest unit
        return float(np.min(np.linalg.norm(points_xy - p, axis=1)))
    eq = hull.equations  # rows (nx, ny, offset): n . x + offset <= 0 inside
    return float(np.max(eq[:, :2] @ p + eq[:, 2]))


def _inside_polygon(corners_xy: np.ndarray, p: np.ndarray, margin: float) -> bool:
    return _hull_distance(corners_xy, p) <= margin


def _motion_hash(trial: Trial) -> str:
    return hashlib.sha256(np.ascontiguousarray(np.nan_to_num(trial.markers)).tobytes()).hexdigest()


def same_motion(trials: list[Trial], others: list[Trial]) -> list[tuple[str, str]]:
    """``(source in trials, source in others)`` of every pair that holds the same motion
    (identical markers): the same trial, whatever its file is called or where it lies."""
    mine = {_motion_hash(t): str(t.source) for t in trials}
    return [(mine[h], str(o.source)) for o in others if (h := _motion_hash(o)) in mine]


def duplicates(trials: list[Trial]) -> None:
    seen: dict[str, str] = {}
    for t in trials:
        h = _motion_hash(t)
        if h in seen:
            raise InputError(
                f"{t.source} and {seen[h]} hold the same motion (identical markers): the same trial "
                "given twice would count its stances twice; give each trial once."
            )
        seen[h] = str(t.source)


def body_weight(trial: Trial) -> list[str]:
    """The mass against the plates over a stride-long window (module doc); none for a mass
    estimated from these plates (the check would compare the plates with themselves)."""
    if trial.mass_estimated:
        _check_estimated_mass(trial)
        return []
    check = stride_body_weight(trial)
    if check is None:
        return []
    plates, t0, t1 = check
    rel = trial.body_weight / plates - 1.0
    msg = (
        f"{trial.source}: mass {trial.mass:.1f} kg ({trial.mass_source or 'given'}) gives a body weight of "
        f"{trial.body_weight:.0f} N but the plates carry {plates:.0f} N on average over the stride-long window "
        f"{t0:.2f}-{t1:.2f} s ({rel:+.0%})"
    )
    if abs(rel) > MASS_TOLERANCE:
        raise MassError(
            msg
            + f"; check the mass (--mass KG, mass=...; the plates suggest {plates / 9.81:.1f} kg) or the plate calibration."
        )
    return [msg + "; check the mass"] if abs(rel) > MASS_WARNING else []


def _check_estimated_mass(trial: Trial) -> None:
    """A mass estimated from the plates against the trial's height (:data:`BMI_RANGE`)."""
    if not trial.height:
        return
    bmi = trial.mass / trial.height**2
    lo, hi = BMI_RANGE
    if not lo <= bmi <= hi:
        raise MassError(
            f"{trial.source}: the mass estimated from the force data, {trial.mass:.1f} kg, is "
            f"not a person's at the height of {trial.height:.2f} m ({trial.height_source or 'given'}; "
            f"a body-mass index of {bmi:.1f}, people have {lo:g}-{hi:g}): the plates' forces are "
            "probably not in newtons (check the force channels' ANALOG:UNITS and ANALOG:SCALE, or "
            "the MOT's force columns); if they are, pass the mass with --mass KG (mass=...)."
        )


def belt(trial: Trial) -> tuple[Trial, list[str]]:
    """``(trial, notes)`` with the belt speed the fit will use: the stance feet's estimate on a
    treadmill given none (with a note); refused when given for overground walking, or further
    from the feet's speed than the fit's belt correction reaches (its bound,
    :class:`~gc_ocp.estimation.components.belt.BeltSpeed`): friction would slide the feet
    against a belt they do not follow (a speed in km/h given as m/s)."""
    from gc_ocp.estimation.components.belt import BeltSpeed

    try:
        speed, _ = estimate_belt_speed(trial)
    except MarkerError:
        return trial, []
    given = trial.belt_speed
    if given == 0.0 and speed >= TREADMILL_SPEED:
        msg = (
            f"{trial.source}: the stance feet move backward at {speed:.3f} m/s (a treadmill) but no belt speed "
            f"was given: using {speed:.3f} m/s (refined by the fit; pass --belt-speed to set it)"
        )
        return dataclasses.replace(trial, belt_velocity=belt_velocity(speed)), [msg]
    if given != 0.0 and abs(speed) < OVERGROUND_SPEED:
        raise InputError(
            f"{trial.source}: a belt speed of {given:.3f} m/s was given but the stance feet stand still "
            f"({speed:+.3f} m/s along -X): this is overground walking; drop --belt-speed."
        )
    reach = BeltSpeed.bound  # [m/s] the largest correction the fit makes to a given speed
    if given != 0.0 and abs(given - speed) > reach:
        raise InputError(
            f"{trial.source}: a belt speed of {given:.3f} m/s was given but the stance feet move "
            f"backward at {speed:.3f} m/s, and the fit corrects a given speed by at most "
            f"{reach:g} m/s. Give the belt speed in m/s ({given:g} km/h = {given / 3.6:.3f} m/s), "
            "or drop --belt-speed to use the feet's speed."
        )
    return trial, []


def plate_drift(trial: Trial) -> list[str]:
    out = []
    for i, p in enumerate(trial.plates):
        free = np.ones(p.time.size, bool)
        for s in list(trial.stances) + list(trial.excluded_stances):
            if s.plate == i:
                free &= ~((p.time >= s.t_on - 0.05) & (p.time <= s.t_off + 0.05))
        free &= np.isfinite(p.force[:, 2])  # a missing sample is no reading (its NaN hid it)
        if free.sum() < 10:
            continue
        level = float(np.median(np.abs(p.force[free, 2])))
        if level > DRIFT_N:
            out.append(
                f"{trial.source}: plate {p.name} reads {level:.0f} N (median) while unloaded: unzeroed or "
                "drifting; its stances are kept but their forces are offset (re-zero the plate)"
            )
    return out


def force_motion(trial: Trial, kin) -> tuple[Trial, list[str]]:
    """Exclude stances whose COP is not under the foot, or whose loaded unit is off the plate."""
    keep, excluded, notes = [], list(trial.excluded_stances), []
    for s in trial.stances:
        foot = kin.feet.get(s.side)
        reason = None if foot is None else _stance_problem(trial, foot, s)
        if reason is None:
            keep.append(s)
        else:
            excluded.append(ExcludedStance(s.side, s.plate, s.t_on, s.t_off, reason))
            notes.append(f"{trial.source}: stance {s.label} excluded: {reason}")
    if trial.stances and not keep:
        raise PlateError(
            f"{trial.source}: no stance's centre of pressure lies under the foot that should load it "
            f"({'; '.join(n.split(': ', 2)[-1] for n in notes[:2])}): the force data do not belong to this "
            "motion (another trial's plates, shifted timing, or a plate origin in other units); check the files."
        )
    return dataclasses.replace(trial, stances=tuple(keep), excluded_stances=tuple(excluded)), notes


def _stance_problem(trial: Trial, foot, s) -> str | None:
    t = foot.time
    mid = (t >= s.t_on + 0.25 * s.duration) & (t <= s.t_off - 0.25 * s.duration)
    if mid.sum() < 3:
        return None
    w = trial.stance_wrench(s, t[mid])
    plate = trial.plates[s.plate]
    loaded = w[:, 2] > LOADED_FRACTION_BW * trial.body_weight
    if loaded.mean() < 0.5:
        return f"plate {plate.name} carries less than {LOADED_FRACTION_BW:.0%} BW in most of mid-stance"

    cop = cop_from_wrench(w[:, :3], w[:, 3:], s.reference_point, plate.surface_height, 1.0)
    pos = foot.positions[mid]
    dist = np.array(
        [
            _hull_distance(pos[i, :, :2], cop[i, :2])
            for i in np.flatnonzero(loaded)
            if np.isfinite(cop[i, 0])
        ]
    )
    if dist.size and np.mean(dist > COP_MARGIN) > 0.5:
        return (
            f"its centre of pressure is {np.median(dist) * 1e3:.0f} mm (median) outside the "
            f"{s.side} foot's contact units (more than the {COP_MARGIN * 1e3:.0f} mm a sole's edge "
            "and the markers' placement allow) while the plate is loaded: the force is not under "
            "this foot as its markers place it (force data of another moment, a plate origin "
            "off, or a load on the sole's edge, as in a pivot, that the five units cannot carry)"
        )
    if plate.corners is not None:
        # every unit touching the ground (within CONTACT_BAND of the lowest one) must stand on the
        # plate over the whole loaded stance, else part of the force is not measured
        whole = (t >= s.t_on) & (t <= s.t_off)
        ww = trial.stance_wrench(s, t[whole])
        on = ww[:, 2] > LOADED_FRACTION_BW * trial.body_weight
        pw = foot.positions[whole][on]
        corners = np.asarray(plate.corners)[:, :2]
        off = []
        for frame in pw:
            touching = frame[:, 2] - frame[:, 2].min() < CONTACT_BAND
            off.append(
                any(not _inside_polygon(corners, q[:2], PLATE_MARGIN) for q in frame[touching])
            )
        if off and np.mean(off) > 0.2:
            return (
                f"the {s.side} foot stands partly off plate {plate.name} in {np.mean(off):.0%} of the loaded "
                "frames (part of its force is not measured)"
            )
    return None


def one_subject(trials: list[Trial]) -> tuple[list[Trial], list[str]]:
    """The trials as one subject's (module doc): different recorded masses or heights raise;
    estimated masses become one. Returns ``(trials, notes)``."""
    if len(trials) < 2:
        return list(trials), []
    for what, values, spread in (
        ("mass", [(t, t.mass, t.mass_source) for t in trials if not t.mass_estimated], None),
        (
            "height",
            [
                (t, t.height, t.height_source)
                for t in trials
                if t.height is not None and not t.height_estimated
            ],
            SUBJECT_HEIGHT_SPREAD,
        ),
    ):
        if len(values) < 2:
            continue
        lo, hi = min(v for _, v, _ in values), max(v for _, v, _ in values)
        if (hi - lo > spread) if spread is not None else (hi / lo - 1 > SUBJECT_MASS_SPREAD):
            unit = "kg" if what == "mass" else "m"
            listed = "; ".join(f"{t.source}: {v:.3g} {unit} ({src})" for t, v, src in values)
            raise InputError(
                f"The trials are not of one subject: their recorded {what}{'es' if what == 'mass' else 's'} differ ({listed}). Fit "
                f"each subject's trials on their own (gc-ocp batch fits many subjects), or, if "
                f"one file's value is wrong, pass --{what} to set it for all."
            )
    trials, notes = _one_mass(trials)
    trials, more = _one_height(trials)
    return trials, notes + more


_UNITS = {"mass": ("kg", ".1f"), "height": ("m", ".3f")}


def _subject_value(trials: list[Trial], what: str):
    """``(value, source, estimated, recorded)`` for pooling ``what`` (``"mass"``,
    ``"height"``) over one subject's trials: the trials whose value the package estimated, those
    whose value a file or the user gave, and the one value for the estimated ones (a recorded
    one, else the mean of the estimates) with its source; None when no value is estimated or the
    estimates are pooled already."""
    unit, fmt = _UNITS[what]
    known = [t for t in trials if getattr(t, what) is not None]
    estimated = [t for t in known if getattr(t, f"{what}_estimated")]
    recorded = [t for t in known if not getattr(t, f"{what}_estimated")]
    sources = {(getattr(t, what), getattr(t, f"{what}_source")) for t in estimated}
    if not estimated or (not recorded and len(sources) == 1):
        return None  # nothing to pool, or pooled already (its source keeps each estimate)
    if recorded:
        first = recorded[0]
        value = float(getattr(first, what))
        source = f"{getattr(first, f'{what}_source')}, in {first.source} (the subject's trial)"
    else:
        value = float(np.mean([getattr(t, what) for t in estimated]))
        each = ", ".join(f"{getattr(t, what):{fmt}}" for t in estimated)
        source = (
            f"{ESTIMATED} {value:{fmt}} {unit}: the mean of the subject's trials' estimates "
            f"({each} {unit})"
        )
    return value, source, estimated, recorded


def _pooled(trials: list[Trial], what: str, value: float, source: str) -> tuple[list, list]:
    """``trials`` with every estimated ``what`` replaced by ``value``, and the note."""
    unit, fmt = _UNITS[what]
    out = [
        dataclasses.replace(t, **{what: value, f"{what}_source": source})
        if getattr(t, what) is not None and getattr(t, f"{what}_estimated")
        else t
        for t in trials
    ]
    return out, [
        f"one {what} for the subject's {len(trials)} trials: {value:{fmt}} {unit} ({source})"
    ]


def _one_mass(trials: list[Trial]) -> tuple[list[Trial], list[str]]:
    pooled = _subject_value(trials, "mass")
    if pooled is None:
        return list(trials), []
    mass, source, estimated, recorded = pooled
    extra: list[str] = []
    for t in estimated if recorded else []:
        rel = t.mass / mass - 1.0
        if abs(rel) > MASS_TOLERANCE:
            raise InputError(
                f"The trials are not of one subject, or a plate is wrong: "
                f"{recorded[0].source} records {mass:.1f} kg ({recorded[0].mass_source}) but "
                f"the plates of {t.source} give {t.mass:.1f} kg ({rel:+.0%}; the body-weight "
                f"check's limit is {MASS_TOLERANCE:.0%}). Fit each subject's trials on their "
                "own, or pass --mass KG (mass=...) if the recorded value is wrong."
            )
    if not recorded:
        spread = max(t.mass for t in trials) / min(t.mass for t in trials) - 1
        if spread > SUBJECT_ESTIMATE_LIMIT:
            raise InputError(
                f"The trials are not of one subject, or a plate is wrong: their plates give "
                f"masses {100 * spread:.0f} % apart ({'; '.join(f'{t.source}: {t.mass:.1f} kg' for t in trials)}). "
                "Fit each subject's trials on their own, or pass --mass KG (mass=...)."
            )
        if spread > SUBJECT_ESTIMATE_SPREAD:
            each = ", ".join(f"{t.mass:.1f}" for t in trials)
            extra = [
                f"the trials' mass estimates differ by {100 * spread:.0f} % ({each} kg): if these are "
                "one person's trials their plates disagree, else they are two people's; pass "
                "--mass KG (mass=...)"
            ]
    out, notes = _pooled(trials, "mass", mass, source)
    return out, notes + extra


def _one_height(trials: list[Trial]) -> tuple[list[Trial], list[str]]:
    """Heights ESTIMATED per trial (from its markers) become one, as masses do: every stance
    of the subject is then in the same % BW x height (the recorded height where a trial has
    one, else the mean of the estimates; the kinematics keep the body each was scaled to)."""
    pooled = _subject_value(trials, "height")
    if pooled is None:
        return list(trials), []
    height, source, _, _ = pooled
    return _pooled(trials, "height", height, source)


def own_kinematics(trial: Trial, kin) -> None:
    """Refuse kinematics computed from another trial than ``trial`` (another name or another
    time axis): fitted, the plates of one walk would be explained by the feet of another, and
    the fit's flags would blame the contact model (a notebook's ``[(t1, k2)]``)."""
    t = np.asarray(trial.marker_time)
    same = (
        kin.trial_name == trial.name
        and len(kin.time) == len(t)
        and np.allclose(np.asarray(kin.time), t, atol=1e-9)
    )
    if not same:
        raise InputError(
            f"The kinematics given with {trial.source} are of {kin.trial_name!r} "
            f"({len(kin.time)} frames, {kin.time[0]:.3f}-{kin.time[-1]:.3f} s), not of that trial "
            f"({trial.name!r}, {len(t)} frames, {t[0]:.3f}-{t[-1]:.3f} s): pair each trial with "
            "its own, [(t, gc_ocp.compute_kinematics(t)) for t in trials]."
        )


def check_for_fit(pairs: list) -> tuple[list, list[str]]:
    """Check ``[(trial, kinematics)]`` before fitting: errors raise, the rest returns as
    ``(checked pairs, notes)`` (stances excluded, belt speed set, one mass for the subject)."""
    for t, kin in pairs:
        own_kinematics(t, kin)
    duplicates([t for t, _ in pairs])
    trials, notes = one_subject([t for t, _ in pairs])
    pairs = [(t, kin) for t, (_, kin) in zip(trials, pairs, strict=True)]
    out = []
    for t, kin in pairs:
        notes += body_weight(t)
        t, n = belt(t)
        notes += n
        notes += plate_drift(t)
        t, n = force_motion(t, kin)
        notes += n
        out.append((t, kin))
    return out, notes


__all__ = ["check_for_fit", "one_subject", "same_motion"]
