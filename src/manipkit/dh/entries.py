"""The algebra of single DH entries: each row as elementary transforms, and a joint turned the other way.

A row is a product of elementary transforms, one per entry, with the joint's
motion next to its own entry (docs/architecture.md):

- standard DH: ``Rz(q) Rz(theta) Tz(d) Tx(a) Rx(alpha)`` (revolute; a prismatic
  row has ``Tz(q)`` before ``Tz(d)`` instead);
- modified DH: ``Rx(alpha) Tx(a) Rz(q) Rz(theta) Tz(d)``.

Each entry's transform is ``exp(v G)`` with ``G`` its generator
(``GENERATORS``), so FK is affine in a length and in ``(cos v, sin v)`` of
an angle: :mod:`manipkit.dh.check` fits single entries in closed form with
these. :func:`reverse_joint` turns one joint the other way. Metres and radians.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from manipkit.dh.table import DHTable, dh_link_transform
from manipkit.spatial.rotations import wrap_angle

__all__ = [
    "ANGLE_ENTRIES", "dh_link_matrices", "ENTRIES", "GENERATORS", "reverse_joint", "row_factors",
]

ENTRIES = ("a", "alpha", "d", "theta")
ANGLE_ENTRIES = ("alpha", "theta")


def reverse_joint(table: DHTable, j: int) -> DHTable:
    """The table with joint ``j`` (0-based) turning the other way: ``T'(q) = T(q with q_j negated)``.

    Its DH z axis is turned half a turn about x. Standard DH (joint j about
    ``z_{j-1}``): ``A_j(-q) = Rx(pi) Rz(q - theta) Tz(-d) Tx(a) Rx(alpha + pi)``,
    so alpha of row j-1 (or the base, for joint 1) gains 180 deg, and row j
    has theta and d negated and alpha + 180 deg. Modified DH (joint j about
    ``z_j``): ``A_j(-q) = Rx(alpha + pi) Tx(a) Rz(q - theta) Tz(-d) Rx(pi)``:
    row j has alpha + 180 deg, theta and d negated, and the next row's alpha
    (or the tool) gains 180 deg. Applying it twice gives the table back.

    >>> from manipkit.dh.table import DHRow, dh_fk
    >>> t = DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0.5, 0.3)], "standard")
    >>> q = np.array([0.2, 0.7])
    >>> bool(np.allclose(dh_fk(reverse_joint(t, 1), q), dh_fk(t, [0.2, -0.7])))
    True
    """
    rows = list(table.rows)
    base, tool = table.base, table.tool
    half = np.diag([1.0, -1.0, -1.0, 1.0])  # Rx(pi)

    def turn_alpha(k):
        rows[k] = replace(rows[k], alpha=float(wrap_angle(rows[k].alpha + math.pi)))

    row = rows[j]
    rows[j] = replace(row, theta=float(wrap_angle(-row.theta)) if row.theta else 0.0, d=-row.d if row.d else 0.0,
                      alpha=float(wrap_angle(row.alpha + math.pi)))
    if table.convention == "standard":
        if j > 0:
            turn_alpha(j - 1)
        else:
            base = base @ half
    elif j + 1 < len(rows):
        turn_alpha(j + 1)
    else:
        tool = half @ tool
    return DHTable(tuple(rows), table.convention, table.name, base=base, tool=tool)


def row_factors(row, q, convention: str) -> list:
    """The elementary transforms of one row at joint values ``q`` (m,), named by entry; "q" for the motion."""
    m = len(q)
    value = {entry: np.full(m, getattr(row, entry)) for entry in ENTRIES}
    motion = ("q", _elementary("theta" if row.is_revolute else "d", q))
    own = {entry: (entry, _elementary(entry, value[entry])) for entry in ENTRIES}
    moving = "theta" if row.is_revolute else "d"
    if convention == "standard":
        order = ["theta", "d", "a", "alpha"]
    else:
        order = ["alpha", "a", "theta", "d"]
    factors = []
    for entry in order:
        if entry == moving:
            factors.append(motion)
        factors.append(own[entry])
    return factors


GENERATORS = {name: np.zeros((4, 4)) for name in ENTRIES}
GENERATORS["a"][0, 3] = 1.0
GENERATORS["d"][2, 3] = 1.0
GENERATORS["alpha"][2, 1], GENERATORS["alpha"][1, 2] = 1.0, -1.0
GENERATORS["theta"][1, 0], GENERATORS["theta"][0, 1] = 1.0, -1.0


def _elementary(entry: str, values) -> np.ndarray:
    """Tx(a), Rx(alpha), Tz(d) or Rz(theta) for each value, shape (m, 4, 4)."""
    values = np.asarray(values, dtype=float)
    G = GENERATORS[entry]
    if entry in ANGLE_ENTRIES:
        s, c = np.sin(values)[:, None, None], np.cos(values)[:, None, None]
        return np.eye(4) + s * G + (1.0 - c) * (G @ G)
    return np.eye(4) + values[:, None, None] * G


def dh_link_matrices(table: DHTable, k: int, q) -> np.ndarray:
    """``A_k(q)`` of row ``k`` (0-based) for each joint value in ``q`` (m,), shape (m, 4, 4)."""
    row = table.rows[k]
    q = np.asarray(q, dtype=float)
    theta = row.theta + q if row.is_revolute else np.full_like(q, row.theta)
    d = np.full_like(q, row.d) if row.is_revolute else row.d + q
    return dh_link_transform(row.a, row.alpha, d, theta, convention=table.convention)
