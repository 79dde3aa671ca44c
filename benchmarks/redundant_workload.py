"""A 7R arm's ranked set across its self-motion (issue 36): ``manipkit.ik(arm, T, all=True)`` per pose against one
numerical solve of the same pose, timed in turns.

Rows as in :mod:`benchmarks.workloads` (:func:`benchmarks.workloads.row`), workload ``redundant``, per arm (Panda:
its last joint locked and swept, each value solved by the closed form of the 6R arm it leaves; iiwa14: the SRS arm
angle swept; the Sawyer of the shared Menagerie copy, a general 7R: its last joint locked and swept, each value
solved by the general 6R elimination, ``SAWYER``): the ranked set of 16 solutions (sweep at 2 pi / 128 rad, crossings bisected to 1e-7 rad, ranked by
the distance to the limits) on ``n_poses`` poses (FK of seeded random configurations inside the limits), against
``manipkit.ik(arm, T, method="numerical")`` (one solution, restarts until one converges) on the same poses, and
ssik's ``Manipulator.solve`` (PyPI ``ssik``, in the bench extra; its defaults: its full sampling of the self-motion,
in-limit rows) on the same arm built from manipkit's URDF text and frames. Every ranked row is checked by
Pinocchio's FK to 1e-10, every numerical answer to ``IK_ACCEPT`` and every ssik row by the chain's FK to
``IK_ACCEPT`` first; rows with a wrong answer get no time. All three are timed in turns. The ratios (ranked set /
numerical solve, ssik / ranked set, medians) are in the ranked row's note.
"""

from __future__ import annotations

import tempfile
import warnings

import numpy as np

from benchmarks import peers as peer_adapters
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


def _ssik_arm(robot, chain, targets):
    """(ssik's Manipulator of the chain, its rows per target, its largest FK error by the chain's FK) or (None, the
    reason, None) when ssik is not installed or cannot load or solve the arm."""
    try:
        import ssik
    except ImportError:
        return None, "ssik is not installed (pip install 'ssik[urdf]')", None
    try:
        with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as handle:
            handle.write(robot.urdf)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # its one-time note on arms solved from a URDF
            arm = ssik.Manipulator.from_urdf(handle.name, base=robot.frame(chain.base), ee=robot.frame(chain.tip))
            answers = [np.array([s.q for s in arm.solve(T)], dtype=float).reshape(-1, chain.n) for T in targets]
    except Exception as exc:  # a peer that cannot read the arm is reported, not timed
        return None, f"ssik could not solve this arm: {type(exc).__name__}: {str(exc)[:120]}", None
    worst = max((float(np.abs(chain.fk(Q) - T).max()) for Q, T in zip(answers, targets) if len(Q)), default=0.0)
    return arm, answers, worst


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
    arm, answers, ssik_error = _ssik_arm(robot, chain, targets)
    ssik_ok = arm is not None and ssik_error <= IK_ACCEPT
    if ok and ssik_ok:
        timers["ssik"] = timed(arm.solve)
    times = in_turns(timers, rounds) if ok else {"ranked": None, "numerical": None}
    ratio = (f"; ranked set / one numerical solve = {np.median(times['ranked']) / np.median(times['numerical']):.3g} "
             "(medians, same poses, timed in turns)" if ok else "")
    if "ssik" in times:
        ratio += f"; ssik / ranked set = {np.median(times['ssik']) / np.median(times['ranked']):.3g}"
    check = (f"every ranked row lands by Pinocchio within {ranked_error:.1e} (<= {RANKED_ACCEPT:g}); "
             f"{min(counts)}-{max(counts)} solutions per pose")
    return [
        row("redundant", robot_name, "manipkit ik --all on a 7R: the ranked set (16 across the self-motion)",
            times["ranked"], unit="pose", n=n_poses, ours=True, status="ok" if ok else "wrong", check=check,
            note=f"target <= 1 ms per pose{ratio}"),
        row("redundant", robot_name, "manipkit numerical IK, one solution", times["numerical"], unit="pose",
            n=n_poses, status="ok" if ok else "wrong",
            check=f"every answer lands by Pinocchio within {numerical_error:.1e} (<= {IK_ACCEPT:g})"),
        _ssik_row(robot_name, arm, answers, ssik_error, times.get("ssik"), n_poses),
    ]


def _ssik_row(robot_name: str, arm, answers, worst, times, n_poses: int) -> dict:
    """The row of ssik's solve (``answers``: its rows per pose, or the reason it has none)."""
    label = "ssik Manipulator.solve, every solution (its sampling of the self-motion)"
    if arm is None:
        return row("redundant", robot_name, label, None, unit="pose", status="missing", note=answers)
    version = peer_adapters.version("ssik") or "?"
    counts = [len(Q) for Q in answers]
    return row("redundant", robot_name, f"{label} (ssik {version}, {arm.solver_name})", times, unit="pose", n=n_poses,
               status="ok" if worst <= IK_ACCEPT else "wrong",
               check=f"every row lands by the chain's FK within {worst:.1e} (<= {IK_ACCEPT:g}); "
                     f"{min(counts)}-{max(counts)} solutions per pose", note="its defaults, in-limit rows")
