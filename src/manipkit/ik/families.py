"""Which closed form a chain has, found from its geometry: :func:`chain_family` and :class:`Family`.

The joint axes of a chain at a reference configuration ``q0`` (zero, or
the middle of the limits when zero is outside them), as
``chain.axes(q0)`` gives them in the base frame, decide the family:

- ``"spherical wrist, two parallel"`` (6R): axes 4, 5, 6 meet in a point,
  axes 2 and 3 are parallel (the industrial arms of ROS-Industrial's
  opw_kinematics: KUKA, ABB, FANUC, Motoman, Staubli).
- ``"three parallel, two intersecting"`` (6R): axes 2, 3, 4 are parallel
  and axes 5 and 6 meet (Universal Robots).
- ``"spherical wrist, two intersecting"`` (6R): axes 4, 5, 6 meet in a
  point and axes 1 and 2 meet (Stanford-like shoulders).
- the same with the chain read tip to base (a spherical joint group at the
  base): ``reversed`` True.
- ``"spherical shoulder, elbow, spherical wrist"`` (7R, SRS: the iiwa14):
  axes 1, 2, 3 meet and axes 5, 6, 7 meet; solved at a given arm angle
  (:mod:`manipkit.closed_form.srs`).
- ``"planar"``: every axis parallel (revolute), ``"scara"``: parallel
  revolute axes and one prismatic joint along them. These are recognised
  (so the bundled textbook arms are found by geometry) but solved by the
  named solvers of :mod:`manipkit.ik.textbook`.

Axes *meet* when the point nearest all of them (least squares) lies
within the distance tolerance of each: for two axes that is half the
distance between their lines (two lines 1.5 mm apart meet within 1 mm);
they are *parallel* when the angle between them is within the angle
tolerance. Every relation found is
kept as :class:`Relation` evidence with the measured miss distance and
angle, so a calibrated description (axes missing by 1e-4) says how far it
is from the ideal arm it is solved on.

This module is given a chain object (``robot.chain(base, tip)``) and reads
its ``axes``, ``lower``, ``upper`` and ``joint_names``; it never imports
the kinematics layer (docs/architecture.md, "Layers").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from manipkit.closed_form.checks import quantity_text, tolerance_pair
from manipkit.errors import ClosedFormIKError
from manipkit.memo import keep

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain

__all__ = [
    "FAMILY_TOL",
    "IDEAL_TOL",
    "SOLVED",
    "Family",
    "Geometry",
    "Relation",
    "chain_family",
    "common_point",
    "reference_configuration",
    "reversed_geometry",
]

#: Default tolerance (m, rad) within which axes count as meeting or parallel.
FAMILY_TOL = (1e-3, 1e-3)
#: A relation holding to this (m or rad) holds exactly: the arm is its family's ideal arm, nothing snapped.
IDEAL_TOL = 1e-12
OPW = "spherical wrist, two parallel"
UR = "three parallel, two intersecting"
SPHERICAL_12 = "spherical wrist, two intersecting"
SRS = "spherical shoulder, elbow, spherical wrist"
PLANAR = "planar"
SCARA = "scara"
NONE = "none"
#: The families :mod:`manipkit.ik.chain_ik` solves from the geometry.
SOLVED = (OPW, UR, SPHERICAL_12, SRS)


@dataclass(frozen=True)
class Relation:
    """One geometric fact about a group of axes (1-based joint numbers in the chain).

    Attributes
    ----------
    kind : str
        ``"meet"`` (the axes pass through one point) or ``"parallel"``.
    axes : tuple of int
        The joints, 1-based along the chain.
    miss : float
        Meet: the largest distance (m) from the common point to an axis.
        Parallel: 0.
    angle : float
        Parallel: the largest angle (rad) between two of the axes. Meet: 0.
    point : tuple of float
        Meet: the common point (base frame, m); parallel: ``()``.
    """

    kind: str
    axes: tuple[int, ...]
    miss: float
    angle: float
    point: tuple[float, ...] = ()

    def __str__(self) -> str:
        names = ", ".join(map(str, self.axes))
        if self.kind == "meet":
            where = ", ".join(quantity_text(v) for v in self.point)
            return f"axes {names} meet at ({where}) m, miss {quantity_text(self.miss)} m"
        return f"axes {names} parallel, angle {quantity_text(self.angle)} rad"


@dataclass(frozen=True, eq=False)
class Geometry:
    """A chain's joint axes at ``q0`` in the base frame, and its tip pose there: the product of exponentials.

    ``T_base_tip(q) = E_1 ... E_n M`` with ``E_i`` the rotation by
    ``scale[i] * (q[c_i] - q0[c_i])`` about the line through ``point[i]`` along
    ``direction[i]``, and ``M = T_base_tip(q0)``; ``c_i = columns[i]`` is the
    joint's place in the chain vector (``q0`` is a whole chain vector: a
    locked joint keeps its value there and has no axis here).
    """

    direction: np.ndarray
    point: np.ndarray
    scale: np.ndarray
    prismatic: np.ndarray
    q0: np.ndarray
    M: np.ndarray
    columns: np.ndarray


@dataclass(frozen=True, eq=False)
class Family:
    """What closed form a chain has, with the evidence measured on its axes.

    Attributes
    ----------
    kind : str
        One of ``"spherical wrist, two parallel"``, ``"three parallel, two
        intersecting"``, ``"spherical wrist, two intersecting"``,
        ``"planar"``, ``"scara"``, ``"none"``.
    reversed : bool
        The family is found reading the chain tip to base (a spherical group
        at the base): it is solved on the reversed chain.
    evidence : tuple of Relation
        The relations the kind rests on, with their measured miss and angle.
    tol : (float, float)
        The distance (m) and angle (rad) tolerance the relations were found with.
    joint_names : tuple of str
    geometry : Geometry
        The axes at ``q0`` and ``M``, as measured.
    note : str
        One line: the family, or why none applies (with the nearest misses).
    locked : tuple of (str, float)
        Joints held at a value (``chain_family(..., lock=...)``); the family is that of the others.

    ``ideal`` is True when every relation holds to 1e-12 (no refinement
    needed); ``snap`` is the evidence that does not (the relations the
    nearest ideal arm makes exact); ``deviation`` is the largest miss (m) or
    angle (rad) of the evidence: how far the nearest ideal arm is.
    """

    kind: str
    reversed: bool
    evidence: tuple[Relation, ...]
    tol: tuple[float, float]
    joint_names: tuple[str, ...]
    geometry: Geometry
    note: str
    locked: tuple[tuple[str, float], ...] = ()

    @property
    def solved(self) -> bool:
        """A closed form from the geometry exists for this kind."""
        return self.kind in SOLVED

    @property
    def deviation(self) -> float:
        return max((max(r.miss, r.angle) for r in self.evidence), default=0.0)

    @property
    def snap(self) -> tuple[Relation, ...]:
        """The evidence that holds only within the tolerance (a miss or angle over 1e-12): what the ideal arm
        the closed form is solved on changes. Empty for an ideal arm (and for ``"none"``)."""
        return tuple(r for r in self.evidence if max(r.miss, r.angle) > IDEAL_TOL)

    @property
    def ideal(self) -> bool:
        return not self.snap

    def __str__(self) -> str:
        lines = [f"family: {self.kind}{' (read tip to base)' if self.reversed else ''}"]
        lines += [f"  {relation}" for relation in self.evidence]
        lines.append(f"  tolerance: {quantity_text(self.tol[0])} m, {quantity_text(self.tol[1])} rad")
        lines.append(f"  {self.note}")
        return "\n".join(lines)


def reference_configuration(lower, upper) -> np.ndarray:
    """``q0``: zero where zero is inside a joint's limits, else the middle of its limits."""
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    inside = (lower <= 0.0) & (upper >= 0.0)
    finite = np.isfinite(lower) & np.isfinite(upper)
    middle = 0.5 * (np.where(finite, lower, 0.0) + np.where(finite, upper, 0.0))
    return np.where(inside, 0.0, middle)


def _geometry(chain: Chain, lock: dict) -> Geometry:
    q0 = reference_configuration(chain.lower, chain.upper)
    names = list(chain.joint_names)
    for name, value in lock.items():
        if name not in names:
            raise ClosedFormIKError(f"cannot lock '{name}': it is not a joint of the chain {chain.base} -> {chain.tip} "
                                    f"({', '.join(names)})")
        if not math.isfinite(float(value)):
            raise ClosedFormIKError(f"cannot lock '{name}' at {value}: give a finite value (rad or m)")
        q0[names.index(name)] = float(value)
    axes = chain.axes(q0)
    if len(axes.joint) != len(set(axes.joint.tolist())):
        raise ClosedFormIKError(
            f"the chain {chain.base} -> {chain.tip} moves a joint in more than one place (a mimic joint); "
            "the geometric closed forms need one axis per joint")
    locked = {names.index(name) for name in lock}
    keep = np.array([i for i, j in enumerate(axes.joint.tolist()) if j not in locked], dtype=np.intp)
    return Geometry(np.array(axes.direction)[keep], np.array(axes.point)[keep], np.array(axes.scale)[keep],
                    np.array(axes.prismatic)[keep], q0, np.array(chain.fk(q0)), np.array(axes.joint)[keep])


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """The angle (rad) between two lines' directions, in [0, pi/2]."""
    return math.atan2(float(np.linalg.norm(np.cross(a, b))), abs(float(a @ b)))


def _parallel(geometry: Geometry, indices: tuple[int, ...]) -> Relation:
    h = geometry.direction
    angle = max(_angle(h[i], h[j]) for i in indices for j in indices if i < j)
    return Relation("parallel", tuple(i + 1 for i in indices), 0.0, angle)


def common_point(direction: np.ndarray, point: np.ndarray) -> tuple[np.ndarray, float]:
    """The point nearest a set of lines (least squares) and its largest distance (m) to one of them.

    Examples
    --------
    >>> c, miss = common_point(np.eye(3), np.zeros((3, 3)))
    >>> c.round(12) + 0.0, miss
    (array([0., 0., 0.]), 0.0)
    """
    projectors = [np.eye(3) - np.outer(h, h) for h in direction]
    A = sum(projectors)
    b = sum(P @ p for P, p in zip(projectors, point))
    c = np.linalg.lstsq(A, b, rcond=None)[0]
    miss = max(float(np.linalg.norm(P @ (c - p))) for P, p in zip(projectors, point))
    return c, miss


def _meet(geometry: Geometry, indices: tuple[int, ...]) -> Relation:
    h, p = geometry.direction[list(indices)], geometry.point[list(indices)]
    if max(_angle(a, b) for a in h for b in h) < 1e-9:  # parallel lines meet nowhere (or everywhere)
        distance = max(float(np.linalg.norm(np.cross(h[0], q - p[0]))) for q in p)
        return Relation("meet", tuple(i + 1 for i in indices), distance if distance > 1e-12 else 0.0, 0.0,
                        tuple(float(v) for v in p[0]))
    c, miss = common_point(h, p)
    return Relation("meet", tuple(i + 1 for i in indices), miss, 0.0, tuple(float(v) for v in c))


def _holds(relation: Relation, tol: tuple[float, float]) -> bool:
    return relation.miss <= tol[0] and relation.angle <= tol[1]


def _six_r(geometry: Geometry, tol: tuple[float, float]) -> tuple[str, tuple[Relation, ...], list[Relation]]:
    """(kind, evidence, nearest misses) of a 6R chain read base to tip."""
    wrist, shoulder = _meet(geometry, (3, 4, 5)), _meet(geometry, (0, 1))
    elbow, three = _parallel(geometry, (1, 2)), _parallel(geometry, (1, 2, 3))
    last_two = _meet(geometry, (4, 5))
    axial = _parallel(geometry, (0, 1))  # axes 1 and 2 parallel: the shoulder turn decides nothing (no closed form here)
    lateral = _parallel(geometry, (1, 4))  # UR type: axis 5 along axis 2 leaves joint 5 undetermined
    if _holds(three, tol) and _holds(last_two, tol) and not _holds(axial, tol) and not _holds(lateral, tol):
        return UR, (three, last_two), []
    if _holds(wrist, tol) and _holds(elbow, tol) and not _holds(axial, tol):
        return OPW, (wrist, elbow), []
    if _holds(wrist, tol) and _holds(shoulder, tol) and not _holds(axial, tol):
        return SPHERICAL_12, (wrist, shoulder), []
    return NONE, (), [wrist, elbow, three, last_two, shoulder]


def reversed_geometry(geometry: Geometry) -> Geometry:
    """The chain read tip to base: ``T^-1 = E_n^-1 ... E_1^-1 M^-1`` as ``E'_1 ... E'_n M'`` with ``M' = I``.

    ``E_i^-1`` is the rotation by the negated angle: the reversed axes point the other way.
    The reversed chain's end pose at q0 is ``M^-1`` moved to the base side, so the
    reversed problem is solved for ``g' = g^-1`` (``g = T M^-1``) with ``M' = I``.
    """
    return Geometry(-geometry.direction[::-1].copy(), geometry.point[::-1].copy(), geometry.scale[::-1].copy(),
                    geometry.prismatic[::-1].copy(), geometry.q0, np.eye(4), geometry.columns[::-1].copy())


def chain_family(chain: Chain, *, tol=FAMILY_TOL, lock=None) -> Family:
    """The closed-form family of ``chain`` (``robot.chain(base, tip)``), found from its joint axes.

    Parameters
    ----------
    chain : manipkit.kinematics.chain.Chain
    tol : float or (float, float), keyword-only
        How far (m) axes may miss a common point and how far (rad) from
        parallel they may be to count as meeting or parallel (one number:
        both). The default, 1e-3, takes calibrated descriptions (axes off by
        1e-4) as their ideal arm; the solver then refines every branch on
        the true chain.
    lock : dict of str to float, keyword-only
        Joints held at a value (rad or m): a 7R arm with one joint locked is
        classified (and solved) as the 6R arm of the others; axes are then
        numbered among the unlocked joints.

    Returns
    -------
    Family
        ``kind`` ``"none"`` when no family applies; its ``note`` then gives
        the nearest misses.

    Examples
    --------
    >>> import manipkit
    >>> family = chain_family(manipkit.load("ur5").chain("base_link", "tool0"))
    >>> family.kind, family.reversed, [str(r) for r in family.evidence][0]
    ('three parallel, two intersecting', False, 'axes 2, 3, 4 parallel, angle 0 rad')
    """
    tol = tolerance_pair(tol, error=ClosedFormIKError)  # two floats
    lock = dict(lock or {})
    try:
        key = (id(chain), tol, tuple((name, float(value)) for name, value in lock.items()) if lock else ())
    except (TypeError, ValueError):
        key = None  # a value that is not a number: _geometry says what is wrong with it
    cached = _FAMILIES.get(key) if key is not None else None
    if cached is not None and cached[0] is chain:
        return cached[1]
    family = _chain_family(chain, tol, lock)
    if key is not None:  # the chain is held, so its id is not reused while the entry lives
        keep(_FAMILIES, key, (chain, family), limit=_MAX_CACHED)
    return family


#: (id(chain), tol, lock) -> (chain, family): a chain is immutable, so its family is found once (oldest dropped first).
_FAMILIES: dict = {}
_MAX_CACHED = 64


def _chain_family(chain: Chain, tol: tuple[float, float], lock: dict) -> Family:
    """:func:`chain_family` without the cache."""
    geometry = _geometry(chain, lock)
    family = _classify(geometry, tol, tuple(chain.joint_names))
    if not lock:
        return family
    held = tuple((name, float(value)) for name, value in lock.items())
    words = ", ".join(f"{name} = {quantity_text(value)}" for name, value in held)
    return replace(family, locked=held, note=f"{family.note} (with {words} locked; axes numbered among the others)")


def _classify(geometry: Geometry, tol: tuple[float, float], names: tuple[str, ...]) -> Family:
    """The family of the unlocked joints' geometry."""
    n = len(geometry.columns)
    prismatic = geometry.prismatic
    if n >= 2 and not prismatic.any() and _holds(_parallel(geometry, tuple(range(n))), tol) and n <= 3:
        evidence = (_parallel(geometry, tuple(range(n))),)
        return Family(PLANAR, False, evidence, tol, names, geometry, f"planar {n}R arm: every axis parallel")
    if n == 4 and prismatic.sum() == 1 and _holds(_parallel(geometry, tuple(range(n))), tol):
        evidence = (_parallel(geometry, tuple(range(n))),)
        return Family(SCARA, False, evidence, tol, names, geometry,
                      "SCARA: parallel revolute axes and one prismatic joint along them")
    if n == 7 and not prismatic.any():
        shoulder, wrist = _meet(geometry, (0, 1, 2)), _meet(geometry, (4, 5, 6))
        if _holds(shoulder, tol) and _holds(wrist, tol):
            return Family(SRS, False, (shoulder, wrist), tol, names, geometry,
                          f"7R arm: {SRS} (solved at a given arm angle, or with one joint locked)")
    if n != 6 or prismatic.any():
        kinds = f"{n} joint(s)" + (f", {int(prismatic.sum())} prismatic" if prismatic.any() else "")
        return Family(NONE, False, (), tol, names, geometry,
                      f"no geometric closed form for a chain of {kinds}; closed forms exist for 6 revolute joints "
                      "(spherical wrist or three parallel axes), planar arms and SCARA arms")
    kind, evidence, near = _six_r(geometry, tol)
    if kind != NONE:
        return Family(kind, False, evidence, tol, names, geometry, f"6R arm: {kind}")
    kind, evidence, _ = _six_r(reversed_geometry(geometry), tol)
    if kind != NONE:
        evidence = tuple(Relation(r.kind, tuple(7 - a for a in reversed(r.axes)), r.miss, r.angle, r.point)
                         for r in evidence)
        return Family(kind, True, evidence, tol, names, geometry, f"6R arm: {kind}, read tip to base")
    misses = "; ".join(str(r) for r in near)
    return Family(NONE, False, (), tol, names, geometry,
                  f"no closed-form family within {quantity_text(tol[0])} m, {quantity_text(tol[1])} rad: {misses} "
                  "(a spherical wrist needs axes 4, 5, 6 to meet; a UR-type arm needs axes 2, 3, 4 parallel and "
                  "5, 6 to meet); a larger tol accepts a nearly ideal arm")
