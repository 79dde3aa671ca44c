"""What the closed-form solvers return: manipkit's one IK result type, and the closed forms' check tolerance.

Planar 2R/3R (:mod:`manipkit.closed_form.planar`, :mod:`manipkit.closed_form.planar_modes`),
decoupled arms (:mod:`manipkit.closed_form.decoupled`) and the bundled-robot
binding (:func:`manipkit.ik.textbook.analytic_ik`) all return
:class:`manipkit.ik.result.IKResult`, the type numerical IK returns too
(docs/site/internals/ik-results.md); the planar batch solvers return
:class:`manipkit.ik.result.IKBatch`, as ``ik_many`` does.

What a solver solves, and what was asked, is one of four modes
(:data:`MODES`): ``PLANAR_POSITION`` (x, y), ``PLANAR_POSE`` (x, y, phi),
``SPATIAL_POSITION`` (x, y, z) and ``SPATIAL_POSE`` (x, y, z and the
rotation). A result records the mode it answers in ``mode``; its residuals
are those of that mode (rotation 0 in a position mode), measured by forward
kinematics of each row (the solver's DH table, or the robot's URDF) with
:func:`manipkit.spatial.transforms.pose_residuals`, never taken from the
solver's algebra. A component of the target the arm cannot meet (the
orientation for a 2R arm, a height off a planar arm's plane, a tilted SCARA
tool, a point out of reach) gives 0 solutions and is named, with its size,
in ``unmet``.
"""

from __future__ import annotations

from manipkit.ik.result import (
    PLANAR_POSE,
    PLANAR_POSITION,
    SPATIAL_POSE,
    SPATIAL_POSITION,
    IKBatch,
    IKResult,
    read_only,
)

__all__ = [
    "CHECK_TOL",
    "MODES",
    "PLANAR_POSE",
    "PLANAR_POSITION",
    "SPATIAL_POSE",
    "SPATIAL_POSITION",
    "IKBatch",
    "IKResult",
    "read_only",
]

#: The four things a closed-form solver can solve (and a user can ask of one).
MODES = (PLANAR_POSITION, PLANAR_POSE, SPATIAL_POSITION, SPATIAL_POSE)
#: Residual (m and rad) within which a row's forward kinematics must reproduce the target to be returned.
CHECK_TOL = 1e-9
