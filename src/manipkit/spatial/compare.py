"""Agreement between a hand-derived transform and the model's, with a diagnosis.

A student derives ``T_a_b`` (the pose of frame b in frame a, 4x4 homogeneous,
metres) on paper, types it into a file, and asks whether it matches the
model. This module reads such a file in the formats people paste
(:func:`read_matrix`), says how a matrix fails to be a homogeneous transform
and how far it is from the model's (with
:func:`~manipkit.spatial.transforms.transform_violations` and
:func:`~manipkit.spatial.transforms.pose_error`) and recognises the usual mistakes: the inverse
direction, a transposed matrix or rotation, a translation in millimetres or
in the bottom row (:func:`compare_transform`, :meth:`ComparisonResult.explain`).

Indices in messages about matrix entries are 0-based, as in numpy
(``T[0, 3]`` is the x translation); rows of a file are counted from 1.

Only numpy is imported, so this module loads fast.
"""

from __future__ import annotations

import json
import math
import os
import re
from dataclasses import dataclass, field

import numpy as np

from manipkit.errors import InputFileError, InvalidTransformError
from manipkit.inputs import MAX_MATRIX_BYTES, check_input_file
from manipkit.spatial.rotations import AXIS_NAMES, as_float_array, axis_angle_from_matrix, rotation_violations
from manipkit.spatial.transforms import (
    as_transforms,
    invert_transform,
    pose_error,
    projected_rotation,
    transform_violations,
)
from manipkit.text import near_text, short_text, vector_text

__all__ = ["ComparisonResult", "compare_transform", "read_matrix"]


# --------------------------------------------------------------------------
# reading


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
    name = os.fspath(path)
    if not os.path.lexists(name):
        raise InvalidTransformError(f"{name}: no such file")
    if os.path.isdir(name):
        raise InvalidTransformError(f"{name}: is a folder, expected a matrix file")
    try:  # a FIFO, device, symlink loop or huge file is refused here, before anything reads it
        check_input_file(name, what="matrix file", max_bytes=MAX_MATRIX_BYTES)
    except InputFileError as exc:
        raise InvalidTransformError(str(exc)) from None
    suffix = os.path.splitext(name)[1].lower()
    try:
        if suffix in (".npy", ".npz"):
            return _finite(_read_npy(name, rotation), name)
        with open(name, "rb") as stream:
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
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        where = f"line {exc.lineno}, column {exc.colno}"
        raise InvalidTransformError(f"{name}: invalid JSON at {where}: {exc.msg}") from None
    except RecursionError:
        raise InvalidTransformError(f"{name}: JSON nested too deeply; expected rows like [[1, 0, 0, 0], ...]") from None
    if isinstance(data, dict):
        if "matrix" not in data:
            keys = ", ".join(map(str, list(data)[:8])) or "none"
            raise InvalidTransformError(f'{name}: JSON object has no key "matrix" (keys: {keys})')
        data = data["matrix"]
    if not isinstance(data, list) or not all(isinstance(row, list) for row in data):
        got = json.dumps(data)[:60]
        raise InvalidTransformError(f"{name}: expected a list of rows like [[1, 0, 0, 0], ...], got {got}")
    rows = []
    for number, row in enumerate(data, start=1):
        for column, value in enumerate(row, start=1):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                what = json.dumps(value)
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
                message = f"{name}: row {number}, entry {column} is '{token}', not a number"
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


# --------------------------------------------------------------------------
# comparison


@dataclass(frozen=True, eq=False)
class ComparisonResult:
    """How a hand-derived transform compares with the model's.

    Attributes
    ----------
    violations : tuple of str
        Ways ``T_hand`` fails to be a homogeneous transform
        (:func:`~manipkit.spatial.transforms.transform_violations`); empty when it is one.
    position_error : float
        ``|t_hand - t_model|`` in metres.
    rotation_error_deg : float
        Angle between the rotation blocks in degrees (after projecting a
        non-rotation block to the nearest rotation, see :func:`~manipkit.spatial.transforms.pose_error`).
    agrees : bool
        No violations, ``position_error <= tol`` (metres) and the rotation
        error ``<= tol`` in radians.
    T_model, T_hand : ndarray, shape (4, 4)
        The matrices compared.
    tol : float
        Tolerance of ``agrees``.
    hint_tol : float
        Looser tolerance used by :meth:`explain` to recognise typical
        mistakes in hand values rounded to a few decimals.
    rotation_only : bool
        The hand matrix was a 3x3 rotation: only the rotations were compared
        (``position_error`` is NaN; ``T_hand`` holds the hand rotation with
        the model's translation).
    """

    violations: tuple[str, ...]
    position_error: float
    rotation_error_deg: float
    agrees: bool
    T_model: np.ndarray = field(repr=False)
    T_hand: np.ndarray = field(repr=False)
    tol: float = 1e-6
    hint_tol: float = 1e-3
    rotation_only: bool = False

    def explain(self, *, summary: bool = True) -> list[str]:
        """Human-readable lines: the verdict, what is invalid, and the likely mistake.

        Parameters
        ----------
        summary : bool, keyword-only
            Start with the verdict line and one line per violation (default).
            Pass ``False`` when those are shown already (as the command line
            does) to get only the diagnosis of a mismatch.

        Returns
        -------
        list of str
            The verdict with both errors and each violation (if
            ``summary``); then, for a mismatch, the recognised mistakes (the
            hand matrix is the inverse or the transpose of the model's, its
            rotation is transposed, its translation is in millimetres or
            centimetres or in the bottom row, only the translation or only
            the rotation differs, and by what), the largest differing entry,
            and a hint when the differences are rounding-sized.
        """
        lines = []
        if self.rotation_only:
            return self._explain_rotation(summary)
        if summary and self.agrees:
            lines.append(
                f"agrees with the model within tol {short_text(self.tol)}: "
                f"position error {short_text(self.position_error, 3)} m, "
                f"rotation error {short_text(self.rotation_error_deg, 3)} deg"
            )
        elif summary:
            lines.append(
                f"does not agree with the model (tol {short_text(self.tol)}): "
                f"position error {short_text(self.position_error, 4)} m, "
                f"rotation error {short_text(self.rotation_error_deg, 4)} deg"
            )
            lines += [f"hand matrix is not a homogeneous transform: {v}" for v in self.violations]
        if self.agrees:
            return lines
        if not np.all(np.isfinite(self.T_hand)):
            return lines + ["cannot diagnose further: the hand matrix has entries that are not finite"]
        lines += _diagnose(self.T_model, self.T_hand, max(self.tol, self.hint_tol))
        difference = np.abs(self.T_hand - self.T_model)
        i, j = np.unravel_index(np.argmax(difference), difference.shape)
        lines.append(
            f"largest entry difference at T[{i}, {j}]: model {near_text(self.T_model[i, j], self.T_hand[i, j])}, "
            f"hand {near_text(self.T_hand[i, j], self.T_model[i, j])}"
        )
        if (
            self.position_error <= self.hint_tol
            and np.radians(self.rotation_error_deg) <= self.hint_tol
            and not transform_violations(self.T_hand, tol=self.hint_tol)
        ):
            lines.append(
                f"the differences are small; if your hand values are rounded, a tolerance of {short_text(self.hint_tol)} "
                "would accept them"
            )
        return lines


    def _explain_rotation(self, summary: bool) -> list[str]:
        R, R_hand = self.T_model[:3, :3], self.T_hand[:3, :3]
        lines = []
        if summary:
            verdict = "agrees with" if self.agrees else "does not agree with"
            lines.append(f"a 3x3 rotation: compared with the model's rotation only (the translation is not checked); "
                         f"{verdict} it within tol {short_text(self.tol)}: rotation error "
                         f"{short_text(self.rotation_error_deg, 4)} deg")
            lines += [f"hand matrix is not a rotation: {v}" for v in self.violations]
        if self.agrees:
            return lines
        if not np.all(np.isfinite(R_hand)):
            return lines + ["cannot diagnose further: the hand matrix has entries that are not finite"]
        if np.abs(R_hand - R.T).max() <= max(self.tol, self.hint_tol) and np.abs(R_hand - R).max() > self.hint_tol:
            lines.append("the hand rotation is the transpose of the model's (the inverse rotation: R_b_a instead of R_a_b)")
        else:
            lines.append("the rotation differs: " + _rotation_difference(R, R_hand))
        difference = np.abs(R_hand - R)
        i, j = np.unravel_index(np.argmax(difference), difference.shape)
        lines.append(f"largest entry difference at R[{i}, {j}]: model {near_text(R[i, j], R_hand[i, j])}, "
                     f"hand {near_text(R_hand[i, j], R[i, j])}")
        if np.radians(self.rotation_error_deg) <= self.hint_tol and not rotation_violations(R_hand, tol=self.hint_tol):
            lines.append(f"the difference is small; if your hand values are rounded, a tolerance of "
                         f"{short_text(self.hint_tol)} would accept them")
        return lines


def compare_transform(T_model, T_hand, *, tol: float = 1e-6, hint_tol: float = 1e-3) -> ComparisonResult:
    """Compare a hand-derived transform with the model's.

    Parameters
    ----------
    T_model : array_like, shape (4, 4)
        The model's transform ``T_a_b`` (pose of frame b in frame a, metres).
    T_hand : array_like, shape (4, 4) or (3, 3)
        The hand-derived transform meant to be the same ``T_a_b``; or a 3x3
        rotation meant to be its rotation block ``R_a_b``: then rotations
        only are compared (``rotation_only``), and the result says so.
    tol : float, keyword-only
        Agreement tolerance: metres for the translation, radians for the
        rotation, and the tolerance of :func:`~manipkit.spatial.transforms.transform_violations`.
    hint_tol : float, keyword-only
        Looser tolerance (metres, radians, matrix entries) used only by
        :meth:`ComparisonResult.explain` to recognise typical mistakes in
        hand values rounded to a few decimals.

    Returns
    -------
    ComparisonResult

    Raises
    ------
    InvalidTransformError
        If either matrix is not numeric 4x4, or ``T_model`` is not a
        homogeneous transform within ``tol``.

    Examples
    --------
    >>> from manipkit.spatial.rotations import rot_z
    >>> T = np.eye(4); T[:3, :3] = rot_z(0.5); T[:3, 3] = [0.3, 0.4, 0.0]
    >>> compare_transform(T, np.linalg.inv(T)).explain()[1]
    'the hand matrix is the inverse of the model: the opposite direction (T_b_a, the pose of a in b, instead of T_a_b)'
    """
    T_model = as_transforms(T_model, "T_model")
    T_hand = as_float_array(T_hand, "T_hand")  # a ragged or non-numeric matrix: one line, before its shape is read
    if T_hand.shape == (3, 3) and T_model.shape == (4, 4):
        return _compare_rotation(T_model, T_hand, tol, hint_tol)
    T_hand = as_transforms(T_hand, "T_hand")
    if T_model.shape != (4, 4) or T_hand.shape != (4, 4):
        raise InvalidTransformError(
            f"compare_transform takes two 4x4 matrices, got {T_model.shape} and {T_hand.shape}"
        )
    model_problems = transform_violations(T_model, tol=tol)
    if model_problems:
        raise InvalidTransformError(f"T_model is not a homogeneous transform: {'; '.join(model_problems)}")
    violations = tuple(transform_violations(T_hand, tol=tol))
    position_error, rotation_error = (float(e) for e in pose_error(T_model, T_hand))
    agrees = not violations and position_error <= tol and rotation_error <= tol
    return ComparisonResult(
        violations=violations,
        position_error=position_error,
        rotation_error_deg=float(np.degrees(rotation_error)),
        agrees=bool(agrees),
        T_model=T_model.copy(),
        T_hand=T_hand.copy(),
        tol=tol,
        hint_tol=hint_tol,
    )


def _compare_rotation(T_model: np.ndarray, R_hand: np.ndarray, tol: float, hint_tol: float) -> ComparisonResult:
    """A 3x3 hand rotation against the model's rotation block: rotations only, the translation not compared."""
    model_problems = transform_violations(T_model, tol=tol)
    if model_problems:
        raise InvalidTransformError(f"T_model is not a homogeneous transform: {'; '.join(model_problems)}")
    violations = tuple(rotation_violations(R_hand, tol=tol))
    T_hand = np.eye(4)
    T_hand[:3, :3], T_hand[:3, 3] = R_hand, T_model[:3, 3]  # the model's translation: only rotations differ
    _, rotation_error = (float(e) for e in pose_error(T_model, T_hand))
    return ComparisonResult(
        violations=violations,
        position_error=math.nan,
        rotation_error_deg=float(np.degrees(rotation_error)),
        agrees=bool(not violations and rotation_error <= tol),
        T_model=T_model.copy(),
        T_hand=T_hand,
        tol=tol,
        hint_tol=hint_tol,
        rotation_only=True,
    )


def _diagnose(T_model: np.ndarray, T_hand: np.ndarray, tol: float) -> list[str]:
    """Recognise the usual mistakes; entries compared within ``tol``."""

    def close(a, b) -> bool:
        return bool(np.max(np.abs(np.asarray(a) - np.asarray(b))) <= tol)

    if close(T_hand, T_model):
        return []  # only small (rounding-sized) differences: nothing to recognise
    R, t = T_model[:3, :3], T_model[:3, 3]
    R_hand, t_hand = T_hand[:3, :3], T_hand[:3, 3]
    last_row_ok = close(T_hand[3], [0.0, 0.0, 0.0, 1.0])
    inverse = invert_transform(T_model)

    # whole-matrix mistakes, most specific first
    if close(T_hand, inverse):
        return [
            "the hand matrix is the inverse of the model: the opposite direction "
            "(T_b_a, the pose of a in b, instead of T_a_b)"
        ]
    if close(T_hand, T_model.T):
        return [
            "the hand matrix is the transpose of the model's: rows and columns swapped "
            "(the translation belongs in the last column, not the bottom row)"
        ]
    if close(R_hand, R) and close(T_hand[3, :3], t) and close(t_hand, 0.0):
        return ["the translation is written in the bottom row; it belongs in the last column"]
    if close(R_hand, R.T) and close(t_hand, -t) and last_row_ok:
        return [
            "the hand matrix is a half-done inverse: the rotation is transposed and the translation negated, "
            "but the inverse's translation is -R^T t, the negated translation rotated by R^T"
        ]
    for factor, unit in ((1000.0, "millimetres"), (100.0, "centimetres")):
        if close(R_hand, R) and close(t_hand / factor, t) and last_row_ok:
            return [f"the translation is {short_text(factor)} times the model's: {unit} instead of metres?"]

    # block by block
    rotation_ok, translation_ok = close(R_hand, R), close(t_hand, t)
    if rotation_ok:
        rotation = "the rotation matches"
    elif close(R_hand, R.T):
        rotation = "the rotation block is the transpose of the model's (the inverse rotation)"
    else:
        rotation = "the rotation differs: " + _rotation_difference(R, R_hand)
    if translation_ok:
        translation = "the translation matches"
    else:
        translation = "the translation differs: " + _translation_difference(t, t_hand, tol)
    if rotation_ok and translation_ok and not last_row_ok:
        return [f"{rotation}; {translation}; only the last row differs: it should be [0 0 0 1]"]
    return [f"{rotation}; {translation}"]


def _translation_difference(t: np.ndarray, t_hand: np.ndarray, tol: float) -> str:
    parts = []
    for k in range(3):
        if abs(t_hand[k] - t[k]) > tol:
            sign = " (opposite sign)" if abs(t_hand[k] + t[k]) <= tol else ""
            parts.append(f"{AXIS_NAMES[k]}: model {near_text(t[k])}, hand {near_text(t_hand[k], t[k])}{sign}")
    return "; ".join(parts) + " (metres)"


def _rotation_difference(R: np.ndarray, R_hand: np.ndarray) -> str:
    """The rotation taking the model's frame to the hand one, in the model frame."""
    if np.linalg.det(R_hand) <= 0.0:
        return f"det(R_hand) = {near_text(float(np.linalg.det(R_hand)))}, so no relative rotation can be given"
    relative = R.T @ projected_rotation(R_hand)
    axis, angle = axis_angle_from_matrix(relative, check=False)
    named = [f"{'+-'[int(axis[k] < 0)]}{AXIS_NAMES[k]}" for k in range(3) if abs(abs(axis[k]) - 1.0) < 1e-9]
    about = f"the model frame's {named[0]} axis" if named else f"axis {vector_text(np.round(axis, 4), near_text)} of the model frame"
    return f"R_hand = R_model @ rotation of {short_text(np.degrees(angle), 4)} deg about {about}"
