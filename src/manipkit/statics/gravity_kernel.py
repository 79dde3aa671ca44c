"""The compiled loops of the static torques: gravity on a chain's lumped bodies and a payload, one pass per row,
and the margins against the effort limits.

Numbers in, numbers out (numpy and :mod:`manipkit.kernels` only, so that a change to the statics modules around it
does not recompile every kernel). The chain comes prepared as its program's Jacobian
(:class:`manipkit.kernels.program.JacobianProgram`, ``chain.program.jacobian``: every joint about its local z axis,
constant placements folded, joint values ``scale * q[column] + offset`` read from the chain vector); per joint step
``k`` the bodies lumped after it have mass ``masses[k]`` and first moment ``moments[k] = masses[k] * c_k`` (kg m, in
the program's frame after that joint, whose axes are the joint frame's turned by ``z_to_axis``); the payload
(``payload_mass``, CoG ``payload_cog`` in the tip frame) hangs after the last placement.

Per configuration (:func:`gravity_rows`), with no Python per row: a forward pass records each joint's origin ``o_k``
and axis ``z_k`` (base frame) and the lumps' first moments; a backward pass adds them up from the tip, ``M_k`` (kg)
and ``F_k`` (kg m) of everything after joint ``k``, and the torque holding them is ``-z_k . ((F_k - M_k o_k) x g)``
for a revolute joint and ``-M_k z_k . g`` for a prismatic one (``tau = g(q) = dV/dq``, the static convention of
:mod:`manipkit.statics.torques`), added to the step's column times its scale (a mimic joint's multiplier). The
sines and cosines are the C library's, taken in the row's pass. The loops run
without the GIL, so threads may take blocks of rows at once (:func:`static_blocks`).
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.kernels import lazy_kernel
from manipkit.kernels.blocks import run_blocks

__all__ = ["MIN_ROWS_PER_THREAD", "STATIC_BLOCK", "gravity_rows", "gravity_rows_kernel", "margin_rows",
           "margin_rows_kernel", "static_blocks"]

_REVOLUTE = 0
#: Rows per block of :func:`static_blocks` (the block's rows and answers, about 0.5 MB for 7 joints, stay in L2).
STATIC_BLOCK = 8192
#: Fewest rows per thread: a smaller batch runs on the calling thread alone (a thread's start, about 0.1 ms, is worth
#: about 1000 rows).
MIN_ROWS_PER_THREAD = 4096


def gravity_rows(Q, rotations, translations, identity, kinds, columns, scales, offsets, masses, moments,
                 payload_mass, payload_cog, g, tau, tau_payload):
    """Fill ``tau`` (N, n) and ``tau_payload`` (N, n) (overwritten) for the chain vectors ``Q`` (N, n).

    ``g`` (G, 3) is gravity in the chain base's axes (m/s^2): one row for every configuration (G = 1) or one per row.
    Each row's pose product is kept in registers (``R`` and ``p`` as scalars). Over 80 lines: the forward and the
    backward pass of one row belong together (the per-step records live between them).
    """
    n_steps = kinds.shape[0]
    n_joints = tau.shape[1]
    origins = np.empty((n_steps, 3))
    axes = np.empty((n_steps, 3))
    first = np.empty((n_steps, 3))
    c0, c1, c2 = payload_cog[0], payload_cog[1], payload_cog[2]
    for n in range(Q.shape[0]):
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
        p0, p1, p2 = 0.0, 0.0, 0.0
        for k in range(n_steps + 1):
            t0, t1, t2 = translations[k, 0], translations[k, 1], translations[k, 2]
            p0 += r00 * t0 + r01 * t1 + r02 * t2  # p <- p + R t
            p1 += r10 * t0 + r11 * t1 + r12 * t2
            p2 += r20 * t0 + r21 * t1 + r22 * t2
            if not identity[k]:  # R <- R C
                C = rotations[k]
                r00, r01, r02 = (r00 * C[0, 0] + r01 * C[1, 0] + r02 * C[2, 0],
                                 r00 * C[0, 1] + r01 * C[1, 1] + r02 * C[2, 1],
                                 r00 * C[0, 2] + r01 * C[1, 2] + r02 * C[2, 2])
                r10, r11, r12 = (r10 * C[0, 0] + r11 * C[1, 0] + r12 * C[2, 0],
                                 r10 * C[0, 1] + r11 * C[1, 1] + r12 * C[2, 1],
                                 r10 * C[0, 2] + r11 * C[1, 2] + r12 * C[2, 2])
                r20, r21, r22 = (r20 * C[0, 0] + r21 * C[1, 0] + r22 * C[2, 0],
                                 r20 * C[0, 1] + r21 * C[1, 1] + r22 * C[2, 1],
                                 r20 * C[0, 2] + r21 * C[1, 2] + r22 * C[2, 2])
            if k == n_steps:
                break
            origins[k, 0], origins[k, 1], origins[k, 2] = p0, p1, p2
            axes[k, 0], axes[k, 1], axes[k, 2] = r02, r12, r22
            v = Q[n, columns[k]] * scales[k] + offsets[k]  # the joint's value (a mimic joint's scaled)
            if kinds[k] == _REVOLUTE:  # R <- R Rz(q)
                cq, sq = math.cos(v), math.sin(v)
                r00, r01 = r00 * cq + r01 * sq, r01 * cq - r00 * sq
                r10, r11 = r10 * cq + r11 * sq, r11 * cq - r10 * sq
                r20, r21 = r20 * cq + r21 * sq, r21 * cq - r20 * sq
            else:  # p <- p + q z
                p0, p1, p2 = p0 + v * r02, p1 + v * r12, p2 + v * r22
            m, h0, h1, h2 = masses[k], moments[k, 0], moments[k, 1], moments[k, 2]
            first[k, 0] = m * p0 + r00 * h0 + r01 * h1 + r02 * h2
            first[k, 1] = m * p1 + r10 * h0 + r11 * h1 + r12 * h2
            first[k, 2] = m * p2 + r20 * h0 + r21 * h1 + r22 * h2
        e0 = payload_mass * (p0 + r00 * c0 + r01 * c1 + r02 * c2)  # the payload's first moment (kg m)
        e1 = payload_mass * (p1 + r10 * c0 + r11 * c1 + r12 * c2)
        e2 = payload_mass * (p2 + r20 * c0 + r21 * c1 + r22 * c2)
        for j in range(n_joints):
            tau[n, j] = 0.0
            tau_payload[n, j] = 0.0
        row = n if g.shape[0] > 1 else 0
        g0, g1, g2 = g[row, 0], g[row, 1], g[row, 2]
        total_m, f0, f1, f2 = 0.0, 0.0, 0.0, 0.0
        for k in range(n_steps - 1, -1, -1):
            total_m += masses[k]
            f0 += first[k, 0]
            f1 += first[k, 1]
            f2 += first[k, 2]
            z0, z1, z2 = axes[k, 0], axes[k, 1], axes[k, 2]
            col, sc = columns[k], scales[k]
            if kinds[k] == _REVOLUTE:
                o0, o1, o2 = origins[k, 0], origins[k, 1], origins[k, 2]
                a0, a1, a2 = f0 - total_m * o0, f1 - total_m * o1, f2 - total_m * o2
                b0, b1, b2 = e0 - payload_mass * o0, e1 - payload_mass * o1, e2 - payload_mass * o2
                tau[n, col] -= sc * (z0 * (a1 * g2 - a2 * g1) + z1 * (a2 * g0 - a0 * g2)
                                     + z2 * (a0 * g1 - a1 * g0))
                tau_payload[n, col] -= sc * (z0 * (b1 * g2 - b2 * g1) + z1 * (b2 * g0 - b0 * g2)
                                             + z2 * (b0 * g1 - b1 * g0))
            else:
                tau[n, col] -= sc * total_m * (z0 * g0 + z1 * g1 + z2 * g2)
                tau_payload[n, col] -= sc * payload_mass * (z0 * g0 + z1 * g1 + z2 * g2)


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


# nogil: static_blocks runs them on blocks of rows from several threads at once (each block its own rows)
gravity_rows_kernel = lazy_kernel(gravity_rows, error_model="numpy", nogil=True)
margin_rows_kernel = lazy_kernel(margin_rows, error_model="numpy", nogil=True)


def static_blocks(work, n_rows: int, threads: int) -> None:
    """``work(start, stop)`` on the blocks of :data:`STATIC_BLOCK` rows covering ``0 .. n_rows``, on up to ``threads``
    threads (one when there are fewer than :data:`MIN_ROWS_PER_THREAD` rows per thread): :func:`run_blocks`."""
    run_blocks(work, n_rows, block=STATIC_BLOCK, min_rows_per_thread=MIN_ROWS_PER_THREAD, threads=threads,
               name="static_torques")
