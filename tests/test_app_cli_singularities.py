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
from cli_helper import run_cli

import manipkit
from manipkit.analysis.singularities import KNOWN_ROBOTS, singular_families

SRC = Path(manipkit.__file__).resolve().parents[1]


def test_text_lists_the_stanford_arms_families_with_their_conditions():
    # det J = d3^2 s2 s5 (Spong): the wrist (q5), the boom along joint 1's axis (q2), the boom fully in (d3)
    result = run_cli("manipkit", "singularities", "--robot", "stanford_arm")
    status, out, err = result.returncode, result.stdout, result.stderr
    assert status == 0 and err == ""
    lines = out.splitlines()
    assert lines[0] == "robot stanford_arm: 3 known singular families (the ee_link Jacobian loses rank in the rows named)"
    assert lines[1] == "1. wrist: joint5 = 0 or 180 deg (all rows)"
    assert "joint4 and joint6 turn about the same axis" in lines[2]
    assert lines[3] == "2. boom along joint 1's axis: joint2 = 0 or 180 deg (all rows)"
    assert lines[5] == "3. wrist centre at the shoulder: joint3 = 0 m (all rows, outside the joint limits)"


def test_text_names_the_rows_a_planar_arm_moves():
    out = run_cli("manipkit", "singularities", "--robot", "planar_3r").stdout
    assert "1. elbow straight: joint2 = 0 or 180 deg (rows vx, vy, wz)" in out
    assert "2. all links in line: joint2 and joint3 = 0 or 180 deg (rows vx, vy)" in out


def test_elbow_arm_shoulder_condition_uses_the_xacro_lengths():
    # the wrist centre's horizontal distance from joint 1's axis is a2 c2 + a3 c23
    out = run_cli("manipkit", "singularities", "--robot", "elbow_arm", "--arg", "a2:=0.6").stdout
    assert "wrist centre on joint 1's axis: 0.6 cos(joint2) + 0.4 cos(joint2 + joint3) = 0 m (all rows)" in out


@pytest.mark.parametrize("robot", KNOWN_ROBOTS)
def test_json_holds_every_family_of_the_library(robot):
    result = run_cli("manipkit", "singularities", "--robot", robot, "--format", "json")
    status, out = result.returncode, result.stdout
    data = json.loads(out)
    expected = singular_families(manipkit.load(robot))
    assert status == 0 and data["robot"] == robot and data["note"] is None
    assert [f["name"] for f in data["families"]] == [f.name for f in expected]
    assert [f["condition"] for f in data["families"]] == [f.condition for f in expected]
    assert set(data["families"][0]) == {"name", "condition", "description", "rows", "unit", "reachable"}


def test_a_robot_without_known_families_is_told_so_with_the_numeric_check():
    result = run_cli("manipkit", "singularities", "--robot", "panda")
    status, out = result.returncode, result.stdout
    assert status == 0
    assert out.startswith("no singular families are known for robot panda (they are for planar_2r, ")
    assert "manipkit jacobian --robot panda --q ..." in out
    result = run_cli("manipkit", "singularities", "--robot", "panda", "--format", "json")
    status, out = result.returncode, result.stdout
    data = json.loads(out)
    assert data["families"] == [] and "manipkit jacobian" in data["note"]


def test_the_same_arm_from_a_urdf_file_gets_the_families(tmp_path):
    # recognised by its robot name and structure, not by the bundled path
    path = tmp_path / "my_scara.urdf"
    path.write_text(manipkit.load("scara").urdf)
    out = run_cli("manipkit", "singularities", "--robot", str(path)).stdout
    assert out.startswith("robot scara: 1 known singular family")


def test_an_unknown_robot_is_an_error_exit_2():
    # a real subprocess, the one test of `python -m manipkit.app.cli` (__main__.py makes main's status the
    # process's exit status): one error line, no traceback
    env = dict(os.environ, PYTHONPATH=str(SRC))
    result = subprocess.run([sys.executable, "-m", "manipkit.app.cli", "singularities", "--robot", "no_such_arm"],
                            capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 2
    assert result.stderr.startswith("manipkit: error: unknown robot 'no_such_arm'")
    assert "Traceback" not in result.stderr and result.stdout == ""
