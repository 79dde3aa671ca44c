"""``manipkit path``: can the arm follow this tool path, on which IK branches, and if not, where and why.

The poses come from a file (``--poses FILE``: CSV ``x,y,z,qx,qy,qz,qw[,t]`` or
YAML, :func:`manipkit.paths.poses.read_pose_path`) or a straight line
(``--line X Y Z R P Y X Y Z R P Y --step M``, rpy in the URDF convention,
:func:`manipkit.paths.poses.line_poses`) or a circular arc (``--arc`` start, via,
end, :func:`manipkit.paths.poses.arc_poses`); the plan is
:func:`manipkit.paths.plan.plan_path` (docs/site/guides/paths.md). Exit
status 0 when the path can be followed, 1 when it cannot (the output says
where and why), 2 for a usage error.
"""

from __future__ import annotations

import math

from manipkit.app.cli.common import (
    EXIT_MISMATCH,
    EXIT_OK,
    UsageError,
    add_joint_options,
    add_robot_options,
    alias_lines,
    command_chain,
    joint_vector,
    load_robot,
    print_json,
)
from manipkit.text import printable, short_text

__all__ = ["motion_csv", "motion_text", "parse_angle", "plan_text", "register", "run_path", "trajectory_csv"]


def register(commands) -> None:
    """Add ``manipkit path`` to the subparsers ``commands``."""
    path = commands.add_parser("path", help="can the arm follow a tool path: every IK branch, the best joint path, "
                                            "or where and why not")
    add_robot_options(path)
    path.add_argument("--tip", "--frame", dest="tip", default="ee_link", help="frame that follows the path (default ee_link)")
    path.add_argument("--base", default="base_link", help="frame the poses are given in (default base_link)")
    source = path.add_mutually_exclusive_group(required=True)
    source.add_argument("--poses", metavar="FILE", help="CSV (x,y,z,qx,qy,qz,qw and optional t) or YAML pose file")
    source.add_argument("--line", type=float, nargs=12, metavar="V",
                        help="a straight line: X Y Z R P Y of the start then of the end (m; rpy rad, or deg with --deg)")
    source.add_argument("--arc", type=float, nargs=18, metavar="V",
                        help="a circular arc: X Y Z R P Y of the start, of a point it passes (via), of the end")
    path.add_argument("--step", type=float, default=None, metavar="M", help="with --line or --arc: largest distance "
                                                                            "between waypoints (m, along the path)")
    path.add_argument("--speed", type=float, default=None, metavar="M/S",
                      help="tool speed along the path (m/s): times the steps, which must fit the joints' velocity "
                           "limits (a file's t is used otherwise)")
    path.add_argument("--velocity-scale", type=float, default=1.0, metavar="S",
                      help="fraction of each joint's URDF velocity limit a step may use (default 1)")
    path.add_argument("--free-axis", choices=("x", "y", "z"), default=None,
                      help="the tool axis the task leaves free: the tool may turn about it")
    path.add_argument("--free-step", default=None, metavar="ANGLE", help="with --free-axis: the angle step, e.g. "
                                                                         "10deg or 0.17 (rad; default 10deg)")
    path.add_argument("--free-range", nargs=2, default=None, metavar=("LOW", "HIGH"),
                      help="with --free-axis: the range of tool angles, e.g. -90deg 90deg (default a full turn)")
    path.add_argument("--arm-angle-step", default="10deg", metavar="ANGLE",
                      help="7R SRS arms (iiwa14): the arm angle sampled over a full turn at this step (default 10deg)")
    path.add_argument("--no-aliases", action="store_true",
                      help="one value per IK branch (the dispatcher's), not every in-limit q + 2 pi k")
    path.add_argument("--path-tol", type=float, nargs=2, default=(1e-3, 1.0), metavar=("M", "DEG"),
                      help="how far a joint-interpolated point between waypoints may be from the path (default 1e-3 m, 1 deg)")
    path.add_argument("--singular-tol", type=float, default=None, metavar="SIGMA",
                      help="drop candidates whose Jacobian's smallest singular value is below SIGMA (m/rad, rad/rad)")
    path.add_argument("--reconfigure", action="store_true",
                      help="allow breaks (retract, reconfigure, resume): the fewest, and where")
    path.add_argument("--collision-free", action="store_true",
                      help="check the path's waypoints and steps for collisions (self, --floor, --world) and plan around them")
    path.add_argument("--collision-step", default="1deg", metavar="ANGLE",
                      help="with --collision-free: steps are checked at samples this far apart in every joint (default 1deg)")
    from manipkit.app.cli.collisions import add_collision_options

    add_collision_options(path)
    add_joint_options(path)
    path.add_argument("--retime", action="store_true",
                      help="with --speed: the fastest motion through every waypoint in order within the joints' "
                           "velocity and acceleration limits and the tool speed (TOPP-RA)")
    path.add_argument("--acceleration-scale", type=float, default=None, metavar="S",
                      help="with --retime: each joint's acceleration limit is S x its velocity limit per 0.5 s "
                           "(a URDF gives none; default 1)")
    path.add_argument("--plot", default=None, metavar="FILE.png",
                      help="draw the joints along the path between their limits, and the singularity margin")
    path.add_argument("--map", default=None, metavar="FILE.png",
                      help="with --free-axis: draw the waypoint x tool angle feasibility map, coloured by kind")
    path.add_argument("--view-html", default=None, metavar="FILE.html",
                      help="write a standalone meshcat page: the tool path drawn, the arm animated along the joint "
                           "path (on a path that fails: the path, its first failure marked, the arm at rest)")
    path.add_argument("--view", action="store_true",
                      help="show the same scene as --view-html in meshcat, live, until Ctrl-C")
    path.add_argument("--format", choices=("text", "json"), default="text")
    path.add_argument("-o", "--output", default=None, metavar="FILE",
                      help="write the joint path as CSV (t, joints); with --retime the trajectory (t, q, qd, qdd)")
    path.add_argument("--progress", choices=("yes", "no", "auto"), default="auto",
                      help="progress bars on stderr (auto: when it is a terminal)")
    from manipkit.app.cli.path_place import add_place_options

    add_place_options(path)
    path.set_defaults(run=run_path)


def parse_angle(text: str, option: str, *, degrees: bool = False) -> float:
    """An angle option in radians: ``10deg``, ``0.5rad``, or a bare number (rad; deg with ``degrees``)."""
    word = str(text).strip().lower()
    unit_deg = degrees
    for suffix, is_deg in (("deg", True), ("rad", False)):
        if word.endswith(suffix):
            word, unit_deg = word[: -len(suffix)].strip(), is_deg
            break
    try:
        value = float(word)
    except ValueError:
        raise UsageError(f"{option} {printable(str(text))[:40]}: give an angle, e.g. 10deg or 0.17 (rad)") from None
    if not math.isfinite(value):
        raise UsageError(f"{option} {printable(str(text))[:40]}: give a finite angle")
    return math.radians(value) if unit_deg else value


def _poses(args):
    """(poses (N, 4, 4), t or None) from --poses, --line or --arc."""
    import numpy as np

    from manipkit.paths.poses import arc_poses, line_poses, read_pose_path
    from manipkit.spatial.transforms import transform_from_xyz_rpy

    if args.poses is not None:
        if args.step is not None:
            raise UsageError("--step applies to --line and --arc; a pose file gives its own waypoints")
        path = read_pose_path(args.poses)
        return np.asarray(path.poses), None if path.t is None else np.asarray(path.t)
    option, values = ("--line", args.line) if args.line is not None else ("--arc", args.arc)
    if not all(math.isfinite(v) for v in values):
        raise UsageError(f"{option}: give {len(values)} finite numbers (X Y Z R P Y of each pose)")
    if args.step is None:
        raise UsageError(f"{option} needs --step M, the largest distance between waypoints (m)")
    ends = [transform_from_xyz_rpy(values[k:k + 3], [math.radians(v) if args.deg else v for v in values[k + 3:k + 6]])
            for k in range(0, len(values), 6)]
    if option == "--arc":
        return arc_poses(*ends, step=args.step), None
    return line_poses(*ends, step=args.step), None


def _checker(robot, args):
    if not args.collision_free:
        if args.world is not None:
            raise UsageError("--world applies with --collision-free (the path is checked against it then)")
        return None
    from manipkit.app.cli.collisions import collision_checker

    return collision_checker(robot, args)


def run_path(args) -> int:
    """Plan the path and print the plan (text or JSON), optionally writing the joint path (``-o``)."""
    from manipkit.analysis.reachmap.pathplace import shifted_poses
    from manipkit.app.cli.path_place import check_place_options, offset_of
    from manipkit.app.progress import progress_bar
    from manipkit.paths.plan import plan_path

    if args.speed is not None:
        from manipkit import bounds

        bounds.speed(args.speed, "--speed", error=UsageError)
    robot = load_robot(args, mesh_warnings=args.view_html is None and not args.view)  # the views say it, once
    chain = command_chain(robot, args.base, args.tip)
    poses, t = _poses(args)
    if args.offset is not None:
        poses = shifted_poses(poses, offset_of(args))
    if args.speed is not None and t is not None:
        t = None  # --speed given: it times the steps, not the file's t
    checker = _checker(robot, args)
    q0 = joint_vector(robot, args) if args.q else None
    free_step = None if args.free_step is None else parse_angle(args.free_step, "--free-step", degrees=args.deg)
    free_range = None if args.free_range is None else tuple(
        parse_angle(v, "--free-range", degrees=args.deg) for v in args.free_range)
    if args.free_axis is None and (free_step is not None or free_range is not None):
        raise UsageError("--free-step and --free-range apply with --free-axis x|y|z")
    position_tol, angle_tol = args.path_tol
    _check_retime(args)
    _check_pictures(args)
    if args.output is not None:
        from manipkit.outputs import writable_path

        writable_path(args.output, inputs=[args.poses, args.world])
    check_place_options(args)
    options = dict(t=t, speed=args.speed, velocity_scale=args.velocity_scale, free_axis=args.free_axis,
                   free_step=free_step, free_range=free_range,
                   arm_angle_step=parse_angle(args.arm_angle_step, "--arm-angle-step"), aliases=not args.no_aliases,
                   reconfigure=args.reconfigure, collisions=checker,
                   collision_step=parse_angle(args.collision_step, "--collision-step"),
                   path_tol=(position_tol, math.radians(angle_tol)), singular_tol=args.singular_tol, q0=q0)
    if args.place:
        from manipkit.app.cli.path_place import run_place

        return run_place(args, robot, poses, options)
    with progress_bar({"yes": True, "no": False, "auto": None}[args.progress]) as progress:
        plan = plan_path(robot, poses, base=args.base, tip=args.tip, progress=progress, **options)
    motion = None
    if args.retime and plan.feasible:
        from manipkit.paths.timing import retime_plan

        scale = 1.0 if args.acceleration_scale is None else args.acceleration_scale
        motion = retime_plan(plan, chain, speed=args.speed, acceleration_scale=scale)
    if args.output is not None and plan.feasible:
        from manipkit.outputs import write_text

        csv = trajectory_csv(plan) if motion is None else motion_csv(motion, chain)
        write_text(args.output, csv, inputs=[args.poses, args.world])
    drawn = _draw(args, plan, motion, robot)
    if args.view_html is not None:
        drawn.append(_view_html(args, plan, poses, robot, chain, q0))
    if args.format == "json":
        answer = plan.as_dict()
        if args.retime:
            from manipkit.paths.timing import trajectory_dict

            answer["trajectory"] = None if motion is None else trajectory_dict(motion)
        print_json(answer)
    else:
        for line in alias_lines(robot, args.base, args.tip):
            print(line)
        print(plan_text(plan, robot=robot.name, base=args.base, tip=args.tip, speed=args.speed,
                        written=args.output if plan.feasible and motion is None else None))
        if motion is not None:
            print(motion_text(motion, speed=args.speed, written=args.output, velocity_scale=args.velocity_scale,
                              acceleration_scale=1.0 if args.acceleration_scale is None else args.acceleration_scale))
        for line in drawn:
            print(line)
    if args.view:
        _serve_view(args, plan, poses, robot, chain, q0)
    return EXIT_OK if plan.feasible else EXIT_MISMATCH


def _check_retime(args) -> None:
    """Usage errors of --retime and --acceleration-scale, before any planning."""
    if not args.retime:
        if args.acceleration_scale is not None:
            raise UsageError("--acceleration-scale applies with --retime")
        return
    if args.speed is None:
        raise UsageError("--retime needs --speed M/S, the tool speed the motion may not exceed")
    if args.reconfigure:
        raise UsageError("--retime with --reconfigure: a path with breaks is retimed piece by piece (in Python)")
    scale = args.acceleration_scale
    if scale is not None and not (math.isfinite(scale) and 0 < scale <= 1e6):
        raise UsageError(f"--acceleration-scale {short_text(scale)}: give a positive factor")


def _check_pictures(args) -> None:
    """Usage errors of --plot, --map and --view-html, before any planning."""
    from manipkit.outputs import distinct_outputs, writable_path

    if args.map is not None and args.free_axis is None:
        raise UsageError("--map draws waypoint x tool angle: give --free-axis x|y|z")
    for option, name in (("--plot", args.plot), ("--map", args.map)):
        if name is not None:
            if not str(name).lower().endswith(".png"):
                raise UsageError(f"{option} {printable(str(name))[:60]}: give a .png file name")
            writable_path(name, inputs=[args.poses, args.world, args.output])
    if args.view_html is not None:
        writable_path(args.view_html, inputs=[args.poses, args.world, args.output])
    distinct_outputs([("-o", args.output), ("--plot", args.plot), ("--map", args.map), ("--view-html", args.view_html)])


def _draw(args, plan, motion, robot) -> list[str]:
    """Write the pictures asked for; the lines that say so (the joint plot only of a feasible plan)."""
    from manipkit.app import path_plots

    lines = []
    inputs = [args.poses, args.world]
    if args.plot is not None and plan.feasible:
        path_plots.joint_plot(plan, robot.chain(args.base, args.tip), args.plot, motion=motion, inputs=inputs,
                              title=f"{robot.name}: {args.tip} along the path")
        lines.append(f"joint plot written to {printable(str(args.plot))}")
    elif args.plot is not None:
        lines.append(f"no joint plot: no joint path ({printable(str(args.plot))} not written)")
    if args.map is not None:
        path_plots.feasibility_map(plan, args.map, free_axis=args.free_axis, inputs=inputs,
                                   title=f"{robot.name}: {args.tip}, waypoint x tool angle about {args.free_axis}")
        lines.append(f"feasibility map written to {printable(str(args.map))}")
    return lines


def _path_picture(args, plan, poses, chain, q0) -> dict:
    """What the path's meshcat scene is handed (:func:`manipkit.app.viewer.path_scene.path_scene`): the poses and,
    on a plan, its whole-robot rows (the chain's joints from the plan, the others at --q or their defaults) and
    times; on a failed plan, the pose at rest and the first failure."""
    if not plan.feasible:
        return {"poses": poses, "base": args.base, "tip": args.tip, "q": q0, "first_failure": plan.first_failure}
    return {"poses": poses, "rows": [chain.full(q, q0) for q in plan.q], "base": args.base, "tip": args.tip,
            "times": plan.t}


def _picture_words(plan) -> str:
    """What the path's scene shows, in words."""
    from manipkit.app.viewer.path_scene import UNTIMED_STEP

    if not plan.feasible:
        failed = "" if plan.first_failure is None else f", waypoint {plan.first_failure} marked red"
        return f"the path only{failed}: no joint path to animate"
    timing = "at the waypoint times" if plan.t is not None else f"{short_text(UNTIMED_STEP)} s per waypoint (untimed)"
    return f"the arm along the joint path, {timing}, in a loop"


def _view_html(args, plan, poses, robot, chain, q0) -> str:
    """Write the --view-html page; the line that says so."""
    from manipkit.app.viewer.path_scene import write_path_html

    write_path_html(robot, args.view_html, **_path_picture(args, plan, poses, chain, q0), inputs=[args.poses, args.world])
    return f"path view written to {printable(str(args.view_html))} ({_picture_words(plan)})"


def _serve_view(args, plan, poses, robot, chain, q0) -> None:
    """Show the path's scene in its own meshcat server until Ctrl-C or SIGTERM (its lines on stderr after JSON)."""
    import sys

    from manipkit.app.viewer.path_scene import path_scene
    from manipkit.app.viewer.reachmap_scene import serve_until_stopped

    stream = sys.stderr if args.format == "json" else sys.stdout
    scene = path_scene(robot, **_path_picture(args, plan, poses, chain, q0))
    print(f"meshcat scene: {scene.url}", file=stream, flush=True)
    controls = " (meshcat's controls: Animations)" if plan.feasible else ""
    print(f"{_picture_words(plan)}{controls}; Ctrl-C stops", file=stream, flush=True)
    serve_until_stopped(scene)
    print("viewer stopped", file=stream, flush=True)


def motion_csv(motion, chain) -> str:
    """The retimed trajectory as CSV: ``t[s]``, then ``q.<joint>[rad]``, ``qd.<joint>[rad/s]``,
    ``qdd.<joint>[rad/s^2]`` for every joint in chain order (m for a prismatic joint), one row per sample."""
    units = ["rad" if joint.is_angular else "m" for joint in chain.joints]
    head = ["t[s]"] + [f"{kind}.{name}[{unit}{suffix}]" for kind, suffix in (("q", ""), ("qd", "/s"), ("qdd", "/s^2"))
                       for name, unit in zip(motion.joint_names, units)]
    lines = [",".join(head)]
    for row in zip(motion.t, motion.q, motion.qd, motion.qdd):
        lines.append(",".join([repr(float(row[0]))] + [repr(float(v)) for part in row[1:] for v in part]))
    return "\n".join(lines) + "\n"


def motion_text(motion, *, speed, written=None, most: int = 8, velocity_scale: float = 1.0,
                acceleration_scale: float = 1.0) -> str:
    """The retimed motion in words: how long, within what, and where and why it slows down."""
    from manipkit.paths.timing import ACCELERATION_TIME

    lines = [f"RETIMED (TOPP-RA): {short_text(motion.duration, 6)} s through {len(motion.waypoint_times)} waypoints in "
             f"order, rest to rest, {len(motion.t)} samples"]
    lines.append(f"  limits: {short_text(velocity_scale)} x each joint's URDF velocity limit v; acceleration "
                 f"{short_text(acceleration_scale)} x v / {short_text(ACCELERATION_TIME)} s (the URDF gives none); "
                 f"tool at most {short_text(speed)} m/s")
    tool = "" if motion.max_tool_speed is None else (f", tool speed at most {short_text(motion.max_tool_speed, 4)} "
                                                     f"m/s (asked {short_text(speed)})")
    lines.append(f"  peaks: {short_text(100 * motion.max_velocity_ratio, 4)}% of a velocity limit, "
                 f"{short_text(100 * motion.max_acceleration_ratio, 4)}% of an acceleration limit{tool}")
    for line in motion.explain()[1:]:
        if not line.startswith("waypoints "):
            lines.append("  " + line)
    slow = motion.slowdowns
    runs = _binding_runs(motion)
    lines.append(f"  where it slows down ({len(slow)} (segment, limit) pair(s) bind, over "
                 f"{len({s.segment for s in slow})} of {len(motion.waypoint_times) - 1} segment(s)):" if slow
                 else "  no limit binds")
    for words in runs[:most]:
        lines.append("    " + words)
    if len(runs) > most:
        lines.append(f"    ... and {len(runs) - most} more (--format json: trajectory.slowdowns)")
    if written:
        lines.append(f"trajectory (t, q, qd, qdd) written to {printable(str(written))}")
    return "\n".join(lines)


def _binding_runs(motion) -> list[str]:
    """Each binding limit over runs of consecutive segments, in words, longest binding time first: "the tool
    speed limit binds on waypoints 0-10 for 95 % of their time"."""
    import numpy as np

    seconds = np.diff(np.asarray(motion.waypoint_times))
    found: dict = {}
    for item in motion.slowdowns:
        found.setdefault((item.limit, item.joint), []).append(item)
    runs = []
    for (limit, joint), items in found.items():
        items = sorted(items, key=lambda item: item.segment)
        start = 0
        for k in range(1, len(items) + 1):
            if k == len(items) or items[k].segment != items[k - 1].segment + 1:
                run = items[start:k]
                first, last = run[0].segment, run[-1].segment
                span = float(seconds[first:last + 1].sum())
                bound = sum(item.share * float(seconds[item.segment]) for item in run)
                what = "the tool speed" if joint is None else f"{joint}'s {limit}"
                share = 100 * bound / span if span > 0 else 100.0
                runs.append((-bound, first, f"{what} limit binds on waypoints {first}-{last + 1} for "
                                            f"{share:.0f} % of their {short_text(span, 3)} s"))
                start = k
    return [words for _, _, words in sorted(runs)]


def trajectory_csv(plan) -> str:
    """The joint path as CSV: a header ``waypoint[,t],<joint names>`` and one row per waypoint (rad or m, s)."""
    head = ["waypoint"] + (["t"] if plan.t is not None else []) + list(plan.joint_names)
    lines = [",".join(head)]
    for i, q in enumerate(plan.q):
        row = [str(i)] + ([repr(float(plan.t[i]))] if plan.t is not None else []) + [repr(float(v)) for v in q]
        lines.append(",".join(row))
    return "\n".join(lines) + "\n"


def _failure_words(record, names_of_kind: dict) -> str:
    what = names_of_kind[record.kind]
    text = f"{record.count} {what}"
    if record.kind == "velocity":
        text += f" (best step: {record.joint} at {short_text(record.ratio, 3)} x its velocity limit)"
    elif record.kind == "joint_limits" and record.joint:
        text += f" (most often {record.joint})"
    elif record.kind == "collision" and record.pairs:
        text += " (" + ", ".join(f"{a} - {b}" for a, b in record.pairs[:3]) + ")"
    elif record.kind == "near_singular":
        text += f" (smallest singular value {short_text(record.ratio, 3)})"
    return text


KIND_WORDS = {
    "unreachable": "target sample(s) with no IK branch (unreachable)",
    "joint_limits": "branch(es) outside a joint's limits",
    "collision": "candidate(s) in collision",
    "near_singular": "candidate(s) near a singularity",
    "velocity": "candidate(s) with every step in too fast for a joint's velocity limit",
    "deviation": "candidate(s) whose every step in leaves the path between waypoints",
    "unfinished": "re-plan(s) done when max_replans ran out, the last path failing a check here",
}


def plan_text(plan, *, robot: str, base: str, tip: str, speed=None, written=None) -> str:
    """The plan in words: what was planned, at what resolution, optimal for which cost, where and why it fails."""
    r = plan.resolution
    lines = [f"path of {r['waypoints']} waypoints for frame {tip} in {base} on {robot} "
             f"({len(plan.joint_names)} joints)"]
    samples = [f"{r['tool_angles']} tool angle(s) about the free axis"] if r["tool_angles"] > 1 else []
    if r["arm_angles"]:
        samples.append(f"{r['arm_angles']} arm angle(s)")
    lines.append(f"searched: {r['method']}{' at ' + ' x '.join(samples) if samples else ''}, "
                 f"{'with every in-limit 2 pi alias' if r['aliases'] else 'one value per branch (no 2 pi aliases)'}: "
                 f"{r['candidates']} candidates, {r['edges']} edges evaluated (none stored)")
    if not r["timed"]:
        lines.append("timing: none given (no --speed, no t): steps are not bounded by the joints' velocity limits")
    elif speed is not None:
        lines.append(f"timing: tool at {short_text(speed)} m/s; each step within {short_text(r['velocity_scale'])} "
                     "x every joint's URDF velocity limit")
    else:
        lines.append(f"timing: the file's t; each step within {short_text(r['velocity_scale'])} x every joint's URDF "
                     "velocity limit")
    tol = r["path_tol"]
    lines.append(f"between waypoints: {2 ** r['depth'] - 1} joint-interpolated points per step must lie within "
                 f"{short_text(tol[0])} m and {short_text(math.degrees(tol[1]))} deg of the path "
                 f"({plan.deviation_points} checked)")
    if r["collision_step"] is not None:
        lines.append(f"collisions: waypoints and steps (samples {short_text(math.degrees(r['collision_step']))} deg "
                     f"apart in every joint) checked: {plan.collision_checks} configurations, "
                     f"{plan.replans} re-plan(s)")
    if plan.feasible:
        lines.append(f"FEASIBLE: the least {r['cost']} over these candidates, {short_text(plan.cost, 6)} "
                     "(optimal for that cost at this resolution)")
        if plan.max_velocity_ratio is not None:
            lines.append(f"fastest joint step: {short_text(100 * plan.max_velocity_ratio, 4)}% of its allowed speed")
        if plan.reconfigurations:
            where = ", ".join(str(i) for i in plan.reconfigurations)
            lines.append(f"{len(plan.reconfigurations)} reconfiguration(s) (retract, reconfigure, resume), the fewest "
                         f"possible: resuming at waypoint(s) {where}")
        lines.append("start: " + " ".join(f"{n}={short_text(float(v), 6)}" for n, v in zip(plan.joint_names, plan.q[0])))
        lines.append("end:   " + " ".join(f"{n}={short_text(float(v), 6)}" for n, v in zip(plan.joint_names, plan.q[-1])))
        if written:
            lines.append(f"joint path written to {printable(str(written))}")
    elif plan.first_failure is None:
        lines.append(f"NOT FOUND: {plan.replans} re-plans ran out before a path cleared its checks (nothing is "
                     "proven: a path may exist)")
    else:
        i = plan.first_failure
        lines.append(f"NOT FEASIBLE: no candidate survives at waypoint {i} (counting from 0)")
        for record in plan.failures[i]:
            lines.append(f"  waypoint {i}: " + _failure_words(record, KIND_WORDS))
    earlier = [(i, f) for i, fs in enumerate(plan.failures) for f in fs if plan.feasible or i != plan.first_failure]
    if earlier:
        lines.append(f"candidates that died along the way: at {len({i for i, _ in earlier})} waypoint(s), first:")
        for i, record in earlier[:5]:
            lines.append(f"  waypoint {i}: " + _failure_words(record, KIND_WORDS))
    return "\n".join(lines)
