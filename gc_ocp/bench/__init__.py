"""The research harness: how well the estimator and the diagnosis recover a known truth.

Public and documented because a user checking the package on their own lab's motion needs it
(``docs/diagnosis.md``, withheld-effect benchmark; ``gc-ocp benchmark-diagnosis``):

* :mod:`.recovery` -- synthetic recovery on real motion: the stances of a real trial, a truth
  fitted to them, the plate data that truth (plus an effect) predicts, with plate and marker noise;
* :mod:`.withheld` -- the withheld-effect benchmark of the diagnosis: each candidate effect
  injected into a truth at known magnitudes, the diagnosis run blind, the confusion table.

Why a package module and not scripts in ``benchmarks/``: ``gc-ocp benchmark-diagnosis`` and
notebook 03 run it, tests pin its behaviour, and every candidate effect says how it is injected
(``Component.inject``); the scripts in ``benchmarks/`` drive it at full size and keep the outputs.
"""
