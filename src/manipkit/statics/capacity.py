"""Payload capacity: the largest payload mass a chain can hold at a pose, for a given centre-of-gravity offset.

The torque is affine in the payload's mass: ``tau(m) = a + m b``, with ``a``
the torque without the payload (the arm's own weight and any wrenches) and
``b`` the torque one kilogram at the CoG adds (:mod:`manipkit.statics.torques`,
``tau = g(q) - sum J^T w``). Each joint with an effort limit allows
``lower_k <= a_k + m b_k <= upper_k``, so

- ``b_k > 0``: ``m <= (upper_k - a_k) / b_k``; ``b_k < 0``: ``m <= (lower_k - a_k) / b_k``;
- ``|b_k| <= lever_tol`` (the CoG on the joint's axis, or the axis along
  gravity): the joint sets no bound, so the answer stays finite while
  another joint bounds it (infinite, with no saturating joint, only when none does);
- ``a_k`` already outside its limits: "gravity alone saturates": the
  capacity is 0 and that joint is named.

Limits may be asymmetric (``effort=(lower, upper)``); by default they are the
URDF's ``-effort, +effort``. Joints without a limit bound nothing.

Examples
--------
>>> import manipkit
>>> robot = manipkit.load("planar_2r")  # 1 kg links of 1 m, effort 10 N m; gravity in the plane along -y
>>> cap = payload_capacity(robot, [0.0, 0.0], gravity=(0.0, -9.81, 0.0))
>>> cap.saturating_joint, float(cap.max_mass), bool(cap.gravity_saturates)  # joint1 holds 9.81 (0.5 + 1.5) > 10 N m
('joint1', 0.0, True)
>>> cap = payload_capacity(robot, [np.pi / 2, 0.0], gravity=(0.0, -9.81, 0.0))  # the arm along gravity: no lever
>>> cap.saturating_joint, float(cap.max_mass)
(None, inf)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.errors import OptionError
from manipkit.statics.torques import GRAVITY, Payload, static_torques

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain
    from manipkit.kinematics.robot import Robot

__all__ = ["LEVER_TOL", "PayloadCapacity", "capacity_from_parts", "payload_capacity"]

#: A joint whose torque changes by at most this much per kg of payload (N m / kg) bounds no mass.
LEVER_TOL = 1e-12


@dataclass(frozen=True)
class PayloadCapacity:
    """The answer of :func:`payload_capacity` (arrays (...,) over the configurations given).

    Attributes
    ----------
    max_mass : ndarray or float
        kg; 0 when gravity alone saturates, ``inf`` when no joint bounds the mass.
    saturating : ndarray of int
        The joint that reaches its limit at ``max_mass`` (-1: none).
    gravity_saturates : ndarray of bool
        The torque without a payload is already outside a joint's limits.
    joint_names : tuple of str
    per_kg, unloaded : ndarray (..., n)
        ``b`` and ``a`` of the module's ``tau(m) = a + m b``.
    lower, upper : ndarray (n,)
        The limits used (NaN: none).
    inertia_grade : str
        The robot's inertia-audit grade (:func:`manipkit.statics.audit.inertia_grade`).
    """

    max_mass: np.ndarray
    saturating: np.ndarray
    gravity_saturates: np.ndarray
    joint_names: tuple
    per_kg: np.ndarray
    unloaded: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    inertia_grade: str = ""

    @property
    def saturating_joint(self) -> str | None:
        """The saturating joint's name for one configuration (None: none)."""
        k = int(self.saturating)
        return None if k < 0 else self.joint_names[k]


def capacity_from_parts(unloaded, per_kg, lower, upper, *, lever_tol: float = LEVER_TOL):
    """(max_mass, saturating, gravity_saturates) from ``tau(m) = unloaded + m per_kg`` (..., n) and limits ``lower``,
    ``upper`` (n,) (NaN: none): one compiled pass over the rows
    (:func:`manipkit.statics.gravity_kernel.capacity_rows`, the module's rule).

    Examples
    --------
    >>> m, k, over = capacity_from_parts(np.array([1.0, 2.0]), np.array([0.5, 0.0]), np.array([-4.0, -4.0]),
    ...                                  np.array([4.0, 4.0]))
    >>> float(m), int(k), bool(over)
    (6.0, 0, False)
    """
    from manipkit.statics.gravity_kernel import capacity_rows_kernel

    a, b = np.asarray(unloaded, dtype=float), np.asarray(per_kg, dtype=float)
    shape = np.broadcast_shapes(a.shape, b.shape)
    n, rows = shape[-1], math.prod(shape[:-1])
    lower, upper = (np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), (n,))) for x in (lower, upper))
    a, b = (np.ascontiguousarray(np.broadcast_to(x, shape).reshape(rows, n)) for x in (a, b))
    max_mass, saturating, over = np.empty(rows), np.empty(rows, dtype=np.intp), np.empty(rows, dtype=np.bool_)
    capacity_rows_kernel()(a, b, lower, upper, float(lever_tol), max_mass, saturating, over)
    if len(shape) == 1:  # one row: numpy scalars, as numpy's reductions give them
        return max_mass[0], saturating.reshape(()), over[0]
    return max_mass.reshape(shape[:-1]), saturating.reshape(shape[:-1]), over.reshape(shape[:-1])


def payload_capacity(robot: Robot | Chain, q, *, cog=(0.0, 0.0, 0.0), wrench=None, gravity=GRAVITY,
                     effort=None, base: str | None = None, tip: str | None = None, q_rest=None,
                     lever_tol: float = LEVER_TOL) -> PayloadCapacity:
    """The largest payload (kg) at ``cog`` (tip frame's axes, m) the chain can hold still at ``q`` (one or many).

    Parameters
    ----------
    robot, q, wrench, gravity, base, tip, q_rest
        As :func:`manipkit.statics.torques.static_torques`.
    cog : (3,) float
        The payload's centre of gravity from the tip's origin, in the tip's axes (m).
    effort : None, (n,) or ((n,), (n,))
        The limits: None, the URDF's ``+-effort``; one array, symmetric; two, ``(lower, upper)`` (N m or N).

    Raises
    ------
    OptionError
        No chain joint has an effort limit (a capacity needs one), or ``effort`` has the wrong shape.
    """
    unit = static_torques(robot, q, payload=Payload(1.0, cog), wrench=wrench, gravity=gravity, base=base, tip=tip,
                          q_rest=q_rest)
    n = len(unit.joint_names)
    lower, upper = _limits(effort, unit.effort_limit, n)
    if not (np.isfinite(lower) | np.isfinite(upper)).any():
        raise OptionError(f"no effort limit on any joint of the chain {unit.base} -> {unit.tip} "
                          f"({', '.join(unit.joint_names)}): a payload capacity needs them (URDF <limit effort=...>)")
    lever_tol = float(lever_tol)
    if not (math.isfinite(lever_tol) and lever_tol >= 0):
        raise OptionError(f"lever_tol={lever_tol!r}: give a tolerance >= 0 (N m per kg)")
    unloaded = unit.gravity + unit.wrench if wrench is not None else unit.gravity  # no wrench: its part is 0
    m, k, over = capacity_from_parts(unloaded, unit.payload, lower, upper, lever_tol=lever_tol)
    return PayloadCapacity(m, k, over, unit.joint_names, unit.payload, unloaded, lower, upper, unit.inertia_grade)


def _limits(effort, urdf: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    if effort is None:
        return -urdf, urdf.copy()
    try:
        array = np.asarray(effort, dtype=float)
    except (TypeError, ValueError):
        raise OptionError(f"effort: give {n} limits, or two rows of {n} (lower, upper), in N m or N") from None
    if array.shape == (n,):
        if np.any(array <= 0):
            raise OptionError("effort: every symmetric limit must be > 0 (NaN: no limit)")
        return -array, array
    if array.shape == (2, n):
        if np.any(array[0] >= array[1]):
            raise OptionError("effort (lower, upper): every lower limit must be below its upper limit")
        return array[0], array[1]
    raise OptionError(f"effort of shape {array.shape}: give {n} limits, or two rows of {n} (lower, upper)")


