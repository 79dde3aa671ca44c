"""One rotation in every form: matrix, rpy, Euler ZYX, Euler ZYZ, axis-angle, quaternion, with the singular cases named.

:func:`rotation_from_form` builds the matrix from any form; :func:`rotation_forms`
gives all forms of a matrix (a :class:`RotationForms`) and says where a form
is not unique. Conventions (docs/architecture.md), restated:

- ``rpy = (roll, pitch, yaw)``, ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (URDF);
  Euler ZYX ``(yaw, pitch, roll)`` is the same rotation with the triple
  reversed. At gimbal lock (pitch = +-90 deg) only ``yaw - roll`` (+90) or
  ``yaw + roll`` (-90) is defined: roll is set to 0.
- Euler ZYZ ``(phi, theta, psi)``, ``R = Rz(phi) Ry(theta) Rz(psi)``, theta in
  [0, pi]. At theta = 0 or 180 deg only ``phi + psi`` or ``phi - psi`` is
  defined: psi is set to 0.
- Axis-angle: unit axis and angle in [0, pi]. At angle 0 every axis is
  valid ((0, 0, 1) is given); at 180 deg ``axis`` and ``-axis`` are the same
  rotation (the first non-zero component is made positive).
- Quaternion ``(x, y, z, w)`` (ROS order): ``q`` and ``-q`` are the same
  rotation; the one with ``w >= 0`` is given.
- Radians throughout.

A hand-written matrix is rarely exactly a rotation (entries rounded to three
decimals are 1e-4 off): :func:`rotation_from_matrix` accepts it within a
tolerance, or takes the nearest rotation (:func:`manipkit.spatial.transforms.nearest_rotation`,
the SVD projection) and says how far that moved (a :class:`NearestRotation`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from manipkit.errors import InvalidRotationError
from manipkit.spatial.euler import euler_zyz_from_matrix, matrix_from_euler_zyx, matrix_from_euler_zyz
from manipkit.spatial.rotations import (
    axis_angle_from_matrix,
    check_rotation,
    matrix_from_axis_angle,
    matrix_from_quaternion,
    matrix_from_rpy,
    quaternion_from_matrix,
    rotation_violations,
    rpy_from_matrix,
)
from manipkit.spatial.transforms import nearest_rotation, projected_rotation
from manipkit.text import short_text

__all__ = ["FORMS", "ROUNDING_TOL", "SINGULAR_TOL", "NearestRotation", "RotationForms", "rotation_forms",
           "rotation_from_form", "rotation_from_matrix"]

#: The forms a rotation is written in, and how many numbers each takes.
FORMS = {"matrix": 9, "rpy": 3, "zyx": 3, "zyz": 3, "axis-angle": 4, "quaternion": 4}
#: A rotation within this of a singular set (|cos pitch|, |sin theta|, the angle's distance from 0 or pi, rad)
#: counts as on it, and the form's convention there is used.
SINGULAR_TOL = 1e-9
#: A matrix at most this far from a rotation may be a rotation with rounded entries: the refusal says how to take it.
ROUNDING_TOL = 0.05


@dataclass(frozen=True)
class RotationForms:
    """All forms of one rotation (radians), and a note for each form that is not unique here.

    Attributes
    ----------
    matrix : ndarray, shape (3, 3)
    rpy : ndarray, shape (3,)
        ``(roll, pitch, yaw)``, ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
    zyx : ndarray, shape (3,)
        ``(yaw, pitch, roll)``, ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
    zyz : ndarray, shape (3,)
        ``(phi, theta, psi)``, ``R = Rz(phi) Ry(theta) Rz(psi)``, theta in [0, pi].
    axis : ndarray, shape (3,)
    angle : float
        In [0, pi].
    quaternion : ndarray, shape (4,)
        ``(x, y, z, w)``, ``w >= 0``.
    notes : dict of str to str
        For each form (``"rpy"``, ``"zyx"``, ``"zyz"``, ``"axis-angle"``,
        ``"quaternion"``) whose values are not unique for this rotation, what
        is and is not defined and the choice made.
    """

    matrix: np.ndarray
    rpy: np.ndarray
    zyx: np.ndarray
    zyz: np.ndarray
    axis: np.ndarray
    angle: float
    quaternion: np.ndarray
    notes: dict


@dataclass(frozen=True)
class NearestRotation:
    """A matrix read as a rotation: the rotation taken, the matrix given and how far apart they are.

    Attributes
    ----------
    matrix : ndarray, shape (3, 3)
        The rotation: the given matrix itself when it is one (to
        :data:`~manipkit.spatial.transforms.EXACT_ROTATION_TOL`), else its
        nearest rotation in the Frobenius norm (SVD;
        :func:`~manipkit.spatial.transforms.projected_rotation`).
    given : ndarray, shape (3, 3)
        The matrix as given.
    distance : float
        ``||matrix - given||`` (Frobenius norm), 0 when the matrix is used as given.
    largest_change : float
        The largest change of one entry.
    projected : bool
        True when ``matrix`` is the nearest rotation, not the given matrix.
    """

    matrix: np.ndarray
    given: np.ndarray
    distance: float
    largest_change: float
    projected: bool


def rotation_from_matrix(M, *, tol: float = 1e-6, nearest: bool = False) -> NearestRotation:
    """The rotation a hand-written 3x3 matrix stands for: itself, or its nearest rotation, with how far it moved.

    Parameters
    ----------
    M : array_like, shape (3, 3)
        The matrix (row by row as written).
    tol : float, keyword-only
        Without ``nearest``, ``M`` must be a rotation within this (column
        norms, column dot products, det; :func:`~manipkit.spatial.rotations.check_rotation`).
        A matrix within it that is not exactly a rotation is replaced by its
        nearest rotation, so every form printed describes one rotation.
    nearest : bool, keyword-only
        Take the nearest rotation of any matrix with a positive determinant,
        however far (:func:`manipkit.spatial.transforms.nearest_rotation`).

    Returns
    -------
    NearestRotation

    Raises
    ------
    InvalidRotationError
        Not a rotation within ``tol`` (for rounded entries the message gives
        the tolerance that accepts them and the distance to the nearest
        rotation); with ``nearest``, a determinant <= 0 (a reflection has no
        nearest rotation worth the name).

    Examples
    --------
    >>> M = [[0.707, -0.707, 0], [0.707, 0.707, 0], [0, 0, 1]]  # Rz(45 deg), three decimals
    >>> taken = rotation_from_matrix(M, nearest=True)
    >>> taken.projected, round(taken.largest_change, 6), bool(np.allclose(taken.matrix[0, 0], np.sqrt(0.5)))
    (True, 0.000107, True)
    """
    given = np.asarray(M, dtype=float)
    if given.shape != (3, 3):
        raise InvalidRotationError(f"a rotation matrix is 3x3, got shape {given.shape}")
    if not np.all(np.isfinite(given)):
        raise InvalidRotationError(f"the matrix has entries that are not finite: {given.tolist()}")
    if nearest:
        det = float(np.linalg.det(given))
        if not det > 0.0:
            raise InvalidRotationError(f"det = {short_text(det, 4)}: the nearest rotation needs a matrix with a positive "
                                       "determinant (a negative one is a reflection; check the signs)")
    else:
        problems = rotation_violations(given, tol=tol)
        if problems:
            raise InvalidRotationError(f"R is not a rotation matrix within tol {short_text(tol)}: {'; '.join(problems)}"
                                       f"{_rounding_hint(given)}")
    R = projected_rotation(given)
    if R is given:
        return NearestRotation(given, given, 0.0, 0.0, False)
    return NearestRotation(R, given, float(np.linalg.norm(R - given)), float(np.abs(R - given).max()), True)


def _rounding_hint(M: np.ndarray) -> str:
    """For a matrix near a rotation (rounded entries): the tolerance that accepts it and the distance to the nearest one."""
    if float(np.linalg.det(M)) <= 0.0:
        return ""
    gram = M.T @ M
    off = max(float(np.abs(np.sqrt(np.diag(gram)) - 1.0).max()), float(np.abs(gram - np.diag(np.diag(gram))).max()),
              abs(float(np.linalg.det(M)) - 1.0))
    if off > ROUNDING_TOL:
        return ""
    power = 10.0 ** math.floor(math.log10(off))
    accepts = next(m * power for m in (1.0, 2.0, 5.0, 10.0) if m * power >= off)  # 1, 2 or 5 times a power of ten
    distance = float(np.linalg.norm(nearest_rotation(M) - M))
    return (f"; if its entries are rounded, --tol {short_text(accepts)} accepts it, and --nearest uses the nearest "
            f"rotation (SVD, {short_text(distance, 2)} away)")


def rotation_from_form(form: str, values, *, tol: float = 1e-6, nearest: bool = False) -> np.ndarray:
    """The rotation matrix of ``values`` written in ``form`` (radians).

    Parameters
    ----------
    form : {"matrix", "rpy", "zyx", "zyz", "axis-angle", "quaternion"}
    values : array_like
        9 numbers (the matrix row by row) or a 3x3 array; 3 angles; axis (3) and angle;
        quaternion ``(x, y, z, w)`` (normalised first).
    tol, nearest : keyword-only
        For a matrix, as :func:`rotation_from_matrix` (a matrix within ``tol``
        of a rotation, or any with ``nearest``, gives its nearest rotation).

    Returns
    -------
    R : ndarray, shape (3, 3)

    Raises
    ------
    InvalidRotationError
        An unknown form, the wrong count of numbers, a matrix that is not a
        rotation, a zero axis or quaternion.

    Examples
    --------
    >>> rotation_from_form("axis-angle", [0, 0, 1, np.pi / 2]).round(12) + 0.0
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]])
    """
    if form not in FORMS:
        raise InvalidRotationError(f"rotation form '{form}': choose one of {', '.join(FORMS)}")
    array = np.asarray(values, dtype=float)
    if form == "matrix" and array.shape == (3, 3):
        array = array.reshape(9)
    if array.shape != (FORMS[form],):
        raise InvalidRotationError(f"{form} takes {FORMS[form]} numbers, got {array.size}")
    if not np.all(np.isfinite(array)):
        raise InvalidRotationError(f"{form}: the numbers must be finite, got {array.tolist()}")
    if form == "matrix":
        return rotation_from_matrix(array.reshape(3, 3), tol=tol, nearest=nearest).matrix
    if form == "rpy":
        return matrix_from_rpy(array)
    if form == "zyx":
        return matrix_from_euler_zyx(array)
    if form == "zyz":
        return matrix_from_euler_zyz(array)
    if form == "axis-angle":
        norm = float(np.linalg.norm(array[:3]))
        if norm == 0.0:
            raise InvalidRotationError("axis-angle: the axis is (0, 0, 0); give a non-zero axis (it is normalised)")
        return matrix_from_axis_angle(array[:3] / norm, array[3])
    return matrix_from_quaternion(array)


def rotation_forms(R, *, singular_tol: float = SINGULAR_TOL, tol: float = 1e-6) -> RotationForms:
    """Every form of the rotation ``R``, with a note where a form is not unique.

    Parameters
    ----------
    R : array_like, shape (3, 3)
        A rotation matrix (checked within ``tol``).
    singular_tol : float, keyword-only
        How close to a singular set counts as on it (``SINGULAR_TOL``, 1e-9):
        ``|cos(pitch)|`` for rpy and ZYX, ``|sin(theta)|`` for ZYZ, the angle's
        distance (rad) from 0 or 180 deg for axis-angle. On it, the form's
        convention (module docstring) fixes the free angle, so a matrix with
        rounding noise gives clean angles.

    Returns
    -------
    RotationForms

    Examples
    --------
    >>> from manipkit.spatial.rotations import rot_y
    >>> forms = rotation_forms(rot_y(np.pi / 2))
    >>> forms.rpy.round(12) + 0.0, forms.notes["rpy"]
    (array([0.        , 1.57079633, 0.        ]), 'gimbal lock (pitch = +90 deg): only yaw - roll is defined; roll set to 0')
    """
    R = check_rotation(R, tol=tol)
    rpy = rpy_from_matrix(R, gimbal_tol=singular_tol, check=False)
    zyz = euler_zyz_from_matrix(R, gimbal_tol=singular_tol, check=False)
    axis, angle = axis_angle_from_matrix(R, check=False)
    angle = float(angle)
    quaternion = quaternion_from_matrix(R, check=False)
    notes = {}
    if math.hypot(R[2, 1], R[2, 2]) <= singular_tol:
        up = rpy[1] > 0
        notes["rpy"] = (f"gimbal lock (pitch = {'+' if up else '-'}90 deg): only yaw {'-' if up else '+'} roll "
                        "is defined; roll set to 0")
        notes["zyx"] = notes["rpy"]
    if math.hypot(R[2, 0], R[2, 1]) <= singular_tol:
        at_zero = R[2, 2] > 0
        notes["zyz"] = (f"theta = {'0' if at_zero else '180'} deg: only phi {'+' if at_zero else '-'} psi is "
                        "defined; psi set to 0")
    if angle <= singular_tol:
        angle = 0.0
        axis = np.array([0.0, 0.0, 1.0])
        notes["axis-angle"] = "angle 0: every axis is valid; (0, 0, 1) given"
    elif math.pi - angle <= singular_tol:
        axis = axis * _first_sign(axis, singular_tol)
        notes["axis-angle"] = "angle 180 deg: axis and -axis are the same rotation; the first non-zero component made positive"
    if abs(quaternion[3]) <= singular_tol:
        quaternion = quaternion * _first_sign(quaternion[:3], singular_tol)
        quaternion[3] = 0.0  # rounding noise of cos(90 deg), whose sign would otherwise pick q or -q
        notes["quaternion"] = "w = 0 (180 deg): q and -q are the same rotation; the first non-zero of x, y, z made positive"
    return RotationForms(R, rpy, rpy[::-1].copy(), zyz, np.asarray(axis, dtype=float), angle, quaternion, notes)


def _first_sign(vector: np.ndarray, tol: float) -> float:
    """+1 or -1: the sign that makes the first component larger than ``tol`` in size positive."""
    for value in vector:
        if abs(value) > tol:
            return 1.0 if value > 0 else -1.0
    return 1.0
