"""Does a DH table agree with a robot's URDF chain? If not, where and how.

The table's rows map in order to the movable joints on the URDF path from a
base frame to a tip frame; the same joint values go to both. Agreement is
measured on sampled configurations inside the joint limits: the largest
position error (m) and rotation error (rad) of ``T_base_tip``.

The diagnosis compares the two chains as products of exponentials. At the
zero configuration each joint i is a screw axis ``S_i = (w_i, v_i)`` in the
base frame (w the unit axis, v = -w x p for a point p on it; ``(0, v)`` for
a prismatic joint), and ``T(q) = exp([S_1] q_1) ... exp([S_n] q_n) M``.
Two chains agree for all q exactly when their screws and their home poses
``M`` are equal. So:

- a joint whose screw is the negative of the URDF's turns the other way;
- the first joint whose screw differs otherwise is where the chains stop
  agreeing (reported with the angle between the axes and their distance);
- when every screw agrees (up to sign), a constant tool transform
  ``X = M_dh^-1 M_urdf`` reconciles them;
- a constant base transform ``B`` with ``Ad(B) S_dh = S_urdf`` moves every
  axis at once (a shift along axes that are all parallel commutes with the
  chain: it is put in ``B``, not in the tool transform); joint zero offsets
  ``o`` move the axes after joint i about axis i. Each candidate correction
  is checked on the samples, and the report says whether it reconciles the
  two fully.

The screws are taken numerically (central differences of the FK, error
about 1e-10), the same way for both sources, so no DH convention is assumed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from manipkit.spatial.transforms import pose_error
from manipkit.dh.table import DHTable, dh_fk
from manipkit.spatial.rotations import rpy_from_matrix

SCREW_TOL = 1e-6  # screws equal within this (axis direction and moment)
RECONCILE_TOL = 1e-8  # a correction "reconciles fully" when it leaves less than this (m, rad)


@dataclass(frozen=True)
class DHCheck:
    """Result of :func:`check_dh`.

    Attributes
    ----------
    max_position_error : float
        Largest ``|p_dh - p_urdf|`` over the samples (m); NaN when the joint
        counts differ.
    max_rotation_error : float
        Largest rotation angle between the two orientations (rad).
    passed : bool
        Both errors within ``tol``.
    diagnosis : tuple of str
        Human-readable findings (empty when the table agrees).
    joints : tuple of str
        URDF joints the rows map to.
    samples, tol : int, float
        How the check was run.
    """

    max_position_error: float
    max_rotation_error: float
    passed: bool
    diagnosis: tuple[str, ...]
    joints: tuple[str, ...]
    samples: int
    tol: float


def check_dh(table: DHTable, robot, *, base: str = "base_link", tip: str = "ee_link",
             samples: int = 1000, tol: float = 1e-9, seed: int = 0) -> DHCheck:
    """Compare a DH table's FK with a robot's URDF chain from ``base`` to ``tip``.

    Parameters
    ----------
    table : DHTable
        Rows map in order to the movable joints from ``base`` to ``tip``.
    robot : manipkit.kinematics.robot.Robot
    base, tip : str
        URDF frames (aliases ``base_link`` and ``ee_link`` work).
    samples : int
        Configurations of the chain's joints drawn uniformly inside their
        limits (continuous joints in [-pi, pi]) from the fixed ``seed``;
        joints off the chain stay at ``robot.q()`` (0, or the nearest value
        inside their limits).
    tol : float
        Pass when both maximum errors (m, rad) are within it.

    Returns
    -------
    DHCheck
    """
    joints = robot.chain_joints(base, tip)
    if table.n != len(joints):
        note = (
            f"the table has {table.n} rows but the URDF chain {base} -> {tip} has {len(joints)} movable joints"
            f" ({', '.join(joints) or 'none'}); rows map in order to those joints"
        )
        extra = _count_hint(table, len(joints))
        return DHCheck(math.nan, math.nan, False, (note,) + extra, joints, 0, tol)

    index = [robot.joint_names.index(name) for name in joints]
    Q = robot.sample_q(samples, seed=seed)[:, index]
    urdf_fk = _urdf_fk(robot, base, tip, index)
    position_errors, rotation_errors = pose_error(urdf_fk(Q), dh_fk(table, Q))
    max_position, max_rotation = float(position_errors.max()), float(rotation_errors.max())
    passed = max_position <= tol and max_rotation <= tol
    diagnosis = () if passed else tuple(_diagnose(table, urdf_fk, joints, Q, tol, max_position, max_rotation))
    return DHCheck(max_position, max_rotation, passed, diagnosis, joints, samples, tol)


def _urdf_fk(robot, base, tip, index):
    """FK of the URDF chain as a function of the chain's joint values only."""
    q_rest = robot.q()

    def fk(q_chain):
        q_chain = np.asarray(q_chain, dtype=float)
        Q = np.broadcast_to(q_rest, q_chain.shape[:-1] + q_rest.shape).copy()
        Q[..., index] = q_chain
        return robot.fk(Q, tip, base=base)

    return fk


def _count_hint(table: DHTable, n_joints: int) -> tuple[str, ...]:
    if table.n == n_joints + 1:
        last = table.rows[-1]
        return (
            f"the last row (a={last.a:g}, alpha={math.degrees(last.alpha):g} deg, d={last.d:g}, "
            f"theta={math.degrees(last.theta):g} deg) has no joint to map to: if it only places the tool, "
            "write it as `tool:` instead of a row",
        )
    if table.n < n_joints:
        return (f"{n_joints - table.n} joint(s) of the URDF chain have no row; check --base and --tip",)
    return (f"{table.n - n_joints} row(s) too many; check --base and --tip",)


# --------------------------------------------------------------------------
# Screws and the diagnosis
# --------------------------------------------------------------------------


def screws(fk, n: int, q0=None, *, step: float = 1e-5) -> np.ndarray:
    """Spatial screw axes of a chain at ``q0`` (default zero), in the chain's base frame.

    Parameters
    ----------
    fk : callable
        ``fk(q) -> (4, 4)`` for q of shape (n,).
    n : int
        Number of joints.

    Returns
    -------
    S : ndarray, shape (n, 6)
        Rows ``(w, v)``: unit axis w and ``v = -w x p`` for revolute joints,
        ``(0, direction)`` for prismatic ones; ``[S_i] = dT/dq_i T^-1``.
    """
    q0 = np.zeros(n) if q0 is None else np.asarray(q0, dtype=float)
    T_inv = np.linalg.inv(fk(q0))
    result = np.empty((n, 6))
    for i in range(n):
        e = np.zeros(n)
        e[i] = step
        twist = (fk(q0 + e) - fk(q0 - e)) / (2 * step) @ T_inv
        result[i] = [twist[2, 1], twist[0, 2], twist[1, 0], *twist[:3, 3]]
    return result


def _screw_line(S):
    """(direction, a point on the axis) of a revolute screw; (direction, None) for prismatic."""
    w, v = S[:3], S[3:]
    if np.linalg.norm(w) < 0.5:
        return v / np.linalg.norm(v), None
    return w, np.cross(w, v)  # v = -w x p = p x w, so w x v is the foot point of the origin


def _compare_screws(S_urdf, S_dh):
    """'same', 'reversed' or a description of how two joint axes differ."""
    if np.abs(S_urdf - S_dh).max() < SCREW_TOL:
        return "same"
    if np.abs(S_urdf + S_dh).max() < SCREW_TOL:
        return "reversed"
    (w_u, p_u), (w_d, p_d) = _screw_line(S_urdf), _screw_line(S_dh)
    if (p_u is None) != (p_d is None):
        urdf_moves, table_moves = ("slides", "turns") if p_u is None else ("turns", "slides")
        return f"the URDF joint {urdf_moves}, the table's row {table_moves} (check the row's type)"
    angle = math.degrees(math.atan2(np.linalg.norm(np.cross(w_u, w_d)), abs(float(w_u @ w_d))))
    if p_u is None:  # both slide
        return f"its axis differs by {angle:.3g} deg (URDF {_vec(w_u)}, table {_vec(w_d)})"
    distance = _line_distance(w_u, p_u, w_d, p_d)
    return (
        f"its axis differs: URDF along {_vec(w_u)} through {_vec(p_u)}, table along {_vec(w_d)} "
        f"through {_vec(p_d)} (angle {angle:.3g} deg, distance {distance:.4g} m)"
    )


def _line_distance(w1, p1, w2, p2) -> float:
    normal = np.cross(w1, w2)
    if np.linalg.norm(normal) < 1e-9:
        return float(np.linalg.norm(np.cross(p2 - p1, w1)))
    return float(abs((p2 - p1) @ normal) / np.linalg.norm(normal))


def _diagnose(table, urdf_fk, joints, Q, tol, max_position, max_rotation) -> list[str]:
    n = len(joints)
    dh = lambda q: dh_fk(table, q)  # noqa: E731
    lines = [
        f"does not agree: max position error {max_position:.4g} m, max rotation error "
        f"{max_rotation:.4g} rad ({math.degrees(max_rotation):.4g} deg) over {len(Q)} samples"
    ]
    if n == 0:
        return lines + [_tool_line(_home_difference(urdf_fk, dh, np.zeros(0)))]
    S_u, S_d = screws(urdf_fk, n), screws(dh, n)
    verdicts = [_compare_screws(S_u[i], S_d[i]) for i in range(n)]
    signs = np.array([-1.0 if v == "reversed" else 1.0 for v in verdicts])
    reversed_joints = [i for i, v in enumerate(verdicts) if v == "reversed"]
    differing = [i for i, v in enumerate(verdicts) if v not in ("same", "reversed")]
    for i in reversed_joints:
        lines.append(
            f"joint {i + 1} ({joints[i]}) turns the other way: the table's z axis points opposite to the URDF axis "
            f"{_vec(_screw_line(S_u[i])[0])} at q = 0"
        )
    if differing:
        first = differing[0]
        lines.append(f"the chains stop agreeing at joint {first + 1} ({joints[first]}): {verdicts[first]}")
        if len(differing) > 1:
            lines.append("axes also differ at joints " + ", ".join(f"{i + 1} ({joints[i]})" for i in differing[1:]))
    else:
        lines.append("every joint axis of the table lies on the URDF's axis at q = 0" +
                     (" (some reversed)" if reversed_joints else ""))

    candidates = _reconciliations(table, urdf_fk, S_u, S_d, signs, Q, tol)
    full = [c for c in candidates if c[1] <= max(tol, RECONCILE_TOL)]
    if full:
        lines.append(f"{full[0][0]}: reconciles them fully (remaining error {full[0][1]:.2g})")
    else:
        best = min(candidates, key=lambda c: c[1], default=None)
        if best is not None and best[1] < 0.5 * max(max_position, max_rotation):
            lines.append(f"{best[0]}: reduces the error to {best[1]:.3g} but does not reconcile them fully")
        lines.append("no constant base or tool transform, joint zero offset or joint direction change reconciles them")
    return lines


def _reconciliations(table, urdf_fk, S_u, S_d, signs, Q, tol):
    """Candidate corrections ``(description, remaining max error)``, simplest first."""
    n = len(signs)
    dh = lambda q: dh_fk(table, q)  # noqa: E731
    flips = [i + 1 for i in range(n) if signs[i] < 0]
    flip_text = f"with joint(s) {', '.join(map(str, flips))} reversed, " if flips else ""
    M_u, M_d = urdf_fk(np.zeros(n)), dh(np.zeros(n))  # home poses
    out = []

    # Tool only: T_urdf(q) = T_dh(s q) X.
    X = np.linalg.inv(M_d) @ M_u
    out.append((f"{flip_text}{_tool_line(X)}", _residual(urdf_fk, lambda q: dh(q * signs) @ X, Q)))

    # Base only: T_urdf(q) = B T_dh(s q).
    B = M_u @ np.linalg.inv(M_d)
    out.append((f"{flip_text}a constant base transform {_pose_text(B)} (before row 1)",
                 _residual(urdf_fk, lambda q: B @ dh(q * signs), Q)))

    # Base and tool: align the table's axes with the URDF's by one rigid motion.
    B = _align_axes(S_u, S_d * signs[:, None], M_u[:3, 3], M_d[:3, 3])
    if B is not None:
        X = np.linalg.inv(B @ M_d) @ M_u
        out.append((f"{flip_text}a base transform {_pose_text(B)} and a tool transform {_pose_text(X)}",
                    _residual(urdf_fk, lambda q: B @ dh(q * signs) @ X, Q)))

    # Joint zero offsets (and a tool transform for what is left at the tip).
    offsets = _fit_offsets(S_u, dh, signs, n)
    if offsets is not None and np.abs(offsets).max() > 1e-9:
        X = _home_difference(urdf_fk, dh, offsets)
        described = ", ".join(f"joint {i + 1} by {math.degrees(o):+.6g} deg" for i, o in enumerate(offsets) if abs(o) > 1e-9)
        out.append((f"{flip_text}joint zero offsets ({described} added to theta) and {_tool_line(X)}",
                    _residual(urdf_fk, lambda q: dh(q * signs + offsets) @ X, Q)))
    return out


def _home_difference(urdf_fk, dh, q_dh):
    n = len(q_dh)
    return np.linalg.inv(dh(np.asarray(q_dh))) @ urdf_fk(np.zeros(n))


def _residual(urdf_fk, corrected, Q) -> float:
    """Largest position (m) or rotation (rad) error of ``corrected(Q)``, a batch of poses, over the samples."""
    position, rotation = pose_error(urdf_fk(Q), corrected(Q))
    return float(max(position.max(), rotation.max()))


def _align_axes(S_u, S_d, tip_u, tip_d):
    """A rigid transform B with Ad(B) S_d = S_u for every screw, if the axes allow one.

    The rotation is fitted to the axis directions and, for consecutive
    parallel turning axes, to the offset between them, ``(I - w w^T)(p_j - p_i)``
    (the same whichever points p are taken on the two lines). The offsets fix
    the turn about the shared axis that the directions leave open when all
    axes are parallel (planar arms, SCARA). A shift the axes leave open
    (along parallel axes; any shift when every joint slides) goes into B,
    chosen so that B takes the table's tool point ``tip_d`` (at q = 0) as
    close to the URDF's ``tip_u`` as it can: the tool transform then has no
    shift along the shared axis.
    """
    lines_u, lines_d = [_screw_line(s) for s in S_u], [_screw_line(s) for s in S_d]
    directions_u, directions_d = np.array([w for w, _ in lines_u]), np.array([w for w, _ in lines_d])
    turning = [i for i in range(len(S_u)) if lines_u[i][1] is not None and lines_d[i][1] is not None]
    offsets_u, offsets_d = [], []
    for i, j in zip(turning, turning[1:]):
        if np.linalg.norm(np.cross(directions_u[i], directions_u[j])) < SCREW_TOL:
            offsets_u.append(_across(directions_u[i], lines_u[j][1] - lines_u[i][1]))
            offsets_d.append(_across(directions_d[i], lines_d[j][1] - lines_d[i][1]))
    H = np.vstack([directions_d, *offsets_d]).T @ np.vstack([directions_u, *offsets_u])
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
    R = Vt.T @ D @ U.T
    if np.abs(R @ directions_d.T - directions_u.T).max() > 1e-6:
        return None
    # Translation t: each rotated table axis point R p_d + t must lie on the URDF axis.
    rows, rhs = [np.zeros((3, 3))], [np.zeros(3)]  # zero rows change nothing and keep A defined when no joint turns
    for i in turning:
        projector = np.eye(3) - np.outer(directions_u[i], directions_u[i])
        rows.append(projector)
        rhs.append(projector @ (lines_u[i][1] - R @ lines_d[i][1]))
    A = np.vstack(rows)
    t = np.linalg.lstsq(A, np.concatenate(rhs), rcond=None)[0]
    _, sigma, Vt = np.linalg.svd(A, full_matrices=False)
    free = Vt[np.count_nonzero(sigma > SCREW_TOL):]  # directions no axis fixes
    t += free.T @ (free @ (tip_u - R @ tip_d - t))
    B = np.eye(4)
    B[:3, :3], B[:3, 3] = R, t
    return B


def _across(w, v):
    """The part of ``v`` perpendicular to the unit vector ``w``: ``(I - w w^T) v``."""
    return v - (v @ w) * w


def _fit_offsets(S_u, dh, signs, n, grid: int = 72):
    """Joint offsets o such that the table's axes at q = o lie on the URDF's axes (sign-corrected).

    Joint by joint: offset i turns every later axis about axis i; it is chosen
    to bring the next axis that does not coincide with axis i onto the URDF's.
    """
    offsets = np.zeros(n)
    for i in range(n - 1):
        def mismatch(angle):
            trial = offsets.copy()
            trial[i] = angle
            S = screws(dh, n, trial) * signs[:, None]
            return float(np.abs(S[i + 1:] - S_u[i + 1:]).sum(axis=1)[0])

        S_now = screws(dh, n, offsets) * signs[:, None]
        if np.abs(S_now[i + 1] - S_u[i + 1]).max() < SCREW_TOL:
            continue
        angles = np.linspace(-math.pi, math.pi, grid, endpoint=False)
        values = [mismatch(a) for a in angles]
        best = float(angles[int(np.argmin(values))])
        a, b = best - 2 * math.pi / grid, best + 2 * math.pi / grid
        for _ in range(60):  # ternary search around the best grid point
            m1, m2 = a + (b - a) / 3, b - (b - a) / 3
            if mismatch(m1) < mismatch(m2):
                b = m2
            else:
                a = m1
        best = (a + b) / 2
        if mismatch(best) > 1e-5:
            return None
        offsets[i] = math.remainder(best, 2 * math.pi)
    return offsets


def _tool_line(X) -> str:
    if np.abs(X - np.eye(4)).max() < RECONCILE_TOL:
        return "no tool transform"
    return f"a constant tool transform {_pose_text(X)} (after the last row)"


def _pose_text(T) -> str:
    rpy = np.degrees(rpy_from_matrix(T[:3, :3], check=False))
    return f"xyz {_vec(T[:3, 3])} m, rpy {_vec(rpy, 4)} deg"


def _vec(values, digits: int = 6) -> str:
    return "[" + " ".join(f"{v + 0.0:.{digits}g}" if abs(v) > 1e-9 else "0" for v in values) + "]"
