"""Loading walking trials: C3D (markers + plates) or OpenSim TRC + MOT/STO.

>>> from gc_ocp.io import load_trial
>>> trial = load_trial()            # the bundled Plug-in Gait example (MIT, see gc_ocp/data)
>>> [s.side for s in trial.stances]
['right', 'left', 'right']

Everything returned is in SI units and in the ``lab`` frame (Z up, X walking direction, Y left);
see :mod:`gc_ocp.trial`. Frames: OpenSim files are Y up and are mapped (x, y, z) -> (x, -z, y);
then the trial is turned about Z by a multiple of 90 degrees so that the subject walks along +X
(:func:`walking_rotation`). The total file -> lab rotation is ``Trial.lab_rotation``.
"""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path

import numpy as np

from gc_ocp.errors import InputError, MarkerError
from gc_ocp.gaps import MAX_GAP_FILL, fill_short_gaps, nan_runs
from gc_ocp.io._common import foot_markers, heel_toe, rotation_z, warn
from gc_ocp.io.stances import DEFAULT_THRESHOLD, detect_stances
from gc_ocp.trial import GRAVITY, Plate, Trial

__all__ = [
    "load_trial",
    "bundled_example_path",
    "describe_trial",
    "require_markers",
    "estimate_height_from_markers",
    "estimate_belt_speed",
    "stride_body_weight",
    "walking_rotation",
    "DEFAULT_THRESHOLD",
    "MAX_GAP_FILL",
]

MIN_OVERGROUND_SPEED = 0.3
"""Centroid speed [m/s] above which a trial is taken as overground (direction from the centroid);
below it (treadmill), the walking direction is the mean heel -> toe direction of the feet."""


def bundled_example_path() -> Path:
    """Path of the bundled example C3D (Plug-in Gait, Vicon; MIT licence, see
    ``gc_ocp/data/LICENSE_test_small.txt``)."""
    return Path(str(resources.files("gc_ocp") / "data" / "test_small.c3d"))


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

    path: ``.c3d`` file, or ``.trc`` marker file (then ``grf`` is required); ``None`` = bundled
        example. grf: OpenSim ``.mot``/``.sto`` ground reactions for a TRC.
    mass: subject mass in [kg]; overrides the file. Required when the files carry none (TRC/MOT).
    height: subject height in [m]; overrides the file. ``None`` and not in the file -> ``None``
        (the kinematics then estimate it: see :func:`estimate_height_from_markers`).
    belt_speed: treadmill belt speed in [m/s] (>= 0); sets ``belt_velocity = (-belt_speed, 0, 0)``
        in lab (the belt runs backwards under a subject walking +X). Never guessed: see
        :func:`estimate_belt_speed`.
    stance_threshold: vertical-force contact threshold in [N] (default 20 N).
    """
    from gc_ocp.io.c3d import read_c3d
    from gc_ocp.io.opensim import read_opensim

    path = bundled_example_path() if path is None else Path(path)
    if not path.is_file():
        raise InputError(f"Trial file {path} does not exist; check the path (a .c3d or .trc file).")
    suffix = path.suffix.lower()
    threshold = DEFAULT_THRESHOLD if stance_threshold is None else float(stance_threshold)
    if suffix == ".c3d":
        if grf is not None:
            warn(f"{path} is a C3D file: its own plates are used and --grf {grf} is ignored.")
        raw = read_c3d(path)
    elif suffix == ".trc":
        if grf is None:
            raise InputError(
                f"{path} is a TRC marker file without ground reactions: give --grf FILE "
                f"(grf=FILE.mot/.sto with the OpenSim ground_force_* columns)."
            )
        grf = Path(grf)
        if not grf.is_file():
            raise InputError(f"Ground-reaction file {grf} does not exist; check the --grf path.")
        if grf.suffix.lower() not in (".mot", ".sto"):
            raise InputError(f"{grf}: expected an OpenSim .mot or .sto file for --grf.")
        raw = read_opensim(path, grf, threshold)
    else:
        raise InputError(
            f'{path}: unsupported file type "{suffix}"; give a .c3d file, or a .trc with '
            f"--grf FILE.mot."
        )
    if mass is not None:
        raw.mass, raw.mass_source = float(mass), "given (mass=)"
    if raw.mass is None:
        raise InputError(
            f"No subject mass in {path}{' or ' + str(raw.grf_source) if raw.grf_source else ''}; "
            f"pass mass=... / --mass KG."
        )
    if not (10.0 < raw.mass < 400.0):
        raise InputError(
            f"Subject mass {raw.mass} kg ({raw.mass_source}) is not plausible; "
            f"pass the mass in kilograms with mass=... / --mass KG."
        )
    if height is not None:
        raw.height, raw.height_source = float(height), "given (height=)"
    if raw.height is not None and not (0.5 < raw.height < 2.6):
        raise InputError(
            f"Subject height {raw.height} m ({raw.height_source}) is not plausible; "
            f"pass it in metres (height=... / --height M)."
        )

    rot, rot_note = walking_rotation(raw.marker_names, raw.markers, raw.marker_time)
    raw.notes.append(rot_note)
    markers = raw.markers @ rot.T
    plates = [_rotate_plate(p, rot) for p in raw.plates]
    markers, _gaps = fill_short_gaps(markers, raw.marker_time)

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
    if belt_speed is not None and belt_speed < 0:
        raise InputError(
            f"belt_speed={belt_speed}: give the belt speed as a positive number in m/s."
        )
    belt = np.array([-(belt_speed or 0.0), 0.0, 0.0])
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
    )
    return trial


def _rotate_plate(p: Plate, rot: np.ndarray) -> Plate:
    if np.array_equal(rot, np.eye(3)):
        return p
    return Plate(
        name=p.name,
        time=p.time,
        force=p.force @ rot.T,
        moment=p.moment @ rot.T,
        reference_point=rot @ p.reference_point,
        reference_kind=p.reference_kind,
        corners=None if p.corners is None else p.corners @ rot.T,
        surface_height=p.surface_height,
    )


def walking_rotation(names, markers: np.ndarray, time: np.ndarray) -> tuple[np.ndarray, str]:
    """Rotation about Z (multiple of 90 degrees) turning the walking direction to +X.

    Direction: the mean horizontal velocity of the marker centroid (least-squares slope) when
    faster than :data:`MIN_OVERGROUND_SPEED`; otherwise (treadmill: the body stays put) the mean
    heel -> toe vector of both feet. Returns the 3x3 rotation and a one-line description.
    """
    centroid = np.nanmean(markers, axis=1)[:, :2] if markers.size else np.zeros((0, 2))
    ok = np.all(np.isfinite(centroid), axis=1)
    direction = None
    how = ""
    if ok.sum() >= 3:
        vel = np.polyfit(time[ok], centroid[ok], 1)[0]
        if np.linalg.norm(vel) > MIN_OVERGROUND_SPEED:
            direction, how = vel, f"marker-centroid velocity {np.linalg.norm(vel):.2f} m/s"
    if direction is None:
        vecs = []
        for side in ("left", "right"):
            h, t = heel_toe(names, side)
            if h is not None and t is not None:
                vecs.append(np.nanmean(markers[:, t, :2] - markers[:, h, :2], axis=0))
        if vecs and np.linalg.norm(np.mean(vecs, axis=0)) > 0.03:
            direction, how = np.mean(vecs, axis=0), "heel->toe direction (treadmill-like trial)"
    if direction is None:
        warn(
            "Could not detect the walking direction (no motion, no heel/toe markers): "
            "the file's X axis is kept as the walking direction."
        )
        return np.eye(3), "walking direction unknown: file X kept"
    angle = math.degrees(math.atan2(direction[1], direction[0]))
    k = int(round(angle / 90.0))
    if abs(angle - 90.0 * k) > 20.0:
        warn(
            f"Walking direction is {angle:.0f} deg from the file X axis, not close to a multiple "
            f"of 90 deg; rotated by {90 * k} deg only."
        )
    rot = rotation_z(-k)
    return (
        rot,
        f"walking direction {angle:.0f} deg in file axes from {how}; rotated {-90 * k} deg about Z",
    )


def require_markers(trial: Trial, names) -> None:
    """Raise :class:`MarkerError` unless every marker in ``names`` is present without gaps.

    Gaps up to :data:`MAX_GAP_FILL` were filled on load; what is still NaN is a long gap.
    """
    for name in names:
        if name not in trial.marker_names:
            raise MarkerError(
                f'Marker "{name}" is not in {trial.source}; markers found: '
                f"{list(trial.marker_names)}. Rename it in the marker set or in your mocap file."
            )
        xyz = trial.marker(name)
        runs = nan_runs(np.all(np.isfinite(xyz), axis=1))
        if runs:
            a, b = max(runs, key=lambda r: r[1] - r[0])
            t = trial.marker_time
            dur = (b - a) / trial.marker_rate
            raise MarkerError(
                f'Marker "{name}" in {trial.source} has a gap of {dur:.3f} s '
                f"({t[a]:.3f}-{t[b - 1]:.3f} s; {len(runs)} gap(s) in all) longer than the "
                f"{MAX_GAP_FILL} s filled automatically: fill the gap in your mocap software or "
                f"remove the marker from the marker set."
            )


def estimate_height_from_markers(
    trial: Trial,
    markerset=None,
    standing: bool = False,
    floor: float | None = None,
) -> tuple[float, str]:
    """ESTIMATE of the subject height [m] from the pelvis markers (never applied automatically).

    The kinematics pipeline's estimator, :func:`gc_ocp.kinematics.scaling.estimate_height`, on
    the trial's markers of ``markerset`` (a :class:`~gc_ocp.model.markerset.MarkerSet`, a shipped
    name or a TOML path; default: detected from the labels), low-passed as in
    :func:`~gc_ocp.kinematics.compute_kinematics` for a walking trial (``standing=False``: 95th
    percentile of the pelvis height), raw for a static one (``standing=True``: median).
    floor: floor height [m], default :attr:`Trial.floor_height` (give the walking trial's for a
    static trial, which has no plates). Accuracy is a few per cent: pass the measured height when
    you have it. Returns (height, description).
    """
    from gc_ocp.kinematics.filtering import lowpass
    from gc_ocp.kinematics.scaling import estimate_height
    from gc_ocp.model.markerset import MarkerSet, detect_markerset, load_markerset

    if markerset is None:
        markerset = detect_markerset(trial.marker_names)
    elif not isinstance(markerset, MarkerSet):
        markerset = load_markerset(markerset)
    names = markerset.select(trial.marker_names, trial.source)
    markers = trial.markers[:, [trial.marker_names.index(n) for n in names]]
    if not standing:
        markers = lowpass(markers, trial.marker_rate, time=trial.marker_time)
    floor = trial.floor_height if floor is None else float(floor)
    height = estimate_height(markers, names, markerset, floor, standing)
    pelvis = [n for n in names if markerset.markers[n].segment == "pelvis"]
    how = "median standing" if standing else "95th-percentile walking"
    return height, (
        f"ESTIMATE from the {how} height of the pelvis markers {pelvis} of marker set "
        f'"{markerset.name}" above the floor z = {floor:.3f} m'
    )


def estimate_belt_speed(trial: Trial) -> tuple[float, str]:
    """ESTIMATE of the treadmill belt speed [m/s] (never applied automatically).

    Mean backward (-X) velocity of the stance foot's markers over the middle half of every
    stance (and excluded stance with full foot markers). ~0 for an overground trial.
    """
    v = []
    dt = 1.0 / trial.marker_rate
    for s in list(trial.stances) + list(trial.excluded_stances):
        idx = foot_markers(trial.marker_names, s.side)
        if not idx:
            continue
        q = s.t_on + 0.25 * (s.t_off - s.t_on), s.t_off - 0.25 * (s.t_off - s.t_on)
        sel = (trial.marker_time >= q[0]) & (trial.marker_time <= q[1])
        if sel.sum() < 3:
            continue
        vx = np.gradient(trial.markers[:, idx, 0], dt, axis=0)[sel]
        v.append(float(np.nanmean(vx)))
    if not v:
        raise MarkerError(
            f"No stance with foot markers in {trial.source} to estimate the belt speed."
        )
    speed = -float(np.mean(v))
    return speed, (
        f"ESTIMATE: stance feet move at {-speed:+.3f} m/s along X over mid-stance "
        f"({len(v)} stances) -> belt speed {speed:.3f} m/s"
    )


def _trapezoid(y: np.ndarray, x: np.ndarray) -> float:
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(x)))


def _total_vertical(trial: Trial) -> tuple[np.ndarray, np.ndarray]:
    t = trial.plates[0].time
    fz = np.zeros_like(t)
    for p in trial.plates:
        fz += np.interp(t, p.time, p.force[:, 2])
    return t, fz


def stride_body_weight(trial: Trial) -> tuple[float, float, float] | None:
    """Check of the body weight: mean total vertical force [N] over one stride period.

    The period T is the shortest interval between two contacts of the same foot. Since some
    contacts of a stride usually fall outside the plates, the value is the *maximum* over all
    T-long windows of the mean summed plate Fz: windows in which every contact is measured all
    give the same (largest) value, windows missing a contact give less. Returns
    ``(value, t_start, t_end)`` or ``None`` without two contacts of one foot. A check only: the
    mass used is always the given/file one.
    """
    ons: dict[str, list[float]] = {}
    for s in list(trial.stances) + list(trial.excluded_stances):
        if getattr(s, "reason", "").startswith("clipped: force already"):
            continue
        ons.setdefault(s.side, []).append(s.t_on)
    periods = [
        b - a for v in ons.values() for a, b in zip(sorted(v)[:-1], sorted(v)[1:], strict=True)
    ]
    if not periods:
        return None
    t, fz = _total_vertical(trial)
    dt = float(np.median(np.diff(t)))
    n = int(round(min(periods) / dt))
    if n < 2 or n >= len(t):
        return None
    c = np.concatenate([[0.0], np.cumsum(0.5 * (fz[1:] + fz[:-1]) * np.diff(t))])
    mean = (c[n:] - c[:-n]) / (t[n:] - t[:-n])
    k = int(np.argmax(mean))
    return float(mean[k]), float(t[k]), float(t[k + n])


def describe_trial(trial: Trial) -> str:
    """Readable summary: rates, markers, plates, stances (times, peak force in N and % BW),
    exclusions with reasons, body weight and its source, and the stride body-weight check."""
    bw = trial.body_weight
    lines = [f"Trial {trial.source}" + (f" + {trial.grf_source}" if trial.grf_source else "")]
    lines.append(
        f"  markers: {len(trial.marker_names)} at {trial.marker_rate:.0f} Hz, "
        f"{trial.marker_time[0]:.3f}-{trial.marker_time[-1]:.3f} s"
    )
    for side in ("left", "right"):
        idx = foot_markers(trial.marker_names, side)
        lines.append(f"  {side} foot markers: {[trial.marker_names[i] for i in idx]}")
    nan = np.isnan(trial.markers).any(axis=2)
    gappy = [n for n, g in zip(trial.marker_names, nan.any(axis=0), strict=True) if g]
    if gappy:
        lines.append(f"  markers with gaps > {MAX_GAP_FILL} s left NaN: {gappy}")
    for p in trial.plates:
        lines.append(
            f"  {p.name}: {p.rate:.0f} Hz, reference {p.reference_kind} "
            f"{np.round(p.reference_point, 4).tolist()} m, surface z {p.surface_height:.4f} m"
            + ("" if p.corners is not None else ", no corners")
        )
    lines.append(
        f"  body weight {bw:.1f} N = {trial.mass:.2f} kg x {GRAVITY} ({trial.mass_source})"
    )
    h = f"{trial.height:.3f} m ({trial.height_source})" if trial.height else "unknown"
    lines.append(f"  height {h}")
    if np.any(trial.belt_velocity):
        lines.append(f"  treadmill belt velocity {trial.belt_velocity.tolist()} m/s (lab)")
    for s in trial.stances:
        p = trial.plates[s.plate]
        sel = (p.time >= s.t_on) & (p.time <= s.t_off)
        peak = float(p.force[sel, 2].max())
        lines.append(
            f"  stance {s.side:5s} {p.name}: {s.t_on:.3f}-{s.t_off:.3f} s, peak Fz {peak:.0f} N "
            f"({100 * peak / bw:.0f} % BW), reference {s.reference_kind}"
        )
    for s in trial.excluded_stances:
        lines.append(
            f"  EXCLUDED {s.side} {trial.plates[s.plate].name} "
            f"{s.t_on:.3f}-{s.t_off:.3f} s: {s.reason}"
        )
    check = stride_body_weight(trial)
    if check:
        v, t0, t1 = check
        lines.append(
            f"  check: mean vertical force over the stride {t0:.3f}-{t1:.3f} s = {v:.0f} N "
            f"({100 * (v / bw - 1):+.1f} % vs body weight)"
        )
    for n in trial.load_notes:
        lines.append(f"  note: {n}")
    return "\n".join(lines)


def load_static(path: str | Path, walking: Trial) -> Trial:
    """Load a static standing trial (markers only) into the ``lab`` frame of ``walking``.

    A static trial has no walking direction, so the walking trial's rotation is reused: the
    static file must come from the same lab set-up (same axes). Plates are not read: the floor
    height is the walking trial's plate surface.
    """
    import dataclasses

    from gc_ocp.io._common import Y_UP_TO_LAB
    from gc_ocp.io.c3d import read_c3d
    from gc_ocp.io.opensim import read_trc

    path = Path(path)
    if not path.is_file():
        raise InputError(f"Static trial {path} does not exist; check the --static path.")
    suffix = path.suffix.lower()
    if suffix == ".trc":
        names, markers, time = read_trc(path)  # already Z-up
        file_rot = Y_UP_TO_LAB
    elif suffix == ".c3d":
        raw = read_c3d(path)
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
    rot = walking.lab_rotation @ np.linalg.inv(file_rot)
    markers, _ = fill_short_gaps(markers @ rot.T, time)
    return dataclasses.replace(
        walking,
        source=path,
        marker_names=tuple(names),
        markers=markers,
        marker_time=time,
        plates=(),
        stances=(),
        excluded_stances=(),
        grf_source=None,
        load_notes=(f"static trial in the lab frame of {walking.source.name}",),
    )
