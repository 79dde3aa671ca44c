"""manipkit.ik.numerical_many: batched IK, every answer checked by Pinocchio.

Independent sources: reachable targets come from FK of random in-limit
configurations (a solution exists); every answer is re-measured with
``Robot.transform`` (Pinocchio, not the batched kernel ik_many itself uses)
and ``spatial.rotations.rotation_angle_between``. Unreachable targets are
beyond the reach sphere (the arm's link lengths summed).
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from manipkit.errors import IKOptionError, InvalidTransformError, JointValueError, UnknownFrameError
from manipkit.ik.numerical_many import MIN_TARGETS_PER_THREAD, _blocks, _on_threads, ik_many, target_seeds
from manipkit.spatial.rotations import rot_z, rotation_angle_between


def pinocchio_residuals(robot, base, frame, Q, T):
    """(position m, rotation rad) per row, measured by Pinocchio's transform."""
    out = []
    for q, target in zip(Q, T):
        reached = robot.transform(base, frame, q)
        out.append((np.linalg.norm(reached[:3, 3] - target[:3, 3]), rotation_angle_between(reached[:3, :3], target[:3, :3])))
    return np.array(out).reshape(-1, 2)


def test_reachable_targets_are_solved_and_pinocchio_agrees(iiwa14):
    Q_true = iiwa14.sample_q(200, seed=4)
    T = iiwa14.fk(Q_true, base="base_link", tip="ee_link")
    batch = ik_many(iiwa14, T)
    assert batch.success.all()
    measured = pinocchio_residuals(iiwa14, "base_link", "ee_link", batch.q, T)
    assert measured.max() < 1e-9
    np.testing.assert_allclose(batch.q_residuals, measured, atol=1e-12)
    # every target solved: its one slot holds the answer, with the same residuals
    assert batch.solutions.shape == (200, 1, 7) and np.array_equal(batch.solutions[:, 0], batch.q)
    np.testing.assert_allclose(batch.residuals[:, 0], measured, atol=1e-12)
    assert (batch.count == 1.0).all() and batch.labels == ("",) and batch.mode == "spatial pose (x, y, z, R)"
    assert not iiwa14.outside_limits(batch.q).any()


def test_unreachable_targets_fail_with_their_fk_residuals(iiwa14):
    # iiwa14: the links from joint 1 to the flange add up to about 1.3 m; 3 m away is out of reach
    T = iiwa14.fk(iiwa14.sample_q(5, seed=1), base="base_link", tip="ee_link")
    T[:, 0, 3] += 3.0
    batch = ik_many(iiwa14, T, restarts=2)
    assert not batch.success.any()
    assert (batch.q_residuals[:, 0] > 1.0).all()
    np.testing.assert_allclose(batch.q_residuals, pinocchio_residuals(iiwa14, "base_link", "ee_link", batch.q, T), atol=1e-12)
    # no solution: the slot is empty (NaN), q is the closest configuration found
    assert np.isnan(batch.solutions).all() and np.isnan(batch.residuals).all() and (batch.count == 0.0).all()
    assert (batch.attempts == 3).all()


def test_a_target_gets_the_same_answer_in_a_larger_batch(iiwa14):
    T = iiwa14.fk(iiwa14.sample_q(20, seed=8), base="base_link", tip="ee_link")
    small, large = ik_many(iiwa14, T[:7], seed=5), ik_many(iiwa14, T, seed=5)
    np.testing.assert_array_equal(small.q, large.q[:7])
    assert not np.array_equal(ik_many(iiwa14, T[:7], seed=6).q, small.q)


def test_seed_per_target_is_the_same_in_any_batch():
    np.testing.assert_array_equal(target_seeds(9, 5, first=10), target_seeds(9, 20)[10:15])
    assert len(set(target_seeds(9, 1000).tolist())) == 1000


def test_start_at_the_answer_takes_one_attempt_and_no_iteration(course_arm):
    Q_true = course_arm.sample_q(30, seed=3)
    T = course_arm.fk(Q_true, base="base_link", tip="ee_link")
    batch = ik_many(course_arm, T, q0=Q_true)
    assert batch.success.all() and (batch.attempts == 1).all() and (batch.iterations == 0).all()
    np.testing.assert_allclose(batch.q, Q_true, atol=1e-12)


def test_one_start_vector_serves_every_target(course_arm):
    T = course_arm.fk(course_arm.sample_q(10, seed=6), base="base_link", tip="ee_link")
    batch = ik_many(course_arm, T, q0=course_arm.q())
    assert batch.success.all()
    assert pinocchio_residuals(course_arm, "base_link", "ee_link", batch.q, T).max() < 1e-9


def test_time_budget_stops_the_restarts(iiwa14):
    T = np.tile(np.eye(4), (3, 1, 1))
    T[:, 0, 3] = 5.0  # out of reach: every restart fails, only the budget ends the search
    batch = ik_many(iiwa14, T, restarts=10**5, time_budget=0.002)  # 1e5 restarts: seconds of work without the budget
    assert (batch.attempts >= 1).all() and (batch.attempts < 10**5).all()
    assert not batch.success.any()


def test_off_chain_joints_keep_their_start_and_a_base_below_the_root(load_robot):
    robot = load_robot("mobile_manipulator")
    # arm_base is below arm_base_joint: T_arm_base_ee depends on the four joints after it only
    Q_true = robot.sample_q(20, seed=2)
    T = robot.fk(Q_true, base="arm_base", tip="ee_link")
    Q0 = robot.sample_q(20, seed=3)
    batch = ik_many(robot, T, "arm_base", "ee_link", q0=Q0)
    assert batch.success.all()
    assert pinocchio_residuals(robot, "arm_base", "ee_link", batch.q, T).max() < 1e-9
    off_chain = [robot.joint_names.index(n) for n in ("arm_base_joint", "left_wheel_joint", "right_wheel_joint")]
    np.testing.assert_array_equal(batch.q[:, off_chain], Q0[:, off_chain])


def test_position_mode_takes_points_and_ignores_rotation(iiwa14):
    points = iiwa14.fk(iiwa14.sample_q(10, seed=5), base="base_link", tip="ee_link")[:, :3, 3]
    batch = ik_many(iiwa14, points, mode="position")
    assert batch.success.all() and (batch.residual_rotation == 0.0).all() and (batch.q_residuals[:, 1] == 0.0).all()
    reached = np.array([iiwa14.transform("base_link", "ee_link", q)[:3, 3] for q in batch.q])
    assert np.abs(reached - points).max() < 1e-9


def test_position_axis_mode_matches_the_axis(course_arm):
    T = course_arm.fk(course_arm.sample_q(10, seed=7), base="base_link", tip="ee_link")
    T[:, :3, :3] = T[:, :3, :3] @ rot_z(0.7)  # spin about z: the pointing axis stays, the pose changes
    batch = ik_many(course_arm, T, mode="position+axis", axis="z")
    assert batch.success.all()
    for q, target in zip(batch.q, T):
        reached = course_arm.transform("base_link", "ee_link", q)
        assert np.linalg.norm(reached[:3, 3] - target[:3, 3]) < 1e-9
        assert math.atan2(np.linalg.norm(np.cross(reached[:3, 2], target[:3, 2])), reached[:3, 2] @ target[:3, 2]) < 1e-9


def test_no_targets_is_an_empty_answer(iiwa14):
    batch = ik_many(iiwa14, np.zeros((0, 4, 4)))
    assert batch.q.shape == (0, 7) and len(batch) == 0


@pytest.mark.parametrize(
    ("T", "message"),
    [
        (np.eye(4), "shape"),
        (np.zeros((2, 4, 4)), "IK target 0: last row"),
        (np.stack([np.eye(4), np.diag([1.0, 1.0, -1.0, 1.0])]), "IK target 1"),
        (np.stack([np.eye(4), np.full((4, 4), np.nan)]), "IK target 1: entries must be finite"),
    ],
)
def test_bad_targets_name_the_first_bad_one(iiwa14, T, message):
    with pytest.raises(InvalidTransformError, match=message):
        ik_many(iiwa14, T)


def test_bad_start_and_options_are_user_errors(iiwa14):
    T = np.tile(np.eye(4), (2, 1, 1))
    with pytest.raises(JointValueError, match="per target"):
        ik_many(iiwa14, T, q0=np.zeros((3, 7)))
    with pytest.raises(JointValueError, match="finite"):
        ik_many(iiwa14, T, q0=np.full(7, np.inf))
    with pytest.raises(IKOptionError, match="time_budget"):
        ik_many(iiwa14, T, time_budget=-1.0)
    with pytest.raises(IKOptionError, match="restarts"):
        ik_many(iiwa14, T, restarts=-1)


@settings(max_examples=15, deadline=None)
@given(st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3), st.floats(-math.pi, math.pi))
def test_success_always_means_fk_within_tolerance(planar_3r_robot, xy_yaw, yaw):
    # Any point and angle in the plane, reachable or not: success must be confirmed by Pinocchio.
    T = np.eye(4)
    T[:3, :3] = rot_z(yaw)
    T[:2, 3] = np.array(xy_yaw[:2]) * 4.0
    batch = ik_many(planar_3r_robot, T[None], restarts=3, tol=1e-9)
    measured = pinocchio_residuals(planar_3r_robot, "base_link", "ee_link", batch.q, T[None])[0]
    assert batch.success[0] == bool(measured.max() <= 1e-9)


@pytest.fixture(scope="module")
def planar_3r_robot(load_robot):
    return load_robot("planar_3r")


def test_a_base_link_offset_from_the_root_is_taken_into_account(load_robot):
    # mobile_manipulator's base_link sits 0.05 m above its root base_footprint: targets are T_base_link_ee
    robot = load_robot("mobile_manipulator")
    Q_true = robot.sample_q(20, seed=5)
    T = robot.fk(Q_true, base="base_link", tip="ee_link")
    batch = ik_many(robot, T, base="base_link", tip="ee_link")
    assert batch.success.all()
    assert pinocchio_residuals(robot, "base_link", "ee_link", batch.q, T).max() < 1e-9


def test_targets_are_checked_as_ik_checks_them(iiwa14):
    # the same check_transform as ik: a column off by 7e-7 is accepted (within 1e-6), one off by 1 % is named
    T = iiwa14.transform("base_link", "ee_link", iiwa14.sample_q(1, seed=2)[0])
    nearly = T.copy()
    nearly[:3, 0] *= 1 + 0.7e-6
    ik_many(iiwa14, np.stack([T, nearly]), restarts=0)
    bad = T.copy()
    bad[:3, 0] *= 1.01
    with pytest.raises(InvalidTransformError, match="IK target 1: rotation column 0 \\(x axis\\) has norm 1.01"):
        ik_many(iiwa14, np.stack([T, bad]))


def test_the_0_1_positional_start_and_frame_keyword_are_gone(course_arm):
    Q_true = course_arm.sample_q(5, seed=9)
    T = course_arm.fk(Q_true, base="base_link", tip="ee_link")
    with pytest.raises(TypeError, match="frame"):
        ik_many(course_arm, T, frame="ee_link", q0=Q_true)
    with pytest.raises(UnknownFrameError):  # a start as the third argument is a base frame now, and not a name
        ik_many(course_arm, T, Q_true)
    batch = ik_many(course_arm, T, q0=Q_true)
    assert batch.success.all() and (batch.attempts == 1).all()
    assert np.abs(course_arm.fk(batch.q, base="base_link", tip="ee_link") - T).max() < 1e-9


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 10**6), st.integers(2 * MIN_TARGETS_PER_THREAD, 400),
       st.sampled_from([None, "near"]))
def test_answers_are_the_same_bit_for_bit_on_any_number_of_threads(iiwa14, seed, target_seed, n, start):
    # FK of random configurations (reachable) and a tenth of them moved 3 m away (unreachable: every restart runs)
    Q_true = iiwa14.sample_q(n, seed=target_seed)
    T = iiwa14.fk(Q_true, base="base_link", tip="ee_link")
    T[::10, 0, 3] += 3.0
    q0 = None if start is None else Q_true + 0.3  # clamped into the limits by ik_many
    options = dict(q0=q0, seed=seed, restarts=3)
    one, two, three = (ik_many(iiwa14, T, threads=k, **options) for k in (1, 2, 3))
    for other in (two, three):
        for field in ("q", "q_residuals", "iterations", "attempts", "success"):
            np.testing.assert_array_equal(getattr(one, field), getattr(other, field), err_msg=field)
    # and every success is one by Pinocchio's FK, not by the kernel's word
    measured = pinocchio_residuals(iiwa14, "base_link", "ee_link", one.q[one.success], T[one.success])
    assert one.success.mean() > 0.8 and not one.success[::10].any() and measured.max() < 1e-9


def test_blocks_cover_every_target_once_and_small_batches_stay_on_one_thread():
    for n, threads in [(0, 2), (1, 4), (2 * MIN_TARGETS_PER_THREAD - 1, 2), (2 * MIN_TARGETS_PER_THREAD, 2),
                       (1000, 3), (20_000, 8)]:
        used, blocks = _blocks(n, threads)
        covered = np.concatenate([np.arange(a, b) for a, b in blocks]) if blocks else np.zeros(0)
        assert np.array_equal(covered, np.arange(n)) and all(b > a for a, b in blocks if n)
        assert used == max(1, min(threads, n // MIN_TARGETS_PER_THREAD))
    assert _blocks(2 * MIN_TARGETS_PER_THREAD - 1, 8)[0] == 1  # no thread started for a small batch


def test_threads_run_every_block_once_and_raise_a_block_error_in_the_caller():
    import threading
    import time

    seen, names = [], set()

    def record(a, b):
        seen.append((a, b))
        names.add(threading.current_thread().name)
        time.sleep(0.002)  # a block takes a while (and lets go of the GIL), as a solve does: both threads take blocks

    _on_threads(record, 7, 5007, 2)
    assert sorted(seen) == [(a + 7, b + 7) for a, b in _blocks(5000, 2)[1]] and len(names) == 2

    def fail(a, b):
        if a > 0:
            raise ValueError(f"block {a}")

    with pytest.raises(ValueError, match="block"):
        _on_threads(fail, 0, 5000, 2)


@pytest.mark.parametrize("threads", [0, -1, 1.5, True, "2"])
def test_bad_thread_counts_are_refused(course_arm, threads):
    T = course_arm.fk(course_arm.sample_q(2, seed=1), base="base_link", tip="ee_link")
    with pytest.raises(IKOptionError, match="threads must be a whole number"):
        ik_many(course_arm, T, threads=threads)
