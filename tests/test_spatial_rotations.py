"""Tests of manipkit.spatial.rotations: hand values, round trips, singular sets, validation.

Conventions under test: rpy = (roll, pitch, yaw) with R = Rz(yaw) Ry(pitch)
Rx(roll) (URDF, Euler ZYX); quaternions (x, y, z, w) with w >= 0; axis-angle
with the angle in [0, pi].
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from manipkit.errors import InvalidRotationError, ManipkitError
from manipkit.spatial.euler import (
    euler_zyx_from_matrix,
    euler_zyz_from_matrix,
    matrix_from_euler_zyx,
    matrix_from_euler_zyz,
)
from manipkit.spatial.rotations import (
    axis_angle_from_matrix,
    check_rotation,
    matrix_from_axis_angle,
    matrix_from_quaternion,
    matrix_from_rpy,
    quaternion_from_matrix,
    rot_x,
    rot_y,
    rot_z,
    rotation_angle_between,
    rotation_violations,
    rpy_from_matrix,
)

PI = math.pi
S45 = math.sqrt(0.5)  # sin 45 deg = cos 45 deg

# no deadline: timing is not under test, and a loaded machine must not fail these
SETTINGS = settings(deadline=None, max_examples=200)

# ---------------------------------------------------------------- strategies

angles = st.floats(-PI, PI, allow_nan=False)
pitches = st.floats(-PI / 2, PI / 2, allow_nan=False)
components = st.floats(-1.0, 1.0, allow_nan=False)


@st.composite
def unit_vectors(draw):
    v = np.array([draw(components) for _ in range(3)])
    norm = np.linalg.norm(v)
    if norm < 0.1:
        v, norm = np.array([0.0, 0.0, 1.0]), 1.0
    return v / norm


@st.composite
def unit_quaternions(draw):
    q = np.array([draw(components) for _ in range(4)])
    norm = np.linalg.norm(q)
    if norm < 0.1:
        q, norm = np.array([0.0, 0.0, 0.0, 1.0]), 1.0
    return q / norm


@st.composite
def rotations(draw):
    """Rotations from random axis-angle pairs (independent of the quaternion code)."""
    return matrix_from_axis_angle(draw(unit_vectors()), draw(st.floats(0.0, PI)))


def wrapped(angle):
    """Angle difference mapped to [-pi, pi)."""
    return (np.asarray(angle) + PI) % (2 * PI) - PI


def max_error(A, B) -> float:
    return float(np.max(np.abs(np.asarray(A) - np.asarray(B))))


# ---------------------------------------------------------------- elementary rotations


def test_rot_x_quarter_turn_maps_y_to_z():
    # Rx(90 deg) = [[1, 0, 0], [0, 0, -1], [0, 1, 0]], so y -> z and z -> -y
    assert max_error(rot_x(PI / 2), [[1, 0, 0], [0, 0, -1], [0, 1, 0]]) < 1e-15


def test_rot_y_quarter_turn_maps_z_to_x():
    # Ry(90 deg) = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], so z -> x and x -> -z
    assert max_error(rot_y(PI / 2), [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]) < 1e-15


def test_rot_z_quarter_turn_maps_x_to_y():
    # Rz(90 deg) = [[0, -1, 0], [1, 0, 0], [0, 0, 1]], so x -> y and y -> -x
    assert max_error(rot_z(PI / 2), [[0, -1, 0], [1, 0, 0], [0, 0, 1]]) < 1e-15


def test_elementary_rotations_keep_leading_dimensions():
    theta = np.linspace(-3, 3, 6).reshape(2, 3)
    for rot in (rot_x, rot_y, rot_z):
        R = rot(theta)
        assert R.shape == (2, 3, 3, 3)
        assert max_error(R[1, 2], rot(theta[1, 2])) == 0.0


# ---------------------------------------------------------------- roll-pitch-yaw


def test_matrix_from_rpy_roll_then_yaw_hand_value():
    # R = Rz(90) Rx(90): Rx takes x->x, y->z, z->-y, then Rz takes x->y, y->-x, z->z,
    # so x->y, y->z, z->x; columns are the images: [[0, 0, 1], [1, 0, 0], [0, 1, 0]].
    # (The other order, Rx(90) Rz(90), would send x -> z.)
    assert max_error(matrix_from_rpy([PI / 2, 0.0, PI / 2]), [[0, 0, 1], [1, 0, 0], [0, 1, 0]]) < 1e-15


@SETTINGS
@given(angles, pitches, angles)
def test_matrix_from_rpy_equals_rz_ry_rx_product(roll, pitch, yaw):
    expected = rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)
    assert max_error(matrix_from_rpy([roll, pitch, yaw]), expected) < 1e-15


def test_rpy_from_matrix_hand_value():
    # the matrix of test_matrix_from_rpy_roll_then_yaw_hand_value: roll = atan2(R21, R22) = atan2(1, 0),
    # pitch = atan2(-R20, hypot(R21, R22)) = atan2(0, 1), yaw = 90 deg
    rpy = rpy_from_matrix([[0, 0, 1], [1, 0, 0], [0, 1, 0]])
    assert max_error(rpy, [PI / 2, 0.0, PI / 2]) < 1e-15


@SETTINGS
@given(rotations())
def test_matrix_rpy_matrix_round_trip(R):
    assert max_error(matrix_from_rpy(rpy_from_matrix(R)), R) <= 1e-12


@SETTINGS
@given(angles, st.floats(-PI / 2 + 1e-3, PI / 2 - 1e-3), angles)
def test_rpy_matrix_rpy_round_trip_away_from_gimbal_lock(roll, pitch, yaw):
    rpy = rpy_from_matrix(matrix_from_rpy([roll, pitch, yaw]))
    assert np.max(np.abs(wrapped(rpy - [roll, pitch, yaw]))) <= 1e-12


@SETTINGS
@given(angles, st.sampled_from([PI / 2, -PI / 2]), angles)
def test_rpy_at_gimbal_lock_sets_roll_zero_and_keeps_the_rotation(roll, pitch, yaw):
    R = matrix_from_rpy([roll, pitch, yaw])
    rpy = rpy_from_matrix(R)
    assert rpy[0] == 0.0
    assert abs(rpy[1] - pitch) <= 1e-12
    assert max_error(matrix_from_rpy(rpy), R) <= 1e-12


def test_rpy_at_pitch_plus_90_puts_yaw_minus_roll_in_yaw():
    # Ry(90) Rx(0.4): at pitch +90 only yaw - roll is determined, here 0 - 0.4
    rpy = rpy_from_matrix(rot_y(PI / 2) @ rot_x(0.4))
    assert max_error(rpy, [0.0, PI / 2, -0.4]) < 1e-15


def test_rpy_at_pitch_minus_90_puts_yaw_plus_roll_in_yaw():
    # Rz(0.3) Ry(-90) Rx(0.4): at pitch -90 only yaw + roll is determined, here 0.7
    rpy = rpy_from_matrix(rot_z(0.3) @ rot_y(-PI / 2) @ rot_x(0.4))
    assert max_error(rpy, [0.0, -PI / 2, 0.7]) < 1e-15


@SETTINGS
@given(angles, st.floats(0.0, 0.9e-12), st.sampled_from([1.0, -1.0]), angles)
def test_rpy_inside_gimbal_tolerance_reproduces_rotation_within_twice_the_tolerance(roll, gap, sign, yaw):
    R = matrix_from_rpy([roll, sign * (PI / 2 - gap), yaw])
    rpy = rpy_from_matrix(R, gimbal_tol=1e-12)
    assert rpy[0] == 0.0
    assert max_error(matrix_from_rpy(rpy), R) <= 2e-12 + 1e-15


@SETTINGS
@given(rotations())
def test_rpy_from_matrix_ranges(R):
    roll, pitch, yaw = rpy_from_matrix(R)
    assert -PI < roll <= PI and -PI < yaw <= PI
    assert -PI / 2 <= pitch <= PI / 2


def test_rpy_from_matrix_maps_minus_pi_to_plus_pi():
    # Rx(pi) computed by hand has R21 = +0.0 or -0.0 depending on rounding; roll must read +pi
    R = np.diag([1.0, -1.0, -1.0])
    R[2, 1] = -0.0
    assert rpy_from_matrix(R)[0] == PI


def test_rpy_from_matrix_keeps_leading_dimensions():
    rng = np.random.default_rng(1)
    rpy = np.stack(
        [rng.uniform(-3, 3, (4, 5)), rng.uniform(-1.5, 1.5, (4, 5)), rng.uniform(-3, 3, (4, 5))], axis=-1
    )
    R = matrix_from_rpy(rpy)
    assert R.shape == (4, 5, 3, 3)
    result = rpy_from_matrix(R)
    assert result.shape == (4, 5, 3)
    assert max_error(result[2, 3], rpy_from_matrix(R[2, 3])) == 0.0


def test_rpy_from_matrix_rejects_a_reflection():
    with pytest.raises(InvalidRotationError, match="reflection"):
        rpy_from_matrix(np.diag([1.0, 1.0, -1.0]))


# ---------------------------------------------------------------- quaternions


def test_quaternion_of_rz_90_hand_value():
    # q = (sin(theta/2) * axis, cos(theta/2)) with theta = 90 deg, axis z: (0, 0, sin 45, cos 45)
    assert max_error(quaternion_from_matrix(rot_z(PI / 2)), [0.0, 0.0, S45, S45]) < 1e-15


def test_quaternion_of_ry_minus_90_keeps_negative_y():
    # theta = -90 deg about y: (0, sin(-45), 0, cos(-45)) = (0, -sin 45, 0, cos 45), already w > 0
    assert max_error(quaternion_from_matrix(rot_y(-PI / 2)), [0.0, -S45, 0.0, S45]) < 1e-15


def test_quaternion_sign_choice_makes_w_non_negative():
    # 240 deg about z: (0, 0, sin 120, cos 120) = (0, 0, 0.866, -0.5) has w < 0; the other
    # quaternion of the same rotation, (0, 0, -0.866, 0.5), is returned (120 deg about -z)
    q = quaternion_from_matrix(rot_z(4 * PI / 3))
    assert max_error(q, [0.0, 0.0, -math.sqrt(3) / 2, 0.5]) < 1e-15


def test_quaternion_of_exact_half_turn_has_positive_first_component():
    # diag(-1, 1, -1) is 180 deg about y: (0, +-1, 0, 0) with w = 0 exactly; y > 0 is chosen
    assert quaternion_from_matrix(np.diag([-1.0, 1.0, -1.0])).tolist() == [0.0, 1.0, 0.0, 0.0]


def test_quaternion_of_identity():
    assert quaternion_from_matrix(np.eye(3)).tolist() == [0.0, 0.0, 0.0, 1.0]


def test_matrix_from_quaternion_of_rz_90_hand_value():
    # x = y = 0, z = w = sin 45: R00 = 1 - 2 z^2 = 0, R01 = -2 z w = -1, R10 = 2 z w = 1
    assert max_error(matrix_from_quaternion([0.0, 0.0, S45, S45]), rot_z(PI / 2)) < 1e-15


def test_matrix_from_quaternion_normalises_its_input():
    # (0, 0, 2, 2) is 2 * sqrt(2) times the unit quaternion of Rz(90)
    assert max_error(matrix_from_quaternion([0.0, 0.0, 2.0, 2.0]), rot_z(PI / 2)) < 1e-15


def test_matrix_from_quaternion_rejects_zero_quaternion():
    with pytest.raises(InvalidRotationError, match=r"quaternion\[1\] = \[0. 0. 0. 0.\].*zero or not finite"):
        matrix_from_quaternion([[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 0.0]])


def test_matrix_from_quaternion_rejects_wrong_length():
    with pytest.raises(InvalidRotationError, match=r"shape \(\.\.\., 4\), got \(3,\)"):
        matrix_from_quaternion([0.0, 0.0, 1.0])


@SETTINGS
@given(rotations())
def test_matrix_quaternion_matrix_round_trip(R):
    assert max_error(matrix_from_quaternion(quaternion_from_matrix(R)), R) <= 1e-12


@SETTINGS
@given(unit_quaternions())
def test_quaternion_matrix_quaternion_round_trip_up_to_sign(q):
    result = quaternion_from_matrix(matrix_from_quaternion(q))
    assert result[3] >= 0.0
    assert min(max_error(result, q), max_error(result, -q)) <= 1e-12


@SETTINGS
@given(unit_vectors(), st.sampled_from([PI, PI - 1e-9, PI - 1e-15, math.nextafter(PI, 0.0)]))
def test_quaternion_near_half_turn_is_accurate(axis, angle):
    # q = (sin(angle/2) axis, cos(angle/2)) up to sign; a trace-based method loses it here
    R = matrix_from_axis_angle(axis, angle)
    expected = np.append(math.sin(angle / 2) * axis, math.cos(angle / 2))
    q = quaternion_from_matrix(R)
    assert min(max_error(q, expected), max_error(q, -expected)) <= 1e-12
    assert q[3] >= 0.0


def test_quaternion_from_matrix_keeps_leading_dimensions():
    R = rot_z(np.linspace(0, 6, 10).reshape(2, 5))
    q = quaternion_from_matrix(R)
    assert q.shape == (2, 5, 4)
    assert max_error(q[1, 4], quaternion_from_matrix(R[1, 4])) == 0.0


def test_quaternion_from_matrix_rejects_a_scaled_matrix():
    with pytest.raises(InvalidRotationError, match="column 0 \\(x axis\\) has norm 2"):
        quaternion_from_matrix(2.0 * np.eye(3))


def test_quaternion_from_matrix_check_can_be_disabled():
    # a matrix rounded to 4 decimals fails the default tolerance but converts with check=False
    R = np.round(rot_z(0.3), 4)
    with pytest.raises(InvalidRotationError):
        quaternion_from_matrix(R)
    q = quaternion_from_matrix(R, check=False)
    assert max_error(q, [0.0, 0.0, math.sin(0.15), math.cos(0.15)]) < 1e-4


# ---------------------------------------------------------------- axis-angle


def test_matrix_from_axis_angle_normalises_the_axis():
    # (0, 0, 2) is the z axis; 90 deg about z is Rz(90)
    assert max_error(matrix_from_axis_angle([0.0, 0.0, 2.0], PI / 2), rot_z(PI / 2)) < 1e-15


def test_matrix_from_axis_angle_broadcasts_axis_and_angles():
    angles_ = np.array([0.1, 0.2, 0.3])
    R = matrix_from_axis_angle([1.0, 0.0, 0.0], angles_)
    assert R.shape == (3, 3, 3)
    assert max_error(R, rot_x(angles_)) < 1e-15


def test_matrix_from_axis_angle_rejects_zero_axis():
    with pytest.raises(InvalidRotationError, match=r"axis = \[0. 0. 0.\] is zero"):
        matrix_from_axis_angle([0.0, 0.0, 0.0], 0.5)


def test_axis_angle_of_identity_is_zero_about_z():
    axis, angle = axis_angle_from_matrix(np.eye(3))
    assert axis.tolist() == [0.0, 0.0, 1.0]
    assert angle == 0.0


def test_axis_angle_of_three_quarter_turn_is_quarter_turn_about_minus_axis():
    # 270 deg about z = 90 deg about -z; angles are reported in [0, pi]
    axis, angle = axis_angle_from_matrix(rot_z(3 * PI / 2))
    assert max_error(axis, [0.0, 0.0, -1.0]) < 1e-15
    assert abs(angle - PI / 2) < 1e-15


def test_axis_angle_of_exact_half_turn_about_x():
    # diag(1, -1, -1) is 180 deg about x; (1, 0, 0) and (-1, 0, 0) are both valid, + is chosen
    axis, angle = axis_angle_from_matrix(np.diag([1.0, -1.0, -1.0]))
    assert axis.tolist() == [1.0, 0.0, 0.0]
    assert angle == PI


@SETTINGS
@given(rotations())
def test_matrix_axis_angle_matrix_round_trip(R):
    axis, angle = axis_angle_from_matrix(R)
    assert 0.0 <= angle <= PI
    assert abs(np.linalg.norm(axis) - 1.0) <= 1e-15
    assert max_error(matrix_from_axis_angle(axis, angle), R) <= 1e-12


@SETTINGS
@given(unit_vectors(), st.floats(1e-9, PI - 1e-9))
def test_axis_angle_matrix_axis_angle_round_trip(axis, angle):
    result_axis, result_angle = axis_angle_from_matrix(matrix_from_axis_angle(axis, angle))
    assert abs(result_angle - angle) <= 1e-12
    assert max_error(result_axis, axis) <= 1e-12


@SETTINGS
@given(unit_vectors())
def test_axis_angle_at_half_turn_recovers_axis_up_to_sign(axis):
    R = matrix_from_axis_angle(axis, PI)
    result_axis, result_angle = axis_angle_from_matrix(R)
    assert abs(result_angle - PI) <= 1e-12
    assert min(max_error(result_axis, axis), max_error(result_axis, -axis)) <= 1e-12
    assert max_error(matrix_from_axis_angle(result_axis, result_angle), R) <= 1e-12


@SETTINGS
@given(unit_vectors())
def test_axis_angle_at_zero_angle_returns_the_rotation(axis):
    R = matrix_from_axis_angle(axis, 0.0)
    result_axis, result_angle = axis_angle_from_matrix(R)
    assert result_angle == 0.0
    assert result_axis.tolist() == [0.0, 0.0, 1.0]
    assert max_error(matrix_from_axis_angle(result_axis, result_angle), R) == 0.0


# ---------------------------------------------------------------- angle between


def test_rotation_angle_between_rotations_about_one_axis():
    # Rz(0.3)^T Rz(0.5) = Rz(0.2)
    assert abs(rotation_angle_between(rot_z(0.3), rot_z(0.5)) - 0.2) < 1e-15


def test_rotation_angle_between_is_accurate_for_tiny_angles():
    # acos((trace - 1) / 2) reads 1e-10 as 0 (cos(1e-10) rounds to 1); atan2 keeps it
    assert abs(rotation_angle_between(np.eye(3), rot_x(1e-10)) - 1e-10) <= 1e-22


def test_rotation_angle_between_at_half_turn():
    assert abs(rotation_angle_between(np.eye(3), rot_y(PI)) - PI) <= 1e-15


@SETTINGS
@given(rotations(), rotations())
def test_rotation_angle_between_is_symmetric_and_equals_axis_angle(R_a, R_b):
    angle = rotation_angle_between(R_a, R_b)
    assert 0.0 <= angle <= PI
    assert abs(angle - rotation_angle_between(R_b, R_a)) <= 1e-12
    assert abs(angle - axis_angle_from_matrix(R_a.T @ R_b, tol=1e-9)[1]) <= 1e-12


def test_rotation_angle_between_broadcasts():
    angles_ = np.array([0.1, 0.2, 0.3])
    result = rotation_angle_between(np.eye(3), rot_z(angles_))
    assert result.shape == (3,)
    assert max_error(result, angles_) < 1e-15


# ---------------------------------------------------------------- validation


def test_check_rotation_returns_a_valid_rotation_as_float_array():
    R = check_rotation([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    assert R.dtype == float and R.shape == (3, 3)


def test_check_rotation_names_a_wrong_shape():
    with pytest.raises(InvalidRotationError, match=r"R must have shape \(\.\.\., 3, 3\), got \(3, 4\)"):
        check_rotation(np.zeros((3, 4)))


def test_check_rotation_names_a_non_finite_entry():
    R = np.eye(3)
    R[1, 2] = np.nan
    with pytest.raises(InvalidRotationError, match=r"entry \[1, 2\] is not finite \(nan\)"):
        check_rotation(R)


def test_check_rotation_names_a_column_norm():
    with pytest.raises(InvalidRotationError, match=r"column 1 \(y axis\) has norm 1.5, expected 1"):
        check_rotation(np.diag([1.0, 1.5, 1.0]))


def test_check_rotation_names_non_orthogonal_columns():
    # unit columns x and (0.35, sqrt(1 - 0.35^2), 0): their dot product is 0.35
    R = np.eye(3)
    R[:, 1] = [0.35, math.sqrt(1 - 0.35**2), 0.0]
    with pytest.raises(InvalidRotationError, match=r"columns 0 and 1 are not orthogonal \(dot 0.35\)"):
        check_rotation(R)


def test_check_rotation_asks_whether_a_reflection_was_meant():
    with pytest.raises(InvalidRotationError) as raised:
        check_rotation(np.diag([1.0, 1.0, -1.0]))
    assert str(raised.value) == "R is not a rotation matrix: det(R) = -1, expected +1 (is this a reflection?)"


def test_check_rotation_names_the_failing_matrix_of_a_stack():
    stack = np.stack([np.eye(3), np.eye(3), np.diag([1.0, 1.0, -1.0]), np.diag([-1.0, 1.0, 1.0])])
    with pytest.raises(InvalidRotationError) as raised:
        check_rotation(stack)
    assert str(raised.value).startswith("R[2] is not a rotation matrix: det(R) = -1")
    assert str(raised.value).endswith("(and 1 more matrices fail)")


def test_check_rotation_honours_its_tolerance():
    R = rot_z(0.3) * (1 + 1e-7)
    assert check_rotation(R).shape == (3, 3)
    with pytest.raises(InvalidRotationError, match=r"norm 1.0000001, expected 1"):
        check_rotation(R, tol=1e-9)


def test_invalid_rotation_error_is_a_manipkit_value_error():
    with pytest.raises(ManipkitError):
        check_rotation(np.zeros((3, 3)))
    with pytest.raises(ValueError):
        check_rotation(np.zeros((3, 3)))


def test_rotation_violations_of_a_zero_matrix_lists_every_problem():
    assert rotation_violations(np.zeros((3, 3))) == [
        "column 0 (x axis) has norm 0, expected 1",
        "column 1 (y axis) has norm 0, expected 1",
        "column 2 (z axis) has norm 0, expected 1",
        "det(R) = 0, expected +1 (the matrix is singular)",
    ]


def test_rotation_violations_of_a_rotation_is_empty():
    assert rotation_violations(matrix_from_rpy([0.1, -0.7, 2.0])) == []


# ---------------------------------------------------------------- Euler ZYX (yaw, pitch, roll)

# fewer examples than SETTINGS: many properties here, and the singular sets are sampled on purpose
EULER_SETTINGS = settings(deadline=None, max_examples=100)

zyx_locked_pitches = st.sampled_from([PI / 2, -PI / 2])


@st.composite
def zyx_locked_rotations(draw):
    """Rotations with pitch exactly +-90 deg (the gimbal-lock set), sampled on purpose."""
    return rot_z(draw(angles)) @ rot_y(draw(zyx_locked_pitches)) @ rot_x(draw(angles))


@EULER_SETTINGS
@given(angles, pitches, angles)
def test_matrix_from_euler_zyx_equals_rz_ry_rx_product(alpha, beta, gamma):
    expected = rot_z(alpha) @ rot_y(beta) @ rot_x(gamma)
    assert max_error(matrix_from_euler_zyx([alpha, beta, gamma]), expected) < 1e-15


def test_matrix_from_euler_zyx_matches_seed_general_formula():
    # seed 004 eq. 1.2, entries written out by hand, at alpha = 30, beta = 45, gamma = 60 deg
    a, b, g = math.radians(30), math.radians(45), math.radians(60)
    ca, sa, cb, sb, cg, sg = math.cos(a), math.sin(a), math.cos(b), math.sin(b), math.cos(g), math.sin(g)
    expected = [
        [ca * cb, -sa * cg + sb * sg * ca, sa * sg + sb * ca * cg],
        [sa * cb, sa * sb * sg + ca * cg, sa * sb * cg - sg * ca],
        [-sb, sg * cb, cb * cg],
    ]
    assert max_error(matrix_from_euler_zyx([a, b, g]), expected) < 1e-15


def test_matrix_from_euler_zyx_at_pitch_plus_90_is_seed_equation_1_4():
    # seed 004 eq. 1.4: R(alpha, 90, gamma) = [[0, -s, c], [0, c, s], [-1, 0, 0]] with s, c of alpha - gamma
    d = 0.5 - 0.2
    expected = [[0, -math.sin(d), math.cos(d)], [0, math.cos(d), math.sin(d)], [-1, 0, 0]]
    assert max_error(matrix_from_euler_zyx([0.5, PI / 2, 0.2]), expected) < 1e-15


def test_matrix_from_euler_zyx_at_pitch_minus_90_is_seed_equation_1_5():
    # seed 004 eq. 1.5: R(alpha, -90, gamma) = [[0, -s, -c], [0, c, -s], [1, 0, 0]] with s, c of alpha + gamma
    t = 0.5 + 0.2
    expected = [[0, -math.sin(t), -math.cos(t)], [0, math.cos(t), -math.sin(t)], [1, 0, 0]]
    assert max_error(matrix_from_euler_zyx([0.5, -PI / 2, 0.2]), expected) < 1e-15


def test_euler_zyx_from_matrix_hand_value():
    # R = Rz(90) Rx(90) maps x->y, y->z, z->x: [[0, 0, 1], [1, 0, 0], [0, 1, 0]];
    # alpha = atan2(r21, r11) = atan2(1, 0) = 90, beta = atan2(-r31, .) = 0, gamma = atan2(r32, r33) = 90
    ypr = euler_zyx_from_matrix([[0, 0, 1], [1, 0, 0], [0, 1, 0]])
    assert max_error(ypr, [PI / 2, 0.0, PI / 2]) < 1e-15


def test_euler_zyx_at_pitch_plus_90_returns_alpha_minus_gamma_and_zero_roll():
    # seed eq. 1.4 with alpha = 0.5, gamma = 0.2: only alpha - gamma = 0.3 is in R; roll is set to 0
    ypr = euler_zyx_from_matrix(matrix_from_euler_zyx([0.5, PI / 2, 0.2]))
    assert ypr[2] == 0.0
    assert max_error(ypr, [0.3, PI / 2, 0.0]) < 1e-15


def test_euler_zyx_at_pitch_minus_90_returns_alpha_plus_gamma_and_zero_roll():
    # seed eq. 1.5 with alpha = 0.5, gamma = 0.2: only alpha + gamma = 0.7 is in R; roll is set to 0
    ypr = euler_zyx_from_matrix(matrix_from_euler_zyx([0.5, -PI / 2, 0.2]))
    assert ypr[2] == 0.0
    assert max_error(ypr, [0.7, -PI / 2, 0.0]) < 1e-15


@EULER_SETTINGS
@given(angles, st.floats(-PI / 2 + 1e-3, PI / 2 - 1e-3), angles)
def test_euler_zyx_round_trip_away_from_gimbal_lock(alpha, beta, gamma):
    ypr = euler_zyx_from_matrix(matrix_from_euler_zyx([alpha, beta, gamma]))
    assert np.max(np.abs(wrapped(ypr - [alpha, beta, gamma]))) <= 1e-12


@EULER_SETTINGS
@given(angles, zyx_locked_pitches, angles)
def test_euler_zyx_round_trip_at_gimbal_lock_keeps_the_determined_combination(alpha, beta, gamma):
    # beta = +90: alpha - gamma is determined; beta = -90: alpha + gamma (seed eqs. 1.4, 1.5)
    ypr = euler_zyx_from_matrix(matrix_from_euler_zyx([alpha, beta, gamma]))
    combination = alpha - gamma if beta > 0 else alpha + gamma
    assert ypr[1] == beta and ypr[2] == 0.0
    assert abs(wrapped(ypr[0] - combination)) <= 1e-12


@EULER_SETTINGS
@given(st.one_of(rotations(), zyx_locked_rotations()))
def test_matrix_euler_zyx_matrix_round_trip_including_gimbal_lock(R):
    assert max_error(matrix_from_euler_zyx(euler_zyx_from_matrix(R)), R) <= 1e-12


def test_euler_zyx_from_matrix_keeps_leading_dimensions():
    R = matrix_from_euler_zyx(np.stack([np.linspace(-3, 3, 6), np.linspace(-1.5, 1.5, 6), np.zeros(6)], -1))
    result = euler_zyx_from_matrix(R.reshape(2, 3, 3, 3))
    assert result.shape == (2, 3, 3)
    assert max_error(result[1, 2], euler_zyx_from_matrix(R[5])) == 0.0


def test_euler_zyx_from_matrix_rejects_a_reflection():
    with pytest.raises(InvalidRotationError, match="reflection"):
        euler_zyx_from_matrix(np.diag([1.0, 1.0, -1.0]))


# ---------------------------------------------------------------- Euler ZYZ (phi, theta, psi)

zyz_singular_thetas = st.sampled_from([0.0, PI])


@st.composite
def zyz_singular_rotations(draw):
    """Rotations with theta exactly 0 or pi (the ZYZ singular set), sampled on purpose."""
    return rot_z(draw(angles)) @ rot_y(draw(zyz_singular_thetas)) @ rot_z(draw(angles))


@EULER_SETTINGS
@given(angles, st.floats(-PI, PI), angles)
def test_matrix_from_euler_zyz_equals_rz_ry_rz_product(phi, theta, psi):
    expected = rot_z(phi) @ rot_y(theta) @ rot_z(psi)
    assert max_error(matrix_from_euler_zyz([phi, theta, psi]), expected) < 1e-15


def test_matrix_from_euler_zyz_hand_value():
    # Rz(90) Ry(90): Ry(90) sends x->-z, y->y, z->x; then Rz(90) sends x->y, y->-x, z->z;
    # so x -> -z, y -> -x, z -> y, and those images are the columns
    R = matrix_from_euler_zyz([PI / 2, PI / 2, 0.0])
    assert max_error(R, [[0, -1, 0], [0, 0, 1], [-1, 0, 0]]) < 1e-15


def test_euler_zyz_from_matrix_hand_value():
    # the matrix above: theta = atan2(hypot(r31, r32), r33) = atan2(1, 0) = 90 deg,
    # psi = atan2(r32, -r31) = atan2(0, 1) = 0, phi = atan2(r23, r13) = atan2(1, 0) = 90 deg
    angles_ = euler_zyz_from_matrix([[0, -1, 0], [0, 0, 1], [-1, 0, 0]])
    assert max_error(angles_, [PI / 2, PI / 2, 0.0]) < 1e-15


def test_euler_zyz_negative_branch_hand_value():
    # (phi, theta, psi) = (0.3, 0.2, 0.1) -> other branch (0.3 - pi, -0.2, 0.1 - pi), wrapped into (-pi, pi]
    R = rot_z(0.3) @ rot_y(0.2) @ rot_z(0.1)
    angles_ = euler_zyz_from_matrix(R, theta_negative=True)
    assert max_error(angles_, [0.3 - PI, -0.2, 0.1 - PI]) < 1e-15


@EULER_SETTINGS
@given(angles, st.floats(1e-3, PI - 1e-3), angles)
def test_euler_zyz_round_trip_away_from_singularity(phi, theta, psi):
    result = euler_zyz_from_matrix(matrix_from_euler_zyz([phi, theta, psi]))
    assert np.max(np.abs(wrapped(result - [phi, theta, psi]))) <= 1e-12


@EULER_SETTINGS
@given(angles, st.floats(1e-3, PI - 1e-3), angles)
def test_euler_zyz_negative_branch_is_phi_plus_pi_minus_theta_psi_plus_pi(phi, theta, psi):
    result = euler_zyz_from_matrix(matrix_from_euler_zyz([phi, theta, psi]), theta_negative=True)
    assert np.max(np.abs(wrapped(result - [phi + PI, -theta, psi + PI]))) <= 1e-12


@EULER_SETTINGS
@given(angles, angles, st.booleans())
def test_euler_zyz_at_theta_zero_returns_phi_plus_psi_and_zero_psi(phi, psi, negative):
    # theta = 0: R = Rz(phi + psi), only the sum is determined
    result = euler_zyz_from_matrix(matrix_from_euler_zyz([phi, 0.0, psi]), theta_negative=negative)
    assert result[1] == 0.0 and result[2] == 0.0
    assert abs(wrapped(result[0] - (phi + psi))) <= 1e-12


@EULER_SETTINGS
@given(angles, angles, st.booleans())
def test_euler_zyz_at_theta_pi_returns_phi_minus_psi_and_zero_psi(phi, psi, negative):
    # theta = pi: R = Rz(phi) Ry(pi) Rz(psi) = Rz(phi - psi) Ry(pi), only the difference is determined
    result = euler_zyz_from_matrix(matrix_from_euler_zyz([phi, PI, psi]), theta_negative=negative)
    assert result[1] == (-PI if negative else PI) and result[2] == 0.0
    assert abs(wrapped(result[0] - (phi - psi))) <= 1e-12


@EULER_SETTINGS
@given(st.one_of(rotations(), zyz_singular_rotations()), st.booleans())
def test_matrix_euler_zyz_matrix_round_trip_both_branches_including_singular(R, negative):
    angles_ = euler_zyz_from_matrix(R, theta_negative=negative)
    assert max_error(matrix_from_euler_zyz(angles_), R) <= 1e-12


@EULER_SETTINGS
@given(st.one_of(rotations(), zyz_singular_rotations()))
def test_euler_zyz_ranges(R):
    phi, theta, psi = euler_zyz_from_matrix(R)
    assert -PI < phi <= PI and -PI < psi <= PI and 0.0 <= theta <= PI
    phi, theta, psi = euler_zyz_from_matrix(R, theta_negative=True)
    assert -PI < phi <= PI and -PI < psi <= PI and -PI <= theta <= 0.0


@EULER_SETTINGS
@given(angles, st.floats(0.0, 0.9e-12), st.sampled_from([0.0, PI]), angles, st.booleans())
def test_euler_zyz_inside_singular_tolerance_reproduces_rotation_within_twice_the_tolerance(
    phi, gap, theta0, psi, negative
):
    R = matrix_from_euler_zyz([phi, theta0 + gap if theta0 == 0.0 else theta0 - gap, psi])
    result = euler_zyz_from_matrix(R, theta_negative=negative, gimbal_tol=1e-12)
    assert result[2] == 0.0
    assert max_error(matrix_from_euler_zyz(result), R) <= 2e-12 + 1e-15


def test_euler_zyz_from_matrix_keeps_leading_dimensions():
    zyz = np.stack([np.linspace(-3, 3, 6), np.linspace(0.1, 3, 6), np.linspace(3, -3, 6)], axis=-1)
    R = matrix_from_euler_zyz(zyz.reshape(3, 2, 3))
    assert R.shape == (3, 2, 3, 3)
    result = euler_zyz_from_matrix(R)
    assert result.shape == (3, 2, 3)
    assert max_error(result.reshape(6, 3), zyz) < 1e-12


def test_euler_zyz_from_matrix_rejects_a_reflection():
    with pytest.raises(InvalidRotationError, match="reflection"):
        euler_zyz_from_matrix(np.diag([1.0, -1.0, 1.0]))


# ---------------------------------------------------------------- seed 004, section 3: axis-angle


def test_axis_angle_seed_example_x_axis_45_deg():
    # seed 004 A.4: axis (1, 0, 0), 45 deg; eq. 3.3 gives [[1, 0, 0], [0, c, -s], [0, s, c]] with
    # c = s = sqrt(1/2); eq. 3.4 reads back theta = acos((1 + 2c - 1) / 2) = 45 deg and
    # n = (r32 - r23, r13 - r31, r21 - r12) / (2 sin theta) = (2s, 0, 0) / (2s) = (1, 0, 0)
    R = matrix_from_axis_angle([1.0, 0.0, 0.0], PI / 4)
    assert max_error(R, [[1, 0, 0], [0, S45, -S45], [0, S45, S45]]) < 1e-15
    axis, angle = axis_angle_from_matrix(R)
    assert max_error(axis, [1.0, 0.0, 0.0]) < 1e-15
    assert abs(angle - PI / 4) < 1e-15


def test_axis_angle_at_half_turn_where_seed_equation_3_4_divides_by_zero():
    # seed eq. 3.4 divides the skew part by 2 sin(theta) = 0 at 180 deg; Rx(pi) still has axis x
    R = np.diag([1.0, -1.0, -1.0])
    skew = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    assert np.all(skew == 0.0)  # 0 / 0: the seed's formula gives no axis here
    axis, angle = axis_angle_from_matrix(R)
    assert axis.tolist() == [1.0, 0.0, 0.0] and angle == PI


def test_wrap_angle_is_half_open_even_a_few_ulps_above_pi():
    # pi - mod(pi - a, 2 pi) rounds to -pi for a = pi + 4.4e-16; the result must be +pi.
    from manipkit.spatial.rotations import wrap_angle

    angles = np.array([np.pi, -np.pi, np.pi + 4.440892098500626e-16, 3 * np.pi, -3 * np.pi, 0.5, -0.5 - 2 * np.pi])
    wrapped = wrap_angle(angles)
    assert np.all((wrapped > -np.pi) & (wrapped <= np.pi))
    assert wrapped[:5] == pytest.approx([np.pi] * 5, abs=1e-15)
    assert wrapped[5:] == pytest.approx([0.5, -0.5], abs=1e-15)


def test_euler_zyz_other_branch_found_by_hypothesis_stays_in_range():
    # A half turn about y (theta = pi, singular) with 4e-16 noise: psi + pi landed on -pi before the fix.
    R = np.array([[-2.22044605e-16, 4.00614097e-16, -1.0],
                  [-4.00614097e-16, -1.0, -4.00614097e-16],
                  [-1.0, 4.00614097e-16, -2.22044605e-16]])
    phi, theta, psi = euler_zyz_from_matrix(R, theta_negative=True, check=False)
    assert -PI < phi <= PI and -PI < psi <= PI and -PI <= theta <= 0.0
    assert np.abs(matrix_from_euler_zyz([phi, theta, psi]) - R).max() < 1e-12


# --------------------------------------------------------------------------
# both forms of the rotation helpers (issue 14, finding 9)


def test_rotation_helpers_take_the_angles_as_one_array_or_as_arguments():
    from manipkit.spatial.euler import matrix_from_euler_zyx, matrix_from_euler_zyz
    from manipkit.spatial.rotations import matrix_from_quaternion, matrix_from_rpy, rot_x, rot_y, rot_z

    yaw, pitch, roll = 0.3, -0.2, 1.1
    # independent: the product of elementary rotations, R = Rz(yaw) Ry(pitch) Rx(roll)
    expected = rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)
    assert np.abs(matrix_from_euler_zyx(yaw, pitch, roll) - expected).max() < 1e-15
    assert np.abs(matrix_from_euler_zyx([yaw, pitch, roll]) - expected).max() < 1e-15
    assert np.abs(matrix_from_rpy(roll, pitch, yaw) - expected).max() < 1e-15
    assert np.abs(matrix_from_euler_zyz(0.4, 0.5, 0.6) - rot_z(0.4) @ rot_y(0.5) @ rot_z(0.6)).max() < 1e-15
    s = np.sin(0.25)  # a turn of 0.5 rad about z: (0, 0, sin 0.25, cos 0.25)
    assert np.abs(matrix_from_quaternion(0.0, 0.0, s, np.cos(0.25)) - rot_z(0.5)).max() < 1e-15
    # the parts broadcast: three yaws with one pitch and roll
    stack = matrix_from_euler_zyx(np.array([0.1, 0.2, 0.3]), 0.0, 0.0)
    assert stack.shape == (3, 3, 3) and np.abs(stack[2] - rot_z(0.3)).max() < 1e-15


def test_rotation_helper_with_some_parts_missing_says_which():
    from manipkit.errors import InvalidRotationError
    from manipkit.spatial.euler import matrix_from_euler_zyx

    with pytest.raises(InvalidRotationError, match="roll missing"):
        matrix_from_euler_zyx(0.1, 0.2)


# issue 26: NaN and integers too large for a float went through the rotation helpers
@pytest.mark.parametrize("angles", [(math.nan, 0.0, 0.0), (0.0, math.inf, 0.0), (10**400, 0.0, 0.0)])
def test_rotation_helpers_refuse_angles_that_are_not_finite_floats(angles):
    with pytest.raises(InvalidRotationError, match="rpy"):
        matrix_from_rpy(*angles)
    with pytest.raises(InvalidRotationError, match="rpy"):
        matrix_from_rpy(list(angles))
