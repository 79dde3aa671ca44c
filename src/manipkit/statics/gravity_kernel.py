"""The compiled loops of the static torques: gravity on a chain's lumped bodies and a payload, 256 rows at a time,
and the margins against the effort limits.

Numbers in, numbers out (numpy and :mod:`manipkit.kernels` only, so that a change to the statics modules around it
does not recompile every kernel). The chain comes prepared as its program's Jacobian
(:class:`manipkit.kernels.program.JacobianProgram`, ``chain.program.jacobian``: every joint about its local z axis,
constant placements folded, joint values ``scale * q[column] + offset`` read from the chain vector); per joint step
``k`` the bodies lumped after it have mass ``masses[k]`` and first moment ``moments[k] = masses[k] * c_k`` (kg m, in
the program's frame after that joint, whose axes are the joint frame's turned by ``z_to_axis``); the payload
(``payload_mass``, CoG ``payload_cog`` in the tip frame) hangs after the last placement.

For :data:`LANES` configurations at a time (:func:`gravity_rows`, structure of arrays, each step a loop across
the configurations), with no Python per row: a forward pass records each joint's origin ``o_k``
and axis ``z_k`` (base frame) and the lumps' first moments; a backward pass adds them up from the tip, ``M_k`` (kg)
and ``F_k`` (kg m) of everything after joint ``k``, and the torque holding them is ``-z_k . ((F_k - M_k o_k) x g)``
for a revolute joint and ``-M_k z_k . g`` for a prismatic one (``tau = g(q) = dV/dq``, the static convention of
:mod:`manipkit.statics.torques`), added to the step's column times its scale (a mimic joint's multiplier). The
sines and cosines come from one numpy ``tan(q/2)`` per block (:func:`joint_tan_half`), turned into them in the loop. The loops run
without the GIL, so threads may take blocks of rows at once (:func:`static_blocks`).
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.kernels import lazy_kernel
from manipkit.kernels.blocks import run_blocks

__all__ = ["LANES", "MIN_ROWS_PER_THREAD", "STATIC_BLOCK", "capacity_rows", "capacity_rows_kernel", "gravity_rows",
           "gravity_rows_kernel", "joint_tan_half", "margin_rows", "margin_rows_kernel", "static_blocks"]

_REVOLUTE = 0
#: Rows taken together by :func:`gravity_rows` (structure of arrays: the per-step records, about 170 kB for 7 joints).
LANES = 256
#: Rows per block of :func:`static_blocks` (the block's rows and answers, about 0.5 MB for 7 joints, stay in L2).
STATIC_BLOCK = 8192
#: Fewest rows per thread: a smaller batch runs on the calling thread alone (a thread's start, about 0.1 ms, is worth
#: about 1000 rows).
MIN_ROWS_PER_THREAD = 4096


def gravity_rows(Q, tan_half, rotations, translations, identity, kinds, columns, scales, offsets, masses,
                 moments, payload_mass, payload_cog, g, tau, tau_payload):
    """Fill ``tau`` (N, n) and ``tau_payload`` (N, n) (overwritten) for the chain vectors ``Q`` (N, n).

    ``tan_half`` (N, n_steps) is ``tan(v / 2)`` of each step's joint value ``v`` (:func:`joint_tan_half`; read for
    revolute steps only), turned into its cosine and sine here: ``cos = 2 / (1 + t^2) - 1``, ``sin = 2 t / (1 + t^2)``
    (the FK kernel's rule; a few ulp from ``cos``/``sin``). ``g`` (G, 3) is gravity in the chain base's axes
    (m/s^2): one row for every configuration (G = 1) or one per row. Structure of arrays: :data:`LANES` rows at a time, every step a loop
    across those rows (the pose product ``R`` (9, LANES) and ``p`` (3, LANES) stay in L1). Over 80 lines: the forward
    and the backward pass belong together (the per-step records live between them).
    """
    n_steps = kinds.shape[0]
    n_joints = tau.shape[1]
    R, P = np.empty((9, LANES)), np.empty((3, LANES))
    cos_b, sin_b = np.empty(LANES), np.empty(LANES)
    origins, axes, first = np.empty((n_steps, 3, LANES)), np.empty((n_steps, 3, LANES)), np.empty((n_steps, 3, LANES))
    c0, c1, c2 = payload_cog[0], payload_cog[1], payload_cog[2]
    for start in range(0, Q.shape[0], LANES):
        nb = min(LANES, Q.shape[0] - start)
        for b in range(nb):
            for i in range(9):
                R[i, b] = 1.0 if i % 4 == 0 else 0.0
            P[0, b], P[1, b], P[2, b] = 0.0, 0.0, 0.0
        for k in range(n_steps + 1):
            t0, t1, t2 = translations[k, 0], translations[k, 1], translations[k, 2]
            for i in range(3):  # p <- p + R t
                for b in range(nb):
                    P[i, b] += R[3 * i, b] * t0 + R[3 * i + 1, b] * t1 + R[3 * i + 2, b] * t2
            if not identity[k]:  # R <- R C
                C = rotations[k]
                for i in range(3):
                    for b in range(nb):
                        x, y, z = R[3 * i, b], R[3 * i + 1, b], R[3 * i + 2, b]
                        R[3 * i, b] = x * C[0, 0] + y * C[1, 0] + z * C[2, 0]
                        R[3 * i + 1, b] = x * C[0, 1] + y * C[1, 1] + z * C[2, 1]
                        R[3 * i + 2, b] = x * C[0, 2] + y * C[1, 2] + z * C[2, 2]
            if k == n_steps:
                break
            for i in range(3):
                for b in range(nb):
                    origins[k, i, b] = P[i, b]
                    axes[k, i, b] = R[3 * i + 2, b]
            if kinds[k] == _REVOLUTE:  # R <- R Rz(q)
                for b in range(nb):
                    t = tan_half[start + b, k]
                    w = 2.0 / (1.0 + t * t)
                    cos_b[b], sin_b[b] = w - 1.0, t * w
                for i in range(3):
                    for b in range(nb):
                        cq, sq = cos_b[b], sin_b[b]
                        x, y = R[3 * i, b], R[3 * i + 1, b]
                        R[3 * i, b], R[3 * i + 1, b] = x * cq + y * sq, y * cq - x * sq
            else:  # p <- p + q z (a mimic joint's value scaled)
                col, sc, off = columns[k], scales[k], offsets[k]
                for i in range(3):
                    for b in range(nb):
                        P[i, b] += (Q[start + b, col] * sc + off) * R[3 * i + 2, b]
            m, h0, h1, h2 = masses[k], moments[k, 0], moments[k, 1], moments[k, 2]
            for i in range(3):
                for b in range(nb):
                    first[k, i, b] = m * P[i, b] + R[3 * i, b] * h0 + R[3 * i + 1, b] * h1 + R[3 * i + 2, b] * h2
        for i in range(3):  # P <- the payload's first moment (kg m)
            for b in range(nb):
                P[i, b] = payload_mass * (P[i, b] + R[3 * i, b] * c0 + R[3 * i + 1, b] * c1 + R[3 * i + 2, b] * c2)
        for b in range(nb):
            for j in range(n_joints):
                tau[start + b, j] = 0.0
                tau_payload[start + b, j] = 0.0
        total_m = 0.0
        for k in range(n_steps - 1, -1, -1):
            total_m += masses[k]
            if k < n_steps - 1:  # F_k: the first moments of everything after joint k
                for i in range(3):
                    for b in range(nb):
                        first[k, i, b] += first[k + 1, i, b]
            col, sc = columns[k], scales[k]
            for b in range(nb):
                row = start + b if g.shape[0] > 1 else 0
                g0, g1, g2 = g[row, 0], g[row, 1], g[row, 2]
                z0, z1, z2 = axes[k, 0, b], axes[k, 1, b], axes[k, 2, b]
                if kinds[k] == _REVOLUTE:
                    o0, o1, o2 = origins[k, 0, b], origins[k, 1, b], origins[k, 2, b]
                    a0, a1, a2 = first[k, 0, b] - total_m * o0, first[k, 1, b] - total_m * o1, first[k, 2, b] - total_m * o2
                    e0, e1, e2 = P[0, b] - payload_mass * o0, P[1, b] - payload_mass * o1, P[2, b] - payload_mass * o2
                    tau[start + b, col] -= sc * (z0 * (a1 * g2 - a2 * g1) + z1 * (a2 * g0 - a0 * g2)
                                                 + z2 * (a0 * g1 - a1 * g0))
                    tau_payload[start + b, col] -= sc * (z0 * (e1 * g2 - e2 * g1) + z1 * (e2 * g0 - e0 * g2)
                                                         + z2 * (e0 * g1 - e1 * g0))
                else:
                    zg = z0 * g0 + z1 * g1 + z2 * g2
                    tau[start + b, col] -= sc * total_m * zg
                    tau_payload[start + b, col] -= sc * payload_mass * zg


def joint_tan_half(Q, columns, scales, offsets) -> np.ndarray:
    """``tan(v / 2)`` (N, n_steps) of every step's joint value ``v = scale * Q[:, column] + offset``: one numpy
    ``tan`` on the whole block (the FK kernel's rule), the half-angle tangent :func:`gravity_rows` takes."""
    return np.tan(0.5 * (Q[:, columns] * scales + offsets))


def margin_rows(tau, limits, margin, saturating):
    """``margin = 100 (1 - |tau| / limits)`` (N, n) percent (NaN where the limit is NaN) and ``saturating`` (N,): the
    first joint of least margin among those with a finite limit, -1 when none has one (the rule of
    :func:`manipkit.statics.torques.margins`)."""
    n_joints = tau.shape[1]
    for n in range(tau.shape[0]):
        best, best_k = np.inf, -1
        for k in range(n_joints):
            limit = limits[k]
            value = 100.0 * (1.0 - abs(tau[n, k]) / limit)  # NaN for a NaN limit
            margin[n, k] = value
            if math.isfinite(limit) and (best_k < 0 or value < best):
                best, best_k = value, k
        saturating[n] = best_k


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
