"""The subcommands: one ``cmd_*`` function each, ``args`` in, exit status out (errors are raised
and turned into one line and a status by :func:`gc_ocp.cli.main`)."""

from __future__ import annotations

import argparse
import dataclasses
import sys

from gc_ocp.cli.common import (
    _effect_list,
    _kinematics,
    _load,
    _load_one,
    _load_subject,
    _print_landmarks,
    _progress,
    _trial_files,
)
from gc_ocp.errors import InputError, SolveError
from gc_ocp.text import json_text
from gc_ocp.workflow.provenance import provenance


def _print_skipped(skipped) -> None:
    """The trials left out of a fit or diagnosis, after its summary (also printed as skipped)."""
    for s in skipped:
        print(f"not used: {s.describe()}")


def cmd_info(args: argparse.Namespace) -> int:
    """Describe every trial; one that cannot be read is reported and the others described
    (exit status 2 at the end if any failed: a lab's folder is checked in one run), as is a
    mass the plates contradict beyond what a fit accepts (described, then refused), and so is a
    belt speed the stance feet contradict."""
    from gc_ocp.io import describe_trial
    from gc_ocp.io.consistency import belt, body_weight

    files = _trial_files(args)
    failed = refused = 0
    for f in files:
        try:
            trial = _load_one(args, f)
        except InputError as e:
            if len(files) == 1:
                raise
            failed += 1
            print(f"gc-ocp info: error: {' '.join(str(e).split())}", file=sys.stderr)
            continue
        print(describe_trial(trial))
        print()
        try:  # what a fit refuses of the subject's values (--mass in pounds, --belt-speed in
            # km/h): bad input, said as the fit says it
            body_weight(trial)
            belt(trial)
        except InputError as e:
            refused += 1
            print(f"gc-ocp info: error: {' '.join(str(e).split())}", file=sys.stderr)
    if failed:
        print(
            f"gc-ocp info: {failed} of {len(files)} trials could not be read (above); the "
            "others are described.",
            file=sys.stderr,
        )
    return 2 if failed or refused else 0


KINEMATICS_OUTPUTS = (
    "sole_points.csv",
    "sole_points.npz",
    "kinematics_summary.json",
    "landmarks.json",
    "kinematics.png",
)
"""Every file ``gc-ocp kinematics`` may write in a trial's folder (one set, replaced as a whole)."""


def cmd_kinematics(args: argparse.Namespace) -> int:
    from gc_ocp.kinematics.export import write_kinematics
    from gc_ocp.outputs import OutputSet, check_writable, claim

    check_writable(args.out, command="gc-ocp kinematics")  # before any computation
    trials = _load(args)
    names = [t.name for t in trials]
    kins = []
    for trial in trials:  # every trial posed before anything is written: a trial that cannot
        # be posed left the earlier trials' folders in --out, a study's part looking whole
        kins.append(_kinematics(trial, args))
        _print_landmarks(kins[-1])
    sets = []
    try:
        for i, (trial, kin) in enumerate(zip(trials, kins, strict=True)):
            sub = trial.name if names.count(trial.name) == 1 else f"{i + 1}_{trial.name}"
            out = args.out if len(trials) == 1 else args.out / sub  # one folder per trial
            # staged and moved in together: an interrupt while the figure was drawn left the
            # trajectories without their summary and figure (or beside an earlier run's)
            sets.append(OutputSet(out, KINEMATICS_OUTPUTS, "gc-ocp kinematics"))
            for p in write_kinematics(trial, kin, sets[-1].stage, fmt=args.format):
                sets[-1].path(p.name)
        paths = [p for files in sets for p in files.commit()]
    finally:
        for files in sets:
            files.discard()
    for p in paths:
        print(f"wrote {p}")
    if len(trials) > 1:  # the folder of the trials' folders (one trial's set claims its own)
        claim(args.out, "gc-ocp kinematics")
    return 0


def cmd_reproduce_seed(args: argparse.Namespace) -> int:
    from gc_ocp.contact.seed_study import (
        SEED_COMMAND,
        reproduce_seed,
        table1_markdown,
        table2_markdown,
    )
    from gc_ocp.io.consistency import belt
    from gc_ocp.outputs import check_writable

    check_writable(args.out, command=SEED_COMMAND)  # before any computation
    if args.seeds < 1:
        raise InputError(f"--seeds must be 1 or more, but got {args.seeds}")
    trials = _load(args)
    if len(trials) != 1:
        raise InputError(
            f"reproduce-seed takes one trial, but got {len(trials)}; run it once per trial."
        )
    [trial] = trials
    kin = _kinematics(trial, args)
    # a treadmill's belt, as fit sets it (its friction slides against the belt, not the floor)
    trial, notes = belt(trial)
    for note in notes:
        _progress(f"check: {note}")
    res = reproduce_seed(
        trial,
        kin,
        seeds=args.seeds,
        out_dir=args.out,  # the four tables as one set, the folder claimed with them
        progress=lambda done, total, label: _progress(f"[{done}/{total}] {label}"),
    )
    for note in res["notes"]:
        _progress(f"note: {note}")
    print(table1_markdown(res["table1"]))
    print(table2_markdown(res["table2"]))
    print(f"wrote table1.json, table1.md, table2.json, table2.md to {args.out}")
    return 0


def fit_model(effects: list[str] | None) -> tuple | None:
    """``gc-ocp fit``'s model: :func:`~gc_ocp.estimation.components.full_model` plus the
    registered ``effects`` (None: the full model itself); an effect the full model already has
    is refused (it would estimate the same physics twice)."""
    from gc_ocp.estimation.components import REGISTRY, full_model, model_from_names

    if effects is None:
        return None
    base = full_model()
    have = [e for e in effects if REGISTRY[e].present_in(base)]
    if have:
        free = [e for e in REGISTRY if REGISTRY[e].candidate and not REGISTRY[e].present_in(base)]
        raise InputError(
            f"--effects: {', '.join(have)} already in the fitted model (gc-ocp fit fits the full "
            f"model: contact law with n, c, mu; sole, pose and belt corrections); choose from "
            f"{', '.join(free)}."
        )
    return model_from_names(effects, base=base)


def cmd_fit(args: argparse.Namespace) -> int:
    from gc_ocp.estimation.components import full_model
    from gc_ocp.outputs import OutputSet, check_writable
    from gc_ocp.workflow.fit_files import FIT_OUTPUTS, write_fit
    from gc_ocp.workflow.fitting import check_holdout, check_options, fit

    check_writable(args.out, command="gc-ocp fit")  # before any computation
    model = fit_model(None if args.effects is None else _effect_list(args.effects))
    # the problem is not convex: with effects, the full model's optimum is one more start, so
    # that adding effects cannot end above the model without them
    options = {  # the fit's options, each sensitivity refit's too
        "holdout": args.holdout,
        "extends": None if model is None else full_model(),
        "pose_scale": not args.fixed_pose_width,
        "sole_scale": False if args.fixed_sole_width else None,
        "pose_correlation": args.pose_correlation,
    }
    check_options(  # before the kinematics, as the fit would raise it after them
        options["pose_scale"],
        options["sole_scale"],
        options["pose_correlation"],
        args.bias_correction,
    )
    pairs, skipped = _load_subject(args, lambda trials: check_holdout(args.holdout, trials))
    prov = provenance(args, pairs, skipped)
    out = OutputSet(args.out, FIT_OUTPUTS, "gc-ocp fit")
    landmarks = {"trials": [kin.info.get("landmarks") for _, kin in pairs]}
    try:
        try:
            report = fit(
                pairs,
                model=model,
                progress=_progress,
                bias_correction=args.bias_correction,
                **options,
            )
        except SolveError as e:
            if e.result is not None:
                out.text(
                    "fit_failed.json",
                    json_text({**e.result.to_json(), "provenance": prov}, indent=2),
                )
                out.commit()
                print(
                    f"wrote the non-converged result to {args.out / 'fit_failed.json'}",
                    file=sys.stderr,
                )
            raise
        print(report.summary())
        _print_skipped(skipped)
        sens = None
        if args.sensitivity:
            from gc_ocp.io import load_static
            from gc_ocp.kinematics import compute_kinematics
            from gc_ocp.workflow.sensitivity import sensitivity

            def kin(t, cutoff_hz):
                static = load_static(args.static, t) if args.static is not None else None
                return compute_kinematics(
                    t,
                    markerset=args.markerset,
                    static=static,
                    cutoff_hz=cutoff_hz,
                    foot_roll=args.foot_roll,
                )

            from gc_ocp.kinematics.filtering import DEFAULT_CUTOFF_HZ

            # the refits as the fit reported (its cutoff the reference, its options), each
            # differing from it by one processing choice
            sens = sensitivity(
                [t for t, _ in pairs],
                model=model,
                compute_kinematics=kin,
                progress=_progress,
                reference_cutoff=DEFAULT_CUTOFF_HZ if args.cutoff is None else args.cutoff,
                fit_options=options,
            ).with_se(report.result)  # spreads in the reported fit's SEs, which the flag judges
            print(
                "sensitivity of the headline parameters to processing choices:\n" + sens.summary()
            )
            for f in sens.flags():  # also among fit.json's flags and the page's
                print(f"  ! {f['message']}")
            out.text("sensitivity.json", json_text(sens.to_json(), indent=2))
            out.text("sensitivity.md", sens.summary() + "\n")
        doc = write_fit(out, report, prov, landmarks, sens)
        written = out.commit()
    finally:
        out.discard()
    n_flags = len(doc["flags"]) + len(doc.get("heldout_flags", []))  # with --sensitivity's
    n_figs = sum(p.suffix == ".png" for p in written)
    print(
        f"wrote {len(written)} files to {args.out} (fit.json and {n_figs} figures); {n_flags} flags"
    )
    return 0


DIAGNOSE_FIGURES = {
    "heatmap": "where_heatmap.png",
    "heatmap_final": "where_heatmap_final.png",
    "residuals": "where_residuals.png",
    "ranking": "ranking.png",
    "waterfall": "waterfall.png",
}
"""The report's figures (:func:`gc_ocp.diagnosis.report.report_pngs`) and their file names."""

DIAGNOSE_OUTPUTS = ("diagnosis.json", "final_fit.json", "report.html", *DIAGNOSE_FIGURES.values())
"""Every file ``gc-ocp diagnose`` may write (one set, replaced as a whole)."""


def _effects(args: argparse.Namespace) -> list[str] | None:
    """``--effects a,b`` checked against the effect library and the base (before any work)."""
    from gc_ocp.diagnosis import candidate_names
    from gc_ocp.diagnosis.diagnose import resolve_base

    effects = None if args.effects is None else _effect_list(args.effects)
    _, base = resolve_base(args.base)
    if not candidate_names(base, effects):
        raise InputError(
            f"--effects {args.effects}: every effect is already in the base '{args.base}'; "
            "choose other effects or a smaller --base (seed, registered)."
        )
    return effects


def cmd_diagnose(args: argparse.Namespace) -> int:
    from gc_ocp.diagnosis import diagnose
    from gc_ocp.diagnosis.report import report_html, report_pngs
    from gc_ocp.outputs import OutputSet, atomic_write, check_writable

    check_writable(args.out, command="gc-ocp diagnose")  # before any computation
    if args.plate_calibration and args.null_draws == 0:
        raise InputError(
            "--plate-calibration puts plate errors in the null's mismatch draws, but "
            "--null-draws 0 makes none (a noise-only null): drop --null-draws 0 (32 draws by "
            "default) or drop --plate-calibration."
        )
    effects = _effects(args)
    if args.null_draws is not None and args.null_draws < 0:  # before the kinematics
        raise InputError(f"--null-draws must be 0 or more, but got {args.null_draws}")
    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers must be 1 or more, but got {args.workers}")
    pairs, skipped = _load_subject(args)
    prov = provenance(args, pairs, skipped)
    kw = {"pose_width": args.pose_width, "null_fits": args.null_fits}
    if args.plate_calibration:
        from gc_ocp.diagnosis.null import DEFAULT_FAMILY

        kw["mismatch"] = DEFAULT_FAMILY.with_plate_calibration()
    if args.null_draws is not None:
        kw["mismatch_draws"] = args.null_draws
    if args.workers is not None:
        kw["workers"] = args.workers
    d = diagnose(pairs, base=args.base, candidates=effects, progress=_progress, **kw)
    print(d.summary())
    _print_skipped(skipped)
    pngs = report_pngs(d)
    out = OutputSet(args.out, DIAGNOSE_OUTPUTS, "gc-ocp diagnose")
    try:
        out.text("diagnosis.json", json_text({**d.to_json(), "provenance": prov}, indent=2))
        final = d.final_evaluation.full  # the selected model on all stances, as fit.json has it
        out.text("final_fit.json", json_text({**final.to_json(), "provenance": prov}, indent=2))
        out.text("report.html", report_html(d, provenance=prov, pngs=pngs))
        for key, png in pngs.items():
            atomic_write(out.path(DIAGNOSE_FIGURES[key]), lambda tmp, png=png: tmp.write_bytes(png))
        written = out.commit()
    finally:
        out.discard()
    print(f"wrote {len(written)} files to {args.out}; open {args.out / 'report.html'} in a browser")
    return 0


def cmd_benchmark_diagnosis(args: argparse.Namespace) -> int:
    """The withheld-effect benchmark of the diagnosis (``gc_ocp.bench.withheld``)."""
    from gc_ocp.bench.truth import DEFAULT_MAGNITUDES, DEFAULT_REALISM
    from gc_ocp.bench.withheld import report, run_benchmark
    from gc_ocp.diagnosis.mismatch import MismatchFamily
    from gc_ocp.diagnosis.null import DEFAULT_FAMILY

    realism = DEFAULT_REALISM
    plates = args.plate_calibration
    if args.mismatch is not None:
        if not (args.mismatch >= 0):
            raise InputError(
                f"--mismatch must be a scale >= 0 (1: the family), but got {args.mismatch}"
            )
        family = MismatchFamily(scale=args.mismatch)
        if plates in ("truth", "both"):
            family = family.with_plate_calibration()
        realism = dataclasses.replace(realism, mismatch=family)
    elif plates in ("truth", "both"):
        raise InputError(
            f"--plate-calibration {plates} puts the member in the truth's mismatch family: "
            "give --mismatch too (e.g. --mismatch 1)."
        )
    null_family = DEFAULT_FAMILY.with_plate_calibration() if plates in ("null", "both") else None
    effects = [e.strip() for e in args.effects.split(",") if e.strip()] if args.effects else None
    candidates = None if args.candidates is None else _effect_list(args.candidates, "--candidates")
    res = run_benchmark(
        args.out,
        base=args.base,
        effects=effects,
        candidates=candidates,
        seeds=args.seeds,
        magnitudes=args.magnitude or DEFAULT_MAGNITUDES,
        resume=args.resume,
        progress=_progress,
        first_seed=args.first_seed,
        files=args.trial or None,
        realism=realism,
        stances_per_foot=args.stances_per_foot,
        pose_width=args.pose_width,
        stop_early=not args.full_null,
        null_fits=args.null_fits,
        null_family=null_family,
    )
    print(report(res))
    print(f"wrote {args.out / 'confusion.json'} and {args.out / 'confusion.png'}")
    return 0


def cmd_batch(args: argparse.Namespace) -> int:
    from gc_ocp.batch import Settings, run

    result = run(
        args.manifest,
        args.out,
        settings=Settings(
            diagnose=args.diagnose,
            pose_scale=not args.fixed_pose_width,
            sole_scale=False if args.fixed_sole_width else None,
            bias_correction=args.bias_correction,
            strict_trials=args.strict_trials,
        ),
        workers=args.workers,
        scheduler=args.scheduler,
        progress=_progress,
    )
    counts = ", ".join(f"{v} {k}" for k, v in sorted(result.counts().items()))
    print(
        f"{len(result.subjects)} subjects ({counts}) in {result.seconds:.0f} s; "
        f"summary: {args.out / 'summary.csv'}"
    )
    for s in result.failed():
        e = s["error"]
        print(f"  {s['subject']}: {e['type']}: {e['message']} -> {e['fix']}")
    return 1 if result.failed() else 0


def cmd_export(args: argparse.Namespace) -> int:
    if args.target == "casadi":
        from gc_ocp.export.calibrated import fit_document
        from gc_ocp.export.casadi_export import casadi_function, write_casadi
        from gc_ocp.outputs import check_writable, claim

        given = {
            "--radius": args.radius is not None,
            "--hertz": args.hertz,
            "--model": args.model is not None,
            "--no-compare": args.no_compare,
        }
        wrong = [k for k, v in given.items() if v]
        if wrong:  # they would be ignored: the function has no spheres, no body, no refit
            raise InputError(
                f"{', '.join(wrong)} {'is' if len(wrong) == 1 else 'are'} for the OpenSim export; "
                "the CasADi function is the fitted law itself: leave them out, or export opensim"
            )
        if args.out.suffix == ".casadi" and not args.out.is_dir():  # the file itself (a
            # folder so named is a folder: it was status 3, IsADirectoryError on the move)
            check_writable(args.out.parent)
            path = args.out
        else:  # a folder, perhaps another command's
            path = check_writable(args.out, command="gc-ocp export") / "contact.casadi"
        doc = fit_document(args.fit_json)  # read once, for the file and what is printed
        f = casadi_function(doc, trial=args.trial)  # built once, saved and printed
        write_casadi(f, path)
        if path != args.out:
            claim(args.out, "gc-ocp export")
        print(f)
        trials = list(dict.fromkeys(sf["trial"] for sf in doc["stance_fits"]))
        if len(trials) > 1:  # each trial's kinematics place the points: say whose they are
            print(
                f"unit points of trial {args.trial or trials[0]} (the fit's trials: "
                f"{', '.join(trials)}; --trial NAME for another)"
            )
        print(f"wrote {path}")
        return 0
    from gc_ocp.export.calibrated import CalibratedContact, fit_document
    from gc_ocp.export.opensim_export import (
        DEFAULT_RADIUS,
        check_request,
        export_opensim,
        fit_pairs,
        hertz_refit,
    )
    from gc_ocp.outputs import check_writable

    check_writable(args.out, command="gc-ocp export")
    check_request(None, args.model)  # a --model that is no file, said before the fit is read
    fit = fit_document(args.fit_json)  # read once, for the checks, a refit and the export
    check_request(fit, trial=args.trial)  # before a --hertz refit
    pairs = None
    if args.hertz:
        cal = CalibratedContact.from_fit(fit)
        pairs = fit_pairs(cal, _progress)
        # the exported fit's bias correction (its provenance's option; None: the default rule)
        asked = (cal.provenance.get("options") or {}).get("bias_correction")
        fit = hertz_refit(pairs, progress=_progress, bias_correction=asked)
        print(fit.summary())
    ex = export_opensim(
        fit,
        args.out,
        pairs=pairs,
        radius=DEFAULT_RADIUS if args.radius is None else args.radius,
        compare_forces=not args.no_compare,
        model=args.model,
        progress=_progress,
        trial=args.trial,
    )
    print(ex.summary())
    return 0
