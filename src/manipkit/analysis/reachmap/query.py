"""What a reachability map answers for a pose, and the exact answer by IK from the bin's certificate.

(docs/site/internals/reach-maps.md.) A map is certain at its
resolution: whether the **voxel** holding the position and the **orientation
bin** holding the rotation were reached (``bin_reached``; a configuration
whose FK lands in that voxel-bin is stored). The bin is the approach-axis
direction plus the roll about it, or the direction alone with **any roll**
when the map was built with one roll; a planar map's bin is a turn about its
axis.

A voxel-bin counts as reached when any part of it is, so near the edge of
the reach a pose in a reached voxel-bin is often not reachable. The map's
yes (:meth:`ReachMap.query`, ``reachable`` here) therefore also asks for
**support** around the position: the ``score`` (0..1) is the trilinear blend
of the reached flags of the same orientation bin at the 8 voxel centres
around the position (bilinear over 4 for a planar map, whose grid is one
layer; centres outside the grid count as unreached), so it is 1 deep inside
the reached set, 0 far from it, and falls across its edge. A yes means
``bin_reached and score >= threshold`` (default :data:`DEFAULT_THRESHOLD`);
``threshold=0`` or ``interpolate=False`` is the plain voxel-bin answer.
:func:`query_answer` says which bins, per pose, and with
``confirm=True`` runs IK for the **exact** pose (mode ``"pose"``) from the
certificate of the pose's voxel-bin (a configuration whose FK lands in it),
then random restarts; ``confirmed`` is True only where FK of the answer
reaches the pose within ``tol`` (and it is collision-free when collisions are
given). IK failing does not prove a pose unreachable.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.reachmap.constants import (
    DEFAULT_THRESHOLD,
    HOW_NONE,
    PLANAR_TILT_TOL,
    check_threshold,
    finite_array,
)
from manipkit.errors import ReachMapError
from manipkit.text import printable, short_text

if TYPE_CHECKING:
    from manipkit.analysis.reachmap.map import ReachMap
    from manipkit.kinematics.collisions import CollisionSettings
    from manipkit.kinematics.robot import Robot

__all__ = [
    "QueryAnswer", "bin_text", "checks_lines", "corner_keys", "first_confirmed", "in_plane", "map_robot",
    "query_answer", "refined_answer", "resolution_text", "support_score",
]



@dataclass(frozen=True, eq=False)
class QueryAnswer:
    """A map's answer for poses ``T`` (...,), and (``confirm=True``) IK's answer for the exact poses.

    Attributes
    ----------
    reachable : ndarray of bool, shape (...)
        The map's answer: ``bin_reached`` and ``score >= threshold``.
    bin_reached : ndarray of bool, shape (...)
        The certified answer: the voxel-bin holding the pose was reached.
    score : ndarray of float, shape (...)
        The support around the position in the pose's orientation bin, 0..1 (:func:`support_score`).
    threshold : float
        The least ``score`` a yes needed (0: the plain voxel-bin answer).
    voxel : ndarray of int, shape (..., 3)
        Grid index of the voxel holding the position (0 outside the grid).
    inside : ndarray of bool, shape (...)
        The position is inside the grid (and, planar, in the arm's plane).
    direction : ndarray of int, shape (...)
        Approach-direction index (spatial) or turn index (planar).
    roll : ndarray of int, shape (...), or None
        Roll bin about the approach axis; None when the map holds any roll.
    resolution : str
        What the map's answer is about, in words (:func:`resolution_text`).
    certificate : ndarray, shape (..., n)
        The stored configuration of the voxel-bin (NaN where it was not reached).
    confirmed : ndarray of bool, shape (...), or None
        ``confirm=True``: IK reached the exact pose (FK residuals within ``tol``).
    q : ndarray, shape (..., n), or None
        ``confirm=True``: IK's answers (meaningful where ``confirmed``).
    """

    reachable: np.ndarray
    bin_reached: np.ndarray
    score: np.ndarray
    threshold: float
    voxel: np.ndarray
    inside: np.ndarray
    direction: np.ndarray
    roll: np.ndarray | None
    resolution: str
    certificate: np.ndarray
    confirmed: np.ndarray | None = None
    q: np.ndarray | None = None


def bin_text(reach_map: ReachMap) -> str:
    """The voxel-bin a pose falls in, in words (voxel edge, orientation bins, roll or any roll)."""
    o = reach_map.orientations
    voxel = f"the position's {short_text(reach_map.voxel)} m voxel"
    if o.kind == "planar":
        return f"{voxel} and the tool's turn about the arm's axis to {short_text(360.0 / o.n_rolls, 4)} deg bins"
    cap = math.degrees(math.acos(max(-1.0, 1.0 - 2.0 / o.n_directions)))  # a cap of 4 pi / n steradians
    direction = f"its approach axis (z) to one of {o.n_directions} directions (about {short_text(cap, 3)} deg each)"
    if o.n_rolls == 1:
        return f"{voxel} and {direction}, any roll about it"
    return f"{voxel}, {direction} and the roll about it to {short_text(360.0 / o.n_rolls, 4)} deg bins"


def resolution_text(reach_map: ReachMap, *, threshold: float = DEFAULT_THRESHOLD) -> str:
    """What a yes of the map means, in words: the voxel-bin reached and, for ``threshold > 0``, the support asked for."""
    reached = f"the pose's voxel-bin was reached ({bin_text(reach_map)})"
    if check_threshold(threshold) == 0.0:
        return reached
    corners = "4 voxel centres around the position, blended bilinearly" if reach_map.orientations.kind == "planar" \
        else "8 voxel centres around the position, blended trilinearly"
    return (f"{reached} and its support is at least {short_text(threshold, 3)} (the reached flags of the same "
            f"orientation bin at the {corners} by distance); query(T, interpolate=False) answers for the voxel-bin alone")


def corner_keys(reach_map: ReachMap, xyz, bins) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The voxel-bins around each position ``xyz`` (..., 3, in ``base``, m) in its orientation bin ``bins`` (...,).

    Returns ``(keys, weights, inside)``, each (..., 8) (4 used on a planar
    map's one layer, the other 4 of weight 0): the flat voxel-bin index (into
    ``reach.reshape(-1)``) of each of the 8 voxel centres around the point,
    its trilinear weight (they sum to 1), and whether that centre is in the
    grid (a planar map's point must also lie within half a voxel of the plane).
    """
    shape = reach_map.shape
    local = (np.asarray(xyz, dtype=float) - reach_map.origin) @ reach_map.axes / reach_map.voxel
    local = np.clip(local, -2.0, np.array(shape) + 1.0)  # a point farther out has every corner outside already
    strides = (shape[1] * shape[2] * reach_map.orientations.size, shape[2] * reach_map.orientations.size,
               reach_map.orientations.size)
    # per axis, the two layers around the point (one on a planar map's single layer): flat offset, weight, inside
    layers = []
    for axis, n in enumerate(shape):
        u = local[..., axis]
        if n == 1:  # a planar map's one layer: no neighbours across the plane
            layers.append([(np.zeros(u.shape, dtype=np.int64), np.ones_like(u), np.rint(u) == 0),
                           (np.zeros(u.shape, dtype=np.int64), np.zeros_like(u), np.zeros(u.shape, dtype=bool))])
            continue
        low = np.floor(u)
        frac = u - low
        layers.append([(np.clip(low + step, 0, n - 1).astype(np.int64) * strides[axis], weight,
                        (low + step >= 0) & (low + step < n)) for step, weight in ((0, 1.0 - frac), (1, frac))])
    keys, weights, inside = [], [], []
    for (ox, wx, ix), (oy, wy, iy), (oz, wz, iz) in itertools.product(*layers):
        keys.append(ox + oy + oz + bins)
        weights.append(wx * wy * wz)
        inside.append(ix & iy & iz)
    return np.stack(keys, axis=-1), np.stack(weights, axis=-1), np.stack(inside, axis=-1)


def support_score(reach_map: ReachMap, xyz, bins) -> np.ndarray:
    """(...,) support of each position ``xyz`` (..., 3, in ``base``, m) in its orientation bin ``bins`` (...,), 0..1.

    The trilinear blend of the reached flags (1 reached, 0 not) at the 8
    voxel centres around the position in bin ``bins`` (bilinear over 4 on a
    planar map's one layer, where a point must lie within half a voxel of
    the plane); centres outside the grid count as 0 (:func:`corner_keys`). At
    a voxel centre it is that voxel-bin's flag; it is 1 where all 8 are
    reached, 0 where none is.
    """
    keys, weights, inside = corner_keys(reach_map, xyz, np.asarray(bins))
    reached = inside & (reach_map.reach.reshape(-1)[keys] > HOW_NONE)
    return np.clip(np.where(reached, weights, 0.0).sum(axis=-1), 0.0, 1.0)


def refined_answer(reach_map: ReachMap, T: np.ndarray, value: np.ndarray, bins: np.ndarray, robot: Robot, *,
                   tol: float = 1e-9, restarts: int = 4, seed: int = 0) -> np.ndarray:
    """The map's answer ``value`` (...,) for poses ``T`` (..., 4, 4), decided by IK in the boundary band.

    **Refine near the boundary**: a pose whose support (:func:`support_score`)
    is strictly between 0 and 1 lies where reached and unreached voxel-bins
    of its orientation bin meet, which is where a blended answer says yes to
    poses no configuration reaches and no to poses one does. There the
    answer is IK of the exact pose in the mode the map was built in (the
    settings' ``ik_mode``: ``position+axis`` for a map of any roll), started
    from the certificate (a stored configuration whose FK lands in the
    voxel-bin) of each reached voxel-bin around it, ``restarts`` random
    restarts after each; yes only where FK of an answer within the limits
    reaches the pose to ``tol`` (m and rad). Elsewhere (support 0 or 1)
    ``value`` stands. A yes in the band is thus proved; a no in it is IK
    failing from up to 8 nearby starts, which does not prove a pose unreachable.
    The IK answers are not checked for collisions: on a map built collision-free
    a refined yes in the band means reachable, not reachable collision-free.
    """
    from manipkit.ik.numerical_many import ik_many

    if reach_map.cert_keys is None or not reach_map.cert_keys.size:
        return value
    keys, _, inside = corner_keys(reach_map, T[..., :3, 3], bins)
    reached = inside & (reach_map.reach.reshape(-1)[keys] > HOW_NONE)
    score = support_score(reach_map, T[..., :3, 3], bins)
    band = (score > 0.0) & (score < 1.0) & reached.any(axis=-1)
    if reach_map.orientations.kind == "planar":  # a tool tilted out of the plane is never reached
        band &= in_plane(reach_map, T)
    if not band.any():
        return value
    pose, corner = np.nonzero(reached.reshape(-1, keys.shape[-1]) & band.reshape(-1, 1))
    flat_keys = keys.reshape(-1, keys.shape[-1])[pose, corner]
    rows = np.clip(np.searchsorted(reach_map.cert_keys, flat_keys), 0, reach_map.cert_keys.size - 1)
    has = reach_map.cert_keys[rows] == flat_keys
    pose, rows = pose[has], rows[has]
    batch = ik_many(robot, T.reshape(-1, 4, 4)[pose], base=reach_map.base, tip=reach_map.frame,
                    q0=reach_map.cert_q[rows], mode=reach_map.settings.get("ik_mode", "pose"), tol=tol,
                    restarts=restarts, seed=seed)
    proved = np.zeros(band.size, dtype=bool)
    np.logical_or.at(proved, pose, np.asarray(batch.success, dtype=bool))
    return np.where(band, proved.reshape(band.shape), value)


def in_plane(reach_map: ReachMap, T: np.ndarray) -> np.ndarray:
    """(...,) bool: a planar map's poses ``T`` keep the tool's axis along the arm's axis (to :data:`PLANAR_TILT_TOL`,
    or half a bin if less)."""
    o = reach_map.orientations
    cos_tilt = (T[..., :3, :3] @ o.tool_axis) @ o.axis
    return cos_tilt >= math.cos(min(math.pi / o.size, PLANAR_TILT_TOL))


def query_answer(reach_map: ReachMap, T, *, interpolate: bool = True, threshold: float = DEFAULT_THRESHOLD,
                 confirm: bool = False, robot: Robot | None = None, tol: float = 1e-6, restarts: int = 20,
                 seed: int = 0, collisions: CollisionSettings | None = None, mode: str = "pose",
                 axis: str = "z", refine: bool | None = None) -> QueryAnswer:
    """The map's answer for poses ``T`` (..., 4, 4) ``T_base_frame`` and, with ``confirm``, IK's for the exact poses.

    ``reachable`` is ``bin_reached and score >= threshold`` (the module
    docstring); ``interpolate=False`` makes it ``bin_reached`` (threshold 0).
    ``robot``: the robot the map is of (default: loaded by the map's robot
    name, which works for bundled and example-robot-data robots). ``tol``:
    position (m) and rotation (rad) residual of a confirmed answer. ``mode``
    and ``axis``: what IK must match (:func:`manipkit.ik`: ``"pose"``, the
    full pose; ``"position+axis"``, the origin and the direction of the tip's
    ``axis``, what an arm of fewer than 6 joints can match). IK is the one
    dispatcher's :func:`manipkit.ik.dispatch.ik_many` (the closed form where
    the chain has one for ``mode``, every branch; numerical IK seeded from the
    certificate otherwise); a target is confirmed by the first answer within
    ``tol`` (and collision-free when ``collisions`` are given).
    ``refine`` (default: when ``robot`` is given): ``reachable`` decided by IK
    in the boundary band (:func:`refined_answer`).
    """
    threshold = check_threshold(threshold) if interpolate else 0.0
    T = finite_array(T, "T", (4, 4), "poses (..., 4, 4) T_base_frame")
    bin_reached = np.asarray(reach_map.query(T, interpolate=False))
    ijk, inside = reach_map.voxel_of(T[..., :3, 3])
    bins = np.asarray(reach_map.orientations.bin_of(T[..., :3, :3]))
    score = support_score(reach_map, T[..., :3, 3], bins)
    reachable = bin_reached & (score >= threshold)
    if robot is not None if refine is None else refine:
        robot = map_robot(reach_map, robot)
        reachable = refined_answer(reach_map, T, reachable, bins, robot)
    o = reach_map.orientations
    direction, roll = (bins, None) if o.kind == "planar" or o.n_rolls == 1 else np.divmod(bins, o.n_rolls)
    n = len(reach_map.joint_names)
    keys = np.ravel_multi_index(tuple(np.moveaxis(ijk, -1, 0)), reach_map.shape) * o.size + bins
    certificate = np.full(T.shape[:-2] + (n,), np.nan)
    if reach_map.cert_keys is not None and reach_map.cert_keys.size:
        rows = np.clip(np.searchsorted(reach_map.cert_keys, keys), 0, reach_map.cert_keys.size - 1)
        found = bin_reached & (reach_map.cert_keys[rows] == keys) & (reach_map.reach.reshape(-1)[keys] > HOW_NONE)
        certificate[found] = reach_map.cert_q[rows[found]]
    answer = dict(reachable=reachable, bin_reached=bin_reached, score=score, threshold=threshold, voxel=ijk,
                  inside=inside, direction=direction, roll=roll,
                  resolution=resolution_text(reach_map, threshold=threshold), certificate=certificate)
    if not confirm:
        return QueryAnswer(**answer)
    robot = map_robot(reach_map, robot)
    from manipkit.ik.dispatch import ik_many

    flat_T, flat_seed = T.reshape(-1, 4, 4), certificate.reshape(-1, n)
    q0 = np.where(np.isnan(flat_seed), robot.q(), flat_seed)
    batch = ik_many(robot, flat_T, base=reach_map.base, tip=reach_map.frame, q0=q0, mode=mode, axis=axis, tol=tol,
                    restarts=restarts, seed=seed)
    confirmed, q = first_confirmed(batch, tol, robot, collisions)
    return QueryAnswer(**answer, confirmed=confirmed.reshape(T.shape[:-2]), q=q.reshape(T.shape[:-2] + (-1,)))


def first_confirmed(batch, tol: float, robot: Robot, collisions: CollisionSettings | None = None):
    """(confirmed (N,), q (N, n)) of an :class:`manipkit.ik.result.IKBatch` of N targets: per target the first slot
    whose FK residuals are within ``tol`` (m, rad) and, with ``collisions``, collision-free; ``q`` is that slot (else
    the batch's closest configuration ``batch.q``, NaN for a closed form)."""
    solutions = np.asarray(batch.solutions)
    ok = (np.asarray(batch.residual_position) <= tol) & (np.asarray(batch.residual_rotation) <= tol)
    if collisions is not None and ok.any():
        ok[ok] = collisions.free(robot, solutions[ok])
    confirmed = ok.any(axis=-1)
    q = np.array(batch.q, dtype=float)
    first = np.argmax(ok, axis=-1)
    q[confirmed] = solutions[confirmed, first[confirmed]]
    return confirmed, q


def map_robot(reach_map: ReachMap, robot: Robot | None) -> Robot:
    """``robot``, or the robot the map is of loaded by its name (bundled and example-robot-data robots), else a
    :class:`ReachMapError` asking for ``robot=``."""
    if robot is not None:
        return robot
    import manipkit

    try:
        return manipkit.load(reach_map.robot)
    except Exception as exc:  # noqa: BLE001 - said as one line: the caller gives the robot
        raise ReachMapError(f"IK of the exact pose needs the robot the map is of ('{printable(reach_map.robot)}' did "
                            f"not load: {printable(str(exc))[:120]}); pass robot=") from None


def checks_lines(reach_map: ReachMap) -> list[str]:
    """Lines: how the sampling ended, the held-out completeness and the false-positive bound (when built)."""
    s, lines = reach_map.settings, []
    if "samples_used" in s:
        converge = s.get("converge", 0.0)
        stopping = "converge 0: every sample of the budget drawn" if not converge else (
            f"it stops after a block that adds fewer than {short_text(converge)} x the voxel-bins reached before it")
        lines.append(f"sampling {'converged' if s.get('converged') else 'used its whole budget'}: "
                     f"{s['samples_used']} samples in {s['blocks']} blocks ({stopping}); IK fill passes: "
                     f"{s.get('fill_passes', 0)}")
    t = s.get("checked_threshold")  # maps built before the support rule measured the voxel-bins alone
    c = s.get("completeness")
    if isinstance(c, dict) and c.get("n"):
        measured = "lands in reached voxel-bins" if t is None else f"the map says yes to (support >= {short_text(t)})"
        lines.append(f"completeness: of a held-out sample of {c['n']} reachable poses (FK of joint samples the "
                     f"build never drew), {measured} {short_text(100 * c['rate'], 4)} % (95 % interval "
                     f"{short_text(100 * c['low'], 4)}-{short_text(100 * c['high'], 4)} %)")
    f = s.get("false_positive")
    if isinstance(f, dict) and f.get("n"):
        if t is None or "drawn" not in f:
            said = f"IK ({printable(str(f['mode']))}) failed on {f['failed']} of {f['n']} poses drawn inside reached voxel-bins"
        else:
            said = (f"of {f['drawn']} poses drawn one in each of {f['drawn']} random reached voxel-bins (every bin "
                    f"weighted alike, those at the boundary as much as those inside) the map says yes to {f['n']}, "
                    f"and IK ({printable(str(f['mode']))}) failed on {f['failed']} of those")
        lines.append(f"false positives: {said}: at most {short_text(100 * f['high'], 3)} % (95 % bound; an IK "
                     "failure need not be unreachable)")
    lines.append(f"a yes means: {resolution_text(reach_map)}")
    return lines
