"""``manipkit singularities``: the known singular families of a robot, in words.

The families and their derivations come from
:mod:`manipkit.analysis.singularities` (docs/architecture.md, "analysis"):
the bundled textbook arms (planar 2R and 3R, SCARA, Stanford arm, elbow arm,
iiwa14) are recognised by name and structure, so the same arm loaded from a
URDF file gets them too. For any other robot the command says that none are
known and points to the numeric check of a configuration (``manipkit jacobian``).
"""

from __future__ import annotations

from manipkit.app.cli.common import EXIT_OK, add_robot_options, command_line, load_robot, print_json, robot_words

__all__ = ["register", "run_singularities"]

_ROW_NAMES = ("vx", "vy", "vz", "wx", "wy", "wz")


def register(commands) -> None:
    """Add ``manipkit singularities`` to the subparsers ``commands``."""
    parser = commands.add_parser("singularities", help="the known singular families of a textbook arm, in words")
    add_robot_options(parser)
    parser.add_argument("--format", choices=("text", "json"), default="text")
    parser.set_defaults(run=run_singularities)


def run_singularities(args) -> int:
    """List the robot's singular families (name, condition, what happens), or say none are known."""
    from manipkit.analysis.singularities import KNOWN_ROBOTS, singular_families

    robot = load_robot(args)
    families = singular_families(robot)
    hint = (
        f"no singular families are known for robot {robot.name} (they are for {', '.join(KNOWN_ROBOTS)}); "
        f"check a configuration numerically: {command_line('manipkit', 'jacobian', *robot_words(args, robot))} --q ... "
        "(it says when the Jacobian is singular)"
    )
    if args.format == "json":
        print_json({
            "robot": robot.name,
            "joints": list(robot.joint_names),
            "families": [
                {
                    "name": f.name,
                    "condition": f.condition,
                    "description": f.description,
                    "rows": [_ROW_NAMES[i] for i in f.rows],
                    "unit": f.unit,
                    "reachable": f.reachable,
                }
                for f in families
            ],
            "note": None if families else hint,
        })
        return EXIT_OK
    if not families:
        print(hint)
        return EXIT_OK
    count = f"{len(families)} known singular famil{'y' if len(families) == 1 else 'ies'}"
    print(f"robot {robot.name}: {count} (the ee_link Jacobian loses rank in the rows named)")
    for i, f in enumerate(families, start=1):
        rows = "all rows" if len(f.rows) == 6 else "rows " + ", ".join(_ROW_NAMES[r] for r in f.rows)
        reach = "" if f.reachable else ", outside the joint limits"
        print(f"{i}. {f.name}: {f.condition} ({rows}{reach})")
        print(f"   {f.description}")
    return EXIT_OK
