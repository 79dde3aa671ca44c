"""manipkit.kinematics.robot: joint vectors, frame aliases, Pinocchio transforms and the batched FK path.

Independent sources: Pinocchio (``Robot.transform``) against the numpy chain
of ``Robot.fk``, and both against yourdfpy's own forward kinematics, which
parses the URDF with a different parser and composes the chain itself.
"""

import math

import numpy as np
import pytest

import manipkit
from manipkit.description.sources import bundled_robots
from manipkit.errors import JointValueError, UnknownFrameError

ROBOTS = sorted(bundled_robots()) + ["panda", "ur5"]


@pytest.fixture(scope="module")
def loaded(load_robot):
    return {name: load_robot(name) for name in ROBOTS}


def random_q(robot, rng, n):
    lower = np.array([max(j.lower, -math.pi) for j in robot.joints])
    upper = np.array([min(j.upper, math.pi) for j in robot.joints])
    return rng.uniform(lower, upper, size=(n, len(robot.joints)))


def yourdfpy_model(robot):
    from io import BytesIO

    import yourdfpy

    return yourdfpy.URDF.load(BytesIO(robot.urdf.encode()), build_scene_graph=True, load_meshes=False,
                              build_collision_scene_graph=False, load_collision_meshes=False)


@pytest.mark.parametrize("name", ROBOTS)
def test_pinocchio_agrees_with_yourdfpy_fk_at_100_random_configurations(loaded, name):
    robot = loaded[name]
    urdf = yourdfpy_model(robot)
    actuated = set(urdf.actuated_joint_names)
    mimicked = {j.name for j in urdf.robot.joints if j.mimic is not None}
    # Frames whose chain has no mimic joint (yourdfpy applies mimic rules, Pinocchio does not).
    frames = [f for f in robot.frame_names if not (mimicked & {j.name for j in robot.joints if j.child in _ancestors(urdf, f)})]
    assert robot.ee_frame in frames and len(frames) >= 3
    rng = np.random.default_rng(7)
    worst = 0.0
    for q in random_q(robot, rng, 100):
        urdf.update_cfg({n: v for n, v in zip(robot.joint_names, q) if n in actuated})
        for frame in frames:
            T_yourdfpy = urdf.get_transform(frame_to=frame, frame_from=robot.root_link)
            worst = max(worst, np.abs(T_yourdfpy - robot.transform(robot.root_link, frame, q, check_limits=False)).max())
    assert worst < 1e-9


def _ancestors(urdf, link):
    parents = {j.child: (j.parent, j.name) for j in urdf.robot.joints}
    chain = {link}
    while link in parents:
        link = parents[link][0]
        chain.add(link)
    return chain


@pytest.mark.parametrize("name", ROBOTS)
def test_batched_fk_equals_pinocchio_per_configuration(loaded, name):
    robot = loaded[name]
    Q = random_q(robot, np.random.default_rng(3), 50)
    source, target = robot.frame_names[1], robot.ee_frame
    T_batch = robot.fk(Q, base=source, tip=target)
    T_loop = np.array([robot.transform(source, target, q, check_limits=False) for q in Q])
    assert T_batch.shape == (50, 4, 4)
    assert np.abs(T_batch - T_loop).max() < 1e-12


def pinocchio_poses(robot, base, frame, Q):
    return np.array([robot.transform(base, frame, q, check_limits=False) for q in Q])


def is_above(robot, base, frame) -> bool:
    """The base's parent joint supports the frame (Pinocchio's model): the chain has no step up from the base."""
    model = robot.model
    return model.frames[robot.frame_id(base)].parentJoint in model.supports[model.frames[robot.frame_id(frame)].parentJoint]


@pytest.mark.parametrize("name, base", [("mobile_manipulator", "arm_base"), ("iiwa14", "iiwa_link_3")])
def test_fk_from_a_link_above_the_frame_runs_one_chain_equal_to_pinocchio(loaded, name, base):
    robot = loaded[name]
    assert is_above(robot, base, "ee_link")
    Q = np.vstack([robot.sample_q(300, seed=21), np.random.default_rng(22).uniform(-20, 20, (20, len(robot.joints)))])
    T = robot.fk(Q, base=base, tip="ee_link")
    chain = robot.chain(base, "ee_link")  # the program of the chain base -> ee_link ran, on its columns
    assert np.array_equal(T, chain.program.fk.transforms(np.ascontiguousarray(Q[:, chain.columns])))
    # tan(q/2) vs Pinocchio's sin/cos at |q| up to 20 rad: a few ulps of 20, well inside 1e-12
    assert np.abs(T - pinocchio_poses(robot, base, "ee_link", Q)).max() < 1e-12


@pytest.mark.parametrize("name", ["mobile_manipulator", "iiwa14"])
def test_fk_between_every_pair_of_frames_equals_pinocchio(loaded, name):
    """Bases above the frame, equal to it, below it or on another branch: one chain each (up, then down)."""
    robot = loaded[name]
    Q = robot.sample_q(20, seed=23)
    paths = set()
    for base in robot.frame_names:
        for frame in robot.frame_names:
            paths.add(is_above(robot, base, frame))
            T = robot.fk(Q, base=base, tip=frame)
            assert np.abs(T - pinocchio_poses(robot, base, frame, Q)).max() < 1e-12, (base, frame)
    assert paths == {True, False}


def test_fk_keeps_leading_dimensions(loaded):
    robot = loaded["iiwa14"]
    Q = random_q(robot, np.random.default_rng(1), 12).reshape(3, 4, 7)
    T = robot.fk(Q, tip="ee_link")
    assert T.shape == (3, 4, 4, 4)
    assert np.allclose(T[2, 1], robot.transform("base_link", "ee_link", Q[2, 1], check_limits=False), atol=1e-12)


def test_fk_rejects_wrong_width(loaded):
    with pytest.raises(JointValueError, match="needs 7 joint values per row"):
        loaded["iiwa14"].fk(np.zeros((4, 6)), tip="ee_link")


def test_q_by_name_in_joint_order_with_missing_joints_zero(loaded):
    robot = loaded["course_arm"]
    q = robot.q(elbow_joint=0.5, shoulder_joint=-1.0)
    assert robot.joint_names == ("arm_base_joint", "shoulder_joint", "bottom_wrist_joint", "elbow_joint", "top_wrist_joint")
    assert q.tolist() == [0.0, -1.0, 0.0, 0.5, 0.0]


def test_q_in_degrees_converts_angles_only():
    robot = manipkit.load("panda")
    q = robot.q(panda_joint2=90, panda_finger_joint1=0.02, degrees=True)
    assert q[1] == pytest.approx(math.pi / 2, abs=1e-15)
    assert q[robot.joint_names.index("panda_finger_joint1")] == 0.02  # metres stay metres


def test_missing_joint_defaults_to_nearest_value_inside_limits(loaded):
    # panda_joint4 has limits [-3.0718, -0.0698]: 0 is outside, the nearest inside value is the upper limit.
    robot = manipkit.load("panda")
    joint4 = robot.joints[robot.joint_names.index("panda_joint4")]
    assert joint4.upper < 0
    assert robot.q()[3] == joint4.upper


def test_unknown_joint_lists_the_valid_ones(loaded):
    with pytest.raises(JointValueError, match=r"no joint 'elbow'; did you mean elbow_joint\? joints: arm_base_joint"):
        loaded["course_arm"].q(elbow=1.0)


@pytest.mark.parametrize("value", ["abc", "nan", "inf", None])
def test_non_numeric_or_non_finite_joint_value_is_rejected(loaded, value):
    with pytest.raises(JointValueError, match="elbow_joint"):
        loaded["course_arm"].q(elbow_joint=value)


def test_continuous_joint_takes_angles_beyond_pi(loaded):
    # A continuous joint is (cos, sin) inside Pinocchio; 2 pi + a is the same pose as a.
    robot = loaded["course_arm"]
    a = 0.7
    T1 = robot.transform("base_link", "ee_link", robot.q(elbow_joint=a))
    T2 = robot.transform("base_link", "ee_link", robot.q(elbow_joint=a + 2 * math.pi))
    assert np.abs(T1 - T2).max() < 1e-12
    assert robot.model.nq == 10 and len(robot.joint_names) == 5


def test_outside_limits_names_the_joint_and_limits(loaded):
    robot = loaded["iiwa14"]
    q = robot.q(iiwa_joint_2=2.5)
    # iiwa14's joint 2 limit is +-120 deg = +-2.0944 rad (shared/reference)
    assert robot.outside_limits(q).tolist() == [False, True, False, False, False, False, False]
    assert [str(e) for e in robot.limit_violations(q)] == [
        "joint 'iiwa_joint_2' = 2.5 is above its upper limit 2.0944 (limits [-2.0944, 2.0944] rad)"]
    chain = robot.chain("base_link", "ee_link")  # the same rule, one implementation (JointSpace), on chain vectors
    assert np.array_equal(chain.outside_limits(q), robot.outside_limits(q))
    assert [str(e) for e in chain.limit_violations(q)] == [str(e) for e in robot.limit_violations(q)]
    Q = np.random.default_rng(3).uniform(-3, 3, (50, 7))
    assert np.array_equal(robot.within_limits(Q), chain.within_limits(Q)) and not robot.within_limits(Q).all()
    assert np.array_equal(robot.clamp(Q), chain.clamp(Q))


def test_base_link_alias_is_the_root_of_a_robot_without_such_link():
    robot = manipkit.load("panda")
    assert "base_link" not in robot.frame_names
    assert robot.frame("base_link") == "panda_link0" == robot.root_link
    assert robot.frame("world") == "panda_link0"


def test_real_link_wins_over_alias():
    # ur5 has real links named world (root) and base_link; base_link is not the root.
    robot = manipkit.load("ur5")
    assert robot.root_link == "world"
    assert robot.frame("base_link") == "base_link"


def test_declared_end_effector_is_ee_link_alias():
    robot = manipkit.load("panda")
    assert robot.frame("ee_link") == "panda_hand_tcp"
    assert "declared" in robot.ee_reason


def test_ee_link_of_undeclared_robot_is_tip_of_longest_chain(tmp_path):
    # A branching robot: base -> a -> b -> tip (3 joints) and base -> side (1 joint).
    urdf = tmp_path / "branch.urdf"
    joint = '<joint name="{0}" type="revolute"><parent link="{1}"/><child link="{2}"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
    links = "".join(f'<link name="{n}"/>' for n in ("base", "side", "a", "b", "tip"))
    joints = "".join(joint.format(*j) for j in [("j_side", "base", "side"), ("j1", "base", "a"), ("j2", "a", "b"), ("j3", "b", "tip")])
    urdf.write_text(f'<robot name="branch">{links}{joints}</robot>')
    robot = manipkit.load(urdf)
    assert robot.ee_frame == "tip"
    assert "longest chain" in robot.ee_reason


def test_unknown_frame_suggests_close_names(loaded):
    with pytest.raises(UnknownFrameError, match="no frame 'top_wrst'; did you mean top_wrist"):
        loaded["course_arm"].transform("base_link", "top_wrst")


def test_transform_direction_is_pose_of_target_in_source(loaded):
    # T_a_b @ T_b_a = I, and T_base_ee's translation is where ee is seen from base.
    robot = loaded["iiwa14"]
    q = random_q(robot, np.random.default_rng(5), 1)[0]
    T_ab = robot.transform("iiwa_link_2", "ee_link", q)
    T_ba = robot.transform("ee_link", "iiwa_link_2", q)
    assert np.abs(T_ab @ T_ba - np.eye(4)).max() < 1e-12
    # Hand value: at zero the iiwa stands straight up, ee_link 1.306 m above the base.
    assert robot.transform("base_link", "ee_link")[:3, 3] == pytest.approx([0, 0, 1.306], abs=1e-12)


# --------------------------------------------------------------------------
# The public chain: Robot.chain, ChainStep


@pytest.mark.parametrize("name, base, tip", [
    ("mobile_manipulator", None, "ee_link"), ("mobile_manipulator", "arm_base", "ee_link"),
    ("mobile_manipulator", "ee_link", "arm_base"),  # up only: every joint inverted
    ("mobile_manipulator", "left_wheel_link", "ee_link"),  # up a wheel, down the arm
    ("panda", "panda_leftfinger", "panda_rightfinger"),  # up one finger, down the other (a mimic joint)
])
def test_chain_steps_multiply_to_the_pose_pinocchio_gives(loaded, name, base, tip):
    from manipkit.kernels.fk import ChainStep
    from manipkit.spatial.rotations import matrix_from_axis_angle

    robot = loaded[name]
    base = base or robot.root_link
    assert is_above(robot, base, tip) == (base in (robot.root_link, "arm_base"))
    for q in robot.sample_q(3, seed=31):
        T = np.eye(4)
        for step in robot.chain(base, tip).steps:
            assert isinstance(step, ChainStep)
            placement = np.eye(4)
            placement[:3, :3], placement[:3, 3] = step.rotation, step.translation
            motion = np.eye(4)
            value = step.scale * q[step.index] + step.offset if step.index >= 0 else 0.0
            if step.index >= 0 and step.prismatic:
                motion[:3, 3] = value * step.axis
            elif step.index >= 0:
                motion[:3, :3] = matrix_from_axis_angle(step.axis, value)
            T = T @ placement @ motion
        expected = robot.transform(base, tip, q, check_limits=False)
        assert np.abs(T - expected).max() < 1e-12, base


def test_chain_is_shared_and_read_only(loaded):
    robot = loaded["iiwa14"]
    steps = robot.chain("base_link", "ee_link").steps
    assert [s.index for s in steps] == list(range(7)) + [-1]
    with pytest.raises(ValueError):
        steps[0].rotation[0, 0] = 2.0
    assert robot.chain("base_link", "ee_link").steps[0] is steps[0]


def test_chain_from_a_base_below_the_frame_is_the_inverse_chain(loaded):
    robot = loaded["iiwa14"]
    down, up = robot.chain("iiwa_link_2", "iiwa_link_5"), robot.chain("iiwa_link_5", "iiwa_link_2")
    assert up.joint_names == ("iiwa_joint_5", "iiwa_joint_4", "iiwa_joint_3")  # base to tip: up from link 5
    Q = robot.sample_q(30, seed=32)
    T_up = robot.fk(Q, base="iiwa_link_5", tip="iiwa_link_2")
    assert np.abs(T_up @ robot.fk(Q, base="iiwa_link_2", tip="iiwa_link_5") - np.eye(4)).max() < 1e-12
    assert np.abs(T_up - pinocchio_poses(robot, "iiwa_link_5", "iiwa_link_2", Q)).max() < 1e-12
    assert down.joint_names == ("iiwa_joint_3", "iiwa_joint_4", "iiwa_joint_5")


def test_fk_runs_the_chains_one_program(loaded):
    robot = loaded["iiwa14"]
    Q = robot.sample_q(5, seed=32)
    chain = robot.chain("base_link", "ee_link")
    assert chain.compiled_fk is chain.program.fk and robot.chain("base_link", "ee_link") is chain
    assert np.array_equal(chain.program.fk.transforms(Q), robot.fk(Q, tip="ee_link"))
    chain3 = robot.chain("iiwa_link_3", "ee_link")
    assert np.array_equal(chain3.program.fk.transforms(np.ascontiguousarray(Q[:, chain3.columns])),
                          robot.fk(Q, base="iiwa_link_3", tip="ee_link"))


# ---------------------------------------------------------------- issue 15: API faults and long chains


def test_a_joint_given_in_the_dict_and_as_a_keyword_is_refused(planar_2r):
    with pytest.raises(JointValueError, match="joint 'joint1' is given twice \\(in the dict and as a keyword\\); give each joint once"):
        planar_2r.q({"joint1": 1}, joint1=2)
    assert planar_2r.q({"joint1": 1}, joint2=2).tolist() == [1, 2]


def test_joint_values_by_position_are_taken_in_joint_order(planar_2r):
    np.testing.assert_array_equal(planar_2r.q([1, 2]), [1.0, 2.0])
    with pytest.raises(JointValueError, match="either in joint order or by name, not both"):
        planar_2r.q([1, 2], joint1=3)


@pytest.mark.parametrize("value", [1 + 1j, np.complex128(1 + 0j), np.complex64(2j)])
def test_complex_joint_values_are_refused_not_truncated(planar_2r, value):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's ComplexWarning would be the old behaviour
        with pytest.raises(JointValueError, match="joint values must be real numbers \\(rad or m\\); got complex values"):
            planar_2r.fk(np.array([[value, 0]]), tip="ee_link")
        with pytest.raises(JointValueError, match="joint values must be real numbers"):
            planar_2r.fk(np.array([[value, 0]], dtype=object), tip="ee_link")
        with pytest.raises(JointValueError, match="joint values must be real numbers"):
            planar_2r.transform("base_link", "ee_link", [value, 0])
        with pytest.raises(JointValueError, match="is not a number"):
            planar_2r.q(joint1=value)


@pytest.mark.parametrize("q", ["abc", [["a", 0]], [[1, 2], [3]]])
def test_joint_values_that_are_not_numbers_are_one_line_errors(planar_2r, q):
    with pytest.raises(JointValueError, match="joint values must be real numbers \\(rad or m\\), a vector or equal rows"):
        planar_2r.fk(q, tip="ee_link")


@pytest.mark.parametrize("frame", [None, 3, ["base_link"]])
def test_a_frame_that_is_not_a_string_is_an_unknown_frame(planar_2r, frame):
    with pytest.raises(UnknownFrameError, match="a frame is named by a string such as 'base_link' or 'ee_link', not"):
        planar_2r.transform(frame, "ee_link")
    with pytest.raises(UnknownFrameError, match="not NoneType None"):
        planar_2r.transform("base_link", None)


def test_the_tip_of_a_1500_link_chain_is_ee_link(tmp_path):
    # The tip search used to stop counting frames at 1,000 and chose l500 (equal counts, first found).
    lines = ['<robot name="long">', '<link name="l0"/>']
    for i in range(1, 1501):
        lines.append(f'<link name="l{i}"/><joint name="j{i}" type="fixed"><parent link="l{i - 1}"/><child link="l{i}"/>'
                     '<origin xyz="0 0 0.001"/></joint>')
    path = tmp_path / "long.urdf"
    path.write_text("\n".join(lines + ["</robot>"]))
    robot = manipkit.load(path)
    assert robot.ee_frame == "l1500"
    assert robot.transform("base_link", "ee_link")[:3, 3] == pytest.approx([0, 0, 1.5], abs=1e-9)  # 1500 x 1 mm


# issue 26: counts and batches are bounded before anything is allocated; a 400-digit value is one line
@pytest.mark.parametrize("n", [-1, 10**12, 2.5, "3", True])
def test_sample_q_refuses_counts_that_are_not_whole_numbers_in_range(n):
    robot = manipkit.load("planar_2r")
    with pytest.raises(manipkit.ManipkitError, match="give a whole number from 0 to 10000000"):
        robot.sample_q(n)


def test_fk_of_a_huge_broadcast_view_is_refused_before_allocating():
    robot = manipkit.load("planar_2r")
    Q = np.broadcast_to(np.zeros(2), (10**9, 2))  # costs nothing until computed on: 119 GiB of poses
    with pytest.raises(JointValueError, match="1000000000 configurations in one call; give at most 10000000"):
        robot.fk(Q)


def test_a_joint_value_too_large_for_a_float_is_one_line():
    robot = manipkit.load("planar_2r")
    with pytest.raises(JointValueError, match="a float can hold"):
        robot.transform("base_link", "ee_link", [10**400, 0])
    with pytest.raises(JointValueError, match="a float can hold"):
        robot.fk([10**400, 0])
