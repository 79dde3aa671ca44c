"""Numerical inverse kinematics for any URDF chain (Levenberg-Marquardt, compiled, checked by Pinocchio).

Conventions (docs/architecture.md), restated:

- ``target`` is ``T_base_frame``: the wanted pose of ``frame`` expressed in
  ``base``, a 4x4 homogeneous matrix in metres, the same direction as
  ``robot.transform(base, frame, q)`` and ``tf2_echo base frame``.
- Joint vectors have one value per movable joint, in ``robot.joint_names``
  order (radians or metres). Only the joints on the chain from ``base`` down
  to ``frame`` are varied; every other joint keeps its value from ``q0`` (or
  its default: 0, or the nearest value inside its limits).
- Answers respect the joint limits; continuous joints are wrapped to
  (-pi, pi].
- Residuals are measured at the returned ``q``: ``residual_position`` is the
  distance (m) between the reached and the wanted frame origin,
  ``residual_rotation`` the angle (rad) of the rotation between the reached and
  the wanted orientation (mode ``"pose"``), or the angle between the reached
  and the wanted direction of the pointing axis (mode ``"position+axis"``), or
  0 (mode ``"position"``, no rotation equations).

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

Speed: the iteration runs as compiled code (:mod:`manipkit.kinematics.ik_kernel`, numba),
with the chain's pose and Jacobian computed there (tested equal to
Pinocchio's); Pinocchio then measures the residuals of every answer, so
``success`` never rests on the compiled code alone. The first solve in a
fresh installation compiles the kernel (a few seconds, cached on disk after).
"""

from __future__ import annotations

import html
import math
import numbers
import weakref
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from manipkit.errors import ChainError, IKOptionError, InvalidTransformError, JointValueError
from manipkit.kinematics.ik_kernel import MODE_CODES, error_and_jacobian, lm_attempt, pack_chain
from manipkit.spatial.rotations import wrap_angle
from manipkit.spatial.transforms import check_transform
from manipkit.text import short_text

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["AXES", "DISTINCT_TOL", "IKOptionError", "IKResult", "IKSolutions", "IKSolver", "MODES", "check_budget", "ik", "ik_solver"]

MODES = ("pose", "position", "position+axis")
AXES = ("x", "y", "z")
DISTINCT_TOL = 1e-6  # rad (or m): solutions closer than this are the same solution
TARGET_TOL = 1e-6  # how far a target may be from a rigid transform (check_transform's tol)
NEAR_MISS = 1e-5  # m and rad: a failed best residual below this is called close in the failure message
_LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])


@dataclass(frozen=True, eq=False)
class IKResult:
    """One IK answer.

    Attributes
    ----------
    q : ndarray, shape (n,)
        Joint vector in ``robot.joint_names`` order (read-only): the solution,
        or on failure the best configuration found. Joints off the chain keep
        their ``q0`` (or default) values; continuous joints are in (-pi, pi].
    success : bool
        Both residuals are within the tolerances.
    iterations : int
        Levenberg-Marquardt iterations (Jacobian evaluations), summed over all
        attempts up to the one that produced this answer.
    residual_position : float
        Distance (m) between the frame origin at ``q`` and the target's.
    residual_rotation : float
        Rotation angle (rad) between reached and wanted orientation (mode
        ``"pose"``); angle between reached and wanted axis (``"position+axis"``);
        0 for ``"position"``.
    reason : str or None
        None on success, else why not: ``"did not converge: best residual ..."``
        or ``"target out of reach: ..."``.
    restarts : int
        Random restarts used before this answer (0: the first start worked).
    """

    q: np.ndarray
    success: bool
    iterations: int
    residual_position: float
    residual_rotation: float
    reason: str | None
    restarts: int

    def as_solutions(self) -> IKSolutions:
        """This answer as an :class:`IKSolutions`: one solution on success, none otherwise (``best`` is this answer).

        So one presenter prints a single answer, ``all=True`` answers and
        closed-form answers alike (same properties, see :class:`IKSolutions`).
        """
        return IKSolutions((self,) if self.success else (), self, self.iterations, self.restarts + 1)

    def _repr_html_(self) -> str:
        """A one-row HTML table for Jupyter: joint values, residuals (m, rad), success, and the reason on failure."""
        label = "solution" if self.success else "best found (fails)"
        head = f"numerical IK: {self.iterations} iterations"
        return _results_html(head, [(label, self)], self.success, self.reason or "")


@dataclass(frozen=True, eq=False)
class IKSolutions:
    """The distinct solutions found with ``all=True``, a sequence of :class:`IKResult`.

    ``len(found)``, iteration and indexing go over the successful,
    pairwise distinct answers in the order found: any two differ by more
    than 1e-6 (rad or m) on some chain joint, angles compared modulo 2 pi (so
    ``q`` and ``q + 2 pi`` on a joint with wide limits count once). ``best``
    is the first solution, or, when there is none, the best failed attempt
    with its ``reason``.

    Shares ``solutions``, ``labels``, ``count``, ``reason``, ``success``,
    ``residual_position``, ``residual_rotation`` and ``residuals`` with the
    closed-form :class:`manipkit.closed_form.result.ClosedFormSolutions`, so
    one presenter prints either; :meth:`IKResult.as_solutions` turns a single
    answer into one of these.

    Attributes
    ----------
    results : tuple of IKResult
        The successful answers (what iteration and indexing go over).
    best : IKResult
    iterations : int
        Iterations summed over every attempt.
    attempts : int
        Starts tried (1 + restarts).
    """

    results: tuple[IKResult, ...]
    best: IKResult
    iterations: int
    attempts: int

    def __len__(self) -> int:
        return len(self.results)

    def __iter__(self):
        return iter(self.results)

    def __getitem__(self, index):
        return self.results[index]

    @property
    def solutions(self) -> np.ndarray:
        """(k, n) read-only: the joint vector of each answer, in ``robot.joint_names`` order."""
        Q = np.array([r.q for r in self.results], dtype=float).reshape(len(self.results), self.best.q.size)
        Q.setflags(write=False)
        return Q

    @property
    def labels(self) -> tuple[str, ...]:
        """``""`` per answer: a numerical solver does not name its branches."""
        return ("",) * len(self.results)

    @property
    def count(self) -> int:
        """Solutions found (a numerical search does not prove there are no others, nor count a continuum)."""
        return len(self.results)

    @property
    def reason(self) -> str:
        """``""`` when a solution was found, else why not (the best attempt's reason)."""
        return "" if self.results else (self.best.reason or "")

    @property
    def success(self) -> bool:
        """At least one solution."""
        return bool(self.results)

    @property
    def residual_position(self) -> np.ndarray:
        """(k,) m: distance between the reached and the wanted frame origin, per answer."""
        return np.array([r.residual_position for r in self.results], dtype=float)

    @property
    def residual_rotation(self) -> np.ndarray:
        """(k,) rad: rotation residual per answer (see :func:`ik` for what it measures in each mode)."""
        return np.array([r.residual_rotation for r in self.results], dtype=float)

    @property
    def residuals(self) -> np.ndarray:
        """(k, 2): position (m) and rotation (rad) residual of each answer."""
        return np.column_stack([self.residual_position, self.residual_rotation]).reshape(-1, 2)

    def _repr_html_(self) -> str:
        """An HTML table for Jupyter: one row per solution (or the best failed attempt), residuals, success."""
        rows = [(f"solution {i}", r) for i, r in enumerate(self.results, start=1)] or [("best found (fails)", self.best)]
        head = f"numerical IK: {len(self.results)} solution(s) from {self.attempts} start(s)"
        return _results_html(head, rows, self.success, self.reason)


def _results_html(head: str, rows, success: bool, reason: str) -> str:  # success: in the caption
    """HTML table of (label, IKResult) rows: joint values, position (m) and rotation (rad) residuals; escaped."""
    n = rows[0][1].q.size
    cells = ["label", *(f"q{i + 1}" for i in range(n)), "position (m)", "rotation (rad)", "success"]
    lines = [f"<table><caption>{html.escape(head)}; success: {success}</caption>",
             "<tr>" + "".join(f"<th>{html.escape(c)}</th>" for c in cells) + "</tr>"]
    for label, result in rows:
        values = [label, *(short_text(float(v)) for v in result.q), short_text(result.residual_position, 3),
                  short_text(result.residual_rotation, 3), str(result.success)]
        lines.append("<tr>" + "".join(f"<td>{html.escape(v)}</td>" for v in values) + "</tr>")
    lines.append("</table>")
    if reason:
        lines.append(f"<p>{html.escape(reason)}</p>")
    return "\n".join(lines)


def ik(
    robot: Robot,
    target,
    *,
    frame: str = "ee_link",
    base: str = "base_link",
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
) -> IKResult | IKSolutions:
    """Joint values that put ``frame`` at ``target`` (T_base_frame), by damped least squares.

    Parameters
    ----------
    robot : manipkit.kinematics.robot.Robot
    target : array_like, shape (4, 4)
        T_base_frame: the wanted pose of ``frame`` in ``base`` (metres). Mode
        ``"position"`` uses its translation only (and also accepts a 3-vector).
    frame, base : str, keyword-only
        Tip and base frames (aliases ``ee_link`` and ``base_link`` allowed).
        Only the movable joints between them are varied.
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
        [-pi, pi]) after the first start, if it fails. A failed solve costs
        the whole budget (about ``restarts + 1`` times 10-20 iterations).
    seed : int, keyword-only
        Seed of the random starts (same seed, same answer).
    all : bool, keyword-only
        Keep going through the whole restart budget and return every
        distinct solution found, as :class:`IKSolutions`.
    damping : float, keyword-only
        Initial Levenberg-Marquardt damping, relative to the largest diagonal
        entry of J^T J (and scaled down by the error when it is below 1); it
        then adapts (Nielsen's rule). See :class:`IKSolver`.
    free : sequence of str, keyword-only
        Floating or planar joints to solve for too (their coordinates);
        by default they stay where ``q0`` puts them (the identity).

    Returns
    -------
    IKResult
        ``success`` is True only when both residuals (measured by Pinocchio
        at the returned ``q``) are within ``tol``. Otherwise ``q`` is the best
        configuration found, with its residuals and a ``reason``.
    IKSolutions
        With ``all=True``.

    Raises
    ------
    UnknownFrameError, ChainError
        A frame the robot does not have; ``frame`` not below ``base``, or no
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
    >>> result = ik(robot, T_base_ee)
    >>> result.success, result.residual_position < 1e-10, result.reason
    (True, True, None)
    >>> bool(np.allclose(robot.transform("base_link", "ee_link", result.q), T_base_ee, atol=1e-9))
    True
    """
    # Over 80 lines: the docstring (every option and the conventions) is nearly all of it.
    solver = ik_solver(robot, frame=frame, base=base, mode=mode, axis=axis, free=tuple(free))
    return solver.solve(
        target, q0=q0, tol=tol, max_iters=max_iters, restarts=restarts, seed=seed, all=all, damping=damping
    )


_SOLVERS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def ik_solver(robot: Robot, *, frame: str = "ee_link", base: str = "base_link", mode: str = "pose", axis: str = "z",
              free: tuple[str, ...] = ()) -> IKSolver:
    """The prepared :class:`IKSolver` for a robot, frame pair and mode (built once, then cached per robot)."""
    free = tuple(sorted(set(free)))
    key = (robot.frame(frame), robot.frame(base), mode, axis, free)
    per_robot = _SOLVERS.setdefault(robot, {})
    solver = per_robot.get(key)
    if solver is None:
        solver = per_robot[key] = IKSolver(robot, frame=frame, base=base, mode=mode, axis=axis, free=free)
    return solver


class IKSolver:
    """Prepared IK for one robot, tip frame, base frame and mode; :meth:`solve` answers targets.

    Everything that does not depend on the target is computed once here: the
    chain's joint indices in the user vector, the chain packed for the
    compiled kernel, the limits as arrays,
    the reach bound, and a Pinocchio data workspace of its own for checking
    answers. A solver keeps the current target while it solves: use one per
    thread. :func:`ik_solver` builds and caches them; :func:`ik` uses that.

    Parameters
    ----------
    robot : manipkit.kinematics.robot.Robot
    frame, base, mode, axis : str, keyword-only
        As in :func:`ik`.

    Notes
    -----
    Error, expressed in the axes of the model root, with the target brought
    there as ``T_root_target = T_root_base @ T_base_target`` (constant during
    a solve: no chain joint lies above ``base``)::

        e_pos = p_target - p                (m)
        e_rot = log3(R_target @ R.T)        (rad, rotation vector in root axes)

    Its Jacobian is Pinocchio's ``LOCAL_WORLD_ALIGNED`` frame Jacobian
    (linear rows: velocity of the frame origin; angular rows: angular
    velocity; both in root axes), restricted to the chain's columns and
    computed by :func:`manipkit.kinematics.ik_kernel.chain_pose_jacobian`: at the
    solution ``de/dq = -J`` exactly (tested by finite differences). Residuals
    do not depend on the axes they are measured in, so they equal those of
    ``T_base_frame``. For ``"position+axis"`` the rotation error is
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

    STALL_WINDOW = 8
    STALL_GAIN = 0.9
    SHRINK_MIN = 0.1

    def __init__(self, robot: Robot, *, frame: str = "ee_link", base: str = "base_link", mode: str = "pose", axis: str = "z",
                 free: tuple[str, ...] = ()):
        if mode not in MODES:
            raise IKOptionError(f"unknown IK mode '{mode}'; modes: {', '.join(MODES)}")
        if axis not in AXES:
            raise IKOptionError(f"unknown pointing axis '{axis}'; axes: x, y, z")
        self.robot = robot
        self.frame = robot.frame(frame)
        self.base = robot.frame(base)
        self.mode = mode
        self.axis = axis
        self._axis_index = AXES.index(axis)
        user_index = {name: i for i, name in enumerate(robot.joint_names)}
        free = set(free)
        unknown = sorted(free - {j.joint for j in robot.joints if j.coordinate is not None})
        if unknown:
            multi = sorted({j.joint for j in robot.joints if j.coordinate is not None})
            raise IKOptionError(f"--free names a floating or planar joint to solve for; '{unknown[0]}' is not one "
                                f"(this robot's: {', '.join(multi) or 'none'})")
        # Floating and planar joints stay where q0 puts them unless freed.
        self.chain = tuple(
            name for name in robot.chain_joints(self.base, self.frame)
            if robot.joints[user_index[name]].coordinate is None or robot.joints[user_index[name]].joint in free
        )
        if not self.chain:
            raise ChainError(
                f"robot '{robot.name}': no movable joint between '{self.base}' and '{self.frame}', nothing to solve for"
            )
        model = robot.model
        self._model = model
        self._data = model.createData()
        self._frame_id = robot.frame_id(self.frame)

        joints = [robot.joints[user_index[name]] for name in self.chain]
        self._chain_user = np.array([user_index[name] for name in self.chain], dtype=np.intp)
        self._lower = np.array([j.lower for j in joints], dtype=float)
        self._upper = np.array([j.upper for j in joints], dtype=float)
        self._wrap = np.array([j.type == "continuous" for j in joints], dtype=bool)  # wrapped to (-pi, pi]
        self._has_cs = bool(self._wrap.any())
        self._angular = np.array([j.is_angular for j in joints], dtype=bool)
        self._sample_low = np.where(np.isfinite(self._lower), self._lower, -math.pi)
        self._sample_high = np.where(np.isfinite(self._upper), self._upper, math.pi)
        self._n = len(self.chain)
        self._default_q = robot.q()

        # The compiled iteration's view of the chain, root to frame (manipkit.kinematics.ik_kernel).
        steps = robot.chain(robot.root_link, self.frame).steps
        self._geometry, self._kinds = pack_chain(steps, self._chain_user)
        # A solved joint must not also move the base: the target is placed in the root once per solve.
        joint_steps = [k for k, step in enumerate(steps) if step.index >= 0]
        n_below = sum(1 for step in robot.chain(self.base, self.frame).steps if step.index >= 0)
        moves_base = [k for k in joint_steps[: len(joint_steps) - n_below] if self._kinds[k, 1] >= 0]
        if moves_base:
            name = robot.joint_names[steps[moves_base[0]].index]
            raise ChainError(
                f"robot '{robot.name}': joint '{name}' moves '{self.base}' (it lies above it) and, through a mimic "
                f"joint, the chain from '{self.base}' to '{self.frame}'; IK from this base cannot solve for it: "
                f"choose a base above '{name}'"
            )
        # Reach bound: the frame origin stays within this distance of the first solved joint's origin.
        solved = [k for k, step in enumerate(steps) if step.index >= 0 and self._kinds[k, 1] >= 0]
        reach = sum(float(np.linalg.norm(step.translation)) for step in steps[solved[0] + 1 :])
        for k in solved:
            if steps[k].prismatic:
                joint = robot.joints[steps[k].index]
                reach += abs(steps[k].scale) * max(abs(joint.lower), abs(joint.upper)) + abs(steps[k].offset)
        self.reach = reach
        self._first_joint = model.getJointId(robot.joints[steps[solved[0]].index].joint)
        not_solved = [k for k, step in enumerate(steps) if step.index >= 0 and self._kinds[k, 1] < 0]
        self._fixed_steps = np.array(not_solved, dtype=np.intp)  # joints above the base, fixed coordinates
        self._fixed_user = np.array([steps[k].index for k in not_solved], dtype=np.intp)
        self._fixed_scale = np.array([steps[k].scale for k in not_solved], dtype=float)
        self._fixed_offset = np.array([steps[k].offset for k in not_solved], dtype=float)
        self._q_fixed = np.zeros(len(steps))
        self._mode_code = MODE_CODES[mode]
        self._base_is_root = self.base == robot.root_link

    def __repr__(self) -> str:
        return (
            f"IKSolver({self.robot.name!r}, frame={self.frame!r}, base={self.base!r}, mode={self.mode!r}"
            + (f", axis={self.axis!r}" if self.mode == "position+axis" else "")
            + f", {self._n} joints: {', '.join(self.chain)})"
        )

    # ------------------------------------------------------------------

    def solve(
        self,
        target,
        *,
        q0=None,
        tol=1e-10,
        max_iters: int = 100,
        restarts: int = 50,
        seed: int = 0,
        all: bool = False,
        damping: float = 1e-1,
    ) -> IKResult | IKSolutions:
        """Solve for one target; parameters and results as in :func:`ik`."""
        tol_position, tol_rotation = _tolerances(tol)
        check_budget(max_iters, restarts, damping)
        q_full = self._start_vector(q0)
        T_base_target = self._target_matrix(target)

        # Target in root axes: T_root_target = T_root_base @ T_base_target (off-chain joints at q_full).
        if self._base_is_root:
            T_root_target = T_base_target
        else:
            T_root_target = self.robot.transform(self.robot.root_link, self.base, q_full, check_limits=False) @ T_base_target
        self._p_target = np.ascontiguousarray(T_root_target[:3, 3])
        self._R_target = np.ascontiguousarray(T_root_target[:3, :3])
        self._q_full = q_full
        if self._fixed_steps.size:
            self._q_fixed[self._fixed_steps] = self._fixed_scale * q_full[self._fixed_user] + self._fixed_offset

        attempts = int(restarts) + 1
        starts = None  # random starts, drawn on first need (a generator costs ~10 us)
        best = None  # (cost, x, pos, rot)
        found: list[IKResult] = []
        found_x: list[np.ndarray] = []
        total = 0
        for attempt in range(attempts):
            if attempt == 0 and q0 is not None:
                x0 = q_full[self._chain_user]
            else:
                if starts is None:
                    unit = np.random.default_rng(seed).random((attempts, self._n))
                    starts = self._sample_low + unit * (self._sample_high - self._sample_low)
                x0 = starts[attempt]
            x, cost, pos, rot, its = self._attempt(x0, tol_position, tol_rotation, max_iters, damping)
            total += its
            if best is None or cost < best[0]:
                best = (cost, x, pos, rot)
            if pos <= tol_position and rot <= tol_rotation:
                result = IKResult(self._full_q(q_full, x), True, total, pos, rot, None, attempt)
                if not all:
                    return result
                if not any(self._same(x, other) for other in found_x):
                    found.append(result)
                    found_x.append(x)
        if found:
            best_result = found[0]
        else:
            _, x, pos, rot = best
            reason = self._failure_reason(pos, rot, attempts)
            best_result = IKResult(self._full_q(q_full, x), False, total, pos, rot, reason, attempts - 1)
        if all:
            return IKSolutions(tuple(found), best_result, total, attempts)
        return best_result

    # ------------------------------------------------------------------

    def _attempt(self, x0, tol_position, tol_rotation, max_iters, tau):
        """One Levenberg-Marquardt run from ``x0``: (x, cost, residual_position, residual_rotation, iterations).

        The iteration runs compiled (:func:`manipkit.kinematics.ik_kernel.lm_attempt`);
        the residuals it reports are then measured again by Pinocchio at the
        answer, and those are the ones returned (success is never taken from
        the kernel's word alone).
        """
        x = np.empty(self._n)
        _, _, _, iterations = lm_attempt(
            np.ascontiguousarray(x0, dtype=float), self._q_fixed, self._geometry, self._kinds, self._R_target, self._p_target,
            self._mode_code, self._axis_index, self._lower, self._upper, self._wrap, tol_position, tol_rotation,
            max_iters, tau, self.STALL_WINDOW, self.STALL_GAIN, self.SHRINK_MIN, x,
        )
        if self._has_cs:
            x[self._wrap] = wrap_angle(x[self._wrap])
        pos, rot = self._residuals(x)
        cost = 0.5 * pos * pos + 0.5 * rot * rot
        return x, cost, pos, rot, iterations

    def _evaluate(self, x):
        """(error, Jacobian, pos, rot) at chain values ``x`` for the current target, as the kernel sees them."""
        J, e = np.zeros((6, self._n)), np.zeros(6)
        R, p = np.empty((3, 3)), np.empty(3)
        pos, rot = error_and_jacobian(
            np.asarray(x, dtype=float), self._q_fixed, self._geometry, self._kinds, self._R_target, self._p_target,
            self._mode_code, self._axis_index, R, p, J, e,
        )
        rows = 3 if self.mode == "position" else 6
        return e[:rows], J[:rows], pos, rot

    def _residuals(self, x) -> tuple[float, float]:
        """(position, rotation) residuals at chain values ``x``, measured by Pinocchio (see :func:`ik`)."""
        config = self.robot.pinocchio_configuration(self._full_q(self._q_full, x))
        pin.forwardKinematics(self._model, self._data, config)
        placement = pin.updateFramePlacement(self._model, self._data, self._frame_id)
        dp = self._p_target - placement.translation
        pos = math.sqrt(dp.dot(dp))
        if self.mode == "position":
            return pos, 0.0
        R = placement.rotation
        if self.mode == "pose":
            w = pin.log3(self._R_target.dot(R.T))
            return pos, math.sqrt(w.dot(w))
        a, t = R[:, self._axis_index], self._R_target[:, self._axis_index]
        cross = np.cross(a, t)
        return pos, math.atan2(math.sqrt(cross.dot(cross)), float(a.dot(t)))

    # ------------------------------------------------------------------

    def _project(self, x: np.ndarray) -> np.ndarray:
        x = np.minimum(np.maximum(x, self._lower), self._upper)
        if self._has_cs:
            x[self._wrap] = wrap_angle(x[self._wrap])
        return x

    def _same(self, x: np.ndarray, y: np.ndarray) -> bool:
        d = x - y
        d = np.where(self._angular, np.abs(math.pi - np.mod(math.pi - d, 2.0 * math.pi)), np.abs(d))
        return bool(np.all(d <= DISTINCT_TOL))

    def _full_q(self, q_full: np.ndarray, x: np.ndarray) -> np.ndarray:
        q = q_full.copy()
        q[self._chain_user] = x
        q.flags.writeable = False
        return q

    def _start_vector(self, q0) -> np.ndarray:
        robot = self.robot
        if q0 is None:
            return self._default_q.copy()
        q = robot.q(q0) if isinstance(q0, dict) else np.array(q0, dtype=float)
        if q.shape != self._default_q.shape:
            raise JointValueError(
                f"q0: robot '{robot.name}' needs {len(robot.joints)} joint values "
                f"({', '.join(robot.joint_names)}), got shape {q.shape}"
            )
        if not math.isfinite(float(q.sum())):
            raise JointValueError("q0: joint values must be finite numbers")
        q = robot.clamp(q)
        q[self._chain_user] = self._project(q[self._chain_user])
        return q

    def _target_matrix(self, target) -> np.ndarray:
        """``target`` as T_base_frame (4, 4), validated by :func:`manipkit.spatial.transforms.check_transform`.

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
                f"IK target must be a homogeneous transform T_base_frame of shape {shapes}, got shape {T.shape}"
            )
        T = check_transform(target if T is None else T, tol=TARGET_TOL, what="IK target")
        T[3] = _LAST_ROW
        return T

    def _failure_reason(self, pos, rot, attempts) -> str:
        residual = f"best residual {pos:.3g} m" + ("" if self.mode == "position" else f", {rot:.3g} rad")
        # Origin of the first chain joint (does not move with the chain; data still holds it).
        first = self._first_joint
        center = (self._data.oMi[self._model.parents[first]] * self._model.jointPlacements[first]).translation
        distance = float(np.linalg.norm(self._p_target - center))
        if distance > self.reach:
            joint = self.chain[0]
            return (
                f"target out of reach: it lies {distance:.4g} m from the origin of {joint}, "
                f"the chain to {self.frame} reaches at most {self.reach:.4g} m; {residual}"
            )
        if max(pos, rot) <= NEAR_MISS:
            return (f"did not converge: {residual} after {attempts} start(s); that is close: a target rounded from "
                    "printed output (or just out of reach) ends like this, and a larger tol accepts the answer")
        return f"did not converge: {residual} after {attempts} start(s) (the target may be unreachable)"


def check_budget(max_iters, restarts, damping) -> None:
    """:class:`IKOptionError` unless ``max_iters`` >= 1 and ``restarts`` >= 0 are whole numbers and ``damping`` > 0."""
    for name, value, least in (("max_iters", max_iters, 1), ("restarts", restarts, 0)):
        if not isinstance(value, numbers.Integral) or isinstance(value, bool) or value < least:
            raise IKOptionError(f"{name} must be a whole number >= {least}, got {value!r}")
    if not (isinstance(damping, numbers.Real) and math.isfinite(damping) and damping > 0.0):
        raise IKOptionError(f"damping must be a positive number, got {damping}")


def _tolerances(tol) -> tuple[float, float]:
    if type(tol) is float and tol > 0.0 and math.isfinite(tol):  # the common case, fast
        return tol, tol
    try:
        values = np.atleast_1d(np.asarray(tol, dtype=float))
    except (TypeError, ValueError):
        values = np.zeros(0)
    if values.shape not in ((1,), (2,)) or not np.all(np.isfinite(values)) or np.any(values <= 0.0):
        raise IKOptionError(f"tol must be a positive number or (position m, rotation rad), got {tol!r}")
    return float(values[0]), float(values[-1])
