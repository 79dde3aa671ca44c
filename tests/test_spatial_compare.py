"""Tests of manipkit.spatial.compare: comparing hand matrices with the model, diagnoses (reading them: test_inputs_matrices.py).

Validity messages and pose errors are manipkit.spatial.transforms' (tests/test_spatial_transforms.py).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from manipkit.errors import InvalidRotationError, InvalidTransformError
from manipkit.inputs.matrices import read_matrix
from manipkit.spatial.compare import ComparisonResult, compare_transform
from manipkit.spatial.rotations import matrix_from_rpy, rot_x, rot_y, rot_z

# T_a_b with a rotation of 30 deg about z and a translation: the "model" answer
T_MODEL = np.eye(4)
T_MODEL[:3, :3] = rot_z(math.radians(30))
T_MODEL[:3, 3] = [0.1, 0.2, 0.3]

# what a student wrote as a transform (seed 000): every row starts with 1
SEED = [[1, 0, 0, 0.172], [1, 0, 0, 0], [1, 0, 0, 0], [1, 0, 0, 0]]

EXPECTED = np.array([[1.0, 0.0, 0.0, 0.1], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def transform(R, t) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


def write(tmp_path, name: str, text: str):
    path = tmp_path / name
    path.write_text(text)
    return path


# ---------------------------------------------------------------- read_matrix: formats


# ---------------------------------------------------------------- read_matrix: bad files


# ---------------------------------------------------------------- compare_transform


def test_identical_transforms_agree():
    result = compare_transform(T_MODEL, T_MODEL.copy())
    assert result.agrees
    assert result.violations == ()
    assert result.explain()[0].startswith("agrees with the model within tol 1e-06")


def test_tiny_difference_within_tol_agrees():
    T = T_MODEL.copy()
    T[0, 3] += 5e-7
    result = compare_transform(T_MODEL, T)
    assert result.agrees
    assert abs(result.position_error - 5e-7) < 1e-15


def test_difference_beyond_tol_disagrees():
    T = T_MODEL.copy()
    T[0, 3] += 2e-6
    assert not compare_transform(T_MODEL, T).agrees


def test_rotation_tolerance_is_in_radians():
    # 1e-6 rad = 5.7e-5 deg: with tol 1e-6 a rotation error of 0.5e-6 rad agrees, 2e-6 rad does not
    near = transform(T_MODEL[:3, :3] @ rot_x(0.5e-6), T_MODEL[:3, 3])
    far = transform(T_MODEL[:3, :3] @ rot_x(2e-6), T_MODEL[:3, 3])
    assert compare_transform(T_MODEL, near).agrees
    result = compare_transform(T_MODEL, far)
    assert not result.agrees
    assert abs(result.rotation_error_deg - math.degrees(2e-6)) < 1e-12


def test_violation_prevents_agreement_even_with_zero_errors():
    T = T_MODEL.copy()
    T[3, 3] = 2.0
    result = compare_transform(T_MODEL, T)
    assert result.position_error == 0.0 and result.rotation_error_deg == 0.0
    assert not result.agrees
    lines = result.explain()
    assert "hand matrix is not a homogeneous transform: last row is [0 0 0 2], expected [0 0 0 1]" in lines
    assert "the rotation matches; the translation matches; only the last row differs: it should be [0 0 0 1]" in lines


def test_explain_recognises_the_inverse():
    result = compare_transform(T_MODEL, np.linalg.inv(T_MODEL))
    assert not result.agrees
    assert result.explain()[1].startswith("the hand matrix is the inverse of the model: the opposite direction")


def test_explain_recognises_the_transpose():
    result = compare_transform(T_MODEL, T_MODEL.T)
    assert result.explain()[-2].startswith("the hand matrix is the transpose of the model's")


def test_explain_recognises_translation_in_the_bottom_row():
    T = np.eye(4)
    T[:3, :3] = T_MODEL[:3, :3]
    T[3, :3] = T_MODEL[:3, 3]
    result = compare_transform(T_MODEL, T)
    assert "the translation is written in the bottom row; it belongs in the last column" in result.explain()


def test_explain_recognises_a_half_done_inverse():
    # R^T with -t instead of -R^T t
    T = transform(T_MODEL[:3, :3].T, -T_MODEL[:3, 3])
    lines = compare_transform(T_MODEL, T).explain()
    assert any(line.startswith("the hand matrix is a half-done inverse") for line in lines)


def test_explain_recognises_a_transposed_rotation_with_correct_translation():
    T = transform(T_MODEL[:3, :3].T, T_MODEL[:3, 3])
    lines = compare_transform(T_MODEL, T).explain()
    assert "the rotation block is the transpose of the model's (the inverse rotation); the translation matches" in lines


def test_explain_recognises_millimetres():
    T = transform(T_MODEL[:3, :3], 1000.0 * T_MODEL[:3, 3])
    lines = compare_transform(T_MODEL, T).explain()
    assert "the translation is 1000 times the model's: millimetres instead of metres?" in lines


def test_explain_recognises_a_translation_sign_error():
    T = T_MODEL.copy()
    T[2, 3] = -0.3
    lines = compare_transform(T_MODEL, T).explain()
    assert "the rotation matches; the translation differs: z: model 0.3, hand -0.3 (opposite sign) (metres)" in lines


def test_explain_gives_the_relative_rotation_when_only_the_rotation_differs():
    # hand = model followed by 90 deg about the model frame's z: R_hand = R_model Rz(90)
    T = transform(T_MODEL[:3, :3] @ rot_z(math.pi / 2), T_MODEL[:3, 3])
    lines = compare_transform(T_MODEL, T).explain()
    expected = (
        "the rotation differs: R_hand = R_model @ rotation of 90 deg about the model frame's +z axis; "
        "the translation matches"
    )
    assert expected in lines


def test_explain_without_summary_gives_only_the_diagnosis():
    result = compare_transform(T_MODEL, T_MODEL.T)
    lines = result.explain(summary=False)
    assert lines == result.explain()[2:]
    assert lines[0].startswith("the hand matrix is the transpose of the model's")
    assert compare_transform(T_MODEL, T_MODEL).explain(summary=False) == []


def test_explain_names_the_largest_entry_difference():
    T = T_MODEL.copy()
    T[1, 3] = 0.25
    assert "largest entry difference at T[1, 3]: model 0.2, hand 0.25" in compare_transform(T_MODEL, T).explain()


def test_explain_suggests_a_tolerance_for_rounded_hand_values():
    # the student's matrix written with 3 decimals: right, but only to about 5e-4
    T = np.round(T_MODEL, 3)
    result = compare_transform(T_MODEL, T)
    assert not result.agrees
    assert result.explain()[-1] == (
        "the differences are small; if your hand values are rounded, a tolerance of 0.001 would accept them"
    )


def test_explain_of_the_seed_matrix():
    # the student meant a translation of 0.172 m along x with no rotation
    T_model = transform(np.eye(3), [0.172, 0.0, 0.0])
    result = compare_transform(T_model, SEED)
    lines = result.explain()
    assert not result.agrees
    assert len(result.violations) == 5
    assert "hand matrix is not a homogeneous transform: last row is [1 0 0 0], expected [0 0 0 1]" in lines
    assert any("det(R_hand) = 0, so no relative rotation can be given" in line for line in lines)


def test_explain_stops_at_non_finite_hand_entries():
    T = T_MODEL.copy()
    T[0, 0] = np.nan
    lines = compare_transform(T_MODEL, T).explain()
    assert lines[-1] == "cannot diagnose further: the hand matrix has entries that are not finite"


def test_compare_rejects_an_invalid_model():
    with pytest.raises(InvalidTransformError, match="T_model is not a homogeneous transform: det"):
        compare_transform(np.diag([1.0, 1.0, -1.0, 1.0]), np.eye(4))


def test_compare_rejects_a_hand_matrix_neither_4x4_nor_3x3():
    # (a 3x3 is a rotation, compared with the rotation block: see the tests at the end)
    with pytest.raises(InvalidTransformError, match=r"T_hand must have shape \(\.\.\., 4, 4\), got \(3, 4\)"):
        compare_transform(T_MODEL, np.eye(3, 4))


def test_comparison_result_is_frozen():
    result = compare_transform(T_MODEL, T_MODEL)
    assert isinstance(result, ComparisonResult)
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.agrees = False


def test_compare_with_rpy_built_model_and_rounded_hand_values_reads_back(tmp_path):
    # end to end: a hand matrix written to a file with 6 decimals agrees at tol 1e-5
    T_model = transform(matrix_from_rpy([0.2, -0.4, 1.1]), [0.5, -0.25, 0.75])
    path = tmp_path / "hand.txt"
    path.write_text("\n".join(" ".join(f"{v:.6f}" for v in row) for row in T_model))
    assert compare_transform(T_model, read_matrix(path), tol=1e-5).agrees
    assert not compare_transform(T_model, read_matrix(path), tol=1e-9).agrees


def test_rot_y_hand_matrix_against_rot_z_model_names_both_differences():
    T_model = transform(rot_z(math.pi / 2), [0.1, 0.0, 0.0])
    T_hand = transform(rot_y(math.pi / 2), [0.0, 0.1, 0.0])
    lines = compare_transform(T_model, T_hand).explain()
    assert any(line.startswith("the rotation differs: R_hand = R_model @ rotation of 120 deg") for line in lines)
    assert any("the translation differs: x: model 0.1, hand 0; y: model 0, hand 0.1" in line for line in lines)


# ---------------------------------------------------------------- read_matrix: limits (issue 15)


# --------------------------------------------------------------------------
# a 3x3 rotation compared with the model's rotation block (issue 14)


def model_pose():
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = rot_z(0.5) @ rot_x(0.2), [0.3, -0.1, 0.8]
    return T


def test_a_3x3_rotation_is_compared_with_the_rotation_only():
    T = model_pose()
    result = compare_transform(T, T[:3, :3].copy())
    assert result.rotation_only and result.agrees and math.isnan(result.position_error)
    assert result.explain()[0].startswith("a 3x3 rotation: compared with the model's rotation only (the translation is "
                                          "not checked); agrees with it")


def test_a_3x3_rotation_that_differs_says_by_how_much_and_about_which_axis():
    T = model_pose()
    hand = T[:3, :3] @ rot_z(math.radians(2.0))  # 2 deg more about the model frame's z axis
    result = compare_transform(T, hand)
    assert not result.agrees and result.rotation_error_deg == pytest.approx(2.0, abs=1e-9)
    text = "\n".join(result.explain())
    assert "R_hand = R_model @ rotation of 2 deg about the model frame's +z axis" in text


def test_a_transposed_3x3_rotation_is_named():
    T = model_pose()
    text = "\n".join(compare_transform(T, T[:3, :3].T.copy()).explain())
    assert "the hand rotation is the transpose of the model's (the inverse rotation" in text


def test_a_3x3_that_is_not_a_rotation_is_named():
    T = model_pose()
    result = compare_transform(T, np.diag([1.0, 1.0, -1.0]))
    assert not result.agrees and result.violations and "det" in " ".join(result.violations)


@pytest.mark.parametrize("T_hand", [[[1, 0, 0], [0, 1], [0, 0, 1]], [["a", "b", "c"]] * 3])
def test_a_ragged_or_non_numeric_hand_matrix_is_one_line(T_hand):
    with pytest.raises((InvalidTransformError, InvalidRotationError)) as info:
        compare_transform(np.eye(4), T_hand)
    assert "T_hand" in str(info.value) and "\n" not in str(info.value)
