"""manipkit.kinematics.chain: the Chain between two frames, checked against Pinocchio, finite differences and hand values."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest

from manipkit.errors import ChainError, JointLimitError, JointValueError
from manipkit.kinematics.chain import Chain


def test_the_same_call_returns_the_same_immutable_chain(load_robot):
    robot = load_robot("iiwa14")
    chain = robot.chain("base_link", "ee_link")
    assert isinstance(chain, Chain)
    assert robot.chain("base_link", "ee_link") is chain
    assert robot.chain(robot.base_link, robot.ee_frame) is chain  # aliases resolve to the same key
    with pytest.raises(AttributeError, match="immutable"):
        chain.tip = "iiwa_link_3"
    with pytest.raises(AttributeError, match="immutable"):
        chain.new_field = 1
    with pytest.raises(ValueError):
        chain.lower[0] = 0.0  # read-only arrays
    with pytest.raises(AttributeError, match="immutable"):
        robot.name = "other"


def test_joint_names_are_the_joints_between_the_frames(load_robot):
    robot = load_robot("mobile_manipulator")
    # The arm from its own base: the wheels and arm_base_joint (above arm_base) are not on the chain.
    chain = robot.chain("arm_base", "ee_link")
    assert chain.joint_names == ("shoulder_joint", "bottom_wrist_joint", "elbow_joint", "top_wrist_joint")
    assert [robot.joint_names[c] for c in chain.columns] == list(chain.joint_names)
    whole = robot.chain("base_link", "ee_link")
    assert whole.joint_names[0] == "arm_base_joint" and "left_wheel_joint" not in whole.joint_names
    still = robot.chain("ee_link", "ee_link")
    assert still.joint_names == ()
    # no joints: the pose is the identity and the Jacobian has no columns, for one row or many
    assert np.array_equal(still.fk([]), np.eye(4)) and still.jacobian([]).shape == (6, 0)
    assert still.jacobians(np.zeros((3, 0))).shape == (3, 6, 0) and still.fk(np.zeros((3, 0))).shape == (3, 4, 4)


def pinocchio_T(robot, base, tip, q):
    """``oMf[base]^-1 oMf[tip]`` by Pinocchio directly (its own Data), for a whole-robot vector ``q``."""
    import pinocchio as pin

    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.pinocchio_configuration(q))
    return (data.oMf[robot.model.getFrameId(base)].inverse() * data.oMf[robot.model.getFrameId(tip)]).homogeneous


def twist_by_central_differences(chain, q, h=1e-6):
    """(6, n) columns ``(dp/dq_k, w_k)`` of ``T_base_tip = chain.fk(q)``: ``w_k`` the vee of ``dR/dq_k R^T``
    (the tip's angular velocity relative to the base, base axes), both by central differences of the chain's FK."""
    R = chain.fk(q)[:3, :3]
    J = np.zeros((6, chain.n))
    for k in range(chain.n):
        step = np.zeros(chain.n)
        step[k] = h
        T_plus, T_minus = chain.fk(q + step), chain.fk(q - step)
        J[:3, k] = (T_plus[:3, 3] - T_minus[:3, 3]) / (2 * h)
        W = (T_plus[:3, :3] - T_minus[:3, :3]) / (2 * h) @ R.T
        J[3:, k] = W[2, 1], W[0, 2], W[1, 0]
    return J


@pytest.mark.parametrize("name, base, tip, joints", [
    ("panda", "panda_leftfinger", "panda_rightfinger", ("panda_finger_joint1",)),  # up one finger, down the other
    ("mobile_manipulator", "lidar_link", "ee_link",  # up from the lidar to base_link, down the arm
     ("arm_base_joint", "shoulder_joint", "bottom_wrist_joint", "elbow_joint", "top_wrist_joint")),
    ("mobile_manipulator", "left_wheel_link", "ee_link",  # up a wheel: its joint is inverted
     ("left_wheel_joint", "arm_base_joint", "shoulder_joint", "bottom_wrist_joint", "elbow_joint", "top_wrist_joint")),
    ("iiwa14", "iiwa_link_5", "iiwa_link_2", ("iiwa_joint_5", "iiwa_joint_4", "iiwa_joint_3")),  # up only
])
def test_a_chain_between_any_two_frames_equals_pinocchio(load_robot, name, base, tip, joints):
    robot = load_robot(name)
    chain = robot.chain(base, tip)
    assert isinstance(chain, Chain) and chain.joint_names == joints
    Q = np.vstack([robot.sample_q(40, seed=11), np.random.default_rng(12).uniform(-7, 7, (10, len(robot.joints)))])
    expected = np.array([pinocchio_T(robot, base, tip, q) for q in Q])
    assert np.abs(chain.fk(Q[:, chain.columns]) - expected).max() < 1e-12
    assert np.abs(robot.fk(Q, base=base, tip=tip) - expected).max() < 1e-12
    assert np.abs(np.array([robot.transform(base, tip, q, check_limits=False) for q in Q]) - expected).max() < 1e-12
    assert np.abs(chain.compiled_fk.transforms(np.ascontiguousarray(Q[:, chain.columns])) - expected).max() < 1e-12


@pytest.mark.parametrize("name, base, tip", [
    ("panda", "panda_leftfinger", "panda_rightfinger"),
    ("mobile_manipulator", "lidar_link", "ee_link"),
    ("mobile_manipulator", "left_wheel_link", "ee_link"),
    ("iiwa14", "iiwa_link_5", "iiwa_link_2"),
])
def test_the_jacobian_of_an_up_then_down_chain_is_the_tips_twist_relative_to_the_base(load_robot, name, base, tip):
    # Column k: d/dq_k of T_base_tip as (velocity of the tip's origin, angular velocity of the tip), both relative to
    # the base and in the base's axes; "local": the same twist in the tip's axes.
    robot = load_robot(name)
    chain = robot.chain(base, tip)
    for q in chain.sample(6, seed=13):
        J = chain.jacobian(q)
        np.testing.assert_allclose(J, twist_by_central_differences(chain, q), rtol=0, atol=1e-7)
        R = chain.fk(q)[:3, :3]
        np.testing.assert_allclose(chain.jacobian(q, reference="local"), np.vstack([R.T @ J[:3], R.T @ J[3:]]),
                                   rtol=0, atol=1e-12)
    # the finger to finger chain by hand: both finger frames keep the hand's axes; the left finger sits at y = +q, the
    # right at y = -q (panda_finger_joint2 mimics joint1 along -y), so T_left_right is a shift by (0, -2 q, 0) and
    # the one column is (0, -2, 0, 0, 0, 0)
    if name == "panda":
        np.testing.assert_allclose(chain.fk([0.01])[:3, 3], [0.0, -0.02, 0.0], atol=1e-12)
        np.testing.assert_allclose(chain.jacobian([0.01])[:, 0], [0.0, -2.0, 0.0, 0.0, 0.0, 0.0], atol=1e-12)


@pytest.mark.parametrize("name, base, tip", [
    ("iiwa14", "base_link", "ee_link"),
    ("mobile_manipulator", "arm_base", "ee_link"),
    ("panda", "panda_link0", "panda_hand"),
    ("course_arm", "bicep", "ee_link"),
])
def test_fk_equals_pinocchio(load_robot, name, base, tip):
    robot = load_robot(name)
    chain = robot.chain(base, tip)
    Q = chain.sample(20, seed=3)
    T = chain.fk(Q)
    for q, T_k in zip(Q, T):
        expected = robot.transform(base, tip, chain.full(q), check_limits=False)  # Pinocchio
        assert np.abs(T_k - expected).max() < 1e-12
    # One vector gives one pose; whole-robot rows give the same poses.
    assert np.abs(chain.fk(Q[0]) - T[0]).max() == 0.0
    whole = np.array([chain.full(q) for q in Q])
    assert np.abs(chain.fk(whole) - T).max() == 0.0
    # the compiled FK without the checks (for rows a compiled caller made): the same poses, into a given array
    out = np.empty((len(Q), 4, 4))
    assert chain.compiled_fk.transforms(np.ascontiguousarray(Q), out=out) is out
    assert np.array_equal(out, T)


@pytest.mark.parametrize("name, base, tip", [("iiwa14", "base_link", "ee_link"), ("scara", "base_link", "ee_link")])
def test_jacobian_is_the_derivative_of_fk(load_robot, name, base, tip):
    """Columns against central differences of the FK: v = dp/dq, w from dR R^T (skew part)."""
    chain = load_robot(name).chain(base, tip)
    q = chain.sample(1, seed=5)[0]
    J = chain.jacobian(q)
    h = 1e-6
    for k in range(chain.n):
        dq = np.zeros(chain.n)
        dq[k] = h
        T_plus, T_minus = chain.fk(q + dq), chain.fk(q - dq)
        v = (T_plus[:3, 3] - T_minus[:3, 3]) / (2 * h)
        W = (T_plus[:3, :3] - T_minus[:3, :3]) / (2 * h) @ chain.fk(q)[:3, :3].T
        w = np.array([W[2, 1], W[0, 2], W[1, 0]])
        assert np.abs(J[:3, k] - v).max() < 1e-7 and np.abs(J[3:, k] - w).max() < 1e-7


def test_jacobian_has_only_the_chains_columns(load_robot):
    robot = load_robot("mobile_manipulator")
    chain = robot.chain("base_link", "ee_link")
    q = chain.sample(1, seed=2)[0]
    J = chain.jacobian(q)
    assert J.shape == (6, 5)  # the arm's five joints; no wheel columns
    J_robot = robot.jacobian(chain.full(q), base="base_link", tip="ee_link")  # the whole-robot Jacobian, one column per joint
    assert np.abs(J - J_robot[:, chain.columns]).max() < 1e-12
    J_local = chain.jacobian(q, reference="local")
    R = chain.fk(q)[:3, :3]
    assert np.abs(J_local[:3] - R.T @ J[:3]).max() < 1e-12 and np.abs(J_local[3:] - R.T @ J[3:]).max() < 1e-12


def test_axes_of_the_2r_by_hand(load_robot):
    """planar_2r (l1 = l2 = 1): both axes are z; joint 1 at the origin, joint 2 at (cos q1, sin q1, 0)."""
    chain = load_robot("planar_2r").chain("base_link", "ee_link")
    axes = chain.axes([0.3, -1.1])
    assert np.abs(axes.direction - [[0, 0, 1], [0, 0, 1]]).max() < 1e-15
    assert np.abs(axes.point - [[0, 0, 0], [math.cos(0.3), math.sin(0.3), 0]]).max() < 1e-15
    assert axes.joint.tolist() == [0, 1] and not axes.prismatic.any()


@pytest.mark.parametrize("name", ["iiwa14", "scara", "stanford_arm"])
def test_axes_agree_with_the_jacobian(load_robot, name):
    """A revolute column is (a x (p - o), a), a prismatic one (a, 0), with p the tip's origin."""
    chain = load_robot(name).chain("base_link", "ee_link")
    q = chain.sample(1, seed=7)[0]
    axes, J, p = chain.axes(q), chain.jacobian(q), chain.fk(q)[:3, 3]
    for k, (a, o, prismatic) in enumerate(zip(axes.direction, axes.point, axes.prismatic)):
        column = np.concatenate([a, np.zeros(3)]) if prismatic else np.concatenate([np.cross(a, p - o), a])
        assert np.abs(J[:, axes.joint[k]] - column).max() < 1e-12


def test_q_takes_every_form_and_says_what_is_valid(load_robot):
    robot = load_robot("mobile_manipulator")
    chain = robot.chain("arm_base", "ee_link")
    expected = np.array([math.pi / 2, 0.0, 0.0, 0.0])
    assert np.array_equal(chain.q(shoulder_joint=90, degrees=True), expected)
    assert np.array_equal(chain.q({"shoulder_joint": math.pi / 2}), expected)
    assert np.array_equal(chain.q([90, 0, 0, 0], degrees=True), expected)
    assert np.array_equal(chain.q(robot.q(shoulder_joint=math.pi / 2)), expected)  # a whole-robot vector
    with pytest.raises(JointValueError, match=r"needs 4 joint values .*or 7 for the whole robot; got shape \(3,\)"):
        chain.q([0, 0, 0])
    with pytest.raises(JointValueError, match="finite"):
        chain.q([0, math.nan, 0, 0])
    with pytest.raises(JointValueError, match="no joint 'shoulder'"):
        chain.q(shoulder=1.0)


def test_sample_is_inside_the_limits_and_reproducible(load_robot):
    chain = load_robot("iiwa14").chain("base_link", "ee_link")
    Q = chain.sample(1000, seed=4)
    assert Q.shape == (1000, 7)
    assert chain.within_limits(Q).all()
    assert np.array_equal(Q, chain.sample(1000, seed=4)) and not np.array_equal(Q, chain.sample(1000, seed=5))


def test_check_limits_names_the_joint(load_robot):
    chain = load_robot("iiwa14").chain("base_link", "ee_link")
    with pytest.raises(JointLimitError, match="iiwa_joint_2"):
        chain.check_limits(chain.q(iiwa_joint_2=2.5))
    assert np.array_equal(chain.clamp(chain.q(iiwa_joint_2=2.5))[1], chain.upper[1])


def test_a_chain_takes_two_frames_and_always_returns_a_chain(load_robot):
    robot = load_robot("iiwa14")
    with pytest.raises(TypeError):
        robot.chain("ee_link")  # the 0.1 one-frame form (the steps from the root) is gone
    assert isinstance(robot.chain(robot.root_link, "ee_link"), Chain)


def test_two_threads_get_right_answers_at_once(load_robot):
    """transform (Pinocchio Data per thread) and chain.fk (scratch memory per thread) from two threads at once."""
    robot = load_robot("iiwa14")
    chain = robot.chain("base_link", "ee_link")
    Q = chain.sample(400, seed=9)
    expected = [robot.transform("base_link", "ee_link", q) for q in Q]
    errors = []

    def work(offset):
        for _ in range(5):
            for k in range(offset, len(Q), 2):
                if np.abs(robot.transform("base_link", "ee_link", Q[k]) - expected[k]).max() > 1e-12:
                    errors.append(("transform", k))
            if np.abs(chain.fk(Q[offset::2]) - np.array(expected[offset::2])).max() > 1e-12:
                errors.append(("fk", offset))

    threads = [threading.Thread(target=work, args=(k,)) for k in (0, 1)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []


def test_every_function_taking_one_q_takes_it_by_name(load_robot):
    """docs/architecture.md: a dict by joint name (others at their defaults) works wherever one q does."""
    robot = load_robot("planar_2r")
    chain = robot.chain("base_link", "ee_link")
    by_name, q = {"joint2": 0.3}, np.array([0.0, 0.3])
    assert np.array_equal(chain.fk(by_name), chain.fk(q))
    assert np.array_equal(chain.jacobian(by_name), chain.jacobian(q))
    assert np.array_equal(chain.axes(by_name).point, chain.axes(q).point)
    assert np.array_equal(robot.clamp(by_name), q) and np.array_equal(robot.jacobian(by_name), robot.jacobian(q))
    assert np.array_equal(robot.transform("base_link", "ee_link", by_name), robot.transform("base_link", "ee_link", q))


def test_ik_takes_a_chain_for_its_robot_and_frames(load_robot):
    import manipkit
    from manipkit.ik.numerical_many import ik_many

    robot = load_robot("mobile_manipulator")
    chain = robot.chain("arm_base", "ee_link")
    q_true = chain.sample(3, seed=4)
    T = chain.fk(q_true)
    result = manipkit.ik(chain, T[0], seed=1)
    assert result.success and np.abs(chain.fk(result.q) - T[0]).max() < 1e-9  # confirmed by FK of the answer
    same = manipkit.ik(robot, T[0], base="arm_base", tip="ee_link", seed=1)
    assert np.array_equal(result.q, same.q)
    batch = ik_many(chain, T, seed=1)
    assert batch.success.all() and np.abs(chain.fk(batch.q) - T).max() < 1e-9
    with pytest.raises(ChainError, match="has its own frames"):
        manipkit.ik(chain, T[0], base="base_link", tip="ee_link")
