"""Spatial math: rotations, SE(3) transforms and hand-matrix comparison (numpy only).

The lowest layer of manipkit: nothing here knows about robots or files of
robots. Conventions (docs/architecture.md): ``T_a_b`` is the pose of frame b
expressed in frame a (4x4 homogeneous); quaternions are (x, y, z, w); rpy is
(roll, pitch, yaw) with ``R = Rz(yaw) Ry(pitch) Rx(roll)`` as in URDF.
"""

from manipkit.spatial.rotations import *  # noqa: F401,F403
from manipkit.spatial.rotations import __all__ as _rotations_all
from manipkit.spatial.compare import *  # noqa: F401,F403
from manipkit.spatial.compare import __all__ as _compare_all

__all__ = [*_rotations_all, *_compare_all]
