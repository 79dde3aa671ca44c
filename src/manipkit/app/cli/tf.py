"""``tf-between SOURCE TARGET`` and ``manipkit tf``: T_SOURCE_TARGET, the pose of TARGET in SOURCE.

Printed like ROS 2 ``tf2_echo SOURCE TARGET`` (text), as the JSON of the
command-line contract, or for ``--q-file`` one pose a CSV row or a JSON Lines
object (``--format jsonl``), or one JSON document; ``--q-file`` streams: rows
are read, computed and written a batch at a time, in bounded memory however
long the file. ``--compare`` checks a hand-derived matrix against the model. Conventions (frames
``T_a_b``, metres and radians, quaternion (x, y, z, w), URDF rpy):
docs/architecture.md.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from manipkit.app.cli.common import (
    EXIT_MISMATCH,
    EXIT_OK,
    Parser,
    UsageError,
    add_joint_options,
    add_robot_options,
    alias_lines,
    alias_rules,
    check_precision,
    check_tolerance,
    joint_vector,
    limit_hint,
    load_robot,
    print_json,
    q_text,
    warn,
)
from manipkit.errors import JointLimitError, ManipkitError
from manipkit.text import short_text

if TYPE_CHECKING:

    from manipkit.kinematics.robot import Robot

__all__ = ["register", "run_tf", "tf_parser"]


def tf_parser(prog: str) -> argparse.ArgumentParser:
    """The parser of ``tf-between`` (its own program)."""
    parser = Parser(
        prog=prog,
        description="Print T_SOURCE_TARGET, the pose of TARGET expressed in SOURCE (like tf2_echo SOURCE TARGET).",
    )
    _configure(parser)
    return parser


def register(commands) -> None:
    """Add ``manipkit tf`` to the subparsers ``commands``."""
    tf = commands.add_parser("tf", help="pose of TARGET in SOURCE (same as tf-between)")
    _configure(tf)
    tf.set_defaults(run=run_tf)


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("source", metavar="SOURCE", help="reference frame (base_link and ee_link always work)")
    parser.add_argument("target", metavar="TARGET", help="frame whose pose is printed")
    add_robot_options(parser)
    add_joint_options(parser)
    parser.add_argument("--q-file", type=Path, metavar="FILE", help="CSV with a header of joint names, one configuration a row")
    parser.add_argument("--precision", type=int, default=6, metavar="N", help="decimals printed (default 6)")
    parser.add_argument("--format", choices=("text", "json", "csv", "jsonl"), default="text",
                        help="output format; with --q-file: text or csv (one pose a row), jsonl (JSON Lines: one pose "
                             "a line) or json (one document); all stream, but only csv and jsonl can be read as "
                             "they arrive (csv and jsonl only with --q-file)")
    parser.add_argument("--compare", type=Path, metavar="FILE",
                        help="hand-derived 4x4 (text rows, CSV, JSON or .npy) to check against the model; "
                             "a 3x3 rotation compares the rotations only")
    parser.add_argument("--tol", type=float, default=1e-6, help="agreement tolerance for --compare (m and rad, default 1e-6)")


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


def run_tf(args) -> int:
    """One pose (text or JSON, optionally compared with a hand matrix), or one a row of ``--q-file``."""
    _import_numpy_with_one_blas_thread()
    robot = load_robot(args)
    source, target = args.source, args.target
    robot.frame(source), robot.frame(target)  # unknown frames fail before anything else
    check_precision(args.precision)
    if args.compare is not None:
        check_tolerance(args.tol)
    if args.q_file is not None:
        return _run_batch(robot, args)
    if args.format in ("csv", "jsonl"):
        raise UsageError(f"--format {args.format} needs --q-file; use text or json for one configuration")
    q = joint_vector(robot, args)  # checked here once: finite, one per joint, inside the limits (or clamped)
    T = robot.transform(source, target, q, check_limits=False)
    status, comparison = EXIT_OK, None
    if args.compare is not None:
        from manipkit.inputs.matrices import read_matrix
        from manipkit.spatial.compare import compare_transform

        comparison = compare_transform(T, read_matrix(args.compare, rotation=True), tol=args.tol)
        status = EXIT_OK if comparison.agrees else EXIT_MISMATCH
    from manipkit.app.pose import pose_report

    report = pose_report(robot, source, target, q, T=T)
    if args.format == "json":
        report.update(alias_rules(robot, source, target))  # "ee_link": {"link": ..., "rule": ...}
        if comparison is not None:
            report["compare"] = {
                "file": str(args.compare),
                "rotation_only": comparison.rotation_only,  # a 3x3 rotation: the translation is not compared
                "violations": list(comparison.violations),
                "position_error": None if comparison.rotation_only else comparison.position_error,
                "rotation_error_deg": comparison.rotation_error_deg,
                "agrees": comparison.agrees,
                "explanation": comparison.explain(),
            }
        print_json(report)
    else:
        lines = _pose_lines(robot, report, args.precision)
        if comparison is not None:
            lines += _compare_lines(comparison, args.compare, args.tol)
        print("\n".join(lines))
    return status


def _pose_lines(robot: Robot, report: dict, precision: int) -> list[str]:
    """The text of ``tf-between``: robot, joint values, what the aliases stand for, then the pose."""
    from manipkit.app.pose import pose_text

    lines = [f"robot: {robot.name} ({robot.source.path})"]
    lines.append(f"joints (rad/m): {q_text(report['q'], precision) or 'none'}")
    lines += alias_lines(robot, report["source"], report["target"])
    lines.append(pose_text(report, precision=precision))
    return lines


def _compare_lines(result, path: Path, tol: float) -> list[str]:
    lines = [f"compare with {path} (tolerance {short_text(tol)}):"]
    if result.rotation_only:
        lines.append("  a 3x3 rotation: comparing rotations only (the translation is not checked)")
        if result.violations:
            lines.append("  not a valid rotation:")
            lines += [f"  - {v}" for v in result.violations]
        else:
            lines.append("  valid rotation (3x3, orthonormal with det +1)")
        lines.append(f"  rotation error: {short_text(result.rotation_error_deg)} deg")
        lines += [f"  {line}" for line in result.explain(summary=False)]
        lines.append("  the rotation AGREES with the model" if result.agrees else "  the rotation DOES NOT AGREE with the model")
        return lines
    if result.violations:
        lines.append("  not a valid homogeneous transform:")
        lines += [f"  - {v}" for v in result.violations]
    else:
        lines.append("  valid homogeneous transform (4x4, last row 0 0 0 1, R orthonormal with det +1)")
    lines.append(f"  position error: {short_text(result.position_error)} m")
    lines.append(f"  rotation error: {short_text(result.rotation_error_deg)} deg")
    lines += [f"  {line}" for line in result.explain(summary=False)]
    lines.append("  AGREES with the model" if result.agrees else "  DOES NOT AGREE with the model")
    return lines


def _run_batch(robot: Robot, args) -> int:
    """``--q-file``: one pose a row as CSV (text, csv), JSON Lines (jsonl) or one JSON document (json), streamed.

    Rows are read, computed (:meth:`Robot.fk` on a batch) and written a batch
    at a time (:func:`manipkit.kinematics.q_file.iter_q_file`), so memory
    does not grow with the file. A bad row in the first batch stops the
    command before anything is written; a bad row further on stops the
    output there (exit 2, the line named on stderr). ``--clamp`` warnings
    come at the end.
    """
    import warnings

    if args.q or args.compare is not None:
        raise UsageError("--q-file cannot be combined with --q or --compare")
    begin, pose_rows, separator, end = _batch_format(robot, args)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        for index, Q in enumerate(_q_file_batches(robot, args)):
            T = robot.fk(Q, base=args.source, tip=args.target)
            sys.stdout.write((begin if index == 0 else separator) + pose_rows(Q, T))
        sys.stdout.write(end)
        sys.stdout.flush()
    for caught_warning in caught:
        if issubclass(caught_warning.category, UserWarning):
            warn(f"--q-file {caught_warning.message}")
        else:
            warnings.showwarning(caught_warning.message, caught_warning.category, caught_warning.filename, caught_warning.lineno)
    return EXIT_OK


def _batch_format(robot: Robot, args):
    """(text before the first batch, batch -> text, text between batches, text after the last batch).

    The text is what the whole-file printout gave: CSV numbers as
    :func:`manipkit.text.number_text` writes them, JSON as ``json.dumps``
    (``indent=2`` for ``json``, one compact object a line for ``jsonl``).
    Each batch is formatted with one %-template a pose (floats as ``repr``,
    which is how ``json`` writes them), not value by value.
    """
    import json
    import re

    import numpy as np

    from manipkit.app.pose import pose_fields

    if args.format not in ("json", "jsonl"):
        fmt = ",".join([f"%.{args.precision}f"] * 10)
        negative_zero = re.compile(r"(?m)(^|,)-(?=0(?:\.0*)?(?:,|$))")  # "-0.000" -> "0.000", as number_text

        def csv_rows(Q, T):
            fields = pose_fields(T)
            table = np.hstack([fields["translation"], fields["quaternion_xyzw"], fields["rpy"]])
            return negative_zero.sub(r"\1", "\n".join(fmt % tuple(row) for row in table.tolist())) + "\n"

        begin = (f"# T_{args.source}_{args.target} of {robot.name}, one pose a row of {args.q_file}; m, rad, quaternion xyzw\n"
                 "x,y,z,qx,qy,qz,qw,roll,pitch,yaw\n")
        return begin, csv_rows, "", ""
    slot = "\x00"  # a placeholder no joint name holds (XML has no NUL); its JSON is "\u0000"
    sample = {"q": dict.fromkeys(robot.joint_names, slot), "translation": [slot] * 3, "quaternion_xyzw": [slot] * 4,
              "rpy": [slot] * 3, "matrix": [[slot] * 4 for _ in range(4)]}
    indent = 2 if args.format == "json" else None
    pose = json.dumps(sample, indent=indent).replace("%", "%%").replace(json.dumps(slot), "%r")
    if args.format == "json":
        pose = "\n".join("    " + line for line in pose.splitlines())
    separator = ",\n" if args.format == "json" else "\n"

    def json_rows(Q, T):
        fields = pose_fields(T)
        table = np.hstack([Q, fields["translation"], fields["quaternion_xyzw"], fields["rpy"],
                           fields["matrix"].reshape(len(Q), 16)])
        return separator.join(pose % tuple(row) for row in table.tolist())

    if args.format == "jsonl":
        return "", json_rows, "\n", "\n"
    document = json.dumps({"source": args.source, "target": args.target, "robot": robot.name, "poses": [None]}, indent=2)
    begin, end = document.split("\n    null\n")
    return begin + "\n", json_rows, separator, "\n" + end + "\n"


def _q_file_batches(robot: Robot, args):
    """The joint vectors of ``--q-file`` a batch at a time: limits checked (or clamped with --clamp), errors as usage errors."""
    from manipkit.errors import InputFileError
    from manipkit.kinematics.q_file import iter_q_file

    batches = iter_q_file(robot, args.q_file, degrees=args.deg, limits="clamp" if args.clamp else "error", what="--q-file")
    while True:
        try:
            Q = next(batches)
        except StopIteration:
            return
        except InputFileError:
            raise  # names --q-file itself
        except JointLimitError as exc:
            raise UsageError(f"--q-file {exc}; use --clamp to clamp{limit_hint(exc, args.deg)}") from None
        except ManipkitError as exc:
            raise UsageError(f"--q-file {exc}") from None
        yield Q
