"""Reachability maps (issue 17): certified reachable poses per core-second, batched IK, agreement with IK labels.

    python -m benchmarks.reachmap_workload            # iiwa14 at 0.1 m, 200 directions (a few minutes)
    python -m benchmarks.reachmap_workload --quick    # small sizes (seconds)

`make bench` (:mod:`benchmarks.run`, workload ``reachmap``) runs it as this
command in a child process, with its own sizes (``--sizes``): Dask's worker
processes start by importing the parent's main module, which must not run the
whole benchmark again (this module's is guarded; ``python -m benchmarks`` is not).

Rows as in :mod:`benchmarks.workloads` (:func:`benchmarks.workloads.row`):

- ``reachmap_fk``: ``reachmap.build(method="fk")`` in this process (one
  core). "Certified" voxel-bins are those a sampled configuration lands in;
  the rate is certified voxel-bins per core-second, beside reuleaux_moveit's
  reported 3.8 reachable poses per core-second (issue 17).
- ``reachmap_hybrid``: the same map with the IK pass at the boundary; the
  IK-certified voxel-bins are checked again here with Pinocchio FK.
- ``reachmap_dask``: the FK map on a LocalCluster of 1 and of 2 worker
  processes (wall time with and without the cluster's start), the maps
  checked identical to the in-process one.
- ``ik_many``: solves per second on iiwa14 (FK of random configurations,
  random first starts) on 2 threads and on 1, timed in turns in one run
  (with the load average, since the machine may be shared); success checked
  by Pinocchio at 1e-9, and the answers of the two must be identical.
- ``reachmap_agreement``: poses the map never saw, labelled by IK with
  restarts (``ik_many``, 20 restarts): FK poses of random configurations
  (all reachable) and random poses in the grid's box (uniform position, a
  uniform random rotation). Agreement = map and label agree; false positive =
  the map says reachable and IK finds no solution. Timed: ``ReachMap.query`` per pose.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

from benchmarks.workloads import IK_ACCEPT, row

FULL = dict(voxel=0.1, directions=200, samples=4_000_000, ik_targets=20_000, labelled=4000, dask_samples=2_000_000)
QUICK = dict(voxel=0.1, directions=50, samples=300_000, ik_targets=2000, labelled=600, dask_samples=300_000)


def _random_rotations(n: int, rng) -> np.ndarray:
    """Uniform random rotations (Shoemake's unit quaternions)."""
    u1, u2, u3 = rng.random((3, n))
    x, y = np.sqrt(1 - u1) * np.sin(2 * np.pi * u2), np.sqrt(1 - u1) * np.cos(2 * np.pi * u2)
    z, w = np.sqrt(u1) * np.sin(2 * np.pi * u3), np.sqrt(u1) * np.cos(2 * np.pi * u3)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
    ], 1)


def ik_many_rows(robot, robot_name: str, ik_targets: int, *, repeats: int = 3) -> list[dict]:
    """The ``ik_many`` rows: solves per second on 2 threads and on 1, in turns in one run, answers compared."""
    from manipkit.kinematics.ik_many import ik_many

    Q_true = robot.sample_q(ik_targets, seed=21)
    targets = robot.fk(Q_true, base="base_link", tip="ee_link")
    ik_many(robot, targets[:200], threads=2)  # warm-up: the kernel compiled or loaded, threads started once
    times, batches, loads = {1: [], 2: []}, {}, []
    for _ in range(repeats):
        for threads in (2, 1):
            start = time.perf_counter()
            batches[threads] = ik_many(robot, targets, threads=threads)
            times[threads].append((time.perf_counter() - start) / ik_targets)
        loads.append(os.getloadavg()[0])
    same = all(np.array_equal(getattr(batches[1], f), getattr(batches[2], f)) for f in ("q", "iterations", "attempts"))
    rows = []
    for threads in (2, 1):
        batch = batches[threads]
        worst = np.array([np.linalg.norm(robot.transform("base_link", "ee_link", q)[:3, 3] - t[:3, 3])
                          for q, t in zip(batch.q[:500], targets[:500])])
        fine = float(worst[batch.success[:500]].max(initial=0.0)) <= IK_ACCEPT and same
        rate = 1.0 / float(np.median(times[threads]))
        rows.append(row("ik_many", robot_name, f"manipkit ik_many, {threads} thread{'s' if threads > 1 else ''}",
                        times[threads], unit="solve", n=ik_targets, ours=True, success=float(batch.success.mean()),
                        solves_per_second=rate, threads=threads, cores=os.cpu_count(),
                        speedup_vs_1_thread=float(np.median(times[1]) / np.median(times[threads])),
                        identical_on_1_and_2_threads=same, load_average=float(np.median(loads)),
                        pinocchio_max_position_residual_500=float(worst.max()), status="ok" if fine else "wrong",
                        check=f"success by FK residuals <= {IK_ACCEPT:g}; 500 answers re-measured by Pinocchio; "
                              f"answers on 1 and 2 threads identical: {same}",
                        note=f"random first starts, up to 20 restarts, tol 1e-10; median of {repeats}, 1 and 2 "
                             f"threads in turns; load average {np.median(loads):.2f} on {os.cpu_count()} cores"))
    return rows


def reachmap_workload(robot_name: str = "iiwa14", *, voxel: float, directions: int, samples: int, ik_targets: int,
                      labelled: int, dask_samples: int) -> list[dict]:
    """Every row of the module docstring, for ``robot_name``."""
    # Over 80 lines: one workload, its steps in order; each check sits beside the number it guards.
    import manipkit
    from manipkit.analysis import reachmap
    from manipkit.kinematics.ik_many import ik_many

    robot = manipkit.load(robot_name)
    rows = []
    settings = dict(voxel=voxel, orientations=directions, manipulability=False)  # the map alone (overlay: its own cost)
    reachmap.build(robot, **settings, samples=1000)  # warm-up: numba kernels loaded

    start = time.perf_counter()
    fk_map = reachmap.build(robot, **settings, samples=samples)
    seconds = time.perf_counter() - start
    certified = int((fk_map.reach == reachmap.HOW_SAMPLE).sum())
    rows.append(row("reachmap_fk", robot_name, "manipkit reachmap.build(method='fk'), 1 core", [seconds], unit="map",
                    n=1, ours=True, certified=certified, per_core_second=certified / seconds,
                    samples=samples, voxels=int(fk_map.reachable.sum()),
                    check="certified = a sampled configuration lands in the voxel-bin (FK kernel = Pinocchio to 1e-12)",
                    note=f"{voxel} m voxels, {directions} approach directions; reuleaux_moveit reports 3.8 per core-second"))

    start = time.perf_counter()
    hybrid = reachmap.build(robot, **settings, samples=samples, method="hybrid")
    seconds_h = time.perf_counter() - start
    by_ik = int((hybrid.reach == reachmap.HOW_IK).sum())
    T = robot.fk(hybrid.ik_q, base=hybrid.base, tip=hybrid.frame)
    query_ok = bool(hybrid.query(T).all()) if len(T) else True
    rows.append(row("reachmap_hybrid", robot_name, "manipkit reachmap.build(method='hybrid'), 1 core", [seconds_h],
                    unit="map", n=1, ours=True, certified=certified + by_ik, by_ik=by_ik,
                    per_core_second=(certified + by_ik) / seconds_h, ik_answers_in_their_bins=query_ok,
                    status="ok" if query_ok else "wrong",
                    check="IK cells: FK of the stored answer falls in its voxel-bin",
                    note="IK on unmarked voxel-bins next to marked ones, seeded from the neighbour's sample"))

    rows += ik_many_rows(robot, robot_name, ik_targets)

    rng = np.random.default_rng(5)
    fk_poses = robot.fk(robot.sample_q(labelled, seed=99), base="base_link", tip="ee_link")
    box_low = fk_map.origin
    box_high = fk_map.origin + (np.array(fk_map.shape) - 1) * fk_map.voxel
    random_poses = np.tile(np.eye(4), (labelled, 1, 1))
    random_poses[:, :3, :3] = _random_rotations(labelled, rng)
    random_poses[:, :3, 3] = box_low + rng.random((labelled, 3)) * (box_high - box_low)
    poses = np.concatenate([fk_poses, random_poses])
    labels = ik_many(robot, poses, restarts=20, tol=1e-9).success.copy()  # results are read-only
    labels[:labelled] = True  # FK poses are reachable by construction (IK confirms nearly all)
    for name, reach_map in (("fk", fk_map), ("hybrid", hybrid)):
        start = time.perf_counter()
        says = reach_map.query(poses)
        seconds_query = time.perf_counter() - start
        rows.append(row("reachmap_agreement", robot_name, f"map ({name}) vs IK labels: ReachMap.query",
                        [seconds_query / len(poses)], unit="pose", n=len(poses),
                        ours=True, agreement=float((says == labels).mean()),
                        false_positive=float((says & ~labels).mean()), false_negative=float((~says & labels).mean()),
                        fk_poses_in_map=float(says[:labelled].mean()),
                        random_poses_reachable=float(labels[labelled:].mean()),
                        check="labels by ik_many (20 restarts), FK-confirmed",
                        note=f"{labelled} FK poses of random configurations + {labelled} random poses in the grid box"))

    one = reachmap.build(robot, **settings, samples=dask_samples)
    for workers in (1, 2):
        start = time.perf_counter()
        distributed_map = reachmap.build(robot, **settings, samples=dask_samples, workers=workers)
        wall = time.perf_counter() - start
        identical = bool(np.array_equal(distributed_map.reach, one.reach))
        rows.append(row("reachmap_dask", robot_name, f"LocalCluster, {workers} worker process(es)", [wall], unit="map",
                        n=1, ours=True, identical_to_in_process=identical, status="ok" if identical else "wrong",
                        samples=dask_samples, check="map identical to the in-process build",
                        note="wall time including the cluster's start (a few seconds)"))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--robot", default="iiwa14")
    parser.add_argument("--sizes", default=None, help="the sizes as a JSON object (keys of FULL), instead of FULL or QUICK")
    parser.add_argument("--out", default=None, help="write the rows as JSON here")
    args = parser.parse_args(argv)
    sizes = dict(QUICK if args.quick else FULL)
    if args.sizes:
        extra = json.loads(args.sizes)
        unknown = set(extra) - set(FULL)
        if unknown:
            parser.error(f"unknown size(s) {', '.join(sorted(unknown))}; choose from {', '.join(FULL)}")
        sizes.update(extra)
    rows = reachmap_workload(args.robot, **sizes)
    for r in rows:
        shown = {k: v for k, v in r.items() if k not in ("ours", "p95_s", "status") and v not in (None, "")}
        print(json.dumps(shown))
    if args.out:
        with open(args.out, "w", encoding="utf-8") as f:
            json.dump({"cores": os.cpu_count(), "rows": rows}, f, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
