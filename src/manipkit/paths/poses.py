"""Tool paths as stacks of poses: read from a file, or generated along a straight line or a circular arc.

Conventions (docs/architecture.md): a pose is ``T_base_tip``, the pose of the
tool frame in the chain's base frame, a 4x4 ``[[R, p], [0, 0, 0, 1]]`` with
``p`` in metres; a path is a stack ``(N, 4, 4)`` in the order the tool visits
it; times are seconds from the path's start. Quaternions are ``(x, y, z, w)``
(ROS order); ``rpy`` is ``(roll, pitch, yaw)`` in radians with
``R = Rz(yaw) Ry(pitch) Rx(roll)`` as in URDF.

Orientation between two poses is interpolated by slerp: the rotation
``R(s) = R0 expm(s log(R0^T R1))`` about the one fixed axis of ``R0^T R1``
at a constant angular rate (the shorter way round; at exactly 180 degrees the
axis :func:`manipkit.spatial.axis_angle_from_matrix` returns). Position is
linear (:func:`line_poses`) or on the circle through three points
(:func:`arc_poses`).
"""

from __future__ import annotations

import io
import math
import os
import warnings
from dataclasses import dataclass

import numpy as np

from manipkit import bounds
from manipkit.errors import InputFileError, InvalidTransformError, OptionError
from manipkit.inputs.files import read_text
from manipkit.inputs.yamls import load_yaml
from manipkit.spatial.rotations import (
    axis_angle_from_matrix,
    matrix_from_axis_angle,
    matrix_from_quaternion,
    matrix_from_rpy,
)
from manipkit.spatial.transforms import as_transforms, check_transform, transform_violations
from manipkit.text import printable

__all__ = [
    "COLLINEAR_TOL",
    "MAX_POSE_FILE_BYTES",
    "MAX_WAYPOINTS",
    "POSE_CSV_COLUMNS",
    "QUATERNION_NORM_TOL",
    "RIGID_TOL",
    "PosePath",
    "arc_poses",
    "interpolate_pose_pairs",
    "interpolate_pose_steps",
    "interpolate_poses",
    "line_poses",
    "read_pose_path",
]

#: Waypoints one path may hold (:data:`manipkit.bounds.MAX_COUNT`), checked before anything is allocated.
MAX_WAYPOINTS = bounds.MAX_COUNT
#: Largest pose file read (about a million waypoints of CSV at 60 bytes a row).
MAX_POSE_FILE_BYTES = 64 * 1024 * 1024
#: A quaternion in a file is taken when ``|x^2 + y^2 + z^2 + w^2 - 1| <= QUATERNION_NORM_TOL`` (tf2's rule for a
#: "properly normalized" quaternion) and then normalised; beyond it the row is refused as not a rotation.
QUATERNION_NORM_TOL = 0.01
#: Tolerance of the rigid-transform check of given pose arrays (as :func:`manipkit.spatial.check_transform`).
RIGID_TOL = 1e-6
#: Three positions are collinear (no circle through them) when ``|u x w| <= COLLINEAR_TOL |u| |w|``,
#: ``u`` and ``w`` the chords from the first to the other two: the sine of the angle between them.
COLLINEAR_TOL = 1e-9
#: The CSV columns of a pose file, ``t`` optional.
POSE_CSV_COLUMNS = ("x", "y", "z", "qx", "qy", "qz", "qw")


@dataclass(frozen=True)
class PosePath:
    """A tool path: poses ``T_base_tip`` in visiting order and, optionally, the time of each.

    Parameters
    ----------
    poses : array_like, shape (N, 4, 4)
        Rigid transforms (metres), each checked within :data:`RIGID_TOL`; ``1 <= N <= MAX_WAYPOINTS``.
    t : array_like, shape (N,), or None
        Seconds, finite and strictly increasing; None when the path has no timing (the planner then takes a
        speed).

    Raises
    ------
    InvalidTransformError
        A wrong shape or a pose that is not rigid (its index named).
    OptionError
        Too many waypoints, or ``t`` of the wrong length, not finite, or not strictly increasing (the index
        named).

    The arrays are stored as read-only float copies.

    Examples
    --------
    >>> path = PosePath(np.stack([np.eye(4)] * 3), t=[0.0, 0.5, 1.0])
    >>> len(path), float(path.t[-1])
    (3, 1.0)
    """

    poses: np.ndarray
    t: np.ndarray | None = None

    def __post_init__(self):
        poses = _checked_poses(self.poses, "poses")
        object.__setattr__(self, "poses", _frozen(poses))
        if self.t is not None:
            object.__setattr__(self, "t", _frozen(_checked_times(self.t, len(poses), "t")))

    def __len__(self) -> int:
        return len(self.poses)


def _frozen(array: np.ndarray) -> np.ndarray:
    array = np.array(array, dtype=float)
    array.flags.writeable = False
    return array


def _checked_poses(poses, what: str) -> np.ndarray:
    """``poses`` as a float (N, 4, 4) stack of rigid transforms, else one line naming the first bad index."""
    T = as_transforms(poses, what)
    if T.ndim != 3:
        raise InvalidTransformError(f"{what} must have shape (N, 4, 4), got {T.shape}")
    bounds.count(len(T), f"{what}: waypoints", maximum=MAX_WAYPOINTS, error=OptionError)
    with np.errstate(all="ignore"):  # NaN and inf compare False below: such a pose is not good
        R = T[:, :3, :3]
        gram = np.abs(np.einsum("nki,nkj->nij", R, R) - np.eye(3)).max(axis=(-1, -2))
        last = np.abs(T[:, 3, :] - [0.0, 0.0, 0.0, 1.0]).max(axis=-1)
        det = np.einsum("ni,ni->n", R[:, :, 0], np.cross(R[:, :, 1], R[:, :, 2]))  # column triple product
        good = (gram <= RIGID_TOL) & (last <= RIGID_TOL) & (np.abs(det - 1.0) <= RIGID_TOL)
        good &= np.abs(T[:, :3, 3]).max(axis=-1) <= bounds.MAX_LENGTH
    if not good.all():
        index = int(np.argmin(good))
        problems = transform_violations(T[index], tol=RIGID_TOL) or [
            f"a position of {np.abs(T[index, :3, 3]).max():g} m, beyond {bounds.MAX_LENGTH:g} m"]
        raise InvalidTransformError(f"{what}[{index}] is not a rigid transform: {problems[0]}")
    return T


def _checked_times(t, n: int, what: str) -> np.ndarray:
    try:
        t = np.asarray(t, dtype=float)
    except (TypeError, ValueError):
        raise OptionError(f"{what} must be numbers of seconds, got {printable(repr(t))[:60]}") from None
    if t.shape != (n,):
        raise OptionError(f"{what} has shape {t.shape}; give one time per waypoint, shape ({n},)")
    if not np.isfinite(t).all():
        index = int(np.argmin(np.isfinite(t)))
        raise OptionError(f"{what}[{index}] is {t[index]}; give finite seconds")
    steps = np.diff(t)
    if (steps <= 0.0).any():
        index = int(np.argmax(steps <= 0.0)) + 1
        raise OptionError(f"{what}[{index}] = {t[index]:g} s is not after {what}[{index - 1}] = {t[index - 1]:g} s; "
                          "times must increase strictly")
    return t


# --------------------------------------------------------------------------
# files


def read_pose_path(path: str | os.PathLike) -> PosePath:
    """A tool path from a CSV or YAML file, read safely (:func:`manipkit.inputs.files.read_text`).

    Parameters
    ----------
    path : str or path-like
        ``.yaml`` / ``.yml``: a list of waypoints, each a mapping with ``xyz`` (3 numbers, m), one of
        ``quat`` (``[x, y, z, w]``) or ``rpy`` (``[roll, pitch, yaw]`` rad, URDF convention), and ``t``
        (seconds) on every waypoint or on none; or a mapping with that list under ``poses``.
        Anything else: CSV with a header naming the columns ``x,y,z,qx,qy,qz,qw`` in any order and an
        optional ``t``; one waypoint per line; blank lines and lines starting with ``#`` skipped.

    Returns
    -------
    PosePath
        ``poses`` (N, 4, 4) ``T_base_tip`` and ``t`` (N,) or None.

    Raises
    ------
    InputFileError
        One line naming the file and the waypoint (0-based, as the array; for CSV also the 1-based line):
        not a readable file, larger than :data:`MAX_POSE_FILE_BYTES`, a missing or unknown column, a value
        that is not a finite number (NaN), a quaternion whose squared norm is off 1 by more than
        :data:`QUATERNION_NORM_TOL` (not a rotation), a position beyond :data:`manipkit.bounds.MAX_LENGTH`,
        times not strictly increasing, no waypoint, or more than :data:`MAX_WAYPOINTS`.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> file = pathlib.Path(tempfile.mkdtemp()) / "seam.csv"
    >>> _ = file.write_text("x,y,z,qx,qy,qz,qw,t\\n0.4,0,0.3,1,0,0,0,0\\n0.5,0,0.3,1,0,0,0,2\\n")
    >>> path = read_pose_path(file)
    >>> path.poses[1, :3, 3], path.t
    (array([0.5, 0. , 0.3]), array([0., 2.]))
    """
    name = printable(os.fspath(path))
    text = read_text(path, what="pose file", max_bytes=MAX_POSE_FILE_BYTES)
    if os.path.splitext(os.fspath(path))[1].lower() in (".yaml", ".yml"):
        xyz, rotations, t, where = _read_yaml(text, name)
    else:
        xyz, rotations, t, where = _read_csv(text, name)
    bad = np.abs(xyz).max(axis=-1) > bounds.MAX_LENGTH
    if bad.any():
        index = int(np.argmax(bad))
        raise InputFileError(f"{name} {where(index)}: a position of {np.abs(xyz[index]).max():g} m; give positions "
                             f"within {bounds.MAX_LENGTH:g} m")
    if t is not None:
        steps = np.diff(t)
        if (steps <= 0.0).any():
            index = int(np.argmax(steps <= 0.0)) + 1
            raise InputFileError(f"{name} {where(index)}: t = {t[index]:g} s is not after the previous waypoint's "
                                 f"{t[index - 1]:g} s; times must increase strictly")
    poses = np.zeros((len(xyz), 4, 4))
    poses[:, :3, :3] = rotations
    poses[:, :3, 3] = xyz
    poses[:, 3, 3] = 1.0
    return PosePath(poses, t)


def _count_check(n: int, name: str) -> None:
    if n == 0:
        raise InputFileError(f"{name}: no waypoint in it; give one pose per row")
    bounds.count(n, f"{name}: waypoints", maximum=MAX_WAYPOINTS, error=InputFileError)


def _rotations_from_quaternions(quat: np.ndarray, name: str, where) -> np.ndarray:
    """Rotation matrices of (N, 4) quaternions (x, y, z, w) near unit length, else one line naming the waypoint."""
    squared = np.einsum("ij,ij->i", quat, quat)
    bad = ~(np.abs(squared - 1.0) <= QUATERNION_NORM_TOL)
    if bad.any():
        index = int(np.argmax(bad))
        raise InputFileError(f"{name} {where(index)}: the quaternion {np.round(quat[index], 6).tolist()} (x, y, z, w) has "
                             f"norm {math.sqrt(squared[index]):.6g}, not a rotation; give a unit quaternion (squared "
                             f"norm within {QUATERNION_NORM_TOL:g} of 1)")
    return matrix_from_quaternion(quat)  # normalised there


def _read_csv(text: str, name: str):
    """xyz (N, 3), rotations (N, 3, 3), t (N,) or None, and a function naming waypoint i, from CSV text.

    The numbers are parsed by ``np.loadtxt`` (compiled: 800,000 rows in a second or two, in little memory);
    when it refuses the text, the rows are read one by one to name the first bad one."""
    header_line, start = 0, 0
    while True:  # the header: the first line that is neither blank nor a comment
        end = text.find("\n", start)
        line, header_line = text[start:end if end >= 0 else len(text)], header_line + 1
        if line.strip() and not line.strip().startswith("#"):
            break
        if end < 0:
            raise InputFileError(f"{name}: empty; give a header {','.join(POSE_CSV_COLUMNS)}[,t] and one pose per row")
        start = end + 1
    offset = len(text) if end < 0 else end + 1
    header = [column.strip().lower() for column in line.split(",")]
    known = (*POSE_CSV_COLUMNS, "t")
    unknown = [column for column in header if column not in known]
    missing = [column for column in POSE_CSV_COLUMNS if column not in header]
    if unknown or missing or len(set(header)) != len(header):
        problem = (f"unknown column '{printable(unknown[0])[:40]}'" if unknown else f"no column {missing[0]}"
                   if missing else "a column named twice")
        raise InputFileError(f"{name} line {header_line}: {problem}; the header names the columns "
                             f"{','.join(POSE_CSV_COLUMNS)} and optionally t")
    body = text[offset:]
    bounds.count(body.count("\n") + 1, f"{name}: lines", maximum=MAX_WAYPOINTS + 1, error=InputFileError)

    def where(index: int) -> str:
        """``line L (waypoint i)``, counting the data lines after the header (only when a message needs it)."""
        seen = -1
        for number, row in enumerate(body.splitlines(), header_line + 1):
            if row.strip() and not row.strip().startswith("#"):
                seen += 1
                if seen == index:
                    return f"line {number} (waypoint {index})"
        return f"waypoint {index}"  # pragma: no cover - every index comes from a data row

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "input contained no data": counted below
            values = np.loadtxt(io.StringIO(body), delimiter=",", comments="#", dtype=float, ndmin=2)
        if values.shape[1] != len(header) and len(values):
            raise ValueError("column count")
    except ValueError:
        values = _csv_rows_one_by_one(body, header, name, where)
    _count_check(len(values), name)
    finite = np.isfinite(values)
    if not finite.all():
        index, column = (int(i) for i in np.argwhere(~finite)[0])
        raise InputFileError(f"{name} {where(index)}: {header[column]} is {values[index, column]}, not a finite number")
    column = {key: header.index(key) for key in header}
    xyz = values[:, [column["x"], column["y"], column["z"]]]
    quat = values[:, [column["qx"], column["qy"], column["qz"], column["qw"]]]
    t = values[:, column["t"]] if "t" in column else None
    return xyz, _rotations_from_quaternions(quat, name, where), t, where


def _csv_rows_one_by_one(body: str, header: list[str], name: str, where) -> np.ndarray:
    """The rows of ``body`` parsed in Python, refusing the first with the wrong count or a token not a number."""
    rows = [row.strip() for row in body.splitlines()]
    rows = [row for row in rows if row and not row.startswith("#")]
    values = np.empty((len(rows), len(header)))
    for index, row in enumerate(rows):
        tokens = row.split(",")
        if len(tokens) != len(header):
            raise InputFileError(f"{name} {where(index)}: {len(tokens)} values; the header has {len(header)} columns")
        for column, token in enumerate(tokens):
            try:
                values[index, column] = float(token)
            except ValueError:
                raise InputFileError(f"{name} {where(index)}: {header[column]} is '{printable(token.strip())[:40]}', "
                                     "not a number") from None
    return values


def _read_yaml(text: str, name: str):
    """xyz, rotations, t and a function naming waypoint i, from YAML text (a list of waypoint mappings)."""
    document = load_yaml(text, name, error=InputFileError)
    if isinstance(document, dict) and set(document) == {"poses"}:
        document = document["poses"]
    if not isinstance(document, list):
        raise InputFileError(f"{name}: expected a list of waypoints like - {{xyz: [x, y, z], quat: [x, y, z, w], t: 0}}")
    _count_check(len(document), name)

    def where(index: int) -> str:
        return f"waypoint {index}"

    xyz, quat, rpy, kinds, times = [], [], [], [], []
    for index, entry in enumerate(document):
        if not isinstance(entry, dict):
            raise InputFileError(f"{name} {where(index)}: expected a mapping with xyz and quat or rpy")
        keys = [str(key) for key in entry]
        unknown = [key for key in keys if key not in ("xyz", "quat", "rpy", "t")]
        if unknown or "xyz" not in keys or ("quat" in keys) == ("rpy" in keys):
            problem = (f"unknown key '{printable(unknown[0])[:40]}'" if unknown else "no xyz" if "xyz" not in keys
                       else "both quat and rpy" if "quat" in keys else "neither quat nor rpy")
            raise InputFileError(f"{name} {where(index)}: {problem}; give xyz, one of quat (x, y, z, w) or rpy, "
                                 "and optionally t")
        kind = "quat" if "quat" in keys else "rpy"
        xyz.append(_yaml_numbers(entry["xyz"], 3, f"{name} {where(index)}: xyz"))
        (quat if kind == "quat" else rpy).append(_yaml_numbers(entry[kind], 4 if kind == "quat" else 3,
                                                               f"{name} {where(index)}: {kind}"))
        kinds.append(kind)
        if "t" in keys:
            times.append(_yaml_numbers([entry["t"]], 1, f"{name} {where(index)}: t")[0])
        if bool(times) != ("t" in keys) or len(times) not in (0, index + 1):
            raise InputFileError(f"{name} {where(index)}: t given on some waypoints only; give t on every waypoint "
                                 "or on none")
    is_quat = np.array([kind == "quat" for kind in kinds])
    rotations = np.empty((len(kinds), 3, 3))
    if is_quat.any():
        indices = np.flatnonzero(is_quat)
        rotations[is_quat] = _rotations_from_quaternions(np.array(quat), name, lambda i: where(int(indices[i])))
    if not is_quat.all():
        angles = np.array(rpy)
        bad = np.abs(angles).max(axis=-1) > bounds.MAX_ANGLE
        if bad.any():
            index = int(np.flatnonzero(~is_quat)[np.argmax(bad)])
            raise InputFileError(f"{name} {where(index)}: rpy beyond {bounds.MAX_ANGLE:g} rad names no definite rotation")
        rotations[~is_quat] = matrix_from_rpy(angles)
    return np.array(xyz), rotations, (np.array(times) if times else None), where


def _yaml_numbers(value, length: int, what: str) -> list[float]:
    if not isinstance(value, list) or len(value) != length:
        raise InputFileError(f"{what}: give {length} number{'s' if length > 1 else ''}"
                             + (f" in a list like [{', '.join(['0'] * length)}]" if length > 1 else ""))
    numbers = []
    for item in value:
        if isinstance(item, bool) or not isinstance(item, (int, float)):
            raise InputFileError(f"{what}: '{printable(str(item))[:40]}' is not a number")
        number = float(item)
        if not math.isfinite(number):
            raise InputFileError(f"{what}: {number} is not a finite number")
        numbers.append(number)
    return numbers


# --------------------------------------------------------------------------
# generated paths


def interpolate_poses(T0, T1, s) -> np.ndarray:
    """Poses between ``T0`` and ``T1`` at fractions ``s``: position linear, orientation by slerp.

    Parameters
    ----------
    T0, T1 : array_like, shape (4, 4)
        ``T_base_tip`` at ``s = 0`` and ``s = 1`` (checked as rigid transforms).
    s : array_like, shape (M,)
        Path fractions; values outside [0, 1] extrapolate along the same screw-free (position linear,
        rotation about one fixed axis) motion.

    Returns
    -------
    T : ndarray, shape (M, 4, 4)
        ``p(s) = (1 - s) p0 + s p1`` and ``R(s) = R0 expm(s log(R0^T R1))`` (the rotation of angle in
        [0, pi] from :func:`manipkit.spatial.axis_angle_from_matrix`).

    Examples
    --------
    >>> from manipkit.spatial import transform_from_xyz_rpy
    >>> T = interpolate_poses(np.eye(4), transform_from_xyz_rpy([1, 0, 0], [0, 0, np.pi / 2]), [0.5])
    >>> T[0, :3, 3], round(float(np.degrees(np.arctan2(T[0, 1, 0], T[0, 0, 0]))), 9)
    (array([0.5, 0. , 0. ]), 45.0)
    """
    T0 = check_transform(T0, what="T0")
    T1 = check_transform(T1, what="T1")
    return interpolate_pose_steps(np.stack([T0, T1]), [0], s)[0]


def interpolate_pose_steps(T, steps, s) -> np.ndarray:
    """:func:`interpolate_poses` on many steps of a path at once: between ``T[i]`` and ``T[i + 1]`` for each ``i`` of
    ``steps``, at the same fractions ``s``.

    Parameters
    ----------
    T : ndarray, shape (N, 4, 4)
        ``T_base_tip`` along a path, already checked as rigid transforms (not checked here).
    steps : array_like of int, shape (m,)
        The steps (``i``: from ``T[i]`` to ``T[i + 1]``).
    s : array_like, shape (p,)
        Fractions of each step.

    Returns
    -------
    ndarray, shape (m, p, 4, 4)
        Position linear, rotation ``R_i expm(s log(R_i^T R_{i+1}))`` (angle in [0, pi]).
    """
    T = np.asarray(T, dtype=float)
    steps = np.asarray(steps, dtype=np.intp).reshape(-1)
    return interpolate_pose_pairs(T[steps], T[steps + 1], s)


def interpolate_pose_pairs(T0, T1, s) -> np.ndarray:
    """:func:`interpolate_poses` on many pairs of poses at once: between ``T0[m]`` and ``T1[m]`` for each ``m``, at
    the same fractions ``s`` (the rule of :func:`interpolate_pose_steps`, for pairs that are not consecutive).

    Parameters
    ----------
    T0, T1 : ndarray, shape (m, 4, 4)
        ``T_base_tip`` at ``s = 0`` and ``s = 1``, already checked as rigid transforms (not checked here).
    s : array_like, shape (p,)
        Fractions of each pair.

    Returns
    -------
    ndarray, shape (m, p, 4, 4)
        Position linear, rotation ``R0 expm(s log(R0^T R1))`` (angle in [0, pi]).
    """
    T0 = np.asarray(T0, dtype=float).reshape(-1, 4, 4)
    T1 = np.asarray(T1, dtype=float).reshape(-1, 4, 4)
    s = np.atleast_1d(np.asarray(s, dtype=float))
    axis, angle = axis_angle_from_matrix(np.swapaxes(T0[:, :3, :3], -1, -2) @ T1[:, :3, :3], check=False)
    out = np.zeros((len(T0), len(s), 4, 4))
    out[:, :, :3, :3] = T0[:, None, :3, :3] @ matrix_from_axis_angle(axis[:, None, :],
                                                                     s[None, :] * np.reshape(angle, (-1, 1)))
    out[:, :, :3, 3] = (1.0 - s)[None, :, None] * T0[:, None, :3, 3] + s[None, :, None] * T1[:, None, :3, 3]
    out[:, :, 3, 3] = 1.0
    return out


def _angle_step(angle_step) -> float | None:
    if angle_step is None:
        return None
    try:
        value = float(angle_step)
    except (TypeError, ValueError):
        raise OptionError(f"angle_step {printable(repr(angle_step))[:40]}: give radians, a positive number") from None
    if not (math.isfinite(value) and 0.0 < value <= bounds.MAX_ANGLE):
        raise OptionError(f"angle_step {value:g}: give a positive angle in radians up to {bounds.MAX_ANGLE:g}")
    return value


def _segments(length: float, angle: float, step: float, angle_step: float | None, what: str) -> int:
    """Intervals so that each spans at most ``step`` metres and ``angle_step`` radians (at least 1)."""
    needed = max(math.ceil(length / step - 1e-12), math.ceil(angle / angle_step - 1e-12) if angle_step else 0, 1)
    bounds.count(needed + 1, f"{what}: waypoints", maximum=MAX_WAYPOINTS, error=OptionError)
    return needed


def line_poses(T0, T1, *, step: float, angle_step: float | None = None) -> np.ndarray:
    """Poses on the straight line from ``T0`` to ``T1``, orientation slerped, evenly spaced.

    Parameters
    ----------
    T0, T1 : array_like, shape (4, 4)
        Start and end ``T_base_tip`` (metres).
    step : float, keyword-only
        Largest distance between consecutive positions, metres (``manipkit.bounds.length``: 1e-9 to 1e6).
    angle_step : float or None, keyword-only
        Largest rotation between consecutive orientations, radians; None: no bound (a pure rotation in place
        then gives the two end poses).

    Returns
    -------
    T : ndarray, shape (N, 4, 4)
        ``N = k + 1`` poses at fractions ``i / k``, ``k`` the least count of intervals keeping both bounds;
        the first is ``T0`` and the last ``T1`` (to rounding). When ``T0 == T1`` (no distance and no
        rotation) one pose.

    Raises
    ------
    OptionError
        A step out of its bounds (0, negative, NaN) or more than :data:`MAX_WAYPOINTS` poses.
    InvalidTransformError
        ``T0`` or ``T1`` not a rigid transform.

    Examples
    --------
    >>> from manipkit.spatial import transform_from_xyz_rpy
    >>> line_poses(np.eye(4), transform_from_xyz_rpy([0.3, 0, 0]), step=0.1)[:, 0, 3]
    array([0. , 0.1, 0.2, 0.3])
    """
    step = bounds.length(step, "step", error=OptionError)
    angle_step = _angle_step(angle_step)
    T0 = check_transform(T0, what="T0")
    T1 = check_transform(T1, what="T1")
    length = float(np.linalg.norm(T1[:3, 3] - T0[:3, 3]))
    _, angle = axis_angle_from_matrix(T0[:3, :3].T @ T1[:3, :3], check=False)
    if length == 0.0 and float(angle) == 0.0:
        return T0[None].copy()
    k = _segments(length, float(angle), step, angle_step, "line")
    return interpolate_poses(T0, T1, np.arange(k + 1) / k)


def arc_poses(T0, T_via, T1, *, step: float, angle_step: float | None = None) -> np.ndarray:
    """Poses on the circular arc from ``T0`` through ``T_via`` to ``T1``, orientation slerped piecewise.

    Parameters
    ----------
    T0, T_via, T1 : array_like, shape (4, 4)
        ``T_base_tip`` at the start, at a point the arc passes, and at the end. Their positions fix the
        circle (they must not be collinear); the arc runs from ``T0`` through ``T_via`` to ``T1`` (less than
        a full turn).
    step : float, keyword-only
        Largest arc length between consecutive positions, metres (the chord is shorter).
    angle_step : float or None, keyword-only
        Largest rotation of the orientation between consecutive poses, radians.

    Returns
    -------
    T : ndarray, shape (N, 4, 4)
        The first pose is ``T0``, ``T_via`` is one of them, the last is ``T1``. Each of the two pieces
        (start to via, via to end) is evenly spaced by arc angle, and its orientation is slerped from one
        end's to the other's in proportion to the arc length.

    Raises
    ------
    OptionError
        Collinear positions (no circle through them; :data:`COLLINEAR_TOL`), two positions equal, a step out
        of its bounds, or more than :data:`MAX_WAYPOINTS` poses.
    InvalidTransformError
        A pose that is not a rigid transform.

    Examples
    --------
    >>> from manipkit.spatial import transform_from_xyz_rpy as pose
    >>> T = arc_poses(pose([1, 0, 0]), pose([0, 1, 0]), pose([-1, 0, 0]), step=np.pi / 4)
    >>> T[:, :2, 3].round(6) + 0.0
    array([[ 1.      ,  0.      ],
           [ 0.707107,  0.707107],
           [ 0.      ,  1.      ],
           [-0.707107,  0.707107],
           [-1.      ,  0.      ]])
    """
    step = bounds.length(step, "step", error=OptionError)
    angle_step = _angle_step(angle_step)
    T0, T_via, T1 = (check_transform(T, what=what) for T, what in ((T0, "T0"), (T_via, "T_via"), (T1, "T1")))
    p0, pv, p1 = T0[:3, 3], T_via[:3, 3], T1[:3, 3]
    u, w = pv - p0, p1 - p0
    normal = np.cross(u, w)
    lengths = [float(np.linalg.norm(v)) for v in (u, w, p1 - pv)]
    if min(lengths) == 0.0:
        pair = ("T0 and T_via", "T0 and T1", "T_via and T1")[int(np.argmin(lengths))]
        raise OptionError(f"arc: the positions of {pair} are the same; an arc needs three distinct positions")
    if float(np.linalg.norm(normal)) <= COLLINEAR_TOL * lengths[0] * lengths[1]:
        raise OptionError("arc: the three positions are collinear, so no circle passes through them; use a line")
    # circumcentre of the triangle p0, pv, p1 (offset from p0), and the plane's axes
    centre = p0 + np.cross(u @ u * w - w @ w * u, normal) / (2.0 * normal @ normal)
    radius = float(np.linalg.norm(p0 - centre))
    e1 = (p0 - centre) / radius
    e2 = np.cross(normal / np.linalg.norm(normal), e1)  # p0 -> pv -> p1 turns positively about the normal

    def polar(p):
        return math.atan2(float(e2 @ (p - centre)), float(e1 @ (p - centre))) % (2.0 * math.pi)

    theta_via, theta_end = polar(pv), polar(p1)
    pieces = []
    for (start, end), (Ta, Tb) in zip(((0.0, theta_via), (theta_via, theta_end)), ((T0, T_via), (T_via, T1))):
        _, angle = axis_angle_from_matrix(Ta[:3, :3].T @ Tb[:3, :3], check=False)
        k = _segments(radius * (end - start), float(angle), step, angle_step, "arc")
        s = np.arange(k + 1) / k
        T = interpolate_poses(Ta, Tb, s)
        theta = start + s * (end - start)
        T[:, :3, 3] = centre + radius * (np.cos(theta)[:, None] * e1 + np.sin(theta)[:, None] * e2)
        T[-1, :3, 3] = Tb[:3, 3]  # the given positions exactly, not their rounded circle points
        pieces.append(T if not pieces else T[1:])
    pieces[0][0, :3, 3] = p0
    result = np.concatenate(pieces)
    bounds.count(len(result), "arc: waypoints", maximum=MAX_WAYPOINTS, error=OptionError)
    return result
