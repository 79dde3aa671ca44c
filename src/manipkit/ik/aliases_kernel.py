"""The 2 pi aliases of IK rows, compiled: :func:`fresh_aliases` (``manipkit.ik.aliases`` calls it).

Every combination of each row's in-limit values ``q + 2 pi k`` (``k`` from the turns given, in their order), in
``itertools.product``'s order, less those equal (to 1e-9, every entry) to a row already listed; a Python loop
per row and numpy on arrays of a few rows cost more than the rows themselves. numpy only here (numba on first
use, through :func:`manipkit.kernels.lazy_kernel`), so the kernel's cache key does not move with the IK layer.
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.kernels import lazy_kernel

__all__ = ["fresh_aliases", "leading_rows", "nearest_zero_into"]

TWO_PI = 2.0 * math.pi


def _fresh_aliases(Q, low, high, aliased, turns, limit, listed, cap):
    """The combinations of :func:`manipkit.ik.aliases.alias_rows` (``limit`` of them at most, rows of ``Q`` in turn, each entry's whole
    ``turns`` in their order), less those within
    1e-9 (every entry) of a row of ``listed``: (the first ``cap`` of them (r, n), their rows of ``Q``, how many there
    are, counted up to ``cap + 1``)."""
    # Over 80 lines: itertools.product's order over each row's inside values, written out for numba.
    m, n = Q.shape
    T = turns.shape[0]
    values = np.empty((m, n, T))  # each entry's values inside the limits, in the order of the turns
    counts = np.zeros((m, n), dtype=np.int64)
    for r in range(m):
        for j in range(n):
            for t in range(T):
                if turns[t] != 0.0 and not aliased[j]:
                    continue
                v = Q[r, j] + TWO_PI * turns[t]
                if v >= low[j] and v <= high[j]:
                    values[r, j, counts[r, j]] = v
                    counts[r, j] += 1
    room = limit
    total = 0
    for r in range(m):
        combos = 1
        for j in range(n):
            combos *= counts[r, j]
        combos = min(combos, max(room, 0))
        total += combos
        room -= combos
    out = np.empty((min(total, cap + 1), n))
    origin = np.empty(min(total, cap + 1), dtype=np.intp)
    digit = np.zeros(n, dtype=np.int64)
    row = np.empty(n)
    found = 0
    room = limit
    for r in range(m):
        combos = 1
        for j in range(n):
            combos *= counts[r, j]
        combos = min(combos, max(room, 0))
        room -= combos
        for j in range(n):
            digit[j] = 0
        for _ in range(combos):
            for j in range(n):
                row[j] = values[r, j, digit[j]]
            fresh = True
            for s in range(listed.shape[0]):
                close = True
                for j in range(n):
                    if not abs(row[j] - listed[s, j]) <= 1e-9:
                        close = False
                        break
                if close:
                    fresh = False
                    break
            if fresh:
                if found < out.shape[0]:
                    for j in range(n):  # copies by loops (internals/kernels.md, "Copies by loops")
                        out[found, j] = row[j]
                    origin[found] = r
                found += 1
                if found > cap:
                    return out[:cap], origin[:cap], found
            j = n - 1  # the next combination: the last entry's choice changes fastest
            while j >= 0:
                digit[j] += 1
                if digit[j] < counts[r, j]:
                    break
                digit[j] = 0
                j -= 1
    return out[:found], origin[:found], found



def _leading_rows(Q, aliased):
    """Each row of ``Q`` (k, n) equal to no earlier row (every entry within 1e-9, the ``aliased`` ones modulo 2 pi):
    a bool (k,) mask, True for the first of equal rows (an earlier row need not be a leader itself)."""
    m, n = Q.shape
    lead = np.ones(m, dtype=np.bool_)
    for r in range(m):
        for s in range(r):
            same = True
            for j in range(n):
                gap = Q[r, j] - Q[s, j]
                if aliased[j]:
                    gap = abs((gap + math.pi) % TWO_PI - math.pi)  # numpy's remainder: the sign of the divisor
                if not abs(gap) <= 1e-9:
                    same = False
                    break
            if same:
                lead[r] = False
                break
    return lead


def _nearest_zero_into(Q, columns, low, high, turns):
    """Each entry ``Q[:, columns[c]]`` (Q (k, n), written) wrapped to (-pi, pi], then moved by the first of the whole
    ``turns`` (in their order) that puts it inside ``[low[c], high[c]]`` (kept wrapped when none does)."""
    for r in range(Q.shape[0]):
        for c in range(columns.shape[0]):
            j = columns[c]
            wrapped = math.pi - (math.pi - Q[r, j]) % TWO_PI  # numpy's mod: the sign of the divisor
            Q[r, j] = wrapped
            for t in range(turns.shape[0]):
                v = wrapped + TWO_PI * turns[t]
                if v >= low[c] and v <= high[c]:
                    Q[r, j] = v
                    break


fresh_aliases = lazy_kernel(_fresh_aliases)
nearest_zero_into = lazy_kernel(_nearest_zero_into)
leading_rows = lazy_kernel(_leading_rows)
