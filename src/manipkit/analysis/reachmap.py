"""Reachability maps of any arm: which voxels the tool reaches, in how many orientations, certified by IK.

A map is a voxel grid over the arm's reach, in ``base``, times a set of
orientation bins (:mod:`manipkit.analysis.orientations`). A voxel-bin is
**reached** when some configuration inside the joint limits puts ``frame``
inside the voxel with an orientation in the bin. The **index** of a voxel
is the fraction of its bins reached (0..1): the **reachable workspace** is
``index > 0``, the **dexterous workspace** ``index == 1`` (Zacharias et al.
2007's capability map; for a planar arm the voxels are squares in its plane
and the bins turns about its axis, the spatial form of the planar annuli of
:mod:`manipkit.closed_form.planar_workspace`).

Methods (docs/architecture.md, "Reachability maps"):

- ``"fk"``: random configurations, uniform inside the limits (continuous
  joints in [-pi, pi]), in blocks of ``block_samples``; each block's
  configurations go through the batched FK kernel (:meth:`Robot.fk`) and
  mark the voxel-bins they land in. A mark is certain (a configuration
  lands there); an unmarked bin may still be reachable (not sampled).
- ``"hybrid"``: then IK fill passes (:mod:`manipkit.analysis.reachstages`:
  every unreached voxel-bin in the reach shell next to a reached one, at the
  voxel centre with the bin's representative orientation, mode
  ``"position+axis"`` when rolls are ignored, else ``"pose"``, seeded from that
  neighbour's certificate) until a pass adds nothing; answers within ``ik_tol``
  whose FK lands in the voxel-bin are kept (``ik_keys``, ``ik_q``). Sampling
  itself stops early once a block adds fewer than ``converge`` x the bins
  before it; every reached bin keeps a certificate (``cert_keys``, ``cert_q``).

Every voxel-bin records how it was reached: :data:`HOW_SAMPLE`,
:data:`HOW_IK` or :data:`HOW_NONE` (``ReachMap.reach``).

**Manipulability overlay** (``manipulability=True``, the default): every
configuration that reaches a voxel (each FK sample, each hybrid IK answer)
gets Yoshikawa's index ``w`` of the translation rows of its Jacobian
(:func:`manipkit.analysis.manipulability.manipulability`, batched Jacobians
:meth:`Robot.jacobians`), the linear rows taken along the grid axes: rows
``x y z`` of ``base`` for a spatial arm (``w`` in m^3 per rad^3 for revolute
joints), the rows ``u v`` of the arm's plane for a planar one (m^2). Per voxel
the map keeps the best (largest) ``w`` and the mean; NaN where nothing reached.

Each block of samples (or IK targets) has its own seed, so the map is
bit-identical whatever runs them (a cluster's task runs a few blocks in a row). Block ``b`` of the FK stage
holds samples ``b * block_samples ..`` and draws them as
``numpy.random.default_rng([seed, 0, b]).random((n, m))`` scaled into the
limits of the ``m`` chain joints (joint order, the other joints at their
defaults); IK block ``b`` (``reachjob.IK_BLOCK`` targets in key order) uses
``ik_many(..., seed=seed + 1 + b)``.
Without ``workers`` or ``scheduler`` the blocks run here, one after the
other; ``workers=N`` starts a ``distributed.LocalCluster`` of N
single-threaded worker processes, ``scheduler="tcp://host:port"`` uses a
running Dask cluster. Results are merged in block order (a block that finishes early waits
for the ones before it): OR per voxel-bin, the first sample of a voxel as its
stored configuration, the largest ``w`` as the best and the sums and counts
of ``w`` for the mean, then the IK answers in key order; so the floating-point
sums, too, are the same however the blocks ran.

Grid: voxel ``(i, j, k)`` has its centre at ``origin + axes @ ((i, j, k) *
voxel)`` in ``base`` (metres); ``axes`` is the identity for a spatial arm,
and ``(u, v, a)`` for a planar one (``a`` its joint axis; the grid has one
layer, ``k = 0``, in the plane the tool moves in). The grid covers the
reach bound of :class:`manipkit.kinematics.ik.IKSolver` around the first
chain joint.

Maps are stored in Zarr (a folder): arrays ``reach`` (chunked), ``voxel_q``,
``ik_keys``, ``ik_q``, ``manipulability`` and ``manipulability_mean`` (when
built) and the settings as attributes (:meth:`ReachMap.save`, :func:`load`),
written into a temporary sibling and renamed into place, and read back
validated as a whole (:mod:`manipkit.analysis.mapstore`).

Every option is bounded before anything is allocated or started, with the
bound in the message (:data:`MAX_SAMPLES`, :data:`MAX_BLOCK_SAMPLES`,
:data:`MAX_SEED`, :data:`MIN_VOXEL`..:data:`MAX_VOXEL`, :data:`MAX_BINS`,
:data:`MAX_IK_RESTARTS`, :func:`manipkit.analysis.blocks.max_workers`).
"""

from __future__ import annotations

import json
import math
import numbers
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis import reachstages
from manipkit.analysis.blocks import BlockRunner, check_workers
from manipkit.analysis.orientations import OrientationSet, perpendicular, planar_orientations, spatial_orientations
from manipkit.analysis.reachjob import MapJob, translation_manipulability
from manipkit.analysis.reachquery import DEFAULT_THRESHOLD
from manipkit.errors import ReachMapError
from manipkit.text import printable, repr_text, short_text

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain
    from manipkit.kinematics.collisions import CollisionSettings
    from manipkit.kinematics.robot import Robot

__all__ = [
    "DEFAULT_SAMPLES", "FORMAT", "HOW_IK", "HOW_NONE", "HOW_SAMPLE", "LAYERS", "METHODS", "ReachMap", "ReachMapError",
    "build", "load", "parse_orientations",
    "finite_array", "map_bytes", "writable_map_path",
]

HOW_NONE, HOW_SAMPLE, HOW_IK = 0, 1, 2
METHODS = ("fk", "hybrid")
LAYERS = ("index", "manipulability")  # what a picture of a map shows
FORMAT = "manipkit-reachmap-2"  # 2: certificates (cert_keys, cert_q) and the build's checks in settings
DEFAULT_SAMPLES = 1_000_000
DEFAULT_BLOCK = 1 << 16  # samples per block (a task): about 5 ms of FK for a 7-joint arm
DEFAULT_HOLDOUT = 20_000  # held-out FK samples behind the completeness estimate
DEFAULT_FP_CHECKS = 200  # reached voxel-bins checked by IK for the false-positive bound
MAX_FP_CHECKS = 1_000_000
MAX_GRID_BYTES = 2 * 1024**3  # bytes a map's arrays may take (a byte per voxel-bin, a configuration per voxel)
MAX_MAP_FILES = 1_000_000  # files a map folder may hold (its chunks)
MAX_SAMPLES = 10**10  # random configurations a build may draw (about 150,000 blocks of the default size)
MAX_BLOCK_SAMPLES = 1 << 20  # samples per block: a block's configurations and poses stay near 200 MB
MAX_SEED = 2**63 - 1  # seeds numpy's generators take (non-negative)
MAX_IK_RESTARTS = 1000
MAX_BINS = 100_000  # orientation bins (directions x rolls) a map may have
MIN_VOXEL, MAX_VOXEL = 1e-6, 1e6  # m: a voxel edge (MAX_VOXEL is the longest length a description may hold)
PLANAR_TILT_TOL = 1e-3  # rad: how far a pose queried in a planar map may tilt out of the arm's plane
PARALLEL_TOL = 1e-9  # joint axes closer than this (|a x b|) count as parallel


def finite_array(value, name: str, tail: tuple[int, ...], what: str) -> np.ndarray:
    """``value`` as a float array of shape (..., *tail), every entry finite, else :class:`ReachMapError` naming ``name``."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise ReachMapError(f"{name} {repr_text(value)}: give {what}, numbers") from None
    if array.shape[array.ndim - len(tail):] != tail or array.ndim < len(tail):
        raise ReachMapError(f"{name} has shape {array.shape}; give {what}")
    if not np.isfinite(array).all():
        raise ReachMapError(f"{name} holds NaN or infinite values; give {what}, finite numbers")
    return array


@dataclass(frozen=True, eq=False)
class ReachMap:
    """A reachability map (see the module docstring for the grid and the methods).

    Attributes
    ----------
    reach : ndarray of uint8, shape (nx, ny, nz, bins)
        How each voxel-bin was reached: HOW_NONE, HOW_SAMPLE or HOW_IK.
    origin : ndarray, shape (3,)
        Centre of voxel (0, 0, 0), metres, in ``base``.
    axes : ndarray, shape (3, 3)
        Grid axes (columns) in ``base``: identity (spatial) or ``(u, v, a)`` (planar).
    voxel : float
        Edge length (m).
    orientations : OrientationSet
    method : {"fk", "hybrid"}
    robot, frame, base : str
        Robot name and the frames the map is for (``T_base_frame``).
    joint_names : tuple of str
    voxel_q : ndarray, shape (nx, ny, nz, n)
        Per voxel, a sampled configuration that reaches it (NaN where no sample did).
    ik_keys : ndarray of int, shape (K,)
        Flat voxel-bin indices (into ``reach.reshape(-1)``) reached by IK only.
    ik_q : ndarray, shape (K, n)
        The IK answer for each of them (FK puts ``frame`` at the voxel centre
        with the bin's representative orientation).
    settings : dict
        samples, seed, block sizes, IK tolerance and budget.
    manipulability : ndarray, shape (nx, ny, nz), or None
        Per voxel the best (largest) Yoshikawa index of the translation rows
        over the configurations that reached it (NaN where none did); None
        when the map was built with ``manipulability=False``.
    manipulability_mean : ndarray, shape (nx, ny, nz), or None
        The mean over those configurations.
    """

    reach: np.ndarray
    origin: np.ndarray
    axes: np.ndarray
    voxel: float
    orientations: OrientationSet
    method: str
    robot: str
    frame: str
    base: str
    joint_names: tuple[str, ...]
    voxel_q: np.ndarray
    ik_keys: np.ndarray
    ik_q: np.ndarray
    settings: dict = field(default_factory=dict)
    manipulability: np.ndarray | None = None
    manipulability_mean: np.ndarray | None = None
    cert_keys: np.ndarray | None = None
    cert_q: np.ndarray | None = None

    @property
    def shape(self) -> tuple[int, int, int]:
        """Grid shape (nx, ny, nz)."""
        return tuple(int(s) for s in self.reach.shape[:3])

    @property
    def index(self) -> np.ndarray:
        """(nx, ny, nz) fraction of orientation bins reached per voxel, 0..1."""
        return (self.reach > HOW_NONE).mean(axis=-1)

    @property
    def how(self) -> np.ndarray:
        """(nx, ny, nz) per voxel: HOW_SAMPLE if a sample reached it, else HOW_IK if IK did, else HOW_NONE."""
        sampled = (self.reach == HOW_SAMPLE).any(axis=-1)
        by_ik = (self.reach == HOW_IK).any(axis=-1)
        return np.where(sampled, HOW_SAMPLE, np.where(by_ik, HOW_IK, HOW_NONE)).astype(np.uint8)

    @property
    def reachable(self) -> np.ndarray:
        """(nx, ny, nz) bool: the reachable workspace, ``index > 0``."""
        return (self.reach > HOW_NONE).any(axis=-1)

    @property
    def dexterous(self) -> np.ndarray:
        """(nx, ny, nz) bool: the dexterous workspace, ``index == 1`` (every bin reached)."""
        return (self.reach > HOW_NONE).all(axis=-1)

    def centers(self) -> np.ndarray:
        """(nx, ny, nz, 3) voxel centres (m) in ``base``."""
        grid = np.stack(np.meshgrid(*(np.arange(s) for s in self.shape), indexing="ij"), axis=-1) * self.voxel
        return self.origin + grid @ self.axes.T

    def voxel_of(self, xyz) -> tuple[np.ndarray, np.ndarray]:
        """(indices (..., 3) int, inside (...,) bool) of the voxels holding points ``xyz`` (..., 3) in ``base``.

        A point is inside when it falls in the grid (for a planar map: in the
        layer of the plane, within half a voxel of it). Points that are not
        numbers, hold NaN or infinity, or are not (..., 3) are a :class:`ReachMapError`.
        """
        local = (finite_array(xyz, "xyz", (3,), "points (..., 3) in metres") - self.origin) @ self.axes / self.voxel
        nearest = np.rint(local)  # decided in floats: a far point (1e300 m) never overflows the integer cast
        inside = np.all((nearest >= 0) & (nearest < np.array(self.shape)), axis=-1)
        return np.where(inside[..., None], nearest, 0).astype(np.int64), inside

    def index_at(self, xyz) -> np.ndarray | float:
        """Index (0..1) of the voxel holding each point ``xyz`` (..., 3) in ``base``; 0 outside the grid."""
        ijk, inside = self.voxel_of(xyz)
        value = np.where(inside, self.index[ijk[..., 0], ijk[..., 1], ijk[..., 2]], 0.0)
        return float(value) if value.ndim == 0 else value

    def query(self, T, *, interpolate: bool = True, threshold: float = DEFAULT_THRESHOLD, confirm: bool = False,
              detail: bool = False, robot: Robot | None = None):
        """Whether the map says each pose ``T`` (..., 4, 4), ``T_base_frame``, is reachable.

        A yes means: the pose's voxel-bin was reached (:meth:`resolution`: the
        voxel, the approach-axis bin and the roll bin, or any roll) **and** its
        support is at least ``threshold`` (default
        :data:`manipkit.analysis.reachquery.DEFAULT_THRESHOLD`, 0.65): the trilinear blend of the reached
        flags of the same orientation bin at the 8 voxel centres around the
        position (bilinear over 4 on a planar map) is at least ``threshold``
        (:func:`manipkit.analysis.reachquery.support_score`; a reached
        voxel-bin counts whenever any part of it is reached, which near the
        edge of the reach says yes to poses no configuration reaches).
        ``interpolate=False`` (or ``threshold=0``) answers for the voxel-bin
        alone, the certified answer. With ``detail`` or ``confirm`` the answer
        is a :class:`manipkit.analysis.reachquery.QueryAnswer` (both answers,
        the score, voxel, bins, the bin's certificate; with ``confirm`` IK of
        the exact pose from that certificate, confirmed by FK; ``robot`` the map's robot).
        For a planar map the pose must also keep the frame's axis along the
        arm's axis ``a`` (to :data:`PLANAR_TILT_TOL`, or half a bin if less): a tilted tool is never reached.
        A ``T`` that is not numbers, holds NaN or infinity, or is not (..., 4, 4), or a ``threshold``
        outside [0, 1], is a :class:`ReachMapError`.
        """
        from manipkit.analysis.reachquery import check_threshold, query_answer, support_score

        if confirm or detail:
            return query_answer(self, T, interpolate=interpolate, threshold=threshold, confirm=confirm, robot=robot)
        threshold = check_threshold(threshold)
        T = finite_array(T, "T", (4, 4), "poses (..., 4, 4) T_base_frame")
        ijk, inside = self.voxel_of(T[..., :3, 3])
        bins = self.orientations.bin_of(T[..., :3, :3])
        if self.orientations.kind == "planar":
            cos_tilt = (T[..., :3, :3] @ self.orientations.tool_axis) @ self.orientations.axis
            inside = inside & (cos_tilt >= math.cos(min(math.pi / self.orientations.size, PLANAR_TILT_TOL)))
        value = inside & (self.reach[ijk[..., 0], ijk[..., 1], ijk[..., 2], bins] > HOW_NONE)
        if interpolate and threshold > 0.0:
            value = value & (support_score(self, T[..., :3, 3], bins) >= threshold)
        return bool(value) if value.ndim == 0 else value

    def summary(self) -> str:
        """A few lines for humans: what the map is of, its grid and its workspaces."""
        reach = self.reach
        cell = self.voxel**2 if self.orientations.kind == "planar" else self.voxel**3
        unit = "m^2" if self.orientations.kind == "planar" else "m^3"
        reachable, dexterous = int(self.reachable.sum()), int(self.dexterous.sum())
        return "\n".join([
            f"reachability map of {printable(self.robot)}: {printable(self.frame)} in {printable(self.base)}, "
            f"method {printable(self.method)}",
            f"grid {'x'.join(str(s) for s in self.shape)} voxels of {short_text(self.voxel)} m, "
            f"voxel (0, 0, 0) at ({', '.join(short_text(v) for v in self.origin)}) m; "
            f"orientations {self.orientations.label} ({self.orientations.size} bins, {self.orientations.kind})",
            f"reachable (index > 0): {reachable} voxels, {short_text(reachable * cell, 4)} {unit}; "
            f"dexterous (index = 1): {dexterous} voxels, {short_text(dexterous * cell, 4)} {unit}",
            f"voxel-bins reached: {int((reach == HOW_SAMPLE).sum())} by samples, {int((reach == HOW_IK).sum())} by IK "
            f"({printable(str(self.settings.get('samples', 0)))} samples, seed {printable(str(self.settings.get('seed', 0)))})",
            *self.checks_text(),
            *([self.manipulability_text()] if self.manipulability is not None else []),
            *([_collisions_text(self.settings["collisions"])] if self.settings.get("collisions") else []),
        ])

    def resolution(self) -> str:
        """What a yes of :meth:`query` means, in words (the voxel, the orientation bin, roll or any roll)."""
        from manipkit.analysis.reachquery import resolution_text
        return resolution_text(self)

    def checks_text(self) -> list[str]:
        """Lines: how the sampling ended, the held-out completeness and the false-positive bound (when built)."""
        from manipkit.analysis.reachquery import checks_lines
        return checks_lines(self)

    def best_manipulability(self) -> tuple[float, np.ndarray] | None:
        """(the largest per-voxel best index, the centre (3,) m in ``base`` of its voxel), or None (none built or reached)."""
        if self.manipulability is None or not np.isfinite(self.manipulability).any():
            return None
        flat = int(np.nanargmax(self.manipulability))
        return float(self.manipulability.reshape(-1)[flat]), self.centers().reshape(-1, 3)[flat]

    def manipulability_text(self) -> str:
        """One line: the best Yoshikawa index of the map, where, and the mean over the reachable voxels."""
        best = self.best_manipulability()
        rows = "the plane's translation rows" if self.orientations.kind == "planar" else "translation rows"
        if best is None:
            return f"manipulability (Yoshikawa, {rows}): no voxel reached"
        w, where = best
        return (f"manipulability (Yoshikawa, {rows}): best {short_text(w, 4)} at "
                f"({', '.join(short_text(v, 4) for v in where)}) m; mean over the reachable voxels "
                f"{short_text(float(np.nanmean(self.manipulability_mean)), 4)}")

    def save(self, path) -> Path:
        """Write the map to the Zarr folder ``path`` (replacing a map there; never another folder); returns it.

        Written beside ``path`` and renamed into place at the end (:func:`manipkit.analysis.mapstore.save_map`).
        """
        from manipkit.analysis.mapstore import save_map

        return save_map(self, path)

    def attrs(self) -> dict:
        """The map's settings as JSON-ready values (the Zarr attributes)."""
        return {
            "format": FORMAT, "robot": self.robot, "frame": self.frame, "base": self.base, "voxel": self.voxel,
            "origin": self.origin.tolist(), "axes": self.axes.tolist(), "method": self.method,
            "orientations": self.orientations.attrs(), "joint_names": list(self.joint_names),
            "settings": json.loads(json.dumps(self.settings)),
        }


def _collisions_text(c: dict) -> str:
    floor = f", floor at z = {short_text(c['floor'])} m" if c.get("floor") is not None else ""
    srdf = f", {c['disabled_pairs']} pairs disabled by {c['srdf']}" if c.get("srdf") else ""
    return f"collision-free only: {' and '.join(c['checked'])} ({c['geometry']} geometry{floor}{srdf})"


def writable_map_path(path) -> Path:
    """``path`` if a map can be written there (:func:`manipkit.analysis.mapstore.writable_map_path`)."""
    from manipkit.analysis.mapstore import writable_map_path as check

    return check(path)


def map_bytes(n_voxels: int, n_bins: int, n_joints: int) -> int:
    """Memory (bytes) of a map's arrays: a byte per voxel-bin; per voxel a configuration and three statistics."""
    return n_voxels * n_bins + n_voxels * (8 * n_joints + 8 * 3 + 1)


def load(path) -> ReachMap:
    """The map stored in the Zarr folder ``path`` by :meth:`ReachMap.save`, validated as a whole.

    Attributes, array shapes, axes, orientation kinds and the presence and
    size of every chunk are checked before any array is decoded
    (:func:`manipkit.analysis.mapstore.load_map`).

    Raises
    ------
    InputFileError
        No such folder, not a manipkit reachability map, or a map that fails a check (named in the message).
    """
    from manipkit.analysis.mapstore import load_map

    return load_map(path)


# --------------------------------------------------------------------------
# Options


def parse_orientations(text: str) -> int | tuple[int, int]:
    """``"N"`` -> N, ``"DIRxROLL"`` -> (DIR, ROLL): the ``--orientations`` option.

    >>> parse_orientations("200"), parse_orientations("50x8")
    (200, (50, 8))
    """
    parts = str(text)[:40].lower().split("x")
    try:
        values = [int(p) for p in parts]
    except ValueError:
        values = []
    if len(values) not in (1, 2) or min(values) < 1 or math.prod(values) > MAX_BINS:
        raise ReachMapError(f"orientations '{printable(str(text)[:40])}': give N (directions, or turns of a planar arm) "
                            f"or DIRxROLL, whole numbers >= 1, at most {MAX_BINS} bins in all (200, 50x8)")
    return values[0] if len(values) == 1 else (values[0], values[1])


def _planar_axis(axes: np.ndarray, prismatic: list[bool]) -> np.ndarray | None:
    """The common axis when every revolute axis is parallel to it and every prismatic one perpendicular, else None."""
    revolute = [a for a, p in zip(axes, prismatic) if not p]
    if not revolute:
        return None
    a = revolute[0] / np.linalg.norm(revolute[0])
    if any(np.linalg.norm(np.cross(a, b)) > PARALLEL_TOL for b in revolute[1:]):
        return None
    if any(abs(a @ b) > PARALLEL_TOL for b, p in zip(axes, prismatic) if p):
        return None
    return a


def _in_plane(normal: np.ndarray) -> np.ndarray:
    """The first of x, y, z projected onto the plane perpendicular to ``normal`` (unit), normalised."""
    for e in np.eye(3):
        w = e - (e @ normal) * normal
        if np.linalg.norm(w) > 0.3:
            return w / np.linalg.norm(w)
    return perpendicular(normal)  # not reached: some axis is at least 55 degrees off any unit normal


def _whole(name: str, value, low: int, high: int, what: str) -> int:
    """``value`` as an int if it is a whole number in ``low..high``, else :class:`ReachMapError` with the bounds."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not low <= value <= high:
        raise ReachMapError(f"{name} {repr_text(value)}: give a whole number from {low} to {high} ({what})")
    return int(value)


def _real(name: str, value, low: float, high: float, what: str) -> float:
    """``value`` as a float if it is a real number in ``low..high`` (finite), else :class:`ReachMapError`."""
    if (isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value)
            or not low <= value <= high):
        raise ReachMapError(f"{name} {repr_text(value)}: give {what}, a number from {low:g} to {high:g}")
    return float(value)


def _check_options(voxel, orientations, method, samples, workers, scheduler, block_samples, seed=0, ik_tol=1e-9,
                   ik_restarts=2, ik_time_budget=0.02) -> None:
    """Every option of :func:`build` in its range, before anything is allocated or started (bounds in the message)."""
    _real("voxel", voxel, MIN_VOXEL, MAX_VOXEL, "the voxel edge in metres (0.05)")
    if method not in METHODS:
        raise ReachMapError(f"unknown method '{printable(str(method)[:40])}'; methods: {', '.join(METHODS)}")
    _whole("samples", samples, 1, MAX_SAMPLES, "random configurations")
    _whole("block_samples", block_samples, 1, MAX_BLOCK_SAMPLES, "samples per task")
    _whole("seed", seed, 0, MAX_SEED, "the seed of every block")
    _real("ik_tol", ik_tol, 1e-15, 1.0, "the IK residual tolerance (m and rad)")
    _whole("ik_restarts", ik_restarts, 0, MAX_IK_RESTARTS, "random IK restarts per target")
    _real("ik_time_budget", ik_time_budget, 1e-4, 60.0, "seconds of IK per target")
    check_workers(workers)
    if scheduler is not None and not isinstance(scheduler, str):
        raise ReachMapError(f"scheduler {repr_text(scheduler)}: give the address of a running Dask "
                            "scheduler (tcp://host:8786)")
    if workers is not None and scheduler is not None:
        raise ReachMapError("give workers (a local cluster) or scheduler (an existing one), not both")
    if orientations is not None and not isinstance(orientations, int | tuple | list | str):
        raise ReachMapError(f"orientations {repr_text(orientations)}: give N or (directions, rolls)")
    if isinstance(orientations, tuple | list):
        if len(orientations) != 2:
            raise ReachMapError(f"orientations {repr_text(orientations)}: give N or (directions, rolls)")
        for value in orientations:
            _whole("orientations", value, 1, MAX_BINS, "directions and rolls")
    elif isinstance(orientations, int):
        _whole("orientations", orientations, 1, MAX_BINS, "directions, or turns of a planar arm")


# --------------------------------------------------------------------------
# Building


def build(
    chain: Chain | Robot,
    *legacy,
    base: str | None = None,
    tip: str | None = None,
    frame: str | None = None,
    voxel: float = 0.05,
    orientations: int | tuple[int, int] | str | None = None,
    method: str = "fk",
    samples: int = DEFAULT_SAMPLES,
    workers: int | None = None,
    scheduler: str | None = None,
    seed: int = 0,
    progress=None,
    block_samples: int = DEFAULT_BLOCK,
    ik_tol: float = 1e-9,
    ik_restarts: int = 8,
    ik_time_budget: float = 0.02,
    manipulability: bool = True,
    collisions: CollisionSettings | None = None,
    converge: float = 0.0,
    holdout: int = DEFAULT_HOLDOUT,
    fp_checks: int = DEFAULT_FP_CHECKS,
    resume_dir: str | Path | None = None,
) -> ReachMap:
    """Build the reachability map of a chain's tip in its base (see the module docstring).

    Parameters
    ----------
    chain : Chain or Robot
        The chain whose tip is mapped in its base (``robot.chain(base, tip)``),
        or a robot with ``base=`` and ``tip=`` (defaults ``base_link``,
        ``ee_link``; the old positional ``frame, base`` and ``frame=`` work
        one release with a ``DeprecationWarning``).
    voxel : float, keyword-only
        Voxel edge (m).
    orientations : int, (int, int) or str, keyword-only
        Spatial arm: ``N`` approach directions (roll ignored) or
        ``(directions, rolls)`` / ``"DIRxROLL"``; planar arm: ``N`` turns
        about its axis. Default: 200 directions, or 36 turns.
    method : {"fk", "hybrid"}, keyword-only
    samples : int, keyword-only
        Random configurations for the FK stage.
    workers : int, keyword-only, optional
        Start a ``distributed.LocalCluster`` with this many single-threaded worker processes.
    scheduler : str, keyword-only, optional
        Address of a running Dask scheduler (``tcp://host:8786``).
    seed : int, keyword-only
        Seeds every block (same seed, same map, however it is run).
    progress : callable, keyword-only, optional
        ``progress(stage, done, total)`` after each block of work (the
        command line draws it with :func:`manipkit.app.progress.progress_bar`).
    block_samples : int, keyword-only
        Samples per task.
    ik_tol, ik_restarts, ik_time_budget : keyword-only
        Hybrid IK: FK residual tolerance (m and rad), random restarts after the seeded start, seconds per target.
    converge, holdout, fp_checks : keyword-only
        Stop share of new bins per block (0: every sample); held-out samples; bins checked by IK (reachstages).
    manipulability : bool, keyword-only
        Also keep, per voxel, the best and the mean Yoshikawa index of the
        configurations that reached it (``False`` skips the Jacobians).
    collisions : CollisionSettings, keyword-only, optional
        Count only samples and IK answers that pass this check (self, floor;
        :class:`manipkit.kinematics.collisions.CollisionSettings`); recorded
        in ``settings["collisions"]``.
    resume_dir : path, keyword-only, optional
        Keep each finished block in this folder (made if new; its parent
        must exist) and, when it holds blocks of a build with the same
        settings, read those back instead of computing them: an interrupted
        build resumes and gives the same map, bit for bit
        (:mod:`manipkit.analysis.blockstore`, :mod:`manipkit.analysis.reachresume`).
        Blocks of other settings there are removed (a warning says so). The
        folder is kept after the build: remove it
        (:func:`manipkit.analysis.blockstore.remove_store`) once the map is saved.
        None (the default): nothing is saved.

    Returns
    -------
    ReachMap

    Raises
    ------
    ReachMapError
        An option that is not valid, or a grid too large to hold.
    UnknownFrameError, ChainError
        Frames the robot does not have or that do not form a chain.

    Examples
    --------
    >>> import manipkit
    >>> m = build(manipkit.load("planar_2r"), voxel=0.25, orientations=1, samples=20000)
    >>> m.shape, round(float(m.index_at([1.0, 1.0, 0.0])), 3), round(float(m.index_at([2.5, 0.0, 0.0])), 3)
    ((19, 19, 1), 1.0, 0.0)
    """
    # Over 80 lines: the docstring is most of it; the rest reads best as the steps in order.
    from manipkit.kinematics.chain import chain_of
    from manipkit.kinematics.ik import ik_solver

    _check_options(voxel, orientations, method, samples, workers, scheduler, block_samples, seed, ik_tol, ik_restarts,
                   ik_time_budget)
    _real("converge", converge, 0.0, 1.0, "the share of new voxel-bins below which sampling stops (0: every sample)")
    _whole("holdout", holdout, 0, MAX_SAMPLES, "held-out FK samples for the completeness estimate")
    _whole("fp_checks", fp_checks, 0, MAX_FP_CHECKS, "reached voxel-bins checked by IK for the false-positive bound")
    voxel = float(voxel)
    chain = chain_of(chain, "reachmap.build", legacy, base=base, tip=tip, frame=frame)
    robot, frame, base = chain.robot, chain.tip, chain.base
    solver = ik_solver(robot, base, frame)
    joint_axes = chain.axes()
    axes_k, origins_k, prismatic = joint_axes.direction, joint_axes.point, joint_axes.prismatic.tolist()
    T_tip = chain.fk(chain.q())
    planar = _planar_axis(axes_k, prismatic)
    spec = orientations if orientations is not None else (36 if planar is not None else 200)
    spec = parse_orientations(spec) if isinstance(spec, str) else spec
    n_dir, n_roll = (spec, 1) if isinstance(spec, int) else (int(spec[0]), int(spec[1]))
    if n_dir * n_roll > MAX_BINS:
        raise ReachMapError(f"orientations {n_dir}x{n_roll}: {n_dir * n_roll} bins, more than {MAX_BINS}; give fewer")
    centre = origins_k[0]
    M = int(math.ceil(solver.reach / voxel)) + 1
    if planar is not None:
        if n_roll != 1:
            raise ReachMapError(f"orientations {n_dir}x{n_roll}: the arm is planar (every joint axis along "
                                f"({', '.join(short_text(v) for v in planar)})): give one number, the turns about it")
        a = planar
        u = _in_plane(a)
        tool_axis = T_tip[:3, :3].T @ a
        bins = planar_orientations(n_dir, a, u, tool_axis, _in_plane(tool_axis))
        axes = np.column_stack([u, np.cross(a, u), a])
        centre = centre + (a @ (T_tip[:3, 3] - centre)) * a  # into the plane the tool moves in
        shape = (2 * M + 1, 2 * M + 1, 1)
        origin = centre - M * voxel * (axes[:, 0] + axes[:, 1])
    else:
        bins = spatial_orientations(n_dir, n_roll)
        axes = np.eye(3)
        shape = (2 * M + 1,) * 3
        origin = centre - M * voxel
    size = map_bytes(math.prod(shape), bins.size, len(robot.joint_names))  # Python integers: no overflow
    if size > MAX_GRID_BYTES:
        raise ReachMapError(f"a {'x'.join(map(str, shape))} grid of {short_text(voxel)} m voxels times {bins.size} "
                            f"orientation bins needs {size} bytes, more than {MAX_GRID_BYTES}: use a coarser voxel "
                            "or fewer orientations")
    low, high = solver.program.sample_low, solver.program.sample_high  # the solved joints' sampling box
    job = MapJob(robot, frame, base, solver.columns, low, high, robot.q(), origin, axes, voxel, shape, bins, int(samples),
               int(block_samples), int(seed), "position+axis" if bins.kind == "spatial" and n_roll == 1 else "pose",
               float(ik_tol), int(ik_restarts), float(ik_time_budget), bool(manipulability), collisions, centre)
    store = None
    if resume_dir is not None:
        from manipkit.analysis.blockstore import open_store
        from manipkit.analysis.reachresume import build_settings, result_checks

        store = open_store(resume_dir, build_settings(job, method=method, orientations=(n_dir, n_roll), converge=float(
            converge), holdout=int(holdout), fp_checks=int(fp_checks), map_format=FORMAT), result_checks(job))
    n_voxels = math.prod(shape)
    reach = np.zeros(n_voxels * bins.size, dtype=np.uint8)
    voxel_q = np.full((n_voxels, len(robot.joint_names)), np.nan)
    seen = np.zeros(n_voxels, dtype=bool)
    best, total, count = np.full(n_voxels, np.nan), np.zeros(n_voxels), np.zeros(n_voxels, dtype=np.int64)
    ik_keys, ik_q = np.zeros(0, dtype=np.int64), np.zeros((0, len(robot.joint_names)))
    cert = {"keys": [np.zeros(0, dtype=np.int64)], "q": [np.zeros((0, len(robot.joint_names)))]}

    def merge(result) -> int:  # one FK block, in block order: returns the voxel-bins it newly reached
        _, keys, voxels, Q, stats, key_q = result
        new_keys = reach[keys] == HOW_NONE
        cert["keys"].append(keys[new_keys])
        cert["q"].append(key_q[new_keys])
        reach[keys] = HOW_SAMPLE
        new = ~seen[voxels]
        voxel_q[voxels[new]], seen[voxels] = Q[new], True
        if stats is not None:
            best[voxels] = np.fmax(best[voxels], stats[0])
            total[voxels] += stats[1]
            count[voxels] += stats[2]
        return int(new_keys.sum())

    with BlockRunner(workers, scheduler, progress, store) as runner:
        used = reachstages.sample_until_converged(job, runner, merge, float(converge))
        cert_keys, cert_q = np.concatenate(cert["keys"]), np.concatenate(cert["q"])
        order = np.argsort(cert_keys)
        cert_keys, cert_q = cert_keys[order], cert_q[order]
        passes = 0
        if method == "hybrid":
            ik_keys, ik_q, cert_keys, cert_q, passes = reachstages.fill_passes(job, runner, reach, cert_keys, cert_q,
                                                                    solver.reach + voxel, HOW_IK)
    if manipulability and ik_keys.size:  # the IK answers too, in key order
        w = translation_manipulability(robot, ik_q, frame, base, axes, planar=planar is not None)
        voxels = ik_keys // bins.size
        np.fmax.at(best, voxels, w)
        np.add.at(total, voxels, w)
        np.add.at(count, voxels, 1)
    settings = {"samples": int(samples), "seed": int(seed), "block_samples": int(block_samples), "ik_tol": float(ik_tol),
                "ik_restarts": int(ik_restarts), "ik_time_budget": float(ik_time_budget), "ik_mode": job.ik_mode,
                "planar": planar is not None, "manipulability": bool(manipulability),
                "collisions": None if collisions is None else collisions.as_dict(), "converge": float(converge),
                **used, "fill_passes": passes}
    mean = np.divide(total, count, out=np.full(n_voxels, np.nan), where=count > 0)
    unchecked = ReachMap(reach.reshape(*shape, bins.size), origin, axes, voxel, bins, method, robot.name, frame, base,
                         tuple(robot.joint_names), voxel_q.reshape(*shape, -1), ik_keys, ik_q, settings,
                         best.reshape(shape) if manipulability else None,
                         mean.reshape(shape) if manipulability else None, cert_keys, cert_q)
    # the map's own checks measure its yes (query: voxel-bin reached and support >= DEFAULT_THRESHOLD)
    checks = {"completeness": reachstages.holdout_completeness(job, reach, int(holdout), unchecked.query),
              "false_positive": reachstages.false_positive_bound(job, cert_keys, cert_q, int(fp_checks),
                                                                 unchecked.query),
              "checked_threshold": DEFAULT_THRESHOLD}
    return replace(unchecked, settings={**settings, **checks})
