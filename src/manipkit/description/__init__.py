"""Robot descriptions: where they come from, xacro, validation, meshes, the link tree.

- :mod:`~manipkit.description.sources`: robot names and paths to description files (:func:`resolve_robot`).
- :mod:`~manipkit.description.packages`: ROS packages without ROS (:class:`PackageResolver`).
- :mod:`~manipkit.description.access`: what a description may read (:class:`ReadPolicy`, ``--allow-read``).
- :mod:`~manipkit.description.xacro`: description files to URDF text (:func:`describe`, :func:`urdf_text`).
- :mod:`~manipkit.description.mjcf`: MuJoCo MJCF files compiled by MuJoCo, written out as URDF text (:func:`mjcf_urdf`).
- :mod:`~manipkit.description.validate`: checks before a model is built (:func:`check_urdf`).
- :mod:`~manipkit.description.meshes`: mesh URIs to files (:func:`mesh_path`); links whose meshes are missing drawn
  another way (:func:`visual_urdf`).
- :mod:`~manipkit.description.mesh_colours`: a DAE visual mesh as triangles with a colour per vertex, what the
  viewer sends (:func:`coloured_triangles`).
- :mod:`~manipkit.description.tree`: the link tree as text, DOT and an image (:func:`tree_text`).

Imports only :mod:`manipkit.spatial` and :mod:`manipkit.errors`; Pinocchio is
not loaded here (that is :mod:`manipkit.kinematics`). The names below load
their module on first use, so importing this package costs nothing and lxml,
xacro, mujoco, yourdfpy, pycollada and matplotlib load only when needed (docs/architecture.md).
"""

from __future__ import annotations

from manipkit.exports import homes_of, lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    **homes_of(
        "manipkit.description.sources",
        "DEFAULT_ROBOT", "EXAMPLE_ROBOT_DATA_ARMS", "RobotSource", "bundled_dh_tables", "bundled_dir",
        "bundled_robots", "example_robot_data_arms", "example_robot_data_dir", "example_robot_data_urdfs",
        "resolve_dh_table", "resolve_robot",
    ),
    **homes_of("manipkit.description.packages", "PACKAGE_SCHEME", "PackageResolver", "split_package_uri"),
    **homes_of("manipkit.description.access", "ReadPolicy"),
    **homes_of(
        "manipkit.description.xacro",
        "XacroExpansion", "describe", "expand_xacro", "urdf_text", "xacro_arg_declarations", "xacro_locator",
    ),
    **homes_of("manipkit.description.mjcf", "mjcf_disabled_pairs", "mjcf_rules", "mjcf_urdf", "rules_source_text"),
    **homes_of("manipkit.description.validate", "CheckedURDF", "check_urdf", "package_uri_warnings"),
    **homes_of("manipkit.description.mesh_colours", "ColouredMesh", "coloured_triangles"),
    **homes_of("manipkit.description.meshes", "MissingMeshWarning", "MissingMeshes", "mesh_path", "urdf_with_mesh_paths",
               "visual_urdf"),
    **homes_of("manipkit.description.tree", "parse_structure", "tree_dot", "tree_text", "write_tree_image"),
})
