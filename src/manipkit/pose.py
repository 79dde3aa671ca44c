"""A pose as the numbers people read: translation, quaternion, roll-pitch-yaw.

Conventions: translation in metres; quaternion (x, y, z, w) with w >= 0;
rpy = (roll, pitch, yaw) in radians with R = Rz(yaw) Ry(pitch) Rx(roll), the
URDF convention (equal to Euler ZYX (yaw, pitch, roll)). The same numbers feed
``tf-between`` (text, JSON, CSV) and the viewer's readout.
"""

from __future__ import annotations

import numpy as np

from manipkit.rotations import quaternion_from_matrix, rpy_from_matrix


def pose_fields(T) -> dict[str, np.ndarray]:
    """Split homogeneous transforms into the fields ``tf2_echo`` prints.

    Parameters
    ----------
    T : array_like, shape (..., 4, 4)

    Returns
    -------
    dict with ``translation`` (..., 3), ``quaternion_xyzw`` (..., 4),
    ``rpy`` (..., 3) in radians, ``rpy_deg`` (..., 3) and ``matrix`` (..., 4, 4).

    Examples
    --------
    >>> T = np.eye(4); T[:3, 3] = [0.1, 0.2, 0.3]
    >>> pose_fields(T)["quaternion_xyzw"]
    array([0., 0., 0., 1.])
    """
    T = np.asarray(T, dtype=float)
    R = T[..., :3, :3]
    rpy = rpy_from_matrix(R)
    return {
        "translation": T[..., :3, 3].copy(),
        "quaternion_xyzw": quaternion_from_matrix(R),
        "rpy": rpy,
        "rpy_deg": np.degrees(rpy),
        "matrix": T.copy(),
    }


def pose_report(robot, source: str, target: str, q, *, T=None) -> dict:
    """T_source_target as the JSON ``tf-between SOURCE TARGET --format json`` prints.

    The viewer's readout and the command line share this function, so the
    two always agree.

    Parameters
    ----------
    robot : manipkit.model.Robot
    source, target : str
        Frame names (or the aliases ``base_link``, ``ee_link``), kept as given.
    q : array_like, shape (n,)
        Joint vector in ``robot.joint_names`` order (radians, metres).
    T : array_like, shape (4, 4), optional, keyword-only
        ``robot.transform(source, target, q)`` when the caller already has it.

    Returns
    -------
    dict with the keys ``source``, ``target``, ``robot``, ``q`` (joint name ->
    value), ``translation``, ``quaternion_xyzw``, ``rpy`` (radians, URDF
    convention) and ``matrix`` (4x4 rows), as plain Python lists and floats.

    Examples
    --------
    >>> import manipkit
    >>> robot = manipkit.load("planar_2r")
    >>> report = pose_report(robot, "base_link", "ee_link", robot.q())
    >>> list(report)
    ['source', 'target', 'robot', 'q', 'translation', 'quaternion_xyzw', 'rpy', 'matrix']
    """
    if T is None:
        T = robot.transform(source, target, q)
    fields = pose_fields(T)
    return {
        "source": source,
        "target": target,
        "robot": robot.name,
        "q": robot.as_dict(q),
        "translation": fields["translation"].tolist(),
        "quaternion_xyzw": fields["quaternion_xyzw"].tolist(),
        "rpy": fields["rpy"].tolist(),
        "matrix": fields["matrix"].tolist(),
    }
