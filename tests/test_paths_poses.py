"""Tool paths as pose stacks: files (CSV, YAML), lines and arcs, checked against hand derivations."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from manipkit.errors import InputFileError, InvalidTransformError, OptionError
from manipkit.paths import PosePath, arc_poses, interpolate_poses, line_poses, read_pose_path
from manipkit.spatial import matrix_from_axis_angle, rot_x, rot_y, rot_z, transform_from_xyz_rpy


def pose(xyz, R=None):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = np.eye(3) if R is None else R, xyz
    return T


def angle_between(Ra, Rb):
    return math.acos(np.clip((np.trace(Ra.T @ Rb) - 1.0) / 2.0, -1.0, 1.0))


# --------------------------------------------------------------------------
# files


def test_csv_with_times_reads_poses_in_any_column_order(tmp_path):
    s = math.sqrt(0.5)
    file = tmp_path / "seam.csv"
    file.write_text(f"# a seam\nt,x,y,z,qx,qy,qz,qw\n0,0.4,0,0.3,0,0,{s:.4f},{s:.4f}\n\n1.5,0.5,0.1,0.3,1,0,0,0\n")
    path = read_pose_path(file)
    assert path.t.tolist() == [0.0, 1.5]
    # quaternion (0, 0, sin 45, cos 45) is Rz(90 deg), rounded to 4 digits then normalised: exact to rounding
    np.testing.assert_allclose(path.poses[0, :3, :3], rot_z(np.pi / 2), atol=1e-12)
    np.testing.assert_allclose(path.poses[1, :3, :3], rot_x(np.pi), atol=1e-12)  # (1, 0, 0, 0) is Rx(180 deg)
    np.testing.assert_allclose(path.poses[:, :3, 3], [[0.4, 0, 0.3], [0.5, 0.1, 0.3]])
    assert path.poses.flags.writeable is False


def test_csv_without_t_has_no_times(tmp_path):
    file = tmp_path / "p.csv"
    file.write_text("x,y,z,qx,qy,qz,qw\n0,0,0,0,0,0,1\n")
    path = read_pose_path(file)
    assert path.t is None and len(path) == 1


def test_yaml_quat_and_rpy_waypoints(tmp_path):
    file = tmp_path / "p.yaml"
    file.write_text("- {xyz: [0.1, 0, 0], quat: [0, 0, 0, 1], t: 0}\n- {xyz: [0.2, 0, 0], rpy: [0.1, 0.2, 0.3], t: 2}\n")
    path = read_pose_path(file)
    np.testing.assert_allclose(path.poses[1, :3, :3], rot_z(0.3) @ rot_y(0.2) @ rot_x(0.1),
                               atol=1e-15)
    assert path.t.tolist() == [0.0, 2.0]


@pytest.mark.parametrize(("suffix", "text", "message"), [
    ("csv", "x,y,z,qx,qy,qz,qw\n0,0,nan,0,0,0,1\n", "line 2 (waypoint 0): z is nan, not a finite number"),
    ("csv", "x,y,z,qx,qy,qz,qw\n0,0,0,0,0,0,1\n0,0,0,0,0,0,2\n", "line 3 (waypoint 1): the quaternion"),
    ("csv", "x,y,z,qx,qy,qz,qw\n0,0,0,0,0,0,0\n", "norm 0, not a rotation"),
    ("csv", "x,y,z,qx,qy,qz,qw,t\n0,0,0,0,0,0,1,1\n0,0,0,0,0,0,1,1\n", "line 3 (waypoint 1): t = 1 s is not after"),
    ("csv", "x,y,z,qx,qy,qz\n0,0,0,0,0,0\n", "no column qw"),
    ("csv", "x,y,z,qx,qy,qz,qw,speed\n", "unknown column 'speed'"),
    ("csv", "x,y,z,qx,qy,qz,qw\n0,0,0,0,0,1\n", "line 2 (waypoint 0): 6 values; the header has 7 columns"),
    ("csv", "x,y,z,qx,qy,qz,qw\n0,0,abc,0,0,0,1\n", "z is 'abc', not a number"),
    ("csv", "x,y,z,qx,qy,qz,qw\n", "no waypoint"),
    ("csv", "x,y,z,qx,qy,qz,qw\n2e6,0,0,0,0,0,1\n", "a position of 2e+06 m"),
    ("yaml", "- {xyz: [0, 0, 0]}\n", "waypoint 0: neither quat nor rpy"),
    ("yaml", "- {xyz: [0, 0, 0], quat: [0, 0, 0, 1], rpy: [0, 0, 0]}\n", "both quat and rpy"),
    ("yaml", "- {xyz: [0, 0, .nan], quat: [0, 0, 0, 1]}\n", "waypoint 0: xyz: nan is not a finite number"),
    ("yaml", "- {xyz: [0, 0, 0], quat: [0, 0, 0, 1], t: 0}\n- {xyz: [0, 0, 0], quat: [0, 0, 0, 1]}\n", "t given on some"),
    ("yaml", "- {xyz: [0, 0, 0], quat: [0, 0, 0, 1]}\n- {xyz: [0, 0], quat: [0, 0, 0, 1]}\n", "waypoint 1: xyz: give 3 numbers"),
    ("yaml", "- {xyz: [0, 0, 0], quat: [0, 0, 1, 1]}\n", "waypoint 0: the quaternion"),
    ("yaml", "- {xyz: [0, 0, 0], rpy: [0, 0, 1], t: 1}\n- {xyz: [0, 0, 0], rpy: [0, 0, 1], t: 0.5}\n", "waypoint 1: t = 0.5"),
    ("yaml", "a: [1\n", "malformed YAML"),
    ("yaml", "{x: 1}\n", "expected a list of waypoints"),
    ("yaml", "[]\n", "no waypoint"),
])
def test_bad_file_is_one_line_naming_the_waypoint(tmp_path, suffix, text, message):
    file = tmp_path / f"bad.{suffix}"
    file.write_text(text)
    with pytest.raises(InputFileError) as info:
        read_pose_path(file)
    assert message in str(info.value) and "\n" not in str(info.value)


def test_quaternion_within_the_stated_tolerance_is_normalised(tmp_path):
    file = tmp_path / "p.csv"
    file.write_text("x,y,z,qx,qy,qz,qw\n0,0,0,0,0,0.71,0.71\n")  # squared norm 1.0082: within 0.01
    R = read_pose_path(file).poses[0, :3, :3]
    np.testing.assert_allclose(R, rot_z(np.pi / 2), atol=1e-12)


def test_huge_file_is_refused_before_reading(tmp_path):
    file = tmp_path / "huge.csv"
    with open(file, "wb") as stream:  # a sparse file of 1.4 GB: 10^8 rows of "0,0,0,0,0,0,1\n"
        stream.truncate(10**8 * 14)
    with pytest.raises(InputFileError, match="above the limit"):
        read_pose_path(file)


def test_fifo_is_refused(tmp_path):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    with pytest.raises(InputFileError, match="FIFO"):
        read_pose_path(fifo)


# --------------------------------------------------------------------------
# PosePath from arrays


def test_pose_path_refuses_a_non_rotation_naming_the_index():
    poses = np.stack([np.eye(4)] * 3)
    poses[2, :3, :3] = np.diag([1.0, 1.0, -1.0])
    with pytest.raises(InvalidTransformError, match=r"poses\[2\] is not a rigid transform: det\(R\) = -1"):
        PosePath(poses)


def test_pose_path_refuses_nan_and_bad_times():
    poses = np.stack([np.eye(4)] * 3)
    bad = poses.copy()
    bad[1, 0, 3] = np.nan
    with pytest.raises(InvalidTransformError, match=r"poses\[1\]"):
        PosePath(bad)
    with pytest.raises(OptionError, match=r"t\[2\] = 1 s is not after t\[1\] = 1 s"):
        PosePath(poses, t=[0, 1, 1])
    with pytest.raises(OptionError, match=r"one time per waypoint, shape \(3,\)"):
        PosePath(poses, t=[0, 1])


def test_hundred_million_waypoints_are_refused_before_allocation():
    with pytest.raises(OptionError, match="give a whole number from 1 to 10000000"):
        line_poses(np.eye(4), transform_from_xyz_rpy([1, 0, 0]), step=1e-8)  # 10^8 + 1 poses


# --------------------------------------------------------------------------
# lines and arcs


def test_line_spacing_and_ends():
    T0 = pose([0.4, -0.2, 0.3], rot_x(np.pi))
    T1 = pose([0.4, 0.25, 0.3], rot_x(np.pi) @ rot_z(0.6))
    T = line_poses(T0, T1, step=0.01, angle_step=0.01)
    # 0.45 m at 0.01 m needs 45 intervals; 0.6 rad at 0.01 rad needs 60: the finer one wins
    assert len(T) == 61
    np.testing.assert_allclose(T[0], T0, atol=1e-15)
    np.testing.assert_allclose(T[-1], T1, atol=1e-14)
    steps = np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1)
    np.testing.assert_allclose(steps, 0.45 / 60, rtol=1e-9)
    angles = [angle_between(T[i, :3, :3], T[i + 1, :3, :3]) for i in range(60)]
    np.testing.assert_allclose(angles, 0.01, atol=1e-7)  # acos loses half the digits near 1
    # on the line: every position is p0 + s (p1 - p0)
    np.testing.assert_allclose(T[:, [0, 2], 3], np.broadcast_to([0.4, 0.3], (61, 2)), atol=1e-15)


def test_line_with_equal_ends_is_one_pose():
    T0 = transform_from_xyz_rpy([0.1, 0.2, 0.3], [0.1, 0.2, 0.3])
    assert line_poses(T0, T0, step=0.01).shape == (1, 4, 4)


@pytest.mark.parametrize("step", [0, -0.1, float("nan"), "x"])
def test_line_bad_step_is_one_line(step):
    with pytest.raises(OptionError, match="step"):
        line_poses(np.eye(4), transform_from_xyz_rpy([1, 0, 0]), step=step)


def test_slerp_is_constant_rate_about_one_axis():
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    T1 = pose([0, 0, 0], matrix_from_axis_angle(axis, 2.5))
    T = interpolate_poses(np.eye(4), T1, [0.2, 0.6])
    np.testing.assert_allclose(T[0, :3, :3], matrix_from_axis_angle(axis, 0.5), atol=1e-14)
    np.testing.assert_allclose(T[1, :3, :3], matrix_from_axis_angle(axis, 1.5), atol=1e-14)


def test_arc_lies_on_the_circle_through_three_points():
    # circle of radius 0.2 about (0.5, 0, 0.3) in a tilted plane; three points on it by hand
    centre, r = np.array([0.5, 0.0, 0.3]), 0.2
    e1, e2 = np.array([1.0, 0.0, 0.0]), np.array([0.0, math.sqrt(0.5), math.sqrt(0.5)])

    def at(theta):
        return centre + r * (math.cos(theta) * e1 + math.sin(theta) * e2)

    R0, Rv, R1 = rot_x(np.pi), rot_x(np.pi) @ rot_z(0.4), rot_x(np.pi) @ rot_z(1.0)
    T = arc_poses(pose(at(0.0), R0), pose(at(1.0), Rv), pose(at(2.5), R1), step=0.01)
    np.testing.assert_allclose(np.linalg.norm(T[:, :3, 3] - centre, axis=1), r, atol=1e-12)
    np.testing.assert_allclose((T[:, :3, 3] - centre) @ np.cross(e1, e2), 0.0, atol=1e-12)
    # arc lengths 0.2 and 0.3 m at most 0.01 apart: 20 and 30 intervals, the via pose among them
    assert len(T) == 51
    np.testing.assert_allclose(T[20, :3, 3], at(1.0), atol=1e-15)
    np.testing.assert_allclose(T[20, :3, :3], Rv, atol=1e-14)
    np.testing.assert_allclose(T[-1, :3, :3], R1, atol=1e-14)
    chords = np.linalg.norm(np.diff(T[:, :3, 3], axis=0), axis=1)
    np.testing.assert_allclose(chords, 2 * r * math.sin(0.05 / 2), rtol=1e-9)  # 0.01 m of arc is 0.05 rad


def test_arc_through_collinear_points_is_refused():
    with pytest.raises(OptionError, match="collinear"):
        arc_poses(pose([0, 0, 0]), pose([0.1, 0.1, 0.1]), pose([0.3, 0.3, 0.3]), step=0.01)
    with pytest.raises(OptionError, match="T0 and T1 are the same"):
        arc_poses(pose([0, 0, 0]), pose([0.1, 0, 0]), pose([0, 0, 0]), step=0.01)


def test_pose_steps_equal_each_step_alone():
    # interpolate_pose_steps (all steps at once, as the path check takes them) against interpolate_poses step by
    # step: the same bits.
    import manipkit
    from manipkit.paths.poses import interpolate_pose_steps

    chain = manipkit.load("ur5").chain("base_link", "tool0")
    T = chain.fk(chain.sample(40, seed=5))
    s = np.arange(1, 16) / 16
    together = interpolate_pose_steps(T, np.arange(39), s)
    assert together.shape == (39, 15, 4, 4)
    for i in range(39):
        assert np.array_equal(together[i], interpolate_poses(T[i], T[i + 1], s))
