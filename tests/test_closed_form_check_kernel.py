"""The compiled check of closed-form branches (closed_form.check_kernel) against the numpy definitions it twins.

- ``pose_residual`` is the compiled twin of ``spatial.transforms.pose_residuals(..., project=False)``: equal (to
  the 2 ulp of its atan2) on random poses (hypothesis), rotations or not;
- ``exact_rotation`` decides as ``projected_rotation`` does (a block used as is, or projected);
- ``pose_rows`` (kinematics.fk_kernel, the chain's FK program one row at a time) equals ``chain.fk``, and so
  Pinocchio, on arms with revolute, prismatic and continuous joints; rows that share their first joints' values
  (a target's branches) give each row's pose alone, bit for bit;
- the single-call path (``solve_check_one``) gives the general path's answer field for field: rows, order,
  labels, residuals, limits, note; on random, elbow-straight and limit-aliased targets.
"""

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import manipkit
from manipkit.closed_form.check_kernel import exact_rotation, pose_residual, pose_rows
from manipkit.ik.chain_ik import chain_ik, chain_ik_many
from manipkit.ik.families import chain_family
from manipkit.spatial.rotations import matrix_from_axis_angle
from manipkit.spatial.transforms import pose_residuals, projected_rotation

finite = st.floats(-3.0, 3.0, allow_nan=False)
vectors = st.tuples(finite, finite, finite)


def transform(axis, angle, t):
    T = np.eye(4)
    axis = np.asarray(axis, dtype=float)
    T[:3, :3] = matrix_from_axis_angle(axis / np.linalg.norm(axis), angle) if np.linalg.norm(axis) > 1e-3 else np.eye(3)
    T[:3, 3] = t
    return T


@settings(max_examples=300, deadline=None)
@given(vectors, st.floats(-np.pi, np.pi), vectors, vectors, st.floats(-np.pi, np.pi), vectors,
       st.floats(0.0, 1e-3))
def test_pose_residual_equals_pose_residuals(a1, t1, p1, a2, t2, p2, skew):
    T_ref, T = transform(a1, t1, p1), transform(a2, t2, p2)
    T[:3, :3] += skew * np.array([[0.0, 1.0, 0.3], [-0.2, 0.0, 0.5], [0.1, 0.4, 0.0]])  # not always a rotation
    position, rotation = pose_residuals(T_ref, T, project=False)
    compiled = pose_residual(T_ref, T)
    assert compiled[0] == pytest.approx(float(position), abs=1e-15)
    assert compiled[1] == pytest.approx(float(rotation), abs=1e-15)  # its atan2 within 2 ulp of numpy's (pi: 9e-16)


@settings(max_examples=200, deadline=None)
@given(vectors, st.floats(-np.pi, np.pi), st.floats(-1e-10, 1e-10), st.booleans())
def test_exact_rotation_decides_as_projected_rotation(axis, angle, off, reflect):
    T = transform(axis, angle, (0.0, 0.0, 0.0))
    T[0, :3] *= 1.0 + off
    if reflect:
        T[:3, 0] *= -1.0
    R = T[:3, :3]
    used_as_is = projected_rotation(R) is R  # returned as is, or projected
    assert exact_rotation(T) == used_as_is


@pytest.mark.parametrize("name, base, tip", [("ur5", "base_link", "tool0"), ("iiwa14", "base_link", "ee_link"),
                                              ("stanford_arm", "base_link", "ee_link"),
                                              ("mobile_manipulator", "arm_base", "ee_link")])
def test_pose_rows_equal_the_chain_fk_and_pinocchio(name, base, tip):
    robot = manipkit.load(name)
    chain = robot.chain(base, tip)
    floats, ints = chain.program.row_tables
    Q = chain.sample(50, seed=4)
    states, reached = np.empty((ints[0] + 1, 4, 3)), np.full((50, 4, 4), 7.0)
    present = np.arange(50) % 5 != 3  # rows not present are not written
    pose_rows(Q, present, floats, ints, states, reached)
    assert (reached[~present] == 7.0).all()
    data = robot.model.createData()
    for q, T in zip(Q[present], reached[present]):
        assert np.abs(T - chain.fk(q)).max() < 1e-14
        pin.framesForwardKinematics(robot.model, data, robot.pinocchio_configuration(chain.full(q)))
        expected = np.linalg.inv(data.oMf[robot.frame_id(base)].homogeneous) @ data.oMf[robot.frame_id(tip)].homogeneous
        assert np.abs(T - expected).max() < 1e-12


@settings(max_examples=60, deadline=None)
@given(st.sampled_from([("ur5", "base_link", "tool0"), ("iiwa14", "base_link", "ee_link"),
                        ("mobile_manipulator", "arm_base", "ee_link")]),
       st.integers(0, 2**32 - 1), st.lists(st.tuples(st.integers(0, 3), st.integers(0, 7)), min_size=1, max_size=8))
def test_pose_rows_sharing_first_joints_give_each_rows_pose_alone_bit_for_bit(arm, seed, recipe):
    """Rows made of a few random vectors, each row taking its first ``j`` entries from one (a target's branches
    share their shoulder), some with 0.0 where another has -0.0: the poses of all rows in one call equal, bit for
    bit, those of each row put through alone."""
    name, base, tip = arm
    chain = manipkit.load(name).chain(base, tip)
    floats, ints = chain.program.row_tables
    sources = chain.sample(4, seed=seed)
    sources[3, : chain.n // 2] = 0.0
    Q = np.array([np.concatenate([sources[a, :j], sources[(a + 1) % 4, j:]]) for a, j in recipe])
    Q[1::2][Q[1::2] == 0.0] = -0.0
    states = np.empty((ints[0] + 1, 4, 3))
    together, alone = np.empty((len(Q), 4, 4)), np.empty((len(Q), 4, 4))
    pose_rows(Q, np.ones(len(Q), dtype=bool), floats, ints, states, together)
    for r in range(len(Q)):
        pose_rows(Q[r:r + 1], np.ones(1, dtype=bool), floats, ints, states, alone[r:r + 1])
    assert np.array_equal(together.view(np.int64), alone.view(np.int64))


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(-2, 2), st.sampled_from([0.0, 1e-12, 5e-10, 2e-9, 1e-7, 0.3])), min_size=3,
                max_size=3), st.booleans())
def test_kept_rows_drop_repeats_modulo_two_pi_as_chain_ik_does(offsets, miss_tolerance):
    """kept_rows against the rule written here (chain_ik's: rows equal when every entry's difference, wrapped to
    (-pi, pi], is within 1e-9): a row 2 pi k + e from the first is dropped exactly when it is a repeat; rows come
    out in the stable order of their keys; codes_of reads back the kept rows' codes; a row missing the tolerances
    answers nothing (the general path refines it)."""
    from manipkit.closed_form.check_kernel import codes_of, kept_rows

    base = np.array([0.4, -1.2, 2.5])
    second = base + np.array([2 * np.pi * k + e for k, e in offsets])
    rows = np.array([base, second, base + 1.0])
    residuals = np.zeros((3, 2))
    if miss_tolerance:
        residuals[2, 0] = 1e-6
    valid, within = np.ones(3, dtype=bool), np.array([True, False, True])
    keys = codes = np.array([5, 2, 5])
    block, inside, named = kept_rows(valid, rows, residuals, within, keys, codes, 1e-10, 1e-10)
    if miss_tolerance:
        assert len(block) == 0 and len(inside) == 0
        return
    difference = np.pi - np.mod(np.pi - (second - base), 2 * np.pi)
    repeat = bool(np.all(np.abs(difference) <= 1e-9))
    expected = [1, 0, 2] if not repeat else [0, 2]  # stable by key: code 2 first
    assert block[:, :3].tolist() == rows[expected].tolist() and inside.tolist() == within[expected].tolist()
    assert codes_of(named) == tuple(codes[expected].tolist())


def same_fields(fast, reference):
    assert fast.labels == reference.labels and fast.note == reference.note and fast.count == reference.count
    assert fast.solutions.shape == reference.solutions.shape
    assert np.abs(fast.solutions - reference.solutions).max(initial=0.0) < 1e-9  # the same aliases, not mod 2 pi
    assert fast.within_limits.tolist() == reference.within_limits.tolist()
    assert np.abs(fast.residual_position - reference.residual_position).max(initial=0.0) < 1e-13
    assert np.abs(fast.residual_rotation - reference.residual_rotation).max(initial=0.0) < 1e-13
    assert fast.refined.tolist() == reference.refined.tolist() and fast.solver == reference.solver


@pytest.mark.parametrize("name, base, tip", [("ur5", "base_link", "tool0"),
                                              ("kinova", "base", "j2s6s200_end_effector")])
def test_single_call_equals_the_general_path(name, base, tip):
    """Random poses, elbow straight (q3 = 0: a tangency, handed back) and near it, a joint at its limit alias."""
    robot = manipkit.load(name)
    chain = robot.chain(base, tip)
    family = chain_family(chain)
    Q = chain.sample(60, seed=11)
    Q[0, 2], Q[1, 2] = 0.0, 1e-6
    Q[2, 0] = chain.upper[0] - 1e-3 if np.isfinite(chain.upper[0]) else 3.1
    for q in Q:
        T = chain.fk(q)
        fast = chain_ik(chain, T, family=family)
        same_fields(fast, chain_ik(chain, T, family=family, compiled=False))
        for s in fast.solutions:  # Pinocchio, independent of the compiled FK the residuals come from
            data = robot.model.createData()
            pin.framesForwardKinematics(robot.model, data, robot.pinocchio_configuration(chain.full(s)))
            reached = np.linalg.inv(data.oMf[robot.frame_id(base)].homogeneous) @ data.oMf[robot.frame_id(tip)].homogeneous
            assert np.abs(reached - T).max() < 1e-10


def test_a_target_whose_rotation_is_projected_is_measured_against_its_projection():
    """A rotation block 1e-9 off orthonormal: both paths measure the rows against the projected target."""
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    T = chain.fk(chain.sample(3, seed=2))
    T[:, 0, :3] *= 1.0 + 1e-9
    fast, reference = chain_ik_many(chain, T), chain_ik_many(chain, T, compiled=False)
    assert np.abs(fast.residual_position - reference.residual_position)[~np.isnan(fast.residual_position)].max() < 1e-13
    assert np.abs(fast.residual_rotation - reference.residual_rotation)[~np.isnan(fast.residual_rotation)].max() < 1e-13
    same_fields(chain_ik(chain, T[0]), chain_ik(chain, T[0], compiled=False))


def test_a_target_the_kernel_does_not_take_as_is_is_checked_by_check_transform():
    """The single call takes only targets check_transform accepts as is (plain_target): a list, a transposed
    (Fortran-ordered) copy, a last row 1e-9 off [0 0 0 1] go the general path with the same answer; a matrix that is
    no transform is refused as before."""
    from manipkit.closed_form.check_kernel import plain_target
    from manipkit.errors import InvalidTransformError
    from manipkit.spatial.transforms import check_transform

    chain = manipkit.load("ur5").chain("base_link", "tool0")
    T = chain.fk(chain.sample(1, seed=5)[0])
    fast = chain_ik(chain, T)
    assert plain_target(T) and check_transform(T) is not None
    same_fields(chain_ik(chain, T.tolist()), fast)
    same_fields(chain_ik(chain, np.asfortranarray(T)), fast)
    off = T.copy()
    off[3, 3] += 1e-9
    assert not plain_target(off)
    same_fields(chain_ik(chain, off), chain_ik(chain, off, compiled=False))
    for bad in (np.zeros((4, 4)), np.full((4, 4), np.nan)):
        assert not plain_target(bad)
        with pytest.raises(InvalidTransformError):
            chain_ik(chain, bad)


def test_srs_at_an_arm_angle_equals_the_reference():
    """iiwa14 (7R SRS) at the arm angle of each generating configuration: the compiled solve and check give the
    numpy reference's answer field for field; the generating configuration is among the rows; every row lands on
    its target by Pinocchio. Singular targets (elbow straight: q4 = 0; wrist axes aligned: q6 = 0) and an
    unreachable one are handed back and answered as the reference answers them."""
    from manipkit.closed_form.srs_kernel import solve_check_srs
    from manipkit.ik.chain_ik import srs_arm_angle

    robot = manipkit.load("iiwa14")
    chain = robot.chain("base_link", "ee_link")
    family = chain_family(chain)
    Q = chain.sample(40, seed=21)
    Q[0, 3], Q[1, 5] = 0.0, 0.0
    data = robot.model.createData()
    for index, q in enumerate(Q):
        T = chain.fk(q)
        psi = srs_arm_angle(chain, q, family=family)
        fast = chain_ik(chain, T, family=family, arm_angle=psi)
        same_fields(fast, chain_ik(chain, T, family=family, arm_angle=psi, compiled=False))
        if index >= 2:  # a singular target's rows stand for families (the free joint held at its reference value)
            assert any(np.abs(np.pi - np.mod(np.pi - (s - q), 2 * np.pi)).max() < 1e-7 for s in fast.solutions)
        for s in fast.solutions:
            pin.framesForwardKinematics(robot.model, data, robot.pinocchio_configuration(chain.full(s)))
            assert np.abs(data.oMf[robot.frame_id("ee_link")].homogeneous - T).max() < 1e-10
    from manipkit.ik.ideal_arm import compiled_arm, ideal_arm

    prepared = compiled_arm(chain, ideal_arm(family))
    T = chain.fk(Q[0])
    assert solve_check_srs(prepared, T, srs_arm_angle(chain, Q[0], family=family), (1e-10, 1e-10)) is None  # q4 = 0
    assert solve_check_srs(prepared, chain.fk(Q[2]), srs_arm_angle(chain, Q[2], family=family), (1e-10, 1e-10)) is not None
    far = chain.fk(np.zeros(7))
    far[:3, 3] *= 3.0
    fast, reference = chain_ik(chain, far, family=family, arm_angle=0.3), chain_ik(chain, far, family=family,
                                                                                   arm_angle=0.3, compiled=False)
    assert not fast.success and fast.unmet == reference.unmet and fast.note == reference.note
