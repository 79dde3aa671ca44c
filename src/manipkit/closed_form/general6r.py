"""Every isolated IK solution of a general 6R chain by Raghavan-Roth elimination: :func:`prepare` and :func:`solve`.

The chain is given as a product of exponentials, ``g = E_1(t_1) ... E_6(t_6)``
(``g = T_base_tip M^-1``, ``M`` the tip pose at the reference configuration),
each ``E_i`` the rotation by ``t_i`` (rad, right-hand rule) about the line
through ``point[i]`` along the unit ``direction[i]`` (base frame, m). Any 6R
chain fits, Pieper or not; prismatic joints are not covered.

The elimination (Raghavan and Roth 1993, as reformulated by Manocha and Canny
1994), written in coordinate-free form:

1. Split the loop as ``E_4 E_5 = E_3^-1 E_2^-1 E_1^-1 g E_6^-1`` and apply it
   to ``x6``, a point on axis 6 (fixed by ``E_6``), and to axis 6's direction:
   ``p = E_4 E_5 x6 - o`` and ``l = R_4 R_5 h_6`` (``o`` a point on axis 3)
   equal ``E_3^-1 E_2^-1 E_1^-1 g x6 - o`` and ``R_3^T R_2^T R_1^T R_g h_6``.
2. The 14 Raghavan-Roth quantities ``p, l, p.p, p.l, p x l,
   (p.p) l - 2 (p.l) p`` are on each side trigonometric polynomials of
   degree at most one in each joint angle (the degree-two terms cancel by
   ``(b.u) w - (b.w) u = -b x (u x w)``). Their coefficients are found
   numerically, without symbolic algebra, by exact trigonometric
   interpolation (a 3-point DFT per joint) of the two sides evaluated on a
   grid: the joints 4-5 side once per chain (a constant ``14 x 9`` matrix
   ``P``), the joints 1-3 side per target from 27 grid poses kept per chain.
3. The 8 monomials of joints 4 and 5 are eliminated by the left null space
   ``N`` (6 x 14, once per chain) of ``P`` without its constant column: six
   equations of degree one in each of joints 1, 2, 3.
4. With half-angle tangents ``x_j = tan((t_j - phi_j) / 2)`` (a Moebius
   shift ``phi_j`` moves ``t = pi`` away from the roots), the six equations
   are biquadratic in two of the joints with coefficients quadratic in the
   third; the six and their products with ``x_a`` are 12 equations in the 12
   monomials ``x_a^i x_b^j`` (i <= 3, j <= 2): ``(M0 + M1 x + M2 x^2) u = 0``.
   Its determinant has degree 24 (16 roots and the factor ``(1 + x^2)^4``).
   Which joint is the eigenvalue is chosen per target by the conditioning of
   the matrix polynomial; the 24 x 24 pencil is solved as a generalized
   eigenproblem, so a singular ``M2`` (roots at infinity, as parallel axes
   give) is no special case.
5. Each real (or nearly real: a near-double root splits into a pair with a
   small imaginary part, kept) eigenvalue gives joints ``a`` and ``b`` from
   its eigenvector, joints 4 and 5 from the 14 equations (least squares),
   joint 6 from the remaining rotation; every candidate is polished by
   Newton steps on the product of exponentials and kept when its residual
   is below ``tol``; candidates that land on the same configuration are one.

Lengths are scaled by the arm's size inside (the equations mix m and m^2).
:func:`prepare` and :func:`solve` are the numpy reference (:func:`solve` polishes by the compiled
:func:`~manipkit.closed_form.newton_kernel.polish_rows` unless ``compiled=False``);
:func:`solve_targets` (and :func:`solve_way`, by default) runs every step of every way of a stack of targets
compiled by numba (:mod:`manipkit.closed_form.general6r_kernel`, its eigenvalues from
:mod:`manipkit.closed_form.eigen_kernel`; the same rows within rounding, tested). The caller
(:mod:`manipkit.ik.general6r`) maps angles to joint values and checks every row by the chain's own forward
kinematics.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from manipkit.errors import ClosedFormIKError

__all__ = ["WAYS", "General6R", "Roots", "poe_fk", "prepare", "prepared", "ranked_ways", "rr_sides", "solve", "solve_targets",
           "solve_way", "warm_up", "way_reason"]

TWO_PI = 2.0 * math.pi
_EYE3 = np.eye(3)
_GRID = np.array([0.0, TWO_PI / 3.0, 2.0 * TWO_PI / 3.0])
#: basis (1, cos t, sin t) at the three grid angles; its inverse interpolates one joint exactly
_V1 = np.stack([np.ones(3), np.cos(_GRID), np.sin(_GRID)], axis=1)
_V1_INV = np.linalg.inv(_V1)
_V2_INV = np.kron(_V1_INV, _V1_INV)
_V3_INV = np.kron(_V2_INV, _V1_INV)
#: Moebius shifts of the half-angle tangents (rad), irrational multiples of pi so t = pi + shift is no root by design
_SHIFTS = np.array([0.7390851332, -1.1141571408, 2.2360679775])
#: where the matrix polynomial's conditioning is measured, and the centre of the Moebius change of variable
_PROBE = 0.3183098862
#: (i, j) pairs of the 12 monomials x_a^i x_b^j
_COLUMNS = [(i, j) for i in range(4) for j in range(3)]


def _skew(k: np.ndarray) -> np.ndarray:
    """``[k]x`` (..., 3, 3) for vectors ``k`` (..., 3)."""
    K = np.zeros(k.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -k[..., 2], k[..., 1], -k[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = k[..., 2], -k[..., 1], k[..., 0]
    return K


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` over the last axis (np.cross without its axis handling: this runs in every solve)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _rotations(h: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``R(h, t) = cos t I + sin t [h]x + (1 - cos t) h h^T`` (..., 3, 3) for unit axes ``h`` (3,) or (n, 3) and
    angles ``t`` (...) broadcast against them (``t`` (..., n) with n axes: one rotation per axis)."""
    h = np.asarray(h, dtype=float)
    t = np.asarray(t, dtype=float)[..., None, None]
    c = np.cos(t)
    return c * _EYE3 + np.sin(t) * _skew(h) + (1.0 - c) * (h[..., :, None] * h[..., None, :])


def _motions(h: np.ndarray, p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``E(t)`` (..., 4, 4): the rotation by ``t`` about the line through ``p`` along ``h`` (one line, or n lines
    ``h``, ``p`` (n, 3) against ``t`` (..., n))."""
    R = _rotations(h, t)
    E = np.zeros(R.shape[:-2] + (4, 4))
    E[..., :3, :3] = R
    E[..., :3, 3] = p - (R @ p[..., None])[..., 0]
    E[..., 3, 3] = 1.0
    return E


def poe_fk(direction: np.ndarray, point: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``E_1(t_1) ... E_6(t_6)`` (..., 4, 4) for angles ``theta`` (..., 6): the product of exponentials."""
    theta = np.asarray(theta, dtype=float)
    n = theta.shape[-1]
    E = _motions(np.asarray(direction, dtype=float)[:n], np.asarray(point, dtype=float)[:n], theta)  # (..., n, 4, 4)
    G = E[..., 0, :, :]
    for i in range(1, theta.shape[-1]):
        G = G @ E[..., i, :, :]
    return G


def _foot(h_a: np.ndarray, p_a: np.ndarray, h_b: np.ndarray, p_b: np.ndarray) -> np.ndarray:
    """The point on line a nearest line b (its own point when they are parallel)."""
    n = _cross(h_a, h_b)
    nn = float(n @ n)
    if nn < 1e-12:
        return p_a.copy()
    return p_a + (_cross(p_b - p_a, h_b) @ n) / nn * h_a


def rr_sides(p: np.ndarray, line: np.ndarray) -> np.ndarray:
    """The 14 Raghavan-Roth quantities (..., 14) of ``p`` and ``l = line`` (..., 3): p, l, p.p, p.l, p x l,
    (p.p) l - 2 (p.l) p."""
    pp = np.sum(p * p, axis=-1, keepdims=True)
    pl = np.sum(p * line, axis=-1, keepdims=True)
    return np.concatenate([p, line, pp, pl, _cross(p, line), pp * line - 2.0 * pl * p], axis=-1)


@dataclass(frozen=True, eq=False)
class General6R:
    """What :func:`solve` needs of one chain, found once by :func:`prepare` (lengths divided by ``size``).

    ``h``, ``p`` (6, 3): axes and points (scaled); ``x6``, ``o``: the points on axes 6 and 3;
    ``P`` (14, 9): the joints 4-5 side in the basis ``(1, cos t4, sin t4) x (1, cos t5, sin t5)``;
    ``N`` (6, 14): the left null space of ``P[:, 1:]``; ``R_grid`` (27, 3, 3), ``b_grid`` (27, 3):
    ``(E_1 E_2 E_3)^-1`` on the interpolation grid of joints 1-3, so that the joints 1-3 side of a
    target is ``R_grid @ (g x6) + b_grid`` and ``R_grid @ (R_g h_6)``; ``rank``: the rank of ``P[:, 1:]``.
    """

    h: np.ndarray
    p: np.ndarray
    size: float
    origin: np.ndarray
    x6: np.ndarray
    o: np.ndarray
    P: np.ndarray
    N: np.ndarray
    R_grid: np.ndarray
    b_grid: np.ndarray
    rank: int


def prepare(direction, point) -> General6R:
    """The per-chain part of the elimination for axes ``direction`` (6, 3) and points ``point`` (6, 3) (base frame, m).

    Raises
    ------
    ClosedFormIKError
        Not six axes, or the joints 4-5 side does not eliminate (its 14 x 8 matrix has rank below 8:
        axes 4 and 5 parallel or in a special position; the reversed chain may serve).
    """
    h = np.array(direction, dtype=float).reshape(-1, 3)
    q = np.array(point, dtype=float).reshape(-1, 3)
    if h.shape != (6, 3) or q.shape != (6, 3) or not np.all(np.isfinite(h)) or not np.all(np.isfinite(q)):
        raise ClosedFormIKError(f"the general 6R solver takes 6 joint axes, got directions {np.shape(direction)}")
    h = h / np.linalg.norm(h, axis=1, keepdims=True)
    size = max(1e-3, float(np.max(np.linalg.norm(q - q.mean(axis=0), axis=1))))
    origin = q[0].copy()
    R_grid, b_unit, o_unit = _grid_123(h[:4], q[:4] - origin)
    q = (q - origin) / size  # origin on axis 1, unit size: every quantity O(1)
    x6 = _foot(h[5], q[5], h[4], q[4])
    o, b_grid = o_unit / size, b_unit / size  # translations are linear in the points
    t45 = np.array([(a, b) for a in _GRID for b in _GRID])  # (9, 2), joint 4 slow
    E = _motions(h[3], q[3], t45[:, 0]) @ _motions(h[4], q[4], t45[:, 1])
    pl = E[:, :3, :3] @ x6 + E[:, :3, 3] - o
    ll = E[:, :3, :3] @ h[5]
    P = (_V2_INV @ rr_sides(pl, ll)).T  # (14, 9)
    U, s, _ = np.linalg.svd(P[:, 1:])
    rank = int(np.sum(s > 1e-9 * s[0]))
    if rank < 8:
        raise ClosedFormIKError(f"the joints 4-5 side has rank {rank} < 8 (axes 4 and 5 in a special position)")
    N = U[:, 8:].T  # (6, 14)
    return General6R(h, q, size, origin, x6, o, P, N, R_grid, b_grid, rank)


def _grid_123(h: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(R_grid, b_grid, o) of :class:`General6R` before the division by the size, from axes 1-4 ``h``, ``q`` (4, 3)
    (points relative to axis 1's): kept per arrays (the 64 made last), since a shifted way (:func:`solve_way`) keeps
    axes 1-4 while its axes 5 and 6 move with every target."""
    key = (h.tobytes(), q.tobytes())
    grid = _GRIDS.get(key)
    if grid is not None:
        return grid
    o = _foot(h[2], q[2], h[3], q[3])
    t123 = np.array([(a, b, c) for a in _GRID for b in _GRID for c in _GRID])  # (27, 3), joint 1 slowest
    F = _motions(h[0], q[0], t123[:, 0]) @ _motions(h[1], q[1], t123[:, 1]) @ _motions(h[2], q[2], t123[:, 2])
    R_grid = np.transpose(F[:, :3, :3], (0, 2, 1))
    b_grid = -np.einsum("kij,kj->ki", R_grid, F[:, :3, 3]) - o
    grid = (R_grid, b_grid, o)
    for array in grid:
        array.setflags(write=False)
    if len(_GRIDS) >= 64:
        _GRIDS.pop(next(iter(_GRIDS)), None)
    _GRIDS[key] = grid
    return grid


#: (bytes of axes 1-4 and their points) -> their joints 1-3 grid (oldest dropped first).
_GRIDS: dict = {}


def prepared(direction, point) -> General6R:
    """:func:`prepare`, made once per distinct arrays and kept (the 64 made last): keyed on their bytes."""
    h = np.ascontiguousarray(direction, dtype=float)
    q = np.ascontiguousarray(point, dtype=float)
    key = (h.shape, h.tobytes(), q.shape, q.tobytes())
    arm = _PREPARED.get(key)
    if arm is None:
        arm = prepare(h, q)
        if len(_PREPARED) >= 64:
            _PREPARED.pop(next(iter(_PREPARED)), None)
        _PREPARED[key] = arm
    return arm


#: (shapes and bytes of direction and point) -> their General6R (oldest dropped first).
_PREPARED: dict = {}


def _scaled_target(arm: General6R, g: np.ndarray, origin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) of target ``g`` in the arm's scaled frame (origin on axis 1, lengths / size)."""
    R = g[:3, :3]
    t = (g[:3, 3] + R @ origin - origin) / arm.size
    return R, t


def _equations(arm: General6R, R: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the six equations (6, 27) in (1, c, s)^3 of joints 1-3, the joints 1-3 side Q (14, 27)) of a scaled target."""
    P6 = R @ arm.x6 + t
    L6 = R @ arm.h[5]
    right = rr_sides(arm.R_grid @ P6 + arm.b_grid, arm.R_grid @ L6)  # (27, 14)
    Q = (_V3_INV @ right).T  # (14, 27)
    Q[:, 0] -= arm.P[:, 0]
    return arm.N @ Q, Q


def _half_angle(coefficients: np.ndarray) -> np.ndarray:
    """(6, 27) in (1, c, s)^3 -> (6, 3, 3, 3) polynomial coefficients in the shifted half-angle tangents x1, x2, x3."""
    C = coefficients.reshape(-1, 3, 3, 3)
    for axis, phi in enumerate(_SHIFTS):
        a0, a1, a2 = np.moveaxis(C, axis + 1, 0)
        c, s = math.cos(phi), math.sin(phi)
        b1, b2 = a1 * c + a2 * s, -a1 * s + a2 * c  # in (1, cos t', sin t') of t' = t - phi
        C = np.moveaxis(np.stack([a0 + b1, 2.0 * b2, a0 - b1]), 0, axis + 1)  # times (1 + x^2)
    return C


def _pencil(K: np.ndarray, eigen: int, multiplied: int) -> np.ndarray:
    """(3, 12, 12) ``M0, M1, M2`` of the six equations ``K`` (6, 3, 3, 3) with ``eigen`` the eigenvalue's joint and
    ``multiplied`` the joint whose tangent multiplies the six (monomials ``x_a^i x_b^j``, a = multiplied)."""
    other = 3 - eigen - multiplied
    A = np.transpose(K, (0, 1 + multiplied, 1 + other, 1 + eigen))  # (6, a, b, power of eigen)
    M = np.zeros((3, 12, 12))
    for i in range(3):
        for j in range(3):
            for shift in (0, 1):
                M[:, 6 * shift:6 * shift + 6, 3 * (i + shift) + j] = A[:, i, j, :].T
    return M


def _conditioning(M: np.ndarray) -> float:
    """How far the matrix polynomial is from singular: the reciprocal condition number in the 1-norm,
    ``1 / (|L|_1 |L^-1|_1)``, of ``L = M(x)`` at a value of its variable (no root there but by coincidence); 0 when
    ``L`` is exactly singular. (Within a factor 12 of sigma_min / sigma_max; the compiled twin computes the same from
    the inverse it needs anyway.)"""
    L = M[0] + _PROBE * M[1] + _PROBE * _PROBE * M[2]
    try:
        inverse = np.linalg.inv(L)
    except np.linalg.LinAlgError:
        return 0.0
    return float(1.0 / (np.abs(L).sum(axis=0).max() * np.abs(inverse).sum(axis=0).max()))


@dataclass(frozen=True)
class Roots:
    """The solutions of one target: ``theta`` (k, 6) PoE angles (rad, wrapped to (-pi, pi]), ``residual`` (k,) the
    pose residual (scaled position + rotation) of each after polishing, ``candidates`` how many eigenvalues were
    tried, ``eigen`` the joint (0-based) taken as the eigenvalue, ``conditioning`` of its matrix polynomial."""

    theta: np.ndarray
    residual: np.ndarray
    candidates: int
    eigen: int
    conditioning: float


def _wrap(t: np.ndarray) -> np.ndarray:
    return np.pi - np.mod(np.pi - t, TWO_PI)


def _from_tangent(x: np.ndarray, joint: int) -> np.ndarray:
    return _SHIFTS[joint] + 2.0 * np.arctan(x)


def _ratio(u: np.ndarray, step: tuple[int, int]) -> np.ndarray:
    """x from monomial vectors u (k, 4, 3): least squares of u[i + di, j + dj] = x u[i, j] over the pairs."""
    di, dj = step
    num = u[:, di:, dj:] * np.conj(u[:, :4 - di, :3 - dj])
    den = np.abs(u[:, :4 - di, :3 - dj]) ** 2
    return np.real(num.sum(axis=(1, 2)) / np.maximum(den.sum(axis=(1, 2)), 1e-300))


def _joints_456(arm: General6R, Q: np.ndarray, theta123: np.ndarray, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(k, 6) from joints 1-3 (k, 3): joints 4, 5 from the 14 equations (least squares), joint 6 from the rest."""
    basis = np.stack([np.ones_like(theta123), np.cos(theta123), np.sin(theta123)], axis=-1)  # (k, 3, 3)
    X123 = np.einsum("ka,kb,kc->kabc", basis[:, 0], basis[:, 1], basis[:, 2]).reshape(-1, 27)
    rhs = X123 @ Q.T  # (k, 14): P[:, 1:] X45 = Q X123 (Q holds -P[:, 0] in its constant column)
    X45 = np.linalg.lstsq(arm.P[:, 1:], rhs.T, rcond=None)[0].T  # (k, 8): monomials 1..8 of (1, c4, s4) x (1, c5, s5)
    t4 = np.arctan2(X45[:, 5], X45[:, 2])  # (s4, 1) is monomial 6, (c4, 1) monomial 3
    t5 = np.arctan2(X45[:, 1], X45[:, 0])  # (1, s5) monomial 2, (1, c5) monomial 1
    theta = np.concatenate([theta123, t4[:, None], t5[:, None], np.zeros((len(t4), 1))], axis=1)
    G = np.eye(4)
    G[:3, :3], G[:3, 3] = R, t
    rest = np.linalg.inv(poe_fk(arm.h[:5], arm.p[:5], theta[:, :5])) @ G  # E_6 (k, 4, 4)
    h6 = arm.h[5]
    u = _cross(h6, np.eye(3)[int(np.argmin(np.abs(h6)))])
    u /= np.linalg.norm(u)
    v = rest[:, :3, :3] @ u
    theta[:, 5] = np.arctan2(_cross(u, v) @ h6, v @ u)
    return theta


#: (scaled m + rad) candidates starting farther than this from the target are dropped before Newton
_FAR = 0.5


def _polish(arm: General6R, G: np.ndarray, theta: np.ndarray, iterations: int) -> tuple[np.ndarray, np.ndarray]:
    """Newton steps on the (scaled) product of exponentials for every row of ``theta`` (k, 6); (theta, residual)."""
    h, p = arm.h, arm.p
    for _ in range(iterations + 1):
        frames = [np.broadcast_to(np.eye(4), (len(theta), 4, 4)).copy()]
        for i in range(6):
            frames.append(frames[-1] @ _motions(h[i], p[i], theta[:, i]))
        F = frames[-1]
        dR = G[:3, :3] @ np.transpose(F[:, :3, :3], (0, 2, 1))
        cos = (np.trace(dR, axis1=1, axis2=2) - 1.0) * 0.5
        w = np.stack([dR[:, 2, 1] - dR[:, 1, 2], dR[:, 0, 2] - dR[:, 2, 0], dR[:, 1, 0] - dR[:, 0, 1]], axis=1) * 0.5
        sin = np.linalg.norm(w, axis=1)
        angle = np.arctan2(sin, cos)  # not arccos: exact near 0
        omega = w * np.where(sin > 1e-12, angle / np.maximum(sin, 1e-300), 1.0)[:, None]
        dp = G[:3, 3] - F[:, :3, 3]
        residual = np.linalg.norm(dp, axis=1) + np.linalg.norm(omega, axis=1)
        if _ == 0:  # a start half the arm's size or half a radian away is no root of this target: not polished
            near = residual < _FAR
            if not near.all():
                theta, residual, dp, omega = theta[near], residual[near], dp[near], omega[near]
                frames = [frame[near] if frame.ndim == 3 and len(frame) == len(near) else frame for frame in frames]
                F = frames[-1]
        if _ == iterations or not len(theta) or residual.max() < 1e-13:
            break
        # spatial Jacobian at the tip point: columns (h_i x (tip - point_i), h_i) of the moved axes
        J = np.empty((len(theta), 6, 6))
        tip = F[:, :3, 3]
        for i in range(6):
            Ri, ti = frames[i][:, :3, :3], frames[i][:, :3, 3]
            hi = Ri @ h[i]
            pi = np.einsum("kij,j->ki", Ri, p[i]) + ti
            J[:, :3, i] = _cross(hi, tip - pi)
            J[:, 3:, i] = hi
        error = np.concatenate([dp, omega], axis=1)
        theta = theta + np.einsum("kij,kj->ki", np.linalg.pinv(J, rcond=1e-12), error)
    return _wrap(theta), residual


def _best_pencil(K: np.ndarray) -> tuple:
    """(conditioning, eigen, multiplied, M) of the best conditioned of the three pencils of the six equations K."""
    best = None
    for eigen, multiplied in ((2, 0), (0, 1), (1, 0)):
        M = _pencil(K, eigen, multiplied)
        score = _conditioning(M)
        if best is None or score > best[0]:
            best = (score, eigen, multiplied, M)
    return best


def _polished(arm: General6R, G: np.ndarray, theta: np.ndarray, iterations: int, compiled: bool):
    """:func:`_polish`, or its compiled twin (:func:`manipkit.closed_form.newton_kernel.polish_rows`)."""
    if not compiled:
        return _polish(arm, G, theta, iterations)
    from manipkit.closed_form.newton_kernel import polish_rows

    return polish_rows(arm.h, arm.p, G, theta, iterations=iterations, far=_FAR)


def solve(arm: General6R, g, *, tol: float = 1e-9, iterations: int = 6, imaginary: float = 1e-3,
          compiled: bool = True) -> Roots:
    """Every isolated solution ``theta`` (k, 6) of ``g = E_1(t_1) ... E_6(t_6)`` (4x4, the base frame of ``prepare``).

    Parameters
    ----------
    arm : General6R
        :func:`prepare` of the chain's axes.
    g : array_like, shape (4, 4)
        The wanted product of exponentials ``T M^-1`` (m).
    tol : float, keyword-only
        Largest residual (position in units of the arm's size plus rotation in rad) of a kept root after polishing.
    iterations : int, keyword-only
        Newton steps on every candidate.
    imaginary : float, keyword-only
        Eigenvalues with ``|Im x| <= imaginary (1 + |x|)`` are candidates (a near-double root's pair is kept).
    compiled : bool, keyword-only
        Polish the candidates by the compiled kernel (:mod:`manipkit.closed_form.newton_kernel`, numba,
        compiled on first use); False: by the numpy reference here (the same steps, within rounding).

    Returns
    -------
    Roots
        Distinct rows (to 1e-7 rad) in the order of their first joint; none when every candidate misses.

    Raises
    ------
    ClosedFormIKError
        The elimination is degenerate at this target (every matrix polynomial singular: a continuum of
        solutions or a special arm).
    """
    g = np.asarray(g, dtype=float)
    R, t = _scaled_target(arm, g, arm.origin)
    six, Q = _equations(arm, R, t)
    K = _half_angle(six)
    score, eigen, multiplied, M = _best_pencil(K)
    if not score > 1e-13:
        raise ClosedFormIKError(f"the elimination is degenerate at this target (conditioning {score:.2g}): "
                                "a continuum of solutions, or a special arm")
    # Moebius change of variable x = s + 1 / y: y^2 M(s + 1/y) = M(s) y^2 + (M1 + 2 s M2) y + M2, whose leading
    # matrix M(s) is the well-conditioned one the choice above measured; roots at x = infinity become y = 0
    s = _PROBE
    lead = M[0] + s * M[1] + s * s * M[2]
    inverse = np.linalg.inv(lead)
    companion = np.zeros((24, 24))
    companion[:12, 12:] = np.eye(12)
    companion[12:, :12] = -inverse @ M[2]
    companion[12:, 12:] = -inverse @ (M[1] + 2.0 * s * M[2])
    ys, vectors = np.linalg.eig(companion)
    finite = np.abs(ys) > 1e-8
    values = np.where(finite, s + 1.0 / np.where(finite, ys, 1.0), np.inf)
    near = finite & (np.abs(values.imag) <= imaginary * (1.0 + np.abs(values)))
    x = values[near].real
    u = vectors[:12, near].T  # (k, 12): the monomials x_a^i x_b^j
    u = u / u[np.arange(len(u)), np.argmax(np.abs(u), axis=1)][:, None]
    u = u.reshape(-1, 4, 3)
    xa, xb = _ratio(u, (1, 0)), _ratio(u, (0, 1))
    other = 3 - eigen - multiplied
    theta123 = np.empty((len(x), 3))
    theta123[:, eigen] = _from_tangent(x, eigen)
    theta123[:, multiplied] = _from_tangent(xa, multiplied)
    theta123[:, other] = _from_tangent(xb, other)
    G = np.eye(4)
    G[:3, :3], G[:3, 3] = R, t
    if len(x):
        theta = _joints_456(arm, Q, theta123, R, t)
        theta, residual = _polished(arm, G, theta, iterations, compiled)
        keep = residual <= tol
        theta, residual = theta[keep], residual[keep]
    else:
        theta, residual = np.zeros((0, 6)), np.zeros(0)
    order = np.lexsort(theta.T[::-1])
    theta, residual = theta[order], residual[order]
    same = np.all(np.abs(_wrap(theta[:, None, :] - theta[None, :, :])) <= 1e-7, axis=-1)
    first = ~np.any(np.tril(same, -1), axis=1)  # a row equal to an earlier one is that one
    rows, kept = theta[first], residual[first]
    return Roots(rows.reshape(-1, 6), kept, int(near.sum()), eigen, score)


#: The ways the loop can be eliminated: (shift, reverse). The loop ``E_1 ... E_6 = g`` is also
#: ``E_{k+1} ... E_6 F_1 ... F_k = g`` with ``F_i = g^-1 E_i g`` (the rotation about axis i moved by ``g^-1``), and
#: read tip to base ``E_6^-1 ... E_1^-1 = g^-1``: twelve eliminations, each with other joints on each side. Special
#: arms (axes 1, 2 meeting and 2, 3 parallel, as the xArm6 has) make some of them degenerate for every target.
WAYS = tuple((shift, reverse) for reverse in (False, True) for shift in range(6))


def _shifted(h: np.ndarray, p: np.ndarray, g: np.ndarray, shift: int, reverse: bool):
    """(directions, points, target) of the loop eliminated the way ``(shift, reverse)``."""
    if shift:
        gi = np.linalg.inv(g)
        h = np.concatenate([h[shift:], h[:shift] @ gi[:3, :3].T])
        p = np.concatenate([p[shift:], p[:shift] @ gi[:3, :3].T + gi[:3, 3]])
    if reverse:
        return -h[::-1], p[::-1], np.linalg.inv(g)
    return h, p, g


#: The interpolation grid, matrices, Moebius shifts and probe, as the compiled elimination takes them.
_CONSTANTS = (_GRID, np.ascontiguousarray(_V2_INV), np.ascontiguousarray(_V3_INV), _SHIFTS, _PROBE)


def way_reason(status: np.ndarray) -> str:
    """The ClosedFormIKError message of a way :func:`solve_targets` could not solve (its status row (4,))."""
    code, value = int(status[0]), float(status[1])
    if code == 1:
        return f"the joints 4-5 side has rank {int(value)} < 8 (axes 4 and 5 in a special position)"
    if code == 2:
        return (f"the elimination is degenerate at this target (conditioning {value:.2g}): a continuum of solutions, "
                "or a special arm")
    return "the eigenvalue iteration did not converge at this target"


@functools.lru_cache(maxsize=64)
def _way_array(ways: tuple) -> np.ndarray:
    """``ways`` ((shift, reverse), ...) as the (W, 2) int64 array the compiled elimination takes (kept; writable, as
    numba types a read-only array apart, but never written)."""
    return np.array([(shift, int(reverse)) for shift, reverse in ways], dtype=np.int64).reshape(-1, 2)


def solve_targets(direction, point, G, ways, *, tol: float = 1e-9, iterations: int = 6, imaginary: float = 1e-3,
                  poor: float = 0.0, threads: int = 1, block: int = 16) -> tuple:
    """Every isolated solution of each target ``G`` (n, 4, 4) of ``g = E_1 ... E_6`` by the ways ``ways`` (W, 2) in
    turn (the next one while the last solved is conditioned below ``poor``), compiled
    (:func:`manipkit.closed_form.general6r_kernel.solve_targets`): the steps of :func:`solve_way` for each way, with
    the options of :func:`solve`, in blocks of ``block`` targets on up to ``threads`` threads.

    Returns (rows (n, 24 W, 6) PoE angles in chain order wrapped to (-pi, pi], each way's rows sorted and distinct
    to 1e-7 rad, appended way after way; residual (n, 24 W); count (n,) rows written; status (n, W, 4): per way
    (0 solved, 1 rank below 8, 2 every pencil singular, 3 no convergence, -1 not tried; the rank or conditioning;
    candidates; the eigenvalue's joint)). Each target's numbers come from it alone: the same on any thread count.
    """
    from manipkit.closed_form.general6r_kernel import solve_targets as kernel
    from manipkit.kernels.blocks import run_blocks

    G = np.ascontiguousarray(np.asarray(G, dtype=float).reshape(-1, 4, 4))
    ways = _way_array(tuple((int(shift), bool(reverse)) for shift, reverse in ways))
    n, width = len(G), 24 * len(ways)
    rows, residual = np.zeros((n, width, 6)), np.zeros((n, width))
    count, status = np.zeros(n, dtype=np.int64), np.zeros((n, len(ways), 4))
    h = np.ascontiguousarray(direction, dtype=float)
    p = np.ascontiguousarray(point, dtype=float)

    def work(a: int, b: int) -> None:
        kernel(h, p, G[a:b], ways, _CONSTANTS, tol=tol, iterations=iterations, imaginary=imaginary, far=_FAR,
               poor=poor, rows=rows[a:b], res=residual[a:b], count=count[a:b], status=status[a:b])

    if n <= block or threads <= 1:
        work(0, n)  # one block, or one thread: no pool
    else:
        run_blocks(work, n, block=block, min_rows_per_thread=block, threads=threads, name="general6r")
    return rows, residual, count, status


def solve_way(direction, point, g, way: tuple[int, bool], *, compiled: bool = True, **options) -> Roots:
    """:func:`solve` of ``g = E_1 ... E_6`` (axes ``direction``, ``point`` (6, 3)) eliminated the way ``way``
    (:data:`WAYS`); angles in the chain's order. ClosedFormIKError when that way is degenerate here.

    ``compiled`` True: the whole elimination compiled (:func:`solve_targets`; the same steps, within rounding);
    False: the numpy reference (:func:`solve` with ``compiled=False``)."""
    if compiled:
        rows, residual, count, status = solve_targets(direction, point, np.asarray(g, dtype=float)[None], [way],
                                                      **options)
        if status[0, 0, 0] != 0:
            raise ClosedFormIKError(way_reason(status[0, 0]))
        k = int(count[0])
        return Roots(rows[0, :k].copy(), residual[0, :k].copy(), int(status[0, 0, 2]), int(status[0, 0, 3]),
                     float(status[0, 0, 1]))
    shift, reverse = way
    h, p, target = _shifted(np.asarray(direction, dtype=float), np.asarray(point, dtype=float),
                            np.asarray(g, dtype=float), shift, reverse)
    arm = prepared(h, p) if shift == 0 else prepare(h, p)  # a shifted way's axes move with the target
    roots = solve(arm, target, compiled=False, **options)
    theta = roots.theta[:, ::-1] if reverse else roots.theta
    theta = np.roll(theta, shift, axis=1)
    return Roots(theta, roots.residual, roots.candidates, roots.eigen, roots.conditioning)


def ranked_ways(direction, point, *, trials: int = 4, seed: int = 0) -> tuple[tuple[int, bool], ...]:
    """The ways (:data:`WAYS`) that eliminate this arm, best first: each solved for the poses of ``trials`` random
    configurations, kept when it finds every one of them, ranked by its worst conditioning (kept per arrays)."""
    h = np.ascontiguousarray(direction, dtype=float)
    p = np.ascontiguousarray(point, dtype=float)
    key = (h.tobytes(), p.tobytes(), trials, seed)
    cached = _RANKED.get(key)
    if cached is not None:
        return cached
    rng = np.random.default_rng(seed)
    thetas = rng.uniform(-np.pi, np.pi, (trials, 6))
    scores = []
    for way in WAYS:
        worst = np.inf
        for theta in thetas:
            try:
                roots = solve_way(h, p, poe_fk(h, p, theta), way)
            except ClosedFormIKError:
                worst = 0.0
                break
            if not len(roots.theta) or np.abs(_wrap(roots.theta - theta)).max(axis=1).min() > 1e-7:
                worst = 0.0
                break
            worst = min(worst, roots.conditioning)
        if worst > 0.0:
            scores.append((-worst * (10.0 if way[0] == 0 else 1.0), way))  # shift 0 is cheaper (kept prepared)
    ranked = tuple(way for *_, way in sorted(scores))
    if len(_RANKED) >= 64:
        _RANKED.pop(next(iter(_RANKED)), None)
    _RANKED[key] = ranked
    return ranked


#: (bytes of the arrays, trials, seed) -> their ranked ways.
_RANKED: dict = {}


def warm_up() -> None:
    """Compile (or load from the kernel cache) the compiled elimination (:func:`solve_targets`) and the numpy
    reference's compiled polishing, with the types the solvers pass (``make kernels``)."""
    from manipkit.closed_form.newton_kernel import warm_up as warm_polishing

    warm_polishing()
    rng = np.random.default_rng(0)
    h = rng.normal(size=(6, 3))
    p = rng.normal(size=(6, 3))
    solve_targets(h, p, poe_fk(h, p, rng.uniform(-3.0, 3.0, 6))[None], [(0, False)])
