"""The calibrated model where users simulate: OpenSim files and models, and a CasADi function
(``docs/export.md``).

* :func:`opensim` (:func:`gc_ocp.export.opensim_export.export_opensim`): the subject's body
  with one ``SmoothSphereHalfSpaceForce`` per unit, the coordinates and ground reactions as
  OpenSim files, and OpenSim's own contact forces compared with the package's;
* :func:`casadi_function` / :func:`write_casadi`: the contact model as a ``casadi.Function``;
* :mod:`gc_ocp.export.calibrated`: a fit's calibrated model as plain data (what both share);
* :mod:`gc_ocp.export.forward`: a model run forward on a whole trial;
* :mod:`gc_ocp.export.opensim_files`: OpenSim's ``.trc``, ``.mot`` / ``.sto`` and
  ``ExternalLoads`` files, written.
"""

from gc_ocp.export.calibrated import CalibratedContact
from gc_ocp.export.casadi_export import casadi_function, write_casadi
from gc_ocp.export.forward import FootWrenches, foot_wrenches
from gc_ocp.export.opensim_export import export_opensim
from gc_ocp.export.opensim_files import external_loads_xml, write_grf, write_table, write_trc

opensim = export_opensim
"""``gc_ocp.export.opensim(fit, out, ...)``: :func:`~gc_ocp.export.opensim_export.export_opensim`."""

__all__ = (
    "CalibratedContact",
    "FootWrenches",
    "casadi_function",
    "export_opensim",
    "external_loads_xml",
    "foot_wrenches",
    "opensim",
    "write_casadi",
    "write_grf",
    "write_table",
    "write_trc",
)
