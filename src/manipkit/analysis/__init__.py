"""Analysis built on kinematics and closed forms: planar workspaces, manipulability and ellipsoids, dexterity (GCI)."""

__all__ = ["dexterity", "manipulability", "workspace"]
