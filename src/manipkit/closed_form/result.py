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

What a solver solves, and what was asked, is one of four modes
(:data:`MODES`): ``PLANAR_POSITION`` (x, y), ``PLANAR_POSE`` (x, y, phi),
``SPATIAL_POSITION`` (x, y, z) and ``SPATIAL_POSE`` (x, y, z and the
rotation). A result records the mode it answers in ``mode``; its residuals
are those of that mode (rotation 0 in a position mode), measured by forward
kinematics of each row (the solver's DH table, or the robot's URDF), never
taken from the solver's algebra. A component of the target the arm cannot
meet (the orientation for a 2R arm, a height off a planar arm's plane, a
tilted SCARA tool, a point out of reach) gives 0 solutions and is named,
with its size, in ``unmet``.
"""

from __future__ import annotations

import html
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from manipkit.errors import ClosedFormIKError
from manipkit.text import short_text

__all__ = [
    "CHECK_TOL",
    "MODES",
    "PLANAR_POSE",
    "PLANAR_POSITION",
    "SPATIAL_POSE",
    "SPATIAL_POSITION",
    "ClosedFormSolutions",
    "read_only",
    "solutions_html",
]

PLANAR_POSITION = "planar position (x, y)"
PLANAR_POSE = "planar pose (x, y, phi)"
SPATIAL_POSITION = "spatial position (x, y, z)"
SPATIAL_POSE = "spatial pose (x, y, z, R)"
#: The four things a closed-form solver can solve (and a user can ask for).
MODES = (PLANAR_POSITION, PLANAR_POSE, SPATIAL_POSITION, SPATIAL_POSE)
#: Residual (m and rad) within which a row's forward kinematics must reproduce the target to be returned.
CHECK_TOL = 1e-9


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
        at 0), or, when the free parameter is not a joint (a position asked
        of a planar 3R arm or a SCARA), the members at a few sampled values
        of it (:meth:`members` gives any others).
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
    mode : str
        What this result answers, one of :data:`MODES` (``""`` if unset).
    unmet : tuple of (str, float)
        With no solution: each component of the target the arm cannot meet
        and by how much (m or rad), e.g. ``(("orientation", 1.14),)`` or
        ``(("z", 0.3),)``; ``()`` otherwise.
    family_function : callable or None
        For a family whose free parameter is not a joint (``phi`` of a planar
        3R arm asked for a position, ``theta4`` of a SCARA asked for a
        position): ``values -> ClosedFormSolutions``, the members at those
        values of the free parameter (see :meth:`members`).
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
    mode: str = ""
    unmet: tuple[tuple[str, float], ...] = ()
    family_function: Callable[..., ClosedFormSolutions] | None = field(default=None, repr=False)

    def members(self, values) -> ClosedFormSolutions:
        """The members of the family at ``values`` of its free parameter (``free_parameter``).

        Every returned row is checked by forward kinematics like the
        solver's own rows. Raises :class:`manipkit.errors.ClosedFormIKError`
        when this result is not a family with a parameter.
        """
        if self.family_function is None:
            raise ClosedFormIKError(
                "this result is not a family of solutions with a free parameter "
                f"(count = {self.count}); members() applies to position-only answers of planar 3R and SCARA arms"
            )
        return self.family_function(values)

    def _repr_html_(self) -> str:
        """A small HTML table for Jupyter: label, joint values, residuals, success (see :func:`solutions_html`)."""
        count = "infinitely many" if self.infinite else str(self.count)
        head = f"closed form{' (' + self.solver + ')' if self.solver else ''}: {count} solution(s)"
        if self.mode:
            head += f", {self.mode}"
        if self.free_parameter:
            head += f", free: {self.free_parameter}"
        return solutions_html(self, head)

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


def solutions_html(result, head: str, joint_names=()) -> str:
    """An HTML table of an IK result's rows: label, joint values, residuals (m, rad) and success (every row
    returned has passed the forward-kinematics check; the caption says whether there is any).

    ``result`` is anything with the shared properties (docs/architecture.md,
    "IK results"); ``head`` is the caption; the reason follows the table.
    Text is escaped.
    """
    names = tuple(getattr(result, "joint_names", ()) or joint_names)
    n = result.solutions.shape[1] if result.solutions.ndim == 2 else 0
    names = names if len(names) == n else tuple(f"q{i + 1}" for i in range(n))
    cells = ["#", "label", *names, "position (m)", "rotation (rad)", "success"]
    lines = [f"<table><caption>{html.escape(head)}; success: {result.success}</caption>",
             "<tr>" + "".join(f"<th>{html.escape(c)}</th>" for c in cells) + "</tr>"]
    rows = zip(result.labels, result.solutions, result.residual_position, result.residual_rotation)
    for index, (label, q, position, rotation) in enumerate(rows, start=1):
        values = [str(index), label, *(short_text(float(v)) for v in q),
                  short_text(float(position), 3), short_text(float(rotation), 3), "True"]  # every row passed FK
        lines.append("<tr>" + "".join(f"<td>{html.escape(v)}</td>" for v in values) + "</tr>")
    lines.append("</table>")
    if result.reason:
        lines.append(f"<p>{html.escape(result.reason)}</p>")
    return "\n".join(lines)
