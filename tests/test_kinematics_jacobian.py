"""Frame Jacobians (kinematics.jacobian) against Pinocchio, central differences of Robot.transform and hand values."""

import dataclasses

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import manipkit
from manipkit.errors import JointValueError, ManipkitError, UnknownFrameError
from manipkit.kernels.program import JacobianProgram
from manipkit.kinematics.jacobian import jacobian, jacobians, mass_matrix, rpy_rate_matrix
from manipkit.spatial.rotations import matrix_from_rpy, rpy_from_matrix

ROBOTS = ["planar_2r", "planar_3r", "course_arm", "scara", "stanford_arm", "elbow_arm", "iiwa14",
          "mobile_manipulator", "panda", "ur5"]


def pinocchio_jacobian(robot, q, frame, reference):
    """Pinocchio's frame Jacobian (``reference`` a pin.ReferenceFrame) of ``frame`` at ``q``, in joint_names columns.

    Pinocchio's model has every URDF joint; a mimic joint's column (the Panda's second finger) is added to its
    leader's with the multiplier (``v = S qdot``; the mimic test below checks the fold against ``mimic=True``).
    """
    config = robot.pinocchio_configuration(q)
    data = robot.model.createData()
    pin.computeJointJacobians(robot.model, data, config)
    pin.framesForwardKinematics(robot.model, data, config)
    J = pin.getFrameJacobian(robot.model, data, robot.frame_id(frame), reference)
    return J @ robot.velocity_map()


def skew_vee(W):
    return np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]]) / 2


def central_difference_jacobian(robot, q, frame, base, reference="base", h=1e-6):
    """(v, w) columns from robot.transform(base, frame, q +- h e_j): v = dp/dq, [w]x = dR/dq R^T (R^T dR for local)."""
    q = np.asarray(q, dtype=float)
    R = robot.transform(base, frame, q)[:3, :3]
    J = np.zeros((6, len(q)))
    for j in range(len(q)):
        step = np.zeros(len(q))
        step[j] = h
        T_plus, T_minus = robot.transform(base, frame, q + step), robot.transform(base, frame, q - step)
        dp, dR = (T_plus[:3, 3] - T_minus[:3, 3]) / (2 * h), (T_plus[:3, :3] - T_minus[:3, :3]) / (2 * h)
        if reference == "base":
            J[:3, j], J[3:, j] = dp, skew_vee(dR @ R.T)
        else:
            J[:3, j], J[3:, j] = R.T @ dp, skew_vee(R.T @ dR)
    return J


@pytest.mark.parametrize("name", ROBOTS)
def test_equals_pinocchio_local_world_aligned_and_local(load_robot, name):
    robot = load_robot(name)
    Q = robot.sample_q(25, seed=3)
    J_base = jacobians(robot, Q, base=robot.root_link, tip="ee_link")
    J_local = jacobians(robot, Q, base=robot.root_link, tip="ee_link", reference="local")
    for k, q in enumerate(Q):
        np.testing.assert_allclose(J_base[k], pinocchio_jacobian(robot, q, "ee_link", pin.LOCAL_WORLD_ALIGNED),
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose(J_local[k], pinocchio_jacobian(robot, q, "ee_link", pin.LOCAL), rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", ["iiwa14", "stanford_arm", "scara", "panda"])
@pytest.mark.parametrize("reference", ["base", "local"])
def test_equals_central_differences_of_transform(load_robot, name, reference):
    robot = load_robot(name)
    for q in robot.sample_q(5, seed=4):
        expected = central_difference_jacobian(robot, q, "ee_link", "base_link", reference)
        np.testing.assert_allclose(jacobian(robot, q, reference=reference), expected, rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", ["iiwa14", "course_arm", "mobile_manipulator"])
def test_batched_equals_single(load_robot, name):
    robot = load_robot(name)
    Q = robot.sample_q(40, seed=5).reshape(4, 10, -1)  # any leading shape
    J = jacobians(robot, Q, reference="local")
    assert J.shape == (4, 10, 6, len(robot.joint_names))
    for index in np.ndindex(4, 10):
        np.testing.assert_allclose(J[index], jacobian(robot, Q[index], reference="local"), rtol=0, atol=1e-12)


def test_more_rows_than_one_block_of_the_kernel(iiwa14):
    from manipkit.kernels.program import BLOCK

    Q = iiwa14.sample_q(BLOCK + 3, seed=6)
    J = jacobians(iiwa14, Q)
    for k in (0, BLOCK - 1, BLOCK, BLOCK + 2):
        np.testing.assert_allclose(J[k], pinocchio_jacobian(iiwa14, Q[k], "ee_link", pin.LOCAL_WORLD_ALIGNED),
                                   rtol=0, atol=1e-12)


def relative_jacobian_from_pinocchio(robot, q, frame, base, reference):
    """Velocity of ``frame`` relative to ``base`` from Pinocchio's WORLD Jacobians (spatial twists at the root origin).

    The relative spatial twist in the root is V_f - V_b; moved into the base by Ad(T_root_base^-1) it is
    (v0, w) in base axes with v0 the velocity of the point at the base origin; the frame's origin at
    p (in the base) moves with v0 + w x p. Local: both turned by R_base_frame^T.
    """
    config = robot.pinocchio_configuration(q)
    data = robot.model.createData()
    pin.computeJointJacobians(robot.model, data, config)
    pin.framesForwardKinematics(robot.model, data, config)
    J_f = pin.getFrameJacobian(robot.model, data, robot.frame_id(frame), pin.WORLD)
    J_b = pin.getFrameJacobian(robot.model, data, robot.frame_id(base), pin.WORLD)
    S = robot.velocity_map()  # mimic columns onto their leaders (see pinocchio_jacobian)
    V = data.oMf[robot.frame_id(base)].inverse().toActionMatrix() @ (J_f - J_b) @ S
    T_base_frame = robot.transform(base, frame, q)
    p, R = T_base_frame[:3, 3], T_base_frame[:3, :3]
    v = V[:3] + np.cross(V[3:].T, p).T
    J = np.vstack([v, V[3:]])
    if reference == "local":
        J = np.vstack([R.T @ J[:3], R.T @ J[3:]])
    return J


@pytest.mark.parametrize(("name", "frame", "base"), [
    ("iiwa14", "ee_link", "iiwa_link_3"),  # base above the frame: one chain
    ("mobile_manipulator", "ee_link", "base_link"),  # a real base_link below the root
    ("panda", "panda_rightfinger", "panda_leftfinger"),  # another branch: one chain, up and down
    ("iiwa14", "iiwa_link_2", "ee_link"),  # base below the frame
    ("ur5", "ee_link", "shoulder_link"),
])
@pytest.mark.parametrize("reference", ["base", "local"])
def test_non_root_base(load_robot, name, frame, base, reference):
    robot = load_robot(name)
    Q = robot.sample_q(6, seed=7)
    J = jacobians(robot, Q, base=base, tip=frame, reference=reference)
    for k, q in enumerate(Q):
        np.testing.assert_allclose(J[k], relative_jacobian_from_pinocchio(robot, q, frame, base, reference),
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose(J[k], central_difference_jacobian(robot, q, frame, base, reference),
                                   rtol=0, atol=1e-6)


def test_joints_above_the_base_have_zero_columns(iiwa14):
    J = jacobian(iiwa14, iiwa14.sample_q(1, seed=8)[0], base="iiwa_link_3", tip="ee_link")
    assert np.all(J[:, :3] == 0.0)
    assert np.all(np.linalg.norm(J[:, 3:], axis=0) > 0.0)


def test_planar_2r_by_hand(planar_2r):
    # 2R with l1 = l2 = 1 in the xy plane: p = (c1 + c12, s1 + s12), so
    # dp/dq1 = (-s1 - s12, c1 + c12), dp/dq2 = (-s12, c12); both joints turn about z.
    q1, q2 = 0.4, -1.1
    s1, c1, s12, c12 = np.sin(q1), np.cos(q1), np.sin(q1 + q2), np.cos(q1 + q2)
    expected = np.array([[-s1 - s12, -s12], [c1 + c12, c12], [0, 0], [0, 0], [0, 0], [1, 1]])
    np.testing.assert_allclose(jacobian(planar_2r, [q1, q2]), expected, rtol=0, atol=1e-14)


# ---------------------------------------------------------------------------
# Analytic Jacobian (roll-pitch-yaw rates)


@pytest.mark.parametrize("name", ["iiwa14", "stanford_arm"])
def test_rpy_representation_equals_central_differences_of_rpy(load_robot, name):
    robot = load_robot(name)
    h = 1e-6
    for q in robot.sample_q(5, seed=9):
        J = jacobian(robot, q, representation="rpy")
        np.testing.assert_allclose(J[:3], jacobian(robot, q)[:3], rtol=0, atol=0)
        for j in range(len(q)):
            step = np.zeros(len(q))
            step[j] = h
            rpy_plus = rpy_from_matrix(robot.transform("base_link", "ee_link", q + step)[:3, :3])
            rpy_minus = rpy_from_matrix(robot.transform("base_link", "ee_link", q - step)[:3, :3])
            difference = (rpy_plus - rpy_minus + np.pi) % (2 * np.pi) - np.pi  # across the +-pi seam
            np.testing.assert_allclose(J[3:, j], difference / (2 * h), rtol=0, atol=1e-5)


@given(st.tuples(*[st.floats(-3.1, 3.1)] * 3))
@settings(max_examples=50, deadline=None)
def test_rpy_rate_matrix_inverts_the_rate_to_velocity_map(rpy):
    roll, pitch, yaw = rpy
    if abs(np.cos(pitch)) < 1e-3:
        return
    R = matrix_from_rpy(rpy)
    _, pitch, yaw = rpy_from_matrix(R)  # pitch in [-pi/2, pi/2], as the rate matrix assumes
    # w = E rpy_dot, E = [Rz(yaw) Ry(pitch) e_x, Rz(yaw) e_y, e_z] (columns for roll, pitch, yaw)
    E = np.column_stack([[np.cos(yaw) * np.cos(pitch), np.sin(yaw) * np.cos(pitch), -np.sin(pitch)],
                         [-np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(rpy_rate_matrix(R) @ E, np.eye(3), rtol=0, atol=1e-9 / abs(np.cos(pitch)))


TILT_URDF = """<robot name="tilt">
  <link name="base_link"/><link name="tip"/>
  <joint name="pitch" type="revolute"><parent link="base_link"/><child link="tip"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>"""


def test_rpy_representation_names_the_gimbal_lock():
    robot = manipkit.Robot.from_urdf(TILT_URDF)
    with pytest.raises(ManipkitError, match=r"pitch = \+-90 deg"):
        jacobian(robot, [np.pi / 2], tip="tip", representation="rpy")
    with pytest.raises(ManipkitError, match=r"configuration 1"):
        jacobians(robot, [[0.1], [-np.pi / 2]], tip="tip", representation="rpy")
    np.testing.assert_allclose(jacobian(robot, [0.3], tip="tip", representation="rpy")[3:, 0], [0, 1, 0], atol=1e-15)


# ---------------------------------------------------------------------------
# Mimic joints: value = scale * q[leader] + offset, column = scale * contribution

MIMIC_URDF = """<robot name="mimic">
  <link name="base_link"/><link name="a"/><link name="b"/><link name="tip"/>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="a"/><origin xyz="0 0 0.3"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0.4 0 0" rpy="0.2 0 0.1"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/>
    <mimic joint="j1" multiplier="2.0" offset="0.1"/></joint>
  <joint name="j3" type="prismatic"><parent link="b"/><child link="tip"/><origin xyz="0.3 0 0.05"/>
    <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"""


def pinocchio_mimic_jacobians(q):
    model = pin.buildModelFromXML(MIMIC_URDF, mimic=True)
    data = model.createData()
    config = np.asarray(q, dtype=float)
    pin.computeJointJacobians(model, data, config)
    pin.framesForwardKinematics(model, data, config)
    frame = model.getFrameId("tip")
    return (pin.getFrameJacobian(model, data, frame, pin.LOCAL_WORLD_ALIGNED),
            pin.getFrameJacobian(model, data, frame, pin.LOCAL))


def test_mimic_steps_add_scale_times_their_column_to_the_leader():
    # The chain as the lead's mimic support will give it: j2 reads column 0 with scale 2 and offset 0.1.
    robot = manipkit.Robot.from_urdf(MIMIC_URDF)
    steps = list(robot.chain(robot.root_link, "tip").steps)
    steps[1] = dataclasses.replace(steps[1], index=0, scale=2.0, offset=0.1)
    steps[2] = dataclasses.replace(steps[2], index=1)
    program = JacobianProgram.from_steps(steps, 2)
    Q = np.array([[0.3, 0.2], [-1.0, -0.5], [2.0, 0.7]])
    J_base, _, _ = program.run(Q)
    J_local, _, _ = program.run(Q, local=True)
    for k, q in enumerate(Q):
        expected_base, expected_local = pinocchio_mimic_jacobians(q)
        np.testing.assert_allclose(J_base[k], expected_base, rtol=0, atol=1e-12)
        np.testing.assert_allclose(J_local[k], expected_local, rtol=0, atol=1e-12)


def test_mimic_robot_jacobian_equals_pinocchio_with_mimic():
    robot = manipkit.Robot.from_urdf(MIMIC_URDF)
    q = np.array([0.3, 0.2])
    expected_base, expected_local = pinocchio_mimic_jacobians(q)
    np.testing.assert_allclose(jacobian(robot, q, tip="tip"), expected_base, rtol=0, atol=1e-12)
    np.testing.assert_allclose(jacobian(robot, q, tip="tip", reference="local"), expected_local, rtol=0, atol=1e-12)


# ---------------------------------------------------------------------------
# Inputs


def test_q_none_is_the_default_joint_vector(iiwa14):
    np.testing.assert_array_equal(jacobian(iiwa14), jacobian(iiwa14, iiwa14.q()))


@pytest.mark.parametrize(("q", "message"), [
    ([0.0, 1.0, 2.0], "needs 2 joint values"),
    ([0.0, np.nan], "finite"),
    (["a", "b"], "real numbers"),
    ([1j, 0.0], "real numbers"),
    ([[0.0, 0.0]], "one joint vector"),
])
def test_bad_joint_values(planar_2r, q, message):
    with pytest.raises(JointValueError, match=message):
        jacobian(planar_2r, q)


def test_bad_options_and_frames(planar_2r):
    with pytest.raises(ManipkitError, match="reference='world' is not one of 'base', 'local'"):
        jacobian(planar_2r, [0, 0], reference="world")
    with pytest.raises(ManipkitError, match="representation"):
        jacobian(planar_2r, [0, 0], representation="zyz")
    with pytest.raises(ManipkitError, match="reference='base'"):
        jacobian(planar_2r, [0, 0], reference="local", representation="rpy")
    with pytest.raises(UnknownFrameError):
        jacobian(planar_2r, [0, 0], tip="nowhere")


def test_frame_equal_to_base_and_empty_batches(iiwa14):
    assert np.all(jacobian(iiwa14, iiwa14.sample_q(1, seed=1)[0], base="iiwa_link_4", tip="iiwa_link_4") == 0.0)
    assert jacobians(iiwa14, np.zeros((0, 7))).shape == (0, 6, 7)


def test_robot_jacobian_methods_take_a_dict_and_equal_the_functions(iiwa14):
    q = iiwa14.sample_q(1, seed=9)[0]
    by_name = dict(zip(iiwa14.joint_names, q))
    np.testing.assert_array_equal(iiwa14.jacobian(by_name), jacobian(iiwa14, q))
    np.testing.assert_array_equal(iiwa14.jacobians(q[None], reference="local")[0],
                                  jacobian(iiwa14, q, reference="local"))


def test_mass_matrix_folds_mimic_joints_like_pinocchio_with_mimic():
    # Pinocchio's own mimic support (mimic=True) folds the inertia onto the independent joints: M = S^T M_full S
    robot = manipkit.Robot.from_urdf(MIMIC_URDF)
    model = pin.buildModelFromXML(MIMIC_URDF, mimic=True)
    q = np.array([0.3, 0.2])
    expected = pin.crba(model, model.createData(), q)
    expected = np.triu(expected) + np.triu(expected, 1).T
    np.testing.assert_allclose(mass_matrix(robot, q), expected, rtol=0, atol=1e-12)


def test_jacobian_columns_leave_out_joints_off_the_chain(load_robot):
    # the mobile manipulator carries the course arm (same joint names) on a 2-wheel base: the arm's indices must
    # not see the wheels' zero columns (with them, 7 columns and 6 rows would give a zero singular value)
    from manipkit.analysis.dexterity import global_conditioning_index
    from manipkit.analysis.manipulability import manipulability
    from manipkit.kinematics.jacobian import jacobian_columns

    arm, mobile = load_robot("course_arm"), load_robot("mobile_manipulator")
    assert [mobile.joint_names[i] for i in jacobian_columns(mobile)] == list(arm.joint_names)
    q = arm.sample_q(1, seed=3)[0]
    q_mobile = mobile.q(dict(zip(arm.joint_names, q)))
    J = mobile.jacobian(q_mobile)[:, jacobian_columns(mobile)]
    assert manipulability(J, axes="all", length=0.3) == pytest.approx(manipulability(arm.jacobian(q), axes="all",
                                                                                     length=0.3), rel=1e-12)
    on_base = global_conditioning_index(mobile, 4000, length=0.3, seed=1)
    alone = global_conditioning_index(arm, 4000, length=0.3, seed=1)
    assert on_base.mean > 0 and abs(on_base.mean - alone.mean) < (on_base.high - on_base.low) + (alone.high - alone.low)
