"""The diagnosis report: one self-contained HTML page."""

from __future__ import annotations

import dataclasses
import json
import re
import warnings
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from gc_ocp.diagnosis.result import RankRow


@pytest.fixture(scope="module")
def diagnosis(bundled_stances):
    """A cheap diagnosis of the bundled trial: the registered base and one candidate."""
    from gc_ocp.diagnosis import diagnose_stances

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # LLS start / height notes are tested elsewhere
        return diagnose_stances(
            list(bundled_stances), candidates=["damping"], n_boot=200, mismatch_draws=4
        )


@pytest.fixture(scope="module")
def page(diagnosis):
    from gc_ocp.diagnosis.report import report_html

    return report_html(diagnosis)


def test_report_is_self_contained(page):
    assert page.startswith("<!DOCTYPE html>") and page.rstrip().endswith("</html>")
    refs = re.findall(r'(?:src|href)\s*=\s*["\']?([^"\'\s>]+)', page, flags=re.I)
    assert refs  # the figures
    for ref in refs:
        assert not re.match(r"(https?:)?//", ref, flags=re.I), ref
        assert ref.startswith("data:"), ref  # nothing outside the file, not even a local path
    imgs = re.findall(r"<img\b[^>]*>", page, flags=re.I)
    assert len(imgs) >= 4  # heat map, residual over time, ranking, waterfall
    for img in imgs:
        assert re.search(r'src="data:image/png;base64,[A-Za-z0-9+/=]{1000,}"', img), img[:80]
    assert not re.search(r"<(script|link|iframe|object|embed)\b", page, flags=re.I)
    assert not re.search(r"url\(|@import", page, flags=re.I)  # no CSS fetch either


def test_report_names_every_ranked_effect_and_its_numbers(diagnosis, page):
    for r in diagnosis.ranking:
        assert f"<b>{r.effect}</b>" in page
        assert f"{r.heldout_rms_reduction_pct:+.1f}" in page
        lo, hi = r.heldout_rms_reduction_ci
        assert f"[{lo:+.1f}, {hi:+.1f}]" in page
        assert f"{r.insample_rms_reduction_pct:+.1f}" in page
    for heading in (
        "Where the gap is",
        "Which effect explains it",
        "How far the gap shrinks",
        "The final model",
        "Decision rule",
        "Notes and flags",
        "Provenance",
    ):
        assert heading in page, heading
    assert "Contact units" in page and "Shared parameters" in page and " ± " in page


def test_report_says_when_effects_are_confounded(diagnosis):
    """Two effects flagged as confounded are named as ambiguous in plain words."""
    from gc_ocp.diagnosis.report import confounded_groups, report_html

    r = diagnosis.ranking[0]
    twin = dataclasses.replace(r, effect="ground_offset", confounded_with=(r.effect,))
    ranking = [dataclasses.replace(r, confounded_with=("ground_offset",)), twin]
    assert confounded_groups(ranking) == [[r.effect, "ground_offset"]]
    d = dataclasses.replace(diagnosis, ranking=ranking, rounds=[ranking])
    page = report_html(d, provenance=_provenance())
    assert (
        f"<b>{r.effect}</b> and <b>ground_offset</b> explain the same part of the gap: the "
        "data cannot tell them apart." in page
    )
    assert "sha256 0123456789abcdef" in page and "gc-ocp diagnose" in page

    alone = [
        dataclasses.replace(r, confounded_with=("kinematic_correction",), gain_from_nuisance=0.8)
    ]
    assert confounded_groups(alone) == []  # a part of the base is not a candidate
    page = report_html(dataclasses.replace(diagnosis, ranking=alone, rounds=[alone]))
    assert (
        f"<b>{r.effect}</b> and the base's <b>kinematic_correction</b> (the per-stance "
        "correction the base already has) explain the same part of the gap" in page
    )
    assert "80 % of its held-out gain" in page


def test_write_report_is_atomic(diagnosis, tmp_path):
    from gc_ocp.diagnosis.report import write_report

    path = write_report(diagnosis, tmp_path / "r" / "report.html")
    assert path.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    assert [p.name for p in path.parent.iterdir()] == ["report.html"]


def _provenance() -> dict:
    return {
        "gc_ocp_version": "0.0",
        "date": "2026-01-01T00:00:00+00:00",
        "python": "3",
        "command": "gc-ocp diagnose",
        "options": {"effects": "damping"},
        "trials": [
            {
                "name": "walk",
                "files": [{"path": "/data/walk.c3d", "sha256": "0123456789abcdef" * 4}],
                "mass_kg": 70.0,
                "mass_source": "file",
                "height_m": 1.7,
                "height_source": "file",
                "stances_used": ["walk:right@0.4s"],
                "stances_excluded": [],
            }
        ],
    }


def _unnamed_row(row, test, pct, ci, insample, floor):
    """``row`` made an inconclusive candidate the rule does not name: its calibrated ``test``,
    held-out reduction ``pct`` [%] with interval ``ci``, in-sample reduction ``insample`` and
    the floor's number of further stances ``floor``; no confounding."""
    return dataclasses.replace(
        row,
        passes=False,
        inconclusive=True,
        heldout_rms_reduction_pct=pct,
        heldout_rms_reduction_ci=ci,
        insample_rms_reduction_pct=insample,
        confounded_with=(),
        calibrated=test,
        floor_stances=floor,
    )


def test_report_says_when_none_is_inconclusive(diagnosis):
    """A "none" whose candidate's one-step gain is above its null but not significant, with a
    practical number of further steps that would decide it, is called inconclusive, in the
    result, its JSON, its summary and the page, with that number; the verdict of each row says
    what the calibrated test found."""
    from gc_ocp.diagnosis.null import NullTest
    from gc_ocp.diagnosis.report import _verdict, report_html
    from gc_ocp.diagnosis.selection import floor_stances

    r = diagnosis.ranking[0]
    test = NullTest(1.2, 0.1, 0.6, 1.8, 0.12, 2.4, 24, 6)
    floor = floor_stances({"pct": 1.5, "ci": (-0.1, 3.1), "insample_pct": 6.0}, 6)
    weak = _unnamed_row(r, test, 1.5, (-0.1, 3.1), 6.0, floor)
    assert 0 < weak.floor_stances < 24  # the test's number is the rule's here
    d = dataclasses.replace(
        diagnosis, ranking=[weak], rounds=[[weak]], selected=[], waterfall=diagnosis.waterfall[:1]
    )
    assert d.inconclusive == [r.effect] and d.to_json()["inconclusive"] == [r.effect]
    said = f"{r.effect}: inconclusive (p = 0.12); about 24 more steps would decide"
    assert said in d.summary()
    page = report_html(d)
    assert "No candidate effect passes" in page and "about 24 more steps would decide" in page
    assert _verdict(weak) == "inconclusive (p = 0.12); about 24 more steps would decide"
    far = dataclasses.replace(
        weak, inconclusive=False, calibrated=dataclasses.replace(test, more_stances=400)
    )
    assert _verdict(far) == "not named (p = 0.12); about 400 more steps would decide at this gain"
    # a number beyond one session's steps is said as an order, the JSON keeps it
    huge = dataclasses.replace(far, calibrated=dataclasses.replace(test, more_stances=122781))
    assert _verdict(huge) == (
        "not named (p = 0.12); more than 1000 more steps (beyond one session) would decide at "
        "this gain"
    )
    assert huge.to_json()["calibrated"]["more_stances"] == 122781
    one = dataclasses.replace(
        far, floor_stances=0, calibrated=dataclasses.replace(test, more_stances=1)
    )
    assert "about 1 more step would decide" in _verdict(one)
    at = dataclasses.replace(far, calibrated=dataclasses.replace(test, more_stances=1000))
    assert "about 1000 more steps" in _verdict(at)
    over = dataclasses.replace(far, calibrated=dataclasses.replace(test, more_stances=1001))
    assert "more than 1000 more steps" in _verdict(over)
    # an inconclusive row's number is a practical follow-up of its own data: said as it is
    long = dataclasses.replace(
        weak,
        inconclusive=True,
        calibrated=dataclasses.replace(test, more_stances=1200, n_heldout=400),
    )
    assert _verdict(long) == "inconclusive (p = 0.12); about 1200 more steps would decide"
    # a row read back inconclusive without its number says no number (it printed "None")
    lost = dataclasses.replace(long, calibrated=dataclasses.replace(test, more_stances=None))
    assert _verdict(lost) == "inconclusive (p = 0.12)"
    # no number: within what the mismatch gives every stance (1.1 against 2.4 x 0.5), or over
    # it but too uncertain for any study to be likely to decide it
    bound = dataclasses.replace(test, more_stances=None, null_sd_mismatch_pct=0.5)
    within = dataclasses.replace(far, calibrated=bound)
    assert "within what noise and model mismatch give" in _verdict(within)
    unsure = dataclasses.replace(far, calibrated=dataclasses.replace(test, more_stances=None))
    assert "too uncertain on 6 held-out stances to say how many more steps" in _verdict(unsure)

    # the test's one-step statistic has no gain, the refit has: both figures are said
    flat = dataclasses.replace(
        within, calibrated=dataclasses.replace(within.calibrated, observed_pct=-0.1)
    )
    assert _verdict(flat) == (
        "not named (p = 0.12): no gain one step from the parent's solution (the test's "
        "statistic, -0.1 %), although the refit gains +1.5 %"
    )
    lost = dataclasses.replace(flat, heldout_rms_reduction_pct=-0.4)
    assert _verdict(lost) == "no gain (p = 0.12)"
    named = dataclasses.replace(
        weak,
        passes=True,
        inconclusive=False,
        calibrated=dataclasses.replace(test, p_adjusted=0.004, more_stances=0),
    )
    assert _verdict(named) == "named (p = 0.004)"
    assert RankRow.from_json(named.to_json()) == named
    # a candidate these stances do not move: no p-value or steps of round-off said
    inert = dataclasses.replace(
        within,
        calibrated=NullTest(1e-9, 8e-10, 1e-10, 0.0, 1.0, 2.4, None, 6, inert=True),
    )
    assert _verdict(inert).startswith("no gain: these stances do not move it")
    assert RankRow.from_json(inert.to_json()) == inert


def test_inconclusive_rows_of_a_round_that_selected_say_so(diagnosis):
    """When the selection stops on a round that selected an effect (max_effects reached), that
    round's inconclusive rows and their steps were measured before the effect was added: the
    summary and the page say so, and say nothing of it when the last round selected nothing."""
    from gc_ocp.diagnosis.null import NullTest
    from gc_ocp.diagnosis.report import report_html

    r = diagnosis.ranking[0]
    test = NullTest(1.2, 0.1, 0.6, 1.8, 0.12, 2.4, 14, 6)
    weak = dataclasses.replace(_unnamed_row(r, test, 1.5, (-0.1, 3.1), 6.0, 1), effect="friction")
    chosen = dataclasses.replace(r, passes=True, inconclusive=False)
    stopped = dataclasses.replace(
        diagnosis, ranking=[chosen, weak], rounds=[[chosen, weak]], selected=[r.effect]
    )
    assert stopped.inconclusive == ["friction"] and stopped.inconclusive_before == r.effect
    said = f"measured before {r.effect} was added"
    assert said in stopped.summary()
    assert f"Measured before <b>{r.effect}</b> was added" in report_html(stopped)
    ended = dataclasses.replace(stopped, rounds=[[chosen, weak], [weak]])
    assert ended.inconclusive_before is None and said not in ended.summary()


def test_a_row_the_floor_stops_says_whether_more_steps_would_clear_it(diagnosis):
    """The rule's number of further steps is the test's and the effect-size floor's, the
    larger (``RankRow.more_stances``): a candidate the test names whose held-out interval still
    reaches 0 gets the floor's number; one whose held-out gain is under the floor gets none
    (more steps estimate a gain better, they do not raise it), and its verdict says so."""
    from gc_ocp.diagnosis.null import NullTest
    from gc_ocp.diagnosis.report import _verdict

    named_by_test = NullTest(2.2, 0.4, 0.6, 3.0, 0.039, 2.4, 0, 8)
    row = _unnamed_row(diagnosis.ranking[0], named_by_test, 2.0, (-0.3, 4.3), 11.8, 3)
    assert row.more_stances == 3
    assert _verdict(row) == (
        "inconclusive: named by the test (p = 0.039), but its held-out interval still reaches 0;"
        " about 3 more steps would decide"
    )
    under = dataclasses.replace(row, heldout_rms_reduction_pct=0.3, floor_stances=None)
    assert under.more_stances is None
    assert _verdict(under) == (
        "inconclusive: named by the test (p = 0.039), but its held-out gain is under the rule's "
        "effect-size floor, which more steps do not raise"
    )
    # the test would decide with more steps, the floor would not: both said
    both = dataclasses.replace(under, calibrated=dataclasses.replace(named_by_test, more_stances=5))
    assert _verdict(both) == (
        "inconclusive (p = 0.039); about 5 more steps would decide the test, but its held-out "
        "gain is under the rule's effect-size floor, which more steps do not raise"
    )
    # a held-out gain above the floor, the in-sample one under it: the verdict names the
    # in-sample gain, not the held-out one (+2.0 % is not under a 0.5 % floor)
    in_sample = dataclasses.replace(
        both, heldout_rms_reduction_pct=2.0, insample_rms_reduction_pct=0.2
    )
    assert _verdict(in_sample) == (
        "inconclusive (p = 0.039); about 5 more steps would decide the test, but its in-sample "
        "gain is under the rule's effect-size floor, which more steps do not raise"
    )
    # named by the test with a held-out loss: not inconclusive (the row's flag, the summary's
    # list), and its verdict does not call it so
    loss = dataclasses.replace(
        under,
        heldout_rms_reduction_pct=-0.3,
        heldout_rms_reduction_ci=(-0.6, -0.1),
        inconclusive=False,
    )
    assert _verdict(loss) == (
        "not named: the test names it (p = 0.039), but its held-out gain is under the rule's "
        "effect-size floor, which more steps do not raise"
    )
    assert RankRow.from_json(row.to_json()) == row and RankRow.from_json(under.to_json()) == under
    # a diagnosis.json written before the floor's number: the test's number, as it was read then
    old = {k: v for k, v in both.to_json().items() if k != "floor_stances"}
    assert RankRow.from_json(old).more_stances == 5
    old = {k: v for k, v in row.to_json().items() if k != "floor_stances"}
    assert _verdict(RankRow.from_json(old)) == (
        "inconclusive: named by the test (p = 0.039), below the rule's effect-size floor"
    )


def test_report_states_the_rule_the_code_applies(diagnosis, page):
    """The page's method section gives the decision rule and the confounding criteria with the
    library's constants (a changed constant changes the page), and says when the interval
    cannot resample stances (fewer held-out stances than ``MIN_CLUSTERS``)."""
    from gc_ocp.diagnosis import compare
    from gc_ocp.diagnosis import selection as rule
    from gc_ocp.diagnosis.report import report_html

    text = page.split("How the effects were judged")[1].split("Notes and flags")[0]
    assert f"at most {diagnosis.alpha:g}" in text  # the family-wise rate
    assert f"on {diagnosis.calibration[0]['replicates']} such replicates" in text
    assert "inconclusive" in text and "only the candidates the test names are held out" in text
    assert f"cosine above {rule.CONFOUND_COSINE:g}" in text
    assert f"{100 * rule.COMPARABLE_FRACTION:.0f} % of the larger" in text
    assert f"less than {100 * rule.NON_ADDITIVE_FRACTION:.0f} % of its gain" in text
    assert f"more than {100 * rule.NUISANCE_SHARE:.0f} % of an effect" in text
    n_held = len(diagnosis.folds["heldout"])
    assert n_held < compare.MIN_CLUSTERS  # the bundled trial: two held-out stances
    assert f"fewer than {compare.MIN_CLUSTERS}) the stances themselves are not resampled" in text
    many = dataclasses.replace(
        diagnosis, folds={**diagnosis.folds, "heldout": [f"s{i}" for i in range(6)], "n": 6}
    )
    pngs = dict.fromkeys(("heatmap", "residuals", "ranking", "waterfall", "heatmap_final"), b"")
    assert "the held-out stances resampled" in report_html(many, pngs=pngs)
    # a round whose null draws stopped early says so, with the draws each round made
    assert "stop early" not in text
    cal = [
        {**c, "mismatch_draws": 8, "mismatch_draws_planned": 32, "null_stopped_early": True}
        for c in diagnosis.calibration
    ]
    stopped = dataclasses.replace(diagnosis, calibration=cal)
    page2 = report_html(stopped, pngs=pngs)
    assert "draws stop early" in page2 and "one of up to 32 draws" in page2
    assert f"draws made per round: {', '.join(['8'] * len(cal))})" in page2


def test_effect_block_values_carry_their_standard_errors():
    """A standard error (``key_se``) is shown as ``value ± SE`` beside its value, not as a
    parameter of its own; a zero SE says fixed."""
    from gc_ocp.html.fit_tables import flatten_block

    rows = dict(
        flatten_block(
            {"trial": {"ms": 10.4, "ms_se": 0.797}, "c": 1.9, "c_se": 0.13, "n": 1.0, "n_se": 0.0}
        )
    )
    assert rows == {"trial / ms": "10.4 ± 0.8", "c": "1.9 ± 0.13", "n": "1 (fixed)"}


# --- the page and the JSON against those of the f-string renderer (tests/report_fixtures) ---------
FIXTURES = Path(__file__).parent / "report_fixtures"
CASES = sorted(p.name for p in FIXTURES.iterdir() if (p / "diagnosis.json").exists())


BLOCKS = frozenset(
    "html head title body h1 h2 h3 p ul li table tr td th div figure figcaption br img".split()
)
"""Elements that start a new line of a page's visible text (as a browser lays them out)."""


class _Page(HTMLParser):
    """What a reader of a page gets: its visible text (each image by its alt text; a line break
    at every block element, whitespace within a line collapsed, as a browser shows it), its
    markup (each start tag with its attributes, image data cut) and its style sheet."""

    def __init__(self, page: str):
        super().__init__(convert_charrefs=True)
        self.chunks: list[str] = []
        self.tags: list[tuple] = []
        self.style = ""
        self._in_style = False
        self.feed(page)
        self.close()

    def handle_starttag(self, tag, attrs):
        attrs = [(k, "data:" if k == "src" else v) for k, v in attrs]
        self.tags.append((tag, tuple(sorted(attrs, key=lambda a: a[0]))))
        self._in_style = tag == "style"
        if tag in BLOCKS:
            self.chunks.append("\n")
        if tag == "img":
            self.chunks.append(f"[image: {dict(attrs).get('alt')}]\n")

    def handle_endtag(self, tag):
        self.tags.append(("/" + tag,))
        self._in_style = False
        if tag in BLOCKS:
            self.chunks.append("\n")

    def handle_data(self, data):
        if self._in_style:
            self.style += " ".join(data.split())
        else:
            self.chunks.append(data)

    @property
    def visible(self) -> str:
        """The text, line by line (empty lines dropped), whitespace collapsed in each."""
        lines = (" ".join(line.split()) for line in "".join(self.chunks).split("\n"))
        return "\n".join(line for line in lines if line)


def _fixture(case: str):
    from gc_ocp.diagnosis import Diagnosis
    from gc_ocp.estimation.result import EstimationResult

    folder = FIXTURES / case
    text = (folder / "diagnosis.json").read_text()
    js = json.loads(text)
    final = EstimationResult.from_json(folder / "final_fit.json")
    return folder, text, js, Diagnosis.from_json(js), final


@pytest.mark.parametrize("case", CASES)
def test_report_page_reads_as_before(case):
    """The page of a diagnosis read back from the CLI's ``diagnosis.json`` (+ its
    ``final_fit.json``) shows the text, numbers and markup of the page that run wrote (made by
    the f-string renderer the template replaced; images cut): the same visible text, whitespace
    normalised, and the same tags with the same attributes."""
    from gc_ocp.diagnosis.report import report_html

    folder, _, js, d, final = _fixture(case)
    pngs = dict.fromkeys(("heatmap", "residuals", "ranking", "waterfall"), b"\x89PNG")
    if d.selected:
        pngs["heatmap_final"] = b"\x89PNG"
    new = _Page(report_html(d, provenance=js["provenance"], pngs=pngs, final=final))
    old = _Page((folder / "report.html").read_text(encoding="utf-8"))
    assert len(old.visible) > 3000 and "Provenance" in old.visible
    assert new.visible == old.visible
    assert new.tags == old.tags
    assert new.style == old.style


@pytest.mark.parametrize("case", CASES)
def test_diagnosis_json_is_written_back_byte_for_byte(case):
    """``Diagnosis.from_json`` then ``to_json`` gives the CLI's ``diagnosis.json`` back, byte for
    byte (keys, their order, every value): the JSON is written from the result's fields alone."""
    from gc_ocp.diagnosis import Diagnosis

    _, text, js, d, _ = _fixture(case)
    again = json.dumps({**d.to_json(), "provenance": js["provenance"]}, indent=2)
    assert again == text
    assert Diagnosis.from_json(json.loads(again)).summary() == d.summary()


def test_a_diagnosis_json_of_a_later_format_is_refused_naming_both_versions(tmp_path):
    """diagnosis.json had no format number: a file of a later layout would be read as this
    one's. A later ``"format"`` is one error naming the file, the version that wrote it (its
    provenance's), this version and the fix; a file without the field (written before it) is
    read as today's."""
    from gc_ocp import __version__
    from gc_ocp.diagnosis import Diagnosis
    from gc_ocp.diagnosis.result import DIAGNOSIS_FORMAT
    from gc_ocp.errors import InputError

    _, _, js, d, _ = _fixture("damping_time_offset")
    assert d.to_json()["format"] == DIAGNOSIS_FORMAT
    older = {k: v for k, v in js.items() if k != "format"}
    assert Diagnosis.from_json(older).summary() == d.summary()
    later = tmp_path / "diagnosis.json"
    prov = {**js["provenance"], "gc_ocp_version": "9.0"}
    later.write_text(json.dumps({**js, "format": DIAGNOSIS_FORMAT + 1, "provenance": prov}))
    with pytest.raises(InputError) as e:
        Diagnosis.from_json(later)
    words = [
        f"{later} is a diagnosis.json of format {DIAGNOSIS_FORMAT + 1}, written by gc_ocp 9.0",
        f"this gc_ocp {__version__} reads diagnosis.json format 1 to {DIAGNOSIS_FORMAT}",
        "run gc-ocp diagnose again with this version",
    ]
    assert all(w in str(e.value) for w in words), e.value


@pytest.mark.parametrize("case", CASES)
def test_each_effect_block_is_shown_by_its_component(case):
    """Every row a component gives of its block (``Component.describe``: label, value ± SE
    with its unit) is on the page; the fixture's final model has effects of its own."""
    from gc_ocp.diagnosis.report import report_html
    from gc_ocp.html.fit_tables import pm_value

    _, _, js, d, final = _fixture(case)
    described = final.block_rows()
    assert len(set(described) - {c for c in d.base_components}) >= 2  # two effects selected
    pngs = dict.fromkeys(("heatmap", "residuals", "ranking", "waterfall", "heatmap_final"), b"")
    page = _Page(report_html(d, provenance=js["provenance"], pngs=pngs, final=final)).visible
    for rows in described.values():
        for r in rows:
            assert f"{r.label}\n{pm_value(r.value, r.se, unit=r.unit)}" in page


def test_figures_label_channels_in_words():
    """The heat map's rows and the waterfall's legend name the channels as the page's tables
    do ("right superior force", "COP"), not by their JSON keys ("superior_force", "cop_mm")."""
    _, _, _, d, _ = _fixture(CASES[0])
    fig = d.heatmap("base")
    rows = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    assert rows and not [r for r in rows if "_" in r], rows
    assert any(r.endswith(" COP") for r in rows) and any("superior force" in r for r in rows)
    fig = d.waterfall_figure()
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "anteroposterior torque" in legend and not [t for t in legend if "_" in t], legend


def test_the_summary_says_which_round_s_null_stopped_early():
    """A round whose null draws stopped early (``null_stopped_early``) is named in the summary
    with the draws it made of those planned; a diagnosis whose nulls made every draw (the
    fixture's) says nothing of it."""
    _, _, _, d, _ = _fixture(CASES[0])
    assert "null stopped" not in d.summary()
    cal = [dict(c) for c in d.calibration]
    cal[-1].update(mismatch_draws=8, mismatch_draws_planned=32, null_stopped_early=True)
    text = dataclasses.replace(d, calibration=cal).summary()
    assert f"round {len(cal)}'s null stopped after 8 of 32 mismatch draws" in text
    # draws whose refit failed are left out: said, since they may be the null's largest
    assert "left out" not in d.summary()
    cal[-1].update(mismatch_draws_left_out=2)
    text = dataclasses.replace(d, calibration=cal).summary()
    assert f"round {len(cal)}'s null left out 2 mismatch draw(s)" in text


def test_the_one_step_s_miss_of_the_parent_is_measured_and_noted(diagnosis, bundled_stances):
    """Each round records how far the test's one step puts its parent's held-out score from the
    parent's refitted folds' (here recomputed directly from the base's evaluation), and a note
    says so exactly when that exceeds the rule's effect-size floor."""
    from gc_ocp.diagnosis.compare import fold_plan
    from gc_ocp.diagnosis.diagnose import step_note, unseen_gains
    from gc_ocp.diagnosis.onestep import fold_prior_means, heldout_energy, linearize_parent
    from gc_ocp.diagnosis.selection import MIN_REDUCTION_PCT

    data = list(bundled_stances)
    base = diagnosis.evaluations["base"]
    plan = fold_plan(data)
    lp = linearize_parent(data, base.model, base.full, None)
    occam = np.array([f.occam for f in base.folds])
    e_step = heldout_energy(lp, lp.r[:, None], plan, fold_prior_means(data, base.model, plan))
    e_step = e_step[:, 0] + occam
    e_refit = np.array([f.energy for f in base.folds])
    miss = diagnosis.calibration[0]["one_step_miss"]
    # round-off of the same linear algebra on the same fits: 1e-9 relative
    assert miss["pct"] == pytest.approx(100 * (np.sqrt(e_step.sum() / e_refit.sum()) - 1), rel=1e-9)
    per = 100 * (np.sqrt(e_step / e_refit) - 1)
    assert miss["worst_stance_pct"] == pytest.approx(per[np.argmax(np.abs(per))], rel=1e-9)
    rows = diagnosis.rounds[0]
    gap = [r.effect for r in unseen_gains(rows)]
    noted = [n for n in diagnosis.notes if n.startswith("round 1: ")]
    assert bool(noted) == (bool(gap) or abs(miss["pct"]) > MIN_REDUCTION_PCT)
    assert all(f"{e} (refit" in noted[0] for e in gap)
    info = diagnosis.calibration[0]
    far = {**info, "one_step_miss": {**miss, "pct": 5.0}}
    assert "own held-out score +5.0 % from its refitted folds'" in step_note([], far, "base", 1)
    near = {**info, "one_step_miss": {**miss, "pct": 0.1}}
    assert step_note([], near, "base", 1) is None
    # damping here: refit +8.7 %, one step +1.9 % (named by its test alone); unnamed, it is listed
    (row,) = [dataclasses.replace(r, passes=False) for r in rows if r.effect == "damping"]
    gain = row.heldout_rms_reduction_pct - row.calibrated.observed_pct
    listed = step_note([row], near, "base", 1)
    assert (listed is not None and "for damping (refit" in listed) == (
        gain > MIN_REDUCTION_PCT and row.heldout_rms_reduction_pct > MIN_REDUCTION_PCT
    )


def test_a_standard_error_is_written_as_its_value_is():
    """A reviewer read "704 ± 2.3e+02" and "13451 ± 7.8e+03" on a page: ``.2g`` writes a
    two-digit SE of 100 or more with an exponent beside a written-out value. It is now written
    out there, and in the exponent form beside a value in that form, so a cell never mixes the
    two; two significant digits either way."""
    from gc_ocp.html.fit_tables import pm_value
    from gc_ocp.values import two_digits

    assert pm_value(704.2, 230.4, ".0f") == "704 ± 230"
    assert pm_value(13451.0, 7812.0, ".0f") == "13451 ± 7800"
    assert pm_value(38960.0, 6400.0) == "3.896e+04 ± 6.4e+03"
    assert pm_value(0.2601, 0.0112) == "0.2601 ± 0.011"
    # ".2g"'s digits where it writes no exponent; rounding up carries to the next decade
    for v in (0.0876, 1.5, 0.5, 9.96, 0.00012, 2e7):
        assert two_digits(v) == format(v, ".2g")
    assert (two_digits(99.6), two_digits(15000.0)) == ("100", "15000")


def test_a_parameter_at_its_bound_shows_no_standard_error():
    """A reviewer read "n = 1 ± 0.088" in a fit's tables while its flags said n sat on its
    bound and its SE is not meaningful. A parameter the fit flags ``at_bound`` is shown with
    that in place of its SE, in the page's tables and the summary; the others as before."""
    import dataclasses

    from gc_ocp.html.fit_tables import contact_tables
    from gc_ocp.values import BOUND_TEXT

    _, _, _, _, final = _fixture(CASES[0])
    before = contact_tables(final.params, final.at_bound)
    flagged = dataclasses.replace(
        final,
        flags=[
            *final.flags,
            {"code": "at_bound", "what": "contact/mu", "message": "mu at its bound"},
            {"code": "at_bound", "what": "contact/k/left/PL", "message": "k at its bound"},
        ],
    )
    assert flagged.at_bound >= {"contact/mu", "contact/k/left/PL"}
    after = contact_tables(flagged.params, flagged.at_bound)
    shared = dict(after["shared"])
    assert shared["mu"].endswith(BOUND_TEXT) and "±" not in shared["mu"]
    assert dict(before["shared"])["mu"].count("±") == 1
    pl = next(u for u in after["units"] if (u["side"], u["unit"]) == ("left", "PL"))
    assert pl["k"].endswith(BOUND_TEXT)
    assert [u for u in after["units"] if u is not pl] == [
        u for u in before["units"] if (u["side"], u["unit"]) != ("left", "PL")
    ]
    assert f"shared mu = {final.params['shared']['mu']:.4g} {BOUND_TEXT}" in flagged.summary()


@pytest.mark.parametrize("steps", [1, None])
def test_waterfall_legend_hides_no_point(steps):
    """Every point of the waterfall is visible: the legend covers none of them. With one step (a
    diagnosis that names nothing, as notebook 03's part 2 in small mode) every channel's point
    sits in one column, and the legend at matplotlib's "best" place lay over the superior force's
    point, the figure's main one."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from gc_ocp.diagnosis.result import WaterfallStep

    _, _, _, d, _ = _fixture(CASES[0])
    if steps == 1:  # notebook 03's part 2 (small mode): base only, superior force on top
        rms = {
            "anterior_force_pct_bw": 0.64,
            "superior_force_pct_bw": 1.40,
            "lateral_force_pct_bw": 0.55,
            "anteroposterior_torque_pct_bwh": 0.23,
            "longitudinal_torque_pct_bwh": 0.036,
            "mediolateral_torque_pct_bwh": 0.17,
        }
        d = dataclasses.replace(
            d, waterfall=[WaterfallStep("base", 1.40, {"right": rms}, 0.62, "base")]
        )
    fig = d.waterfall_figure()
    canvas = FigureCanvasAgg(fig)  # drawn as savefig draws it (the constrained layout done)
    canvas.draw()
    ax = fig.axes[0]
    box = ax.get_legend().get_window_extent(canvas.get_renderer())
    covered = [
        (line.get_label(), x, y)
        for line in ax.get_lines()
        for x, y in ax.transData.transform(line.get_xydata())
        if box.x0 - 3 <= x <= box.x1 + 3 and box.y0 - 3 <= y <= box.y1 + 3
    ]
    assert not covered, covered


def test_the_plate_member_s_sizes_in_the_method_are_those_drawn():
    """The method's words on the plate calibration member give the sizes its draws have: the
    family's ranges times its scale (a family at half scale draws plates 1-2.5 mm off and
    channels within +-1 %, :meth:`~gc_ocp.diagnosis.mismatch.MismatchFamily.draw`)."""
    from gc_ocp.diagnosis.mismatch import MismatchFamily
    from gc_ocp.diagnosis.report import _plates

    half = MismatchFamily(scale=0.5).with_plate_calibration()
    drawn = half.draw(np.random.default_rng(0))
    lo, hi = (1e3 * v for v in drawn.plate_offset)
    text = _plates(half.to_json())
    assert f"{lo:g}-{hi:g} mm off" in text and f"\u00b1{100 * drawn.plate_gain:g} %" in text
    assert _plates(MismatchFamily().to_json()) == "" and _plates(None) == ""


def test_the_method_says_what_the_steps_are_computed_with():
    """The method section's account of the further steps: of the null's spread between
    mismatch draws only the part every held-out stance shares does not shrink with more
    stances (``null.systematic_sd``, since 2026-11-28; the page said all of it does not), and a
    candidate above its null is *inconclusive* only when a follow-up of at most
    ``PRACTICAL_FACTOR + 1`` times its data would decide it (the page called every such
    candidate so; the rows give the others "not named" with their number)."""
    from gc_ocp.diagnosis.null import PRACTICAL_FACTOR
    from gc_ocp.diagnosis.report import report_html

    _, _, js, d, final = _fixture(CASES[0])
    pngs = dict.fromkeys(("heatmap", "residuals", "ranking", "waterfall", "heatmap_final"), b"")
    text = _Page(report_html(d, provenance=js["provenance"], pngs=pngs, final=final)).visible
    assert "the part of its spread between mismatch draws that every held-out stance" in text
    assert "its mean and its spread between mismatch draws" not in text
    assert f"at most {PRACTICAL_FACTOR + 1} times the held-out stances it had" in text


def test_a_sole_correction_at_its_bound_shows_no_standard_error():
    """The bundled trial's fit (``gc-ocp fit --holdout auto``) left right TT's sole correction on
    its 25 mm bound and flagged it ``at_bound`` ("its SE is not meaningful"), while the page's
    sole table showed "-25.0 ± 6.7". A unit whose correction the fit flags ``at_bound`` is shown
    without its SEs, saying so, on the fit's page and the diagnosis's; the others as before."""
    from gc_ocp.values import BOUND_TEXT
    from gc_ocp.workflow.fit_report import fit_report_html
    from gc_ocp.workflow.fitting import FitReport

    _, _, _, _, final = _fixture(CASES[0])
    flagged = dataclasses.replace(
        final,
        flags=[
            *final.flags,
            {"code": "at_bound", "what": "sole/right/TT", "message": "on its bound"},
        ],
    )
    figures = dict.fromkeys(("fit_wrench.png", "fit_sole.png", "fit_pose_corrections.png"), b"")

    def sole_rows(result):
        page = fit_report_html(FitReport(result=result), None, figures)
        table = page.split("Sole-point corrections")[1].split("</table>")[0]
        rows = re.findall(r"<tr><td class=l>(\w+)</td><td class=l>(.*?)</td>(.*?)</tr>", table)
        return {(side, unit.split()[0]): (unit, cells) for side, unit, cells in rows}

    before, after = sole_rows(final), sole_rows(flagged)
    unit, cells = after[("right", "TT")]
    assert "±" not in cells and BOUND_TEXT in unit
    assert before[("right", "TT")][1].count("±") == 3
    assert {k: v for k, v in after.items() if k != ("right", "TT")} == {
        k: v for k, v in before.items() if k != ("right", "TT")
    }


def test_the_sole_figure_gives_no_number_for_a_unit_not_identified():
    """The fixture's left AM is not identified (14669 N at 5 mm, 24 BW): the summary and the
    flags say so, yet the sole figure labelled it "14669 N" and drew it the largest, every
    identified unit shrunk beside it. A unit not identified is drawn with no force and says so;
    the identified units keep theirs."""
    from gc_ocp.estimation.plots import plot_sole_fit

    _, _, _, _, final = _fixture(CASES[0])  # its stance fits are not stored: two made here
    assert final.params["left"]["AM"]["identified"] is False
    pts = np.array(
        [[-0.03, 0.03, 0], [-0.03, -0.03, 0], [0.1, 0.04, 0], [0.1, -0.04, 0], [0.05, 0, 0]]
    )
    fig = plot_sole_fit(dataclasses.replace(final, stance_fits=_sole_fits(pts)))
    texts = {
        ax.get_title(): {t.get_text().split("\n")[0]: t.get_text() for t in ax.texts}
        for ax in fig.axes
    }
    assert texts["left"]["AM"] == "AM\nnot identified"
    pl = final.params["left"]["PL"]["f_ref"]
    assert texts["left"]["PL"] == f"PL\n{pl:.0f} N"
    sizes = {
        ax.get_title(): [c.get_sizes()[0] for c in ax.collections if len(c.get_sizes())]
        for ax in fig.axes
    }
    assert max(sizes["left"][:5]) == 300  # the largest identified unit sets the scale


def test_a_unit_stiffness_at_its_bound_shows_no_standard_error_in_the_summary():
    """The page's table said "at its bound" for a unit's k flagged ``at_bound``, but the
    summary (the CLI's output, ``.summary()``) printed it, and its force at 5 mm (k times a
    power of the depth: pinned by that bound as well), with an SE; the table also gave that
    force an SE. Both now say so in place of the SE; the other units as before."""
    from gc_ocp.html.fit_tables import contact_tables
    from gc_ocp.values import BOUND_TEXT

    _, _, _, _, final = _fixture(CASES[0])
    flagged = dataclasses.replace(
        final,
        flags=[
            *final.flags,
            {"code": "at_bound", "what": "contact/k/left/PL", "message": "k at its bound"},
        ],
    )
    lines = {ln.split(":")[0].strip(): ln for ln in flagged.summary().splitlines()}
    k_line, f_line = (
        lines["left k [N/m^n]"],
        next(v for k, v in lines.items() if k.startswith("left force")),
    )
    pl_k = k_line.split(": ", 1)[1].split(", ")[0]
    pl_f = f_line.split(": ", 1)[1].split(", ")[0]
    assert pl_k.startswith("PL ") and "±" not in pl_k and BOUND_TEXT in pl_k
    assert "±" not in pl_f and BOUND_TEXT in pl_f
    before = {ln.split(":")[0].strip(): ln for ln in final.summary().splitlines()}
    assert k_line.split(", ")[1:] == before["left k [N/m^n]"].split(", ")[1:]
    pl = next(
        u
        for u in contact_tables(flagged.params, flagged.at_bound)["units"]
        if u["unit"] == "PL" and u["side"] == "left"
    )
    assert pl["f_ref"].endswith(BOUND_TEXT) and "±" not in pl["f_ref"]


def test_an_option_given_as_zero_is_in_the_page_s_provenance():
    """The page's provenance line leaves out the options not given (None, False, []); a zero
    compares equal to False and was left out with them: ``--belt-speed 0`` (overground, said
    by the user) read as an option not given (the belt speed found from the markers)."""
    from gc_ocp.html import provenance_context

    opts = {"belt_speed": 0.0, "bias_correction": 0, "holdout": None, "sensitivity": False}
    line = provenance_context({"options": {**opts, "effects": [], "cutoff": 6.0}})["options"]
    assert line == "belt_speed=0.0, bias_correction=0, cutoff=6.0"


def test_the_fit_page_shows_the_fitted_belt_speed():
    """A treadmill fit estimates each trial's belt speed (``fit.json``'s ``belt_speed_m_s``, the
    summary, the diagnosis page), but the fit's page left it out of its parameters: a reader
    of ``report.html`` could not see the speed the friction was fitted against."""
    import html

    from gc_ocp.workflow.fit_report import fit_report_html
    from gc_ocp.workflow.fitting import FitReport

    _, _, _, _, final = _fixture(CASES[0])
    belt = {"walk<1>": {"value": 1.1834, "se": 0.0031, "nominal": 1.1, "correction": 0.0834}}
    res = dataclasses.replace(final, blocks={**final.blocks, "belt": belt})
    figures = dict.fromkeys(("fit_wrench.png", "fit_sole.png", "fit_pose_corrections.png"), b"")
    page = fit_report_html(FitReport(result=res), None, figures)
    text = _Page(page).visible
    assert "Belt speed (walk<1>): 1.183 ± 0.0031 m/s (from 1.100 m/s" in text
    assert "walk<1>" not in page and html.escape("walk<1>") in page
    # the diagnosis page shows it by the same definition (html.fit_tables.belt_rows): it looked
    # for a "value_se" the block does not have and showed the speed without its SE
    from gc_ocp.diagnosis.report import report_html

    folder, _, js, d, _ = _fixture(CASES[0])
    pngs = dict.fromkeys(("heatmap", "residuals", "ranking", "waterfall"), b"\x89PNG")
    pngs.update({"heatmap_final": b"\x89PNG"} if d.selected else {})
    diag = _Page(report_html(d, provenance=js["provenance"], pngs=pngs, final=res)).visible
    assert "Belt speed (walk<1>): 1.183 ± 0.0031 m/s (from 1.100 m/s" in diag
    # at its bound: no SE, on both pages
    flag = {"code": "at_bound", "what": "belt/walk<1>", "message": "at its bound"}
    res = dataclasses.replace(res, flags=[*res.flags, flag])
    page = _Page(fit_report_html(FitReport(result=res), None, figures)).visible
    assert "Belt speed (walk<1>): 1.183 m/s (at its bound: not an estimate)" in page


def test_a_diagnosis_read_back_from_its_json_renders_its_page():
    """``Diagnosis.from_json`` promises the report page (given the final fit), but
    ``report_html`` drew the residual-over-time figure, which needs the fits the file does not
    keep: KeyError 'base', a traceback. The page is made without that figure and says why; the
    figure asked for alone is an error that names the fix."""
    from gc_ocp.diagnosis.report import report_html
    from gc_ocp.errors import InputError

    _, _, js, d, final = _fixture(CASES[0])
    page = _Page(report_html(d, provenance=js["provenance"], final=final)).visible
    assert "needs the diagnosis's fits, which diagnosis.json does not keep" in page
    assert "Held-out residual of the base model" in page  # the figures that need no fit
    with pytest.raises(InputError, match="diagnosis.json does not keep them"):
        d.residual_figure("base")


def test_an_effect_at_its_bound_shows_no_standard_error():
    """An effect's parameter the fit flags at its bound (damping's c, a trial's clock offset)
    was shown with its SE on the pages and in the summary, beside the flag saying its SE means
    nothing; it is shown as the contact law's and the sole's are: at its bound, no SE."""
    from gc_ocp.diagnosis.report import report_html
    from gc_ocp.values import BOUND_TEXT

    _, _, js, d, final = _fixture(CASES[0])
    rows = final.block_rows()
    name, r = next((n, r) for n, rs in rows.items() for r in rs if r.key)
    flag = {"code": "at_bound", "what": "/".join((name, *r.key)), "message": "at its bound"}
    res = dataclasses.replace(final, flags=[*final.flags, flag])
    assert f"{name} {r.label} = {r.value:.4g}" in res.summary()
    assert (
        f"{r.label} = {r.value:.4g}"
        + (f" {r.unit}" if r.unit not in ("", "-") else "")
        + (f" {BOUND_TEXT}")
        in res.summary()
    )
    pngs = dict.fromkeys(("heatmap", "residuals", "ranking", "waterfall", "heatmap_final"), b"")
    page = _Page(report_html(d, provenance=js["provenance"], pngs=pngs, final=res)).visible
    assert f"{r.label}\n" in page and BOUND_TEXT in page.split(f"{r.label}\n", 1)[1][:80]


def test_a_ranking_only_diagnosis_does_not_say_no_effect_passes():
    """With ``max_effects=0`` (rank only) a row that passes the rule is not selected; the
    summary said "selected: none (no effect passes)" and the page "No candidate effect passes
    the decision rule" beside that row's PASS. They now say it passes and was not selected."""
    from gc_ocp.diagnosis.report import report_html

    _, _, js, d, final = _fixture(CASES[0])
    ranked = dataclasses.replace(
        d, selected=[], rounds=[d.ranking], waterfall=d.waterfall[:1], max_effects=0
    )
    passing = [r.effect for r in ranked.ranking if r.passes]
    assert passing  # the fixture's round 1 names an effect
    text = ranked.summary()
    assert "no effect passes" not in text
    assert f"selected: none (max_effects=0: ranked only, not selected; {passing[0]}" in text
    pngs = dict.fromkeys(("heatmap", "residuals", "ranking", "waterfall"), b"")
    page = _Page(report_html(ranked, provenance=js["provenance"], pngs=pngs, final=final))
    assert "No candidate effect passes" not in page.visible
    assert "No effect was selected (max_effects=0: the ranking only)" in page.visible
    # nothing passing: "none" as before
    none = dataclasses.replace(
        ranked, rounds=[[dataclasses.replace(r, passes=False) for r in ranked.ranking]]
    )
    assert "selected: none (no effect passes)" in none.summary()


def test_a_run_with_too_few_null_draws_says_first_that_nothing_could_be_named(diagnosis):
    """A small run (``mismatch_draws=4``, the fixture's; ``--null-draws 8``) can name nothing:
    the p-value counts draws. The summary's "selected: none (no effect passes)" and the page's
    "none ... predicts the held-out stances clearly better" read as the data's answer beside a
    +5 % [+3, +7] gain, the reason last among the notes; both now say it first, with the fix."""
    from gc_ocp.diagnosis.report import report_html

    assert diagnosis.calibration[0]["mismatch_draws_planned"] == 4 and not diagnosis.selected
    assert diagnosis.draws_too_few == 20  # 1 / 21 < 0.05 <= 1 / 20
    said = "selected: none (none could be: 4 mismatch draws per round cannot give a p-value"
    assert said in diagnosis.summary() and "give at least 20, the default 32" in diagnosis.summary()
    lead = _Page(report_html(diagnosis)).visible.split("1. Where the gap is")[0]
    assert "none could on this run: with 4 mismatch draws per round" in lead
    assert "at least 20 are needed, 32 by default" in lead and "--null-draws" in lead
    # the steps a row's verdict gives are those of a run with the default draws (null.decide's
    # critical value is the full null's): said beside them, or "28 more steps would decide"
    # reads as if more steps alone would. A row of the fixture with a number, and every one said so
    # reads as if more steps alone would. The fixture's row given a number (test_diagnosis's
    # inconclusive row: named by the test, its interval reaching 0, 1200 more steps by the floor)
    from gc_ocp.diagnosis.null import NullTest

    row = dataclasses.replace(
        diagnosis.ranking[0],
        heldout_rms_reduction_ci=(-6.0, 7.2),
        calibrated=NullTest(2.2, 0.4, 0.6, 3.0, 0.039, 2.4, 0, 400),
        inconclusive=True,
        floor_stances=1200,
    )
    small = dataclasses.replace(diagnosis, ranking=[row], rounds=[[row]])
    qualified = "steps would decide with 32 mismatch draws per round"
    assert qualified in row.verdict(small.steps_draws)
    for text in (small.summary(), _Page(report_html(small)).visible):
        assert text.count("steps would decide") == text.count(qualified) > 0
    # enough draws planned: the answer is the data's, said as before
    enough = dataclasses.replace(
        diagnosis, calibration=[dict(diagnosis.calibration[0], mismatch_draws_planned=20)]
    )
    assert enough.draws_too_few is None
    assert "selected: none (no effect passes)" in enough.summary()
    assert enough.steps_draws is None and "mismatch draws per round" not in row.verdict()
    lead = _Page(report_html(enough)).visible.split("1. Where the gap is")[0]
    assert "No candidate effect passes the decision rule:" in lead and "none could" not in lead


def test_a_diagnosis_figure_of_a_model_that_is_not_base_or_final_is_refused():
    """``heatmap(which="fnal")`` raised a bare KeyError and ``residual_figure(which="fnal")``
    drew the final model's; each says which models there are."""
    from gc_ocp.diagnosis import Diagnosis
    from gc_ocp.errors import InputError

    d = Diagnosis.from_json(json.loads((FIXTURES / "all_effects" / "diagnosis.json").read_text()))
    for figure in (d.heatmap, d.residual_figure):
        with pytest.raises(InputError, match='"base" or the "final"'):
            figure(which="fnal")
    assert d.heatmap(which="final") is not None


def test_the_summary_names_the_body_weight_and_height_its_percentages_are_of():
    """The summary gives its errors in % BW and % BW x height; it now prints the body weight
    [N] and height [m] they are of, once (one subject), or per trial (subjects that differ)."""
    _, _, _, _, final = _fixture(CASES[0])  # its stance fits are cut: the scale of two here
    one = [
        {"label": f"t:{s}@1s", "side": s, "trial": "t", "body_weight": 623.916, "height": 1.58}
        for s in ("left", "right")
    ]
    text = dataclasses.replace(final, stance_fits=one).summary()
    line = next(ln for ln in text.splitlines() if "body weight" in ln)
    assert "624 N" in line and "1.58 m" in line and "% BW x height" in line
    two = [one[0], {**one[1], "trial": "u", "body_weight": 700.0, "height": 1.8}]
    text = dataclasses.replace(final, stance_fits=two).summary()
    line = next(ln for ln in text.splitlines() if "body weight" in ln)
    assert "624 N and height 1.58 m (t)" in line and "700 N and height 1.80 m (u)" in line
    assert "body weight" not in final.summary()  # no stance fits: no scale to name


def test_a_held_out_fit_s_summary_says_its_contact_law_is_fixed_in_one_line():
    """A held-out fit (the contact law frozen at the training fit's values: every SE zero)
    printed a k line and a force line per foot, each unit "(fixed)", repeating the values the
    training fit's summary prints just above; it now says once that the law is fixed. A fit
    that estimated the law prints its lines as before."""
    _, _, _, _, final = _fixture(CASES[0])

    def frozen(d):
        if isinstance(d, dict):
            return {k: (0.0 if k.endswith("_se") else frozen(v)) for k, v in d.items()}
        return d

    blocks = {**final.blocks, "contact": frozen(final.params)}
    text = dataclasses.replace(final, blocks=blocks).summary()
    assert "(fixed)" not in text and "k [N/m^n]" not in text and "shared n =" not in text
    line = next(ln for ln in text.splitlines() if ln.startswith("contact law: fixed"))
    assert "k of PL, PM, AL, AM, TT" in line
    before = final.summary()
    assert "contact law: fixed" not in before and " left k [N/m^n]" in before


def _sole_fits(pts):
    from gc_ocp.foot import SEED_LAYOUT

    return [
        {
            "side": side,
            "label": f"t:{side}@1.000s",
            "units": list(SEED_LAYOUT.units),
            "parents": list(SEED_LAYOUT.parents),
            "points_local": pts,
            "nominal_points": pts,
            "toes_offset": np.array([0.13, 0.0, 0.0]),
        }
        for side in ("right", "left")
    ]


def test_the_sole_figure_keeps_its_unit_labels_inside_the_frame():
    """A unit at the sole's edge had its label ("AL 704 N" on the right foot of the bundled
    trial's fit) run over the frame: every label (and every unit, nominal or corrected) now
    lies inside its axes."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from gc_ocp.estimation.plots import plot_sole_fit

    _, _, _, _, final = _fixture(CASES[0])  # its stance fits are not stored: two made here
    # the units of the bundled trial's fit [m] (hindfoot frame; the toe on the toes frame)
    pts = np.array(
        [[-0.032, 0.031, 0], [-0.033, -0.034, 0], [0.095, 0.037, 0], [0.096, -0.047, 0]]
        + [[0.028, -0.002, 0]]
    )
    fig = plot_sole_fit(dataclasses.replace(final, stance_fits=_sole_fits(pts)))
    canvas = FigureCanvasAgg(fig)  # the figure as savefig draws it
    canvas.draw()
    renderer = canvas.get_renderer()
    for ax in fig.axes:
        frame = ax.get_window_extent(renderer)
        assert len(ax.texts) == 5
        for t in ax.texts:
            box = t.get_window_extent(renderer)
            inside = frame.x0 <= box.x0 and box.x1 <= frame.x1
            assert inside and frame.y0 <= box.y0 and box.y1 <= frame.y1, (ax.get_title(), t)
        (x0, x1), (y0, y1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
        for c in ax.collections:
            xy = c.get_offsets()
            assert ((xy[:, 0] > x0) & (xy[:, 0] < x1) & (xy[:, 1] > y0) & (xy[:, 1] < y1)).all()


def test_the_pose_corrections_figure_has_a_readable_key_on_each_panel():
    """The key was in 6 pt on the translation panel only (nine entries over the curves): each
    panel now has one in the text's size, a colour per stance and a line style per axis."""
    import matplotlib as mpl
    from matplotlib.font_manager import FontProperties

    from gc_ocp.estimation.plots import plot_pose_corrections

    _, _, _, _, final = _fixture(CASES[0])
    fits = _sole_fits(np.zeros((5, 3)))
    t = np.linspace(0.0, 0.6, 31)
    for f in fits:
        f["time"] = t
    stances = {
        f["label"]: {"translation_m": np.full((31, 3), 1e-3), "rotation_rad": np.zeros((31, 3))}
        for f in fits
    }
    blocks = {**final.blocks, "pose": {"stances": stances}}
    fig = plot_pose_corrections(dataclasses.replace(final, blocks=blocks, stance_fits=fits))
    small = FontProperties(size=mpl.rcParams["legend.fontsize"]).get_size_in_points()
    for ax in fig.axes:
        legend = ax.get_legend()
        assert legend is not None, ax.get_ylabel()
        labels = [x.get_text() for x in legend.get_texts()]
        assert labels == ["right@1.000s", "left@1.000s", "x", "y", "z"]
        assert all(x.get_fontsize() >= min(small, 8) for x in legend.get_texts())


def test_the_contact_table_gives_each_unit_s_force_in_body_weights_too():
    """The flags say a unit is not identified at "24 BW"; the contact table gave its force at
    5 mm in N only (14669 N). It now gives it in % BW beside, of the subject's body weight
    (each foot's stances', as the flag divides; from the provenance's mass when the stance
    fits are cut, as in the fixture)."""
    from gc_ocp.diagnosis.report import report_html
    from gc_ocp.html.fit_tables import body_weights, contact_tables
    from gc_ocp.trial import GRAVITY

    _, _, js, d, final = _fixture(CASES[0])
    bw = js["provenance"]["trials"][0]["mass_kg"] * GRAVITY
    assert body_weights(final, js["provenance"]) == {"left": bw, "right": bw}
    fits = [{"side": "left", "body_weight": 700.0}, {"side": "right", "body_weight": 650.0}]
    assert body_weights(dataclasses.replace(final, stance_fits=fits), None) == {
        "left": 700.0,
        "right": 650.0,
    }
    assert body_weights(final, None) == {}  # nothing to divide by: the cells say "–"
    units = contact_tables(final.params, final.at_bound, None, {"left": bw, "right": bw})["units"]
    am = next(u for u in units if (u["side"], u["unit"]) == ("left", "AM"))
    f = final.params["left"]["AM"]["f_ref"]
    assert am["f_ref_pct_bw"] == f"{100 * f / bw:.0f}" == "2351"  # the flag's "24 BW"
    assert "24 BW" in " ".join(x["message"] for x in final.flags)
    pngs = dict.fromkeys(("heatmap", "residuals", "ranking", "waterfall", "heatmap_final"), b"")
    page = _Page(report_html(d, js["provenance"], pngs, final))
    assert "force [% BW]" in page.visible
    row = page.visible.split("left\nAM\n", 1)[1].split("\n")[:3]
    assert row == ["2.934e+06 ± 1.9e+06", "14669 ± 9400", "2351"], row


def test_the_fit_page_s_flags_table_breaks_long_stance_labels():
    """The fit page's flags table ran wider than the text column: a flag's "where" (and its
    fit's label) is a stance label with no space in it, "pose/<trial>:right@0.407s/trans",
    which a browser does not break. Those cells now break anywhere (the codes stay whole)."""
    from gc_ocp.workflow.fit_report import fit_report_html
    from gc_ocp.workflow.fitting import FitReport

    _, _, _, _, final = _fixture(CASES[0])
    label = "Walking1_subject03_overground_session2:right@0.407s"
    flag = {"code": "prior_exceeded", "what": f"pose/{label}/trans", "message": "-"}
    report = FitReport(result=dataclasses.replace(final, flags=[flag]))
    names = ("fit_wrench.png", "fit_sole.png", "fit_pose_corrections.png")
    page = _Page(fit_report_html(report, None, dict.fromkeys(names, b"")))
    assert "table.flags td { overflow-wrap: anywhere; }" in page.style
    assert "td.nw { white-space: nowrap; }" in page.style
    tags = page.tags[
        next(i for i, t in enumerate(page.tags) if t == ("table", (("class", "flags"),))) :
    ]
    cells = [dict(t[1]).get("class") for t in tags[: tags.index(("/table",))] if t[0] == "td"]
    assert cells == ["l", "l nw", "l", "l"]  # fit, code (whole), where, message


# --- every figure the package draws stays out of pyplot -----------------------------------
FIGURE_MODULES = (
    "gc_ocp.estimation.plots",
    "gc_ocp.contact.plots",
    "gc_ocp.export.opensim_export",
    "gc_ocp.diagnosis.result",
    "gc_ocp.diagnosis.where",
    "gc_ocp.batch.page",
    "gc_ocp.bench.summary",
    "gc_ocp.kinematics.export",
)


def _drawable_fits():
    """Two stance fits (right, left) carrying every key a figure reads: the wrench (a 1 % BW
    superior-force error), the phases' inputs and the sole's units."""
    t = np.linspace(0.0, 0.6, 61)
    pts = np.array(
        [[-0.03, 0.03, 0], [-0.03, -0.03, 0], [0.1, 0.04, 0], [0.1, -0.04, 0], [0.05, 0, 0]]
    )
    fits = _sole_fits(pts)
    for f in fits:
        meas = np.zeros((t.size, 6))
        meas[:, 2] = 700.0 * np.sin(np.pi * t / 0.6)
        meas[:, 0] = 0.1 * meas[:, 2]
        mod = meas.copy()
        mod[:, 2] += 7.0
        f.update(
            time=t,
            measured=meas,
            model=mod,
            in_contact=np.ones(t.size, bool),
            reference_point=np.zeros(3),
            ground_height=0.0,
            body_weight=700.0,
            height=1.7,
        )
    return fits


def _figure_calls() -> dict:
    """``{public plotting function: a call of it on cheap inputs}``; each call returns a
    figure, or ``summary_figures``'s dict of them."""
    import types

    from gc_ocp.batch.page import summary_figures
    from gc_ocp.bench.summary import confusion_figure
    from gc_ocp.contact.plots import plot_sole, plot_wrench_fit
    from gc_ocp.diagnosis.result import Diagnosis
    from gc_ocp.diagnosis.where import heatmap_figure, residual_figure
    from gc_ocp.estimation.plots import plot_fit, plot_pose_corrections, plot_sole_fit
    from gc_ocp.export.opensim_export import plot_comparison
    from gc_ocp.kinematics.export import plot_kinematics

    ns = types.SimpleNamespace

    def fitted():
        _, _, _, d, final = _fixture(CASES[0])
        fits = _drawable_fits()
        pose = {
            f["label"]: {"translation_m": np.full((61, 3), 1e-3), "rotation_rad": np.zeros((61, 3))}
            for f in fits
        }
        blocks = {**final.blocks, "pose": {"stances": pose}}
        return d, dataclasses.replace(final, stance_fits=fits, blocks=blocks), fits

    def kinematics():
        t = np.linspace(0.0, 1.0, 11)
        foot = ns(time=t, positions=np.zeros((t.size, 5, 3)))
        trial = ns(name="t", floor_height=0.0, stances=[ns(side="left", t_on=0.2, t_off=0.8)])
        return plot_kinematics(
            trial, ns(time=t, marker_rms=np.zeros(t.size), feet={"left": foot, "right": foot})
        )

    def comparison():
        time = np.linspace(0.0, 2.0, 21)
        w = {s: np.ones((time.size, 6)) for s in ("left", "right")}
        return plot_comparison(time, w, w, w, ns(body_weight=600.0), [("left", 0.4, 1.0)])

    def confusion():
        summary = {
            "matrix": [[2, 0], [1, 1]],
            "answers": ["damping", "none"],
            "truths": ["damping", "none"],
            "top1_accuracy": 0.75,
            "none_correct_rejection": 0.5,
            "n_cases": 4,
        }
        return confusion_figure({"summary": summary, "settings": {"base": "registered"}})

    fits = _drawable_fits()
    evaluation = ns(base_evaluation=ns(scored_fits=fits, weights=None))
    return {
        "plot_fit": lambda: plot_fit(fitted()[1]),
        "plot_sole_fit": lambda: plot_sole_fit(fitted()[1]),
        "plot_pose_corrections": lambda: plot_pose_corrections(fitted()[1]),
        "plot_wrench_fit": lambda: plot_wrench_fit(
            [f["time"] for f in fits], [f["measured"] for f in fits], [f["model"] for f in fits]
        ),
        "plot_sole": lambda: plot_sole({"left": fits[1]["points_local"]}),
        "plot_comparison": comparison,
        "heatmap": lambda: fitted()[0].heatmap("base"),
        "Diagnosis.residual_figure": lambda: Diagnosis.residual_figure(evaluation, "base"),
        "ranking_figure": lambda: fitted()[0].ranking_figure(),
        "waterfall_figure": lambda: fitted()[0].waterfall_figure(),
        "heatmap_figure": lambda: heatmap_figure(fitted()[0].where["base"]),
        "residual_figure": lambda: residual_figure(fits),
        "summary_figures": lambda: summary_figures(
            [{"subject": "S1", "status": "failed", "diagnosis_selected": "damping"}]
        ),
        "confusion_figure": confusion,
        "plot_kinematics": kinematics,
    }


def test_every_plotting_function_is_in_the_pyplot_test():
    """The list below names every public plotting function of the modules that draw (a new one
    is added to it, or this fails): ``plot_*`` and ``*_figure(s)`` functions, and the figure
    methods of :class:`~gc_ocp.diagnosis.result.Diagnosis`."""
    import importlib
    import inspect

    from gc_ocp.diagnosis.result import Diagnosis

    def drawing(name):
        return name.startswith("plot_") or name.endswith(("_figure", "_figures"))

    found = set()
    for module in map(importlib.import_module, FIGURE_MODULES):
        for name, obj in vars(module).items():
            if inspect.isfunction(obj) and obj.__module__ == module.__name__ and drawing(name):
                found.add(name)
    found |= {n for n in vars(Diagnosis) if drawing(n) and n != "residual_figure"}
    found |= {"heatmap", "Diagnosis.residual_figure"}
    assert found == set(_figure_calls())


@pytest.mark.parametrize("name", list(_figure_calls()))
def test_figures_stay_out_of_pyplot(name):
    """Every figure the package draws is a :class:`~matplotlib.figure.Figure` pyplot does not
    hold: a notebook or a study drawing hundreds of them does not accumulate open figures (nor
    meet pyplot's "more than 20 figures" warning), and no caller has to close them. Nine were
    drawn with ``plt.subplots`` (the diagnosis's, the study page's, the benchmark's confusion
    matrix and the kinematics figure)."""
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    before = plt.get_fignums()
    out = _figure_calls()[name]()
    figs = list(out.values()) if isinstance(out, dict) else [out]
    assert figs and all(isinstance(f, Figure) for f in figs)
    assert plt.get_fignums() == before
    for f in figs:  # each draws as savefig draws it (the constrained layout included)
        f.savefig(__import__("io").BytesIO(), format="png", dpi=40)


def test_no_module_of_the_package_uses_pyplot():
    """The behavioural test above covers the plotting modules' public functions; this scan
    covers the rest of the package: no module imports pyplot (its figures are held open by
    pyplot's state until closed)."""
    import ast

    import gc_ocp

    users = []
    for path in sorted(Path(gc_ocp.__file__).parent.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else [f"{node.module}.{a.name}" for a in node.names]
                if isinstance(node, ast.ImportFrom) and node.module
                else []
            )
            users += [(path.name, n) for n in names if n.startswith("matplotlib.pyplot")]
    assert not users, users


def _sole_figures():
    """The sole figure of the bundled trial's fit (its units; the fixture's forces) and a sole
    whose units all have the largest marker."""
    from gc_ocp.contact.plots import plot_sole
    from gc_ocp.estimation.plots import plot_sole_fit
    from gc_ocp.foot import SEED_LAYOUT

    _, _, _, _, final = _fixture(CASES[0])
    pts = np.array(
        [[-0.032, 0.031, 0], [-0.033, -0.034, 0], [0.095, 0.037, 0], [0.096, -0.047, 0]]
        + [[0.028, -0.002, 0]]
    )
    yield plot_sole_fit(dataclasses.replace(final, stance_fits=_sole_fits(pts)))
    yield plot_sole({"left": pts}, k={"left": dict.fromkeys(SEED_LAYOUT.units, 1e5)})


@pytest.mark.parametrize("which", [0, 1])
def test_the_sole_figure_s_labels_lie_off_every_marker(which):
    """A unit's label was set 8 pt right of its marker's centre, inside the disk of the
    largest markers (radius sqrt(300) / 2 = 8.7 pt): the bundled fit's labels ran over their
    markers' edges. No label's box now meets any marker's disk (its centre, its radius in
    points from the marker's size, an area in pt^2), the nominal units' markers included."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = list(_sole_figures())[which]
    canvas = FigureCanvasAgg(fig)  # as savefig draws it
    canvas.draw()
    renderer = canvas.get_renderer()
    px_per_pt = fig.dpi / 72.0
    met = []
    for ax in fig.axes:
        boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in ax.texts]
        assert len(boxes) == 5
        for c in ax.collections:
            centres = ax.transData.transform(c.get_offsets())
            radii = np.broadcast_to(np.sqrt(c.get_sizes()) / 2 * px_per_pt, len(centres))
            for (x, y), r in zip(centres, radii, strict=True):
                for text, b in boxes:
                    # the box's nearest point to the centre, closer than the radius: they meet
                    gap = np.hypot(max(b.x0 - x, 0, x - b.x1), max(b.y0 - y, 0, y - b.y1))
                    if gap < r:
                        met.append((ax.get_title(), text, round(gap, 1), round(r, 1)))
    assert not met, met
