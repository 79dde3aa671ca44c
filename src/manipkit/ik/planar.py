"""Every IK solution of planar 2R and 3R arms as manipkit's one IK result (:class:`manipkit.ik.result.IKResult`).

The math is :mod:`manipkit.closed_form.planar` (its conventions hold here: the arm in the x-y plane of its
base, joints about +z, angles counter-clockwise from +x, radians wrapped to (-pi, pi], metres; elbow-down,
``q2`` in (0, pi), first). This module turns its rows into answers: every returned row is put through the
forward kinematics of the arm's DH table (:func:`manipkit.closed_form.planar.planar_dh_table`,
:func:`manipkit.dh.dh_fk`: an independent path from the IK algebra) and kept only when it reproduces the
target in the asked mode within ``max(CHECK_TOL, tol)``; those are the residuals reported. :func:`ik_2r`
solves a planar position (x, y), :func:`ik_3r` a planar pose (x, y, phi); the other modes of these arms are in
:mod:`manipkit.ik.planar_modes`. The ``*_batch`` solvers handle millions of targets without a Python loop.
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.closed_form.checks import finite_array, link_length, quantity_text, tolerance
from manipkit.closed_form.planar import (
    ELBOW_DOWN,
    ELBOW_UP,
    FREE_CASE,
    case_labels,
    describe_2r,
    planar_target,
    solve_planar,
    table_of,
    wrist_point,
)
from manipkit.dh.table import dh_fk
from manipkit.ik.result import PLANAR_POSE, PLANAR_POSITION, IKBatch, IKResult, read_only
from manipkit.spatial.rotations import rot_z
from manipkit.spatial.transforms import pose_residuals

__all__ = ["CHECK_TOL", "checked_solutions", "ik_2r", "ik_2r_batch", "ik_3r", "ik_3r_batch"]

#: Residual (m and rad) within which a row's forward kinematics must reproduce the target to be returned.
CHECK_TOL = 1e-9


# --------------------------------------------------------------------------
# inverse kinematics: 2R


def ik_2r_batch(xy, l1, l2, *, tol: float = 1e-12) -> IKBatch:
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
    IKBatch
        ``solutions`` (..., 2, 2) with rows ``(q1, q2)``: slot 0 elbow-down
        (or the boundary solution), slot 1 elbow-up, NaN where absent;
        ``count`` (...) in {0, 1, 2, inf}; ``outside_by`` (...); ``mode``
        ``PLANAR_POSITION``. ``success`` and the residuals per slot come from
        the DH table's forward kinematics of every slot, measured on first use.

    Examples
    --------
    >>> result = ik_2r_batch([[1.0, 1.0], [2.0, 0.0], [3.0, 0.0]], 1.0, 1.0)
    >>> result.count, result.success
    (array([2., 1., 0.]), array([ True,  True, False]))
    >>> result.solutions[0].round(6)  # elbow-down (q2 > 0), then elbow-up
    array([[ 0.      ,  1.570796],
           [ 1.570796, -1.570796]])
    """
    l1, l2 = link_length(l1, "l1"), link_length(l2, "l2")
    given = xy
    xy = finite_array(xy, "xy", shape_tail=(2,))
    tol = tolerance(tol)
    solutions, _, counts, outside = solve_planar(xy[..., 0], xy[..., 1], l1, l2, tol)
    return _batch(solutions, counts, outside, (l1, l2), xy.copy() if xy is given else xy, mode=PLANAR_POSITION,
                  tol=tol, solver="planar.ik_2r_batch")


def ik_2r(x, y, l1, l2, *, tol: float = 1e-12) -> IKResult:
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
    IKResult
        ``solutions`` (k, 2), rows ``(q1, q2)`` in radians wrapped to
        (-pi, pi], elbow-down (q2 > 0) first; ``labels``, ``count``,
        ``note`` (why that many), ``reason`` (``""`` unless there is none),
        for unreachable targets ``outside_by`` and ``side``, and per row the
        distance (m) of the DH table's FK (:func:`planar_dh_table`) from the target in
        ``residual_position`` (``residual_rotation`` is 0: a 2R target has
        no orientation).

        - 2 solutions strictly inside the annulus ``|l1 - l2| < r < l1 + l2``;
        - 1 on either boundary circle (``"straight"`` or ``"folded"``);
        - 0 outside it (``side`` ``"too far"`` or ``"too close"``);
        - infinitely many at the base when ``l1 = l2``: ``q2 = pi`` and any
          ``q1`` (``free_parameter = "q1"``, ``free_joints = (0,)``;
          ``solutions`` holds ``(0, pi)``).

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
    l1, l2 = link_length(l1, "l1"), link_length(l2, "l2")
    x, y = finite_array(x, "x", scalar=True), finite_array(y, "y", scalar=True)
    solutions, case, _, outside = solve_planar(x, y, l1, l2, tolerance(tol))
    case = int(case)
    labels = case_labels(case)
    rows = read_only(solutions[: len(labels)], (2,))
    reason, side = describe_2r(case, float(np.hypot(x, y)), l1, l2, "target")
    return _planar_result(rows, case, reason, (l1, l2), planar_target(x, y), outside, side,
                          mode=PLANAR_POSITION, tol=tol, solver="planar.ik_2r")


# --------------------------------------------------------------------------
# inverse kinematics: 3R


def ik_3r_batch(poses, l1, l2, l3, *, tol: float = 1e-12) -> IKBatch:
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
    IKBatch
        ``solutions`` (..., 2, 3) with rows ``(q1, q2, q3)``: slot 0
        elbow-down (or the boundary solution), slot 1 elbow-up, NaN where
        absent; ``count`` (...) in {0, 1, 2, inf}; ``outside_by`` (...) of
        the wrist point; ``mode`` ``PLANAR_POSE``. ``success`` and the
        residuals per slot (m, and the tool angle error in rad) come from the
        DH table's forward kinematics, measured on first use.

    Examples
    --------
    >>> result = ik_3r_batch([[3.0, 2.0, np.pi], [9.0, 0.0, 0.0]], 4.0, 2.0, 1.0)
    >>> result.count
    array([2., 0.])
    """
    l1, l2, l3 = link_length(l1, "l1"), link_length(l2, "l2"), link_length(l3, "l3")
    given = poses
    poses = finite_array(poses, "poses", shape_tail=(3,))
    tol = tolerance(tol)
    solutions, _, counts, outside = solve_planar(poses[..., 0], poses[..., 1], l1, l2, tol, phi=poses[..., 2], l3=l3)
    return _batch(solutions, counts, outside, (l1, l2, l3), poses.copy() if poses is given else poses,
                  mode=PLANAR_POSE, tol=tol, solver="planar.ik_3r_batch")


def ik_3r(x, y, phi, l1, l2, l3, *, tol: float = 1e-12) -> IKResult:
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
    IKResult
        ``solutions`` (k, 3), rows ``(q1, q2, q3)`` in radians wrapped to
        (-pi, pi], elbow-down (q2 > 0) first, and the same ``labels``,
        ``count``, ``note``, ``reason``, ``outside_by``, ``side`` as :func:`ik_2r` for
        the wrist point; residuals of the DH table's FK of each row (m, and the
        tool angle error in rad). With infinitely many solutions (wrist at the base,
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
    l1, l2, l3 = link_length(l1, "l1"), link_length(l2, "l2"), link_length(l3, "l3")
    x, y = finite_array(x, "x", scalar=True), finite_array(y, "y", scalar=True)
    phi = finite_array(phi, "phi", scalar=True)
    solutions, case, _, outside = solve_planar(x, y, l1, l2, tolerance(tol), phi=phi, l3=l3)
    wx, wy = wrist_point(x, y, phi, l3)  # for the message
    case = int(case)
    labels = case_labels(case)
    rows = read_only(solutions[: len(labels)], (3,))
    point = f"wrist point ({quantity_text(float(wx))}, {quantity_text(float(wy))})"
    reason, side = describe_2r(case, float(np.hypot(wx, wy)), l1, l2, point)
    if case == FREE_CASE:
        reason += ", and q3 = phi - q1 - pi"
    return _planar_result(rows, case, reason, (l1, l2, l3), planar_target(x, y, phi), outside, side,
                          mode=PLANAR_POSE, tol=tol, solver="planar.ik_3r")


# --------------------------------------------------------------------------
# the check by forward kinematics


def checked_solutions(rows, labels, lengths, target, *, pose: bool, tol: float, rejected: int = 0) -> IKResult:
    """The rows whose DH forward kinematics reproduce ``target`` (position, and rotation when ``pose``)."""
    rows = read_only(rows, (len(lengths),))
    T_reached = dh_fk(table_of(tuple(lengths)), rows).reshape(-1, 4, 4)
    # the target and the tables' rotations are exact products of Rz: no need to project them first
    residuals = pose_residuals(target, T_reached, mode="pose" if pose else "position", project=False)
    position, rotation = (np.atleast_1d(e) for e in residuals)
    limit = max(CHECK_TOL, tol)
    keep = (position <= limit) & (rotation <= limit)
    dropped = rejected + int(np.count_nonzero(~keep))
    kept = tuple(label for label, k in zip(labels, keep) if k)
    reason = ""
    if dropped:
        reason = f"{dropped} candidate(s) failed the forward-kinematics check (residual > {quantity_text(limit)})"
    return IKResult(read_only(rows[keep], (len(lengths),)), kept, len(kept), reason,
                    read_only(position[keep]), read_only(rotation[keep]), rejected=dropped)


def _planar_result(rows, case: int, reason: str, lengths, target, outside, side, *, mode: str, tol: float,
                   solver: str) -> IKResult:
    checked = checked_solutions(rows, case_labels(case), lengths, target, pose=mode == PLANAR_POSE, tol=tol)
    free = case == FREE_CASE and checked.success
    if checked.rejected:
        reason += "; " + checked.note
    unmet = (("position", float(outside)),) if outside > 0.0 else ()
    return checked.replaced(
        count=math.inf if free else checked.count, note=reason, free_parameter="q1" if free else "",
        free_joints=(0,) if free else (), outside_by=float(outside), side=side or "", mode=mode, solver=solver,
        unmet=unmet,
    )


_RESIDUAL_BLOCK = 65536  # targets whose slots are put through FK at once (their (2, 4, 4) poses: 16 MB)


def _batch(solutions, counts, outside, lengths, targets, *, mode: str, tol: float, solver: str) -> IKBatch:
    """The planar batch answer; ``success`` and the residuals of every slot by the DH table's FK, on first use."""
    def measure(Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return _slot_residuals(Q, targets, tuple(lengths), pose=mode == PLANAR_POSE)

    limit = max(CHECK_TOL, tol)
    return IKBatch(solutions, counts, labels=(ELBOW_DOWN, ELBOW_UP), mode=mode, solver=solver, measure=measure,
                   limit=(limit, limit), outside_by=outside)


def _slot_residuals(Q: np.ndarray, targets: np.ndarray, lengths: tuple[float, ...], *, pose: bool):
    """Residuals (..., 2) m and rad of every slot of ``Q`` (..., 2, n) against planar ``targets`` (..., 2 or 3),
    by :func:`manipkit.dh.dh_fk` of the arm's table and :func:`manipkit.spatial.transforms.pose_residuals`;
    NaN for an empty slot."""
    table, n = table_of(lengths), len(lengths)
    flat_Q, flat_targets = Q.reshape(-1, 2, n), targets.reshape(-1, targets.shape[-1])
    position, rotation = np.empty(flat_Q.shape[:2]), np.empty(flat_Q.shape[:2])
    for start in range(0, flat_Q.shape[0], _RESIDUAL_BLOCK):
        block = slice(start, start + _RESIDUAL_BLOCK)
        wanted = flat_targets[block]
        T_target = np.tile(np.eye(4), (wanted.shape[0], 1, 1, 1))
        T_target[..., 0, 3], T_target[..., 1, 3] = wanted[:, 0, None], wanted[:, 1, None]
        if pose:
            T_target[..., :3, :3] = rot_z(wanted[:, 2])[:, None]
        with np.errstate(invalid="ignore"):
            position[block], rotation[block] = pose_residuals(T_target, dh_fk(table, flat_Q[block], check=False),
                                                              mode="pose" if pose else "position", project=False)
    rotation[np.isnan(position)] = np.nan
    return position.reshape(Q.shape[:-1]), rotation.reshape(Q.shape[:-1])
