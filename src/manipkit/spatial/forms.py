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
    rpy_from_matrix,
)

__all__ = ["FORMS", "SINGULAR_TOL", "RotationForms", "rotation_forms", "rotation_from_form"]

#: The forms a rotation is written in, and how many numbers each takes.
FORMS = {"matrix": 9, "rpy": 3, "zyx": 3, "zyz": 3, "axis-angle": 4, "quaternion": 4}
#: A rotation within this of a singular set (|cos pitch|, |sin theta|, the angle's distance from 0 or pi, rad)
#: counts as on it, and the form's convention there is used.
SINGULAR_TOL = 1e-9


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


def rotation_from_form(form: str, values, *, tol: float = 1e-6) -> np.ndarray:
    """The rotation matrix of ``values`` written in ``form`` (radians).

    Parameters
    ----------
    form : {"matrix", "rpy", "zyx", "zyz", "axis-angle", "quaternion"}
    values : array_like
        9 numbers (the matrix row by row) or a 3x3 array; 3 angles; axis (3) and angle;
        quaternion ``(x, y, z, w)`` (normalised first).
    tol : float, keyword-only
        A given matrix must be a rotation within this (:func:`~manipkit.spatial.rotations.check_rotation`).

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
        return check_rotation(array.reshape(3, 3), tol=tol)
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
