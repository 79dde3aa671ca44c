"""A planned joint path in time: :func:`retime_plan` (the policy of limits) over :func:`~manipkit.paths.retiming.retime`.

:func:`~manipkit.paths.plan.plan_path` gives a joint path through the waypoints; this module turns it into a
motion through them, in order, rest to rest, within every joint's velocity and acceleration limit and at no
more than a tool speed, by TOPP-RA. It holds the choice of limits so that the command line and Python agree:

- velocity: each joint's URDF ``<limit velocity>`` times ``velocity_scale`` (the plan's, by default);
- acceleration: a URDF has no acceleration limit (Pinocchio reads none), so unless ``acceleration_limits``
  are given each joint's is its velocity limit reached from rest in :data:`ACCELERATION_TIME` seconds,
  ``a_j = acceleration_scale * v_j / ACCELERATION_TIME`` (UR5: 3.15 rad/s over 0.5 s, 6.3 rad/s^2);
- tool speed: the speed of the tip frame's origin in the base frame (m/s), from the chain's Jacobian.

Conventions: joint arrays ``(M, n)`` in the chain's joint order (rad or m), times in seconds.
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.errors import OptionError
from manipkit.paths.trajectory import values_per_item

__all__ = ["ACCELERATION_TIME", "default_acceleration_limits", "retime_plan", "trajectory_dict"]

#: Seconds from rest to a joint's velocity limit under the default acceleration limit (no URDF gives one).
ACCELERATION_TIME = 0.5


def default_acceleration_limits(velocity_limits, acceleration_scale: float = 1.0) -> np.ndarray:
    """``acceleration_scale * v / ACCELERATION_TIME`` per joint (rad/s^2 or m/s^2), from velocity limits ``v``."""
    scale = float(acceleration_scale)
    if not (math.isfinite(scale) and 0.0 < scale <= 1e6):
        raise OptionError(f"acceleration_scale {scale:g}: give a positive factor of the default acceleration limits")
    return scale * np.asarray(velocity_limits, dtype=float) / ACCELERATION_TIME


def retime_plan(plan, chain, *, speed: float | None = None, velocity_scale: float | None = None,
                acceleration_scale: float = 1.0, acceleration_limits=None, dt: float = 1e-3):
    """The fastest motion, rest to rest, through the waypoints of a feasible ``plan`` in order (TOPP-RA).

    Parameters
    ----------
    plan : manipkit.paths.plan.PathPlan
        A feasible plan without reconfiguration breaks.
    chain : manipkit.kinematics.chain.Chain
        The chain it was planned for (``robot.chain(base, tip)``): the limits and the tool speed.
    speed : float, optional
        Largest speed of the tip frame's origin (m/s); None: only the joints' limits bound the motion.
    velocity_scale : float, optional
        Fraction of each URDF velocity limit the motion may use; None: the plan's (``resolution``).
    acceleration_scale : float
        Factor on the default acceleration limits (:data:`ACCELERATION_TIME`); ignored with
        ``acceleration_limits``.
    acceleration_limits : float or array_like, shape (n,), optional
        Each joint's acceleration limit (rad/s^2 or m/s^2), instead of the default.
    dt : float
        Sample interval of the result (s); every waypoint's time is a sample too.

    Returns
    -------
    manipkit.paths.retiming.RetimeResult

    Raises
    ------
    OptionError
        An infeasible plan, one of a single waypoint, one with breaks, a joint without a URDF velocity limit, or bad limits.

    Examples
    --------
    >>> import numpy as np, manipkit
    >>> from manipkit.paths import line_poses, retime_plan
    >>> chain = manipkit.load("ur5").chain("base_link", "tool0")
    >>> T0 = chain.fk([0.3, -1.2, 1.4, -1.8, -1.5, 0.2])
    >>> T1 = T0.copy(); T1[2, 3] += 0.1
    >>> plan = manipkit.plan_path(chain, line_poses(T0, T1, step=0.01), speed=0.05)
    >>> motion = retime_plan(plan, chain, speed=0.05)
    >>> motion.max_tool_speed <= 0.05, round(motion.duration, 1)   # 0.1 m at 0.05 m/s, and the blends
    (True, 2.0)
    """
    from manipkit.paths.plan import velocity_limits
    from manipkit.paths.retiming import retime

    if not plan.feasible:
        raise OptionError("an infeasible plan has no joint path to retime")
    if plan.reconfigurations:
        raise OptionError(f"the plan breaks at waypoint(s) {', '.join(map(str, plan.reconfigurations))} (retract, "
                          "reconfigure): retime each piece, plan.q[a:b], on its own")
    if len(plan.q) < 2:
        raise OptionError("the path has one waypoint: there is no motion to retime")
    if tuple(chain.joint_names) != tuple(plan.joint_names):
        raise OptionError("the chain's joints are not the plan's: give the chain the plan was made for")
    scale = plan.resolution.get("velocity_scale", 1.0) if velocity_scale is None else float(velocity_scale)
    v = velocity_limits(chain)
    if not np.isfinite(v).all():
        missing = chain.joint_names[int(np.argmax(~np.isfinite(v)))]
        raise OptionError(f"joint {missing} has no velocity limit in the description: give limits to retime() directly")
    v = values_per_item(v * scale, "velocity limits", chain.n)
    a = (default_acceleration_limits(v / scale, acceleration_scale) if acceleration_limits is None else
         values_per_item(acceleration_limits, "acceleration_limits", chain.n))
    return retime(plan.q, velocity_limits=v, acceleration_limits=a, tool_speed=speed, chain=chain if speed else None,
                  dt=dt, joint_names=plan.joint_names)


def trajectory_dict(result) -> dict:
    """JSON-safe: ``t``, ``q``, ``qd``, ``qdd`` (lists, chain order), ``waypoint_times``, ``duration``, ``slowdowns``."""
    return {
        "t": result.t.tolist(), "q": result.q.tolist(), "qd": result.qd.tolist(), "qdd": result.qdd.tolist(),
        "waypoint_times": result.waypoint_times.tolist(), "duration": float(result.duration),
        "slowdowns": [{"segment": s.segment, "limit": s.limit, "joint": s.joint, "share": float(s.share)}
                      for s in result.slowdowns],
    }
