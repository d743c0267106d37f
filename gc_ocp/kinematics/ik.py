"""Marker-based inverse kinematics on the Pinocchio gait model.

Markers are added to a copy of the body model as Pinocchio ``OP_FRAME`` s attached to their segment.
Each frame is solved by a damped Gauss-Newton / Levenberg-Marquardt iteration on the stacked
marker Jacobians (``pin.computeJointJacobians`` + ``pin.getFrameJacobian(..., LOCAL_WORLD_ALIGNED)``),

    minimise  sum_i w_i || p_i(q) - m_i ||^2   subject to  q_lower <= q <= q_upper,

with the step ``(J^T W J + lambda D) dq = J^T W r``, ``D = diag(J^T W J) + eps`` (Marquardt scaling),
``lambda`` adapted on success/failure, and the joint limits enforced by projection (clipping) after
each step. Frames are warm-started from the previous solution; the first frame starts from the
pelvis pose fitted to the pelvis markers (Kabsch) and gets more iterations.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from gc_ocp.geometry import kabsch
from gc_ocp.model.body import BodyModel
from gc_ocp.model.urdf import PELVIS_JOINTS


@dataclass(frozen=True, eq=False)
class MarkerModel:
    """A copy of the body model with one ``OP_FRAME`` per marker.

    names: marker labels; segments: their segment frame names; local: ``(m, 3)`` positions in the
    segment frames [m]; weights: ``(m,)`` IK weights; frame_ids: ids in ``model``.
    """

    body: BodyModel
    model: pin.Model
    names: tuple[str, ...]
    segments: tuple[str, ...]
    local: np.ndarray
    weights: np.ndarray
    frame_ids: tuple[int, ...]

    @classmethod
    def build(cls, body: BodyModel, names, segments, local, weights) -> MarkerModel:
        model = pin.Model(body.model)  # copy; the body model stays untouched
        ids = []
        for n, s, p in zip(names, segments, np.asarray(local, float), strict=True):
            seg_id = body.frame_id(s)
            seg = model.frames[seg_id]
            placement = seg.placement * pin.SE3(np.eye(3), p)
            ids.append(
                model.addFrame(
                    pin.Frame(
                        f"marker:{n}", seg.parentJoint, seg_id, placement, pin.FrameType.OP_FRAME
                    )
                )
            )
        local = np.array(local, float)
        local.setflags(write=False)
        w = np.array(weights, float)
        w.setflags(write=False)
        return cls(body, model, tuple(names), tuple(segments), local, w, tuple(int(i) for i in ids))

    def with_local(self, local: np.ndarray) -> MarkerModel:
        return MarkerModel.build(self.body, self.names, self.segments, local, self.weights)

    def with_weights(self, weights: np.ndarray) -> MarkerModel:
        return MarkerModel.build(self.body, self.names, self.segments, self.local, weights)

    def positions(self, q: np.ndarray, data: pin.Data | None = None) -> np.ndarray:
        """Model marker positions in ``lab`` ``(n, m, 3)`` for ``q`` ``(n, nq)`` (or ``(m, 3)`` for ``(nq,)``)."""
        data = data or self.model.createData()
        q = np.asarray(q, float)
        single = q.ndim == 1
        qs = q[None] if single else q
        out = np.empty((len(qs), len(self.names), 3))
        for k, qk in enumerate(qs):
            pin.framesForwardKinematics(self.model, data, qk)
            for i, f in enumerate(self.frame_ids):
                out[k, i] = data.oMf[f].translation
        return out[0] if single else out


@dataclass(frozen=True)
class IKResult:
    """q: ``(n, nq)``; marker_rms: ``(n,)`` unweighted RMS marker distance per frame [m];
    residuals: ``(n, m)`` marker distances [m] (NaN where the marker is missing);
    iterations: ``(n,)``; seconds: wall time [s]."""

    q: np.ndarray
    marker_rms: np.ndarray
    residuals: np.ndarray
    iterations: np.ndarray
    seconds: float


def pelvis_q_from_pose(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Pelvis coordinates (tx, ty, tz, rz, rx, ry) of the pose ``R = Rz(rz) Rx(rx) Ry(ry)``, ``t``."""
    rx = np.arcsin(np.clip(R[2, 1], -1, 1))
    ry = np.arctan2(-R[2, 0], R[2, 2])
    rz = np.arctan2(-R[0, 1], R[1, 1])
    return np.r_[t, rz, rx, ry]


def initial_q(mm: MarkerModel, frame_markers: np.ndarray) -> np.ndarray:
    """Neutral limbs; pelvis from a Kabsch fit of the pelvis markers (>= 3), else the marker centroid."""
    body = mm.body
    q = body.neutral()
    idx = [body.q_index(j) for j in PELVIS_JOINTS]
    ok = ~np.isnan(frame_markers).any(1)
    pel = np.array([s == "pelvis" for s in mm.segments]) & ok
    if pel.sum() >= 3:
        R, t = kabsch(mm.local[pel], frame_markers[pel])
        q[idx] = pelvis_q_from_pose(R, t)
    elif ok.any():
        q[idx[:3]] = frame_markers[ok].mean(0)
    return np.clip(q, body.lower_limits, body.upper_limits)


class _Solver:
    def __init__(self, mm: MarkerModel) -> None:
        self.mm = mm
        self.data = mm.model.createData()
        self.lo = mm.body.lower_limits
        self.hi = mm.body.upper_limits

    def residual(self, q, target, w):
        pin.framesForwardKinematics(self.mm.model, self.data, q)
        p = np.array([self.data.oMf[f].translation for f in self.mm.frame_ids])
        r = target - p
        return r, float(np.sum(w[:, None] * r * r))

    def solve(self, q, target, valid, max_iter=30, tol=1e-7):
        mm, model, data = self.mm, self.mm.model, self.data
        w = np.where(valid, mm.weights, 0.0)
        tgt = np.where(valid[:, None], target, 0.0)
        r, cost = self.residual(q, tgt, w)
        r[~valid] = 0
        lam = 1e-3
        nv = model.nv
        it = 0
        for it in range(1, max_iter + 1):  # noqa: B007
            pin.computeJointJacobians(model, data, q)
            J = np.empty((len(mm.frame_ids), 3, nv))
            for i, f in enumerate(mm.frame_ids):
                J[i] = pin.getFrameJacobian(model, data, int(f), pin.LOCAL_WORLD_ALIGNED)[:3]
            Jw = J * np.sqrt(w)[:, None, None]
            Jf = Jw.reshape(-1, nv)
            A = Jf.T @ Jf
            g = Jf.T @ (r * np.sqrt(w)[:, None]).reshape(-1)
            D = np.diag(A).copy() + 1e-6
            while True:
                dq = np.linalg.solve(A + lam * np.diag(D), g)
                qn = np.clip(q + dq, self.lo, self.hi)
                rn, cn = self.residual(qn, tgt, w)
                if cn <= cost:
                    lam = max(lam / 3, 1e-7)
                    break
                lam *= 5
                if lam > 1e6:
                    break
            if cn > cost:
                break
            improve = cost - cn
            q, r, cost = qn, rn, cn
            if np.max(np.abs(dq)) < tol or improve < 1e-12 * max(cost, 1e-12):
                break
        return q, it


def solve_ik(
    mm: MarkerModel,
    markers: np.ndarray,
    q0: np.ndarray | None = None,
    max_iter: int = 30,
    first_iter: int = 300,
    progress: Callable[[int, int], None] | None = None,
    q_guess: np.ndarray | None = None,
) -> IKResult:
    """IK over all frames; a frame without any marker seen has no pose (its ``q`` is NaN) and
    the warm start carries over it from the last frame solved.

    mm: marker model; markers: ``(n, m, 3)`` lab positions [m] in ``mm.names`` order, NaN = missing;
    q0: start of the first frame (default :func:`initial_q`); max_iter/first_iter: iterations per
    frame / for the first frame; progress: called as ``progress(frame, n_frames)`` every 50 frames;
    q_guess: ``(n, nq)`` per-frame starting points (replaces the warm start, e.g. a previous pass).
    """
    t0 = _time.perf_counter()
    markers = np.asarray(markers, float)
    n = markers.shape[0]
    s = _Solver(mm)
    Q = np.empty((n, mm.model.nq))
    its = np.zeros(n, int)
    seen = ~np.isnan(markers).any(axis=2)  # (n, m)
    first_seen = int(np.argmax(seen.any(axis=1)))  # (0 when no frame has a marker)
    q = initial_q(mm, markers[first_seen]) if q0 is None else np.asarray(q0, float).copy()
    qprev = None
    for k in range(n):
        valid = seen[k]
        if not valid.any():  # no marker seen (outside the capture volume): no pose
            Q[k] = np.nan
        else:
            if q_guess is not None:
                guess = q_guess[k]
            elif k > first_seen and qprev is not None:
                guess = np.clip(
                    q + 0.5 * (q - qprev), s.lo, s.hi
                )  # damped constant-velocity prediction
            else:
                guess = q
            qprev = q
            first = k == first_seen and q_guess is None
            q, its[k] = s.solve(guess, markers[k], valid, first_iter if first else max_iter)
            Q[k] = q
        if progress is not None and (k % 50 == 0 or k == n - 1):
            progress(k + 1, n)
    model_pos = mm.positions(Q, s.data)
    d = np.linalg.norm(model_pos - markers, axis=2)
    seen = np.isfinite(d).sum(axis=1)
    rms = np.full(n, np.nan)  # NaN in frames without any marker (e.g. outside the capture volume)
    rms[seen > 0] = np.sqrt(np.nansum(d[seen > 0] ** 2, axis=1) / seen[seen > 0])
    return IKResult(Q, rms, d, its, _time.perf_counter() - t0)
