"""Time scaling of a joint path within velocity, acceleration and tool-speed limits, by TOPP-RA.

:func:`retime` takes the joint path a planner chose (waypoints in order), lays a cubic spline through
them and finds the fastest motion along it, rest to rest, that keeps every joint's velocity and
acceleration and, given a chain, the tool's speed within their limits: TOPP-RA (Pham and Pham, "A New
Approach to Time-Optimal Path Parameterization Based on Reachability Analysis", IEEE T-RO 2018), through
the ``toppra`` package (the ``paths`` extra; imported inside the function).

TOPP-RA enforces the limits at the points of a grid along the path. Between grid points the velocity and
acceleration of the sampled result can exceed them by a little (the path's tangent turns between grid
points), so the result is checked on a finer sampling of every grid interval (:data:`CHECK_SUBDIVISIONS`).
Intervals that exceed a limit by more than :data:`REFINE_TOL` are split in four and TOPP-RA is solved again
(at most :data:`REFINEMENTS` times); what is left over is removed by slowing the whole motion down
uniformly in time by the worst ratio ``r`` (velocities scale by ``1/r``, accelerations by ``1/r^2``). The
answer stays within every limit on the checked samples, and ``time_dilation`` says by how much it was
stretched (measured: 1.00001 to 1.0001 on smooth 60-waypoint paths).

Conventions: joint arrays ``(N, n)`` in the chain's joint order (rad or m), times in seconds, limits per
joint (rad/s, rad/s^2; m/s, m/s^2 for prismatic joints), tool speed in m/s: the speed of the tip frame's
origin relative to the base, from the chain's Jacobian (``chain.jacobians``, base axes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from manipkit import bounds
from manipkit.errors import OptionError
from manipkit.paths.poses import MAX_WAYPOINTS
from manipkit.paths.trajectory import values_per_item
from manipkit.text import printable

__all__ = ["BIND_TOL", "CHECK_SUBDIVISIONS", "GRID_POINTS", "MAX_GRID_POINTS", "REFINEMENTS", "REFINE_TOL", "RetimeResult", "Slowdown", "retime"]

#: A limit binds on a grid interval of TOPP-RA's solution when its ratio (value / limit) is within this of 1.
BIND_TOL = 1e-3
#: TOPP-RA grid intervals over the whole path by default (:func:`retime`'s ``subdivisions``).
GRID_POINTS = 2000
#: Grid refinements: where the motion between grid points exceeds a limit by more than REFINE_TOL, those
#: intervals are split in four and TOPP-RA solved again, at most REFINEMENTS times (MAX_GRID_POINTS at most).
REFINEMENTS = 4
REFINE_TOL = 1e-3
MAX_GRID_POINTS = 200_000
#: Samples per grid interval on which the result is checked against the limits (and stretched if needed).
CHECK_SUBDIVISIONS = 8
#: Consecutive waypoints closer than this (Euclidean norm of the joint difference, rad or m) are one.
SAME_WAYPOINT_TOL = 1e-12

_LIMITS = ("velocity", "acceleration", "tool speed")


@dataclass(frozen=True)
class Slowdown:
    """One limit that binds on one segment of the path (between waypoints ``segment`` and ``segment + 1``).

    Attributes
    ----------
    segment : int
        Index of the segment's first waypoint (0-based, as the rows of the input path).
    limit : str
        ``"velocity"``, ``"acceleration"`` or ``"tool speed"``.
    joint : str or None
        The joint whose limit binds (None for the tool speed).
    share : float
        Fraction of the segment's time during which this limit binds, in (0, 1].
    """

    segment: int
    limit: str
    joint: str | None
    share: float

    def text(self) -> str:
        what = "the tool speed" if self.joint is None else f"{self.joint}'s {self.limit}"
        return f"waypoints {self.segment}-{self.segment + 1}: {what} limit binds for {100 * self.share:.0f} % of the time"


@dataclass(frozen=True)
class RetimeResult:
    """A retimed joint path: samples in time, when each waypoint is passed, and which limits bind where.

    Attributes
    ----------
    t : ndarray, shape (M,)
        Sample times (s), from 0: every ``dt`` and the time of every waypoint.
    q, qd, qdd : ndarray, shape (M, n)
        Positions, velocities and accelerations at ``t`` (the exact derivatives of the motion).
    waypoint_times : ndarray, shape (N,)
        When each input waypoint is passed (s), non-decreasing (equal for repeated waypoints).
    waypoint_index : ndarray of int, shape (N,)
        The sample of each waypoint: ``q[waypoint_index[k]] == waypoints[k]`` to rounding.
    duration : float
        Seconds from rest at the first waypoint to rest at the last.
    joint_names : tuple of str
        The joints (the chain's names, or ``joint 0`` ... without a chain).
    slowdowns : tuple of Slowdown
        Per segment, the limits that bind on it in TOPP-RA's solution and for what share of its time
        (largest share first within a segment).
    time_dilation : float
        The uniform stretch applied after TOPP-RA so the finely sampled motion is within every limit
        (1.0: none was needed).
    max_velocity_ratio, max_acceleration_ratio : float
        Largest ``|qd| / velocity_limit`` and ``|qdd| / acceleration_limit`` over the checked samples.
    max_tool_speed : float or None
        Largest tool speed over the checked samples (m/s); None without a chain.
    path_deviation : float
        Largest distance (joint-space norm, rad or m) of the spline from the straight joint segments
        between the waypoints, over the checked samples: how far the motion strays from the piecewise
        linear path a planner checks.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    waypoint_times: np.ndarray
    waypoint_index: np.ndarray
    duration: float
    joint_names: tuple
    slowdowns: tuple
    time_dilation: float
    max_velocity_ratio: float
    max_acceleration_ratio: float
    max_tool_speed: float | None
    path_deviation: float

    def __post_init__(self):
        for name in ("t", "q", "qd", "qdd", "waypoint_times", "waypoint_index"):
            array = np.array(getattr(self, name))
            array.flags.writeable = False
            object.__setattr__(self, name, array)

    def explain(self) -> list[str]:
        """The result in words: duration, stretch, the spline's deviation, and where which limit binds."""
        lines = [f"{self.duration:.6g} s through {len(self.waypoint_times)} waypoints, rest to rest"]
        if self.time_dilation > 1.0:
            lines.append(f"{100 * (self.time_dilation - 1.0):.2g} % longer than TOPP-RA's answer, to stay within the limits "
                         "between its grid points")
        lines.append(f"the spline through the waypoints strays at most {self.path_deviation:.3g} (joint-space norm, rad or "
                     "m) from the straight joint steps between them")
        lines += [slowdown.text() for slowdown in self.slowdowns]
        return lines


def _path(q) -> np.ndarray:
    try:
        Q = np.asarray(q, dtype=float)
    except (TypeError, ValueError):
        raise OptionError(f"q must be an (N, n) array of joint values, got {printable(repr(q))[:60]}") from None
    if Q.ndim != 2 or Q.shape[1] == 0:
        raise OptionError(f"q has shape {Q.shape}; give an (N, n) joint path, waypoint by joint")
    bounds.count(len(Q), "q: waypoints", minimum=2, maximum=MAX_WAYPOINTS, error=OptionError)
    if not np.isfinite(Q).all():
        k, j = (int(i) for i in np.argwhere(~np.isfinite(Q))[0])
        raise OptionError(f"q[{k}, {j}] is {Q[k, j]}; a joint path has finite values")
    return Q


def retime(q, *, velocity_limits, acceleration_limits, tool_speed: float | None = None, chain=None,
           dt: float = 1e-3, subdivisions: int | None = None, joint_names=None) -> RetimeResult:
    """The fastest rest-to-rest motion through the waypoints ``q`` in order, within the limits (TOPP-RA).

    Parameters
    ----------
    q : array_like, shape (N, n)
        Joint path, waypoint by joint (the chain's order), ``N >= 2``. Consecutive equal waypoints are
        passed at the same time.
    velocity_limits, acceleration_limits : float or array_like, shape (n,), keyword-only
        Largest ``|qd|`` (rad/s or m/s) and ``|qdd|`` (rad/s^2 or m/s^2) per joint, positive.
    tool_speed : float or None, keyword-only
        Largest speed of the tip frame's origin (m/s), measured by ``chain``'s Jacobian; needs ``chain``.
    chain : manipkit.kinematics.chain.Chain or None, keyword-only
        The chain the path is for: names the joints and gives the tool speed.
    dt : float, keyword-only
        Sample interval of the result (s); the waypoint times are added to the samples.
    subdivisions : int or None, keyword-only
        TOPP-RA grid intervals per segment between waypoints (1 to 1000): finer is closer to time-optimal
        (less ``time_dilation``) and slower to solve. None: :data:`GRID_POINTS` over the path, 2 to 64 a
        segment.
    joint_names : sequence of str, keyword-only
        Names for the report when there is no chain.

    Returns
    -------
    RetimeResult
        Samples ``t``, ``q``, ``qd``, ``qdd``; when each waypoint is passed; which limit binds on each
        segment; and the checks' maxima.

    Raises
    ------
    OptionError
        A path that is not a finite (N, n) array with ``2 <= N <= MAX_WAYPOINTS``, a limit that is not
        positive and finite (the joint named), a tool speed without a chain, a chain with another number
        of joints, or more than ``MAX_WAYPOINTS`` samples.

    Notes
    -----
    The geometric path is the cubic spline (not-a-knot ends) through the distinct waypoints, parameterised
    by the cumulative joint-space chord length; it passes every waypoint in order but bends between them
    (``path_deviation`` says how far). Tool speed enters TOPP-RA as a bound on the path speed:
    ``|J_v(q(s)) q'(s)| s_dot <= tool_speed``, expressed as a varying velocity bound of the joint that
    moves most at that grid point. The motion starts and ends at rest.

    Examples
    --------
    >>> result = retime([[0.0], [1.0]], velocity_limits=1.0, acceleration_limits=2.0)
    >>> round(result.duration, 2)  # accelerate 0.5 s, cruise 0.5 s, brake 0.5 s: 1.5 s by hand
    1.5
    """
    # Over 80 lines: the docstring states the method and its conventions; the body is 50 lines of one pipeline.
    try:
        import toppra
        import toppra.algorithm
        import toppra.constraint
    except ModuleNotFoundError:
        raise OptionError("retime needs the toppra package (TOPP-RA): pip install 'manipkit[paths]'") from None

    Q, vmax, amax, step, tool_speed, names = _arguments(q, velocity_limits, acceleration_limits, tool_speed, chain, dt,
                                                        joint_names)
    n = Q.shape[1]

    # distinct waypoints and their path coordinate (cumulative chord length)
    chords = np.linalg.norm(np.diff(Q, axis=0), axis=1)
    distinct = np.concatenate([[True], chords > SAME_WAYPOINT_TOL])
    group = np.cumsum(distinct) - 1  # each input waypoint's distinct waypoint
    s_way = np.concatenate([[0.0], np.cumsum(chords[distinct[1:]])])
    if len(s_way) == 1:
        zeros = np.zeros((1, n))
        return RetimeResult(np.zeros(1), Q[:1], zeros, zeros, np.zeros(len(Q)), np.zeros(len(Q), dtype=np.intp), 0.0,
                            names, (), 1.0, 0.0, 0.0, 0.0 if chain is not None else None, 0.0)
    path = toppra.SplineInterpolator(s_way, Q[distinct])
    per_segment = (min(64, max(2, math.ceil(GRID_POINTS / (len(s_way) - 1)))) if subdivisions is None else
                   bounds.count(subdivisions, "subdivisions", maximum=1000, error=OptionError))
    fractions = np.arange(per_segment) / per_segment
    grid = np.concatenate([s_way[:-1, None] + fractions * np.diff(s_way)[:, None], s_way[-1:, None]], axis=None)

    def tool_gain(s):
        """|J_v(q(s)) q'(s)|: tool speed per unit path speed, at path coordinates s (M,)."""
        J = chain.jacobians(path(s))
        return np.linalg.norm(np.einsum("mij,mj->mi", J[:, :3, :], path(s, 1)), axis=1)

    limits = _Limits(vmax, amax, tool_speed, tool_gain if chain is not None else None)
    for refinement in range(REFINEMENTS + 1):
        sd = _solve(toppra, path, grid, limits)
        motion = _Motion(path, grid, sd, limits)
        over = motion.interval_ratio > 1.0 + REFINE_TOL
        if not over.any() or refinement == REFINEMENTS or len(grid) + 3 * over.sum() > MAX_GRID_POINTS:
            break
        # split each grid interval whose motion exceeds a limit between its grid points into four
        inserted = grid[:-1][over, None] + np.diff(grid)[over, None] * (np.arange(1, 4) / 4.0)
        grid = np.union1d(grid, inserted.ravel())
    grid_segment = np.minimum(np.searchsorted(s_way, grid, side="right") - 1, len(s_way) - 2)
    slowdowns = _slowdowns(path, grid, sd, motion.u, motion.interval_time, grid_segment[:-1], limits, names,
                           len(s_way) - 1)
    ratio = max(1.0, float(motion.interval_ratio.max()))  # the uniform stretch that brings every check within
    sd, u, interval_time = sd / ratio, motion.u / ratio**2, motion.interval_time * ratio
    grid_time = np.concatenate([[0.0], np.cumsum(interval_time)])
    deviation = _deviation(path(motion.check_s), motion.check_s, s_way, Q[distinct])

    way_time = grid_time[np.searchsorted(grid, s_way)]
    t, q_out, qd, qdd = _samples(path, grid, grid_time, sd, u, s_way, way_time, Q[distinct], step)
    return RetimeResult(
        t, q_out, qd, qdd, way_time[group], np.searchsorted(t, way_time)[group], float(grid_time[-1]), names,
        slowdowns, ratio, motion.max_velocity / ratio, motion.max_acceleration / ratio**2,
        motion.max_tool_speed / ratio if motion.max_tool_speed is not None else None, deviation)


def _arguments(q, velocity_limits, acceleration_limits, tool_speed, chain, dt, joint_names):
    """:func:`retime`'s arguments checked: the path, limits, sample interval, tool speed and joint names."""
    Q = _path(q)
    n = Q.shape[1]
    vmax = values_per_item(velocity_limits, "velocity_limits", n)
    amax = values_per_item(acceleration_limits, "acceleration_limits", n)
    step = bounds.duration(dt, "dt", error=OptionError)
    if tool_speed is not None:
        tool_speed = bounds.speed(tool_speed, "tool_speed", error=OptionError)
        if chain is None:
            raise OptionError("tool_speed needs the chain (chain=robot.chain(base, tip)) to measure the tool's speed")
    if chain is not None and len(chain.joint_names) != n:
        raise OptionError(f"q has {n} joints per waypoint but the chain {chain.base} -> {chain.tip} has "
                          f"{len(chain.joint_names)}")
    names = tuple(chain.joint_names) if chain is not None else (
        tuple(str(name) for name in joint_names) if joint_names is not None else tuple(f"joint {j}" for j in range(n)))
    return Q, vmax, amax, step, tool_speed, names


def _samples(path, grid, grid_time, sd, u, s_way, way_time, waypoints, step):
    """t, q, qd, qdd every ``step`` and at every waypoint's time, from the path speeds at the grid points."""
    bounds.count(int(grid_time[-1] / step) + len(s_way) + 1, "retime: samples (duration / dt)", maximum=MAX_WAYPOINTS,
                 error=OptionError)
    t = np.arange(0.0, grid_time[-1], step)
    j = np.clip(np.searchsorted(way_time, t), 1, len(way_time) - 1)
    near = np.minimum(np.abs(t - way_time[j - 1]), np.abs(t - way_time[j]))
    t = np.union1d(t[near > 0.01 * step], way_time)  # no sample a hair from a waypoint: differences stay sound
    i = np.clip(np.searchsorted(grid_time, t, side="right") - 1, 0, len(grid) - 2)
    local = t - grid_time[i]
    s = np.minimum(grid[i] + sd[i] * local + u[i] * local**2 / 2.0, grid[-1])
    at_waypoint = np.isin(t, way_time)
    s[at_waypoint] = s_way[np.searchsorted(way_time, t[at_waypoint])]
    s_dot = np.maximum(sd[i] + u[i] * local, 0.0)
    s_dot[-1] = 0.0  # the last sample is the last waypoint, reached at rest
    q_out, tangent_out = path(s), path(s, 1)
    qd = tangent_out * s_dot[:, None]
    qdd = path(s, 2) * s_dot[:, None] ** 2 + tangent_out * u[i, None]
    q_out[at_waypoint] = waypoints  # the waypoints exactly (the spline meets them to rounding)
    return t, q_out, qd, qdd


@dataclass(frozen=True)
class _Limits:
    vmax: np.ndarray
    amax: np.ndarray
    tool_speed: float | None
    tool_gain: object  # s (M,) -> |J_v q'| (M,), or None without a chain


def _solve(toppra, path, grid: np.ndarray, limits: _Limits) -> np.ndarray:
    """TOPP-RA's path speeds s_dot at the grid points, rest to rest."""
    constraints = [toppra.constraint.JointAccelerationConstraint(limits.amax)]
    if limits.tool_speed is None:
        constraints.append(toppra.constraint.JointVelocityConstraint(limits.vmax))
    else:
        gain = limits.tool_gain(grid)
        tangents = np.abs(path(grid, 1))

        def velocity_bounds(s):
            i = min(int(np.searchsorted(grid, s - 1e-12 * (1.0 + abs(s)))), len(grid) - 1)
            bound = limits.vmax.copy()
            j = int(np.argmax(tangents[i]))  # s_dot <= c is |q'_j| s_dot <= |q'_j| c for the joint moving most
            if gain[i] > 0.0:
                bound[j] = min(bound[j], tangents[i, j] * limits.tool_speed / gain[i])
            return np.stack([-bound, bound], axis=1)

        constraints.append(toppra.constraint.JointVelocityConstraintVarying(velocity_bounds))
    solver = toppra.algorithm.TOPPRA(constraints, path, gridpoints=grid, solver_wrapper="seidel")
    sd = solver.compute_parameterization(0.0, 0.0)[1]
    if sd is None or not np.isfinite(sd).all():
        raise OptionError("TOPP-RA found no motion along this path within the limits (a numerical failure on a "
                          f"grid of {len(grid)} points); try other subdivisions")
    return np.maximum(sd, 0.0)


class _Motion:
    """The motion of path speeds ``sd`` at grid points (constant path acceleration between them), checked on
    :data:`CHECK_SUBDIVISIONS` samples of every interval: ``interval_ratio`` is the time stretch each
    interval needs to be within every limit (``max(|qd| / v, sqrt(|qdd| / a), speed / tool_speed)``)."""

    def __init__(self, path, grid, sd, limits: _Limits):
        ds = np.diff(grid)
        self.u = (sd[1:] ** 2 - sd[:-1] ** 2) / (2.0 * ds)
        self.interval_time = 2.0 * ds / (sd[:-1] + sd[1:])
        k = CHECK_SUBDIVISIONS + 1
        tau = (np.arange(k) / CHECK_SUBDIVISIONS)[None, :] * self.interval_time[:, None]
        check_s = np.minimum((grid[:-1, None] + sd[:-1, None] * tau + self.u[:, None] * tau**2 / 2.0).ravel(), grid[-1])
        check_sd = (sd[:-1, None] + self.u[:, None] * tau).ravel()
        tangent, curvature = path(check_s, 1), path(check_s, 2)
        velocity = (np.abs(tangent * check_sd[:, None]) / limits.vmax).max(axis=1)
        acceleration = (np.abs(curvature * check_sd[:, None] ** 2 + tangent * np.repeat(self.u, k)[:, None])
                        / limits.amax).max(axis=1)
        ratio = np.maximum(velocity, np.sqrt(acceleration))
        tool = limits.tool_gain(check_s) * check_sd if limits.tool_gain is not None else None
        if tool is not None and limits.tool_speed is not None:
            ratio = np.maximum(ratio, tool / limits.tool_speed)
        self.interval_ratio = ratio.reshape(-1, k).max(axis=1)
        self.check_s = check_s
        self.max_velocity, self.max_acceleration = float(velocity.max()), float(acceleration.max())
        self.max_tool_speed = float(tool.max()) if tool is not None else None


def _slowdowns(path, grid, sd, u, interval_time, interval_segment, limits: _Limits, names, segments) -> tuple:
    """Which limit binds on each grid interval of TOPP-RA's solution, summed by time over each segment."""
    vmax, amax, tool_speed = limits.vmax, limits.amax, limits.tool_speed
    ends = np.stack([grid[:-1], grid[1:]])  # (2, K): both ends of each interval, as TOPP-RA constrains them
    speeds = np.stack([sd[:-1], sd[1:]])
    tangent, curvature = path(ends.ravel(), 1).reshape(2, -1, len(vmax)), path(ends.ravel(), 2).reshape(2, -1, len(vmax))
    ratios = {  # a velocity limit binds where it holds the whole interval; the others where they touch it
        "velocity": (np.abs(tangent) * speeds[..., None] / vmax).min(axis=0),
        "acceleration": (np.abs(curvature * speeds[..., None] ** 2 + tangent * u[None, :, None]) / amax).max(axis=0),
    }
    if tool_speed is not None:
        ratios["tool speed"] = (limits.tool_gain(ends.ravel()).reshape(2, -1) * speeds / tool_speed).max(axis=0)[:, None]
    found: dict[tuple[int, str, int | None], float] = {}
    for limit, ratio in ratios.items():
        binding = ratio >= 1.0 - BIND_TOL
        for k, j in zip(*np.nonzero(binding)):
            key = (int(interval_segment[k]), limit, None if limit == "tool speed" else int(j))
            found[key] = found.get(key, 0.0) + float(interval_time[k])
    segment_time = np.bincount(interval_segment, weights=interval_time, minlength=segments)
    result = [Slowdown(segment, limit, None if joint is None else names[joint], min(1.0, time / segment_time[segment]))
              for (segment, limit, joint), time in found.items()]
    return tuple(sorted(result, key=lambda item: (item.segment, -item.share, _LIMITS.index(item.limit))))


def _deviation(points: np.ndarray, s: np.ndarray, s_way: np.ndarray, waypoints: np.ndarray) -> float:
    """Largest distance of spline points from the straight joint segment between their waypoints."""
    k = np.clip(np.searchsorted(s_way, s, side="right") - 1, 0, len(s_way) - 2)
    a, b = waypoints[k], waypoints[k + 1]
    chord = b - a
    along = np.clip(np.einsum("ij,ij->i", points - a, chord) / np.einsum("ij,ij->i", chord, chord), 0.0, 1.0)
    return float(np.linalg.norm(points - a - along[:, None] * chord, axis=1).max())
