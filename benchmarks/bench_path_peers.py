"""Task paths (issue 39): other libraries' Cartesian planners beside plan_path on the same UR5 lines.

    make peers                                              # the peers' own venvs (never manipkit's)
    .venv/bin/python -m benchmarks.bench_path_peers [--quick] [--paths 200]

Each peer runs in its own venv (``PEERS`` below: the venv's python and the runner script) as a subprocess, fed the
same poses through a file, since a peer may bring its own Pinocchio/coal/eigenpy. The lines are
:func:`benchmarks.bench_paths.random_lines` (20 waypoints, 1 cm apart, random speed; those plan_path finds
feasible), from the generating configuration; then the bench's circle of 1000 waypoints (radius 0.15 m, tool down,
0.1 m/s) with the tool fixed (8 candidates a rung: the 36 tool angles of bench_paths would give Descartes, which
stores its edges, 288^2 x 999 = 83 M of them), roboplan started from plan_path's first configuration. manipkit checks every peer's output itself: a path is completed
when every waypoint is reached by some configuration of the peer's joint trajectory whose pose (the chain's FK,
Pinocchio's model) lands within 1e-6 m and 1e-6 rad of it, in order. Its cost is the summed joint motion
(sum over samples and joints of |dq|, rad) from the first waypoint's configuration to the last's; ours is
plan_path's ``cost`` on the same waypoints. Time per path: plan_path's wall time in this process, the peer's as
its runner measured its ``plan`` call (import and model loading left out on both sides).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import manipkit
from manipkit.paths.plan import plan_path, velocity_limits
from manipkit.spatial.transforms import pose_residuals

from .bench_paths import circle_poses, random_lines

__all__ = ["PEERS", "check_peer_path", "main", "run_peer", "velocity_ratio"]

HERE = Path(__file__).resolve().parent
VENVS = HERE.parent / ".peers"  # made by `make peers`; ROBOPLAN_VENV / TESSERACT_VENV name others
PEERS = {"roboplan": (Path(os.environ.get("ROBOPLAN_VENV", VENVS / "roboplan")) / "bin" / "python",
                      HERE / "peer_roboplan.py"),
         "tesseract descartes": (Path(os.environ.get("TESSERACT_VENV", VENVS / "tesseract")) / "bin" / "python",
                                 HERE / "peer_tesseract.py")}
TOL = (1e-6, 1e-6)  # m, rad: a waypoint is reached when a configuration's FK lands this close
OWN_TOL = {"roboplan": (5e-3, 1e-2)}  # a peer's own default path tolerance (m, rad), reported beside ours


def check_peer_path(chain, poses: np.ndarray, Q: np.ndarray, tol=TOL) -> dict:
    """Check a peer's joint trajectory ``Q`` (M, n) against ``poses`` (N, 4, 4) by the chain's FK.

    Waypoint i is reached at the first sample from waypoint i-1's on whose pose is within ``tol`` (m, rad);
    ``reached`` counts the waypoints reached in order, ``worst`` is the smallest position error (m) among the
    samples within the rotation tolerance (inf if none) at the first waypoint not reached, ``cost`` the summed |dq| (rad) from the first waypoint's sample to the
    last's (None unless all are reached)."""
    if not len(Q):
        return {"reached": 0, "completed": False, "cost": None, "worst": None}
    T = chain.fk(np.asarray(Q, float))
    start, marks = 0, []
    for pose in poses:
        position, rotation = pose_residuals(pose, T[start:])
        inside = rotation <= tol[1]
        hits = np.flatnonzero(inside & (position <= tol[0]))
        if not len(hits):
            worst = float(position[inside].min()) if inside.any() else math.inf
            return {"reached": len(marks), "completed": False, "cost": None, "worst": worst}
        start += int(hits[0])
        marks.append(start)
    cost = float(np.abs(np.diff(Q[marks[0]:marks[-1] + 1], axis=0)).sum())
    return {"reached": len(marks), "completed": True, "cost": cost, "worst": 0.0, "marks": marks}


def velocity_ratio(chain, poses: np.ndarray, Q: np.ndarray, marks, speed: float) -> float:
    """Largest ``|dq_j| / (v_j dt)`` between consecutive waypoints' samples of ``Q`` (``dt``: the step's length
    over ``speed``, ``v_j`` the URDF velocity limits): plan_path's edge rule, which a peer's path may break."""
    dq = np.abs(np.diff(np.asarray(Q)[marks], axis=0))
    dt = np.linalg.norm(np.diff(poses[:, :3, 3], axis=0), axis=1) / speed
    return float((dq / (velocity_limits(chain) * dt[:, None])).max())


def run_peer(name: str, lines, chain, urdf: str, python: Path | None = None, script: Path | None = None):
    """Run peer ``name``'s runner on ``lines`` (q0, poses, speed) in its own python; returns per path
    ``(Q, seconds, error)``, or None with the reason when the peer's python is missing."""
    python, script = python or PEERS[name][0], script or PEERS[name][1]
    if not Path(python).exists():
        return None, f"{python} missing (make peers)"
    with tempfile.TemporaryDirectory() as folder:
        source, target = Path(folder, "in.npz"), Path(folder, "out.npz")
        share = [str(folder) for folder in Path(urdf).parents if folder.name == "share"]  # package:// meshes
        arrays = {"urdf": urdf, "package_paths": np.array(share[:1]), "base": chain.base, "tip": chain.tip, "joint_names": np.array(chain.joint_names),
                  "paths": len(lines)}
        for k, (q0, poses, speed) in enumerate(lines):
            arrays.update({f"q0_{k}": q0, f"poses_{k}": poses, f"speed_{k}": speed})
        np.savez(source, **arrays)
        done = subprocess.run([str(python), str(script), str(source), str(target)], capture_output=True, text=True,
                              check=False)
        if done.returncode:
            lines_of = [line for line in done.stderr.splitlines() if "error" in line.lower() or "exception" in line.lower()]
            return None, (lines_of or done.stderr.strip().splitlines() or [f"exit status {done.returncode}"])[-1].strip()
        out = np.load(target)
        return [(out[f"q_{k}"], float(out[f"seconds_{k}"]), str(out[f"error_{k}"])) for k in range(len(lines))], ""


def compare(lines, workload: str, rounds: int = 3) -> list[dict]:
    """plan_path and every peer on the same ``lines`` ((q0, poses, speed) on the UR5, base_link -> tool0), timed
    in turns: ``rounds`` rounds, each timing plan_path on every line then each peer's process on every line; a
    path's time is the median of its rounds."""
    robot = manipkit.load("ur5")
    chain = robot.chain("base_link", "tool0")
    ours_s, peer_s, answers_of = [], {name: [] for name in PEERS}, {}
    for _ in range(rounds):
        times, costs = [], []
        for _, poses, speed in lines:
            start = time.perf_counter()
            plan = plan_path(chain, poses, speed=speed)
            times.append(time.perf_counter() - start)
            costs.append(plan.cost)
        ours_s.append(times)
        for name in PEERS:
            answers_of[name] = run_peer(name, lines, chain, str(robot.source.path))
            if answers_of[name][0] is not None:
                peer_s[name].append([s for _, s, _ in answers_of[name][0]])
    ours = list(zip(np.median(ours_s, axis=0), costs))
    rows = [{"workload": workload, "planner": "manipkit plan_path", "paths": len(lines), "completed": 1.0, "rounds": rounds,
             "median_s": float(np.median([s for s, _ in ours])), "cost": float(sum(c for _, c in ours))}]
    for name in PEERS:
        answers, why = answers_of[name]
        if answers is None:
            rows.append({"workload": workload, "planner": name, "paths": len(lines), "error": why})
            continue
        checks = [check_peer_path(chain, poses, Q) for (_, poses, _), (Q, _, _) in zip(lines, answers)]
        both = [(c["cost"], cost) for c, (_, cost) in zip(checks, ours) if c["completed"]]
        below = [peer - mine for peer, mine in both if peer < mine - 1e-9]
        fast = [velocity_ratio(chain, poses, Q, c["marks"], speed) > 1 + 1e-9
                for c, (_, poses, speed), (Q, _, _) in zip(checks, lines, answers) if c["completed"]]
        below_fast = sum(f for f, (peer, mine) in zip(fast, both) if peer < mine - 1e-9)
        worst = [c["worst"] for c in checks if not c["completed"] and c["worst"] is not None]
        own = OWN_TOL.get(name, TOL)
        loose = [check_peer_path(chain, poses, Q, own) for (_, poses, _), (Q, _, _) in zip(lines, answers)]
        both_own = [(c["cost"], cost) for c, (_, cost) in zip(loose, ours) if c["completed"]]
        errors = sorted({e for _, _, e in answers if e})
        rows.append({"workload": workload, "planner": name, "paths": len(lines),
                     "completed": sum(c["completed"] for c in checks) / len(lines),
                     "raised": sum(bool(e) for _, _, e in answers) / len(lines),
                     "own_tol": own, "completed_own_tol": sum(c["completed"] for c in loose) / len(lines),
                     "cost_own_tol": float(sum(p for p, _ in both_own)),
                     "ours_on_those_own_tol": float(sum(m for _, m in both_own)),
                     "waypoints_reached": sum(c["reached"] for c in checks) / (len(lines) * len(lines[0][1])),
                     "median_s": float(np.median(np.median(peer_s[name], axis=0))),
                     "cost_completed": float(sum(p for p, _ in both)), "ours_on_those": float(sum(m for _, m in both)),
                     "below_ours": len(below), "below_ours_over_velocity": below_fast,
                     "over_velocity": sum(fast), "median_miss": float(np.median(worst)) if worst else None,
                     "errors": errors[:3]})
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="5 paths (seconds)")
    parser.add_argument("--paths", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=3, help="rounds of plan_path and the peers, in turns")
    parser.add_argument("--out", default=None, help="write the rows as JSON here")
    args = parser.parse_args(argv)
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    rounds = max(1, args.rounds)
    lines = [(q0, poses, speed) for q0, poses, speed, _ in random_lines(chain, 5 if args.quick else args.paths)]
    circle = circle_poses((0.45, 0.1, 0.3), 0.15, 50 if args.quick else 1000)
    start = plan_path(chain, circle, speed=0.1).q[0]  # roboplan needs a start: our plan's, at waypoint 0
    rows = compare(lines, "random lines", rounds) + compare([(start, circle, 0.1)], "circle, fixed tool", rounds)
    for row in rows:
        print(json.dumps(row))
    if args.out:
        with open(args.out, "w", encoding="utf-8") as stream:
            json.dump(rows, stream, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
