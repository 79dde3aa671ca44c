"""The bundled robot descriptions (robots/*.urdf.xacro) against their references.

The robot side of every comparison is manipkit's model of the bundled
description. The expected side is composed here, with numpy only, from the
joint tables of shared/reference/course_arm.md and shared/reference/iiwa14.md,
from the closed-form planar formulas, and from the base geometry written in
robots/mobile_manipulator.urdf.xacro. The tables are copied below as literal
numbers so that a wrong number in a description shows up as a failure here.

Conventions (DESIGN.md): metres and radians; T_a_b is the pose of frame b in
frame a; URDF rpy means R = Rz(yaw) Ry(pitch) Rx(roll); a joint's transform is
T_parent_child(q) = T_origin @ Rot(axis, q).
"""

import io
import math
import pathlib

import numpy as np
import pytest
import xacro
import yourdfpy
from reference import (
    COURSE_ARM_JOINT_NAMES,
    COURSE_ARM_JOINTS,
    COURSE_ARM_POSES,
    IIWA_JOINT_NAMES,
    IIWA_JOINTS,
    IIWA_LIMITS,
    IIWA_LIMITS_DEG,
    MOBILE_ARM_JOINTS,
    T_BASE_FOOTPRINT_BASE_LINK,
    T_BASE_LINK_LIDAR_LINK,
    T_IIWA_LINK_7_EE_LINK,
    T_TOP_WRIST_EE_LINK,
    WHEEL_RADIUS,
    WHEEL_X,
    WHEEL_Y,
    compose_chain,
    homogeneous,
    rot_y,
    rot_z,
)

import manipkit
from manipkit.description.sources import bundled_robots

TOL = 1e-12
ROBOTS_DIR = pathlib.Path(__file__).resolve().parents[1] / "robots"
BUNDLED = sorted(bundled_robots())



def assert_transform_close(actual, expected, tol=TOL):
    actual = np.asarray(actual)
    assert actual.shape == expected.shape
    error = np.max(np.abs(actual - expected))
    assert error <= tol, f"max |difference| = {error:.3e} > {tol:.0e}\n{actual}\n!=\n{expected}"


def random_angles(rng, limits, n):
    """(n, len(limits)) angles uniformly inside +-0.99 limits."""
    limits = 0.99 * np.asarray(limits, dtype=float)
    return rng.uniform(-limits, limits, size=(n, len(limits)))


def expand(name, **args):
    """URDF text of a bundled description, expanded by xacro directly."""
    mappings = {key: str(value) for key, value in args.items()}
    path = ROBOTS_DIR / f"{name}.urdf.xacro"
    return xacro.process_file(str(path), mappings=mappings).toprettyxml()


# --------------------------------------------------------------------------
# Fixtures
# --------------------------------------------------------------------------


# course_arm and iiwa14: session fixtures of conftest.py


@pytest.fixture(scope="module")
def mobile(load_robot):
    return load_robot("mobile_manipulator")


# --------------------------------------------------------------------------
# Every description: expands anywhere, is a valid URDF
# --------------------------------------------------------------------------


@pytest.mark.parametrize("name", BUNDLED)
def test_description_expands_from_another_working_directory(name, tmp_path, monkeypatch):
    # xacro:include paths are relative to the including file, not to the cwd.
    monkeypatch.chdir(tmp_path)
    text = expand(name)
    assert "<robot" in text and f'name="{name}"' in text


@pytest.mark.parametrize("name", BUNDLED)
def test_description_is_a_valid_urdf_with_masses_limits_and_unit_axes(name):
    urdf = yourdfpy.URDF.load(
        io.StringIO(expand(name)), build_scene_graph=False, load_meshes=False
    )
    assert urdf.validate()
    for link in urdf.robot.links:
        assert link.inertial is not None, f"link {link.name} has no inertial"
        assert link.inertial.mass > 0, f"link {link.name} has mass {link.inertial.mass}"
    for joint in urdf.robot.joints:
        if joint.type == "fixed":
            continue
        assert np.linalg.norm(joint.axis) == pytest.approx(1.0, abs=1e-12), joint.name
        if joint.type == "revolute":
            assert joint.limit.lower < joint.limit.upper, joint.name
            assert joint.limit.effort > 0 and joint.limit.velocity > 0, joint.name


# --------------------------------------------------------------------------
# Course arm
# --------------------------------------------------------------------------


def test_course_arm_joint_names_follow_the_chain(course_arm):
    assert list(course_arm.joint_names) == COURSE_ARM_JOINT_NAMES


def test_course_arm_zero_pose_top_wrist_matches_hand_worked_position(course_arm):
    # At zero every joint rotation is the identity, so only the origins count:
    #   z = 0.1 + 0.20271 + 0.269 + 0.13522 + 0.20994 = 0.91687
    # The shoulder origin turns the frame by yaw 1.5708 (not exactly pi/2), so
    # the bicep's y offset (0, -0.05194, 0) lands at
    #   Rz(1.5708) (0, -0.05194, 0) = (0.05194 sin 1.5708, -0.05194 cos 1.5708, 0)
    #                               = (0.05193999999965, 1.90786e-07, 0)
    #   x = -0.05166 + 0.05194 sin 1.5708 = 0.00028 - 3.5e-13
    #   y = -0.05194 cos 1.5708 = 0.05194 * 3.67321e-06 = 1.90786e-07
    # and top_wrist is turned by Rz(1.5708). ee_link is 0.13522 further up z.
    T = course_arm.transform("base_link", "top_wrist", course_arm.q())
    expected_p = [
        -0.05166 + 0.05194 * math.sin(1.5708),
        -0.05194 * math.cos(1.5708),
        0.1 + 0.20271 + 0.269 + 0.13522 + 0.20994,
    ]
    np.testing.assert_allclose(T[:3, 3], expected_p, rtol=0, atol=TOL)
    np.testing.assert_allclose(T[:3, 3], [0.00028, 1.90786e-07, 0.91687], rtol=0, atol=1e-11)
    np.testing.assert_allclose(T[:3, :3], rot_z(1.5708), rtol=0, atol=TOL)
    T_ee = course_arm.transform("base_link", "ee_link", course_arm.q())
    np.testing.assert_allclose(T_ee[:3, 3], [0.00028, 1.90786e-07, 1.05209], rtol=0, atol=1e-11)


@pytest.mark.parametrize("pose", sorted(COURSE_ARM_POSES))
def test_course_arm_matches_reference_table_at_seed_pose(course_arm, pose):
    angles = COURSE_ARM_POSES[pose]
    q = course_arm.q(**dict(zip(COURSE_ARM_JOINT_NAMES, angles)))
    T_base_link_top_wrist = compose_chain(COURSE_ARM_JOINTS, angles)
    T_base_link_ee_link = T_base_link_top_wrist @ T_TOP_WRIST_EE_LINK
    assert_transform_close(course_arm.transform("base_link", "top_wrist", q), T_base_link_top_wrist)
    assert_transform_close(course_arm.transform("base_link", "ee_link", q), T_base_link_ee_link)


def test_course_arm_batched_fk_matches_reference_table(course_arm):
    rng = np.random.default_rng(7)
    Q_table = rng.uniform(-math.pi, math.pi, size=(20, 5))
    Q = np.array([course_arm.q(**dict(zip(COURSE_ARM_JOINT_NAMES, row))) for row in Q_table])
    poses = course_arm.fk(Q, tip="ee_link")
    assert poses.shape == (20, 4, 4)
    for T, row in zip(poses, Q_table):
        assert_transform_close(T, compose_chain(COURSE_ARM_JOINTS, row) @ T_TOP_WRIST_EE_LINK)


# --------------------------------------------------------------------------
# KUKA iiwa 14
# --------------------------------------------------------------------------


def test_iiwa14_zero_pose_stands_straight_up(iiwa14):
    # At zero only the origins count. Joint 2's and 3's rpy (pi/2, 0, pi) is
    # Ra = Rz(pi) Rx(pi/2), which maps y onto z and is a half turn (Ra Ra = I);
    # Rx(pi/2) Ry(pi) Rx(-pi/2) = Rz(pi) for joints 4..7. So the frames of
    # links 2, 4, 6 have y up and those of links 1, 3, 5, 7 have z up, and
    # every offset points up:
    #   z(iiwa_link_7) = 0.1575 + 0.2025 + 0.2045 + 0.2155 + 0.1845 + 0.2155 + 0.081
    #                  = 1.261
    #   z(ee_link) = 1.261 + 0.045 = 1.306, and iiwa_link_7 is not turned.
    q = iiwa14.q()
    T_link_7 = iiwa14.transform("base_link", "iiwa_link_7", q)
    T_ee = iiwa14.transform("base_link", "ee_link", q)
    np.testing.assert_allclose(T_link_7[:3, 3], [0.0, 0.0, 1.261], rtol=0, atol=TOL)
    np.testing.assert_allclose(T_ee[:3, 3], [0.0, 0.0, 1.306], rtol=0, atol=TOL)
    np.testing.assert_allclose(T_link_7[:3, :3], np.eye(3), rtol=0, atol=TOL)


def test_iiwa14_matches_reference_table_at_random_configurations(iiwa14):
    assert list(iiwa14.joint_names) == IIWA_JOINT_NAMES
    rng = np.random.default_rng(14)
    Q = random_angles(rng, IIWA_LIMITS, 50)
    link_7 = iiwa14.fk(Q, tip="iiwa_link_7")
    ee = iiwa14.fk(Q, tip="ee_link")
    for q, T_link_7, T_ee in zip(Q, link_7, ee):
        # base_link -> iiwa_link_0 is the identity
        T_expected = compose_chain(IIWA_JOINTS, q)
        assert_transform_close(T_link_7, T_expected)
        assert_transform_close(T_ee, T_expected @ T_IIWA_LINK_7_EE_LINK)


def test_iiwa14_joint_limits_match_reference():
    urdf = yourdfpy.URDF.load(
        io.StringIO(expand("iiwa14")), build_scene_graph=False, load_meshes=False
    )
    joints = {joint.name: joint for joint in urdf.robot.joints}
    for name, limit, degrees in zip(IIWA_JOINT_NAMES, IIWA_LIMITS, IIWA_LIMITS_DEG):
        joint = joints[name]
        assert joint.type == "revolute"
        assert joint.limit.upper == pytest.approx(math.radians(degrees), abs=1e-12)
        assert joint.limit.upper == pytest.approx(limit, abs=5e-6)  # table's rounding
        assert joint.limit.lower == -joint.limit.upper


# --------------------------------------------------------------------------
# Planar arms
# --------------------------------------------------------------------------


def planar_tool_pose(lengths, angles):
    """T_base_link_ee_link of a planar nR arm, closed form.

    x = sum_i l_i cos(t_1 + ... + t_i), y = sum_i l_i sin(t_1 + ... + t_i),
    turned by t_1 + ... + t_n about z.
    """
    cumulative = np.cumsum(angles)
    x = sum(length * math.cos(a) for length, a in zip(lengths, cumulative))
    y = sum(length * math.sin(a) for length, a in zip(lengths, cumulative))
    return homogeneous(rot_z(cumulative[-1]), (x, y, 0.0))


@pytest.mark.parametrize(
    ("name", "args", "lengths"),
    [
        ("planar_2r", {}, (1.0, 1.0)),
        ("planar_2r", {"l1": 2.5, "l2": 0.7}, (2.5, 0.7)),
        ("planar_3r", {}, (4.0, 2.0, 1.0)),
        ("planar_3r", {"l1": 2, "l2": 1.5, "l3": 0.25}, (2.0, 1.5, 0.25)),
    ],
    ids=["2r-default", "2r-args", "3r-default", "3r-args"],
)
def test_planar_tool_pose_matches_closed_form(name, args, lengths):
    robot = manipkit.load(name, **args)
    n = len(lengths)
    assert list(robot.joint_names) == [f"joint{i}" for i in range(1, n + 1)]
    rng = np.random.default_rng(n)
    Q = random_angles(rng, [math.pi] * n, 20)
    for q, T in zip(Q, robot.fk(Q, tip="ee_link")):
        assert_transform_close(T, planar_tool_pose(lengths, q))


# --------------------------------------------------------------------------
# Mobile manipulator
# --------------------------------------------------------------------------


def random_mobile_q(robot, rng):
    """Random angles for every joint of the mobile manipulator (arm and wheels)."""
    arm = dict(zip(COURSE_ARM_JOINT_NAMES, rng.uniform(-math.pi, math.pi, 5)))
    wheels = dict(zip(["left_wheel_joint", "right_wheel_joint"], rng.uniform(-math.pi, math.pi, 2)))
    return robot.q(**arm, **wheels), [arm[name] for name in COURSE_ARM_JOINT_NAMES]


def test_mobile_manipulator_joints_are_arm_and_wheels(mobile):
    expected = set(COURSE_ARM_JOINT_NAMES) | {"left_wheel_joint", "right_wheel_joint"}
    assert set(mobile.joint_names) == expected
    assert len(mobile.joint_names) == len(expected)


def test_mobile_manipulator_lidar_to_ee_matches_base_geometry(mobile):
    # T_lidar_ee = (T_base_link_lidar)^-1 T_base_link_arm_base(q0) T_arm_base_ee(q)
    # and the wheel angles must not enter it.
    rng = np.random.default_rng(3)
    T_lidar_link_base_link = np.linalg.inv(T_BASE_LINK_LIDAR_LINK)
    for _ in range(20):
        q, arm_angles = random_mobile_q(mobile, rng)
        expected = (
            T_lidar_link_base_link
            @ compose_chain(MOBILE_ARM_JOINTS, arm_angles)
            @ T_TOP_WRIST_EE_LINK
        )
        assert_transform_close(mobile.transform("lidar_link", "ee_link", q), expected)


def test_mobile_manipulator_fk_is_in_base_footprint_frame(mobile):
    rng = np.random.default_rng(4)
    pairs = [random_mobile_q(mobile, rng) for _ in range(10)]
    Q = np.array([q for q, _ in pairs])
    for T, (_, arm_angles) in zip(mobile.fk(Q, base="base_footprint", tip="ee_link"), pairs):
        expected = (
            T_BASE_FOOTPRINT_BASE_LINK
            @ compose_chain(MOBILE_ARM_JOINTS, arm_angles)
            @ T_TOP_WRIST_EE_LINK
        )
        assert_transform_close(T, expected)
    for T in mobile.fk(Q, base="base_footprint", tip="lidar_link"):
        assert_transform_close(T, T_BASE_FOOTPRINT_BASE_LINK @ T_BASE_LINK_LIDAR_LINK)


def test_mobile_manipulator_wheels_turn_about_their_axles_on_the_ground(mobile):
    # Each wheel's centre is one wheel radius above base_footprint (it touches
    # the ground) and turns about y; the caster ball touches the ground too.
    urdf = yourdfpy.URDF.load(
        io.StringIO(expand("mobile_manipulator")), build_scene_graph=False, load_meshes=False
    )
    links = {link.name: link for link in urdf.robot.links}
    angle = 0.7
    for side, sign in [("left", 1.0), ("right", -1.0)]:
        q = mobile.q(**{f"{side}_wheel_joint": angle})
        T = mobile.transform("base_footprint", f"{side}_wheel_link", q)
        expected = homogeneous(rot_y(angle), (WHEEL_X, sign * WHEEL_Y, WHEEL_RADIUS))
        assert_transform_close(T, expected)
        assert links[f"{side}_wheel_link"].visuals[0].geometry.cylinder.radius == WHEEL_RADIUS
    caster_radius = links["caster_link"].visuals[0].geometry.sphere.radius
    T_caster = mobile.transform("base_footprint", "caster_link", mobile.q())
    assert T_caster[2, 3] == pytest.approx(caster_radius, abs=TOL)
