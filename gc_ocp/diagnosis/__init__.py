"""The sim-to-real diagnosis: where the residual lies, which unmodelled effect causes it, how far
it shrinks once that effect is added (``docs/diagnosis.md``).

>>> import gc_ocp                                                    # doctest: +SKIP
>>> trial = gc_ocp.load_trial(); kin = gc_ocp.compute_kinematics(trial)   # doctest: +SKIP
>>> d = gc_ocp.diagnose([(trial, kin)])                              # doctest: +SKIP
>>> print(d.summary()); d.heatmap(); d.waterfall_figure()            # doctest: +SKIP

Layout: :mod:`.phases` (gait phases of a stance), :mod:`.where` (residual map and figures),
:mod:`.compare` (folds, held-out score, bootstrap), :mod:`.diagnose` (ranking, selection,
confounding, the :class:`Diagnosis` result), :mod:`.report` (the self-contained HTML report).
"""

from gc_ocp.diagnosis.diagnose import (
    BASES,
    MIN_REDUCTION_PCT,
    Diagnosis,
    candidate_names,
    confirm,
    confirm_stances,
    diagnose,
    diagnose_stances,
)
from gc_ocp.diagnosis.phases import PHASES, phase_bounds
from gc_ocp.diagnosis.report import report_html, write_report
from gc_ocp.diagnosis.where import heatmap_figure, residual_figure, where

__all__ = [
    "BASES",
    "MIN_REDUCTION_PCT",
    "PHASES",
    "Diagnosis",
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
]
