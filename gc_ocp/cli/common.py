"""What the subcommands share: the trial arguments, loading and pairing the trials, progress on
stderr, the ``--effects`` list (the provenance written beside every output:
:mod:`gc_ocp.workflow.provenance`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from gc_ocp.errors import InputError
from gc_ocp.foot import FOOT_ROLLS


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
        "--mass",
        type=float,
        metavar="KG",
        help="Subject mass [kg] (overrides the file; with none in either, it is estimated from "
        "the plates, with a warning).",
    )
    p.add_argument(
        "--height",
        type=float,
        metavar="M",
        help="Subject height [m] (overrides the file; with none in either, the commands that "
        "pose the body estimate it from the markers, with a warning).",
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
        p.add_argument(
            "--foot-roll",
            choices=FOOT_ROLLS,
            default="chain",
            help="A foot with two landmarks (heel and one forefoot marker): its roll about "
            "them as the body chain poses it (chain, default) or level across (level); "
            "docs/quality.md, 'A Davis-like foot'.",
        )


def _add_strict_trials(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--strict-trials",
        action="store_true",
        dest="strict_trials",
        help="Stop at the first trial that cannot be used. Default: with several trials, such "
        "a trial is skipped with its reason (printed and recorded in the provenance) and the "
        "others are used (docs/data_formats.md, 'A trial that cannot be used').",
    )


def _load(args: argparse.Namespace):
    """The trials of the command line (several trials = one subject), each TRC paired with its
    ground reactions (:func:`gc_ocp.io.pairing.pair_trials`; the pairing is printed)."""
    return [_load_one(args, f) for f in _trial_files(args)]


def _load_one(args: argparse.Namespace, f):
    """One trial's files (:class:`~gc_ocp.io.pairing.TrialFiles`) read with the subject's
    values of the command line."""
    from gc_ocp.io import load_trial

    f = f.require()
    return load_trial(
        f.trial, grf=f.grf, mass=args.mass, height=args.height, belt_speed=args.belt_speed
    )


def _trial_files(args: argparse.Namespace) -> list:
    """The command line's trials paired with their ground reactions, the pairing printed."""
    from gc_ocp.io.pairing import pair_trials

    files = pair_trials(args.trial, args.grf, keep_going=True)
    for f in files:  # what was found, and every trial of a multi-trial command
        if f.error is None and ((f.grf is not None and not args.grf) or len(files) > 1):
            _progress(f.describe())
    return files


def _load_subject(args: argparse.Namespace, check_loaded=None):
    """``(pairs, skipped)``: the trials of a fit or diagnosis with their kinematics, a trial
    that cannot be used skipped with its reason when others remain (``--strict-trials``: stop
    instead; :mod:`gc_ocp.workflow.trials`)."""
    from gc_ocp.workflow.trials import usable_trials

    pairs, skipped = usable_trials(
        _trial_files(args),
        lambda f: _load_one(args, f),
        lambda f, trial: _kinematics(trial, args),
        strict=args.strict_trials,
        progress=_progress,
        check_loaded=check_loaded,
    )
    for _, kin in pairs:
        _print_landmarks(kin)
    return pairs, skipped


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
        trial,
        markerset=args.markerset,
        static=static,
        progress=_progress,
        foot_roll=args.foot_roll,
        **kw,
    )


def _print_landmarks(kin) -> None:
    """Print the marker mapping (label -> landmark -> segment) the kinematics used."""
    from gc_ocp.model.recognition import format_mapping

    if "landmarks" in kin.info:
        print(format_mapping(kin.info["landmarks"]))


def _effect_list(text: str, option: str = "--effects") -> list[str]:
    """The comma-separated effect names of ``option``, each checked against the effect library
    (:data:`gc_ocp.estimation.components.EFFECTS`)."""
    from gc_ocp.estimation.components import candidate_effects

    effects_now = candidate_effects()
    effects = [e.strip() for e in text.split(",") if e.strip()]
    unknown = [e for e in effects if e not in effects_now]
    if unknown or not effects:
        what = f"unknown effect(s) {', '.join(unknown)}" if unknown else "no effect given"
        raise InputError(
            f"{option} {text!r}: {what}; choose from {', '.join(effects_now)} (comma-separated)."
        )
    return effects
