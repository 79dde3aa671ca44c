"""The one IK dispatcher: :func:`ik` for one target (in transit: numerical IK until the closed forms join it)."""

from __future__ import annotations

__all__ = ["ik"]


def ik(robot, target, *args, **kwargs):
    """Joint values that put the tip at ``target`` (T_base_tip); see :func:`manipkit.kinematics.ik.ik`."""
    from manipkit.kinematics.ik import ik as numerical_ik

    return numerical_ik(robot, target, *args, **kwargs)
