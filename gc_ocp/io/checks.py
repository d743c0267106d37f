"""Checks of a loaded trial against what the analysis needs: markers present without long gaps,
and the body weight against the plates over one stride."""

from __future__ import annotations

import numpy as np

from gc_ocp.errors import MarkerError
from gc_ocp.gaps import MAX_GAP_FILL, nan_runs
from gc_ocp.trial import Trial


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
