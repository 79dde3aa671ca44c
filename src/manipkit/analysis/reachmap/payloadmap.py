"""Build a reach map's payload layer in blocks, here or on Dask, resumable: :func:`payload_map`.

(docs/site/guides/reach.md.) What the layer holds is
:mod:`manipkit.analysis.reachmap.payload`'s. The map's certificates
(``cert_q``, one configuration per reached voxel-bin, in key order) are cut
into blocks of ``block`` configurations. For a chain with a closed-form
family each block's poses (FK of its certificates) are solved for every
branch at once (:func:`manipkit.ik.dispatch.ik_many`, compiled; a 7R SRS
arm's at each certificate's own arm angle,
:func:`manipkit.ik.chain_ik.srs_arm_angle`, vectorised, then at each of
``arm_angles`` sampled arm angles over its self-motion, one solve of the
block per angle, :func:`manipkit.analysis.reachmap.payload.arm_angle_grid`), the branches inside
the joint limits kept with the certificate; otherwise the certificate alone
is weighed. Each block's capacities come from
:func:`manipkit.statics.capacity.payload_capacity` (batched static torques,
compiled), reduced per voxel-bin to its largest and smallest, run by the
map's own :class:`~manipkit.analysis.reachmap.blocks.BlockRunner` (here,
``workers=N`` on a new ``distributed.LocalCluster``, or ``scheduler=`` a
running one) and merged in block order, so the layer is
the same bits however the blocks ran. With ``resume_dir`` the finished
blocks are kept in a :class:`~manipkit.analysis.reachmap.blockstore.BlockStore`
under the fingerprint of everything that determines them (the robot's
description, the chain, the CoG, gravity, limits, block size, the map's
certificates and the source of the modules that compute a block), and an
interrupted build run again reads them back.
"""

from __future__ import annotations

import hashlib
import math
import numbers
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.reachmap.payload import MAX_ARM_ANGLES, PayloadLayer, arm_angle_grid, per_voxel
from manipkit.analysis.reachmap.payload_kernel import kept_branches_kernel, per_bin_kernel
from manipkit.errors import ReachMapError
from manipkit.kinematics.chain import limits_ok
from manipkit.text import printable

if TYPE_CHECKING:
    from manipkit.analysis.reachmap.map import ReachMap
    from manipkit.kinematics.robot import Robot

__all__ = ["ARM_ANGLES", "BRANCH_TOL", "PAYLOAD_BLOCK", "PAYLOAD_FORMAT", "PayloadJob", "branch_rows", "capacity_of",
           "configurations_of", "payload_block", "payload_map"]

PAYLOAD_BLOCK = 1 << 16  # configurations per block (about 20 ms of static torques for a 7-joint arm)
PAYLOAD_FORMAT = "manipkit-payload-4"  # 4: a 7R SRS arm's self-motion sampled at arm_angles arm angles
#: Arm angles a 7R SRS arm's layer samples over its self-motion by default, besides each certificate's own (45 deg
#: apart; each costs about one more solve and one more capacity of every branch of the block).
ARM_ANGLES = 8
BRANCH_TOL = 1e-6  # m and rad: a closed-form branch counts when FK puts the tip this close to the bin's pose
MAX_PAYLOAD_BLOCK = 1 << 22


@dataclass(frozen=True, eq=False)
class PayloadJob:
    """What a worker needs to compute a block of capacities (pickled once per run)."""

    robot: Robot
    base: str
    frame: str
    cog: np.ndarray
    gravity: np.ndarray  # m/s^2 in the root link's axes (what static_torques takes)
    effort: np.ndarray  # (2, n): lower, upper
    configurations: str = "certificates"  # or "branches", "self_motion", "arm_angle_branches" (payload.CONFIGURATIONS)
    arm_angles: int = 0  # "self_motion": the arm angles sampled (payload.arm_angle_grid)


def configurations_of(robot: Robot, base: str, tip: str, arm_angles: int = ARM_ANGLES) -> str:
    """``"branches"`` when the chain ``base -> tip`` has a closed-form family whose every branch of a pose
    :func:`manipkit.ik.dispatch.ik_many` lists; for a 7R SRS arm ``"self_motion"`` (every branch at the stored
    configuration's arm angle and at ``arm_angles`` sampled ones), or ``"arm_angle_branches"`` with
    ``arm_angles=0`` (at the stored one only); else ``"certificates"`` (the stored configuration alone)."""
    from manipkit.errors import ClosedFormIKError
    from manipkit.ik.families import SRS, chain_family

    try:
        family = chain_family(robot.chain(base, tip))
    except ClosedFormIKError:
        return "certificates"
    if not family.solved:
        return "certificates"
    if family.kind != SRS:
        return "branches"
    return "self_motion" if arm_angles else "arm_angle_branches"


def branch_rows(robot: Robot, base: str, tip: str, Q: np.ndarray, *, tol: float = BRANCH_TOL,
                at_arm_angle: bool = False, arm_angle: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(rows (N, 1 + k, n), kept (N, 1 + k) bool): chain vectors, per configuration of ``Q`` (N, n_robot,
    whole-robot vectors) itself, then every other closed-form branch of its pose ``T_base_tip`` (with
    ``at_arm_angle``, a 7R SRS chain's: the branches at the configuration's own arm angle,
    :func:`manipkit.ik.chain_ik.srs_arm_angle`, or at ``arm_angle`` (rad) when given).

    A branch is kept when it exists, lies inside the joint limits, FK puts
    ``tip`` within ``tol`` (m and rad) of the pose, and it is not the
    configuration itself (every joint within ``tol`` of it, modulo 2 pi: the
    branch the configuration is on, weighed once). Rows not kept hold the
    configuration.
    """
    from manipkit.ik.dispatch import ik_many

    chain = robot.chain(base, tip)
    q = np.asarray(Q, dtype=float)[:, chain.columns]
    psi = None
    if at_arm_angle and arm_angle is not None:
        psi = np.full(len(q), float(arm_angle))
    elif at_arm_angle:
        from manipkit.ik.chain_ik import srs_arm_angle

        psi = srs_arm_angle(chain, q)
    batch = ik_many(robot, chain.fk(q), base=base, tip=tip, method="closed_form", tol=tol, arm_angle=psi)
    S = np.ascontiguousarray(batch.solutions, dtype=float)
    rows, kept = np.empty((len(q), 1 + S.shape[1], chain.n)), np.empty((len(q), 1 + S.shape[1]), dtype=bool)
    kept_branches_kernel()(np.ascontiguousarray(q), S, np.ascontiguousarray(batch.residual_position, dtype=float),
                           np.ascontiguousarray(batch.residual_rotation, dtype=float), float(tol),
                           *limits_ok(chain.lower, chain.upper), rows, kept)
    return rows, kept


def payload_block(job: PayloadJob, block: int, Q: np.ndarray) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """Block ``block``: (block, largest capacity kg (N,), smallest (N,), the joint saturating at the smallest (N,),
    -1 none) per voxel-bin of the certificates ``Q`` (N, n) over the configurations ``job.configurations`` names."""
    at_arm_angle = job.configurations in ("arm_angle_branches", "self_motion")
    sampled = arm_angle_grid(job.arm_angles) if job.configurations == "self_motion" else ()
    best, worst, joint = _block_range(job, Q, at_arm_angle, None)  # the certificates' own arm angles first
    for psi in sampled:  # then each sampled arm angle: the block's range widened by its branches
        top, low, low_joint = _block_range(job, Q, True, float(psi))
        best = np.fmax(best, top)  # NaN only where both are (numpy.nanmax's rule)
        lower = ~np.isnan(worst) & (np.isnan(low) | (low < worst))  # per_bin's rule: the first NaN, else the smallest
        worst, joint = np.where(lower, low, worst), np.where(lower, low_joint, joint)
    return block, best, worst, joint  # the worst: the first kept row (the certificate) on ties


def _block_range(job: PayloadJob, Q: np.ndarray, at_arm_angle: bool, arm_angle: float | None) -> tuple:
    """(largest capacity (N,), smallest (N,), the joint saturating at the smallest (N,)) over the certificates ``Q``
    and, unless ``job.configurations`` is ``"certificates"``, their kept branches (at ``arm_angle`` when given)."""
    from manipkit.statics.capacity import payload_capacity

    if job.configurations == "certificates":
        rows, kept = Q[:, None], np.ones((len(Q), 1), dtype=bool)
    else:
        rows, kept = branch_rows(job.robot, job.base, job.frame, Q, at_arm_angle=at_arm_angle, arm_angle=arm_angle)
    cap = payload_capacity(job.robot, rows[kept], cog=job.cog, gravity=job.gravity, effort=job.effort,
                           base=job.base, tip=job.frame)
    best, worst, joint = np.empty(len(Q)), np.empty(len(Q)), np.empty(len(Q), dtype=np.int64)
    per_bin_kernel()(kept, np.ascontiguousarray(cap.max_mass, dtype=float),
                     np.ascontiguousarray(cap.saturating, dtype=np.int64), best, worst, joint)
    return best, worst, joint


def _check_block(job: PayloadJob, n_joints: int, result, arguments: tuple) -> str | None:
    """payload_block's (block, best, worst, saturating) for the block ``arguments``."""
    if not isinstance(result, tuple) or len(result) != 4 or result[0] != arguments[0]:
        return "not the result of this payload block"
    _, best, cap, sat = result
    n = len(arguments[1])
    if not all(isinstance(c, np.ndarray) and c.dtype == float and c.shape == (n,) and not np.isnan(c).any()
               and bool(np.all(c >= 0)) for c in (best, cap)) or bool(np.any(best < cap)):
        return "its capacities are not (N,) numbers >= 0 kg, the best at least the worst"
    if not (isinstance(sat, np.ndarray) and sat.dtype == np.int64 and sat.shape == (n,)
            and bool(np.all((sat >= -1) & (sat < n_joints)))):
        return "its saturating joints are not joint indices or -1"
    return None


def _vector3(value, name: str, what: str) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        v = np.zeros(0)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise ReachMapError(f"{name} {printable(repr(value))[:60]}: give {what}, 3 finite numbers")
    return v


def _code_digest() -> str:
    from manipkit.analysis.reachmap import payload, payload_kernel
    from manipkit.statics import capacity, gravity_kernel, torques

    digest = hashlib.sha256()
    for module in (payload, payload_kernel, capacity, torques, gravity_kernel):
        digest.update(Path(module.__file__).read_bytes())
    digest.update(Path(__file__).read_bytes())
    return digest.hexdigest()


def _settings(job: PayloadJob, reach_map: ReachMap, block: int) -> dict:
    import manipkit

    certs = hashlib.sha256(reach_map.cert_keys.astype(np.int64).tobytes() + reach_map.cert_q.tobytes()).hexdigest()
    return {"payload_format": PAYLOAD_FORMAT, "manipkit": manipkit.__version__, "code_sha256": _code_digest(),
            "robot": job.robot.name, "description_sha256": hashlib.sha256(job.robot.urdf.encode()).hexdigest(),
            "base": job.base, "frame": job.frame, "cog": job.cog.tolist(), "gravity": job.gravity.tolist(),
            "effort": [[None if math.isnan(v) else v for v in row] for row in job.effort.tolist()],
            "block": block, "certificates_sha256": certs, "configurations": job.configurations,
            "arm_angles": job.arm_angles}


def _root_gravity(robot: Robot, base: str, g_base: np.ndarray) -> np.ndarray:
    """Gravity (m/s^2) in the root link's axes from the map's base frame's (the base's rotation at the defaults)."""
    return robot.transform(robot.root_link, base)[:3, :3] @ g_base


def capacity_of(reach_map: ReachMap, robot: Robot, Q) -> np.ndarray:
    """(N,) kg: the capacity at configurations ``Q`` (N, n) for the map's payload layer (its CoG, gravity, limits).

    Raises :class:`ReachMapError` when the map has no payload layer or ``robot`` is not the map's.
    """
    from manipkit.statics.capacity import payload_capacity

    layer = reach_map.payload
    if layer is None:
        raise ReachMapError("the map has no payload layer: add one with payload_map(map, robot, cog=...)")
    if robot.name != reach_map.robot or tuple(robot.joint_names) != tuple(reach_map.joint_names):
        raise ReachMapError(f"the map is of '{printable(reach_map.robot)}'; the robot given is "
                            f"'{printable(robot.name)}': give the map's robot")
    cap = payload_capacity(robot, Q, cog=layer.cog, gravity=_root_gravity(robot, reach_map.base, layer.gravity),
                           effort=np.stack([layer.lower, layer.upper]), base=reach_map.base, tip=reach_map.frame)
    return np.asarray(cap.max_mass, dtype=float)


def payload_map(reach_map: ReachMap, robot: Robot, *, cog=(0.0, 0.0, 0.0), gravity=(0.0, 0.0, -9.81), effort=None,
                branches: bool = True, arm_angles: int = ARM_ANGLES, workers: int | None = None,
                scheduler: str | None = None, progress=None, block: int = PAYLOAD_BLOCK,
                resume_dir: str | Path | None = None) -> ReachMap:
    """The map with its payload layer (``reach_map.payload``, :class:`~manipkit.analysis.reachmap.payload.PayloadLayer`).

    A function of a built map rather than an option of
    :func:`~manipkit.analysis.reachmap.builder.build`: a saved map gets a
    layer without being rebuilt, one map serves several CoGs and limits, and a
    map's build (and the fingerprint its resumed blocks are kept under) does
    not depend on a payload.

    Parameters
    ----------
    reach_map : ReachMap
        A map of ``robot`` (its name and joints must match).
    robot : Robot
        The robot the map is of: its masses, CoGs and effort limits are used.
    cog : (3,) float
        The payload's centre of gravity from the tip's origin, in the tip frame's axes (m).
    gravity : (3,) float
        m/s^2 in the map's base frame (``reach_map.base``; turned into the
        root link's axes with the base's rotation at the robot's default configuration).
    effort : None, (n,) or ((n,), (n,))
        The chain joints' limits as :func:`manipkit.statics.capacity.payload_capacity` takes them (default the URDF's).
    branches : bool
        True: for a chain with a closed-form family (:func:`configurations_of`) weigh every branch of each bin's
        pose inside the joint limits, with the stored configuration (a 7R SRS arm: every branch at the stored
        configuration's arm angle and at ``arm_angles`` arm angles over its self-motion); False, or a chain without
        one: the stored configuration alone. The layer's ``configurations`` (and ``arm_angles``) say which was done.
    arm_angles : int
        A 7R SRS arm's self-motion: the arm angles sampled besides each stored configuration's own,
        ``-pi + 2 pi j / arm_angles`` (a resolution of ``2 pi / arm_angles`` rad; default 8, 45 deg), each
        branch weighed where it lies inside the limits there; 0 weighs the stored configuration's arm angle alone.
        Each sample costs about one more solve and capacity of the block. Ignored by other chains.
    workers, scheduler, progress
        As :func:`~manipkit.analysis.reachmap.builder.build` (``progress(stage, done, total)`` in blocks).
    block : int
        Configurations per block.
    resume_dir : path, optional
        Keep finished blocks there; an interrupted build run again with the same arguments reads them back.

    Returns
    -------
    ReachMap
        ``dataclasses.replace(reach_map, payload=layer)`` (saved with the map: :meth:`ReachMap.save`).

    Raises
    ------
    ReachMapError
        A map of another robot, a CoG or gravity that is not 3 finite numbers, a block size outside 1..MAX_PAYLOAD_BLOCK.
    OptionError
        No chain joint has an effort limit, or ``effort`` of the wrong shape (checked before any block runs).

    Examples
    --------
    >>> import manipkit
    >>> from manipkit.analysis.reachmap import build
    >>> robot = manipkit.load("planar_2r")
    >>> m = payload_map(build(robot, voxel=0.25, orientations=4, samples=5000), robot, gravity=(0, -9.81, 0),
    ...                 effort=[40.0, 20.0])
    >>> layer = m.payload
    >>> bool(np.nanmax(layer.best) >= np.nanmax(layer.worst)), layer.joints
    (True, ('joint1', 'joint2'))
    """
    # Over 80 lines: the docstring is most of it; the rest is the checks, the blocks and the merge in order.
    from manipkit.analysis.reachmap.blocks import BlockRunner, check_workers, in_block_order
    from manipkit.statics.capacity import payload_capacity

    if robot.name != reach_map.robot or tuple(robot.joint_names) != tuple(reach_map.joint_names):
        raise ReachMapError(f"the map is of '{printable(reach_map.robot)}' ({len(reach_map.joint_names)} joints); "
                            f"the robot given is '{printable(robot.name)}': give the map's robot")
    cog = _vector3(cog, "cog", "the payload's centre of gravity in the tip frame's axes (m)")
    g_base = _vector3(gravity, "gravity", "gravity in the map's base frame (m/s^2)")
    if isinstance(block, bool) or not isinstance(block, numbers.Integral) or not 1 <= block <= MAX_PAYLOAD_BLOCK:
        raise ReachMapError(f"block {printable(repr(block))[:40]}: give a whole number from 1 to {MAX_PAYLOAD_BLOCK}")
    if isinstance(arm_angles, bool) or not isinstance(arm_angles, numbers.Integral) or \
            not 0 <= arm_angles <= MAX_ARM_ANGLES:
        raise ReachMapError(f"arm_angles {printable(repr(arm_angles))[:40]}: give a whole number of arm angles from 0 "
                            f"to {MAX_ARM_ANGLES}")
    check_workers(workers)
    g_root = _root_gravity(robot, reach_map.base, g_base)
    probe = payload_capacity(robot, robot.q(), cog=cog, gravity=g_root, effort=effort, base=reach_map.base,
                             tip=reach_map.frame)  # the limits, and every option checked before a block runs
    configurations = configurations_of(robot, reach_map.base, reach_map.frame, int(arm_angles)) if branches \
        else "certificates"
    sampled = int(arm_angles) if configurations == "self_motion" else 0
    job = PayloadJob(robot, reach_map.base, reach_map.frame, cog, g_root, np.stack([probe.lower, probe.upper]),
                     configurations, sampled)
    n = len(probe.joint_names)
    store = None
    if resume_dir is not None:
        from manipkit.analysis.reachmap.blockstore import open_store

        store = open_store(resume_dir, _settings(job, reach_map, int(block)),
                           {"payload_block": partial(_check_block, job, n)})
    Q = reach_map.cert_q
    blocks = [(b, Q[s:s + block]) for b, s in enumerate(range(0, len(Q), block))]
    tops, caps, sats = [np.zeros(0)], [np.zeros(0)], [np.zeros(0, dtype=np.int64)]
    with BlockRunner(workers, scheduler, progress, store) as runner:
        if blocks:
            for _, top, cap, sat in in_block_order(runner.run(payload_block, job, blocks, "payload capacity")):
                tops.append(top)
                caps.append(cap)
                sats.append(sat)
    top, cap, sat = np.concatenate(tops), np.concatenate(caps), np.concatenate(sats)
    best, worst, worst_joint = per_voxel(reach_map.cert_keys, top, sat, reach_map.orientations.size,
                                         math.prod(reach_map.shape), worst_capacity=cap)
    layer = PayloadLayer(best.reshape(reach_map.shape), worst.reshape(reach_map.shape),
                         worst_joint.reshape(reach_map.shape), top, cog, g_base, tuple(probe.joint_names),
                         probe.lower, probe.upper, probe.inertia_grade, bins_worst=cap, configurations=configurations,
                         arm_angles=sampled)
    return replace(reach_map, payload=layer)
