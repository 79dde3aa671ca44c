"""manipkit: URDF-driven manipulator kinematics on Pinocchio, without ROS.

>>> import manipkit
>>> robot = manipkit.load("course_arm")
>>> T_base_ee = robot.transform("base_link", "ee_link", robot.q(shoulder_joint=-1.34))

The layers (docs/architecture.md), each importing only those below it:
:mod:`manipkit.kernels`, :mod:`manipkit.spatial`, :mod:`manipkit.description`,
:mod:`manipkit.kinematics`, :mod:`manipkit.closed_form`, :mod:`manipkit.dh`,
:mod:`manipkit.ik`, :mod:`manipkit.analysis`, :mod:`manipkit.app`.
``manipkit.ik(robot, T_base_tip)`` is the one IK dispatcher (closed form where
the chain has one, numerical otherwise; :mod:`manipkit.ik`).

Heavy modules (Pinocchio, numba) load on first use, so the command line starts fast.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"
from manipkit.errors import ManipkitError

#: Public name -> the module that holds it, imported on first use (``import manipkit`` stays cheap,
#: so ``tf-between`` starts fast; the names still show in ``dir(manipkit)`` and tab completion).
_LAZY = {
    "load": "manipkit.kinematics.robot",
    "Robot": "manipkit.kinematics.robot",
    "IKResult": "manipkit.ik.result",
    "IKBatch": "manipkit.ik.result",
    "DHTable": "manipkit.dh.table",
    "dh_fk": "manipkit.dh.table",
    "load_dh": "manipkit.dh.files",
    "check_dh": "manipkit.dh.check",
    "chain_family": "manipkit.ik.families",
    "IKFailure": "manipkit.ik.result",
    "manipulability": "manipkit.analysis.manipulability",
    "singular_values": "manipkit.analysis.manipulability",
    "velocity_ellipsoid": "manipkit.analysis.manipulability",
    "force_ellipsoid": "manipkit.analysis.manipulability",
    "global_conditioning_index": "manipkit.analysis.dexterity",
    "singular_families": "manipkit.analysis.singularities",
    "singular_family_at": "manipkit.analysis.singularities",
    "ik_many": "manipkit.ik.dispatch",
    "plan_path": "manipkit.paths.plan",
    "collisions": "manipkit.kinematics.collisions",
    "collision_free": "manipkit.kinematics.collisions",
    "matrix_from_rpy": "manipkit.spatial.rotations",
    "rpy_from_matrix": "manipkit.spatial.rotations",
    "matrix_from_quaternion": "manipkit.spatial.rotations",
    "quaternion_from_matrix": "manipkit.spatial.rotations",
    "matrix_from_axis_angle": "manipkit.spatial.rotations",
    "axis_angle_from_matrix": "manipkit.spatial.rotations",
    "matrix_from_euler_zyx": "manipkit.spatial.euler",
    "euler_zyx_from_matrix": "manipkit.spatial.euler",
    "matrix_from_euler_zyz": "manipkit.spatial.euler",
    "euler_zyz_from_matrix": "manipkit.spatial.euler",
    "invert_transform": "manipkit.spatial.transforms",
    "transform_from_xyz_rpy": "manipkit.spatial.transforms",
}
#: Modules offered at the top (``manipkit.reachmap.build(robot)``, ``manipkit.reachmap.load(path)``; ``manipkit.ik``,
#: the IK package, is callable: ``manipkit.ik(robot, T)`` is its dispatcher).
_LAZY_MODULES = {"reachmap": "manipkit.analysis.reachmap", "ik": "manipkit.ik"}
__all__ = ["ManipkitError", *_LAZY, *_LAZY_MODULES]


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    if name in _LAZY_MODULES:
        return importlib.import_module(_LAZY_MODULES[name])
    raise AttributeError(f"module 'manipkit' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY) | set(_LAZY_MODULES))
