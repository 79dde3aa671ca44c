"""``tf-between SOURCE TARGET`` and ``manipkit tf``: T_SOURCE_TARGET, the pose of TARGET in SOURCE.

Printed like ROS 2 ``tf2_echo SOURCE TARGET`` (text), as the JSON of the
command-line contract, or one pose a CSV row for ``--q-file``; ``--compare``
checks a hand-derived matrix against the model. Conventions (frames
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
    import numpy as np

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
    parser.add_argument("--format", choices=("text", "json", "csv"), default="text", help="output format (csv only with --q-file)")
    parser.add_argument("--compare", type=Path, metavar="FILE", help="hand-derived 4x4 (text rows, CSV, JSON or .npy) to check against the model")
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
    if args.format == "csv":
        raise UsageError("--format csv needs --q-file; use text or json for one configuration")
    q = joint_vector(robot, args)
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
    for alias in (report["source"], report["target"]):
        resolved = robot.frame(alias)
        if resolved != alias:
            note = f" ({robot.ee_reason})" if alias == "ee_link" else " (the root link)"
            lines.append(f"frame {alias} = {resolved}{note}")
    lines.append(pose_text(report, precision=precision))
    return lines


def _compare_lines(result, path: Path, tol: float) -> list[str]:
    lines = [f"compare with {path} (tolerance {short_text(tol)}):"]
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
    """``--q-file``: one pose a row, as CSV (text) or JSON."""
    import numpy as np

    from manipkit.app.pose import pose_fields
    from manipkit.text import number_text

    if args.q or args.compare is not None:
        raise UsageError("--q-file cannot be combined with --q or --compare")
    Q = _q_file_rows(robot, args)
    T = robot.fk(Q, args.target, base=args.source)
    fields = pose_fields(T)
    if args.format == "json":
        rows = [
            {"q": robot.as_dict(q), "translation": t.tolist(), "quaternion_xyzw": quat.tolist(),
             "rpy": rpy.tolist(), "matrix": m.tolist()}
            for q, t, quat, rpy, m in zip(Q, fields["translation"], fields["quaternion_xyzw"], fields["rpy"], fields["matrix"])
        ]
        print_json({"source": args.source, "target": args.target, "robot": robot.name, "poses": rows})
        return EXIT_OK
    header = "x,y,z,qx,qy,qz,qw,roll,pitch,yaw"
    table = np.hstack([fields["translation"], fields["quaternion_xyzw"], fields["rpy"]])
    print(f"# T_{args.source}_{args.target} of {robot.name}, one pose a row of {args.q_file}; m, rad, quaternion xyzw")
    print(header)
    for row in table:
        print(",".join(number_text(v, args.precision) for v in row))
    return EXIT_OK


def _q_file_rows(robot: Robot, args) -> np.ndarray:
    """The joint vectors of ``--q-file``: limits checked (or clamped with --clamp), errors as usage errors."""
    import warnings

    from manipkit.kinematics.q_file import read_q_file

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        try:
            Q = read_q_file(robot, args.q_file, degrees=args.deg, limits="clamp" if args.clamp else "error")
        except JointLimitError as exc:
            raise UsageError(f"--q-file {exc}; use --clamp to clamp{limit_hint(exc, args.deg)}") from None
        except ManipkitError as exc:
            raise UsageError(f"--q-file {exc}") from None
    for caught_warning in caught:
        if issubclass(caught_warning.category, UserWarning):
            warn(f"--q-file {caught_warning.message}")
        else:
            warnings.showwarning(caught_warning.message, caught_warning.category, caught_warning.filename, caught_warning.lineno)
    return Q
