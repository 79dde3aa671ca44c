"""Closed-form kinematics of planar 2R and 3R arms: FK, every IK solution, workspaces.

Conventions (DESIGN.md, "Conventions"), restated where they matter:

- The arm moves in the x-y plane of its base frame. Every joint turns about
  +z, so angles are counter-clockwise positive seen from +z (looking down on
  the plane). Radians; lengths in metres (any unit works if used throughout).
- ``q1`` is the angle of link 1 from the base x axis, ``q2`` the angle of
  link 2 from link 1, ``q3`` that of link 3 from link 2; link ``i`` points
  along ``q1 + ... + qi``. The tool frame sits at the end of the last link,
  its x axis along that link, so its orientation is ``phi = q1 + q2 (+ q3)``.
  This is the bundled ``planar_2r`` / ``planar_3r`` description.
- Joint angles from the solvers are wrapped to (-pi, pi].
- Elbow convention (Spong): **elbow-down** is ``q2`` in (0, pi), the ``+``
  sign of ``q2 = atan2(+-sqrt(1 - D**2), D)``; **elbow-up** is ``q2`` in
  (-pi, 0). With ``q2 > 0`` the elbow lies on the clockwise side of the ray
  from the base to the wrist (to its right, looking along the ray), which is
  below the arm when it reaches out along +x. The solvers list elbow-down
  first. On the workspace boundary the two meet: ``q2 = 0`` ("straight",
  outer circle) or ``q2 = pi`` ("folded", inner circle).

Every function is pure and works on numpy arrays; the ``*_batch`` solvers
handle millions of targets without a Python loop. Only numpy is imported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from manipkit.errors import PlanarArmError
from manipkit.spatial.rotations import _scalar_or_array, wrap_angle

__all__ = [
    "ELBOW_DOWN",
    "ELBOW_UP",
    "FOLDED",
    "PlanarArmError",
    "PlanarIKBatch",
    "PlanarIKResult",
    "Q1_FREE",
    "STRAIGHT",
    "Workspace",
    "chain_points",
    "fk_2r",
    "fk_3r",
    "ik_2r",
    "ik_2r_batch",
    "ik_3r",
    "ik_3r_batch",
    "se2_3r",
    "workspace_2r",
    "workspace_3r",
]

ELBOW_DOWN = "elbow-down"  # q2 in (0, pi)
ELBOW_UP = "elbow-up"  # q2 in (-pi, 0)
STRAIGHT = "straight"  # q2 = 0: on the outer circle r = l1 + l2
FOLDED = "folded"  # q2 = pi: on the inner circle r = |l1 - l2|
Q1_FREE = "q1 free"  # target at the base with l1 = l2: q2 = pi, any q1


# --------------------------------------------------------------------------
# helpers


def _as_float(value, what: str) -> np.ndarray:
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise PlanarArmError(f"{what} must be numeric, got {value!r:.80}") from None


def _length(value, what: str) -> float:
    """A link length: a finite scalar > 0."""
    array = _as_float(value, what)
    if array.ndim != 0:
        raise PlanarArmError(f"{what} must be a single number, got shape {array.shape}")
    length = float(array)
    if not math.isfinite(length) or length <= 0.0:
        raise PlanarArmError(f"{what} = {length} is not a valid link length; it must be a finite number > 0")
    return length


def _finite(value, what: str, *, shape_tail: tuple[int, ...] = (), scalar: bool = False) -> np.ndarray:
    array = _as_float(value, what)
    if scalar and array.ndim != 0:
        raise PlanarArmError(f"{what} must be a single number, got shape {array.shape}; use the *_batch solver")
    if shape_tail and array.shape[-len(shape_tail):] != shape_tail:
        raise PlanarArmError(f"{what} must have shape (..., {', '.join(map(str, shape_tail))}), got {array.shape}")
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        where = f"{what}[{', '.join(str(int(i)) for i in bad)}]" if array.ndim else what
        raise PlanarArmError(f"{where} = {array[tuple(bad)]} is not finite; targets must be finite numbers")
    return array


def _g(value: float) -> str:
    """A length or angle for a message: up to 6 significant digits, rounding noise below 1e-12 dropped."""
    text = f"{round(float(value), 12):.6g}"
    return "0" if text == "-0" else text


# --------------------------------------------------------------------------
# forward kinematics


def fk_2r(q1, q2, l1, l2):
    """Tool position of a planar 2R arm.

    Parameters
    ----------
    q1, q2 : array_like
        Joint angles in radians (see the module conventions: q1 from the base
        x axis, q2 from link 1, counter-clockwise seen from +z).
    l1, l2 : array_like
        Link lengths (m). All four broadcast against each other.

    Returns
    -------
    x, y : ndarray or float
        Tool position in the base frame (m)::

            x = l1 cos(q1) + l2 cos(q1 + q2)
            y = l1 sin(q1) + l2 sin(q1 + q2)

        The tool orientation is ``q1 + q2``.

    Examples
    --------
    >>> x, y = fk_2r(np.pi / 2, -np.pi / 2, 1.0, 0.5)  # up 1, then right 0.5
    >>> round(float(x), 12), round(float(y), 12)
    (0.5, 1.0)
    """
    q1, q2 = _as_float(q1, "q1"), _as_float(q2, "q2")
    l1, l2 = _as_float(l1, "l1"), _as_float(l2, "l2")
    q12 = q1 + q2
    x = l1 * np.cos(q1) + l2 * np.cos(q12)
    y = l1 * np.sin(q1) + l2 * np.sin(q12)
    return _scalar_or_array(np.asarray(x)), _scalar_or_array(np.asarray(y))


def fk_3r(q1, q2, q3, l1, l2, l3):
    """Tool pose ``(x, y, phi)`` of a planar 3R arm.

    Parameters
    ----------
    q1, q2, q3 : array_like
        Joint angles in radians (module conventions).
    l1, l2, l3 : array_like
        Link lengths (m). All six broadcast against each other.

    Returns
    -------
    x, y : ndarray or float
        Tool position in the base frame (m)::

            x = l1 cos(q1) + l2 cos(q1 + q2) + l3 cos(q1 + q2 + q3)
            y = l1 sin(q1) + l2 sin(q1 + q2) + l3 sin(q1 + q2 + q3)

    phi : ndarray or float
        Tool orientation ``q1 + q2 + q3`` (angle of the tool x axis from the
        base x axis), wrapped to (-pi, pi].

    Examples
    --------
    >>> x, y, phi = fk_3r(0.0, np.pi / 2, np.pi / 2, 4.0, 2.0, 1.0)  # right 4, up 2, left 1
    >>> round(float(x), 12), round(float(y), 12), round(float(phi), 12)
    (3.0, 2.0, 3.14159265359)
    """
    q1, q2, q3 = _as_float(q1, "q1"), _as_float(q2, "q2"), _as_float(q3, "q3")
    l1, l2, l3 = _as_float(l1, "l1"), _as_float(l2, "l2"), _as_float(l3, "l3")
    q12 = q1 + q2
    q123 = q12 + q3
    x = l1 * np.cos(q1) + l2 * np.cos(q12) + l3 * np.cos(q123)
    y = l1 * np.sin(q1) + l2 * np.sin(q12) + l3 * np.sin(q123)
    phi = wrap_angle(q123 + 0.0 * (l1 + l2 + l3))  # broadcast to the common shape
    return tuple(_scalar_or_array(np.asarray(v)) for v in (x, y, phi))


def se2_3r(q1, q2, q3, l1, l2, l3) -> np.ndarray:
    """Tool pose of a planar 3R arm as a homogeneous SE(2) matrix ``T_base_tool``.

    Parameters
    ----------
    q1, q2, q3, l1, l2, l3 : array_like
        As for :func:`fk_3r`; they broadcast.

    Returns
    -------
    T_base_tool : ndarray, shape (..., 3, 3)
        ``[[cos phi, -sin phi, x], [sin phi, cos phi, y], [0, 0, 1]]`` with
        ``(x, y, phi)`` from :func:`fk_3r`: the pose of the tool frame in the
        base frame.

    Examples
    --------
    >>> se2_3r(0.0, np.pi / 2, np.pi / 2, 4.0, 2.0, 1.0).round(12) + 0.0
    array([[-1.,  0.,  3.],
           [ 0., -1.,  2.],
           [ 0.,  0.,  1.]])
    """
    x, y, phi = (np.asarray(v) for v in fk_3r(q1, q2, q3, l1, l2, l3))
    c, s = np.cos(phi), np.sin(phi)
    T = np.zeros(phi.shape + (3, 3))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 2] = c, -s, x
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2] = s, c, y
    T[..., 2, 2] = 1.0
    return T


def chain_points(q, lengths) -> np.ndarray:
    """Positions of the base, every joint and the tool of a planar serial arm.

    Parameters
    ----------
    q : array_like, shape (..., n)
        Joint angles in radians (module conventions), n >= 1.
    lengths : array_like, shape (n,)
        Link lengths (m).

    Returns
    -------
    points : ndarray, shape (..., n + 1, 2)
        ``points[..., 0]`` is the base (origin), ``points[..., i]`` the end of
        link ``i`` (joint ``i + 1``), ``points[..., n]`` the tool. Drawn as a
        polyline they show the arm.

    Examples
    --------
    >>> chain_points([0.0, np.pi / 2], [1.0, 0.5]).round(12) + 0.0
    array([[0. , 0. ],
           [1. , 0. ],
           [1. , 0.5]])
    """
    q = _as_float(q, "q")
    lengths = _as_float(lengths, "lengths")
    if q.ndim == 0 or lengths.shape != q.shape[-1:]:
        raise PlanarArmError(f"q must have shape (..., n) with n = len(lengths) = {lengths.size}, got {q.shape}")
    heading = np.cumsum(q, axis=-1)
    steps = lengths * np.stack([np.cos(heading), np.sin(heading)], axis=-1).swapaxes(-1, -2)
    points = np.cumsum(steps, axis=-1).swapaxes(-1, -2)
    return np.concatenate([np.zeros(q.shape[:-1] + (1, 2)), points], axis=-2)


# --------------------------------------------------------------------------
# inverse kinematics: results


@dataclass(frozen=True, eq=False)
class PlanarIKResult:
    """Every solution of a planar IK problem (2R or 3R).

    Attributes
    ----------
    solutions : ndarray, shape (k, n)
        One row of joint angles (rad, wrapped to (-pi, pi]) per solution,
        elbow-down first. ``k`` is 0, 1 or 2; for infinitely many solutions
        it holds one representative of the family (``q1 = 0``). Read-only.
    labels : tuple of str
        One per row: ``"elbow-down"`` (q2 in (0, pi)), ``"elbow-up"``
        (q2 in (-pi, 0)), ``"straight"`` (q2 = 0, outer boundary),
        ``"folded"`` (q2 = pi, inner boundary) or ``"q1 free"``.
    count : int or float
        Number of solutions: 0, 1, 2, or ``math.inf``.
    reason : str
        One line saying why there are that many, with the numbers.
    outside_by : float
        How far (m) the target (2R) or wrist point (3R) lies outside the
        reachable annulus; 0.0 when it is reachable.
    side : str or None
        ``"too far"`` (beyond ``l1 + l2``), ``"too close"`` (inside
        ``|l1 - l2|``) when ``count == 0``, else None.
    free_joint : int or None
        When ``count`` is infinite, the index of the joint that may take any
        value (0: q1; the other angles follow from it as ``reason`` says).
    """

    solutions: np.ndarray
    labels: tuple[str, ...]
    count: int | float
    reason: str
    outside_by: float = 0.0
    side: str | None = None
    free_joint: int | None = None

    @property
    def infinite(self) -> bool:
        """True for a one-parameter family of solutions."""
        return math.isinf(self.count)


@dataclass(frozen=True, eq=False)
class PlanarIKBatch:
    """Planar IK solutions for many targets at once.

    Attributes
    ----------
    solutions : ndarray, shape (..., 2, n)
        Slot 0 is elbow-down (or the single boundary solution: straight or
        folded), slot 1 elbow-up; absent solutions are NaN. For infinitely
        many solutions slot 0 holds the representative with ``q1 = 0``.
        Angles in radians, wrapped to (-pi, pi].
    counts : ndarray of float, shape (...)
        0.0, 1.0, 2.0 or ``inf`` per target (float so ``inf`` fits;
        ``counts == 2`` selects the two-solution targets).
    outside_by : ndarray, shape (...)
        Distance (m) of the target (2R) or wrist point (3R) outside the
        reachable annulus, 0.0 where reachable.
    """

    solutions: np.ndarray
    counts: np.ndarray
    outside_by: np.ndarray


# --------------------------------------------------------------------------
# inverse kinematics: the core, shared by every solver
#
# Two passes. The fast one (_solve_inside) treats every target as if it were
# inside the annulus |l1 - l2| < r < l1 + l2, with two solutions: the cosine
# rule in components, no sin or cos, over blocks of _BLOCK targets so the
# temporaries stay in the CPU cache. The few targets that are not safely
# inside (on or near a boundary circle, at the base, unreachable) go to the
# second pass (_solve_rest), which sorts them into cases and redoes their rows.


_TWO, _OUTER, _INNER, _FREE, _FAR, _CLOSE = range(6)
_COUNTS = np.array([2.0, 1.0, 1.0, np.inf, 0.0, 0.0])  # number of solutions per case code
_BLOCK = 8192  # targets per fast pass: its ~20 temporaries of 64 kB stay in the L2 cache
_PI, _TWO_PI = np.pi, 2.0 * np.pi
_EPS = np.finfo(float).eps


def _wrist(x, y, phi, l3):
    """Wrist point (joint 3): the tool pulled back along its x axis by l3.

    ``(x - l3 cos phi, y - l3 sin phi)`` with cos and sin from ``t = tan(phi / 2)``:
    ``cos phi = 2 / (1 + t^2) - 1`` and ``sin phi = t * 2 / (1 + t^2)``. numpy's
    tan is several times faster than its cos and sin, and as accurate here (a
    few 1e-16 for any phi). At ``phi = +-pi``, ``t`` is about 1.6e16, ``t^2``
    is far from overflowing, and ``cos = -1``, ``sin = 2 / t = sin(pi)``.
    """
    t = np.tan(0.5 * phi)
    u = 2.0 / (1.0 + t * t)
    return x - l3 * (u - 1.0), y - l3 * (t * u)


def _atan2_half_open(angle: np.ndarray) -> None:
    """In place: atan2 gives [-pi, pi]; its -pi (x < 0 with y = -0.0 or tiny) is +pi in (-pi, pi]."""
    np.copyto(angle, _PI, where=angle == -_PI)


def _third_joint(phi: np.ndarray, q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """``q3 = phi - q1 - q2`` wrapped to (-pi, pi], for phi, q1, q2 in [-pi, pi].

    ``q3`` is then in [-3 pi, 3 pi]: one shift by 2 pi at most, and an exact one
    (``a -+ 2 pi`` has no rounding for ``pi <= |a| <= 4 pi``, Sterbenz's lemma).
    Only ``-3 pi`` itself lands on ``-pi``, which must read ``+pi``. (Adding
    ``2 pi * mask``, 0 where the mask is False, beats a masked assignment
    several times over when the mask is a random mix.)
    """
    q3 = phi - q1
    q3 -= q2
    q3 -= _TWO_PI * (q3 > _PI)
    q3 += _TWO_PI * (q3 <= -_PI)
    _atan2_half_open(q3)
    return q3


def _solve_inside(x, y, phi, l1: float, l2: float, l3: float, tol: float, out: np.ndarray) -> np.ndarray:
    """Fast pass: both solutions of every target safely inside the annulus.

    ``x``, ``y`` (n,) are 2R targets, or with ``phi`` (n,) (else None) 3R tool
    poses, whose wrist point is the 2R target. Fills ``out`` (n, 2, 2 or 3)
    with the rows elbow-down, elbow-up, angles in (-pi, pi]. Returns the
    indices of the targets not safely inside: their rows are junk, for
    :func:`_solve_rest` to redo.
    """
    if phi is not None:
        phi = np.ascontiguousarray(phi)  # a column of the poses: a copy is faster to work on
        x, y = _wrist(x, y, phi, l3)
    outer, inner = l1 + l2, abs(l1 - l2)
    r2 = x * x + y * y
    r = np.sqrt(r2)
    to_outer, from_inner = outer - r, r - inner
    # inside by more than tol, plus a few ulps: this r may differ from the documented hypot(x, y) in
    # the last bit, so _solve_rest, which uses hypot, decides every target near a boundary
    margin = tol + 8.0 * _EPS * outer
    inside = (to_outer > margin) & (from_inner > margin)

    # cosine rule times 2 l1 l2, written so nothing cancels near the boundary circles:
    #   C = 2 l1 l2 cos q2 = r^2 - l1^2 - l2^2,
    #   S = 2 l1 l2 sin q2 = sqrt(((l1 + l2)^2 - r^2) (r^2 - (l1 - l2)^2)) >= 0,
    # q2 = atan2(S, C) in [0, pi] is elbow-down, -q2 elbow-up. (Outside the annulus the product is
    # negative; clamped to 0 it gives junk that _solve_rest replaces.)
    S = np.sqrt(np.maximum((to_outer * (outer + r)) * (from_inner * (r + inner)), 0.0))
    q2 = np.arctan2(S, r2 - (l1 * l1 + l2 * l2))
    # shoulder: x = k1 cos q1 - k2 sin q1, y = k1 sin q1 + k2 cos q1 with k1 = l1 + l2 cos q2,
    # k2 = l2 sin q2, so (k1 y - k2 x, k1 x + k2 y) = (k1^2 + k2^2) (sin q1, cos q1): one atan2, right
    # quadrant. atan2 ignores the factor 2 l1 > 0 in 2 l1 k1 = A = r^2 + l1^2 - l2^2, 2 l1 k2 = +-S:
    #   q1 = atan2(A y -+ S x, A x +- S y)   (upper signs elbow-down, lower elbow-up)
    A = r2 + (l1 * l1 - l2 * l2)
    Ax, Ay, Sx, Sy = A * x, A * y, S * x, S * y
    q1_down = np.arctan2(Ay - Sx, Ax + Sy)
    q1_up = np.arctan2(Ay + Sx, Ax - Sy)
    q2_up = -q2
    for angle in (q1_down, q1_up, q2_up):  # to (-pi, pi]; q2 in [0, pi] already is
        _atan2_half_open(angle)
    rows = [(q1_down, q2), (q1_up, q2_up)]

    if phi is not None:
        if not (phi.min() > -_PI and phi.max() <= _PI):
            phi = wrap_angle(phi)  # so q3 = phi - q1 - q2 is in [-3 pi, 3 pi]
        rows = [(q1, q2, _third_joint(phi, q1, q2)) for q1, q2 in rows]

    for slot, angles in enumerate(rows):
        for joint, angle in enumerate(angles):
            np.add(angle, 0.0, out=out[:, slot, joint])  # + 0.0 turns -0.0 into 0.0, as wrap_angle does
    return np.flatnonzero(~inside)


def _solve_rest(x, y, phi, l1: float, l2: float, l3: float, tol: float):
    """Second pass, for the targets :func:`_solve_inside` left: every case, as documented.

    Same arguments as :func:`_solve_inside` (tool poses or 2R targets), any
    number of targets. Returns rows (k, 2, 2 or 3), NaN where absent, a case
    code per target and the distance of the (wrist) point outside the annulus.
    """
    wx, wy = (x, y) if phi is None else _wrist(x, y, phi, l3)
    r = np.hypot(wx, wy)
    outer, inner = l1 + l2, abs(l1 - l2)
    free = (inner <= tol) & (r <= tol)
    on_outer = ~free & (np.abs(r - outer) <= tol)
    on_inner = ~free & ~on_outer & (np.abs(r - inner) <= tol)
    too_far = ~on_outer & (r > outer)
    too_close = ~free & ~on_inner & (r < inner)
    case = np.full(r.shape, _TWO, dtype=np.int8)
    for mask, code in ((on_outer, _OUTER), (on_inner, _INNER), (free, _FREE), (too_far, _FAR), (too_close, _CLOSE)):
        case[mask] = code

    rows = np.full(r.shape + (2, 2), np.nan)
    two = np.flatnonzero(case == _TWO)  # inside, but within a few ulps of the margin
    if two.size:
        inside = np.empty((two.size, 2, 2))
        _solve_inside(wx[two], wy[two], None, l1, l2, 0.0, tol, inside)
        rows[two] = inside
    # on the boundary circles sin q2 = 0, and link 1 points along the target direction (straight, or
    # folded with l1 > l2) or against it (folded with l2 > l1); at the base (l1 = l2) q1 = 0 stands for any
    toward = np.arctan2(wy, wx)
    q1 = np.where(case == _OUTER, toward, rows[:, 0, 0])
    q1 = np.where(case == _INNER, toward + (_PI if l2 > l1 else 0.0), q1)
    q1 = np.where(case == _FREE, 0.0, q1)
    q2 = np.where(case == _OUTER, 0.0, np.where((case == _INNER) | (case == _FREE), _PI, rows[:, 0, 1]))
    rows[:, 0, 0], rows[:, 0, 1] = wrap_angle(q1), q2
    if phi is not None:
        q3 = wrap_angle(phi[:, None] - rows[..., 0] - rows[..., 1])
        rows = np.concatenate([rows, q3[..., None]], axis=-1)
    outside = np.where(too_far, r - outer, np.where(too_close, inner - r, 0.0))
    return rows, case, outside


def _ik_core(x, y, l1: float, l2: float, tol: float, phi=None, l3: float = 0.0):
    """Every IK solution for arrays of 2R targets ``(x, y)``, or of 3R tool poses ``(x, y, phi)``.

    Returns solutions (..., 2, 2 or 3) with NaN where absent (slot 0
    elbow-down or the one solution, slot 1 elbow-up), a case code per target
    (``_TWO`` ... ``_CLOSE``), the number of solutions per target and the
    distance of the target (wrist point) outside the annulus.
    """
    shape = np.shape(x)
    x, y = np.reshape(x, -1), np.reshape(y, -1)  # views, for the usual (..., 2 or 3) input
    phi = None if phi is None else np.reshape(phi, -1)
    n = x.size
    solutions = np.empty((n, 2, 2 if phi is None else 3))
    rest = []  # indices of the targets not safely inside, per block
    with np.errstate(over="ignore", invalid="ignore"):  # x * x of a target beyond 1e154: inf, left for _solve_rest
        for start in range(0, n, _BLOCK):
            block = slice(start, start + _BLOCK)
            index = _solve_inside(
                x[block], y[block], None if phi is None else phi[block], l1, l2, l3, tol, solutions[block]
            )
            rest.append(index + start)
    rest = np.concatenate(rest) if rest else np.zeros(0, dtype=np.intp)
    case = np.full(n, _TWO, dtype=np.int8)
    counts = np.full(n, _COUNTS[_TWO])
    outside = np.zeros(n)
    if rest.size:
        phi_rest = None if phi is None else phi[rest]
        solutions[rest], case[rest], outside[rest] = _solve_rest(x[rest], y[rest], phi_rest, l1, l2, l3, tol)
        counts[rest] = _COUNTS[case[rest]]
    return (
        solutions.reshape(shape + solutions.shape[1:]),
        case.reshape(shape),
        counts.reshape(shape)[()],  # a 0-d input gives a numpy float, as _COUNTS[case] did
        outside.reshape(shape),
    )


def _describe_2r(case: int, r: float, l1: float, l2: float, point: str) -> tuple[str, str | None]:
    outer, inner = l1 + l2, abs(l1 - l2)
    where = f"{point} at r = {_g(r)}"
    if case == _TWO:
        return f"2 solutions: {where} is inside the workspace |l1 - l2| = {_g(inner)} < r < l1 + l2 = {_g(outer)}", None
    if case == _OUTER:
        return f"1 solution: {where} is on the outer boundary r = l1 + l2 = {_g(outer)} (arm straight, q2 = 0)", None
    if case == _INNER:
        return f"1 solution: {where} is on the inner boundary r = |l1 - l2| = {_g(inner)} (arm folded, q2 = pi)", None
    if case == _FREE:
        return (
            f"infinitely many solutions: {point} at the base with l1 = l2 = {_g(l1)}: "
            "q2 = pi (folded) and q1 takes any value"
        ), None
    if case == _FAR:
        return (
            f"no solution: {point} too far: r = {_g(r)} > l1 + l2 = {_g(outer)}, outside by {_g(r - outer)}"
        ), "too far"
    return (
        f"no solution: {point} too close: r = {_g(r)} < |l1 - l2| = {_g(inner)}, outside by {_g(inner - r)}"
    ), "too close"


def _labels(case: int) -> tuple[str, ...]:
    return {
        _TWO: (ELBOW_DOWN, ELBOW_UP),
        _OUTER: (STRAIGHT,),
        _INNER: (FOLDED,),
        _FREE: (Q1_FREE,),
    }.get(case, ())


def _tolerance(tol) -> float:
    tol = float(tol)
    if not tol >= 0.0:
        raise PlanarArmError(f"tol = {tol} must be a number >= 0")
    return tol


# --------------------------------------------------------------------------
# inverse kinematics: 2R


def ik_2r_batch(xy, l1, l2, *, tol: float = 1e-12) -> PlanarIKBatch:
    """Every IK solution of a planar 2R arm for many target positions at once.

    Parameters
    ----------
    xy : array_like, shape (..., 2)
        Target tool positions ``(x, y)`` in the base frame (m).
    l1, l2 : float
        Link lengths (m), > 0.
    tol : float, keyword-only
        Distance (m) within which a target counts as on a boundary circle
        (one solution) or, when ``|l1 - l2| <= tol``, at the base (infinitely
        many), as in :func:`ik_2r`.

    Returns
    -------
    PlanarIKBatch
        ``solutions`` (..., 2, 2) with rows ``(q1, q2)``: slot 0 elbow-down
        (or the boundary solution), slot 1 elbow-up, NaN where absent;
        ``counts`` (...) in {0, 1, 2, inf}; ``outside_by`` (...).

    Examples
    --------
    >>> result = ik_2r_batch([[1.0, 1.0], [2.0, 0.0], [3.0, 0.0]], 1.0, 1.0)
    >>> result.counts
    array([2., 1., 0.])
    >>> result.solutions[0].round(6)  # elbow-down (q2 > 0), then elbow-up
    array([[ 0.      ,  1.570796],
           [ 1.570796, -1.570796]])
    """
    l1, l2 = _length(l1, "l1"), _length(l2, "l2")
    xy = _finite(xy, "xy", shape_tail=(2,))
    solutions, _, counts, outside = _ik_core(xy[..., 0], xy[..., 1], l1, l2, _tolerance(tol))
    return PlanarIKBatch(solutions, counts, outside)


def ik_2r(x, y, l1, l2, *, tol: float = 1e-12) -> PlanarIKResult:
    """Every joint solution ``(q1, q2)`` putting a planar 2R tool at ``(x, y)``.

    Parameters
    ----------
    x, y : float
        Target tool position in the base frame (m).
    l1, l2 : float
        Link lengths (m), > 0.
    tol : float, keyword-only
        Distance (m) within which ``r = hypot(x, y)`` counts as on a boundary
        circle (``|r - (l1 + l2)| <= tol`` or ``|r - |l1 - l2|| <= tol``: one
        solution, ``q2 = 0`` or ``pi`` exactly) or, when ``|l1 - l2| <= tol``
        and ``r <= tol``, at the base (infinitely many).

    Returns
    -------
    PlanarIKResult
        ``solutions`` (k, 2), rows ``(q1, q2)`` in radians wrapped to
        (-pi, pi], elbow-down (q2 > 0) first; ``labels``, ``count``,
        ``reason``, and for unreachable targets ``outside_by`` and ``side``.

        - 2 solutions strictly inside the annulus ``|l1 - l2| < r < l1 + l2``;
        - 1 on either boundary circle (``"straight"`` or ``"folded"``);
        - 0 outside it (``side`` ``"too far"`` or ``"too close"``);
        - infinitely many at the base when ``l1 = l2``: ``q2 = pi`` and any
          ``q1`` (``free_joint = 0``; ``solutions`` holds ``(0, pi)``).

    Notes
    -----
    Cosine rule: ``cos q2 = D = (r^2 - l1^2 - l2^2) / (2 l1 l2)`` and
    ``q2 = atan2(+-sqrt(1 - D^2), D)``, with ``1 - D^2`` formed as the
    product ``((l1 + l2)^2 - r^2) (r^2 - (l1 - l2)^2) / (2 l1 l2)^2`` so it
    does not cancel next to the boundary. Then
    ``q1 = atan2(k1 y - k2 x, k1 x + k2 y)`` with ``k1 = l1 + l2 cos q2`` and
    ``k2 = l2 sin q2``, i.e. ``atan2(y, x) - atan2(k2, k1)`` in one step.
    ``atan(y / x)`` would lose the quadrant (off by pi for ``x < 0``).

    Examples
    --------
    >>> result = ik_2r(0.0, 1.5, 1.0, 1.0)
    >>> result.count, result.labels
    (2, ('elbow-down', 'elbow-up'))
    >>> result.solutions.round(6)
    array([[ 0.848062,  1.445468],
           [ 2.293531, -1.445468]])
    >>> ik_2r(3.0, 0.0, 1.0, 1.0).reason
    'no solution: target too far: r = 3 > l1 + l2 = 2, outside by 1'
    """
    l1, l2 = _length(l1, "l1"), _length(l2, "l2")
    x, y = _finite(x, "x", scalar=True), _finite(y, "y", scalar=True)
    solutions, case, _, outside = _ik_core(x, y, l1, l2, _tolerance(tol))
    case = int(case)
    labels = _labels(case)
    rows = solutions[: len(labels)].copy()
    rows.setflags(write=False)
    reason, side = _describe_2r(case, float(np.hypot(x, y)), l1, l2, "target")
    count = math.inf if case == _FREE else len(labels)
    return PlanarIKResult(rows, labels, count, reason, float(outside), side, 0 if case == _FREE else None)


# --------------------------------------------------------------------------
# inverse kinematics: 3R


def ik_3r_batch(poses, l1, l2, l3, *, tol: float = 1e-12) -> PlanarIKBatch:
    """Every IK solution of a planar 3R arm for many tool poses at once.

    Parameters
    ----------
    poses : array_like, shape (..., 3)
        Target tool poses ``(x, y, phi)`` in the base frame (m, m, rad).
    l1, l2, l3 : float
        Link lengths (m), > 0.
    tol : float, keyword-only
        As in :func:`ik_3r`, applied to the wrist point.

    Returns
    -------
    PlanarIKBatch
        ``solutions`` (..., 2, 3) with rows ``(q1, q2, q3)``: slot 0
        elbow-down (or the boundary solution), slot 1 elbow-up, NaN where
        absent; ``counts`` (...) in {0, 1, 2, inf}; ``outside_by`` (...) of
        the wrist point.

    Examples
    --------
    >>> result = ik_3r_batch([[3.0, 2.0, np.pi], [9.0, 0.0, 0.0]], 4.0, 2.0, 1.0)
    >>> result.counts
    array([2., 0.])
    """
    l1, l2, l3 = _length(l1, "l1"), _length(l2, "l2"), _length(l3, "l3")
    poses = _finite(poses, "poses", shape_tail=(3,))
    solutions, _, counts, outside = _ik_core(
        poses[..., 0], poses[..., 1], l1, l2, _tolerance(tol), phi=poses[..., 2], l3=l3
    )
    return PlanarIKBatch(solutions, counts, outside)


def ik_3r(x, y, phi, l1, l2, l3, *, tol: float = 1e-12) -> PlanarIKResult:
    """Every joint solution ``(q1, q2, q3)`` putting a planar 3R tool at pose ``(x, y, phi)``.

    Parameters
    ----------
    x, y : float
        Target tool position in the base frame (m).
    phi : float
        Target tool orientation (rad): angle of the tool x axis from the base
        x axis, ``q1 + q2 + q3``.
    l1, l2, l3 : float
        Link lengths (m), > 0.
    tol : float, keyword-only
        As in :func:`ik_2r`, applied to the wrist point.

    Returns
    -------
    PlanarIKResult
        ``solutions`` (k, 3), rows ``(q1, q2, q3)`` in radians wrapped to
        (-pi, pi], elbow-down (q2 > 0) first, and the same ``labels``,
        ``count``, ``reason``, ``outside_by``, ``side`` as :func:`ik_2r` for
        the wrist point. With infinitely many solutions (wrist at the base,
        ``l1 = l2``) ``q1`` is free, ``q2 = pi`` and ``q3 = phi - q1 - pi``.

    Notes
    -----
    Decoupling: the wrist (joint 3) is at
    ``(x - l3 cos phi, y - l3 sin phi)`` whatever the joint angles; solve the
    2R arm (l1, l2) for it with :func:`ik_2r`, then ``q3 = phi - q1 - q2``.

    Examples
    --------
    >>> result = ik_3r(3.0, 2.0, np.pi, 4.0, 2.0, 1.0)  # wrist at (4, 2)
    >>> result.labels
    ('elbow-down', 'elbow-up')
    >>> result.solutions.round(6) + 0.0
    array([[ 0.      ,  1.570796,  1.570796],
           [ 0.927295, -1.570796, -2.498092]])
    """
    l1, l2, l3 = _length(l1, "l1"), _length(l2, "l2"), _length(l3, "l3")
    x, y = _finite(x, "x", scalar=True), _finite(y, "y", scalar=True)
    phi = _finite(phi, "phi", scalar=True)
    solutions, case, _, outside = _ik_core(x, y, l1, l2, _tolerance(tol), phi=phi, l3=l3)
    wx, wy = _wrist(x, y, phi, l3)  # for the message
    case = int(case)
    labels = _labels(case)
    rows = solutions[: len(labels)].copy()
    rows.setflags(write=False)
    point = f"wrist point ({_g(float(wx))}, {_g(float(wy))})"
    reason, side = _describe_2r(case, float(np.hypot(wx, wy)), l1, l2, point)
    if case == _FREE:
        reason += ", and q3 = phi - q1 - pi"
    count = math.inf if case == _FREE else len(labels)
    return PlanarIKResult(rows, labels, count, reason, float(outside), side, 0 if case == _FREE else None)


# --------------------------------------------------------------------------
# workspaces


def _interval_text(low: float, high: float) -> str:
    if high == 0.0:
        return "the base point only (r = 0)"
    if low == 0.0:
        return f"disc r <= {_g(high)}"
    if low == high:
        return f"circle r = {_g(low)}"
    return f"annulus {_g(low)} <= r <= {_g(high)}"


@dataclass(frozen=True)
class Workspace:
    """Reachable and dexterous workspaces of a planar arm, as radii about the base.

    Both are rotationally symmetric (joint 1 turns the whole arm), so they
    are sets of distances ``r`` from the base.

    Attributes
    ----------
    lengths : tuple of float
        Link lengths (m), base to tool.
    reachable : tuple of float
        ``(r_min, r_max)``: the tool reaches exactly the points with
        ``r_min <= r <= r_max`` (a disc when ``r_min = 0``).
    dexterous : tuple of (float, float)
        The points the tool reaches with *every* orientation, as disjoint
        closed intervals ``(r_min, r_max)`` of r in increasing order: ``()``
        when empty, one interval usually, two when a disc around the base and
        an annulus are both dexterous but the ring between them is not.
        ``(0, 0)`` is the base point alone.
    why_dexterous : str
        The reasoning behind ``dexterous`` for these lengths, in one line.
    """

    lengths: tuple[float, ...]
    reachable: tuple[float, float]
    dexterous: tuple[tuple[float, float], ...]
    why_dexterous: str

    @property
    def description(self) -> str:
        """One line for humans: both workspaces in words, with the radii."""
        lengths = ", ".join(_g(v) for v in self.lengths)
        reach = _interval_text(*self.reachable)
        if self.dexterous:
            dext = " and ".join(_interval_text(*piece) for piece in self.dexterous)
        else:
            dext = "empty"
        return f"planar {len(self.lengths)}R (l = {lengths}): reachable {reach}; dexterous {dext}: {self.why_dexterous}"

    def __str__(self) -> str:
        return self.description


def workspace_2r(l1, l2, *, tol: float = 1e-12) -> Workspace:
    """Reachable and dexterous workspaces of a planar 2R arm.

    Parameters
    ----------
    l1, l2 : float
        Link lengths (m), > 0.
    tol : float, keyword-only
        ``|l1 - l2| <= tol`` counts as equal links.

    Returns
    -------
    Workspace
        ``reachable = (|l1 - l2|, l1 + l2)``: link 2 sweeps a circle of radius
        l2 around the elbow, which is at distance l1, so the tool's distance
        ``sqrt(l1^2 + l2^2 + 2 l1 l2 cos q2)`` takes every value between
        ``|l1 - l2|`` (q2 = pi) and ``l1 + l2`` (q2 = 0).

        ``dexterous`` is empty: the tool orientation ``q1 + q2`` is fixed by
        the position up to the two elbow solutions. The one exception is
        ``l1 = l2``, where the base point is reached folded (q2 = pi) with
        any q1, hence every orientation: ``dexterous = ((0, 0),)``.

    Examples
    --------
    >>> workspace_2r(1.0, 0.5).reachable
    (0.5, 1.5)
    >>> workspace_2r(1.0, 1.0).dexterous  # folded at the base, any q1
    ((0.0, 0.0),)
    """
    l1, l2 = _length(l1, "l1"), _length(l2, "l2")
    tol = _tolerance(tol)
    reachable = (abs(l1 - l2), l1 + l2)
    if abs(l1 - l2) <= tol:
        return Workspace(
            (l1, l2), (0.0, l1 + l2), ((0.0, 0.0),),
            "with l1 = l2 the arm folds onto the base, where any q1 turns the tool through every angle",
        )
    return Workspace(
        (l1, l2), reachable, (), "a 2R tool's orientation q1 + q2 is fixed by its position, up to the elbow choice"
    )


def workspace_3r(l1, l2, l3, *, tol: float = 1e-12) -> Workspace:
    """Reachable and dexterous workspaces of a planar 3R arm.

    Parameters
    ----------
    l1, l2, l3 : float
        Link lengths (m), > 0.
    tol : float, keyword-only
        Pieces of the dexterous set closer than this are merged.

    Returns
    -------
    Workspace
        For lengths 4, 2, 1: reachable ``1 <= r <= 7``, dexterous
        ``3 <= r <= 5``.

    Notes
    -----
    Reachable: a chain of links reaches every distance from
    ``max(0, 2 l_max - (l1 + l2 + l3))`` (the longest link folded back on the
    others, or 0 when they can close a triangle) to ``l1 + l2 + l3``.

    Dexterous (every tool orientation phi): for orientation phi the wrist
    (joint 3) must sit at ``p - l3 (cos phi, sin phi)``. As phi turns, that
    point runs round the circle of radius l3 about the tool point ``p``, and
    every one of its points must lie in the annulus ``a <= |w| <= b`` that the
    2R arm (l1, l2) reaches, ``a = |l1 - l2|``, ``b = l1 + l2``. The circle's
    points have distances from ``|r - l3|`` to ``r + l3`` from the base
    (``r = |p|``), so the condition is

        ``r + l3 <= b``  and  ``|r - l3| >= a``,

    that is ``l3 + a <= r <= b - l3`` (the wrist circle between the two
    boundary circles: an annulus, non-empty when ``2 l3 <= b - a``) or
    ``r <= min(l3 - a, b - l3)`` (the wrist circle enclosing the inner
    boundary circle: a disc around the base, when ``l3 >= a``). For 4, 2, 1:
    ``a = 2``, ``b = 6``, so ``3 <= r <= 5``, and ``l3 = 1 < a`` rules out the
    disc.

    Examples
    --------
    >>> ws = workspace_3r(4.0, 2.0, 1.0)
    >>> ws.reachable, ws.dexterous
    ((1.0, 7.0), ((3.0, 5.0),))
    >>> workspace_3r(1.0, 1.0, 0.5).dexterous  # a disc
    ((0.0, 1.5),)
    >>> workspace_3r(1.0, 1.0, 3.0).dexterous  # l3 longer than the 2R reach: empty
    ()
    """
    l1, l2, l3 = _length(l1, "l1"), _length(l2, "l2"), _length(l3, "l3")
    tol = _tolerance(tol)
    total = l1 + l2 + l3
    reachable = (max(0.0, 2.0 * max(l1, l2, l3) - total), total)
    a, b = abs(l1 - l2), l1 + l2
    pieces = []
    if l3 >= a and b - l3 >= 0.0:
        pieces.append([0.0, min(l3 - a, b - l3)])
    if l3 + a <= b - l3:
        if pieces and pieces[0][1] >= l3 + a - tol:
            pieces[0][1] = max(pieces[0][1], b - l3)
        else:
            pieces.append([l3 + a, b - l3])
    dexterous = tuple((float(lo), float(hi)) for lo, hi in pieces)
    a_b = f"what links 1 and 2 reach ({_interval_text(a, b)})"
    if not dexterous:
        why = f"a wrist circle of radius l3 = {_g(l3)} fits nowhere in {a_b}"
    else:
        why = f"the wrist circle of radius l3 = {_g(l3)} about the tool lies in {a_b}"
    return Workspace((l1, l2, l3), reachable, dexterous, why)
