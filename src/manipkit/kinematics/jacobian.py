"""Frame Jacobians of a robot, one configuration or many at once (compiled, no Python loop over rows).

Conventions (docs/architecture.md), restated:

- ``J`` maps joint velocities to the frame's velocity: ``(v, w) = J qdot``.
  Rows are the **linear velocity of the frame's origin** (m/s) then the
  **angular velocity** (rad/s): ``vx vy vz wx wy wz``. Columns follow
  ``robot.joint_names`` (rad/s for revolute joints, m/s for prismatic ones).
- The velocity is that of ``frame`` relative to ``base``. ``reference`` says
  in which axes both halves are written:

  ============  ===================================  ============================  ==============
  reference     axes                                 Pinocchio (base = root link)  Robotics Toolbox
  ============  ===================================  ============================  ==============
  ``"base"``    the base frame's axes                ``LOCAL_WORLD_ALIGNED``       ``jacob0``
  ``"local"``   the frame's own axes                 ``LOCAL``                     ``jacobe``
  ============  ===================================  ============================  ==============

  (Pinocchio's ``WORLD`` Jacobian is neither: its linear rows are the
  velocity of the point at the world origin moving with the frame.)
- A mimic joint (a :class:`~manipkit.kernels.fk.ChainStep` whose value
  is ``scale * q[index] + offset``) adds ``scale`` times its own column to
  its leader's column; several steps may share a column.
- ``representation="rpy"`` (with ``reference="base"``) gives the analytic
  Jacobian: angular rows replaced by the rates of the frame's roll, pitch,
  yaw in the base frame (URDF rpy, ``R = Rz(yaw) Ry(pitch) Rx(roll)``,
  pitch in [-pi/2, pi/2]): ``rpy_dot = E(rpy)^-1 w`` with
  ``E = [Rz(yaw) Ry(pitch) e_x, Rz(yaw) e_y, e_z]``, ``det E = cos(pitch)``,
  so it does not exist at pitch = +-90 deg (gimbal lock).

How it is computed: by the chain's program, ``robot.chain(base, tip).program.jacobian``
(:class:`manipkit.kernels.program.JacobianProgram`): the steps from the base
to the frame (up the tree and down again for frames on different branches)
with every joint turned about (or sliding along) its local z axis; per
configuration, column ``k`` is ``(z_k x (p - o_k), z_k)`` for a revolute
joint, ``(z_k, 0)`` for a prismatic one, ``o_k`` and ``z_k`` the joint's
origin and axis in the base.

Examples
--------
>>> import numpy as np
>>> import manipkit
>>> robot = manipkit.load("planar_2r")
>>> J = jacobian(robot, [0.0, np.pi / 2])
>>> J.shape
(6, 2)
>>> np.round(J[[0, 1, 5]], 12) + 0.0  # vx, vy, wz: [[-l1 s1 - l2 s12, -l2 s12], [l1 c1 + l2 c12, l2 c12], [1, 1]]
array([[-1., -1.],
       [ 1.,  0.],
       [ 1.,  1.]])
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from manipkit.errors import JointValueError, OptionError, SingularityError
from manipkit.kinematics.chain import chain_columns

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = [
    "GIMBAL_TOL", "REFERENCES", "REPRESENTATIONS", "jacobian", "jacobian_columns", "jacobians",
    "mass_matrix",
    "rpy_rate_matrix",
]

REFERENCES = ("base", "local")
REPRESENTATIONS = ("geometric", "rpy")
#: ``representation="rpy"`` refuses a configuration where ``cos(pitch)`` is at most this (gimbal lock).
GIMBAL_TOL = 1e-9


def _check_option(name: str, value, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise OptionError(f"{name}={value!r} is not one of {', '.join(repr(a) for a in allowed)}")


def _joint_rows(robot: Robot, Q) -> np.ndarray:
    """``Q`` as a float array (..., n) of finite joint values, with a one-line error otherwise."""
    n = len(robot.joint_names)
    try:
        array = np.asarray(Q)
        if array.dtype.kind in "cOSUV":
            raise TypeError(array.dtype)
        array = array.astype(float, copy=False)
    except (TypeError, ValueError):
        raise JointValueError(f"joint values must be real numbers (rad or m), {n} per configuration "
                              f"({', '.join(robot.joint_names)})") from None
    if array.ndim == 0 or array.shape[-1] != n:
        raise JointValueError(f"robot '{robot.name}' needs {n} joint values per configuration "
                              f"({', '.join(robot.joint_names) or 'none'}), got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise JointValueError("joint values must be finite numbers")
    return array


def rpy_rate_matrix(R, *, gimbal_tol: float = GIMBAL_TOL) -> np.ndarray:
    """``E^-1`` (..., 3, 3): roll-pitch-yaw rates from an angular velocity in the base frame, ``rpy_dot = E^-1 w``.

    ``R`` (..., 3, 3) is the frame's rotation in the base, ``R = Rz(yaw)
    Ry(pitch) Rx(roll)`` (URDF rpy, pitch in [-pi/2, pi/2]). With ``c``,
    ``s`` the cosines and sines::

        E^-1 = 1 / cp * [[ cy,     sy,     0 ],
                         [-sy cp,  cy cp,  0 ],
                         [ cy sp,  sy sp,  cp]]

    Raises
    ------
    SingularityError
        At gimbal lock, ``cos(pitch) <= gimbal_tol`` (pitch = +-90 deg), where
        roll and yaw turn about the same axis and no rates exist.

    Examples
    --------
    >>> from manipkit.spatial.rotations import matrix_from_rpy
    >>> E_inv = rpy_rate_matrix(matrix_from_rpy([0.1, 0.2, 0.3]))
    >>> w = E_inv @ np.array([0.0, 0.0, 1.0])  # a turn about the base's z axis is a pure yaw rate
    >>> np.round(w, 12) + 0.0
    array([0., 0., 1.])
    """
    R = np.asarray(R, dtype=float)
    cp = np.hypot(R[..., 0, 0], R[..., 1, 0])
    locked = cp <= gimbal_tol
    if np.any(locked):
        where = "" if R.ndim == 2 else f" (configuration {int(np.flatnonzero(locked.ravel())[0])})"
        raise SingularityError(
            f"the roll-pitch-yaw rates do not exist at pitch = +-90 deg (gimbal lock: cos(pitch) = "
            f"{float(cp.ravel()[np.flatnonzero(locked.ravel())[0]]):.3g}){where}, where roll and yaw turn about "
            "the same axis; use representation='geometric' (angular velocity) there"
        )
    cy, sy, sp = R[..., 0, 0] / cp, R[..., 1, 0] / cp, -R[..., 2, 0]
    zero = np.zeros_like(cp)
    E_inv = np.stack([
        np.stack([cy, sy, zero], -1),
        np.stack([-sy * cp, cy * cp, zero], -1),
        np.stack([cy * sp, sy * sp, cp], -1),
    ], -2)
    return E_inv / cp[..., None, None]


def jacobians(robot: Robot, Q, *, base: str | None = None, tip: str | None = None, reference: str = "base",
              representation: str = "geometric", gimbal_tol: float = GIMBAL_TOL) -> np.ndarray:
    """Jacobians of ``tip`` relative to ``base`` for many configurations at once: ``robot.chain(base, tip)``'s program.

    Parameters
    ----------
    robot : Robot
    Q : array_like, shape (..., n)
        Joint vectors in ``robot.joint_names`` order (rad, m).
    base, tip : str, keyword-only
        Frame names (aliases ``base_link``, ``ee_link``, the defaults); any
        two frames (:meth:`manipkit.kinematics.robot.Robot.chain`).
    reference : {"base", "local"}, keyword-only
        Axes of both halves: the base frame's (Pinocchio ``LOCAL_WORLD_ALIGNED``
        when the base is the root, RTB ``jacob0``) or the frame's own
        (Pinocchio ``LOCAL``, RTB ``jacobe``). See the module docstring.
    representation : {"geometric", "rpy"}, keyword-only
        ``"rpy"``: angular rows are roll, pitch, yaw rates (rad/s) of the
        frame in the base (only with ``reference="base"``).
    gimbal_tol : float, keyword-only
        ``"rpy"`` refuses ``cos(pitch) <= gimbal_tol``.

    Returns
    -------
    J : ndarray, shape (..., 6, n)
        Rows ``vx vy vz wx wy wz`` (or ``vx vy vz roll pitch yaw`` rates):
        :meth:`manipkit.kinematics.chain.Chain.jacobians` in the chain's
        columns of ``robot.joint_names``, zero in the others.

    Raises
    ------
    JointValueError, UnknownFrameError
        Bad joint values, a frame the robot does not have.
    OptionError, SingularityError
        An unknown option, or gimbal lock with ``representation="rpy"``.
    """
    _check_option("reference", reference, REFERENCES)
    _check_option("representation", representation, REPRESENTATIONS)
    if representation == "rpy" and reference != "base":
        raise OptionError("representation='rpy' gives rates of the frame's roll, pitch, yaw in the base: "
                            "use it with reference='base'")
    chain = robot.chain("base_link" if base is None else base, "ee_link" if tip is None else tip)
    Q = _joint_rows(robot, Q)
    lead = Q.shape[:-1]
    n = len(robot.joint_names)
    flat = np.ascontiguousarray(Q.reshape(-1, n))
    J, R, _ = chain.program.jacobian.run(chain_columns(flat, chain.columns), local=reference == "local",
                                         out_columns=chain.columns, width=n)  # the robot's columns, written once
    if representation == "rpy":
        J[:, 3:] = rpy_rate_matrix(R, gimbal_tol=gimbal_tol) @ J[:, 3:]
    return J.reshape(*lead, 6, n)


def jacobian(robot: Robot, q=None, *, base: str | None = None, tip: str | None = None, reference: str = "base",
             representation: str = "geometric", gimbal_tol: float = GIMBAL_TOL) -> np.ndarray:
    """The Jacobian (6, n) of ``tip`` relative to ``base`` at one configuration ``q``.

    ``q`` is a joint vector in ``robot.joint_names`` order (rad, m), or None
    for every joint at 0 (as :meth:`manipkit.kinematics.robot.Robot.transform`).
    Rows ``vx vy vz wx wy wz``: the velocity of the frame's origin, then its
    angular velocity. Columns follow ``robot.joint_names``.

    ==============  ==================================  ==============================  ================
    reference       axes of v and w                     Pinocchio (base = root link)    Robotics Toolbox
    ==============  ==================================  ==============================  ================
    ``"base"``      base frame's                        ``LOCAL_WORLD_ALIGNED``         ``jacob0``
    ``"local"``     frame's own                         ``LOCAL``                       ``jacobe``
    ==============  ==================================  ==============================  ================

    Other parameters as :func:`jacobians` (``representation="rpy"``: the
    analytic Jacobian for roll-pitch-yaw rates, refused at pitch = +-90 deg).

    Examples
    --------
    >>> import manipkit
    >>> robot = manipkit.load("iiwa14")
    >>> J = jacobian(robot, robot.sample_q(1, seed=0)[0], reference="local")
    >>> J.shape
    (6, 7)
    """
    q = robot.q(q) if q is None or isinstance(q, Mapping) else q  # a dict by joint name, as Robot.jacobian takes
    q = _joint_rows(robot, q)
    if q.ndim != 1:
        raise JointValueError(f"robot '{robot.name}' needs one joint vector of {len(robot.joint_names)} values, "
                              f"got shape {q.shape}; use jacobians for many")
    return jacobians(robot, q[None], base=base, tip=tip, reference=reference, representation=representation,
                     gimbal_tol=gimbal_tol)[0]


def jacobian_columns(robot: Robot, *, base: str | None = None, tip: str | None = None) -> np.ndarray:
    """The columns of the Jacobian of ``tip`` relative to ``base`` that the chain can make nonzero.

    The joints between the two frames (those moving one frame and not the
    other: ``robot.chain(base, tip).columns``), in :attr:`joint_names`
    order. The other columns are zero at every configuration (a wheel, a
    finger, a joint above both frames): indices that count singular values
    (Yoshikawa's, the condition number) take these columns only, else a
    5-joint arm on a 2-wheel base would read as singular everywhere.

    Examples
    --------
    >>> import manipkit
    >>> robot = manipkit.load("mobile_manipulator")
    >>> [robot.joint_names[i] for i in jacobian_columns(robot)]  # the arm's joints, not the wheels
    ['arm_base_joint', 'shoulder_joint', 'bottom_wrist_joint', 'elbow_joint', 'top_wrist_joint']
    """
    chain = robot.chain("base_link" if base is None else base, "ee_link" if tip is None else tip)
    return np.sort(chain.columns).astype(np.intp)


def mass_matrix(robot: Robot, q=None) -> np.ndarray:
    """The joint-space inertia matrix ``M(q)`` (n, n) in ``robot.joint_names`` order (kg, kg m, kg m^2).

    Pinocchio's composite rigid body algorithm (``crba``) on the inertias of
    the description, folded onto the independent joints (a mimic joint
    moves with its leader); used by Asada's index
    (:func:`manipkit.analysis.manipulability.manipulability`, ``method="asada"``).

    Examples
    --------
    >>> import manipkit
    >>> M = mass_matrix(manipkit.load("iiwa14"))
    >>> bool(np.allclose(M, M.T)) and bool(np.all(np.linalg.eigvalsh(M) > 0))
    True
    """
    import pinocchio as pin

    data = robot.model.createData()
    M = np.array(pin.crba(robot.model, data, robot.pinocchio_configuration(q)))
    M = np.triu(M) + np.triu(M, 1).T  # crba fills the upper triangle
    S = robot.velocity_map()  # mimic joints move with their leaders: M_q = S^T M S
    return S.T @ M @ S
