"""``manipkit tree``: the link/joint tree as text, Graphviz DOT, PNG or SVG (from :mod:`manipkit.description.tree`).

See docs/architecture.md ("app").
"""

from __future__ import annotations

import sys
from pathlib import Path

from manipkit.app.cli.common import EXIT_OK, UsageError, add_robot_options, load_robot
from manipkit.outputs import writable_path, write_text

__all__ = ["register", "run_tree"]


def register(commands) -> None:
    """Add ``manipkit tree`` to the subparsers ``commands``."""
    tree = commands.add_parser("tree", help="the link/joint tree as text, Graphviz DOT or an image")
    add_robot_options(tree)
    tree.add_argument("--format", choices=("text", "dot", "png", "svg"), default=None, help="default: from -o's suffix, else text")
    tree.add_argument("-o", "--output", type=Path, default=None, metavar="FILE")
    tree.set_defaults(run=run_tree)


def run_tree(args) -> int:
    """Print the tree, or write it to ``-o`` in the format given or named by the file's suffix.

    The output file is checked (its folder exists, it is not a folder) and
    its format known before the robot is loaded.
    """
    from manipkit.description import tree
    from manipkit.description.tree import parse_structure

    if args.output is not None:
        writable_path(args.output, inputs=(args.robot,))
    fmt = _tree_format(args.format, args.output)
    robot = load_robot(args)
    description = parse_structure(robot.urdf)
    if fmt in ("png", "svg"):
        path = tree.write_tree_image(description, args.output, fmt=fmt)
        print(f"wrote {path}")
        return EXIT_OK
    ascii_only = args.output is None and not _can_encode(sys.stdout, "├└│──")  # LC_ALL=C, PYTHONIOENCODING=ascii
    text = tree.tree_text(description, ascii_only=ascii_only) if fmt == "text" else tree.tree_dot(description)
    if args.output is not None:
        write_text(args.output, text + ("" if text.endswith("\n") else "\n"))
        print(f"wrote {args.output}")
    else:
        print(text)
    return EXIT_OK


def _can_encode(stream, text: str) -> bool:
    """Whether ``stream``'s encoding can write ``text`` (the box-drawing characters of the text tree)."""
    try:
        text.encode(getattr(stream, "encoding", None) or "utf-8")
    except (UnicodeEncodeError, LookupError):
        return False
    return True


def _tree_format(fmt: str | None, output: Path | None) -> str:
    """``--format``, else the one ``-o``'s suffix names (``.txt``, ``.dot``/``.gv``, ``.png``, ``.svg``), else text."""
    if fmt is None and output is not None:
        suffix = output.suffix.lstrip(".").lower()
        if not suffix:
            raise UsageError(f"tree -o {output}: the file name has no suffix to choose a format from; "
                             "name a .txt, .dot, .png or .svg file, or give --format")
        fmt = {"txt": "text", "gv": "dot"}.get(suffix, suffix)
        if fmt not in ("text", "dot", "png", "svg"):
            raise UsageError(f"tree -o {output}: no tree format for '.{suffix}' files; "
                             "name a .txt, .dot, .png or .svg file, or give --format")
    fmt = fmt or "text"
    if fmt in ("png", "svg") and output is None:
        raise UsageError(f"--format {fmt} needs -o FILE.{fmt}")
    return fmt
