"""Command-line interface."""

from __future__ import annotations

import html
import json
from pathlib import Path

import pytest
from conftest import strict_json  # noqa: E402

from gc_ocp.cli import main
from gc_ocp.contact.channels import CHANNELS, TABLE_KEYS
from gc_ocp.foot import UNITS
from gc_ocp.html.fit_tables import pose_prior_text, sole_prior_text

TABLE1_CASES = [
    "synthetic_noiseless_uniform_k",
    "synthetic_noiseless_random_k",
    "synthetic_noisy_uniform_k",
    "synthetic_noisy_random_k",
    "experimental",
]
TABLE1_KEYS = ["case", "k_rms_pct", *(TABLE_KEYS[c] for c in CHANNELS)]


def test_reproduce_seed_cli(tmp_path, capsys):
    out = tmp_path / "seed"
    assert main(["reproduce-seed", "--seeds", "2", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "Table 1" in captured.out and "Table 2" in captured.out
    assert "[1/" in captured.err  # progress goes to stderr

    rows = json.loads((out / "table1.json").read_text())
    assert [r["case"] for r in rows] == TABLE1_CASES
    for r in rows:
        noisy = "noisy" in r["case"]
        expected = TABLE1_KEYS + ([f"{k}_sd" for k in TABLE1_KEYS[1:]] if noisy else [])
        assert list(r) == expected, r["case"]
    assert rows[-1]["k_rms_pct"] is None
    assert all(isinstance(r["k_rms_pct"], float) for r in rows[:-1])
    assert rows[0]["k_rms_pct"] < 1e-6  # noiseless synthetic data are recovered exactly

    t2 = json.loads((out / "table2.json").read_text())
    assert sorted(t2) == ["left", "right"]
    for side in ("left", "right"):
        assert list(t2[side]) == list(UNITS) == ["PL", "PM", "AL", "AM", "TT"]
        assert all(isinstance(v, float) for v in t2[side].values())
    for name in ("table1.md", "table2.md"):
        assert (out / name).read_text().startswith("# Table")


def test_reproduce_seed_on_a_treadmill_sets_the_belt_as_fit_does(tmp_path, capsys):
    """A treadmill trial without ``--belt-speed``: ``fit`` takes the belt speed the stance feet
    show (and says so); ``reproduce-seed`` ran with a still belt, its friction sliding against
    the floor instead of the belt, without a word. It now sets the belt as ``fit`` does."""
    from conftest import G23

    if not G23.is_dir():
        pytest.skip(f"real datasets not found at {G23}")
    out = tmp_path / "seed"
    argv = ["reproduce-seed", str(G23 / "subject01_walk1.trc"), "--mass", "72.6"]
    assert main([*argv, "--seeds", "1", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "(a treadmill) but no belt speed was given: using 1." in err


def test_reproduce_seed_stopped_midway_leaves_no_part_of_its_tables(tmp_path, monkeypatch, capsys):
    """``reproduce-seed`` wrote table1.json, table1.md, table2.json, table2.md one by one: an
    interrupt between them left this run's Table 1 in --out, alone (a new folder) or beside an
    earlier run's Table 2, looking like a result. The four are now staged and moved in as one
    set (:class:`gc_ocp.outputs.OutputSet`): the interrupt, while table2.json is written, leaves
    a new folder empty and an earlier complete result as it was."""
    import os

    move = os.replace

    def interrupted(src, dst):  # Ctrl-C while table2.json is moved into place
        if Path(dst).name == "table2.json":
            raise KeyboardInterrupt
        move(src, dst)

    earlier, fresh = tmp_path / "earlier", tmp_path / "fresh"
    assert main(["reproduce-seed", "--seeds", "1", "--out", str(earlier)]) == 0
    before = {p.name: p.read_bytes() for p in earlier.iterdir()}
    assert {"table1.json", "table2.json", ".gc_ocp_outputs"} <= set(before)
    monkeypatch.setattr(os, "replace", interrupted)
    # --seeds 2: noisy rows with their spreads, a Table 1 unlike the earlier one
    for out in (earlier, fresh):
        assert main(["reproduce-seed", "--seeds", "2", "--out", str(out)]) == 130
    monkeypatch.undo()
    assert "interrupted" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in earlier.iterdir()} == before
    assert not fresh.exists() or not any(fresh.iterdir())
    assert not list(tmp_path.glob(".*"))  # no staging folder left beside either


def test_info_on_bundled_example(capsys):
    assert main(["info"]) == 0
    out = capsys.readouterr().out
    assert "test_small" in out and "right" in out and "left" in out
    # the lab's processing as a fit reads it (info showed none of it): the bundled trial's
    # first two plates were zeroed by Vicon below ~10 N, as every fit's notes say
    from gc_ocp import load_trial
    from gc_ocp.io.processing import censor_threshold, detect_processing

    proc = detect_processing(load_trial())
    for name in ("plate1", "plate2"):
        x = censor_threshold(proc.plates[name])
        assert x > 0 and f"{name} as processed: zeroed below {x:.1f} N" in out


def test_info_describes_every_readable_trial_and_names_the_unreadable_one(tmp_path, capsys):
    from pathlib import Path

    import gc_ocp

    example = Path(gc_ocp.__file__).parent / "data" / "test_small.c3d"
    broken = tmp_path / "copy_interrupted.c3d"
    broken.write_bytes(example.read_bytes()[:5000])  # cut before its data section
    assert main(["info", str(broken), str(example)]) == 2  # one failed: bad input
    printed = capsys.readouterr()
    assert "copy_interrupted.c3d" in printed.err and "truncated" in printed.err
    assert "1 of 2 trials could not be read" in printed.err
    assert "test_small" in printed.out and "stance" in printed.out  # the other, described
    assert "Traceback" not in printed.err


def test_info_refuses_a_mass_the_plates_contradict(capsys):
    """``info --mass 140`` (the bundled subject's 63.6 kg in pounds) printed a -55 % check and
    exit status 0, while a fit refuses that mass: it is bad input, said with its fix (after the
    description, which is still printed)."""
    assert main(["info", "--mass", "140"]) == 2
    printed = capsys.readouterr()
    assert "stance right" in printed.out  # described
    assert "gc-ocp info: error:" in printed.err and "check the mass (--mass KG" in printed.err
    assert "the plates suggest 62." in printed.err and "Traceback" not in printed.err
    assert main(["info", "--mass", "62"]) == 0  # within the fit's tolerance


def test_info_goes_on_past_a_trc_it_cannot_pair(tmp_path, capsys):
    """A missing TRC and one without ground reactions are named; the C3D is still described
    (the pairing used to stop the whole run at the first of them)."""
    from pathlib import Path

    import gc_ocp

    example = Path(gc_ocp.__file__).parent / "data" / "test_small.c3d"
    (tmp_path / "alone").mkdir()
    lonely = tmp_path / "alone" / "walk.trc"
    lonely.write_text("PathFileType\t4\t(X/Y/Z)\twalk.trc\n")
    args = ["info", str(tmp_path / "missing.trc"), str(lonely), str(example)]
    assert main(args) == 2
    printed = capsys.readouterr()
    assert "missing.trc does not exist" in printed.err
    assert "walk.trc is a TRC marker file without ground reactions" in printed.err
    assert "2 of 3 trials could not be read" in printed.err
    assert "test_small" in printed.out and "Traceback" not in printed.err
    assert main(["info", str(tmp_path / "missing.trc")]) == 2  # alone: its error, as before
    assert "missing.trc does not exist" in capsys.readouterr().err


def test_kinematics_cli_writes_trajectories_summary_and_figure(tmp_path):
    import numpy as np

    assert main(["kinematics", "--out", str(tmp_path), "--format", "npz"]) == 0
    d = np.load(tmp_path / "sole_points.npz")
    n = d["time"].size
    assert d["left_positions"].shape == (n, 5, 3) and d["q"].shape == (n, 27)
    s = json.loads((tmp_path / "kinematics_summary.json").read_text())
    assert s["marker_rms_mm"]["median"] < 15.0  # skin-marker artefact bound, as in test_kinematics
    assert (tmp_path / "kinematics.png").stat().st_size > 10_000
    assert not list(tmp_path.glob(".*.tmp*"))  # no temporary file left behind


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["info", "no_such_trial.c3d"], "does not exist"),
        (["info", "walk.trc"], "does not exist"),
        (["fit", "--holdout", "nonexistent", "--out", "OUT"], "matches 0 stances"),
        # a folder where a file belongs: named as a folder, not as missing
        (["info", "FOLDER"], "is a folder, not a file; give a trial's .c3d file"),
        (["export", "casadi", "FOLDER", "--out", "OUT"], "is a folder, not a file; give the fit"),
        # it was "Model FOLDER does not exist"
        (["export", "opensim", "FIT", "--model", "FOLDER", "--out", "OUT"], "is a folder, not a"),
    ],
)
def test_bad_input_exits_2_with_one_clear_message(argv, needle, capsys, tmp_path):
    (tmp_path / "fit.json").write_text("{}")  # "FIT": the check of --model comes first
    given = {"OUT": str(tmp_path / "o"), "FOLDER": str(tmp_path), "FIT": str(tmp_path / "fit.json")}
    argv = [given.get(a, a) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err


def test_a_holdout_that_names_no_stance_stops_before_the_kinematics(monkeypatch, capsys, tmp_path):
    """The typo is found on the loaded trials' stances, before inverse kinematics (seconds to
    minutes a trial): posing a trial here would fail the test with another message."""
    import gc_ocp.cli.common as common

    def no_kinematics(*_):
        raise AssertionError("the kinematics were computed before the --holdout check")

    monkeypatch.setattr(common, "_kinematics", no_kinematics)
    assert main(["fit", "--holdout", "right@9.99", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "matches 0 stances" in err and "test_small:right@0.407s" in err
    assert not (tmp_path / "o").exists()


def test_check_holdout_lets_every_label_the_fit_could_use_through():
    """A part of the label the fit will make passes (the fit decides which one stance it
    names); with two trials the names are the stems, with a path's end or the full path."""
    import dataclasses

    from conftest import c3d_trial

    from gc_ocp.errors import InputError
    from gc_ocp.workflow.fitting import check_holdout

    t = c3d_trial()
    other = dataclasses.replace(t, source=t.source.with_name("walk2.c3d"))
    folder = f"{t.source.parent.name}/walk2:left"  # a name the fit gives when stems collide
    for ok in ("right@0.407", "test_small:right@0.407s", "walk2:left", folder, "auto", None):
        check_holdout(ok, [t, other])
    with pytest.raises(InputError, match="matches 0 stances"):
        check_holdout("walk3:left", [t, other])


def test_trc_without_grf_names_the_option(tmp_path, capsys):
    trc = tmp_path / "walk.trc"
    trc.write_text("PathFileType\t4\n")
    assert main(["info", str(trc)]) == 2
    assert "--grf" in capsys.readouterr().err


def test_non_numeric_trc_cell_exits_2_naming_file_line_and_marker(tmp_path, capsys):
    from conftest import RAJ

    if not RAJ.is_dir():
        pytest.skip(f"real datasets not found at {RAJ}")
    lines = (RAJ / "motion_capture_walk.trc").read_text().splitlines()
    cells = lines[11].split("\t")  # line 12 = the 7th data row
    cells[9] = "1.2.3"  # the third marker's Y coordinate (cells: frame, time, x1, y1, z1, ...)
    lines[11] = "\t".join(cells)
    trc = tmp_path / "damaged.trc"
    trc.write_text("\n".join(lines) + "\n")
    marker = [n.strip() for n in lines[3].split("\t")[2:] if n.strip()][2]
    argv = ["info", str(trc), "--grf", str(RAJ / "grf_walk.mot"), "--mass", "85.07"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "damaged.trc, line 12" in err and '"1.2.3", not a number' in err
    assert f'marker "{marker}" Y' in err, err


def test_unexpected_exception_is_one_line_internal_error_exit_3(monkeypatch, capsys):
    import gc_ocp.cli as cli

    def boom(args):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(cli, "cmd_info", boom)
    monkeypatch.delenv("GC_OCP_DEBUG", raising=False)
    assert main(["info"]) == 3
    err = capsys.readouterr().err
    assert err == (
        "gc-ocp info: internal error: ZeroDivisionError: float division by zero "
        "(please report with the command line)\n"
    )
    monkeypatch.setenv("GC_OCP_DEBUG", "1")
    assert main(["info"]) == 3
    assert "Traceback" in capsys.readouterr().err


def test_fit_outputs_are_one_consistent_set(tmp_path, capsys):
    """A rerun replaces the command's whole set (a stale held-out figure and fit_failed.json go;
    the user's own files stay); files follow the umask; fit.json carries provenance and flags.
    The rerun is given a second, truncated trial: it is skipped with its reason (printed, in
    fit.json's provenance and in report.html) and the fit uses the bundled one."""
    import json
    import os
    import re
    import stat
    from pathlib import Path

    import gc_ocp
    from gc_ocp.cli import main

    out = tmp_path / "fit"
    assert main(["fit", "--holdout", "right@0.407", "--out", str(out)]) == 0
    assert (out / "heldout_wrench.png").exists()
    _check_fit_report(out)
    (out / "fit_failed.json").write_text("{}")  # stale, from an imagined earlier failed run
    (out / "notes.txt").write_text("mine")
    example = Path(gc_ocp.__file__).parent / "data" / "test_small.c3d"
    broken = tmp_path / "copy_interrupted.c3d"
    broken.write_bytes(example.read_bytes()[:5000])  # cut before its data section
    broken = broken.resolve()  # as the provenance records files
    capsys.readouterr()
    old = os.umask(0o022)
    try:
        assert main(["fit", str(example), str(broken), "--out", str(out)]) == 0
    finally:
        os.umask(old)
    printed = capsys.readouterr()
    assert f"skipped trial {broken}: " in printed.err
    assert re.search(rf"not used: skipped trial {re.escape(str(broken))}: .*truncated", printed.out)
    names = sorted(p.name for p in out.iterdir())
    assert names == [
        ".gc_ocp_outputs",  # the command whose outputs these are (gc_ocp.outputs.OWNER)
        "fit.json",
        "fit_pose_corrections.png",
        "fit_sole.png",
        "fit_wrench.png",
        "landmarks.json",
        "notes.txt",
        "report.html",
    ]
    assert json.loads((out / "landmarks.json").read_text())["trials"][0]["markerset"] == (
        "plugingait"
    )
    assert stat.S_IMODE((out / "fit.json").stat().st_mode) == 0o644
    d = strict_json((out / "fit.json").read_text())
    trial = d["provenance"]["trials"][0]
    assert len(trial["files"][0]["sha256"]) == 64 and trial["mass_source"]
    assert d["provenance"]["gc_ocp_version"] and isinstance(d["flags"], list)
    assert len(d["provenance"]["trials"]) == 1
    # the bias correction is decided from the markers' noise and the decision recorded: this
    # lab's markers were low-passed before export (0.003 mm at the units), so none was made
    assert d["provenance"]["options"]["bias_correction"] is None
    assert d["bias_correction"]["replicates"] == 0
    assert "moves no contact unit by 0.15 mm" in d["bias_correction"]["message"]
    assert "Bias correction for the markers' error: not made: the markers' noise moves" in (
        html.unescape((out / "report.html").read_text(encoding="utf-8"))
    )
    [skip] = d["provenance"]["trials_skipped"]
    assert skip["files"] == [str(broken)] and skip["error"] == "InputError"
    assert "truncated" in skip["message"]
    page = (out / "report.html").read_text(encoding="utf-8")
    assert f"Trial not used: <code>{broken}</code>" in page
    assert not list(tmp_path.glob(".fit.*"))  # no staging folder left


def _check_fit_report(out):
    """``report.html`` of a fit: self-contained (no link, no script; every figure embedded), and
    it says what fit.json says: each shared parameter with its SE, every flag's code, the
    held-out stance and its superior-force RMS."""
    import re

    page = (out / "report.html").read_text(encoding="utf-8")
    d = strict_json((out / "fit.json").read_text())
    assert "<script" not in page and not re.search(r"(src|href)=\"(?!data:)", page)
    assert page.count('src="data:image/png;base64,') == 4  # wrench, sole, pose, held-out
    for p in ("n", "c", "mu"):
        v, se = d["params"]["shared"][p], d["params"]["shared"][p + "_se"]
        assert f"{v:.4g} ± {se:.2g}" in page
    # the damping's unit beside its value, in the lead and the table (it was "c" alone)
    assert page.count("c [s/m]") == 2 and "mu [" not in page
    for f in d["flags"]:
        assert f["code"] in page
    held = d["heldout_stance"]
    assert held in page
    # the sole table names the prior width the fit used (5 mm, or estimated with sole_scale)
    assert f"foot frame; prior {sole_prior_text(d['blocks']['sole'])})" in page
    assert f"{d['heldout_rms']['right']['superior_force_pct_bw']:.2f} % BW" in page
    # the held-out stance's own pose correction, which its flags (if any) speak of
    pose = d["heldout_pose_correction_rms"]["right"]
    prior = pose_prior_text(d["heldout"]["blocks"]["pose"])
    said = f"Its foot-pose correction RMS (prior {prior}): right {pose['mm']:.2f} mm, "
    assert said + f"{pose['deg']:.2f} deg." in page


def test_the_sole_table_names_an_estimated_prior_width():
    """The fit report's and the diagnosis report's sole table (one macro) give the width the
    fit used: an estimated one (``sole_scale``), 5 mm for a fit.json written before the width
    was recorded."""
    from gc_ocp.html import environment

    macro = environment().from_string(
        '{% from "_fit_tables.html.j2" import sole_table %}{{ sole_table([], w) }}'
    )
    per_axis = sole_prior_text({"prior_mm": [5.0, 7.2511, 9.96]})
    assert per_axis == "x 5, y 7.25, z 9.96 mm"  # 9.96 is not the 10 mm limit
    assert "foot frame; prior x 5, y 7.25, z 9.96 mm)" in macro.render(w=per_axis)
    assert sole_prior_text({"prior_mm": 9.5211}) == "9.52 mm"  # one width (before 2026-11-30)
    assert sole_prior_text({}) == "5 mm"  # no width recorded: the component's default


def test_the_pose_prior_text_names_estimated_widths():
    """The reports' pose line gives the widths the fit used: per axis where they differ (an
    estimated width), the component's defaults for a fit.json written before they were
    recorded."""
    from gc_ocp.html.fit_tables import pose_prior_text

    assert pose_prior_text({}) == "2 mm / 1 deg"
    block = {"prior_mm": [0.2, 0.2, 2.744], "prior_deg": [0.1, 0.1, 0.1]}
    assert pose_prior_text(block) == "x 0.2, y 0.2, z 2.74 mm / 0.1 deg"


def test_fit_with_an_effect_shows_its_block(tmp_path, capsys):
    """``fit --effects friction``: the full model plus the Stribeck friction; its block is in
    fit.json, its parameters in the printed summary, the option in the provenance."""

    from gc_ocp.cli import main

    out = tmp_path / "fit"
    assert main(["fit", "--effects", "friction", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    d = strict_json((out / "fit.json").read_text())
    assert d["components"]["friction"] == "StribeckFriction"
    assert d["provenance"]["options"]["effects"] == "friction"
    b = d["blocks"]["friction"]
    assert f"friction mu_s - mu_d = {b['static_excess']:.4g}" in printed, printed
    assert f"friction b = {b['viscous']:.4g}" in printed


@pytest.mark.parametrize(
    "effects, needle",
    [
        ("friction,wobble", "unknown effect(s) wobble; choose from damping"),
        ("", "no effect given"),
        ("damping", "damping already in the fitted model"),
    ],
)
def test_fit_bad_effects_exit_2_before_any_work(tmp_path, capsys, effects, needle):
    from gc_ocp.cli import main

    out = tmp_path / "fit"
    assert main(["fit", "--effects", effects, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err and "choose from" in err, err
    assert "solving" not in err and not out.exists()


def test_unusable_out_fails_before_any_computation(tmp_path, capsys):
    from gc_ocp.cli import main

    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    assert main(["fit", "--out", str(blocker)]) == 2
    err = capsys.readouterr().err
    assert "--out" in err and "not a folder" in err and "Traceback" not in err
    assert "solving" not in err  # nothing was computed


@pytest.mark.skipif(not Path("/proc/self").exists(), reason="needs Linux's /proc")
def test_an_out_folder_on_a_file_system_that_refuses_files_is_bad_input(capsys):
    """``/proc`` refuses new files even to root, for whom an access check passes: exit 2 with
    the folder named, before any computation (it was status 3, a PermissionError, or a
    message naming an internal staging folder)."""
    from gc_ocp.cli import main

    assert main(["fit", "--out", "/proc/gc_ocp_out"]) == 2
    err = capsys.readouterr().err
    assert "--out /proc/gc_ocp_out: cannot write in /proc" in err and "Traceback" not in err
    assert ".gc_ocp_out." not in err and "solving" not in err


def test_a_folder_holding_another_command_s_outputs_is_refused(tmp_path, capsys):
    """A fit's folder given to ``diagnose`` (both write report.html; a diagnosis beside another
    trial's fit.json would read as one study): exit 2 before any computation, naming the
    command whose outputs are there. The command that wrote them may write there again."""
    from gc_ocp.cli import main
    from gc_ocp.outputs import OWNER, OutputSet, check_writable

    out = tmp_path / "study"
    fit = OutputSet(out, ("fit.json", "report.html"), "gc-ocp fit")
    fit.text("fit.json", "{}")
    fit.commit()
    assert (out / OWNER).read_text().strip() == "gc-ocp fit"
    assert check_writable(out, command="gc-ocp fit") == out
    assert main(["diagnose", "--effects", "damping", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "holds the outputs of `gc-ocp fit`" in err and "Traceback" not in err
    # the commands that write file by file too (they overwrote the fit's landmarks.json)
    for argv in (["kinematics"], ["reproduce-seed", "--seeds", "1"]):
        assert main([*argv, "--out", str(out)]) == 2
        assert "holds the outputs of `gc-ocp fit`" in capsys.readouterr().err
    # an existing file as casadi's folder (it was status 3, FileExistsError)
    blocker = tmp_path / "notes.txt"
    blocker.write_text("x")
    assert main(["export", "casadi", str(out / "fit.json"), "--out", str(blocker)]) == 2
    assert "not a folder" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == sorted([OWNER, "fit.json"])


def test_version(capsys):
    import pytest

    from gc_ocp import __version__
    from gc_ocp.cli import main

    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and capsys.readouterr().out.strip() == f"gc-ocp {__version__}"


HELDOUT_KEYS = [*(TABLE_KEYS[c] for c in CHANNELS), "cop_mm"]
RANKING_KEYS = {
    "effect",
    "heldout_rms_reduction_pct",
    "heldout_rms_reduction_ci",
    "insample_rms_reduction_pct",
    "n_params",
    "confounded_with",
}


def test_diagnose_cli_writes_json_report_and_figures(tmp_path, capsys):
    out = tmp_path / "diagnosis"
    argv = ["diagnose", "--effects", "damping", "--null-draws", "4", "--workers", "2"]
    # with the mismatch family's opt-in plate member: recorded in diagnosis.json and the report
    assert main([*argv, "--plate-calibration", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "fitting the base" in captured.err and "round 1" in captured.err  # progress
    assert "report.html" in captured.out and "ranking" in captured.out

    d = strict_json((out / "diagnosis.json").read_text())
    assert d["base"]["model"] == ["contact", "sole", "pose", "belt"]
    assert d["base"]["heldout_rms"]
    for side, chans in d["base"]["heldout_rms"].items():
        assert side in ("left", "right") and list(chans) == HELDOUT_KEYS
    [r] = d["ranking"]
    assert r["effect"] == "damping" and RANKING_KEYS <= set(r)
    lo, hi = r["heldout_rms_reduction_ci"]
    assert lo <= r["heldout_rms_reduction_pct"] <= hi and r["n_params"] >= 1
    assert isinstance(d["selected"], list) and set(d["selected"]) <= {"damping"}
    assert [w["model"] for w in d["waterfall"]][0] == "base"
    for w in d["waterfall"]:
        assert w["heldout_superior_force_pct_bw"] > 0
        assert all(list(c) == HELDOUT_KEYS for c in w["heldout_rms"].values())
    assert {"base", "final"} <= set(d["where"]) and d["folds"]["n"] >= 1 and d["seconds"] > 0
    cal = d["calibration"][0]  # --null-draws reached the null: its draws, kept or left out
    assert cal["mismatch_draws"] + cal["mismatch_draws_left_out"] == 4
    from gc_ocp.diagnosis.null import DEFAULT_FAMILY

    assert d["mismatch_family"] == DEFAULT_FAMILY.with_plate_calibration().to_json()
    prov = d["provenance"]
    assert prov["command"] == "gc-ocp diagnose" and prov["options"]["effects"] == "damping"
    assert len(prov["trials"][0]["files"][0]["sha256"]) == 64

    names = {p.name for p in out.iterdir()}
    figures = {"where_heatmap.png", "where_residuals.png", "ranking.png", "waterfall.png"}
    assert {"diagnosis.json", "final_fit.json", "report.html"} | figures <= names
    from gc_ocp.estimation.result import EstimationResult

    final = EstimationResult.from_json(out / "final_fit.json")
    assert set(final.components) >= {"contact", "sole", "pose", *d["selected"]}
    assert all((out / f).stat().st_size > 10_000 for f in figures)
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "<b>damping</b>" in page and "http" not in page.split("<body>")[1].split("sha256")[0]
    assert "every stance also recorded by a plate 2-5 mm off with its channels within" in page
    assert not list(tmp_path.glob(".diagnosis.*"))  # no staging folder left


def test_the_command_line_s_pose_width_is_the_diagnosis_s_default():
    """``--pose-width`` of ``diagnose`` and ``benchmark-diagnosis`` defaults to the library's
    :data:`~gc_ocp.diagnosis.diagnose.POSE_WIDTH` (the parser does not import the diagnosis, so
    its default is written out; this keeps the two one)."""
    from gc_ocp.cli import build_parser
    from gc_ocp.diagnosis.diagnose import POSE_WIDTH

    parser = build_parser()
    for cmd in (["diagnose", "--out", "x"], ["benchmark-diagnosis", "--out", "x"]):
        assert parser.parse_args(cmd).pose_width == POSE_WIDTH


def test_the_plate_member_s_help_gives_its_sizes():
    """The ``--plate-calibration`` help of ``diagnose`` and ``benchmark-diagnosis`` states the
    member's sizes (the parser does not import the diagnosis, so they are written out; this
    keeps them :data:`~gc_ocp.diagnosis.mismatch.PLATE_OFFSET` and ``PLATE_GAIN``)."""
    from gc_ocp.cli import build_parser
    from gc_ocp.diagnosis.mismatch import PLATE_GAIN, PLATE_OFFSET

    lo, hi = (1e3 * v for v in PLATE_OFFSET)
    sizes = f"{lo:g}-{hi:g} mm off", f"+-{100 * PLATE_GAIN:g} %"
    parser = build_parser()
    subs = next(a for a in parser._actions if a.choices and "diagnose" in a.choices).choices
    for cmd in ("diagnose", "benchmark-diagnosis"):
        [plate] = [a for a in subs[cmd]._actions if "--plate-calibration" in a.option_strings]
        text = plate.help % {}  # argparse's %% as printed
        assert all(s in text for s in sizes), (cmd, text)


def test_plates_in_the_truth_without_its_family_exit_2_before_any_work(tmp_path, capsys):
    """``benchmark-diagnosis --plate-calibration truth`` puts the member in the truth's
    mismatch family, which only ``--mismatch`` gives: refused with the fix, nothing written."""
    out = tmp_path / "bench"
    argv = ["benchmark-diagnosis", "--plate-calibration", "truth", "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "give --mismatch too" in err and "Traceback" not in err and not out.exists()


@pytest.mark.parametrize("seeds", ["0", "-2"])
def test_a_benchmark_without_noise_draws_exits_2_before_any_work(tmp_path, capsys, seeds):
    """``--seeds 0`` plans no case: it was status 3 (numpy's AxisError in the confusion
    figure) with the output folder left behind."""
    out = tmp_path / "bench"
    assert main(["benchmark-diagnosis", "--seeds", seeds, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"--seeds must be 1 or more, but got {seeds}" in err and "Traceback" not in err, err
    assert not out.exists()


def test_plates_in_a_null_without_draws_exit_2_before_any_work(tmp_path, capsys):
    """``diagnose --plate-calibration --null-draws 0``: a noise-only null draws no plate errors,
    so the flag would be void (and the note on claims plate errors mimic withheld): refused
    with the fix, nothing written."""
    out = tmp_path / "diag"
    argv = ["diagnose", "--plate-calibration", "--null-draws", "0", "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--null-draws 0 makes none" in err and "Traceback" not in err and not out.exists()


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--effects", "damping,wobble"], "unknown effect(s) wobble; choose from damping"),
        (["--base", "full", "--effects", "damping,stiffness_exponent"], "already in the base"),
    ],
)
def test_diagnose_bad_effects_exit_2_before_any_work(tmp_path, capsys, argv, needle):
    out = tmp_path / "diagnosis"
    assert main(["diagnose", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err and "Traceback" not in err, err
    assert "choose" in err and "solving" not in err and not out.exists()


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["fit", "--bias-correction", "-1"], "bias_correction=-1: give the number"),
        (["fit", "--bias-correction", "1"], "bias_correction=1: give the number"),
        (["fit", "--fixed-pose-width", "--pose-correlation"], "keep pose_scale=True"),
        (["diagnose", "--null-draws", "-3"], "--null-draws must be 0 or more"),
        (["diagnose", "--workers", "0"], "--workers must be 1 or more"),
        # an empty label is part of every label: it went through to the fit, which refused it
        # after the kinematics as matching every stance
        (["fit", "--holdout", ""], "(--holdout) is blank: it names no stance"),
    ],
)
def test_bad_numbers_and_option_clashes_exit_2_before_the_kinematics(
    monkeypatch, capsys, tmp_path, argv, needle
):
    """These were refused only after every trial's inverse kinematics (seconds to minutes a
    trial): the values are known from the command line."""
    import gc_ocp.cli.common as common

    def no_kinematics(*_):
        raise AssertionError("the kinematics were computed before the options were checked")

    monkeypatch.setattr(common, "_kinematics", no_kinematics)
    assert main([*argv, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err, err
    assert not (tmp_path / "o").exists()


def test_trc_is_paired_with_the_only_mot_in_its_folder(capsys):
    """The Rajagopal folder holds one .mot (grf_walk.mot, not named after the TRC) and a static
    TRC; the Gait2392 folder's .mot is named after its TRC. Several trials, one command."""
    from conftest import G23, RAJ

    if not RAJ.is_dir():
        pytest.skip(f"real datasets not found at {RAJ}")
    argv = ["info", str(RAJ / "motion_capture_walk.trc"), str(G23 / "subject01_walk1.trc")]
    assert main([*argv, "--mass", "80"]) == 0
    err = capsys.readouterr().err
    assert f"+ ground reactions {RAJ / 'grf_walk.mot'} (the only .mot/.sto file" in err
    assert f"{G23 / 'subject01_walk1_grf.mot'} (its name starts with" in err


def test_pairing_rules(tmp_path):
    from gc_ocp.errors import InputError
    from gc_ocp.io.pairing import pair_trials

    for name in ("walk1.trc", "walk10.trc", "walk1_grf.mot", "walk10_grf.sto", "static.trc"):
        (tmp_path / name).write_text("")
    w1, w10 = tmp_path / "walk1.trc", tmp_path / "walk10.trc"
    got = pair_trials([w1, w10])
    assert [f.grf.name for f in got] == ["walk1_grf.mot", "walk10_grf.sto"]
    given = pair_trials([w10, tmp_path / "a.c3d", w1], ["x.mot", "y.mot"])  # TRC order
    assert [f.grf and f.grf.name for f in given] == ["x.mot", None, "y.mot"]
    with pytest.raises(InputError, match=r"2 TRC trial\(s\).*one --grf per TRC trial"):
        pair_trials([w1, w10], ["x.mot"])
    with pytest.raises(InputError, match="cannot tell which ground-reaction file"):
        pair_trials([tmp_path / "static.trc"])
    with pytest.raises(InputError, match="given twice"):
        pair_trials([w1, tmp_path / "." / "walk1.trc"])
    (tmp_path / "only").mkdir()
    (tmp_path / "only" / "a.trc").write_text("")
    (tmp_path / "only" / "b.trc").write_text("")
    (tmp_path / "only" / "grf.mot").write_text("")
    assert pair_trials([tmp_path / "only" / "a.trc"])[0].grf.name == "grf.mot"
    with pytest.raises(InputError, match="would both take the ground reactions"):
        pair_trials([tmp_path / "only" / "a.trc", tmp_path / "only" / "b.trc"])


def test_fit_with_a_bias_correction_reports_what_it_removed(tmp_path, capsys):
    """``fit --bias-correction 2`` on the bundled trial: fit.json has the correction (its
    replicates, the parameters as fitted, the bias), the reported parameters are the fitted
    ones minus the bias, and the summary says so (the correction's validity over many draws is
    ``benchmarks/coverage.py --bias-correction``'s)."""
    out = tmp_path / "fit"
    assert main(["fit", "--bias-correction", "2", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    d = strict_json((out / "fit.json").read_text())
    b = d["bias_correction"]
    assert b["replicates"] + b["failed"] == 2 and b["replicates"] >= 2
    shared = d["blocks"]["contact"]["shared"]
    for p in ("n", "c", "mu"):
        # a parameter the fit put at its bound (this trial's n at 1) is not corrected: its
        # replicates can move only one way
        moved = 0.0 if p in b["at_bound"] else b["bias"][p]
        assert shared[p] == pytest.approx(b["as_fitted"][p] - moved, abs=1e-9)
        assert b["bias_se"][p] >= 0
    assert all(shared[p] == b["as_fitted"][p] for p in b["at_bound"])
    assert d["provenance"]["options"]["bias_correction"] == 2
    assert "bias correction (2 replicates" in printed
    page = (out / "report.html").read_text()
    assert "replicates of the fit): bias correction (2 replicates" in page, page[:3000]
    # this trial's pose widths stop at soft tissue's limit (a misfit): no drift is drawn, and
    # the correction says so
    assert b["drift"] is False and "drew the markers&#39; noise only" in page


def test_fit_sensitivity_refits_with_the_fit_s_own_options(tmp_path, capsys, monkeypatch):
    """``--sensitivity`` refits as the fit was made: its cutoff is the reference and its
    options (here a fixed pose width and a held-out stance) are every refit's; they were
    dropped (the refits estimated the width the user fixed, around a 6 Hz cutoff)."""
    import importlib

    from gc_ocp.workflow.sensitivity import SensitivityReport

    # (the package's attribute of that name is the function)
    sensitivity_module = importlib.import_module("gc_ocp.workflow.sensitivity")
    got = {}

    def recorded(trials, **kw):
        got.update(kw)
        return SensitivityReport(["8 Hz, 30 ms"], {"n": [1.0]}, {"n": 0.1}, "8 Hz, 30 ms")

    monkeypatch.setattr(sensitivity_module, "sensitivity", recorded)
    argv = ["fit", "--sensitivity", "--cutoff", "8", "--fixed-pose-width", "--holdout", "auto"]
    assert main([*argv, "--out", str(tmp_path / "fit")]) == 0
    assert got["reference_cutoff"] == 8.0
    options = got["fit_options"]
    assert options["holdout"] == "auto" and options["pose_scale"] is False
    assert options["sole_scale"] is None and options["pose_correlation"] is False
    assert (tmp_path / "fit" / "sensitivity.json").exists()


def test_every_option_with_a_default_states_it_in_its_help():
    """``--help`` of every command says the default of each option that has one (a value the
    user gets without asking), so that no default is found only by reading the code."""
    import argparse

    from gc_ocp.cli import build_parser

    [sub] = [a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)]
    silent = [
        f"{name} {a.option_strings[0]} (default {a.default!r})"
        for name, p in sub.choices.items()
        for a in p._actions
        if a.option_strings
        and a.default not in (None, False, argparse.SUPPRESS)
        and "default" not in (a.help or "").lower()
    ]
    assert not silent, silent


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_an_interrupted_fit_says_so_in_one_line_and_leaves_nothing(tmp_path, sig):
    """Ctrl-C printed a traceback of some 30 lines; SIGTERM killed the process where it stood
    and left the outputs' staging folder (``.fit.*``) beside ``--out`` for good. Both now stop
    with one line, exit status 130 / 143, and nothing written. The signal is sent when the
    inverse kinematics has started (its first progress line), seconds before the fit could
    write anything."""
    import os
    import signal
    import subprocess
    import sys

    out = tmp_path / "fit"
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    p = subprocess.Popen(
        [sys.executable, "-m", "gc_ocp.cli", "fit", "--out", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        # Ctrl-C's default, as in a terminal: a test run in the background (a CI's) ignores
        # SIGINT, and a child inherits that, Python then keeping it ignored
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    err = []
    for line in p.stderr:
        err.append(line)
        if line.startswith("IK frame"):
            p.send_signal(getattr(signal, sig))
            break
    err += p.stderr.readlines()
    status = p.wait(timeout=120)
    text = "".join(err)
    assert status == {"SIGINT": 130, "SIGTERM": 143}[sig], text
    assert "Traceback" not in text
    assert err[-1].startswith("gc-ocp fit: " + ("interrupted" if sig == "SIGINT" else "terminated"))
    assert not out.exists() and not list(tmp_path.glob(".fit.*"))


def test_kinematics_interrupted_while_drawing_its_figure_leaves_no_partial_set(
    tmp_path, monkeypatch, capsys
):
    """``gc-ocp kinematics`` wrote its files one by one into --out: Ctrl-C while the figure was
    drawn left sole_points.csv alone (no summary, figure or owner file), or beside an earlier
    run's figure. Its files are now staged and moved in together."""
    import gc_ocp.kinematics.export as export

    def interrupted(*a, **kw):
        raise KeyboardInterrupt

    out = tmp_path / "kin"
    monkeypatch.setattr(export, "plot_kinematics", interrupted)
    assert main(["kinematics", "--out", str(out)]) == 130
    assert "interrupted" in capsys.readouterr().err
    assert not out.exists() or not any(out.iterdir())
    assert not list(tmp_path.glob(".kin.*"))


def test_kinematics_of_trials_one_cannot_pose_writes_no_trial(tmp_path, capsys):
    """Two trials, the second without the marker set's foot markers: the first trial's folder
    was written before the second failed, a part of the run looking like its result."""
    from conftest import RAJ

    if not RAJ.is_dir():
        pytest.skip(f"real datasets not found at {RAJ}")
    bundled = Path(__file__).resolve().parents[1] / "gc_ocp" / "data" / "test_small.c3d"
    out = tmp_path / "kin"
    argv = ["kinematics", str(bundled), str(RAJ / "motion_capture_walk.trc"), "--mass", "70"]
    assert main([*argv, "--markerset", "plugingait", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert 'Foot marker "LANK" of marker set "plugingait"' in err and "Traceback" not in err, err
    assert not out.exists() and not list(tmp_path.glob(".kin*"))


def test_a_killed_run_s_staging_folder_is_removed_by_the_next(tmp_path):
    """A run killed outright (SIGKILL) cannot remove its staging folder ``.OUT.*`` beside
    ``--out`` (an interruption review found them left for good). The next run of any command
    into that folder removes the staging folders of this host's dead processes; a live
    process's (a run going on now) and one without an owner record stay."""
    import os
    import subprocess
    import sys

    from gc_ocp.outputs import STAGE_OWNER, OutputSet

    out = tmp_path / "fit"
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        check=True,
        capture_output=True,
        text=True,
    )
    stages = {}
    for name, pid in (("dead", int(dead.stdout)), ("live", os.getpid()), ("unowned", None)):
        stages[name] = tmp_path / f".fit.{name}"
        stages[name].mkdir()
        if pid is not None:
            import socket

            (stages[name] / STAGE_OWNER).write_text(f"{socket.gethostname()} {pid}\n")
    files = OutputSet(out, ("fit.json",), "gc-ocp fit")
    try:
        assert not stages["dead"].exists()
        assert stages["live"].exists() and stages["unowned"].exists()
        assert files.stage.exists() and (files.stage / STAGE_OWNER).exists()
        files.text("fit.json", "{}")
        assert [p.name for p in files.commit()] == ["fit.json"]
    finally:
        files.discard()
    assert sorted(p.name for p in out.iterdir()) == [".gc_ocp_outputs", "fit.json"]


def test_ctrl_c_in_a_parallel_diagnosis_prints_no_worker_traceback(tmp_path):
    """Ctrl-C reaches every process of the terminal's group: the command stopped with one line,
    but each worker of its local Dask cluster printed a traceback of its own (four, ~100 lines,
    in an interruption review). The workers now ignore SIGINT (``gc_ocp.signals``, a
    Dask worker preload): the command closes them. The signal goes to the whole group when the
    first candidate's evaluation is reported, i.e. while the workers run the others; the tasks
    still running are cancelled when the cluster closes, and Dask's log of that (a line per
    cancelled task; under load, a busy worker's heartbeat traceback and its nanny's "killing")
    is not shown either."""
    import os
    import signal
    import subprocess
    import sys

    from gc_ocp.signals import CLOSE_NOISE

    out = tmp_path / "diag"
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    p = subprocess.Popen(
        [sys.executable, "-m", "gc_ocp.cli", "diagnose", "--workers", "2", "--out", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,  # its own group, as a terminal's job
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),  # as in a terminal
    )
    err = []
    for line in p.stderr:
        err.append(line)
        if "base+" in line and "held-out score" in line:  # a candidate's, on a worker
            os.killpg(p.pid, signal.SIGINT)
            break
    err += p.stderr.readlines()
    status = p.wait(timeout=300)
    text = "".join(err)
    assert status == 130, text
    assert "Traceback" not in text and "KeyboardInterrupt" not in text, text
    assert not any(m in text for m in CLOSE_NOISE), text  # what the closing made Dask log
    assert err[-1].startswith("gc-ocp diagnose: interrupted")
    assert not out.exists()


def test_an_interrupt_during_the_move_of_a_set_waits_for_its_end(tmp_path, monkeypatch):
    """An output set is moved in file by file; Ctrl-C between two moves left the folder half
    this run's, half the last one's (an interruption review, by reading). The interrupt now
    waits for the set's end and then acts: every file is the new run's, and KeyboardInterrupt
    follows. The signal is sent to this process between the first and the second move."""
    import os
    import signal

    from gc_ocp import outputs

    out = tmp_path / "fit"
    old = outputs.OutputSet(out, ("a.txt", "b.txt"), "gc-ocp fit")
    old.text("a.txt", "old")
    old.text("b.txt", "old")
    old.commit()
    real = os.replace
    sent = []

    moved = []

    def replace(src, dst):
        if Path(dst).parent == out:
            moved.append(dst)
            if len(moved) == 2:  # Ctrl-C now, the first file moved, the second not yet
                sent.append(signal.SIGINT)
                os.kill(os.getpid(), signal.SIGINT)
        return real(src, dst)

    monkeypatch.setattr(outputs.os, "replace", replace)
    # Python's own Ctrl-C handler, as in a terminal (a pytest-xdist worker ignores SIGINT)
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        new = outputs.OutputSet(out, ("a.txt", "b.txt"), "gc-ocp fit")
        new.text("a.txt", "new")
        new.text("b.txt", "new")
        with pytest.raises(KeyboardInterrupt):
            new.commit()
    finally:
        signal.signal(signal.SIGINT, before)
    assert sent and [(out / n).read_text() for n in ("a.txt", "b.txt")] == ["new", "new"]
    assert signal.getsignal(signal.SIGINT) is before  # the handlers are the caller's again


def test_what_a_closing_cluster_logs_is_dropped_and_nothing_else():
    """``signals.CloseNoise`` drops exactly the records Dask writes because the package's local
    cluster closes under busy workers (a cancelled task, a worker's failed heartbeat with its
    traceback, a nanny killing a worker busy in a solve: each seen in an interruption or a CI
    run under load) and keeps every other record of those loggers."""
    import logging

    from gc_ocp.signals import CLOSE_NOISE, CloseNoise, quiet_close

    def record(msg, *args):
        return logging.LogRecord("distributed.worker", logging.ERROR, __file__, 1, msg, args, None)

    f = CloseNoise()
    seen = [
        "Async instruction for <Task cancelled name='execute(x)'> ended with CancelledError",
        "Failed to communicate with scheduler during heartbeat.",
    ]
    assert not any(f.filter(record(m)) for m in seen)
    assert not f.filter(record("Worker process still alive after %.1f seconds, killing", 4.0))
    assert len(CLOSE_NOISE) == 3
    kept = ["Worker exceeded 95% memory budget. Restarting...", "Compute Failed"]
    assert all(f.filter(record(m)) for m in kept)
    quiet_close("gc_ocp_test_logger")
    quiet_close("gc_ocp_test_logger")  # once
    log = logging.getLogger("gc_ocp_test_logger")
    assert sum(isinstance(x, CloseNoise) for x in log.filters) == 1


def _damaged_trc(tmp_path, edit) -> Path:
    """The Rajagopal TRC with ``edit(lines)`` applied (the list of its lines, changed in place)."""
    from conftest import RAJ

    if not RAJ.is_dir():
        pytest.skip(f"real datasets not found at {RAJ}")
    lines = (RAJ / "motion_capture_walk.trc").read_text().splitlines()
    edit(lines)
    trc = tmp_path / "damaged.trc"
    trc.write_text("\n".join(lines) + "\n")
    return trc


def test_a_trc_without_marker_names_exits_2_naming_its_line(tmp_path, capsys):
    """Line 4 of a TRC names the markers: without names it was status 3 (a ValueError of
    numpy's reshape, cannot reshape array of size 0)."""
    from conftest import RAJ

    def edit(lines):
        lines[3] = "Frame#\tTime"

    trc = _damaged_trc(tmp_path, edit)
    assert main(["info", str(trc), "--grf", str(RAJ / "grf_walk.mot"), "--mass", "85.07"]) == 2
    err = capsys.readouterr().err
    assert "damaged.trc, line 4: no marker names" in err and "Traceback" not in err, err


@pytest.mark.parametrize("which", ["trc", "mot"])
def test_a_time_column_that_goes_back_exits_2_naming_the_row(tmp_path, capsys, which):
    """Rows out of order (two exports joined, a row pasted at the wrong place): the times step
    back. It was accepted, the frames then taken in file order as if their times increased."""
    from conftest import RAJ

    def back(lines, first, col, sep):
        cells = lines[first + 20].split(sep)  # the 21st data row gets the time of the 5th
        cells[col] = lines[first + 4].split(sep)[col]
        lines[first + 20] = sep.join(cells)

    trc, mot = RAJ / "motion_capture_walk.trc", RAJ / "grf_walk.mot"
    if which == "trc":
        # lines 1-5 the header, line 6 blank (as OpenSim writes it), the data from line 7
        trc = _damaged_trc(tmp_path, lambda lines: back(lines, 6, 1, "\t"))
    else:
        if not RAJ.is_dir():
            pytest.skip(f"real datasets not found at {RAJ}")
        lines = mot.read_text().splitlines()
        end = next(i for i, ln in enumerate(lines) if ln.strip().lower() == "endheader")
        col = [c.strip().lower() for c in lines[end + 1].split("\t")].index("time")
        back(lines, end + 2, col, "\t")
        mot = tmp_path / "damaged.mot"
        mot.write_text("\n".join(lines) + "\n")
    assert main(["info", str(trc), "--grf", str(mot), "--mass", "85.07"]) == 2
    err = capsys.readouterr().err
    assert f"damaged.{which}: the time goes back at data row 21" in err, err
    assert "Traceback" not in err


def test_a_belt_speed_the_stance_feet_contradict_exits_2(capsys):
    """The Gait2392 trial's stance feet move backward at 1.06 m/s: 4 (its speed in km/h, 1.1
    m/s) is beyond what the fit's belt correction can reach (BeltSpeed.bound, 0.5 m/s), so the
    friction would slide against a belt the feet do not follow. It was described and fitted."""
    from conftest import G23

    if not G23.is_dir():
        pytest.skip(f"real datasets not found at {G23}")
    argv = ["info", str(G23 / "subject01_walk1.trc"), "--mass", "72.6"]
    assert main([*argv, "--belt-speed", "4"]) == 2
    err = capsys.readouterr().err
    assert "a belt speed of 4.000 m/s was given but the stance feet move backward at 1.0" in err
    assert "4 km/h = 1.111 m/s" in err and "Traceback" not in err, err
    assert main([*argv, "--belt-speed", "1.2"]) == 0  # within the correction's reach


@pytest.mark.parametrize("target", ["casadi", "opensim"])
@pytest.mark.parametrize("text", ["[1, 2]", '"fit"', "3"])
def test_export_of_json_that_is_not_an_object_exits_2(tmp_path, capsys, target, text):
    """A fit.json is a JSON object: another JSON value was status 3 (AttributeError: 'list'
    object has no attribute 'to_json')."""
    fit = tmp_path / "fit.json"
    fit.write_text(text)
    out = tmp_path / "export"
    assert main(["export", target, str(fit), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{fit} is not a gc-ocp fit.json" in err and "JSON object" in err, err
    assert "Traceback" not in err and not out.exists()


def test_an_export_into_a_folder_named_like_a_casadi_file_writes_in_the_folder(
    tmp_path, monkeypatch
):
    """``--out`` names a .casadi file or a folder: an existing folder named ``x.casadi`` was
    taken for the file (status 3, IsADirectoryError on the move). What is written is not the
    point here (test_export's): the law is a stand-in, so that no fit is needed."""
    import casadi as ca

    import gc_ocp.export.casadi_export as casadi_export

    x = ca.SX.sym("x")
    monkeypatch.setattr(
        casadi_export, "casadi_function", lambda doc, trial: ca.Function("f", [x], [x])
    )
    fitted = tmp_path / "fit.json"
    # (the keys every reader of a fit.json checks first: check_fit_document)
    stand_in = {"components": {}, "blocks": {}, "stance_fits": [{"trial": "walk"}]}
    fitted.write_text(json.dumps(stand_in))
    out = tmp_path / "models.casadi"
    out.mkdir()
    assert main(["export", "casadi", str(fitted), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [".gc_ocp_outputs", "contact.casadi"]
    assert not list(tmp_path.glob(".models.casadi.*"))  # no staging file left beside it


def test_a_batch_with_an_unusable_scheduler_or_no_workers_exits_2(tmp_path, capsys):
    """``--scheduler nonsense`` was status 3 (distributed's ValueError, missing port number);
    ``--workers 0`` was refused after the study's folder was made and claimed (left behind)."""
    bundled = Path(__file__).resolve().parents[1] / "gc_ocp" / "data" / "test_small.c3d"
    manifest = tmp_path / "study.csv"
    manifest.write_text(f"subject,trial\nP01,{bundled}\n")
    out = tmp_path / "results"
    assert main(["batch", str(manifest), "--out", str(out), "--workers", "0"]) == 2
    assert "workers must be 1 or more, but got 0" in capsys.readouterr().err
    assert not out.exists()
    assert main(["batch", str(manifest), "--out", str(out), "--scheduler", "nonsense"]) == 2
    err = capsys.readouterr().err
    assert "--scheduler nonsense: cannot connect" in err and "tcp://" in err, err
    assert "Traceback" not in err and "internal error" not in err


def test_a_batch_whose_scheduler_does_not_answer_leaves_no_claimed_folder(tmp_path, capsys):
    """``--scheduler tcp://127.0.0.1:PORT`` with nothing listening was refused (status 2) after
    Dask's connect timeout, but only once the study's folder had been made and claimed (its
    lock and owner files, no summary). The connection is now made before the folder is. Dask's
    connect timeout is cut to 2 s here (30 s by default): a refused port fails the same way,
    only sooner."""
    import socket

    import dask

    bundled = Path(__file__).resolve().parents[1] / "gc_ocp" / "data" / "test_small.c3d"
    manifest = tmp_path / "study.csv"
    manifest.write_text(f"subject,trial\nP01,{bundled}\n")
    with socket.socket() as s:  # a port nothing listens on (bound, then released)
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    scheduler = f"tcp://127.0.0.1:{port}"
    new, empty = tmp_path / "results", tmp_path / "empty"
    empty.mkdir()
    with dask.config.set({"distributed.comm.timeouts.connect": "2s"}):
        for out in (new, empty):
            argv = ["batch", str(manifest), "--out", str(out), "--scheduler", scheduler]
            assert main(argv) == 2
            err = capsys.readouterr().err
            assert f"--scheduler {scheduler}: cannot connect" in err, err
    assert not new.exists()
    assert not any(empty.iterdir())


def test_a_file_given_as_markerset_that_is_not_toml_is_named_as_such(tmp_path, capsys):
    """An existing file that is not a .toml marker set (a trial given to --markerset by
    mistake) was said "not found"."""
    trc = tmp_path / "static.trc"
    trc.write_text("PathFileType\t4\n")
    out = tmp_path / "kin"
    assert main(["kinematics", "--markerset", str(trc), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f'Marker set "{trc}" is a .trc file, not a marker set' in err, err
    assert "not found" not in err and not out.exists()


def test_python_m_gc_ocp_is_the_command():
    """``python -m gc_ocp`` (the usual way to run a package's command) was "No module named
    gc_ocp.__main__"."""
    import subprocess
    import sys

    from gc_ocp import __version__

    run = subprocess.run(
        [sys.executable, "-m", "gc_ocp", "--version"], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0 and run.stdout.strip() == f"gc-ocp {__version__}", run.stderr
