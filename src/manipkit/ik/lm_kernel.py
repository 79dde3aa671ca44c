"""The Levenberg-Marquardt iteration of :mod:`manipkit.ik.numerical`, compiled with numba for one serial chain.

Why compiled: an IK solve takes 10-20 iterations, and each needs the chain's
pose, its Jacobian, a 6 x n product and an n x n solve. The arithmetic is
about 2 microseconds; driving it from Python (one Pinocchio call and a dozen
small numpy calls per iteration) costs 25-30. Here the whole attempt, from
a start to convergence, runs as one machine-code loop.

Conventions:

- The chain is the steps of a :class:`manipkit.kinematics.chain.Chain`, base
  to tip, packed by :func:`manipkit.kernels.program.pack_chain` (the chain's
  program: ``chain.program.ik_tables``):
  row ``k`` of ``geometry`` is the placement of joint ``k`` in its parent
  joint's frame (``R`` row-major, 9 numbers; ``t``, 3 numbers, metres) and
  the joint's unit axis in its own frame (3 numbers); the last row is the tip
  frame's placement in the last joint's frame (axis unused).
- ``kinds[k] = (kind, column)``: kind 0 revolute, 1 prismatic, -1 the tip;
  column is the joint's position in the solved vector ``x``, or -1 for a
  joint not solved for (a floating coordinate not freed), which keeps the
  value ``q_fixed[k]`` during a solve.
- Poses and Jacobians are expressed in the axes of the chain's base. The
  Jacobian is the ``LOCAL_WORLD_ALIGNED`` frame Jacobian of Pinocchio (linear
  rows: velocity of the tip's origin; angular rows: angular velocity), so
  column ``j`` of a revolute joint with axis ``z_j`` through ``o_j`` is
  ``(z_j x (p - o_j), z_j)``, of a prismatic joint ``(z_j, 0)``.
- The error of mode ``"pose"`` is ``(p_target - p, log3(R_target R^T))``;
  the algorithm, the limits, the stall test and the damping rule are those
  documented in :class:`manipkit.ik.numerical.IKSolver`.

Each piece (``chain_pose_jacobian``, ``log3``, ``solve_linear``) is a plain
function, tested on its own against Pinocchio and numpy. Each is compiled by
:func:`manipkit.kernels.compile.compile_kernel` on first use: cached on disk
by numba where that works, else compiled in memory with one warning.
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.kernels.compile import compile_kernel
from manipkit.kernels.fk import ChainStep
from manipkit.kernels.program import pack_chain

__all__ = [
    "MODE_CODES", "SHRINK_MIN", "STALL_GAIN", "STALL_WINDOW", "chain_pose_jacobian", "error_and_jacobian",
    "lm_attempt", "log3", "solve_linear", "warm_up",
]

MODE_CODES = {"pose": 0, "position": 1, "position+axis": 2}
#: The stall rule of an attempt (IKSolver's docstring): stop when the cost fell by less than 1 - STALL_GAIN over
#: the last STALL_WINDOW iterations; the damping shrinks by at most SHRINK_MIN per accepted step.
STALL_WINDOW, STALL_GAIN, SHRINK_MIN = 8, 0.9, 0.1
_REVOLUTE, _PRISMATIC, _TIP = 0, 1, -1  # the kinds of manipkit.kernels.program.pack_chain
_TWO_PI = 2.0 * math.pi


@compile_kernel
def chain_pose_jacobian(x, q_fixed, geometry, kinds, R, p, J):
    """Pose of the tip in the base (``R`` 3x3, ``p`` 3) and its Jacobian ``J`` (6 x n) at ``x``, in place.

    ``x`` holds the solved joints (by column), ``q_fixed`` the values of the
    joints above the base (by step). A step's joint value is
    ``scale * x[column] + offset``, and its column of ``J`` gets ``scale``
    times the step's motion (mimic joints add to their leader's column). Each joint: ``T <- T X_k``, record the
    joint's origin ``o = p`` and world axis ``z = R a``, then ``T <- T M(q)``
    with ``M`` Rodrigues' rotation ``I + sin q [a]x + (1 - cos q) [a]x^2`` or
    the translation ``q a``. Columns are filled once the tip is known.
    """
    _chain_pose_jacobian(x, q_fixed, geometry, kinds, R, p, J, np.empty((geometry.shape[0], 6)))


@compile_kernel
def _chain_pose_jacobian(x, q_fixed, geometry, kinds, R, p, J, frames):
    """:func:`chain_pose_jacobian` with its work array passed in (the loop of :func:`lm_attempt` allocates nothing).

    ``frames`` (S+1, 6) receives each joint's origin (columns 0-2) and world
    axis (columns 3-5). ``R`` is multiplied in place row by row: row ``i`` of
    ``R X`` needs row ``i`` of ``R`` only.
    """
    n_steps = geometry.shape[0]
    for i in range(3):
        for j in range(3):
            R[i, j] = 1.0 if i == j else 0.0
        p[i] = 0.0
    for k in range(n_steps):
        g = geometry[k]
        # T <- T X_k
        for i in range(3):
            p[i] += R[i, 0] * g[9] + R[i, 1] * g[10] + R[i, 2] * g[11]
        for i in range(3):
            r0, r1, r2 = R[i, 0], R[i, 1], R[i, 2]
            R[i, 0] = r0 * g[0] + r1 * g[3] + r2 * g[6]
            R[i, 1] = r0 * g[1] + r1 * g[4] + r2 * g[7]
            R[i, 2] = r0 * g[2] + r1 * g[5] + r2 * g[8]
        kind = kinds[k, 0]
        if kind == _TIP:
            continue
        column = kinds[k, 1]
        q = g[15] * x[column] + g[16] if column >= 0 else q_fixed[k]
        a0, a1, a2 = g[12], g[13], g[14]
        for i in range(3):
            frames[k, i] = p[i]
            frames[k, 3 + i] = R[i, 0] * a0 + R[i, 1] * a1 + R[i, 2] * a2
        if kind == _PRISMATIC:
            for i in range(3):
                p[i] += frames[k, 3 + i] * q
            continue
        s, c = math.sin(q), math.cos(q)
        v = 1.0 - c
        # Rodrigues: M = c I + s [a]x + v a a^T
        m00, m01, m02 = c + v * a0 * a0, v * a0 * a1 - s * a2, v * a0 * a2 + s * a1
        m10, m11, m12 = v * a1 * a0 + s * a2, c + v * a1 * a1, v * a1 * a2 - s * a0
        m20, m21, m22 = v * a2 * a0 - s * a1, v * a2 * a1 + s * a0, c + v * a2 * a2
        for i in range(3):
            r0, r1, r2 = R[i, 0], R[i, 1], R[i, 2]
            R[i, 0] = r0 * m00 + r1 * m10 + r2 * m20
            R[i, 1] = r0 * m01 + r1 * m11 + r2 * m21
            R[i, 2] = r0 * m02 + r1 * m12 + r2 * m22
    for j in range(J.shape[1]):
        for i in range(6):
            J[i, j] = 0.0
    for k in range(n_steps):
        column = kinds[k, 1]
        if kinds[k, 0] == _TIP or column < 0:
            continue
        scale = geometry[k, 15]
        z0, z1, z2 = frames[k, 3] * scale, frames[k, 4] * scale, frames[k, 5] * scale
        if kinds[k, 0] == _PRISMATIC:
            J[0, column] += z0
            J[1, column] += z1
            J[2, column] += z2
        else:
            d0, d1, d2 = p[0] - frames[k, 0], p[1] - frames[k, 1], p[2] - frames[k, 2]
            J[0, column] += z1 * d2 - z2 * d1
            J[1, column] += z2 * d0 - z0 * d2
            J[2, column] += z0 * d1 - z1 * d0
            J[3, column] += z0
            J[4, column] += z1
            J[5, column] += z2


@compile_kernel
def log3(R, w):
    """Rotation vector ``w`` (rad, angle in [0, pi]) of the rotation matrix ``R``, in place; returns the angle.

    ``v = vee(R - R^T) / 2 = sin(theta) u`` and ``cos(theta) = (trace R - 1) / 2``
    give ``theta = atan2(|v|, cos)`` and ``w = theta / |v| * v``, accurate
    except near ``theta = pi`` where ``|v|`` vanishes; there the axis comes
    from the symmetric part ``(R + R^T) / 2 = cos I + (1 - cos) u u^T``
    (largest diagonal entry first), its sign from ``v``.
    """
    theta, w[0], w[1], w[2] = _log3(R[0, 0], R[0, 1], R[0, 2], R[1, 0], R[1, 1], R[1, 2], R[2, 0], R[2, 1], R[2, 2])
    return theta


@compile_kernel
def _log3(r00, r01, r02, r10, r11, r12, r20, r21, r22):
    """:func:`log3` of the matrix given by its entries ``r_ij``: (theta, w0, w1, w2), no array allocated."""
    c = 0.5 * (r00 + r11 + r22 - 1.0)
    v0 = 0.5 * (r21 - r12)
    v1 = 0.5 * (r02 - r20)
    v2 = 0.5 * (r10 - r01)
    s = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    theta = math.atan2(s, c)
    if c > -0.9:  # theta below about 154 degrees: v is well conditioned
        k = theta / s if s > 1e-8 else 1.0 + s * s / 6.0  # theta / sin(theta) ~ 1 + theta^2 / 6
        return theta, k * v0, k * v1, k * v2
    one_minus_c = 1.0 - c
    # the axis u from the column of (R + R^T) / 2 with the largest diagonal entry r_ii
    if r11 > r00 and r11 >= r22:
        u1 = math.sqrt(max((r11 - c) / one_minus_c, 0.0))
        u0 = 0.5 * (r10 + r01) / (one_minus_c * u1)
        u2 = 0.5 * (r12 + r21) / (one_minus_c * u1)
    elif r22 > r00 and r22 > r11:
        u2 = math.sqrt(max((r22 - c) / one_minus_c, 0.0))
        u0 = 0.5 * (r20 + r02) / (one_minus_c * u2)
        u1 = 0.5 * (r21 + r12) / (one_minus_c * u2)
    else:
        u0 = math.sqrt(max((r00 - c) / one_minus_c, 0.0))
        u1 = 0.5 * (r01 + r10) / (one_minus_c * u0)
        u2 = 0.5 * (r02 + r20) / (one_minus_c * u0)
    norm = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    if u0 * v0 + u1 * v1 + u2 * v2 < 0.0:
        norm = -norm
    return theta, theta * u0 / norm, theta * u1 / norm, theta * u2 / norm


@compile_kernel
def solve_linear(M, b, out):
    """``out = M^-1 b`` by Gaussian elimination with partial pivoting (``M`` n x n, modified in place).

    Returns False when a pivot is zero or not finite (a singular or NaN
    system); the damped normal equations of the caller are regular.
    """
    n = b.shape[0]
    for i in range(n):
        out[i] = b[i]
    for col in range(n):
        pivot = col
        for row in range(col + 1, n):
            if abs(M[row, col]) > abs(M[pivot, col]):
                pivot = row
        if not (abs(M[pivot, col]) > 0.0) or not math.isfinite(M[pivot, col]):
            return False
        if pivot != col:
            for j in range(n):
                M[col, j], M[pivot, j] = M[pivot, j], M[col, j]
            out[col], out[pivot] = out[pivot], out[col]
        inv = 1.0 / M[col, col]
        for row in range(col + 1, n):
            f = M[row, col] * inv
            if f != 0.0:
                for j in range(col, n):
                    M[row, j] -= f * M[col, j]
                out[row] -= f * out[col]
    for row in range(n - 1, -1, -1):
        acc = out[row]
        for j in range(row + 1, n):
            acc -= M[row, j] * out[j]
        out[row] = acc / M[row, row]
    return True


@compile_kernel
def _wrap(angle):
    """An angle in (-pi, pi] (the caller applies ``rotations.wrap_angle`` to the final answer)."""
    wrapped = angle - _TWO_PI * math.floor((angle + math.pi) / _TWO_PI)
    return math.pi if wrapped <= -math.pi else wrapped


@compile_kernel
def error_and_jacobian(x, q_fixed, geometry, kinds, R_target, p_target, mode, axis_index, R, p, J, e):
    """Fill the error ``e`` (6) and Jacobian ``J`` (6 x n) at ``x``; returns the (pos, rot) residuals.

    Mode 1 uses the first 3 rows only. At the target ``de/dx = -J`` (tested).

    Mode 0 pose: ``e = (p_t - p, log3(R_t R^T))``. Mode 1 position: ``e = p_t - p``.
    Mode 2 position+axis: rotation error ``angle * unit(a x t)`` (``a``, ``t``
    the frame's and the target's pointing axes) and rows ``(I - a a^T) J_w``.
    """
    return _error_and_jacobian(x, q_fixed, geometry, kinds, R_target, p_target, mode, axis_index, R, p, J, e,
                               np.empty((geometry.shape[0], 6)))


@compile_kernel
def _error_and_jacobian(x, q_fixed, geometry, kinds, R_target, p_target, mode, axis_index, R, p, J, e, frames):
    """:func:`error_and_jacobian` with the work array of :func:`_chain_pose_jacobian` passed in."""
    _chain_pose_jacobian(x, q_fixed, geometry, kinds, R, p, J, frames)
    d0, d1, d2 = p_target[0] - p[0], p_target[1] - p[1], p_target[2] - p[2]
    e[0], e[1], e[2] = d0, d1, d2
    pos = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if mode == 1:
        return pos, 0.0
    if mode == 0:  # log3 of E = R_t R^T, E_ij = R_t[i] . R[j]
        t00, t01, t02 = R_target[0, 0], R_target[0, 1], R_target[0, 2]
        t10, t11, t12 = R_target[1, 0], R_target[1, 1], R_target[1, 2]
        t20, t21, t22 = R_target[2, 0], R_target[2, 1], R_target[2, 2]
        rot, e[3], e[4], e[5] = _log3(
            t00 * R[0, 0] + t01 * R[0, 1] + t02 * R[0, 2], t00 * R[1, 0] + t01 * R[1, 1] + t02 * R[1, 2],
            t00 * R[2, 0] + t01 * R[2, 1] + t02 * R[2, 2], t10 * R[0, 0] + t11 * R[0, 1] + t12 * R[0, 2],
            t10 * R[1, 0] + t11 * R[1, 1] + t12 * R[1, 2], t10 * R[2, 0] + t11 * R[2, 1] + t12 * R[2, 2],
            t20 * R[0, 0] + t21 * R[0, 1] + t22 * R[0, 2], t20 * R[1, 0] + t21 * R[1, 1] + t22 * R[1, 2],
            t20 * R[2, 0] + t21 * R[2, 1] + t22 * R[2, 2],
        )
        return pos, rot
    a0, a1, a2 = R[0, axis_index], R[1, axis_index], R[2, axis_index]
    t0, t1, t2 = R_target[0, axis_index], R_target[1, axis_index], R_target[2, axis_index]
    c0, c1, c2 = a1 * t2 - a2 * t1, a2 * t0 - a0 * t2, a0 * t1 - a1 * t0
    sin_angle = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    angle = math.atan2(sin_angle, a0 * t0 + a1 * t1 + a2 * t2)
    if sin_angle > 1e-300:
        k = angle / sin_angle
        e[3], e[4], e[5] = k * c0, k * c1, k * c2
    elif angle > 1.0:  # antiparallel: turn about an axis perpendicular to a
        m = 0
        if abs(a1) < abs(a0):
            m = 1
        if abs(a2) < abs(a0 if m == 0 else a1):
            m = 2
        # a x e_m
        if m == 0:
            u0, u1, u2 = 0.0, a2, -a1
        elif m == 1:
            u0, u1, u2 = -a2, 0.0, a0
        else:
            u0, u1, u2 = a1, -a0, 0.0
        k = angle / math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        e[3], e[4], e[5] = k * u0, k * u1, k * u2
    else:
        e[3] = e[4] = e[5] = 0.0
    for j in range(J.shape[1]):  # J_w <- (I - a a^T) J_w: spin about a does not count
        dot = a0 * J[3, j] + a1 * J[4, j] + a2 * J[5, j]
        J[3, j] -= a0 * dot
        J[4, j] -= a1 * dot
        J[5, j] -= a2 * dot
    return pos, angle


@compile_kernel
def _copy_square(src, dst):
    """``dst[:, :] = src`` for two n x n arrays, by loops (docs/site/internals/kernels.md, "Copies by loops")."""
    n = src.shape[0]
    for i in range(n):
        for j in range(n):
            dst[i, j] = src[i, j]


@compile_kernel
def lm_attempt(x0, q_fixed, geometry, kinds, R_target, p_target, mode, axis_index, lower, upper, wrap,
             tol_position, tol_rotation, max_iters, tau, stall_window, stall_gain, shrink_min, x_out):
    """One Levenberg-Marquardt run from ``x0`` into ``x_out``: returns (cost, pos, rot, iterations).

    The algorithm of :class:`manipkit.ik.numerical.IKSolver` (damped normal equations,
    Nielsen's damping update, limits by projection with an active set, the
    stall test), step for step.
    """
    # Over 80 lines: one compiled loop, step for step the algorithm documented in IKSolver; its fifteen
    # work arrays would have to be passed to every piece if it were split, and the loop is easiest to check
    # against that description whole.
    n = x0.shape[0]
    rows = 3 if mode == 1 else 6
    n_steps = geometry.shape[0]
    # Every work array is a view of one buffer: one allocation per attempt, none per iteration.
    work = np.zeros(12 + 2 * 6 * n + 2 * 6 + 3 * n * n + 5 * n + max_iters + 1 + 6 * n_steps)
    R = work[0:9].reshape((3, 3))
    p = work[9:12]
    at = 12
    J = work[at:at + 6 * n].reshape((6, n))
    at += 6 * n
    J_new = work[at:at + 6 * n].reshape((6, n))
    at += 6 * n
    e = work[at:at + 6]
    e_new = work[at + 6:at + 12]
    at += 12
    A = work[at:at + n * n].reshape((n, n))
    at += n * n
    M = work[at:at + n * n].reshape((n, n))
    at += n * n
    M_work = work[at:at + n * n].reshape((n, n))  # solve_linear overwrites its matrix
    at += n * n
    g = work[at:at + n]
    h = work[at + n:at + 2 * n]
    x = work[at + 2 * n:at + 3 * n]
    x_new = work[at + 3 * n:at + 4 * n]
    step = work[at + 4 * n:at + 5 * n]
    at += 5 * n
    history = work[at:at + max_iters + 1]
    at += max_iters + 1
    frames = work[at:at + 6 * n_steps].reshape((n_steps, 6))
    for j in range(n):
        v = min(max(x0[j], lower[j]), upper[j])
        x[j] = _wrap(v) if wrap[j] else v
    pos, rot = _error_and_jacobian(x, q_fixed, geometry, kinds, R_target, p_target, mode, axis_index, R, p, J, e,
                                   frames)
    cost = 0.0
    for i in range(rows):
        cost += e[i] * e[i]
    cost *= 0.5
    history[0] = cost
    lam = lam_min = scale = -1.0
    nu = 2.0
    iterations = 0
    while iterations < max_iters:
        if pos <= tol_position and rot <= tol_rotation:
            break
        if iterations >= stall_window and cost > stall_gain * history[iterations - stall_window]:
            break  # stalled: a local minimum (often against a limit); a restart does better
        for i in range(n):  # A = J^T J, g = J^T e
            acc = 0.0
            for r in range(rows):
                acc += J[r, i] * e[r]
            g[i] = acc
            for j in range(i, n):
                acc = 0.0
                for r in range(rows):
                    acc += J[r, i] * J[r, j]
                A[i, j] = A[j, i] = acc
        if lam < 0.0:
            scale = 1e-12
            for i in range(n):
                scale = max(scale, A[i, i])
            lam = tau * scale * min(1.0, math.sqrt(2.0 * cost))  # little damping near the target
            lam_min = 1e-12 * scale  # J^T J is singular for redundant arms: keep the system regular
        elif lam < lam_min:
            lam = lam_min
        for i in range(n):  # copies by loops (internals/kernels.md, "Copies by loops")
            for j in range(n):
                M[i, j] = A[i, j]
            M[i, i] += lam
        _copy_square(M, M_work)
        if not solve_linear(M_work, g, h):
            break
        clipped_any = False
        for j in range(n):
            x_new[j] = x[j] + h[j]
            v = min(max(x_new[j], lower[j]), upper[j])
            if v != x_new[j]:
                clipped_any = True
        if clipped_any:
            # Joints at a limit that the step pushes further out stay there: re-solve without them.
            blocked_any = False
            for j in range(n):
                if (x_new[j] < lower[j] and x[j] <= lower[j]) or (x_new[j] > upper[j] and x[j] >= upper[j]):
                    M[j, j] += 1e12 * (scale + lam)  # a stiff diagonal pins it: the others get the reduced step
                    blocked_any = True
            if blocked_any:
                _copy_square(M, M_work)
                if not solve_linear(M_work, g, h):
                    break
                for j in range(n):
                    x_new[j] = x[j] + h[j]
            moved = False
            for j in range(n):
                x_new[j] = min(max(x_new[j], lower[j]), upper[j])
                if x_new[j] != x[j]:
                    moved = True
            if not moved:
                break  # every joint that could move is pinned against a limit
        for j in range(n):
            step[j] = x_new[j] - x[j]
            if wrap[j]:
                x_new[j] = _wrap(x_new[j])
        iterations += 1
        pos_new, rot_new = _error_and_jacobian(x_new, q_fixed, geometry, kinds, R_target, p_target, mode, axis_index,
                                               R, p, J_new, e_new, frames)
        cost_new = 0.0
        for i in range(rows):
            cost_new += e_new[i] * e_new[i]
        cost_new *= 0.5
        predicted = 0.0  # step . g - step . A step / 2
        for i in range(n):
            acc = 0.0
            for j in range(n):
                acc += A[i, j] * step[j]
            predicted += step[i] * (g[i] - 0.5 * acc)
        if predicted > 0.0:
            rho = (cost - cost_new) / predicted
        else:  # only possible after projection; accept any decrease
            rho = 0.5 if cost_new < cost else -1.0
        if rho > 0.0:
            x, x_new = x_new, x
            J, J_new = J_new, J
            e, e_new = e_new, e
            pos, rot, cost = pos_new, rot_new, cost_new
            lam *= max(shrink_min, 1.0 - (2.0 * rho - 1.0) ** 3)
            nu = 2.0
        else:
            lam *= nu
            nu *= 2.0
            if lam > 1e20:
                break
        history[iterations] = cost
    for j in range(n):
        x_out[j] = x[j]
    return cost, pos, rot, iterations


def warm_up() -> None:
    """Compile (or load from numba's on-disk cache) every kernel :mod:`manipkit.ik.numerical` calls.

    ``make setup`` runs it (``python -m manipkit.ik.lm_kernel``), so the first IK
    solve of a new installation does not pay the few seconds of compilation.
    The argument types are those :class:`manipkit.ik.numerical.IKSolver` passes.
    """
    steps = [ChainStep(np.eye(3), np.zeros(3), 0, False, np.array([0.0, 0.0, 1.0])),
             ChainStep(np.eye(3), np.array([1.0, 0.0, 0.0]), -1, False, None)]
    geometry, kinds = pack_chain(steps, [0])
    R_target, p_target = np.eye(3), np.array([0.0, 1.0, 0.0])
    lower, upper, wrap = np.array([-math.pi]), np.array([math.pi]), np.array([True])
    lm_attempt(np.zeros(1), np.zeros(2), geometry, kinds, R_target, p_target, 0, 2, lower, upper, wrap,
               1e-10, 1e-10, 100, 0.1, 8, 0.9, 0.1, np.empty(1))
    error_and_jacobian(np.zeros(1), np.zeros(2), geometry, kinds, R_target, p_target, 0, 2,
                       np.empty((3, 3)), np.empty(3), np.zeros((6, 1)), np.zeros(6))


if __name__ == "__main__":
    import time

    start = time.perf_counter()
    warm_up()
    print(f"manipkit IK kernel ready ({time.perf_counter() - start:.1f} s; compiled once, then cached by numba)")
