"""Make a report fixture from a ``gc-ocp diagnose --out DIR`` folder (run once, by hand).

    python tests/report_fixtures/make_fixtures.py DIR NAME
    python tests/report_fixtures/make_fixtures.py --rerender NAME

Copies ``diagnosis.json`` as written; ``final_fit.json`` without its per-frame arrays and
variable vector (the page does not show them); ``report.html`` with the base64 image data cut
(``data:image/png;base64,`` kept). The fixtures of this folder were made from the outputs of the
f-string renderer the jinja2 template replaced (commit 076f609), on the bundled trial:
``damping_time_offset`` from ``gc-ocp diagnose --effects damping,time_offset``, ``all_effects``
from ``gc-ocp diagnose`` (every effect of the library).

Deliberate changes since, each re-rendered from the fixture's own JSON (no new run) and checked
to change nothing else of the page: issue 21, each effect's block shown by its component
(``Component.describe``: ``c 1.976 ± 0.13 s/m``, ``dz 3.961 ± 1.6 mm``, ``delay 10.44 ± 0.8 ms``)
instead of the block's raw leaves (metres and radians beside the same values in mm and deg);
the clock offset's standard error is ``ms_se`` (was ``se_ms``, the one key of another spelling).

Issue 22 (the calibrated decision: a test with a family-wise rate replaced the 2 % threshold;
``diagnosis.json`` has ``alpha``, ``calibration``, ``measurement`` and a ``calibrated`` test per
row instead of ``threshold_pct``; the lab's plate thresholds are censored): both fixtures made
again from new runs of the same commands on the bundled trial; then re-rendered from their own
JSON once (the ranking table's three test columns merged into one, so that the table fits the
page). The null's mismatch draws became refits of the parent (the method text says so):
both pages re-rendered from their own JSON (``--rerender``), the method paragraph the only
change. The test's row gained ``null_sd_mismatch_pct`` (the null's spread between mismatch
draws, which more stances do not shrink): added to both ``diagnosis.json`` as 0.0, which is
what the fixtures' own steps-needed figures assumed (their null did not group its replicates
by draw); the pages do not show it and are unchanged.
The method text then said that only the null's noise, not its spread between mismatch
draws, shrinks with more stances: both pages re-rendered (``--rerender``), that sentence the only
change.
A standard error is written as its value is (2026-11-30, ``gc_ocp.values.se_text``): written out
beside a written-out value (``207 ± 160``, ``14669 ± 9400``, where ``.2g`` gave ``1.6e+02``),
in the exponent form beside a value in that form (``3.896e+04 ± 6.4e+03``, unchanged): both
pages re-rendered (``--rerender``), those cells the only change. The ranking table laid out
for a reader (same day, a review's screenshot: intervals broken over two lines, the decision
column a word wide): the interval and the test kept on their lines (``td.nw``), the decision
column at least 12em wide, the page 72em wide, the test's p-value to three significant digits
as the decision gives it: both pages re-rendered, those cells, the style and that width the
only change.
The method text's steps (2026-12-01, a review): of the spread between mismatch draws only the
part every held-out stance shares does not shrink (as the steps have been computed since
2026-11-28), and *inconclusive* only within a follow-up of five times the data: both pages
re-rendered (``--rerender``), that sentence the only change.
The contact-units table gives each unit's force at 5 mm in % BW too (2026-12-03, a newcomer's
walkthrough: the flags said "24 BW" of a unit the table gave in N only): a column "force [% BW]"
after "force at 5 mm [N] ± SE", of the provenance's mass (63.6 kg, 623.9 N). Both pages
re-rendered (``--rerender``) and only the one line of that table (line 45 of ``all_effects``,
43 of ``damping_time_offset``) taken from the new page: the rest of the re-rendered pages
differed in whitespace alone (a line break before "<h2>2. Which effect" and the file's last
newline, the template's since an earlier change), left as it was.
diagnosis.json gained its ``"format"`` number (2026-12-03, ``DIAGNOSIS_FORMAT`` = 1, its first
key): added to both fixtures' ``diagnosis.json`` by hand; the pages do not show it.

2026-12-03: the method paragraph says that the further steps are counted with 80 % assurance
(the observed gain's own uncertainty included): both pages re-rendered from their own JSON
(``--rerender``), that paragraph the only change of the visible text (its ``<i>assurance</i>``
the only new element; the line break before "<h2>2. Which effect" went, whitespace the text
comparison ignores); the rows' numbers are the stored ones.
"""

from __future__ import annotations

import json
import re
import shutil
import sys
from pathlib import Path


def main(src: str, name: str) -> None:
    src_dir, dst = Path(src), Path(__file__).parent / name
    dst.mkdir(exist_ok=True)
    shutil.copyfile(src_dir / "diagnosis.json", dst / "diagnosis.json")
    fit = json.loads((src_dir / "final_fit.json").read_text())
    fit.update(stance_fits=[], x=[], variables=[], covariance=None)
    (dst / "final_fit.json").write_text(json.dumps(fit, indent=1))
    page = (src_dir / "report.html").read_text(encoding="utf-8")
    page = re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "data:image/png;base64,", page)
    (dst / "report.html").write_text(page, encoding="utf-8")


def rerender(name: str) -> None:
    """The fixture's page made again from its own JSON by today's template (images empty, as
    cut): for a deliberate change of the page's text."""
    from gc_ocp.diagnosis import Diagnosis
    from gc_ocp.diagnosis.report import report_html
    from gc_ocp.estimation.result import EstimationResult

    dst = Path(__file__).parent / name
    js = json.loads((dst / "diagnosis.json").read_text())
    d = Diagnosis.from_json(js)
    final = EstimationResult.from_json(dst / "final_fit.json")
    keys = ["heatmap", "residuals", "ranking", "waterfall"] + (
        ["heatmap_final"] if d.selected else []
    )
    page = report_html(d, provenance=js["provenance"], pngs=dict.fromkeys(keys, b""), final=final)
    (dst / "report.html").write_text(page, encoding="utf-8")


if __name__ == "__main__":
    if sys.argv[1] == "--rerender":
        rerender(sys.argv[2])
    else:
        main(*sys.argv[1:3])
