"""Euler angles: ZYX ``(yaw, pitch, roll)`` and ZYZ ``(phi, theta, psi)`` (Spong, for spherical wrists).

Conventions (docs/architecture.md), restated where they matter: angles in
radians; Euler ZYX ``(alpha, beta, gamma)`` means ``R = Rz(alpha) Ry(beta)
Rx(gamma)``, the same rotation as roll-pitch-yaw (URDF ``rpy``) with the
triple reversed; Euler ZYZ ``(phi, theta, psi)`` means ``R = Rz(phi) Ry(theta)
Rz(psi)``. Every function works on stacks (leading dimensions carried
through), and the inverse conversions use ``atan2`` only, so they stay
accurate at their singular sets (see each function's Notes).

Only numpy is imported, so this module loads fast.
"""

from __future__ import annotations

import numpy as np

from manipkit.spatial.rotations import (
    as_rotation_matrices,
    check_rotation,
    matrix_from_rpy,
    rpy_from_matrix,
    vectors_or_parts,
    wrap_angle,
)

__all__ = [
    "euler_zyx_from_matrix",
    "euler_zyz_from_matrix",
    "matrix_from_euler_zyx",
    "matrix_from_euler_zyz",
]


def matrix_from_euler_zyx(ypr, pitch=None, roll=None) -> np.ndarray:
    """Rotation matrix from Euler ZYX angles: ``matrix_from_euler_zyx([yaw, pitch, roll])`` or ``(yaw, pitch, roll)``.

    Parameters
    ----------
    ypr : array_like, shape (..., 3)
        ``(alpha, beta, gamma)`` = ``(yaw, pitch, roll)`` in radians, with
        ``R = Rz(alpha) @ Ry(beta) @ Rx(gamma)``: rotate about z, then about
        the new y, then about the newest x. This is the same rotation as
        roll-pitch-yaw (URDF ``rpy``) with the triple reversed, so
        ``matrix_from_euler_zyx([a, b, c]) == matrix_from_rpy([c, b, a])``.
        Or the yaw alone, when ``pitch`` and ``roll`` are given.
    pitch, roll : array_like, optional
        The other two angles as separate arguments (broadcast together).

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
        With ``c_a = cos(alpha)`` etc.::

            [[c_a c_b,  c_a s_b s_g - s_a c_g,  c_a s_b c_g + s_a s_g],
             [s_a c_b,  s_a s_b s_g + c_a c_g,  s_a s_b c_g - c_a s_g],
             [ -s_b,           c_b s_g,                c_b c_g      ]]

    Examples
    --------
    >>> matrix_from_euler_zyx([np.pi / 2, 0.0, np.pi / 2]).round(12) + 0.0
    array([[0., 0., 1.],
           [1., 0., 0.],
           [0., 1., 0.]])
    """
    ypr = vectors_or_parts(ypr, {"pitch": pitch, "roll": roll}, "ypr")
    return matrix_from_rpy(ypr[..., ::-1])


def euler_zyx_from_matrix(R, *, gimbal_tol: float = 1e-12, check: bool = True, tol: float = 1e-6) -> np.ndarray:
    """Euler ZYX angles ``(yaw, pitch, roll)`` of a rotation matrix.

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrix.
    gimbal_tol : float, keyword-only
        Where ``cos(beta) <= gimbal_tol`` the rotation is treated as
        gimbal-locked (see Notes); the angles then reproduce ``R`` to about
        ``2 * gimbal_tol``, elsewhere to rounding error.
    check : bool, keyword-only
        Validate ``R`` with :func:`~manipkit.spatial.rotations.check_rotation` first (default).
    tol : float, keyword-only
        Tolerance of that check.

    Returns
    -------
    ypr : ndarray, shape (..., 3)
        ``(alpha, beta, gamma)`` = ``(yaw, pitch, roll)`` in radians with
        ``R = Rz(alpha) Ry(beta) Rx(gamma)``; alpha and gamma in (-pi, pi],
        beta in [-pi/2, pi/2]. Equal to ``rpy_from_matrix(R)[..., ::-1]``.

    Notes
    -----
    Away from the singularity ``alpha = atan2(r21, r11)``,
    ``beta = atan2(-r31, hypot(r32, r33))`` and ``gamma = atan2(r32, r33)``
    (1-based entries ``r_ij``).

    At ``beta = +-90 deg`` (gimbal lock) ``r11 = r21 = r32 = r33 = 0`` and
    only a combination of alpha and gamma is determined::

        beta = +90 deg:  R = [[0, -sin(alpha - gamma), cos(alpha - gamma)],
                              [0,  cos(alpha - gamma), sin(alpha - gamma)],
                              [-1,         0,                  0         ]]
        beta = -90 deg:  R = [[0, -sin(alpha + gamma), -cos(alpha + gamma)],
                              [0,  cos(alpha + gamma), -sin(alpha + gamma)],
                              [1,          0,                   0         ]]

    This function then returns ``gamma = 0`` (roll = 0, as
    :func:`~manipkit.spatial.rotations.rpy_from_matrix` does) and ``alpha = atan2(-r12, r22)``, which is
    ``alpha - gamma`` at +90 deg and ``alpha + gamma`` at -90 deg. (Some
    course notes set ``alpha = 0`` instead and put the angle in gamma; both
    describe the same rotation.)

    Examples
    --------
    >>> from manipkit.spatial.rotations import rot_x, rot_y, rot_z
    >>> euler_zyx_from_matrix(rot_z(0.3) @ rot_y(0.2) @ rot_x(0.1)).round(12)
    array([0.3, 0.2, 0.1])
    >>> euler_zyx_from_matrix(rot_z(0.5) @ rot_y(np.pi / 2) @ rot_x(0.2)).round(12) + 0.0  # alpha - gamma
    array([0.3       , 1.57079633, 0.        ])
    """
    return rpy_from_matrix(R, gimbal_tol=gimbal_tol, check=check, tol=tol)[..., ::-1]


def matrix_from_euler_zyz(angles, theta=None, psi=None) -> np.ndarray:
    """Rotation matrix from Euler ZYZ angles (Spong): ``matrix_from_euler_zyz([phi, theta, psi])`` or ``(phi, theta, psi)``.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        ``(phi, theta, psi)`` in radians with
        ``R = Rz(phi) @ Ry(theta) @ Rz(psi)``: rotate about z, then about the
        new y, then about the newest z. The orientation of a spherical wrist
        whose three axes are z, y, z. Or phi alone, when ``theta`` and ``psi`` are given.
    theta, psi : array_like, optional
        The other two angles as separate arguments (broadcast together).

    Returns
    -------
    R : ndarray, shape (..., 3, 3)
        With ``c_f = cos(phi)``, ``c_t = cos(theta)``, ``c_p = cos(psi)``::

            [[c_f c_t c_p - s_f s_p,  -c_f c_t s_p - s_f c_p,  c_f s_t],
             [s_f c_t c_p + c_f s_p,  -s_f c_t s_p + c_f c_p,  s_f s_t],
             [       -s_t c_p,                s_t s_p,            c_t ]]

    Examples
    --------
    >>> matrix_from_euler_zyz([0.0, np.pi / 2, 0.0]).round(12) + 0.0  # Ry(90 deg)
    array([[ 0.,  0.,  1.],
           [ 0.,  1.,  0.],
           [-1.,  0.,  0.]])
    """
    angles = vectors_or_parts(angles, {"theta": theta, "psi": psi}, "angles")
    cf, ct, cp = np.cos(angles[..., 0]), np.cos(angles[..., 1]), np.cos(angles[..., 2])
    sf, st, sp = np.sin(angles[..., 0]), np.sin(angles[..., 1]), np.sin(angles[..., 2])
    R = np.empty(angles.shape[:-1] + (3, 3))
    R[..., 0, 0] = cf * ct * cp - sf * sp
    R[..., 0, 1] = -cf * ct * sp - sf * cp
    R[..., 0, 2] = cf * st
    R[..., 1, 0] = sf * ct * cp + cf * sp
    R[..., 1, 1] = -sf * ct * sp + cf * cp
    R[..., 1, 2] = sf * st
    R[..., 2, 0] = -st * cp
    R[..., 2, 1] = st * sp
    R[..., 2, 2] = ct
    return R


# Over 80 lines because of the docstring: both branches and the singular set are stated in full.
def euler_zyz_from_matrix(
    R,
    *,
    theta_negative: bool = False,
    gimbal_tol: float = 1e-12,
    check: bool = True,
    tol: float = 1e-6,
) -> np.ndarray:
    """Euler ZYZ angles ``(phi, theta, psi)`` of a rotation matrix (Spong).

    Parameters
    ----------
    R : array_like, shape (..., 3, 3)
        Rotation matrix.
    theta_negative : bool, keyword-only
        Which of the two solutions to return. Every rotation off the singular
        set has two: ``(phi, theta, psi)`` with theta in (0, pi) (default) and
        ``(phi + pi, -theta, psi + pi)`` with theta in (-pi, 0) (``True``).
        Spherical-wrist IK needs both (wrist flipped or not).
    gimbal_tol : float, keyword-only
        Where ``|sin(theta)| <= gimbal_tol`` the rotation is treated as
        singular (see Notes); the angles then reproduce ``R`` to about
        ``2 * gimbal_tol``, elsewhere to rounding error.
    check : bool, keyword-only
        Validate ``R`` with :func:`~manipkit.spatial.rotations.check_rotation` first (default).
    tol : float, keyword-only
        Tolerance of that check.

    Returns
    -------
    angles : ndarray, shape (..., 3)
        ``(phi, theta, psi)`` in radians with ``R = Rz(phi) Ry(theta) Rz(psi)``;
        phi and psi in (-pi, pi]; theta in [0, pi], or in [-pi, 0] with
        ``theta_negative=True``.

    Notes
    -----
    With 1-based entries ``r_ij``, the default solution is
    ``theta = atan2(hypot(r31, r32), r33)``, ``psi = atan2(r32, -r31)`` and
    ``phi`` read from ``R Rz(psi)^T = Rz(phi) Ry(theta)``, whose second
    column is ``(-sin phi, cos phi, 0)`` for every theta (equal to
    ``atan2(r23, r13)`` off the singular set, but never divided by
    ``sin(theta)``).

    At ``theta = 0`` and ``theta = pi`` the two z rotations line up and only
    their sum or difference is determined::

        theta = 0:   R = Rz(phi + psi)
                       = [[cos(phi + psi), -sin(phi + psi), 0],
                          [sin(phi + psi),  cos(phi + psi), 0],
                          [      0,               0,        1]]
        theta = pi:  R = Rz(phi - psi) Ry(pi)
                       = [[-cos(phi - psi), -sin(phi - psi),  0],
                          [-sin(phi - psi),  cos(phi - psi),  0],
                          [       0,                0,       -1]]

    This function then returns ``psi = 0`` and ``phi = atan2(-r12, r22)``,
    which is ``phi + psi`` at theta = 0 and ``phi - psi`` at theta = pi, in
    both branches (the negative branch has theta = 0 or -pi there).

    Examples
    --------
    >>> from manipkit.spatial.rotations import rot_y, rot_z
    >>> R = rot_z(0.3) @ rot_y(0.2) @ rot_z(0.1)
    >>> euler_zyz_from_matrix(R).round(12)
    array([0.3, 0.2, 0.1])
    >>> euler_zyz_from_matrix(R, theta_negative=True).round(6)  # (0.3 - pi, -0.2, 0.1 - pi)
    array([-2.841593, -0.2     , -3.041593])
    >>> euler_zyz_from_matrix(rot_z(0.4) @ rot_z(0.5)).round(12)  # theta = 0: phi + psi
    array([0.9, 0. , 0. ])
    """
    # Over 80 lines: the docstring (convention, singular cases, examples) is most of it.
    R = check_rotation(R, tol=tol) if check else as_rotation_matrices(R)
    sin_theta = np.hypot(R[..., 2, 0], R[..., 2, 1])
    singular = sin_theta <= gimbal_tol
    theta = np.arctan2(sin_theta, R[..., 2, 2])
    psi = np.where(singular, 0.0, np.arctan2(R[..., 2, 1], -R[..., 2, 0]))
    cp, sp = np.cos(psi), np.sin(psi)
    # second column of R @ Rz(psi).T is (-sin phi, cos phi, 0)
    phi = np.arctan2(-(R[..., 0, 0] * sp + R[..., 0, 1] * cp), R[..., 1, 0] * sp + R[..., 1, 1] * cp)
    if theta_negative:
        # Rz(phi + pi) Ry(-theta) Rz(psi + pi) = Rz(phi) [Rz(pi) Ry(-theta) Rz(pi)] Rz(psi) = R,
        # since turning the y axis half a turn about z reverses it
        flip = np.where(singular, 0.0, np.pi)
        phi, theta, psi = phi + flip, -theta, psi + flip
    return np.stack([wrap_angle(phi), theta + 0.0, wrap_angle(psi)], axis=-1)
