"""Tests of manipkit.spatial.transforms: the one SE(3) module (build, invert, check, pose error).

Conventions under test (docs/architecture.md): T_a_b = [[R, t], [0, 0, 0, 1]] is the pose of
frame b in frame a, t in metres; rpy = (roll, pitch, yaw) with R = Rz(yaw) Ry(pitch) Rx(roll);
quaternions (x, y, z, w). Expected values are worked out by hand in the comments, or built
here independently of manipkit's conversions (the quaternions from half angles).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from manipkit.errors import IKOptionError, InvalidTransformError, ManipkitError
from manipkit.spatial.rotations import rot_x, rot_y, rot_z
from manipkit.spatial.transforms import (
    check_transform,
    invert_transform,
    pose_error,
    pose_residuals,
    transform_from_xyz_quaternion,
    transform_from_xyz_rpy,
    transform_violations,
)

PI = math.pi

# T_a_b with a rotation of 30 deg about z and a translation: a valid transform
T_MODEL = np.eye(4)
T_MODEL[:3, :3] = rot_z(math.radians(30))
T_MODEL[:3, 3] = [0.1, 0.2, 0.3]

# what a student wrote as a transform (seed 000): every row starts with 1
SEED = [[1, 0, 0, 0.172], [1, 0, 0, 0], [1, 0, 0, 0], [1, 0, 0, 0]]

# no deadline: timing is not under test, and a loaded machine must not fail these
SETTINGS = settings(deadline=None, max_examples=200)

angles = st.floats(-PI, PI, allow_nan=False)
lengths = st.floats(-10.0, 10.0, allow_nan=False)


def transform(R, t) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


def quaternion_xyzw_from_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """q = q_z(yaw) q_y(pitch) q_x(roll) from half angles, multiplied out by hand (Hamilton product).

    With c_r = cos(roll / 2), s_r = sin(roll / 2) and the same for pitch (p) and yaw (y):
    q_x = (s_r, 0, 0, c_r), q_y = (0, s_p, 0, c_p), q_z = (0, 0, s_y, c_y); their product is
    the textbook ZYX formula below. Independent of manipkit.spatial.rotations.
    """
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array([
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    ])


# ---------------------------------------------------------------- building


def test_transform_from_xyz_rpy_hand_value():
    # rpy (0, 0, 90 deg): Rz(90) sends x -> y and y -> -x; those images are the first two columns
    T = transform_from_xyz_rpy([1.0, 2.0, 3.0], [0.0, 0.0, PI / 2])
    expected = [[0, -1, 0, 1], [1, 0, 0, 2], [0, 0, 1, 3], [0, 0, 0, 1]]
    assert np.max(np.abs(T - expected)) < 1e-15


def test_transform_from_xyz_quaternion_hand_value():
    # a quarter turn about x: q = (sin 45, 0, 0, cos 45); Rx(90) sends y -> z and z -> -y
    s = math.sqrt(0.5)
    T = transform_from_xyz_quaternion([0.5, 0.0, -0.5], [s, 0.0, 0.0, s])
    expected = [[1, 0, 0, 0.5], [0, 0, -1, 0], [0, 1, 0, -0.5], [0, 0, 0, 1]]
    assert np.max(np.abs(T - expected)) < 1e-15  # cos 90 computed as 1 - 2 s^2 = 2.2e-16


def test_hand_built_quaternion_of_a_quarter_turn_about_z():
    # the helper itself, on a value known by heart: rpy (0, 0, 90 deg) is q = (0, 0, sin 45, cos 45)
    s = math.sqrt(0.5)
    assert np.max(np.abs(quaternion_xyzw_from_rpy(0.0, 0.0, PI / 2) - [0.0, 0.0, s, s])) < 1e-15


@SETTINGS
@given(lengths, lengths, lengths, angles, st.floats(-PI / 2, PI / 2), angles)
def test_xyz_rpy_and_xyz_quaternion_build_the_same_transform(x, y, z, roll, pitch, yaw):
    from_rpy = transform_from_xyz_rpy([x, y, z], [roll, pitch, yaw])
    from_quaternion = transform_from_xyz_quaternion([x, y, z], quaternion_xyzw_from_rpy(roll, pitch, yaw))
    assert np.max(np.abs(from_rpy - from_quaternion)) < 1e-14
    assert from_rpy[3].tolist() == [0.0, 0.0, 0.0, 1.0]


def test_transform_from_xyz_quaternion_normalises_the_quaternion():
    # (0, 0, 2, 0) is the half turn about z (0, 0, 1, 0) scaled by 2
    T = transform_from_xyz_quaternion([0.0, 0.0, 0.0], [0.0, 0.0, 2.0, 0.0])
    assert np.max(np.abs(T - np.diag([-1.0, -1.0, 1.0, 1.0]))) < 1e-15


# ---------------------------------------------------------------- inverting


def test_invert_transform_hand_value():
    # T_a_b = [Rz(90), (1, 0, 0)]: T_b_a = [Rz(-90), -Rz(-90) (1, 0, 0)] = [Rz(-90), (0, 1, 0)]
    T_a_b = transform(rot_z(PI / 2), [1.0, 0.0, 0.0])
    T_b_a = invert_transform(T_a_b)
    assert np.max(np.abs(T_b_a - transform(rot_z(-PI / 2), [0.0, 1.0, 0.0]))) < 1e-15


@SETTINGS
@given(lengths, lengths, lengths, angles, st.floats(-PI / 2, PI / 2), angles)
def test_invert_transform_round_trip_is_the_identity(x, y, z, roll, pitch, yaw):
    T = transform_from_xyz_rpy([x, y, z], [roll, pitch, yaw])
    inverse = invert_transform(T)
    assert np.max(np.abs(T @ inverse - np.eye(4))) < 1e-13
    assert np.max(np.abs(inverse @ T - np.eye(4))) < 1e-13
    assert np.max(np.abs(invert_transform(inverse) - T)) < 1e-14


def test_invert_transform_keeps_leading_dimensions():
    angles_ = np.linspace(-3.0, 3.0, 10)
    stack = np.stack([transform(rot_x(a) @ rot_y(a / 2), [a, -a, 2 * a]) for a in angles_]).reshape(5, 2, 4, 4)
    inverse = invert_transform(stack)
    assert inverse.shape == (5, 2, 4, 4)
    assert np.max(np.abs(stack @ inverse - np.eye(4))) < 1e-13
    assert np.max(np.abs(inverse[3, 1] - np.linalg.inv(stack[3, 1]))) < 1e-13


def test_invert_transform_does_not_change_its_argument():
    T = T_MODEL.copy()
    invert_transform(T)
    assert np.array_equal(T, T_MODEL)


# ---------------------------------------------------------------- check_transform


def check_error(T, what: str = "T") -> str:
    with pytest.raises(InvalidTransformError) as info:
        check_transform(T, what=what)
    assert isinstance(info.value, ManipkitError)
    return str(info.value)


def test_check_transform_returns_a_float_copy():
    T = np.eye(4, dtype=int)
    checked = check_transform(T)
    assert checked.dtype == float and checked.shape == (4, 4)
    checked[0, 3] = 1.0
    assert T[0, 3] == 0


def test_check_transform_accepts_nested_lists():
    assert np.array_equal(check_transform(T_MODEL.tolist()), T_MODEL)


def test_check_transform_non_numeric_names_what():
    message = check_error([["a", 0, 0, 0]] * 4, what="IK target")
    assert message.startswith("IK target: entries are not all numbers: ")


def test_check_transform_wrong_shape_names_what():
    assert check_error(np.eye(3), what="pose") == "pose: shape is (3, 3), expected (4, 4)"


def test_check_transform_non_finite_entry_names_what():
    T = T_MODEL.copy()
    T[1, 3] = np.inf
    assert check_error(T, what="target") == "target: entry T[1, 3] is not finite (inf)"


def test_check_transform_last_row_names_what():
    T = T_MODEL.copy()
    T[3] = [0.0, 0.0, 0.5, 1.0]
    assert check_error(T, what="T_base_tool") == "T_base_tool: last row is [0 0 0.5 1], expected [0 0 0 1]"


def test_check_transform_non_rotation_block_names_what_and_counts_the_rest():
    # y axis scaled by sqrt(2): norm 1.414 and det(R) = 1.414, two problems
    message = check_error(np.diag([1.0, math.sqrt(2), 1.0, 1.0]), what="hand matrix")
    assert message == "hand matrix: rotation column 1 (y axis) has norm 1.414, expected 1 (and 1 more problem)"


def test_check_transform_reflection_names_what():
    message = check_error(np.diag([1.0, 1.0, -1.0, 1.0]))
    assert message == "T: det(R) = -1, expected +1 (is this a reflection?)"


def test_check_transform_tolerance():
    T = T_MODEL.copy()
    T[3, 3] = 1.0 + 1e-7
    check_transform(T)  # within the default 1e-6
    with pytest.raises(InvalidTransformError, match=r"last row is \[0 0 0 1.0000001\]"):
        check_transform(T, tol=1e-9)


# ---------------------------------------------------------------- transform_violations (the messages check_transform raises)


def test_valid_transform_has_no_violations():
    assert transform_violations(T_MODEL) == []


def test_seed_matrix_violations():
    # R = [[1, 0, 0], [1, 0, 0], [1, 0, 0]]: column x = (1, 1, 1) has norm sqrt(3) = 1.732,
    # columns y and z are zero, so det(R) = 0; the last row is [1 0 0 0]
    assert transform_violations(SEED) == [
        "last row is [1 0 0 0], expected [0 0 0 1]",
        "rotation column 0 (x axis) has norm 1.732, expected 1",
        "rotation column 1 (y axis) has norm 0, expected 1",
        "rotation column 2 (z axis) has norm 0, expected 1",
        "det(R) = 0, expected +1 (the matrix is singular)",
    ]


def test_last_row_violation():
    T = T_MODEL.copy()
    T[3] = [0.0, 0.0, 0.5, 1.0]
    assert transform_violations(T) == ["last row is [0 0 0.5 1], expected [0 0 0 1]"]


def test_column_norm_violation():
    # y axis scaled by sqrt(2): norm 1.414, and det(R) = 1.414 with it
    T = np.diag([1.0, math.sqrt(2), 1.0, 1.0])
    assert transform_violations(T) == [
        "rotation column 1 (y axis) has norm 1.414, expected 1",
        "det(R) = 1.414, expected +1",
    ]


def test_orthogonality_violation():
    # unit columns x and (0.35, sqrt(1 - 0.35^2), 0) meet at acos(0.35): dot 0.35, det 0.9367
    T = np.eye(4)
    T[:3, 1] = [0.35, math.sqrt(1 - 0.35**2), 0.0]
    assert transform_violations(T) == [
        "rotation columns 0 and 1 are not orthogonal (dot 0.35)",
        "det(R) = 0.9367, expected +1",
    ]


def test_reflection_violation():
    assert transform_violations(np.diag([1.0, 1.0, -1.0, 1.0])) == [
        "det(R) = -1, expected +1 (is this a reflection?)"
    ]


def test_non_finite_entry_violation():
    T = T_MODEL.copy()
    T[1, 3] = np.nan
    assert transform_violations(T) == ["entry T[1, 3] is not finite (nan)"]


def test_wrong_shape_violation():
    assert transform_violations(np.eye(3)) == ["shape is (3, 3), expected (4, 4)"]


def test_violation_tolerance_shows_the_deviation():
    T = T_MODEL.copy()
    T[3, 3] = 1.0 + 1e-7
    assert transform_violations(T) == []
    assert transform_violations(T, tol=1e-9) == ["last row is [0 0 0 1.0000001], expected [0 0 0 1]"]


# ---------------------------------------------------------------- pose_error


def test_pose_error_hand_values():
    # translation (0.3, 0.4, 0) is 0.5 m from the origin (3-4-5); Rz(0.5) is 0.5 rad from I
    position, rotation = pose_error(np.eye(4), transform(rot_z(0.5), [0.3, 0.4, 0.0]))
    assert abs(position - 0.5) < 1e-15
    assert abs(rotation - 0.5) < 1e-15


def test_pose_error_projects_a_scaled_rotation_block():
    # 2 * Rz(0.3) is not a rotation; its nearest rotation is Rz(0.3)
    position, rotation = pose_error(np.eye(4), transform(2.0 * rot_z(0.3), [0.0, 0.0, 0.0]))
    assert position == 0.0
    assert abs(rotation - 0.3) < 1e-12


def test_pose_error_projects_a_reflection_to_a_proper_rotation():
    # diag(1, 1, -1) has nearest proper rotation I (flip the smallest singular direction)
    _, rotation = pose_error(np.eye(4), np.diag([1.0, 1.0, -1.0, 1.0]))
    assert rotation < 1e-12


def test_pose_error_is_nan_for_non_finite_rotation():
    T = np.eye(4)
    T[0, 0] = np.inf
    assert math.isnan(pose_error(np.eye(4), T)[1])


def test_pose_error_broadcasts_over_leading_dimensions():
    stack = np.stack([transform(rot_x(a), [a, 0.0, 0.0]) for a in (0.1, 0.2, 0.3)])
    position, rotation = pose_error(np.eye(4), stack)
    assert position.shape == rotation.shape == (3,)
    assert np.max(np.abs(rotation - [0.1, 0.2, 0.3])) < 1e-15


def test_pose_error_hand_values_between_two_turned_poses():
    # T_ref = [Rz(90), (1, 0, 0)], T = [Rz(90) Rx(60), (1, 0.6, 0.8)]:
    # translation gap (0, 0.6, 0.8) has length sqrt(0.36 + 0.64) = 1 m;
    # R_ref^T R = Rx(60 deg), a rotation of pi/3 = 1.0471975511965976 rad
    T_ref = transform(rot_z(PI / 2), [1.0, 0.0, 0.0])
    T = transform(rot_z(PI / 2) @ rot_x(PI / 3), [1.0, 0.6, 0.8])
    position, rotation = pose_error(T_ref, T)
    assert abs(position - 1.0) < 1e-15
    assert abs(rotation - 1.0471975511965976) < 1e-15


def test_pose_error_is_symmetric_and_zero_for_equal_poses():
    T = transform(rot_y(0.7), [0.1, -0.2, 0.3])
    assert pose_error(T, T) == (0.0, 0.0)
    assert pose_error(T_MODEL, T) == pose_error(T, T_MODEL)


def test_pose_error_rejects_a_non_4x4_argument():
    with pytest.raises(InvalidTransformError, match=r"T must have shape \(\.\.\., 4, 4\), got \(3, 3\)"):
        pose_error(np.eye(4), np.eye(3))


# ---------------------------------------------------------------- pose_residuals (every IK solver's measure)


def test_pose_residuals_by_mode_hand_values():
    # T = [Rx(0.5), (0, 0.3, 0.4)] against I: the origin is 0.5 m away (3-4-5) in every mode; pose: Rx(0.5) is
    # 0.5 rad from I; position: 0; position+axis x: Rx leaves the x axis where it was (0); axis z: z turns by 0.5
    T = transform(rot_x(0.5), [0.0, 0.3, 0.4])
    assert pose_residuals(np.eye(4), T) == pytest.approx((0.5, 0.5), abs=1e-15)
    assert pose_residuals(np.eye(4), T, mode="position") == (pytest.approx(0.5, abs=1e-15), 0.0)
    assert pose_residuals(np.eye(4), T, mode="position+axis", axis="x") == pytest.approx((0.5, 0.0), abs=1e-15)
    assert pose_residuals(np.eye(4), T, mode="position+axis", axis="z") == pytest.approx((0.5, 0.5), abs=1e-15)


@SETTINGS
@given(st.lists(st.floats(-np.pi, np.pi), min_size=6, max_size=6), st.lists(st.floats(-2.0, 2.0), min_size=6, max_size=6),
       st.sampled_from(["pose", "position", "position+axis"]), st.sampled_from(["x", "y", "z"]))
def test_pose_residuals_of_one_pair_equal_those_of_a_stack(angles, xyz, mode, axis):
    # one (4, 4) pair takes a plain-float path: it must give the vectorised numbers (and the pose mode pose_error's)
    T_a, T_b = transform_from_xyz_rpy(xyz[:3], angles[:3]), transform_from_xyz_rpy(xyz[3:], angles[3:])
    single = pose_residuals(T_a, T_b, mode=mode, axis=axis)
    stacked = pose_residuals(T_a[None], T_b[None], mode=mode, axis=axis)
    assert single[0] == pytest.approx(stacked[0][0], abs=1e-15) and single[1] == pytest.approx(stacked[1][0], abs=1e-14)
    if mode == "pose":
        assert single == pose_residuals(T_b, T_a)  # symmetric, exactly


@pytest.mark.parametrize("project", [True, False])
@pytest.mark.parametrize("bad", [np.inf, -np.inf, np.nan])
def test_pose_error_of_one_pair_is_nan_for_a_non_finite_rotation_entry(project, bad):
    for i, j in ((0, 0), (1, 2), (2, 1)):
        T = transform(rot_z(0.3), [0.1, 0.2, 0.3])
        T[i, j] = bad
        assert math.isnan(pose_error(np.eye(4), T, project=project)[1])
        assert math.isnan(pose_error(T, np.eye(4), project=project)[1])


def test_pose_error_without_projection_takes_the_blocks_as_they_are():
    # 2 * Rz(0.3): projected, 0.3 rad from I; as it is, M = 2 Rz(0.3): atan2(|v|, (tr M - 1) / 2) with
    # |v| = 2 sin 0.3 and tr M = 2 (1 + 2 cos 0.3), i.e. atan2(2 sin 0.3, 0.5 + 2 cos 0.3)
    T = transform(2.0 * rot_z(0.3), [0.0, 0.0, 0.0])
    assert pose_error(np.eye(4), T)[1] == pytest.approx(0.3, abs=1e-12)
    expected = math.atan2(2.0 * math.sin(0.3), 0.5 + 2.0 * math.cos(0.3))
    assert pose_error(np.eye(4), T, project=False)[1] == pytest.approx(expected, abs=1e-15)
    assert pose_error(np.eye(4)[None], T[None], project=False)[1][0] == pytest.approx(expected, abs=1e-15)


def test_pose_residuals_broadcast_a_target_over_reached_poses():
    stack = np.stack([transform(rot_z(a), [0.0, 0.0, a]) for a in (0.1, 0.2, 0.3)])
    position, rotation = pose_residuals(np.eye(4), stack, mode="position+axis", axis="x")
    assert position.shape == rotation.shape == (3,)
    np.testing.assert_allclose(position, [0.1, 0.2, 0.3], atol=1e-15)
    np.testing.assert_allclose(rotation, [0.1, 0.2, 0.3], atol=1e-15)  # Rz turns the x axis by its angle


def test_pose_residuals_refuse_an_unknown_mode_or_axis():
    with pytest.raises(IKOptionError, match="unknown IK mode 'orientation'; modes: pose, position, position\\+axis"):
        pose_residuals(np.eye(4), np.eye(4), mode="orientation")
    with pytest.raises(IKOptionError, match="axes: x, y, z"):
        pose_residuals(np.eye(4), np.eye(4), mode="position+axis", axis="w")


@settings(max_examples=300)
@given(
    angles=st.tuples(*[st.floats(-np.pi, np.pi)] * 3),
    noise=st.lists(st.floats(-1.0, 1.0), min_size=16, max_size=16),
    scale=st.sampled_from([0.0, 1e-8, 2e-7, 4e-7, 6e-7, 1e-6, 3e-6]),
)
def test_check_transform_accepts_exactly_what_transform_violations_finds_nothing_in(angles, noise, scale):
    # a rotation (rpy) and translation, perturbed entry by entry around the tolerance 1e-6: the quick
    # acceptance inside check_transform must never let through what the full list of violations refuses
    T = transform_from_xyz_rpy([0.3, -0.2, 0.5], angles) + scale * np.reshape(noise, (4, 4))
    if transform_violations(T, tol=1e-6):
        with pytest.raises(InvalidTransformError):
            check_transform(T, tol=1e-6)
    else:
        assert np.array_equal(check_transform(T, tol=1e-6), T)


# issue 26: the API passed NaN through and inverted a scaling as if it were rigid
def test_invert_transform_refuses_what_is_not_a_rigid_transform():
    with pytest.raises(InvalidTransformError, match=r"^T is not a rigid transform: rotation column 0 \(x axis\) has norm 2"):
        invert_transform(np.diag([2.0, 2.0, 2.0, 1.0]))
    with pytest.raises(InvalidTransformError, match=r"^T is not a rigid transform: entry T\[0, 3\] is not finite"):
        invert_transform(np.array([[1.0, 0, 0, np.nan], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]))
    stack = np.stack([np.eye(4), np.diag([1.0, 1.0, -1.0, 1.0])])
    with pytest.raises(InvalidTransformError, match=r"^T\[1\] is not a rigid transform: det\(R\) = -1"):
        invert_transform(stack)
    # the rigid ones still invert: T^-1 T = I
    T = transform_from_xyz_rpy([1.0, -2.0, 0.5], [0.3, -0.2, 1.1])
    assert np.abs(invert_transform(T) @ T - np.eye(4)).max() < 1e-15
