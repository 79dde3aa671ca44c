"""General 6R IK (`make bench`, workload ``general6r``): every solution of the xArm6 per pose, in one run against
one numerical solve of manipkit and against ssik (PyPI ``ssik``, when installed) on the same arm from its URDF.

The xArm6 is loaded from ../shared/realworld/ws_more as its users load it (xacro arguments dof=6,
robot_type=xarm); targets are FK of random in-limit configurations. Every answer is checked before timing: each
returned row by Pinocchio's FK (``robot.transform``), and the generating configuration must be among manipkit's
rows. The rows are then timed in turns (:func:`benchmarks.workloads.in_turns`), so the ratios are of one run.
"""

from __future__ import annotations

import tempfile
import warnings
from functools import partial
from pathlib import Path

import numpy as np

from benchmarks import peers as peer_adapters
from benchmarks.workloads import IK_ACCEPT, batch_timed, calls_timed, in_turns, row

__all__ = ["XARM6", "general6r_workload"]

XARM6 = ("xarm_ros2/xarm_description/urdf/xarm_device.urdf.xacro", {"dof": "6", "robot_type": "xarm"})


def _xarm6():
    for base in Path(__file__).resolve().parents[1:4]:
        path = base / "shared" / "realworld" / "ws_more" / "src" / XARM6[0]
        if path.is_file():
            import manipkit

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return manipkit.load(str(path), **XARM6[1])
    return None


def _wrapped_gap(A, B):
    return np.abs(np.pi - np.mod(np.pi - (np.asarray(A) - np.asarray(B)), 2 * np.pi))


def _ssik(robot, chain, T, Q, rounds, timers) -> list:
    """ssik's ``Manipulator.solve`` on the same arm built from its URDF (manipkit's expanded text; base ``world``,
    tip ``link_eef``): pending ``(timer key or None, times -> row)``."""
    label = "ssik Manipulator.solve, every solution"
    try:
        import ssik
    except ImportError:
        return [(None, partial(row, "general6r", "xarm6", f"{label} (ssik)", unit="pose", status="missing",
                               note="ssik is not installed (pip install 'ssik[urdf]')"))]
    try:
        with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as handle:
            handle.write(robot.urdf)
        arm = ssik.Manipulator.from_urdf(handle.name, base=chain.base, ee=robot.frame(chain.tip))
        answers = [[np.asarray(s.q, dtype=float) for s in arm.solve(target)] for target in T]
    except Exception as exc:  # a peer that cannot read the file is reported, not timed
        return [(None, partial(row, "general6r", "xarm6", f"{label} (ssik)", unit="pose", status="missing",
                               note=f"ssik could not solve the xArm6: {type(exc).__name__}: {exc}"))]
    worst = max((float(np.abs(robot.transform(chain.base, chain.tip, q, check_limits=False) - target).max())
                 for rows, target in zip(answers, T) for q in rows), default=0.0)
    found = float(np.mean([any(_wrapped_gap(q, g).max() < 1e-6 for q in rows) for rows, g in zip(answers, Q)]))
    ok = worst <= IK_ACCEPT
    if ok:
        timers["ssik"] = lambda r: calls_timed(arm.solve, list(T[r::rounds]))
    version = peer_adapters.version("ssik") or "?"
    return [("ssik" if ok else None, partial(
        row, "general6r", "xarm6", f"{label} (ssik {version}, {arm.solver_name})", unit="pose", n=len(T),
        status="ok" if ok else "wrong", max_fk_error=worst, recovered=found,
        solutions_per_pose=float(np.mean([len(a) for a in answers])),
        check=f"Pinocchio FK of every answer: max error {worst:.1e}; generating configuration among the answers: "
              f"{found:.1%}", note="its defaults: in-limit rows with 2 pi windings enumerated"))]


def general6r_workload(*, n_poses: int = 200, rounds: int = 5, seed: int = 17) -> list[dict]:
    """Rows of workload ``general6r``: manipkit's every-solution call (``ik(all=True)``, the algebraic
    elimination), its batch (``ik_many`` of all the targets on 2 threads), one numerical solve of manipkit
    (``ik(method="numerical")``) and ssik, per pose."""
    import manipkit

    robot = _xarm6()
    if robot is None:
        return [row("general6r", "xarm6", "xarm6 description", unit="pose", status="missing",
                    note="the shared workspace ws_more with the xArm6 is not here: not run")]
    chain = robot.chain("base_link", "ee_link")
    Q = chain.sample(n_poses, seed=seed)
    T = chain.fk(Q)
    answers = [manipkit.ik(robot, target, all=True) for target in T]
    worst = max((float(np.abs(robot.transform("base_link", "ee_link", q, check_limits=False) - target).max())
                 for a, target in zip(answers, T) for q in a.solutions), default=0.0)
    found = float(np.mean([len(a.solutions) and _wrapped_gap(a.solutions, q).max(axis=1).min() < 1e-7
                           for a, q in zip(answers, Q)]))
    method = {a.method for a in answers}
    batch = manipkit.ik_many(robot, T, threads=2)
    single = [manipkit.ik(robot, target, all=True, aliases=False).solutions[:, chain.columns] for target in T]
    same = all(np.array_equal(b[~np.isnan(b[:, 0])], s) for b, s in zip(batch.solutions, single))
    batch_worst = max((float(np.abs(robot.transform("base_link", "ee_link", q, check_limits=False) - target).max())
                       for b, target in zip(batch.solutions, T) for q in b[~np.isnan(b[:, 0])]), default=0.0)
    numerical = [manipkit.ik(robot, target, method="numerical") for target in T]
    solved = float(np.mean([a.success for a in numerical]))
    timers = {
        "ours": lambda r: calls_timed(lambda target: manipkit.ik(robot, target, all=True), list(T[r::rounds])),
        "numerical": lambda r: calls_timed(lambda target: manipkit.ik(robot, target, method="numerical"),
                                           list(T[r::rounds])),
        "batch": lambda r: np.array([batch_timed(lambda: manipkit.ik_many(robot, T, threads=2), len(T))]),
    }
    pending = _ssik(robot, chain, T, Q, rounds, timers)
    times = in_turns(timers, rounds)
    ok = worst <= 1e-10 and found >= 0.999 and method == {"algebraic"}
    rows = [row("general6r", "xarm6", "manipkit ik(all=True), every solution (algebraic elimination)",
                times["ours"] if ok else None, unit="pose", n=n_poses, ours=True, status="ok" if ok else "wrong",
                max_fk_error=worst, recovered=found,
                solutions_per_pose=float(np.mean([len(a.solutions) for a in answers])),
                check=f"Pinocchio FK of every answer: max error {worst:.1e}; generating configuration among the "
                      f"answers: {found:.1%}; method {', '.join(sorted(method))}",
                note="every isolated solution, limits marked; the elimination, the rows' check and their aliases compiled"),
            row("general6r", "xarm6", "manipkit ik_many, every solution, 2 threads (algebraic elimination)",
                times["batch"] if same and batch_worst <= 1e-10 and batch.method == "algebraic" else None,
                unit="pose", n=n_poses, ours=True,
                status="ok" if same and batch_worst <= 1e-10 and batch.method == "algebraic" else "wrong",
                max_fk_error=batch_worst, solutions_per_pose=float(np.mean(batch.count)),
                check=f"each target's rows those of ik(all=True, aliases=False): {'yes' if same else 'NO'}; "
                      f"Pinocchio FK of every row: max error {batch_worst:.1e}; method {batch.method}",
                note="the whole batch of targets per call, 2 pi aliases not listed; compiled, blocks of 16 on threads"),
            row("general6r", "xarm6", "manipkit ik(method='numerical'), one solution", times["numerical"],
                unit="pose", n=n_poses, success=solved,
                check=f"solved {solved:.1%} (residual checked by FK in the solver)",
                note="the compiled Levenberg-Marquardt search, stops at its first solution")]
    for key, make in pending:
        rows.append(make(times[key]) if key else make())
    return rows
