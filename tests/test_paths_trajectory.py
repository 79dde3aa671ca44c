"""Joint and Cartesian trajectories: hand derivations, finite differences, and Robotics Toolbox's numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from manipkit.errors import OptionError
from manipkit.paths import PosePath, Trajectory, ctraj, jtraj, mstraj, trapezoidal
from manipkit.spatial import matrix_from_axis_angle, rot_x, rot_z, transform_from_xyz_rpy


def finite_difference_check(traj: Trajectory, *, rtol: float) -> None:
    """qd and qdd agree with central differences of q and qd (second order: error ~ h^2 q''' / 6)."""
    scale_qd = max(np.abs(traj.qd).max(), 1e-12)
    scale_qdd = max(np.abs(traj.qdd).max(), 1e-12)
    np.testing.assert_allclose(np.gradient(traj.q, traj.t, axis=0)[1:-1], traj.qd[1:-1], atol=rtol * scale_qd)
    np.testing.assert_allclose(np.gradient(traj.qd, traj.t, axis=0)[1:-1], traj.qdd[1:-1], atol=rtol * scale_qdd)


# --------------------------------------------------------------------------
# jtraj


def test_jtraj_meets_its_boundary_conditions():
    q0, q1 = np.array([0.1, -0.4, 2.0]), np.array([1.2, 0.3, 2.0])
    v0, v1 = np.array([0.5, 0.0, 0.0]), np.array([-0.2, 0.1, 0.0])
    t = np.linspace(0.0, 2.0, 2001)
    traj = jtraj(q0, q1, t, qd0=v0, qd1=v1)
    np.testing.assert_allclose(traj.q[[0, -1]], [q0, q1], atol=1e-15)
    np.testing.assert_allclose(traj.qd[[0, -1]], [v0, v1], atol=1e-14)
    np.testing.assert_allclose(traj.qdd[0], 0.0, atol=1e-15)  # RTB's quintic has no s^2 term
    finite_difference_check(traj, rtol=1e-5)


def test_jtraj_rest_to_rest_peak_speed_is_fifteen_eighths_of_the_mean():
    # q(s) = q0 + dq (10 s^3 - 15 s^4 + 6 s^5); q'(1/2) = dq (30/4 - 60/8 + 30/16) = 15/8 dq; q''(1) = 0
    traj = jtraj([0.0], [2.0], np.linspace(0.0, 4.0, 5))
    assert traj.qd[2, 0] == pytest.approx(15 / 8 * 2.0 / 4.0, abs=1e-15)
    assert traj.qdd[-1, 0] == pytest.approx(0.0, abs=1e-14)
    # q(1/4) = 2 (10/64 - 15/256 + 6/1024) = 0.2070...
    assert traj.q[1, 0] == pytest.approx(2 * (10 / 64 - 15 / 256 + 6 / 1024), abs=1e-15)


def test_jtraj_count_runs_from_zero_to_one_and_equal_ends_stay():
    traj = jtraj([1.0, 2.0], [1.0, 2.0], 7)
    np.testing.assert_array_equal(traj.t, np.linspace(0, 1, 7))
    np.testing.assert_array_equal(traj.q, [[1.0, 2.0]] * 7)
    assert not np.isnan(traj.qdd).any()


# --------------------------------------------------------------------------
# trapezoidal


def test_trapezoid_by_hand_and_its_area():
    # dq = 3 in T = 3 s at V = 1.5: tb = (0 - 3 + 4.5) / 1.5 = 1 s, a = 1.5; area V (T - tb) = 1.5 * 2 = 3
    t = np.linspace(0.0, 3.0, 3001)
    traj = trapezoidal([0.0, 1.0], [3.0, 1.0], t, v=1.5)
    qd = traj.qd[:, 0]
    assert qd.max() == pytest.approx(1.5, abs=1e-15)
    np.testing.assert_allclose(traj.qdd[t < 1.0 - 1e-9, 0], 1.5)
    np.testing.assert_allclose(traj.qdd[(t > 1.0 + 1e-9) & (t < 2.0 - 1e-9), 0], 0.0)
    np.testing.assert_allclose(traj.qdd[t > 2.0 + 1e-9, 0], -1.5)
    # the velocity is piecewise linear with breaks on samples: the trapezoid rule integrates it exactly
    assert np.sum((qd[1:] + qd[:-1]) / 2 * np.diff(t)) == pytest.approx(3.0, abs=1e-12)
    assert traj.q[1500, 0] == pytest.approx(1.5, abs=1e-15)  # symmetric: halfway at half time
    np.testing.assert_array_equal(traj.q[:, 1], 1.0)  # a still joint stays still, no NaN
    # central differences are exact for a quadratic; across a jump of the acceleration by 1.5 they err by
    # h * 1.5 / 4 = 3.75e-4 (h = 1 ms), and only there
    error = np.abs(np.gradient(traj.q[:, 0], t)[1:-1] - qd[1:-1])
    assert error.max() <= 3.75e-4 + 1e-12 and np.count_nonzero(error > 1e-9) <= 4


def test_trapezoid_default_speed_is_one_and_a_half_times_the_mean():
    traj = trapezoidal([0.0], [-2.0], np.linspace(0.0, 4.0, 401))
    assert traj.qd[:, 0].min() == pytest.approx(-1.5 * 2.0 / 4.0, abs=1e-15)
    assert traj.q[-1, 0] == pytest.approx(-2.0, abs=1e-15)


def test_trapezoid_triangle_at_twice_the_mean():
    traj = trapezoidal([0.0], [1.0], np.linspace(0.0, 2.0, 201), v=1.0)  # tb = T / 2: no linear part
    assert traj.qd[100, 0] == pytest.approx(1.0, abs=1e-15)
    assert traj.q[-1, 0] == pytest.approx(1.0, abs=1e-14)


@pytest.mark.parametrize(("v", "message"), [(0.3, "v[0] = 0.3: joint 0 moves 1 in 2, so its cruise speed must be above 0.5"),
                                            (1.2, "at most 1"), (0.5, "above 0.5")])
def test_trapezoid_speed_out_of_range_is_one_line(v, message):
    with pytest.raises(OptionError, match=message.replace("[", r"\[").replace("]", r"\]")):
        trapezoidal([0.0], [1.0], np.linspace(0, 2, 5), v=v)


# --------------------------------------------------------------------------
# ctraj


def test_ctraj_translation_linear_and_rotation_about_one_axis_by_the_profile():
    axis = np.array([0.0, 0.6, 0.8])
    T0 = transform_from_xyz_rpy([0.3, 0.1, 0.5], [0.2, 0.0, 0.0])
    T1 = T0.copy()
    T1[:3, :3] = T0[:3, :3] @ matrix_from_axis_angle(axis, 1.2)
    T1[:3, 3] = [0.6, -0.2, 0.4]
    t = np.linspace(0.0, 2.0, 21)
    path = ctraj(T0, T1, t, profile="quintic")
    assert isinstance(path, PosePath) and path.t is not None
    tau = t / 2.0
    s = 10 * tau**3 - 15 * tau**4 + 6 * tau**5  # the rest-to-rest quintic, by hand
    np.testing.assert_allclose(path.poses[:, :3, 3], T0[:3, 3] + s[:, None] * (T1[:3, 3] - T0[:3, 3]), atol=1e-15)
    expected = T0[:3, :3] @ matrix_from_axis_angle(axis, 1.2 * s)
    np.testing.assert_allclose(path.poses[:, :3, :3], expected, atol=1e-14)


def test_ctraj_count_has_no_times():
    path = ctraj(np.eye(4), transform_from_xyz_rpy([1, 0, 0]), 5)
    assert path.t is None and len(path) == 5


def test_ctraj_unknown_profile_is_one_line():
    with pytest.raises(OptionError, match="give one of trapezoidal, quintic"):
        ctraj(np.eye(4), np.eye(4), 5, profile="cubic")


# --------------------------------------------------------------------------
# mstraj


def test_mstraj_by_hand_one_joint():
    # dt 0.1, tacc 0.2 (half blends 0.1 at the ends). Segment 0: 0 -> 2 at 1 rad/s: 0.1 + 2.0 = 2.1 s,
    # cruise 2/2.1. Segment 1: 2 -> 1: max(0.2 + 1.0, 2 * 0.2) = 1.2 s, cruise -1/1.2. End at 2.1 + 1.2 s.
    traj = mstraj([[0.0], [2.0], [1.0]], 0.1, 0.2, qdmax=1.0)
    assert traj.t[-1] == pytest.approx(3.3, abs=1e-12)
    assert traj.q[0, 0] == 0.0 and traj.q[-1, 0] == pytest.approx(1.0, abs=1e-15)
    on_first = (traj.t > 0.15) & (traj.t < 1.95)
    np.testing.assert_allclose(traj.qd[on_first, 0], 2 / 2.1, atol=1e-15)
    on_second = (traj.t > 2.25) & (traj.t < 3.15)
    np.testing.assert_allclose(traj.qd[on_second, 0], -1 / 1.2, atol=1e-15)
    assert np.abs(traj.qd).max() <= 1.0  # the speed limit
    # the corner at 2.0 is cut by the blend: the joint turns at less than 2
    assert traj.q[:, 0].max() < 2.0
    np.testing.assert_allclose(traj.qd[[0, -1], 0], 0.0, atol=1e-14)


def test_mstraj_velocity_is_continuous_and_differentiates_q():
    via = np.array([[0.0, 0.0], [1.0, 0.5], [0.5, 1.5], [0.0, 0.0]])
    traj = mstraj(via, 0.001, 0.4, qdmax=[1.0, 2.0])
    # central differences err by h^2 q''' / 6: the 0.2 s start blend has a jerk of a few hundred rad/s^3
    np.testing.assert_allclose(np.gradient(traj.q, traj.t, axis=0)[1:-1], traj.qd[1:-1], atol=3e-4)
    # continuous velocity: no step changes it by more than the largest acceleration times the step
    assert (np.abs(np.diff(traj.qd, axis=0)) <= np.abs(traj.qdd).max(axis=0) * 0.001 * 1.001).all()  # 0.1 %: the peak between samples
    np.testing.assert_allclose(traj.q[[0, -1]], via[[0, -1]], atol=1e-14)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"qdmax": 1.0, "tsegment": [1.0]}, "exactly one of qdmax"),
    ({}, "exactly one of qdmax"),
    ({"qdmax": [1.0, 2.0]}, "qdmax has 2 values"),
    ({"qdmax": 0.0}, r"qdmax\[0\] = 0"),
    ({"tsegment": [0.15]}, "leaves no time for its linear part"),
])
def test_mstraj_bad_arguments_are_one_line(kwargs, message):
    with pytest.raises(OptionError, match=message):
        mstraj([[0.0], [1.0]], 0.1, 0.2, **kwargs)


@pytest.mark.parametrize(("call", "message"), [
    (lambda: jtraj([0.0, 1.0], [1.0], 5), r"q1 has shape \(1,\); give shape \(2,\)"),
    (lambda: jtraj([0.0], [np.nan], 5), r"q1\[0\] is nan"),
    (lambda: jtraj([0.0], [1.0], 1), "give a whole number from 2"),
    (lambda: jtraj([0.0], [1.0], [0.0, 1.0, 1.0]), r"t\[2\] = 1 is not after t\[1\] = 1"),
    (lambda: trapezoidal([0.0], [1.0], 10**8), "give a whole number from 2 to 10000000"),
    (lambda: jtraj([0.0], [1.0], 5.0), "t 5.0: give a count of samples"),
    (lambda: mstraj([[0.0], [1.0]], 1e-7, 0.0, qdmax=1e-3), "mstraj: samples"),
])
def test_bad_trajectory_arguments_are_one_line(call, message):
    with pytest.raises(OptionError, match=message) as info:
        call()
    assert "\n" not in str(info.value)


# --------------------------------------------------------------------------
# Robotics Toolbox for Python, an independent implementation of the same definitions


@pytest.fixture(scope="module")
def rtb():
    return pytest.importorskip("roboticstoolbox.tools.trajectory")


def test_jtraj_matches_rtb(rtb):
    rng = np.random.default_rng(7)
    q0, q1, v0, v1 = rng.normal(size=(4, 6))
    t = np.linspace(0.0, 2.5, 40)
    for ours, theirs in ((jtraj(q0, q1, t, qd0=v0, qd1=v1), rtb.jtraj(q0, q1, t, qd0=v0, qd1=v1)),
                         (jtraj(q0, q1, 50), rtb.jtraj(q0, q1, 50))):
        for name in ("q", "qd", "qdd"):
            np.testing.assert_allclose(getattr(ours, name), getattr(theirs, name), atol=1e-9, rtol=0)
    np.testing.assert_allclose(jtraj(q0, q1, t).t, rtb.jtraj(q0, q1, t).t, atol=1e-15)


def test_trapezoidal_matches_rtb(rtb):
    rng = np.random.default_rng(8)
    q0, q1 = rng.normal(size=(2, 6))
    for t in (np.linspace(0.0, 2.5, 40), 33):
        ours, theirs = trapezoidal(q0, q1, t), rtb.mtraj(rtb.trapezoidal, q0, q1, t)
        np.testing.assert_allclose(ours.t, theirs.t, atol=0)
        for name in ("q", "qd", "qdd"):
            np.testing.assert_allclose(getattr(ours, name), getattr(theirs, name), atol=1e-9, rtol=0)
    ours, theirs = trapezoidal([0.0], [2.0], np.linspace(0, 3, 31), v=0.9), rtb.trapezoidal(0.0, 2.0, np.linspace(0, 3, 31), 0.9)
    np.testing.assert_allclose(ours.q[:, 0], theirs.q, atol=1e-9, rtol=0)


def test_ctraj_matches_rtb(rtb):
    SE3 = pytest.importorskip("spatialmath").SE3
    T0 = SE3.Rx(0.3) * SE3.Trans(0.1, 0.2, 0.3)
    T1 = SE3.Rz(2.0) * SE3.Ry(0.5) * SE3.Trans(0.5, -0.2, 0.1)
    for t in (20, np.linspace(0.0, 3.0, 31)):
        ours, theirs = ctraj(T0.A, T1.A, t), rtb.ctraj(T0, T1, t)
        np.testing.assert_allclose(ours.poses, np.array([T.A for T in theirs]), atol=1e-9, rtol=0)


@pytest.mark.parametrize("kwargs", [
    {"tacc": 0.3, "qdmax": [1.0, 2.0, 0.5]},
    {"tacc": [0.3, 0.2, 0.4, 0.1], "tsegment": [1.0, 2.0, 1.5, 1.0], "qd0": [0.1, 0, 0], "qdf": [0, 0.2, 0]},
    {"tacc": 0.0, "qdmax": 1.5},
])
def test_mstraj_matches_rtb_after_its_first_sample(rtb, kwargs):
    via = np.random.default_rng(9).normal(size=(5, 3))
    tacc = kwargs.pop("tacc")
    ours, theirs = mstraj(via, 0.05, tacc, **kwargs), rtb.mstraj(via, 0.05, tacc, **kwargs)
    assert len(ours) == len(theirs.t) + 1
    np.testing.assert_allclose(ours.t[1:] - 0.05, theirs.t, atol=1e-12)
    for name in ("q", "qd", "qdd"):
        np.testing.assert_allclose(getattr(ours, name)[1:], getattr(theirs, name), atol=1e-9, rtol=0)


def test_rotation_helpers_used_by_the_tests_agree():
    # the tests' own reference rotations: Rz(pi/2) as an axis-angle equals rot_z; rot_x(pi) squared is I
    np.testing.assert_allclose(matrix_from_axis_angle([0, 0, 1], math.pi / 2), rot_z(math.pi / 2), atol=1e-15)
    np.testing.assert_allclose(rot_x(math.pi) @ rot_x(math.pi), np.eye(3), atol=1e-15)
