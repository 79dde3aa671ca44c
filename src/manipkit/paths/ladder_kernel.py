"""The compiled step of the ladder's dynamic program: one rung's candidates reduced to their best predecessors.

Numbers in, numbers out (numpy only, so that a change to the modules around it does not recompile it); the
rule is :mod:`manipkit.paths.ladder`'s. Between rung ``i`` (``Q_prev`` (k_prev, n), chain order, rad or m) and
rung ``i + 1`` (``Q_next`` (k_next, n)) an edge ``a -> b`` is allowed when ``M_prev[a]`` is finite, every joint's
``|Q_next[b, j] - Q_prev[a, j]|`` fits ``bound[j]`` and ``a * k_next + b`` is not in ``forbid`` (sorted keys); its
cost is ``M_prev[a] + sum_j w_j |dq_j|`` (summed over ``j`` in order). Each candidate ``b`` takes the allowed edge
of fewest breaks ``B_prev[a]`` (with ``breaks``; else none count), then least cost, then lowest ``a``.

The pairs tried are windows: the next rung sorted by its most selective joint ``s`` (least bound over spread), each
live predecessor's window ``|dq_s| <= bound_s`` found by binary search; or every pair, when no joint is bounded or
the windows hold more than ``share`` of the pairs (dense). A joint fits as ``|dq| / bound <= 1`` (``|dq| = 0``
fits a zero bound) on windows and as ``|dq| inv <= 1`` (``inv = 1 / bound``, 0 for no bound) on the dense block:
the two ways the numpy reduction this replaces read it, so each gives the same edges bit for bit.

A candidate with no allowed edge in gets the best step in for its failure record: over the live predecessors, the
least of the step's largest joint ratio ``|dq_j| inv_j`` (inf for a forbidden edge), the lowest predecessor on a
tie, and that step's joint of largest ratio (every live predecessor's ratio at once, joint by joint over a
contiguous copy of their values, so the compiler vectorises it).
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.kernels import compile_kernel, lazy_kernel

__all__ = ["in_sorted", "reduce_rung", "reduce_rung_kernel", "selective_joint"]


@compile_kernel
def in_sorted(keys, key) -> bool:
    """Whether ``key`` is in the sorted int64 array ``keys`` (binary search)."""
    if len(keys) == 0:
        return False
    at = np.searchsorted(keys, key)
    return at < len(keys) and keys[at] == key


@compile_kernel
def selective_joint(Q_next, bound) -> int:
    """The bounded joint of least ``bound / (spread of Q_next's column + 1e-300)`` (the first on a tie); -1: none."""
    best, chosen = math.inf, -1
    for j in range(Q_next.shape[1]):
        if not math.isfinite(bound[j]) or Q_next.shape[0] == 0:
            continue
        low, high = Q_next[0, j], Q_next[0, j]
        for b in range(1, Q_next.shape[0]):
            low, high = min(low, Q_next[b, j]), max(high, Q_next[b, j])
        value = bound[j] / ((high - low) + 1e-300)
        if chosen < 0 or value < best:
            best, chosen = value, j
    return chosen


def reduce_rung(Q_prev, B_prev, M_prev, Q_next, bound, weights, forbid, breaks, share,
                best_B, best_M, best_a, best_ratio, best_joint):
    """Fill ``best_B``, ``best_M``, ``best_a`` (k_next,) with each candidate's best allowed edge in (inf, inf, -1:
    none), and ``best_ratio``, ``best_joint`` with the best step into each candidate that has none (inf, -1 where it
    has one, or where no live predecessor is reached without a forbidden edge)."""
    # Over 80 lines: the windows, the allowed edges and the best step into a stuck candidate share the sorts.
    n = Q_prev.shape[1]
    k_prev, k_next = Q_prev.shape[0], Q_next.shape[0]
    inv = np.empty(n)
    for j in range(n):
        inv[j] = 1.0 / bound[j] if math.isfinite(bound[j]) else 0.0  # a bound of 0 allows no motion: inv = inf
    count = 0
    for a in range(k_prev):
        if math.isfinite(M_prev[a]):
            count += 1
    live = np.empty(count, dtype=np.intp)
    count = 0
    for a in range(k_prev):
        if math.isfinite(M_prev[a]):
            live[count] = a
            count += 1
    for b in range(k_next):
        best_B[b] = math.inf
        best_M[b] = math.inf
        best_a[b] = -1
        best_ratio[b] = math.inf
        best_joint[b] = -1
    s = selective_joint(Q_next, bound) if n else -1
    lo = np.zeros(len(live), dtype=np.intp)
    hi = np.full(len(live), k_next, dtype=np.intp)
    order = np.arange(k_next)
    dense = True
    if s >= 0:
        order = np.argsort(Q_next[:, s], kind="mergesort")
        values = Q_next[order, s]
        total = 0
        for r in range(len(live)):
            lo[r] = np.searchsorted(values, Q_prev[live[r], s] - bound[s], side="left")
            hi[r] = np.searchsorted(values, Q_prev[live[r], s] + bound[s], side="right")
            total += hi[r] - lo[r]
        dense = total > int(max(1, k_prev * k_next) * share)
        if dense:
            order = np.arange(k_next)
            lo[:] = 0
            hi[:] = k_next
    for r in range(len(live)):
        a = live[r]
        brk = B_prev[a] if breaks else 0.0
        for p in range(lo[r], hi[r]):
            b = order[p]
            fits = True
            for j in range(n):
                d = abs(Q_next[b, j] - Q_prev[a, j])
                if dense:
                    if inv[j] != 0.0 and d != 0.0 and d * inv[j] > 1.0:
                        fits = False
                        break
                elif d != 0.0 and d / bound[j] > 1.0:
                    fits = False
                    break
            if not fits or in_sorted(forbid, a * k_next + b):
                continue
            motion = 0.0
            for j in range(n):
                d = abs(Q_next[b, j] - Q_prev[a, j])
                motion += weights[j] * d if weights[j] != 1.0 else d
            cost = M_prev[a] + motion
            if brk < best_B[b] or (brk == best_B[b] and cost < best_M[b]):
                best_B[b] = brk
                best_M[b] = cost
                best_a[b] = a
    # the best step into each stuck candidate: every live predecessor's ratio at once (a loop over contiguous
    # predecessors per joint, which the compiler vectorises), then the first least one not forbidden
    live_T = np.empty((n, len(live)))
    for j in range(n):
        for r in range(len(live)):
            live_T[j, r] = Q_prev[live[r], j]
    ratios = np.empty(len(live))
    for b in range(k_next):
        if math.isfinite(best_M[b]) or len(live) == 0:
            continue
        ratios[:] = 0.0
        for j in range(n):
            if inv[j] == 0.0:
                continue
            q, w = Q_next[b, j], inv[j]
            for r in range(len(live)):
                d = abs(q - live_T[j, r])
                value = d * w if d != 0.0 else 0.0
                ratios[r] = value if value > ratios[r] else ratios[r]
        found, best = -1, math.inf
        for r in range(len(live)):
            if ratios[r] < best and not in_sorted(forbid, live[r] * k_next + b):
                best, found = ratios[r], live[r]
        if found >= 0:
            best_ratio[b] = best
            largest, joint = -1.0, 0
            for j in range(n):
                d = abs(Q_next[b, j] - Q_prev[found, j])
                value = d * inv[j] if d != 0.0 else 0.0
                if value > largest:
                    largest, joint = value, j
            best_joint[b] = joint


reduce_rung_kernel = lazy_kernel(reduce_rung, error_model="numpy")
