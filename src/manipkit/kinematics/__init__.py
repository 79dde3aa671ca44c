"""Kinematics of a loaded robot: :class:`Robot` (Pinocchio), the joint vector (mimic, floating and planar joints),
batched FK, Jacobians, collision geometry and checks
(Pinocchio + coal) against the robot itself, the floor and a world file.

The modules load on first use (Pinocchio here, numba in the compiled kernels),
so ``tf-between`` pays only for what it runs.
"""

from __future__ import annotations

from manipkit.exports import homes_of, lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    **homes_of("manipkit.kinematics.robot", "Robot", "load"),
    **homes_of("manipkit.kinematics.chain", "Chain", "JointAxes"),
    **homes_of("manipkit.kinematics.jacobian", "jacobian", "jacobians"),
    **homes_of("manipkit.kinematics.collisions", "collisions", "collision_free", "CollisionChecker", "CollisionReport"),
    **homes_of("manipkit.kinematics.collision_geometry", "collision_geometry"),
    **homes_of("manipkit.kinematics.world", "read_world"),
})
