"""Batched inverse kinematics: many targets in one compiled call, each confirmed by FK.

:func:`ik_many` solves ``N`` targets ``T_base_frame`` (N, 4, 4) with the
Levenberg-Marquardt attempt of :mod:`manipkit.ik.lm_kernel`
(:func:`~manipkit.ik.lm_kernel.lm_attempt`, the algorithm documented in
:class:`manipkit.ik.numerical.IKSolver`), looping over targets and their
restarts inside one numba function, so no Python runs between targets. The
function runs without the GIL, so a large batch is cut into contiguous blocks
of targets solved on a few threads at once (``threads``, default every core):
each target draws its starts from its own seed and uses nothing of another
target, so the answers are the same bit for bit on any number of threads.

Conventions (docs/architecture.md), as in :func:`manipkit.ik.numerical.ik`:

- Frames come base first: ``ik_many(robot, T, base, tip)``. ``T`` holds
  ``T_base_tip``: the wanted pose of ``tip`` in ``base`` (metres), the
  direction of ``robot.transform(base, tip, q)``.
- Joint vectors have one value per movable joint in ``robot.joint_names``
  order; only the chain from ``base`` to ``frame`` is varied, the other
  joints keep their ``q0`` (or default) values. Continuous joints come back
  in (-pi, pi].
- Starts per target: ``q0[i]`` first when given, then random restarts drawn
  uniformly inside the limits from a stream seeded per target (target ``i``
  of seed ``s`` draws the same starts whatever the batch around it).
- A time budget per target: no new restart begins once the target has used
  ``time_budget`` seconds of wall time (an attempt already running finishes:
  a few microseconds to a millisecond). With a budget, how many restarts a
  target gets depends on the machine's speed, so the answers are only as
  reproducible as the clock; without one (the default) they are exact.
- Residuals are measured at the answers by :meth:`Robot.fk
  <manipkit.kinematics.robot.Robot.fk>` (the batched FK kernel, equal to
  Pinocchio to about 1e-15) and :func:`manipkit.spatial.transforms.pose_residuals`,
  never taken from the solver's word: position (m) and, by mode, the rotation
  angle or the pointing-axis angle (rad).
- The answer is an :class:`manipkit.ik.result.IKBatch`: the fields of the one
  IK result type with a leading target axis (one slot per target).
"""

from __future__ import annotations

import math
import numbers
import threading
import time
import warnings
from typing import TYPE_CHECKING

import numpy as np
from numba import objmode  # this module is only imported to run its kernel (kinematics/__init__ does not import it)

from manipkit.bounds import tolerances
from manipkit.errors import IKOptionError, InvalidTransformError, JointValueError
from manipkit.ik.lm_kernel import SHRINK_MIN, STALL_GAIN, STALL_WINDOW, lm_attempt
from manipkit.ik.numerical import RESULT_MODES, TARGET_TOL, check_budget, ik_solver
from manipkit.ik.result import IKBatch
from manipkit.kernels.compile import lazy_kernel
from manipkit.kernels.fk import thread_count
from manipkit.kernels.program import LMOptions
from manipkit.kinematics.chain import robot_and_frames
from manipkit.spatial.rotations import wrap_angle
from manipkit.spatial.transforms import check_transform, pose_residuals

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["IKBatch", "ik_many", "target_seeds"]

RIGID_TOL = TARGET_TOL  # how far a target may be from a rigid transform (as for ik)
#: Fewest targets per thread: a batch of fewer than twice this runs on the calling thread alone, so small batches
#: pay no thread start (about 0.1 ms), and every thread gets work worth starting (64 targets: about 2 ms).
MIN_TARGETS_PER_THREAD = 64
#: Blocks handed to the threads per thread: enough that a thread whose targets are hard (many restarts) does not
#: hold up the others, few enough that a block's call costs nothing beside its solves.
BLOCKS_PER_THREAD = 8


def _now() -> float:
    return time.perf_counter()


def _solve_many(X0, has_start, seeds, Q_fixed, R_targets, p_targets, program, options, X_out, iterations_out,
                attempts_out):
    """Every target's attempts in one loop: ``lm_attempt`` from ``X0[i]``, then seeded random starts.

    ``program`` is the chain's packed IK program (:class:`manipkit.kernels.program.IKProgram`),
    ``options`` the settings (:class:`manipkit.kernels.program.LMOptions`); the
    per-target arrays come first, the outputs last.

    Keeps per target the attempt of least cost in ``X_out``; stops a target
    at the first attempt within tolerance (as the kernel measures it; FK
    decides success afterwards), after ``restarts`` restarts, or once
    ``budget`` seconds (> 0) have passed since its first attempt began.
    Compiled with ``nogil=True``: only the clock (read when there is a
    budget, through ``objmode``) takes the GIL. numba's random state is the
    thread's own, seeded here per target, so a target's starts do not
    depend on the thread that solves it. ``lm_attempt`` is compiled into
    it: its disk cache is keyed by the whole package's source
    (:func:`manipkit.kernels.sources_digest`), so a change to
    :mod:`~manipkit.ik.lm_kernel` compiles it again.
    """
    n_targets, n = X0.shape
    P, o = program, options
    budget, restarts, low, high = o.budget, o.restarts, P.sample_low, P.sample_high
    tol_position, tol_rotation = o.tol_position, o.tol_rotation
    x = np.empty(n)
    start = np.empty(n)
    t0 = 0.0
    for i in range(n_targets):
        best = math.inf
        total = 0
        used = 0
        seeded = False
        for attempt in range(restarts + 1):
            if budget > 0.0:  # one clock read per attempt, in one place (numba compiles each objmode block apart)
                with objmode(now="float64"):
                    now = _now()
                if attempt == 0:
                    t0 = now
                elif now - t0 >= budget:
                    break  # no new restart once the budget is spent
            if attempt == 0 and has_start:
                for j in range(n):
                    start[j] = X0[i, j]
            else:
                if not seeded:
                    np.random.seed(seeds[i])
                    seeded = True
                for j in range(n):
                    start[j] = low[j] + np.random.random() * (high[j] - low[j])
            cost, pos, rot, its = lm_attempt(start, Q_fixed[i], P.geometry, P.kinds, R_targets[i], p_targets[i],
                                             P.mode_code, P.axis_index, P.lower, P.upper, P.wrap, tol_position,
                                             tol_rotation, o.max_iters, o.tau, o.stall_window, o.stall_gain,
                                             o.shrink_min, x)
            total += its
            used += 1
            if cost < best:
                best = cost
                for j in range(n):
                    X_out[i, j] = x[j]
            if pos <= tol_position and rot <= tol_rotation:
                break
        iterations_out[i] = total
        attempts_out[i] = used


_kernel = lazy_kernel(_solve_many, nogil=True)
_compiled: set[bool] = set()  # the paths compiled in this process: with the clock (a budget), without
_compile_lock = threading.Lock()


def _compile_here(solve_block, with_clock: bool) -> int:
    """Compile (or load) the kernel on the calling thread before a helper thread calls it: how many targets it solved.

    numba warns, when it compiles the ``objmode`` clock of a ``nogil``
    kernel (at the clock's first run in a process), that object-mode code is
    not parallel: true of the clock read alone, which takes the GIL for about
    a microsecond per restart, and only when there is a time budget. That
    warning is silenced here, on that compilation only: an empty block
    compiles the kernel; with a budget, target 0 is solved here to compile
    the clock (the block runs at a target's first attempt, before its clock
    starts: the compilation does not eat into its budget).
    """
    with _compile_lock:
        if with_clock in _compiled:
            return 0
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="Code running in object mode won't allow parallel execution")
            done = 1 if with_clock else 0
            solve_block(0, done)
        _compiled.add(with_clock)
        return done


def target_seeds(seed: int, n: int, *, first: int = 0) -> np.ndarray:
    """(n,) uint32 seeds of targets ``first .. first + n - 1`` for seed ``seed`` (the same for a target in any batch).

    >>> bool(np.array_equal(target_seeds(3, 2, first=5), target_seeds(3, 10)[5:7]))
    True
    """
    index = np.arange(first, first + n, dtype=np.uint64)
    mixed = (index + np.uint64(1)) * np.uint64(0x9E3779B97F4A7C15) ^ np.uint64(int(seed) & 0xFFFFFFFFFFFFFFFF)
    mixed ^= mixed >> np.uint64(31)
    mixed *= np.uint64(0xBF58476D1CE4E5B9)
    mixed ^= mixed >> np.uint64(29)
    return (mixed & np.uint64(0xFFFFFFFF)).astype(np.uint32)


def ik_many(
    robot: Robot,
    T,
    base: str | None = None,
    tip: str | None = None,
    *,
    q0=None,
    mode: str = "pose",
    axis: str = "z",
    tol=1e-10,
    max_iters: int = 100,
    restarts: int = 20,
    time_budget: float | None = None,
    seed: int = 0,
    damping: float = 1e-1,
    threads: int | None = None,
) -> IKBatch:
    """Solve ``N`` IK targets in one compiled call; success by FK of every answer.

    Parameters
    ----------
    robot : manipkit.kinematics.robot.Robot
    T : array_like, shape (N, 4, 4)
        Targets ``T_base_tip`` (metres). Mode ``"position"`` also takes (N, 3).
    base, tip : str
        Base and tip frames, base first (default ``base_link`` and
        ``ee_link``), as in :func:`manipkit.ik.numerical.ik`.
    q0 : array_like, shape (n,) or (N, n), keyword-only, optional
        First start per target (one vector for all, or one row each), in
        ``robot.joint_names`` order, clamped into the limits; also the values
        of the joints off the chain. Default: a random first start, off-chain
        joints at their defaults.
    mode, axis : str, keyword-only
        As in :func:`manipkit.ik.numerical.ik`.
    tol : float or (float, float), keyword-only
        Position (m) and rotation (rad) tolerance.
    max_iters : int, keyword-only
        Iterations per attempt.
    restarts : int, keyword-only
        Random restarts per target after the first start.
    time_budget : float, keyword-only, optional
        Seconds per target after which no new restart begins (None: no limit).
    seed : int, keyword-only
        Seed of the random starts (:func:`target_seeds`: target ``i`` draws
        the same starts in any batch of the same seed).
    damping : float, keyword-only
        Initial Levenberg-Marquardt damping (see :class:`manipkit.ik.numerical.IKSolver`).
    threads : int, keyword-only, optional
        Most threads solving at once (default: the cores this process may
        run on, at most :data:`manipkit.kernels.fk.MAX_THREADS`). Fewer are used when the batch
        is small (:data:`MIN_TARGETS_PER_THREAD` targets per thread at
        least); the answers do not depend on it.

    Returns
    -------
    IKBatch
        :class:`manipkit.ik.result.IKBatch` with one slot per target:
        ``success`` (N,) by FK of every answer; ``q`` (N, n) the solution, or
        the closest configuration found where there is none, and its
        residuals ``q_residuals`` (N, 2); ``solutions`` (N, 1, n) and the
        per-slot ``residual_position``, ``residual_rotation`` (N, 1), NaN
        where there is no solution; ``count`` (N,) 1.0 or 0.0;
        ``iterations`` and ``attempts`` (N,).

    Raises
    ------
    InvalidTransformError
        ``T`` is not a stack of 4x4 homogeneous transforms (the first bad one named).
    JointValueError
        ``q0`` of the wrong shape or not finite.
    IKOptionError
        Unknown mode or axis; a non-positive tolerance, budget or damping; ``threads`` not a whole number >= 1.

    Examples
    --------
    >>> import manipkit
    >>> robot = manipkit.load("iiwa14")
    >>> T = robot.fk(robot.sample_q(50, seed=2), base="base_link", tip="ee_link")
    >>> batch = ik_many(robot, T, "base_link", "ee_link")
    >>> bool(batch.success.all()), bool(np.allclose(robot.fk(batch.q, base="base_link", tip="ee_link"), T, atol=1e-9))
    (True, True)
    """
    # Over 80 lines: the docstring (every option and the conventions) is most of it.
    robot, base, tip = robot_and_frames(robot, "ik_many", base=base, tip=tip)
    solver = ik_solver(robot, base, tip, mode=mode, axis=axis)
    tol_position, tol_rotation = tolerances(tol)
    check_budget(max_iters, restarts, damping)
    if time_budget is not None and not (isinstance(time_budget, numbers.Real) and time_budget > 0.0):
        raise IKOptionError(f"time_budget must be a positive number of seconds or None, got {time_budget!r}")
    threads = thread_count(threads)
    T_base = _targets(T, mode)
    Q_full = _start_rows(robot, q0, T_base.shape[0])
    X, iterations, attempts = _run(solver, T_base, Q_full, q0 is not None, (tol_position, tol_rotation),
                                   (int(max_iters), int(restarts), float(time_budget or 0.0), float(damping)), seed,
                                   threads)
    Q_full[:, solver.columns] = X
    pos, rot = (np.asarray(e, dtype=float) for e in
                pose_residuals(T_base, robot.fk(Q_full, base=solver.base, tip=solver.tip), mode=mode, axis=axis,
                               project=False))
    success = (pos <= tol_position) & (rot <= tol_rotation)
    solutions = np.where(success[:, None], Q_full, np.nan)[:, None, :]
    return IKBatch(
        solutions, success.astype(float), labels=("",), mode=RESULT_MODES[mode], solver="ik.numerical_many",
        joint_names=robot.joint_names, q=Q_full, success=success,
        residual_position=np.where(success, pos, np.nan)[:, None], residual_rotation=np.where(success, rot, np.nan)[:, None],
        q_residuals=np.column_stack([pos, rot]), iterations=iterations, attempts=attempts,
        limit=(tol_position, tol_rotation), method="numerical", failure_kinds=np.full(success.shape, "tolerance"),
    )


def _blocks(n_targets: int, threads: int) -> tuple[int, list[tuple[int, int]]]:
    """(threads used, contiguous target blocks [start, stop)) for a batch of ``n_targets`` on at most ``threads``.

    >>> _blocks(100, 2)
    (1, [(0, 100)])
    >>> used, blocks = _blocks(200, 2)
    >>> used, len(blocks), blocks[:2], blocks[-1]
    (2, 16, [(0, 13), (13, 26)], (195, 200))
    """
    used = max(1, min(threads, n_targets // MIN_TARGETS_PER_THREAD))
    if used == 1:
        return 1, [(0, n_targets)]
    size = max(1, -(-n_targets // (used * BLOCKS_PER_THREAD)))
    return used, [(a, min(a + size, n_targets)) for a in range(0, n_targets, size)]


def _on_threads(solve_block, first: int, n_targets: int, threads: int) -> None:
    """``solve_block(start, stop)`` over contiguous blocks covering ``first .. n_targets``, on up to ``threads`` threads.

    The calling thread works too; the others take the next block as they
    finish one. An error (or a Ctrl-C in the calling thread) stops the hand-out;
    blocks already running finish, then the error is raised here.
    """
    used, blocks = _blocks(n_targets - first, threads)
    blocks = [(first + a, first + b) for a, b in blocks]
    if used == 1:
        for a, b in blocks:
            solve_block(a, b)
        return
    lock, stop = threading.Lock(), threading.Event()
    queue = iter(blocks)
    errors: list[BaseException] = []

    def work():
        while not stop.is_set():
            with lock:
                block = next(queue, None)
            if block is None:
                return
            try:
                solve_block(*block)
            except BaseException as exc:  # raised again in the calling thread
                errors.append(exc)
                stop.set()

    helpers = [threading.Thread(target=work, name=f"manipkit-ik_many-{k}", daemon=True) for k in range(used - 1)]
    for helper in helpers:
        helper.start()
    try:
        work()
    finally:  # also on a Ctrl-C or an error here: no new block starts, the running ones finish
        stop.set()
        for helper in helpers:
            helper.join()
    if errors:
        raise errors[0]


def _run(solver, T_base: np.ndarray, Q_full: np.ndarray, has_start: bool, tol, budget, seed: int, threads: int = 1):
    """The compiled loop over every target, on up to ``threads`` threads: (X (N, n), iterations (N,), attempts (N,))."""
    n_targets = T_base.shape[0]
    Q_fixed = np.zeros((n_targets, solver.program.n_steps))
    if solver.program.fixed_steps.size:
        # joints not solved for (floating and planar coordinates not freed): scale * q + offset
        Q_fixed[:, solver.program.fixed_steps] = solver.program.fixed_scale * Q_full[:, solver.program.fixed_columns] + solver.program.fixed_offset
    X = np.empty((n_targets, solver.columns.size))
    iterations = np.zeros(n_targets, dtype=np.int64)
    attempts = np.zeros(n_targets, dtype=np.int64)
    max_iters, restarts, time_budget, damping = budget
    X0, seeds = np.ascontiguousarray(Q_full[:, solver.columns]), target_seeds(seed, n_targets)
    # the chain's program runs base to tip: the targets T_base_tip as given
    R_root, p_root = np.ascontiguousarray(T_base[:, :3, :3]), np.ascontiguousarray(T_base[:, :3, 3])
    program, kernel = solver.program, _kernel()
    options = LMOptions(float(tol[0]), float(tol[1]), int(max_iters), int(restarts), float(time_budget), float(damping),
                        STALL_WINDOW, STALL_GAIN, SHRINK_MIN)

    def solve_block(a: int, b: int) -> None:  # row slices of C-contiguous arrays: views, written in place
        kernel(X0[a:b], has_start, seeds[a:b], Q_fixed[a:b], R_root[a:b], p_root[a:b], program, options, X[a:b],
               iterations[a:b], attempts[a:b])

    if n_targets:
        done = _compile_here(solve_block, time_budget > 0.0)
        _on_threads(solve_block, done, n_targets, threads)
    if solver.program.has_cs:
        X[:, solver.program.wrap] = wrap_angle(X[:, solver.program.wrap])
    return X, iterations, attempts


def _targets(T, mode: str) -> np.ndarray:
    """``T`` as (N, 4, 4) float, each a rigid transform within :data:`RIGID_TOL` (else the first bad one named)."""
    try:
        M = np.array(T, dtype=float)
    except (TypeError, ValueError):
        raise InvalidTransformError("IK targets must be an array of 4x4 transforms T_base_tip, shape (N, 4, 4)") from None
    if mode == "position" and M.ndim == 2 and M.shape[1] == 3:
        positions, M = M, np.tile(np.eye(4), (M.shape[0], 1, 1))
        M[:, :3, 3] = positions
    if M.ndim != 3 or M.shape[1:] != (4, 4):
        shapes = "(N, 4, 4) or, for mode 'position', (N, 3)" if mode == "position" else "(N, 4, 4)"
        raise InvalidTransformError(f"IK targets must be transforms T_base_tip of shape {shapes}, got shape {M.shape}")
    if not np.all(np.isfinite(M)):
        bad = int(np.flatnonzero(~np.isfinite(M).reshape(len(M), -1).all(axis=1))[0])
        raise InvalidTransformError(f"IK target {bad}: entries must be finite numbers")
    R = M[:, :3, :3]
    off = np.abs(R @ np.swapaxes(R, 1, 2) - np.eye(3)).max(axis=(1, 2), initial=0.0)
    off = np.maximum(off, np.abs(M[:, 3] - [0.0, 0.0, 0.0, 1.0]).max(axis=1, initial=0.0))
    off = np.maximum(off, np.abs(np.linalg.det(R) - 1.0) if len(M) else off)
    for bad in np.flatnonzero(off > RIGID_TOL / 2):  # a quick pass; the few it flags get the check ik makes
        check_transform(M[bad], tol=RIGID_TOL, what=f"IK target {bad}")
    M[:, 3] = [0.0, 0.0, 0.0, 1.0]
    return M


def _start_rows(robot: Robot, q0, n_targets: int) -> np.ndarray:
    """(N, n) full joint vectors: ``q0`` (one row for all, or one per target) clamped, else the defaults."""
    default = robot.q()
    if q0 is None:
        return np.tile(default, (n_targets, 1))
    try:
        Q = np.array(q0, dtype=float)
    except (TypeError, ValueError):
        raise JointValueError("q0: joint values must be numbers") from None
    if Q.ndim == 1:
        Q = np.tile(Q, (n_targets, 1)) if Q.shape == default.shape else Q.reshape(1, -1)
    if Q.shape != (n_targets, default.size):
        raise JointValueError(
            f"q0: robot '{robot.name}' needs {default.size} joint values ({', '.join(robot.joint_names)}) "
            f"per target, as shape ({default.size},) or ({n_targets}, {default.size}); got shape {np.shape(q0)}"
        )
    if not np.all(np.isfinite(Q)):
        raise JointValueError("q0: joint values must be finite numbers")
    lower = np.array([j.lower for j in robot.joints], dtype=float)
    upper = np.array([j.upper for j in robot.joints], dtype=float)
    return np.clip(Q, lower, upper)
