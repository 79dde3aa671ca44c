"""``manipkit collisions`` (is this configuration in collision?) and ``manipkit acm`` (the allowed-collision matrix).

The checks are :func:`manipkit.kinematics.collisions.collisions` and the
matrix :func:`manipkit.analysis.acm.allowed_collision_matrix`
(docs/architecture.md, "Collisions"); this module parses and formats.
Distances are in metres (negative: penetration depth), witness points in the
robot's root link frame.
"""

from __future__ import annotations

import math

from manipkit.app.cli.common import (
    EXIT_OK,
    UsageError,
    add_joint_options,
    add_robot_options,
    joint_vector,
    load_robot,
    print_json,
    warn,
)
from manipkit.app.collision_text import collision_lines, geometry_lines, left_out_lines
from manipkit.text import printable

__all__ = ["add_collision_options", "add_collision_set_options", "collision_checker", "collision_set", "parse_floor",
           "register", "run_acm", "run_collisions"]


def register(commands) -> None:
    """Add ``manipkit collisions`` and ``manipkit acm`` to the subparsers ``commands``."""
    parser = commands.add_parser(
        "collisions", help="self-collision (and floor, world) check of one configuration: pairs in contact, closest pair")
    add_robot_options(parser)
    add_joint_options(parser)
    add_collision_options(parser, geometry="meshes")
    parser.add_argument("--precision", type=int, default=4, metavar="N", help="decimals printed (default 4)")
    parser.add_argument("--format", choices=("text", "json"), default="text")
    parser.set_defaults(run=run_collisions)

    acm = commands.add_parser("acm", help="allowed-collision matrix (MoveIt's rules) written as an SRDF")
    add_robot_options(acm)
    _add_geometry_option(acm, "meshes")
    acm.add_argument("--srdf", default=None, metavar="FILE|none",
                     help="the SRDF to compare with, pair by pair (default: the one the robot ships, or an MJCF "
                          "robot's contact rules; none: no comparison)")
    acm.add_argument("-o", "--output", required=True, metavar="FILE", help="the SRDF to write")
    acm.add_argument("--samples", type=int, default=10_000, metavar="N",
                     help="random configurations checked (default 10000)")
    acm.add_argument("--seed", type=int, default=0, help="seed of the samples (default 0)")
    acm.add_argument("--workers", type=int, default=None, metavar="N",
                     help="threads checking the samples (default: every core); the matrix is the same for any N")
    acm.add_argument("--progress", choices=("yes", "no", "auto"), default="auto",
                     help="progress bar on stderr (auto: when stderr is a terminal)")
    acm.set_defaults(run=run_acm)


#: The help of ``--srdf``: what the default is.
_SRDF_HELP = ("SRDF whose <disable_collisions> pairs are not checked (default: the one the robot ships, beside "
              "it, in the workspace's *_moveit_config package or in example-robot-data; a robot loaded from MJCF: "
              "its contype/conaffinity and <exclude> rules; an MJCF file: its rules; none: no SRDF)")


def add_collision_options(parser, *, geometry: str = "hulls") -> None:
    """``--geometry`` (default ``geometry``), ``--srdf``, ``--floor`` and ``--world`` (read by :func:`collision_checker`)."""
    _add_geometry_option(parser, geometry)
    parser.add_argument("--srdf", default=None, metavar="FILE|none", help=_SRDF_HELP)
    parser.add_argument("--floor", default="none", metavar="Z|none",
                        help="floor height z (m) in the root link's frame, or none (default: none)")
    parser.add_argument("--world", default=None, metavar="FILE",
                        help="YAML world file of obstacles (boxes, spheres, cylinders) in the root link's frame")


def add_collision_set_options(parser, *, what: str) -> None:
    """``--collisions self,floor|self|floor|none``, ``--floor Z|none``, ``--srdf``, ``--geometry`` (read by
    :func:`collision_set`); ``what`` says what the checks are for, in the help of ``--collisions``."""
    parser.add_argument("--collisions", default="none", metavar="self,floor|self|floor|none",
                        help=f"{what}: self-collision and/or the floor (default none)")
    parser.add_argument("--floor", type=_floor_option, default=0.0, metavar="Z|none",
                        help="with --collisions floor: floor height (m) in the root link's frame (default 0)")
    parser.add_argument("--srdf", default=None, metavar="FILE|none", help=f"with --collisions: {_SRDF_HELP}")
    _add_geometry_option(parser, "hulls")


def collision_set(args) -> dict:
    """The options of :func:`add_collision_set_options` as the keyword arguments of
    :meth:`~manipkit.kinematics.collisions.CollisionSettings.parse` (``what``, ``floor``, ``geometry``, ``srdf``).

    ``--srdf`` without ``--collisions`` is a usage error (it would do nothing).
    """
    if args.collisions.strip().lower() == "none" and args.srdf is not None:
        raise UsageError("--srdf applies with --collisions self, floor or self,floor")
    return {"what": args.collisions, "floor": args.floor, "geometry": args.geometry, "srdf": args.srdf,
            "skip_home_contacts": True}


def _floor_option(text: str) -> float | None:
    """argparse type of ``--floor Z|none`` (:func:`parse_floor`, refused the argparse way)."""
    import argparse

    try:
        return parse_floor(text)
    except UsageError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("--floor ")) from None


def collision_checker(robot, args):
    """The :class:`~manipkit.kinematics.collisions.CollisionChecker` of ``--geometry/--srdf/--floor/--world``.

    An SRDF that leaves pairs touching at the default pose with this
    geometry is warned about (a matrix is validated, not trusted).
    """
    from manipkit.description.mjcf import rules_source_text
    from manipkit.kinematics.collisions import CollisionChecker, srdf_check
    from manipkit.kinematics.world import read_world

    srdf = args.srdf if args.srdf is not None else (None if robot.srdf is None else robot.srdf.path)
    if srdf is not None and str(srdf).strip().lower() != "none":
        touching = srdf_check(robot, srdf, geometry=args.geometry)
        if touching:
            pairs = ", ".join(f"{p.link1} - {p.link2}" for p in touching)
            warn(f"{rules_source_text(str(srdf))} leaves {len(touching)} pair{'s' if len(touching) != 1 else ''} in contact "
                 f"at the default pose with {args.geometry} geometry ({pairs}); was it made for other geometry? "
                 f"`manipkit acm --geometry {args.geometry}` makes one for it")
    world = () if args.world is None else read_world(args.world)
    return CollisionChecker(robot, geometry=args.geometry, srdf=args.srdf, floor=parse_floor(args.floor), world=world,
                            skip_home_contacts=True)


def _add_geometry_option(parser, default: str) -> None:
    other = "hulls" if default == "meshes" else "meshes"
    parser.add_argument("--geometry", default=default, metavar="hulls|meshes",
                        help=f"collision meshes as convex hulls (fast, conservative) or as meshes (exact); "
                             f"default {default}, the output says how {other} differ")


def parse_floor(text: str) -> float | None:
    """``--floor``: a height in metres, or ``none`` (no floor).

    Examples
    --------
    >>> parse_floor("none") is None, parse_floor("-0.05")
    (True, -0.05)
    """
    if text.strip().lower() == "none":
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise UsageError(f"--floor {printable(text)}: give a height in metres (such as 0 or -0.05), or none")
    return value


def run_collisions(args) -> int:
    """Print whether the configuration is in collision, every pair in contact and the closest pair."""
    robot = load_robot(args, mesh_warnings=False)  # a missing collision mesh is the error; visual meshes are not used
    q = joint_vector(robot, args)
    floor = parse_floor(args.floor)
    from manipkit.kinematics.collisions import other_geometry

    checker = collision_checker(robot, args)
    report = checker.report(q)
    distances = checker.distances(q)
    other = other_geometry(checker, q)
    if args.format == "json":
        compared = None if other is None else {
            "geometry": other[0], "in_contact": [list(p) for p, d in other[1].items() if d <= 0],
            "distances": [{"link1": a, "link2": b, report.geometry: distances[(a, b)], other[0]: d}
                          for (a, b), d in other[1].items()]}
        print_json({**report.as_dict(), "disabled_pairs": len(checker.disabled), "other_geometry": compared,
                    "q": dict(zip(robot.joint_names, map(float, q)))})
        return EXIT_OK
    lines = collision_lines(report, floor=floor, precision=args.precision)
    lines += left_out_lines(report, disabled=len(checker.disabled), notes=robot.srdf_notes if args.srdf is None else ())
    lines += geometry_lines(report.geometry, distances, other, precision=args.precision)
    for line in lines:
        print(line)
    return EXIT_OK


def _comparison_srdf(robot, srdf):
    """The SRDF ``acm --srdf`` compares with: the file given, the one the robot ships (default), or None (``none``)."""
    if srdf is None:
        return None if robot.srdf is None else robot.srdf.path
    return None if srdf.strip().lower() == "none" else srdf


def run_acm(args) -> int:
    """Make the allowed-collision matrix, write it as an SRDF, check it at the default pose and say so."""
    from manipkit.analysis.acm import REASONS, allowed_collision_matrix, compare_matrix, srdf_text
    from manipkit.app.collision_text import comparison_lines
    from manipkit.app.progress import progress_bar
    from manipkit.description.srdf import parse_srdf
    from manipkit.kinematics.collisions import MAX_THREADS, collisions, read_srdf
    from manipkit.outputs import is_stream, writable_path, write_text

    if not 1 <= args.samples <= 10_000_000:
        raise UsageError(f"--samples {args.samples}: give a whole number from 1 to 10000000")
    if args.seed < 0:
        raise UsageError(f"--seed {args.seed}: give a whole number, 0 or more")
    if args.workers is not None and not 1 <= args.workers <= MAX_THREADS:
        raise UsageError(f"--workers {args.workers}: give a whole number of threads from 1 to {MAX_THREADS}")
    writable_path(args.output)  # a typo in -o is said at once, not after the sampling
    robot = load_robot(args, mesh_warnings=False)
    enabled = {"yes": True, "no": False, "auto": None}[args.progress]
    with progress_bar(enabled) as progress:
        matrix = allowed_collision_matrix(robot, samples=args.samples, seed=args.seed, geometry=args.geometry,
                                          workers=args.workers, progress=progress)
    text = srdf_text(matrix)
    write_text(args.output, text)
    counts = matrix.counts()
    total = len(matrix.disabled) + len(matrix.enabled)
    print(f"robot {robot.name}: {total} link pairs, {matrix.samples} samples, {matrix.geometry} geometry; "
          f"wrote {printable(str(args.output))}")
    print("disabled: " + ", ".join(f"{counts[r]} {r}" for r in REASONS) + f"; enabled (checked): {len(matrix.enabled)}")
    # The check reads the file back, as every other command would (--srdf), and checks the default pose.
    compare = _comparison_srdf(robot, args.srdf)
    if compare is not None:
        for line in comparison_lines(compare_matrix(matrix, read_srdf(compare, robot), str(compare))):
            print(line)
    # a stream (/dev/stdout, a FIFO) cannot be read back: its text is checked instead
    written = parse_srdf(text, str(args.output)).pairs() if is_stream(args.output) else args.output
    report = collisions(robot, srdf=written, geometry=args.geometry)
    if report.in_collision:
        pairs = ", ".join(f"{p.link1} - {p.link2}" for p in report.pairs)
        print(f"check FAILED: enabled pairs in contact at the default pose: {pairs}")
        return 1
    print(f"check: no enabled pair is in contact at the default pose ({report.checked} pairs checked with "
          f"{printable(str(args.output))})")
    return EXIT_OK
