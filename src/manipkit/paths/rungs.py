"""The rungs of a path's ladder: every IK branch at every waypoint, from the one IK dispatcher.

At each waypoint ``T_base_tip`` (and, with a free tool axis, at each sampled
rotation of the tool about it; for a 7R SRS arm, at each sampled arm angle),
every solution :mod:`manipkit.ik.dispatch` gives (the closed form's branches
where the chain has one, else numerical IK with ``all=True``), checked by
forward kinematics to ``tol``, then each solution's in-limit ``2 pi``
aliases (a joint whose range spans more than a full turn has more than one
value for the same pose). Candidates are joint vectors in the chain's order
(rad or m); each remembers its target (waypoint, sample) and IK slot, and the
reasons candidates were dropped are counted per waypoint (unreachable: no
branch reaches the target; joint_limits: a branch has no value inside some
joint's limits).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from manipkit.errors import ManipkitError

__all__ = ["Rungs", "alias_group", "build_rungs", "ik_source", "tool_rotations"]

AXES = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True)
class Rungs:
    """The candidates of every waypoint, flat, with where each came from.

    Attributes
    ----------
    Q : tuple of ndarray, each (k_i, n)
        Per waypoint, the candidate joint vectors (chain order).
    sample : tuple of ndarray of int, each (k_i,)
        The target sample (tool angle x arm angle index) of each candidate.
    slot : tuple of ndarray of int, each (k_i,)
        The IK slot (closed-form branch, or numerical solution index) of each candidate.
    unreachable : ndarray of int, shape (N,)
        Per waypoint, how many target samples no IK branch reaches.
    limits : ndarray of int, shape (N,)
        Per waypoint, how many IK branches have a joint with no value inside its limits.
    limit_joint : tuple of str
        Per waypoint, the joint most often outside its limits among those branches (``""``: none).
    samples : int
        Target samples per waypoint.
    method : str
        What produced the branches, in words.
    ik_calls : int
        How many targets were handed to the IK dispatcher.
    reachable : ndarray of bool, shape (N, samples), or None
        Per waypoint and target sample, whether some IK branch reaches it (the feasibility map's data).
    """

    Q: tuple[np.ndarray, ...]
    sample: tuple[np.ndarray, ...]
    slot: tuple[np.ndarray, ...]
    unreachable: np.ndarray
    limits: np.ndarray
    limit_joint: tuple[str, ...]
    samples: int
    method: str
    ik_calls: int
    reachable: np.ndarray | None = None


def tool_rotations(axis: str | None, angles) -> np.ndarray:
    """(A, 4, 4): turns of the tip about its own ``axis`` ("x", "y", "z") by ``angles`` (rad); None: the identity."""
    angles = np.atleast_1d(np.asarray(angles, dtype=float))
    out = np.tile(np.eye(4), (len(angles), 1, 1))
    if axis is None:
        return out[:1]
    i = AXES[axis]
    j, k = (i + 1) % 3, (i + 2) % 3
    c, s = np.cos(angles), np.sin(angles)
    out[:, j, j], out[:, j, k], out[:, k, j], out[:, k, k] = c, -s, s, c
    return out


def ik_source(robot, base: str, tip: str) -> str:
    """Which solver answers every branch: ``"closed_form"`` (a 6R family), ``"srs"`` (a 7R SRS arm, solved at
    sampled arm angles) or ``"numerical"``."""
    from manipkit.ik.textbook import closed_form_solves

    if closed_form_solves(robot, base, tip) not in ("", "named"):
        return "closed_form"
    try:
        if closed_form_solves(robot, base, tip, arm_angle=0.0):
            return "srs"
    except ManipkitError:
        pass
    return "numerical"


def _aliases(Q: np.ndarray, lower: np.ndarray, upper: np.ndarray, angular: np.ndarray, every: bool):
    """(rows, origin, outside): every in-limit alias ``q + 2 pi k`` of each row of ``Q`` (m, n) (``every=False``:
    the row itself if inside the limits), the row each came from, and per row the first joint with no value inside
    its limits (-1: none)."""
    m, n = Q.shape
    choices = []
    outside = np.full(m, -1, dtype=np.intp)
    for j in range(n):
        if every and angular[j]:
            turns = np.array([0, -1, 1, -2, 2, -3, 3])  # the value itself first: ties go to it
            values = Q[:, j, None] + 2.0 * math.pi * turns[None, :]
        else:
            values = Q[:, j, None]
        inside = (values >= lower[j]) & (values <= upper[j])
        choices.append((values, inside))
        none = ~inside.any(axis=1) & (outside < 0)
        outside[none] = j
    if not every:
        kept = np.flatnonzero(outside < 0)
        return Q[kept], kept, outside
    rows, origin = [], []
    for r in np.flatnonzero(outside < 0):
        per_joint = [values[r][inside[r]] for values, inside in choices]
        combos = np.array(list(itertools.product(*per_joint)), dtype=float).reshape(-1, n)
        rows.append(combos)
        origin.append(np.full(len(combos), r, dtype=np.intp))
    if not rows:
        return np.zeros((0, n)), np.zeros(0, dtype=np.intp), outside
    return np.concatenate(rows), np.concatenate(origin), outside


def _solve(chain, targets: np.ndarray, source: str, arm_angles, tol, restarts: int, seed: int):
    """(solutions (M, S, k, n) with NaN where absent, valid (M, S, k)) for targets (M, S, 4, 4)."""
    from manipkit.ik.dispatch import ik, ik_many

    M, S = targets.shape[:2]
    n = chain.n
    flat = targets.reshape(-1, 4, 4)
    if source == "numerical":
        rows = []
        for T in flat:
            result = ik(chain, T, all=True, method="numerical", restarts=restarts, seed=seed, tol=tol)
            rows.append(result.solutions[:, chain.columns] if result.solutions.shape[1] != n else result.solutions)
        k = max([len(r) for r in rows] + [1])
        Q = np.full((len(flat), k, n), np.nan)
        for i, r in enumerate(rows):
            Q[i, :len(r)] = r
        return Q.reshape(M, S, k, n), np.isfinite(Q).all(axis=-1).reshape(M, S, k)
    position, rotation = (tol, tol) if np.ndim(tol) == 0 else tol
    batches = []
    for psi in (arm_angles if source == "srs" else [None]):
        batch = ik_many(chain, flat, tol=tol, **({} if psi is None else {"arm_angle": float(psi)}))
        ok = (np.isfinite(batch.solutions).all(axis=-1) & (batch.residual_position <= position)
              & (batch.residual_rotation <= rotation))
        batches.append((np.asarray(batch.solutions), ok))
    Q = np.stack([b[0] for b in batches], axis=1)  # (M*S, P, 8, n)
    ok = np.stack([b[1] for b in batches], axis=1)
    P = Q.shape[1]
    return Q.reshape(M, S * P, -1, n), ok.reshape(M, S * P, -1)


def build_rungs(chain, poses: np.ndarray, turns: np.ndarray, *, source: str, arm_angles=None, tol=1e-9,
                aliases: bool = True, restarts: int = 20, seed: int = 0, block: int = 2000,
                progress=None) -> Rungs:
    """The ladder's rungs of ``poses`` (N, 4, 4) ``T_base_tip``, each tried turned by every rotation ``R``
    (A, 4, 4) about the tip's own free axis (the target ``T_base_tip @ R``) and, for ``source == "srs"``, every arm angle in ``arm_angles`` (rad).

    ``progress("IK", done, N)`` as blocks of waypoints are solved.
    """
    # Over 80 lines: solving, validity, aliasing and the per-waypoint failure counts are one pass over blocks.
    N = len(poses)
    A = len(turns)
    P = len(arm_angles) if source == "srs" else 1
    lower = np.asarray(chain.lower, dtype=float)
    upper = np.asarray(chain.upper, dtype=float)
    angular = np.array([j.is_angular for j in chain.joints], dtype=bool)
    Qs, samples, slots = [], [], []
    unreachable = np.zeros(N, dtype=np.intp)
    limits = np.zeros(N, dtype=np.intp)
    limit_joint = []
    reachable = np.zeros((N, A * P), dtype=bool)
    step = max(1, block // max(1, A * P)) if source != "numerical" else 1
    for start in range(0, N, step):
        stop = min(N, start + step)
        targets = poses[start:stop, None] @ turns[None]  # (m, A, 4, 4): each pose turned about the free axis
        Q, ok = _solve(chain, targets, source, arm_angles, tol, restarts, seed)
        m, S, k, n = Q.shape
        for w in range(m):
            i = start + w
            reachable[i] = ok[w].any(axis=1)
            unreachable[i] = int((~reachable[i]).sum())
            flat = Q[w].reshape(S * k, n)
            keep = ok[w].reshape(S * k)
            idx = np.flatnonzero(keep)
            rows, origin, outside = _aliases(flat[idx], lower, upper, angular, aliases)
            bad = outside[outside >= 0]
            limits[i] = len(bad)
            limit_joint.append(chain.joint_names[int(np.bincount(bad).argmax())] if len(bad) else "")
            src = idx[origin]
            Qs.append(rows)
            samples.append((src // k).astype(np.intp))
            slots.append((src % k).astype(np.intp))
        if progress is not None:
            progress("IK", stop, N)
    what = {"closed_form": "every closed-form branch", "srs": f"every closed-form branch at {P} arm angles",
            "numerical": f"every distinct solution numerical IK found from {restarts} restarts"}[source]
    return Rungs(tuple(Qs), tuple(samples), tuple(slots), unreachable, limits, tuple(limit_joint), A * P, what,
                 N * A * P if source != "numerical" else N * A, reachable)


def alias_group(rungs: Rungs, i: int, a: int) -> np.ndarray:
    """The candidates of waypoint ``i`` that are ``2 pi`` aliases of candidate ``a`` (the same target sample and IK
    slot: the same pose and the same link placements, so the same collisions), ``a`` included."""
    return np.flatnonzero((rungs.sample[i] == rungs.sample[i][a]) & (rungs.slot[i] == rungs.slot[i][a]))
