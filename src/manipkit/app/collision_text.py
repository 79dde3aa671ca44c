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

from manipkit.description.mjcf import is_mjcf, rules_source_text
from manipkit.text import number_text, printable, short_text

if TYPE_CHECKING:
    from manipkit.kinematics.collisions import CollisionReport

__all__ = ["collision_lines", "comparison_lines", "geometry_lines", "left_out_lines", "unavailable_text"]


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


def left_out_lines(report: CollisionReport, *, disabled: int, notes=()) -> list[str]:
    """What was not checked and why: the SRDF's ``disabled`` pairs (and its file; an MJCF file: its contact
    rules, :func:`~manipkit.description.mjcf.rules_source_text`), and, with no SRDF pairs, the
    pairs in contact at the home configuration, as MoveIt's Setup Assistant leaves them out; ``notes``: why
    SRDFs found for the robot were not used (:attr:`Robot.srdf_notes <manipkit.kinematics.robot.Robot>`)."""
    lines = [] if report.srdf else [f"SRDF found but not used: {note}" for note in notes]
    if report.srdf and is_mjcf(report.srdf):
        lines.append(f"allowed pairs: {rules_source_text(report.srdf)}: the {disabled} pair"
                     f"{'s' if disabled != 1 else ''} MuJoCo never tests {'are' if disabled != 1 else 'is'} not "
                     "checked (--srdf FILE: an SRDF's pairs instead; --srdf none: none)")
    elif report.srdf:
        lines.append(f"SRDF {printable(report.srdf)}: its {disabled} <disable_collisions> pair"
                     f"{'s are' if disabled != 1 else ' is'} not checked (--srdf none: no SRDF)")
    if not disabled:
        home = report.default_contacts
        lines.append(f"{'no SRDF pairs' if report.srdf else 'no SRDF'}: not checked: adjacent links and the {len(home)} "
                     f"pair{'s' if len(home) != 1 else ''} in contact at the home configuration, as MoveIt's Setup "
                     "Assistant leaves them out" + (f" ({', '.join(f'{a} - {b}' for a, b in home)})" if home else ""))
    return lines


def geometry_lines(geometry: str, distances: dict, other, *, precision: int = 4) -> list[str]:
    """Which geometry answered, and how the answer differs with the other kind.

    ``distances`` are the checked pairs' distances with ``geometry`` (m,
    :meth:`~manipkit.kinematics.collisions.CollisionChecker.distances`);
    ``other`` is :func:`~manipkit.kinematics.collisions.other_geometry` (None:
    every shape is a primitive). A hull contains its mesh, so hull distances
    are at most mesh distances: the pairs in contact with hulls but apart
    with meshes are named with both numbers.
    """
    if other is None:
        return ["geometry: every collision shape is a primitive (box, cylinder, sphere, capsule): hulls and meshes are the same"]
    kind, theirs = other
    hulls, meshes = (theirs, distances) if kind == "hulls" else (distances, theirs)
    differ = sorted(pair for pair in hulls if hulls[pair] <= 0 < meshes.get(pair, 0))
    if geometry == "meshes":
        head = "geometry: meshes; the hulls that IK with collisions, reach maps and placement use"
    else:
        head = "geometry: hulls (conservative: a hull contains its mesh); the meshes"
    if not differ:
        touching = sum(1 for d in distances.values() if d <= 0)
        return [f"{head} find the same {touching} pair{'s' if touching != 1 else ''} in contact"]
    lines = [f"{head} differ on {len(differ)} pair{'s' if len(differ) != 1 else ''}:"]
    for a, b in differ:
        depth = f" (penetration {number_text(-hulls[(a, b)], precision)} m)" if hulls[(a, b)] < 0 else ""
        lines.append(f"  {a} - {b}: in contact with hulls{depth}; {number_text(1000 * meshes[(a, b)], 1)} mm "
                     "apart with meshes")
    return lines


def comparison_lines(comparison) -> list[str]:
    """An :class:`~manipkit.analysis.acm.MatrixComparison` in words: agreement, then each difference and why."""
    lines = [f"compared with {rules_source_text(comparison.srdf)}: {comparison.agree} of {comparison.total} pairs agree "
             f"(disabled in both or checked in both; {comparison.same_reason} disabled for the same reason)"]
    for a, b, ours, theirs, why in comparison.differences:
        lines.append(f"  {a} - {b}: ours {ours}, theirs {printable(theirs)}: {why}")
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
