"""Newton steps on a product of exponentials, compiled: the one polisher of IK rows on a true chain.

The chain is ``g = E_1(t_1) ... E_n(t_n)`` (n = 6 or 7 revolute joints; each ``E_i`` the rotation by ``t_i`` rad
about the line through ``p[i]`` along the unit ``h[i]``, in the chain's base frame, or the general 6R elimination's
scaled one); a pose ``T = g M`` of a chain whose axes at ``q0`` and tip pose ``M`` are known
(:class:`manipkit.ik.families.Geometry`) is reached when ``g = T M^-1``. One Newton step: the error
``(t_g - t, rotation vector of R_g R^T)`` (the rotation vector from the skew part and the trace) solved against
the spatial Jacobian at the tip point, columns ``(h_i x (t - point_i), h_i)`` of the moved axes: for six joints
by elimination with partial pivoting, its pseudo-inverse (``rcond`` 1e-12) where a pivot is below 1e-10 of its
largest entry (as at a near-double root); for seven the least-norm step (the pseudo-inverse). The residual is the
norm of the position error (in the frame's length unit) plus the rotation angle (rad). A start whose residual is
``far`` or more is no root of this target and is dropped before any step; a row stops when its residual is below
``stop``, or after ``iterations`` steps. Each row is polished on its own.

Users: the general 6R elimination polishes every candidate root with it
(:mod:`manipkit.closed_form.general6r_kernel`, and its numpy reference through :func:`polish_rows`), and the IK
layer polishes a snapped arm's closed-form rows on the true chain (:func:`polish_targets`, one target per row).

Importing this module imports numba; the kernels compile on their first use through the project's kernel cache
(:func:`manipkit.kernels.compile_kernel`), and :func:`warm_up` compiles them ahead (``make kernels``).
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.closed_form.subproblems_kernel import compile_kernel

__all__ = ["axis_products", "polish_one", "polish_rows", "polish_targets", "warm_up"]

TWO_PI = 2.0 * math.pi


@compile_kernel
def polish_one(K, H, h, p, G, q, iterations, far, stop, Rf, tf, E, J, error):
    """Newton steps on ``q`` (n,, moved in place) towards ``G``: (False, residual) for a start dropped as ``far``,
    else (True, the residual of the final ``q``). ``K``, ``H`` (n, 3, 3): ``[h_i]x`` and ``h_i h_i^T``
    (:func:`axis_products`); the rest are work arrays (frames ``Rf`` (n + 1, 3, 3), ``tf`` (n + 1, 3), ``E``
    (3, 3), ``J`` (6, n), ``error`` (6,))."""
    # Over 80 lines: FK, its residual, the Jacobian and the step of one Newton iteration, written out for numba.
    n = h.shape[0]
    value = 0.0
    step = np.zeros(n)
    for it in range(iterations + 1):
        for a in range(3):
            for b in range(3):
                Rf[0, a, b] = 1.0 if a == b else 0.0
            tf[0, a] = 0.0
        for i in range(n):
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
        d00 = d11 = d22 = d01 = d10 = d02 = d20 = d12 = d21 = 0.0
        for b in range(3):
            d00 += G[0, b] * Rf[n, 0, b]
            d11 += G[1, b] * Rf[n, 1, b]
            d22 += G[2, b] * Rf[n, 2, b]
            d01 += G[0, b] * Rf[n, 1, b]
            d10 += G[1, b] * Rf[n, 0, b]
            d02 += G[0, b] * Rf[n, 2, b]
            d20 += G[2, b] * Rf[n, 0, b]
            d12 += G[1, b] * Rf[n, 2, b]
            d21 += G[2, b] * Rf[n, 1, b]
        cos = (d00 + d11 + d22 - 1.0) * 0.5
        w0, w1, w2 = (d21 - d12) * 0.5, (d02 - d20) * 0.5, (d10 - d01) * 0.5
        sin = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        angle = math.atan2(sin, cos)
        scale = angle / sin if sin > 1e-12 else 1.0
        error[3], error[4], error[5] = w0 * scale, w1 * scale, w2 * scale
        for a in range(3):
            error[a] = G[a, 3] - tf[n, a]
        value = (math.sqrt(error[0] ** 2 + error[1] ** 2 + error[2] ** 2)
                 + math.sqrt(error[3] ** 2 + error[4] ** 2 + error[5] ** 2))
        if it == 0 and not value < far:
            return False, value
        if it == iterations or value < stop:
            break
        for i in range(n):  # columns (h_i x (tip - point_i), h_i) of the moved axes
            hi0 = Rf[i, 0, 0] * h[i, 0] + Rf[i, 0, 1] * h[i, 1] + Rf[i, 0, 2] * h[i, 2]
            hi1 = Rf[i, 1, 0] * h[i, 0] + Rf[i, 1, 1] * h[i, 1] + Rf[i, 1, 2] * h[i, 2]
            hi2 = Rf[i, 2, 0] * h[i, 0] + Rf[i, 2, 1] * h[i, 1] + Rf[i, 2, 2] * h[i, 2]
            r0 = tf[n, 0] - (Rf[i, 0, 0] * p[i, 0] + Rf[i, 0, 1] * p[i, 1] + Rf[i, 0, 2] * p[i, 2] + tf[i, 0])
            r1 = tf[n, 1] - (Rf[i, 1, 0] * p[i, 0] + Rf[i, 1, 1] * p[i, 1] + Rf[i, 1, 2] * p[i, 2] + tf[i, 1])
            r2 = tf[n, 2] - (Rf[i, 2, 0] * p[i, 0] + Rf[i, 2, 1] * p[i, 1] + Rf[i, 2, 2] * p[i, 2] + tf[i, 2])
            J[0, i] = hi1 * r2 - hi2 * r1
            J[1, i] = hi2 * r0 - hi0 * r2
            J[2, i] = hi0 * r1 - hi1 * r0
            J[3, i], J[4, i], J[5, i] = hi0, hi1, hi2
        if n != 6:  # seven joints: the least-norm step
            least_norm = np.linalg.pinv(J) @ error
            for i in range(n):  # copies by loops (internals/kernels.md, "Copies by loops")
                step[i] = least_norm[i]
        elif not _solve6(J, error, step):  # J nearly singular (a near-double root): its pseudo-inverse, as numpy's
            least_norm = np.linalg.pinv(J, 1e-12) @ error
            for i in range(n):
                step[i] = least_norm[i]
        for i in range(n):
            q[i] += step[i]
    return True, value


@compile_kernel
def _solve6(J, e, x):
    """``x = J^-1 e`` (6 x 6, Gaussian elimination with partial pivoting; ``J`` kept); False when a pivot is below
    1e-10 of the largest entry (then the caller takes the pseudo-inverse)."""
    a = J.copy()
    b = e.copy()
    big = 0.0
    for i in range(6):
        for j in range(6):
            big = max(big, abs(a[i, j]))
    for c in range(6):
        best = c
        for i in range(c + 1, 6):
            if abs(a[i, c]) > abs(a[best, c]):
                best = i
        if not abs(a[best, c]) > 1e-10 * big:
            return False
        if best != c:
            for j in range(6):
                a[c, j], a[best, j] = a[best, j], a[c, j]
            b[c], b[best] = b[best], b[c]
        for i in range(c + 1, 6):
            f = a[i, c] / a[c, c]
            for j in range(c, 6):
                a[i, j] -= f * a[c, j]
            b[i] -= f * b[c]
    for i in range(5, -1, -1):
        acc = b[i]
        for j in range(i + 1, 6):
            acc -= a[i, j] * x[j]
        x[i] = acc / a[i, i]
    return True


@compile_kernel
def axis_products(h, K, H):
    """``K[i] = [h_i]x`` and ``H[i] = h_i h_i^T`` (n, 3, 3) of the unit axes ``h`` (n, 3)."""
    for i in range(h.shape[0]):
        K[i, 0, 0] = K[i, 1, 1] = K[i, 2, 2] = 0.0
        K[i, 0, 1], K[i, 0, 2], K[i, 1, 2] = -h[i, 2], h[i, 1], -h[i, 0]
        K[i, 1, 0], K[i, 2, 0], K[i, 2, 1] = h[i, 2], -h[i, 1], h[i, 0]
        for a in range(3):
            for b in range(3):
                H[i, a, b] = h[i, a] * h[i, b]


def _polish_targets(h, p, G, theta, iterations, far, stop, out, residual, keep):
    """Polish row ``k`` of ``theta`` (k, n) towards ``G[k]`` (k, 4, 4): angles wrapped to (-pi, pi] into ``out``
    (k, n), the residual of those angles into ``residual`` (k,), ``keep`` (k,) False for a start dropped as ``far``."""
    n = h.shape[0]
    K = np.zeros((n, 3, 3))
    H = np.zeros((n, 3, 3))
    axis_products(h, K, H)
    Rf, tf, E, J, error = np.zeros((n + 1, 3, 3)), np.zeros((n + 1, 3)), np.zeros((3, 3)), np.zeros((6, n)), np.zeros(6)
    q = np.zeros(n)
    for k in range(theta.shape[0]):
        for i in range(n):
            q[i] = theta[k, i]
        keep[k], residual[k] = polish_one(K, H, h, p, G[k], q, iterations, far, stop, Rf, tf, E, J, error)
        for i in range(n):
            out[k, i] = math.pi - ((math.pi - q[i]) % TWO_PI)


_KERNEL = []


def _kernel():
    if not _KERNEL:
        _KERNEL.append(compile_kernel(_polish_targets))
    return _KERNEL[0]


def polish_targets(h: np.ndarray, p: np.ndarray, G: np.ndarray, theta: np.ndarray, *, iterations: int, far: float,
                   stop: float = 1e-13) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(theta (k, n) wrapped to (-pi, pi], residual (k,), kept (k,)) of every row of ``theta`` (k, n; n = 6 or 7)
    after at most ``iterations`` Newton steps on axes ``h``, points ``p`` (n, 3) towards its own ``G[k]`` (k, 4, 4);
    ``kept`` is False for a start dropped as ``far`` (its row and residual as they started).

    >>> from manipkit.closed_form.general6r import poe_fk
    >>> rng = np.random.default_rng(1)
    >>> h = rng.normal(size=(6, 3)); h /= np.linalg.norm(h, axis=1, keepdims=True); p = rng.normal(size=(6, 3))
    >>> theta = rng.uniform(-3.0, 3.0, (2, 6))
    >>> G = np.stack([poe_fk(h, p, t) for t in theta])
    >>> rows, residual, kept = polish_targets(h, p, G, theta + 0.01, iterations=6, far=0.5)
    >>> bool(np.abs(rows - theta).max() < 1e-12), bool(residual.max() < 1e-13), kept.tolist()
    (True, True, [True, True])
    """
    h = np.ascontiguousarray(h, dtype=float)
    theta = np.ascontiguousarray(theta, dtype=float).reshape(-1, len(h))
    G = np.ascontiguousarray(np.broadcast_to(G, (len(theta), 4, 4)), dtype=float)
    out = np.empty_like(theta)
    residual = np.empty(len(theta))
    keep = np.empty(len(theta), dtype=np.bool_)
    _kernel()(h, np.ascontiguousarray(p, dtype=float), G, theta, int(iterations), float(far), float(stop), out,
              residual, keep)
    return out, residual, keep


def polish_rows(h: np.ndarray, p: np.ndarray, G: np.ndarray, theta: np.ndarray, *, iterations: int, far: float,
                stop: float = 1e-13) -> tuple[np.ndarray, np.ndarray]:
    """(theta (m, 6) wrapped to (-pi, pi], residual (m,)) of the rows of ``theta`` (k, 6) not dropped as ``far``,
    after at most ``iterations`` Newton steps on axes ``h``, points ``p`` (6, 3) towards one ``G`` (4, 4)
    (:func:`polish_targets` with one target).

    >>> from manipkit.closed_form.general6r import poe_fk
    >>> rng = np.random.default_rng(1)
    >>> h = rng.normal(size=(6, 3)); h /= np.linalg.norm(h, axis=1, keepdims=True); p = rng.normal(size=(6, 3))
    >>> theta = rng.uniform(-3.0, 3.0, 6)
    >>> rows, residual = polish_rows(h, p, poe_fk(h, p, theta), theta[None] + 0.01, iterations=6, far=0.5)
    >>> bool(np.abs(rows - theta).max() < 1e-12), bool(residual[0] < 1e-13)
    (True, True)
    """
    out, residual, keep = polish_targets(h, p, G, np.reshape(theta, (-1, 6)), iterations=iterations, far=far,
                                         stop=stop)
    return out[keep], residual[keep]


def warm_up() -> None:
    """Compile (or load from the kernel cache) the polisher's kernel with the types its callers pass (6 and 7
    joints)."""
    for n in (6, 7):
        polish_targets(np.eye(3)[[2, 1, 1, 0, 1, 0, 2][:n]], np.zeros((n, 3)), np.eye(4), np.zeros((1, n)),
                       iterations=1, far=0.5)
