"""Inverse kinematics: one dispatcher, one result type, the numerical and the chain-bound closed-form solvers.

``manipkit.ik`` is this package and its dispatcher at once:
``manipkit.ik(robot_or_chain, T_base_tip, base=..., tip=..., method="auto", all=False)``
calls :func:`manipkit.ik.dispatch.ik` (the module is callable), and
``manipkit.ik.IKResult`` is the one answer type of every solver.

Above :mod:`manipkit.kinematics` and :mod:`manipkit.closed_form`: the closed
forms here read a chain's axes and hand arrays to the pure math below, and the
textbook arms' solvers (planar 2R/3R, SCARA, Stanford, elbow) turn the pure
math's rows into checked results (docs/architecture.md, "Layers").
"""

from __future__ import annotations

import sys
import types

from manipkit.exports import homes_of, lazy_exports

__all__, _getattr, __dir__ = lazy_exports(__name__, {
    **homes_of("manipkit.ik.result", "IKBatch", "IKFailure", "IKResult"),
    **homes_of("manipkit.ik.dispatch", "ik_many"),
    **homes_of("manipkit.ik.families", "Family", "chain_family"),
    **homes_of("manipkit.ik.numerical", "IKSolver", "ik_solver"),
    **homes_of("manipkit.ik.planar", "ik_2r", "ik_2r_batch", "ik_3r", "ik_3r_batch"),
    **homes_of("manipkit.ik.planar_modes", "ik_2r_pose", "ik_3r_position"),
    **homes_of("manipkit.ik.decoupled", "ik_elbow", "ik_scara", "ik_stanford", "wrist_center"),
})


def __getattr__(name: str):
    return _getattr(name)


class _DispatchingModule(types.ModuleType):
    """This package, callable: ``manipkit.ik(...)`` is :func:`manipkit.ik.dispatch.ik` (``manipkit.ik`` is both)."""

    def __call__(self, *args, **kwargs):
        from manipkit.ik.dispatch import ik

        return ik(*args, **kwargs)


sys.modules[__name__].__class__ = _DispatchingModule
