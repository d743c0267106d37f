"""What an output was computed from (``fit.json``'s and ``diagnosis.json``'s ``provenance``):
the command line's and the batch's one definition."""

from __future__ import annotations

import functools
import os
from pathlib import Path


def sha256(path) -> str:
    """The file's SHA-256 (hex). Hashed once per process for the same file, size and
    modification time (a study hashes each input for its key, its kinematics cache and its
    provenance)."""
    st = os.stat(path)
    return _sha256(os.path.realpath(path), st.st_size, st.st_mtime_ns)


@functools.lru_cache(maxsize=4096)
def _sha256(path: str, size: int, mtime_ns: int) -> str:
    import hashlib

    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def provenance(args, pairs, skipped=()) -> dict:
    """What a ``fit.json`` (or ``diagnosis.json``) was computed from: inputs with content
    hashes, command and options, subject values and their sources, stances used and excluded
    (with the reason), the trials given but not used (``skipped``: their
    :class:`~gc_ocp.workflow.trials.SkippedTrial`), package version, date. ``args``: the
    command's options (an ``argparse.Namespace``, or any object whose attributes are the
    options, with ``command``)."""
    import datetime
    import platform

    from gc_ocp import __version__
    from gc_ocp.io.consistency import check_for_fit
    from gc_ocp.io.processing import detect_processing
    from gc_ocp.stance import trial_names
    from gc_ocp.trial import ESTIMATED
    from gc_ocp.workflow.fitting import with_height

    # the stances as the fit uses them: the checks before it exclude a stance whose force is
    # not under its foot (before, such a stance was listed as used)
    # and the subject's heights as the fit pools them (a TRC has none: the kinematics')
    pairs, _ = check_for_fit([(with_height(t, k, warn=False), k) for t, k in pairs])
    trials = []
    for (t, kin), name in zip(pairs, trial_names([t.source for t, _ in pairs]), strict=True):
        files = [p for p in (t.source, t.grf_source) if p is not None]
        trials.append(
            {
                "name": name,  # as in the stance labels (name:side@t_on)
                "files": [{"path": str(Path(p).resolve()), "sha256": sha256(p)} for p in files],
                "mass_kg": t.mass,
                "mass_source": t.mass_source,
                "height_m": t.height if t.height is not None else kin.info.get("height"),
                "height_source": t.height_source
                or (f"{ESTIMATED} from the markers" if t.height is None else ""),
                "belt_velocity_m_s": list(map(float, t.belt_velocity)),
                "stances_used": [s.label for s in t.stances],
                "stances_excluded": [
                    {
                        "side": e.side,
                        "plate": e.plate,  # index into the trial's plates (from 0)
                        "plate_name": t.plates[e.plate].name,  # as gc-ocp info prints it
                        "t_on": e.t_on,
                        "t_off": e.t_off,
                        "reason": e.reason,
                    }
                    for e in t.excluded_stances
                ],
                "load_notes": list(t.load_notes),
                "marker_cutoff_hz": kin.cutoff_hz,
                # per foot: posed by its markers, or (two landmarks) its roll as the chain
                # gives it or levelled (compute_kinematics' foot_roll)
                "foot_roll": kin.info.get("foot_roll"),
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
        # given but not used, each with the error that names its problem (gc_ocp.workflow.trials)
        "trials_skipped": [s.to_json() for s in skipped],
    }


__all__ = ("provenance",)
