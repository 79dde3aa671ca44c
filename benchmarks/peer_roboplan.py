"""roboplan's Cartesian planner on the paths in a file, run in roboplan's own venv (not manipkit's).

    PEER_PYTHON benchmarks/peer_roboplan.py IN.npz OUT.npz

IN holds ``urdf`` (path), ``package_paths`` (where ``package://`` meshes resolve), ``base``, ``tip`` (frame names), ``joint_names``, and per path ``poses_K`` (N, 4, 4),
``q0_K`` (n,) and ``speed_K`` (m/s); ``paths`` is their count. OUT holds per path ``q_K`` (M, n): every sample of
the joint trajectory the planner returned (joint_names order; empty when it raised), ``seconds_K`` (the wall time
of its ``plan`` call) and ``error_K`` (the exception text, or ""). Nothing is checked here: the caller checks the
output with manipkit's FK. Standard library, numpy and roboplan only (manipkit is not importable here).
"""

from __future__ import annotations

import sys
import time

import numpy as np

__all__ = ["main"]


def main(argv=None) -> int:
    source, target = (argv or sys.argv[1:])[:2]
    from roboplan.cartesian_planning import CartesianPathPlanner, CartesianPlannerOptions
    from roboplan.core import CartesianPath, JointConfiguration, Scene, loadUrdfSceneDescription

    data = np.load(source)
    base, tip = str(data["base"]), str(data["tip"])
    names = [str(name) for name in data["joint_names"]]
    scene = Scene("ur5", loadUrdfSceneDescription(str(data["urdf"]), [str(p) for p in data["package_paths"]]))
    scene.addGroupFromChain("arm", base, tip)
    out = {}
    for k in range(int(data["paths"])):
        poses = data[f"poses_{k}"]
        options = CartesianPlannerOptions(group_name="arm", max_linear_speed=float(data[f"speed_{k}"]))
        planner = CartesianPathPlanner(scene, options)
        path = CartesianPath([base], [tip], [[np.asfortranarray(T) for T in poses]])
        start = time.perf_counter()
        try:
            trajectory = planner.plan(path, JointConfiguration(names, np.asarray(data[f"q0_{k}"], float)))
            error = ""
        except Exception as exc:  # noqa: BLE001 - the peer's failure is the measured answer
            trajectory, error = None, f"{type(exc).__name__}: {exc}"
        out[f"seconds_{k}"] = time.perf_counter() - start
        out[f"error_{k}"] = error
        if trajectory is None:
            out[f"q_{k}"] = np.zeros((0, len(names)))
        else:
            order = [list(trajectory.joint_names).index(name) for name in names]
            out[f"q_{k}"] = np.asarray(trajectory.positions, float)[:, order]
    np.savez(target, **out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
