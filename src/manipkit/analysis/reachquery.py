"""What a reachability map answers for a pose, and the exact answer by IK from the bin's certificate.

(docs/architecture.md, "Reachability maps".) A map answers at its
resolution: whether the **voxel** holding the position and the **orientation
bin** holding the rotation were reached (:meth:`ReachMap.query`). The bin is
the approach-axis direction plus the roll about it, or the direction alone
with **any roll** when the map was built with one roll; a planar map's bin is
a turn about its axis. :func:`query_answer` says which, per pose, and with
``confirm=True`` runs IK for the **exact** pose (mode ``"pose"``) from the
certificate of the pose's voxel-bin (a configuration whose FK lands in it),
then random restarts; ``confirmed`` is True only where FK of the answer
reaches the pose within ``tol`` (and it is collision-free when collisions are
given). IK failing does not prove a pose unreachable.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.text import printable, short_text

if TYPE_CHECKING:
    from manipkit.analysis.reachmap import ReachMap
    from manipkit.kinematics.collisions import CollisionSettings
    from manipkit.kinematics.robot import Robot

__all__ = ["QueryAnswer", "checks_lines", "query_answer", "resolution_text"]


@dataclass(frozen=True, eq=False)
class QueryAnswer:
    """A map's answer for poses ``T`` (...,), and (``confirm=True``) IK's answer for the exact poses.

    Attributes
    ----------
    reachable : ndarray of bool, shape (...)
        The map's answer: the voxel-bin holding the pose was reached.
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
    voxel: np.ndarray
    inside: np.ndarray
    direction: np.ndarray
    roll: np.ndarray | None
    resolution: str
    certificate: np.ndarray
    confirmed: np.ndarray | None = None
    q: np.ndarray | None = None


def resolution_text(reach_map: ReachMap) -> str:
    """One line: what a yes of the map means (voxel edge, orientation bins, roll or any roll)."""
    o = reach_map.orientations
    voxel = f"the position's {short_text(reach_map.voxel)} m voxel"
    if o.kind == "planar":
        return f"{voxel} and the tool's turn about the arm's axis to {short_text(360.0 / o.n_rolls, 4)} deg bins"
    cap = math.degrees(math.acos(max(-1.0, 1.0 - 2.0 / o.n_directions)))  # a cap of 4 pi / n steradians
    direction = f"its approach axis (z) to one of {o.n_directions} directions (about {short_text(cap, 3)} deg each)"
    if o.n_rolls == 1:
        return f"{voxel} and {direction}, any roll about it"
    return f"{voxel}, {direction} and the roll about it to {short_text(360.0 / o.n_rolls, 4)} deg bins"


def query_answer(reach_map: ReachMap, T, *, confirm: bool = False, robot: Robot | None = None, tol: float = 1e-6,
                 restarts: int = 20, seed: int = 0, collisions: CollisionSettings | None = None) -> QueryAnswer:
    """The map's answer for poses ``T`` (..., 4, 4) ``T_base_frame`` and, with ``confirm``, IK's for the exact poses.

    ``robot``: the robot the map is of (default: loaded by the map's robot
    name, which works for bundled and example-robot-data robots). ``tol``:
    position (m) and rotation (rad) residual of a confirmed answer.
    """
    from manipkit.analysis.reachmap import HOW_NONE, ReachMapError, finite_array

    T = finite_array(T, "T", (4, 4), "poses (..., 4, 4) T_base_frame")
    reachable = np.asarray(reach_map.query(T))
    ijk, inside = reach_map.voxel_of(T[..., :3, 3])
    bins = np.asarray(reach_map.orientations.bin_of(T[..., :3, :3]))
    o = reach_map.orientations
    direction, roll = (bins, None) if o.kind == "planar" or o.n_rolls == 1 else np.divmod(bins, o.n_rolls)
    n = len(reach_map.joint_names)
    keys = np.ravel_multi_index(tuple(np.moveaxis(ijk, -1, 0)), reach_map.shape) * o.size + bins
    certificate = np.full(T.shape[:-2] + (n,), np.nan)
    if reach_map.cert_keys is not None and reach_map.cert_keys.size:
        rows = np.clip(np.searchsorted(reach_map.cert_keys, keys), 0, reach_map.cert_keys.size - 1)
        found = reachable & (reach_map.cert_keys[rows] == keys) & (reach_map.reach.reshape(-1)[keys] > HOW_NONE)
        certificate[found] = reach_map.cert_q[rows[found]]
    answer = dict(reachable=reachable, voxel=ijk, inside=inside, direction=direction, roll=roll,
                  resolution=resolution_text(reach_map), certificate=certificate)
    if not confirm:
        return QueryAnswer(**answer)
    if robot is None:
        import manipkit

        try:
            robot = manipkit.load(reach_map.robot)
        except Exception as exc:  # noqa: BLE001 - said as one line: the caller gives the robot
            raise ReachMapError(f"confirm needs the robot the map is of ('{printable(reach_map.robot)}' did not load: "
                                f"{printable(str(exc))[:120]}); pass robot=") from None
    from manipkit.kinematics.ik_many import ik_many

    flat_T, flat_seed = T.reshape(-1, 4, 4), certificate.reshape(-1, n)
    q0 = np.where(np.isnan(flat_seed), robot.q(), flat_seed)
    batch = ik_many(robot, flat_T, reach_map.base, reach_map.frame, q0=q0, mode="pose", tol=tol, restarts=restarts,
                    seed=seed)
    confirmed = np.array(batch.success, dtype=bool)
    if collisions is not None and confirmed.any():
        confirmed[confirmed] = collisions.free(robot, batch.q[confirmed])
    return QueryAnswer(**answer, confirmed=confirmed.reshape(T.shape[:-2]), q=batch.q.reshape(T.shape[:-2] + (-1,)))


def checks_lines(reach_map: ReachMap) -> list[str]:
    """Lines: how the sampling ended, the held-out completeness and the false-positive bound (when built)."""
    s, lines = reach_map.settings, []
    if "samples_used" in s:
        lines.append(f"sampling {'converged' if s.get('converged') else 'used its whole budget'}: "
                     f"{s['samples_used']} samples in {s['blocks']} blocks (stop below {short_text(s['converge'])} "
                     f"new voxel-bins per block); IK fill passes: {s.get('fill_passes', 0)}")
    c = s.get("completeness")
    if isinstance(c, dict) and c.get("n"):
        lines.append(f"completeness: a held-out sample of {c['n']} reachable poses (FK of joint samples the build "
                     f"never drew) lands in reached voxel-bins {short_text(100 * c['rate'], 4)} % (95 % interval "
                     f"{short_text(100 * c['low'], 4)}-{short_text(100 * c['high'], 4)} %)")
    f = s.get("false_positive")
    if isinstance(f, dict) and f.get("n"):
        lines.append(f"false positives: IK ({printable(str(f['mode']))}) failed on {f['failed']} of {f['n']} poses "
                     f"drawn inside reached voxel-bins: at most {short_text(100 * f['high'], 3)} % (95 % bound; "
                     "an IK failure need not be unreachable)")
    lines.append(f"a yes means: {resolution_text(reach_map)}")
    return lines
