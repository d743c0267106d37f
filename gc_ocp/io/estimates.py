"""ESTIMATES of subject and set-up quantities from a loaded trial (height, treadmill belt speed),
offered to the user and never applied automatically."""

from __future__ import annotations

import numpy as np

from gc_ocp.errors import MarkerError
from gc_ocp.io._common import foot_markers
from gc_ocp.kinematics.filtering import lowpass
from gc_ocp.kinematics.scaling import estimate_height
from gc_ocp.model.markerset import MarkerSet, detect_markerset, load_markerset
from gc_ocp.trial import Trial


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
