"""Stance detection on force plates, side assignment from foot markers, exclusions.

* Contact: vertical force above ``threshold`` (default :data:`DEFAULT_THRESHOLD` = 20 N, about
  3 % of body weight for a 65 kg subject and well above plate noise (< 2 N)). Hysteresis in
  time: above-threshold runs separated by less than :data:`MERGE_GAP` are one contact (a COP
  flicker near the threshold does not split a stance); contacts shorter than
  :data:`MIN_DURATION` are dropped. ``t_on``/``t_off`` are the threshold crossings, linearly
  interpolated between samples.
* Side: the foot (left/right) whose heel/ankle/toe markers are horizontally nearest the COP at
  mid-stance.
* Heading: the direction of the body's horizontal velocity over the stance
  (:func:`gc_ocp.io.orientation.body_velocity`), or on a treadmill the stance foot's heel -> toe
  direction (``Stance.heading``).
* Exclusions (warning + :class:`~gc_ocp.trial.ExcludedStance`): clipped by the file ends
  (force above threshold at the first/last sample, a lab's zeroing that hides it:
  :func:`_zeroed_file_edge`, or markers not covering the stance); not a
  walking stance (longer than :data:`MAX_STANCE`, or the body moving slower than
  :data:`~gc_ocp.io.orientation.MIN_OVERGROUND_SPEED` while the stance foot stands still:
  standing or stepping in place; on a treadmill the foot moves with the belt); a COP outside the
  plate outline by more than :data:`EDGE_TOL` for more than :data:`COP_OFF_TIME` while Fz >
  20 % BW (a plate cannot measure a load where it has no surface: the corners, origin or channels
  are wrong; a briefer excursion, e.g. an impact transient at heel strike, is noted and ignored);
  the foot partly off the plate (a stance-foot marker low enough to touch the floor outside the
  outline by more than :data:`EDGE_TOL`); two feet on one plate (the other foot's markers on the
  plate, low and still, for more than 50 ms while loaded). The last three need the plate corners
  (C3D), not available for MOT channels. Two contacts of one foot on one plate less than
  :data:`MIN_SWING` apart while the foot's markers stay put are one contact the plate lost
  for a while (zeros or NaN: a dropout): both parts are excluded, naming the gap. A centre of
  pressure that does not roll from heel to toe in the foot's frame (:data:`COP_ACROSS`) means
  the plate's axes are wrong (corners in another order): excluded, naming the set-up.
"""

from __future__ import annotations

import warnings

import numpy as np

from gc_ocp.errors import PlateError
from gc_ocp.io._common import foot_markers, heel_toe, warn
from gc_ocp.io.orientation import MIN_OVERGROUND_SPEED, body_velocity
from gc_ocp.io.processing import fz_run_min, held_level, mean_rate
from gc_ocp.trial import ExcludedStance, Plate, Stance

DEFAULT_THRESHOLD = 20.0
"""Default contact threshold on the vertical force, in [N]."""
MIN_DURATION = 0.1
"""Shortest contact kept, in [s]."""
MERGE_GAP = 0.02
"""Above-threshold runs closer than this [s] are merged into one contact."""
EDGE_TOL = 0.01
"""Tolerance [m] for the COP / foot markers outside the plate outline."""
LOW_MARKER = 0.08
"""A foot marker below surface + this [m] is taken as able to touch the plate."""
PLANTED_SPEED = 0.3
"""Horizontal speed [m/s] below which a low foot marker is taken as planted."""
MAX_STANCE = 2.0
"""Longest walking stance [s]: ~0.6 s at a normal pace, ~1.2 s at the slowest walking speeds;
a longer contact is standing."""
STILL_FOOT = 0.15
"""Mean horizontal speed [m/s] of a stance foot below which it stands still (overground); on a
treadmill it moves backward with the belt (~1 m/s)."""
COP_OFF_TIME = 0.02
"""Longest time [s] the COP may lie outside the plate outline while loaded before the stance is
excluded (impact transients at heel strike last a few ms)."""


def contact_windows(
    plate: Plate, threshold: float, keep_short: bool = False
) -> list[tuple[int, int, float, float]]:
    """Runs where ``Fz > threshold``: ``(i_on, i_off, t_on, t_off)``, ``i_off`` exclusive;
    those shorter than :data:`MIN_DURATION` only with ``keep_short``."""
    fz = plate.force[:, 2]
    t = plate.time
    above = fz > threshold
    d = np.diff(np.concatenate([[0], above.astype(int), [0]]))
    starts, ends = list(np.flatnonzero(d == 1)), list(np.flatnonzero(d == -1))
    runs: list[list[int]] = []
    for a, b in zip(starts, ends, strict=True):
        if runs and t[a] - t[runs[-1][1] - 1] < MERGE_GAP:
            runs[-1][1] = b
        else:
            runs.append([a, b])
    out = []
    for a, b in runs:
        t_on = _crossing(t, fz, a - 1, a, threshold) if a > 0 else float(t[0])
        t_off = _crossing(t, fz, b - 1, b, threshold) if b < len(t) else float(t[-1])
        if keep_short or t_off - t_on >= MIN_DURATION:
            out.append((a, b, t_on, t_off))
    return out


def _crossing(t, f, i, j, level) -> float:
    if not (np.isfinite(f[i]) and np.isfinite(f[j])):  # a run that ends at missing samples
        return float(t[i] if np.isfinite(f[i]) else t[j])
    if f[j] == f[i]:
        return float(t[j])
    return float(t[i] + (level - f[i]) * (t[j] - t[i]) / (f[j] - f[i]))


def _inside(points_xy: np.ndarray, corners: np.ndarray, tol: float) -> np.ndarray:
    """True where a point is within ``tol`` of the (convex, axis-agnostic) plate outline."""
    c = corners[:, :2]
    centre = c.mean(axis=0)
    ok = np.ones(points_xy.shape[0], dtype=bool)
    for k in range(4):
        a, b = c[k], c[(k + 1) % 4]
        edge = b - a
        normal = np.array([edge[1], -edge[0]]) / np.linalg.norm(edge)
        if np.dot(centre - a, normal) > 0:
            normal = -normal  # outward
        ok &= (points_xy - a) @ normal <= tol
    return ok


def _markers_at(markers, marker_time, idx, times):
    """Marker positions ``(len(times), len(idx), 3)`` interpolated at ``times``; NaN outside."""
    out = np.full((len(times), len(idx), 3), np.nan)
    for k, j in enumerate(idx):
        for a in range(3):
            out[:, k, a] = np.interp(
                times, marker_time, markers[:, j, a], left=np.nan, right=np.nan
            )
    return out


def detect_stances(
    plates,
    marker_names,
    markers,
    marker_time,
    body_weight: float | None,
    threshold: float = DEFAULT_THRESHOLD,
    source: str = "",
) -> tuple[list[Stance], list[ExcludedStance], list[str]]:
    """Stances on every plate; returns (usable stances, excluded ones, side-check notes)."""
    feet = {s: foot_markers(marker_names, s) for s in ("left", "right")}
    stances: list[Stance] = []
    excluded: list[ExcludedStance] = []
    notes: list[str] = []
    for ip, plate in enumerate(plates):
        cop = plate.cop(min_vertical=threshold)
        runs = contact_windows(plate, threshold, keep_short=True)
        windows = [w for w in runs if w[3] - w[2] >= MIN_DURATION]
        sides: list[str] = []
        dists: list[dict] = []
        for a, b, t_on, t_off in windows:
            t_mid = 0.5 * (t_on + t_off)
            i_mid = int(np.argmin(np.abs(plate.time - t_mid)))
            # side: nearest foot marker to the COP at mid-stance (skip frames with NaN COP)
            window = np.arange(a, b)
            valid = window[np.all(np.isfinite(cop[window]), axis=1)]
            if valid.size:
                i_mid = valid[np.argmin(np.abs(plate.time[valid] - t_mid))]
            dist = {}
            for s, idx in feet.items():
                if not idx:
                    continue
                m = _markers_at(markers, marker_time, idx, plate.time[[i_mid]])[0]
                d = np.linalg.norm(m[:, :2] - cop[i_mid, :2], axis=1)
                if np.isfinite(d).any():
                    dist[s] = float(np.nanmin(d))
            if dist:
                side = min(dist, key=dist.get)
            elif plate.name.endswith(("_left", "_right")):
                side = plate.name.rsplit("_", 1)[1]
            else:
                side = "unknown"
            sides.append(side)
            dists.append(dist)
        by_run = dict(zip(windows, sides, strict=True))
        dropouts = _dropouts(plate, runs, by_run, feet, markers, marker_time)
        levels = zero_levels(plate) if windows else (0.0,)
        for (a, b, t_on, t_off), side, dist in zip(windows, sides, dists, strict=True):
            window = np.arange(a, b)
            if plate.name in ("grf_left", "grf_right") and side != plate.name[4:] and dist:
                notes.append(
                    f"{plate.name} at {t_on:.3f}-{t_off:.3f} s: the {side} foot markers are "
                    f"nearest the COP ({dist}), contradicting the column names"
                )
                warn(f"{source}: {notes[-1]}; check the GRF column sides.")
            heading, motion = _stance_motion(
                marker_names, markers, marker_time, feet.get(side, []), side, t_on, t_off
            )
            # the body's direction of travel over the stance (None: it stands, or a treadmill)
            travel = heading if motion.get("body", 0.0) > MIN_OVERGROUND_SPEED else None
            reason = _exclusion(
                plate,
                a,
                b,
                t_on,
                t_off,
                side,
                cop,
                feet,
                marker_names,
                markers,
                marker_time,
                body_weight,
                threshold,
                notes,
                travel,
                levels,
            )
            if not reason.startswith("clipped"):
                reason = _not_walking(t_on, t_off, motion) or reason
            reason = reason or dropouts.get(a, "")
            if reason:
                warn(
                    f"{source}: stance {side} on {plate.name} {t_on:.3f}-{t_off:.3f} s "
                    f"excluded: {reason}"
                )
                excluded.append(ExcludedStance(side, ip, t_on, t_off, reason))
                continue
            if plate.reference_kind in ("electrical_center", "surface_center"):
                ref, kind = plate.reference_point, plate.reference_kind
            else:
                loaded = window[np.all(np.isfinite(cop[window]), axis=1)]
                w = plate.force[loaded, 2]
                ref = np.average(cop[loaded], axis=0, weights=w)
                ref[2] = plate.surface_height
                kind = "floor_under_mean_cop"
            stances.append(Stance(side, ip, t_on, t_off, ref, kind, heading=heading))
    stances.sort(key=lambda s: s.t_on)
    excluded.sort(key=lambda s: s.t_on)
    return stances, excluded, notes


MIN_SWING = 0.25
"""Shortest time [s] between two contacts of one foot: a swing lasts 0.35-0.45 s in walking
(and longer in running). A plate that reads no force for less than this inside what the
markers place as one foot's contact has dropped out (:func:`_dropouts`)."""


STILL_MARKER = 0.02
"""[m] A foot on the ground keeps at least one marker within this of where it was (the heel
while it is flat, the toe in heel rise: skin on bone, the foot rolling over); a foot that
lifts, however briefly, moves them all farther (:func:`_dropouts`)."""


def _dropouts(plate: Plate, runs, sides: dict, feet, markers, mtime) -> dict[int, str]:
    """Reasons to exclude, keyed by a window's first sample: two contacts of the same foot on
    ``plate`` separated by less than :data:`MIN_SWING` while the foot's markers stay within
    :data:`STILL_MARKER` of where they were (the foot never left the plate) are one contact
    whose force the plate lost in between (zeros, NaN, a cable): neither part is a stance, and
    the gap is named. A foot that lifts in between (a shuffle, a step in place) is not this.
    ``runs``: every contact of the plate in time order, those shorter than
    :data:`MIN_DURATION` included (a dropout near heel strike or toe-off leaves such a part);
    ``sides``: the foot of each run long enough to be a window (a short part takes its
    neighbour's)."""
    out: dict[int, str] = {}
    for r0, r1 in zip(runs, runs[1:], strict=False):
        (a0, b0, _, t_off0), (a1, _, t_on1, _) = r0, r1
        s0, s1 = sides.get(r0), sides.get(r1)
        if s0 is None and s1 is None:
            continue
        s0, s1 = s0 or s1, s1 or s0
        gap = t_on1 - t_off0
        if s0 != s1 or gap >= MIN_SWING or not feet.get(s0):
            continue
        m = _markers_at(markers, mtime, feet[s0], np.linspace(t_off0, t_on1, 12))
        moved = np.linalg.norm(m - m[:1], axis=2)  # (time, marker)
        if not np.isfinite(moved).any():
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a marker missing throughout
            stillest = np.nanmin(np.nanmax(moved, axis=0))
        # the foot stays on the plate while one of its markers stays put (the toe in heel rise)
        if stillest < STILL_MARKER:
            lost = plate.force[b0:a1, 2]
            what = "no value (NaN)" if np.isnan(lost).any() else "no force"
            reason = (
                f"plate {plate.name} reads {what} for {gap * 1e3:.0f} ms at {t_off0:.3f} s inside "
                f"one contact of the {s0} foot (a swing takes at least {MIN_SWING:.2f} s): the "
                f"plate dropped out; check its cable or amplifier, or the file's analog data"
            )
            out[a0] = out[a1] = reason
    return out


PEAK_RATIO = 4.0
"""Largest ratio of two plates' stance peaks (the median over each plate's stances) in one
trial. A walking stance peaks at 1.0-1.4 body weights whatever the speed (running 2-3, every
stance alike); sides differ in hemiparetic gait by tens of per cent and with crutches by up to
~3x; a plate's wrong gain (ANALOG:SCALE, its calibration, a unit) is 10x or 1000x."""


def check_peaks(plates, stances: list[Stance], source: str) -> None:
    """A :class:`~gc_ocp.errors.PlateError` naming the plates when the C3D plates' stance peaks
    disagree by more than :data:`PEAK_RATIO` (before: a plate read 10 times too high gave an
    estimated mass of 358 kg). Plates without corners (OpenSim MOT columns: one per foot, no
    gain of their own) are not compared."""
    per_plate: dict[int, list[float]] = {}
    for s in stances:
        p = plates[s.plate]
        if p.corners is None:
            continue
        sel = (p.time >= s.t_on) & (p.time <= s.t_off)
        per_plate.setdefault(s.plate, []).append(float(np.nanmax(p.force[sel, 2])))
    if len(per_plate) < 2:
        return
    med = {k: float(np.median(v)) for k, v in per_plate.items()}
    hi, lo = max(med, key=med.get), min(med, key=med.get)
    if med[hi] > PEAK_RATIO * med[lo]:
        raise PlateError(
            f"{source}: the plates' stance peaks disagree by {med[hi] / med[lo]:.1f}x "
            f"({plates[hi].name} {med[hi]:.0f} N, {plates[lo].name} {med[lo]:.0f} N; walking "
            f"stances of one subject peak within tens of per cent of each other): a plate's "
            f"gain (ANALOG:SCALE, its calibration, a unit) is wrong. Fix that plate's set-up in "
            f"the file."
        )


def _stance_motion(names, markers, mtime, foot, side, t_on, t_off):
    """``(heading [rad], {"body": speed, "foot": speed})`` over ``[t_on, t_off]``: body velocity
    (median marker velocity, :func:`~gc_ocp.io.orientation.body_velocity`) and the stance
    foot's mean horizontal velocity (median over its markers); speeds in [m/s]."""
    sel = (mtime >= t_on) & (mtime <= t_off)
    if sel.sum() < 3:
        return float("nan"), {}
    v = body_velocity(markers[sel], mtime[sel])
    v = v[np.isfinite(v).all(axis=1)]
    body = v.mean(axis=0) if len(v) else np.full(2, np.nan)
    motion = {"body": float(np.linalg.norm(body))}
    if foot:
        fv = np.gradient(markers[sel][:, foot, :2], mtime[sel], axis=0)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            fm = np.nanmedian(np.nanmean(fv, axis=0), axis=0)
        if np.isfinite(fm).all():
            motion["foot"] = float(np.linalg.norm(fm))
    if motion["body"] > MIN_OVERGROUND_SPEED:
        return float(np.arctan2(body[1], body[0])), motion
    h, t = heel_toe(names, side)
    if h is not None and t is not None:
        d = markers[sel][:, t, :2] - markers[sel][:, h, :2]
        d = d[np.isfinite(d).all(axis=1)]
        if len(d):
            d = d.mean(axis=0)
            return float(np.arctan2(d[1], d[0])), motion
    return float("nan"), motion


def _not_walking(t_on, t_off, motion) -> str:
    """Reason a contact is not a walking stance (standing, stepping in place), else ``""``."""
    if t_off - t_on > MAX_STANCE:
        return (
            f"not a walking stance: {t_off - t_on:.2f} s on the plate (a walking stance lasts "
            f"< {MAX_STANCE:.0f} s): standing"
        )
    body, foot = motion.get("body", np.nan), motion.get("foot", np.nan)
    if body < MIN_OVERGROUND_SPEED and foot < STILL_FOOT:
        return (
            f"not a walking stance: the body moves at {body:.2f} m/s (walking: > "
            f"{MIN_OVERGROUND_SPEED} m/s) and the foot stands still ({foot:.2f} m/s; on a "
            f"treadmill it moves with the belt): standing or stepping in place"
        )
    return ""


COP_BACKWARD = 0.05
COP_ACROSS = 0.08
"""[m] How a walking stance's centre of pressure moves in the foot's frame (heel -> toe axis
from the markers; its sign that of the direction of travel, so that walking backward, toe to
heel, counts as forward), from the median of its first to its last quarter while loaded
(> 20 % BW):
forward by 6-16 cm in every stance of the shared walking files (turns included; +1 cm in one
child's stance), across by at most 3 cm. A path more than 5 cm backward, or more than 8 cm
across and more across than along, is not a walking foot's: the plate's axes are wrong (corners
listed in another order move it 13-17 cm across or 15 cm backward)."""


COP_TRAVEL_MAX = 0.30
"""[m] A foot's centre of pressure travels at most the foot's length heel to toe in a stance
(6-16 cm forward in every stance of the shared walking files, :data:`COP_ACROSS`; an adult foot
is 22-30 cm long). More, either way, is not one foot: two feet or several steps on one plate
(or one force set of a MOT that sums both feet)."""


def _cop_path(
    cop, loaded, times, side, names, markers, mtime, travel
) -> tuple[float, float] | None:
    """``(along, across)`` [m]: how the COP moves in the stance foot's frame (see
    :data:`COP_ACROSS`) over the ``loaded`` samples; ``along`` in the direction of
    ``travel`` (the body's heading [rad], ``None`` when it stands); ``None`` without heel and
    toe markers or loaded COP samples."""
    h, t = heel_toe(names, side)
    if h is None or t is None:
        return None
    ok = np.all(np.isfinite(cop[:, :2]), axis=1) & loaded
    if ok.sum() < 8:
        return None
    heel = _markers_at(markers, mtime, [h], times[ok])[:, 0, :2]
    toe = _markers_at(markers, mtime, [t], times[ok])[:, 0, :2]
    axis = toe - heel
    norm = np.linalg.norm(axis, axis=1)
    good = np.isfinite(norm) & (norm > 0.05)
    if good.sum() < 8:
        return None
    axis = axis[good] / norm[good, None]
    rel = cop[ok][good, :2] - heel[good]
    along = np.sum(rel * axis, axis=1)
    across = rel[:, 0] * -axis[:, 1] + rel[:, 1] * axis[:, 0]
    q = max(len(along) // 4, 1)
    along_m = float(np.median(along[-q:]) - np.median(along[:q]))
    # walking backward the COP rolls from toe to heel: measured along the direction of travel
    if travel is not None and float(axis.mean(axis=0) @ [np.cos(travel), np.sin(travel)]) < 0:
        along_m = -along_m
    return along_m, float(np.median(across[-q:]) - np.median(across[:q]))


def _two_feet(along: float, side: str, plate, what: str) -> str:
    return (
        f"its centre of pressure travels {along * 100:+.0f} cm along the {side} foot, more than "
        f"a foot is long ({COP_TRAVEL_MAX * 100:.0f} cm): two feet, or several steps, on one "
        f"{what} ({plate.name}); the contact model needs each stance's foot alone on its plate"
    )


def zero_levels(plate) -> tuple[float, ...]:
    """The levels ``plate``'s zeroed vertical force may read: 0, and the small residue its longer
    runs are held at where a lab removed an offset after its zeroing
    (:func:`~gc_ocp.io.processing.held_level`); once per plate."""
    level = held_level(plate.force[:, 2], fz_run_min(mean_rate(plate.time)))
    return (0.0,) if level is None or level == 0.0 else (0.0, level)


def _zeroed_file_edge(fz: np.ndarray, a: int, b: int, thr: float, levels: tuple) -> str:
    """The clipping a lab's zeroing hides (``""``: none). A plate zeroed below X > ``thr`` reads
    exactly 0 from the file's first sample up to a stance's first kept sample (>= X): those zeros
    say "below X", not "below ``thr``", so the force may already have been above ``thr`` at the
    first sample, as the clipping test of the unzeroed plate would have found. The stance is
    clipped when the zeros are fewer than twice the samples the force takes to rise from ``thr``
    to its first kept value at its rate there (a walking force passes 20-50 N in a few ms: a
    stance that starts from a longer zero run began inside the file). Same at the file's end.
    A lab that removed an offset after its zeroing holds its zeros at a small level instead of
    0 (``levels``, :func:`zero_levels`): the edge's run at that level is its zeros just the
    same."""
    n = fz.size

    def zeroed(run: np.ndarray) -> float | None:
        """The zeroing level ``run`` is held at throughout, or None."""
        return next((v for v in levels if np.all(run == v)), None)

    def says(v: float) -> str:
        return "reads 0" if v == 0.0 else f"reads {v:g} N throughout (its zeroing level)"

    def short(zeros: int, edge: float, nxt: float) -> bool:
        rise = abs(nxt - edge)
        return edge > thr and rise > 0 and zeros < 2.0 * (edge - thr) / rise

    if 0 < a and a + 1 < n and (v := zeroed(fz[:a])) is not None and short(a, fz[a], fz[a + 1]):
        return (
            f"clipped: the plate {says(v)} (zeroed by the lab below ~{fz[a]:.0f} N) from the "
            f"first sample of the file to the stance, too briefly to show its onset"
        )
    if 2 <= b < n and (v := zeroed(fz[b:])) is not None and short(n - b, fz[b - 1], fz[b - 2]):
        return (
            f"clipped: the plate {says(v)} (zeroed by the lab below ~{fz[b - 1]:.0f} N) from "
            f"the stance to the last sample of the file, too briefly to show its end"
        )
    return ""


def _exclusion(
    plate, a, b, t_on, t_off, side, cop, feet, names, markers, mtime, bw, thr, notes, travel, levels
):
    n = len(plate.time)
    if a == 0:
        return "clipped: force already above threshold at the first sample of the file"
    if b >= n:
        return "clipped: force still above threshold at the last sample of the file"
    zeroed = _zeroed_file_edge(plate.force[:, 2], a, b, thr, levels)
    if zeroed:
        return zeroed
    if t_on < mtime[0] or t_off > mtime[-1]:
        return "clipped: marker data do not cover the stance"
    times = plate.time[a:b]
    if side in feet and feet[side]:
        m = _markers_at(markers, mtime, feet[side], times)
        if np.all(np.isnan(m).any(axis=2), axis=1).any():
            return "markers: no foot marker of the stance foot during part of the stance"
    heavy = plate.force[a:b, 2] > (0.2 * bw if bw else 100.0)
    path = _cop_path(cop[a:b], heavy, times, side, names, markers, mtime, travel)
    too_far = path is not None and abs(path[0]) > COP_TRAVEL_MAX
    if plate.corners is None:  # a MOT's force set: no outline, no axes of its own to check
        return _two_feet(path[0], side, plate, "force set") if too_far else ""
    c = cop[a:b][heavy]
    c = c[np.all(np.isfinite(c), axis=1)]
    if c.size:
        out = ~_inside(c[:, :2], plate.corners, EDGE_TOL)
        dt = float(np.median(np.diff(plate.time)))
        if out.sum() * dt > COP_OFF_TIME:
            return (
                f"COP outside {plate.name} for {out.sum() * dt * 1e3:.0f} ms while loaded "
                f"(> {EDGE_TOL * 100:.0f} cm beyond its corners; a plate cannot measure a load "
                f"where it has no surface): its corners, origin or channels are wrong in the "
                f"file; fix the force-plate set-up and export again"
            )
        if out.any():
            notes.append(
                f"{side} stance on {plate.name} {t_on:.3f}-{t_off:.3f} s: COP outside the plate "
                f"for {out.sum() * dt * 1e3:.0f} ms (<= {COP_OFF_TIME * 1e3:.0f} ms: a transient, "
                f"ignored)"
            )
    if path is not None:
        along, across = path
        if along < -COP_BACKWARD or (abs(across) > COP_ACROSS and abs(across) > along):
            return (
                f"its centre of pressure moves {along * 100:+.0f} cm along the {side} foot "
                f"(heel to toe, in the direction of travel) and {across * 100:+.0f} cm across "
                f"it; a walking stance rolls from heel to toe: the plate's axes are wrong in the "
                f"file (FORCE_PLATFORM:CORNERS order, ORIGIN, or its moment/COP channels); fix "
                f"the force-plate set-up"
                + (
                    f"; or, as it travels more than a foot is long ({COP_TRAVEL_MAX * 100:.0f} "
                    "cm), two feet or several steps were on the plate"
                    if too_far
                    else ""
                )
            )
        if too_far:
            return _two_feet(along, side, plate, "plate")
    if side in feet and feet[side]:
        m = _markers_at(markers, mtime, feet[side], times)
        low = np.isfinite(m[..., 2]) & (m[..., 2] < plate.surface_height + LOW_MARKER)
        off = np.zeros(m.shape[:2], dtype=bool)
        off[low] = ~_inside(m[low][:, :2], plate.corners, EDGE_TOL)
        if off.any():
            bad = [names[feet[side][k]] for k in np.flatnonzero(off.any(axis=0))]
            return (
                f"foot partly off {plate.name}: the {side} foot marker(s) {bad} touch the floor "
                f"outside its corners (by > {EDGE_TOL * 100:.0f} cm) during the stance, so part "
                f"of the foot's force is not measured"
            )
    other = "left" if side == "right" else "right"
    if other in feet and feet[other]:
        m = _markers_at(markers, mtime, feet[other], times)
        speed = np.linalg.norm(np.gradient(m[..., :2], times, axis=0), axis=2)
        # planted = low and (nearly) still: a swing foot passing low over the plate is not on it
        low = np.isfinite(m[..., 2]) & (m[..., 2] < plate.surface_height + LOW_MARKER)
        low &= speed < PLANTED_SPEED
        on = np.zeros(m.shape[:2], dtype=bool)
        on[low] = _inside(m[low][:, :2], plate.corners, -EDGE_TOL)
        dt = float(np.median(np.diff(plate.time)))
        if on.any(axis=1).sum() * dt > 0.05:
            return (
                f"two feet on {plate.name}: the {other} foot is also on it for "
                f"{on.any(axis=1).sum() * dt:.2f} s while loaded (the plate measures the sum of "
                f"both feet)"
            )
    return ""
