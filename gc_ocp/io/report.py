"""Readable report of a loaded trial (``gc-ocp info``)."""

from __future__ import annotations

import numpy as np

from gc_ocp.gaps import MAX_GAP_FILL
from gc_ocp.io._common import foot_markers
from gc_ocp.io.checks import stride_body_weight
from gc_ocp.trial import GRAVITY, Trial


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
