"""Batched inverse kinematics: many targets in one compiled call, each confirmed by FK.

:func:`ik_many` solves ``N`` targets ``T_base_frame`` (N, 4, 4) with the
Levenberg-Marquardt attempt of :mod:`manipkit.kinematics.ik_kernel`
(:func:`~manipkit.kinematics.ik_kernel.lm_attempt`, the algorithm documented in
:class:`manipkit.kinematics.ik.IKSolver`), looping over targets and their
restarts inside one numba function, so no Python runs between targets.

Conventions (docs/architecture.md), as in :func:`manipkit.kinematics.ik.ik`:

- ``T`` holds ``T_base_frame``: the wanted pose of ``frame`` in ``base``
  (metres), the direction of ``robot.transform(base, frame, q)``.
- Joint vectors have one value per movable joint in ``robot.joint_names``
  order; only the chain from ``base`` to ``frame`` is varied, the other
  joints keep their ``q0`` (or default) values. Continuous joints come back
  in (-pi, pi].
- Starts per target: ``q0[i]`` first when given, then random restarts drawn
  uniformly inside the limits from a stream seeded per target (target ``i``
  of seed ``s`` draws the same starts whatever the batch around it).
- A time budget per target: no new restart begins once the target has used
  ``time_budget`` seconds (an attempt already running finishes: a few
  microseconds to a millisecond).
- Residuals are measured at the answers by :meth:`Robot.fk
  <manipkit.kinematics.robot.Robot.fk>` (the batched FK kernel, equal to
  Pinocchio to about 1e-15), never taken from the solver's word: position (m)
  and, by mode, the rotation angle or the pointing-axis angle (rad).
"""

from __future__ import annotations

import math
import numbers
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numba import objmode  # this module is only imported to run its kernel (kinematics/__init__ does not import it)

from manipkit.errors import IKOptionError, InvalidTransformError, JointValueError
from manipkit.kinematics.fk_kernel import compile_kernel
from manipkit.kinematics.ik import TARGET_TOL, _tolerances, check_budget, ik_solver
from manipkit.kinematics.ik_kernel import lm_attempt
from manipkit.spatial.rotations import rotation_angle_between, wrap_angle
from manipkit.spatial.transforms import check_transform

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["IKBatch", "ik_many", "target_seeds"]

RIGID_TOL = TARGET_TOL  # how far a target may be from a rigid transform (as for ik)


@dataclass(frozen=True, eq=False)
class IKBatch:
    """Answers of :func:`ik_many`, one row per target.

    Attributes
    ----------
    q : ndarray, shape (N, n)
        Joint vectors in ``robot.joint_names`` order: the solution, or the
        best configuration found when ``success`` is False.
    success : ndarray of bool, shape (N,)
        Both FK residuals within the tolerances.
    residual_position : ndarray, shape (N,)
        Distance (m) between the frame origin at ``q`` (by FK) and the target's.
    residual_rotation : ndarray, shape (N,)
        Angle (rad) between the reached and the wanted orientation (mode
        ``"pose"``), or pointing axis (``"position+axis"``); 0 for ``"position"``.
    iterations, attempts : ndarray of int, shape (N,)
        Levenberg-Marquardt iterations and starts used per target.
    """

    q: np.ndarray
    success: np.ndarray
    residual_position: np.ndarray
    residual_rotation: np.ndarray
    iterations: np.ndarray
    attempts: np.ndarray

    def __len__(self) -> int:
        return int(self.success.shape[0])

    @property
    def residuals(self) -> np.ndarray:
        """(N, 2): position (m) and rotation (rad) residual per target."""
        return np.column_stack([self.residual_position, self.residual_rotation])


def _now() -> float:
    return time.perf_counter()


def _solve_many(X0, has_start, seeds, Q_fixed, geometry, kinds, R_targets, p_targets, mode, axis_index, lower, upper,
                low, high, wrap, tol_position, tol_rotation, max_iters, restarts, budget, tau, stall_window, stall_gain,
                shrink_min, X_out, iterations_out, attempts_out):
    """Every target's attempts in one loop: ``lm_attempt`` from ``X0[i]``, then seeded random starts.

    Keeps per target the attempt of least cost in ``X_out``; stops a target
    at the first attempt within tolerance (as the kernel measures it; FK
    decides success afterwards), after ``restarts`` restarts, or once
    ``budget`` seconds (> 0) have passed since its first attempt began.
    """
    n_targets, n = X0.shape
    x = np.empty(n)
    start = np.empty(n)
    for i in range(n_targets):
        with objmode(t0="float64"):
            t0 = _now()
        best = math.inf
        total = 0
        used = 0
        seeded = False
        for attempt in range(restarts + 1):
            if attempt == 0 and has_start:
                for j in range(n):
                    start[j] = X0[i, j]
            else:
                if not seeded:
                    np.random.seed(seeds[i])
                    seeded = True
                for j in range(n):
                    start[j] = low[j] + np.random.random() * (high[j] - low[j])
            cost, pos, rot, its = lm_attempt(start, Q_fixed[i], geometry, kinds, R_targets[i], p_targets[i], mode,
                                             axis_index, lower, upper, wrap, tol_position, tol_rotation, max_iters,
                                             tau, stall_window, stall_gain, shrink_min, x)
            total += its
            used += 1
            if cost < best:
                best = cost
                for j in range(n):
                    X_out[i, j] = x[j]
            if pos <= tol_position and rot <= tol_rotation:
                break
            if budget > 0.0:
                with objmode(t1="float64"):
                    t1 = _now()
                if t1 - t0 >= budget:
                    break
        iterations_out[i] = total
        attempts_out[i] = used


_KERNEL = None


def _kernel():
    global _KERNEL
    if _KERNEL is None:
        _KERNEL = compile_kernel(_solve_many)
    return _KERNEL


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
    q0=None,
    *,
    frame: str = "ee_link",
    base: str = "base_link",
    mode: str = "pose",
    axis: str = "z",
    tol=1e-10,
    max_iters: int = 100,
    restarts: int = 20,
    time_budget: float | None = None,
    seed: int = 0,
    damping: float = 1e-1,
) -> IKBatch:
    """Solve ``N`` IK targets in one compiled call; success by FK of every answer.

    Parameters
    ----------
    robot : manipkit.kinematics.robot.Robot
    T : array_like, shape (N, 4, 4)
        Targets ``T_base_frame`` (metres). Mode ``"position"`` also takes (N, 3).
    q0 : array_like, shape (n,) or (N, n), optional
        First start per target (one vector for all, or one row each), in
        ``robot.joint_names`` order, clamped into the limits; also the values
        of the joints off the chain. Default: a random first start, off-chain
        joints at their defaults.
    frame, base, mode, axis : str, keyword-only
        As in :func:`manipkit.kinematics.ik.ik`.
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
        Initial Levenberg-Marquardt damping (see :class:`manipkit.kinematics.ik.IKSolver`).

    Returns
    -------
    IKBatch
        ``q`` (N, n), ``success`` (N,), FK residuals, iterations and attempts.

    Raises
    ------
    InvalidTransformError
        ``T`` is not a stack of 4x4 homogeneous transforms (the first bad one named).
    JointValueError
        ``q0`` of the wrong shape or not finite.
    IKOptionError
        Unknown mode or axis; a non-positive tolerance, budget or damping.

    Examples
    --------
    >>> import manipkit
    >>> robot = manipkit.load("iiwa14")
    >>> T = robot.fk(robot.sample_q(50, seed=2), "ee_link", "base_link")
    >>> batch = ik_many(robot, T)
    >>> bool(batch.success.all()), bool(np.allclose(robot.fk(batch.q, "ee_link", "base_link"), T, atol=1e-9))
    (True, True)
    """
    # Over 80 lines: the docstring (every option and the conventions) is most of it.
    solver = ik_solver(robot, frame=frame, base=base, mode=mode, axis=axis)
    tol_position, tol_rotation = _tolerances(tol)
    check_budget(max_iters, restarts, damping)
    if time_budget is not None and not (isinstance(time_budget, numbers.Real) and time_budget > 0.0):
        raise IKOptionError(f"time_budget must be a positive number of seconds or None, got {time_budget!r}")
    T_base = _targets(T, mode)
    n_targets = T_base.shape[0]
    Q_full = _start_rows(robot, solver, q0, n_targets)
    chain = solver._chain_user

    # Targets in the axes of the model root: T_root_target = T_root_base @ T_base_target.
    if solver._base_is_root:
        T_root = T_base
    else:
        T_root = robot.fk(Q_full, solver.base, base=robot.root_link) @ T_base
    Q_fixed = np.zeros((n_targets, solver._q_fixed.shape[0]))
    if solver._fixed_steps.size:
        # joints not solved for (above the base, mimics of them, fixed floating coordinates): scale * q + offset
        Q_fixed[:, solver._fixed_steps] = solver._fixed_scale * Q_full[:, solver._fixed_user] + solver._fixed_offset
    X = np.empty((n_targets, chain.size))
    iterations = np.zeros(n_targets, dtype=np.int64)
    attempts = np.zeros(n_targets, dtype=np.int64)
    if n_targets:
        _kernel()(
            np.ascontiguousarray(Q_full[:, chain]), q0 is not None, target_seeds(seed, n_targets), Q_fixed,
            solver._geometry, solver._kinds, np.ascontiguousarray(T_root[:, :3, :3]),
            np.ascontiguousarray(T_root[:, :3, 3]), solver._mode_code, solver._axis_index, solver._lower,
            solver._upper, solver._sample_low, solver._sample_high, solver._wrap, tol_position, tol_rotation,
            int(max_iters), int(restarts), float(time_budget or 0.0), float(damping), solver.STALL_WINDOW,
            solver.STALL_GAIN, solver.SHRINK_MIN, X, iterations, attempts,
        )
    if solver._has_cs:
        X[:, solver._wrap] = wrap_angle(X[:, solver._wrap])
    Q_full[:, chain] = X
    pos, rot = _fk_residuals(robot, solver, Q_full, T_base)
    success = (pos <= tol_position) & (rot <= tol_rotation)
    return IKBatch(Q_full, success, pos, rot, iterations, attempts)


def _fk_residuals(robot: Robot, solver, Q, T_base) -> tuple[np.ndarray, np.ndarray]:
    """Position (m) and rotation (rad) residuals of ``Q`` against ``T_base`` by the batched FK (see :func:`ik_many`)."""
    T_reached = robot.fk(Q, solver.frame, solver.base)
    pos = np.linalg.norm(T_reached[:, :3, 3] - T_base[:, :3, 3], axis=1)
    if solver.mode == "position":
        return pos, np.zeros_like(pos)
    if solver.mode == "pose":
        return pos, rotation_angle_between(T_base[:, :3, :3], T_reached[:, :3, :3], check=False)
    a, t = T_reached[:, :3, solver._axis_index], T_base[:, :3, solver._axis_index]
    return pos, np.arctan2(np.linalg.norm(np.cross(a, t), axis=1), np.einsum("ij,ij->i", a, t))


def _targets(T, mode: str) -> np.ndarray:
    """``T`` as (N, 4, 4) float, each a rigid transform within :data:`RIGID_TOL` (else the first bad one named)."""
    try:
        M = np.array(T, dtype=float)
    except (TypeError, ValueError):
        raise InvalidTransformError("IK targets must be an array of 4x4 transforms T_base_frame, shape (N, 4, 4)") from None
    if mode == "position" and M.ndim == 2 and M.shape[1] == 3:
        positions, M = M, np.tile(np.eye(4), (M.shape[0], 1, 1))
        M[:, :3, 3] = positions
    if M.ndim != 3 or M.shape[1:] != (4, 4):
        shapes = "(N, 4, 4) or, for mode 'position', (N, 3)" if mode == "position" else "(N, 4, 4)"
        raise InvalidTransformError(f"IK targets must be transforms T_base_frame of shape {shapes}, got shape {M.shape}")
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


def _start_rows(robot: Robot, solver, q0, n_targets: int) -> np.ndarray:
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
