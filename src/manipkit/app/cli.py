"""Command-line front end: parse, call the library, format. No kinematics here.

``tf-between SOURCE TARGET`` prints T_SOURCE_TARGET (the pose of TARGET in
SOURCE) like ROS 2 ``tf2_echo``; ``manipkit`` groups the other commands.
User errors print one line on stderr and exit with status 2; a bug exits
with status 1 and asks to be reported. Warnings (a normalised joint axis, an
unresolved ``package://`` mesh, a value moved into its limits by ``--clamp``)
print as ``warning: ...`` lines on stderr; the answer stays alone on stdout.
Joint values outside their limits are an error naming the joint, the value
and the limits, unless ``--clamp`` is given.

argparse (standard library) is used rather than click/typer so that
``tf-between`` starts fast; heavy modules (and json) are imported inside the
commands.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

from manipkit.errors import JointLimitError, ManipkitError

EXIT_OK, EXIT_MISMATCH, EXIT_USAGE = 0, 1, 2
EXIT_INTERNAL = 1  # a bug (an exception that is not a ManipkitError)


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (usage goes to --help, not to every mistake)."""

    def error(self, message: str):
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


class UsageError(ManipkitError):
    """A malformed command-line value."""


def warn(message: str) -> None:
    """The warnings channel: one ``warning: ...`` line on stderr (stdout stays the answer)."""
    print(f"warning: {' '.join(str(message).split())}", file=sys.stderr)


def _print_json(value) -> None:
    import json

    print(json.dumps(value, indent=2))


_BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")


def _import_numpy_with_one_blas_thread() -> None:
    """Import numpy (when not yet imported) with OpenBLAS limited to one thread, for a fast start.

    OpenBLAS starts a worker thread per core when numpy loads it, and the
    workers spin while the main thread goes on importing: 15-30 ms of wall
    time per ``tf-between`` on a 2-core machine, more under load. ``tf``
    multiplies nothing large enough for BLAS to use a second thread (4x4 and
    stacked 3x3 matrices), so no result changes. OpenBLAS reads the variable
    once, when numpy loads it; the environment is restored right after (child
    processes see it unchanged), and a thread count the user set is kept.
    """
    if "numpy" in sys.modules or any(name in os.environ for name in _BLAS_THREAD_VARIABLES):
        return
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    try:
        import numpy  # noqa: F401
    finally:
        del os.environ["OPENBLAS_NUM_THREADS"]


# ----------------------------------------------------------------------
# Shared options
# ----------------------------------------------------------------------


def _add_robot_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--robot", default=None, metavar="R",
        help="bundled name (course_arm, iiwa14, ...), example-robot-data name (panda, ur5, ...) "
        "or a .urdf/.xacro path (default: course_arm)",
    )
    parser.add_argument(
        "--arg", action="append", default=[], metavar="KEY=VALUE", help="xacro argument (repeatable)"
    )
    parser.add_argument(
        "--package-dir", action="append", default=[], metavar="NAME=DIR",
        help="folder of a ROS package, for $(find NAME) and package://NAME (repeatable)",
    )


def _add_joint_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--q", action="extend", nargs="+", default=[], metavar="NAME=VALUE",
        help="joint values by name (repeatable), or all joint values in order; joints not given are 0",
    )
    parser.add_argument("--deg", action="store_true", help="angles are given in degrees (prismatic joints stay in metres)")
    parser.add_argument(
        "--clamp", action="store_true",
        help="move joint values outside their limits to the nearest limit (with a warning) instead of an error",
    )


def _pairs(items: list[str], option: str) -> dict[str, str]:
    pairs = {}
    for item in items:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise UsageError(f"{option} '{item}': expected NAME=VALUE")
        if key in pairs:
            raise UsageError(f"{option}: {key} given twice ({key}={pairs[key]} and {key}={value}); give it once")
        pairs[key] = value
    return pairs


def _load(args, *, mesh_warnings: bool = True):
    """The robot of --robot/--arg/--package-dir; its load warnings go to the warnings channel.

    ``mesh_warnings=False`` leaves out unresolved ``package://`` meshes (the viewer makes them an error).
    """
    import manipkit

    package_dirs = {}
    for name, folder in _pairs(args.package_dir, "--package-dir").items():
        if not folder:
            raise UsageError(f"--package-dir {name}=: give the folder of package {name}")
        package_dirs[name] = Path(folder)
    robot = manipkit.load(args.robot, package_dirs=package_dirs, **_pairs(args.arg, "--arg"))
    for message in robot.warnings:
        if mesh_warnings or message not in robot.mesh_warnings:
            warn(message)
    return robot


def _joint_vector(robot, args, *, option: str = "--q", items=None):
    """Joint vector from --q NAME=VALUE ... or --q V1 V2 ... (all joints in order), limits checked."""
    items = args.q if items is None else items
    if items and all(_is_number(item) for item in items):
        if len(items) != len(robot.joint_names):
            raise UsageError(
                f"{option} got {len(items)} value{'s' if len(items) != 1 else ''} but {robot.name} has "
                f"{len(robot.joint_names)} joints ({', '.join(robot.joint_names) or 'none'}); "
                "give all of them in order, or NAME=VALUE pairs"
            )
        values = dict(zip(robot.joint_names, items))
    else:
        values = _pairs(items, option)
    prefix = "" if option == "--q" else f"{option}: "
    try:
        q = robot.q(values, degrees=args.deg)
    except ManipkitError as exc:
        if not prefix:
            raise
        raise UsageError(f"{prefix}{exc}") from None
    return _limit_checked(robot, q, degrees=args.deg, clamp=args.clamp, given=set(values), prefix=prefix)


def _limit_checked(robot, q, *, degrees: bool, clamp: bool, given=None, prefix: str = ""):
    """``q`` if inside the joint limits; clamped with a warning under --clamp; else a one-line error.

    The error names the joint, its value and the limits; a value above a
    full turn on an angular joint without --deg gets a degrees hint.
    Values of continuous joints above a full turn get the hint as a warning.
    """
    violations = robot.limit_violations(q)
    for joint, value in zip(robot.joints, q):
        unlimited = not (math.isfinite(joint.lower) and math.isfinite(joint.upper))
        if unlimited and joint.is_angular and not degrees and abs(value) > 2 * math.pi and (given is None or joint.name in given):
            warn(f"{prefix}joint '{joint.name}' = {value:.6g} rad is more than a full turn; "
                 "did you mean degrees? add --deg")
    if not violations:
        return q
    if clamp:
        clamped = robot.clamp(q)
        for error in violations:
            side = "upper" if error.value > error.upper else "lower"
            limit = error.upper if side == "upper" else error.lower
            warn(f"{prefix}joint '{error.joint}' = {_joint_value_text(error.value, error.unit, degrees)} "
                 f"clamped to its {side} limit {_joint_value_text(limit, error.unit, degrees)}")
        return clamped
    error = violations[0]
    message = _limit_message(error, degrees)
    if len(violations) > 1:
        others = ", ".join(e.joint for e in violations[1:4]) + (", ..." if len(violations) > 4 else "")
        message += f"; also outside: {others}"
    hint = ""
    if not degrees and error.unit == "rad" and abs(error.value) > 2 * math.pi:
        hint = " (did you mean degrees? add --deg)"
    elif error.unit == "m" and error.lower <= error.value / 1000 <= error.upper:
        hint = f" (values are in metres: did you mean {error.value / 1000:g}?)"
    raise UsageError(f"{prefix}{message}; use --clamp to clamp{hint}")


def _joint_value_text(value: float, unit: str, degrees: bool) -> str:
    return f"{math.degrees(value):.6g} deg" if degrees and unit == "rad" else f"{value:.6g} {unit}"


def _limit_message(error, degrees: bool) -> str:
    """JointLimitError's message, in degrees when the user gave degrees."""
    if not (degrees and error.unit == "rad"):
        return str(error)
    in_degrees = (math.degrees(v) for v in (error.value, error.lower, error.upper))
    return str(JointLimitError(error.joint, *in_degrees, unit="deg"))


def _check_precision(precision: int) -> None:
    if precision < 0 or precision > 17:
        raise UsageError(f"--precision {precision}: give a number of decimals from 0 to 17")


def _check_tolerance(tol: float, option: str = "--tol") -> None:
    if not (math.isfinite(tol) and tol > 0):
        raise UsageError(f"{option} {tol:g}: give a positive finite tolerance (m and rad)")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


# ----------------------------------------------------------------------
# tf-between / manipkit tf
# ----------------------------------------------------------------------


def _tf_parser(prog: str) -> argparse.ArgumentParser:
    parser = _Parser(
        prog=prog,
        description="Print T_SOURCE_TARGET, the pose of TARGET expressed in SOURCE (like tf2_echo SOURCE TARGET).",
    )
    _configure_tf(parser)
    return parser


def _configure_tf(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("source", metavar="SOURCE", help="reference frame (base_link and ee_link always work)")
    parser.add_argument("target", metavar="TARGET", help="frame whose pose is printed")
    _add_robot_options(parser)
    _add_joint_options(parser)
    parser.add_argument("--q-file", type=Path, metavar="FILE", help="CSV with a header of joint names, one configuration a row")
    parser.add_argument("--precision", type=int, default=6, metavar="N", help="decimals printed (default 6)")
    parser.add_argument("--format", choices=("text", "json", "csv"), default="text", help="output format (csv only with --q-file)")
    parser.add_argument("--compare", type=Path, metavar="FILE", help="hand-derived 4x4 (text rows, CSV, JSON or .npy) to check against the model")
    parser.add_argument("--tol", type=float, default=1e-6, help="agreement tolerance for --compare (m and rad, default 1e-6)")


def _pose_lines(robot, report: dict, precision: int) -> list[str]:
    """The text of ``tf-between``: robot, joint values, what the aliases stand for, then the pose."""
    from manipkit.app.pose import number_text, pose_text

    lines = [f"robot: {robot.name} ({robot.source.path})"]
    joints = " ".join(f"{name}={number_text(value, precision)}" for name, value in report["q"].items())
    lines.append(f"joints (rad/m): {joints or 'none'}")
    for alias in (report["source"], report["target"]):
        resolved = robot.frame(alias)
        if resolved != alias:
            note = f" ({robot.ee_reason})" if alias == "ee_link" else " (the root link)"
            lines.append(f"frame {alias} = {resolved}{note}")
    lines.append(pose_text(report, precision=precision))
    return lines


def _compare_lines(result, path: Path, tol: float) -> list[str]:
    lines = [f"compare with {path} (tolerance {tol:g}):"]
    if result.violations:
        lines.append("  not a valid homogeneous transform:")
        lines += [f"  - {v}" for v in result.violations]
    else:
        lines.append("  valid homogeneous transform (4x4, last row 0 0 0 1, R orthonormal with det +1)")
    lines.append(f"  position error: {result.position_error:.6g} m")
    lines.append(f"  rotation error: {result.rotation_error_deg:.6g} deg")
    lines += [f"  {line}" for line in result.explain(summary=False)]
    lines.append("  AGREES with the model" if result.agrees else "  DOES NOT AGREE with the model")
    return lines


def run_tf(args) -> int:
    _import_numpy_with_one_blas_thread()
    robot = _load(args)
    source, target = args.source, args.target
    robot.frame(source), robot.frame(target)  # unknown frames fail before anything else
    _check_precision(args.precision)
    if args.compare is not None:
        _check_tolerance(args.tol)
    if args.q_file is not None:
        return _run_tf_batch(robot, args)
    if args.format == "csv":
        raise UsageError("--format csv needs --q-file; use text or json for one configuration")
    q = _joint_vector(robot, args)
    T = robot.transform(source, target, q)
    status, comparison = EXIT_OK, None
    if args.compare is not None:
        from manipkit.spatial.compare import compare_transform, read_matrix

        comparison = compare_transform(T, read_matrix(args.compare), tol=args.tol)
        status = EXIT_OK if comparison.agrees else EXIT_MISMATCH
    from manipkit.app.pose import pose_report

    report = pose_report(robot, source, target, q, T=T)
    if args.format == "json":
        if comparison is not None:
            report["compare"] = {
                "file": str(args.compare),
                "violations": list(comparison.violations),
                "position_error": comparison.position_error,
                "rotation_error_deg": comparison.rotation_error_deg,
                "agrees": comparison.agrees,
                "explanation": comparison.explain(),
            }
        _print_json(report)
    else:
        lines = _pose_lines(robot, report, args.precision)
        if comparison is not None:
            lines += _compare_lines(comparison, args.compare, args.tol)
        print("\n".join(lines))
    return status


def _run_tf_batch(robot, args) -> int:
    import numpy as np

    from manipkit.app.pose import number_text, pose_fields

    if args.q or args.compare is not None:
        raise UsageError("--q-file cannot be combined with --q or --compare")
    Q = read_q_file(robot, args.q_file, degrees=args.deg, limits="clamp" if args.clamp else "error")
    T = robot.fk(Q, args.target, base=args.source)
    fields = pose_fields(T)
    if args.format == "json":
        rows = [
            {"q": robot.as_dict(q), "translation": t.tolist(), "quaternion_xyzw": quat.tolist(),
             "rpy": rpy.tolist(), "matrix": m.tolist()}
            for q, t, quat, rpy, m in zip(Q, fields["translation"], fields["quaternion_xyzw"], fields["rpy"], fields["matrix"])
        ]
        _print_json({"source": args.source, "target": args.target, "robot": robot.name, "poses": rows})
        return EXIT_OK
    header = "x,y,z,qx,qy,qz,qw,roll,pitch,yaw"
    table = np.hstack([fields["translation"], fields["quaternion_xyzw"], fields["rpy"]])
    print(f"# T_{args.source}_{args.target} of {robot.name}, one pose a row of {args.q_file}; m, rad, quaternion xyzw")
    print(header)
    for row in table:
        print(",".join(number_text(v, args.precision) for v in row))
    return EXIT_OK


def read_q_file(robot, path: Path, *, degrees: bool = False, limits: str = "ignore"):
    """Joint vectors (N, n) from a CSV whose header names joints; missing joints are 0.

    ``limits``: ``"ignore"`` (values as given), ``"error"`` (a value outside
    its joint's limits is an error naming the line) or ``"clamp"`` (moved
    to the nearest limit, with one warning summing up what was clamped).
    """
    import csv

    import numpy as np

    try:
        with open(path, newline="", encoding="utf-8") as handle:
            numbered = [
                (handle_line, row) for handle_line, row in _numbered_rows(csv.reader(handle))
                if row and any(cell.strip() for cell in row) and not row[0].lstrip().startswith("#")
            ]
    except IsADirectoryError:
        raise UsageError(f"--q-file {path}: is a folder, expected a CSV file") from None
    except OSError as exc:
        raise UsageError(f"--q-file {path}: cannot read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise UsageError(f"--q-file {path}: not a text file; expected CSV with a header of joint names") from None
    except csv.Error as exc:
        raise UsageError(f"--q-file {path}: not valid CSV ({exc})") from None
    if len(numbered) < 2:
        raise UsageError(f"--q-file {path}: needs a header of joint names and at least one row")
    header = [cell.strip() for cell in numbered[0][1]]
    unknown = [name for name in header if name not in robot.joint_names]
    if unknown:
        import difflib

        close = difflib.get_close_matches(unknown[0], robot.joint_names, n=1, cutoff=0.5)
        hint = f"did you mean {close[0]}? " if close else ""
        raise UsageError(f"--q-file {path}: unknown joint column(s) {', '.join(unknown)}; {hint}"
                         f"joints: {', '.join(robot.joint_names)}")
    repeated = sorted({name for name in header if header.count(name) > 1})
    if repeated:
        raise UsageError(f"--q-file {path}: column(s) {', '.join(repeated)} appear twice in the header")
    Q = np.empty((len(numbered) - 1, len(robot.joint_names)))
    clamped: list[str] = []
    for index, (number, row) in enumerate(numbered[1:]):
        if len(row) != len(header):
            raise UsageError(f"--q-file {path}: line {number} has {len(row)} values, the header has {len(header)}")
        try:
            q = robot.q(dict(zip(header, (cell.strip() for cell in row))), degrees=degrees)
        except ManipkitError as exc:
            raise UsageError(f"--q-file {path}: line {number}: {exc}") from None
        if limits != "ignore":
            violations = robot.limit_violations(q)
            if violations and limits == "clamp":
                clamped += [f"line {number} {e.joint}" for e in violations]
                q = robot.clamp(q)
            elif violations:  # the error of --q, with this file's line
                _limit_checked(robot, q, degrees=degrees, clamp=False, given=set(), prefix=f"--q-file {path}: line {number}: ")
        Q[index] = q
    if clamped:
        warn(f"--q-file {path}: clamped {len(clamped)} value(s) into the joint limits "
             f"({', '.join(clamped[:3])}{', ...' if len(clamped) > 3 else ''})")
    return Q


def _numbered_rows(reader):
    """(line number in the file, row) for each CSV row."""
    for row in reader:
        yield reader.line_num, row


# ----------------------------------------------------------------------
# manipkit robots | frames | tree
# ----------------------------------------------------------------------


def run_robots(args) -> int:
    from rich.console import Console
    from rich.table import Table

    import manipkit
    from manipkit.description.sources import bundled_robots, example_robot_data_arms

    table = Table(title="robots (--robot NAME); any .urdf/.xacro path works too")
    for column in ("name", "from", "DOF", "base_link", "ee_link", "file"):
        table.add_column(column)
    entries = [(name, "bundled") for name in bundled_robots()] + [(name, "example-robot-data") for name in example_robot_data_arms()]
    for name, origin in entries:
        try:
            robot = manipkit.load(name)
        except ManipkitError as exc:
            table.add_row(name, origin, "?", "?", "?", f"cannot load: {exc}")
            continue
        table.add_row(name, origin, str(len(robot.joints)), robot.root_link, robot.ee_frame, robot.source.path.name)
    Console(width=160).print(table)
    return EXIT_OK


def run_frames(args) -> int:
    from rich.console import Console
    from rich.table import Table

    robot = _load(args)
    console = Console(width=160)
    console.print(f"robot {robot.name}: {len(robot.frame_names)} frames; base_link = {robot.root_link}; ee_link = {robot.ee_reason}")
    console.print("frames: " + ", ".join(robot.frame_names))
    table = Table(title=f"movable joints of {robot.name} (radians / metres)")
    for column in ("#", "joint", "type", "axis", "parent -> child", "lower", "upper"):
        table.add_column(column)
    for index, joint in enumerate(robot.joints):
        table.add_row(
            str(index), joint.name, joint.type, " ".join(f"{a:g}" for a in joint.axis),
            f"{joint.parent} -> {joint.child}", f"{joint.lower:.6g}", f"{joint.upper:.6g}",
        )
    console.print(table)
    return EXIT_OK


def run_tree(args) -> int:
    from manipkit.description import tree
    from manipkit.description.tree import parse_structure

    robot = _load(args)
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


def run_dh_show(args) -> int:
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


def run_dh_check(args) -> int:
    from manipkit import dh
    from manipkit.dh.check import check_dh
    from manipkit.description.sources import resolve_dh_table

    path = resolve_dh_table(args.table)
    table = dh.load_dh(path)
    robot = _load(args)
    if args.samples < 1:
        raise UsageError(f"--samples {args.samples}: give at least 1")
    _check_tolerance(args.tol)
    result = check_dh(table, robot, base=args.base, tip=args.tip, samples=args.samples, tol=args.tol)
    if args.format == "json":
        _print_json({
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
            "diagnosis": list(result.diagnosis),
        })
    else:
        print(f"{table.convention} DH table {path.name} vs {robot.name} URDF chain {args.base} -> {args.tip}"
              f" ({len(result.joints)} joints: {', '.join(result.joints)})")
        if result.samples:
            print(f"{result.samples} configurations inside the joint limits: max position error "
                  f"{result.max_position_error:.3g} m, max rotation error {result.max_rotation_error:.3g} rad")
        print(f"PASS (within {result.tol:g})" if result.passed else f"FAIL (tolerance {result.tol:g})")
        for line in result.diagnosis[1 if result.samples else 0 :]:  # the first repeats the errors above
            print(f"- {line}")
    return EXIT_OK if result.passed else EXIT_MISMATCH


def run_dh_to_urdf(args) -> int:
    from manipkit import dh
    from manipkit.description.sources import resolve_dh_table

    table = dh.load_dh(resolve_dh_table(args.table))
    text = dh.urdf_from_dh(table)
    if args.output is None:
        print(text)
    else:
        args.output.write_text(text)
        print(f"wrote {args.output} ({table.n} joints, frames base_link, link_1..link_{table.n}, ee_link)")
    return EXIT_OK


def run_dh_from_urdf(args) -> int:
    from manipkit import dh
    from manipkit.dh.from_urdf import dh_from_urdf_chain

    robot = _load(args)
    table = dh_from_urdf_chain(robot, args.base, args.tip, convention=args.convention)
    if args.output is not None:
        header = (
            f"{table.convention} DH table of {robot.name} from {robot.frame(args.base)} to {robot.frame(args.tip)}, "
            f"rows = joints {', '.join(robot.chain_joints(args.base, args.tip))};\n"
            f"derived by `manipkit dh from-urdf --robot {args.robot or robot.source.name} --base {args.base} "
            f"--tip {args.tip} --convention {args.convention}` (exact to the URDF's numbers)"
        )
        dh.save_dh(table, args.output, header=header)
        print(f"wrote {args.output}")
    print(dh.format_dh_table(table))
    return EXIT_OK


def _ik_target(args):
    """T_base_frame from --xyz and --rpy/--quat (degrees for --rpy with --deg)."""
    import numpy as np

    from manipkit.spatial.rotations import matrix_from_quaternion, matrix_from_rpy

    for option, values, unit in (("--xyz", args.xyz, "m"), ("--rpy", args.rpy, "deg" if args.deg else "rad"),
                                 ("--quat", args.quat, "")):
        if values is not None and not all(math.isfinite(v) for v in values):
            bad = next(v for v in values if not math.isfinite(v))
            raise UsageError(f"{option} {' '.join(f'{v:g}' for v in values)}: {bad:g} is not finite; "
                             f"give finite numbers{' (' + unit + ')' if unit else ''}")
    T = np.eye(4)
    T[:3, 3] = args.xyz
    if args.rpy is not None:
        rpy = np.radians(args.rpy) if args.deg else np.array(args.rpy)
        T[:3, :3] = matrix_from_rpy(rpy)
    elif args.quat is not None:
        T[:3, :3] = matrix_from_quaternion(args.quat)  # InvalidRotationError for a zero quaternion
    return T


def _q_text(robot, q, precision: int) -> str:
    from manipkit.app.pose import number_text

    return " ".join(f"{name}={number_text(value, precision)}" for name, value in robot.as_dict(q).items())


def run_ik(args) -> int:
    from manipkit.kinematics.ik import analytic_ik, ik

    _check_precision(args.precision)
    if args.restarts < 0:
        raise UsageError(f"--restarts {args.restarts}: give 0 or more")
    robot = _load(args)
    target = _ik_target(args)
    oriented = args.rpy is not None or args.quat is not None
    mode = "position" if args.position_only or not oriented else ("position+axis" if args.axis else "pose")
    if args.analytic:
        if args.frame != "ee_link" or args.base != "base_link":
            raise UsageError("--analytic solves base_link -> ee_link; leave out --frame/--base")
        result = analytic_ik(robot, target)
        answers = [(label, q) for label, q in zip(result.labels, result.solutions)]
        success = bool(answers)
        residuals = result.residuals.max(axis=0) if success else (None, None)
        header = f"closed form ({result.solver}): {len(answers)} solution(s)" + (
            f" (count: {result.count})" if result.count != len(answers) else "")
        notes = [result.reason] if result.reason else []
        fallback = None
    else:
        q0 = _joint_vector(robot, args, option="--seed-q", items=args.seed_q) if args.seed_q else None
        found = ik(robot, target, frame=args.frame, base=args.base, mode=mode, axis=args.axis or "z",
                   q0=q0, all=args.all, restarts=args.restarts, seed=args.seed)
        results = list(found) if args.all else ([found] if found.success else [])
        best = found.best if args.all else found
        answers = [(None, r.q) for r in results]
        success = bool(answers)
        residuals = (best.residual_position, best.residual_rotation)
        header = (f"numerical IK ({mode}, frame {args.frame} in {args.base}): "
                  f"{'success' if success else 'FAILED'}; {best.iterations} iterations")
        notes = [best.reason] if best.reason else []
        fallback = None if success else best.q
    if args.format == "json":
        _print_json({
            "robot": robot.name,
            "mode": "analytic" if args.analytic else mode,
            "target": target.tolist(),
            "solutions": [robot.as_dict(q) for _, q in answers],
            "labels": [label for label, _ in answers] if args.analytic else None,
            "success": success,
            "residual_position": None if residuals[0] is None else float(residuals[0]),
            "residual_rotation": None if residuals[1] is None else float(residuals[1]),
            "notes": notes,
        })
    else:
        print(header)
        for index, (label, q) in enumerate(answers, start=1):
            print(f"{index}. {('[' + label + '] ') if label else ''}{_q_text(robot, q, args.precision)}")
        if fallback is not None:
            print(f"best found (does not reach the target): {_q_text(robot, fallback, args.precision)}")
        if residuals[0] is not None:
            print(f"residual: position {residuals[0]:.3g} m, rotation {residuals[1]:.3g} rad")
        for note in notes:
            print(f"note: {note}")
        if success:
            print(f"check one with: tf-between {args.base} {args.frame} --robot {args.robot or robot.source.name} --q "
                  + _q_text(robot, answers[0][1], args.precision))
    return EXIT_OK if success else EXIT_MISMATCH


def run_workspace(args) -> int:
    from manipkit.analysis.workspace import planar_link_lengths, planar_workspace, plot_planar_workspace

    if args.samples < 1:
        raise UsageError(f"--samples {args.samples}: give at least 1")
    robot = _load(args)
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
        _print_json(out)
    else:
        print(f"robot {robot.name}: planar arm with link lengths {', '.join(f'{v:g}' for v in lengths)} m")
        print(workspace.description)
        if args.plot is not None:
            print(f"wrote {args.plot}")
    return EXIT_OK


def run_view(args) -> int:
    import signal
    import threading
    import webbrowser

    from manipkit.app import viewer

    robot = _load(args, mesh_warnings=False)
    q = _joint_vector(robot, args)
    frames = tuple(args.frames)
    if args.static is not None:
        path = viewer.write_static(robot, args.static, frames=frames, q=q)
        size = path.stat().st_size / 1e6
        print(f"wrote {path} ({size:.1f} MB): {robot.name} with triads at {frames[0]} and {frames[1]}; "
              "open it in a browser, no server needed")
        return EXIT_OK

    def stop(signum, frame):  # `kill` (SIGTERM) stops as cleanly as Ctrl-C
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, stop)
    view = None
    try:
        view = viewer.open_view(robot, frames=frames, q=q, port=args.port)
        for warning in view.scene.warnings:
            warn(warning)
        print(f"control page: {view.url}", flush=True)
        print(f"meshcat scene: {view.scene_url}", flush=True)
        print(f"robot {robot.name}, T_{frames[0]}_{frames[1]} live; Ctrl-C stops the viewer", flush=True)
        if not args.no_browser:
            if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
                print("no display found: open the control page in a browser yourself", flush=True)
            else:  # in a thread: a console browser must not hold up the server
                threading.Thread(target=webbrowser.open, args=(view.url,), daemon=True).start()
        view.wait()
    except KeyboardInterrupt:
        print("viewer stopped", flush=True)
    finally:
        if view is not None:
            view.close()
        signal.signal(signal.SIGTERM, previous)
    return EXIT_OK


# ----------------------------------------------------------------------
# Entry points
# ----------------------------------------------------------------------


def _main_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="manipkit", description="Manipulator kinematics from URDF/xacro, without ROS.")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", parser_class=_Parser)
    tf = commands.add_parser("tf", help="pose of TARGET in SOURCE (same as tf-between)")
    _configure_tf(tf)
    tf.set_defaults(run=run_tf)
    robots = commands.add_parser("robots", help="bundled and example-robot-data robots with DOF and frames")
    robots.set_defaults(run=run_robots)
    frames = commands.add_parser("frames", help="links/frames and joints (type, axis, parent/child, limits)")
    _add_robot_options(frames)
    frames.set_defaults(run=run_frames)
    tree = commands.add_parser("tree", help="the link/joint tree as text, Graphviz DOT or an image")
    _add_robot_options(tree)
    tree.add_argument("--format", choices=("text", "dot", "png", "svg"), default=None, help="default: from -o's suffix, else text")
    tree.add_argument("-o", "--output", type=Path, default=None, metavar="FILE")
    tree.set_defaults(run=run_tree)
    dh = commands.add_parser("dh", help="DH tables: show, check against a URDF, to-urdf, from-urdf")
    dh_commands = dh.add_subparsers(dest="dh_command", required=True, metavar="COMMAND", parser_class=_Parser)
    show = dh_commands.add_parser("show", help="print a DH table (and its symbolic T_base_tool)")
    show.add_argument("table", metavar="TABLE", help="a bundled table name (e.g. iiwa14_seed004) or a .yaml file")
    show.add_argument("--symbolic", action="store_true", help="also print T_base_tool with SymPy (c_i/s_i shorthand)")
    show.add_argument("--latex", action="store_true", help="print the symbolic transform as LaTeX")
    show.set_defaults(run=run_dh_show)
    check = dh_commands.add_parser("check", help="compare a DH table with a robot's URDF chain, with a diagnosis")
    check.add_argument("table", metavar="TABLE", help="a bundled table name or a .yaml file")
    _add_robot_options(check)
    check.add_argument("--base", default="base_link", help="URDF frame of the table's base (default base_link)")
    check.add_argument("--tip", default="ee_link", help="URDF frame of the table's tool (default ee_link)")
    check.add_argument("--samples", type=int, default=1000, metavar="N", help="configurations within the limits (default 1000, fixed seed)")
    check.add_argument("--tol", type=float, default=1e-9, help="pass tolerance, m and rad (default 1e-9)")
    check.add_argument("--format", choices=("text", "json"), default="text")
    check.set_defaults(run=run_dh_check)
    to_urdf = dh_commands.add_parser("to-urdf", help="write a URDF for a DH table")
    to_urdf.add_argument("table", metavar="TABLE", help="a bundled table name or a .yaml file")
    to_urdf.add_argument("-o", "--output", type=Path, default=None, metavar="FILE.urdf")
    to_urdf.set_defaults(run=run_dh_to_urdf)
    from_urdf = dh_commands.add_parser("from-urdf", help="derive a DH table from a robot's URDF chain")
    _add_robot_options(from_urdf)
    from_urdf.add_argument("--base", default="base_link", help="URDF frame of the table's base (default base_link)")
    from_urdf.add_argument("--tip", default="ee_link", help="URDF frame of the table's tool (default ee_link)")
    from_urdf.add_argument("--convention", choices=("standard", "modified"), default="standard")
    from_urdf.add_argument("-o", "--output", type=Path, default=None, metavar="FILE.yaml", help="also save the table")
    from_urdf.set_defaults(run=run_dh_from_urdf)
    ik = commands.add_parser("ik", help="joint values that put a frame at a target pose (numerical or closed form)")
    _add_robot_options(ik)
    ik.add_argument("--frame", default="ee_link", help="frame to place (default ee_link)")
    ik.add_argument("--base", default="base_link", help="frame the target is given in (default base_link)")
    ik.add_argument("--xyz", type=float, nargs=3, required=True, metavar=("X", "Y", "Z"), help="target position (m)")
    orientation = ik.add_mutually_exclusive_group()
    orientation.add_argument("--rpy", type=float, nargs=3, metavar=("R", "P", "Y"), help="target orientation, URDF rpy (rad, or deg with --deg)")
    orientation.add_argument("--quat", type=float, nargs=4, metavar=("X", "Y", "Z", "W"), help="target orientation as a quaternion (x, y, z, w)")
    ik.add_argument("--position-only", action="store_true", help="ignore the orientation (default when none is given)")
    ik.add_argument("--axis", choices=("x", "y", "z"), default=None, help="match only this axis of the frame to the target's (position + pointing)")
    ik.add_argument("--analytic", action="store_true", help="use the robot's closed-form solver (planar_2r/3r, scara, stanford_arm, elbow_arm)")
    ik.add_argument("--all", action="store_true", help="numerical: return every distinct solution found within the restart budget")
    ik.add_argument("--seed-q", action="extend", nargs="+", default=[], metavar="NAME=VALUE", help="starting joint values")
    ik.add_argument("--deg", action="store_true", help="--rpy and --seed-q angles in degrees; solutions stay in radians")
    ik.add_argument("--clamp", action="store_true", help="clamp --seed-q values outside the joint limits (else an error)")
    ik.add_argument("--restarts", type=int, default=50, metavar="N", help="random restarts (default 50)")
    ik.add_argument("--seed", type=int, default=0, help="random seed for the restarts (default 0)")
    ik.add_argument("--precision", type=int, default=6, metavar="N")
    ik.add_argument("--format", choices=("text", "json"), default="text")
    ik.set_defaults(run=run_ik)
    workspace = commands.add_parser("workspace", help="reachable and dexterous workspace of a planar 2R/3R arm, with a plot")
    _add_robot_options(workspace)
    workspace.add_argument("--plot", type=Path, default=None, metavar="FILE.png", help="draw sampled points, boundary circles and a few poses")
    workspace.add_argument("--samples", type=int, default=20000, metavar="N", help="random configurations drawn for the plot (default 20000)")
    workspace.add_argument("--format", choices=("text", "json"), default="text")
    workspace.set_defaults(run=run_workspace)
    view = commands.add_parser("view", help="the robot in a browser (meshcat) with joint sliders and a live T_A_B readout")
    _add_robot_options(view)
    _add_joint_options(view)
    view.add_argument("--frames", nargs=2, default=["base_link", "ee_link"], metavar=("A", "B"),
                      help="frames of the readout T_A_B and of the two triads (default base_link ee_link)")
    view.add_argument("--port", type=int, default=8700, metavar="P", help="port of the control page (default 8700, 0 = any free port)")
    view.add_argument("--no-browser", action="store_true", help="print the URLs but do not open a browser")
    view.add_argument("--static", type=Path, default=None, metavar="FILE.html",
                      help="write a standalone HTML snapshot of the pose instead of serving")
    view.set_defaults(run=run_view)
    return parser


def _run(parser: argparse.ArgumentParser, argv, runner=None) -> int:
    args = parser.parse_args(argv)
    try:
        return (runner or args.run)(args)
    except ManipkitError as exc:
        print(f"{parser.prog}: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        return EXIT_OK
    except Exception as exc:  # a bug: short message, no traceback, exit 1
        detail = " ".join(str(exc).split())[:300]
        print(
            f"{parser.prog}: internal error ({type(exc).__name__}: {detail}); this is a bug in manipkit, "
            "please report it with the command line used",
            file=sys.stderr,
        )
        return EXIT_INTERNAL


def tf_between_main(argv=None) -> int:
    """``tf-between SOURCE TARGET [options]``."""
    return _run(_tf_parser("tf-between"), argv, run_tf)


def main(argv=None) -> int:
    """``manipkit COMMAND [options]``."""
    return _run(_main_parser(), argv)


if __name__ == "__main__":
    sys.exit(main())
