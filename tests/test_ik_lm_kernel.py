"""manipkit.ik.lm_kernel: each compiled piece against an independent source.

- ``chain_pose_jacobian`` against Pinocchio's ``framesForwardKinematics`` and
  its ``LOCAL_WORLD_ALIGNED`` frame Jacobian, on robots with revolute,
  continuous and prismatic joints, tilted axes, ``rpy`` placements, fixed
  joints folded into placements, and joints above the IK base;
- ``log3`` against Pinocchio's ``log3``, including angles near 0 and pi;
- ``solve_linear`` against ``numpy.linalg.solve``;
- the IK answers of a base that is not the root (a joint above it keeps its
  ``q0`` value) against ``Robot.transform``.
"""

import math

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_kernels_fk import chain_urdf, joint_strategy  # the random-chain generator of the FK kernel's tests

import manipkit
from manipkit.ik.lm_kernel import chain_pose_jacobian, log3, solve_linear
from manipkit.ik.numerical import ik, ik_solver
from manipkit.kernels.program import pack_chain
from manipkit.spatial.rotations import matrix_from_axis_angle, rotation_angle_between

# A chain with what the bundled arms lack: tilted revolute, continuous and prismatic axes
# (one given non-unit, normalised by the loader), rpy placements and a fixed joint in between.
TILTED_URDF = """<?xml version="1.0"?>
<robot name="tilted">
  <link name="base_link"/><link name="a"/><link name="b"/><link name="c"/><link name="d"/><link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="a"/>
    <origin xyz="0.1 -0.2 0.3" rpy="0.3 -0.5 1.1"/><axis xyz="0.267261 0.534522 0.801784"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="continuous"><parent link="a"/><child link="b"/>
    <origin xyz="0 0.4 0.05" rpy="1.5707963267948966 0 0.2"/><axis xyz="1 0 0"/></joint>
  <joint name="j3" type="prismatic"><parent link="b"/><child link="c"/>
    <origin xyz="0.3 0 0" rpy="0 0.7 0"/><axis xyz="0 -2 1"/>
    <limit lower="-0.5" upper="0.5" effort="1" velocity="1"/></joint>
  <joint name="fixed_between" type="fixed"><parent link="c"/><child link="d"/>
    <origin xyz="0.05 0.05 0.2" rpy="-0.4 0.1 2.5"/></joint>
  <joint name="j4" type="revolute"><parent link="d"/><child link="tool"/>
    <origin xyz="0 0 0.15" rpy="0 0 0"/><axis xyz="0 0 -1"/>
    <limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
</robot>
"""


@pytest.fixture(scope="module")
def robots(load_robot):
    loaded = {name: load_robot(name) for name in ("iiwa14", "panda", "course_arm", "scara", "stanford_arm", "mobile_manipulator")}
    loaded["tilted"] = manipkit.kinematics.robot.Robot.from_urdf(TILTED_URDF)
    return loaded


def kernel_pose_jacobian(robot, frame, base, q):
    """(T_root_frame 4x4, J 6 x n) from the kernel, for the chain base -> frame at the full joint vector q."""
    steps = robot.chain(robot.root_link, frame).steps
    chain = robot.chain_joints(base, frame)
    columns = [robot.joint_names.index(name) for name in chain]
    geometry, kinds = pack_chain(steps, columns)
    q_fixed = np.array([q[s.index] if s.index >= 0 else 0.0 for s in steps])
    R, p, J = np.empty((3, 3)), np.empty(3), np.zeros((6, len(chain)))
    chain_pose_jacobian(np.asarray(q, dtype=float)[columns], q_fixed, geometry, kinds, R, p, J)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T, J, chain


def pinocchio_pose_jacobian(robot, frame, chain, q):
    model, data = robot.model, robot.model.createData()
    config = robot.pinocchio_configuration(q)
    frame_id = robot.frame_id(frame)
    J_full = pin.computeFrameJacobian(model, data, config, frame_id, pin.LOCAL_WORLD_ALIGNED).reshape(6, model.nv)
    columns = [model.joints[model.getJointId(name)].idx_v for name in chain]
    return data.oMf[frame_id].homogeneous, J_full[:, columns]


@pytest.mark.parametrize(
    "name, base",
    [
        ("iiwa14", None),
        ("panda", None),
        ("course_arm", None),
        ("scara", None),
        ("stanford_arm", None),
        ("tilted", None),
        ("mobile_manipulator", None),
        ("mobile_manipulator", "arm_base"),  # arm_base_joint lies above the base: held at q
        ("iiwa14", "iiwa_link_3"),
    ],
)
def test_chain_pose_and_jacobian_equal_pinocchio(robots, name, base):
    robot = robots[name]
    frame = robot.ee_frame if name != "tilted" else "tool"
    base = base or robot.root_link
    for q in robot.sample_q(25, seed=11):
        T_kernel, J_kernel, chain = kernel_pose_jacobian(robot, frame, base, q)
        T_pin, J_pin = pinocchio_pose_jacobian(robot, frame, chain, q)
        np.testing.assert_allclose(T_kernel, T_pin, rtol=0, atol=1e-12)
        np.testing.assert_allclose(J_kernel, J_pin, rtol=0, atol=1e-12)


def test_tilted_chain_jacobian_equals_finite_differences(robots):
    # A check that does not use Pinocchio's Jacobian: central differences of the kernel's own pose.
    # Linear rows: dp/dq. Angular rows: vee(dR/dq R^T) (the angular velocity in root axes).
    robot = robots["tilted"]
    q = robot.sample_q(1, seed=3)[0]
    T0, J, chain = kernel_pose_jacobian(robot, "tool", "base_link", q)
    h = 1e-6
    for k in range(len(chain)):
        dq = np.zeros_like(q)
        dq[k] = h
        T_plus, _, _ = kernel_pose_jacobian(robot, "tool", "base_link", q + dq)
        T_minus, _, _ = kernel_pose_jacobian(robot, "tool", "base_link", q - dq)
        dT = (T_plus - T_minus) / (2 * h)
        W = dT[:3, :3] @ T0[:3, :3].T
        numeric = np.concatenate((dT[:3, 3], [W[2, 1], W[0, 2], W[1, 0]]))
        np.testing.assert_allclose(J[:, k], numeric, rtol=0, atol=1e-8)


def pin_log3(R):
    return np.asarray(pin.log3(R))


@given(
    axis=st.tuples(*[st.floats(-1, 1) for _ in range(3)]).filter(lambda v: np.linalg.norm(v) > 1e-3),
    angle=st.one_of(
        st.floats(0.0, math.pi),
        st.floats(math.pi - 1e-3, math.pi),  # near pi: the symmetric-part branch
        st.floats(0.0, 1e-6),  # near 0: theta / sin(theta) series
    ),
)
@settings(max_examples=400, deadline=None)
def test_log3_equals_pinocchio(axis, angle):
    u = np.array(axis) / np.linalg.norm(axis)
    R = matrix_from_axis_angle(u, angle)
    w = np.empty(3)
    theta = log3(R, w)
    reference = pin_log3(R)
    assert abs(theta - np.linalg.norm(reference)) < 1e-12
    if angle < math.pi - 1e-6:
        np.testing.assert_allclose(w, reference, rtol=0, atol=1e-9)
    else:  # at pi, w and -w are the same rotation: compare the rotations they make
        np.testing.assert_allclose(matrix_from_axis_angle(w / theta, theta), R, rtol=0, atol=1e-9)


def test_log3_at_exactly_pi_and_identity():
    for axis in np.eye(3):
        R = matrix_from_axis_angle(axis, math.pi)
        w = np.empty(3)
        assert log3(R, w) == pytest.approx(math.pi, abs=1e-15)
        np.testing.assert_allclose(np.abs(w), axis * math.pi, atol=1e-12)
    w = np.empty(3)
    assert log3(np.eye(3), w) == 0.0 and not w.any()


@pytest.mark.parametrize("n", [1, 3, 7, 10])
def test_solve_linear_equals_numpy(n):
    rng = np.random.default_rng(n)
    for _ in range(50):
        M = rng.normal(size=(n, n))
        if n > 1 and rng.random() < 0.5:
            M = M @ M.T + 1e-9 * np.eye(n)  # the damped normal equations' kind of matrix
        b = rng.normal(size=n)
        out = np.empty(n)
        assert solve_linear(M.copy(), b, out)
        np.testing.assert_allclose(M @ out, b, rtol=0, atol=1e-8 * max(1.0, np.abs(out).max()))
        np.testing.assert_allclose(out, np.linalg.solve(M, b), rtol=1e-6, atol=1e-9)


def test_solve_linear_refuses_singular_and_nan_systems():
    out = np.empty(2)
    assert not solve_linear(np.array([[1.0, 2.0], [2.0, 4.0]]), np.ones(2), out)
    assert not solve_linear(np.array([[np.nan, 0.0], [0.0, 1.0]]), np.ones(2), out)


def test_ik_from_a_base_below_a_moving_joint(robots):
    # The mobile manipulator's arm from 'bicep' (below arm_base_joint and shoulder_joint) to ee_link:
    # the two joints above the base keep their q0 values, and the target is T_bicep_ee.
    robot = robots["mobile_manipulator"]
    solver = ik_solver(robot, "bicep", "ee_link", mode="position")
    assert solver.joint_names == ("bottom_wrist_joint", "elbow_joint", "top_wrist_joint")
    for i, q_true in enumerate(robot.sample_q(20, seed=21)):
        T = robot.transform("bicep", "ee_link", q_true)
        q0 = robot.sample_q(1, seed=100 + i)[0]  # a different arm_base_joint and shoulder_joint
        result = ik(robot, T, "bicep", "ee_link", mode="position", q0=q0, seed=i)
        assert result.success
        above = [robot.joint_names.index("arm_base_joint"), robot.joint_names.index("shoulder_joint")]
        assert np.array_equal(result.q[above], q0[above])
        reached = robot.transform("bicep", "ee_link", result.q)
        assert np.linalg.norm(reached[:3, 3] - T[:3, 3]) < 1e-9


# ----------------------------------------------------------------------
# Random chains (the generator of tests/test_chain.py): tilted, prismatic, continuous and fixed joints


@settings(max_examples=60, deadline=None)
@given(st.lists(joint_strategy, min_size=1, max_size=7).filter(lambda js: any(kind != "fixed" for kind, *_ in js)))
def test_random_chains_pose_and_jacobian_equal_pinocchio(joints):
    robot = manipkit.kinematics.robot.Robot.from_urdf(chain_urdf(joints))
    tip = f"l{len(joints) + 1}"
    for q in robot.sample_q(10, seed=5):
        T_kernel, J_kernel, chain = kernel_pose_jacobian(robot, tip, robot.root_link, q)
        T_pin, J_pin = pinocchio_pose_jacobian(robot, tip, chain, q)
        np.testing.assert_allclose(T_kernel, T_pin, rtol=0, atol=1e-12)
        np.testing.assert_allclose(J_kernel, J_pin, rtol=0, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(joint_strategy, min_size=1, max_size=7).filter(lambda js: any(kind != "fixed" for kind, *_ in js)),
    st.sampled_from(["pose", "position"]),
)
def test_random_chains_ik_from_a_nearby_start(joints, mode):
    # Local convergence: from 1e-3 away, a chain whose Jacobian at the solution has full row rank with
    # smallest singular value >= 0.05 must converge (Gauss-Newton contracts there); any chain's answer,
    # success or not, lies inside the limits, and a success is confirmed by Robot.transform.
    robot = manipkit.kinematics.robot.Robot.from_urdf(chain_urdf(joints))
    tip = f"l{len(joints) + 1}"
    rows = 6 if mode == "pose" else 3
    for i, q_true in enumerate(robot.sample_q(4, seed=9)):
        T = robot.transform(robot.root_link, tip, q_true)
        q0 = q_true + 1e-3 * np.random.default_rng(i).standard_normal(q_true.size)
        result = ik(robot, T, robot.root_link, tip, mode=mode, q0=q0, restarts=0)
        assert not robot.outside_limits(result.q).any()
        _, J, _ = kernel_pose_jacobian(robot, tip, robot.root_link, q_true)
        sigma = np.linalg.svd(J[:rows], compute_uv=False)
        well_conditioned = sigma.size >= rows and sigma[rows - 1] >= 0.05
        at_limit = np.any(np.isclose(q_true, [j.lower for j in robot.joints], atol=2e-3)
                          | np.isclose(q_true, [j.upper for j in robot.joints], atol=2e-3))
        if well_conditioned and not at_limit:
            assert result.success, (result.reason, sigma)
        if result.success:
            reached = robot.transform(robot.root_link, tip, result.q)
            assert np.linalg.norm(reached[:3, 3] - T[:3, 3]) <= 1e-10
            if mode == "pose":
                assert rotation_angle_between(reached[:3, :3], T[:3, :3]) <= 1e-9
