"""Closed-form IK of the bundled textbook arms, bound to their robot objects: :func:`analytic_ik`.

The solvers themselves (:mod:`manipkit.closed_form.planar`,
:mod:`manipkit.closed_form.decoupled`) work on numbers and DH tables; this
module reads a loaded robot's xacro arguments (link lengths, offsets,
prismatic limits), calls the matching solver and checks every solution
through the robot's own URDF model. It takes the robot object and never
imports the kinematics layer (docs/architecture.md, "Layers").

Conventions: ``target`` is ``T_base_link_ee_link`` (4x4, metres), the same
direction as ``robot.transform("base_link", "ee_link", q)``; solutions are
joint vectors in ``robot.joint_names`` order.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from manipkit.closed_form import decoupled, planar
from manipkit.closed_form.result import ClosedFormSolutions, read_only
from manipkit.errors import IKOptionError
from manipkit.spatial.transforms import check_transform, pose_error

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["ANALYTIC_SOLVERS", "analytic_ik"]


def _planar_2r(T: np.ndarray, args: dict) -> ClosedFormSolutions:
    return replace(planar.ik_2r(T[0, 3], T[1, 3], float(args["l1"]), float(args["l2"])),
                   solver="planar.ik_2r (position x, y)")


def _planar_3r(T: np.ndarray, args: dict) -> ClosedFormSolutions:
    phi = math.atan2(T[1, 0], T[0, 0])
    result = planar.ik_3r(T[0, 3], T[1, 3], phi, *(float(args[k]) for k in ("l1", "l2", "l3")))
    return replace(result, solver="planar.ik_3r (x, y, phi)")


def _decoupled(function: str, names: tuple[str, ...], limits=None) -> Callable[[np.ndarray, dict], ClosedFormSolutions]:
    def solve(T: np.ndarray, args: dict) -> ClosedFormSolutions:
        kwargs = {name: float(args[name]) for name in names}
        if limits is not None:
            kwargs["d3_limits"] = limits(args)
        return replace(getattr(decoupled, function)(T, **kwargs), solver=f"decoupled.{function}")

    return solve


#: Bundled robot name -> closed-form solver of ``(T_base_link_ee_link, xacro arguments)``.
ANALYTIC_SOLVERS: dict[str, Callable[[np.ndarray, dict], ClosedFormSolutions]] = {
    "planar_2r": _planar_2r,
    "planar_3r": _planar_3r,
    "scara": _decoupled("ik_scara", ("a1", "a2", "d1", "d4"), lambda a: (0.0, float(a["d3_max"]))),
    "stanford_arm": _decoupled("ik_stanford", ("d1", "d2", "d6"), lambda a: (float(a["d3_min"]), float(a["d3_max"]))),
    "elbow_arm": _decoupled("ik_elbow", ("d1", "a2", "a3", "d6")),
}


def analytic_ik(robot: Robot, target, *, tol: float = 1e-9) -> ClosedFormSolutions:
    """All closed-form IK solutions for ``T_base_link_ee_link = target`` on a bundled textbook arm.

    The solver parameters (link lengths, offsets, prismatic limits) are the
    robot's xacro arguments, so ``load("stanford_arm", d2=0.2)`` is solved
    with d2 = 0.2. Each solution is checked again through the URDF model
    (``robot.transform("base_link", "ee_link", q)``) and kept when both
    residuals are within ``tol``; the residuals are those of the URDF.

    Parameters
    ----------
    robot : manipkit.kinematics.robot.Robot
        ``planar_2r``, ``planar_3r``, ``scara``, ``stanford_arm`` or ``elbow_arm``.
    target : array_like, shape (4, 4)
        ``T_base_link_ee_link`` (metres); checked by
        :func:`manipkit.spatial.transforms.check_transform`. ``planar_2r``
        uses its position only (its rotation residual is 0).
    tol : float, keyword-only
        Residual tolerance of the URDF check (m and rad).

    Returns
    -------
    ClosedFormSolutions
        ``solver`` names the function used; ``solutions`` are joint vectors
        in ``robot.joint_names`` order; ``count``, ``reason``, ``labels``
        and the family fields are the solver's.

    Raises
    ------
    IKOptionError
        If the robot has no closed-form solver here (the message lists those that do).
    InvalidTransformError
        ``target`` is not a 4x4 homogeneous transform.

    Examples
    --------
    >>> import manipkit
    >>> robot = manipkit.load("planar_2r")
    >>> result = analytic_ik(robot, robot.transform("base_link", "ee_link", [0.3, 0.5]))
    >>> result.solver, result.count, result.labels
    ('planar.ik_2r (position x, y)', 2, ('elbow-down', 'elbow-up'))
    """
    solve = ANALYTIC_SOLVERS.get(robot.source.name) if robot.source.origin == "bundled" else None
    if solve is None:
        raise IKOptionError(
            f"no closed-form solver for robot '{robot.name}'; closed forms exist for "
            f"{', '.join(ANALYTIC_SOLVERS)} (use numerical IK otherwise)"
        )
    T = check_transform(target, what="IK target")
    result = solve(T, robot.xacro_args)
    n = len(robot.joint_names)
    rows = [i for i, q in enumerate(result.solutions) if q.size == n]
    Q = np.array([result.solutions[i] for i in rows], dtype=float).reshape(-1, n)
    T_reached = np.array([robot.transform("base_link", "ee_link", q, check_limits=False) for q in Q]).reshape(-1, 4, 4)
    position, rotation = (np.atleast_1d(e) for e in pose_error(T, T_reached))
    if robot.source.name == "planar_2r":
        rotation = np.zeros_like(position)  # a position target: the tool's orientation is free
    keep = (position <= tol) & (rotation <= tol)
    return replace(
        result,
        solutions=read_only(Q[keep], (n,)),
        labels=tuple(result.labels[i] for i, k in zip(rows, keep) if k),
        residual_position=read_only(position[keep]),
        residual_rotation=read_only(rotation[keep]),
        joint_names=robot.joint_names,
    )
