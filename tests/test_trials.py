"""A subject's unusable trial is skipped with its reason, never silently, and only when others
remain (gc_ocp.workflow.trials; the command line's and the study's use of it: test_cli.py,
test_batch.py)."""

from __future__ import annotations

import dataclasses
import functools
import re
import warnings
from pathlib import Path

import pytest

from gc_ocp.errors import InputError, PlateError, SolveError
from gc_ocp.io.pairing import TrialFiles
from gc_ocp.workflow.trials import usable_trials


@functools.cache
def _bundled():
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics

    trial = load_trial()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the height estimate's note is tested elsewhere
        return trial, compute_kinematics(trial)


def _load(f: TrialFiles):
    """The bundled trial for ``good*``; a plate error for ``unreadable*``; the bundled trial
    without its stances for ``standing*`` (what a trial with no foot alone on a plate loads as)."""
    trial, _ = _bundled()
    name = f.trial.name
    if name.startswith("unreadable"):
        raise PlateError(f"{f.trial}: plate 2's corners are all zero; re-export the set-up.")
    if name.startswith("standing"):
        return dataclasses.replace(trial, stances=(), source=f.trial)
    return trial


def _pose(f, trial):
    return _bundled()[1]


def _files(*names: str) -> list[TrialFiles]:
    return [TrialFiles(Path("/lab") / n, None, "C3D") for n in names]


def test_an_unusable_trial_is_skipped_with_its_reason_and_the_others_are_used():
    said = []
    pairs, skipped = usable_trials(
        _files("good.c3d", "unreadable.c3d", "standing.c3d"), _load, _pose, progress=said.append
    )
    assert len(pairs) == 1 and pairs[0] == _bundled()
    assert [s.files for s in skipped] == [("/lab/unreadable.c3d",), ("/lab/standing.c3d",)]
    assert [s.error for s in skipped] == ["PlateError", "PlateError"]
    assert "corners are all zero" in skipped[0].message
    assert "no usable stance" in skipped[1].message  # require_stances' message, with its fix
    assert said == [s.describe() for s in skipped]  # reported as it happens
    assert skipped[0].to_json() == {
        "files": ["/lab/unreadable.c3d"],
        "error": "PlateError",
        "message": skipped[0].message,
        "reason": "plate 2's corners are all zero; re-export the set-up.",  # without the file
    }
    assert skipped[0].describe().count("/lab/unreadable.c3d") == 1


def test_one_trial_strict_runs_and_errors_of_the_code_are_raised_as_they_are():
    with pytest.raises(PlateError, match="corners are all zero"):
        usable_trials(_files("unreadable.c3d"), _load, _pose)  # nothing else to fit
    with pytest.raises(PlateError, match="corners are all zero"):
        usable_trials(_files("good.c3d", "unreadable.c3d"), _load, _pose, strict=True)

    def failing_pose(f, trial):
        raise SolveError("inverse kinematics did not converge")

    with pytest.raises(SolveError):  # not a property of the trial's files: never skipped
        usable_trials(_files("good.c3d", "good2.c3d"), _load, failing_pose)


def test_every_trial_unusable_is_one_error_naming_each_file_and_reason():
    with pytest.raises(InputError) as e:
        usable_trials(_files("unreadable.c3d", "standing.c3d"), _load, _pose)
    msg = str(e.value)
    assert msg.startswith("none of the 2 trials can be used")
    assert "/lab/unreadable.c3d: " in msg and "corners are all zero" in msg
    assert "/lab/standing.c3d: " in msg and "no usable stance" in msg


def test_no_trial_loaded_is_that_error_not_the_command_s_argument_check():
    """With no trial loaded, a --holdout check on the (empty) stances blamed the holdout
    ('matches 0 stances; choose one of []') instead of naming each file's problem."""
    from gc_ocp.workflow.fitting import check_holdout

    with pytest.raises(InputError) as e:
        usable_trials(
            _files("unreadable.c3d", "unreadable2.c3d"),
            _load,
            _pose,
            check_loaded=lambda trials: check_holdout("right@0.4", trials),
        )
    msg = str(e.value)
    assert msg.startswith("none of the 2 trials can be used"), msg
    assert "/lab/unreadable.c3d: " in msg and "corners are all zero" in msg


def test_fit_names_the_usual_slips_of_its_first_argument():
    """``fit([trial])``, ``fit((trial, kin))`` and the like: one message with the call to
    make, not a TypeError from deep inside (the diagnosis takes the same pairs)."""
    import gc_ocp

    trial, kin = _bundled()
    for bad, words in (
        ([trial], "item 0 of the trials is a Trial without its kinematics"),
        ((trial, kin), "got one (trial, kinematics) pair, not a list"),
        (trial, "got a Trial on its own, not a list"),
        ([], "got an empty list"),
        ([(kin, trial)], "item 0 of the trials is tuple of (TrialKinematics, Trial)"),
    ):
        with pytest.raises(InputError, match=re.escape(words)) as e:
            gc_ocp.fit(bad)
        assert "gc_ocp.fit([(trial, kin)])" in str(e.value)
    with pytest.raises(InputError, match="a Trial without its kinematics"):
        gc_ocp.diagnose([trial])
    from gc_ocp.workflow.fitting import _require_pairs

    assert _require_pairs(zip([trial], [kin], strict=True)) == [(trial, kin)]  # read once


def test_a_skipped_trial_given_by_a_relative_path_is_named_once(tmp_path, monkeypatch):
    from gc_ocp.workflow.trials import SkippedTrial

    monkeypatch.chdir(tmp_path)
    s = SkippedTrial(
        (str((tmp_path / "data" / "w1.c3d").resolve()),), "PlateError", "data/w1.c3d: plate 2 ..."
    )
    assert s.reason == "plate 2 ..." and s.describe().count("w1.c3d") == 1


def test_the_subject_s_mass_against_the_plates_is_not_skipped_as_one_trial_s_problem():
    """A mass the plates of one trial contradict (a given --mass 25 % off): before the trial
    rule, the run stopped; skipping that trial would fit the others with the wrong mass."""
    from gc_ocp.errors import MassError

    def wrong_mass(f):
        return dataclasses.replace(_load(f), mass=_bundled()[0].mass * 1.3, mass_source="given")

    with pytest.raises(MassError, match="check the mass"):
        usable_trials(_files("good.c3d", "good2.c3d"), wrong_mass, _pose)
