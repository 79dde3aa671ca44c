"""The compiled loop of the static torques: gravity on a chain's lumped bodies and a payload, one pass per row.

Numbers in, numbers out (numpy and :mod:`manipkit.kernels` only, so that a change to the statics modules around it
does not recompile every kernel). The chain comes prepared as
:class:`manipkit.kinematics.jacobian.JacobianProgram` prepares it (every joint about its local z axis, constant
placements folded); per joint step ``k`` the bodies lumped after it have mass ``masses[k]`` and first moment
``moments[k] = masses[k] * c_k`` (kg m, in the program's frame after that joint, whose axes are the joint frame's
turned by ``z_to_axis``); the payload (``payload_mass``, CoG ``payload_cog`` in the tip frame) hangs after the last
placement.

Per configuration: a forward pass records each joint's origin ``o_k`` and axis ``z_k`` and the first moments in the
base frame; a backward pass adds them up from the tip, ``M_k`` (kg) and ``F_k`` (kg m) of everything after joint
``k``, and the torque holding them is ``-z_k . ((F_k - M_k o_k) x g)`` for a revolute joint and ``-M_k z_k . g``
for a prismatic one (``tau = g(q) = dV/dq``, the static convention of :mod:`manipkit.statics.torques`), added to the
step's column times its scale (a mimic joint's multiplier).
"""

from __future__ import annotations

import numpy as np

from manipkit.kernels import lazy_kernel

__all__ = ["gravity_rows", "gravity_rows_kernel"]

_REVOLUTE = 0


def gravity_rows(tan_half, values, rotations, translations, identity, kinds, rows, columns, scales, masses, moments,
                 payload_mass, payload_cog, g, tau, tau_payload):
    """Fill ``tau`` (N, n) and ``tau_payload`` (N, n) (zeros on entry) for every configuration; ``g`` (N, 3)."""
    n_steps = kinds.shape[0]
    origins = np.empty((n_steps, 3))
    axes = np.empty((n_steps, 3))
    first = np.empty((n_steps, 3))
    R = np.empty((3, 3))
    tmp = np.empty((3, 3))
    p = np.empty(3)
    tip_first = np.empty(3)
    for n in range(tau.shape[0]):
        for i in range(3):
            p[i] = 0.0
            for j in range(3):
                R[i, j] = 1.0 if i == j else 0.0
        for k in range(n_steps + 1):
            t = translations[k]
            for i in range(3):
                p[i] += R[i, 0] * t[0] + R[i, 1] * t[1] + R[i, 2] * t[2]
            if not identity[k]:
                C = rotations[k]
                for i in range(3):
                    r0, r1, r2 = R[i, 0], R[i, 1], R[i, 2]
                    for j in range(3):
                        tmp[i, j] = r0 * C[0, j] + r1 * C[1, j] + r2 * C[2, j]
                for i in range(3):
                    for j in range(3):
                        R[i, j] = tmp[i, j]
            if k == n_steps:
                c = payload_cog
                for i in range(3):
                    tip_first[i] = payload_mass * (p[i] + R[i, 0] * c[0] + R[i, 1] * c[1] + R[i, 2] * c[2])
                break
            for i in range(3):
                origins[k, i] = p[i]
                axes[k, i] = R[i, 2]
            if kinds[k] == _REVOLUTE:
                th = tan_half[rows[k], n]
                w = 2.0 / (1.0 + th * th)
                cq, sq = w - 1.0, th * w
                for i in range(3):
                    x, y = R[i, 0], R[i, 1]
                    R[i, 0] = x * cq + y * sq
                    R[i, 1] = y * cq - x * sq
            else:
                v = values[rows[k], n]
                for i in range(3):
                    p[i] += v * R[i, 2]
            m, h = masses[k], moments[k]
            for i in range(3):
                first[k, i] = m * p[i] + R[i, 0] * h[0] + R[i, 1] * h[1] + R[i, 2] * h[2]
        g0, g1, g2 = g[n, 0], g[n, 1], g[n, 2]
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
                b0, b1, b2 = (tip_first[0] - payload_mass * o0, tip_first[1] - payload_mass * o1,
                              tip_first[2] - payload_mass * o2)
                tau[n, col] -= sc * (z0 * (a1 * g2 - a2 * g1) + z1 * (a2 * g0 - a0 * g2) + z2 * (a0 * g1 - a1 * g0))
                tau_payload[n, col] -= sc * (z0 * (b1 * g2 - b2 * g1) + z1 * (b2 * g0 - b0 * g2)
                                             + z2 * (b0 * g1 - b1 * g0))
            else:
                tau[n, col] -= sc * total_m * (z0 * g0 + z1 * g1 + z2 * g2)
                tau_payload[n, col] -= sc * payload_mass * (z0 * g0 + z1 * g1 + z2 * g2)


gravity_rows_kernel = lazy_kernel(gravity_rows, error_model="numpy")
