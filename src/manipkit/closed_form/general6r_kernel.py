"""The general 6R elimination compiled: the whole elimination of a stack of targets (:func:`solve_targets`).

:func:`solve_targets` runs the steps of ``manipkit.closed_form.general6r.solve`` (module docstring there) for
each target and each way of eliminating the loop, without the GIL; the pencils' conditioning is the reciprocal
1-norm condition number of ``M(x)`` at the probe (as the reference's), the joints 4-5 null space a pivoted
Householder QR, the eigenvalues :func:`manipkit.closed_form.eigen_kernel.eigenvalues`, each candidate's monomial
vector the null vector of the matrix polynomial at its eigenvalue (inverse iteration). Every candidate root is
polished by Newton steps on the product of exponentials in the arm's scaled base frame
(:func:`manipkit.closed_form.newton_kernel.polish_one`, the one polisher; the numpy reference
``manipkit.closed_form.general6r`` calls it as :func:`manipkit.closed_form.newton_kernel.polish_rows`: the reference
stops when every row is below ``stop``, the kernel row by row; both are within rounding of each other, tested).

Importing this module imports numba; the kernel compiles on its first use
through the project's kernel cache (:func:`manipkit.kernels.compile_kernel`);
``manipkit.closed_form.general6r.warm_up`` compiles it ahead (``make kernels``).
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.closed_form.eigen_kernel import eigenvalues, inverse, null_vector
from manipkit.closed_form.newton_kernel import axis_products, polish_one
from manipkit.closed_form.subproblems_kernel import compile_kernel

__all__ = ["solve_targets"]

TWO_PI = 2.0 * math.pi


# --- the whole elimination of one target, compiled (the numpy reference: manipkit.closed_form.general6r.solve) ---


@compile_kernel
def _motion(h, p, t, R, b):
    """``R``, ``b`` (3, 3), (3,): the rotation by ``t`` about the line through ``p`` along the unit ``h``."""
    c, s = math.cos(t), math.sin(t)
    v = 1.0 - c
    R[0, 0], R[0, 1], R[0, 2] = c + v * h[0] * h[0], v * h[0] * h[1] - s * h[2], v * h[0] * h[2] + s * h[1]
    R[1, 0], R[1, 1], R[1, 2] = v * h[0] * h[1] + s * h[2], c + v * h[1] * h[1], v * h[1] * h[2] - s * h[0]
    R[2, 0], R[2, 1], R[2, 2] = v * h[0] * h[2] - s * h[1], v * h[1] * h[2] + s * h[0], c + v * h[2] * h[2]
    for a in range(3):
        b[a] = p[a] - (R[a, 0] * p[0] + R[a, 1] * p[1] + R[a, 2] * p[2])


@compile_kernel
def _compose(R1, b1, R2, b2, R, b):
    """``(R, b) = (R1, b1) (R2, b2)`` (``R`` and ``b`` may not be ``R1``, ``b1``)."""
    for a in range(3):
        for c in range(3):
            R[a, c] = R1[a, 0] * R2[0, c] + R1[a, 1] * R2[1, c] + R1[a, 2] * R2[2, c]
        b[a] = R1[a, 0] * b2[0] + R1[a, 1] * b2[1] + R1[a, 2] * b2[2] + b1[a]


@compile_kernel
def _foot(ha, pa, hb, pb, out):
    """``out``: the point on line a nearest line b (``pa`` when they are parallel)."""
    n0, n1, n2 = ha[1] * hb[2] - ha[2] * hb[1], ha[2] * hb[0] - ha[0] * hb[2], ha[0] * hb[1] - ha[1] * hb[0]
    nn = n0 * n0 + n1 * n1 + n2 * n2
    f = 0.0
    if nn >= 1e-12:
        d0, d1, d2 = pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]
        c0, c1, c2 = d1 * hb[2] - d2 * hb[1], d2 * hb[0] - d0 * hb[2], d0 * hb[1] - d1 * hb[0]
        f = (c0 * n0 + c1 * n1 + c2 * n2) / nn
    for a in range(3):
        out[a] = pa[a] + f * ha[a]


@compile_kernel
def _rr(p, line, out):
    """The 14 Raghavan-Roth quantities of ``p`` and ``line``: p, l, p.p, p.l, p x l, (p.p) l - 2 (p.l) p."""
    pp = p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
    pl = p[0] * line[0] + p[1] * line[1] + p[2] * line[2]
    for a in range(3):
        out[a] = p[a]
        out[3 + a] = line[a]
        out[11 + a] = pp * line[a] - 2.0 * pl * p[a]
    out[6], out[7] = pp, pl
    out[8] = p[1] * line[2] - p[2] * line[1]
    out[9] = p[2] * line[0] - p[0] * line[2]
    out[10] = p[0] * line[1] - p[1] * line[0]


@compile_kernel
def _null_and_solve(A, N, pinv):
    """Householder QR with column pivoting of ``A`` (14, 8): ``N`` (6, 14) an orthonormal basis of its left null
    space (rows), ``pinv`` (8, 14) its least-squares solve; returns the numerical rank (``|R_jj| > 1e-9 |R_00|``)."""
    m, n = A.shape
    a = A.copy()
    perm = np.arange(n)
    V = np.zeros((n, m))
    diag = np.zeros(n)
    for j in range(n):
        best, norm_best = j, -1.0
        for c in range(j, n):
            norm = 0.0
            for i in range(j, m):
                norm += a[i, c] * a[i, c]
            if norm > norm_best:
                best, norm_best = c, norm
        if best != j:
            for i in range(m):
                a[i, j], a[i, best] = a[i, best], a[i, j]
            perm[j], perm[best] = perm[best], perm[j]
        alpha = math.sqrt(norm_best)
        if a[j, j] > 0.0:
            alpha = -alpha
        vv = 0.0
        for i in range(j, m):
            V[j, i] = a[i, j]
        V[j, j] -= alpha
        for i in range(j, m):
            vv += V[j, i] * V[j, i]
        diag[j] = alpha
        if vv > 0.0:
            for c in range(j, n):
                dot = 0.0
                for i in range(j, m):
                    dot += V[j, i] * a[i, c]
                f = 2.0 * dot / vv
                for i in range(j, m):
                    a[i, c] -= f * V[j, i]
            for i in range(j, m):
                V[j, i] /= math.sqrt(vv / 2.0)  # H = I - v v^T with |v|^2 = 2
        a[j, j] = alpha
    rank = 0
    for j in range(n):
        if abs(diag[j]) > 1e-9 * abs(diag[0]):
            rank += 1
    Q = np.eye(m)  # Q = H_0 H_1 ... H_{n-1}
    for j in range(n - 1, -1, -1):
        for c in range(m):
            dot = 0.0
            for i in range(j, m):
                dot += V[j, i] * Q[i, c]
            for i in range(j, m):
                Q[i, c] -= dot * V[j, i]
    for r in range(m - n):
        for i in range(m):
            N[r, i] = Q[i, n + r]
    if rank < n:
        return rank
    Y = np.zeros((n, m))  # R^-1 Q_1^T by back substitution, then the columns' permutation undone
    for c in range(m):
        for i in range(n - 1, -1, -1):
            acc = Q[c, i]
            for k in range(i + 1, n):
                acc -= a[i, k] * Y[k, c]
            Y[i, c] = acc / a[i, i]
    for i in range(n):
        for c in range(m):
            pinv[perm[i], c] = Y[i, c]
    return rank


@compile_kernel
def _prepare(h_in, p_in, grid, V2_INV, h, p, R_grid, b_grid, x6, o, P, N, pinv, origin):
    """:func:`manipkit.closed_form.general6r.prepare` into the arrays given: returns (rank of the joints 4-5 side,
    size)."""
    # Over 80 lines: the per-chain part (scaling, the joints 1-3 grid, the joints 4-5 side, its null space) in order.
    mean = np.zeros(3)
    for i in range(6):
        norm = math.sqrt(h_in[i, 0] ** 2 + h_in[i, 1] ** 2 + h_in[i, 2] ** 2)
        for a in range(3):
            h[i, a] = h_in[i, a] / norm
            mean[a] += p_in[i, a] / 6.0
    size = 0.0
    for i in range(6):
        size = max(size, math.sqrt((p_in[i, 0] - mean[0]) ** 2 + (p_in[i, 1] - mean[1]) ** 2
                                   + (p_in[i, 2] - mean[2]) ** 2))
    size = max(1e-3, size)
    for a in range(3):
        origin[a] = p_in[0, a]
    rel = np.zeros((6, 3))
    for i in range(6):
        for a in range(3):
            rel[i, a] = p_in[i, a] - origin[a]
    o_unit = np.zeros(3)
    _foot(h[2], rel[2], h[3], rel[3], o_unit)
    R1, b1, R2, b2, R3, b3 = np.zeros((3, 3)), np.zeros(3), np.zeros((3, 3)), np.zeros(3), np.zeros((3, 3)), np.zeros(3)
    R12, b12, F, bF = np.zeros((3, 3)), np.zeros(3), np.zeros((3, 3)), np.zeros(3)
    k = 0
    for i1 in range(3):
        _motion(h[0], rel[0], grid[i1], R1, b1)
        for i2 in range(3):
            _motion(h[1], rel[1], grid[i2], R2, b2)
            _compose(R1, b1, R2, b2, R12, b12)
            for i3 in range(3):
                _motion(h[2], rel[2], grid[i3], R3, b3)
                _compose(R12, b12, R3, b3, F, bF)
                for a in range(3):
                    for c in range(3):
                        R_grid[k, a, c] = F[c, a]
                for a in range(3):
                    b_grid[k, a] = -(F[0, a] * bF[0] + F[1, a] * bF[1] + F[2, a] * bF[2]) - o_unit[a]
                    b_grid[k, a] /= size
                k += 1
    for i in range(6):
        for a in range(3):
            p[i, a] = rel[i, a] / size
    for a in range(3):
        o[a] = o_unit[a] / size
    _foot(h[5], p[5], h[4], p[4], x6)
    S = np.zeros((9, 14))
    pl, ll, quantities = np.zeros(3), np.zeros(3), np.zeros(14)
    k = 0
    for i4 in range(3):
        _motion(h[3], p[3], grid[i4], R1, b1)
        for i5 in range(3):
            _motion(h[4], p[4], grid[i5], R2, b2)
            _compose(R1, b1, R2, b2, F, bF)
            for a in range(3):
                pl[a] = F[a, 0] * x6[0] + F[a, 1] * x6[1] + F[a, 2] * x6[2] + bF[a] - o[a]
                ll[a] = F[a, 0] * h[5, 0] + F[a, 1] * h[5, 1] + F[a, 2] * h[5, 2]
            _rr(pl, ll, quantities)
            for c in range(14):
                S[k, c] = quantities[c]
            k += 1
    for c in range(14):
        for j in range(9):
            acc = 0.0
            for m in range(9):
                acc += V2_INV[j, m] * S[m, c]
            P[c, j] = acc
    return _null_and_solve(np.ascontiguousarray(P[:, 1:]), N, pinv), size


@compile_kernel
def _rcond(L, inv):
    """``1 / (|L|_1 |L^-1|_1)`` with ``inv`` = L^-1 written; 0 when a pivot of ``L`` is exactly 0."""
    if not inverse(L, inv):
        return 0.0
    a = b = 0.0
    n = L.shape[0]
    for j in range(n):
        ca = cb = 0.0
        for i in range(n):
            ca += abs(L[i, j])
            cb += abs(inv[i, j])
        a, b = max(a, ca), max(b, cb)
    return 1.0 / (a * b)


@compile_kernel
def _pencil(K, eigen, multiplied, M):
    """``M`` (3, 12, 12): ``M0, M1, M2`` of the six equations ``K`` (6, 3, 3, 3), as the reference's ``_pencil``."""
    other = 3 - eigen - multiplied
    M[:] = 0.0
    power = np.zeros(3, dtype=np.int64)
    for e in range(6):
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    power[multiplied], power[other], power[eigen] = i, j, k
                    value = K[e, power[0], power[1], power[2]]
                    for shift in range(2):
                        M[k, 6 * shift + e, 3 * (i + shift) + j] = value


@compile_kernel
def _solve(h_in, p_in, g, grid, V2_INV, V3_INV, shifts, probe, tol, iterations, imaginary, far, rows, res, info):
    """Every isolated solution of ``g = E_1 ... E_6`` (axes ``h_in``, points ``p_in``): the reference
    ``general6r.solve(prepare(h_in, p_in), g)`` compiled. Rows into ``rows`` (24, 6), residuals into ``res``;
    returns their count. ``info``: (status: 0 solved, 1 the joints 4-5 side of rank < 8, 2 every pencil singular,
    3 the QR iteration did not converge; that rank or the conditioning; candidates; the eigenvalue's joint)."""
    # Over 80 lines: the elimination's steps 1-5 (module docstring of manipkit.closed_form.general6r) in order.
    h, p = np.zeros((6, 3)), np.zeros((6, 3))
    R_grid, b_grid, x6, o = np.zeros((27, 3, 3)), np.zeros((27, 3)), np.zeros(3), np.zeros(3)
    P, N, pinv, origin = np.zeros((14, 9)), np.zeros((6, 14)), np.zeros((8, 14)), np.zeros(3)
    rank, size = _prepare(h_in, p_in, grid, V2_INV, h, p, R_grid, b_grid, x6, o, P, N, pinv, origin)
    info[:] = 0.0
    if rank < 8:
        info[0], info[1] = 1.0, rank
        return 0
    G = np.zeros((4, 4))  # the target in the scaled frame (origin on axis 1, lengths / size)
    for a in range(3):
        for c in range(3):
            G[a, c] = g[a, c]
        G[a, 3] = (g[a, 3] + g[a, 0] * origin[0] + g[a, 1] * origin[1] + g[a, 2] * origin[2] - origin[a]) / size
    G[3, 3] = 1.0
    P6, L6, pk, lk, quantities = np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(14)
    for a in range(3):
        P6[a] = G[a, 0] * x6[0] + G[a, 1] * x6[1] + G[a, 2] * x6[2] + G[a, 3]
        L6[a] = G[a, 0] * h[5, 0] + G[a, 1] * h[5, 1] + G[a, 2] * h[5, 2]
    right = np.zeros((27, 14))
    for k in range(27):
        for a in range(3):
            pk[a] = R_grid[k, a, 0] * P6[0] + R_grid[k, a, 1] * P6[1] + R_grid[k, a, 2] * P6[2] + b_grid[k, a]
            lk[a] = R_grid[k, a, 0] * L6[0] + R_grid[k, a, 1] * L6[1] + R_grid[k, a, 2] * L6[2]
        _rr(pk, lk, quantities)
        for c in range(14):
            right[k, c] = quantities[c]
    Q = np.zeros((14, 27))  # the joints 1-3 side in (1, c, s)^3, less the joints 4-5 side's constant column
    for c in range(14):
        for k in range(27):
            acc = 0.0
            for m in range(27):
                acc += V3_INV[k, m] * right[m, c]
            Q[c, k] = acc
        Q[c, 0] -= P[c, 0]
    C = np.zeros((6, 3, 3, 3))
    for e in range(6):
        for k in range(27):
            acc = 0.0
            for c in range(14):
                acc += N[e, c] * Q[c, k]
            C[e, k // 9, (k // 3) % 3, k % 3] = acc
    for axis in range(3):  # (1, cos t, sin t) of each joint -> powers of its shifted half-angle tangent, times (1 + x^2)
        cs, sn = math.cos(shifts[axis]), math.sin(shifts[axis])
        for e in range(6):
            for u in range(3):
                for v in range(3):
                    if axis == 0:
                        a0, a1, a2 = C[e, 0, u, v], C[e, 1, u, v], C[e, 2, u, v]
                    elif axis == 1:
                        a0, a1, a2 = C[e, u, 0, v], C[e, u, 1, v], C[e, u, 2, v]
                    else:
                        a0, a1, a2 = C[e, u, v, 0], C[e, u, v, 1], C[e, u, v, 2]
                    b1, b2 = a1 * cs + a2 * sn, -a1 * sn + a2 * cs
                    c0, c1, c2 = a0 + b1, 2.0 * b2, a0 - b1
                    if axis == 0:
                        C[e, 0, u, v], C[e, 1, u, v], C[e, 2, u, v] = c0, c1, c2
                    elif axis == 1:
                        C[e, u, 0, v], C[e, u, 1, v], C[e, u, 2, v] = c0, c1, c2
                    else:
                        C[e, u, v, 0], C[e, u, v, 1], C[e, u, v, 2] = c0, c1, c2
    M, best_M = np.zeros((3, 12, 12)), np.zeros((3, 12, 12))
    lead, inv, best_inv = np.zeros((12, 12)), np.zeros((12, 12)), np.zeros((12, 12))
    score, eigen, multiplied = -1.0, 0, 0
    for choice in range(3):  # the reference's order: (eigen, multiplied) = (2, 0), (0, 1), (1, 0)
        e_joint = 2 if choice == 0 else choice - 1
        m_joint = 0 if choice != 1 else 1
        _pencil(C, e_joint, m_joint, M)
        for a in range(12):
            for c in range(12):
                lead[a, c] = M[0, a, c] + probe * M[1, a, c] + probe * probe * M[2, a, c]
        value = _rcond(lead, inv)
        if value > score:
            score, eigen, multiplied = value, e_joint, m_joint
            for a in range(12):  # copies by loops (internals/kernels.md, "Copies by loops")
                for c in range(12):
                    best_M[0, a, c], best_M[1, a, c], best_M[2, a, c] = M[0, a, c], M[1, a, c], M[2, a, c]
                    best_inv[a, c] = inv[a, c]
    info[1], info[3] = score, eigen
    if not score > 1e-13:
        info[0] = 2.0
        return 0
    # the Moebius change x = s + 1 / y: y^2 M(s) + y (M1 + 2 s M2) + M2, its companion matrix
    companion = np.zeros((24, 24))
    for a in range(12):
        companion[a, 12 + a] = 1.0
        for c in range(12):
            acc2 = acc1 = 0.0
            for m in range(12):
                acc2 += best_inv[a, m] * best_M[2, m, c]
                acc1 += best_inv[a, m] * (best_M[1, m, c] + 2.0 * probe * best_M[2, m, c])
            companion[12 + a, c] = -acc2
            companion[12 + a, 12 + c] = -acc1
    wr, wi = np.zeros(24), np.zeros(24)
    if not eigenvalues(companion, wr, wi):
        info[0] = 3.0
        return 0
    other = 3 - eigen - multiplied
    L = np.zeros((12, 12), dtype=np.complex128)
    u = np.zeros(12, dtype=np.complex128)
    K3, H3 = np.zeros((6, 3, 3)), np.zeros((6, 3, 3))
    axis_products(h, K3, H3)
    Rf, tf, E, J, error = np.zeros((7, 3, 3)), np.zeros((7, 3)), np.zeros((3, 3)), np.zeros((6, 6)), np.zeros(6)
    theta = np.zeros(6)
    found, candidates = np.zeros((24, 6)), 0
    found_res = np.zeros(24)
    n_found = 0
    basis, X123, rhs = np.zeros((3, 3)), np.zeros(27), np.zeros(14)
    Fr, Fb, Er, Eb, Tr, Tb = np.zeros((3, 3)), np.zeros(3), np.zeros((3, 3)), np.zeros(3), np.zeros((3, 3)), np.zeros(3)
    h6 = h[5]
    small = 0
    for a in range(1, 3):
        if abs(h6[a]) < abs(h6[small]):
            small = a
    e_small = np.zeros(3)
    e_small[small] = 1.0
    perp = np.array([h6[1] * e_small[2] - h6[2] * e_small[1], h6[2] * e_small[0] - h6[0] * e_small[2],
                     h6[0] * e_small[1] - h6[1] * e_small[0]])
    perp /= math.sqrt(perp[0] ** 2 + perp[1] ** 2 + perp[2] ** 2)
    for i in range(24):
        y = complex(wr[i], wi[i])
        if not abs(y) > 1e-8:
            continue
        x = probe + 1.0 / y
        if not abs(x.imag) <= imaginary * (1.0 + abs(x)):
            continue
        candidates += 1
        if wi[i] < 0.0:  # its conjugate (listed just before it) gives the same real start
            continue
        for a in range(12):
            for c in range(12):
                L[a, c] = best_M[0, a, c] + x * best_M[1, a, c] + x * x * best_M[2, a, c]
        null_vector(L, u)
        num_a = num_b = 0.0
        den_a = den_b = 0.0
        for r in range(4):
            for c in range(3):
                if r >= 1:
                    num_a += (u[3 * r + c] * u[3 * (r - 1) + c].conjugate()).real
                    den_a += abs(u[3 * (r - 1) + c]) ** 2
                if c >= 1:
                    num_b += (u[3 * r + c] * u[3 * r + c - 1].conjugate()).real
                    den_b += abs(u[3 * r + c - 1]) ** 2
        theta[eigen] = shifts[eigen] + 2.0 * math.atan(x.real)
        theta[multiplied] = shifts[multiplied] + 2.0 * math.atan(num_a / max(den_a, 1e-300))
        theta[other] = shifts[other] + 2.0 * math.atan(num_b / max(den_b, 1e-300))
        for j in range(3):  # joints 4, 5 from the 14 equations (least squares), joint 6 from the rest
            basis[j, 0], basis[j, 1], basis[j, 2] = 1.0, math.cos(theta[j]), math.sin(theta[j])
        for k in range(27):
            X123[k] = basis[0, k // 9] * basis[1, (k // 3) % 3] * basis[2, k % 3]
        for c in range(14):
            acc = 0.0
            for k in range(27):
                acc += Q[c, k] * X123[k]
            rhs[c] = acc
        x45_0 = x45_1 = x45_2 = x45_5 = 0.0
        for c in range(14):
            x45_0 += pinv[0, c] * rhs[c]
            x45_1 += pinv[1, c] * rhs[c]
            x45_2 += pinv[2, c] * rhs[c]
            x45_5 += pinv[5, c] * rhs[c]
        theta[3] = math.atan2(x45_5, x45_2)
        theta[4] = math.atan2(x45_1, x45_0)
        _motion(h[0], p[0], theta[0], Fr, Fb)
        for j in range(1, 5):
            _motion(h[j], p[j], theta[j], Er, Eb)
            _compose(Fr, Fb, Er, Eb, Tr, Tb)
            for a in range(3):  # copies by loops (internals/kernels.md, "Copies by loops")
                Fb[a] = Tb[a]
                for c in range(3):
                    Fr[a, c] = Tr[a, c]
        v = np.zeros(3)  # R_rest u with R_rest = F^T R_g, the rotation E_6 must make
        for a in range(3):
            acc = 0.0
            for m in range(3):
                acc += Fr[m, a] * (G[m, 0] * perp[0] + G[m, 1] * perp[1] + G[m, 2] * perp[2])
            v[a] = acc
        cross = ((perp[1] * v[2] - perp[2] * v[1]) * h6[0] + (perp[2] * v[0] - perp[0] * v[2]) * h6[1]
                 + (perp[0] * v[1] - perp[1] * v[0]) * h6[2])
        theta[5] = math.atan2(cross, v[0] * perp[0] + v[1] * perp[1] + v[2] * perp[2])
        keep, value = polish_one(K3, H3, h, p, G, theta, iterations, far, 1e-13, Rf, tf, E, J, error)
        if keep and value <= tol:
            for j in range(6):
                found[n_found, j] = math.pi - ((math.pi - theta[j]) % TWO_PI)
            found_res[n_found] = value
            n_found += 1
    info[2] = candidates
    order = np.zeros(n_found, dtype=np.int64)  # lexicographic order, then a row equal to an earlier one dropped
    for i in range(n_found):
        order[i] = i
    for i in range(1, n_found):
        j = i
        while j > 0:
            a, b = order[j - 1], order[j]
            later = False
            for c in range(6):
                if found[a, c] != found[b, c]:
                    later = found[a, c] > found[b, c]
                    break
            if not later:
                break
            order[j - 1], order[j] = b, a
            j -= 1
    count = 0
    for i in range(n_found):
        same = False
        for j in range(i):
            close = True
            for c in range(6):
                d = found[order[i], c] - found[order[j], c]
                if abs(math.pi - ((math.pi - d) % TWO_PI)) > 1e-7:
                    close = False
                    break
            if close:
                same = True
                break
        if not same:
            for c in range(6):
                rows[count, c] = found[order[i], c]
            res[count] = found_res[order[i]]
            count += 1
    return count


@compile_kernel
def _solve_ways(h0, p0, g, ways, grid, V2_INV, V3_INV, shifts, probe, tol, iterations, imaginary, far, poor, rows,
                res, status):
    """The ways ``ways`` (W, 2) of (shift, reverse) in turn (:func:`manipkit.closed_form.general6r.solve_way`
    compiled), the next one while the last solved is conditioned below ``poor``: rows (chain order) appended into
    ``rows`` (24 W, 6), ``res``; ``status`` (W, 4) each way's ``info`` of :func:`_solve` (status -1: not tried).
    Returns the rows written."""
    h, p, target, gi = np.zeros((6, 3)), np.zeros((6, 3)), np.zeros((4, 4)), np.zeros((4, 4))
    for a in range(3):  # the rigid inverse of g
        for c in range(3):
            gi[a, c] = g[c, a]
        gi[a, 3] = -(g[0, a] * g[0, 3] + g[1, a] * g[1, 3] + g[2, a] * g[2, 3])
    gi[3, 3] = 1.0
    way_rows, way_res, info = np.zeros((24, 6)), np.zeros(24), np.zeros(4)
    status[:, :] = 0.0
    status[:, 0] = -1.0
    total = 0
    for w in range(ways.shape[0]):
        shift, reverse = ways[w, 0], ways[w, 1] != 0
        for i in range(6):  # the loop E_{k+1} ... E_6 F_1 ... F_k = g, F_i = g^-1 E_i g
            j = (i + shift) % 6
            moved = i + shift >= 6
            for a in range(3):
                if moved:
                    h[i, a] = gi[a, 0] * h0[j, 0] + gi[a, 1] * h0[j, 1] + gi[a, 2] * h0[j, 2]
                    p[i, a] = gi[a, 0] * p0[j, 0] + gi[a, 1] * p0[j, 1] + gi[a, 2] * p0[j, 2] + gi[a, 3]
                else:
                    h[i, a], p[i, a] = h0[j, a], p0[j, a]
        if reverse:  # read tip to base: E_6^-1 ... E_1^-1 = g^-1
            for i in range(3):
                for a in range(3):
                    h[i, a], h[5 - i, a] = -h[5 - i, a], -h[i, a]
                    p[i, a], p[5 - i, a] = p[5 - i, a], p[i, a]
        for a in range(4):  # copies by loops (internals/kernels.md, "Copies by loops")
            for c in range(4):
                target[a, c] = gi[a, c] if reverse else g[a, c]
        n = _solve(h, p, target, grid, V2_INV, V3_INV, shifts, probe, tol, iterations, imaginary, far, way_rows,
                   way_res, info)
        for c in range(4):
            status[w, c] = info[c]
        if info[0] != 0.0:
            continue
        for r in range(n):
            for i in range(6):
                joint = (5 - i if reverse else i)
                rows[total + r, (joint + shift) % 6] = way_rows[r, i]
            res[total + r] = way_res[r]
        total += n
        if info[1] >= poor:
            break
    return total


def _solve_targets(h0, p0, G, ways, grid, V2_INV, V3_INV, shifts, probe, tol, iterations, imaginary, far, poor,
                   rows, res, count, status):
    """:func:`_solve_ways` of every target ``G`` (n, 4, 4): ``rows`` (n, 24 W, 6), ``res`` (n, 24 W), ``count``
    (n,), ``status`` (n, W, 4). Each target's numbers come from that target alone (the same on any block)."""
    for k in range(G.shape[0]):
        count[k] = _solve_ways(h0, p0, G[k], ways, grid, V2_INV, V3_INV, shifts, probe, tol, iterations, imaginary,
                               far, poor, rows[k], res[k], status[k])


_TARGETS = []


def solve_targets(h0: np.ndarray, p0: np.ndarray, G: np.ndarray, ways: np.ndarray, constants: tuple, *, tol: float,
                  iterations: int, imaginary: float, far: float, poor: float, rows: np.ndarray, res: np.ndarray,
                  count: np.ndarray, status: np.ndarray) -> None:
    """Every isolated solution of each target ``G`` (n, 4, 4) of the chain ``h0``, ``p0`` (6, 3) (base frame, m), by
    the ways ``ways`` (W, 2) in turn, into ``rows`` (n, 24 W, 6) (PoE angles in chain order, wrapped to (-pi, pi]),
    ``res`` (n, 24 W), ``count`` (n,) and ``status`` (n, W, 4): the compiled twin of
    ``manipkit.closed_form.general6r.solve_way`` over ways (``constants``: the reference's grid, interpolation
    matrices, Moebius shifts and probe). Runs without the GIL."""
    if not _TARGETS:
        _TARGETS.append(compile_kernel(_solve_targets, nogil=True))
    grid, V2_INV, V3_INV, shifts, probe = constants
    _TARGETS[0](np.ascontiguousarray(h0, dtype=float), np.ascontiguousarray(p0, dtype=float), G,
                np.ascontiguousarray(ways, dtype=np.int64), grid, V2_INV, V3_INV, shifts, float(probe), float(tol),
                int(iterations), float(imaginary), float(far), float(poor), rows, res, count, status)
