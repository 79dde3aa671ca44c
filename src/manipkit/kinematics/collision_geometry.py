"""Collision geometry of a robot: its ``<collision>`` elements as a Pinocchio ``GeometryModel`` (coal shapes).

Conventions (docs/architecture.md, "Collisions"); the checks on this
geometry are :mod:`manipkit.kinematics.collisions`:

- The geometry is the description's ``<collision>`` elements, read by
  Pinocchio's ``buildGeomFromUrdfString``; meshes are found by the one mesh
  resolver (:func:`manipkit.description.meshes.urdf_with_mesh_paths`), as the
  viewer finds its meshes. ``geometry="hulls"`` (the default) replaces every
  mesh by its convex hull (coal's qhull); ``"meshes"`` keeps the triangles.
  Boxes, cylinders, spheres and capsules stay what they are.
- Every mesh is checked before coal builds anything from it (:func:`_checked_mesh`):
  finite vertices, at most :data:`~manipkit.bounds.MAX_MESH_VERTICES`, an extent in
  at least two directions (a point or a line, e.g. ``scale="0 0 0"``, is refused). A flat
  mesh (a thin plate, or ``scale="1 1 0"``) has no convex hull of its own: it is kept as
  its triangles, which coal checks exactly (qhull crashed the process on one).
- A robot without ``<collision>`` elements, or whose collision meshes are
  missing, has no collision geometry: :class:`~manipkit.errors.CollisionError`
  names what is missing.
- Pairs are pairs of links, names sorted (:func:`link_pair`); adjacent links
  are those joined by a joint, links without geometry passed through, as
  MoveIt's Setup Assistant counts them (:func:`adjacent_links`).
"""

from __future__ import annotations

import threading
import weakref
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import coal
import numpy as np
import pinocchio as pin

from manipkit.bounds import MAX_MESH_VERTICES
from manipkit.errors import CollisionError, DescriptionError
from manipkit.text import printable

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["GEOMETRIES", "CollisionGeometry", "adjacent_links", "collision_geometry", "link_pair"]

#: The kinds of collision geometry: convex hulls of the meshes (the default) or the meshes themselves.
GEOMETRIES = ("hulls", "meshes")

_GEOMETRY_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # Robot -> {geometry: CollisionGeometry}
_CACHE_LOCK = threading.Lock()


def link_pair(a: str, b: str) -> tuple[str, str]:
    """A link pair in one order (sorted), so (a, b) and (b, a) are one key.

    >>> link_pair("panda_link5", "panda_hand")
    ('panda_hand', 'panda_link5')
    """
    return (a, b) if a <= b else (b, a)


@dataclass(frozen=True, eq=False)
class CollisionGeometry:
    """A robot's collision geometry, built once per robot and kind (:func:`collision_geometry`); never modified.

    Attributes
    ----------
    robot_name : str
    geometry : str
        ``"hulls"`` or ``"meshes"`` (:data:`GEOMETRIES`).
    model : pinocchio.GeometryModel
        The objects (no collision pairs); checkers copy it and add theirs.
    links : tuple of str
        The link of each object, in the model's order.
    bodies : tuple of int
        The Pinocchio joint that moves each object (0: none, rigid with the root).
    adjacent : frozenset of (str, str)
        Link pairs joined by a joint (links without geometry passed through), sorted names.
    """

    robot_name: str
    geometry: str
    model: pin.GeometryModel = field(repr=False)
    links: tuple[str, ...]
    bodies: tuple[int, ...]
    adjacent: frozenset

    @property
    def has_meshes(self) -> bool:
        """Whether some object is a mesh (``"meshes"``) or a mesh's hull (``"hulls"``): the two kinds then differ."""
        return any(isinstance(obj.geometry, (*_BVH_TYPES, coal.ConvexBase)) for obj in self.model.geometryObjects)

    @property
    def link_names(self) -> tuple[str, ...]:
        """The links that have collision geometry, in model order (each once)."""
        return tuple(dict.fromkeys(self.links))

    def rigid(self, a: str, b: str) -> bool:
        """Whether no joint moves links ``a`` and ``b`` apart (their objects all hang on one Pinocchio joint)."""
        joints = {body for link, body in zip(self.links, self.bodies) if link in (a, b)}
        return len(joints) == 1

    def candidate_pairs(self) -> tuple[tuple[str, str], ...]:
        """Every link pair that can come into contact: not adjacent, not rigid, in model order."""
        names = self.link_names
        pairs = []
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                key = link_pair(a, b)
                if key not in self.adjacent and not self.rigid(a, b):
                    pairs.append(key)
        return tuple(pairs)


def collision_geometry(robot: Robot, geometry: str = "hulls") -> CollisionGeometry:
    """The robot's collision geometry of the kind ``geometry``, built on first use and cached per robot.

    Raises
    ------
    CollisionError
        ``geometry`` is not one of :data:`GEOMETRIES`; the robot has no
        ``<collision>`` element; a collision mesh cannot be found or read
        (the message names the link and the file).
    """
    if geometry not in GEOMETRIES:
        raise CollisionError(f"geometry '{printable(str(geometry))}' is not known; give one of {', '.join(GEOMETRIES)}")
    with _CACHE_LOCK:
        cached = _GEOMETRY_CACHE.get(robot, {}).get(geometry)
    if cached is not None:
        return cached
    built = _build_geometry(robot, geometry)
    with _CACHE_LOCK:
        return _GEOMETRY_CACHE.setdefault(robot, {}).setdefault(geometry, built)


def _build_geometry(robot: Robot, geometry: str) -> CollisionGeometry:
    import xml.etree.ElementTree as ET

    from manipkit.description.access import ReadPolicy
    from manipkit.description.meshes import urdf_with_mesh_paths
    from manipkit.description.packages import PackageResolver
    from manipkit.kinematics.joints import native_call

    root = ET.fromstring(robot.urdf)
    if not any(link.find("collision") is not None for link in root.iter("link")):
        raise CollisionError(
            f"robot '{robot.name}' has no <collision> elements, so collisions cannot be checked for it; "
            "add <collision> geometry (box, cylinder, sphere or mesh) to its links"
        )
    near = robot.source.path if robot.source.path.exists() else None
    resolver = PackageResolver(dict(robot.package_dirs), near=near)
    policy = ReadPolicy(near, resolver, robot.allow_read) if near is not None else None  # as the viewer reads meshes
    try:
        text, package_dirs = urdf_with_mesh_paths(robot.urdf, resolver, relative_to=robot.source.path.parent,
                                                  element="collision", policy=policy)
    except DescriptionError as exc:
        raise CollisionError(f"robot '{robot.name}': collision geometry unavailable: {exc}") from None
    try:
        # on a sized stack; coal's raw "eigen: too many iterations" lines for a NaN mesh (refused below) captured
        model, _ = native_call(pin.buildGeomFromUrdfString, robot.model, text, pin.GeometryType.COLLISION,
                               package_dirs=package_dirs)
    except (ValueError, RuntimeError) as exc:
        raise CollisionError(
            f"robot '{robot.name}': Pinocchio cannot load the collision geometry: {' '.join(str(exc).split())}"
        ) from None
    links, bodies = [], []
    for obj in model.geometryObjects:
        links.append(robot.model.frames[obj.parentFrame].name)
        bodies.append(int(obj.parentJoint))
        if isinstance(obj.geometry, _BVH_TYPES):
            solid = _checked_mesh(obj.geometry, f"robot '{robot.name}': link '{printable(links[-1])}'")
            if geometry == "hulls" and solid:
                obj.geometry = _hull(obj.geometry, robot.name, links[-1])
    return CollisionGeometry(robot.name, geometry, model, tuple(links), tuple(bodies),
                             adjacent_links(root, set(links)))


_BVH_TYPES = tuple(getattr(coal, name) for name in ("BVHModelOBBRSS", "BVHModelOBB", "BVHModelAABB") if hasattr(coal, name))


#: An extent (m) at or below this is none: the mesh is flat in that direction.
_FLAT = 1e-9


def _checked_mesh(mesh, where: str) -> bool:
    """Whether a loaded collision mesh (coal BVH, scale applied) is a solid; False for a flat one (a thin plate).

    Raises
    ------
    CollisionError
        No vertices, more than :data:`~manipkit.bounds.MAX_MESH_VERTICES`, a vertex that is not finite (NaN,
        inf), or an extent in fewer than two directions (a point or a line: ``scale="0 0 0"``, one vertex).
    """
    count = int(mesh.num_vertices)
    if count > MAX_MESH_VERTICES:
        raise CollisionError(f"{where}: its collision mesh has {count} vertices, above the limit of "
                             f"{MAX_MESH_VERTICES}; simplify it (or give a primitive shape)")
    vertices = np.asarray(mesh.vertices(), dtype=float).reshape(-1, 3) if count else np.zeros((0, 3))
    if not len(vertices):
        raise CollisionError(f"{where}: its collision mesh has no vertices")
    finite = np.isfinite(vertices).all(axis=1)
    if not finite.all():
        raise CollisionError(f"{where}: its collision mesh has {int((~finite).sum())} vertices that are not finite "
                             f"(NaN or inf; the first is vertex {int(np.argmin(finite))}); fix the mesh file")
    extent = vertices.max(axis=0) - vertices.min(axis=0)
    if int((extent > _FLAT).sum()) < 2:
        raise CollisionError(f"{where}: its collision mesh spans {' x '.join(f'{e:.3g}' for e in extent)} m, a point "
                             "or a line, not a surface (a mesh scale of 0?); give a non-zero scale or another shape")
    return bool((extent > _FLAT).all())


def _hull(mesh, robot_name: str, link: str):
    """The convex hull of a coal BVH mesh (qhull), as a coal ``Convex``."""
    try:
        mesh.buildConvexHull(True, "Qt")
    except (ValueError, RuntimeError) as exc:
        raise CollisionError(f"robot '{robot_name}': link '{link}': the convex hull of its collision mesh cannot be "
                             f"built ({' '.join(str(exc).split())}); use geometry 'meshes'") from None
    return mesh.convex


def adjacent_links(robot_xml, with_geometry: set[str]) -> frozenset:
    """Link pairs joined by a joint, as MoveIt's Setup Assistant counts them ("Adjacent").

    A link with collision geometry is adjacent to its nearest ancestor with
    geometry (links without geometry between them are passed through), and
    so to the nearest descendants with geometry. Pairs are sorted names.
    """
    parent_of = {}
    for joint in robot_xml.iter("joint"):
        parent, child = joint.find("parent"), joint.find("child")
        if parent is not None and child is not None:
            parent_of[child.get("link")] = parent.get("link")
    pairs = set()
    for link in with_geometry:
        up, seen = parent_of.get(link), {link}
        while up is not None and up not in with_geometry and up not in seen:
            seen.add(up)
            up = parent_of.get(up)
        if up is not None and up in with_geometry:
            pairs.add(link_pair(link, up))
    return frozenset(pairs)
