"""Kinematics of a loaded robot: :class:`Robot` (Pinocchio), the joint vector (mimic, floating and planar joints),
batched FK, Jacobians, numerical IK (one target, or many in one compiled call).

The modules load on first use (Pinocchio here, numba in the compiled kernels),
so ``tf-between`` pays only for what it runs.
"""

from __future__ import annotations

__all__ = ["Robot", "load", "ik", "ik_solver", "IKResult", "IKSolutions", "ik_many", "IKBatch"]

_HOME = {"Robot": "robot", "load": "robot", "ik": "ik", "ik_solver": "ik", "IKResult": "ik", "IKSolutions": "ik",
         "ik_many": "ik_many", "IKBatch": "ik_many"}


def __getattr__(name: str):
    if name in _HOME:
        import importlib

        return getattr(importlib.import_module(f"manipkit.kinematics.{_HOME[name]}"), name)
    raise AttributeError(f"module 'manipkit.kinematics' has no attribute {name!r}")
