"""Loading walking trials: C3D (markers + plates) or OpenSim TRC + MOT/STO.

>>> from gc_ocp.io import load_trial
>>> trial = load_trial()            # the bundled Plug-in Gait example (MIT, see gc_ocp/data)
>>> [s.side for s in trial.stances]
['right', 'left', 'right']

Everything returned is in SI units and in the ``lab`` frame (Z up, X walking direction, Y left);
see :mod:`gc_ocp.trial`. Frames: OpenSim files are Y up and are mapped (x, y, z) -> (x, -z, y);
then the trial is turned about Z by a multiple of 90 degrees so that the subject walks along +X
(:func:`walking_rotation`). The total file -> lab rotation is ``Trial.lab_rotation``.
"""

from gc_ocp.gaps import MAX_GAP_FILL
from gc_ocp.io.checks import require_markers, stride_body_weight
from gc_ocp.io.estimates import estimate_belt_speed, estimate_height_from_markers
from gc_ocp.io.load import bundled_example_path, load_static, load_trial
from gc_ocp.io.orientation import MIN_OVERGROUND_SPEED, walking_rotation
from gc_ocp.io.report import describe_trial
from gc_ocp.io.stances import DEFAULT_THRESHOLD

__all__ = [
    "load_trial",
    "load_static",
    "bundled_example_path",
    "describe_trial",
    "require_markers",
    "estimate_height_from_markers",
    "estimate_belt_speed",
    "stride_body_weight",
    "walking_rotation",
    "DEFAULT_THRESHOLD",
    "MAX_GAP_FILL",
    "MIN_OVERGROUND_SPEED",
]
