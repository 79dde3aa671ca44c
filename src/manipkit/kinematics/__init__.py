"""Kinematics of a loaded robot: :class:`Robot` (Pinocchio), batched FK, numerical IK.

The modules load on first use (Pinocchio here, numba in the compiled kernels),
so ``tf-between`` pays only for what it runs.
"""

from __future__ import annotations

__all__ = ["Robot", "load", "ik", "ik_solver", "IKResult", "IKSolutions"]

_HOME = {"Robot": "robot", "load": "robot", "ik": "ik", "ik_solver": "ik", "IKResult": "ik", "IKSolutions": "ik"}


def __getattr__(name: str):
    if name in _HOME:
        import importlib

        return getattr(importlib.import_module(f"manipkit.kinematics.{_HOME[name]}"), name)
    raise AttributeError(f"module 'manipkit.kinematics' has no attribute {name!r}")
