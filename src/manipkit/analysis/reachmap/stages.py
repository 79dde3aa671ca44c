"""The stages of a reachability map build: sampling until it converges, IK fill passes, and the map's own checks.

(docs/site/internals/reach-maps.md; :func:`manipkit.analysis.reachmap.build` runs them in this order.)

- **Certificates**: every reached voxel-bin keeps one configuration whose FK
  lands in it (voxel and orientation bin): the first sample in block order,
  or the IK answer that reached it, kept only once its own FK is binned back
  into the same voxel-bin (:func:`certified`). ``cert_keys`` (sorted flat
  voxel-bin indices, exactly the reached ones) and ``cert_q`` hold them.
- **Sampling until it converges** (:func:`sample_until_converged`): FK blocks
  are run in rounds of ``ROUND_BLOCKS`` blocks (with collisions checked and
  no manipulability statistics: 1, 2, 4, then ``ROUND_BLOCKS``; a fixed
  schedule either way) and merged in block order; the stage stops after the first block
  ``b >= 1`` that adds fewer than ``converge`` times the voxel-bins reached
  before it, or when the ``samples`` budget is spent. The decision depends on
  blocks ``0..b`` only, so the map is the same whatever ran them (blocks
  after ``b`` are dropped). Two rounds are in flight: round ``k + 2`` is
  handed out as soon as round ``k`` is merged, so a cluster's workers run
  round ``k + 1`` while the driver merges. Each block of round ``k`` is
  given the voxel-bins and voxels reached before round ``k - 1`` (none for
  rounds 0 and 1; bit-packed, :class:`KnownBins`, sent to a cluster's
  workers once per round) and leaves them out of its result, and, with
  collisions checked and no manipulability statistics, checks no sample
  landing in them (:func:`manipkit.analysis.reachmap.jobs.sample_block`): a
  snapshot fixed by the round's number, so the map is the same for any
  worker count (and the same as merging everything), a resumed build asks
  for the same blocks, and the small first rounds keep the bins checked
  twice few.
- **IK fill** (:func:`fill_passes`): IK on every unreached voxel-bin whose
  voxel centre lies inside the reach shell (within ``reach + voxel`` of the
  first joint) and that has a face-neighbour voxel reached in the same bin,
  aiming at the voxel centre with the bin's representative orientation,
  seeded from that neighbour's certificate; repeated until a pass adds
  nothing. A voxel-bin is tried once (from one neighbour, with the random
  restarts of ``ik_restarts``).
- **Held-out completeness** (:func:`holdout_completeness`): ``holdout``
  further FK samples from a stream the build never drew from
  (``default_rng([seed, 2, b])``, collision-free ones only when collisions
  are checked): the fraction the map says yes to (``says_yes``: the map's
  :meth:`~manipkit.analysis.reachmap.ReachMap.query`, its voxel-bin reached
  and its support at least the threshold; without it, the fraction landing
  in reached voxel-bins) estimates the share of reachable poses (weighted as
  uniform joint samples weight them) the map calls reachable, with a 95 %
  Wilson interval.
- **False-positive bound** (:func:`false_positive_bound`): ``fp_checks``
  reached voxel-bins drawn at random (``default_rng([seed, 3])``), one pose
  drawn inside each (uniform in the voxel, an orientation inside the bin);
  of those the map says yes to (``says_yes``; without it, all), IK for the
  exact pose in the map's IK mode from the bin's certificate; the share IK
  fails on, with its 95 % Wilson upper bound, bounds how often a yes of the
  map near its reached bins is wrong (IK failing does not prove a pose
  unreachable, so this is an upper bound).
"""

from __future__ import annotations

import math
from collections import deque
from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.reachmap.blocks import in_block_order
from manipkit.analysis.reachmap.jobs import IK_BLOCK, ik_block, sample_block

if TYPE_CHECKING:
    from manipkit.analysis.reachmap.blocks import BlockRunner

__all__ = [
    "HOLDOUT_STREAM", "ROUND_BLOCKS", "KnownBins", "certified", "false_positive_bound", "fill_passes", "holdout_completeness",
    "sample_until_converged", "wilson",
]

ROUND_BLOCKS = 16  # FK blocks of a full round (fixed: the map does not depend on the workers; 16 keep a cluster busy)
HOLDOUT_STREAM, FP_STREAM = 2, 3  # the seed streams of the checks (the FK stage draws from stream 0)
Z95 = 1.959963984540054  # the two-sided 95 % normal quantile
MAX_FILL_PASSES = 1000
ROTATION_TRIES = 64  # draws of an orientation inside a bin before its centre is taken


def wilson(hits: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval (low, high) of a proportion ``hits / n`` (``(0, 1)`` when ``n`` is 0).

    >>> [round(v, 4) for v in wilson(95, 100)]  # p = 0.95, z = 1.96: centre 0.9333, half-width 0.0451
    [0.8882, 0.9785]
    """
    if n <= 0:
        return 0.0, 1.0
    p = hits / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def keys_of(job, T: np.ndarray) -> np.ndarray:
    """Flat voxel-bin index of each pose ``T`` (N, 4, 4) in ``base``; -1 outside the grid."""
    cells, inside = job.cells(T[:, :3, 3])
    if job.orientations.kind == "planar":  # off the plane the tool is in no bin of the map
        local = (T[:, :3, 3] - job.origin) @ job.axes[:, 2]
        inside &= np.abs(local) <= job.voxel / 2
    return np.where(inside, cells * job.orientations.size + job.orientations.bin_of(T[:, :3, :3]), -1)


def certified(job, keys: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Mask of the rows of ``Q`` whose FK (``frame`` in ``base``) lands in voxel-bin ``keys`` (the certificate test)."""
    if len(keys) == 0:
        return np.zeros(0, dtype=bool)
    return keys_of(job, job.robot.fk(Q, base=job.base, tip=job.frame)) == keys


def sample_until_converged(job, runner: BlockRunner, merge, converge: float) -> dict:
    """Run FK blocks in rounds until one adds fewer than ``converge`` x the bins before it (module docstring).

    ``merge(result)`` folds one block's result into the caller's arrays and
    returns how many voxel-bins it newly reached. Returns what was used:
    ``{"blocks", "samples_used", "converged"}``.

    Two rounds are in flight: round ``k + 2`` is handed to the runner as soon
    as round ``k`` is merged, with the voxel-bins known then (before round
    ``k + 1``) as its snapshot, so a cluster's workers go on with round
    ``k + 1`` while the driver merges; rounds 0 and 1 have no snapshot.
    """
    n_blocks = -(-job.samples // job.block_samples)
    ramp = job.collisions is not None and not job.manipulability  # small first rounds: fewer samples checked twice
    rounds = _rounds(n_blocks, ramp)
    known = KnownBins(math.prod(job.shape), job.orientations.size)
    in_flight = deque()

    def submit(snapshot) -> None:
        span = next(rounds, None)
        if span is None:
            return
        first, stop = span
        label = "FK samples" if stop - first == n_blocks else f"FK samples, blocks {first + 1}-{stop} of at most " \
            f"{n_blocks}"
        arguments = [(b, snapshot) for b in range(first, stop)]  # one snapshot object: sent to a cluster once
        in_flight.append((first, runner.submit(sample_block, job, arguments, label)))

    submit(None)
    submit(None)
    reached, block, converged = 0, 0, False
    while in_flight and not converged:
        first, batch = in_flight.popleft()
        for result in in_block_order(batch.results(), first):
            added = merge(result)
            known.add(result[1], result[2])
            converged = result[0] >= 1 and converge > 0 and added < converge * reached
            reached += added
            block = result[0] + 1
            if converged:
                break  # blocks after the stopping one are dropped (their results may be computed anyway)
        if converged:
            batch.cancel()
        else:
            submit(known.snapshot())
    for _, batch in in_flight:
        batch.cancel()
    used = min(job.samples, block * job.block_samples)
    return {"blocks": block, "samples_used": int(used), "converged": bool(converged)}


def _rounds(n_blocks: int, ramp: bool):
    """(first, stop) block numbers of each round in order: ``ROUND_BLOCKS`` blocks, or 1, 2, 4 .. up to it (``ramp``)."""
    first = 0
    while first < n_blocks:
        size = min(ROUND_BLOCKS, first + 1) if ramp else ROUND_BLOCKS  # 1, 2, 4, 8, 16, 16 .. or 16, 16 ..
        yield first, min(n_blocks, first + size)
        first += size


class KnownBins:
    """The voxel-bins and voxels reached so far, bit-packed as ``numpy.packbits`` packs them (big-endian bits, the
    last byte padded with zeros), kept up to date block by block (:func:`manipkit.analysis.reachmap.jobs.sample_block`).

    >>> known = KnownBins(2, 4)  # 2 voxels x 4 bins
    >>> known.add(np.array([1, 6]), np.array([0, 1]))
    >>> [a.tolist() for a in known.snapshot()]  # bits 1 and 6 of 8; voxels 0 and 1
    [[66], [192]]
    """

    def __init__(self, n_voxels: int, n_bins: int):
        self.bins = np.zeros(-(-n_voxels * n_bins // 8), dtype=np.uint8)
        self.voxels = np.zeros(-(-n_voxels // 8), dtype=np.uint8)

    def add(self, keys: np.ndarray, voxels: np.ndarray) -> None:
        """Mark voxel-bins ``keys`` and voxels ``voxels`` (flat indices) reached."""
        for packed, index in ((self.bins, keys), (self.voxels, voxels)):
            np.bitwise_or.at(packed, index >> 3, (128 >> (index & 7)).astype(np.uint8))

    def snapshot(self) -> tuple[np.ndarray, np.ndarray]:
        """(bins, voxels): copies of what is known now (the next round's blocks are given this)."""
        return self.bins.copy(), self.voxels.copy()


def _neighbour_seeds(job, marked: np.ndarray, tried: np.ndarray) -> np.ndarray:
    """Per voxel-bin, the flat key of a face neighbour marked in the same bin (-1: none), for unmarked, untried ones."""
    B = job.orientations.size
    voxel_ids = np.arange(math.prod(job.shape), dtype=np.int64).reshape(job.shape)
    seed_key = np.full(marked.shape, -1, dtype=np.int64)
    bin_ids = np.arange(B, dtype=np.int64)
    for axis in range(3):
        if job.shape[axis] < 2:
            continue
        for shift in (1, -1):  # the neighbour at -1 along the axis first, then +1
            neighbour = np.roll(marked, shift, axis=axis)
            neighbour_id = np.roll(voxel_ids, shift, axis=axis)
            edge = [slice(None)] * 3
            edge[axis] = 0 if shift == 1 else -1
            neighbour[tuple(edge)] = False  # np.roll wraps around: no neighbour across the grid's edge
            new = neighbour & ~marked & ~tried & (seed_key < 0)
            keys = neighbour_id[..., None] * B + bin_ids
            seed_key[new] = keys[new]
    return seed_key


def fill_passes(job, runner: BlockRunner, reach: np.ndarray, cert_keys: np.ndarray, cert_q: np.ndarray,
                shell: float, how_ik: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """IK fill passes until one adds nothing (module docstring); marks ``how_ik`` in ``reach`` (flat).

    Returns (ik keys, ik configurations, all certificate keys, their configurations, passes), keys sorted.
    """

    B = job.orientations.size
    centres = job.origin + (np.stack(np.unravel_index(np.arange(math.prod(job.shape)), job.shape), axis=-1)
                            * job.voxel) @ job.axes.T
    in_shell = (np.linalg.norm(centres - job.centre, axis=-1) <= shell).reshape(job.shape)
    tried = np.zeros((*job.shape, B), dtype=bool)
    tried[~in_shell] = True
    rotations = job.orientations.rotations()
    ik_keys, ik_q, passes = [np.zeros(0, dtype=np.int64)], [np.zeros((0, cert_q.shape[1]))], 0
    while passes < MAX_FILL_PASSES:
        seed_key = _neighbour_seeds(job, reach.reshape(*job.shape, B) > 0, tried).reshape(-1)
        keys = np.flatnonzero(seed_key >= 0)
        if keys.size == 0:
            break
        passes += 1
        tried.reshape(-1)[keys] = True
        voxels, bins = np.divmod(keys, B)
        T = np.tile(np.eye(4), (keys.size, 1, 1))
        T[:, :3, :3] = rotations[bins]
        T[:, :3, 3] = centres[voxels]
        Q_seed = cert_q[np.searchsorted(cert_keys, seed_key[keys])]
        blocks = [(b, T[s:s + IK_BLOCK], Q_seed[s:s + IK_BLOCK]) for b, s in enumerate(range(0, keys.size, IK_BLOCK))]
        found_keys, found_q = [np.zeros(0, dtype=np.int64)], [np.zeros((0, cert_q.shape[1]))]
        for block, success, Q in in_block_order(runner.run(ik_block, job, blocks, f"IK fill, pass {passes}")):
            start = block * IK_BLOCK
            found_keys.append(keys[start:start + len(success)][success])
            found_q.append(Q[success])
        new_keys, new_q = np.concatenate(found_keys), np.concatenate(found_q)
        keep = certified(job, new_keys, new_q)  # an answer whose FK is binned elsewhere (a voxel edge) reaches nothing
        new_keys, new_q = new_keys[keep], new_q[keep]
        if new_keys.size == 0:
            break
        reach[new_keys] = how_ik
        ik_keys.append(new_keys)
        ik_q.append(new_q)
        cert_keys, cert_q = _merged(cert_keys, cert_q, new_keys, new_q)
    keys, Q = np.concatenate(ik_keys), np.concatenate(ik_q)
    order = np.argsort(keys)
    return keys[order], Q[order], cert_keys, cert_q, passes


def _merged(keys_a, q_a, keys_b, q_b):
    keys = np.concatenate([keys_a, keys_b])
    order = np.argsort(keys, kind="stable")
    return keys[order], np.concatenate([q_a, q_b])[order]


def holdout_completeness(job, reach: np.ndarray, n: int, says_yes=None) -> dict:
    """Share of ``n`` held-out FK samples the map says yes to, with its 95 % Wilson interval (module docstring).

    ``says_yes``: poses (N, 4, 4) -> bool (N,), the map's answer; None: the
    sample's voxel-bin was reached.
    """
    rng = np.random.default_rng([job.seed, HOLDOUT_STREAM])
    Q = np.tile(job.q_default, (n, 1))
    Q[:, job.chain] = job.low + rng.random((n, job.chain.size)) * (job.high - job.low)
    if job.collisions is not None and n:
        Q = Q[job.collisions.free(job.robot, Q)]
    T = job.robot.fk(Q, base=job.base, tip=job.frame) if len(Q) else np.zeros((0, 4, 4))
    keys = keys_of(job, T) if len(Q) else np.zeros(0, dtype=np.int64)
    hits = int((reach[keys[keys >= 0]] > 0).sum()) if says_yes is None else int(np.count_nonzero(says_yes(T)))
    low, high = wilson(hits, len(keys))
    return {"n": int(len(keys)), "hits": hits, "rate": hits / len(keys) if len(keys) else 0.0, "low": low, "high": high}


def poses_in_bins(job, keys: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One pose (N, 4, 4) drawn inside each voxel-bin ``keys``: uniform in the voxel (in the plane of a planar map),
    an orientation inside the bin (a random turn of the bin's centre, redrawn until it falls in the bin, at most
    :data:`ROTATION_TRIES` times, else the centre). The poses still without one are redrawn together, a round at a time."""
    from manipkit.spatial.rotations import matrix_from_axis_angle

    o = job.orientations
    voxels, bins = np.divmod(keys, o.size)
    ijk = np.stack(np.unravel_index(voxels, job.shape), axis=-1).astype(float)
    offset = rng.random((len(keys), 3)) - 0.5
    if o.kind == "planar":
        offset[:, 2] = 0.0
    T = np.tile(np.eye(4), (len(keys), 1, 1))
    T[:, :3, 3] = job.origin + ((ijk + offset) * job.voxel) @ job.axes.T
    centres = o.rotations()[bins]
    T[:, :3, :3] = centres
    spread = math.pi / o.size if o.kind == "planar" else max(2.5 / math.sqrt(o.n_directions), math.pi / o.n_rolls)
    pending = np.arange(len(keys))
    for _ in range(ROTATION_TRIES):
        if not len(pending):
            break
        axes = np.broadcast_to(o.axis, (len(pending), 3)) if o.kind == "planar" else rng.normal(size=(len(pending), 3))
        turn = matrix_from_axis_angle(axes, (2 * rng.random(len(pending)) - 1) * spread) @ centres[pending]
        if o.n_rolls == 1 and o.kind == "spatial":  # any roll: a random one
            turn = turn @ matrix_from_axis_angle([0.0, 0.0, 1.0], rng.uniform(-math.pi, math.pi, len(pending)))
        inside = o.bin_of(turn) == bins[pending]
        T[pending[inside], :3, :3] = turn[inside]
        pending = pending[~inside]
    return T


def false_positive_bound(job, cert_keys: np.ndarray, cert_q: np.ndarray, n: int, says_yes=None) -> dict:
    """IK on one pose inside each of ``n`` random reached voxel-bins that the map says yes to (module docstring).

    ``says_yes``: poses (N, 4, 4) -> bool (N,), the map's answer (None: every
    drawn pose is checked). Returns ``{"drawn", "n"`` (poses IK checked),
    ``"failed", "rate", "high", "mode"}``.
    """
    from manipkit.ik.numerical_many import ik_many

    rng = np.random.default_rng([job.seed, FP_STREAM])
    n = min(n, len(cert_keys))
    if n == 0:
        return {"drawn": 0, "n": 0, "failed": 0, "rate": 0.0, "high": 1.0, "mode": job.ik_mode}
    rows = np.sort(rng.choice(len(cert_keys), size=n, replace=False))
    T = poses_in_bins(job, cert_keys[rows], rng)
    drawn = n
    if says_yes is not None:
        yes = np.asarray(says_yes(T), dtype=bool)
        rows, T, n = rows[yes], T[yes], int(yes.sum())
        if n == 0:
            return {"drawn": drawn, "n": 0, "failed": 0, "rate": 0.0, "high": 1.0, "mode": job.ik_mode}
    batch = ik_many(job.robot, T, base=job.base, tip=job.frame, q0=cert_q[rows], mode=job.ik_mode, tol=1e-6,
                    restarts=max(job.ik_restarts, 10), time_budget=max(job.ik_time_budget, 0.05),
                    seed=job.seed + FP_STREAM)
    success = np.array(batch.success, dtype=bool)
    if job.collisions is not None and success.any():
        success[success] = job.collisions.free(job.robot, batch.q[success])
    failed = int((~success).sum())
    return {"drawn": int(drawn), "n": int(n), "failed": failed, "rate": failed / n, "high": wilson(failed, n)[1],
            "mode": job.ik_mode}
