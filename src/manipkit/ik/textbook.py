"""Closed-form IK of the bundled textbook arms, bound to their robot objects: :func:`analytic_ik`.

The solvers themselves (:mod:`manipkit.ik.planar`,
:mod:`manipkit.ik.decoupled`) work on numbers and DH tables; this
module reads a loaded robot's xacro arguments (link lengths, offsets,
prismatic limits), calls the matching solver and checks every solution
through the robot's own URDF model. It takes the robot object and never
imports the kinematics layer (docs/architecture.md, "Layers").

Conventions: ``target`` is ``T_base_link_ee_link`` (4x4, metres), the same
direction as ``robot.transform("base_link", "ee_link", q)``; solutions are
joint vectors in ``robot.joint_names`` order.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.bounds import tolerances
from manipkit.closed_form.checks import quantity_text, tolerance_pair
from manipkit.errors import ClosedFormIKError, IKOptionError
from manipkit.ik import decoupled, planar, planar_modes
from manipkit.ik.chain_ik import chain_ik_many, single_solver
from manipkit.ik.families import FAMILY_TOL, SRS, chain_family
from manipkit.ik.result import (
    PLANAR_POSE,
    PLANAR_POSITION,
    SPATIAL_POSE,
    SPATIAL_POSITION,
    IKBatch,
    IKResult,
    read_only,
)
from manipkit.memo import keep
from manipkit.spatial.transforms import check_transform, pose_residuals

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["ANALYTIC_SOLVERS", "AnalyticSolver", "analytic_ik", "analytic_ik_many", "checked_targets", "closed_form_refusal",
           "closed_form_solves", "named_family"]


@dataclass(frozen=True)
class AnalyticSolver:
    """A bundled robot's closed-form solver and what it solves.

    Attributes
    ----------
    solves : tuple of str
        The modes (:data:`manipkit.ik.result.MODES`) the solver
        answers; a position mode whose result is a family says so here too.
    planar : bool
        A planar arm: it moves in the x-y plane of ``base_link``, its tool
        turns about z only.
    solve : callable
        ``(T_base_link_ee_link, xacro arguments, mode, samples, tol) -> IKResult``
        with ``mode`` ``"pose"`` or ``"position"``.
    """

    solves: tuple[str, ...]
    planar: bool
    solve: Callable[[np.ndarray, dict, str, int, float], IKResult]


def _heading(T: np.ndarray) -> float:
    """The angle (rad) of the tool x axis about z: phi of a planar pose."""
    return math.atan2(T[1, 0], T[0, 0])


def _planar_2r(T: np.ndarray, args: dict, mode: str, samples: int, tol: float) -> IKResult:
    lengths = float(args["l1"]), float(args["l2"])
    if mode == "position":
        return planar.ik_2r(T[0, 3], T[1, 3], *lengths)
    return planar_modes.ik_2r_pose(T[0, 3], T[1, 3], _heading(T), *lengths, tol=tol)


def _planar_3r(T: np.ndarray, args: dict, mode: str, samples: int, tol: float) -> IKResult:
    lengths = tuple(float(args[k]) for k in ("l1", "l2", "l3"))
    if mode == "position":
        return planar_modes.ik_3r_position(T[0, 3], T[1, 3], *lengths, samples=samples)
    return planar.ik_3r(T[0, 3], T[1, 3], _heading(T), *lengths)


def _scara(T: np.ndarray, args: dict, mode: str, samples: int, tol: float) -> IKResult:
    kwargs = {name: float(args[name]) for name in ("a1", "a2", "d1", "d4")}
    result = decoupled.ik_scara(T, d3_limits=(0.0, float(args["d3_max"])), mode=mode, samples=samples, tol=tol, **kwargs)
    return result.replaced(solver="decoupled.ik_scara")


def _decoupled(function: str, names: tuple[str, ...], limits=None) -> Callable[..., IKResult]:
    def solve(T: np.ndarray, args: dict, mode: str, samples: int, tol: float) -> IKResult:
        kwargs = {name: float(args[name]) for name in names}
        kwargs["tol"] = tol
        if limits is not None:
            kwargs["d3_limits"] = limits(args)
        return getattr(decoupled, function)(T, **kwargs).replaced(solver=f"decoupled.{function}")

    return solve


def named_family(name: str) -> str:
    """The ``arm_family`` of a bundled textbook arm's closed form: ``"textbook planar_2r"``."""
    return f"textbook {name}"


#: Bundled robot name -> its closed-form solver and what it solves.
ANALYTIC_SOLVERS: dict[str, AnalyticSolver] = {
    "planar_2r": AnalyticSolver((PLANAR_POSITION,), True, _planar_2r),
    "planar_3r": AnalyticSolver((PLANAR_POSE, PLANAR_POSITION), True, _planar_3r),
    "scara": AnalyticSolver((SPATIAL_POSE, SPATIAL_POSITION), False, _scara),
    "stanford_arm": AnalyticSolver(
        (SPATIAL_POSE,), False, _decoupled("ik_stanford", ("d1", "d2", "d6"), lambda a: (float(a["d3_min"]), float(a["d3_max"])))),
    "elbow_arm": AnalyticSolver((SPATIAL_POSE,), False, _decoupled("ik_elbow", ("d1", "a2", "a3", "d6"))),
}


def analytic_ik(robot: Robot, target, base: str = "base_link", tip: str = "ee_link", *, mode: str = "pose", tol=1e-9,
                samples: int = 4, family_tol=FAMILY_TOL, lock=None, arm_angle=None) -> IKResult:
    """All closed-form IK solutions for ``T_base_tip = target``: a bundled textbook arm's, or any chain's with a 6R family.

    Two paths. The bundled textbook arms (below) between ``base_link`` and
    ``ee_link`` are solved by their named solvers, as before. Any other
    robot or frames are solved from the chain's own geometry
    (:func:`manipkit.ik.chain_ik.chain_ik` on ``robot.chain(base,
    tip)``: spherical-wrist and UR-type 6R arms, every branch labelled,
    limit-aware, FK-checked; a pose only), with ``family_tol`` (m, rad) the
    tolerance within which axes count as meeting or parallel. What this path
    finds for a robot, frames and options (the chain, its family and solver,
    the parsed ``tol``) is kept for the next call with the same ones (without
    ``lock``; the 64 latest): every call still checks its target and solves
    and checks every branch.

    The named path (a bundled textbook arm, ``base_link`` to ``ee_link``):

    The solver parameters (link lengths, offsets, prismatic limits) are the
    robot's xacro arguments, so ``load("stanford_arm", d2=0.2)`` is solved
    with d2 = 0.2. Each solution is checked again through the URDF model
    (``robot.transform("base_link", "ee_link", q)``) in the asked mode and
    kept when its residuals are within ``tol``; the residuals are those of
    the URDF, never the solver's own.

    What each arm solves (``ANALYTIC_SOLVERS[name].solves``):

    - ``planar_2r``: a planar position (x, y). Asked for a pose, the tool
      angle is checked too and, when no elbow has it, 0 solutions with
      ``unmet`` ``("orientation", rad)``.
    - ``planar_3r``: a planar pose (x, y, phi); asked for a position, the
      family in phi (``free_parameter = "phi"``, a few sampled, all through
      ``result.members(phis)``).
    - planar arms: a target off the arm's plane (z) or, for a pose, turned
      out of it (``"tilt"``: the angle between the target's z axis and the
      base z axis) has 0 solutions, the component and its size in ``unmet``.
    - ``scara``: a pose with the tool vertical, or a position: the family in
      the tool roll theta4.
    - ``stanford_arm``, ``elbow_arm``: a spatial pose only.

    Parameters
    ----------
    robot : manipkit.kinematics.robot.Robot
        ``planar_2r``, ``planar_3r``, ``scara``, ``stanford_arm`` or ``elbow_arm``.
    target : array_like, shape (4, 4)
        ``T_base_link_ee_link`` (metres); checked by
        :func:`manipkit.spatial.transforms.check_transform`.
    base, tip : str
        The frames, base first as everywhere: the closed forms solve
        ``base_link`` to ``ee_link`` (the defaults; their aliases and real
        names are accepted too).
    mode : {"pose", "position"}, keyword-only
        Match the whole pose, or the tool origin only (the target's rotation
        is then ignored and the rotation residuals are 0).
    tol : float or (float, float), keyword-only
        Residual tolerance of the URDF check: one number for both, or
        ``(position m, rotation rad)``; also how far off a planar arm's plane
        (m) or out of it (rad) a target may be.
    samples : int, keyword-only
        For a family with a free parameter: how many of its values to sample.
    family_tol : float or (float, float), keyword-only
        The geometric path's tolerance (m, rad) for axes that meet or are
        parallel (:func:`manipkit.ik.families.chain_family`).
    lock : dict of str to float, keyword-only
        The geometric path: joints held at a value, so a 7R arm is solved as
        the 6R arm of the others (``{"iiwa_joint_3": 0.4}``); rows keep them.
    arm_angle : float, keyword-only
        The geometric path on a 7R SRS arm (iiwa14): the arm angle (rad) to
        solve at (:func:`manipkit.ik.chain_ik.srs_arm_angle`).

    Returns
    -------
    IKResult
        manipkit's one IK result type (:class:`manipkit.ik.result.IKResult`):
        ``solver`` names the function used; ``mode`` what was asked (one of
        :data:`manipkit.ik.result.MODES`); ``solutions`` are joint
        vectors in ``robot.joint_names`` order, with the residuals of the
        URDF; ``count``, ``note``, ``reason``, ``labels``, ``unmet`` and the
        family fields are the solver's.

    Raises
    ------
    IKOptionError
        If the chain has no closed form (the message gives the family
        evidence: the measured misses), the mode is unknown, or the arm does
        not solve it (6R arms: a position alone).
    InvalidTransformError
        ``target`` is not a 4x4 homogeneous transform.

    Examples
    --------
    >>> import manipkit
    >>> robot = manipkit.load("planar_2r")
    >>> result = analytic_ik(robot, robot.transform("base_link", "ee_link", [0.3, 0.5]), mode="position")
    >>> result.solver, result.mode, result.count, result.labels
    ('planar.ik_2r', 'planar position (x, y)', 2, ('elbow-down', 'elbow-up'))
    """
    # Over 80 lines: the docstring (what each arm solves, every option) is most of it.
    if lock is None:  # a chain solved before with these arguments: its plan (below) answers at once
        try:
            plan = _PLANS.get((id(robot), base, tip, mode, tol, family_tol, arm_angle is None))
        except TypeError:  # an argument that cannot be a key (a list): checked on the way below
            plan = None
        if plan is not None and plan[0] is robot:
            return _planned(plan, target, arm_angle)
    arm = ANALYTIC_SOLVERS.get(robot.source.name) if robot.source.origin == "bundled" else None
    named_frames = (robot.frame(base), robot.frame(tip)) == (robot.frame("base_link"), robot.frame("ee_link"))
    if arm is None or not named_frames or lock or arm_angle is not None:
        return _geometric(robot, target, base, tip, mode, tol, family_tol, named=arm is not None, lock=lock,
                          arm_angle=arm_angle)
    if mode not in ("pose", "position"):
        raise IKOptionError(f"unknown closed-form mode '{mode}'; modes: pose, position")
    asked = ((PLANAR_POSE if mode == "pose" else PLANAR_POSITION) if arm.planar
             else (SPATIAL_POSE if mode == "pose" else SPATIAL_POSITION))
    if mode == "position" and not arm.planar and SPATIAL_POSITION not in arm.solves:
        raise IKOptionError(_position_refusal(robot.source.name, arm))
    tol = tolerances(tol)
    T = check_transform(target, what="IK target")
    result = arm.solve(T, robot.xacro_args, mode, samples, max(tol))
    if arm.planar:
        off_plane = _off_plane(robot, T, mode, tol)
        if off_plane:
            texts = [text for _, _, text in off_plane]
            in_plane = result.note.removeprefix("no solution: ")
            return IKResult(
                read_only((), (len(robot.joint_names),)), (), 0,
                "no solution: " + "; ".join(texts) + f"; within the plane: {in_plane}", read_only(()), read_only(()),
                solver=result.solver, joint_names=robot.joint_names, mode=asked,
                unmet=tuple((c, size) for c, size, _ in off_plane) + result.unmet,
                arm_family=named_family(robot.source.name),
            )
    checked = _verified(robot, T, result, mode == "pose", tol)
    family_function = None
    if result.family_function is not None:
        def family_function(values, _solve=result.family_function):
            return _verified(robot, T, _solve(values), mode == "pose", tol).replaced(mode=asked)
    return checked.replaced(mode=asked, family_function=family_function, arm_family=named_family(robot.source.name))


def _off_plane(robot: Robot, T: np.ndarray, mode: str, tol: tuple[float, float]) -> list[tuple[str, float, str]]:
    """A planar arm's target components out of its plane: [(component, size, sentence)]."""
    q0 = np.zeros(len(robot.joint_names))
    z_plane = float(robot.transform("base_link", "ee_link", q0, check_limits=False)[2, 3])  # any q: the plane
    problems = []
    dz = float(T[2, 3]) - z_plane
    if abs(dz) > tol[0]:
        problems.append((
            "z", abs(dz),
            f"z: the target is at z = {quantity_text(float(T[2, 3]))} m, off the arm's plane z = {quantity_text(z_plane)} m "
            f"by {quantity_text(abs(dz))} m (a planar arm moves in the x-y plane of base_link)",
        ))
    if mode == "pose":
        tilt = math.atan2(math.hypot(T[0, 2], T[1, 2]), T[2, 2])
        if tilt > tol[1]:
            problems.append((
                "tilt", tilt,
                f"tilt: the target's z axis is {quantity_text(tilt)} rad ({quantity_text(math.degrees(tilt))} deg) "
                "from the plane's normal (base z); a planar arm's tool turns about z only",
            ))
    return problems


def _verified(robot: Robot, T: np.ndarray, result: IKResult, pose: bool, tol: tuple[float, float]) -> IKResult:
    """``result`` with only the rows whose URDF forward kinematics reach T (in the asked mode), and those residuals."""
    n = len(robot.joint_names)
    rows = [i for i, q in enumerate(result.solutions) if q.size == n]
    Q = np.array([result.solutions[i] for i in rows], dtype=float).reshape(-1, n)
    T_reached = np.array([robot.transform("base_link", "ee_link", q, check_limits=False) for q in Q]).reshape(-1, 4, 4)
    residuals = pose_residuals(T, T_reached, mode="pose" if pose else "position")  # position: the orientation is free
    position, rotation = (np.atleast_1d(e).astype(float) for e in residuals)
    keep = (position <= tol[0]) & (rotation <= tol[1])
    dropped = int(np.count_nonzero(~keep))
    reason = result.note
    if dropped:
        worst = float(np.max(np.maximum(position, rotation)[~keep]))
        reason += (f"; {dropped} row(s) failed the check through the URDF (worst residual {quantity_text(worst)} > "
                   f"tol {' m, '.join(quantity_text(t) for t in tol)} rad) and were dropped")
    kept = int(np.count_nonzero(keep))
    count = result.count if math.isinf(result.count) and kept else kept
    return result.replaced(
        solutions=read_only(Q[keep], (n,)),
        labels=tuple(result.labels[i] for i, k in zip(rows, keep) if k),
        residual_position=read_only(position[keep]),
        residual_rotation=read_only(rotation[keep]),
        joint_names=robot.joint_names,
        count=count,
        note=reason,
        rejected=result.rejected + dropped,
    )


def _geometric_chain(robot: Robot, base: str, tip: str, mode: str, family_tol, named: bool, lock=None,
                     arm_angle=0.0):
    """(chain, family) of a chain with a geometric closed form, else IKOptionError saying why."""
    if mode not in ("pose", "position"):
        raise IKOptionError(f"unknown closed-form mode '{mode}'; modes: pose, position")
    chain = robot.chain(base, tip)
    try:
        family = chain_family(chain, tol=family_tol, lock=lock)
    except ClosedFormIKError as exc:
        raise IKOptionError(f"no closed-form solver for robot '{robot.name}' ({base} -> {tip}): {exc}") from None
    if not family.solved:
        if named:
            raise IKOptionError(f"the closed form of {robot.source.name} solves base_link -> ee_link, not {base} -> {tip}, "
                                f"and that chain has none from its geometry ({family.note}); use numerical IK for other frames")
        six_r = len(family.geometry.columns) == 6 and not family.geometry.prismatic.any()
        raise IKOptionError(f"no closed-form solver for robot '{robot.name}' ({base} -> {tip}): {family.note}; "
                            f"the bundled textbook arms {', '.join(ANALYTIC_SOLVERS)} have named solvers; "
                            + ("method 'algebraic' (ik --method algebraic) gives every isolated solution of this 6R "
                               "chain" if six_r else "use numerical IK otherwise"))
    if family.kind == SRS and arm_angle is None:
        raise IKOptionError(f"no closed-form solver for robot '{robot.name}' ({base} -> {tip}) without an arm angle: "
                            f"it is a 7R arm ({SRS}) with a family of solutions per target; give arm_angle (rad; "
                            "ik --arm-angle PSI) or lock a joint (lock=, ik --lock JOINT=VALUE)")
    if mode == "position":
        raise IKOptionError(f"the closed form of {robot.name} ({family.kind}) solves spatial pose (x, y, z, R) only, "
                            "not a position alone (a position alone leaves the orientation's degrees of freedom free); give an "
                            "orientation, or use numerical IK for a position")
    return chain, family


def _geometric(robot: Robot, target, base: str, tip: str, mode: str, tol, family_tol, named: bool,
               lock=None, arm_angle=None) -> IKResult:
    """:func:`analytic_ik` by the chain's geometry, rows as whole-robot vectors; its plan kept for the next call
    with the same arguments (:data:`_PLANS`)."""
    chain, family = _geometric_chain(robot, base, tip, mode, family_tol, named, lock, arm_angle)
    check = tolerance_pair(tol)
    try:
        solver = single_solver(chain, family)
    except ClosedFormIKError as exc:
        raise IKOptionError(str(exc)) from None
    whole = None
    if chain.joint_names != robot.joint_names:  # rows to whole-robot rows: the robot's defaults, the chain's columns
        whole = (read_only(np.asarray(robot.q(), dtype=float)), tuple(int(c) for c in chain.columns), robot.joint_names)
    plan = (robot, solver, check, whole)
    if lock is None:
        try:
            # the plan holds the robot, so its id is not reused while the entry lives
            keep(_PLANS, (id(robot), base, tip, mode, tol, family_tol, arm_angle is None), plan, limit=64)
        except TypeError:  # not a key (a tolerance that cannot be hashed): not kept
            pass
    return _planned(plan, target, arm_angle)


def _planned(plan: tuple, target, arm_angle) -> IKResult:
    """The answer of a plan ``(robot, chain's SingleSolver, check (m, rad), whole-robot rows or None)`` for ``target``:
    :func:`manipkit.ik.chain_ik.chain_ik` on the chain, rows as whole-robot vectors."""
    _, solver, check, whole = plan
    try:
        result = solver.solve(target, check, arm_angle)
    except ClosedFormIKError as exc:
        raise IKOptionError(str(exc)) from None
    if whole is None:  # the chain's rows are whole-robot rows already
        return result
    defaults, columns, names = whole
    Q = np.repeat(defaults[None], len(result.solutions), axis=0)
    Q[:, columns] = result.solutions
    Q.setflags(write=False)
    return result.with_rows(Q, names, tuple(columns[j] for j in result.free_joints))


#: (id(robot), base, tip, mode, tol, family_tol, arm_angle is None) -> the plan of analytic_ik's geometric path for
#: those arguments (lock None): the robot, the chain's SingleSolver, the parsed tol and the whole-robot row map; the
#: robot, its chain and family are immutable, so they are found once (the 64 made last are kept).
_PLANS: dict = {}


def checked_targets(targets) -> np.ndarray:
    """``targets`` as a float array (..., 4, 4) of finite numbers, else :class:`IKOptionError` in one line (the
    closed-form batches' check; each target's rotation block is checked where it is solved)."""
    T = np.asarray(targets, dtype=float)
    if T.ndim < 2 or T.shape[-2:] != (4, 4) or not np.all(np.isfinite(T)):
        raise IKOptionError(f"targets must be finite 4x4 transforms, shape (N, 4, 4); got shape {T.shape}")
    return T


def analytic_ik_many(robot: Robot, targets, base: str = "base_link", tip: str = "ee_link", *, tol=1e-9,
                     family_tol=FAMILY_TOL, lock=None, arm_angle=None) -> IKBatch:
    """Every closed-form branch for many targets ``T_base_tip`` (N, 4, 4) at once, from the chain's geometry.

    compiled over the targets (:func:`manipkit.ik.chain_ik.chain_ik_many`):
    an :class:`~manipkit.ik.result.IKBatch` of 8 slots per target, NaN where
    a branch does not exist, joint vectors in ``robot.chain(base,
    tip).joint_names`` order; residuals and ``success`` are measured by the
    chain's compiled FK, against ``tol``; ``lock`` as in
    :func:`analytic_ik`; ``arm_angle`` (rad) for a 7R SRS arm: one for every
    target or one per target (slots ``4 elbow + 2 shoulder + wrist``).
    Raises :class:`IKOptionError` when the chain has no geometric closed
    form, or an arm angle is missing or not valid.

    Examples
    --------
    >>> import manipkit
    >>> robot = manipkit.load("ur5")
    >>> chain = robot.chain("base_link", "tool0")
    >>> batch = analytic_ik_many(robot, chain.fk(chain.sample(3)), "base_link", "tool0")
    >>> batch.solutions.shape, bool(batch.success.all())
    ((3, 8, 6), True)
    """
    chain, family = _geometric_chain(robot, base, tip, "pose", family_tol, named=False, lock=lock, arm_angle=arm_angle)
    T = checked_targets(targets)
    try:
        return chain_ik_many(chain, T.reshape(-1, 4, 4), family=family, check_tol=tolerance_pair(tol), arm_angle=arm_angle)
    except ClosedFormIKError as exc:  # an arm angle that is not one number or one per target
        raise IKOptionError(str(exc)) from None


def _position_refusal(name: str, arm: AnalyticSolver) -> str:
    return (f"the closed form of {name} solves {' and '.join(arm.solves)} only, not a position alone (a position "
            "alone leaves the orientation's degrees of freedom free); give an orientation, or use numerical IK for a "
            "position")


def closed_form_refusal(robot: Robot, base: str = "base_link", tip: str = "ee_link", *, mode: str = "pose",
                        family_tol=FAMILY_TOL, lock=None, arm_angle=None) -> str:
    """Why :func:`analytic_ik` does not answer these frames in ``mode`` (one line with the geometric evidence), or
    ``""`` when it does."""
    if closed_form_solves(robot, base, tip, mode=mode, family_tol=family_tol, lock=lock, arm_angle=arm_angle):
        return ""
    arm = ANALYTIC_SOLVERS.get(robot.source.name) if robot.source.origin == "bundled" else None
    if arm is not None and not lock and mode == "position" and \
            (robot.frame(base), robot.frame(tip)) == (robot.frame("base_link"), robot.frame("ee_link")):
        return _position_refusal(robot.source.name, arm)
    try:
        _geometric_chain(robot, base, tip, mode, family_tol, named=arm is not None, lock=lock, arm_angle=arm_angle)
    except IKOptionError as exc:
        return str(exc)
    return f"no closed-form solver for robot '{robot.name}' ({base} -> {tip}) in mode {mode}"


def closed_form_solves(robot: Robot, base: str = "base_link", tip: str = "ee_link", *, mode: str = "pose",
                       family_tol=FAMILY_TOL, lock=None, arm_angle=None) -> str:
    """What :func:`analytic_ik` solves for these frames in ``mode`` (``""``: it does not; use numerical IK).

    ``"named"`` for a bundled textbook arm between ``base_link`` and
    ``ee_link`` whose solver answers ``mode``; the family's kind (e.g.
    ``"three parallel, two intersecting"``) for a chain with a geometric
    closed form and ``mode`` ``"pose"`` (a 7R SRS arm: with ``arm_angle``).

    Examples
    --------
    >>> import manipkit
    >>> closed_form_solves(manipkit.load("ur5"), "base_link", "tool0"), closed_form_solves(manipkit.load("iiwa14"))
    ('three parallel, two intersecting', '')
    """
    arm = ANALYTIC_SOLVERS.get(robot.source.name) if robot.source.origin == "bundled" else None
    if arm is not None and not lock and \
            (robot.frame(base), robot.frame(tip)) == (robot.frame("base_link"), robot.frame("ee_link")):
        position_ok = arm.planar or SPATIAL_POSITION in arm.solves
        return "named" if mode == "pose" or (mode == "position" and position_ok) else ""
    if mode != "pose":
        return ""
    try:
        family = chain_family(robot.chain(base, tip), tol=family_tol, lock=lock)
    except ClosedFormIKError:
        return ""
    if family.kind == SRS and arm_angle is None:
        return ""  # a 7R SRS arm needs its arm angle
    return family.kind if family.solved else ""
