"""Tests of manipkit.spatial.compare: reading hand matrices, comparing them with the model, diagnoses.

Validity messages and pose errors are manipkit.spatial.transforms' (tests/test_spatial_transforms.py).
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from manipkit.errors import InvalidRotationError, InvalidTransformError
from manipkit.spatial.compare import ComparisonResult, compare_transform, read_matrix
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


def test_read_matrix_whitespace_rows(tmp_path):
    path = write(tmp_path, "hand.txt", "1 0 0 0.1\n0 1 0 0\n0 0 1 0\n0 0 0 1\n")
    assert read_matrix(path).tolist() == EXPECTED.tolist()


def test_read_matrix_csv(tmp_path):
    path = write(tmp_path, "hand.csv", "1,0,0,0.1\n0, 1, 0, 0\n0,0,1,0\n0,0,0,1\n")
    assert read_matrix(path).tolist() == EXPECTED.tolist()


def test_read_matrix_numpy_nested_list_on_one_line(tmp_path):
    path = write(tmp_path, "hand.txt", "[[1, 0, 0, 0.1], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]")
    assert read_matrix(path).tolist() == EXPECTED.tolist()


def test_read_matrix_numpy_array_repr_over_several_lines(tmp_path):
    text = (
        "array([[1. , 0. , 0. , 0.1],\n"
        "       [0. , 1. , 0. , 0. ],\n"
        "       [0. , 0. , 1. , 0. ],\n"
        "       [0. , 0. , 0. , 1. ]])\n"
    )
    assert read_matrix(write(tmp_path, "hand.txt", text)).tolist() == EXPECTED.tolist()


def test_read_matrix_numpy_print_without_commas(tmp_path):
    text = "[[1.  0.  0.  0.1]\n [0.  1.  0.  0. ]\n [0.  0.  1.  0. ]\n [0.  0.  0.  1. ]]\n"
    assert read_matrix(write(tmp_path, "hand.txt", text)).tolist() == EXPECTED.tolist()


def test_read_matrix_matlab_semicolon_rows(tmp_path):
    path = write(tmp_path, "hand.m", "T = [1 0 0 0.1; 0 1 0 0; 0 0 1 0; 0 0 0 1];")
    assert read_matrix(path).tolist() == EXPECTED.tolist()


def test_read_matrix_ignores_comments_and_blank_lines(tmp_path):
    text = "# T_base_tool by hand\n\n1 0 0 0.1  # x = 0.1 m\n0 1 0 0\n% matlab comment\n0 0 1 0\n0 0 0 1\n"
    assert read_matrix(write(tmp_path, "hand.txt", text)).tolist() == EXPECTED.tolist()


def test_read_matrix_scientific_notation(tmp_path):
    path = write(tmp_path, "hand.txt", "1 0 0 1e-1\n0 1 0 0\n0 0 1 0\n0 0 0 1.0E+00\n")
    assert read_matrix(path).tolist() == EXPECTED.tolist()


def test_read_matrix_json_nested_list(tmp_path):
    path = write(tmp_path, "hand.json", json.dumps(EXPECTED.tolist()))
    assert read_matrix(path).tolist() == EXPECTED.tolist()


def test_read_matrix_json_object_with_matrix_key(tmp_path):
    # the shape tf-between --format json writes
    path = write(tmp_path, "tf.json", json.dumps({"source": "a", "target": "b", "matrix": EXPECTED.tolist()}))
    assert read_matrix(path).tolist() == EXPECTED.tolist()


def test_read_matrix_npy(tmp_path):
    path = tmp_path / "hand.npy"
    np.save(path, EXPECTED)
    assert read_matrix(path).tolist() == EXPECTED.tolist()


def test_read_matrix_accepts_a_string_path(tmp_path):
    path = write(tmp_path, "hand.txt", "1 0 0 0.1\n0 1 0 0\n0 0 1 0\n0 0 0 1\n")
    assert read_matrix(str(path)).shape == (4, 4)


# ---------------------------------------------------------------- read_matrix: bad files


def read_error(path) -> str:
    with pytest.raises(InvalidTransformError) as raised:
        read_matrix(path)
    message = str(raised.value)
    assert "\n" not in message
    return message


def test_read_matrix_missing_file(tmp_path):
    path = tmp_path / "nothere.txt"
    assert read_error(path) == f"{path}: no such file"


def test_read_matrix_folder(tmp_path):
    assert read_error(tmp_path).endswith("is a folder, expected a matrix file")


def test_read_matrix_short_row_is_named(tmp_path):
    path = write(tmp_path, "hand.txt", "1 0 0 0.1\n0 1 0 0\n0 0 1\n0 0 0 1\n")
    assert read_error(path) == f"{path}: row 3 has 3 numbers, expected 4"


def test_read_matrix_non_numeric_entry_is_named(tmp_path):
    path = write(tmp_path, "hand.txt", "1 0 0 0.1\n0 1 cos(q1) 0\n0 0 1 0\n0 0 0 1\n")
    assert read_error(path) == f"{path}: row 2, entry 3 is 'cos(q1)', not a number"


def test_read_matrix_empty_csv_field_is_named(tmp_path):
    path = write(tmp_path, "hand.csv", "1,,0,0.1\n0,1,0,0\n0,0,1,0\n0,0,0,1\n")
    assert read_error(path) == f"{path}: row 1, entry 2 is empty"


def test_read_matrix_3x3_names_the_shape(tmp_path):
    path = write(tmp_path, "hand.txt", "1 0 0\n0 1 0\n0 0 1\n")
    assert read_error(path) == f"{path}: has 3 rows of 3 numbers (a 3x3 matrix), expected a 4x4 transform"


def test_read_matrix_3x4_suggests_the_last_row(tmp_path):
    path = write(tmp_path, "hand.txt", "1 0 0 0.1\n0 1 0 0\n0 0 1 0\n")
    assert read_error(path) == f"{path}: has 3 rows of 4 numbers, expected 4x4 (add the last row 0 0 0 1)"


def test_read_matrix_empty_file(tmp_path):
    path = write(tmp_path, "hand.txt", "# nothing yet\n")
    assert read_error(path) == f"{path}: no numbers found, expected a 4x4 matrix"


def test_read_matrix_binary_text_file(tmp_path):
    path = tmp_path / "hand.txt"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe")
    assert read_error(path).endswith("not a text file (save the matrix as .txt, .csv, .json or .npy)")


def test_read_matrix_json_without_matrix_key(tmp_path):
    path = write(tmp_path, "hand.json", json.dumps({"T": EXPECTED.tolist()}))
    assert read_error(path) == f'{path}: JSON object has no key "matrix" (keys: T)'


def test_read_matrix_json_string_entry(tmp_path):
    rows = EXPECTED.tolist()
    rows[1][2] = "s1"
    path = write(tmp_path, "hand.json", json.dumps(rows))
    assert read_error(path) == f'{path}: row 2, entry 3 is "s1", not a number'


def test_read_matrix_json_ragged_rows(tmp_path):
    rows = EXPECTED.tolist()
    rows[3] = [0, 0, 1]
    path = write(tmp_path, "hand.json", json.dumps(rows))
    assert read_error(path) == f"{path}: row 4 has 3 numbers, expected 4"


def test_read_matrix_invalid_json(tmp_path):
    path = write(tmp_path, "hand.json", "[[1, 0, 0, 0.1], [0, 1")
    assert read_error(path).startswith(f"{path}: invalid JSON at line 1, column")


def test_read_matrix_npy_of_wrong_shape(tmp_path):
    path = tmp_path / "hand.npy"
    np.save(path, np.eye(3))
    assert read_error(path) == f"{path}: has 3 rows of 3 numbers (a 3x3 matrix), expected a 4x4 transform"


def test_read_matrix_flat_npy_names_the_shape(tmp_path):
    path = tmp_path / "hand.npy"
    np.save(path, np.eye(4).ravel())
    assert read_error(path) == f"{path}: holds an array of shape (16,), expected a 4x4 transform"


def test_read_matrix_corrupt_npy(tmp_path):
    path = tmp_path / "hand.npy"
    path.write_bytes(b"not numpy at all")
    assert read_error(path).startswith(f"{path}: not a valid .npy file")


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


@pytest.mark.parametrize("text, entry", [("1 0 0 nan\n0 1 0 0\n0 0 1 0\n0 0 0 1", "row 1, entry 4 is nan"),
                                         ("1 0 0 0; 0 1 0 0; 0 0 1 -inf; 0 0 0 1", "row 3, entry 4 is -inf")])
def test_read_matrix_refuses_entries_that_are_not_finite(tmp_path, text, entry):
    path = write(tmp_path, "hand.txt", text)
    assert read_error(path) == f"{path}: {entry}, not a finite number; a transform has finite entries"


def test_read_matrix_refuses_nan_in_json_and_npy(tmp_path):
    path = write(tmp_path, "hand.json", '{"matrix": [[1, 0, 0, 0], [0, 1, 0, NaN], [0, 0, 1, 0], [0, 0, 0, 1]]}')
    assert read_error(path).endswith("row 2, entry 4 is nan, not a finite number; a transform has finite entries")
    T = np.eye(4)
    T[3, 3] = np.inf
    np.save(tmp_path / "hand.npy", T)
    assert read_error(tmp_path / "hand.npy").endswith("row 4, entry 4 is inf, not a finite number; a transform has finite entries")


def test_read_matrix_refuses_a_file_above_the_limit_before_reading_it(tmp_path):
    from manipkit.inputs import MAX_MATRIX_BYTES

    path = tmp_path / "hand.txt"
    with open(path, "w") as stream:
        stream.write("1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n")  # a valid matrix, then a sparse tail of NUL bytes
        stream.truncate(2 * MAX_MATRIX_BYTES)
    assert read_error(path) == f"matrix file {path} is 2 MB, above the limit of 1 MB for a matrix file"


def test_read_matrix_npy_header_claiming_a_huge_shape_allocates_nothing(tmp_path):
    from numpy.lib import format as npy_format

    path = tmp_path / "hand.npy"
    with open(path, "wb") as stream:  # 10^10 float64 claimed (75 GB), 128 bytes present
        npy_format.write_array_header_1_0(stream, {"descr": "<f8", "fortran_order": False, "shape": (10**10,)})
        stream.write(b"\0" * 128)
    assert read_error(path).startswith(f"{path}: not a valid .npy file")


def test_read_matrix_json_nested_deeper_than_python_recursion(tmp_path):
    path = write(tmp_path, "hand.json", "[" * 5000)
    assert read_error(path) == f"{path}: JSON nested too deeply; expected rows like [[1, 0, 0, 0], ...]"


def test_read_matrix_skips_a_byte_order_mark(tmp_path):
    path = tmp_path / "hand.csv"
    path.write_bytes(b"\xef\xbb\xbf1,0,0,0.5\n0,1,0,0\n0,0,1,0\n0,0,0,1\n")
    assert read_matrix(path)[0].tolist() == [1, 0, 0, 0.5]


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


def test_read_matrix_takes_a_3x3_only_when_asked(tmp_path):
    path = tmp_path / "R.txt"
    path.write_text("0 -1 0\n1 0 0\n0 0 1\n")
    assert read_matrix(path, rotation=True).shape == (3, 3)
    with pytest.raises(InvalidTransformError, match="expected a 4x4 transform"):
        read_matrix(path)
    flat = tmp_path / "two.txt"
    flat.write_text("1 0\n0 1\n")
    with pytest.raises(InvalidTransformError, match="expected a 4x4 transform or a 3x3 rotation"):
        read_matrix(flat, rotation=True)


@pytest.mark.parametrize("T_hand", [[[1, 0, 0], [0, 1], [0, 0, 1]], [["a", "b", "c"]] * 3])
def test_a_ragged_or_non_numeric_hand_matrix_is_one_line(T_hand):
    with pytest.raises((InvalidTransformError, InvalidRotationError)) as info:
        compare_transform(np.eye(4), T_hand)
    assert "T_hand" in str(info.value) and "\n" not in str(info.value)
