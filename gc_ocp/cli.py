"""Command-line interface: ``gc-ocp SUBCOMMAND ...``.

Every subcommand prints a one-line error (no traceback) and exits with status 2 on bad input
(any :class:`gc_ocp.errors.GcOcpError`), and exits 1 when a numerical solve fails. Any other
exception is a bug: one line ``internal error: <type>: <message> (please report with the command
line)`` and exit status 3. Set the environment variable ``GC_OCP_DEBUG=1`` to also print the
traceback.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import traceback
import warnings
from pathlib import Path

from gc_ocp.errors import GcOcpError, InputError, SolveError


def _add_trial_args(p: argparse.ArgumentParser, with_static: bool = True) -> None:
    p.add_argument(
        "trial",
        nargs="*",
        type=Path,
        metavar="TRIAL",
        help="C3D files, or TRC marker files (with --grf, or the MOT/STO file beside each); "
        "several trials are the trials of one subject. Default: the bundled example C3D.",
    )
    p.add_argument(
        "--grf",
        type=Path,
        action="append",
        metavar="FILE",
        help="OpenSim MOT/STO ground reactions of a TRC trial; repeat it for several TRC trials, "
        "in their order. Default: the MOT/STO file beside the TRC (named after it, or the only "
        "one in its folder).",
    )
    p.add_argument(
        "--mass", type=float, metavar="KG", help="Subject mass [kg] (overrides the file)."
    )
    p.add_argument(
        "--height", type=float, metavar="M", help="Subject height [m] (overrides the file)."
    )
    p.add_argument(
        "--belt-speed",
        type=float,
        dest="belt_speed",
        metavar="M/S",
        help="Treadmill belt speed [m/s]; the belt moves backward (-X lab).",
    )
    if with_static:
        p.add_argument(
            "--static",
            type=Path,
            metavar="FILE",
            help="Static standing trial (TRC or C3D) for scaling.",
        )
        p.add_argument(
            "--markerset",
            metavar="NAME|FILE",
            help="Marker set name (plugingait, rajagopal, gait2392) or TOML file. "
            "Default: a shipped set matching the labels exactly, else one built from the "
            "anatomical landmarks recognised in the labels (docs/data_formats.md).",
        )
        p.add_argument(
            "--cutoff",
            type=float,
            metavar="HZ",
            default=None,
            help="Marker low-pass cutoff [Hz] (zero-lag 4th-order Butterworth; default 6).",
        )


def _load(args: argparse.Namespace):
    """The trials of the command line (several trials = one subject), each TRC paired with its
    ground reactions (:func:`gc_ocp.io.pairing.pair_trials`; the pairing is printed)."""
    from gc_ocp.io import load_trial
    from gc_ocp.io.pairing import pair_trials

    files = pair_trials(args.trial, args.grf)
    for f in files:  # what was found, and every trial of a multi-trial command
        if (f.grf is not None and not args.grf) or len(files) > 1:
            _progress(f.describe())
    return [
        load_trial(
            f.trial, grf=f.grf, mass=args.mass, height=args.height, belt_speed=args.belt_speed
        )
        for f in files
    ]


def _progress(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _kinematics(trial, args):
    from gc_ocp.io import load_static
    from gc_ocp.kinematics import compute_kinematics

    kw = {}
    if args.cutoff is not None:
        kw["cutoff_hz"] = args.cutoff
    static = load_static(args.static, trial) if args.static is not None else None
    return compute_kinematics(
        trial, markerset=args.markerset, static=static, progress=_progress, **kw
    )


def _print_landmarks(kin) -> None:
    """Print the marker mapping (label -> landmark -> segment) the kinematics used."""
    from gc_ocp.model.recognition import format_mapping

    if "landmarks" in kin.info:
        print(format_mapping(kin.info["landmarks"]))


def cmd_info(args: argparse.Namespace) -> int:
    from gc_ocp.io import describe_trial

    for trial in _load(args):
        print(describe_trial(trial))
        print()
    return 0


def cmd_kinematics(args: argparse.Namespace) -> int:
    from gc_ocp.kinematics.export import write_kinematics

    trials = _load(args)
    names = [t.name for t in trials]
    for i, trial in enumerate(trials):
        kin = _kinematics(trial, args)
        _print_landmarks(kin)
        sub = trial.name if names.count(trial.name) == 1 else f"{i + 1}_{trial.name}"
        out = args.out if len(trials) == 1 else args.out / sub  # one folder per trial
        paths = write_kinematics(trial, kin, out, fmt=args.format)
        for p in paths:
            print(f"wrote {p}")
    return 0


def cmd_reproduce_seed(args: argparse.Namespace) -> int:
    from gc_ocp.contact.seed_study import reproduce_seed, table1_markdown, table2_markdown

    trials = _load(args)
    if len(trials) != 1:
        raise InputError(
            f"reproduce-seed takes one trial, but got {len(trials)}; run it once per trial."
        )
    [trial] = trials
    kin = _kinematics(trial, args)
    res = reproduce_seed(
        trial,
        kin,
        seeds=args.seeds,
        out_dir=args.out,
        progress=lambda done, total, label: _progress(f"[{done}/{total}] {label}"),
    )
    for note in res["notes"]:
        _progress(f"note: {note}")
    print(table1_markdown(res["table1"]))
    print(table2_markdown(res["table2"]))
    print(f"wrote table1.json, table1.md, table2.json, table2.md to {args.out}")
    return 0


FIT_OUTPUTS = (
    "fit.json",
    "landmarks.json",
    "fit_failed.json",
    "fit_wrench.png",
    "fit_sole.png",
    "fit_pose_corrections.png",
    "heldout_wrench.png",
    "sensitivity.json",
    "sensitivity.md",
)
"""Every file ``gc-ocp fit`` may write: a run replaces the whole set (stale ones are removed)."""


def _sha256(path) -> str:
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def provenance(args: argparse.Namespace, pairs) -> dict:
    """What a ``fit.json`` (or ``diagnosis.json``) was computed from: inputs with content
    hashes, command and options, subject values and their sources, stances used and excluded
    (with the reason), package version, date."""
    import datetime
    import platform

    from gc_ocp import __version__
    from gc_ocp.stance import trial_names

    trials = []
    for (t, kin), name in zip(pairs, trial_names([t.source for t, _ in pairs]), strict=True):
        files = [p for p in (t.source, t.grf_source) if p is not None]
        trials.append(
            {
                "name": name,  # as in the stance labels (name:side@t_on)
                "files": [{"path": str(Path(p).resolve()), "sha256": _sha256(p)} for p in files],
                "mass_kg": t.mass,
                "mass_source": t.mass_source,
                "height_m": t.height if t.height is not None else kin.info.get("height"),
                "height_source": t.height_source
                or ("estimated from markers" if t.height is None else ""),
                "belt_velocity_m_s": list(map(float, t.belt_velocity)),
                "stances_used": [s.label for s in t.stances],
                "stances_excluded": [
                    {
                        "side": e.side,
                        "plate": e.plate,
                        "t_on": e.t_on,
                        "t_off": e.t_off,
                        "reason": e.reason,
                    }
                    for e in t.excluded_stances
                ],
                "load_notes": list(t.load_notes),
                "marker_cutoff_hz": kin.cutoff_hz,
            }
        )

    def plain(v):
        if isinstance(v, Path):
            return str(v)
        return [plain(x) for x in v] if isinstance(v, (list, tuple)) else v

    options = {k: plain(v) for k, v in vars(args).items() if k not in ("func", "command")}
    return {
        "gc_ocp_version": __version__,
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "python": platform.python_version(),
        "command": f"gc-ocp {args.command}",
        "options": options,
        "trials": trials,
    }


def _effect_list(text: str, option: str = "--effects") -> list[str]:
    """The comma-separated effect names of ``option``, each checked against the effect library
    (:data:`gc_ocp.estimation.components.EFFECTS`)."""
    from gc_ocp.estimation.components import EFFECTS

    effects = [e.strip() for e in text.split(",") if e.strip()]
    unknown = [e for e in effects if e not in EFFECTS]
    if unknown or not effects:
        what = f"unknown effect(s) {', '.join(unknown)}" if unknown else "no effect given"
        raise InputError(
            f"{option} {text!r}: {what}; choose from {', '.join(EFFECTS)} (comma-separated)."
        )
    return effects


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
    from gc_ocp.estimation.plots import plot_fit, plot_pose_corrections, plot_sole_fit
    from gc_ocp.io.checks import require_stances
    from gc_ocp.outputs import OutputSet, check_writable
    from gc_ocp.workflow.fitting import fit

    check_writable(args.out)  # before any computation
    model = fit_model(None if args.effects is None else _effect_list(args.effects))
    trials = _load(args)
    for t in trials:
        require_stances(t)
    pairs = [(t, _kinematics(t, args)) for t in trials]
    for _, kin in pairs:
        _print_landmarks(kin)
    prov = provenance(args, pairs)
    out = OutputSet(args.out, FIT_OUTPUTS)
    landmarks = {"trials": [kin.info.get("landmarks") for _, kin in pairs]}
    try:
        try:
            start = None
            if model is not None:  # the problem is not convex: the full model's optimum is one
                # more start, so that adding effects cannot end above the model without them
                _progress("fitting the full model first (its optimum starts the fit with effects)")
                start = fit(pairs, holdout=args.holdout, progress=_progress).result
            report = fit(pairs, model=model, holdout=args.holdout, progress=_progress, start=start)
        except SolveError as e:
            if e.result is not None:
                out.text(
                    "fit_failed.json",
                    json.dumps({**e.result.to_json(), "provenance": prov}, indent=2),
                )
                out.commit()
                print(
                    f"wrote the non-converged result to {args.out / 'fit_failed.json'}",
                    file=sys.stderr,
                )
            raise
        print(report.summary())
        figs = {
            "fit_wrench.png": plot_fit(report.result),
            "fit_sole.png": plot_sole_fit(report.result),
            "fit_pose_corrections.png": plot_pose_corrections(report.result),
        }
        if report.heldout is not None:
            figs["heldout_wrench.png"] = plot_fit(
                report.heldout, title=f"held-out {report.heldout_label}"
            )
        out.text("fit.json", json.dumps({**report.to_json(), "provenance": prov}, indent=2))
        out.text("landmarks.json", json.dumps(landmarks, indent=2))
        if args.sensitivity:
            from gc_ocp.io import load_static
            from gc_ocp.kinematics import compute_kinematics
            from gc_ocp.workflow.sensitivity import sensitivity

            def kin(t, cutoff_hz):
                static = load_static(args.static, t) if args.static is not None else None
                return compute_kinematics(
                    t, markerset=args.markerset, static=static, cutoff_hz=cutoff_hz
                )

            sens = sensitivity(
                [t for t, _ in pairs], model=model, compute_kinematics=kin, progress=_progress
            )
            print(
                "sensitivity of the headline parameters to processing choices:\n" + sens.summary()
            )
            out.text("sensitivity.json", json.dumps(sens.to_json(), indent=2))
            out.text("sensitivity.md", sens.summary() + "\n")
        for name, fig in figs.items():
            out.figure(name, fig, dpi=100)
        written = out.commit()
    finally:
        out.discard()
    n_flags = len(report.result.flags) + (len(report.heldout.flags) if report.heldout else 0)
    print(
        f"wrote {len(written)} files to {args.out} (fit.json and {len(figs)} figures); {n_flags} flags"
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

    check_writable(args.out)  # before any computation
    effects = _effects(args)
    trials = _load(args)
    pairs = [(t, _kinematics(t, args)) for t in trials]
    prov = provenance(args, pairs)
    d = diagnose(pairs, base=args.base, candidates=effects, progress=_progress)
    print(d.summary())
    pngs = report_pngs(d)
    out = OutputSet(args.out, DIAGNOSE_OUTPUTS)
    try:
        out.text("diagnosis.json", json.dumps({**d.to_json(), "provenance": prov}, indent=2))
        final = d.final_evaluation.full  # the selected model on all stances, as fit.json has it
        out.text("final_fit.json", json.dumps({**final.to_json(), "provenance": prov}, indent=2))
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
    from gc_ocp.bench.withheld import report, run_benchmark

    effects = [e.strip() for e in args.effects.split(",") if e.strip()] if args.effects else None
    candidates = None if args.candidates is None else _effect_list(args.candidates, "--candidates")
    res = run_benchmark(
        args.out,
        base=args.base,
        effects=effects,
        candidates=candidates,
        seeds=args.seeds,
        magnitudes=args.magnitude or ("moderate", "strong"),
        resume=args.resume,
        progress=_progress,
        first_seed=args.first_seed,
        files=args.trial or None,
    )
    print(report(res))
    print(f"wrote {args.out / 'confusion.json'} and {args.out / 'confusion.png'}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gc-ocp",
        description="Estimate foot-ground contact models of human walking from motion capture and "
        "force plates, and diagnose where the model still disagrees with the plates.",
    )
    from gc_ocp import __version__

    parser.add_argument("--version", action="version", version=f"gc-ocp {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser(
        "info",
        help="Print rates, markers, plates, stances and body weight of a trial.",
        description="Load a trial and print what was found: marker and analog rates, "
        "markers, force plates, detected stances (foot, plate, window) and excluded "
        "ones with the reason, body weight and its check against the plates.",
    )
    _add_trial_args(p, with_static=False)
    p.set_defaults(func=cmd_info)

    p = sub.add_parser(
        "kinematics",
        help="Inverse kinematics and sole-point trajectories.",
        description="Scale the 27-DOF body model, run per-frame inverse kinematics "
        "(Pinocchio, Levenberg-Marquardt) and write the five sole points' lab "
        "positions and velocities per foot plus a figure of marker residuals and "
        "sole-point heights with stances shaded.",
    )
    _add_trial_args(p)
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="Output folder.")
    p.add_argument(
        "--format", choices=("csv", "npz"), default="csv", help="Trajectory file format."
    )
    p.set_defaults(func=cmd_kinematics)

    p = sub.add_parser(
        "reproduce-seed",
        help="The seed report's five applications (Tables 1 and 2).",
        description="Linear least squares for k (n=1, c=0) on four synthetic data sets "
        "driven by the trial's motion and on the trial's real ground reactions; "
        "writes table1/table2 as JSON and Markdown beside the seed's values.",
    )
    _add_trial_args(p)
    p.add_argument(
        "--seeds", type=int, default=20, help="Noise draws for the noisy rows (default 20)."
    )
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="Output folder.")
    p.set_defaults(func=cmd_reproduce_seed)

    p = sub.add_parser(
        "fit",
        help="Joint kinematics-contact estimation (CasADi + Ipopt).",
        description="Co-estimate per-unit stiffness, shared exponent, damping and "
        "friction, sole-point corrections and smooth foot-pose corrections against "
        "the measured wrenches of every stance (and, on a treadmill, the belt speed); "
        "writes DIR/fit.json and fit_wrench.png, fit_sole.png, "
        "fit_pose_corrections.png. With --holdout, the named stance is left out of "
        "the fit and evaluated with the contact parameters fixed (only the pose "
        "correction re-estimated; heldout_wrench.png). Exit status 1 if Ipopt does "
        "not converge (the result is written to fit_failed.json), 2 on bad input.",
    )
    _add_trial_args(p)
    p.add_argument(
        "--sensitivity",
        action="store_true",
        help="Also refit with other marker cutoffs (4, 8 Hz) and stance margins (60 ms) and report how "
        "far the headline parameters move, in units of their SE (sensitivity.json/.md).",
    )
    p.add_argument("--holdout", help='Stance to hold out, e.g. "right@0.407s" (see `gc-ocp info`).')
    p.add_argument(
        "--effects",
        metavar="A,B,...",
        help="Comma-separated effects (docs/effects.md) fitted with the full model, e.g. "
        "friction,time_offset; each adds its own block to fit.json and the summary. The full "
        "model is fitted first and its optimum is one more start. Default: the full model alone.",
    )
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="Output folder.")
    p.set_defaults(func=cmd_fit)

    p = sub.add_parser(
        "diagnose",
        help="Where the model disagrees with the plates, which effect causes it, how far it "
        "shrinks.",
        description="Fit the base model on the trials of one subject, score it on held-out "
        "stances (leave one stance out), add each candidate effect alone and rank them by the "
        "held-out reduction (95 % bootstrap interval), add the best passing one and re-rank "
        "(forward selection). Writes DIR/diagnosis.json, DIR/report.html (one self-contained "
        "page) and the figures as PNG. Exit status 1 if a solve fails, 2 on bad input.",
    )
    _add_trial_args(p)
    p.add_argument(
        "--base",
        choices=("seed", "registered", "full"),
        default="registered",
        help="Model the effects are added to: seed (the seed's law alone), registered (default: "
        "+ friction, sole and pose registration, belt speed), full (+ damping, stiffness "
        "exponent).",
    )
    p.add_argument(
        "--effects",
        metavar="A,B,...",
        help="Comma-separated candidate effects (docs/effects.md), e.g. damping,friction. "
        "Default: every effect the base does not have.",
    )
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="Output folder.")
    p.set_defaults(func=cmd_diagnose)

    p = sub.add_parser(
        "benchmark-diagnosis",
        help="Withheld-effect benchmark: does the diagnosis find an effect it is not told of?",
        description="Generate plate data on the bundled trial's real motion from a truth (the "
        "base fitted to it, frozen) plus one effect (or none) at a known value, with marker "
        "noise, soft-tissue drift, plate noise and a 20 N threshold; diagnose blind "
        "(max_effects=1) and compare the top-1 answer with the truth. Writes "
        "DIR/confusion.json (after every case; --resume continues it) and confusion.png.",
    )
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="Output folder.")
    p.add_argument("--seeds", type=int, default=3, help="Noise draws per effect and magnitude.")
    p.add_argument(
        "--magnitude",
        action="append",
        choices=("moderate", "strong"),
        help="Magnitude of the injected effect (repeatable; default both).",
    )
    p.add_argument(
        "--base", choices=("registered", "seed"), default="registered", help="Diagnosis base."
    )
    p.add_argument(
        "--effects", help='Comma-separated truths (effects and/or "none"); default all candidates.'
    )
    p.add_argument(
        "--candidates",
        metavar="A,B,...",
        help="Comma-separated effects the blind diagnosis may name (default: every effect the "
        "base does not have); fewer candidates make a case faster.",
    )
    p.add_argument(
        "--first-seed",
        type=int,
        default=0,
        dest="first_seed",
        help="First noise draw (runs of other seeds can be merged; default 0).",
    )
    p.add_argument("--resume", action="store_true", help="Keep the cases of an earlier run.")
    p.add_argument(
        "--trial",
        action="append",
        type=Path,
        metavar="FILE",
        help="A trial whose real motion the cases use (repeatable: trials of one subject; "
        "default: the bundled example). More stances per foot give more held-out folds.",
    )
    p.set_defaults(func=cmd_benchmark_diagnosis)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    warnings.simplefilter("default")
    warnings.formatwarning = lambda msg, cat, *a, **k: f"warning: {msg}\n"
    try:
        return int(args.func(args) or 0)
    except SolveError as e:
        return _fail(args, f"solve failed: {e}", 1)
    except GcOcpError as e:
        return _fail(args, f"error: {e}", 2)
    except FileNotFoundError as e:
        return _fail(args, f"error: file not found: {e.filename}; check the path.", 2)
    except Exception as e:  # last resort: not bad input but a bug
        return _fail(
            args,
            f"internal error: {type(e).__name__}: {e} (please report with the command line)",
            3,
        )


def _fail(args: argparse.Namespace, message: str, status: int) -> int:
    """Print ``message`` as one line on stderr (the traceback too if ``GC_OCP_DEBUG=1``)."""
    if os.environ.get("GC_OCP_DEBUG") == "1":
        traceback.print_exc()
    print(f"gc-ocp {args.command}: {' '.join(message.split())}", file=sys.stderr)
    return status


if __name__ == "__main__":
    sys.exit(main())
