"""Analysis built on kinematics and closed forms.

Planar workspaces (``workspace``), manipulability indices and ellipsoids
(``manipulability``), the global conditioning index (``dexterity``), the
singular families of the textbook arms (``singularities``), the Jacobian
report of one configuration (``jacobian_report``: ranks, singular or not,
the families that hold, what is lost), reachability maps and
base placement (the ``reachmap`` package) and the allowed-collision matrix (``acm``).
"""

from __future__ import annotations

from manipkit.exports import homes_of, lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    **homes_of(
        "manipkit.analysis.dexterity",
        "ConditioningIndex", "generic_rank", "global_conditioning_index", "rank",
    ),
    **homes_of("manipkit.analysis.jacobian_report", "JacobianReport", "jacobian_report"),
    **homes_of(
        "manipkit.analysis.manipulability",
        "force_ellipsoid", "manipulability", "singular_values", "velocity_ellipsoid",
    ),
    **homes_of("manipkit.analysis.singularities", "families_at", "singular_families"),
    **homes_of("manipkit.analysis.reachmap.map", "ReachMap"),
    **homes_of("manipkit.analysis.reachmap.builder", "build"),
    **homes_of("manipkit.analysis.reachmap.placement", "BasePlacement", "base_placement"),
    **homes_of("manipkit.analysis.workspace", "planar_workspace"),
    **homes_of("manipkit.analysis.acm", "CollisionMatrix", "allowed_collision_matrix", "srdf_text"),
})
