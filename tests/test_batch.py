"""Studies on Dask (gc_ocp.batch): manifests, a real ``distributed.LocalCluster``, a broken
trial recorded while the others complete, a killed run restarted without redoing finished
subjects. (The diagnosis's answers on the Dask layer against one process:
``tests/test_diagnosis.py::test_parallel_rounds_give_the_serial_answer``.)"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import gc_ocp
from gc_ocp.batch import Settings, Subject, TrialSpec, read_manifest, run
from gc_ocp.batch.manifest import STATIC_SPEED, marker_speed
from gc_ocp.errors import InputError

EXAMPLE = Path(gc_ocp.__file__).parent / "data" / "test_small.c3d"
DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
FAST = Settings(pose_scale=False)  # the fit() path without the width's refits: a faster subject


def _broken(folder: Path) -> Path:
    """A C3D cut before its data section (what an interrupted copy leaves)."""
    folder.mkdir(parents=True, exist_ok=True)
    p = folder / "broken.c3d"
    p.write_bytes(EXAMPLE.read_bytes()[:5000])
    return p


# --- manifests ---------------------------------------------------------------------------------


def test_csv_manifest_groups_trials_by_subject_and_types_the_values(tmp_path):
    (tmp_path / "a").mkdir()
    for name in ("a/w1.c3d", "a/w2.c3d", "b.c3d"):
        shutil.copy(EXAMPLE, tmp_path / name)
    m = tmp_path / "study.csv"
    m.write_text("subject,trial,mass,height\nS1,a/w1.c3d,70,\nS1,a/w2.c3d,,1.8\nS2,b.c3d,,\n")
    subs = read_manifest(m)
    assert [s.id for s in subs] == ["S1", "S2"]
    assert [t.path for t in subs[0].trials] == [tmp_path / "a/w1.c3d", tmp_path / "a/w2.c3d"]
    assert subs[0].mass == 70.0 and subs[0].height == 1.8  # a value may stand on any row
    assert subs[1].mass is None and subs[1].holdout == "auto"
    # "none" holds no stance out (it was looked up as a stance's name and refused)
    m.write_text("subject,trial,holdout\nS1,a/w1.c3d,None\nS2,b.c3d,right@0.4\n")
    assert [s.holdout for s in read_manifest(m)] == [None, "right@0.4"]


@pytest.mark.parametrize(
    "text, words",
    [
        ("subject,file\nS1,x.c3d\n", ["no trial column"]),
        ("subject,trial,weight\nS1,x.c3d,70\n", ["unknown column", "weight"]),
        ("subject,trial,mass\nS1,x.c3d,70\nS1,x.c3d,71\n", ["row 2", "row 3", "mass"]),
        ("subject,trial,mass\nS1,x.c3d,heavy\n", ["row 2", "mass", "kg"]),
        ("subject,trial\nS 1,x.c3d\n", ["row 2", "folder name"]),
        ("subject,trial,foot_roll\nS1,x.c3d,flat\n", ["row 2", "foot_roll", "chain", "level"]),
        ("subject,trial\nS1,missing.c3d\n", ["subject S1", "missing.c3d", "does not exist"]),
        ("subject,trial\nS1,x.c3d,50\n", ["row 2", "beyond the header", "'50'"]),
    ],
)
def test_a_bad_manifest_names_the_row_and_the_fix(tmp_path, text, words):
    _refused(tmp_path / "m.csv", text, words)


def _refused(manifest: Path, text: str, words: list[str]) -> None:
    """``text`` written as ``manifest`` (beside a copy of the example as x.c3d) is refused
    with every one of ``words`` in the message."""
    shutil.copy(EXAMPLE, manifest.parent / "x.c3d")
    manifest.write_text(text)
    with pytest.raises(InputError) as e:
        read_manifest(manifest)
    for w in words:
        assert w in str(e.value)


@pytest.mark.parametrize(
    "text, words",
    [
        ('[[subject]]\nid = "S1"\ntrials = "x.c3d"\n', ["trials is a list", "not 'x.c3d'"]),
        ('[[subject]]\nid = "S1"\ntrials = [{trial = 5}]\n', ["a trial is a path or a table"]),
        ('[[subject]]\nid = "S1"\ntrials = ["x.c3d"]\nmass = true\n', ["mass True", "kg"]),
        (
            '[[subject]]\nid = "S1"\ntrials = [{trial = "x.c3d", forces = "x.mot"}]\n',
            ["unknown key", "forces", "grf"],
        ),
    ],
)
def test_a_toml_value_of_the_wrong_type_names_the_key(tmp_path, text, words):
    """A list written as a string (it was iterated letter by letter: "t does not exist"), a
    trial path that is a number (an AttributeError, status 3), a mass that is a boolean (read
    as 1 kg), a trial table's misspelt grf key (ignored: the trial took the file beside it,
    or failed asking for the grf the table gave)."""
    _refused(tmp_path / "m.toml", text, words)


@pytest.mark.parametrize("suffix", [".csv", ".toml"])
def test_a_manifest_that_is_not_utf8_says_so(tmp_path, suffix):
    """A manifest saved as Latin-1 (a spreadsheet's default in some locales): refused naming
    the file and the encoding to use (it was a UnicodeDecodeError, status 3)."""
    m = tmp_path / f"m{suffix}"
    m.write_bytes(
        "subject,trial\nM\u00fcller,x.c3d\n".encode("latin-1")
        if suffix == ".csv"
        else '[[subject]]\nid = "M\u00fcller"\ntrials = ["x.c3d"]\n'.encode("latin-1")
    )
    with pytest.raises(InputError, match="is not UTF-8 text .* save it as UTF-8"):
        read_manifest(m)


def test_a_manifest_s_marker_set_file_is_its_folder_s_and_part_of_the_results_key(tmp_path):
    """A marker-set path in a manifest is relative to the manifest (as its trials; it was the
    working folder's), and the file's content is in the subject's key: editing the file makes
    the results stale (its name alone was, and a rerun skipped the subject)."""
    from gc_ocp.batch.subject import subject_key

    shutil.copy(EXAMPLE, tmp_path / "x.c3d")
    ms = tmp_path / "ms.toml"
    shutil.copy(Path(gc_ocp.__file__).parent / "data" / "markersets" / "plugingait.toml", ms)
    m = tmp_path / "m.csv"
    m.write_text("subject,trial,markerset\nS1,x.c3d,ms.toml\n")
    (s,) = read_manifest(m)
    assert Path(s.markerset) == ms
    key = subject_key(s, Settings())
    ms.write_text(ms.read_text().replace("reference_height = 1.7", "reference_height = 1.75"))
    assert subject_key(s, Settings()) != key


@pytest.mark.parametrize(
    "subject, words",
    [
        ("x.c3d", ["Subject objects", "not str"]),
        (Subject("../evil", (TrialSpec(EXAMPLE),)), ["'../evil'", "folder name"]),
        (Subject("summary.csv", (TrialSpec(EXAMPLE),)), ["study's own files"]),
        (Subject("S1\n", (TrialSpec(EXAMPLE),)), ["'S1\\n'", "spaces around it"]),
        (Subject("S1", ("x.c3d",)), ["TrialSpec", "not str"]),
    ],
)
def test_a_study_of_subjects_that_are_not_subjects_is_refused_before_any_work(
    tmp_path, subject, words
):
    """The Python API given what a manifest cannot hold: a path for a subject, an id that
    leaves the study's folder (its files were written to ../evil) or is the study's own
    summary.csv (the run crashed after fitting), a path for a trial, an id with white space
    around it (read from a text file: its folder was "S1\\n", and "S1 " was another subject than
    "S1"). Each an InputError before the output folder is made."""
    out = tmp_path / "out"
    with pytest.raises(InputError) as e:
        run([subject], out, progress=None)
    for w in words:
        assert w in str(e.value)
    assert not out.exists()


def test_two_subject_ids_that_differ_only_in_case_are_refused(tmp_path):
    """P01 and p01 (two rows of a spreadsheet, typed twice): two subjects whose output folders
    are one on a case-insensitive file system (macOS, Windows), where each overwrote the other's
    files and done.json (two subjects' results crossing, and a rerun redid both for ever)."""
    out = tmp_path / "out"
    subjects = [Subject("P01", (TrialSpec(EXAMPLE),)), Subject("p01", (TrialSpec(EXAMPLE),))]
    with pytest.raises(InputError, match="P01.*p01"):
        run(subjects, out, progress=None)
    assert not out.exists()


def test_a_flag_is_counted_on_the_foot_it_names_and_a_subject_s_on_both():
    """The summary's flags per foot: a poor fit of the left foot (``what`` "left") and the
    held-out right stance's flag (its label, no "/") were counted on both feet, a stance of a
    trial named "Bright_walk" on the right foot whatever its side, and the shared friction at
    its bound ("contact/mu") on neither, though params_at_bound names it on both rows."""
    from gc_ocp.batch.summary import subject_rows

    doc = {
        "provenance": {"trials": [{"mass_kg": 70.0, "height_m": 1.7}]},
        "params": {},
        "rms": {"left": {}, "right": {}},
        "solver": {"status": "Solve_Succeeded", "iterations": 10},
        "flags": [
            {"code": "poor_fit", "what": "left", "message": "-"},
            {"code": "at_bound", "what": "contact/mu", "message": "-"},
            {
                "code": "prior_exceeded",
                "what": "pose/Bright_walk:left@0.941s/trans",
                "message": "-",
            },
            {"code": "unit_not_identified", "what": "right/PM", "message": "-"},
            {"code": "bias_correction_failed", "what": "bias correction", "message": "-"},
        ],
        "heldout_flags": [
            {"code": "heldout_not_converged", "what": "Bright_walk:right@1.494s", "message": "-"}
        ],
    }
    rows = {r["foot"]: r for r in subject_rows(Subject("S1", ()), doc, None)}
    assert rows["left"]["flag_codes"] == (
        "at_bound; bias_correction_failed; poor_fit; prior_exceeded"
    )
    assert rows["right"]["flag_codes"] == (
        "at_bound; bias_correction_failed; heldout_not_converged; unit_not_identified"
    )
    assert rows["left"]["flags"] == rows["right"]["flags"] == 4


def test_the_study_page_draws_when_no_subject_was_fitted():
    """Every subject failed: the summary figures have nothing to put on their log axis (it
    raised, and the run ended with status 3 before its summary page)."""
    import io

    from gc_ocp.batch.page import summary_figures

    figs = summary_figures([{"subject": "S1", "status": "failed"}])
    for fig in figs.values():
        fig.savefig(io.BytesIO(), format="png")


def test_the_study_page_s_median_leaves_out_units_not_identified():
    """The summary's columns say to leave a not-identified unit's f_ref out of a group's
    statistics; the page's median bar took it in (here a free PM at 1e5 N moved the left foot's
    PM median from 400 to 1e5 N). It is drawn hollow and left out of the median."""
    from gc_ocp.batch.page import summary_figures
    from gc_ocp.batch.summary import COLUMNS

    def row(subject, pm, free):  # a summary row as the study writes it (every column)
        r = dict.fromkeys(COLUMNS) | {"subject": subject, "status": "done", "foot": "left"}
        r.update({f"f_ref_{u}_N": 300.0 for u in ("PL", "PM", "AL", "AM", "TT")})
        return {**r, "f_ref_PM_N": pm, "units_not_identified": "PM; AM" if free else ""}

    rows = [row("S1", 400.0, False), row("S2", 1e5, True), row("S3", 1e5, True)]
    fig = summary_figures(rows)["units"]
    bars = [ln for ln in fig.axes[0].lines if ln.get_marker() == "None"]  # median bars
    pm = [ln for ln in bars if abs(np.mean(ln.get_xdata()) - (1 - 0.15)) < 1e-9]  # PM, left
    assert len(pm) == 1 and list(pm[0].get_ydata()) == [400.0, 400.0]
    hollow = [ln for ln in fig.axes[0].lines if ln.get_markerfacecolor() == "none"]
    assert sorted(y for ln in hollow for y in ln.get_ydata()) == [300.0, 300.0, 1e5, 1e5]


def test_a_subject_that_now_fails_leaves_no_earlier_results_beside_its_error(tmp_path):
    """A subject fitted before whose inputs changed and whose fit now fails: its earlier
    fit.json and report.html are removed with its done.json (they stayed beside the new
    error.json, a report of inputs the study no longer has)."""
    from gc_ocp.batch.subject import process_subject

    folder = tmp_path / "out" / "S1"
    folder.mkdir(parents=True)
    for name in ("fit.json", "report.html", "done.json", "fit_wrench.png"):
        (folder / name).write_text("earlier")
    (folder / "notes.txt").write_text("mine")
    subject = Subject("S1", (TrialSpec(_broken(tmp_path / "in")),))
    outcome = process_subject(subject, tmp_path / "out", FAST)
    assert outcome["status"] == "failed"
    assert sorted(p.name for p in folder.iterdir()) == ["error.json", "notes.txt"]


def test_a_subject_whose_file_is_gone_is_a_failed_subject_with_its_error_json(tmp_path):
    """A subject (the Python API's, or a file deleted after the manifest was read) whose trial
    does not exist: its key could not be computed, and the task raised FileNotFoundError out of
    process_subject, which the study recorded as "the worker running it died (memory?)" with no
    error.json. It is the subject's failure: error.json, and a fix that names the file."""
    from gc_ocp.batch.subject import process_subject

    gone = tmp_path / "in" / "walk.c3d"  # the one trial: nothing left to fit, the subject fails
    outcome = process_subject(Subject("S1", (TrialSpec(gone),)), tmp_path / "out", FAST)
    assert outcome["status"] == "failed" and outcome["error"]["type"] == "InputError"
    err = json.loads((tmp_path / "out" / "S1" / "error.json").read_text())
    assert err["type"] == "InputError" and f"{gone} does not exist" in err["message"]
    # a static trial not there: the key reads it first
    shutil.copy(EXAMPLE, tmp_path / "w.c3d")
    subject = Subject("S2", (TrialSpec(tmp_path / "w.c3d"),), static=gone)
    outcome = process_subject(subject, tmp_path / "out", FAST)
    assert outcome["status"] == "failed" and outcome["error"]["type"] == "FileNotFoundError"
    assert str(gone) in outcome["error"]["fix"] and "memory" not in outcome["error"]["fix"]
    err = json.loads((tmp_path / "out" / "S2" / "error.json").read_text())
    assert err["type"] == "FileNotFoundError" and str(gone) in err["message"]


def test_an_interrupt_after_the_new_files_are_in_leaves_no_earlier_done_json(tmp_path, monkeypatch):
    """A subject done with settings A, redone with settings B: B's files were moved in
    (OutputSet.commit; a Ctrl-C during it is raised at its end) and the task stopped before
    B's done.json, so A's done.json sat beside B's files. A later run with settings A took
    B's files for A's results (skipped, A's rows in the summary). The earlier done.json goes
    before the new files come in."""
    import types

    subject_mod = sys.modules["gc_ocp.batch.subject"]
    from gc_ocp.batch.subject import completed, process_subject, subject_key

    shutil.copy(EXAMPLE, tmp_path / "w.c3d")
    subject = Subject("S1", (TrialSpec(tmp_path / "w.c3d"),))
    folder = tmp_path / "out" / "S1"
    folder.mkdir(parents=True)
    key_a = subject_key(subject, Settings())
    (folder / "fit.json").write_text("A")
    done_a = {"key": key_a, "subject": "S1", "files": ["fit.json"], "rows": [], "seconds": 1}
    (folder / "done.json").write_text(json.dumps(done_a))

    def write_fit(out, report, prov, extra):
        out.text("fit.json", "B")
        return {}

    class Interrupted(subject_mod.OutputSet):
        def commit(self):
            super().commit()
            raise KeyboardInterrupt  # a Ctrl-C deferred during the commit

    monkeypatch.setattr(subject_mod, "load_subject", lambda *a, **k: ([], []))
    monkeypatch.setattr(subject_mod, "subject_rows", lambda *a: [])
    monkeypatch.setattr(subject_mod, "OutputSet", Interrupted)
    monkeypatch.setattr("gc_ocp.workflow.provenance.provenance", lambda *a: {})
    monkeypatch.setattr("gc_ocp.workflow.fitting.fit", lambda *a, **k: types.SimpleNamespace())
    monkeypatch.setattr("gc_ocp.workflow.fit_files.write_fit", write_fit)
    with pytest.raises(KeyboardInterrupt):
        process_subject(subject, tmp_path / "out", FAST)
    assert (folder / "fit.json").read_text() == "B"
    assert completed(folder, key_a) is None  # B's files are not A's results


def test_a_study_folder_whose_subject_keeps_its_trials_one_level_down_says_so(tmp_path):
    """Subject B's trials in B/session1/: refused naming the folder (B vanished from the study
    without a word). A subfolder with no trial anywhere (an output folder) is still passed."""
    (tmp_path / "A").mkdir()
    shutil.copy(EXAMPLE, tmp_path / "A" / "walk.c3d")
    (tmp_path / "B" / "session1").mkdir(parents=True)
    shutil.copy(EXAMPLE, tmp_path / "B" / "session1" / "walk.c3d")
    (tmp_path / "out").mkdir()
    with pytest.raises(InputError, match="B holds trials only in its subfolders"):
        read_manifest(tmp_path)
    shutil.rmtree(tmp_path / "B")
    assert [s.id for s in read_manifest(tmp_path)] == ["A"]


def test_toml_manifest(tmp_path):
    shutil.copy(EXAMPLE, tmp_path / "w.c3d")
    m = tmp_path / "m.toml"
    m.write_text('[[subject]]\nid = "S1"\ntrials = ["w.c3d"]\nbelt_speed = 1.2\n')
    (s,) = read_manifest(m)
    assert s.trials == (TrialSpec(tmp_path / "w.c3d"),) and s.belt_speed == 1.2
    assert s.foot_roll == "chain"  # the default
    m.write_text('[[subject]]\nid = "S1"\ntrials = ["w.c3d"]\nfoot_roll = "level"\n')
    assert read_manifest(m)[0].foot_roll == "level"
    m.write_text('[[subject]]\nid = "S1"\ntrials = ["w.c3d"]\nspeed = 1.2\n')
    with pytest.raises(InputError, match="unknown key"):
        read_manifest(m)


def test_a_trc_without_its_grf_in_the_manifest_is_paired_as_fit_pairs_it(tmp_path):
    """A manifest may give the GRF file of some TRC trials only: each other TRC finds its own
    beside it (as ``gc-ocp fit`` does), a C3D keeps its plates, and a TRC with no GRF anywhere
    is an error that names the file and the fix."""
    from gc_ocp.batch.subject import subject_files

    for d in ("w1", "w2"):
        (tmp_path / d).mkdir()
        (tmp_path / d / "walk.trc").write_text("x")
    (tmp_path / "w1" / "grf_given.mot").write_text("x")
    (tmp_path / "w2" / "walk_grf.mot").write_text("x")
    shutil.copy(EXAMPLE, tmp_path / "c.c3d")
    subject = Subject(
        "S1",
        (
            TrialSpec(tmp_path / "w1/walk.trc", tmp_path / "w1/grf_given.mot"),
            TrialSpec(tmp_path / "w2/walk.trc"),
            TrialSpec(tmp_path / "c.c3d"),
        ),
    )
    files = subject_files(subject)
    assert [f.grf for f in files] == [
        tmp_path / "w1/grf_given.mot",
        tmp_path / "w2/walk_grf.mot",
        None,
    ]
    (tmp_path / "w2" / "walk_grf.mot").unlink()
    with pytest.raises(InputError, match="w2/walk.trc.*--grf"):
        subject_files(subject, keep_going=False)
    # as gc-ocp fit: the trial carries its error, raised when it is loaded (the others go on)
    with pytest.raises(InputError, match="w2/walk.trc.*--grf"):
        subject_files(subject)[1].require()


def test_a_trial_with_no_ground_reactions_or_no_file_is_skipped_as_fit_skips_it(tmp_path):
    """A subject's TRC with no ground reactions beside it, or a trial file not there, among
    other trials: skipped with its reason, the subject fitted on the rest, as ``gc-ocp fit``
    does (``workflow.trials``). The study failed the whole subject (its pairing raised), and a
    missing file made its key raise."""
    from gc_ocp.batch.subject import load_subject, subject_key

    good = tmp_path / "good.c3d"
    shutil.copy(EXAMPLE, good)
    (tmp_path / "lone.trc").write_text("x")
    gone = tmp_path / "gone.c3d"
    subject = Subject("S1", (TrialSpec(good), TrialSpec(tmp_path / "lone.trc"), TrialSpec(gone)))
    key = subject_key(subject, FAST)
    pairs, skipped = load_subject(subject, tmp_path / "cache")
    assert len(pairs) == 1 and pairs[0][0].name == "good"
    assert [Path(s.files[0]).name for s in skipped] == ["lone.trc", "gone.c3d"]
    assert "--grf" in skipped[0].message and "does not exist" in skipped[1].message
    shutil.copy(EXAMPLE, gone)  # the file is there now: the results made without it are stale
    assert subject_key(subject, FAST) != key


def test_the_grf_file_found_beside_a_trc_is_part_of_the_results_key(tmp_path):
    """A TRC whose ground reactions the manifest does not give is fitted with the MOT beside it;
    that file's content was not in the subject's key (only a manifest's grf was): a corrected
    MOT left the subject "complete", and a rerun skipped it with the old forces' results."""
    from gc_ocp.batch.subject import subject_key

    (tmp_path / "walk.trc").write_text("x")
    mot = tmp_path / "walk_grf.mot"
    mot.write_text("forces")
    subject = Subject("S1", (TrialSpec(tmp_path / "walk.trc"),))
    key = subject_key(subject, Settings())
    mot.write_text("forces, corrected")
    assert subject_key(subject, Settings()) != key


@pytest.mark.skipif(not DATA.is_dir(), reason="needs ../shared/data")
def test_a_study_folder_finds_the_static_trial_by_its_markers_standing_still(tmp_path):
    # every static file of the shared data stands still, every walking file moves: the rule is
    # the markers' speed (physics), not the file names, which these copies do not keep
    sub = tmp_path / "P01"
    sub.mkdir()
    shutil.copy(DATA / "bts_unipd_5trials" / "Static1.c3d", sub / "a.c3d")
    shutil.copy(DATA / "bts_unipd_5trials" / "Walking1.c3d", sub / "b.c3d")
    (s,) = read_manifest(tmp_path)
    assert s.id == "P01" and s.static == sub / "a.c3d"
    assert [t.path for t in s.trials] == [sub / "b.c3d"]
    assert (
        marker_speed(sub / "a.c3d")
        < STATIC_SPEED / 3
        < 3 * STATIC_SPEED
        < marker_speed(sub / "b.c3d")
    )


# --- runs on a real LocalCluster -----------------------------------------------------------


def _rows(out: Path) -> dict:
    import pyarrow.parquet as pq

    t = pq.read_table(out / "summary.parquet").to_pylist()
    return {(r["subject"], r["foot"]): r for r in t}


def test_a_broken_trial_is_recorded_and_the_others_complete_then_a_rerun_skips_them(tmp_path):
    from distributed import Client, LocalCluster

    good = tmp_path / "in" / "good.c3d"
    good.parent.mkdir()
    shutil.copy(EXAMPLE, good)
    # S1's second trial is broken too: skipped with its reason, S1 fitted on the good one
    extra = _broken(tmp_path / "in" / "s1_extra")
    subjects = [
        Subject("S1", (TrialSpec(good), TrialSpec(extra))),
        Subject("BAD", (TrialSpec(_broken(tmp_path / "in" / "bad")),)),
    ]
    out = tmp_path / "out"
    # one worker: the broken subject fails at once, the good one runs after or beside it
    with (
        LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=":0") as cluster,
        Client(cluster) as client,
    ):
        first = run(subjects, out, client=client, settings=FAST, progress=None)
        assert first.counts() == {"done": 1, "failed": 1}
        rows = _rows(out)
        assert {k[0] for k in rows} == {"S1", "BAD"}
        bad = rows[("BAD", None)]
        assert bad["status"] == "failed" and bad["error_type"] == "InputError"
        assert "truncated" in bad["error_message"] and bad["error_fix"]
        err = json.loads((out / "BAD" / "error.json").read_text())
        assert err["type"] == "InputError" and "broken.c3d" in err["message"]
        for foot in ("left", "right"):
            r = rows[("S1", foot)]
            assert r["status"] == "done" and np.isfinite(r["n"]) and r["n_se"] > 0
            assert 0 < r["rms_superior_force_pct_bw"] < 10  # % BW: a fit, not a failure
            assert r["trials"] == 1 and r["trials_skipped"] == 1
            assert r["bias_replicates"] == 0  # the bundled trial's markers are quiet
        # the worker's warnings are kept with the subject, not printed between progress lines
        said = json.loads((out / "S1" / "done.json").read_text())["warnings"]
        assert any("LLS initialisation" in w for w in said), said  # this subject's one warning
        [skip] = json.loads((out / "S1" / "fit.json").read_text())["provenance"]["trials_skipped"]
        assert skip["files"] == [str(extra.resolve())] and "truncated" in skip["message"]
        assert rows[("S1", "right")]["heldout_stance"]  # "auto": the right foot has two
        law = json.loads((out / "S1" / "fit.json").read_text())["blocks"]["contact"]
        for foot in ("left", "right"):  # the units whose force the data do not fix, by name
            weak = [u for u, e in law[foot].items() if isinstance(e, dict) and not e["identified"]]
            assert (rows[("S1", foot)]["units_not_identified"] or "") == "; ".join(weak)
        # a parameter the fit left on a bound: named, its SE left empty (not an estimate); the
        # flags added to this subject's fit.json as a fit writes them (at_bound, "what": the key)
        from gc_ocp.batch.summary import subject_rows
        from gc_ocp.foot import UNITS

        doc = json.loads((out / "S1" / "fit.json").read_text())
        marks = [("contact/mu", "mu"), ("contact/k/left/PM", "k PM")]
        doc["flags"] += [
            {"code": "at_bound", "what": w, "message": "at its bound"} for w, _ in marks
        ]
        rows_b = {r["foot"]: r for r in subject_rows(Subject("S1", ()), doc, None)}
        assert rows_b["left"]["params_at_bound"] == "mu; k PM"
        assert rows_b["right"]["params_at_bound"] == "mu"  # the left foot's unit is its own
        assert rows_b["left"]["mu_se"] is None and rows_b["left"]["f_ref_PM_N_se"] is None
        assert rows_b["right"]["f_ref_PM_N_se"] == rows[("S1", "right")]["f_ref_PM_N_se"]
        assert rows_b["left"]["n_se"] == rows[("S1", "left")]["n_se"] > 0  # the others kept
        # a stiffness of a wider scope (one k per foot) at its bound: every unit of that foot
        doc["flags"].append({"code": "at_bound", "what": "contact/k/right", "message": "-"})
        rows_c = {r["foot"]: r for r in subject_rows(Subject("S1", ()), doc, None)}
        assert rows_c["right"]["params_at_bound"] == "mu; " + "; ".join(f"k {u}" for u in UNITS)
        assert rows_c["left"]["params_at_bound"] == "mu; k PM"
        page = (out / "summary.html").read_text(encoding="utf-8")
        # self-contained but for the subjects' own reports beside it
        assert set(re.findall(r'href="([^"]+)"', page)) == {"S1/report.html"}  # one per foot row
        assert "<script" not in page and page.count('src="data:image/png;base64,') == 2
        assert "broken.c3d" in page and "InputError" in page
        assert page.count("+1 not used</b>") == 2  # S1's rows: its skipped trial
        assert (out / "S1" / "report.html").is_file()
        done = out / "S1" / "done.json"
        stamp = done.stat().st_mtime_ns
        second = run(subjects, out, client=client, settings=FAST, progress=None)
    assert second.counts() == {"skipped": 1, "failed": 1}
    assert done.stat().st_mtime_ns == stamp  # not redone
    again = _rows(out)
    assert again[("S1", "left")]["n"] == rows[("S1", "left")]["n"]  # read back, not refitted
    csv = (out / "summary.csv").read_text().splitlines()
    assert csv[0].startswith("subject,foot,status") and len(csv) == 1 + 3  # header + 3 rows


def test_a_killed_run_restarts_without_redoing_finished_subjects(tmp_path):
    trials = tmp_path / "in"
    trials.mkdir()
    lines = ["subject,trial"]
    for k in range(2):
        shutil.copy(EXAMPLE, trials / f"w{k}.c3d")
        lines.append(f"S{k},in/w{k}.c3d")
    manifest = tmp_path / "study.csv"
    manifest.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "gc_ocp.cli", "batch", str(manifest), "--out", str(out)]
    cmd.append("--fixed-pose-width")  # faster subjects; the resumption is what is tested
    proc = subprocess.Popen(
        [*cmd, "--workers", "1"],
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 600
        while not any(out.glob("S*/done.json")):
            assert proc.poll() is None, "the run ended before any subject finished"
            assert time.monotonic() < deadline
            time.sleep(0.5)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the command, its scheduler and workers
        proc.wait()
    finished = {p.parent.name: p.stat().st_mtime_ns for p in out.glob("S*/done.json")}
    assert len(finished) == 1  # one worker: the second subject was running
    assert not (out / "summary.csv").exists()  # no summary of a run that did not end
    for sid in ("S0", "S1"):  # nothing half-written is taken for a result
        folder = out / sid
        if sid not in finished and folder.exists():
            assert not (folder / "fit.json").exists() or not (folder / "done.json").exists()
    res = subprocess.run([*cmd, "--workers", "1"], capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, res.stderr[-2000:]
    status = {r["subject"]: r["status"] for r in _rows(out).values()}
    assert status == dict.fromkeys(("S0", "S1"), "done")  # every subject complete
    for sid, stamp in finished.items():
        assert (out / sid / "done.json").stat().st_mtime_ns == stamp  # not redone
    assert "skipped" in res.stdout
    assert not list(out.glob(".S*"))  # no staging folder left behind


def test_a_long_error_in_the_progress_line_is_cut_at_a_word_and_says_where_the_rest_is():
    from gc_ocp.batch.run import Progress

    msg = "The trials are not of one subject: their recorded masses differ " * 4
    line = Progress(3, None).line(
        {"subject": "P07", "status": "failed", "error": {"type": "InputError", "message": msg}}
    )
    cut = line.split("(InputError: ", 1)[1]
    assert cut.startswith(msg[:100]) and "... (P07/error.json)" in cut
    assert not cut.split("...")[0].endswith(("differ", "of one", "th"))  # a whole word last


def test_an_interrupt_while_the_summary_is_made_writes_none_of_it(tmp_path, monkeypatch):
    """Ctrl-C while the study's page drew its figures (seconds) left summary.csv and
    summary.parquet without summary.html, or beside an earlier run's page: "no summary is
    written for a run that did not end". And a worker killed midway (its subject redone on
    another) left its staging folder ``OUT/.<id>.*`` in a finished study's folder."""
    from distributed import Client, LocalCluster

    batch_run = sys.modules["gc_ocp.batch.run"]  # (gc_ocp.batch.run is the function)

    subjects = [Subject("S1", (TrialSpec(_broken(tmp_path / "in")),))]  # fails fast
    out = tmp_path / "out"
    gather = batch_run._gather

    def killed_worker_left_staging(*a, **kw):
        gather(*a, **kw)
        (out / ".S1.x1y2z3").mkdir()  # what OutputSet's mkdtemp names, for a killed task

    def interrupted(*a, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(batch_run, "_gather", killed_worker_left_staging)
    monkeypatch.setattr(batch_run, "summary_html", interrupted)
    with (
        LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=":0") as cluster,
        Client(cluster) as client,
    ):
        with pytest.raises(KeyboardInterrupt):
            run(subjects, out, client=client, settings=FAST, progress=None)
    assert not list(out.glob("summary*"))
    assert not list(out.glob(".S1.*"))


def test_a_second_run_on_the_same_folder_is_refused_while_the_first_runs(tmp_path):
    """Two runs on one folder ran together: the second's start removed the first's staging
    folders as stale (its subject then failed, FileNotFoundError), and that failure deleted
    the subject's results the first had finished: the first exited 0 with a subject whose
    files were gone. The running study holds a lock on its folder; a second run is refused
    before it touches anything."""
    import fcntl

    out = tmp_path / "out"
    out.mkdir()
    staging = out / ".S1.abc123"  # the first run's subject, being written
    staging.mkdir()
    subjects = [Subject("S1", (TrialSpec(_broken(tmp_path / "in")),))]
    with open(
        out / ".gc_ocp_batch.lock", "a"
    ) as first:  # gc_ocp.batch.run.LOCK  # what the first run holds
        fcntl.flock(first, fcntl.LOCK_EX | fcntl.LOCK_NB)
        with pytest.raises(InputError, match="another gc-ocp batch is running"):
            run(subjects, out, settings=FAST, workers=1, progress=None)
    assert staging.is_dir() and not (out / "S1").exists()


def test_a_number_that_is_not_finite_is_null_in_the_table_as_after_a_resume():
    """A fresh run's row may hold NaN (an SE not identified); the same row read back from
    ``done.json`` on a resume holds null there (strict JSON). Both are one missing value: an
    empty CSV cell, and a null (not a NaN) in the parquet table, so a resumed study's table is
    the fresh one's."""
    from gc_ocp.batch.summary import NUMERIC, to_arrow, to_csv
    from gc_ocp.text import json_text

    col = sorted(NUMERIC)[0]
    fresh = [{"subject": "S1", "foot": "left", col: float("nan")}]
    resumed = json.loads(json_text(fresh))
    assert resumed[0][col] is None
    for rows in (fresh, resumed):
        assert to_arrow(rows).column(col).to_pylist() == [None]
    assert to_csv(fresh) == to_csv(resumed)


def _unbreakable_widths(page: str) -> list[int]:
    """Per column of the page's ``table.wide``, the widest piece [characters] a browser cannot
    break: a cell of class ``w`` breaks between words but not inside a ``<span>``; any other
    cell (``white-space: nowrap`` in that table) is one piece; a header breaks between words."""
    from html.parser import HTMLParser

    class Table(HTMLParser):
        def __init__(self):
            super().__init__()
            self.inside, self.cells, self.cell, self.span = False, [], None, 0

        def handle_starttag(self, tag, attrs):
            a = dict(attrs)
            if tag == "table" and a.get("class") == "wide":
                self.inside = True
            elif self.inside and tag == "tr":
                self.col = 0
            elif self.inside and tag in ("td", "th"):
                wrap = tag == "th" or "w" in (a.get("class") or "").split()
                self.cell = {"col": self.col, "wrap": wrap, "pieces": [""]}
            elif self.cell is not None and tag == "span":
                self.span += 1

        def handle_endtag(self, tag):
            if tag == "table":
                self.inside = False
            elif self.inside and tag in ("td", "th") and self.cell is not None:
                self.cells.append(self.cell)
                self.cell, self.col = None, self.col + 1
            elif tag == "span":
                self.span -= 1

        def handle_data(self, data):
            if self.cell is None:
                return
            if not self.cell["wrap"] or self.span:
                self.cell["pieces"][-1] += data
            else:
                words = data.split(" ")
                self.cell["pieces"][-1] += words[0]
                self.cell["pieces"] += words[1:]

    t = Table()
    t.feed(page)
    widths: dict[int, int] = {}
    for c in t.cells:
        widths[c["col"]] = max(widths.get(c["col"], 0), *(len(p.strip()) for p in c["pieces"]))
    return [widths[k] for k in sorted(widths)]


def test_the_study_table_fits_a_1280_px_window():
    """The table of every subject and foot was wider than a 1280 px window (every cell kept on
    one line; the last columns cut, the reader scrolled sideways). Its narrowest layout, the
    widest unbreakable piece of each column at the table's type size, now fits: the status,
    a subject's trials note and its diagnosis wrap, a value's SE goes below it."""
    import re

    from gc_ocp.batch.page import summary_html
    from gc_ocp.batch.summary import COLUMNS

    done = dict.fromkeys(COLUMNS) | {
        "subject": "subject_0042",
        "status": "done",
        "trials": 3,
        "trials_skipped": 1,
        "stances": 4,
        **{k: 1.5682 for k in ("n", "c", "mu")},
        **{k: 0.1234 for k in ("n_se", "c_se", "mu_se")},
        **{k: 1.79 for k in COLUMNS if k.startswith("rms_")},
        "cop_rms_mm": 12.3,
        "heldout_rms_superior_force_pct_bw": 2.83,
        "flags": 7,
        "diagnosis_selected": "ground_offset, time_offset, damping",
        "seconds": 1234.0,
    }
    rows = [done | {"foot": f} for f in ("left", "right")]
    rows.append(dict.fromkeys(COLUMNS) | {"subject": "BAD", "status": "failed"})
    rows[-1]["error_type"] = "InputError"
    subjects = [{"subject": "subject_0042", "status": "done"}]
    page = summary_html(rows, subjects, 1.0)
    size = re.search(r"table\.wide \{ font-size: ([0-9.]+)em", page)
    em = float(size.group(1)) if size else 1.0
    # 16 px type, 0.9 em tables (gc_ocp/html/templates/_style.html.j2) scaled by table.wide's;
    # a character of Helvetica/Arial digits and lower case is at most ~0.6 em wide; each cell
    # adds its padding (0.4 em a side) and a 1 px border; the body 1 em each side of the window
    px = 16 * 0.9 * em
    widths = _unbreakable_widths(page)
    need = sum(n * 0.6 * px + 0.8 * px + 1 for n in widths) + 2 * 16
    assert len(widths) == 19 and need <= 1280, (widths, need)
