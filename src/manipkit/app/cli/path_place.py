"""``manipkit path --place``: the offsets of the path (or the base) at which the arm can follow it.

The search is :func:`manipkit.analysis.reachmap.pathplace.place_path`
(docs/site/guides/paths.md, "Where to put the part"); this module reads the
options, prints the answer and the command that plans the best offset
(``manipkit path ... --offset DX DY DZ YAW``). Exit status 0 when some
offset is feasible, 1 when none is, 2 for a usage error.
"""

from __future__ import annotations

import math
import shlex

from manipkit.app.cli.common import EXIT_MISMATCH, EXIT_OK, UsageError, print_json
from manipkit.text import short_text

__all__ = ["add_place_options", "check_place_options", "full_option", "offset_of", "place_text", "reproduce_command",
           "run_place"]

#: Options of the search, with how many values each takes: left out of the command that plans one offset.
SEARCH_OPTIONS = {"--place": 0, "--place-x": 3, "--place-y": 3, "--place-z": 3, "--place-yaw": 3,
                  "--reach-map": 1, "--reach-share": 1, "--workers": 1, "--offset": 4}


def add_place_options(path) -> None:
    """Add ``--place``, its ranges, the reach-map screen, ``--workers`` and ``--offset`` to ``manipkit path``."""
    path.add_argument("--place", action="store_true",
                      help="search offsets of the path (dx dy dz in the base frame, yaw about its z) on the grid of "
                           "--place-x/-y/-z/-yaw: the feasible region and the best offset by plan cost")
    for axis, unit in (("x", "m"), ("y", "m"), ("z", "m"), ("yaw", "rad, deg with --deg")):
        path.add_argument(f"--place-{axis}", type=float, nargs=3, default=None, metavar=("MIN", "MAX", "STEP"),
                          help=f"with --place: offsets along {axis} from MIN to MAX every STEP ({unit}; default 0)")
    path.add_argument("--reach-map", default=None, metavar="DIR",
                      help="with --place: plan only offsets at which this reach map (of --tip in --base) says yes "
                           "to at least --reach-share of the waypoints")
    path.add_argument("--reach-share", type=float, default=1.0, metavar="S",
                      help="with --reach-map: the share of waypoints (0..1, default 1)")
    path.add_argument("--workers", type=int, default=None, metavar="N",
                      help="with --place: plan the candidates on a local Dask cluster of N worker processes "
                           "(default: here); the answer is the same for any N")
    path.add_argument("--offset", type=float, nargs=4, default=None, metavar=("DX", "DY", "DZ", "YAW"),
                      help="move the path by this offset (m in the base frame; yaw about its z, rad or deg with --deg)")
    # every option name of `manipkit path` (added last, so all are there): argparse's list of them is only in
    # `_actions` (docs/hooks.py reads it too); the printed command spells out what the user abbreviated
    path.set_defaults(option_names=frozenset(s for action in path._actions for s in action.option_strings))


def _yaw(value: float, args) -> float:
    return math.radians(value) if args.deg else value


def offset_of(args) -> tuple[float, float, float, float]:
    """``--offset`` as (dx, dy, dz, yaw rad); one line, exit 2, when not finite."""
    if not all(math.isfinite(v) for v in args.offset):
        raise UsageError("--offset: give 4 finite numbers DX DY DZ YAW")
    dx, dy, dz, yaw = args.offset
    return dx, dy, dz, _yaw(yaw, args)


def full_option(word: str, names) -> str:
    """``word`` with the option it abbreviates spelt out (``--reach-m=DIR`` -> ``--reach-map=DIR``): argparse
    takes a unique prefix of a long option, and a printed command must name it whole, so that it is dropped
    with the search options and reads the same should another option of that prefix be added. Words that are
    not an abbreviation of one of ``names`` are returned as they are."""
    name, sep, value = word.partition("=")
    if not name.startswith("--") or name in names:
        return word
    matches = [option for option in names if option.startswith(name)]
    return matches[0] + sep + value if len(matches) == 1 else word


def reproduce_command(args, offset) -> str:
    """The ``manipkit`` command line of this run without the search options, with ``--offset`` of ``offset``;
    options the user abbreviated are spelt out (:func:`full_option`)."""
    names = getattr(args, "option_names", frozenset())
    words, skip = [], 0
    given = [full_option(word, names) for word in getattr(args, "command_line", [])]
    for word in given:
        if skip:
            skip -= 1
            continue
        name = word.split("=", 1)[0]
        if name in SEARCH_OPTIONS:
            skip = SEARCH_OPTIONS[name] if "=" not in word else 0
            continue
        words.append(word)
    yaw = math.degrees(offset[3]) if args.deg else offset[3]
    words += ["--offset", *(_fixed(v) for v in (*offset[:3], yaw))]
    return shlex.join(["manipkit", *words])


def _fixed(value) -> str:
    """``value`` in fixed notation to 1e-15 (argparse takes ``-1e-05`` for an option, ``-0.00001`` for a number)."""
    text = f"{float(value):.15f}".rstrip("0").rstrip(".")
    return "0" if text in ("", "-0") else text


def check_place_options(args) -> None:
    """The grid, the screen and ``--workers`` apply with ``--place`` only (one line, exit 2)."""
    if not args.place and any(v is not None for v in (args.place_x, args.place_y, args.place_z, args.place_yaw,
                                                      args.reach_map, args.workers)):
        raise UsageError("--place-x/-y/-z/-yaw, --reach-map and --workers apply with --place")


def run_place(args, robot, poses, options: dict) -> int:
    """Search the offsets of ``--place-*`` with the plan ``options`` of :func:`manipkit.paths.plan.plan_path` and
    print the region, the best offset and the command that plans it."""
    from manipkit.analysis.reachmap.pathplace import offset_grid, place_path
    from manipkit.app.progress import progress_bar

    for option in ("retime", "plot", "map", "view_html", "output"):
        if getattr(args, option) not in (None, False):
            raise UsageError(f"--{option.replace('_', '-')} applies to one plan, not to --place: run the printed "
                             "command for the best offset")
    if args.view or args.offset is not None:
        raise UsageError("--view and --offset apply to one plan, not to --place")
    ranges = [args.place_x, args.place_y, args.place_z, args.place_yaw]
    if all(r is None for r in ranges):
        raise UsageError("--place needs a grid: give at least one of --place-x/-y/-z/-yaw MIN MAX STEP")
    if ranges[3] is not None:
        ranges[3] = [_yaw(v, args) for v in ranges[3]]
    offsets = offset_grid(*ranges)
    reach_map = None
    if args.reach_map is not None:
        from manipkit.analysis.reachmap.map import load

        reach_map = load(args.reach_map)
    with progress_bar({"yes": True, "no": False, "auto": None}[args.progress]) as progress:
        result = place_path(robot, poses, base=args.base, tip=args.tip, offsets=offsets, reach_map=reach_map,
                            share=args.reach_share, workers=args.workers, progress=progress, **options)
    best = result.best
    command = None if best is None else reproduce_command(args, result.offsets[best])
    if args.format == "json":
        answer = result.as_dict()
        answer["command"] = command
        print_json(answer)
    else:
        print(place_text(result, robot=robot.name, base=args.base, tip=args.tip, command=command))
    return EXIT_OK if best is not None else EXIT_MISMATCH


def place_text(result, *, robot: str, base: str, tip: str, command: str | None) -> str:
    """The search in words: candidates, how many the map screened out, how many were planned and feasible, the
    region's bounds, the best offset and the command that plans it."""
    lines = [f"placement of a path of {result.waypoints} waypoints for frame {tip} in {base} on {robot}: "
             f"{len(result.offsets)} candidate offset(s) (dx dy dz m in {base}, yaw rad about its z)"]
    if result.screened is not None:
        lines.append(f"reach map screen: {int((~result.planned).sum())} candidate(s) dropped (the map says yes to "
                     f"fewer than {short_text(100 * result.share, 4)}% of the waypoints)")
    lines.append(f"planned: {int(result.planned.sum())}; feasible: {int(result.feasible.sum())}")
    region = result.region()
    if region is None:
        lines.append("NO FEASIBLE OFFSET on this grid")
        return "\n".join(lines)
    lines.append("feasible region (bounds of the feasible offsets): " + ", ".join(
        f"{axis} {short_text(lo, 6)} .. {short_text(hi, 6)}" for axis, (lo, hi) in region.items()))
    best = result.best
    lines.append("best (least plan cost " + short_text(float(result.cost[best]), 6) + "): " + " ".join(
        f"{axis}={short_text(float(v), 6)}" for axis, v in zip(("dx", "dy", "dz", "yaw"), result.offsets[best])))
    lines.append(f"plan it: {command}")
    return "\n".join(lines)
