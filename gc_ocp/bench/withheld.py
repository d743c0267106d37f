"""The withheld-effect benchmark: does the diagnosis name an effect it was not told about?

For every effect of the library (and for "none"), several seeds and magnitudes, plate data
are generated on the real motion of the bundled trial (its three stances) from a **truth** = the
base model fitted to the real data and frozen (:func:`~gc_ocp.bench.recovery.truth_from_fit`)
plus that one effect with a known value. :func:`~gc_ocp.diagnosis.diagnose_stances` then runs
blind (``max_effects=1``) and its top-1 answer (the first selected effect, or "none") is
compared with the truth. Output: ``confusion.json`` (every case with its ranking, the confusion
matrix, top-1 accuracy, "none" correct-rejection rate; rewritten atomically after every case,
so a partial run leaves a valid file) and ``confusion.png``.

**Injected values** (physical; "moderate" is a typical value of the literature or of the fits
of real walking, "strong" about twice it, "small" half the moderate's departure from neutral,
asked for by name (``magnitudes``; the default is moderate and strong): near the detection
limit, where the steps-needed prediction is made; :func:`~gc_ocp.bench.truth.injected_values`,
made of each effect's own ``benchmark_values``; the truth is the effect's ``inject``,
:func:`truth_model`):

====================  =======================  =================================  =================
effect                small                    moderate                           strong
====================  =======================  =================================  =================
damping               c = 0.25 s/m             c = 0.5 s/m                        c = 1.0 s/m
stiffness_exponent    n = 1.125                n = 1.25 (same force at 5 mm)      n = 1.5
sole_geometry         U(-1, 1) mm              offsets U(-2, 2) mm per axis       U(-4, 4) mm
kinematic_correction  0.25 mm, 1 mm, 0.25 deg  noise 0.5 mm, drift 2 mm, 0.5 deg  1 mm, 4 mm, 1 deg
contact_density       ratio 1.5                heel/toe stiffness ratio 2         ratio 3
toe_joint             5 deg                    toes to 10 deg at toe-off          15 deg
ground_offset         +-1 mm, +-0.25 deg       +-2 mm, tilts +-0.5 deg            +-4 mm, +-1 deg
time_offset           5 ms late                plate 10 ms late                   20 ms late
friction              0.075, 0.2 s/m           mu_s - mu_d 0.15, b 0.4 s/m        0.3, 0.75 s/m
====================  =======================  =================================  =================

(``sole_geometry`` and ``kinematic_correction`` are effects only against the bare seed base;
the registered base already has them. The stiffness exponent's k is rescaled so that the force
at 5 mm is the base's; the denser sole has 16 units.)

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

**The mismatch family** (``Realism.mismatch``, off by default; ``docs/diagnosis.md``, "Mismatch
family"): with a :class:`~gc_ocp.diagnosis.mismatch.MismatchFamily`, every case's truth and data
also differ from the model by one draw of it (law smoothing width and form, units off the
layout, plate threshold and hum, a lower-passed seen motion), drawn from a child of the case's
generator (the case's own draws unchanged: paired with the case without), restricted to the
base, and recorded in the case's row (``"mismatch"``, JSON).
"""

from __future__ import annotations

import json
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from gc_ocp.bench.summary import _json, _pct, confusion_figure, markdown, merge, report, summarize
from gc_ocp.bench.truth import (
    DEFAULT_MAGNITUDES,
    DEFAULT_REALISM,
    MAGNITUDES,
    NONE,
    Realism,
    base_truth,
    drift,
    generate,
    generate_case,
    injected_values,
    motion,
    truth_model,
)
from gc_ocp.diagnosis.diagnose import POSE_WIDTH, candidate_names, diagnose_stances, resolve_base
from gc_ocp.diagnosis.mismatch import MismatchFamily
from gc_ocp.diagnosis.null import DEFAULT_FAMILY
from gc_ocp.errors import GcOcpError, InputError
from gc_ocp.estimation.components import REGISTRY
from gc_ocp.outputs import atomic_savefig, atomic_write_text, check_writable
from gc_ocp.workflow.fitting import with_detected_censoring

# --- the benchmark -----------------------------------------------------------------------------


CASE_ROW_KEYS = (
    "effect",
    "heldout_rms_reduction_pct",
    "heldout_rms_reduction_ci",
    "insample_rms_reduction_pct",
    "n_params",
    "passes",
    "confounded_with",
    "per_stance_reduction_pct",
    "gain_from_nuisance",
    "inconclusive",
    "calibrated",
    "not_evaluable",
)
"""What a case keeps of each ranking row (its ``diagnosis.json`` keys)."""


def plan(
    base: str = "registered",
    effects: Sequence[str] | None = None,
    seeds: int = 3,
    magnitudes: Sequence[str] = DEFAULT_MAGNITUDES,
    first_seed: int = 0,
) -> list[dict]:
    """The cases: every truth (the base's candidates and "none") x magnitude x seed (``seeds``
    of them from ``first_seed``: runs of other seeds can be merged), seeds outermost (a partial
    run covers every truth). "none" has no magnitude: it gets one case per (magnitude, seed)
    with distinct seeds, as many as any effect."""
    if seeds < 1:  # no case: nothing to score, and no confusion matrix to draw
        raise InputError(
            f"--seeds must be 1 or more, but got {seeds} (noise draws per effect and magnitude)"
        )
    _, model = resolve_base(base)
    values = injected_values()
    cands = [e for e in candidate_names(model) if e in values]  # those it can inject
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
    effect: str, magnitude: str, base_model: tuple, realism: Realism = DEFAULT_REALISM
) -> tuple[float, float, float] | None:
    """The kinematic error ``(marker noise [m], drift [m], drift [deg])`` through which the
    fitter sees the foot in a case of ``effect`` at ``magnitude`` on ``base_model``: the effect's
    own when it is an effect of the data (``Component.benchmark_kinematic_error``, e.g.
    ``kinematic_correction``); else the realism's when the base can register it (it has the
    pose correction); else none (module doc)."""
    values = injected_values()
    if effect in values:
        own = REGISTRY[effect].benchmark_kinematic_error(values[effect][magnitude])
        if own is not None:
            return own
    if any(c.name == "pose" for c in base_model):
        return (realism.marker_noise, realism.drift_translation, realism.drift_rotation_deg)
    return None


def _case_seed(base: str, truth: str, magnitude: str, seed: int) -> int:
    """A seed per case, stable across runs and processes (no Python hash)."""
    key = f"{base}|{truth}|{magnitude}|{seed}".encode()
    return int.from_bytes(__import__("hashlib").sha256(key).digest()[:8], "little")


def _resolved(files: Sequence[str] | None) -> tuple[str, ...] | None:
    """The trials' paths resolved: a run resumed from another folder, or with the same files
    written another way, is the same run (and the same cached motion)."""
    return None if files is None else tuple(str(Path(f).resolve()) for f in files)


def case_data(
    case: dict,
    base: str = "registered",
    realism: Realism = DEFAULT_REALISM,
    files: Sequence[str] | None = None,
    stances_per_foot: int | None = None,
) -> tuple[list, object, tuple[float, float, float] | None]:
    """``(data, mismatch draw or None, kinematic error)`` of one case: what the blind diagnosis
    of :func:`run_case` gets, the same for every run of the case (its own seed), with the zero
    threshold the fitter's loader would find in each stance's plate signal."""
    truth_name, mag = case["truth"], case["magnitude"]
    rng = np.random.default_rng(_case_seed(base, truth_name, mag, case["seed"]))
    files = _resolved(files)
    stances = motion(base, truth_name, files, stances_per_foot)
    _, base_model_ = resolve_base(base)
    truth = truth_model(truth_name, mag, base_truth(base, files), stances, rng)
    kin_err = kinematic_error(truth_name, mag, base_model_, realism)
    data, draw = generate_case(stances, truth, rng, realism, kin_err, base_model_)
    # what the fitter's loader does with a plate signal: find a zero threshold and censor it
    return with_detected_censoring(data), draw, kin_err


def run_case(
    case: dict,
    base: str = "registered",
    candidates: Sequence[str] | None = None,
    realism: Realism = DEFAULT_REALISM,
    n_boot: int = 2000,
    progress: Callable[[str], None] | None = None,
    workers: int | None = None,
    files: Sequence[str] | None = None,
    stances_per_foot: int | None = None,
    pose_width: str = POSE_WIDTH,
    stop_early: bool = True,
    null_fits: str = "one-step",
    null_family: MismatchFamily | None = None,
) -> dict:
    """Generate one case's data and diagnose it blind: the case with ``answer``, ``correct``,
    the ranking rows and timing. ``files``: trials of one subject whose motion the case uses
    (default: the bundled trial); ``stances_per_foot``: that many stances of each foot
    (:func:`~gc_ocp.bench.truth.per_foot`; None: the motion's own); ``pose_width``,
    ``stop_early``, ``null_fits``: the diagnosis's; ``null_family``: the family its null
    draws from (None: the diagnosis's default, :data:`~gc_ocp.diagnosis.null.DEFAULT_FAMILY`)."""
    t0 = time.perf_counter()
    truth_name, mag = case["truth"], case["magnitude"]
    data, draw, kin_err = case_data(case, base, realism, files, stances_per_foot)
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
            pose_width=pose_width,
            stop_early=stop_early,
            null_fits=null_fits,
            mismatch=DEFAULT_FAMILY if null_family is None else null_family,
        )
    answer = d.selected[0] if d.selected else NONE
    rows = [{k: v for k, v in r.to_json().items() if k in CASE_ROW_KEYS} for r in d.ranking]
    row = next((r for r in rows if r["effect"] == answer), None)
    truth_row = next((r for r in rows if r["effect"] == truth_name), None)
    return {
        **case,
        "value": injected_values().get(truth_name, {}).get(mag),
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
        "base_heldout_superior_pct_bw": d.waterfall[0].heldout_superior_force_pct_bw,
        "seconds_generate": t1 - t0,
        "seconds_diagnose": d.seconds,
        # per round: the null's draws made, whether it stopped early, what its looks saw
        "null": [
            {k: c.get(k) for k in ("mismatch_draws", "null_stopped_early", "null_looks", "seconds")}
            for c in d.calibration
        ],
        # the mismatch draw of the case (Realism.mismatch), only when there is one: the rows of
        # runs without stay as they were
        **({} if draw is None else {"mismatch": draw.to_json()}),
    }


ERROR = "error"
"""The answer of a case whose diagnosis stopped with an error (:func:`failed_case`)."""


def failed_case(case: dict, error: Exception, seconds: float) -> dict:
    """The row of a case whose diagnosis stopped with ``error`` (e.g. the base's fit did not
    converge on the case's data): answer :data:`ERROR`, not correct, the message kept."""
    return {
        **case,
        "value": injected_values().get(case["truth"], {}).get(case["magnitude"]),
        "answer": ERROR,
        "correct": False,
        "error": f"{type(error).__name__}: {error}",
        "confounded_with": [],
        "inconclusive": [],
        "truth_rank": None,
        "truth_passes": None,
        "ranking": [],
        "seconds_generate": 0.0,
        "seconds_diagnose": seconds,
    }


def settings_differ(old: dict, new: dict) -> list[str]:
    """The keys of a benchmark run's ``settings`` whose values differ between an earlier run
    (``old``) and this one (``new``); the trials' paths compared resolved (an earlier run may
    have recorded them as given)."""
    out = []
    for key in sorted(set(old) | set(new)):
        a, b = old.get(key), new.get(key)
        if key == "motion_files" and a is not None and b is not None:
            a, b = list(_resolved(a)), list(_resolved(b))
        if a != b:
            out.append(key)
    return out


def run_benchmark(
    out: str | Path,
    base: str = "registered",
    effects: Sequence[str] | None = None,
    seeds: int = 3,
    magnitudes: Sequence[str] = DEFAULT_MAGNITUDES,
    candidates: Sequence[str] | None = None,
    realism: Realism = DEFAULT_REALISM,
    n_boot: int = 2000,
    resume: bool = False,
    progress: Callable[[str], None] | None = None,
    workers: int | None = None,
    first_seed: int = 0,
    files: Sequence[str] | None = None,
    stances_per_foot: int | None = None,
    pose_width: str = POSE_WIDTH,
    stop_early: bool = True,
    null_fits: str = "one-step",
    null_family: MismatchFamily | None = None,
) -> dict:
    """Run every case of :func:`plan`; ``DIR/confusion.json`` is rewritten atomically after each
    case (``resume``: keep the cases of an earlier run with the same settings), then
    ``DIR/confusion.png``. Returns the result dict written to ``confusion.json``. ``workers``:
    processes per diagnosis round (:func:`~gc_ocp.diagnosis.diagnose.diagnose_stances`);
    ``files``: trials of one subject whose real motion the cases use (default: the bundled
    trial; more stances per foot give the held-out score more folds); ``stances_per_foot``: that
    many stances of each foot (:func:`~gc_ocp.bench.truth.per_foot`); ``pose_width``,
    ``stop_early``, ``null_fits``, ``null_family``: the diagnosis's (:func:`run_case`)."""
    say = progress or (lambda s: None)
    if null_family == DEFAULT_FAMILY:
        null_family = None  # the default however given: its settings as they always were
    out = check_writable(out)
    files = _resolved(files)
    cases = plan(base, effects, seeds, magnitudes, first_seed)
    _, model = resolve_base(base)
    cands = candidate_names(model, candidates)
    settings = {
        "base": base,
        "base_components": [c.name for c in model],
        "candidates": cands,
        "seeds": list(range(first_seed, first_seed + seeds)),
        "magnitudes": list(magnitudes),
        "values": {k: v for k, v in injected_values().items() if k in {c["truth"] for c in cases}},
        "realism": realism.settings(),
        "motion": [st.label for st in motion(base, NONE, files, stances_per_foot)],
        "motion_files": None if files is None else list(files),
        "truth_fit": "registered base fitted to the real stances, frozen"
        + ("; its sole offsets baked into the sole points" if base == "seed" else ""),
        "n_boot": n_boot,
        "decision": "top-1 = first effect selected by diagnose_stances(max_effects=1)",
        # only when not the guessed prior (the default until 2026-11-28, so absent in the
        # runs made before): those runs resume unchanged with --pose-width prior
        **({} if pose_width == "prior" else {"pose_width": pose_width}),
        **({} if stop_early else {"null": "every draw made (no early stop)"}),
        **({} if null_fits == "one-step" else {"null_fits": null_fits}),
        # only when not the default (absent in the runs made before it could be chosen)
        **({} if null_family is None else {"null_family": null_family.to_json()}),
    }
    done: list[dict] = []
    path = Path(out) / "confusion.json"
    if resume and path.exists():
        old = json.loads(path.read_text())
        differ = settings_differ(old.get("settings") or {}, json.loads(json.dumps(settings)))
        if differ:
            raise InputError(
                f"--resume: {path} was made with other settings ({', '.join(differ)} differ), "
                "so its cases are not cases of this run; give another --out, or the same "
                "settings as that run, or drop --resume to start again (it is overwritten)."
            )
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
        c0 = time.perf_counter()
        try:
            r = run_case(
                case,
                base,
                candidates,
                realism,
                n_boot,
                progress=None,
                workers=workers,
                files=files,
                stances_per_foot=stances_per_foot,
                pose_width=pose_width,
                stop_early=stop_early,
                null_fits=null_fits,
                null_family=null_family,
            )
        except GcOcpError as e:
            # a case whose diagnosis cannot finish (the base's fit did not converge on its
            # data) is an answer of its own, counted as not right, and the run goes on
            r = failed_case(case, e, time.perf_counter() - c0)
        done.append(r)
        s = summarize(done, labels)
        say(
            f"    -> {r['answer']}"
            + (f" ({r['error']})" if r["answer"] == ERROR else "")
            + f" ({'ok' if r['correct'] else 'WRONG'}"
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
    return res


__all__ = [
    "DEFAULT_MAGNITUDES",
    "ERROR",
    "MAGNITUDES",
    "NONE",
    "injected_values",
    "Realism",
    "base_truth",
    "case_data",
    "confusion_figure",
    "drift",
    "failed_case",
    "generate",
    "generate_case",
    "kinematic_error",
    "markdown",
    "merge",
    "motion",
    "plan",
    "report",
    "run_benchmark",
    "run_case",
    "settings_differ",
    "summarize",
    "truth_model",
]
