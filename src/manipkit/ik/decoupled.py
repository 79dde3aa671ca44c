"""Closed-form inverse kinematics by kinematic decoupling: SCARA, Stanford arm, elbow arm.

Conventions (docs/architecture.md, "Conventions"), restated where they matter:

- Metres and radians. ``T`` is ``T_base_tool``: the pose of the tool frame
  (DH frame n, the bundled URDF's ``ee_link``) in the base frame (DH frame 0,
  ``base_link``), a 4x4 homogeneous matrix.
- Standard DH (Spong): ``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``.
  Each arm's table is built by :func:`scara_dh_table`,
  :func:`stanford_dh_table` or :func:`elbow_dh_table` (from
  :mod:`manipkit.closed_form.arm_tables`); at their default
  parameters they are the bundled ``robots/dh/*.yaml`` tables and agree with
  the bundled ``robots/*.urdf.xacro`` descriptions.
- Joint vectors are in table order (``joint1 .. joint4`` or ``joint1 ..
  joint6``); revolute values are wrapped to (-pi, pi], the prismatic value
  d3 is in metres.
- Every returned solution has been put through the table's forward
  kinematics (:func:`manipkit.dh.dh_fk`) and reproduces ``T`` within ``tol``
  in position (m) and in rotation angle (rad). A candidate that does not is
  dropped and counted in ``rejected``; none is returned unchecked. The
  answer is a :class:`manipkit.ik.result.IKResult`, manipkit's one IK result type.

Decoupling (Spong): the three axes of a spherical wrist meet at the wrist
centre ``o_c = o - d6 R z`` (:func:`wrist_center`), which joints 4 to 6 do
not move. So joints 1 to 3 are found from ``o_c`` alone (inverse position),
and joints 4 to 6 from ``R_3^6 = (R_0^3)^T R`` (inverse orientation). With
the wrist rows ``(0, -90, 0, theta4)``, ``(0, 90, 0, theta5)``,
``(0, 0, d6, theta6)``, ``R_3^6 = Rz(theta4) Ry(theta5) Rz(theta6)``: the
wrist angles are the ZYZ Euler angles of ``R_3^6``, two sets for every
rotation off the singular set (:func:`manipkit.spatial.euler.euler_zyz_from_matrix`).

Labels (one per solution, parts joined by ``", "``; solutions come in the
order listed):

- SCARA: ``"righty"`` (theta2 in (0, pi): seen from above, the elbow lies to
  the right of the line from joint 1 to the quill, as with a right arm),
  then ``"lefty"`` (theta2 in (-pi, 0)); on the workspace boundary
  ``"straight"`` (theta2 = 0) or ``"folded"`` (theta2 = pi).
- Shoulder (Stanford and elbow arms): ``"front"`` (the arm reaches the wrist
  centre on the side joint 1 faces: ``c1 x_c + s1 y_c > 0``; Stanford theta2
  in (0, pi)), then ``"back"`` (joint 1 turned the other way and the arm
  reaching back over its top; Stanford theta2 in (-pi, 0)); ``"vertical"``
  (Stanford, boom vertical, ``c1 x_c + s1 y_c = 0``) or ``"overhead"``
  (wrist centre on joint 1's axis, theta1 free).
- Elbow (elbow arm): ``"elbow up"`` (the elbow above the line from the
  shoulder to the wrist centre, in the arm's vertical plane: theta3 < 0 in
  front, > 0 in back), then ``"elbow down"``; ``"arm straight"``
  (theta3 = 0), ``"arm folded"`` (theta3 = pi) on the boundary spheres.
- Wrist: ``"no flip"`` (theta5 in (0, pi)), then ``"flip"`` (theta5 in
  (-pi, 0), the same pose with theta4 and theta6 turned by pi);
  ``"wrist singular"`` (theta5 = 0 or pi, see below).

Singular sets: where a joint (or a combination) is free the result holds one
representative row with ``singular=True``, ``count`` infinite, the free
joints' indices in ``free_joints`` (their textbook names in
``free_parameter``) and the family in words in ``family``. At the wrist
singularity (z6 parallel to z3, theta5 = 0 or pi) only ``theta4 + theta6``
(theta5 = 0) or ``theta4 - theta6`` (theta5 = pi) is fixed: the row holds
theta4 = 0, and ``theta4 = t`` with ``theta6 = theta6_row - t`` (theta5 = 0)
or ``theta6 = theta6_row + t`` (theta5 = pi) gives the same pose for every t.

Modes (:data:`manipkit.ik.result.MODES`): the Stanford and elbow arms solve
a spatial pose only (``mode="pose"``). The SCARA solves a spatial pose with
its tool vertical (``mode="pose"``: x, y, z and the tool's heading; a tilted
tool is named with its tilt in ``unmet``) and a spatial position
(``mode="position"``): then the tool roll theta4 is free, a few values are
sampled and ``result.members(theta4_values)`` gives any others. Every
result names, when there is no solution, each component it cannot meet and
by how much (``unmet``).

Only numpy is imported (with manipkit's numpy-only rotations, planar and dh
modules).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from manipkit.bounds import tolerances
from manipkit.closed_form import planar as planar_ik  # its solution labels (a local 'planar' is an ik_2r result)
from manipkit.closed_form.arm_tables import (
    ELBOW_VARIABLES,
    SCARA_JOINTS,
    SCARA_VARIABLES,
    SIX_JOINTS,
    STANFORD_VARIABLES,
    elbow_dh_table,
    finite_number,
    scara_dh_table,
    stanford_dh_table,
)
from manipkit.closed_form.checks import finite_array, quantity_text
from manipkit.dh.table import DHTable, dh_fk
from manipkit.errors import ClosedFormIKError
from manipkit.ik.planar import ik_2r
from manipkit.ik.result import SPATIAL_POSE, SPATIAL_POSITION, IKResult, read_only
from manipkit.spatial.euler import euler_zyz_from_matrix
from manipkit.spatial.rotations import rot_x, rot_y, rot_z, wrap_angle
from manipkit.spatial.transforms import check_transform, pose_residuals

__all__ = [
    "ClosedFormIKError",
    "elbow_dh_table",
    "ik_elbow",
    "ik_scara",
    "ik_stanford",
    "scara_dh_table",
    "stanford_dh_table",
    "wrist_center",
]

# labels
RIGHTY, LEFTY, STRAIGHT, FOLDED = "righty", "lefty", "straight", "folded"
FRONT, BACK, VERTICAL, OVERHEAD = "front", "back", "vertical", "overhead"
ELBOW_UP, ELBOW_DOWN, ARM_STRAIGHT, ARM_FOLDED = "elbow up", "elbow down", "arm straight", "arm folded"
NO_FLIP, FLIP, WRIST_SINGULAR = "no flip", "flip", "wrist singular"
THETA1_FREE, THETA2_FREE = "theta1 free", "theta2 free"

_WRIST_FAMILY = (
    "wrist singular (z6 parallel to z3) in the rows labelled 'wrist singular': only theta4 + theta6 "
    "(theta5 = 0) or theta4 - theta6 (theta5 = pi) is fixed; each such row holds theta4 = 0, and theta4 = t "
    "with theta6 = theta6_row - t (theta5 = 0) or theta6 = theta6_row + t (theta5 = pi) reaches the same pose "
    "for every t"
)



# --------------------------------------------------------------------------
# candidates, input checks and small helpers


@dataclass(frozen=True)
class _Candidate:
    q: tuple[float, ...]
    label: str
    free: tuple[int, ...] = ()
    family: tuple[str, ...] = ()


def _tolerances(tol, singular_tol) -> tuple[tuple[float, float], float]:
    """((position m, rotation rad), singular_tol): ``tol`` by :func:`manipkit.ik.result.tolerances` (one number
    or a pair), ``singular_tol`` in [0, min(tol) / 4]."""
    tol = tolerances(tol, error=ClosedFormIKError)
    singular_tol = finite_number(singular_tol, "singular_tol")
    if not 0.0 <= singular_tol <= min(tol) / 4.0:
        raise ClosedFormIKError(
            f"singular_tol = {singular_tol} must be in [0, tol / 4] = [0, {quantity_text(min(tol) / 4.0)}], so that "
            "the representative of a singular family still passes the forward-kinematics check"
        )
    return tol, singular_tol


def _pose(T) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The target checked by :func:`manipkit.spatial.transforms.check_transform`, with its rotation and position."""
    T = check_transform(T, what="T")
    return T, T[:3, :3], T[:3, 3].copy()


_Problem = tuple[str, float, str]  # (component of the target, by how much it is missed (m or rad), the sentence)


def _prismatic(d3: float, limits: tuple[float, float], margin: float, low: str, high: str,
               component: str = "d3") -> tuple[float, _Problem | None]:
    """d3 clamped into its limits (when within ``margin`` of them), or the problem: (component, size, reason)."""
    lower, upper = limits
    d3_text = quantity_text(d3)
    if d3 < lower - margin:
        gap = lower - d3
        return d3, (component, gap, f"d3 = {d3_text} m is below its lower limit {quantity_text(lower)} m by {quantity_text(gap)} m ({low})")
    if d3 > upper + margin:
        gap = d3 - upper
        return d3, (component, gap, f"d3 = {d3_text} m is above its upper limit {quantity_text(upper)} m by {quantity_text(gap)} m ({high})")
    return min(max(d3, lower), upper), None


def _unmet(problems: list[_Problem]) -> tuple[tuple[str, float], ...]:
    """Each component once, with the smallest amount it is missed by (over the branches that tried it)."""
    sizes: dict[str, float] = {}
    for component, size, _ in problems:
        sizes[component] = min(size, sizes.get(component, math.inf))
    return tuple(sizes.items())


def _wrist(R_0_3: np.ndarray, R: np.ndarray, singular_tol: float) -> list[tuple[tuple[float, float, float], str, bool]]:
    """Wrist angles (theta4, theta5, theta6) reaching R from frame 3: [(angles, label, singular)].

    ``R_3^6 = (R_0^3)^T R = Rz(theta4) Ry(theta5) Rz(theta6)``. Off the
    singular set both ZYZ branches, theta5 > 0 ("no flip") first. On it
    (``|sin theta5| <= singular_tol``) one representative with theta4 = 0.
    """
    R_3_6 = R_0_3.T @ R
    sin5 = math.hypot(R_3_6[2, 0], R_3_6[2, 1])
    if sin5 <= singular_tol:
        # theta5 = 0:  R_3_6 = Rz(theta4 + theta6);  theta5 = pi: R_3_6 = Rz(theta4 - theta6) Ry(pi).
        # Either way phi = atan2(-r12, r22) is that sum or difference (psi = 0 on the singular set).
        phi = float(euler_zyz_from_matrix(R_3_6, gimbal_tol=singular_tol, check=False)[0])
        if R_3_6[2, 2] > 0.0:
            return [((0.0, 0.0, float(wrap_angle(phi))), WRIST_SINGULAR, True)]
        return [((0.0, math.pi, float(wrap_angle(-phi))), WRIST_SINGULAR, True)]
    up = euler_zyz_from_matrix(R_3_6, gimbal_tol=singular_tol, check=False)
    down = euler_zyz_from_matrix(R_3_6, theta_negative=True, gimbal_tol=singular_tol, check=False)
    return [(tuple(map(float, up)), NO_FLIP, False), (tuple(map(float, down)), FLIP, False)]


def _result(table: DHTable, T: np.ndarray, candidates: list[_Candidate], *, problems: list[_Problem], notes: list[str],
            tol: tuple[float, float], joint_names: tuple[str, ...], variables: tuple[str, ...],
            mode: str = SPATIAL_POSE) -> IKResult:
    """Check every candidate by the table's FK (residuals by :func:`manipkit.spatial.transforms.pose_residuals`;
    in mode ``SPATIAL_POSITION`` the position only), keep those within tol (m, rad), say why."""
    n = table.n
    if not candidates:
        reasons = list(dict.fromkeys(text for _, _, text in problems)) or ["no candidate solution"]
        nothing = read_only((), (n,))
        return IKResult(nothing, (), 0, "no solution: " + "; ".join(reasons), read_only(()), read_only(()),
                        joint_names=joint_names, mode=mode, unmet=_unmet(problems))

    Q = np.array([c.q for c in candidates], dtype=float)
    revolute = np.array([row.is_revolute for row in table.rows])
    Q[:, revolute] = wrap_angle(Q[:, revolute])
    measure = "position" if mode == SPATIAL_POSITION else "pose"
    position_error, rotation_error = (np.atleast_1d(e) for e in pose_residuals(T, dh_fk(table, Q), mode=measure))
    keep = (position_error <= tol[0]) & (rotation_error <= tol[1])
    rejected = int(np.count_nonzero(~keep))
    kept = [c for c, k in zip(candidates, keep) if k]

    free = tuple(sorted({j for c in kept for j in c.free}))
    families = list(dict.fromkeys(text for c in kept for text in c.family))
    family = "; ".join(families)

    lines = list(dict.fromkeys(notes))
    if family:
        lines.append("singular: " + family)
    if rejected:
        worst = float(np.max(np.maximum(position_error, rotation_error)[~keep]))
        lines.append(
            f"{rejected} candidate(s) failed the forward-kinematics check (worst residual {worst:.3g} > tol "
            f"{tol[0]:g} m, {tol[1]:g} rad) and were dropped; is T a proper rigid transform?"
        )
    k = len(kept)
    head = f"{k} solution{'s' if k != 1 else ''}" if k else "no solution"
    return IKResult(
        read_only(Q[keep], (n,)), tuple(c.label for c in kept), math.inf if free else k, head + ": " + "; ".join(lines),
        read_only(position_error[keep]), read_only(rotation_error[keep]),
        free_parameter=", ".join(variables[j] for j in free), joint_names=joint_names, family=family,
        free_joints=free, rejected=rejected, mode=mode, unmet=() if k else _unmet(problems),
    )


# --------------------------------------------------------------------------
# the wrist centre


def wrist_center(T, d6) -> np.ndarray:
    """Wrist centre ``o_c = o - d6 R z`` of a pose (Spong, decoupling).

    Parameters
    ----------
    T : array_like, shape (..., 4, 4)
        Tool poses ``T_base_tool`` (homogeneous; only the top three rows are read).
    d6 : float or array_like, shape (...)
        Distance (m) from the wrist centre to the tool frame along the tool's z axis.

    Returns
    -------
    o_c : ndarray, shape (..., 3)
        The wrist centre in the base frame: the tool origin ``o = T[:3, 3]``
        moved back by ``d6`` along the tool's z axis ``R z = T[:3, 2]``, i.e.
        ``(o_x - d6 r13, o_y - d6 r23, o_z - d6 r33)``.

    Examples
    --------
    >>> T = np.eye(4)
    >>> T[:3, 3] = [0.5, 0.0, 1.0]
    >>> wrist_center(T, 0.2)  # tool z points up: the wrist centre is 0.2 below
    array([0.5, 0. , 0.8])
    """
    try:
        T = np.asarray(T, dtype=float)
        d6 = np.asarray(d6, dtype=float)
    except (TypeError, ValueError):
        raise ClosedFormIKError("T and d6 must be numeric") from None
    if T.ndim < 2 or T.shape[-2:] != (4, 4):
        raise ClosedFormIKError(f"T must have shape (..., 4, 4), got {T.shape}")
    return T[..., :3, 3] - d6[..., None] * T[..., :3, 2]


def _wrist_centre_from_shoulder(T: np.ndarray, d1: float, d6: float):
    """(xc, yc, zc, r, s, label): the wrist centre, its distance ``r`` from joint 1's axis and its
    height ``s = zc - d1`` above the shoulder, as the decoupled solvers use them (Spong's r and s)."""
    xc, yc, zc = (float(v) for v in wrist_center(T, d6))
    label = "wrist centre (" + ", ".join(quantity_text(v) for v in (xc, yc, zc)) + ")"
    return xc, yc, zc, math.hypot(xc, yc), zc - d1, label


# --------------------------------------------------------------------------
# SCARA


_SCARA_LABELS = {planar_ik.ELBOW_DOWN: RIGHTY, planar_ik.ELBOW_UP: LEFTY, planar_ik.STRAIGHT: STRAIGHT, planar_ik.FOLDED: FOLDED,
                 planar_ik.Q1_FREE: THETA1_FREE}


def ik_scara(T, *, a1: float = 0.35, a2: float = 0.25, d1: float = 0.4, d4: float = 0.05,
             d3_limits: tuple[float, float] = (0.0, 0.3), mode: str = "pose", samples: int = 4, tol=1e-9,
             singular_tol: float = 1e-10) -> IKResult:
    """Every joint vector ``(theta1, theta2, d3, theta4)`` putting the SCARA's tool at pose T.

    Parameters
    ----------
    T : array_like, shape (4, 4)
        Target ``T_base_tool`` (base_link to ee_link of the bundled ``scara``).
    a1, a2, d1, d4, d3_limits : keyword-only
        The arm, as in :func:`scara_dh_table` (defaults: the bundled robot).
    mode : {"pose", "position"}, keyword-only
        ``"pose"``: position and orientation (the tool must point straight
        down; its heading is met by theta4). ``"position"``: the tool origin
        only (the rotation of T is ignored); the tool roll theta4 is then free.
    samples : int, keyword-only
        ``mode="position"``: how many values of theta4 to sample
        (``2 pi k / samples`` wrapped, k = 0 .. samples - 1).
    tol : float or (float, float), keyword-only
        Every returned row reproduces T within ``tol`` in position (m) and
        rotation (rad, mode ``"pose"``): one number for both, or ``(position,
        rotation)``; the rotation one is also how far the tool's z axis may
        be from straight down.
    singular_tol : float, keyword-only
        Distances (m) within which the quill axis counts as on a boundary
        circle (one solution) and d3 as at a limit.

    Returns
    -------
    IKResult
        Rows ``(theta1, theta2, d3, theta4)``, rad and m, angles in (-pi, pi]:

        - 2 generically: ``"righty"`` (theta2 > 0) then ``"lefty"`` (theta2 < 0);
        - 1 when the quill axis is on a boundary circle ``r = a1 + a2``
          (``"straight"``) or ``r = |a1 - a2|`` (``"folded"``);
        - 0 (with the reason, and ``unmet`` naming ``"tool z axis tilt"`` (rad),
          ``"position (r)"`` or ``"z"`` (m) with the amount) when the tool's z
          axis is not straight down (mode ``"pose"``), the quill axis is
          outside that annulus, or d3 is outside its limits;
        - mode ``"position"``: a family (``count`` infinite,
          ``free_parameter = "theta4"``, ``mode = SPATIAL_POSITION``), one row
          per elbow and sampled theta4, labelled ``"righty, theta4 = 0"``;
          ``result.members(theta4_values)`` gives the rows at other values;
        - a family when ``a1 = a2`` and the quill axis is joint 1's axis:
          theta1 free (row: theta1 = 0), theta2 = pi, theta4 = theta4_row + theta1.

    Notes
    -----
    With ``t12 = theta1 + theta2`` the pose is
    ``R = Rz(t12 - theta4) Rx(pi)`` (tool z down) and
    ``o = (a1 c1 + a2 c12, a1 s1 + a2 s12, d1 - d3 - d4)``. So
    ``d3 = d1 - d4 - o_z`` (the quill moves down: seed 001's
    ``l1 + l4 + d3 = z`` has the sign of d3 wrong), ``(theta1, theta2)`` are
    the planar 2R solutions for ``(o_x, o_y)`` with lengths a1, a2
    (:func:`manipkit.closed_form.planar.ik_2r`; seed 001 gives only the righty one), and
    ``theta4 = theta1 + theta2 - alpha`` with ``alpha = atan2(r21, r11)``,
    the heading of the tool's x axis.

    Examples
    --------
    >>> from manipkit.dh import dh_fk
    >>> T = dh_fk(scara_dh_table(), [0.3, 1.2, 0.1, -0.5])
    >>> result = ik_scara(T)
    >>> result.labels
    ('righty', 'lefty')
    >>> result.solutions.round(6)
    array([[ 0.3     ,  1.2     ,  0.1     , -0.5     ],
           [ 1.272935, -1.2     ,  0.1     , -1.927065]])
    """
    # Over 80 lines: the docstring (cases, labels and the derivation) is most of it.
    table = scara_dh_table(a1=a1, a2=a2, d1=d1, d4=d4, d3_limits=d3_limits)
    tol, singular_tol = _tolerances(tol, singular_tol)
    T, R, p = _pose(T)
    if mode == "pose":
        return _scara(table, T, R, p, None, tol, singular_tol)
    if mode != "position":
        raise ClosedFormIKError(f"mode '{mode}': the SCARA's closed form solves 'pose' or 'position'")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise ClosedFormIKError(f"samples = {samples!r} must be a whole number >= 1")

    def members(values) -> IKResult:
        rolls = np.atleast_1d(finite_array(values, "theta4 values"))
        if rolls.ndim != 1:
            raise ClosedFormIKError(f"theta4 values must be a sequence of angles, got shape {rolls.shape}")
        return _scara(table, T, R, p, rolls, tol, singular_tol)

    sampled = members(wrap_angle(2.0 * math.pi * np.arange(samples) / samples))
    if not sampled.success:
        return sampled
    family = ("position only: the tool roll theta4 is free (it turns the tool about its vertical axis and moves "
              "nothing else); the rows sample theta4, result.members(theta4_values) gives any other")
    if sampled.family:
        family += "; " + sampled.family
    free = ", ".join(dict.fromkeys(["theta4", *filter(None, sampled.free_parameter.split(", "))]))
    return sampled.replaced(count=math.inf, free_parameter=free, family=family, family_function=members,
                            note=sampled.note.replace(" solutions:", " sampled solutions:", 1) + "; " + family)


def _scara(table: DHTable, T: np.ndarray, R: np.ndarray, p: np.ndarray, theta4_values, tol: tuple[float, float],
           singular_tol: float) -> IKResult:
    """The SCARA rows for pose T (``theta4_values`` None), or for its position at each theta4 in ``theta4_values``."""
    a1, a2, d1, d4 = table.rows[0].a, table.rows[1].a, table.rows[0].d, table.rows[3].d
    limits = table.rows[2].qlim
    position_only = theta4_values is not None
    problems, notes, candidates = [], [], []
    tilt = math.atan2(math.hypot(R[0, 2], R[1, 2]), -R[2, 2])
    if not position_only and tilt > tol[1]:
        problems.append((
            "tool z axis tilt", tilt,
            f"the tool's z axis is tilted {quantity_text(tilt)} rad ({quantity_text(math.degrees(tilt))} deg) from straight down; "
            "a SCARA's tool axis is always vertical, pointing down (T[:3, 2] = (0, 0, -1)); ask for the position only "
            "to leave the orientation free",
        ))
    d3, out = _prismatic(d1 - d4 - p[2], limits, singular_tol, f"the target is too high: z = {quantity_text(p[2])} m",
                         f"the target is too low: z = {quantity_text(p[2])} m", component="z")
    if out:
        problems.append(out)
    planar = ik_2r(p[0], p[1], a1, a2, tol=singular_tol)
    r = math.hypot(p[0], p[1])
    if planar.count == 0:
        problems.append((
            "position (r)", planar.outside_by,
            f"the quill axis at (x, y) = ({quantity_text(p[0])}, {quantity_text(p[1])}) is r = {quantity_text(r)} m from joint 1's axis, "
            f"{planar.side} for the annulus |a1 - a2| = {quantity_text(abs(a1 - a2))} <= r <= a1 + a2 = {quantity_text(a1 + a2)} m, "
            f"outside by {quantity_text(planar.outside_by)} m",
        ))
    mode = SPATIAL_POSITION if position_only else SPATIAL_POSE
    if problems:
        return _result(table, T, [], problems=problems, notes=[], tol=tol, joint_names=SCARA_JOINTS,
                       variables=SCARA_VARIABLES, mode=mode)

    where = {
        planar_ik.ELBOW_DOWN: f"inside the annulus |a1 - a2| = {quantity_text(abs(a1 - a2))} < r < a1 + a2 = {quantity_text(a1 + a2)} m",
        planar_ik.STRAIGHT: f"on its outer circle r = a1 + a2 = {quantity_text(a1 + a2)} m (arm straight, theta2 = 0)",
        planar_ik.FOLDED: f"on its inner circle r = |a1 - a2| = {quantity_text(abs(a1 - a2))} m (arm folded, theta2 = pi)",
        planar_ik.Q1_FREE: "on joint 1's axis with a1 = a2",
    }[planar.labels[0]]
    notes.append(f"quill axis at r = {quantity_text(r)} m from joint 1's axis, {where}; d3 = {quantity_text(d3)} m")
    alpha = math.atan2(R[1, 0], R[0, 0])
    rolls = [None] if not position_only else [float(v) for v in np.atleast_1d(np.asarray(theta4_values, dtype=float))]
    for roll in rolls:
        for (theta1, theta2), label in zip(planar.solutions, planar.labels):
            free, family = (), ()
            if label == planar_ik.Q1_FREE:
                free = (0,)
                family = (
                    "theta1 free (a1 = a2 and the quill on joint 1's axis, arm folded with theta2 = pi): the row holds "
                    "theta1 = 0, and theta1 = t with theta4 = theta4_row + t reaches the same pose for every t",
                )
            theta4 = theta1 + theta2 - alpha if roll is None else roll
            name = _SCARA_LABELS[label] + ("" if roll is None else f", theta4 = {quantity_text(float(wrap_angle(roll)))}")
            candidates.append(_Candidate((theta1, theta2, d3, theta4), name, free, family))
    return _result(table, T, candidates, problems=problems, notes=notes, tol=tol, joint_names=SCARA_JOINTS,
                   variables=SCARA_VARIABLES, mode=mode)


# --------------------------------------------------------------------------
# Stanford arm


def ik_stanford(T, *, d1: float = 0.0, d2: float = 0.154, d6: float = 0.263,
                d3_limits: tuple[float, float] = (0.1, 1.0), tol=1e-9,
                singular_tol: float = 1e-10) -> IKResult:
    """Every joint vector ``(theta1, theta2, d3, theta4, theta5, theta6)`` putting the Stanford arm's tool at T.

    Parameters
    ----------
    T : array_like, shape (4, 4)
        Target ``T_base_tool`` = Spong's ``T_0^6`` (base_link to ee_link of
        the bundled ``stanford_arm``).
    d1, d2, d6, d3_limits : keyword-only
        The arm, as in :func:`stanford_dh_table` (defaults: the bundled robot,
        d3 in 0.1 .. 1.0 m).
    tol : float or (float, float), keyword-only
        Every returned row reproduces T within ``tol`` (m, rad): one number
        for both, or ``(position, rotation)``.
    singular_tol : float, keyword-only
        Within it (m, or sin theta5) the wrist centre counts as on the
        cylinder ``r = |d2|`` (one shoulder solution), the wrist as singular,
        d3 as at a limit.

    Returns
    -------
    IKResult
        Rows in rad and m, angles in (-pi, pi]:

        - 4 generically: ``"front, no flip"``, ``"front, flip"``,
          ``"back, no flip"``, ``"back, flip"``;
        - 2 shoulder-vertical rows (``"vertical, ..."``) when the wrist centre
          is on the cylinder ``r = |d2|`` about joint 1's axis;
        - one ``"wrist singular"`` row instead of two for each arm solution
          whose z3 is parallel to z6 (``singular=True``);
        - 0 with the reason when the wrist centre is inside that cylinder
          (by how much) or d3 would break a limit (which, by how much).

    Notes
    -----
    Inverse position (seed 001 part b, corrected). The wrist centre is
    ``o_c = (c1 s2 d3 - s1 d2, s1 s2 d3 + c1 d2, c2 d3 + d1)``. With
    ``rho = s2 d3`` this reads ``(x_c, y_c) = Rz(theta1) (rho, d2)``, so
    ``rho = +-sqrt(r^2 - d2^2)`` (``r^2 = x_c^2 + y_c^2``) and
    ``theta1 = atan2(rho y_c - d2 x_c, rho x_c + d2 y_c)``: "front" takes
    ``rho > 0``, "back" ``rho < 0``; with ``phi = atan2(y_c, x_c)`` these
    are ``phi - atan(d2 / sqrt(r^2 - d2^2))`` and
    ``phi + atan(d2 / sqrt(r^2 - d2^2)) - pi``. (The seed writes
    ``sin(theta1 - phi) = d2 / r`` for ``sin(phi - theta1) = d2 / r`` and
    gives the second branch without the ``- pi``.) Then with
    ``s = z_c - d1``: ``d3 = sqrt(rho^2 + s^2)``, ``theta2 = atan2(rho, s)``.
    The other root ``d3 < 0`` (with theta2 + pi) would need the boom to
    reach back through the shoulder; it is never a solution, since the
    lower limit is >= 0.

    Inverse orientation: ``R_0^3 = Rz(theta1) Ry(theta2)`` and the wrist
    angles are the ZYZ angles of ``R_3^6 = (R_0^3)^T R``, both branches.

    Examples
    --------
    >>> from manipkit.dh import dh_fk
    >>> T = dh_fk(stanford_dh_table(), [0.4, 0.8, 0.6, 0.3, 1.0, -0.2])
    >>> result = ik_stanford(T)
    >>> result.labels
    ('front, no flip', 'front, flip', 'back, no flip', 'back, flip')
    >>> result.solutions[0].round(6)
    array([ 0.4,  0.8,  0.6,  0.3,  1. , -0.2])
    """
    # Over 80 lines: the docstring (cases, labels and the derivation) is half of it; the code is one pass,
    # inverse position then inverse orientation.
    table = stanford_dh_table(d1=d1, d2=d2, d6=d6, d3_limits=d3_limits)
    d1, d2, d6 = table.rows[0].d, table.rows[1].d, table.rows[5].d
    limits = table.rows[2].qlim
    tol, singular_tol = _tolerances(tol, singular_tol)
    T, R, p = _pose(T)

    xc, yc, zc, r, s, centre = _wrist_centre_from_shoulder(T, d1, d6)
    problems, notes = [], []

    shoulders = []  # (theta1, rho, label, free, family)
    if abs(d2) <= singular_tol and r <= singular_tol:
        shoulders.append((0.0, xc, OVERHEAD, (0,), (
            "theta1 free (d2 = 0 and the wrist centre on joint 1's axis): the rows hold theta1 = 0; any other "
            "theta1 = t reaches the pose too, with theta2, d3 unchanged and the wrist re-solved from "
            "R_3^6 = (Rz(t) Ry(theta2))^T R",
        )))
    elif r < abs(d2) - singular_tol:
        problems.append((
            "wrist centre", abs(d2) - r,
            f"the {centre} is r = {quantity_text(r)} m from joint 1's axis, inside the cylinder r < |d2| = {quantity_text(abs(d2))} m "
            f"that the offset boom cannot enter, by {quantity_text(abs(d2) - r)} m",
        ))
    elif r <= abs(d2) + singular_tol:
        shoulders.append((math.atan2(-d2 * xc, d2 * yc), 0.0, VERTICAL, (), ()))
        notes.append(f"{centre} on the cylinder r = |d2| = {quantity_text(abs(d2))} m: one shoulder solution, boom vertical")
    else:
        rho = math.sqrt((r - abs(d2)) * (r + abs(d2)))
        for signed, label in ((rho, FRONT), (-rho, BACK)):
            shoulders.append((math.atan2(signed * yc - d2 * xc, signed * xc + d2 * yc), signed, label, (), ()))

    candidates = []
    for theta1, rho, shoulder, free, family in shoulders:
        d3_raw = math.hypot(rho, s)
        d3, out = _prismatic(d3_raw, limits, singular_tol,
                             "the wrist centre is too close to the shoulder", "the wrist centre is too far from the shoulder")
        if out:
            problems.append(out)
            continue
        theta2 = math.atan2(rho, s)
        if d3_raw <= singular_tol:
            theta2, free = 0.0, free + (1,)
            family = family + (
                "theta2 free (d3 = 0: the wrist centre at the shoulder): the rows hold theta2 = 0; any other theta2 "
                "reaches the pose too, with the wrist re-solved",
            )
        R_0_3 = rot_z(theta1) @ rot_y(theta2)
        for (theta4, theta5, theta6), wrist_label, wrist_singular in _wrist(R_0_3, R, singular_tol):
            candidates.append(_Candidate(
                (theta1, theta2, d3, theta4, theta5, theta6), f"{shoulder}, {wrist_label}",
                free + ((3,) if wrist_singular else ()), family + ((_WRIST_FAMILY,) if wrist_singular else ()),
            ))
    if candidates:
        notes.insert(0, f"{centre}, r = {quantity_text(r)} m from joint 1's axis, d3 = {quantity_text(candidates[0].q[2])} m")
    return _result(table, T, candidates, problems=problems, notes=notes, tol=tol, joint_names=SIX_JOINTS,
                   variables=STANFORD_VARIABLES)


# --------------------------------------------------------------------------
# elbow manipulator


def _elbow_label(planar_label: str, back: bool) -> str:
    if planar_label == planar_ik.ELBOW_DOWN:  # theta3 > 0: the elbow on the clockwise side of the ray to the wrist
        return ELBOW_UP if back else ELBOW_DOWN
    if planar_label == planar_ik.ELBOW_UP:
        return ELBOW_DOWN if back else ELBOW_UP
    return {planar_ik.STRAIGHT: ARM_STRAIGHT, planar_ik.FOLDED: ARM_FOLDED, planar_ik.Q1_FREE: THETA2_FREE}[planar_label]


def ik_elbow(T, *, d1: float = 0.4, a2: float = 0.45, a3: float = 0.4, d6: float = 0.1,
             tol=1e-9, singular_tol: float = 1e-10) -> IKResult:
    """Every joint vector ``(theta1, ..., theta6)`` putting the elbow arm's tool at T.

    Parameters
    ----------
    T : array_like, shape (4, 4)
        Target ``T_base_tool`` = the table's ``T_0^6`` (base_link to ee_link
        of the bundled ``elbow_arm``).
    d1, a2, a3, d6 : float, keyword-only
        The arm, as in :func:`elbow_dh_table` (defaults: the bundled robot).
    tol : float or (float, float), keyword-only
        Every returned row reproduces T within ``tol`` (m, rad): one number
        for both, or ``(position, rotation)``.
    singular_tol : float, keyword-only
        Within it (m, or sin theta5) the wrist centre counts as on joint 1's
        axis, on a boundary sphere about the shoulder, or the wrist as singular.

    Returns
    -------
    IKResult
        Rows in rad, wrapped to (-pi, pi]:

        - 8 generically, in the order front/back x elbow up/down x no flip/flip,
          e.g. ``"front, elbow up, no flip"``;
        - 4 when the wrist centre is on a boundary sphere about the shoulder
          (``"arm straight"``: distance a2 + a3, or ``"arm folded"``:
          ``|a2 - a3|``);
        - one ``"wrist singular"`` row instead of two for each arm solution
          at the wrist singularity (z6 parallel to z3; then every arm
          solution is singular, since z3 = (s1, -c1, 0) depends on theta1 only);
        - ``"overhead"`` rows, theta1 free (rows hold theta1 = 0), when the
          wrist centre is on joint 1's axis;
        - 0 with the reason when the wrist centre is out of reach (how far).

    Notes
    -----
    Inverse position: the wrist centre (frame 3's origin) is
    ``o_c = (c1 u, s1 u, d1 + a2 s2 + a3 s23)`` with ``u = a2 c2 + a3 c23``.
    So ``theta1 = atan2(y_c, x_c)`` ("front", ``u = r``) or that plus pi
    ("back", ``u = -r``), and ``(theta2, theta3)`` solve the planar 2R arm
    (a2, a3) for the point ``(u, z_c - d1)`` in the arm's vertical plane
    (:func:`manipkit.closed_form.planar.ik_2r`, whose elbow-down / elbow-up become
    elbow down / up in front and up / down in back).

    Inverse orientation: ``R_0^3 = Rz(theta1) Rx(90 deg) Rz(theta2 + theta3)``
    and the wrist angles are the ZYZ angles of ``R_3^6 = (R_0^3)^T R``.

    Examples
    --------
    >>> from manipkit.dh import dh_fk
    >>> T = dh_fk(elbow_dh_table(), [0.5, 0.4, -1.0, 0.3, 0.9, 0.2])
    >>> result = ik_elbow(T)
    >>> result.count, result.labels[0]
    (8, 'front, elbow up, no flip')
    >>> result.solutions[0].round(6)
    array([ 0.5,  0.4, -1. ,  0.3,  0.9,  0.2])
    """
    # Over 80 lines: the docstring (cases, labels and the derivation) is half of it; the code is one pass,
    # inverse position then inverse orientation.
    table = elbow_dh_table(d1=d1, a2=a2, a3=a3, d6=d6)
    d1, a2, a3, d6 = table.rows[0].d, table.rows[1].a, table.rows[2].a, table.rows[5].d
    tol, singular_tol = _tolerances(tol, singular_tol)
    T, R, p = _pose(T)

    xc, yc, zc, r, s, centre = _wrist_centre_from_shoulder(T, d1, d6)
    distance = math.hypot(r, s)
    problems, notes = [], []

    if r <= singular_tol:
        shoulders = [(0.0, xc, OVERHEAD, False, (0,), (
            "theta1 free (the wrist centre on joint 1's axis): the rows hold theta1 = 0; any other theta1 = t "
            "reaches the pose too, with theta2, theta3 unchanged and the wrist re-solved from "
            "R_3^6 = (Rz(t) Rx(90 deg) Rz(theta2 + theta3))^T R",
        ))]
    else:
        heading = math.atan2(yc, xc)
        shoulders = [(heading, r, FRONT, False, (), ()), (heading + math.pi, -r, BACK, True, (), ())]

    candidates = []
    for theta1, u, shoulder, back, free, family in shoulders:
        planar = ik_2r(u, s, a2, a3, tol=singular_tol)
        if planar.count == 0:
            problems.append((
                "wrist centre", planar.outside_by,
                f"the {centre} is {quantity_text(distance)} m from the shoulder (0, 0, {quantity_text(d1)}), {planar.side} for "
                f"the shell |a2 - a3| = {quantity_text(abs(a2 - a3))} <= distance <= a2 + a3 = {quantity_text(a2 + a3)} m, "
                f"outside by {quantity_text(planar.outside_by)} m",
            ))
            continue
        arms = sorted(
            ((row, _elbow_label(label, back)) for row, label in zip(planar.solutions, planar.labels)),
            key=lambda item: item[1] != ELBOW_UP,
        )
        for (theta2, theta3), elbow in arms:
            arm_free, arm_family = free, family
            if elbow == THETA2_FREE:
                arm_free = free + (1,)
                arm_family = family + (
                    "theta2 free (a2 = a3 and the wrist centre at the shoulder, arm folded with theta3 = pi): the rows "
                    "hold theta2 = 0; any other theta2 reaches the pose too, with the wrist re-solved",
                )
            R_0_3 = rot_z(theta1) @ rot_x(math.pi / 2.0) @ rot_z(theta2 + theta3)
            for (theta4, theta5, theta6), wrist_label, wrist_singular in _wrist(R_0_3, R, singular_tol):
                candidates.append(_Candidate(
                    (theta1, theta2, theta3, theta4, theta5, theta6), f"{shoulder}, {elbow}, {wrist_label}",
                    arm_free + ((3,) if wrist_singular else ()),
                    arm_family + ((_WRIST_FAMILY,) if wrist_singular else ()),
                ))
    if candidates:
        notes.append(f"{centre}, {quantity_text(distance)} m from the shoulder, r = {quantity_text(r)} m from joint 1's axis")
    return _result(table, T, candidates, problems=problems, notes=notes, tol=tol, joint_names=SIX_JOINTS,
                   variables=ELBOW_VARIABLES)
