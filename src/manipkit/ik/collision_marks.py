"""Collisions of IK answers: :func:`mark_collisions` marks (or drops) the solutions of a result that collide.

The checks are the kinematics layer's (:class:`manipkit.kinematics.collisions.CollisionChecker`, coal through
Pinocchio); this module only carries their verdicts into the IK result, with a structured ``collision`` failure
when every solution collides.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from manipkit.ik.result import IKFailure, IKResult
from manipkit.text import short_text

if TYPE_CHECKING:
    from manipkit.kinematics.collisions import CollisionChecker

__all__ = ["mark_collisions"]


def mark_collisions(result: IKResult, checker: CollisionChecker, *, drop: bool = False) -> IKResult:
    """An IK result with ``collides`` and ``clearance`` per solution; ``drop=True`` keeps the collision-free ones only.

    ``result.solutions`` are whole-robot joint vectors (:func:`manipkit.ik.dispatch.ik`). With ``drop`` and every
    solution in collision, there is none left: ``reason`` names the deepest
    pair of the first, and ``closest`` is that configuration.
    """

    reports = [checker.report(q) for q in result.solutions]
    collides = tuple(r.in_collision for r in reports)
    clearance = np.array([np.inf if r.min_distance is None else r.min_distance.distance for r in reports])
    if not drop or not any(collides):
        return result.replaced(collides=collides, clearance=clearance)
    keep = np.array([not c for c in collides], dtype=bool)
    rows = result.solutions[keep]
    labels = tuple(label for label, k in zip(result.labels, keep) if k)
    count = result.count if np.isinf(result.count) and keep.any() else int(keep.sum())
    common = dict(solutions=rows, labels=labels, count=count, residual_position=result.residual_position[keep],
                  residual_rotation=result.residual_rotation[keep], collides=(False,) * len(rows),
                  clearance=clearance[keep],
                  within_limits=None if result.within_limits is None else result.within_limits[keep],
                  refined=None if result.refined is None else result.refined[keep])  # per-row fields follow the rows
    if keep.any():
        note = f"{result.note}; {int((~keep).sum())} in collision dropped" if result.note else ""
        return result.replaced(note=note, **common)
    first = reports[0].pairs[0]
    depth = f"penetration {short_text(-first.distance, 3)} m" if first.distance < 0 else "touching"
    reason = (f"every solution is in collision ({len(reports)}); the first: {first.link1} - {first.link2} ({depth})")
    failure = IKFailure("collision", reason, pairs=tuple((p.link1, p.link2) for p in reports[0].pairs),
                        values=(("distance", float(first.distance)),))
    closest_residuals = np.array([result.residual_position[0], result.residual_rotation[0]])
    return result.replaced(note=reason, closest=result.solutions[0], failure=failure,
                           closest_residuals=closest_residuals, **common)
