"""``manipkit ik`` as a user runs it: the entry point called with argv in this process (tests/cli_helper.py).

Each of the findings of issue 14 about the command has a test here; every
solution printed is checked against forward kinematics computed
independently (the planar formulas written out below, or Pinocchio through
the robot's URDF), never against the solver's own numbers.
"""

import json
import re
import shlex
from pathlib import Path

import numpy as np
import pytest
from cli_helper import run_cli

import manipkit


def run_json(*args, status=None):
    return json.loads(run_cli("manipkit", "ik", *args, "--format", "json", status=status).stdout)


def planar_fk(q, lengths):
    """(x, y, phi) of a planar arm, written out: link i points along q1 + ... + qi."""
    heading = np.cumsum(q)
    return (float(np.dot(lengths, np.cos(heading))), float(np.dot(lengths, np.sin(heading))), float(heading[-1]))


def test_finding_1_planar_2r_pose_whose_orientation_it_cannot_meet_has_no_solution():
    # Issue 14, finding 1: main printed success with "rotation 0 rad"; the elbows' tool angles are off.
    result = run_cli("manipkit", "ik", "--robot", "planar_2r", "--xyz", 1, 0.5, 0, "--rpy", 0, 0, 0.3, "--analytic", status=1)
    assert "0 solution(s)" in result.stdout and "orientation" in result.stdout
    # By hand (l1 = l2 = 1): cos q2 = (r^2 - 2) / 2 with r^2 = 1.25; q1 = atan2(y, x) -+ atan2(sin q2, 1 + cos q2).
    q2 = np.arccos((1.25 - 2.0) / 2.0)
    headings = []
    for sign in (1.0, -1.0):
        q1 = np.arctan2(0.5, 1.0) - np.arctan2(sign * np.sin(q2), 1.0 + np.cos(q2))
        x, y, phi = planar_fk([q1, sign * q2], [1.0, 1.0])
        assert abs(x - 1.0) < 1e-12 and abs(y - 0.5) < 1e-12
        headings.append(phi)
    miss = min(abs(np.angle(np.exp(1j * (h - 0.3)))) for h in headings)
    assert miss > 0.8
    out = run_json("--robot", "planar_2r", "--xyz", 1, 0.5, 0, "--rpy", 0, 0, 0.3, "--analytic", status=1)
    assert out["success"] is False and out["solutions"] == [] and out["count"] == 0
    assert abs(out["unmet"]["orientation"] - miss) < 1e-12
    assert out["closed_form_mode"] == "planar pose (x, y, phi)"


def test_finding_2_planar_3r_position_only_is_a_family_in_phi():
    # Issue 14, finding 2: main assumed phi = 0 and printed "2 solution(s)".
    result = run_cli("manipkit", "ik", "--robot", "planar_3r", "--xyz", 4, 2, 0, "--analytic", status=0)
    assert "infinitely many solutions (free: phi)" in result.stdout and "2 solution(s)" not in result.stdout
    out = run_json("--robot", "planar_3r", "--xyz", 4, 2, 0, "--analytic", status=0)
    assert out["count"] == "inf" and out["free_parameter"] == "phi" and out["closed_form_mode"] == "planar position (x, y)"
    phis = set()
    for solution in out["solutions"]:
        x, y, phi = planar_fk([solution[f"joint{i}"] for i in (1, 2, 3)], [4.0, 2.0, 1.0])  # l1, l2, l3 = 4, 2, 1
        assert abs(x - 4.0) < 1e-9 and abs(y - 2.0) < 1e-9
        phis.add(round(phi % (2 * np.pi), 6))
    assert len(out["solutions"]) >= 4 and len(phis) >= 2  # several members of the family, at different tool angles


def test_finding_3_scara_position_only_in_closed_form_frees_the_tool_roll():
    # Issue 14, finding 3: main ignored --position-only and gave 0 solutions (tool "tilted 180 deg").
    result = run_cli("manipkit", "ik", "--robot", "scara", "--xyz", 0.4, 0.3, 0.25, "--position-only", "--analytic", status=0)
    assert "infinitely many solutions (free: theta4)" in result.stdout and "tilted" not in result.stdout
    out = run_json("--robot", "scara", "--xyz", 0.4, 0.3, 0.25, "--position-only", "--analytic", status=0)
    robot = manipkit.load("scara")
    rolls = set()
    for solution in out["solutions"]:
        q = [solution[name] for name in robot.joint_names]
        reached = robot.transform("base_link", "ee_link", q)  # Pinocchio, through the URDF
        assert np.linalg.norm(reached[:3, 3] - [0.4, 0.3, 0.25]) < 1e-9
        rolls.add(round(solution["joint4"], 6))
    assert len(rolls) >= 2 and out["residual_rotation"] == 0.0


def test_finding_4_planar_target_off_the_plane_names_z_and_by_how_much():
    # Issue 14, finding 4: main printed "0 solution(s) (count: 2)" and "2 solutions ... inside" without z.
    result = run_cli("manipkit", "ik", "--robot", "planar_2r", "--xyz", 1, 1, 0.3, "--analytic", status=1)
    assert "0 solution(s)" in result.stdout and "(count: 2)" not in result.stdout
    assert "z = 0.3 m, off the arm's plane z = 0 m by 0.3 m" in result.stdout
    out = run_json("--robot", "planar_2r", "--xyz", 1, 1, 0.3, "--analytic", status=1)
    z_plane = manipkit.load("planar_2r").transform("base_link", "ee_link", [0.4, -1.0])[2, 3]  # any q: the plane
    assert out["count"] == 0 and abs(out["unmet"]["z"] - (0.3 - z_plane)) < 1e-12


def test_analytic_position_of_a_six_joint_arm_is_refused_with_the_way_out():
    result = run_cli("manipkit", "ik", "--robot", "elbow_arm", "--xyz", 0.5, 0.1, 0.3, "--analytic", status=2)
    assert "solves spatial pose (x, y, z, R) only" in result.stderr and "numerical IK" in result.stderr


def test_analytic_with_an_axis_is_a_usage_error():
    result = run_cli("manipkit", "ik", "--robot", "scara", "--xyz", 0.4, 0.3, 0.25, "--rpy", 3.14159, 0, 0, "--axis", "z", "--analytic",
                 status=2)
    assert "leave out the axis" in result.stderr


def test_finding_8_a_pose_pasted_from_tf_between_is_explained_and_tol_accepts_it():
    # Issue 14, finding 8: the course arm's pose A, pasted from tf-between's 6-decimal text, failed with
    # "the target may be unreachable" (5 joints cannot meet a rounded 6D pose exactly) and ik had no --tol.
    from reference import POSE_A, course_arm_T_base_ee, matrix_from_rpy

    joints = ("arm_base_joint", "shoulder_joint", "bottom_wrist_joint", "elbow_joint", "top_wrist_joint")
    text = run_cli("tf-between", "base_link", "ee_link", "--q", *(f"{n}={v}" for n, v in zip(joints, POSE_A))).stdout
    xyz = re.search(r"Translation \(m\): \[([^\]]*)\]", text).group(1).replace(",", " ").split()
    rpy = re.search(r"RPY \(radian\) \[roll, pitch, yaw\]: \[([^\]]*)\]", text).group(1).replace(",", " ").split()
    assert all(len(v.partition(".")[2]) == 6 for v in xyz + rpy)  # the printed precision this test is about
    failed = run_cli("manipkit", "ik", "--xyz", *xyz, "--rpy", *rpy, status=1)
    assert "within what the target's printed precision can express (6 decimals" in failed.stdout
    suggested = re.search(r"accept it with --tol (\S+)", failed.stdout).group(1)
    assert float(suggested) <= 1e-5
    out = run_json("--xyz", *xyz, "--rpy", *rpy, "--tol", suggested, status=0)
    q = [out["solutions"][0][name] for name in joints]
    T = course_arm_T_base_ee(q)  # the independent chain of tests/reference.py
    T_target = np.eye(4)
    T_target[:3, :3], T_target[:3, 3] = matrix_from_rpy(*map(float, rpy)), list(map(float, xyz))
    assert np.linalg.norm(T[:3, 3] - T_target[:3, 3]) <= float(suggested)
    assert np.abs(T[:3, :3] - T_target[:3, :3]).max() <= 2 * float(suggested)
    assert np.abs(np.array(q) - POSE_A).max() < 1e-5  # the pose it was printed from


def test_tol_is_checked():
    result = run_cli("manipkit", "ik", "--xyz", 0.1, 0, 0, "--tol", 0, status=2)
    assert "--tol 0: give one or two positive numbers (position m, rotation rad)" in result.stderr
    result = run_cli("manipkit", "ik", "--xyz", 0.1, 0, 0, "--tol", 1, 2, 3, status=2)
    assert "--tol 1 2 3" in result.stderr


def test_a_far_target_gets_no_precision_note():
    out = run_json("--xyz", 3.123456, 0, 0, "--restarts", 2, status=1)
    assert not any("printed precision" in note for note in out["notes"])


# ----------------------------------------------------------------------
# issue 25: every command manipkit prints for the user to run reproduces the answer
# ----------------------------------------------------------------------

REALWORLD_MORE = next((base / "shared" / "realworld" / "ws_more" / "src" for base in Path(__file__).resolve().parents[2:4]
                       if (base / "shared" / "realworld").is_dir()), Path("/nonexistent"))
TIAGO = REALWORLD_MORE / "tiago_robot/tiago_description/robots/tiago.urdf.xacro"
XARM = REALWORLD_MORE / "xarm_ros2/xarm_description/urdf/xarm_device.urdf.xacro"


@pytest.mark.skipif(not TIAGO.is_file(), reason="the shared real-world workspace is not here")
def test_the_check_line_of_ik_loads_the_same_robot_and_lands_on_the_target():
    # TIAGo without its force-torque sensor: the arm's tool frame is 2.3 cm nearer the wrist than the default
    # robot's; the check line used to drop --arg, so it answered for the other robot, silently.
    options = ["--robot", str(TIAGO), "--arg", "ft_sensor:=no-ft-sensor", "--arg", "end_effector:=pal-gripper"]
    target = [0.6, 0.1, 0.9]
    result = run_cli("manipkit", "ik", *options, "--frame", "arm_tool_link", "--xyz", *map(str, target),
                     "--position-only")
    assert result.returncode == 0, result.stderr
    line = next(line for line in result.stdout.splitlines() if line.startswith("check one with: "))
    words = shlex.split(line.removeprefix("check one with: "))
    assert words[0] == "tf-between" and words[1:3] == ["base_link", "arm_tool_link"]
    assert "ft_sensor:=no-ft-sensor" in words and "end_effector:=pal-gripper" in words
    check = run_cli(*words, "--format", "json")
    assert check.returncode == 0, check.stderr
    assert json.loads(check.stdout)["translation"] == pytest.approx(target, abs=1e-9)  # the IK tolerance, not 1e-6


def test_ik_names_the_link_ee_link_stands_for():
    result = run_cli("manipkit", "ik", "--robot", "panda", "--xyz", "0.4", "0.1", "0.5", "--position-only")
    assert "frame ee_link = panda_hand_tcp, the end effector declared in panda.srdf" in result.stdout


@pytest.mark.skipif(not XARM.is_file(), reason="the shared real-world workspace is not here")
def test_the_derived_by_line_of_a_dh_file_reproduces_the_table(tmp_path):
    options = ["--robot", str(XARM), "--arg", "dof:=6", "--arg", "robot_type:=xarm"]
    out = tmp_path / "xarm6.yaml"
    result = run_cli("manipkit", "dh", "from-urdf", *options, "--base", "link_base", "--tip", "link_eef", "-o", out)
    assert result.returncode == 0, result.stderr
    recorded = re.search(r"derived by `([^`]*)`", out.read_text().replace("\n# ", " ")).group(1)
    again = run_cli(*shlex.split(recorded))
    assert again.returncode == 0, again.stderr
    # the same table and summary (after the "wrote FILE" line); the recorded command names the tolerance the
    # table was made at (--tol 0 here: snapping would have failed dh check), so the rerun has no reason to say
    # why it did not snap
    first = re.sub(r"^not snapped: [^;]*; ", "", result.stdout.split("\n", 1)[1], flags=re.M)
    assert "--tol 0.0" in recorded and again.stdout == first


def test_a_pose_for_a_five_joint_arm_that_fails_says_why_and_what_to_ask_instead():
    # issue 25: 6D IK on a 4- or 5-joint arm failed with no hint
    pose = ["--xyz", "0.3", "0.2", "0.2", "--rpy", "0.3", "0.2", "0.1"]
    result = run_cli("manipkit", "ik", "--robot", "course_arm", *pose)
    assert result.returncode == 1
    assert ("note: the chain base_link -> ee_link has 5 joints, fewer than the 6 a full pose needs, so most poses "
            "are out of its reach: ask for the position only (--position-only) or the position and the tool's axis "
            "(--axis z)") in result.stdout
    assert run_cli("manipkit", "ik", "--robot", "course_arm", *pose, "--axis", "z").returncode in (0, 1)  # a valid command


def test_the_check_line_uses_a_solution_inside_the_limits_and_reproduces_it():
    # iiwa14 with joint 3 held at 0.2: 7 of the 8 branches leave the limits; tf-between refuses those, so the
    # check line must name the one inside them (it named the first branch, which tf-between refused)
    target = ["0.5", "0.1", "0.6"]
    result = run_cli("manipkit", "ik", "--robot", "iiwa14", "--analytic", "--lock", "iiwa_joint_3=0.2",
                     "--xyz", *target, "--rpy", "3.14", "0", "0")
    assert result.returncode == 0, result.stderr
    line = next(line for line in result.stdout.splitlines() if line.startswith("check one with: "))
    check = run_cli(*shlex.split(line.removeprefix("check one with: ")), "--format", "json")
    assert check.returncode == 0, check.stderr
    assert json.loads(check.stdout)["translation"] == pytest.approx([0.5, 0.1, 0.6], abs=1e-9)


def test_family_prints_an_ik_command_that_loads_the_same_robot_and_refuses_a_lock_of_nan():
    result = run_cli("manipkit", "family", "--robot", "iiwa14", "--lock", "iiwa_joint_3=0.2")
    line = result.stdout.splitlines()[-1]
    assert line.startswith("closed form: manipkit ik --analytic --robot iiwa14 --base base_link --tip ee_link "
                           "--lock iiwa_joint_3=0.2 --xyz X Y Z")
    refused = run_cli("manipkit", "family", "--robot", "iiwa14", "--lock", "iiwa_joint_3=nan")
    assert refused.returncode == 2 and "--lock iiwa_joint_3=nan: give JOINT=VALUE with a finite number" in refused.stderr


def test_the_header_says_when_the_one_branch_shown_is_outside_the_limits():
    # A Panda pose (found by a random search) where every branch of the closed form with joint 7 locked at
    # 0.5 rad break a joint limit: --all shows that premise; without --all the one row shown is a branch outside
    # the limits and the header must not call it "inside the joint limits".
    pose = ("--robot", "panda", "--xyz", "-0.2403", "-0.0928", "0.1227", "--rpy", "-2.25430034", "1.02374649",
            "0.88313707", "--lock", "panda_joint7=0.5")
    every = json.loads(run_cli("manipkit", "ik", *pose, "--all", "--format", "json", status=0).stdout)
    assert every["solutions"] and not any(every["within_limits"])
    header = run_cli("manipkit", "ik", *pose, status=0).stdout.splitlines()[0]
    assert "outside the joint limits: no branch is inside them" in header and "(the first branch inside" not in header
