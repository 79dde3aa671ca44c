"""The viewer's collision checks: what is checked, the report at a pose, its words and the links to tint.

:class:`CollisionView` holds what a view checks (self-collision, the floor:
:class:`manipkit.kinematics.collisions.CollisionSettings`) or, for a robot
whose collision geometry is missing, the reason it cannot. It asks
:mod:`manipkit.kinematics.collisions` for the report at each pose (the
analysis stays there) and words it with :mod:`manipkit.app.collision_text`,
the lines ``manipkit collisions`` prints. A robot without collision geometry
gets one line saying that collisions are unavailable for it, never "collision-free".

Conventions (docs/architecture.md, "Collisions"): distances in metres
(negative: penetration depth), witness points and the floor in the robot's root link frame.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from manipkit.app.collision_text import collision_lines, unavailable_text
from manipkit.errors import CollisionError
from manipkit.kinematics.collisions import GEOMETRIES, CollisionSettings, collision_geometry

if TYPE_CHECKING:
    from manipkit.kinematics.collisions import CollisionReport
    from manipkit.kinematics.robot import Robot

__all__ = ["CollisionView", "collision_view"]


class CollisionView:
    """What a view checks for collisions, or why it cannot; immutable.

    Build it with :func:`collision_view`. ``settings`` is the
    :class:`CollisionSettings` checked (None when unavailable); ``unavailable``
    is "" or the reason collisions cannot be checked for this robot (the
    :class:`CollisionError` of its missing geometry).
    """

    def __init__(self, settings: CollisionSettings | None, unavailable: str = ""):
        if (settings is None) == (not unavailable):
            raise CollisionError("a collision view needs settings or the reason there are none, not both")
        self.settings = settings
        self.unavailable = unavailable

    @property
    def floor(self) -> float | None:
        """The floor height checked (m, root frame), or None."""
        return None if self.settings is None else self.settings.floor

    def report(self, robot: Robot, q) -> CollisionReport | None:
        """The collision report at ``q`` (whole-robot joint vector); None when collisions are unavailable."""
        if self.settings is None:
            return None
        return self.settings.checker(robot).report(q)

    def as_dict(self, report: CollisionReport | None) -> dict:
        """JSON-ready: ``available``, ``checked`` (self, floor), ``floor``, ``geometry``; the report's
        ``in_collision``, ``pairs``, ``min_distance``; ``links`` in contact; ``unavailable`` (the reason or "")."""
        if self.settings is None or report is None:
            return {"available": False, "unavailable": self.unavailable}
        links = sorted({name for pair in report.pairs for name in (pair.link1, pair.link2)} - {"floor"})
        return {"available": True, "unavailable": "", **self.settings.as_dict(), **report.as_dict(), "links": links}

    def text(self, report: CollisionReport | None, *, precision: int = 4) -> str:
        """The readout's lines: :func:`manipkit.app.collision_text.collision_lines`, or the one unavailable line."""
        if self.settings is None or report is None:
            return unavailable_text(self.unavailable)
        return "\n".join(collision_lines(report, floor=self.settings.floor, precision=precision))

    def __repr__(self) -> str:
        return f"CollisionView({self.settings!r})" if self.settings is not None else f"CollisionView(unavailable: {self.unavailable})"


def collision_view(robot: Robot, what: str = "self", *, floor: float | None = 0.0, geometry: str = "hulls",
                   srdf=None, skip_home_contacts: bool = False) -> CollisionView | None:
    """What a view of ``robot`` checks: ``what`` is ``"self"``, ``"floor"``, ``"self,floor"`` or ``"none"`` (None).

    Arguments as :meth:`CollisionSettings.parse` (``floor``: height in metres
    in the root link's frame when ``what`` names it). A robot without
    collision geometry (no ``<collision>`` element, a missing mesh) is not an
    error here: the view says once that collisions are unavailable for it.

    Raises
    ------
    CollisionError
        Unknown words in ``what``, a floor without a height, an unknown
        ``geometry``, an SRDF that cannot be read or names unknown links.
    """
    try:
        settings = CollisionSettings.parse(robot, what, floor=floor, geometry=geometry, srdf=srdf,
                                           skip_home_contacts=skip_home_contacts)
    except CollisionError as exc:
        if geometry not in GEOMETRIES:
            raise
        try:
            collision_geometry(robot, geometry)
        except CollisionError as missing:
            if str(missing) == str(exc):  # the geometry itself is what is missing: say so in the view
                return CollisionView(None, str(exc))
        raise
    return None if settings is None else CollisionView(settings)
