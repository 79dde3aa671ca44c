"""One block of a reach map's build, run wherever Dask puts it: :class:`MapJob`, :func:`sample_block`, :func:`ik_block`.

:func:`manipkit.analysis.reachmap.build` makes one :class:`MapJob` (the
robot, the grid and its orientation bins, the sampling box of the chain
joints, the IK settings) and the stages of
:mod:`manipkit.analysis.reachmap.stages` run blocks of it: FK samples seeded
``[seed, 0, block]`` (:func:`sample_block`) and IK targets seeded
``seed + 1 + block`` (:func:`ik_block`), so a block's result depends on
its number only, never on where or when it ran. Keys of voxel-bins are
``voxel * orientations.size + bin`` (flat voxel index in C order).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.reachmap.orientations import OrientationSet

if TYPE_CHECKING:
    from manipkit.kinematics.collisions import CollisionSettings
    from manipkit.kinematics.robot import Robot

__all__ = ["IK_BLOCK", "MapJob", "ik_block", "packed_bit", "sample_block", "translation_manipulability"]

IK_BLOCK = 2048  # IK targets per block


@dataclass(frozen=True, eq=False)
class MapJob:
    """Everything a worker needs to run one block of a map's build (pickled once per run): the robot, the grid,
    the orientation bins, the sampling box of the chain joints and the IK settings."""

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
    centre: np.ndarray | None = None  # the first joint's point, the centre of the reach shell

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


def sample_block(job: MapJob, block: int, known: tuple[np.ndarray, np.ndarray] | None = None) -> tuple:
    """Block ``block`` of FK samples: (block, reached voxel-bin keys, voxels, first configuration in each voxel, stats,
    first configuration in each voxel-bin of ``keys``).

    ``stats``: per voxel (best, sum, count) of the manipulability index of the
    block's samples in it, or None when the map is built without it.
    ``known``: the round's snapshot (:mod:`manipkit.analysis.reachmap.stages`): (voxel-bins reached, voxels reached),
    each bit-packed (``numpy.packbits``, flat keys and flat voxel indices).
    Keys reached before are left out of ``keys`` and, without the
    statistics, voxels reached before out of ``voxels`` (merging them would
    change nothing: each already holds its first configuration); with
    collisions checked and no statistics, samples landing in a bin reached
    before are not checked at all.
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
            if known is not None:  # bins in the snapshot need no new sample
                groups[(groups >= 0) & packed_bit(known[0], groups)] = -1
            free = job.collisions.first_free(job.robot, Q, groups)
        Q, T = Q[free], T[free]
    cells, inside = job.cells(T[:, :3, 3])
    cells, Q = cells[inside], Q[inside]
    keys, first_of_key = np.unique(cells * job.orientations.size + job.orientations.bin_of(T[inside, :3, :3]),
                                   return_index=True)  # each voxel-bin's first sample: its certificate
    order = np.argsort(cells, kind="stable")  # a voxel's samples together, each run in sample order
    starts = np.flatnonzero(np.diff(cells[order], prepend=-1)) if cells.size else np.zeros(0, dtype=np.intp)
    voxels, first = cells[order][starts], order[starts]
    stats = None
    if job.manipulability and cells.size:
        w = translation_manipulability(job.robot, Q, job.frame, job.base, job.axes,
                                       planar=job.orientations.kind == "planar")[order]
        stats = (np.maximum.reduceat(w, starts), np.add.reduceat(w, starts), np.diff(starts, append=w.size))
    if known is not None:
        fresh = ~packed_bit(known[0], keys)
        keys, first_of_key = keys[fresh], first_of_key[fresh]
        if stats is None:
            fresh = ~packed_bit(known[1], voxels)
            voxels, first = voxels[fresh], first[fresh]
    return block, keys, voxels, Q[first], stats, Q[first_of_key]


def packed_bit(packed: np.ndarray, index: np.ndarray) -> np.ndarray:
    """(N,) bool: bit ``index`` of the ``numpy.packbits`` array ``packed`` (big-endian bit order, its default)."""
    return (packed[index >> 3] >> (7 - (index & 7)).astype(np.uint8) & 1).astype(bool)


def ik_block(job: MapJob, block: int, T: np.ndarray, Q_seed: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """Block ``block`` of IK targets: (block, success mask, configurations), by :func:`ik_many` seeded per block."""
    from manipkit.ik.numerical_many import ik_many

    batch = ik_many(job.robot, T, base=job.base, tip=job.frame, q0=Q_seed, mode=job.ik_mode, tol=job.ik_tol,
                    restarts=job.ik_restarts, time_budget=job.ik_time_budget, seed=job.seed + 1 + block,
                    threads=1 if _in_dask_worker() else None)  # a cluster runs one block per core already
    success = np.array(batch.success, dtype=bool)
    if job.collisions is not None and success.any():  # an answer in collision reaches nothing
        success[success] = job.collisions.free(job.robot, batch.q[success])
    return block, success, batch.q


def _in_dask_worker() -> bool:
    """Whether this runs in a Dask worker (each is one process of the cluster, with a core of its own)."""
    import sys

    if "distributed" not in sys.modules:
        return False
    from distributed import get_worker

    try:
        get_worker()
    except ValueError:
        return False
    return True
