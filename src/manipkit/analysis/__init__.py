"""Analysis built on kinematics and closed forms: planar workspaces (later manipulability and maps)."""

__all__ = ["workspace"]
