"""Joint torques along a trajectory: inverse dynamics (Pinocchio's recursive Newton-Euler, ``rnea``), split into the
gravity, inertial and Coriolis/centrifugal terms, against the effort limits.

Conventions (docs/architecture.md), restated:

- ``tau = M(q) qdd + C(q, qd) qd + g(q)``, the torque each motor produces
  (N m, N for prismatic joints), as ``pinocchio.rnea(q, qd, qdd)``: at
  ``qd = qdd = 0`` it is the static torque ``g(q)`` of
  :mod:`manipkit.statics.torques`. The parts: ``gravity = g(q)``,
  ``inertial = M(q) qdd``, ``coriolis = C(q, qd) qd``.
- Rows are samples of the trajectory, columns the chain's joints; joints off
  the chain hold ``q_rest`` at rest. A mimic joint moves with its leader
  (``v = S qd``, ``a = S qdd``) and its torque is folded onto the leader
  (``S^T tau``).
- ``gravity`` in the root link's axes (m/s^2); a :class:`~manipkit.statics.torques.Payload`
  is added to the tip link (its inertia, about its CoG in the tip's axes, counts here).
- The *share* of a term on a joint is ``sum_t |term| / sum_t (|gravity| +
  |inertial| + |coriolis|)`` over the samples (the three shares add to 1;
  NaN for a joint that holds no torque, :data:`SHARE_TOL`).

Examples
--------
>>> import numpy as np, manipkit
>>> robot = manipkit.load("planar_2r")
>>> Q = np.zeros((3, 2)); Qd = np.ones((3, 2)); Qdd = np.zeros((3, 2))
>>> answer = trajectory_torques(robot, Q, Qd, Qdd, gravity=(0, 0, -9.81))  # gravity across the plane
>>> bool(np.allclose(answer.gravity, 0)) and bool(np.allclose(answer.tau, answer.coriolis))
True
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit import bounds
from manipkit.errors import OptionError
from manipkit.kinematics.chain import chain_of, joint_array
from manipkit.statics.torques import GRAVITY, Payload, effort_limits

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain
    from manipkit.kinematics.robot import Robot

__all__ = ["SHARE_TOL", "TrajectoryTorques", "trajectory_torques"]

#: A joint whose torques add up to at most this per sample (N m) has no shares (NaN): they would be rounding noise.
SHARE_TOL = 1e-9


@dataclass(frozen=True)
class TrajectoryTorques:
    """The answer of :func:`trajectory_torques` (arrays (T, n) over the samples, or (n,) per joint).

    Attributes
    ----------
    joint_names : tuple of str
    times : ndarray (T,)
        s (the sample index when none were given).
    tau, gravity, inertial, coriolis : ndarray (T, n)
    effort_limit : ndarray (n,)
        NaN where the URDF gives none.
    share : dict
        ``"gravity"``, ``"inertial"``, ``"coriolis"`` -> (n,) fractions (see the module).
    first_over : tuple (int, str) or None
        (sample index, joint) of the first sample where a torque exceeds its effort limit.
    peak : ndarray (n,)
        The largest ``|tau|`` per joint.
    """

    joint_names: tuple
    times: np.ndarray
    tau: np.ndarray
    gravity: np.ndarray
    inertial: np.ndarray
    coriolis: np.ndarray
    effort_limit: np.ndarray
    share: dict
    first_over: tuple | None
    peak: np.ndarray


def _rows(chain: Chain, values, what: str) -> np.ndarray:
    array = joint_array(values)
    if array.ndim != 2 or array.shape[1] != chain.n:
        raise OptionError(f"{what}: give one row of {chain.n} values per sample ({', '.join(chain.joint_names)}), "
                          f"got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise OptionError(f"{what}: every value must be a finite number")
    return array


def trajectory_torques(robot: Robot | Chain, Q, Qd, Qdd, *, times=None, payload: Payload | None = None,
                       gravity=GRAVITY, base: str | None = None, tip: str | None = None,
                       q_rest=None) -> TrajectoryTorques:
    """Inverse dynamics along samples ``Q``, ``Qd``, ``Qdd`` (T, n) of the chain (rad, rad/s, rad/s^2; m for slides).

    ``times`` (T,) in s, increasing (default: the sample index). See the module for the convention.
    """
    import pinocchio as pin

    chain = chain_of(robot, "trajectory_torques", base=base, tip=tip)
    Q, Qd, Qdd = (_rows(chain, v, what) for v, what in ((Q, "q"), (Qd, "qd"), (Qdd, "qdd")))
    if not Q.shape == Qd.shape == Qdd.shape:
        raise OptionError(f"q, qd and qdd need the same number of samples; got {len(Q)}, {len(Qd)}, {len(Qdd)}")
    times = np.arange(len(Q), dtype=float) if times is None else np.asarray(times, dtype=float).reshape(-1)
    if times.shape != (len(Q),) or not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
        raise OptionError(f"times: give {len(Q)} finite, increasing times (s), one per sample")
    g = bounds.gravity(gravity, "gravity")
    model = _model_with(chain, payload, g)
    data = model.createData()
    robot = chain.robot
    S = robot.velocity_map()
    rest = robot.q() if q_rest is None else robot.q(q_rest)
    n_robot = len(robot.joint_names)
    parts = np.empty((3, len(Q), chain.n))
    zero = np.zeros(model.nv)
    for t in range(len(Q)):
        whole = rest.copy()
        whole[chain.columns] = Q[t]
        config = robot.pinocchio_configuration(whole)
        v, a = np.zeros(n_robot), np.zeros(n_robot)
        v[chain.columns], a[chain.columns] = Qd[t], Qdd[t]
        v, a = S @ v, S @ a
        static = np.array(pin.rnea(model, data, config, zero, zero))
        inertial = np.array(pin.rnea(model, data, config, zero, a)) - static
        coriolis = np.array(pin.rnea(model, data, config, v, zero)) - static
        for k, part in enumerate((static, inertial, coriolis)):
            parts[k, t] = (S.T @ part)[chain.columns]
    tau = parts.sum(axis=0)
    limits = effort_limits(chain)
    over = np.abs(tau) > limits  # NaN limits compare False
    first = None
    if over.any():
        t = int(np.flatnonzero(over.any(axis=1))[0])
        first = (t, chain.joint_names[int(np.flatnonzero(over[t])[0])])
    magnitude = np.abs(parts).sum(axis=1)  # (3, n)
    total = magnitude.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        shares = np.where(total > SHARE_TOL * max(len(Q), 1), magnitude / total, np.nan)
    share = dict(zip(("gravity", "inertial", "coriolis"), shares))
    return TrajectoryTorques(chain.joint_names, times, tau, parts[0], parts[1], parts[2], limits, share, first,
                             np.abs(tau).max(axis=0) if len(tau) else np.zeros(chain.n))


def _model_with(chain: Chain, payload: Payload | None, gravity: np.ndarray):
    """A copy of the robot's Pinocchio model with ``gravity`` and the payload added to the tip's joint body."""
    import pinocchio as pin

    robot = chain.robot
    model = robot.model.copy()
    model.gravity = pin.Motion(gravity, np.zeros(3))
    if payload is not None:
        if not isinstance(payload, Payload):
            raise OptionError("payload: give a manipkit.statics.Payload(mass, cog, inertia)")
        if payload.mass > 0:
            tip = model.frames[robot.frame_id(chain.tip)]
            inertia = np.zeros((3, 3)) if payload.inertia is None else payload.inertia
            body = tip.placement.act(pin.Inertia(payload.mass, payload.cog, inertia))
            model.inertias[tip.parentJoint] = model.inertias[tip.parentJoint] + body
    return model
