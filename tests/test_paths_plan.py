"""plan_path (manipkit.paths.plan) on hand cases derived here, on the UR5 and the iiwa14.

Geometry used in the derivations (the UR5 of example-robot-data, base_link -> tool0): joints 2, 3 and 4 are
parallel (axis y of their links), with a2 = 0.425 m and a3 = 0.39225 m between them; joint 5 (wrist_2) at 0
puts axes 4 and 6 in line (the wrist singularity); the tool's z axis is joint 6's axis. Every number the tests
check is measured independently: forward kinematics of the returned joints (compiled FK, equal to Pinocchio),
joint steps against the URDF velocity limits, collisions by coal at samples finer than the planner's.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import manipkit
from manipkit.paths.plan import plan_path, velocity_limits
from manipkit.spatial.transforms import pose_residuals

Q_SINGULAR = np.array([0.3, -1.2, 1.4, -1.8, 0.0, 0.2])  # wrist_2 = 0: the wrist singularity, shoulder "A" (q1 = 0.3)
OFFSETS = -0.045 + 0.01 * np.arange(10)  # waypoints 1 cm apart; the singular pose (s = 0) lies between 4 and 5


@pytest.fixture(scope="module")
def ur5():
    return manipkit.load("ur5")


def limited(robot, **limits):
    """The robot with joint limits replaced (joint=(lower, upper), rad): the same geometry and velocity limits."""
    text = robot.urdf
    for joint, (lower, upper) in limits.items():
        text, count = re.subn(rf'(<joint name="{joint}".*?<limit[^/]*?)lower="[^"]*" upper="[^"]*"',
                              rf'\1lower="{lower!r}" upper="{upper!r}"', text, count=1, flags=re.S)
        assert count == 1, joint
    return manipkit.kinematics.robot.Robot.from_urdf(text)


def line_through(chain, q, direction, offsets):
    """Poses T(q) moved by s * direction (base frame, m) for s in offsets: a straight line, orientation fixed."""
    T = chain.fk(q)
    poses = np.repeat(T[None], len(offsets), axis=0)
    poses[:, :3, 3] += np.asarray(offsets)[:, None] * np.asarray(direction, dtype=float)
    return poses


def assert_follows(plan, chain, poses, dt=None):
    """Every waypoint reached by FK to 1e-9 (m, rad); every step inside the scaled velocity bound."""
    position, rotation = pose_residuals(poses, chain.fk(plan.q))
    assert position.max() <= 1e-9 and rotation.max() <= 1e-9
    assert np.all(plan.q >= chain.lower - 1e-12) and np.all(plan.q <= chain.upper + 1e-12)
    if dt is not None:
        steps = np.abs(np.diff(plan.q, axis=0))
        assert np.all(steps <= dt * velocity_limits(chain) * (1 + 1e-12))
        assert plan.max_velocity_ratio == pytest.approx((steps / (dt * velocity_limits(chain))).max(), rel=1e-12)


def test_line_one_branch_can_follow(ur5):
    # Limits elbow and wrist_2 in [0, pi] leave one branch per shoulder: "A" (q1 = 0.3) and "B" (q1 near -2.5).
    # The line runs along base y through the pose at Q_SINGULAR, so A's wrist_2 passes through 0 between
    # waypoints 4 and 5: A's continuous branch goes on with wrist_2 < 0 (outside the limits), its in-limit
    # branch there has wrist_1 and wrist_3 turned by about pi: a step of about pi in 0.1 s (1 cm at 0.1 m/s) against
    # 0.32 rad allowed (3.2 rad/s). B's wrist_2 stays near +-2.8, far from 0: only B follows the line.
    robot = limited(ur5, elbow_joint=(0.0, math.pi), wrist_2_joint=(0.0, math.pi))
    chain = robot.chain("base_link", "tool0")
    poses = line_through(chain, Q_SINGULAR, [0, 1, 0], OFFSETS)
    plan = plan_path(chain, poses, speed=0.1)
    assert plan.feasible and plan.first_failure is None
    assert np.all(np.abs(np.abs(plan.q[:, 4]) - 2.8) < 0.1)  # shoulder B's wrist, far from singular
    assert np.all(np.abs(plan.q[:, 0] + 2.5) < 0.1)  # shoulder B (as the value nearest 0 of its aliases)
    assert_follows(plan, chain, poses, dt=np.full(9, 0.1)[:, None])
    died = {f.kind: f for f in plan.failures[5]}
    assert died["velocity"].ratio > 5 and died["velocity"].joint in chain.joint_names
    assert plan.cost == pytest.approx(np.abs(np.diff(plan.q, axis=0)).sum(), abs=1e-9)


def test_only_the_singular_branch_cannot_follow_then_one_reconfiguration(ur5):
    # The same line with shoulder_pan limited to [-0.7, 1.3] (shoulder A only): no branch follows, and the first
    # waypoint where every candidate is dead is 5 (past the singularity), by velocity. With breaks allowed the
    # fewest is 1: the arm resumes at waypoint 5 in the flipped wrist.
    robot = limited(ur5, shoulder_pan_joint=(-0.7, 1.3), elbow_joint=(0.0, math.pi), wrist_2_joint=(0.0, math.pi))
    chain = robot.chain("base_link", "tool0")
    poses = line_through(chain, Q_SINGULAR, [0, 1, 0], OFFSETS)
    plan = plan_path(chain, poses, speed=0.1)
    assert not plan.feasible and plan.first_failure == 5 and plan.q is None
    # at every waypoint the branches of the other elbow, the other wrist and shoulder B are outside the limits;
    # at 5 the one in-limit branch left is reached from 4 only by the wrist's half turn
    assert [f.kind for f in plan.failures[5]] == ["joint_limits", "velocity"]
    assert all([f.kind for f in plan.failures[i]] == ["joint_limits"] for i in range(5))
    again = plan_path(chain, poses, speed=0.1, reconfigure=True)
    assert again.feasible and again.reconfigurations == (5,)
    assert_follows(again, chain, poses)
    assert again.q[4, 4] > 0 and again.q[5, 4] > 0 and abs(again.q[5, 3] - again.q[4, 3]) > 2.5  # wrist turned


def test_line_leaving_the_reach_fails_where_derived(ur5):
    # At Q_EXTENDED the elbow is straight (elbow_joint = 0): the points on axes 2 and 4 are a2 + a3 = 0.81725 m
    # apart across the plane of the arm. Moving the tool, orientation fixed, by s along that segment's direction
    # (in the arm's plane, so the shoulder angle and the wrist stay) makes the distance a2 + a3 + s: reachable
    # for s <= 0 only. Waypoints at s = -0.045 + 0.01 k: the first unreachable is k = 5.
    chain = ur5.chain("base_link", "tool0")
    q_extended = np.array([0.3, -0.5, 0.0, -1.0, math.pi / 2, 0.4])
    T2 = ur5.transform("base_link", "upper_arm_link", q_extended)
    T4 = ur5.transform("base_link", "wrist_1_link", q_extended)
    axis = T2[:3, :3] @ chain.joints[1].axis
    v = T4[:3, 3] - T2[:3, 3]
    v -= (v @ axis) * axis
    assert np.linalg.norm(v) == pytest.approx(0.425 + 0.39225, abs=1e-9)
    poses = line_through(chain, q_extended, v / np.linalg.norm(v), OFFSETS)
    plan = plan_path(chain, poses)
    assert not plan.feasible and plan.first_failure == 5
    assert [f.kind for f in plan.failures[5]] == ["unreachable"] and plan.failures[5][0].count == 1
    assert all(not any(f.kind == "unreachable" for f in plan.failures[i]) for i in range(5))


def test_tool_free_about_its_axis(ur5):
    # wrist_3 limited to [-0.1, 0.1] rad. Turning the target about the tool's z (joint 6's axis) by theta turns
    # wrist_3 by theta and leaves the other joints; with 10 deg samples (0.1745 rad < the 0.2 rad window) every
    # branch has a sample whose wrist_3 lands inside. With the orientation fixed no branch is inside: waypoint 0
    # fails on joint limits.
    robot = limited(ur5, wrist_3_joint=(-0.1, 0.1))
    chain = robot.chain("base_link", "tool0")
    q = np.array([0.3, -1.2, 1.4, -1.8, -1.2, 1.0])
    poses = line_through(chain, q, [1, 0, 0], 0.01 * np.arange(8))
    every = manipkit.ik_many(ur5.chain("base_link", "tool0"), poses).solutions
    assert np.nanmin(np.abs(every[..., 5])) > 0.1  # precondition: no branch inside [-0.1, 0.1]
    fixed = plan_path(chain, poses)
    assert not fixed.feasible and fixed.first_failure == 0 and fixed.failures[0][0].kind == "joint_limits"
    assert fixed.failures[0][0].joint == "wrist_3_joint"
    free = plan_path(chain, poses, free_axis="z", free_step=math.radians(10))
    assert free.feasible and free.resolution["tool_angles"] == 36
    turned = np.stack([T @ manipkit.spatial.transforms.transform_from_xyz_rpy([0, 0, 0], [0, 0, a])
                       for T, a in zip(poses, free.tool_angles)])
    position, rotation = pose_residuals(turned, chain.fk(free.q))
    assert position.max() <= 1e-9 and rotation.max() <= 1e-9
    # and the tool's z axis (the task's axis) is where the path wants it
    assert np.abs(chain.fk(free.q)[:, :3, 2] - poses[:, :3, 2]).max() <= 1e-9


def test_iiwa14_line_on_arm_angle_samples():
    # The iiwa14 is a 7R SRS arm: no finite set of branches; the planner solves it in closed form at arm angles
    # sampled every 10 deg (36 samples x 8 branches per waypoint) and picks a path over them.
    robot = manipkit.load("iiwa14")
    chain = robot.chain("base_link", "ee_link")
    q = np.array([0.2, 0.5, 0.1, -1.2, 0.3, 0.8, 0.1])
    poses = line_through(chain, q, [0, 0, 1], 0.01 * np.arange(6))
    plan = plan_path(chain, poses, speed=0.05)
    assert plan.feasible and plan.resolution["arm_angles"] == 36 and plan.resolution["samples"] == 36
    assert_follows(plan, chain, poses, dt=np.full(5, 0.2)[:, None])
    grid = -math.pi + math.radians(10) * np.arange(36)
    assert np.all(np.min(np.abs(plan.arm_angles[:, None] - grid[None]), axis=1) <= 1e-12)


def test_bad_inputs_are_one_line_errors(ur5):
    chain = ur5.chain("base_link", "tool0")
    poses = line_through(chain, Q_SINGULAR, [0, 1, 0], OFFSETS)
    bad = poses.copy()
    bad[3, 0, 0] = np.nan
    with pytest.raises(manipkit.errors.ManipkitError, match=r"\[3\]"):
        plan_path(chain, bad)
    with pytest.raises(manipkit.errors.ManipkitError, match="speed"):
        plan_path(chain, poses, speed=0.0)
    with pytest.raises(manipkit.errors.ManipkitError, match="free_axis"):
        plan_path(chain, poses, free_axis="w")
    with pytest.raises(manipkit.errors.ManipkitError, match="free_step"):
        plan_path(chain, poses, free_axis="z", free_step=0.0)
    reflected = poses.copy()
    reflected[:, :3, 0] *= -1
    with pytest.raises(manipkit.errors.ManipkitError):
        plan_path(chain, reflected)


def test_best_branch_through_a_box_is_avoided(ur5, tmp_path):
    # The least-motion plan of this line keeps the elbow up; a 6 cm box centred on its elbow (forearm_link's
    # origin) at the middle waypoint blocks that branch (and its 2 pi aliases, the same link placements). The
    # plan with collisions takes another branch; checked here by coal at samples 0.1 deg apart along every step,
    # ten times finer than the planner's 1 deg.
    from manipkit.kinematics.collisions import CollisionChecker
    from manipkit.kinematics.world import read_world
    from manipkit.spatial.transforms import transform_from_xyz_rpy

    chain = ur5.chain("base_link", "tool0")
    poses = np.stack([transform_from_xyz_rpy([x, 0.1, 0.4], [3.14159, 0, 0]) for x in np.linspace(0.4, 0.5, 11)])
    best = plan_path(chain, poses, speed=0.1)
    elbow = ur5.transform("base_link", "forearm_link", best.q[5])[:3, 3]
    world = tmp_path / "world.yaml"
    world.write_text(f"obstacles:\n  - name: box\n    box: [0.06, 0.06, 0.06]\n    xyz: {elbow.tolist()}\n")
    checker = CollisionChecker(ur5, world=read_world(world), skip_home_contacts=True)
    assert checker.in_collision(best.q).any()
    plan = plan_path(chain, poses, speed=0.1, collisions=checker)
    assert plan.feasible and plan.replans >= 1
    assert np.sign(plan.q[5, 2]) != np.sign(best.q[5, 2])  # the other elbow
    assert plan.cost > best.cost
    assert_follows(plan, chain, poses)
    dense = [q0 + s * (q1 - q0) for q0, q1 in zip(plan.q[:-1], plan.q[1:]) for s in
             np.linspace(0, 1, int(np.ceil(np.abs(q1 - q0).max() / math.radians(0.1))) + 1)]
    assert not checker.in_collision(np.array(dense)).any()
    died = [f for fs in plan.failures for f in fs if f.kind == "collision"]
    assert died and died[0].pairs and "box" in died[0].pairs[0]
    assert plan.collision_checks >= len(poses)  # every waypoint, then the samples of the steps


def test_running_out_of_replans_proves_nothing(ur5, tmp_path):
    # The box case with no re-plan allowed: the first path collides and nothing is left to try it again: the plan
    # is not feasible, names no failing waypoint and says it is unfinished.
    from manipkit.kinematics.collisions import CollisionChecker
    from manipkit.kinematics.world import world_obstacles
    from manipkit.spatial.transforms import transform_from_xyz_rpy

    chain = ur5.chain("base_link", "tool0")
    poses = np.stack([transform_from_xyz_rpy([x, 0.1, 0.4], [3.14159, 0, 0]) for x in np.linspace(0.4, 0.5, 11)])
    best = plan_path(chain, poses, speed=0.1)
    elbow = ur5.transform("base_link", "forearm_link", best.q[5])[:3, 3]
    world = world_obstacles({"obstacles": [{"name": "box", "box": [0.06] * 3, "xyz": elbow.tolist()}]})
    checker = CollisionChecker(ur5, world=world, skip_home_contacts=True)
    plan = plan_path(chain, poses, speed=0.1, collisions=checker, max_replans=0)
    assert not plan.feasible and plan.first_failure is None and plan.resolution["unfinished"]


def test_progress_names_the_ik_and_ladder_stages(ur5):
    chain = ur5.chain("base_link", "tool0")
    calls = []
    plan_path(chain, line_through(chain, Q_SINGULAR, [0, 1, 0], OFFSETS), speed=0.1,
              progress=lambda stage, done, total: calls.append((stage, done, total)))
    assert ("IK", 10, 10) in calls and ("ladder", 9, 9) in calls


def test_near_singular_candidates_are_dropped_and_named(ur5):
    # Shoulder A only (as above): its wrist_2 passes 0 between waypoints 4 and 5, where axes 4 and 6 line up and
    # the Jacobian loses rank (its smallest singular value is 0 at Q_SINGULAR). One branch is inside the limits
    # at each waypoint; a tolerance of 0.02 drops it where its smallest singular value (numpy's SVD of its
    # Jacobian, computed here from the in-limit IK rows) is below 0.02: the first such waypoint is the first
    # failure, and each record carries the value found.
    robot = limited(ur5, shoulder_pan_joint=(-0.7, 1.3), elbow_joint=(0.0, math.pi), wrist_2_joint=(0.0, math.pi))
    chain = robot.chain("base_link", "tool0")
    assert np.linalg.svd(chain.jacobians(Q_SINGULAR), compute_uv=False)[-1] <= 1e-12
    poses = line_through(chain, Q_SINGULAR, [0, 1, 0], OFFSETS)
    rows = manipkit.ik_many(chain, poses).solutions
    sigma = {}
    for i, Q in enumerate(rows):
        inside = [q for q in Q if np.all(np.isfinite(q)) and np.all(q >= chain.lower) and np.all(q <= chain.upper)]
        assert len(inside) == 1
        sigma[i] = np.linalg.svd(chain.jacobians(inside[0]), compute_uv=False)[-1]
    low = sorted(i for i in sigma if sigma[i] < 0.02)
    assert low and low[0] > 0 and low[-1] < 9  # some waypoints near the singular pose, not the ends
    plan = plan_path(chain, poses, speed=0.1, singular_tol=0.02)
    near = {i: f for i, fs in enumerate(plan.failures) for f in fs if f.kind == "near_singular"}
    assert sorted(near) == low and not plan.feasible and plan.first_failure == low[0]
    for i in low:
        assert near[i].ratio == pytest.approx(sigma[i], rel=1e-9)


def test_a_chain_without_a_closed_form_is_planned_on_numerical_solutions():
    # The Panda's offsets leave it without a closed form: every distinct solution numerical IK finds from 20
    # restarts is a candidate; the plan says so and lands on every waypoint by FK.
    robot = manipkit.load("panda")
    chain = robot.chain("panda_link0", "panda_hand_tcp")
    q = np.array([0.1, -0.4, 0.2, -2.0, 0.1, 1.8, 0.6])
    poses = line_through(chain, q, [0, 0, 1], 0.01 * np.arange(3))
    plan = plan_path(chain, poses, restarts=8)
    assert plan.feasible and "numerical" in plan.resolution["method"]
    position, rotation = pose_residuals(poses, chain.fk(plan.q))
    assert position.max() <= 1e-9 and rotation.max() <= 1e-9


def test_step_samples_beyond_the_bound_are_refused_before_they_are_made():
    """Two configurations a whole turn apart in one joint, sampled 1e-6 rad apart, would be 6.3 million rows:
    refused in one line (OptionError) instead of allocated."""
    from manipkit.errors import OptionError
    from manipkit.paths.steps import MAX_STEP_SAMPLES, step_samples

    Q = np.array([[0.0, 0.0], [2 * np.pi, 0.0]])
    assert 2 * np.pi / 1e-6 > MAX_STEP_SAMPLES
    with pytest.raises(OptionError, match="give a larger collision step"):
        step_samples(Q, np.array([0]), 1e-6)
    rows, owner = step_samples(Q, np.array([0]), np.pi / 2)  # a quarter turn apart: the 3 inner samples
    np.testing.assert_allclose(rows[:, 0], [np.pi / 2, np.pi, 3 * np.pi / 2])
    assert owner.tolist() == [0, 0, 0]
