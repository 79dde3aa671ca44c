"""``manipkit jacobian`` (the Jacobian at one configuration, with its indices) and ``manipkit dexterity`` (GCI).

The numbers come from :func:`manipkit.analysis.jacobian_report.jacobian_report`
(the chain's Jacobian, its indices, ranks, whether it is singular, the
families that hold and what is lost, worded by :mod:`manipkit.app.jacobian_text`)
and :mod:`manipkit.analysis.dexterity` (docs/architecture.md): rows ``vx vy vz wx wy wz`` (linear velocity of the
frame's origin, m/s, then angular velocity, rad/s), columns by joint name.
Indices that combine linear and angular rows multiply the angular ones by a
characteristic length (``--length``, 1 m unless given; always printed).
"""

from __future__ import annotations

import math

from manipkit import bounds
from manipkit.app.cli.common import (
    EXIT_OK,
    UsageError,
    add_joint_options,
    add_robot_options,
    check_precision,
    command_chain,
    joint_vector,
    load_robot,
    print_json,
    q_text,
)
from manipkit.text import number_text, short_text

__all__ = ["jacobian_json", "parse_axes", "register", "run_dexterity", "run_jacobian"]

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
    jac.add_argument("--tip", "--frame", dest="tip", default="ee_link", metavar="F", help="frame whose velocity is given (default ee_link)")
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
    dex.add_argument("--tip", "--frame", dest="tip", default="ee_link", metavar="F", help="frame of the Jacobian (default ee_link)")
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
    bounds.length(length, "--length", error=UsageError)


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


def jacobian_json(robot, q, report) -> dict:
    """The answer of ``manipkit jacobian`` as a JSON-ready dict (keys of the command-line contract).

    ``report`` is :func:`manipkit.analysis.jacobian_report.jacobian_report` of
    ``robot.chain(base, frame)`` at ``q`` (a whole-robot vector). The matrix
    has one column per robot joint (``joints``; those off the chain are 0),
    the indices, ranks and what is lost count the chain's joints only
    (``chain_joints``); the singularity keys are
    :func:`manipkit.app.jacobian_text.singularity_data`.
    """
    import numpy as np

    from manipkit.app.jacobian_text import singularity_data

    chain = report.chain
    J_robot = np.zeros((6, len(robot.joint_names)))
    J_robot[:, chain.columns] = report.jacobian  # joints that do not move the frame relative to the base: 0
    return {
        "robot": robot.name,
        "frame": chain.tip,
        "base": chain.base,
        "q": robot.as_dict(q),
        "reference": report.reference,
        "rows": list(ROW_NAMES),
        "joints": list(robot.joint_names),
        "chain_joints": list(chain.joint_names),
        "jacobian": J_robot.tolist(),
        "length": report.length,
        "manipulability": report.manipulability,
        "manipulability_translation": report.manipulability_translation,
        "condition_number": _finite_or_none(report.condition_number),
        "singular_values": report.singular_values.tolist(),
        **singularity_data(report),
    }


def run_jacobian(args) -> int:
    """Print the Jacobian as a labelled matrix (text) or the JSON of :func:`jacobian_json`."""
    from manipkit.analysis.jacobian_report import jacobian_report

    check_precision(args.precision)
    _check_length(args.length)
    if not (math.isfinite(args.singular_tol) and args.singular_tol >= 0):
        raise UsageError(f"--singular-tol {short_text(args.singular_tol)}: give a tolerance >= 0")
    robot = load_robot(args)
    chain = command_chain(robot, args.base, args.tip)  # unknown frames, or none joined by a joint: before the q
    q = joint_vector(robot, args)
    report = jacobian_report(chain, q[chain.columns], reference=args.reference, length=args.length,
                             tol=args.singular_tol)
    answer = jacobian_json(robot, q, report)
    answer["frame"], answer["base"] = args.tip, args.base  # as given (aliases such as ee_link kept)
    if args.format == "json":
        print_json(answer)
    else:
        print("\n".join(_jacobian_lines(robot, answer, report, args.precision)))
    return EXIT_OK


def _jacobian_lines(robot, answer: dict, report, precision: int) -> list[str]:
    from manipkit.app.jacobian_text import singularity_lines

    frame, base = answer["frame"], answer["base"]
    names = [frame if robot.frame(frame) == frame else f"{frame} ({robot.frame(frame)})",
             base if robot.frame(base) == base else f"{base} ({robot.frame(base)})"]
    lines = [
        f"robot: {robot.name} ({robot.source.path})",
        f"joints (rad/m): {q_text(answer['q'], precision) or 'none'}",
        f"Jacobian of {names[0]} relative to {names[1]}, in {REFERENCE_NAMES[answer['reference']]}",
        "rows: velocity of the frame's origin (m/s), angular velocity (rad/s), per unit joint rate (rad/s or m/s)",
    ]
    # the chain's own columns, in chain order (the JSON keeps one column per robot joint, 0 off the chain)
    cells = [[number_text(value, precision) for value in row] for row in report.jacobian]
    joints = list(report.chain.joint_names)
    widths = [max([len(name)] + [len(row[j]) for row in cells]) for j, name in enumerate(joints)]
    lines.append("    " + "  ".join(name.rjust(width) for name, width in zip(joints, widths)))
    for label, row in zip(ROW_NAMES, cells):
        lines.append(f"{label:<4}" + "  ".join(cell.rjust(width) for cell, width in zip(row, widths)))
    length = short_text(answer["length"])
    kappa = answer["condition_number"]
    lines += [
        f"manipulability (Yoshikawa, all rows, angular rows times length {length} m): "
        f"{short_text(answer['manipulability'])}",
        f"manipulability (Yoshikawa, translation rows): {short_text(answer['manipulability_translation'])}",
        f"condition number (all rows, length {length} m): {'inf' if kappa is None else short_text(kappa)}",
        f"singular values: {' '.join(short_text(v) for v in answer['singular_values']) or 'none'}",
    ]
    return lines + singularity_lines(report)


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
    chain = command_chain(robot, args.base, args.tip)
    from manipkit.app.progress import progress_bar

    length = args.length if mixes_units(axes) else None
    with progress_bar(None if args.progress == "auto" else args.progress == "yes") as progress:
        gci = global_conditioning_index(chain, args.samples, axes=axes, length=length,
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
