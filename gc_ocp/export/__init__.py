"""The calibrated model where users simulate: OpenSim files and models, and a CasADi function.

* :mod:`gc_ocp.export.forward`: the model run forward on a whole trial (each foot's wrench on
  every frame);
* :mod:`gc_ocp.export.opensim_files`: OpenSim's ``.trc``, ``.mot`` / ``.sto`` and
  ``ExternalLoads`` files, written.
"""

from gc_ocp.export.forward import FootWrenches, foot_wrenches
from gc_ocp.export.opensim_files import external_loads_xml, write_grf, write_table, write_trc

__all__ = (
    "FootWrenches",
    "external_loads_xml",
    "foot_wrenches",
    "write_grf",
    "write_table",
    "write_trc",
)
