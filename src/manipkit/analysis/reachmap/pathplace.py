"""Where to put the part: offsets of a tool path (or of the base) at which the chain can follow it.

Conventions (docs/site/guides/paths.md, "Where to put the part"):

- An offset is ``(dx, dy, dz, yaw)``: metres and radians in the chain's
  ``base`` frame. It moves the path: ``T_base_waypoint' = O @ T_base_waypoint``
  with ``O = [Rz(yaw), (dx, dy, dz)]``. Moving the path by ``O`` is the same
  as moving the base by ``O^-1`` with the path fixed in the world.
- Candidates are the points of a grid: each of x, y, z and yaw is a range
  ``(low, high, step)`` (every ``low + k step`` up to ``high``) or fixed at 0;
  candidates are numbered in C order (x slowest, yaw fastest).
- Screening (with a reach map of the same base and tip): a candidate is
  planned only when the map says yes to at least ``share`` of its shifted
  waypoints (:meth:`manipkit.analysis.reachmap.ReachMap.query` at
  ``threshold``); the map is an estimate at its resolution, so the screen may
  drop a candidate the planner would accept near the region's edge.
- Each surviving candidate is planned by :func:`manipkit.paths.plan.plan_path`
  with the same options; blocks of candidate indices run here or on a Dask
  ``LocalCluster`` (:class:`manipkit.analysis.reachmap.blocks.BlockRunner`);
  results are stored by candidate index, so the answer is the same for any
  number of workers. The best candidate is the feasible one of least plan
  cost, the lowest index among equal costs.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from manipkit.analysis.reachmap.blocks import BlockRunner, check_workers, in_block_order
from manipkit.analysis.reachmap.constants import DEFAULT_THRESHOLD, check_threshold
from manipkit.errors import ReachMapError
from manipkit.text import repr_text, short_text

__all__ = ["AXES", "MAX_OFFSETS", "PathPlacement", "offset_grid", "offset_transform", "place_path", "shifted_poses"]

AXES = ("x", "y", "z", "yaw")
MAX_OFFSETS = 100_000  # candidates a search may plan (each is a whole ladder)
BLOCK_CANDIDATES = 1  # candidates per block: one, so that progress counts candidates (each is a whole ladder)


def _count(axis: str, spec) -> int:
    low, high, step = (float(v) for v in spec)
    if not all(math.isfinite(v) for v in (low, high, step)):
        raise ReachMapError(f"place {axis} {repr_text(spec)}: give finite LOW HIGH STEP")
    if step <= 0:
        raise ReachMapError(f"place {axis} step {short_text(step)}: give a step > 0")
    if high < low:
        raise ReachMapError(f"place {axis} {short_text(low)} .. {short_text(high)}: the range is empty (HIGH < LOW)")
    span = (high - low) / step
    if span > MAX_OFFSETS:
        raise ReachMapError(f"place {axis}: {short_text(span, 3)} steps, more than {MAX_OFFSETS} candidates; "
                            "use a coarser step or a smaller range")
    return int(math.floor(span + 1e-9)) + 1


def offset_grid(x=None, y=None, z=None, yaw=None) -> np.ndarray:
    """The candidate offsets (K, 4) ``(dx, dy, dz, yaw)`` of the ranges given (``(low, high, step)``, m or rad;
    None: fixed at 0), in C order; :class:`ReachMapError` for a step <= 0, an empty range, or more than
    :data:`MAX_OFFSETS` candidates."""
    axes = []
    for name, spec in zip(AXES, (x, y, z, yaw)):
        if spec is None:
            axes.append(np.zeros(1))
            continue
        n = _count(name, spec)
        axes.append(float(spec[0]) + float(spec[2]) * np.arange(n))
    total = math.prod(len(a) for a in axes)
    if total > MAX_OFFSETS:
        raise ReachMapError(f"{' x '.join(str(len(a)) for a in axes)} = {total} candidate offsets, more than "
                            f"{MAX_OFFSETS}: use coarser steps or smaller ranges")
    grids = np.meshgrid(*axes, indexing="ij")
    return np.stack([g.reshape(-1) for g in grids], axis=1)


def offset_transform(offset) -> np.ndarray:
    """``O = [Rz(yaw), (dx, dy, dz)]`` (4, 4) of one offset ``(dx, dy, dz, yaw)``."""
    dx, dy, dz, yaw = (float(v) for v in offset)
    c, s = math.cos(yaw), math.sin(yaw)
    shift = np.eye(4)
    shift[:2, :2] = [[c, -s], [s, c]]
    shift[:3, 3] = dx, dy, dz
    return shift


def shifted_poses(poses, offset) -> np.ndarray:
    """The path ``poses`` (N, 4, 4) moved by ``offset``: ``O @ T`` for each."""
    return offset_transform(offset) @ np.asarray(poses, dtype=float)


@dataclass(frozen=True, eq=False)
class PlaceJob:
    """What a worker needs to plan candidates: the robot, the path, the frames and the plan options."""

    robot: object
    poses: np.ndarray
    base: str
    tip: str
    options: dict


def plan_block(job: PlaceJob, block: int, indices: np.ndarray, offsets: np.ndarray) -> tuple:
    """(block, indices, feasible, cost, first_failure) of planning the path at each offset of a block."""
    from manipkit.paths.plan import plan_path

    feasible = np.zeros(len(indices), dtype=bool)
    cost = np.full(len(indices), np.nan)
    first = np.full(len(indices), -1, dtype=np.int64)
    for k, offset in enumerate(offsets):
        plan = plan_path(job.robot, shifted_poses(job.poses, offset), base=job.base, tip=job.tip, **job.options)
        feasible[k] = plan.feasible
        if plan.feasible:
            cost[k] = plan.cost
        elif plan.first_failure is not None:
            first[k] = plan.first_failure
    return block, indices, feasible, cost, first


@dataclass(frozen=True, eq=False)
class PathPlacement:
    """The answer of :func:`place_path` (module docstring for the frames and the order).

    Attributes
    ----------
    offsets : ndarray, shape (K, 4)
        Candidate offsets ``(dx, dy, dz, yaw)`` (m, rad).
    screened : ndarray, shape (K,), or None
        Per candidate, how many of the path's waypoints the reach map says yes to; None without a map.
    planned : ndarray, shape (K,) bool
        The candidates planned (those the screen kept; all without a map).
    feasible : ndarray, shape (K,) bool
        The planned candidates whose plan is feasible.
    cost : ndarray, shape (K,)
        The plan cost of each feasible candidate (rad or m), NaN elsewhere.
    first_failure : ndarray, shape (K,) int
        The first waypoint where every branch dies, of a planned infeasible candidate; -1 elsewhere.
    waypoints : int
        Waypoints of the path.
    share : float
        The screen's share of waypoints (with a map).
    """

    offsets: np.ndarray
    screened: np.ndarray | None
    planned: np.ndarray
    feasible: np.ndarray
    cost: np.ndarray
    first_failure: np.ndarray
    waypoints: int
    share: float

    @property
    def best(self) -> int | None:
        """Index of the feasible candidate of least cost (the lowest index among equal costs), or None."""
        if not self.feasible.any():
            return None
        cost = np.where(self.feasible, self.cost, np.inf)
        return int(np.argmin(cost))

    def region(self) -> dict | None:
        """``{axis: [low, high]}`` bounds of the feasible candidates, or None when none is feasible."""
        if not self.feasible.any():
            return None
        chosen = self.offsets[self.feasible]
        return {axis: [float(chosen[:, i].min()), float(chosen[:, i].max())] for i, axis in enumerate(AXES)}

    def as_dict(self) -> dict:
        """JSON-safe: counts, the region, the best offset and its cost, and every feasible offset with its cost."""
        best = self.best
        return {
            "candidates": len(self.offsets), "screened_out": int((~self.planned).sum()),
            "planned": int(self.planned.sum()), "feasible": int(self.feasible.sum()), "waypoints": self.waypoints,
            "share": self.share if self.screened is not None else None, "region": self.region(),
            "best": None if best is None else {"index": best, "offset": dict(zip(AXES, map(float, self.offsets[best]))),
                                               "cost": float(self.cost[best])},
            "feasible_offsets": [[*map(float, self.offsets[i]), float(self.cost[i])]
                                 for i in np.flatnonzero(self.feasible)],
        }


def place_path(robot, poses, *, base: str, tip: str, offsets, reach_map=None, share: float = 1.0,
               threshold: float = DEFAULT_THRESHOLD, workers: int | None = None, progress=None,
               **plan_options) -> PathPlacement:
    """Plan the path ``poses`` (N, 4, 4, ``T_base_tip``) at every candidate ``offsets`` (K, 4) and say where it
    is feasible and where it is best (module docstring).

    ``reach_map`` (of ``tip`` in ``base``) screens candidates: only those whose shifted waypoints the map says
    yes to in at least ``share`` (0..1) of the waypoints are planned. ``workers`` starts a Dask
    ``LocalCluster`` of that many processes (None: plan here); ``progress("candidates planned", done, total)`` is
    called after each planned candidate. ``plan_options`` go to :func:`manipkit.paths.plan.plan_path` (not ``progress``).
    """
    check_workers(workers)
    offsets = np.asarray(offsets, dtype=float)
    if offsets.ndim != 2 or offsets.shape[1] != 4 or not len(offsets) or not np.isfinite(offsets).all():
        raise ReachMapError(f"offsets have shape {offsets.shape}; give one or more finite (dx, dy, dz, yaw) rows")
    if len(offsets) > MAX_OFFSETS:
        raise ReachMapError(f"{len(offsets)} candidate offsets, more than {MAX_OFFSETS}")
    if isinstance(share, bool) or not isinstance(share, numbers.Real) or not 0 <= share <= 1:
        raise ReachMapError(f"share {repr_text(share)}: give a fraction of the waypoints from 0 to 1")
    poses = np.asarray(poses, dtype=float)
    screened = None
    planned = np.ones(len(offsets), dtype=bool)
    if reach_map is not None:
        check_threshold(threshold)
        if (reach_map.base, reach_map.frame) != (base, tip):
            raise ReachMapError(f"the reach map is of {reach_map.frame} in {reach_map.base}, the path of {tip} in "
                                f"{base}: build the map for the path's frames")
        screened = np.array([int(reach_map.query(shifted_poses(poses, o), threshold=threshold).sum())
                             for o in offsets], dtype=np.int64)
        planned = screened >= math.ceil(share * len(poses) - 1e-9)
    feasible = np.zeros(len(offsets), dtype=bool)
    cost = np.full(len(offsets), np.nan)
    first = np.full(len(offsets), -1, dtype=np.int64)
    kept = np.flatnonzero(planned)
    blocks = [kept[i:i + BLOCK_CANDIDATES] for i in range(0, len(kept), BLOCK_CANDIDATES)]
    job = PlaceJob(robot, poses, base, tip, dict(plan_options))
    if blocks:
        with BlockRunner(workers, None, progress) as runner:
            arguments = [(b, idx, offsets[idx]) for b, idx in enumerate(blocks)]
            for _, idx, ok, c, f in in_block_order(runner.run(plan_block, job, arguments, "candidates planned")):
                feasible[idx], cost[idx], first[idx] = ok, c, f
    return PathPlacement(offsets, screened, planned, feasible, cost, first, len(poses), float(share))
