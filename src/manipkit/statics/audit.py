"""The inertia audit: can a description's masses, inertias and effort limits be trusted for statics?

One :class:`Finding` per problem, by link (or joint) and check, with the
numbers; one grade per robot:

- ``"A"``: nothing found;
- ``"B"``: warnings only (implausible against the geometry, placeholders,
  missing effort limits): the torques follow from the numbers given, which may be rough;
- ``"C"``: an error that makes gravity torques wrong (a moving link with
  geometry but no mass, a tensor no rigid body has).

Checks (``check`` names), each per link of the URDF (inertia about the
centre of mass, in the ``<inertial>`` origin's axes):

``mass_missing``, ``mass_zero``, ``mass_tiny`` (error, error, warning)
    A link moved by a joint, with visual or collision geometry, without
    ``<inertial>``, with mass 0, or below ``tiny_mass`` kg. (Pinocchio
    reads a missing ``<inertial>`` as zero mass without a word.) A link
    fixed to its parent (a tool frame with a small box) is a warning only:
    its parent's mass carries it.
``inertia_not_psd`` (error)
    A principal moment below 0.
``triangle_inequality`` (error)
    ``I1 + I2 < I3`` for the principal moments: the pseudo-inertia is not
    positive semidefinite; no mass distribution has this tensor.
``parallel_axis_shift`` (error)
    The tensor fails the two checks above but passes once shifted by the
    parallel-axis term ``m (|c|^2 1 - c c^T)`` of its CoG offset ``c``:
    given about the link origin rather than the CoG?
``cog_outside_geometry`` (warning)
    The CoG lies outside the bounding box of the link's collision geometry
    (grown by ``box_margin`` of its size on each side).
``density_implausible``, ``gyration_implausible`` (warning)
    Mass over the collision geometry's bounding-box volume outside
    ``density_range`` kg/m^3; a radius of gyration ``sqrt(I_max / m)`` above
    the box's half diagonal times ``gyration_factor``.
``placeholder_repeated`` (warning)
    The same mass and tensor on ``placeholder_count`` or more links.
``effort_missing``, ``effort_zero`` (warning)
    A movable, independent joint without ``<limit effort=...>``, or with 0:
    capacities cannot be computed for it.

Examples
--------
>>> import manipkit
>>> report = inertia_audit(manipkit.load("planar_2r"))
>>> report.grade
'A'
"""

from __future__ import annotations

import math
import weakref
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from manipkit.errors import CollisionError, OptionError
from manipkit.spatial.rotations import matrix_from_rpy

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["CHECKS", "Finding", "InertiaAudit", "inertia_audit", "inertia_grade"]

ERROR, WARNING = "error", "warning"
CHECKS = {
    "mass_missing": ERROR, "mass_zero": ERROR, "mass_tiny": WARNING, "inertia_not_psd": ERROR,
    "triangle_inequality": ERROR, "parallel_axis_shift": ERROR, "cog_outside_geometry": WARNING,
    "density_implausible": WARNING, "gyration_implausible": WARNING, "placeholder_repeated": WARNING,
    "effort_missing": WARNING, "effort_zero": WARNING,
}


@dataclass(frozen=True)
class Finding:
    """One problem: where (``link``: a link or, for effort limits, a joint), which ``check``, its ``severity``,
    a sentence saying what is wrong, and the numbers it was judged on."""

    link: str
    check: str
    severity: str
    message: str
    numbers: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {"link": self.link, "check": self.check, "severity": self.severity, "message": self.message,
                "numbers": self.numbers}


@dataclass(frozen=True)
class InertiaAudit:
    """Every finding and the robot's grade (see the module); ``geometry_checked`` says whether the collision
    geometry could be read (the geometry checks are skipped without it, and ``geometry_note`` says why)."""

    robot: str
    findings: tuple
    grade: str
    links_checked: int
    geometry_checked: bool
    geometry_note: str = ""

    def by_link(self, link: str) -> list[Finding]:
        return [f for f in self.findings if f.link == link]

    def as_dict(self) -> dict:
        return {"robot": self.robot, "grade": self.grade, "links_checked": self.links_checked,
                "geometry_checked": self.geometry_checked, "geometry_note": self.geometry_note,
                "findings": [f.as_dict() for f in self.findings]}


def _floats(text: str | None, n: int, default: float = 0.0) -> np.ndarray:
    if text is None:
        return np.full(n, default)
    values = [float(v) for v in text.split()]
    return np.array(values if len(values) == n else [default] * n)


def _inertial(link: ET.Element):
    """(mass or None, CoG (3,), tensor about the CoG in the link's axes (3, 3)) of a link's ``<inertial>``."""
    inertial = link.find("inertial")
    if inertial is None:
        return None, np.zeros(3), np.zeros((3, 3))
    origin = inertial.find("origin")
    xyz = _floats(origin.get("xyz") if origin is not None else None, 3)
    rpy = _floats(origin.get("rpy") if origin is not None else None, 3)
    mass_el = inertial.find("mass")
    mass = float(mass_el.get("value", 0.0)) if mass_el is not None else 0.0
    el = inertial.find("inertia")
    get = (lambda k: float(el.get(k, 0.0))) if el is not None else (lambda k: 0.0)
    inertia = np.array([[get("ixx"), get("ixy"), get("ixz")], [get("ixy"), get("iyy"), get("iyz")],
                  [get("ixz"), get("iyz"), get("izz")]])
    R = matrix_from_rpy(rpy)
    return mass, xyz, R @ inertia @ R.T


def _valid_tensor(inertia: np.ndarray, tol: float) -> tuple[bool, bool, np.ndarray]:
    """(principal moments >= 0, triangle inequality holds, the moments sorted) within ``tol`` (kg m^2)."""
    moments = np.sort(np.linalg.eigvalsh(0.5 * (inertia + inertia.T)))
    return bool(moments[0] >= -tol), bool(moments[0] + moments[1] >= moments[2] - tol), moments


def _moving_links(root: ET.Element) -> dict[str, bool]:
    """Links moved by at least one non-fixed joint above them -> whether their own joint is that one (not fixed)."""
    parent_of = {}
    for joint in root.iter("joint"):
        child, parent = joint.find("child"), joint.find("parent")
        if child is not None and parent is not None:
            parent_of[child.get("link")] = (parent.get("link"), joint.get("type", "fixed") != "fixed")
    moving = {}
    for link in parent_of:
        name, seen = link, set()
        while name in parent_of and name not in seen:
            seen.add(name)
            name, moves = parent_of[name]
            if moves:
                moving[link] = parent_of[link][1]
                break
    return moving


def _geometry_boxes(robot: Robot) -> tuple[dict, str]:
    """Link -> (min, max) of its collision geometry's bounding box in the link frame (m), or ({}, why not)."""
    from manipkit.kinematics.collision_geometry import collision_geometry

    try:
        geometry = collision_geometry(robot, "meshes")
    except CollisionError as exc:
        return {}, str(exc)
    boxes: dict[str, list] = {}
    for obj, link in zip(geometry.model.geometryObjects, geometry.links):
        frame = robot.model.frames[obj.parentFrame]
        shape = obj.geometry
        shape.computeLocalAABB()
        lo, hi = np.asarray(shape.aabb_local.min_), np.asarray(shape.aabb_local.max_)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        in_link = frame.placement.inverse() * obj.placement  # geometry in the link frame (both given in the joint's)
        points = corners @ np.asarray(in_link.rotation).T + np.asarray(in_link.translation)
        box = boxes.setdefault(link, [points.min(0), points.max(0)])
        box[0], box[1] = np.minimum(box[0], points.min(0)), np.maximum(box[1], points.max(0))
    return {k: (v[0], v[1]) for k, v in boxes.items()}, ""


_GRADES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # robot -> its grade with the default thresholds


def inertia_grade(robot: Robot) -> str:
    """The grade of :func:`inertia_audit` with its defaults, computed once per robot (robots are immutable).

    >>> import manipkit
    >>> inertia_grade(manipkit.load("iiwa14"))
    'A'
    """
    grade = _GRADES.get(robot)
    if grade is None:
        grade = _GRADES.setdefault(robot, inertia_audit(robot).grade)
    return grade


def inertia_audit(robot: Robot, *, tiny_mass: float = 1e-3, tensor_tol: float = 1e-12, box_margin: float = 0.1,
                  density_range=(20.0, 25000.0), gyration_factor: float = 1.5, placeholder_count: int = 3,
                  geometry: bool = True) -> InertiaAudit:
    """Audit ``robot``'s inertials and effort limits (see the module for the checks and thresholds).

    ``geometry=False`` skips the checks against the collision geometry (no meshes are read).
    """
    if not (math.isfinite(tiny_mass) and tiny_mass >= 0 and math.isfinite(box_margin) and box_margin >= 0):
        raise OptionError("tiny_mass and box_margin: give finite numbers >= 0")
    root = ET.fromstring(robot.urdf)
    moving = _moving_links(root)
    boxes, note = _geometry_boxes(robot) if geometry else ({}, "not asked for")
    findings: list[Finding] = []
    signatures: dict[tuple, list[str]] = {}
    links = list(root.iter("link"))
    for link in links:
        name = link.get("name")
        has_geometry = link.find("visual") is not None or link.find("collision") is not None
        mass, c, inertia = _inertial(link)
        if name in moving and has_geometry:
            findings += _mass_findings(name, mass, moving[name], tiny_mass)
        if mass is None or mass <= 0:
            continue
        findings += _tensor_findings(name, mass, c, inertia, tensor_tol)
        if name in boxes:
            findings += _geometry_findings(name, mass, c, inertia, boxes[name], box_margin, density_range, gyration_factor)
        signatures.setdefault((mass, *np.round(inertia, 12).ravel().tolist()), []).append(name)
    for (mass, *_), names in signatures.items():
        if len(names) >= placeholder_count:
            for name in names:
                findings.append(Finding(name, "placeholder_repeated", WARNING,
                                        f"the same mass ({mass:g} kg) and inertia tensor on {len(names)} links "
                                        f"({', '.join(names)}): placeholder values?", {"mass": mass,
                                                                                     "links": len(names)}))
    findings += _effort_findings(root, set(robot.mimic_joints))
    severities = {f.severity for f in findings}
    grade = "C" if ERROR in severities else "B" if findings else "A"
    return InertiaAudit(robot.name, tuple(findings), grade, len(links), bool(boxes), note)


def _mass_findings(name, mass, own_joint_moves: bool, tiny_mass: float) -> list[Finding]:
    severity = ERROR if own_joint_moves else WARNING
    fixed = "" if own_joint_moves else " (fixed to its parent, which carries it)"
    if mass is None:
        return [Finding(name, "mass_missing", severity, f"link '{name}' moves and has geometry but no <inertial>: "
                        f"Pinocchio takes its mass as 0{fixed}", {"mass": None})]
    if mass <= 0:
        return [Finding(name, "mass_zero", severity, f"link '{name}' moves and has geometry but mass {mass:g} kg"
                        f"{fixed}", {"mass": mass})]
    if mass < tiny_mass:
        return [Finding(name, "mass_tiny", WARNING, f"link '{name}' weighs {mass:g} kg, below {tiny_mass:g} kg: "
                        "a placeholder?", {"mass": mass, "tiny_mass": tiny_mass})]
    return []


def _tensor_findings(name, mass, c, inertia, tol) -> list[Finding]:
    psd, triangle, moments = _valid_tensor(inertia, tol)
    if psd and triangle:
        return []
    shift = mass * (float(c @ c) * np.eye(3) - np.outer(c, c))
    numbers = {"principal_moments": moments.tolist(), "mass": mass, "cog": c.tolist()}
    for sign, where in ((-1.0, "given about the link origin, not the centre of mass"),
                        (1.0, "written about the centre of mass where another point was meant")):
        if float(c @ c) > 0 and all(_valid_tensor(inertia + sign * shift, tol)[:2]):
            return [Finding(name, "parallel_axis_shift", ERROR,
                            f"link '{name}': the inertia tensor is valid only after a parallel-axis shift by its "
                            f"CoG offset: {where}?", numbers)]
    if not psd:
        return [Finding(name, "inertia_not_psd", ERROR, f"link '{name}': a principal moment is negative "
                        f"({moments[0]:.6g} kg m^2)", numbers)]
    return [Finding(name, "triangle_inequality", ERROR,
                    f"link '{name}': principal moments {moments[0]:.6g} + {moments[1]:.6g} < {moments[2]:.6g} kg m^2 "
                    "(no rigid body has them: the pseudo-inertia is not positive semidefinite)", numbers)]


def _geometry_findings(name, mass, c, inertia, box, margin, density_range, gyration_factor) -> list[Finding]:
    lo, hi = box
    size = hi - lo
    found = []
    grow = margin * size + 1e-6
    if np.any(c < lo - grow) or np.any(c > hi + grow):
        found.append(Finding(name, "cog_outside_geometry", WARNING,
                             f"link '{name}': the centre of mass {np.round(c, 4).tolist()} m lies outside its collision "
                             f"geometry's bounding box {np.round(lo, 4).tolist()} .. {np.round(hi, 4).tolist()} m",
                             {"cog": c.tolist(), "box_min": lo.tolist(), "box_max": hi.tolist()}))
    volume = float(np.prod(size))
    if volume > 0:
        density = mass / volume
        if not density_range[0] <= density <= density_range[1]:
            found.append(Finding(name, "density_implausible", WARNING,
                                 f"link '{name}': {mass:g} kg in a bounding box of {volume:.4g} m^3 is "
                                 f"{density:.4g} kg/m^3 (plausible: {density_range[0]:g} to {density_range[1]:g})",
                                 {"mass": mass, "box_volume": volume, "density": density}))
    half_diagonal = 0.5 * float(np.linalg.norm(size))
    radius = math.sqrt(max(float(np.linalg.eigvalsh(inertia).max()), 0.0) / mass)
    if half_diagonal > 0 and radius > gyration_factor * half_diagonal:
        found.append(Finding(name, "gyration_implausible", WARNING,
                             f"link '{name}': radius of gyration {radius:.4g} m against a geometry of half diagonal "
                             f"{half_diagonal:.4g} m (a missing decimal in the tensor?)",
                             {"radius_of_gyration": radius, "half_diagonal": half_diagonal}))
    return found


def _effort_findings(root: ET.Element, mimics: set) -> list[Finding]:
    found = []
    for joint in root.iter("joint"):
        kind, name = joint.get("type", "fixed"), joint.get("name")
        if kind in ("fixed", "floating", "planar") or name in mimics:
            continue
        limit = joint.find("limit")
        effort = None if limit is None else limit.get("effort")
        if effort is None:
            found.append(Finding(name, "effort_missing", WARNING, f"joint '{name}' has no <limit effort=...>: no "
                                 "capacity or margin for it", {"effort": None}))
        elif float(effort) == 0:
            found.append(Finding(name, "effort_zero", WARNING, f"joint '{name}' has effort 0: no capacity or margin "
                                 "for it", {"effort": 0.0}))
    return found
