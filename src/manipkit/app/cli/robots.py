"""``manipkit robots`` (every robot ``--robot`` can name) and ``manipkit frames`` (one robot's frames and joints).

Tables drawn with rich; numbers as :mod:`manipkit.text` writes them
(docs/architecture.md, "app"). Names are printed as written: rich's markup
(``[bold]``), emoji codes (``:smile:``) and highlighting are off, so a name
such as ``[/]`` is text, not a (broken) style tag.
"""

from __future__ import annotations

from manipkit.app.cli.common import EXIT_OK, add_robot_options, load_robot
from manipkit.errors import ManipkitError
from manipkit.text import short_text

__all__ = ["register", "run_frames", "run_robots"]


def register(commands) -> None:
    """Add ``manipkit robots`` and ``manipkit frames`` to the subparsers ``commands``."""
    robots = commands.add_parser("robots", help="bundled and example-robot-data robots with DOF and frames")
    robots.set_defaults(run=run_robots)
    frames = commands.add_parser("frames", help="links/frames and joints (type, axis, parent/child, limits)")
    add_robot_options(frames)
    frames.set_defaults(run=run_frames)


def run_robots(args) -> int:
    """A table of the bundled and example-robot-data robots: DOF, base_link, ee_link, file."""
    from rich.table import Table

    import manipkit
    from manipkit.description.sources import bundled_robots, example_robot_data_arms

    table = Table(title="robots (--robot NAME); any .urdf/.xacro/MJCF .xml path works too")
    for column in ("name", "from", "DOF", "base_link", "ee_link", "file"):
        table.add_column(column)
    entries = [(name, "bundled") for name in bundled_robots()] + [(name, "example-robot-data") for name in example_robot_data_arms()]
    for name, origin in entries:
        try:
            robot = manipkit.load(name)
        except ManipkitError as exc:
            table.add_row(name, origin, "?", "?", "?", f"cannot load: {exc}")
            continue
        base = robot.base_link if robot.base_link == "base_link" else f"{robot.base_link} (root)"
        table.add_row(name, origin, str(len(robot.joints)), base, robot.ee_frame, robot.source.path.name)
    _console().print(table)
    return EXIT_OK


def run_frames(args) -> int:
    """The robot's frames, then a table of its movable joints (type, axis, parent -> child, limits)."""
    from rich.table import Table

    robot = load_robot(args)
    console = _console()
    console.print(f"robot {robot.name}: {len(robot.frame_names)} frames; base_link = {_base_text(robot)}; "
                  f"ee_link = {robot.ee_reason}")
    if robot.mimic_joints:
        console.print("mimic joints (no value of their own): " + "; ".join(
            f"{m.name} = {short_text(m.multiplier)} {m.leader} + {short_text(m.offset)}" for m in robot.mimic_joints.values()))
    console.print("frames: " + ", ".join(robot.frame_names))
    table = Table(title=f"movable joints of {robot.name} (radians / metres)")
    for column in ("#", "joint", "type", "axis", "parent -> child", "lower", "upper"):
        table.add_column(column)
    for index, joint in enumerate(robot.joints):
        table.add_row(
            str(index), joint.name, joint.type, " ".join(short_text(a) for a in joint.axis),
            f"{joint.parent} -> {joint.child}", short_text(joint.lower), short_text(joint.upper),
        )
    console.print(table)
    return EXIT_OK


def _base_text(robot) -> str:
    """Which link ``base_link`` means: the link of that name, else the root (said so)."""
    return robot.base_link if robot.base_link == "base_link" else f"{robot.base_link} (the root; no link named base_link)"


def _console():
    """A rich console that prints text as written (no markup, emoji codes or highlighting), 160 columns."""
    from rich.console import Console

    return Console(width=160, markup=False, emoji=False, highlight=False)
