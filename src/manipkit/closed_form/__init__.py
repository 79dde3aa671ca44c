"""Closed-form inverse kinematics: planar 2R/3R arms, decoupled arms (SCARA, Stanford, elbow), and any 6R chain
with a spherical wrist or three parallel axes, found from its geometry.

Pure functions on numbers and DH tables (numpy; the UR and OPW closed forms
also compiled with numba in arms_kernel, imported when first solved); the
geometric closed forms (families, chain_ik) are given a chain object and read
its axes. Joint angles are wrapped to (-pi, pi] (docs/architecture.md).
"""

from __future__ import annotations

from manipkit.exports import homes_of, lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    **homes_of("manipkit.closed_form.planar", "fk_2r", "fk_3r", "ik_2r", "ik_2r_batch", "ik_3r", "ik_3r_batch",
               "workspace_2r", "workspace_3r"),
    **homes_of("manipkit.closed_form.planar_modes", "ik_2r_pose", "ik_3r_position"),
    **homes_of("manipkit.closed_form.decoupled", "ik_elbow", "ik_scara", "ik_stanford", "wrist_center"),
    **homes_of("manipkit.closed_form.subproblems", "sp1", "sp2", "sp3", "sp4"),
})
