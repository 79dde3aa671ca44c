"""Statics of a chain: joint torques that hold a payload and resist wrenches, payload capacity, and the audit of a
description's inertias (docs/architecture.md, "statics": imports kinematics and spatial).

Convention everywhere: ``tau = g(q) - sum J^T w`` (Pinocchio's ``computeStaticTorque``), the torque the motors
produce to hold still, with each wrench applied *on* the robot.
"""

from __future__ import annotations

from manipkit.exports import homes_of, lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    **homes_of("manipkit.statics.torques", "Payload", "StaticTorques", "Wrench", "static_torques"),
    **homes_of("manipkit.statics.capacity", "PayloadCapacity", "payload_capacity"),
    **homes_of("manipkit.statics.audit", "Finding", "InertiaAudit", "inertia_audit"),
    **homes_of("manipkit.statics.dynamics", "TrajectoryTorques", "trajectory_torques"),
    **homes_of("manipkit.statics.sensitivity", "TorqueBand", "gravity_contributions", "torque_band"),
    **homes_of("manipkit.statics.capability", "ForceCapacity", "force_capacity"),
    **homes_of("manipkit.statics.diagram", "PayloadDiagram", "draw_payload_diagram", "payload_diagram"),
})
