"""Time scaling by TOPP-RA: limits checked by finite differences of the output, waypoints, tool speed by Pinocchio."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from manipkit.errors import OptionError
from manipkit.paths import retime

pytest.importorskip("toppra")

SLACK = 1e-3  # the 0.1 % the issue allows finite differences of the output


def differences(result):
    """Velocities over each sample interval and second differences (non-uniform three-point formula).

    Each is a weighted average of the true derivative over its interval(s) (mean value theorem; the
    second difference's Peano kernel is positive), so it cannot exceed a bound the motion keeps."""
    h = np.diff(result.t)
    velocity = np.diff(result.q, axis=0) / h[:, None]
    acceleration = 2.0 * np.diff(velocity, axis=0) / (h[1:] + h[:-1])[:, None]
    return velocity, acceleration


def assert_within(result, vmax, amax):
    velocity, acceleration = differences(result)
    assert (np.abs(velocity) <= np.broadcast_to(vmax, velocity.shape[1:]) * (1 + SLACK)).all()
    assert (np.abs(acceleration) <= np.broadcast_to(amax, acceleration.shape[1:]) * (1 + SLACK)).all()
    return velocity, acceleration


def smooth_path(seed: int, n: int = 6, count: int = 60) -> np.ndarray:
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, count)[:, None]
    amplitude, frequency, phase = rng.uniform(0.2, 1.0, (3, n))
    return amplitude * np.sin(2 * np.pi * frequency * s + 6 * phase) + rng.normal(scale=1e-3, size=(count, n))


# --------------------------------------------------------------------------
# hand cases


def test_one_joint_trapezoid_by_hand():
    # vmax 1, amax 2: accelerate 0.5 s over 0.25 rad, cruise 0.5 rad in 0.5 s, brake 0.5 s: 1.5 s
    result = retime([[0.0], [1.0]], velocity_limits=1.0, acceleration_limits=2.0)
    assert result.duration == pytest.approx(1.5, abs=1e-6)
    assert np.abs(result.qd).max() == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_array_equal(result.q[result.waypoint_index], [[0.0], [1.0]])
    assert result.waypoint_times.tolist() == [0.0, result.duration]
    shares = {(s.limit, s.joint): s.share for s in result.slowdowns}
    # acceleration binds while speeding up and braking (1 s of 1.5), velocity while cruising (0.5 s)
    assert shares == pytest.approx({("acceleration", "joint 0"): 2 / 3, ("velocity", "joint 0"): 1 / 3}, abs=1e-6)


def test_one_joint_triangle_by_hand():
    # 0.25 rad at amax 2 never reaches vmax 1: peak sqrt(a d) = sqrt(0.5), duration 2 sqrt(d / a) = 0.7071 s
    result = retime([[0.0], [0.25]], velocity_limits=1.0, acceleration_limits=2.0)
    assert result.duration == pytest.approx(2 * math.sqrt(0.125), abs=1e-6)
    assert np.abs(result.qd).max() == pytest.approx(math.sqrt(0.5), abs=1e-3)  # sampled every ms near the peak
    assert [(s.limit, s.share) for s in result.slowdowns] == [("acceleration", pytest.approx(1.0))]


def test_slowdowns_say_which_limit_binds_on_which_segment():
    # one joint, 0 -> 5 -> 10 rad at 1 rad/s and 2 rad/s^2: each segment takes 5.25 s, 0.5 s of it accelerating
    result = retime([[0.0], [5.0], [10.0]], velocity_limits=1.0, acceleration_limits=2.0, joint_names=["slide"])
    # the blends end at 0.25 rad from the ends, between grid points (5/64 rad apart): TOPP-RA's piecewise constant
    # path acceleration reaches cruise a little later, never sooner, than the exact optimum
    assert 10.5 - 1e-9 <= result.duration <= 10.5 + 0.005
    assert result.waypoint_times == pytest.approx([0.0, 5.25, 10.5], abs=0.005)
    by_segment = {(s.segment, s.limit): s.share for s in result.slowdowns}
    grid = 5.0 / 64 / 1.0  # one grid interval at cruise speed, in seconds: how finely shares are resolved
    assert by_segment[(0, "acceleration")] == pytest.approx(0.5 / 5.25, abs=grid / 5.25)
    assert by_segment[(0, "velocity")] == pytest.approx(4.75 / 5.25, abs=grid / 5.25)
    assert by_segment[(1, "acceleration")] == pytest.approx(0.5 / 5.25, abs=grid / 5.25)
    assert "waypoints 0-1: slide's velocity limit binds" in "\n".join(result.explain())
    # one joint: the spline through collinear waypoints is the line itself
    assert result.path_deviation < 1e-14 and "strays at most" in result.explain()[1]


# --------------------------------------------------------------------------
# limits, waypoints, order


@pytest.mark.parametrize("seed", range(4))
def test_limits_hold_by_finite_differences_and_every_waypoint_is_passed_in_order(seed):
    Q = smooth_path(seed)
    vmax = np.array([2.0, 2.0, 3.0, 3.0, 3.0, 3.0])
    amax = np.array([4.0, 4.0, 6.0, 8.0, 8.0, 8.0])
    result = retime(Q, velocity_limits=vmax, acceleration_limits=amax)
    velocity, acceleration = assert_within(result, vmax, amax)
    # some limit is reached (the motion is not needlessly slow): within 2 % of one
    assert max((np.abs(velocity) / vmax).max(), (np.abs(acceleration) / amax).max()) > 0.98
    np.testing.assert_array_equal(result.q[result.waypoint_index], Q)
    assert (np.diff(result.waypoint_times) > 0).all() and (np.diff(result.waypoint_index) > 0).all()
    assert result.t[0] == 0.0 and result.t[-1] == pytest.approx(result.duration, abs=1e-12)
    np.testing.assert_allclose(result.qd[[0, -1]], 0.0, atol=1e-9)  # rest to rest
    # qd and qdd are the derivatives of q: the interval velocity is the mean of qd at its ends to O(h^2)
    mean_qd = (result.qd[1:] + result.qd[:-1]) / 2
    assert np.abs(velocity - mean_qd).max() <= 1e-3 * vmax.max()
    assert result.max_velocity_ratio <= 1 + 1e-9 and result.max_acceleration_ratio <= 1 + 1e-9


def test_repeated_waypoints_are_passed_at_one_time():
    Q = np.array([[0.0, 0.0], [0.5, 0.2], [0.5, 0.2], [1.0, 0.3]])
    result = retime(Q, velocity_limits=1.0, acceleration_limits=1.0)
    assert result.waypoint_times[1] == result.waypoint_times[2]
    np.testing.assert_array_equal(result.q[result.waypoint_index], Q)
    assert_within(result, 1.0, 1.0)


def test_a_path_that_stays_put_takes_no_time():
    result = retime([[0.1, 0.2]] * 3, velocity_limits=1.0, acceleration_limits=1.0)
    assert result.duration == 0.0 and len(result.t) == 1 and result.waypoint_times.tolist() == [0.0, 0.0, 0.0]


# --------------------------------------------------------------------------
# tool speed on ur5, measured by Pinocchio's FK


@pytest.fixture(scope="module")
def ur5_chain(load_robot):
    robot = load_robot("ur5")
    return robot, robot.chain("base_link", "ee_link")


def pinocchio_tip_positions(robot, Q) -> np.ndarray:
    model, data = robot.model, robot.model.createData()
    base, tip = robot.frame_id("base_link"), robot.frame_id("ee_link")
    positions = []
    for q in Q:
        pin.framesForwardKinematics(model, data, robot.pinocchio_configuration(q))
        positions.append((data.oMf[base].inverse() * data.oMf[tip]).translation.copy())
    return np.array(positions)


def test_tool_speed_is_never_exceeded_by_pinocchio_fk(ur5_chain):
    robot, chain = ur5_chain
    q0 = np.array([0.1, -1.2, 1.5, -1.8, -1.5, 0.3])
    s = np.linspace(0.0, 1.0, 30)[:, None]
    Q = q0 + s * np.array([0.8, 0.3, -0.5, 0.4, 0.6, -0.2]) + 0.1 * np.sin(3 * s) * np.array([1, -1, 0, 1, 0, 0])
    vmax, amax, speed = 2.0, 4.0, 0.2
    result = retime(Q, velocity_limits=vmax, acceleration_limits=amax, tool_speed=speed, chain=chain)
    assert_within(result, vmax, amax)
    positions = pinocchio_tip_positions(robot, result.q)
    tool = np.linalg.norm(np.diff(positions, axis=0), axis=1) / np.diff(result.t)
    assert tool.max() <= speed * (1 + SLACK)
    assert tool.max() >= 0.99 * speed  # it binds: the same path without it is faster
    free = retime(Q, velocity_limits=vmax, acceleration_limits=amax)
    assert free.duration < result.duration
    free_tool = np.linalg.norm(np.diff(pinocchio_tip_positions(robot, free.q), axis=0), axis=1) / np.diff(free.t)
    assert free_tool.max() > 1.5 * speed
    assert any(s.limit == "tool speed" for s in result.slowdowns)
    assert result.max_tool_speed == pytest.approx(tool.max(), rel=1e-3)
    np.testing.assert_array_equal(result.q[result.waypoint_index], Q)
    assert result.joint_names == chain.joint_names


# --------------------------------------------------------------------------
# bad input: one line each


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"velocity_limits": 0.0}, r"velocity_limits\[0\] = 0; give positive values"),
    ({"velocity_limits": [1.0, -1.0]}, r"velocity_limits\[1\] = -1"),
    ({"acceleration_limits": float("nan")}, r"acceleration_limits\[0\] is nan; give finite numbers"),
    ({"acceleration_limits": [1.0, 1.0, 1.0]}, r"acceleration_limits has 3 values; give one number or one per joint \(2\)"),
    ({"tool_speed": 0.5}, "tool_speed needs the chain"),
    ({"tool_speed": 0.0}, "tool_speed 0: give a speed in m/s from 1e-09"),
    ({"dt": 0}, "dt 0"),
    ({"q": [[0.0, np.nan], [1.0, 1.0]]}, r"q\[0, 1\] is nan"),
    ({"q": [[0.0, 0.0]]}, "q: waypoints 1: give a whole number from 2"),
    ({"q": [0.0, 1.0]}, r"q has shape \(2,\)"),
    ({"subdivisions": 0}, "subdivisions 0"),
])
def test_bad_retime_input_is_one_line(kwargs, message):
    arguments = {"q": [[0.0, 0.0], [1.0, 1.0]], "velocity_limits": 1.0, "acceleration_limits": 1.0, **kwargs}
    with pytest.raises(OptionError, match=message) as info:
        retime(arguments.pop("q"), **arguments)
    assert "\n" not in str(info.value)


def test_chain_of_other_size_is_refused(ur5_chain):
    _, chain = ur5_chain
    with pytest.raises(OptionError, match="q has 2 joints per waypoint but the chain base_link -> ee_link has 6"):
        retime([[0.0, 0.0], [1.0, 1.0]], velocity_limits=1.0, acceleration_limits=1.0, chain=chain)
