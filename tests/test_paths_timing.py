"""A planned ur5 path retimed (retime_plan): limits by finite differences, waypoints in order, tool speed by Pinocchio.

The velocity limits are read from the URDF's XML here (not through Pinocchio or manipkit); the acceleration limits
are the stated default, each joint's velocity limit reached from rest in 0.5 s.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from test_paths_retime import pinocchio_tip_positions

import manipkit
from manipkit.errors import OptionError
from manipkit.paths import line_poses, plan_path, retime_plan

pytest.importorskip("toppra")

SLACK = 1e-3  # the 0.1 % the issue allows


@pytest.fixture(scope="module")
def ur5():
    robot = manipkit.load("ur5")
    return robot, robot.chain("base_link", "tool0")


@pytest.fixture(scope="module")
def seam(ur5):
    """A 0.2 m line on ur5 planned at 0.1 m/s, and the URDF's velocity limits from its XML."""
    robot, chain = ur5
    T0 = chain.fk([0.3, -1.2, 1.4, -1.8, -1.5, 0.2])
    T1 = T0.copy()
    T1[:3, 3] += [0.1, 0.15, 0.05]
    plan = plan_path(chain, line_poses(T0, T1, step=0.01), speed=0.1)
    assert plan.feasible
    root = ET.parse(robot.source.path).getroot()
    limits = {j.get("name"): float(j.find("limit").get("velocity")) for j in root.iter("joint") if j.find("limit") is not None}
    return plan, np.array([limits[name] for name in chain.joint_names])


def differences(result):
    h = np.diff(result.t)
    velocity = np.diff(result.q, axis=0) / h[:, None]
    acceleration = 2.0 * np.diff(velocity, axis=0) / (h[1:] + h[:-1])[:, None]
    return velocity, acceleration


def test_retimed_plan_keeps_every_limit_passes_every_waypoint_and_the_tool_speed(ur5, seam):
    robot, chain = ur5
    plan, vmax = seam
    speed = 0.08
    motion = retime_plan(plan, chain, speed=speed)
    amax = vmax / 0.5  # the stated default: each joint's velocity limit reached from rest in 0.5 s
    velocity, acceleration = differences(motion)
    assert (np.abs(velocity) <= vmax * (1 + SLACK)).all()
    assert (np.abs(acceleration) <= amax * (1 + SLACK)).all()
    # every waypoint, in order, exactly
    index = motion.waypoint_index
    assert (np.diff(index) > 0).all() and index[0] == 0 and index[-1] == len(motion.t) - 1
    np.testing.assert_array_equal(motion.q[index], plan.q)
    # the tool by Pinocchio's FK: never faster than asked, and the limit binds (a line at 0.1 m/s planned)
    positions = pinocchio_tip_positions(robot, motion.q)  # ee_link: tool0 turned, the same origin
    tool = np.linalg.norm(np.diff(positions, axis=0), axis=1) / np.diff(motion.t)
    assert tool.max() <= speed * (1 + SLACK)
    assert tool.max() >= 0.99 * speed
    np.testing.assert_allclose(positions[index], plan.targets[:, :3, 3], atol=1e-9)
    # 0.187 m at 0.08 m/s at best: at least 2.34 s
    length = np.linalg.norm([0.1, 0.15, 0.05])
    assert motion.duration >= length / speed
    assert any(s.limit == "tool speed" for s in motion.slowdowns)


def test_a_low_velocity_scale_makes_a_joint_limit_bind(ur5, seam):
    _, chain = ur5
    plan, vmax = seam
    motion = retime_plan(plan, chain, speed=0.1, velocity_scale=0.01)
    velocity, _ = differences(motion)
    assert (np.abs(velocity) <= 0.01 * vmax * (1 + SLACK)).all()
    moved = np.abs(np.diff(plan.q, axis=0)).sum(axis=0) / (0.01 * vmax)  # seconds each joint needs at its limit
    binding = {s.joint for s in motion.slowdowns if s.limit == "velocity"}
    assert chain.joint_names[int(np.argmax(moved))] in binding
    assert motion.duration >= moved.max()


def test_explicit_acceleration_limits_and_the_scale(ur5, seam):
    _, chain = ur5
    plan, vmax = seam
    slow = retime_plan(plan, chain, acceleration_limits=0.05)
    _, acceleration = differences(slow)
    assert np.abs(acceleration).max() <= 0.05 * (1 + SLACK)
    fast = retime_plan(plan, chain, acceleration_scale=4.0)
    _, acceleration = differences(fast)
    assert (np.abs(acceleration) <= 4.0 * vmax / 0.5 * (1 + SLACK)).all()
    assert fast.duration < slow.duration


def test_plans_that_cannot_be_retimed_are_refused(ur5, seam):
    _, chain = ur5
    plan, _ = seam
    with pytest.raises(OptionError, match="acceleration_scale -1: give a positive factor"):
        retime_plan(plan, chain, acceleration_scale=-1)
    other = manipkit.load("iiwa14").chain("base_link", "ee_link")
    with pytest.raises(OptionError, match="the chain's joints are not the plan's"):
        retime_plan(plan, other)
