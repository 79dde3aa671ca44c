"""What a reachability map is made of and bounded by: reach codes, methods, the format, every bound, and their checks.

(docs/site/internals/reach-maps.md.) The bottom of
:mod:`manipkit.analysis.reachmap`: the package's modules read their codes
and bounds here, and this module imports none of them.

>>> HOW_NONE, HOW_SAMPLE, HOW_IK
(0, 1, 2)
>>> map_bytes(10, 4, 2)  # 10 x 4 voxel-bins of a byte; per voxel 2 joints and 3 statistics of 8 bytes, a flag
450
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from manipkit.errors import ReachMapError
from manipkit.text import repr_text

__all__ = [
    "DEFAULT_BLOCK", "DEFAULT_FP_CHECKS", "DEFAULT_HOLDOUT", "DEFAULT_SAMPLES", "DEFAULT_THRESHOLD", "FORMAT", "HOW_IK",
    "HOW_NONE", "HOW_SAMPLE", "LAYERS", "MAX_BINS", "MAX_BLOCK_SAMPLES", "MAX_FP_CHECKS", "MAX_GRID_BYTES",
    "MAX_IK_RESTARTS", "MAX_MAP_FILES", "MAX_SAMPLES", "MAX_SEED", "MAX_VOXEL", "METHODS", "MIN_VOXEL", "PARALLEL_TOL",
    "PLANAR_TILT_TOL", "check_threshold", "finite_array", "map_bytes",
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
#: The least support (``score``) a yes needs besides a reached voxel-bin; chosen on the iiwa14 5 cm map of
#: benchmarks/reachmap_workload.py (false positives and recall at several thresholds in docs/architecture.md).
DEFAULT_THRESHOLD = 0.65


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


def map_bytes(n_voxels: int, n_bins: int, n_joints: int) -> int:
    """Memory (bytes) of a map's arrays: a byte per voxel-bin; per voxel a configuration and three statistics."""
    return n_voxels * n_bins + n_voxels * (8 * n_joints + 8 * 3 + 1)


def check_threshold(threshold) -> float:
    """``threshold`` as a float if it is a real number in [0, 1], else :class:`ReachMapError`."""
    if (isinstance(threshold, bool) or not isinstance(threshold, numbers.Real) or not math.isfinite(threshold)
            or not 0.0 <= threshold <= 1.0):
        raise ReachMapError(f"threshold {repr_text(threshold)}: give the least support a yes needs, a number from 0 "
                            "to 1 (0: the plain voxel-bin answer)")
    return float(threshold)
