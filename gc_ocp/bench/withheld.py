"""The withheld-effect benchmark: does the diagnosis name an effect it was not told about?

For every effect of the library (and for "none"), several seeds and two magnitudes, plate data
are generated on the real motion of the bundled trial (its three stances) from a **truth** = the
base model fitted to the real data and frozen (:func:`~gc_ocp.bench.recovery.truth_from_fit`)
plus that one effect with a known value. :func:`~gc_ocp.diagnosis.diagnose_stances` then runs
blind (``max_effects=1``) and its top-1 answer (the first selected effect, or "none") is
compared with the truth. Output: ``confusion.json`` (every case with its ranking, the confusion
matrix, top-1 accuracy, "none" correct-rejection rate; rewritten atomically after every case,
so a partial run leaves a valid file) and ``confusion.png``.

**Injected values** (physical; "moderate" is a typical value of the literature or of the fits
of real walking, "strong" about twice it; :data:`VALUES`, made of each effect's own
``benchmark_values``; the truth is the effect's ``inject``, :func:`truth_model`):

=====================  =========================================  ==============================
effect                 moderate                                   strong
=====================  =========================================  ==============================
damping                c = 0.5 s/m                                c = 1.0 s/m
stiffness_exponent     n = 1.25 (k rescaled: same force at 5 mm)  n = 1.5
sole_geometry          unit offsets U(-2, 2) mm per axis          U(-4, 4) mm
kinematic_correction   marker noise 0.5 mm, drift 2 mm, 0.5 deg   1.0 mm, 4 mm, 1 deg
contact_density        heel/toe stiffness ratio 2 (16 units)      ratio 3
toe_joint              toes dorsiflex to 10 deg at toe-off        15 deg
ground_offset          +-2 mm, tilts +-0.5 deg per stance         +-4 mm, +-1 deg
time_offset            plate 10 ms late                           20 ms late
friction               mu_s - mu_d = 0.15, b = 0.4 s/m            0.3, 0.75 s/m
=====================  =========================================  ==============================

(``sole_geometry`` and ``kinematic_correction`` are effects only against the bare seed base;
the registered base already has them.)

**Where the truth generator differs from the fitter** (:class:`Realism`):

* *marker noise* on the kinematics the fitter sees: 0.5 mm iid per virtual marker before the
  6 Hz low-pass of :func:`~gc_ocp.estimation.synthetic.noisy_pose` (4 markers, Kabsch):
  optoelectronic marker noise is 0.1-0.5 mm, skin-marker jitter after filtering about 0.5-1 mm
  (Chiari et al. 2005, Gait Posture 21:197);
* *soft-tissue drift*: a slow rigid error of the foot, an offset plus a linear trend over the
  stance per axis, 2 mm (translation) and 0.5 deg (rotation) RMS per axis: foot skin markers
  move 1-4 mm and a few degrees against the bones in stance (Nester et al. 2007, Gait Posture
  25:406; Leardini et al. 2005, Gait Posture 21:212). The pattern is the foot's and repeats
  from stride to stride with 25 % variation (soft-tissue artefacts are subject- and
  task-specific and repeatable): a drift drawn independently per stance gives each stance a
  constant offset of its own, exactly what ``ground_offset`` models, and was taken for it in a
  pilot (5.9 % held-out gain on a damping case);
* *plate*: white noise 0.5 % BW (moments 0.5 % BW x 20 mm), then the wrench set to zero on
  frames whose vertical force is below 20 N (the threshold many labs apply);
* the truth's forces are computed on the recorded kinematics, the fitter sees them through the
  errors above (the drift and noise are exactly what the base's pose correction exists for).

The truth is always the *registered* base fitted to the real stances (law, sole offsets); for
the bare ``seed`` base its sole offsets are baked into the sole points of the motion
(:func:`motion`): a bare law fitted on the nominal points of real kinematics leaves the heel
units of one right stance never touching the ground, and a truth fitted that way made every
held-out score a matter of extrapolating unidentified unit stiffnesses (in a pilot
``kinematic_correction`` was the answer to the damping and stiffness_exponent cases; damping's
held-out gain was 0.6 % for an in-sample 59 %).

The kinematic error is applied whenever the model can register it (a base with the pose
correction); against the bare seed base it *is* the ``kinematic_correction`` effect and is
applied only in those cases (otherwise every case's right answer would be that effect).

What does **not** differ (documented limits): the truth's contact law has the fitter's smoothing
(penetration 0.5 mm, slip 5 cm/s) and the truth motion is the recorded 6 Hz kinematics. A
smaller smoothing in the truth (0.1 mm, 3 cm/s) changes the truth's wrench by 0.5-4.8 % BW and a
10 Hz truth motion by 1-5 % BW (measured on the bundled trial): both are model differences of
their own (the law's shape, heel-strike content the 6 Hz kinematics lack) that the friction and
stiffness candidates would rightly pick up; the smoothing is an option of :class:`Realism`
(``truth_depth_smoothing``, ``truth_slip_smoothing``), off by default.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from gc_ocp.diagnosis.diagnose import candidate_names, diagnose_stances, resolve_base
from gc_ocp.errors import InputError
from gc_ocp.estimation.components import EFFECTS, REGISTRY
from gc_ocp.stance import StanceData

MAGNITUDES = ("moderate", "strong")

VALUES: dict[str, dict[str, object]] = {
    name: REGISTRY[name].benchmark_values
    for name in EFFECTS
    if REGISTRY[name].benchmark_values is not None
}
"""Injected value per effect and magnitude (module doc): each effect's own
``benchmark_values`` (:class:`~gc_ocp.estimation.components.Component`), in :data:`EFFECTS`
order."""

NONE = "none"


@dataclasses.dataclass(frozen=True)
class Realism:
    """What the truth generator does that the fitter does not know (module doc).

    marker_noise: iid noise per virtual marker [m] (before the 6 Hz low-pass);
    drift_translation / drift_rotation_deg: RMS per axis of the per-stance soft-tissue drift
    [m], [deg]; plate_noise_pct_bw: white plate noise [% BW]; force_threshold: vertical force
    [N] below which the plate wrench is set to zero; stride_variation: the drift's change from
    stance to stance, relative to its size (:func:`drift`); truth_depth_smoothing /
    truth_slip_smoothing: the truth law's smoothing [m], [m/s] (None: the fitter's)."""

    marker_noise: float = 0.5e-3
    drift_translation: float = 2e-3
    drift_rotation_deg: float = 0.5
    plate_noise_pct_bw: float = 0.5
    force_threshold: float = 20.0
    stride_variation: float = 0.25
    truth_depth_smoothing: float | None = None
    truth_slip_smoothing: float | None = None


# --- the truth ---------------------------------------------------------------------------------


@functools.cache
def _source(files: tuple[str, ...] | None) -> tuple[tuple[StanceData, ...], tuple]:
    """``(stances, registered truth)`` of the motion source: the bundled trial (``None``, the
    shared truth of the tests, :func:`~gc_ocp.bench.recovery.bundled_base_truth`) or the
    trials ``files`` of one subject, loaded as ``gc-ocp`` loads them, with the registered base
    fitted to all their stances and frozen (fitted once per process)."""
    from gc_ocp.bench.recovery import bundled_base_truth, truth_from_fit

    if files is None:
        stances, truth = bundled_base_truth()
        return tuple(stances), truth
    from gc_ocp.estimation.components import base_model
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics
    from gc_ocp.workflow.fitting import fit_data

    pairs = []
    for f in files:
        t = load_trial(f)
        pairs.append((t, compute_kinematics(t)))
    _, stances, _ = fit_data(pairs)
    return tuple(stances), truth_from_fit(stances, base_model())


def base_truth(base: str, files: tuple[str, ...] | None = None) -> tuple:
    """The frozen truth of ``base``: the registered base fitted to the real stances of the
    motion source (``files``: trials of one subject; None: the bundled trial) (law, sole offsets,
    belt); for the bare ``seed`` base its law alone, the fitted sole offsets being baked into
    the motion's sole points (:func:`motion`)."""
    resolve_base(base)
    truth = _source(files)[1]
    return (_law(truth),) if base == "seed" else truth


def motion(base: str, effect: str = NONE, files: tuple[str, ...] | None = None) -> list[StanceData]:
    """The true motion of the cases: the stances of the motion source (``files``; None: the
    bundled trial). For the ``seed`` base the sole
    points are the registered fit's (nominal + fitted offsets; the units an effect declares in
    ``benchmark_nominal_units`` at their nominal point, e.g. TT for ``toe_joint``, see
    :func:`truth_model`): a bare law on the nominal points of real kinematics
    leaves heel units of a stance that never touch the ground, so a truth fitted that way has
    per-unit stiffnesses no other stance can predict, and every held-out score is dominated by
    that, not by the effect."""
    stances = list(_source(files)[0])
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
    """``base`` (a frozen base fit) plus ``effect`` at ``magnitude`` (:data:`VALUES`), as the
    effect's class injects it (``Component.inject``; random signs and patterns from ``rng``),
    after the sole units it declares in ``benchmark_nominal_units`` are reset to nominal.
    ``none`` returns ``base``; so does an effect of the data (``kinematic_correction``: the
    kinematic error is applied to the data, :func:`kinematic_error`, :func:`generate`)."""
    if effect == NONE:
        return base
    if effect not in VALUES:
        why = "declares no benchmark_values" if effect in REGISTRY else "is not a registered effect"
        raise InputError(
            f'Effect "{effect}" {why}: the benchmark cannot inject it; choose from '
            f"{[*VALUES, NONE]}"
        )
    cls = REGISTRY[effect]
    units = cls.benchmark_nominal_units
    base = tuple(_at_nominal(c, units, stances[0].layout) for c in base)
    return cls.inject(base, VALUES[effect][magnitude], list(stances), rng)


# --- the data ----------------------------------------------------------------------------------


def drift(
    stances: Sequence[StanceData],
    translation: float,
    rotation_deg: float,
    rng,
    stride_variation: float = 0.25,
) -> list[StanceData]:
    """``stances`` with a slow rigid soft-tissue drift of the foot: per axis an offset plus a
    linear trend over the stance, RMS ~``translation`` [m] and ``rotation_deg`` per axis. The
    pattern is the foot's (soft-tissue artefacts repeat from stride to stride of a subject and
    task, Leardini et al. 2005), and each stance varies it by ``stride_variation`` of its size."""
    from gc_ocp.estimation.synthetic import with_pose_error

    def coefficients(sd):
        return rng.normal(0.0, sd / np.sqrt(2), (2, 3))

    pattern = {
        side: (coefficients(translation), coefficients(np.deg2rad(rotation_deg)))
        for side in sorted({st.side for st in stances})
    }
    out = []
    for st in stances:
        t = st.time
        s = (2 * (t - t[0]) / (t[-1] - t[0]) - 1)[:, None] * np.sqrt(3)  # unit RMS over stance
        tr, rot = pattern[st.side]
        tr = tr + stride_variation * coefficients(translation)
        rot = rot + stride_variation * coefficients(np.deg2rad(rotation_deg))
        out.append(st.with_foot(with_pose_error(st.foot, rot[0] + rot[1] * s, tr[0] + tr[1] * s)))
    return out


def _thresholded(st: StanceData, threshold: float) -> StanceData:
    """The plate wrench zeroed where its vertical force is below ``threshold`` [N]."""

    def cut(w):
        w = np.array(w, float)
        w[w[:, 2] < threshold] = 0.0
        return w

    st = st.with_measured(cut(st.measured))
    if st.plate_wrench is not None:
        st = dataclasses.replace(st, plate_wrench=cut(st.plate_wrench))
    return st


def generate(
    stances: Sequence[StanceData],
    truth: tuple,
    rng: np.random.Generator,
    realism: Realism = Realism(),
    kinematic_error: tuple[float, float, float] | None = None,
) -> list[StanceData]:
    """What the fitter gets: the plate data ``truth`` predicts on ``stances`` (the true motion),
    with plate noise and thresholding, and the foot kinematics seen through ``kinematic_error``
    = (marker noise [m], drift [m], drift [deg]) (None: exact kinematics)."""
    from gc_ocp.bench.recovery import simulate
    from gc_ocp.estimation.synthetic import noisy_pose

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
    data = simulate(list(stances), truth, rng, plate_noise_pct_bw=realism.plate_noise_pct_bw)
    data = [_thresholded(st, realism.force_threshold) for st in data]
    if kinematic_error is None:
        return data
    noise, d_m, d_deg = kinematic_error
    data = drift(data, d_m, d_deg, rng, realism.stride_variation)
    if noise > 0:
        data = [st.with_foot(noisy_pose(st.foot, noise, rng)) for st in data]
    return data


# --- the benchmark -----------------------------------------------------------------------------


def plan(
    base: str = "registered",
    effects: Sequence[str] | None = None,
    seeds: int = 3,
    magnitudes: Sequence[str] = MAGNITUDES,
    first_seed: int = 0,
) -> list[dict]:
    """The cases: every truth (the base's candidates and "none") x magnitude x seed (``seeds``
    of them from ``first_seed``: runs of other seeds can be merged), seeds outermost (a partial
    run covers every truth). "none" has no magnitude: it gets one case per (magnitude, seed)
    with distinct seeds, as many as any effect."""
    _, model = resolve_base(base)
    cands = [e for e in candidate_names(model) if e in VALUES]  # those it can inject
    truths = [*cands, NONE] if effects is None else list(effects)
    bad = [e for e in truths if e != NONE and e not in cands]
    if bad:
        raise InputError(
            f"Effect(s) {bad} are not candidates on base '{base}' that the benchmark can inject "
            f"(benchmark_values); choose from {[*cands, NONE]}"
        )
    bad = [m for m in magnitudes if m not in MAGNITUDES]
    if bad:
        raise InputError(f"Unknown magnitude(s) {bad}; choose from {list(MAGNITUDES)}")
    cases = []
    for seed in range(first_seed, first_seed + seeds):
        for j, mag in enumerate(magnitudes):
            for e in truths:
                s = seed if e != NONE else seed * len(magnitudes) + j
                cases.append({"truth": e, "magnitude": mag if e != NONE else "-", "seed": s})
    return cases


def kinematic_error(
    effect: str, magnitude: str, base_model: tuple, realism: Realism = Realism()
) -> tuple[float, float, float] | None:
    """The kinematic error ``(marker noise [m], drift [m], drift [deg])`` through which the
    fitter sees the foot in a case of ``effect`` at ``magnitude`` on ``base_model``: the effect's
    own when it is an effect of the data (``Component.benchmark_kinematic_error``, e.g.
    ``kinematic_correction``); else the realism's when the base can register it (it has the
    pose correction); else none (module doc)."""
    if effect in VALUES:
        own = REGISTRY[effect].benchmark_kinematic_error(VALUES[effect][magnitude])
        if own is not None:
            return own
    if any(c.name == "pose" for c in base_model):
        return (realism.marker_noise, realism.drift_translation, realism.drift_rotation_deg)
    return None


def _case_seed(base: str, truth: str, magnitude: str, seed: int) -> int:
    """A seed per case, stable across runs and processes (no Python hash)."""
    key = f"{base}|{truth}|{magnitude}|{seed}".encode()
    return int.from_bytes(__import__("hashlib").sha256(key).digest()[:8], "little")


def run_case(
    case: dict,
    base: str = "registered",
    candidates: Sequence[str] | None = None,
    realism: Realism = Realism(),
    n_boot: int = 2000,
    progress: Callable[[str], None] | None = None,
    workers: int | None = None,
    files: Sequence[str] | None = None,
) -> dict:
    """Generate one case's data and diagnose it blind: the case with ``answer``, ``correct``,
    the ranking rows and timing. ``files``: trials of one subject whose motion the case uses
    (default: the bundled trial)."""
    t0 = time.perf_counter()
    truth_name, mag = case["truth"], case["magnitude"]
    rng = np.random.default_rng(_case_seed(base, truth_name, mag, case["seed"]))
    files = None if files is None else tuple(str(f) for f in files)
    stances = motion(base, truth_name, files)
    _, base_model_ = resolve_base(base)
    truth = truth_model(truth_name, mag, base_truth(base, files), stances, rng)
    kin_err = kinematic_error(truth_name, mag, base_model_, realism)
    data = generate(stances, truth, rng, realism, kin_err)
    t1 = time.perf_counter()
    with warnings.catch_warnings():
        # units that never touch in a fold's training stances: expected under drift, noted
        # by the fit itself; not the benchmark's message
        warnings.filterwarnings("ignore", message="LLS initialisation not possible")
        d = diagnose_stances(
            data,
            base=base,
            candidates=candidates,
            max_effects=1,
            n_boot=n_boot,
            progress=progress,
            workers=workers,
        )
    answer = d.selected[0] if d.selected else NONE
    rows = [
        {
            k: r[k]
            for k in (
                "effect",
                "heldout_rms_reduction_pct",
                "heldout_rms_reduction_ci",
                "insample_rms_reduction_pct",
                "n_params",
                "passes",
                "confounded_with",
                "per_stance_reduction_pct",
                "gain_from_nuisance",
            )
            if k in r
        }
        for r in d.ranking
    ]
    row = next((r for r in rows if r["effect"] == answer), None)
    truth_row = next((r for r in rows if r["effect"] == truth_name), None)
    return {
        **case,
        "value": VALUES[truth_name][mag] if truth_name in VALUES else None,
        "kinematic_error": kin_err,
        "answer": answer,
        "correct": answer == truth_name,
        "confounded_with": row["confounded_with"] if row else [],
        "inconclusive": d.inconclusive,
        "truth_rank": (
            next(i for i, r in enumerate(rows) if r["effect"] == truth_name) + 1
            if truth_row
            else None
        ),
        "truth_passes": bool(truth_row["passes"]) if truth_row else None,
        "ranking": rows,
        "base_heldout_superior_pct_bw": d.waterfall[0]["heldout_superior_force_pct_bw"],
        "seconds_generate": t1 - t0,
        "seconds_diagnose": d.seconds,
    }


def summarize(cases: list[dict], labels: Sequence[str]) -> dict:
    """Confusion matrix (rows: truth, columns: answer; ``labels`` then any other answer),
    top-1 accuracy on the effect cases, the "none" correct-rejection rate, overall accuracy and
    the accuracy counting a confusion flagged as ambiguous (the truth among the answer's
    ``confounded_with``, or among the ``inconclusive`` candidates of a "none") as not wrong."""
    truths = [t for t in labels if any(c["truth"] == t for c in cases)]
    answers = list(labels) + sorted({c["answer"] for c in cases} - set(labels))
    m = np.zeros((len(truths), len(answers)), int)
    for c in cases:
        m[truths.index(c["truth"]), answers.index(c["answer"])] += 1
    eff = [c for c in cases if c["truth"] != NONE]
    non = [c for c in cases if c["truth"] == NONE]

    def rate(cs, ok=lambda c: c["correct"]):
        return float(np.mean([ok(c) for c in cs])) if cs else None

    def flagged(c) -> bool:
        """Right, or the truth named by the answer: among the selected effect's
        ``confounded_with``, or (answer "none") among the ``inconclusive`` candidates."""
        return (
            c["correct"]
            or c["truth"] in c["confounded_with"]
            or (c["answer"] == NONE and c["truth"] in c.get("inconclusive", []))
        )

    per = {
        t: {
            mag: rate([c for c in cases if c["truth"] == t and c["magnitude"] == mag])
            for mag in sorted({c["magnitude"] for c in cases if c["truth"] == t})
        }
        for t in truths
    }
    return {
        "truths": truths,
        "answers": answers,
        "matrix": m.tolist(),
        "n_cases": len(cases),
        "top1_accuracy": rate(eff),
        "none_correct_rejection": rate(non),
        "overall_accuracy": rate(cases),
        "top1_accuracy_ambiguity_flagged_ok": rate(eff, flagged),
        "per_truth_and_magnitude": per,
    }


def merge(results: Sequence[dict]) -> dict:
    """Runs of the same base with other seeds as one result (cases keyed by truth, magnitude and
    seed; a later result's case replaces an earlier one; the summary recomputed)."""
    first = results[0]
    by_key: dict = {}
    for r in results:
        if r["settings"]["base"] != first["settings"]["base"]:
            raise InputError("merge: results of different bases")
        for c in r["cases"]:
            by_key[(c["truth"], c["magnitude"], c["seed"])] = c
    cases = list(by_key.values())
    settings = {
        **first["settings"],
        "seeds": sorted({c["seed"] for c in cases if c["truth"] != NONE}),
    }
    return {
        "settings": settings,
        "summary": summarize(cases, [*settings["candidates"], NONE]),
        "cases": cases,
        "seconds": {
            "wall_this_run": None,
            "cases_total": sum(c["seconds_generate"] + c["seconds_diagnose"] for c in cases),
        },
    }


def confusion_figure(result: dict):
    """The confusion matrix (counts; rows truth, columns answer) as a matplotlib figure."""
    import matplotlib.pyplot as plt

    s = result["summary"]
    m = np.asarray(s["matrix"], float)
    fig, ax = plt.subplots(figsize=(1.0 + 0.62 * len(s["answers"]), 1.2 + 0.5 * len(s["truths"])))
    share = m / np.maximum(m.sum(axis=1, keepdims=True), 1)
    ax.imshow(share, cmap="Blues", vmin=0, vmax=1)
    for i in range(m.shape[0]):
        for j in range(m.shape[1]):
            if m[i, j]:
                ax.text(
                    j,
                    i,
                    int(m[i, j]),
                    ha="center",
                    va="center",
                    color="white" if share[i, j] > 0.6 else "black",
                )
    ax.set_xticks(range(len(s["answers"])), s["answers"], rotation=40, ha="right")
    ax.set_yticks(range(len(s["truths"])), s["truths"])
    ax.set_xlabel("diagnosis (top-1)")
    ax.set_ylabel("withheld truth")
    acc, rej = s["top1_accuracy"], s["none_correct_rejection"]
    ax.set_title(
        f"base '{result['settings']['base']}': top-1 "
        f"{'-' if acc is None else f'{100 * acc:.0f} %'}, none rejected "
        f"{'-' if rej is None else f'{100 * rej:.0f} %'} ({s['n_cases']} cases)",
        fontsize=10,
    )
    fig.tight_layout()
    return fig


def run_benchmark(
    out: str | Path,
    base: str = "registered",
    effects: Sequence[str] | None = None,
    seeds: int = 3,
    magnitudes: Sequence[str] = MAGNITUDES,
    candidates: Sequence[str] | None = None,
    realism: Realism = Realism(),
    n_boot: int = 2000,
    resume: bool = False,
    progress: Callable[[str], None] | None = None,
    workers: int | None = None,
    first_seed: int = 0,
    files: Sequence[str] | None = None,
) -> dict:
    """Run every case of :func:`plan`; ``DIR/confusion.json`` is rewritten atomically after each
    case (``resume``: keep the cases of an earlier run with the same settings), then
    ``DIR/confusion.png``. Returns the result dict written to ``confusion.json``. ``workers``:
    processes per diagnosis round (:func:`~gc_ocp.diagnosis.diagnose.diagnose_stances`);
    ``files``: trials of one subject whose real motion the cases use (default: the bundled
    trial; more stances per foot give the held-out score more folds)."""
    from gc_ocp.outputs import atomic_savefig, atomic_write_text, check_writable

    say = progress or (lambda s: None)
    out = check_writable(out)
    files = None if files is None else tuple(str(f) for f in files)
    cases = plan(base, effects, seeds, magnitudes, first_seed)
    _, model = resolve_base(base)
    cands = candidate_names(model, candidates)
    settings = {
        "base": base,
        "base_components": [c.name for c in model],
        "candidates": cands,
        "seeds": list(range(first_seed, first_seed + seeds)),
        "magnitudes": list(magnitudes),
        "values": {k: VALUES[k] for k in VALUES if k in {c["truth"] for c in cases}},
        "realism": dataclasses.asdict(realism),
        "motion": [st.label for st in _source(files)[0]],
        "motion_files": None if files is None else list(files),
        "truth_fit": "registered base fitted to the real stances, frozen"
        + ("; its sole offsets baked into the sole points" if base == "seed" else ""),
        "n_boot": n_boot,
        "decision": "top-1 = first effect selected by diagnose_stances(max_effects=1)",
    }
    done: list[dict] = []
    path = Path(out) / "confusion.json"
    if resume and path.exists():
        old = json.loads(path.read_text())
        if old.get("settings") == json.loads(json.dumps(settings)):
            done = old["cases"]
            say(f"resuming: {len(done)} case(s) done")
    key = lambda c: (c["truth"], c["magnitude"], c["seed"])  # noqa: E731
    have = {key(c) for c in done}
    labels = [*cands, NONE]
    t0 = time.perf_counter()

    def result():
        return {
            "settings": settings,
            "summary": summarize(done, labels),
            "cases": done,
            "seconds": {
                "wall_this_run": time.perf_counter() - t0,
                "cases_total": sum(c["seconds_generate"] + c["seconds_diagnose"] for c in done),
            },
        }

    todo = [c for c in cases if key(c) not in have]
    for case in todo:
        say(
            f"[{len(done) + 1}/{len(cases)}] base {base}: truth {case['truth']} "
            f"({case['magnitude']}), seed {case['seed']}"
        )
        r = run_case(
            case, base, candidates, realism, n_boot, progress=None, workers=workers, files=files
        )
        done.append(r)
        s = summarize(done, labels)
        say(
            f"    -> {r['answer']} ({'ok' if r['correct'] else 'WRONG'}"
            + (
                f", confounded with {', '.join(r['confounded_with'])}"
                if r["confounded_with"]
                else ""
            )
            + f"); {r['seconds_generate'] + r['seconds_diagnose']:.0f} s; running top-1 "
            f"{_pct(s['top1_accuracy'])}, none rejected {_pct(s['none_correct_rejection'])}"
        )
        atomic_write_text(path, json.dumps(result(), indent=1, default=_json))
    res = result()
    atomic_write_text(path, json.dumps(res, indent=1, default=_json))
    fig = confusion_figure(res)
    atomic_savefig(fig, Path(out) / "confusion.png", dpi=120)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return res


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.0f} %"


def _json(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(type(o).__name__)


def report(result: dict) -> str:
    """The summary lines printed by the CLI."""
    s = result["summary"]
    return "\n".join(
        [
            f"withheld-effect benchmark, base '{result['settings']['base']}': {s['n_cases']} cases",
            f"top-1 accuracy (effect cases): {_pct(s['top1_accuracy'])}",
            f'"none" correct rejection: {_pct(s["none_correct_rejection"])}',
            f"overall: {_pct(s['overall_accuracy'])}; effect cases right or flagged ambiguous: "
            f"{_pct(s['top1_accuracy_ambiguity_flagged_ok'])}",
        ]
    )


def markdown(result: dict) -> str:
    """The confusion matrix and rates of a result as Markdown (rows truth, columns answer)."""
    s, st = result["summary"], result["settings"]
    short = {a: a.replace("_", " ") for a in s["answers"]}
    lines = [
        f"**base `{st['base']}`** ({', '.join(st['base_components'])}); candidates: "
        f"{', '.join(st['candidates'])}; {s['n_cases']} cases, "
        f"{result['seconds']['cases_total'] / 60:.0f} min of case time",
        "",
        "| truth \\ answer | " + " | ".join(short[a] for a in s["answers"]) + " |",
        "|---|" + "---|" * len(s["answers"]),
    ]
    for t, row in zip(s["truths"], s["matrix"], strict=True):
        cells = [
            f"**{v}**" if a == t and v else (str(v) if v else ".")
            for a, v in zip(s["answers"], row, strict=True)
        ]
        lines.append(f"| {t} | " + " | ".join(cells) + " |")
    lines += [
        "",
        f"top-1 accuracy (effect cases): **{_pct(s['top1_accuracy'])}**; "
        f'"none" correctly rejected: **{_pct(s["none_correct_rejection"])}**; overall '
        f"{_pct(s['overall_accuracy'])}; effect cases right or flagged ambiguous (truth among "
        f'the answer\'s `confounded_with`, or among the `inconclusive` of a "none"): '
        f"{_pct(s['top1_accuracy_ambiguity_flagged_ok'])}",
    ]
    return "\n".join(lines)


__all__ = [
    "MAGNITUDES",
    "NONE",
    "VALUES",
    "Realism",
    "base_truth",
    "confusion_figure",
    "drift",
    "generate",
    "kinematic_error",
    "markdown",
    "merge",
    "motion",
    "plan",
    "report",
    "run_benchmark",
    "run_case",
    "summarize",
    "truth_model",
]
