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
That is the map's **unrefined estimate**. The **default** answer refines it:
the poses of support strictly between 0 and 1 (:func:`boundary_band`) are
decided by IK of the exact pose (:func:`refined_answer`) with the robot
given, else the map's robot loaded by its name (:func:`refine_robot`,
:func:`robot_by_name`); :func:`answer_text` says which answer it is.
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
import weakref
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
    "CERTIFICATES_CHECKED", "QueryAnswer", "UnrefinedWarning", "answer_text", "bin_text", "boundary_band",
    "certificates_landing", "checks_lines", "corner_keys", "first_confirmed", "in_plane", "map_robot", "measured_error", "query_answer", "refine_robot", "refined_answer",
    "resolution_text", "robot_by_name", "support_score", "unrefined_text",
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
    decided_by_ik : ndarray of bool, shape (...), or None
        The poses whose ``reachable`` IK decided (the boundary band, :func:`refined_answer`); None when the answer
        is the map's unrefined estimate.
    unrefined_because : str
        Why the answer is the map's unrefined estimate ("" when refined).
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
    decided_by_ik: np.ndarray | None = None
    unrefined_because: str = ""


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


def boundary_band(reach_map: ReachMap, T: np.ndarray, bins: np.ndarray):
    """(band, keys, reached) of poses ``T`` (..., 4, 4) in orientation bins ``bins`` (...,): ``band`` (...,) the poses
    of support strictly between 0 and 1 with a reached voxel-bin around them (a planar map's also in the plane), the
    ones :func:`refined_answer` decides by IK; ``keys`` and ``reached`` (..., 8) the corner voxel-bins
    (:func:`corner_keys`) and which of them were reached."""
    keys, _, inside = corner_keys(reach_map, T[..., :3, 3], bins)
    reached = inside & (reach_map.reach.reshape(-1)[keys] > HOW_NONE)
    score = support_score(reach_map, T[..., :3, 3], bins)
    band = (score > 0.0) & (score < 1.0) & reached.any(axis=-1)
    if reach_map.orientations.kind == "planar":  # a tool tilted out of the plane is never reached
        band &= in_plane(reach_map, T)
    return band, keys, reached


def refined_answer(reach_map: ReachMap, T: np.ndarray, value: np.ndarray, bins: np.ndarray, robot: Robot, *,
                   tol: float = 1e-9, restarts: int = 4, seed: int = 0) -> np.ndarray:
    """The map's answer ``value`` (...,) for poses ``T`` (..., 4, 4), decided by IK in the boundary band.

    **Refine near the boundary**: a pose whose support (:func:`support_score`)
    is strictly between 0 and 1 lies where reached and unreached voxel-bins
    of its orientation bin meet, which is where a blended answer says yes to
    poses no configuration reaches and no to poses one does
    (:func:`boundary_band`). There the answer is IK of the exact pose in the
    mode the map was built in (the settings' ``ik_mode``: ``position+axis``
    for a map of any roll) by the one dispatcher's batch
    (:func:`manipkit.ik.dispatch.ik_many`, method ``"auto"``): the closed
    form where the chain has one for that mode (every branch; a UR arm's map
    of rolls, mode ``pose``), else numerical IK started from the certificate
    (a stored configuration whose FK lands in the voxel-bin) of each reached
    voxel-bin around it, ``restarts`` random restarts after each. Yes only
    where FK of an answer inside the joint limits reaches the pose to ``tol``
    (m and rad). Elsewhere (support 0 or 1) ``value`` stands. A yes in the
    band is thus proved; a no in it is the closed form finding no in-limit
    branch, or numerical IK failing from up to 8 nearby starts, which does
    not prove a pose unreachable.
    The IK answers are not checked for collisions: on a map built collision-free
    a refined yes in the band means reachable, not reachable collision-free.
    """
    from manipkit.ik.dispatch import ik_many

    if reach_map.cert_keys is None or not reach_map.cert_keys.size:
        return value
    band, keys, reached = boundary_band(reach_map, T, bins)
    if not band.any():
        return value
    pose, corner = np.nonzero(reached.reshape(-1, keys.shape[-1]) & band.reshape(-1, 1))
    flat_keys = keys.reshape(-1, keys.shape[-1])[pose, corner]
    rows = np.clip(np.searchsorted(reach_map.cert_keys, flat_keys), 0, reach_map.cert_keys.size - 1)
    has = reach_map.cert_keys[rows] == flat_keys
    pose, rows = pose[has], rows[has]
    batch = ik_many(robot, T.reshape(-1, 4, 4)[pose], base=reach_map.base, tip=reach_map.frame, method="auto",
                    q0=reach_map.cert_q[rows], mode=reach_map.settings.get("ik_mode", "pose"), tol=tol,
                    restarts=restarts, seed=seed)
    solutions = np.asarray(batch.solutions)
    ok = (np.asarray(batch.residual_position) <= tol) & (np.asarray(batch.residual_rotation) <= tol)
    if ok.any():  # a closed form's branches are every solution, in limits or not
        ok[ok] = robot.chain(reach_map.base, reach_map.frame).within_limits(solutions[ok])
    proved = np.zeros(band.size, dtype=bool)
    np.logical_or.at(proved, pose, ok.any(axis=-1))
    return np.where(band, proved.reshape(band.shape), value)


def in_plane(reach_map: ReachMap, T: np.ndarray) -> np.ndarray:
    """(...,) bool: a planar map's poses ``T`` keep the tool's axis along the arm's axis (to :data:`PLANAR_TILT_TOL`,
    or half a bin if less)."""
    o = reach_map.orientations
    cos_tilt = (T[..., :3, :3] @ o.tool_axis) @ o.axis
    return cos_tilt >= math.cos(min(math.pi / o.size, PLANAR_TILT_TOL))


def query_answer(reach_map: ReachMap, T, *, interpolate: bool = True, threshold: float | None = None,
                 confirm: bool = False, robot: Robot | None = None, tol: float = 1e-6, restarts: int = 20,
                 seed: int = 0, collisions: CollisionSettings | None = None, mode: str = "pose",
                 axis: str = "z", refine: bool | None = None) -> QueryAnswer:
    """The map's answer for poses ``T`` (..., 4, 4) ``T_base_frame`` and, with ``confirm``, IK's for the exact poses.

    ``reachable`` is ``bin_reached and score >= threshold`` (the module
    docstring; ``threshold`` default :data:`DEFAULT_THRESHOLD`), decided by
    IK in the boundary band when refined (``refine``, :func:`refine_robot`:
    by default whenever the robot is given or the map's robot loads by its
    name and neither ``interpolate=False`` nor a ``threshold`` is given);
    ``interpolate=False`` makes it ``bin_reached`` (threshold 0).
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
    ``decided_by_ik`` says which poses IK decided, ``unrefined_because`` why
    none did (:func:`answer_text` says it in words).
    """
    asked_rule = not interpolate or threshold is not None
    threshold = (DEFAULT_THRESHOLD if threshold is None else check_threshold(threshold)) if interpolate else 0.0
    T = finite_array(T, "T", (4, 4), "poses (..., 4, 4) T_base_frame")
    bin_reached = np.asarray(reach_map.query(T, interpolate=False))
    ijk, inside = reach_map.voxel_of(T[..., :3, 3])
    bins = np.asarray(reach_map.orientations.bin_of(T[..., :3, :3]))
    score = support_score(reach_map, T[..., :3, 3], bins)
    reachable = bin_reached & (score >= threshold)
    refiner, because = refine_robot(reach_map, robot, refine, asked_rule=asked_rule)
    decided = None
    if refiner is not None:
        reachable = refined_answer(reach_map, T, reachable, bins, refiner)
        decided = boundary_band(reach_map, T, bins)[0] if reach_map.cert_keys is not None and \
            reach_map.cert_keys.size else np.zeros(reachable.shape, dtype=bool)
        robot = refiner
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
                  resolution=resolution_text(reach_map, threshold=threshold), certificate=certificate,
                  decided_by_ik=decided, unrefined_because=because)
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


class UnrefinedWarning(UserWarning):
    """A map's default answer is its unrefined estimate: the map's robot did not load by the name it stores."""


#: The robots loaded by the names maps store, (robot or None, why not) per name; and per map object, the answer of
#: :func:`robot_by_name` (its chain and certificates checked), kept while the map lives.
_LOADED: dict[str, tuple[Robot | None, str]] = {}
_CHECKED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def robot_by_name(reach_map: ReachMap) -> tuple[Robot | None, str]:
    """(the map's robot, "") loaded by the name the map stores, or (None, why not); loaded once per name, checked
    once per map.

    Only a bundled or example-robot-data name loads: a map is a file from
    anywhere, and a file path it names is never read (pass ``robot=``). The
    robot must have the map's chain: ``base`` to ``frame`` with the map's
    joint names, in order, and put the map's certificates back in their
    voxel-bins (FK of up to :data:`CERTIFICATES_CHECKED` of them, spread over
    the map; at least 95 %, a bin edge aside): another robot of the same name
    would not.
    """
    if reach_map in _CHECKED:
        return _CHECKED[reach_map]
    import manipkit
    from manipkit.description.sources import resolve_robot
    from manipkit.errors import ManipkitError

    name = printable(reach_map.robot)
    try:
        if reach_map.robot not in _LOADED:
            try:
                if resolve_robot(reach_map.robot).origin == "file":
                    raise ReachMapError("the name is a file path, which a map is never trusted to name")
                _LOADED[reach_map.robot] = (manipkit.load(reach_map.robot), "")
            except ManipkitError as exc:
                _LOADED[reach_map.robot] = (None, printable(str(exc))[:200])
        robot, because = _LOADED[reach_map.robot]
        if robot is None:
            raise ReachMapError(because)
        names = tuple(robot.chain(reach_map.base, reach_map.frame).joint_names)
        if names != tuple(reach_map.joint_names):
            raise ReachMapError(f"its chain's joints {names} are not the map's {tuple(reach_map.joint_names)}")
        landed = certificates_landing(reach_map, robot)
        if landed < 0.95:
            raise ReachMapError(f"FK of the robot of that name puts {100 * landed:.0f} % of the map's checked "
                                "certificates in their voxel-bins: not the robot the map was built of")
        answer = (robot, "")
    except ManipkitError as exc:
        answer = (None, f"the map's robot '{name}' did not load by its name ({printable(str(exc))[:200]})")
    _CHECKED[reach_map] = answer
    return answer


#: How many of a map's certificates :func:`robot_by_name` checks by FK against the robot it loads.
CERTIFICATES_CHECKED = 100


def certificates_landing(reach_map: ReachMap, robot: Robot) -> float:
    """The share of up to :data:`CERTIFICATES_CHECKED` of the map's certificates (evenly spread over ``cert_keys``)
    whose FK by ``robot`` (``base`` to ``frame``) lands in the voxel-bin it certifies (1.0 for a map without any)."""
    if reach_map.cert_keys is None or not reach_map.cert_keys.size:
        return 1.0
    rows = np.unique(np.linspace(0, reach_map.cert_keys.size - 1, CERTIFICATES_CHECKED).astype(np.int64))
    T = robot.fk(reach_map.cert_q[rows], base=reach_map.base, tip=reach_map.frame)
    ijk, inside = reach_map.voxel_of(T[:, :3, 3])
    keys = np.ravel_multi_index(tuple(ijk.T), reach_map.shape) * reach_map.orientations.size \
        + np.asarray(reach_map.orientations.bin_of(T[:, :3, :3]))
    return float(np.mean(inside & (keys == reach_map.cert_keys[rows])))


def refine_robot(reach_map: ReachMap, robot: Robot | None, refine: bool | None, *,
                 asked_rule: bool = False) -> tuple[Robot | None, str]:
    """(the robot whose IK decides the boundary band, "") or (None, why the answer is the map's unrefined estimate).

    ``refine=False``: none. ``refine=True``: ``robot``, else the map's robot
    (:func:`map_robot`, a :class:`ReachMapError` when it does not load).
    ``refine=None`` (the default): none when the map's own rule was asked for
    (``asked_rule``: ``interpolate=False`` or a ``threshold``); else ``robot``,
    else the map's robot by its name (:func:`robot_by_name`), else none, with
    an :class:`UnrefinedWarning` saying so and the map's measured error.
    """
    if refine is False:
        return None, "refinement turned off: refine=False, or --no-refine on the command line"
    if refine is None and asked_rule:
        return None, "interpolate=False or a threshold asked for the map's own rule"
    if robot is not None or refine:
        return map_robot(reach_map, robot), ""
    loaded, because = robot_by_name(reach_map)
    if loaded is None:
        import warnings

        warnings.warn(f"{unrefined_text(reach_map, because)}; pass robot= to decide the boundary band by IK",
                      UnrefinedWarning, stacklevel=3)
    return loaded, because


def measured_error(reach_map: ReachMap) -> str:
    """The map's unrefined answer's error as its build measured it (held-out completeness, false positives), in
    words, or that it was not measured."""
    said = [line for line in checks_lines(reach_map) if line.startswith(("completeness", "false positives"))]
    return "; ".join(said) if said else "its error was not measured (built with holdout=0 and fp_checks=0)"


def unrefined_text(reach_map: ReachMap, because: str) -> str:
    """The map's unrefined estimate, why (``because``) and its measured error, in words."""
    return f"the map's unrefined estimate, not decided by IK ({because}); measured error: {measured_error(reach_map)}"


def answer_text(reach_map: ReachMap, answer: QueryAnswer) -> str:
    """Which answer ``answer.reachable`` is, in words: decided by IK near the boundary for N of M poses, or the map's
    unrefined estimate with why and its measured error."""
    if answer.decided_by_ik is None:
        return unrefined_text(reach_map, answer.unrefined_because)
    n, m = int(answer.decided_by_ik.sum()), int(answer.decided_by_ik.size)
    return (f"decided by IK near the boundary: {n} of {m} poses (support strictly between 0 and 1; IK of the exact "
            f"pose, yes only where FK lands on it to 1e-9); the rest by the map (support 1: yes, 0: no), whose "
            f"measured error is: {measured_error(reach_map)}")


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
    lines.append(f"a yes means: {resolution_text(reach_map)} (the map's unrefined estimate; query(T) and 'manipkit "
                 "reachmap query' decide the poses of support strictly between 0 and 1 by IK of the exact pose)")
    return lines
