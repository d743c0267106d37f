"""Subject scaling: anthropometric model from height and mass, then marker registration.

1. Height: ``trial.height`` when known; otherwise estimated from the pelvis markers (see
   :func:`estimate_height`). The body model is the de Leva model of that height and the trial mass.
2. Marker registration (as OpenSim's marker placer, iterated): IK on a subset of frames (the static
   trial when given, else evenly spaced walking frames), then each marker's position in its segment
   frame is re-estimated as the mean of its local coordinates over those frames, pulled towards the
   nominal (marker-set) position by a weak prior of ``prior_frames`` frame-equivalents (none for
   ``cluster`` markers, whose nominal positions are guesses). The first IK pass uses the anatomical
   markers only (clusters weigh 0). A few alternations suffice (the marker RMS stops decreasing).
Segment lengths are not rescaled individually (not implemented); the registration absorbs
part of the length mismatch.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from gc_ocp.errors import MarkerError
from gc_ocp.kinematics.ik import IKResult, MarkerModel, solve_ik
from gc_ocp.model.anthropometry import ANKLE_HEIGHT_RATIO, anthropometry
from gc_ocp.model.body import BodyModel
from gc_ocp.model.markerset import MarkerSet


def hip_height_ratio() -> float:
    """Hip joint centre height / body height in the neutral standing pose of the model."""
    a = anthropometry(1.0, 70.0)
    return a.thigh_length + a.shank_length + ANKLE_HEIGHT_RATIO


def estimate_height(
    markers: np.ndarray, names, markerset: MarkerSet, floor: float = 0.0, standing: bool = False
) -> float:
    """Subject height [m] from the pelvis markers' height above the floor.

    Standing (static trial): median height of each pelvis marker; walking: its 95th percentile
    (the pelvis is highest in mid-stance, knee nearly straight). Each marker gives
    ``H = z / (hip_height_ratio + z_nominal / reference_height)``; we take the median. Expect a few
    per cent error: pass the measured height whenever it is known.
    """
    hh = hip_height_ratio()
    est = []
    for i, n in enumerate(names):
        m = markerset.markers.get(n)
        if m is None or m.segment != "pelvis":
            continue
        z = markers[:, i, 2] - floor
        z = z[~np.isnan(z)]
        if len(z) == 0:
            continue
        zm = np.median(z) if standing else np.percentile(z, 95)
        est.append(zm / (hh + m.position[2] / markerset.reference_height))
    if not est:
        raise MarkerError(
            f'No pelvis marker of marker set "{markerset.name}" in the trial: cannot '
            "estimate the subject height; give the height (Trial.height)."
        )
    return float(np.median(est))


def build_marker_model(body: BodyModel, markerset: MarkerSet, names, height: float) -> MarkerModel:
    """Marker model with the nominal positions of ``names`` scaled to ``height`` [m]."""
    pos = markerset.positions(height)
    defs = [markerset.markers[n] for n in names]
    return MarkerModel.build(
        body,
        list(names),
        [d.segment for d in defs],
        [pos[n] for n in names],
        [d.weight for d in defs],
    )


def local_coordinates(mm: MarkerModel, q: np.ndarray, markers: np.ndarray) -> np.ndarray:
    """Each marker's position in its segment frame ``(n, m, 3)`` for poses ``q`` ``(n, nq)``."""
    data = mm.model.createData()
    seg_ids = [mm.body.frame_id(s) for s in mm.segments]
    out = np.empty(markers.shape)
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(mm.model, data, qk)
        for i, f in enumerate(seg_ids):
            M = data.oMf[f]
            out[k, i] = M.rotation.T @ (markers[k, i] - M.translation)
    return out


def register_markers(
    mm: MarkerModel,
    markers: np.ndarray,
    cluster: np.ndarray,
    n_iter: int = 4,
    prior_frames: float | np.ndarray = 3.0,
    anatomical_first: bool = True,
    progress: Callable[[str], None] | None = None,
) -> tuple[MarkerModel, IKResult, list[float]]:
    """Alternate IK and marker re-estimation on ``markers`` ``(n, m, 3)`` (a few frames).

    cluster: ``(m,)`` bool, tracking markers (no prior, weight 0 in the first IK pass if
    ``anatomical_first``); prior_frames: scalar or ``(m,)`` prior strength towards ``mm.local``.
    Returns the registered marker model, the last IK result and the median RMS [m] of each pass.
    """
    nominal = mm.local.copy()
    prior = np.where(cluster, 0.0, prior_frames)
    cur = mm.with_weights(np.where(cluster, 0.0, mm.weights)) if anatomical_first else mm
    history = []
    q_guess = None
    res = None
    for it in range(n_iter + 1):
        res = solve_ik(cur, markers, max_iter=60, q_guess=q_guess)
        history.append(float(np.nanmedian(res.marker_rms)))  # (NaN: a frame without markers)
        if progress:
            progress(f"registration pass {it}: median marker RMS {1e3 * history[-1]:.1f} mm")
        if it == n_iter:
            break
        loc = local_coordinates(cur, res.q, markers)
        cnt = (~np.isnan(loc).any(2)).sum(0)
        s = np.nansum(loc, axis=0)
        new = (s + prior[:, None] * nominal) / (cnt + prior)[:, None]
        new = np.where((cnt + prior)[:, None] > 0, new, nominal)
        cur = mm.with_local(new)  # full weights from the second pass on
        q_guess = res.q
    return cur, res, history
