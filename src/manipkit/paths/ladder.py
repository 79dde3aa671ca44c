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
proves there is none: rung by rung, each candidate's best predecessor is
found by a compiled loop over the edges that can pass
(:mod:`manipkit.paths.ladder_kernel`: the next rung sorted by its most
selective joint, each predecessor's window of allowed steps found by binary
search), no edge kept; only the costs so far and the back-pointers are kept
(memory ``O(sum k_i)``, not the ``O(sum k_i k_{i+1})`` edges a stored graph
holds). The answer is optimal for the stated cost over the candidates
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

#: The windows of steps that can pass (by the most selective joint) are searched pair by pair when they hold at most
#: this share of a rung's pairs; above it, every pair is.
SPARSE_SHARE = 0.25


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
    """Per candidate of the next rung: best (breaks, motion, predecessor) over allowed edges, and, for those with
    none, the best ratio and its joint over reached predecessors: the compiled
    :func:`manipkit.paths.ladder_kernel.reduce_rung` (windows of steps that can pass when they hold at most
    :data:`SPARSE_SHARE` of the pairs)."""
    from manipkit.paths.ladder_kernel import reduce_rung_kernel

    k_next = len(Q_next)
    keys = np.zeros(0, dtype=np.int64) if forbid is None else np.unique(
        forbid[:, 0].astype(np.int64) * k_next + forbid[:, 1])
    out = (np.empty(k_next), np.empty(k_next), np.empty(k_next, dtype=np.intp), np.empty(k_next),
           np.empty(k_next, dtype=np.intp))
    reduce_rung_kernel()(np.ascontiguousarray(Q_prev), B_prev, M_prev, np.ascontiguousarray(Q_next),
                         np.ascontiguousarray(bound), np.ascontiguousarray(weights), keys, bool(breaks),
                         float(SPARSE_SHARE), *out)
    return out


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
            nb, nm, na, ratio, joint = _reduce(Q_prev, B, M, Q_next, bounds[i], w, forbid, reconfigure)
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
