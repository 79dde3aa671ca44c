"""A collision report in words: the lines ``manipkit collisions`` prints and the viewer's readout shows.

One place for the wording of :class:`manipkit.kinematics.collisions.CollisionReport`
(docs/architecture.md, "Collisions"): in collision or collision-free, every
pair in contact with its penetration depth, the closest pair with its
distance and witness points. Distances are in metres (negative: penetration
depth); witness points are in the robot's root link frame. A robot whose
collision geometry is missing gets one line (:func:`unavailable_text`), never
"collision-free".
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from manipkit.text import number_text, short_text

if TYPE_CHECKING:
    from manipkit.kinematics.collisions import CollisionReport

__all__ = ["collision_lines", "unavailable_text"]


def collision_lines(report: CollisionReport, *, floor: float | None = None, precision: int = 4) -> list[str]:
    """The report as lines: the verdict (pairs checked, geometry, floor), the pairs in contact, the closest pair.

    ``floor`` is the floor height checked (m, root frame; None: no floor), said
    in the first line; ``precision`` is the number of decimals of distances and points.
    """
    where = f"{report.checked} link pair{'s' if report.checked != 1 else ''} checked, {report.geometry} geometry"
    where += "" if floor is None else f", floor at z = {short_text(floor)} m"
    lines = []
    if report.in_collision:
        count = len(report.pairs)
        lines.append(f"robot {report.robot}: IN COLLISION ({count} pair{'s' if count != 1 else ''} in contact; {where})")
        lines += [f"  {pair.link1} - {pair.link2}: {_depth_text(pair.distance, precision)}" for pair in report.pairs]
    else:
        lines.append(f"robot {report.robot}: collision-free ({where})")
    closest = report.min_distance
    if closest is not None:
        lines.append(f"closest pair: {closest.link1} - {closest.link2}, distance {number_text(closest.distance, precision)} m")
        lines.append(f"  witness points in {report.base} (m): {_point_text(closest.point1, precision)} on "
                     f"{closest.link1}, {_point_text(closest.point2, precision)} on {closest.link2}")
    return lines


def unavailable_text(reason: str) -> str:
    """The one line shown when a robot's collisions cannot be checked (``reason``: the :class:`CollisionError`'s message)."""
    return f"collisions unavailable: {reason}"


def _depth_text(distance: float, precision: int) -> str:
    if distance < 0:
        return f"penetration {number_text(-distance, precision)} m"
    return "touching (no depth for meshes)"


def _point_text(point, precision: int) -> str:
    return "(" + ", ".join(number_text(v, precision) for v in point) + ")"
