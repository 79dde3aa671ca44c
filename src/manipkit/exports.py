"""How every manipkit package exports its names: listed once, each loaded from its module on first use.

A package's ``__init__.py`` names each public name and the module it lives
in; :func:`lazy_exports` turns that table into the package's ``__all__``,
``__getattr__`` (PEP 562) and ``__dir__``. Importing a package therefore costs
nothing, and a heavy module (Pinocchio, numba, matplotlib, SymPy) loads only
when one of its names is used (docs/architecture.md, "Layers").

Examples
--------
>>> __all__, __getattr__, __dir__ = lazy_exports("manipkit.spatial", {"rot_z": "manipkit.spatial.rotations"})
>>> __getattr__("rot_z").__name__
'rot_z'
"""

from __future__ import annotations

import importlib
from collections.abc import Callable

__all__ = ["homes_of", "lazy_exports"]


def lazy_exports(package: str, homes: dict[str, str]) -> tuple[list[str], Callable[[str], object], Callable[[], list]]:
    """(``__all__``, ``__getattr__``, ``__dir__``) for ``package`` from ``homes``: name -> the module that defines it.

    A name whose home is ``package.name`` itself is that submodule; any
    other submodule is reachable as an attribute as well (loaded then).
    """
    names = sorted(homes)

    def __getattr__(name: str):
        home = homes.get(name)
        if home is None:  # a submodule is an attribute too, as after an eager import (``package.planar.ik_2r``)
            if name.isidentifier() and not name.startswith("_"):
                try:
                    return importlib.import_module(f"{package}.{name}")
                except ModuleNotFoundError as exc:
                    if exc.name != f"{package}.{name}":
                        raise
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module = importlib.import_module(home)
        return module if home == f"{package}.{name}" else getattr(module, name)

    def __dir__() -> list[str]:
        return names

    return names, __getattr__, __dir__


def homes_of(module: str, *names: str) -> dict[str, str]:
    """``{name: module for name in names}``: the rows of a package's table for one of its modules."""
    return dict.fromkeys(names, module)
