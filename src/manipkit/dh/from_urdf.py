"""A DH table derived from the joint axes of a URDF chain.

``dh_from_urdf_chain(robot, base, tip, convention=...)`` returns a
:class:`~manipkit.dh.DHTable` whose forward kinematics equals the robot's:
``dh_fk(table, q_chain) == robot.fk(q, tip, base=base)`` for every joint
vector ``q``, where ``q_chain`` holds the values of the joints
``robot.chain_joints(base, tip)`` (the movable joints from ``base`` down to
``tip``, in order). Joints off that chain (the wheels of a mobile base, other
branches) are left out.

Conventions (docs/architecture.md), restated:

- Standard DH (Spong, Corke): ``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``;
  DH frame ``i-1`` has its z axis on joint ``i``.
- Modified DH (Craig): ``A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``;
  DH frame ``i`` has its z axis on joint ``i``.
- ``T_base_tip(q) = table.base @ A_1(q_1) @ ... @ A_n(q_n) @ table.tool``;
  ``table.base`` is T_base_dh0 (DH frame 0 in the base frame), ``table.tool``
  is T_dhn_tip.
- Joint values are the URDF's, unchanged: every DH z axis points along its
  URDF joint axis (so positive q turns or slides the same way), and the
  ``theta`` (revolute) or ``d`` (prismatic) column holds the constant offset
  that makes the URDF zero pose ``q = 0``.
- Metres and radians.

How the table is built: at ``q = 0`` each joint axis is a line in the base
frame (point and unit direction, from Pinocchio's placements); after the last
joint comes the tip frame's z axis. Between consecutive lines ``L_i`` and
``L_{i+1}`` a common normal ``N_i`` is chosen (foot ``A_i`` on ``L_i``, foot
``B_i`` on ``L_{i+1}``, unit direction ``x_i``); it is the x axis of DH frame
``i`` in both conventions. A standard DH frame ``i`` sits at ``B_i`` with z
along ``L_{i+1}``; a modified DH frame ``i`` sits at ``A_i`` with z along
``L_i``. Both conventions therefore share the same numbers, grouped
differently: ``a_i, alpha_i`` belong to ``N_i``, ``d_i, theta_i`` to the
move along ``L_i`` from ``N_{i-1}`` to ``N_i``.

Where DH is not unique, these choices are made:

- **DH frame 0** (both conventions): origin at the point of joint 1's axis
  nearest the base origin, z along joint 1's axis, and the base frame turned
  by the smallest rotation that takes its z axis onto joint 1's axis (so
  ``table.base`` is the identity when joint 1 turns about the base z axis
  through the base origin). In modified DH this gives ``a_0 = alpha_0 = 0``.
- **Skew axes**: the common normal is unique.
- **Intersecting axes**: the normal passes through the intersection
  (``a = 0``), along ``+-(z_i x z_{i+1})``.
- **Parallel axes** (``|sin(angle)| < tol``): the normal through the point
  where the previous normal meets the axis, so ``d = 0``.
- **Coincident axes**: no normal is defined; the previous x axis is kept
  (``theta`` offset 0) at the previous foot (``d = 0``, ``a = 0``, ``alpha``
  0 or 180 deg).
- **Sign of x** (skew, intersecting and parallel cases): the one closer to
  the previous x axis, so every ``theta`` offset lies in (-90, 90] deg
  (``a`` may then be negative, as in the usual UR tables). When the normal
  is perpendicular to the previous x axis, ``a > 0`` decides, and for
  intersecting axes then ``x = +(z_i x z_{i+1})``, which makes ``alpha``
  positive.
- **Prismatic joints**: only the direction is defined; the line is taken
  through the point where the previous normal meets the previous joint axis
  (the previous standard-DH origin; the base origin for joint 1), so the
  normal before it has ``a = 0`` and the row before it ``d = 0``.
- **Last DH frame**: its normal runs from the last joint axis to the tip
  frame's z axis (standard DH: frame n lies on the tip's z axis, so
  ``table.tool`` is a turn about and a shift along z). Whatever remains
  goes into ``table.tool``.

Parameters smaller than 1e-12 in magnitude are written as exact zeros
(rounding noise; their effect on the pose is below 1e-12).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.dh.table import CONVENTIONS, DHRow, DHTable, dh_fk
from manipkit.errors import DHDerivationError
from manipkit.spatial.rotations import matrix_from_axis_angle, rotation_angle_between
from manipkit.spatial.transforms import invert_transform, nearest_rotation, pose_error

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

# DHDerivationError is re-exported: manipkit 0.1 offered it here (manipkit.dh_from_urdf)
__all__ = ["DEFAULT_SNAP", "MAX_SNAP", "DHDerivation", "DHDerivationError", "check_snap", "derive_dh", "dh_from_urdf_chain"]

_ZERO_SNAP = 1e-12  # parameters below this are rounding noise and written as 0


# --------------------------------------------------------------------------
# geometry (numpy only)


def _frame(origin, z, x) -> np.ndarray:
    """4x4 pose with the given origin and unit z; x is made exactly perpendicular to z."""
    x = x - (x @ z) * z
    x = x / np.linalg.norm(x)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, np.cross(z, x), z, origin
    return T


def _x_of_frame_0(z: np.ndarray) -> np.ndarray:
    """The base x axis turned by the smallest rotation taking the base z axis onto ``z``."""
    e_x, e_z = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
    axis = np.cross(e_z, z)
    sine = np.linalg.norm(axis)
    if sine < 1e-12:  # z = +-e_z: identity, or half a turn about x; both keep x
        return e_x
    return matrix_from_axis_angle(axis, math.atan2(sine, float(e_z @ z))) @ e_x


def _common_normal(P, u, Q, w, start, x_prev, tol):
    """The DH common normal from line (P, u) to line (Q, w).

    ``start`` is where the previous normal meets (P, u); ``x_prev`` is its
    direction. Returns (A on the first line, B on the second line, unit x),
    following the choices in the module docstring.
    """
    cross = np.cross(u, w)
    sine = np.linalg.norm(cross)
    if sine < tol:  # parallel: the normal through the previous foot (d = 0)
        A = start
        B = Q + ((A - Q) @ w) * w
        mean = u + math.copysign(1.0, u @ w) * w
        mean /= np.linalg.norm(mean)
        gap = (B - A) - ((B - A) @ mean) * mean
        if np.linalg.norm(gap) < tol:  # coincident: keep the previous x
            return A, B, x_prev
        normal = gap / np.linalg.norm(gap)
    else:  # skew or intersecting: the unique common normal
        normal = cross / sine
        r = Q - P
        b, e, c = r @ u, r @ w, u @ w
        A = P + ((b - c * e) / sine**2) * u
        B = Q + ((c * b - e) / sine**2) * w
    toward = (B - A) @ normal
    alignment = normal @ x_prev
    if abs(alignment) > tol:
        sign = math.copysign(1.0, alignment)
    elif abs(toward) > tol:
        sign = math.copysign(1.0, toward)
    else:
        sign = 1.0
    return A, B, sign * normal


def _row_parameters(T: np.ndarray, convention: str) -> tuple[float, float, float, float]:
    """(a, alpha, d, theta) of a DH link transform (the inverse of ``dh_link_transform``)."""
    R, p = T[:3, :3], T[:3, 3]
    if convention == "standard":  # Rz(theta) Tz(d) Tx(a) Rx(alpha)
        theta = math.atan2(R[1, 0], R[0, 0])
        alpha = math.atan2(R[2, 1], R[2, 2])
        a = p[0] * math.cos(theta) + p[1] * math.sin(theta)
        d = p[2]
    else:  # Rx(alpha) Tx(a) Rz(theta) Tz(d)
        alpha = math.atan2(-R[1, 2], R[2, 2])
        theta = math.atan2(-R[0, 1], R[0, 0])
        a = p[0]
        d = -p[1] * math.sin(alpha) + p[2] * math.cos(alpha)
    return _clean(a), _clean_angle(alpha), _clean(d), _clean_angle(theta)


def _clean(value: float) -> float:
    return 0.0 if abs(value) < _ZERO_SNAP else float(value)


def _clean_angle(angle: float) -> float:
    if abs(angle) < _ZERO_SNAP:
        return 0.0
    if abs(abs(angle) - math.pi) < _ZERO_SNAP:
        return math.pi
    return float(angle)


def _dh_frames(points, directions, prismatic, T_base_tip, tol):
    """DH frames (4x4 in the base frame) of both conventions, from the joint lines at q = 0.

    Returns (standard frames 0..n, modified frames 0..n).
    """
    n = len(directions)
    points = [np.asarray(p, dtype=float) for p in points]
    lines_z = list(directions) + [T_base_tip[:3, 2]]
    lines_p = points + [T_base_tip[:3, 3]]
    if prismatic[0]:
        lines_p[0] = np.zeros(3)  # joint 1 slides along a line through the base origin
    u1 = lines_z[0]
    origin0 = lines_p[0] + (-lines_p[0] @ u1) * u1  # nearest point to the base origin
    x0 = _x_of_frame_0(u1)
    frame0 = _frame(origin0, u1, x0)
    standard, modified = [frame0], [frame0]
    start, x_prev = origin0, frame0[:3, 0]
    for i in range(n):
        if i + 1 < n and prismatic[i + 1]:
            lines_p[i + 1] = start  # the next slide's line through the previous DH origin
        A, B, x = _common_normal(lines_p[i], lines_z[i], lines_p[i + 1], lines_z[i + 1], start, x_prev, tol)
        standard.append(_frame(B, lines_z[i + 1], x))
        modified.append(_frame(A, lines_z[i], x))
        start, x_prev = B, standard[-1][:3, 0]
    return standard, modified


# --------------------------------------------------------------------------
# the table


def dh_from_urdf_chain(
    robot: Robot,
    base: str = "base_link",
    tip: str = "ee_link",
    *,
    convention: str = "standard",
    tol: float = 1e-9,
    snap: float = 0.0,
) -> DHTable:
    """DH table (with base and tool transforms) of the chain from ``base`` to ``tip``.

    Parameters
    ----------
    robot : manipkit.kinematics.robot.Robot
        A loaded robot (:func:`manipkit.load`).
    base, tip : str
        Frame (link) names or the aliases ``base_link``, ``ee_link``; ``tip``
        must lie below ``base`` in the link tree. ``base`` may be any link,
        also one below some joints (then the chain starts there).
    convention : {"standard", "modified"}, keyword-only
        Standard DH (Spong, Corke): ``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``.
        Modified DH (Craig): ``A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``.
    tol : float, keyword-only
        Axes whose directions differ by less than ``tol`` (sine of the angle)
        are parallel; normals shorter than ``tol`` metres count as zero
        (intersecting or coincident axes) when choosing a sign, and so do
        alignments (cosines) below ``tol``. Near-parallel axes (angle
        between about 1e-9 and 1e-6 rad) are ill-conditioned in any DH
        table: their common normal lies far away.
    snap : float, keyword-only
        Angle (rad) within which the joint axes, the tip's z axis and the
        table's angles are snapped to the base frame's axes and to multiples
        of 90 deg (a description that writes pi as 3.1415926 or pi/2 as
        1.571); 0 (default) snaps nothing and the table is exact.
        :func:`derive_dh` snaps and says what moved, checked against the URDF.

    Returns
    -------
    DHTable
        One row per joint of ``robot.chain_joints(base, tip)`` (revolute
        for revolute and continuous joints, prismatic for prismatic ones;
        ``qlim`` from the URDF limits, ``None`` for continuous joints), with
        ``T_base_tip(q) = table.base @ A_1(q_1) @ ... @ A_n(q_n) @ table.tool``
        equal to ``robot.fk(q, tip, base=base)`` for every ``q``. The joint
        values are the URDF's: each DH z axis points along its URDF joint
        axis, and the constant ``theta`` (revolute) or ``d`` (prismatic)
        offsets absorb the URDF zero pose. See the module docstring for the
        choices made where DH is not unique.

    Raises
    ------
    UnknownFrameError
        If ``base`` or ``tip`` is not a frame of the robot.
    ChainError
        If ``tip`` is not below ``base``.
    DHDerivationError
        If ``tip`` is ``base``, no movable joint lies between them, or
        ``convention`` is unknown.

    Examples
    --------
    >>> import manipkit
    >>> table = dh_from_urdf_chain(manipkit.load("planar_3r"), convention="standard")
    >>> [(row.a, row.alpha, row.d, row.theta) for row in table.rows]
    [(4.0, 0.0, 0.0, 0.0), (2.0, 0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0)]
    """
    return _derivation(robot, base, tip, convention, tol, snap)[0]


def _derivation(robot: Robot, base: str, tip: str, convention: str, tol: float, snap: float):
    """(table, what snapping moved): the body of :func:`dh_from_urdf_chain`."""
    if convention not in CONVENTIONS:
        raise DHDerivationError(f"convention '{convention}': choose standard or modified")
    moved: list[tuple[str, float]] = []
    joints = _movable_joints(robot, base, tip)
    points, directions = _joint_lines(robot, base, joints)
    T_base_tip = robot.transform(base, tip, np.zeros(len(robot.joints)), check_limits=False)
    if snap > 0:
        snapped = [_snapped_direction(v, snap) for v in directions]
        moved += [(f"axis of {joint.name}", _angle(v, w)) for joint, v, w in zip(joints, directions, snapped)]
        directions = snapped
        T_base_tip = T_base_tip.copy()
        R = _snapped_rotation(T_base_tip[:3, :3], snap)
        moved.append((f"{robot.frame(tip)}'s axes", rotation_angle_between(T_base_tip[:3, :3], R, check=False)))
        T_base_tip[:3, :3] = R
    prismatic = [not joint.is_angular for joint in joints]
    standard, modified = _dh_frames(points, directions, prismatic, T_base_tip, tol)
    frames = standard if convention == "standard" else modified
    rows = []
    for i, joint in enumerate(joints):
        a, alpha, d, theta = _row_parameters(invert_transform(frames[i], check=False) @ frames[i + 1], convention)
        if snap > 0:
            snapped_alpha, snapped_theta = _snapped_angle(alpha, snap), _snapped_angle(theta, snap)
            moved += [(f"alpha_{i + 1}", abs(snapped_alpha - alpha)), (f"theta_{i + 1} offset", abs(snapped_theta - theta))]
            alpha, theta = snapped_alpha, snapped_theta
        limits = (joint.lower, joint.upper)
        qlim = limits if all(map(math.isfinite, limits)) else None
        rows.append(DHRow(a, alpha, d, theta, type="prismatic" if prismatic[i] else "revolute", qlim=qlim))
    table = DHTable(tuple(rows), convention=convention, name=robot.name, base=frames[0])
    # Tool from the table's own zero pose, so q = 0 is reproduced exactly.
    T_base_dhn = dh_fk(table, np.zeros(table.n), upto=table.n)
    tool = invert_transform(T_base_dhn, check=False) @ T_base_tip
    if snap > 0:
        R = _snapped_rotation(tool[:3, :3], snap)
        moved.append(("tool rotation", rotation_angle_between(tool[:3, :3], R, check=False)))
        tool[:3, :3] = R
    tool[np.abs(tool) < _ZERO_SNAP] = 0.0
    table = DHTable(table.rows, convention=convention, name=robot.name, base=frames[0], tool=tool)
    return table, tuple((what, float(angle)) for what, angle in moved if angle > _ZERO_SNAP)


#: Largest snapping tolerance (rad): 22.5 deg, half way between multiples of 45 deg.
MAX_SNAP = math.pi / 8
#: ``derive_dh``'s snapping tolerance (rad) by default: 0.057 deg.
DEFAULT_SNAP = 1e-3


def check_snap(snap, what: str) -> float:
    """``snap`` if it is a tolerance from 0 to :data:`MAX_SNAP` rad, else DHDerivationError naming ``what``."""
    if not (isinstance(snap, (int, float)) and not isinstance(snap, bool) and 0 <= snap <= MAX_SNAP):
        raise DHDerivationError(f"{what} {snap!r:.40}: give a snapping tolerance from 0 to {MAX_SNAP:.3f} rad (22.5 deg)")
    return float(snap)


@dataclass(frozen=True)
class DHDerivation:
    """A DH table derived from a URDF chain with its angles snapped, and how far it is from the URDF.

    Attributes
    ----------
    table : DHTable
    snap : float
        The snapping tolerance (rad) used.
    moved : tuple of (str, float)
        What snapping moved and by how much (rad): joint axes, the tip's axes,
        the rows' ``alpha`` and ``theta`` offsets, the tool rotation.
    position_error, rotation_error : float
        The largest distance (m) and rotation angle (rad) between the
        table's FK and the URDF's at :attr:`samples` configurations drawn
        inside the limits (and at q = 0).
    samples : int
    """

    table: DHTable
    snap: float
    moved: tuple[tuple[str, float], ...]
    position_error: float
    rotation_error: float
    samples: int


def derive_dh(robot: Robot, base: str = "base_link", tip: str = "ee_link", *, convention: str = "standard",
              snap: float = DEFAULT_SNAP, samples: int = 200, seed: int = 0) -> DHDerivation:
    """:func:`dh_from_urdf_chain` with snapping, what it moved, and the table checked against the URDF.

    ``snap`` (rad, default 1e-3: 0.057 deg) is the tolerance within which axes
    and angles are taken as multiples of 90 deg; ``snap=0`` derives the exact
    table (the errors are then rounding noise). The check compares the
    table's FK with the robot's at q = 0 and ``samples`` random
    configurations inside the limits (``seed``), so the errors say what
    snapping cost.

    Examples
    --------
    >>> import manipkit
    >>> derived = derive_dh(manipkit.load("planar_3r"), samples=10)
    >>> derived.moved, derived.position_error < 1e-12
    ((), True)
    """
    check_snap(snap, "snap")
    table, moved = _derivation(robot, base, tip, convention, 1e-9, float(snap))
    chain = robot.chain(base, tip)
    Q = np.vstack([np.zeros((1, chain.n)), chain.sample(samples, seed=seed)])
    position, rotation = pose_error(chain.fk(Q), dh_fk(table, Q))
    return DHDerivation(table, float(snap), moved, float(np.max(position)), float(np.max(rotation)), int(samples))


# --------------------------------------------------------------------------
# snapping (descriptions that write pi as 3.1415926)


def _snapped_direction(v: np.ndarray, tol: float) -> np.ndarray:
    """``v`` with the components below ``sin(tol)`` made 0 (the nearest direction in a base-frame plane or axis)."""
    snapped = np.where(np.abs(v) < math.sin(tol), 0.0, v)
    return snapped / np.linalg.norm(snapped)


def _snapped_rotation(R: np.ndarray, tol: float) -> np.ndarray:
    """``R`` with every column snapped like a direction, then made a rotation again (nearest, by SVD)."""
    return nearest_rotation(np.column_stack([_snapped_direction(R[:, k], tol) for k in range(3)]))


def _angle(u: np.ndarray, v: np.ndarray) -> float:
    """The angle (rad) between two unit vectors (atan2: accurate for tiny angles)."""
    return math.atan2(float(np.linalg.norm(np.cross(u, v))), float(u @ v))




def _snapped_angle(angle: float, tol: float) -> float:
    """``angle`` moved to the nearest multiple of 90 deg when within ``tol`` (rad) of it, in (-pi, pi]."""
    quarter = round(angle / (math.pi / 2))
    if abs(angle - quarter * math.pi / 2) > tol:
        return angle
    return _clean_angle(math.remainder(quarter * math.pi / 2, 2 * math.pi))


def _movable_joints(robot: Robot, base: str, tip: str) -> list:
    """The robot's joints (``robot.joints`` entries) on the chain from ``base`` down to ``tip``, in order."""
    base_name, tip_name = robot.frame(base), robot.frame(tip)  # UnknownFrameError with suggestions
    if base_name == tip_name:
        same = f"'{base}'" if base == base_name else f"'{base}' ({base_name})"
        raise DHDerivationError(
            f"robot '{robot.name}': base and tip are the same frame {same}; a DH chain runs from a base "
            f"frame down to a different tip frame below it, e.g. base='{robot.root_link}', tip='{robot.ee_frame}'"
        )
    names = robot.chain_joints(base_name, tip_name)  # ChainError when tip is not below base
    if not names:
        raise DHDerivationError(
            f"robot '{robot.name}': no movable joint between '{base_name}' and '{tip_name}' (only fixed "
            f"joints); a DH table needs at least one, and T_{base_name}_{tip_name} is constant: "
            "use robot.transform instead"
        )
    mimics = _mimics_on_path(robot, base_name, tip_name)
    if mimics:
        m = mimics[0]
        raise DHDerivationError(
            f"robot '{robot.name}': joint '{m.name}' between '{base_name}' and '{tip_name}' mimics '{m.leader}'; "
            "a DH table has one independent joint value per row, so a chain with a mimic joint has no DH table "
            "(choose a base and tip with no mimic joint between them)"
        )
    return [robot.joints[robot.joint_names.index(name)] for name in names]


def _mimics_on_path(robot: Robot, base: str, tip: str) -> list:
    """The mimic joints (``robot.mimic_joints`` entries) between ``base`` and ``tip`` (tip below base)."""
    model = robot.model
    base_joint = model.frames[robot.frame_id(base)].parentJoint
    support = list(model.supports[model.frames[robot.frame_id(tip)].parentJoint])
    on_path = {model.names[j] for j in support[support.index(base_joint) + 1 :]}
    return [m for m in robot.mimic_joints.values() if m.name in on_path]


def _joint_lines(robot: Robot, base: str, joints: list) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Each joint's axis at q = 0 as a line in the ``base`` frame: (points on the lines, unit directions)."""
    q0 = np.zeros(len(robot.joints))
    points, directions = [], []
    for joint in joints:
        T_base_joint = robot.transform(base, joint.child, q0, check_limits=False)  # the joint frame is its child link's frame
        axis = T_base_joint[:3, :3] @ np.asarray(joint.axis, dtype=float)
        points.append(T_base_joint[:3, 3])
        directions.append(axis / np.linalg.norm(axis))
    return points, directions
