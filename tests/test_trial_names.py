"""Trials whose files share a name (issue 21, part 0, bug 1).

With one folder per trial (``walking1/markers.trc``, ``walking2/markers.trc``), stance labels
used to be ``markers:right@0.268s`` for both trials, and a fit of the two stopped with "pose:
stance labels must be unique". A stance's identity (its label, and the key of its trial's
variables) must not depend on file names being distinct:
:func:`gc_ocp.stance.trial_names` names such trials by the shortest distinguishing end of their
path, and leaves distinctly named trials as they were.

Real data: the BTS subject's Walking1-3 (three different trials of one subject) copied to
``walking{i}/trial.c3d``; the Rajagopal TRC + MOT in ``walking1/`` and, cut 0.2 s short, in
``walking2/`` (the reported layout, with a stance starting at the same millisecond in both).
"""

from __future__ import annotations

import json
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import DATA, RAJ, _need_data

from gc_ocp.errors import ModelError
from gc_ocp.stance import fit_stances, trial_names, trial_stances

BTS = DATA / "bts_unipd_5trials"
BTS_MASS = 95.0  # [kg] not in the files; the plates carry about 930 N over the stride


def test_names_tell_files_apart_by_the_shortest_path_end():
    """Distinct stems keep their stem (labels of existing layouts unchanged); files sharing a stem
    are named by the shortest end of their path that differs, each on its own; the same file
    (however it is written) keeps one name; paths differing only in the extension fall back to
    the position."""
    assert trial_names(["a/walk1.c3d", "b/walk2.trc"]) == ["walk1", "walk2"]
    assert trial_names(["s/walking1/markers.trc", "s/walking2/markers.trc", "s/x.trc"]) == [
        "walking1/markers",
        "walking2/markers",
        "x",
    ]
    # a/x/m and b/x/m need three parts; c/y/m is told apart from both by two
    assert trial_names(["r/a/x/m.c3d", "r/b/x/m.c3d", "r/c/y/m.c3d"]) == [
        "a/x/m",
        "b/x/m",
        "y/m",
    ]
    here = Path.cwd()
    assert trial_names(["d/t.c3d", here / "d" / "t.c3d", "d/../d/t.c3d"]) == ["t", "t", "t"]
    assert trial_names(["d/t.c3d", "d/t.trc"]) == ["t#1", "t#2"]


@pytest.fixture(scope="module")
def bundled():
    from conftest import c3d_trial

    from gc_ocp.kinematics import compute_kinematics

    trial = c3d_trial()
    return trial, compute_kinematics(trial)


def test_one_file_given_twice_with_other_content_is_numbered(bundled):
    """Two trials of one fit read from the same path (e.g. edited in memory) cannot be told apart
    by their path: their position does (``name#k``), so labels and trial keys stay unique."""
    import dataclasses

    trial, kin = bundled
    other = dataclasses.replace(trial, markers=trial.markers + 1e-3)  # another motion, same path
    data = fit_stances([(trial, kin), (other, kin)])
    labels = [d.label for d in data]
    assert len(set(labels)) == len(labels) == 2 * len(trial.stances)
    assert labels[0] == f"test_small#1:{trial.stances[0].label}"
    assert {d.trial for d in data} == {"test_small#1", "test_small#2"}
    # a single trial keeps the label pins and docs rely on
    assert [d.label for d in fit_stances([(trial, kin)])] == [
        d.label for d in trial_stances(trial, kin)
    ]
    assert fit_stances([(trial, kin)])[0].label == "test_small:right@0.407s"


@pytest.fixture(scope="module")
def trc_folders(tmp_path_factory):
    """The reported layout: ``walking1/markers.trc`` + ``walking1/grf.mot`` (the Rajagopal trial)
    and ``walking2/...`` (the same recording cut 20 frames short: another motion array, with the
    first stance at the same millisecond: the exact label clash)."""
    _need_data()
    root = tmp_path_factory.mktemp("trc_layout")
    lines = (RAJ / "motion_capture_walk.trc").read_text().splitlines()
    for folder, drop in (("walking1", 0), ("walking2", 20)):
        (root / folder).mkdir()
        shutil.copy(RAJ / "grf_walk.mot", root / folder / "grf.mot")
        out = list(lines[: len(lines) - drop])
        head = out[2].split("\t")  # NumFrames and OrigNumFrames follow the rows kept
        n = len(lines) - 6 - drop
        head[4] = head[-1] = f"{n}"
        out[2] = "\t".join(head)
        (root / folder / "markers.trc").write_text("\n".join(out) + "\n")
    return root


def test_one_folder_per_trial_with_trc_files_gives_unique_stances(trc_folders):
    """Each TRC is paired with the MOT of its folder; with the files' stems the two first
    stances would both be ``markers:right@0.268s`` (the reported clash); named by their folders
    the stances and the trials' variables are distinct, and the model that refused them builds."""
    from gc_ocp.estimation.components import base_model
    from gc_ocp.estimation.components.time_offset import TimeOffset
    from gc_ocp.estimation.problem import build_estimation
    from gc_ocp.io import load_trial
    from gc_ocp.io.pairing import pair_trials
    from gc_ocp.kinematics import compute_kinematics
    from gc_ocp.workflow.fitting import fit_data

    files = pair_trials(
        [trc_folders / "walking1/markers.trc", trc_folders / "walking2/markers.trc"]
    )
    assert [f.grf.parent.name for f in files] == ["walking1", "walking2"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pairs = []
        for f in files:
            t = load_trial(f.trial, grf=f.grf, mass=85.07)
            pairs.append((t, compute_kinematics(t)))
        old = [st.label for t, k in pairs for st in trial_stances(t, k)]
        assert len(set(old)) < len(old) and "markers:right@0.268s" in old  # the bug's input
        _, data, _ = fit_data(pairs)
    labels = [d.label for d in data]
    assert len(set(labels)) == len(labels)
    assert "walking1/markers:right@0.268s" in labels and "walking2/markers:right@0.268s" in labels
    pb = build_estimation(data, (*base_model(), TimeOffset()))
    keys = {s.key for s in pb.variables.specs if s.key[0] == "time_offset"}
    assert keys == {("time_offset", "walking1/markers"), ("time_offset", "walking2/markers")}


@pytest.fixture(scope="module")
def bts_folders(tmp_path_factory):
    """Three different trials of the BTS subject, each as ``walking{i}/trial.c3d``."""
    _need_data()
    root = tmp_path_factory.mktemp("bts_layout")
    for i in (1, 2, 3):
        (root / f"walking{i}").mkdir()
        shutil.copy(BTS / f"Walking{i}.c3d", root / f"walking{i}" / "trial.c3d")
    return root


@pytest.fixture(scope="module")
def bts_pairs(bts_folders):
    from gc_ocp.io import load_trial
    from gc_ocp.kinematics import compute_kinematics

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = []
        for i in (1, 2, 3):
            t = load_trial(bts_folders / f"walking{i}" / "trial.c3d", mass=BTS_MASS)
            out.append((t, compute_kinematics(t)))
    assert [t.name for t, _ in out] == ["trial"] * 3  # the files' stems are all the same
    return out


def _labelled(labels, trials):
    """Every label names its trial's folder, and the stances of each trial are there."""
    want = [f"walking{i}/trial:{s.label}" for i, (t, _) in trials for s in t.stances]
    return sorted(labels) == sorted(want)


def test_fit_of_two_trials_with_the_same_file_name(bts_pairs):
    from gc_ocp.estimation.components import base_model
    from gc_ocp.workflow.fitting import fit

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rep = fit(bts_pairs[:2], model=base_model())
    labels = [f["label"] for f in rep.result.stance_fits]
    assert _labelled(labels, [(1, bts_pairs[0]), (2, bts_pairs[1])]), labels
    assert rep.result.success


def test_diagnose_and_confirm_trials_with_the_same_file_name(bts_pairs):
    """The diagnosis holds out every stance of the two trials (two per foot), and its
    confirmation on a third trial of the same file name scores that trial's stances: new
    stances, not a clash with the diagnosed ones."""
    from gc_ocp.diagnosis import confirm, diagnose

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d = diagnose(
            bts_pairs[:2],
            candidates=["damping"],
            max_effects=0,
            n_boot=100,
            workers=1,
            mismatch_draws=4,
            pose_width="prior",  # the labels are the point, not the nuisance's size (faster)
        )
        c = confirm(bts_pairs[:2], bts_pairs[2:], [], n_boot=100)
    trained = [(1, bts_pairs[0]), (2, bts_pairs[1])]
    assert _labelled(d.folds["stances"], trained) and d.folds["n"] == 4
    assert [r.effect for r in d.ranking] == ["damping"]
    assert d.ranking[0].heldout_rms_reduction_pct is not None
    assert _labelled(c["train"], trained)
    assert _labelled(c["test"], [(3, bts_pairs[2])])
    assert [s["model"] for s in c["steps"]] == ["base"]
    assert c["steps"][0]["heldout_superior_force_pct_bw"] > 0


def test_confirm_still_refuses_a_diagnosed_trial(bts_pairs, bts_folders, tmp_path):
    """The same trial as new trial is refused, given by its path or as a copy under another
    folder (same motion); nothing is fitted before the refusal."""
    from gc_ocp.diagnosis import confirm
    from gc_ocp.io import load_trial

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ModelError, match=r"walking1/trial:right@.* in both the diagnosed"):
            confirm(bts_pairs[:2], bts_pairs[:1], [])
        (tmp_path / "copy").mkdir()
        shutil.copy(bts_folders / "walking1" / "trial.c3d", tmp_path / "copy" / "trial.c3d")
        t = load_trial(tmp_path / "copy" / "trial.c3d", mass=BTS_MASS)
        with pytest.raises(ModelError, match=r"copy/trial.c3d holds the same motion"):
            confirm(bts_pairs[:2], [(t, bts_pairs[0][1])], [])


@pytest.mark.slow  # a full fit and a diagnosis with their figures and report (~40 s)
def test_cli_fit_and_diagnose_two_trial_folders_with_the_same_file_name(
    bts_folders, tmp_path, capsys
):
    """``gc-ocp fit`` and ``gc-ocp diagnose`` with two trial paths of the same file name: both
    run, and the outputs name the stances and trials by their folders."""
    from gc_ocp.cli import main

    trials = [str(bts_folders / f"walking{i}" / "trial.c3d") for i in (1, 2)]
    common = [*trials, "--mass", str(BTS_MASS)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # the labels are the point, not the pose width (--fixed-pose-width, --pose-width
        # prior: the guessed width, no width rounds; faster)
        fit = ["fit", *common, "--fixed-pose-width", "--out", str(tmp_path / "fit")]
        assert main(fit) == 0
        argv = [
            "diagnose",
            *common,
            "--effects",
            "damping",
            "--null-draws",
            "4",
            "--pose-width",
            "prior",
            "--out",
            str(tmp_path / "d"),
        ]
        assert main(argv) == 0
    err = capsys.readouterr().err
    assert "labels must be unique" not in err
    fit = json.loads((tmp_path / "fit" / "fit.json").read_text())
    names = [t["name"] for t in fit["provenance"]["trials"]]
    assert names == ["walking1/trial", "walking2/trial"]
    labels = [s["label"] for s in fit["stance_fits"]]
    assert len(labels) == 4 and all(lab.split(":")[0] in names for lab in labels)
    d = json.loads((tmp_path / "d" / "diagnosis.json").read_text())
    assert d["folds"]["n"] == 4 and sorted(d["folds"]["heldout"]) == sorted(labels)
    assert [r["effect"] for r in d["ranking"]] == ["damping"]
    assert np.isfinite(d["ranking"][0]["heldout_rms_reduction_pct"])
