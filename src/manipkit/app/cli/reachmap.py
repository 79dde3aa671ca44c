"""``manipkit reachmap`` (a reachability map of any arm, saved as Zarr) and ``manipkit base-placement``.

The map and the placement search come from :mod:`manipkit.analysis.reachmap`
and :mod:`manipkit.analysis.reachmap.placement` (docs/site/internals/reach-maps.md).
"""

from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path

from manipkit.app.cli.collisions import add_collision_set_options, collision_set
from manipkit.app.cli.common import (
    EXIT_OK,
    UsageError,
    add_robot_options,
    command_chain,
    load_robot,
    print_json,
    warn,
)
from manipkit.outputs import writable_path
from manipkit.text import printable, short_text

__all__ = ["present_map", "register", "run_base_placement", "run_reachmap", "run_reachmap_query", "run_reachmap_show"]


def _add_map_options(parser, *, voxel: float, orientations: str | None, samples: int, converge: float) -> None:
    parser.add_argument("--tip", "--frame", dest="tip", default="ee_link", help="tool frame (default ee_link)")
    parser.add_argument("--voxel", type=float, default=voxel, metavar="M", help=f"voxel edge in metres (default {voxel})")
    parser.add_argument("--orientations", default=orientations, metavar="N|DIRxROLL",
                        help="approach directions (x rolls) of a spatial arm, turns of a planar one "
                        f"(default {orientations or '200, or 36 for a planar arm'})")
    parser.add_argument("--method", choices=("fk", "hybrid"), default=None,
                        help="fk: random samples only; hybrid: then IK on the unmarked cells next to marked ones "
                        "(default hybrid for a planar arm, fk otherwise)")
    parser.add_argument("--samples", type=int, default=samples, metavar="N", help=f"random configurations (default {samples})")
    parser.add_argument("--seed", type=int, default=0, help="seed of every block (same seed, same map)")
    add_collision_set_options(parser, what="count only samples and IK answers free of collisions")
    parser.add_argument("--converge", type=float, default=converge, metavar="F",
                        help="stop sampling after a block adds fewer than F times the voxel-bins reached before it "
                        f"(--samples is the budget; 0 draws every sample; default {converge:g})")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, default=None, metavar="N", help="start a local Dask cluster of N worker processes (at most 4 per core, 64)")
    where.add_argument("--scheduler", default=None, metavar="ADDRESS", help="use a running Dask scheduler (tcp://host:8786)")


_PLACEMENT_MAP = {"voxel": 0.05, "orientations": "50", "samples": 500_000, "converge": 0.001}  # base-placement's map
#: Settings of a map being built: with --map, the map's own apply and these must be left at their defaults.
_BUILD_DEFAULTS = {**_PLACEMENT_MAP, "method": None, "seed": 0, "workers": None, "scheduler": None, "collisions": "none",
                   "floor": 0.0, "srdf": None, "geometry": "hulls"}


#: The options only a build reads: given before ``show``, they would do nothing.
_BUILD_ONLY = ("output", "base", "tip", "voxel", "orientations", "method", "samples", "seed", "collisions", "floor",
               "srdf", "geometry", "converge", "workers", "scheduler", "no_manipulability", "gravity")
_USAGE = """manipkit reachmap [--robot R] [--base FRAME] [--tip FRAME] [BUILD OPTIONS] -o MAP [SHOW OPTIONS]
       manipkit reachmap show MAP [SHOW OPTIONS] [--robot R]
       manipkit reachmap query MAP --targets FILE [--robot R] [--no-refine] [--format text|json]
SHOW OPTIONS: [--plot FILE.png] [--plot-manipulability FILE.png] [--view] [--view-html FILE.html] [--format text|json]
              [--payload MASS[@X,Y,Z]]"""


def _add_show_options(parser, **default) -> None:
    """What is shown of a map, built or loaded: the summary (text or JSON), slices, the 3D view."""
    parser.add_argument("--plot", type=Path, metavar="FILE.png", help="draw slices of the index", **default)
    parser.add_argument("--plot-manipulability", type=Path, metavar="FILE.png",
                        help="draw the same slices of the best Yoshikawa index per voxel", **default)
    parser.add_argument("--view", action="store_true", help="show the map in meshcat (Ctrl-C stops)", **default)
    parser.add_argument("--view-html", type=Path, metavar="FILE.html",
                        help="write the meshcat view as a standalone HTML file", **default)
    parser.add_argument("--format", choices=("text", "json"), help="text (default) or json", **default)
    parser.add_argument("--payload", metavar="MASS[@X,Y,Z]", help="where the arm carries MASS kg, its centre of "
                        "gravity at X,Y,Z m in the tip frame's axes (default 0,0,0): a build adds the payload layer "
                        "for that CoG to the map; show answers from the layer a map holds", **default)


def _add_payload_build_options(parser) -> None:
    parser.add_argument("--gravity", default="0,0,-9.81", metavar="GX,GY,GZ",
                        help="gravity for --payload in the map's base frame, m/s^2 (default 0,0,-9.81)")
    parser.add_argument("--arm-angles", type=int, default=None, metavar="N",
                        help="a 7R SRS arm's payload layer: arm angles sampled over the self-motion besides each "
                             "stored configuration's own, 360/N deg apart (default 8; 0: its own alone)")


def register(commands) -> None:
    """Add ``manipkit reachmap`` (build, or ``show`` a saved map) and ``manipkit base-placement`` to ``commands``."""
    import argparse

    from manipkit.app.cli.common import Parser

    reach = commands.add_parser(
        "reachmap", help="reachability map of an arm (voxels x orientations), saved as Zarr; 'reachmap show MAP' shows one",
        usage=_USAGE, description="Build a reachability map and save it to -o MAP (finished blocks are kept in "
        ".MAP.partial beside it until the map is saved, so an interrupted build resumes with the same command), or "
        "show a saved one with 'manipkit reachmap show MAP' (see 'manipkit reachmap show --help'). Both print the "
        "same summary and draw the same pictures.")
    add_robot_options(reach)
    reach.add_argument("--base", default="base_link", help="frame the map is in (default base_link)")
    # sampled until it converges (the iiwa14 at 5 cm: about 40 M samples, a minute on one core, 99 % complete)
    _add_map_options(reach, voxel=0.05, orientations=None, samples=200_000_000, converge=1e-4)
    reach.add_argument("-o", "--output", type=Path, default=None, metavar="MAP",
                       help="Zarr folder to write (needed to build)")
    reach.add_argument("--no-manipulability", action="store_true",
                       help="skip the manipulability overlay (no Jacobians: about half the FK-stage time)")
    _add_payload_build_options(reach)
    _add_show_options(reach, default=None)
    reach.set_defaults(run=run_reachmap, format="text", view=False)
    build_defaults = {name: reach.get_default(name) for name in _BUILD_ONLY}
    shows = reach.add_subparsers(dest="reachmap_command", metavar="show|query", parser_class=Parser,
                                 title="show or query a saved map instead of building one")
    show = shows.add_parser("show", prog="manipkit reachmap show", help="print the summary of the map MAP, draw its slices, show its 3D view",
                            argument_default=argparse.SUPPRESS,
                            description="Load a map saved by 'manipkit reachmap -o MAP' (no robot needed) and print "
                            "the summary its build printed; draw slices; show it in meshcat (--view and --view-html "
                            "load the map's robot by its name for the meshes, or the one --robot gives).")
    show.add_argument("map", type=Path, metavar="MAP", help="a map folder written by 'manipkit reachmap -o MAP'")
    _add_show_options(show)
    _add_map_robot_options(show, "whose meshes --view and --view-html draw")
    show.set_defaults(run=run_reachmap_show, build_defaults=build_defaults)
    _add_query_parser(shows, build_defaults)

    place = commands.add_parser("base-placement", help="floor positions (x, y, yaw) of a mobile base scored by targets reached")
    add_robot_options(place)
    place.add_argument("--targets", type=Path, required=True, metavar="FILE",
                       help="target poses in the floor frame: lines of x y z roll pitch yaw, or 4x4 matrices")
    place.add_argument("--map", type=Path, default=None, metavar="MAP", help="a map from 'manipkit reachmap' (default: build one)")
    place.add_argument("--floor-frame", default=None, metavar="FRAME",
                       help="the robot frame placed on the floor (default: the root link)")
    _add_map_options(place, **_PLACEMENT_MAP)
    place.add_argument("--step", type=float, default=None, metavar="M", help="grid step of the floor positions (default: the voxel)")
    place.add_argument("--yaws", type=int, default=16, metavar="N", help="headings tried (default 16)")
    place.add_argument("--candidates", type=int, default=20, metavar="K",
                       help="the map's K best-scored placements re-scored by IK; the one IK confirms most is printed "
                            "(default 20)")
    place.add_argument("--ik-mode", choices=("auto", "pose", "position+axis"), default="auto",
                       help="what IK must match: the full pose, or the position and the tool's z axis (auto: the "
                            "full pose for an arm of 6 joints or more, else position+axis)")
    place.add_argument("--plot", type=Path, default=None, metavar="FILE.png", help="draw the heat map")
    place.add_argument("--format", choices=("text", "json"), default="text")
    place.add_argument("--payload", default=None, metavar="MASS[@X,Y,Z]",
                       help="count a target only where the arm also holds MASS kg (CoG X,Y,Z m in the tip frame's "
                            "axes; the map's payload layer, added for that CoG when it has none)")
    _add_payload_build_options(place)
    place.set_defaults(run=run_base_placement)


def _add_map_robot_options(parser, what: str) -> None:
    """``--robot`` (the robot ``what``; default: the name the map stores), ``--arg``, ``--package-dir``, ``--allow-read``
    of a command on a saved map."""
    parser.add_argument("--robot", metavar="R", help=f"the robot {what}: a bundled or example-robot-data name or a "
                        ".urdf/.xacro/MJCF .xml path (default: the robot name the map stores)")
    parser.add_argument("--arg", action="append", metavar="KEY:=VALUE", help="xacro argument of --robot (repeatable)")
    parser.add_argument("--package-dir", action="append", metavar="NAME=DIR", help="folder of a ROS package (repeatable)")
    parser.add_argument("--allow-read", action="append", metavar="DIR",
                        help="let the description read files in DIR (repeatable)")


def _add_query_parser(shows, build_defaults: dict) -> None:
    """``manipkit reachmap query MAP --targets FILE``: the map's answer per pose, refined by IK near the boundary."""
    import argparse

    query = shows.add_parser(
        "query", prog="manipkit reachmap query", help="whether the map MAP says each target pose is reachable",
        argument_default=argparse.SUPPRESS,
        description="Answer for each target pose (T_base_frame in the map's base frame) whether it is reachable: "
        "yes deep inside the map's reached set, no far from it, and near the boundary (support strictly between 0 "
        "and 1) decided by IK of the exact pose, with the map's robot loaded by the name it stores (or --robot). "
        "--no-refine, or a map whose robot does not load, gives the map's unrefined estimate and its measured error.")
    query.add_argument("map", type=Path, metavar="MAP", help="a map folder written by 'manipkit reachmap -o MAP'")
    query.add_argument("--targets", type=Path, required=True, metavar="FILE",
                       help="target poses in the map's base frame: lines of x y z roll pitch yaw, or 4x4 matrices")
    query.add_argument("--no-refine", action="store_true", default=False,
                       help="the map's own answer (voxel-bin reached and support >= 0.65), no IK")
    query.add_argument("--format", choices=("text", "json"), default="text", help="text (default) or json")
    _add_map_robot_options(query, "whose IK decides the boundary band")
    query.set_defaults(run=run_reachmap_query, build_defaults=build_defaults, robot=None)


def _build(robot, args, base: str, *, manipulability: bool = False, resume_dir=None):
    from manipkit.analysis.reachmap.builder import build
    from manipkit.app.progress import progress_bar
    from manipkit.kinematics.collisions import CollisionSettings

    collisions = CollisionSettings.parse(robot, **collision_set(args))
    with progress_bar() as progress, warnings.catch_warnings():
        warnings.showwarning = _note_or_warning
        return build(command_chain(robot, base, args.tip), voxel=args.voxel, orientations=args.orientations, method=args.method,
                     samples=args.samples, workers=args.workers, scheduler=args.scheduler, seed=args.seed,
                     manipulability=manipulability, progress=progress, collisions=collisions,
                     converge=args.converge, resume_dir=resume_dir)


def _payload_spec(args):
    """(Payload of --payload, gravity of --gravity (3,) m/s^2) or None without --payload; one line, exit 2, if bad."""
    if getattr(args, "payload", None) is None:
        return None
    from manipkit.app.cli.statics import parse_gravity, parse_payload

    return parse_payload(args.payload), parse_gravity(getattr(args, "gravity", "0,0,-9.81"), direction=True)


def _with_payload(reach_map, robot, args, load_spec, *, resume_dir=None):
    """The map with its payload layer for ``load_spec`` (:func:`_payload_spec`), built with a progress bar."""
    from manipkit.analysis.reachmap.payloadmap import ARM_ANGLES, payload_map
    from manipkit.app.progress import progress_bar

    with progress_bar() as progress, warnings.catch_warnings():
        warnings.showwarning = _note_or_warning
        return payload_map(reach_map, robot, cog=load_spec[0].cog, gravity=load_spec[1], workers=args.workers,
                           scheduler=args.scheduler, progress=progress, resume_dir=resume_dir,
                           arm_angles=ARM_ANGLES if args.arm_angles is None else args.arm_angles)


def _note_or_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A :class:`ResumeNote` as its own line on stderr (``resuming: ...``), any other warning as ``warning: ...``."""
    from manipkit.analysis.reachmap.blockstore import ResumeNote

    if issubclass(category, ResumeNote):
        print(printable(" ".join(str(message).split())), file=sys.stderr, flush=True)
    else:
        warn(str(message))


def _checked_pictures(args) -> list[Path]:
    """The picture files asked for, each writable (checked before any work)."""
    pictures = [p for p in (args.plot, args.plot_manipulability, args.view_html) if p is not None]
    for path in pictures:
        writable_path(path)
    return pictures


def _visual(robot, args):
    """The robot's geometry for the 3D view when one is asked for (missing meshes said once, up front), else None."""
    if not (args.view or args.view_html):
        return None
    from manipkit.app.viewer.scene import visual_model

    return visual_model(robot)


def run_reachmap(args) -> int:
    """Build the map, save it to ``-o``, then present it as ``reachmap show`` does (:func:`present_map`).

    Finished blocks are kept in ``.MAP.partial`` beside ``-o MAP``
    (:func:`manipkit.analysis.reachmap.store.resume_folder`) until the map is
    saved; an interrupted build leaves them, and the same command resumes.
    """
    from manipkit.analysis.reachmap.blockstore import remove_store
    from manipkit.analysis.reachmap.builder import parse_orientations
    from manipkit.analysis.reachmap.store import resume_folder, writable_map_path

    if args.output is None:
        raise UsageError("give -o MAP, the folder to write the map to (or 'manipkit reachmap show MAP' to show a saved "
                         "map)")
    writable_map_path(args.output)  # before any work; no folder is created but the map's own (and its blocks')
    pictures = _checked_pictures(args)
    if args.no_manipulability and args.plot_manipulability is not None:
        raise UsageError("--plot-manipulability needs the overlay: drop --no-manipulability")
    if args.orientations is not None:
        parse_orientations(args.orientations)
    robot = load_robot(args, mesh_warnings=False) if args.view or args.view_html else load_robot(args)
    visual = _visual(robot, args)
    load_spec = _payload_spec(args)
    blocks = resume_folder(args.output)
    payload_blocks = blocks.with_name(f".{args.output.name}.payload.partial")
    try:
        reach_map = _build(robot, args, args.base, manipulability=not args.no_manipulability, resume_dir=blocks)
        if load_spec is not None:
            reach_map = _with_payload(reach_map, robot, args, load_spec, resume_dir=payload_blocks)
    except KeyboardInterrupt:
        for folder in (blocks, payload_blocks):
            kept = len(list(folder.glob("*.npz"))) if folder.is_dir() else 0
            if kept:
                print(f"{kept} finished block(s) kept in {printable(str(folder))}: the same command resumes from "
                      "them", file=sys.stderr, flush=True)
            else:  # interrupted before a block finished: nothing to resume from
                remove_store(folder)
        raise
    reach_map.save(args.output)
    remove_store(blocks)
    remove_store(payload_blocks)
    present_map(reach_map, args, robot=robot, visual=visual, map_path=args.output, written=[args.output, *pictures])
    return EXIT_OK


def run_reachmap_show(args) -> int:
    """Load the map ``MAP`` (validated; no robot needed) and present it as its build did (:func:`present_map`)."""
    from manipkit.analysis.reachmap.map import load

    _refuse_build_options(args, "'reachmap show' shows a saved map as it was built")
    pictures = _checked_pictures(args)
    load_spec = _payload_spec(args)
    reach_map = load(args.map)
    if load_spec is not None:
        layer = reach_map.payload
        cog = load_spec[0].cog
        if layer is None or not layer.same_load(cog, layer.gravity):
            held = "no payload layer" if layer is None else \
                f"a payload layer for the CoG {','.join(short_text(v) for v in layer.cog)}"
            raise UsageError(f"--payload: {printable(str(args.map))} holds {held}; build it with 'manipkit reachmap "
                             f"... --payload {printable(args.payload)} -o MAP'")
    if args.plot_manipulability is not None and reach_map.manipulability is None:
        raise UsageError(f"--plot-manipulability: {printable(str(args.map))} was built without the manipulability "
                         "overlay (--no-manipulability); drop --plot-manipulability")
    robot = visual = None
    if args.view or args.view_html:
        robot = _map_robot(args, reach_map)
        visual = _visual(robot, args)
    present_map(reach_map, args, robot=robot, visual=visual, map_path=args.map, written=pictures)
    return EXIT_OK


def _refuse_build_options(args, what: str) -> None:
    """One line, exit 2, when an option only a build reads was given before ``show``/``query`` (``what`` says why)."""
    given = [name for name, default in args.build_defaults.items() if getattr(args, name, default) != default]
    if given:
        option = "-o" if given[0] == "output" else f"--{given[0].replace('_', '-')}"
        raise UsageError(f"{option} sets how a map is built; {what}: leave it out")


def run_reachmap_query(args) -> int:
    """Answer the targets of ``--targets`` from the map ``MAP``: refined by IK near the boundary where the map's robot
    (or ``--robot``) loads, else (or ``--no-refine``) the map's unrefined estimate, said with its measured error."""
    from manipkit.analysis.reachmap.map import load
    from manipkit.analysis.reachmap.query import UnrefinedWarning, answer_text
    from manipkit.inputs.poses import read_targets

    _refuse_build_options(args, "'reachmap query' answers from a saved map")
    if args.no_refine and args.robot is not None:
        raise UsageError("--robot loads the robot whose IK refines the answer, and --no-refine turns that off: give "
                         "one of them")
    targets = read_targets(args.targets)
    reach_map = load(args.map)
    robot = _map_robot(args, reach_map) if args.robot is not None else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnrefinedWarning)  # the answer's own line says it, with the measured error
        answer = reach_map.query(targets, detail=True, robot=robot, refine=False if args.no_refine else None)
    said = answer_text(reach_map, answer)
    decided = answer.decided_by_ik
    how = ["IK" if decided is not None and decided[k] else "map" for k in range(len(targets))]
    if args.format == "json":
        print_json({"map": str(args.map), "robot": reach_map.robot, "base": reach_map.base, "frame": reach_map.frame,
                    "refined": decided is not None, "decided_by_ik": None if decided is None else int(decided.sum()),
                    "poses_total": len(targets), "answer": said,
                    "poses": [{"reachable": bool(answer.reachable[k]), "decided_by": how[k],
                               "support": float(answer.score[k]), "voxel_bin_reached": bool(answer.bin_reached[k])}
                              for k in range(len(targets))]})
        return EXIT_OK
    print(f"reach map of {printable(reach_map.robot)}: {printable(reach_map.frame)} in {printable(reach_map.base)}, "
          f"{len(targets)} target pose(s) from {printable(str(args.targets))}")
    words = {("IK", True): "reachable", ("IK", False): "not reached by IK from nearby starts",
             ("map", True): "reachable by the map", ("map", False): "not reachable by the map"}
    for k in range(len(targets)):
        print(f"pose {k + 1}: {words[how[k], bool(answer.reachable[k])]} (decided by {how[k]}; support "
              f"{short_text(float(answer.score[k]), 3)})")
    print(f"yes to {int(answer.reachable.sum())} of {len(targets)} poses; {said}")
    return EXIT_OK


def _map_robot(args, reach_map):
    """The robot of ``--robot`` (default: the name the map stores, taken only as a bundled or example-robot-data
    name: a map is a file from anywhere, and the file path it might name is never read), which must be the map's."""
    from manipkit.description.sources import resolve_robot
    from manipkit.errors import ManipkitError, UnknownRobotError

    given = args.robot is not None
    args.robot = args.robot if given else reach_map.robot
    args.arg, args.package_dir, args.allow_read = args.arg or [], args.package_dir or [], args.allow_read or []
    try:
        if not given and resolve_robot(reach_map.robot).origin == "file":
            raise UnknownRobotError("the map's robot name is a path, not a name")
        robot = load_robot(args, mesh_warnings=False)
    except ManipkitError:
        if given:
            raise
        raise UsageError(f"the 3D view draws the map's robot '{printable(reach_map.robot)}', which does not load by "
                         "that name (not a bundled or example-robot-data robot?); give its description with --robot "
                         "FILE") from None
    if robot.name != reach_map.robot:
        raise UsageError(f"--robot {printable(str(args.robot))} is '{printable(robot.name)}'; the map is of "
                         f"'{printable(reach_map.robot)}': give its robot")
    return robot


def present_map(reach_map, args, *, robot, visual, map_path: Path, written: list[Path]) -> None:
    """What ``reachmap`` prints and draws of a map, built or loaded: slices (``--plot``, ``--plot-manipulability``),
    the HTML view, the summary (text or JSON, with the files ``written``), then the live view (``--view``)."""
    from manipkit.analysis.reachmap.plot import plot_reachmap

    if args.plot is not None:
        plot_reachmap(reach_map, args.plot)
    if args.plot_manipulability is not None:
        plot_reachmap(reach_map, args.plot_manipulability, layer="manipulability")
    if args.view_html is not None:
        from manipkit.app.viewer.reachmap_scene import write_reachmap_html

        write_reachmap_html(reach_map, args.view_html, robot=robot, visual=visual)
    best = reach_map.best_manipulability()
    mass = _payload_spec(args)[0].mass if getattr(args, "payload", None) is not None else None
    if args.format == "json":
        print_json({
            "robot": reach_map.robot, "frame": reach_map.frame, "base": reach_map.base, "method": reach_map.method,
            "voxel": reach_map.voxel, "shape": list(reach_map.shape), "origin": reach_map.origin.tolist(),
            "orientations": reach_map.orientations.size, "reachable_voxels": int(reach_map.reachable.sum()),
            "dexterous_voxels": int(reach_map.dexterous.sum()), "map": str(map_path),
            "a_yes_means": reach_map.resolution(), **{key: reach_map.settings.get(key) for key in (
                "samples_used", "converged", "fill_passes", "completeness", "false_positive")},
            "collisions": reach_map.settings.get("collisions"),
            **({"best_manipulability": best[0], "best_manipulability_at": best[1].tolist()} if best else {}),
            **({"payload": _payload_json(reach_map, mass)} if reach_map.payload is not None else {}),
            **{name: str(path) for name, path in (("plot", args.plot), ("plot_manipulability", args.plot_manipulability),
                                                  ("view_html", args.view_html)) if path is not None},
        })
    else:
        print(reach_map.summary())
        if mass is not None:
            print(reach_map.payload_text(mass))
        if written:
            print(f"wrote {', '.join(printable(str(p)) for p in written)}")
    if args.view:
        _serve_view(reach_map, robot, visual)


def _payload_json(reach_map, mass) -> dict:
    """The payload layer's settings and, with ``mass`` (kg), the voxels carrying it (counts of voxels; inf as None)."""
    import numpy as np

    layer = reach_map.payload
    top = float(np.nanmax(layer.best)) if (~np.isnan(layer.best)).any() else None
    return {**layer.attrs(), "largest_capacity": top if top is None or math.isfinite(top) else None,
            **({} if mass is None else {"mass": mass, "voxels_carrying": int(layer.carries(mass).sum()),
                                        "voxels_carrying_in_every_bin": int(layer.carries_everywhere(mass).sum()),
                                        "reachable_voxels": int(reach_map.reachable.sum()), "voxel": reach_map.voxel})}


def _serve_view(reach_map, robot, visual) -> None:
    """Show the map in its own meshcat server until Ctrl-C (or SIGTERM)."""
    from manipkit.app.viewer.reachmap_scene import reachmap_scene, serve_until_stopped

    scene = reachmap_scene(reach_map, robot, visual=visual)
    print(f"meshcat scene: {scene.url}", flush=True)
    print("reachable voxels coloured by index (the manipulability layer is in meshcat's controls); Ctrl-C stops",
          flush=True)
    serve_until_stopped(scene)
    print("viewer stopped", flush=True)


def run_base_placement(args) -> int:
    """Score floor placements by the targets reached; print the best (text or JSON); draw the heat map."""
    from manipkit.analysis.reachmap.constants import MAX_VOXEL, MIN_VOXEL
    from manipkit.analysis.reachmap.map import load
    from manipkit.analysis.reachmap.placement import (
        MAX_CANDIDATES,
        MAX_YAWS,
        base_placement,
        confirm_placement,
        plot_base_placement,
    )
    from manipkit.inputs.poses import read_targets
    from manipkit.kinematics.collisions import CollisionSettings

    if args.plot is not None:
        writable_path(args.plot)
    if not 1 <= args.yaws <= MAX_YAWS:
        raise UsageError(f"--yaws {args.yaws}: give from 1 to {MAX_YAWS} headings")
    if not 1 <= args.candidates <= MAX_CANDIDATES:
        raise UsageError(f"--candidates {args.candidates}: give from 1 to {MAX_CANDIDATES} placements to re-score by IK")
    if args.step is not None and not (math.isfinite(args.step) and MIN_VOXEL <= args.step <= MAX_VOXEL):
        raise UsageError(f"--step {args.step}: give the grid step in metres, from {MIN_VOXEL:g} to {MAX_VOXEL:g}")
    targets = read_targets(args.targets)
    load_spec = _payload_spec(args)
    robot = load_robot(args)
    floor = robot.frame(args.floor_frame) if args.floor_frame is not None else robot.root_link
    if args.map is not None:
        reach_map = load(args.map)
        if reach_map.robot != robot.name:
            raise UsageError(f"--map {args.map} is a map of '{printable(reach_map.robot)}', not of '{robot.name}'; "
                             "give its --robot")
        if robot.frame(args.tip) != reach_map.frame:
            raise UsageError(f"--map {args.map} is a map of '{printable(reach_map.frame)}', not of "
                             f"'{robot.frame(args.tip)}'; give --tip {printable(reach_map.frame)} or build a map "
                             "of that frame")
        given = [name for name, default in _BUILD_DEFAULTS.items() if getattr(args, name) != default]
        if given:
            raise UsageError(f"--{given[0]} sets how a map is built; with --map {args.map} the map's own settings "
                             "apply: leave it out")
    else:
        reach_map = _build(robot, args, floor)
    if load_spec is not None and (reach_map.payload is None or not reach_map.payload.same_load(load_spec[0].cog,
                                                                                               load_spec[1])):
        reach_map = _with_payload(reach_map, robot, args, load_spec)
    mount = robot.transform(floor, reach_map.base)
    result = base_placement(reach_map, targets, yaws=args.yaws, step=args.step, mount=mount,
                            payload=None if load_spec is None else load_spec[0].mass)
    if args.plot is not None:
        plot_base_placement(result, args.plot, title=f"{robot.name}: the map's count of targets from each floor position")
    checked = (reach_map.settings.get("collisions") or {}).get("checked")
    collisions = None if not checked else CollisionSettings.parse(
        robot, ",".join(checked), floor=reach_map.settings["collisions"].get("floor") or 0.0,
        geometry=reach_map.settings["collisions"].get("geometry", "hulls"),
        srdf=_map_srdf(robot, reach_map.settings["collisions"].get("srdf") or "none", args.map))
    chosen = confirm_placement(reach_map, result, robot, mount=mount, collisions=collisions,
                               candidates=args.candidates, mode=args.ik_mode)
    if args.format == "json":
        full = chosen.confirmed if chosen.pose_confirmed is None else chosen.pose_confirmed
        print_json({"robot": robot.name, "floor_frame": floor, "x": chosen.x, "y": chosen.y, "yaw": chosen.yaw,
                    "ik_mode": chosen.mode, "ik_axis": None if chosen.mode == "pose" else chosen.axis,
                    "confirmed": int(chosen.confirmed.sum()), "confirmed_targets": chosen.confirmed.tolist(),
                    "confirmed_full_pose": int(full.sum()), "candidates": chosen.candidates,
                    "refined": None if chosen.refined is None else {
                        "x": chosen.refined[0], "y": chosen.refined[1], "yaw": chosen.refined[2],
                        "confirmed_full_pose": int(chosen.refined[3].sum()),
                        "confirmed_full_pose_targets": chosen.refined[3].tolist()},
                    "candidates_tried": [{"x": x, "y": y, "yaw": yaw, "map_estimate": int(score), "confirmed": int(n)}
                                         for x, y, yaw, score, n in chosen.tried.tolist()],
                    "map_estimate": chosen.map_score, "map_estimate_means": chosen.resolution,
                    "collision_free": collisions is not None, "targets": len(targets),
                    "payload": None if load_spec is None else load_spec[0].mass,
                    **({"plot": str(args.plot)} if args.plot is not None else {})})
    else:
        print(f"robot {printable(robot.name)}: {printable(floor)} placed on the floor, map of "
              f"{printable(reach_map.frame)} in {printable(reach_map.base)} "
              f"({short_text(reach_map.voxel)} m voxels, {reach_map.orientations.size} orientation bins)")
        print(chosen.summary() + (" (collision-free answers only)" if collisions is not None else ""))
        if args.plot is not None:
            print(f"wrote {printable(str(args.plot))} (the map's count, not IK's)")
    return EXIT_OK


def _map_srdf(robot, srdf: str, map_path) -> str:
    """The SRDF a map was built with, if the robot's description may read it (its read policy,
    :mod:`manipkit.description.access`): a map is data, and the path it records is no licence to read a file."""
    if srdf == "none" or map_path is None:
        return srdf  # a map built just now: the user's own --srdf
    from manipkit.description.access import ReadPolicy
    from manipkit.description.packages import PackageResolver

    shipped = getattr(robot, "srdf", None)
    if shipped is not None and Path(srdf) == Path(shipped.path):
        return srdf
    near = robot.source.path if robot.source.path.exists() else None
    if near is None:
        raise UsageError(f"--map {printable(map_path)} names the SRDF {printable(srdf)[:200]}, and robot "
                         f"'{robot.name}' has no description folder it may lie in; rebuild the map")
    ReadPolicy(near, PackageResolver(dict(robot.package_dirs), near=near), robot.allow_read).check(
        srdf, f"--map {printable(map_path)}: its SRDF")
    return srdf
