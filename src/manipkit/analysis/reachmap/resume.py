"""Resuming a reach map's build: what its saved blocks are keyed by, and the checks a saved block must pass.

(docs/site/internals/reach-maps.md.) :func:`manipkit.analysis.reachmap.build`
with ``resume_dir`` keeps its finished blocks in a
:class:`manipkit.analysis.reachmap.blockstore.BlockStore` under the fingerprint of
:func:`build_settings` (the robot's description text, base, frame, every
build setting, the map format, manipkit's version and the source of the
modules that compute a block), and reads a saved block back only if
:func:`result_checks` accepts it: the layout of :func:`~manipkit.analysis.reachmap.jobs.sample_block`'s
or :func:`~manipkit.analysis.reachmap.jobs.ik_block`'s result, dtypes, shapes,
keys inside the grid, finite configurations, and every stored configuration
landing (by FK) in the voxel-bin or voxel it is stored for.
"""

from __future__ import annotations

import hashlib
import math
from functools import partial
from pathlib import Path

import numpy as np

from manipkit.analysis.reachmap.jobs import MapJob, packed_bit

__all__ = ["build_settings", "result_checks"]


def _code_digest() -> str:
    """SHA-256 of the source of the modules that compute a block (a changed computation is a new build)."""
    from manipkit.analysis.reachmap import jobs, orientations, stages

    digest = hashlib.sha256()
    for module in (jobs, stages, orientations):
        digest.update(Path(module.__file__).read_bytes())
    return digest.hexdigest()


def build_settings(job: MapJob, *, method: str, orientations: tuple[int, int], converge: float, holdout: int,
                   fp_checks: int, map_format: str) -> dict:
    """Everything that determines a map's blocks and the map, JSON-ready (the store's fingerprint is its hash)."""
    import manipkit

    return {
        "map_format": map_format, "manipkit": manipkit.__version__, "code_sha256": _code_digest(),
        "robot": job.robot.name, "description_sha256": hashlib.sha256(job.robot.urdf.encode()).hexdigest(),
        "base": job.base, "frame": job.frame, "voxel": job.voxel, "orientations": list(orientations),
        "method": method, "samples": job.samples, "seed": job.seed, "block_samples": job.block_samples,
        "ik_tol": job.ik_tol, "ik_restarts": job.ik_restarts, "ik_time_budget": job.ik_time_budget,
        "manipulability": job.manipulability, "converge": converge, "holdout": holdout, "fp_checks": fp_checks,
        "collisions": None if job.collisions is None else job.collisions.as_dict(),
    }


def result_checks(job: MapJob) -> dict:
    """``{function name: check(result, arguments)}`` for the block store (None: accepted, else what is wrong)."""
    return {"sample_block": partial(_check_sample, job), "ik_block": partial(_check_ik, job)}


def _array(value, dtype, shape: tuple) -> bool:
    return isinstance(value, np.ndarray) and value.dtype == np.dtype(dtype) and value.shape == shape


def _increasing_below(values: np.ndarray, top: int) -> bool:
    return values.ndim == 1 and (values.size == 0 or (values[0] >= 0 and values[-1] < top
                                                      and bool(np.all(np.diff(values) > 0))))


def _check_sample(job: MapJob, result, arguments: tuple) -> str | None:
    """sample_block's (block, keys, voxels, Q, stats, key_q) for block ``arguments[0]`` of ``job``."""
    from manipkit.analysis.reachmap.stages import certified, keys_of

    if not isinstance(result, tuple) or len(result) != 6 or result[0] != arguments[0]:
        return "not the result of this FK block"
    _, keys, voxels, Q, stats, key_q = result
    n_voxels, bins, n_joints = math.prod(job.shape), job.orientations.size, len(job.q_default)
    if not (isinstance(keys, np.ndarray) and keys.dtype == np.int64 and _increasing_below(keys, n_voxels * bins)):
        return "its voxel-bin keys are not increasing keys inside the grid"
    if not (isinstance(voxels, np.ndarray) and voxels.dtype == np.int64 and _increasing_below(voxels, n_voxels)):
        return "its voxels are not increasing voxel indices inside the grid"
    known = arguments[1] if len(arguments) > 1 else None  # the round's snapshot: (bins, voxels) reached, packed
    if known is None:
        if not np.array_equal(np.unique(keys // bins), voxels):
            return "its voxels are not the voxels of its keys"
    else:  # a voxel reached before is left out of voxels (without statistics), never one of a new key's otherwise
        key_voxels = np.unique(keys // bins)
        if not np.all(np.isin(key_voxels, voxels) | packed_bit(known[1], key_voxels)):
            return "a voxel of its keys is missing from its voxels"
        if packed_bit(known[0], keys).any():
            return "its keys hold a voxel-bin of its round's snapshot"
        if stats is None and packed_bit(known[1], voxels).any():
            return "its voxels hold one of its round's snapshot"
    if not (_array(Q, float, (len(voxels), n_joints)) and _array(key_q, float, (len(keys), n_joints))
            and np.isfinite(Q).all() and np.isfinite(key_q).all()):
        return "its configurations are not finite (voxels or keys, joints) arrays"
    if (stats is None) != (not job.manipulability or voxels.size == 0):
        return "its manipulability statistics do not match the build's"
    if stats is not None and not (isinstance(stats, tuple) and len(stats) == 3 and
                                  _array(stats[0], float, voxels.shape) and _array(stats[1], float, voxels.shape)
                                  and _array(stats[2], np.int64, voxels.shape) and np.isfinite(stats[0]).all()
                                  and np.isfinite(stats[1]).all() and bool(np.all(stats[2] >= 1))):
        return "its manipulability statistics are not (best, sum, count) per voxel"
    if not certified(job, keys, key_q).all():
        return "a configuration does not reach the voxel-bin it is stored for"
    T = job.robot.fk(Q, base=job.base, tip=job.frame) if len(Q) else np.zeros((0, 4, 4))
    if len(Q) and not np.array_equal(keys_of(job, T) // bins, voxels):
        return "a configuration does not reach the voxel it is stored for"
    return None


def _check_ik(job: MapJob, result, arguments: tuple) -> str | None:
    """ik_block's (block, success, Q) for block ``arguments[0]`` of ``arguments[1]`` targets."""
    if not isinstance(result, tuple) or len(result) != 3 or result[0] != arguments[0]:
        return "not the result of this IK block"
    _, success, Q = result
    n = len(arguments[1])
    if not (_array(success, bool, (n,)) and _array(Q, float, (n, len(job.q_default)))
            and np.isfinite(Q[success]).all()):
        return "not (success, configurations) of its targets"
    return None
