"""Agreement between a hand-derived transform and the model's, with a diagnosis.

A student derives ``T_a_b`` (the pose of frame b in frame a, 4x4 homogeneous,
metres) on paper, types it into a file (read by
:func:`manipkit.inputs.matrices.read_matrix`), and asks whether it matches the
model. This module says how a matrix fails to be a homogeneous transform
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

import math
from dataclasses import dataclass, field

import numpy as np

from manipkit.errors import InvalidTransformError
from manipkit.spatial.rotations import AXIS_NAMES, as_float_array, axis_angle_from_matrix, rotation_violations
from manipkit.spatial.transforms import (
    as_transforms,
    invert_transform,
    pose_error,
    projected_rotation,
    transform_violations,
)
from manipkit.text import near_text, short_text, vector_text

__all__ = ["ComparisonResult", "compare_transform"]


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
    T_hand = as_float_array(T_hand, "T_hand", finite=False)  # a ragged or non-numeric matrix: one line, before its shape is read
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
    inverse = invert_transform(T_model, check=False)

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
