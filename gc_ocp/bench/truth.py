"""The withheld-effect benchmark's truth and data: a base fitted to real motion, an effect
injected into it (each effect's own ``inject`` and ``benchmark_values``), and the plate and
marker data that truth produces with the lab realism the fitter does not know (:class:`Realism`).
The protocol is described in :mod:`gc_ocp.bench.withheld`.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence

import numpy as np

from gc_ocp.bench.recovery import bundled_base_truth, simulate, truth_from_fit
from gc_ocp.diagnosis.diagnose import resolve_base
from gc_ocp.diagnosis.mismatch import (
    MismatchDraw,
    MismatchFamily,
    drift,
    plate_processing,
    seen_motion,
    thresholded,
    true_motion,
    truth_variant,
)
from gc_ocp.errors import InputError
from gc_ocp.estimation.components import REGISTRY, base_model, candidate_effects
from gc_ocp.estimation.synthetic import noisy_pose
from gc_ocp.io import load_trial
from gc_ocp.kinematics import compute_kinematics
from gc_ocp.stance import StanceData
from gc_ocp.workflow.fitting import fit_data

MAGNITUDES = ("small", "moderate", "strong")
"""The magnitudes an effect's ``benchmark_values`` declare: "moderate" a typical value of the
literature or of real walking's fits, "strong" about twice it, "small" half the moderate's
departure from the effect's neutral value (near the diagnosis's detection limit at the
benchmark's sizes: the cases that make the steps-needed prediction, docs/diagnosis.md)."""

DEFAULT_MAGNITUDES = ("moderate", "strong")
"""The magnitudes of a benchmark run unless it names others."""


def injected_values() -> dict[str, dict[str, object]]:
    """Injected value per effect and magnitude (module doc): each candidate's own
    ``benchmark_values`` (:class:`~gc_ocp.estimation.components.Component`), in the order of
    :func:`~gc_ocp.estimation.components.candidate_effects` (as the registry stands now: an
    effect registered at run time is injected too)."""
    return {
        name: REGISTRY[name].benchmark_values
        for name in candidate_effects()
        if REGISTRY[name].benchmark_values is not None
    }


NONE = "none"


@dataclasses.dataclass(frozen=True)
class Realism:
    """What the truth generator does that the fitter does not know (module doc).

    marker_noise: iid noise per virtual marker [m] (before the 6 Hz low-pass);
    drift_translation / drift_rotation_deg: RMS per axis of the per-stance soft-tissue drift
    [m], [deg]; plate_noise_pct_bw: white plate noise [% BW]; force_threshold: vertical force
    [N] below which the plate wrench is set to zero; stride_variation: the drift's change from
    stance to stance, relative to its size (:func:`drift`); truth_depth_smoothing /
    truth_slip_smoothing: the truth law's smoothing [m], [m/s] (None: the fitter's);
    mismatch: the family of small truth-model differences that are not candidate effects
    (:class:`~gc_ocp.diagnosis.mismatch.MismatchFamily`) a draw of which every case gets
    (:func:`generate_case`); None: none, the cases as they have always been."""

    marker_noise: float = 0.5e-3
    drift_translation: float = 2e-3
    drift_rotation_deg: float = 0.5
    plate_noise_pct_bw: float = 0.5
    force_threshold: float = 20.0
    stride_variation: float = 0.25
    truth_depth_smoothing: float | None = None
    truth_slip_smoothing: float | None = None
    mismatch: MismatchFamily | None = None

    def settings(self) -> dict:
        """The realism as plain data for a benchmark's settings (``mismatch`` only when set, and
        its plate calibration member only when on, so that the settings of runs without them
        read as they always have: ``--resume`` of such a run goes on)."""
        out = dataclasses.asdict(self)
        if self.mismatch is None:
            del out["mismatch"]
        elif not self.mismatch.plate_calibration:  # the opt-in member off: as before it existed
            del out["mismatch"]["plate_offset"], out["mismatch"]["plate_gain"]
        return out


DEFAULT_REALISM = Realism()
"""The realism of every case unless a run says otherwise (an immutable default argument)."""


# --- the truth ---------------------------------------------------------------------------------


@functools.cache
def _source(files: tuple[str, ...] | None) -> tuple[tuple[StanceData, ...], tuple]:
    """``(stances, registered truth)`` of the motion source: the bundled trial (``None``, the
    shared truth of the tests, :func:`~gc_ocp.bench.recovery.bundled_base_truth`) or the
    trials ``files`` of one subject, loaded as ``gc-ocp`` loads them, with the registered base
    fitted to all their stances and frozen (fitted once per process)."""
    if files is None:
        stances, truth = bundled_base_truth()
        return tuple(stances), truth

    pairs = []
    for f in files:
        t = load_trial(f)
        pairs.append((t, compute_kinematics(t)))
    _, stances, _ = fit_data(pairs)
    truth = truth_from_fit(stances, base_model())  # fitted as any fit is: thresholds censored
    # the true motion carries no plate processing: the data generated on it get their own,
    # which the fitter then finds in them (bench.withheld.run_case)
    return tuple(dataclasses.replace(st, censor_below=0.0) for st in stances), truth


def base_truth(base: str, files: tuple[str, ...] | None = None) -> tuple:
    """The frozen truth of ``base``: the registered base fitted to the real stances of the
    motion source (``files``: trials of one subject; None: the bundled trial) (law, sole offsets,
    belt); for the bare ``seed`` base its law alone, the fitted sole offsets being baked into
    the motion's sole points (:func:`motion`)."""
    resolve_base(base)
    truth = _source(files)[1]
    return (_law(truth),) if base == "seed" else truth


def per_foot(stances: Sequence[StanceData], n: int) -> list[StanceData]:
    """``n`` stances of each foot from ``stances`` (in their order): the first ``n`` of a foot
    that has as many; a foot with fewer has them repeated as further strides of the subject,
    each repetition a trial of its own (``Walking1~2``: its own clock offset and belt speed, its
    own noise, drift and mismatch draws when data are generated on it). The motion of a repeat
    is the real stride's (real walking varies more from stride to stride; the benchmark's
    stride variation of the soft-tissue drift stands for that)."""
    if n < 1:
        raise InputError(f"stances per foot must be at least 1, but got {n}")
    sides = sorted({st.side for st in stances})
    count = dict.fromkeys(sides, 0)
    have = {side: sum(st.side == side for st in stances) for side in sides}
    out = []
    r = 0
    while any(count[side] < n for side in sides):
        for st in stances:
            if count[st.side] >= n or r >= -(-n // have[st.side]):
                continue
            count[st.side] += 1
            if r == 0:
                out.append(st)
                continue
            trial = f"{st.trial}~{r + 1}"
            label = (
                f"{trial}:{st.label.split(':', 1)[1]}" if ":" in st.label else f"{trial}:{st.label}"
            )
            out.append(dataclasses.replace(st, trial=trial, label=label))
        r += 1
    return out


def motion(
    base: str,
    effect: str = NONE,
    files: tuple[str, ...] | None = None,
    stances_per_foot: int | None = None,
) -> list[StanceData]:
    """The true motion of the cases: the stances of the motion source (``files``; None: the
    bundled trial). For the ``seed`` base the sole
    points are the registered fit's (nominal + fitted offsets; the units an effect declares in
    ``benchmark_nominal_units`` at their nominal point, e.g. TT for ``toe_joint``, see
    :func:`truth_model`): a bare law on the nominal points of real kinematics
    leaves heel units of a stance that never touch the ground, so a truth fitted that way has
    per-unit stiffnesses no other stance can predict, and every held-out score is dominated by
    that, not by the effect. ``stances_per_foot``: that many stances of each foot
    (:func:`per_foot`; None: the source's own)."""
    stances = list(_source(files)[0])
    if stances_per_foot is not None:
        stances = per_foot(stances, stances_per_foot)
    if base != "seed":
        return stances
    sole = next(c for c in _source(files)[1] if c.name == "sole")
    nominal = _nominal_units(effect)
    out = []
    for st in stances:
        off = np.array(sole.fixed[st.side], float)
        for u in nominal:
            off[list(st.layout.units).index(u)] = 0.0
        out.append(st.with_foot(st.foot.with_points(st.foot.points_local + off)))
    return out


def _nominal_units(effect: str) -> tuple[str, ...]:
    """The sole units the truth keeps at nominal for ``effect`` (its declared
    ``benchmark_nominal_units``; none for "none" or a name that is not registered)."""
    cls = REGISTRY.get(effect)
    return () if cls is None else cls.benchmark_nominal_units


def _at_nominal(component, units: tuple[str, ...], layout):
    """A frozen sole correction (block name ``"sole"``) with the offsets of ``units`` at zero;
    any other component unchanged."""
    if not units or component.name != "sole":
        return component
    fixed = {}
    for side, o in component.fixed.items():
        o = np.array(o, float)
        for u in units:
            o[list(layout.units).index(u)] = 0.0
        fixed[side] = o
    return dataclasses.replace(component, fixed=fixed)


def _law(truth: tuple):
    return next(c for c in truth if c.name == "contact")


def _replace_law(truth: tuple, law) -> tuple:
    return tuple(law if c.name == "contact" else c for c in truth)


def truth_model(effect: str, magnitude: str, base: tuple, stances, rng) -> tuple:
    """``base`` (a frozen base fit) plus ``effect`` at ``magnitude`` (:func:`injected_values`), as the
    effect's class injects it (``Component.inject``; random signs and patterns from ``rng``),
    after the sole units it declares in ``benchmark_nominal_units`` are reset to nominal.
    ``none`` returns ``base``; so does an effect of the data (``kinematic_correction``: the
    kinematic error is applied to the data, :func:`kinematic_error`, :func:`generate`)."""
    if effect == NONE:
        return base
    values = injected_values()
    if effect not in values:
        why = "declares no benchmark_values" if effect in REGISTRY else "is not a registered effect"
        raise InputError(
            f'Effect "{effect}" {why}: the benchmark cannot inject it; choose from '
            f"{[*values, NONE]}"
        )
    if magnitude not in values[effect]:
        raise InputError(
            f'Effect "{effect}" declares no "{magnitude}" benchmark value; it declares '
            f"{list(values[effect])} (its class's benchmark_values)"
        )
    cls = REGISTRY[effect]
    units = cls.benchmark_nominal_units
    base = tuple(_at_nominal(c, units, stances[0].layout) for c in base)
    return cls.inject(base, values[effect][magnitude], list(stances), rng)


# --- the data ----------------------------------------------------------------------------------


def generate(
    stances: Sequence[StanceData],
    truth: tuple,
    rng: np.random.Generator,
    realism: Realism = DEFAULT_REALISM,
    kinematic_error: tuple[float, float, float] | None = None,
    model: tuple | None = None,
) -> list[StanceData]:
    """What the fitter gets: the plate data ``truth`` predicts on ``stances`` (the true motion),
    with plate noise and thresholding, and the foot kinematics seen through ``kinematic_error``
    = (marker noise [m], drift [m], drift [deg]) (None: exact kinematics); with
    ``realism.mismatch``, a draw of it (:func:`generate_case`, which also returns the draw)."""
    return generate_case(stances, truth, rng, realism, kinematic_error, model)[0]


def generate_case(
    stances: Sequence[StanceData],
    truth: tuple,
    rng: np.random.Generator,
    realism: Realism = DEFAULT_REALISM,
    kinematic_error: tuple[float, float, float] | None = None,
    model: tuple | None = None,
) -> tuple[list[StanceData], MismatchDraw | None]:
    """:func:`generate` and the mismatch draw it applied (None without ``realism.mismatch``).

    The draw comes from a child of ``rng`` (``rng.spawn``), which leaves ``rng``'s own stream
    as it is: the plate noise, drift and marker noise of a case are the same with and without
    a mismatch (paired cases), and a case without one is bit for bit what it always was. It is
    restricted to the fitter's ``model`` (:meth:`MismatchDraw.for_model`; None: every member)
    and has no marker noise or drift of its own: the case's kinematic error is
    ``kinematic_error``, the realism's (:func:`MismatchDraw.without_pose_error`). The truth is
    :func:`~gc_ocp.diagnosis.mismatch.truth_variant` on :func:`true_motion` (units off the
    layout), the plate gets the draw's hum and threshold before the realism's threshold, and
    the fitter sees the motion on the nominal layout low-passed at the draw's cutoff before the
    kinematic error."""
    law = _law(truth)
    changes = {
        k: v
        for k, v in (
            ("depth_smoothing", realism.truth_depth_smoothing),
            ("slip_smoothing", realism.truth_slip_smoothing),
        )
        if v is not None
    }
    if changes:
        truth = _replace_law(truth, dataclasses.replace(law, **changes))
    draw = None
    sim_stances = list(stances)
    if realism.mismatch is not None:
        mrng = rng.spawn(1)[0]
        draw = realism.mismatch.draw(mrng, stances[0].layout)
        if model is not None:
            draw = draw.for_model(model)
        draw = draw.without_pose_error()
        truth = truth_variant(truth, draw)
        sim_stances = true_motion(stances, draw)
    data = simulate(sim_stances, truth, rng, plate_noise_pct_bw=realism.plate_noise_pct_bw)
    if draw is not None:
        data = plate_processing(data, draw, mrng)
        seen = seen_motion(stances, draw, mrng)
        data = [d.with_foot(s.foot) for d, s in zip(data, seen, strict=True)]
    data = [thresholded(st, realism.force_threshold) for st in data]
    if kinematic_error is None:
        return data, draw
    noise, d_m, d_deg = kinematic_error
    data = drift(data, d_m, d_deg, rng, realism.stride_variation)
    if noise > 0:
        data = [st.with_foot(noisy_pose(st.foot, noise, rng)) for st in data]
    return data, draw
