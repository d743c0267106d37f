"""Command-line interface: ``gc-ocp SUBCOMMAND ...``.

Every subcommand prints a one-line error (no traceback) and exits with status 2 on bad input
(any :class:`gc_ocp.errors.GcOcpError`), and exits 1 when a numerical solve fails. Any other
exception is a bug: one line ``internal error: <type>: <message> (please report with the command
line)`` and exit status 3. Set the environment variable ``GC_OCP_DEBUG=1`` to also print the
traceback. Ctrl-C (SIGINT) and SIGTERM stop a command with one line and exit status 130 / 143,
after its staged outputs are discarded (:class:`gc_ocp.outputs.OutputSet`): SIGTERM is raised as
:class:`Terminated`, a ``KeyboardInterrupt``, so every cleanup that Ctrl-C runs runs too.

Layout: :mod:`.common` (trial arguments, loading, provenance), :mod:`.commands` (one function per
subcommand); this module builds the parser and runs a command.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
import traceback
import warnings
from pathlib import Path

from gc_ocp.cli.commands import (
    cmd_batch,
    cmd_benchmark_diagnosis,
    cmd_diagnose,
    cmd_export,
    cmd_fit,
    cmd_info,
    cmd_kinematics,
    cmd_reproduce_seed,
)
from gc_ocp.cli.common import _add_strict_trials, _add_trial_args
from gc_ocp.errors import GcOcpError, SolveError


def _pose_width_argument(p: argparse.ArgumentParser) -> None:
    """``--pose-width`` of the diagnosis (``diagnose`` and ``benchmark-diagnosis``)."""
    p.add_argument(
        "--pose-width",
        choices=("prior", "estimated"),
        default="estimated",
        help="The base's foot-pose correction width: estimated on every stance first "
        "(default; docs/quality.md) or its guessed prior (2 mm, 1 deg; the default until "
        "2026-11-28, docs/diagnosis.md).",
    )


def _null_fits_argument(p: argparse.ArgumentParser) -> None:
    """``--null-fits`` of the diagnosis (``diagnose`` and ``benchmark-diagnosis``)."""
    p.add_argument(
        "--null-fits",
        choices=("one-step", "refit"),
        default="one-step",
        help="How the calibrated null scores a replicate: one Gauss-Newton step per fit "
        "(default) or every fold of every model refitted, the ranking's own statistic (tens of "
        "times slower; for few stances per foot, where the one step misses gains the refit "
        "shows; docs/diagnosis.md, 'The refit null').",
    )


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
        "--format",
        choices=("csv", "npz"),
        default="csv",
        help="Trajectory file format (default csv).",
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
    _add_strict_trials(p)
    p.add_argument(
        "--sensitivity",
        action="store_true",
        help="Also refit with other marker cutoffs (4, 6, 8 Hz beside the fit's own --cutoff) "
        "and stance margins (60 ms), each refit with the fit's other options, and report how "
        "far the headline parameters move, in units of their SE (sensitivity.json/.md).",
    )
    p.add_argument(
        "--holdout",
        help='Stance to hold out: its label or a unique part of it, e.g. "right@0.407s" (`gc-ocp '
        'info` lists them; with several trials, the trial\'s name first: "walk2:right@1.2"); '
        '"auto": the last stance of the foot with the most stances (default: none held out).',
    )
    p.add_argument(
        "--fixed-pose-width",
        action="store_true",
        help="Keep the foot-pose correction's prior width (2 mm, 1 deg) instead of estimating "
        "it from the stances (docs/quality.md).",
    )
    p.add_argument(
        "--fixed-sole-width",
        action="store_true",
        help="Keep the sole correction's 5 mm prior width instead of estimating it per axis "
        "from the stances between 5 and 10 mm (docs/quality.md, 'The sole correction's "
        "width'); "
        "--fixed-pose-width keeps it too.",
    )
    p.add_argument(
        "--pose-correlation",
        action="store_true",
        help="Also estimate the foot-pose correction's knot-to-knot correlation (a prior whose "
        "variance sits in the low frequencies, as a soft-tissue drift's does). Better on "
        "synthetic drifts, worse on real files whose pose widths stop at their limit: "
        "docs/quality.md.",
    )
    p.add_argument(
        "--bias-correction",
        type=int,
        default=None,
        metavar="B",
        help="Remove the bias the markers' noise and soft-tissue drift give the parameters "
        "(the friction coefficient most: -2 %% at 1 mm of marker noise, -6 %% at 2 mm), "
        "estimated from B "
        "simulated replicates of the fit, each a warm refit; their spread enters the SEs. "
        "Default: 16 where the markers' noise moves the contact units by 0.15 mm or more "
        "after the low-pass (the fit's checks say so), none elsewhere; 0: off "
        "(docs/quality.md).",
    )
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
        "held-out reduction (95 % bootstrap interval); name an effect only when a calibrated "
        "test (null replicates of the base with model mismatch, family-wise rate 5 %) does, "
        "add the best named one and re-test (forward selection); say how many more steps "
        "would decide the others. Writes DIR/diagnosis.json, DIR/report.html (one "
        "self-contained page) and the figures as PNG. Exit status 1 if a solve fails, 2 on bad "
        "input.",
    )
    _add_trial_args(p)
    _add_strict_trials(p)
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
    _pose_width_argument(p)
    _null_fits_argument(p)
    p.add_argument(
        "--plate-calibration",
        action="store_true",
        help="Let the null's mismatch family also draw plate calibration errors (each stance's "
        "plate 2-5 mm off, its channels within +-2 %%): for plates not calibrated in situ "
        "(docs/diagnosis.md, 'Mismatch family').",
    )
    p.add_argument(
        "--null-draws",
        type=int,
        default=None,
        metavar="N",
        help="Draws of the mismatch family in the calibrated null, each a refit of the base "
        "(default 32; the p-value counts draws, so it is at least 1/(N+1): fewer than 20 "
        "cannot name an effect at 5 %%, and fewer give a rougher split of the null's spread "
        "into noise and mismatch; 0: noise only, not calibrated for model mismatch; with "
        "--null-fits refit each draw is one replicate, every fold refitted).",
    )
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="Worker processes of a local Dask cluster for the base's and the candidates' fits"
        " and the null's draws (default: every core, at most 4; 1: in this process).",
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
    p.add_argument(
        "--seeds", type=int, default=3, help="Noise draws per effect and magnitude (default 3)."
    )
    p.add_argument(
        "--magnitude",
        action="append",
        metavar="{small,moderate,strong}",
        help="Magnitude of the injected effect (repeatable; default moderate and strong; "
        "small: half the moderate's departure from neutral; gc_ocp.bench.truth.MAGNITUDES).",
    )
    p.add_argument(
        "--base",
        choices=("registered", "seed"),
        default="registered",
        help="Diagnosis base (default registered).",
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
    p.add_argument(
        "--stances-per-foot",
        type=int,
        default=None,
        metavar="N",
        help="Cases on N stances of each foot (a foot with fewer has its strides repeated as "
        "further trials; default: the motion's own).",
    )
    p.add_argument(
        "--mismatch",
        type=float,
        default=None,
        metavar="SCALE",
        help="Also make every truth differ from the model by a draw of the mismatch family at "
        "this scale (1: the documented family; default: none; docs/diagnosis.md).",
    )
    p.add_argument(
        "--plate-calibration",
        choices=("truth", "null", "both"),
        default=None,
        help="The mismatch family's plate calibration member (plates 2-5 mm off, channels "
        "within +-2 %%) in every truth (with --mismatch), in the diagnosis's null, or both "
        "(default: neither; docs/diagnosis.md, 'Mismatch family').",
    )
    _pose_width_argument(p)
    _null_fits_argument(p)
    p.add_argument(
        "--full-null",
        action="store_true",
        help="Make every mismatch draw of each round's null, even when the first already rule "
        "out any claim (default: stop early then; the record checks the stop costs no claim).",
    )
    p.set_defaults(func=cmd_benchmark_diagnosis)

    p = sub.add_parser(
        "batch",
        help="A study: fit (and diagnose) every subject of a manifest on Dask, resumable.",
        description="Fit every subject of MANIFEST (a CSV or TOML manifest, or a folder with "
        "one subfolder per subject; docs/batch.md) with its trials together, on a local Dask "
        "cluster or a running scheduler. Writes OUT/<subject>/ (fit.json, figures; "
        "diagnosis.json with --diagnose), OUT/summary.csv and OUT/summary.parquet. A rerun skips "
        "the subjects already complete for the same inputs and settings; a subject that fails "
        "is recorded (OUT/<subject>/error.json and the summary) and the others go on.",
    )
    p.add_argument("manifest", type=Path, metavar="MANIFEST")
    p.add_argument("--out", type=Path, required=True, help="Output folder.")
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        help="Worker processes of the local cluster (default: the cores available).",
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        default=None,
        help="A running Dask scheduler (e.g. tcp://10.0.0.5:8786) instead of a local cluster; "
        "its workers need gc_ocp and the study's files at the same paths (docs/batch.md).",
    )
    p.add_argument(
        "--diagnose", action="store_true", help="Also run the diagnosis on every subject."
    )
    p.add_argument(
        "--fixed-pose-width",
        action="store_true",
        help="Keep the pose correction's prior width instead of estimating it (as gc-ocp fit "
        "--fixed-pose-width; faster).",
    )
    p.add_argument(
        "--fixed-sole-width",
        action="store_true",
        help="Keep the sole correction's prior width (as gc-ocp fit --fixed-sole-width).",
    )
    p.add_argument(
        "--bias-correction",
        type=int,
        default=None,
        metavar="B",
        help="Remove the markers' noise's bias from every fit with B replicates (as gc-ocp "
        "fit --bias-correction; default: where a subject's markers are noisy enough to need "
        "it; 0: off).",
    )
    _add_strict_trials(p)
    p.set_defaults(func=cmd_batch)

    p = sub.add_parser(
        "export",
        help="The calibrated contact model where users simulate: OpenSim or CasADi.",
        description="Export a fit (FIT.json, written by gc-ocp fit or gc-ocp batch). "
        "'opensim': the subject's body with one SmoothSphereHalfSpaceForce per contact unit "
        "(model.osim), the coordinates and the plates' and the model's ground reactions as "
        "OpenSim files with their ExternalLoads, and OpenSim's own contact forces compared with "
        "gc_ocp's (export.json). 'casadi': a serialized casadi.Function from foot poses and "
        "velocities to each foot's wrench and unit forces (docs/export.md).",
    )
    p.add_argument("target", choices=("opensim", "casadi"))
    p.add_argument("fit_json", type=Path, metavar="FIT.json")
    p.add_argument(
        "--out",
        type=Path,
        required=True,
        help="Output folder (opensim) or .casadi file (casadi).",
    )
    p.add_argument(
        "--trial",
        default=None,
        metavar="NAME",
        help="The fit's trial exported (a fit of several trials: each has its own kinematics, "
        "which place the unit points; its name as in the fit's stance labels, e.g. walk2; "
        "default the first).",
    )
    p.add_argument(
        "--radius",
        type=float,
        default=None,
        metavar="M",
        help="Contact sphere radius [m] (opensim; default 0.005).",
    )
    p.add_argument(
        "--hertz",
        action="store_true",
        help="(opensim) Refit the model with the penetration exponent fixed at OpenSim's 1.5 "
        "before exporting, so that OpenSim's law is the fitted law (the fit's trials are "
        "loaded again).",
    )
    p.add_argument(
        "--model",
        type=Path,
        default=None,
        metavar="SUBJECT.osim",
        help="(opensim) Attach the contact to your own OpenSim model instead of the package's "
        "body: each foot's spheres go on the body holding the foot markers the model shares "
        "with the trial (at least three, fitted rigidly); no coordinates or comparison then.",
    )
    p.add_argument(
        "--no-compare",
        action="store_true",
        help="(opensim) Do not compute OpenSim's contact forces on the trial.",
    )
    p.set_defaults(func=cmd_export)
    return parser


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the command runs (as Ctrl-C is): its ``finally`` blocks discard the
    staged outputs (a killed process left its staging folder beside ``--out``)."""


def _terminated(signum, frame) -> None:
    raise Terminated


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    warnings.simplefilter("default")
    warnings.formatwarning = lambda msg, cat, *a, **k: f"warning: {msg}\n"
    on_term = None
    if threading.current_thread() is threading.main_thread():
        on_term = signal.signal(signal.SIGTERM, _terminated)
    try:
        return _run(args)
    finally:
        if on_term is not None:
            signal.signal(signal.SIGTERM, on_term)


def _run(args: argparse.Namespace) -> int:
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt as e:
        how, status = (
            ("terminated (SIGTERM)", 143) if isinstance(e, Terminated) else ("interrupted", 130)
        )
        kept = (
            "finished subjects are kept, rerun the same command to resume"
            if args.command == "batch"
            else "no output of this run is half-written; rerun the same command"
        )
        return _fail(args, f"{how}: {kept}.", status)
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
