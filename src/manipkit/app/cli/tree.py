"""``manipkit tree``: the link/joint tree as text, Graphviz DOT, PNG or SVG (from :mod:`manipkit.description.tree`).

See docs/architecture.md ("app").
"""

from __future__ import annotations

from pathlib import Path

from manipkit.app.cli.common import EXIT_OK, UsageError, add_robot_options, load_robot

__all__ = ["register", "run_tree"]


def register(commands) -> None:
    """Add ``manipkit tree`` to the subparsers ``commands``."""
    tree = commands.add_parser("tree", help="the link/joint tree as text, Graphviz DOT or an image")
    add_robot_options(tree)
    tree.add_argument("--format", choices=("text", "dot", "png", "svg"), default=None, help="default: from -o's suffix, else text")
    tree.add_argument("-o", "--output", type=Path, default=None, metavar="FILE")
    tree.set_defaults(run=run_tree)


def run_tree(args) -> int:
    """Print the tree, or write it to ``-o`` in the format given or named by the file's suffix."""
    from manipkit.description import tree
    from manipkit.description.tree import parse_structure

    robot = load_robot(args)
    description = parse_structure(robot.urdf)
    fmt = args.format
    if fmt is None:
        fmt = args.output.suffix.lstrip(".").lower() if args.output is not None else "text"
        fmt = {"txt": "text", "gv": "dot"}.get(fmt, fmt)
    if fmt not in ("text", "dot", "png", "svg"):
        raise UsageError(f"tree format '{fmt}': choose text, dot, png or svg")
    if fmt in ("png", "svg"):
        if args.output is None:
            raise UsageError(f"--format {fmt} needs -o FILE.{fmt}")
        path = tree.write_tree_image(description, args.output, fmt=fmt)
        print(f"wrote {path}")
        return EXIT_OK
    text = tree.tree_text(description) if fmt == "text" else tree.tree_dot(description)
    if args.output is not None:
        args.output.write_text(text + ("" if text.endswith("\n") else "\n"))
        print(f"wrote {args.output}")
    else:
        print(text)
    return EXIT_OK
