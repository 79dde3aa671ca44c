"""Joint and Cartesian trajectories with Robotics Toolbox semantics: quintic, trapezoidal, SE(3), via points.

The functions follow Peter Corke's Robotics Toolbox for Python (``roboticstoolbox.tools.trajectory``,
version 1.5, the same definitions as the toolbox's MATLAB ``jtraj``, ``ctraj``, ``mtraj(@tpoly/@lspb)``
and ``mstraj``); each docstring says where the numbers match RTB's and the few places where manipkit
deliberately differs (RTB's time labels of an int count, a corner where RTB divides by zero).

Conventions: joint arrays are ``(N, n)``, sample by joint in the chain's order (rad or m); times ``(N,)``
in seconds (or steps, where the docstring says so); velocities and accelerations are derivatives with
respect to that time. Poses are ``T_base_tip`` ``(N, 4, 4)`` in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from manipkit import bounds
from manipkit.errors import OptionError
from manipkit.paths.poses import MAX_WAYPOINTS, PosePath, interpolate_poses
from manipkit.text import printable

__all__ = ["PROFILES", "Trajectory", "ctraj", "jtraj", "mstraj", "trapezoidal", "values_per_item"]

#: The time scalings :func:`ctraj` takes.
PROFILES = ("trapezoidal", "quintic")


@dataclass(frozen=True)
class Trajectory:
    """A sampled joint trajectory: times and, per sample, positions, velocities and accelerations.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Sample times, increasing (seconds, or steps where the function that made it says so).
    q : ndarray, shape (N, n)
        Joint positions (rad or m), joints in the chain's order.
    qd, qdd : ndarray, shape (N, n)
        First and second derivatives of ``q`` with respect to ``t``.

    The arrays are read-only.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray

    def __post_init__(self):
        for name in ("t", "q", "qd", "qdd"):
            array = np.array(getattr(self, name), dtype=float)
            array.flags.writeable = False
            object.__setattr__(self, name, array)

    def __len__(self) -> int:
        return len(self.t)


# --------------------------------------------------------------------------
# argument checks


def _joints(value, what: str, n: int | None = None) -> np.ndarray:
    """A finite float vector (n,), else one line naming ``what``."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise OptionError(f"{what} must be numbers, got {printable(repr(value))[:60]}") from None
    array = np.atleast_1d(array)
    if array.ndim != 1 or (n is not None and len(array) != n):
        expected = f"({n},), one value per joint" if n is not None else "(n,)"
        raise OptionError(f"{what} has shape {array.shape}; give shape {expected}")
    if not np.isfinite(array).all():
        index = int(np.argmin(np.isfinite(array)))
        raise OptionError(f"{what}[{index}] is {array[index]}; give finite numbers")
    return array


def _times(t, what: str = "t") -> tuple[np.ndarray, bool]:
    """(times, given): a time vector as given (finite, strictly increasing, at least 2), or ``arange(t)`` for a
    count (``given`` False)."""
    if isinstance(t, (int, np.integer)) and not isinstance(t, bool):
        return np.arange(bounds.count(t, f"{what} (a count of samples)", minimum=2, maximum=MAX_WAYPOINTS,
                                      error=OptionError), dtype=float), False
    if np.ndim(t) == 0:
        raise OptionError(f"{what} {printable(repr(t))[:40]}: give a count of samples (an int, at least 2) or a time "
                          "vector in seconds")
    times = _joints(t, what)
    bounds.count(len(times), f"{what}: samples", minimum=2, maximum=MAX_WAYPOINTS, error=OptionError)
    steps = np.diff(times)
    if (steps <= 0.0).any():
        index = int(np.argmax(steps <= 0.0)) + 1
        raise OptionError(f"{what}[{index}] = {times[index]:g} is not after {what}[{index - 1}] = {times[index - 1]:g}; "
                          "times must increase strictly")
    return times, True


def _ends(q0, q1) -> tuple[np.ndarray, np.ndarray]:
    q0 = _joints(q0, "q0")
    return q0, _joints(q1, "q1", len(q0))


# --------------------------------------------------------------------------
# one segment


def jtraj(q0, q1, t, *, qd0=None, qd1=None) -> Trajectory:
    """Quintic joint trajectory from ``q0`` to ``q1`` (RTB ``jtraj``; MATLAB toolbox ``jtraj``).

    Each joint follows ``q(s) = A s^5 + B s^4 + C s^3 + E s + F`` in the normalised time
    ``s = (t - t_0) / T``, ``T = t_end - t_0``, with the coefficients that give ``q(0) = q0``,
    ``q(1) = q1``, velocities ``qd0`` and ``qd1`` at the ends (zero by default) and zero acceleration at the
    start (RTB's polynomial: the ``s^2`` coefficient is 0, so with non-zero boundary velocities the final
    acceleration is not zero in general)::

        A = 6 dq - 3 (qd1 + qd0) T        B = -15 dq + (8 qd0 + 7 qd1) T
        C = 10 dq - (6 qd0 + 4 qd1) T     E = qd0 T,  F = q0,  dq = q1 - q0

    Parameters
    ----------
    q0, q1 : array_like, shape (n,)
        Start and end joint positions (rad or m). ``q0 == q1`` gives a constant trajectory.
    t : int or array_like, shape (N,)
        A count of samples (at least 2): time runs from 0 to 1 in ``t`` evenly spaced samples, as RTB's
        docstring says (RTB labels those samples ``t * s``; manipkit labels them ``s``, the time its
        velocities are derivatives by). Or a time vector in seconds, strictly increasing; RTB assumes it
        starts at 0, manipkit measures from its first entry (the same numbers when it starts at 0).
    qd0, qd1 : array_like, shape (n,), keyword-only
        Velocities at the ends (per second of ``t``); None is zero.

    Returns
    -------
    Trajectory
        ``t`` (N,), and ``q``, ``qd``, ``qdd`` (N, n): RTB's numbers to rounding.

    Raises
    ------
    OptionError
        Shapes that disagree, values that are not finite, a count below 2, times not strictly increasing.

    Examples
    --------
    >>> traj = jtraj([0.0, 1.0], [1.0, 1.0], 5)
    >>> traj.q[:, 0].round(6), traj.qd[2]  # midway: q = 1/2, the peak speed 15/8 of the average
    (array([0.      , 0.103516, 0.5     , 0.896484, 1.      ]), array([1.875, 0.   ]))
    """
    q0, q1 = _ends(q0, q1)
    times, given = _times(t)
    if not given:
        times = np.linspace(0.0, 1.0, len(times))
    duration = times[-1] - times[0]
    v0 = np.zeros_like(q0) if qd0 is None else _joints(qd0, "qd0", len(q0))
    v1 = np.zeros_like(q0) if qd1 is None else _joints(qd1, "qd1", len(q0))
    dq = q1 - q0
    A = 6.0 * dq - 3.0 * (v1 + v0) * duration
    B = -15.0 * dq + (8.0 * v0 + 7.0 * v1) * duration
    C = 10.0 * dq - (6.0 * v0 + 4.0 * v1) * duration
    E = v0 * duration
    s = ((times - times[0]) / duration)[:, None]
    q = (((A * s + B) * s + C) * s * s + E) * s + q0
    qd = ((5.0 * A * s + 4.0 * B) * s + 3.0 * C) * s * s + E
    qdd = ((20.0 * A * s + 12.0 * B) * s + 6.0 * C) * s
    return Trajectory(times, q, qd / duration, qdd / duration**2)


def trapezoidal(q0, q1, t, *, v=None) -> Trajectory:
    """Trapezoidal-velocity joint trajectory: parabolic blend, linear segment, parabolic blend.

    RTB's ``mtraj(trapezoidal, q0, q1, t)`` (the MATLAB toolbox's ``mtraj(@lspb, ...)``), with a cruise
    speed per joint. Each joint, over ``T = t_end - t_0``, with ``tau = t - t_0``, cruise velocity ``V``
    (signed as ``q1 - q0``), blend time ``tb = (q0 - q1 + V T) / V`` and acceleration ``a = V / tb``::

        tau <= tb:           q = q0 + a tau^2 / 2
        tau <= T - tb:       q = (q0 + q1 - V T) / 2 + V tau
        otherwise:           q = q1 - a T^2 / 2 + a T tau - a tau^2 / 2

    The velocity-time graph is a trapezoid of area ``q1 - q0``: ``V (T - tb) = q1 - q0``.

    Parameters
    ----------
    q0, q1 : array_like, shape (n,)
        Start and end positions; a joint with ``q0 == q1`` stays still.
    t : int or array_like, shape (N,)
        A count of samples: times are the steps ``0, 1, ..., t - 1`` (as RTB; velocities are then per step).
        Or a time vector in seconds, strictly increasing.
    v : float or array_like, shape (n,), keyword-only
        Cruise speed magnitude per joint (or one for all); None: ``1.5 |q1 - q0| / T`` (RTB's default).
        A moving joint needs ``|q1 - q0| / T < v <= 2 |q1 - q0| / T`` (at the upper end the linear segment
        vanishes and the profile is a triangle; at the lower end the blends would take no time, which RTB
        accepts and answers with NaN; refused here).

    Returns
    -------
    Trajectory
        ``t`` (N,) and ``q``, ``qd``, ``qdd`` (N, n): RTB's numbers to rounding.

    Raises
    ------
    OptionError
        A speed outside its range (the joint and the range named), or bad shapes and times as :func:`jtraj`.

    Examples
    --------
    >>> traj = trapezoidal([0.0], [3.0], [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0], v=1.5)
    >>> traj.qd[:, 0]  # tb = (0 - 3 + 4.5) / 1.5 = 1 s, a = 1.5 rad/s^2
    array([0.  , 0.75, 1.5 , 1.5 , 1.5 , 0.75, 0.  ])
    """
    q0, q1 = _ends(q0, q1)
    times, _ = _times(t)
    duration = times[-1] - times[0]
    dq = q1 - q0
    if v is None:
        V = dq / duration * 1.5  # RTB's order of operations, so a sample at a blend's end falls on RTB's side
    else:
        speed = np.abs(_joints(v, "v", len(q0)) if np.ndim(v) else np.full(len(q0), float(_joints(v, "v")[0])))
        low, high = np.abs(dq) / duration, 2.0 * np.abs(dq) / duration
        bad = (dq != 0.0) & ~((speed > low) & (speed <= high * (1.0 + 1e-12)))
        if bad.any():
            j = int(np.argmax(bad))
            raise OptionError(f"v[{j}] = {speed[j]:g}: joint {j} moves {dq[j]:g} in {duration:g}, so its cruise speed must "
                              f"be above {low[j]:.6g} and at most {high[j]:.6g}")
        V = speed * np.sign(dq)
    moving = V != 0.0
    tb = np.where(moving, (q0 - q1 + V * duration) / np.where(moving, V, 1.0), np.inf)
    a = np.where(moving, V / np.where(moving, tb, 1.0), 0.0)
    tau = (times - times[0])[:, None]
    first, linear = tau <= tb, tau <= duration - tb
    q = np.where(first, q0 + a / 2.0 * tau**2,
                 np.where(linear, (q1 + q0 - V * duration) / 2.0 + V * tau,
                          q1 - a / 2.0 * duration**2 + a * duration * tau - a / 2.0 * tau**2))
    qd = np.where(first, a * tau, np.where(linear, V, a * duration - a * tau))
    qdd = np.where(first, a, np.where(linear, 0.0, -a)) + np.zeros_like(tau)
    return Trajectory(times, q, qd, qdd)


def ctraj(T0, T1, t, *, profile: str = "trapezoidal") -> PosePath:
    """Cartesian trajectory from ``T0`` to ``T1`` (RTB ``ctraj``; MATLAB toolbox ``ctraj``).

    The path fraction ``s(t)`` follows a time scaling from 0 to 1, and the pose at ``s`` is
    ``interpolate_poses(T0, T1, s)``: translation linear, rotation by slerp (RTB ``SE3.interp``).

    Parameters
    ----------
    T0, T1 : array_like, shape (4, 4)
        ``T_base_tip`` at the start and the end.
    t : int or array_like, shape (N,)
        A count of samples, or a time vector in seconds (strictly increasing).
    profile : {"trapezoidal", "quintic"}, keyword-only
        ``s(t)``: :func:`trapezoidal` from 0 to 1 with RTB's default cruise speed (RTB's ``ctraj``), or the
        quintic of :func:`jtraj` (zero velocity and acceleration at both ends).

    Returns
    -------
    PosePath
        ``poses`` (N, 4, 4) and ``t``: the given time vector, or None for a count (the poses then carry no
        time; RTB's ``ctraj`` returns poses only).

    Examples
    --------
    >>> from manipkit.spatial import transform_from_xyz_rpy
    >>> path = ctraj(np.eye(4), transform_from_xyz_rpy([1.0, 0, 0]), 5)
    >>> path.poses[:, 0, 3]  # over 4 steps: V = 3/8 per step, blends of 4/3 steps, s(1) = (9/32) / 2
    array([0.      , 0.140625, 0.5     , 0.859375, 1.      ])
    """
    if profile not in PROFILES:
        raise OptionError(f"profile {printable(repr(profile))[:40]}: give one of {', '.join(PROFILES)}")
    scaling = trapezoidal if profile == "trapezoidal" else jtraj
    times, given = _times(t)
    s = scaling([0.0], [1.0], times if given else len(times)).q[:, 0]
    return PosePath(interpolate_poses(T0, T1, s), times if given else None)


# --------------------------------------------------------------------------
# via points


def _mrange(start: float, stop: float, step: float) -> np.ndarray:
    """MATLAB's ``start:step:stop`` with the ends rounded to whole steps (RTB's ``mrange``): ends included."""
    return np.arange(round(start / step), round(stop / step) + 1) * step


def values_per_item(value, what: str, count: int, *, item: str = "joint", positive: bool = True) -> np.ndarray:
    """``value`` as a float vector (count,): one number for all or one per ``item``, finite, positive (or, with
    ``positive=False``, non-negative); else :class:`~manipkit.errors.OptionError` naming ``what`` and the index."""
    array = _joints(value, what)
    if array.size == 1:
        array = np.full(count, float(array[0]))
    if len(array) != count:
        raise OptionError(f"{what} has {len(array)} values; give one number or one per {item} ({count})")
    bad = array <= 0.0 if positive else array < 0.0
    if bad.any():
        index = int(np.argmax(bad))
        raise OptionError(f"{what}[{index}] = {array[index]:g}; give {'positive' if positive else 'non-negative'} values")
    return array


def mstraj(via, dt: float, tacc, *, qdmax=None, tsegment=None, q0=None, qd0=None, qdf=None) -> Trajectory:
    """Multi-segment joint trajectory through via points, with velocity limits and blends (RTB ``mstraj``).

    Between consecutive via points each joint moves linearly; at each via point a quintic blend of
    ``tacc`` seconds (:func:`jtraj` with the incoming and outgoing velocities) joins the segments, so the
    motion passes near, not through, an intermediate via point; it starts at the first and ends at the last
    exactly. Each segment takes, with ``qdmax`` given, the time its slowest joint needs at its speed limit
    plus the blend (rounded up to whole ``dt``, at least twice the blend time), or the given ``tsegment``.
    Segments concatenate: one sample every ``dt``.

    This is RTB's algorithm and its numbers (``tacc`` rounded up to whole steps; the first blend and the
    last take half the blend time). Two differences: RTB drops the sample at time 0 and labels its first
    sample (time ``dt``) 0; manipkit keeps it, so ``q[1:]`` here is RTB's ``q`` and ``t[1:] - dt`` its ``t``.
    A segment left no time for its linear part (RTB then blends from a stale point, or divides by zero)
    is refused.

    Parameters
    ----------
    via : array_like, shape (M, n)
        Via points, joint by joint; the first is the start unless ``q0`` is given.
    dt : float
        Sample interval, seconds (positive).
    tacc : float or array_like, shape (segments,)
        Blend (acceleration) time at the start of each segment, seconds (non-negative).
    qdmax : float or array_like, shape (n,), keyword-only
        Speed limit of each joint (or one for all), rad/s or m/s; give exactly one of ``qdmax`` and
        ``tsegment``.
    tsegment : array_like, shape (segments,), keyword-only
        Duration of each segment, seconds.
    q0 : array_like, shape (n,), keyword-only
        Start, when it is not the first row of ``via``.
    qd0, qdf : array_like, shape (n,), keyword-only
        Velocity at the start and at the end; zero by default.

    Returns
    -------
    Trajectory
        ``t = dt * arange(N)``, ``q``, ``qd``, ``qdd`` (N, n).

    Raises
    ------
    OptionError
        Both or neither of ``qdmax`` and ``tsegment``, sizes that do not match, non-positive limits or
        times, fewer than one segment, a segment without a linear part, or more than
        :data:`~manipkit.paths.poses.MAX_WAYPOINTS` samples.

    Examples
    --------
    >>> traj = mstraj([[0.0], [2.0], [1.0]], 0.1, 0.2, qdmax=1.0)  # segments of 0.1 + 2/1 s and 0.2 + 1/1 s
    >>> round(float(traj.t[-1]), 9), traj.q[-1]
    (3.3, array([1.]))
    """
    # Over 80 lines: the docstring states RTB's semantics and both differences; the body is one loop of 40 lines.
    start, targets, step, limits, durations, blends, velocity, final_velocity = _mstraj_arguments(
        via, dt, tacc, qdmax, tsegment, q0, qd0, qdf)
    segments, n = targets.shape
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    previous, blend_from, half, samples = start, start, 0.0, 0
    for seg in range(segments):
        target = targets[seg]
        blend = math.ceil(blends[seg] / step) * step
        half = math.ceil(blend / 2.0 / step) * step
        blend_time = half if seg == 0 else blend
        dq = target - previous
        if limits is not None:
            needed = blend_time + np.ceil(np.abs(dq) / limits / step) * step
            duration = max(float(needed.max()), 2.0 * blend)
        else:
            duration = float(durations[seg])
        linear_count = round((duration - half) / step) - round((half + step) / step) + 1  # _mrange's length
        if linear_count <= 0:
            raise OptionError(f"mstraj segment {seg}: {duration:g} s leaves no time for its linear part after blends of "
                              f"{half:g} s at each end; give a longer tsegment or a tacc of at least 2 dt")
        samples += linear_count + round(blend_time / step) + 1
        bounds.count(samples, "mstraj: samples", maximum=MAX_WAYPOINTS, error=OptionError)  # before allocating
        linear_times = _mrange(half + step, duration - half, step)
        cruise = dq / duration
        if blend_time > 0.0:
            joined = jtraj(blend_from, previous + half * cruise, _mrange(0.0, blend_time, step),
                           qd0=velocity, qd1=cruise)
            first = 0 if not parts else 1  # the start sample once, at t = 0
            parts.append((joined.q[first:], joined.qd[first:], joined.qdd[first:]))
        elif not parts:
            parts.append((start[None], velocity[None], np.zeros((1, n))))
        s = (linear_times / duration)[:, None]
        linear = (1.0 - s) * previous + s * target
        parts.append((linear, np.broadcast_to(cruise, linear.shape), np.zeros_like(linear)))
        previous, blend_from, velocity = target, linear[-1], cruise
    if half > 0.0:
        bounds.count(samples + round(half / step), "mstraj: samples", maximum=MAX_WAYPOINTS, error=OptionError)
        joined = jtraj(blend_from, previous, _mrange(0.0, half, step), qd0=velocity, qd1=final_velocity)
        parts.append((joined.q[1:], joined.qd[1:], joined.qdd[1:]))
    q, qd, qdd = (np.concatenate([p[i] for p in parts]) for i in range(3))
    return Trajectory(step * np.arange(len(q)), q, qd, qdd)


def _mstraj_arguments(via, dt, tacc, qdmax, tsegment, q0, qd0, qdf):
    """:func:`mstraj`'s arguments checked: start, targets (segments, n), dt, limits or durations, blend times,
    start and end velocities."""
    try:
        via = np.asarray(via, dtype=float)
    except (TypeError, ValueError):
        via = None
    if via is None or via.ndim != 2 or not np.isfinite(via).all():
        raise OptionError("via must be a finite (M, n) array of via points, joint by joint")
    if q0 is None:
        start, targets = via[0], via[1:]
    else:
        start, targets = _joints(q0, "q0", via.shape[1]), via
    segments, n = targets.shape
    if segments == 0:
        raise OptionError("via: one point gives no segment; give at least two via points (or q0 and one)")
    step = float(values_per_item(dt, "dt", 1, item="step")[0])
    if (qdmax is None) == (tsegment is None):
        raise OptionError("mstraj: give exactly one of qdmax (speed limits) and tsegment (segment times)")
    limits = values_per_item(qdmax, "qdmax", n) if qdmax is not None else None
    durations = values_per_item(tsegment, "tsegment", segments, item="segment") if tsegment is not None else None
    blends = values_per_item(tacc, "tacc", segments, item="segment", positive=False)
    velocity = np.zeros(n) if qd0 is None else _joints(qd0, "qd0", n)
    final_velocity = np.zeros(n) if qdf is None else _joints(qdf, "qdf", n)
    return start, targets, step, limits, durations, blends, velocity, final_velocity
