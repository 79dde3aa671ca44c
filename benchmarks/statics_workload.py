"""Static torques (issue 37): batched ``static_torques`` with a payload against a Python loop over Pinocchio's
``computeStaticTorque``, timed in turns.

Rows as in :mod:`benchmarks.workloads` (:func:`benchmarks.workloads.row`), workload ``statics``: manipkit's
``static_torques(chain, Q, payload=...)`` on ``n_batch`` configurations of the iiwa14 (one batched call), against
``pinocchio.computeStaticTorque`` called per configuration on a copy of the model with the payload appended to the
tip's body (the same question asked of Pinocchio directly). Every answer of the loop's subset is checked against
manipkit's to 1e-10 first; a row with wrong answers gets no time. The two are timed in turns (``in_turns``), so a
change in the machine's load falls on both; the loop's time is per configuration over ``loop_subset`` rows.

Workload ``reachmap_payload`` (:func:`payload_map_workload`): the payload layer of a reach map
(:func:`manipkit.analysis.reachmap.payload_map`, best and worst capacity per voxel) against the reach map of the same
grid (``build``, method ``fk``, ``samples`` samples, here on one core), timed in turns in one run; the payload row
carries ``payload_over_map`` (the layer's time over the map's) and ``map_and_payload_over_map`` (a payload map from
nothing: the map and its layer, over the map alone; issue 37's goal is at most 2). For a 7R SRS arm (the iiwa14)
the goal's row is the layer at the stored configurations' own arm angles (``arm_angles=0``: the same poses and
branches the map's certificates give, as the goal was set), and a second row, timed in the same turns, is the
default layer that also samples the self-motion at ``ARM_ANGLES`` arm angles (about one more solve and capacity
of every block per angle, so it is compared with the map but not held to the goal). Its check: ``checked`` stored
configurations' capacities recomputed one at a time by ``payload_capacity``: equal to the bit to their bins' (a
layer of the stored configurations alone), or inside their bins' worst..best (every closed-form branch, the UR5,
the iiwa14 at its own arm angle).
"""

from __future__ import annotations

import time

import numpy as np

from benchmarks.workloads import in_turns, max_error, row

__all__ = ["payload_map_workload", "statics_workload"]


def statics_workload(robot_name: str = "iiwa14", *, n_batch: int = 100_000, loop_subset: int = 5000, rounds: int = 5,
                     seed: int = 37) -> list[dict]:
    import pinocchio as pin

    import manipkit
    from manipkit.statics.torques import Payload, static_torques

    robot = manipkit.load(robot_name)
    chain = robot.chain("base_link", "ee_link")
    Q = chain.sample(n_batch, seed=seed)
    payload = Payload(3.0, (0.0, 0.02, 0.1))
    model = robot.model.copy()
    tip = model.frames[robot.frame_id(chain.tip)]
    model.inertias[tip.parentJoint] = model.inertias[tip.parentJoint] + tip.placement.act(
        pin.Inertia(payload.mass, payload.cog, np.zeros((3, 3))))
    data = model.createData()
    fext = pin.StdVec_Force()
    for _ in range(model.njoints):
        fext.append(pin.Force.Zero())
    configs = [robot.pinocchio_configuration(chain.full(q)) for q in Q[:loop_subset]]
    S = robot.velocity_map()

    def loop():
        return np.array([pin.computeStaticTorque(model, data, c, fext) for c in configs])

    ours = static_torques(chain, Q, payload=payload).tau
    reference = (loop() @ S)[:, chain.columns]
    err = max_error(ours[:loop_subset], reference)
    ok = err <= 1e-10
    check = f"max |tau - Pinocchio computeStaticTorque| = {err:.1e} (<= 1e-10) over {loop_subset}"
    timers = {"ours": lambda r: _seconds(lambda: static_torques(chain, Q, payload=payload)) / n_batch,
              "loop": lambda r: _seconds(loop) / loop_subset}
    times = in_turns(timers, rounds) if ok else {"ours": None, "loop": None}
    return [
        row("statics", robot_name, "manipkit static_torques with a payload, batched", times["ours"], unit="config",
            n=n_batch, ours=True, status="ok" if ok else "wrong", check=check),
        row("statics", robot_name, "Pinocchio computeStaticTorque (payload appended), Python loop", times["loop"],
            unit="config", n=loop_subset, status="ok" if ok else "wrong", check="the reference",
            note=f"a loop over {loop_subset} rows, timed in turns with the batch"),
    ]


def _seconds(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def payload_map_workload(robot_name: str = "iiwa14", *, voxel: float = 0.05, directions: int = 200,
                         samples: int = 10_000_000, rounds: int = 3, checked: int = 500) -> list[dict]:
    import manipkit
    from manipkit.analysis.reachmap import build, payload_map
    from manipkit.analysis.reachmap.payloadmap import ARM_ANGLES, configurations_of
    from manipkit.statics.capacity import payload_capacity

    robot = manipkit.load(robot_name)
    cog = (0.0, 0.02, 0.1)
    options = dict(voxel=voxel, orientations=directions, samples=samples, holdout=0, fp_checks=0)
    built = {}
    sampled = configurations_of(robot, "base_link", "ee_link") == "self_motion"

    def map_once(r):
        start = time.perf_counter()
        built["map"] = build(robot, **options)
        return time.perf_counter() - start

    def payload_once(r):
        start = time.perf_counter()
        built["layer"] = payload_map(built["map"], robot, cog=cog, arm_angles=0)
        return time.perf_counter() - start

    def self_motion_once(r):
        start = time.perf_counter()
        built["moving"] = payload_map(built["map"], robot, cog=cog, arm_angles=ARM_ANGLES)
        return time.perf_counter() - start

    timers = {"map": map_once, "payload": payload_once, **({"moving": self_motion_once} if sampled else {})}
    times = in_turns(timers, rounds)
    reach_map, layer = built["map"], built["layer"].payload
    rows = np.random.default_rng(37).choice(len(reach_map.cert_q), size=min(checked, len(reach_map.cert_q)),
                                            replace=False)
    again = np.array([float(payload_capacity(robot, reach_map.cert_q[i], cog=cog).max_mass) for i in rows])
    if layer.configurations == "certificates":
        ok = np.array_equal(again, layer.bins[rows])
        check = (f"{len(rows)} stored capacities recomputed one configuration at a time by payload_capacity: "
                 f"{'equal' if ok else 'NOT equal'}")
    else:  # the stored configuration is one of the bin's branches: its capacity lies in the bin's range
        ok = bool(np.all((layer.bins_worst[rows] <= again) & (again <= layer.bins[rows])))
        check = (f"{len(rows)} stored configurations' capacities, one at a time by payload_capacity: "
                 f"{'inside' if ok else 'NOT inside'} their bins' worst..best over the weighed branches")
    m, p = float(np.median(times["map"])), float(np.median(times["payload"]))
    grid = f"{'x'.join(map(str, reach_map.shape))} voxels of {voxel:g} m, {directions} directions"
    out = [
        row("reachmap_payload", robot_name, "manipkit reachmap.build (fk), one core", times["map"], unit="map", n=1,
            ours=True, status="ok", check="the reach map the layer is on", note=f"{grid}, {samples} samples",
            voxel_bins=int(len(reach_map.cert_q))),
        row("reachmap_payload", robot_name, "manipkit payload_map on it (best and worst capacity per voxel)",
            times["payload"] if ok else None, unit="map", n=1, ours=True, status="ok" if ok else "wrong", check=check,
            note=f"{len(reach_map.cert_q)} voxel-bins, {layer.configurations_text()}, CoG {cog} m; timed "
                 f"in turns with the map", payload_over_map=p / m, map_and_payload_over_map=(m + p) / m),
    ]
    if sampled:
        moving = built["moving"].payload
        reached = ~np.isnan(layer.best)
        wider = bool(np.all(moving.best[reached] >= layer.best[reached])
                     and np.all(moving.worst[reached] <= layer.worst[reached]))
        s = float(np.median(times["moving"]))
        out.append(row(
            "reachmap_payload", robot_name, f"manipkit payload_map over the self-motion ({ARM_ANGLES} arm angles)",
            times["moving"] if ok and wider else None, unit="map", n=1, ours=True,
            status="ok" if ok and wider else "wrong",
            check=f"its best >= the fixed-angle layer's and its worst <= it in every reached voxel: "
                  f"{'yes' if wider else 'NO'}",
            note=f"{moving.configurations_text()}; not held to the 2x goal (about {ARM_ANGLES + 1} solves of every "
                 f"block); timed in turns with the map",
            payload_over_map=s / m, map_and_payload_over_map=(m + s) / m))
    return out
