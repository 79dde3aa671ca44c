"""The command line as a user runs it: the entry points called with argv in this process (tests/cli_helper.py)."""

import json
import re

import numpy as np
import pytest
from cli_helper import run_cli
from reference import POSE_A, POSE_B, course_arm_T_base_ee, course_arm_T_base_top_wrist

from manipkit.description.sources import bundled_robots

JOINTS = ("arm_base_joint", "shoulder_joint", "bottom_wrist_joint", "elbow_joint", "top_wrist_joint")

# The seed's hand answers (seed 000, "Using the sliders..." and question 4).
SEED_ZERO_POSE = [[1, 0, 0, 0.172], [1, 0, 0, 0], [1, 0, 0, 0], [1, 0, 0, 0]]
SEED_POSE_A = [[-0.411, 0.897, -0.153, 0.2412], [0.910, 0.4, -0.05, 0.32], [-0.014, 0.16, 0.986, 0.11], [0, 0, 0, 1]]


def q_args(pose):
    return ["--q", *(f"{name}={value}" for name, value in zip(JOINTS, pose))]


def tf_json(*args):
    return json.loads(run_cli("tf-between", *args, "--format", "json", status=0).stdout)


@pytest.mark.parametrize("pose", [(0, 0, 0, 0, 0), POSE_A, POSE_B], ids=["zero", "A", "B"])
def test_tf_between_course_arm_matches_independent_chain(pose):
    out = tf_json("base_link", "top_wrist", *q_args(pose))
    assert np.abs(np.array(out["matrix"]) - course_arm_T_base_top_wrist(pose)).max() < 1e-12


def test_tf_between_json_has_the_contract_keys():
    out = tf_json("base_link", "ee_link", *q_args(POSE_A))
    assert list(out) == ["source", "target", "robot", "q", "translation", "quaternion_xyzw", "rpy", "matrix"]
    assert out["q"] == dict(zip(JOINTS, map(float, POSE_A)))
    T = course_arm_T_base_ee(POSE_A)
    assert np.allclose(out["translation"], T[:3, 3], atol=1e-12)
    # quaternion (x, y, z, w) and rpy reproduce the matrix (R = Rz(yaw) Ry(pitch) Rx(roll)).
    x, y, z, w = out["quaternion_xyzw"]
    R_quat = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])
    from reference import rot_x, rot_y, rot_z

    roll, pitch, yaw = out["rpy"]
    assert np.abs(R_quat - T[:3, :3]).max() < 1e-12
    assert np.abs(rot_z(yaw) @ rot_y(pitch) @ rot_x(roll) - T[:3, :3]).max() < 1e-12


def test_tf_between_text_reads_like_tf2_echo_with_direction_and_conventions():
    out = run_cli("tf-between", "base_link", "ee_link", status=0).stdout
    assert "pose of ee_link expressed in base_link (T_base_link_ee_link, as tf2_echo base_link ee_link)" in out
    assert "Quaternion (x, y, z, w)" in out and "RPY (radian) [roll, pitch, yaw]" in out and "RPY (degree)" in out
    assert "R = Rz(yaw) Ry(pitch) Rx(roll)" in out
    # Hand value at zero: z = 0.1 + 0.20271 + 0.269 + 0.13522 + 0.20994 + 0.13522 = 1.05209 m;
    # x = -0.05166 + 0.05194 (bicep's -y offset turned by the 1.5708 yaw) = 0.00028 m.
    assert "- Translation (m): [0.000280, 0.000000, 1.052090]" in out
    rows = out.split("- Matrix:\n")[1].strip().splitlines()
    matrix = np.array([[float(v) for v in row.split()] for row in rows])
    assert np.abs(matrix - course_arm_T_base_ee((0,) * 5)).max() <= 5e-7


def test_precision_sets_the_decimals():
    out = run_cli("tf-between", "base_link", "ee_link", "--precision", "3", status=0).stdout
    assert "- Translation (m): [0.000, 0.000, 1.052]" in out


def test_degrees_and_positional_values_give_the_same_pose():
    by_name = tf_json("base_link", "ee_link", *q_args(POSE_A))
    in_degrees = tf_json("base_link", "ee_link", "--deg", *q_args(np.degrees(POSE_A)))
    positional = tf_json("base_link", "ee_link", "--q", *map(str, POSE_A))
    assert np.allclose(by_name["matrix"], in_degrees["matrix"], atol=1e-12)
    assert by_name["matrix"] == positional["matrix"]


def test_manipkit_tf_is_tf_between():
    a = run_cli("tf-between", "bicep", "top_wrist", *q_args(POSE_B), status=0).stdout
    b = run_cli("manipkit", "tf", "bicep", "top_wrist", *q_args(POSE_B), status=0).stdout
    assert a == b


def test_alias_resolution_is_said(tmp_path):
    out = run_cli("tf-between", "base_link", "ee_link", "--robot", "panda", status=0).stdout
    assert "frame base_link = panda_link0, the root link" in out
    assert "frame ee_link = panda_hand_tcp, the end effector declared in panda.srdf" in out  # example-robot-data's SRDF


def test_xacro_args_on_the_command_line():
    # planar 3R with l1 = 2 (default l2 = 2, l3 = 1) stretched out: ee at x = 2 + 2 + 1 = 5.
    out = tf_json("base_link", "ee_link", "--robot", "planar_3r", "--arg", "l1=2")
    assert out["translation"] == pytest.approx([5, 0, 0], abs=1e-12)


def test_compare_agrees_with_the_models_own_matrix(tmp_path):
    T = course_arm_T_base_ee(POSE_A)
    path = tmp_path / "hand.txt"
    path.write_text("\n".join(" ".join(repr(float(v)) for v in row) for row in T))
    result = run_cli("tf-between", "base_link", "ee_link", *q_args(POSE_A), "--compare", path, status=0)
    assert "valid homogeneous transform" in result.stdout and "AGREES with the model" in result.stdout


def test_compare_shows_the_seeds_zero_pose_answer_invalid(tmp_path):
    path = tmp_path / "seed.json"
    path.write_text(json.dumps(SEED_ZERO_POSE))
    result = run_cli("tf-between", "base_link", "ee_link", "--compare", path, status=1)
    assert "not a valid homogeneous transform" in result.stdout
    assert "last row is [1 0 0 0], expected [0 0 0 1]" in result.stdout
    assert "DOES NOT AGREE" in result.stdout


def test_compare_gives_the_seeds_pose_a_errors(tmp_path):
    path = tmp_path / "seed.csv"
    path.write_text("\n".join(",".join(map(str, row)) for row in SEED_POSE_A))
    result = run_cli("tf-between", "base_link", "top_wrist", *q_args(POSE_A), "--compare", path, "--format", "json", status=1)
    compare = json.loads(result.stdout)["compare"]
    T = course_arm_T_base_top_wrist(POSE_A)
    hand = np.array(SEED_POSE_A)
    assert compare["position_error"] == pytest.approx(np.linalg.norm(hand[:3, 3] - T[:3, 3]), rel=1e-9)
    assert compare["agrees"] is False


def test_q_file_gives_one_pose_a_row(tmp_path):
    path = tmp_path / "poses.csv"
    path.write_text(",".join(JOINTS) + "\n" + "\n".join(",".join(map(str, p)) for p in (POSE_A, POSE_B, (0,) * 5)))
    out = run_cli("tf-between", "base_link", "ee_link", "--q-file", path, "--precision", "12", status=0).stdout
    lines = [line for line in out.splitlines() if not line.startswith("#")]
    assert lines[0] == "x,y,z,qx,qy,qz,qw,roll,pitch,yaw"
    for line, pose in zip(lines[1:], (POSE_A, POSE_B, (0,) * 5)):
        xyz = [float(v) for v in line.split(",")[:3]]
        assert xyz == pytest.approx(course_arm_T_base_ee(pose)[:3, 3], abs=1e-11)
    data = json.loads(run_cli("tf-between", "base_link", "ee_link", "--q-file", path, "--format", "json", status=0).stdout)
    assert len(data["poses"]) == 3
    assert np.abs(np.array(data["poses"][1]["matrix"]) - course_arm_T_base_ee(POSE_B)).max() < 1e-12


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["base_link", "ee_link", "--robot", "pand"], "unknown robot 'pand'; did you mean panda"),
        (["base_link", "ee_link", "--robot", "missing/robot.urdf"], "robot file not found: missing/robot.urdf"),
        (["base_link", "top_wrst"], "no frame 'top_wrst'; did you mean top_wrist"),
        (["base_link", "ee_link", "--q", "elbow=1"], "no joint 'elbow'; did you mean elbow_joint"),
        (["base_link", "ee_link", "--q", "elbow_joint=abc"], "joint 'elbow_joint': value 'abc' is not a number"),
        (["base_link", "ee_link", "--q", "elbow_joint=nan"], "joint 'elbow_joint': value nan is not finite"),
        (["base_link", "ee_link", "--q", "1", "2"], "--q got 2 values but course_arm has 5 joints"),
        (["base_link", "ee_link", "--q", "elbow_joint"], "--q 'elbow_joint': expected NAME=VALUE"),
        (["base_link", "ee_link", "--arg", "l1=2"], "unknown xacro argument l1"),
        (["base_link", "ee_link", "--compare", "nothere.txt"], "nothere.txt"),
        (["base_link", "ee_link", "--format", "yaml"], "invalid choice: 'yaml'"),
        (["base_link"], "the following arguments are required: TARGET"),
        (["base_link", "ee_link", "--precision", "40"], "--precision 40"),
    ],
)
def test_user_errors_exit_2_with_one_line_and_no_traceback(args, fragment):
    result = run_cli("tf-between", *args)
    assert result.returncode == 2, result.stdout + result.stderr
    assert result.stderr.count("\n") == 1 and fragment in result.stderr
    assert "Traceback" not in result.stderr + result.stdout


def test_malformed_description_exits_2(tmp_path):
    path = tmp_path / "broken.urdf"
    path.write_text('<robot name="b"><link name="a"></robot>')
    result = run_cli("tf-between", "a", "a", "--robot", path, status=2)
    assert re.search(r"broken.urdf:1:\d+: malformed XML: Opening and ending tag mismatch", result.stderr)
    assert result.stderr.count("\n") == 1


def test_bad_q_file_cell_names_the_line(tmp_path):
    path = tmp_path / "poses.csv"
    path.write_text("elbow_joint\n0.1\nx\n")
    result = run_cli("tf-between", "base_link", "ee_link", "--q-file", path, status=2)
    assert "line 3: joint 'elbow_joint': value 'x' is not a number" in result.stderr


def test_out_of_limit_value_is_an_error_naming_the_limit():
    result = run_cli("tf-between", "base_link", "ee_link", "--robot", "iiwa14", "--q", "iiwa_joint_2=2.5", status=2)
    assert result.stderr == (
        "tf-between: error: joint 'iiwa_joint_2' = 2.5 is above its upper limit 2.0944 "
        "(limits [-2.0944, 2.0944] rad); use --clamp to clamp\n"
    )
    assert result.stdout == ""


def test_clamp_clamps_with_a_warning_and_answers_at_the_limit():
    clamped = run_cli("tf-between", "base_link", "ee_link", "--robot", "iiwa14", "--q", "iiwa_joint_2=2.5",
                  "--clamp", "--format", "json", status=0)
    assert clamped.stderr == "warning: joint 'iiwa_joint_2' = 2.5 rad clamped to its upper limit 2.0944 rad\n"
    at_limit = tf_json("base_link", "ee_link", "--robot", "iiwa14", "--q", "iiwa_joint_2=120", "--deg")
    assert np.abs(np.array(json.loads(clamped.stdout)["matrix"]) - np.array(at_limit["matrix"])).max() < 1e-12
    assert json.loads(clamped.stdout)["q"]["iiwa_joint_2"] == pytest.approx(np.radians(120), abs=1e-12)


def test_value_above_a_full_turn_without_deg_gets_a_degrees_hint():
    result = run_cli("tf-between", "base_link", "ee_link", "--robot", "iiwa14", "--q", "iiwa_joint_2=90", status=2)
    assert result.stderr.rstrip("\n").endswith("use --clamp to clamp (did you mean degrees? add --deg)")
    # With --deg the same number is inside the limits (90 deg < 120 deg).
    run_cli("tf-between", "base_link", "ee_link", "--robot", "iiwa14", "--q", "iiwa_joint_2=90", "--deg", status=0)


def test_limit_error_with_deg_speaks_degrees():
    result = run_cli("tf-between", "base_link", "ee_link", "--robot", "iiwa14", "--q", "iiwa_joint_2=150", "--deg", status=2)
    assert "joint 'iiwa_joint_2' = 150 is above its upper limit 120 (limits [-120, 120] deg)" in result.stderr
    below = run_cli("tf-between", "base_link", "ee_link", "--robot", "iiwa14", "--q", "iiwa_joint_7=-180", "--deg", status=2)
    assert "joint 'iiwa_joint_7' = -180 is below its lower limit -175 (limits [-175, 175] deg)" in below.stderr


def test_continuous_joint_above_a_full_turn_answers_with_a_degrees_warning():
    result = run_cli("tf-between", "base_link", "ee_link", "--q", "elbow_joint=90", status=0)
    assert result.stderr == "warning: joint 'elbow_joint' = 90 rad is more than a full turn; did you mean degrees? add --deg\n"


def test_q_file_row_outside_the_limits_names_the_line(tmp_path):
    path = tmp_path / "poses.csv"
    path.write_text("iiwa_joint_2,iiwa_joint_4\n0.1,0.2\n# a comment line\n2.5,0\n")
    result = run_cli("tf-between", "base_link", "ee_link", "--robot", "iiwa14", "--q-file", path, status=2)
    assert f"--q-file {path}: line 4: joint 'iiwa_joint_2' = 2.5 is above its upper limit 2.0944" in result.stderr
    clamped = run_cli("tf-between", "base_link", "ee_link", "--robot", "iiwa14", "--q-file", path, "--clamp", status=0)
    assert clamped.stderr == f"warning: --q-file {path}: clamped 1 value(s) into the joint limits (line 4 iiwa_joint_2)\n"


def test_description_warnings_go_to_stderr_as_warning_lines(tmp_path):
    path = tmp_path / "long_axis.urdf"
    path.write_text('<robot name="t">\n<link name="a"/>\n<link name="b"/>\n<joint name="j" type="continuous">'
                    '<parent link="a"/><child link="b"/><axis xyz="0 0 3"/></joint>\n</robot>')
    result = run_cli("tf-between", "a", "b", "--robot", path, "--q", "j=0.5", "--format", "json", status=0)
    assert result.stderr == "warning: long_axis.urdf:4: joint 'j' axis '0 0 3' (length 3) normalised to '0 0 1'\n"
    T = np.array(json.loads(result.stdout)["matrix"])
    assert np.arctan2(T[1, 0], T[0, 0]) == pytest.approx(0.5, abs=1e-12)  # 0.5 rad about z, not 1.5


def test_unresolved_mesh_is_a_warning_for_kinematics(tmp_path):
    path = tmp_path / "meshy.urdf"
    path.write_text('<robot name="t">\n<link name="a"/>\n<link name="b"><visual><geometry>'
                    '<mesh filename="package://no_such_pkg/b.stl"/></geometry></visual></link>\n'
                    '<joint name="j" type="fixed"><parent link="a"/><child link="b"/></joint>\n</robot>')
    result = run_cli("tf-between", "a", "b", "--robot", path, status=0)
    assert result.stderr.startswith("warning: meshy.urdf:3: link 'b' mesh package://no_such_pkg/b.stl: package 'no_such_pkg' not found")
    assert result.stderr.count("\n") == 1 and "- Translation (m): [0.000000, 0.000000, 0.000000]" in result.stdout


def test_internal_error_exits_1_with_a_short_message_and_a_report_hint(capsys):
    from manipkit.app.cli import run_command
    from manipkit.app.cli.tf import tf_parser

    def broken(args):
        raise RuntimeError("an invariant broke")

    status = run_command(tf_parser("tf-between"), ["base_link", "ee_link"], broken)
    err = capsys.readouterr().err
    assert status == 1
    assert err == ("tf-between: internal error (RuntimeError: an invariant broke); this is a bug in manipkit, "
                   "please report it with the command line used\n")


def test_user_error_message_is_always_one_line(capsys):
    from manipkit.app.cli import run_command
    from manipkit.app.cli.common import UsageError
    from manipkit.app.cli.tf import tf_parser

    def multiline(args):
        raise UsageError("first line\nsecond line")

    assert run_command(tf_parser("tf-between"), ["base_link", "ee_link"], multiline) == 2
    assert capsys.readouterr().err == "tf-between: error: first line second line\n"


BUNDLED = sorted(bundled_robots())


@pytest.mark.parametrize("name", BUNDLED)
def test_tree_text_lists_every_link(name):
    import manipkit
    from manipkit.description.tree import parse_structure

    out = run_cli("manipkit", "tree", "--robot", name, status=0).stdout
    links = [link.name for link in parse_structure(manipkit.load(name).urdf).robot.links]
    assert len(links) >= 3
    for link in links:
        assert re.search(rf"(^|\s){re.escape(link)}\b", out), link


def test_mobile_manipulator_tree_shows_the_lidar():
    out = run_cli("manipkit", "tree", "--robot", "mobile_manipulator", status=0).stdout
    assert "lidar_joint (fixed) ── lidar_link" in out


def test_tree_png_is_a_real_image(tmp_path):
    path = tmp_path / "tree.png"
    run_cli("manipkit", "tree", "--robot", "course_arm", "-o", path, status=0)
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    assert width > 200 and height > 200


def test_tree_dot_to_file(tmp_path):
    path = tmp_path / "tree.dot"
    run_cli("manipkit", "tree", "--robot", "iiwa14", "-o", path, status=0)
    text = path.read_text()
    assert text.startswith("digraph") and "iiwa_joint_4" in text and "iiwa_link_0" in text


def test_robots_lists_bundled_and_example_robot_data_with_dof():
    out = run_cli("manipkit", "robots", status=0).stdout
    assert re.search(r"iiwa14\s+│ bundled\s+│ 7\s+│ base_link\s+│ ee_link", out)
    # the hand's second finger mimics the first: 7 arm joints + 1 finger
    assert re.search(r"panda\s+│ example-robot-data │ 8\s+│ panda_link0 \(root\)\s+│ panda_hand_tcp", out)


def test_frames_lists_joints_with_limits():
    out = run_cli("manipkit", "frames", "--robot", "iiwa14", status=0).stdout
    assert "iiwa_joint_7" in out and "3.05433" in out and "iiwa_link_6 -> iiwa_link_7" in out


def test_dh_show_prints_the_boxed_table_and_symbolic_transform():
    out = run_cli("manipkit", "dh", "show", "planar_2r", "--symbolic", status=0).stdout
    assert "standard DH" in out and "┌" in out
    # Hand value: 0T2 of a 2R arm with l1 = l2 = 1 has x = c_1 + c_12.
    assert "c₁ + c₁₂" in out and "s₁ + s₁₂" in out


def test_dh_gravity_prints_the_textbook_torques_of_a_vertical_2r():
    # planar_2r (unit links, standard DH), y up, point masses m1, m2 at the link ends (the DH frames' origins):
    # V = g (m1 s_1 + m2 (s_1 + s_12)), so g1 = g (m1 c_1 + m2 c_1 + m2 c_12) and g2 = g m2 c_12.
    out = run_cli("manipkit", "dh", "gravity", "planar_2r", "--mass", "m1", "m2", "--up", "y", status=0).stdout
    assert "gravity -g along y" in out and "g⋅(c₁⋅m₁ + c₁⋅m₂ + c₁₂⋅m₂)" in out and "c₁₂⋅g⋅m₂" in out
    # numbers, masses 1 and 2 kg at mid-links (-0.5, 0, 0) in each DH frame, g = 9.81:
    # g1 = 9.81 (1 * 0.5 + 2 * 1) c_1 + 9.81 * 2 * 0.5 c_12 = 24.525 c_1 + 9.81 c_12, g2 = 9.81 c_12.
    out = run_cli("manipkit", "dh", "gravity", "planar_2r", "--mass", "1", "2", "--cog", "-0.5", "0", "0", "--cog",
                  "-0.5", "0", "0", "--gravity", "0", "-9.81", "0", status=0).stdout
    assert "24.525⋅c₁ + 9.81⋅c₁₂" in out and "9.81⋅c₁₂" in out


@pytest.mark.parametrize("args, message", [
    (("--mass", "1"), "masses: give 2 values"),
    (("--mass", "1", "-2"), "mass 2 = -2 kg: give a mass >= 0 kg"),
    (("--mass", "1", "2", "--gravity", "0", "nan", "0"), "--gravity [0, nan, 0]: give 3 finite numbers (m/s^2)"),
    (("--mass", "1", "m 2"), "mass 2 'm 2': give a number or a symbol name"),
])
def test_dh_gravity_refuses_bad_input_in_one_line(args, message):
    result = run_cli("manipkit", "dh", "gravity", "planar_2r", *args, status=2)
    assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_dh_show_latex():
    out = run_cli("manipkit", "dh", "show", "iiwa14_seed004", "--latex", status=0).stdout
    assert "\\begin{bmatrix}" in out or "\\left[" in out


def test_dh_check_seed_table_fails_with_its_diagnosis():
    result = run_cli("manipkit", "dh", "check", "iiwa14_seed004", "--robot", "iiwa14", status=1)
    assert "FAIL" in result.stdout
    assert "joint 2 (iiwa_joint_2) turns the other way" in result.stdout
    assert "with joint(s) 2, 6 reversed, a constant tool transform xyz [0 0 0] m, rpy [0 0 180] deg" in result.stdout
    data = json.loads(run_cli("manipkit", "dh", "check", "iiwa14_seed004", "--robot", "iiwa14", "--format", "json", status=1).stdout)
    assert {"max_position_error", "max_rotation_error", "pass", "diagnosis"} <= set(data)
    assert data["pass"] is False and data["max_position_error"] > 1.0


def test_dh_check_corrected_table_passes():
    data = json.loads(run_cli("manipkit", "dh", "check", "iiwa14", "--robot", "iiwa14", "--format", "json", status=0).stdout)
    assert data["pass"] is True and data["max_position_error"] <= 1e-9 and data["diagnosis"] == []


def test_dh_from_urdf_output_passes_dh_check(tmp_path):
    path = tmp_path / "ur5.yaml"
    run_cli("manipkit", "dh", "from-urdf", "--robot", "ur5", "--base", "base", "--tip", "tool0", "--convention", "modified", "-o", path, status=0)
    run_cli("manipkit", "dh", "check", path, "--robot", "ur5", "--base", "base", "--tip", "tool0", status=0)


def test_dh_to_urdf_loads_and_matches_the_table(tmp_path):
    # The URDF written for the planar 3R table is a robot whose ee_link sits at x = 4 + 2 + 1 = 7 at q = 0.
    path = tmp_path / "p3.urdf"
    run_cli("manipkit", "dh", "to-urdf", "planar_3r", "-o", path, status=0)
    out = json.loads(run_cli("tf-between", "base_link", "ee_link", "--robot", path, "--format", "json", status=0).stdout)
    assert out["translation"] == pytest.approx([7, 0, 0], abs=1e-12)


def test_dh_check_unknown_table_exits_2():
    result = run_cli("manipkit", "dh", "check", "iiwa15", "--robot", "iiwa14", status=2)
    assert "DH table not found: iiwa15; did you mean iiwa14" in result.stderr


def test_dh_check_wrong_count_is_a_mismatch():
    result = run_cli("manipkit", "dh", "check", "planar_2r", "--robot", "planar_3r", status=1)
    assert "the table has 2 rows but the URDF chain base_link -> ee_link has 3 movable joints" in result.stdout


def test_workspace_json_and_plot(tmp_path):
    # Seed 004: lengths 4 2 1 reach 1 <= r <= 7 (|4 - 2 - 1| to 4 + 2 + 1) and every orientation for 3 <= r <= 5.
    path = tmp_path / "ws.png"
    data = json.loads(run_cli("manipkit", "workspace", "--robot", "planar_3r", "--plot", path, "--format", "json", status=0).stdout)
    assert data["reachable"] == pytest.approx([1, 7]) and data["dexterous"] == pytest.approx([3, 5])
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_workspace_of_a_non_planar_robot_exits_2():
    result = run_cli("manipkit", "workspace", "--robot", "course_arm", status=2)
    assert "needs a 2R or 3R arm" in result.stderr


def test_ik_solution_is_accepted_back_by_tf_between():
    # Target: the iiwa's flange pose at a known configuration; the answer, fed to tf-between, must reproduce it.
    q_known = ["iiwa_joint_1=0.3", "iiwa_joint_2=0.5", "iiwa_joint_4=-1.2", "iiwa_joint_6=0.7"]
    pose = tf_json("base_link", "ee_link", "--robot", "iiwa14", "--q", *q_known)
    out = json.loads(run_cli("manipkit", "ik", "--robot", "iiwa14", "--xyz", *pose["translation"], "--rpy", *pose["rpy"],
                         "--format", "json", status=0).stdout)
    assert out["success"] is True and out["residual_position"] < 1e-9 and out["residual_rotation"] < 1e-9
    answer = [f"{k}={v!r}" for k, v in out["solutions"][0].items()]
    back = tf_json("base_link", "ee_link", "--robot", "iiwa14", "--q", *answer)
    assert np.abs(np.array(back["matrix"]) - np.array(pose["matrix"])).max() < 1e-9


def test_ik_analytic_stanford_gives_four_labelled_solutions():
    q = ["joint1=0.4", "joint2=0.7", "joint3=0.5", "joint4=0.3", "joint5=1.1", "joint6=-0.4"]
    pose = tf_json("base_link", "ee_link", "--robot", "stanford_arm", "--q", *q)
    result = run_cli("manipkit", "ik", "--robot", "stanford_arm", "--analytic", "--all", "--xyz", *pose["translation"],
                 "--rpy", *pose["rpy"], status=0)
    assert "closed form (textbook stanford_arm, frame ee_link in base_link): 4 solution(s)" in result.stdout
    assert "[front, no flip]" in result.stdout and "[back, flip]" in result.stdout


def test_ik_analytic_without_a_closed_form_exits_2():
    result = run_cli("manipkit", "ik", "--robot", "iiwa14", "--analytic", "--xyz", "0.3", "0", "0.5", status=2)
    assert "no closed-form solver for robot 'iiwa14'" in result.stderr


def test_ik_unreachable_reports_failure_with_residual():
    out = json.loads(run_cli("manipkit", "ik", "--robot", "iiwa14", "--xyz", "3", "0", "0", "--restarts", "3",
                         "--format", "json", status=1).stdout)
    assert out["success"] is False and out["solutions"] == []
    # The flange reaches at most 1.148 m from joint 1's origin at z = 0.1575, and (3, 0, 0) is 3.004 m from it.
    assert out["residual_position"] >= 3.004 - 1.148 - 1e-6
    assert "target out of reach" in out["notes"][0]


def test_ik_course_arm_position_only_when_no_orientation_given():
    pose = tf_json("base_link", "ee_link", *q_args(POSE_B))
    out = json.loads(run_cli("manipkit", "ik", "--xyz", *pose["translation"], "--format", "json", status=0).stdout)
    assert out["mode"] == "position" and out["residual_position"] < 1e-9


@pytest.mark.parametrize(("argv", "prog"), [
    (("view", "--view-html"), "manipkit view"),  # issue 25: pointed to `manipkit --help`
    (("dh", "check", "T.yaml", "--bogus"), "manipkit dh check"),
    (("--bogus", "robots"), "manipkit"),
])
def test_an_unknown_argument_points_to_the_help_of_the_command_given_it(argv, prog):
    result = run_cli("manipkit", *argv)
    assert result.returncode == 2
    assert result.stderr == f"{prog}: error: unrecognized arguments: {argv[-1] if prog != 'manipkit' else '--bogus'} (see {prog} --help)\n"


def test_every_command_names_a_chains_tip_with_tip_and_keeps_frame_as_its_alias():
    # One flag for the chain's tip everywhere (ik, jacobian, dexterity, reachmap, torques, family, dh): --tip,
    # with --frame accepted where it was the spelling, both filling the same option.
    import argparse

    from manipkit.app.cli import parsers

    main = parsers()["manipkit"]
    commands = next(a for a in main._actions if isinstance(a, argparse._SubParsersAction)).choices
    for name, parser in commands.items():
        options = {s: a for a in parser._actions for s in a.option_strings}
        if "--frame" in options:
            assert "--tip" in options and options["--frame"] is options["--tip"], name
            assert options["--tip"].dest == "tip", name
    both = [run_cli("manipkit", "jacobian", "--robot", "planar_2r", flag, "link2", "--format", "json", status=0).stdout
            for flag in ("--tip", "--frame")]
    assert both[0] == both[1]


# ur5 (example-robot-data): wrist_3_link-tool0_fixed_joint is fixed, origin xyz 0 0.0823 0, rpy -pi/2 0 0: no joint
# joins wrist_3_link and tool0. Every command about a chain refuses the pair in one line (issue 38).
NO_JOINT_COMMANDS = [
    ["jacobian"],
    ["dexterity"],
    ["ik", "--xyz", "0", "0.0823", "0"],
    ["ik", "--all", "--xyz", "0", "0.0823", "0"],
    ["family"],
    ["torques"],
    ["payload"],
    ["force-capacity"],
    ["path", "--line", *["0"] * 12],
    ["reachmap", "-o", "MAP"],
]


@pytest.mark.parametrize("command", NO_JOINT_COMMANDS, ids=lambda c: " ".join(c[:2]))
def test_every_chain_command_refuses_frames_fixed_to_each_other(command, tmp_path):
    words = [str(tmp_path / "map") if w == "MAP" else w for w in command]
    result = run_cli("manipkit", *words, "--robot", "ur5", "--base", "wrist_3_link", "--tip", "tool0", status=2)
    assert result.stdout == "" and result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert result.stderr == (
        "manipkit: error: robot 'ur5': base wrist_3_link and tip tool0 are fixed to each other, joined by no joint, "
        "so there is no chain to move; give a base and a tip with a joint between them (`tf-between wrist_3_link "
        "tool0` gives their fixed transform)\n")
    assert not (tmp_path / "map").exists()


def test_an_alias_in_the_refusal_names_its_link():
    # the panda's ee_link is panda_hand_tcp (its own tool frame); relative to itself it is the same frame
    result = run_cli("manipkit", "jacobian", "--robot", "panda", "--base", "ee_link", "--tip", "panda_hand_tcp",
                     status=2)
    assert "base ee_link (panda_hand_tcp) and tip panda_hand_tcp are the same frame, joined by no joint" in (
        result.stderr)


def test_tf_between_frames_fixed_to_each_other_is_still_their_fixed_transform():
    # not a chain command: T_wrist_3_link_tool0 is the joint's origin, xyz (0, 0.0823, 0), Rx(-pi/2), at any q
    out = tf_json("wrist_3_link", "tool0", "--robot", "ur5", "--q", "wrist_3_joint=1.2")
    c, s = np.cos(-np.pi / 2), np.sin(-np.pi / 2)
    expected = [[1, 0, 0, 0], [0, c, -s, 0.0823], [0, s, c, 0], [0, 0, 0, 1]]
    np.testing.assert_allclose(out["matrix"], expected, atol=1e-11)
