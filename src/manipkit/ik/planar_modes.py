"""The other modes of the planar arms: a 2R arm asked for a pose, a 3R arm asked for a position.

:func:`manipkit.closed_form.planar.ik_2r` solves a planar position and
:func:`manipkit.closed_form.planar.ik_3r` a planar pose (docs/architecture.md,
"IK results"). Here:

- :func:`ik_2r_pose`: a planar pose (x, y, phi) for a 2R arm, whose tool
  angle follows from its position: the elbows that have the angle, else 0
  solutions with ``unmet = (("orientation", rad),)``.
- :func:`ik_3r_position`: a planar position (x, y) for a 3R arm: a family in
  the free tool angle ``phi``, a few members sampled, any others through
  ``result.members(phis)``.

Conventions as in :mod:`manipkit.closed_form.planar`; every returned row is
checked by the forward kinematics of the arm's DH table
(:func:`manipkit.closed_form.planar.planar_dh_table`).
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.closed_form.checks import finite_array, link_length, quantity_text, tolerance
from manipkit.closed_form.planar import FOLDED, planar_target
from manipkit.errors import PlanarArmError
from manipkit.ik.planar import checked_solutions, ik_2r, ik_3r
from manipkit.ik.result import PLANAR_POSE, PLANAR_POSITION, IKResult, read_only
from manipkit.spatial.rotations import wrap_angle

__all__ = ["ik_2r_pose", "ik_3r_position"]


def ik_2r_pose(x, y, phi, l1, l2, *, tol: float = 1e-12) -> IKResult:
    """The planar 2R solutions that put the tool at ``(x, y)`` *with* tool angle ``phi``: usually none.

    A 2R arm has two joints for three pose components: its tool angle
    ``q1 + q2`` follows from the position (one value per elbow), so a pose
    target is met only when ``phi`` is one of those values.

    Parameters
    ----------
    x, y : float
        Target tool position (m).
    phi : float
        Target tool angle (rad), the angle of the tool x axis from the base x axis.
    l1, l2 : float
        Link lengths (m), > 0.
    tol : float, keyword-only
        As in :func:`ik_2r`.

    Returns
    -------
    IKResult
        ``mode`` is ``PLANAR_POSE``. The rows of :func:`ik_2r` whose pose
        (by the DH table's FK) matches ``(x, y, phi)`` within
        ``max(CHECK_TOL, tol)``. When the position is reached but no row has
        the angle, 0 solutions with ``unmet = (("orientation", e),)``, ``e``
        the smallest angle error (rad) over the position solutions. At the
        base with ``l1 = l2`` (q1 free) the angle fixes ``q1 = phi - pi``.

    Examples
    --------
    >>> result = ik_2r_pose(1.0, 0.5, 0.3, 1.0, 1.0)
    >>> result.count, result.unmet[0][0], round(result.unmet[0][1], 6)
    (0, 'orientation', 0.813949)
    >>> ik_2r_pose(1.0, 1.0, np.pi / 2, 1.0, 1.0).labels  # elbow-down reaches (1, 1) at q = (0, pi / 2)
    ('elbow-down',)
    """
    phi = float(finite_array(phi, "phi", scalar=True))
    position = ik_2r(x, y, l1, l2, tol=tol)
    l1, l2, x, y = float(l1), float(l2), float(x), float(y)
    if not position.success:
        return position.replaced(mode=PLANAR_POSE, solver="planar.ik_2r_pose")
    rows, labels = position.solutions, position.labels
    if position.infinite:  # at the base with l1 = l2: q2 = pi, and phi = q1 + pi fixes q1
        rows, labels = read_only([[float(wrap_angle(phi - math.pi)), math.pi]], (2,)), (FOLDED,)
    target = planar_target(x, y, phi)
    result = checked_solutions(rows, labels, (l1, l2), target, pose=True, tol=tol)
    if result.success:
        return result.replaced(note=f"{result.count} solution(s): {position.note}; the tool angle matches phi",
                               mode=PLANAR_POSE, solver="planar.ik_2r_pose")
    headings = wrap_angle(rows[:, 0] + rows[:, 1])
    errors = np.abs(wrap_angle(headings - phi))
    miss = float(errors.min())
    reason = (
        f"no solution: orientation: phi = {quantity_text(phi)} rad cannot be met; a 2R arm's tool angle q1 + q2 "
        f"follows from its position, here {', '.join(quantity_text(float(h)) for h in headings)} rad "
        f"({', '.join(labels)}); off by {quantity_text(miss)} rad at the nearest (position-only IK reaches (x, y))"
    )
    return IKResult(
        read_only((), (2,)), (), 0, reason, read_only(()), read_only(()), mode=PLANAR_POSE,
        solver="planar.ik_2r_pose", unmet=(("orientation", miss),),
    )


def ik_3r_position(x, y, l1, l2, l3, *, samples: int = 4, tol: float = 1e-12) -> IKResult:
    """Planar 3R solutions putting the tool at position ``(x, y)``, any tool angle: a family in ``phi``.

    Three joints for two position components leave one free: the tool angle
    ``phi``. For each ``phi`` whose wrist point ``(x - l3 cos phi, y - l3 sin phi)``
    lies in the annulus ``|l1 - l2| <= |w| <= l1 + l2``, :func:`ik_3r`
    gives up to two solutions.

    Parameters
    ----------
    x, y : float
        Target tool position (m).
    l1, l2, l3 : float
        Link lengths (m), > 0.
    samples : int, keyword-only
        How many values of ``phi`` to sample (>= 1), spread evenly over the
        reachable angles (inside them, away from their ends).
    tol : float, keyword-only
        As in :func:`ik_3r`; also how far out of reach still counts as on the boundary.

    Returns
    -------
    IKResult
        ``mode`` ``PLANAR_POSITION``; ``count`` infinite with
        ``free_parameter = "phi"`` and ``family`` the reachable angles in
        words; rows: the members at the sampled angles, labelled
        ``"phi = 0.5, elbow-down"``, residuals by FK (position; rotation 0).
        ``result.members(phis)`` solves any other angles. Out of reach
        (``r > l1 + l2 + l3`` or closer than the arm can fold): 0 solutions,
        ``unmet = (("position", distance outside),)``.

    Notes
    -----
    With ``r = |(x, y)|``, ``psi = atan2(y, x)`` and ``delta = phi - psi``,
    ``|w|^2 = r^2 + l3^2 - 2 r l3 cos(delta)``, so ``|w| <= l1 + l2`` and
    ``|w| >= |l1 - l2|`` bound ``cos(delta)`` to ``[c_lo, c_hi]``: ``phi`` is
    reachable on the two arcs ``psi +- [acos(c_hi), acos(c_lo)]``. At the
    base (``r = 0``) ``|w| = l3`` for every ``phi``.

    Examples
    --------
    >>> result = ik_3r_position(4.0, 2.0, 4.0, 2.0, 1.0)
    >>> result.count, result.free_parameter, len(result.labels)
    (inf, 'phi', 8)
    >>> result.members([np.pi]).solutions.round(6) + 0.0  # phi = pi: wrist at (5, 2), cos q2 = 9/16
    array([[ 0.068399,  0.97339 ,  2.099804],
           [ 0.692614, -0.97339 , -2.860816]])
    """
    # Over 80 lines: the docstring (the family's arcs, derived) is half of it; the code is one pass.
    l1, l2, l3 = link_length(l1, "l1"), link_length(l2, "l2"), link_length(l3, "l3")
    x, y = float(finite_array(x, "x", scalar=True)), float(finite_array(y, "y", scalar=True))
    tol = tolerance(tol)
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise PlanarArmError(f"samples = {samples!r} must be a whole number >= 1")
    r, psi = math.hypot(x, y), math.atan2(y, x)
    outer, inner = l1 + l2, abs(l1 - l2)
    far, near = outer + l3, max(0.0, inner - l3, l3 - outer)

    def members(values) -> IKResult:
        return _members_3r(x, y, values, (l1, l2, l3), tol)

    where = f"target at r = {quantity_text(r)}"
    if r > far + tol or r < near - tol:
        gap = r - far if r > far else near - r
        side = "too far" if r > far else "too close"
        bound = f"l1 + l2 + l3 = {quantity_text(far)}" if r > far else f"the closest the arm folds, {quantity_text(near)}"
        reason = f"no solution: {where} {side} for any tool angle: {'beyond' if r > far else 'inside'} {bound}, outside by {quantity_text(gap)}"
        return IKResult(
            read_only((), (3,)), (), 0, reason, read_only(()), read_only(()), outside_by=gap, side=side,
            mode=PLANAR_POSITION, solver="planar.ik_3r_position", unmet=(("position", gap),),
        )
    if r <= tol:
        deltas = 2.0 * math.pi * np.arange(samples) / samples
        arcs = "every phi"
    else:
        c_hi = (r * r + l3 * l3 - inner * inner) / (2.0 * r * l3)
        c_lo = (r * r + l3 * l3 - outer * outer) / (2.0 * r * l3)
        a, b = math.acos(min(max(c_hi, -1.0), 1.0)), math.acos(min(max(c_lo, -1.0), 1.0))
        half = -(-samples // 2)
        inside = a + (b - a) * (np.arange(half) + 0.5) / half
        deltas = np.unique(np.concatenate([inside, -inside])) if b - a > 0.0 else np.unique([a, -a])
        arcs = "every phi" if a == 0.0 and b == math.pi else (
            f"phi in psi +- [{quantity_text(a)}, {quantity_text(b)}] rad with psi = atan2(y, x) = {quantity_text(psi)}")
    sampled = members(wrap_angle(psi + deltas))
    family = (f"the tool angle phi is free ({arcs}); for each, up to 2 solutions (elbow-down, elbow-up) of the "
              "wrist point (x - l3 cos phi, y - l3 sin phi), q3 = phi - q1 - q2; result.members(phis) gives them")
    if not sampled.success:  # reachable by the bounds, yet no sampled member passed the FK check: say so, no family
        return sampled.replaced(note=f"no solution: {where}: no sampled tool angle gave a solution that passed the "
                                f"forward-kinematics check ({sampled.note})", solver="planar.ik_3r_position")
    reason = f"infinitely many solutions: {where}, position only: {family}; {sampled.count} sampled"
    return sampled.replaced(count=math.inf, note=reason, free_parameter="phi", family=family,
                            family_function=members, solver="planar.ik_3r_position")


def _members_3r(x: float, y: float, values, lengths, tol: float) -> IKResult:
    """The planar 3R solutions at each tool angle in ``values``, checked for the position (x, y)."""
    phis = np.atleast_1d(finite_array(values, "phi values"))
    if phis.ndim != 1:
        raise PlanarArmError(f"phi values must be a sequence of angles, got shape {phis.shape}")
    rows, labels = [], []
    for phi in phis:
        member = ik_3r(x, y, float(phi), *lengths, tol=tol)
        rows.extend(member.solutions)
        labels.extend(f"phi = {quantity_text(float(phi))}, {label}" for label in member.labels)
    result = checked_solutions(read_only(rows, (3,)), tuple(labels), lengths, planar_target(x, y), pose=False, tol=tol)
    return result.replaced(note=f"{result.count} solution(s) at {phis.size} tool angle(s) phi", mode=PLANAR_POSITION,
                           solver="planar.ik_3r_position")
