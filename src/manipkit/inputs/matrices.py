"""Hand-written matrices from files: a 4x4 transform (or a 3x3 rotation) in the formats people paste.

Read for ``tf-between --compare`` and ``manipkit rot matrix FILE``
(:func:`read_matrix`); the comparison with the model is
:mod:`manipkit.spatial.compare`. Indices in messages about matrix entries are
1-based rows and entries, as a person counts lines of a file.
"""

from __future__ import annotations

import json
import os
import re

import numpy as np

from manipkit.errors import InputFileError, InvalidTransformError
from manipkit.inputs.files import MAX_MATRIX_BYTES, check_input_file
from manipkit.text import printable

__all__ = ["read_matrix"]




def read_matrix(path: str | os.PathLike, *, rotation: bool = False) -> np.ndarray:
    """Read a 4x4 homogeneous transform (or, with ``rotation=True``, also a 3x3 rotation) from a file.

    Parameters
    ----------
    path : str or path-like
        The format follows the extension:

        - ``.npy``: a numpy array saved with ``np.save``.
        - ``.json``: a nested list ``[[...], ...]`` or an object with the key
          ``"matrix"`` holding one (as ``tf-between --format json`` writes).
        - anything else (``.txt``, ``.csv``, ...): text, one matrix row per
          line or separated by ``;`` (MATLAB), numbers separated by spaces
          and/or commas. Brackets and braces are ignored, so rows pasted
          from numpy (``[[1, 0, 0, 0.1], [0, 1, 0, 0], ...]``, also inside
          ``array(...)``), MATLAB (``[1 0 0 0.1; 0 1 0 0; ...]``) or
          Mathematica (``{{1, 0, 0, 0.1}, ...}``) are read, also after an
          assignment such as ``T = ``. ``#`` and ``%`` start comments.

    rotation : bool, keyword-only
        Accept a 3x3 matrix too (a rotation: ``tf --compare`` then compares
        rotations only, ``manipkit rot matrix FILE`` reads one).

    Returns
    -------
    T : ndarray, shape (4, 4), or (3, 3) with ``rotation=True``
        The matrix as written. It is not validated as a transform; see
        :func:`~manipkit.spatial.transforms.transform_violations`.

    Raises
    ------
    InvalidTransformError
        One line naming the file and the problem: missing or unreadable file,
        a FIFO, device or folder, a file larger than
        :data:`manipkit.inputs.MAX_MATRIX_BYTES` (refused before it is read),
        a row with the wrong count of numbers ("row 3 has 3 numbers, expected
        4"), an entry that is not a number or not finite (nan, inf), or a
        matrix of another shape (named).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "hand.txt"
    >>> _ = path.write_text("[1 0 0 0.172; 0 1 0 0; 0 0 1 0; 0 0 0 1]")
    >>> read_matrix(path)[0]
    array([1.   , 0.   , 0.   , 0.172])
    """
    path = os.fspath(path)
    name = printable(path)  # for messages; the file is opened by its own name
    if not os.path.lexists(path):
        raise InvalidTransformError(f"{name}: no such file")
    if os.path.isdir(path):
        raise InvalidTransformError(f"{name}: is a folder, expected a matrix file")
    try:  # a FIFO, device, symlink loop or huge file is refused here, before anything reads it
        check_input_file(path, what="matrix file", max_bytes=MAX_MATRIX_BYTES)
    except InputFileError as exc:
        raise InvalidTransformError(str(exc)) from None
    suffix = os.path.splitext(path)[1].lower()
    try:
        if suffix in (".npy", ".npz"):
            return _finite(_read_npy(path, rotation), name)
        with open(path, "rb") as stream:
            text = stream.read(MAX_MATRIX_BYTES + 1).decode("utf-8").removeprefix("\ufeff")
    except OSError as exc:
        raise InvalidTransformError(f"{name}: cannot read ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise InvalidTransformError(f"{name}: not a text file (save the matrix as .txt, .csv, .json or .npy)") from None
    if suffix == ".json":
        rows = _rows_from_json(text, name)
    else:
        rows = _rows_from_text(text, name)
    return _finite(_check_shape(_matrix_from_rows(rows, name), name, rotation), name)


def _finite(matrix: np.ndarray, name: str) -> np.ndarray:
    """``matrix`` when every entry is finite; else the first nan or inf, named by row and entry (from 1)."""
    bad = np.argwhere(~np.isfinite(matrix))
    if bad.size:
        row, column = bad[0]
        raise InvalidTransformError(f"{name}: row {row + 1}, entry {column + 1} is {matrix[row, column]}, not a finite "
                                    "number; a transform has finite entries")
    return matrix


def _read_npy(name: str, rotation: bool = False) -> np.ndarray:
    """The 4x4 (or 3x3 rotation) array of a ``.npy`` file, memory-mapped first: a header claiming a huge shape allocates nothing."""
    try:
        array = np.load(name, mmap_mode="r", allow_pickle=False)
    except (ValueError, EOFError, OSError) as exc:
        raise InvalidTransformError(f"{name}: not a valid .npy file ({' '.join(str(exc).split())})") from None
    if not isinstance(array, np.ndarray):
        if hasattr(array, "close"):
            array.close()
        raise InvalidTransformError(f"{name}: holds several arrays, expected one 4x4 array")
    if not (np.issubdtype(array.dtype, np.number) or array.dtype == bool) or np.iscomplexobj(array):
        raise InvalidTransformError(f"{name}: holds {array.dtype} values, expected real numbers")
    return np.array(_check_shape(array, name, rotation), dtype=float)  # a copy: the file is not kept open


def _rows_from_json(text: str, name: str) -> list[list]:
    try:
        data = json.loads(text, parse_int=float)  # a 400-digit integer is a float too large (inf), refused below
    except json.JSONDecodeError as exc:
        where = f"line {exc.lineno}, column {exc.colno}"
        raise InvalidTransformError(f"{name}: invalid JSON at {where}: {exc.msg}") from None
    except RecursionError:
        raise InvalidTransformError(f"{name}: JSON nested too deeply; expected rows like [[1, 0, 0, 0], ...]") from None
    if isinstance(data, dict):
        if "matrix" not in data:
            raise InvalidTransformError(f'{name}: JSON object has no key "matrix" (it has {len(data)} other keys)')
        data = data["matrix"]
    if not isinstance(data, list) or not all(isinstance(row, list) for row in data):
        got = "a list with entries that are not rows" if isinstance(data, list) else f"a JSON {type(data).__name__}"
        raise InvalidTransformError(f"{name}: expected a list of rows like [[1, 0, 0, 0], ...], got {got}")
    rows = []
    for number, row in enumerate(data, start=1):
        for column, value in enumerate(row, start=1):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                what = "a list" if isinstance(value, list) else "an object" if isinstance(value, dict) else (
                    "a text" if isinstance(value, str) else json.dumps(value))  # null, true, false
                raise InvalidTransformError(f"{name}: row {number}, entry {column} is {what}, not a number")
        rows.append([float(value) for value in row])
    return rows


_ASSIGNMENT = re.compile(r"^\s*[A-Za-z_]\w*\s*=(?!=)")  # T = ...
_CALL = re.compile(r"^\s*[A-Za-z_][\w.]*\s*\(")  # array( / np.array( / Matrix(
_DTYPE = re.compile(r",\s*dtype\s*=\s*[\w.]+\s*\)\s*$")  # ..., dtype=float32)


def _rows_from_text(text: str, name: str) -> list[list[float]]:
    text = _ASSIGNMENT.sub("", re.sub(r"[#%].*", "", text).lstrip(), count=1)
    if _CALL.match(text):
        text = _DTYPE.sub(")", _CALL.sub("", text, count=1).rstrip())
        text = text[:-1] if text.endswith(")") else text
    # a closing bracket ends a row; so do ';' and line breaks
    text = re.sub(r"[\]}]", "\n", text).replace(";", "\n")
    text = re.sub(r"[\[{]", " ", text)
    rows = []
    for line in text.splitlines():
        line = line.strip().strip(",").strip()
        if not line:
            continue
        tokens = re.split(r"\s*,\s*|\s+", line)
        number = len(rows) + 1
        row = []
        for column, token in enumerate(tokens, start=1):
            if not token:
                raise InvalidTransformError(f"{name}: row {number}, entry {column} is empty")
            try:
                row.append(float(token))
            except ValueError:
                # the entry itself is not quoted: the file may be anything (/proc/self/environ), and its text is not ours to show
                message = f"{name}: row {number}, entry {column} ({len(token)} characters) is not a number"
                raise InvalidTransformError(message) from None
        rows.append(row)
    return rows


def _matrix_from_rows(rows: list[list[float]], name: str) -> np.ndarray:
    if not rows:
        raise InvalidTransformError(f"{name}: no numbers found, expected a 4x4 matrix")
    lengths = [len(row) for row in rows]
    if len(set(lengths)) > 1:
        expected = 4 if 4 in lengths else max(set(lengths), key=lengths.count)
        number = next(i for i, length in enumerate(lengths, start=1) if length != expected)
        raise InvalidTransformError(f"{name}: row {number} has {lengths[number - 1]} numbers, expected {expected}")
    return np.array(rows, dtype=float)


def _check_shape(array: np.ndarray, name: str, rotation: bool = False) -> np.ndarray:
    if array.shape == (4, 4) or (rotation and array.shape == (3, 3)):
        return array
    expected = "a 4x4 transform or a 3x3 rotation" if rotation else "a 4x4 transform"
    if array.shape == (3, 4):
        raise InvalidTransformError(f"{name}: has 3 rows of 4 numbers, expected 4x4 (add the last row 0 0 0 1)")
    if array.ndim == 2:
        rows, columns = array.shape
        raise InvalidTransformError(
            f"{name}: has {rows} rows of {columns} numbers (a {rows}x{columns} matrix), expected {expected}"
        )
    raise InvalidTransformError(f"{name}: holds an array of shape {array.shape}, expected {expected}")
