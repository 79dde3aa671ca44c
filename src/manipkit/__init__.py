"""manipkit: URDF-driven manipulator kinematics on Pinocchio, without ROS.

>>> import manipkit
>>> robot = manipkit.load("course_arm")
>>> T_base_ee = robot.transform("base_link", "ee_link", robot.q(shoulder_joint=-1.34))

The layers (docs/architecture.md), each importing only those below it:
:mod:`manipkit.spatial`, :mod:`manipkit.description`,
:mod:`manipkit.kinematics`, :mod:`manipkit.dh`, :mod:`manipkit.closed_form`,
:mod:`manipkit.analysis`, :mod:`manipkit.app`.

Heavy modules (Pinocchio, numba) load on first use, so the command line starts fast.
"""

from __future__ import annotations

import importlib
import sys
import warnings

__version__ = "0.1.0"
from manipkit.errors import ManipkitError

#: Public name -> the module that holds it, imported on first use (``import manipkit`` stays cheap,
#: so ``tf-between`` starts fast; the names still show in ``dir(manipkit)`` and tab completion).
_LAZY = {
    "load": "manipkit.kinematics.robot",
    "Robot": "manipkit.kinematics.robot",
    "ik_solver": "manipkit.kinematics.ik",
    "IKResult": "manipkit.ik.result",
    "IKBatch": "manipkit.ik.result",
    "IKSolutions": "manipkit.kinematics.ik",
    "DHTable": "manipkit.dh.table",
    "dh_fk": "manipkit.dh.table",
    "load_dh": "manipkit.dh.files",
    "check_dh": "manipkit.dh.check",
    "analytic_ik": "manipkit.closed_form.robots",
    "analytic_ik_many": "manipkit.closed_form.robots",
    "chain_family": "manipkit.closed_form.families",
    "manipulability": "manipkit.analysis.manipulability",
    "singular_values": "manipkit.analysis.manipulability",
    "velocity_ellipsoid": "manipkit.analysis.manipulability",
    "force_ellipsoid": "manipkit.analysis.manipulability",
    "global_conditioning_index": "manipkit.analysis.dexterity",
    "singular_families": "manipkit.analysis.singularities",
    "singular_family_at": "manipkit.analysis.singularities",
    "ik_many": "manipkit.kinematics.ik_many",
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


# --------------------------------------------------------------------------
# Module paths of release 0.1 (before the subpackages): they keep working for
# one release, with a DeprecationWarning naming the new path.

MOVED_MODULES = {
    "manipkit.rotations": "manipkit.spatial.rotations",
    "manipkit.compare": "manipkit.spatial.compare",
    "manipkit.robots": "manipkit.description.sources",
    "manipkit.validate": "manipkit.description.validate",
    "manipkit.tree": "manipkit.description.tree",
    "manipkit.model": "manipkit.kinematics.robot",
    "manipkit.chain": "manipkit.kinematics.fk_kernel",
    "manipkit.ik_kernel": "manipkit.kinematics.ik_kernel",
    "manipkit.dh_check": "manipkit.dh.check",
    "manipkit.dh_from_urdf": "manipkit.dh.from_urdf",
    "manipkit.planar": "manipkit.closed_form.planar",
    "manipkit.decoupled": "manipkit.closed_form.decoupled",
    "manipkit.workspace": "manipkit.analysis.workspace",
    "manipkit.cli": "manipkit.app.cli",
    "manipkit.viewer": "manipkit.app.viewer",
    "manipkit.pose": "manipkit.app.pose",
}


class _MovedModuleFinder:
    """Answers ``import manipkit.<old name>`` with the module at its new path (a meta path finder and loader).

    Not derived from ``importlib.abc`` on purpose: importing it costs about 10 ms at every CLI start.
    """

    def find_spec(self, fullname, path=None, target=None):
        if fullname in MOVED_MODULES:
            from importlib.machinery import ModuleSpec

            return ModuleSpec(fullname, self)
        return None

    def create_module(self, spec):
        return None  # a placeholder, replaced in sys.modules by the real module below

    def exec_module(self, module):
        new = MOVED_MODULES[module.__name__]
        warnings.warn(f"{module.__name__} moved to {new}; the old path goes in manipkit 0.3", DeprecationWarning, stacklevel=2)
        sys.modules[module.__name__] = importlib.import_module(new)


if not any(isinstance(finder, _MovedModuleFinder) for finder in sys.meta_path):
    sys.meta_path.append(_MovedModuleFinder())
