"""The general 6R elimination's root polishing, compiled: :func:`polish_rows`.

What ``manipkit.closed_form.general6r`` does to every candidate root in
numpy (its reference, ``solve(..., compiled=False)``): Newton steps on the
product of exponentials ``g = E_1(t_1) ... E_6(t_6)`` (each ``E_i`` the
rotation by ``t_i`` rad about the line through ``p[i]`` along the unit
``h[i]``, in the arm's scaled base frame), the step the pseudo-inverse
(``rcond`` 1e-12) of the spatial Jacobian at the tip point times the error
``(t_g - t, rotation vector of R_g R^T)``. The residual is the norm of the
position error (in units of the arm's size) plus the rotation angle (rad).
A start whose residual is ``far`` or more is no root of this target and is
dropped before any step; a row stops when its residual is below ``stop``.
Each row is polished on its own (the numpy reference stops when every row
is below ``stop``; both are within rounding of each other, tested).

Importing this module imports numba; the kernel compiles on its first use
through the project's kernel cache (:func:`manipkit.kernels.compile_kernel`),
and :func:`warm_up` compiles it ahead (``make kernels``).
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.closed_form.subproblems_kernel import compile_kernel

__all__ = ["polish_rows", "warm_up"]

TWO_PI = 2.0 * math.pi


def _polish_rows(h, p, G, theta, iterations, far, stop, out, residual, keep):
    """Polish every row of ``theta`` (k, 6) towards ``G`` (4, 4): angles wrapped to (-pi, pi] into ``out`` (k, 6),
    the residual of those angles into ``residual`` (k,), ``keep`` (k,) False for a start dropped as ``far``."""
    # Over 80 lines: FK, its residual, the Jacobian and the step of one Newton iteration, written out for numba.
    n = theta.shape[0]
    K = np.zeros((6, 3, 3))
    H = np.zeros((6, 3, 3))
    for i in range(6):
        K[i, 0, 1], K[i, 0, 2], K[i, 1, 2] = -h[i, 2], h[i, 1], -h[i, 0]
        K[i, 1, 0], K[i, 2, 0], K[i, 2, 1] = h[i, 2], -h[i, 1], h[i, 0]
        for a in range(3):
            for b in range(3):
                H[i, a, b] = h[i, a] * h[i, b]
    Rf = np.zeros((7, 3, 3))  # the frames E_1 ... E_i, i = 0..6
    tf = np.zeros((7, 3))
    E = np.zeros((3, 3))
    J = np.zeros((6, 6))
    error = np.zeros(6)
    q = np.zeros(6)
    for k in range(n):
        for i in range(6):
            q[i] = theta[k, i]
        keep[k] = True
        value = 0.0
        for it in range(iterations + 1):
            for a in range(3):
                for b in range(3):
                    Rf[0, a, b] = 1.0 if a == b else 0.0
                tf[0, a] = 0.0
            for i in range(6):
                c, s = math.cos(q[i]), math.sin(q[i])
                for a in range(3):
                    for b in range(3):
                        E[a, b] = s * K[i, a, b] + (1.0 - c) * H[i, a, b] + (c if a == b else 0.0)
                for a in range(3):
                    move = p[i, a] - (E[a, 0] * p[i, 0] + E[a, 1] * p[i, 1] + E[a, 2] * p[i, 2])
                    for b in range(3):
                        Rf[i + 1, a, b] = Rf[i, a, 0] * E[0, b] + Rf[i, a, 1] * E[1, b] + Rf[i, a, 2] * E[2, b]
                    error[a] = move  # E's translation, for the frame's
                for a in range(3):
                    tf[i + 1, a] = (tf[i, a] + Rf[i, a, 0] * error[0] + Rf[i, a, 1] * error[1]
                                    + Rf[i, a, 2] * error[2])
            # dR = R_g R^T, its angle and rotation vector
            d = np.zeros((3, 3))
            for a in range(3):
                for b in range(3):
                    d[a, b] = G[a, 0] * Rf[6, b, 0] + G[a, 1] * Rf[6, b, 1] + G[a, 2] * Rf[6, b, 2]
            cos = (d[0, 0] + d[1, 1] + d[2, 2] - 1.0) * 0.5
            w0, w1, w2 = (d[2, 1] - d[1, 2]) * 0.5, (d[0, 2] - d[2, 0]) * 0.5, (d[1, 0] - d[0, 1]) * 0.5
            sin = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
            angle = math.atan2(sin, cos)
            scale = angle / sin if sin > 1e-12 else 1.0
            error[3], error[4], error[5] = w0 * scale, w1 * scale, w2 * scale
            for a in range(3):
                error[a] = G[a, 3] - tf[6, a]
            value = (math.sqrt(error[0] ** 2 + error[1] ** 2 + error[2] ** 2)
                     + math.sqrt(error[3] ** 2 + error[4] ** 2 + error[5] ** 2))
            if it == 0 and not value < far:
                keep[k] = False
                break
            if it == iterations or value < stop:
                break
            for i in range(6):  # columns (h_i x (tip - point_i), h_i) of the moved axes
                hi = np.zeros(3)
                pi = np.zeros(3)
                for a in range(3):
                    hi[a] = Rf[i, a, 0] * h[i, 0] + Rf[i, a, 1] * h[i, 1] + Rf[i, a, 2] * h[i, 2]
                    pi[a] = tf[6, a] - (Rf[i, a, 0] * p[i, 0] + Rf[i, a, 1] * p[i, 1] + Rf[i, a, 2] * p[i, 2]
                                        + tf[i, a])
                J[0, i] = hi[1] * pi[2] - hi[2] * pi[1]
                J[1, i] = hi[2] * pi[0] - hi[0] * pi[2]
                J[2, i] = hi[0] * pi[1] - hi[1] * pi[0]
                J[3, i], J[4, i], J[5, i] = hi[0], hi[1], hi[2]
            step = np.linalg.pinv(J, 1e-12) @ error
            for i in range(6):
                q[i] += step[i]
        for i in range(6):
            out[k, i] = math.pi - ((math.pi - q[i]) % TWO_PI)
        residual[k] = value


_KERNEL = []


def _kernel():
    if not _KERNEL:
        _KERNEL.append(compile_kernel(_polish_rows))
    return _KERNEL[0]


def polish_rows(h: np.ndarray, p: np.ndarray, G: np.ndarray, theta: np.ndarray, *, iterations: int, far: float,
                stop: float = 1e-13) -> tuple[np.ndarray, np.ndarray]:
    """(theta (m, 6) wrapped to (-pi, pi], residual (m,)) of the rows of ``theta`` (k, 6) not dropped as ``far``,
    after at most ``iterations`` Newton steps on axes ``h``, points ``p`` (6, 3) towards ``G`` (4, 4) (scaled units).

    >>> from manipkit.closed_form.general6r import poe_fk
    >>> rng = np.random.default_rng(1)
    >>> h = rng.normal(size=(6, 3)); h /= np.linalg.norm(h, axis=1, keepdims=True); p = rng.normal(size=(6, 3))
    >>> theta = rng.uniform(-3.0, 3.0, 6)
    >>> rows, residual = polish_rows(h, p, poe_fk(h, p, theta), theta[None] + 0.01, iterations=6, far=0.5)
    >>> bool(np.abs(rows - theta).max() < 1e-12), bool(residual[0] < 1e-13)
    (True, True)
    """
    theta = np.ascontiguousarray(theta, dtype=float).reshape(-1, 6)
    out = np.empty_like(theta)
    residual = np.empty(len(theta))
    keep = np.empty(len(theta), dtype=np.bool_)
    _kernel()(np.ascontiguousarray(h, dtype=float), np.ascontiguousarray(p, dtype=float),
              np.ascontiguousarray(G, dtype=float), theta, int(iterations), float(far), float(stop), out, residual,
              keep)
    return out[keep], residual[keep]


def warm_up() -> None:
    """Compile (or load from the kernel cache) :func:`polish_rows`'s kernel with the types the solver passes."""
    polish_rows(np.eye(3)[[2, 1, 1, 0, 1, 0]], np.zeros((6, 3)), np.eye(4), np.zeros((1, 6)), iterations=1, far=0.5)
