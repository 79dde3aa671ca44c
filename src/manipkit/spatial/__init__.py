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

from __future__ import annotations

from manipkit.exports import homes_of, lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    **homes_of(
        "manipkit.spatial.rotations",
        "axis_angle_from_matrix", "check_rotation", "matrix_from_axis_angle", "matrix_from_quaternion",
        "matrix_from_rpy", "quaternion_from_matrix", "rot_x", "rot_y", "rot_z", "rotation_angle_between",
        "rotation_violations", "rpy_from_matrix", "wrap_angle",
    ),
    **homes_of(
        "manipkit.spatial.euler",
        "euler_zyx_from_matrix", "euler_zyz_from_matrix", "matrix_from_euler_zyx", "matrix_from_euler_zyz",
    ),
    **homes_of(
        "manipkit.spatial.forms",
        "FORMS", "ROUNDING_TOL", "SINGULAR_TOL", "NearestRotation", "RotationForms", "rotation_forms",
        "rotation_from_form", "rotation_from_matrix",
    ),
    **homes_of(
        "manipkit.spatial.transforms", "EXACT_ROTATION_TOL",
        "as_transforms", "check_transform", "invert_transform", "nearest_rotation", "pose_error",
        "projected_rotation", "transform_from_xyz_quaternion", "transform_from_xyz_rpy", "transform_violations",
    ),
    **homes_of("manipkit.spatial.compare", "ComparisonResult", "compare_transform"),
})
