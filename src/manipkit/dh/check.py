"""Does a DH table agree with a robot's URDF chain? If not, where and how.

The table's rows map in order to the movable joints on the URDF path from a
base frame to a tip frame; the same joint values go to both. Agreement is
measured on sampled configurations inside the joint limits: the largest
position error (m) and rotation error (rad) of ``T_base_tip``.

The diagnosis looks for the simplest explanation first, each candidate
checked on the samples (``DHCheck.candidate`` is the first corrected table
that agrees):

1. **constant base and tool transforms**, any rotation: a tool ``X = M_dh^-1
   M_urdf`` alone, a base ``B = M_urdf M_dh^-1`` alone, then both, with ``B``
   fitted (Kabsch) so that ``Ad(B) S_dh = S_urdf`` for the screws at q = 0
   and at two sampled configurations (a shift along axes that are all
   parallel commutes with the chain: it is put in ``B``);
2. **one table entry**: for every row and parameter (a, alpha, d, theta)
   the value that makes the table agree, in closed form (FK is ``L E(v) R``
   with ``E`` the entry's ``Tx``, ``Rx``, ``Tz`` or ``Rz``: least squares in
   ``v`` or in ``(cos v, sin v)``), named as "row 2: a = 0.43 m, the URDF
   implies 0.425 m"; every entry that alone explains the difference is
   named (theta of row 1 and a base turn about z can be the same thing), so
   a flipped alpha is that alpha, not a reversed joint; then one length
   (a or d) together with a base and tool transform (a published table
   whose base is turned against the URDF's and one length mistyped);
3. **one joint turning the other way** (:func:`~manipkit.dh.entries.reverse_joint`), with a base
   and tool refitted if need be;
4. otherwise, the chains are compared as products of exponentials. At the
   zero configuration each joint i is a screw axis ``S_i = (w_i, v_i)`` in the
   base frame (w the unit axis, v = -w x p for a point p on it; ``(0, v)`` for
   a prismatic joint), and ``T(q) = exp([S_1] q_1) ... exp([S_n] q_n) M``. Two
   chains agree for all q exactly when their screws and home poses ``M``
   are equal: a joint whose screw is the negative of the URDF's turns the
   other way, the first joint whose screw differs otherwise is where the
   chains stop agreeing (with the angle between the axes and their
   distance), and joint zero offsets are tried. When the rows match the
   URDF chain in kind, the table :func:`~manipkit.dh.from_urdf.dh_from_urdf_chain`
   derives in the same convention names every entry that differs (and is
   the candidate).

The screws are taken numerically (central differences of the FK, error
about 1e-10), the same way for both sources, so no DH convention is assumed.

Conventions (docs/architecture.md): ``T_a_b`` is the pose of frame b in frame
a; metres and radians, degrees only in the messages; rpy is ``R = Rz(yaw)
Ry(pitch) Rx(roll)``. The robot is used through its public methods only
(``chain_joints``, ``joint_names``, ``sample_q``, ``q``, ``fk``), so this
module does not import :mod:`manipkit.kinematics`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import partial
from itertools import pairwise
from typing import TYPE_CHECKING

import numpy as np

from manipkit.dh.entries import ANGLE_ENTRIES, ENTRIES, GENERATORS, dh_link_matrices, reverse_joint, row_factors
from manipkit.dh.from_urdf import dh_from_urdf_chain
from manipkit.dh.table import DHTable, dh_fk
from manipkit.dh.text import NOISE
from manipkit.errors import ManipkitError
from manipkit.spatial.rotations import rpy_from_matrix, wrap_angle
from manipkit.spatial.transforms import invert_transform, pose_residuals
from manipkit.text import short_text, vector_text

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["RECONCILE_TOL", "SCREW_TOL", "DHCheck", "check_dh", "screws"]

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
    candidate : DHTable or None
        When the table does not agree: a corrected table that does (the
        first full reconciliation the diagnosis names), else None.
    """

    max_position_error: float
    max_rotation_error: float
    passed: bool
    diagnosis: tuple[str, ...]
    joints: tuple[str, ...]
    samples: int
    tol: float
    candidate: DHTable | None = None


def check_dh(table: DHTable, robot: Robot, *, base: str = "base_link", tip: str = "ee_link",
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
    position_errors, rotation_errors = pose_residuals(urdf_fk(Q), dh_fk(table, Q))
    max_position, max_rotation = float(position_errors.max()), float(rotation_errors.max())
    passed = max_position <= tol and max_rotation <= tol
    diagnosis, candidate = (), None
    if not passed:
        def derive():
            try:
                return dh_from_urdf_chain(robot, base, tip, convention=table.convention)
            except ManipkitError:
                return None

        lines, candidate = _diagnose(table, urdf_fk, joints, Q, tol, max_position, max_rotation, derive)
        diagnosis = tuple(lines)
    return DHCheck(max_position, max_rotation, passed, diagnosis, joints, samples, tol, candidate)


def _urdf_fk(robot: Robot, base: str, tip: str, index: list[int]):
    """FK of the URDF chain as a function of the chain's joint values only."""
    q_rest = robot.q()

    def fk(q_chain):
        q_chain = np.asarray(q_chain, dtype=float)
        Q = np.broadcast_to(q_rest, q_chain.shape[:-1] + q_rest.shape).copy()
        Q[..., index] = q_chain
        return robot.fk(Q, base=base, tip=tip)

    return fk


def _count_hint(table: DHTable, n_joints: int) -> tuple[str, ...]:
    if table.n == n_joints + 1:
        last = table.rows[-1]
        return (
            (
                f"the last row (a={short_text(last.a)}, alpha={short_text(math.degrees(last.alpha))} deg, "
                f"d={short_text(last.d)}, theta={short_text(math.degrees(last.theta))} deg) has no joint to map to: "
                "if it only places the tool, write it as `tool:` instead of a row"
            ),
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
        ``fk(q) -> (4, 4)`` homogeneous transform for q of shape (n,).
    n : int
        Number of joints.

    Returns
    -------
    S : ndarray, shape (n, 6)
        Rows ``(w, v)``: unit axis w and ``v = -w x p`` for revolute joints,
        ``(0, direction)`` for prismatic ones; ``[S_i] = dT/dq_i T^-1``.
    """
    q0 = np.zeros(n) if q0 is None else np.asarray(q0, dtype=float)
    T_inv = invert_transform(fk(q0))
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
    angle = short_text(math.degrees(math.atan2(np.linalg.norm(np.cross(w_u, w_d)), abs(float(w_u @ w_d)))), 3)
    along_u, along_d = _vector_message(w_u), _vector_message(w_d)
    if p_u is None:  # both slide
        return f"its axis differs by {angle} deg (URDF {along_u}, table {along_d})"
    distance = short_text(_line_distance(w_u, p_u, w_d, p_d), 4)
    return (
        f"its axis differs: URDF along {along_u} through {_vector_message(p_u)}, table along {along_d} "
        f"through {_vector_message(p_d)} (angle {angle} deg, distance {distance} m)"
    )


def _line_distance(w1, p1, w2, p2) -> float:
    normal = np.cross(w1, w2)
    if np.linalg.norm(normal) < 1e-9:
        return float(np.linalg.norm(np.cross(p2 - p1, w1)))
    return float(abs((p2 - p1) @ normal) / np.linalg.norm(normal))


def _diagnose(table, urdf_fk, joints, Q, tol, max_position, max_rotation, derive) -> tuple[list[str], DHTable | None]:
    """The diagnosis lines and the first corrected table that agrees (None when none was found).

    In stages, simplest explanation first: (1) constant base and tool
    transforms (any rotation), (2) one table entry (row, parameter), (3) one
    joint turning the other way (with base and tool refitted); only when none
    of these reconciles the two chains, the screw comparison below locates
    where they stop agreeing, and the table derived from the URDF in the
    same convention (``derive()``) names the entries that differ.
    """
    n = len(joints)
    dh = partial(dh_fk, table)
    lines = [(
        f"does not agree: max position error {short_text(max_position, 4)} m, max rotation error "
        f"{short_text(max_rotation, 4)} rad ({short_text(math.degrees(max_rotation), 4)} deg) over {len(Q)} samples"
    )]
    if n == 0:
        return lines + [_tool_line(_home_difference(urdf_fk, dh, np.zeros(0)))], None
    limit = tol  # a candidate must pass the check it is offered for (DHCheck.candidate)
    fit = _Fit(table, urdf_fk, Q)

    full = [c for c in fit.base_and_tool(table, "") if c[2] <= limit][:1]  # stage 1: the simplest one
    full += [c for c in fit.single_entries() if c[2] <= limit]  # stage 2: every entry that alone explains it
    S_u, S_d = screws(urdf_fk, n), screws(dh, n)
    verdicts = [_compare_screws(S_u[i], S_d[i]) for i in range(n)]
    signs = np.array([-1.0 if v == "reversed" else 1.0 for v in verdicts])
    reversed_joints = [i for i, v in enumerate(verdicts) if v == "reversed"]
    if not full:  # stage 2b: one length and a base or tool transform
        full = [c for c in fit.length_entries_with_base_and_tool() if c[2] <= limit]
    if not full:
        full = fit.reversed_joints(joints, limit)  # stage 3
        if full and len(reversed_joints) > 1:  # several joints reversed as the table stands, if that explains it too
            turned = " and ".join(f"joint {i + 1} ({joints[i]}) turns the other way" for i in reversed_joints)
            full += [(f"{turned}: {text}", None, residual)
                     for text, residual in _reconciliations(table, urdf_fk, S_u, S_d, signs, Q, tol)
                     if residual <= limit][:1]
    if full:
        (text, candidate, residual), *others = full
        lines.append(f"{text}: reconciles them fully (remaining error {short_text(residual, 2)})")
        lines += [f"or equally {other}: reconciles them fully" for other, _, _ in others]
        return lines, candidate

    differing = [i for i, v in enumerate(verdicts) if v not in ("same", "reversed")]
    for i in reversed_joints:
        lines.append(
            f"joint {i + 1} ({joints[i]}) turns the other way: the table's z axis points opposite to the URDF axis "
            f"{_vector_message(_screw_line(S_u[i])[0])} at q = 0"
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
    full = [c for c in candidates if c[1] <= limit]
    if full:
        lines.append(f"{full[0][0]}: reconciles them fully (remaining error {short_text(full[0][1], 2)})")
    else:
        best = min(candidates, key=lambda c: c[1], default=None)
        if best is not None and best[1] < 0.5 * max(max_position, max_rotation):
            lines.append(f"{best[0]}: reduces the error to {short_text(best[1], 3)} but does not reconcile them fully")
        lines.append("no constant base or tool transform, single table entry, joint zero offset or joint direction "
                     "change reconciles them")
    derived = derive()
    differences = _entry_differences(table, derived) if derived is not None else []
    if not differences:
        return lines, None
    # the derived table, with the table's own names, limits and name: it agrees by construction
    rows = tuple(replace(new, qlim=row.qlim, name=row.name) for row, new in zip(table.rows, derived.rows))
    return lines + differences, DHTable(rows, table.convention, table.name, base=derived.base, tool=derived.tool)


def _reconciliations(table, urdf_fk, S_u, S_d, signs, Q, tol):
    """Candidate corrections ``(description, remaining max error)``, simplest first."""
    n = len(signs)
    dh = partial(dh_fk, table)
    flips = [i + 1 for i in range(n) if signs[i] < 0]
    flip_text = f"with joint(s) {', '.join(map(str, flips))} reversed, " if flips else ""
    M_u, M_d = urdf_fk(np.zeros(n)), dh(np.zeros(n))  # home poses
    out = []

    # Tool only: T_urdf(q) = T_dh(s q) X.
    X = invert_transform(M_d) @ M_u
    out.append((f"{flip_text}{_tool_line(X)}", _residual(urdf_fk, lambda q: dh(q * signs) @ X, Q)))

    # Base only: T_urdf(q) = B T_dh(s q).
    B = M_u @ invert_transform(M_d)
    out.append((f"{flip_text}a constant base transform {_pose_text(B)} (before row 1)",
                 _residual(urdf_fk, lambda q: B @ dh(q * signs), Q)))

    # Base and tool: align the table's axes with the URDF's by one rigid motion.
    B = _align_axes(S_u, S_d * signs[:, None], M_u[:3, 3], M_d[:3, 3])
    if B is not None:
        X = invert_transform(B @ M_d) @ M_u
        out.append((f"{flip_text}a base transform {_pose_text(B)} and a tool transform {_pose_text(X)}",
                    _residual(urdf_fk, lambda q: B @ dh(q * signs) @ X, Q)))

    # Joint zero offsets (and a tool transform for what is left at the tip).
    offsets = _fit_offsets(S_u, dh, signs, n)
    if offsets is not None and np.abs(offsets).max() > 1e-9:
        X = _home_difference(urdf_fk, dh, offsets)
        described = ", ".join(
            f"joint {i + 1} by {'+' if o > 0 else '-'}{short_text(math.degrees(abs(o)))} deg"
            for i, o in enumerate(offsets) if abs(o) > 1e-9
        )
        out.append((f"{flip_text}joint zero offsets ({described} added to theta) and {_tool_line(X)}",
                    _residual(urdf_fk, lambda q: dh(q * signs + offsets) @ X, Q)))
    return out


_FIT_SAMPLES = 32  # configurations an entry's value is fitted on (then checked on all samples)


class _Fit:
    """Corrections of a table fitted to the URDF's poses ``T_u`` at the samples ``Q`` (each checked on all of them)."""

    def __init__(self, table: DHTable, urdf_fk, Q):
        self.table, self.urdf_fk, self.Q = table, urdf_fk, Q
        self.T_u = urdf_fk(Q)
        n = table.n
        self.M_u = urdf_fk(np.zeros(n))
        # screws at q = 0 and at two sampled configurations: axes in general position fix any base rotation
        self.configurations = [np.zeros(n), *Q[:2]]
        self.S_u = np.vstack([_precise_screws(urdf_fk, n, q) for q in self.configurations])

    def residual(self, candidate: DHTable) -> float:
        """Largest position (m) or rotation (rad) error of ``candidate`` against the URDF over the samples."""
        position, rotation = pose_residuals(self.T_u, dh_fk(candidate, self.Q))
        return float(max(position.max(), rotation.max()))

    def base_and_tool(self, variant: DHTable, prefix: str) -> list:
        """``(text, corrected table, residual)`` for a new tool, a new base, then both (any rotations)."""
        n = variant.n
        M_d = dh_fk(variant, np.zeros(n))
        out = []

        def add(text, B, X):
            base = variant.base if np.array_equal(B, np.eye(4)) else _snapped(_snapped(B) @ variant.base)
            tool = variant.tool if np.array_equal(X, np.eye(4)) else _snapped(variant.tool @ _snapped(X))
            candidate = DHTable(variant.rows, variant.convention, variant.name, base=base, tool=tool)
            out.append((prefix + text, candidate, self.residual(candidate)))

        X = invert_transform(M_d) @ self.M_u  # T_urdf(q) = T_dh(q) X
        B = self.M_u @ invert_transform(M_d)  # T_urdf(q) = B T_dh(q)
        if np.abs(X - np.eye(4)).max() < RECONCILE_TOL:  # the home poses agree: the table as it is
            add("", np.eye(4), np.eye(4))
        else:
            add(_tool_line(X), np.eye(4), X)
            add(f"a constant base transform {_pose_text(B)} (before row 1)", B, np.eye(4))
        S_d = np.vstack([_precise_screws(partial(dh_fk, variant), n, q) for q in self.configurations])
        B = _align_axes(self.S_u, S_d, self.M_u[:3, 3], M_d[:3, 3])  # Ad(B) S_dh = S_urdf, then X at the tip
        if B is not None:
            X = invert_transform(B @ M_d) @ self.M_u
            add(f"a base transform {_pose_text(B)} and a tool transform {_pose_text(X)}", B, X)
        return out

    def single_entries(self) -> list:
        """``(text, corrected table, residual)`` for each entry whose right value alone makes the table agree.

        The value is fitted in closed form: FK is ``L E(v) R`` with ``E`` the
        entry's elementary transform (``Tx(a)``, ``Rx(alpha)``, ``Tz(d)``,
        ``Rz(theta)``), affine in ``v`` (lengths) or in ``(cos v, sin v)``
        (angles), so least squares over the samples gives ``v``.
        """
        out = []
        table = self.table
        for i, row in enumerate(table.rows):
            for entry in ENTRIES:
                value = self._fit_entry(i, entry)
                if value is None:
                    continue
                value = _snapped_entry(entry, value)
                current = getattr(row, entry)
                change = math.remainder(value - current, 2 * math.pi) if entry in ANGLE_ENTRIES else value - current
                if abs(change) < 1e-12:
                    continue
                rows = list(table.rows)
                rows[i] = replace(row, **{entry: value})
                candidate = replace(table, rows=tuple(rows))
                out.append((
                    f"row {i + 1}: {entry} = {_entry_text(entry, current)}, the URDF implies {_entry_text(entry, value)}",
                    candidate, self.residual(candidate),
                ))
        return out

    def _around(self, i: int, entry: str):
        """(L, G, R) over the fitting samples: FK of the table is ``L E(v) R`` with ``E = exp(v G)`` the entry's."""
        table = self.table
        Q = self.Q[:_FIT_SAMPLES]
        links = [dh_link_matrices(table, k, Q[:, k]) for k in range(table.n)]
        L = np.broadcast_to(table.base, (len(Q), 4, 4))
        for A in links[:i]:
            L = L @ A
        R = np.broadcast_to(table.tool, (len(Q), 4, 4))
        for A in reversed(links[i + 1:]):
            R = A @ R
        factors = row_factors(table.rows[i], Q[:, i], table.convention)
        k = [name for name, _ in factors].index(entry)
        for _, F in factors[:k]:
            L = L @ F
        for _, F in reversed(factors[k + 1:]):
            R = F @ R
        return L, GENERATORS[entry], R

    def _fit_entry(self, i: int, entry: str) -> float | None:
        L, G, R = self._around(i, entry)
        T_u = self.T_u[:_FIT_SAMPLES]
        if entry in ANGLE_ENTRIES:  # E = I + sin(v) K + (1 - cos(v)) K^2
            Y = (T_u - L @ (np.eye(4) + G @ G) @ R)[:, :3].ravel()
            A = np.stack([(L @ G @ R)[:, :3].ravel(), -(L @ G @ G @ R)[:, :3].ravel()], axis=1)
            (s, c), *_ = np.linalg.lstsq(A, Y, rcond=None)
            return float(math.atan2(s, c)) if math.hypot(s, c) > 0.5 else None
        Y = (T_u - L @ R)[:, :3].ravel()  # E = I + v G
        A = (L @ G @ R)[:, :3].ravel()
        norm = float(A @ A)
        return float(A @ Y / norm) if norm > 1e-18 else None

    def length_entries_with_base_and_tool(self) -> list:
        """``(text, corrected table, residual)`` for each length (a or d) whose right value, with a constant base
        and tool transform, makes the table agree.

        A length changes no joint axis direction, so the base rotation ``R_B``
        comes from the axes (:func:`_align_axes`) and the tool rotation from
        the home poses; what is left, ``p_urdf(q) = R_B (R_LR(q) t_X + p_LR(q)
        + v c(q)) + t_B``, is linear in the tool shift ``t_X``, the value ``v``
        and the base shift ``t_B``: least squares over the samples. A length
        that a base or tool shift could stand in for (d of row 1, say) is not
        named.
        """
        table, n = self.table, self.table.n
        M_d = dh_fk(table, np.zeros(n))
        S_d = np.vstack([_precise_screws(partial(dh_fk, table), n, q) for q in self.configurations])
        B = _align_axes(self.S_u, S_d, self.M_u[:3, 3], M_d[:3, 3])
        if B is None:
            return []
        R_B = B[:3, :3]
        R_X = (R_B @ M_d[:3, :3]).T @ self.M_u[:3, :3]
        p_u = self.T_u[:_FIT_SAMPLES, :3, 3]
        out = []
        for i, row in enumerate(table.rows):
            for entry in ("a", "d"):
                L, G, R = self._around(i, entry)
                LR, c = L @ R, (L @ G @ R)[:, :3, 3]
                m = len(LR)
                A = np.concatenate([R_B @ LR[:, :3, :3], (c @ R_B.T)[:, :, None], np.broadcast_to(np.eye(3), (m, 3, 3))],
                                   axis=2).reshape(3 * m, 7)
                y = (p_u - LR[:, :3, 3] @ R_B.T).reshape(3 * m)
                rank = np.linalg.matrix_rank(A, tol=1e-9)
                if rank < 7 or np.linalg.matrix_rank(np.delete(A, 3, axis=1), tol=1e-9) < 6:
                    continue  # v is not told apart from a base or tool shift
                x = np.linalg.lstsq(A, y, rcond=None)[0]
                value = _snapped_entry(entry, float(x[3]))
                if abs(value - getattr(row, entry)) < 1e-12:
                    continue
                rows = list(table.rows)
                rows[i] = replace(row, **{entry: value})
                variant = replace(table, rows=tuple(rows))
                base, tool = np.eye(4), np.eye(4)
                base[:3, :3], base[:3, 3] = R_B, x[4:]
                tool[:3, :3], tool[:3, 3] = R_X, x[:3]
                base, tool = _snapped(base), _snapped(tool)
                candidate = replace(variant, base=_snapped(base @ table.base), tool=_snapped(table.tool @ tool))
                placed = [text for text, T in ((f"a constant base transform {_pose_text(base)} (before row 1)", base),
                                               (_tool_line(tool), tool)) if np.abs(T - np.eye(4)).max() >= RECONCILE_TOL]
                out.append((
                    f"row {i + 1}: {entry} = {_entry_text(entry, getattr(row, entry))}, the URDF implies "
                    f"{_entry_text(entry, value)}" + "".join(f", with {text}" for text in placed),
                    candidate, self.residual(candidate),
                ))
        return out

    def reversed_joints(self, joints, limit: float) -> list:
        """``(text, corrected table, residual)`` for each joint that, turned the other way (with a base and
        tool transform refitted if need be), makes the table agree."""
        out = []
        for j in range(self.table.n):
            variant = reverse_joint(self.table, j)
            changes = "; ".join(_entry_changes(self.table, variant))
            prefix = f"joint {j + 1} ({joints[j]}) turns the other way: reversing it in the table ({changes})"
            fits = [(text.removesuffix(", with "), candidate, residual)
                    for text, candidate, residual in self.base_and_tool(variant, prefix + ", with ")]
            out += [fit for fit in fits if fit[2] <= limit][:1]
        return out


def _snapped(T: np.ndarray) -> np.ndarray:
    """``T`` with entries within 1e-12 of 0 or +-1 made exact (fitting noise), so a written table reads clean."""
    T = np.where(np.abs(T) < 1e-12, 0.0, T)
    return np.where(np.abs(np.abs(T) - 1.0) < 1e-12, np.sign(T), T)


def _snapped_entry(entry: str, value: float) -> float:
    """A fitted entry with its noise removed: angles within 1e-12 rad of a multiple of 15 deg made that
    multiple, lengths rounded to 1e-12 m (the candidate is checked on the samples afterwards)."""
    if entry in ANGLE_ENTRIES:
        k = round(value / (math.pi / 12))
        return k * math.pi / 12 if abs(value - k * math.pi / 12) < 1e-12 else value
    return round(value, 12)


def _precise_screws(fk, n: int, q0) -> np.ndarray:
    """:func:`screws` with Richardson extrapolation of two steps (error about 1e-12 instead of 1e-10)."""
    return (4.0 * screws(fk, n, q0, step=5e-4) - screws(fk, n, q0, step=1e-3)) / 3.0


def _entry_text(entry: str, value: float) -> str:
    if entry in ANGLE_ENTRIES:
        return f"{short_text(math.degrees(float(wrap_angle(value))), 6, zero=math.degrees(NOISE))} deg"
    return f"{short_text(value, 6, zero=NOISE)} m"


def _differing_entries(table: DHTable, other: DHTable):
    """(row number, entry, table's value, other's value) for every entry that differs (angles modulo 2 pi)."""
    for i, (row, new) in enumerate(zip(table.rows, other.rows)):
        for entry in ENTRIES:
            mine, theirs = getattr(row, entry), getattr(new, entry)
            gap = math.remainder(theirs - mine, 2 * math.pi) if entry in ANGLE_ENTRIES else theirs - mine
            if abs(gap) > 1e-9:
                yield i + 1, entry, mine, theirs


def _differing_ends(table: DHTable, other: DHTable) -> list[str]:
    """``base`` and/or ``tool`` when they differ between the two tables."""
    return [what for what in ("base", "tool") if np.abs(getattr(table, what) - getattr(other, what)).max() > 1e-9]


def _entry_changes(table: DHTable, other: DHTable) -> list[str]:
    """``row 2: alpha 0 deg -> 180 deg``, one per entry that differs; base and tool when they differ."""
    out = [f"row {row}: {entry} {_entry_text(entry, old)} -> {_entry_text(entry, new)}"
           for row, entry, old, new in _differing_entries(table, other)]
    return out + [f"{what} {_pose_text(getattr(other, what))}" for what in _differing_ends(table, other)]


def _entry_differences(table: DHTable, derived: DHTable) -> list[str]:
    """Every entry in which ``table`` differs from the one derived from the URDF, when their rows match in kind."""
    if [r.type for r in table.rows] != [r.type for r in derived.rows]:
        return []
    out = [f"row {row}: {entry} = {_entry_text(entry, mine)}, the URDF implies {_entry_text(entry, urdf)}"
           for row, entry, mine, urdf in _differing_entries(table, derived)]
    out += [f"{what} {_pose_text(getattr(table, what))}, the URDF implies {_pose_text(getattr(derived, what))}"
            for what in _differing_ends(table, derived)]
    if not out:
        return []
    shown = out[:12] + ([f"... and {len(out) - 12} more"] if len(out) > 12 else [])
    return [
        f"the {derived.convention} DH table derived from the URDF (as `manipkit dh from-urdf` derives it) differs in "
        f"{len(out)} place(s); DH frames are not unique, so an entry can also differ where a frame was chosen "
        "differently:",
        *shown,
    ]


def _home_difference(urdf_fk, dh, q_dh):
    n = len(q_dh)
    return invert_transform(dh(np.asarray(q_dh))) @ urdf_fk(np.zeros(n))


def _residual(urdf_fk, corrected, Q) -> float:
    """Largest position (m) or rotation (rad) error of ``corrected(Q)``, a batch of poses, over the samples."""
    position, rotation = pose_residuals(urdf_fk(Q), corrected(Q))
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
    for i, j in pairwise(turning):
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
        def mismatch(angle, i=i):
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
    rpy = np.degrees(rpy_from_matrix(T[:3, :3], check=False, gimbal_tol=NOISE))  # at gimbal lock roll is 0
    return f"xyz {_vector_message(T[:3, 3])} m, rpy {_vector_message(rpy, 6, zero=math.degrees(NOISE))} deg"


def _vector_message(values, digits: int = 6, *, zero: float = 1e-9) -> str:
    """:func:`manipkit.text.vector_text` with ``digits`` significant digits; entries within ``zero`` of zero
    (finite-difference noise: 1e-9 m, 1e-7 deg) print as 0."""
    return vector_text(values, lambda v: short_text(v, digits, zero=zero))
