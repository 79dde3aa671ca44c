"""Does a DH table agree with a robot's URDF chain? If not, where and how.

The table's rows map in order to the movable joints on the URDF path from a
base frame to a tip frame; the same joint values go to both. Agreement is
measured on sampled configurations inside the joint limits: the largest
position error (m) and rotation error (rad) of ``T_base_tip``.

The diagnosis (``DHCheck.diagnosis``, a :class:`~manipkit.dh.diagnosis.DHDiagnosis`:
data, no words; :mod:`manipkit.app.dh_text` words it) looks for the
simplest explanation first, each candidate checked on the samples
(``DHCheck.candidate`` is the first corrected table that agrees):

1. **constant base and tool transforms**, any rotation: a tool ``X = M_dh^-1
   M_urdf`` alone, a base ``B = M_urdf M_dh^-1`` alone, then both, with ``B``
   fitted (Kabsch) so that ``Ad(B) S_dh = S_urdf`` for the screws at q = 0
   and at two sampled configurations (a shift along axes that are all
   parallel commutes with the chain: it is put in ``B``);
2. **one table entry**: for every row and parameter (a, alpha, d, theta)
   the value that makes the table agree, in closed form (FK is ``L E(v) R``
   with ``E`` the entry's ``Tx``, ``Rx``, ``Tz`` or ``Rz``: least squares in
   ``v`` or in ``(cos v, sin v)``), given with the value the URDF implies
   (:class:`~manipkit.dh.diagnosis.EntryChange`); every entry that alone
   explains the difference is listed (theta of row 1 and a base turn about z
   can be the same thing), so a flipped alpha is that alpha, not a reversed
   joint; then one length
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
a; metres and radians throughout (degrees only in the app's words); rpy is ``R = Rz(yaw)
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

from manipkit.dh.diagnosis import AxisComparison, DHCorrection, DHDiagnosis, EndChange, EntryChange
from manipkit.dh.entries import ANGLE_ENTRIES, ENTRIES, GENERATORS, dh_link_matrices, reverse_joint, row_factors
from manipkit.dh.from_urdf import dh_from_urdf_chain
from manipkit.dh.table import DHTable, dh_fk
from manipkit.errors import ManipkitError
from manipkit.spatial.transforms import invert_transform, pose_residuals

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["CHECK_TOL", "RECONCILE_TOL", "SCREW_TOL", "DHCheck", "check_dh", "screws"]

#: The tolerance (m and rad) a table passes ``check_dh`` within by default; ``dh from-urdf`` keeps its snapping
#: by default only when the snapped table stays within it.
CHECK_TOL = 1e-9
SCREW_TOL = 1e-6  # screws equal within this (axis direction and moment)
RECONCILE_TOL = 1e-8  # home poses, and a base or tool transform and the identity, are equal within this (each entry)


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
    diagnosis : DHDiagnosis
        What the check found, as data (:mod:`manipkit.dh.diagnosis`; kind
        ``"agrees"`` when the table passes); :mod:`manipkit.app.dh_text`
        words it.
    joints : tuple of str
        URDF joints the rows map to.
    samples, tol : int, float
        How the check was run (``samples`` is 0 when the row count is wrong).
    candidate : DHTable or None
        When the table does not agree: a corrected table that does, else
        None. Up to the reversed-joint stage it is ``diagnosis.fixes[0]``'s;
        at ``"axes compared"`` it is ``diagnosis.derived`` with the table's
        row names and limits, when entries differ.
    base, tip : str
        The URDF frames the table was checked between, as given.
    """

    max_position_error: float
    max_rotation_error: float
    passed: bool
    diagnosis: DHDiagnosis
    joints: tuple[str, ...]
    samples: int
    tol: float
    candidate: DHTable | None = None
    base: str = "base_link"
    tip: str = "ee_link"


def check_dh(table: DHTable, robot: Robot, *, base: str = "base_link", tip: str = "ee_link",
             samples: int = 1000, tol: float = CHECK_TOL, seed: int = 0) -> DHCheck:
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
        extra_row = table.rows[-1] if table.n == len(joints) + 1 else None
        diagnosis = DHDiagnosis("row count", rows=table.n, extra_row=extra_row)
        return DHCheck(math.nan, math.nan, False, diagnosis, joints, 0, tol, base=base, tip=tip)

    index = [robot.joint_names.index(name) for name in joints]
    Q = robot.sample_q(samples, seed=seed)[:, index]
    urdf_fk = _urdf_fk(robot, base, tip, index)
    position_errors, rotation_errors = pose_residuals(urdf_fk(Q), dh_fk(table, Q))
    max_position, max_rotation = float(position_errors.max()), float(rotation_errors.max())
    passed = max_position <= tol and max_rotation <= tol
    diagnosis, candidate = DHDiagnosis("agrees"), None
    if not passed:
        def derive():
            try:
                return dh_from_urdf_chain(robot, base, tip, convention=table.convention)
            except ManipkitError:
                return None

        diagnosis, candidate = _diagnose(table, urdf_fk, joints, Q, tol, max_position, max_rotation, derive)
    return DHCheck(max_position, max_rotation, passed, diagnosis, joints, samples, tol, candidate, base, tip)


def _urdf_fk(robot: Robot, base: str, tip: str, index: list[int]):
    """FK of the URDF chain as a function of the chain's joint values only."""
    q_rest = robot.q()

    def fk(q_chain):
        q_chain = np.asarray(q_chain, dtype=float)
        Q = np.broadcast_to(q_rest, q_chain.shape[:-1] + q_rest.shape).copy()
        Q[..., index] = q_chain
        return robot.fk(Q, base=base, tip=tip)

    return fk


# --------------------------------------------------------------------------
# Screws and the diagnosis
# --------------------------------------------------------------------------


def screws(fk, n: int, q0=None, *, step: float = 1e-5, vectorised: bool = False) -> np.ndarray:
    """Spatial screw axes of a chain at ``q0`` (default zero), in the chain's base frame.

    Central differences of step ``step`` about ``q0``: the FK at ``q0`` and
    with each joint stepped up and down, 2n + 1 poses.

    Parameters
    ----------
    fk : callable
        ``fk(q) -> (4, 4)`` homogeneous transform for q of shape (n,); with
        ``vectorised``, ``fk(Q) -> (m, 4, 4)`` for Q of shape (m, n), called
        once for all 2n + 1 poses (as :func:`manipkit.dh.dh_fk` and
        ``Robot.fk`` can be).
    n : int
        Number of joints.

    Returns
    -------
    S : ndarray, shape (n, 6)
        Rows ``(w, v)``: unit axis w and ``v = -w x p`` for revolute joints,
        ``(0, direction)`` for prismatic ones; ``[S_i] = dT/dq_i T^-1``.
    """
    q0 = np.zeros(n) if q0 is None else np.asarray(q0, dtype=float)
    E = step * np.eye(n)
    Q = np.concatenate([q0[None, :], q0 + E, q0 - E])  # q0, then each joint stepped up, then each stepped down
    T = fk(Q) if vectorised else np.array([fk(q) for q in Q]).reshape(len(Q), 4, 4)
    twist = (T[1:n + 1] - T[n + 1:]) / (2 * step) @ invert_transform(T[0], check=False)
    return np.column_stack([twist[:, 2, 1], twist[:, 0, 2], twist[:, 1, 0], twist[:, :3, 3]])


def _screw_line(S):
    """(direction, a point on the axis) of a revolute screw; (direction, None) for prismatic."""
    w, v = S[:3], S[3:]
    if np.linalg.norm(w) < 0.5:
        return v / np.linalg.norm(v), None
    return w, np.cross(w, v)  # v = -w x p = p x w, so w x v is the foot point of the origin


def _compare_axes(joint: int, S_urdf, S_dh) -> AxisComparison:
    """How joint ``joint``'s axis in the table (screw ``S_dh``) compares with the URDF's (``S_urdf``)."""
    (w_u, p_u), (w_d, p_d) = _screw_line(S_urdf), _screw_line(S_dh)
    if np.abs(S_urdf - S_dh).max() < SCREW_TOL:
        relation = "same"
    elif np.abs(S_urdf + S_dh).max() < SCREW_TOL:
        relation = "reversed"
    else:
        relation = "joint type" if (p_u is None) != (p_d is None) else "different"
    angle = math.atan2(np.linalg.norm(np.cross(w_u, w_d)), abs(float(w_u @ w_d)))
    distance = None if p_u is None or p_d is None else _line_distance(w_u, p_u, w_d, p_d)
    return AxisComparison(joint, relation, w_u, w_d, p_u, p_d, angle, distance)


def _line_distance(w1, p1, w2, p2) -> float:
    normal = np.cross(w1, w2)
    if np.linalg.norm(normal) < 1e-9:
        return float(np.linalg.norm(np.cross(p2 - p1, w1)))
    return float(abs((p2 - p1) @ normal) / np.linalg.norm(normal))


def _diagnose(table, urdf_fk, joints, Q, tol, max_position, max_rotation, derive) -> tuple[DHDiagnosis, DHTable | None]:
    """The diagnosis and the first corrected table that agrees (None when none was found).

    In stages, simplest explanation first: (1) constant base and tool
    transforms (any rotation), (2) one table entry (row, parameter), (3) one
    joint turning the other way (with base and tool refitted); only when none
    of these reconciles the two chains, the screw comparison below locates
    where they stop agreeing, and the table derived from the URDF in the
    same convention (``derive()``) gives the entries that differ.
    """
    n = len(joints)
    dh = partial(dh_fk, table)
    if n == 0:
        return DHDiagnosis("no joints", tool=_home_difference(urdf_fk, dh, np.zeros(0))), None
    limit = tol  # a candidate must pass the check it is offered for (DHCheck.candidate)
    fit = _Fit(table, urdf_fk, Q)

    full = [c for c in fit.base_and_tool(table) if c.residual <= limit][:1]  # stage 1: the simplest one
    full += [c for c in fit.single_entries() if c.residual <= limit]  # stage 2: every entry that alone explains it
    S_u, S_d = screws(urdf_fk, n, vectorised=True), screws(dh, n, vectorised=True)
    axes = tuple(_compare_axes(i + 1, S_u[i], S_d[i]) for i in range(n))
    signs = np.array([-1.0 if a.relation == "reversed" else 1.0 for a in axes])
    if not full:  # stage 2b: one length and a base or tool transform
        full = [c for c in fit.length_entries_with_base_and_tool() if c.residual <= limit]
    if not full:
        full = fit.reversed_joints(limit)  # stage 3
        if full and np.count_nonzero(signs < 0) > 1:  # several joints reversed as the table stands, if that explains it too
            full += [c for c in _reconciliations(table, urdf_fk, S_u, S_d, signs, Q, tol) if c.residual <= limit][:1]
    if full:
        return DHDiagnosis(full[0].kind, fixes=tuple(full), axes=axes), full[0].candidate

    candidates = _reconciliations(table, urdf_fk, S_u, S_d, signs, Q, tol)
    fixes = [c for c in candidates if c.residual <= limit][:1]
    best = min(candidates, key=lambda c: c.residual, default=None)
    if fixes or best is None or best.residual >= 0.5 * max(max_position, max_rotation):
        best = None
    derived = derive()
    if derived is not None and [r.type for r in table.rows] != [r.type for r in derived.rows]:
        derived = None  # rows that differ in kind: no entry-by-entry comparison
    differences = () if derived is None else _differences(table, derived)
    diagnosis = DHDiagnosis("axes compared", fixes=tuple(fixes), axes=axes, partial=best, derived=derived,
                            differences=differences)
    if not differences:
        return diagnosis, None
    # the derived table, with the table's own names, limits and name: it agrees by construction
    rows = tuple(replace(new, qlim=row.qlim, name=row.name) for row, new in zip(table.rows, derived.rows))
    return diagnosis, DHTable(rows, table.convention, table.name, base=derived.base, tool=derived.tool)


def _reconciliations(table, urdf_fk, S_u, S_d, signs, Q, tol) -> list[DHCorrection]:
    """Candidate corrections of the table as it stands, with the joints of ``signs`` -1 reversed (no corrected
    table: described only), simplest first."""
    n = len(signs)
    dh = partial(dh_fk, table)
    flips = tuple(i + 1 for i in range(n) if signs[i] < 0)
    M_u, M_d = urdf_fk(np.zeros(n)), dh(np.zeros(n))  # home poses
    out = []

    # Tool only: T_urdf(q) = T_dh(s q) X.
    X = invert_transform(M_d, check=False) @ M_u
    out.append(DHCorrection("base and tool", _residual(urdf_fk, lambda q: dh(q * signs) @ X, Q), reversed=flips, tool=X))

    # Base only: T_urdf(q) = B T_dh(s q).
    B = M_u @ invert_transform(M_d, check=False)
    out.append(DHCorrection("base and tool", _residual(urdf_fk, lambda q: B @ dh(q * signs), Q), reversed=flips, base=B))

    # Base and tool: align the table's axes with the URDF's by one rigid motion.
    B = _align_axes(S_u, S_d * signs[:, None], M_u[:3, 3], M_d[:3, 3])
    if B is not None:
        X = invert_transform(B @ M_d, check=False) @ M_u
        out.append(DHCorrection("base and tool", _residual(urdf_fk, lambda q: B @ dh(q * signs) @ X, Q),
                                reversed=flips, base=B, tool=X))

    # Joint zero offsets (and a tool transform for what is left at the tip).
    offsets = _fit_offsets(S_u, dh, signs, n)
    if offsets is not None and np.abs(offsets).max() > 1e-9:
        X = _home_difference(urdf_fk, dh, offsets)
        nonzero = [(i + 1, o) for i, o in enumerate(offsets) if abs(o) > 1e-9]
        out.append(DHCorrection("joint offsets", _residual(urdf_fk, lambda q: dh(q * signs + offsets) @ X, Q),
                                reversed=flips, tool=X, offsets=nonzero))
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

    def base_and_tool(self, variant: DHTable, *, kind: str = "base and tool", **fields) -> list[DHCorrection]:
        """A new tool, a new base, then both (any rotations) for ``variant`` of the table (the table itself, or
        one with a joint reversed: ``kind`` and ``fields`` say which)."""
        n = variant.n
        M_d = dh_fk(variant, np.zeros(n))
        out = []

        def add(B, X):  # None: no such transform
            identity = np.eye(4)
            base = variant.base if B is None or np.array_equal(B, identity) else _snapped(_snapped(B) @ variant.base)
            tool = variant.tool if X is None or np.array_equal(X, identity) else _snapped(variant.tool @ _snapped(X))
            candidate = DHTable(variant.rows, variant.convention, variant.name, base=base, tool=tool)
            out.append(DHCorrection(kind, self.residual(candidate), candidate, base=B, tool=X, **fields))

        X = invert_transform(M_d, check=False) @ self.M_u  # T_urdf(q) = T_dh(q) X
        B = self.M_u @ invert_transform(M_d, check=False)  # T_urdf(q) = B T_dh(q)
        if np.abs(X - np.eye(4)).max() < RECONCILE_TOL:  # the home poses agree: the table as it is
            add(None, None)
        else:
            add(None, X)
            add(B, None)
        S_d = np.vstack([_precise_screws(partial(dh_fk, variant), n, q) for q in self.configurations])
        B = _align_axes(self.S_u, S_d, self.M_u[:3, 3], M_d[:3, 3])  # Ad(B) S_dh = S_urdf, then X at the tip
        if B is not None:
            add(B, invert_transform(B @ M_d, check=False) @ self.M_u)
        return out

    def single_entries(self) -> list[DHCorrection]:
        """The correction of each entry whose right value alone makes the table agree.

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
                out.append(DHCorrection("single entry", self.residual(candidate), candidate,
                                        entry=EntryChange(i + 1, entry, current, value)))
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

    def length_entries_with_base_and_tool(self) -> list[DHCorrection]:
        """The correction of each length (a or d) whose right value, with a constant base and tool transform,
        makes the table agree (``base`` and ``tool`` within ``RECONCILE_TOL`` of the identity are not needed).

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
                out.append(DHCorrection("length with base and tool", self.residual(candidate), candidate,
                                        entry=EntryChange(i + 1, entry, getattr(row, entry), value), base=base, tool=tool))
        return out

    def reversed_joints(self, limit: float) -> list[DHCorrection]:
        """The correction of each joint that, turned the other way (with a base and tool transform refitted
        if need be), makes the table agree within ``limit``."""
        out = []
        for j in range(self.table.n):
            variant = reverse_joint(self.table, j)
            fits = self.base_and_tool(variant, kind="reversed joint", reversed=(j + 1,),
                                      changes=_differences(self.table, variant))
            out += [fit for fit in fits if fit.residual <= limit][:1]
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
    return (4.0 * screws(fk, n, q0, step=5e-4, vectorised=True) - screws(fk, n, q0, step=1e-3, vectorised=True)) / 3.0


def _differences(table: DHTable, other: DHTable) -> tuple[EntryChange | EndChange, ...]:
    """Every entry (angles modulo 2 pi), then the base and tool, in which ``other`` differs from ``table``."""
    out = []
    for i, (row, new) in enumerate(zip(table.rows, other.rows)):
        for entry in ENTRIES:
            mine, theirs = getattr(row, entry), getattr(new, entry)
            gap = math.remainder(theirs - mine, 2 * math.pi) if entry in ANGLE_ENTRIES else theirs - mine
            if abs(gap) > 1e-9:
                out.append(EntryChange(i + 1, entry, mine, theirs))
    for end in ("base", "tool"):
        if np.abs(getattr(table, end) - getattr(other, end)).max() > 1e-9:
            out.append(EndChange(end, getattr(table, end), getattr(other, end)))
    return tuple(out)


def _home_difference(urdf_fk, dh, q_dh):
    n = len(q_dh)
    return invert_transform(dh(np.asarray(q_dh)), check=False) @ urdf_fk(np.zeros(n))


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
            S = screws(dh, n, trial, vectorised=True) * signs[:, None]
            return float(np.abs(S[i + 1:] - S_u[i + 1:]).sum(axis=1)[0])

        S_now = screws(dh, n, offsets, vectorised=True) * signs[:, None]
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
