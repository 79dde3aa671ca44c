"""``manipkit ik``: joint values that put a frame at a target pose, numerical or closed form.

The target T_base_frame is built from ``--xyz`` (m) and ``--rpy`` (URDF
convention, R = Rz(yaw) Ry(pitch) Rx(roll)) or ``--quat`` (x, y, z, w) by
:mod:`manipkit.spatial.transforms`; the solvers are
:func:`manipkit.ik.numerical.ik` and :func:`manipkit.ik.textbook.analytic_ik`
(docs/architecture.md). Exit status 1 when no solution reaches the target.

``--tol`` sets the residual tolerance (one number for m and rad, or two:
position m, rotation rad). The target's numbers remember how many decimals
they were written with: when a numerical search fails with a best residual no
larger than what rounding to those decimals can cause (a pose pasted from
``tf-between``'s 6-decimal output), the message says so and suggests a
``--tol`` that accepts the answer.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from manipkit.app.cli.common import (
    EXIT_MISMATCH,
    EXIT_OK,
    UsageError,
    add_robot_options,
    alias_lines,
    check_angles,
    check_precision,
    command_chain,
    command_line,
    exact_q_words,
    joint_vector,
    load_robot,
    lock_values,
    print_json,
    q_text,
    robot_words,
)
from manipkit.errors import ManipkitError
from manipkit.text import number_text, short_text

if TYPE_CHECKING:
    import numpy as np

    from manipkit.ik.result import IKResult
    from manipkit.kinematics.robot import Robot

__all__ = ["register", "run_ik"]


def register(commands) -> None:
    """Add ``manipkit ik`` to the subparsers ``commands``."""
    ik = commands.add_parser("ik", help="joint values that put a frame at a target pose (numerical or closed form)")
    add_robot_options(ik)
    ik.add_argument("--tip", "--frame", dest="tip", default="ee_link", help="frame to place, the chain's tip (default ee_link)")
    ik.add_argument("--base", default="base_link", help="frame the target is given in (default base_link)")
    ik.add_argument("--xyz", type=_number, nargs=3, required=True, metavar=("X", "Y", "Z"), help="target position (m)")
    orientation = ik.add_mutually_exclusive_group()
    orientation.add_argument("--rpy", type=_number, nargs=3, metavar=("R", "P", "Y"), help="target orientation, URDF rpy (rad, or deg with --deg)")
    orientation.add_argument("--quat", type=_number, nargs=4, metavar=("X", "Y", "Z", "W"), help="target orientation as a quaternion (x, y, z, w)")
    ik.add_argument("--position-only", action="store_true", help="ignore the orientation (default when none is given)")
    ik.add_argument("--axis", choices=("x", "y", "z"), default=None, help="match only this axis of the frame to the target's (position + pointing)")
    ik.add_argument("--method", choices=("auto", "closed_form", "numerical", "algebraic"), default="auto",
                    help="auto (default): the closed form wherever the chain has one, else for a pose of a 6R arm "
                         "every isolated solution by algebraic elimination, else numerical IK")
    ik.add_argument("--analytic", action="store_true", help="the same as --method closed_form: the bundled textbook arms' named "
                         "solvers, or any 6R chain with a spherical wrist or three parallel axes (found from its geometry)")
    ik.add_argument("--all", action="store_true", help="every solution: every closed-form branch and its in-limit 2 pi "
                         "aliases, or every distinct solution numerical IK finds within the restart budget")
    ik.add_argument("--no-aliases", action="store_true",
                    help="with --all: the closed-form branches only, each joint at its in-limit value nearest 0 "
                         "(default: also every other value q + 2 pi k inside the limits of a joint wider than 2 pi)")
    ik.add_argument("--lock", action="extend", nargs="+", default=[], metavar="JOINT=VALUE",
                    help="closed form: hold these joints at a value (rad, or deg with --deg) and solve the others "
                         "(a 7R arm as a 6R one; a general 7R with one joint locked: every solution by elimination)")
    ik.add_argument("--arm-angle", type=float, default=None, metavar="PSI",
                    help="closed form of a 7R SRS arm (iiwa14): the arm angle (rad, or deg with --deg)")
    ik.add_argument("--count", default=None, metavar="N",
                    help="a 7R arm with --all (no --lock/--arm-angle): how many solutions to spread across its "
                         "self-motion (default 16)")
    ik.add_argument("--rank", default=None, metavar="CRITERION",
                    help="a 7R arm with --all: order the solutions by limits (default), manipulability or "
                         "clearance (with --collisions or --collision-free)")
    ik.add_argument("--seed-q", action="extend", nargs="+", default=[], metavar="NAME=VALUE", help="starting joint values")
    ik.add_argument("--deg", action="store_true", help="--rpy and --seed-q angles in degrees; solutions stay in radians")
    ik.add_argument("--clamp", action="store_true", help="clamp --seed-q values outside the joint limits (else an error)")
    ik.add_argument("--tol", type=float, nargs="+", default=None, metavar="TOL",
                    help="residual tolerance: one number (m and rad) or two (position m, rotation rad); default 1e-9")
    ik.add_argument("--free", action="extend", nargs="+", default=[], metavar="JOINT",
                    help="floating or planar joints to solve for too (by default they stay at --seed-q or the identity)")
    ik.add_argument("--restarts", type=int, default=50, metavar="N", help="random restarts (default 50)")
    ik.add_argument("--seed", type=int, default=0, help="random seed for the restarts (default 0)")
    ik.add_argument("--precision", type=int, default=6, metavar="N")
    ik.add_argument("--format", choices=("text", "json"), default="text")
    ik.add_argument("--collision-free", action="store_true",
                    help="accept only answers not in collision (numerical: restart until one is found; "
                         "--analytic: drop the solutions in collision)")
    ik.add_argument("--collisions", action="store_true",
                    help="mark each solution in collision or not, with its clearance (m)")
    from manipkit.app.cli.collisions import add_collision_options

    add_collision_options(ik)
    ik.set_defaults(run=run_ik)


class _Number(float):
    """A number from the command line that remembers how many decimals it was written with (``decimals``:
    the digits after the point, None without a point or with an exponent)."""

    decimals: int | None

    @classmethod
    def parse(cls, text: str) -> _Number:
        number = cls(float(text))  # ValueError: argparse reports "invalid float value"
        digits = text.strip()
        point = "." in digits and "e" not in digits.lower() and math.isfinite(number)
        number.decimals = len(digits.partition(".")[2]) if point else None
        return number


def _number(text: str) -> _Number:
    return _Number.parse(text)


_number.__name__ = "float"  # argparse names the type in its message: "invalid float value: 'x'", as before

PRINTED_DECIMALS = 3  # values all written with this many decimals or more, the same for each, look like a printout


def _rounding(values, scale: float = 1.0) -> tuple[float, int | None]:
    """(largest change as a vector norm, decimals) that rounding to the written decimals can cause (``scale``
    converts the unit), when the values look printed: each with a point, all with the same number of
    decimals, at least ``PRINTED_DECIMALS``; else (0, None): numbers typed by hand are taken as exact."""
    decimals = {getattr(v, "decimals", None) for v in values}
    if len(decimals) != 1 or None in decimals or min(decimals) < PRINTED_DECIMALS:
        return 0.0, None
    places = decimals.pop()
    return scale * math.sqrt(len(values)) * 0.5 * 10.0 ** -places, places


def _precision_note(args, mode: str, position: float, rotation: float) -> str | None:
    """The note for a failed numerical search whose best residual rounding of the target's printed digits explains."""
    position_bound, places = _rounding(args.xyz)
    if places is None:
        return None
    rotation_bound = 0.0
    if mode != "position" and args.rpy is not None:
        change, rpy_places = _rounding(args.rpy, math.pi / 180.0 if args.deg else 1.0)
        rotation_bound = math.sqrt(3.0) * change  # |dR| <= |d roll| + |d pitch| + |d yaw| <= sqrt(3) |d rpy|
    elif mode != "position" and args.quat is not None:
        change, rpy_places = _rounding(args.quat)
        rotation_bound = 2.0 * change / math.sqrt(sum(v * v for v in args.quat))  # angle <= 2 |dq| for a unit q
    else:
        rpy_places = places
    if rpy_places is None:
        return None
    # The target is within (position_bound, rotation_bound) of the pose it was printed from; the least-squares
    # best answer is no farther than that pose's configuration, so a residual inside the bound is rounding.
    if math.hypot(position, rotation) > math.hypot(position_bound, rotation_bound):
        return None
    suggest = 10.0 ** math.ceil(math.log10(max(position, rotation, 1e-15) * 1.01))
    rotation_text = f" and {short_text(rotation_bound, 2)} rad" if rotation_bound else ""
    return (f"the best residual ({short_text(position, 3)} m, {short_text(rotation, 3)} rad) is within what the target's "
            f"printed precision can express ({min(places, rpy_places)} decimals: up to {short_text(position_bound, 2)} m"
            f"{rotation_text}); it is likely a rounded copy of a reachable pose: accept it with --tol {short_text(suggest)}")


def _tolerance(args) -> tuple[float, float] | None:
    """--tol as (position m, rotation rad), read by the one tolerance parser (:func:`manipkit.ik.result.tolerances`),
    or None for the solvers' default."""
    from manipkit.bounds import tolerances

    if args.tol is None:
        return None
    try:
        return tolerances(tuple(args.tol))
    except ManipkitError:
        raise UsageError(f"--tol {' '.join(short_text(t) for t in args.tol)}: give one or two positive numbers "
                         "(position m, rotation rad)") from None


def _ik_target(args) -> np.ndarray:
    """T_base_frame from --xyz and --rpy/--quat (degrees for --rpy with --deg); no orientation: the identity rotation."""
    import numpy as np

    from manipkit.spatial.transforms import transform_from_xyz_quaternion, transform_from_xyz_rpy

    for option, values, unit in (("--xyz", args.xyz, "m"), ("--rpy", args.rpy, "deg" if args.deg else "rad"),
                                 ("--quat", args.quat, "")):
        if values is not None and not all(math.isfinite(v) for v in values):
            bad = next(v for v in values if not math.isfinite(v))
            raise UsageError(f"{option} {' '.join(short_text(v) for v in values)}: {short_text(bad)} is not finite; "
                             f"give finite numbers{' (' + unit + ')' if unit else ''}")
    if args.rpy is not None:
        check_angles("--rpy", args.rpy, degrees=args.deg)
        return transform_from_xyz_rpy(args.xyz, np.radians(args.rpy) if args.deg else args.rpy)
    # no orientation given: the identity rotation, (0, 0, 0, 1) (exact zeros, none of them -0.0 in the JSON)
    quaternion = (0.0, 0.0, 0.0, 1.0) if args.quat is None else args.quat
    return transform_from_xyz_quaternion(args.xyz, quaternion)  # InvalidRotationError for a zero quaternion


def _solve(args, robot: Robot, target: np.ndarray, mode: str) -> IKResult:
    """The one IK dispatcher (:func:`manipkit.ik.dispatch.ik`) on the command's options: the same answer as
    ``manipkit.ik(robot, T, ...)`` with the same arguments."""
    from manipkit.ik.dispatch import ik

    checker = None
    if args.collision_free or args.collisions:
        from manipkit.app.cli.collisions import collision_checker

        checker = collision_checker(robot, args)
    tol = _tolerance(args)
    arm_angle = args.arm_angle
    if arm_angle is not None:
        if not math.isfinite(arm_angle):
            raise UsageError(f"--arm-angle {arm_angle}: give a finite angle")
        check_angles("--arm-angle", [arm_angle], degrees=args.deg)
        arm_angle = math.radians(arm_angle) if args.deg else arm_angle
    q0 = joint_vector(robot, args, option="--seed-q", items=args.seed_q) if args.seed_q else None
    return ik(robot, target, base=args.base, tip=args.tip, method="closed_form" if args.analytic else args.method,
              all=args.all, mode=mode, axis=args.axis or "z", q0=q0, lock=lock_values(args.lock, robot, degrees=args.deg) or None,
              arm_angle=arm_angle, restarts=args.restarts, seed=args.seed, free=tuple(args.free),
              collisions=checker if args.collisions and not args.collision_free else None,
              collision_free=checker if args.collision_free else False, count=_count(args.count), rank=args.rank,
              aliases=not args.no_aliases, **({} if tol is None else {"tol": tol}))


def _count(text: str | None):
    """--count as a number for the library's bounds check (:func:`manipkit.ik.redundant.check_options`), or None."""
    if text is None:
        return None
    try:
        return float(text) if any(c in text for c in ".eE") else int(text)
    except ValueError:
        raise UsageError(f"--count {text}: give a whole number of solutions") from None


def _header(args, result: IKResult) -> str:
    """The first line: which solver answered (the result's ``method`` and ``arm_family``), how many solutions."""
    frames = f"frame {args.tip} in {args.base}"
    if result.parameter:
        solver = "algebraic elimination" if result.method == "algebraic" else "closed form"
        return (f"{solver} ({result.arm_family}, {frames}): {len(result.solutions)} solution(s) across the "
                f"self-motion of {result.parameter}, ranked by {result.ranked_by} (best first)\nmode: {result.mode}")
    if result.method in ("closed_form", "algebraic"):
        closed = result.method == "closed_form"
        found, noun = len(result.solutions), "branch" if closed else "solution"
        count = (f"infinitely many solutions (free: {result.free_parameter}), {found} listed" if result.infinite
                 else f"{found} solution(s)" + ("" if closed or not args.all else " (every isolated solution)"))
        aliases = 0 if result.alias_of is None else int((result.alias_of >= 0).sum())
        if aliases:
            kind = "branches" if closed else "solutions"
            count += f": {found - aliases} {kind} and {aliases} 2 pi alias(es) of them (--no-aliases: the {kind} only)"
        if not args.all and found == 1:
            inside = result.within_limits is None or all(result.within_limits)
            chosen = f"the {noun} nearest --seed-q" if args.seed_q else f"the first {noun}"
            where = "inside the joint limits" if inside else f"outside the joint limits: no {noun} is inside them"
            count += f" ({chosen} {where}; --all lists every {noun})"
        solver = "closed form" if closed else "algebraic elimination"
        return f"{solver} ({result.arm_family}, {frames}): {count}\nmode: {result.mode}"
    outcome = "success" if result.success else "FAILED"
    return (f"numerical IK ({result.mode}, {frames}): {outcome}; {len(result.solutions)} solution(s), "
            f"{result.iterations} iterations from {result.attempts} start(s)")


def _failure_json(result: IKResult) -> dict | None:
    failure = result.failure
    if failure is None:
        return None
    return {"kind": failure.kind, "message": failure.message, "joints": list(failure.joints),
            "pairs": [list(pair) for pair in failure.pairs], "values": dict(failure.values)}


def _collision_text(result: IKResult, row: int) -> str:
    """`` (collision-free, clearance 0.012 m)`` or `` (IN COLLISION, penetration 0.01 m)`` when collisions were asked."""
    if result.clearance is None:
        return ""
    clearance = float(result.clearance[row])
    if result.collides[row]:
        return f" (IN COLLISION, penetration {short_text(-clearance, 3)} m)" if clearance < 0 else " (IN COLLISION)"
    return f" (collision-free, clearance {short_text(clearance, 3)} m)"


def run_ik(args) -> int:
    """Solve, then print the solutions (text or JSON) with the residual and a tf-between line to check one.

    Every solver answers with one type (:class:`manipkit.ik.result.IKResult`),
    printed alike: the solutions with their labels, the residual line (the
    worst over the listed solutions, or, when there is none, that of the
    closest configuration a numerical search found, which is printed too),
    and the solver's note.
    """
    from manipkit.ik.numerical import MAX_RESTARTS

    check_precision(args.precision)
    if not 0 <= args.restarts <= MAX_RESTARTS:
        raise UsageError(f"--restarts {args.restarts}: give a whole number from 0 to {MAX_RESTARTS}")
    robot = load_robot(args)
    chain = command_chain(robot, args.base, args.tip)
    target = _ik_target(args)
    oriented = args.rpy is not None or args.quat is not None
    mode = "position" if args.position_only or not oriented else ("position+axis" if args.axis else "pose")
    result = _solve(args, robot, target, mode)
    residuals = result.residuals.max(axis=0) if result.success else result.closest_residuals  # None: nothing to measure
    notes = [result.note] if result.note else []
    if result.closest is not None:
        note = _precision_note(args, mode, *map(float, result.closest_residuals))
        if note:
            notes.append(note)
        joints = chain.n
        if mode == "pose" and joints < 6:
            notes.append(f"the chain {args.base} -> {args.tip} has {joints} joint{'s' * (joints != 1)}, fewer than "
                         "the 6 a full pose needs, so most poses are out of its reach: ask for the position only "
                         "(--position-only) or the position and the tool's axis (--axis z)")
    if args.format == "json":
        print_json(_json_answer(robot, chain, target, mode, result, residuals, notes))
    else:
        _print_answer(args, robot, result, residuals, notes)
    return EXIT_OK if result.success else EXIT_MISMATCH


def _json_answer(robot: Robot, chain, target, mode: str, result: IKResult, residuals, notes: list[str]) -> dict:
    """The answer as JSON; ``solutions`` hold the chain's own joints (base to tip), as the text rows."""
    return {
        "robot": robot.name,
        "method": result.method,
        "arm_family": result.arm_family or None,
        "mode": mode,
        "target": target.tolist(),
        "solutions": [chain.as_dict(q[chain.columns]) for q in result.solutions],
        "labels": list(result.labels),
        "closed_form_mode": result.mode if result.method == "closed_form" else None,
        "within_limits": None if result.within_limits is None else result.within_limits.tolist(),
        "alias_of": None if result.alias_of is None else [None if a < 0 else a for a in result.alias_of.tolist()],
        "refined": None if result.refined is None else result.refined.tolist(),
        "count": "inf" if result.infinite else result.count,
        "free_parameter": result.free_parameter or None,
        "unmet": dict(result.unmet),
        "success": result.success,
        "failure": _failure_json(result),
        "residual_position": None if residuals is None else float(residuals[0]),
        "residual_rotation": None if residuals is None else float(residuals[1]),
        "notes": notes,
        **({"collides": list(result.collides), "clearance": [float(c) for c in result.clearance]}
           if result.clearance is not None else {}),
        **({"parameter": result.parameter, "parameter_values": result.parameter_values.tolist(),
            "intervals": [{"branch": b, "low": low, "high": high} for b, low, high in result.intervals],
            "ranked_by": result.ranked_by, "scores": result.scores.tolist()} if result.parameter else {}),
    }


def _print_answer(args, robot: Robot, result: IKResult, residuals, notes: list[str]) -> None:
    """The text answer; rows and the check line hold the chain's own joints (the others do not move the tip)."""
    chain = robot.chain(args.base, args.tip)

    def own(q) -> dict[str, float]:
        return chain.as_dict(q[chain.columns])

    print(_header(args, result))
    for line in alias_lines(robot, args.base, args.tip):
        print(line)
    for branch, low, high in result.intervals:
        print(f"feasible: [{branch}] {result.parameter.split(' ')[0]} from {number_text(low, args.precision)} "
              f"to {number_text(high, args.precision)} rad")
    within = [True] * len(result.solutions) if result.within_limits is None else result.within_limits.tolist()
    for index, (label, q, inside) in enumerate(zip(result.labels, result.solutions, within), start=1):
        if result.parameter:
            value, score = float(result.parameter_values[index - 1]), float(result.scores[index - 1])
            label = (f"{label}; {result.parameter.split(' ')[0]} = {number_text(value, args.precision)}; "
                     f"{result.ranked_by} {short_text(score, 4)}")
        if result.alias_of is not None and result.alias_of[index - 1] >= 0:
            label = f"{label}; 2 pi alias of {int(result.alias_of[index - 1]) + 1}"
        print(f"{index}. {('[' + label + '] ') if label else ''}{'' if inside else '(outside the joint limits) '}"
              f"{q_text(own(q), args.precision)}" + _collision_text(result, index - 1))
    if result.closest is not None:
        collided = result.failure is not None and result.failure.kind == "collision"
        what = "in collision" if collided else "does not reach the target"
        print(f"best found ({what}): {q_text(own(result.closest), args.precision)}")
    if residuals is not None:
        print(f"residual: position {short_text(residuals[0], 3)} m, rotation {short_text(residuals[1], 3)} rad")
    for note in notes:
        print(f"note: {note}")
    if result.success:
        inside = [q for q, ok in zip(result.solutions, within) if ok]
        if inside:  # tf-between refuses values outside the limits: the check uses one inside them
            check = command_line("tf-between", args.base, args.tip, *robot_words(args, robot),
                                 *exact_q_words(own(inside[0])))
            print(f"check one with: {check}")
        else:
            print("no solution inside the joint limits, so none to check with tf-between (it refuses values "
                  "outside them)")
