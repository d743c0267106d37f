"""Loading a walking trial (C3D, or TRC + MOT/STO) or a static trial into a
:class:`~gc_ocp.trial.Trial` in the ``lab`` frame (see :mod:`gc_ocp.io`)."""

from __future__ import annotations

import dataclasses
import os
import warnings
from importlib import resources
from pathlib import Path

import numpy as np

from gc_ocp.errors import InputError, MarkerError, require_file
from gc_ocp.gaps import MAX_MARKER_SPEED, fill_short_gaps, marker_spikes
from gc_ocp.io._common import Y_UP_TO_LAB, warn, without_subject_prefix
from gc_ocp.io.c3d import read_c3d
from gc_ocp.io.checks import (
    STATIC_MAX_STD,
    force_unit_hint,
    marker_spread,
    stance_gap_report,
    static_hint,
)
from gc_ocp.io.opensim import read_opensim, read_trc
from gc_ocp.io.orientation import SWAPPED_LEGS, leg_swaps, said_pairs, walking_rotation
from gc_ocp.io.pairing import TRIAL_FIX, find_grf
from gc_ocp.io.stances import DEFAULT_THRESHOLD, check_peaks, detect_stances
from gc_ocp.io.subject import estimate_body_weight, read_subject_metadata
from gc_ocp.trial import ESTIMATED, GRAVITY, ExcludedStance, Plate, Trial, belt_velocity
from gc_ocp.values import number, require


def bundled_example_path() -> Path:
    """Path of the bundled example C3D (Plug-in Gait, Vicon; MIT licence, see
    ``gc_ocp/data/LICENSE_test_small.txt``)."""
    return Path(str(resources.files("gc_ocp") / "data" / "test_small.c3d"))


def _filled_markers(markers: np.ndarray, time: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~gc_ocp.gaps.fill_short_gaps` of ``(n, m, 3)`` markers, and ``(n, m)`` the samples
    it interpolated (:attr:`~gc_ocp.trial.Trial.marker_filled`: not seen by the cameras, so no
    noise is measured there)."""
    seen = np.isfinite(markers).all(axis=2)
    out, _ = fill_short_gaps(markers, time)
    return out, ~seen & np.isfinite(out).all(axis=2)


def load_trial(
    path: str | Path | None = None,
    grf: str | Path | None = None,
    *,
    mass: float | None = None,
    height: float | None = None,
    belt_speed: float | None = None,
    stance_threshold: float | None = None,
) -> Trial:
    """Load a walking trial into a :class:`~gc_ocp.trial.Trial`.

    path: ``.c3d`` file, or ``.trc`` marker file; ``None`` = bundled example. grf: OpenSim
        ``.mot``/``.sto`` ground reactions for a TRC (``None``: the file beside it, found as the
        command line finds it, :func:`gc_ocp.io.pairing.find_grf`, with a warning naming it).
    mass: subject mass in [kg]; overrides the file. Otherwise: the file (C3D PROCESSING:Bodymass
        ...), subject metadata beside the trial (:func:`gc_ocp.io.subject.read_subject_metadata`),
        else an ESTIMATE from the force data with a warning (``Trial.mass_source`` says which).
    height: subject height in [m]; overrides the file. ``None`` and not in the file -> ``None``
        (the kinematics then estimate it: see
        :func:`~gc_ocp.io.estimates.estimate_height_from_markers`).
    belt_speed: treadmill belt speed in [m/s] (>= 0); sets ``belt_velocity = (-belt_speed, 0, 0)``
        in lab (the belt runs backwards under a subject walking +X). Never guessed: see
        :func:`~gc_ocp.io.estimates.estimate_belt_speed`.
    stance_threshold: vertical-force contact threshold in [N] (default 20 N).

    Returns the trial in the ``lab`` frame (Z up, walking +X), SI units, its usable stances
    detected (``trial.stances``; ``print(trial)`` lists them). One file per call: the trials of
    a subject are loaded one by one (:func:`gc_ocp.describe_trial` says what was read).

    >>> import gc_ocp
    >>> trial = gc_ocp.load_trial()           # the bundled example (gc_ocp/data/test_small.c3d)
    >>> trial                                 # doctest: +ELLIPSIS
    Trial('...test_small.c3d', 33 markers at 100 Hz, 4 plates, 3 stances (right@0.407s, left@0.941s, right@1.494s), mass 63.6 kg, height 1.58 m)
    >>> # skipped: files of your own (a TRC, its ground reactions, the mass the files lack)
    >>> trial = gc_ocp.load_trial("walk.trc", grf="walk_grf.mot", mass=72.6)  # doctest: +SKIP
    """
    if path is not None and not isinstance(path, str | os.PathLike):
        raise InputError(
            f"load_trial takes one trial's file, but got {type(path).__name__}: load each "
            "trial of a subject on its own, [gc_ocp.load_trial(p) for p in paths]."
        )
    path = bundled_example_path() if path is None else Path(path)
    require_file(path, "Trial file", TRIAL_FIX)
    suffix = path.suffix.lower()
    try:
        threshold = DEFAULT_THRESHOLD if stance_threshold is None else float(stance_threshold)
    except (TypeError, ValueError):
        threshold = float("nan")
    if not np.isfinite(threshold) or threshold <= 0:
        raise InputError(
            f"stance_threshold={stance_threshold!r}: give the vertical force [N] above which a "
            f"plate counts as loaded, a positive number (default {DEFAULT_THRESHOLD:g} N: above "
            "a zeroed plate's noise, far below body weight)."
        )
    if suffix == ".c3d":
        if grf is not None:
            warn(f"{path} is a C3D file: its own plates are used and --grf {grf} is ignored.")
        raw = read_c3d(path)
    elif suffix == ".trc":
        if grf is None:  # beside it, as the command line finds it (gc_ocp.io.pairing)
            grf, why = find_grf(path)
            warn(f"{path}: ground reactions from {grf} ({why}); pass grf=FILE to choose another.")
        grf = Path(grf)
        require_file(grf, "Ground-reaction file", "give the trial's .mot or .sto file (--grf).")
        if grf.suffix.lower() not in (".mot", ".sto"):
            raise InputError(f"{grf}: expected an OpenSim .mot or .sto file for --grf.")
        raw = read_opensim(path, grf, threshold)
    else:
        raise InputError(
            f'{path}: unsupported file type "{suffix}"; give a .c3d file, or a .trc with '
            f"--grf FILE.mot."
        )
    if mass is not None:
        raw.mass, raw.mass_source = number(mass, "mass", "kg"), "given (mass=)"
    meta = read_subject_metadata([p for p in (path, raw.grf_source) if p is not None])
    if raw.mass is None and "mass" in meta:
        raw.mass, raw.mass_source = meta["mass"]
    if raw.height is None and height is None and "height" in meta:
        raw.height, raw.height_source = meta["height"]
    if raw.mass is not None:
        _check_mass(raw.mass, raw.mass_source)
    if height is not None:
        raw.height, raw.height_source = number(height, "height", "m"), "given (height=)"
    if raw.height is not None and not (0.5 < raw.height < 2.6):
        raise InputError(
            f"Subject height {raw.height} m ({raw.height_source}) is not plausible; "
            f"pass it in metres (height=... / --height M)."
        )

    loaded = np.zeros(len(raw.marker_time), bool)
    for p in raw.plates:
        loaded |= np.interp(raw.marker_time, p.time, p.force[:, 2], left=0, right=0) > threshold
    rot, rot_note = walking_rotation(raw.marker_names, raw.markers, raw.marker_time, loaded)
    raw.notes.append(rot_note)
    markers = raw.markers @ rot.T
    plates = [_rotate_plate(p, rot) for p in raw.plates]
    legs, swapped = leg_swaps(raw.marker_names, markers, raw.marker_time)
    if legs:
        said = SWAPPED_LEGS.format(said=said_pairs(legs))
        raise MarkerError(f"In {path} {said}. Fix the labels, or export the file again.")
    if swapped:
        raw.notes.append(
            f"left and right labels of {said_pairs(swapped)} are exchanged in the file (the "
            f"left one lies to the subject's right); they do not pose the feet and are used as "
            f"labelled"
        )
        warn(f"{path}: {raw.notes[-1]}.")
    markers, spikes = marker_spikes(markers, raw.marker_time)
    for j, t0, t1 in spikes:
        raw.notes.append(
            f"marker {raw.marker_names[j]}: {t0:.3f}-{t1:.3f} s leave its path faster than "
            f"{MAX_MARKER_SPEED:.0f} m/s and come back (a ghost or mislabelled point): removed "
            f"as a gap"
        )
    markers, filled = _filled_markers(markers, raw.marker_time)

    if raw.mass is None:
        raw.mass, raw.mass_source = _estimate_mass(raw, plates, markers, threshold, path)
        _check_mass(raw.mass, raw.mass_source)
    stances, excluded, side_notes = detect_stances(
        plates,
        raw.marker_names,
        markers,
        raw.marker_time,
        raw.mass * GRAVITY,
        threshold,
        source=str(path),
    )
    raw.notes.extend(side_notes)
    check_peaks(plates, stances, str(path))
    if belt_speed is not None:
        belt_speed = number(belt_speed, "belt_speed", "m/s")
    if belt_speed is not None and belt_speed < 0:
        raise InputError(
            f"belt_speed={belt_speed}: give the belt speed as a positive number in m/s."
        )
    belt = belt_velocity(belt_speed or 0.0)
    trial = Trial(
        source=path,
        marker_names=tuple(raw.marker_names),
        markers=markers,
        marker_time=raw.marker_time,
        plates=tuple(plates),
        mass=raw.mass,
        height=raw.height,
        stances=tuple(stances),
        excluded_stances=tuple(excluded),
        belt_velocity=belt,
        lab_rotation=rot @ raw.file_rotation,
        grf_source=raw.grf_source,
        mass_source=raw.mass_source,
        height_source=raw.height_source,
        load_notes=tuple(raw.notes),
        contact_threshold=threshold,
        marker_filled=filled,
    )
    return apply_stance_gaps(trial)


def _check_mass(mass: float, source: str) -> None:
    if not (10.0 < mass < 400.0):
        raise InputError(
            f"Subject mass {mass} kg ({source}) is not plausible; "
            f"pass the mass in kilograms with mass=... / --mass KG."
        )


def _estimate_mass(raw, plates, markers, threshold: float, path: Path) -> tuple[float, str]:
    """ESTIMATE of the mass from the force data when no mass is given or stored
    (:func:`gc_ocp.io.subject.estimate_body_weight`), with a warning; error without a basis."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the stances are detected again below
        stances, _, _ = detect_stances(
            plates, raw.marker_names, markers, raw.marker_time, None, threshold, str(path)
        )
    check_peaks(plates, stances, str(path))  # a plate's wrong gain would make the estimate
    est = estimate_body_weight(plates, stances)
    files = f"{path}{' or ' + str(raw.grf_source) if raw.grf_source else ''}"
    if est is None:
        raise InputError(
            f"No subject mass in {files} or beside it (subject JSON, OpenSim scale set-up), and "
            f"the force data hold neither quiet standing nor two consecutive walking stances to "
            f"estimate it from{force_unit_hint(plates, threshold)}; pass mass=... / --mass KG."
            + static_hint(raw.marker_names, markers)
        )
    bw, basis = est
    mass = bw / GRAVITY
    warn(
        f"No subject mass in {files}: ESTIMATED {mass:.1f} kg from the force data ({basis}). "
        f"Pass --mass KG (mass=...) to set it."
    )
    return mass, f"{ESTIMATED} {mass:.1f} kg from the force data ({basis})"


def apply_stance_gaps(trial: Trial) -> Trial:
    """Move the stances with an unbridged foot-marker gap to ``excluded_stances`` (warning) and
    note the bridged ones (see :func:`gc_ocp.io.checks.stance_gap_report`)."""
    excluded, bridged = stance_gap_report(trial)
    if not excluded and not bridged:
        return trial
    keep, out = [], list(trial.excluded_stances)
    for s in trial.stances:
        if s.label in excluded:
            warn(f"{trial.source}: stance {s.label} excluded: {excluded[s.label]}")
            out.append(ExcludedStance(s.side, s.plate, s.t_on, s.t_off, excluded[s.label]))
        else:
            keep.append(s)
    out.sort(key=lambda e: e.t_on)
    notes = [f"stance {k}: {v}" for k, v in bridged.items()]
    return dataclasses.replace(
        trial,
        stances=tuple(keep),
        excluded_stances=tuple(out),
        load_notes=tuple(trial.load_notes) + tuple(notes),
    )


def check_static(path: Path, names, markers: np.ndarray) -> None:
    """Raise :class:`InputError` unless the markers ``(n, m, 3)`` [m] stand still
    (:data:`STATIC_MAX_STD`): a walking trial given as the static trial."""
    if markers.shape[0] < 2:
        return
    moved = marker_spread(names, markers)
    if max(moved.values()) > STATIC_MAX_STD:
        what = ", ".join(f"{k} {v * 1e3:.0f} mm" for k, v in moved.items() if v)
        raise InputError(
            f"Static trial {path} is not static: its markers move over the trial (standard "
            f"deviation, median: {what}; a standing subject moves less than "
            f"{STATIC_MAX_STD * 1e3:.0f} mm): it is a walking trial. Give a standing (static) "
            f"trial with --static, or none."
        )


def _rotate_plate(p: Plate, rot: np.ndarray) -> Plate:
    if np.array_equal(rot, np.eye(3)):
        return p
    off = p.zero_offset
    return dataclasses.replace(
        p,
        force=p.force @ rot.T,
        moment=p.moment @ rot.T,
        reference_point=rot @ p.reference_point,
        corners=None if p.corners is None else p.corners @ rot.T,
        zero_offset=None if off is None else np.concatenate([rot @ off[:3], rot @ off[3:]]),
    )


def load_static(path: str | Path, walking: Trial) -> Trial:
    """Load a static standing trial (markers only) into the ``lab`` frame of ``walking``.

    A static trial has no walking direction, so the walking trial's rotation is reused: the
    static file must come from the same lab set-up (same axes). Plates are not read: the floor
    height is the walking trial's plate surface. ``path``: the static trial's ``.c3d`` or
    ``.trc``; ``walking``: a walking trial of the same session, loaded. Returns a
    :class:`~gc_ocp.trial.Trial` with no plates or stances, for
    :func:`~gc_ocp.kinematics.compute_kinematics`'s ``static``.

    >>> import gc_ocp
    >>> # skipped: files of your own (no static trial is bundled)
    >>> trial = gc_ocp.load_trial("walk.c3d")                  # doctest: +SKIP
    >>> static = gc_ocp.load_static("static.c3d", trial)       # doctest: +SKIP
    >>> kin = gc_ocp.compute_kinematics(trial, static=static)  # doctest: +SKIP
    """
    how = "trial = gc_ocp.load_trial(walking_path); static = gc_ocp.load_static(path, trial)"
    require(path, str | os.PathLike, "load_static takes the static trial's file first", how)
    require(walking, Trial, "load_static takes the loaded walking trial second", how)
    path = Path(path)
    require_file(path, "Static trial", "give the static trial's .c3d or .trc file (--static).")
    suffix = path.suffix.lower()
    if suffix == ".trc":
        names, markers, time = read_trc(path)  # already Z-up
        names, _ = without_subject_prefix(names, path)
        file_rot = Y_UP_TO_LAB
    elif suffix == ".c3d":
        raw = read_c3d(path, strict=False)  # its plates only help find the vertical axis
        names, time, markers, file_rot = (
            raw.marker_names,
            raw.marker_time,
            raw.markers,
            raw.file_rotation,
        )
    else:
        raise InputError(
            f'{path}: unsupported static-trial type "{suffix}"; give a .trc or .c3d file.'
        )
    check_static(path, names, markers)
    rot = walking.lab_rotation @ np.linalg.inv(file_rot)
    markers, filled = _filled_markers(markers @ rot.T, time)
    return dataclasses.replace(
        walking,
        source=path,
        marker_names=tuple(names),
        markers=markers,
        marker_time=time,
        marker_filled=filled,
        plates=(),
        stances=(),
        excluded_stances=(),
        grf_source=None,
        load_notes=(f"static trial in the lab frame of {walking.source.name}",),
    )
