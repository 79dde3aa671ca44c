"""Checks of a chosen joint path between its waypoints: it stays on the tool path, and it does not collide.

A step from ``q_a`` (at pose ``T_a``) to ``q_b`` (at ``T_b``) is executed as
the joint-space straight line ``q(s) = q_a + s (q_b - q_a)``, ``s`` in
[0, 1]. :func:`deviating_steps` (and :func:`deviating_pairs`, on any pairs of
candidates at once) checks it as MoveIt 2's precision check of a Cartesian
path does: the forward kinematics of the joint midpoint must lie
within ``tol`` (m, rad) of the Cartesian midpoint of the two poses (position
interpolated linearly, rotation along the geodesic), and each half is
checked again, recursively, to ``depth`` levels (``2**depth - 1`` points per
step, all of them checked). A branch flip hidden between two waypoints (a wrist turning half a
turn and back) leaves the path at some midpoint and fails. :func:`step_samples`
gives the configurations a step passes through at most ``joint_step`` (rad
or m, the largest joint change) apart, for collision checks.
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.errors import OptionError
from manipkit.spatial.transforms import pose_residuals
from manipkit.text import short_text

__all__ = ["MAX_STEP_SAMPLES", "PAIR_CHUNK", "deviating_pairs", "deviating_steps", "step_samples"]

#: The most configurations the steps of one path are sampled at for collision checks (112 MB of rows for
#: a 7-joint arm; each is a collision check of some microseconds).
MAX_STEP_SAMPLES = 2_000_000
#: How many candidate pairs :func:`deviating_pairs` checks at once (each pair's ``2**depth - 1`` target poses and
#: configurations are held together: 4096 pairs at depth 4 are about 8 MB of poses).
PAIR_CHUNK = 4096


def deviating_steps(chain, Q: np.ndarray, T: np.ndarray, *, tol: tuple[float, float], depth: int = 4,
                    steps=None) -> tuple[np.ndarray, np.ndarray, int]:
    """Which steps of the joint path ``Q`` (N, n) between target poses ``T`` (N, 4, 4) leave the tool path.

    Every point a recursive midpoint check to ``depth`` levels would visit is checked: the fractions
    ``k / 2**depth``, ``k = 1 .. 2**depth - 1``, of each step in ``steps`` (default all), the joint-interpolated
    configuration's forward kinematics against :func:`manipkit.paths.poses.interpolate_poses` at the same fraction
    (all steps at once: :func:`manipkit.paths.poses.interpolate_pose_steps`).
    Returns ``(bad (N - 1,) bool, worst (N - 1, 2) (position m, rotation rad) of the worst point, points
    checked)``; a step is bad when some point is farther than ``tol`` (position m, rotation rad).
    """
    N = len(Q)
    bad = np.zeros(max(N - 1, 0), dtype=bool)
    worst = np.zeros((max(N - 1, 0), 2))
    steps = np.arange(N - 1) if steps is None else np.asarray(steps, dtype=np.intp)
    if N < 2 or not len(steps):
        return bad, worst, 0
    bad[steps], worst[steps], count = deviating_pairs(chain, Q[steps], Q[steps + 1], T[steps], T[steps + 1],
                                                      tol=tol, depth=depth)
    return bad, worst, count


def deviating_pairs(chain, Qa: np.ndarray, Qb: np.ndarray, Ta: np.ndarray, Tb: np.ndarray, *,
                    tol: tuple[float, float], depth: int = 4) -> tuple[np.ndarray, np.ndarray, int]:
    """Which steps ``Qa[m] -> Qb[m]`` (m, n) between target poses ``Ta[m] -> Tb[m]`` (m, 4, 4) leave the tool path:
    :func:`deviating_steps`' rule on any pairs at once (every pair of candidates between two rungs that the
    velocity bound lets pass, checked before the ladder first uses them), ``PAIR_CHUNK`` pairs at a time.

    At the fractions ``k / 2**depth``, ``k = 1 .. 2**depth - 1``, the joint-interpolated configuration's forward
    kinematics against :func:`manipkit.paths.poses.interpolate_pose_pairs`. Returns ``(bad (m,) bool, worst (m, 2)
    (position m, rotation rad) of the worst point, points checked)``; a pair is bad when some point is farther
    than ``tol`` (position m, rotation rad).
    """
    from manipkit.paths.poses import interpolate_pose_pairs

    m = len(Qa)
    worst = np.zeros((m, 2))
    s = np.arange(1, 2 ** depth) / 2 ** depth
    for start in range(0, m, PAIR_CHUNK):
        part = slice(start, min(start + PAIR_CHUNK, m))
        wanted = interpolate_pose_pairs(Ta[part], Tb[part], s)  # (chunk, p, 4, 4)
        q = Qa[part, None, :] + s[None, :, None] * (Qb[part] - Qa[part])[:, None, :]
        position, rotation = pose_residuals(wanted, chain.fk(q), project=False)
        worst[part, 0] = position.max(axis=1)
        worst[part, 1] = rotation.max(axis=1)
    bad = (worst[:, 0] > tol[0]) | (worst[:, 1] > tol[1])
    return bad, worst, int(m * len(s))


def step_samples(Q: np.ndarray, steps: np.ndarray, joint_step: float) -> tuple[np.ndarray, np.ndarray]:
    """Configurations inside the steps ``steps`` (indices ``i``: from ``Q[i]`` to ``Q[i + 1]``), at most
    ``joint_step`` apart in every joint (the ends excluded): ``(rows (M, n), step of each row (M,))``."""
    spans = [float(np.abs(Q[i + 1] - Q[i]).max()) for i in steps]
    total = sum(max(1, math.ceil(span / joint_step)) - 1 for span in spans)
    if total > MAX_STEP_SAMPLES:
        raise OptionError(f"checking the steps {short_text(joint_step)} rad apart takes {total} samples, more than "
                          f"{MAX_STEP_SAMPLES}: give a larger collision step")
    rows, owner = [], []
    for i, span in zip(steps, spans):
        pieces = max(1, math.ceil(span / joint_step))
        if pieces < 2:
            continue
        s = np.arange(1, pieces) / pieces
        rows.append(Q[i] + s[:, None] * (Q[i + 1] - Q[i]))
        owner.append(np.full(len(s), i, dtype=np.intp))
    if not rows:
        return np.zeros((0, Q.shape[1])), np.zeros(0, dtype=np.intp)
    return np.concatenate(rows), np.concatenate(owner)
