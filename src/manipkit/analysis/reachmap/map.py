"""The reachability map: :class:`ReachMap` (the grid, the orientation bins, how each voxel-bin was reached) and :func:`load`.

(docs/site/internals/reach-maps.md; built by
:func:`manipkit.analysis.reachmap.builder.build`.) Voxel ``(i, j, k)`` has
its centre at ``origin + axes @ ((i, j, k) * voxel)`` in ``base`` (metres);
``axes`` is the identity for a spatial arm and ``(u, v, a)`` for a planar one
(``a`` its joint axis; one layer, ``k = 0``). A voxel-bin is reached
(:data:`~manipkit.analysis.reachmap.constants.HOW_SAMPLE` or ``HOW_IK``)
when a configuration inside the joint limits puts the frame inside the voxel
with an orientation in the bin; the index of a voxel is the fraction of its
bins reached. What a yes of :meth:`ReachMap.query` means is
:mod:`manipkit.analysis.reachmap.query`'s; the Zarr folder a map is saved in
is :mod:`manipkit.analysis.reachmap.store`'s.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.reachmap.constants import (
    DEFAULT_THRESHOLD,
    FORMAT,
    HOW_IK,
    HOW_NONE,
    HOW_SAMPLE,
    check_threshold,
    finite_array,
)
from manipkit.analysis.reachmap.query import (
    checks_lines,
    in_plane,
    query_answer,
    refine_robot,
    refined_answer,
    resolution_text,
    support_score,
)
from manipkit.analysis.reachmap.store import read_map, save_map
from manipkit.description.mjcf import rules_source_text
from manipkit.text import printable, short_text

if TYPE_CHECKING:
    from manipkit.analysis.reachmap.orientations import OrientationSet
    from manipkit.analysis.reachmap.payload import PayloadLayer
    from manipkit.kinematics.robot import Robot

__all__ = ["ReachMap", "load"]


@dataclass(frozen=True, eq=False)
class ReachMap:
    """A reachability map (the module docstring says what its grid and bins are; :mod:`manipkit.analysis.reachmap.builder` how it is built).

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
    payload : PayloadLayer or None
        Per voxel the best and worst payload capacity (kg) for one CoG and
        gravity (:mod:`manipkit.analysis.reachmap.payload`; added by
        :func:`manipkit.analysis.reachmap.payloadmap.payload_map`), or None.
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
    payload: PayloadLayer | None = None

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

    def query(self, T, *, interpolate: bool = True, threshold: float | None = None, confirm: bool = False,
              detail: bool = False, robot: Robot | None = None, refine: bool | None = None):
        """Whether the map says each pose ``T`` (..., 4, 4), ``T_base_frame``, is reachable.

        **By default the answer is refined**: deep inside the reached set
        (support 1, below) yes, far from it (support 0) no, and a pose in the
        boundary band (support strictly between 0 and 1) answered by IK of the
        exact pose (the dispatcher's batch: the closed form where the chain
        has one for the map's IK mode, else numerical IK from the certificates
        of the reached voxel-bins around it), yes only where FK of an in-limit
        answer reaches it to 1e-9
        (:func:`manipkit.analysis.reachmap.query.refined_answer`). The IK is
        of ``robot``, else of the map's robot loaded by the name it stores (a
        bundled or example-robot-data name; a file path a map names is never
        read: :func:`manipkit.analysis.reachmap.query.robot_by_name`).
        On the iiwa14's 5 cm map this says yes to 0.39 % of unreachable
        poses (recall 99.96 %) where the unrefined estimate says 1.76 % (96.0 %).

        **The map's unrefined estimate** (``refine=False``; also where the
        robot does not load, with an
        :class:`~manipkit.analysis.reachmap.query.UnrefinedWarning` giving the
        map's measured error; also when ``interpolate=False`` or a
        ``threshold`` asks for the map's own rule, unless ``refine=True``): a
        yes means the pose's voxel-bin was reached (:meth:`resolution`: the
        voxel, the approach-axis bin and the roll bin, or any roll) **and** its
        support is at least ``threshold`` (default
        :data:`manipkit.analysis.reachmap.query.DEFAULT_THRESHOLD`, 0.65): the trilinear blend of the reached
        flags of the same orientation bin at the 8 voxel centres around the
        position (bilinear over 4 on a planar map) is at least ``threshold``
        (:func:`manipkit.analysis.reachmap.query.support_score`; a reached
        voxel-bin counts whenever any part of it is reached, which near the
        edge of the reach says yes to poses no configuration reaches).
        ``interpolate=False`` (or ``threshold=0``) answers for the voxel-bin
        alone, the certified answer. ``refine=True`` without ``robot`` loads
        the map's robot by name or path, and raises if it does not load.
        With ``detail`` or ``confirm`` the answer
        is a :class:`manipkit.analysis.reachmap.query.QueryAnswer` (both answers,
        the score, voxel, bins, the bin's certificate, which poses IK decided;
        with ``confirm`` IK of the exact pose from that certificate, confirmed by FK).
        For a planar map the pose must also keep the frame's axis along the
        arm's axis ``a`` (to :data:`PLANAR_TILT_TOL`, or half a bin if less): a tilted tool is never reached.
        A ``T`` that is not numbers, holds NaN or infinity, or is not (..., 4, 4), or a ``threshold``
        outside [0, 1], is a :class:`ReachMapError`.
        """
        if confirm or detail:
            return query_answer(self, T, interpolate=interpolate, threshold=threshold, confirm=confirm, robot=robot,
                                refine=refine)
        asked_rule = not interpolate or threshold is not None
        threshold = DEFAULT_THRESHOLD if threshold is None else check_threshold(threshold)
        T = finite_array(T, "T", (4, 4), "poses (..., 4, 4) T_base_frame")
        ijk, inside = self.voxel_of(T[..., :3, 3])
        bins = self.orientations.bin_of(T[..., :3, :3])
        if self.orientations.kind == "planar":
            inside = inside & in_plane(self, T)
        value = inside & (self.reach[ijk[..., 0], ijk[..., 1], ijk[..., 2], bins] > HOW_NONE)
        if interpolate and threshold > 0.0:
            value = value & (support_score(self, T[..., :3, 3], bins) >= threshold)
        refiner = refine_robot(self, robot, refine, asked_rule=asked_rule)[0]
        if refiner is not None:
            value = refined_answer(self, T, value, np.asarray(bins), refiner)
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
            *([self.payload_text()] if self.payload is not None else []),
            *([_collisions_text(self.settings["collisions"])] if self.settings.get("collisions") else []),
        ])

    def resolution(self) -> str:
        """What a yes of :meth:`query` means, in words (the voxel, the orientation bin, roll or any roll)."""
        return resolution_text(self)

    def checks_text(self) -> list[str]:
        """Lines: how the sampling ended, the held-out completeness and the false-positive bound (when built)."""
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

    def payload_text(self, mass: float | None = None) -> str:
        """One line about the payload layer: its CoG and gravity, the largest best capacity, and with ``mass`` (kg)
        the voxels whose best (some reached bin) and worst (every reached bin) capacity is at least ``mass``."""
        layer = self.payload
        cog = ", ".join(short_text(v, 4) for v in layer.cog)
        g = ", ".join(short_text(v, 4) for v in layer.gravity)
        reached = ~np.isnan(layer.best)
        top = float(np.nanmax(layer.best)) if reached.any() else math.nan
        head = (f"payload (CoG ({cog}) m in {printable(self.frame)}'s axes, gravity ({g}) m/s^2 in "
                f"{printable(self.base)}; {layer.configurations_text()}): ")
        if mass is None:
            return head + (f"the largest capacity {short_text(top, 4)} kg" if reached.any() else "no voxel reached")
        cell = self.voxel ** (2 if self.orientations.kind == "planar" else 3)
        unit = "m^2" if self.orientations.kind == "planar" else "m^3"
        some, every = int(layer.carries(mass).sum()), int(layer.carries_everywhere(mass).sum())
        return (head + f"{short_text(float(mass), 4)} kg carried in {some} of {int(reached.sum())} reachable voxels "
                f"({short_text(some * cell, 4)} {unit}) in at least one orientation bin, in {every} in every reached "
                f"bin ({short_text(self.voxel)} m voxels, {self.orientations.size} orientation bins)")

    def save(self, path) -> Path:
        """Write the map to the Zarr folder ``path`` (replacing a map there; never another folder); returns it.

        Written beside ``path`` and renamed into place at the end (:func:`manipkit.analysis.reachmap.store.save_map`).
        """
        return save_map(self, path)

    def attrs(self) -> dict:
        """The map's settings as JSON-ready values (the Zarr attributes)."""
        return {
            "format": FORMAT, "robot": self.robot, "frame": self.frame, "base": self.base, "voxel": self.voxel,
            "origin": self.origin.tolist(), "axes": self.axes.tolist(), "method": self.method,
            "orientations": self.orientations.attrs(), "joint_names": list(self.joint_names),
            "settings": json.loads(json.dumps(self.settings)),
            **({"payload": self.payload.attrs()} if self.payload is not None else {}),
        }


def _collisions_text(c: dict) -> str:
    floor = f", floor at z = {short_text(c['floor'])} m" if c.get("floor") is not None else ""
    srdf = f", {c['disabled_pairs']} pairs disabled by {rules_source_text(c['srdf'])}" if c.get("srdf") else ""
    return f"collision-free only: {' and '.join(c['checked'])} ({c['geometry']} geometry{floor}{srdf})"


def load(path) -> ReachMap:
    """The map stored in the Zarr folder ``path`` by :meth:`ReachMap.save`, validated as a whole.

    Attributes, array shapes, axes, orientation kinds and the presence and
    size of every chunk are checked before any array is decoded
    (:func:`manipkit.analysis.reachmap.store.read_map`).

    Raises
    ------
    InputFileError
        No such folder, not a manipkit reachability map, or a map that fails a check (named in the message).
    """
    return ReachMap(**read_map(path))

