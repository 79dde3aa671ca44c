"""How far the static torques and the payload capacity move when the description's masses and CoGs are off,
and each body's share of each joint's gravity torque (for ``--explain``).

The band: every body moved by the chain (:func:`manipkit.statics.torques.chain_bodies`)
has its mass scaled by a factor in ``[1 - p, 1 + p]`` and its centre of
gravity moved by up to ``p |c|`` along each axis of its joint's frame (``c``:
the CoG's offset from that joint's origin), ``p = percent / 100``, each body
independently. A body's gravity torque ``-m J_c(q)^T g`` is bilinear in its
mass and CoG, and the torques add over bodies, so each joint's interval is
exact: the sum over bodies of the extremes over the 16 corners of each
body's box. The capacity interval is an outer bound: each joint's unloaded
torque taken at its own worst (or best) end.

Examples
--------
>>> import manipkit
>>> band = torque_band(manipkit.load("iiwa14"), [0, 0.5, 0, -1.0, 0, 0.5, 0], percent=10)
>>> bool(np.all(band.low <= band.nominal)) and bool(np.all(band.nominal <= band.high))
True
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.errors import OptionError
from manipkit.kinematics.chain import chain_of
from manipkit.statics.capacity import capacity_from_parts
from manipkit.statics.torques import (
    GRAVITY,
    Payload,
    chain_bodies,
    effort_limits,
    gravity_in_base,
    payload_torques,
    point_program,
    whole_rows,
)

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain
    from manipkit.kinematics.robot import Robot

__all__ = ["TorqueBand", "gravity_contributions", "torque_band"]

_CORNERS = np.array(list(itertools.product((-1.0, 1.0), repeat=4)))  # (16, 4): mass sign, then x, y, z signs


@dataclass(frozen=True)
class TorqueBand:
    """Gravity torques (n,) at one configuration: ``nominal`` and the interval ``[low, high]`` (N m or N), and the
    payload capacity's interval ``[capacity_low, capacity_high]`` (kg; NaN without a payload asked)."""

    joint_names: tuple
    percent: float
    nominal: np.ndarray
    low: np.ndarray
    high: np.ndarray
    capacity_nominal: float
    capacity_low: float
    capacity_high: float


def _point_jacobian(J: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The linear rows (3, n) for the point at ``r`` (base axes) from its frame's origin: ``v_p = v - r x w``."""
    return J[:3] - np.cross(r, J[3:].T).T


def _body_frames(chain: Chain, whole: np.ndarray, positions) -> dict:
    """position -> (J (6, n_robot), R (3, 3)) of the frame after that joint step, at one whole-robot row."""
    frames = {}
    for position in set(positions):
        steps_program = point_program(chain, position, np.zeros(3))
        J, R, _ = steps_program.run(np.ascontiguousarray(whole[None]))
        frames[position] = (J[0], R[0])
    return frames


def _bodies_at(robot, q, gravity, base, tip, q_rest, what: str):
    """(chain, whole row (1, n_robot), gravity in base axes (3,), chain_bodies, their frames) at one configuration."""
    chain = chain_of(robot, what, base=base, tip=tip)
    whole, lead = whole_rows(chain, q, q_rest)
    if lead != ():
        raise OptionError(f"{what} takes one configuration")
    g = gravity_in_base(chain, whole, gravity)[0]
    bodies = chain_bodies(chain, q_rest)
    return chain, whole, g, bodies, _body_frames(chain, whole[0], [b[0] for b in bodies])


def gravity_contributions(robot: Robot | Chain, q, *, gravity=GRAVITY, base=None, tip=None,
                          q_rest=None) -> list[tuple[str, float, np.ndarray]]:
    """(link, mass kg, torque (n,) N m) per body: its share of each chain joint's gravity torque, base to tip.

    They add up to :attr:`manipkit.statics.torques.StaticTorques.gravity`.
    """
    chain, whole, g, bodies, frames = _bodies_at(robot, q, gravity, base, tip, q_rest, "gravity_contributions")
    found = []
    for position, link, mass, centre in bodies:
        J, R = frames[position]
        J_point = _point_jacobian(J, R @ centre)
        found.append((link, mass, -mass * (J_point.T @ g)[chain.columns]))
    return found


def torque_band(robot: Robot | Chain, q, *, percent: float, payload: Payload | None = None, gravity=GRAVITY,
                base=None, tip=None, q_rest=None) -> TorqueBand:
    """The gravity torques (and, with ``payload``, the capacity at its CoG) with masses and CoGs off by ``percent``.

    See the module for the perturbation. ``payload``'s mass is only used for its CoG (the capacity is a mass).
    """
    percent = float(percent)
    if not (math.isfinite(percent) and 0 <= percent < 100):
        raise OptionError(f"percent={percent!r}: give a perturbation from 0 to below 100 (%)")
    p = percent / 100.0
    chain, whole, g, bodies, frames = _bodies_at(robot, q, gravity, base, tip, q_rest, "torque_band")
    nominal, low, high = np.zeros(chain.n), np.zeros(chain.n), np.zeros(chain.n)
    for position, _, mass, centre in bodies:
        J, R = frames[position]
        reach = p * float(np.linalg.norm(centre))
        values = []
        for corner in _CORNERS:
            m = mass * (1.0 + p * corner[0])
            c = centre + reach * corner[1:]
            values.append(-m * (_point_jacobian(J, R @ c).T @ g)[chain.columns])
        values = np.array(values)
        nominal += -mass * (_point_jacobian(J, R @ centre).T @ g)[chain.columns]
        low += values.min(axis=0)
        high += values.max(axis=0)
    capacity = (math.nan, math.nan, math.nan)
    if payload is not None:
        per_kg = payload_torques(chain, whole, Payload(1.0, payload.cog), g[None])[0]
        limits = effort_limits(chain)
        worst = np.where(per_kg > 0, high, low)  # the unloaded torque that leaves the least room
        best = np.where(per_kg > 0, low, high)
        capacity = tuple(float(capacity_from_parts(a, per_kg, -limits, limits)[0]) for a in (nominal, worst, best))
    return TorqueBand(chain.joint_names, percent, nominal, low, high, *capacity)
