"""``manipkit torques`` (static joint torques with a payload and wrenches) and ``manipkit payload`` (capacity).

The numbers come from :mod:`manipkit.statics` (docs/architecture.md): ``tau =
g(q) - sum J^T w``, the torque each motor must produce to hold the arm still
(Pinocchio's ``computeStaticTorque``), each wrench applied *on* the robot (a
force pushing the tool down is ``0,0,-5,0,0,0``); per joint the effort limit
from the URDF and the margin ``100 (1 - |tau| / limit)`` percent.
"""

from __future__ import annotations

import math

from manipkit import bounds
from manipkit.app.cli.common import (
    EXIT_OK,
    UsageError,
    add_joint_options,
    add_robot_options,
    alias_lines,
    check_precision,
    command_chain,
    command_line,
    is_number,
    joint_vector,
    load_robot,
    print_json,
    q_text,
    robot_words,
)
from manipkit.text import clipped_text, number_text, printable, short_text

__all__ = ["MAX_TRAJECTORY_BYTES", "band_words", "grade_line", "parse_gravity", "parse_payload", "parse_triple", "parse_wrench", "read_trajectory",
           "register", "run_force_capacity", "run_inertia", "run_payload", "run_torques", "torques_json"]

CONVENTION = ("tau = g(q) - sum J^T w: the torque each motor produces to hold still (N m, N for prismatic joints); "
              "wrenches act on the robot")


def register(commands) -> None:
    """Add ``manipkit torques`` and ``manipkit payload`` to the subparsers ``commands``."""
    tor = commands.add_parser("torques", help="static joint torques holding the arm, a payload and wrenches still")
    _common(tor)
    tor.add_argument("--payload", default=None, metavar="MASS[@X,Y,Z]",
                     help="a payload of MASS kg added to the tip link, its centre of gravity at X,Y,Z m from the "
                          "tip's origin in the tip frame's axes (default 0,0,0)")
    tor.add_argument("--wrench", action="append", default=[], metavar="FX,FY,FZ,TX,TY,TZ@FRAME",
                     help="a wrench (N, N m) applied on the robot at FRAME's origin (default: the tip), components "
                          "in the base frame's axes unless --wrench-axes frame (repeatable)")
    tor.add_argument("--wrench-axes", choices=("base", "frame"), default="base",
                     help="axes of the --wrench components: the base frame's (default) or FRAME's own")
    tor.add_argument("--trajectory", default=None, metavar="CSV",
                     help="inverse dynamics (RNEA) along a trajectory instead: a CSV with a header of t (s, "
                          "optional), joint names (q), NAME.qd and NAME.qdd columns (columns not given are 0); "
                          "--q sets the joints the file leaves out")
    _band_option(tor)
    tor.add_argument("--explain", action="store_true",
                     help="also show each body's part of each joint's gravity torque and each wrench's J^T columns")
    tor.add_argument("--precision", type=int, default=6, metavar="N", help="decimals printed (default 6)")
    tor.set_defaults(run=run_torques)

    pay = commands.add_parser("payload", help="the largest payload mass the arm holds still at a pose")
    _common(pay)
    pay.add_argument("--cog", default=None, metavar="X,Y,Z",
                     help="the payload's centre of gravity from the tip's origin, in the tip frame's axes, m "
                          "(default 0,0,0)")
    pay.add_argument("--diagram", default=None, metavar="PNG",
                     help="draw the largest payload against the CoG offset along --direction, worst case over "
                          "--samples configurations, into PNG (the data goes to stdout); --q and --cog are refused with it")
    pay.add_argument("--direction", default=None, metavar="X,Y,Z",
                     help="the diagram's offset direction in the tip frame's axes (default 0,0,1)")
    pay.add_argument("--max-offset", type=float, default=None, metavar="M",
                     help="the diagram's largest offset, m (default 0.3)")
    pay.add_argument("--steps", type=int, default=None, metavar="K", help="offsets drawn, 0 to --max-offset (default 16)")
    pay.add_argument("--samples", type=int, default=None, metavar="N",
                     help="configurations sampled inside the limits for the diagram (default 1000)")
    pay.add_argument("--seed", type=int, default=None, help="with --diagram: seed of the sampler (default 0)")
    _band_option(pay)
    pay.set_defaults(run=run_payload)

    force = commands.add_parser("force-capacity",
                                help="the largest force (or moment) the tool can apply, the arm's weight held first")
    _common(force)
    force.add_argument("--kind", choices=("force", "moment"), default="force",
                       help="force at the tip's origin (N) or moment (N m), never mixed (default force)")
    force.add_argument("--direction", action="append", default=[], metavar="X,Y,Z",
                       help="a direction in the base frame's axes (repeatable; default +-x, +-y, +-z)")
    force.add_argument("--payload", default=None, metavar="MASS[@X,Y,Z]", help="a payload held as well (as torques)")
    force.set_defaults(run=run_force_capacity)

    audit = commands.add_parser("inertia", help="audit the description's masses, inertias and effort limits")
    add_robot_options(audit)
    audit.add_argument("--no-geometry", action="store_true",
                       help="skip the checks against the collision geometry (no meshes are read)")
    audit.add_argument("--format", choices=("text", "json"), default="text")
    audit.set_defaults(run=run_inertia)


def _band_option(parser) -> None:
    parser.add_argument("--band", type=float, default=None, metavar="PERCENT",
                        help="also the interval with every body's mass and CoG off by up to PERCENT %% (the CoG by "
                             "PERCENT %% of its distance from its joint, along each axis)")


def _common(parser) -> None:
    add_robot_options(parser)
    add_joint_options(parser)
    parser.add_argument("--tip", "--frame", dest="tip", default="ee_link", metavar="F", help="the tip of the chain (default ee_link)")
    parser.add_argument("--base", default="base_link", metavar="B", help="the base of the chain (default base_link)")
    parser.add_argument("--gravity", default="0,0,-9.81", metavar="GX,GY,GZ",
                        help="gravity in the root link's axes, m/s^2 (default 0,0,-9.81)")
    parser.add_argument("--format", choices=("text", "json"), default="text")


def parse_triple(text: str, option: str) -> tuple[float, float, float]:
    """``X,Y,Z`` -> three finite floats, or a one-line :class:`UsageError` naming ``option``.

    Examples
    --------
    >>> parse_triple("0,0.1,-2", "--cog")
    (0.0, 0.1, -2.0)
    """
    return tuple(_numbers(text, option, 3, "X,Y,Z"))


def parse_gravity(text: str, *, direction: bool = False) -> tuple[float, float, float]:
    """``--gravity GX,GY,GZ`` (m/s^2) within :func:`manipkit.bounds.gravity` (``direction``: not zero), or one line.

    Examples
    --------
    >>> parse_gravity("0,0,-9.81")
    (0.0, 0.0, -9.81)
    """
    values = parse_triple(text, "--gravity")
    return tuple(float(v) for v in bounds.gravity(values, "--gravity", direction=direction, error=UsageError))


def _numbers(text: str, option: str, count: int, form: str) -> list[float]:
    parts = [part.strip() for part in text.split(",")]
    if len(parts) != count or not all(is_number(part) for part in parts) or not all(
            math.isfinite(float(part)) for part in parts):
        raise UsageError(f"{option} {clipped_text(text)}: give {count} finite numbers as {form}")
    return [float(part) for part in parts]


def parse_payload(text: str):
    """``MASS[@X,Y,Z]`` -> :class:`manipkit.statics.torques.Payload` (mass >= 0 kg, CoG in the tip's axes, m).

    Examples
    --------
    >>> parse_payload("2.5@0,0,0.1").mass
    2.5
    """
    from manipkit.statics.torques import Payload

    mass_text, sep, cog_text = text.partition("@")
    mass_text = mass_text.strip()
    if not is_number(mass_text) or not math.isfinite(float(mass_text)) or float(mass_text) < 0:
        raise UsageError(f"--payload {clipped_text(text)}: give MASS[@X,Y,Z] with a finite mass >= 0 kg "
                         "(e.g. --payload 2.5@0,0,0.1)")
    try:
        cog = parse_triple(cog_text, "--payload") if sep else (0.0, 0.0, 0.0)
    except UsageError:
        raise UsageError(f"--payload {clipped_text(text)}: give the centre of gravity after @ as 3 finite numbers "
                         "X,Y,Z (m, tip frame's axes), e.g. --payload 2.5@0,0,0.1") from None
    return Payload(float(mass_text), cog)


def parse_wrench(text: str, axes: str):
    """``FX,FY,FZ,TX,TY,TZ[@FRAME]`` -> :class:`manipkit.statics.torques.Wrench` (N, N m; FRAME default ee_link)."""
    from manipkit.statics.torques import Wrench

    values, sep, frame = text.partition("@")
    if sep and not frame.strip():
        raise UsageError(f"--wrench {clipped_text(text)}: name the frame after @ (FX,FY,FZ,TX,TY,TZ@FRAME)")
    numbers = _numbers(values, "--wrench", 6, "FX,FY,FZ,TX,TY,TZ[@FRAME] (N, N m)")
    return Wrench(numbers, frame.strip() if sep else "ee_link", axes)


def _chain_and_q(args):
    robot = load_robot(args)
    chain = command_chain(robot, args.base, args.tip)  # unknown or unjoined frames fail before the joint values
    q = joint_vector(robot, args)
    return robot, chain, q


def torques_json(robot, chain, q, answer) -> dict:
    """The answer of ``manipkit torques`` as a JSON-ready dict (NaN limits and margins as null)."""
    def listed(values):
        return [float(v) if math.isfinite(v) else None for v in values]

    return {
        "robot": robot.name, "base": chain.base, "tip": chain.tip, "q": robot.as_dict(q),
        "convention": CONVENTION, "gravity_vector": answer.gravity_vector.tolist(),
        "joint_names": list(answer.joint_names), "tau": answer.tau.tolist(), "gravity": answer.gravity.tolist(),
        "payload": answer.payload.tolist(), "wrench": answer.wrench.tolist(),
        "effort_limit": listed(answer.effort_limit), "margin": listed(answer.margin),
        "saturating": answer.saturating_joint, "over_limit": [n for n, o in zip(answer.joint_names, answer.over_limit)
                                                             if o],
        "inertia_grade": answer.inertia_grade,
    }


def _audit(robot):
    from manipkit.statics.audit import inertia_audit

    return inertia_audit(robot)


def grade_line(robot, args=None, audit=None) -> str:
    """``inertia grade: B (0 errors, 2 warnings ...)``: the audit's grade, said with every torque and payload answer;
    with ``args``, the command that lists the findings."""
    audit = _audit(robot) if audit is None else audit
    if audit.grade == "A":
        return "inertia grade: A (the inertia audit found nothing)"
    errors = sum(f.severity == "error" for f in audit.findings)
    warnings = len(audit.findings) - errors
    listed = "" if args is None else f"; {command_line('manipkit', 'inertia', *robot_words(args, robot))} lists them"
    return (f"inertia grade: {audit.grade} ({errors} error{'s' * (errors != 1)}, {warnings} "
            f"warning{'s' * (warnings != 1)} about the description's inertias and effort limits{listed})")


def run_torques(args) -> int:
    """Print the static torques per joint (text table or the JSON of :func:`torques_json`)."""
    from manipkit.statics.torques import static_torques

    check_precision(args.precision)
    gravity = parse_gravity(args.gravity)
    payload = parse_payload(args.payload) if args.payload is not None else None
    wrenches = [parse_wrench(text, args.wrench_axes) for text in args.wrench]
    robot, chain, q = _chain_and_q(args)
    if args.trajectory is not None:
        if wrenches:
            raise UsageError("--wrench is for static torques; --trajectory takes no wrench")
        return _run_trajectory(args, robot, chain, q, payload, gravity)
    for wrench in wrenches:
        robot.frame(wrench.frame)  # an unknown frame: one line naming the closest ones
    answer = static_torques(chain, q, payload=payload, wrench=wrenches, gravity=gravity, q_rest=q)
    data = torques_json(robot, chain, q, answer)
    band = _band(args, chain, q, gravity, payload)
    if band is not None:
        data["band"] = {"percent": band.percent, "gravity_low": band.low.tolist(), "gravity_high": band.high.tolist(),
                        "tau_low": (band.low + answer.payload + answer.wrench).tolist(),
                        "tau_high": (band.high + answer.payload + answer.wrench).tolist()}
    explained = _explain(chain, q, gravity, wrenches) if args.explain else None
    if explained is not None:
        data["explain"] = explained
    if args.format == "json":
        print_json(data)
        return EXIT_OK
    p = args.precision
    lines = [f"robot: {robot.name} ({robot.source.path})", *alias_lines(robot, args.base, args.tip),
             f"chain {chain.base} -> {chain.tip}; joints (rad/m): {q_text(data['q'], p) or 'none'}",
             f"gravity (m/s^2, root link's axes): {' '.join(number_text(v, p) for v in data['gravity_vector'])}",
             CONVENTION, grade_line(robot, args)]
    header = ("joint", "tau", "gravity", "payload", "wrench", "limit", "margin %")
    rows = [(name, *(number_text(v, p) for v in (data["tau"][k], data["gravity"][k], data["payload"][k],
                                                   data["wrench"][k])),
             "none" if data["effort_limit"][k] is None else number_text(data["effort_limit"][k], p),
             "-" if data["margin"][k] is None else number_text(data["margin"][k], 1))
            for k, name in enumerate(data["joint_names"])]
    widths = [max(len(row[i]) for row in [header, *rows]) for i in range(len(header))]
    lines += ["  ".join(cell.rjust(w) if i else cell.ljust(w) for i, (cell, w) in enumerate(zip(row, widths)))
              for row in [header, *rows]]
    saturating = data["saturating"]
    lines.append("no joint of the chain has an effort limit" if saturating is None else
                 f"least margin: {saturating}" + (f"; over the limit: {', '.join(data['over_limit'])}"
                                                 if data["over_limit"] else ""))
    if band is not None:
        lines.append(f"with masses and CoGs off by up to {number_text(band.percent, 3)} %, tau lies in:")
        lines += [f"  {name}: [{number_text(lo, p)}, {number_text(hi, p)}]"
                  for name, lo, hi in zip(data["joint_names"], data["band"]["tau_low"], data["band"]["tau_high"])]
    if explained is not None:
        lines += _explain_lines(explained, data["joint_names"], p)
    print("\n".join(lines))
    return EXIT_OK


def _band(args, chain, q, gravity, payload):
    if args.band is None:
        return None
    from manipkit.statics.sensitivity import torque_band

    return torque_band(chain, q, percent=args.band, payload=payload, gravity=gravity, q_rest=q)


def _explain(chain, q, gravity, wrenches) -> dict:
    """Each body's part of the gravity torques, and per wrench the Jacobian columns and the -J^T w terms."""
    import numpy as np

    from manipkit.statics.sensitivity import gravity_contributions

    robot = chain.robot
    parts = [{"link": link, "mass": mass, "torque": torque.tolist()}
             for link, mass, torque in gravity_contributions(chain, q, gravity=gravity, q_rest=q)]
    columns = []
    for wrench in wrenches:
        reference = "local" if wrench.axes == "frame" else "base"
        J = robot.jacobian(q, base=chain.base, tip=wrench.frame, reference=reference)[:, chain.columns]
        columns.append({"frame": wrench.frame, "axes": wrench.axes, "wrench": wrench.wrench.tolist(),
                        "jacobian_columns": J.T.tolist(), "force_part": (-(J[:3].T @ wrench.force)).tolist(),
                        "moment_part": (-(J[3:].T @ wrench.moment)).tolist()})
    return {"gravity_by_body": parts, "wrenches": columns, "total_gravity": np.sum(
        [part["torque"] for part in parts], axis=0).tolist() if parts else [0.0] * chain.n}


def _explain_lines(explained: dict, joints, p: int) -> list[str]:
    lines = ["gravity torque by body (N m; positive turns the joint the positive way about its axis; "
             "each body weighs only on the joints above it):"]
    width = max([len(part["link"]) for part in explained["gravity_by_body"]] + [4])
    lines.append(" " * (width + 12) + "  ".join(f"{name:>14}" for name in joints))
    for part in explained["gravity_by_body"]:
        lines.append(f"{part['link']:<{width}} {number_text(part['mass'], 3):>7} kg "
                     + "  ".join(f"{number_text(v, p):>14}" for v in part["torque"]))
    for item in explained["wrenches"]:
        axes = "the base frame's" if item["axes"] == "base" else f"{item['frame']}'s own"
        lines.append(f"wrench {', '.join(number_text(v, p) for v in item['wrench'])} (N, N m) on the robot at "
                     f"{item['frame']}, {axes} axes: tau_k = -(J_v,k . f) - (J_w,k . n)")
        for name, col, fp, mp in zip(joints, item["jacobian_columns"], item["force_part"], item["moment_part"]):
            lines.append(f"  {name}: J_k = ({', '.join(number_text(v, p) for v in col)}) (m/rad, 1); "
                         f"-J_v.f = {number_text(fp, p)} N m, -J_w.n = {number_text(mp, p)} N m")
    return lines


def run_payload(args) -> int:
    """Print the largest payload mass at the pose, and the joint that saturates."""
    from manipkit.statics.capacity import payload_capacity

    gravity = parse_gravity(args.gravity, direction=True)
    given = [option for option, value in (("--direction", args.direction), ("--max-offset", args.max_offset),
                                          ("--steps", args.steps), ("--samples", args.samples), ("--seed", args.seed))
             if value is not None]
    if args.diagram is None and given:
        raise UsageError(f"{given[0]} applies to the payload diagram: give --diagram PNG, or leave {given[0]} out")
    if args.diagram is not None:
        refused = [option for option, value in (("--q", args.q), ("--cog", args.cog), ("--band", args.band))
                   if value not in (None, [])]
        if refused:
            raise UsageError(f"{refused[0]} with --diagram: the diagram samples configurations and offsets along "
                             "--direction itself; leave it out")
        return _run_diagram(args, gravity)
    cog = parse_triple(args.cog or "0,0,0", "--cog")
    robot, chain, q = _chain_and_q(args)
    cap = payload_capacity(chain, q, cog=cog, gravity=gravity, q_rest=q)
    max_mass = float(cap.max_mass)
    data = {"robot": robot.name, "base": chain.base, "tip": chain.tip, "q": robot.as_dict(q), "cog": list(cog),
            "gravity_vector": list(gravity), "max_mass": max_mass if math.isfinite(max_mass) else None,
            "unbounded": not math.isfinite(max_mass), "saturating": cap.saturating_joint,
            "gravity_saturates": bool(cap.gravity_saturates), "convention": CONVENTION,
            "inertia_grade": cap.inertia_grade}
    band = _band(args, chain, q, gravity, _payload_at(cog))
    if band is not None:
        data["band"] = {"percent": band.percent, **{f"max_mass_{end}": value if math.isfinite(value) else None
                                                    for end, value in (("low", band.capacity_low),
                                                                       ("high", band.capacity_high))},
                        "unbounded_high": not math.isfinite(band.capacity_high)}
    if args.format == "json":
        print_json(data)
        return EXIT_OK
    print(f"robot: {robot.name} ({robot.source.path})")
    print(f"chain {chain.base} -> {chain.tip}; joints (rad/m): {q_text(data['q'], 6) or 'none'}")
    print(f"payload centre of gravity (m, tip frame's axes): {' '.join(number_text(v, 6) for v in cog)}")
    print(grade_line(robot, args))
    if data["gravity_saturates"]:
        print(f"max payload: 0 kg: the arm's own weight alone saturates {data['saturating']}")
    elif data["unbounded"]:
        print("max payload: unbounded: no joint with an effort limit feels a payload at this CoG")
    else:
        print(f"max payload: {number_text(max_mass, 6)} kg ({data['saturating']} reaches its effort limit)")
    if band is not None:
        print(f"with masses and CoGs off by up to {number_text(band.percent, 3)} %: {band_words(band)}")
    return EXIT_OK


def band_words(band) -> str:
    """The capacity interval of ``band`` in words, true when an end is unbounded (no joint with an effort limit
    feels the payload, ``inf``): "between 2.1 and 2.6 kg (an outer bound)", "at least 2.1 kg, possibly unbounded".
    """
    low, high = band.capacity_low, band.capacity_high
    if math.isinf(low):
        return "unbounded as well (no joint with an effort limit feels a payload at this CoG)"
    if math.isinf(high):
        return f"at least {number_text(low, 6)} kg, possibly unbounded (an outer bound)"
    return f"between {number_text(low, 6)} and {number_text(high, 6)} kg (an outer bound)"


def _payload_at(cog):
    from manipkit.statics.torques import Payload

    return Payload(1.0, cog)


def run_force_capacity(args) -> int:
    """Print the largest force (moment) along each direction and the ellipsoid, the weight held first."""
    from manipkit.statics.capability import force_capacity

    gravity = parse_gravity(args.gravity)
    payload = parse_payload(args.payload) if args.payload is not None else None
    directions = [parse_triple(text, "--direction") for text in args.direction] or None
    if directions is not None and any(d == (0.0, 0.0, 0.0) for d in directions):
        raise UsageError("--direction 0,0,0: give a direction that is not zero")
    robot, chain, q = _chain_and_q(args)
    cap = force_capacity(chain, q, kind=args.kind, directions=directions, payload=payload, gravity=gravity, q_rest=q)
    unit = "N" if cap.kind == "force" else "N m"

    def finite(v):
        return float(v) if math.isfinite(v) else None

    data = {"robot": robot.name, "base": chain.base, "tip": chain.tip, "q": robot.as_dict(q), "kind": cap.kind,
            "unit": unit, "directions": cap.directions.tolist(), "max_along": [finite(v) for v in cap.along],
            "saturating": list(cap.saturating), "ellipsoid_centre": cap.centre.tolist(),
            "ellipsoid_axes": cap.axes.T.tolist(), "ellipsoid_radii": [finite(v) for v in cap.radii],
            "ellipsoid_empty": cap.empty, "inertia_grade": _audit(robot).grade,
            "convention": "applied by the tool on the environment; motors produce g(q) + J^T f within +-effort"}
    if args.format == "json":
        print_json(data)
        return EXIT_OK
    print(f"robot: {robot.name} ({robot.source.path}); chain {chain.base} -> {chain.tip}")
    print(f"the largest {cap.kind} ({unit}) the tool applies at {chain.tip}'s origin, in the base frame's axes, with "
          "the arm's weight" + (" and the payload" if payload is not None else "") + " held first:")
    print(grade_line(robot, args))
    for d, t, joint in zip(cap.directions, cap.along, cap.saturating):
        amount = "unbounded" if not math.isfinite(t) else f"{number_text(t, 3)} {unit} ({joint} at its limit)"
        print(f"  along ({', '.join(number_text(v, 3) for v in d)}): {amount}")
    if cap.empty:
        print("ellipsoid: empty (the weight alone uses the whole torque budget)")
    else:
        print(f"ellipsoid ||diag(1/effort) (g + J^T f)|| <= 1: centre ({', '.join(number_text(v, 3) for v in cap.centre)})"
              f" {unit}")
        for axis, radius in zip(cap.axes.T, cap.radii):
            size = "unbounded" if not math.isfinite(radius) else f"{number_text(radius, 3)} {unit}"
            print(f"  semi-axis {size} along ({', '.join(number_text(v, 3) for v in axis)})")
    return EXIT_OK


def _run_diagram(args, gravity) -> int:
    import numpy as np

    from manipkit.outputs import writable_path
    from manipkit.statics.diagram import draw_payload_diagram, payload_diagram

    # the defaults --help states; given without --diagram, these options are refused by run_payload
    direction = parse_triple("0,0,1" if args.direction is None else args.direction, "--direction")
    if direction == (0.0, 0.0, 0.0):
        raise UsageError("--direction 0,0,0: give a direction that is not zero")
    max_offset = bounds.length(0.3 if args.max_offset is None else args.max_offset, "--max-offset", error=UsageError)
    seed = 0 if args.seed is None else args.seed
    steps = bounds.count(16 if args.steps is None else args.steps, "--steps", minimum=2, maximum=1000, error=UsageError)
    samples = bounds.count(1000 if args.samples is None else args.samples, "--samples", minimum=1, error=UsageError)
    writable_path(args.diagram)
    robot = load_robot(args)
    chain = command_chain(robot, args.base, args.tip)
    diagram = payload_diagram(chain, np.linspace(0.0, max_offset, steps), samples=samples, seed=seed,
                              direction=direction, gravity=gravity)
    draw_payload_diagram(diagram, args.diagram)
    data = {**diagram.as_dict(), "png": str(args.diagram), "seed": seed}
    if args.format == "json":
        print_json(data)
        return EXIT_OK
    print(f"robot: {robot.name} ({robot.source.path}); chain {chain.base} -> {chain.tip}")
    along = ",".join(short_text(v) for v in direction)
    print(f"largest payload held still against the CoG offset along {along} (tip frame's axes), "
          f"over {diagram.configurations} configurations sampled inside the limits (seed {seed}); "
          f"drawn in {printable(args.diagram)}")
    print(grade_line(robot, args))
    print(f"{'offset m':>9}  {'worst kg':>10}  {'median kg':>10}  saturating at the worst")
    for d, worst, median, joint in zip(diagram.offsets, diagram.worst, diagram.median, diagram.worst_joint):
        print(f"{d:9.4f}  {number_text(worst, 3):>10}  {number_text(median, 3):>10}  {joint or 'none'}")
    return EXIT_OK


def run_inertia(args) -> int:
    """Print the inertia audit: one line (text) or one record (JSON, with the grade) per finding."""
    from manipkit.statics.audit import inertia_audit

    robot = load_robot(args)
    audit = inertia_audit(robot, geometry=not args.no_geometry)
    if args.format == "json":
        data = audit.as_dict()
        data["findings"] = [{**record, "grade": audit.grade} for record in data["findings"]]
        print_json(data)
        return EXIT_OK
    print(f"robot: {robot.name} ({robot.source.path}); {audit.links_checked} links checked")
    if not audit.geometry_checked:
        print(f"collision geometry not checked: {printable(audit.geometry_note)}")
    for finding in audit.findings:
        print(f"{finding.severity}: {finding.link}: {finding.check}: {finding.message}")
    print(grade_line(robot, audit=audit))
    return EXIT_OK


#: The largest trajectory file read (bytes).
MAX_TRAJECTORY_BYTES = 64 << 20


def read_trajectory(path, chain, rest) -> tuple:
    """(times or None, Q, Qd, Qdd) (T, n) from a trajectory CSV (header: ``t``, ``NAME``, ``NAME.qd``, ``NAME.qdd``).

    Lines starting with ``#`` and blank lines are skipped; a position column the header leaves out holds ``rest``
    (the chain vector of ``--q``), a rate column is 0. Messages name the file and line.
    """
    import csv

    import numpy as np

    from manipkit.inputs import read_text

    where = f"trajectory file {printable(str(path))}"
    text = read_text(path, what="trajectory file", max_bytes=MAX_TRAJECTORY_BYTES)
    lines = [(k + 1, row) for k, row in enumerate(csv.reader(text.splitlines()))
             if row and any(cell.strip() for cell in row) and not row[0].lstrip().startswith("#")]
    if not lines:
        raise UsageError(f"{where}: no header row; give t,NAME,...,NAME.qd,NAME.qdd")
    header = [cell.strip() for cell in lines[0][1]]
    names = chain.joint_names
    known = {"t", *names, *(f"{n}.qd" for n in names), *(f"{n}.qdd" for n in names)}
    unknown = [cell for cell in header if cell not in known]
    if unknown or len(set(header)) != len(header):
        what = f"unknown column {printable(unknown[0])}" if unknown else "a column given twice"
        raise UsageError(f"{where} line {lines[0][0]}: {what}; the columns are t, the chain's joints "
                         f"({', '.join(names)}), NAME.qd and NAME.qdd")
    if len(lines) < 2:
        raise UsageError(f"{where}: a header but no samples")
    values = np.zeros((len(lines) - 1, len(header)))
    for r, (number, row) in enumerate(lines[1:]):
        cells = [cell.strip() for cell in row]
        if len(cells) != len(header) or not all(is_number(c) and math.isfinite(float(c)) for c in cells):
            raise UsageError(f"{where} line {number}: give {len(header)} finite numbers, one per header column")
        values[r] = [float(c) for c in cells]
    column = {name: k for k, name in enumerate(header)}

    def block(suffix: str, fill) -> np.ndarray:
        return np.stack([values[:, column[f"{n}{suffix}"]] if f"{n}{suffix}" in column else
                         np.full(len(values), fill[k]) for k, n in enumerate(names)], axis=-1)

    zeros = [0.0] * chain.n
    times = values[:, column["t"]] if "t" in column else None
    return times, block("", rest), block(".qd", zeros), block(".qdd", zeros)


def _run_trajectory(args, robot, chain, q, payload, gravity) -> int:
    from manipkit.statics.dynamics import trajectory_torques

    times, Q, Qd, Qdd = read_trajectory(args.trajectory, chain, q[chain.columns])
    answer = trajectory_torques(chain, Q, Qd, Qdd, times=times, payload=payload, gravity=gravity, q_rest=q)
    first = answer.first_over
    data = {
        "robot": robot.name, "base": chain.base, "tip": chain.tip, "joint_names": list(answer.joint_names),
        "convention": "tau = M(q) qdd + C(q, qd) qd + g(q) (pinocchio.rnea): the torque each motor produces",
        "samples": len(answer.times), "times": answer.times.tolist(), "tau": answer.tau.tolist(),
        "gravity": answer.gravity.tolist(), "inertial": answer.inertial.tolist(),
        "coriolis": answer.coriolis.tolist(),
        "effort_limit": [float(v) if math.isfinite(v) else None for v in answer.effort_limit],
        "peak": answer.peak.tolist(),
        "share": {k: [float(v) if math.isfinite(v) else None for v in vals] for k, vals in answer.share.items()},
        "first_over": None if first is None else {"sample": first[0], "time": float(answer.times[first[0]]),
                                                  "joint": first[1]},
        "inertia_grade": _audit(robot).grade,
    }
    if args.format == "json":
        print_json(data)
        return EXIT_OK
    p = args.precision
    print(f"robot: {robot.name} ({robot.source.path}); chain {chain.base} -> {chain.tip}")
    print(f"{data['convention']}; {data['samples']} samples")
    print(grade_line(robot, args))
    header = ("joint", "peak |tau|", "limit", "gravity %", "inertial %", "coriolis %")
    rows = [(name, number_text(data["peak"][k], p),
             "none" if data["effort_limit"][k] is None else number_text(data["effort_limit"][k], p),
             *("-" if data["share"][part][k] is None else f"{100 * data['share'][part][k]:.1f}"
               for part in ("gravity", "inertial", "coriolis")))
            for k, name in enumerate(data["joint_names"])]
    widths = [max(len(row[i]) for row in [header, *rows]) for i in range(len(header))]
    for row in [header, *rows]:
        print("  ".join(cell.rjust(w) if i else cell.ljust(w) for i, (cell, w) in enumerate(zip(row, widths))))
    if first is None:
        print("no torque exceeds its effort limit along the trajectory")
    else:
        print(f"first over its effort limit: {first[1]} at sample {first[0]} (t = {number_text(data['first_over']['time'], p)})")
    return EXIT_OK
