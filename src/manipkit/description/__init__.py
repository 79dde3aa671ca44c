"""Robot descriptions: where they come from, xacro, validation, meshes, the link tree.

- :mod:`~manipkit.description.sources`: robot names and paths to description files (:func:`resolve_robot`).
- :mod:`~manipkit.description.packages`: ROS packages without ROS (:class:`PackageResolver`).
- :mod:`~manipkit.description.xacro`: description files to URDF text (:func:`describe`, :func:`urdf_text`).
- :mod:`~manipkit.description.validate`: checks before a model is built (:func:`check_urdf`).
- :mod:`~manipkit.description.meshes`: mesh URIs to files (:func:`mesh_path`).
- :mod:`~manipkit.description.tree`: the link tree as text, DOT and an image (:func:`tree_text`).

Imports only :mod:`manipkit.spatial` and :mod:`manipkit.errors`; Pinocchio is
not loaded here (that is :mod:`manipkit.kinematics`). The names below load
their module on first use, so importing this package costs nothing and lxml,
xacro, yourdfpy and matplotlib load only when needed (docs/architecture.md).
"""

from __future__ import annotations

import importlib

_MODULE_OF = {
    **dict.fromkeys(
        ("DEFAULT_ROBOT", "EXAMPLE_ROBOT_DATA_ARMS", "RobotSource", "bundled_dh_tables", "bundled_dir",
         "bundled_robots", "example_robot_data_arms", "example_robot_data_dir", "example_robot_data_urdfs",
         "resolve_dh_table", "resolve_robot"),
        "manipkit.description.sources",
    ),
    **dict.fromkeys(("PACKAGE_SCHEME", "PackageResolver", "split_package_uri"), "manipkit.description.packages"),
    **dict.fromkeys(
        ("XacroExpansion", "describe", "expand_xacro", "urdf_text", "xacro_arg_declarations", "xacro_locator"),
        "manipkit.description.xacro",
    ),
    **dict.fromkeys(("CheckedURDF", "check_urdf", "package_uri_warnings"), "manipkit.description.validate"),
    **dict.fromkeys(("mesh_path", "urdf_with_mesh_paths"), "manipkit.description.meshes"),
    **dict.fromkeys(("parse_structure", "tree_dot", "tree_text", "write_tree_image"), "manipkit.description.tree"),
}

__all__ = sorted(_MODULE_OF)


def __getattr__(name: str):
    if name in _MODULE_OF:
        return getattr(importlib.import_module(_MODULE_OF[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
