"""``manipkit family``: which closed form a chain has, found from its joint axes, with the evidence.

The family and its evidence come from
:func:`manipkit.ik.families.chain_family` (docs/architecture.md,
"closed_form"): which axes meet or are parallel, the measured miss distance
and angle, the tolerance used. ``manipkit ik --analytic`` (or ``--all``)
solves the chains whose family has a closed form.
"""

from __future__ import annotations

from manipkit.app.cli.common import (
    EXIT_OK,
    UsageError,
    add_robot_options,
    command_chain,
    command_line,
    load_robot,
    lock_values,
    print_json,
    robot_words,
)
from manipkit.text import short_text

__all__ = ["register", "run_family"]


def register(commands) -> None:
    """Add ``manipkit family`` to the subparsers ``commands``."""
    parser = commands.add_parser("family", help="the closed-form family of a chain (spherical wrist, UR type, ...), "
                                                "found from its joint axes, with the evidence")
    add_robot_options(parser)
    parser.add_argument("--base", default="base_link", help="base frame of the chain (default base_link)")
    parser.add_argument("--tip", default="ee_link", help="tip frame of the chain (default ee_link)")
    parser.add_argument("--tol", type=float, nargs="+", default=None, metavar="TOL",
                        help="how far axes may miss a point (m) and be from parallel (rad): one number or two "
                             "(default 1e-3)")
    parser.add_argument("--lock", action="extend", nargs="+", default=[], metavar="JOINT=VALUE",
                        help="hold these joints at a value (rad): the family of the others (a 7R arm as a 6R one)")
    parser.add_argument("--format", choices=("text", "json"), default="text")
    parser.set_defaults(run=run_family)


def _general_evidence(chain, family, tol) -> tuple[str, str] | None:
    """("general 6R", the evidence in words) for a 6R revolute chain with no closed-form family, else None."""
    from manipkit.ik.general6r import GENERAL_6R, general_solves, general_ways

    if family.kind != "none" or family.locked or not general_solves(chain, family_tol=tol):
        return None
    ways = general_ways(chain, family_tol=tol)
    if not ways:
        return GENERAL_6R, ("6 revolute joints, no closed-form family (the misses above); no elimination of its loop "
                            "is regular: ik answers numerically")
    shift, reverse = ways[0]
    how = ("the loop split as E4 E5 = (E1 E2 E3)^-1 g E6^-1" if shift == 0 else
           f"the loop turned by {shift} joint(s) before the split") + (", read tip to base" if reverse else "")
    return GENERAL_6R, (f"6 revolute joints, no closed-form family (the misses above); solved by Raghavan-Roth "
                        f"elimination, {how} ({len(ways)} of 12 ways regular on this arm)")


def snap_words(family) -> str:
    """The ``snap:`` line of a family found within its tolerance: which relations the ideal arm makes exact, by how much.

    "none" when every relation holds to ``IDEAL_TOL`` (the arm is its family's ideal arm).
    """
    from manipkit.closed_form.checks import quantity_text

    if not family.snap:
        return "snap: none (every relation of the family holds to 1e-12)"
    parts = [f"axes {', '.join(map(str, r.axes))} " + (f"miss a common point by {quantity_text(r.miss)} m"
                                                        if r.kind == "meet" else
                                                        f"are off parallel by {quantity_text(r.angle)} rad")
             for r in family.snap]
    tol = f"{quantity_text(family.tol[0])} m, {quantity_text(family.tol[1])} rad"
    how = ("; solved in closed form on that ideal arm, each branch checked by FK on this chain and refined by Newton "
           "where it misses") if family.solved else ""
    return f"snap: {'; '.join(parts)} (within the tolerance {tol}; the nearest ideal arm makes them exact){how}"


def run_family(args) -> int:
    """Print the family, its evidence and whether ``ik --analytic`` solves it."""
    from manipkit.bounds import tolerances
    from manipkit.errors import ManipkitError
    from manipkit.ik.families import FAMILY_TOL, chain_family

    try:
        tol = FAMILY_TOL if args.tol is None else tolerances(tuple(args.tol))
    except ManipkitError:
        raise UsageError(f"--tol {' '.join(short_text(t) for t in args.tol)}: give one or two positive numbers "
                         "(distance m, angle rad)") from None
    robot = load_robot(args)
    chain = command_chain(robot, args.base, args.tip)
    lock = lock_values(args.lock, robot)
    family = chain_family(chain, tol=tol, lock=lock)
    opw, opw_note = None, ""
    if family.kind == "spherical wrist, two parallel":
        from manipkit.ik.opw import opw_parameters

        try:
            opw = opw_parameters(chain, family=family)
        except ManipkitError as exc:
            opw_note = str(exc)
    general = _general_evidence(chain, family, tol)
    if args.format == "json":
        print_json({
            "robot": robot.name, "base": chain.base, "tip": chain.tip, "joints": list(chain.joint_names),
            "family": family.kind, "reversed": family.reversed, "solved": family.solved,
            "class": general[0] if general else family.kind, "general_6r": general[1] if general else None,
            "evidence": [{"kind": r.kind, "axes": list(r.axes), "miss": r.miss, "angle": r.angle,
                          "point": list(r.point) or None} for r in family.evidence],
            "tol": list(family.tol), "deviation": family.deviation, "note": family.note,
            "snap": [{"kind": r.kind, "axes": list(r.axes), "miss": r.miss, "angle": r.angle} for r in family.snap],
            "opw": None if opw is None else {
                **{name: getattr(opw, name) for name in ("a1", "a2", "b", "c1", "c2", "c3", "c4")},
                "offsets": list(opw.offsets), "sign_corrections": list(opw.sign_corrections), "fk_error": opw.fk_error},
            "opw_note": opw_note or None,
        })
        return EXIT_OK
    print(f"chain {chain.base} -> {chain.tip}: {', '.join(chain.joint_names) or 'no joints'}")
    print(str(family))
    if family.kind != "none":
        print(snap_words(family))
    if opw is not None or opw_note:
        print(f"  {opw if opw is not None else opw_note}")
    if general:
        command = command_line("manipkit", "ik", "--all", *robot_words(args, robot), "--base", chain.base, "--tip",
                               chain.tip)
        print(f"class: {general[0]}: {general[1]}")
        print(f"algebraic: {command} --xyz X Y Z --rpy R P Y gives every isolated solution")
    if family.solved:
        command = command_line("manipkit", "ik", "--analytic", *robot_words(args, robot), "--base", chain.base,
                               "--tip", chain.tip, *(["--lock", *(f"{name}={value!r}" for name, value in lock.items())] if lock else []))
        print(f"closed form: {command} --xyz X Y Z --rpy R P Y gives every branch")
    return EXIT_OK
