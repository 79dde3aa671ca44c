"""``manipkit dh show | check | to-urdf | from-urdf``: DH tables printed, checked against a URDF, converted.

The tables, their text and the check with its diagnosis (as data) come from
:mod:`manipkit.dh`; the diagnosis is worded by :mod:`manipkit.app.dh_text`.
DH conventions (standard, modified) are in docs/architecture.md.
"""

from __future__ import annotations

import math
from pathlib import Path

from manipkit.app.cli.common import (
    EXIT_MISMATCH,
    EXIT_OK,
    Parser,
    UsageError,
    add_robot_options,
    alias_lines,
    check_tolerance,
    command_line,
    load_robot,
    print_json,
    robot_words,
)
from manipkit.outputs import writable_path, write_text
from manipkit.text import short_text

__all__ = ["register", "run_dh_check", "run_dh_from_urdf", "run_dh_show", "run_dh_to_urdf"]


def register(commands) -> None:
    """Add ``manipkit dh`` and its five commands to the subparsers ``commands``."""
    dh = commands.add_parser("dh", help="DH tables: show, gravity, check against a URDF, to-urdf, from-urdf")
    dh_commands = dh.add_subparsers(dest="dh_command", required=True, metavar="COMMAND", parser_class=Parser)
    show = dh_commands.add_parser("show", help="print a DH table (and its symbolic T_base_tool)")
    show.add_argument("table", metavar="TABLE", help="a bundled table name (e.g. iiwa14_seed004) or a .yaml file")
    show.add_argument("--symbolic", action="store_true", help="also print T_base_tool with SymPy (c_i/s_i shorthand)")
    show.add_argument("--latex", action="store_true", help="print the symbolic transform as LaTeX")
    show.set_defaults(run=run_dh_show)
    gravity = dh_commands.add_parser("gravity", help="the gravity torques g(q) of a DH table with point masses (SymPy)")
    gravity.add_argument("table", metavar="TABLE", help="a bundled table name or a .yaml file")
    gravity.add_argument("--mass", nargs="+", required=True, metavar="M",
                         help="one mass per row: kg, or a symbol name (m1 m2 ...)")
    gravity.add_argument("--cog", nargs=3, action="append", default=None, metavar=("X", "Y", "Z"),
                         help="a link's centre in its DH frame (m or symbol names), once per row in row order "
                              "(default each frame's origin)")
    gravity.add_argument("--up", choices=("x", "y", "z"), default="z",
                         help="the base axis pointing up: gravity is -g along it, g a symbol (default z)")
    gravity.add_argument("--gravity", nargs=3, type=float, default=None, metavar=("GX", "GY", "GZ"),
                         help="gravity in the base frame as numbers (m/s^2), instead of --up")
    gravity.add_argument("--latex", action="store_true", help="print g(q) as LaTeX")
    gravity.set_defaults(run=run_dh_gravity)
    check = dh_commands.add_parser("check", help="compare a DH table with a robot's URDF chain, with a diagnosis")
    check.add_argument("table", metavar="TABLE", help="a bundled table name or a .yaml file")
    add_robot_options(check)
    check.add_argument("--base", default="base_link", help="URDF frame of the table's base (default base_link)")
    check.add_argument("--tip", default="ee_link", help="URDF frame of the table's tool (default ee_link)")
    check.add_argument("--samples", type=int, default=1000, metavar="N", help="configurations within the limits (default 1000, fixed seed)")
    check.add_argument("--tol", type=float, default=None, help="pass tolerance, m and rad (default 1e-9, dh.check.CHECK_TOL)")
    check.add_argument("--format", choices=("text", "json"), default="text")
    check.add_argument("--fix", type=Path, default=None, metavar="FILE.yaml",
                       help="when the diagnosis finds a corrected table that passes, write it here")
    check.set_defaults(run=run_dh_check)
    to_urdf = dh_commands.add_parser("to-urdf", help="write a URDF for a DH table")
    to_urdf.add_argument("table", metavar="TABLE", help="a bundled table name or a .yaml file")
    to_urdf.add_argument("-o", "--output", type=Path, default=None, metavar="FILE.urdf")
    to_urdf.set_defaults(run=run_dh_to_urdf)
    from_urdf = dh_commands.add_parser("from-urdf", help="derive a DH table from a robot's URDF chain")
    add_robot_options(from_urdf)
    from_urdf.add_argument("--base", default="base_link", help="URDF frame of the table's base (default base_link)")
    from_urdf.add_argument("--tip", default="ee_link", help="URDF frame of the table's tool (default ee_link)")
    from_urdf.add_argument("--convention", choices=("standard", "modified"), default="standard")
    from_urdf.add_argument("--tol", type=float, default=None, metavar="RAD",
                           help="snap joint axes and angles within RAD of multiples of 90 deg (a description that "
                                "writes pi as 3.1415926); 0 derives the exact table (default: 0.001 where the snapped "
                                "table still passes dh check's default 1e-9 m and rad, else 0)")
    from_urdf.add_argument("-o", "--output", type=Path, default=None, metavar="FILE.yaml", help="also save the table")
    from_urdf.set_defaults(run=run_dh_from_urdf)


def run_dh_show(args) -> int:
    """Print the table (and, asked, its symbolic T_base_tool as text or LaTeX)."""
    from manipkit import dh
    from manipkit.description.sources import resolve_dh_table

    table = dh.load_dh(resolve_dh_table(args.table))
    print(dh.format_dh_table(table))
    if args.symbolic or args.latex:
        T = dh.dh_fk_symbolic(table)
        label = f"T_base_tool of {table.name or 'the table'} (c_i = cos q_i, s_i = sin q_i):"
        print(label if not args.latex else f"% {label}")
        print(dh.format_symbolic(dh.shorthand(T), latex=args.latex))
    return EXIT_OK


def _symbolic_value(text: str):
    """A number when the text is one (so 1.5 stays 1.5, not a symbol), else the text (a symbol name)."""
    try:
        return float(text)
    except ValueError:
        return text


def run_dh_gravity(args) -> int:
    """Print g(q) = dV/dq of the table with a point mass on each link (:func:`manipkit.dh.dh_gravity_symbolic`)."""
    from manipkit import dh
    from manipkit.description.sources import resolve_dh_table

    table = dh.load_dh(resolve_dh_table(args.table))
    centres = None if args.cog is None else [[_symbolic_value(v) for v in cog] for cog in args.cog]
    if args.gravity is not None:
        from manipkit import bounds

        gravity = bounds.gravity(args.gravity, "--gravity", error=UsageError).tolist()
        down = f"({', '.join(short_text(v) for v in gravity)}) m/s^2"
    else:
        gravity = ["-g" if axis == args.up else 0 for axis in "xyz"]
        down = f"-g along {args.up}"
    tau = dh.dh_gravity_symbolic(table, [_symbolic_value(m) for m in args.mass], centres=centres, gravity=gravity)
    where = "at each DH frame's origin" if centres is None else "at the given centres in their DH frames"
    label = (f"g(q) of {table.name or 'the table'}: the torque (N m) or force (N) each joint holds still, "
             f"point masses {where}, gravity {down} in the base frame (c_i = cos q_i, s_i = sin q_i):")
    print(label if not args.latex else f"% {label}")
    print(dh.format_symbolic(dh.shorthand(tau), latex=args.latex, name="g"))
    return EXIT_OK


def run_dh_check(args) -> int:
    """Compare the table's FK with the robot's chain; exit 1 on a mismatch, with the diagnosis."""
    from manipkit import dh
    from manipkit.app.dh_text import diagnosis_lines, fix_reason
    from manipkit.description.sources import resolve_dh_table
    from manipkit.dh.check import CHECK_TOL, check_dh

    args.tol = CHECK_TOL if args.tol is None else args.tol
    if args.fix is not None:
        writable_path(args.fix, inputs=(args.table, args.robot))  # before the robot is loaded
    path = resolve_dh_table(args.table)
    table = dh.load_dh(path)
    robot = load_robot(args)
    if args.samples < 1:
        raise UsageError(f"--samples {args.samples}: give at least 1")
    check_tolerance(args.tol)
    result = check_dh(table, robot, base=args.base, tip=args.tip, samples=args.samples, tol=args.tol)
    fixed = None
    if args.fix is not None and result.candidate is not None:
        header = (f"{path.name} corrected by `manipkit dh check` against {robot.name} {args.base} -> {args.tip}: "
                  + fix_reason(result))
        write_text(args.fix, dh.yaml_from_dh(result.candidate, header=header))
        fixed = str(args.fix)
    if args.format == "json":
        print_json({
            "table": str(path),
            "robot": robot.name,
            "base": args.base,
            "tip": args.tip,
            "joints": list(result.joints),
            "samples": result.samples,
            "tol": result.tol,
            "max_position_error": None if result.max_position_error != result.max_position_error else result.max_position_error,
            "max_rotation_error": None if result.max_rotation_error != result.max_rotation_error else result.max_rotation_error,
            "pass": result.passed,
            "diagnosis": diagnosis_lines(result),
            "corrected_table": None if result.candidate is None else dh.yaml_from_dh(result.candidate),
            "fix_written": fixed,
        })
    else:
        print(f"{table.convention} DH table {path.name} vs {robot.name} URDF chain {args.base} -> {args.tip}"
              f" ({len(result.joints)} joints: {', '.join(result.joints)})")
        if result.samples:
            print(f"{result.samples} configurations inside the joint limits: max position error "
                  f"{short_text(result.max_position_error, 3)} m, max rotation error {short_text(result.max_rotation_error, 3)} rad")
        print(f"PASS (within {short_text(result.tol)})" if result.passed else f"FAIL (tolerance {short_text(result.tol)})")
        for line in diagnosis_lines(result, summary=False):  # the errors are above
            print(f"- {line}")
        if fixed is not None:
            print(f"wrote the corrected table to {fixed} (it passes)")
        elif result.candidate is not None:
            print("(--fix FILE.yaml writes the corrected table)")
        elif args.fix is not None and not result.passed:
            print(f"no corrected table found; {args.fix} not written")
    return EXIT_OK if result.passed else EXIT_MISMATCH


def run_dh_to_urdf(args) -> int:
    """Print the URDF of the table, or write it to ``-o`` (checked before the table is read)."""
    from manipkit import dh
    from manipkit.description.sources import resolve_dh_table

    if args.output is not None:
        writable_path(args.output, inputs=(args.table,))
    table = dh.load_dh(resolve_dh_table(args.table))
    if args.output is None:
        print(dh.urdf_from_dh(table))
    else:
        dh.save_urdf(table, args.output)
        print(f"wrote {args.output} ({table.n} joints, frames base_link, link_1..link_{table.n}, ee_link)")
    return EXIT_OK


def run_dh_from_urdf(args) -> int:
    """Print the DH table of the chain base -> tip, snapped within ``--tol`` and checked against the URDF.

    ``-o`` (checked before the robot is loaded, written through
    :mod:`manipkit.outputs`) also saves it, with a header saying how it was
    made: the command that makes it again and how far it is from the URDF.
    """
    from manipkit import dh
    from manipkit.dh.check import CHECK_TOL
    from manipkit.dh.from_urdf import DEFAULT_SNAP, check_snap, derive_dh

    if args.output is not None:
        writable_path(args.output, inputs=(args.robot,))  # before the robot is loaded
    if args.tol is not None:
        check_snap(args.tol, "--tol")
    robot = load_robot(args)
    snap = DEFAULT_SNAP if args.tol is None else args.tol
    derived = derive_dh(robot, args.base, args.tip, convention=args.convention, snap=snap)
    unsnapped = ""
    if args.tol is None and max(derived.position_error, derived.rotation_error) > CHECK_TOL and derived.moved:
        # snapped, the table would fail `dh check` of the same robot at its default: the exact table instead
        unsnapped = (f"not snapped: snapping within {short_text(snap)} rad would leave the table "
                     f"{short_text(derived.position_error, 2)} m and {short_text(derived.rotation_error, 2)} rad off, "
                     f"beyond dh check's default {short_text(CHECK_TOL)} (--tol {short_text(snap)} snaps anyway); ")
        snap = 0.0
        derived = derive_dh(robot, args.base, args.tip, convention=args.convention, snap=snap)
    table, summary = derived.table, unsnapped + snap_summary(derived)
    if args.output is not None:
        derived_by = command_line("manipkit", "dh", "from-urdf", *robot_words(args, robot), "--base", args.base,
                                  "--tip", args.tip, "--convention", args.convention, "--tol", repr(snap))
        header = (
            f"{table.convention} DH table of {robot.name} from {robot.frame(args.base)} to {robot.frame(args.tip)}, "
            f"rows = joints {', '.join(robot.chain_joints(args.base, args.tip))};\n"
            f"derived by `{derived_by}`;\n{summary}"
        )
        write_text(args.output, dh.yaml_from_dh(table, header=header))  # what dh.save_dh writes
        print(f"wrote {args.output}")
    for line in alias_lines(robot, args.base, args.tip):
        print(line)
    print(dh.format_dh_table(table))
    print(summary)
    return EXIT_OK


def snap_summary(derived) -> str:
    """What ``dh from-urdf`` snapped and how far the table is from the URDF, in one sentence."""
    if derived.snap == 0:
        snapped = "exact (nothing snapped, --tol 0)"
    elif not derived.moved:
        snapped = (f"nothing snapped (no axis or angle lay within {short_text(derived.snap)} rad of a multiple of "
                   "90 deg without being on it)")
    else:
        shown = ", ".join(f"{what} by {short_text(math.degrees(angle), 3)} deg" for what, angle in derived.moved[:6])
        more = f" and {len(derived.moved) - 6} more" if len(derived.moved) > 6 else ""
        snapped = f"snapped to multiples of 90 deg within {short_text(derived.snap)} rad: {shown}{more}"
    return (f"{snapped}; the table's FK agrees with the URDF within {short_text(derived.position_error, 2)} m and "
            f"{short_text(derived.rotation_error, 2)} rad at q = 0 and {derived.samples} random configurations")
