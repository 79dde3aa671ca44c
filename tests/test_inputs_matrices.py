"""Tests of manipkit.inputs.matrices: hand-written matrices read from files in the formats people paste."""

from __future__ import annotations

import json

import numpy as np
import pytest

from manipkit.errors import InvalidTransformError
from manipkit.inputs.matrices import read_matrix

EXPECTED = np.array([[1.0, 0.0, 0.0, 0.1], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def write(tmp_path, name: str, text: str):
    path = tmp_path / name
    path.write_text(text)
    return path


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
    assert read_error(path) == f"{path}: row 2, entry 3 (7 characters) is not a number"


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
    assert read_error(path) == f'{path}: JSON object has no key "matrix" (it has 1 other keys)'


def test_read_matrix_json_string_entry(tmp_path):
    rows = EXPECTED.tolist()
    rows[1][2] = "s1"
    path = write(tmp_path, "hand.json", json.dumps(rows))
    assert read_error(path) == f'{path}: row 2, entry 3 is a text, not a number'


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


def test_read_matrix_never_quotes_the_file_text(tmp_path):
    """Issue 40: /proc/self/environ given as a matrix file was echoed whole in the error line."""
    path = write(tmp_path, "environ.txt", "SECRET=hunter2\0PATH=/usr/bin\n1 0 0 0\n")
    message = read_error(path)
    assert message == f"{path}: row 1, entry 1 (21 characters) is not a number"  # after "SECRET=", read as an assignment
    json_path = write(tmp_path, "env.json", json.dumps({"SECRET": "hunter2"}))
    assert "SECRET" not in read_error(json_path) and "hunter2" not in read_error(json_path)
    listed = write(tmp_path, "list.json", json.dumps(["hunter2"]))
    assert "hunter2" not in read_error(listed)
