"""``manipkit singularities``: the known families in words, JSON, and robots without known families.

The families themselves are checked against Pinocchio in
tests/test_analysis_singularities.py; here the command's output is checked
against the library's answer and the derivations (conditions by hand).
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import manipkit
from manipkit.analysis.singularities import KNOWN_ROBOTS, singular_families
from manipkit.app.cli import main

SRC = Path(manipkit.__file__).resolve().parents[1]


def run(capsys, *args):
    status = main(["singularities", *args])
    out, err = capsys.readouterr()
    return status, out, err


def test_text_lists_the_stanford_arms_families_with_their_conditions(capsys):
    # det J = d3^2 s2 s5 (Spong): the wrist (q5), the boom along joint 1's axis (q2), the boom fully in (d3)
    status, out, err = run(capsys, "--robot", "stanford_arm")
    assert status == 0 and err == ""
    lines = out.splitlines()
    assert lines[0] == "robot stanford_arm: 3 known singular families (the ee_link Jacobian loses rank in the rows named)"
    assert lines[1] == "1. wrist: joint5 = 0 or 180 deg (all rows)"
    assert "joint4 and joint6 turn about the same axis" in lines[2]
    assert lines[3] == "2. boom along joint 1's axis: joint2 = 0 or 180 deg (all rows)"
    assert lines[5] == "3. wrist centre at the shoulder: joint3 = 0 m (all rows, outside the joint limits)"


def test_text_names_the_rows_a_planar_arm_moves(capsys):
    _, out, _ = run(capsys, "--robot", "planar_3r")
    assert "1. elbow straight: joint2 = 0 or 180 deg (rows vx, vy, wz)" in out
    assert "2. all links in line: joint2 and joint3 = 0 or 180 deg (rows vx, vy)" in out


def test_elbow_arm_shoulder_condition_uses_the_xacro_lengths(capsys):
    # the wrist centre's horizontal distance from joint 1's axis is a2 c2 + a3 c23
    _, out, _ = run(capsys, "--robot", "elbow_arm", "--arg", "a2:=0.6")
    assert "wrist centre on joint 1's axis: 0.6 cos(joint2) + 0.4 cos(joint2 + joint3) = 0 m (all rows)" in out


@pytest.mark.parametrize("robot", KNOWN_ROBOTS)
def test_json_holds_every_family_of_the_library(capsys, robot):
    status, out, _ = run(capsys, "--robot", robot, "--format", "json")
    data = json.loads(out)
    expected = singular_families(manipkit.load(robot))
    assert status == 0 and data["robot"] == robot and data["note"] is None
    assert [f["name"] for f in data["families"]] == [f.name for f in expected]
    assert [f["condition"] for f in data["families"]] == [f.condition for f in expected]
    assert set(data["families"][0]) == {"name", "condition", "description", "rows", "unit", "reachable"}


def test_a_robot_without_known_families_is_told_so_with_the_numeric_check(capsys):
    status, out, _ = run(capsys, "--robot", "panda")
    assert status == 0
    assert out.startswith("no singular families are known for robot panda (they are for planar_2r, ")
    assert "manipkit jacobian --robot panda --q ..." in out
    status, out, _ = run(capsys, "--robot", "panda", "--format", "json")
    data = json.loads(out)
    assert data["families"] == [] and "manipkit jacobian" in data["note"]


def test_the_same_arm_from_a_urdf_file_gets_the_families(capsys, tmp_path):
    # recognised by its robot name and structure, not by the bundled path
    path = tmp_path / "my_scara.urdf"
    path.write_text(manipkit.load("scara").urdf)
    _, out, _ = run(capsys, "--robot", str(path))
    assert out.startswith("robot scara: 1 known singular family")


def test_an_unknown_robot_is_an_error_exit_2():
    # a real subprocess: one error line, no traceback
    env = dict(os.environ, PYTHONPATH=str(SRC))
    result = subprocess.run([sys.executable, "-m", "manipkit.app.cli", "singularities", "--robot", "no_such_arm"],
                            capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 2
    assert result.stderr.startswith("manipkit: error: unknown robot 'no_such_arm'")
    assert "Traceback" not in result.stderr and result.stdout == ""
