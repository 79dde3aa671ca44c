"""The forces (or moments) the tool can apply at a pose, with the arm's weight and the payload's taken out of the
torque budget first.

Conventions (docs/architecture.md), restated:

- The tool applies ``f`` on the environment, so the environment pushes
  ``-f`` on the robot and the motors produce ``tau = g(q) + J^T f`` (the
  statics convention ``tau = g - J^T w`` with ``w = -f``). ``g`` includes the
  payload. Each joint with an effort limit needs ``-limit <= tau <= limit``.
- Force and moment are kept apart: ``kind="force"`` uses the linear rows
  ``J_v`` (N, at the tip's origin, base axes), ``kind="moment"`` the angular
  rows ``J_w`` (N m), never mixed.
- The **polytope** is ``{f : -limit - g <= J^T f <= limit - g}`` (exact);
  :func:`force_capacity` gives its radial extent: the largest ``t`` with
  ``t d`` inside, per unit direction ``d`` (the same closed form as the payload
  capacity: :func:`manipkit.statics.capacity.capacity_from_parts`).
- The **ellipsoid** is ``{f : || D (g + J^T f) || <= 1}`` with ``D =
  diag(1 / limit)``: centre ``f_c`` (where the weight is best balanced),
  principal axes and radii; without gravity it is the classic force
  ellipsoid of ``J D^2 J^T``. It is empty when gravity alone uses the whole
  budget (``|| D (g + J^T f_c) || >= 1``). Joints without an effort limit are
  left out of both (they bound nothing).

Examples
--------
>>> import manipkit
>>> cap = force_capacity(manipkit.load("iiwa14"), [0, 0.5, 0, -1.0, 0, 0.5, 0], directions=[[0, 0, -1], [0, 0, 1]])
>>> bool(cap.along[0] > cap.along[1])  # pushing down is helped by the arm's weight being held up already
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.errors import OptionError
from manipkit.kinematics.chain import chain_of
from manipkit.statics.capacity import capacity_from_parts
from manipkit.statics.torques import GRAVITY, static_torques

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain
    from manipkit.kinematics.robot import Robot

__all__ = ["KINDS", "ForceCapacity", "force_capacity"]

KINDS = ("force", "moment")


@dataclass(frozen=True)
class ForceCapacity:
    """The answer of :func:`force_capacity` at one configuration (see the module).

    Attributes
    ----------
    kind : str
        ``"force"`` (N) or ``"moment"`` (N m).
    directions : ndarray (k, 3)
        Unit directions (base axes).
    along : ndarray (k,)
        The largest magnitude applicable along each (``inf``: unbounded; 0: gravity alone saturates).
    saturating : tuple
        The joint that limits each direction (None where unbounded).
    centre : ndarray (3,)
        The ellipsoid's centre.
    axes : ndarray (3, 3)
        Its principal axes (columns), longest first.
    radii : ndarray (3,)
        Its semi-axes (``inf`` along a direction no joint resists: a singular ``J``); all 0 when it is empty.
    empty : bool
        Gravity and the payload alone use the whole budget (the ellipsoid has no interior).
    joint_names : tuple of str
    """

    kind: str
    directions: np.ndarray
    along: np.ndarray
    saturating: tuple
    centre: np.ndarray
    axes: np.ndarray
    radii: np.ndarray
    empty: bool
    joint_names: tuple


def force_capacity(robot: Robot | Chain, q, *, kind: str = "force", directions=None, payload=None,
                   gravity=GRAVITY, base=None, tip=None, q_rest=None) -> ForceCapacity:
    """The polytope's extent along ``directions`` (default ±x, ±y, ±z of the base) and the ellipsoid, at ``q``."""
    if kind not in KINDS:
        raise OptionError(f"kind={kind!r} is not one of 'force', 'moment'")
    chain = chain_of(robot, "force_capacity", base=base, tip=tip)
    held = static_torques(chain, q, payload=payload, gravity=gravity, q_rest=q_rest)
    if np.ndim(held.tau) != 1:
        raise OptionError("force_capacity takes one configuration")
    limits = held.effort_limit
    limited = np.isfinite(limits)
    if not limited.any():
        raise OptionError(f"no effort limit on any joint of the chain {chain.base} -> {chain.tip}: a force capacity "
                          "needs them (URDF <limit effort=...>)")
    J = chain.jacobian(chain.q(q))
    rows = J[:3] if kind == "force" else J[3:]
    d = np.eye(3)[[0, 0, 1, 1, 2, 2]] * np.array([1, -1, 1, -1, 1, -1])[:, None] if directions is None else \
        np.asarray(directions, dtype=float).reshape(-1, 3)
    norms = np.linalg.norm(d, axis=1)
    if not np.all(np.isfinite(d)) or np.any(norms == 0):
        raise OptionError("directions: give finite 3-vectors, none of them 0")
    d = d / norms[:, None]
    g = held.tau
    per_unit = d @ rows  # (k, n): J^T d
    along, k, _ = capacity_from_parts(np.broadcast_to(g, per_unit.shape), per_unit, -limits, limits)
    names = tuple(None if j < 0 else chain.joint_names[int(j)] for j in np.atleast_1d(k))
    centre, axes, radii, empty = _ellipsoid(rows[:, limited], g[limited], limits[limited])
    return ForceCapacity(kind, d, np.atleast_1d(along), names, centre, axes, radii, empty, chain.joint_names)


def _ellipsoid(rows: np.ndarray, g: np.ndarray, limits: np.ndarray):
    """{f : ||D (g + rows^T f)|| <= 1}: (centre, axes, radii, empty) by least squares on D rows^T."""
    A = (rows / limits).T  # (n, 3): D J^T
    b = -g / limits
    U, s, Vt = np.linalg.svd(A, full_matrices=False)
    tol = max(A.shape) * np.finfo(float).eps * (s[0] if s.size and s[0] > 0 else 1.0)
    keep = s > tol
    centre = Vt[keep].T @ ((U[:, keep].T @ b) / s[keep])
    residual = float(np.sum((A @ centre - b) ** 2))
    order = np.argsort(s)  # the smallest singular value is the longest semi-axis
    axes = Vt[order].T
    if residual >= 1.0:
        return centre, axes, np.zeros(3), True
    room = math.sqrt(1.0 - residual)
    radii = np.array([room / value if value > tol else math.inf for value in s[order]])
    return centre, axes, radii, False
