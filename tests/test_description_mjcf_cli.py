"""Every command on an MJCF arm, run as a user runs it; answers checked against MuJoCo and the ROS UR5e.

The independent sources: MuJoCo's own ``mj_kinematics`` and ``mj_jacBody``
on the same file (meshes deleted, see tests/test_description_mjcf.py), and
the UR5e URDF of the shared ROS workspace for ``ik --all``.

UR5e frames, MuJoCo Menagerie vs ros-industrial ``ur_description`` (found
by fitting, checked below on 100 configurations): the joints agree in
order, zero pose and sign; ROS ``base_link`` is MuJoCo's ``world`` turned
-90 deg about z (``T_base_link_world = Rz(-pi/2)``); ROS ``tool0`` is
MuJoCo's ``wrist_3_link`` moved 0.0996 m along its y axis (the wrist-3 axis)
and turned -90 deg about x (``T_wrist_3_link_tool0 = Trans(0, 0.0996, 0)
Rx(-pi/2)``). Menagerie's lengths are rounded: d1 0.163 (ROS 0.1625), a3
0.392 (0.3922), d4 0.134 (0.1333), d5 0.1 (0.0997), so the two models' tool
frames differ by up to 1 mm (0.97 mm on 100 configurations) and their ``ik --all`` solutions by up to
0.05 rad (0.033 rad measured on three targets). The same file with ROS's lengths
(:func:`ros_lengths`) agrees with the URDF to 1e-9 (ROS rounds pi/2 to
1.570796327 in two joint origins, 3.3e-10 off), and there ``ik --all`` gives
the URDF's solutions.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
from cli_helper import run_cli
from test_description_mjcf import MENAGERIE, mujoco_model, needs_menagerie

import manipkit
from manipkit.spatial import quaternion_from_matrix, rot_x, rot_z

UR5E = MENAGERIE / "universal_robots_ur5e" / "ur5e.xml"
IIWA = MENAGERIE / "kuka_iiwa_14" / "iiwa14.xml"
ROS_UR5E = MENAGERIE.parent / "ws_ros1" / "src" / "universal_robot" / "ur_description" / "urdf" / "ur5e.xacro"
T_BASE_LINK_WORLD = np.eye(4)
T_BASE_LINK_WORLD[:3, :3] = rot_z(-math.pi / 2)
T_WRIST_3_TOOL0 = np.eye(4)
T_WRIST_3_TOOL0[:3, :3] = rot_x(-math.pi / 2)
T_WRIST_3_TOOL0[:3, 3] = [0.0, 0.0996, 0.0]
#: Menagerie's rounded UR5e lengths -> ROS's (ur_description config/ur5e/default_kinematics.yaml values)
ROS_LENGTHS = [('pos="0 0 0.163"', 'pos="0 0 0.1625"'), ('pos="0 0 0.392"', 'pos="0 0 0.3922"'),
               ('name="wrist_2_link" pos="0 0.127 0"', 'name="wrist_2_link" pos="0 0.1263 0"'),  # d4 0.138-0.131+0.1263
               ('name="wrist_3_link" pos="0 0 0.1"', 'name="wrist_3_link" pos="0 0 0.0997"')]

pytestmark = needs_menagerie


@pytest.fixture(scope="module")
def ros_lengths(tmp_path_factory) -> Path:
    """Menagerie's ur5e.xml with ROS's link lengths (everything else as published)."""
    text = UR5E.read_text()
    for old, new in ROS_LENGTHS:
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    path = tmp_path_factory.mktemp("ur5e") / "ur5e.xml"
    path.write_text(text)
    return path


def mujoco_at(path, q: dict):
    model = mujoco_model(path)
    data = mujoco.MjData(model)
    for name, value in q.items():
        data.qpos[model.jnt_qposadr[model.joint(name).id]] = value
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    return model, data


def q_args(q: dict) -> list[str]:
    return [f"{k}={v!r}" for k, v in q.items()]


Q = {"shoulder_pan_joint": 0.3, "shoulder_lift_joint": -1.1, "elbow_joint": 1.4, "wrist_1_joint": -0.6,
     "wrist_2_joint": 0.9, "wrist_3_joint": 2.2}


def test_tf_between_is_mujocos_pose():
    shown = json.loads(run_cli("tf-between", "world", "wrist_3_link", "--robot", UR5E, "--q", *q_args(Q),
                               "--format", "json", status=0).stdout)
    model, data = mujoco_at(UR5E, Q)
    b = model.body("wrist_3_link").id
    np.testing.assert_allclose(np.array(shown["matrix"])[:3, 3], data.xpos[b], atol=1e-12)
    np.testing.assert_allclose(np.array(shown["matrix"])[:3, :3], data.xmat[b].reshape(3, 3), atol=1e-12)


def test_tree_shows_every_body_and_joint():
    out = run_cli("manipkit", "tree", "--robot", UR5E, status=0).stdout
    model = mujoco_model(UR5E)
    for b in range(1, model.nbody):
        assert model.body(b).name in out
    assert "7 joints: 6 revolute, 1 fixed" in out  # six hinges, and the base body on the world


def test_frames_lists_bodies_and_sites_and_says_which_is_ee_link():
    out = run_cli("manipkit", "frames", "--robot", IIWA, status=0).stdout
    model = mujoco_model(IIWA)
    listed = out.split("frames: ", 1)[1].splitlines()[0].split(", ")
    assert listed == ["world", *(model.body(b).name for b in range(1, model.nbody)), "attachment_site"]
    assert "ee_link = attachment_site, named like an arm tool frame" in out


def test_jacobian_is_mujocos_body_jacobian():
    shown = json.loads(run_cli("manipkit", "jacobian", "--robot", UR5E, "--base", "world", "--frame", "wrist_3_link",
                               "--q", *q_args(Q), "--format", "json", status=0).stdout)
    model, data = mujoco_at(UR5E, Q)
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    b = model.body("wrist_3_link").id
    mujoco.mj_jac(model, data, jacp, jacr, data.xpos[b], b)  # the body origin's velocity, world axes
    order = [model.jnt_dofadr[model.joint(name).id] for name in shown["joints"]]
    np.testing.assert_allclose(np.array(shown["jacobian"]), np.vstack([jacp, jacr])[:, order], atol=1e-12)


def test_family_finds_the_ur_geometry():
    out = run_cli("manipkit", "family", "--robot", UR5E, status=0).stdout
    assert "family: three parallel, two intersecting" in out


def ik_all(robot, base, tip, T) -> list[np.ndarray]:
    x, y, z, w = quaternion_from_matrix(T[:3, :3])
    # the branches (--no-aliases): the same eight on both descriptions, whatever their joint ranges allow
    shown = json.loads(run_cli("manipkit", "ik", "--all", "--no-aliases", "--robot", robot, "--base", base, "--frame", tip,
                               "--xyz", *T[:3, 3], "--quat", x, y, z, w, "--format", "json", status=0).stdout)
    return [np.array(list(solution.values())) for solution in shown["solutions"]]


def test_ur5e_frames_differ_from_ros_by_the_fixed_transforms(ros_lengths):
    ros, exact, menagerie = manipkit.load(ROS_UR5E), manipkit.load(ros_lengths), manipkit.load(UR5E)
    assert ros.joint_names == exact.joint_names == menagerie.joint_names
    worst = {"exact": 0.0, "menagerie": 0.0}
    for q in ros.sample_q(100, seed=5):
        T_ros = ros.transform("base_link", "tool0", q, check_limits=False)
        for name, robot in (("exact", exact), ("menagerie", menagerie)):
            T = T_BASE_LINK_WORLD @ robot.transform("world", "wrist_3_link", q, check_limits=False) @ T_WRIST_3_TOOL0
            worst[name] = max(worst[name], np.abs(T - T_ros).max())
    assert worst["exact"] < 1e-9  # ROS's pi/2 is 1.570796327
    assert 5e-4 < worst["menagerie"] < 1.5e-3  # the rounded lengths: 0.7 mm at most each, 0.97 mm measured


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ik_all_gives_the_ros_urdf_solutions(ros_lengths, seed):
    ros = manipkit.load(ROS_UR5E)
    q = ros.sample_q(1, seed=seed)[0]
    T_ros = ros.transform("base_link", "tool0", q, check_limits=False)
    T_mj = np.linalg.inv(T_BASE_LINK_WORLD) @ T_ros @ np.linalg.inv(T_WRIST_3_TOOL0)
    expected = ik_all(ROS_UR5E, "base_link", "tool0", T_ros)
    for path, tol in ((ros_lengths, 1e-7), (UR5E, 5e-2)):  # Menagerie's own lengths: nearby solutions (docstring)
        found = ik_all(path, "world", "wrist_3_link", T_mj)
        assert len(found) == len(expected) == 8
        for solution in expected:
            gap = min(np.abs(np.angle(np.exp(1j * (solution - other)))).max() for other in found)
            assert gap < tol, (path.name, gap)
        model = mujoco_model(path)  # each MJCF solution puts MuJoCo's wrist_3_link on the target
        data = mujoco.MjData(model)
        for solution in found:
            data.qpos[:] = solution
            mujoco.mj_kinematics(model, data)
            b = model.body("wrist_3_link").id
            assert np.abs(data.xpos[b] - T_mj[:3, 3]).max() < 1e-9
            assert np.abs(data.xmat[b].reshape(3, 3) - T_mj[:3, :3]).max() < 1e-9


def test_collisions_use_the_geoms():
    out = run_cli("manipkit", "collisions", "--robot", UR5E, status=0).stdout
    assert out.startswith("robot ur5e: collision-free")


def test_an_xacro_argument_on_mjcf_is_refused_in_one_line():
    result = run_cli("manipkit", "frames", "--robot", UR5E, "--arg", "a:=1", status=2)
    assert result.stderr.strip().splitlines() == [
        "manipkit: error: ur5e.xml is an MJCF file; xacro arguments (a) only apply to .xacro files"]
