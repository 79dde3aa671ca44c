"""Target poses from a file: one pose per line (x y z roll pitch yaw, or a 4x4), for base placement."""

from __future__ import annotations

import math

import numpy as np

from manipkit.errors import InputFileError
from manipkit.inputs.files import MAX_TABLE_BYTES, read_text
from manipkit.spatial.transforms import check_transform, transform_from_xyz_rpy
from manipkit.text import printable

__all__ = ["MAX_POSITION", "MAX_TARGETS", "read_targets"]

MAX_TARGETS = 100_000  # target poses a file (or a base-placement search) may hold
#: Largest target coordinate (m), the longest length a description may hold (description.validate.MAX_LENGTH):
#: beyond it a grid of floor positions around the targets loses its step to rounding.
MAX_POSITION = 1e6


def read_targets(path) -> np.ndarray:
    """Target poses ``T_F_target`` (K, 4, 4) from a text file, read safely (:func:`manipkit.inputs.files.read_text`).

    One pose per line as ``x y z roll pitch yaw`` (m, rad; ``R = Rz(yaw)
    Ry(pitch) Rx(roll)`` as in URDF) or 16 numbers (a 4x4 row by row), or a
    4x4 as four lines of 4 numbers. Numbers are separated by spaces or
    commas; blank lines and lines starting with ``#`` are skipped.

    At most :data:`MAX_TARGETS` poses, counted as they are read.

    Raises
    ------
    InputFileError
        Not a readable text file, a line that is none of these forms, no pose, or more than ``MAX_TARGETS``.
    InvalidTransformError
        A 4x4 that is not a rigid transform (the line named).
    """
    poses, rows, first_row_line = [], [], 0
    name = printable(str(path))
    for number, line in enumerate(read_text(path, what="targets file", max_bytes=MAX_TABLE_BYTES).splitlines(), 1):
        if len(poses) >= MAX_TARGETS:
            raise InputFileError(f"{name}: more than {MAX_TARGETS} target poses; give at most {MAX_TARGETS}")
        text = line.split("#", 1)[0].replace(",", " ").split()
        if not text:
            continue
        try:
            values = [float(v) for v in text]
        except ValueError:
            raise InputFileError(f"{name} line {number}: '{printable(line.strip()[:60])}' is not numbers; give x y z roll pitch "
                                 "yaw, 16 numbers of a 4x4, or four lines of 4") from None
        if not all(math.isfinite(v) for v in values) or len(values) not in (4, 6, 16) or (rows and len(values) != 4):
            raise InputFileError(f"{name} line {number}: {len(values)} numbers; give 6 (x y z roll pitch yaw), 16 (a 4x4 "
                                 "row by row) or 4 (one row of a 4x4, four lines in a row), all finite")
        if len(values) == 6:
            poses.append(transform_from_xyz_rpy(values[:3], values[3:]))
        elif len(values) == 16:
            poses.append(check_transform(np.reshape(values, (4, 4)), what=f"{name} line {number}"))
        else:
            first_row_line = first_row_line or number
            rows.append(values)
            if len(rows) == 4:
                poses.append(check_transform(np.array(rows), what=f"{name} lines {first_row_line}-{number}"))
                rows, first_row_line = [], 0
        if poses and not rows and np.abs(poses[-1][:3, 3]).max() > MAX_POSITION:
            raise InputFileError(f"{name} line {number}: a position of {np.abs(poses[-1][:3, 3]).max():g} m; give "
                                 f"positions within {MAX_POSITION:g} m")
    if rows:
        raise InputFileError(f"{name}: the 4x4 from line {first_row_line} has {len(rows)} rows; give 4")
    if not poses:
        raise InputFileError(f"{name}: no target pose in it; give lines of x y z roll pitch yaw or 4x4 matrices")
    return np.array(poses)
