"""Rotation matrices and their parametrisations, robust at the singularities.

Conventions (docs/architecture.md), restated where they matter:

- Angles are in radians.
- A rotation matrix ``R`` (..., 3, 3) maps coordinates in the rotated frame
  to coordinates in the reference frame; its columns are the rotated axes.
- Roll-pitch-yaw ``rpy`` (..., 3) is ``(roll, pitch, yaw)`` with
  ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``, as in a URDF ``rpy`` attribute; this
  equals Euler ZYX with angles ``(yaw, pitch, roll)``.
- Quaternions ``q`` (..., 4) are stored in ``(x, y, z, w)`` order, as ROS does.
- Axis-angle is a unit axis (..., 3) and an angle (...) in ``[0, pi]``.

Every function works on stacks: leading dimensions are carried through, so
``matrix_from_rpy(np.zeros((5, 2, 3)))`` has shape ``(5, 2, 3, 3)``. Inverse
conversions never divide by a quantity that can vanish on a singular set
(``atan2`` everywhere, Shepperd's branch choice for quaternions), so they stay
accurate at pitch = +-90 deg and at 0 and 180 deg rotations.

Euler ZYX and ZYZ angles are in :mod:`manipkit.spatial.euler`. Only numpy is
imported, so this module loads fast.
"""

from __future__ import annotations

import numpy as np

from manipkit.errors import InvalidRotationError
from manipkit.text import near_text, repr_text

__all__ = [
    "as_float_array", "as_rotation_matrices", "axis_angle_from_matrix", "check_rotation", "matrix_from_axis_angle",
    "matrix_from_quaternion", "matrix_from_rpy", "quaternion_from_matrix", "rot_x", "rot_y", "rot_z",
    "rotation_angle_between", "rotation_violations", "rpy_from_matrix", "vectors_or_parts", "wrap_angle",
]

AXIS_NAMES = ("x", "y", "z")


# --------------------------------------------------------------------------
# input handling


def as_float_array(value, what: str, *, finite: bool = True) -> np.ndarray:
    """``value`` as a float array, or :class:`InvalidRotationError` in one line naming ``what``
    (ragged, not numbers, too large for a float; with ``finite`` (default), NaN or infinite: for angles,
    axes and vectors a rotation is built from; matrices checked later say what is wrong themselves)."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise InvalidRotationError(f"{what} must be finite numbers, got {repr_text(value, 80)}") from None
    if finite and not np.isfinite(array).all():
        bad = np.argwhere(~np.isfinite(array))[0]
        where = f"{what}[{', '.join(str(int(i)) for i in bad)}]" if array.ndim else what
        raise InvalidRotationError(f"{where} is {array[tuple(bad)]}; give finite numbers")
    return array


def _as_vectors(value, length: int, what: str) -> np.ndarray:
    array = as_float_array(value, what)
    if array.ndim == 0 or array.shape[-1] != length:
        raise InvalidRotationError(f"{what} must have shape (..., {length}), got {array.shape}")
    return array


def vectors_or_parts(first, rest: dict, what: str) -> np.ndarray:
    """One (..., k) array from either form a rotation helper takes: the array itself (``rest`` all None),
    or its k parts as separate arguments (broadcast against each other and stacked)."""
    given = [name for name, value in rest.items() if value is not None]
    if not given:
        return _as_vectors(first, len(rest) + 1, what)
    if len(given) != len(rest):
        missing = [name for name, value in rest.items() if value is None]
        raise InvalidRotationError(
            f"{what}: give one array of {len(rest) + 1} values or all {len(rest) + 1} values as arguments; "
            f"{', '.join(missing)} missing"
        )
    parts = [as_float_array(v, what) for v in (first, *rest.values())]
    try:
        parts = np.broadcast_arrays(*parts)
    except ValueError:
        raise InvalidRotationError(f"{what}: the parts have shapes {[p.shape for p in parts]}, which do not broadcast") from None
    return np.stack(parts, axis=-1)


def as_rotation_matrices(value, what: str = "R") -> np.ndarray:
    """``value`` as a float array of shape (..., 3, 3) (not checked for orthonormality), else a one-line error."""
    array = as_float_array(value, what, finite=False)
    if array.ndim < 2 or array.shape[-2:] != (3, 3):
        raise InvalidRotationError(f"{what} must have shape (..., 3, 3), got {array.shape}")
    return array


def _unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors and norms over the last axis, scaled first so tiny vectors keep their direction.

    Rows that are zero or not finite give norm 0, inf or nan and a unit row of nan.
    """
    scale = np.max(np.abs(v), axis=-1)
    regular = (scale > 0.0) & np.isfinite(scale)
    safe = np.where(regular, scale, 1.0)[..., None]
    scaled_norm = np.linalg.norm(v / safe, axis=-1, keepdims=True)
    unit = np.where(regular[..., None], v / safe / np.where(regular[..., None], scaled_norm, 1.0), np.nan)
    return unit, np.where(regular, safe[..., 0] * scaled_norm[..., 0], scale)


def _scalar_or_array(array: np.ndarray):
    """A 0-d result as a numpy float, anything else unchanged."""
    return array[()] if array.ndim == 0 else array


def wrap_angle(angle):
    """Angles mapped to (-pi, pi], exactly at the edges.

    ``pi - mod(pi - a, 2 pi)`` can round to ``-pi`` for ``a`` a few ulps above
    ``pi`` (``mod`` of a tiny negative number returns ``2 pi``); such results
    are moved to ``+pi``. Angles already inside are returned unchanged.

    Parameters
    ----------
    angle : array_like, shape (...)
        Radians.

    Returns
    -------
    ndarray, shape (...), in (-pi, pi]

    Examples
    --------
    >>> wrap_angle([-np.pi, 3 * np.pi / 2, np.nextafter(np.pi, 4)])
    array([ 3.14159265, -1.57079633,  3.14159265])
    """
    angle = np.asarray(angle, dtype=float)
    inside = (angle > -np.pi) & (angle <= np.pi)
    wrapped = np.pi - np.mod(np.pi - angle, 2.0 * np.pi)
    wrapped = np.where(wrapped <= -np.pi, wrapped + 2.0 * np.pi, wrapped)
    return np.where(inside, angle, wrapped) + 0.0


# --------------------------------------------------------------------------
# elementary rotations


def _elementary(angle, axis: int) -> np.ndarray:
    angle = as_float_array(angle, "angle")
    c, s = np.cos(angle), np.sin(angle)
    R = np.zeros(angle.shape + (3, 3))
    i, j = (axis + 1) % 3, (axis + 2) % 3  # cyclic, so R[i, j] = -sin for x, y and z
    R[..., axis, axis] = 1.0
    R[..., i, i] = c
    R[..., j, j] = c
    R[..., i, j] = -s
    R[..., j, i] = s
    return R


def rot_x(angle) -> np.ndarray:
    """Rotation about the x axis by ``angle``.

    Parameters
    ----------
    angle : array_like, shape (...)
        Radians, positive counter-clockwise looking down the +x axis.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
        ``[[1, 0, 0], [0, c, -s], [0, s, c]]``.

    Examples
    --------
    >>> rot_x(np.pi / 2) @ [0.0, 1.0, 0.0]  # y goes to z
    array([0.000000e+00, 6.123234e-17, 1.000000e+00])
    """
    return _elementary(angle, 0)


def rot_y(angle) -> np.ndarray:
    """Rotation about the y axis by ``angle``.

    Parameters
    ----------
    angle : array_like, shape (...)
        Radians, positive counter-clockwise looking down the +y axis.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
        ``[[c, 0, s], [0, 1, 0], [-s, 0, c]]``.

    Examples
    --------
    >>> rot_y(np.pi / 2) @ [0.0, 0.0, 1.0]  # z goes to x
    array([1.000000e+00, 0.000000e+00, 6.123234e-17])
    """
    return _elementary(angle, 1)


def rot_z(angle) -> np.ndarray:
    """Rotation about the z axis by ``angle``.

    Parameters
    ----------
    angle : array_like, shape (...)
        Radians, positive counter-clockwise looking down the +z axis.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
        ``[[c, -s, 0], [s, c, 0], [0, 0, 1]]``.

    Examples
    --------
    >>> rot_z(np.pi / 2) @ [1.0, 0.0, 0.0]  # x goes to y
    array([6.123234e-17, 1.000000e+00, 0.000000e+00])
    """
    return _elementary(angle, 2)


# --------------------------------------------------------------------------
# roll-pitch-yaw


def matrix_from_rpy(rpy, pitch=None, yaw=None) -> np.ndarray:
    """Rotation matrix from roll-pitch-yaw angles: ``matrix_from_rpy([r, p, y])`` or ``matrix_from_rpy(r, p, y)``.

    Parameters
    ----------
    rpy : array_like, shape (..., 3)
        ``(roll, pitch, yaw)`` in radians, ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``
        as in URDF (equal to Euler ZYX with angles ``(yaw, pitch, roll)``):
        roll about the fixed x axis first, then pitch about fixed y, then
        yaw about fixed z. Or the roll alone, when ``pitch`` and ``yaw`` are given.
    pitch, yaw : array_like, optional
        The other two angles as separate arguments (broadcast together).

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Examples
    --------
    >>> matrix_from_rpy([np.pi / 2, 0.0, np.pi / 2]).round(12) + 0.0
    array([[0., 0., 1.],
           [1., 0., 0.],
           [0., 1., 0.]])
    >>> bool(np.array_equal(matrix_from_rpy(0.1, 0.2, 0.3), matrix_from_rpy([0.1, 0.2, 0.3])))
    True
    """
    rpy = vectors_or_parts(rpy, {"pitch": pitch, "yaw": yaw}, "rpy")
    cr, cp, cy = np.cos(rpy[..., 0]), np.cos(rpy[..., 1]), np.cos(rpy[..., 2])
    sr, sp, sy = np.sin(rpy[..., 0]), np.sin(rpy[..., 1]), np.sin(rpy[..., 2])
    R = np.empty(rpy.shape[:-1] + (3, 3))
    R[..., 0, 0] = cy * cp
    R[..., 0, 1] = cy * sp * sr - sy * cr
    R[..., 0, 2] = cy * sp * cr + sy * sr
    R[..., 1, 0] = sy * cp
    R[..., 1, 1] = sy * sp * sr + cy * cr
    R[..., 1, 2] = sy * sp * cr - cy * sr
    R[..., 2, 0] = -sp
    R[..., 2, 1] = cp * sr
    R[..., 2, 2] = cp * cr
    return R


def rpy_from_matrix(R, *, gimbal_tol: float = 1e-12, check: bool = True, tol: float = 1e-6) -> np.ndarray:
    """Roll-pitch-yaw angles of a rotation matrix.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrix.
    gimbal_tol : float, keyword-only
        Where ``cos(pitch) <= gimbal_tol`` (pitch within about ``gimbal_tol``
        radians of +-90 deg) the rotation is treated as gimbal-locked, see
        Notes. The returned angles then reproduce ``R`` to about
        ``2 * gimbal_tol``; elsewhere to rounding error.
    check : bool, keyword-only
        Validate ``R`` with :func:`check_rotation` first (default).
    tol : float, keyword-only
        Tolerance of that check.

    Returns
    -------
    rpy : ndarray, shape (..., 3)
        ``(roll, pitch, yaw)`` in radians with ``R = Rz(yaw) Ry(pitch) Rx(roll)``
        (URDF; Euler ZYX ``(yaw, pitch, roll)``); roll and yaw in (-pi, pi],
        pitch in [-pi/2, pi/2].

    Notes
    -----
    At pitch = +-90 deg (gimbal lock) only ``yaw - roll`` (pitch = +90 deg)
    or ``yaw + roll`` (pitch = -90 deg) is determined. This function then
    returns ``roll = 0`` and puts the whole rotation about z in ``yaw``.

    Roll is ``atan2(R[2, 1], R[2, 2])``, pitch is
    ``atan2(-R[2, 0], hypot(R[2, 1], R[2, 2]))`` and yaw is read from
    ``R @ Rx(roll).T = Rz(yaw) Ry(pitch)``, whose second column is
    ``(-sin yaw, cos yaw, 0)`` for every pitch, so no angle is divided by
    ``cos(pitch)`` and the angles reproduce ``R`` even next to the lock.

    Examples
    --------
    >>> rpy_from_matrix(rot_z(0.3) @ rot_y(0.2) @ rot_x(0.1)).round(12)
    array([0.1, 0.2, 0.3])
    >>> rpy_from_matrix(rot_y(np.pi / 2) @ rot_x(0.4)).round(12) + 0.0  # locked
    array([ 0.        ,  1.57079633, -0.4       ])
    """
    R = check_rotation(R, tol=tol) if check else as_rotation_matrices(R)
    cos_pitch = np.hypot(R[..., 2, 1], R[..., 2, 2])
    locked = cos_pitch <= gimbal_tol
    roll = np.where(locked, 0.0, np.arctan2(R[..., 2, 1], R[..., 2, 2]))
    pitch = np.arctan2(-R[..., 2, 0], cos_pitch)
    cr, sr = np.cos(roll), np.sin(roll)
    # second column of R @ Rx(roll).T is (-sin yaw, cos yaw, 0)
    yaw = np.arctan2(R[..., 0, 2] * sr - R[..., 0, 1] * cr, R[..., 1, 1] * cr - R[..., 1, 2] * sr)
    return np.stack([wrap_angle(roll), pitch, wrap_angle(yaw)], axis=-1)  # atan2's -pi is +pi here


# --------------------------------------------------------------------------
# quaternions


def matrix_from_quaternion(q, y=None, z=None, w=None) -> np.ndarray:
    """Rotation matrix of a quaternion: ``matrix_from_quaternion([x, y, z, w])`` or ``(x, y, z, w)`` as four arguments.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternion in ``(x, y, z, w)`` order (ROS). It is normalised first,
        so a rounded unit quaternion such as ``(0, 0, 0.7071, 0.7071)`` is
        accepted; ``q`` and ``-q`` give the same matrix. Or its x alone,
        when ``y``, ``z`` and ``w`` are given.
    y, z, w : array_like, optional
        The other three components as separate arguments (broadcast together).

    Returns
    -------
    R : ndarray, shape (..., 3, 3)

    Raises
    ------
    InvalidRotationError
        If a quaternion is zero or not finite.

    Examples
    --------
    >>> s = np.sin(np.pi / 4)
    >>> matrix_from_quaternion([0.0, 0.0, s, s]).round(12) + 0.0  # Rz(90 deg)
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]])
    """
    q = vectors_or_parts(q, {"y": y, "z": z, "w": w}, "quaternion")
    unit, norm = _unit(q)
    bad = ~np.isfinite(norm) | (norm == 0.0)
    if np.any(bad):
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        where = f"quaternion[{', '.join(map(str, index))}]" if index else "quaternion"
        raise InvalidRotationError(
            f"{where} = {q[index]} (x, y, z, w) is zero or not finite; a rotation needs a non-zero finite quaternion"
        )
    x, y, z, w = np.moveaxis(unit, -1, 0)
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1.0 - 2.0 * (y * y + z * z)
    R[..., 0, 1] = 2.0 * (x * y - z * w)
    R[..., 0, 2] = 2.0 * (x * z + y * w)
    R[..., 1, 0] = 2.0 * (x * y + z * w)
    R[..., 1, 1] = 1.0 - 2.0 * (x * x + z * z)
    R[..., 1, 2] = 2.0 * (y * z - x * w)
    R[..., 2, 0] = 2.0 * (x * z - y * w)
    R[..., 2, 1] = 2.0 * (y * z + x * w)
    R[..., 2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return R


def quaternion_from_matrix(R, *, check: bool = True, tol: float = 1e-6) -> np.ndarray:
    """Unit quaternion of a rotation matrix, in ``(x, y, z, w)`` order.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrix.
    check : bool, keyword-only
        Validate ``R`` with :func:`check_rotation` first (default).
    tol : float, keyword-only
        Tolerance of that check.

    Returns
    -------
    q : ndarray, shape (..., 4)
        Unit quaternion ``(x, y, z, w)`` (ROS order) with ``w >= 0``: of the
        two quaternions ``q`` and ``-q`` of a rotation, the one with
        non-negative ``w`` is returned, so the rotation angle
        ``2 * atan2(|(x, y, z)|, w)`` is in [0, pi]. For a 180 deg rotation
        (``w == 0``) the sign makes the first non-zero of ``x, y, z``
        positive.

    Notes
    -----
    Shepperd's method: the entries of ``R`` give the ten products
    ``4 q_i q_j`` linearly (for example ``4 w x = R[2, 1] - R[1, 2]`` and
    ``4 x x = 1 + R[0, 0] - R[1, 1] - R[2, 2]``). The row ``4 q_k q`` with
    the largest diagonal ``4 q_k**2 >= 1`` is normalised, so nothing small
    is divided by and the result is accurate near 180 deg as well as near 0.

    Examples
    --------
    >>> quaternion_from_matrix(rot_z(np.pi / 2)).round(6)  # (0, 0, sin 45, cos 45)
    array([0.      , 0.      , 0.707107, 0.707107])
    """
    R = check_rotation(R, tol=tol) if check else as_rotation_matrices(R)
    r = {(i, j): R[..., i, j] for i in range(3) for j in range(3)}
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    # K[a, b] = 4 q_a q_b with index order (x, y, z, w)
    xx = 1.0 + 2.0 * r[0, 0] - trace
    yy = 1.0 + 2.0 * r[1, 1] - trace
    zz = 1.0 + 2.0 * r[2, 2] - trace
    ww = 1.0 + trace
    xy, xz, yz = r[1, 0] + r[0, 1], r[0, 2] + r[2, 0], r[2, 1] + r[1, 2]
    xw, yw, zw = r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]
    K = np.stack(
        [
            np.stack([xx, xy, xz, xw], axis=-1),
            np.stack([xy, yy, yz, yw], axis=-1),
            np.stack([xz, yz, zz, zw], axis=-1),
            np.stack([xw, yw, zw, ww], axis=-1),
        ],
        axis=-2,
    )
    best = np.argmax(np.stack([xx, yy, zz, ww], axis=-1), axis=-1)
    row = np.take_along_axis(K, best[..., None, None], axis=-2)[..., 0, :]
    q = row / np.linalg.norm(row, axis=-1, keepdims=True)
    return _canonical_sign(q)


def _canonical_sign(q: np.ndarray) -> np.ndarray:
    """Flip q where w < 0, or where w == 0 and the first non-zero of x, y, z is negative."""
    vector = q[..., :3]
    first = np.take_along_axis(vector, np.argmax(vector != 0.0, axis=-1)[..., None], axis=-1)[..., 0]
    flip = (q[..., 3] < 0.0) | ((q[..., 3] == 0.0) & (first < 0.0))
    return np.where(flip[..., None], -q, q) + 0.0  # + 0.0 turns -0.0 into 0.0


# --------------------------------------------------------------------------
# axis-angle


def matrix_from_axis_angle(axis, angle) -> np.ndarray:
    """Rotation by ``angle`` about ``axis`` (Rodrigues' formula).

    Parameters
    ----------
    axis : array_like, shape (..., 3)
        Rotation axis; normalised first, must be non-zero.
    angle : array_like, shape (...)
        Radians, right-hand rule about ``axis``; any value is accepted.
        ``axis`` and ``angle`` broadcast against each other.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
        ``cos(angle) I + sin(angle) [a]x + (1 - cos(angle)) a a^T``, with
        ``1 - cos`` computed as ``2 sin(angle / 2)**2`` for small angles.

    Raises
    ------
    InvalidRotationError
        If an axis is zero or not finite.

    Examples
    --------
    >>> matrix_from_axis_angle([0.0, 0.0, 2.0], np.pi / 2).round(12) + 0.0
    array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]])
    """
    axis = _as_vectors(axis, 3, "axis")
    angle = as_float_array(angle, "angle")
    a, norm = _unit(axis)
    bad = ~np.isfinite(norm) | (norm == 0.0)
    if np.any(bad):
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        where = f"axis[{', '.join(map(str, index))}]" if index else "axis"
        raise InvalidRotationError(f"{where} = {axis[index]} is zero or not finite; an axis needs a direction")
    shape = np.broadcast_shapes(a.shape[:-1], angle.shape)
    a = np.broadcast_to(a, shape + (3,))
    angle = np.broadcast_to(angle, shape)
    c, s = np.cos(angle), np.sin(angle)
    one_minus_c = 2.0 * np.sin(angle / 2.0) ** 2
    x, y, z = a[..., 0], a[..., 1], a[..., 2]
    R = one_minus_c[..., None, None] * (a[..., :, None] * a[..., None, :])
    R[..., 0, 0] += c
    R[..., 1, 1] += c
    R[..., 2, 2] += c
    R[..., 0, 1] -= s * z
    R[..., 1, 0] += s * z
    R[..., 0, 2] += s * y
    R[..., 2, 0] -= s * y
    R[..., 1, 2] -= s * x
    R[..., 2, 1] += s * x
    return R


def axis_angle_from_matrix(R, *, check: bool = True, tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Unit axis and angle of a rotation matrix.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrix.
    check : bool, keyword-only
        Validate ``R`` with :func:`check_rotation` first (default).
    tol : float, keyword-only
        Tolerance of that check.

    Returns
    -------
    axis : ndarray, shape (..., 3)
        Unit axis. For the identity (angle 0) every axis is valid and
        ``(0, 0, 1)`` is returned. For a 180 deg rotation ``axis`` and
        ``-axis`` are equivalent; the first non-zero component is made
        positive.
    angle : ndarray or float, shape (...)
        Radians in [0, pi], right-hand rule about ``axis``.

    Notes
    -----
    Read from the quaternion (:func:`quaternion_from_matrix`,
    ``w >= 0``): ``angle = 2 atan2(|(x, y, z)|, w)`` and ``axis = (x, y, z)``
    normalised. The vector part is large exactly where ``sin(angle)`` is
    small near 180 deg, so no ``sin(pi)`` is divided by and the axis is
    accurate there.

    Examples
    --------
    >>> axis, angle = axis_angle_from_matrix(rot_x(np.pi))
    >>> axis, float(angle)
    (array([1., 0., 0.]), 3.141592653589793)
    """
    q = quaternion_from_matrix(R, check=check, tol=tol)
    vector = q[..., :3]
    unit, sin_half = _unit(vector)
    angle = 2.0 * np.arctan2(sin_half, q[..., 3])
    axis = np.where((sin_half == 0.0)[..., None], [0.0, 0.0, 1.0], unit)
    return axis, _scalar_or_array(angle)


# --------------------------------------------------------------------------
# distances


def rotation_angle_between(R_a, R_b, *, check: bool = True, tol: float = 1e-6):
    """Geodesic angle between two rotations: the angle of ``R_a.T @ R_b``.

    Parameters
    ----------
    R_a, R_b : array_like, shape (..., 3, 3)
        Rotation matrices; leading dimensions broadcast.
    check : bool, keyword-only
        Validate both with :func:`check_rotation` first (default).
    tol : float, keyword-only
        Tolerance of that check.

    Returns
    -------
    angle : ndarray or float, shape (...)
        Radians in [0, pi]; symmetric in ``R_a`` and ``R_b``.

    Notes
    -----
    ``atan2(|v|, (trace - 1) / 2)`` with ``v`` the axial vector of the
    skew part, ``|v| = sin(angle)``. Unlike ``acos((trace - 1) / 2)``, which
    loses half the digits near 0 (an angle of 1e-9 reads as 0), this is
    accurate to rounding error over the whole range.

    Examples
    --------
    >>> float(rotation_angle_between(np.eye(3), rot_x(1e-9)))  # acos gives 0.0
    1e-09
    """
    if check:
        R_a, R_b = check_rotation(R_a, tol=tol, what="R_a"), check_rotation(R_b, tol=tol, what="R_b")
    else:
        R_a, R_b = as_rotation_matrices(R_a, "R_a"), as_rotation_matrices(R_b, "R_b")
    M = np.swapaxes(R_a, -1, -2) @ R_b
    skew = np.stack([M[..., 2, 1] - M[..., 1, 2], M[..., 0, 2] - M[..., 2, 0], M[..., 1, 0] - M[..., 0, 1]], axis=-1)
    sin_angle = 0.5 * np.linalg.norm(skew, axis=-1)
    cos_angle = 0.5 * (M[..., 0, 0] + M[..., 1, 1] + M[..., 2, 2] - 1.0)
    return _scalar_or_array(np.arctan2(sin_angle, cos_angle))


# --------------------------------------------------------------------------
# validation


def rotation_violations(R, *, tol: float = 1e-6) -> list[str]:
    """Each way a single 3x3 matrix fails to be a rotation, with its numbers.

    Parameters
    ----------
    R : array_like, shape (3, 3)
        Candidate rotation matrix; indices in messages are 0-based, as in
        numpy (column 0 is the rotated x axis).
    tol : float, keyword-only
        Allowed deviation of column norms from 1, of column dot products from
        0 and of the determinant from +1.

    Returns
    -------
    list of str
        Empty when ``R`` is a rotation within ``tol``. Otherwise one line per
        problem: a wrong shape, a non-finite entry, a column norm, a pair of
        non-orthogonal columns, the determinant (-1 suggests a reflection).

    Examples
    --------
    >>> rotation_violations(np.diag([1.0, 1.0, -1.0]))
    ['det(R) = -1, expected +1 (is this a reflection?)']
    """
    try:
        R = np.asarray(R, dtype=float)
    except (TypeError, ValueError):
        return [f"entries are not all numbers: {R!r:.80}"]
    if R.shape != (3, 3):
        return [f"shape is {R.shape}, expected (3, 3)"]
    problems = [
        f"entry [{i}, {j}] is not finite ({R[i, j]})" for i, j in zip(*np.nonzero(~np.isfinite(R)))
    ]
    if problems:
        return problems
    norms = np.linalg.norm(R, axis=0)
    for j in range(3):
        if abs(norms[j] - 1.0) > tol:
            problems.append(f"column {j} ({AXIS_NAMES[j]} axis) has norm {near_text(norms[j], 1.0)}, expected 1")
    for i, j in ((0, 1), (0, 2), (1, 2)):
        dot = float(R[:, i] @ R[:, j])
        if abs(dot) > tol:
            problems.append(f"columns {i} and {j} are not orthogonal (dot {near_text(dot, 0.0)})")
    det = float(np.linalg.det(R))
    if abs(det - 1.0) > tol:
        if det < 0.0:
            hint = " (is this a reflection?)"
        elif abs(det) <= tol:
            hint = " (the matrix is singular)"
        else:
            hint = ""
        problems.append(f"det(R) = {near_text(det, 1.0)}, expected +1{hint}")
    return problems


def check_rotation(R, *, tol: float = 1e-6, what: str = "R") -> np.ndarray:
    """Raise unless ``R`` is a rotation matrix (or a stack of them) within ``tol``.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Candidate rotation matrices.
    tol : float, keyword-only
        Allowed deviation of column norms from 1, of column dot products from
        0 and of ``det(R)`` from +1.
    what : str, keyword-only
        How to name ``R`` in the message.

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
        The input as a float array, for ``R = check_rotation(R)``.

    Raises
    ------
    InvalidRotationError
        One line naming the problem with its numbers: a wrong shape,
        non-finite entries, column norms, non-orthogonal columns, or
        ``det(R) = -1`` ("is this a reflection?"). For a stack, the first
        failing index is named and the count of others given.

    Examples
    --------
    >>> check_rotation(np.diag([1.0, -1.0, 1.0]))
    Traceback (most recent call last):
    ...
    manipkit.errors.InvalidRotationError: R is not a rotation matrix: det(R) = -1, expected +1 (is this a reflection?)
    """
    R = as_rotation_matrices(R, what)
    with np.errstate(invalid="ignore", over="ignore"):
        finite = np.all(np.isfinite(R), axis=(-2, -1))
        clean = np.where(finite[..., None, None], R, 0.0)
        norms = np.linalg.norm(clean, axis=-2)
        dots = (np.swapaxes(clean, -1, -2) @ clean)[..., [0, 0, 1], [1, 2, 2]]
        bad = ~finite
        bad |= np.any(np.abs(norms - 1.0) > tol, axis=-1)
        bad |= np.any(np.abs(dots) > tol, axis=-1)
        bad |= np.abs(np.linalg.det(clean) - 1.0) > tol
    if not np.any(bad):
        return R
    failing = np.argwhere(bad)
    index = tuple(int(i) for i in failing[0])
    name = f"{what}[{', '.join(map(str, index))}]" if index else what
    problems = rotation_violations(R[index], tol=tol)
    more = f" (and {len(failing) - 1} more matrices fail)" if len(failing) > 1 else ""
    raise InvalidRotationError(f"{name} is not a rotation matrix: {'; '.join(problems)}{more}")

