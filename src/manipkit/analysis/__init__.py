"""Analysis built on kinematics and closed forms.

Planar workspaces (``workspace``), manipulability indices and ellipsoids
(``manipulability``), the global conditioning index (``dexterity``), the
singular families of the textbook arms (``singularities``), the Jacobian
report of one configuration (``jacobian_report``: ranks, singular or not,
the families that hold, what is lost), reachability maps
(``reachmap``, ``orientations``) and base placement (``placement``).
"""

__all__ = ["dexterity", "jacobian_report", "manipulability", "orientations", "placement", "reachmap", "singularities", "workspace"]
