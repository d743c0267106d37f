"""What the subcommands share: the trial arguments, loading and pairing the trials, progress on
stderr, the provenance written beside every output, the ``--effects`` list."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from gc_ocp.errors import InputError


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
    from gc_ocp.io.processing import detect_processing
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
                # the markers' measured noise and what it leaves in each foot's pose
                # (gc_ocp.marker_noise)
                "marker_error": kin.info.get("marker_error"),
                "foot_pose_noise": kin.info.get("foot_pose_noise"),
                # what the lab's processing did, as detected (the measurement model uses the
                # plates' zero thresholds: gc_ocp.io.processing)
                "processing": detect_processing(t).to_json(),
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
