"""Singular configurations: the known families of the textbook arms.

A configuration is singular when the geometric Jacobian (6 x n, rows vx, vy,
vz, wx, wy, wz, docs/architecture.md "Conventions") loses rank among the rows
the arm can move: a planar 2R moves (vx, vy), a planar 3R (vx, vy, wz), a
SCARA (vx, vy, vz, wz), the spatial arms all six. :func:`singular_families`
lists, for the bundled textbook arms, the families of singular configurations
derived by hand (below), each with a distance over q that is zero on the
family and a sampler of random members; :func:`families_at` names every
family a configuration is in (:func:`singular_family_at` the first).
:func:`manipkit.analysis.jacobian_report.jacobian_report` decides whether a
configuration is singular and says what is lost there.

Derivations (lengths as in robots/dh/*.yaml; ``s2 = sin q2``, ``c23 = cos(q2 + q3)``):

- **planar 2R**: ``det J_v = l1 l2 s2`` (J_v the 2 x 2 block of vx, vy), zero
  for ``q2 = 0`` or ``pi``: the links are in line and the tip cannot move along them.
- **planar 3R**: rows (vx, vy, wz): subtracting column 3 from columns 1 and 2
  leaves ``det = l1 l2 s2``, so ``q2 = 0`` or ``pi``. Position only
  (vx, vy; 2 x 3): rank 1 needs every column ``z x (p - o_i)`` parallel, so
  the joints and the tip in line: ``q2`` and ``q3`` both 0 or pi.
- **SCARA**: rows (vx, vy, vz, wz): the quill gives vz alone and joint 4
  wz alone, so ``det = a1 a2 s2``: the elbow straight, ``q2 = 0`` or ``pi``.
- **Stanford arm**: at the wrist centre the wrist's columns have no linear
  part, so ``det J = det J_11 det J_22`` with ``det J_22 = s5`` (z3 and z5
  at angle q5) and ``det J_11 = d3^2 s2`` (the spherical coordinates q1, q2,
  d3 of the wrist centre; the shoulder offset d2 cancels):
  ``det J = d3^2 s2 s5`` (Spong). Families: wrist ``q5 = 0, pi`` (joints 4
  and 6 on one axis); boom parallel to joint 1's axis ``q2 = 0, pi`` (joints
  1 and 2 then move the wrist centre along the same line: it cannot move
  along the shoulder offset); ``d3 = 0`` (the wrist centre at the shoulder,
  outside the bundled stroke 0.1 .. 1.0 m).
- **elbow arm** (Spong's elbow manipulator with a spherical wrist, no offsets):
  ``det J = a2 a3 s3 (a2 c2 + a3 c23) s5``. Families: wrist ``q5 = 0, pi``;
  elbow straight ``q3 = 0, pi`` (the wrist centre cannot move along the
  arm); shoulder ``a2 c2 + a3 c23 = 0``: the wrist centre on joint 1's axis
  (its horizontal distance from the axis is ``a2 c2 + a3 c23``), where joint 1
  only turns it in place. Members: for any q3,
  ``q2 = atan2(a2 + a3 c3, a3 s3)`` or that plus pi.
- **iiwa14** (an S-R-S arm: joints 1-2-3 meet at the shoulder S, joint 4 is
  the elbow E, joints 5-6-7 meet at the wrist W; 7 joints, so singular means
  rank below 6). Joint pairs line up when a joint between them is at 0:
  ``q2 = 0`` puts joints 1 and 3 on one axis, ``q4 = 0`` joints 3 and 5,
  ``q6 = 0`` joints 5 and 7. One pair alone costs only the redundancy (six
  different columns remain), except the elbow: with ``q4 = 0`` W is as far from S
  as it gets, a workspace boundary, so ``q4 = 0`` (and the folded ``q4 = pi``,
  outside the limits) is singular on its own. Two pairs at once,
  ``q2 = 0`` and ``q6 = 0``, leave five different columns: singular. With
  ``q2 = 0`` the arm is a 6-joint arm whose position part at W is joints
  (1, 2, 4); when ``q3 = +-pi/2`` joint 4's axis is perpendicular to joint
  2's and W - S lies in the plane of joint 1's and joint 2's axes, so joints 1
  and 2 both move W along joint 4's axis: rank 2, singular. Reversing the
  chain (7 -> 1 is the same S-R-S structure) gives ``q6 = 0`` with
  ``q5 = +-pi/2``. A search for further minima of the smallest singular
  value on the slice ``q2 = 0`` found only these families; the list is not
  proven complete.

- **course arm** (yaw, two pitches, forearm roll, pitch; 5 joints, so
  singular means rank below 5): at the wrist centre W (on the roll axis, on
  the last pitch axis) ``J = [[A, 0], [B, C]]`` with ``C`` of rank 2, so J
  loses rank exactly when W's velocity block ``A`` (joints 1-3) has a null
  vector whose turn lies in the span of the last two axes. Families: the
  forearm in line with the upper arm (``q3 = 0, pi``) with the last pitch
  parallel to the others (``q4 = 0, pi``); and W in the vertical plane
  through joint 1's axis across the arm with one forearm roll angle, which
  the model's small offsets (the 0.28 mm sideways shift of the arm's plane,
  1.9e-7 m between the first two axes) move, so it is computed from the
  model (``_course_arm`` spells out the steps). Elbow straight alone, or W
  over joint 1's axis alone, is not singular for this 5-joint arm.

Robots are recognised by their URDF name (``robot.name``) and structure (the
number of joints and which are prismatic), so a URDF of the same arm loaded
from a file gets the same families; lengths that enter a condition (the
elbow arm's a2, a3) are read from the loaded model, so xacro arguments
(``--arg a2:=0.5``) are honoured. Other robots get an empty list: use the
numeric check (the smallest singular value of the Jacobian).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from manipkit.errors import JointValueError
from manipkit.kinematics.chain import sampling_bounds
from manipkit.text import short_text

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = [
    "ALL_ROWS",
    "FAMILY_TOL",
    "KNOWN_ROBOTS",
    "SingularFamily",
    "families_at",
    "singular_families",
    "singular_family_at",
]

ALL_ROWS = (0, 1, 2, 3, 4, 5)
FAMILY_TOL = 1e-6
"""Default distance (rad or m) within which :func:`families_at` counts a configuration as in a family."""


@dataclass(frozen=True)
class SingularFamily:
    """A family of singular configurations of one robot.

    Attributes
    ----------
    name : str
        Short name (``"wrist"``, ``"elbow straight"``).
    description : str
        What happens, in words.
    condition : str
        The condition on the joints (``"joint5 = 0 or 180 deg"``).
    rows : tuple of int
        The Jacobian rows (0..5 = vx, vy, vz, wx, wy, wz) that lose rank
        there: the rows the arm can move.
    unit : str
        Unit of :meth:`distance`: ``"rad"``, ``"m"``, or ``"m and rad"``
        (the larger of a distance and an angle).
    reachable : bool
        Whether members exist inside the joint limits (the Stanford arm's
        ``d3 = 0`` lies outside its stroke).
    """

    name: str
    description: str
    condition: str
    rows: tuple[int, ...]
    unit: str
    reachable: bool
    _distance: Callable[[np.ndarray], np.ndarray] = field(repr=False, compare=False)
    _fix: Callable[[np.ndarray, np.random.Generator], None] = field(repr=False, compare=False)
    _lower: np.ndarray = field(repr=False, compare=False)
    _upper: np.ndarray = field(repr=False, compare=False)

    def distance(self, q) -> np.ndarray:
        """How far ``q`` (..., n) is from the family, in :attr:`unit`; 0 on it. Vectorised over leading axes."""
        return self._distance(np.asarray(q, dtype=float))

    def member(self, q, tol: float = FAMILY_TOL) -> np.ndarray:
        """``distance(q) <= tol`` (a bool, or a bool array for a batch)."""
        return self.distance(q) <= tol

    def sample(self, rng: np.random.Generator, n: int = 1) -> np.ndarray:
        """``n`` random members, shape (n, joints): the other joints uniform in their limits (continuous: -pi..pi)."""
        u = rng.random((n, self._lower.size))
        Q = self._lower * (1.0 - u) + self._upper * u
        self._fix(Q, rng)
        return Q


# --------------------------------------------------------------------------
# distances and samplers


def _angle_off(q, values) -> np.ndarray:
    """Distance (rad) of the angles ``q`` from the nearest of ``values``, turns ignored."""
    return np.min([np.abs(np.remainder(q - v + math.pi, 2 * math.pi) - math.pi) for v in values], axis=0)


def _at(index: int, values: Sequence[float]):
    """(distance, fix) for ``q[index]`` in ``values``."""
    def distance(q):
        return _angle_off(q[..., index], values)

    def fix(Q, rng):
        Q[:, index] = rng.choice(np.asarray(values, dtype=float), size=len(Q))

    return distance, fix


def _all_of(*parts):
    """(distance, fix) for several conditions at once: the largest distance; each fix in turn."""
    def distance(q):
        return np.max([d(q) for d, _ in parts], axis=0)

    def fix(Q, rng):
        for _, f in parts:
            f(Q, rng)

    return distance, fix


_STRAIGHT = (0.0, math.pi)
_QUARTER = (math.pi / 2, -math.pi / 2)


def _deg_text(values) -> str:
    return " or ".join(short_text(math.degrees(v)) for v in values) + " deg"


# --------------------------------------------------------------------------
# the bundled arms


def _planar_2r(robot: Robot):
    j = robot.joint_names
    return [(
        "elbow straight",
        f"the two links are in line (stretched out or folded back): {j[0]} and {j[1]} both move the tip "
        "across the arm, so it cannot move along it",
        f"{j[1]} = {_deg_text(_STRAIGHT)}", (0, 1), "rad", _at(1, _STRAIGHT),
    )]


def _planar_3r(robot: Robot):
    j = robot.joint_names
    return [
        (
            "elbow straight",
            "links 1 and 2 are in line: the tip frame loses one combination of moving and turning in the plane",
            f"{j[1]} = {_deg_text(_STRAIGHT)}", (0, 1, 5), "rad", _at(1, _STRAIGHT),
        ),
        (
            "all links in line",
            "the three links are in line: every joint moves the tip across the arm, so it cannot move along it "
            "(position only, rows vx and vy)",
            f"{j[1]} and {j[2]} = {_deg_text(_STRAIGHT)}", (0, 1), "rad", _all_of(_at(1, _STRAIGHT), _at(2, _STRAIGHT)),
        ),
    ]


def _scara(robot: Robot):
    j = robot.joint_names
    return [(
        "elbow straight",
        f"the two arm links are in line: {j[0]} and {j[1]} both move the tool across the arm, so it cannot "
        "move along it horizontally",
        f"{j[1]} = {_deg_text(_STRAIGHT)}", (0, 1, 2, 5), "rad", _at(1, _STRAIGHT),
    )]


def _wrist(j):
    return (
        "wrist",
        f"{j[3]} and {j[5]} turn about the same axis (the wrist's middle joint is straight), so the tool "
        "cannot turn about the axis perpendicular to all three wrist axes",
        f"{j[4]} = {_deg_text(_STRAIGHT)}", ALL_ROWS, "rad", _at(4, _STRAIGHT),
    )


def _stanford_arm(robot: Robot):
    j = robot.joint_names

    def d3_distance(q):
        return np.abs(q[..., 2])

    def d3_fix(Q, rng):
        Q[:, 2] = 0.0

    lower = robot.joints[2].lower
    return [
        _wrist(j),
        (
            "boom along joint 1's axis",
            f"the boom is parallel to {j[0]}'s axis: {j[0]} and {j[1]} move the wrist centre along the same "
            "line, so it cannot move along the shoulder offset",
            f"{j[1]} = {_deg_text(_STRAIGHT)}", ALL_ROWS, "rad", _at(1, _STRAIGHT),
        ),
        (
            "wrist centre at the shoulder",
            f"the boom is fully in ({j[2]} = 0, its lower limit is {short_text(lower)} m): {j[1]} turns the wrist "
            "centre in place",
            f"{j[2]} = 0 m", ALL_ROWS, "m", (d3_distance, d3_fix),
        ),
    ]


def _elbow_arm(robot: Robot):
    j = robot.joint_names
    # a2, a3: joint 3 sits a2 along link2's x axis, joint 4 (the wrist centre) a3 along link3's
    a2, a3 = (float(np.linalg.norm(robot.model.jointPlacements[robot.model.getJointId(name)].translation))
              for name in (j[2], j[3]))

    def shoulder_distance(q):
        return np.abs(a2 * np.cos(q[..., 1]) + a3 * np.cos(q[..., 1] + q[..., 2]))

    def shoulder_fix(Q, rng):
        q3 = Q[:, 2]
        q2 = np.arctan2(a2 + a3 * np.cos(q3), a3 * np.sin(q3)) + math.pi * rng.integers(0, 2, len(Q))
        Q[:, 1] = np.remainder(q2 + math.pi, 2 * math.pi) - math.pi

    return [
        _wrist(j),
        (
            "elbow straight",
            "the upper arm and the forearm are in line: the wrist centre cannot move along the arm",
            f"{j[2]} = {_deg_text(_STRAIGHT)}", ALL_ROWS, "rad", _at(2, _STRAIGHT),
        ),
        (
            "wrist centre on joint 1's axis",
            f"the wrist centre is on {j[0]}'s axis (the left side of the condition is its horizontal distance "
            f"from the axis): {j[0]} only turns it in place, so it cannot move perpendicular to the arm's plane",
            f"{short_text(a2)} cos({j[1]}) + {short_text(a3)} cos({j[1]} + {j[2]}) = 0 m", ALL_ROWS, "m",
            (shoulder_distance, shoulder_fix),
        ),
    ]


def _iiwa14(robot: Robot):
    j = robot.joint_names
    return [
        (
            "elbow straight",
            f"{j[2]} and {j[4]} turn about the same axis and the wrist is as far from the shoulder as it gets: it "
            "cannot move away from the shoulder (folded back, 180 deg, is outside the limits)",
            f"{j[3]} = {_deg_text(_STRAIGHT)}", ALL_ROWS, "rad", _at(3, _STRAIGHT),
        ),
        (
            "shoulder and wrist axes aligned",
            f"{j[0]} and {j[2]} turn about one axis, and so do {j[4]} and {j[6]}: two joints are lost, one more "
            "than the redundancy",
            f"{j[1]} = 0 or 180 deg and {j[5]} = 0 or 180 deg", ALL_ROWS, "rad",
            _all_of(_at(1, _STRAIGHT), _at(5, _STRAIGHT)),
        ),
        (
            "shoulder aligned, elbow axis across",
            f"{j[0]} and {j[2]} turn about one axis and {j[3]}'s axis is perpendicular to {j[1]}'s: {j[0]} and "
            f"{j[1]} move the wrist centre along the same line",
            f"{j[1]} = 0 or 180 deg and {j[2]} = {_deg_text(_QUARTER)}", ALL_ROWS, "rad",
            _all_of(_at(1, _STRAIGHT), _at(2, _QUARTER)),
        ),
        (
            "wrist aligned, elbow axis across",
            f"{j[4]} and {j[6]} turn about one axis and {j[3]}'s axis is perpendicular to {j[5]}'s (the shoulder "
            "case seen from the flange)",
            f"{j[5]} = 0 or 180 deg and {j[4]} = {_deg_text(_QUARTER)}", ALL_ROWS, "rad",
            _all_of(_at(5, _STRAIGHT), _at(4, _QUARTER)),
        ),
    ]


def _joint_axes(robot: Robot, q) -> list[tuple[np.ndarray, np.ndarray]]:
    """(unit axis, point on it) of every joint at ``q``, in base_link's axes (the child link's frame is the joint's)."""
    axes = []
    for joint in robot.joints:
        T = robot.transform("base_link", joint.child, q)
        axes.append((T[:3, :3] @ joint.axis, T[:3, 3]))
    return axes


def _course_shoulder(robot: Robot, q) -> tuple[float, float]:
    """(r, q5 solution) of the course arm at ``q``: r (m) the wrist centre's distance from joint 1's axis in
    the arm's plane; the top-wrist angle (rad) that makes the configuration singular when r = 0."""
    (w1, p1), (w2, p2), (w3, p3), (w4, _), (_, W) = _joint_axes(robot, q)
    r = float((W - p1) @ np.cross(w2, w1))
    columns = [np.cross(w, W - p) for w, p in ((w1, p1), (w2, p2), (w3, p3))]
    x = np.linalg.lstsq(np.column_stack(columns[1:]), -columns[0], rcond=None)[0]
    b = w1 + x[0] * w2 + x[1] * w3  # the turn left when joints 2 and 3 cancel joint 1's motion of the wrist centre
    w5_0 = _joint_axes(robot, np.r_[q[:3], 0.0, q[4]])[4][0]
    return r, math.atan2(b @ np.cross(w4, w5_0), b @ w5_0)


def _course_arm(robot: Robot):
    # yaw (1), pitch (2, 3) on parallel axes, forearm roll (4), pitch (5) through the wrist centre W on the roll
    # axis. At W joints 4 and 5 move nothing, so J = [[A, 0], [B, C]] with C = [w4 w5] of rank 2 (w4 is
    # perpendicular to w5): J (6 x 5) loses rank exactly when A (W's velocity from joints 1-3) has a null
    # vector x whose turn B x lies in span(w4, w5).
    # - Forearm in line (q3 = 0 or pi; the DH offsets of 90 deg cancel, so exactly): x = (0, l3, -(l2 + l3))
    #   turns about the pitch axis h, which lies in span(w4, w5) exactly when w5 = +-h: q4 = 0 or pi.
    # - W in the vertical plane through joint 1's axis across the arm (r = (W - p1) . (w2 x w1) = 0): then
    #   joint 1 moves W only within the arm's plane (by the 0.28 mm offset of that plane), joints 2 and 3
    #   cancel it, and what is left, b = w1 + x2 w2 + x3 w3, must lie in span(w4, w5): one value of q4 (and that
    #   plus pi), q4 = atan2(b . (w4 x w5_0), b . w5_0). Without the offsets any q4 with w4 x w5 horizontal
    #   would do; the bundled arm's 1.9e-7 m and 0.28 mm offsets move the family, so it is computed
    #   from the model. Members: q2 solves r = 0 (r is a cos q2 + b sin q2 + c), then q4 as above.
    j = robot.joint_names

    def straight_distance(q):
        return np.max([_angle_off(q[..., 2], _STRAIGHT), _angle_off(q[..., 3], _STRAIGHT)], axis=0)

    def straight_fix(Q, rng):
        for index in (2, 3):
            Q[:, index] = rng.choice(np.asarray(_STRAIGHT), size=len(Q))

    def shoulder_distance(q):
        flat = np.reshape(q, (-1, q.shape[-1]))
        out = np.empty(len(flat))
        for i, row in enumerate(flat):
            r, q4 = _course_shoulder(robot, row)
            out[i] = max(abs(r), float(_angle_off(row[3], (q4, q4 + math.pi))))
        return out.reshape(q.shape[:-1])

    def shoulder_fix(Q, rng):
        for row in Q:
            (w1, p1), (w2, p2) = _joint_axes(robot, row)[:2]
            k = np.cross(w2, w1)
            v = _joint_axes(robot, np.r_[row[0], 0.0, row[2:]])[4][1] - p2
            a = v @ k - (w2 @ v) * (w2 @ k)
            b = np.cross(w2, v) @ k
            c = (p2 - p1) @ k + (w2 @ v) * (w2 @ k)
            row[1] = math.atan2(b, a) + rng.choice((-1.0, 1.0)) * math.acos(max(-1.0, min(1.0, -c / math.hypot(a, b))))
            row[3] = _course_shoulder(robot, row)[1] + rng.choice((0.0, math.pi))
        Q[:, [1, 3]] = np.remainder(Q[:, [1, 3]] + math.pi, 2 * math.pi) - math.pi

    (_, p1), (w2, _) = _joint_axes(robot, robot.q())[:2]
    sideways = abs(float((_joint_axes(robot, robot.q())[4][1] - p1) @ w2))  # the arm's plane from joint 1's axis
    return [
        (
            "forearm in line, wrist pitch parallel",
            f"the forearm continues the upper arm and {j[4]} turns about the same direction as {j[1]} and {j[2]}: "
            f"{j[1]} and {j[2]} together only turn the tool about that direction, which {j[4]} does already",
            f"{j[2]} = {_deg_text(_STRAIGHT)} and {j[3]} = {_deg_text(_STRAIGHT)}", ALL_ROWS, "rad",
            (straight_distance, straight_fix),
        ),
        (
            "wrist centre over joint 1's axis",
            f"the wrist centre is in the vertical plane through {j[0]}'s axis across the arm, so {j[1]} and {j[2]} "
            f"can cancel {j[0]}'s motion of it, and the forearm roll has put {j[0]}'s axis in the plane of {j[3]}'s "
            f"and {j[4]}'s axes, so the wrist makes the turn that is left too",
            f"r = 0 m (the wrist centre's distance from {j[0]}'s axis in the arm's plane) and {j[3]} puts {j[0]}'s "
            f"axis in the plane of {j[3]}'s and {j[4]}'s axes (corrected for the arm's plane lying "
            f"{short_text(sideways, 3)} m off that axis; computed from the model)",
            ALL_ROWS, "m and rad", (shoulder_distance, shoulder_fix),
        ),
    ]


# name -> (builder, number of joints, indices of the prismatic joints)
_KNOWN: dict[str, tuple[Callable, int, tuple[int, ...]]] = {
    "planar_2r": (_planar_2r, 2, ()),
    "planar_3r": (_planar_3r, 3, ()),
    "scara": (_scara, 4, (2,)),
    "stanford_arm": (_stanford_arm, 6, (2,)),
    "elbow_arm": (_elbow_arm, 6, ()),
    "iiwa14": (_iiwa14, 7, ()),
    "course_arm": (_course_arm, 5, ()),
}
KNOWN_ROBOTS = tuple(_KNOWN)
"""Robot names whose singular families are known (matched with their structure, see the module docstring)."""


def _matches(robot: Robot, count: int, prismatic: tuple[int, ...]) -> bool:
    if len(robot.joint_names) != count:
        return False
    return tuple(i for i, joint in enumerate(robot.joints) if joint.type == "prismatic") == prismatic


def singular_families(robot: Robot) -> list[SingularFamily]:
    """The known singular families of ``robot``; empty when it is not one of :data:`KNOWN_ROBOTS`.

    Parameters
    ----------
    robot : manipkit.Robot
        Recognised by ``robot.name`` and its structure (joint count, which
        joints are prismatic); lengths in a condition come from the model.

    Returns
    -------
    list of SingularFamily
        In the order of the module docstring; joints named as in ``robot.joint_names``.

    Examples
    --------
    >>> import manipkit
    >>> [f.condition for f in singular_families(manipkit.load("planar_2r"))]
    ['joint2 = 0 or 180 deg']
    """
    return list(_families_of(robot))


@functools.lru_cache(maxsize=16)
def _families_of(robot: Robot) -> tuple[SingularFamily, ...]:
    """The families of one (immutable) robot, built once: the course arm's take about 13 ms to build, and the
    viewer's overlay asks for them at every change of a slider."""
    known = _KNOWN.get(robot.name)
    if known is None or not _matches(robot, known[1], known[2]):
        return ()
    lower, upper = sampling_bounds([j.lower for j in robot.joints], [j.upper for j in robot.joints])
    lower.setflags(write=False)  # shared by every caller
    upper.setflags(write=False)
    families = []
    for name, description, condition, rows, unit, (distance, fix) in known[0](robot):
        reachable = _reachable(fix, lower, upper)
        families.append(SingularFamily(name, description, condition, tuple(rows), unit, reachable, distance, fix,
                                       lower, upper))
    return tuple(families)


def _reachable(fix, lower, upper, tries: int = 16) -> bool:
    """Whether members drawn with a fixed seed ever fall inside the limits (the fixed joints' values decide)."""
    rng = np.random.default_rng(0)
    Q = lower * 0.5 + upper * 0.5 + (upper - lower) * (rng.random((tries, lower.size)) - 0.5)
    fix(Q, rng)
    return bool(np.any(np.all((Q >= lower - 1e-12) & (Q <= upper + 1e-12), axis=1)))


def families_at(robot: Robot, q, tol: float = FAMILY_TOL) -> list[SingularFamily]:
    """Every one of :func:`singular_families` whose distance from ``q`` is at most ``tol``, in their order.

    ``q`` is one joint vector in ``robot.joint_names`` order (rad, m) or joint
    name -> value (as :meth:`Robot.q` takes it); ``tol`` is in each family's
    :attr:`~SingularFamily.unit`. A vector of the wrong length or with a NaN
    raises JointValueError.

    Examples
    --------
    >>> import manipkit
    >>> stanford = manipkit.load("stanford_arm")  # at q = 0: the wrist straight and the boom upright
    >>> [f.name for f in families_at(stanford, {"joint3": 0.5})]
    ['wrist', "boom along joint 1's axis"]
    """
    if isinstance(q, Mapping):
        q = robot.q(q)
    q = np.asarray(q, dtype=float)
    if q.shape != (len(robot.joint_names),) or not np.all(np.isfinite(q)):
        raise JointValueError(f"q has shape {q.shape}; give {len(robot.joint_names)} finite joint values "
                              f"({', '.join(robot.joint_names)})")
    return [family for family in singular_families(robot) if family.member(q, tol)]


def singular_family_at(robot: Robot, q, tol: float = FAMILY_TOL) -> SingularFamily | None:
    """The first of :func:`families_at` (``q`` and ``tol`` as there), else None.

    Examples
    --------
    >>> import manipkit
    >>> singular_family_at(manipkit.load("planar_2r"), [0.3, 0.0]).name
    'elbow straight'
    """
    families = families_at(robot, q, tol)
    return families[0] if families else None
