"""A pose as the numbers people read: translation, quaternion, roll-pitch-yaw.

Conventions (docs/architecture.md): translation in metres; quaternion (x, y, z, w) with w >= 0;
rpy = (roll, pitch, yaw) in radians with R = Rz(yaw) Ry(pitch) Rx(roll), the
URDF convention (equal to Euler ZYX (yaw, pitch, roll)). The same numbers feed
``tf-between`` (text, JSON, CSV) and the viewer's readout, and the same text
(:func:`pose_text`) shows them to people in both.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from manipkit.spatial.forms import SINGULAR_TOL, rotation_forms
from manipkit.spatial.rotations import quaternion_from_matrix, rpy_from_matrix
from manipkit.text import number_text

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = ["NOISE", "pose_fields", "pose_report", "pose_text"]

#: Printed noise (docs/architecture.md): a number within this much of its scale (1 for rotations and
#: quaternions, the largest of 1 m and the translation's size for lengths) prints as 0; the rpy within it
#: of gimbal lock takes roll = 0, as ``manipkit rot`` does.
NOISE = SINGULAR_TOL


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
    rpy = rpy_from_matrix(R, gimbal_tol=NOISE)  # at gimbal lock roll = 0, as manipkit rot (spatial.forms)
    return {
        "translation": T[..., :3, 3].copy(),
        "quaternion_xyzw": quaternion_from_matrix(R),
        "rpy": rpy,
        "rpy_deg": np.degrees(rpy),
        "matrix": T.copy(),
    }


def pose_report(robot: Robot, source: str, target: str, q, *, T=None) -> dict:
    """T_source_target as the JSON ``tf-between SOURCE TARGET --format json`` prints.

    The viewer's readout and the command line share this function, so the
    two always agree.

    Parameters
    ----------
    robot : Robot
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


def pose_text(report: dict, *, precision: int = 6) -> str:
    """A pose report for people: the pose lines of ``tf-between``'s text output, worded like ``tf2_echo``.

    Translation (m), quaternion (x, y, z, w), RPY in radians and in degrees
    (URDF convention, labelled) and the 4x4 matrix, under a header that says
    the direction: the pose of ``target`` expressed in ``source``.

    Parameters
    ----------
    report : dict
        From :func:`pose_report` (the ``tf-between --format json`` keys).
    precision : int, keyword-only
        Decimals of every number.

    Examples
    --------
    >>> import manipkit
    >>> robot = manipkit.load("planar_2r")
    >>> print(pose_text(pose_report(robot, "base_link", "ee_link", robot.q()), precision=1))
    pose of ee_link expressed in base_link (T_base_link_ee_link, as tf2_echo base_link ee_link):
    - Translation (m): [2.0, 0.0, 0.0]
    - Rotation: in Quaternion (x, y, z, w): [0.0, 0.0, 0.0, 1.0]
    - Rotation: in RPY (radian) [roll, pitch, yaw]: [0.0, 0.0, 0.0]
    - Rotation: in RPY (degree) [roll, pitch, yaw]: [0.0, 0.0, 0.0]
      (RPY as in URDF: R = Rz(yaw) Ry(pitch) Rx(roll), fixed axes x, y, z)
    - Matrix:
        1.0   0.0   0.0   2.0
        0.0   1.0   0.0   0.0
        0.0   0.0   1.0   0.0
        0.0   0.0   0.0   1.0
    """

    length = NOISE * max(1.0, float(np.max(np.abs(report["translation"]))))  # the noise of a length, m

    def vector(values, zero=NOISE) -> str:
        return "[" + ", ".join(number_text(v, precision, zero=zero) for v in values) + "]"

    source, target = report["source"], report["target"]
    width = precision + 4
    matrix = np.asarray(report["matrix"], dtype=float)
    gimbal = rotation_forms(matrix[:3, :3]).notes.get("rpy")
    lines = [
        f"pose of {target} expressed in {source} (T_{source}_{target}, as tf2_echo {source} {target}):",
        f"- Translation (m): {vector(report['translation'], length)}",
        f"- Rotation: in Quaternion (x, y, z, w): {vector(report['quaternion_xyzw'])}",
        f"- Rotation: in RPY (radian) [roll, pitch, yaw]: {vector(report['rpy'])}",
        f"- Rotation: in RPY (degree) [roll, pitch, yaw]: {vector(np.degrees(report['rpy']), np.degrees(NOISE))}",
        "  (RPY as in URDF: R = Rz(yaw) Ry(pitch) Rx(roll), fixed axes x, y, z)",
        *([f"  ({gimbal})"] if gimbal else []),
        "- Matrix:",
    ]
    lines += ["  " + " ".join(number_text(v, precision, zero=length if c == 3 else NOISE).rjust(width)
                              for c, v in enumerate(row)) for row in matrix]
    return "\n".join(lines)
