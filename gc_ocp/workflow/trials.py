"""A subject's trials, each loaded, posed and checked on its own, so that one unusable trial does
not stop the others: the one definition ``gc-ocp fit``, ``gc-ocp diagnose`` and ``gc-ocp batch``
share.

A trial is *unusable* when loading it, posing its feet or the checks of one trial before a fit
raise an :class:`~gc_ocp.errors.InputError` (a plate set up wrongly, a foot that cannot be
tracked, no stance alone on a plate, a body weight the plates contradict, ...). With other trials
left, such a trial is skipped: its files and the error are reported as it happens and recorded
in the output's provenance (``trials_skipped``), and the fit uses the rest. What is never
skipped:

* a single trial's error (nothing would be left to fit: it is raised as it is);
* every trial unusable (one error naming each file and its reason);
* ``strict=True`` (``--strict-trials``): the first unusable trial stops the run, as before
  2026-11-30;
* errors of the trials together (the same motion given twice, trials of two people, the
  subject's mass against the plates: :class:`~gc_ocp.errors.MassError`), of the solver and of
  the code: they are not a property of one trial's files.

The trials are loaded first and given the subject's one mass
(:func:`~gc_ocp.io.consistency.one_subject`) before each is posed and checked, so that each
trial is checked with the mass the fit will use.

Decision (2026-11-30): skipping is the default. A subject's five walking trials with one broken
plate in one of them is the common case in a lab's archive; stopping the other four would make
the user delete the file by hand and lose the record of why. The skipped trial is not silent: it
is printed, in ``fit.json``/``diagnosis.json`` and in the HTML report's provenance, and counted
in a study's summary table.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from pathlib import Path

from gc_ocp.errors import InputError, MassError


@dataclasses.dataclass(frozen=True)
class SkippedTrial:
    """One trial left out: its files, and the error's type and message (which name the fix)."""

    files: tuple[str, ...]
    error: str
    message: str

    @property
    def reason(self) -> str:
        """The message without the file name it starts with (the files are listed beside it;
        the message names a file as it was given, relative or absolute)."""
        head, sep, rest = self.message.partition(": ")
        if sep and head and Path(head).resolve() in {Path(f) for f in self.files}:
            return rest
        return self.message

    def describe(self) -> str:
        return f"skipped trial {' + '.join(self.files)}: {self.reason}"

    def to_json(self) -> dict:
        return {
            "files": list(self.files),
            "error": self.error,
            "message": self.message,
            "reason": self.reason,
        }


def usable_trials(
    files: Sequence,
    load: Callable,
    pose: Callable,
    *,
    strict: bool = False,
    progress: Callable[[str], None] | None = None,
    check_loaded: Callable[[list], None] | None = None,
) -> tuple[list, list[SkippedTrial]]:
    """``([(trial, kinematics), ...], [SkippedTrial, ...])`` of ``files`` (each a
    :class:`~gc_ocp.io.pairing.TrialFiles`); ``load(files) -> Trial`` reads one trial and
    ``pose(files, trial) -> TrialKinematics`` computes its kinematics (after the trial is known to have
    a stance to fit); ``check_loaded(trials)``, if given, checks the command's own arguments
    against the loaded trials before the kinematics (a ``--holdout`` that names no stance).
    Each pair passes the checks of one trial before a fit
    (:func:`~gc_ocp.io.consistency.check_for_fit` on it alone); see the module doc for what is
    skipped and what is raised."""
    from gc_ocp.io.checks import require_stances
    from gc_ocp.io.consistency import check_for_fit, one_subject

    skipped: list[SkippedTrial] = []

    def skip(f, e: InputError) -> None:
        if strict or len(files) == 1:
            raise e
        s = SkippedTrial(_names(f), type(e).__name__, str(e))
        skipped.append(s)
        if progress is not None:
            progress(s.describe())

    loaded = []
    for f in files:
        try:
            loaded.append((f, load(f)))
        except InputError as e:
            skip(f, e)
    if not loaded:  # raised here, not by a check of the command's arguments on no stances
        _none_usable(files, skipped)
    # one person's one mass before each trial's checks, so that a trial is checked with the
    # mass the fit will use (trials of two people: raised, not skipped)
    trials, _ = one_subject([t for _, t in loaded])
    if check_loaded is not None:
        check_loaded(trials)
    pairs = []
    for (f, _), trial in zip(loaded, trials, strict=True):
        try:
            require_stances(trial)
            pair = (trial, pose(f, trial))
            check_for_fit([pair])  # the fit checks them again, together (a duplicate motion)
        except MassError:
            raise  # the subject's mass against the plates: not one trial's property
        except InputError as e:
            skip(f, e)
            continue
        pairs.append(pair)
    if not pairs:
        _none_usable(files, skipped)
    return pairs, skipped


def _none_usable(files: Sequence, skipped: list[SkippedTrial]) -> None:
    raise InputError(
        f"none of the {len(files)} trials can be used: "
        + "; ".join(f"{' + '.join(s.files)}: {s.reason}" for s in skipped)
    )


def _names(f) -> tuple[str, ...]:
    paths = [p for p in (f.trial, f.grf) if p is not None]
    # absolute, as the provenance lists the files used
    return tuple(str(Path(p).resolve()) for p in paths) or ("the bundled example",)


__all__ = ("SkippedTrial", "usable_trials")
