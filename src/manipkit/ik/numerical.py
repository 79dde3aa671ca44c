"""Numerical inverse kinematics for any URDF chain (Levenberg-Marquardt, compiled, checked by Pinocchio).

Conventions (docs/architecture.md), restated:

- Frames come base first, as in ``tf-between SOURCE TARGET``:
  ``ik(robot, target, base, tip)``. ``target`` is ``T_base_tip``: the wanted
  pose of ``tip`` expressed in ``base``, a 4x4 homogeneous matrix in metres,
  the same direction as ``robot.transform(base, tip, q)`` and
  ``tf2_echo base tip``.
- Joint vectors have one value per movable joint, in ``robot.joint_names``
  order (radians or metres). Only the joints of ``robot.chain(base, tip)``
  are varied; every other joint keeps its value from ``q0`` (or its default:
  0, or the nearest value inside its limits).
- Answers respect the joint limits; continuous joints are wrapped to
  (-pi, pi].
- The answer is manipkit's one IK result type,
  :class:`manipkit.ik.result.IKResult`: residuals are measured at each
  returned configuration by Pinocchio's forward kinematics with
  :func:`manipkit.spatial.transforms.pose_residuals`: ``residual_position``
  is the distance (m) between the reached and the wanted frame origin,
  ``residual_rotation`` the angle (rad) of the rotation between the reached
  and the wanted orientation (mode ``"pose"``), or the angle between the
  reached and the wanted direction of the pointing axis (mode
  ``"position+axis"``), or 0 (mode ``"position"``, no rotation equations).

Modes:

- ``"pose"``: position and orientation, 6 equations.
- ``"position"``: the frame origin only, 3 equations (the target's rotation
  is ignored; a 3-vector target is accepted too).
- ``"position+axis"``: the frame origin and the direction of one of its axes
  (``axis="x" | "y" | "z"``), which must point along the same axis of the
  target: 5 equations, a pointing constraint for 5-joint arms that cannot
  reach arbitrary 6D poses (the spin about that axis is free).

Algorithm (see :class:`IKSolver`): damped least squares with Nielsen's
adaptive (Levenberg-Marquardt) damping on the error
``e = (p_target - p, log3(R_target R^T))`` expressed in the axes of the model
root (the residuals do not depend on the axes), whose matching Jacobian is
Pinocchio's ``LOCAL_WORLD_ALIGNED`` frame Jacobian; each step is projected
into the joint limits; random restarts inside the limits (reproducible from
``seed``) until a solution is found.

Speed: the iteration runs as compiled code (:mod:`manipkit.ik.lm_kernel`, numba),
with the chain's pose and Jacobian computed there (tested equal to
Pinocchio's); Pinocchio then measures the residuals of every answer, so
``success`` never rests on the compiled code alone. The first solve in a
fresh installation compiles the kernel (a few seconds, cached on disk after).

Threads: a prepared :class:`IKSolver` holds only what does not depend on the
target; everything of one call (the target, the start, the fixed joints)
lives in that call, and Pinocchio's workspace is the calling thread's own
(``robot.data``), so threads may call :func:`ik` on one robot at once.
"""

from __future__ import annotations

import math
import numbers
import weakref
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import pinocchio as pin

from manipkit.bounds import tolerances
from manipkit.errors import ChainError, IKOptionError, InvalidTransformError, JointValueError
from manipkit.ik.lm_kernel import (
    MODE_CODES,
    SHRINK_MIN,
    STALL_GAIN,
    STALL_WINDOW,
    error_and_jacobian,
    lm_attempt,
)
from manipkit.ik.result import SPATIAL_POINTING, SPATIAL_POSE, SPATIAL_POSITION, IKFailure, IKResult
from manipkit.kernels.program import IKProgram
from manipkit.kinematics.chain import robot_and_frames, sampling_bounds
from manipkit.spatial.rotations import wrap_angle
from manipkit.spatial.transforms import check_transform, pose_residuals
from manipkit.text import repr_text, short_text

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["AXES", "DISTINCT_TOL", "IKOptionError", "IKResult", "IKSolver", "MODES", "check_budget",
           "ik", "ik_solver"]

MODES = ("pose", "position", "position+axis")
AXES = ("x", "y", "z")
DISTINCT_TOL = 1e-6  # rad (or m): solutions closer than this are the same solution
TARGET_TOL = 1e-6  # how far a target may be from a rigid transform (check_transform's tol)
NEAR_MISS = 1e-5  # m and rad: a failed best residual below this is called close in the failure message
SOLVER_NAME = "ik.numerical"
#: The result's ``mode`` (:data:`manipkit.ik.result.MODES`) for each numerical mode.
RESULT_MODES = {"pose": SPATIAL_POSE, "position": SPATIAL_POSITION, "position+axis": SPATIAL_POINTING}
_LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])


def ik(
    robot: Robot,
    target,
    base: str | None = None,
    tip: str | None = None,
    *,
    mode: str = "pose",
    axis: str = "z",
    q0=None,
    tol=1e-10,
    max_iters: int = 100,
    restarts: int = 50,
    seed: int = 0,
    all: bool = False,
    damping: float = 1e-1,
    free=(),
    collision_free=False,
) -> IKResult:
    """Joint values that put ``tip`` at ``target`` (T_base_tip), by damped least squares.

    Parameters
    ----------
    robot : manipkit.kinematics.robot.Robot
    target : array_like, shape (4, 4)
        T_base_tip: the wanted pose of ``tip`` in ``base`` (metres). Mode
        ``"position"`` uses its translation only (and also accepts a 3-vector).
    base, tip : str
        Base and tip frames, base first (default ``base_link`` and
        ``ee_link``; any frame name or those aliases). Only the movable
        joints between them are varied.
    mode : {"pose", "position", "position+axis"}, keyword-only
        What must match: 6D pose; origin only; origin and the direction of
        the frame's ``axis`` (the target's same axis gives the direction).
    axis : {"x", "y", "z"}, keyword-only
        The pointing axis for ``"position+axis"``.
    q0 : array_like, shape (n,), or dict, optional
        First start (in ``robot.joint_names`` order, or joint name -> value
        with the others at their defaults), clamped into the limits; also the
        values of the joints off the chain. Default: a random first start,
        off-chain joints at their defaults.
    tol : float or (float, float), keyword-only
        Residual tolerance, metres and radians: one number for both, or
        ``(position, rotation)``.
    max_iters : int, keyword-only
        Iteration budget of one attempt (one start).
    restarts : int, keyword-only
        Random restarts (uniform inside the limits, continuous joints in
        [-pi, pi], :meth:`Chain.sample <manipkit.kinematics.chain.Chain.sample>`)
        after the first start, if it fails. A failed solve costs the whole
        budget (about ``restarts + 1`` times 10-20 iterations).
    seed : int, keyword-only
        Seed of the random starts (same seed, same answer).
    all : bool, keyword-only
        Keep going through the whole restart budget and return every
        distinct solution found (pairwise more than 1e-6 apart on some chain
        joint, angles compared modulo 2 pi), in the order found.
    damping : float, keyword-only
        Initial Levenberg-Marquardt damping, relative to the largest diagonal
        entry of J^T J (and scaled down by the error when it is below 1); it
        then adapts (Nielsen's rule). See :class:`IKSolver`.
    free : sequence of str, keyword-only
        Floating or planar joints to solve for too (their coordinates);
        by default they stay where ``q0`` puts them (the identity).
    collision_free : bool or CollisionChecker, keyword-only
        Accept only answers that are not in collision (True: the robot
        against itself, adjacent and rigidly joined links skipped; or a
        :class:`~manipkit.kinematics.collisions.CollisionChecker` with an
        SRDF, floor or world): an answer in collision does not count, and
        the search restarts. The result then has ``collides`` and
        ``clearance`` per solution; when every answer found collides,
        ``reason`` names the pair of the first.

    Returns
    -------
    IKResult
        manipkit's one IK result type (:class:`manipkit.ik.result.IKResult`).
        ``success`` is True only when both residuals, measured by Pinocchio
        at the answer, are within ``tol``; then ``q`` is the answer and
        ``solutions`` holds it (``all=True``: every distinct one found), with
        ``reason == ""``. Otherwise ``solutions`` is empty, ``q`` is the
        configuration found closest to the target (``closest``, residuals in
        ``q_residuals``) and ``reason`` says why (``"target out of reach: ..."``,
        with ``unmet`` and ``outside_by`` then, or ``"did not converge: ..."``).
        ``iterations`` and ``attempts`` count the work done.

    Raises
    ------
    UnknownFrameError, ChainError
        A frame the robot does not have; ``tip`` not below ``base``, or no
        movable joint between them.
    InvalidTransformError, InvalidRotationError
        ``target`` is not a 4x4 homogeneous transform.
    JointValueError
        A ``q0`` of the wrong size or with non-finite values.
    IKOptionError
        Unknown ``mode`` or ``axis``, or a non-positive tolerance or budget.

    Examples
    --------
    >>> import manipkit
    >>> robot = manipkit.load("iiwa14")
    >>> q_true = robot.sample_q(1, seed=1)[0]
    >>> T_base_ee = robot.transform("base_link", "ee_link", q_true)
    >>> result = ik(robot, T_base_ee, "base_link", "ee_link")
    >>> result.success, bool(result.q_residuals.max() < 1e-10), result.reason
    (True, True, '')
    >>> bool(np.allclose(robot.transform("base_link", "ee_link", result.q), T_base_ee, atol=1e-9))
    True
    """
    # Over 80 lines: the docstring (every option and the conventions) is nearly all of it.
    robot, base, tip = robot_and_frames(robot, "ik", base=base, tip=tip)
    solver = ik_solver(robot, base, tip, mode=mode, axis=axis, free=tuple(free))
    checker = None
    if collision_free is True:
        from manipkit.kinematics.collisions import CollisionChecker

        checker = CollisionChecker(robot)
    elif collision_free is not False and collision_free is not None:
        checker = collision_free
    return solver.solve(
        target, q0=q0, tol=tol, max_iters=max_iters, restarts=restarts, seed=seed, all=all, damping=damping,
        collisions=checker,
    )


_SOLVERS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def ik_solver(robot: Robot, base: str | None = None, tip: str | None = None, *, mode: str = "pose", axis: str = "z",
              free: tuple[str, ...] = ()) -> IKSolver:
    """The prepared :class:`IKSolver` for a robot, frame pair (base first) and mode: built once, cached per robot.

    The cached solver holds nothing of any call, so it is shared by every
    caller and thread. ``robot`` may also be a :class:`~manipkit.kinematics.chain.Chain`
    (its base and tip are then the frames).
    """
    robot, base, tip = robot_and_frames(robot, "ik_solver", base=base, tip=tip)
    free = tuple(sorted(set(free)))
    key = (robot.frame(tip), robot.frame(base), mode, axis, free)
    per_robot = _SOLVERS.setdefault(robot, {})
    solver = per_robot.get(key)
    if solver is None:
        solver = per_robot.setdefault(key, IKSolver(robot, base, tip, mode=mode, axis=axis, free=free))
    return solver


class _Goal(NamedTuple):
    """Everything of one solve (never stored on the shared solver): the target T_base_tip, the whole
    start vector (joints off the chain keep its values) and the values of the joints that are not solved for."""

    T_target: np.ndarray
    p_target: np.ndarray
    R_target: np.ndarray
    q_full: np.ndarray
    q_fixed: np.ndarray


class IKSolver:
    """Prepared IK for one robot, base frame, tip frame and mode; :meth:`solve` answers targets.

    Everything that does not depend on the target is computed once here from
    ``robot.chain(base, tip)``: the solved joints (the chain's, less the
    floating and planar coordinates not freed), their limits and columns,
    the chain packed for the compiled kernel and the reach bound. A solver
    keeps nothing of a call (the target and start live in the call, and
    Pinocchio's workspace is the calling thread's), so one solver serves any
    number of threads. :func:`ik_solver` builds and caches them; :func:`ik`
    uses that.

    Parameters
    ----------
    robot : manipkit.kinematics.robot.Robot
    base, tip : str
        As in :func:`ik`.
    mode, axis, free : keyword-only
        As in :func:`ik`.

    Attributes
    ----------
    chain : manipkit.kinematics.chain.Chain
        ``robot.chain(base, tip)``.
    joint_names : tuple of str
        The joints solved for, base to tip; ``columns`` their places in a
        whole-robot vector.
    reach : float
        Bound (m) on how far the tip's origin gets from the first solved joint's origin.

    Notes
    -----
    Error of ``T_base_tip`` (the chain's program, base to tip), in the
    base's axes::

        e_pos = p_target - p                (m)
        e_rot = log3(R_target @ R.T)        (rad, rotation vector in base axes)

    Its Jacobian is the chain's (:meth:`Chain.jacobian
    <manipkit.kinematics.chain.Chain.jacobian>`, reference ``"base"``: linear
    rows the velocity of the tip's origin, angular rows its angular velocity,
    both relative to the base and in its axes), restricted to the solved
    entries and computed by :func:`manipkit.ik.lm_kernel.chain_pose_jacobian`:
    at the solution ``de/dq = -J`` exactly (tested by finite differences). For ``"position+axis"`` the rotation error is
    ``angle * unit(a x t)`` (``a`` the frame's axis, ``t`` the target's) and
    its rows are ``P @ J_w`` with ``P = I - a a^T``: spin about ``a`` does
    not count, 2 of the 3 rows carry information (5 equations).

    Each iteration solves the damped normal equations
    ``(J^T J + lam I) h = J^T e`` (n x n, n chain joints) and takes
    ``q_new = clip(q + h, lower, upper)``, continuous joints wrapped to
    (-pi, pi]. Joints already at a limit that ``h`` pushes further out are
    pinned there and the step is re-solved for the others (an active set, so
    a limit does not stall the remaining joints). The step is accepted when
    the gain ratio ``rho`` (actual over predicted decrease of ``|e|^2 / 2``,
    predicted for the projected step) is positive; then
    ``lam *= max(1/10, 1 - (2 rho - 1)^3)``, else ``lam *= nu`` with ``nu``
    doubling on each rejection (Nielsen's rule, with a faster floor than
    his 1/3). ``lam`` starts at ``damping * max(diag(J^T J)) * min(1, |e|)``
    (a warm start near the target begins almost as Gauss-Newton) and never
    drops below 1e-12 of that scale (J^T J is singular for redundant arms). An attempt ends when both
    residuals are within tolerance, after ``max_iters`` iterations, when
    every joint that could move is pinned, or when the cost fell by less
    than 10 % over the last 8 iterations (a local minimum, typically against
    a limit: a random restart is cheaper than crawling).
    """


    def __init__(self, robot: Robot, base: str | None = None, tip: str | None = None, *, mode: str = "pose",
                 axis: str = "z", free: tuple[str, ...] = ()):
        base, tip = ("base_link" if base is None else base), ("ee_link" if tip is None else tip)
        if mode not in MODES:
            raise IKOptionError(f"unknown IK mode '{mode}'; modes: {', '.join(MODES)}")
        if axis not in AXES:
            raise IKOptionError(f"unknown pointing axis '{axis}'; axes: x, y, z")
        self.robot = robot
        self.tip = robot.frame(tip)
        self.base = robot.frame(base)
        self.mode = mode
        self.axis = axis
        free = set(free)
        unknown = sorted(free - {j.joint for j in robot.joints if j.coordinate is not None})
        if unknown:
            multi = sorted({j.joint for j in robot.joints if j.coordinate is not None})
            raise IKOptionError(f"--free names a floating or planar joint to solve for; '{unknown[0]}' is not one "
                                f"(this robot's: {', '.join(multi) or 'none'})")
        chain = self.chain = robot.chain(self.base, self.tip)
        # Floating and planar joints stay where q0 puts them unless freed.
        solved = np.array([j.coordinate is None or j.joint in free for j in chain.joints], dtype=bool)
        self._solved = solved
        self.joint_names = tuple(name for name, s in zip(chain.joint_names, solved) if s)
        if not self.joint_names:
            raise ChainError(
                f"robot '{robot.name}': no movable joint between '{self.base}' and '{self.tip}', nothing to solve for"
            )
        self.columns = chain.columns[solved]
        joints = [j for j, s in zip(chain.joints, solved) if s]
        lower, upper = chain.lower[solved], chain.upper[solved]
        wrap = np.array([j.type == "continuous" for j in joints], dtype=bool)  # wrapped to (-pi, pi]
        self._angular = np.array([j.is_angular for j in joints], dtype=bool)
        sample_low, sample_high = sampling_bounds(lower, upper)  # as Chain.sample draws
        self._n = len(self.joint_names)
        self._model = robot.model
        self._frame_id = robot.frame_id(self.tip)
        self._configuration = robot.joint_layout.configuration  # Pinocchio's vector of a checked joint vector
        self._robot_lower = np.array([j.lower for j in robot.joints], dtype=float)
        self._robot_upper = np.array([j.upper for j in robot.joints], dtype=float)

        # The compiled iteration runs on the chain's program (base to tip: targets are T_base_tip as given).
        steps = chain.program.steps
        geometry, kinds = chain.program.ik_tables  # one row per joint step, in order, then the tip
        solved_position = np.full(chain.n, -1, dtype=np.int64)  # chain entry -> position among the solved, or -1
        solved_position[solved] = np.arange(int(solved.sum()))
        kinds = kinds.copy()
        kinds[:-1, 1] = solved_position[kinds[:-1, 1]]
        joint_steps = [step for step in steps if step.index >= 0]  # the kernel's joint rows, in their order
        # Reach bound: the frame origin stays within this distance of the first solved joint's origin.
        first = next(k for k, step in enumerate(steps) if step.index >= 0 and solved[step.index])
        reach = sum(float(np.linalg.norm(step.translation)) for step in steps[first + 1 :])
        for step in steps[first:]:
            if step.index >= 0 and solved[step.index] and step.prismatic:
                joint = chain.joints[step.index]
                reach += abs(step.scale) * max(abs(joint.lower), abs(joint.upper)) + abs(step.offset)
        self.reach = reach
        # the first solved joint's row of chain.axes: its origin, in the base, is the centre of the reach bound
        self._first_step_row = next(k for k, step in enumerate(joint_steps) if step is steps[first])
        self._base_id = None if self.base == robot.root_link else robot.frame_id(self.base)
        not_solved = [k for k, step in enumerate(joint_steps) if not solved[step.index]]
        self.program = IKProgram(
            geometry, kinds, MODE_CODES[mode], AXES.index(axis), lower, upper, sample_low, sample_high, wrap,
            fixed_steps=np.array(not_solved, dtype=np.intp),  # floating and planar coordinates not freed
            fixed_columns=chain.columns[[joint_steps[k].index for k in not_solved]].astype(np.intp),
            fixed_scale=np.array([joint_steps[k].scale for k in not_solved], dtype=float),
            fixed_offset=np.array([joint_steps[k].offset for k in not_solved], dtype=float),
            n_steps=geometry.shape[0],
        )

    def __repr__(self) -> str:
        return (
            f"IKSolver({self.robot.name!r}, base={self.base!r}, tip={self.tip!r}, mode={self.mode!r}"
            + (f", axis={self.axis!r}" if self.mode == "position+axis" else "")
            + f", {self._n} joints: {', '.join(self.joint_names)})"
        )

    # ------------------------------------------------------------------

    def solve(self, target, *, q0=None, tol=1e-10, max_iters: int = 100, restarts: int = 50, seed: int = 0,
              all: bool = False, damping: float = 1e-1, collisions=None) -> IKResult:
        """Solve for one target; parameters and result as in :func:`ik` (``collisions``: a CollisionChecker or None)."""
        tol_position, tol_rotation = tolerances(tol)
        check_budget(max_iters, restarts, damping)
        goal = self.goal(target, q0)
        attempts = int(restarts) + 1
        starts = None  # random starts, drawn on first need (a generator costs ~10 us)
        best = None  # (cost, x, pos, rot)
        found: list[tuple[np.ndarray, float, float]] = []
        colliding, reports = [], []  # answers in collision (x, pos, rot, report); the reports of those found
        total = used = 0
        for attempt in range(attempts):
            if attempt == 0 and q0 is not None:
                x0 = goal.q_full[self.columns]
            else:
                if starts is None:
                    starts = self.chain.sample(attempts, seed=seed)[:, self._solved]
                x0 = starts[attempt]
            x, cost, pos, rot, its = self._attempt(goal, x0, tol_position, tol_rotation, max_iters, damping)
            total += its
            used = attempt + 1
            if best is None or cost < best[0]:
                best = (cost, x, pos, rot)
            if pos <= tol_position and rot <= tol_rotation:
                if any(self._same(x, other) for other, _, _ in found) or any(self._same(x, c[0]) for c in colliding):
                    continue
                if collisions is not None:
                    report = collisions.report(self._full_q(goal.q_full, x))
                    if report.in_collision:
                        colliding.append((x, pos, rot, report))
                        continue
                    reports.append(report)
                found.append((x, pos, rot))
                if not all:
                    break
        result = self._result(goal, found, best, total, used)
        if collisions is None:
            return result
        return self._with_collisions(goal, result, reports, colliding)

    def _with_collisions(self, goal: _Goal, result: IKResult, reports, colliding) -> IKResult:
        """``result`` with ``collides`` and ``clearance`` per solution; with none found but some in collision, the
        first of those as ``closest`` and a reason naming its deepest pair."""

        clearance = np.array([math.inf if r.min_distance is None else r.min_distance.distance for r in reports])
        if result.success or not colliding:
            return result.replaced(collides=(False,) * len(reports), clearance=clearance)
        x, pos, rot, report = colliding[0]
        pair = report.pairs[0]
        depth = f"penetration {short_text(-pair.distance, 3)} m" if pair.distance < 0 else "touching"
        reason = (f"every answer found is in collision ({len(colliding)} distinct); the first: {pair.link1} - "
                  f"{pair.link2} ({depth})")
        failure = IKFailure("collision", reason, pairs=tuple((p.link1, p.link2) for p in report.pairs),
                            values=(("distance", float(pair.distance)),))
        return result.replaced(note=reason, unmet=(), outside_by=0.0, side="", closest=self._full_q(goal.q_full, x),
                               closest_residuals=np.array([pos, rot]), collides=(), clearance=None, failure=failure)

    def goal(self, target, q0=None) -> _Goal:
        """The per-call state of a solve for ``target`` from ``q0`` (checked as :func:`ik` checks them)."""
        q_full = self._start_vector(q0)
        T_base_target = self._target_matrix(target)
        q_fixed = np.zeros(self.program.n_steps)
        if self.program.fixed_steps.size:
            q_fixed[self.program.fixed_steps] = self.program.fixed_scale * q_full[self.program.fixed_columns] + self.program.fixed_offset
        return _Goal(T_base_target, np.ascontiguousarray(T_base_target[:3, 3]),
                     np.ascontiguousarray(T_base_target[:3, :3]), q_full, q_fixed)

    def _result(self, goal: _Goal, found, best, iterations: int, attempts: int) -> IKResult:
        """The :class:`IKResult` of a solve: the distinct answers found, else the closest attempt and why it fails."""
        robot = self.robot
        common = dict(mode=RESULT_MODES[self.mode], solver=SOLVER_NAME, joint_names=robot.joint_names,
                      iterations=iterations, attempts=attempts, method="numerical")
        if found:
            Q = np.array([self._full_q(goal.q_full, x) for x, _, _ in found])
            position, rotation = np.array([pos for _, pos, _ in found]), np.array([rot for _, _, rot in found])
            for array in (Q, position, rotation):
                array.setflags(write=False)  # fresh arrays: read-only as they are, no copies
            return IKResult(Q, ("",) * len(found), len(found), "", position, rotation, **common)
        _, x, pos, rot = best
        reason, outside = self._failure(goal, pos, rot, attempts)
        return IKResult(
            np.zeros((0, len(robot.joint_names))), (), 0, reason, np.zeros(0), np.zeros(0),
            unmet=(("position", outside),) if outside > 0.0 else (), outside_by=outside,
            side="too far" if outside > 0.0 else "", closest=self._full_q(goal.q_full, x),
            closest_residuals=np.array([pos, rot]), **common,
        )

    # ------------------------------------------------------------------

    def _attempt(self, goal: _Goal, x0, tol_position, tol_rotation, max_iters, tau):
        """One Levenberg-Marquardt run from ``x0``: (x, cost, residual_position, residual_rotation, iterations).

        The iteration runs compiled (:func:`manipkit.ik.lm_kernel.lm_attempt`);
        the residuals it reports are then measured again by Pinocchio at the
        answer, and those are the ones returned (success is never taken from
        the kernel's word alone).
        """
        x = np.empty(self._n)
        _, _, _, iterations = lm_attempt(
            np.ascontiguousarray(x0, dtype=float), goal.q_fixed, self.program.geometry, self.program.kinds, goal.R_target,
            goal.p_target, self.program.mode_code, self.program.axis_index, self.program.lower, self.program.upper, self.program.wrap, tol_position,
            tol_rotation, max_iters, tau, STALL_WINDOW, STALL_GAIN, SHRINK_MIN, x,
        )
        if self.program.has_cs:
            x[self.program.wrap] = wrap_angle(x[self.program.wrap])
        pos, rot = self._residuals(goal, x)
        cost = 0.5 * pos * pos + 0.5 * rot * rot
        return x, cost, pos, rot, iterations

    def _evaluate(self, goal: _Goal, x):
        """(error, Jacobian, pos, rot) at chain values ``x`` for ``goal``, as the kernel sees them."""
        J, e = np.zeros((6, self._n)), np.zeros(6)
        R, p = np.empty((3, 3)), np.empty(3)
        pos, rot = error_and_jacobian(
            np.asarray(x, dtype=float), goal.q_fixed, self.program.geometry, self.program.kinds, goal.R_target, goal.p_target,
            self.program.mode_code, self.program.axis_index, R, p, J, e,
        )
        rows = 3 if self.mode == "position" else 6
        return e[:rows], J[:rows], pos, rot

    def _residuals(self, goal: _Goal, x) -> tuple[float, float]:
        """(position, rotation) residuals at chain values ``x``: Pinocchio's FK (the thread's own workspace),
        measured by :func:`manipkit.spatial.transforms.pose_residuals` (see :func:`ik`)."""
        data = self.robot.data
        pin.forwardKinematics(self._model, data, self._configuration(self._full_q(goal.q_full, x)))
        T_root_tip = pin.updateFramePlacement(self._model, data, self._frame_id)  # one or two frames, not every frame
        if self._base_id is None:  # the base is the root link: T_base_tip is T_root_tip
            T_base_tip = T_root_tip.homogeneous
        else:
            T_base_tip = pin.updateFramePlacement(self._model, data, self._base_id).actInv(T_root_tip).homogeneous
        pos, rot = pose_residuals(goal.T_target, T_base_tip, mode=self.mode, axis=self.axis, project=False)
        return float(pos), float(rot)

    # ------------------------------------------------------------------

    def _same(self, x: np.ndarray, y: np.ndarray) -> bool:
        d = x - y
        d = np.where(self._angular, np.abs(math.pi - np.mod(math.pi - d, 2.0 * math.pi)), np.abs(d))
        return bool(np.all(d <= DISTINCT_TOL))

    def _full_q(self, q_full: np.ndarray, x: np.ndarray) -> np.ndarray:
        q = q_full.copy()
        q[self.columns] = x
        return q

    def _start_vector(self, q0) -> np.ndarray:
        """The whole start vector: ``q0`` checked by ``robot.q`` (else the defaults), clamped into the limits."""
        robot = self.robot
        if q0 is None:
            return robot.q()
        try:
            q = robot.q(q0)
        except JointValueError as error:
            raise JointValueError(f"q0: {error}") from None
        q = np.minimum(np.maximum(q, self._robot_lower), self._robot_upper)  # clamped into the limits
        x = q[self.columns]
        if self.program.has_cs:
            x[self.program.wrap] = wrap_angle(x[self.program.wrap])
        q[self.columns] = x
        return q

    def _target_matrix(self, target) -> np.ndarray:
        """``target`` as T_base_tip (4, 4), validated by :func:`manipkit.spatial.transforms.check_transform`.

        Mode ``"position"`` also takes a 3-vector (the wanted origin).
        """
        try:
            T = np.array(target, dtype=float)
        except (TypeError, ValueError):
            T = None
        if T is not None and self.mode == "position" and T.shape == (3,):
            position, T = T, np.eye(4)
            T[:3, 3] = position
        if T is not None and T.shape != (4, 4):
            shapes = "(4, 4) or, for mode 'position', (3,)" if self.mode == "position" else "(4, 4)"
            raise InvalidTransformError(
                f"IK target must be a homogeneous transform T_base_tip of shape {shapes}, got shape {T.shape}"
            )
        T = check_transform(target if T is None else T, tol=TARGET_TOL, what="IK target")
        T[3] = _LAST_ROW
        return T

    def _failure(self, goal: _Goal, pos, rot, attempts) -> tuple[str, float]:
        """(why no solution, how far out of the reach bound the target is (m), 0 when not out of it)."""
        residual = f"best residual {pos:.3g} m" + ("" if self.mode == "position" else f", {rot:.3g} rad")
        # Origin of the first solved joint, in the base: the solved joints do not move it.
        center = self.chain.axes(goal.q_full[self.chain.columns]).point[self._first_step_row]
        distance = float(np.linalg.norm(goal.p_target - center))
        if distance > self.reach:
            joint = self.joint_names[0]
            return (
                f"target out of reach: it lies {distance:.4g} m from the origin of {joint}, "
                f"the chain to {self.tip} reaches at most {self.reach:.4g} m; {residual}"
            ), distance - self.reach
        if max(pos, rot) <= NEAR_MISS:
            return (f"did not converge: {residual} after {attempts} start(s); that is close: a target rounded from "
                    "printed output (or just out of reach) ends like this, and a larger tol accepts the answer"), 0.0
        return f"did not converge: {residual} after {attempts} start(s) (the target may be unreachable)", 0.0


#: Most random restarts and iterations per restart one call takes: at about 20 us an iteration, the
#: largest budget runs for minutes, not days.
MAX_RESTARTS = 100_000
MAX_ITERS = 100_000


def check_budget(max_iters, restarts, damping) -> None:
    """:class:`IKOptionError` unless ``max_iters`` (1 to :data:`MAX_ITERS`) and ``restarts`` (0 to
    :data:`MAX_RESTARTS`) are whole numbers and ``damping`` > 0."""
    for name, value, least, most in (("max_iters", max_iters, 1, MAX_ITERS), ("restarts", restarts, 0, MAX_RESTARTS)):
        if not isinstance(value, numbers.Integral) or isinstance(value, bool) or not least <= value <= most:
            raise IKOptionError(f"{name} must be a whole number from {least} to {most}, got {repr_text(value)}")
    if not (isinstance(damping, numbers.Real) and math.isfinite(damping) and damping > 0.0):
        raise IKOptionError(f"damping must be a positive number, got {damping}")
