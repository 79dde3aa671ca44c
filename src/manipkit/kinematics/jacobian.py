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
- A mimic joint (a :class:`~manipkit.kinematics.fk_kernel.ChainStep` whose value
  is ``scale * q[index] + offset``) adds ``scale`` times its own column to
  its leader's column; several steps may share a column.
- ``representation="rpy"`` (with ``reference="base"``) gives the analytic
  Jacobian: angular rows replaced by the rates of the frame's roll, pitch,
  yaw in the base frame (URDF rpy, ``R = Rz(yaw) Ry(pitch) Rx(roll)``,
  pitch in [-pi/2, pi/2]): ``rpy_dot = E(rpy)^-1 w`` with
  ``E = [Rz(yaw) Ry(pitch) e_x, Rz(yaw) e_y, e_z]``, ``det E = cos(pitch)``,
  so it does not exist at pitch = +-90 deg (gimbal lock).

How it is computed: the chain from the base (or the root link) to the frame
(:meth:`manipkit.kinematics.robot.Robot.chain`) is prepared once with every
joint turned about (or sliding along) its local z axis; then, per
configuration, ``T <- T X_k`` and ``T <- T Jz(q_k)`` record each joint's
origin ``o_k`` and axis ``z_k``, and column ``k`` is ``(z_k x (p - o_k), z_k)``
for a revolute joint, ``(z_k, 0)`` for a prismatic one. ``cos`` and ``sin``
come from one vectorised ``tan(q / 2)`` per angle, as in
:mod:`manipkit.kinematics.fk_kernel`. A base on another branch of the tree (not
above the frame) combines the two chains from the root:
``v = v_f - v_b - w_b x (p_f - p_b)``, ``w = w_f - w_b``, then turned into the
base's axes.

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

import weakref
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from manipkit.errors import ChainError, JointValueError, OptionError, SingularityError
from manipkit.kinematics.chain import frame_arguments
from manipkit.kinematics.fk_kernel import (  # the batched FK's preparation
    ChainStep,
    lazy_kernel,
    snap_placement,
    z_to_axis,
)

if TYPE_CHECKING:
    from manipkit.kinematics.robot import Robot

__all__ = [
    "GIMBAL_TOL", "JacobianProgram", "REFERENCES", "REPRESENTATIONS", "jacobian", "jacobian_columns", "jacobians",
    "mass_matrix",
    "rpy_rate_matrix",
]

REFERENCES = ("base", "local")
REPRESENTATIONS = ("geometric", "rpy")
#: ``representation="rpy"`` refuses a configuration where ``cos(pitch)`` is at most this (gimbal lock).
GIMBAL_TOL = 1e-9
BLOCK = 8192  # rows per numpy tan call
_REVOLUTE, _PRISMATIC = 0, 1


# --------------------------------------------------------------------------
# Preparing a chain: every joint about / along its local z axis


@dataclass(frozen=True)
class JacobianProgram:
    """A chain prepared for the compiled Jacobian loop (built by :meth:`from_steps`).

    ``rotations[k]``, ``translations[k]`` (k = 0..S) are the constant
    placements before joint ``k`` (the last one: before the tip), with every
    joint turned to its local z axis; ``kinds[k]`` 0 revolute, 1 prismatic;
    ``rows[k]`` the joint's row among the revolute (or prismatic) ones;
    ``columns[k]`` its column of the joint vector, ``scales[k]``,
    ``offsets[k]`` its value ``scale * q[column] + offset``.
    """

    rotations: np.ndarray  # (S + 1, 3, 3)
    translations: np.ndarray  # (S + 1, 3)
    identity: np.ndarray  # (S + 1,) bool: rotations[k] is the identity (skipped)
    kinds: np.ndarray  # (S,) int
    rows: np.ndarray  # (S,) int
    columns: np.ndarray  # (S,) int
    scales: np.ndarray  # (S,)
    offsets: np.ndarray  # (S,)
    n_joints: int

    @classmethod
    def from_steps(cls, steps: Sequence[ChainStep], n_joints: int) -> JacobianProgram:
        """Fold the fixed steps and the joints' axis rotations into one constant placement per joint."""
        rotations, translations, kinds, columns, scales, offsets = [], [], [], [], [], []
        C, t, A_prev_T = np.eye(3), np.zeros(3), np.eye(3)
        for step in steps:
            t = t + C @ np.asarray(step.translation, dtype=float)
            C = C @ np.asarray(step.rotation, dtype=float)
            if step.index < 0:
                continue
            A = z_to_axis(step.axis)
            rotations.append(A_prev_T @ C @ A)
            translations.append(A_prev_T @ t)
            kinds.append(_PRISMATIC if step.prismatic else _REVOLUTE)
            columns.append(int(step.index))
            scales.append(float(step.scale))
            offsets.append(float(step.offset))
            C, t, A_prev_T = np.eye(3), np.zeros(3), A.T
        rotations.append(A_prev_T @ C)
        translations.append(A_prev_T @ t)
        R = snap_placement(np.array(rotations).reshape(-1, 3, 3))  # a URDF rpy of 1.5707963 leaves 6e-17 where 0 is meant
        kinds_a = np.array(kinds, dtype=np.int64)
        rows = np.zeros(len(kinds), dtype=np.int64)
        rows[kinds_a == _REVOLUTE] = np.arange(int(np.sum(kinds_a == _REVOLUTE)))
        rows[kinds_a == _PRISMATIC] = np.arange(int(np.sum(kinds_a == _PRISMATIC)))
        return cls(
            np.ascontiguousarray(R), np.array(translations).reshape(-1, 3),
            np.array([np.array_equal(r, np.eye(3)) for r in R], dtype=bool), kinds_a, rows,
            np.array(columns, dtype=np.int64), np.array(scales), np.array(offsets), int(n_joints),
        )

    def run(self, Q: np.ndarray, *, local: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(J (N, 6, n), R (N, 3, 3), p (N, 3)) for the rows of ``Q`` (N, n), in the chain base's axes.

        ``local``: J in the tip frame's axes instead. ``R``, ``p`` are the tip's pose in the chain's base.
        """
        n = Q.shape[0]
        J = np.zeros((n, 6, self.n_joints))
        R = np.empty((n, 3, 3))
        p = np.empty((n, 3))
        revolute = self.kinds == _REVOLUTE
        rev_cols, pri_cols = self.columns[revolute], self.columns[~revolute]
        rev_scale, pri_scale = self.scales[revolute], self.scales[~revolute]
        rev_offset, pri_offset = self.offsets[revolute], self.offsets[~revolute]
        kernel = _kernel()
        for start in range(0, n, BLOCK):
            block = Q[start : start + BLOCK]
            tan_half = np.ascontiguousarray((block[:, rev_cols] * (0.5 * rev_scale) + 0.5 * rev_offset).T)
            np.tan(tan_half, out=tan_half)
            values = np.ascontiguousarray((block[:, pri_cols] * pri_scale + pri_offset).T)
            kernel(tan_half, values, self.rotations, self.translations, self.identity, self.kinds, self.rows,
                   self.columns, self.scales, local, J[start : start + BLOCK], R[start : start + BLOCK],
                   p[start : start + BLOCK])
        return J, R, p


def _jacobian_rows(tan_half, values, rotations, translations, identity, kinds, rows, columns, scales, local, J, R_out, p_out):
    """Fill J (zeros on entry), R_out, p_out for every configuration (compiled by numba, see :func:`_kernel`)."""
    n_steps = kinds.shape[0]
    origins = np.empty((n_steps, 3))
    axes = np.empty((n_steps, 3))
    R = np.empty((3, 3))
    tmp = np.empty((3, 3))
    p = np.empty(3)
    for n in range(J.shape[0]):
        for i in range(3):
            p[i] = 0.0
            for j in range(3):
                R[i, j] = 1.0 if i == j else 0.0
        for k in range(n_steps + 1):
            t = translations[k]
            for i in range(3):  # p <- p + R t
                p[i] += R[i, 0] * t[0] + R[i, 1] * t[1] + R[i, 2] * t[2]
            if not identity[k]:  # R <- R C
                C = rotations[k]
                for i in range(3):
                    r0, r1, r2 = R[i, 0], R[i, 1], R[i, 2]
                    for j in range(3):
                        tmp[i, j] = r0 * C[0, j] + r1 * C[1, j] + r2 * C[2, j]
                for i in range(3):
                    for j in range(3):
                        R[i, j] = tmp[i, j]
            if k == n_steps:
                break
            for i in range(3):
                origins[k, i] = p[i]
                axes[k, i] = R[i, 2]
            if kinds[k] == _REVOLUTE:  # R <- R Rz(q)
                th = tan_half[rows[k], n]
                w = 2.0 / (1.0 + th * th)
                c, s = w - 1.0, th * w
                for i in range(3):
                    x, y = R[i, 0], R[i, 1]
                    R[i, 0] = x * c + y * s
                    R[i, 1] = y * c - x * s
            else:  # p <- p + q z
                v = values[rows[k], n]
                for i in range(3):
                    p[i] += v * R[i, 2]
        for k in range(n_steps):
            col, sc = columns[k], scales[k]
            z0, z1, z2 = axes[k, 0], axes[k, 1], axes[k, 2]
            if kinds[k] == _REVOLUTE:
                d0, d1, d2 = p[0] - origins[k, 0], p[1] - origins[k, 1], p[2] - origins[k, 2]
                J[n, 0, col] += sc * (z1 * d2 - z2 * d1)
                J[n, 1, col] += sc * (z2 * d0 - z0 * d2)
                J[n, 2, col] += sc * (z0 * d1 - z1 * d0)
                J[n, 3, col] += sc * z0
                J[n, 4, col] += sc * z1
                J[n, 5, col] += sc * z2
            else:
                J[n, 0, col] += sc * z0
                J[n, 1, col] += sc * z1
                J[n, 2, col] += sc * z2
        if local:  # rows R^T v, R^T w
            for col in range(J.shape[2]):
                for h in range(2):
                    a0, a1, a2 = J[n, 3 * h, col], J[n, 3 * h + 1, col], J[n, 3 * h + 2, col]
                    for i in range(3):
                        J[n, 3 * h + i, col] = R[0, i] * a0 + R[1, i] * a1 + R[2, i] * a2
        for i in range(3):
            p_out[n, i] = p[i]
            for j in range(3):
                R_out[n, i, j] = R[i, j]


_kernel = lazy_kernel(_jacobian_rows, error_model="numpy")


# --------------------------------------------------------------------------
# Public functions

_programs: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # robot -> {(frame, base): program}


def _program(robot: Robot, frame: str, base: str | None) -> JacobianProgram:
    cache = _programs.setdefault(robot, {})
    key = (frame, base)
    if key not in cache:
        cache[key] = JacobianProgram.from_steps(robot.chain(base or robot.root_link, frame).steps, len(robot.joint_names))
    return cache[key]


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


def jacobians(robot: Robot, Q, *legacy, base: str | None = None, tip: str | None = None, reference: str = "base",
              representation: str = "geometric", gimbal_tol: float = GIMBAL_TOL, frame: str | None = None) -> np.ndarray:
    """Jacobians of ``tip`` relative to ``base`` for many configurations at once (compiled).

    Parameters
    ----------
    robot : Robot
    Q : array_like, shape (..., n)
        Joint vectors in ``robot.joint_names`` order (rad, m).
    base, tip : str, keyword-only
        Frame names (aliases ``base_link``, ``ee_link``, the defaults). ``base``
        may be any frame: above ``tip`` (one chain) or on another branch (two
        chains from the root, combined). The old ``frame=`` and positional
        ``(Q, frame, base)`` work for one release with a ``DeprecationWarning``.
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
        Rows ``vx vy vz wx wy wz`` (or ``vx vy vz roll pitch yaw`` rates).

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
    base, frame = frame_arguments("jacobians", legacy, base, tip, frame, default_base="base_link", default_tip="ee_link")
    Q = _joint_rows(robot, Q)
    lead = Q.shape[:-1]
    n = len(robot.joint_names)
    flat = np.ascontiguousarray(Q.reshape(-1, n))
    frame_name = robot.frame(frame)
    base_name = robot.frame(base)
    base_arg = None if base_name == robot.root_link else base_name
    try:
        program = _program(robot, frame_name, base_arg)
    except ChainError:  # base on another branch: combine the two chains from the root
        program = None
    local = reference == "local"
    if program is not None:
        J, R, _ = program.run(flat, local=local)
    else:
        J_f, R_f, p_f = _program(robot, frame_name, None).run(flat)
        J_b, R_b, p_b = _program(robot, base_name, None).run(flat)
        d = p_f - p_b
        J = J_f - J_b
        # v = v_f - v_b - w_b x d = v_f - v_b + d x w_b
        J[:, :3] += np.cross(d[:, :, None], J_b[:, 3:], axisa=1, axisb=1, axisc=1)
        R = np.swapaxes(R_b, -1, -2) @ R_f  # R_base_frame
        to_axes = np.swapaxes(R_f if local else R_b, -1, -2)
        J[:, :3] = to_axes @ J[:, :3]
        J[:, 3:] = to_axes @ J[:, 3:]
    if representation == "rpy":
        J[:, 3:] = rpy_rate_matrix(R, gimbal_tol=gimbal_tol) @ J[:, 3:]
    return J.reshape(*lead, 6, n)


def jacobian(robot: Robot, q=None, *legacy, base: str | None = None, tip: str | None = None, reference: str = "base",
             representation: str = "geometric", gimbal_tol: float = GIMBAL_TOL, frame: str | None = None) -> np.ndarray:
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
    base, tip = frame_arguments("jacobian", legacy, base, tip, frame, default_base="base_link", default_tip="ee_link")
    q = robot.q(q) if q is None or isinstance(q, Mapping) else q  # a dict by joint name, as Robot.jacobian takes
    q = _joint_rows(robot, q)
    if q.ndim != 1:
        raise JointValueError(f"robot '{robot.name}' needs one joint vector of {len(robot.joint_names)} values, "
                              f"got shape {q.shape}; use jacobians for many")
    return jacobians(robot, q[None], base=base, tip=tip, reference=reference, representation=representation,
                     gimbal_tol=gimbal_tol)[0]


def jacobian_columns(robot: Robot, *legacy, base: str | None = None, tip: str | None = None,
                     frame: str | None = None) -> np.ndarray:
    """The columns of the Jacobian of ``frame`` relative to ``base`` that the chain can make nonzero.

    The joints between the two frames (those moving one frame and not the
    other), in :attr:`joint_names` order. The other columns are zero at every
    configuration (a wheel, a finger, a joint above both frames): indices that
    count singular values (Yoshikawa's, the condition number) take these
    columns only, else a 5-joint arm on a 2-wheel base would read as
    singular everywhere.

    Examples
    --------
    >>> import manipkit
    >>> robot = manipkit.load("mobile_manipulator")
    >>> [robot.joint_names[i] for i in jacobian_columns(robot)]  # the arm's joints, not the wheels
    ['arm_base_joint', 'shoulder_joint', 'bottom_wrist_joint', 'elbow_joint', 'top_wrist_joint']
    """
    base, frame = frame_arguments("jacobian_columns", legacy, base, tip, frame, default_base="base_link",
                                  default_tip="ee_link")
    moving_frame = set(robot.chain(robot.root_link, frame).columns.tolist())
    moving_base = set(robot.chain(robot.root_link, base).columns.tolist())
    return np.array(sorted(moving_frame ^ moving_base), dtype=np.intp)


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
