"""Time offset: a constant delay between the force-plate clock and the motion-capture clock."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import butter, filtfilt

from gc_ocp.errors import InputError
from gc_ocp.estimation.components.base import Component, DecodeContext, SummaryRow
from gc_ocp.estimation.flags import BOUND_FRACTION, flag
from gc_ocp.stance import PLATE_SIGNAL_MARGIN


def lanczos(x, a: int = 3):
    """Lanczos kernel ``sinc(x) sinc(x / a)`` for ``|x| < a``, else 0 (NumPy or CasADi SX).

    Smooth in ``x`` (C1 at ``|x| = a``, analytic inside); a Kronecker delta at the integers
    (1 at 0, ``sin(pi j) ~ 1e-16`` at ``j != 0``). Near 0 its Taylor series (to ``x^4``; the
    ``x^6`` term is < 1e-18 for ``|x| < 1e-3``) replaces the ``0/0`` of the closed form.
    """
    pi = math.pi
    c2 = pi**2 * (1 + 1 / a**2) / 6
    c4 = pi**4 * (1 / 120 + 1 / (120 * a**4) + 1 / (36 * a**2))
    if isinstance(x, (ca.SX, ca.MX)):
        absx = ca.fabs(x)
        small = absx < 1e-3
        xs = ca.if_else(small, 1.0, x)  # no 0/0 anywhere in the graph or its derivatives
        direct = a * ca.sin(pi * xs) * ca.sin(pi * xs / a) / (pi**2 * xs**2)
        taylor = 1 - c2 * x**2 + c4 * x**4
        return ca.if_else(absx < a, ca.if_else(small, taylor, direct), 0.0)
    x = np.asarray(x, float)
    small = np.abs(x) < 1e-3
    xs = np.where(small, 1.0, x)
    direct = a * np.sin(pi * xs) * np.sin(pi * xs / a) / (pi**2 * xs**2)
    taylor = 1 - c2 * x**2 + c4 * x**4
    return np.where(np.abs(x) < a, np.where(small, taylor, direct), 0.0)


def interpolation_weights(u, half: int, a: int = 3):
    """Weights ``w_j(u)``, ``j = -half..half``, of the value at ``u`` grid steps from a grid
    point: the Lanczos kernel normalised to sum to 1 (exact for constants; the plain Lanczos
    kernel ripples by ~1e-3 of the signal between grid points). NumPy (a ``(2 half + 1,)`` array)
    or CasADi (a list of SX)."""
    js = range(-half, half + 1)
    if isinstance(u, (ca.SX, ca.MX)):
        k = [lanczos(u - j, a) for j in js]
        total = sum(k[1:], k[0])
        return [kj / total for kj in k]
    k = lanczos(float(u) - np.arange(-half, half + 1), a)
    return k / k.sum()


@dataclass(frozen=True)
class TimeOffset(Component):
    """Constant delay ``delta`` [s] of the force-plate clock behind the motion-capture clock.

    Convention (positive = the plate is late): the plate sample stamped ``t`` holds the wrench
    that acted at ``t - delta``, ``measured(t) = true(t - delta)``; so the model wrench at a
    motion frame ``t`` is compared with the plate signal at ``t + delta``. One ``delta`` per
    trial (scope ``"trial"``): the two systems are synchronised once per recording.

    How it enters. The plate signal (``StanceData.plate_time``, ``plate_wrench``: the plate's own
    samples over the stance +- 0.1 s, zero where the plate rings or carries another load:
    :func:`gc_ocp.stance.without_other_loads`) is low-passed (zero-phase Butterworth, ``lowpass`` Hz) to
    ``F``; :meth:`data` samples ``F`` on the grid ``t + j h``, ``j = -K..K``, of every frame
    (``h`` = ``step``, ``K = ceil(bound / h) + a`` so that the kernel stays on the grid for any
    admissible ``delta``); :meth:`edit_measured` compares the model with::

        measured(t) + F(t + delta) - F(t),   F(t + delta) = sum_j w_j(delta / h) F(t + j h)

    (``w_j``: the Lanczos kernel with ``a`` = ``lobes`` lobes, normalised to sum to 1; smooth in
    the one slot ``time_offset``, which is linear in x). The content of the plate signal below
    ``lowpass`` is shifted, the rest (mostly noise) stays at its sample: shifting the raw
    samples instead would average neighbouring noisy samples by a ``delta``-dependent amount
    (the noise variance of an interpolated white signal drops by 21 % half-way between grid
    points), a spurious pull of ``delta`` towards half-steps that biased a 20 ms recovery by
    1.5 ms (z = -17) once the pose correction flattens the objective in ``delta``; with the
    low-passed signal the noise variance varies by < 1 % beyond 10 ms. At ``delta = 0`` the
    kernel is a Kronecker delta and the comparison is the base model's to round-off.

    Variable ``(name, trial)``: ``delta`` [s], Gaussian prior N(0, sigma^2) with ``sigma`` = 20 ms
    and bounds +-``bound`` = +-50 ms. The prior is weak on purpose: the heel-strike transient
    (Fz rises by ~40 % BW in 10 ms) fixes delta to a fraction of a millisecond, so a 20 ms prior
    moves the estimate by ``(SE / sigma)^2`` < 1e-3 of its distance to 0; it only keeps delta
    defined on a trial whose stances carry no transient. The bound is a gross-sync limit (a 50 ms
    offset is five 100 Hz frames, visible by eye) and what the plate window holds: 50 ms plus
    the kernel's ``a h`` = 7.5 ms fit inside :data:`gc_ocp.stance.PLATE_SIGNAL_MARGIN` = 0.1 s.
    ``fixed``: ``{trial: delta [s]}`` applied without estimating it (a held-out stance of a
    fitted trial keeps its trial's delay; a trial not in it is estimated). Neutral value: 0.

    Identifiability: from the force data alone, through the fast force transients (heel strike
    above all, toe-off less); the model cannot shift its wrench in time otherwise (the pose
    correction can mimic ~1 ms of it at heel strike, hence its larger SE in the full model).
    A stance without a plate signal (hand-made ``StanceData``) is refused (:class:`InputError`).

    Near the ends of a recording. A stance that starts (or ends) close to the start (end) of its
    file has less plate signal around it than the kernel needs at +-``bound``. Each trial's
    bound then shrinks to what the plate signal around every one of its stances allows
    (:meth:`trial_bound`: a whole number of steps), the result block of that trial records it
    (``bound_ms``, and ``bound_limited_by``: the stance) and the flag
    ``time_offset_bound_reduced`` says so. A trial with no room at all (the frames reach the
    first or last plate sample, less than ``lobes * step`` beyond them) cannot be estimated:
    an :class:`InputError` naming the stance (a diagnosis reports the effect as not evaluable).
    A fixed delay (a held-out stance of a fitted trial) must fit in its stance's plate signal.
    """

    sigma: float = 0.020
    bound: float = 0.050
    step: float = 0.0025
    lobes: int = 3
    lowpass: float = 50.0
    fixed: dict | None = None
    name: str = "time_offset"
    scope = "trial"
    neutral_at_zero = True
    candidate = True
    # a shifted transient: one step from 0 gains -0.25 % where the refit gains +8.0 % held out
    # (BTS subject, 10 ms, 2 stances per foot), from its own fit +8.5 % (docs/diagnosis.md,
    # "Where the clock offset's step starts")
    one_step_from_own_fit = True
    # plate errors alone had it named (p 0.88 -> 0.044, out_of_family_output.md); with them in
    # the null a strong 20 ms offset at 2 per foot went from 49 more steps to undecidable
    plate_mimicked = True
    benchmark_values = {"small": 0.005, "moderate": 0.010, "strong": 0.020}  # plate late [s]

    @classmethod
    def inject(cls, base, value, stances, rng) -> tuple:
        """The base plus the plate of every trial ``value`` [s] late."""
        return (*base, cls(fixed={st.trial: float(value) for st in stances}))

    @classmethod
    def describe(cls, block: dict) -> list[SummaryRow]:
        """Per trial: the plate's delay [ms] (positive: plate late)."""
        return [
            SummaryRow(f"{trial} delay", v["ms"], v["ms_se"], "ms", (trial,))
            for trial, v in block.items()
        ]

    @property
    def half(self) -> int:
        """``K``: grid points on each side of the frame."""
        return math.ceil(self.bound / self.step - 1e-9) + self.lobes

    def _free(self, trial: str) -> bool:
        return self.fixed is None or trial not in self.fixed

    # --- how far the plate signal lets delta go ---------------------------------------------------
    def stance_bound(self, stance) -> float:
        """The largest bound [s] (at most :attr:`bound`, a whole number ``n`` of steps) for which
        the kernel reads only the plate signal around ``stance``: at ``|delta| <= n h`` its
        non-zero weights reach ``n + lobes - 1`` grid steps beyond the first and last frame
        (the weight at ``lobes`` steps from ``delta / h`` is 0). 0: not one step."""
        if stance.plate_time is None or np.size(stance.plate_time) == 0:
            return 0.0
        t, pt = np.asarray(stance.time, float), np.asarray(stance.plate_time, float)
        room = min(t[0] - pt[0], pt[-1] - t[-1])
        n = math.floor((room + _SLACK) / self.step) - (self.lobes - 1)
        return float(self.bound if n >= self.half - self.lobes else max(n, 0) * self.step)

    def trial_bound(self, trial: str, stances) -> tuple[float, str | None]:
        """``(bound [s], the stance that limits it or None)`` of ``trial`` over ``stances``: the
        smallest :meth:`stance_bound` of its stances (``None``: the full :attr:`bound`)."""
        mine = [st for st in stances if st.trial == trial]
        worst = min(mine, key=self.stance_bound)
        b = self.stance_bound(worst)
        return b, (worst.label if b < self.bound else None)

    def _no_room(self, trial: str, stance) -> InputError:
        t, pt = stance.time, stance.plate_time
        plate = (
            ""
            if pt is None or np.size(pt) == 0
            else f" and its plate signal [{pt[0]:.3f}, {pt[-1]:.3f}] s"
        )
        return InputError(
            f"time_offset cannot be estimated for trial {trial}: stance {stance.label} has frames "
            f"[{t[0]:.3f}, {t[-1]:.3f}] s{plate}, less than "
            f"{self.lobes * self.step * 1e3:g} ms of plate samples beyond the frames on one "
            "side (the recording starts or ends inside the stance's margin); leave time_offset "
            "out, or drop that stance."
        )

    # --- synthetic data -------------------------------------------------------------------------
    def observe(self, stance, wrench: np.ndarray):
        """The plate records ``wrench`` (the model's, on the stance frames) late by this
        component's ``fixed`` delay of the stance's trial: a cubic spline through the frames
        (edge values held outside them), evaluated at ``t - delta`` on the frames (``measured``)
        and on a 1 kHz plate grid over the frames +- ``PLATE_SIGNAL_MARGIN``."""
        delta = float((self.fixed or {}).get(stance.trial, 0.0))
        t = np.asarray(stance.time, float)
        w = np.asarray(wrench, float)
        spline = CubicSpline(t, w, axis=0)

        def at(times):
            return spline(np.clip(times, t[0], t[-1]))

        rate = 1000.0
        n_margin = round(PLATE_SIGNAL_MARGIN * rate)
        k = np.arange(-n_margin, round((t[-1] - t[0]) * rate) + n_margin + 1)
        plate_t = t[0] + k / rate
        return replace(
            stance, measured=at(t - delta), plate_time=plate_t, plate_wrench=at(plate_t - delta)
        )

    # --- variables and per-frame inputs ---------------------------------------------------------
    def declare(self, variables, stances) -> None:
        for st in stances:
            _require_plate_signal(st)
        for trial in dict.fromkeys(st.trial for st in stances):
            if self._free(trial):
                bound, limit = self.trial_bound(trial, stances)
                if bound <= 0.0:
                    raise self._no_room(trial, next(st for st in stances if st.label == limit))
                variables.prior_variable((self.name, trial), 1, self.sigma, bound)

    def slot_sizes(self, layout) -> dict[str, int]:
        return {"time_offset": 1}

    def slots(self, variables, index, stance) -> dict:
        key = (self.name, stance.trial)
        if variables.has(key):
            return {"time_offset": variables.get(key)}
        return {"time_offset": ca.MX(1, 1) + float((self.fixed or {}).get(stance.trial, 0.0))}

    def data_sizes(self, layout) -> dict[str, int]:
        return {"plate_shift": 6 * 2 * self.half}

    def data(self, stance) -> dict[str, np.ndarray]:
        """``plate_shift``: ``(T, 12 K)``, ``F(t + j h) - F(t)`` for ``j = -K..-1, 1..K`` (six
        columns each, in that order; ``F`` the low-passed plate signal)."""
        _require_plate_signal(stance)
        pt, pw = stance.plate_time, stance.plate_wrench
        K, h = self.half, self.step
        t = np.asarray(stance.time, float)
        if pt.size < 16:
            raise InputError(
                f"Stance {stance.label}: the plate signal around it has {pt.size} samples; the "
                "time_offset effect needs at least 16 (a plate sampled below 100 Hz?)."
            )
        allowed = self.stance_bound(stance)
        if self._free(stance.trial):
            # declare() bounds the trial's delta by ``allowed`` at most: the kernel gives the
            # grid points beyond the plate signal (np.interp holds its end values) weight 0
            if allowed <= 0.0:
                raise self._no_room(stance.trial, stance)
        else:
            fixed = float(self.fixed[stance.trial])
            if abs(fixed) > allowed + 1e-12:
                raise InputError(
                    f"Stance {stance.label}: its trial's clock offset is fixed at "
                    f"{fixed * 1e3:+.1f} ms (e.g. fitted on the trial's other stances), but the "
                    f"plate signal around it, [{pt[0]:.3f}, {pt[-1]:.3f}] s for frames "
                    f"[{t[0]:.3f}, {t[-1]:.3f}] s, allows +-{allowed * 1e3:g} ms at most "
                    f"(bound {self.bound * 1e3:g} ms, step {h * 1e3:g} ms, {self.lobes} lobes): "
                    "the recording starts or ends close to this stance; not evaluable on it."
                )
        ft, fw = self._lowpassed(pt, pw)
        js = np.concatenate([np.arange(-K, 0), np.arange(1, K + 1)])
        times = t[:, None] + js[None, :] * h  # (T, 2K)
        grid = np.stack([np.interp(times, ft, fw[:, c]) for c in range(6)], axis=-1)
        here = np.stack([np.interp(t, ft, fw[:, c]) for c in range(6)], axis=-1)
        return {"plate_shift": (grid - here[:, None, :]).reshape(t.size, -1)}

    def _lowpassed(self, pt: np.ndarray, pw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plate signal on a uniform grid at its median rate, zero-phase low-passed."""
        dt = float(np.median(np.diff(pt)))
        n = int(round((pt[-1] - pt[0]) / dt)) + 1
        ut = pt[0] + dt * np.arange(n)
        uw = np.stack([np.interp(ut, pt, pw[:, c]) for c in range(6)], axis=-1)
        nyquist = 0.5 / dt
        if self.lowpass >= nyquist:
            return ut, uw
        b, a = butter(2, self.lowpass / nyquist)
        return ut, filtfilt(b, a, uw, axis=0)

    # --- the per-frame model ---------------------------------------------------------------------
    def edit_measured(self, frame) -> None:
        K = self.half
        shift = ca.reshape(frame.data("plate_shift"), 6, 2 * K)
        w = interpolation_weights(frame.slot("time_offset") / self.step, K, self.lobes)
        w = w[:K] + w[K + 1 :]  # the weight of j = 0 multiplies F(t) - F(t) = 0
        frame.measured = frame.measured + sum(
            (w[i] * shift[:, i] for i in range(1, 2 * K)), w[0] * shift[:, 0]
        )

    def signature(self) -> tuple:
        return ("TimeOffset", self.half, self.step, self.lobes)

    # --- results -----------------------------------------------------------------------------------
    def decode(self, ctx: DecodeContext) -> dict:
        """``{trial: {"ms": delta [ms], "ms_se": its standard error [ms]}}`` (plate late by
        ``ms`` when positive; ``ms_se`` = 0 for a fixed trial); for a trial whose bound the
        plate signal reduced (:meth:`trial_bound`), also ``"bound_ms"`` and
        ``"bound_limited_by"`` (the stance that limits it)."""
        out: dict = {}
        index = ctx.index()
        for st in ctx.stances:
            if st.trial in out:
                continue
            if (self.name, st.trial) in index:
                v, s = ctx.values((self.name, st.trial))
                out[st.trial] = {"ms": float(v[0]) * 1e3, "ms_se": float(s[0]) * 1e3}
                bound, limit = self.trial_bound(st.trial, ctx.stances)
                if limit is not None:
                    out[st.trial].update(bound_ms=bound * 1e3, bound_limited_by=limit)
            else:
                out[st.trial] = {
                    "ms": float((self.fixed or {}).get(st.trial, 0.0)) * 1e3,
                    "ms_se": 0.0,
                }
        return out

    def flags(self, block: dict, stances: list) -> list[dict]:
        """``time_offset_bound_reduced``: a trial's bound was reduced to what the plate signal
        around its stances allows (the message says whether delta ended at it: then the value
        is not an estimate, the true offset may lie beyond)."""
        out = []
        for trial, v in block.items():
            if "bound_ms" not in v:
                continue
            b = v["bound_ms"]
            at = abs(v["ms"]) >= b * (1.0 - BOUND_FRACTION)
            out.append(
                flag(
                    "time_offset_bound_reduced",
                    trial,
                    f"clock offset of {trial}: bound reduced from +-{self.bound * 1e3:g} to "
                    f"+-{b:g} ms, as far as the plate signal around stance "
                    f"{v['bound_limited_by']} reaches (the recording starts or ends close to "
                    "it)"
                    + (
                        f"; the estimate {v['ms']:+.1f} ms is at that bound: not an estimate, "
                        "the offset may lie beyond"
                        if at
                        else ""
                    ),
                )
            )
        return out

    def frozen(self, block: dict) -> TimeOffset:
        return replace(self, fixed={t: v["ms"] * 1e-3 for t, v in block.items()})


def _require_plate_signal(stance) -> None:
    if stance.plate_time is None or stance.plate_wrench is None:
        raise InputError(
            f"Stance {stance.label}: the time_offset effect resamples the force-plate signal, "
            "but this stance carries none (plate_time/plate_wrench are None, e.g. a hand-made "
            "StanceData); cut it from a trial with gc_ocp.stance.stance_data, or leave "
            "time_offset out of the model."
        )


_SLACK = 1e-6
"""Tolerance [s] on the plate signal's extent (its sample times carry round-off)."""


__all__ = ["TimeOffset", "interpolation_weights", "lanczos"]
