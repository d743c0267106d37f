"""The measurement model: how a model wrench is compared with what the plate recorded.

One definition, two backends: :func:`residual` forms the residual of one frame inside the
per-frame CasADi function (:mod:`.frame`) and of every frame of a fitted stance in NumPy
(:meth:`~gc_ocp.estimation.problem.Weights.residuals`, the diagnosis's scores, the reported
errors), from the same code (the backend's ``where``/``maximum``/``logical_and`` passed in, as
``adam`` writes one algorithm for several backends).

**Censored samples.** Many labs (and every OpenSim ``.mot`` export we have seen) set the whole
plate wrench to exactly 0 wherever the vertical force is below a threshold ``X`` (10-50 N).
Such a sample does not say the force was 0: it says it was below ``X``. It is *censored*: its
residual is ``max(F_z - X, 0)`` on the vertical channel (the model is charged only for a force
the plate would have recorded) and 0 on the other five (a force below ``X`` carries a friction
force and moments the plate did not record). Without this, the rising and falling edges of every
stance look like a force that starts late and ends early, which a clock offset and damping
partly imitate (issue 22). A measured vertical force below ``X`` is censored: after the plate
signal is resampled (a clock offset), values between 0 and ``X`` occur at the edges and mean the
same thing.

**A continuous switch.** A recorded sample of a thresholded plate is either exactly 0 or at
least ``X``; only a resampled one (a clock offset shifts the measurement by a fraction of a
sample) falls in between. Whether such a sample is censored must not jump as the offset moves
it across ``X``: a residual discontinuous in the offset left Ipopt cycling for 1000 iterations on
the clock offset of thresholded data (three BTS trials with a mismatch draw). The residual is
therefore the blend ``s r_plain + (1 - s) r_censored`` with the smoothstep ``s = 3u^2 - 2u^3``,
``u = clip(F_meas / X, 0, 1)``: ``s`` is exactly 0 at 0 and exactly 1 from ``X`` up, so every
recorded sample is charged as before, and a resampled one in between is charged partly as
data, continuously (C1) in the offset. On such a sample the censored part's ramp
``max(F_z - X, 0)`` is rounded to the hyperbola ``(d + sqrt(d^2 + (s X)^2)) / 2``,
``d = F_z - X``: blended with a data residual that is not 0 at ``F_z = X``, the kink of the ramp
would make the cost's gradient jump there (Ipopt then cycled for 1000 iterations on a fold of
the same BTS case, dual infeasibility alternating 0.5 / 2.0 with steps of 1e-9). A wholly
censored sample keeps the exact ramp (its residual is 0 at the kink: the squared cost is C1).
``censor_below = 0``: no threshold (the residual is the plain difference; fits of unthresholded
data are bit-identical to before).
"""

from __future__ import annotations

from types import SimpleNamespace

import casadi as ca
import numpy as np

NUMPY = SimpleNamespace(
    where=np.where,
    maximum=np.maximum,
    minimum=np.minimum,
    sqrt=np.sqrt,
    logical_and=np.logical_and,
)
"""NumPy backend of :func:`residual` (channels are ``(T,)`` arrays)."""

CASADI = SimpleNamespace(
    where=ca.if_else, maximum=ca.fmax, minimum=ca.fmin, sqrt=ca.sqrt, logical_and=ca.logic_and
)
"""CasADi backend of :func:`residual` (channels are SX scalars)."""


def residual(wrench, measured, inv_sigma, censor_below, lib=NUMPY) -> list:
    """Weighted residual per channel (six items, in wrench order): ``(model - measured) x
    inv_sigma``, censored below ``censor_below`` [N] (module doc). ``wrench``, ``measured``,
    ``inv_sigma``: indexable by channel (an SX column, or six ``(T,)`` arrays / a ``(6,)``
    array); ``censor_below``: scalar [N] (0: none); ``lib``: :data:`NUMPY` or :data:`CASADI`."""
    plains = [(wrench[k] - measured[k]) * inv_sigma[k] for k in range(6)]
    # u = clip(F_meas / X, 0, 1), and 1 (every sample plain) without a threshold; X is data of
    # the compiled function (an SX symbol), so no Python branch on it
    x = lib.maximum(censor_below, 1e-12)
    u = lib.where(censor_below > 0, lib.minimum(lib.maximum(measured[2] / x, 0.0), 1.0), 1.0)
    s = u * u * (3.0 - 2.0 * u)  # smoothstep: 0 at u = 0, 1 at u = 1, C1 (module doc)
    # the censored part: max(F_z - X, 0), rounded (hyperbola of width s X) on a partly censored
    # sample, where its kink would not be hidden by a zero residual (module doc)
    d = wrench[2] - censor_below
    eps = s * censor_below
    ramp = lib.where(s > 0.0, 0.5 * (d + lib.sqrt(d * d + eps * eps)), lib.maximum(d, 0.0))
    above = ramp * inv_sigma[2]
    out = []
    for k in range(6):
        cens = above if k == 2 else 0.0 * plains[k]
        out.append(lib.where(s >= 1.0, plains[k], s * plains[k] + (1.0 - s) * cens))
    return out


def stance_residuals(
    model: np.ndarray, measured: np.ndarray, inv_sigma, censor_below
) -> np.ndarray:
    """``(T, 6)`` residuals of one stance (:func:`residual` in NumPy); ``inv_sigma``: ``(6,)``
    (ones: the residual in N and N m)."""
    m, w = np.asarray(measured, float), np.asarray(model, float)
    s = np.broadcast_to(np.asarray(inv_sigma, float), (6,))
    cols = residual(w.T, m.T, s, float(censor_below))
    return np.stack(cols, axis=1)


def fit_error(fit: dict) -> np.ndarray:
    """``(T, 6)`` model error [N, N m] of a stance fit (``EstimationResult.stance_fits`` item):
    :func:`stance_residuals` with unit weights (fits written before the threshold was modelled
    have no ``censor_below``: none)."""
    return stance_residuals(fit["model"], fit["measured"], 1.0, fit.get("censor_below", 0.0))


def measurement_of(stances) -> dict:
    """What the measurement model knew of each stance (``fit.json``, ``diagnosis.json``):
    ``{label: {"censor_below": threshold [N] (0: none)}}``."""
    return {st.label: {"censor_below": st.censor_below} for st in stances}


def censored(measured: np.ndarray, censor_below: float) -> np.ndarray:
    """``(T,)`` which samples of ``measured`` ``(T, 6)`` are censored, wholly or partly (a
    resampled value between 0 and the threshold; module doc)."""
    m = np.asarray(measured, float)
    return np.zeros(m.shape[0], bool) if censor_below <= 0 else m[:, 2] < censor_below


__all__ = [
    "CASADI",
    "NUMPY",
    "censored",
    "fit_error",
    "measurement_of",
    "residual",
    "stance_residuals",
]
