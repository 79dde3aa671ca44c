"""Small dense linear algebra compiled for one target at a time: :func:`eigenvalues`, :func:`inverse`,
:func:`null_vector`.

LAPACK's routines pay a fixed cost per call (workspace queries, blocking)
that dominates on the 12 x 12 and 24 x 24 matrices of the general 6R
elimination (a 24 x 24 ``dgeev`` about 120 us here, against about 36 us for
these loops); these are the textbook algorithms written out for numba:

- :func:`eigenvalues`: every eigenvalue of a real square matrix, by
  balancing (Parlett and Reinsch: rows and columns scaled by powers of 2),
  reduction to upper Hessenberg form by Gaussian elimination with pivoting,
  and the Francis double-shift QR iteration (EISPACK ``hqr``, as in Press et
  al., Numerical Recipes, sections 11.5-11.6);
- :func:`inverse`: Gauss-Jordan elimination with partial pivoting;
- :func:`null_vector`: a vector of the near null space of a complex square
  matrix by inverse iteration (two solves with its LU factors, partial
  pivoting, a zero pivot replaced by ``eps`` times the matrix's size).

Importing this module imports numba (through
:mod:`manipkit.closed_form.subproblems_kernel`); each function compiles on
first use through the project's kernel cache.
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.closed_form.subproblems_kernel import compile_kernel

__all__ = ["eigenvalues", "inverse", "null_vector"]

#: QR sweeps allowed per eigenvalue before :func:`eigenvalues` gives up (EISPACK's 30)
_SWEEPS = 30


@compile_kernel
def _balance(a, n):
    """Scale rows and columns of ``a`` (1-based, (n + 1, n + 1)) by powers of 2 until their norms match."""
    done = False
    while not done:
        done = True
        for i in range(1, n + 1):
            r = 0.0
            c = 0.0
            for j in range(1, n + 1):
                if j != i:
                    c += abs(a[j, i])
                    r += abs(a[i, j])
            if c != 0.0 and r != 0.0:
                g = r / 2.0
                f = 1.0
                s = c + r
                while c < g:
                    f *= 2.0
                    c *= 4.0
                g = r * 2.0
                while c > g:
                    f /= 2.0
                    c /= 4.0
                if (c + r) / f < 0.95 * s:
                    done = False
                    g = 1.0 / f
                    for j in range(1, n + 1):
                        a[i, j] *= g
                    for j in range(1, n + 1):
                        a[j, i] *= f


@compile_kernel
def _hessenberg(a, n):
    """``a`` (1-based) reduced to upper Hessenberg form by elimination with pivoting (a similarity); zero below."""
    for m in range(2, n):
        x = 0.0
        i = m
        for j in range(m, n + 1):
            if abs(a[j, m - 1]) > abs(x):
                x = a[j, m - 1]
                i = j
        if i != m:
            for j in range(m - 1, n + 1):
                a[i, j], a[m, j] = a[m, j], a[i, j]
            for j in range(1, n + 1):
                a[j, i], a[j, m] = a[j, m], a[j, i]
        if x != 0.0:
            for i in range(m + 1, n + 1):
                y = a[i, m - 1]
                if y != 0.0:
                    y /= x
                    a[i, m - 1] = y
                    for j in range(m, n + 1):
                        a[i, j] -= y * a[m, j]
                    for j in range(1, n + 1):
                        a[j, m] += y * a[j, i]
    for i in range(1, n + 1):
        for j in range(1, i - 1):
            a[i, j] = 0.0


@compile_kernel
def _hqr(a, n, wr, wi):
    """Every eigenvalue ``wr + i wi`` (0-based outputs) of the upper Hessenberg ``a`` (1-based, destroyed); False when
    an eigenvalue takes more than :data:`_SWEEPS` sweeps."""
    # Over 80 lines: EISPACK's hqr written out (deflation test, exceptional shifts, the double-shift sweep).
    anorm = 0.0
    for i in range(1, n + 1):
        for j in range(max(i - 1, 1), n + 1):
            anorm += abs(a[i, j])
    nn = n
    t = 0.0
    x = y = z = w = p = q = r = 0.0
    while nn >= 1:
        its = 0
        while True:
            l = 1  # noqa: E741 - EISPACK's name
            for ll in range(nn, 1, -1):
                s = abs(a[ll - 1, ll - 1]) + abs(a[ll, ll])
                if s == 0.0:
                    s = anorm
                if abs(a[ll, ll - 1]) + s == s:
                    a[ll, ll - 1] = 0.0
                    l = ll  # noqa: E741
                    break
            x = a[nn, nn]
            if l == nn:
                wr[nn - 1] = x + t
                wi[nn - 1] = 0.0
                nn -= 1
            else:
                y = a[nn - 1, nn - 1]
                w = a[nn, nn - 1] * a[nn - 1, nn]
                if l == nn - 1:
                    p = 0.5 * (y - x)
                    q = p * p + w
                    z = math.sqrt(abs(q))
                    x += t
                    if q >= 0.0:
                        z = p + (z if p >= 0.0 else -z)
                        wr[nn - 2] = wr[nn - 1] = x + z
                        if z != 0.0:
                            wr[nn - 1] = x - w / z
                        wi[nn - 2] = wi[nn - 1] = 0.0
                    else:
                        wr[nn - 2] = wr[nn - 1] = x + p
                        wi[nn - 2] = -z
                        wi[nn - 1] = z
                    nn -= 2
                else:
                    if its == _SWEEPS:
                        return False
                    if its == 10 or its == 20:  # exceptional shift
                        t += x
                        for i in range(1, nn + 1):
                            a[i, i] -= x
                        s = abs(a[nn, nn - 1]) + abs(a[nn - 1, nn - 2])
                        x = y = 0.75 * s
                        w = -0.4375 * s * s
                    its += 1
                    m = nn - 2
                    while m >= l:
                        z = a[m, m]
                        r = x - z
                        s = y - z
                        p = (r * s - w) / a[m + 1, m] + a[m, m + 1]
                        q = a[m + 1, m + 1] - z - r - s
                        r = a[m + 2, m + 1]
                        s = abs(p) + abs(q) + abs(r)
                        p /= s
                        q /= s
                        r /= s
                        if m == l:
                            break
                        u = abs(a[m, m - 1]) * (abs(q) + abs(r))
                        v = abs(p) * (abs(a[m - 1, m - 1]) + abs(z) + abs(a[m + 1, m + 1]))
                        if u + v == v:
                            break
                        m -= 1
                    for i in range(m + 2, nn + 1):
                        a[i, i - 2] = 0.0
                        if i != m + 2:
                            a[i, i - 3] = 0.0
                    for k in range(m, nn):
                        if k != m:
                            p = a[k, k - 1]
                            q = a[k + 1, k - 1]
                            r = 0.0
                            if k != nn - 1:
                                r = a[k + 2, k - 1]
                            x = abs(p) + abs(q) + abs(r)
                            if x != 0.0:
                                p /= x
                                q /= x
                                r /= x
                        s = math.sqrt(p * p + q * q + r * r)
                        if p < 0.0:
                            s = -s
                        if s != 0.0:
                            if k == m:
                                if l != m:
                                    a[k, k - 1] = -a[k, k - 1]
                            else:
                                a[k, k - 1] = -s * x
                            p += s
                            x = p / s
                            y = q / s
                            z = r / s
                            q /= p
                            r /= p
                            for j in range(k, nn + 1):
                                p = a[k, j] + q * a[k + 1, j]
                                if k != nn - 1:
                                    p += r * a[k + 2, j]
                                    a[k + 2, j] -= p * z
                                a[k + 1, j] -= p * y
                                a[k, j] -= p * x
                            top = nn if nn < k + 3 else k + 3
                            for i in range(l, top + 1):
                                p = x * a[i, k] + y * a[i, k + 1]
                                if k != nn - 1:
                                    p += z * a[i, k + 2]
                                    a[i, k + 2] -= p * r
                                a[i, k + 1] -= p * q
                                a[i, k] -= p
            if not l < nn - 1:  # EISPACK's "until": this block deflated (or nothing is left)
                break
    return True


@compile_kernel
def eigenvalues(A, wr, wi):
    """``wr``, ``wi`` (n,) = the real and imaginary parts of every eigenvalue of the real square ``A`` (kept):
    balanced, reduced to Hessenberg form, double-shift QR; False when the QR iteration did not converge."""
    n = A.shape[0]
    a = np.zeros((n + 1, n + 1))
    for i in range(n):
        for j in range(n):
            a[i + 1, j + 1] = A[i, j]
    _balance(a, n)
    _hessenberg(a, n)
    return _hqr(a, n, wr, wi)


@compile_kernel
def inverse(A, out):
    """``out`` = A^-1 of the square ``A`` by Gauss-Jordan with partial pivoting; False when a pivot is exactly 0."""
    n = A.shape[0]
    a = A.copy()
    for i in range(n):
        for j in range(n):
            out[i, j] = 1.0 if i == j else 0.0
    for c in range(n):
        best = c
        for i in range(c + 1, n):
            if abs(a[i, c]) > abs(a[best, c]):
                best = i
        if a[best, c] == 0.0:
            return False
        if best != c:
            for j in range(n):
                a[c, j], a[best, j] = a[best, j], a[c, j]
                out[c, j], out[best, j] = out[best, j], out[c, j]
        d = 1.0 / a[c, c]
        for j in range(n):
            a[c, j] *= d
            out[c, j] *= d
        for i in range(n):
            if i != c:
                f = a[i, c]
                if f != 0.0:
                    for j in range(n):
                        a[i, j] -= f * a[c, j]
                        out[i, j] -= f * out[c, j]
    return True


@compile_kernel
def null_vector(L, out):
    """``out`` (n,) complex, largest entry 1: inverse iteration on the complex square ``L`` (destroyed: its LU)."""
    n = L.shape[0]
    scale = 0.0
    for i in range(n):
        for j in range(n):
            scale = max(scale, abs(L[i, j]))
    tiny = 2.220446049250313e-16 * max(scale, 1e-300)
    piv = np.empty(n, dtype=np.int64)
    for c in range(n):
        best = c
        for i in range(c + 1, n):
            if abs(L[i, c]) > abs(L[best, c]):
                best = i
        piv[c] = best
        if best != c:
            for j in range(n):
                L[c, j], L[best, j] = L[best, j], L[c, j]
        if abs(L[c, c]) < tiny:
            L[c, c] = tiny
        d = 1.0 / L[c, c]
        for i in range(c + 1, n):
            f = L[i, c] * d
            L[i, c] = f
            if f != 0.0:
                for j in range(c + 1, n):
                    L[i, j] -= f * L[c, j]
    for i in range(n):
        out[i] = 1.0 + 0.0j
    for _sweep in range(2):
        for c in range(n):  # the row swaps, then L y = b, then U x = y
            if piv[c] != c:
                out[c], out[piv[c]] = out[piv[c]], out[c]
        for i in range(n):
            acc = out[i]
            for j in range(i):
                acc -= L[i, j] * out[j]
            out[i] = acc
        for i in range(n - 1, -1, -1):
            acc = out[i]
            for j in range(i + 1, n):
                acc -= L[i, j] * out[j]
            out[i] = acc / L[i, i]
        big = 0
        for i in range(1, n):
            if abs(out[i]) > abs(out[big]):
                big = i
        d = out[big]
        for i in range(n):
            out[i] = out[i] / d


