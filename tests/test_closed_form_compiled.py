"""The compiled closed forms (closed_form.arms_kernel) give the numpy reference's answers (arms.solve_6r).

Both paths solve the same Paden-Kahan sequences; the compiled one hands every
target near a decision threshold back to the reference. So for random poses,
singular poses (q5 = 0, the wrist centre on axis 1), poses just off a
singularity and unreachable ones, ``chain_ik`` and ``chain_ik_many`` must
return the same set of rows (modulo 2 pi), the same labels, the same count,
free joints and misses with ``compiled=True`` as with ``compiled=False``; and
every row must land on its target by Pinocchio's FK (an independent check of
both). The robots: ur5 and kinova (example-robot-data), UR5e and ABB IRB2400
(the shared ROS workspace, skipped without it).
"""

import math
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import manipkit
from manipkit.closed_form.arms import solve_6r
from manipkit.closed_form.arms_kernel import chain_rows, solve_many
from manipkit.ik.chain_ik import chain_ik, chain_ik_many
from manipkit.ik.families import SRS, chain_family
from manipkit.ik.ideal_arm import ideal_arm

REALWORLD = next((base / "shared" / "realworld" / "ws_ros1" / "src" for base in Path(__file__).resolve().parents[2:4]
                  if (base / "shared" / "realworld").is_dir()), Path("/nonexistent"))
CHAINS = {
    "ur5": ("ur5", "base_link", "tool0"),
    "kinova": ("kinova", "base", "j2s6s200_end_effector"),
    "ur5e": ("universal_robot/ur_description/urdf/ur5e.xacro", "base_link", "tool0"),
    "irb2400": ("abb/abb_irb2400_support/urdf/irb2400.xacro", "base_link", "tool0"),
}


def load(name: str):
    source, base, tip = CHAINS[name]
    if "/" in source:
        if not REALWORLD.is_dir():
            pytest.skip("the shared real-world workspace is not here")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # ur_description is also in example-robot-data: one warning
            robot = manipkit.load(str(REALWORLD / source))
    else:
        robot = manipkit.load(source)
    return robot, base, tip


def pinocchio_pose(robot, base: str, tip: str, q_full) -> np.ndarray:
    """T_base_tip by Pinocchio itself (not manipkit's compiled FK)."""
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.pinocchio_configuration(q_full))
    return np.linalg.inv(data.oMf[robot.frame_id(base)].homogeneous) @ data.oMf[robot.frame_id(tip)].homogeneous


def wrapped(a):
    return np.pi - np.mod(np.pi - np.asarray(a), 2 * np.pi)


def same_answer(fast, reference, tol=1e-8):
    """Same rows modulo 2 pi (in the same order), labels, count, free joints, limits, misses."""
    assert fast.labels == reference.labels
    assert fast.count == reference.count and fast.free_joints == reference.free_joints
    assert fast.solutions.shape == reference.solutions.shape
    if len(fast.solutions):
        assert np.abs(wrapped(fast.solutions - reference.solutions)).max() < tol
    assert fast.within_limits.tolist() == reference.within_limits.tolist()
    assert fast.unmet == reference.unmet and fast.success == reference.success
    assert fast.reason == reference.reason


@pytest.mark.parametrize("name", list(CHAINS))
def test_compiled_single_calls_equal_the_reference_on_random_poses(name):
    robot, base, tip = load(name)
    chain = robot.chain(base, tip)
    family = chain_family(chain)
    for q in chain.sample(40, seed=3):
        T = chain.fk(q)
        fast = chain_ik(chain, T, family=family)
        same_answer(fast, chain_ik(chain, T, family=family, compiled=False))
        assert any(np.abs(wrapped(s - q)).max() < 1e-7 for s in fast.solutions)  # the generating configuration
        for s in fast.solutions[:2]:  # Pinocchio, independent of the compiled FK the residuals come from
            assert np.abs(pinocchio_pose(robot, base, tip, chain.full(s)) - T).max() < 1e-10


@pytest.mark.parametrize("name", list(CHAINS))
def test_compiled_batch_equals_the_reference_batch(name):
    robot, base, tip = load(name)
    chain = robot.chain(base, tip)
    Q = chain.sample(500, seed=5)
    T = chain.fk(Q)
    fast, reference = chain_ik_many(chain, T), chain_ik_many(chain, T, compiled=False)
    assert np.array_equal(np.isnan(fast.solutions), np.isnan(reference.solutions))
    present = ~np.isnan(fast.solutions)
    assert np.abs(wrapped(fast.solutions[present] - reference.solutions[present])).max() < 1e-8
    assert np.array_equal(fast.count, reference.count)
    assert bool(fast.success.all())  # every pose solved, every row within the check by the chain's FK
    assert np.array_equal(fast.success, reference.success)  # the compiled loop's decision, numpy's on first use
    assert np.nanmax(np.abs(fast.residual_position - reference.residual_position)) < 1e-13
    assert np.nanmax(np.abs(fast.residual_rotation - reference.residual_rotation)) < 1e-13
    assert np.nanmax(np.maximum(fast.residual_position, fast.residual_rotation)) < 1e-10
    found = np.nan_to_num(np.abs(wrapped(fast.solutions - Q[:, None])), nan=9.0).max(axis=-1) < 1e-7
    assert found.any(axis=-1).all()


def test_the_kernel_hands_back_singular_targets_and_agrees_elsewhere():
    """solve_many itself: the rows it keeps equal solve_6r's slot by slot; a q5 = 0 target (a free q6 on one
    shoulder: a threshold decision) is handed back."""
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    arm = ideal_arm(chain_family(chain))
    Q = chain.sample(200, seed=9)
    Q[0] = [0.3, -1.1, 1.2, -0.8, 0.0, 0.4]
    g = chain.fk(Q) @ arm.M_inv
    theta, valid, near, fallback = solve_many(arm.family.kind, arm.h, arm.p, arm.points["wrist"], arm.scale, g)
    reference = solve_6r(arm.family.kind, arm.h, arm.p, g, arm.points)
    assert fallback[0] and not fallback[1:].any()
    kept = ~fallback
    assert np.array_equal(valid[kept], reference.valid[kept]) and np.array_equal(near[kept], reference.near[kept])
    both = valid & kept[:, None]
    assert np.abs(wrapped(theta[both] - reference.theta[both])).max() < 1e-9


@pytest.mark.parametrize("name", ["ur5", "irb2400"])
def test_singular_targets_give_the_reference_families(name):
    """q5 = 0 (axis 6 along 2, 3, 4 on a UR arm; axes 4 and 6 aligned on a spherical wrist): families, as the
    reference names them; a target 1e-7 off that gives what the reference gives (the UR arm: family members refined
    by Newton; the spherical wrist: 8 ordinary rows)."""
    robot, base, tip = load(name)
    chain = robot.chain(base, tip)
    for q5 in (0.0, 1e-7):
        q = np.array([0.2, 0.3, 0.1, 0.5, q5, 0.3])
        T = chain.fk(q)
        fast, reference = chain_ik(chain, T), chain_ik(chain, T, compiled=False)
        same_answer(fast, reference)
        assert fast.family == reference.family and np.array_equal(fast.refined > 0, reference.refined > 0)
        assert math.isinf(fast.count) or q5 > 0.0


@pytest.mark.parametrize("name", ["ur5", "kinova"])
def test_unreachable_targets_give_the_reference_misses(name):
    """1 m beyond the stretched arm: no row, the same unmet component and size."""
    robot, base, tip = load(name)
    chain = robot.chain(base, tip)
    T = chain.fk(np.zeros(len(chain.joint_names)))
    direction = T[:3, 3] / np.linalg.norm(T[:3, 3])
    T[:3, 3] += direction
    fast, reference = chain_ik(chain, T), chain_ik(chain, T, compiled=False)
    same_answer(fast, reference)
    assert not fast.success and fast.unmet == reference.unmet and fast.unmet[0][1] > 0.0
    batch, batch_reference = chain_ik_many(chain, T[None]), chain_ik_many(chain, T[None], compiled=False)
    assert np.isnan(batch.solutions).all() and np.isnan(batch_reference.solutions).all()
    assert not batch.success[0] and not batch_reference.success[0]


def test_chain_rows_take_the_in_limit_alias_nearest_zero():
    """By hand: a joint limited to [3, 6] rad solved at -3 rad: -3 + 2 pi = 3.283 is inside, so that is the row;
    a continuous joint (infinite limits) at 4 rad is wrapped to 4 - 2 pi; an invalid slot is NaN."""
    theta = np.array([[[-3.0, 4.0], [0.0, 0.0]]])
    valid = np.array([[True, False]])
    rows = chain_rows(theta, valid, np.zeros(2), np.array([0, 1]), np.ones(2), np.array([3.0, -np.inf]),
                      np.array([6.0, np.inf]))
    assert rows[0, 0].tolist() == pytest.approx([-3.0 + 2 * np.pi, 4.0 - 2 * np.pi], abs=1e-15)
    assert np.isnan(rows[0, 1]).all()


def test_solve_rows_into_packs_the_non_empty_rows_in_order_and_measure_at_equals_measure_many():
    from manipkit.closed_form.arms_kernel import measure_at, measure_many, solve_rows_into, solve_rows_many
    from manipkit.ik.ideal_arm import compiled_arm

    chain = manipkit.load("ur5").chain("base_link", "tool0")
    prepared = compiled_arm(chain, ideal_arm(chain_family(chain)))
    Q = chain.sample(300, seed=21)
    Q[::7, 4] = 0.0  # wrist singular: handed back (NaN rows, not packed)
    T = chain.fk(Q)
    T[::11, :3, 3] += 5.0  # out of reach: no branch
    N, n = len(T), 6
    valid, fallback, project = np.zeros((N, 8), dtype=bool), np.zeros(N, dtype=bool), np.zeros(N, dtype=bool)
    rows, packed, index = np.empty((N, 8, n)), np.full((8 * N, n), -7.0), np.full(8 * N, -1, dtype=np.int64)
    M = solve_rows_into(prepared, T, valid, fallback, project, rows, packed, index)
    expected = solve_rows_many(prepared, T)
    for got, want in zip((valid, fallback, project, rows), expected):
        assert np.array_equal(got, want, equal_nan=True)
    present = ~np.isnan(rows[..., 0])
    assert fallback.any() and (~present).any() and M == present.sum()
    assert np.array_equal(index[:M], np.flatnonzero(present.reshape(-1)))
    assert np.array_equal(packed[:M], rows[present])
    reached = chain.fk(packed[:M])
    residuals, success = np.empty((N, 8, 2)), np.empty(N, dtype=bool)
    measure_at(T, reached, index[:M], (1e-10, 1e-10), residuals, success)
    all_reached = np.broadcast_to(np.eye(4), (N, 8, 4, 4)).copy()
    all_reached[present] = reached
    want_residuals, want_success = measure_many(T, all_reached, rows, (1e-10, 1e-10))
    assert np.array_equal(residuals, want_residuals, equal_nan=True) and np.array_equal(success, want_success)
    assert np.isnan(residuals[~present]).all() and (residuals[present] < 1e-10).all()


finite = st.floats(allow_nan=False, allow_infinity=False, allow_subnormal=True)


@settings(max_examples=400, deadline=None)
@given(finite, finite)
def test_the_compiled_atan2_is_math_atan2_to_two_ulp(y, x):
    """The branch-free atan2 of the loops (octant by arithmetic on 0/1 flags, one division for the argument) against
    the C library's, including the sign of a zero result."""
    from manipkit.closed_form.subproblems_kernel import atan2

    got, want = atan2(y, x), math.atan2(y, x)
    assert abs(got - want) <= 2.0 * math.ulp(want)
    assert math.copysign(1.0, got) == math.copysign(1.0, want)


@pytest.mark.parametrize(("y", "x"), [(0.0, 1.0), (-0.0, 1.0), (0.0, -1.0), (-0.0, -1.0), (0.0, 0.0), (-0.0, -0.0),
                                      (1.0, 0.0), (-1.0, -0.0), (1.0, 1.0), (-1.0, 1.0), (1.0, -1.0), (-1.0, -1.0),
                                      (0.66, 1.0), (1.0, 0.66), (-0.66, -1.0), (5e-324, 1.0), (1.0, 5e-324)])
def test_the_compiled_atan2_on_axes_diagonals_and_the_reduction_edge(y, x):
    from manipkit.closed_form.subproblems_kernel import atan2

    got, want = atan2(y, x), math.atan2(y, x)
    assert abs(got - want) <= 2.0 * math.ulp(want) and math.copysign(1.0, got) == math.copysign(1.0, want)


vectors = st.lists(st.floats(min_value=-2.0, max_value=2.0, allow_nan=False), min_size=3, max_size=3).map(tuple)


@settings(max_examples=200, deadline=None)
@given(vectors, vectors, vectors, st.floats(min_value=0.0, max_value=3.0))
def test_sp1_pair_and_sp3_squared_answer_as_sp1_and_sp3(k, p, q, delta):
    """The lanes' shortcuts (an angle left as its unnormalised sine and cosine, its atan2 taken later; subproblem 3
    given delta squared) against the subproblems they stand for, and sp1's angle against the rotation it must
    produce."""
    from manipkit.closed_form.subproblems_kernel import atan2, rotate, sp1, sp1_pair, sp3, sp3_squared

    size_k = math.sqrt(sum(v * v for v in k))
    assume(size_k > 0.1)
    k = tuple(v / size_k for v in k)
    c, s, size, miss = sp1(k, p, q)
    y, x, size_a, miss_a = sp1_pair(k, p, q)
    t = atan2(y, x)
    assert size_a == size and miss_a == miss
    assert abs(math.cos(t) - c) < 1e-14 and abs(math.sin(t) - s) < 1e-14
    if size > 1e-3:  # the angle turns p as close to q as it can come: |R p - q| is the miss
        turned = rotate(k, math.cos(t), math.sin(t), p)
        assert abs(math.dist(turned, q) - miss) < 1e-12
    a, b = sp3(k, p, q, delta), sp3_squared(k, p, q, delta * delta)
    assert a[4:] == b[4:] and np.allclose(a[:4], b[:4], rtol=0.0, atol=0.0)


edges = [k * math.pi for k in range(-5, 6)] + [k * 2.0 * math.pi for k in (-2, -1, 1, 2)]
near_edges = st.sampled_from(edges).flatmap(
    lambda e: st.sampled_from([e, math.nextafter(e, math.inf), math.nextafter(e, -math.inf), e + 1e-16, e - 1e-16]))


@settings(max_examples=600, deadline=None)
@given(st.one_of(st.floats(min_value=-12.0, max_value=12.0), near_edges, st.floats(allow_nan=True)))
def test_the_wraps_by_selects_equal_the_wraps_bit_for_bit(x):
    """subproblems_kernel.wrap_by_selects and check_kernel.wrap_angle_by_selects (no branch, no fmod: the lanes'
    rows on vector registers) give wrap's and wrap_angle's bits wherever they say exact, and say exact for every
    x in (-3 pi, 3 pi] (pi - x in [-2 pi, 4 pi)), where the remainder is one exact subtraction or the same
    addition numba's % makes (derivation in wrap_by_selects)."""
    from manipkit.closed_form.check_kernel import wrap_angle, wrap_angle_by_selects
    from manipkit.closed_form.subproblems_kernel import wrap, wrap_by_selects

    for plain, selected in ((wrap, wrap_by_selects), (wrap_angle, wrap_angle_by_selects)):
        got, exact = selected(x)
        assert exact == (-2.0 * math.pi <= math.pi - x < 4.0 * math.pi)
        if exact:
            assert np.float64(got).tobytes() == np.float64(plain(x)).tobytes(), (plain.__name__, x)


@settings(max_examples=300, deadline=None)
@given(st.one_of(st.floats(allow_nan=True), st.sampled_from([0.0, -0.0, 5e-324, -5e-324, math.inf, -math.inf, -1.0])))
def test_the_compiled_sqrt_is_math_sqrt_bit_for_bit(x):
    """subproblems_kernel.sqrt (LLVM's instruction, so the lanes stay on vector registers) is the same correctly
    rounded IEEE square root as math.sqrt: equal bits for every float, nan below zero (math raises there)."""
    from manipkit.closed_form.subproblems_kernel import sqrt

    got = sqrt(x)
    if x < 0.0 or math.isnan(x):
        assert math.isnan(got)
    else:
        assert np.float64(got).tobytes() == np.float64(math.sqrt(x)).tobytes()


@pytest.mark.parametrize("name", ["ur5", "kinova", "irb2400"])
def test_chunks_of_lanes_give_the_one_target_answers_bit_for_bit(name):
    """The batch solves targets in chunks of 64 lanes (on vector registers; the last chunk padded), the single
    and general paths one target at a time (solve_many): the same code, so the same angles and flags bit for
    bit, on a count of targets that is no multiple of 64, with random, singular, straight-elbow and unreachable
    targets among them. Rows compared through chain_rows, the batch's own aliasing."""
    from manipkit.closed_form.arms_kernel import solve_rows_many
    from manipkit.ik.ideal_arm import compiled_arm

    robot, base, tip = load(name)
    chain = robot.chain(base, tip)
    arm = ideal_arm(chain_family(chain))
    Q = chain.sample(64 * 5 + 37, seed=11)
    Q[:40, 4] = 0.0  # the wrist singular
    Q[40:80, 2] = 1e-9  # the elbow straight
    T = chain.fk(Q)
    T[80:120, :3, 3] *= 3.0  # out of reach
    valid, fallback, _, rows = solve_rows_many(compiled_arm(chain, arm), T)
    assert not arm.family.reversed  # these arms are solved base to tip: the solver takes T M^-1
    M = arm.M_inv  # summed in the kernel's order (T @ M rounds differently)
    g = ((T[:, :, 0, None] * M[0] + T[:, :, 1, None] * M[1]) + T[:, :, 2, None] * M[2]) + T[:, :, 3, None] * M[3]
    theta, valid_one, _, fallback_one = solve_many(arm.family.kind, arm.h, arm.p, arm.points["wrist"], arm.scale, g)
    assert np.array_equal(fallback, fallback_one) and 0 < fallback.sum() < len(T)
    keep = ~fallback
    assert np.array_equal(valid[keep], valid_one[keep])
    theta = theta[..., ::-1] if arm.family.reversed else theta
    geometry = arm.family.geometry
    lower, upper = (np.asarray(limit, dtype=float)[geometry.columns] for limit in (chain.lower, chain.upper))
    want = chain_rows(theta[keep], valid_one[keep], geometry.q0, geometry.columns, geometry.scale, lower, upper)
    assert np.array_equal(rows[keep].view(np.int64), want.view(np.int64))


@pytest.mark.parametrize("name", ["ur5", "irb2400"])
def test_the_batch_rows_equal_chain_rows_with_offsets_and_scales(name):
    """The batch makes most rows in flat loops over the lanes (selects, wraps included) and the rest with
    check_kernel.chain_row (a lane whose value q0 + angle / scale is too far from 0 for the wrap by selects): on an
    arm packed with a reference configuration of 0.3 rad on a solved joint, a scale of -1 on another and of 0.2 on
    a third (values up to 5 pi), values inside (-pi, pi], wrapped by selects and left to chain_row all occur, and
    every row equals chain_rows' (the one-target aliasing) bit for bit."""
    from manipkit.closed_form.arms_kernel import KIND_CODES, solve_rows_many
    from manipkit.closed_form.check_kernel import pack_arm

    robot, base, tip = load(name)
    chain = robot.chain(base, tip)
    arm = ideal_arm(chain_family(chain))
    geometry = arm.family.geometry
    columns = np.ascontiguousarray(geometry.columns, dtype=np.int64)
    q0 = np.asarray(geometry.q0, dtype=float).copy()
    q0[columns[1]] = 0.3
    scale = np.asarray(geometry.scale, dtype=float).copy()
    scale[2] = -scale[2]
    scale[4] = 0.2 * scale[4]
    lower, upper = np.asarray(chain.lower, dtype=float), np.asarray(chain.upper, dtype=float)
    floats, ints = chain.program.row_tables
    points = np.array([arm.points["wrist"], arm.points.get("shoulder", arm.p[1]), *arm.label_axes], dtype=float)
    prepared = pack_arm(KIND_CODES[arm.family.kind], arm.h, arm.p, points, float(arm.scale), arm.M_inv,
                        bool(arm.family.reversed), q0, columns, np.array([scale, lower[columns], upper[columns]]),
                        np.array([lower, upper]), floats, ints)
    Q = chain.sample(64 * 3 + 5, seed=12)
    T = chain.fk(Q)
    valid, fallback, _, rows = solve_rows_many(prepared, T)
    M = arm.M_inv  # the targets as the kernel takes them (summed in its order)
    g = ((T[:, :, 0, None] * M[0] + T[:, :, 1, None] * M[1]) + T[:, :, 2, None] * M[2]) + T[:, :, 3, None] * M[3]
    theta, valid_one, _, _ = solve_many(arm.family.kind, arm.h, arm.p, arm.points["wrist"], arm.scale, g)
    keep = ~fallback
    want = chain_rows(theta[keep], valid_one[keep], q0, columns, scale, lower[columns], upper[columns])
    got = rows[keep]
    raw = q0[columns] + theta[keep] / scale  # before wrapping (these arms are solved base to tip)
    outside = ((raw <= -np.pi) | (raw > np.pi)).any(axis=-1) & valid_one[keep]
    far = ((np.pi - raw < -2 * np.pi) | (np.pi - raw >= 4 * np.pi)).any(axis=-1) & valid_one[keep]
    assert (outside & ~far).any() and far.any() and not outside.any(axis=-1).all()  # every kind of lane
    assert np.isnan(got).any() and not np.isnan(got).all()
    assert np.array_equal(got.view(np.int64), want.view(np.int64))


@pytest.mark.parametrize("name", ["ur5", "kinova", "irb2400"])
def test_branches_share_the_angles_the_tables_say_they_share(name):
    """The angle step takes the atan2 of the distinct angles only (arms_lanes.UR_ANGLES, OPW_ANGLES) and copies the
    rest (UR_COPIES, OPW_COPIES). That is exact only if a copied entry's two atan2 arguments equal its source's bit
    for bit, in every lane: checked on the lanes' own output for random, singular and unreachable targets; the
    tables cover the 48 entries once each (30 + 18 for UR, 34 + 14 for OPW: 2 shoulder choices x 15 and 17
    distinct angles, derived in arms_lanes)."""
    from manipkit.closed_form import arms_lanes

    robot, base, tip = load(name)
    chain = robot.chain(base, tip)
    arm = ideal_arm(chain_family(chain))
    ur = arm.family.kind == "three parallel, two intersecting"
    angles, copies = ((arms_lanes.UR_ANGLES, arms_lanes.UR_COPIES) if ur
                      else (arms_lanes.OPW_ANGLES, arms_lanes.OPW_COPIES))
    assert (len(angles), len(copies)) == ((30, 18) if ur else (34, 14))
    assert sorted([*angles, *(e for e, _ in copies)]) == list(range(48))
    assert all(s in angles for _, s in copies)
    L = arms_lanes.LANES
    Q = chain.sample(L, seed=5)
    Q[:8, 4] = 0.0  # the wrist singular
    T = chain.fk(Q)
    T[8:16, :3, 3] *= 3.0  # out of reach
    g = T @ arm.M_inv
    G = np.ascontiguousarray(g[:, :3, :].reshape(L, 12).T).reshape(-1)  # entry i of the top rows at G[i L + n]
    K = arms_lanes.arm_tuple(arm.h, arm.p, tuple(float(v) for v in arm.points["wrist"]), float(arm.scale))
    out = np.empty(arms_lanes.ENTRIES * L)
    (arms_lanes.ur_chunk if ur else arms_lanes.opw_chunk)(K, G, out)
    entries = out.reshape(arms_lanes.ENTRIES, L).view(np.int64)
    for e, s in copies:
        assert np.array_equal(entries[e], entries[s]) and np.array_equal(entries[48 + e], entries[48 + s]), (e, s)
    # and no sharing is missed: two distinct entries of one joint differ in some lane of the random targets
    random_lanes = entries[:, 16:]
    for a in angles:
        for b in angles:
            if a < b and a % 6 == b % 6:
                assert not np.array_equal(random_lanes[a], random_lanes[b]), (a, b)


def test_each_family_compiles_only_its_own_lanes():
    """The loops of a family (arms_kernel.family_kernels) reach the lanes only through their globals, which hold
    that family's lanes and code; so a UR arm's first solve never compiles the OPW lanes (nothing compiled here)."""
    from manipkit.closed_form import arms_kernel, arms_lanes

    lanes = {"ur_one", "ur_chunk", "opw_one", "opw_chunk"}
    for code, family in arms_kernel.FAMILY_NAMES.items():
        kernels = arms_kernel.family_kernels(code)
        assert kernels is arms_kernel.family_kernels(code)  # made once
        for name in ("solve_all", "labels", "solve_rows_all", "solve_check_one"):
            function = getattr(kernels, name).py_func
            assert function.__qualname__ == f"_{name}_{family}"
            assert not lanes & set(function.__code__.co_names)  # no family's lanes named in the code itself
            scope = function.__globals__
            assert scope["KIND"] == code and scope["_target"].py_func.__globals__ is scope
            assert scope["lanes_one"] is getattr(arms_lanes, f"{family}_one")
            assert scope["lanes_chunk"] is getattr(arms_lanes, f"{family}_chunk")
    ur, opw = arms_kernel.family_kernels(0), arms_kernel.family_kernels(1)
    assert ur.solve_check_one is not opw.solve_check_one
    assert arms_kernel.KIND_CODES == {"three parallel, two intersecting": 0, "spherical wrist, two parallel": 1}


@pytest.mark.parametrize("name", ["ur5", "irb2400", "kinova", "iiwa14"])
def test_the_compiled_check_runs_the_chain_program_and_measures_as_pinocchio(name):
    """The compiled loops' constants (``compiled_arm``) carry the chain's own FK program, packed once per chain
    (``chain.program.row_tables``, the same arrays every call), and the residuals the compiled check reports, single
    (``chain_ik``: ``pose_rows`` inside the loop) and batched (``chain_ik_many``: the chain's batched FK), equal those
    of Pinocchio's FK of every row to 1e-12 (iiwa14: a 7R SRS arm, each target at its own arm angle)."""
    from manipkit.ik.chain_ik import srs_arm_angle
    from manipkit.ik.ideal_arm import compiled_arm
    from manipkit.spatial.transforms import pose_residuals

    robot, base, tip = (manipkit.load("iiwa14"), "base_link", "ee_link") if name == "iiwa14" else load(name)
    chain = robot.chain(base, tip)
    family = chain_family(chain)
    floats, ints = chain.program.row_tables
    assert chain.program.row_tables[0] is floats  # packed once, kept
    arm_reals, arm_ints = compiled_arm(chain, ideal_arm(family))
    assert np.array_equal(arm_reals[-len(floats):], floats) and np.array_equal(arm_ints[-len(ints):], ints)
    Q = chain.sample(40, seed=3)
    T = chain.fk(Q)
    psi = np.array([srs_arm_angle(chain, q, family=family) for q in Q]) if family.kind == SRS else None
    data = robot.model.createData()

    def pinocchio_residuals(target, rows):
        reached = []
        for q in rows:
            pin.framesForwardKinematics(robot.model, data, robot.pinocchio_configuration(chain.full(q)))
            reached.append(np.linalg.inv(data.oMf[robot.frame_id(base)].homogeneous)
                           @ data.oMf[robot.frame_id(tip)].homogeneous)
        return np.stack(pose_residuals(target, np.array(reached), project=False), axis=-1)

    measured = 0
    for k in range(len(Q)):
        result = chain_ik(chain, T[k], family=family, **({} if psi is None else {"arm_angle": float(psi[k])}))
        assert result.success
        expected = pinocchio_residuals(T[k], result.solutions)
        assert np.abs(np.stack([result.residual_position, result.residual_rotation], axis=-1) - expected).max() < 1e-12
        measured += len(result.solutions)
    batch = chain_ik_many(chain, T, family=family, **({} if psi is None else {"arm_angle": psi}))
    for k in range(len(Q)):
        present = ~np.isnan(batch.solutions[k, :, 0])
        assert present.any()
        expected = pinocchio_residuals(T[k], batch.solutions[k, present])
        assert np.abs(batch.residuals[k, present] - expected).max() < 1e-12
    assert measured >= 4 * len(Q)
