"""manipkit: URDF-driven manipulator kinematics on Pinocchio, without ROS.

>>> import manipkit
>>> robot = manipkit.load("course_arm")
>>> T_base_ee = robot.transform("base_link", "ee_link", robot.q(shoulder_joint=-1.34))

Heavy modules (Pinocchio) load on first use, so the command line starts fast.
"""

from __future__ import annotations

__version__ = "0.1.0"
__all__ = ["load", "Robot", "ManipkitError"]

from manipkit.errors import ManipkitError


def __getattr__(name: str):
    if name in ("load", "Robot"):
        from manipkit import model

        return getattr(model, name)
    raise AttributeError(f"module 'manipkit' has no attribute {name!r}")
