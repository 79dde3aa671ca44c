"""7R arms with a spherical shoulder, a revolute elbow and a spherical wrist (SRS), at a given arm angle.

Axes 1, 2, 3 meet at the shoulder point ``S``, axes 5, 6, 7 at the wrist
centre ``c``; axis 4 is the elbow (the KUKA iiwa, the DLR/Franka-like SRS
arms). For a target ``g = T M^-1`` the wrist centre ``W = g c`` is fixed, so:

1. the elbow angle ``t4`` makes the distance from ``S`` to the wrist centre
   right (subproblem 3: two angles);
2. the shoulder turns the elbow-moved centre ``u = E4 c - S`` onto
   ``v = W - S``: a one-parameter family, the rotation about ``v``. Its
   parameter is the **arm angle** ``psi``: the angle of the elbow's plane
   about the shoulder-wrist line from the *reference plane*, the plane the
   arm takes with joint 3 at its reference value (``q0``). The reference
   shoulder ``R_ref`` (joint 3 held) comes from subproblem 2 on axes 1, 2;
   the shoulder at ``psi`` is ``R(v, psi) R_ref``, split into ``t1, t2, t3``
   by subproblems 2 and 1;
3. the wrist ``t5, t6, t7`` as for a 6R spherical wrist.

Up to 8 branches per arm angle (elbow, shoulder, wrist). numpy only; one target (:func:`solve_srs`) or
one after another, each at its own arm angle (:func:`solve_srs_many`). The same sequence compiled, with the
check of every branch, is :mod:`manipkit.closed_form.srs_kernel` (it hands targets near a threshold back
here).
"""

from __future__ import annotations

import numpy as np

from manipkit.closed_form.arms import Branches, rotation_matrix
from manipkit.closed_form.subproblems import rotate, sp1, sp2, sp3

__all__ = ["solve_srs", "solve_srs_many"]


def _split_shoulder(h, R) -> list[tuple[float, float, float]]:
    """Angles (t1, t2, t3) with ``R(h1, t1) R(h2, t2) R(h3, t3) = R`` (up to two)."""
    x = R @ h[2]
    pair = sp2(h[0], x, h[1], h[2])  # R(h1, -t1) x = R(h2, t2) h3
    if not pair.count:
        return []
    out = []
    v = np.cross(h[2], np.eye(3)[int(np.argmin(np.abs(h[2])))])
    v = v / np.linalg.norm(v)
    for minus1, t2 in pair.theta[: int(min(pair.count, 2)) if np.isfinite(pair.count) else 1]:
        t1 = -float(minus1)
        wanted = rotation_matrix(h[1], -t2) @ rotation_matrix(h[0], -t1) @ R @ v
        t3, _, _ = sp1(h[2], v, wanted)
        out.append((t1, float(t2), float(t3)))
    return out


def solve_srs(h: np.ndarray, p: np.ndarray, g: np.ndarray, points: dict, arm_angle: float, *,
              tol: float = 1e-12) -> Branches:
    """Every branch of an SRS arm (axes ``h``, points ``p``: (7, 3)) for one target ``g`` (4, 4) at ``arm_angle``.

    ``points``: ``"shoulder"`` (where axes 1-3 meet) and ``"wrist"`` (5-7).
    Returns :class:`manipkit.closed_form.arms.Branches` with one target and
    8 slots of 7 angles; ``miss["reach"]`` when the elbow cannot make the
    shoulder-wrist distance; ``free`` marks the wrist's first joint when its
    axes 5 and 7 align (t5 free).
    """
    S, c = points["shoulder"], points["wrist"]
    g = np.asarray(g, dtype=float).reshape(4, 4)
    W = g[:3, :3] @ c + g[:3, 3]
    v = W - S
    theta = np.zeros((1, 8, 7))
    valid = np.zeros((1, 8), dtype=bool)
    free = np.full((1, 8), -1)
    elbow = sp3(h[3], c - p[3], S - p[3], float(np.linalg.norm(v)), tol=tol)
    miss = {"shoulder": np.zeros(1), "reach": np.array([float(elbow.miss)] if not elbow.count else [0.0]),
            "orientation": np.zeros(1)}
    wrist_axes = h[4:7]
    for e, t4 in enumerate(elbow.theta[: int(min(elbow.count, 2))]):
        u = p[3] + rotate(h[3], t4, c - p[3]) - S
        reference = sp2(h[1], u, h[0], v, tol=tol)  # R(h2, t2) u = R(h1, -t1) v, joint 3 at its reference
        if not reference.count:
            continue
        t2, minus1 = reference.theta[0]
        R_ref = rotation_matrix(h[0], -minus1) @ rotation_matrix(h[1], t2)
        R_shoulder = rotation_matrix(v / np.linalg.norm(v), arm_angle) @ R_ref
        for s, (t1, t2_, t3) in enumerate(_split_shoulder(h, R_shoulder)[:2]):
            R_arm = R_shoulder @ rotation_matrix(h[3], t4)
            R_rem = R_arm.T @ g[:3, :3]
            x = R_rem @ wrist_axes[2]
            pair = sp2(wrist_axes[0], x, wrist_axes[1], wrist_axes[2], tol=tol)
            if not pair.count:
                continue
            singular = bool(np.isinf(pair.count))
            vv = np.cross(wrist_axes[2], np.eye(3)[int(np.argmin(np.abs(wrist_axes[2])))])
            vv = vv / np.linalg.norm(vv)
            for w, (minus5, t6) in enumerate(pair.theta[: 1 if singular else int(pair.count)]):
                t5 = -float(minus5)
                wanted = rotation_matrix(wrist_axes[1], -t6) @ rotation_matrix(wrist_axes[0], -t5) @ R_rem @ vv
                t7, _, _ = sp1(wrist_axes[2], vv, wanted)
                slot = 4 * e + 2 * s + w
                theta[0, slot] = [t1, t2_, t3, t4, t5, t6, float(t7)]
                valid[0, slot] = True
                free[0, slot] = 4 if singular else -1
    return Branches(theta, valid, free, miss, valid.copy())


def solve_srs_many(h: np.ndarray, p: np.ndarray, g: np.ndarray, points: dict, arm_angles: np.ndarray) -> Branches:
    """:func:`solve_srs` of every target ``g[i]`` (N, 4, 4) at its arm angle ``arm_angles[i]`` (N,, rad), stacked
    into one :class:`manipkit.closed_form.arms.Branches` of N targets."""
    parts = [solve_srs(h, p, target, points, float(angle)) for target, angle in zip(g, arm_angles, strict=True)]
    if not parts:
        return Branches(np.zeros((0, 8, 7)), np.zeros((0, 8), dtype=bool), np.full((0, 8), -1),
                        {key: np.zeros(0) for key in ("shoulder", "reach", "orientation")}, np.zeros((0, 8), dtype=bool))
    return Branches(np.concatenate([b.theta for b in parts]), np.concatenate([b.valid for b in parts]),
                    np.concatenate([b.free for b in parts]),
                    {key: np.concatenate([b.miss[key] for b in parts]) for key in parts[0].miss},
                    np.concatenate([b.near for b in parts]))
