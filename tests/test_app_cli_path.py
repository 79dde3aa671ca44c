"""``manipkit path``: the JSON contract, the words, the trajectory file and one-line errors (run in process).

The numbers are checked against forward kinematics of the printed joints (compiled FK, equal to Pinocchio) and
against the poses the command was given.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from cli_helper import run_cli

import manipkit
from manipkit.spatial.rotations import quaternion_from_matrix
from manipkit.spatial.transforms import pose_residuals, transform_from_xyz_rpy

LINE = ["--line", "0.4", "0.1", "0.4", "3.14159", "0", "0", "0.5", "0.1", "0.4", "3.14159", "0", "0", "--step", "0.01"]
KEYS = ["feasible", "joint_names", "q", "t", "failures", "first_failure", "reconfigurations", "cost",
        "max_velocity_ratio"]


def test_json_has_exactly_the_contract_keys_and_lands_on_the_line():
    result = run_cli("manipkit", "path", "--robot", "ur5", "--tip", "tool0", *LINE, "--speed", "0.1", "--format", "json")
    answer = json.loads(result.stdout)
    assert list(answer) == KEYS
    assert answer["feasible"] and answer["first_failure"] is None and answer["reconfigurations"] == []
    chain = manipkit.load("ur5").chain("base_link", "tool0")
    assert answer["joint_names"] == list(chain.joint_names)
    q = np.array(answer["q"])
    assert q.shape == (11, 6)  # 0.1 m at steps of at most 0.01 m: 10 intervals
    x = np.linspace(0.4, 0.5, 11)
    wanted = np.stack([transform_from_xyz_rpy([xi, 0.1, 0.4], [3.14159, 0, 0]) for xi in x])
    position, rotation = pose_residuals(wanted, chain.fk(q))
    assert position.max() <= 1e-9 and rotation.max() <= 1e-9
    assert answer["t"] == pytest.approx(np.arange(11) * 0.1, abs=1e-12)  # 1 cm at 0.1 m/s
    assert answer["cost"] == pytest.approx(np.abs(np.diff(q, axis=0)).sum(), abs=1e-9)
    assert 0 < answer["max_velocity_ratio"] <= 1
    assert len(answer["failures"]) == 11


def test_text_says_what_was_planned_and_writes_the_trajectory(tmp_path):
    out = tmp_path / "trajectory.csv"
    result = run_cli("manipkit", "path", "--robot", "ur5", "--tip", "tool0", *LINE, "--speed", "0.1", "-o", str(out))
    text = result.stdout
    assert "path of 11 waypoints for frame tool0 in base_link on ur5" in text
    assert "FEASIBLE" in text and "optimal for that cost at this resolution" in text
    assert "every closed-form branch" in text and "2 pi alias" in text
    rows = out.read_text().splitlines()
    assert rows[0] == "waypoint,t,shoulder_pan_joint,shoulder_lift_joint,elbow_joint,wrist_1_joint,wrist_2_joint,wrist_3_joint"
    assert len(rows) == 12
    json_q = json.loads(run_cli("manipkit", "path", "--robot", "ur5", "--tip", "tool0", *LINE, "--speed", "0.1",
                                "--format", "json").stdout)["q"]
    assert [float(v) for v in rows[5].split(",")[2:]] == json_q[4]


def test_pose_file_and_a_failure_in_words(tmp_path):
    # Straight out along +x from the base at the height of the shoulder: far beyond the UR5's reach (about 0.95 m
    # from the shoulder with the wrist): the waypoint at x = 2 m can have no branch.
    path = tmp_path / "poses.csv"
    R = transform_from_xyz_rpy([0, 0, 0], [math.pi, 0, 0])[:3, :3]
    quat = quaternion_from_matrix(R)
    lines = ["x,y,z,qx,qy,qz,qw"] + [f"{x},0.1,0.4,{quat[0]},{quat[1]},{quat[2]},{quat[3]}" for x in (0.4, 0.45, 2.0)]
    path.write_text("\n".join(lines) + "\n")
    result = run_cli("manipkit", "path", "--robot", "ur5", "--tip", "tool0", "--poses", str(path), status=1)
    assert "NOT FEASIBLE: no candidate survives at waypoint 2" in result.stdout
    assert "unreachable" in result.stdout
    answer = json.loads(run_cli("manipkit", "path", "--robot", "ur5", "--tip", "tool0", "--poses", str(path),
                                "--format", "json", status=1).stdout)
    assert answer["first_failure"] == 2 and answer["q"] is None and answer["cost"] is None
    assert answer["failures"][2][0]["kind"] == "unreachable"


@pytest.mark.parametrize("args, words", [
    (["--line", *LINE[1:13], "--step", "0"], "step"),
    (["--line", *LINE[1:13], "--step", "1e-9"], "waypoints"),  # 0.1 m at 1 nm: 1e8 waypoints, refused
    ([*LINE, "--speed", "0"], "speed"),
    ([*LINE, "--free-axis", "w"], "free-axis"),
    ([*LINE, "--free-axis", "z", "--free-step", "0deg"], "free_step"),
    ([*LINE, "--free-step", "10deg"], "--free-axis"),
])
def test_bad_options_are_one_line(args, words):
    result = run_cli("manipkit", "path", "--robot", "ur5", "--tip", "tool0", *args, status=2)
    assert len(result.stderr.strip().splitlines()) == 1 and words in result.stderr


@pytest.mark.parametrize("row", ["0.4,0.1,nan,0,0,0,1", "0.4,0.1,0.4,0,0,0,3"])
def test_bad_pose_files_are_one_line(tmp_path, row):
    path = tmp_path / "poses.csv"
    path.write_text("x,y,z,qx,qy,qz,qw\n0.4,0.1,0.4,1,0,0,0\n" + row + "\n")
    result = run_cli("manipkit", "path", "--robot", "ur5", "--tip", "tool0", "--poses", str(path), status=2)
    assert len(result.stderr.strip().splitlines()) == 1


def test_world_box_is_planned_around(tmp_path):
    # A 6 cm box on the elbow of the least-motion plan at its middle waypoint (as in test_paths_plan): with
    # --collision-free the command plans around it; the joints it prints are clear of the box by coal.
    from manipkit.kinematics.collisions import CollisionChecker
    from manipkit.kinematics.world import read_world

    robot = manipkit.load("ur5")
    first = json.loads(run_cli("manipkit", "path", "--robot", "ur5", "--tip", "tool0", *LINE, "--speed", "0.1",
                               "--format", "json").stdout)
    elbow = robot.transform("base_link", "forearm_link", first["q"][5])[:3, 3]
    world = tmp_path / "world.yaml"
    world.write_text(f"obstacles:\n  - name: box\n    box: [0.06, 0.06, 0.06]\n    xyz: {elbow.tolist()}\n")
    result = run_cli("manipkit", "path", "--robot", "ur5", "--tip", "tool0", *LINE, "--speed", "0.1",
                     "--collision-free", "--world", str(world))
    assert "collisions: waypoints and steps" in result.stdout and "FEASIBLE" in result.stdout
    answer = json.loads(run_cli("manipkit", "path", "--robot", "ur5", "--tip", "tool0", *LINE, "--speed", "0.1",
                                "--collision-free", "--world", str(world), "--format", "json").stdout)
    checker = CollisionChecker(robot, world=read_world(world), skip_home_contacts=True)
    assert checker.in_collision(np.array(first["q"])).any() and not checker.in_collision(np.array(answer["q"])).any()


def test_output_into_a_missing_folder_is_refused_before_planning(tmp_path):
    out = tmp_path / "no_such_folder" / "trajectory.csv"
    result = run_cli("manipkit", "path", "--robot", "ur5", "--tip", "tool0", *LINE, "-o", str(out), status=2)
    assert len(result.stderr.strip().splitlines()) == 1 and "cannot write" in result.stderr
    assert list(tmp_path.iterdir()) == []
