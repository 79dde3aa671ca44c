"""Reachability maps (issues 17 and 24): the issue's iiwa14 map, its agreement with IK labels, Dask, batched IK.

    python -m benchmarks.reachmap_workload            # the issue's sizes: iiwa14 at 5 cm, 200 directions (~10 min)
    python -m benchmarks.reachmap_workload --quick    # small sizes (seconds)

`make bench` (:mod:`benchmarks.run`, workload ``reachmap``) runs it as this
command in a child process, with its own sizes (``--sizes``): Dask's worker
processes start by importing the parent's main module, which must not run the
whole benchmark again (this module's is guarded; ``python -m benchmarks`` is not).

The map is issue 24's: ``voxel`` (5 cm), ``directions`` approach directions
times the default rolls (one: any roll about the approach axis), method
``fk`` sampled until a block adds fewer than ``converge`` times the
voxel-bins before it (``samples`` the budget), built twice, on a
LocalCluster of 1 and of 2 worker processes. Rows as in
:mod:`benchmarks.workloads` (:func:`benchmarks.workloads.row`):

- ``reachmap_dask``: the build on 1 and on 2 workers, ``dask_repeats``
  times each in turns (1, 2, 1, 2 ..; medians, with the load average): the
  time from the first progress report (the cluster up, the first blocks
  handed out) to the map, the cluster's start apart (``cluster_start_s``),
  and 2 workers' speed-up over 1; every map checked identical (reach codes,
  certificates, first configurations, settings: same seed, same map, any
  worker count). ``--only-dask`` runs these rows alone.
- ``reachmap_fk``: the 1-worker build as certified voxel-bins per
  core-second, beside reuleaux_moveit's reported 3.8 reachable poses per
  core-second (issue 17); every certificate's FK checked to land in its bin.
- ``reachmap_hybrid``: a smaller map (``hybrid_voxel``, ``hybrid_directions``,
  up to ``hybrid_samples`` samples, converge 0.001) with the IK fill passes,
  in this process (one core): the voxel-bins IK added, the passes, the time;
  every IK answer's FK checked to land in its voxel-bin. (The fill tries
  every unreached voxel-bin next to a reached one: on the 5 cm map that is
  over a million IK targets a pass.)
- ``reachmap_agreement``: ``labelled`` FK poses of random configurations
  (reachable by construction; seed 99, a stream the build never draws from)
  and ``labelled`` random poses in the grid's box (uniform position, uniform
  rotation) labelled by ``ik_many`` with 50 restarts in the mode the map
  answers in (``position+axis`` for one roll: the map says "any roll"),
  success by FK at 1e-9. Recall = reachable-labelled poses the map calls
  reachable; false-positive rate = unreachable-labelled poses it calls
  reachable (issue 24's wording), also as a share of all labelled poses;
  both also per set (``false_positive`` is of the unreachable-labelled
  poses, ``false_positive_of`` says so). Three rows: the default answer
  (``query``: refined, the poses of support strictly between 0 and 1
  decided by IK of the exact pose, ``decided_by_ik`` of them), the map's
  unrefined yes (``refine=False``: voxel-bin reached and support at least
  the default threshold; its row also tabulates ``AGREEMENT_THRESHOLDS``)
  and the plain voxel-bin answer (``interpolate=False``). IK failing does not prove a pose unreachable,
  so a false positive may be a pose IK missed.
- ``ik_many``: solves per second on iiwa14 (FK of random configurations,
  random first starts) on 2 threads and on 1, timed in turns in one run
  (with the load average, since the machine may be shared); success checked
  by Pinocchio at 1e-9, and the answers of the two must be identical.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

from benchmarks.workloads import IK_ACCEPT, row

FULL = dict(voxel=0.05, directions=200, samples=150_000_000, converge=3e-5, ik_targets=20_000, labelled=50_000,
            hybrid_voxel=0.1, hybrid_directions=50, hybrid_samples=4_000_000, dask_repeats=2)
QUICK = dict(voxel=0.1, directions=50, samples=300_000, converge=1e-3, ik_targets=2000, labelled=600,
             hybrid_voxel=0.2, hybrid_directions=20, hybrid_samples=100_000, dask_repeats=1)
LABEL_RESTARTS = 50
AGREEMENT_THRESHOLDS = (0.5, 0.6, 0.65, 0.7, 0.75, 0.8)  # the support thresholds tabulated


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
    from manipkit.ik.numerical_many import ik_many

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


def agreement_rows(robot, robot_name: str, one, labelled: int, what: str) -> list[dict]:
    """The ``reachmap_agreement`` rows of the map ``one``: its default (refined) yes, its unrefined yes, the voxel-bin
    answer."""
    from manipkit.analysis.reachmap.constants import DEFAULT_THRESHOLD
    from manipkit.analysis.reachmap.query import query_answer
    from manipkit.ik.numerical_many import ik_many

    rng = np.random.default_rng(5)
    fk_poses = robot.fk(robot.sample_q(labelled, seed=99), base=one.base, tip=one.frame)
    box_low = one.origin
    box_high = one.origin + (np.array(one.shape) - 1) * one.voxel
    random_poses = np.tile(np.eye(4), (labelled, 1, 1))
    random_poses[:, :3, :3] = _random_rotations(labelled, rng)
    random_poses[:, :3, 3] = box_low + rng.random((labelled, 3)) * (box_high - box_low)
    mode = one.settings["ik_mode"]
    start = time.perf_counter()
    batch = ik_many(robot, random_poses, one.base, one.frame, mode=mode, restarts=LABEL_RESTARTS, tol=1e-9, seed=7)
    seconds_label = time.perf_counter() - start
    labels = np.concatenate([np.ones(labelled, dtype=bool), np.array(batch.success, dtype=bool)])
    poses = np.concatenate([fk_poses, random_poses])
    answer = query_answer(one, poses, refine=False)  # both answers and the score, to tabulate thresholds on the poses
    completeness = one.settings["completeness"]
    sweep = {f"{t:g}": {"false_positive_share_of_all": float((answer.bin_reached & (answer.score >= t) & ~labels).mean()),
                        "recall": float((answer.bin_reached & (answer.score >= t))[labels].mean())}
             for t in AGREEMENT_THRESHOLDS}
    rows = []
    refined = query_answer(one, poses, robot=robot)  # which poses IK decided
    for interpolate, refine, how in (
            (True, None, "ReachMap.query (default: refined, IK of the exact pose where 0 < support < 1)"),
            (True, False, f"ReachMap.query(refine=False) (voxel-bin reached and support >= {DEFAULT_THRESHOLD:g})"),
            (False, False, "ReachMap.query(interpolate=False) (voxel-bin reached)")):
        start = time.perf_counter()
        says = one.query(poses, interpolate=interpolate, refine=refine)
        seconds_query = time.perf_counter() - start
        same = bool(np.array_equal(says, refined.reachable if refine is None else answer.reachable if interpolate
                                   else answer.bin_reached))
        recall = float(says[labels].mean())
        false_positive = float(says[~labels].mean()) if (~labels).any() else 0.0
        rows.append(row("reachmap_agreement", robot_name, f"map (fk, converged) vs IK labels: {how}",
                        [seconds_query / len(poses)], unit="pose", n=len(poses), ours=True, recall=recall,
                        false_positive=false_positive, agreement=float((says == labels).mean()),
                        false_positive_share_of_all=float((says & ~labels).mean()),
                        recall_fk_poses=float(says[:labelled].mean()),
                        recall_random_reachable=float(says[labelled:][labels[labelled:]].mean()),
                        random_poses_reachable=float(labels[labelled:].mean()), label_seconds=seconds_label,
                        false_positive_of="unreachable-labelled poses", unreachable_labelled=int((~labels).sum()),
                        threshold=DEFAULT_THRESHOLD if interpolate else 0.0, status="ok" if same else "wrong",
                        **({"thresholds": sweep} if interpolate and refine is False else {}),
                        **({"decided_by_ik": int(refined.decided_by_ik.sum())} if refine is None else {}),
                        check=f"labels: ik_many mode {mode}, {LABEL_RESTARTS} restarts, tol 1e-9 (success by FK); "
                              f"query equals query_answer's {'reachable' if interpolate else 'bin_reached'}: {same}",
                        note=f"{labelled} FK poses of random configurations + {labelled} random poses in the grid box; "
                             f"{what}; the map's own held-out completeness {completeness['rate']:.2%}"))
    return rows


def dask_rows(robot, robot_name: str, settings: dict, *, repeats: int) -> tuple[dict, list[dict]]:
    """The ``reachmap_dask`` rows: ``repeats`` builds on 1 and on 2 workers, in turns (1, 2, 1, 2 ..); ({workers: the
    last map}, rows). A build's time runs from its first progress report (the cluster up, the first blocks handed out)
    to the map; the cluster's start (from the call to that report) is given apart."""
    from manipkit.analysis import reachmap

    maps, builds, starts, loads, identical = {}, {1: [], 2: []}, {1: [], 2: []}, [], True
    for _ in range(repeats):
        for workers in (1, 2):
            first = []
            start = time.perf_counter()
            built = reachmap.build(robot, **settings, workers=workers,
                                   progress=lambda *_: first.append(time.perf_counter()) if not first else None)
            end = time.perf_counter()
            starts[workers].append(first[0] - start)
            builds[workers].append(end - first[0])
            loads.append(os.getloadavg()[0])
            if maps:  # every map equal to the first: same seed, same map, any worker count
                reference = next(iter(maps.values()))
                identical &= bool(np.array_equal(reference.reach, built.reach)
                                  and np.array_equal(reference.cert_keys, built.cert_keys)
                                  and np.array_equal(reference.cert_q, built.cert_q)
                                  and np.array_equal(reference.voxel_q, built.voxel_q, equal_nan=True)
                                  and reference.settings == built.settings)
            maps[workers] = built
    used = maps[1].settings["samples_used"]
    ratio = float(np.median(builds[1]) / np.median(builds[2]))
    load = float(np.median(loads))
    rows = []
    for workers in (1, 2):
        rows.append(row("reachmap_dask", robot_name, f"LocalCluster, {workers} worker process(es)", builds[workers],
                        unit="map", n=1, ours=True, identical_1_2=identical, status="ok" if identical else "wrong",
                        samples=used, cluster_start_s=float(np.median(starts[workers])),
                        speedup_2_vs_1_worker=ratio, load_average=load, cores=os.cpu_count(),
                        check=f"all {2 * repeats} maps (1 and 2 workers) identical (reach, certificates, "
                              "configurations, settings)",
                        note=f"{settings['voxel']} m voxels, {maps[1].orientations.label} orientation bins, {used} "
                             f"samples (converge {settings['converge']:g}); median of {repeats} build(s) per worker "
                             f"count, 1 and 2 in turns; time from the first progress report to the map, the "
                             f"cluster's start ({np.median(starts[workers]):.1f} s) apart; 2 workers "
                             f"{ratio:.2f}x 1 worker; load average {load:.2f} on {os.cpu_count()} cores"))
    return maps, rows


def reachmap_workload(robot_name: str = "iiwa14", *, voxel: float, directions: int, samples: int, converge: float,
                      ik_targets: int, labelled: int, hybrid_voxel: float, hybrid_directions: int,
                      hybrid_samples: int, dask_repeats: int = 1, only_dask: bool = False) -> list[dict]:
    """Every row of the module docstring, for ``robot_name`` (only the ``reachmap_dask`` rows with ``only_dask``)."""
    # Over 80 lines: one workload, its steps in order; each check sits beside the number it guards.
    import manipkit
    from manipkit.analysis import reachmap

    robot = manipkit.load(robot_name)
    settings = dict(voxel=voxel, orientations=directions, manipulability=False, samples=samples, converge=converge)
    reachmap.build(robot, voxel=voxel, orientations=directions, samples=1000)  # warm-up: numba kernels loaded

    maps, rows = dask_rows(robot, robot_name, settings, repeats=dask_repeats)
    one, walls = maps[1], {1: rows[0]["median_s"]}
    used = one.settings["samples_used"]
    what = (f"{voxel} m voxels, {one.orientations.label} orientation bins (directions x rolls), {used} samples "
            f"drawn of {samples} (converge {converge:g})")
    if only_dask:
        return rows
    T_cert = robot.fk(one.cert_q, base=one.base, tip=one.frame)  # each certificate's voxel and bin, found again
    ijk, inside = one.voxel_of(T_cert[:, :3, 3])
    keys = np.ravel_multi_index(tuple(ijk.T), one.shape) * one.orientations.size + one.orientations.bin_of(T_cert[:, :3, :3])
    lands = bool(inside.all() and np.array_equal(keys, one.cert_keys)
                 and np.array_equal(np.sort(keys), np.flatnonzero(one.reach.reshape(-1))))
    certified = int(keys.size)
    completeness = one.settings["completeness"]
    rows.append(row("reachmap_fk", robot_name, "manipkit reachmap.build(method='fk'), LocalCluster of 1 worker",
                    [walls[1]], unit="map", n=1, ours=True, certified=certified, per_core_second=certified / walls[1],
                    samples=used, voxels=int(one.reachable.sum()), status="ok" if lands else "wrong",
                    held_out_completeness=completeness["rate"],
                    check=f"one certificate per reached voxel-bin, its FK (Pinocchio-checked kernel) in that bin: {lands}",
                    note=f"{what}; reuleaux_moveit reports 3.8 per core-second"))

    start = time.perf_counter()
    hybrid = reachmap.build(robot, voxel=hybrid_voxel, orientations=hybrid_directions, manipulability=False,
                            samples=hybrid_samples, converge=1e-3, method="hybrid")
    seconds_h = time.perf_counter() - start
    by_ik = int((hybrid.reach == reachmap.HOW_IK).sum())
    T = robot.fk(hybrid.ik_q, base=hybrid.base, tip=hybrid.frame)
    ijk, inside = hybrid.voxel_of(T[:, :3, 3])
    ik_keys = np.ravel_multi_index(tuple(ijk.T), hybrid.shape) * hybrid.orientations.size \
        + hybrid.orientations.bin_of(T[:, :3, :3])
    lands = bool(inside.all() and np.array_equal(ik_keys, hybrid.ik_keys))
    rows.append(row("reachmap_hybrid", robot_name, "manipkit reachmap.build(method='hybrid'), 1 core", [seconds_h],
                    unit="map", n=1, ours=True, certified=int(hybrid.cert_keys.size), by_ik=by_ik,
                    fill_passes=hybrid.settings["fill_passes"], samples=hybrid.settings["samples_used"],
                    status="ok" if lands else "wrong", check=f"every IK answer's FK lands in its voxel-bin: {lands}",
                    note=f"{hybrid_voxel} m voxels, {hybrid_directions} directions, converge 0.001; IK on unreached "
                         "voxel-bins next to reached ones, seeded from the neighbour's certificate"))

    rows += agreement_rows(robot, robot_name, one, labelled, what)
    rows += ik_many_rows(robot, robot_name, ik_targets)
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--robot", default="iiwa14")
    parser.add_argument("--sizes", default=None, help="the sizes as a JSON object (keys of FULL), instead of FULL or QUICK")
    parser.add_argument("--out", default=None, help="write the rows as JSON here")
    parser.add_argument("--only-dask", action="store_true", help="only the reachmap_dask rows (1 and 2 workers)")
    args = parser.parse_args(argv)
    sizes = dict(QUICK if args.quick else FULL)
    if args.sizes:
        extra = json.loads(args.sizes)
        unknown = set(extra) - set(FULL)
        if unknown:
            parser.error(f"unknown size(s) {', '.join(sorted(unknown))}; choose from {', '.join(FULL)}")
        sizes.update(extra)
    rows = reachmap_workload(args.robot, **sizes, only_dask=args.only_dask)
    for r in rows:
        shown = {k: v for k, v in r.items() if k not in ("ours", "p95_s", "status") and v not in (None, "")}
        print(json.dumps(shown))
    if args.out:
        with open(args.out, "w", encoding="utf-8") as f:
            json.dump({"cores": os.cpu_count(), "rows": rows}, f, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
