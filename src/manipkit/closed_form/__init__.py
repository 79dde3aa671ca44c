"""Closed-form inverse kinematics: planar 2R/3R arms and decoupled arms (SCARA, Stanford, elbow).

Pure functions on numbers and DH tables (numpy only); no robot file is
needed. Joint angles are wrapped to (-pi, pi] (docs/architecture.md).
"""

from manipkit.closed_form import decoupled, planar, planar_modes, planar_workspace, result

__all__ = ["decoupled", "planar", "planar_modes", "planar_workspace", "result"]
