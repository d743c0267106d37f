"""Which files make up each trial: a C3D alone, or a TRC marker file with its ground reactions.

Every command that takes trials takes several (the trials of one subject) and resolves them
here, in one place (:func:`pair_trials`):

* a ``.c3d`` trial carries its own plates;
* a ``.trc`` trial needs an OpenSim ``.mot``/``.sto`` file. Given explicitly (``--grf``,
  repeated in the order of the TRC trials), or else found in the TRC's folder: the file whose
  name starts with the TRC's stem (``walk1.trc`` -> ``walk1_grf.mot``), or the only
  ``.mot``/``.sto`` file of the folder. Anything else (none, several candidates, one file
  claimed by two trials) is an :class:`~gc_ocp.errors.InputError` that names the files and the
  fix.

>>> from gc_ocp.io.pairing import pair_trials
>>> [(p.trial, p.grf, p.how) for p in pair_trials([])]   # the bundled example
[(None, None, 'bundled example')]
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Sequence
from pathlib import Path

from gc_ocp.errors import InputError, require_file

TRIAL_FIX = (
    "give a trial's .c3d file, or its .trc file (with the ground reactions beside it or --grf); "
    "several files are one subject's trials (a folder of subjects is gc-ocp batch FOLDER)."
)
"""What a path given as a trial should be (the fix of a missing or folder path)."""

GRF_SUFFIXES = (".mot", ".sto")


@dataclasses.dataclass(frozen=True)
class TrialFiles:
    """One trial's files: ``trial`` (``None``: the bundled example), ``grf`` (TRC only) and how
    the ground reactions were found (``how``, printed for the user). ``error``: why this
    trial's files cannot be found (``pair_trials(keep_going=True)``), raised by
    :meth:`require` when it is loaded, so that the other trials go on."""

    trial: Path | None
    grf: Path | None
    how: str
    error: InputError | None = None

    def require(self) -> TrialFiles:
        """These files, or the :class:`InputError` that stopped their pairing."""
        if self.error is not None:
            raise self.error
        return self

    def describe(self) -> str:
        if self.trial is None:
            return "trial: the bundled example (gc_ocp/data/test_small.c3d)"
        if self.grf is None:
            return f"trial {self.trial}: {self.how}"
        return f"trial {self.trial} + ground reactions {self.grf} ({self.how})"


def _is_trc(p: Path) -> bool:
    return p.suffix.lower() == ".trc"


def find_grf(trc: Path) -> tuple[Path, str]:
    """The ground-reaction file beside ``trc`` (see the module doc) and why it was chosen."""
    folder = trc.parent
    files = (
        sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in GRF_SUFFIXES)
        if folder.is_dir()
        else []
    )
    named = [p for p in files if p.stem.startswith(trc.stem)]
    if len(named) > 1:  # walk1 vs walk10: keep names where the stem ends at a separator
        named = [p for p in named if not p.stem[len(trc.stem) : len(trc.stem) + 1].isalnum()]
    if len(named) == 1:
        return named[0], f'its name starts with "{trc.stem}"'
    if not files:
        raise InputError(
            f"{trc} is a TRC marker file without ground reactions, and its folder has no "
            ".mot/.sto file: give --grf FILE (OpenSim ground_force_* columns)."
        )
    if len(files) == 1:
        return files[0], "the only .mot/.sto file in its folder"
    raise InputError(
        f"{trc}: cannot tell which ground-reaction file belongs to it: {[p.name for p in files]} "
        f'(none, or more than one, starts with "{trc.stem}"); give --grf FILE, once per TRC '
        "trial in the order of the trials."
    )


def pair_trials(
    trials: Sequence[str | Path],
    grfs: Sequence[str | Path] | None = None,
    *,
    keep_going: bool = False,
) -> list[TrialFiles]:
    """The files of each trial of ``trials`` (empty: the bundled example).

    grfs: ground-reaction files for the TRC trials, in their order (one per TRC trial), or
    empty/None to find each beside its TRC (module doc). Raises :class:`InputError` naming the
    files and the fix when a TRC cannot be paired; with ``keep_going``, a TRC that is missing
    or has no ground reactions of its own is returned with its error instead
    (:meth:`TrialFiles.require`), so that a command describes or fits the others (errors of
    the trials together, a trial given twice or one file claimed by two, still raise)."""
    paths = [Path(t) for t in trials]
    grfs = [Path(g) for g in (grfs or [])]
    if not paths:
        if grfs:
            raise InputError(
                f"--grf {grfs[0]} needs a TRC trial: give the TRC marker file(s) before --grf "
                "(the bundled example is a C3D file with its own plates)."
            )
        return [TrialFiles(None, None, "bundled example")]
    seen = {}
    for p in paths:
        key = p.resolve()
        if key in seen:
            raise InputError(f"Trial {p} is given twice; give each trial once.")
        seen[key] = p
    trcs = [p for p in paths if _is_trc(p)]
    if grfs and not trcs:
        warnings.warn(
            f"--grf {', '.join(map(str, grfs))} ignored: the trials are C3D files, which carry "
            "their own plates.",
            stacklevel=2,
        )
    elif grfs and len(grfs) != len(trcs):
        raise InputError(
            f"Got {len(grfs)} --grf file(s) for {len(trcs)} TRC trial(s) "
            f"({', '.join(p.name for p in trcs)}); give one --grf per TRC trial, in the order of "
            "the trials, or none to use the .mot/.sto file beside each TRC."
        )
    out = []
    given = iter(grfs if trcs else [])
    for p in paths:
        if not _is_trc(p):
            out.append(TrialFiles(p, None, "C3D with its own plates"))
        elif grfs:
            out.append(TrialFiles(p, next(given), "given with --grf"))
        else:
            try:
                require_file(p, "Trial file", TRIAL_FIX)
                grf, why = find_grf(p)
            except InputError as e:
                if not keep_going:
                    raise
                out.append(TrialFiles(p, None, "", error=e))
                continue
            out.append(TrialFiles(p, grf, why))
    if not grfs:
        claimed: dict[Path, Path] = {}
        for f in out:
            if f.grf is None:
                continue
            other = claimed.setdefault(f.grf.resolve(), f.trial)
            if other != f.trial:
                raise InputError(
                    f"{other} and {f.trial} would both take the ground reactions of {f.grf}; "
                    "give --grf FILE once per TRC trial, in the order of the trials."
                )
    return out


__all__ = ["GRF_SUFFIXES", "TrialFiles", "find_grf", "pair_trials"]
