"""The 6R closed forms of :mod:`manipkit.closed_form.arms`, compiled with numba: the loops over targets.

The families' Paden-Kahan sequences (``"three parallel, two intersecting"``,
the UR arms, and ``"spherical wrist, two parallel"``, the OPW arms) are
written once, as straight-line code, in
:mod:`manipkit.closed_form.arms_lanes`; this module runs them on chunks of
targets (vector registers) or on one target, takes their atan2 in one
vectorised pass, and turns every branch into its chain row (limit aliases),
its label and its check, with every branch in the same slot as the
reference (``4 shoulder + 2 elbow + wrist``) and the same ``valid`` and
``near`` rules.

The compiled loops solve the *generic* targets only. A target is handed
back (``fallback`` True) when any decision of the reference path is close
to its threshold there: a subproblem near a tangency or degenerate (a free
angle: singular targets), a branch missing by a little (``near`` but not
exact), or no branch at all (the reference measures how far it misses).
Those targets are solved again by the numpy reference, so the answer is
the reference's everywhere, to rounding; the margins (``MARGIN`` times the
arm's size, and ``TANGENT`` for a tangency: both far above the two paths'
rounding differences of about 1e-16 of the size) decide which path answers.
Between ``TANGENT`` and ``MARGIN`` from tangent the two near-equal angles of
a tangency agree to about 1e-11 rad (their sensitivity there).

Each function is compiled by :func:`manipkit.kernels.compile_kernel` (numba's
disk cache where it works); importing this module imports numba, so the
closed forms import it inside the functions that use it. The loops that run a
family's lanes are compiled once per family (:func:`family_kernels`, chosen
at the first call for a chain of that family): the family is a constant of
each compiled loop, which then holds only its own family's lanes, so the
first solve of a UR arm does not also compile the OPW lanes (each family's
loop compiles in about half the time of one loop holding both).
"""

from __future__ import annotations

import math
import threading
import types

import numpy as np

from manipkit.closed_form.arms import ELBOW_TIE
from manipkit.closed_form.arms_lanes import (
    ENTRIES,
    LANES,
    OPW_ANGLES,
    OPW_COPIES,
    UR_ANGLES,
    UR_COPIES,
    arm_tuple,
    opw_chunk,
    opw_one,
    ur_chunk,
    ur_one,
)
from manipkit.closed_form.check_kernel import (
    LIMIT_TOL,
    arm_constants,
    chain_row,
    check_rows,
    exact_rotation,
    in_limit_alias,
    kept_rows,
    measure_rows,
    pack_arm,
    packed_row,
    plain_target,
    pose_residual,
    pose_residual_parts,
    wrap_angle_by_selects,
)
from manipkit.closed_form.subproblems_kernel import MARGIN, compile_kernel, inlined_kernel
from manipkit.closed_form.subproblems_kernel import add as _add
from manipkit.closed_form.subproblems_kernel import atan2 as _atan2
from manipkit.closed_form.subproblems_kernel import dot as _dot
from manipkit.closed_form.subproblems_kernel import move as _move
from manipkit.closed_form.subproblems_kernel import mv as _mv
from manipkit.closed_form.subproblems_kernel import rotate as _rotate
from manipkit.closed_form.subproblems_kernel import row as _row
from manipkit.closed_form.subproblems_kernel import sub as _sub
from manipkit.closed_form.subproblems_kernel import wrap as _wrap
from manipkit.closed_form.subproblems_kernel import wrap_by_selects as _wrap_by_selects

__all__ = ["FAMILY_NAMES", "KIND_CODES", "MARGIN", "SLOTS", "branch_labels", "chain_rows", "family_kernels", "measure_at",
           "measure_many", "solve_check_one", "solve_many", "solve_rows_into", "solve_rows_many", "warm_up"]

#: Branch slots per target (``4 shoulder + 2 elbow + wrist``).
SLOTS = 8

#: Family kind -> the code the compiled loop takes.
KIND_CODES = {"three parallel, two intersecting": 0, "spherical wrist, two parallel": 1}
#: Family code -> the short name its compiled loops carry (``_solve_check_one_ur``, ...) and its lanes' prefix in
#: :mod:`manipkit.closed_form.arms_lanes` (``ur_one``, ``ur_chunk``).
FAMILY_NAMES = {0: "ur", 1: "opw"}
#: The family's code, in the per-family loops (:func:`family_kernels` sets it in each one's globals; this
#: module's own value is never compiled).
KIND = -1


def lanes_one(K, R, t, out):
    """The family's one-target lanes (``arms_lanes.ur_one`` or ``opw_one``, set per family by family_kernels)."""
    raise NotImplementedError("compiled per family: see family_kernels")


def lanes_chunk(K, G, out):
    """The family's chunk of lanes (``arms_lanes.ur_chunk`` or ``opw_chunk``, set per family by family_kernels)."""
    raise NotImplementedError("compiled per family: see family_kernels")


@inlined_kernel
def _angles_of(out, L, entries, copies):
    """``out[e L + i] = atan2(out[e L + i], out[(48 + e) L + i])`` for the entries ``e`` of ``entries`` and every
    lane ``i`` of ``L``, then each ``(e, s)`` of ``copies``: ``out[e L + i] = out[s L + i]``."""
    for e in entries:
        for i in range(L):
            out[e * L + i] = _atan2(out[e * L + i], out[(48 + e) * L + i])
    for e, s in copies:
        for i in range(L):
            out[e * L + i] = out[s * L + i]


@inlined_kernel
def _lane_angles(kind, out, L):
    """The angles of ``L`` lanes in place (see :mod:`manipkit.closed_form.arms_lanes`): ``out[i] = atan2(out[i],
    out[48 L + i])`` for the 48 L sine-like entries.

    The lanes write each angle as the two arguments of its atan2 and the atan2 are taken here, in flat loops over
    the lanes with no dependency between their entries: the compiler runs them on vector registers, four at a time
    (about 3 ns an atan2, where one by one inside the solve each was a chain of two divisions, 12-25 ns). Branches
    share some angles by construction (``arms_lanes.UR_ANGLES``, ``OPW_ANGLES``): their atan2 is taken once (30 of
    48 for UR, 34 for OPW) and copied. The same operations on the same numbers: the angles are the same bit for
    bit."""
    if kind == 0:
        _angles_of(out, L, UR_ANGLES, UR_COPIES)
    else:
        _angles_of(out, L, OPW_ANGLES, OPW_COPIES)


@inlined_kernel
def _lane_flags(out, n, L, valid):
    """valid (8,) of lane ``n`` of ``L``; returns whether the reference must decide."""
    for slot in range(SLOTS):
        valid[slot] = out[(96 + slot) * L + n] != 0.0
    return out[104 * L + n] != 0.0


@inlined_kernel
def _ur_signs(H):
    """(sign3, sign4): h3 = sign3 h2 and h4 = sign4 h2 on the ideal UR arm (its three parallel axes)."""
    sign3 = 1.0 if H[2, 0] * H[1, 0] + H[2, 1] * H[1, 1] + H[2, 2] * H[1, 2] > 0.0 else -1.0
    sign4 = 1.0 if H[3, 0] * H[1, 0] + H[3, 1] * H[1, 1] + H[3, 2] * H[1, 2] > 0.0 else -1.0
    return sign3, sign4


@inlined_kernel
def _lane_rows(kind, H, out, reverse, q0, columns, solved, values, odd):
    """The solved columns' joint values of every branch of the LANES lanes of ``out`` (angles taken), as
    ``check_kernel.chain_row`` gives them, in flat loops over the lanes (vectorised: selects, no branch):
    ``values[(slot m + i) LANES + lane]`` for solved column ``i`` of ``m``. ``q0 + angle / scale`` is wrapped
    (``check_kernel.wrap_angle_by_selects``; UR's joint 4 from the turn of joints 2-4, wrapped first by
    ``subproblems_kernel.wrap_by_selects``, as _lane_answer takes it) and aliased as chain_row does
    (``check_kernel.in_limit_alias``). A lane with a valid branch whose wrap those cannot take exactly (a value
    more than about 3 pi from 0: never for a reference configuration within pi of 0 and scales of at least 1) gets
    ``odd`` > 0, and chain_row makes its rows itself. The same numbers as chain_row, bit for bit (tested)."""
    m = columns.shape[0]
    sign3, sign4 = _ur_signs(H)
    for lane in range(LANES):
        odd[lane] = 0.0
    for slot in range(SLOTS):
        ok = (96 + slot) * LANES
        for i in range(m):
            e = m - 1 - i if reverse else i  # the angle of solved column i, in solve order
            start, dst = (6 * slot + e) * LANES, (slot * m + i) * LANES
            base, scale = q0[columns[i]], solved[0, i]
            lower, upper = solved[1, i] - LIMIT_TOL, solved[2, i] + LIMIT_TOL
            if kind == 0 and e == 3:  # UR: t4 = sign4 (turn - t2 - sign3 t3), wrapped
                t2, t3 = (6 * slot + 1) * LANES, (6 * slot + 2) * LANES
                for lane in range(LANES):
                    x, exact_x = _wrap_by_selects(sign4 * (out[start + lane] - out[t2 + lane] - sign3 * out[t3 + lane]))
                    value, exact = wrap_angle_by_selects(base + x / scale)
                    odd[lane] = max(odd[lane], out[ok + lane] * (0.0 if exact & exact_x else 1.0))
                    values[dst + lane] = in_limit_alias(value, lower, upper)
            else:
                for lane in range(LANES):
                    value, exact = wrap_angle_by_selects(base + out[start + lane] / scale)
                    odd[lane] = max(odd[lane], out[ok + lane] * (0.0 if exact else 1.0))
                    values[dst + lane] = in_limit_alias(value, lower, upper)


@inlined_kernel
def _lane_answer(kind, H, out, n, L, theta, valid, near):
    """Lane ``n`` of ``L`` (its angles taken by :func:`_lane_angles`) into theta (8, 6), valid (8,), near (8,);
    returns whether the reference must decide. UR: axes 2, 3, 4 are parallel on the ideal arm (h3 = sign3 h2,
    h4 = sign4 h2), so R(h2, t2 + sign3 t3 + sign4 t4) = R1^T R_g R6^T R5^T, whose angle about h2 (column 3, the
    turn) gives t4 = sign4 (turn - t2 - sign3 t3), wrapped."""
    handed_back = _lane_flags(out, n, L, valid)
    for slot in range(SLOTS):
        for j in range(6):
            theta[slot, j] = out[(6 * slot + j) * L + n]
        near[slot] = valid[slot]
    if kind == 0:
        sign3, sign4 = _ur_signs(H)
        for slot in range(SLOTS):
            theta[slot, 3] = _wrap(sign4 * (theta[slot, 3] - theta[slot, 1] - sign3 * theta[slot, 2]))
    return handed_back


def _target(K, H, g, out, theta, valid, near):
    """One target ``g`` (4, 4, in the solve frame) of the family, solved as one lane (``out`` (ENTRIES,):
    scratch) into theta (8, 6), valid (8,), near (8,); True when the reference must decide. Per family,
    inlined."""
    R = (g[0, 0], g[0, 1], g[0, 2], g[1, 0], g[1, 1], g[1, 2], g[2, 0], g[2, 1], g[2, 2])
    t = (g[0, 3], g[1, 3], g[2, 3])
    lanes_one(K, R, t, out)
    _lane_angles(KIND, out, 1)
    return _lane_answer(KIND, H, out, 0, 1, theta, valid, near)


def _solve_all(H, P, c, scale, G, theta, valid, near, fallback):
    """Every target of ``G`` by _target (per family)."""
    K, out = arm_tuple(H, P, c, scale), np.empty(ENTRIES)
    for n in range(G.shape[0]):
        fallback[n] = _target(K, H, G[n], out, theta[n], valid[n], near[n])


def solve_many(kind: str, h: np.ndarray, p: np.ndarray, wrist: np.ndarray, scale: float, g: np.ndarray):
    """(theta (N, 8, 6), valid (N, 8), near (N, 8), fallback (N,)) of targets ``g`` (N, 4, 4), compiled.

    ``kind``: a key of :data:`KIND_CODES`; ``h``, ``p`` (6, 3) the ideal
    arm's axes; ``wrist`` its wrist centre (OPW) or where axes 5 and 6 meet
    (UR); ``scale`` the arm's size as the reference takes it. Rows with
    ``fallback`` True hold nothing meaningful: solve them with
    :func:`manipkit.closed_form.arms.solve_6r`. Elsewhere ``free`` is -1 for
    every slot (no free angle) and the misses are 0 (a branch exists).
    """
    g = np.ascontiguousarray(g, dtype=float)
    N = g.shape[0]
    theta = np.zeros((N, SLOTS, 6))
    valid = np.zeros((N, SLOTS), dtype=np.bool_)
    near = np.zeros((N, SLOTS), dtype=np.bool_)
    fallback = np.zeros(N, dtype=np.bool_)
    c = (float(wrist[0]), float(wrist[1]), float(wrist[2]))
    family_kernels(KIND_CODES[kind]).solve_all(np.ascontiguousarray(h, dtype=float), np.ascontiguousarray(p, dtype=float),
                                               c, float(scale), g, theta, valid, near, fallback)
    return theta, valid, near, fallback


@compile_kernel
def _rows(theta, valid, q0, columns, solved, out):
    """out[n, k] = the chain vector of slot k (NaN where not valid); see chain_rows."""
    for n in range(theta.shape[0]):
        theta_n, out_n = theta[n], out[n]
        for k in range(theta.shape[1]):
            if valid[n, k]:
                chain_row(theta_n, k, False, q0, columns, solved, out_n)
            else:
                out_n[k, :] = np.nan


def chain_rows(theta: np.ndarray, valid: np.ndarray, q0: np.ndarray, columns: np.ndarray, scale: np.ndarray,
               lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Chain vectors (N, k, n) of solved angles ``theta`` (N, k, m) (chain order): ``q0`` with column
    ``columns[i]`` moved by ``theta[..., i] / scale[i]`` and taken, by whole turns, to the in-limit value nearest 0
    (``lower``/``upper`` of the solved columns; wrapped to (-pi, pi] when none is inside); NaN rows where not
    ``valid``. The same numbers as chain_ik's numpy ``_joint_values`` and ``_aliases`` (revolute joints only)."""
    theta = np.ascontiguousarray(theta, dtype=float)
    out = np.empty((*theta.shape[:2], len(q0)))
    _rows(theta, np.ascontiguousarray(valid, dtype=np.bool_), np.ascontiguousarray(q0, dtype=float),
          np.ascontiguousarray(columns, dtype=np.int64), np.array([scale, lower, upper], dtype=float), out)
    return out


def _labels(H, P, c, s, reference, up, g, theta, out):
    """out[r] = (front, elbow above, no flip) of each row of theta (k, 6), as chain_ik's _labels computes them
    (per family)."""
    h0, h1, h2 = _row(H, 0), _row(H, 1), _row(H, 2)
    p0, p1, p2, p3 = _row(P, 0), _row(P, 1), _row(P, 2), _row(P, 3)
    w = _add(_mv(g[:3, :3], c), (g[0, 3], g[1, 3], g[2, 3]))
    for r in range(theta.shape[0]):
        t1, t2, t3 = theta[r, 0], theta[r, 1], theta[r, 2]
        c1, s1 = math.cos(t1), math.sin(t1)
        w1 = _add(p0, _rotate(h0, c1, -s1, _sub(w, p0)))
        out[r, 0] = _dot(_sub(w1, p0), reference) >= 0.0
        c2, s2 = math.cos(t2), math.sin(t2)
        shoulder = _move(h0, p0, c1, s1, s)
        elbow = _move(h0, p0, c1, s1, _move(h1, p1, c2, s2, p2))
        wrist = w
        if KIND == 0:
            c3, s3 = math.cos(t3), math.sin(t3)
            wrist = _move(h0, p0, c1, s1, _move(h1, p1, c2, s2, _move(h2, p2, c3, s3, p3)))
        normal = _rotate(h0, c1, s1, h1)
        line, offset = _sub(wrist, shoulder), _sub(elbow, shoulder)
        a, b = _dot(line, normal), _dot(offset, normal)
        line = (line[0] - a * normal[0], line[1] - a * normal[1], line[2] - a * normal[2])
        offset = (offset[0] - b * normal[0], offset[1] - b * normal[1], offset[2] - b * normal[2])
        length = _dot(line, line)
        along = _dot(offset, line) / length if length > 0.0 else 0.0
        offset = (offset[0] - along * line[0], offset[1] - along * line[1], offset[2] - along * line[2])
        # an elbow within ELBOW_TIE of the line (straight, where two branches meet) counts as up on both paths
        out[r, 1] = _dot(offset, up) >= -ELBOW_TIE * math.sqrt(length)
        out[r, 2] = theta[r, 4] >= 0.0


def branch_labels(kind: str, h: np.ndarray, p: np.ndarray, wrist: np.ndarray, shoulder: np.ndarray,
                  reference: np.ndarray, up: np.ndarray, g: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """(k, 3) bool: front, elbow above the shoulder-wrist line, no wrist flip, of rows ``theta`` (k, 6) (solve
    direction) for one target ``g`` (4, 4): chain_ik's labels, compiled (``reference``, ``up``: its axes)."""
    out = np.zeros((len(theta), 3), dtype=np.bool_)
    family_kernels(KIND_CODES[kind]).labels(np.ascontiguousarray(h, dtype=float), np.ascontiguousarray(p, dtype=float),
            tuple(float(v) for v in wrist), tuple(float(v) for v in shoulder), tuple(float(v) for v in reference),
            tuple(float(v) for v in up), np.ascontiguousarray(g, dtype=float), np.ascontiguousarray(theta, dtype=float),
            out)
    return out


@compile_kernel
def _solved_target(T, M_inv, reverse, g):
    """g = T M^-1 (inverted when ``reverse``: a family solved tip to base), as chain_ik's _solved_direction."""
    for i in range(4):
        for j in range(4):
            g[i, j] = T[i, 0] * M_inv[0, j] + T[i, 1] * M_inv[1, j] + T[i, 2] * M_inv[2, j] + T[i, 3] * M_inv[3, j]
    if reverse:
        t0, t1, t2 = g[0, 3], g[1, 3], g[2, 3]
        for i in range(3):
            for j in range(i + 1, 3):
                g[i, j], g[j, i] = g[j, i], g[i, j]
        for i in range(3):
            g[i, 3] = -(g[i, 0] * t0 + g[i, 1] * t1 + g[i, 2] * t2)
        g[3, 0], g[3, 1], g[3, 2], g[3, 3] = 0.0, 0.0, 0.0, 1.0


def _checked_target(K, H, M_inv, reverse, T, q0, columns, solved, limits, floats, ints, g, states, reached, out,
                    theta, valid, near, rows, residuals, within):
    """One target: every branch solved (as _solve_all), then each valid one's chain row, FK on the true chain,
    residual and limits (check_kernel); True when the reference must decide (nothing else is written then).
    ``solved`` (3, m): joint scales, lower and upper limits of the solved columns; ``limits`` (2, n): the chain's.
    Per family."""
    _solved_target(T, M_inv, reverse, g)
    if _target(K, H, g, out, theta, valid, near):
        return True
    for k in range(theta.shape[0]):
        if valid[k]:
            chain_row(theta, k, reverse, q0, columns, solved, rows)
    check_rows(rows, valid, T, floats, ints, limits, states, reached, residuals, within)
    return False


def _solve_rows_all(arm_reals, arm_ints, T, valid, fallback, project, rows, packed, index):
    """Every target of ``T``: its rows (NaN where no branch, or handed back), and the rows that are not NaN also
    packed in order into ``packed`` (M, n) with their slot ``index`` (M,) (``8 target + slot``); returns M.

    Targets go through the lanes in chunks of LANES (:func:`manipkit.closed_form.arms_lanes.ur_chunk`, ``opw_chunk``:
    on vector registers), a short last chunk padded with copies of its last target (their answers not read).
    Per family (nogil: chain_ik_many runs it on blocks of targets from several threads at once, each block its own
    rows)."""
    _, H, P, points, scale, M_inv, reverse, q0, columns, solved, _, _, _ = arm_constants(arm_reals, arm_ints)
    K = arm_tuple(H, P, _row(points, 0), scale)
    g = np.empty((4, 4))
    chunk, out = np.empty(12 * LANES), np.empty(ENTRIES * LANES)
    m, n_columns = columns.shape[0], q0.shape[0]
    values, odd = np.empty(SLOTS * m * LANES), np.empty(LANES)
    # one target's angles and flags, reused: no (N, 8, m) array, and no view of valid made (and counted) per target
    theta, near, valid_k = np.zeros((SLOTS, H.shape[0])), np.zeros(SLOTS, dtype=np.bool_), np.zeros(SLOTS, dtype=np.bool_)
    count = 0
    for start in range(0, T.shape[0], LANES):
        used = min(LANES, T.shape[0] - start)
        for lane in range(LANES):
            n = start + min(lane, used - 1)
            _solved_target(T[n], M_inv, reverse, g)
            for i in range(3):
                for j in range(4):
                    chunk[(4 * i + j) * LANES + lane] = g[i, j]
        lanes_chunk(K, chunk, out)
        _lane_angles(KIND, out, LANES)
        _lane_rows(KIND, H, out, reverse, q0, columns, solved, values, odd)
        for lane in range(used):
            n = start + lane
            project[n] = not exact_rotation(T[n])
            plain = odd[lane] == 0.0  # its rows from values; else (and theta) by chain_row
            if plain:
                fallback[n] = _lane_flags(out, lane, LANES, valid_k)
            else:
                fallback[n] = _lane_answer(KIND, H, out, lane, LANES, theta, valid_k, near)
            for k in range(SLOTS):  # rows[n, k, j] indexed whole: a view rows[n] per target costs two atomic counts
                valid[n, k] = valid_k[k]
                made = valid_k[k] and not fallback[n]
                if made and plain:
                    for j in range(n_columns):
                        rows[n, k, j] = q0[j]
                    for i in range(m):
                        rows[n, k, columns[i]] = values[(k * m + i) * LANES + lane]
                elif made:
                    chain_row(theta, k, reverse, q0, columns, solved, rows[n])
                count = packed_row(rows, n, k, made, packed, index, count)
    return count


def _measure_at(T, reached, index, position_tol, rotation_tol, residuals, success):
    """residuals[n, k] = the residual (m, rad) of reached[i] against T[n] for slot ``index[i] = SLOTS n + k``, NaN
    in the other slots; success[n]: some slot of target n within both tolerances. The rotations' atan2 are taken
    in one flat loop (vectorised: see _lane_angles), as pose_residual takes them one by one."""
    for n in range(residuals.shape[0]):
        for k in range(SLOTS):
            residuals[n, k, 0], residuals[n, k, 1] = np.nan, np.nan
    M = index.shape[0]
    parts = np.empty((3, M))
    for i in range(M):  # SLOTS a compile-time constant: a shift, not a division
        n = index[i] // SLOTS
        parts[0, i], parts[1, i], parts[2, i] = pose_residual_parts(T[n], reached[i])
    for i in range(M):
        parts[1, i] = _atan2(parts[1, i], parts[2, i])
    for i in range(M):
        n, k = index[i] // SLOTS, index[i] % SLOTS
        residuals[n, k, 0], residuals[n, k, 1] = parts[0, i], parts[1, i]
    for n in range(residuals.shape[0]):
        success[n] = False
        for k in range(SLOTS):
            if residuals[n, k, 0] <= position_tol and residuals[n, k, 1] <= rotation_tol:  # NaN: False
                success[n] = True


_measure_at = compile_kernel(_measure_at, nogil=True)


@compile_kernel
def _measure_all(T, reached, rows, position_tol, rotation_tol, residuals, success):
    for n in range(rows.shape[0]):
        success[n] = False
        for k in range(rows.shape[1]):
            if math.isnan(rows[n, k, 0]):
                residuals[n, k, 0], residuals[n, k, 1] = np.nan, np.nan
            else:
                position, rotation = pose_residual(T[n], reached[n, k])
                residuals[n, k, 0], residuals[n, k, 1] = position, rotation
                if position <= position_tol and rotation <= rotation_tol:
                    success[n] = True


def _solve_check_one(arm_reals, arm_ints, T, position_tol, rotation_tol):
    """_checked_target for one target (the chain's constants packed by check_kernel.pack_arm), its rows kept,
    ordered and coded as chain_ik answers (:func:`manipkit.closed_form.check_kernel.kept_rows`; code ``4 back + 2
    elbow down + wrist flip``); no rows when the general path must answer. Per family."""
    _, H, P, points, scale, M_inv, reverse, q0, columns, solved, limits, floats, ints = arm_constants(arm_reals, arm_ints)
    m, n = H.shape[0], q0.shape[0]
    theta, valid, near = np.zeros((SLOTS, m)), np.zeros(SLOTS, dtype=np.bool_), np.zeros(SLOTS, dtype=np.bool_)
    rows, residuals, within = np.full((SLOTS, n), np.nan), np.full((SLOTS, 2), np.nan), np.zeros(SLOTS, dtype=np.bool_)
    bits, codes = np.zeros((SLOTS, 3), dtype=np.bool_), np.zeros(SLOTS, dtype=np.int64)
    g, states, reached = np.empty((4, 4)), np.empty((ints[0] + 1, 4, 3)), np.empty((SLOTS, 4, 4))
    c = _row(points, 0)
    K = arm_tuple(H, P, c, scale)
    if not plain_target(T) or _checked_target(K, H, M_inv, reverse, T, q0, columns, solved, limits, floats,
                                              ints, g, states, reached, np.empty(ENTRIES), theta, valid, near, rows,
                                              residuals, within):
        return np.empty((0, n + 2)), np.empty(0, dtype=np.bool_), 0
    _labels(H, P, c, _row(points, 1), _row(points, 2), _row(points, 3), g, theta, bits)
    for k in range(SLOTS):
        codes[k] = 4 * (not bits[k, 0]) + 2 * (not bits[k, 1]) + (not bits[k, 2])
    return kept_rows(valid, rows, residuals, within, codes, codes, position_tol, rotation_tol)


def solve_rows_many(prepared: tuple, T: np.ndarray):
    """Every branch of targets ``T`` (N, 4, 4) (``T_base_tip``) as chain vectors, in one compiled loop.

    ``prepared``: the chain's constants (``ik.ideal_arm.compiled_arm``). Returns (valid (N, 8), fallback (N,),
    project (N,), rows (N, 8, n): chain vectors with the in-limit aliases nearest 0, NaN where not valid). Targets
    with ``fallback`` have NaN rows (the reference solves them); ``project``: a target whose rotation block is not
    a rotation to 1e-12 (measure against its projection).
    """
    arm_reals, arm_ints = prepared
    T = np.ascontiguousarray(T, dtype=float)
    N, n = T.shape[0], int(arm_ints[3])
    valid = np.zeros((N, SLOTS), dtype=np.bool_)
    fallback, project = np.zeros(N, dtype=np.bool_), np.zeros(N, dtype=np.bool_)
    rows = np.empty((N, SLOTS, n))
    family_kernels(int(arm_ints[0])).solve_rows_all(arm_reals, arm_ints, T, valid, fallback, project, rows,
                                                    np.empty((SLOTS * N, n)), np.empty(SLOTS * N, dtype=np.int64))
    return valid, fallback, project, rows


def solve_rows_into(prepared: tuple, T: np.ndarray, valid: np.ndarray, fallback: np.ndarray, project: np.ndarray,
                    rows: np.ndarray, packed: np.ndarray, index: np.ndarray) -> int:
    """:func:`solve_rows_many` written into the given arrays (C-contiguous: valid (N, 8) bool, fallback and project
    (N,) bool, rows (N, 8, n) float), without the GIL: each thread of a batch passes its own block of targets.
    The rows that are not NaN are also copied, in order, into ``packed`` (at least (8 N, n)), with their slot
    ``8 target + k`` in ``index`` (int64): returns how many, M (``packed[:M]`` is what the check puts through FK)."""
    return family_kernels(int(prepared[1][0])).solve_rows_all(prepared[0], prepared[1], T, valid, fallback, project,
                                                              rows, packed, index)


def measure_at(T: np.ndarray, reached: np.ndarray, index: np.ndarray, tol: tuple[float, float], residuals: np.ndarray,
               success: np.ndarray) -> None:
    """``residuals`` (N, 8, 2, written): the residuals (m, rad) of the reached pose ``reached[i]`` (M, 4, 4) against
    target ``T[n]`` (N, 4, 4) in slot ``index[i] = 8 n + slot`` (M,) (:data:`SLOTS`), by
    :func:`~manipkit.closed_form.check_kernel.pose_residual` (as :func:`measure_many`), NaN in every other slot;
    ``success`` (N,, written): some slot within ``tol`` (m, rad). Without the GIL."""
    if residuals.shape[1:] != (SLOTS, 2):
        raise ValueError(f"residuals must have shape (N, {SLOTS}, 2), got {residuals.shape}")
    _measure_at(T, reached, index, float(tol[0]), float(tol[1]), residuals, success)


def measure_many(T: np.ndarray, reached: np.ndarray, rows: np.ndarray, tol: tuple[float, float]
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(residuals (N, k, 2), success (N,)): the residuals (m, rad) of reached poses ``reached`` (N, k, 4, 4) against
    targets ``T`` (N, 4, 4) by :func:`manipkit.closed_form.check_kernel.pose_residual` (``pose_residuals``'
    compiled twin), NaN where the row ``rows`` (N, k, n) is NaN (no branch); success: some row within ``tol``
    (m, rad)."""
    residuals, success = np.empty((*rows.shape[:2], 2)), np.empty(rows.shape[0], dtype=np.bool_)
    _measure_all(np.ascontiguousarray(T, dtype=float), np.ascontiguousarray(reached, dtype=float), rows,
                 float(tol[0]), float(tol[1]), residuals, success)
    return residuals, success


def solve_check_one(prepared: tuple, T: np.ndarray, tol: tuple[float, float]):
    """One target ``T`` (4, 4, float, C-contiguous) solved, each branch's chain row put through the chain's FK and
    measured (as :func:`solve_rows_many` and :func:`measure_many`), labelled (:func:`branch_labels`), and kept as
    ``chain_ik`` keeps rows (repeats modulo 2 pi dropped, ordered front, elbow up, no flip first), in one call.

    ``prepared``: the chain's constants (``ik.ideal_arm.compiled_arm``: :func:`~manipkit.closed_form.check_kernel.
    pack_arm`'s two arrays). Returns (block (k, n + 2), within (k,), codes) as
    :func:`~manipkit.closed_form.check_kernel.kept_rows` gives them (chain vectors and their position and rotation
    residuals, within limits, the rows' codes ``4 back + 2 elbow down + wrist flip`` as one number:
    :func:`~manipkit.closed_form.check_kernel.codes_of`), or None when the general path must answer (the
    reference must decide, ``T`` is not a transform check_transform takes as is with a rotation block exact to
    1e-12, or a row misses ``tol`` (m, rad)).
    """
    answer = family_kernels(int(prepared[1][0])).solve_check_one(prepared[0], prepared[1], T, tol[0], tol[1])
    return answer if len(answer[0]) else None


#: The per-family functions, in the order family_kernels compiles them (a later one calls the earlier ones by name):
#: (name, numba options; None: inlined into its callers).
_PER_FAMILY = (("_target", None), ("_solve_all", {}), ("_labels", {}), ("_checked_target", {}),
               ("_solve_rows_all", {"nogil": True}), ("_solve_check_one", {}))
_families: dict = {}
_families_lock = threading.Lock()


def family_kernels(code: int) -> types.SimpleNamespace:
    """The compiled loops of the family with code ``code`` (a value of :data:`KIND_CODES`), made on first use.

    Each of the functions in ``_PER_FAMILY`` is made again with globals in which :data:`KIND` is ``code`` and
    :func:`lanes_one`, :func:`lanes_chunk` are that family's lanes (``arms_lanes.ur_one``, ...), named
    ``<function>_<family>`` (``_solve_check_one_ur``): so each compiled loop holds one family's lanes, and
    numba's disk cache keeps each family's under its own name. Returns a namespace of the dispatchers
    (``solve_all``, ``labels``, ``solve_rows_all``, ``solve_check_one``; compiled on their first call).
    """
    made = _families.get(code)
    if made is not None:
        return made
    with _families_lock:
        if code not in _families:
            family = FAMILY_NAMES[code]
            one, chunk = {0: (ur_one, ur_chunk), 1: (opw_one, opw_chunk)}[code]
            scope = dict(globals(), KIND=code, lanes_one=one, lanes_chunk=chunk)
            for name, options in _PER_FAMILY:
                source = globals()[name]
                function = types.FunctionType(source.__code__, scope, f"{name}_{family}", source.__defaults__)
                function.__qualname__, function.__doc__ = f"{name}_{family}", source.__doc__
                scope[name] = inlined_kernel(function) if options is None else compile_kernel(function, **options)
            _families[code] = types.SimpleNamespace(**{name.lstrip("_"): scope[name] for name, _ in _PER_FAMILY})
    return _families[code]


def warm_up(kinds=tuple(KIND_CODES)) -> None:
    """Compile (or load from numba's on-disk cache) every kernel here, for the families ``kinds`` (keys of
    :data:`KIND_CODES`; default both), with the argument types chain_ik passes.

    ``make kernels`` runs it (``python -m manipkit.closed_form.arms_kernel``), so that no first closed-form solve
    pays for it; each family compiles on its first use otherwise.
    """
    from manipkit.closed_form.srs_kernel import solve_check_srs
    from manipkit.kernels.fk import ChainStep
    from manipkit.kernels.program import ChainProgram

    z, y = (0.0, 0.0, 1.0), (0.0, 1.0, 0.0)
    h = np.array([z, y, y, y, z, y])
    p = np.array([[0.0, 0.0, 0.1], [0.0, 0.1, 0.1], [0.4, 0.1, 0.1], [0.8, 0.1, 0.1], [0.8, 0.2, 0.1], [0.8, 0.2, 0.0]])
    g = np.eye(4)[None]
    # the solve-and-check loops, on a chain of seven joints about z (only the argument types matter here)
    floats, ints = ChainProgram([ChainStep(np.eye(3), np.array([0.0, 0.0, 0.1]), k, False, np.array(z))
                                 for k in range(7)], 7).row_tables
    h7, p7 = np.vstack([h, [z]]), np.vstack([p, [[0.8, 0.2, -0.1]]])
    limits = np.full(7, np.pi)
    for kind in kinds:
        theta, valid, _, _ = solve_many(kind, h, p, p[5], 1.0, g)
        chain_rows(theta, valid, np.zeros(6), np.arange(6), np.ones(6), np.full(6, -np.pi), np.full(6, np.pi))
        branch_labels(kind, h, p, p[5], p[1], np.array([1.0, 0.0, 0.0]), h[0], g[0], theta[0])
        prepared = pack_arm(KIND_CODES[kind], h7, p7, np.array([z, y, z, y]), 1.0, np.eye(4), False, np.zeros(7),
                            np.arange(7), np.array([np.ones(7), -limits, limits]), np.array([-limits, limits]), floats,
                            ints)
        solve_check_one(prepared, np.eye(4), (1e-10, 1e-10))
        rows = solve_rows_many(prepared, g)[-1]
    measure_many(g, np.repeat(g[:, None], SLOTS, axis=1), rows, (1e-10, 1e-10))
    measure_at(g, np.repeat(g, SLOTS, axis=0), np.arange(SLOTS, dtype=np.int64), (1e-10, 1e-10),
               np.empty((1, SLOTS, 2)),
               np.empty(1, dtype=np.bool_))
    solve_check_srs(prepared, np.eye(4), 0.3, (1e-10, 1e-10))
    measure_rows(np.zeros((1, 7)), g, np.zeros(1, dtype=np.intp), floats, ints, np.empty((1, 2)))


if __name__ == "__main__":
    import time

    start = time.perf_counter()
    warm_up()
    print(f"manipkit closed-form kernels ready ({time.perf_counter() - start:.1f} s; compiled once, then cached by numba)")
