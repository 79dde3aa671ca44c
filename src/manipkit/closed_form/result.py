"""One result type for every closed-form IK solver: :class:`ClosedFormSolutions`.

Planar 2R/3R (:mod:`manipkit.closed_form.planar`), decoupled arms
(:mod:`manipkit.closed_form.decoupled`) and the bundled-robot binding
(:func:`manipkit.closed_form.robots.analytic_ik`) all return it. The
numerical solver's :class:`manipkit.kinematics.ik.IKSolutions` has the same
properties, so one presenter prints either (docs/architecture.md, "IK results"):

=====================  ===========================================================
``solutions``          (k, n) read-only array, one joint vector per row, first solution first
``labels``             one str per row (``""`` where a solver has no name for it)
``count``              number of solutions: an int, or ``math.inf`` for a family
``reason``             one line: why there are that many (why none, which family), or ``""``
``success``            at least one row
``residual_position``  (k,) m, per row: distance between reached and wanted frame origin
``residual_rotation``  (k,) rad, per row: angle between reached and wanted orientation
``residuals``          (k, 2): the two above side by side
=====================  ===========================================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["ClosedFormSolutions", "read_only"]


def read_only(array, shape_tail: tuple[int, ...] = ()) -> np.ndarray:
    """A float copy of ``array`` that cannot be written to (an empty input gets shape ``(0, *shape_tail)``)."""
    copy = np.array(array, dtype=float)
    if copy.size == 0:
        copy = copy.reshape((0,) + tuple(shape_tail))
    copy.setflags(write=False)
    return copy


@dataclass(frozen=True, eq=False)
class ClosedFormSolutions:
    """Every closed-form IK solution for one target.

    Shares ``solutions``, ``labels``, ``count``, ``reason``, ``success``,
    ``residual_position``, ``residual_rotation`` and ``residuals`` with
    :class:`manipkit.kinematics.ik.IKSolutions` (module docstring).

    Attributes
    ----------
    solutions : ndarray, shape (k, n)
        One joint vector per row (rad, wrapped to (-pi, pi]; m for a
        prismatic joint), in the solver's order, read-only. For a family
        (``count`` infinite) a row holds one representative (the free joint
        at 0).
    labels : tuple of str
        One per row: the branch, e.g. ``"elbow-down"`` or
        ``"front, elbow up, no flip"``.
    count : int or float
        0, 1, 2, ... solutions, or ``math.inf`` when the rows stand for
        one-parameter families (``free_parameter`` names the free joints).
    reason : str
        One line saying why there are that many solutions, with the numbers
        (for none: how far out of reach, which limit).
    residual_position, residual_rotation : ndarray, shape (k,)
        Per row: position error (m) and rotation angle error (rad) of the
        row's forward kinematics (planar FK, the DH table, or the robot's
        URDF) against the target; 0 where the target has no orientation.
    free_parameter : str
        With an infinite ``count``: the free joint(s) by their textbook name,
        e.g. ``"q1"`` or ``"theta4"``; else ``""``.
    solver : str
        The closed-form function that answered, e.g. ``"decoupled.ik_stanford"``
        (set by :func:`manipkit.closed_form.robots.analytic_ik`).
    joint_names : tuple of str
        The joints the columns stand for (``()`` when the solver has no
        names for them).
    family : str or None
        The family in words (which joint is free and how the others follow).
    free_joints : tuple of int
        Columns (0-based) of the free joints.
    rejected : int
        Candidates dropped because their forward kinematics missed the target.
    outside_by : float
        Planar arms: how far (m) the target (2R) or wrist point (3R) lies
        outside the reachable annulus; 0.0 when reachable.
    side : str or None
        Planar arms: ``"too far"`` or ``"too close"`` when out of reach.
    """

    solutions: np.ndarray
    labels: tuple[str, ...]
    count: int | float
    reason: str
    residual_position: np.ndarray
    residual_rotation: np.ndarray
    free_parameter: str = ""
    solver: str = ""
    joint_names: tuple[str, ...] = ()
    family: str | None = None
    free_joints: tuple[int, ...] = ()
    rejected: int = 0
    outside_by: float = 0.0
    side: str | None = None

    @property
    def success(self) -> bool:
        """At least one solution (row)."""
        return len(self.labels) > 0

    @property
    def residuals(self) -> np.ndarray:
        """(k, 2): position (m) and rotation (rad) residual of each row."""
        return read_only(np.column_stack([self.residual_position, self.residual_rotation]), (2,))

    @property
    def infinite(self) -> bool:
        """True for one-parameter families of solutions."""
        return math.isinf(self.count)

    @property
    def singular(self) -> bool:
        """True when a row stands for a family (a joint is free)."""
        return bool(self.free_joints)

    @property
    def free_joint(self) -> int | None:
        """The first free joint's column, or None."""
        return self.free_joints[0] if self.free_joints else None
