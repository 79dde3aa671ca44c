"""Collision checks of a robot (Pinocchio + coal) against itself, the floor and a world, one or many at a time.

Conventions (docs/architecture.md, "Collisions"):

- The geometry is the description's ``<collision>`` elements, convex hulls
  of the meshes by default (:mod:`manipkit.kinematics.collision_geometry`,
  whose names are importable from here too).
- A robot without ``<collision>`` elements, or whose collision meshes are
  missing, has no collision checks: :class:`CollisionError` names what is
  missing. It is never reported collision-free.
- Pairs are pairs of links. Not checked by default: links joined by a joint
  (adjacent; a link without geometry is passed through, as MoveIt's Setup
  Assistant does), links that no joint moves apart (both on the same rigid
  body), and the pairs an SRDF's ``<disable_collisions>`` names.
- Everything is placed and reported in the robot's root link frame (its
  base as the URDF has it: ``panda_link0``, ``base_link`` of the bundled
  arms, ``base_footprint`` on the ground for the mobile manipulator).
- The floor is the plane ``z = floor`` in the root frame; the space below it
  is solid. Links that stand on it are not checked against it: those no joint
  moves relative to the root, and those touching it (within :data:`RESTING`)
  at the robot's default configuration (wheels).
- Distances are in metres: positive is the gap between the two closest
  points, negative the penetration depth of a pair in contact (coal gives no
  depth between two meshes: such a pair reads 0). Witness points are given
  in the root frame.
- Many configurations at once (:meth:`CollisionChecker.in_collision`,
  :meth:`CollisionChecker.contact_counts`, :func:`collision_free`) run in
  Pinocchio's ``computeCollisionsInParallel``: C++ threads without the GIL
  (``workers``, default every core). Pinocchio's one-configuration calls
  (``computeCollisions``) hold the GIL, so Python threads around them do
  not run at once. Every query starts afresh, so the answers do not depend
  on the number of threads.
"""

from __future__ import annotations

import os
import threading
import weakref
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING

import coal
import numpy as np
import pinocchio as pin

from manipkit.description.srdf import Srdf
from manipkit.errors import CollisionError
from manipkit.kinematics.collision_geometry import (  # the geometry's names stay importable from here, as before
    GEOMETRIES,
    CollisionGeometry,
    adjacent_links,
    collision_geometry,
    link_pair,
)
from manipkit.text import printable, short_text

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = [
    "FLOOR",
    "GEOMETRIES",
    "MAX_THREADS",
    "MIN_ROWS_PER_THREAD",
    "NO_SRDF",
    "CollisionChecker",
    "CollisionGeometry",
    "CollisionReport",
    "CollisionSettings",
    "LinkPair",
    "adjacent_links",
    "collision_free",
    "collision_geometry",
    "collisions",
    "other_geometry",
    "read_srdf",
    "resolve_srdf",
    "srdf_check",
    "thread_count",
]

#: The name the floor goes by in pairs and messages.
FLOOR = "floor"
#: A link closer to the floor than this (m) at the default configuration stands on it (wheels) and is not checked
#: against it; one deeper in it is.
RESTING = 1e-3
#: ``srdf=`` of no SRDF at all (``--srdf none``); ``srdf=None`` is the SRDF the robot ships.
NO_SRDF = "none"
#: Most threads of one batched check (each holds a copy of Pinocchio's workspaces).
MAX_THREADS = 64
#: Fewest configurations per thread of a batched check (about 10 ms of work): waking a second thread costs from
#: 0.1 ms on an idle machine to a scheduler time slice (several ms) on a busy one, so smaller batches run on one.
MIN_ROWS_PER_THREAD = 1000

_CACHE_LOCK = threading.Lock()


# ----------------------------------------------------------------------
# SRDF
# ----------------------------------------------------------------------


def read_srdf(path: str | os.PathLike, robot: Robot) -> dict[tuple[str, str], str]:
    """The ``<disable_collisions link1= link2= reason=/>`` of an SRDF file: link pair (sorted) -> reason.

    Read by :func:`manipkit.description.srdf.read_srdf_file` (bounded in size, no entities). An MJCF
    file (:func:`manipkit.description.mjcf.is_mjcf`) gives instead the pairs its contact rules exclude
    (:func:`manipkit.description.mjcf.mjcf_disabled_pairs`; the robot's own description: the pairs read
    when it was loaded, :attr:`Robot.srdf <manipkit.kinematics.robot.Robot>`), compiled within what the
    robot may read (``allow_read``).

    Raises
    ------
    CollisionError
        The file is not XML, an element lacks ``link1``/``link2``, or names a
        link the robot does not have (the message names the element, the
        link, quoted with a bounded prefix, and the closest link names).
    InputFileError
        The file cannot be read (missing, a folder, too large).
    """
    from manipkit.description.mjcf import is_mjcf, mjcf_rules
    from manipkit.description.srdf import check_srdf_links, read_srdf_file

    if is_mjcf(path):
        own = getattr(robot, "srdf", None)
        if own is not None and own.kind == "mjcf" and os.path.realpath(own.path) == os.path.realpath(path):
            return own.pairs()
        srdf = mjcf_rules(path, robot.name, allow_read=getattr(robot, "allow_read", ()))
    else:
        srdf = read_srdf_file(path)
    check_srdf_links(Srdf(srdf.path, srdf.robot, srdf.disabled, (), kind=srdf.kind), robot.frame_names, robot.name)
    return srdf.pairs()


def resolve_srdf(robot: Robot, srdf) -> tuple[dict[tuple[str, str], str], str]:
    """The pairs ``srdf=`` disables and where they come from: (pairs, file or ``""``).

    ``srdf`` is None (the default everywhere: the SRDF the robot ships,
    :attr:`Robot.srdf <manipkit.kinematics.robot.Robot>`, for a robot loaded
    from MJCF its file's contact rules; else none), :data:`NO_SRDF`
    (``"none"``: no SRDF), a path (an SRDF, or an MJCF file: its rules,
    :func:`read_srdf`), or pairs as a dict (link pair -> reason; an empty one
    is no SRDF). The file is named in words by
    :func:`manipkit.description.mjcf.rules_source_text`.
    """
    if srdf is None:
        shipped = getattr(robot, "srdf", None)
        return ({}, "") if shipped is None else (shipped.pairs(), str(shipped.path))
    if isinstance(srdf, dict):
        return dict(srdf), ""
    if isinstance(srdf, str) and srdf.strip().lower() == NO_SRDF:
        return {}, ""
    return read_srdf(srdf, robot), str(srdf)


# ----------------------------------------------------------------------
# Results
# ----------------------------------------------------------------------


@dataclass(frozen=True)
class LinkPair:
    """Two links (or a link and the floor) and the distance between them.

    ``distance`` (m) is positive for a gap, negative for the penetration
    depth of a pair in contact; ``point1`` and ``point2`` are the witness
    points on ``link1`` and ``link2`` in the root link's frame (m).
    """

    link1: str
    link2: str
    distance: float
    point1: tuple[float, float, float]
    point2: tuple[float, float, float]

    def as_dict(self) -> dict:
        """JSON-safe: names, distance (m), witness points in the base frame (m)."""
        return {"link1": self.link1, "link2": self.link2, "distance": self.distance,
                "point1": list(self.point1), "point2": list(self.point2)}


@dataclass(frozen=True)
class CollisionReport:
    """The answer of :func:`collisions` for one configuration.

    Attributes
    ----------
    in_collision : bool
        Some checked pair is in contact.
    pairs : tuple of LinkPair
        Every pair in contact, deepest first.
    min_distance : LinkPair or None
        The closest checked pair (in contact: the deepest); None when no pair is checked.
    checked : int
        How many link pairs were checked.
    base : str
        The frame of the witness points (the root link).
    geometry : str
        ``"hulls"`` or ``"meshes"``.
    srdf : str
        The file whose disabled pairs were not checked: an SRDF (its ``<disable_collisions>``) or an MJCF
        (its contact rules); ``""``: none.
    default_contacts : tuple of (str, str)
        Without SRDF pairs: the pairs left out because they are in contact at the home configuration.
    """

    robot: str
    geometry: str
    base: str
    q: tuple[float, ...]
    in_collision: bool
    pairs: tuple[LinkPair, ...]
    min_distance: LinkPair | None
    checked: int
    srdf: str = ""
    default_contacts: tuple = ()

    def as_dict(self) -> dict:
        """JSON-safe: ``in_collision``, ``pairs``, ``min_distance`` (and the robot, geometry, frame, pair count,
        the file of the disabled pairs, ``srdf``, and its kind, ``srdf_kind``: ``"srdf"``, ``"mjcf"`` or None)."""
        from manipkit.description.mjcf import is_mjcf

        kind = None if not self.srdf else "mjcf" if is_mjcf(self.srdf) else "srdf"
        return {
            "robot": self.robot, "geometry": self.geometry, "frame": self.base, "in_collision": self.in_collision,
            "pairs": [p.as_dict() for p in self.pairs],
            "min_distance": None if self.min_distance is None else self.min_distance.as_dict(),
            "checked_pairs": self.checked, "srdf": self.srdf or None, "srdf_kind": kind,
            "left_out_in_contact_at_home": [list(p) for p in self.default_contacts],
        }


# ----------------------------------------------------------------------
# Checker
# ----------------------------------------------------------------------


class CollisionChecker:
    """Collision checks of one robot against itself, the floor and a world, with a set of pairs; immutable.

    Parameters
    ----------
    robot : Robot
    geometry : str, keyword-only
        ``"hulls"`` (default) or ``"meshes"``.
    srdf : path-like, dict or "none", optional
        An SRDF file whose ``<disable_collisions>`` pairs are not checked, or
        such pairs as a dict (link pair -> reason); default (None): the SRDF
        the robot ships (:attr:`Robot.srdf <manipkit.kinematics.robot.Robot>`);
        ``"none"`` (:data:`NO_SRDF`) or an empty dict: none.
    floor : float or None
        The floor's height ``z`` (m) in the root link's frame; None: no floor.
    world : sequence of (name, coal geometry, T_base_object), optional
        Obstacles fixed in the root link's frame (:func:`manipkit.kinematics.world.read_world`).
    pairs : sequence of (str, str), optional
        Check exactly these link pairs (the allowed-collision matrix does);
        default: every pair that can come into contact less the disabled ones.
    self_collisions : bool, keyword-only
        False: check the links against the floor and the world only.
    skip_home_contacts : bool, keyword-only
        With no SRDF pairs (none given or shipped, or an SRDF that disables
        none), leave out the pairs in contact at the home configuration
        (``robot.q()``) too, as MoveIt's Setup Assistant disables them
        ("Default"); they are :attr:`default_contacts`. The command line does
        (``manipkit collisions``, ``ik --collisions``, reach maps, the viewer);
        default False: every pair the SRDF leaves is checked.

    Notes
    -----
    Pinocchio's workspaces are the calling thread's, so threads may share a checker.
    """

    def __init__(self, robot: Robot, *, geometry: str = "hulls", srdf=None, floor: float | None = None,
                 world=(), pairs=None, self_collisions: bool = True, skip_home_contacts: bool = False):
        self.robot = robot
        self.geometry = collision_geometry(robot, geometry)
        self.disabled, self.srdf = resolve_srdf(robot, srdf)
        if floor is not None and not np.isfinite(floor):
            raise CollisionError(f"floor {floor}: give a finite height in metres, or no floor")
        self.floor = None if floor is None else float(floor)
        self.base = robot.root_link
        model = self.geometry.model.copy()
        links = list(self.geometry.links)
        extra = []  # (name, geometry, T_root_object)
        if self.floor is not None:
            T_root_floor = np.eye(4)
            T_root_floor[2, 3] = self.floor
            extra.append((FLOOR, coal.Halfspace(np.array([0.0, 0.0, 1.0]), 0.0), T_root_floor))
        frames = set(robot.frame_names) | {FLOOR}
        for name, _, _ in world:  # pairs are named by their two sides: an obstacle is never taken for a link
            if name in frames:
                raise CollisionError(f"world obstacle '{printable(str(name))[:100]}' has the name of "
                                     f"{'the floor' if name == FLOOR else f'a frame of robot {robot.name!r}'}; "
                                     "give the obstacle another name")
        extra += list(world)
        for name, shape, T_root_object in extra:
            placement = pin.SE3(np.asarray(T_root_object, dtype=float))
            model.addGeometryObject(pin.GeometryObject(f"manipkit_world/{name}", 0, 0, placement, shape))
            links.append(name)
        obstacles = {name for name, _, _ in extra}
        self.default_contacts: tuple[tuple[str, str], ...] = ()
        if pairs is None:
            wanted = [p for p in self.geometry.candidate_pairs() if p not in self.disabled] if self_collisions else []
            if wanted and not self.disabled and skip_home_contacts:  # as MoveIt's Setup Assistant, without an SRDF
                home = CollisionChecker(robot, geometry=geometry, pairs=wanted).pairs_in_contact(robot.q())
                self.default_contacts = tuple(p for p in wanted if p in home)
                wanted = [p for p in wanted if p not in home]
            resting = self._resting_on_floor() if self.floor is not None else set()
            wanted += [(link, name) for name in obstacles for link in self.geometry.link_names
                       if not (name == FLOOR and link in resting)]
        else:
            wanted = [tuple(p) for p in pairs]
        wanted_keys = {link_pair(*p) for p in wanted}
        self.pairs: tuple[tuple[str, str], ...] = tuple(dict.fromkeys(link_pair(*p) for p in wanted))
        self._pair_links: list[tuple[str, str]] = []
        for i in range(len(links)):
            for j in range(i + 1, len(links)):
                if links[i] != links[j] and link_pair(links[i], links[j]) in wanted_keys:
                    model.addCollisionPair(pin.CollisionPair(i, j))
                    self._pair_links.append((links[i], links[j]))
        self._links = tuple(links)
        self.model = model
        self._local = threading.local()
        self._pool_lock = threading.Lock()
        self._pools: dict[int, object] = {}  # threads -> Pinocchio's pool of workspaces
        self.disabled = MappingProxyType(self.disabled)
        self._frozen = True

    def __setattr__(self, name, value):
        if getattr(self, "_frozen", False):
            raise AttributeError(f"a CollisionChecker is immutable: cannot set '{name}' (make another one)")
        object.__setattr__(self, name, value)

    def _resting_on_floor(self) -> set[str]:
        """Links that stand on the floor: rigid with the root, or touching it (within :data:`RESTING`) at ``robot.q()``."""
        shapes, robot = self.geometry, self.robot
        data = shapes.model.createData()
        pin.updateGeometryPlacements(robot.model, robot.model.createData(), shapes.model, data,
                                     robot.pinocchio_configuration(robot.q()))
        floor, at = coal.Halfspace(np.array([0.0, 0.0, 1.0]), self.floor), coal.Transform3s()
        gap: dict[str, float] = {}
        for link, body, obj, placement in zip(shapes.links, shapes.bodies, shapes.model.geometryObjects, data.oMg):
            result = coal.DistanceResult()
            coal.distance(obj.geometry, coal.Transform3s(placement.rotation, placement.translation), floor, at,
                          coal.DistanceRequest(), result)
            gap[link] = min(gap.get(link, np.inf), -np.inf if body == 0 else result.min_distance)
        return {link for link, distance in gap.items() if abs(distance) <= RESTING or distance == -np.inf}

    @property
    def _data(self) -> pin.GeometryData:
        data = getattr(self._local, "data", None)
        if data is None:
            data = self._local.data = _without_cached_guesses(self.model.createData())
        return data

    def report(self, q=None) -> CollisionReport:
        """Whether the robot at ``q`` is in collision, every pair in contact and the closest pair."""
        robot = self.robot
        q = robot.q() if q is None else robot.q(q)
        data = self._data
        if not self._pair_links:
            return CollisionReport(robot.name, self.geometry.geometry, self.base, tuple(q), False, (), None, 0,
                                   self.srdf, self.default_contacts)
        configuration = robot.pinocchio_configuration(q)
        pin.computeCollisions(robot.model, robot.data, self.model, data, configuration, False)
        pin.computeDistances(robot.model, robot.data, self.model, data, configuration)
        by_pair: dict[tuple[str, str], LinkPair] = {}
        contact: set[tuple[str, str]] = set()
        for k, (a, b) in enumerate(self._pair_links):
            result = data.distanceResults[k]
            hit = data.collisionResults[k].isCollision()
            distance = float(result.min_distance)
            if hit:
                distance = min(distance, 0.0)
            key = (a, b)
            if key not in by_pair or distance < by_pair[key].distance:
                by_pair[key] = LinkPair(a, b, distance, self._in_base(result.getNearestPoint1()),
                                        self._in_base(result.getNearestPoint2()))
            if hit:
                contact.add(key)
        ordered = sorted(by_pair.values(), key=lambda p: (p.distance, p.link1, p.link2))
        colliding = tuple(p for p in ordered if (p.link1, p.link2) in contact)
        closest = colliding[0] if colliding else ordered[0]
        return CollisionReport(robot.name, self.geometry.geometry, self.base, tuple(float(v) for v in q),
                               bool(colliding), colliding, closest, len(self.pairs), self.srdf,
                               self.default_contacts)

    def distances(self, q=None) -> dict[tuple[str, str], float]:
        """Every checked pair's distance at ``q`` (m; negative: penetration depth; 0 for meshes in contact), by pair."""
        robot = self.robot
        q = robot.q() if q is None else robot.q(q)
        data = self._data
        configuration = robot.pinocchio_configuration(q)
        pin.computeCollisions(robot.model, robot.data, self.model, data, configuration, False)
        pin.computeDistances(robot.model, robot.data, self.model, data, configuration)
        found: dict[tuple[str, str], float] = {}
        for k, (a, b) in enumerate(self._pair_links):
            distance = float(data.distanceResults[k].min_distance)
            if data.collisionResults[k].isCollision():
                distance = min(distance, 0.0)
            key = link_pair(a, b)
            found[key] = min(found.get(key, np.inf), distance)
        return found

    @staticmethod
    def _in_base(point) -> tuple[float, float, float]:
        return (float(point[0]), float(point[1]), float(point[2]))

    def pairs_in_contact(self, q) -> frozenset:
        """The link pairs (sorted names) in contact at ``q`` (a whole-robot joint vector), without distances."""
        data = self._data
        pin.computeCollisions(self.robot.model, self.robot.data, self.model, data,
                              self.robot.pinocchio_configuration(q), False)
        return frozenset(link_pair(*self._pair_links[k]) for k, result in enumerate(data.collisionResults) if result.isCollision())

    def in_collision(self, Q, *, workers: int | None = None) -> np.ndarray:
        """For each row of ``Q`` (N, n), whether some checked pair is in contact: (N,) bool.

        Runs Pinocchio's ``computeCollisionsInParallel`` with a broad phase
        (a dynamic AABB tree) on at most ``workers`` threads (default: every
        core; OpenMP threads in C++), one per :data:`MIN_ROWS_PER_THREAD`
        configurations at most, stopping at a configuration's first contact;
        the answers equal :meth:`report`'s on any thread count (tested).
        """
        configurations = self._configurations(Q)
        workers = thread_count(workers)
        if not self._pair_links or configurations.shape[1] == 0:
            return np.zeros(configurations.shape[1], dtype=bool)
        workers = max(1, min(workers, configurations.shape[1] // MIN_ROWS_PER_THREAD))
        with self._pool_lock:  # a pool's workspaces serve one call at a time
            hits = pin.computeCollisionsInParallel(workers, self._pool(workers), configurations, True, False)
        return np.asarray(hits, dtype=bool).reshape(configurations.shape[1])

    def contact_counts(self, Q, *, workers: int | None = None) -> dict[tuple[str, str], int]:
        """In how many rows of ``Q`` (N, n) each checked link pair is in contact: {pair: count}, in :attr:`pairs` order.

        :meth:`in_collision` (Pinocchio's C++ threads, ``workers``) finds the
        rows with any contact, usually a minority; only those are then checked
        pair by pair (:meth:`pairs_in_contact`, on the calling thread). Equal to
        counting :meth:`pairs_in_contact` on every row (tested), on any thread count.
        """
        counts = dict.fromkeys(self.pairs, 0)
        Q = np.asarray(Q, dtype=float)
        for q in Q.reshape(-1, Q.shape[-1])[self.in_collision(Q, workers=workers)] if Q.size else ():
            for pair in self.pairs_in_contact(q):
                counts[pair] += 1
        return counts

    def _configurations(self, Q) -> np.ndarray:
        """Pinocchio configurations (nq, N) of the whole-robot rows of ``Q``, checked (one :class:`CollisionError`)."""
        from manipkit.kinematics.chain import joint_array

        robot = self.robot
        Q = joint_array(Q)
        if Q.ndim == 1:
            Q = Q[None, :]
        if Q.ndim != 2 or Q.shape[1] != len(robot.joint_names):
            raise CollisionError(f"robot '{robot.name}' needs configurations of {len(robot.joint_names)} joint values "
                                 f"(N, {len(robot.joint_names)}); got shape {Q.shape}")
        if not np.all(np.isfinite(Q)):
            raise CollisionError("joint values must be finite numbers")
        return robot.joint_layout.configurations(Q)

    def _pool(self, workers: int):
        """Pinocchio's per-thread workspaces for ``workers`` threads, made once (the caller holds ``_pool_lock``).

        A dynamic AABB tree prunes far pairs first (2-3x fewer narrow-phase
        queries); cached GJK guesses are off.
        """
        pool = self._pools.get(workers)
        if pool is None:
            pool = pin.BroadPhaseManagerPool_DynamicAABBTreeCollisionManager(self.robot.model, self.model, workers)
            for data in pool.getGeometryDatas():
                _without_cached_guesses(data)
            self._pools[workers] = pool
        return pool

    def __repr__(self) -> str:
        return (f"CollisionChecker({self.robot.name!r}, {self.geometry.geometry}, {len(self.pairs)} link pairs, "
                f"floor {'none' if self.floor is None else short_text(self.floor)})")


@dataclass(frozen=True)
class CollisionSettings:
    """What a batched check looks at, as plain data: picklable (reach-map blocks on Dask workers) and JSON-able.

    Attributes
    ----------
    self_collisions : bool
        Check the robot against itself.
    floor : float or None
        Floor height (m) in the root link's frame, or no floor.
    geometry : str
        ``"hulls"`` or ``"meshes"``.
    disabled : tuple of (str, str, str)
        Pairs not checked (an SRDF's ``<disable_collisions>``: link1, link2, reason).
    srdf : str
        Where ``disabled`` came from (a path, or ``""``), recorded in metadata.
    skip_home_contacts : bool
        As :class:`CollisionChecker`'s: without SRDF pairs, leave out the pairs in contact at home.
    """

    self_collisions: bool = True
    floor: float | None = None
    geometry: str = "hulls"
    disabled: tuple = ()
    srdf: str = ""
    skip_home_contacts: bool = False

    @classmethod
    def parse(cls, robot: Robot, what: str, *, floor: float | None = 0.0, geometry: str = "hulls",
              srdf=None, skip_home_contacts: bool = False) -> CollisionSettings | None:
        """Settings from ``what`` (``"self"``, ``"floor"``, ``"self,floor"`` or ``"none"``: None).

        The floor is at ``floor`` (m, root frame) when ``what`` names it.
        The geometry is built here, so a robot without it is refused before any work.
        """
        words = {w.strip() for w in str(what).lower().split(",") if w.strip()}
        if words == {"none"}:
            return None
        if not words or not words <= {"self", "floor"}:
            raise CollisionError(f"collisions '{printable(str(what))}': give self, floor, self,floor or none")
        if "floor" in words and (floor is None or not np.isfinite(floor)):
            raise CollisionError(f"collisions '{printable(str(what))}' needs a floor height in metres, not {floor}")
        collision_geometry(robot, geometry)  # CollisionError now, before a long build
        pairs, source = resolve_srdf(robot, srdf)
        disabled = tuple(sorted((a, b, r) for (a, b), r in pairs.items()))
        return cls("self" in words, float(floor) if "floor" in words else None, geometry, disabled, source,
                   bool(skip_home_contacts))

    def checker(self, robot: Robot) -> CollisionChecker:
        """The :class:`CollisionChecker` of these settings for ``robot``, built once per robot (and process)."""
        with _CACHE_LOCK:
            checker = _CHECKER_CACHE.get(robot, {}).get(self)
        if checker is None:
            checker = CollisionChecker(robot, geometry=self.geometry, srdf={(a, b): r for a, b, r in self.disabled},
                                       floor=self.floor, self_collisions=self.self_collisions,
                                       skip_home_contacts=self.skip_home_contacts)
            with _CACHE_LOCK:
                checker = _CHECKER_CACHE.setdefault(robot, {}).setdefault(self, checker)
        return checker

    def free(self, robot: Robot, Q) -> np.ndarray:
        """(N,) bool: the rows of ``Q`` (whole-robot vectors) with no checked pair in contact."""
        return ~self.checker(robot).in_collision(Q)

    def first_free(self, robot: Robot, Q, groups) -> np.ndarray:
        """(N,) bool: for each group, its first row (in row order) not in collision; rows of group -1 are skipped.

        Checks the first row of every group at once, then the next row of the
        groups whose row collided, and so on: about one check per group
        instead of one per row (a reach map needs one free sample per voxel-bin).
        """
        groups = np.asarray(groups)
        order = np.lexsort((np.arange(len(groups)), groups))
        order = order[groups[order] >= 0]
        starts = np.flatnonzero(np.diff(groups[order], prepend=-2)) if order.size else np.zeros(0, dtype=np.intp)
        ends = np.append(starts[1:], order.size)
        position, active = starts.copy(), np.arange(starts.size)
        first = np.zeros(len(groups), dtype=bool)
        while active.size:
            candidates = order[position[active]]
            free = self.free(robot, np.asarray(Q)[candidates])
            first[candidates[free]] = True
            position[active] += 1
            active = active[~free & (position[active] < ends[active])]
        return first

    def as_dict(self) -> dict:
        """JSON-safe, for a map's metadata: what was checked, with which geometry and matrix."""
        checked = [name for name, on in (("self", self.self_collisions), ("floor", self.floor is not None)) if on]
        return {"checked": checked, "floor": self.floor, "geometry": self.geometry, "srdf": self.srdf or None,
                "disabled_pairs": len(self.disabled)}


_CHECKER_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # Robot -> {CollisionSettings: checker}


def _without_cached_guesses(data: pin.GeometryData) -> pin.GeometryData:
    """``data`` with coal's cached GJK guess off for every pair (each query starts afresh), and contacts on.

    Pinocchio turns the cache on; with it a query starts from the previous
    configuration's answer, and coal's GJK then misses (or invents) contacts
    of a few millimetres between cylinders now and then (measured: 8 of 5,000
    iiwa14 configurations differed from fresh queries). The flag is deprecated
    in coal 3 but still the one that turns the cache off.
    """
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        for request in (*data.collisionRequests, *data.distanceRequests):
            request.enable_cached_gjk_guess = False
    for request in data.collisionRequests:
        # Pinocchio turns contacts off; coal's boolean-only path then misses deep overlaps of some shapes
        # (measured: two OMY-3M cylinders 18.8 mm into each other reported apart; coal.collide with contacts: hit)
        request.enable_contact = True
    return data


def thread_count(workers: int | None) -> int:
    """``workers`` checked: a whole number of threads from 1 to :data:`MAX_THREADS`; None: every core.

    Raises :class:`CollisionError` naming the bound (each thread holds a copy of the robot's workspaces).
    """
    if workers is None:
        return max(1, min(MAX_THREADS, os.cpu_count() or 1))
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or not 1 <= workers <= MAX_THREADS:
        raise CollisionError(f"workers {printable(repr(workers))}: give a whole number of threads, at least 1 "
                             f"and at most {MAX_THREADS}")
    return int(workers)


def collisions(robot: Robot, q=None, *, srdf=None, floor: float | None = None, world=None,
               geometry: str = "hulls") -> CollisionReport:
    """Collisions of the robot at ``q`` with itself (and the floor, and a world): every pair in contact, the closest.

    Parameters
    ----------
    robot : Robot
    q : array_like or dict, optional
        Anything ``robot.q`` takes; default: the robot's default configuration.
    srdf : path-like or "none", optional
        An SRDF whose ``<disable_collisions>`` pairs are not checked (adjacent
        and rigidly joined links never are); default: the SRDF the robot
        ships, if any (:func:`resolve_srdf`); without one, the pairs in
        contact at the home configuration are not checked either.
    floor : float or None, keyword-only
        Height ``z`` (m) of the floor in the root link's frame; None: no floor.
    world : path-like, optional
        A world file of obstacles (:func:`manipkit.kinematics.world.read_world`).
    geometry : str, keyword-only
        ``"hulls"`` (convex hulls of the meshes, the default) or ``"meshes"``.

    Returns
    -------
    CollisionReport

    Raises
    ------
    CollisionError
        No collision geometry, missing meshes, an SRDF naming unknown links,
        a malformed world file.

    Examples
    --------
    >>> from manipkit.kinematics.robot import load
    >>> collisions(load("course_arm")).in_collision
    False
    """
    return _checker(robot, srdf, floor, world, geometry).report(q)


def srdf_check(robot: Robot, srdf, *, geometry: str = "hulls") -> tuple[LinkPair, ...]:
    """The pairs an SRDF leaves checked that are in contact at the robot's default configuration (``robot.q()``).

    A matrix is made for one geometry (Franka's SRDF for the meshes leaves
    pairs touching on primitive shapes); empty when the SRDF holds for
    ``geometry``. ``manipkit collisions --srdf`` warns with these pairs.
    """
    return CollisionChecker(robot, geometry=geometry, srdf=srdf).report().pairs


def other_geometry(checker: CollisionChecker, q=None) -> tuple[str, dict[tuple[str, str], float]] | None:
    """The same pairs checked with the other kind of geometry (hulls for meshes, meshes for hulls) at ``q``.

    Returns (the other kind, {pair: distance (m)}) for the checker's pairs
    between links and with the floor (not with a world's obstacles), or None
    when the robot has no meshes (both kinds are the same shapes). A hull
    contains its mesh, so a pair's hull distance is at most its mesh
    distance: hulls can report a contact the meshes do not have, never the
    other way round.
    """
    if not checker.geometry.has_meshes:
        return None
    kind = "hulls" if checker.geometry.geometry == "meshes" else "meshes"
    names = set(checker.geometry.link_names) | ({FLOOR} if checker.floor is not None else set())
    pairs = [p for p in checker.pairs if p[0] in names and p[1] in names]
    if not pairs:
        return kind, {}
    return kind, CollisionChecker(checker.robot, geometry=kind, floor=checker.floor, pairs=pairs).distances(q)


def collision_free(robot: Robot, Q, *, srdf=None, floor: float | None = None, world=None, geometry: str = "hulls",
                   workers: int | None = None) -> np.ndarray:
    """For each configuration (row of ``Q``, (N, n) in ``robot.joint_names`` order): no checked pair in contact.

    One call for many configurations: Pinocchio's ``computeCollisionsInParallel``
    on ``workers`` threads (default: every core). Arguments as :func:`collisions`.

    Returns
    -------
    free : ndarray of bool, shape (N,)
    """
    return ~_checker(robot, srdf, floor, world, geometry).in_collision(Q, workers=workers)


def _checker(robot, srdf, floor, world, geometry) -> CollisionChecker:
    obstacles = ()
    if world is not None:
        from manipkit.kinematics.world import read_world

        obstacles = read_world(world)
    return CollisionChecker(robot, geometry=geometry, srdf=srdf, floor=floor, world=obstacles)
