"""The 7R SRS closed form of :mod:`manipkit.closed_form.srs` at a given arm angle, compiled, with its check.

The same sequence as :func:`manipkit.closed_form.srs.solve_srs` (elbow by
subproblem 3, the reference shoulder by subproblem 2, the shoulder turned by
the arm angle ``psi`` about the shoulder-wrist line and split into ``t1, t2,
t3``, the wrist ``t5, t6, t7``), on scalars and 3-tuples
(:mod:`manipkit.closed_form.subproblems_kernel`), every branch in the same
slot (``4 elbow + 2 shoulder + wrist``); then each branch's chain row, FK on
the true chain and residual (:mod:`manipkit.closed_form.check_kernel`), in
one compiled call per target (:func:`solve_check_srs`). Many targets, each at
its own arm angle, are solved into rows as the 6R batch takes them
(:func:`solve_srs_rows_into`: ``chain_ik_many``, checked by the chain's FK
afterwards, :mod:`manipkit.ik.chain_batch`).

Like the 6R loops it answers generic targets only: a target where a
decision of the reference comes near its threshold (a tangency, a free
angle, subproblem 2's acceptance of a pair, a missing branch) is handed back
and solved by the numpy reference, so the answer is the reference's
everywhere. Importing this module imports numba.
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.closed_form.check_kernel import (
    arm_constants,
    chain_row,
    check_rows,
    exact_rotation,
    kept_rows,
    packed_row,
    plain_target,
)
from manipkit.closed_form.subproblems_kernel import (
    MARGIN,
    add,
    atan2,
    compile_kernel,
    dot,
    mv,
    norm,
    perpendicular,
    rotate,
    row,
    sp1,
    sp3,
    sp4,
    sub,
)

__all__ = ["arm_angles_into", "solve_check_srs", "solve_srs_rows_into", "solve_srs_target"]

PAIR_MISS = 1e-10  # a subproblem-2 pair missing by more is left to the reference (it accepts up to sqrt(1e-12))
#: The arm angle's choice between the two shoulder turns (the second only with the elbow straight) is the
#: reference's ``gap' < gap - 1e-9``; within this much of that threshold the reference decides.
CHOICE_MARGIN = 1e-12


@compile_kernel
def _apply(C0, C1, C2, x):
    """M x for the matrix with columns C0, C1, C2."""
    return (C0[0] * x[0] + C1[0] * x[1] + C2[0] * x[2], C0[1] * x[0] + C1[1] * x[1] + C2[1] * x[2],
            C0[2] * x[0] + C1[2] * x[1] + C2[2] * x[2])


@compile_kernel
def _shoulder(v, pc, ps, h0, c1, s1, h1, ca, sa, x):
    """R(v, psi) R(h0, -b) R(h1, a) x: the reference shoulder turned by the arm angle (cos, sin given)."""
    return rotate(v, pc, ps, rotate(h0, c1, s1, rotate(h1, ca, sa, x)))


@compile_kernel
def solve_srs_target(H, P, S, c, pc, ps, R, t, theta, valid, wanted):
    """One target (``R``, ``t`` of ``g``) at the arm angle (cos ``pc``, sin ``ps``) into theta (8, 7), valid (8,);
    True when the reference must decide. ``wanted`` >= 0: only that slot's angles are written (every slot is
    still solved and decided, so ``valid`` and the answer are the same; the other slots' angles are left out)."""
    # Over 80 lines: the reference's elbow, shoulder and wrist stages and their slots, in its order.
    h0, h1, h2, h3, h4, h5, h6 = row(H, 0), row(H, 1), row(H, 2), row(H, 3), row(H, 4), row(H, 5), row(H, 6)
    p3 = row(P, 3)
    v = sub(add(mv(R, c), t), S)
    length = norm(v)
    if length <= MARGIN:
        return True
    vhat = (v[0] / length, v[1] / length, v[2] / length)
    ca4, sa4, cb4, sb4, count4, _, unsure4 = sp3(h3, sub(c, p3), sub(S, p3), length)
    if unsure4 or count4 == 0.0:
        return True
    v2, v6 = perpendicular(h2), perpendicular(h6)
    e1, e2, e3 = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
    for e in range(2):
        c4, s4 = (ca4, sa4) if e == 0 else (cb4, sb4)
        u = sub(add(p3, rotate(h3, c4, s4, sub(c, p3))), S)
        # the reference shoulder: R(h1, a) u = R(h0, b) v (subproblem 2, its first pair)
        ca, sa, _, _, count_r, _, unsure_r = sp4(h0, h1, u, dot(h0, v))
        if unsure_r or count_r == 0.0:
            return True
        cb, sb, size_b, miss_b = sp1(h0, v, rotate(h1, ca, sa, u))
        if size_b <= MARGIN or miss_b > PAIR_MISS * max(1.0, norm(u)):
            return True
        C0 = _shoulder(vhat, pc, ps, h0, cb, -sb, h1, ca, sa, e1)
        C1 = _shoulder(vhat, pc, ps, h0, cb, -sb, h1, ca, sa, e2)
        C2 = _shoulder(vhat, pc, ps, h0, cb, -sb, h1, ca, sa, e3)
        # split: R(h0, m) x = R(h1, t2) h2 with x = R_shoulder h2, t1 = -m
        x = _apply(C0, C1, C2, h2)
        cma, sma, cmb, smb, count_s, _, unsure_s = sp4(h1, h0, x, dot(h1, h2))
        if unsure_s or count_s == 0.0:
            return True
        turned_v2 = _apply(C0, C1, C2, v2)
        # R_arm = R_shoulder R(h3, t4): its columns; R_rem y = R_arm^T R y
        A0 = _apply(C0, C1, C2, rotate(h3, c4, s4, e1))
        A1 = _apply(C0, C1, C2, rotate(h3, c4, s4, e2))
        A2 = _apply(C0, C1, C2, rotate(h3, c4, s4, e3))
        g6, gv = mv(R, h6), mv(R, v6)
        x6 = (dot(A0, g6), dot(A1, g6), dot(A2, g6))
        rv = (dot(A0, gv), dot(A1, gv), dot(A2, gv))
        cwa, swa, cwb, swb, count_w, _, unsure_w = sp4(h5, h4, x6, dot(h5, h6))
        if unsure_w or count_w == 0.0:
            return True
        # the wrist's two pairs do not depend on the shoulder's: solved once per elbow, each angle's atan2 once
        wrist_a, wrist_b = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)  # t5, t6, t7 of each wrist pair
        for w in range(2):
            cw, sw = (cwa, swa) if w == 0 else (cwb, swb)  # the angle -t5
            c6, s6, size6, miss6 = sp1(h5, h6, rotate(h4, cw, sw, x6))
            if size6 <= MARGIN or (w == 0 and miss6 > PAIR_MISS):
                return True
            c7, s7, _, _ = sp1(h6, v6, rotate(h5, c6, -s6, rotate(h4, cw, sw, rv)))
            if wanted < 0 or (wanted // 4 == e and wanted % 2 == w):
                angles = (atan2(-sw, cw), atan2(s6, c6), atan2(s7, c7))
                if w == 0:
                    wrist_a = angles
                else:
                    wrist_b = angles
        t4 = atan2(s4, c4)
        for s in range(2):
            cm, sm = (cma, sma) if s == 0 else (cmb, smb)
            c2, s2, size2, miss2 = sp1(h1, h2, rotate(h0, cm, sm, x))
            if size2 <= MARGIN or (s == 0 and miss2 > PAIR_MISS):
                return True
            c3, s3, _, _ = sp1(h2, v2, rotate(h1, c2, -s2, rotate(h0, cm, sm, turned_v2)))
            if wanted >= 0 and wanted // 2 != 2 * e + s:
                for w in range(2):
                    valid[4 * e + 2 * s + w] = True
                continue
            t1, t2, t3 = atan2(-sm, cm), atan2(s2, c2), atan2(s3, c3)
            for w in range(2):
                slot = 4 * e + 2 * s + w
                valid[slot] = True
                if wanted >= 0 and slot != wanted:
                    continue
                theta[slot, 0], theta[slot, 1], theta[slot, 2], theta[slot, 3] = t1, t2, t3, t4
                t5, t6, t7 = wrist_a if w == 0 else wrist_b
                theta[slot, 4], theta[slot, 5], theta[slot, 6] = t5, t6, t7
    return False


@compile_kernel
def _srs_check_one(arm_reals, arm_ints, T, psi, position_tol, rotation_tol):
    """One target: every branch at the arm angle ``psi``, each branch's chain row, FK, residual and limits, kept as
    chain_ik keeps rows (:func:`manipkit.closed_form.check_kernel.kept_rows`; ordered by the wrist's split, code
    ``4 (t4 < 0) + 2 (t2 < 0) + (t6 < 0)``); no rows when the general path must answer. ``arm_reals``,
    ``arm_ints``: the chain's constants (:func:`manipkit.closed_form.check_kernel.pack_arm`)."""
    _, H, P, points, _, M_inv, _, q0, columns, solved, limits, floats, ints = arm_constants(arm_reals, arm_ints)
    n = q0.shape[0]
    theta, valid = np.zeros((8, 7)), np.zeros(8, dtype=np.bool_)
    rows, residuals, within = np.full((8, n), np.nan), np.full((8, 2), np.nan), np.zeros(8, dtype=np.bool_)
    keys, codes = np.zeros(8, dtype=np.int64), np.zeros(8, dtype=np.int64)
    states, reached, g = np.empty((ints[0] + 1, 4, 3)), np.empty((8, 4, 4)), np.empty((4, 4))
    for i in range(4):  # g = T M^-1
        for j in range(4):
            g[i, j] = T[i, 0] * M_inv[0, j] + T[i, 1] * M_inv[1, j] + T[i, 2] * M_inv[2, j] + T[i, 3] * M_inv[3, j]
    if not plain_target(T) or solve_srs_target(H, P, row(points, 1), row(points, 0), math.cos(psi), math.sin(psi),
                                          g[:3, :3], (g[0, 3], g[1, 3], g[2, 3]), theta, valid, -1):
        return np.empty((0, n + 2)), np.empty(0, dtype=np.bool_), 0
    for k in range(theta.shape[0]):
        if valid[k]:
            chain_row(theta, k, False, q0, columns, solved, rows)
        keys[k] = 1 if theta[k, 5] < 0.0 else 0
        codes[k] = 4 * (theta[k, 3] < 0.0) + 2 * (theta[k, 1] < 0.0) + keys[k]
    check_rows(rows, valid, T, floats, ints, limits, states, reached, residuals, within)
    return kept_rows(valid, rows, residuals, within, keys, codes, position_tol, rotation_tol)


def solve_check_srs(prepared: tuple, T: np.ndarray, arm_angle: float, tol: tuple[float, float]):
    """Every branch of an SRS arm for one target ``T`` (4, 4, float, C-contiguous) at ``arm_angle`` (rad), checked
    on the true chain and kept as ``chain_ik`` keeps rows, in one compiled call.

    ``prepared``: the chain's constants (``ik.ideal_arm.compiled_arm``). Returns None when the general path must
    answer (the reference must decide, ``T`` is not a transform with a rotation block exact to 1e-12, or a row
    misses ``tol`` (m, rad)); else (block, within, codes) as :func:`manipkit.closed_form.arms_kernel.solve_check_one`
    gives them (codes ``4 elbow - + 2 shoulder - + wrist flip``).
    """
    answer = _srs_check_one(prepared[0], prepared[1], T, float(arm_angle), tol[0], tol[1])
    return answer if len(answer[0]) else None


def _srs_rows_all(arm_reals, arm_ints, T, arm_angles, valid, fallback, project, rows, packed, index):
    """Every target ``T[t]`` at its arm angle ``arm_angles[t]``: valid (N, 8), fallback and project (N,), rows
    (N, 8, n) and the packed rows as :func:`solve_srs_rows_into` writes them; returns how many rows were packed."""
    _, H, P, points, _, M_inv, _, q0, columns, solved, _, _, _ = arm_constants(arm_reals, arm_ints)
    theta, valid_k = np.zeros((8, 7)), np.zeros(8, dtype=np.bool_)
    g = np.empty((4, 4))
    S, c = row(points, 1), row(points, 0)
    count = 0
    for t in range(T.shape[0]):
        for i in range(3):  # g = T M^-1 (its last row is not read)
            for j in range(4):
                g[i, j] = (T[t, i, 0] * M_inv[0, j] + T[t, i, 1] * M_inv[1, j] + T[t, i, 2] * M_inv[2, j]
                           + T[t, i, 3] * M_inv[3, j])
        for k in range(8):
            valid_k[k] = False
        project[t] = not exact_rotation(T[t])
        angle = arm_angles[t]
        fallback[t] = solve_srs_target(H, P, S, c, math.cos(angle), math.sin(angle), g[:3, :3],
                                  (g[0, 3], g[1, 3], g[2, 3]), theta, valid_k, -1)
        for k in range(8):
            valid[t, k] = valid_k[k]
            made = valid_k[k] and not fallback[t]
            if made:
                chain_row(theta, k, False, q0, columns, solved, rows[t])
            count = packed_row(rows, t, k, made, packed, index, count)
    return count


# nogil: chain_ik_many runs it on blocks of targets from several threads at once (each block its own rows)
_srs_rows_all = compile_kernel(_srs_rows_all, nogil=True)


def solve_srs_rows_into(prepared: tuple, T: np.ndarray, arm_angles: np.ndarray, valid: np.ndarray,
                        fallback: np.ndarray, project: np.ndarray, rows: np.ndarray, packed: np.ndarray,
                        index: np.ndarray) -> int:
    """Every branch of an SRS arm for targets ``T`` (N, 4, 4), target ``t`` at ``arm_angles[t]`` (rad), as chain
    vectors written into the given arrays, without the GIL: the contract of
    :func:`manipkit.closed_form.arms_kernel.solve_rows_into` (valid (N, 8) bool: slot ``4 elbow + 2 shoulder +
    wrist`` solved; fallback (N,): handed back to the numpy reference, its rows NaN; project (N,): a rotation
    block not exact to 1e-12, measured against its projection; rows (N, 8, n): the in-limit aliases nearest 0, NaN
    where not valid; the rows that are not NaN copied in order into ``packed`` with their slot ``8 t + k`` in
    ``index``; returns how many). ``prepared``: the chain's constants (``ik.ideal_arm.compiled_arm``), the
    family solved base to tip. The same rows bit for bit as :func:`solve_check_srs` checks for one target.
    """
    return _srs_rows_all(prepared[0], prepared[1], T, arm_angles, valid, fallback, project, rows, packed, index)


@compile_kernel
def _turns(h0, c0, s0, h1, c1, s1, h2, c2, s2, x):
    """R(h0, t0) R(h1, t1) R(h2, t2) x (cos, sin of each angle given)."""
    return rotate(h0, c0, s0, rotate(h1, c1, s1, rotate(h2, c2, s2, x)))


@compile_kernel
def _arm_angles_all(arm_reals, arm_ints, T, Q, psi, fallback):
    """psi (N,) and fallback (N,) for the configurations ``Q`` (N, n) with FK ``T`` (N, 4, 4); see
    :func:`arm_angles_into`."""
    _, H, P, points, _, M_inv, _, q0, columns, solved, _, _, _ = arm_constants(arm_reals, arm_ints)
    h0, h1, h2, h3 = row(H, 0), row(H, 1), row(H, 2), row(H, 3)
    p3 = row(P, 3)
    S, c = row(points, 1), row(points, 0)
    e = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    angle, g, D = np.empty(4), np.empty((3, 4)), np.empty((3, 3))
    gaps, values = np.empty(2), np.empty(2)
    for t in range(T.shape[0]):
        psi[t] = np.nan
        fallback[t] = True
        for i in range(4):
            angle[i] = solved[0, i] * (Q[t, columns[i]] - q0[columns[i]])
        for i in range(3):  # g = T M^-1 (its last row is not needed)
            for j in range(4):
                g[i, j] = (T[t, i, 0] * M_inv[0, j] + T[t, i, 1] * M_inv[1, j] + T[t, i, 2] * M_inv[2, j]
                           + T[t, i, 3] * M_inv[3, j])
        # the wrist centre g c, and v its direction from the shoulder S
        wc = (g[0, 0] * c[0] + g[0, 1] * c[1] + g[0, 2] * c[2] + g[0, 3] - S[0],
              g[1, 0] * c[0] + g[1, 1] * c[1] + g[1, 2] * c[2] + g[1, 3] - S[1],
              g[2, 0] * c[0] + g[2, 1] * c[1] + g[2, 2] * c[2] + g[2, 3] - S[2])
        length = norm(wc)
        if length <= MARGIN:
            continue
        v = (wc[0] / length, wc[1] / length, wc[2] / length)
        # the elbow at q: u, the wrist centre's offset from S with joint 4 at its angle
        u = sub(add(p3, rotate(h3, math.cos(angle[3]), math.sin(angle[3]), sub(c, p3))), S)
        size = norm(u)
        target = (v[0] * size, v[1] * size, v[2] * size)
        # the reference shoulder: R(h1, a) u = R(h0, b) target (subproblem 2, its first pair)
        ca, sa, _, _, count_r, _, unsure_r = sp4(h0, h1, u, dot(h0, target))
        if unsure_r or count_r == 0.0:
            continue
        cb, sb, size_b, miss_b = sp1(h0, target, rotate(h1, ca, sa, u))
        if size_b <= MARGIN or miss_b > PAIR_MISS * max(1.0, size):
            continue
        c0, s0, c1, s1, c2, s2 = (math.cos(angle[0]), math.sin(angle[0]), math.cos(angle[1]), math.sin(angle[1]),
                                  math.cos(angle[2]), math.sin(angle[2]))
        for turn in range(2):  # D = R_shoulder R_ref^T, then R_shoulder R(h2, pi) R_ref^T (sum of column products)
            D[:] = 0.0
            for i in range(3):
                ref = rotate(h0, cb, -sb, rotate(h1, ca, sa, e[i]))
                base = e[i] if turn == 0 else rotate(h2, -1.0, 0.0, e[i])
                col = _turns(h0, c0, s0, h1, c1, s1, h2, c2, s2, base)
                for r in range(3):
                    for k in range(3):
                        D[r, k] += col[r] * ref[k]
            Dv = mv(D, v)
            gaps[turn] = norm(sub(Dv, v))
            w = (D[2, 1] - D[1, 2], D[0, 2] - D[2, 0], D[1, 0] - D[0, 1])
            values[turn] = atan2(0.5 * dot(v, w), 0.5 * (D[0, 0] + D[1, 1] + D[2, 2] - 1.0))
        choice = gaps[1] - (gaps[0] - 1e-9)
        if abs(choice) <= CHOICE_MARGIN:
            continue
        psi[t] = values[1] if choice < 0.0 else values[0]
        fallback[t] = False


def arm_angles_into(prepared: tuple, T: np.ndarray, Q: np.ndarray, psi: np.ndarray, fallback: np.ndarray) -> None:
    """The arm angles (rad) of the chain configurations ``Q`` (N, n) of a 7R SRS chain into ``psi`` (N,), as
    :func:`manipkit.ik.chain_ik.srs_arm_angle` (the numpy reference) computes them: the turn about the
    shoulder-wrist line taking the reference plane to the elbow's plane; ``T`` (N, 4, 4): the chain's FK of ``Q``.

    ``prepared``: the chain's constants (``ik.ideal_arm.compiled_arm``), a family solved base to tip. A
    configuration where a decision comes near its threshold (the wrist centre at the shoulder, subproblem 2
    near tangent or free, the two shoulder turns' gaps near the reference's 1e-9 choice) is marked in
    ``fallback`` (N,) with ``psi`` NaN: the reference answers it.
    """
    _arm_angles_all(prepared[0], prepared[1], T, Q, psi, fallback)
