"""``manipkit jacobian`` and ``manipkit dexterity`` as a user runs them: the entry point called in process."""

import json

import numpy as np
import pinocchio as pin
import pytest
from cli_helper import run_cli


def run(*args, status=0):
    """``manipkit ARGS`` (tests/cli_helper.py) with this file's checks on every run: the status, no traceback."""
    result = run_cli("manipkit", *args, status=status)
    assert "Traceback" not in result.stdout + result.stderr
    return result


def jacobian_json(*args):
    return json.loads(run("jacobian", *args, "--format", "json").stdout)


def test_json_has_the_contract_keys_and_pinocchios_numbers(iiwa14):
    q = iiwa14.sample_q(1, seed=2)[0]
    report = jacobian_json("--robot", "iiwa14", "--q", *q)
    assert {"jacobian", "joints", "chain_joints", "reference", "manipulability", "length", "manipulability_translation",
            "condition_number", "singular_values", "singular", "singular_families", "lost_directions",
            "lost_motions", "same_axis", "movable_rows"} <= set(report)
    assert report["joints"] == list(iiwa14.joint_names) and report["reference"] == "base"
    config = iiwa14.pinocchio_configuration(q)
    data = iiwa14.model.createData()
    expected = pin.computeFrameJacobian(iiwa14.model, data, config, iiwa14.frame_id("ee_link"), pin.LOCAL_WORLD_ALIGNED)
    J = np.array(report["jacobian"])
    np.testing.assert_allclose(J, expected, rtol=0, atol=1e-12)
    s = np.linalg.svd(J, compute_uv=False)  # length 1 m: the rows as they are
    assert report["length"] == 1.0
    np.testing.assert_allclose(report["singular_values"], s, rtol=1e-12)
    np.testing.assert_allclose(report["manipulability"], np.prod(s), rtol=1e-12)
    np.testing.assert_allclose(report["manipulability_translation"],
                               np.sqrt(np.linalg.det(J[:3] @ J[:3].T)), rtol=1e-10)
    np.testing.assert_allclose(report["condition_number"], s[0] / s[-1], rtol=1e-12)
    assert report["singular"] is False and report["singular_families"] == [] and report["lost_motions"] == []


def test_local_reference_and_length(iiwa14):
    q = iiwa14.sample_q(1, seed=3)[0]
    report = jacobian_json("--robot", "iiwa14", "--q", *q, "--reference", "local", "--length", "0.5")
    config = iiwa14.pinocchio_configuration(q)
    expected = pin.computeFrameJacobian(iiwa14.model, iiwa14.model.createData(), config, iiwa14.frame_id("ee_link"),
                                        pin.LOCAL)
    np.testing.assert_allclose(report["jacobian"], expected, rtol=0, atol=1e-12)
    scaled = np.vstack([expected[:3], 0.5 * expected[3:]])
    np.testing.assert_allclose(report["manipulability"], np.prod(np.linalg.svd(scaled, compute_uv=False)), rtol=1e-10)


def test_planar_2r_text_by_hand():
    # l1 = l2 = 1 at q = (0, 90 deg): p = (c1 + c12, s1 + s12); dp/dq1 = (-s1 - s12, c1 + c12) = (-1, 1),
    # dp/dq2 = (-s12, c12) = (-1, 0); translation manipulability l1 l2 |sin q2| = 1.
    out = run("jacobian", "--robot", "planar_2r", "--q", "0", "90", "--deg").stdout
    lines = out.splitlines()
    header = next(i for i, line in enumerate(lines) if line.split() == ["joint1", "joint2"])
    rows = {line.split()[0]: [float(v) for v in line.split()[1:]] for line in lines[header + 1 : header + 7]}
    assert list(rows) == ["vx", "vy", "vz", "wx", "wy", "wz"]
    assert rows["vx"] == [-1.0, -1.0] and rows["vy"] == [1.0, 0.0] and rows["wz"] == [1.0, 1.0]
    assert "manipulability (Yoshikawa, translation rows): 1\n" in out
    assert "LOCAL_WORLD_ALIGNED" in out and "singular: no" in out
    assert "rank: 2 of 2 (all rows), 2 of 2 (translation rows), 1 of 1 (rotation rows)" in out


@pytest.mark.parametrize(("robot", "q", "singular"), [
    ("planar_2r", ["0.3", "0"], True),  # elbow straight: the translation rows lose rank
    ("planar_2r", ["0.3", "1"], False),
    ("scara", ["0.3", "0", "0.1", "0"], True),  # q2 = 0: a1 a2 sin q2 = 0
    ("iiwa14", [], True),  # all zeros: the arm stands straight up, axes 1, 3, 5, 7 aligned
])
def test_singular_configurations_are_flagged(robot, q, singular):
    report = jacobian_json("--robot", robot, *(["--q", *q] if q else []))
    assert report["singular"] is singular
    if singular:
        assert report["rank"] < report["generic_rank"] or report["rank_translation"] < report["generic_rank_translation"]
        assert report["singular_families"] and report["lost_motions"]
    else:
        assert report["singular_families"] == [] and report["lost_motions"] == [] and report["lost_directions"] == []


def test_non_root_base_and_frame_alias(iiwa14):
    q = iiwa14.sample_q(1, seed=4)[0]
    report = jacobian_json("--robot", "iiwa14", "--q", *q, "--frame", "iiwa_link_6", "--base", "iiwa_link_2")
    J = np.array(report["jacobian"])
    assert np.all(J[:, :2] == 0.0)  # joints 1 and 2 are above the base
    h = 1e-6  # central difference of the position of link 6 in link 2 along joint 4
    step = np.zeros(7)
    step[3] = h
    dp = (iiwa14.transform("iiwa_link_2", "iiwa_link_6", q + step)[:3, 3]
          - iiwa14.transform("iiwa_link_2", "iiwa_link_6", q - step)[:3, 3]) / (2 * h)
    np.testing.assert_allclose(J[:3, 3], dp, atol=1e-7)


def test_dexterity_text_and_json():
    out = run("dexterity", "--robot", "planar_2r", "--samples", "4000", "--axes", "vx,vy").stdout
    assert "GCI = " in out and "95% confidence interval" in out and "4000 samples" in out
    report = json.loads(run("dexterity", "--robot", "planar_2r", "--samples", "4000", "--axes", "vx,vy", "--format",
                            "json", "--seed", "3").stdout)
    low, high = report["interval"]
    assert low < report["gci"] < high and report["samples"] == 4000 and report["length"] is None
    again = json.loads(run("dexterity", "--robot", "planar_2r", "--samples", "4000", "--axes", "vx,vy", "--format",
                           "json", "--seed", "3").stdout)
    assert again["gci"] == report["gci"]  # seeded


def test_dexterity_progress_goes_to_stderr_only():
    result = run("dexterity", "--robot", "iiwa14", "--samples", "3000", "--progress", "yes", "--format", "json")
    json.loads(result.stdout)  # stdout is the answer alone


@pytest.mark.parametrize(("args", "fragment"), [
    (["jacobian", "--robot", "planar_2r", "--frame", "nowhere"], "has no frame 'nowhere'"),
    (["jacobian", "--robot", "planar_2r", "--q", "1", "2", "3"], "got 3 values but planar_2r has 2 joints"),
    (["jacobian", "--robot", "planar_2r", "--reference", "world"], "invalid choice: 'world'"),
    (["jacobian", "--robot", "planar_2r", "--length", "-1"], "--length -1: give a length in metres from 1e-09 to 1e+06"),
    # issue 26: --length 1e308 printed nan (the angular rows times 1e308 overflow)
    (["jacobian", "--robot", "planar_2r", "--length", "1e308"], "--length 1e+308: give a length in metres from 1e-09"),
    (["dexterity", "--robot", "planar_2r", "--length", "1e308"], "--length 1e+308: give a length in metres from 1e-09"),
    (["jacobian", "--robot", "planar_2r", "--singular-tol", "nan"], "--singular-tol nan"),
    (["jacobian", "--robot", "planar_2r", "--q", "joint2=9"], "did you mean degrees? add --deg"),
    (["dexterity", "--robot", "planar_2r", "--samples", "1"], "--samples 1: give at least 2"),
    (["dexterity", "--robot", "planar_2r", "--axes", "vx,vq"], "--axes vx,vq: give all, trans, rot"),
    (["dexterity", "--robot", "planar_2r", "--confidence", "95"], "--confidence 95: give a level between 0 and 1"),
])
def test_bad_input_is_one_line_and_exit_2(args, fragment):
    result = run(*args, status=2)
    assert result.stderr.count("\n") == 1 and "error" in result.stderr, result.stderr
    assert fragment in result.stderr, result.stderr


def test_a_singular_configuration_names_its_family_and_the_lost_motion():
    # Stanford arm with the wrist straight (joint5 = 0): joints 4 and 6 turn about one axis (hand derivation in
    # manipkit.analysis.singularities); the boom is kept off joint 1's axis (joint2 = 0.7) and out (joint3 = 0.5).
    # Equal columns: turning joint 4 forward and joint 6 back by as much, (1, -1)/sqrt2, leaves the tool still.
    out = json.loads(run("jacobian", "--robot", "stanford_arm", "--q", "joint2=0.7", "joint3=0.5", "joint5=0",
                         "--format", "json").stdout)
    assert out["singular"] is True
    assert out["singular_families"] == [{"name": "wrist", "condition": "joint5 = 0 or 180 deg"}]
    assert out["same_axis"] == [["joint4", "joint6"]]
    [motion] = out["lost_motions"]
    assert motion["still"] == "frame"
    rates = {name: rate for name, rate in motion["joint_rates"].items() if rate}
    assert rates == {"joint4": pytest.approx(0.5**0.5, abs=1e-12), "joint6": pytest.approx(-(0.5**0.5), abs=1e-12)}
    regular = json.loads(run("jacobian", "--robot", "stanford_arm", "--q", "joint2=0.7", "joint3=0.5", "joint5=0.4",
                             "--format", "json").stdout)
    assert regular["singular"] is False and regular["singular_families"] == [] and regular["lost_motions"] == []


def test_a_singular_arm_on_a_wheeled_base_names_the_arm_joints_only():
    # mobile_manipulator at q = 0: its course arm stands straight up and loses rank (translation rank 2 of 3); the wheels'
    # columns are zero and must not enter the indices or the words
    out = json.loads(run("jacobian", "--robot", "mobile_manipulator", "--length", "0.3", "--format", "json").stdout)
    assert out["singular"] is True and len(out["jacobian"][0]) == 7 and len(out["chain_joints"]) == 5
    assert (out["rank_translation"], out["generic_rank_translation"]) == (2, 3)
    assert not any("wheel" in joint for joint in out["chain_joints"])
    assert all(set(motion["joint_rates"]) == set(out["chain_joints"]) for motion in out["lost_motions"])
    text = run("jacobian", "--robot", "mobile_manipulator", "--length", "0.3").stdout
    assert "wheel" not in text.split("singular: yes")[1]


def singular_lines(out: str) -> list[str]:
    """The lines from ``singular:`` on."""
    lines = out.splitlines()
    return lines[next(i for i, line in enumerate(lines) if line.startswith("singular:")):]


def test_iiwa14_upright_says_what_each_motion_keeps_still():
    # q = 0 (hand derivation in tests/test_analysis_jacobian_report.py): joints 1, 3, 5, 7 turn about the z axis
    # through the flange origin, so each alone keeps the origin still and spins the flange at 1 rad/s; pairs of
    # them turning opposite ways leave the whole flange still. Both families that hold are named.
    lines = singular_lines(run("jacobian", "--robot", "iiwa14").stdout)
    assert lines[0] == ("singular: yes (families: elbow straight: iiwa_joint_4 = 0 or 180 deg; shoulder and wrist axes "
                        "aligned: iiwa_joint_2 = 0 or 180 deg and iiwa_joint_6 = 0 or 180 deg)")
    assert lines[1:5] == [
        "  iiwa_joint_1, iiwa_joint_3, iiwa_joint_5 and iiwa_joint_7 turn about the same axis",
        "  the origin cannot move along (0, 1, 0)",
        "  the origin cannot move along (0, 0, 1)",
        "  the frame cannot turn about (1, 0, 0)",
    ]
    assert "  iiwa_joint_1 and iiwa_joint_7 moving as (0.707, -0.707) leave the frame still" in lines
    assert "  iiwa_joint_1 alone keeps the origin still and turns the frame at 1 rad/s about (0, 0, 1)" in lines
    assert not any("iiwa_joint_7 alone" in line or "does not move" in line for line in lines)


def test_scara_tool_roll_keeps_the_origin_still():
    # joint4 turns about -z through the tool origin: alone it keeps the origin still and turns the tool
    lines = singular_lines(run("jacobian", "--robot", "scara", "--q", "0.3", "0", "0.1", "0").stdout)
    assert "  joint4 alone keeps the origin still and turns the frame at 1 rad/s about (0, 0, -1)" in lines
    assert not any("does not move" in line for line in lines)


def test_planar_2r_straight_turns_the_tool_and_never_loses_z():
    # q = (0.3, 0): (-1, 2)/sqrt5 keeps the origin still and turns the tool at 1/sqrt5 = 0.447 rad/s; the origin
    # cannot move along the arm, (cos 0.3, sin 0.3, 0); vz is 0 at every configuration of a planar arm
    out = run("jacobian", "--robot", "planar_2r", "--q", "0.3", "0").stdout
    assert "rows the arm moves: vx, vy, wz (vz, wx, wy are 0 at every configuration, so never lost)" in out
    assert singular_lines(out) == [
        "singular: yes (family: elbow straight: joint2 = 0 or 180 deg)",
        "  the origin cannot move along (0.955, 0.296, 0)",
        "  joint1 and joint2 moving as (-0.447, 0.894) keep the origin still and turn the frame at 0.447 rad/s "
        "about (0, 0, 1)",
    ]


def test_stanford_default_names_the_wrist_and_the_boom():
    lines = singular_lines(run("jacobian", "--robot", "stanford_arm").stdout)
    assert lines[0] == ("singular: yes (families: wrist: joint5 = 0 or 180 deg; boom along joint 1's axis: "
                        "joint2 = 0 or 180 deg)")


def test_a_frame_relative_to_itself_is_refused_as_a_chain_with_no_joint():
    # issue 38: this printed a zero Jacobian, "rank 0 of 0" and "condition number inf". The library keeps the
    # mathematically right answer for a chain with no joints (Chain.jacobian is a (6, 0) array, jacobian_report
    # has rank 0: tests/test_kinematics_chain.py, tests/test_analysis_jacobian_report.py); the command, which is
    # about a chain, refuses it in one line naming the two frames (app.cli.common.command_chain).
    result = run("jacobian", "--robot", "planar_2r", "--base", "ee_link", "--frame", "ee_link", "--format", "json",
                 status=2)
    assert result.stdout == "" and result.stderr.count("\n") == 1
    assert "base ee_link and tip ee_link are the same frame, joined by no joint" in result.stderr


def test_a_base_below_the_frame_gives_the_jacobian_of_the_chain_up_the_tree():
    # planar 2R, unit links, q = 0: seen from ee_link (at x = 2), base_link sits at -2 along ee_link's x. Turning
    # joint 2 by +w turns the base by -w about z around joint 2 (1 m behind ee_link): its origin moves at
    # (0, +1, 0) and spins at -1; joint 1 turns it by -w about its own origin: no velocity, spin -1. Columns in
    # the robot's joint order (joint1, joint2); the chain lists its entries base to tip, up from ee_link.
    report = jacobian_json("--robot", "planar_2r", "--base", "ee_link", "--frame", "base_link", "--q", "joint1=0",
                           "--q", "joint2=0")
    assert report["chain_joints"] == ["joint2", "joint1"] and report["joints"] == ["joint1", "joint2"]
    np.testing.assert_allclose(report["jacobian"], [[0, 0], [0, 1], [0, 0], [0, 0], [0, 0], [-1, -1]], atol=1e-12)


def test_the_text_matrix_has_the_chains_own_columns_only(panda):
    # The panda's finger joint does not move panda_hand_tcp relative to panda_link0: the text shows the seven arm
    # columns, each equal to Pinocchio's column of that joint (the JSON keeps one column per robot joint).
    q = panda.sample_q(1, seed=4)[0]
    text = run("jacobian", "--robot", "panda", "--q", *q, "--precision", "9").stdout.splitlines()
    header = next(line for line in text if line.lstrip().startswith("panda_joint1"))
    assert header.split() == [f"panda_joint{i}" for i in range(1, 8)]
    rows = [line.split() for line in text if line[:2] in ("vx", "vy", "vz", "wx", "wy", "wz")]
    shown = np.array([[float(v) for v in row[1:]] for row in rows])
    config = panda.pinocchio_configuration(q)
    expected = pin.computeFrameJacobian(panda.model, panda.model.createData(), config, panda.frame_id("ee_link"),
                                        pin.LOCAL_WORLD_ALIGNED)
    arm = [panda.joint_names.index(f"panda_joint{i}") for i in range(1, 8)]
    np.testing.assert_allclose(shown, expected[:, arm], atol=1e-9)
