"""Task paths: can a chain follow a tool path, on which IK branches, how fast, and if not, where and why
(docs/architecture.md, "paths": imports the IK layer and everything below it except dh and closed_form).

Poses are ``T_base_tip`` stacks ``(N, 4, 4)`` in metres; joint paths are ``(N, n)`` in the chain's own joint
order (radians or metres); times in seconds.
"""

from __future__ import annotations

from manipkit.exports import homes_of, lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    **homes_of(
        "manipkit.paths.retiming",
        "BIND_TOL", "CHECK_SUBDIVISIONS", "GRID_POINTS", "MAX_GRID_POINTS", "REFINEMENTS", "REFINE_TOL", "RetimeResult",
        "Slowdown", "retime",
    ),
    **homes_of("manipkit.paths.trajectory", "PROFILES", "Trajectory", "ctraj", "jtraj", "mstraj", "trapezoidal",
               "values_per_item"),
    **homes_of(
        "manipkit.paths.poses",
        "COLLINEAR_TOL", "MAX_POSE_FILE_BYTES", "MAX_WAYPOINTS", "POSE_CSV_COLUMNS", "QUATERNION_NORM_TOL",
        "RIGID_TOL", "PosePath", "arc_poses", "interpolate_pose_pairs", "interpolate_pose_steps", "interpolate_poses",
        "line_poses", "read_pose_path",
    ),
    **homes_of("manipkit.paths.plan", "BranchFailure", "PathPlan", "plan_path"),
    **homes_of("manipkit.paths.timing", "ACCELERATION_TIME", "default_acceleration_limits", "retime_plan",
               "trajectory_dict"),
    **homes_of("manipkit.paths.ladder", "LadderResult", "solve_ladder"),
})
