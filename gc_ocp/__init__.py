"""gc_ocp: foot-ground contact models of human walking, estimated from lab data.

The public API, importable from the top level:

>>> import gc_ocp
>>> trial = gc_ocp.load_trial()                   # the bundled example; or load_trial("walk.c3d")
>>> kin = gc_ocp.compute_kinematics(trial)        # IK and sole-point trajectories
>>> report = gc_ocp.fit([(trial, kin)], model=gc_ocp.full_model(), holdout="right@0.407")
>>> print(report.summary())                       # doctest: +ELLIPSIS
input checks:
...
Ipopt: Solve_Succeeded in ...
>>> # skipped: a diagnosis is minutes of Ipopt fits (tests/test_diagnosis.py runs small ones)
>>> diagnosis = gc_ocp.diagnose([(trial, kin)])   # which unmodelled effect  # doctest: +SKIP
>>> print(diagnosis.summary())                    # doctest: +SKIP

Layers (each importable on its own): :mod:`gc_ocp.io` (trial loading), :mod:`gc_ocp.model` (the
27-DOF body model), :mod:`gc_ocp.kinematics` (IK, sole points), :mod:`gc_ocp.stance` (the stance
type), :mod:`gc_ocp.contact` (contact laws, equivalent wrench, the seed's study),
:mod:`gc_ocp.estimation` (composable joint kinematics-contact estimation, CasADi + Ipopt),
:mod:`gc_ocp.diagnosis` (where the model-data gap lies, which effect causes it, how far it shrinks),
:mod:`gc_ocp.batch` (studies of many subjects on Dask: ``gc_ocp.batch.run(manifest, out)``),
:mod:`gc_ocp.export` (the calibrated model for OpenSim and CasADi simulations).
Names are imported on first use, so ``import gc_ocp`` stays light.

Where to start: the five calls above, each with its units and an example in its help
(``help(gc_ocp.load_trial)``, ``help(gc_ocp.fit)``, ...); the notebooks in ``notebooks/`` (01
the seed study, 02 a fit, 03 the diagnosis); the README for the command line. SI units
throughout (m, s, N, kg), arrays time-first; the usual wrong inputs raise :class:`InputError` (or another
:class:`GcOcpError`) that names the fix.
"""

from __future__ import annotations

import importlib

from gc_ocp._version import __version__

_PUBLIC = {
    # loading and kinematics
    "load_trial": "gc_ocp.io",
    "load_static": "gc_ocp.io",
    "describe_trial": "gc_ocp.io",
    "Trial": "gc_ocp.trial",
    "compute_kinematics": "gc_ocp.kinematics",
    "StanceData": "gc_ocp.stance",
    "stance_data": "gc_ocp.stance",
    "trial_stances": "gc_ocp.stance",
    "SoleLayout": "gc_ocp.foot",
    "SEED_LAYOUT": "gc_ocp.foot",
    # estimation
    "fit": "gc_ocp.workflow",
    "FitReport": "gc_ocp.workflow",
    "EstimationResult": "gc_ocp.estimation",
    "build_estimation": "gc_ocp.estimation",
    "solve": "gc_ocp.estimation",
    "IpoptOptions": "gc_ocp.estimation",
    "Weights": "gc_ocp.estimation",
    "Component": "gc_ocp.estimation",
    "ContactLaw": "gc_ocp.estimation",
    "Param": "gc_ocp.estimation",
    "SoleCorrection": "gc_ocp.estimation",
    "PoseCorrection": "gc_ocp.estimation",
    "BeltSpeed": "gc_ocp.estimation",
    "seed_model": "gc_ocp.estimation",
    "full_model": "gc_ocp.estimation",
    "model_from_names": "gc_ocp.estimation",
    "register": "gc_ocp.estimation",
    "base_model": "gc_ocp.estimation",
    "bare_seed_model": "gc_ocp.estimation",
    "EFFECTS": "gc_ocp.estimation",
    # the sim-to-real diagnosis
    "diagnose": "gc_ocp.diagnosis",
    "diagnose_stances": "gc_ocp.diagnosis",
    "Diagnosis": "gc_ocp.diagnosis",
    # plots (figures are returned, never shown)
    "plot_fit": "gc_ocp.estimation.plots",
    # errors
    "GcOcpError": "gc_ocp.errors",
    "InputError": "gc_ocp.errors",
    "MarkerError": "gc_ocp.errors",
    "PlateError": "gc_ocp.errors",
    "UnitsError": "gc_ocp.errors",
    "ModelError": "gc_ocp.errors",
    "SolveError": "gc_ocp.errors",
}

_SUBPACKAGES = (
    "batch",
    "bench",
    "contact",
    "diagnosis",
    "estimation",
    "execution",
    "export",
    "html",
    "io",
    "kinematics",
    "model",
    "workflow",
)
"""Layers reachable as attributes after a bare ``import gc_ocp`` (``gc_ocp.estimation.…``)."""

__all__ = ["__version__", *_PUBLIC]


def __getattr__(name: str):
    if name in _PUBLIC:
        value = getattr(importlib.import_module(_PUBLIC[name]), name)
    elif name in _SUBPACKAGES:
        value = importlib.import_module(f"gc_ocp.{name}")
    else:
        raise AttributeError(f"module 'gc_ocp' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_PUBLIC) | set(_SUBPACKAGES))
