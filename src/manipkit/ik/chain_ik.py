"""Every closed-form IK solution of a chain, from its own geometry: :func:`chain_ik` and :func:`chain_ik_many`.

The chain (``robot.chain(base, tip)``, any base and tip frames: ``tool0``,
``flange``, a TCP beyond the last joint, a base above the first joint) is
classified by :func:`manipkit.ik.families.chain_family`; its axes
at the reference configuration ``q0`` and its tip pose there, ``M``, make
the product of exponentials ``T_base_tip(q) = E_1 ... E_6 M`` in which the
base and tip offsets are folded exactly. :mod:`manipkit.closed_form.arms`
gives every branch (the UR and OPW families compiled by
:mod:`manipkit.closed_form.arms_kernel`, targets near a decision threshold by
the numpy reference; ``compiled=False``: the reference alone); each is then:

- mapped to joint values ``q = q0 + angle / scale`` and, for a revolute
  joint, to the alias ``q + 2 pi k`` inside the limits nearest 0 (a joint
  whose range spans more than 2 pi has others: the note says so); a row
  outside the limits is kept and marked (``within_limits`` False);
- checked by the chain's compiled forward kinematics (``chain.fk``, not
  the solver's algebra); a row that misses by more than ``check_tol`` (a
  calibrated arm solved on its nearest ideal arm, or rounding) is refined by
  Newton steps on the true chain, and ``refined`` says by how far (rad or
  m, the joint-space step); rows that still miss are dropped and counted
  in ``rejected``;
- labelled ``"front|back, elbow up|down, no flip|wrist flip"`` (shoulder:
  the wrist centre on the side of axis 1 where it is at ``q0``, or the
  other; elbow: above or below the shoulder-wrist line, "above" along axis
  1 turned to point up the base z; wrist: the angle of the middle wrist
  joint from ``q0`` >= 0 or < 0), rows sharing these words numbered
  ``#1``, ``#2`` in slot order: :mod:`manipkit.ik.branch_names`, the one
  rule, which :meth:`IKBatch.branch_labels` of :func:`chain_ik_many` applies
  to each target's slots too.

A singular target (the wrist's first and last axes aligned, the wrist
centre on axis 1, axis 6 along the parallel axes of a UR arm) gives rows
standing for a one-parameter family: ``count`` is infinite, ``free_joints``
and ``free_parameter`` name the joint held at its ``q0`` value, and
``family`` says which combination is determined.

Given a chain object (the ik layer sits above kinematics); the pure math it hands arrays to is
:mod:`manipkit.closed_form`, and its compiled check runs the chain's FK program (:mod:`manipkit.kernels.fk`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from manipkit.bounds import tolerances
from manipkit.closed_form.arms import Branches, rotation_matrix, solve_6r
from manipkit.closed_form.checks import arm_angles, quantity_text, tolerance_pair
from manipkit.closed_form.srs import solve_srs_many
from manipkit.closed_form.subproblems import rotate, sp2
from manipkit.errors import ClosedFormIKError
from manipkit.ik.branch_names import REVERSED, SRS_WORDS, WORDS, branch_names, label_order, numbered
from manipkit.ik.chain_newton import newton_rows
from manipkit.ik.families import FAMILY_TOL, OPW, SPHERICAL_12, SRS, UR, Family, chain_family
from manipkit.ik.ideal_arm import IdealArm, compiled_arm, compiled_entry, ideal_arm, wide_joints
from manipkit.ik.result import SPATIAL_POSE, IKBatch, IKResult, read_only
from manipkit.memo import keep
from manipkit.spatial.rotations import wrap_angle
from manipkit.spatial.transforms import check_transform, invert_transform, pose_residuals, projected_rotation

if TYPE_CHECKING:
    from manipkit.kinematics.chain import Chain

__all__ = ["ARM_ANGLES_COMPILED_FROM", "CHECK_TOL", "SingleSolver", "chain_ik", "chain_ik_many", "refined_many", "single_solver", "slot_labels",
           "solve_branches", "srs_arm_angle"]

#: Residual (m and rad) within which a row's forward kinematics must reach the target.
CHECK_TOL = 1e-10
TWO_PI = 2.0 * math.pi


def _solved_direction(arm: IdealArm, T: np.ndarray) -> np.ndarray:
    """``g`` (N, 4, 4) of targets T (N, 4, 4) as the solver takes them: ``T M^-1``, inverted for a reversed family."""
    g = T @ arm.M_inv
    return invert_transform(g, check=False) if arm.family.reversed else g


def solve_branches(arm: IdealArm, g: np.ndarray, *, compiled: bool = True) -> Branches:
    """Every branch of ``arm`` for targets ``g`` (N, 4, 4): the compiled loop for the UR and OPW families
    (:mod:`manipkit.closed_form.arms_kernel`) and for "spherical wrist, two intersecting"
    (:mod:`manipkit.closed_form.spherical12_kernel`), the numpy reference for their hand-backs and for the other
    families.

    The two give the same branches (tested); ``compiled=False`` is the reference alone."""
    kind = arm.family.kind
    if not compiled or kind not in (UR, OPW, SPHERICAL_12):
        return solve_6r(kind, arm.h, arm.p, g, arm.points)
    if kind == SPHERICAL_12:
        from manipkit.closed_form.spherical12_kernel import solve_spherical_12_many

        theta, valid, miss, fallback = solve_spherical_12_many(arm.h, arm.p, arm.points["wrist"],
                                                                arm.points["shoulder"], g)
        near = valid.copy()
    else:
        from manipkit.closed_form.arms_kernel import solve_many

        theta, valid, near, fallback = solve_many(kind, arm.h, arm.p, arm.points["wrist"], arm.scale, g)
        miss = {"shoulder": np.zeros(len(g)), "reach": np.zeros(len(g)), "orientation": np.zeros(len(g))}
    N = len(g)
    free = np.full((N, 8), -1)
    if fallback.any():
        rows = np.flatnonzero(fallback)
        reference = solve_6r(kind, arm.h, arm.p, g[rows], arm.points)
        theta[rows], valid[rows], near[rows], free[rows] = (reference.theta, reference.valid, reference.near,
                                                            reference.free)
        for key, value in reference.miss.items():
            miss[key][rows] = value
    return Branches(theta, valid, free, miss, near)


def _branches(arm: IdealArm, T: np.ndarray, arm_angle=None, compiled: bool = True
              ) -> tuple[np.ndarray, Branches, np.ndarray]:
    """(theta (N, 8, n) in chain order, branches as solved, g as solved) for targets T (N, 4, 4)."""
    family = arm.family
    g = _solved_direction(arm, T)
    if family.kind == SRS:  # arm_angle: one (rad) or one per target
        branches = solve_srs_many(arm.h, arm.p, g, arm.points, arm_angles(arm_angle, len(g)))
        return branches.theta, branches, g
    branches = solve_branches(arm, g, compiled=compiled)
    theta = branches.theta[..., ::-1] if family.reversed else branches.theta
    return theta, branches, g


def _aliases(chain: Chain, Q: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """The solved (revolute) ``columns`` of chain vectors moved by whole turns to the in-limit value nearest 0
    (wrapped to (-pi, pi] when none is inside, or for a continuous joint); other entries (locked joints) as given."""
    Q = np.array(Q, dtype=float)
    lower, upper = np.asarray(chain.lower, dtype=float)[columns], np.asarray(chain.upper, dtype=float)[columns]
    wrapped = wrap_angle(Q[..., columns])
    best = np.array(wrapped, dtype=float)
    found = (wrapped >= lower - 1e-12) & (wrapped <= upper + 1e-12)
    for k in (1, -1, 2, -2):
        candidate = wrapped + k * TWO_PI
        inside = (candidate >= lower - 1e-12) & (candidate <= upper + 1e-12) & ~found
        best = np.where(inside, candidate, best)
        found |= inside
    Q[..., columns] = best
    return Q


def _joint_values(geometry, theta: np.ndarray) -> np.ndarray:
    """Chain vectors (..., n) from solved angles (..., 6): ``q0`` with the solved columns moved by ``theta / scale``."""
    Q = np.broadcast_to(geometry.q0, (*theta.shape[:-1], len(geometry.q0))).copy()
    Q[..., geometry.columns] = geometry.q0[geometry.columns] + theta / geometry.scale
    return Q




def _family_text(names: tuple[str, ...], free: int, kind: str) -> str:
    if free == 3:
        return (f"wrist singular (axes 4 and 6 aligned): only {names[3]} and {names[5]} together are determined; "
                f"the row holds {names[3]} at its reference value")
    if free == 5:
        return (f"wrist singular (axis 6 parallel to axes 2, 3, 4): {names[5]} with {names[1]}, {names[2]}, "
                f"{names[3]} is not determined; the row holds the member with the elbow mid-reach")
    if free == 0:
        return f"shoulder singular (the wrist centre on axis 1): {names[0]} is free; the row holds it at its reference value"
    return f"{names[free]} is free at this target; the row holds it at its reference value"


def chain_ik(chain: Chain, target, *, family: Family | None = None, tol=FAMILY_TOL, check_tol=CHECK_TOL,
             max_iters: int = 20, lock=None, arm_angle=None, compiled: bool = True) -> IKResult:
    """Every closed-form IK solution of ``chain`` for ``T_base_tip = target``, found from the chain's geometry.

    Parameters
    ----------
    chain : manipkit.kinematics.chain.Chain
        ``robot.chain(base, tip)``: the answer is for these frames exactly.
    target : array_like, shape (4, 4)
        ``T_base_tip`` (metres).
    family : Family, keyword-only
        A family found before (:func:`chain_family`); found here otherwise with ``tol``.
    tol : float or (float, float), keyword-only
        The family tolerance (m, rad), as :func:`chain_family` takes it.
    check_tol : float or (float, float), keyword-only
        Residual (m, rad) a row's FK must reach; rows missing by more are refined.
    max_iters : int, keyword-only
        Newton steps at most per refined row.
    lock : dict of str to float, keyword-only
        Joints held at a value (a 7R arm solved as the 6R arm of the others;
        ``family`` found with the same ``lock``); rows keep those values.
    arm_angle : float, keyword-only
        A 7R SRS arm (:mod:`manipkit.closed_form.srs`): the angle (rad) of
        the elbow's plane about the shoulder-wrist line from the plane with
        joint 3 at its reference value.
    compiled : bool, keyword-only
        Solve the UR and OPW families in the compiled loop (:func:`solve_branches`);
        False: the numpy reference alone (the same branches; for tests).

    Returns
    -------
    IKResult
        Rows are chain vectors in ``chain.joint_names`` order, with
        ``labels``, ``within_limits`` and ``refined`` per row.

    Raises
    ------
    ClosedFormIKError
        The chain has no geometric closed form (the message gives the measured misses).

    Examples
    --------
    >>> import manipkit
    >>> chain = manipkit.load("ur5").chain("base_link", "tool0")
    >>> result = chain_ik(chain, chain.fk([0.1, -1.2, 1.4, -0.3, 1.1, 0.5]))
    >>> result.count, result.labels[0], bool(result.residual_position.max() < 1e-10)
    (8, 'front, elbow up, no flip', True)
    """
    family = chain_family(chain, tol=tol, lock=lock) if family is None else family
    solver = single_solver(chain, family)
    check = tolerance_pair(check_tol, error=ClosedFormIKError, what="check_tol")
    return solver.solve(target, check, arm_angle, max_iters=max_iters, compiled=compiled)


def _general(chain: Chain, arm: IdealArm, target, check: tuple[float, float], max_iters: int, arm_angle,
             compiled: bool) -> IKResult:
    """:func:`chain_ik` by the general path (any family, any target; the compiled single call hands targets here)."""
    # Over 80 lines: the parts of one honest answer (check, refine, limits, labels, families, misses) in order.
    family = arm.family
    T = check_transform(target, what="IK target")
    theta, branches, g = _branches(arm, T[None], arm_angle, compiled)
    geometry = family.geometry
    names = tuple(chain.joint_names)
    slots = np.flatnonzero(branches.near[0])  # exact branches, and those just off a tangency: refined if they miss
    candidates = _candidates(chain, arm, theta[0], slots, compiled)  # (k, n), one batched FK below
    T_check = _projected_target(T)
    position, rotation = (pose_residuals(T_check, chain.fk(candidates), project=False) if len(slots)
                          else (np.zeros(0), np.zeros(0)))
    position, rotation = np.atleast_1d(position).tolist(), np.atleast_1d(rotation).tolist()
    rows, labels, free_of, refined, rejected = [], [], [], [], 0
    residual_rows, kept = [], []
    worst = [0.0, 0.0]  # the largest position (m) and rotation (rad) miss of a dropped branch
    free_slots = branches.free[0].tolist()
    same = _pairwise_same(candidates)  # (k, k): equal modulo 2 pi (rows moved by Newton are compared again)
    steps = np.zeros(len(candidates))
    miss = np.flatnonzero((np.array(position) > check[0]) | (np.array(rotation) > check[1]))
    if len(miss):  # refined on the true chain, all in one compiled call, then measured again by its FK
        better = newton_rows(geometry, T, candidates[miss], iterations=max_iters)
        steps[miss] = np.abs(better - candidates[miss]).max(axis=1)
        candidates = candidates.copy()
        candidates[miss] = _aliases(chain, better, geometry.columns)
        again = pose_residuals(T_check, chain.fk(candidates[miss]), project=False)
        for k, i in enumerate(miss.tolist()):
            position[i], rotation[i] = float(np.atleast_1d(again[0])[k]), float(np.atleast_1d(again[1])[k])
    for index, (q, slot, p_err, r_err) in enumerate(zip(candidates, slots.tolist(), position, rotation)):
        moved = float(steps[index])
        if p_err > check[0] or r_err > check[1]:
            rejected += 1
            worst = [max(worst[0], float(p_err)), max(worst[1], float(r_err))]
            continue
        free = free_slots[slot]
        if family.reversed and free >= 0:
            free = 5 - free
        free = int(geometry.columns[free]) if free >= 0 else -1  # a chain column (locked joints have none)
        if rows and (_repeats(q, rows, free, free_of) if moved or any(refined)
                     else any(same[index][j] and free == f for j, f in zip(kept, free_of))):
            continue
        rows.append(q)
        kept.append(index)
        labels.append(int(slot))  # named below, all rows at once
        free_of.append(free)
        refined.append(moved)
        residual_rows.append((p_err, r_err))
    if labels:
        labels = branch_names(arm, g[0], branches.theta[0, labels], compiled)
    order = sorted(range(len(rows)), key=lambda i: label_order(labels[i]))  # front, elbow up, no flip first
    rows, labels, free_of, refined, residual_rows = ([seq[i] for i in order]
                                                     for seq in (rows, labels, free_of, refined, residual_rows))
    n = len(names)
    Q = np.array(rows, dtype=float).reshape(-1, n)
    residuals = np.array(residual_rows, dtype=float).reshape(-1, 2).T  # measured above, by FK of each row as kept
    within = np.asarray(chain.within_limits(Q), dtype=bool).reshape(-1) if len(rows) else np.zeros(0, dtype=bool)
    free_joints = tuple(sorted({f for f in free_of if f >= 0}))
    count: int | float = math.inf if free_joints else len(rows)
    solver = f"ik.chain_ik ({family.kind})"
    parts = [f"{len(rows)} {'row(s) (one-parameter families among them)' if free_joints else 'solution(s)'} "
             f"of the {family.kind} closed form"]
    if len(rows) and not within.all():
        parts.append(f"{int((~within).sum())} outside the joint limits (marked, not dropped)")
    if any(m > 0 for m in refined):
        parts.append(f"refined by Newton on the true chain (ideal arm {quantity_text(arm.moved)} m/rad away, "
                     f"largest step {quantity_text(max(refined))})")
    wide = wide_joints(chain, geometry.columns)
    if wide and len(rows):
        parts.append(f"{', '.join(wide)} span more than 2 pi: each also has the alias q +- 2 pi where inside its limits")
    if family.kind == SRS:
        parts.append(f"at arm angle psi = {quantity_text(float(arm_angle))} rad (each psi has its own solutions)")
    if family.locked:
        parts.append("with " + ", ".join(f"{k} = {quantity_text(v)}" for k, v in family.locked) + " locked")
    if rejected:
        parts.append(f"{rejected} branch(es) dropped: after refinement FK missed by up to {worst[0]:.3g} m and "
                     f"{worst[1]:.3g} rad, beyond check_tol ({check[0]:.3g} m, {check[1]:.3g} rad)")
    unmet = ()
    outside_by = 0.0
    if not rows:
        unmet, words = _unmet(branches, rejected)
        outside_by = float(branches.miss["reach"][0])
        parts = ["no solution: " + words] + parts[1:]
    solved = [int(c) for c in geometry.columns]
    solved_names = tuple(names[c] for c in solved)
    family_words = "; ".join(dict.fromkeys(_family_text(solved_names, solved.index(f), family.kind) for f in free_joints))
    return IKResult(
        read_only(Q, (n,)), tuple(labels), count, "; ".join(parts),
        read_only(np.atleast_1d(residuals[0])), read_only(np.atleast_1d(residuals[1])),
        mode=SPATIAL_POSE, solver=solver, joint_names=names,
        free_parameter=", ".join(names[f] for f in free_joints), family=family_words, free_joints=free_joints,
        unmet=unmet, rejected=rejected, outside_by=outside_by, within_limits=within,
        refined=np.array(refined, dtype=float), arm_family=family.kind,
    )


class SingleSolver:
    """:func:`chain_ik` on one chain and family, one target per call, with what every call reads looked up once: the
    ideal arm, the compiled loop's constants and the words of its notes and labels (:func:`single_solver`).

    ``solve(target, check, arm_angle)``, ``check`` a parsed (m, rad) pair, is ``chain_ik(chain, target,
    family=family, check_tol=check, arm_angle=arm_angle)``: the same answer, from the same code.
    """

    __slots__ = ("chain", "family", "arm", "compiled_kinds", "entry")

    def __init__(self, chain: Chain, family: Family):
        self.chain, self.family, self.arm = chain, family, ideal_arm(family)  # ClosedFormIKError: no solver
        kind = family.kind
        # whether the compiled single call may answer, without and with an arm angle
        self.compiled_kinds = (kind in (UR, OPW), kind in (UR, OPW) or (kind == SRS and not family.reversed))
        self.entry = None  # (constants, wide joints, notes, labels) of the compiled call, on its first use

    def solve(self, target, check: tuple[float, float], arm_angle=None, *, max_iters: int = 20,
              compiled: bool = True) -> IKResult:
        """Every closed-form solution for ``T_base_tip = target``, as :func:`chain_ik` gives it."""
        if arm_angle is not None and not isinstance(arm_angle, float):  # (numpy float64 is one) both paths take a float
            arm_angle = float(arm_angles(arm_angle, 1)[0])  # ClosedFormIKError: not one number
        if (compiled and self.compiled_kinds[arm_angle is not None] and type(target) is np.ndarray
                and target.shape == (4, 4) and target.dtype == np.float64 and target.flags.c_contiguous):
            # the kernel takes a target check_transform accepts as is (plain_target), else hands it back to be checked
            answer = self._checked_one(target, check, arm_angle)
            if answer is not None:
                return answer
        return _general(self.chain, self.arm, target, check, max_iters, arm_angle, compiled)

    def _checked_one(self, T: np.ndarray, check: tuple[float, float], arm_angle) -> IKResult | None:
        """A generic target of the UR and OPW families (or of a 7R SRS arm at ``arm_angle``) from one compiled call
        (:func:`manipkit.closed_form.arms_kernel.solve_check_one`, :func:`manipkit.closed_form.srs_kernel.
        solve_check_srs`: every branch solved, aliased, put through the chain's FK, measured, labelled, kept and
        ordered): the same rows, order, labels, residuals and note as the general path. None when that path must
        answer: the kernel hands the target back (near a threshold, a free angle, no branch, a target that is not
        one check_transform accepts as is with a rotation block exact to 1e-12: ``plain_target``), or a row misses
        ``check`` (refined by Newton there). ``T``: a C-contiguous float (4, 4) array."""
        if self.entry is None:
            self.entry = compiled_entry(self.chain, self.arm)[1:]
        prepared, wide, notes, words = self.entry
        family = self.family
        kernels = _KERNELS or _load_kernels()
        srs = family.kind == SRS
        solved = kernels[1](prepared, T, arm_angle, check) if srs else kernels[0](prepared, T, check)
        if solved is None:
            return None
        block, within, named = solved
        block.setflags(write=False)  # its columns below are read-only views
        within.setflags(write=False)
        count = len(within)
        labels = words.get(named)
        if labels is None:  # a new order of branches on this arm: worded once (at most 8 distinct codes, 0..7 each)
            table, suffix = SRS_WORDS if srs else WORDS, REVERSED if family.reversed else ""
            labels = numbered(table[code] + suffix for code in kernels[2](named))
            if len(words) < 4096:
                words[named] = labels
        key = within.tobytes()  # the note depends on the count of rows and of those outside the limits
        parts = notes.get(key)
        if parts is None:
            parts = notes[key] = _note_parts(self.arm, wide, count, within.tolist().count(False))
        head, tail = parts
        if srs:
            head += f"; at arm angle psi = {quantity_text(float(arm_angle))} rad (each psi has its own solutions)"
        n = block.shape[1] - 2
        return IKResult.of_checked_rows(block[:, :n], labels, head + tail, block[:, n], block[:, n + 1], within,
                                        _UNREFINED[count], mode=SPATIAL_POSE, solver=_SOLVER_NAMES[family.kind],
                                        joint_names=self.chain.joint_names, arm_family=family.kind)


def single_solver(chain: Chain, family: Family) -> SingleSolver:
    """The :class:`SingleSolver` of ``chain`` and ``family`` (both immutable), made on first use and kept (the 64
    made last); :class:`ClosedFormIKError` if the family has no solver."""
    key = (id(chain), id(family))
    solver = _SOLVERS.get(key)
    if solver is None or solver.chain is not chain or solver.family is not family:
        # the solver holds the chain and family, so their ids are not reused while the entry lives
        solver = keep(_SOLVERS, key, SingleSolver(chain, family), limit=64)
    return solver


#: (id(chain), id(family)) -> its SingleSolver (oldest dropped first).
_SOLVERS: dict = {}


def _note_parts(arm: IdealArm, wide: list[str], count: int, outside: int) -> tuple[str, str]:
    """The note of a compiled single call with ``count`` rows, ``outside`` of them outside the limits, in two parts
    (the arm angle of an SRS arm goes between them), as the general path words it; kept per arm."""
    family = arm.family
    parts = [f"{count} solution(s) of the {family.kind} closed form"]
    if outside:
        parts.append(f"{outside} outside the joint limits (marked, not dropped)")
    if wide:
        parts.append(f"{', '.join(wide)} span more than 2 pi: each also has the alias q +- 2 pi where inside its limits")
    locked = ("; with " + ", ".join(f"{k} = {quantity_text(v)}" for k, v in family.locked) + " locked"
              if family.locked else "")
    return "; ".join(parts), locked


_SOLVER_NAMES = {kind: f"ik.chain_ik ({kind})" for kind in (UR, OPW, SRS)}


#: (arms_kernel.solve_check_one, srs_kernel.solve_check_srs, check_kernel.codes_of), imported on the first
#: compiled single call.
_KERNELS: list = []
#: refined of k rows none of which Newton moved: read-only zeros, k = 0..8.
_UNREFINED = tuple(read_only(np.zeros(k)) for k in range(9))


def _load_kernels() -> list:
    """Import the compiled single-call kernels (numba) once; :data:`_KERNELS` then holds them."""
    from manipkit.closed_form.arms_kernel import solve_check_one
    from manipkit.closed_form.check_kernel import codes_of
    from manipkit.closed_form.srs_kernel import solve_check_srs

    _KERNELS[:] = [solve_check_one, solve_check_srs, codes_of]
    return _KERNELS




def _same(a: np.ndarray, b: np.ndarray, tol: float = 1e-9) -> bool:
    difference = np.pi - np.mod(np.pi - (a - b), TWO_PI)
    return bool(np.all(np.abs(difference) <= tol))


def _pairwise_same(rows: np.ndarray, tol: float = 1e-9) -> list:
    """(k, k) nested lists: rows i and j equal modulo 2 pi (to ``tol``), as :func:`_same` of each pair."""
    difference = np.pi - np.mod(np.pi - (rows[:, None, :] - rows[None, :, :]), TWO_PI)
    return np.all(np.abs(difference) <= tol, axis=-1).tolist()


def _repeats(q: np.ndarray, rows: list, free: int, free_of: list) -> bool:
    """``q`` equals (modulo 2 pi, to 1e-9) a kept row with the same free joint."""
    others = np.array([row for row, f in zip(rows, free_of) if f == free]).reshape(-1, len(q))
    difference = np.pi - np.mod(np.pi - (others - q), TWO_PI)
    return bool(np.any(np.all(np.abs(difference) <= 1e-9, axis=-1)))


def _projected_target(T: np.ndarray) -> np.ndarray:
    """``T`` (..., 4, 4) with its rotation block(s) projected to the nearest rotation where not one to 1e-12, as
    :func:`~manipkit.spatial.transforms.pose_residuals` does by default: projected once here, the residuals of
    every row are measured with ``project=False`` (FK poses are rotations)."""
    T = np.array(T, dtype=float)
    T[..., :3, :3] = projected_rotation(T[..., :3, :3])
    return T


def _candidates(chain: Chain, arm: IdealArm, theta: np.ndarray, slots: np.ndarray, compiled: bool) -> np.ndarray:
    """Chain vectors (k, n) of the slots ``slots`` of ``theta`` (8, m) (chain order), in-limit aliases nearest 0."""
    geometry = arm.family.geometry
    if not compiled:
        return _aliases(chain, _joint_values(geometry, theta[slots]), geometry.columns)
    from manipkit.closed_form.arms_kernel import chain_rows

    lower, upper = _limits(chain, arm)
    rows = chain_rows(theta[None, slots], np.ones((1, len(slots)), dtype=bool), geometry.q0, geometry.columns,
                      geometry.scale, lower, upper)
    return rows[0]


def _limits(chain: Chain, arm: IdealArm) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) of the solved columns (chain order of ``columns``)."""
    columns = arm.family.geometry.columns
    return np.asarray(chain.lower, dtype=float)[columns], np.asarray(chain.upper, dtype=float)[columns]


def _unmet(branches: Branches, rejected: int) -> tuple[tuple, str]:
    """((component, size), ...) and words for a target with no branch."""
    miss = {k: float(v[0]) for k, v in branches.miss.items()}
    if miss["shoulder"] > 0.0:
        return (("shoulder", miss["shoulder"]),), (
            f"shoulder: the wrist centre cannot be turned into the arm's plane (misses by {quantity_text(miss['shoulder'])} m;"
            " it lies closer to axis 1 than the arm's lateral offset)")
    if miss["reach"] > 0.0:
        return (("reach", miss["reach"]),), (
            f"reach: the wrist centre is out of the elbow's reach by {quantity_text(miss['reach'])} m")
    if miss["orientation"] > 0.0:
        return (("orientation", miss["orientation"]),), "orientation: the wrist cannot turn the tool to the target"
    return (), f"every branch missed the target by more than check_tol ({rejected} dropped)"


def slot_labels(family: Family) -> tuple[str, ...]:
    """The names of :func:`chain_ik_many`'s 8 slots, slot ``4 a + 2 b + c`` first choice ``a``: ``"shoulder a,
    elbow b, wrist a"`` (a 7R SRS arm: ``"elbow a, shoulder b, wrist a"``)."""
    words = ("elbow", "shoulder", "wrist") if family.kind == SRS else ("shoulder", "elbow", "wrist")
    return tuple(f"{words[0]} {a}, {words[1]} {b}, {words[2]} {c}" for a in "ab" for b in "ab" for c in "ab")


def refined_many(chain: Chain, targets, *, family: Family, check_tol=CHECK_TOL, max_iters: int = 20) -> IKBatch:
    """:func:`chain_ik` of many 6R targets ``(N, 4, 4)`` in 8 slots (slot order, as :func:`chain_ik_many`): per target
    the rows ``chain_ik(chain, T, family=family, check_tol=check_tol)`` gives (a snapped arm's answers).

    Each exact branch and each just off a tangency (``Branches.near``) of the nearest ideal arm, at its in-limit
    alias nearest 0, measured by the chain's FK; those that miss ``check_tol`` refined by Newton steps on the true
    chain (:func:`manipkit.ik.chain_newton.newton_rows`, every target's rows in one compiled call) and measured
    again; NaN where still missing, and where a row equals (modulo 2 pi, 1e-9) an earlier slot's of its target
    with the same free joint. ``count`` infinite where a slot is a one-parameter family;
    :meth:`IKBatch.branch_labels` names each target's rows as :func:`chain_ik` does (from the ideal arm's branches).
    """
    arm = ideal_arm(family)
    check = tolerances(check_tol, error=ClosedFormIKError, what="check_tol")
    T = np.asarray(targets, dtype=float).reshape(-1, 4, 4)
    theta, branches, g = _branches(arm, T)
    geometry = family.geometry
    near = np.asarray(branches.near, dtype=bool)
    Q = np.where(near[..., None], _aliases(chain, _joint_values(geometry, np.nan_to_num(theta)), geometry.columns),
                 np.nan)
    T_check = _projected_target(T)
    position, rotation = np.full(near.shape, np.inf), np.full(near.shape, np.inf)
    if near.any():
        position[near], rotation[near] = pose_residuals(T_check[np.nonzero(near)[0]], chain.fk(Q[near]),
                                                        project=False)
    miss = near & ((position > check[0]) | (rotation > check[1]))
    if miss.any():
        owner = np.nonzero(miss)[0]
        better = newton_rows(geometry, T[owner], Q[miss], iterations=max_iters)
        Q[miss] = _aliases(chain, better, geometry.columns)
        position[miss], rotation[miss] = pose_residuals(T_check[owner], chain.fk(Q[miss]), project=False)
    kept = near & (position <= check[0]) & (rotation <= check[1])
    free = np.where(branches.free >= 0, 5 - branches.free if family.reversed else branches.free, -1)
    for s in range(1, Q.shape[1]):  # a slot repeating an earlier kept one of its target (the same free joint)
        gap = np.abs(np.pi - np.mod(np.pi - (Q[:, s:s + 1] - Q[:, :s]), TWO_PI)).max(axis=-1)  # (N, s)
        kept[:, s] &= ~((gap <= 1e-9) & kept[:, :s] & (free[:, :s] == free[:, s:s + 1])).any(axis=-1)
    Q = np.where(kept[..., None], Q, np.nan)
    count = np.where((kept & (free >= 0)).any(axis=-1), np.inf, kept.sum(axis=-1).astype(float))

    def measure(solutions):
        missing = np.isnan(solutions).any(axis=-1)
        filled = np.where(missing[..., None], 0.0, solutions)
        position, rotation = pose_residuals(T_check[:, None], chain.fk(filled), project=False)
        return np.where(missing, np.nan, position), np.where(missing, np.nan, rotation)

    def name(index: int) -> tuple[str, ...]:  # as chain_ik: the ideal arm's branches of the kept slots
        slots = np.flatnonzero(kept[index])
        names = [""] * Q.shape[1]
        for slot, label in zip(slots.tolist(), branch_names(arm, g[index], branches.theta[index, slots])
                               if len(slots) else ()):
            names[slot] = label
        return tuple(names)

    return IKBatch(Q, count, labels=slot_labels(family), mode=SPATIAL_POSE,
                   solver=f"ik.chain_ik refined ({family.kind})", joint_names=tuple(chain.joint_names),
                   measure=measure, limit=check, name=name)


def chain_ik_many(chain: Chain, targets, *, family: Family | None = None, tol=FAMILY_TOL, check_tol=CHECK_TOL,
                  lock=None, arm_angle=None, compiled: bool = True, threads: int | None = None) -> IKBatch:
    """Every branch for many targets ``(N, 4, 4)`` at once (compiled): an :class:`IKBatch` of 8 slots.

    Slot ``4 a + 2 b + c``: shoulder, elbow, wrist choice (a 7R SRS arm: elbow, shoulder, wrist, at ``arm_angle``,
    one angle in rad or one per target); NaN where a
    branch does not exist. Revolute entries are the in-limit aliases nearest
    0 (as :func:`chain_ik`); rows are not refined (a calibrated arm's rows
    carry the ideal arm's error: use :func:`chain_ik` for them). Residuals
    and ``success`` are measured by the chain's compiled FK against
    ``check_tol``: in the call for the UR, OPW and SRS families (the solve, the
    FK of every non-empty slot and the residuals compiled, in blocks of
    targets on up to ``threads`` threads:
    :func:`manipkit.ik.chain_batch.checked_many`), on first use
    for the others. ``compiled`` as in :func:`chain_ik` (False: the numpy
    reference, measured on first use). ``threads``: most threads at once
    (default: the cores this process may run on, up to 8, as ``ik_many``);
    the answers are the same bit for bit for any number.
    """
    family = chain_family(chain, tol=tol, lock=lock) if family is None else family
    arm = ideal_arm(family)
    check = tolerances(check_tol, error=ClosedFormIKError, what="check_tol")
    T = np.asarray(targets, dtype=float).reshape(-1, 4, 4)
    srs = family.kind == SRS
    psi = arm_angles(arm_angle, len(T)) if srs else None  # ClosedFormIKError: none given, or not one per target
    slots = slot_labels(family)
    solver = f"ik.chain_ik_many ({family.kind})"
    if compiled and (family.kind in (UR, OPW) or (srs and not family.reversed)):
        from manipkit.ik.chain_batch import checked_many
        from manipkit.kernels.fk import thread_count

        Q, count, success, residuals = checked_many(
            chain, compiled_arm(chain, arm), T, check, thread_count(threads), arm_angles=psi,
            reference=lambda rows: _reference_rows(chain, arm, T[rows], None if psi is None else psi[rows]),
            projected=_projected_target)
        return IKBatch(Q, count, labels=slots, mode=SPATIAL_POSE, solver=solver, joint_names=tuple(chain.joint_names),
                       success=success, residual_position=residuals[..., 0], residual_rotation=residuals[..., 1],
                       q_residuals=residuals[..., 0, :], limit=check, name=_namer(arm, T, Q))
    theta, branches, _ = _branches(arm, T, psi, compiled=compiled)
    geometry = family.geometry
    Q = _aliases(chain, _joint_values(geometry, theta), geometry.columns)
    Q = np.where(branches.valid[..., None], Q, np.nan)
    count = branches.valid.sum(axis=-1).astype(float)
    count = np.where((branches.free >= 0).any(axis=-1), np.inf, count)

    def measure(solutions):
        missing = np.isnan(solutions).any(axis=-1)
        filled = np.where(missing[..., None], 0.0, solutions)
        position, rotation = pose_residuals(_projected_target(T)[:, None], chain.fk(filled), project=False)
        return np.where(missing, np.nan, position), np.where(missing, np.nan, rotation)

    return IKBatch(Q, count, labels=slots, mode=SPATIAL_POSE, solver=solver, joint_names=tuple(chain.joint_names),
                   measure=measure, limit=check, name=_namer(arm, T, Q))


def _namer(arm: IdealArm, T: np.ndarray, Q: np.ndarray):
    """``IKBatch.branch_labels``' callable: flat target index -> the names of its slots (``""`` where empty) by
    :func:`~manipkit.ik.branch_names.branch_names`, from the slots' rows ``Q`` (N, 8, n) and targets ``T`` (N, 4, 4)
    as :func:`chain_ik` names that target's rows."""
    geometry = arm.family.geometry
    columns = geometry.columns

    def name(index: int) -> tuple[str, ...]:
        rows = Q[index]
        filled = np.flatnonzero(~np.isnan(rows).any(axis=-1))
        names = [""] * len(rows)
        if len(filled):
            theta = (rows[filled][:, columns] - geometry.q0[columns]) * geometry.scale  # chain order, any alias
            if arm.family.reversed and arm.family.kind != SRS:
                theta = theta[:, ::-1]  # the solve direction, as _branches turns it
            g = _solved_direction(arm, T[index][None])[0]
            for slot, label in zip(filled.tolist(), branch_names(arm, g, theta)):
                names[slot] = label
        return tuple(names)

    return name


def _reference_rows(chain: Chain, arm: IdealArm, T: np.ndarray, psi: np.ndarray | None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(valid (K, 8), free (K,): some slot has a free angle, rows (K, 8, n)) of targets ``T`` (K, 4, 4) (a 7R SRS
    arm's at arm angles ``psi`` (K,)) by the numpy reference, for the targets :func:`chain_ik_many`'s compiled loop
    hands back (rows as its compiled rows)."""
    from manipkit.closed_form.arms_kernel import chain_rows

    theta, reference, _ = _branches(arm, T, psi, compiled=False)
    geometry = arm.family.geometry
    rows = chain_rows(theta, reference.valid, geometry.q0, geometry.columns, geometry.scale, *_limits(chain, arm))
    return reference.valid, (reference.free >= 0).any(axis=-1), rows


def srs_arm_angle(chain: Chain, q, *, family: Family | None = None, compiled: bool = True):
    """The arm angle (rad) of configuration ``q`` of a 7R SRS chain, as :func:`chain_ik`'s ``arm_angle`` takes it:
    a float for ``q`` (n,), an (N,) array for the rows of ``q`` (N, n) (one vectorised pass).

    The rotation about the shoulder-wrist line that takes the reference
    plane (joint 3 at its reference value) to the elbow's plane at ``q``;
    ``chain_ik(chain, chain.fk(q), arm_angle=srs_arm_angle(chain, q))`` lists ``q``.

    From :data:`ARM_ANGLES_COMPILED_FROM` rows on, one compiled pass
    (:func:`manipkit.closed_form.srs_kernel.arm_angles_into`) answers the rows
    away from its thresholds and this numpy pass the rest; both give the same
    angle to rounding (about 1e-15 rad; up to about 1e-13 rad near the
    shoulder's singularity, the wrist centre near axis 1). ``compiled=False``:
    the numpy pass alone (the reference).
    """
    family = chain_family(chain) if family is None else family
    if family.kind != SRS:
        raise ClosedFormIKError(f"an arm angle belongs to a 7R SRS chain; this chain is '{family.kind}'")
    arm = ideal_arm(family)
    q = np.asarray(q, dtype=float)
    if compiled and q.ndim == 2 and len(q) >= ARM_ANGLES_COMPILED_FROM and not family.reversed:
        from manipkit.closed_form.srs_kernel import arm_angles_into

        rows = np.ascontiguousarray(q)
        psi, fallback = np.empty(len(rows)), np.empty(len(rows), dtype=bool)
        arm_angles_into(compiled_arm(chain, arm), np.ascontiguousarray(chain.fk(rows)), rows, psi, fallback)
        if fallback.any():
            psi[fallback] = _arm_angles(chain, arm, family, rows[fallback])
        return psi
    return _arm_angles(chain, arm, family, q)


#: From this many configurations on, :func:`srs_arm_angle` takes the compiled pass (below it the pass's call and
#: first compile would cost more than the numpy pass saves).
ARM_ANGLES_COMPILED_FROM = 64


def _arm_angles(chain: Chain, arm: IdealArm, family: Family, q: np.ndarray):
    """:func:`srs_arm_angle` by numpy (the reference): a float for ``q`` (n,), (N,) for ``q`` (N, n)."""
    h, p = arm.h, arm.p
    geometry = family.geometry
    rows = np.atleast_2d(q)
    theta = geometry.scale * (rows[:, geometry.columns] - geometry.q0[geometry.columns])
    g = np.asarray(chain.fk(rows)).reshape(-1, 4, 4) @ invert_transform(geometry.M)
    S, c = arm.points["shoulder"], arm.points["wrist"]
    v = g[:, :3, :3] @ c + g[:, :3, 3] - S
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    u = p[3] + rotate(h[3], theta[:, 3], c - p[3]) - S
    axes = np.broadcast_to(h[1], u.shape), np.broadcast_to(h[0], u.shape)
    first = sp2(axes[0], u, axes[1], v * np.linalg.norm(u, axis=-1, keepdims=True)).theta[:, 0]
    R_ref = rotation_matrix(h[0], -first[:, 1]) @ rotation_matrix(h[1], first[:, 0])
    R_shoulder = rotation_matrix(h[0], theta[:, 0]) @ rotation_matrix(h[1], theta[:, 1]) @ \
        rotation_matrix(h[2], theta[:, 2])
    gaps, angles = [], []
    # R_ref u = |u| v and R_shoulder u = |u| v at q, so the first turn fixes v; the second (joint 3 turned by pi)
    # does so only with the elbow straight (u along axis 3), where it must not win by rounding: its psi lists q's
    # twin with t3 + pi, not q
    for D in (R_shoulder @ np.swapaxes(R_ref, -1, -2),
              R_shoulder @ rotation_matrix(h[2], np.pi) @ np.swapaxes(R_ref, -1, -2)):
        gaps.append(np.linalg.norm(np.einsum("nij,nj->ni", D, v) - v, axis=-1))
        w = np.stack([D[:, 2, 1] - D[:, 1, 2], D[:, 0, 2] - D[:, 2, 0], D[:, 1, 0] - D[:, 0, 1]], axis=-1)
        angles.append(np.arctan2(0.5 * np.sum(v * w, axis=-1), 0.5 * (np.trace(D, axis1=-2, axis2=-1) - 1.0)))
    psi = np.where(gaps[1] < gaps[0] - 1e-9, angles[1], angles[0])
    return float(psi[0]) if q.ndim == 1 else psi
