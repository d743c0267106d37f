"""Foot-ground contact model: laws, equivalent wrench, stiffness fit, seed reproduction.

Modules: :mod:`~gc_ocp.contact.laws` (one CasADi definition of each law),
:mod:`~gc_ocp.contact.channels` (channel names, order, normalisation),
:mod:`~gc_ocp.contact.equivalent_wrench` (Eqs 4-9), :mod:`~gc_ocp.contact.lls` (the seed's linear
least squares), :mod:`~gc_ocp.contact.synthetic` (the seed's synthetic sets),
:mod:`~gc_ocp.contact.seed_study` (Tables 1-2), :mod:`~gc_ocp.contact.plots`.
"""

from gc_ocp.contact.channels import CHANNELS, TABLE_KEYS, channel_rms_pct, k_rms_pct
from gc_ocp.contact.equivalent_wrench import (
    LawParams,
    model_cop,
    model_free_moment,
    model_wrench,
    wrench_function,
    wrench_per_unit_stiffness,
)
from gc_ocp.contact.laws import (
    DEFAULT_SMOOTHING,
    Smoothing,
    friction_force_function,
    normal_force_function,
    unit_force_function,
    unit_forces,
)
from gc_ocp.contact.lls import (
    SEED_LAW,
    LLSResult,
    fit_stiffness_lls,
    stances_from_trial,
)

__all__ = [
    "CHANNELS",
    "TABLE_KEYS",
    "channel_rms_pct",
    "k_rms_pct",
    "DEFAULT_SMOOTHING",
    "Smoothing",
    "friction_force_function",
    "normal_force_function",
    "unit_force_function",
    "unit_forces",
    "SEED_LAW",
    "LLSResult",
    "fit_stiffness_lls",
    "stances_from_trial",
    "LawParams",
    "model_cop",
    "model_free_moment",
    "model_wrench",
    "wrench_function",
    "wrench_per_unit_stiffness",
]
