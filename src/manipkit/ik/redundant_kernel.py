"""The sweep and narrowing of a 7R ranked set (:mod:`manipkit.ik.redundant`), compiled: one call per pose.

Two kinds of parameter (:data:`LOCKED`, :data:`ARM_ANGLE`): an end joint locked over a 6R arm "spherical wrist,
two intersecting" (Panda, FR3), and a 7R SRS arm's arm angle (iiwa14). What :mod:`manipkit.ik.redundant` does
through the dispatcher round by round (``_Solver.solve`` over :func:`manipkit.ik.chain_ik.chain_ik_many`, then
``_intervals``), in one loop of machine code, with the same operations in the same order:

- at a value ``v`` of the locked joint, the 6R arm's target (``T A(v)^-1`` for the last joint, ``A(v)^-1 T`` for
  the first; ``A`` by the locked joint's own FK program, inverted as a rigid transform), solved as
  :func:`~manipkit.ik.chain_ik.chain_ik_many` solves it: ``g = target M^-1`` (inverted for a family solved tip to
  base), every branch by :func:`manipkit.closed_form.spherical12_kernel.solve_target`; at an arm angle ``psi``,
  ``g = T M^-1`` and every branch by :func:`manipkit.closed_form.srs_kernel.solve_srs_target` (as
  ``srs_kernel``'s rows); each branch to a chain vector (:func:`manipkit.closed_form.check_kernel.chain_row`:
  in-limit aliases nearest 0), checked by the chain's FK program (:func:`~manipkit.closed_form.check_kernel.pose_rows`,
  :func:`~manipkit.closed_form.check_kernel.pose_residual`) against the target solved; a branch is feasible where
  it exists, reaches the target within ``tol`` and lies inside every joint limit, and its margin is its joints'
  least distance to a limit (rad; NaN where it does not reach);
- the sweep over ``values``, the runs of feasible samples per branch, and each run's end bracketed and narrowed
  in rounds by the Illinois variant of false position on the margin, else bisection (``redundant._intervals``'
  rule; a step at a bracket checks that bracket's branch only: each row's check is its own).

The reference's hand-backs stay the reference's: the targets the compiled closed form hands back (near a
threshold) come back with status :data:`REFERENCE`, their values and ``g`` (the sweep's all at once, then a
narrowing round's at its end); the caller solves them by the numpy reference and calls again with those answers
among ``known`` (the values are the same bits on every call, so the loop comes back to the same place). A row that
would be polished (missing the target by more than ``POLISH_TO`` and less than ``POLISH_BELOW``) or a target whose
rotation is not exact stops it with :data:`PYTHON`: the caller answers the pose the way it did before. Importing
this module imports numba.
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.closed_form.check_kernel import arm_constants, chain_row, exact_rotation, pose_residual, pose_rows
from manipkit.closed_form.spherical12_kernel import solve_target
from manipkit.closed_form.srs_kernel import solve_srs_target
from manipkit.closed_form.subproblems_kernel import compile_kernel, inlined_kernel

__all__ = ["ARM_ANGLE", "DONE", "LOCKED", "PYTHON", "REFERENCE", "SLOTS", "pack_settings", "reference_branches",
           "sweep_intervals", "sweep_rows"]

#: The parameter: an end joint locked over a 6R arm "spherical wrist, two intersecting"; a 7R SRS arm's arm angle.
LOCKED, ARM_ANGLE = 0, 1
#: Statuses of a call: answered; a target for the numpy reference (its ``g`` returned); answer the pose in Python.
DONE, REFERENCE, PYTHON = 0, 1, 2
#: Branches of the closed forms (their slots).
SLOTS = 8


def pack_settings(tol: tuple[float, float], parameter_tol: float, margin_tol: float, limit_slack: float,
                  polish_to: float, polish_below: float) -> np.ndarray:
    """The numbers of the ranked set's rule as the loop reads them (the constants of :mod:`manipkit.ik.redundant`,
    given by it): residual tolerance (m, rad), bracket width, margin at a limit, limit slack, polish bounds."""
    return np.array([tol[0], tol[1], parameter_tol, margin_tol, limit_slack, polish_to, polish_below], dtype=float)


def reference_branches(kind: int, arm, g: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The numpy reference's branches (theta (k, 8, m), valid (k, 8)) of the solve targets ``g`` (k, 4, 4) a call
    handed back at ``values`` (k,): :func:`manipkit.closed_form.srs.solve_srs_many` at those arm angles, else
    :func:`manipkit.closed_form.arms.solve_6r` of the 6R arm (``arm``: the ideal arm, ``ik.ideal_arm.IdealArm``)."""
    if kind == ARM_ANGLE:
        from manipkit.closed_form.srs import solve_srs_many

        branches = solve_srs_many(arm.h, arm.p, g, arm.points, values)
    else:
        from manipkit.closed_form.arms import SPHERICAL_12, solve_6r

        branches = solve_6r(SPHERICAL_12, arm.h, arm.p, g, arm.points)
    return branches.theta, branches.valid


@inlined_kernel
def _rigid_inverse(T, out):
    """``out`` (4, 4) = ``[[R^T, -R^T t], [0, 0, 0, 1]]`` of ``T`` (as ``spatial.transforms.invert_transform``)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = T[j, i]
    for i in range(3):
        out[i, 3] = -(out[i, 0] * T[0, 3] + out[i, 1] * T[1, 3] + out[i, 2] * T[2, 3])
        out[3, i] = 0.0
    out[3, 3] = 1.0


@inlined_kernel
def _product(A, B, out):
    """``out`` (4, 4) = ``A @ B`` (4, 4 each; ``out`` neither of them)."""
    for i in range(4):
        for j in range(4):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j] + A[i, 3] * B[3, j]


@inlined_kernel
def _keep_pose(poses, k, g):
    """``poses[k] = g`` (a 4x4), by loops (docs/site/internals/kernels.md, "Copies by loops")."""
    for a in range(4):
        for c in range(4):
            poses[k, a, c] = g[a, c]


@compile_kernel
def _solve_value(kind, value, slot, T, arm, arm_ints, moving_floats, moving_ints, column, limits, settings,
                 known_values, known_theta, known_valid, work, Q, ok, margin, g):
    """Every branch at ``value`` of the parameter (``kind``: :data:`LOCKED` or :data:`ARM_ANGLE`; ``slot`` >= 0:
    that branch only, the others left out as not ok; ``arm``: :func:`_arm`'s constants): ``Q`` (8, 7) chain vectors
    (NaN where none), ``ok`` (8,), ``margin`` (8,); returns (status, some branch reached the target). ``g`` (4, 4) is the solved target (the one to hand to the reference when the status is
    :data:`REFERENCE`). A branch's row, check and margin are its own (the FK of each row is that row's alone), so
    one branch alone is what it is among all eight."""
    # Over 80 lines: one value's solve, chain rows, FK check and limit margins, in the reference's order.
    H, P, points, M_inv, reverse, q0, columns, solved, floats, ints = arm
    theta, valid, miss, rows, reached, states, moving_states, locked, present, scratch, wanted, views = work
    one, inverse, target, solve = views
    if kind == ARM_ANGLE:  # the target itself, g = T M^-1 (srs_kernel's rows)
        for i in range(4):
            for j in range(4):
                target[i, j] = T[i, j]
        if not exact_rotation(target):
            return PYTHON, False
        _product(target, M_inv, g)
    else:  # the locked joint's transform A(value), then the 6R arm's target
        locked[0, 0] = value
        pose_rows(locked, present, moving_floats, moving_ints, moving_states, one)
        _rigid_inverse(one[0], inverse)
        if column == 0:
            _product(inverse, T, target)
        else:
            _product(T, inverse, target)
        if not exact_rotation(target):
            return PYTHON, False
        _product(target, M_inv, solve)
        if reverse:
            _rigid_inverse(solve, g)
        else:
            for i in range(4):
                for j in range(4):
                    g[i, j] = solve[i, j]
    known = -1
    for k in range(known_values.shape[0]):
        if known_values[k] == value and math.copysign(1.0, known_values[k]) == math.copysign(1.0, value):
            known = k
            break
    if known >= 0:
        for s in range(SLOTS):
            valid[s] = known_valid[known, s]
            for j in range(theta.shape[1]):
                theta[s, j] = known_theta[known, s, j]
    elif kind == ARM_ANGLE:
        for s in range(SLOTS):
            valid[s] = False
        if solve_srs_target(H, P, (points[1, 0], points[1, 1], points[1, 2]), (points[0, 0], points[0, 1], points[0, 2]),
                            math.cos(value), math.sin(value), g[:3, :3], (g[0, 3], g[1, 3], g[2, 3]), theta, valid,
                            slot):
            return REFERENCE, False
    else:
        c = (points[0, 0], points[0, 1], points[0, 2])
        s_ = (points[1, 0], points[1, 1], points[1, 2])
        if solve_target(H, P, c, s_, g[:3, :3], (g[0, 3], g[1, 3], g[2, 3]), theta, valid, miss, slot):
            return REFERENCE, False
    for s in range(SLOTS):
        wanted[s] = valid[s] and (slot < 0 or s == slot)
        if wanted[s]:
            chain_row(theta, s, reverse, q0, columns, solved, rows)
        else:
            for j in range(rows.shape[1]):
                rows[s, j] = np.nan
    pose_rows(rows, wanted, floats, ints, states, reached)
    any_reached = False
    n = Q.shape[1]
    for s in range(SLOTS):
        margin[s] = np.nan
        ok[s] = False
        if not wanted[s]:
            for j in range(n):
                Q[s, j] = np.nan
            continue
        at = 0
        for j in range(n):
            if j == column:
                Q[s, j] = value
            else:
                Q[s, j] = rows[s, at]
                at += 1
        position, rotation = pose_residual(target, reached[s])
        worst = max(position, rotation)
        if worst > settings[5] and worst < settings[6]:
            return PYTHON, False  # a row the reference polishes by Newton steps
        if position <= settings[0] and rotation <= settings[1]:
            least = np.inf
            for j in range(n):
                least = min(least, min(Q[s, j] - limits[0, j], limits[1, j] - Q[s, j]))
            margin[s] = least
            ok[s] = least >= -settings[4]
            any_reached = True
    return DONE, any_reached


@compile_kernel
def _work(arm_ints, moving_ints):
    """Scratch of :func:`_solve_value`: theta (8, m), valid (8,), miss (3,), rows (8, m), reached (8, 4, 4), the 6R
    chain's and the locked joint's FK states, the locked joint's row (1, 1) and its mask (1,), four (4, 4), the rows
    checked (8,), and the four's views (made once: a view costs its reference counts on every call)."""
    m = arm_ints[2]
    steps = arm_ints[4 + m]  # the 6R chain's FK program: its first int is its joint steps
    scratch = np.empty((4, 4, 4))
    return (np.empty((SLOTS, m)), np.zeros(SLOTS, dtype=np.bool_), np.zeros(3), np.empty((SLOTS, m)),
            np.empty((SLOTS, 4, 4)), np.empty((steps + 1, 4, 3)), np.empty((moving_ints[0] + 1, 4, 3)),
            np.empty((1, 1)), np.ones(1, dtype=np.bool_), scratch, np.zeros(SLOTS, dtype=np.bool_),
            (scratch[0:1], scratch[1], scratch[2], scratch[3]))


@compile_kernel
def _arm(arm_reals, arm_ints):
    """The constants :func:`_solve_value` reads, unpacked once per call of the loop (:func:`arm_constants`)."""
    _, H, P, points, _, M_inv, reverse, q0, columns, solved, _, floats, ints = arm_constants(arm_reals, arm_ints)
    return H, P, points, M_inv, reverse, q0, columns, solved, floats, ints


@compile_kernel
def sweep_intervals(kind, values, rounds, T, arm_reals, arm_ints, moving_floats, moving_ints, column, limits, settings,
                     known_values, known_theta, known_valid):
    """The feasible intervals of every branch over the sweep ``values`` (ascending, the parameter's range), each
    crossing narrowed in at most ``rounds`` steps.

    Returns (status, runs (R, 3): branch, low, high in the order of the branches then of the runs, reached: some
    branch reached the target at some value, asked (k,) and their g (k, 4, 4): with status :data:`REFERENCE` the
    values the numpy reference must answer (every such sample of the sweep at once, else those of the narrowing's
    round where the loop stopped)).
    """
    # Over 80 lines: the sweep, the runs and the narrowing of every bracket, as redundant._intervals has them.
    samples = values.shape[0]
    n = limits.shape[1]
    work = _work(arm_ints, moving_ints)
    arm = _arm(arm_reals, arm_ints)
    Q = np.empty((SLOTS, n))
    ok_at = np.zeros(SLOTS, dtype=np.bool_)
    margin_at = np.empty(SLOTS)
    g = np.empty((4, 4))
    ok = np.zeros((samples, SLOTS), dtype=np.bool_)
    margin = np.empty((samples, SLOTS))
    asked, asked_g = np.empty(samples), np.empty((samples, 4, 4))
    count_asked = 0
    reached_any = False
    for i in range(samples):
        status, reached = _solve_value(kind, values[i], -1, T, arm, arm_ints, moving_floats, moving_ints, column,
                                       limits, settings, known_values, known_theta, known_valid, work, Q, ok_at,
                                       margin_at, g)
        if status == PYTHON:
            return status, np.empty((0, 3)), reached_any, asked[:0], asked_g[:0]
        if status == REFERENCE:  # every sample the reference must answer, asked at once
            asked[count_asked] = values[i]
            _keep_pose(asked_g, count_asked, g)
            count_asked += 1
            continue
        reached_any = reached_any or reached
        for b in range(SLOTS):
            ok[i, b] = ok_at[b]
            margin[i, b] = margin_at[b]
    if count_asked:
        return REFERENCE, np.empty((0, 3)), reached_any, asked[:count_asked], asked_g[:count_asked]
    # runs of feasible samples: [branch, first sample, last sample]
    first = np.empty(SLOTS * samples, dtype=np.int64)
    last = np.empty(SLOTS * samples, dtype=np.int64)
    branch = np.empty(SLOTS * samples, dtype=np.int64)
    count = 0
    for b in range(SLOTS):
        i = 0
        while i < samples:
            if not ok[i, b]:
                i += 1
                continue
            j = i
            while j + 1 < samples and ok[j + 1, b]:
                j += 1
            branch[count], first[count], last[count] = b, i, j
            count += 1
            i = j + 1
    runs = np.empty((count, 3))
    # brackets: [run, end (0 low, 1 high)] and their outside, inside, margins there and the side kept last
    run_of, end_of = np.empty(2 * count, dtype=np.int64), np.empty(2 * count, dtype=np.int64)
    outside, inside = np.empty(2 * count), np.empty(2 * count)
    g_out, g_in = np.empty(2 * count), np.empty(2 * count)
    kept = np.zeros(2 * count, dtype=np.int64)
    brackets = 0
    for r in range(count):
        b, i, j = branch[r], first[r], last[r]
        runs[r, 0], runs[r, 1], runs[r, 2] = b, values[i], values[j]
        if i > 0:
            run_of[brackets], end_of[brackets] = r, 0
            outside[brackets], inside[brackets] = values[i - 1], values[i]
            g_out[brackets], g_in[brackets] = margin[i - 1, b], margin[i, b]
            brackets += 1
        if j < samples - 1:
            run_of[brackets], end_of[brackets] = r, 1
            outside[brackets], inside[brackets] = values[j + 1], values[j]
            g_out[brackets], g_in[brackets] = margin[j + 1, b], margin[j, b]
            brackets += 1
    parameter_tol, margin_tol = settings[2], settings[3]
    asked = np.empty(max(brackets, 1))
    asked_g = np.empty((max(brackets, 1), 4, 4))
    for _ in range(rounds):  # every active bracket one step per round, as redundant._intervals' rounds
        stepped = 0
        for k in range(brackets):
            if not (abs(outside[k] - inside[k]) > parameter_tol and not (g_in[k] <= margin_tol)):
                continue
            stepped += 1
            if math.isfinite(g_out[k]) and math.isfinite(g_in[k]) and g_in[k] > g_out[k]:
                t = min(max(g_in[k] / (g_in[k] - g_out[k]), 0.01), 0.99)  # false position, kept off the ends
                trial = inside[k] + t * (outside[k] - inside[k])
            else:
                trial = 0.5 * (outside[k] + inside[k])
            b = branch[run_of[k]]
            # the bracket's own branch only: whether any branch reaches the target is known from the sweep (a
            # bracket ends a run of feasible samples)
            status, reached = _solve_value(kind, trial, b, T, arm, arm_ints, moving_floats, moving_ints, column,
                                           limits, settings, known_values, known_theta, known_valid, work, Q, ok_at,
                                           margin_at, g)
            if status == PYTHON:
                return status, np.empty((0, 3)), reached_any, asked[:0], asked_g[:0]
            if status == REFERENCE:  # this round's hand-backs are asked together, at its end
                asked[count_asked] = trial
                _keep_pose(asked_g, count_asked, g)
                count_asked += 1
                continue
            reached_any = reached_any or reached
            if ok_at[b]:
                inside[k], g_in[k] = trial, margin_at[b]
                if kept[k] == 1:  # the outside end kept twice running: halve its margin (Illinois)
                    g_out[k] *= 0.5
                kept[k] = 1
            else:
                outside[k], g_out[k] = trial, margin_at[b]
                if kept[k] == -1:
                    g_in[k] *= 0.5
                kept[k] = -1
        if count_asked:
            return REFERENCE, np.empty((0, 3)), reached_any, asked[:count_asked], asked_g[:count_asked]
        if stepped == 0:
            break
    for k in range(brackets):
        runs[run_of[k], 1 + end_of[k]] = inside[k]
    return DONE, runs, reached_any, asked[:0], asked_g[:0]


@compile_kernel
def sweep_rows(kind, values, T, arm_reals, arm_ints, moving_floats, moving_ints, column, limits, settings, known_values,
                known_theta, known_valid):
    """Every branch at each of ``values``: (status, Q (k, 8, n), ok (k, 8), reached, asked, their g), handing back
    every value the reference must answer at once as :func:`sweep_intervals`' sweep does."""
    n = limits.shape[1]
    work = _work(arm_ints, moving_ints)
    arm = _arm(arm_reals, arm_ints)
    Q = np.empty((values.shape[0], SLOTS, n))
    ok = np.zeros((values.shape[0], SLOTS), dtype=np.bool_)
    margin = np.empty(SLOTS)
    g = np.empty((4, 4))
    asked, asked_g = np.empty(values.shape[0]), np.empty((values.shape[0], 4, 4))
    count = 0
    reached_any = False
    for i in range(values.shape[0]):
        status, reached = _solve_value(kind, values[i], -1, T, arm, arm_ints, moving_floats, moving_ints, column,
                                       limits, settings, known_values, known_theta, known_valid, work, Q[i], ok[i],
                                       margin, g)
        if status == PYTHON:
            return status, Q, ok, reached_any, asked[:0], asked_g[:0]
        if status == REFERENCE:
            asked[count] = values[i]
            _keep_pose(asked_g, count, g)
            count += 1
        reached_any = reached_any or reached
    return DONE if count == 0 else REFERENCE, Q, ok, reached_any, asked[:count], asked_g[:count]
