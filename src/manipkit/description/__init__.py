"""Robot descriptions: where they come from (names, paths, ROS packages), xacro, validation, the link tree.

Imports only :mod:`manipkit.spatial` and :mod:`manipkit.errors`; Pinocchio is
not loaded here (that is :mod:`manipkit.kinematics`).
"""
