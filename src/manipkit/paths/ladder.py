"""The ladder over IK branches, solved by dynamic programming over its rungs without storing its edges.

A *rung* is the set of candidate joint vectors at one waypoint (every IK
branch, its in-limit 2*pi aliases, every sampled tool angle or arm angle),
an array ``(k_i, n)`` in the chain's joint order (rad or m). An *edge* joins
a candidate ``a`` of rung ``i`` to a candidate ``b`` of rung ``i + 1``; it is
allowed only if every joint's step fits its bound, ``|q_b - q_a|_j <=
step_bounds[i, j]`` (a joint's velocity limit times the time between the two
waypoints), and is not in ``forbidden``. Its cost is ``sum_j w_j |q_b -
q_a|_j`` plus the vertex penalty of ``b``; a path's cost is the sum over its
edges (plus the first vertex's penalty).

:func:`solve_ladder` finds the path of least cost through every rung, or
proves there is none: rung by rung, a ``(k_prev, k_next)`` block of edge
costs is computed (vectorised numpy), reduced to the best predecessor of
each candidate, and dropped; only the costs so far and the back-pointers are
kept (memory ``O(sum k_i)``, not the ``O(sum k_i k_{i+1})`` edges a stored
graph holds). The answer is optimal for the stated cost over the candidates
given: it is exactly the dynamic program's, not a heuristic.

With ``reconfigure=True`` a *break* may be taken between any two rungs (the
arm retracts, changes configuration and resumes): the path minimises the
number of breaks first, then the joint motion (the motion of a
reconfiguration itself is not counted; it is a separate move).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["LadderResult", "StepBlock", "solve_ladder"]

#: Above this many entries (k_prev * k_next * n) a rung's block of edges is reduced in slices of predecessors.
BLOCK_ENTRIES = 4_000_000


@dataclass(frozen=True)
class StepBlock:
    """Why candidates of a rung have no allowed edge in: the best edge from any reached predecessor.

    Attributes
    ----------
    rung : int
        The rung (waypoint index) of the candidates.
    ratio : ndarray, shape (k,)
        Per candidate of the rung, the smallest over reached predecessors of the largest joint ratio
        ``|dq_j| / step_bounds_j`` (above 1: too fast; inf: no predecessor was reached, or every edge forbidden).
    joint : ndarray of int, shape (k,)
        The joint (column) of that largest ratio, -1 where there is none.
    """

    rung: int
    ratio: np.ndarray
    joint: np.ndarray


@dataclass(frozen=True)
class LadderResult:
    """The best path through a ladder, or the proof that there is none.

    Attributes
    ----------
    feasible : bool
        A path through every rung exists (with ``reconfigure``: possibly with breaks).
    choice : ndarray of int, shape (N,)
        The candidate chosen at each rung (-1 everywhere when infeasible).
    cost : float
        The path's cost (inf when infeasible): sum of ``w_j |dq_j|`` over its edges plus its vertex penalties.
    breaks : tuple of int
        Steps ``i`` (between rung ``i`` and ``i + 1``) where the path breaks (``reconfigure=True`` only).
    reached : tuple of ndarray of bool
        Per rung, which candidates some allowed path from the first rung reaches.
    first_dead : int or None
        The first rung none of whose candidates is reached (None when feasible).
    blocked : tuple of StepBlock
        For each rung with a candidate that is valid but not reached, why (the best edge into it).
    edges : int
        How many edges were evaluated (the sum of ``k_i k_{i+1}``), none of them stored.
    """

    feasible: bool
    choice: np.ndarray
    cost: float
    breaks: tuple[int, ...]
    reached: tuple[np.ndarray, ...]
    first_dead: int | None
    blocked: tuple[StepBlock, ...]
    edges: int


def _rung_arrays(rungs, n: int) -> list[np.ndarray]:
    out = []
    for i, rung in enumerate(rungs):
        Q = np.asarray(rung, dtype=float)
        if Q.size == 0:
            Q = np.zeros((0, n))
        if Q.ndim != 2 or (n is not None and Q.shape[1] != n):
            raise ValueError(f"rung {i}: candidates must be (k, {n}), got shape {Q.shape}")
        n = Q.shape[1]
        out.append(Q)
    return out


def _reduce(Q_prev, B_prev, M_prev, Q_next, bound, weights, forbid, breaks: bool):
    """Per candidate of the next rung: best (breaks, motion, predecessor) over allowed edges, and the best ratio and
    its joint over reached predecessors. Joint by joint on (k_prev, k_next) blocks (a reduction over a short
    trailing axis is slow in numpy); slices of predecessors keep a block under :data:`BLOCK_ENTRIES`."""
    k_prev, n = Q_prev.shape
    k_next = len(Q_next)
    with np.errstate(divide="ignore"):
        inv = np.where(np.isfinite(bound), 1.0 / bound, 0.0)  # a bound of 0 allows no motion: inv = inf
    best_B = np.full(k_next, np.inf)
    best_M = np.full(k_next, np.inf)
    best_a = np.full(k_next, -1, dtype=np.intp)
    best_ratio = np.full(k_next, np.inf)
    ratio_a = np.full(k_next, -1, dtype=np.intp)
    rows = max(1, BLOCK_ENTRIES // max(1, k_next * 4))
    columns = np.arange(k_next)
    for start in range(0, k_prev, rows):
        stop = min(k_prev, start + rows)
        ratio = np.zeros((stop - start, k_next))
        motion = np.zeros((stop - start, k_next))
        for j in range(n):
            d = np.abs(Q_next[None, :, j] - Q_prev[start:stop, j, None])
            if inv[j]:
                with np.errstate(invalid="ignore"):
                    r = d * inv[j]
                if not np.isfinite(inv[j]):
                    r[d == 0.0] = 0.0
                np.maximum(ratio, r, out=ratio)
            motion += weights[j] * d if weights[j] != 1.0 else d
        dead = ~np.isfinite(M_prev[start:stop])
        ratio[dead] = np.inf
        if forbid is not None:
            f = forbid[(forbid[:, 0] >= start) & (forbid[:, 0] < stop)]
            ratio[f[:, 0] - start, f[:, 1]] = np.inf
        ok = ratio <= 1.0
        if breaks:
            Bm = np.where(ok, B_prev[start:stop, None], np.inf)
            bmin = Bm.min(axis=0)
            ok &= Bm == bmin[None, :]
        else:
            bmin = np.where(ok.any(axis=0), 0.0, np.inf)
        Mm = np.where(ok, M_prev[start:stop, None] + motion, np.inf)
        a = Mm.argmin(axis=0)
        mmin = Mm[a, columns]
        better = (bmin < best_B) | ((bmin == best_B) & (mmin < best_M))
        best_B = np.where(better, bmin, best_B)
        best_M = np.where(better, mmin, best_M)
        best_a = np.where(better, a + start, best_a)
        ra = ratio.argmin(axis=0)
        rmin = ratio[ra, columns]
        closer = rmin < best_ratio
        best_ratio = np.where(closer, rmin, best_ratio)
        ratio_a = np.where(closer, ra + start, ratio_a)
    best_joint = np.full(k_next, -1, dtype=np.intp)
    known = ratio_a >= 0
    if known.any() and n:
        per_joint = np.abs(Q_next[known] - Q_prev[ratio_a[known]]) * inv
        per_joint[np.isnan(per_joint)] = 0.0
        best_joint[known] = per_joint.argmax(axis=1)
    return best_B, best_M, best_a, best_ratio, best_joint


def _sparse_reduce(Q_prev, B_prev, M_prev, Q_next, bound, weights, forbid, breaks: bool):
    """:func:`_reduce` by the edges that can pass only, or None when too many can: the candidates of both rungs
    sorted by the most selective joint, each predecessor's window ``|dq_j| <= bound_j`` found by binary search,
    the full rule checked on those pairs; the best step into a candidate with no allowed edge is then found on the
    dense block of those candidates alone."""
    k_prev, n = Q_prev.shape
    k_next = len(Q_next)
    finite = np.flatnonzero(np.isfinite(bound))
    if not len(finite) or not n:
        return None
    spread = np.ptp(Q_next[:, finite], axis=0) + 1e-300
    j = int(finite[np.argmin(bound[finite] / spread)])
    live = np.flatnonzero(np.isfinite(M_prev))
    order = np.argsort(Q_next[:, j], kind="stable")
    values = Q_next[order, j]
    lo = np.searchsorted(values, Q_prev[live, j] - bound[j], side="left")
    hi = np.searchsorted(values, Q_prev[live, j] + bound[j], side="right")
    counts = hi - lo
    total = int(counts.sum())
    if total > max(1, k_prev * k_next) // 4:
        return None
    a = np.repeat(live, counts)
    b = order[np.repeat(lo, counts) + np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)]
    D = np.abs(Q_next[b] - Q_prev[a])
    with np.errstate(divide="ignore", invalid="ignore"):
        over = np.where(D == 0.0, 0.0, D / bound)
    ok = over.max(axis=1) <= 1.0 if total else np.zeros(0, dtype=bool)
    if forbid is not None and total:
        ok &= ~np.isin(a * k_next + b, forbid[:, 0] * k_next + forbid[:, 1])
    a, b, cost = a[ok], b[ok], M_prev[a[ok]] + D[ok] @ weights
    brk = B_prev[a] if breaks else np.zeros(len(a))
    first = np.lexsort((a, cost, brk, b))
    b_sorted = b[first]
    head = np.ones(len(first), dtype=bool)
    head[1:] = b_sorted[1:] != b_sorted[:-1]
    pick = first[head]
    best_B = np.full(k_next, np.inf)
    best_M = np.full(k_next, np.inf)
    best_a = np.full(k_next, -1, dtype=np.intp)
    best_B[b[pick]], best_M[b[pick]], best_a[b[pick]] = brk[pick], cost[pick], a[pick]
    ratio = np.full(k_next, np.inf)
    joint = np.full(k_next, -1, dtype=np.intp)
    stuck = np.flatnonzero(~np.isfinite(best_M))
    if len(stuck) and len(live):  # the best step into each stuck candidate, from the live predecessors only
        _, _, _, ratio[stuck], joint[stuck] = _reduce(Q_prev[live], B_prev[live], M_prev[live], Q_next[stuck],
                                                      bound, weights, _renumbered(forbid, live, stuck), breaks)
    return best_B, best_M, best_a, ratio, joint


def _renumbered(forbid, rows: np.ndarray, columns: np.ndarray):
    """Forbidden edges ``(a, b)`` among predecessors ``rows`` and candidates ``columns``, numbered by their positions
    there (None when none is left)."""
    if forbid is None:
        return None
    size = int(max(forbid.max(), rows.max(initial=0), columns.max(initial=0))) + 1
    row_at, column_at = np.full(size, -1, dtype=np.intp), np.full(size, -1, dtype=np.intp)
    row_at[rows], column_at[columns] = np.arange(len(rows)), np.arange(len(columns))
    kept = forbid[(row_at[forbid[:, 0]] >= 0) & (column_at[forbid[:, 1]] >= 0)]
    return np.column_stack([row_at[kept[:, 0]], column_at[kept[:, 1]]]) if len(kept) else None


def solve_ladder(rungs, step_bounds, *, weights=None, penalties=None, forbidden=None, reconfigure: bool = False,
                 progress: Callable[[str, int, int], None] | None = None) -> LadderResult:
    """The least-cost path through the ladder's rungs (one candidate per rung), by dynamic programming.

    Parameters
    ----------
    rungs : sequence of array_like, each (k_i, n)
        The candidates of each waypoint, chain joint order (rad or m); a rung may be empty.
    step_bounds : array_like, shape (N - 1, n)
        The largest allowed ``|dq_j|`` between rung ``i`` and ``i + 1`` (rad or m; inf: no bound).
    weights : array_like, shape (n,), optional
        Cost weight of each joint's motion (default 1: the cost is the summed joint motion, rad or m).
    penalties : sequence of array_like, each (k_i,), optional
        A cost added for visiting each candidate (inf: the candidate is invalid).
    forbidden : dict of int to array_like of (a, b), optional
        Edges from candidate ``a`` of rung ``i`` to ``b`` of rung ``i + 1`` that are not allowed (found in
        collision, or leaving the path between waypoints).
    reconfigure : bool, keyword-only
        Allow breaks between rungs; minimise their number first, then the motion.
    progress : callable, optional
        ``progress("ladder", done, total)`` as rungs are solved.

    Returns
    -------
    LadderResult

    Examples
    --------
    >>> rungs = [[[0.0], [3.0]], [[0.1], [2.0]], [[0.2], [2.9]]]
    >>> result = solve_ladder(rungs, [[0.5], [0.5]])
    >>> result.feasible, result.choice.tolist(), round(result.cost, 12)
    (True, [0, 0, 0], 0.2)
    """
    # Over 80 lines: the forward pass, the failure record of a dead rung and the back-tracking belong together.
    arrays = [np.asarray(rung, dtype=float) for rung in rungs]
    N = len(arrays)
    widths = [a.shape[1] for a in arrays if a.ndim == 2 and a.shape[1]]
    n = widths[0] if widths else np.asarray(step_bounds).reshape(max(N - 1, 1), -1).shape[1] if N > 1 else 0
    Qs = _rung_arrays(arrays, n)
    bounds = np.asarray(step_bounds, dtype=float).reshape(max(N - 1, 0), n)
    w = np.ones(n) if weights is None else np.asarray(weights, dtype=float).reshape(n)
    pens = [np.zeros(len(Q)) if penalties is None else np.asarray(p, dtype=float).reshape(len(Q))
            for Q, p in zip(Qs, penalties if penalties is not None else [None] * N)]
    forbidden = {} if forbidden is None else forbidden
    if N == 0:
        return LadderResult(False, np.zeros(0, dtype=np.intp), float("inf"), (), (), 0, (), 0)
    M = np.where(np.isfinite(pens[0]), pens[0], np.inf)
    B = np.where(np.isfinite(M), 0.0, np.inf)
    back, broke, reached, blocked = [], [], [np.isfinite(M)], []
    first_dead = None if reached[0].any() else 0
    edges = 0
    every = max(1, (N - 1) // 100)
    for i in range(N - 1):
        Q_prev, Q_next = Qs[i], Qs[i + 1]
        edges += len(Q_prev) * len(Q_next)
        forbid = forbidden.get(i)
        forbid = None if forbid is None or len(forbid) == 0 else np.asarray(forbid, dtype=np.intp).reshape(-1, 2)
        if len(Q_prev) and len(Q_next):
            answer = _sparse_reduce(Q_prev, B, M, Q_next, bounds[i], w, forbid, reconfigure)
            if answer is None:
                answer = _reduce(Q_prev, B, M, Q_next, bounds[i], w, forbid, reconfigure)
            nb, nm, na, ratio, joint = answer
        else:
            k = len(Q_next)
            nb, nm, na = np.full(k, np.inf), np.full(k, np.inf), np.full(k, -1, dtype=np.intp)
            ratio, joint = np.full(k, np.inf), np.full(k, -1, dtype=np.intp)
        valid = np.isfinite(pens[i + 1])
        nm = nm + pens[i + 1]
        took_break = np.zeros(len(Q_next), dtype=bool)
        if reconfigure and np.isfinite(M).any() and len(Q_next):
            b0 = B[np.isfinite(M)].min()
            among = np.where(B == b0, M, np.inf)
            a0 = int(among.argmin())
            kb, km = b0 + 1.0, among[a0] + pens[i + 1]
            took_break = valid & ((kb < nb) | ((kb == nb) & (km < nm)))
            nb = np.where(took_break, kb, nb)
            nm = np.where(took_break, km, nm)
            na = np.where(took_break, a0, na)
        nm = np.where(valid, nm, np.inf)
        nb = np.where(np.isfinite(nm), nb, np.inf)
        stuck = valid & ~np.isfinite(nm)
        if stuck.any():
            blocked.append(StepBlock(i + 1, np.where(stuck, ratio, np.nan), np.where(stuck, joint, -1)))
        back.append(na)
        broke.append(took_break)
        B, M = nb, nm
        reached.append(np.isfinite(M))
        if first_dead is None and not reached[-1].any():
            first_dead = i + 1
        if progress is not None and ((i + 1) % every == 0 or i == N - 2):
            progress("ladder", i + 1, N - 1)
    if first_dead is not None:
        return LadderResult(False, np.full(N, -1, dtype=np.intp), float("inf"), (), tuple(reached), first_dead,
                            tuple(blocked), edges)
    last = np.where(B == B.min(), M, np.inf)
    j = int(last.argmin())
    cost = float(last[j])
    choice = np.empty(N, dtype=np.intp)
    breaks = []
    choice[-1] = j
    for i in range(N - 2, -1, -1):
        if broke[i][j]:
            breaks.append(i)
        j = int(back[i][j])
        choice[i] = j
    return LadderResult(True, choice, cost, tuple(sorted(breaks)), tuple(reached), None, tuple(blocked), edges)
