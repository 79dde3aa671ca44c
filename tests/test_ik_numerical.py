"""manipkit.ik.numerical: numerical IK checked against forward kinematics.

Independent sources: reachable targets are made by the numpy chain of
``Robot.fk`` at random joint values (so a solution is known to exist), and
every answer is checked with ``Robot.transform`` (Pinocchio) and, for the
rotation, ``rotation_angle_between``: the solver's own residuals are not
trusted. Unreachability is shown without the solver: by a covering grid with
a Lipschitz bound (course arm) or by the reach sphere (iiwa).
"""

import math

import numpy as np
import pytest

from manipkit.errors import InvalidTransformError, JointValueError
from manipkit.ik.numerical import IKOptionError, ik, ik_solver
from manipkit.ik.result import IKResult
from manipkit.spatial.rotations import rot_x, rotation_angle_between


@pytest.fixture(scope="module")
def robots(load_robot):
    return {name: load_robot(name) for name in ("iiwa14", "panda", "ur5", "course_arm")}


def pose_error(robot, base, frame, q, T_base_frame):
    """(distance m, rotation angle rad) between the FK pose of ``frame`` at ``q`` and the target."""
    T = robot.transform(base, frame, q)
    return (
        float(np.linalg.norm(T[:3, 3] - T_base_frame[:3, 3])),
        float(rotation_angle_between(T[:3, :3], T_base_frame[:3, :3])),
    )


def axis_angle_between(u, v):
    return math.atan2(np.linalg.norm(np.cross(u, v)), float(u @ v))


def within_limits(robot, q):
    return not robot.outside_limits(q).any()


def solve_random_reachable(robot, n, *, seed):
    """Targets from FK of random q, solved from random starts; returns results and targets."""
    frame = robot.ee_frame
    targets = robot.fk(robot.sample_q(n, seed=seed), tip=frame)
    starts = robot.sample_q(n, seed=seed + 1)
    results = [ik(robot, T, tip=frame, q0=q0, seed=i) for i, (T, q0) in enumerate(zip(targets, starts))]
    return results, targets, starts


# ----------------------------------------------------------------------
# Reachable poses


def test_iiwa_solves_at_least_99_percent_of_1000_random_reachable_poses_within_1e9(robots):
    robot = robots["iiwa14"]
    results, targets, _ = solve_random_reachable(robot, 1000, seed=100)
    successes = [(r, T) for r, T in zip(results, targets) if r.success]
    assert len(successes) >= 990
    for result, T in successes:
        position, angle = pose_error(robot, robot.root_link, "ee_link", result.q, T)
        assert position < 1e-9 and angle < 1e-9
        assert within_limits(robot, result.q)
    assert all(within_limits(robot, r.q) for r in results)


@pytest.mark.parametrize("name", ["panda", "ur5"])
def test_example_robot_data_arms_solve_random_reachable_poses(robots, name):
    robot = robots[name]
    results, targets, starts = solve_random_reachable(robot, 100, seed=200)
    assert sum(r.success for r in results) >= 99
    chain = set(robot.chain_joints(robot.root_link, robot.ee_frame))
    off_chain = [i for i, joint in enumerate(robot.joint_names) if joint not in chain]  # panda's fingers
    for result, T, q0 in zip(results, targets, starts):
        assert within_limits(robot, result.q)
        assert np.array_equal(result.q[off_chain], q0[off_chain])
        if result.success:
            position, angle = pose_error(robot, robot.root_link, robot.ee_frame, result.q, T)
            assert position < 1e-9 and angle < 1e-9


def test_reported_residuals_are_those_of_the_returned_q(robots):
    robot = robots["iiwa14"]
    results, targets, _ = solve_random_reachable(robot, 20, seed=300)
    for result, T in zip(results, targets):
        position, angle = pose_error(robot, robot.root_link, "ee_link", result.q, T)
        assert result.q_residuals == pytest.approx([position, angle], abs=1e-12)
        if result.success:  # the answer is the first (only) solution, with the same residuals
            assert np.array_equal(result.solutions, [result.q]) and np.array_equal(result.residuals, [result.q_residuals])


def test_success_is_never_claimed_above_the_tolerance(robots):
    # Tiny budgets leave many attempts unfinished: success must follow the measured residuals.
    robot = robots["iiwa14"]
    wanted = robot.sample_q(200, seed=400)
    targets = robot.fk(wanted, tip="ee_link")
    starts = wanted + np.random.default_rng(401).normal(scale=0.1, size=wanted.shape)
    tol = (1e-6, 1e-5)
    outcomes = []
    for i, (T, q0) in enumerate(zip(targets, starts)):
        result = ik(robot, T, q0=q0, tol=tol, max_iters=1 + i % 4, restarts=0)
        position, angle = pose_error(robot, robot.root_link, "ee_link", result.q, T)
        within = position <= tol[0] + 1e-15 and angle <= tol[1] + 1e-15
        assert result.success == within
        assert (result.reason == "") == result.success
        outcomes.append(result.success)
    assert 0 < sum(outcomes) < len(outcomes)  # both cases really occurred


def test_same_seed_gives_the_same_answer(robots):
    robot = robots["panda"]
    T = robot.fk(robot.sample_q(1, seed=500)[0], tip=robot.ee_frame)
    first = ik(robot, T, tip=robot.ee_frame, seed=7)
    again = ik(robot, T, tip=robot.ee_frame, seed=7)
    other = ik(robot, T, tip=robot.ee_frame, seed=8)
    assert np.array_equal(first.q, again.q) and first.iterations == again.iterations
    assert not np.array_equal(first.q, other.q)


# ----------------------------------------------------------------------
# The Jacobian's frame matches the error's frame


@pytest.mark.parametrize(
    "name, mode", [("iiwa14", "pose"), ("course_arm", "pose"), ("course_arm", "position+axis"), ("ur5", "position")]
)
def test_error_derivative_equals_minus_the_jacobian(robots, name, mode):
    # At the target (error 0) the error's derivative is exactly -J for the matching Jacobian;
    # a LOCAL Jacobian against this LOCAL_WORLD_ALIGNED error would miss by O(1).
    robot = robots[name]
    solver = ik_solver(robot, tip=robot.ee_frame, mode=mode)
    for q in robot.sample_q(5, seed=600):
        T = robot.transform(robot.root_link, robot.ee_frame, q)
        goal = solver.goal(T, q)  # the per-call state of a solve
        x = q[solver.columns]
        e0, J, _, _ = solver._evaluate(goal, x)
        assert np.abs(e0).max() < 1e-12
        h = 1e-6
        numeric = np.empty_like(J)
        for k in range(x.size):
            dx = np.zeros(x.size)
            dx[k] = h
            numeric[:, k] = -(solver._evaluate(goal, x + dx)[0] - solver._evaluate(goal, x - dx)[0]) / (2 * h)
        assert np.abs(numeric - J).max() < 1e-7


# ----------------------------------------------------------------------
# Modes on the 5-joint course arm


def test_position_mode_solves_course_arm_positions(robots):
    robot = robots["course_arm"]
    targets = robot.fk(robot.sample_q(100, seed=700), tip="ee_link")
    for i, T in enumerate(targets):
        # Only the translation counts: give the target a rotation no configuration has.
        scrambled = T.copy()
        scrambled[:3, :3] = T[:3, :3] @ rot_x(math.pi / 2)
        result = ik(robot, scrambled, mode="position", seed=i)
        assert result.success and result.q_residuals[1] == 0.0
        assert np.linalg.norm(robot.transform("base_link", "ee_link", result.q)[:3, 3] - T[:3, 3]) < 1e-9


def test_position_mode_accepts_a_translation_vector(robots):
    robot = robots["course_arm"]
    T = robot.fk(robot.sample_q(1, seed=701)[0], tip="ee_link")
    result = ik(robot, T[:3, 3], mode="position")
    assert result.success
    assert np.linalg.norm(robot.transform("base_link", "ee_link", result.q)[:3, 3] - T[:3, 3]) < 1e-9


def test_position_and_axis_mode_solves_course_arm_pointing_targets(robots):
    robot = robots["course_arm"]
    targets = robot.fk(robot.sample_q(100, seed=800), tip="ee_link")
    for i, T in enumerate(targets):
        result = ik(robot, T, mode="position+axis", axis="z", seed=i)
        assert result.success
        T_reached = robot.transform("base_link", "ee_link", result.q)
        assert np.linalg.norm(T_reached[:3, 3] - T[:3, 3]) < 1e-9
        assert axis_angle_between(T_reached[:3, 2], T[:3, 2]) < 1e-9
        assert result.q_residuals[1] == pytest.approx(axis_angle_between(T_reached[:3, 2], T[:3, 2]), abs=1e-12)


def test_position_and_axis_mode_uses_the_named_axis(robots):
    robot = robots["course_arm"]
    T = robot.fk(robot.sample_q(1, seed=801)[0], tip="ee_link")
    result = ik(robot, T, mode="position+axis", axis="x")
    assert result.success
    T_reached = robot.transform("base_link", "ee_link", result.q)
    assert axis_angle_between(T_reached[:3, 0], T[:3, 0]) < 1e-9


def test_course_arm_cannot_reach_its_tool_turned_90_deg_about_its_x_and_reports_the_best_residual(robots):
    robot = robots["course_arm"]
    T_reachable = robot.fk(robot.sample_q(1, seed=5)[0], tip="ee_link")
    T_turned = T_reachable.copy()
    T_turned[:3, :3] = T_reachable[:3, :3] @ rot_x(math.pi / 2)

    # Why unreachable, without the solver. Premises, checked at random q:
    # the wrist point W (top_wrist origin) = p_ee - 0.13522 z_ee and depends on q1..q3 only;
    # the tool's y axis is perpendicular to the z axis of top_wrist at q5 = 0 (= the elbow's z).
    Q = robot.sample_q(50, seed=900)
    T_ee, T_wrist = robot.fk(Q, tip="ee_link"), robot.fk(Q, tip="top_wrist")
    assert np.abs(T_wrist[:, :3, 3] - (T_ee[:, :3, 3] - 0.13522 * T_ee[:, :3, 2])).max() < 1e-12
    Q_wrist_zero = Q.copy()
    Q_wrist_zero[:, 3:] = 0.0
    T_wrist_zero = robot.fk(Q_wrist_zero, tip="top_wrist")
    assert np.abs(T_wrist_zero[:, :3, 3] - T_wrist[:, :3, 3]).max() < 1e-12
    assert np.abs(np.einsum("ni,ni->n", T_ee[:, :3, 1], T_wrist_zero[:, :3, 2])).max() < 1e-12
    # So a pose (p, R) is reachable only if some (q1, q2, q3) puts W at p - 0.13522 z and has
    # z_wrist . y = 0. On a cell-centred grid of spacing d, an exact solution has a grid point
    # within d/2 per joint, where W is within 3 * (d/2) * 0.83 m (0.83 m bounds the path from
    # the first joint to W: |(-0.05166, 0, 0.20271)| + |(0, -0.05194, 0.269)| + 0.13522 + 0.20994)
    # and z_wrist . y within 3 * d/2.
    n = 60
    d = 2 * math.pi / n
    grid = -math.pi + (np.arange(n) + 0.5) * d
    Q_grid = np.zeros((n**3, 5))
    Q_grid[:, :3] = np.stack(np.meshgrid(grid, grid, grid, indexing="ij"), axis=-1).reshape(-1, 3)
    T_grid = robot.fk(Q_grid, tip="top_wrist")

    def worst_case_perpendicularity(T):
        W = T[:3, 3] - 0.13522 * T[:3, 2]
        near = np.linalg.norm(T_grid[:, :3, 3] - W, axis=1) <= 3 * (d / 2) * 0.83
        return float(np.abs(T_grid[near, :3, 2] @ T[:3, 1]).min())

    assert worst_case_perpendicularity(T_turned) > 3 * d / 2  # no exact solution exists
    assert worst_case_perpendicularity(T_reachable) < 3 * d / 2  # the test would see a reachable one

    result = ik(robot, T_turned, restarts=20)
    assert not result.success
    assert result.reason.startswith("did not converge: best residual")
    assert result.solutions.shape == (0, 5) and result.q is None and result.closest is not None and result.unmet == ()
    position, angle = pose_error(robot, "base_link", "ee_link", result.closest, T_turned)
    assert result.closest_residuals == pytest.approx([position, angle], abs=1e-12)
    # The best found is at least as good as 20000 random configurations (same measure as the solver's).
    T_samples = robot.fk(robot.sample_q(20000, seed=901), tip="ee_link")
    sampled = np.hypot(
        np.linalg.norm(T_samples[:, :3, 3] - T_turned[:3, 3], axis=1),
        rotation_angle_between(T_samples[:, :3, :3], T_turned[:3, :3]),
    )
    assert math.hypot(position, angle) <= sampled.min()
    assert math.hypot(position, angle) > 1e-3


def test_target_outside_the_reach_sphere_fails_with_its_distance_to_the_boundary(robots):
    robot = robots["iiwa14"]
    # Straight up: at q = 0 every iiwa link points up, so the farthest point up is the ee at q = 0.
    top = robot.transform("base_link", "ee_link", robot.q())
    T = top.copy()
    T[2, 3] += 0.3
    for mode in ("position", "pose"):
        result = ik(robot, T, mode=mode, restarts=5)
        assert not result.success
        assert result.reason.startswith("target out of reach")
        assert result.closest_residuals[0] == pytest.approx(0.3, abs=1e-6)
        assert within_limits(robot, result.closest)
        # out of the reach bound (joint 2's origin to the flange), so provably unmet, by at least 0.3 m less slack
        assert result.unmet[0][0] == "position" and 0.0 < result.unmet[0][1] <= 0.3 + 1e-9
        assert result.outside_by == result.unmet[0][1] and result.side == "too far"


# ----------------------------------------------------------------------
# Joint space


def test_continuous_joints_are_wrapped_into_minus_pi_pi(robots):
    robot = robots["course_arm"]
    assert all(j.type == "continuous" for j in robot.joints)
    targets = robot.fk(robot.sample_q(30, seed=1000), tip="ee_link")
    for i, T in enumerate(targets):
        q0 = np.full(5, 10.0) + i  # far outside (-pi, pi]
        result = ik(robot, T, q0=q0, mode="position+axis", seed=i)
        assert result.success
        assert np.all(result.q > -math.pi) and np.all(result.q <= math.pi)


def test_all_returns_distinct_solutions_each_valid(robots):
    robot = robots["course_arm"]
    T = robot.fk(robot.sample_q(1, seed=5)[0], tip="ee_link")
    found = ik(robot, T, mode="position+axis", all=True, restarts=60)
    assert isinstance(found, IKResult) and found.success
    assert found.count == len(found.solutions) >= 2  # a 5R arm pointing at a point has several postures
    for q, position, rotation in zip(found.solutions, found.residual_position, found.residual_rotation):
        T_reached = robot.transform("base_link", "ee_link", q)
        assert np.linalg.norm(T_reached[:3, 3] - T[:3, 3]) < 1e-9
        assert axis_angle_between(T_reached[:3, 2], T[:3, 2]) < 1e-9
        assert rotation == pytest.approx(axis_angle_between(T_reached[:3, 2], T[:3, 2]), abs=1e-12)
        assert position == pytest.approx(np.linalg.norm(T_reached[:3, 3] - T[:3, 3]), abs=1e-12)
    for a in range(found.count):
        for b in range(a):
            wrapped = np.angle(np.exp(1j * (found.solutions[a] - found.solutions[b])))
            assert np.abs(wrapped).max() > 1e-6
    single = ik(robot, T, mode="position+axis", restarts=60)
    assert np.array_equal(found.q, single.q) and np.array_equal(found.solutions[0], found.q)


def test_all_without_any_solution_keeps_the_best_failure(robots):
    robot = robots["iiwa14"]
    T = np.eye(4)
    T[0, 3] = 3.0
    found = ik(robot, T, all=True, restarts=3)
    assert found.count == 0 and found.solutions.shape == (0, 7) and found.attempts == 4
    assert not found.success and found.reason.startswith("target out of reach") and found.closest is not None
    assert found.q is None and found.q_residuals is None  # q is a solution or nothing, for every method


def test_base_other_than_root_varies_only_the_chain_joints(robots):
    robot = robots["iiwa14"]
    assert robot.chain_joints("iiwa_link_2", "ee_link") == tuple(f"iiwa_joint_{i}" for i in range(3, 8))
    wanted = robot.sample_q(20, seed=1100)
    starts = robot.sample_q(20, seed=1101)
    for q_wanted, q0 in zip(wanted, starts):
        T_link2_ee = robot.transform("iiwa_link_2", "ee_link", q_wanted)
        result = ik(robot, T_link2_ee, "iiwa_link_2", "ee_link", q0=q0)
        assert result.success
        assert np.array_equal(result.q[:2], q0[:2])  # joints 1 and 2 are above the base: untouched
        position, angle = pose_error(robot, "iiwa_link_2", "ee_link", result.q, T_link2_ee)
        assert position < 1e-9 and angle < 1e-9


def test_q0_is_the_first_start(robots):
    robot = robots["iiwa14"]
    q = robot.sample_q(1, seed=1200)[0]
    T = robot.transform("base_link", "ee_link", q)
    result = ik(robot, T, q0=q)
    assert result.success and result.iterations == 0 and result.attempts == 1
    assert np.array_equal(result.q, q)


# ----------------------------------------------------------------------
# Bad input


def test_unknown_mode_names_the_valid_ones(robots):
    with pytest.raises(IKOptionError, match="unknown IK mode 'orientation'; modes: pose, position, position\\+axis"):
        ik(robots["iiwa14"], np.eye(4), mode="orientation")


def test_unknown_axis_names_the_valid_ones(robots):
    with pytest.raises(IKOptionError, match="axes: x, y, z"):
        ik(robots["course_arm"], np.eye(4), mode="position+axis", axis="w")


def test_target_with_a_reflection_is_rejected(robots):
    T = np.diag([1.0, 1.0, -1.0, 1.0])
    with pytest.raises(InvalidTransformError, match="reflection"):
        ik(robots["iiwa14"], T)


def test_target_of_the_wrong_shape_is_rejected(robots):
    with pytest.raises(InvalidTransformError, match="shape \\(4, 4\\), got shape \\(3, 3\\)"):
        ik(robots["iiwa14"], np.eye(3))


def test_q0_of_the_wrong_length_names_the_joints(robots):
    with pytest.raises(JointValueError, match="needs 7 joint values \\(iiwa_joint_1"):
        ik(robots["iiwa14"], robots["iiwa14"].transform("base_link", "ee_link"), q0=np.zeros(6))


def test_non_positive_tolerance_is_rejected(robots):
    with pytest.raises(IKOptionError, match="tol must be a positive number"):
        ik(robots["iiwa14"], np.eye(4), tol=0.0)


# --------------------------------------------------------------------------
# The one result type: numerical answers have the fields of every IK answer


def test_all_solutions_are_one_result_with_the_shared_fields(robots):
    robot = robots["iiwa14"]
    T = robot.transform("base_link", "ee_link", robot.sample_q(1, seed=41)[0])
    found = ik(robot, T, all=True, restarts=5)
    assert found.success and found.count == found.solutions.shape[0] > 0 and found.reason == ""
    assert found.labels == ("",) * found.count and found.joint_names == robot.joint_names
    assert found.solutions.shape == (found.count, 7) and not found.solutions.flags.writeable
    assert np.array_equal(found.solutions[0], found.q)
    assert found.residuals.shape == (found.count, 2) and np.all(found.residuals <= 1e-10)
    assert found.mode == "spatial pose (x, y, z, R)" and found.solver == "ik.numerical" and found.attempts == 6
    for q, residuals in zip(found.solutions, found.residuals):  # each row's residuals are those of its FK
        assert residuals == pytest.approx(pose_error(robot, robot.root_link, "ee_link", q, T), abs=1e-12)


def test_a_single_answer_and_a_miss_are_results_like_any_other(robots):
    robot = robots["iiwa14"]
    T = robot.transform("base_link", "ee_link", robot.sample_q(1, seed=42)[0])
    single = ik(robot, T)
    assert single.count == 1 and single.success and single.labels == ("",) and single.closest is None
    far = np.eye(4)
    far[0, 3] = 5.0
    missed = ik(robot, far, restarts=2)
    assert missed.count == 0 and not missed.success and missed.solutions.shape == (0, 7)
    assert missed.reason.startswith("target out of reach") and missed.residuals.shape == (0, 2)
    assert missed.attempts == 3 and missed.note == missed.reason
    assert missed.closest_residuals == pytest.approx(pose_error(robot, robot.root_link, "ee_link", missed.closest, far),
                                                      abs=1e-12)


def test_the_0_1_frame_keyword_is_gone(robots):
    robot = robots["iiwa14"]
    q = robot.sample_q(1, seed=44)[0]
    T = robot.transform("iiwa_link_2", "iiwa_link_6", q)
    for call in (lambda: ik(robot, T, base="iiwa_link_2", frame="iiwa_link_6", q0=q),
                 lambda: ik_solver(robot, frame="iiwa_link_6")):
        with pytest.raises(TypeError, match="frame"):
            call()
    result = ik(robot, T, "iiwa_link_2", "iiwa_link_6", q0=q)
    assert result.success
    assert np.abs(robot.transform("iiwa_link_2", "iiwa_link_6", result.q) - T).max() < 1e-9


def test_two_threads_solving_on_one_robot_get_their_own_answers(robots):
    # Both threads share the robot and its cached solver; each must get the answer to its own target, every time.
    import sys
    import threading

    robot = robots["iiwa14"]
    Q_true = robot.sample_q(2 * 60, seed=45)
    Q_start = robot.sample_q(2 * 60, seed=46)
    targets = robot.fk(Q_true, tip="ee_link")
    answers: dict[int, object] = {}
    errors = []
    barrier = threading.Barrier(2)

    def work(offset):
        try:
            barrier.wait()
            for i in range(offset, len(targets), 2):
                answers[i] = ik(robot, targets[i], q0=Q_start[i], seed=i)
        except Exception as error:  # a failure in a thread is reported by the test, not lost
            errors.append(error)

    threads = [threading.Thread(target=work, args=(k,)) for k in (0, 1)]
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # switch threads as often as the interpreter can: interleave inside every solve
    try:
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    finally:
        sys.setswitchinterval(interval)
    assert errors == [] and len(answers) == len(targets)
    for i, result in answers.items():
        position, angle = pose_error(robot, robot.root_link, "ee_link", result.q, targets[i])
        assert result.q_residuals == pytest.approx([position, angle], abs=1e-12)
        assert result.success and position < 1e-9 and angle < 1e-9
        alone = ik(robot, targets[i], q0=Q_start[i], seed=i)  # the same call, on its own
        assert np.array_equal(alone.q, result.q) and alone.iterations == result.iterations


def test_target_slightly_off_rigid_within_the_tolerance_is_accepted(robots):
    robot = robots["iiwa14"]
    T = robot.transform("base_link", "ee_link", robot.sample_q(1, seed=43)[0])
    T[:3, :3] *= 1.0 + 2e-7  # norms 1 + 2e-7, det 1 + 6e-7: inside check_transform's 1e-6, past the quick test
    assert ik(robot, T, tol=1e-5).success
    T[:3, :3] *= 1.0 + 4e-6
    with pytest.raises(InvalidTransformError, match="IK target: rotation column 0 \\(x axis\\) has norm"):
        ik(robot, T)


def test_a_near_miss_is_called_close_and_a_larger_tol_accepts_it(robots):
    # Issue 14, finding 8: the course arm's pose A as tf-between prints it (6 decimals). Five joints cannot meet a
    # rounded 6D pose exactly; the failure says it is close (not "may be unreachable"), and tol 1e-6 accepts it.
    from reference import POSE_A, matrix_from_rpy

    T = np.eye(4)
    T[:3, :3] = matrix_from_rpy(-2.416032, 0.329921, -0.272644)
    T[:3, 3] = [-0.007121, 0.070759, 0.017976]
    robot = robots["course_arm"]
    failed = ik(robot, T, restarts=5)
    assert not failed.success and "that is close" in failed.reason and "may be unreachable" not in failed.reason
    assert failed.closest_residuals.max() < 1e-6
    accepted = ik(robot, T, tol=1e-6, restarts=5)
    assert accepted.success and np.abs(accepted.q - POSE_A).max() < 1e-5
    position, angle = pose_error(robot, "base_link", "ee_link", accepted.q, T)
    assert position <= 1e-6 and angle <= 1e-6


def test_html_repr_shows_the_answer_or_the_closest_failed_attempt(robots):
    import xml.etree.ElementTree as ET

    robot = robots["iiwa14"]
    T = robot.transform("base_link", "ee_link", robot.sample_q(1, seed=3)[0])
    far = np.eye(4)
    far[0, 3] = 5.0  # 5 m away: beyond the iiwa's reach
    for result, index, label, success in ((ik(robot, T), "1", "", "True"),
                                          (ik(robot, T, all=True, restarts=2), "1", "", "True"),
                                          (ik(robot, far, restarts=1), "-", "closest found (fails)", "False")):
        root = ET.fromstring(f"<div>{result._repr_html_()}</div>")
        rows = [[cell.text or "" for cell in row] for row in root.find("table").findall("tr")]
        assert rows[0] == ["#", "label", *robot.joint_names, "position (m)", "rotation (rad)", "success"]
        assert rows[1][:2] == [index, label] and rows[1][-1] == success
        assert f"success: {success}" in root.find("table/caption").text
        assert "numerical IK (ik.numerical)" in root.find("table/caption").text
        shown = result.q if result.success else result.closest  # a failure shows the closest configuration
        residuals = result.q_residuals if result.success else result.closest_residuals
        np.testing.assert_allclose([float(v) for v in rows[1][2:9]], shown, rtol=1e-5, atol=1e-6)
        assert float(rows[1][9]) == pytest.approx(residuals[0], rel=1e-2, abs=1e-300)
        if success == "False":
            assert root.find("p").text == result.reason
