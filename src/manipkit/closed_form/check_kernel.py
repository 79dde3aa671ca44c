"""The check of a closed-form branch on the true chain, compiled: its joint row, its FK, its residual.

What :func:`manipkit.ik.chain_ik.chain_ik` does to every branch
in numpy (``_joint_values``, ``_aliases``, ``chain.fk``,
:func:`manipkit.spatial.transforms.pose_residuals`, ``chain.within_limits``),
as functions numba compiles into the closed forms' loop over targets
(:mod:`manipkit.closed_form.arms_kernel`), so a target's eight branches are
solved and checked without leaving machine code:

- :func:`chain_row`: solved angles -> a chain vector, each revolute entry
  moved by whole turns to its in-limit value nearest 0;
- the chain's forward kinematics by
  :func:`manipkit.kernels.fk.pose_rows` (the program of the chain's
  own compiled FK, one row at a time, a target's branches sharing their
  first joints' part: the true chain, not the solver's ideal arm);
- :func:`pose_residual`: the compiled twin of
  ``pose_residuals(T_target, T, project=False)`` (one rule, one definition:
  the same formulas, tested equal to it);
- :func:`exact_rotation`: whether a target's rotation block is used as is
  (the test of :func:`manipkit.spatial.transforms.projected_rotation`);
  a target that is not is projected in numpy first.

Importing this module imports numba. It reads the chain's FK program from
:mod:`manipkit.kernels.fk`, the chain programs of the kernels layer
the closed forms may import (numpy and the kernels only; docs/architecture.md,
"Layers").
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.closed_form.subproblems_kernel import atan2, compile_kernel, inlined_kernel, sqrt, wrap_by_selects
from manipkit.kernels.fk import pose_rows_kernel
from manipkit.spatial.transforms import EXACT_ROTATION_TOL

__all__ = ["LIMIT_TOL", "arm_constants", "chain_row", "check_rows", "codes_of", "exact_rotation", "in_limit_alias",
           "kept_rows", "measure_rows", "pack_arm", "packed_row", "plain_target", "pose_residual", "pose_residual_parts", "pose_rows", "wrap_angle", "wrap_angle_by_selects"]

#: A joint value this far outside a limit counts as inside (the chain's LIMIT_TOLERANCE, chain_ik's aliases).
LIMIT_TOL = 1e-12
TWO_PI = 2.0 * math.pi
pose_rows = pose_rows_kernel()


@inlined_kernel
def pose_residual_parts(T_ref, T):
    """(position m, y, x) of the reached pose ``T`` against ``T_ref`` (both (4, 4)): the rotation residual is
    ``atan2(y, x)`` (:func:`pose_residual`), left to the caller so a loop over many poses takes its atan2 in one
    vectorised pass (:mod:`manipkit.closed_form.arms_kernel`'s ``_measure_at``)."""
    a00, a01, a02 = T_ref[0, 0], T_ref[0, 1], T_ref[0, 2]
    a10, a11, a12 = T_ref[1, 0], T_ref[1, 1], T_ref[1, 2]
    a20, a21, a22 = T_ref[2, 0], T_ref[2, 1], T_ref[2, 2]
    b00, b01, b02 = T[0, 0], T[0, 1], T[0, 2]
    b10, b11, b12 = T[1, 0], T[1, 1], T[1, 2]
    b20, b21, b22 = T[2, 0], T[2, 1], T[2, 2]
    m01, m10 = a00 * b01 + a10 * b11 + a20 * b21, a01 * b00 + a11 * b10 + a21 * b20
    m02, m20 = a00 * b02 + a10 * b12 + a20 * b22, a02 * b00 + a12 * b10 + a22 * b20
    m12, m21 = a01 * b02 + a11 * b12 + a21 * b22, a02 * b01 + a12 * b11 + a22 * b21
    trace = ((a00 * b00 + a10 * b10 + a20 * b20) + (a01 * b01 + a11 * b11 + a21 * b21)
             + (a02 * b02 + a12 * b12 + a22 * b22))
    v0, v1, v2 = m21 - m12, m02 - m20, m10 - m01
    dx, dy, dz = T[0, 3] - T_ref[0, 3], T[1, 3] - T_ref[1, 3], T[2, 3] - T_ref[2, 3]
    return sqrt(dx * dx + dy * dy + dz * dz), 0.5 * sqrt(v0 * v0 + v1 * v1 + v2 * v2), 0.5 * (trace - 1.0)


@inlined_kernel
def pose_residual(T_ref, T):
    """(position m, rotation rad) of the reached pose ``T`` against ``T_ref`` (both (4, 4)).

    The compiled twin of ``pose_residuals(T_ref, T, project=False)``
    (:mod:`manipkit.spatial.transforms`): ``|t - t_ref|`` and
    ``atan2(|v| / 2, (trace M - 1) / 2)`` of ``M = R_ref^T R``, ``v`` the
    vector of its skew part, with the same operations in the same order,
    except the atan2: :func:`manipkit.closed_form.subproblems_kernel.atan2`
    (within 2 units in the last place of numpy's, under 1e-15 rad).
    """
    position, y, x = pose_residual_parts(T_ref, T)
    return position, atan2(y, x)


@inlined_kernel
def exact_rotation(T):
    """The rotation block of ``T`` (4, 4) is orthonormal to EXACT_ROTATION_TOL with det > 0 (False for nan):
    it is used as is, as :func:`manipkit.spatial.transforms.projected_rotation` decides."""
    worst = 0.0
    for i in range(3):
        for j in range(i, 3):
            g = T[0, i] * T[0, j] + T[1, i] * T[1, j] + T[2, i] * T[2, j] - (1.0 if i == j else 0.0)
            if not abs(g) <= worst:
                worst = abs(g)
            if not worst <= EXACT_ROTATION_TOL:  # nan too
                return False
    det = (T[0, 0] * (T[1, 1] * T[2, 2] - T[1, 2] * T[2, 1]) - T[0, 1] * (T[1, 0] * T[2, 2] - T[1, 2] * T[2, 0])
           + T[0, 2] * (T[1, 0] * T[2, 1] - T[1, 1] * T[2, 0]))
    return det > 0.0


@inlined_kernel
def wrap_angle(a):
    """As manipkit.spatial.rotations.wrap_angle: (-pi, pi], angles inside unchanged."""
    if -math.pi < a <= math.pi:
        return a + 0.0
    w = math.pi - (math.pi - a) % TWO_PI
    return w + TWO_PI if w <= -math.pi else w


@inlined_kernel
def wrap_angle_by_selects(a):
    """(:func:`wrap_angle` of ``a``, exact): the same number bit for bit by selects, no branch
    (:func:`manipkit.closed_form.subproblems_kernel.wrap_by_selects`; ``exact`` False where ``pi - a`` leaves
    [-2 pi, 4 pi))."""
    w, exact = wrap_by_selects(a)
    inside = (a > -math.pi) & (a <= math.pi)
    return a + 0.0 if inside else (w + TWO_PI if w <= -math.pi else w), exact


@inlined_kernel
def in_limit_alias(w, lower, upper):
    """The alias of wrapped angle ``w`` (in (-pi, pi], not -0.0) that chain_ik keeps: ``w`` itself if inside
    ``[lower, upper]``, else the first inside of ``w + 2 pi``, ``w - 2 pi``, ``w + 4 pi``, ``w - 4 pi``, else ``w``.
    Chosen by selects, with no branch, so a loop over many angles runs on vector registers (arms_kernel's
    ``_lane_rows``)."""
    c1, c2, c3, c4 = w + TWO_PI, w - TWO_PI, w + 2.0 * TWO_PI, w - 2.0 * TWO_PI
    best = c4 if (lower <= c4) & (c4 <= upper) else w
    best = c3 if (lower <= c3) & (c3 <= upper) else best
    best = c2 if (lower <= c2) & (c2 <= upper) else best
    best = c1 if (lower <= c1) & (c1 <= upper) else best
    return w if (lower <= w) & (w <= upper) else best


@inlined_kernel
def chain_row(theta, k, reverse, q0, columns, solved, out):
    """``out[k]`` (n,) = the chain vector of solved angles ``theta[k]`` (m,): ``q0`` with column ``columns[i]`` moved
    by ``theta[k, i] / scale[i]`` (``theta[k, m - 1 - i]`` when ``reverse``: a family solved tip to base) and taken,
    by whole turns, to the in-limit value nearest 0 (``solved`` (3, m): the solved columns' scales, lower and upper
    limits; wrapped to (-pi, pi] when none is inside). chain_ik's ``_joint_values`` and ``_aliases`` (revolute
    joints). Rows by index, not as views: a view costs the loop two atomic reference counts."""
    m = columns.shape[0]
    for j in range(out.shape[1]):
        out[k, j] = q0[j]
    for i in range(m):
        col = columns[i]
        angle = theta[k, m - 1 - i] if reverse else theta[k, i]
        out[k, col] = in_limit_alias(wrap_angle(q0[col] + angle / solved[0, i]), solved[1, i] - LIMIT_TOL,
                                     solved[2, i] + LIMIT_TOL)


@inlined_kernel
def packed_row(rows, t, k, solved, packed, index, count):
    """Slot ``k`` of target ``t`` in a batch's rows (N, slots, n) once its row is made: when ``solved`` and present
    (its first entry is not NaN: as the batch's check reads a row), copied into ``packed[count]`` with its slot
    ``slots t + k`` in ``index[count]``; when not ``solved``, set to NaN. Returns the count of packed rows after
    it."""
    if not solved:
        for j in range(rows.shape[2]):
            rows[t, k, j] = np.nan
        return count
    if math.isnan(rows[t, k, 0]):
        return count
    for j in range(rows.shape[2]):
        packed[count, j] = rows[t, k, j]
    index[count] = rows.shape[1] * t + k
    return count + 1


@inlined_kernel
def check_rows(rows, valid, T_target, floats, ints, limits, states, reached, residuals, within):
    """``residuals[k]`` (position m, rotation rad) and ``within[k]`` (every entry inside the chain's limits
    ``limits`` (2, n) to LIMIT_TOL: ``Chain.within_limits``) of every chain vector ``rows[k]`` with ``valid[k]``
    against ``T_target``, by the chain's FK (:func:`manipkit.kernels.fk.pose_rows`, tables ``floats``,
    ``ints``, ``states`` (m + 1, 4, 3) scratch; ``reached`` (k, 4, 4) written: branches sharing their first joints
    share that part of the FK) and :func:`pose_residual`."""
    pose_rows(rows, valid, floats, ints, states, reached)
    for k in range(rows.shape[0]):
        if valid[k]:
            residuals[k, 0], residuals[k, 1] = pose_residual(T_target, reached[k])
            inside = True
            for j in range(rows.shape[1]):
                if rows[k, j] < limits[0, j] - LIMIT_TOL or rows[k, j] > limits[1, j] + LIMIT_TOL:
                    inside = False
            within[k] = inside


@compile_kernel
def measure_rows(Q, T, owner, floats, ints, residuals):
    """``residuals[k]`` (position m, rotation rad) of chain vector ``Q[k]`` (M, n) against ``T[owner[k]]`` ((N, 4, 4),
    rotation blocks that are rotations): the chain's FK (:func:`manipkit.kernels.fk.pose_rows`, tables ``floats``,
    ``ints`` of ``chain.program.row_tables``) and :func:`pose_residual`, in one compiled call."""
    count = Q.shape[0]
    states = np.empty((ints[0] + 1, 4, 3))
    reached = np.empty((count, 4, 4))
    present = np.ones(count, dtype=np.bool_)
    pose_rows(Q, present, floats, ints, states, reached)
    for k in range(count):
        residuals[k, 0], residuals[k, 1] = pose_residual(T[owner[k]], reached[k])


@compile_kernel
def kept_rows(valid, rows, residuals, within, keys, codes, position_tol, rotation_tol):
    """The answer of one target from its checked slots, as chain_ik keeps it: every valid row within the tolerances
    (else not ok: the general path refines it), a row equal modulo 2 pi (to 1e-9) to one kept before it dropped, the
    rest in the stable order of ``keys`` (the labels' order).

    Returns (block (k, n + 2): per kept branch its chain vector (n) and position and rotation residual (m, rad);
    within (k,) bool: inside the joint limits; codes: the kept rows' ``codes`` (each 0..7) as one number,
    ``sum((codes[a] + 1) 9**a)`` (:func:`codes_of`)); no rows (0, n + 2) when a row misses the tolerances (the
    general path answers). Few arrays, because numba returns each array object at a cost of about half a
    microsecond."""
    n = rows.shape[1]
    order = np.empty(rows.shape[0], dtype=np.int64)
    count = 0
    for k in range(rows.shape[0]):
        if not valid[k]:
            continue
        if not (residuals[k, 0] <= position_tol and residuals[k, 1] <= rotation_tol):
            return np.empty((0, n + 2)), np.empty(0, dtype=np.bool_), 0
        repeated = False
        for a in range(count):
            j = order[a]
            equal = True
            for i in range(n):
                d = rows[k, i] - rows[j, i]
                if abs(d) <= 1e-9:
                    continue
                if abs(d - TWO_PI * round(d / TWO_PI)) > 1e-6:  # far from every whole turn: no remainder needed
                    equal = False
                    break
                d = math.pi - (math.pi - d) % TWO_PI
                if not abs(d) <= 1e-9:
                    equal = False
                    break
            if equal:
                repeated = True
                break
        if not repeated:
            order[count] = k
            count += 1
    for a in range(1, count):  # insertion sort: stable, on at most 8 rows
        k = order[a]
        b = a
        while b > 0 and keys[order[b - 1]] > keys[k]:
            order[b] = order[b - 1]
            b -= 1
        order[b] = k
    block, inside = np.empty((count, n + 2)), np.empty(count, dtype=np.bool_)
    named, digit = 0, 1
    for a in range(count):
        k = order[a]
        for i in range(n):  # copies by loops (internals/kernels.md, "Copies by loops")
            block[a, i] = rows[k, i]
        block[a, n], block[a, n + 1] = residuals[k, 0], residuals[k, 1]
        inside[a] = within[k]
        named += (codes[k] + 1) * digit
        digit *= 9
    return block, inside, named


def codes_of(named: int) -> tuple[int, ...]:
    """The codes (each 0..7, in row order) of :func:`kept_rows`' one number ``sum((codes[a] + 1) 9**a)``."""
    codes = []
    while named:
        named, digit = divmod(named, 9)
        codes.append(digit - 1)
    return tuple(codes)


def pack_arm(kind: int, h: np.ndarray, p: np.ndarray, points: np.ndarray, scale: float, M_inv: np.ndarray,
             reverse: bool, q0: np.ndarray, columns: np.ndarray, solved: np.ndarray, limits: np.ndarray,
             floats: np.ndarray, ints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A chain's constants for the compiled closed forms as two flat arrays (``arm_reals`` float, ``arm_ints``
    int), the layout :func:`arm_constants` reads: numba checks the type of every argument of a call (about 0.1 us
    each), so a single call passes the chain in two.

    ``kind``: the family's code; ``h``, ``p`` (m, 3): the ideal arm's axes; ``points`` (4, 3): wrist, shoulder,
    label reference and label up; ``scale``: the arm's size; ``M_inv`` (4, 4); ``reverse``: solved tip to base;
    ``q0`` (n,): the reference configuration; ``columns`` (m,): the solved chain columns; ``solved`` (3, m): their
    scales, lower and upper limits; ``limits`` (2, n): the chain's; ``floats``, ``ints``: the chain's FK program
    (``ChainProgram.row_tables``: :func:`manipkit.kernels.fk.row_tables`). ``arm_ints = [kind, reverse, m, n,
    columns..., ints...]``, ``arm_reals = [scale, h, p, points, M_inv, q0, solved, limits, floats...]`` (each
    row-major).
    """
    m, n = len(h), len(q0)
    arm_reals = np.concatenate([[float(scale)], np.ravel(h), np.ravel(p), np.ravel(points), np.ravel(M_inv), q0,
                                np.ravel(solved), np.ravel(limits), floats]).astype(float)
    arm_ints = np.concatenate([[kind, int(bool(reverse)), m, n], columns, ints]).astype(np.int64)
    if points.shape != (4, 3) or M_inv.shape != (4, 4) or solved.shape != (3, m) or limits.shape != (2, n):
        raise ValueError("pack_arm: points (4, 3), M_inv (4, 4), solved (3, m) and limits (2, n) expected")
    return arm_reals, arm_ints


@inlined_kernel
def arm_constants(arm_reals, arm_ints):
    """The views of :func:`pack_arm`'s arrays: (kind, H, P, points, scale, M_inv, reverse, q0, columns, solved,
    limits, floats, ints), no copy."""
    m, n = arm_ints[2], arm_ints[3]
    o = 1
    H = arm_reals[o:o + 3 * m].reshape((m, 3))
    o += 3 * m
    P = arm_reals[o:o + 3 * m].reshape((m, 3))
    o += 3 * m
    points = arm_reals[o:o + 12].reshape((4, 3))
    M_inv = arm_reals[o + 12:o + 28].reshape((4, 4))
    o += 28
    q0 = arm_reals[o:o + n]
    solved = arm_reals[o + n:o + n + 3 * m].reshape((3, m))
    o += n + 3 * m
    limits = arm_reals[o:o + 2 * n].reshape((2, n))
    return (arm_ints[0], H, P, points, arm_reals[0], M_inv, arm_ints[1] != 0, q0, arm_ints[4:4 + m], solved, limits,
            arm_reals[o + 2 * n:], arm_ints[4 + m:])


@inlined_kernel
def plain_target(T):
    """``T`` (4, 4) is a rigid transform that :func:`manipkit.spatial.transforms.check_transform` accepts as is:
    last row exactly ``[0 0 0 1]``, a finite translation and a rotation block exact to EXACT_ROTATION_TOL
    (:func:`exact_rotation`; far inside check_transform's 1e-6). Anything else is checked by check_transform."""
    if not (T[3, 0] == 0.0 and T[3, 1] == 0.0 and T[3, 2] == 0.0 and T[3, 3] == 1.0):
        return False
    if not (math.isfinite(T[0, 3]) and math.isfinite(T[1, 3]) and math.isfinite(T[2, 3])):
        return False
    return exact_rotation(T)
