"""SE(3): homogeneous transforms, built, inverted, checked and compared, in one place.

Conventions (docs/architecture.md): ``T_a_b`` is the pose of frame b expressed
in frame a, a 4x4 matrix ``[[R, t], [0, 0, 0, 1]]`` with ``t`` in metres;
``T_a_c = T_a_b @ T_b_c``. ``rpy`` is ``(roll, pitch, yaw)`` in radians with
``R = Rz(yaw) Ry(pitch) Rx(roll)``, as in a URDF ``<origin>``; quaternions are
``(x, y, z, w)``.

Every part of manipkit that takes a transform from a user validates it with
:func:`check_transform` (one error class, :class:`InvalidTransformError`) and
measures how far a reached pose is from a wanted one with :func:`pose_error`;
every IK solver measures its answers with :func:`pose_residuals` (the same
measure, by IK mode).
"""

from __future__ import annotations

import math

import numpy as np

from manipkit.errors import IKOptionError, InvalidTransformError
from manipkit.spatial.rotations import (
    matrix_from_quaternion,
    matrix_from_rpy,
    rotation_angle_between,
    rotation_violations,
)
from manipkit.text import near_text

__all__ = [
    "EXACT_ROTATION_TOL",
    "as_transforms",
    "check_transform",
    "invert_transform",
    "nearest_rotation",
    "pose_error",
    "pose_residuals",
    "projected_rotation",
    "RESIDUAL_MODES",
    "transform_from_xyz_quaternion",
    "transform_from_xyz_rpy",
    "transform_violations",
]


# --------------------------------------------------------------------------
# building and inverting


def transform_from_xyz_rpy(xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> np.ndarray:
    """A 4x4 homogeneous transform from a translation and roll-pitch-yaw angles.

    Parameters
    ----------
    xyz : array_like, shape (3,)
        Translation in metres.
    rpy : array_like, shape (3,)
        ``(roll, pitch, yaw)`` in radians, ``R = Rz(yaw) Ry(pitch) Rx(roll)`` as
        in a URDF ``<origin>``.

    Returns
    -------
    T : ndarray, shape (4, 4)

    Examples
    --------
    >>> transform_from_xyz_rpy([0, 0, 0.126])[:3, 3]
    array([0.   , 0.   , 0.126])
    """
    T = np.eye(4)
    T[:3, :3] = matrix_from_rpy(np.asarray(rpy, dtype=float))
    T[:3, 3] = np.asarray(xyz, dtype=float)
    return T


def transform_from_xyz_quaternion(xyz, quaternion) -> np.ndarray:
    """A 4x4 homogeneous transform from a translation (m) and a quaternion ``(x, y, z, w)``.

    The quaternion is normalised; a zero quaternion raises
    :class:`~manipkit.errors.InvalidRotationError`.

    Examples
    --------
    >>> transform_from_xyz_quaternion([1, 2, 3], [0, 0, 1, 0])[:3, :3].round(12) + 0.0
    array([[-1.,  0.,  0.],
           [ 0., -1.,  0.],
           [ 0.,  0.,  1.]])
    """
    T = np.eye(4)
    T[:3, :3] = matrix_from_quaternion(quaternion)
    T[:3, 3] = np.asarray(xyz, dtype=float)
    return T


def invert_transform(T, *, check: bool = True, tol: float = 1e-6) -> np.ndarray:
    """``T_b_a`` from ``T_a_b``: ``[[R^T, -R^T t], [0, 0, 0, 1]]``, for shape (..., 4, 4).

    Uses the rigid structure (no general matrix inverse), so ``T`` must be a
    homogeneous transform: with ``check`` (default) every one is checked
    (finite, last row ``[0 0 0 1]``, ``R^T R = I`` and ``det R = 1`` within
    ``tol``) and :class:`InvalidTransformError` names the first that is not
    (``diag(2, 2, 2, 1)`` is a scaling, whose inverse this is not).
    ``check=False`` is for transforms made by forward kinematics.

    Examples
    --------
    >>> T = transform_from_xyz_rpy([1, 0, 0], [0, 0, np.pi / 2])
    >>> np.allclose(invert_transform(T) @ T, np.eye(4))
    True
    """
    T = as_transforms(T, "T") if check else np.asarray(T, dtype=float)
    if check:
        _check_rigid(T, tol)
    R_t = np.swapaxes(T[..., :3, :3], -1, -2)
    inverse = np.zeros_like(T)
    inverse[..., :3, :3] = R_t
    inverse[..., :3, 3] = -(R_t @ T[..., :3, 3, None])[..., 0]
    inverse[..., 3, 3] = 1.0
    return inverse


def _check_rigid(T: np.ndarray, tol: float) -> None:
    """InvalidTransformError naming the first of the stack ``T`` (..., 4, 4) that is not a rigid transform."""
    with np.errstate(all="ignore"):
        R = T[..., :3, :3]
        gram = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(axis=(-1, -2), initial=0.0)
        last = np.abs(T[..., 3, :] - [0.0, 0.0, 0.0, 1.0]).max(axis=-1, initial=0.0)
        good = np.isfinite(T).all(axis=(-1, -2)) & (gram <= tol) & (last <= tol) & (np.linalg.det(R) > 0)
    if not good.all():
        index = tuple(int(i) for i in np.argwhere(~good)[0])
        where = f"T[{', '.join(map(str, index))}]" if index else "T"
        problems = transform_violations(T[index], tol=tol)
        more = f" (and {len(problems) - 1} more problems)" if len(problems) > 1 else ""
        raise InvalidTransformError(f"{where} is not a rigid transform: {problems[0]}{more}")


# --------------------------------------------------------------------------
# validity


def check_transform(T, *, tol: float = 1e-6, what: str = "T") -> np.ndarray:
    """``T`` as a float (4, 4) array, or :class:`InvalidTransformError` naming the first problem.

    The one validator of user-given transforms (IK targets, closed-form
    poses, hand matrices): numeric, shape (4, 4), finite, last row
    ``[0 0 0 1]`` and a rotation block, each within ``tol``
    (:func:`transform_violations` lists every problem).

    Examples
    --------
    >>> check_transform(np.eye(4)).shape
    (4, 4)
    >>> check_transform(np.zeros((4, 4)), what="IK target")
    Traceback (most recent call last):
    ...
    manipkit.errors.InvalidTransformError: IK target: last row is [0 0 0 0], expected [0 0 0 1] (and 4 more problems)
    """
    try:
        M = np.array(T, dtype=float)
    except (TypeError, ValueError):
        M = None
    if M is not None and M.shape == (4, 4) and _plainly_rigid(M, tol / 2):
        return M  # every test below passes with room to spare (a few microseconds instead of ~45)
    problems = transform_violations(T, tol=tol)
    if problems:
        more = f" (and {len(problems) - 1} more problem{'s' if len(problems) > 2 else ''})" if len(problems) > 1 else ""
        raise InvalidTransformError(f"{what}: {problems[0]}{more}")
    return np.array(T, dtype=float)


def transform_violations(T, *, tol: float = 1e-6) -> list[str]:
    """Each way a matrix fails to be a 4x4 homogeneous transform, with its numbers.

    Parameters
    ----------
    T : array_like, shape (4, 4)
        Candidate ``[[R, t], [0, 0, 0, 1]]`` with ``R`` a rotation and ``t``
        a translation in metres. Indices in messages are 0-based (numpy).
    tol : float, keyword-only
        Allowed deviation of the last row from ``[0 0 0 1]``, of the column
        norms of ``R`` from 1, of their dot products from 0 and of
        ``det(R)`` from +1.

    Returns
    -------
    list of str
        Empty when ``T`` is valid. Otherwise one line per problem, e.g.
        ``"last row is [1 0 0 0], expected [0 0 0 1]"``,
        ``"rotation column 0 (x axis) has norm 1.732, expected 1"``,
        ``"rotation columns 0 and 1 are not orthogonal (dot 0.35)"``,
        ``"det(R) = -1, expected +1 (is this a reflection?)"``,
        ``"entry T[1, 3] is not finite (nan)"``, or a wrong shape.

    Examples
    --------
    >>> transform_violations(np.eye(4))
    []
    >>> transform_violations([[1, 0, 0, 0.172], [1, 0, 0, 0], [1, 0, 0, 0], [1, 0, 0, 0]])[0]
    'last row is [1 0 0 0], expected [0 0 0 1]'
    """
    try:
        T = np.asarray(T, dtype=float)
    except (TypeError, ValueError):
        return [f"entries are not all numbers: {T!r:.80}"]
    if T.shape != (4, 4):
        return [f"shape is {T.shape}, expected (4, 4)"]
    finite = np.isfinite(T)
    problems = [f"entry T[{i}, {j}] is not finite ({T[i, j]})" for i, j in zip(*np.nonzero(~finite))]
    if finite[3].all() and np.max(np.abs(T[3] - [0.0, 0.0, 0.0, 1.0])) > tol:
        last_row = "[" + " ".join(near_text(v, e) for v, e in zip(T[3], (0.0, 0.0, 0.0, 1.0))) + "]"
        problems.append(f"last row is {last_row}, expected [0 0 0 1]")
    if finite[:3, :3].all():
        for problem in rotation_violations(T[:3, :3], tol=tol):
            problems.append(problem if problem.startswith("det") else f"rotation {problem}")
    return problems


def _plainly_rigid(T: np.ndarray, tol: float) -> bool:
    """Finite, last row ``[0 0 0 1]``, ``R^T R = I`` and ``det R = 1``, each within ``tol``.

    Within ``tol`` = half the tolerance of :func:`transform_violations`, this
    implies that it finds nothing (column norms, dot products, det, last row).
    """
    rows = T.tolist()
    (a, b, c, x), (d, e, f, y), (g, h, i, z), (r0, r1, r2, r3) = rows
    if not math.isfinite(x + y + z + r0 + r1 + r2 + r3) or max(abs(r0), abs(r1), abs(r2), abs(r3 - 1.0)) > tol:
        return False
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    if not abs(det - 1.0) <= tol:  # False for nan too: every entry of R is in a product of det
        return False
    gram = (a * a + d * d + g * g - 1.0, b * b + e * e + h * h - 1.0, c * c + f * f + i * i - 1.0,
            a * b + d * e + g * h, a * c + d * f + g * i, b * c + e * f + h * i)  # R^T R - I, upper triangle
    return max(map(abs, gram)) <= tol




# --------------------------------------------------------------------------
# distance between poses


def nearest_rotation(M: np.ndarray) -> np.ndarray:
    """The rotation nearest to M in the Frobenius norm (SVD, det forced to +1)."""
    U, _, Vt = np.linalg.svd(M)
    D = np.ones(M.shape[:-1])
    D[..., 2] = np.sign(np.linalg.det(U @ Vt))
    D[..., 2] = np.where(D[..., 2] == 0.0, 1.0, D[..., 2])
    return (U * D[..., None, :]) @ Vt


def as_transforms(T, what: str) -> np.ndarray:
    """``T`` as a float array of shape (..., 4, 4), or :class:`InvalidTransformError` naming ``what``.

    Only the type and shape are checked (for stacks of poses whose values are
    measured, not trusted, as in :func:`pose_error`); :func:`check_transform`
    checks one transform completely.
    """
    try:
        T = np.asarray(T, dtype=float)
    except (TypeError, ValueError):
        raise InvalidTransformError(f"{what} must be numeric, got {T!r:.80}") from None
    if T.ndim < 2 or T.shape[-2:] != (4, 4):
        raise InvalidTransformError(f"{what} must have shape (..., 4, 4), got {T.shape}")
    return T


def pose_error(T_ref, T, *, project: bool = True):
    """Distance between two poses: translation in metres, rotation in radians.

    Parameters
    ----------
    T_ref, T : array_like, shape (..., 4, 4)
        Homogeneous transforms ``[[R, t], [0, 0, 0, 1]]``, ``t`` in metres;
        leading dimensions broadcast. The last rows are ignored.
    project : bool, keyword-only
        Project a block that is not a rotation to its nearest rotation first
        (default, see below). False takes the blocks as they are (the poses
        of forward kinematics against a target already checked by
        :func:`check_transform`): faster, the same numbers for rotations.

    Returns
    -------
    position_error : float or ndarray, shape (...)
        ``|t - t_ref|`` in metres.
    rotation_error : float or ndarray, shape (...)
        Geodesic angle between the rotation blocks in radians, in [0, pi]
        (:func:`manipkit.spatial.rotations.rotation_angle_between`). A block that is
        not a rotation (orthonormal with det +1 to 1e-12) is first projected
        to its nearest rotation by SVD, so a slightly scaled, sheared or
        rounded block still gives a meaningful angle; ``nan`` if an entry is
        not finite. Use :func:`transform_violations` to learn whether a
        projection was needed.

    Examples
    --------
    >>> from manipkit.spatial.rotations import rot_z
    >>> T = np.eye(4); T[:3, :3] = rot_z(0.5); T[:3, 3] = [0.3, 0.4, 0.0]
    >>> tuple(round(float(e), 12) for e in pose_error(np.eye(4), T))
    (0.5, 0.5)
    """
    if type(T_ref) is np.ndarray and type(T) is np.ndarray and T_ref.shape == T.shape == (4, 4):
        single = _one_pose_error(T_ref, T, project)  # one pair: the same numbers in microseconds instead of ~50
        if single is not None:
            return single
    T_ref, T = as_transforms(T_ref, "T_ref"), as_transforms(T, "T")
    position = np.linalg.norm(T[..., :3, 3] - T_ref[..., :3, 3], axis=-1)
    blocks = [projected_rotation(M[..., :3, :3]) if project else M[..., :3, :3] for M in (T_ref, T)]
    finite = np.all(np.isfinite(blocks[0]), axis=(-2, -1)) & np.all(np.isfinite(blocks[1]), axis=(-2, -1))
    with np.errstate(invalid="ignore"):
        rotation = np.where(finite, rotation_angle_between(*blocks, check=False), np.nan)
    return position[()], rotation[()]


# a block closer than this to orthonormal (with det > 0) is used as is, not projected
EXACT_ROTATION_TOL = 1e-12


def projected_rotation(M: np.ndarray) -> np.ndarray:
    """Each (..., 3, 3) block that is a rotation to :data:`EXACT_ROTATION_TOL` as is, else its :func:`nearest_rotation`.

    Blocks with an entry that is not finite come back as all ``nan``.
    """
    if type(M) is np.ndarray and M.shape == (3, 3) and M.dtype == np.float64 and _exact_rotation(M.tolist()):
        return M  # one block, a rotation: the same test in plain floats, in a microsecond instead of ~20
    finite = np.all(np.isfinite(M), axis=(-2, -1))
    clean = np.where(finite[..., None, None], M, 0.0)
    deviation = np.max(np.abs(np.swapaxes(clean, -1, -2) @ clean - np.eye(3)), axis=(-2, -1))
    is_rotation = (deviation <= EXACT_ROTATION_TOL) & (np.linalg.det(clean) > 0.0)
    if np.all(is_rotation | ~finite):
        return M
    projected = nearest_rotation(clean)
    return np.where(finite[..., None, None], np.where(is_rotation[..., None, None], M, projected), np.nan)




def _one_pose_error(T_ref: np.ndarray, T: np.ndarray, project: bool = True):
    """:func:`pose_error` of one pair of float (4, 4) arrays with plain floats, or None when the vectorised path is
    needed (an entry not finite, or with ``project`` a block that is not a rotation to :data:`EXACT_ROTATION_TOL`).

    The same formulas: ``|t - t_ref|``, and ``atan2(|v|, (trace M - 1) / 2)`` of ``M = R_ref^T R`` (see
    :func:`manipkit.spatial.rotations.rotation_angle_between`); symmetric in its arguments, bit for bit.
    """
    if T_ref.dtype != np.float64 or T.dtype != np.float64:
        return None
    a, b = T_ref.tolist(), T.tolist()
    if project and not (_exact_rotation(a) and _exact_rotation(b)):  # False for a block with nan or inf too
        return None
    (a00, a01, a02, ax), (a10, a11, a12, ay), (a20, a21, a22, az), _ = a
    (b00, b01, b02, bx), (b10, b11, b12, by), (b20, b21, b22, bz), _ = b
    # entries of M = R_ref^T R: m_ij = sum_r a_ri b_rj
    m01, m10 = a00 * b01 + a10 * b11 + a20 * b21, a01 * b00 + a11 * b10 + a21 * b20
    m02, m20 = a00 * b02 + a10 * b12 + a20 * b22, a02 * b00 + a12 * b10 + a22 * b20
    m12, m21 = a01 * b02 + a11 * b12 + a21 * b22, a02 * b01 + a12 * b11 + a22 * b21
    trace = (a00 * b00 + a10 * b10 + a20 * b20) + (a01 * b01 + a11 * b11 + a21 * b21) + (a02 * b02 + a12 * b12 + a22 * b22)
    if not math.isfinite(trace):  # every entry of both rotation blocks is in a product of the trace
        return None
    v0, v1, v2 = m21 - m12, m02 - m20, m10 - m01
    dx, dy, dz = bx - ax, by - ay, bz - az
    return (np.float64(math.sqrt(dx * dx + dy * dy + dz * dz)),
            np.float64(math.atan2(0.5 * math.sqrt(v0 * v0 + v1 * v1 + v2 * v2), 0.5 * (trace - 1.0))))


def _distance(a, b) -> np.float64:
    """``|t_b - t_a|`` of two (4, 4) matrices given as nested lists."""
    dx, dy, dz = b[0][3] - a[0][3], b[1][3] - a[1][3], b[2][3] - a[2][3]
    return np.float64(math.sqrt(dx * dx + dy * dy + dz * dz))


def _exact_rotation(rows) -> bool:
    """The 3x3 block of a (4, 4) matrix given as nested lists is orthonormal to :data:`EXACT_ROTATION_TOL`, det > 0."""
    (a, b, c), (d, e, f), (g, h, i) = rows[0][:3], rows[1][:3], rows[2][:3]
    gram = (a * a + d * d + g * g - 1.0, b * b + e * e + h * h - 1.0, c * c + f * f + i * i - 1.0,
            a * b + d * e + g * h, a * c + d * f + g * i, b * c + e * f + h * i)
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    return max(map(abs, gram)) <= EXACT_ROTATION_TOL and det > 0.0


#: What an IK answer must match, and so how its residuals are measured (:func:`pose_residuals`).
RESIDUAL_MODES = ("pose", "position", "position+axis")
_AXES = ("x", "y", "z")


def pose_residuals(T_target, T, *, mode: str = "pose", axis: str = "z", project: bool = True):
    """How far reached poses are from their targets, as every IK solver reports it: (position m, rotation rad).

    The one residual of manipkit's IK (numerical, batched and closed form):
    each solver puts its answers through forward kinematics of the real chain
    and measures them here.

    Parameters
    ----------
    T_target, T : array_like, shape (..., 4, 4)
        Wanted and reached poses ``T_base_tip`` (metres); leading dimensions broadcast.
    mode : {"pose", "position", "position+axis"}, keyword-only
        What must match. ``"pose"``: the rotation residual is the geodesic
        angle between the rotation blocks (:func:`pose_error`: a block that
        is not quite a rotation is projected to the nearest one first).
        ``"position"``: the rotation residual is 0 (the orientation is free).
        ``"position+axis"``: the angle between the reached and the wanted
        direction of the frame's ``axis`` (the spin about it is free).
    axis : {"x", "y", "z"}, keyword-only
        The pointing axis of ``"position+axis"``.
    project : bool, keyword-only
        As in :func:`pose_error` (mode ``"pose"``): False takes the rotation
        blocks as they are, for FK answers against a checked target.

    Returns
    -------
    position : float or ndarray, shape (...)
        ``|t - t_target|`` (m).
    rotation : float or ndarray, shape (...)
        The angle (rad) in [0, pi] that ``mode`` measures.

    Raises
    ------
    IKOptionError
        An unknown mode or axis.
    InvalidTransformError
        An argument that is not a stack of 4x4 matrices.

    Examples
    --------
    >>> from manipkit.spatial.rotations import rot_x
    >>> T = np.eye(4); T[:3, :3] = rot_x(0.5); T[:3, 3] = [0.0, 0.3, 0.4]
    >>> tuple(round(float(e), 12) for e in pose_residuals(np.eye(4), T))
    (0.5, 0.5)
    >>> tuple(round(float(e), 12) for e in pose_residuals(np.eye(4), T, mode="position+axis", axis="x"))
    (0.5, 0.0)
    """
    if mode == "pose":
        return pose_error(T_target, T, project=project)
    if mode not in RESIDUAL_MODES:
        raise IKOptionError(f"unknown IK mode '{mode}'; modes: {', '.join(RESIDUAL_MODES)}")
    if axis not in _AXES:
        raise IKOptionError(f"unknown pointing axis '{axis}'; axes: x, y, z")
    if type(T_target) is np.ndarray and type(T) is np.ndarray and T_target.shape == T.shape == (4, 4) \
            and T_target.dtype == T.dtype == np.float64:  # one pair: plain floats, a few microseconds
        a, b = T_target.tolist(), T.tolist()
        if mode == "position":
            return _distance(a, b), np.float64(0.0)
        k = _AXES.index(axis)
        u, w = (b[0][k], b[1][k], b[2][k]), (a[0][k], a[1][k], a[2][k])
        c = (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0])
        dot = u[0] * w[0] + u[1] * w[1] + u[2] * w[2]
        return _distance(a, b), np.float64(math.atan2(math.sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]), dot))
    T_target, T = as_transforms(T_target, "T_target"), as_transforms(T, "T")
    position = np.linalg.norm(T[..., :3, 3] - T_target[..., :3, 3], axis=-1)
    if mode == "position":
        return position[()], np.zeros_like(position)[()]
    k = _AXES.index(axis)
    reached, wanted = T[..., :3, k], T_target[..., :3, k]
    cross = np.linalg.norm(np.cross(reached, wanted), axis=-1)
    angle = np.arctan2(cross, np.sum(reached * wanted, axis=-1)) + np.zeros_like(position)  # broadcast to position's shape
    return position[()], angle[()]
