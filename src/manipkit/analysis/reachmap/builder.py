"""Reachability maps of any arm: which voxels the tool reaches, in how many orientations, certified by IK.

A map is a voxel grid over the arm's reach, in ``base``, times a set of
orientation bins (:mod:`manipkit.analysis.reachmap.orientations`). A voxel-bin is
**reached** when some configuration inside the joint limits puts ``frame``
inside the voxel with an orientation in the bin. The **index** of a voxel
is the fraction of its bins reached (0..1): the **reachable workspace** is
``index > 0``, the **dexterous workspace** ``index == 1`` (Zacharias et al.
2007's capability map; for a planar arm the voxels are squares in its plane
and the bins turns about its axis, the spatial form of the planar annuli of
:mod:`manipkit.closed_form.planar_workspace`).

Methods (docs/site/internals/reach-maps.md):

- ``"fk"``: random configurations, uniform inside the limits (continuous
  joints in [-pi, pi]), in blocks of ``block_samples``; each block's
  configurations go through the batched FK kernel (:meth:`Robot.fk`) and
  mark the voxel-bins they land in. A mark is certain (a configuration
  lands there); an unmarked bin may still be reachable (not sampled).
- ``"hybrid"``: then IK fill passes (:mod:`manipkit.analysis.reachmap.stages`:
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
defaults); IK block ``b`` (``jobs.IK_BLOCK`` targets in key order) uses
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
reach bound of :class:`manipkit.ik.numerical.IKSolver` around the first
chain joint.

Maps are stored in Zarr (a folder): arrays ``reach`` (chunked), ``voxel_q``,
``ik_keys``, ``ik_q``, ``manipulability`` and ``manipulability_mean`` (when
built) and the settings as attributes (:meth:`ReachMap.save`, :func:`manipkit.analysis.reachmap.map.load`),
written into a temporary sibling and renamed into place, and read back
validated as a whole (:mod:`manipkit.analysis.reachmap.store`).

Every option is bounded before anything is allocated or started, with the
bound in the message (:data:`MAX_SAMPLES`, :data:`MAX_BLOCK_SAMPLES`,
:data:`MAX_SEED`, :data:`MIN_VOXEL`..:data:`MAX_VOXEL`, :data:`MAX_BINS`,
:data:`MAX_IK_RESTARTS`, :func:`manipkit.analysis.reachmap.blocks.max_workers`).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.reachmap import stages
from manipkit.analysis.reachmap.blocks import BlockRunner, check_workers
from manipkit.analysis.reachmap.constants import (
    DEFAULT_BLOCK,
    DEFAULT_FP_CHECKS,
    DEFAULT_HOLDOUT,
    DEFAULT_SAMPLES,
    DEFAULT_THRESHOLD,
    FORMAT,
    HOW_IK,
    HOW_NONE,
    HOW_SAMPLE,
    MAX_BINS,
    MAX_BLOCK_SAMPLES,
    MAX_FP_CHECKS,
    MAX_GRID_BYTES,
    MAX_IK_RESTARTS,
    MAX_SAMPLES,
    MAX_SEED,
    MAX_VOXEL,
    METHODS,
    MIN_VOXEL,
    PARALLEL_TOL,
    map_bytes,
)
from manipkit.analysis.reachmap.jobs import MapJob, translation_manipulability
from manipkit.analysis.reachmap.map import ReachMap
from manipkit.analysis.reachmap.orientations import perpendicular, planar_orientations, spatial_orientations
from manipkit.errors import ReachMapError
from manipkit.text import printable, repr_text, short_text

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain
    from manipkit.kinematics.collisions import CollisionSettings
    from manipkit.kinematics.robot import Robot

__all__ = ["build", "parse_orientations"]


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
    if method is not None and method not in METHODS:
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
    *,
    base: str | None = None,
    tip: str | None = None,
    voxel: float = 0.05,
    orientations: int | tuple[int, int] | str | None = None,
    method: str | None = None,
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
        ``ee_link``).
    voxel : float, keyword-only
        Voxel edge (m).
    orientations : int, (int, int) or str, keyword-only
        Spatial arm: ``N`` approach directions (roll ignored) or
        ``(directions, rolls)`` / ``"DIRxROLL"``; planar arm: ``N`` turns
        about its axis. Default: 200 directions, or 36 turns.
    method : {"fk", "hybrid"}, keyword-only
        Default: ``"hybrid"`` for a planar arm (its IK fill is cheap and marks
        the whole dexterous annulus of the planar 3R), ``"fk"`` for a spatial one.
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
        Stop share of new bins per block (0: every sample); held-out samples; bins checked by IK (:mod:`~manipkit.analysis.reachmap.stages`).
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
        (:mod:`manipkit.analysis.reachmap.blockstore`, :mod:`manipkit.analysis.reachmap.resume`).
        Blocks of other settings there are removed (a warning says so). The
        folder is kept after the build: remove it
        (:func:`manipkit.analysis.reachmap.blockstore.remove_store`) once the map is saved.
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
    from manipkit.ik.numerical import ik_solver
    from manipkit.kinematics.chain import chain_of

    _check_options(voxel, orientations, method, samples, workers, scheduler, block_samples, seed, ik_tol, ik_restarts,
                   ik_time_budget)
    _real("converge", converge, 0.0, 1.0, "the share of new voxel-bins below which sampling stops (0: every sample)")
    _whole("holdout", holdout, 0, MAX_SAMPLES, "held-out FK samples for the completeness estimate")
    _whole("fp_checks", fp_checks, 0, MAX_FP_CHECKS, "reached voxel-bins checked by IK for the false-positive bound")
    voxel = float(voxel)
    chain = chain_of(chain, "reachmap.build", base=base, tip=tip)
    robot, frame, base = chain.robot, chain.tip, chain.base
    solver = ik_solver(robot, base=base, tip=frame)
    joint_axes = chain.axes()
    axes_k, origins_k, prismatic = joint_axes.direction, joint_axes.point, joint_axes.prismatic.tolist()
    T_tip = chain.fk(chain.q())
    planar = _planar_axis(axes_k, prismatic)
    method = method if method is not None else ("hybrid" if planar is not None else "fk")
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
        from manipkit.analysis.reachmap.blockstore import open_store
        from manipkit.analysis.reachmap.resume import build_settings, result_checks

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
        used = stages.sample_until_converged(job, runner, merge, float(converge))
        cert_keys, cert_q = np.concatenate(cert["keys"]), np.concatenate(cert["q"])
        order = np.argsort(cert_keys)
        cert_keys, cert_q = cert_keys[order], cert_q[order]
        passes = 0
        if method == "hybrid":
            ik_keys, ik_q, cert_keys, cert_q, passes = stages.fill_passes(job, runner, reach, cert_keys, cert_q,
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
    # the map's own checks measure its unrefined yes (voxel-bin reached and support >= DEFAULT_THRESHOLD), the
    # estimate a query gives without the robot's IK (refine=False)
    def unrefined(T):
        return unchecked.query(T, refine=False)

    checks = {"completeness": stages.holdout_completeness(job, reach, int(holdout), unrefined),
              "false_positive": stages.false_positive_bound(job, cert_keys, cert_q, int(fp_checks), unrefined),
              "checked_threshold": DEFAULT_THRESHOLD}
    return replace(unchecked, settings={**settings, **checks})
