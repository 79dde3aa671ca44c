"""Collision checks (issue 23): batched self-collision checks, the allowed-collision matrix, a filtered reach map.

Rows as in :mod:`benchmarks.workloads` (:func:`benchmarks.workloads.row`):

- ``collisions``: self-collision checks per configuration on the Panda (convex
  hulls, Franka's SRDF): ``manipkit.collision_free`` (Pinocchio's
  ``computeCollisionsInParallel`` with a broad phase, on 2 threads and on 1)
  against a Python loop over ``pinocchio.computeCollisions`` (stop at the
  first contact) on the same geometry and pairs, timed in turns; the answers
  must agree on every configuration.
- ``acm``: the Panda's allowed-collision matrix from 10,000 samples on 2
  threads and on 1, whole runs timed; checked equal to the SRDF
  example-robot-data ships, and the two equal.

Pinocchio's Python calls hold the GIL (``computeCollisions`` and
``computeCollisionsInParallel`` alike), so threads help only inside
``computeCollisionsInParallel`` (OpenMP, statically split); each row gives
the load average, since a busy machine takes the second core away.
- ``reachmap_collisions``: the iiwa14 FK map at 0.1 m with and without
  ``collisions=self,floor``, each sampled until it converges as the command
  line builds it (``--converge 0.001``, ``map_samples`` the budget; each
  row says how many samples its map drew); the filtered map must reach a
  subset of the plain one. Then both again at a fixed ``map_samples`` drawn
  in full (``converge=0``), the same comparison at equal sample counts.
"""

from __future__ import annotations

import os
import re
import time
import warnings

import numpy as np

from benchmarks.workloads import no_gc, row


def _srdf_pairs(text: str) -> dict:
    return {tuple(sorted(m[:2])): m[2] for m in re.findall(r'link1="([^"]+)" link2="([^"]+)" reason="([^"]+)"', text)}


def collisions_workload(*, checks: int, repeats: int, acm_samples: int, map_samples: int, voxel: float,
                        directions: int, map_converge: float = 0.001, fixed_samples: int = 1_000_000) -> list[dict]:
    """Every row of the module docstring."""
    import pinocchio as pin

    import manipkit
    from manipkit.analysis.acm import allowed_collision_matrix, srdf_text
    from manipkit.analysis.reachmap import build
    from manipkit.kinematics.collisions import CollisionChecker, CollisionSettings

    rows = []
    panda = manipkit.load("panda")
    srdf = panda.source.path.parents[1] / "srdf" / "panda.srdf"
    checker = CollisionChecker(panda, srdf=srdf)
    Q = panda.sample_q(checks, seed=23)
    configurations = panda.joint_layout.configurations(Q)
    data = checker.model.createData()
    with warnings.catch_warnings():  # as the checker's own: no cached guess (see kinematics.collisions)
        warnings.simplefilter("ignore", DeprecationWarning)
        for request in data.collisionRequests:
            request.enable_cached_gjk_guess = False
    model_data = panda.model.createData()

    def loop():
        return np.array([pin.computeCollisions(panda.model, model_data, checker.model, data, configurations[:, i], True)
                         for i in range(configurations.shape[1])])

    expected = loop()
    agree = all(bool((checker.in_collision(Q, workers=k) == expected).all()) for k in (1, 2))
    times = {"batch2": [], "batch1": [], "loop": []}
    loads = []
    with no_gc():
        for _ in range(repeats):
            for key, run in (("batch2", lambda: checker.in_collision(Q, workers=2)),
                             ("batch1", lambda: checker.in_collision(Q, workers=1)), ("loop", loop)):
                t = time.perf_counter()
                run()
                times[key].append((time.perf_counter() - t) / checks)
            loads.append(os.getloadavg()[0])
    status = "ok" if agree else "wrong"
    load = f"load average {np.median(loads):.2f} on {os.cpu_count()} cores"
    check = f"{int(expected.sum())} of {checks} in collision; batched (1 and 2 threads) == loop on every configuration: {agree}"
    speedup = float(np.median(times["batch1"]) / np.median(times["batch2"]))
    rows.append(row("collisions", "panda", "manipkit collision_free (2 threads)", times["batch2"], unit="config", n=checks,
                    ours=True, status=status, check=check, threads=2, speedup_vs_1_thread=speedup,
                    load_average=float(np.median(loads)), note=f"hulls, Franka's SRDF (20 pairs); {load}"))
    rows.append(row("collisions", "panda", "manipkit collision_free (1 thread)", times["batch1"], unit="config", n=checks,
                    status=status, check=check, threads=1, note="the same call on one thread"))
    rows.append(row("collisions", "panda", "Python loop over pinocchio.computeCollisions", times["loop"], unit="config",
                    n=checks, status=status, check=check))

    shipped = _srdf_pairs(srdf.read_text())
    matrices, seconds = {}, {}
    for workers in (2, 1):
        t = time.perf_counter()
        matrices[workers] = allowed_collision_matrix(panda, samples=acm_samples, seed=0, workers=workers)
        seconds[workers] = time.perf_counter() - t
    same_on_threads = matrices[1] == matrices[2]
    for workers in (2, 1):
        matrix = matrices[workers]
        same = _srdf_pairs(srdf_text(matrix)) == shipped
        rows.append(row("acm", "panda", f"manipkit allowed_collision_matrix, {workers} thread{'s' if workers > 1 else ''}",
                        [seconds[workers]], unit="run", n=acm_samples, ours=workers == 2, threads=workers,
                        status="ok" if same_on_threads else "wrong", load_average=os.getloadavg()[0],
                        check=f"{len(matrix.disabled)} pairs disabled; equal to example-robot-data's SRDF: {same}; "
                              f"the same on 1 and 2 threads: {same_on_threads}",
                        note=", ".join(f"{v} {k}" for k, v in matrix.counts().items())
                        + f"; load average {os.getloadavg()[0]:.2f}"))

    iiwa = manipkit.load("iiwa14")
    settings = CollisionSettings.parse(iiwa, "self,floor", floor=0.0)
    base = dict(voxel=voxel, orientations=directions, manipulability=False)
    build(iiwa, **base, samples=1000, collisions=settings)  # warm: kernels compiled, checker built
    for label, options in ((f"converged ({map_converge:g})", dict(samples=map_samples, converge=map_converge)),
                           ("fixed samples", dict(samples=fixed_samples, converge=0.0))):
        t = time.perf_counter()
        plain = build(iiwa, **base, **options)
        t_plain = time.perf_counter() - t
        t = time.perf_counter()
        filtered = build(iiwa, **base, **options, collisions=settings)
        t_filtered = time.perf_counter() - t
        subset = bool((filtered.reach <= plain.reach).all())
        used = (plain.settings["samples_used"], filtered.settings["samples_used"])
        check = (f"reachable voxels {int(filtered.reachable.sum())} of {int(plain.reachable.sum())}; "
                 f"filtered within the plain map: {subset}; samples drawn {used[1]} (filtered) and {used[0]} (plain)")
        rows.append(row("reachmap_collisions", "iiwa14", f"manipkit reachmap.build, collisions self,floor, {label}",
                        [t_filtered], unit="map", n=options["samples"], ours=True, status="ok" if subset else "wrong",
                        check=check, slowdown=t_filtered / t_plain, samples_used=used[1]))
        rows.append(row("reachmap_collisions", "iiwa14", f"manipkit reachmap.build, no collisions, {label}", [t_plain],
                        unit="map", n=options["samples"], check=check, samples_used=used[0]))
    return rows
