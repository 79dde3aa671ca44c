"""The 6R closed form "spherical wrist, two intersecting" of :mod:`manipkit.closed_form.arms`, compiled.

The same sequence as the numpy reference (``arms._spherical_12``): ``t3``
from the wrist centre's distance to the shoulder point (subproblem 3),
``t1, t2`` (subproblem 2: subproblem 4, then 1), then the wrist ``t4, t5``
(subproblem 2) and ``t6`` (subproblem 1), on scalars and 3-tuples
(:mod:`manipkit.closed_form.subproblems_kernel`), every branch in the same
slot (``4 shoulder + 2 elbow + wrist``). It is the 6R arm a Panda, FR3 or
xArm7 leaves with its last joint locked, solved at every value of the sweep
of its ranked set (:mod:`manipkit.ik.redundant`).

Like the other compiled closed forms it answers generic targets only: a
target where a decision of the reference comes near its threshold (a
tangency, a degenerate or free angle, subproblem 2's acceptance of a pair)
is handed back and solved by the numpy reference, so the answer is the reference's
everywhere. Importing this module imports numba.
"""

from __future__ import annotations

import numpy as np

from manipkit.closed_form.subproblems_kernel import (
    MARGIN,
    add,
    atan2,
    compile_kernel,
    dot,
    move,
    mv,
    norm,
    perpendicular,
    rotate,
    row,
    sp1,
    sp3,
    sp4,
    sub,
)

__all__ = ["solve_spherical_12_many", "solve_target", "warm_up"]

#: A subproblem-2 pair missing by more (relative to its vector's length) is left to the reference, which accepts up
#: to sqrt(1e-12) = 1e-6: every pair kept here is far inside that.
PAIR_MISS = 1e-9


@compile_kernel
def _back(h0, h1, h2, c1, s1, c2, s2, c3, s3, x):
    """``R3^T R2^T R1^T x`` with ``R1^T = R(h0, -t1)`` given as (c1, s1) = cos, sin of ``-t1``; (c2, s2), (c3, s3)
    the cosine and sine of ``t2``, ``t3``."""
    return rotate(h2, c3, -s3, rotate(h1, c2, -s2, rotate(h0, c1, s1, x)))


@compile_kernel
def solve_target(H, P, c, s, R, t, theta, valid, miss, wanted):
    """One target ``g = (R, t)`` into theta (8, 6), valid (8,) and miss (3,): the reference's misses (shoulder and
    reach in m, orientation 1 or 0) where no branch exists, else 0; True when the reference must answer it.
    ``wanted`` >= 0: only that slot's angles are written (every slot is still solved and decided, so ``valid``,
    ``miss`` and the answer are the same; the other slots' angles are left out)."""
    # Over 80 lines: the whole sequence of one target, kept in one place so the slots read as the reference's.
    h0, h1, h2, h3, h4, h5 = row(H, 0), row(H, 1), row(H, 2), row(H, 3), row(H, 4), row(H, 5)
    p2 = row(P, 2)
    for k in range(8):
        valid[k] = False
    for k in range(3):
        miss[k] = 0.0
    w = add(mv(R, c), t)
    ws = sub(w, s)
    ca, sa, cb, sb, count3, miss3, unsure = sp3(h2, sub(c, p2), sub(s, p2), norm(ws))
    if unsure:
        return True
    if count3 == 0.0:  # out of reach: no branch, the reference's reach miss
        miss[1] = miss3
        return False
    _, _, size_ws, _ = sp1(h0, ws, ws)
    if size_ws <= MARGIN * max(1.0, norm(ws)):  # the wrist centre on axis 1: t1 free there
        return True
    Rh6 = mv(R, h5)
    v = perpendicular(h5)
    Rv = mv(R, v)
    any_valid, arm_any, shoulder = False, False, 0.0
    for e in range(2):
        c3, s3 = (ca, sa) if e == 0 else (cb, sb)
        u = sub(move(h2, p2, c3, s3, c), s)
        a1, b1, a2, b2, count2, miss2, unsure = sp4(h0, h1, u, dot(h0, ws))
        if unsure:
            return True
        if count2 == 0.0:  # the shoulder misses: the best pair's gap, as subproblem 2 measures it
            _, _, _, miss_a = sp1(h0, ws, rotate(h1, a1, b1, u))
            _, _, _, miss_b = sp1(h0, ws, rotate(h1, a2, b2, u))
            shoulder = max(shoulder, max(min(miss_a, miss_b), miss2))
            continue
        arm_any = True
        size_u = max(1.0, norm(u))
        for a in range(2):  # the shoulder: the pair of subproblem 2
            c2, s2 = (a1, b1) if a == 0 else (a2, b2)
            cq, sq, _, gap = sp1(h0, ws, rotate(h1, c2, s2, u))
            if gap > PAIR_MISS * size_u:
                return True
            # t1 = -(the angle of R(h0, .) ws = R(h1, t2) u): R1^T = R(h0, -t1) turns by that angle (cq, sq)
            x = _back(h0, h1, h2, cq, sq, c2, s2, c3, s3, Rh6)
            rv = _back(h0, h1, h2, cq, sq, c2, s2, c3, s3, Rv)
            a4, b4, a5, b5, count4, _, unsure = sp4(h4, h3, x, dot(h4, h5))
            if unsure:
                return True
            if count4 == 0.0:
                continue
            size_x = max(1.0, norm(x))
            for b in range(2):  # the wrist: the pair of subproblem 2
                c4, s4 = (a4, b4) if b == 0 else (a5, b5)
                c5, s5, size5, miss5 = sp1(h4, h5, rotate(h3, c4, s4, x))
                if size5 <= MARGIN or miss5 > PAIR_MISS * size_x:
                    return True
                # t4 = -(the angle about h4), t5 = the angle about h5: R5^T R4^T turns by (c5, -s5) after (c4, s4)
                turned = rotate(h4, c5, -s5, rotate(h3, c4, s4, rv))
                c6, s6, _, _ = sp1(h5, v, turned)
                slot = 4 * a + 2 * e + b
                valid[slot] = True
                any_valid = True
                if wanted >= 0 and slot != wanted:
                    continue
                theta[slot, 0] = atan2(-sq, cq)
                theta[slot, 1] = atan2(s2, c2)
                theta[slot, 2] = atan2(s3, c3)
                theta[slot, 3] = atan2(-s4, c4)
                theta[slot, 4] = atan2(s5, c5)
                theta[slot, 5] = atan2(s6, c6)
    if not any_valid:
        if arm_any:
            miss[2] = 1.0  # the arm is solved and the wrist rotation is not reached
        else:
            miss[0] = shoulder
    return False


@compile_kernel
def _solve_all(H, P, c, s, G, theta, valid, miss, fallback):
    """Every target ``G[i]`` by :func:`solve_target`: theta (N, 8, 6), valid (N, 8), miss (N, 3), fallback (N,)."""
    for i in range(G.shape[0]):
        fallback[i] = solve_target(H, P, c, s, G[i, :3, :3], (G[i, 0, 3], G[i, 1, 3], G[i, 2, 3]), theta[i], valid[i],
                              miss[i], -1)


def solve_spherical_12_many(h: np.ndarray, p: np.ndarray, wrist: np.ndarray, shoulder: np.ndarray, g: np.ndarray
                            ) -> tuple[np.ndarray, np.ndarray, dict, np.ndarray]:
    """Every branch of the family for targets ``g`` (N, 4, 4) on axes ``h``, ``p`` (6, 3), the wrist centre
    ``wrist`` and the point ``shoulder`` where axes 1 and 2 meet (3,), in the solve frame.

    Returns ``(theta, valid, miss, fallback)``: theta (N, 8, 6) rad (NaN where not valid), valid (N, 8), miss the
    reference's ``miss`` (``"shoulder"``, ``"reach"``, ``"orientation"``: each (N,)), and fallback (N,): the
    targets the numpy reference must answer (their rows here are not valid). Elsewhere theta, valid and miss are
    the reference's (``arms.solve_6r``) to rounding, ``near`` equals valid and no angle is free.
    """
    G = np.ascontiguousarray(g, dtype=float).reshape(-1, 4, 4)
    N = len(G)
    theta = np.full((N, 8, 6), np.nan)
    valid = np.zeros((N, 8), dtype=bool)
    fallback = np.zeros(N, dtype=bool)
    miss = np.zeros((N, 3))
    _solve_all(np.ascontiguousarray(h, dtype=float), np.ascontiguousarray(p, dtype=float),
               tuple(float(x) for x in wrist), tuple(float(x) for x in shoulder), G, theta, valid, miss, fallback)
    theta[~valid] = np.nan
    return theta, valid, {"shoulder": miss[:, 0], "reach": miss[:, 1], "orientation": miss[:, 2]}, fallback


def warm_up() -> None:
    """Compile the loop (or load it from the kernels' cache) on a made-up arm (``make kernels``)."""
    h = np.array([[0, 0, 1], [0, 1, 0], [0, 1, 0], [0, 0, 1], [0, 1, 0], [0, 0, 1]], dtype=float)
    p = np.array([[0, 0, 0], [0, 0, 0], [0, 0, 0.3], [0, 0, 0.7], [0, 0, 0.7], [0, 0, 0.7]], dtype=float)
    g = np.eye(4)[None].repeat(2, axis=0)
    g[:, :3, 3] = (0.2, 0.1, 0.2)
    solve_spherical_12_many(h, p, np.array([0.0, 0.0, 0.7]), np.zeros(3), g)
