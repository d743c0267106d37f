"""Synthetic subjects through the batch (issue 24): real motion, known truth, files on disk.

Usage::

    PYTHONPATH=. python benchmarks/batch_synthetic.py [--subjects 40] [--work DIR] [--skip-loop]

**The subjects.** Each is one walking trial written as OpenSim files (``.trc`` markers and a
``.mot`` of ground reactions, one force set per foot), made from a real trial of
``../shared/data`` (the motions of :data:`MOTIONS`, in turn):

1. markers (the real trial's; with ``refit-*`` truths, the marker model's on the motion the
   real fit saw) with white noise of :data:`MARKER_NOISE` per coordinate (each subject its
   own draw, so each has its own inverse kinematics, as in a real study), written as a TRC and
   loaded back as the batch loads it; the kinematics computed from it are the truth's motion
   (the fitter sees the same: no error in the kinematics; ``refit-true``: the noise-free
   kinematics are the truth's);
2. the truth: the default model fitted to the real trial and frozen (:func:`motion_truth`:
   by default ``refit-seen``, refitted on the motion the real fit saw as the fitter sees it,
   without pose correction and with n fixed; ``--truth fitted-pose``: the real fit with its
   pose corrections in the true motion; other designs there with why they failed),
   then per subject the stiffness of every unit scaled by one factor
   ``s`` (log-normal, SD :data:`STIFFNESS_SPREAD`) and the friction coefficient drawn
   uniformly in :data:`MU_RANGE` (mass scaled by ``s`` too, so the forces stay near one body
   weight);
3. the plates: the truth's wrench on the real trial's stance windows (the frames each fitted
   stance spans, margins included), white noise of ``PLATE_NOISE_PCT_BW`` (forces; moments
   that times 20 mm), set to zero below 20 N (a thresholded plate) and zero elsewhere, written
   in OpenSim's external-loads layout (``gc_ocp.export.write_grf``).

**The runs.** The manifest (CSV: subject, trial, grf, mass, height) goes to
``gc_ocp.batch.run`` with 1 and 2 workers (fresh output folders, measured in one run), then
to a loop of ``gc-ocp fit`` commands (``--skip-loop`` leaves it out).

**The z-scores.** From the 2-worker run's ``summary.csv``: for every subject and foot,
``z = (estimate - truth) / SE`` of each unit's force at the reference depth (``f_ref``) and of
the shared ``n``, ``c`` and ``mu``; their mean, SD and the share within +-1.96 (a 95 %
interval's coverage; 95 % if the SEs are right, binomial spread sqrt(.95 .05 / N)). What the
fit itself reports as not identified (a unit flagged ``unit_not_identified``, a parameter
``at_bound``: its SE is not meaningful, the report says so) is left out and counted, as a
user reading the report would leave it out; so is a truth on a bound (its z is not normal).
One trial per subject: a unit that hardly touches the ground in two or three stances is not
identified, in the real fit the truth comes from as in the synthetic one.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
MOTIONS = (
    ("plugingait_overground/test_small.c3d", None, None),
    ("vicon_plugingait_btk/PiG_Motion3_FF.c3d", None, None),
    ("motionanalysis_helenhayes/Gait.c3d", None, None),
    ("opensim_rajagopal_overground/motion_capture_walk.trc", "grf_walk.mot", 85.07),
)
"""(trial, its GRF file for a TRC, mass [kg] where the files lack it): the real motions."""
MARKER_NOISE = 0.5e-3
"""[m] White noise per marker coordinate of a subject's TRC (a good lab's reconstruction)."""
STIFFNESS_SPREAD = 0.25
"""SD of log(s), the subject's stiffness factor (about +-25 %)."""
MU_RANGE = (0.4, 0.9)
"""The true friction coefficient's range."""
THRESHOLD = 20.0
"""[N] The plates' zero threshold."""
MAX_PASSES = 6
"""Most passes of kinematics and plates until the kinematics hold (make_subject)."""
TRUTH_MARGIN = 0.1
"""[s] How much wider than the real stance's window the truth's wrench is written
(:func:`truth_windows`): a swing is 0.35-0.45 s, so two widened windows of one foot do not
meet, and the frames the fitter's margins add to a stance (:data:`gc_ocp.workflow.fitting.MARGIN`,
on plates the truth made) lie inside."""
KIN_TOL = 2e-5
"""[m] The passes stop when no foot point moves more than this between two passes (a fiftieth
of a millimetre), or when the move stops shrinking: a stance's onset can move by a fraction of
a frame and back, a two-cycle of the sole height's calibration window (0.3 mm on a bundled
subject); the fitter's kinematics then differ from the truth's by that much, reported per
subject."""


def _moved(a, b) -> float:
    """[m] The largest move of a foot point between kinematics ``a`` and ``b``."""
    return max(
        float(np.nanmax(np.abs(a.feet[side].positions - b.feet[side].positions))) for side in a.feet
    )


TRUE_N = 1.5
"""The ``refit-seen`` truth's penetration exponent (Hertz's)."""


PLAUSIBLE_F_REF = (0.01, 3.0)
"""[BW] A unit's plausible force at the reference depth (5 mm): a real fit can push a unit its
stances hardly load far outside (flagged not identified; up to 1000 BW seen)."""


def _plausible(truth: tuple, body_weight: float) -> tuple:
    """``truth`` with each unit outside :data:`PLAUSIBLE_F_REF` made plausible, by the reason a
    real fit leaves it there. *Too stiff*: the stances hardly reach the unit, so its stiffness
    is barely seen (up to 1000 BW at 5 mm); it takes its foot's median, a typical unit (a unit
    at hundreds of body weights turns a tenth of a millimetre of kinematic error into
    thousands of newtons). *Too soft*: the motion pushes the unit deep while the plates show
    no such force; it is clipped to the lower bound and stays soft. Until 2026-11-30 it took
    the median too: on the bundled motion, since the fit's pose correction is a rotation
    (41f6977), the refitted right medial forefoot unit sits at 0.009 BW, and the median
    (1.1 BW) made it 120 times stiffer where the motion pushes it deep: every bundled
    subject's right plate carried 2-5 body weights at push-off and failed the body-weight
    check. Clipping every unit both ways instead spoilt other motions' truths (a heel unit
    of Rajagopal's at 423 BW became a 3 BW heel that every heel strike loads)."""
    import dataclasses as dc

    from gc_ocp.estimation.components.contact import Param

    law = next(c for c in truth if c.name == "contact")
    scale = law.reference_depth ** float(law.n.value)  # f_ref = k d_ref^n
    lo, hi = (b * body_weight for b in PLAUSIBLE_F_REF)
    k = {}
    for side, ks in law.k.value.items():
        ok = [v * scale for v in ks.values() if lo <= v * scale <= hi]
        mid = float(np.median(ok)) if ok else 0.2 * body_weight
        k[side] = {
            u: (mid if v * scale > hi else max(v * scale, lo)) / scale for u, v in ks.items()
        }
    law = dc.replace(law, k=Param("fixed", k))
    return tuple(law if c.name == "contact" else c for c in truth)


def motion_truth(spec, design: str = "refit-seen"):
    """(trial, kinematics, stances, frozen truth, its fit) of one real motion.

    ``refit-seen`` (default, the committed run of 2026-11-27): the motion a real fit saw (the
    recorded kinematics with each stance's foot moved by the fit's pose correction, reached by
    the leg's joints, ``gc_ocp.export.fitted_kinematics``), as the fitter sees it: the marker
    model's markers on it, through the fitter's own inverse kinematics (returned as the
    kinematics). The law is refitted there to the real plates with the exponent fixed at
    :data:`TRUE_N` and without any pose correction (the sole correction stays, comment in the
    code). Each subject's truth moves exactly as the kinematics the fitter computes from its
    noisy TRC, with its units on the fitter's own unit points (:func:`make_subject`), so the
    pose prior (centred on no correction) is right; the sole offsets are the refit's, 13-24 mm
    (median norm per motion), 3-5 sigma of the 5 mm prior, as a real fit of these files gives.

    ``refit-true`` (8-subject pilot): the same truth, moving by the noise-free kinematics; the
    fitter sees the noisy markers' (errors in variables, issue 23).

    ``refit-subject`` (not usable): the law refitted per subject on the subject's own
    kinematics without sole correction (:func:`subject_refit`), both priors at their centres.
    The kinematics depend on the plates through the stances' timing, so the subject's plates
    and kinematics must be iterated; without sole offsets the refitted units are so stiff that
    the timing (and a stance's side) oscillates between two states and never settles, and the
    plates of 5 of 8 pilot subjects carried 0.6-2800 body weights.

    ``fitted-pose`` (the first committed run) is described last.
    ``corrected`` (not yet usable: with the implausible units reset, 3 of 4 pilot subjects still
    fail the batch's mass check, the synthetic plates carrying 34-70 % less or 66 % more than
    the body weight over the stride the check picks; not understood yet): the default model fitted to the real stances and frozen (the
    per-stance pose correction left out), and the motion the fit saw: the recorded kinematics
    with each stance's foot moved by the fit's pose correction, reached by the leg's joints
    (``gc_ocp.export.fitted_kinematics``); the subject's markers are the marker model's on that
    motion (:func:`make_subject`), so the fitter's inverse kinematics find it again and its
    pose prior, centred on no correction, is right. The fit's result is returned as the fourth
    item's companion (for the corrected coordinates: ``(result, kinematics)``).

    ``no-pose`` (pathological, kept as the record of why): the default model *without* the per-stance pose correction fitted to
    the real stances and frozen, each implausible unit (:data:`PLAUSIBLE_F_REF`) made
    plausible (:func:`_plausible`): the true foot moves as the recorded kinematics say, which is what the fitter's pose
    prior (centred on no correction) assumes; the fit returned is None. On real kinematics a
    foot of some stances lies centimetres in the floor without its correction, and the plates
    this truth makes carry 10^5-10^9 N there: every subject fails the mass check.

    ``fitted-pose``: the default model fitted and frozen but the per-stance pose correction,
    which the truth's data take at the fit's values (``simulate(at=fit)``): the true foot moves
    as the recorded kinematics corrected by it, the fitter sees the recorded kinematics and
    must find the correction again under its prior (the design of the first run; its z-scores
    show that prior's pull, ``docs/batch.md``)."""

    from gc_ocp.estimation.components import full_model
    from gc_ocp.estimation.starts import estimate, frozen_model, with_lls_start
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics
    from gc_ocp.workflow.fitting import fit_data

    path, grf, mass = spec
    path = DATA / path
    trial = load_trial(path, None if grf is None else path.parent / grf, mass=mass)
    kin = compute_kinematics(trial)
    _, stances, _ = fit_data([(trial, kin)])
    model = full_model()
    if design == "no-pose":
        model = tuple(c for c in model if c.scope != "stance")
    model = with_lls_start(model, stances)
    res = estimate(stances, model)
    truth = frozen_model(model, res)
    if design == "fitted-pose":
        return trial, kin, stances, truth, res
    if design in ("corrected", "refit-seen", "refit-subject", "refit-true"):
        from gc_ocp.export.fitted_kinematics import fitted_kinematics

        points = {side: f.points_local for side, f in kin.feet.items()}
        fk = fitted_kinematics(res.to_json(), kin, points)
        if design == "corrected":
            truth = _plausible(tuple(c for c in truth if c.scope != "stance"), trial.body_weight)
            return trial, fk.kin, stances, truth, None
        # refit-seen: the corrected motion as the fitter sees it (the marker model's markers on
        # it, through the fitter's own inverse kinematics), and the law refitted there to the
        # real plates without any pose correction: the truth's feet move exactly as the
        # kinematics the fitter computes say, so its pose prior (centred on none) is right
        from gc_ocp.export import write_grf, write_trc
        from gc_ocp.export.opensim_export import plate_wrenches

        mm = fk.kin.info["marker_model"]
        with tempfile.TemporaryDirectory() as tmp:
            trc, mot = Path(tmp) / "seen.trc", Path(tmp) / "seen_grf.mot"
            write_trc(trc, list(mm.names), mm.positions(fk.kin.q), trial.marker_time)
            t = trial.marker_time
            write_grf(mot, t, plate_wrenches(trial, t), trial.floor_height)
            seen_trial = load_trial(trc, mot, mass=trial.mass, height=trial.height)
            seen = compute_kinematics(seen_trial)
        _, seen_stances, _ = fit_data([(seen_trial, seen)])
        # n fixed at Hertz's 1.5: refitted free, it went to its lower bound 1.0 on 3 of 4
        # motions, and a truth on a bound is not a test of the standard errors
        from gc_ocp.estimation.components.contact import Param

        # (the sole correction stays: refitted without it, the units take stiffnesses that turn
        # the subject's own landmark estimate, 1.5 mm from this one, into 2-4 body weights on
        # the plates; with it, its offsets sit 3-5 sigma from its prior's centre, as in a real
        # fit of these files, which the fitter's prior shrinks)
        model = tuple(
            dataclasses.replace(c, n=Param("fixed", TRUE_N)) if c.name == "contact" else c
            for c in full_model()
            if c.scope != "stance"
        )
        model = with_lls_start(model, seen_stances)
        res = estimate(seen_stances, model)
        truth = _plausible(frozen_model(model, res), trial.body_weight)
        return trial, seen, seen_stances, truth, None
    truth = _plausible(truth, trial.body_weight)
    return trial, kin, stances, truth, None


def subject_refit(seen, kin) -> tuple:
    """The ``refit-subject`` truth of one subject: the law (n fixed at :data:`TRUE_N`) refitted
    on the subject's own kinematics ``kin`` of its trial ``seen`` (loaded with the real
    plates) to the real plates, with neither pose nor sole correction: the truth's feet move as
    the fitter's kinematics say and its units sit on the fitter's own unit points, the centres
    of both priors. Units the real plates hardly load keep the stiffness this fit gives them
    (the fitter flags them not identified as well)."""
    from gc_ocp.estimation.components import full_model
    from gc_ocp.estimation.components.contact import Param
    from gc_ocp.estimation.starts import estimate, frozen_model, with_lls_start
    from gc_ocp.workflow.fitting import fit_data

    _, stances, _ = fit_data([(seen, kin)])
    model = tuple(
        dataclasses.replace(c, n=Param("fixed", TRUE_N)) if c.name == "contact" else c
        for c in full_model()
        if c.scope != "stance" and c.name != "sole"
    )
    model = with_lls_start(model, stances)
    return frozen_model(model, estimate(stances, model))


def subject_truth(truth: tuple, rng) -> tuple[tuple, float]:
    """(the subject's truth, its stiffness factor s): module doc, 2."""
    from gc_ocp.estimation.components.contact import Param

    s = float(np.exp(rng.normal(0.0, STIFFNESS_SPREAD)))
    out = []
    for c in truth:
        if c.name == "contact":
            k = {side: {u: v * s for u, v in ks.items()} for side, ks in c.k.value.items()}
            c = dataclasses.replace(
                c, k=Param("fixed", k), mu=Param("fixed", float(rng.uniform(*MU_RANGE)))
            )
        out.append(c)
    return tuple(out), s


def true_values(truth: tuple) -> dict:
    """``{side: {unit: f_ref}, "n": .., "c": .., "mu": ..}`` of a frozen truth."""
    law = next(c for c in truth if c.name == "contact")
    n = float(law.n.value)
    out = {
        side: {u: k * law.reference_depth**n for u, k in ks.items()}
        for side, ks in law.k.value.items()
    }
    out.update(n=n, c=float(law.c.value), mu=float(law.mu.value))
    return out


def _write_plates(path: Path, t: np.ndarray, sim, noise=None) -> Path:
    """The simulated stances' wrenches (about the ``lab`` origin) as a GRF file at ``path``,
    zero off the stances, each stance's wrench plus ``noise(n)`` (``(n, 6)``, drawn stance by
    stance; None: none)."""
    from gc_ocp.export import write_grf
    from gc_ocp.wrench import transport_wrench

    wrench = {side: np.zeros((t.size, 6)) for side in ("left", "right")}
    height = {side: np.zeros(t.size) for side in ("left", "right")}
    for st in sim:
        idx = np.searchsorted(t, st.time)
        w = transport_wrench(st.measured, st.reference_point, np.zeros(3))
        wrench[st.side][idx] = w if noise is None else w + noise(idx.size)
        height[st.side][idx] = st.ground_height
    return write_grf(path, t, wrench, height, min_force=THRESHOLD)


def truth_windows(real, kin, stances) -> list:
    """The frames the truth's wrench is written on: each real stance's window (its margin
    included; ``real``: the subject's TRC loaded with the real plates) widened by
    :data:`TRUTH_MARGIN` each side, on the subject's kinematics ``kin`` (its own unit points). A plate cut where the truth still carries load is a step no model
    fits: the Helen Hayes truth still loads its left foot at the real window's end (the
    refit's law carried past the real stance), and cut there it moved the fitted n by +3 SE."""
    from gc_ocp.workflow.fitting import MARGIN, fit_data

    _, wide, _ = fit_data([(real, kin)], margin=MARGIN + TRUTH_MARGIN)
    for st in stances:  # every truth stance inside one widened window of its foot
        if not any(
            w.side == st.side and w.time[0] <= st.time[0] and st.time[-1] <= w.time[-1]
            for w in wide
        ):
            raise RuntimeError(
                f"{real.source}: no widened window holds the truth's stance {st.label}"
            )
    return wide


def make_subject(
    j: int, spec, motion, folder: Path, real_grf: Path, design: str = "fitted-pose"
) -> dict:
    """Write subject ``j``'s files (module doc) and return its manifest row and truth;
    ``real_grf``: the real trial's plates as an OpenSim file, to load the subject's TRC for its
    kinematics only (a TRC needs a GRF file to load); ``design``: the truth's
    (:func:`motion_truth`; with ``refit-seen`` and ``refit-subject`` the truth's units sit on
    the subject's own unit points and the kinematics are computed with the subject's own
    plates, comment below; with ``refit-subject`` the law is refitted on the subject's own
    kinematics, :func:`subject_refit`)."""
    from gc_ocp.estimation.synthetic import PLATE_NOISE_PCT_BW, TORQUE_NOISE_LENGTH, simulate
    from gc_ocp.export import write_trc
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics

    trial, true_kin, stances, base, fitted = motion
    rng = np.random.default_rng(1000 + j)
    truth, s = subject_truth(base, rng)
    sid = f"syn{j:02d}"
    folder.mkdir(parents=True, exist_ok=True)
    trc = folder / f"{sid}_walk.trc"
    grf = folder / f"{sid}_walk_grf.mot"
    own_points = design in ("refit-seen", "refit-subject")
    if fitted is None:  # the marker model's markers on the true motion (motion_truth)
        mm = true_kin.info["marker_model"]
        names, markers = list(mm.names), mm.positions(true_kin.q)
    else:  # the real markers
        names, markers = trial.marker_names, trial.markers
    noisy = markers + rng.normal(0.0, MARKER_NOISE, markers.shape)
    write_trc(trc, names, noisy, trial.marker_time)
    # the kinematics the fitter will compute from this TRC (the truth moves as they say); the
    # stance windows (widened with own points, truth_windows) and reference points are the
    # real trial's. ``own_points`` (refit-seen, refit-subject): the truth's units sit on the
    # subject's own landmark estimate (the fitter's unit points; the truth's sole offsets are
    # relative to them). The kinematics depend on the plates through the stances' timing (the
    # sole height is calibrated over 20-45 % of each stance): passes go on, each computing them
    # with the previous pass's noise-free plates (and refitting the refit-subject truth on
    # them), until they hold to KIN_TOL; the fitter then sees the kinematics the truth moved by
    source, last, residual = real_grf, None, 0.0
    # the subject's TRC with the real plates: their stance windows (own points)
    real = load_trial(trc, real_grf, mass=trial.mass, height=trial.height) if own_points else None
    for _ in range(MAX_PASSES if own_points else 1):
        if design == "refit-true":  # the truth moves by the noise-free kinematics
            kin = true_kin
        else:
            seen = load_trial(trc, source, mass=trial.mass, height=trial.height)
            kin = compute_kinematics(seen)
        if last is not None:
            moved = _moved(kin, last)
            if moved < KIN_TOL or moved >= residual > 0:
                residual = moved
                break  # the plates at ``source``: the truth on ``last``, ``moved`` from these
            residual = moved
        if own_points:  # on the subject's own unit points, windows widened
            cut = truth_windows(real, kin, stances)
        else:
            cut = []
            for st in stances:
                foot = kin.feet[st.side].window(st.time[0], st.time[-1])
                if foot.time.shape != st.time.shape:
                    raise RuntimeError(
                        f"{trc}: stance {st.label} has other frames in the TRC's kinematics"
                    )
                if fitted is None:  # the fit's unit points
                    foot = foot.with_points(true_kin.feet[st.side].points_local)
                cut.append(st.with_foot(foot))
        if design == "refit-subject":  # to the real plates, on these kinematics
            truth, s = subject_truth(subject_refit(real, kin), np.random.default_rng(2000 + j))
        # at=None: no pose correction; no noise here (added once below)
        sim = simulate(cut, truth, rng, plate_noise_pct_bw=0.0, at=fitted)
        if own_points:
            source, last = _write_plates(grf, kin.time, sim), kin
    else:
        if own_points:
            raise RuntimeError(f"{trc}: the kinematics still moved after {MAX_PASSES} passes")
    if own_points:
        kin = last  # the kinematics the plates were simulated on
    bw = trial.body_weight * s
    sd = PLATE_NOISE_PCT_BW / 100 * bw * np.array([1, 1, 1, *3 * [TORQUE_NOISE_LENGTH]])
    _write_plates(grf, kin.time, sim, lambda n: rng.normal(0.0, 1.0, (n, 6)) * sd)
    row = {
        "subject": sid,
        "trial": trc.name,
        "grf": grf.name,
        "mass": f"{trial.mass * s:.4f}",
        "height": "" if trial.height is None else f"{trial.height:.4f}",
    }
    out = {"row": row, "truth": true_values(truth), "s": s, "motion": spec[0]}
    return {**out, "kinematics_residual_mm": residual * 1e3}


def write_study(n: int, work: Path, design: str = "refit-seen") -> tuple[Path, list[dict]]:
    from gc_ocp.export import write_grf
    from gc_ocp.export.opensim_export import plate_wrenches

    data = work / "subjects"
    motions, real_grf = {}, {}
    for spec in MOTIONS:
        motions[spec[0]] = motion_truth(spec, design)
        trial = motions[spec[0]][0]
        p = work / "real" / (Path(spec[0]).stem + "_grf.mot")
        p.parent.mkdir(parents=True, exist_ok=True)
        t = trial.marker_time
        write_grf(p, t, plate_wrenches(trial, t), trial.floor_height)
        real_grf[spec[0]] = p
    subjects = []
    for j in range(n):
        spec = MOTIONS[j % len(MOTIONS)]
        subjects.append(make_subject(j, spec, motions[spec[0]], data, real_grf[spec[0]], design))
        print(f"  subject {j + 1}/{n} written ({spec[0]})", flush=True)
    manifest = data / "study.csv"
    with manifest.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(subjects[0]["row"]))
        w.writeheader()
        for s in subjects:
            w.writerow(s["row"])
    return manifest, subjects


def _unidentified(fit_json: Path) -> set[str]:
    """What the fit itself flags as not identified: ``"left/PM"`` (a unit), ``"n"`` (a shared
    parameter at a bound)."""
    import json

    out = set()
    for f in json.loads(fit_json.read_text()).get("flags", []):
        what = str(f.get("what", ""))
        if f["code"] == "unit_not_identified":
            out.add(what)
        elif f["code"] == "at_bound" and what.startswith("contact/"):
            parts = what.split("/")[1:]
            out.add("/".join(parts[1:]) if parts[0] == "k" else parts[0])
    return out


def z_scores(out: Path, subjects: list[dict]) -> tuple[dict[str, list[float]], dict[str, int]]:
    """z-scores of every parameter the fit reports as identified, and how many were left out
    (the fit flags it: a unit not identified, a parameter at its bound; or the truth on a
    bound)."""
    from gc_ocp.foot import UNITS

    truth = {s["row"]["subject"]: s["truth"] for s in subjects}
    bounds = {"n": (1.0, 3.0), "c": (0.0, 10.0), "mu": (0.0, 1.5)}
    z: dict[str, list[float]] = {"f_ref": [], "n": [], "c": [], "mu": []}
    left_out: dict[str, int] = dict.fromkeys(z, 0)
    seen = set()
    with (out / "summary.csv").open() as fh:
        for r in csv.DictReader(fh):
            if r["status"] != "done":
                continue
            sid, foot = r["subject"], r["foot"]
            tr = truth[sid]
            flagged = _unidentified(out / sid / "fit.json")
            for u in UNITS:
                est, se = r[f"f_ref_{u}_N"], r[f"f_ref_{u}_N_se"]
                if f"{foot}/{u}" in flagged or not (est and se and float(se) > 0):
                    left_out["f_ref"] += 1
                    continue
                z["f_ref"].append((float(est) - tr[foot][u]) / float(se))
            if sid in seen:
                continue
            seen.add(sid)
            for p in ("n", "c", "mu"):
                if not r[p] or not r[f"{p}_se"]:
                    continue
                lo, hi = bounds[p]
                if p in flagged or not lo + 1e-6 < tr[p] < hi - 1e-6 or float(r[f"{p}_se"]) <= 0:
                    left_out[p] += 1
                    continue
                z[p].append((float(r[p]) - tr[p]) / float(r[f"{p}_se"]))
    return z, left_out


def print_z(z: dict, left_out: dict) -> None:
    """The z-scores' table (:func:`z_scores`)."""
    print("| parameter | z-scores | mean | SD | within +-1.96 | left out: flagged by the fit |")
    print("|---|---|---|---|---|---|")
    for p, v in z.items():
        v = np.asarray(v)
        if v.size == 0:
            print(f"| {p} | 0 | - | - | - | {left_out[p]} |")
            continue
        cov = np.mean(np.abs(v) < 1.96)
        spread = np.sqrt(0.95 * 0.05 / v.size)
        print(
            f"| {p} | {v.size} | {v.mean():+.2f} | {v.std(ddof=1):.2f} | {cov:.0%} "
            f"(+-{spread:.0%} binomial at 95 %) | {left_out[p]} |"
        )


def by_motion(work: Path, folder: str = "out_2") -> None:
    """Print the z-scores of a finished run (``work``: its ``subjects/truth.json`` and
    ``folder``) by motion: the units' forces (split by whether the fit flags the unit's sole
    correction beyond its prior) and n, c, mu (mean and SD of z, coverage)."""
    from gc_ocp.foot import UNITS

    truth = json.loads((work / "subjects" / "truth.json").read_text())
    names = [spec[0].split("/")[0] for spec in MOTIONS]
    with (work / folder / "summary.csv").open() as fh:
        rows = [r for r in csv.DictReader(fh) if r["status"] == "done"]
    zf = {m: {"no flag": [], "sole flagged": []} for m in names}
    zp = {m: {p: [] for p in ("n", "c", "mu")} for m in names}
    for r in rows:
        sid, foot = r["subject"], r["foot"]
        m, tr = names[int(sid[3:]) % len(names)], truth[sid]
        fit = json.loads((work / folder / sid / "fit.json").read_text())
        flagged = {f.get("what") for f in fit.get("flags", [])}
        for u in UNITS:
            est, se = r[f"f_ref_{u}_N"], r[f"f_ref_{u}_N_se"]
            if f"{foot}/{u}" in _unidentified(work / folder / sid / "fit.json") or not (
                est and se and float(se) > 0
            ):
                continue
            key = "sole flagged" if f"sole/{foot}/{u}" in flagged else "no flag"
            zf[m][key].append((float(est) - tr[foot][u]) / float(se))
        if foot == "left":
            for p in zp[m]:
                if r[p] and r[f"{p}_se"] and float(r[f"{p}_se"]) > 0:
                    zp[m][p].append((float(r[p]) - tr[p]) / float(r[f"{p}_se"]))

    def cell(v) -> str:
        v = np.asarray(v)
        if v.size == 0:
            return "-"
        return f"{v.size}: {v.mean():+.2f}, {v.std(ddof=1):.2f}, {np.mean(np.abs(v) < 1.96):.0%}"

    print(
        "| motion | f_ref, sole not flagged | f_ref, sole flagged beyond its prior | n | c | mu |"
    )
    print("|---|---|---|---|---|---|")
    for m in names:
        cells = [cell(zf[m]["no flag"]), cell(zf[m]["sole flagged"])]
        cells += [cell(zp[m][p]) for p in ("n", "c", "mu")]
        print(f"| {m} | " + " | ".join(cells) + " |")
    print("\n(each cell: z-scores: mean, SD, share within +-1.96)")


def loop(manifest: Path, work: Path) -> int:
    """One ``gc-ocp fit`` command per subject, one after the other: how many exited 0."""
    from gc_ocp.batch.manifest import read_manifest

    ok = 0
    for sub in read_manifest(manifest):
        spec = sub.trials[0]
        cmd = [
            sys.executable,
            "-m",
            "gc_ocp.cli",
            "fit",
            str(spec.path),
            "--grf",
            str(spec.grf),
            "--mass",
            str(sub.mass),
            "--out",
            str(work / "loop" / sub.id),
        ]
        if sub.height:
            cmd += ["--height", str(sub.height)]
        ok += subprocess.run(cmd, capture_output=True).returncode == 0
    return ok


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--subjects", type=int, default=40)
    ap.add_argument("--work", type=Path, default=None)
    ap.add_argument("--skip-loop", action="store_true")
    ap.add_argument(
        "--truth",
        choices=(
            "refit-true",
            "refit-subject",
            "refit-seen",
            "corrected",
            "no-pose",
            "fitted-pose",
        ),
        default="refit-seen",
        help="the truth's design (motion_truth; the first run used fitted-pose)",
    )
    ap.add_argument(
        "--workers",
        type=int,
        nargs="+",
        default=[1, 2],
        help="the batch runs, by workers (the z-scores come from the last)",
    )
    ap.add_argument(
        "--by-motion",
        metavar="FOLDER",
        default=None,
        help="only the z-scores by motion of the run already in --work/FOLDER (e.g. out_2)",
    )
    ap.add_argument(
        "--sole-run",
        action="store_true",
        help="also run the subjects with the sole correction's 5 mm prior (sole_scale=False; "
        "the default estimates its width; runs before 2026-11-27 had it the other way round)",
    )
    ap.add_argument(
        "--loop-only",
        action="store_true",
        help="only the loop of gc-ocp fit on the subjects already written in --work",
    )
    args = ap.parse_args()
    work = args.work or Path(tempfile.mkdtemp(prefix="batch_synthetic_"))
    warnings.simplefilter("ignore")
    from gc_ocp.batch import run
    from gc_ocp.batch.manifest import read_manifest

    t0 = time.perf_counter()
    if args.by_motion:
        by_motion(work, args.by_motion)
        return
    if args.loop_only:
        t = time.perf_counter()
        ok = loop(work / "subjects" / "study.csv", work)
        wall = time.perf_counter() - t
        n = len(read_manifest(work / "subjects" / "study.csv"))
        print(f"| loop of `gc-ocp fit` | {wall:.0f} | {wall / n:.1f} | - | {ok} exit 0 |")
        return
    manifest, subjects = write_study(args.subjects, work, args.truth)
    print("# Synthetic subjects through the batch (`benchmarks/batch_synthetic.py`)\n")
    print(
        f"{len(subjects)} subjects written in {time.perf_counter() - t0:.0f} s "
        f"(motions: {', '.join(m[0] for m in MOTIONS)}); manifest {manifest}.\n"
    )
    rows = []
    for workers in args.workers:
        out = work / f"out_{workers}"
        t = time.perf_counter()
        res = run(manifest, out, workers=workers)
        wall = time.perf_counter() - t
        mem = [s.get("peak_rss_mb") for s in res.subjects if s.get("peak_rss_mb")]
        status = {}
        for s in res.subjects:
            status[s["status"]] = status.get(s["status"], 0) + 1
        rows.append((f"batch, {workers} worker(s)", wall, max(mem) if mem else None, status))
    if not args.skip_loop:
        t = time.perf_counter()
        ok = loop(manifest, work)
        rows.append(("loop of `gc-ocp fit`", time.perf_counter() - t, None, f"{ok} exit 0"))
    n = len(subjects)
    print("| run | wall time [s] | per subject [s] | peak memory of a worker [MB] | subjects |")
    print("|---|---|---|---|---|")
    for name, wall, mem, status in rows:
        m = "-" if mem is None else f"{mem:.0f}"
        print(f"| {name} | {wall:.0f} | {wall / n:.1f} | {m} | {status} |")
    last = args.workers[-1]
    (work / "subjects" / "truth.json").write_text(
        json.dumps({s["row"]["subject"]: s["truth"] for s in subjects}, indent=1)
    )
    print(f"\nTruth design: {args.truth} (motion_truth).")
    res_mm = np.array([s["kinematics_residual_mm"] for s in subjects])
    print(
        "The fitter's kinematics against those the truth moved by (make_subject, KIN_TOL): "
        f"median {np.median(res_mm):.3f} mm, max {res_mm.max():.3f} mm over the subjects."
    )
    runs = [(f"out_{last}", f"{last}-worker run")]
    if args.sole_run:  # the same subjects with the sole correction's fixed 5 mm prior
        from gc_ocp.batch.subject import Settings

        run(manifest, work / "out_sole", workers=last, settings=Settings(sole_scale=False))
        runs.append(("out_sole", f"{last}-worker run, the 5 mm sole prior (sole_scale=False)"))
    for folder, what in runs:
        z, left_out = z_scores(work / folder, subjects)
        print(f"\nz = (estimate - truth) / SE, {what}, of what each fit reports identified:\n")
        print_z(z, left_out)
        print(f"\nBy motion ({what}):\n")
        by_motion(work, folder)
    print(f"\nTotal {time.perf_counter() - t0:.0f} s. Work folder: {work}")


if __name__ == "__main__":
    main()
