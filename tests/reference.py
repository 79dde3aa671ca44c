"""Independent reference kinematics for the tests, written out from ../shared/reference/.

Nothing here uses manipkit or Pinocchio: chains are composed with numpy from
the joint tables, copied below as literal numbers, so that the tests compare
two independent sources and a wrong number in a description shows up.

Conventions (DESIGN.md): metres and radians; T_a_b is the pose of frame b in
frame a; URDF rpy means R = Rz(yaw) Ry(pitch) Rx(roll); a joint's transform is
T_parent_child(q) = T_origin @ Rot(axis, q).
"""

import math

import numpy as np

# --------------------------------------------------------------------------
# Independent transform helpers (numpy only)
# --------------------------------------------------------------------------


def rot_x(angle):
    """(3, 3) rotation by `angle` radians about x."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(angle):
    """(3, 3) rotation by `angle` radians about y."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(angle):
    """(3, 3) rotation by `angle` radians about z."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def matrix_from_rpy(roll, pitch, yaw):
    """(3, 3) URDF rpy: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    return rot_z(yaw) @ rot_y(pitch) @ rot_x(roll)


def matrix_from_axis_angle(axis, angle):
    """(3, 3) rotation by `angle` about the unit vector `axis` (Rodrigues)."""
    x, y, z = axis
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * (K @ K)


def homogeneous(R=None, p=(0.0, 0.0, 0.0)):
    """(4, 4) homogeneous transform from a rotation and a translation."""
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    T[:3, 3] = p
    return T


def translation(x, y, z):
    """(4, 4) pure translation."""
    return homogeneous(p=(x, y, z))


def urdf_origin(xyz, rpy):
    """(4, 4) T_parent_jointframe of a URDF <origin xyz rpy>."""
    return homogeneous(matrix_from_rpy(*rpy), xyz)


def compose_chain(joint_table, q):
    """T_first-parent_last-child of a serial chain of revolute/continuous joints.

    joint_table rows are (origin xyz, origin rpy, axis); q has one angle a row.
    """
    T = np.eye(4)
    for (xyz, rpy, axis), angle in zip(joint_table, q, strict=True):
        T = T @ urdf_origin(xyz, rpy) @ homogeneous(matrix_from_axis_angle(axis, angle))
    return T


# --------------------------------------------------------------------------
# Reference tables, as literal numbers
# --------------------------------------------------------------------------

# course_arm.md, "Joints": (origin xyz, origin rpy, axis). 1.5708 is the
# course file's literal value, deliberately not pi/2.
COURSE_ARM_JOINT_NAMES = [
    "arm_base_joint",
    "shoulder_joint",
    "bottom_wrist_joint",
    "elbow_joint",
    "top_wrist_joint",
]
COURSE_ARM_JOINTS = [
    ((0.0, 0.0, 0.1), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),  # base_link -> arm_base
    ((-0.05166, 0.0, 0.20271), (0.0, 0.0, 1.5708), (0.0, 1.0, 0.0)),  # arm_base -> bicep
    ((0.0, -0.05194, 0.269), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0)),  # bicep -> bottom_wrist
    ((0.0, 0.0, 0.13522), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),  # bottom_wrist -> elbow
    ((0.0, 0.0, 0.20994), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0)),  # elbow -> top_wrist
]
# The project's tool frame: fixed ee_link at the tip of top_wrist.
T_TOP_WRIST_EE_LINK = translation(0.0, 0.0, 0.13522)

# course_arm.md, "Joint values the seed document used with the sliders".
COURSE_ARM_POSES = {
    "zero": (0.0, 0.0, 0.0, 0.0, 0.0),
    "A": (0.0, -1.34, -2.56, -1.15, -0.06),
    "B": (0.0, -1.75, -1.57, -0.60, 1.45),
}

# iiwa14.md: iiwa_link_0 -> ... -> iiwa_link_7, every axis 0 0 1.
PI = math.pi
IIWA_JOINT_NAMES = [f"iiwa_joint_{i}" for i in range(1, 8)]
IIWA_JOINTS = [
    ((0.0, 0.0, 0.1575), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    ((0.0, 0.0, 0.2025), (PI / 2, 0.0, PI), (0.0, 0.0, 1.0)),
    ((0.0, 0.2045, 0.0), (PI / 2, 0.0, PI), (0.0, 0.0, 1.0)),
    ((0.0, 0.0, 0.2155), (PI / 2, 0.0, 0.0), (0.0, 0.0, 1.0)),
    ((0.0, 0.1845, 0.0), (-PI / 2, PI, 0.0), (0.0, 0.0, 1.0)),
    ((0.0, 0.0, 0.2155), (PI / 2, 0.0, 0.0), (0.0, 0.0, 1.0)),
    ((0.0, 0.081, 0.0), (-PI / 2, PI, 0.0), (0.0, 0.0, 1.0)),
]
# Symmetric limits, radians, as printed in iiwa14.md (170/120/.../175 deg).
IIWA_LIMITS = [2.96706, 2.09440, 2.96706, 2.09440, 2.96706, 2.09440, 3.05433]
IIWA_LIMITS_DEG = [170, 120, 170, 120, 170, 120, 175]
# media flange, 0.045 m along iiwa_link_7's z
T_IIWA_LINK_7_EE_LINK = translation(0.0, 0.0, 0.045)

# robots/mobile_manipulator.urdf.xacro, its geometry properties:
WHEEL_RADIUS = 0.05  # base_link sits on the wheel axle, this high above base_footprint
CHASSIS_HEIGHT = 0.1  # the deck is this high above base_link
WHEEL_X, WHEEL_Y = 0.08, 0.15 + 0.02 + 0.005  # half chassis width + half wheel width + gap
LIDAR_X, LIDAR_SCAN_HEIGHT = 0.15, 0.03  # front of the deck; scan plane above the deck
ARM_X = -0.05  # arm_base on the deck, on the centre line, behind the centre
T_BASE_FOOTPRINT_BASE_LINK = translation(0.0, 0.0, WHEEL_RADIUS)
T_BASE_LINK_LIDAR_LINK = translation(LIDAR_X, 0.0, CHASSIS_HEIGHT + LIDAR_SCAN_HEIGHT)
# The arm on the deck: the course table with arm_base_joint's origin replaced
# by the mount on base_link.
MOBILE_ARM_JOINTS = [
    ((ARM_X, 0.0, CHASSIS_HEIGHT), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
] + COURSE_ARM_JOINTS[1:]


POSE_A = COURSE_ARM_POSES["A"]
POSE_B = COURSE_ARM_POSES["B"]


def course_arm_T_base_top_wrist(q):
    """T_base_link_top_wrist of the course arm at joint angles q (5,)."""
    return compose_chain(COURSE_ARM_JOINTS, q)


def course_arm_T_base_ee(q):
    """T_base_link_ee_link of the course arm at joint angles q (5,)."""
    return course_arm_T_base_top_wrist(q) @ T_TOP_WRIST_EE_LINK
