"""Tests of manipkit.closed_form.planar: closed-form 2R/3R FK and IK against Pinocchio and hand values.

Conventions under test: joints turn about +z (counter-clockwise seen from +z),
q1 from the base x axis, q2 (q3) relative to the previous link; tool
orientation phi = q1 + q2 (+ q3); IK angles wrapped to (-pi, pi];
elbow-down = q2 in (0, pi), listed first; elbow-up = q2 in (-pi, 0).

The bundled planar_2r / planar_3r xacros take the link lengths as the xacro
arguments l1, l2 (and l3), and nothing else.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import manipkit
from manipkit.closed_form.planar import (
    PlanarArmError,
    chain_points,
    fk_2r,
    fk_3r,
    se2_3r,
    workspace_2r,
    workspace_3r,
)
from manipkit.errors import ManipkitError
from manipkit.ik.planar import ik_2r, ik_2r_batch, ik_3r, ik_3r_batch
from manipkit.ik.result import IKResult

PI = math.pi
SETTINGS = settings(deadline=None, max_examples=60)

# link lengths drawn once from a seeded generator (and one fixed set each), so the
# Pinocchio models are loaded a handful of times only
_RNG = np.random.default_rng(20240607)
LENGTHS_2R = [(1.0, 1.0), (0.7, 1.3), tuple(_RNG.uniform(0.2, 2.0, 2).round(6)), tuple(_RNG.uniform(0.2, 2.0, 2))]
LENGTHS_3R = [(4.0, 2.0, 1.0), (1.0, 2.0, 4.0), tuple(_RNG.uniform(0.2, 2.0, 3))]

lengths = st.floats(0.1, 5.0, allow_nan=False)
angles = st.floats(-PI, PI, allow_nan=False)


@functools.cache
def robot(*link_lengths: float):
    """The bundled planar arm with these link lengths (xacro args l1, l2[, l3])."""
    name = {2: "planar_2r", 3: "planar_3r"}[len(link_lengths)]
    return manipkit.load(name, **{f"l{i + 1}": value for i, value in enumerate(link_lengths)})


def random_q(n: int, joints: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-PI, PI, (n, joints))


def planar_pose(T: np.ndarray) -> np.ndarray:
    """(x, y, phi) of 4x4 poses of a frame that turns about z only; phi from the rotation."""
    return np.stack([T[..., 0, 3], T[..., 1, 3], np.arctan2(T[..., 1, 0], T[..., 0, 0])], axis=-1)


def wrapped(angle):
    """Angle difference mapped to [-pi, pi)."""
    return (np.asarray(angle) + PI) % (2 * PI) - PI


# ---------------------------------------------------------------- forward kinematics


def test_fk_2r_hand_values():
    # q = (0, 90 deg): link 1 along +x (to (l1, 0)), link 2 turned up: (l1, l2)
    # q = (90 deg, 90 deg): link 1 up to (0, l1), link 2 along 180 deg: (-l2, l1)
    x, y = fk_2r([0.0, PI / 2], [PI / 2, PI / 2], 1.0, 0.5)
    assert np.max(np.abs(x - [1.0, -0.5])) < 1e-15
    assert np.max(np.abs(y - [0.5, 1.0])) < 1e-15


@pytest.mark.parametrize("link_lengths", LENGTHS_2R)
def test_fk_2r_matches_pinocchio_model(link_lengths):
    Q = random_q(200, 2)
    T = robot(*link_lengths).fk(Q, tip="ee_link")
    x, y = fk_2r(Q[:, 0], Q[:, 1], *link_lengths)
    assert np.max(np.abs(np.stack([x, y], -1) - T[:, :2, 3])) <= 1e-12
    assert np.max(np.abs(T[:, 2, 3])) == 0.0  # the arm stays in the x-y plane
    # the tool turns by q1 + q2 about z
    assert np.max(np.abs(wrapped(planar_pose(T)[:, 2] - Q.sum(axis=1)))) <= 1e-12


def test_fk_2r_matches_pinocchio_frame_placement():
    # Pinocchio's own forward kinematics (not manipkit's batched chain) on a few configurations
    link_lengths = LENGTHS_2R[2]
    arm = robot(*link_lengths)
    frame = arm.model.getFrameId("ee_link")
    for q in random_q(5, 2, seed=1):
        pin.framesForwardKinematics(arm.model, arm.data, arm.pinocchio_configuration(q))
        position = arm.data.oMf[frame].translation
        assert np.max(np.abs(np.array(fk_2r(q[0], q[1], *link_lengths)) - position[:2])) <= 1e-12


@pytest.mark.parametrize("link_lengths", LENGTHS_3R)
def test_fk_3r_matches_pinocchio_model(link_lengths):
    Q = random_q(200, 3)
    T = robot(*link_lengths).fk(Q, tip="ee_link")
    pose = np.stack(fk_3r(Q[:, 0], Q[:, 1], Q[:, 2], *link_lengths), axis=-1)
    expected = planar_pose(T)
    assert np.max(np.abs(pose[:, :2] - expected[:, :2])) <= 1e-12
    assert np.max(np.abs(wrapped(pose[:, 2] - expected[:, 2]))) <= 1e-12


@pytest.mark.parametrize("link_lengths", LENGTHS_3R)
def test_se2_3r_is_pinocchio_pose_restricted_to_the_plane(link_lengths):
    Q = random_q(50, 3, seed=2)
    T = robot(*link_lengths).fk(Q, tip="ee_link")
    se2 = se2_3r(Q[:, 0], Q[:, 1], Q[:, 2], *link_lengths)
    assert se2.shape == (50, 3, 3)
    assert np.max(np.abs(se2[:, :2, :2] - T[:, :2, :2])) <= 1e-12
    assert np.max(np.abs(se2[:, :2, 2] - T[:, :2, 3])) <= 1e-12
    assert np.all(se2[:, 2] == [0.0, 0.0, 1.0])


def test_fk_3r_seed_figure_2_configurations_touch_the_workspace_circles():
    # seed 004, figure 2 (lengths 4, 2, 1, all along x at q1 = 0):
    # (0, 0, 0) -> 4 + 2 + 1 = 7, (0, pi, 0) -> 4 - 2 - 1 = 1,
    # (0, 0, pi) -> 4 + 2 - 1 = 5, (0, pi, pi) -> 4 - 2 + 1 = 3
    q2 = np.array([0.0, PI, 0.0, PI])
    q3 = np.array([0.0, 0.0, PI, PI])
    x, y, _ = fk_3r(0.0, q2, q3, 4.0, 2.0, 1.0)
    assert np.max(np.abs(x - [7.0, 1.0, 5.0, 3.0])) < 1e-14
    assert np.max(np.abs(y)) < 1e-14


def test_fk_3r_orientation_is_wrapped():
    # q1 + q2 + q3 = 3 * 2 = 6 rad, which is 6 - 2 pi = -0.283 in (-pi, pi]
    assert abs(fk_3r(2.0, 2.0, 2.0, 1.0, 1.0, 1.0)[2] - (6.0 - 2 * PI)) < 1e-15


def test_chain_points_start_at_base_and_end_at_the_tool():
    Q = random_q(20, 3, seed=3)
    points = chain_points(Q, [4.0, 2.0, 1.0])
    assert points.shape == (20, 4, 2)
    assert np.all(points[:, 0] == 0.0)
    x, y, _ = fk_3r(Q[:, 0], Q[:, 1], Q[:, 2], 4.0, 2.0, 1.0)
    assert np.max(np.abs(points[:, 3] - np.stack([x, y], -1))) < 1e-14
    # each segment is as long as its link
    assert np.max(np.abs(np.linalg.norm(np.diff(points, axis=1), axis=-1) - [4.0, 2.0, 1.0])) < 1e-14


# ---------------------------------------------------------------- 2R inverse kinematics


def test_ik_2r_hand_value_two_solutions():
    # l1 = l2 = 1, target (1, 1): r^2 = 2, cos q2 = (2 - 1 - 1) / 2 = 0, q2 = +-90 deg.
    # elbow-down q2 = +90: q1 = atan2(1, 1) - atan2(sin q2, 1 + cos q2) = 45 - 45 = 0
    #   (link 1 along +x to (1, 0), link 2 up to (1, 1));
    # elbow-up q2 = -90: q1 = 45 + 45 = 90 (link 1 up to (0, 1), link 2 along +x)
    result = ik_2r(1.0, 1.0, 1.0, 1.0)
    assert result.count == 2
    assert result.labels == ("elbow-down", "elbow-up")
    assert np.max(np.abs(result.solutions - [[0.0, PI / 2], [PI / 2, -PI / 2]])) < 1e-15


def test_ik_2r_elbow_down_puts_the_elbow_below_a_target_on_plus_x():
    # l1 = l2 = 1, target (1.5, 0): elbow-down has q2 > 0 and q1 = -acos(0.75) < 0, so the elbow
    # (cos q1, sin q1) is below the x axis; elbow-up mirrors it above
    result = ik_2r(1.5, 0.0, 1.0, 1.0)
    (q1_down, q2_down), (q1_up, q2_up) = result.solutions
    assert q2_down > 0.0 and math.sin(q1_down) < 0.0
    assert q2_up < 0.0 and math.sin(q1_up) > 0.0
    assert abs(q1_down + math.acos(0.75)) < 1e-15


@pytest.mark.parametrize("link_lengths", LENGTHS_2R)
def test_ik_2r_then_pinocchio_fk_returns_the_target(link_lengths):
    # reachable targets made by FK of random joint angles; Pinocchio checks where each solution lands
    Q = random_q(100, 2, seed=4)
    targets = np.stack(fk_2r(Q[:, 0], Q[:, 1], *link_lengths), axis=-1)
    arm = robot(*link_lengths)
    for target in targets:
        result = ik_2r(*target, *link_lengths)
        assert result.count == 2
        reached = arm.fk(result.solutions, tip="ee_link")[:, :2, 3]
        assert np.max(np.abs(reached - target)) <= 1e-9
        (q1_down, q2_down), (q1_up, q2_up) = result.solutions
        assert q2_down > 0.0 > q2_up  # distinct: opposite elbows
        assert abs(q2_down + q2_up) <= 1e-12  # q2 = +-acos(D)


@SETTINGS
@given(lengths, lengths, angles, st.floats(0.05, PI - 0.05))
def test_ik_2r_recovers_the_configuration_it_came_from(l1, l2, q1, q2_abs):
    # away from the boundary (|q2| >= 0.05) the FK of (q1, +-q2) has it among its solutions
    for q2 in (q2_abs, -q2_abs):
        result = ik_2r(*fk_2r(q1, q2, l1, l2), l1, l2)
        row = 0 if q2 > 0 else 1
        assert np.max(np.abs(wrapped(result.solutions[row] - [q1, q2]))) <= 1e-9


def test_ik_2r_target_with_negative_x_where_atan_y_over_x_fails():
    # seed 000 used theta1 = atan(y / x) - atan(l2 s2 / (l1 + l2 c2)); atan(y / x) is in (-90, 90) deg,
    # so for x < 0 it points the arm the opposite way: q = (2.5, 0.6) puts the tool at x < 0
    l1, l2 = 1.0, 0.8
    x, y = fk_2r(2.5, 0.6, l1, l2)
    assert x < 0.0
    q2 = math.acos((x * x + y * y - l1 * l1 - l2 * l2) / (2 * l1 * l2))
    q1_seed = math.atan(y / x) - math.atan(l2 * math.sin(q2) / (l1 + l2 * math.cos(q2)))
    seed_miss = math.dist(fk_2r(q1_seed, q2, l1, l2), (x, y))
    assert seed_miss > 1.0  # the tool lands on the far side of the base: off by 2 r
    result = ik_2r(x, y, l1, l2)
    for q in result.solutions:
        assert math.dist(fk_2r(q[0], q[1], l1, l2), (x, y)) <= 1e-12
    assert np.max(np.abs(result.solutions[0] - [2.5, 0.6])) <= 1e-12  # the elbow-down one we came from


@SETTINGS
@given(lengths, lengths, angles)
def test_ik_2r_on_outer_circle_has_exactly_one_straight_solution(l1, l2, direction):
    x, y = (l1 + l2) * math.cos(direction), (l1 + l2) * math.sin(direction)
    result = ik_2r(x, y, l1, l2, tol=1e-9)
    assert result.count == 1 and result.labels == ("straight",)
    assert result.solutions[0, 1] == 0.0
    assert math.dist(fk_2r(*result.solutions[0], l1, l2), (x, y)) <= 1e-9


@SETTINGS
@given(lengths, lengths, angles)
def test_ik_2r_on_inner_circle_has_exactly_one_folded_solution(l1, l2, direction):
    inner = abs(l1 - l2)
    if inner < 1e-6:
        l2 = l1 + 0.5  # equal links: the inner circle is the base point, tested separately
        inner = 0.5
    x, y = inner * math.cos(direction), inner * math.sin(direction)
    result = ik_2r(x, y, l1, l2, tol=1e-9)
    assert result.count == 1 and result.labels == ("folded",)
    assert result.solutions[0, 1] == PI
    assert math.dist(fk_2r(*result.solutions[0], l1, l2), (x, y)) <= 1e-9


def test_ik_2r_folded_with_longer_second_link_points_link_one_away():
    # l1 = 0.5, l2 = 1, target (0.5, 0) on the inner circle: link 1 goes to (-0.5, 0) (q1 = pi),
    # link 2 folds back over it (q2 = pi) and ends at (0.5, 0)
    result = ik_2r(0.5, 0.0, 0.5, 1.0)
    assert result.count == 1
    assert np.max(np.abs(result.solutions - [[PI, PI]])) < 1e-15


def test_ik_2r_boundary_tolerance_decides_between_one_and_none():
    # r = 2 + 0.5e-12 is within tol = 1e-12 of the outer circle (1 solution), r = 2 + 5e-12 is not (0)
    assert ik_2r(2.0 + 0.5e-12, 0.0, 1.0, 1.0).count == 1
    assert ik_2r(2.0 + 5e-12, 0.0, 1.0, 1.0).count == 0
    assert ik_2r(2.0 - 5e-12, 0.0, 1.0, 1.0).count == 2


def test_ik_2r_too_far_reports_side_and_distance():
    # l1 + l2 = 1.5; the target at r = 5 (3-4-5 triangle) is 3.5 outside
    result = ik_2r(3.0, -4.0, 1.0, 0.5)
    assert result.count == 0 and result.solutions.shape == (0, 2) and result.labels == ()
    assert result.side == "too far"
    assert abs(result.outside_by - 3.5) < 1e-15
    assert result.reason == "no solution: target too far: r = 5 > l1 + l2 = 1.5, outside by 3.5"


def test_ik_2r_too_close_reports_side_and_distance():
    # |l1 - l2| = 0.5; the target at r = 0.1 is 0.4 inside the inner circle
    result = ik_2r(0.0, -0.1, 1.0, 0.5)
    assert result.count == 0 and result.side == "too close"
    assert abs(result.outside_by - 0.4) < 1e-15
    assert "too close: r = 0.1 < |l1 - l2| = 0.5" in result.reason


def test_ik_2r_at_base_with_equal_links_is_infinite_with_q1_free():
    result = ik_2r(0.0, 0.0, 0.8, 0.8)
    assert result.count == math.inf and result.infinite
    assert result.free_joint == 0
    assert result.labels == ("q1 free",)
    assert result.reason == "" and "q2 = pi" in result.note and "q1 takes any value" in result.note
    # every member of the family (any q1, q2 = pi) reaches the base
    q1 = np.linspace(-PI, PI, 9)
    x, y = fk_2r(q1, result.solutions[0, 1], 0.8, 0.8)
    assert np.max(np.hypot(x, y)) < 1e-15


def test_ik_2r_at_base_with_unequal_links_has_no_solution():
    result = ik_2r(0.0, 0.0, 1.0, 0.9)
    assert result.count == 0 and result.side == "too close"
    assert abs(result.outside_by - 0.1) < 1e-15


def test_ik_2r_angles_on_the_negative_x_axis_read_plus_pi():
    # target (-2, -0.0): atan2(-0.0, -2) = -pi; the straight solution must read q1 = +pi
    result = ik_2r(-2.0, -0.0, 1.0, 1.0)
    assert result.solutions.tolist() == [[PI, 0.0]]


@SETTINGS
@given(lengths, lengths, st.floats(-10.0, 10.0), st.floats(-10.0, 10.0))
def test_ik_2r_angles_are_wrapped_to_minus_pi_pi(l1, l2, x, y):
    solutions = ik_2r(x, y, l1, l2).solutions
    assert np.all((solutions > -PI) & (solutions <= PI))


def test_ik_2r_result_is_read_only():
    result = ik_2r(1.0, 1.0, 1.0, 1.0)
    assert isinstance(result, IKResult)
    with pytest.raises(ValueError):
        result.solutions[0, 0] = 1.0
    with pytest.raises(AttributeError):
        result.count = 3


def test_ik_2r_batch_equals_scalar_on_every_case():
    # inside, both boundary circles, too far, too close, the base (equal and unequal links)
    l1, l2 = 1.0, 0.6
    targets = np.array(
        [[1.0, 0.5], [-0.3, -1.2], [1.6, 0.0], [0.0, -0.4], [-2.0, 1.0], [0.1, 0.1], [0.0, 0.0], [-1.0, -1e-3]]
    )
    batch = ik_2r_batch(targets, l1, l2)
    assert np.array_equal(batch.success, batch.count > 0) and batch.mode == ik_2r(1.0, 0.5, l1, l2).mode
    for i, (target, solutions, count, outside) in enumerate(zip(targets, batch.solutions, batch.count, batch.outside_by)):
        result = ik_2r(*target, l1, l2)
        k = len(result.labels)
        assert count == result.count and outside == result.outside_by and batch.success[i] == result.success
        assert np.array_equal(solutions[:k], result.solutions)
        assert np.all(np.isnan(solutions[k:]))
        # the same FK residuals per slot as the scalar solver's per row; NaN in an empty slot
        np.testing.assert_allclose(batch.residuals[i, :k], result.residuals, atol=1e-15)
        assert np.all(np.isnan(batch.residuals[i, k:]))
    equal = ik_2r_batch([[0.0, 0.0]], 0.8, 0.8)
    assert equal.count.tolist() == [math.inf]
    assert np.array_equal(equal.solutions[0, 0], ik_2r(0.0, 0.0, 0.8, 0.8).solutions[0])


def test_ik_2r_batch_keeps_leading_dimensions():
    xy = np.random.default_rng(5).uniform(-2.0, 2.0, (40, 250, 2))
    batch = ik_2r_batch(xy, 1.2, 0.8)
    assert batch.solutions.shape == (40, 250, 2, 2) and batch.count.shape == (40, 250)
    # FK of every present solution returns its target
    x, y = fk_2r(batch.solutions[..., 0], batch.solutions[..., 1], 1.2, 0.8)
    present = ~np.isnan(x)
    assert np.array_equal(present.sum(axis=-1), batch.count.astype(int))
    miss = np.hypot(x - xy[..., None, 0], y - xy[..., None, 1])
    assert np.max(miss[present]) <= 1e-9
    # the batch's own residuals (the DH table's FK) against the formulas written out here
    assert batch.residual_position.shape == (40, 250, 2) and batch.q_residuals.shape == (40, 250, 2)
    np.testing.assert_allclose(batch.residual_position[present], miss[present], atol=1e-12)
    assert np.all(np.isnan(batch.residual_position[~present])) and np.all(batch.residual_rotation[present] == 0.0)
    assert np.array_equal(batch.success, batch.count > 0)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: ik_2r(1.0, 1.0, 0.0, 1.0), r"l1 = 0.0 is not a valid link length; it must be a finite number > 0"),
        (lambda: ik_2r(1.0, 1.0, 1.0, -2.0), r"l2 = -2.0 is not a valid link length"),
        (lambda: ik_2r(1.0, 1.0, 1.0, float("nan")), r"l2 = nan is not a valid link length"),
        (lambda: ik_2r(1.0, 1.0, "one", 1.0), r"l1 must be numeric, got 'one'"),
        (lambda: ik_2r(float("inf"), 1.0, 1.0, 1.0), r"x = inf is not finite"),
        (lambda: ik_2r([1.0, 2.0], 1.0, 1.0, 1.0), r"x must be a single number.*use the \*_batch solver"),
        (lambda: ik_2r_batch([[1.0, 2.0, 3.0]], 1.0, 1.0), r"xy must have shape \(\.\.\., 2\), got \(1, 3\)"),
        (lambda: ik_2r_batch([[1.0, 2.0], [np.nan, 0.0]], 1.0, 1.0), r"xy\[1, 0\] = nan is not finite"),
        (lambda: ik_3r(1.0, 1.0, 0.0, 1.0, 1.0, 0.0), r"l3 = 0.0 is not a valid link length"),
    ],
)
def test_planar_solvers_reject_bad_input_with_a_clear_message(call, message):
    with pytest.raises(PlanarArmError, match=message) as raised:
        call()
    assert isinstance(raised.value, ManipkitError) and isinstance(raised.value, ValueError)


# ---------------------------------------------------------------- 3R inverse kinematics


def test_ik_3r_seed_arm_hand_value():
    # lengths 4, 2, 1; tool at (3, 2) pointing along -x (phi = pi): wrist at (3, 2) - 1 * (-1, 0) = (4, 2).
    # 2R for the wrist: r^2 = 20 = 4^2 + 2^2, so cos q2 = 0, q2 = +-90 deg.
    # elbow-down: q1 = atan2(2, 4) - atan2(2, 4) = 0, q3 = pi - 0 - pi/2 = pi/2
    # elbow-up:   q1 = 2 atan2(2, 4) = 0.9273, q3 = pi - 0.9273 + pi/2 - 2 pi = -2.4981
    result = ik_3r(3.0, 2.0, PI, 4.0, 2.0, 1.0)
    assert result.count == 2 and result.labels == ("elbow-down", "elbow-up")
    q1_up = 2 * math.atan2(2.0, 4.0)
    expected = [[0.0, PI / 2, PI / 2], [q1_up, -PI / 2, PI - q1_up + PI / 2 - 2 * PI]]
    assert np.max(np.abs(result.solutions - expected)) < 1e-14


@pytest.mark.parametrize("link_lengths", LENGTHS_3R)
def test_ik_3r_then_pinocchio_fk_returns_the_target_pose(link_lengths):
    Q = random_q(100, 3, seed=6)
    poses = np.stack(fk_3r(Q[:, 0], Q[:, 1], Q[:, 2], *link_lengths), axis=-1)
    arm = robot(*link_lengths)
    for pose in poses:
        result = ik_3r(*pose, *link_lengths)
        assert result.count == 2
        reached = planar_pose(arm.fk(result.solutions, tip="ee_link"))
        assert np.max(np.abs(reached[:, :2] - pose[:2])) <= 1e-9
        assert np.max(np.abs(wrapped(reached[:, 2] - pose[2]))) <= 1e-9
        assert result.solutions[0, 1] > 0.0 > result.solutions[1, 1]


def test_ik_3r_counts_follow_the_wrist_point():
    # lengths 4, 2, 1 (2R annulus 2 <= r <= 6 for the wrist):
    # tool (7, 0) along +x: wrist (6, 0) on the outer circle -> 1 (straight, q3 = 0)
    one = ik_3r(7.0, 0.0, 0.0, 4.0, 2.0, 1.0)
    assert one.count == 1 and one.labels == ("straight",)
    assert np.max(np.abs(one.solutions - [[0.0, 0.0, 0.0]])) < 1e-15
    # tool (7, 0) along -x: wrist (8, 0), 2 beyond the outer circle -> 0, too far by 2
    none = ik_3r(7.0, 0.0, PI, 4.0, 2.0, 1.0)
    assert none.count == 0 and none.side == "too far" and abs(none.outside_by - 2.0) < 1e-12
    assert "wrist point (8, 0)" in none.reason


def test_ik_3r_wrist_at_base_with_equal_links_is_infinite():
    # l1 = l2 = 1, l3 = 0.5, tool at 0.5 (cos 0.3, sin 0.3) with phi = 0.3: wrist at the base.
    # q1 free, q2 = pi, q3 = phi - q1 - pi; every member reaches the pose
    phi = 0.3
    result = ik_3r(0.5 * math.cos(phi), 0.5 * math.sin(phi), phi, 1.0, 1.0, 0.5)
    assert result.infinite and result.free_joint == 0
    assert "q3 = phi - q1 - pi" in result.note
    q1 = np.linspace(-3.0, 3.0, 7)
    x, y, phi_reached = fk_3r(q1, PI, phi - q1 - PI, 1.0, 1.0, 0.5)
    assert np.max(np.abs(x - 0.5 * math.cos(phi))) < 1e-15 and np.max(np.abs(y - 0.5 * math.sin(phi))) < 1e-15
    assert np.max(np.abs(wrapped(phi_reached - phi))) < 1e-15


def test_ik_3r_batch_equals_scalar():
    rng = np.random.default_rng(7)
    poses = np.column_stack([rng.uniform(-8, 8, 60), rng.uniform(-8, 8, 60), rng.uniform(-PI, PI, 60)])
    poses[0] = [7.0, 0.0, 0.0]  # on the boundary
    batch = ik_3r_batch(poses, 4.0, 2.0, 1.0)
    assert set(batch.count.tolist()) == {0.0, 1.0, 2.0}
    for i, (pose, solutions, count) in enumerate(zip(poses, batch.solutions, batch.count)):
        result = ik_3r(*pose, 4.0, 2.0, 1.0)
        k = len(result.labels)
        assert count == result.count and batch.success[i] == result.success
        assert np.array_equal(solutions[:k], result.solutions)
        assert np.all(np.isnan(solutions[k:]))
        np.testing.assert_allclose(batch.residuals[i, :k], result.residuals, atol=1e-15)  # position and tool angle
        if k:
            np.testing.assert_array_equal(batch.q[i], result.q)


# ---------------------------------------------------------------- workspaces


def test_workspace_3r_seed_004_radii():
    # seed 004, figure 2 (lengths 4, 2, 1): reachable 1 <= r <= 7, dexterous 3 <= r <= 5
    ws = workspace_3r(4.0, 2.0, 1.0)
    assert ws.reachable == (1.0, 7.0)
    assert ws.dexterous == ((3.0, 5.0),)
    assert "reachable annulus 1 <= r <= 7; dexterous annulus 3 <= r <= 5" in ws.description


def test_workspace_3r_dexterous_is_empty_when_the_wrist_circle_does_not_fit():
    # lengths 1, 1, 3: the wrist must stay within 2 of the base, but circles radius 3 about the tool
    ws = workspace_3r(1.0, 1.0, 3.0)
    assert ws.dexterous == ()
    assert ws.reachable == (1.0, 5.0)  # 2 * 3 - 5 = 1
    assert "dexterous empty" in ws.description


def test_workspace_3r_dexterous_is_a_disc_when_the_2r_annulus_is_a_disc():
    # lengths 1, 1, 0.5: 2R reaches the disc r <= 2, the wrist circle radius 0.5 fits for r <= 1.5
    ws = workspace_3r(1.0, 1.0, 0.5)
    assert ws.dexterous == ((0.0, 1.5),)
    assert ws.reachable == (0.0, 2.5)
    assert "dexterous disc r <= 1.5" in ws.description


def test_workspace_3r_dexterous_can_be_a_disc_and_an_annulus():
    # lengths 3, 2, 1.5: 2R annulus 1 <= r <= 5. Wrist circle inside the annulus: 2.5 <= r <= 3.5;
    # wrist circle around the inner hole (r + 1.5 <= 5 and 1.5 - r >= 1): r <= 0.5
    ws = workspace_3r(3.0, 2.0, 1.5)
    assert ws.dexterous == ((0.0, 0.5), (2.5, 3.5))


@pytest.mark.parametrize("link_lengths", [(4.0, 2.0, 1.0), (3.0, 2.0, 1.5), (1.0, 1.0, 0.5), (1.0, 2.0, 4.0)])
def test_workspace_3r_dexterous_radii_agree_with_ik_over_all_orientations(link_lengths):
    # a point is dexterous iff IK has a solution for every orientation; check on a grid of radii
    ws = workspace_3r(*link_lengths)
    radii = np.linspace(0.0, sum(link_lengths), 301)
    phis = np.linspace(-PI, PI, 721)
    r, phi = np.meshgrid(radii, phis, indexing="ij")
    poses = np.stack([r, np.zeros_like(r), phi], axis=-1)  # joint 1 makes the direction irrelevant
    all_orientations = np.all(ik_3r_batch(poses, *link_lengths, tol=1e-9).count > 0, axis=1)
    predicted = np.zeros(radii.shape, dtype=bool)
    for low, high in ws.dexterous:
        predicted |= (radii >= low - 1e-9) & (radii <= high + 1e-9)
    assert np.array_equal(all_orientations, predicted)


@pytest.mark.parametrize("link_lengths", [(4.0, 2.0, 1.0), (1.0, 1.0, 3.0), (1.0, 1.0, 0.5)])
def test_workspace_3r_reachable_radii_agree_with_ik(link_lengths):
    # a point is reachable iff IK has a solution for some orientation
    ws = workspace_3r(*link_lengths)
    radii = np.linspace(0.0, sum(link_lengths) + 1.0, 301)
    phis = np.linspace(-PI, PI, 721)
    r, phi = np.meshgrid(radii, phis, indexing="ij")
    poses = np.stack([r, np.zeros_like(r), phi], axis=-1)
    some_orientation = np.any(ik_3r_batch(poses, *link_lengths).count > 0, axis=1)
    low, high = ws.reachable
    # the grid of orientations only touches the boundary circles approximately, so compare inside
    margin = 0.02
    assert np.all(some_orientation[(radii > low + margin) & (radii < high - margin)])
    assert not np.any(some_orientation[(radii < low - 1e-9) | (radii > high + 1e-9)])


def test_workspace_2r_is_the_annulus_and_has_no_dexterous_part():
    ws = workspace_2r(1.0, 0.4)
    assert ws.reachable == (0.6, 1.4)
    assert ws.dexterous == ()
    assert ws.description.startswith("planar 2R (l = 1, 0.4): reachable annulus 0.6 <= r <= 1.4; dexterous empty")


def test_workspace_2r_with_equal_links_is_dexterous_at_the_base_only():
    # folded (q2 = pi) at the base, q1 turns the tool (orientation q1 + pi) through every angle
    ws = workspace_2r(0.8, 0.8)
    assert ws.reachable == (0.0, 1.6)
    assert ws.dexterous == ((0.0, 0.0),)
    assert "dexterous the base point only (r = 0)" in ws.description


# ---------------------------------------------------------------- batch IK against a textbook reference


def textbook_ik_2r(x, y, l1, l2, tol=1e-12):
    """Reference 2R IK, the textbook (Spong) atan2 formulation, vectorised; independent of manipkit.

    Law of cosines in the triangle base-elbow-tool: r^2 = l1^2 + l2^2 + 2 l1 l2 cos q2, so
    D = cos q2 = (r^2 - l1^2 - l2^2) / (2 l1 l2) and q2 = atan2(+-sqrt(1 - D^2), D), + for elbow-down.
    Seen from the base, the tool lies at atan2(y, x) = q1 + atan2(l2 sin q2, l1 + l2 cos q2) (the tool
    in link 1's frame is (l1 + l2 cos q2, l2 sin q2)), so q1 = atan2(y, x) - atan2(l2 sin q2, l1 + l2 cos q2).
    On a boundary circle (within tol) D = +-1 exactly: one solution; at the base with l1 = l2 the
    representative (0, pi) of infinitely many. Returns solutions (n, 2, 2) NaN where absent, counts,
    outside_by.
    """
    r = np.hypot(x, y)
    outer, inner = l1 + l2, abs(l1 - l2)
    free = (inner <= tol) & (r <= tol)
    on_outer = ~free & (np.abs(r - outer) <= tol)
    on_inner = ~free & ~on_outer & (np.abs(r - inner) <= tol)
    too_far = ~on_outer & (r > outer)
    too_close = ~free & ~on_inner & (r < inner)
    two = ~(free | on_outer | on_inner | too_far | too_close)
    D = np.clip((r * r - l1 * l1 - l2 * l2) / (2 * l1 * l2), -1.0, 1.0)
    D = np.where(on_outer, 1.0, np.where(on_inner, -1.0, D))
    solutions = np.full(r.shape + (2, 2), np.nan)
    for slot, sign in enumerate((1.0, -1.0)):
        q2 = np.arctan2(sign * np.sqrt(1.0 - D * D), D)
        q1 = np.arctan2(y, x) - np.arctan2(l2 * np.sin(q2), l1 + l2 * np.cos(q2))
        present = two | ((on_outer | on_inner) & (slot == 0))
        solutions[present, slot] = np.stack([q1, q2], axis=-1)[present]
    solutions[free, 0] = [0.0, PI]
    counts = np.select([two, on_outer | on_inner, free], [2.0, 1.0, np.inf], 0.0)
    outside = np.select([too_far, too_close], [r - outer, inner - r], 0.0)
    return solutions, counts, outside


def annulus_test_targets(l1, l2, n, seed, tol=1e-12):
    """2R targets: random in and around the annulus, plus every boundary case many times over.

    Exactly on both circles, within tol/2 of them (one solution), 2 tol to 100 tol outside them
    (none, or two just inside), 1e-9 to 1e-4 inside them (two, ill-conditioned), at the base, on
    the negative x axis with y = +-0.0 (where atan2 reads +-pi), and where link 1 of the elbow-down
    solution points along -x (q1 = pi, which atan2 may round to -pi). For tol > 0 the distances from
    the tol edges are at least tol/2, so a last-bit difference in r cannot change the count.
    """
    rng = np.random.default_rng(seed)
    outer, inner = l1 + l2, abs(l1 - l2)
    theta = rng.uniform(-PI, PI, n)
    near = rng.uniform(2.0, 100.0, n) * tol * rng.choice([-1.0, 1.0], n)
    deep = 10.0 ** rng.uniform(-9, -4, n)
    kind = rng.integers(0, 9, n)
    r = np.select(
        [kind == 1, kind == 2, kind == 3, kind == 4, kind == 5, kind == 6, kind == 7, kind == 8],
        [
            np.full(n, outer), np.full(n, inner),
            outer + rng.uniform(-0.5, 0.5, n) * tol, inner + rng.uniform(-0.5, 0.5, n) * tol,
            outer + near, np.abs(inner + near),
            np.where(rng.random(n) < 0.5, outer - deep, inner + deep), np.zeros(n),
        ],
        rng.uniform(0.0, 1.2 * outer, n),
    )
    theta[:200] = PI  # negative x axis; with y = +-0.0 below
    xy = np.stack([r * np.cos(theta), r * np.sin(theta)], axis=-1)
    xy[:100, 1] = 0.0
    xy[100:200, 1] = -0.0
    xy[200:500] = np.stack(fk_2r(PI, rng.uniform(0.05, PI - 0.05, 300), l1, l2), axis=-1)
    return xy


def condition(solutions, r, l1, l2):
    """Per target: min(1, |sin q2|, r / (l1 + l2)). Angle errors from rounding in r scale like
    1 / sin q2 next to the boundary circles and like 1 / r next to the base; 1 elsewhere."""
    sin_q2 = np.abs(np.sin(np.nan_to_num(solutions[:, 0, 1])))
    return np.minimum(1.0, np.minimum(sin_q2, r / (l1 + l2)))


def angle_gap(a, b):
    """|a - b| modulo 2 pi, 0 where both are NaN (angles at +-pi compare equal)."""
    return np.where(np.isnan(a) & np.isnan(b), 0.0, np.abs(wrapped(a - b)))


def assert_matches_textbook(batch, reference, r, l1, l2, fk_miss):
    solutions, counts, outside = reference
    assert np.array_equal(batch.count, counts)
    assert np.array_equal(np.isnan(batch.solutions), np.isnan(solutions))
    assert np.max(np.abs(batch.outside_by - outside)) <= 1e-12
    gap = np.max(angle_gap(batch.solutions, solutions), axis=(1, 2))
    one = counts == 1  # q2 = 0 or pi exactly, q1 along or against the target direction: no conditioning
    assert np.max(gap[one], initial=0.0) <= 1e-12
    # ~1e-12 where well conditioned, more only as the problem itself gets ill-conditioned
    two = counts == 2
    assert np.max((gap * condition(solutions, r, l1, l2))[two], initial=0.0) <= 1e-12
    well = two & (condition(solutions, r, l1, l2) > 0.05)
    assert np.max(gap[well]) <= 1e-12
    # every angle in (-pi, pi], and FK of every solution reaches the target: within rounding, or for
    # a target within tol of a boundary circle, the point of the circle next to it (<= tol / 2 away here)
    present = ~np.isnan(batch.solutions)
    assert np.all((batch.solutions[present] > -PI) & (batch.solutions[present] <= PI))
    assert np.max(fk_miss(batch.solutions)) <= 1e-12


@pytest.mark.parametrize("tol", [1e-12, 0.0])
@pytest.mark.parametrize("link_lengths", [(4.0, 2.0), (1.0, 1.0), (0.7, 1.3), LENGTHS_2R[3]])
def test_ik_2r_batch_matches_textbook_reference_on_every_case(link_lengths, tol):
    # tol = 0: the count follows r = hypot(x, y) exactly, also for targets within an ulp of a circle
    l1, l2 = link_lengths
    xy = annulus_test_targets(l1, l2, 30000, seed=11, tol=tol)
    batch = ik_2r_batch(xy, l1, l2, tol=tol)
    reference = textbook_ik_2r(xy[:, 0], xy[:, 1], l1, l2, tol=tol)
    # every case is represented
    assert {0.0, 1.0, 2.0} <= set(batch.count.tolist())
    assert (math.inf in batch.count) == (l1 == l2)

    def fk_miss(solutions):
        x, y = fk_2r(solutions[..., 0], solutions[..., 1], l1, l2)
        return np.nan_to_num(np.hypot(x - xy[:, None, 0], y - xy[:, None, 1]))

    assert_matches_textbook(batch, reference, np.hypot(xy[:, 0], xy[:, 1]), l1, l2, fk_miss)
    # the scalar solver shares the batch code: identical rows, on a sample of every kind
    for i in np.random.default_rng(12).choice(len(xy), 300, replace=False):
        result = ik_2r(*xy[i], l1, l2, tol=tol)
        assert result.count == batch.count[i] and result.outside_by == batch.outside_by[i]
        assert np.array_equal(result.solutions, batch.solutions[i, : len(result.labels)])


@pytest.mark.parametrize("link_lengths", [(4.0, 2.0, 1.0), (1.0, 1.0, 0.5), (0.7, 1.3, 0.4), LENGTHS_3R[2]])
def test_ik_3r_batch_matches_textbook_reference_on_every_case(link_lengths):
    # wrist points from annulus_test_targets; tool = wrist + l3 (cos phi, sin phi), with phi at +-pi,
    # just inside -pi, and beyond (-pi, pi] too. Reference: textbook 2R for the wrist, q3 = phi - q1 - q2
    l1, l2, l3 = link_lengths
    wrist = annulus_test_targets(l1, l2, 30000, seed=13)
    rng = np.random.default_rng(14)
    phi = rng.uniform(-PI, PI, len(wrist))
    phi[:300:3], phi[1:300:3], phi[2:300:3] = PI, -PI, np.nextafter(-PI, 0.0)
    phi[300:600] = rng.uniform(-12.0, 12.0, 300)
    poses = np.column_stack([wrist[:, 0] + l3 * np.cos(phi), wrist[:, 1] + l3 * np.sin(phi), phi])
    batch = ik_3r_batch(poses, l1, l2, l3)

    wx, wy = poses[:, 0] - l3 * np.cos(phi), poses[:, 1] - l3 * np.sin(phi)
    solutions_2r, counts, outside = textbook_ik_2r(wx, wy, l1, l2)
    q3 = phi[:, None] - solutions_2r[..., 0] - solutions_2r[..., 1]
    reference = (np.concatenate([solutions_2r, q3[..., None]], axis=-1), counts, outside)
    assert {0.0, 1.0, 2.0} <= set(batch.count.tolist())

    def fk_miss(solutions):
        x, y, phi_reached = fk_3r(solutions[..., 0], solutions[..., 1], solutions[..., 2], l1, l2, l3)
        miss = np.maximum(np.hypot(x - poses[:, None, 0], y - poses[:, None, 1]),
                          np.abs(wrapped(phi_reached - phi[:, None])))
        return np.nan_to_num(miss)

    assert_matches_textbook(batch, reference, np.hypot(wx, wy), l1, l2, fk_miss)
    for i in np.random.default_rng(15).choice(len(poses), 300, replace=False):
        result = ik_3r(*poses[i], l1, l2, l3)
        assert result.count == batch.count[i] and result.outside_by == batch.outside_by[i]
        assert np.array_equal(result.solutions, batch.solutions[i, : len(result.labels)])


def test_ik_batch_large_input_in_blocks_equals_small_pieces():
    # the batch solvers work through long inputs in blocks; a block edge must not show
    rng = np.random.default_rng(16)
    poses = np.column_stack([rng.uniform(-8, 8, (50_000, 2)), rng.uniform(-PI, PI, 50_000)])
    whole = ik_3r_batch(poses, 4.0, 2.0, 1.0)
    pieces = [ik_3r_batch(poses[i : i + 777], 4.0, 2.0, 1.0) for i in range(0, len(poses), 777)]
    assert np.array_equal(whole.solutions, np.concatenate([p.solutions for p in pieces]), equal_nan=True)
    assert np.array_equal(whole.count, np.concatenate([p.count for p in pieces]))
    assert np.array_equal(whole.outside_by, np.concatenate([p.outside_by for p in pieces]))


def test_batch_helpers_wrap_third_joint_and_wrist_point_exactly():
    # private helpers of the fast batch pass, at edges random targets do not reach
    from manipkit.closed_form.planar import _third_joint
    from manipkit.closed_form.planar import wrist_point as _wrist

    # q3 = phi - q1 - q2 for phi, q1, q2 in (-pi, pi] lies in [-3 pi, 3 pi]; it equals -3 pi exactly
    # for phi just above -pi and q1 = q2 = pi (-pi + ulp - pi rounds to -2 pi), and must read +pi
    edge = np.array([np.nextafter(-PI, 0.0)])
    assert _third_joint(edge, np.array([PI]), np.array([PI])).tolist() == [PI]
    rng = np.random.default_rng(17)
    phi, q1, q2 = (rng.uniform(-PI, PI, 100_000) for _ in range(3))
    phi[:3], q1[:3], q2[:3] = [PI, -PI + 1e-16, 0.5], [-PI + 1e-16, PI, -0.5], [-PI + 1e-16, PI, 0.0]
    q3 = _third_joint(phi, q1, q2)
    assert np.all((q3 > -PI) & (q3 <= PI))
    assert np.max(np.abs(wrapped(q3 - (phi - q1 - q2)))) <= 1e-15
    # wrist point from tan(phi / 2): within a few 1e-16 of cos / sin, at +-pi and for large phi too
    phi = np.concatenate([rng.uniform(-PI, PI, 100_000), rng.uniform(-1e6, 1e6, 1000), [PI, -PI, 0.0, PI / 2]])
    wx, wy = _wrist(np.zeros_like(phi), np.zeros_like(phi), phi, 1.0)
    assert np.max(np.abs(wx + np.cos(phi))) <= 1e-15 and np.max(np.abs(wy + np.sin(phi))) <= 1e-15
