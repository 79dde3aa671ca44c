"""Tests of manipkit.inputs.poses: target poses read from a file (x y z roll pitch yaw, or 4x4 matrices)."""

from __future__ import annotations

import numpy as np
import pytest

from manipkit.errors import InputFileError, InvalidTransformError
from manipkit.inputs.poses import read_targets
from manipkit.spatial.transforms import transform_from_xyz_rpy


def test_read_targets_takes_xyz_rpy_and_matrices(tmp_path):
    T = transform_from_xyz_rpy([1.0, 2.0, 0.5], [0.1, -0.2, 0.3])
    rows = "\n".join(" ".join(repr(float(v)) for v in row) for row in T)
    flat = ", ".join(repr(float(v)) for v in T.ravel())
    path = tmp_path / "targets.txt"
    path.write_text(f"# poses\n1 2 0.5 0.1 -0.2 0.3\n\n{rows}\n{flat}  # one line\n")
    got = read_targets(path)
    assert got.shape == (3, 4, 4)
    for pose in got:
        np.testing.assert_allclose(pose, T, atol=1e-15)


@pytest.mark.parametrize(
    ("text", "error", "message"),
    [
        ("1 2 3\n", InputFileError, "line 1: 3 numbers"),
        ("1 2 three 4 5 6\n", InputFileError, "line 1: '1 2 three 4 5 6' is not numbers"),
        ("1 0 0 0\n0 1 0 0\n", InputFileError, "has 2 rows"),
        ("# nothing\n", InputFileError, "no target pose"),
        ("1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 0\n", InvalidTransformError, "lines 1-4: last row"),
        ("1 2 3 nan 0 0\n", InputFileError, "all finite"),
    ],
)
def test_read_targets_names_the_bad_line(tmp_path, text, error, message):
    path = tmp_path / "t.txt"
    path.write_text(text)
    with pytest.raises(error, match=message):
        read_targets(path)
