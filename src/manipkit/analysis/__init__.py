"""Analysis built on kinematics and closed forms.

Planar workspaces (``workspace``), manipulability indices and ellipsoids
(``manipulability``), the global conditioning index (``dexterity``), the
singular families of the textbook arms (``singularities``), reachability maps
(``reachmap``, ``orientations``) and base placement (``placement``).
"""

__all__ = ["dexterity", "manipulability", "orientations", "placement", "reachmap", "singularities", "workspace"]
