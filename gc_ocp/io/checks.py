"""Checks of a loaded trial against what the analysis needs: markers present without long gaps,
and the body weight against the plates over one stride."""

from __future__ import annotations

import numpy as np

from gc_ocp.errors import MarkerError, PlateError
from gc_ocp.gaps import MAX_GAP_FILL, nan_runs
from gc_ocp.io._common import foot_markers
from gc_ocp.trial import Trial

FOOT_FIX_LEVER = 0.03
"""Smallest distance [m] of a visible foot marker from the line through the two farthest-apart
visible ones for the visible markers to fix the foot's orientation: skin and marker noise of
~2 mm over a 30 mm lever arm leaves ~4 deg about that line; collinear markers leave it free."""


STATIC_MAX_STD = 0.02
"""Largest marker movement [m] of a static (standing) trial: standard deviation over the trial of
a marker's position, median over the markers (and over the foot markers). Quiet standing sways
the body by ~1 cm and the feet stay put (~1 mm); walking moves the markers by decimetres, even on
a treadmill (the feet swing +-0.3 m)."""


def marker_spread(names, markers: np.ndarray) -> dict[str, float]:
    """[m] How far the markers ``(n, m, 3)`` move over the trial: the median over the markers
    (and over the foot markers) of each one's positional standard deviation (0 without
    frames)."""
    std = np.full(markers.shape[1], np.nan)
    if markers.shape[0] >= 2:
        ok = np.isfinite(markers).all(axis=2)
        for j in range(markers.shape[1]):
            if ok[:, j].sum() >= 2:
                std[j] = float(np.linalg.norm(markers[ok[:, j], j].std(axis=0)))
    feet = [i for side in ("left", "right") for i in foot_markers(names, side)]
    body = std[np.isfinite(std)]
    foot = std[feet][np.isfinite(std[feet])] if feet else np.zeros(0)
    return {
        "markers": float(np.median(body)) if body.size else 0.0,
        "foot markers": float(np.median(foot)) if foot.size else 0.0,
    }


def static_hint(names, markers: np.ndarray) -> str:
    """A sentence for the error of a walking command given a standing trial (its markers move
    less than :data:`STATIC_MAX_STD`), else ``""``."""
    if markers.shape[0] < 2:
        return ""
    moved = marker_spread(names, markers)
    if max(moved.values()) > STATIC_MAX_STD or not any(moved.values()):
        return ""
    return (
        f" Its markers stand still ({moved['markers'] * 1e3:.0f} mm, the median standard "
        "deviation): it looks like a static (standing) trial; give it with --static FILE "
        "beside a walking trial, not as a walking trial."
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


def force_unit_hint(plates, threshold: float) -> str:
    """A clause for a "no stance" message when no plate ever reaches ``threshold`` [N] but some
    carry a force: plates whose forces are in kN (or another unit) read as newtons; else ""."""
    peak = max(
        (float(np.nanmax(np.abs(np.asarray(p.force)[:, 2]), initial=0.0)) for p in plates),
        default=0.0,
    )
    if not 0.0 < peak < threshold:
        return ""
    return (
        f"; the largest vertical force on any plate is {peak:.3g} N, which no person walking "
        "puts on a plate: the force channels are probably in kN or another unit read as N "
        "(check ANALOG:UNITS and ANALOG:SCALE, or the MOT's force columns)"
    )


def require_stances(trial: Trial) -> None:
    """Raise :class:`PlateError` when ``trial`` has no usable stance, naming the file, why each
    contact was excluded and the fix (before any output is written)."""
    if trial.stances:
        return

    why = "; ".join(
        f"{e.side} on {trial.plates[e.plate].name} {e.t_on:.3f}-{e.t_off:.3f} s: {e.reason}"
        for e in trial.excluded_stances
    )
    unit = force_unit_hint(trial.plates, trial.contact_threshold)
    raise PlateError(
        f"{trial.source}: no usable stance ("
        + (
            why
            or f"no plate is loaded above the contact threshold, {trial.contact_threshold:g} N"
            + unit
        )
        + "). A stance needs one foot, fully and alone on one plate, in a walking step: give a "
        "trial where each foot lands cleanly on its own plate, or fix the plate set-up."
        + static_hint(trial.marker_names, trial.markers)
    )


def _fixes_foot(points: np.ndarray) -> bool:
    """True if ``points`` ``(k, 3)`` are >= 3 markers, not collinear within FOOT_FIX_LEVER."""
    if len(points) < 3:
        return False
    d = np.linalg.norm(points[:, None] - points[None], axis=2)
    i, j = np.unravel_index(np.argmax(d), d.shape)
    axis = (points[j] - points[i]) / max(d[i, j], 1e-12)
    rel = points - points[i]
    off = np.linalg.norm(rel - np.outer(rel @ axis, axis), axis=1)
    return bool(off.max() >= FOOT_FIX_LEVER)


def stance_gap_report(
    trial: Trial, foot_names: dict[str, list[str]] | None = None
) -> tuple[dict[str, str], dict[str, str]]:
    """Foot-marker gaps inside the stances of ``trial``: ``(excluded, bridged)``, each
    ``{stance label: reason}``.

    Gaps of at most :data:`MAX_GAP_FILL` were filled on load; a foot marker of the stance foot
    still missing inside ``[t_on, t_off]`` leaves the foot pose to the other foot markers. If in
    every such frame >= 3 visible foot markers fix the foot (:func:`_fixes_foot`), the gap is
    bridged by them (``bridged``, a note); otherwise the stance is to be excluded (``excluded``):
    the IK would pose the foot from too few markers and the fit would degrade silently.
    foot_names: ``{side: [marker names]}`` (default: the foot markers found by name,
    :func:`gc_ocp.io._common.foot_markers`). Markers never visible in the trial are not foot
    markers of this trial (absent, not a gap).
    """
    names = list(trial.marker_names)
    t = np.asarray(trial.marker_time)
    rate = trial.marker_rate
    excluded: dict[str, str] = {}
    bridged: dict[str, str] = {}
    for s in trial.stances:
        if foot_names is not None:
            idx = [names.index(n) for n in foot_names.get(s.side, []) if n in names]
        else:
            idx = foot_markers(names, s.side)
        idx = [i for i in idx if np.isfinite(trial.markers[:, i]).all(axis=1).any()]
        win = np.flatnonzero((t >= s.t_on) & (t <= s.t_off))
        if not idx or not win.size:
            continue
        m = np.asarray(trial.markers)[:, idx]
        ok = np.all(np.isfinite(m), axis=2)  # (n_frames, k)
        gaps = []
        for k, i in enumerate(idx):
            for a, b in nan_runs(ok[:, k]):
                if b > win[0] and a <= win[-1]:
                    gaps.append(
                        f'"{names[i]}" missing for {(b - a) / rate:.3f} s '
                        f"({t[a]:.3f}-{t[b - 1]:.3f} s)"
                    )
        if not gaps:
            continue
        holes = win[~ok[win].all(axis=1)]
        fixed = all(_fixes_foot(m[f][ok[f]]) for f in holes)
        what = (
            f"{s.side} foot marker {'; '.join(gaps)} inside the stance {s.t_on:.3f}-{s.t_off:.3f} s"
        )
        if fixed:
            seen = sorted(
                {names[idx[k]] for f in holes for k in np.flatnonzero(ok[f])},
                key=names.index,
            )
            bridged[s.label] = (
                f"{what}, longer than the {MAX_GAP_FILL} s filled automatically: bridged by the "
                f"other {s.side} foot markers {seen} (>= 3 non-collinear visible in every frame)"
            )
        else:
            excluded[s.label] = (
                f"{what}, longer than the {MAX_GAP_FILL} s filled automatically, and the other "
                f"{s.side} foot markers do not fix the foot then (need >= 3 non-collinear, "
                f">= {FOOT_FIX_LEVER * 1e3:.0f} mm off a line): fill the gap in your mocap "
                f"software to use this stance"
            )
    return excluded, bridged


def stance_gaps(trial: Trial, foot_names: dict[str, list[str]] | None = None) -> dict[str, str]:
    """Stances of ``trial`` to exclude for foot-marker gaps, ``{stance label: reason}`` (see
    :func:`stance_gap_report`; gaps bridged by the other foot markers are not listed).
    :func:`gc_ocp.io.load_trial` already applies it with the foot markers found by name."""
    return stance_gap_report(trial, foot_names)[0]


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
    mass used is always the given/file one. A window holding a missing (non-finite) plate sample
    is not used (before, one NaN made every later window NaN and the check silently passed);
    ``None`` when every window holds one.
    """
    ons: dict[str, list[float]] = {}
    for s in list(trial.stances) + list(trial.excluded_stances):
        if getattr(s, "reason", "").startswith(("clipped: force already", "not a walking")):
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
    missing = ~np.isfinite(fz)
    fz = np.where(missing, 0.0, fz)
    c = np.concatenate([[0.0], np.cumsum(0.5 * (fz[1:] + fz[:-1]) * np.diff(t))])
    mean = (c[n:] - c[:-n]) / (t[n:] - t[:-n])
    # missing samples among samples i..i+n of the window starting at sample i
    gaps = np.concatenate([[0], np.cumsum(missing)])
    mean[gaps[n + 1 :] - gaps[: -n - 1] > 0] = np.nan
    if not np.isfinite(mean).any():
        return None
    k = int(np.nanargmax(mean))
    return float(mean[k]), float(t[k]), float(t[k + n])
