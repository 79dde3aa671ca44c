"""``manipkit workspace``: reachable and dexterous workspace of a planar 2R/3R arm, with a plot.

The numbers and the plot come from :mod:`manipkit.analysis.workspace`
(docs/architecture.md, "analysis").
"""

from __future__ import annotations

from pathlib import Path

from manipkit.app.cli.common import EXIT_OK, UsageError, add_robot_options, load_robot, print_json
from manipkit.outputs import writable_path
from manipkit.text import short_text

__all__ = ["register", "run_workspace"]


def register(commands) -> None:
    """Add ``manipkit workspace`` to the subparsers ``commands``."""
    workspace = commands.add_parser("workspace", help="reachable and dexterous workspace of a planar 2R/3R arm, with a plot")
    add_robot_options(workspace)
    workspace.add_argument("--plot", type=Path, default=None, metavar="FILE.png", help="draw sampled points, boundary circles and a few poses")
    workspace.add_argument("--samples", type=int, default=20000, metavar="N", help="random configurations drawn for the plot (default 20000)")
    workspace.add_argument("--format", choices=("text", "json"), default="text")
    workspace.set_defaults(run=run_workspace)


def run_workspace(args) -> int:
    """Print the link lengths and the workspace's description (text or JSON); draw it to ``--plot``."""
    from manipkit.analysis.workspace import planar_link_lengths, planar_workspace, plot_planar_workspace

    if args.samples < 1:
        raise UsageError(f"--samples {args.samples}: give at least 1")
    if args.plot is not None:
        writable_path(args.plot, inputs=(args.robot,))  # before the robot is loaded; no folder is ever created
    robot = load_robot(args)
    lengths = planar_link_lengths(robot)
    workspace = planar_workspace(lengths)
    intervals = [list(interval) for interval in workspace.dexterous]
    if args.plot is not None:
        plot_planar_workspace(lengths, args.plot, n_samples=args.samples)
    if args.format == "json":
        out = {
            "robot": robot.name,
            "lengths": list(lengths),
            "reachable": list(workspace.reachable),
            "dexterous": intervals[0] if len(intervals) == 1 else (None if not intervals else intervals),
            "description": workspace.description,
        }
        if args.plot is not None:
            out["plot"] = str(args.plot)
        print_json(out)
    else:
        print(f"robot {robot.name}: planar arm with link lengths {', '.join(short_text(v) for v in lengths)} m")
        print(workspace.description)
        if args.plot is not None:
            print(f"wrote {args.plot}")
    return EXIT_OK
