"""Spatial math: rotations, Euler angles, SE(3) transforms and hand-matrix comparison (numpy only).

The lowest layer of manipkit: nothing here knows about robots or files of
robots. Conventions (docs/architecture.md): ``T_a_b`` is the pose of frame b
expressed in frame a (4x4 homogeneous); quaternions are (x, y, z, w); rpy is
(roll, pitch, yaw) with ``R = Rz(yaw) Ry(pitch) Rx(roll)`` as in URDF.

- :mod:`manipkit.spatial.rotations`: rotation matrices, rpy, quaternions, axis-angle, checks.
- :mod:`manipkit.spatial.euler`: Euler ZYX and ZYZ angles.
- :mod:`manipkit.spatial.forms`: one rotation in every form, with the singular cases named.
- :mod:`manipkit.spatial.transforms`: SE(3): build, invert, check, pose error.
- :mod:`manipkit.spatial.compare`: a hand-derived transform against the model's, with a diagnosis.
"""

from manipkit.spatial.compare import *  # noqa: F401,F403
from manipkit.spatial.compare import __all__ as _compare_all
from manipkit.spatial.euler import *  # noqa: F401,F403
from manipkit.spatial.euler import __all__ as _euler_all
from manipkit.spatial.forms import *  # noqa: F401,F403
from manipkit.spatial.forms import __all__ as _forms_all
from manipkit.spatial.rotations import *  # noqa: F401,F403
from manipkit.spatial.rotations import __all__ as _rotations_all
from manipkit.spatial.transforms import *  # noqa: F401,F403
from manipkit.spatial.transforms import __all__ as _transforms_all

__all__ = [*_rotations_all, *_euler_all, *_forms_all, *_transforms_all, *_compare_all]
