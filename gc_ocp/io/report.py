"""Readable report of a loaded trial (``gc-ocp info``)."""

from __future__ import annotations

import numpy as np

from gc_ocp.errors import GcOcpError
from gc_ocp.gaps import MAX_GAP_FILL
from gc_ocp.io._common import foot_markers
from gc_ocp.io.checks import stride_body_weight
from gc_ocp.model.markerset import detect_markerset
from gc_ocp.model.recognition import label_key
from gc_ocp.trial import GRAVITY, Trial
from gc_ocp.values import require


def _markerset_line(trial: Trial) -> str:
    """The recognised marker set (``gc_ocp.model.markerset.detect_markerset``), or why not."""
    try:
        ms = detect_markerset(trial.marker_names)
    except GcOcpError as e:
        return f"  marker set: not recognised ({str(e).split(';')[0]}); give --markerset"
    found = [n for n in ms.markers if n in trial.marker_names]
    return f'  marker set: "{ms.name}" ({len(found)} of its {len(ms.markers)} markers found)'


def vertical_axis_of(trial: Trial) -> str:
    """The file axis that became lab +Z, e.g. ``"+Y"`` (from ``Trial.lab_rotation``)."""
    row = np.asarray(trial.lab_rotation)[2]
    k = int(np.argmax(np.abs(row)))
    return f"{'+' if row[k] > 0 else '-'}{'XYZ'[k]}"


def _heading(rad: float) -> str:
    return "unknown" if not np.isfinite(rad) else f"{np.degrees(rad):+.0f} deg"


def processing_lines(trial: Trial) -> list[str]:
    """What the lab's processing did to the plates and markers, as a fit reads it
    (:func:`gc_ocp.io.processing.detect_processing`; a zero threshold is censored in every fit):
    one line per finding, for ``gc-ocp info``, which showed none of it (a processing review)."""
    from gc_ocp.io.processing import detect_processing

    proc = detect_processing(trial)
    out = []
    for name, p in proc.plates.items():
        out += [f"  {name} as processed: {s}" for s in p.findings()]
    if proc.markers is not None:
        out += [f"  markers as processed: {s}" for s in proc.markers.findings()]
    return out


def describe_trial(trial: Trial) -> str:
    """Readable summary: rates, markers and the recognised marker set, vertical axis and walking
    direction, plates (type, reference, removed offset), the lab's processing
    (:func:`processing_lines`), stances (foot, plate, times, heading,
    peak force in N and % BW), exclusions with reasons, mass and its source, and the stride
    body-weight check (what ``gc-ocp info`` prints).

    >>> import gc_ocp
    >>> print(gc_ocp.describe_trial(gc_ocp.load_trial()))  # doctest: +ELLIPSIS
    Trial ...test_small.c3d
      markers: 33 at 100 Hz, 0.000-3.360 s
      marker set: "plugingait" (33 of its 35 markers found)
    ...
      stance right plate1: 0.407-1.061 s, used, heading +1 deg, peak Fz 669 N (107 % BW), ...
    ...
    """
    require(
        trial,
        Trial,
        "describe_trial takes one loaded trial",
        "gc_ocp.describe_trial(gc_ocp.load_trial(path))",
    )
    bw = trial.body_weight
    lines = [f"Trial {trial.source}" + (f" + {trial.grf_source}" if trial.grf_source else "")]
    lines.append(
        f"  markers: {len(trial.marker_names)} at {trial.marker_rate:.0f} Hz, "
        f"{trial.marker_time[0]:.3f}-{trial.marker_time[-1]:.3f} s"
    )
    lines.append(_markerset_line(trial))
    walk = next((n for n in trial.load_notes if n.startswith("walking direction")), "")
    lines.append(
        f"  vertical axis: {vertical_axis_of(trial)} of the file is up (lab +Z); "
        + (walk or "walking direction: file X kept")
    )
    names = list(trial.marker_names)
    # a label the file uses twice is shown as the fit names it: LANK, LANK#2
    shown = [label_key(names, i) for i in range(len(names))]
    for side in ("left", "right"):
        idx = foot_markers(trial.marker_names, side)
        twice = sorted({names[i] for i in idx if names.count(names[i]) > 1})
        lines.append(
            f"  {side} foot markers: {[shown[i] for i in idx]}"
            + (f" (the file labels two markers {', '.join(twice)})" if twice else "")
        )
    nan = np.isnan(trial.markers).any(axis=2)
    feet = {i for side in ("left", "right") for i in foot_markers(trial.marker_names, side)}
    t = trial.marker_time
    inside = np.zeros(t.size, bool)
    for s in trial.stances:
        inside |= (t >= s.t_on) & (t <= s.t_off)
    in_stance = [shown[i] for i in sorted(feet) if nan[inside, i].any()]
    other = [shown[i] for i in range(len(names)) if nan[:, i].any() and shown[i] not in in_stance]
    if in_stance:  # what the fit needs: a foot marker lost within a stance
        lines.append(
            f"  foot markers missing within a stance (gaps > {MAX_GAP_FILL} s, not filled): "
            f"{in_stance}"
        )
    if other:
        first = ", ".join(other[:8]) + (f" and {len(other) - 8} more" if len(other) > 8 else "")
        lines.append(
            f"  {len(other)} other markers missing in some frames (gaps > {MAX_GAP_FILL} s or "
            f"the file's ends; none a foot marker within a stance): {first}"
        )
    for p in trial.plates:
        off = p.zero_offset
        if off is None:
            zero = "no unloaded offset removed"
        elif not np.any(off):
            zero = "zeroed (reads 0 N unloaded)"
        else:
            zero = f"removed unloaded offset (lab axes) F={np.round(off[:3], 1).tolist()} N"
        lines.append(
            f"  {p.name}: {p.plate_type or 'plate'}, {p.rate:.0f} Hz, reference "
            f"{p.reference_kind} {np.round(p.reference_point, 4).tolist()} m, surface z "
            f"{p.surface_height:.4f} m"
            + ("" if p.corners is not None else ", no corners")
            + f", {zero}"
        )
    lines += processing_lines(trial)
    lines.append(f"  mass {trial.mass:.2f} kg ({trial.mass_source})")
    lines.append(f"  body weight {bw:.1f} N = {trial.mass:.2f} kg x {GRAVITY}")
    h = f"{trial.height:.3f} m ({trial.height_source})" if trial.height else "unknown"
    lines.append(f"  height {h}")
    if np.any(trial.belt_velocity):
        lines.append(f"  treadmill belt velocity {trial.belt_velocity.tolist()} m/s (lab)")
    if trial.stances:
        # info reads the file alone: the fit's checks of each stance's force against the foot's
        # posed markers (gc_ocp.io.consistency) come later and can exclude more
        lines.append(
            "  stances (usable as read; a fit also checks each force against the posed foot):"
        )
    for s in trial.stances:
        p = trial.plates[s.plate]
        sel = (p.time >= s.t_on) & (p.time <= s.t_off)
        peak = float(p.force[sel, 2].max())
        lines.append(
            f"  stance {s.side:5s} {p.name}: {s.t_on:.3f}-{s.t_off:.3f} s, used, heading "
            f"{_heading(s.heading)}, peak Fz {peak:.0f} N ({100 * peak / bw:.0f} % BW), "
            f"reference {s.reference_kind}"
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
            f"  check: mean vertical force over the stride-long window {t0:.3f}-{t1:.3f} s = "
            f"{v:.0f} N "
            f"({100 * (v / bw - 1):+.1f} % vs body weight)"
        )
    for n in trial.load_notes:
        lines.append(f"  note: {n}")
    return "\n".join(lines)
