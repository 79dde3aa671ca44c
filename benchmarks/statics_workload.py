"""Static torques (issue 37): batched ``static_torques`` with a payload against a Python loop over Pinocchio's
``computeStaticTorque``, timed in turns.

Rows as in :mod:`benchmarks.workloads` (:func:`benchmarks.workloads.row`), workload ``statics``: manipkit's
``static_torques(chain, Q, payload=...)`` on ``n_batch`` configurations of the iiwa14 (one batched call), against
``pinocchio.computeStaticTorque`` called per configuration on a copy of the model with the payload appended to the
tip's body (the same question asked of Pinocchio directly). Every answer of the loop's subset is checked against
manipkit's to 1e-10 first; a row with wrong answers gets no time. The two are timed in turns (``in_turns``), so a
change in the machine's load falls on both; the loop's time is per configuration over ``loop_subset`` rows.
"""

from __future__ import annotations

import numpy as np

from benchmarks.workloads import in_turns, max_error, row

__all__ = ["statics_workload"]


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
    import time

    start = time.perf_counter()
    fn()
    return time.perf_counter() - start
