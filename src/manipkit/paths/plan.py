"""Can a chain follow a tool path, on which IK branches, and if not, where and why: :func:`plan_path`.

Conventions (docs/architecture.md): ``poses`` are ``T_base_tip`` (N, 4, 4),
metres; joint paths ``q`` are (N, n) in the chain's joint order (rad or m);
times in seconds; velocity limits are the URDF ``<limit velocity>`` (rad/s or
m/s) times ``velocity_scale``.

The plan is a ladder (:mod:`manipkit.paths.ladder`): at every waypoint every
IK branch the one dispatcher gives (:mod:`manipkit.paths.rungs`), their
in-limit 2*pi aliases, each tool rotation about a free axis and, for a 7R SRS
arm, each sampled arm angle; an edge between consecutive waypoints is allowed
when every joint's step fits its velocity limit for the time between them;
the path of least summed joint motion is found by dynamic programming and is
optimal for that cost over those candidates (the stated resolution). The
chosen steps are then checked between the waypoints (:mod:`manipkit.paths.steps`:
on the tool path within ``path_tol``, and, with ``collisions``, free of
contact at samples ``collision_step`` apart); what fails is taken out and the
ladder solved again, until the path is clear or no path is left. The first
time a chosen step between rungs ``i`` and ``i + 1`` leaves the path, every
pair of their candidates the velocity bound lets pass is checked at once
(:func:`manipkit.paths.steps.deviating_pairs`) and the deviating ones are
forbidden: at most one deviation re-plan per rung pair. Collisions stay lazy
(only the chosen path's vertices and steps). When ``max_replans`` runs out
the plan is not feasible and says so: an ``unfinished`` failure record.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from manipkit import bounds
from manipkit.errors import OptionError
from manipkit.paths.ladder import solve_ladder
from manipkit.paths.poses import PosePath
from manipkit.paths.rungs import AXES, alias_group, build_rungs, ik_source, tool_rotations
from manipkit.paths.steps import deviating_pairs, deviating_steps, step_samples
from manipkit.text import short_text

__all__ = ["FAILURE_KINDS", "FEASIBILITY_KINDS", "BranchFailure", "PathPlan", "plan_path", "velocity_limits"]

#: Why candidates at a waypoint died: no IK branch reaches the target; a branch has no value inside a joint's
#: limits; the configuration (or every allowed step into it) is in collision; the configuration is within the
#: singularity tolerance; every step into it from a live candidate is faster than a joint's velocity limit; every
#: step into it fast enough leaves the tool path between the waypoints; ``max_replans`` ran out while the last path
#: still failed a check here (nothing is proven: a path may exist; ``count`` is the re-plans done).
ONE_DEGREE = math.pi / 180.0
TEN_DEGREES = math.pi / 18.0
FAILURE_KINDS = ("unreachable", "joint_limits", "collision", "near_singular", "velocity", "deviation", "unfinished")
#: The cells of :attr:`PathPlan.feasibility` (waypoint x tool angle), worst first; a cell is the best of its
#: candidates: no IK branch reaches the target; branches do, none inside the joint limits; every candidate is
#: near-singular; every one is (found) in collision; none is reached from the start by allowed steps (the steps
#: in leave the path or collide, or nothing before is reached); the best step in is too fast for a joint's velocity
#: limit; reached from the start by allowed steps; the tool angle the plan takes.
FEASIBILITY_KINDS = ("unreachable", "joint_limits", "near_singular", "collision", "cut_off", "velocity", "reached",
                     "chosen")


@dataclass(frozen=True)
class BranchFailure:
    """Why ``count`` candidates (IK branches, aliases and samples) at one waypoint died, as data.

    Attributes
    ----------
    kind : str
        One of :data:`FAILURE_KINDS`.
    count : int
        How many candidates (``unreachable``: target samples with no branch) died this way; ``unfinished``: the
        re-plans done before ``max_replans`` ran out.
    joint : str
        ``joint_limits``: the joint most often outside its limits; ``velocity``: the joint of the best step's
        largest ratio; ``near_singular``: the joint with the largest share of the least singular direction.
    ratio : float
        ``velocity``: the smallest, over live predecessors, of the step's largest ``|dq_j| / (v_j dt)``
        (above 1); ``near_singular``: the smallest singular value found; else 0.
    pairs : tuple of (str, str)
        ``collision``: link pairs found in contact.
    """

    kind: str
    count: int
    joint: str = ""
    ratio: float = 0.0
    pairs: tuple[tuple[str, str], ...] = ()

    def as_dict(self) -> dict:
        """JSON-safe: every field (pairs as lists)."""
        return {"kind": self.kind, "count": self.count, "joint": self.joint or None, "ratio": float(self.ratio),
                "pairs": [list(p) for p in self.pairs]}


@dataclass(frozen=True)
class PathPlan:
    """The answer of :func:`plan_path`: the joint path, or where and why there is none.

    Attributes
    ----------
    feasible : bool
        A joint path follows every waypoint (with ``reconfigure``: possibly with breaks).
    q : ndarray, shape (N, n), or None
        The joint path in ``joint_names`` order (rad or m); None when infeasible.
    joint_names : tuple of str
        The chain's joints.
    t : ndarray, shape (N,), or None
        Time at each waypoint (s): the given ``t``, or from ``speed``; None when neither was given.
    failures : tuple of tuple of BranchFailure
        Per waypoint, why candidates died there (empty where none did). Past ``first_failure`` only the reasons
        found at the waypoint itself are listed (unreachable, joint limits, near-singular): no path reaches it
        to die of a step.
    first_failure : int or None
        The first waypoint where every candidate is dead (None when feasible, or when ``max_replans`` ran out
        before a path cleared its checks: ``resolution["unfinished"]``, nothing proven).
    reconfigurations : tuple of int
        With ``reconfigure``: the waypoints where the arm resumes after a break (retract, reconfigure, resume).
    cost : float or None
        The path's cost: summed ``w_j |dq_j|`` over its steps (rad or m), plus penalties; None when infeasible.
    max_velocity_ratio : float or None
        Largest ``|dq_j| / (velocity_scale v_j dt)`` over the path's steps (<= 1 on a plan); None without timing.
    tool_angles : ndarray, shape (N,), or None
        With a free axis: the chosen rotation of the tool about it at each waypoint (rad).
    arm_angles : ndarray, shape (N,), or None
        For a 7R SRS arm: the arm angle sample of each waypoint's solution (rad).
    targets : ndarray, shape (N, 4, 4), or None
        The pose the tip reaches at each waypoint (the path pose turned about the free axis).
    resolution : dict
        What was searched: ``waypoints``, ``samples`` per waypoint, ``tool_angles``, ``arm_angles``,
        ``aliases``, ``candidates``, ``edges`` (evaluated, none stored), ``method`` (in words), ``cost`` (in
        words), ``path_tol`` (m, rad), ``depth``, ``collision_step`` (rad or m, or None), ``ik_calls``.
    collision_checks : int
        Configurations put through the collision checker (vertices and step samples, over every re-plan).
    deviation_points : int
        Joint-interpolated points checked against the tool path.
    replans : int
        How many times the ladder was solved again after taking out what failed a check.
    feasibility : ndarray of int8, shape (N, A), or None
        Per waypoint and tool angle (``free_angles``; one column without a free axis), the index in
        :data:`FEASIBILITY_KINDS` of the best its candidates (over every branch, alias and arm angle) reach,
        as the last ladder solved saw them: the data of the feasibility map.
    free_angles : ndarray, shape (A,), or None
        The sampled tool angles about the free axis (rad); ``[0.0]`` without one.
    """

    feasible: bool
    q: np.ndarray | None
    joint_names: tuple[str, ...]
    t: np.ndarray | None
    failures: tuple[tuple[BranchFailure, ...], ...]
    first_failure: int | None
    reconfigurations: tuple[int, ...]
    cost: float | None
    max_velocity_ratio: float | None
    tool_angles: np.ndarray | None = None
    arm_angles: np.ndarray | None = None
    targets: np.ndarray | None = field(default=None, repr=False)
    resolution: dict = field(default_factory=dict)
    collision_checks: int = 0
    deviation_points: int = 0
    replans: int = 0
    feasibility: np.ndarray | None = field(default=None, repr=False)
    free_angles: np.ndarray | None = field(default=None, repr=False)

    def as_dict(self) -> dict:
        """The JSON contract of ``manipkit path --format json`` (the keys the issue names, in order)."""
        return {
            "feasible": self.feasible,
            "joint_names": list(self.joint_names),
            "q": None if self.q is None else self.q.tolist(),
            "t": None if self.t is None else self.t.tolist(),
            "failures": [[f.as_dict() for f in waypoint] for waypoint in self.failures],
            "first_failure": self.first_failure,
            "reconfigurations": list(self.reconfigurations),
            "cost": self.cost,
            "max_velocity_ratio": self.max_velocity_ratio,
        }


def velocity_limits(chain) -> np.ndarray:
    """Each chain joint's URDF velocity limit (rad/s or m/s), inf where the description gives none (0 or missing)."""
    model = chain.robot.model
    out = []
    for joint in chain.joints:
        limit = float(model.velocityLimit[model.joints[model.getJointId(joint.name)].idx_v])
        out.append(limit if math.isfinite(limit) and limit > 0 else math.inf)
    return np.array(out)


def _step_times(T: np.ndarray, t, speed, angular_speed) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(times (N,), dt (N - 1,)), from ``t`` or from the tool's speeds; (None, None) without timing."""
    N = len(T)
    if t is not None:
        if speed is not None or angular_speed is not None:
            raise OptionError("give the times t or a speed, not both")
        times = np.array(PosePath(T, t).t)  # checked there: one time per waypoint, finite, increasing
        return times, np.diff(times)
    if speed is None and angular_speed is None:
        return None, None
    dt = np.zeros(N - 1)
    if speed is not None:
        speed = bounds.speed(speed, "speed")
        dt = np.maximum(dt, np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1) / speed)
    if angular_speed is not None:
        angular_speed = bounds.speed(angular_speed, "angular_speed", unit="rad/s")
        from manipkit.spatial.rotations import rotation_angle_between

        turn = rotation_angle_between(T[:-1, :3, :3], T[1:, :3, :3], check=False) if N > 1 else np.zeros(0)
        dt = np.maximum(dt, np.asarray(turn) / angular_speed)
    return np.concatenate([[0.0], np.cumsum(dt)]), dt


def _free_angles(free_axis, free_step, free_range) -> np.ndarray:
    if free_axis is None:
        if free_step is not None or free_range is not None:
            raise OptionError("free_step and free_range need free_axis ('x', 'y' or 'z')")
        return np.zeros(1)
    if free_axis not in AXES:
        raise OptionError(f"free_axis {str(free_axis)[:20]!r}: give 'x', 'y' or 'z' (the tool axis left free)")
    step = math.radians(10.0) if free_step is None else float(free_step)
    if not (math.isfinite(step) and 1e-6 <= step <= 2 * math.pi):
        raise OptionError(f"free_step {short_text(step)} rad: give a step from 1e-6 rad to 2 pi")
    low, high = (-math.pi, math.pi) if free_range is None else (float(free_range[0]), float(free_range[1]))
    if not (math.isfinite(low) and math.isfinite(high) and low <= high and high - low <= 2 * math.pi + 1e-12):
        raise OptionError(f"free_range ({short_text(low)}, {short_text(high)}) rad: give low <= high, at most a turn")
    full = high - low >= 2 * math.pi - 1e-12
    count = int(math.floor((high - low) / step + 1e-9)) + (0 if full else 1)
    bounds.count(count, "tool angles", maximum=100_000)
    return low + step * np.arange(count)


def _pairs_words(checker, rows) -> tuple[tuple[str, str], ...]:
    found: dict = {}
    for q in rows[:3]:
        for pair in sorted(checker.pairs_in_contact(q)):
            found[pair] = None
    return tuple(found)


def plan_path(subject, poses, *, base: str | None = None, tip: str | None = None, t=None, speed=None,
              angular_speed=None, velocity_scale: float = 1.0, free_axis: str | None = None, free_step=None,
              free_range=None, arm_angle_step: float = TEN_DEGREES, aliases: bool = True,
              reconfigure: bool = False, collisions=None, collision_step: float = ONE_DEGREE,
              path_tol=(1e-3, ONE_DEGREE), depth: int = 4, weights=None, singular_tol: float | None = None,
              tol: float = 1e-9, q0=None, restarts: int = 20, seed: int = 0, max_replans: int = 10_000,
              progress=None) -> PathPlan:
    """Plan a joint path that puts ``tip`` on every pose of ``poses``, over every IK branch, or say where and why
    none exists.

    Parameters
    ----------
    subject : Robot or Chain
        The robot (with ``base`` and ``tip``, defaults ``base_link`` and ``ee_link``), or a chain.
    poses : array_like, shape (N, 4, 4)
        ``T_base_tip`` at each waypoint (metres).
    t : array_like, shape (N,), optional
        Time at each waypoint (s, increasing); or ``speed`` (m/s of the tip's origin) and/or
        ``angular_speed`` (rad/s of its rotation), each step taking the longer of the two. Without either,
        steps are not bounded by the velocity limits (the path check still refuses jumps off the path).
    velocity_scale : float
        Fraction of each joint's URDF velocity limit a step may use (0 < scale; 1: the limit).
    free_axis : {"x", "y", "z"}, optional
        The tool axis the task leaves free: the tip may turn about it; ``free_step`` (rad, default 10 deg)
        over ``free_range`` (low, high) rad (default a full turn).
    arm_angle_step : float
        7R SRS arms (iiwa14): the arm angle is sampled over a full turn at this step (rad).
    aliases : bool
        Every in-limit ``q + 2 pi k`` of every branch (default); False: the dispatcher's one value per branch.
    reconfigure : bool
        Allow breaks (retract, reconfigure, resume): the fewest breaks first, then the least motion.
    collisions : bool or CollisionChecker, optional
        Check the chosen path's waypoints and steps (samples at most ``collision_step`` apart, rad or m, in
        every joint) and re-plan around contacts; True: the robot against itself.
    path_tol : float or (float, float)
        How far (m, rad) a joint-interpolated point of a step may be from the tool path; ``depth`` levels of
        midpoints are checked per step.
    weights : array_like, shape (n,), optional
        Cost weight of each joint's motion (default 1).
    singular_tol : float, optional
        Candidates whose Jacobian's smallest singular value is below it are dropped (``near_singular``).
    tol : float
        IK residual tolerance (m and rad) of every candidate, by forward kinematics.
    q0 : array_like, optional
        The whole robot's joint values off the chain (collision checks); default the robot's defaults.
    progress : callable, optional
        ``progress(stage, done, total)`` for the IK and ladder stages.

    Returns
    -------
    PathPlan

    Examples
    --------
    >>> import manipkit
    >>> ur5 = manipkit.load("ur5")
    >>> chain = ur5.chain("base_link", "tool0")
    >>> T0 = chain.fk([0.3, -1.2, 1.4, -1.8, -1.5, 0.2])
    >>> poses = np.repeat(T0[None], 5, axis=0)
    >>> poses[:, 2, 3] += np.linspace(0.0, 0.04, 5)
    >>> plan = plan_path(chain, poses, speed=0.05)
    >>> plan.feasible, plan.q.shape, plan.first_failure
    (True, (5, 6), None)
    """
    # Over 80 lines: the docstring is half of it; the rest is the one loop of solve, check and re-plan.
    from manipkit.ik.dispatch import robot_and_frames

    robot, base, tip = robot_and_frames(subject, base, tip)
    chain = robot.chain(base, tip)
    T = np.array(PosePath(poses).poses)  # checked there: a stack of rigid transforms, at most MAX_WAYPOINTS
    N, n = len(T), chain.n
    times, dt = _step_times(T, t, speed, angular_speed)
    scale = float(velocity_scale)
    if not (math.isfinite(scale) and 0.0 < scale <= 1e6):
        raise OptionError(f"velocity_scale {short_text(scale)}: give a positive fraction of the URDF limits")
    angles = _free_angles(free_axis, free_step, free_range)
    path_tol = (float(path_tol), float(path_tol)) if np.ndim(path_tol) == 0 else tuple(map(float, path_tol))
    if not all(math.isfinite(v) and v > 0 for v in path_tol):
        raise OptionError(f"path_tol {path_tol}: give positive tolerances (m, rad)")
    bounds.count(depth, "depth", minimum=1, maximum=20)
    source = ik_source(robot, base, tip)
    psi = None
    if source == "srs":
        step = float(arm_angle_step)
        if not (math.isfinite(step) and 1e-4 <= step <= 2 * math.pi):
            raise OptionError(f"arm_angle_step {short_text(step)} rad: give a step from 1e-4 rad to 2 pi")
        psi = -math.pi + step * np.arange(int(math.floor(2 * math.pi / step + 1e-9)))
    rotations = tool_rotations(free_axis, angles)
    rungs = build_rungs(chain, T, rotations, source=source, arm_angles=psi, tol=tol, aliases=aliases,
                        restarts=restarts, seed=seed, progress=progress)
    limits = velocity_limits(chain)
    step_bounds = np.full((max(N - 1, 0), n), np.inf) if dt is None else dt[:, None] * limits[None, :] * scale
    w = None if weights is None else np.asarray(weights, dtype=float).reshape(n)
    penalties = [np.zeros(len(Q)) for Q in rungs.Q]
    singular = [None] * N
    if singular_tol is not None:
        if not (math.isfinite(float(singular_tol)) and float(singular_tol) > 0):
            raise OptionError(f"singular_tol {short_text(float(singular_tol))}: give a positive singular value")
        for i, Q in enumerate(rungs.Q):
            if len(Q):
                sigma = np.linalg.svd(chain.jacobians(Q), compute_uv=False)[:, -1]
                singular[i] = sigma
                penalties[i] = np.where(sigma < singular_tol, np.inf, penalties[i])
    checker = None
    if collisions is True:
        from manipkit.kinematics.collisions import CollisionChecker

        checker = CollisionChecker(robot)
    elif collisions not in (None, False):
        checker = collisions
    if checker is not None:
        step = float(collision_step)
        if not (math.isfinite(step) and 1e-4 <= step <= 2 * math.pi):
            raise OptionError(f"collision_step {short_text(step)} rad: give a step from 1e-4 rad to 2 pi")
    whole = robot.q() if q0 is None else robot.q(q0)
    forbidden: dict[int, list] = {}
    step_reason: dict[int, set] = {}
    collided: dict[int, list] = {}
    checked_vertices: set = set()
    checked_steps: set = set()
    checks = points = replans = 0
    changed = False
    swept: set = set()  # steps i whose every velocity-allowed pair of candidates was checked for deviation
    failed_at = N
    P = 1 if psi is None else len(psi)

    def sweep(i: int, reached) -> int:
        """The first time a step between rungs i and i + 1 leaves the path, every pair of their candidates the
        velocity bound lets pass is checked at once and the deviating ones forbidden (at most one deviation
        re-plan per rung pair); the interpolated points checked."""
        pairs, count = _deviating_rung_pairs(chain, rungs, T, rotations, i, step_bounds[i], reached,
                                             penalties[i + 1], P, path_tol, depth)
        swept.add(i)
        forbidden.setdefault(i, []).extend(pairs)
        step_reason.setdefault(i, set()).add(("deviation", ()))
        return count

    for replans in range(max_replans + 1):  # noqa: B007 (the count is reported)
        ladder = solve_ladder(rungs.Q, step_bounds, weights=w, penalties=penalties, forbidden=forbidden,
                              reconfigure=reconfigure, progress=progress)
        if not ladder.feasible:
            # before naming first_dead, the best path to the rung before it is checked for deviation (a clean one
            # proves that rung reached, so first_failure is exact); a step of it that leaves the path sweeps its
            # rung pair and the ladder is solved again
            changed = False
            k = ladder.first_dead
            if k > 1:
                part = solve_ladder(rungs.Q[:k], step_bounds[:k - 1], weights=w, penalties=penalties[:k],
                                    forbidden={i: f for i, f in forbidden.items() if i < k - 1},
                                    reconfigure=reconfigure)
                Qk = np.stack([rungs.Q[i][part.choice[i]] for i in range(k)])
                Tk = T[:k] @ rotations[np.stack([rungs.sample[i][part.choice[i]] for i in range(k)]) // P]
                steps = np.array([i for i in range(k - 1) if i not in swept and i not in part.breaks], dtype=np.intp)
                bad = np.zeros(k - 1, dtype=bool)
                if len(steps):
                    bad, _, count = deviating_steps(chain, Qk, Tk, tol=path_tol, depth=depth, steps=steps)
                    points += count
                for i in np.flatnonzero(bad):
                    points += sweep(int(i), part.reached[i])
                    changed = True
            if changed:
                failed_at = k
                continue
            break  # proven blocked: what was taken out leaves no path (not unfinished)
        choice = ladder.choice
        Q = np.stack([rungs.Q[i][choice[i]] for i in range(N)])
        targets = T @ rotations[np.stack([rungs.sample[i][choice[i]] for i in range(N)]) // P]
        changed = False
        failed_at = N
        if checker is not None:
            new = [i for i in range(N) if (i, choice[i]) not in checked_vertices]
            rows = np.repeat(whole[None], len(new), axis=0)
            rows[:, chain.columns] = Q[new]
            hits = checker.in_collision(rows) if new else np.zeros(0, dtype=bool)
            checks += len(new)
            checked_vertices.update((i, choice[i]) for i in new)
            for i, hit, row in zip(new, hits, rows):
                if hit:
                    penalties[i][alias_group(rungs, i, choice[i])] = np.inf
                    collided.setdefault(i, []).append(_pairs_words(checker, row[None]))
                    changed = True
                    failed_at = min(failed_at, i)
        if changed:
            continue
        live = [i for i in range(N - 1) if i not in ladder.breaks and (i, choice[i], choice[i + 1]) not in checked_steps]
        if live:
            idx = np.array(live)
            unknown = np.array([i not in swept for i in live], dtype=bool)
            bad = np.zeros(max(N - 1, 0), dtype=bool)
            if unknown.any():
                bad, _, count = deviating_steps(chain, Q, targets, tol=path_tol, depth=depth, steps=idx[unknown])
                points += count
            for i in idx[bad[idx]]:
                points += sweep(int(i), ladder.reached[i])
                changed = True
                failed_at = min(failed_at, int(i) + 1)
            if checker is not None:
                clear = idx[~bad[idx]]
                samples, owner = step_samples(Q, clear, collision_step)
                rows = np.repeat(whole[None], len(samples), axis=0)
                rows[:, chain.columns] = samples
                hits = checker.in_collision(rows) if len(samples) else np.zeros(0, dtype=bool)
                checks += len(samples)
                for i in np.unique(owner[hits]):
                    forbidden.setdefault(int(i), []).extend(_same_steps(rungs, int(i), choice[i], choice[i + 1]))
                    pairs = _pairs_words(checker, rows[hits & (owner == i)])
                    step_reason.setdefault(int(i), set()).add(("collision", pairs))
                    changed = True
                    failed_at = min(failed_at, int(i) + 1)
            checked_steps.update((i, choice[i], choice[i + 1]) for i in live if not bad[i])
        if not changed:
            break
    failures = _failures(chain, rungs, ladder, penalties, singular, singular_tol, collided, step_reason)
    if changed:  # max_replans ran out: say so where the last path failed its check
        failures = tuple(records + ((BranchFailure("unfinished", replans),) if i == failed_at else ())
                         for i, records in enumerate(failures))
    resolution = {
        "waypoints": N, "samples": rungs.samples, "tool_angles": len(angles),
        "arm_angles": 0 if psi is None else len(psi), "aliases": bool(aliases),
        "candidates": int(sum(len(Q) for Q in rungs.Q)), "edges": ladder.edges, "method": rungs.method,
        "cost": "summed joint motion (rad or m)" if w is None else "weighted summed joint motion",
        "path_tol": list(path_tol), "depth": depth, "collision_step": None if checker is None else collision_step,
        "ik_calls": rungs.ik_calls, "velocity_scale": scale, "timed": dt is not None,
        "unfinished": bool(changed),
    }
    cells = _feasibility(rungs, ladder, penalties, singular, singular_tol, len(angles), P)
    common = dict(joint_names=tuple(chain.joint_names), t=times, failures=failures, resolution=resolution,
                  collision_checks=checks, deviation_points=points, replans=replans, feasibility=cells,
                  free_angles=angles)
    if not ladder.feasible or changed:  # changed: the last path failed a check and max_replans ran out
        return PathPlan(False, None, first_failure=None if changed else ladder.first_dead, reconfigurations=(), cost=None,
                        max_velocity_ratio=None, **common)
    ratio = None
    if dt is not None and N > 1:
        steps = np.abs(np.diff(Q, axis=0)) / (dt[:, None] * limits[None, :] * scale)
        steps[list(ladder.breaks)] = 0.0
        ratio = float(np.nan_to_num(steps, nan=0.0).max())
    if aliases:
        Q = _nearest_zero(Q, chain)
    sample = np.stack([rungs.sample[i][choice[i]] for i in range(N)])
    cells[np.arange(N), sample // P] = FEASIBILITY_KINDS.index("chosen")
    Q.setflags(write=False)
    return PathPlan(True, Q, first_failure=None, reconfigurations=tuple(i + 1 for i in ladder.breaks),
                    cost=ladder.cost, max_velocity_ratio=ratio,
                    tool_angles=None if free_axis is None else angles[sample // P],
                    arm_angles=None if psi is None else psi[sample % P], targets=targets, **common)


def _feasibility(rungs, ladder, penalties, singular, singular_tol, A: int, P: int) -> np.ndarray:
    """(N, A) int8: per waypoint and tool angle, the best :data:`FEASIBILITY_KINDS` index of its candidates."""
    kinds = {name: k for k, name in enumerate(FEASIBILITY_KINDS)}
    N = len(rungs.Q)
    reachable = (np.ones((N, A * P), dtype=bool) if rungs.reachable is None else rungs.reachable).reshape(N, A, P)
    cells = np.where(reachable.any(axis=2), kinds["joint_limits"], kinds["unreachable"]).astype(np.int8)
    blocked = {block.rung: block for block in ladder.blocked}
    for i in range(N):
        if not len(rungs.Q[i]):
            continue
        code = np.full(len(rungs.Q[i]), kinds["cut_off"], dtype=np.int8)
        block = blocked.get(i)
        if block is not None:
            code[np.isfinite(block.ratio) & (block.ratio > 1.0)] = kinds["velocity"]
        code[np.isinf(penalties[i])] = kinds["collision"]
        if singular[i] is not None:
            code[singular[i] < singular_tol] = kinds["near_singular"]
        if i < len(ladder.reached):
            code[np.asarray(ladder.reached[i], dtype=bool)] = kinds["reached"]
        np.maximum.at(cells[i], rungs.sample[i] // P, code)
    return cells


def _deviating_rung_pairs(chain, rungs, T, rotations, i: int, bound, reached, penalty, P: int, path_tol,
                          depth: int) -> tuple[list[tuple[int, int]], int]:
    """Every pair ``(a, b)`` from rung ``i`` to rung ``i + 1`` that leaves the tool path between them
    (:func:`manipkit.paths.steps.deviating_pairs`), among the pairs the ladder could use: ``a`` reached (what is
    taken out only ever shrinks the reached set), ``b`` valid and every joint's step inside ``bound`` (the rule of
    :func:`manipkit.paths.ladder.solve_ladder`). Returns ``(pairs, points checked)``."""
    Qa, Qb = rungs.Q[i], rungs.Q[i + 1]
    A = np.flatnonzero(reached)
    B = np.flatnonzero(np.isfinite(penalty))
    if not len(A) or not len(B):
        return [], 0
    d = np.abs(Qb[B][None, :, :] - Qa[A][:, None, :])
    fits = ((d == 0.0) | (d <= bound[None, None, :] * (1.0 + 1e-12))).all(axis=2)  # a superset of the ladder's rule
    x, y = np.nonzero(fits)
    a, b = A[x], B[y]
    Ta = T[i] @ rotations[rungs.sample[i][a] // P]
    Tb = T[i + 1] @ rotations[rungs.sample[i + 1][b] // P]
    bad, _, count = deviating_pairs(chain, Qa[a], Qb[b], Ta, Tb, tol=path_tol, depth=depth)
    return [(int(p), int(q)) for p, q in zip(a[bad], b[bad])], count


def _same_steps(rungs, i: int, a: int, b: int) -> list[tuple[int, int]]:
    """Every step from waypoint ``i`` to ``i + 1`` between aliases of ``a`` and of ``b`` with the same joint motion
    as ``a -> b`` (the same step moved by whole turns: it leaves the path, or collides, exactly as ``a -> b``)."""
    A, B = alias_group(rungs, i, a), alias_group(rungs, i + 1, b)
    dq = rungs.Q[i + 1][b] - rungs.Q[i][a]
    same = np.abs(rungs.Q[i + 1][B][None, :, :] - rungs.Q[i][A][:, None, :] - dq).max(axis=2) <= 1e-9
    return [(int(A[x]), int(B[y])) for x, y in zip(*np.nonzero(same))]


def _nearest_zero(Q: np.ndarray, chain) -> np.ndarray:
    """``Q`` with each angular joint's whole column moved by the ``2 pi k`` that brings its mean nearest 0 while
    every value stays inside the limits: the same poses, the same steps and cost (the path's aliases are
    candidates too), the one a user expects among equally good ones."""
    Q = Q.copy()
    for j, joint in enumerate(chain.joints):
        if not joint.is_angular:
            continue
        for k in sorted(range(-3, 4), key=lambda k: abs(Q[:, j].mean() + 2 * math.pi * k)):
            moved = Q[:, j] + 2 * math.pi * k
            if moved.min() >= chain.lower[j] and moved.max() <= chain.upper[j]:
                Q[:, j] = moved
                break
    return Q


def _failures(chain, rungs, ladder, penalties, singular, singular_tol, collided, step_reason):
    """Per waypoint, the :class:`BranchFailure` records of the candidates that died there."""
    names = chain.joint_names
    blocked = {block.rung: block for block in ladder.blocked}
    out = []
    for i in range(len(rungs.Q)):
        records = []
        if rungs.unreachable[i]:
            records.append(BranchFailure("unreachable", int(rungs.unreachable[i])))
        if rungs.limits[i]:
            records.append(BranchFailure("joint_limits", int(rungs.limits[i]), joint=rungs.limit_joint[i]))
        if singular[i] is not None:
            low = singular[i] < singular_tol
            if low.any():
                records.append(BranchFailure("near_singular", int(low.sum()), ratio=float(singular[i][low].min())))
        if i in collided:
            pairs = tuple(dict.fromkeys(p for found in collided[i] for p in found))
            records.append(BranchFailure("collision", len(collided[i]), pairs=pairs))
        block = blocked.get(i)
        if block is not None:
            stuck = np.isfinite(block.ratio) | np.isinf(block.ratio)
            fast = stuck & np.isfinite(block.ratio) & (block.ratio > 1.0)
            if fast.any():
                k = int(np.flatnonzero(fast)[np.argmin(block.ratio[fast])])
                records.append(BranchFailure("velocity", int(fast.sum()), joint=names[int(block.joint[k])],
                                             ratio=float(block.ratio[k])))
            cut = stuck & ~fast
            if cut.any():
                reasons = step_reason.get(i - 1, set())
                pairs = tuple(dict.fromkeys(p for kind, found in reasons if kind == "collision" for p in found))
                kind = "collision" if pairs else "deviation"
                records.append(BranchFailure(kind, int(cut.sum()), pairs=pairs))
        out.append(tuple(records))
    return tuple(out)
