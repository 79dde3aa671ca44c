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
- ``"hybrid"``: then batched IK (:func:`manipkit.kinematics.ik_many.ik_many`)
  on every unmarked voxel-bin next to a marked one (a face neighbour with
  the same bin marked), aiming at the voxel's centre with the bin's
  representative orientation (mode ``"position+axis"`` about z when rolls are
  ignored, else ``"pose"``), seeded from that neighbour's stored sample
  configuration. An answer counts only when its FK residuals are within
  ``ik_tol``; its configuration is kept (``ik_keys``, ``ik_q``).

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

Blocks are tasks: each block of samples (or IK targets) has its own seed,
so the map is bit-identical whatever runs them. Block ``b`` of the FK stage
holds samples ``b * block_samples ..`` and draws them as
``numpy.random.default_rng([seed, 0, b]).random((n, m))`` scaled into the
limits of the ``m`` chain joints (joint order, the other joints at their
defaults); IK block ``b`` (``IK_BLOCK`` targets in key order) uses
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
built) and the settings as attributes (:meth:`ReachMap.save`, :func:`load`).
"""

from __future__ import annotations

import json
import math
import numbers
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.blocks import BlockRunner, in_block_order
from manipkit.analysis.orientations import OrientationSet, perpendicular, planar_orientations, spatial_orientations
from manipkit.errors import InputFileError, OutputError, ReachMapError
from manipkit.inputs import MAX_TABLE_BYTES, read_text
from manipkit.text import short_text

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain
    from manipkit.kinematics.collisions import CollisionSettings
    from manipkit.kinematics.robot import Robot

__all__ = [
    "DEFAULT_SAMPLES", "FORMAT", "HOW_IK", "HOW_NONE", "HOW_SAMPLE", "LAYERS", "METHODS", "ReachMap", "ReachMapError",
    "build", "load", "parse_orientations", "plot_reachmap", "translation_manipulability",
    "writable_map_path",
]

HOW_NONE, HOW_SAMPLE, HOW_IK = 0, 1, 2
METHODS = ("fk", "hybrid")
LAYERS = ("index", "manipulability")  # what a picture of a map shows
FORMAT = "manipkit-reachmap-1"
DEFAULT_SAMPLES = 1_000_000
DEFAULT_BLOCK = 1 << 16  # samples per block (a task): about 5 ms of FK for a 7-joint arm
IK_BLOCK = 2048  # IK targets per block
MAX_GRID_BYTES = 2 * 1024**3  # bytes a map's arrays may take (a byte per voxel-bin, a configuration per voxel)
MAX_MAP_FILES = 1_000_000  # files a map folder may hold (its chunks)
PLANAR_TILT_TOL = 1e-3  # rad: how far a pose queried in a planar map may tilt out of the arm's plane
PARALLEL_TOL = 1e-9  # joint axes closer than this (|a x b|) count as parallel


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
        layer of the plane, within half a voxel of it).
        """
        local = (np.asarray(xyz, dtype=float) - self.origin) @ self.axes / self.voxel
        ijk = np.rint(local).astype(np.int64)
        inside = np.all((ijk >= 0) & (ijk < np.array(self.shape)), axis=-1)
        return np.where(inside[..., None], ijk, 0), inside

    def index_at(self, xyz) -> np.ndarray | float:
        """Index (0..1) of the voxel holding each point ``xyz`` (..., 3) in ``base``; 0 outside the grid."""
        ijk, inside = self.voxel_of(xyz)
        value = np.where(inside, self.index[ijk[..., 0], ijk[..., 1], ijk[..., 2]], 0.0)
        return float(value) if value.ndim == 0 else value

    def query(self, T) -> np.ndarray | bool:
        """Whether each pose ``T`` (..., 4, 4), ``T_base_frame``, falls in a reached voxel-bin.

        For a planar map the pose must also keep the frame's axis along the
        arm's axis ``a`` (to :data:`PLANAR_TILT_TOL`, or half a bin if less): a tilted tool is never reached.
        """
        T = np.asarray(T, dtype=float)
        ijk, inside = self.voxel_of(T[..., :3, 3])
        bins = self.orientations.bin_of(T[..., :3, :3])
        if self.orientations.kind == "planar":
            cos_tilt = (T[..., :3, :3] @ self.orientations.tool_axis) @ self.orientations.axis
            inside = inside & (cos_tilt >= math.cos(min(math.pi / self.orientations.size, PLANAR_TILT_TOL)))
        value = inside & (self.reach[ijk[..., 0], ijk[..., 1], ijk[..., 2], bins] > HOW_NONE)
        return bool(value) if value.ndim == 0 else value

    def summary(self) -> str:
        """A few lines for humans: what the map is of, its grid and its workspaces."""
        reach = self.reach
        cell = self.voxel**2 if self.orientations.kind == "planar" else self.voxel**3
        unit = "m^2" if self.orientations.kind == "planar" else "m^3"
        reachable, dexterous = int(self.reachable.sum()), int(self.dexterous.sum())
        return "\n".join([
            f"reachability map of {self.robot}: {self.frame} in {self.base}, method {self.method}",
            f"grid {'x'.join(str(s) for s in self.shape)} voxels of {short_text(self.voxel)} m, "
            f"voxel (0, 0, 0) at ({', '.join(short_text(v) for v in self.origin)}) m; "
            f"orientations {self.orientations.label} ({self.orientations.size} bins, {self.orientations.kind})",
            f"reachable (index > 0): {reachable} voxels, {short_text(reachable * cell, 4)} {unit}; "
            f"dexterous (index = 1): {dexterous} voxels, {short_text(dexterous * cell, 4)} {unit}",
            f"voxel-bins reached: {int((reach == HOW_SAMPLE).sum())} by samples, {int((reach == HOW_IK).sum())} by IK "
            f"({self.settings.get('samples', 0)} samples, seed {self.settings.get('seed', 0)})",
            *([self.manipulability_text()] if self.manipulability is not None else []),
            *([_collisions_text(self.settings["collisions"])] if self.settings.get("collisions") else []),
        ])

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
        """Write the map to the Zarr folder ``path`` (replacing a map there; never another folder); returns it."""
        import zarr

        path = writable_map_path(path)
        try:
            root = zarr.open_group(str(path), mode="w")
            chunk = tuple(min(s, 16) for s in self.shape) + (self.reach.shape[3],)
            root.create_array("reach", data=self.reach, chunks=chunk)
            root.create_array("voxel_q", data=self.voxel_q, chunks=chunk[:3] + (self.voxel_q.shape[3],))
            root.create_array("ik_keys", data=self.ik_keys.astype(np.int64), chunks=(max(1, min(len(self.ik_keys), 65536)),))
            root.create_array("ik_q", data=self.ik_q, chunks=(max(1, min(len(self.ik_keys), 65536)), self.ik_q.shape[1]))
            if self.manipulability is not None:
                root.create_array("manipulability", data=self.manipulability, chunks=chunk[:3])
                root.create_array("manipulability_mean", data=self.manipulability_mean, chunks=chunk[:3])
            root.attrs.update(self.attrs())
        except OSError as exc:
            raise OutputError(f"cannot write {path}: {exc.strerror or exc}") from None
        return path

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
    """``path`` if a map can be written there: its folder exists, and it is new or holds a map (replaced).

    Raises
    ------
    OutputError
        ``cannot write PATH: no such folder ...`` or ``...: it exists and is not a reachability map``.
    """
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise OutputError(f"cannot write {path}: no such folder {parent}")
    if path.exists() and not _is_map(path):
        raise OutputError(f"cannot write {path}: it exists and is not a reachability map; give a new name")
    return path


def _is_map(path: Path) -> bool:
    try:
        meta = json.loads(read_text(path / "zarr.json", what="reachability map metadata", max_bytes=MAX_TABLE_BYTES))
        return meta["attributes"]["format"] == FORMAT
    except (InputFileError, ValueError, KeyError, TypeError):  # missing, a FIFO, too large, not JSON, not a map's
        return False


def _check_map_folder(path: Path) -> None:
    """Every entry of a map folder is a folder or a regular file (a FIFO or device would make zarr wait)."""
    count = 0
    for folder, _, files in os.walk(path):
        for name in files:
            count += 1
            if count > MAX_MAP_FILES:
                raise InputFileError(f"{path}: more than {MAX_MAP_FILES} files: not a map manipkit wrote")
            full = Path(folder) / name
            if not full.is_file():
                raise InputFileError(f"{full}: not a regular file; a reachability map holds folders and files only")
            if name == "zarr.json" and full.stat().st_size > MAX_TABLE_BYTES:
                raise InputFileError(f"{full}: {full.stat().st_size} bytes of metadata, above {MAX_TABLE_BYTES}")


def _map_bytes(n_voxels: int, n_bins: int, n_joints: int) -> int:
    """Memory (bytes) of a map's arrays: a byte per voxel-bin; per voxel a configuration and three statistics."""
    return n_voxels * n_bins + n_voxels * (8 * n_joints + 8 * 3 + 1)


def load(path) -> ReachMap:
    """The map stored in the Zarr folder ``path`` by :meth:`ReachMap.save`.

    Raises
    ------
    InputFileError
        No such folder, or not a manipkit reachability map.
    """
    import zarr

    path = Path(path)
    if not path.is_dir():
        raise InputFileError(f"{path}: no such reachability map (a folder written by 'manipkit reachmap -o')")
    if not _is_map(path):
        raise InputFileError(f"{path}: not a manipkit reachability map (no '{FORMAT}' zarr.json in it)")
    _check_map_folder(path)
    try:
        root = zarr.open_group(str(path), mode="r")
        a = dict(root.attrs)
        shape, n_joints = tuple(root["reach"].shape), len(a["joint_names"])
        o = a["orientations"]
        n_bins = int(o["n_rolls"]) * (1 if o["kind"] == "planar" else int(o["n_directions"]))
        if len(shape) != 4 or shape[3] != n_bins or tuple(root["voxel_q"].shape) != shape[:3] + (n_joints,):
            raise ValueError("array shapes that disagree with the attributes")
        if _map_bytes(math.prod(shape[:3]), n_bins, n_joints) + 8 * math.prod(root["ik_q"].shape) > MAX_GRID_BYTES:
            raise ValueError(f"arrays larger than {MAX_GRID_BYTES} bytes")
        return ReachMap(
            np.asarray(root["reach"][...], dtype=np.uint8), np.array(a["origin"], dtype=float),
            np.array(a["axes"], dtype=float), float(a["voxel"]), OrientationSet.from_attrs(a["orientations"]),
            a["method"], a["robot"], a["frame"], a["base"], tuple(a["joint_names"]), np.asarray(root["voxel_q"][...]),
            np.asarray(root["ik_keys"][...], dtype=np.int64), np.asarray(root["ik_q"][...]), dict(a["settings"]),
            *(np.asarray(root[k][...]) if "manipulability" in root else None for k in ("manipulability", "manipulability_mean")),
        )
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise InputFileError(f"{path}: not a valid reachability map ({' '.join(str(exc).split())[:120]})") from None


# --------------------------------------------------------------------------
# Options


def parse_orientations(text: str) -> int | tuple[int, int]:
    """``"N"`` -> N, ``"DIRxROLL"`` -> (DIR, ROLL): the ``--orientations`` option.

    >>> parse_orientations("200"), parse_orientations("50x8")
    (200, (50, 8))
    """
    parts = str(text).lower().split("x")
    try:
        values = [int(p) for p in parts]
    except ValueError:
        values = []
    if len(values) not in (1, 2) or min(values) < 1:
        raise ReachMapError(f"orientations '{text}': give N (directions, or turns of a planar arm) or DIRxROLL, "
                            "whole numbers >= 1 (200, 50x8)")
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


def _check_options(voxel, orientations, method, samples, workers, scheduler, block_samples) -> None:
    if isinstance(voxel, bool) or not isinstance(voxel, numbers.Real) or not (math.isfinite(voxel) and voxel > 0.0):
        raise ReachMapError(f"voxel {voxel!r}: give the voxel edge in metres, a positive number (0.05)")
    if method not in METHODS:
        raise ReachMapError(f"unknown method '{method}'; methods: {', '.join(METHODS)}")
    for name, value in (("samples", samples), ("block_samples", block_samples)):
        if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
            raise ReachMapError(f"{name} {value!r}: give a whole number >= 1")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, numbers.Integral) or workers < 1):
        raise ReachMapError(f"workers {workers!r}: give a whole number >= 1 (worker processes), or none to run here")
    if workers is not None and scheduler is not None:
        raise ReachMapError("give workers (a local cluster) or scheduler (an existing one), not both")
    if orientations is not None and not isinstance(orientations, int | tuple | list | str):
        raise ReachMapError(f"orientations {orientations!r}: give N or (directions, rolls)")


# --------------------------------------------------------------------------
# The job: everything a worker needs, pickled once per run


@dataclass(frozen=True, eq=False)
class _Job:
    robot: Robot
    frame: str
    base: str
    chain: np.ndarray  # columns of the chain joints in the joint vector
    low: np.ndarray
    high: np.ndarray
    q_default: np.ndarray
    origin: np.ndarray
    axes: np.ndarray
    voxel: float
    shape: tuple[int, int, int]
    orientations: OrientationSet
    samples: int
    block_samples: int
    seed: int
    ik_mode: str
    ik_tol: float
    ik_restarts: int
    ik_time_budget: float
    manipulability: bool
    collisions: CollisionSettings | None = None  # count only configurations that pass this check

    def cells(self, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(flat voxel index, inside) of points ``xyz`` (N, 3) in ``base``."""
        ijk = np.rint((xyz - self.origin) @ self.axes / self.voxel).astype(np.int64)
        inside = np.all((ijk >= 0) & (ijk < np.array(self.shape)), axis=1)
        flat = np.ravel_multi_index(tuple(np.where(inside[:, None], ijk, 0).T), self.shape)
        return flat, inside


def translation_manipulability(robot: Robot, Q: np.ndarray, frame: str, base: str, axes: np.ndarray, *,
                               planar: bool) -> np.ndarray:
    """Yoshikawa's index (N,) of the translation rows of the Jacobians at ``Q`` (N, n), rows along the grid ``axes``.

    The linear rows of :meth:`Robot.jacobians` (``frame`` in ``base``) are
    expressed along the columns of ``axes`` (3, 3); a spatial map (identity
    axes) takes all three, a planar one the first two (``u v``, its plane).
    """
    from manipkit.analysis.manipulability import manipulability

    J = robot.chain(base, frame).jacobians(Q)  # the chain's columns only (whole-robot rows of Q are read by the chain)
    J[:, :3] = np.einsum("ji,njk->nik", axes, J[:, :3])  # axes.T @ J_v for each configuration
    return manipulability(J, "yoshikawa", axes=[0, 1] if planar else "trans")


def sample_block(job: _Job, block: int) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, tuple | None]:
    """Block ``block`` of FK samples: (block, reached voxel-bin keys, voxels, first configuration in each voxel, stats).

    ``stats``: per voxel (best, sum, count) of the manipulability index of the
    block's samples in it, or None when the map is built without it.
    """
    rng = np.random.default_rng([job.seed, 0, block])
    n = min(job.block_samples, job.samples - block * job.block_samples)
    Q = np.tile(job.q_default, (n, 1))
    Q[:, job.chain] = job.low + rng.random((n, job.chain.size)) * (job.high - job.low)
    T = job.robot.fk(Q, base=job.base, tip=job.frame)
    if job.collisions is not None:  # samples in collision reach nothing
        if job.manipulability:  # every sample counts in the statistics
            free = job.collisions.free(job.robot, Q)
        else:  # the map keeps one free sample per voxel-bin, the first: check samples until it is found
            cells, inside = job.cells(T[:, :3, 3])
            groups = np.where(inside, cells * job.orientations.size + job.orientations.bin_of(T[:, :3, :3]), -1)
            free = job.collisions.first_free(job.robot, Q, groups)
        Q, T = Q[free], T[free]
    cells, inside = job.cells(T[:, :3, 3])
    cells, Q = cells[inside], Q[inside]
    keys = np.unique(cells * job.orientations.size + job.orientations.bin_of(T[inside, :3, :3]))
    order = np.argsort(cells, kind="stable")  # a voxel's samples together, each run in sample order
    starts = np.flatnonzero(np.diff(cells[order], prepend=-1)) if cells.size else np.zeros(0, dtype=np.intp)
    voxels, first = cells[order][starts], order[starts]
    stats = None
    if job.manipulability and cells.size:
        w = translation_manipulability(job.robot, Q, job.frame, job.base, job.axes,
                                       planar=job.orientations.kind == "planar")[order]
        stats = (np.maximum.reduceat(w, starts), np.add.reduceat(w, starts), np.diff(starts, append=w.size))
    return block, keys, voxels, Q[first], stats


def ik_block(job: _Job, block: int, T: np.ndarray, Q_seed: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """Block ``block`` of IK targets: (block, success mask, configurations), by :func:`ik_many` seeded per block."""
    from manipkit.kinematics.ik_many import ik_many

    batch = ik_many(job.robot, T, job.base, job.frame, q0=Q_seed, mode=job.ik_mode, tol=job.ik_tol,
                    restarts=job.ik_restarts, time_budget=job.ik_time_budget, seed=job.seed + 1 + block)
    success = np.array(batch.success, dtype=bool)
    if job.collisions is not None and success.any():  # an answer in collision reaches nothing
        success[success] = job.collisions.free(job.robot, batch.q[success])
    return block, success, batch.q


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
    ik_restarts: int = 2,
    ik_time_budget: float = 0.02,
    manipulability: bool = True,
    collisions: CollisionSettings | None = None,
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
        Hybrid IK: FK residual tolerance (m and rad), random restarts after
        the seeded start, seconds per target.
    manipulability : bool, keyword-only
        Also keep, per voxel, the best and the mean Yoshikawa index of the
        configurations that reached it (``False`` skips the Jacobians).
    collisions : CollisionSettings, keyword-only, optional
        Count only samples and IK answers that pass this check (self, floor;
        :class:`manipkit.kinematics.collisions.CollisionSettings`); recorded
        in ``settings["collisions"]``.

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

    _check_options(voxel, orientations, method, samples, workers, scheduler, block_samples)
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
    if min(n_dir, n_roll) < 1:
        raise ReachMapError(f"orientations {spec!r}: give whole numbers >= 1")
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
    size = _map_bytes(math.prod(shape), bins.size, len(robot.joint_names))  # Python integers: no overflow
    if size > MAX_GRID_BYTES:
        raise ReachMapError(f"a {'x'.join(map(str, shape))} grid of {short_text(voxel)} m voxels times {bins.size} "
                            f"orientation bins needs {size} bytes, more than {MAX_GRID_BYTES}: use a coarser voxel "
                            "or fewer orientations")
    low, high = solver.program.sample_low, solver.program.sample_high  # the solved joints' sampling box
    job = _Job(robot, frame, base, solver.columns, low, high, robot.q(), origin, axes, voxel, shape, bins, int(samples),
               int(block_samples), int(seed), "position+axis" if bins.kind == "spatial" and n_roll == 1 else "pose",
               float(ik_tol), int(ik_restarts), float(ik_time_budget), bool(manipulability), collisions)
    n_voxels = math.prod(shape)
    reach = np.zeros(n_voxels * bins.size, dtype=np.uint8)
    voxel_q = np.full((n_voxels, len(robot.joint_names)), np.nan)
    seen = np.zeros(n_voxels, dtype=bool)
    best, total, count = np.full(n_voxels, np.nan), np.zeros(n_voxels), np.zeros(n_voxels, dtype=np.int64)
    ik_keys, ik_q = np.zeros(0, dtype=np.int64), np.zeros((0, len(robot.joint_names)))
    with BlockRunner(workers, scheduler, progress) as runner:
        n_blocks = -(-int(samples) // int(block_samples))
        blocks = runner.run(sample_block, job, [(b,) for b in range(n_blocks)], "FK samples")
        for _, keys, voxels, Q, stats in in_block_order(blocks):
            reach[keys] = HOW_SAMPLE
            new = ~seen[voxels]
            voxel_q[voxels[new]], seen[voxels] = Q[new], True
            if stats is not None:
                best[voxels] = np.fmax(best[voxels], stats[0])
                total[voxels] += stats[1]
                count[voxels] += stats[2]
        if method == "hybrid":
            ik_keys, ik_q = _hybrid(job, runner, reach, voxel_q)
    if manipulability and ik_keys.size:  # the IK answers too, in key order
        w = translation_manipulability(robot, ik_q, frame, base, axes, planar=planar is not None)
        voxels = ik_keys // bins.size
        np.fmax.at(best, voxels, w)
        np.add.at(total, voxels, w)
        np.add.at(count, voxels, 1)
    settings = {"samples": int(samples), "seed": int(seed), "block_samples": int(block_samples), "ik_tol": float(ik_tol),
                "ik_restarts": int(ik_restarts), "ik_time_budget": float(ik_time_budget), "ik_mode": job.ik_mode,
                "planar": planar is not None, "manipulability": bool(manipulability),
                "collisions": None if collisions is None else collisions.as_dict()}
    mean = np.divide(total, count, out=np.full(n_voxels, np.nan), where=count > 0)
    return ReachMap(reach.reshape(*shape, bins.size), origin, axes, voxel, bins, method, robot.name, frame, base,
                    tuple(robot.joint_names), voxel_q.reshape(*shape, -1), ik_keys, ik_q, settings,
                    best.reshape(shape) if manipulability else None, mean.reshape(shape) if manipulability else None)


def _hybrid(job: _Job, runner: BlockRunner, reach: np.ndarray, voxel_q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """IK on every unmarked voxel-bin with a face neighbour marked in the same bin; marks HOW_IK in ``reach``.

    Returns (keys, configurations) of the voxel-bins IK reached, sorted by key.
    """
    B = job.orientations.size
    marked = reach.reshape(*job.shape, B) > HOW_NONE
    voxel_ids = np.arange(int(np.prod(job.shape)), dtype=np.int32).reshape(job.shape)
    seed_voxel = np.full(marked.shape, -1, dtype=np.int32)  # voxel ids: a grid holds far fewer than 2**31
    for axis in range(3):
        if job.shape[axis] < 2:
            continue
        for shift in (1, -1):  # the neighbour at -1 along the axis first, then +1
            neighbour = np.roll(marked, shift, axis=axis)
            neighbour_id = np.roll(voxel_ids, shift, axis=axis)
            edge = [slice(None)] * 3
            edge[axis] = 0 if shift == 1 else -1
            neighbour[tuple(edge)] = False  # np.roll wraps around: no neighbour across the grid's edge
            new = neighbour & ~marked & (seed_voxel < 0)
            seed_voxel[new] = np.broadcast_to(neighbour_id[..., None], marked.shape)[new]
    keys = np.flatnonzero(seed_voxel.reshape(-1) >= 0)
    if keys.size == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, voxel_q.shape[1]))
    voxels, bins = np.divmod(keys, B)
    ijk = np.stack(np.unravel_index(voxels, job.shape), axis=-1)
    T = np.tile(np.eye(4), (keys.size, 1, 1))
    T[:, :3, :3] = job.orientations.rotations()[bins]
    T[:, :3, 3] = job.origin + (ijk * job.voxel) @ job.axes.T
    Q_seed = voxel_q[seed_voxel.reshape(-1)[keys]]
    blocks = [(b, T[s:s + IK_BLOCK], Q_seed[s:s + IK_BLOCK]) for b, s in enumerate(range(0, keys.size, IK_BLOCK))]
    found_keys, found_q = [], []
    for block, success, Q in runner.run(ik_block, job, blocks, "IK at the boundary"):
        start = block * IK_BLOCK
        found_keys.append(keys[start:start + len(success)][success])
        found_q.append(Q[success])
    order_keys = np.concatenate(found_keys)
    order = np.argsort(order_keys)
    reach[order_keys] = HOW_IK
    return order_keys[order], np.concatenate(found_q)[order]


# --------------------------------------------------------------------------
# Pictures


def plot_reachmap(reach_map: ReachMap, path, *, layer: str = "index") -> None:
    """A layer of the map to ``path`` (matplotlib): the plane of a planar map; two slices through the grid centre otherwise.

    ``layer``: ``"index"`` (0..1) or ``"manipulability"`` (the best
    Yoshikawa index per voxel, blank where nothing reached). Spatial slices:
    horizontal (x-y of ``base``) and vertical (x-z), each through the voxel
    layer that holds the grid's centre.

    Raises
    ------
    ReachMapError
        An unknown layer, or ``"manipulability"`` of a map built without it.
    """
    if layer not in LAYERS:
        raise ReachMapError(f"unknown layer '{layer}'; layers: {', '.join(LAYERS)}")
    if layer == "manipulability" and reach_map.manipulability is None:
        raise ReachMapError("this map was built without manipulability (manipulability=False, --no-manipulability)")
    from matplotlib.figure import Figure  # not pyplot: the caller's backend (a notebook's) stays as it is

    from manipkit.outputs import writing

    v = reach_map.voxel
    index = reach_map.index if layer == "index" else np.ma.masked_invalid(reach_map.manipulability)
    top = 1.0 if layer == "index" else max(float(index.max()) if index.count() else 1.0, 1e-12)
    nx, ny, nz = reach_map.shape
    o = reach_map.origin
    if reach_map.orientations.kind == "planar":
        slices = [(index[:, :, 0], "u (m)", "v (m)", (0.0, 0.0), "the arm's plane")]
    else:
        slices = [
            (index[:, :, nz // 2], "x (m)", "y (m)", (o[0], o[1]), f"z = {short_text(o[2] + nz // 2 * v, 4)} m"),
            (index[:, ny // 2, :], "x (m)", "z (m)", (o[0], o[2]), f"y = {short_text(o[1] + ny // 2 * v, 4)} m"),
        ]
    fig = Figure(figsize=(5.2 * len(slices) + 1.0, 4.8))
    axes = fig.subplots(1, len(slices), squeeze=False)
    for ax, (image, xlabel, ylabel, (a0, b0), where) in zip(axes[0], slices):
        if reach_map.orientations.kind == "planar":  # plane coordinates measured from the grid centre
            a0, b0 = -(nx // 2) * v, -(ny // 2) * v
        extent = (a0 - v / 2, a0 + (image.shape[0] - 0.5) * v, b0 - v / 2, b0 + (image.shape[1] - 0.5) * v)
        shown = ax.imshow(image.T, origin="lower", extent=extent, cmap="viridis", vmin=0.0, vmax=top,
                          interpolation="nearest", aspect="equal")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.set_title(where)
    fig.colorbar(shown, ax=list(axes[0]), label="reachability index (1: dexterous)" if layer == "index" else
                 "best Yoshikawa index, translation rows")
    fig.suptitle(f"{reach_map.robot}: {reach_map.frame} in {reach_map.base}, {short_text(v)} m voxels, "
                 f"{reach_map.orientations.size} orientation bins")
    with writing(path) as target:
        fig.savefig(target, dpi=110, bbox_inches="tight")
