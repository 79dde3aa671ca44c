"""Closed-form IK from a chain's own geometry: families found, every branch checked by Pinocchio, limits,
singular families, unreachable targets, calibrated descriptions and the user's frames."""

import math
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import manipkit
from manipkit.errors import ClosedFormIKError
from manipkit.ik.chain_ik import chain_ik, chain_ik_many
from manipkit.ik.families import chain_family
from manipkit.ik.textbook import analytic_ik_many

REALWORLD = next((base / "shared" / "realworld" / "ws_ros1" / "src" for base in Path(__file__).resolve().parents[2:4]
                  if (base / "shared" / "realworld").is_dir()), Path("/nonexistent"))
needs_realworld = pytest.mark.skipif(not REALWORLD.is_dir(), reason="the shared real-world workspace is not here")
UR5E = "universal_robot/ur_description/urdf/ur5e.xacro"
IRB2400 = "abb/abb_irb2400_support/urdf/irb2400.xacro"
SAMPLES = 60


def load_realworld(relative: str):
    """A description by its file path, as users load it (ur_description is also in example-robot-data: one warning)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return manipkit.load(str(REALWORLD / relative))


def pinocchio_pose(robot, base: str, tip: str, q_full) -> np.ndarray:
    """T_base_tip by Pinocchio itself (not manipkit's compiled FK)."""
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.pinocchio_configuration(q_full))
    T_world_base = data.oMf[robot.frame_id(base)].homogeneous
    T_world_tip = data.oMf[robot.frame_id(tip)].homogeneous
    return np.linalg.inv(T_world_base) @ T_world_tip


def pose_gap(A, B) -> float:
    rotation = np.linalg.norm(A[:3, :3] - B[:3, :3])
    return max(float(np.linalg.norm(A[:3, 3] - B[:3, 3])), float(rotation))


def same_modulo_2pi(a, b, tol=1e-7) -> bool:
    return bool(np.all(np.abs(np.pi - np.mod(np.pi - (np.asarray(a) - b), 2 * np.pi)) < tol))


def check_every_branch(robot, base, tip, n=SAMPLES, seed=0):
    """FK of random in-limit configurations: the generating one is among the answers, every answer lands (Pinocchio)."""
    chain = robot.chain(base, tip)
    family = chain_family(chain)
    assert family.solved, family.note
    for q in chain.sample(n, seed=seed):
        T = chain.fk(q)
        result = chain_ik(chain, T, family=family)
        assert any(same_modulo_2pi(s, q) for s in result.solutions), (q, result.note)
        for s in result.solutions:
            assert pose_gap(pinocchio_pose(robot, base, tip, chain.full(s)), T) < 1e-10
        assert len(result.labels) == len(result.solutions) == len(result.within_limits)
        assert result.within_limits.tolist() == chain.within_limits(result.solutions).tolist()
    return family


def test_ur5_is_found_as_three_parallel_and_every_branch_lands():
    robot = manipkit.load("ur5")
    family = check_every_branch(robot, "base_link", "tool0")
    assert family.kind == "three parallel, two intersecting" and not family.reversed
    assert [r.axes for r in family.evidence] == [(2, 3, 4), (5, 6)]


def test_ur5_from_the_base_frame_above_the_first_joint_and_the_flange():
    robot = manipkit.load("ur5")
    check_every_branch(robot, "base", "tool0", n=20, seed=1)


@needs_realworld
def test_ur5e_description_by_file_path():
    robot = load_realworld(UR5E)
    family = check_every_branch(robot, "base_link", "tool0")
    assert family.kind == "three parallel, two intersecting"


@needs_realworld
def test_abb_irb2400_is_a_spherical_wrist_arm_and_every_branch_lands():
    robot = load_realworld(IRB2400)
    family = check_every_branch(robot, "base_link", "tool0")
    assert family.kind == "spherical wrist, two parallel"
    assert [r.axes for r in family.evidence] == [(4, 5, 6), (2, 3)]


def test_a_generic_pose_of_ur5_has_eight_distinct_labelled_branches():
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    result = chain_ik(chain, chain.fk([0.3, -1.1, 1.2, -0.8, 1.0, 0.4]))
    assert result.count == 8 and len(set(result.labels)) == 8
    assert result.labels[0] == "front, elbow up, no flip"
    assert result.refined.max() == 0.0


@needs_realworld
def test_irb2400_keeps_out_of_limit_branches_marked():
    chain = load_realworld(IRB2400).chain("base_link", "tool0")
    q = np.array([0.2, 0.3, 0.1, 0.5, 0.8, 0.3])
    result = chain_ik(chain, chain.fk(q))
    assert result.count == 8
    assert 0 < result.within_limits.sum() < 8  # the back-shoulder branches break the joint-2/3 limits
    assert "outside the joint limits (marked, not dropped)" in result.note


def test_ur5_at_q5_zero_gives_families_in_q6_on_its_own_shoulder_and_four_regular_rows_on_the_other():
    """By hand: with q5 = 0, axis 6 is parallel to axes 2, 3, 4. On the generating shoulder branch the component of
    the tool's axis 6 along the turned axis 2 is +-1 (a tangency: only q5 = 0), and four parallel joints leave
    q6 free: 2 family rows (elbow up, down). On the other shoulder branch that component is cos(q1 - q1') with |.| < 1:
    two q5 and two elbows each, 4 ordinary rows."""
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    q = np.array([0.3, -1.1, 1.2, -0.8, 0.0, 0.4])
    result = chain_ik(chain, chain.fk(q))
    assert math.isinf(result.count)
    assert result.free_joints == (5,) and result.free_parameter == "wrist_3_joint"
    assert "wrist singular" in result.family
    assert len(result.solutions) == 6
    assert result.residual_position.max() < 1e-10 and result.residual_rotation.max() < 1e-10


@needs_realworld
def test_irb2400_at_q5_zero_names_the_wrist_family():
    """By hand: q5 = 0 aligns axes 4 and 6 for the generating arm branch only (the other arm branches turn the wrist
    centre's frame differently), so exactly one row is a family, free in q4, with q4 + q6 fixed."""
    chain = load_realworld(IRB2400).chain("base_link", "tool0")
    q = np.array([0.2, 0.3, 0.1, 0.5, 0.0, 0.3])
    result = chain_ik(chain, chain.fk(q))
    assert math.isinf(result.count) and result.free_joints == (3,)
    assert "only joint_4 and joint_6 together are determined" in result.family
    family_rows = [s for s in result.solutions if abs(s[4]) < 1e-9]
    assert len(family_rows) >= 1
    # a member of the family: turn q4 by a and q6 by -a (axes 4 and 6 point the same way at q5 = 0)
    member = family_rows[0].copy()
    member[3] += 0.4
    member[5] -= 0.4 * np.sign(chain.axes(member).direction[3] @ chain.axes(member).direction[5])
    assert pose_gap(chain.fk(member), chain.fk(q)) < 1e-10


def test_unreachable_target_names_the_reach_and_by_how_much():
    """A target 1 m beyond the stretched arm: the point where axes 5 and 6 meet moves 1 m out; the wrist-1 point the
    elbow must reach lies within |p4 - c| of it (whatever the wrist branch), so the miss is 1 m give or take that."""
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    axes = chain.axes(np.zeros(6))
    wrist_to_c = float(np.linalg.norm(axes.point[3] - axes.point[5]))  # axis-4 point to the 5/6 meeting point
    T = chain.fk(np.zeros(6))  # fully stretched along the base x axis
    T[0, 3] += 1.0 * np.sign(T[0, 3])
    result = chain_ik(chain, T)
    assert not result.success and result.unmet[0][0] == "reach"
    assert 1.0 - wrist_to_c - 0.01 < result.unmet[0][1] <= 1.0 + 1e-9
    assert result.reason.startswith("no solution: reach: the wrist centre is out of the elbow's reach by")


def test_a_chain_without_a_closed_form_says_what_misses():
    chain = manipkit.load("panda").chain("panda_link0", "panda_link8")
    family = chain_family(chain)
    assert family.kind == "none" and "7 joint(s)" in family.note
    with pytest.raises(ClosedFormIKError, match="no geometric closed form"):
        chain_ik(chain, np.eye(4))


def test_bundled_textbook_arms_are_recognised_by_geometry():
    assert chain_family(manipkit.load("planar_2r").chain("base_link", "ee_link")).kind == "planar"
    assert chain_family(manipkit.load("planar_3r").chain("base_link", "ee_link")).kind == "planar"
    assert chain_family(manipkit.load("scara").chain("base_link", "ee_link")).kind == "scara"


def test_batch_recovers_every_generating_configuration():
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    Q = chain.sample(200, seed=3)
    batch = chain_ik_many(chain, chain.fk(Q))
    assert batch.solutions.shape == (200, 8, 6)
    for q, rows in zip(Q, batch.solutions):
        assert any(same_modulo_2pi(s, q) for s in rows if not np.isnan(s).any())
    found = ~np.isnan(batch.residual_position)
    assert batch.residual_position[found].max() < 1e-10 and batch.residual_rotation[found].max() < 1e-10
    assert batch.success.all()


CALIBRATED_UR5 = """<?xml version="1.0"?>
<robot name="ur5_calibrated">
  <link name="base_link"/> <link name="shoulder_link"/> <link name="upper_arm_link"/> <link name="forearm_link"/>
  <link name="wrist_1_link"/> <link name="wrist_2_link"/> <link name="wrist_3_link"/> <link name="tool0"/>
  <joint name="shoulder_pan_joint" type="revolute"><parent link="base_link"/><child link="shoulder_link"/>
    <origin xyz="0.0001 0 0.089159" rpy="0 0 0"/><axis xyz="0 0.0001 1"/><limit lower="-6.2832" upper="6.2832" effort="1" velocity="1"/></joint>
  <joint name="shoulder_lift_joint" type="revolute"><parent link="shoulder_link"/><child link="upper_arm_link"/>
    <origin xyz="0 0.13585 0" rpy="0 1.5708 0"/><axis xyz="0 1 0"/><limit lower="-6.2832" upper="6.2832" effort="1" velocity="1"/></joint>
  <joint name="elbow_joint" type="revolute"><parent link="upper_arm_link"/><child link="forearm_link"/>
    <origin xyz="0 -0.1197 0.425" rpy="0 0 0"/><axis xyz="0.0001 1 0"/><limit lower="-3.1416" upper="3.1416" effort="1" velocity="1"/></joint>
  <joint name="wrist_1_joint" type="revolute"><parent link="forearm_link"/><child link="wrist_1_link"/>
    <origin xyz="0 0 0.39225" rpy="0 1.5708 0"/><axis xyz="0 1 -0.0001"/><limit lower="-6.2832" upper="6.2832" effort="1" velocity="1"/></joint>
  <joint name="wrist_2_joint" type="revolute"><parent link="wrist_1_link"/><child link="wrist_2_link"/>
    <origin xyz="0.0001 0.093 0" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-6.2832" upper="6.2832" effort="1" velocity="1"/></joint>
  <joint name="wrist_3_joint" type="revolute"><parent link="wrist_2_link"/><child link="wrist_3_link"/>
    <origin xyz="0 0 0.09465" rpy="0 0 0"/><axis xyz="0.0001 1 0"/><limit lower="-6.2832" upper="6.2832" effort="1" velocity="1"/></joint>
  <joint name="tool0_fixed_joint" type="fixed"><parent link="wrist_3_link"/><child link="tool0"/>
    <origin xyz="0 0.0823 0" rpy="0 0 1.5708"/></joint>
</robot>
"""


def test_calibrated_ur5_is_solved_on_its_ideal_arm_refined_and_checked(tmp_path):
    path = tmp_path / "ur5_calibrated.urdf"
    path.write_text(CALIBRATED_UR5)
    robot = manipkit.load(str(path))
    chain = robot.chain("base_link", "tool0")
    family = chain_family(chain)
    assert family.kind == "three parallel, two intersecting" and not family.ideal
    assert 1e-5 < family.deviation < 1e-3
    with pytest.raises(ClosedFormIKError, match="miss"):
        chain_ik(chain, np.eye(4), tol=1e-6)  # beyond the tolerance: the message gives the measured miss
    for q in chain.sample(20, seed=5):
        T = chain.fk(q)
        result = chain_ik(chain, T, family=family)
        assert any(same_modulo_2pi(s, q, 1e-6) for s in result.solutions)
        assert result.refined.min() > 0.0 and "refined by Newton" in result.note
        for s in result.solutions:
            assert pose_gap(pinocchio_pose(robot, "base_link", "tool0", chain.full(s)), T) < 1e-10


def six_r_urdf(name: str, joints: list[tuple[str, str]], tip: str) -> str:
    """A 6R arm: (origin xyz, axis xyz) per joint, each child link following the last, and the tool frame."""
    links = "".join(f'<link name="l{i}"/>' for i in range(7)) + '<link name="tool"/>'
    body = "".join(
        f'<joint name="j{i + 1}" type="revolute"><parent link="l{i}"/><child link="l{i + 1}"/>'
        f'<origin xyz="{origin}"/><axis xyz="{axis}"/><limit lower="-3.1" upper="3.1" effort="1" velocity="1"/></joint>'
        for i, (origin, axis) in enumerate(joints))
    body += f'<joint name="tool_joint" type="fixed"><parent link="l6"/><child link="tool"/><origin xyz="{tip}" rpy="0.3 0.2 0.1"/></joint>'
    return f'<?xml version="1.0"?><robot name="{name}">{links}{body}</robot>'


SPHERICAL_SHOULDER = six_r_urdf("spherical_shoulder", [
    ("0 0 0.3", "0 0 1"), ("0 0 0", "0 1 0"), ("0 0 0", "1 0 0"),  # axes 1, 2, 3 meet: a spherical group at the base
    ("0.05 0 0.4", "0 1 0"), ("0 0 0.35", "0 1 0"), ("0.08 0 0.1", "0 0 1")], "0 0 0.1")  # 4 || 5
INTERSECTING_SHOULDER = six_r_urdf("intersecting_shoulder", [
    ("0 0 0.3", "0 0 1"), ("0 0 0", "0 1 0"),  # axes 1 and 2 meet
    ("0 0.1 0.4", "1 0 0"),  # axis 3 crosses neither
    ("0 0 0.3", "0 0 1"), ("0 0 0", "0 1 0"), ("0 0 0", "0 0 1")], "0 0.02 0.1")  # a spherical wrist


def test_a_spherical_group_at_the_base_is_solved_on_the_chain_read_tip_to_base(tmp_path):
    path = tmp_path / "spherical_shoulder.urdf"
    path.write_text(SPHERICAL_SHOULDER)
    family = check_every_branch(manipkit.load(str(path)), "l0", "tool", n=40)
    assert family.kind == "spherical wrist, two parallel" and family.reversed
    assert [r.axes for r in family.evidence] == [(1, 2, 3), (4, 5)]


def test_a_spherical_wrist_with_meeting_shoulder_axes_is_solved(tmp_path):
    path = tmp_path / "intersecting_shoulder.urdf"
    path.write_text(INTERSECTING_SHOULDER)
    family = check_every_branch(manipkit.load(str(path)), "l0", "tool", n=40)
    assert family.kind == "spherical wrist, two intersecting" and not family.reversed


def test_a_target_just_off_the_ur5_wrist_singularity_is_kept_refined_and_lands():
    """q5 = 1e-7: the tangency of q5 is met within the subproblem tolerance, so the generating shoulder's rows come out
    as the q5 = 0 family's members, then Newton on the chain puts them on the target (before: those rows were lost)."""
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    q = np.array([0.2, 0.3, 0.1, 0.5, 1e-7, 0.3])
    T = chain.fk(q)
    result = chain_ik(chain, T)
    assert len(result.solutions) == 6 and result.free_joints == (5,)
    assert result.residual_position.max() < 1e-10 and result.residual_rotation.max() < 1e-10
    assert result.refined.max() > 0.0


@needs_realworld
def test_irb2400_wrist_centre_on_axis_1_is_a_family_free_in_joint_1():
    """By hand: with the wrist centre on axis 1 (and no lateral offset, b = 0), turning joint 1 keeps it there, so
    joint 1 is free; for each of its values two elbows and two wrists remain: 4 rows, each a family, both shoulder
    choices being members of the same families."""
    from manipkit.ik.ideal_arm import ideal_arm
    from manipkit.spatial.rotations import matrix_from_rpy

    chain = load_realworld(IRB2400).chain("base_link", "tool0")
    family = chain_family(chain)
    centre = ideal_arm(family).points["wrist"]
    centre_in_tool = (np.linalg.inv(family.geometry.M) @ np.r_[centre, 1.0])[:3]
    T = np.eye(4)
    T[:3, :3] = matrix_from_rpy([0.3, 2.5, 0.2])
    T[:3, 3] = np.array([0.0, 0.0, 1.3]) - T[:3, :3] @ centre_in_tool  # wrist centre at (0, 0, 1.3): on axis 1
    result = chain_ik(chain, T, family=family)
    assert math.isinf(result.count) and result.free_joints == (0,) and len(result.solutions) == 4
    assert "shoulder singular (the wrist centre on axis 1): joint_1 is free" in result.family
    assert result.residual_position.max() < 1e-10 and result.residual_rotation.max() < 1e-10


@needs_realworld
def test_irb2400_opw_parameters_are_those_ros_industrial_publishes_and_reproduce_its_fk():
    """ROS-Industrial's opw_kinematics lists the IRB2400/10 as a1 0.100, a2 -0.135, b 0, c1 0.615, c2 0.705,
    c3 0.755, c4 0.085, offsets [0, 0, -pi/2, 0, 0, 0], signs all +1."""
    from manipkit.ik.opw import opw_fk, opw_parameters

    chain = load_realworld(IRB2400).chain("base_link", "tool0")
    p = opw_parameters(chain)
    got = [p.a1, p.a2, p.b, p.c1, p.c2, p.c3, p.c4]
    assert np.allclose(got, [0.1, -0.135, 0.0, 0.615, 0.705, 0.755, 0.085], atol=1e-9)
    assert np.allclose(p.offsets, [0, 0, -np.pi / 2, 0, 0, 0], atol=1e-9) and p.sign_corrections == (1,) * 6
    for q in chain.sample(10, seed=2):
        assert np.abs(opw_fk(p, q) - chain.fk(q)).max() < 1e-9


def test_opw_parameters_refuse_a_ur_arm_by_family():
    from manipkit.ik.opw import opw_parameters

    with pytest.raises(ClosedFormIKError, match="not a spherical wrist with axes 2 \\|\\| 3"):
        opw_parameters(manipkit.load("ur5").chain("base_link", "tool0"))


def test_iiwa14_with_joint_3_locked_is_a_spherical_wrist_arm_with_meeting_shoulder_axes():
    robot = manipkit.load("iiwa14")
    chain = robot.chain("base_link", "ee_link")
    family = chain_family(chain, lock={"iiwa_joint_3": 0.4})
    assert family.kind == "spherical wrist, two intersecting" and family.locked == (("iiwa_joint_3", 0.4),)
    for q in chain.sample(30, seed=4):
        q[2] = 0.4
        T = chain.fk(q)
        result = chain_ik(chain, T, family=family)
        assert any(same_modulo_2pi(s, q) for s in result.solutions)
        assert np.all(result.solutions[:, 2] == 0.4)
        for s in result.solutions:
            assert pose_gap(pinocchio_pose(robot, "base_link", "ee_link", chain.full(s)), T) < 1e-10


def test_panda_with_joint_7_locked_is_solved_read_tip_to_base():
    robot = manipkit.load("panda")
    chain = robot.chain("panda_link0", "panda_link8")
    family = chain_family(chain, lock={"panda_joint7": 0.3})
    assert family.kind == "spherical wrist, two intersecting" and family.reversed
    for q in chain.sample(30, seed=6):
        q[6] = 0.3
        T = chain.fk(q)
        result = chain_ik(chain, T, family=family)
        assert any(same_modulo_2pi(s, q) for s in result.solutions)
        for s in result.solutions:
            assert pose_gap(pinocchio_pose(robot, "panda_link0", "panda_link8", chain.full(s)), T) < 1e-10



MORE = next((base / "shared" / "realworld" / "ws_more" / "src" for base in Path(__file__).resolve().parents[2:4]
             if (base / "shared" / "realworld").is_dir()), Path("/nonexistent"))
XSARMS = "interbotix_ros_manipulators/interbotix_ros_xsarms/interbotix_xsarm_descriptions/urdf"


@pytest.mark.skipif(not MORE.is_dir(), reason="the shared real-world workspace ws_more is not here")
@pytest.mark.parametrize("relative, args, base, tip, lock, kind", [
    (f"{XSARMS}/vx300s.urdf.xacro", {}, "vx300s/base_link", "vx300s/ee_gripper_link", None,
     "spherical wrist, two parallel"),
    (f"{XSARMS}/wx250s.urdf.xacro", {}, "wx250s/base_link", "wx250s/ee_gripper_link", None,
     "spherical wrist, two parallel"),
    ("xarm_ros2/xarm_description/urdf/xarm_device.urdf.xacro", {"dof": "6", "robot_type": "lite"}, "world", "link_eef",
     None, "spherical wrist, two parallel"),  # its wrist axes miss meeting by 1.1e-7 m: solved on the ideal arm
    ("franka_description/robots/fr3/fr3.urdf.xacro", {}, "base", "fr3_hand_tcp", {"fr3_joint7": 0.3},
     "spherical wrist, two intersecting"),  # read tip to base
])
def test_the_arms_of_the_second_workspace_land_every_branch_by_pinocchio(relative, args, base, tip, lock, kind):
    """The closed-form arms among ws_more's descriptions (Interbotix, xArm Lite 6, FR3 with a joint held), loaded by
    file path as their users load them: every branch of 25 random in-limit configurations' poses lands by
    Pinocchio to 1e-10 and the generating configuration is among them; the batch's slots land too, except the
    xArm's, which are not refined and whose residuals say how far they miss (Pinocchio's miss, to 1e-12)."""
    from manipkit.ik.ideal_arm import ideal_arm

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = manipkit.load(str(MORE / relative), **args)
    chain = robot.chain(base, tip)
    family = chain_family(chain, lock=lock)
    assert family.kind == kind and family.solved, family.note
    Q = chain.sample(25, seed=11)
    for name, value in (lock or {}).items():
        Q[:, chain.joint_names.index(name)] = value
    T = chain.fk(Q)
    for q, target in zip(Q, T):
        result = chain_ik(chain, target, family=family)
        assert any(same_modulo_2pi(s, q) for s in result.solutions), result.note
        for s in result.solutions:
            assert pose_gap(pinocchio_pose(robot, base, tip, chain.full(s)), target) < 1e-10
    batch = chain_ik_many(chain, T, family=family)
    exact = ideal_arm(family).moved < 1e-12  # the xArm's rows in a batch carry its ideal arm's miss (not refined)
    for i, k in zip(*np.nonzero(~np.isnan(batch.solutions[..., 0]))):
        reached = pinocchio_pose(robot, base, tip, chain.full(batch.solutions[i, k]))
        assert abs(np.linalg.norm(reached[:3, 3] - T[i, :3, 3]) - batch.residual_position[i, k]) < 1e-12  # says so
        assert pose_gap(reached, T[i]) < (1e-10 if exact else 1e-4)
    assert batch.success.all() == exact

def test_locking_a_joint_the_chain_does_not_have_names_the_joints():
    chain = manipkit.load("iiwa14").chain("base_link", "ee_link")
    with pytest.raises(ClosedFormIKError, match="cannot lock 'elbow': it is not a joint of the chain base_link -> ee_link"):
        chain_family(chain, lock={"elbow": 0.1})


def test_iiwa14_is_an_srs_arm_and_every_configuration_is_found_at_its_own_arm_angle():
    from manipkit.ik.chain_ik import srs_arm_angle

    robot = manipkit.load("iiwa14")
    chain = robot.chain("base_link", "ee_link")
    family = chain_family(chain)
    assert family.kind == "spherical shoulder, elbow, spherical wrist"
    assert [r.axes for r in family.evidence] == [(1, 2, 3), (5, 6, 7)]
    for q in chain.sample(40, seed=8):
        T = chain.fk(q)
        psi = srs_arm_angle(chain, q, family=family)
        result = chain_ik(chain, T, family=family, arm_angle=psi)
        assert any(same_modulo_2pi(s, q) for s in result.solutions)
        assert len(set(result.labels)) == len(result.labels) <= 8
        for s in result.solutions:
            assert pose_gap(pinocchio_pose(robot, "base_link", "ee_link", chain.full(s)), T) < 1e-10
            assert abs(math.remainder(srs_arm_angle(chain, s, family=family) - psi, 2 * math.pi)) < 1e-8


def test_an_iiwa14_configuration_with_the_elbow_straight_is_found_at_its_own_arm_angle():
    """With q4 = 0 the elbow lies on the shoulder-wrist line, so its plane is not defined; srs_arm_angle still gives
    the angle whose solutions list q (turning joint 3 by pi would give another angle, whose rows are q's twin with
    t3 + pi and the wrist turned: found by a test of the batch, seed 0)."""
    from manipkit.ik.chain_ik import srs_arm_angle

    chain = manipkit.load("iiwa14").chain("base_link", "ee_link")
    Q = chain.sample(30, seed=0)
    Q[:, 3] = 0.0
    for q in Q:
        result = chain_ik(chain, chain.fk(q), arm_angle=srs_arm_angle(chain, q))
        assert any(same_modulo_2pi(s, q) for s in result.solutions), q


def test_the_arm_angles_of_a_stack_are_each_row_s_own():
    """srs_arm_angle of (N, n) rows, one vectorised pass, against one row at a time (elbow straight included), and
    each row is listed by the closed form at its angle."""
    from manipkit.ik.chain_ik import srs_arm_angle

    chain = manipkit.load("iiwa14").chain("base_link", "ee_link")
    Q = chain.sample(40, seed=3)
    Q[::5, 3] = 0.0
    psi = srs_arm_angle(chain, Q)
    assert psi.shape == (40,)
    np.testing.assert_allclose(psi, [srs_arm_angle(chain, q) for q in Q], rtol=0, atol=1e-12)
    for q, angle in zip(Q, psi):
        assert any(same_modulo_2pi(s, q) for s in chain_ik(chain, chain.fk(q), arm_angle=float(angle)).solutions)


def test_the_compiled_arm_angles_are_the_reference_s():
    """From ARM_ANGLES_COMPILED_FROM rows on srs_arm_angle takes the compiled pass: against the numpy reference on
    3,000 iiwa14 rows (random; the elbow straight, where the second shoulder turn fixes v too; q2 = q4 = 0, the
    wrist centre on axis 1, where subproblem 2 is free and the pass must hand the row back), and each compiled
    angle lists its row by the closed form."""
    from manipkit.closed_form.srs_kernel import arm_angles_into
    from manipkit.ik.chain_ik import ARM_ANGLES_COMPILED_FROM, srs_arm_angle
    from manipkit.ik.families import chain_family
    from manipkit.ik.ideal_arm import compiled_arm, ideal_arm

    chain = manipkit.load("iiwa14").chain("base_link", "ee_link")
    family = chain_family(chain)
    arm = ideal_arm(family)
    Q = chain.sample(3000, seed=41)
    Q[:500, 3] = 0.0
    Q[500:600, 1] = Q[500:600, 3] = 0.0
    assert len(Q) >= ARM_ANGLES_COMPILED_FROM
    psi = srs_arm_angle(chain, Q)
    reference = srs_arm_angle(chain, Q, compiled=False)
    gap = np.abs(np.remainder(psi - reference + np.pi, 2 * np.pi) - np.pi)
    # the angle's own sensitivity: about 1e-15 rad; near the shoulder's singularity up to about 1e-13
    assert gap.max() < 1e-12 and np.median(gap) < 1e-15
    compiled, fallback = np.empty(len(Q)), np.empty(len(Q), dtype=bool)
    arm_angles_into(compiled_arm(chain, arm), np.ascontiguousarray(chain.fk(Q)), Q, compiled, fallback)
    assert fallback[500:600].all() and not fallback[:500].any() and fallback.sum() < 150
    assert np.isnan(compiled[fallback]).all() and np.array_equal(compiled[~fallback], psi[~fallback])
    for q, angle in zip(Q[~fallback][::60], psi[~fallback][::60]):  # the handed-back rows are singular targets
        assert any(same_modulo_2pi(s, q) for s in chain_ik(chain, chain.fk(q), arm_angle=float(angle)).solutions)


def test_an_srs_arm_without_an_arm_angle_says_what_to_give():
    chain = manipkit.load("iiwa14").chain("base_link", "ee_link")
    with pytest.raises(ClosedFormIKError, match="give arm_angle"):
        chain_ik(chain, chain.fk(np.zeros(7)))


def test_ur5_with_the_elbow_straight_has_seven_solutions():
    """By hand: q3 = 0 puts the axis-4 point at the elbow's full reach for the generating shoulder and wrist
    choice: its two elbows coincide (a tangency, 1 row). The other wrist choice moves that point inside the reach
    (2 elbows), and the other shoulder gives 2 wrists x 2 elbows: 1 + 2 + 4 = 7."""
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    q = np.array([0.2, 0.3, 0.0, 0.5, 0.8, 0.3])
    result = chain_ik(chain, chain.fk(q))
    assert result.count == 7 and any(same_modulo_2pi(s, q) for s in result.solutions)
    assert result.residual_position.max() < 1e-10 and result.residual_rotation.max() < 1e-10


def test_dropping_colliding_branches_keeps_the_per_row_fields_with_their_rows():
    from manipkit.ik.collision_marks import mark_collisions
    from manipkit.ik.textbook import analytic_ik
    from manipkit.kinematics.collisions import CollisionChecker

    robot = manipkit.load("ur5")
    chain = robot.chain("base_link", "tool0")
    result = analytic_ik(robot, chain.fk([0.3, -1.1, 1.2, -0.8, 1.0, 0.4]), "base_link", "tool0")
    kept = mark_collisions(result, CollisionChecker(robot, srdf="none"), drop=True)  # every pair but adjacent ones
    assert 0 < len(kept.solutions) < len(result.solutions)  # one branch puts the arm through itself
    assert len(kept.within_limits) == len(kept.refined) == len(kept.labels) == len(kept.solutions)
    for label, q in zip(kept.labels, kept.solutions):
        assert np.array_equal(q, result.solutions[result.labels.index(label)])


# --------------------------------------------------------------------------
# chain_ik_many on threads (issue 22's batched speed): the same answers, bit for bit, on any number of threads


def previous_batch(chain, T, check=(1e-10, 1e-10)):
    """The batched check as it was before it ran in blocks on threads (one solve, chain.fk of every slot with the
    empty ones filled by 0, measure_many): (solutions, count, success, residuals) to compare bit for bit."""
    from manipkit.closed_form.arms_kernel import measure_many, solve_rows_many
    from manipkit.ik.chain_ik import _projected_target, _reference_rows
    from manipkit.ik.ideal_arm import compiled_arm, ideal_arm

    arm = ideal_arm(chain_family(chain))
    valid, fallback, project, Q = solve_rows_many(compiled_arm(chain, arm), T)
    free_any = np.zeros(len(T), dtype=bool)
    if fallback.any():  # the numpy reference's rows (unchanged by the blocks and threads)
        rows = np.flatnonzero(fallback)
        valid[rows], free_any[rows], Q[rows] = _reference_rows(chain, arm, T[rows], None)
    T_check = T.copy()
    T_check[project] = _projected_target(T[project])
    missing = np.isnan(Q[..., 0])
    residuals, success = measure_many(T_check, chain.fk(np.where(missing[..., None], 0.0, Q)), Q, check)
    return Q, np.where(free_any, np.inf, valid.sum(axis=-1).astype(float)), success, residuals


def batch_targets(chain, seed: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(Q, T): FK of ``n`` random in-limit configurations, then one target whose rotation block is 1e-9 off a
    rotation (projected before it is measured; its rows miss by about that) and one with q5 = 0 (UR5, IRB2400:
    the wrist singularity, handed to the numpy reference, a family)."""
    Q = chain.sample(n + 2, seed=seed)
    Q[-1, 4] = 0.0
    T = chain.fk(Q)
    T[-2, :3, :3] *= 1.0 + 1e-9
    return Q, T


def assert_same_for_any_thread_count(robot, base, tip, seed, n, monkeypatch, *, q5_singular=True):
    from manipkit.ik import chain_batch

    monkeypatch.setattr(chain_batch, "BLOCK", 3)  # many blocks and threads even for a small batch
    monkeypatch.setattr(chain_batch, "MIN_TARGETS_PER_THREAD", 1)
    chain = robot.chain(base, tip)
    Q, T = batch_targets(chain, seed, n)
    before = previous_batch(chain, T)
    for threads in (1, 2, 3):
        batch = chain_ik_many(chain, T, threads=threads)
        now = (batch.solutions, batch.count, batch.success, batch.residuals)
        for a, b in zip(now, before):
            assert np.array_equal(a, b, equal_nan=True), threads
    present = ~np.isnan(batch.solutions[..., 0])
    assert np.isinf(batch.count[-1]) == q5_singular and batch.success[:-2].all()
    for i, (q, rows) in enumerate(zip(Q[:n], batch.solutions[:n])):
        assert any(same_modulo_2pi(s, q) for s in rows[present[i]])
    assert not np.isnan(batch.residual_position[n][present[n]]).any()  # the target off a rotation: measured, not solved
    for i, k in zip(*np.nonzero(present)):  # every returned slot of a rigid target, by Pinocchio itself
        if i != n:
            assert pose_gap(pinocchio_pose(robot, base, tip, chain.full(batch.solutions[i, k])), T[i]) < 1e-10


_BATCH_SETTINGS = dict(max_examples=12, deadline=None)


@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 9))
@settings(**_BATCH_SETTINGS, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_ur5_batch_is_the_same_bit_for_bit_on_any_number_of_threads(seed, n, monkeypatch):
    assert_same_for_any_thread_count(manipkit.load("ur5"), "base_link", "tool0", seed, n, monkeypatch)


@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 9))
@settings(**_BATCH_SETTINGS, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_kinova_batch_is_the_same_bit_for_bit_on_any_number_of_threads(seed, n, monkeypatch):
    assert_same_for_any_thread_count(manipkit.load("kinova"), "base", "j2s6s200_end_effector", seed, n, monkeypatch,
                                     q5_singular=False)  # its wrist aligns elsewhere: q5 = 0 is a regular target


@needs_realworld
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 9))
@settings(**_BATCH_SETTINGS, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_irb2400_batch_is_the_same_bit_for_bit_on_any_number_of_threads(seed, n, monkeypatch):
    assert_same_for_any_thread_count(load_realworld(IRB2400), "base_link", "tool0", seed, n, monkeypatch)



def srs_batch_targets(chain, seed: int, n: int):
    """(Q, T, psi): FK of ``n`` random in-limit iiwa14 configurations, each target at its own arm angle, then one
    with the elbow straight (q4 = 0: the shoulder-wrist distance at its largest, handed to the numpy reference) and
    one with the wrist's axes 5 and 7 aligned (q6 = 0: a family in t5)."""
    from manipkit.ik.chain_ik import srs_arm_angle

    Q = chain.sample(n + 2, seed=seed)
    Q[-2, 3], Q[-1, 5] = 0.0, 0.0
    psi = np.array([srs_arm_angle(chain, q) for q in Q])
    return Q, chain.fk(Q), psi


@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 9))
@settings(**_BATCH_SETTINGS, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_iiwa14_batch_at_arm_angles_gives_the_single_calls_rows_bit_for_bit_on_any_number_of_threads(seed, n,
                                                                                                      monkeypatch):
    """chain_ik_many of a 7R SRS arm, each target at its own arm angle: the same arrays on 1, 2 and 3 threads; every
    slot's row is one of chain_ik's rows for that target bit for bit (or a repeat modulo 2 pi it dropped); the
    generating configuration is among them; every slot lands by Pinocchio; the wrist-aligned target is a family
    (count inf), as chain_ik says."""
    from manipkit.ik import chain_batch

    monkeypatch.setattr(chain_batch, "BLOCK", 3)
    monkeypatch.setattr(chain_batch, "MIN_TARGETS_PER_THREAD", 1)
    robot = manipkit.load("iiwa14")
    chain = robot.chain("base_link", "ee_link")
    Q, T, psi = srs_batch_targets(chain, seed, n)
    batches = [chain_ik_many(chain, T, arm_angle=psi, threads=threads) for threads in (1, 2, 3)]
    for batch in batches[1:]:
        for field in ("solutions", "count", "success", "residuals"):
            assert np.array_equal(getattr(batch, field), getattr(batches[0], field), equal_nan=True), field
    batch = batches[0]
    assert batch.solutions.shape == (n + 2, 8, 7) and batch.labels[1] == "elbow a, shoulder a, wrist b"
    assert batch.success.all() and np.isinf(batch.count[-1]) and np.isfinite(batch.count[:-1]).all()
    for i, (q, rows) in enumerate(zip(Q, batch.solutions)):
        single = chain_ik(chain, T[i], arm_angle=psi[i])
        present = rows[~np.isnan(rows[:, 0])]
        assert len(present) == batch.count[i] or np.isinf(batch.count[i])
        if np.isfinite(batch.count[i]):  # not the family: its rows stand for q with t5 = 0 (q5 + q7 determined)
            assert any(same_modulo_2pi(s, q) for s in present)
        assert np.isinf(single.count) == np.isinf(batch.count[i])
        for s in present:
            assert any(np.array_equal(s, r) for r in single.solutions) or any(same_modulo_2pi(s, r) for r in single.solutions)
            assert pose_gap(pinocchio_pose(robot, "base_link", "ee_link", chain.full(s)), T[i]) < 1e-10


def test_iiwa14_batch_by_the_numpy_reference_gives_the_compiled_rows_to_rounding():
    chain = manipkit.load("iiwa14").chain("base_link", "ee_link")
    _, T, psi = srs_batch_targets(chain, 21, 30)
    compiled, reference = chain_ik_many(chain, T, arm_angle=psi), chain_ik_many(chain, T, arm_angle=psi, compiled=False)
    assert np.array_equal(np.isnan(compiled.solutions), np.isnan(reference.solutions))
    assert np.nanmax(np.abs(compiled.solutions - reference.solutions)) < 1e-9
    assert np.array_equal(compiled.count, reference.count) and reference.success.all()


def test_an_srs_batch_takes_one_arm_angle_or_one_per_target_and_says_what_is_wrong():
    from manipkit.errors import IKOptionError

    robot = manipkit.load("iiwa14")
    chain = robot.chain("base_link", "ee_link")
    _, T, _ = srs_batch_targets(chain, 4, 3)
    one, each = chain_ik_many(chain, T, arm_angle=0.4), chain_ik_many(chain, T, arm_angle=np.full(len(T), 0.4))
    assert np.array_equal(one.solutions, each.solutions, equal_nan=True)
    for value, words in ((None, "give arm_angle"), ([0.1, 0.2], r"one number \(rad\) or 5 of them"),
                         (np.nan, "must be finite"), ("left", "must be a number"), ("0.5", "must be a number"),
                         (True, "must be a number"), (1j, "must be a number"), ([[0.1], [0.2, 0.3]], "must be a number"),
                         (np.zeros((5, 1)), "shape")):
        with pytest.raises(ClosedFormIKError, match=words):
            chain_ik_many(chain, T, arm_angle=value)
    with pytest.raises(IKOptionError, match=r"5 of them"):
        analytic_ik_many(robot, T, arm_angle=[0.1, 0.2])
    with pytest.raises(IKOptionError, match="without an arm angle"):
        analytic_ik_many(robot, T)
    with pytest.raises(ClosedFormIKError, match="must be a number"):  # the single call refuses it the same way
        chain_ik(chain, T[0], arm_angle="left")
    from manipkit.ik.chain_ik import srs_arm_angle

    q = chain.sample(1, seed=1)[0]
    q[5] = 0.0  # the wrist's axes 5 and 7 aligned: handed to the general path, which words the angle in its note
    psi = srs_arm_angle(chain, q)
    expected = chain_ik(chain, chain.fk(q), arm_angle=psi)
    assert np.isinf(expected.count)
    for angle in ([psi], np.array([psi]), np.float64(psi)):  # one number however given (a list used to raise TypeError)
        answer = chain_ik(chain, chain.fk(q), arm_angle=angle)
        assert np.array_equal(answer.solutions, expected.solutions) and answer.note == expected.note

def test_a_batch_big_enough_for_both_threads_by_default_gives_the_one_thread_answer():
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    _, T = batch_targets(chain, 5, 2000)
    one, default = chain_ik_many(chain, T, threads=1), chain_ik_many(chain, T)
    for field in ("solutions", "count", "success", "residuals"):
        assert np.array_equal(getattr(one, field), getattr(default, field), equal_nan=True), field


@pytest.mark.parametrize("threads", [0, -1, 1.5, True, "2"])
def test_threads_must_be_a_whole_number_of_at_least_one(threads):
    from manipkit.errors import IKOptionError

    chain = manipkit.load("ur5").chain("base_link", "tool0")
    with pytest.raises(IKOptionError, match="threads must be a whole number"):
        chain_ik_many(chain, np.eye(4)[None], threads=threads)


def test_an_error_in_a_block_is_raised_in_the_calling_thread_after_the_running_blocks_finish(monkeypatch):
    import threading
    import time

    from manipkit.ik import chain_batch

    monkeypatch.setattr(chain_batch, "BLOCK", 2)
    monkeypatch.setattr(chain_batch, "MIN_TARGETS_PER_THREAD", 1)
    lock, started, finished = threading.Lock(), [], []

    def work(a, b):
        with lock:
            started.append(a)
        if a == 4:
            raise ValueError("block 4")
        time.sleep(0.002)
        with lock:
            finished.append(a)

    with pytest.raises(ValueError, match="block 4"):
        chain_batch._run_blocks(work, 40, 2)
    assert 4 in started and sorted(finished) == sorted(set(started) - {4})  # nothing still running

def same_answer(a, b) -> bool:
    """Every field of two IK results equal (arrays: same dtype, shape and values, both read-only)."""
    import dataclasses

    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            if not (isinstance(y, np.ndarray) and x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True)
                    and not x.flags.writeable and not y.flags.writeable):
                return False
        elif x != y:
            return False
    return True


def test_single_solver_is_made_once_per_chain_and_family_and_answers_as_chain_ik():
    from manipkit.ik.chain_ik import single_solver

    chain = manipkit.load("ur5").chain("base_link", "tool0")
    family = chain_family(chain)
    solver = single_solver(chain, family)
    assert single_solver(chain, family) is solver
    assert single_solver(chain, chain_family(chain, tol=(2e-3, 2e-3))) is not solver  # another family object
    stretched = chain.fk(np.zeros(6))
    stretched[0, 3] += np.sign(stretched[0, 3])  # 1 m beyond reach
    targets = [chain.fk([0.3, -1.1, 1.2, -0.8, 1.0, 0.4]),  # generic: the compiled call
               chain.fk([0.3, -1.1, 1.2, -0.8, 0.0, 0.4]),  # wrist singular: the general path's family rows
               stretched]  # unreachable: reach named
    for T in targets:
        answer = solver.solve(T, (1e-10, 1e-10))
        assert same_answer(answer, chain_ik(chain, T, family=family))
        assert same_answer(answer, chain_ik(chain, T))  # the family found again: the same answer
        for T_other in (np.asfortranarray(T), T.tolist()):  # not the compiled call's layout: the general path
            other = chain_ik(chain, T_other, family=family)
            assert other.labels == answer.labels and other.note == answer.note and other.count == answer.count
            assert np.allclose(other.solutions, answer.solutions, atol=1e-12, rtol=0.0)
    assert math.isinf(solver.solve(targets[1], (1e-10, 1e-10)).count)
    assert solver.solve(targets[2], (1e-10, 1e-10)).unmet[0][0] == "reach"


def test_compiled_single_calls_word_their_notes_as_the_general_path_with_and_without_rows_outside_the_limits():
    """Kinova's limited joints put some branches outside the limits: the compiled call's note (kept per pattern of
    within_limits) says as many as the numpy reference's, which words each note itself."""
    chain = manipkit.load("kinova").chain("base", "j2s6s200_end_effector")
    family = chain_family(chain)
    outside_seen = set()
    for q in chain.sample(40, seed=21):
        T = chain.fk(q)
        fast, reference = chain_ik(chain, T, family=family), chain_ik(chain, T, family=family, compiled=False)
        assert fast.note == reference.note and fast.labels == reference.labels
        assert np.array_equal(fast.within_limits, reference.within_limits)
        outside = int((~fast.within_limits).sum())
        assert (f"{outside} outside the joint limits" in fast.note) == (outside > 0)
        outside_seen.add(outside)
    assert 0 in outside_seen and len(outside_seen) > 1  # both kinds of note were made and read back


def test_a_dropped_branch_says_by_how_much_it_missed_in_numbers_that_exceed_the_tolerance():
    """check_tol of 1e-300 m and rad: no double-precision FK meets it, so branches are dropped; the sentence must
    give each miss as a number beyond the tolerance it names (it once printed 'missed by 0 > check_tol')."""
    import re

    chain = manipkit.load("ur5").chain("base_link", "tool0")
    T = chain.fk(np.array([0.3, -1.1, 1.4, -0.5, 0.9, 0.2]))
    result = chain_ik(chain, T, check_tol=1e-300)
    match = re.search(r"FK missed by up to (\S+) m and (\S+) rad, beyond check_tol \((\S+) m, (\S+) rad\)", result.note)
    assert match, result.note
    p, r, tol_p, tol_r = (float(x) for x in match.groups())
    assert (tol_p, tol_r) == (1e-300, 1e-300)
    assert max(p, r) > 1e-300 and max(p, r) < 1e-12
