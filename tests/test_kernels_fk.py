"""manipkit.kernels.fk: the compiled batched FK equals Pinocchio's forward kinematics to 1e-12.

The second source is Pinocchio itself (``robot.transform``, i.e.
``framesForwardKinematics``), one configuration at a time; the chains cover
the bundled and example-robot-data arms and random URDF chains with every
joint type, coordinate and oblique axes, axes pointing backwards, and
``rpy`` placements that the kernel folds into joint offsets (turns about the
joint axis, +-90 deg twists) or must keep as general rotations.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import manipkit
from manipkit.kernels.fk import ChainFK, chain_fk
from manipkit.kinematics.robot import Robot

TOL = 1e-12


def chain_fk_for(robot, frame):
    """The batched FK of the chain root -> ``frame`` on whole-robot rows: a ChainFK of the chain's own steps (they
    index the robot's joint vector), so the kernel is checked on every robot's columns, mimic leaders included."""
    return ChainFK(robot.chain(robot.root_link, frame).steps, len(robot.joint_names))


def pinocchio_poses(robot, frame, Q):
    return np.array([robot.transform(robot.root_link, frame, q, check_limits=False) for q in Q])


@pytest.mark.parametrize("name", ["iiwa14", "panda", "course_arm", "ur5", "scara", "stanford_arm", "planar_3r",
                                  "kinova", "xarm7", "mobile_manipulator"])
def test_ee_poses_equal_pinocchio(name):
    robot = manipkit.load(name)
    Q = robot.sample_q(300, seed=1)
    T = chain_fk_for(robot, "ee_link").transforms(Q)
    assert np.abs(T - pinocchio_poses(robot, "ee_link", Q)).max() < TOL


def test_every_frame_of_the_course_arm_equals_pinocchio():
    robot = manipkit.load("course_arm")
    Q = robot.sample_q(50, seed=2)
    for frame in robot.frame_names:
        T = chain_fk_for(robot, frame).transforms(Q)
        assert np.abs(T - pinocchio_poses(robot, frame, Q)).max() < TOL, frame


def test_angles_far_outside_minus_pi_to_pi_and_at_pi():
    robot = manipkit.load("iiwa14")
    Q = np.vstack([np.full(7, math.pi), np.full(7, -math.pi), np.full(7, 1000.0), np.zeros(7),
                   np.random.default_rng(3).uniform(-50, 50, (100, 7))])
    T = chain_fk_for(robot, "ee_link").transforms(Q)
    assert np.abs(T - pinocchio_poses(robot, "ee_link", Q)).max() < 1e-11  # 1000 rad: Pinocchio's own sin/cos differ


def test_block_boundaries_do_not_change_the_answer():
    robot = manipkit.load("panda")
    Q = robot.sample_q(1001, seed=4)
    n = len(robot.joint_names)
    whole = ChainFK(robot.chain(robot.root_link, "ee_link").steps, n).transforms(Q)
    blocked = ChainFK(robot.chain(robot.root_link, "ee_link").steps, n, block=64).transforms(Q)
    assert np.array_equal(whole, blocked)
    assert np.abs(whole - pinocchio_poses(robot, "ee_link", Q)).max() < TOL


def test_out_is_filled_and_returned():
    robot = manipkit.load("iiwa14")
    Q = robot.sample_q(10, seed=5)
    out = np.full((10, 4, 4), np.nan)
    fk = chain_fk_for(robot, "ee_link")
    assert fk.transforms(Q, out=out) is out
    assert np.array_equal(out, fk.transforms(Q))
    assert np.array_equal(out[:, 3], np.tile([0.0, 0.0, 0.0, 1.0], (10, 1)))


def test_rotations_translations_match_transforms():
    robot = manipkit.load("iiwa14")
    Q = robot.sample_q(10, seed=6)
    R, p = chain_fk(robot.chain(robot.root_link, "ee_link").steps, Q)
    T = chain_fk_for(robot, "ee_link").transforms(Q)
    assert np.array_equal(R, T[:, :3, :3]) and np.array_equal(p, T[:, :3, 3])


def test_zero_rows_and_the_root_frame():
    robot = manipkit.load("iiwa14")
    assert chain_fk_for(robot, "ee_link").transforms(np.zeros((0, 7))).shape == (0, 4, 4)
    T = chain_fk_for(robot, robot.root_link).transforms(robot.sample_q(3))
    assert np.array_equal(T, np.broadcast_to(np.eye(4), (3, 4, 4)))


def test_wrong_shape_says_what_is_expected():
    robot = manipkit.load("iiwa14")
    with pytest.raises(ValueError, match=r"Q must have shape \(N, 7\), got \(3, 6\)"):
        chain_fk_for(robot, "ee_link").transforms(np.zeros((3, 6)))


def test_aligned_chains_compile_to_few_operations():
    # iiwa14: every placement is a signed permutation and every axis is z: about 20 ufunc calls per joint
    robot = manipkit.load("iiwa14")
    assert chain_fk_for(robot, "ee_link").n_ops < 20 * 7


def test_a_tool_turned_about_the_last_axis_costs_nothing():
    # panda_hand is turned -45 deg about joint 7's axis from panda_link8: folded into joint 7's angle
    panda = manipkit.load("panda")
    assert chain_fk_for(panda, "panda_hand").n_ops == chain_fk_for(panda, "panda_link8").n_ops


# --------------------------------------------------------------------------
# Random chains


AXES = [(0, 0, 1), (0, 0, -1), (1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0.6, 0.8, 0.0), (0.267261, 0.534522, 0.801784)]
QUARTER = math.pi / 2
ANGLES = st.one_of(st.sampled_from([0.0, QUARTER, -QUARTER, math.pi, 0.7]), st.floats(-3.0, 3.0))


def chain_urdf(joints) -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(len(joints) + 2))
    parts = []
    for i, (kind, axis, xyz, rpy) in enumerate(joints):
        limit = '<limit lower="-2" upper="2" effort="1" velocity="1"/>' if kind in ("revolute", "prismatic") else ""
        parts.append(
            f'<joint name="j{i}" type="{kind}"><parent link="l{i}"/><child link="l{i + 1}"/>'
            f'<origin xyz="{" ".join(map(repr, xyz))}" rpy="{" ".join(map(repr, rpy))}"/>'
            f'<axis xyz="{" ".join(map(repr, axis))}"/>{limit}</joint>'
        )
    n = len(joints)
    parts.append(f'<joint name="tool" type="fixed"><parent link="l{n}"/><child link="l{n + 1}"/>'
                 f'<origin xyz="0.01 0.02 0.1" rpy="0 0 {-math.pi / 4!r}"/></joint>')
    return f'<robot name="random">{links}{"".join(parts)}</robot>'


joint_strategy = st.tuples(
    st.sampled_from(["revolute", "continuous", "prismatic", "fixed"]),
    st.sampled_from(AXES),
    st.tuples(*[st.sampled_from([0.0, 0.1, -0.25, 0.333]) for _ in range(3)]),
    st.tuples(ANGLES, ANGLES, ANGLES),
)


@settings(max_examples=60, deadline=None)
@given(st.lists(joint_strategy, min_size=1, max_size=7))
def test_random_chains_equal_pinocchio(joints):
    robot = Robot.from_urdf(chain_urdf(joints))
    Q = robot.sample_q(40, seed=7)
    tip = f"l{len(joints) + 1}"
    T = chain_fk_for(robot, tip).transforms(Q)
    assert np.abs(T - pinocchio_poses(robot, tip, Q)).max() < TOL


def test_importing_the_module_does_not_import_numba():
    # numba (0.15-0.4 s) is imported when a ChainFK first runs, so that e.g. tf-between does not pay for it
    import subprocess
    import sys

    code = ("import sys, manipkit.kernels.fk, manipkit.kernels.program, manipkit.kinematics.robot; "
            "print('numba' in sys.modules)")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip() == "False"


def test_bad_block_and_out_are_manipkit_errors():
    from manipkit.errors import ChainError, JointValueError

    robot = manipkit.load("iiwa14")
    with pytest.raises(ChainError, match="block must be at least 1"):
        ChainFK(robot.chain(robot.root_link, "ee_link").steps, 7, block=0)
    with pytest.raises(JointValueError, match=r"out must be a C-contiguous float64 array of shape \(2, 4, 4\)"):
        chain_fk_for(robot, "ee_link").transforms(np.zeros((2, 7)), out=np.empty((3, 4, 4)))
