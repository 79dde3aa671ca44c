"""The 6R closed forms on a chain's geometry, every branch at once, for many targets: :func:`solve_6r`.

An arm is its axes at a reference configuration (unit directions ``h``
and points ``p``, shape (6, 3), base frame) and the target is
``g = T_target M^-1`` (``M`` the tip pose at that configuration), so that
``E_1(t_1) ... E_6(t_6) = g`` with ``E_i`` the rotation by ``t_i`` about
axis ``i`` (the product of exponentials). Each family is a sequence of
Paden-Kahan subproblems (:mod:`manipkit.closed_form.subproblems`):

- spherical wrist, 2 || 3 (``"spherical wrist, two parallel"``): the wrist
  centre ``w = g c`` fixes ``t1`` (subproblem 4: its component along the
  turned axis 2 is the arm's lateral offset), ``t3`` (subproblem 3: its
  distance from axis 2) and ``t2`` (subproblem 1); the wrist rotation then
  gives ``t4, t5`` (subproblem 2) and ``t6`` (subproblem 1).
- 2 || 3 || 4 with 5 and 6 meeting (``"three parallel, two intersecting"``):
  ``t1`` from the point ``c`` where axes 5 and 6 meet (subproblem 4),
  ``t5`` from the component of ``R g h6`` along axis 2 (subproblem 4),
  ``t6`` (subproblem 1), then a planar 3R: ``t3`` (subproblem 3), ``t2``
  and ``t4`` (subproblem 1).
- spherical wrist, 1 and 2 meeting (``"spherical wrist, two intersecting"``):
  ``t3`` from the wrist centre's distance to the shoulder point
  (subproblem 3), ``t1, t2`` (subproblem 2), then the wrist.

The answer holds 8 slots per target, ``(shoulder, elbow, wrist)`` choices
``4 a + 2 b + c``; a slot is valid when every subproblem on its way was
exact. Where a subproblem's angle is free (a singular target) the slot
holds the representative with that angle 0 and ``free`` names the joint.
numpy only; the targets' leading axis is ``N``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manipkit.closed_form.subproblems import rotate, sp1, sp2, sp3, sp4

__all__ = ["ELBOW_TIE", "Branches", "rotation_matrix", "solve_6r"]

#: How close to the shoulder-wrist line (relative to their distance) an elbow counts as on it when branches are
#: named: "elbow up" on the compiled and the numpy path alike, since two branches meet there and the sign of a
#: rounding error would otherwise pick the name.
ELBOW_TIE = 1e-9

OPW = "spherical wrist, two parallel"
UR = "three parallel, two intersecting"
SPHERICAL_12 = "spherical wrist, two intersecting"
#: Relative size of a subproblem miss under which a branch is kept as ``near`` (refined on the chain, not exact).
NEAR = 1e-6
_EYE = np.eye(3)


@dataclass(frozen=True, eq=False)
class Branches:
    """Every branch of a 6R closed form for ``N`` targets.

    Attributes
    ----------
    theta : ndarray, shape (N, 8, 6)
        Angles (rad, about the reference axes, wrapped to (-pi, pi]).
    valid : ndarray of bool, shape (N, 8)
        Every subproblem on the slot's way had an exact answer (a repeated
        tangent answer counts once).
    free : ndarray of int, shape (N, 8)
        The 0-based joint whose angle is free at this target (-1: none);
        the slot holds the member with that angle 0.
    near : ndarray of bool, shape (N, 8)
        Valid, or missing only by a near tangency or a small inconsistency
        (below ``NEAR`` times the arm's size): a target just off a singular
        or boundary configuration. Worth refining on the chain; not exact.
    miss : dict of str to ndarray (N,)
        Per failing stage, how far the nearest branch misses: ``"shoulder"``
        (m: the wrist centre's offset from axis 1 the arm cannot take),
        ``"reach"`` (m: the wrist centre's distance from the shoulder the
        elbow cannot make), ``"orientation"`` (rad-like: the wrist cannot
        turn the tool there); 0 where the stage passed.
    """

    theta: np.ndarray
    valid: np.ndarray
    free: np.ndarray
    miss: dict
    near: np.ndarray


def rotation_matrix(k, theta) -> np.ndarray:
    """``R(k, theta)`` (..., 3, 3) for a unit axis ``k`` (3,) and angles ``theta`` (...).

    Examples
    --------
    >>> rotation_matrix(np.array([0.0, 0, 1]), np.pi / 2).round(12) + 0.0
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]])
    """
    theta = np.asarray(theta, dtype=float)[..., None, None]
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return _EYE + np.sin(theta) * K + (1.0 - np.cos(theta)) * (K @ K)


def _move(h, p, theta, x) -> np.ndarray:
    """``E(t) x``: the point ``x`` (..., 3) turned by ``theta`` (...) about the line through ``p`` along ``h``."""
    return p + rotate(h, theta, x - p)


def _perpendicular(h: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to ``h``."""
    other = _EYE[int(np.argmin(np.abs(h)))]
    v = np.cross(h, other)
    return v / np.linalg.norm(v)


def _mv(R, x) -> np.ndarray:
    """Matrix-vector products over leading axes."""
    return np.einsum("...ij,...j->...i", R, x)


def _count_valid(count: np.ndarray, slots: int = 2) -> np.ndarray:
    """(..., slots) bool: slot i is a distinct exact answer (a tangency fills slot 0 only; free: slot 0)."""
    index = np.arange(slots)
    finite = np.where(np.isinf(count), 1.0, count)
    return index < finite[..., None]


def _near_valid(answer, scale: float, slots: int = 2) -> np.ndarray:
    """Like :func:`_count_valid`, with slot 0 also kept where the subproblem missed by less than ``NEAR * scale``."""
    close = (answer.count == 0.0) & (answer.miss <= NEAR * scale)
    return _count_valid(answer.count, slots) | (close[..., None] & (np.arange(slots) == 0))


def _wrist(h, R_rem, tol) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Angles 4, 5, 6 of ``R4 R5 R6 = R_rem`` (..., 3, 3): (t4, t5, t6, valid, free4), each (..., 2)."""
    h4, h5, h6 = h[3], h[4], h[5]
    x = _mv(R_rem, h6)
    answer = sp2(h4, x, h5, h6, tol=tol)
    t4, t5 = -answer.theta[..., 0], answer.theta[..., 1]
    free4 = np.isinf(answer.count)[..., None] & np.array([True, False])
    v = _perpendicular(h6)
    turned = rotate(h5, -t5, rotate(h4, -t4, _mv(R_rem, v)[..., None, :]))
    t6, _, _ = sp1(h6, v, turned, tol=tol)
    return t4, t5, t6, _count_valid(answer.count), free4


def _stack(N: int, shape: tuple[int, ...], *angles) -> np.ndarray:
    return np.stack([np.broadcast_to(a, (N, *shape)) for a in angles], axis=-1)


def _opw(h, p, c, g, tol) -> Branches:
    """Spherical wrist at ``c`` and axes 2 || 3."""
    N = g.shape[0]
    R_g, t_g = g[:, :3, :3], g[:, :3, 3]
    w = _mv(R_g, c) + t_g  # (N, 3) the wrist centre
    first = sp4(h[1], h[0], w - p[0], h[1] @ (c - p[0]), tol=tol)
    t1 = -first.theta  # (N, 2): about -h1 back to the reference
    w1 = _move(h[0], p[0], -t1, w[:, None, :])  # (N, 2, 3) the wrist centre with t1 undone
    reach = np.linalg.norm(w1 - p[1], axis=-1)
    third = sp3(h[2], c - p[2], p[1] - p[2], reach, tol=tol)  # (N, 2, 2)
    t3 = third.theta
    elbow_c = _move(h[2], p[2], t3, c)  # (N, 2, 2, 3)
    t2, free2, miss2 = sp1(h[1], elbow_c - p[1], w1[:, :, None, :] - p[1], tol=tol)
    R123 = rotation_matrix(h[0], t1)[:, :, None] @ rotation_matrix(h[1], t2) @ rotation_matrix(h[2], t3)
    R_rem = np.swapaxes(R123, -1, -2) @ R_g[:, None, None]
    t4, t5, t6, wrist_ok, free4 = _wrist(h, R_rem, tol)  # (N, 2, 2, 2)
    shape = (2, 2, 2)
    theta = _stack(N, shape, t1[:, :, None, None], t2[..., None], t3[..., None], t4, t5, t6)
    scale = max(1.0, float(np.max(np.abs(p))) + float(np.linalg.norm(c)))
    ok1 = _count_valid(first.count)[:, :, None, None]
    ok3 = _count_valid(third.count)[..., None]
    ok2 = (miss2 <= 1e-9 * scale)[..., None]
    valid = ok1 & ok3 & ok2 & wrist_ok
    near = (_near_valid(first, scale)[:, :, None, None] & _near_valid(third, scale)[..., None]
            & (miss2 <= NEAR * scale)[..., None] & wrist_ok) | valid
    free = np.full((N, *shape), -1)
    free = np.where(free4, 3, free)
    free = np.where(free2[..., None], 1, free)
    free = np.where(np.isinf(first.count)[:, None, None, None] & (np.arange(2) == 0)[None, :, None, None], 0, free)
    miss = _misses(N, first, third, wrist_ok, valid, ok1 & ok3 & ok2)
    return Branches(theta.reshape(N, 8, 6), valid.reshape(N, 8), free.reshape(N, 8), miss, near.reshape(N, 8))


def _misses(N, first, third, wrist_ok, valid, arm_ok) -> dict:
    """How far each stage misses, for the targets where it fails (0 elsewhere)."""
    shoulder = np.where(first.count == 0.0, first.miss, 0.0)
    reach_fail = (first.count != 0.0) & ~np.any(_count_valid(third.count).reshape(N, -1), axis=-1)
    reach = np.where(reach_fail, np.min(third.miss.reshape(N, -1), axis=-1), 0.0)
    wrist_fail = np.any(arm_ok.reshape(N, -1), axis=-1) & ~np.any(valid.reshape(N, -1), axis=-1)
    return {"shoulder": shoulder, "reach": reach, "orientation": np.where(wrist_fail, 1.0, 0.0)}


def _ur(h, p, c, g, tol) -> Branches:
    """Axes 2 || 3 || 4; axes 5 and 6 meet at ``c``."""
    N = g.shape[0]
    R_g = g[:, :3, :3]
    w = _mv(R_g, c) + g[:, :3, 3]
    first = sp4(h[1], h[0], w - p[0], h[1] @ (c - p[0]), tol=tol)
    t1 = -first.theta  # (N, 2)
    R1 = rotation_matrix(h[0], t1)  # (N, 2, 3, 3)
    R1t_Rg = np.swapaxes(R1, -1, -2) @ R_g[:, None]
    fifth = sp4(h[1], h[4], h[5], _mv(R1t_Rg, h[5]) @ h[1], tol=tol)  # (N, 2, 2)
    t5 = fifth.theta
    source = rotate(h[4], -t5, h[1])  # (N, 2, 2, 3) = R5^T h2
    wanted = _mv(np.swapaxes(R1t_Rg, -1, -2), h[1])[:, :, None, :]  # R_g^T R1 h2
    minus6, free6, _ = sp1(h[5], source, wanted, tol=tol)
    t6 = np.where(free6, _ur_free_sixth(h, p, g, t1), -minus6) if free6.any() else -minus6
    # the axis-4 point moved by g' = E1^-1 g E6^-1 E5^-1 = E2 E3 E4
    x = _move(h[5], p[5], -t6, _move(h[4], p[4], -t5, p[3]))  # (N, 2, 2, 3)
    y = _move(h[0], p[0], -t1[:, :, None], _mv(R_g[:, None, None], x) + g[:, None, None, :3, 3])
    third = sp3(h[2], p[3] - p[2], p[1] - p[2], np.linalg.norm(y - p[1], axis=-1), tol=tol)  # (N, 2, 2, 2)
    t3 = third.theta
    elbow = _move(h[2], p[2], t3, p[3])  # (N, 2, 2, 2, 3)
    t2, free2, miss2 = sp1(h[1], elbow - p[1], y[..., None, :] - p[1], tol=tol)
    R4 = (np.swapaxes(rotation_matrix(h[1], t2) @ rotation_matrix(h[2], t3), -1, -2)
          @ R1t_Rg[:, :, None, None]
          @ np.swapaxes(rotation_matrix(h[4], t5) @ rotation_matrix(h[5], t6), -1, -2)[..., None, :, :])
    v = _perpendicular(h[3])
    t4, _, _ = sp1(h[3], v, _mv(R4, v), tol=tol)
    scale = max(1.0, float(np.max(np.abs(p))) + float(np.linalg.norm(c)))
    ok = (_count_valid(first.count)[:, :, None, None] & _count_valid(fifth.count)[..., None]
          & _count_valid(third.count) & (miss2 <= 1e-9 * scale))
    near = (_near_valid(first, scale)[:, :, None, None] & _near_valid(fifth, scale)[..., None]
            & _near_valid(third, scale) & (miss2 <= NEAR * scale)) | ok
    shape = (2, 2, 2)  # (t1, t5, t3) choices here; reordered to (shoulder, elbow, wrist) below
    theta = _stack(N, shape, t1[:, :, None, None], t2, t3, t4, t5[..., None], t6[..., None])
    free = np.full((N, *shape), -1)
    free = np.where(free6[..., None], 5, free)
    free = np.where(free2, 1, free)
    free = np.where(np.isinf(first.count)[:, None, None, None] & (np.arange(2) == 0)[None, :, None, None], 0, free)
    order = (0, 2, 1)
    theta, ok, free, near = (np.transpose(a, (0, *(1 + i for i in order), *range(4, a.ndim)))
                             for a in (theta, ok, free, near))
    shoulder = np.where(first.count == 0.0, first.miss, 0.0)
    wrist_fail = (first.count != 0.0) & ~np.any(_count_valid(fifth.count).reshape(N, -1), axis=-1)
    reach_fail = ~wrist_fail & (first.count != 0.0) & ~np.any(ok.reshape(N, -1), axis=-1)
    miss = {"shoulder": shoulder,
            "reach": np.where(reach_fail, np.min(third.miss.reshape(N, -1), axis=-1), 0.0),
            "orientation": np.where(wrist_fail, np.min(fifth.miss.reshape(N, -1), axis=-1), 0.0)}
    return Branches(theta.reshape(N, 8, 6), ok.reshape(N, 8), free.reshape(N, 8), miss, near.reshape(N, 8))


def _ur_free_sixth(h, p, g, t1) -> np.ndarray:
    """A member of the family when axis 6 lies along axes 2, 3, 4 (t5 = 0, t6 free): the t6 (N, 2, 1) that puts the
    axis-4 point at the middle of the elbow's reach, so the representative exists (t6 = 0 may be out of reach)."""
    o3 = p[2] + ((p[3] - p[2]) @ h[2]) * h[2]  # centre and radius of the circle axis 4's point makes about axis 3
    rho = np.linalg.norm(p[3] - o3)
    middle = (o3 - p[1]) @ (o3 - p[1]) + rho * rho
    a = _move(h[0], p[0], -t1, (_mv(g[:, :3, :3], p[5]) + g[:, :3, 3])[:, None, :]) - p[1]  # (N, 2, 3)
    R1 = rotation_matrix(h[0], -t1)
    b = _mv(R1 @ g[:, None, :3, :3], p[3] - p[5])  # y - p2 = a + R1^T R_g R(h6, -t6) (p4 - p6)
    # |a + R R6^T b0|^2 = |a|^2 + |b0|^2 + 2 (R^T a) . R(h6, -t6) (p4 - p6): subproblem 4 in -t6
    c = _mv(np.swapaxes(R1 @ g[:, None, :3, :3], -1, -2), a)
    d = 0.5 * (middle - np.sum(a * a, axis=-1) - np.sum(b * b, axis=-1))
    answer = sp4(c, h[5], p[3] - p[5], d)
    return -answer.theta[..., :1]


def _spherical_12(h, p, c, s, g, tol) -> Branches:
    """Spherical wrist at ``c``; axes 1 and 2 meet at ``s``."""
    N = g.shape[0]
    R_g = g[:, :3, :3]
    w = _mv(R_g, c) + g[:, :3, 3]
    third = sp3(h[2], c - p[2], s - p[2], np.linalg.norm(w - s, axis=-1), tol=tol)  # (N, 2)
    t3 = third.theta
    u = _move(h[2], p[2], t3, c) - s  # (N, 2, 3)
    pair = sp2(h[1], u, h[0], (w - s)[:, None, :], tol=tol)  # (N, 2 elbow, 2 shoulder, 2)
    t2, t1 = pair.theta[..., 0], -pair.theta[..., 1]
    t1, t2 = np.swapaxes(t1, 1, 2), np.swapaxes(t2, 1, 2)  # (N, shoulder, elbow)
    t3b = np.broadcast_to(t3[:, None, :], t1.shape)
    R123 = rotation_matrix(h[0], t1) @ rotation_matrix(h[1], t2) @ rotation_matrix(h[2], t3b)
    R_rem = np.swapaxes(R123, -1, -2) @ R_g[:, None, None]
    t4, t5, t6, wrist_ok, free4 = _wrist(h, R_rem, tol)
    shape = (2, 2, 2)
    theta = _stack(N, shape, t1[..., None], t2[..., None], t3b[..., None], t4, t5, t6)
    pair_ok = np.swapaxes(_count_valid(pair.count), 1, 2)  # (N, shoulder, elbow)
    free_pair = np.swapaxes(np.isinf(pair.count)[..., None] & (np.arange(2) == 0), 1, 2)
    arm_ok = (pair_ok & _count_valid(third.count)[:, None, :])[..., None]
    valid = arm_ok & wrist_ok
    free = np.where(free4, 3, -1)
    free = np.where(free_pair[..., None] & np.array([True, False]), 0, free)
    reach_fail = ~np.any(_count_valid(third.count), axis=-1)
    wrist_fail = np.any(arm_ok.reshape(N, -1), axis=-1) & ~np.any(valid.reshape(N, -1), axis=-1)
    miss = {"shoulder": np.where(~reach_fail & ~np.any(arm_ok.reshape(N, -1), axis=-1), np.max(pair.miss.reshape(N, -1), axis=-1), 0.0),
            "reach": np.where(reach_fail, third.miss, 0.0),
            "orientation": np.where(wrist_fail, 1.0, 0.0)}
    return Branches(theta.reshape(N, 8, 6), valid.reshape(N, 8), free.reshape(N, 8), miss, valid.reshape(N, 8))


def solve_6r(kind: str, h: np.ndarray, p: np.ndarray, g: np.ndarray, points: dict, *, tol: float = 1e-12) -> Branches:
    """Every branch of the 6R closed form ``kind`` for targets ``g`` (N, 4, 4) on axes ``h``, ``p`` (6, 3).

    ``points``: ``"wrist"`` (the spherical wrist's centre, or where axes 5
    and 6 meet) and, for ``"spherical wrist, two intersecting"``,
    ``"shoulder"`` (where axes 1 and 2 meet). ``tol``: the subproblems'
    zero (degenerate rotations, tangencies).
    """
    g = np.asarray(g, dtype=float).reshape(-1, 4, 4)
    if kind == OPW:
        return _opw(h, p, points["wrist"], g, tol)
    if kind == UR:
        return _ur(h, p, points["wrist"], g, tol)
    if kind == SPHERICAL_12:
        return _spherical_12(h, p, points["wrist"], points["shoulder"], g, tol)
    raise ValueError(f"no 6R closed form for the family {kind!r}")
