"""What every command shares: the parser class, exit statuses, robot and joint options, warnings.

Only the command line prints or exits (docs/architecture.md, "app"); these
helpers parse options into library arguments and format the answers'
common parts. Heavy modules are imported inside the functions that need
them, so ``tf-between`` starts fast.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from manipkit.bounds import MAX_ANGLE  # the largest angle (rad) a command takes: one rule, manipkit.bounds
from manipkit.errors import ChainError, JointLimitError, ManipkitError
from manipkit.text import number_text, printable, short_text

if TYPE_CHECKING:
    import numpy as np

    from manipkit.kinematics.chain import Chain
    from manipkit.kinematics.robot import Robot

__all__ = [
    "is_number",
    "EXIT_INTERNAL",
    "EXIT_MISMATCH",
    "EXIT_OK",
    "EXIT_USAGE",
    "MAX_ANGLE",
    "Parser",
    "UsageError",
    "add_joint_options",
    "alias_lines",
    "alias_rules",
    "add_robot_options",
    "check_angles",
    "check_precision",
    "check_tolerance",
    "command_chain",
    "command_line",
    "exact_q_words",
    "joint_vector",
    "limit_checked",
    "limit_hint",
    "lock_values",
    "load_robot",
    "print_json",
    "q_text",
    "robot_words",
    "warn",
    "xacro_arg_pairs",
]

EXIT_OK, EXIT_MISMATCH, EXIT_USAGE = 0, 1, 2
EXIT_INTERNAL = 1  # a bug (an exception that is not a ManipkitError)



class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (usage goes to --help, not to every mistake)."""

    def error(self, message: str):
        self.exit(EXIT_USAGE, f"{self.prog}: error: {printable(message)} (see {self.prog} --help)\n")

    def parse_known_args(self, args=None, namespace=None):
        """As argparse's, except that arguments left over are an error of this parser: of the command that
        was given them (``manipkit view --view-html``: see ``manipkit view --help``, not ``manipkit --help``)."""
        namespace, extras = super().parse_known_args(args, namespace)
        if extras:
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return namespace, extras


class UsageError(ManipkitError):
    """A malformed command-line value."""


def warn(message: str) -> None:
    """The warnings channel: one ``warning: ...`` line on stderr (stdout stays the answer)."""
    if sys.stderr is not None:  # None: started with stderr closed; print(file=None) would write to stdout
        print(f"warning: {printable(' '.join(str(message).split()))}", file=sys.stderr)


def print_json(value) -> None:
    """``value`` as indented JSON on stdout: always valid JSON (no ``NaN`` or ``Infinity``, which JSON has not).

    A value that is not finite is a bug in the command that built ``value``
    (every answer is finite, or ``null`` where the contract says so): it
    ends as an internal error, never as invalid JSON.
    """
    import json

    print(json.dumps(value, indent=2, allow_nan=False))


# ----------------------------------------------------------------------
# Robot options
# ----------------------------------------------------------------------


def add_robot_options(parser: argparse.ArgumentParser) -> None:
    """``--robot``, ``--arg``, ``--package-dir`` and ``--allow-read`` (read by :func:`load_robot`)."""
    parser.add_argument(
        "--robot", default=None, metavar="R",
        help="bundled name (course_arm, iiwa14, ...), example-robot-data name (panda, ur5, ...) "
        "or a .urdf/.xacro/MJCF .xml path (default: course_arm)",
    )
    parser.add_argument(
        "--arg", action="append", default=[], metavar="KEY:=VALUE",
        help="xacro argument, KEY:=VALUE as in ROS or KEY=VALUE (repeatable)",
    )
    parser.add_argument(
        "--package-dir", action="append", default=[], metavar="NAME=DIR",
        help="folder of a ROS package, for $(find NAME) and package://NAME (repeatable)",
    )
    parser.add_argument(
        "--allow-read", action="append", default=[], metavar="DIR",
        help="let the description read files in DIR (xacro includes, YAML files, meshes); by default it reads "
        "only its own folder tree, its packages and --package-dir folders (repeatable)",
    )


def load_robot(args, *, mesh_warnings: bool = True) -> Robot:
    """The robot of --robot/--arg/--package-dir; its load warnings go to the warnings channel.

    ``mesh_warnings=False`` leaves out unresolved ``package://`` meshes (the viewer says so in one warning).
    """
    import manipkit

    package_dirs = {}
    for name, folder in _pairs(args.package_dir, "--package-dir").items():
        if not folder:
            raise UsageError(f"--package-dir {name}=: give the folder of package {name}")
        package_dirs[name] = Path(folder)
    for folder in args.allow_read:
        if not folder or not Path(folder).is_dir():
            raise UsageError(f"--allow-read {printable(folder)}: no such folder")
    robot = manipkit.load(args.robot, package_dirs=package_dirs, allow_read=list(args.allow_read),
                          **xacro_arg_pairs(args.arg))
    for message in robot.warnings:
        if mesh_warnings or message not in robot.mesh_warnings:
            warn(message)
    return robot


def robot_words(args, robot: Robot) -> list[str]:
    """The options that load ``robot`` again as the user loaded it: ``--robot``, every ``--arg`` and ``--package-dir``.

    For the commands manipkit prints for the user to run (``ik``'s check line,
    the "derived by" line of a DH file): without the xacro arguments and
    package folders they would load another robot (issue 25: TIAGo with
    ``--arg ft_sensor:=no-ft-sensor`` answered 2.3 cm away).
    """
    words = ["--robot", str(args.robot) if args.robot is not None else robot.source.name]
    for item in args.arg:
        words += ["--arg", item]
    for item in args.package_dir:
        words += ["--package-dir", item]
    for item in getattr(args, "allow_read", None) or []:
        words += ["--allow-read", str(item)]
    return words


def command_chain(robot: Robot, base: str, tip: str) -> Chain:
    """``robot.chain(base, tip)`` for a command about a chain (``--base``, ``--tip``), refused when no joint joins them.

    The one place the command line turns its two frames into a chain. Equal
    frames, or frames with only fixed joints between them, make a chain with
    no joints: the library answers for it (an identity pose, a (6, 0)
    Jacobian), but a command about a chain (ik, jacobian, dexterity, family,
    path, reachmap, base-placement, torques, payload, force-capacity) would
    print an empty answer ("rank 0 of 0", "condition number inf"), so it is
    refused in one line naming the two frames. ``tf-between`` is no chain
    command: the transform between two fixed frames is an answer.

    Raises
    ------
    UnknownFrameError
        A frame the robot does not have.
    ChainError
        No joint between ``base`` and ``tip``.
    """
    chain = robot.chain(base, tip)
    if chain.n == 0:
        def named(frame: str, link: str) -> str:
            return printable(frame) if frame == link else f"{printable(frame)} ({printable(link)})"

        if chain.base == chain.tip:
            frames = f"base {named(base, chain.base)} and tip {named(tip, chain.tip)} are the same frame"
            fixed = ""
        else:
            frames = f"base {named(base, chain.base)} and tip {named(tip, chain.tip)} are fixed to each other"
            fixed = f" (`tf-between {printable(chain.base)} {printable(chain.tip)}` gives their fixed transform)"
        raise ChainError(f"robot '{printable(robot.name)}': {frames}, joined by no joint, so there is no chain to "
                         f"move; give a base and a tip with a joint between them{fixed}")
    return chain


def alias_lines(robot: Robot, *frames: str) -> list[str]:
    """``frame ee_link = tool0, named like an arm tool frame (...)`` for each alias among ``frames``.

    Every output that answers for ``ee_link`` or ``base_link`` names the link
    it stands for and the rule that chose it (issue 25: ``ik`` printed "frame
    ee_link" while that was a finger).
    """
    return [f"frame {alias} = {rule['rule']}" for alias, rule in alias_rules(robot, *frames).items()]


def alias_rules(robot: Robot, *frames: str) -> dict[str, dict[str, str]]:
    """``{alias: {"link": resolved link, "rule": the rule that chose it, in words}}`` for each alias among ``frames``
    (JSON outputs: ``tf-between --format json``)."""
    rules = {}
    for alias in dict.fromkeys(frames):  # once when both are the same alias
        resolved = robot.frame(alias)
        if resolved != alias:
            reason = robot.ee_reason if alias == "ee_link" else f"{resolved}, the root link"
            rules[alias] = {"link": resolved, "rule": reason}
    return rules


def lock_values(items: list[str], robot: Robot, *, degrees: bool = False) -> dict[str, float]:
    """``--lock JOINT=VALUE`` items as {joint: value} (rad; degrees converted with ``degrees``), each value finite."""
    pairs = {}
    for name, text in _pairs(items, "--lock", expected="JOINT=VALUE").items():
        if not is_number(text) or not math.isfinite(float(text)):
            raise UsageError(f"--lock {name}={text}: give JOINT=VALUE with a finite number, e.g. "
                             f"--lock {robot.joint_names[-1] if robot.joint_names else 'joint'}=0.3")
        check_angles(f"--lock {printable(name)[:60]}", [float(text)], degrees=degrees)
        pairs[name] = math.radians(float(text)) if degrees else float(text)
    return pairs


def command_line(*words) -> str:
    """``words`` as one shell command line a user can paste (each word quoted where the shell needs it)."""
    import shlex

    return shlex.join(str(word) for word in words)


def exact_q_words(values: dict[str, float]) -> list[str]:
    """``--q name=value ...`` with every value written exactly (the shortest text that reads back as the same float)."""
    return ["--q", *(f"{name}={float(value)!r}" for name, value in values.items())]


def xacro_arg_pairs(items: list[str]) -> dict[str, str]:
    """``--arg`` values -> xacro arguments; ``name:=value`` (as in ROS) and ``name=value`` both work.

    The first ``:=`` or ``=`` ends the name, so a value may hold either
    (``--arg xyz:=a=b`` gives ``xyz`` the value ``a=b``).

    Examples
    --------
    >>> xacro_arg_pairs(["hand:=true", "ur_type=ur5e", "prefix:="])
    {'hand': 'true', 'ur_type': 'ur5e', 'prefix': ''}
    """
    plain = []
    for item in items:
        key, sep, value = item.partition("=")
        plain.append(f"{key[:-1]}={value}" if sep and key.endswith(":") else item)
    return _pairs(plain, "--arg", expected="NAME:=VALUE or NAME=VALUE", shown=dict(zip(plain, items)))


def _pairs(items: list[str], option: str, *, expected: str = "NAME=VALUE", shown=None) -> dict[str, str]:
    pairs = {}
    for item in items:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise UsageError(f"{option} '{(shown or {}).get(item, item)}': expected {expected}")
        if key in pairs:
            raise UsageError(f"{option}: {key} given twice ({key}={pairs[key]} and {key}={value}); give it once")
        pairs[key] = value
    return pairs


# ----------------------------------------------------------------------
# Joint options
# ----------------------------------------------------------------------


def add_joint_options(parser: argparse.ArgumentParser) -> None:
    """``--q``, ``--deg`` and ``--clamp`` (read by :func:`joint_vector`)."""
    parser.add_argument(
        "--q", action="extend", nargs="+", default=[], metavar="NAME=VALUE",
        help="joint values by name (repeatable), or all joint values in order; joints not given are 0",
    )
    parser.add_argument("--deg", action="store_true", help="angles are given in degrees (prismatic joints stay in metres)")
    parser.add_argument(
        "--clamp", action="store_true",
        help="move joint values outside their limits to the nearest limit (with a warning) instead of an error",
    )


def joint_vector(robot: Robot, args, *, option: str = "--q", items=None) -> np.ndarray:
    """Joint vector from --q NAME=VALUE ... or --q V1 V2 ... (all joints in order), limits checked."""
    items = args.q if items is None else items
    if items and all(is_number(item) for item in items):
        if len(items) != len(robot.joint_names):
            raise UsageError(
                f"{option} got {len(items)} value{'s' if len(items) != 1 else ''} but {robot.name} has "
                f"{len(robot.joint_names)} joints ({', '.join(robot.joint_names) or 'none'}); "
                "give all of them in order, or NAME=VALUE pairs"
            )
        values = dict(zip(robot.joint_names, items))
    else:
        values = _pairs(items, option)
        multi = {j.joint for j in robot.joints if j.coordinate is not None}  # floating, planar: x,y,z,roll,pitch,yaw
        values = {name: value.split(",") if name in multi else value for name, value in values.items()}
    prefix = "" if option == "--q" else f"{option}: "
    try:
        q = robot.q(values, degrees=args.deg)
    except ManipkitError as exc:
        if not prefix:
            raise
        raise UsageError(f"{prefix}{exc}") from None
    _check_unlimited_angles(robot, q, degrees=args.deg, prefix=prefix)
    return limit_checked(robot, q, degrees=args.deg, clamp=args.clamp, given=set(values), prefix=prefix)


def _check_unlimited_angles(robot: Robot, q, *, degrees: bool, prefix: str) -> None:
    """A usage error for an angle above :data:`MAX_ANGLE` on a joint without limits (continuous).

    Limited joints need no check: their limits refuse (or ``--clamp`` clamps) such a value.
    """
    for joint, value in zip(robot.joints, q):
        unlimited = not (math.isfinite(joint.lower) and math.isfinite(joint.upper))
        if unlimited and joint.is_angular and abs(value) > MAX_ANGLE:
            shown = f"{short_text(math.degrees(value))} deg" if degrees else f"{short_text(value)} rad"
            raise UsageError(f"{prefix}joint '{joint.name}' = {shown} is too large to name a rotation; "
                             f"give angles within {_angle_limit_text(degrees)}")


def check_angles(option: str, values, *, degrees: bool) -> None:
    """A usage error unless every angle of ``option`` (rad, or deg with ``degrees``) is within :data:`MAX_ANGLE`."""
    limit, unit = (math.degrees(MAX_ANGLE), "deg") if degrees else (MAX_ANGLE, "rad")
    for value in values:
        if abs(value) > limit:
            raise UsageError(f"{option} {' '.join(short_text(v) for v in values)}: {short_text(value)} {unit} is too "
                             f"large to name a rotation; give angles within {_angle_limit_text(degrees)}")


def _angle_limit_text(degrees: bool) -> str:
    if degrees:
        return f"+-{short_text(math.degrees(MAX_ANGLE))} deg ({short_text(MAX_ANGLE)} rad)"
    return f"+-{short_text(MAX_ANGLE)} rad"


def limit_checked(robot: Robot, q, *, degrees: bool, clamp: bool, given=None, prefix: str = "") -> np.ndarray:
    """``q`` if inside the joint limits; clamped with a warning under --clamp; else a one-line error.

    The error names the joint, its value and the limits; a value above a
    full turn on an angular joint without --deg gets a degrees hint.
    Values of continuous joints above a full turn get the hint as a warning.
    """
    from manipkit.kinematics.q_file import joint_limits_error

    violations = robot.limit_violations(q)
    for joint, value in zip(robot.joints, q):
        unlimited = not (math.isfinite(joint.lower) and math.isfinite(joint.upper))
        if unlimited and joint.is_angular and not degrees and abs(value) > 2 * math.pi and (given is None or joint.name in given):
            warn(f"{prefix}joint '{joint.name}' = {short_text(value)} rad is more than a full turn; "
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
    error = joint_limits_error(violations, degrees=degrees)
    raise UsageError(f"{prefix}{error}; use --clamp to clamp{limit_hint(error, degrees)}")


def limit_hint(error: JointLimitError, degrees: bool) -> str:
    """A guess at the unit mistake behind a value outside its limits (``""`` when there is none)."""
    if not degrees and error.unit == "rad" and abs(error.value) > 2 * math.pi:
        return " (did you mean degrees? add --deg)"
    if error.unit == "m" and error.lower <= error.value / 1000 <= error.upper:
        return f" (values are in metres: did you mean {short_text(error.value / 1000)}?)"
    return ""


def _joint_value_text(value: float, unit: str, degrees: bool) -> str:
    return f"{short_text(math.degrees(value))} deg" if degrees and unit == "rad" else f"{short_text(value)} {unit}"


def is_number(text: str) -> bool:
    """Whether ``text`` reads as a float (``1``, ``-0.5``, ``1e-3``, ``nan``)."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def q_text(values: dict[str, float], precision: int) -> str:
    """``name=value ...`` with ``precision`` decimals (the form ``--q`` takes back)."""
    return " ".join(f"{name}={number_text(value, precision)}" for name, value in values.items())


# ----------------------------------------------------------------------
# Number options
# ----------------------------------------------------------------------


def check_precision(precision: int) -> None:
    """A usage error unless ``--precision`` is 0 to 17 decimals."""
    if precision < 0 or precision > 17:
        raise UsageError(f"--precision {precision}: give a number of decimals from 0 to 17")


def check_tolerance(tol: float, option: str = "--tol") -> None:
    """A usage error unless the tolerance is positive and finite."""
    if not (math.isfinite(tol) and tol > 0):
        raise UsageError(f"{option} {short_text(tol)}: give a positive finite tolerance (m and rad)")
