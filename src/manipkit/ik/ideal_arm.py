"""The nearest ideal arm of a chain's closed-form family, and the constants of its compiled loops.

:class:`IdealArm` (made once per family by :func:`ideal_arm`) is the arm the
closed forms of :mod:`manipkit.closed_form` solve: the family's axes at
``q0`` made exactly parallel or concurrent, in the solve direction.
:func:`compiled_arm` packs it with the chain's joint map and limits and the
chain's own FK program (``chain.program.row_tables``, packed once per chain
by :class:`manipkit.kernels.program.ChainProgram`) into the two flat arrays
the compiled solve-and-check loops take
(:func:`manipkit.closed_form.check_kernel.pack_arm`), once per chain and
family. Used by :mod:`manipkit.ik.chain_ik` (single and batched calls).

Units: m and rad; ``h``, ``p``: axis directions and points in the base frame.
"""

from __future__ import annotations

import math
import weakref
from typing import TYPE_CHECKING

import numpy as np

from manipkit.errors import ClosedFormIKError
from manipkit.ik.families import OPW, SPHERICAL_12, SRS, UR, Family, common_point, reversed_geometry
from manipkit.spatial.transforms import invert_transform

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain

__all__ = ["IdealArm", "compiled_arm", "compiled_entry", "ideal_arm", "wide_joints"]

TWO_PI = 2.0 * math.pi


class IdealArm:
    """The nearest ideal arm of a family: axes made exactly parallel or concurrent, in the solve direction.

    ``h``, ``p`` (6, 3): directions and points; ``points``: the wrist centre
    (and shoulder point) the solver needs; ``moved``: the largest change of
    an axis (m for a point, rad for a direction) from the measured chain.
    """

    __slots__ = ("family", "h", "p", "points", "moved", "M_inv", "scale", "label_axes", "__weakref__")

    def __init__(self, family: Family):
        geometry = reversed_geometry(family.geometry) if family.reversed else family.geometry
        h, p = geometry.direction.copy(), geometry.point.copy()
        moved = 0.0
        points = {}
        if family.kind in (OPW, SPHERICAL_12):
            c, miss = common_point(h[3:6], p[3:6])
            p[3:6] = c
            points["wrist"] = c
            moved = max(moved, miss)
        if family.kind == OPW:
            moved = max(moved, _align(h, (1, 2)))
        if family.kind == UR:
            moved = max(moved, _align(h, (1, 2, 3)))
            c, miss = common_point(h[4:6], p[4:6])
            p[4:6] = c
            points["wrist"] = c
            moved = max(moved, miss)
        if family.kind == SRS:
            s, miss_s = common_point(h[0:3], p[0:3])
            c, miss_w = common_point(h[4:7], p[4:7])
            p[0:3], p[4:7] = s, c
            points["shoulder"], points["wrist"] = s, c
            moved = max(moved, miss_s, miss_w)
        if family.kind == SPHERICAL_12:
            s, miss = common_point(h[0:2], p[0:2])
            p[0:2] = s
            points["shoulder"] = s
            moved = max(moved, miss)
        self.family, self.h, self.p, self.points, self.moved = family, h, p, points, moved
        self.M_inv = invert_transform(family.geometry.M, check=False)  # g = T M^-1, once per arm
        # the arm's size as arms.solve_6r takes it (m, at least 1)
        self.scale = max(1.0, float(np.max(np.abs(p))) + float(np.linalg.norm(points.get("wrist", np.zeros(3)))))
        self.label_axes = _label_axes(h, p, points["wrist"]) if "wrist" in points else None


def _align(h: np.ndarray, indices: tuple[int, ...]) -> float:
    """Make the axes ``indices`` of ``h`` exactly parallel (their signed mean); the largest angle turned (rad)."""
    first = h[indices[0]]
    signs = [1.0 if h[i] @ first >= 0 else -1.0 for i in indices]
    mean = sum(s * h[i] for s, i in zip(signs, indices))
    mean = mean / np.linalg.norm(mean)
    turned = 0.0
    for s, i in zip(signs, indices):
        turned = max(turned, math.atan2(float(np.linalg.norm(np.cross(h[i], s * mean))), float(h[i] @ (s * mean))))
        h[i] = s * mean
    return turned


def ideal_arm(family: Family) -> IdealArm:
    """The nearest ideal arm of ``family`` (see :class:`IdealArm`), made once per family and kept;
    :class:`ClosedFormIKError` if it has no solver."""
    if not family.solved:
        raise ClosedFormIKError(family.note)
    arm = _ARMS.get(family)
    if arm is None:
        arm = _ARMS[family] = IdealArm(family)
    return arm


#: Family -> its ideal arm (a Family is immutable; an arm is made once and read by every call after).
_ARMS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def compiled_arm(chain: Chain, arm: IdealArm) -> tuple:
    """The constants the compiled solve-and-check loop takes for ``chain`` solved on ``arm`` (UR or OPW family):
    the ideal arm, its label axes, the joint map and limits and the chain's FK program (``chain.program.row_tables``,
    packed once per chain); made once per chain and family (both immutable) and kept."""
    return compiled_entry(chain, arm)[1]


def compiled_entry(chain: Chain, arm: IdealArm) -> tuple:
    """(chain, :func:`compiled_arm`'s constants, :func:`wide_joints`, notes, labels): the entry of :data:`_COMPILED`
    for ``chain`` and ``arm``, made on first use (the two dicts are filled by ``chain_ik``'s single calls)."""
    cached = _COMPILED.get(arm)
    if cached is None or cached[0] is not chain:
        cached = _COMPILED[arm] = (chain, _compiled_constants(chain, arm),
                                   wide_joints(chain, arm.family.geometry.columns), {}, {})
    return cached


def _compiled_constants(chain: Chain, arm: IdealArm) -> tuple:
    """The two arrays :func:`compiled_arm` keeps (:func:`manipkit.closed_form.check_kernel.pack_arm`)."""
    from manipkit.closed_form.arms_kernel import KIND_CODES
    from manipkit.closed_form.check_kernel import pack_arm

    geometry = arm.family.geometry
    columns = np.ascontiguousarray(geometry.columns, dtype=np.int64)
    lower, upper = np.asarray(chain.lower, dtype=float), np.asarray(chain.upper, dtype=float)
    floats, ints = chain.program.row_tables
    return pack_arm(KIND_CODES.get(arm.family.kind, -1), arm.h, arm.p,
                    np.array([arm.points["wrist"], arm.points.get("shoulder", arm.p[1]), *arm.label_axes], dtype=float),
                    float(arm.scale), arm.M_inv, bool(arm.family.reversed), np.asarray(geometry.q0, dtype=float),
                    columns, np.array([geometry.scale, lower[columns], upper[columns]], dtype=float),
                    np.array([lower, upper]), floats, ints)


#: IdealArm -> (chain, constants of the compiled loop, the solved joints spanning more than 2 pi, the notes of its
#: single calls by their rows' within_limits (bytes), their labels by the kernel's number of the codes): once per chain.
_COMPILED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _label_axes(h: np.ndarray, p: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(reference, up) of the labels of an arm (axes h, p; wrist centre c): "front" is the side of axis 1 along
    ``reference`` (the wrist centre's side at q0, across axis 2), "above" is along ``up`` (axis 1 turned to point up
    the base z)."""
    reference = c - p[0] - ((c - p[0]) @ h[0]) * h[0]
    reference = reference - (reference @ h[1]) * h[1]
    if np.linalg.norm(reference) < 1e-9:
        reference = np.cross(h[0], h[1])
    return reference, (h[0] if h[0][2] >= 0.0 else -h[0])


def wide_joints(chain: Chain, columns: np.ndarray) -> list[str]:
    """The solved joints whose range spans more than 2 pi (each has a second alias inside its limits)."""
    lower, upper = np.asarray(chain.lower, dtype=float)[columns], np.asarray(chain.upper, dtype=float)[columns]
    wide = (upper - lower > TWO_PI + 1e-9) & np.isfinite(upper)
    return [chain.joint_names[k] for k, w in zip(columns.tolist(), wide.tolist()) if w]
