"""Workflows on trials, one layer above the estimator: fit a subject's trials
(:func:`~gc_ocp.workflow.fitting.fit`, with the input checks and a held-out stance) and the
sensitivity of a fit to processing choices (:mod:`.sensitivity`).

>>> import gc_ocp
>>> trial = gc_ocp.load_trial()               # the bundled example
>>> kin = gc_ocp.compute_kinematics(trial)
>>> report = gc_ocp.fit([(trial, kin)], holdout="right@0.407")   # seconds of Ipopt
>>> report.result.success, report.heldout_label
(True, 'test_small:right@0.407s')
>>> print(report.summary())                   # doctest: +ELLIPSIS
input checks:
...
held-out stance test_small:right@0.407s (the contact law and the sole corrections fixed at the values above, its pose re-estimated):
Ipopt: Solve_Succeeded in ...

Layers: :mod:`gc_ocp.estimation` (the NLP on stances; no files) < :mod:`gc_ocp.workflow` (trials,
checks) < :mod:`gc_ocp.diagnosis` (which effect causes the gap) < :mod:`gc_ocp.bench` (research
harness: synthetic recovery and the withheld-effect benchmark).
"""

from gc_ocp.workflow.fitting import MARGIN, FitReport, fit, fit_data
from gc_ocp.workflow.sensitivity import SensitivityReport, sensitivity

__all__ = ["MARGIN", "FitReport", "SensitivityReport", "fit", "fit_data", "sensitivity"]
