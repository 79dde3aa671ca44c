"""A 7R arm's ranked set across its self-motion (issue 36): ``manipkit.ik(arm, T, all=True)`` per pose against one
numerical solve of the same pose, timed in turns.

Rows as in :mod:`benchmarks.workloads` (:func:`benchmarks.workloads.row`), workload ``redundant``, per arm (Panda:
its last joint locked and swept, each value solved by the closed form of the 6R arm it leaves; iiwa14: the SRS arm
angle swept; the Sawyer of the shared Menagerie copy, a general 7R: its last joint locked and swept, each value
solved by the general 6R elimination, ``SAWYER``): the ranked set of 16 solutions (sweep at 2 pi / 128 rad, crossings bisected to 1e-7 rad, ranked by
the distance to the limits) on ``n_poses`` poses (FK of seeded random configurations inside the limits), against
``manipkit.ik(arm, T, method="numerical")`` (one solution, restarts until one converges) on the same poses. Every
ranked row is checked by Pinocchio's FK to 1e-10 and every numerical answer to ``IK_ACCEPT`` first; rows with a
wrong answer get no time. The ratio (ranked set / numerical solve, medians) is in the ranked row's note.
"""

from __future__ import annotations

import numpy as np

from benchmarks.workloads import IK_ACCEPT, in_turns, row

__all__ = ["redundant_workload"]

RANKED_ACCEPT = 1e-10  # every row of the ranked set lands by Pinocchio to this (m and rad)
#: (path, base, tip) of the general 7R arm timed when the shared workspace is here
SAWYER = ("/work/shared/realworld/menagerie/rethink_robotics_sawyer/sawyer.xml", "base", "right_l6")


def _pinocchio_errors(robot, chain, Q, T) -> float:
    """The largest position (m) or rotation (rad) error of whole-robot rows ``Q`` against ``T``, by Pinocchio."""
    import pinocchio as pin

    model, data = robot.model, robot.model.createData()
    base, tip = model.getFrameId(robot.frame(chain.base)), model.getFrameId(robot.frame(chain.tip))
    worst = 0.0
    for q in Q:
        pin.forwardKinematics(model, data, robot.pinocchio_configuration(q))
        pin.updateFramePlacements(model, data)
        reached = np.linalg.inv(data.oMf[base].homogeneous) @ data.oMf[tip].homogeneous
        R = reached[:3, :3].T @ T[:3, :3]
        sine = 0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        worst = max(worst, float(np.linalg.norm(reached[:3, 3] - T[:3, 3])),
                    float(np.arctan2(sine, (np.trace(R) - 1.0) / 2.0)))
    return worst


def redundant_workload(robot_name: str, *, n_poses: int = 50, rounds: int = 3, seed: int = 36, base: str = "base_link",
                       tip: str = "ee_link", label: str | None = None) -> list[dict]:
    """Rows for ``robot_name`` (a name or a path; ``label`` names it in the rows) between ``base`` and ``tip``."""
    import manipkit

    robot = manipkit.load(robot_name)
    chain = robot.chain(base, tip)
    frames = dict(base=base, tip=tip)
    robot_name = label or robot_name
    targets = chain.fk(chain.sample(n_poses, seed=seed))
    ranked = [manipkit.ik(robot, T, all=True, **frames) for T in targets]
    numerical = [manipkit.ik(robot, T, method="numerical", **frames) for T in targets]
    ranked_error = max((_pinocchio_errors(robot, chain, r.solutions, T) for r, T in zip(ranked, targets)), default=0.0)
    numerical_error = max(_pinocchio_errors(robot, chain, r.solutions[:1], T) for r, T in zip(numerical, targets))
    counts = [len(r.solutions) for r in ranked]
    ok = ranked_error <= RANKED_ACCEPT and all(r.success for r in numerical) and numerical_error <= IK_ACCEPT
    share = max(1, n_poses // max(rounds, 1))

    def timed(solve):
        import time

        def once(r):
            chosen = targets[(r * share) % n_poses:][:share]
            seconds = []
            for T in chosen:
                start = time.perf_counter()
                solve(T)
                seconds.append(time.perf_counter() - start)
            return np.array(seconds)
        return once

    timers = {"ranked": timed(lambda T: manipkit.ik(robot, T, all=True, **frames)),
              "numerical": timed(lambda T: manipkit.ik(robot, T, method="numerical", **frames))}
    times = in_turns(timers, rounds) if ok else {"ranked": None, "numerical": None}
    ratio = (f"; ranked set / one numerical solve = {np.median(times['ranked']) / np.median(times['numerical']):.3g} "
             "(medians, same poses, timed in turns)" if ok else "")
    check = (f"every ranked row lands by Pinocchio within {ranked_error:.1e} (<= {RANKED_ACCEPT:g}); "
             f"{min(counts)}-{max(counts)} solutions per pose")
    return [
        row("redundant", robot_name, "manipkit ik --all on a 7R: the ranked set (16 across the self-motion)",
            times["ranked"], unit="pose", n=n_poses, ours=True, status="ok" if ok else "wrong", check=check,
            note=f"target <= 1 ms per pose{ratio}"),
        row("redundant", robot_name, "manipkit numerical IK, one solution", times["numerical"], unit="pose",
            n=n_poses, status="ok" if ok else "wrong",
            check=f"every answer lands by Pinocchio within {numerical_error:.1e} (<= {IK_ACCEPT:g})"),
    ]
