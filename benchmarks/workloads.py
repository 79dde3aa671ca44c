"""The workloads of `make bench`, each returning result rows after checking every answer.

A row is a dict (see :func:`row`): workload, robot, tool, median and p95 time
(seconds, per the row's ``unit``), the sample count, the check that was made
and its outcome. A peer whose answers differ from manipkit's by more than
``FK_TOL`` gets status ``"wrong"`` and no time: a fast wrong answer never
counts. IK answers (many joint vectors reach one pose) are checked by
putting them through Pinocchio's forward kinematics instead.

Timings: ``time.perf_counter`` around each call (single calls) or around a
whole batch (batched calls), garbage collection off while timing, after a
warm-up; the closed-form workload takes all its rows' timings in turns
(:func:`in_turns`), so its ratios to EAIK see the same load. Everything runs in this one process on the same seeded inputs,
except the cold-start and viewer workloads, which time separate processes.
"""

from __future__ import annotations

import atexit
import contextlib
import gc
import json
import math
import os
import queue
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from functools import partial
from pathlib import Path

import numpy as np

from benchmarks import peers as peer_adapters

FK_TOL = 1e-9  # a peer's pose must equal manipkit's to this (every entry of T)
KERNEL_TOL = 1e-12  # manipkit's batched FK must equal Pinocchio's to this
IK_ACCEPT = 1e-9  # an IK answer counts when Pinocchio puts the frame within this (m and rad) of the target
RTB_IK_TOL = 1e-20  # RTB stops when E = e.e / 2 < tol: |e| < 1.4e-10, so its answers can meet IK_ACCEPT
PLANAR_TOL = 1e-9  # closed-form solutions must reach their targets to this (m, rad)
BIN = Path(sys.executable).parent


def row(workload, robot, tool, times=None, *, unit, n=0, ours=False, status="ok", check="", note="", **extra) -> dict:
    """One result: median and p95 of ``times`` (seconds per ``unit``)."""
    times = None if times is None else np.asarray(times, dtype=float)
    has = times is not None and times.size > 0 and status == "ok"
    return {
        "workload": workload,
        "robot": robot,
        "tool": tool,
        "ours": ours,
        "unit": unit,
        "median_s": float(np.median(times)) if has else None,
        "p95_s": float(np.percentile(times, 95)) if has else None,
        "n": int(n),
        "status": status,
        "check": check,
        "note": note,
        **extra,
    }


def _thaw() -> None:
    gc.unfreeze()
    gc.collect()


@contextlib.contextmanager
def no_gc():
    """No garbage collection inside the block, entered after a collection.

    What survives the collection is frozen (``gc.freeze``), so the next block's collection scans only what was
    made since: a full collection of this process took about 0.1 s, 45 of them 4.5 s of a quick run. At exit
    everything is thawed and collected, so that extension modules find their objects freed (nanobind reports
    those it finds alive as leaks).
    """
    enabled = gc.isenabled()
    gc.collect()
    if not gc.get_freeze_count():
        atexit.register(_thaw)
    gc.freeze()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def calls_timed(fn, inputs) -> np.ndarray:
    """Seconds of each ``fn(x)`` for x in ``inputs`` (no warm-up, garbage collection as the caller left it)."""
    times = np.empty(len(inputs))
    clock = time.perf_counter
    for i, x in enumerate(inputs):
        start = clock()
        fn(x)
        times[i] = clock() - start
    return times


def batch_timed(fn, n_items: int) -> float:
    """Seconds per item of one ``fn()`` that handles ``n_items`` (no warm-up)."""
    start = time.perf_counter()
    fn()
    return (time.perf_counter() - start) / n_items


def per_call(fn, inputs, *, warmup: int = 20) -> np.ndarray:
    """Seconds of each ``fn(x)`` for x in ``inputs`` (after ``warmup`` untimed calls)."""
    for x in inputs[:warmup]:
        fn(x)
    with no_gc():
        return calls_timed(fn, inputs)


def per_item(fn, n_items: int, *, repeats: int) -> np.ndarray:
    """Seconds per item of ``fn()`` (which handles ``n_items``), one value per repeat, after a warm-up call."""
    fn()
    with no_gc():
        return np.array([batch_timed(fn, n_items) for _ in range(repeats)])


def in_turns(timers: dict, rounds: int) -> dict:
    """Seconds per item of each timer, taken in turns: ``rounds`` rounds, each calling every timer once in order.

    ``timers`` maps a key to ``once(round)``, which runs that round's share of the work and returns its seconds per
    item (an array: one per call, or one for a whole batch). Every timer is called once before the first round
    (warm-up). A change in the machine's load (other jobs on a shared host) then falls on every row of a comparison
    alike, instead of on whichever row happened to run during it. Garbage collection is off while timing.
    """
    for once in timers.values():
        once(0)
    taken: dict = {key: [] for key in timers}
    with no_gc():
        for r in range(rounds):
            for key, once in timers.items():
                taken[key].append(np.atleast_1d(np.asarray(once(r), dtype=float)))
    return {key: np.concatenate(parts) for key, parts in taken.items()}


def max_error(A, B) -> float:
    return float(np.max(np.abs(np.asarray(A) - np.asarray(B)))) if np.size(A) else 0.0


def _peer_rows(robot_name, urdf_path, robot, wanted=("rtb", "ikpy", "kinpy")):
    loaded = {}
    for key in wanted:
        adapter, reason = peer_adapters.load_peer(key, robot, urdf_path)
        loaded[key] = (adapter, reason)
    return loaded


# --------------------------------------------------------------------------
# 1. forward kinematics


def fk_workload(robot_name: str, *, n_single: int = 1000, n_batch: int = 100_000, repeats: int = 5,
                loop_subset: int = 2000, seed: int = 7, peer_list=("rtb", "ikpy", "kinpy")) -> list[dict]:
    """End-effector pose FK: one configuration per call, and a batch of ``n_batch``."""
    import pinocchio as pin

    import manipkit

    robot = manipkit.load(robot_name)
    root, ee = robot.root_link, robot.frame("ee_link")
    cols = peer_adapters.chain_columns(robot)
    Q = robot.sample_q(n_batch, seed=seed)
    rows: list[dict] = []
    single = Q[:n_single]

    # Pinocchio, the reference: a Python loop over forwardKinematics + updateFramePlacement
    model, data, fid = robot.model, robot.model.createData(), robot.frame_id(ee)
    configs = [robot.pinocchio_configuration(q) for q in Q]

    def pin_pose(config):
        pin.forwardKinematics(model, data, config)
        return pin.updateFramePlacement(model, data, fid).homogeneous

    T_pin = np.array([pin_pose(c) for c in configs])

    # ours, batched: Robot.fk and the kernel alone, checked against Pinocchio
    T_ours = robot.fk(Q, tip=ee)
    chain = robot.chain(root, ee)
    kernel, Q_chain = chain.compiled_fk, np.ascontiguousarray(Q[:, chain.columns])  # the chain's program, chain rows
    T_kernel = kernel.transforms(Q_chain)
    err_fk, err_kernel = max_error(T_ours, T_pin), max_error(T_kernel, T_pin)
    fk_ok, kernel_ok = err_fk <= KERNEL_TOL, err_kernel <= KERNEL_TOL
    rows.append(row("fk_batch", robot_name, "manipkit Robot.fk(Q, tip=frame)", per_item(lambda: robot.fk(Q, tip=ee), n_batch, repeats=repeats)
                    if fk_ok else None, unit="config", n=n_batch, ours=True, status="ok" if fk_ok else "wrong",
                    check=f"max |T - Pinocchio| = {err_fk:.1e} over {n_batch} (<= {KERNEL_TOL:g})"))
    out = np.empty_like(T_kernel)
    rows.append(row("fk_batch", robot_name, "manipkit.kernels.fk.ChainFK (kernel alone)",
                    per_item(lambda: kernel.transforms(Q_chain, out=out), n_batch, repeats=repeats) if kernel_ok else None,
                    unit="config", n=n_batch, status="ok" if kernel_ok else "wrong",
                    check=f"max |T - Pinocchio| = {err_kernel:.1e} over {n_batch} (<= {KERNEL_TOL:g})",
                    note=f"compiled loop: {kernel.n_ops} multiplications per configuration besides cos/sin"))
    rows.append(row("fk_batch", robot_name, "Pinocchio, Python loop", per_item(lambda: [pin_pose(c) for c in configs], n_batch,
                                                                            repeats=max(1, repeats // 2)),
                    unit="config", n=n_batch, check="the reference", note="forwardKinematics + updateFramePlacement per row"))

    # ours, one configuration per call
    err = max_error([robot.transform(root, ee, q) for q in single], T_pin[:n_single])
    rows.append(row("fk_single", robot_name, "manipkit Robot.transform(base, ee, q)",
                    per_call(lambda q: robot.transform(root, ee, q), single), unit="call", n=n_single, ours=True,
                    check=f"max |T - Pinocchio| = {err:.1e} over {n_single}"))
    rows.append(row("fk_single", robot_name, "Pinocchio (forwardKinematics + updateFramePlacement)",
                    per_call(pin_pose, configs[:n_single]), unit="call", n=n_single, check="the reference"))

    with tempfile.TemporaryDirectory() as folder:
        urdf_path = peer_adapters.write_urdf(robot, Path(folder))
        for key, (adapter, reason) in _peer_rows(robot_name, urdf_path, robot, peer_list).items():
            name = peer_adapters.PEERS[key].name
            if adapter is None:
                for workload in ("fk_single", "fk_batch"):
                    rows.append(row(workload, robot_name, name, unit="call" if workload == "fk_single" else "config",
                                    status="missing", note=reason))
                continue
            version = f"{peer_adapters.PEER_PACKAGES[key]} {adapter.version}"
            # single calls: check every answer first, then time
            answers = np.array([adapter.fk(q[cols]) for q in single])
            err = max_error(answers, T_ours[:n_single])
            ok = err <= FK_TOL
            check = f"max |T - manipkit| = {err:.1e} over {n_single} (<= {FK_TOL:g})"
            rows.append(row("fk_single", robot_name, f"{name} fkine" if key == "rtb" else f"{name} forward_kinematics",
                            per_call(lambda q: adapter.fk(q[cols]), single) if ok else None, unit="call", n=n_single,
                            status="ok" if ok else "wrong", check=check, version=version))
            # batches: RTB takes the whole batch; the others loop over single calls
            if key == "rtb":
                Qc = np.ascontiguousarray(Q[:, cols])
                answers = adapter.fk_batch(Qc)
                err = max_error(answers, T_ours)
                ok = err <= FK_TOL
                rows.append(row("fk_batch", robot_name, f"{name} fkine(Q), batched",
                                per_item(lambda: adapter.fk_batch_call(Qc), n_batch, repeats=max(1, repeats // 2)) if ok else None,
                                unit="config", n=n_batch, status="ok" if ok else "wrong",
                                check=f"max |T - manipkit| = {err:.1e} over {n_batch} (<= {FK_TOL:g})", version=version,
                                note="one call with an (N, n) array; returns an SE3 of N poses"))
            else:
                subset = Q[:loop_subset]
                answers = np.array([adapter.fk(q[cols]) for q in subset])
                err = max_error(answers, T_ours[:loop_subset])
                ok = err <= FK_TOL
                rows.append(row("fk_batch", robot_name, f"{name}, Python loop",
                                per_item(lambda: [adapter.fk(q[cols]) for q in subset], loop_subset, repeats=1) if ok else None,
                                unit="config", n=loop_subset, status="ok" if ok else "wrong",
                                check=f"max |T - manipkit| = {err:.1e} over {loop_subset} (<= {FK_TOL:g})", version=version,
                                note=f"no batched call; a loop over {loop_subset} rows"))
    return rows


# --------------------------------------------------------------------------
# 2. numerical IK


def _pose_residuals(robot, q_full: np.ndarray, T_target: np.ndarray) -> tuple[float, float]:
    """Position (m) and rotation (rad) error of ee_link at ``q_full``, by Pinocchio."""
    from manipkit.spatial.rotations import rotation_angle_between  # atan2 form: 1e-10 rad is not lost in 1 - cos

    T = robot.transform(robot.root_link, "ee_link", q_full)
    position = float(np.linalg.norm(T[:3, 3] - T_target[:3, 3]))
    return position, float(rotation_angle_between(T[:3, :3], T_target[:3, :3], check=False))


def ik_workload(robot_name: str, *, n_targets: int = 1000, n_slow: int = 200, seed: int = 11,
                peer_list=("rtb", "ikpy")) -> list[dict]:
    """6D pose IK from the same random starts: success (checked by Pinocchio), median and p95 per solve.

    Targets are FK of random configurations inside the limits (so reachable);
    starts are other random configurations, the same for every solver. The
    Python solvers that take milliseconds (RTB ``ikine_LM``, ikpy) run on the
    first ``n_slow`` targets.
    """
    import manipkit
    from manipkit.ik.numerical import ik

    robot = manipkit.load(robot_name)
    root = robot.root_link
    cols = peer_adapters.chain_columns(robot)
    rng_targets, rng_starts = seed, seed + 1
    Q_true = robot.sample_q(n_targets, seed=rng_targets)
    Q_start = robot.sample_q(n_targets, seed=rng_starts)
    targets = [robot.transform(root, "ee_link", q) for q in Q_true]
    rows = []

    def solve_all(solve, count):
        """Time each solve; verify each answer with Pinocchio. (times, success at IK_ACCEPT, success at 1e-6)."""
        times, answers = np.empty(count), []
        solve(0)  # warm-up (first-call caches)
        with no_gc():
            for i in range(count):
                start = time.perf_counter()
                answers.append(solve(i))
                times[i] = time.perf_counter() - start
        residuals = []
        for i, q_chain in enumerate(answers):
            q_full = Q_start[i].copy()
            q_full[cols] = q_chain
            residuals.append(_pose_residuals(robot, q_full, targets[i]))
        worst = np.max(np.asarray(residuals), axis=1)
        return times, float(np.mean(worst <= IK_ACCEPT)), float(np.mean(worst <= 1e-6))

    def ours(i):
        return ik(robot, targets[i], q0=Q_start[i], seed=i).q[cols]

    times, success, loose = solve_all(ours, n_targets)
    rows.append(row("ik", robot_name, "manipkit ik (compiled LM, numba)", times, unit="solve", n=n_targets, ours=True,
                    success=success, success_1e6=loose,
                    check=f"answers put through Pinocchio FK: residual <= {IK_ACCEPT:g} m and rad",
                    note="tol 1e-10, up to 50 random restarts"))

    with tempfile.TemporaryDirectory() as folder:
        urdf_path = peer_adapters.write_urdf(robot, Path(folder))
        for key in peer_list:
            adapter, reason = peer_adapters.load_peer(key, robot, urdf_path)
            if adapter is None:
                names = ["Robotics Toolbox ik_LM (C++)", "Robotics Toolbox ikine_LM (Python)"] if key == "rtb" else ["ikpy"]
                rows += [row("ik", robot_name, name, unit="solve", status="missing", note=reason) for name in names]
                continue
            version = f"{peer_adapters.PEER_PACKAGES[key]} {adapter.version}"
            check = f"answers put through Pinocchio FK: residual <= {IK_ACCEPT:g} m and rad"
            if key == "rtb":
                times, success, loose = solve_all(
                    lambda i: adapter.ik_LM(targets[i], Q_start[i][cols], tol=RTB_IK_TOL), n_targets)
                rows.append(row("ik", robot_name, "Robotics Toolbox ik_LM (C++)", times, unit="solve", n=n_targets,
                                success=success, success_1e6=loose, check=check, version=version,
                                note=f"ETS prepared once; tol {RTB_IK_TOL:g} on e.e/2, 100 searches"))
                times, success, loose = solve_all(
                    lambda i: adapter.ikine_LM(targets[i], Q_start[i][cols], tol=RTB_IK_TOL, seed=i), n_slow)
                rows.append(row("ik", robot_name, "Robotics Toolbox ikine_LM (Python)", times, unit="solve", n=n_slow,
                                success=success, success_1e6=loose, check=check, version=version,
                                note=f"tol {RTB_IK_TOL:g}; first {n_slow} targets"))
            else:
                times, success, loose = solve_all(lambda i: adapter.ik(targets[i], Q_start[i][cols]), n_slow)
                rows.append(row("ik", robot_name, "ikpy inverse_kinematics_frame", times, unit="solve", n=n_slow,
                                success=success, success_1e6=loose, check=check, version=version,
                                note=f"orientation_mode='all', its default tolerance; first {n_slow} targets"))
    return rows


# --------------------------------------------------------------------------
# 3. closed-form planar IK


def planar_workload(*, n_targets: int = 1_000_000, repeats: int = 5, n_scalar: int = 2000, seed: int = 5) -> list[dict]:
    """ik_2r_batch and ik_3r_batch over ``n_targets`` reachable targets; every solution checked by FK."""
    from manipkit.closed_form import planar
    from manipkit.ik import planar as planar_ik

    rng = np.random.default_rng(seed)
    rows = []
    l1, l2, l3 = 4.0, 2.0, 1.0  # the bundled planar_3r; 2R uses l1, l2
    q = rng.uniform(-np.pi, np.pi, size=(n_targets, 3))
    xy = np.stack(planar.fk_2r(q[:, 0], q[:, 1], l1, l2), axis=-1)  # (N, 2), all reachable
    poses = np.stack(planar.fk_3r(q[:, 0], q[:, 1], q[:, 2], l1, l2, l3), axis=-1)  # (N, 3): x, y, phi

    def angle_error(a, b):
        return np.abs(np.pi - np.mod(np.pi - (a - b), 2.0 * np.pi))

    def check_2r(result, targets):
        """Largest distance from a target of the FK of its solutions (both, where there are two)."""
        sol = result.solutions  # (N, 2, 2), NaN where absent
        x, y = planar.fk_2r(sol[..., 0], sol[..., 1], l1, l2)
        err = np.maximum(np.abs(x - targets[:, None, 0]), np.abs(y - targets[:, None, 1]))
        return float(np.nanmax(err)), float(np.mean(result.count >= 1))

    def check_3r(result, targets):
        sol = result.solutions  # (N, 2, 3)
        x, y, phi = planar.fk_3r(sol[..., 0], sol[..., 1], sol[..., 2], l1, l2, l3)
        err = np.maximum(np.maximum(np.abs(x - targets[:, None, 0]), np.abs(y - targets[:, None, 1])),
                         angle_error(phi, targets[:, None, 2]))
        return float(np.nanmax(err)), float(np.mean(result.count >= 1))

    for name, solve, scalar, targets, checker in (
        ("2R", lambda: planar_ik.ik_2r_batch(xy, l1, l2), lambda i: planar_ik.ik_2r(xy[i, 0], xy[i, 1], l1, l2), xy, check_2r),
        ("3R", lambda: planar_ik.ik_3r_batch(poses, l1, l2, l3),
         lambda i: planar_ik.ik_3r(poses[i, 0], poses[i, 1], poses[i, 2], l1, l2, l3), poses, check_3r),
    ):
        err, solved = checker(solve(), targets)
        ok = err <= PLANAR_TOL and solved == 1.0
        check = f"FK of every solution: max error {err:.1e} (<= {PLANAR_TOL:g}); {solved:.0%} of targets solved"
        rows.append(row("planar", name, f"manipkit planar.ik_{name.lower()}_batch (numpy)",
                        per_item(solve, n_targets, repeats=repeats) if ok else None, unit="target", n=n_targets, ours=True,
                        status="ok" if ok else "wrong", check=check, note="both solutions of every target"))
        rows.append(row("planar", name, f"manipkit planar.ik_{name.lower()} (one target per call)",
                        per_call(scalar, list(range(n_scalar))), unit="target", n=n_scalar,
                        note="the scalar API in a Python loop, for scale"))
    return rows


# --------------------------------------------------------------------------
# 4. cold start


def _time_process(argv: list[str], env: dict) -> float:
    start = time.perf_counter()
    result = subprocess.run(argv, capture_output=True, text=True, env=env, timeout=120)
    elapsed = time.perf_counter() - start
    if result.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} exited with {result.returncode}: {result.stderr.strip()[-400:]}")
    return elapsed


def cold_start_workload(*, runs: int = 15, warm: bool = True) -> list[dict]:
    """``tf-between base_link ee_link`` as a fresh process, against bare imports; interleaved runs, median.

    ``warm``: run each command once untimed first (the file cache); a quick run skips it.
    """
    import manipkit

    # Bytecode as an installed package has it: the warm-up run writes the .pyc files (a shell that sets
    # PYTHONDONTWRITEBYTECODE would otherwise have every run compile the modules changed since the last write).
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHONPROFILE") and k != "PYTHONDONTWRITEBYTECODE"}
    tf_between = str(BIN / "tf-between")
    commands = {
        "manipkit tf-between base_link ee_link": [tf_between, "base_link", "ee_link"],
        # for information: the IK command pays numba's import and the load of the cached kernel
        "manipkit ik --robot iiwa14 (one 6D target)": [str(BIN / "manipkit"), "ik", "--robot", "iiwa14", "--xyz", "0.4",
                                                      "0.2", "0.6", "--rpy", "3.14", "0", "0"],
        'python -c "import pinocchio"': [sys.executable, "-c", "import pinocchio"],
        'python -c "import numpy"': [sys.executable, "-c", "import numpy"],
    }
    missing_rtb = peer_adapters.missing_reason("rtb")
    if not missing_rtb:
        commands['python -c "import roboticstoolbox"'] = [sys.executable, "-c", "import roboticstoolbox"]
    # the answer first: the command must print the model's transform
    result = subprocess.run([tf_between, "base_link", "ee_link", "--format", "json"], capture_output=True, text=True,
                            env=env, timeout=120)
    robot = manipkit.load("course_arm")
    expected = robot.transform("base_link", "ee_link", robot.q())
    shown = np.array(json.loads(result.stdout)["matrix"]) if result.returncode == 0 else None
    err = max_error(shown, expected) if shown is not None else math.inf
    ok = err <= 1e-9
    times = {name: [] for name in commands}
    for argv in commands.values() if warm else ():  # warm the file cache once
        _time_process(argv, env)
    for _ in range(runs):
        for name, argv in commands.items():
            times[name].append(_time_process(argv, env))
    rows = []
    for name in commands:
        ours = name.startswith("manipkit tf-between")
        rows.append(row("cold_start", "-", name, times[name] if (ok or not ours) else None,
                        unit="run", n=runs, ours=ours, status="ok" if (ok or not ours) else "wrong",
                        check=(f"prints course_arm's T_base_link_ee_link = the model's (max error {err:.1e})" if ours
                               else "exit 0 (solved)" if "ik" in name.split() else "exit 0")))
    if missing_rtb:
        rows.append(row("cold_start", "-", 'python -c "import roboticstoolbox"', unit="run", status="missing", note=missing_rtb))
    return rows


# --------------------------------------------------------------------------
# 5. viewer round trip


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _start_viewer(port: int, *options: str, timeout: float = 60.0):
    proc = subprocess.Popen([str(BIN / "manipkit"), "view", "--no-browser", "--port", str(port), *options],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines: queue.Queue = queue.Queue()
    threading.Thread(target=lambda: [lines.put(line) for line in proc.stdout], daemon=True).start()
    url, deadline = None, time.monotonic() + timeout
    while url is None:
        try:
            line = lines.get(timeout=max(deadline - time.monotonic(), 0.01))
        except queue.Empty:
            proc.kill()
            raise RuntimeError(f"manipkit view printed no URL within {timeout} s") from None
        if line.startswith("control page: "):
            url = line.split(": ", 1)[1].strip()
        if proc.poll() is not None:
            raise RuntimeError(f"manipkit view exited with {proc.returncode}: {proc.stderr.read()}")
    return proc, url


def _stop(proc) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
    "--disable-sync", "--no-first-run", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
]


def viewer_workload(*, moves: int = 60, joint: str = "bottom_wrist_joint") -> list[dict]:
    """Slider to readout: HTTP only (the server's answer), without and with ``--collisions self,floor``, and in
    headless Chromium (the page's own timer).

    Each moves ``joint`` of the course arm ``moves`` times, one move at a time,
    and checks the last readout against ``robot.transform`` (1e-9); with
    collisions, the last collision answer against ``manipkit.collisions`` (1e-9 m).
    The two HTTP views run side by side and take turns, move by move, so that
    their ratio is not the machine's load changing between them.
    """
    import manipkit

    robot = manipkit.load("course_arm")
    rows = []
    values = [round(0.02 * (i + 1), 6) for i in range(moves)]
    proc, url = _start_viewer(_free_port())
    checked = None
    try:
        checked, url_checked = _start_viewer(_free_port(), "--collisions", "self,floor")
        post, post_checked = _viewer_poster(url), _viewer_poster(url_checked)
        for send in (post, post_checked):
            for v in values[:5]:  # warm-up
                send({"q": {joint: v}})
        times, times_checked = np.empty(moves), np.empty(moves)
        clock = time.perf_counter
        with no_gc():
            for i, v in enumerate(values):
                start = clock()
                post({"q": {joint: v}})
                times[i] = clock() - start
                start = clock()
                post_checked({"q": {joint: v}})
                times_checked[i] = clock() - start
        err = _readout_error(robot, post({"q": {joint: values[-1]}})["readout"])  # tf-between's JSON keys
        ok = err <= 1e-9
        rows.append(row("viewer", "course_arm", "manipkit view: POST /api/update (HTTP, no browser)", times if ok else None,
                        unit="move", n=moves, ours=True, status="ok" if ok else "wrong",
                        check=f"readout = robot.transform (max error {err:.1e})", note="keep-alive off: a new connection per move"))
        answer = post_checked({"q": {joint: values[-1]}})
        err = _readout_error(robot, answer["readout"])
        report = manipkit.collisions(robot, robot.q(answer["readout"]["q"]), floor=0.0)
        shown = answer["collisions"]
        distance_err = abs(shown["min_distance"]["distance"] - report.min_distance.distance)
        ok = err <= 1e-9 and shown["in_collision"] == report.in_collision and distance_err <= 1e-9
        ratio = float(np.median(times_checked) / np.median(times))
        rows.append(row("viewer", "course_arm", "manipkit view --collisions self,floor: POST /api/update (HTTP, no browser)",
                        times_checked if ok else None, unit="move", n=moves, ours=True, status="ok" if ok else "wrong",
                        check=f"readout = robot.transform (max error {err:.1e}); collisions = manipkit.collisions "
                              f"(closest distance error {distance_err:.1e} m)",
                        note=f"{ratio:.2f}x the move without collisions (medians; the two views take turns)"))
        _stop(checked)
        rows += _browser_round_trip(url, robot, moves, joint)
    finally:
        _stop(proc)
        if checked is not None:
            _stop(checked)
    return rows


def _viewer_poster(url: str):
    """``post(body) -> answer`` for the viewer at ``url``, with the session's token as the page holds it."""
    import urllib.request

    with urllib.request.urlopen(url, timeout=30) as response:
        token = re.search(r'<meta name="manipkit-token" content="([^"]+)">', response.read().decode()).group(1)

    def post(body: dict) -> dict:
        request = urllib.request.Request(url + "api/update", data=json.dumps(body).encode(),
                                         headers={"Content-Type": "application/json", "X-Manipkit-Token": token})
        with urllib.request.urlopen(request, timeout=30) as response:
            return json.loads(response.read())

    return post


def _readout_error(robot, answer: dict) -> float:
    expected = robot.transform(answer["source"], answer["target"], robot.q(answer["q"]))
    return max_error(np.array(answer["matrix"]), expected)


def _browser_round_trip(url: str, robot, moves: int, joint: str) -> list[dict]:
    name = "manipkit view: slider -> readout in headless Chromium"
    if not CHROMIUM.is_file():
        return [row("viewer", "course_arm", name, unit="move", ours=True, status="missing", note=f"{CHROMIUM} is not installed")]
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        return [row("viewer", "course_arm", name, unit="move", ours=True, status="missing", note="playwright is not installed")]
    profile = tempfile.mkdtemp(prefix="bench-chromium-")
    try:
        with sync_playwright() as playwright:
            context = playwright.chromium.launch_persistent_context(profile, executable_path=str(CHROMIUM), headless=True,
                                                                   args=CHROMIUM_ARGS)
            page = context.new_page()
            page.goto(url)
            page.wait_for_function("document.querySelector('pre#readout-json').textContent.length > 0")
            for i in range(moves):
                before = page.text_content("pre#readout-json")
                page.eval_on_selector(
                    f'input[type=range][data-joint="{joint}"]',
                    """(el, value) => { el.value = String(value);
                        el.dispatchEvent(new Event('input', {bubbles: true}));
                        el.dispatchEvent(new Event('change', {bubbles: true})); }""",
                    round(-0.02 * (i + 1), 6),
                )
                page.wait_for_function("b => document.querySelector('pre#readout-json').textContent !== b", arg=before,
                                       timeout=10_000)
            timings = page.evaluate(f"window.manipkitTimings.slice(-{moves})")
            shown = json.loads(page.text_content("pre#readout-json"))
            context.close()
    finally:
        shutil.rmtree(profile, ignore_errors=True)
    expected = robot.transform(shown["source"], shown["target"], robot.q(shown["q"]))
    err = max_error(np.array(shown["matrix"]), expected)
    ok = err <= 1e-9 and len(timings) == moves
    return [row("viewer", "course_arm", name, np.asarray(timings) / 1000.0 if ok else None, unit="move", n=moves,
                ours=True, status="ok" if ok else "wrong", check=f"readout = robot.transform (max error {err:.1e})",
                note="the page's own timer: first input event to readout shown")]


# --------------------------------------------------------------------------
# 6. velocity kinematics: batched Jacobian + Yoshikawa's index, and the global conditioning index


def jacobian_workload(robot_name: str = "iiwa14", *, n_batch: int = 100_000, repeats: int = 5, loop_subset: int = 5000,
                      rtb_subset: int = 2000, seed: int = 13, peer_list=("rtb",)) -> list[dict]:
    """Jacobian of ee_link (base axes) and Yoshikawa's index (all six rows, as they are) for ``n_batch`` configurations.

    manipkit: ``jacobians(robot, Q)`` then ``manipulability(J, length=1.0)`` (one batched call each).
    Against: a Python loop over Pinocchio's ``computeFrameJacobian`` (LOCAL_WORLD_ALIGNED) + numpy's SVD
    (the product of the singular values), and Robotics Toolbox's ``jacob0`` + ``manipulability`` per row. Every
    answer is checked first: J to ``KERNEL_TOL`` against Pinocchio, the index to 1e-10 relative to the SVD
    product and 1e-10 absolute to RTB's (its ``sqrt(det(J J^T))`` loses half the digits of a small index).
    """
    import pinocchio as pin

    import manipkit
    from manipkit.analysis.manipulability import manipulability
    from manipkit.kinematics.jacobian import jacobians

    robot = manipkit.load(robot_name)
    ee = robot.frame("ee_link")
    Q = robot.sample_q(n_batch, seed=seed)
    model, data, fid = robot.model, robot.model.createData(), robot.frame_id(ee)
    configs = [robot.pinocchio_configuration(q) for q in Q[:loop_subset]]

    S = robot.velocity_map()  # Pinocchio's columns (every URDF joint) onto joint_names (mimic joints folded)

    def pin_one(config):
        J = pin.computeFrameJacobian(model, data, config, fid, pin.LOCAL_WORLD_ALIGNED) @ S
        return J, float(np.prod(np.linalg.svd(J, compute_uv=False)))

    reference = [pin_one(c) for c in configs]
    J_pin = np.array([J for J, _ in reference])
    w_pin = np.array([w for _, w in reference])

    def ours():
        return manipulability(jacobians(robot, Q, tip=ee), length=1.0)

    J_ours = jacobians(robot, Q, tip=ee)
    w_ours = ours()
    err_J = max_error(J_ours[:loop_subset], J_pin)
    err_w = float(np.max(np.abs(w_ours[:loop_subset] - w_pin) / np.maximum(np.abs(w_pin), 1e-300)))
    ok = err_J <= KERNEL_TOL and err_w <= 1e-10
    check = (f"max |J - Pinocchio| = {err_J:.1e} (<= {KERNEL_TOL:g}), max relative |w - prod(svd)| = {err_w:.1e} "
             f"(<= 1e-10) over {loop_subset}")
    rows = [row("jacobian", robot_name, "manipkit jacobians + manipulability (Yoshikawa)",
                per_item(ours, n_batch, repeats=repeats) if ok else None, unit="config", n=n_batch, ours=True,
                status="ok" if ok else "wrong", check=check)]
    rows.append(row("jacobian", robot_name, "manipkit jacobians alone",
                    per_item(lambda: jacobians(robot, Q, tip=ee), n_batch, repeats=repeats) if ok else None, unit="config",
                    n=n_batch, status="ok" if ok else "wrong", check="as above"))
    rows.append(row("jacobian", robot_name, "Pinocchio computeFrameJacobian + numpy SVD, Python loop",
                    per_item(lambda: [pin_one(c) for c in configs], loop_subset, repeats=max(1, repeats // 2)),
                    unit="config", n=loop_subset, check="the reference", note=f"a loop over {loop_subset} rows"))
    with tempfile.TemporaryDirectory() as folder:
        urdf_path = peer_adapters.write_urdf(robot, Path(folder))
        for key, (adapter, reason) in _peer_rows(robot_name, urdf_path, robot, peer_list).items():
            name = peer_adapters.PEERS[key].name
            if adapter is None:
                rows.append(row("jacobian", robot_name, f"{name} jacob0 + manipulability", unit="config",
                                status="missing", note=reason))
                continue
            cols = peer_adapters.chain_columns(robot)
            subset = Q[:rtb_subset]
            answers = [adapter.jacobian_manipulability(q[cols]) for q in subset]
            J_rtb = np.zeros((len(subset), 6, len(robot.joint_names)))
            J_rtb[:, :, cols] = np.array([J for J, _ in answers])
            w_rtb = np.array([w for _, w in answers])
            err_J = max_error(J_rtb, J_ours[:rtb_subset])
            # absolute: RTB takes sqrt(det(J J^T)), which keeps only about half the digits of a small index
            err_w = max_error(w_rtb, w_ours[:rtb_subset])
            ok = err_J <= FK_TOL and err_w <= 1e-10
            rows.append(row("jacobian", robot_name, f"{name} jacob0 + manipulability, Python loop",
                            per_item(lambda: [adapter.jacobian_manipulability(q[cols]) for q in subset], rtb_subset,
                                     repeats=1) if ok else None,
                            unit="config", n=rtb_subset, status="ok" if ok else "wrong",
                            check=f"max |J - manipkit| = {err_J:.1e} (<= {FK_TOL:g}), max |w - manipkit| = "
                                  f"{err_w:.1e} (<= 1e-10) over {rtb_subset}",
                            version=f"{peer_adapters.PEER_PACKAGES[key]} {adapter.version}",
                            note=f"a loop over {rtb_subset} rows"))
    return rows


def gci_workload(robot_name: str = "iiwa14", *, samples: int = 1_000_000, repeats: int = 1) -> list[dict]:
    """Global conditioning index from ``samples`` configurations (all rows, length 1 m), whole run timed.

    Checked: the 95% interval is narrow and holds the estimate from a second, independent seed within
    twice its half-width plus the other's (the two estimates agree as Monte Carlo says they should).
    """
    import manipkit
    from manipkit.analysis.dexterity import global_conditioning_index

    robot = manipkit.load(robot_name)
    global_conditioning_index(robot, 1000, length=1.0)  # compiles the kernels
    results = []

    def once():
        results.append(global_conditioning_index(robot, samples, length=1.0, seed=len(results)))

    times = per_item(once, 1, repeats=repeats)
    a, b = results[0], results[-1] if len(results) > 1 else global_conditioning_index(robot, samples, length=1.0, seed=99)
    half = (a.high - a.low) / 2 + (b.high - b.low) / 2
    ok = abs(a.mean - b.mean) <= 2 * half
    return [row("gci", robot_name, f"manipkit global_conditioning_index ({samples} samples)", times if ok else None,
                unit="run", n=samples, ours=True, status="ok" if ok else "wrong",
                check=f"GCI {a.mean:.4f} (95% CI {a.low:.4f} to {a.high:.4f}); another seed: {b.mean:.4f}")]


# --------------------------------------------------------------------------
# 8. closed-form IK of real 6R arms, from their geometry


ANALYTIC_CHAINS = {"ur5": ("base_link", "tool0"), "kinova": ("base", "j2s6s200_end_effector"),
                   "irb2400": ("base_link", "tool0")}
#: Descriptions the closed-form workload reads from a file (the shared ROS workspace), by name.
ANALYTIC_FILES = {"irb2400": "abb/abb_irb2400_support/urdf/irb2400.xacro"}
ANALYTIC_FK_GOAL = 1e-12  # issue 22: every returned solution's FK within this of its target (m, and rotation entries)


def _realworld() -> Path | None:
    for base in Path(__file__).resolve().parents[1:4]:
        folder = base / "shared" / "realworld" / "ws_ros1" / "src"
        if folder.is_dir():
            return folder
    return None


def _analytic_robot(robot_name: str):
    """The robot of the closed-form workload: a loadable name, or a description of the shared ROS workspace."""
    import warnings

    import manipkit

    if robot_name not in ANALYTIC_FILES:
        return manipkit.load(robot_name)
    folder = _realworld()
    if folder is None:
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return manipkit.load(str(folder / ANALYTIC_FILES[robot_name]))


def _wrapped_gap(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    return np.abs(np.pi - np.mod(np.pi - (A - B), 2 * np.pi))


def _eaik_rows(robot_name: str, urdf_path: Path, Q: np.ndarray, n_single: int, n_batch: int, rounds: int,
               timers: dict) -> list:
    """EAIK (PyPI ``eaik``) on the same URDF, when installed: one pose per call (``IK``) and its batched call
    (``IK_batched``), on the poses of its own FK of the same configurations (its end frame is the last joint's
    point, not the URDF's tip); answers checked by its own FK; else one row saying it is missing.

    Returns pending rows, ``(timer key or None, times -> row)``; the timers go into ``timers`` (run in turns with
    manipkit's by :func:`analytic_workload`)."""
    try:
        from eaik.IK_URDF import UrdfRobot
    except ImportError:
        return [(None, partial(row, "analytic", robot_name, "EAIK (eaik, one pose per call)", unit="pose",
                               status="missing", note="eaik is not installed (pip install eaik)"))]
    try:
        version = peer_adapters.version("eaik") or "?"
        bot = UrdfRobot(str(urdf_path))
        poses = [np.asarray(bot.fwdKin(q)) for q in Q[:max(n_single, n_batch)]]

        def exact(answer):
            """EAIK's rows that are solutions (``is_LS`` marks its least-squares answers, which miss)."""
            Q_all = np.atleast_2d(answer.Q)
            return Q_all[~np.asarray(answer.is_LS, dtype=bool).reshape(-1)] if len(Q_all) else Q_all

        def judged(answers, targets, configurations):
            errors = [max((float(np.max(np.abs(np.asarray(bot.fwdKin(q)) - T))) for q in exact(a)), default=0.0)
                      for a, T in zip(answers, targets)]
            found = float(np.mean([any(_wrapped_gap(s, q).max() < 1e-6 for s in exact(a))
                                   for a, q in zip(answers, configurations)]))
            per_pose = float(np.mean([len(exact(a)) for a in answers]))
            return max(errors, default=0.0), found, per_pose

        pending = []
        worst, found, per_pose = judged([bot.IK(T) for T in poses[:n_single]], poses[:n_single], Q[:n_single])
        ok = worst <= IK_ACCEPT
        if ok:
            single = poses[:n_single]
            timers["eaik single"] = lambda r: calls_timed(bot.IK, single[r::rounds])
        pending.append(("eaik single" if ok else None, partial(
            row, "analytic", robot_name, f"EAIK IK, one pose per call (eaik {version})", unit="pose",
            n=n_single, status="ok" if ok else "wrong", solutions_per_pose=per_pose, recovered=found,
            max_fk_error=worst,
            check=f"its own FK of every answer: max error {worst:.1e}; generating configuration among the answers: "
                  f"{found:.1%}",
            note="its end frame is the last joint's point, not the URDF's tip; rows marked is_LS (least squares, "
                 "not solutions) left out; not limit-aware, no labels")))
        batch = poses[:n_batch]
        worst_b, found_b, per_pose_b = judged(bot.IK_batched(batch), batch, Q[:n_batch])
        ok_b = worst_b <= IK_ACCEPT
        if ok_b:
            timers["eaik batched"] = lambda r: batch_timed(lambda: bot.IK_batched(batch), n_batch)
        pending.append(("eaik batched" if ok_b else None, partial(
            row, "analytic", robot_name, f"EAIK IK_batched (eaik {version})", unit="pose", n=n_batch,
            status="ok" if ok_b else "wrong", solutions_per_pose=per_pose_b, recovered=found_b,
            max_fk_error=worst_b,
            check=f"its own FK of every answer: max error {worst_b:.1e}; generating configuration among the "
                  f"answers: {found_b:.1%}",
            note="a list of poses in one call")))
        return pending
    except Exception as exc:  # a peer that cannot read the file is reported, not timed
        return [(None, partial(row, "analytic", robot_name, "EAIK (eaik, one pose per call)", unit="pose",
                               status="missing",
                               note=f"eaik could not solve {urdf_path.name}: {type(exc).__name__}: {exc}"))]


#: ik-geo's constructor for each of manipkit's 6R families it has (the family is chosen by hand there).
IKGEO_FAMILIES = {"three parallel, two intersecting": "three_parallel_two_intersecting",
                  "spherical wrist, two parallel": "spherical_two_parallel"}


def _ikgeo_rows(robot_name: str, chain, family, Q: np.ndarray, T: np.ndarray, n_single: int, rounds: int,
                timers: dict) -> list:
    """ik-geo (PyPI ``ik-geo``, IK-Geo's Rust solvers), when installed: one pose per call (``get_ik``), its family
    chosen as a user must choose it by hand (here from manipkit's ``chain_family``), on manipkit's ideal arm's axes
    and points (H, P in IK-Geo's product of exponentials, the tip's rotation at the reference configuration taken
    out of the target); its Python call reads R transposed, so R.T is passed. Its rows (least-squares ones left out)
    are mapped to chain vectors and checked by the chain's FK on the URDF's own base and tip. Returns pending rows
    as :func:`_eaik_rows`."""
    label = "ik-geo get_ik, one pose per call"
    try:
        import ik_geo
    except ImportError:
        return [(None, partial(row, "analytic", robot_name, f"{label} (ik-geo)", unit="pose", status="missing",
                               note="ik-geo is not installed (pip install ik-geo)"))]
    from manipkit.ik.ideal_arm import ideal_arm

    maker = IKGEO_FAMILIES.get(family.kind)
    if maker is None or family.reversed:
        return [(None, partial(row, "analytic", robot_name, f"{label} (ik-geo)", unit="pose", status="missing",
                               note=f"ik-geo has no solver for the family '{family.kind}' as this chain reads it"))]
    version = peer_adapters.version("ik-geo") or "?"
    arm, geometry = ideal_arm(family), family.geometry
    M = geometry.M
    bot = getattr(ik_geo.Robot, maker)(arm.h, np.vstack([arm.p[0], np.diff(arm.p, axis=0), M[:3, 3] - arm.p[5]]))
    inputs = [(np.ascontiguousarray((target[:3, :3] @ M[:3, :3].T).T), np.ascontiguousarray(target[:3, 3]))
              for target in T[:n_single]]
    answers = [bot.get_ik(R, t) for R, t in inputs]

    def chain_vector(theta):
        """ik-geo's angles about the reference axes -> the chain vector (``q0 + angle / scale`` on the solved
        columns, as manipkit maps its own)."""
        q = np.array(geometry.q0, dtype=float)
        q[geometry.columns] += np.asarray(theta, dtype=float) / geometry.scale
        return q

    rows = [[chain_vector(theta) for theta, least_squares in a if not least_squares] for a in answers]

    def miss(q, target):  # a row that is not finite misses by infinity (the row is then "wrong", not timed)
        return float(np.max(np.abs(chain.fk(q) - target))) if np.all(np.isfinite(q)) else math.inf

    worst = max((miss(q, T[i]) for i, r in enumerate(rows) for q in r), default=0.0)
    found = float(np.mean([any(_wrapped_gap(q, Q[i]).max() < 1e-6 for q in r) for i, r in enumerate(rows)]))
    ok = worst <= IK_ACCEPT
    if ok:
        timers["ik-geo single"] = lambda r: calls_timed(lambda x: bot.get_ik(*x), inputs[r::rounds])
    return [("ik-geo single" if ok else None, partial(
        row, "analytic", robot_name, f"{label} (ik-geo {version})", unit="pose", n=n_single,
        status="ok" if ok else "wrong", solutions_per_pose=float(np.mean([len(r) for r in rows])), recovered=found,
        max_fk_error=worst,
        check=f"the chain's FK of every answer: max error {worst:.1e}; generating configuration among the answers: "
              f"{found:.1%}",
        note=f"family chosen by hand ({maker}) on manipkit's ideal arm; rows marked least squares left out; not "
             "limit-aware, no labels"))]


def analytic_workload(robot_name: str = "ur5", *, n_single: int = 1000, n_batch: int = 10_000, repeats: int = 5,
                      seed: int = 13) -> list[dict]:
    """Every closed-form branch of a 6R arm found from its URDF: one pose per call and batched, against EAIK.

    Targets are FK of random in-limit configurations. Every returned solution of the single calls is put through
    Pinocchio's FK (``robot.transform``), every slot of the batch through the chain's compiled FK (equal to
    Pinocchio to 1e-15); the largest entry of ``T(q) - T_target`` is the row's FK error, and the generating
    configuration must be among the answers (modulo 2 pi) for every target. The batched rows are timed with their
    FK check (``success``, every slot measured).

    Every answer is checked first; then all rows, EAIK's too, are timed in turns (:func:`in_turns`): ``repeats``
    rounds, each timing a share of the single calls (every ``repeats``-th pose) and one whole batch of every row,
    so the ratios to EAIK do not depend on which row ran while another job loaded the machine.
    """
    from manipkit.ik.chain_ik import chain_ik, chain_ik_many
    from manipkit.ik.families import chain_family

    robot = _analytic_robot(robot_name)
    if robot is None:
        return [row("analytic", robot_name, f"{robot_name} description", unit="pose", status="missing",
                    note="the shared ROS workspace with this description is not here: not run")]
    base, tip = ANALYTIC_CHAINS[robot_name]
    chain = robot.chain(base, tip)
    family = chain_family(chain)
    Q = chain.sample(max(n_single, n_batch), seed=seed)
    T = chain.fk(Q)
    rounds = max(1, repeats)
    timers: dict = {}  # key -> once(round): that round's seconds per item
    pending: list = []  # (timer key or None: not timed, times -> row)

    def recovered(rows, q):
        return any(_wrapped_gap(s, q).max() < 1e-6 for s in rows)

    def pinocchio_error(q_chain, T_target):
        """Largest entry of T_base_tip (Pinocchio, through robot.transform) minus the target."""
        return float(np.max(np.abs(robot.transform(base, tip, chain.full(q_chain), check_limits=False) - T_target)))

    def single_calls(key, fn, n, ok, make):
        """A timer of ``fn(T_i)`` on every ``rounds``-th of the first ``n`` targets per round, and its pending row."""
        targets = list(T[:n])
        if ok:
            timers[key] = lambda r: calls_timed(fn, targets[r::rounds])
        pending.append((key if ok else None, make))

    def batch_timer(run):
        return lambda r: batch_timed(run, n_batch)

    for compiled, label in ((True, "manipkit chain_ik, one pose per call (compiled)"),
                            (False, "manipkit chain_ik, one pose per call (numpy reference)")):
        n = n_single if compiled else max(1, n_single // 10)
        single = [chain_ik(chain, T[i], family=family, compiled=compiled) for i in range(n)]
        worst = max((pinocchio_error(s, T[i]) for i, r in enumerate(single) for s in r.solutions), default=0.0)
        found = float(np.mean([recovered(r.solutions, Q[i]) for i, r in enumerate(single)]))
        per_pose = float(np.mean([len(r.solutions) for r in single]))
        ok = worst <= IK_ACCEPT and found == 1.0
        single_calls(label, partial(chain_ik, chain, family=family, compiled=compiled), n, ok, partial(
            row, "analytic", robot_name, label, unit="pose", n=n, ours=compiled, status="ok" if ok else "wrong",
            solutions_per_pose=per_pose, recovered=found, max_fk_error=worst,
            check=f"Pinocchio FK of every answer: max error {worst:.1e}; generating configuration among the "
                  f"answers: {found:.1%}",
            note=f"{family.kind}: every branch, limit aliases, labels, FK-checked (IKResult)"))

    from manipkit.ik.textbook import analytic_ik

    answers = [analytic_ik(robot, T[i], base, tip) for i in range(n_single)]  # whole-robot rows
    worst_a = max((float(np.max(np.abs(robot.transform(base, tip, s, check_limits=False) - T[i])))
                   for i, r in enumerate(answers) for s in r.solutions), default=0.0)
    found_a = float(np.mean([recovered(chain.rows(r.solutions), Q[i]) for i, r in enumerate(answers)]))
    per_pose_a = float(np.mean([len(r.solutions) for r in answers]))
    ok_a = worst_a <= IK_ACCEPT and found_a == 1.0
    single_calls("analytic_ik", lambda target: analytic_ik(robot, target, base, tip), n_single, ok_a, partial(
        row, "analytic", robot_name, "manipkit analytic_ik, one pose per call (the public call)", unit="pose",
        n=n_single, ours=True, status="ok" if ok_a else "wrong", solutions_per_pose=per_pose_a, recovered=found_a,
        max_fk_error=worst_a,
        check=f"Pinocchio FK of every answer: max error {worst_a:.1e}; generating configuration among the answers: "
              f"{found_a:.1%}",
        note="chain_ik behind the robot, frames and family lookup (kept per robot, frames and options after the "
             "first call: the target is checked and solved on every call)"))

    from manipkit.kernels.fk import thread_count

    def batched(compiled, threads):
        batch = chain_ik_many(chain, T[:n_batch], family=family, compiled=compiled, threads=threads)
        _ = batch.success  # the FK check of every slot, measured on first use: timed with the call
        return batch

    cores = thread_count(None)  # chain_ik_many's default: the cores this process may run on
    words = {1: "1 thread", cores: f"{cores} threads (the default: every core)" if cores > 1 else "1 thread (the default)"}
    # the default first: the issue-22 goal reads the first "batched (compiled)" row
    for compiled, threads, label in ((True, cores, f"manipkit chain_ik_many, batched (compiled), {words[cores]}"),
                                     *(((True, 1, f"manipkit chain_ik_many, batched (compiled), {words[1]}"),)
                                       if cores > 1 else ()),
                                     (False, 1, "manipkit chain_ik_many, batched (numpy reference)")):
        batch = batched(compiled, threads)
        solutions = batch.solutions
        present = ~np.isnan(solutions).any(axis=-1)
        found_batch = float(np.mean((np.nan_to_num(_wrapped_gap(solutions, Q[:n_batch, None, :]), nan=9.0)
                                     .max(axis=-1) < 1e-6).any(axis=-1)))
        filled = np.where(present[..., None], solutions, 0.0)
        errors = np.abs(chain.fk(filled) - T[:n_batch, None]).max(axis=(-2, -1))
        worst_batch = float(np.max(np.where(present, errors, 0.0)))
        ok = worst_batch <= IK_ACCEPT and found_batch == 1.0 and bool(batch.success.all())
        if ok:
            timers[label] = batch_timer(partial(batched, compiled, threads))
        pending.append((label if ok else None, partial(
            row, "analytic", robot_name, label, unit="pose", n=n_batch, ours=compiled,
            status="ok" if ok else "wrong", solutions_per_pose=float(present.sum(axis=-1).mean()),
            recovered=found_batch, max_fk_error=worst_batch, threads=threads if compiled else None,
            check=f"chain FK of every answer: max error {worst_batch:.1e}; generating configuration among the "
                  f"answers: {found_batch:.1%}",
            note="8 slots per pose, limit aliases, timed with the FK check of every slot; not refined"
                 + (f"; targets in blocks on up to {threads} thread(s), the same answers bit for bit"
                    if compiled else ""))))
    with tempfile.TemporaryDirectory() as folder:
        urdf_path = Path(folder) / f"{robot_name}.urdf"
        urdf_path.write_text(robot.urdf, encoding="utf-8")
        pending += _eaik_rows(robot_name, urdf_path, Q, n_single, n_batch, rounds, timers)
        pending += _ikgeo_rows(robot_name, chain, family, Q, T, n_single, rounds, timers)
        times = in_turns(timers, rounds)  # EAIK's robot reads its file when made: time inside the folder's life
    return [make(times.get(key)) for key, make in pending]


def srs_workload(*, n_single: int = 200, n_batch: int = 10_000, repeats: int = 5, seed: int = 17) -> list[dict]:
    """The iiwa14 (7R, spherical shoulder and wrist) at the arm angle of each generating configuration, all branches:
    one pose per call (every answer through Pinocchio's FK) and batched (every slot through the chain's compiled
    FK), each answer checked first, then the rows timed in turns (:func:`in_turns`, ``repeats`` rounds)."""
    import manipkit
    from manipkit.ik.chain_ik import chain_ik, chain_ik_many, srs_arm_angle
    from manipkit.ik.families import chain_family
    from manipkit.kernels.fk import thread_count

    robot = manipkit.load("iiwa14")
    chain = robot.chain("base_link", "ee_link")
    family = chain_family(chain)
    Q = chain.sample(max(n_single, n_batch), seed=seed)
    T = chain.fk(Q)
    psi = np.array([srs_arm_angle(chain, q, family=family) for q in Q])
    rounds = max(1, repeats)
    timers: dict = {}
    pending: list = []
    answers = [chain_ik(chain, T[i], family=family, arm_angle=psi[i]) for i in range(n_single)]
    worst = max((float(np.max(np.abs(robot.transform("base_link", "ee_link", chain.full(s), check_limits=False) - T[i])))
                 for i, r in enumerate(answers) for s in r.solutions), default=0.0)
    found = float(np.mean([any(_wrapped_gap(s, Q[i]).max() < 1e-6 for s in r.solutions) for i, r in enumerate(answers)]))
    ok = worst <= IK_ACCEPT and found == 1.0
    label = "manipkit chain_ik at an arm angle, one pose per call (compiled)"
    if ok:
        poses = list(range(n_single))
        timers[label] = lambda r: calls_timed(lambda i: chain_ik(chain, T[i], family=family, arm_angle=psi[i]),
                                              poses[r::rounds])
    pending.append((label if ok else None, partial(
        row, "analytic", "iiwa14", label, unit="pose", n=n_single, ours=True, status="ok" if ok else "wrong",
        solutions_per_pose=float(np.mean([len(r.solutions) for r in answers])), recovered=found, max_fk_error=worst,
        check=f"Pinocchio FK of every answer: max error {worst:.1e}; generating configuration among the answers: "
              f"{found:.1%}",
        note="every branch solved and checked by the chain's FK in one compiled call (closed_form.srs_kernel); "
             "targets near a threshold answered by the numpy reference")))

    def batched(threads):
        batch = chain_ik_many(chain, T[:n_batch], family=family, arm_angle=psi[:n_batch], threads=threads)
        _ = batch.success  # measured in the call: the FK check of every slot
        return batch

    cores = thread_count(None)
    for threads in dict.fromkeys((cores, 1)):
        label = (f"manipkit chain_ik_many at arm angles, batched (compiled), {threads} thread(s)"
                 + (" (the default)" if threads == cores else ""))
        batch = batched(threads)
        solutions = batch.solutions
        present = ~np.isnan(solutions).any(axis=-1)
        filled = np.where(present[..., None], solutions, 0.0)
        errors = np.abs(chain.fk(filled) - T[:n_batch, None]).max(axis=(-2, -1))
        worst_b = float(np.max(np.where(present, errors, 0.0)))
        found_b = float(np.mean((np.nan_to_num(_wrapped_gap(solutions, Q[:n_batch, None, :]), nan=9.0)
                                 .max(axis=-1) < 1e-6).any(axis=-1)))
        ok_b = worst_b <= IK_ACCEPT and found_b == 1.0 and bool(batch.success.all())
        if ok_b:
            timers[label] = lambda r, threads=threads: batch_timed(partial(batched, threads), n_batch)
        pending.append((label if ok_b else None, partial(
            row, "analytic", "iiwa14", label, unit="pose", n=n_batch, ours=True, status="ok" if ok_b else "wrong",
            solutions_per_pose=float(present.sum(axis=-1).mean()), recovered=found_b, max_fk_error=worst_b,
            threads=threads,
            check=f"chain FK of every answer: max error {worst_b:.1e}; generating configuration among the answers: "
                  f"{found_b:.1%}",
            note="each pose at its own arm angle; 8 slots per pose, limit aliases, timed with the FK check of every "
                 f"slot; targets in blocks on up to {threads} thread(s), the same answers bit for bit")))
    times = in_turns(timers, rounds)
    return [make(times.get(key)) for key, make in pending]
