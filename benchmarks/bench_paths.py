"""Task paths (issue 39): the ladder planner against EAIK's IK alone and against a greedy single-branch tracker.

    .venv/bin/python -m benchmarks.bench_paths            # the full sizes (a minute or two)
    .venv/bin/python -m benchmarks.bench_paths --quick    # tiny sizes, seconds

1. Speed and memory: a circle of 1000 waypoints (radius 0.15 m, tool pointing down) on the UR5 (base_link ->
   tool0) with the tool free about its z axis at 10 deg (36 turns: 36,000 poses, up to 288 candidates per rung,
   one value per branch, ``aliases=False``), planned at 0.1 m/s by :func:`manipkit.paths.plan.plan_path` without
   collisions and with them (the robot against itself and the floor it stands on, z = 0: every vertex and step
   of the chosen path checked, re-planned around contacts); against EAIK (``eaik``) solving the same 36,000 poses
   one call each (``IK``), in its own end frame (the pose times the fixed offset between its frame and tool0).
   The three are timed in turns, ``--repeats`` rounds (default 3), each time the median of its rounds. Ratios
   plan / EAIK (goal <= 3) and collision plan / plan (goal <= 3); peak memory of each plan by ``tracemalloc`` in
   an untimed run (numpy's arrays included; goal < 500 MB); the load averages at the end.
2. Completion: random UR5 lines (20 waypoints, 1 cm apart, random speed) that plan_path finds feasible; a greedy
   tracker in the way of MoveIt's ``computeCartesianPath`` (start at the generating configuration, at each
   waypoint take the IK solution nearest the previous one, stop at the first step that breaks a joint's velocity
   limit) on the same candidates: the share of paths each completes.

Ratios in one run matter, not absolute times (2 shared cores).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
import tracemalloc

import numpy as np

import manipkit
from manipkit.kinematics.collisions import CollisionChecker
from manipkit.paths.plan import plan_path, velocity_limits
from manipkit.paths.rungs import build_rungs, tool_rotations

__all__ = ["circle_poses", "completion_workload", "greedy_track", "main", "random_lines"]


def circle_poses(centre, radius: float, n: int) -> np.ndarray:
    """``n`` poses on a horizontal circle (m), the tool's z pointing down (rotation Rx(pi))."""
    angle = 2 * math.pi * np.arange(n) / n
    T = np.tile(np.diag([1.0, -1.0, -1.0, 1.0]), (n, 1, 1))
    T[:, 0, 3] = centre[0] + radius * np.cos(angle)
    T[:, 1, 3] = centre[1] + radius * np.sin(angle)
    T[:, 2, 3] = centre[2]
    return T


def greedy_track(chain, poses: np.ndarray, q_start: np.ndarray, speed: float) -> int:
    """Waypoints a greedy tracker completes: from ``q_start``, at each waypoint the candidate (every branch and
    in-limit alias) nearest the previous configuration; it stops where that step breaks a joint's velocity
    limit for the step's time (MoveIt's jump check, with the bound made explicit)."""
    rungs = build_rungs(chain, poses, tool_rotations(None, [0.0]), source="closed_form")
    bound = velocity_limits(chain)
    q = q_start
    for i, Q in enumerate(rungs.Q):
        if not len(Q):
            return i
        nearest = Q[np.argmin(np.linalg.norm(Q - q, axis=1))]
        dt = 0.0 if i == 0 else np.linalg.norm(poses[i, :3, 3] - poses[i - 1, :3, 3]) / speed
        if i and np.any(np.abs(nearest - q) > bound * dt):
            return i
        q = nearest
    return len(poses)


def _eaik(robot, chain):
    try:
        from eaik.IK_URDF import UrdfRobot
    except ImportError:
        return None, None
    bot = UrdfRobot(str(robot.source.path))
    q = chain.sample(1, seed=0)[0]
    X = np.linalg.inv(np.asarray(bot.fwdKin(q))) @ chain.fk(q)  # EAIK's end frame -> tool0 (fixed on the last link)
    return bot, X


def _timed(run) -> tuple[float, object]:
    start = time.perf_counter()
    answer = run()
    return time.perf_counter() - start, answer


def _peak_mb(run) -> float:
    """Peak traced memory (MB) of ``run()``, in an untimed run (tracing every allocation slows it down)."""
    tracemalloc.start()
    run()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 2**20


def speed_workload(waypoints: int, step_deg: float, repeats: int = 3) -> dict:
    """The plan, the plan with self-collision and a floor, and EAIK's IK of the same poses, timed in turns
    (``repeats`` rounds of the three); each time the median of its rounds."""
    robot = manipkit.load("ur5")
    chain = robot.chain("base_link", "tool0")
    poses = circle_poses((0.45, 0.1, 0.3), 0.15, waypoints)
    checker = CollisionChecker(robot, floor=0.0)  # the robot against itself and the floor it stands on (z = 0)
    options = dict(speed=0.1, free_axis="z", free_step=math.radians(step_deg), aliases=False)

    def plain():
        return plan_path(chain, poses, **options)

    def collision():
        return plan_path(chain, poses, collisions=checker, **options)

    plan_path(chain, poses[:3], collisions=checker, **options)  # warm: kernels compiled or loaded, checker built
    bot, X = _eaik(robot, chain)
    targets = None
    if bot is not None:
        count = int(math.floor(360.0 / step_deg + 1e-9))  # the tool angles of a full turn, as plan_path samples
        angles = math.radians(step_deg) * np.arange(count) - math.pi
        targets = (poses[:, None] @ tool_rotations("z", angles)[None]).reshape(-1, 4, 4) @ np.linalg.inv(X)

    def eaik_all():
        for T in targets:
            bot.IK(T)

    times: dict[str, list] = {"plan_s": [], "collision_plan_s": [], "eaik_s": []}
    for _ in range(repeats):
        elapsed, plan = _timed(plain)
        times["plan_s"].append(elapsed)
        elapsed, guarded = _timed(collision)
        times["collision_plan_s"].append(elapsed)
        if targets is not None:
            times["eaik_s"].append(_timed(eaik_all)[0])
    row = {"workload": "plan", "waypoints": waypoints, "tool_angles": plan.resolution["tool_angles"],
           "poses": waypoints * plan.resolution["tool_angles"], "candidates": plan.resolution["candidates"],
           "feasible": plan.feasible, "edges": plan.resolution["edges"], "repeats": repeats,
           "collision_feasible": guarded.feasible, "collision_checks": guarded.collision_checks,
           "collision_replans": guarded.replans, "same_cost": plan.cost == guarded.cost}
    for name, values in times.items():
        if values:
            row[name] = float(np.median(values))
            row[name.replace("_s", "_runs_s")] = values
    row["peak_mb"] = _peak_mb(plain)
    row["collision_peak_mb"] = _peak_mb(collision)
    row["collision_ratio"] = row["collision_plan_s"] / row["plan_s"]
    if "eaik_s" in row:
        row["ratio"] = row["plan_s"] / row["eaik_s"]
    row["load_average"] = list(os.getloadavg())
    return row


def random_lines(chain, paths: int, seed: int = 0):
    """Random UR5 lines (20 waypoints, 1 cm apart, from FK of a random in-limit configuration, in a random
    direction, at a random speed in [0.05, 0.3] m/s) that :func:`plan_path` finds feasible, drawn until ``paths``
    are found or ``20 * paths`` tried; yields ``(q0, poses, speed, tried)``."""
    rng = np.random.default_rng(seed)
    done = tried = 0
    while done < paths and tried < 20 * paths:
        tried += 1
        q0 = chain.sample(1, seed=int(rng.integers(2**31)))[0]
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        speed = float(rng.uniform(0.05, 0.3))
        poses = np.repeat(chain.fk(q0)[None], 20, axis=0)
        poses[:, :3, 3] += 0.01 * np.arange(20)[:, None] * direction
        if not plan_path(chain, poses, speed=speed).feasible:
            continue
        done += 1
        yield q0, poses, speed, tried


def completion_workload(paths: int, seed: int = 0) -> dict:
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    done = tried = greedy = 0
    for q0, poses, speed, count in random_lines(chain, paths, seed):
        done, tried = done + 1, count
        greedy += greedy_track(chain, poses, q0, speed) == len(poses)
    return {"workload": "completion", "paths": done, "tried": tried, "plan_completed": 1.0 if done else None,
            "greedy_completed": greedy / done if done else None}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="tiny sizes (seconds)")
    parser.add_argument("--repeats", type=int, default=3, help="rounds of the timed plans and EAIK, in turns")
    parser.add_argument("--out", default=None, help="write the rows as JSON here")
    args = parser.parse_args(argv)
    rows = [speed_workload(50 if args.quick else 1000, 10.0, max(1, args.repeats)),
            completion_workload(5 if args.quick else 200)]
    for row in rows:
        print(json.dumps(row))
    plan = rows[0]
    print(f"plan {plan['waypoints']} waypoints x {plan['tool_angles']} tool angles ({plan['poses']} poses, "
          f"{plan['candidates']} candidates): {plan['plan_s']:.2f} s, peak {plan['peak_mb']:.0f} MB"
          + (f"; EAIK IK one call per pose: {plan['eaik_s']:.2f} s; ratio {plan['ratio']:.2f} (goal <= 3)"
             if "ratio" in plan else "; EAIK not installed"))
    print(f"with self-collision and the floor: {plan['collision_plan_s']:.2f} s ({plan['collision_checks']} "
          f"configurations checked, {plan['collision_replans']} re-plans), peak {plan['collision_peak_mb']:.0f} MB; "
          f"ratio to the plan without {plan['collision_ratio']:.2f} (goal <= 3); medians of {plan['repeats']} "
          f"rounds in turns; load averages {' '.join(f'{x:.2f}' for x in plan['load_average'])}")
    done = rows[1]
    print(f"random feasible lines: {done['paths']} (of {done['tried']} tried); completed by the plan "
          f"{done['plan_completed']:.0%}, by the greedy nearest-branch tracker {done['greedy_completed']:.0%}")
    if args.out:
        with open(args.out, "w", encoding="utf-8") as stream:
            json.dump(rows, stream, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
