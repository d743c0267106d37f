"""Kinematics pipeline: trial -> filtered markers -> scaled model -> IK -> foot and sole-point kinematics.

Sole points (``PL, PM, AL, AM`` on the hindfoot, ``TT`` on the toes) in their segment frames:

* X (antero-posterior): posterior units at the registered heel marker + ``POSTERIOR_FROM_HEEL``
  foot lengths (centre of the heel pad; the heel marker sits on the posterior surface); anterior
  units at the mean X of the metatarsal markers (roles ``metatarsal_*``; else ``toe``); ``TT`` at
  the toe-tip marker when there is one, else at heel marker + foot length (0.152 H).
* Y (medio-lateral): lateral/medial metatarsal markers give the anterior units directly; with a
  single forefoot marker the anterior units are at +-half the foot width (0.055 H) around it
  when it is on the mid-line (second metatarsal, toe); a lateral (fifth metatarsal) marker
  places the lateral unit and the medial one a foot width medial of it, a medial (first
  metatarsal, as the Davis protocol's) the medial unit and the lateral one a foot width lateral
  of it; posterior units at +-
  ``POSTERIOR_HALF_WIDTH`` foot widths around the heel marker. ``TT`` on the anterior mid-line.
* Z (height): the known floor plane. With a static trial (feet flat on the floor), each unit's
  local Z is chosen so that its mean lab height over the static frames equals the floor height
  (:attr:`~gc_ocp.trial.Trial.floor_height`: mean plate ``surface_height``, 0 without plates).
  Without a static trial the same is done over the foot-flat part of the walking stances,
  ``FOOT_FLAT`` = 20-45 % of each stance of ``trial.stances`` (after heel-strike loading
  response, before heel-off), on the stance's plate surface. A foot without a usable stance
  on a plate uses its excluded stances, else the periods in which it stands still (hindfoot
  slower than ``STILL_SPEED`` relative to the belt) on ``floor_height``.

Foot-marker gaps longer than the load-time spline fill are bridged by rigid-body fill from the
other markers of the same foot (:func:`fill_foot_gaps`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pinocchio as pin

from gc_ocp.errors import InputError
from gc_ocp.foot import FOOT_ROLLS, SEED_LAYOUT, UNITS, FootKinematics, TrialKinematics
from gc_ocp.gaps import fill_rigid_gaps
from gc_ocp.io._common import LabelMatch, match_labels
from gc_ocp.io.orientation import SWAPPED_LEGS, leg_swaps, said_pairs
from gc_ocp.kinematics.filtering import DEFAULT_CUTOFF_HZ, lowpass
from gc_ocp.kinematics.ik import MarkerModel, solve_ik
from gc_ocp.kinematics.marker_error import MarkerError
from gc_ocp.kinematics.scaling import build_marker_model, estimate_height, register_markers
from gc_ocp.marker_noise import foot_pose_noise, noise_band_hz, white_noise
from gc_ocp.model.anthropometry import FOOT_LENGTH_RATIO, FOOT_WIDTH_RATIO
from gc_ocp.model.body import BodyModel
from gc_ocp.model.landmarks import classify
from gc_ocp.model.markerset import MarkerSet, detect_markerset, load_markerset
from gc_ocp.model.recognition import shipped_mapping
from gc_ocp.model.urdf import POSTERIOR_FROM_HEEL, POSTERIOR_HALF_WIDTH
from gc_ocp.trial import Trial
from gc_ocp.values import number, require

FOOT_FLAT = (0.20, 0.45)
"""Fraction of stance used as foot-flat for the sole-height calibration without a static trial."""
N_REGISTRATION_FRAMES = 40
"""Walking frames (evenly spaced) used for marker registration when there is no static trial."""
N_STATIC_FRAMES = 20
STATIC_SEEN_SHARE = 0.5
"""A static trial's marker is registered there when the static shows it on at least this share
of its frames: a standing subject is in view throughout, and a label seen on a few frames is a
ghost or another marker mislabelled (the BTS static's RIMH: one frame of 107, 7 mm from the
lateral malleolus). One below is registered on the walking frames, as a marker the static
lacks; it was registered from those few frames (an empty one: left at its nominal position)
and, on a foot, then held there for the whole trial."""
STATIC_PRIOR_FRAMES = 2.0
"""Prior strength (in walking-frame equivalents, out of ``N_REGISTRATION_FRAMES``) of the
static-trial marker positions when they are refined on the walking trial."""


def _stance_frames(
    trial: Trial, time: np.ndarray, side: str, window, excluded: bool = False
) -> list[tuple[np.ndarray, float]]:
    """Frames of ``window`` (fractions of stance) of each ``side`` stance and the floor height
    under it; ``excluded``: of the excluded stances instead (a stance excluded for its plate
    data still has the foot flat on the floor)."""
    out = []
    for st in trial.excluded_stances if excluded else trial.stances:
        if st.side != side:
            continue
        dur = st.t_off - st.t_on
        a = st.t_on + window[0] * dur
        b = st.t_on + window[1] * dur
        idx = np.flatnonzero((time >= a) & (time <= b))
        if len(idx):
            h = (
                trial.plates[st.plate].surface_height
                if st.plate < len(trial.plates)
                else trial.floor_height
            )
            out.append((idx, h))
    return out


STILL_SPEED = 0.15
"""Hindfoot speed [m/s] (relative to the belt) below which a foot is taken as still on the floor
when it has no stance on a plate: foot-flat moves < 0.05 m/s, swing 1-5 m/s."""


def _still_frames(
    body: BodyModel, q: np.ndarray, time: np.ndarray, side: str, belt, floor: float
) -> list[tuple[np.ndarray, float]]:
    """Foot-flat frames of ``side`` found from the kinematics alone: runs of >= 5 frames in
    which the hindfoot origin moves slower than :data:`STILL_SPEED` relative to the belt, each
    cut to its ``FOOT_FLAT`` fraction; the floor under them is ``floor`` [m]."""
    data = body.create_data()
    fid = body.foot_frames(side)["hindfoot"]
    pos = np.empty((len(q), 3))
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(body.model, data, qk)
        pos[k] = data.oMf[fid].translation
    v = np.gradient(pos, time, axis=0) - np.asarray(belt, dtype=float)
    still = np.linalg.norm(v, axis=1) < STILL_SPEED
    d = np.diff(np.r_[0, still.astype(int), 0])
    out = []
    for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True):
        if b - a >= 5:
            lo = a + int(FOOT_FLAT[0] * (b - a))
            hi = a + max(int(np.ceil(FOOT_FLAT[1] * (b - a))), lo - a + 1)
            out.append((np.arange(lo, hi), floor))
    return out


def sole_points_xy(
    mm: MarkerModel, markerset: MarkerSet, body: BodyModel, side: str, height: float
) -> np.ndarray:
    """Unit positions ``(5, 3)`` in their parent frames with X, Y from the registered foot markers
    (Z left at the model default; see the module docstring)."""
    s = "l" if side == "left" else "r"
    lat = 1.0 if side == "left" else -1.0
    L, W = FOOT_LENGTH_RATIO * height, FOOT_WIDTH_RATIO * height
    loc = {n: p for n, p in zip(mm.names, mm.local, strict=True)}

    def role(r: str) -> np.ndarray | None:
        d = markerset.by_role(side, r)
        return loc.get(d.name) if d is not None else None

    default = body.unit_points_local(side)
    heel = role("heel")
    if heel is None:
        return default
    mtl, mtm = role("metatarsal_lateral"), role("metatarsal_medial")
    fore = [p for p in (mtl, mtm, role("metatarsal_2")) if p is not None] or [
        p for p in (role("toe"),) if p is not None
    ]
    xa = np.mean([p[0] for p in fore]) if fore else default[2, 0]
    if mtl is not None and mtm is not None:
        yal, yam = mtl[1], mtm[1]
    elif mtl is not None:
        yal, yam = mtl[1], mtl[1] - lat * W
    elif mtm is not None:  # the first metatarsal head alone (e.g. a Davis foot): it is medial
        yal, yam = mtm[1] + lat * W, mtm[1]
    elif fore:
        yal, yam = fore[0][1] + lat * W / 2, fore[0][1] - lat * W / 2
    else:
        yal, yam = heel[1] + lat * W / 2, heel[1] - lat * W / 2
    xp = heel[0] + POSTERIOR_FROM_HEEL * L
    yp = POSTERIOR_HALF_WIDTH * W
    tip = role("toe_tip")
    mtp = body.model.frames[body.frame_id(f"toes_{s}")].placement
    hf = body.model.frames[body.frame_id(f"hindfoot_{s}")].placement
    toes_in_hf = hf.inverse() * mtp  # toes frame in the hindfoot frame (fixed MTP)
    tt_hf = np.array([heel[0] + L, 0.5 * (yal + yam), default[0, 2]]) if tip is None else tip.copy()
    if tip is not None and markerset.by_role(side, "toe_tip").segment.startswith("toes"):
        tt_hf = toes_in_hf.act(tip)  # the marker position was in the toes frame
    z = default[0, 2]
    pts = np.array(
        [
            [xp, heel[1] + lat * yp, z],
            [xp, heel[1] - lat * yp, z],
            [xa, yal, z],
            [xa, yam, z],
            toes_in_hf.actInv(tt_hf),
        ]
    )
    return pts


def calibrate_sole_height(
    body: BodyModel,
    side: str,
    q: np.ndarray,
    points: np.ndarray,
    floors: np.ndarray,
    poses: dict[str, np.ndarray] | None = None,
) -> np.ndarray:
    """Set each unit's local Z so that its mean lab height over poses ``q`` ``(n, nq)`` equals
    ``floors`` ``(n,)`` [m] (feet flat on the floor). ``poses``: the foot segments' placements
    ``{"hindfoot", "toes": (n, 4, 4)}`` at ``q`` when they are not the model's (a levelled
    roll, :func:`level_roll`). Returns the new ``(5, 3)`` points."""
    poses = poses or foot_poses(body, q, side)
    pts = points.copy()
    for i, u in enumerate(UNITS):
        M = poses[SEED_LAYOUT.parent(u)]
        R, p = M[:, :3, :3], M[:, :3, 3]
        # lab z = p_z + R[2,0] x + R[2,1] y + R[2,2] z = floor  ->  z
        z = (floors - p[:, 2] - R[:, 2, 0] * pts[i, 0] - R[:, 2, 1] * pts[i, 1]) / R[:, 2, 2]
        pts[i, 2] = float(np.mean(z))
    return pts


def foot_poses(body: BodyModel, q: np.ndarray, side: str) -> dict[str, np.ndarray]:
    """``{"hindfoot", "toes": (n, 4, 4)}``: the foot segments' placements in ``lab`` over ``q``."""
    data = body.create_data()
    ids = body.foot_frames(side)
    out = {k: np.empty((len(q), 4, 4)) for k in ids}
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(body.model, data, qk)
        for name, f in ids.items():
            out[name][k] = data.oMf[f].homogeneous
    return out


def level_roll(poses: dict[str, np.ndarray], a: np.ndarray, b: np.ndarray) -> dict[str, np.ndarray]:
    """The foot's placements rotated, frame by frame, about the line through its two landmarks
    ``a``, ``b`` ``(n, 3)`` [m, ``lab``] by the smallest angle that makes the hindfoot's
    medio-lateral axis (local Y) horizontal: a foot with two landmarks (a Davis foot: heel and
    one metatarsal head) does not show its roll about the line through them, and the body
    chain that poses it otherwise (shank markers, knee and ankle joints) carries the shank's
    axial rotation into it (12.5-16.5 deg off a full-marker foot over a stance on the BTS
    subject, ``benchmarks/davis_foot_output.md``). Level across is the
    foot's posture where it matters, on the ground (as Plug-in Gait's "foot flat" option
    assumes at the static trial); the landmarks stay where they are. Where no angle levels it
    (the line near vertical, in swing) the nearest is taken."""
    H = poses["hindfoot"]
    u = b - a
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = H[:, :3, 1]  # the hindfoot's Y axis in lab
    c = u[:, 2] * np.einsum("ti,ti->t", u, v)  # Rodrigues: z of Rot(u, phi) v
    A, B = v[:, 2] - c, np.cross(u, v)[:, 2]  # = A cos(phi) + B sin(phi) + c
    r = np.hypot(A, B)
    base = np.arctan2(B, A)
    ratio = np.clip(-c / np.maximum(r, 1e-12), -1.0, 1.0)
    cands = np.stack([base + np.arccos(ratio), base - np.arccos(ratio)])
    cands = (cands + np.pi) % (2 * np.pi) - np.pi
    phi = cands[np.argmin(np.abs(cands), axis=0), np.arange(len(u))]
    K = np.zeros((len(u), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -u[:, 2], u[:, 1], -u[:, 0]
    K -= K.transpose(0, 2, 1)
    s, co = np.sin(phi)[:, None, None], np.cos(phi)[:, None, None]
    Rot = np.eye(3) + s * K + (1 - co) * (K @ K)
    out = {}
    for name, M in poses.items():
        N = M.copy()
        N[:, :3, :3] = Rot @ M[:, :3, :3]
        N[:, :3, 3] = a + np.einsum("tij,tj->ti", Rot, M[:, :3, 3] - a)
        out[name] = N
    return out


def gradient_runs(x: np.ndarray, time: np.ndarray) -> np.ndarray:
    """``np.gradient(x, time, axis=0)`` over each run of frames whose values are all finite (a
    frame without a pose, NaN, breaks the run: one-sided differences at a run's ends, none
    across it); NaN on the NaN frames and on runs of a single frame."""
    x = np.asarray(x, float)
    ok = np.isfinite(x.reshape(len(x), -1)).all(axis=1)
    out = np.full_like(x, np.nan)
    d = np.diff(np.r_[0, ok.astype(int), 0])
    for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True):
        if b - a >= 2:
            out[a:b] = np.gradient(x[a:b], time[a:b], axis=0)
    return out


def _twists(poses: np.ndarray, time: np.ndarray) -> np.ndarray:
    """``(n, 6)`` twists (``LOCAL_WORLD_ALIGNED``: origin velocity, angular velocity, both in
    ``lab``) of the placements ``poses`` ``(n, 4, 4)`` by central differences in ``time``."""
    dp = gradient_runs(poses[:, :3, 3], time)
    dR = gradient_runs(poses[:, :3, :3], time)
    W = dR @ poses[:, :3, :3].transpose(0, 2, 1)  # skew(omega)
    w = 0.5 * np.stack(
        [W[:, 2, 1] - W[:, 1, 2], W[:, 0, 2] - W[:, 2, 0], W[:, 1, 0] - W[:, 0, 1]], 1
    )
    return np.concatenate([dp, w], axis=1)


def foot_kinematics(
    body: BodyModel,
    q: np.ndarray,
    time: np.ndarray,
    side: str,
    points_local: np.ndarray,
    poses: dict[str, np.ndarray] | None = None,
) -> FootKinematics:
    """Hindfoot/toes placements and twists (``LOCAL_WORLD_ALIGNED``) over ``q`` ``(n, nq)``.

    q-dot is ``np.gradient(q, time)`` (q comes from low-pass filtered markers, so it is smooth)
    over each run of frames with a pose (:func:`gradient_runs`; NaN ``q``: a frame without
    markers, whose feet are NaN).
    ``poses``: the segments' placements when they are not the model's at ``q`` (a levelled
    roll, :func:`level_roll`); their twists are then their central differences.
    """
    if poses is not None:
        H, Tp = poses["hindfoot"], poses["toes"]
        return FootKinematics(side, time, H, Tp, _twists(H, time), _twists(Tp, time), points_local)
    v = gradient_runs(q, time)
    data = body.create_data()
    ids = body.foot_frames(side)
    n = len(time)
    poses = {k: np.empty((n, 4, 4)) for k in ids}
    twists = {k: np.empty((n, 6)) for k in ids}
    for k in range(n):
        pin.forwardKinematics(body.model, data, q[k], v[k])
        pin.updateFramePlacements(body.model, data)
        for name, f in ids.items():
            poses[name][k] = data.oMf[f].homogeneous
            tw = pin.getFrameVelocity(body.model, data, f, pin.LOCAL_WORLD_ALIGNED)
            twists[name][k] = np.r_[tw.linear, tw.angular]
    return FootKinematics(
        side,
        time,
        poses["hindfoot"],
        poses["toes"],
        twists["hindfoot"],
        twists["toes"],
        points_local,
    )


def _two_landmarks(markerset: MarkerSet, names, side: str) -> tuple[str, str] | None:
    """The names of ``side``'s foot markers when the foot has exactly two (Helen Hayes, Davis:
    its roll about them is unobserved, :func:`level_roll`), else None."""
    foot = _foot_marker_names(markerset, names, side)
    return (foot[0], foot[1]) if len(foot) == 2 else None


def _foot_marker_names(markerset: MarkerSet, names, side: str) -> list[str]:
    """``side``'s foot markers among ``names``, in their order."""
    foot = {m.name for m in markerset.foot_markers(side)}
    return [n for n in names if n in foot]


def _levelled(body, mm: MarkerModel, q: np.ndarray, side: str, pair) -> dict[str, np.ndarray]:
    """The foot's placements over ``q`` with its roll about the landmarks ``pair`` levelled
    (:func:`level_roll`), the landmarks where the marker model puts them."""
    i, j = mm.names.index(pair[0]), mm.names.index(pair[1])
    pos = mm.positions(q)[:, [i, j]]
    return level_roll(foot_poses(body, q, side), pos[:, 0], pos[:, 1])


SEEN_SHARE = 0.5
"""A foot marker fixes the foot's pose in :func:`_foot_noise` when the trial shows it (before
any gap fill) on at least this share of the frames of the foot's stances: a marker missing
from most of them (the BTS trials' metatarsal markers in every right stance) does not pose the
foot where it is fitted, and a marker filled from the others adds nothing to their rigid fit."""


def _foot_noise(mm, markerset, names, white, q, foot, side, rate, cutoff_hz, seen=None):
    """The :class:`~gc_ocp.foot.PoseNoise` of ``side``'s foot: its markers' median white noise,
    their positions in the hindfoot frame (from the model at the trial's middle frame: the foot's
    segments are welded), the pipeline's low-pass. None when fewer than three foot markers fix
    it (the foot is then posed through the shank and ankle; its noise is not modelled yet).
    seen: ``(n_frames, len(names))``, whether each marker is seen on the frames where the foot
    is fitted (its stances; the whole trial when it has none); the markers seen on fewer than
    :data:`SEEN_SHARE` of them do not fix it (None: every marker counts)."""
    idx = [names.index(n) for n in _foot_marker_names(markerset, names, side)]
    if seen is not None and len(seen):
        idx = [i for i in idx if np.mean(seen[:, i]) >= SEEN_SHARE]
    if len(idx) < 3:
        return None
    sig = white[idx][np.isfinite(white[idx])]
    if not sig.size:
        return None
    posed = np.flatnonzero(np.isfinite(q).all(axis=1))
    if not posed.size:
        return None
    k = posed[np.argmin(np.abs(posed - len(q) // 2))]  # the middle frame with a pose
    x = mm.positions(q[k])[idx]
    H = foot.hindfoot_pose[k]
    local = (x - H[:3, 3]) @ H[:3, :3]
    return foot_pose_noise(local, float(np.median(sig)), rate, cutoff_hz, order=4)


def fill_foot_gaps(
    markers: np.ndarray, names, markerset: MarkerSet, time: np.ndarray
) -> tuple[np.ndarray, list[str]]:
    """Bridge the gaps of each foot's markers by rigid-body fill from the other markers of the
    same foot (hindfoot and toes: one rigid body in the model, the MTP joint is fixed), see
    :func:`gc_ocp.gaps.fill_rigid_gaps`. markers: ``(n, m, 3)`` [m] in ``names`` order.
    Frames with fewer than 3 non-collinear other foot markers stay missing: the IK then poses
    the foot from what is visible and the shank (2-DOF ankle). Returns the filled copy and one
    note per filled gap."""
    out = np.array(markers, dtype=float, copy=True)
    notes: list[str] = []
    for side in ("left", "right"):
        group = [names.index(n) for n in _foot_marker_names(markerset, names, side)]
        if len(group) < 4:
            continue
        out, done = fill_rigid_gaps(out, [group])
        for j, a, b, donors in done:
            notes.append(
                f"{side} foot marker {names[j]} {time[a]:.3f}-{time[b - 1]:.3f} s "
                f"({b - a} frames) from {[names[d] for d in donors]}"
            )
    return out, notes


def landmark_mapping(markerset: MarkerSet, trial: Trial) -> dict:
    """The label -> landmark -> segment mapping used for ``trial`` (plain data, see
    :meth:`gc_ocp.model.recognition.Recognition.to_json`)."""
    if markerset.recognition is not None:
        return markerset.recognition
    return shipped_mapping(markerset, trial.marker_names, trial.markers, trial.source)


STATIC_FOOT_TOLERANCE = (0.15, 0.010)
"""A static trial's foot-marker distances agree with the walking trial's within 15 % and 10 mm
(either suffices), taken as the median over every pair of one foot's markers: a foot is rigid
enough over its markers that skin sliding moves a distance by a few millimetres, and a marker
mislabelled in one file moves only its own pairs (the BTS files: RIIT 170 mm from RIMH in the
static trial, 50 mm in the walking ones). Beyond both, the static trial is another subject's,
or the markers were placed again between the two."""


def check_static_feet(static: Trial, walking: Trial, markerset: MarkerSet) -> None:
    """Refuse a static trial whose feet are not the walking trial's: the distances between two
    foot markers of one side, median over frames, compared pair by pair; the median pair must
    agree (:data:`STATIC_FOOT_TOLERANCE`). A static trial of another (1.3 times larger) subject
    was used, the fit's height 2.34 m where the walking trial's is 1.80 m and every contact
    parameter off."""
    rel, absolute = STATIC_FOOT_TOLERANCE
    pairs = []
    for side in ("left", "right"):
        names = [
            m.name
            for m in markerset.foot_markers(side)
            if m.name in static.marker_names and m.name in walking.marker_names
        ]
        for i, a in enumerate(names):
            for b in names[i + 1 :]:
                dist = [
                    np.linalg.norm(t.marker(a) - t.marker(b), axis=1) for t in (static, walking)
                ]
                d = [
                    float(np.median(x[np.isfinite(x)])) if np.isfinite(x).any() else np.nan
                    for x in dist
                ]
                if all(np.isfinite(d)) and min(d) > 0:
                    pairs.append((abs(d[0] - d[1]) / d[1], a, b, d))
    if not pairs:
        return
    pairs.sort(key=lambda p: p[0])
    off, a, b, (ds, dw) = pairs[len(pairs) // 2]  # the median pair
    if off > rel and abs(ds - dw) > absolute:
        raise InputError(
            f"Static trial {static.source}: its foot markers are {off:.0%} off their distances "
            f"in the walking trial {walking.source} (median over {len(pairs)} pairs; e.g. {a} "
            f"and {b}: {ds * 1e3:.0f} mm against {dw * 1e3:.0f} mm; a foot is rigid to a few mm "
            "there): the static trial is of another subject, or the markers were placed again. "
            "Give this session's static trial, or none (static=None; on the command line: leave "
            "out --static)."
        )


def check_static_sides(static: Trial) -> None:
    """Refuse a static trial whose left and right leg markers are swapped (by the labels, or by
    mirrored axes), as :func:`gc_ocp.io.load.load_trial` refuses a walking trial: a left landmark
    to the subject's right of its right counterpart (:func:`gc_ocp.io.orientation.mirrored_pairs`),
    on a thigh or shank, or on a foot beyond :data:`~gc_ocp.io.orientation.FOOT_CROSSOVER`. The
    registration then put each leg's markers on the other leg: the Rajagopal static swapped gave
    a walking marker RMS of 42 mm (7 mm unswapped) and sole points 0.2 m under the foot."""
    legs, _ = leg_swaps(static.marker_names, np.asarray(static.markers), static.marker_time)
    if legs:
        said = SWAPPED_LEGS.format(said=said_pairs(legs))
        raise InputError(
            f"In the static trial {static.source} {said}. Fix the labels, or give no static "
            "trial (static=None; on the command line: leave out --static)."
        )


def _static_as_walking(
    static: Trial, trial: Trial, markerset: MarkerSet
) -> tuple[Trial, LabelMatch | None]:
    """The static trial with its labels renamed to the marker set's names where it spells them
    otherwise (:func:`gc_ocp.io._common.match_labels`: a subject prefix, case and separators,
    the same landmark on the same side), and the matching (``None`` when every name is among
    its labels: the static is then used as given). The names are the walking trial's markers
    and those of the set it lacks (a shipped set's medial markers, which a static may carry);
    not the second column of a duplicated label (``RANK#2``), which is no label."""
    used = [
        n
        for n in markerset.markers
        if n in trial.marker_names or n.rpartition("#")[0] not in trial.marker_names
    ]
    if all(n in static.marker_names for n in used):
        return static, None
    labels = match_labels(used, static.marker_names, static.source)
    if not labels.renamed:
        return static, labels
    renamed = tuple(labels.renamed.get(x, x) for x in static.marker_names)
    return replace(static, marker_names=renamed), labels


def _unmatched_said(labels: LabelMatch | None) -> str:
    """Why none of the static's other labels stands for the foot markers it lacks (for the
    refusal): the rule, its labels matched to none (computed points left out) and the
    ambiguities."""
    if labels is None:
        return ""
    spare = [x for x in labels.spare if classify(x)[0] != "virtual"]
    out = (
        ": a static label stands for a walking marker when it is spelt the same up to case, "
        "separators and a subject prefix, or is the same landmark on the same side, and no "
        f"other label does (static labels matched to none: {', '.join(spare) or 'none'}"
    )
    if labels.conflicts:
        out += f"; ambiguous, so left unmatched: {'; '.join(labels.conflicts)}"
    return out + ")"


def compute_kinematics(
    trial: Trial,
    model: BodyModel | None = None,
    markerset: MarkerSet | str | None = None,
    static: Trial | None = None,
    cutoff_hz: float = DEFAULT_CUTOFF_HZ,
    progress: Callable[[str], None] | None = None,
    foot_roll: str = "chain",
) -> TrialKinematics:
    """Full kinematics pipeline for one walking trial.

    trial: the walking trial; model: body model (default: de Leva model of the trial's height and
    mass, the height estimated from the pelvis markers when unknown); markerset: a
    :class:`MarkerSet`, a shipped name or a TOML path (default: a shipped set matching the
    labels exactly, else one built from the recognised anatomical landmarks, see
    :func:`gc_ocp.model.markerset.detect_markerset`; the mapping is in ``info["landmarks"]``);
    static: a static standing trial for registration and sole height (optional; labels
    spelt otherwise than the walking trial's are matched to its markers by
    :func:`gc_ocp.io._common.match_labels`, the renaming in ``info["static_labels"]``);
    cutoff_hz: marker low-pass cutoff [Hz]; progress: called with status strings;
    foot_roll: how a foot with two landmarks (heel and one forefoot marker: Helen Hayes, Davis)
    is rolled about the line through them, which its markers do not show: ``"chain"``
    (default) as the body chain poses it (shank markers, knee, 2-DOF ankle), ``"level"``
    with its medio-lateral axis horizontal on every frame (:func:`level_roll`);
    ``docs/quality.md``, "A Davis-like foot", for what each gives (and a third way tried and
    not kept). Feet with three or more landmarks are posed by their markers either way.

    Returns a :class:`~gc_ocp.foot.TrialKinematics`: joint coordinates ``q`` ``(n, 27)``
    [m, rad] on the marker frames ``time`` [s], each foot's segment poses and sole-point
    trajectories in ``lab`` [m] (``feet["left"]``, ``feet["right"]``) and the IK marker RMS
    [m]; what ``gc_ocp.fit`` and ``gc_ocp.diagnose`` take with the trial.

    >>> import gc_ocp
    >>> trial = gc_ocp.load_trial()           # the bundled example, or load_trial("walk.c3d")
    >>> kin = gc_ocp.compute_kinematics(trial)  # or static=gc_ocp.load_static(path, trial)
    >>> kin                                   # doctest: +ELLIPSIS
    TrialKinematics('test_small', 337 frames 0.000-3.360 s, 27 coordinates, feet ['left', 'right'], ...)
    >>> kin.q.shape, kin.feet["right"].positions.shape  # (frames, coordinates), (frames, units, xyz)
    ((337, 27), (337, 5, 3))

    Then ``gc_ocp.fit([(trial, kin)])`` (:func:`gc_ocp.workflow.fit` shows it run).
    """
    if foot_roll not in FOOT_ROLLS:
        raise InputError(f'foot_roll must be one of {FOOT_ROLLS}, but got "{foot_roll}"')
    require(
        trial,
        Trial,
        "compute_kinematics takes one loaded trial",
        "trial = gc_ocp.load_trial(path); kin = gc_ocp.compute_kinematics(trial) (one "
        "call per trial of a subject).",
    )
    if model is not None:
        require(
            model,
            BodyModel,
            "model takes a body model",
            "leave it out (the de Leva model of the trial's height and mass) or give "
            "gc_ocp.model.BodyModel.from_subject(height_m, mass_kg).",
        )
    cutoff_hz = number(cutoff_hz, "cutoff_hz", "Hz")
    if static is not None:
        if not isinstance(static, Trial):
            raise InputError(
                f"static takes a loaded static trial, not {type(static).__name__} {static!r:.60}: "
                "static = gc_ocp.load_static(path, trial); compute_kinematics(trial, static=static)"
            )
        from gc_ocp.io.load import check_static

        check_static(static.source, static.marker_names, static.markers)  # as load_static
    say = progress or (lambda s: None)
    if markerset is None:
        markerset = detect_markerset(trial.marker_names, trial.markers, trial.source)
    elif not isinstance(markerset, MarkerSet):
        markerset = load_markerset(markerset)
    names, idx = markerset.select_columns(trial.marker_names, trial.source, trial.markers)
    raw = np.asarray(trial.markers)[:, idx]
    raw, fills = fill_foot_gaps(raw, names, markerset, trial.marker_time)
    for f in fills:
        say(f"rigid-body fill: {f}")
    markers = lowpass(raw, trial.marker_rate, cutoff_hz, time=trial.marker_time)
    floor = trial.floor_height

    st_markers = None
    relabelled: dict[str, str] = {}  # static label -> walking marker name
    if static is not None:
        static, labels = _static_as_walking(static, trial, markerset)
        if labels is not None and labels.renamed:
            relabelled = labels.renamed
            say(f"static trial: labels matched to the walking trial's: {labels.said()}")
        shown = np.isfinite(np.asarray(static.markers)).all(axis=2).mean(axis=0)
        share = {n: shown[static.marker_names.index(n)] for n in static.marker_names}
        unseen = {n for n in markerset.markers if share.get(n, 1.0) < STATIC_SEEN_SHARE}
        for n in sorted(unseen):
            say(
                f"static trial: {n} seen on {share[n]:.0%} of its frames: registered on the "
                "walking trial instead"
            )
        st_names = [n for n in names if n in static.marker_names and n not in unseen]
        missing = [
            m.name
            for s in ("left", "right")
            for m in markerset.foot_markers(s)
            if m.name not in static.marker_names and m.name in trial.marker_names
        ]  # (a second column of a duplicated label, "RANK#2", has no name in the static)
        if missing:
            raise InputError(
                f"Static trial {static.source} lacks foot markers {missing}"
                f"{_unmatched_said(labels)}; rename its labels as the walking trial's, or "
                "calibrate on the walking trial instead (static=None; on the command line: "
                "leave out --static)."
            )
        check_static_sides(static)
        check_static_feet(static, trial, markerset)
        sidx = [static.marker_names.index(n) for n in st_names]
        k = np.linspace(
            0, len(static.marker_time) - 1, min(N_STATIC_FRAMES, len(static.marker_time))
        )
        st_markers = np.asarray(static.markers)[k.astype(int)][:, sidx]
        static_all = [n for n in markerset.markers if n in static.marker_names and n not in unseen]
    height = trial.height if model is None or model.height is None else model.height
    if height is None:
        if st_markers is not None:
            height = estimate_height(
                st_markers,
                st_names,
                markerset,
                static.floor_height if static.plates else floor,
                True,
            )
        else:
            height = estimate_height(markers, names, markerset, floor, False)
        say(f"estimated height {height:.3f} m")
    body = model or BodyModel.from_subject(height, trial.mass)

    # ---- registration
    if st_markers is not None:
        sidx_all = [static.marker_names.index(n) for n in static_all]
        reg_m = np.asarray(static.markers)[
            np.linspace(0, len(static.marker_time) - 1, st_markers.shape[0]).astype(int)
        ][:, sidx_all]
        reg_names = static_all
    else:
        k = np.linspace(0, len(markers) - 1, min(N_REGISTRATION_FRAMES, len(markers))).astype(int)
        reg_m, reg_names = markers[k], names
    mm_reg = build_marker_model(body, markerset, reg_names, height)
    cluster = np.array([markerset.markers[n].cluster for n in reg_names])
    mm_reg, reg_res, history = register_markers(mm_reg, reg_m, cluster, progress=say)
    # marker model of the walking markers with the registered positions
    loc = dict(zip(mm_reg.names, mm_reg.local, strict=True))
    mm = build_marker_model(body, markerset, names, height)
    mm = mm.with_local(np.array([loc.get(n, p) for n, p in zip(names, mm.local, strict=True)]))
    if st_markers is not None:
        # Refine on walking frames: the static pose cannot place markers whose segment moves
        # differently in walking (arms: no humeral rotation in the model; skin over muscles).
        # Foot markers stay where the static put them (the sole calibration uses them);
        # others are pulled towards their static positions by STATIC_PRIOR_FRAMES; markers
        # the static lacks (or hardly shows, STATIC_SEEN_SHARE) are registered here.
        k = np.linspace(0, len(markers) - 1, min(N_REGISTRATION_FRAMES, len(markers))).astype(int)
        foot = np.array([markerset.markers[n].is_foot for n in names])
        in_static = np.array([n in loc for n in names])
        prior = np.where(foot & in_static, 1e9, np.where(in_static, STATIC_PRIOR_FRAMES, 0.0))
        mm, _, h2 = register_markers(
            mm,
            markers[k],
            ~in_static,
            n_iter=2,
            prior_frames=prior,
            anatomical_first=False,
            progress=say,
        )
        history += h2

    # ---- IK
    say(f"IK on {len(markers)} frames")
    res = solve_ik(mm, markers, progress=(lambda i, n: say(f"IK frame {i}/{n}")))
    q, t = res.q, np.asarray(trial.marker_time)

    # ---- sole points
    feet = {}
    sole_info = {}
    rolls = {}  # per foot: posed by its markers, or two landmarks' roll (chain or level)
    for side in ("left", "right"):
        pts = sole_points_xy(mm, markerset, body, side, height)
        if static is not None:
            qs = reg_res.q
            floors = np.full(len(qs), static.floor_height if static.plates else floor)
            src = "static"
        else:
            frames = _stance_frames(trial, t, side, FOOT_FLAT)
            src = f"walking foot-flat {FOOT_FLAT[0]:.0%}-{FOOT_FLAT[1]:.0%} of stance"
            if not frames:
                frames = _stance_frames(trial, t, side, FOOT_FLAT, excluded=True)
                src += " (excluded stances: their plate data are unusable, the foot is still flat)"
            if not frames:
                frames = _still_frames(body, q, t, side, trial.belt_velocity, floor)
                src = (
                    f"walking foot-flat {FOOT_FLAT[0]:.0%}-{FOOT_FLAT[1]:.0%} of the periods the "
                    f"foot is still (hindfoot slower than {STILL_SPEED} m/s; no {side} stance on "
                    "a plate)"
                )
            if not frames:
                raise InputError(
                    f"No {side} stance in {trial.source} to calibrate the sole height; "
                    "give a static trial or stances."
                )
            qs = np.concatenate([q[i] for i, _ in frames])
            floors = np.concatenate([np.full(len(i), h) for i, h in frames])
        posed = np.isfinite(qs).all(axis=1)  # frames without any marker have no pose
        if not posed.any():
            raise InputError(
                f"No {side} foot-flat frame with markers in {static.source if static is not None else trial.source} "
                "to calibrate the sole height (the markers are missing there); give a static "
                "trial or a trial whose markers cover the stances."
            )
        qs, floors = qs[posed], floors[posed]
        lm = _two_landmarks(markerset, names, side) if foot_roll == "level" else None
        n_foot = len(_foot_marker_names(markerset, names, side))
        rolls[side] = "level" if lm else "markers" if n_foot >= 3 else "chain"
        pts = calibrate_sole_height(
            body, side, qs, pts, floors, _levelled(body, mm, qs, side, lm) if lm else None
        )
        sole_info[side] = src
        lev = _levelled(body, mm, q, side, lm) if lm else None
        feet[side] = foot_kinematics(body, q, t, side, pts, lev)
        if lm:
            say(f"{side} foot: two landmarks ({lm[0]}, {lm[1]}); its roll about them levelled")
    # ---- the markers' error, measured (white noise per marker; what it leaves in each foot)
    # before any gap fill: the loader's interpolated samples (trial.marker_filled) are no
    # camera's, and their smooth stretches would lower the noise's MAD
    seen_xyz = np.array(trial.markers, float)[:, idx]
    if trial.marker_filled is not None:
        seen_xyz[trial.marker_filled[:, idx]] = np.nan
    white = white_noise(seen_xyz, trial.marker_rate)
    merr = MarkerError(
        {n: float(v) * 1e3 for n, v in zip(names, white, strict=True)},
        {n: markerset.markers[n].segment for n in names},
        noise_band_hz(trial.marker_rate),
    )
    for f in merr.outliers():
        say(f)
    seen = np.isfinite(seen_xyz).all(axis=2)
    for side in ("left", "right"):
        frames = [i for i, _ in _stance_frames(trial, t, side, (0.0, 1.0))]
        feet[side] = replace(
            feet[side],
            pose_noise=_foot_noise(
                mm,
                markerset,
                names,
                white,
                q,
                feet[side],
                side,
                trial.marker_rate,
                cutoff_hz,
                seen[np.concatenate(frames)] if frames else seen,
            ),
        )
    info = {
        "height": height,
        "mass": trial.mass,
        "markerset": markerset.name,
        "landmarks": landmark_mapping(markerset, trial),
        "rigid_fills": fills,
        "static_labels": relabelled,
        "registration_rms_history": history,
        "ik_seconds": res.seconds,
        "sole_height_source": sole_info,
        "foot_roll": rolls,
        "marker_local": dict(zip(mm.names, mm.local, strict=True)),
        "body": body,
        "marker_model": mm,
        "residuals": res.residuals,
        "marker_error": merr.to_json(),
        "foot_pose_noise": {
            side: None
            if feet[side].pose_noise is None
            else {
                "sigma_marker_mm": feet[side].pose_noise.sigma_marker * 1e3,
                "translation_mm": (np.sqrt(np.diag(feet[side].pose_noise.cov)[:3]) * 1e3).tolist(),
                "rotation_deg": np.rad2deg(
                    np.sqrt(np.diag(feet[side].pose_noise.cov)[3:])
                ).tolist(),
            }
            for side in feet
        },
    }
    return TrialKinematics(trial.name, t, q, res.marker_rms, feet, cutoff_hz, tuple(names), info)
