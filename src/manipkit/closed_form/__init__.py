"""The pure closed-form math of inverse kinematics: planar 2R/3R arms, the Paden-Kahan subproblems, the 6R arms
with a spherical wrist or three parallel axes (UR, OPW) and SRS arms, on arrays.

Pure functions on numbers, arrays and DH tables (numpy; the UR and OPW closed
forms also compiled with numba in arms_kernel, imported when first solved).
Nothing here builds an IK result or reads a chain: the answers as
:class:`manipkit.ik.result.IKResult` (``ik_2r``, ``ik_scara``, ...) and the
chain-bound closed forms are in :mod:`manipkit.ik`. Joint angles are wrapped
to (-pi, pi] (docs/architecture.md).
"""

from __future__ import annotations

from manipkit.exports import homes_of, lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    **homes_of("manipkit.closed_form.planar", "fk_2r", "fk_3r", "solve_planar", "workspace_2r", "workspace_3r"),
    **homes_of("manipkit.closed_form.subproblems", "sp1", "sp2", "sp3", "sp4"),
})
