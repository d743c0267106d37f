"""The mismatch family: small random differences between a truth and the package's model that
are *not* candidate effects (``docs/diagnosis.md``, "Mismatch family").

A real foot on a real plate never matches the model exactly, even when no effect of
``docs/effects.md`` is at work: the law's smoothing is a numerical choice, the lab filters its
markers and thresholds its plates its own way, the sole's units sit a few millimetres from where
the layout puts them. A diagnosis that claims an effect on such data makes a false claim. The
family describes those differences with documented ranges (:class:`MismatchFamily`); one random
member is a :class:`MismatchDraw`, plain data. Applying a draw:

* :func:`truth_variant`: the truth model with the drawn law smoothing (width and form of the
  penetration and of the friction direction), other components unchanged;
* :func:`true_motion`: the stances the **truth** is simulated on (its units moved off the
  layout); the fitter keeps the nominal layout;
* :func:`seen_motion`: the foot kinematics the **fitter** sees (low-passed at the drawn cutoff,
  soft-tissue drift, marker noise), on the nominal layout;
* :func:`plate_processing`: the plate as the lab records it (mains hum, zero threshold);
* :func:`simulate_mismatched`: all of it, the data a fitter gets from a truth model on stances
  (what a parametric-bootstrap null of the diagnosis draws: its fitted parent model, frozen,
  as the truth, the subject's stances as the motion).

Members that would be a candidate effect of the fitter's model are left out
(:meth:`MismatchDraw.for_model`): moved units are ``sole_geometry`` and kinematic errors are
``kinematic_correction`` for a model without sole or pose registration (the bare seed base).

``scale`` shrinks every member towards the model (0: none; 1: the documented family) with the
same random numbers, so draws at several scales of one seed are paired.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from types import MappingProxyType

import numpy as np
from scipy.signal import butter, filtfilt
from scipy.spatial.transform import Rotation

from gc_ocp.contact.laws import PENETRATION_FORMS, SLIP_FORMS
from gc_ocp.errors import InputError
from gc_ocp.estimation.components import REGISTRY
from gc_ocp.estimation.result import EstimationResult
from gc_ocp.estimation.synthetic import (
    PLATE_NOISE_PCT_BW,
    TORQUE_NOISE_LENGTH,
    noisy_pose,
    simulate,
    with_pose_error,
)
from gc_ocp.foot import SEED_LAYOUT, FootKinematics, SoleLayout
from gc_ocp.stance import StanceData
from gc_ocp.trial import SIDES

MEMBER_CANDIDATES: Mapping[str, str] = MappingProxyType(
    {"unit_offsets": "sole_geometry", "kinematics": "kinematic_correction"}
)
"""Members of the family that *are* a registered candidate effect for a model without it:
units off the layout (``sole_geometry``), the kinematic errors: low-pass, drift, marker noise
(``kinematic_correction``). :meth:`MismatchDraw.for_model` leaves them out for such a model."""

FILTER_ORDER = 4
"""Effective order of the zero-lag Butterworth low-pass of :func:`lowpassed` (``filtfilt`` of a
second-order design, as :func:`gc_ocp.kinematics.filtering.lowpass` does)."""


PLATE_OFFSET: tuple[float, float] = (2e-3, 5e-3)
"""The plate calibration member's misplacement of a stance's plate [m] when it is on
(:meth:`MismatchFamily.with_plate_calibration`): a few millimetres, what in-situ calibration
methods are made to correct (Collins et al. 2009, Gait Posture 29:59)."""

PLATE_GAIN = 0.02
"""The plate calibration member's largest gain error of a channel [-] when it is on: a
percent or two, the same source."""


def _plates_on(plate_offset: tuple[float, float], plate_gain: float) -> bool:
    """The plate calibration member is on: a misplacement range or a gain error above 0 (the
    one rule of :attr:`MismatchFamily.plate_calibration` and
    :attr:`MismatchDraw.plate_calibration`)."""
    return plate_offset[1] > 0 or plate_gain > 0


def _range(name: str, r: tuple[float, float], positive: bool = True) -> None:
    lo, hi = r
    if not (lo <= hi and (lo > 0 if positive else lo >= 0)):
        need = "0 < lo <= hi" if positive else "0 <= lo <= hi"
        raise InputError(f"MismatchFamily.{name} must be a range (lo, hi) with {need}, but got {r}")


@dataclasses.dataclass(frozen=True)
class MismatchFamily:
    """The documented family of small truth-model differences that are not candidate effects.

    Each member, its range at ``scale`` = 1, and why (``docs/diagnosis.md``, "Mismatch family"):

    * **penetration smoothing**, width factor ``depth_factor`` log-uniform in [0.5, 2] around
      the law's ``depth_smoothing`` (0.5 mm: 0.25-1 mm), the other form (``"softplus"``, same
      value and slope at contact, exponential instead of algebraic tails,
      :mod:`gc_ocp.contact.laws`) with probability ``p_depth_form`` = 0.5. The width is a
      numerical device, not a measured property: it is below what foot kinematics resolve
      (skin-marker jitter after filtering 0.5-1 mm, Chiari et al. 2005, Gait Posture 21:197;
      soft-tissue motion 1-4 mm, Nester et al. 2007) and a shoe's touch-down transition (tread,
      floor roughness, a fraction of a millimetre to a millimetre) has no preferred shape. A
      factor 2 either way keeps it at most a fifth of the 5 mm reference depth.
    * **friction regularisation**, width factor ``slip_factor`` log-uniform in [0.5, 2] around
      ``slip_smoothing`` (5 cm/s: 2.5-10 cm/s), the ``"tanh"`` form (same slope at zero
      sliding, same limit) with probability ``p_slip_form`` = 0.5. It stands for the shoe's
      pre-sliding regime, which skin markers cannot see: the loaded units' apparent sliding
      speeds (1-14 cm/s on the bundled trial) are mostly marker artefact. Both regularisations
      are in use in smooth contact models (algebraic here and in the seed study; tanh in e.g.
      OpenSim's smooth sphere contacts).
    * **plate zero threshold**: none with probability 1 - ``p_threshold`` (raw export), else
      ``threshold_n`` uniform in [5, 40] N: labs zero the plate below a few times its unloaded
      noise (about 1 N) and its drift to cut signal outside contact; 10-20 N are common choices.
    * **mains hum**: a sinusoid at 50 or 60 Hz (``hum_frequencies_hz``, the mains of the lab's
      country), amplitude ``hum_amplitude_n`` uniform in [0.5, 3] N on each force channel (the
      moments: times :data:`~gc_ocp.estimation.synthetic.TORQUE_NOISE_LENGTH`), a random phase
      per stance and channel: the order of an unloaded plate's noise floor; a larger hum shows
      in every unloaded recording and is fixed before data are taken. The frames sample it at
      their times (aliased), as a pipeline that reads a plate's samples at the frames does;
      gc_ocp's own low-passes them for the frames first (:mod:`gc_ocp.antialias`), which
      removes a hum above the frames' Nyquist frequency: the member allows for more than the
      package's reading of a trial leaves (a conservative null; kept so that the calibration
      measured with it stands).
    * **marker low-pass**: the fitter sees the foot pose low-passed (zero lag, 4th order) at a
      cutoff ``cutoff_hz`` uniform in [4, 10] Hz: the choices of walking labs (Winter's
      residual analysis gives 4-7 Hz for lower-limb markers; 6 Hz is the common default, up to
      10 Hz to keep heel-strike content).
    * **marker noise and soft-tissue drift** (:func:`~gc_ocp.estimation.synthetic.noisy_pose`,
      :func:`drift`): noise ``marker_noise`` uniform in [0.25, 1] mm per virtual marker,
      drift ``drift_translation`` uniform in [1, 4] mm and ``drift_rotation_deg`` in
      [0.25, 1] deg RMS per axis, ``stride_variation`` 0.25: the sources of the benchmark's
      realism (optoelectronic noise 0.1-0.5 mm and skin jitter 0.5-1 mm, Chiari et al. 2005;
      foot markers move 1-4 mm against the bones, Nester et al. 2007, Gait Posture 25:406,
      Leardini et al. 2005, Gait Posture 21:212), its values (0.5 mm, 2 mm, 0.5 deg) inside.
    * **units off the layout**: each true unit's local point moved by ``unit_offset_sd`` = 2 mm
      per axis, iid normal per side, unit and axis (3.5 mm in 3-D): a unit is a lumped point
      for a sole region 4-8 cm across, and where that region's load acts relative to the markers
      that place it varies by a few millimetres between subjects and shoes; within the sole
      correction's prior (5 mm), so a model with sole registration can register it.

    * **plate calibration** (off by default: ``plate_offset`` = (0, 0), ``plate_gain`` = 0; an
      opt-in member, 2026-12-01): each stance's plate placed ``plate_offset`` [m] (uniform in the
      range, a random horizontal direction) from where the lab takes it to be (its centre of
      pressure moved by that vector: the moment about the reference point gains ``d x F``) and
      its force and moment channels scaled by a gain error uniform in +-``plate_gain`` per
      axis, one plate per stance (overground stances are on different plates). A few
      millimetres and a percent or two are the errors in-situ calibration methods are made to
      correct (e.g. Collins et al. 2009, Gait Posture 29:59). Drawn from its own seed
      (:attr:`MismatchDraw.plate_seed`, from a child generator) so that, on or off, no other
      member's random numbers change, in that draw or the draws after it (paired). Why it
      exists: with plates 2-5 mm off and channels within 2 %, the documented family alone gave
      1 false claim in 16 "none" cases (the clock offset, p 0.88 -> 0.044 on one), with this
      member in the null 0 of 16 (``benchmarks/out_of_family_output.md``). Why it is off: in
      the null it makes the clock offset and the ground offset undecidable and triples the
      steps the stiffness field needs on the bundled motion, and turns one of nine real-data
      answers inconclusive (``benchmarks/plate_member_power/README.md``); the default null
      takes the plates as calibrated, and a claim of an effect they mimic says so
      (:func:`gc_ocp.diagnosis.diagnose.plate_note`). On: :meth:`with_plate_calibration`.

    ``scale`` >= 0 shrinks every member towards the model with the same random numbers: a
    width factor ``f`` becomes ``f ** scale``, sizes (threshold, hum, noise, drift, offsets) are
    multiplied by ``scale``, the cutoff divided by it (no filtering at 0), and the other forms
    are drawn with probability ``p * scale`` (at most 1). Probabilities and ranges are fields, so
    a study can narrow or widen a member; the defaults are the documented family.
    """

    scale: float = 1.0
    depth_factor: tuple[float, float] = (0.5, 2.0)
    p_depth_form: float = 0.5
    depth_forms: tuple[str, ...] = ("softplus",)
    slip_factor: tuple[float, float] = (0.5, 2.0)
    p_slip_form: float = 0.5
    slip_forms: tuple[str, ...] = ("tanh",)
    p_threshold: float = 0.5
    threshold_n: tuple[float, float] = (5.0, 40.0)
    hum_frequencies_hz: tuple[float, ...] = (50.0, 60.0)
    hum_amplitude_n: tuple[float, float] = (0.5, 3.0)
    cutoff_hz: tuple[float, float] = (4.0, 10.0)
    marker_noise: tuple[float, float] = (0.25e-3, 1.0e-3)
    drift_translation: tuple[float, float] = (1e-3, 4e-3)
    drift_rotation_deg: tuple[float, float] = (0.25, 1.0)
    stride_variation: float = 0.25
    unit_offset_sd: float = 2e-3
    plate_offset: tuple[float, float] = (0.0, 0.0)
    plate_gain: float = 0.0

    @property
    def plate_calibration(self) -> bool:
        """The plate calibration member is on (:attr:`plate_offset` or :attr:`plate_gain`)."""
        return _plates_on(self.plate_offset, self.plate_gain)

    def with_plate_calibration(self) -> MismatchFamily:
        """This family with its plate calibration member on at the documented sizes
        (:data:`PLATE_OFFSET`, :data:`PLATE_GAIN`)."""
        return dataclasses.replace(self, plate_offset=PLATE_OFFSET, plate_gain=PLATE_GAIN)

    def to_json(self) -> dict:
        """The family as JSON-able plain data (lists for tuples; what ``diagnosis.json`` and a
        benchmark's settings record); :meth:`from_json` reads it."""
        return {
            k: list(v) if isinstance(v, tuple) else v for k, v in dataclasses.asdict(self).items()
        }

    @classmethod
    def from_json(cls, data: Mapping) -> MismatchFamily:
        """The family written by :meth:`to_json` (fields it lacks keep their defaults)."""
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in data.items()})

    def __post_init__(self) -> None:
        if not self.scale >= 0:
            raise InputError(f"MismatchFamily.scale must be >= 0, but got {self.scale}")
        for name in ("depth_factor", "slip_factor", "threshold_n", "cutoff_hz"):
            _range(name, getattr(self, name))
        for name in (
            "hum_amplitude_n",
            "marker_noise",
            "drift_translation",
            "drift_rotation_deg",
            "plate_offset",
        ):
            _range(name, getattr(self, name), positive=False)
        for name in ("p_depth_form", "p_slip_form", "p_threshold"):
            if not 0 <= getattr(self, name) <= 1:
                raise InputError(
                    f"MismatchFamily.{name} must be a probability in [0, 1], but got "
                    f"{getattr(self, name)}"
                )
        for name, forms, admissible in (
            ("depth_forms", self.depth_forms, PENETRATION_FORMS[1:]),
            ("slip_forms", self.slip_forms, SLIP_FORMS[1:]),
        ):
            bad = [f for f in forms if f not in admissible]
            if not forms or bad:
                raise InputError(
                    f"MismatchFamily.{name} must name other forms than the model's default, from "
                    f"{admissible}, but got {forms}"
                )
        if not self.hum_frequencies_hz or min(self.hum_frequencies_hz) <= 0:
            raise InputError(
                f"MismatchFamily.hum_frequencies_hz must be positive frequencies [Hz], but got "
                f"{self.hum_frequencies_hz}"
            )
        if not 0 <= self.plate_gain < 1:
            raise InputError(
                f"MismatchFamily.plate_gain must be a relative gain error in [0, 1), but got "
                f"{self.plate_gain}"
            )
        if not (self.stride_variation >= 0 and self.unit_offset_sd >= 0):
            raise InputError(
                "MismatchFamily.stride_variation and unit_offset_sd must be >= 0, but got "
                f"{self.stride_variation} and {self.unit_offset_sd}"
            )

    def draw(self, rng: np.random.Generator, layout: SoleLayout = SEED_LAYOUT) -> MismatchDraw:
        """One member of the family: every member drawn, the units of ``layout`` moved on both
        feet. The random numbers used do not depend on ``scale`` (paired draws): 14 uniforms,
        one or two per member in the order of the fields, then the offsets. With the plate
        calibration member on, the seed of the plates' errors comes from a child of ``rng``
        (``rng.spawn``), which leaves ``rng``'s stream as it is: on or off, every other member
        of this draw and of the draws made after it from ``rng`` is the same (paired)."""
        u = iter(rng.uniform(size=14))
        z = rng.standard_normal((len(SIDES), layout.n, 3))
        s = self.scale

        def pick(options):
            return options[min(int(next(u) * len(options)), len(options) - 1)]

        def uniform(r):
            return float(np.interp(next(u), [0, 1], r))

        def log_uniform(r):  # the factor's logarithm is uniform, and scaled
            return float(np.exp(s * np.interp(next(u), [0, 1], np.log(r))))

        def form(p, forms):  # another form with probability p * scale, else the model's
            other = next(u) < min(p * s, 1.0)
            chosen = pick(forms)
            return chosen if other else None

        # in this order (one stream: the same numbers at every scale)
        depth_factor = log_uniform(self.depth_factor)
        depth_form = form(self.p_depth_form, self.depth_forms)
        slip_factor = log_uniform(self.slip_factor)
        slip_form = form(self.p_slip_form, self.slip_forms)
        threshold_on = next(u) < self.p_threshold
        threshold = uniform(self.threshold_n)
        hum_frequency = float(pick(self.hum_frequencies_hz))
        hum_amplitude = uniform(self.hum_amplitude_n)
        cutoff = uniform(self.cutoff_hz)
        noise = uniform(self.marker_noise)
        drift_m = uniform(self.drift_translation)
        drift_deg = uniform(self.drift_rotation_deg)
        offsets = s * self.unit_offset_sd * z
        # from a child generator: ``rng``'s own stream does not move (>= 1, 0 meaning "off")
        plate_seed = int(rng.spawn(1)[0].integers(1, 2**62)) if self.plate_calibration else 0
        return MismatchDraw(
            scale=s,
            depth_factor=depth_factor,
            depth_form=depth_form,
            slip_factor=slip_factor,
            slip_form=slip_form,
            threshold_n=s * threshold if threshold_on else 0.0,
            hum_frequency_hz=hum_frequency,
            hum_amplitude_n=s * hum_amplitude,
            cutoff_hz=cutoff / s if s > 0 else None,
            marker_noise=s * noise,
            drift_translation=s * drift_m,
            drift_rotation_deg=s * drift_deg,
            stride_variation=self.stride_variation,
            units=layout.units,
            unit_offsets={
                side: tuple(tuple(float(v) for v in row) for row in offsets[j])
                for j, side in enumerate(SIDES)
            },
            plate_offset=(s * self.plate_offset[0], s * self.plate_offset[1]),
            plate_gain=s * self.plate_gain,
            plate_seed=plate_seed,
        )


@dataclasses.dataclass(frozen=True)
class MismatchDraw:
    """One member of the :class:`MismatchFamily`, plain data (``to_json`` / ``from_json``).

    scale: the family's scale it was drawn at; depth_factor, slip_factor: the law's smoothing
    widths relative to the model's [-]; depth_form, slip_form: their forms (None: the model's
    own); threshold_n: plate zero threshold on the vertical force [N] (0: none);
    hum_frequency_hz [Hz], hum_amplitude_n [N]: mains hum on each force channel (0: none);
    cutoff_hz: marker low-pass cutoff of the seen kinematics [Hz] (None: not filtered);
    marker_noise [m], drift_translation [m], drift_rotation_deg [deg], stride_variation [-]:
    the seen kinematics' errors (:func:`seen_motion`); units, unit_offsets: the true units'
    offsets from the layout in their parent frames, ``{side: ((x, y, z) per unit)}`` [m];
    off: the members left out for a model (:meth:`for_model`); plate_offset [m], plate_gain
    [-], plate_seed: the plate calibration member's range, size and seed (0: off; each stance's
    errors are drawn from the seed in :func:`plate_processing`).
    """

    scale: float
    depth_factor: float
    depth_form: str | None
    slip_factor: float
    slip_form: str | None
    threshold_n: float
    hum_frequency_hz: float
    hum_amplitude_n: float
    cutoff_hz: float | None
    marker_noise: float
    drift_translation: float
    drift_rotation_deg: float
    stride_variation: float
    units: tuple[str, ...]
    unit_offsets: dict[str, tuple[tuple[float, float, float], ...]]
    off: tuple[str, ...] = ()
    plate_offset: tuple[float, float] = (0.0, 0.0)
    plate_gain: float = 0.0
    plate_seed: int = 0

    @property
    def plate_calibration(self) -> bool:
        """The plate calibration member is on in this draw (:func:`miscalibrated`)."""
        return _plates_on(self.plate_offset, self.plate_gain)

    def to_json(self) -> dict:
        """The draw as JSON-able plain data (lists for tuples); :meth:`from_json` reads it."""
        out = dataclasses.asdict(self)
        out["units"] = list(self.units)
        out["unit_offsets"] = {s: [list(r) for r in o] for s, o in self.unit_offsets.items()}
        out["off"] = list(self.off)
        out["plate_offset"] = list(self.plate_offset)
        return out

    @classmethod
    def from_json(cls, data: dict) -> MismatchDraw:
        """The draw written by :meth:`to_json`."""
        d = dict(data)
        d["units"] = tuple(d["units"])
        d["unit_offsets"] = {
            s: tuple(tuple(float(v) for v in r) for r in o) for s, o in d["unit_offsets"].items()
        }
        d["off"] = tuple(d.get("off", ()))
        d["plate_offset"] = tuple(d.get("plate_offset", (0.0, 0.0)))  # a draw from before it
        return cls(**d)

    def offsets(self, side: str, layout: SoleLayout) -> np.ndarray:
        """``(m, 3)`` offsets [m] of the units of ``layout`` on ``side``."""
        missing = [u for u in layout.units if u not in self.units]
        if missing:
            raise InputError(
                f"The mismatch draw moves the units {self.units}; units {missing} of the layout "
                f"{layout.units} have no offset: draw with that layout (MismatchFamily.draw)"
            )
        rows = self.unit_offsets[side]
        return np.array([rows[self.units.index(u)] for u in layout.units], float)

    def for_model(self, model: tuple) -> MismatchDraw:
        """The draw without the members that are a candidate effect of the fitter's ``model``
        (:data:`MEMBER_CANDIDATES`: a registered candidate that ``model`` lacks, by the
        candidate's own ``present_in``): their sizes set to zero, named in ``off``."""
        off = [
            member
            for member, effect in MEMBER_CANDIDATES.items()
            if effect in REGISTRY and not REGISTRY[effect].present_in(model)
        ]
        out = self
        if "unit_offsets" in off:
            out = out.without_unit_offsets()
        if "kinematics" in off:
            out = out.without_pose_error()
            out = dataclasses.replace(out, cutoff_hz=None)
        return dataclasses.replace(out, off=tuple(sorted({*self.off, *off})))

    def without_unit_offsets(self) -> MismatchDraw:
        """The draw with every unit on the layout (its offsets zero)."""
        return dataclasses.replace(
            self,
            unit_offsets={s: tuple((0.0,) * 3 for _ in o) for s, o in self.unit_offsets.items()},
        )

    def without_pose_error(self) -> MismatchDraw:
        """The draw without marker noise and drift (e.g. when the data's kinematic error comes
        from elsewhere, as the withheld-effect benchmark's realism); the low-pass is kept."""
        return dataclasses.replace(
            self, marker_noise=0.0, drift_translation=0.0, drift_rotation_deg=0.0
        )


# --- the truth ----------------------------------------------------------------------------------


def truth_variant(model: tuple, draw: MismatchDraw) -> tuple:
    """``model`` with its contact law's smoothing as drawn (widths scaled, forms replaced), every
    other component unchanged (``Component.with_law_smoothing``, a no-op but for the law)."""
    return tuple(
        c.with_law_smoothing(draw.depth_factor, draw.slip_factor, draw.depth_form, draw.slip_form)
        for c in model
    )


def true_motion(stances: Sequence[StanceData], draw: MismatchDraw) -> list[StanceData]:
    """The stances the **truth** is simulated on: each unit's local point moved by the draw's
    offset (per side, in its parent frame). The fitter keeps the stances' own (nominal) layout
    (:func:`seen_motion`). Zero offsets return the stances themselves."""
    out = []
    for st in stances:
        off = draw.offsets(st.side, st.layout)
        if not off.any():
            out.append(st)
            continue
        out.append(st.with_foot(st.foot.with_points(st.foot.points_local + off)))
    return out


# --- what the fitter sees ---------------------------------------------------------------------


def lowpassed(foot: FootKinematics, cutoff_hz: float) -> FootKinematics:
    """``foot`` with its hindfoot pose low-passed at ``cutoff_hz`` [Hz] (zero-lag Butterworth of
    effective order :data:`FILTER_ORDER`; the origin in ``lab``, the rotation as a rotation
    vector relative to the mid-stance orientation), the toes moved with it rigidly and the
    twists made consistent (:func:`~gc_ocp.estimation.synthetic.with_pose_error`). A cutoff at
    or above the Nyquist frequency, or a stance of fewer than 10 frames, returns ``foot``.

    Only the stance window is known here, so it is filtered alone, padded by its odd reflection
    over its whole length (``filtfilt``'s ``padlen = n - 1``: the end values are kept, and the
    start-up transient is smaller than with the default 9-sample pad: at 4 Hz on the bundled
    stances the change's RMS is 1.9 mm against 2.5 mm), not as a lab filters a whole trial."""
    t = foot.time
    n = t.size
    rate = 1.0 / float(np.median(np.diff(t)))
    if cutoff_hz >= rate / 2 or n < 10:
        return foot
    b, a = butter(FILTER_ORDER // 2, cutoff_hz / (rate / 2))

    def smooth(x):
        return filtfilt(b, a, x, axis=0, padlen=n - 1)

    P = foot.hindfoot_pose
    R, o = P[:, :3, :3], P[:, :3, 3]
    R0 = R[n // 2]
    r = Rotation.from_matrix(np.einsum("ji,njk->nik", R0, R)).as_rotvec()
    Rf = np.einsum("ij,njk->nik", R0, Rotation.from_rotvec(smooth(r)).as_matrix())
    dR = Rotation.from_matrix(np.einsum("nji,njk->nik", R, Rf)).as_rotvec()
    return with_pose_error(foot, dR, smooth(o) - o)


def drift(
    stances: Sequence[StanceData],
    translation: float,
    rotation_deg: float,
    rng: np.random.Generator,
    stride_variation: float = 0.25,
    pattern: dict | None = None,
) -> list[StanceData]:
    """``stances`` with a slow rigid soft-tissue drift of the foot: per axis an offset plus a
    linear trend over the stance, RMS ~``translation`` [m] and ``rotation_deg`` per axis. The
    pattern is the foot's (soft-tissue artefacts repeat from stride to stride of a subject and
    task, Leardini et al. 2005; :func:`drift_pattern`, drawn here unless given), and each stance
    varies it by ``stride_variation`` of its size."""

    def coefficients(sd):
        return rng.normal(0.0, sd / np.sqrt(2), (2, 3))

    if pattern is None:
        pattern = drift_pattern({st.side for st in stances}, translation, rotation_deg, rng)
    out = []
    for st in stances:
        t = st.time
        s = (2 * (t - t[0]) / (t[-1] - t[0]) - 1)[:, None] * np.sqrt(3)  # unit RMS over stance
        tr, rot = pattern[st.side]
        tr = tr + stride_variation * coefficients(translation)
        rot = rot + stride_variation * coefficients(np.deg2rad(rotation_deg))
        out.append(st.with_foot(with_pose_error(st.foot, rot[0] + rot[1] * s, tr[0] + tr[1] * s)))
    return out


def drift_pattern(sides, translation: float, rotation_deg: float, rng: np.random.Generator) -> dict:
    """``{side: (translation (2, 3) [m], rotation (2, 3) [rad])}``: each foot's soft-tissue
    pattern of :func:`drift` (row 0 the offset, row 1 the trend's coefficient; translation in
    ``lab``, rotation a rotation vector in the hindfoot frame)."""
    return {
        side: (
            rng.normal(0.0, translation / np.sqrt(2), (2, 3)),
            rng.normal(0.0, np.deg2rad(rotation_deg) / np.sqrt(2), (2, 3)),
        )
        for side in sorted(sides)
    }


def seen_motion(
    stances: Sequence[StanceData], draw: MismatchDraw, rng: np.random.Generator
) -> list[StanceData]:
    """The foot kinematics the **fitter** sees of ``stances`` (the true motion on the nominal
    layout): low-passed at the draw's cutoff (:func:`lowpassed`), then drifted (:func:`drift`)
    and re-estimated from noisy markers (:func:`~gc_ocp.estimation.synthetic.noisy_pose`) at the
    draw's sizes. Members at zero draw nothing from ``rng``."""
    out = list(stances)
    if draw.cutoff_hz is not None:
        out = [st.with_foot(lowpassed(st.foot, draw.cutoff_hz)) for st in out]
    if draw.drift_translation > 0 or draw.drift_rotation_deg > 0:
        out = drift(
            out, draw.drift_translation, draw.drift_rotation_deg, rng, draw.stride_variation
        )
    if draw.marker_noise > 0:
        out = [st.with_foot(noisy_pose(st.foot, draw.marker_noise, rng)) for st in out]
    return out


# --- the plate ------------------------------------------------------------------------------


def thresholded(st: StanceData, threshold: float) -> StanceData:
    """The plate wrench (``measured`` and ``plate_wrench``) zeroed where its vertical force is
    below ``threshold`` [N]."""

    def cut(w):
        w = np.array(w, float)
        w[w[:, 2] < threshold] = 0.0
        return w

    st = st.with_measured(cut(st.measured))
    if st.plate_wrench is not None:
        st = dataclasses.replace(st, plate_wrench=cut(st.plate_wrench))
    return st


def miscalibrated(st: StanceData, draw: MismatchDraw, prng: np.random.Generator) -> StanceData:
    """``st`` recorded by a plate placed a horizontal vector ``d`` off (length uniform in
    ``draw.plate_offset``, a random direction) whose channels read ``1 + U(-g, g)`` times the
    true ones per axis (``g`` = ``draw.plate_gain``): the force and the moment scaled, the
    moment about the reference point then gaining ``d x F`` (the line of action moved by ``d``);
    on the frames and on the plate's own samples alike. Eight uniforms per stance from
    ``prng``, whatever the sizes."""
    u = prng.uniform(size=8)
    a = 2 * np.pi * u[0]
    d = float(np.interp(u[1], [0, 1], draw.plate_offset)) * np.array([np.cos(a), np.sin(a), 0.0])
    g = 1.0 + draw.plate_gain * (2 * u[2:8] - 1)

    def wrong(w):
        w = np.asarray(w, float) * g
        return np.hstack([w[:, :3], w[:, 3:] + np.cross(d, w[:, :3])])

    st = st.with_measured(wrong(st.measured))
    if st.plate_wrench is not None:
        st = dataclasses.replace(st, plate_wrench=wrong(st.plate_wrench))
    return st


def plate_processing(
    stances: Sequence[StanceData], draw: MismatchDraw, rng: np.random.Generator
) -> list[StanceData]:
    """``stances`` as the lab's plate records them: each stance's plate calibration error
    (:func:`miscalibrated`), the draw's mains hum added (a random phase per stance and channel
    from ``rng``; forces at ``hum_amplitude_n``, moments at that times
    :data:`~gc_ocp.estimation.synthetic.TORQUE_NOISE_LENGTH`), sampled at the frames and at the
    plate's own samples, then the wrench zeroed below the draw's threshold (:func:`thresholded`).
    Members at zero leave the data (and ``rng``) untouched."""
    amp = draw.hum_amplitude_n * np.array([1, 1, 1, *(3 * [TORQUE_NOISE_LENGTH])])
    prng = np.random.default_rng(draw.plate_seed)
    out = []
    for st in stances:
        if draw.plate_calibration:
            st = miscalibrated(st, draw, prng)
        if draw.hum_amplitude_n > 0:
            phase = rng.uniform(0.0, 2 * np.pi, 6)

            def hum(t, phase=phase):
                return amp * np.sin(2 * np.pi * draw.hum_frequency_hz * t[:, None] + phase)

            st = st.with_measured(st.measured + hum(st.time))
            if st.plate_wrench is not None:
                st = dataclasses.replace(st, plate_wrench=st.plate_wrench + hum(st.plate_time))
        if draw.threshold_n > 0:
            st = thresholded(st, draw.threshold_n)
        out.append(st)
    return out


# --- all of it ---------------------------------------------------------------------------------


def simulate_mismatched(
    stances: Sequence[StanceData],
    truth: tuple,
    draw: MismatchDraw,
    rng: np.random.Generator,
    plate_noise_pct_bw: float = PLATE_NOISE_PCT_BW,
    at: EstimationResult | None = None,
) -> list[StanceData]:
    """The data a fitter gets when ``truth`` (a model with fixed values, e.g. a fitted parent
    model frozen, ``estimation.frozen_model``; its per-stance components at zero, or at the
    values of ``at``, :func:`~gc_ocp.estimation.synthetic.simulate`) walks the motion of
    ``stances`` and differs from
    the model by ``draw``: the truth variant (:func:`truth_variant`) simulated on the true
    motion (:func:`true_motion`) with white plate noise
    (:func:`~gc_ocp.estimation.synthetic.simulate`), recorded by the lab's plate
    (:func:`plate_processing`), with the kinematics the fitter sees of ``stances`` on their
    nominal layout (:func:`seen_motion`). Restrict the draw to the fitter's model first
    (:meth:`MismatchDraw.for_model`)."""
    stances = list(stances)
    data = simulate(
        true_motion(stances, draw), truth_variant(truth, draw), rng, plate_noise_pct_bw, at=at
    )
    data = plate_processing(data, draw, rng)
    seen = seen_motion(stances, draw, rng)
    return [d.with_foot(s.foot) for d, s in zip(data, seen, strict=True)]


__all__ = (
    "FILTER_ORDER",
    "MEMBER_CANDIDATES",
    "MismatchDraw",
    "MismatchFamily",
    "PLATE_GAIN",
    "PLATE_OFFSET",
    "drift",
    "lowpassed",
    "plate_processing",
    "seen_motion",
    "simulate_mismatched",
    "thresholded",
    "true_motion",
    "truth_variant",
)
