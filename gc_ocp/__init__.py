"""gc_ocp: foot-ground contact model estimation for human walking from lab data.

Layers (each importable on its own):

* :mod:`gc_ocp.io` -- trial loading (C3D, OpenSim TRC + MOT) into a :class:`~gc_ocp.trial.Trial`.
* :mod:`gc_ocp.model` -- the 14-segment / 27-DOF body model as URDF, loaded by Pinocchio.
* :mod:`gc_ocp.kinematics` -- scaling, inverse kinematics and sole-point trajectories.
* :mod:`gc_ocp.contact` -- Hunt-Crossley / Coulomb contact laws, equivalent plate wrench, the
  seed's linear least squares and its study.
* :mod:`gc_ocp.estimation` -- joint kinematics-contact estimation (CasADi + Ipopt).
"""

__version__ = "0.1.0"
