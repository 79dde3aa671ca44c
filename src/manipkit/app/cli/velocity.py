"""``manipkit jacobian`` (the Jacobian at one configuration, with its indices) and ``manipkit dexterity`` (GCI).

The numbers come from :mod:`manipkit.kinematics.jacobian`,
:mod:`manipkit.analysis.manipulability` and :mod:`manipkit.analysis.dexterity`
(docs/architecture.md): rows ``vx vy vz wx wy wz`` (linear velocity of the
frame's origin, m/s, then angular velocity, rad/s), columns by joint name.
Indices that combine linear and angular rows multiply the angular ones by a
characteristic length (``--length``, 1 m unless given; always printed).
"""

from __future__ import annotations

import math
import sys

from manipkit.app.cli.common import (
    EXIT_OK,
    UsageError,
    add_joint_options,
    add_robot_options,
    check_precision,
    joint_vector,
    load_robot,
    print_json,
    q_text,
)
from manipkit.text import number_text, short_text

__all__ = ["jacobian_report", "parse_axes", "register", "run_dexterity", "run_jacobian"]

ROW_NAMES = ("vx", "vy", "vz", "wx", "wy", "wz")
REFERENCE_NAMES = {
    "base": "the base frame's axes (Pinocchio LOCAL_WORLD_ALIGNED when the base is the root; RTB jacob0)",
    "local": "the frame's own axes (Pinocchio LOCAL; RTB jacobe)",
}


def register(commands) -> None:
    """Add ``manipkit jacobian`` and ``manipkit dexterity`` to the subparsers ``commands``."""
    jac = commands.add_parser("jacobian", help="the frame Jacobian at one configuration, its manipulability and singular values")
    add_robot_options(jac)
    add_joint_options(jac)
    jac.add_argument("--frame", default="ee_link", metavar="F", help="frame whose velocity is given (default ee_link)")
    jac.add_argument("--base", default="base_link", metavar="B", help="frame it moves relative to (default base_link)")
    jac.add_argument("--reference", choices=("base", "local"), default="base",
                     help="axes of the rows: the base frame's (RTB jacob0) or the frame's own (RTB jacobe); default base")
    _add_length_option(jac)
    jac.add_argument("--singular-tol", type=float, default=1e-9, metavar="TOL",
                     help="singular values below TOL do not count to the rank; the configuration is singular when "
                          "the rank of all rows (angular ones times the length) or of the translation rows is below "
                          "its rank at a generic configuration (default 1e-9)")
    jac.add_argument("--precision", type=int, default=6, metavar="N", help="decimals printed (default 6)")
    jac.add_argument("--format", choices=("text", "json"), default="text")
    jac.set_defaults(run=run_jacobian)

    dex = commands.add_parser("dexterity", help="global conditioning index: mean inverse condition number over the joint space")
    add_robot_options(dex)
    dex.add_argument("--samples", type=int, default=100_000, metavar="N", help="configurations sampled (default 100000)")
    dex.add_argument("--frame", default="ee_link", metavar="F", help="frame of the Jacobian (default ee_link)")
    dex.add_argument("--base", default="base_link", metavar="B", help="base of the Jacobian (default base_link)")
    dex.add_argument("--axes", default="all", metavar="ROWS",
                     help="rows used: all, trans, rot or names such as vx,vy,wz (default all)")
    _add_length_option(dex)
    dex.add_argument("--seed", type=int, default=0, help="seed of the sampler (default 0)")
    dex.add_argument("--confidence", type=float, default=0.95, help="level of the confidence interval (default 0.95)")
    dex.add_argument("--progress", choices=("auto", "yes", "no"), default="auto",
                     help="progress bar on stderr: auto (when stderr is a terminal), yes or no")
    dex.add_argument("--format", choices=("text", "json"), default="text")
    dex.set_defaults(run=run_dexterity)


def _add_length_option(parser) -> None:
    parser.add_argument("--length", type=float, default=1.0, metavar="L",
                        help="characteristic length (m) multiplying the angular rows where they are combined with "
                             "linear ones, so the units agree (default 1)")


def _check_length(length: float) -> None:
    if not (math.isfinite(length) and length > 0):
        raise UsageError(f"--length {short_text(length)}: give a positive characteristic length in metres")


def parse_axes(text: str):
    """``all``, ``trans``, ``rot`` or comma-separated row names (``vx,vy,wz``) -> the ``axes`` argument."""
    if text in ("all", "trans", "rot"):
        return text
    names = [name.strip() for name in text.split(",")]
    unknown = [name for name in names if name not in ROW_NAMES]
    if unknown or len(set(names)) != len(names):
        raise UsageError(f"--axes {text}: give all, trans, rot or distinct row names from "
                         f"{', '.join(ROW_NAMES)} separated by commas (vx,vy,wz)")
    return [ROW_NAMES.index(name) for name in names]


def _finite_or_none(value: float):
    return float(value) if math.isfinite(value) else None


def jacobian_report(robot, q, *, frame: str, base: str, reference: str, length: float, singular_tol: float) -> dict:
    """The answer of ``manipkit jacobian`` as a JSON-ready dict (keys of the command-line contract)."""
    import numpy as np

    from manipkit.analysis.dexterity import generic_rank, rank
    from manipkit.analysis.manipulability import condition_number, manipulability, singular_values
    from manipkit.analysis.singularities import null_space_motion, singular_family_at
    from manipkit.kinematics.jacobian import jacobian, jacobian_columns

    J_all = jacobian(robot, q, frame, base, reference=reference)
    columns = jacobian_columns(robot, frame, base)
    J = J_all[:, columns]  # the indices count the chain's joints only (not wheels)
    s = singular_values(J, "all", length)
    ranks = {axes: rank(J, axes, length, tol=singular_tol) for axes in ("all", "trans")}
    generic = {axes: generic_rank(robot, frame, base, axes, length, tol=singular_tol) for axes in ("all", "trans")}
    report = {
        "robot": robot.name,
        "frame": frame,
        "base": base,
        "q": robot.as_dict(q),
        "reference": reference,
        "rows": list(ROW_NAMES),
        "joints": list(robot.joint_names),
        "jacobian": J_all.tolist(),
        "length": length,
        "manipulability": manipulability(J, "yoshikawa", "all", length),
        "manipulability_translation": manipulability(J, "yoshikawa", "trans"),
        "condition_number": _finite_or_none(float(condition_number(J, "all", length))),
        "singular_values": s.tolist(),
        "rank": ranks["all"],
        "generic_rank": generic["all"],
        "rank_translation": ranks["trans"],
        "generic_rank_translation": generic["trans"],
        "singular": any(ranks[axes] < generic[axes] for axes in ranks),
        "singular_family": None,
        "null_space": None,
    }
    # The families are those of the arm's ee_link in its base_link (analysis.singularities).
    if robot.frame(frame) == robot.frame("ee_link") and robot.frame(base) == robot.frame("base_link"):
        family = singular_family_at(robot, q)
        report["singular_family"] = None if family is None else f"{family.name}: {family.condition}"
    if report["singular"]:  # in words, for the rows that lost rank: the translation rows, else all (scaled)
        if ranks["trans"] < generic["trans"]:
            rows, names = J[:3], ROW_NAMES[:3]
        else:
            rows, names = np.vstack([J[:3], length * J[3:]]), ROW_NAMES
        report["null_space"] = null_space_motion(rows, [robot.joint_names[c] for c in columns], tol=max(singular_tol, 1e-12),
                                                 row_names=names)
    return report


def run_jacobian(args) -> int:
    """Print the Jacobian as a labelled matrix (text) or the JSON of :func:`jacobian_report`."""
    check_precision(args.precision)
    _check_length(args.length)
    if not (math.isfinite(args.singular_tol) and args.singular_tol >= 0):
        raise UsageError(f"--singular-tol {short_text(args.singular_tol)}: give a tolerance >= 0")
    robot = load_robot(args)
    robot.frame(args.frame), robot.frame(args.base)  # unknown frames fail before the joint values are read
    q = joint_vector(robot, args)
    report = jacobian_report(robot, q, frame=args.frame, base=args.base, reference=args.reference,
                             length=args.length, singular_tol=args.singular_tol)
    if args.format == "json":
        print_json(report)
    else:
        print("\n".join(_jacobian_lines(robot, report, args.precision, args.singular_tol)))
    return EXIT_OK


def _jacobian_lines(robot, report: dict, precision: int, singular_tol: float) -> list[str]:
    frame, base = report["frame"], report["base"]
    names = [frame if robot.frame(frame) == frame else f"{frame} ({robot.frame(frame)})",
             base if robot.frame(base) == base else f"{base} ({robot.frame(base)})"]
    lines = [
        f"robot: {robot.name} ({robot.source.path})",
        f"joints (rad/m): {q_text(report['q'], precision) or 'none'}",
        f"Jacobian of {names[0]} relative to {names[1]}, in {REFERENCE_NAMES[report['reference']]}",
        "rows: velocity of the frame's origin (m/s), angular velocity (rad/s), per unit joint rate (rad/s or m/s)",
    ]
    cells = [[number_text(value, precision) for value in row] for row in report["jacobian"]]
    joints = report["joints"]
    widths = [max([len(name)] + [len(row[j]) for row in cells]) for j, name in enumerate(joints)]
    lines.append("    " + "  ".join(name.rjust(width) for name, width in zip(joints, widths)))
    for label, row in zip(ROW_NAMES, cells):
        lines.append(f"{label:<4}" + "  ".join(cell.rjust(width) for cell, width in zip(row, widths)))
    length = short_text(report["length"])
    kappa = report["condition_number"]
    lines += [
        f"manipulability (Yoshikawa, all rows, angular rows times length {length} m): "
        f"{short_text(report['manipulability'])}",
        f"manipulability (Yoshikawa, translation rows): {short_text(report['manipulability_translation'])}",
        f"condition number (all rows, length {length} m): {'inf' if kappa is None else short_text(kappa)}",
        f"singular values: {' '.join(short_text(v) for v in report['singular_values'])}",
        f"rank: {report['rank']} of {report['generic_rank']} (all rows), {report['rank_translation']} of "
        f"{report['generic_rank_translation']} (translation rows), singular values below {short_text(singular_tol)} "
        "not counted",
        f"singular: {'yes' if report['singular'] else 'no'}"
        + (f" (family: {report['singular_family']})" if report["singular_family"] else ""),
    ]
    if report["null_space"]:
        lines.append(f"  {report['null_space']}")
    return lines


def run_dexterity(args) -> int:
    """Print the global conditioning index and its confidence interval; progress bar on stderr."""
    from manipkit.analysis.dexterity import global_conditioning_index
    from manipkit.analysis.manipulability import mixes_units

    if args.samples < 2:
        raise UsageError(f"--samples {args.samples}: give at least 2 configurations")
    if not (0.0 < args.confidence < 1.0):
        raise UsageError(f"--confidence {short_text(args.confidence)}: give a level between 0 and 1 (0.95 for 95%)")
    _check_length(args.length)
    axes = parse_axes(args.axes)
    robot = load_robot(args)
    robot.frame(args.frame), robot.frame(args.base)
    progress = sys.stderr.isatty() if args.progress == "auto" else args.progress == "yes"
    length = args.length if mixes_units(axes) else None
    gci = global_conditioning_index(robot, args.samples, args.frame, args.base, axes=axes, length=length,
                                    seed=args.seed, confidence=args.confidence, progress=progress)
    if args.format == "json":
        print_json({
            "robot": robot.name, "frame": gci.frame, "base": gci.base, "axes": args.axes, "length": gci.length,
            "samples": gci.samples, "seed": args.seed, "gci": gci.mean, "confidence": gci.confidence,
            "interval": [gci.low, gci.high], "std": gci.std,
        })
    else:
        rows = args.axes if length is None else f"{args.axes}, angular rows times length {short_text(length)} m"
        print(f"robot: {robot.name} ({robot.source.path})")
        print(f"Jacobian of {gci.frame} relative to {gci.base}, rows {rows}")
        print(gci)
        print(f"inverse condition number 1/kappa over the samples: mean {short_text(gci.mean, 4)}, "
              f"standard deviation {short_text(gci.std, 4)}; seed {args.seed}")
    return EXIT_OK
