"""Closed-form kinematics of planar 2R and 3R arms: FK and every IK solution (workspaces: :mod:`.planar_workspace`).

Conventions (docs/architecture.md, "Conventions"), restated where they matter:

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

The answers as IK results (every row checked by the DH table's forward
kinematics, residuals, labels, the reason for none) are built one layer up, in
:mod:`manipkit.ik.planar` (``ik_2r``, ``ik_3r`` and their batches) and
:mod:`manipkit.ik.planar_modes`. Here: forward kinematics and the solver core
:func:`solve_planar`, which returns rows, a case code per target
(:func:`case_labels`, :func:`describe_2r`) and the distance out of reach.

Every function is pure and works on numpy arrays, many targets at once without
a Python loop. Only numpy is imported.
"""

from __future__ import annotations

import functools

import numpy as np

from manipkit.closed_form.checks import as_float, link_length, quantity_text
from manipkit.closed_form.planar_workspace import Workspace, workspace_2r, workspace_3r  # documented here too
from manipkit.dh.table import DHRow, DHTable
from manipkit.errors import PlanarArmError
from manipkit.spatial.rotations import rot_z, wrap_angle

__all__ = [
    "chain_points", "case_labels", "describe_2r", "ELBOW_DOWN", "ELBOW_UP", "fk_2r", "fk_3r", "FOLDED", "FREE_CASE",
    "planar_dh_table", "planar_target", "PlanarArmError", "Q1_FREE", "se2_3r", "solve_planar", "STRAIGHT",
    "table_of", "Workspace", "workspace_2r", "workspace_3r", "wrist_point",
]

ELBOW_DOWN = "elbow-down"  # q2 in (0, pi)
ELBOW_UP = "elbow-up"  # q2 in (-pi, 0)
STRAIGHT = "straight"  # q2 = 0: on the outer circle r = l1 + l2
FOLDED = "folded"  # q2 = pi: on the inner circle r = |l1 - l2|
Q1_FREE = "q1 free"  # target at the base with l1 = l2: q2 = pi, any q1


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
    q1, q2 = as_float(q1, "q1"), as_float(q2, "q2")
    l1, l2 = as_float(l1, "l1"), as_float(l2, "l2")
    q12 = q1 + q2
    x = l1 * np.cos(q1) + l2 * np.cos(q12)
    y = l1 * np.sin(q1) + l2 * np.sin(q12)
    return np.asarray(x)[()], np.asarray(y)[()]  # a float for scalar input


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
    q1, q2, q3 = as_float(q1, "q1"), as_float(q2, "q2"), as_float(q3, "q3")
    l1, l2, l3 = as_float(l1, "l1"), as_float(l2, "l2"), as_float(l3, "l3")
    q12 = q1 + q2
    q123 = q12 + q3
    x = l1 * np.cos(q1) + l2 * np.cos(q12) + l3 * np.cos(q123)
    y = l1 * np.sin(q1) + l2 * np.sin(q12) + l3 * np.sin(q123)
    phi = wrap_angle(q123 + 0.0 * (l1 + l2 + l3))  # broadcast to the common shape
    return tuple(np.asarray(v)[()] for v in (x, y, phi))  # floats for scalar input


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
    q = as_float(q, "q")
    lengths = as_float(lengths, "lengths")
    if q.ndim == 0 or lengths.shape != q.shape[-1:]:
        raise PlanarArmError(f"q must have shape (..., n) with n = len(lengths) = {lengths.size}, got {q.shape}")
    heading = np.cumsum(q, axis=-1)
    steps = lengths * np.stack([np.cos(heading), np.sin(heading)], axis=-1).swapaxes(-1, -2)
    points = np.cumsum(steps, axis=-1).swapaxes(-1, -2)
    return np.concatenate([np.zeros(q.shape[:-1] + (1, 2)), points], axis=-2)


# --------------------------------------------------------------------------
# inverse kinematics: the core, shared by every solver
#
# Two passes. The fast one (_solve_inside) treats every target as if it were
# inside the annulus |l1 - l2| < r < l1 + l2, with two solutions: the cosine
# rule in components, no sin or cos, over blocks of _BLOCK targets so the
# temporaries stay in the CPU cache. The few targets that are not safely
# inside (on or near a boundary circle, at the base, unreachable) go to the
# second pass (_solve_rest), which sorts them into cases and redoes their rows.


_TWO, _OUTER, _INNER, FREE_CASE, _FAR, _CLOSE = range(6)
_COUNTS = np.array([2.0, 1.0, 1.0, np.inf, 0.0, 0.0])  # number of solutions per case code
_BLOCK = 8192  # targets per fast pass: its ~20 temporaries of 64 kB stay in the L2 cache
_PI, _TWO_PI = np.pi, 2.0 * np.pi
_EPS = np.finfo(float).eps


def wrist_point(x, y, phi, l3):
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
        x, y = wrist_point(x, y, phi, l3)
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
    wx, wy = (x, y) if phi is None else wrist_point(x, y, phi, l3)
    r = np.hypot(wx, wy)
    outer, inner = l1 + l2, abs(l1 - l2)
    free = (inner <= tol) & (r <= tol)
    on_outer = ~free & (np.abs(r - outer) <= tol)
    on_inner = ~free & ~on_outer & (np.abs(r - inner) <= tol)
    too_far = ~on_outer & (r > outer)
    too_close = ~free & ~on_inner & (r < inner)
    case = np.full(r.shape, _TWO, dtype=np.int8)
    for mask, code in ((on_outer, _OUTER), (on_inner, _INNER), (free, FREE_CASE), (too_far, _FAR), (too_close, _CLOSE)):
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
    q1 = np.where(case == FREE_CASE, 0.0, q1)
    q2 = np.where(case == _OUTER, 0.0, np.where((case == _INNER) | (case == FREE_CASE), _PI, rows[:, 0, 1]))
    rows[:, 0, 0], rows[:, 0, 1] = wrap_angle(q1), q2
    if phi is not None:
        q3 = wrap_angle(phi[:, None] - rows[..., 0] - rows[..., 1])
        rows = np.concatenate([rows, q3[..., None]], axis=-1)
    outside = np.where(too_far, r - outer, np.where(too_close, inner - r, 0.0))
    return rows, case, outside


def solve_planar(x, y, l1: float, l2: float, tol: float, phi=None, l3: float = 0.0):
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


def describe_2r(case: int, r: float, l1: float, l2: float, point: str) -> tuple[str, str | None]:
    outer, inner = l1 + l2, abs(l1 - l2)
    r_text, outer_text, inner_text = (quantity_text(v) for v in (r, outer, inner))
    where = f"{point} at r = {r_text}"
    if case == _TWO:
        inside = f"|l1 - l2| = {inner_text} < r < l1 + l2 = {outer_text}"
        return f"2 solutions: {where} is inside the workspace {inside}", None
    if case == _OUTER:
        return f"1 solution: {where} is on the outer boundary r = l1 + l2 = {outer_text} (arm straight, q2 = 0)", None
    if case == _INNER:
        return f"1 solution: {where} is on the inner boundary r = |l1 - l2| = {inner_text} (arm folded, q2 = pi)", None
    if case == FREE_CASE:
        return (
            f"infinitely many solutions: {point} at the base with l1 = l2 = {quantity_text(l1)}: "
            "q2 = pi (folded) and q1 takes any value"
        ), None
    if case == _FAR:
        gap = quantity_text(r - outer)
        return f"no solution: {point} too far: r = {r_text} > l1 + l2 = {outer_text}, outside by {gap}", "too far"
    gap = quantity_text(inner - r)
    return f"no solution: {point} too close: r = {r_text} < |l1 - l2| = {inner_text}, outside by {gap}", "too close"


def case_labels(case: int) -> tuple[str, ...]:
    """The branch labels of the solutions of a case code of :func:`solve_planar`, in slot order."""
    return {
        _TWO: (ELBOW_DOWN, ELBOW_UP),
        _OUTER: (STRAIGHT,),
        _INNER: (FOLDED,),
        FREE_CASE: (Q1_FREE,),
    }.get(case, ())


# --------------------------------------------------------------------------
# the check by forward kinematics


def planar_dh_table(lengths) -> DHTable:
    """Standard DH table of a planar serial arm: row i is ``(a, alpha, d, theta) = (l_i, 0, 0, 0)``.

    Every joint turns about +z; the tool frame is at the end of the last link,
    its x axis along it (the module conventions, and the bundled
    ``planar_2r`` / ``planar_3r``). :func:`manipkit.dh.dh_fk` of it is the
    independent forward kinematics every planar answer is checked with.

    Examples
    --------
    >>> from manipkit.dh.table import dh_fk
    >>> dh_fk(planar_dh_table([1.0, 0.5]), [np.pi / 2, -np.pi / 2])[:3, 3].round(12) + 0.0
    array([0.5, 1. , 0. ])
    """
    rows = tuple(DHRow(link_length(length, f"l{i + 1}"), 0.0, 0.0, 0.0, name=f"joint{i + 1}")
                 for i, length in enumerate(np.atleast_1d(as_float(lengths, "lengths"))))
    return DHTable(rows, "standard", f"planar_{len(rows)}r")


@functools.lru_cache(maxsize=64)
def table_of(lengths: tuple[float, ...]) -> DHTable:
    """:func:`planar_dh_table` of checked link lengths, kept for the next call with the same arm."""
    return planar_dh_table(lengths)


def planar_target(x: float, y: float, phi: float | None = None) -> np.ndarray:
    """T_base_tool of a planar target: at (x, y, 0), turned by phi about z (identity without phi)."""
    T = np.eye(4)
    T[0, 3], T[1, 3] = x, y
    if phi is not None:
        T[:3, :3] = rot_z(float(phi))
    return T


