"""Inverse reachability: where to put a mobile base so the arm reaches the most target poses.

Frames (docs/site/internals/reach-maps.md):

- ``F``: the floor (world) frame the targets are given in, z up.
- ``P``: the robot's floor frame (its root, ``base_footprint`` for a mobile
  base), placed on the floor at ``(x, y, yaw)``:
  ``T_F_P = [Rz(yaw), (x, y, 0)]``.
- ``B``: the map's base frame, carried by the robot: ``T_P_B = mount``
  (``robot.transform(P, B)`` with the arm at rest; identity when the map
  was built from the floor frame itself).

A target ``T_F_target`` is reachable from a placement when the map says so
for ``T_B_target = mount^-1 T_F_P^-1 T_F_target``
(:meth:`manipkit.analysis.reachmap.ReachMap.query` with ``threshold``: the
target's voxel-bin was reached and its support is at least ``threshold``;
0 counts every target in a reached voxel-bin). The score of a placement is
the number of targets the map says yes to from it, at the map's resolution
(its voxel and orientation bins, roll or any roll: an estimate).
:func:`confirm_placement` then re-scores the map's ``candidates`` best
placements (default :data:`DEFAULT_CANDIDATES`) by IK of every target from
each (the one dispatcher, seeded from the bin's certificate, confirmed by FK,
collision-free when collisions are given): the placement chosen is the one
with the most targets IK confirms, not the one the map scores highest. IK
matches the full pose, or for an arm of fewer than 6 joints the position and
the approach (z) axis (:func:`confirm_mode`): such an arm reaches a full pose
only from exact placements, which a grid does not hold.

**Carrying a payload** (``payload=MASS``, kg; the map needs a payload layer,
:func:`manipkit.analysis.reachmap.payloadmap.payload_map`): a target counts
only when the map says yes to it and its voxel-bin holds ``MASS`` at the
layer's CoG on its best weighed configuration (the stored one, or the best
closed-form branch of its pose: :func:`manipkit.analysis.reachmap.payload.capacity_at`), so placements are
ranked by the share of targets reachable while carrying the mass; and
:func:`confirm_placement` counts an IK answer only when it holds the mass too
(:func:`manipkit.analysis.reachmap.payloadmap.capacity_of`).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.analysis.reachmap.constants import DEFAULT_THRESHOLD, MAX_VOXEL, MIN_VOXEL, check_threshold, finite_array
from manipkit.errors import ReachMapError
from manipkit.inputs.poses import MAX_POSITION, MAX_TARGETS
from manipkit.text import repr_text, short_text

if TYPE_CHECKING:
    from manipkit.analysis.reachmap.map import ReachMap

__all__ = [
    "CONFIRM_MODES", "DEFAULT_CANDIDATES", "MAX_CANDIDATES", "BasePlacement", "ConfirmedPlacement", "base_placement",
    "REFINE_ITERATIONS", "REFINE_TOL", "confirm_mode", "confirm_placement", "placement_transforms",
    "plot_base_placement", "reach_radius", "refine_placement",
]

MAX_POSES = 50_000_000  # placements x targets a search may test
MAX_YAWS = 3600  # headings a search tries (a tenth of a degree apart)
BATCH_POSES = 1 << 17  # placement-target pairs tested at once (about 16 MB of poses)
REFINE_ITERATIONS = 100  # Gauss-Newton steps at most
REFINE_TOL = 1e-9  # m and rad: the largest residual at which the search stops
_STEP = 1e-7  # forward-difference step (m, rad)
_DAMPING = 1e-3  # Levenberg-Marquardt damping of the normal equations


@dataclass(frozen=True, eq=False)
class BasePlacement:
    """Scores of base placements (see the module docstring for the frames).

    Attributes
    ----------
    xs, ys : ndarray
        Floor positions (m) of the robot's floor frame tried, along x and y of ``F``.
    yaws : ndarray
        Headings (rad) tried, about z of ``F``.
    scores : ndarray of int, shape (len(xs), len(ys), len(yaws))
        Targets the map says yes to from each placement (``threshold``).
    targets : ndarray, shape (K, 4, 4)
        ``T_F_target``.
    threshold : float
        The least support a counted target had (:meth:`ReachMap.query`; 0: every target in a reached voxel-bin).
    payload : float or None
        kg: a counted target's voxel-bin also holds this payload (module docstring); None: no payload asked.
    """

    xs: np.ndarray
    ys: np.ndarray
    yaws: np.ndarray
    scores: np.ndarray
    targets: np.ndarray
    threshold: float = DEFAULT_THRESHOLD
    payload: float | None = None

    @property
    def best(self) -> tuple[float, float, float, int]:
        """(x m, y m, yaw rad, score) of the best placement (the first in x, y, yaw order on a tie)."""
        i, j, k = np.unravel_index(int(np.argmax(self.scores)), self.scores.shape)
        return float(self.xs[i]), float(self.ys[j]), float(self.yaws[k]), int(self.scores[i, j, k])

    def summary(self) -> str:
        """One line: the best placement and how many targets the map says it reaches."""
        x, y, yaw, score = self.best
        carrying = "" if self.payload is None else f" carrying {short_text(self.payload, 4)} kg"
        return (f"best base placement x {short_text(x, 4)} m, y {short_text(y, 4)} m, yaw "
                f"{short_text(math.degrees(yaw), 4)} deg: the map says yes to {score} of {len(self.targets)} targets"
                f"{carrying} ({len(self.xs)}x{len(self.ys)}x{len(self.yaws)} placements tried)")


@dataclass(frozen=True, eq=False)
class ConfirmedPlacement:
    """A placement whose targets IK confirmed (:func:`confirm_placement`).

    Attributes
    ----------
    x, y, yaw : float
        The placement (m, m, rad) of the robot's floor frame.
    confirmed : ndarray of bool, shape (K,)
        Per target: IK from this placement reached it in ``mode`` (FK residuals within ``tol``).
    q : ndarray, shape (K, n)
        IK's configurations (meaningful where ``confirmed``).
    map_score : int
        Targets the map says yes to from this placement (at its resolution, with the search's threshold).
    resolution : str
        What the map's yes means (:func:`manipkit.analysis.reachmap.query.resolution_text`).
    candidates : int
        Placements IK was run from (the best-scored by the map).
    payload : float or None
        kg an answer also held (the map's payload layer), or None.
    mode, axis : str
        What IK matched (:func:`confirm_mode`): ``"pose"``, or ``"position+axis"`` (the origin and the tip's ``axis``).
    pose_confirmed : ndarray of bool, shape (K,), or None
        ``mode`` other than ``"pose"``: per target, IK of the full pose from this placement reached it.
    tried : ndarray, shape (candidates, 5)
        Per placement IK was run from, in the map's order: x, y, yaw, the map's count, IK's count.
    refined : tuple (x, y, yaw, pose_confirmed) or None
        ``mode`` other than ``"pose"`` and a full pose unconfirmed: the placement :func:`refine_placement` found
        from this one (off the grid) and, per target, whether IK of the full pose from it reached it; None when
        not searched or when it confirms no more full poses than this placement.
    """

    x: float
    y: float
    yaw: float
    confirmed: np.ndarray
    q: np.ndarray
    map_score: int
    resolution: str
    candidates: int
    payload: float | None = None
    mode: str = "pose"
    axis: str = "z"
    pose_confirmed: np.ndarray | None = None
    tried: np.ndarray | None = None
    refined: tuple | None = None

    def summary(self) -> str:
        """Two lines: the placement and the targets IK confirms; the map's estimate and what it means."""
        n = len(self.confirmed)
        carrying = "" if self.payload is None else f", holding {short_text(self.payload, 4)} kg there"
        what = "full pose" if self.mode == "pose" else f"position and the direction of the tool's {self.axis} axis"
        full = "" if self.pose_confirmed is None else f"; the full pose: {int(self.pose_confirmed.sum())} of {n}"
        text = (f"base placement x {short_text(self.x, 4)} m, y {short_text(self.y, 4)} m, yaw "
                f"{short_text(math.degrees(self.yaw), 4)} deg: IK confirms {int(self.confirmed.sum())} of {n} targets "
                f"({what}, by FK{carrying}{full}; the most IK confirms from the map's {self.candidates} best-scored "
                f"placements)\n"
                f"the map estimates {self.map_score} of {n} from there, counting the targets it says yes to; a yes "
                f"means: {self.resolution}")
        if self.refined is not None:
            x, y, yaw, confirmed = self.refined
            text += (f"\nrefined off the grid (the base pose and the arm's joints searched together from there): x "
                     f"{short_text(x, 4)} m, y {short_text(y, 4)} m, yaw {short_text(math.degrees(yaw), 4)} deg, "
                     f"from which IK confirms the full pose of {int(confirmed.sum())} of {n} targets (by FK{carrying})")
        return text


CONFIRM_MODES = ("auto", "pose", "position+axis")
DEFAULT_CANDIDATES = 20  # placements re-scored by IK: the map's best, in its order
MAX_CANDIDATES = 1000


def confirm_mode(reach_map: ReachMap, robot, mode: str = "auto") -> str:
    """What IK must match for a target to count: ``"pose"``, or ``"position+axis"`` (the origin and the z axis).

    ``"auto"``: the full pose when the map's chain (``robot``, from the map's
    base to its frame) has 6 joints or more, or
    the map is planar (a planar arm's pose is its in-plane position and
    turn); else ``"position+axis"`` along the tool's z axis, the map's
    approach axis: an arm of 5 joints reaches only a 5-dimensional set of
    poses, so from any floor placement but an exact one a target's full pose
    is out of its reach, while its position and approach axis (5 numbers)
    are not.
    """
    if mode not in CONFIRM_MODES:
        raise ReachMapError(f"mode {repr_text(mode)}: give one of {', '.join(CONFIRM_MODES)}")
    if mode != "auto":
        return mode
    if reach_map.orientations.kind == "planar" or len(robot.chain(reach_map.base, reach_map.frame).joint_names) >= 6:
        return "pose"
    return "position+axis"


def confirm_placement(reach_map: ReachMap, result: BasePlacement, robot, *, mount=None,
                      candidates: int = DEFAULT_CANDIDATES, mode: str = "auto", collisions=None, tol: float = 1e-6,
                      restarts: int = 20, seed: int = 0) -> ConfirmedPlacement:
    """Re-score the map's ``candidates`` best placements by the targets IK confirms from each; the one it confirms most.

    The map pre-filters and orders (its count, then x, y, yaw order); IK
    (the one dispatcher, :func:`manipkit.analysis.reachmap.query.query_answer`
    seeded from the bins' certificates) is run for every target from each of
    the ``candidates`` best, all in one batch, in the mode :func:`confirm_mode`
    picks (``mode``). The chosen placement is the one with the most targets
    IK confirms; ties go to the higher map score, then to the map's order.
    With a mode other than ``"pose"``, the full pose is also tried from the
    chosen placement (``pose_confirmed``), and where IK misses some full
    poses, from the placement :func:`refine_placement` finds off the grid
    from the chosen one (``refined``, kept when IK confirms more full poses
    from it).

    ``robot`` is the robot the map is of; ``mount`` as in :func:`base_placement`;
    ``collisions`` (:class:`manipkit.kinematics.collisions.CollisionSettings`)
    counts only collision-free answers; with ``result.payload`` (kg) an answer
    counts only when it also holds that payload (the map's payload layer's CoG,
    gravity and limits).
    """
    from manipkit.analysis.reachmap.query import query_answer, resolution_text

    if isinstance(candidates, bool) or not isinstance(candidates, numbers.Integral) or \
            not 1 <= candidates <= MAX_CANDIDATES:
        raise ReachMapError(f"candidates {repr_text(candidates)}: give a whole number from 1 to {MAX_CANDIDATES}")
    mode = confirm_mode(reach_map, robot, mode)
    mount = np.eye(4) if mount is None else finite_array(mount, "mount", (4, 4), "the 4x4 T_P_B")
    flat = result.scores.reshape(-1)
    order = np.argsort(-flat, kind="stable")[:candidates]
    i, j, k = np.unravel_index(order, result.scores.shape)
    x, y, yaw = result.xs[i], result.ys[j], result.yaws[k]
    T_B_P = np.linalg.inv(mount) @ np.linalg.inv(placement_transforms(x, y, yaw))  # (candidates, 4, 4)
    T_B_target = T_B_P[:, None] @ result.targets  # (candidates, K, 4, 4)

    def confirm(T, how):
        answer = query_answer(reach_map, T, confirm=True, robot=robot, tol=tol, restarts=restarts, seed=seed,
                              collisions=collisions, mode=how, refine=False)
        confirmed = np.array(answer.confirmed, dtype=bool)
        if result.payload is not None and confirmed.any():
            from manipkit.analysis.reachmap.payloadmap import capacity_of

            confirmed[confirmed] = capacity_of(reach_map, robot, answer.q[confirmed]) >= result.payload
        return confirmed, answer.q

    confirmed, q = confirm(T_B_target, mode)
    counts = confirmed.sum(axis=1)
    best = int(np.lexsort((np.arange(len(order)), -flat[order], -counts))[0])
    pose_confirmed = None if mode == "pose" else confirm(T_B_target[best], "pose")[0]
    refined = None
    if pose_confirmed is not None and not pose_confirmed.all() and confirmed[best].any():
        chain = robot.chain(reach_map.base, reach_map.frame)
        keep = confirmed[best]  # the targets whose position and axis IK matched: their answers start the search
        found, _, _ = refine_placement(chain, result.targets[keep], (x[best], y[best], yaw[best]),
                                       q[best][keep][:, chain.columns], mount=mount)
        T_B_found = np.linalg.inv(mount) @ np.linalg.inv(placement_transforms(*found)) @ result.targets
        found_confirmed = confirm(T_B_found, "pose")[0]
        if found_confirmed.sum() > pose_confirmed.sum():
            refined = (float(found[0]), float(found[1]), float(math.remainder(found[2], 2 * math.pi)),
                       found_confirmed)
    tried = np.column_stack([x, y, yaw, flat[order], counts]).astype(float)
    return ConfirmedPlacement(float(x[best]), float(y[best]), float(yaw[best]), confirmed[best], q[best],
                              int(flat[order[best]]), resolution_text(reach_map, threshold=result.threshold),
                              len(order), result.payload, mode, "z", pose_confirmed, tried, refined)


def placement_transforms(x, y, yaw) -> np.ndarray:
    """``T_F_P`` (..., 4, 4) for floor positions ``x``, ``y`` (m) and headings ``yaw`` (rad), broadcast together.

    >>> placement_transforms(1.0, 2.0, 0.0)[:3, 3]
    array([1., 2., 0.])
    """
    x, y, yaw = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, yaw)))
    T = np.zeros(x.shape + (4, 4))
    c, s = np.cos(yaw), np.sin(yaw)
    T[..., 0, 0], T[..., 0, 1], T[..., 1, 0], T[..., 1, 1] = c, -s, s, c
    T[..., 2, 2] = T[..., 3, 3] = 1.0
    T[..., 0, 3], T[..., 1, 3] = x, y
    return T


def reach_radius(reach_map: ReachMap) -> float:
    """Largest horizontal distance (m, in the map's base frame) from its base origin to a reachable voxel's far edge."""
    centres = reach_map.centers()[reach_map.reachable]
    if centres.size == 0:
        return 0.0
    return float(np.hypot(centres[:, 0], centres[:, 1]).max()) + reach_map.voxel


def base_placement(reach_map: ReachMap, targets, *, xs=None, ys=None, yaws=16, step: float | None = None,
                   mount=None, threshold: float = DEFAULT_THRESHOLD, payload: float | None = None) -> BasePlacement:
    """Score floor placements ``(x, y, yaw)`` by the targets the arm reaches from each.

    Parameters
    ----------
    reach_map : ReachMap
        Map of the arm in its base frame ``B``.
    targets : array_like, shape (K, 4, 4)
        Target poses ``T_F_target`` of the map's frame, in the floor frame.
    xs, ys : array_like, optional
        Positions to try (m). Default: the targets' range widened by the
        map's horizontal reach, every ``step``.
    yaws : int or array_like
        Headings to try (rad), or how many evenly spaced in [-pi, pi).
    step : float, optional
        Grid step of the default ``xs``, ``ys`` (default: the map's voxel).
    mount : array_like, shape (4, 4), optional
        ``T_P_B``, the map base in the robot's floor frame (default identity).
    threshold : float
        A target counts when the map says yes to it with this threshold
        (:meth:`ReachMap.query`: its voxel-bin reached and its support at
        least ``threshold``; 0: every target in a reached voxel-bin).
    payload : float, optional
        kg: count a target only when its voxel-bin's stored configuration also
        holds this payload (the map's payload layer; module docstring).

    Returns
    -------
    BasePlacement

    Raises
    ------
    ReachMapError
        Targets, mount, positions or headings that are not finite numbers of
        the right shape, positions beyond ``MAX_POSITION`` (m), more than
        ``MAX_TARGETS`` targets or ``MAX_YAWS`` headings, a step outside the
        voxel bounds, a threshold outside [0, 1], or more than ``MAX_POSES`` placement-target pairs: all
        checked before any grid is allocated (the pairs are then tested
        ``BATCH_POSES`` at a time).

    Examples
    --------
    >>> import manipkit
    >>> from manipkit.analysis.reachmap import build
    >>> arm = build(manipkit.load("planar_2r"), voxel=0.1, orientations=1, samples=20000)
    >>> targets = np.tile(np.eye(4), (2, 1, 1)); targets[1, 0, 3] = 3.0
    >>> found = base_placement(arm, targets, xs=[0.0, 1.5], ys=[0.0], yaws=[0.0])
    >>> found.scores[:, 0, 0].tolist()
    [1, 2]
    """
    # Over 80 lines: the docstring is most of it; every count is checked before anything is allocated.
    T = finite_array(targets, "targets", (4, 4), "one or more 4x4 poses T_floor_target, shape (K, 4, 4)")
    if T.ndim != 3 or not 1 <= len(T) <= MAX_TARGETS:
        raise ReachMapError(f"targets have shape {T.shape}; give 1 to {MAX_TARGETS} 4x4 poses T_floor_target, "
                            "shape (K, 4, 4)")
    mount = np.eye(4) if mount is None else finite_array(mount, "mount", (4, 4), "the 4x4 T_P_B")
    threshold = check_threshold(threshold)
    if payload is not None:
        if isinstance(payload, bool) or not isinstance(payload, numbers.Real) or not 0 <= payload < math.inf:
            raise ReachMapError(f"payload {repr_text(payload)}: give the mass to carry, a finite number >= 0 kg")
        if reach_map.payload is None:
            raise ReachMapError("payload: the map has no payload layer; add one with "
                                "manipkit.reachmap.payload_map(map, robot, cog=...)")
        payload = float(payload)
    if mount.shape != (4, 4):
        raise ReachMapError(f"mount has shape {mount.shape}; give one 4x4 transform T_P_B")
    for name, values in (("targets", T[:, :3, 3]), ("mount", mount[:3, 3]), ("xs", xs), ("ys", ys)):
        values = np.zeros(0) if values is None else finite_array(values, name, (), "positions in metres")
        if values.size and np.abs(values).max() > MAX_POSITION:
            raise ReachMapError(f"{name}: a position of {np.abs(values).max():g} m; give positions within "
                                f"{MAX_POSITION:g} m")
    if step is not None and (isinstance(step, bool) or not isinstance(step, numbers.Real) or not math.isfinite(step)
                             or not MIN_VOXEL <= step <= MAX_VOXEL):
        raise ReachMapError(f"step {repr_text(step)}: give the grid step in metres, a number from {MIN_VOXEL:g} to "
                            f"{MAX_VOXEL:g}")
    step = float(step or reach_map.voxel)
    if isinstance(yaws, numbers.Integral) and not isinstance(yaws, bool):
        if not 1 <= yaws <= MAX_YAWS:
            raise ReachMapError(f"yaws {int(yaws)}: give from 1 to {MAX_YAWS} headings")
        yaws = -math.pi + 2.0 * math.pi * np.arange(int(yaws)) / int(yaws)
    lows, highs = [None, None], [None, None]
    if xs is None or ys is None:
        radius = reach_radius(reach_map) + float(np.hypot(*mount[:2, 3]))
        lows, highs = T[:, :2, 3].min(axis=0) - radius, T[:, :2, 3].max(axis=0) + radius
    counts = []
    for axis, given in enumerate((xs, ys, yaws)):
        if given is None:  # a range every step: its length before it is made
            counts.append(int((highs[axis] - lows[axis]) / step + 0.5) + 1)
        else:
            given = finite_array(given, "xyz"[axis] + "s" if axis < 2 else "yaws", (), "numbers")
            if given.ndim > 1 or given.size == 0:
                raise ReachMapError(f"{'xs ys yaws'.split()[axis]} have shape {given.shape}; give one or more numbers")
            counts.append(given.size)
    poses = math.prod(counts) * len(T)
    if poses > MAX_POSES or max(counts[:2]) > MAX_POSES:
        raise ReachMapError(f"{counts[0]}x{counts[1]}x{counts[2]} placements times {len(T)} targets is {poses} poses, "
                            f"more than {MAX_POSES}: use a coarser step, fewer headings or fewer targets")
    xs = np.arange(lows[0], highs[0] + step / 2, step)[:counts[0]] if xs is None else xs
    ys = np.arange(lows[1], highs[1] + step / 2, step)[:counts[1]] if ys is None else ys
    xs, ys, yaws = (np.atleast_1d(np.asarray(v, dtype=float)) for v in (xs, ys, yaws))
    mount_inv = np.linalg.inv(mount)
    scores = np.zeros((len(xs), len(ys), len(yaws)), dtype=np.int64)
    X, Y = (v.reshape(-1) for v in np.meshgrid(xs, ys, indexing="ij"))
    batch = max(1, BATCH_POSES // len(T))  # placements per batch: a bounded (batch, K, 4, 4) at a time
    for k, yaw in enumerate(yaws):
        for start in range(0, X.size, batch):
            T_F_P = placement_transforms(X[start:start + batch], Y[start:start + batch], yaw)
            R_t = np.swapaxes(T_F_P[..., :3, :3], -1, -2)
            T_P_F = T_F_P.copy()
            T_P_F[..., :3, :3] = R_t
            T_P_F[..., :3, 3] = -np.einsum("...ij,...j->...i", R_t, T_F_P[..., :3, 3])
            T_B_target = mount_inv @ T_P_F[..., None, :, :] @ T  # (batch, K, 4, 4)
            yes = reach_map.query(T_B_target, threshold=threshold, refine=False)
            if payload is not None:
                from manipkit.analysis.reachmap.payload import capacity_at

                yes &= capacity_at(reach_map, T_B_target) >= payload  # NaN (not reached) holds nothing
            scores.reshape(-1, len(yaws))[start:start + batch, k] = yes.sum(axis=-1)
    return BasePlacement(xs, ys, yaws, scores, T, threshold, payload)


def _residuals(chain, mount_inv: np.ndarray, targets: np.ndarray, placement: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """(K, 6): per target, FK's position error (m) and rotation error (rad, small) from ``placement``."""
    T_B = mount_inv @ np.linalg.inv(placement_transforms(*placement)) @ targets
    reached = chain.fk(Q)
    R = np.swapaxes(T_B[:, :3, :3], -1, -2) @ reached[:, :3, :3]
    rotation = 0.5 * np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], axis=-1)
    return np.concatenate([reached[:, :3, 3] - T_B[:, :3, 3], rotation], axis=-1)


def refine_placement(chain, targets, placement, Q, *, mount=None, iterations: int = REFINE_ITERATIONS,
                     tol: float = REFINE_TOL) -> tuple[np.ndarray, np.ndarray, float]:
    """(placement (3,), Q (K, n), largest residual): the floor placement and joint values that best put ``chain``'s
    tip on the full poses ``targets`` (K, 4, 4) ``T_F_target``, from ``placement`` (x, y, yaw) and ``Q`` (K, n, chain
    order); ``mount`` is ``T_P_B`` (default identity).

    An arm of 5 joints reaches a 5-dimensional set of poses, so the full
    poses of several targets are reachable only from exact placements, which
    a grid does not hold. This searches the placement and every target's
    joint values together (``3 + n K`` unknowns, ``6 K`` equations) by damped
    Gauss-Newton (Levenberg-Marquardt), the Jacobian by forward differences;
    target k's residual is its position error (m) and the rotation error
    ``vee(R_target^T R - R^T R_target) / 2`` (rad when small, zero where the
    rotations agree). The answer is only a candidate: what counts is what IK
    then confirms from it (:func:`confirm_placement`).
    """
    mount_inv = np.eye(4) if mount is None else np.linalg.inv(np.asarray(mount, dtype=float))
    targets = np.asarray(targets, dtype=float)
    p, Q = np.array(placement, dtype=float), np.array(Q, dtype=float)
    K, n = Q.shape
    r = _residuals(chain, mount_inv, targets, p, Q)
    for _ in range(iterations):
        if np.abs(r).max() < tol:
            break
        J = np.zeros((K, 6, 3 + n * K))
        for a in range(3):
            moved = p.copy()
            moved[a] += _STEP
            J[:, :, a] = (_residuals(chain, mount_inv, targets, moved, Q) - r) / _STEP
        for j in range(n):  # joint j of every target at once: target k's residual depends on its own joints only
            moved = Q.copy()
            moved[:, j] += _STEP
            J[np.arange(K), :, 3 + n * np.arange(K) + j] = ((_residuals(chain, mount_inv, targets, p, moved) - r)
                                                              / _STEP)
        J = J.reshape(6 * K, 3 + n * K)
        step = np.linalg.solve(J.T @ J + _DAMPING * np.eye(J.shape[1]), -J.T @ r.reshape(-1))
        p, Q = p + step[:3], Q + step[3:].reshape(K, n)
        r = _residuals(chain, mount_inv, targets, p, Q)
    return p, Q, float(np.abs(r).max())


def plot_base_placement(result: BasePlacement, path, *, title: str | None = None) -> None:
    """Heat map of the best score over headings at each floor position, the targets and the best placement, to ``path``."""
    from matplotlib.figure import Figure  # not pyplot: the caller's backend (a notebook's) stays as it is

    from manipkit.outputs import writing

    best_over_yaw = result.scores.max(axis=2)
    x, y, yaw, score = result.best
    fig = Figure(figsize=(6.4, 5.2))
    ax = fig.subplots()
    step_x = result.xs[1] - result.xs[0] if len(result.xs) > 1 else 1.0
    step_y = result.ys[1] - result.ys[0] if len(result.ys) > 1 else 1.0
    extent = (result.xs[0] - step_x / 2, result.xs[-1] + step_x / 2, result.ys[0] - step_y / 2, result.ys[-1] + step_y / 2)
    image = ax.imshow(best_over_yaw.T, origin="lower", extent=extent, cmap="viridis", vmin=0, vmax=len(result.targets),
                      interpolation="nearest", aspect="equal")
    fig.colorbar(image, ax=ax, label="targets the map says yes to (best heading)")
    ax.scatter(result.targets[:, 0, 3], result.targets[:, 1, 3], marker="x", color="tab:red", label="targets")
    ax.arrow(x, y, 0.15 * math.cos(yaw), 0.15 * math.sin(yaw), width=0.01, color="white", length_includes_head=True)
    ax.plot([x], [y], "o", color="white", label=f"best: {score} of {len(result.targets)}")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title or "base placement: targets reached from each floor position", parse_math=False)
    ax.legend(loc="upper right", fontsize="small")
    with writing(path) as target:
        fig.savefig(target, dpi=110, bbox_inches="tight")
