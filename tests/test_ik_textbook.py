"""analytic_ik: the bundled textbook arms bound to their closed-form solvers, checked through the URDF.

Every solution is put through Pinocchio's FK of the robot (an independent
model: the URDF, not the DH table the solvers use) in these tests too.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import manipkit
from manipkit.errors import IKOptionError, InvalidTransformError, ManipkitError
from manipkit.ik.numerical import ik
from manipkit.ik.result import IKResult
from manipkit.ik.textbook import ANALYTIC_SOLVERS, analytic_ik, analytic_ik_many


@pytest.fixture(scope="module")
def arms():
    return {name: manipkit.load(name) for name in ANALYTIC_SOLVERS}


@pytest.mark.parametrize(
    "name, q, count",
    [
        ("planar_2r", [0.3, 0.5], 1),  # a pose: only the elbow whose q1 + q2 is the target's angle
        ("planar_3r", [0.3, 0.5, -0.4], 2),
        ("scara", [0.3, 1.2, 0.1, -0.5], 2),
        ("stanford_arm", [0.4, 0.8, 0.6, 0.3, 1.0, -0.2], 4),
        ("elbow_arm", [0.5, 0.4, -1.0, 0.3, 0.9, 0.2], 8),
    ],
)
def test_every_solution_reaches_the_target_through_the_urdf(arms, name, q, count):
    robot = arms[name]
    T = robot.transform("base_link", "ee_link", q)
    result = analytic_ik(robot, T)
    assert isinstance(result, IKResult) and result.success
    assert result.count == count == len(result.labels) and result.solutions.shape == (count, len(q))
    assert result.joint_names == robot.joint_names and result.solver.split(".")[0] in ("planar", "decoupled")
    for row, position, rotation in zip(result.solutions, result.residual_position, result.residual_rotation):
        reached = robot.transform("base_link", "ee_link", row)
        assert abs(np.linalg.norm(reached[:3, 3] - T[:3, 3]) - position) < 1e-12
        assert position <= 1e-9 and rotation <= 1e-9
    assert np.allclose(result.residuals, np.column_stack([result.residual_position, result.residual_rotation]))
    assert min(np.abs(np.angle(np.exp(1j * (result.solutions - q)))).max(axis=1)) < 1e-7  # q is among them


def test_a_wrist_singular_pose_is_a_family_named_by_its_free_joint(arms):
    robot = arms["stanford_arm"]
    T = robot.transform("base_link", "ee_link", [0.4, 0.8, 0.6, 0.3, 0.0, -0.2])
    result = analytic_ik(robot, T)
    assert result.count == math.inf and result.free_parameter == "theta4" and result.success
    assert all("wrist singular" in label for label in result.labels[:1])


def test_unreachable_target_says_why(arms):
    robot = arms["planar_2r"]
    T = np.eye(4)
    T[0, 3] = 5.0
    result = analytic_ik(robot, T)
    assert not result.success and result.count == 0 and result.solutions.shape == (0, 2)
    assert result.reason == "no solution: target too far: r = 5 > l1 + l2 = 2, outside by 3"


def test_robot_without_a_closed_form_is_an_option_error():
    with pytest.raises(IKOptionError, match="no closed-form solver for robot 'iiwa14'"):
        analytic_ik(manipkit.load("iiwa14"), np.eye(4))


def test_target_is_checked_as_a_transform(arms):
    with pytest.raises(InvalidTransformError, match="IK target: det\\(R\\) = -1"):
        analytic_ik(arms["elbow_arm"], np.diag([1.0, 1.0, -1.0, 1.0]))


def test_closed_form_and_numerical_answers_print_alike(arms):
    # The properties a presenter reads exist on both result types, with the same shapes.
    robot = arms["elbow_arm"]
    T = robot.transform("base_link", "ee_link", [0.5, 0.4, -1.0, 0.3, 0.9, 0.2])
    for result in (analytic_ik(robot, T), ik(robot, T, all=True, restarts=3), ik(robot, T)):
        k = len(result.labels)
        assert result.success and result.count >= k > 0 and isinstance(result.reason, str)
        assert result.solutions.shape == (k, 6) and result.residuals.shape == (k, 2)
        assert result.residual_position.shape == result.residual_rotation.shape == (k,)


def test_tol_takes_position_and_rotation_apart(arms):
    robot = arms["planar_2r"]
    T = robot.transform("base_link", "ee_link", [0.3, 0.5])
    T[2, 3] = 1e-7  # just off the plane z = 0
    strict = analytic_ik(robot, T, mode="position")
    assert not strict.success and strict.unmet == (("z", pytest.approx(1e-7, abs=1e-15)),)
    loose = analytic_ik(robot, T, mode="position", tol=(1e-6, 1e-9))
    assert loose.success and loose.count == 2 and np.all(loose.residual_position <= 1e-6)
    for row in loose.solutions:  # through the URDF: only the height is off
        assert np.linalg.norm(robot.transform("base_link", "ee_link", row)[:3, 3] - T[:3, 3]) == pytest.approx(1e-7, abs=1e-12)
    with pytest.raises(IKOptionError, match="tol must be a positive number"):
        analytic_ik(robot, T, tol=(1e-6, 0.0))


def test_members_through_the_robot_are_checked_by_its_urdf(arms):
    robot = arms["planar_3r"]
    T = robot.transform("base_link", "ee_link", [0.3, 0.5, -0.4])
    result = analytic_ik(robot, T, mode="position")
    assert result.count == math.inf and result.free_parameter == "phi" and result.joint_names == robot.joint_names
    members = result.members([0.2, 0.3 + 0.5 - 0.4])  # the second is the angle of the q the target came from
    assert members.mode == "planar position (x, y)" and members.count == len(members.labels) >= 2
    for row in members.solutions:
        assert np.linalg.norm(robot.transform("base_link", "ee_link", row)[:3, 3] - T[:3, 3]) <= 1e-9
    assert min(np.abs(np.angle(np.exp(1j * (members.solutions - [0.3, 0.5, -0.4])))).max(axis=1)) < 1e-9


def test_a_planar_2r_pose_takes_the_users_tolerance(load_robot):
    # the tool angle is off by 1e-6 rad: outside the default 1e-9, inside 1e-3 (confirmed by FK of the answer)
    from manipkit.spatial.rotations import rot_z

    robot = load_robot("planar_2r")
    T = robot.transform("base_link", "ee_link", [0.3, 0.4])
    T[:3, :3] = T[:3, :3] @ rot_z(1e-6)
    assert analytic_ik(robot, T, mode="pose").count == 0
    loose = analytic_ik(robot, T, mode="pose", tol=1e-3)
    assert loose.count == 1
    np.testing.assert_allclose(robot.transform("base_link", "ee_link", loose.solutions[0])[:3, 3], T[:3, 3], atol=1e-9)


@pytest.mark.parametrize("values", [["x"], [[1.0, 2.0], [3.0, 4.0]], [float("nan")]])
def test_scara_family_members_refuse_bad_values_in_one_line(load_robot, values):
    robot = load_robot("scara")
    family = analytic_ik(robot, robot.transform("base_link", "ee_link", robot.sample_q(1, seed=1)[0]), mode="position")
    with pytest.raises(ManipkitError) as info:
        family.members(values)
    assert "theta4 values" in str(info.value) and "\n" not in str(info.value)


def test_analytic_ik_takes_its_frames_base_first_and_refuses_others(arms):
    robot = arms["planar_2r"]
    T = robot.transform("base_link", "ee_link", [0.3, 0.5])
    named = analytic_ik(robot, T, "base_link", "ee_link", mode="position")
    assert np.array_equal(named.solutions, analytic_ik(robot, T, mode="position").solutions) and named.success
    with pytest.raises(IKOptionError, match="solves base_link -> ee_link, not base_link -> link1"):
        analytic_ik(robot, T, "base_link", "link1")


def test_a_repeated_call_is_answered_for_its_own_arguments():
    """analytic_ik keeps what it found for a robot, frames and options (the chain, its family, the parsed tol): each
    call is answered for its own arguments, the same as the first call with them."""
    from manipkit.ik.chain_ik import chain_ik

    robot = manipkit.load("ur5")
    q = [0.3, -1.1, 1.2, -0.8, 1.0, 0.4]
    T = robot.chain("base_link", "tool0").fk(q)
    first = analytic_ik(robot, T, "base_link", "tool0")
    tight = analytic_ik(robot, T, "base_link", "tool0", tol=1e-300)  # no FK lands that close: every row dropped
    wrist = analytic_ik(robot, T, "base_link", "wrist_3_link")  # tool0's target asked of wrist_3_link: other rows
    again = analytic_ik(robot, T, "base_link", "tool0")
    assert first.count == 8 and tight.count == 0 and "dropped" in tight.note and wrist.success
    for a, b in ((first, again), (first, chain_ik(robot.chain("base_link", "tool0"), T))):
        assert a.labels == b.labels and a.note == b.note and np.array_equal(a.solutions, b.solutions)
        assert np.array_equal(a.residual_position, b.residual_position) and np.array_equal(a.within_limits, b.within_limits)
    for row in wrist.solutions:  # the other tip's rows put the other tip on the target (Pinocchio, through the URDF)
        assert np.abs(robot.transform("base_link", "wrist_3_link", row, check_limits=False) - T).max() < 1e-10
        assert np.abs(robot.transform("base_link", "tool0", row, check_limits=False) - T).max() > 1e-3
    with pytest.raises(InvalidTransformError, match="IK target: det\\(R\\) = -1"):  # checked on every call
        analytic_ik(robot, np.diag([1.0, 1.0, -1.0, 1.0]), "base_link", "tool0")
    with pytest.raises(ManipkitError, match="frame"):
        analytic_ik(robot, T, "base_link", "tool_zero")
    listed = analytic_ik(robot, T.tolist(), "base_link", "tool0")  # a list: checked, then solved the same
    assert listed.labels == first.labels and np.allclose(listed.solutions, first.solutions, atol=1e-12, rtol=0.0)


def test_a_chain_below_the_first_joint_answers_in_whole_robot_rows():
    """iiwa14 from iiwa_link_1 to ee_link: six of its seven joints (a spherical wrist and two intersecting axes).
    Rows are whole-robot vectors: joint 1 at its default, the chain's columns from chain_ik; at q6 = 0 (axes 5 and
    7 aligned) the free joint is named by its whole-robot column."""
    from manipkit.ik.chain_ik import chain_ik

    robot = manipkit.load("iiwa14")
    chain = robot.chain("iiwa_link_1", "ee_link")
    assert len(chain.joint_names) == 6 and chain.columns.tolist() == [1, 2, 3, 4, 5, 6]
    for q in ([0.4, -0.3, 1.1, 0.5, 0.7, 0.2], [0.4, -0.3, 1.1, 0.5, 0.0, 0.2]):
        T = chain.fk(q)
        for _ in range(2):  # the first call and the kept plan's
            result = analytic_ik(robot, T, "iiwa_link_1", "ee_link")
            on_chain = chain_ik(chain, T)
            assert result.joint_names == robot.joint_names and result.solutions.shape == (len(on_chain.solutions), 7)
            assert np.array_equal(result.solutions[:, 1:], on_chain.solutions)
            assert np.all(result.solutions[:, 0] == robot.q()[0]) and not result.solutions.flags.writeable
            assert result.free_joints == tuple(int(chain.columns[f]) for f in on_chain.free_joints)
            assert result.labels == on_chain.labels and result.note == on_chain.note
            for row in result.solutions:
                assert np.abs(robot.transform("iiwa_link_1", "ee_link", row, check_limits=False) - T).max() < 1e-10
    assert result.free_joints and math.isinf(result.count)  # the singular target: a family in whole-robot columns


def test_threads_sharing_a_robot_get_the_answers_of_one_thread():
    """The plans and solvers analytic_ik keeps are shared by threads (a robot may be): four threads solving the same
    targets at once give, target by target, the answer one thread gives."""
    from concurrent.futures import ThreadPoolExecutor

    robot = manipkit.load("ur5")
    chain = robot.chain("base_link", "tool0")
    T = chain.fk(chain.sample(40, seed=8))
    alone = [analytic_ik(robot, t, "base_link", "tool0") for t in T]
    with ThreadPoolExecutor(4) as pool:
        shared = list(pool.map(lambda t: analytic_ik(robot, t, "base_link", "tool0", tol=(1e-9, 1e-9)), list(T) * 4))
    for i, answer in enumerate(shared):
        expected = alone[i % len(T)]
        assert answer.labels == expected.labels and answer.note == expected.note
        assert np.array_equal(answer.solutions, expected.solutions)
        assert np.array_equal(answer.residual_rotation, expected.residual_rotation)


def test_analytic_ik_many_gives_chain_ik_many_for_the_named_frames_and_the_iiwa14_at_its_arm_angles():
    """analytic_ik_many is chain_ik_many on robot.chain(base, tip): the same arrays for ur5 (base_link -> tool0) and
    for the iiwa14 with one arm angle per pose; every present slot lands by Pinocchio (robot.transform)."""
    from manipkit.ik.chain_ik import chain_ik_many, srs_arm_angle

    for name, tip in (("ur5", "tool0"), ("iiwa14", "ee_link")):
        robot = manipkit.load(name)
        chain = robot.chain("base_link", tip)
        Q = chain.sample(12, seed=2)
        T = chain.fk(Q)
        psi = np.array([srs_arm_angle(chain, q) for q in Q]) if name == "iiwa14" else None
        batch = analytic_ik_many(robot, T, "base_link", tip, arm_angle=psi)
        expected = chain_ik_many(chain, T, arm_angle=psi)
        assert np.array_equal(batch.solutions, expected.solutions, equal_nan=True) and batch.success.all()
        for i, k in zip(*np.nonzero(~np.isnan(batch.solutions[..., 0]))):
            reached = robot.transform("base_link", tip, chain.full(batch.solutions[i, k]), check_limits=False)
            assert np.abs(reached - T[i]).max() < 1e-10


def test_analytic_ik_many_refuses_targets_that_are_not_finite_transforms():
    robot = manipkit.load("ur5")
    for targets in (np.full((2, 4, 4), np.nan), np.eye(3)[None], np.zeros(4)):
        with pytest.raises(IKOptionError, match="targets must be finite 4x4 transforms"):
            analytic_ik_many(robot, targets, "base_link", "tool0")
