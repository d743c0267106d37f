"""Joint kinematics-contact estimation (CasADi + Ipopt) on composable models.

>>> import gc_ocp
>>> from gc_ocp.estimation import build_estimation, solve, full_model
>>> trial = gc_ocp.load_trial(); kin = gc_ocp.compute_kinematics(trial)
>>> stances = gc_ocp.trial_stances(trial, kin)
>>> problem = build_estimation(stances, full_model())
>>> result = solve(problem)                   # seconds of Ipopt
>>> result.success, len(stances)
(True, 3)

Layout: :mod:`.variables` (named decision-variable blocks), :mod:`.components` (one file per
component: the physics each adds), :mod:`.frame` (the per-frame model composed from
components), :mod:`.compiled` (SX -> C cache), :mod:`.problem` (the NLP, no component known by
type), :mod:`.solve` (Ipopt), :mod:`.result` (plain-data result), :mod:`.starts` (the one start path, restarts,
a model frozen at a result), :mod:`.synthetic` (synthetic stances), :mod:`.plots`.

This is the core: it knows stances, never files (it imports nothing of :mod:`gc_ocp.io`).
Fitting trials (checks, stance cutting, held-out stance) is :mod:`gc_ocp.workflow`.
"""

from gc_ocp.estimation.components import (
    EFFECTS,
    REGISTRY,
    BeltSpeed,
    Component,
    ContactLaw,
    Param,
    PoseCorrection,
    SoleCorrection,
    SummaryRow,
    bare_seed_model,
    base_model,
    full_model,
    model_from_names,
    register,
    seed_model,
)
from gc_ocp.estimation.problem import EstimationProblem, Weights, build_estimation
from gc_ocp.estimation.result import EstimationResult
from gc_ocp.estimation.solve import IpoptOptions, result_at, solve
from gc_ocp.estimation.starts import frozen_model

__all__ = [
    "EFFECTS",
    "REGISTRY",
    "bare_seed_model",
    "base_model",
    "BeltSpeed",
    "Component",
    "ContactLaw",
    "EstimationProblem",
    "EstimationResult",
    "IpoptOptions",
    "Param",
    "PoseCorrection",
    "SoleCorrection",
    "SummaryRow",
    "Weights",
    "build_estimation",
    "frozen_model",
    "full_model",
    "model_from_names",
    "register",
    "result_at",
    "seed_model",
    "solve",
]
