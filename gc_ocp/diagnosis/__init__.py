"""The sim-to-real diagnosis: where the residual lies, which unmodelled effect causes it, how far
it shrinks once that effect is added (``docs/diagnosis.md``).

>>> import gc_ocp
>>> trial = gc_ocp.load_trial(); kin = gc_ocp.compute_kinematics(trial)
>>> # skipped: a diagnosis is minutes of Ipopt fits (tests/test_diagnosis.py runs small ones)
>>> d = gc_ocp.diagnose([(trial, kin)])                              # doctest: +SKIP
>>> print(d.summary())                                               # doctest: +SKIP
>>> fig = d.heatmap(); fig = d.waterfall_figure()                    # doctest: +SKIP

Layout, one idea per module (the table in ``docs/architecture.md``):

* :mod:`.phases`: gait phases of a stance; :mod:`.where`: the residual map and its figures;
* :mod:`.compare`: folds, the held-out score, the bootstrap (one model's evaluation);
* :mod:`.null`: the calibrated test (null replicates, max statistic, steps that would decide);
  :mod:`.onestep`: its one Gauss-Newton step per fit; :mod:`.draws`: its mismatch draws, each
  a refit of the parent;
* :mod:`.selection`: the decision rule, ranking, confounding, which effect a round adds;
* :mod:`.execution`: a round's candidates as tasks on a ``concurrent.futures.Executor``;
* :mod:`.diagnose`: the orchestration (:func:`diagnose`, :func:`diagnose_stances`, the bases);
* :mod:`.result`: the :class:`Diagnosis` and its rows (:class:`RankRow`,
  :class:`WaterfallStep`): JSON, summary, figures;
* :mod:`.confirm`: confirmation on stances the diagnosis never saw;
* :mod:`.mismatch`: the mismatch family, small truth-model differences that are not candidate
  effects (benchmark "none" truths, a parametric-bootstrap null);
* :mod:`.report`: the self-contained HTML page (markup in ``templates/report.html.j2``).
"""

from gc_ocp.diagnosis.confirm import confirm, confirm_stances
from gc_ocp.diagnosis.diagnose import BASES, candidate_names, diagnose, diagnose_stances
from gc_ocp.diagnosis.null import ALPHA
from gc_ocp.diagnosis.phases import PHASES, phase_bounds
from gc_ocp.diagnosis.report import report_html, write_report
from gc_ocp.diagnosis.result import Diagnosis, RankRow, WaterfallStep
from gc_ocp.diagnosis.where import heatmap_figure, residual_figure, where

__all__ = (
    "ALPHA",
    "BASES",
    "PHASES",
    "Diagnosis",
    "RankRow",
    "WaterfallStep",
    "candidate_names",
    "confirm",
    "confirm_stances",
    "diagnose",
    "diagnose_stances",
    "heatmap_figure",
    "phase_bounds",
    "report_html",
    "residual_figure",
    "where",
    "write_report",
)
