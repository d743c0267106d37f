"""What the lab's processing did to a trial's plate and marker data, read from the data alone.

>>> from gc_ocp.io import load_trial
>>> from gc_ocp.io.processing import detect_processing
>>> print(detect_processing(load_trial()).summary())  # doctest: +ELLIPSIS
Processing detected in ...test_small.c3d:
  plate plate1: zeroed below 10.0 N (exact zeros where unloaded: a threshold, ...)
  plate plate1: raw: a noise floor reaches Nyquist (...)
...
  markers: low-passed by the lab at ~8 Hz before export

Rules (conventions and signal properties only, never a file or lab name; ``docs/data_formats.md``,
"What the lab's processing did", gives the reasons and limits):

* **zeroed below a threshold**: runs of samples where all six wrench channels are exactly 0 (a
  plate's electronics are never exactly 0 on six channels at once), or longer runs where Fz
  alone is (a threshold applied to the vertical channel only); the threshold is the smallest
  |Fz| of the samples kept (the first kept one next to a run is within one sample's rise of it).
* **low-passed**: a raw sensor has a white noise floor up to Nyquist; a filter makes the spectrum
  fall by orders of magnitude above its cutoff, or leaves only the rounding of the stored numbers.
  The cutoff is read on the plate's unloaded noise when there is some (exact for a zero-lag
  Butterworth), else on the spectrum of the data against the steepest fall a walking force or
  marker trajectory has by itself (approximate, never early when that trend holds).
* **resampled**: samples that are a polynomial interpolation of a lower rate (the differences of
  one order above the polynomial's vanish except at its knots), or plates stored at the marker
  rate.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from gc_ocp.io import _spectra as sp
from gc_ocp.io._resampling import DEGREES, MAX_FACTOR, interpolation_factor
from gc_ocp.trial import Plate, Trial

ZERO_RUN_MIN = 5
"""Shortest run [samples] of six exactly-zero wrench channels taken as zeroing. Even a coarsely
quantised raw channel is exactly 0 at most ~half the time: six channels together for 5 samples
in a row, < 0.5^30 ~ 1e-9 per sample."""
FZ_ZERO_RUN_MIN = 30
"""Shortest run [samples] of an exactly-zero vertical force alone taken as zeroing (a lab that
thresholds the vertical channel only and keeps the others): the same odds as
:data:`ZERO_RUN_MIN` for one channel, 0.5^30 ~ 1e-9 per sample (a coarsely quantised raw Fz is
exactly 0 in 26 % of the samples of the type-2a plate of ../shared/data, in runs of <= 6)."""
FZ_ZERO_RUN_TIME = 0.3
"""[s] ... and at least this long when the rate is known: 30 samples of a plate resampled from
100 Hz (a held or interpolated sample repeats its zeros R times, and the odds are those of the
native samples). Shorter than the unloaded time around a stance on its plate."""
RESIDUE_MAX = 10.0
"""[N] Largest level a zeroed vertical force may be held at instead of 0: a lab that removes an
unloaded offset after zeroing leaves its zeros at minus that offset (a few N: the largest
offset an unloaded stretch of ../shared/data reads is 2.2 N). A run of :data:`FZ_ZERO_RUN_MIN`
exactly equal samples is zeroing by the same odds as one of exact zeros; a level of a loaded
foot (hundreds of N) is a held or stuck signal, not zeroing."""
PLATE_WINDOW = 0.25
"""Welch window for plate spectra [s]: several windows per stance (0.6-0.8 s)."""
MARKER_WINDOW = 1.0
"""Welch window for marker spectra [s] (capped at half the trial): resolves 1-2 Hz, below any
cutoff a lab applies to walking markers."""
NOISE_MIN_WINDOWS = 4
"""Unloaded noise stretches must hold this many Welch windows to be read instead of the loaded
spectrum."""
STOP_BAND_FALL = 1.5
"""Decades the PSD must fall across the top of the spectrum (:data:`gc_ocp.io._spectra.TOP_BAND`)
to be a filter's stop band, measured between the centres of the top's bands
(:meth:`~gc_ocp.io._spectra.BandSpectrum.top_fall`: 2 or 3 bands of 1/8 decade, whose centres
lie 0.125-0.25 decade apart with the rate and window, not the top's 0.28 decade): a slope
steeper than -6 (3 bands) to -12 (2 bands). Raw noise floors are white or gently coloured (falls
up to 1.2, slopes down to -4.9, on the raw marker data of ``../shared/data``); the stop band of a
zero-lag Butterworth of order n falls with slope -4n, on top of the signal's own fall, and a
digital one's faster still towards Nyquist, where its response vanishes."""
PLATE_NOISE_MIN = 1e-3
"""[N] A plate's electronics are noisier than this (a 16-bit converter on a ~5 kN range alone
gives 0.04 N): a lower white floor is rounding of the stored numbers after a filter."""
MARKER_NOISE_MIN = 1e-6
"""[m] Optical motion capture resolves ~10-100 um: a white floor below 1 um is rounding after a
filter."""
FORCE_SLOPE = 6.0
"""Steepest spectral slope of an unfiltered walking force between the stride harmonics and the
noise floor: a force leaving 0 at a finite rate falls as f^-4, the raw plates of ../shared/data
fall as f^-4 to f^-6 there. The cutoff is read against this slope (:func:`trend_cutoff`): a
trend at least as steep as the signal's reads late (x1.4 for a 4th-order zero-lag filter on an
f^-4 force), a shallower one would read the signal's own fall as the filter."""
MARKER_SLOPE = 7.0
"""Same for marker trajectories: their acceleration jumps (heel strike, toe-off), so they fall
as f^-6; the raw marker data of ../shared/data fall as f^-6 to f^-7 above the stride harmonics."""
TAIL_SHARE = 0.25
"""Share of the edges of the zero runs below :data:`PLATE_NOISE_MIN` (two samples in a row) that
makes them a filter's tail. A zero-lag (forward-backward) filter leaves its tail on both edges
of every run, a causal one on the edges after the loads only (half of them; the edges before a load then rise
smoothly from 0, by the filter's first coefficient); a threshold or a noisy edge gives a value
below 1 mN by chance only (~1e-3 N / noise per edge)."""
BASELINE_WINDOW = 0.05
"""Window [s] for the unloaded check (as :func:`gc_ocp.io.c3d.unloaded_baseline`)."""
UNLOADED_MAX = 50.0
"""[N] A quiet window whose mean |Fz| is below this is unloaded (a standing or walking foot
loads a plate with hundreds of N)."""
OFFSET_TOL = 2.0
"""[N] An unloaded window whose mean Fz is farther than this from 0 (and than 3 standard errors
of its mean) still reads an offset (plate noise is < 2 N; ``gc_ocp.io.stances``)."""
PLATE_RATE_MIN = 500.0
"""[Hz] Force plates sample at this rate or faster: a plate stored at the marker rate below it
was down-sampled to the cameras' rate (:attr:`PlateProcessing.at_marker_rate`); at or above it
(cameras at 500-2000 Hz) the plate may be at its own rate."""
COP_NOISE_FACTOR = 10.0
"""The COP is ``moment / Fz``: above 10 x the Fz noise, Fz is known to 10 %, so the COP to 10 % of
its distance from the plate's reference point (a few cm on a 0.5 m plate)."""
COP_FALLBACK = 20.0
"""[N] ``cop_min_load`` when neither a threshold nor the noise can be measured: the loader's
contact threshold (``gc_ocp.io.stances.DEFAULT_THRESHOLD``, 3 % of a 65 kg body weight)."""


@dataclass(frozen=True)
class PlateProcessing:
    """What was done to one plate's data before gc_ocp read it.

    name, rate_hz: the plate and its sampling rate [Hz] (samples over duration).
    zero_threshold: [N] the wrench was set to exactly 0 where |Fz| was below this (the smallest
        |Fz| of the samples kept outside the exact-zero runs; an upper bound, within one sample's
        rise of the lab's value); ``None`` when the plate has no exact-zero run of :data:`ZERO_RUN_MIN` samples
        (:data:`FZ_ZERO_RUN_MIN` and :data:`FZ_ZERO_RUN_TIME` of Fz alone:
        :func:`exact_zero_runs`).
    zero_edges: ``"step"`` (the first non-zero samples jump from 0: a threshold),
        ``"continuous"`` (the force leaves 0 at its own rate: zeroed at ~0 N, or at a low rate
        below a threshold under one sample's rise, which the edges cannot tell apart; the threshold is
        then at most one sample's rise) or ``"filter tail"`` (the edges decay to values no plate
        resolves: zeroed, then a recursive low-pass ran over the zeros); ``""`` without zeroing
        (:func:`zero_threshold`).
    zeroed_fraction: share of the samples inside exact-zero runs.
    zero_level: [N] the level the zeroed vertical force is held at: 0, or a small residue where
        an unloaded offset was removed after the zeroing (:func:`held_level`).
    filtered: the lab low-passed the forces (a stop band at the top of the spectrum, a floor
        below any plate's noise, or a filter tail at the zero runs).
    lowpass_hz: cutoff [Hz] of that low-pass, read as a zero-lag Butterworth's design cutoff
        (-6 dB); ``None`` when not filtered or not measurable.
    lowpass_basis: ``"unloaded noise"`` (exact) or ``"force spectrum"`` (approximate), ``""``.
    noise_std: [N] Fz noise: standard deviation over the unloaded stretches, else the
        white-equivalent level of the top of the loaded spectrum (an upper bound if signal
        reaches it); ``None`` when a filter removed it and no unloaded stretch is left.
    native_rate_hz: rate [Hz] the samples were interpolated from, with ``interpolation`` the
        polynomial degree's name (``"hold"``, ``"linear"``, ``"quadratic"``, ``"cubic"``);
        ``None`` when every sample carries its own information.
    at_marker_rate: the plate is stored at the marker rate, below :data:`PLATE_RATE_MIN`
        (plates sample at >= 500 Hz; a plate at the cameras' rate was down-sampled to it).
    zero_offset: the unloaded offset gc_ocp removed on load (``Plate.zero_offset``, 6 values,
        force [N] then moment [N·m]); ``None``: none removed.
    unloaded_offsets: ``(t_start, t_end, mean Fz)`` [s, s, N] of the unloaded stretches that
        still read an offset after load (:data:`OFFSET_TOL`).
    cop_held_below: [N] the largest load at which the COP is held constant in the data
        (:func:`cop_held_below`), ``None`` when it never is.
    cop_min_load: [N] below this vertical load the COP is undefined on this plate: the largest
        of the zero threshold (step edges), ``COP_NOISE_FACTOR x noise_std`` and
        ``cop_held_below``; with none of them, :data:`COP_FALLBACK`. ``cop_min_load_basis`` says
        which.
    """

    name: str
    rate_hz: float
    zero_threshold: float | None
    zero_edges: str
    zeroed_fraction: float
    filtered: bool
    lowpass_hz: float | None
    lowpass_basis: str
    noise_std: float | None
    native_rate_hz: float | None
    interpolation: str
    at_marker_rate: bool
    zero_offset: tuple[float, ...] | None
    unloaded_offsets: tuple[tuple[float, float, float], ...]
    cop_held_below: float | None
    cop_min_load: float
    cop_min_load_basis: str
    zero_level: float = 0.0

    @property
    def resampled(self) -> bool:
        """The stored samples are not the plate's own: interpolated from a lower rate, or stored
        at the marker rate."""
        return self.native_rate_hz is not None or self.at_marker_rate

    def findings(self) -> list[str]:
        """One sentence per finding (``Processing.summary``)."""
        out = []
        if self.zero_threshold is not None:
            thr = f"{self.zero_threshold:.1f} N"
            zeros = "exact zeros" if self.zero_level == 0.0 else "a constant"
            out.append(
                {
                    "step": f"zeroed below {thr} ({zeros} where unloaded: a threshold, as "
                    f"OpenSim exports and some C3D exporters apply)",
                    "continuous": f"{zeros} where unloaded, the force leaving them at its "
                    f"own rate (the smallest kept |Fz| is {thr}: zeroed below at most that, which one "
                    "sample's rise cannot tell from ~0 N; not censored)",
                    "filter tail": f"{zeros} where unloaded, with edges decaying to "
                    f"{self.zero_threshold:.1g} N: zeroed, then low-passed (a recursive "
                    f"filter's tail runs into the zero runs until it underflows)",
                }[self.zero_edges]
            )
            if self.zero_level != 0.0:
                out.append(
                    f"the zeroed Fz reads {self.zero_level:+.3g} N, not 0: an offset removed "
                    "after the zeroing"
                )
        elif self.zeroed_fraction == 1.0:
            out.append("reads exactly 0 throughout (unused)")
        if self.lowpass_hz is not None:
            how = "exact" if self.lowpass_basis == "unloaded noise" else "approximate"
            out.append(
                f"low-passed by the lab at ~{self.lowpass_hz:.0f} Hz ({how}, from the "
                f"{self.lowpass_basis})"
            )
        elif self.filtered:
            out.append("low-passed by the lab; the cutoff is not measurable from the spectrum")
        elif self.noise_std is not None:
            out.append(f"raw: a noise floor reaches Nyquist ({self.noise_std:.2g} N)")
        if self.native_rate_hz is not None:
            out.append(
                f"{self.interpolation} interpolation of {self.native_rate_hz:.0f} Hz samples "
                f"to {self.rate_hz:.0f} Hz"
            )
        if self.at_marker_rate:
            out.append(f"stored at the marker rate ({self.rate_hz:.0f} Hz): down-sampled")
        if self.zero_offset is not None and np.any(self.zero_offset):
            f = np.round(self.zero_offset[:3], 1).tolist()
            out.append(f"unloaded offset F={f} N removed on load")
        for t0, t1, level in self.unloaded_offsets:
            out.append(f"unloaded but reads {level:+.1f} N at {t0:.2f}-{t1:.2f} s after load")
        out.append(f"COP defined above {self.cop_min_load:.1f} N ({self.cop_min_load_basis})")
        return out


@dataclass(frozen=True)
class MarkerProcessing:
    """What was done to the marker trajectories before gc_ocp read them (its own gap filling
    aside). ``filtered``: the lab low-passed them (stop band at the top of the median spectrum of
    the marker coordinates, or a floor below any camera's noise); ``lowpass_hz``: its cutoff [Hz]
    (approximate: read against an f^-7 trajectory, :data:`MARKER_SLOPE`), ``None`` when not
    filtered or not measurable; ``noise_std``: [m] white-equivalent level of the top of the
    spectrum when not filtered (an upper bound of the noise if motion reaches it);
    ``native_rate_hz``/``interpolation`` as for plates; ``n_channels``: coordinates read."""

    rate_hz: float
    filtered: bool
    lowpass_hz: float | None
    lowpass_basis: str
    noise_std: float | None
    native_rate_hz: float | None
    interpolation: str
    n_channels: int

    def findings(self) -> list[str]:
        out = []
        if self.lowpass_hz is not None:
            out.append(f"low-passed by the lab at ~{self.lowpass_hz:.0f} Hz before export")
        elif self.filtered:
            out.append("low-passed by the lab; the cutoff is not measurable from the spectrum")
        elif self.noise_std is not None:
            out.append(f"raw: a noise floor reaches Nyquist ({self.noise_std * 1e3:.2g} mm)")
        else:
            out.append("not enough valid data to tell")
        if self.native_rate_hz is not None:
            out.append(
                f"{self.interpolation} interpolation of {self.native_rate_hz:.0f} Hz frames "
                f"to {self.rate_hz:.0f} Hz"
            )
        return out


@dataclass(frozen=True)
class Processing:
    """Per trial: ``plates`` by plate name and ``markers``; ``source`` names the files."""

    source: str
    plates: dict[str, PlateProcessing] = field(default_factory=dict)
    markers: MarkerProcessing | None = None

    def to_json(self) -> dict:
        """Plain, JSON-serialisable dict (floats rounded to 4 significant digits)."""
        return _rounded(
            {
                "source": self.source,
                "plates": {
                    k: asdict(v) | {"resampled": v.resampled} for k, v in self.plates.items()
                },
                "markers": None if self.markers is None else asdict(self.markers),
            }
        )

    def summary(self) -> str:
        """One line per finding."""
        lines = [f"Processing detected in {self.source}:"]
        for name, p in self.plates.items():
            lines += [f"  plate {name}: {s}" for s in p.findings()]
        if self.markers is not None:
            lines += [f"  markers: {s}" for s in self.markers.findings()]
        return "\n".join(lines)


def _rounded(x):
    if isinstance(x, float | np.floating):
        return float(f"{float(x):.4g}") if np.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _rounded(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_rounded(v) for v in x]
    if isinstance(x, np.bool_):
        return bool(x)
    return x


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open ``[a, b)`` runs where ``mask`` is True."""
    d = np.diff(np.concatenate([[0], np.asarray(mask, dtype=np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True))


def mean_rate(time: np.ndarray) -> float:
    """Sampling rate [Hz] as samples over duration: robust to a time column rounded to fewer
    digits than its step (a 600 Hz MOT written to 0.1 ms has steps of 1.6 and 1.7 ms)."""
    return float((time.size - 1) / (time[-1] - time[0]))


# --- plates ------------------------------------------------------------------------------------


def held_level(fz: np.ndarray, n_min: float) -> float | None:
    """The level at which ``fz`` is held exactly (the same number) for at least ``n_min``
    samples in a row, within :data:`RESIDUE_MAX` of 0: 0 for a plain zeroing, minus an offset
    removed after it; the level holding most such samples when several do; None without one."""
    fz = np.asarray(fz, dtype=float)
    if fz.size < 2:
        return None
    same = np.concatenate([[False], fz[1:] == fz[:-1]])  # equal to the sample before
    held: dict[float, int] = {}
    for a, b in _runs(same):  # samples a-1 .. b-1 hold one value
        if b - a + 1 >= n_min and abs(fz[a]) <= RESIDUE_MAX:
            held[float(fz[a])] = held.get(float(fz[a]), 0) + b - a + 1
    return max(held, key=held.get) if held else None


def fz_run_min(rate: float | None = None) -> float:
    """Shortest run [samples] of a vertical force held at one level taken as zeroing:
    :data:`FZ_ZERO_RUN_MIN`, and :data:`FZ_ZERO_RUN_TIME` at ``rate`` [Hz] when it is known."""
    return FZ_ZERO_RUN_MIN if rate is None else max(FZ_ZERO_RUN_MIN, FZ_ZERO_RUN_TIME * rate)


def exact_zero_runs(wrench: np.ndarray, rate: float | None = None) -> np.ndarray:
    """Mask ``(n,)`` of the samples of ``wrench`` ``(n, 6)`` where all channels are exactly 0,
    when at least one such run reaches :data:`ZERO_RUN_MIN` samples; or where the vertical force
    alone is held at its zeroing level (exactly 0, or a small residue: :func:`held_level`), when
    one such run reaches :data:`FZ_ZERO_RUN_MIN` samples and (``rate`` [Hz] given)
    :data:`FZ_ZERO_RUN_TIME` (a threshold applied to Fz only: the other channels keep their
    noise, and Fz is as censored; or an offset removed after the zeroing); all False without
    either."""
    level = held_level(wrench[:, 2], fz_run_min(rate))
    if level is not None:
        return np.asarray(wrench[:, 2] == level)
    zero = np.all(wrench == 0.0, axis=1)
    if not any(b - a >= ZERO_RUN_MIN for a, b in _runs(zero)):
        return np.zeros(zero.shape, dtype=bool)
    return zero


def zero_threshold(fz: np.ndarray, zero: np.ndarray) -> tuple[float | None, str]:
    """The threshold [N] below which ``fz`` was zeroed (``zero``: the exact-zero samples) and how
    the force leaves the zero runs (see :class:`PlateProcessing`): ``"filter tail"`` when at
    least :data:`TAIL_SHARE` of the edges are, with the sample beyond them, below any plate's
    resolution (:data:`PLATE_NOISE_MIN`: only a recursive filter's response decaying into the
    zeroed stretches makes such numbers; a single one is round-off), else ``"step"`` when most
    edges jump from 0 by more than twice the next sample's change (a lone sample between zero
    runs counts as a step), else ``"continuous"``.

    The threshold is the smallest |fz| of the samples kept (finite, outside the zero runs): a
    threshold keeps no sample below it, and the first kept sample next to a run is within one
    sample's rise of it. Not the smallest edge alone: exact zeros inside a load (the plate lost
    its signal for a moment) have edges of hundreds of N, and a raw plate with such a dropout
    read as "zeroed below 562 N" was censored there. An edge next to a missing (non-finite)
    sample is no edge (a NaN there made the threshold NaN)."""
    fz = np.asarray(fz, dtype=float)
    kept = ~np.asarray(zero, dtype=bool) & np.isfinite(fz)
    step, tail = [], []
    for a, b in _runs(zero):
        for i, j in ((a - 1, a - 2), (b, b + 1)):  # the non-zero sample next to the run, its next
            if not (0 <= i < fz.size and kept[i]):
                continue  # the file's end, or a missing sample
            if 0 <= j < fz.size and kept[j]:
                step.append(abs(fz[i]) > 2.0 * abs(fz[i] - fz[j]))
                # a tail decays over many samples: the next one is below 1 mN too
                tail.append(max(abs(fz[i]), abs(fz[j])) < PLATE_NOISE_MIN)
            elif not (0 <= j < fz.size) or zero[j]:
                step.append(True)  # one sample between zeros: above the threshold alone
                tail.append(False)
    if not step:
        return None, ""
    low = float(np.min(np.abs(fz[kept])))
    if np.mean(tail) >= TAIL_SHARE:
        return low, "filter tail"
    return low, "step" if np.mean(step) >= 0.5 else "continuous"


def unloaded_windows(fz: np.ndarray, rate: float, zero: np.ndarray) -> np.ndarray:
    """Boolean ``(n_windows,)``: the :data:`BASELINE_WINDOW` windows of ``fz`` that are quiet
    (standard deviation below max(2 N, 3 x the quietest window), as the loader's baseline) and
    unloaded (mean |Fz| < :data:`UNLOADED_MAX`) and hold no exactly-zeroed sample."""
    n = max(int(round(BASELINE_WINDOW * rate)), 2)
    nw = fz.size // n
    if nw == 0:
        return np.zeros(0, dtype=bool)
    w = fz[: nw * n].reshape(nw, n)
    std = w.std(axis=1)
    ok = ~zero[: nw * n].reshape(nw, n).any(axis=1)
    if not ok.any():
        return ok
    ok &= std >= PLATE_NOISE_MIN  # quieter than any plate: a filter's tail, not noise
    if not ok.any():
        return ok
    quiet = std < max(2.0, 3.0 * float(std[ok].min()))
    return ok & quiet & (np.abs(w.mean(axis=1)) < UNLOADED_MAX)


def _offsets(fz, rate, unloaded) -> tuple[tuple[float, float, float], ...]:
    n = max(int(round(BASELINE_WINDOW * rate)), 2)
    if unloaded.size == 0:
        return ()
    w = fz[: unloaded.size * n].reshape(-1, n)
    mean, sem = w.mean(axis=1), w.std(axis=1) / np.sqrt(n)
    # not next to a load: the window where a stance's force tapers to 0 has a small mean and, on
    # a noisy plate (mains hum), a std within the quiet limit; it reads a load, not an offset
    load = np.abs(w).max(axis=1) >= UNLOADED_MAX
    near = load | np.concatenate([[False], load[:-1]]) | np.concatenate([load[1:], [False]])
    off = unloaded & ~near & (np.abs(mean) > np.maximum(OFFSET_TOL, 3.0 * sem))
    return tuple((a * n / rate, b * n / rate, float(np.mean(mean[a:b]))) for a, b in _runs(off))


def cop_held_below(plate: Plate, zero: np.ndarray) -> float | None:
    """[N] The largest vertical load at which the plate's COP is held: equal to the previous
    sample's to 1 nm while Fz changes, for :data:`ZERO_RUN_MIN` steps in a row or more (an
    exporter or loader replaced an unreliable COP by a neighbouring one, e.g. OpenSim MOT files
    read by ``gc_ocp.io.opensim``). ``None`` without such a run: a measured COP does not repeat
    to 1 nm five times in a row while the load changes (a COP written with few decimals may,
    once or twice, near a still point)."""
    cop = plate.cop(min_vertical=PLATE_NOISE_MIN)[:, :2]
    fz = plate.force[:, 2]
    with np.errstate(invalid="ignore"):
        same = np.all(np.abs(np.diff(cop, axis=0)) < 1e-9, axis=1) & (np.diff(fz) != 0.0)
    same &= ~zero[1:] & ~zero[:-1]
    # a run of equal steps [a, b) spans samples a..b; one end is the sample whose COP was kept
    runs = [(a + 1, b) for a, b in _runs(same) if b - a >= ZERO_RUN_MIN]
    if not runs:
        return None
    return float(max(np.max(np.abs(fz[a:b])) for a, b in runs))


def detect_plate_processing(plate: Plate, marker_rate: float | None = None) -> PlateProcessing:
    """What was done to ``plate``'s data (:class:`PlateProcessing`); ``marker_rate`` [Hz] for the
    at-marker-rate check."""
    rate = mean_rate(np.asarray(plate.time))
    wrench = np.hstack([plate.force, plate.moment])
    fz = np.asarray(plate.force[:, 2], dtype=float)
    zero = exact_zero_runs(wrench, rate)
    threshold, edges = zero_threshold(fz, zero) if zero.any() else (None, "")
    loaded = [(a, fz[a:b]) for a, b in _runs(~zero & np.isfinite(fz))]

    unloaded = unloaded_windows(fz, rate, zero)
    n = max(int(round(BASELINE_WINDOW * rate)), 2)
    quiet = np.zeros(fz.size, dtype=bool)
    quiet[: unloaded.size * n] = np.repeat(unloaded, n)
    noise_segs = [fz[a:b] - np.mean(fz[a:b]) for a, b in _runs(quiet)]
    longest = max((len(s) for s in noise_segs), default=0)
    nper_noise = 2 ** int(np.log2(max(min(rate, longest), 16)))  # 1 s at most
    noise = sp.band_spectrum(noise_segs, rate, nper_noise, prewhiten=0)
    nper = sp.window_length(rate, PLATE_WINDOW)

    # zeroed, then low-passed: the unloaded stretches hold the filter's response to the zeroing
    # (its tails), not the plate's noise, which the zeroing removed
    use_noise = (
        noise is not None and noise.n_windows >= NOISE_MIN_WINDOWS and edges != "filter tail"
    )
    spec = noise if use_noise else sp.band_spectrum([s for _, s in loaded], rate, nper)
    lowpass, basis, noise_std, filtered = None, "", None, False
    if spec is not None:
        floor = sp.white_std(spec.top_level(), rate)
        filtered = (
            spec.top_fall() >= STOP_BAND_FALL or floor < PLATE_NOISE_MIN or edges == "filter tail"
        )
        if filtered and use_noise:
            lowpass, basis = sp.plateau_cutoff(spec), "unloaded noise"
        elif filtered:
            lowpass, basis = sp.trend_cutoff(spec, FORCE_SLOPE), "force spectrum"
        if use_noise:
            noise_std = float(np.median([np.std(s) for s in noise_segs]))
        elif not filtered:
            noise_std = floor
        basis = basis if lowpass else ""

    interp = interpolation_factor([(a, s) for a, s in loaded if s.size > 3 * MAX_FACTOR])
    held = cop_held_below(plate, zero)
    parts = []
    if edges == "step":
        parts.append((threshold, "zero threshold"))
    if noise_std is not None:
        parts.append((COP_NOISE_FACTOR * noise_std, f"{COP_NOISE_FACTOR:g} x Fz noise"))
    if held is not None:
        parts.append((held, "COP held constant below this load in the data"))
    cop, cop_basis = (
        max(parts)
        if parts
        else (COP_FALLBACK, "no threshold or noise measurable: contact threshold")
    )
    off = plate.zero_offset
    return PlateProcessing(
        name=plate.name,
        rate_hz=rate,
        zero_threshold=threshold,
        zero_edges=edges,
        zeroed_fraction=float(zero.mean()),
        filtered=bool(filtered),
        lowpass_hz=lowpass,
        lowpass_basis=basis,
        noise_std=noise_std,
        native_rate_hz=None if interp is None else rate / interp[0],
        interpolation="" if interp is None else DEGREES[interp[1]],
        at_marker_rate=marker_rate is not None
        and rate < PLATE_RATE_MIN
        and abs(rate / marker_rate - 1.0) < 0.01,
        zero_offset=None if off is None else tuple(float(v) for v in off),
        unloaded_offsets=_offsets(fz, rate, unloaded),
        cop_held_below=held,
        cop_min_load=float(cop),
        cop_min_load_basis=cop_basis,
        zero_level=float(fz[zero][0]) if zero.any() else 0.0,
    )


# --- markers -----------------------------------------------------------------------------------


def detect_marker_processing(markers: np.ndarray, time: np.ndarray) -> MarkerProcessing:
    """What was done to marker trajectories ``markers`` ``(n_frames, n_markers, 3)`` [m] sampled
    at ``time`` ``(n_frames,)`` [s] (NaN where missing)."""
    rate = mean_rate(np.asarray(time))
    x = np.asarray(markers, dtype=float).reshape(len(time), -1)
    nper = sp.window_length(rate, min(MARKER_WINDOW, x.shape[0] / (2.0 * rate)))
    spectra, channels = [], []
    for j in range(x.shape[1]):
        segs = [(a, x[a:b, j]) for a, b in _runs(np.isfinite(x[:, j]))]
        long = [(a, s) for a, s in segs if s.size >= nper + sp.PREWHITEN]
        if not long or max(np.std(np.diff(s, 2)) for _, s in long) < 1e-9:
            continue  # missing, or a computed point moving without noise
        spectra.append(sp.band_spectrum([s for _, s in long], rate, nper))
        channels.append(long)
    spec = sp.median_spectrum(spectra)
    lowpass, basis, noise_std, filtered = None, "", None, False
    if spec is not None:
        floor = sp.white_std(spec.top_level(), rate)
        filtered = spec.top_fall() >= STOP_BAND_FALL or floor < MARKER_NOISE_MIN
        if filtered:
            lowpass = sp.trend_cutoff(spec, MARKER_SLOPE)
            basis = "marker spectrum" if lowpass else ""
        else:
            noise_std = floor
    votes = [interpolation_factor(c) for c in channels]
    found = [v for v in votes if v is not None]
    interp = max(set(found), key=found.count) if len(found) > len(votes) / 2 else None
    return MarkerProcessing(
        rate_hz=rate,
        filtered=bool(filtered),
        lowpass_hz=lowpass,
        lowpass_basis=basis,
        noise_std=noise_std,
        native_rate_hz=None if interp is None else rate / interp[0],
        interpolation="" if interp is None else DEGREES[interp[1]],
        n_channels=len(spectra),
    )


def detect_processing(trial: Trial) -> Processing:
    """What the lab's processing did to ``trial``'s plates and markers (:class:`Processing`)."""
    source = str(trial.source) + (f" + {trial.grf_source}" if trial.grf_source else "")
    plates = {p.name: detect_plate_processing(p, trial.marker_rate) for p in trial.plates}
    return Processing(
        source=source,
        plates=plates,
        markers=detect_marker_processing(trial.markers, trial.marker_time),
    )


# --- what the measurement model uses -----------------------------------------------------------


def censor_threshold(plate: PlateProcessing | None) -> float:
    """The threshold [N] below which the measurement model censors this plate's samples
    (:mod:`gc_ocp.estimation.measurement`): its zero threshold when the force steps from 0 to
    it (``zero_edges == "step"``), else 0. A force that leaves 0 continuously was not cut at a
    level (nothing to censor beyond the zeros, which a model predicting ~0 there fits anyway);
    one zeroed and then filtered has lost its level (the zeros are still data the model must
    meet)."""
    if plate is None or plate.zero_threshold is None or plate.zero_edges != "step":
        return 0.0
    return float(plate.zero_threshold)


def stance_censor_threshold(plate_wrench: np.ndarray | None) -> float:
    """:func:`censor_threshold` of a stance's own plate signal (``StanceData.plate_wrench``: the
    stance and 0.1 s around it at the plate's rate): for stances not cut from a trial here (e.g.
    simulated), where no whole plate recording is at hand. Two edges instead of every edge of the
    plate: the estimate is the smallest value the window keeps (an upper bound of the lab's
    threshold, within one sample's rise)."""
    if plate_wrench is None or len(plate_wrench) == 0:
        return 0.0
    w = np.asarray(plate_wrench, float)
    zero = exact_zero_runs(w)
    if not zero.any():
        return 0.0
    thr, edges = zero_threshold(w[:, 2], zero)
    return float(thr) if thr is not None and edges == "step" else 0.0
