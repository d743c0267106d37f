"""The one stance type, and the one place that cuts a stance out of a trial.

A :class:`StanceData` holds one foot's kinematics over a stance (its contact units placed by the
foot's :class:`~gc_ocp.foot.SoleLayout`) and the measured plate wrench on the same frames. The
seed's linear least squares (:mod:`gc_ocp.contact.lls`), the seed's synthetic sets and the joint
estimator (:mod:`gc_ocp.estimation`) all take it. Numeric, time-first, SI, ``lab`` frame.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from gc_ocp.antialias import band_limited, needs_filter, reach, sample_rate
from gc_ocp.errors import InputError
from gc_ocp.foot import FootKinematics, SoleLayout, TrialKinematics
from gc_ocp.trial import SIDES, Stance, Trial
from gc_ocp.values import given, require


def _ro(a, shape: tuple, name: str, label: str, dtype=float) -> np.ndarray:
    a = np.array(a, dtype=dtype, copy=True)
    if a.shape != shape:
        raise InputError(f"StanceData {label!r}: {name} must have shape {shape}, but got {a.shape}")
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class StanceData:
    """One stance of one foot.

    side: ``"left"``/``"right"``; label: e.g. ``"trial:right@0.41s"`` (names the stance in
    messages); foot: the foot's kinematics on the stance frames (``foot.time`` is the time base);
    measured: ``(n, 6)`` measured wrench (force [N], moment [N·m] about ``reference_point``,
    ``lab``); reference_point: ``(3,)`` [m]; ground_height: plate surface height [m];
    belt_velocity: ``(3,)`` [m/s] (zeros overground); in_contact: ``(n,)`` frames inside the
    detected stance window (the others are margin frames where the plate is unloaded and the model
    must predict no force; default all); trial: the trial's name; body_weight [N], height [m]: the
    subject's, for reporting (per stance, so that stances of several subjects can be pooled);
    plate_time ``(m,)`` [s], plate_wrench ``(m, 6)``: the measured wrench at the plate's own
    samples over the stance window and :data:`PLATE_SIGNAL_MARGIN` around it (same reference
    point), or None: what a clock-offset model resamples; censor_below [N]: the plate recorded
    an exact 0 wherever the vertical force was below this threshold (0: no threshold), so a
    measured vertical force below it is censored, not an error
    (:mod:`gc_ocp.estimation.measurement`).

    Made from a loaded trial and its kinematics, not by hand: :func:`trial_stances` (every
    stance of the trial) or :func:`stance_data` (one).

    >>> import gc_ocp
    >>> trial = gc_ocp.load_trial(); kin = gc_ocp.compute_kinematics(trial)
    >>> first = gc_ocp.trial_stances(trial, kin)[0]
    >>> first.label, first.side, first.measured.shape  # the wrench: (frames, 6) [N, N m]
    ('test_small:right@0.407s', 'right', (66, 6))
    """

    side: str
    label: str
    foot: FootKinematics
    measured: np.ndarray
    reference_point: np.ndarray
    ground_height: float = 0.0
    belt_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    in_contact: np.ndarray | None = None
    trial: str = ""
    body_weight: float = float("nan")
    height: float = float("nan")
    plate_time: np.ndarray | None = None
    plate_wrench: np.ndarray | None = None
    censor_below: float = 0.0

    def __post_init__(self) -> None:
        n = self.foot.time.shape[0]
        if self.side not in SIDES:
            raise InputError(
                f"StanceData {self.label!r}: side must be one of {SIDES}, but got {self.side!r}"
            )
        if self.foot.side != self.side:
            raise InputError(
                f"StanceData {self.label!r}: a {self.side} stance with the {self.foot.side} foot"
            )
        set_ = object.__setattr__
        set_(self, "measured", _ro(self.measured, (n, 6), "measured", self.label))
        set_(
            self, "reference_point", _ro(self.reference_point, (3,), "reference_point", self.label)
        )
        set_(self, "belt_velocity", _ro(self.belt_velocity, (3,), "belt_velocity", self.label))
        contact = np.ones(n, bool) if self.in_contact is None else self.in_contact
        set_(self, "in_contact", _ro(contact, (n,), "in_contact", self.label, bool))
        set_(self, "ground_height", float(self.ground_height))
        set_(self, "body_weight", float(self.body_weight))
        set_(self, "height", float(self.height))
        set_(self, "censor_below", float(self.censor_below))
        if not (np.isfinite(self.censor_below) and self.censor_below >= 0):
            raise InputError(
                f"StanceData {self.label!r}: censor_below must be a threshold >= 0 N, but got "
                f"{self.censor_below}"
            )
        if (self.plate_time is None) != (self.plate_wrench is None):
            raise InputError(
                f"StanceData {self.label!r}: give both plate_time and plate_wrench, or neither"
            )
        if self.plate_time is not None:
            m = np.shape(self.plate_time)[0]
            set_(self, "plate_time", _ro(self.plate_time, (m,), "plate_time", self.label))
            set_(self, "plate_wrench", _ro(self.plate_wrench, (m, 6), "plate_wrench", self.label))

    @property
    def n(self) -> int:
        """Number of frames."""
        return int(self.foot.time.shape[0])

    @property
    def time(self) -> np.ndarray:
        """``(n,)`` [s]."""
        return self.foot.time

    @property
    def layout(self) -> SoleLayout:
        return self.foot.layout

    @property
    def positions(self) -> np.ndarray:
        """``(n, m, 3)`` unit positions in ``lab`` [m] (nominal sole points)."""
        return self.foot.positions

    @property
    def velocities(self) -> np.ndarray:
        """``(n, m, 3)`` unit velocities in ``lab`` [m/s]."""
        return self.foot.velocities

    def with_measured(self, measured: np.ndarray) -> StanceData:
        return replace(self, measured=measured)

    def with_foot(self, foot: FootKinematics) -> StanceData:
        """The stance with another foot kinematics on the same frames (e.g. moved sole points)."""
        if foot.time.shape != self.time.shape or not np.array_equal(foot.time, self.time):
            raise InputError(f"StanceData {self.label!r}: the new foot kinematics has other frames")
        return replace(self, foot=foot)


PLATE_SIGNAL_MARGIN = 0.1
"""Plate samples kept beyond the stance window on each side [s]: room for a +-50 ms clock offset
plus an interpolation kernel."""


def _other_loads(trial: Trial, stance: Stance) -> tuple[float | None, float | None]:
    """``(last_before, first_after)``: the times of the last plate sample before ``t_on`` and of
    the first after ``t_off`` that read more than the trial's contact threshold
    (``Trial.contact_threshold``, 20 N by default; below it the foot is off by the stance
    detector's own definition), None where there is none. Beyond them the plate rings or
    something else loads it: it is not measuring the foot."""
    plate = trial.plates[stance.plate]
    t, fz = plate.time, plate.force[:, 2]
    loud = np.isfinite(fz) & (np.abs(fz) > trial.contact_threshold)
    before, after = t[loud & (t < stance.t_on)], t[loud & (t > stance.t_off)]
    return (
        float(before[-1]) if before.size else None,
        float(after[0]) if after.size else None,
    )


def quiet_margins(trial: Trial, stance: Stance, margin: float) -> tuple[float, float, list[str]]:
    """``(t_lo, t_hi, reasons)``: the frames of the stance's window ``[t_on - margin, t_off +
    margin]`` to fit are those with ``t_lo < t < t_hi`` (open bounds), the window cut where its
    plate stops being quiet in a margin (:func:`_other_loads`): a loud sample after ``t_off``
    (before ``t_on``) leaves out every frame from that sample on (up to it). A plate that rings
    after toe-off (Camargo's plate 1: -151 to +97 N within 25 ms) or that something else loads
    is not measuring the foot. The reasons say where and how loud, for the fit's notes."""
    eps = 1e-9
    t_lo, t_hi, reasons = stance.t_on - margin - eps, stance.t_off + margin + eps, []
    if margin <= 0:
        return t_lo, t_hi, reasons
    plate = trial.plates[stance.plate]
    t, fz = plate.time, plate.force[:, 2]
    last_before, first_after = _other_loads(trial, stance)
    if first_after is not None and first_after < t_hi:
        t_hi = first_after  # open bound: a frame at the loud sample is left out too
        peak = _peak(fz, t, first_after, stance.t_off + margin)
        reasons.append(
            f"plate {plate.name} reads {peak:+.0f} N within {margin * 1e3:.0f} ms after toe-off "
            f"(from {first_after:.3f} s: ringing, or another load): its frames from there are "
            "not fitted"
        )
    if last_before is not None and last_before > t_lo:
        t_lo = last_before
        peak = _peak(fz, t, stance.t_on - margin, last_before)
        reasons.append(
            f"plate {plate.name} reads {peak:+.0f} N within {margin * 1e3:.0f} ms before heel "
            f"strike (to {last_before:.3f} s): its frames up to there are not fitted"
        )
    return t_lo, t_hi, reasons


def plate_signal(
    trial: Trial, stance: Stance, t_first: float, t_last: float, frame_rate: float | None
) -> tuple[np.ndarray, np.ndarray]:
    """``(times, wrench)``: the stance's plate wrench (about ``stance.reference_point``, lab) on
    the plate's samples within :data:`PLATE_SIGNAL_MARGIN` of ``[t_first, t_last]`` [s] and the
    filter's reach beyond, as the frames at ``frame_rate`` [Hz] read it: other loads zeroed
    (:func:`without_other_loads`), then low-passed for the frames
    (:func:`gc_ocp.antialias.band_limited`; None: raw). The frames' measured wrench is this
    signal interpolated at their times, and a clock offset resamples the same signal."""
    plate = trial.plates[stance.plate]
    rate = sample_rate(plate.time)
    filtered = needs_filter(rate, frame_rate)
    far = PLATE_SIGNAL_MARGIN + (reach(rate, frame_rate) if filtered else 0.0)
    near = (plate.time >= t_first - far) & (plate.time <= t_last + far)
    pt = plate.time[near]
    pw = without_other_loads(trial, stance, pt, trial.stance_wrench(stance, pt))
    return pt, band_limited(pt, pw, frame_rate) if filtered else pw


def frame_wrench(
    trial: Trial, stance: Stance, times: np.ndarray, frame_rate: float | None
) -> np.ndarray:
    """``(len(times), 6)``: the stance's measured wrench at the frames ``times`` [s] (about
    ``stance.reference_point``, lab), as a fit compares it: :func:`plate_signal` at the frames'
    rate ``frame_rate`` [Hz], interpolated at their times. The one reading of "the plate at the
    frames" (the fit's :func:`stance_data`, the exports' plate file, the band note of
    ``fit.json``)."""
    times = np.asarray(times, float)
    if not times.size:
        return np.zeros((0, 6))
    pt, pw = plate_signal(trial, stance, times.min(), times.max(), frame_rate)
    return _at(times, pt, pw)


def _at(times: np.ndarray, pt: np.ndarray, pw: np.ndarray) -> np.ndarray:
    return np.column_stack([np.interp(times, pt, pw[:, c]) for c in range(pw.shape[1])])


def without_other_loads(
    trial: Trial, stance: Stance, times: np.ndarray, wrench: np.ndarray
) -> np.ndarray:
    """The stance's plate wrench ``(len(times), 6)`` on plate samples ``times`` around it, zero
    where it is not the foot's: from the first loud sample after ``t_off`` on and up to the
    last before ``t_on`` (:func:`_other_loads`), the plate rings or carries another load, and
    the foot, off by the stance detector's definition, exerts nothing (the rule of
    :func:`quiet_margins`, over the whole plate signal). The clock offset
    (:class:`~gc_ocp.estimation.components.TimeOffset`) shifts this signal by up to 50 ms
    beyond the fitted frames: without the rule a cut margin's ringing came back through it."""
    last_before, first_after = _other_loads(trial, stance)
    out = np.array(wrench, float, copy=True)
    if first_after is not None:
        out[times >= first_after] = 0.0
    if last_before is not None:
        out[times <= last_before] = 0.0
    return out


def _peak(fz: np.ndarray, t: np.ndarray, a: float, b: float) -> float:
    sel = (t >= a - 1e-9) & (t <= b + 1e-9) & np.isfinite(fz)
    seg = fz[sel]
    return float(seg[np.argmax(np.abs(seg))]) if seg.size else float("nan")


def _require_trial_and_kinematics(trial, kin, who: str) -> None:
    how = f"kin = gc_ocp.compute_kinematics(trial); gc_ocp.{who}(trial, kin, ...)"
    require(trial, Trial, f"{who} takes a loaded trial first", how)
    require(kin, TrialKinematics, f"{who} takes the trial's kinematics second", how)


def require_stance_list(stances, who: str) -> list[StanceData]:
    """``stances`` as a list of :class:`StanceData` (an iterator of them read once), else an
    :class:`InputError` naming ``who`` and how to make them (``(trial, kinematics)`` pairs are
    what :func:`gc_ocp.fit` and :func:`gc_ocp.diagnose` take, not the stance-level calls).
    An empty list passes: each caller says what it lacks then."""
    if isinstance(stances, Iterator):
        stances = list(stances)
    how = (
        "stances = gc_ocp.trial_stances(trial, kin) (several trials: the lists added); "
        "with (trial, kinematics) pairs use gc_ocp.fit or gc_ocp.diagnose instead"
    )
    if not isinstance(stances, Sequence) or isinstance(stances, str):
        require(stances, list, f"{who} takes a list of stances (StanceData)", how)
    for i, st in enumerate(stances):
        if not isinstance(st, StanceData):
            raise InputError(
                f"{who} takes a list of stances (StanceData), but item {i} is {given(st)}: {how}"
            )
    return list(stances)


def stance_data(
    trial: Trial,
    kin: TrialKinematics,
    stance: Stance,
    margin: float = 0.0,
    min_frames: int = 1,
    name: str | None = None,
    censor_below: float = 0.0,
) -> StanceData:
    """Cut ``stance`` out of ``trial``: the frames of ``kin.feet[stance.side]`` within
    ``[t_on - margin, t_off + margin]`` [s] (a margin cut where its plate is not quiet:
    :func:`quiet_margins`) and the measured wrench on them. Frames with non-finite
    kinematics or plate data are dropped; fewer than ``min_frames`` left is an :class:`InputError`
    naming the stance and the likely cause. ``name``: the trial's name in the label
    (``name:side@t_on``) and in ``StanceData.trial`` (default ``trial.name``, the file's stem;
    several trials of one fit are named by :func:`trial_names`); ``censor_below``: its plate's
    zero threshold [N] (:attr:`StanceData.censor_below`).

    ``stance`` is one of ``trial.stances`` (a :class:`~gc_ocp.trial.Stance`, not its label).

    >>> import gc_ocp
    >>> trial = gc_ocp.load_trial(); kin = gc_ocp.compute_kinematics(trial)
    >>> stance = trial.stances[0]             # print(trial) lists them: right@0.407s, ...
    >>> data = gc_ocp.stance_data(trial, kin, stance, margin=0.03)
    >>> data.label, data.foot.time.shape      # with 0.03 s (3 frames) each side of the stance
    ('test_small:right@0.407s', (72,))
    """
    _require_trial_and_kinematics(trial, kin, "stance_data")
    require(
        stance,
        Stance,
        "stance_data takes one of the trial's stances",
        "trial.stances[i] (print(trial) lists them), or every stance at once: "
        "gc_ocp.trial_stances(trial, kin).",
    )
    name = trial.name if name is None else name
    if stance.side not in kin.feet:
        raise InputError(
            f"Stance {stance.label} is on the {stance.side} foot but the kinematics have feet {sorted(kin.feet)}"
        )
    foot = kin.feet[stance.side]
    t = foot.time
    rate = sample_rate(t) if t.size > 1 else None
    t_lo, t_hi, _ = quiet_margins(trial, stance, margin)
    sel = (t > t_lo) & (t < t_hi)
    idx = np.flatnonzero(sel)
    ok = np.zeros(0, bool)
    if idx.size:
        foot = foot.window(t[idx[0]], t[idx[-1]])
        pt, pw = plate_signal(trial, stance, foot.time[0], foot.time[-1], rate)
        meas = _at(foot.time, pt, pw)
        ok = (
            np.isfinite(foot.positions).all(axis=(1, 2))
            & np.isfinite(foot.velocities).all(axis=(1, 2))
            & np.isfinite(meas).all(axis=1)
        )
    if ok.sum() < min_frames:
        raise InputError(
            f"{trial.source}: stance {stance.label} [{stance.t_on:.3f}, {stance.t_off:.3f}] s has "
            f"{int(ok.sum())} usable kinematic frames (need {min_frames}); "
            "check marker gaps, the plate channels and that the kinematics cover the stance."
        )
    if not ok.all():
        foot, meas = foot.frames(ok), meas[ok]
    height = float("nan") if trial.height is None else float(trial.height)
    around = (pt >= foot.time[0] - PLATE_SIGNAL_MARGIN) & (
        pt <= foot.time[-1] + PLATE_SIGNAL_MARGIN
    )
    pt, pw = pt[around], pw[around]
    finite = np.isfinite(pw).all(axis=1)
    return StanceData(
        side=stance.side,
        label=f"{name}:{stance.label}",
        foot=foot,
        measured=meas,
        reference_point=np.asarray(stance.reference_point, float),
        ground_height=float(trial.plates[stance.plate].surface_height),
        belt_velocity=np.asarray(trial.belt_velocity, float),
        in_contact=(foot.time >= stance.t_on - 1e-9) & (foot.time <= stance.t_off + 1e-9),
        trial=name,
        body_weight=trial.body_weight,
        height=height,
        plate_time=pt[finite],
        plate_wrench=pw[finite],
        censor_below=censor_below,
    )


def trial_stances(
    trial: Trial,
    kin: TrialKinematics,
    margin: float = 0.0,
    min_frames: int = 1,
    name: str | None = None,
    censor_below: Mapping[int, float] | None = None,
) -> list[StanceData]:
    """Every stance of ``trial`` (see :func:`stance_data`); ``censor_below``: ``{plate index:
    zero threshold [N]}`` (missing: 0). What :func:`~gc_ocp.estimation.build_estimation` and
    :func:`~gc_ocp.diagnosis.diagnose_stances` take (several trials: the lists added together).

    >>> import gc_ocp
    >>> trial = gc_ocp.load_trial(); kin = gc_ocp.compute_kinematics(trial)
    >>> stances = gc_ocp.trial_stances(trial, kin, margin=0.03)
    >>> [st.label for st in stances]
    ['test_small:right@0.407s', 'test_small:left@0.941s', 'test_small:right@1.494s']
    """
    _require_trial_and_kinematics(trial, kin, "trial_stances")
    thr = censor_below or {}
    return [
        stance_data(trial, kin, s, margin, min_frames, name, thr.get(s.plate, 0.0))
        for s in trial.stances
    ]


def _path_parts(source: str | Path) -> tuple[str, ...]:
    """The folders and stem of ``source`` as an absolute, normalised path (no drive or root):
    ``("data", "walking1", "markers")`` for ``data/walking1/markers.trc``."""
    p = Path(os.path.abspath(source))
    return (*p.parent.parts[1:], p.stem)


def trial_names(sources: Sequence[str | Path]) -> list[str]:
    """The name of each trial file of ``sources`` (the trials of one subject): it starts the
    labels of their stances (``name:side@t_on``) and keys their trial-scope variables (clock
    offset, belt speed), so different files must get different names.

    A file's name is its stem (``walk1`` for ``data/walk1.c3d``) when no other file of
    ``sources`` has that stem: labels of distinctly named files are the same as ever. Files that
    share a stem (one folder per trial: ``walking1/markers.trc``, ``walking2/markers.trc``) are
    named by the shortest end of their path that tells each apart (``walking1/markers``,
    ``walking2/markers``; folders joined by ``/``), or, when even the full paths only differ in
    the extension, by the stem and the position in ``sources`` (``markers#2``). The same file
    given twice keeps one name: it is the same trial (a check can then find it twice).

    >>> trial_names(["a/walk1.c3d", "a/walk2.c3d"])
    ['walk1', 'walk2']
    >>> trial_names(["s/walking1/markers.trc", "s/walking2/markers.trc", "s/other.trc"])
    ['walking1/markers', 'walking2/markers', 'other']
    """
    parts = [_path_parts(s) for s in sources]
    keys = [os.path.normcase(os.path.abspath(s)) for s in sources]
    names = []
    for i, mine in enumerate(parts):
        others = {
            parts[j] for j in range(len(parts)) if parts[j][-1] == mine[-1] and keys[j] != keys[i]
        }
        name = None
        for k in range(1, len(mine) + 1):
            if all(o[-k:] != mine[-k:] for o in others):
                name = "/".join(mine[-k:])
                break
        names.append(name if name is not None else f"{mine[-1]}#{i + 1}")
    return names


def fit_stances(
    trials: Sequence[tuple[Trial, TrialKinematics]],
    margin: float = 0.0,
    min_frames: int = 1,
    names: Sequence[str] | None = None,
    censor_below: Sequence[Mapping[int, float]] | None = None,
) -> list[StanceData]:
    """Every stance of every trial of one fit (``[(Trial, TrialKinematics), ...]``, see
    :func:`stance_data`), each trial named by :func:`trial_names` (or ``names``, one per trial,
    e.g. names given to the trials of two fits together). Two trials of one fit with the same
    name (one file given twice with different content, e.g. edited in memory) are told apart by
    their position (``name#2``): a stance's label and a trial's variables never depend on file
    names being distinct. ``censor_below``: per trial, ``{plate index: zero threshold [N]}``."""
    if names is None:
        names = trial_names([t.source for t, _ in trials])
    if len(names) != len(trials):
        raise InputError(f"Got {len(names)} trial names for {len(trials)} trials; give one each.")
    names = [n if list(names).count(n) == 1 else f"{n}#{i + 1}" for i, n in enumerate(names)]
    thresholds = list(censor_below) if censor_below is not None else [{}] * len(trials)
    return [
        st
        for (trial, kin), name, thr in zip(trials, names, thresholds, strict=True)
        for st in trial_stances(trial, kin, margin, min_frames, name, thr)
    ]


__all__ = ["StanceData", "fit_stances", "stance_data", "trial_names", "trial_stances"]
