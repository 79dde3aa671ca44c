"""The compiled loops of the static torques: gravity on a chain's lumped bodies and a payload, 64 rows at a time,
and the margins against the effort limits.

Numbers in, numbers out (numpy and :mod:`manipkit.kernels` only, so that a change to the statics modules around it
does not recompile every kernel). The chain comes prepared as its program's Jacobian
(:class:`manipkit.kernels.program.JacobianProgram`, ``chain.program.jacobian``: every joint about its local z axis,
constant placements folded, joint values ``scale * q[column] + offset`` read from the chain vector); per joint step
``k`` the bodies lumped after it have mass ``masses[k]`` and first moment ``moments[k] = masses[k] * c_k`` (kg m, in
the program's frame after that joint, whose axes are the joint frame's turned by ``z_to_axis``); the payload
(``payload_mass``, CoG ``payload_cog`` in the tip frame) hangs after the last placement.

For :data:`LANES` configurations at a time (:func:`gravity_rows`, structure of arrays, each step a loop across
the configurations), with no Python per row, the recursion of the composite body in each joint's own frame: a
forward pass turns gravity into every joint frame, ``g_k = Rz(q_k)^T C_k^T g_(k-1)`` (``C_k`` the constant placement
before joint ``k``); a backward pass carries from the tip the mass ``M_k`` (kg) of everything after joint ``k``, its
first moment ``F_k`` (kg m) about joint ``k``'s origin and the payload's CoG ``r_k`` (m), both in joint ``k``'s axes
(``F_(k-1) = h_(k-1) + M_k t_k + C_k Rz(q_k) F_k``, ``r_(k-1) = t_k + C_k Rz(q_k) r_k``), and the torque holding them
is ``-(F_k x g_k)_z`` for a revolute joint and ``-M_k (g_k)_z`` for a prismatic one (``tau = g(q) = dV/dq``, the
static convention of :mod:`manipkit.statics.torques`), the payload's ``-m (r_k x g_k)_z`` and ``-m (g_k)_z``, added to
the step's column times its scale (a mimic joint's multiplier). Only 3-vectors are turned (no pose product). The
margins against the effort limits are :func:`margin_rows`, also in lanes. The sines and cosines come from one numpy
``tan(q/2)`` per block (:func:`joint_tan_half`), turned into them in the loop. The loops run without the GIL, so
threads may take blocks of rows at once (:func:`static_blocks`).
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.kernels import lazy_kernel
from manipkit.kernels.blocks import run_blocks

__all__ = ["LANES", "MIN_ROWS_PER_THREAD", "STATIC_BLOCK", "capacity_rows", "capacity_rows_kernel", "gravity_rows",
           "gravity_rows_kernel", "joint_tan_half", "margin_rows", "margin_rows_kernel", "static_blocks"]

_REVOLUTE = 0
#: Rows taken together by :func:`gravity_rows` (structure of arrays: the per-step records, about 25 kB for 7 joints,
#: stay in L1; 64 measured faster than 128 or 256).
LANES = 64
#: Rows per block of :func:`static_blocks` (the block's rows and answers, about 2 MB for 7 joints, stay in L2).
STATIC_BLOCK = 8192
#: Fewest rows per thread: a smaller batch runs on the calling thread alone (a thread's start, about 0.1 ms, is worth
#: about 1000 rows).
MIN_ROWS_PER_THREAD = 4096


def gravity_rows(Q, tan_half, rotations, translations, identity, kinds, columns, scales, offsets, masses,
                 moments, payload_mass, payload_cog, g, tau_w, tau_g, tau_p, tau):
    """Fill ``tau_g`` (N, n), ``tau_p`` (N, n) and ``tau = tau_g + tau_p (+ tau_w)`` (overwritten) for the chain
    vectors ``Q`` (N, n).

    ``tan_half`` (n_steps, N) is ``tan(v / 2)`` of each step's joint value ``v`` (:func:`joint_tan_half`; read for
    revolute steps only), turned into its cosine and sine here: ``cos = 2 / (1 + t^2) - 1``, ``sin = 2 t / (1 + t^2)``
    (the FK kernel's rule; a few ulp from ``cos``/``sin``). ``g`` (G, 3) is gravity in the chain base's axes
    (m/s^2): one row for every configuration (G = 1) or one per row. ``tau_w`` (N, n) is the wrenches' part added to
    ``tau``, or (0, n) for none. Structure of arrays: :data:`LANES` rows at a time, every step a loop across those rows. Over 80 lines: the forward and the
    backward pass belong together (the per-step records live between them).
    """
    n_steps = kinds.shape[0]
    n_joints = tau.shape[1]
    down = np.empty((n_steps, 3, LANES))  # gravity in each joint's frame
    cos_k, sin_k = np.empty((n_steps, LANES)), np.empty((n_steps, LANES))  # a prismatic step's value in cos_k
    G, F, r = np.empty((3, LANES)), np.empty((3, LANES)), np.empty((3, LANES))
    acc_g, acc_p = np.empty((n_joints, LANES)), np.empty((n_joints, LANES))
    last = n_steps - 1
    C = rotations[n_steps]  # the payload's CoG in the last joint's frame: r = t_tip + C_tip c
    r_tip = np.empty(3)
    for i in range(3):
        r_tip[i] = translations[n_steps, i] + (C[i, 0] * payload_cog[0] + C[i, 1] * payload_cog[1]
                                               + C[i, 2] * payload_cog[2])
    one_g = g.shape[0] == 1
    with_w = tau_w.shape[0] > 0
    for start in range(0, Q.shape[0], LANES):
        nb = min(LANES, Q.shape[0] - start)
        for i in range(3):
            for b in range(nb):
                G[i, b] = g[0, i] if one_g else g[start + b, i]
        for k in range(n_steps):  # forward: G <- Rz(q_k)^T C_k^T G, gravity in joint k's frame
            if not identity[k]:
                C = rotations[k]
                for b in range(nb):
                    x, y, z = G[0, b], G[1, b], G[2, b]
                    G[0, b] = C[0, 0] * x + C[1, 0] * y + C[2, 0] * z
                    G[1, b] = C[0, 1] * x + C[1, 1] * y + C[2, 1] * z
                    G[2, b] = C[0, 2] * x + C[1, 2] * y + C[2, 2] * z
            if kinds[k] == _REVOLUTE:
                for b in range(nb):
                    t = tan_half[k, start + b]
                    w = 2.0 / (1.0 + t * t)
                    cq, sq = w - 1.0, t * w
                    cos_k[k, b], sin_k[k, b] = cq, sq
                    x, y = G[0, b], G[1, b]
                    G[0, b], G[1, b] = cq * x + sq * y, cq * y - sq * x
            else:  # a translation: gravity's axes stay
                col, sc, off = columns[k], scales[k], offsets[k]
                for b in range(nb):
                    cos_k[k, b] = Q[start + b, col] * sc + off
            for i in range(3):
                for b in range(nb):
                    down[k, i, b] = G[i, b]
        for i in range(3):
            for b in range(nb):
                F[i, b] = moments[last, i]
                r[i, b] = r_tip[i]
        for j in range(n_joints):
            for b in range(nb):
                acc_g[j, b] = 0.0
                acc_p[j, b] = 0.0
        M = masses[last]
        for k in range(last, -1, -1):  # backward: F, r in joint k's frame, M the mass after joint k
            col, sc = columns[k], scales[k]
            if kinds[k] == _REVOLUTE:
                for b in range(nb):
                    gx, gy = down[k, 0, b], down[k, 1, b]
                    acc_g[col, b] -= sc * (F[0, b] * gy - F[1, b] * gx)
                    acc_p[col, b] -= sc * payload_mass * (r[0, b] * gy - r[1, b] * gx)
            else:
                for b in range(nb):
                    gz = down[k, 2, b]
                    acc_g[col, b] -= sc * M * gz
                    acc_p[col, b] -= sc * payload_mass * gz
            if k == 0:
                break
            if kinds[k] == _REVOLUTE:  # into joint k's placement frame: v <- Rz(q_k) v
                for b in range(nb):
                    cq, sq = cos_k[k, b], sin_k[k, b]
                    x, y = F[0, b], F[1, b]
                    F[0, b], F[1, b] = cq * x - sq * y, sq * x + cq * y
                    x, y = r[0, b], r[1, b]
                    r[0, b], r[1, b] = cq * x - sq * y, sq * x + cq * y
            else:  # v <- v + value z (the first moment: M value z)
                for b in range(nb):
                    F[2, b] += M * cos_k[k, b]
                    r[2, b] += cos_k[k, b]
            if not identity[k]:  # then into joint k-1's frame: v <- C_k v + t_k
                C = rotations[k]
                for b in range(nb):
                    x, y, z = F[0, b], F[1, b], F[2, b]
                    F[0, b] = C[0, 0] * x + C[0, 1] * y + C[0, 2] * z
                    F[1, b] = C[1, 0] * x + C[1, 1] * y + C[1, 2] * z
                    F[2, b] = C[2, 0] * x + C[2, 1] * y + C[2, 2] * z
                    x, y, z = r[0, b], r[1, b], r[2, b]
                    r[0, b] = C[0, 0] * x + C[0, 1] * y + C[0, 2] * z
                    r[1, b] = C[1, 0] * x + C[1, 1] * y + C[1, 2] * z
                    r[2, b] = C[2, 0] * x + C[2, 1] * y + C[2, 2] * z
            for i in range(3):  # F_(k-1) = h_(k-1) + M_k t_k + (turned F_k)
                t, h = translations[k, i], moments[k - 1, i]
                for b in range(nb):
                    F[i, b] += M * t + h
                    r[i, b] += t
            M += masses[k - 1]
        for b in range(nb):
            for j in range(n_joints):
                a, p = acc_g[j, b], acc_p[j, b]
                tau_g[start + b, j] = a
                tau_p[start + b, j] = p
                tau[start + b, j] = a + p + tau_w[start + b, j] if with_w else a + p


def joint_tan_half(Q, columns, scales, offsets) -> np.ndarray:
    """``tan(v / 2)`` (n_steps, N) of every step's joint value ``v = scale * Q[:, column] + offset``, one row per step
    (the lanes' layout): one numpy ``tan`` on the whole block (the FK kernel's rule, ``v / 2`` as ``q (scale / 2) +
    offset / 2``, the same bits), the half-angle tangent :func:`gravity_rows` takes."""
    in_order = columns.shape[0] == Q.shape[1] and bool(np.all(columns == np.arange(Q.shape[1])))
    out = np.multiply((Q if in_order else Q[:, columns]).T, (0.5 * scales)[:, None])  # a chain's own vectors: no copy
    if np.any(offsets):
        out += (0.5 * offsets)[:, None]
    return np.tan(out, out=out)


def margin_rows(tau, limits, margin, saturating):
    """``margin = 100 (1 - |tau| / limits)`` (N, n) percent (NaN where the limit is NaN) and ``saturating`` (N,): the
    first joint of least margin among those with a finite limit, -1 when none has one (the rule of
    :func:`manipkit.statics.torques.margins`), written; :data:`LANES` rows at a time turned into lanes, so that each
    joint's division and comparison run across the rows."""
    n_joints = tau.shape[1]
    lanes, best = np.empty((n_joints, LANES)), np.empty(LANES)
    for start in range(0, tau.shape[0], LANES):
        nb = min(LANES, tau.shape[0] - start)
        for b in range(nb):
            best[b] = np.inf
            saturating[start + b] = -1
            for k in range(n_joints):
                lanes[k, b] = tau[start + b, k]
        for k in range(n_joints):
            limit = limits[k]
            limited = math.isfinite(limit)
            for b in range(nb):
                value = 100.0 * (1.0 - abs(lanes[k, b]) / limit)  # NaN for a NaN limit
                lanes[k, b] = value
                if limited and (saturating[start + b] < 0 or value < best[b]):
                    best[b] = value
                    saturating[start + b] = k
        for b in range(nb):
            for k in range(n_joints):
                margin[start + b, k] = lanes[k, b]


def capacity_rows(unloaded, per_kg, lower, upper, lever_tol, max_mass, saturating, over):
    """The payload capacity of each row of ``tau(m) = unloaded + m per_kg`` (N, n) against ``lower``, ``upper`` (n,)
    (NaN: no limit): ``max_mass`` (N,) kg, ``saturating`` (N,) (-1: none) and ``over`` (N,) (the torque without a
    payload already outside a limit), written; the rule of :func:`manipkit.statics.capacity.capacity_from_parts`,
    one pass per row with numpy's answers to the bit (``min``/``argmin`` take the first NaN, ``maximum(m, 0)``).
    """
    n_joints = unloaded.shape[1]
    for r in range(unloaded.shape[0]):
        best, best_k, first_over = np.inf, 0, -1
        for k in range(n_joints):
            a, b, lo, up = unloaded[r, k], per_kg[r, k], lower[k], upper[k]
            limited = not (math.isnan(lo) or math.isnan(up))
            if limited and (a > up or a < lo):
                bound = 0.0
                if first_over < 0:
                    first_over = k
            elif limited and abs(b) > lever_tol:
                bound = (up - a) / b if b > 0 else (lo - a) / b
            else:
                bound = np.inf
            if math.isnan(bound):
                if not math.isnan(best):
                    best, best_k = bound, k
            elif bound < best:
                best, best_k = bound, k
        over[r] = first_over >= 0
        k_sat = first_over if first_over >= 0 else best_k
        saturating[r] = -1 if math.isinf(best) else k_sat
        max_mass[r] = best if best > 0.0 or math.isnan(best) else 0.0


# nogil: static_blocks runs them on blocks of rows from several threads at once (each block its own rows)
gravity_rows_kernel = lazy_kernel(gravity_rows, error_model="numpy", nogil=True)
margin_rows_kernel = lazy_kernel(margin_rows, error_model="numpy", nogil=True)
capacity_rows_kernel = lazy_kernel(capacity_rows, error_model="numpy", nogil=True)


def static_blocks(work, n_rows: int, threads: int) -> None:
    """``work(start, stop)`` on the blocks of :data:`STATIC_BLOCK` rows covering ``0 .. n_rows``, on up to ``threads``
    threads (one when there are fewer than :data:`MIN_ROWS_PER_THREAD` rows per thread): :func:`run_blocks`."""
    run_blocks(work, n_rows, block=STATIC_BLOCK, min_rows_per_thread=MIN_ROWS_PER_THREAD, threads=threads,
               name="static_torques")
