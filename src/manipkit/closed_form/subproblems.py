"""The Paden-Kahan subproblems: the rotations every geometric closed form is built from.

Each subproblem asks for the angle(s) of a rotation about a unit axis
``k`` through the origin (a point on an axis is subtracted by the caller):

- :func:`sp1` -- rotate ``p`` onto ``q``: one angle.
- :func:`sp2` -- rotate ``p1`` about ``k1`` and ``p2`` about ``k2`` to a
  common vector: ``R(k1, t1) p1 = R(k2, t2) p2``, up to two pairs.
- :func:`sp3` -- rotate ``p1`` to a distance ``delta`` from ``p2``:
  ``|R(k, t) p1 - p2| = delta``, up to two angles.
- :func:`sp4` -- rotate ``p`` into a plane: ``h . R(k, t) p = d``, up to
  two angles.

Rotations follow the right-hand rule, ``R(k, t) p = cos t p + sin t (k x p)
+ (1 - cos t) (k . p) k`` (Rodrigues). Every function takes arrays with any
leading axes ``(...)`` (broadcast together) so a batch of targets is solved
at once; angles are wrapped to (-pi, pi].

Each returns an :class:`Answer`: the angles, how many there are (0, 1, 2,
or ``inf`` where the angle is free), and the residual of the best angle
when there is no exact one (the least-squares answer, so callers can say
by how much a target misses). ``tol`` decides when a quantity counts as
zero (a degenerate rotation) or a tangency (one double root).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Answer", "cross", "rotate", "sp1", "sp2", "sp3", "sp4"]

TOL = 1e-12


@dataclass(frozen=True)
class Answer:
    """Solutions of a subproblem over targets ``(...)``.

    Attributes
    ----------
    theta : ndarray, shape (..., 2) or (..., 2, 2)
        The angles (rad, wrapped to (-pi, pi]); slot 1 repeats slot 0 when
        there is one angle; where there is none, the least-squares angle(s).
        :func:`sp2` gives pairs ``(..., 2, 2)``: ``[..., i] = (t1, t2)``.
    count : ndarray of float, shape (...)
        0, 1 or 2 exact angles (pairs), ``inf`` when the angle is free
        (every value solves it; ``theta`` then holds 0).
    miss : ndarray, shape (...)
        0 where exact, else by how much the best angle misses (the
        subproblem's own measure: a distance in m, or for :func:`sp4` the
        gap in ``h . R p`` in the units of ``d``).
    """

    theta: np.ndarray
    count: np.ndarray
    miss: np.ndarray


def rotate(k, theta, p) -> np.ndarray:
    """``R(k, theta) p`` by Rodrigues' formula, broadcast over leading axes (k, p: (..., 3); theta: (...)).

    Examples
    --------
    >>> rotate([0, 0, 1], np.pi / 2, [1, 0, 0]).round(12) + 0.0
    array([0., 1., 0.])
    """
    k, p = np.asarray(k, dtype=float), np.asarray(p, dtype=float)
    theta = np.asarray(theta, dtype=float)[..., None]
    kp = np.sum(k * p, axis=-1, keepdims=True)
    return np.cos(theta) * p + np.sin(theta) * cross(k, p) + (1.0 - np.cos(theta)) * kp * k


def _dot(a, b) -> np.ndarray:
    return np.sum(a * b, axis=-1)


def cross(a, b) -> np.ndarray:
    """``a x b`` over leading axes (broadcast), without ``np.cross``'s axis shuffling (a few times faster on small arrays).

    Examples
    --------
    >>> cross(np.array([1.0, 0, 0]), np.array([0.0, 1, 0]))
    array([0., 0., 1.])
    """
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack(np.broadcast_arrays(a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), axis=-1)


def _wrap(theta) -> np.ndarray:
    return np.pi - np.mod(np.pi - theta, 2.0 * np.pi)


def sp1(k, p, q, *, tol: float = TOL) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Subproblem 1: the angle ``t`` with ``R(k, t) p = q``.

    Returns ``(theta, free, miss)``, each shape ``(...)``: the angle (the
    least-squares one, minimising ``|R p - q|``, when no angle is exact);
    ``free`` True where ``p`` lies on the axis (every angle does the same,
    ``theta`` 0); ``miss`` the distance ``|R(k, t) p - q|`` left.

    Examples
    --------
    >>> theta, free, miss = sp1([0, 0, 1], [1, 0, 0], [0, 1, 0])
    >>> float(theta.round(12)), bool(free), float(miss.round(12))
    (1.570796326795, False, 0.0)
    """
    k, p, q = (np.asarray(v, dtype=float) for v in (k, p, q))
    p_perp = p - _dot(k, p)[..., None] * k
    q_perp = q - _dot(k, q)[..., None] * k
    free = np.linalg.norm(p_perp, axis=-1) <= tol
    theta = np.where(free, 0.0, np.arctan2(_dot(k, cross(p_perp, q_perp)), _dot(p_perp, q_perp)))
    miss = np.linalg.norm(rotate(k, theta, p) - q, axis=-1)
    return theta, free, miss


def sp4(h, k, p, d, *, tol: float = TOL) -> Answer:
    """Subproblem 4: the angles ``t`` with ``h . R(k, t) p = d`` (rotate ``p`` into the plane ``h . x = d``).

    ``h . R p = A cos t + B sin t + c`` with ``A = h . p_perp``,
    ``B = h . (k x p)``, ``c = (h . k)(k . p)``; with ``r = hypot(A, B)`` and
    ``C = d - c``: two angles when ``|C| < r``, one (a tangency) when
    ``|C| = r`` (within ``tol * max(1, r)``), none when ``|C| > r`` (``miss``
    ``|C| - r``, ``theta`` the angle nearest the plane), every angle when
    ``r = 0`` and ``C = 0``.

    Examples
    --------
    >>> answer = sp4([1, 0, 0], [0, 0, 1], [1, 0, 0], 0.0)
    >>> [round(float(t), 6) for t in answer.theta], float(answer.count)
    ([1.570796, -1.570796], 2.0)
    """
    h, k, p = (np.asarray(v, dtype=float) for v in (h, k, p))
    d = np.asarray(d, dtype=float)
    kp = _dot(k, p)
    A = _dot(h, p - kp[..., None] * k)
    B = _dot(h, cross(k, p))
    C = d - _dot(h, k) * kp
    r = np.hypot(A, B)
    phi = np.arctan2(B, A)
    scale = np.maximum(1.0, r)
    degenerate = r <= tol * scale
    gap = np.abs(C) - r
    inside = np.clip(C / np.where(degenerate, 1.0, r), -1.0, 1.0)
    spread = np.arccos(inside)
    theta = _wrap(np.stack([phi + spread, phi - spread], axis=-1))
    tangent = np.abs(gap) <= tol * scale
    count = np.where(gap > tol * scale, 0.0, np.where(tangent, 1.0, 2.0))
    count = np.where(degenerate, np.where(np.abs(C) <= tol * scale, np.inf, 0.0), count)
    theta = np.where(degenerate[..., None], 0.0, theta)
    touch = _wrap(np.where(C >= 0.0, phi, phi + np.pi))  # a tangency: the one angle exactly, not arccos(1 - eps)
    theta = np.where(tangent[..., None] & ~degenerate[..., None], touch[..., None], theta)
    miss = np.where(count == 0.0, np.where(degenerate, np.abs(C), gap), 0.0)
    return Answer(theta, count, miss)


def sp3(k, p1, p2, delta, *, tol: float = TOL) -> Answer:
    """Subproblem 3: the angles ``t`` with ``|R(k, t) p1 - p2| = delta``.

    The same as :func:`sp4` with ``h = p2`` and
    ``d = (|p1|^2 + |p2|^2 - delta^2) / 2``; ``miss`` is a distance (m): how
    far the nearest (or farthest) point of the circle traced by ``p1`` is
    from the sphere of radius ``delta`` about ``p2``.

    Examples
    --------
    >>> answer = sp3([0, 0, 1], [1, 0, 0], [0, 0, 0], 2.0)  # a circle of radius 1 never reaches distance 2
    >>> float(answer.count), float(answer.miss.round(12))
    (0.0, 1.0)
    """
    k, p1, p2 = (np.asarray(v, dtype=float) for v in (k, p1, p2))
    delta = np.asarray(delta, dtype=float)
    d = 0.5 * (_dot(p1, p1) + _dot(p2, p2) - delta * delta)
    answer = sp4(p2, k, p1, d, tol=tol)
    # the distance actually reached by the best angle, against delta: a length the caller can report
    reached = np.linalg.norm(rotate(k[..., None, :], answer.theta, p1[..., None, :]) - p2[..., None, :], axis=-1)
    miss = np.where(answer.count == 0.0, np.min(np.abs(reached - delta[..., None]), axis=-1), 0.0)
    return Answer(answer.theta, answer.count, miss)


def sp2(k1, p1, k2, p2, *, tol: float = TOL) -> Answer:
    """Subproblem 2: the pairs ``(t1, t2)`` with ``R(k1, t1) p1 = R(k2, t2) p2`` (two axes through one point).

    ``t1`` rotates ``p1`` into the cone ``k2 . x = k2 . p2`` (:func:`sp4`),
    then ``t2`` takes ``p2`` onto it (:func:`sp1`). Up to two pairs; ``inf``
    when an angle is free (``p1`` on ``k1``, or ``k1`` along ``k2`` with the
    cone met everywhere: ``t1`` free, ``t2`` follows; ``p2`` on ``k2`` and
    met: ``t2`` free, held 0);
    ``miss`` is ``|R1 p1 - R2 p2|`` of the best pair (unequal lengths never
    meet). A pair counts when that gap is within ``sqrt(tol)`` (relative):
    near a tangency the angles are good to that much only; callers check
    their answers by forward kinematics.

    Examples
    --------
    >>> answer = sp2([0, 0, 1], [1, 0, 0], [1, 0, 0], [0, 0, 1])
    >>> float(answer.count), [round(float(t), 6) for t in answer.theta[0]]
    (2.0, [1.570796, -1.570796])
    """
    k1, p1, k2, p2 = (np.asarray(v, dtype=float) for v in (k1, p1, k2, p2))
    first = sp4(k2, k1, p1, _dot(k2, p2), tol=tol)
    t1 = first.theta
    target = rotate(k1[..., None, :], t1, p1[..., None, :])
    t2, free, miss = sp1(k2[..., None, :], p2[..., None, :], target, tol=tol)
    theta = np.stack([t1, t2], axis=-1)
    # a tangency met within tol in the cone's equation leaves an angle good to sqrt(tol) only: accept that much
    exact = miss <= np.sqrt(tol) * np.maximum(1.0, np.linalg.norm(p1, axis=-1))[..., None]
    count = first.count
    count = np.where(np.isfinite(count) & (count > 0) & ~exact[..., 0], 0.0, count)
    count = np.where((count > 0) & free[..., 0], np.inf, count)  # p2 on k2 (and met): t2 is free
    best = np.min(miss, axis=-1)
    return Answer(theta, count, np.where(count == 0.0, np.maximum(best, first.miss), 0.0))
