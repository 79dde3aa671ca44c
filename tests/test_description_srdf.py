"""The SRDF a robot ships (manipkit.description.srdf): where it is found, what ee_link becomes, hostile files.

The expected files are found here independently of the module: by a glob of
the workspace and a regular expression on each file's ``<robot name>``, and
the expected tips by a regular expression on the SRDF's text.
"""

import json
import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from cli_helper import run_cli

import manipkit
from manipkit.description.sources import example_robot_data_dir
from manipkit.description.srdf import QUOTE_CHARS, parse_srdf, shipped_srdf
from manipkit.errors import CollisionError
from manipkit.spatial.transforms import transform_from_xyz_rpy

WS_NEW = Path(__file__).resolve().parents[2] / "shared" / "realworld" / "ws_new" / "src"
WS_NEW = WS_NEW if WS_NEW.is_dir() else Path("/work/shared/realworld/ws_new/src")
ERD = example_robot_data_dir()
KINOVA = ERD / "robots" / "kinova_description" / "robots" / "kinova.urdf"
BOX_ARM = Path(__file__).parent / "bad_inputs" / "collisions" / "arm.urdf"

needs_ws = pytest.mark.skipif(not WS_NEW.is_dir(), reason="the shared workspace ws_new is not on this machine")

#: (description, xacro arguments, the SRDF the workspace ships for it)
WORKSPACE_ARMS = [
    ("tmr_ros1/tm_description/xacro/tm5-900.urdf.xacro", {}, "tmr_ros1/tm5-900-moveit_config/config/tm5-900.srdf"),
    ("khi_robot/khi_rs_description/urdf/rs007n.urdf.xacro", {},
     "khi_robot/khi_rs007n_moveit_config/config/khi_rs007n.srdf"),
    ("open_manipulator/open_manipulator_description/urdf/omy_3m/omy_3m.urdf.xacro", {"prefix": ""},
     "open_manipulator/open_manipulator_moveit_config/config/omy_3m/omy_3m.srdf"),
]


def _robot_name(text: str) -> str:
    return re.search(r"<robot\b[^>]*\bname\s*=\s*\"([^\"]*)\"", text).group(1)


def _tip_by_regex(text: str) -> str:
    """The end effector's parent link, else the chain's tip link, read with a regular expression."""
    end = re.search(r"<end_effector\b[^>]*\bparent_link=\"([^\"]+)\"", text)
    return end.group(1) if end else re.search(r"<chain\b[^>]*\btip_link=\"([^\"]+)\"", text).group(1)


def test_parse_reads_pairs_sorted_and_end_effectors_before_chain_tips():
    srdf = parse_srdf('<robot name="r"><group name="arm"><chain base_link="a" tip_link="t"/></group>'
                      '<end_effector name="e" parent_link="hand" group="arm"/>'
                      '<disable_collisions link1="z" link2="a" reason="Adjacent"/>'
                      '<disable_collisions link1="b" link2="c"/></robot>', "r.srdf")
    assert srdf.disabled == (("a", "z", "Adjacent"), ("b", "c", "User"))
    assert srdf.tips == ("hand", "t") and srdf.end_effectors == 1 and srdf.robot == "r"


@needs_ws
@pytest.mark.parametrize("description, args, expected", WORKSPACE_ARMS, ids=["tm5-900", "rs007n", "omy_3m"])
def test_the_workspace_moveit_config_srdf_is_found_and_its_tip_is_ee_link(description, args, expected):
    robot = manipkit.load(WS_NEW / description, **args)
    # Independently: every *.srdf in the workspace whose <robot name> is the URDF's
    name = _robot_name(robot.urdf)
    same_name = [p for p in sorted(WS_NEW.rglob("*.srdf")) if _robot_name(p.read_text()) == name]
    assert same_name == [WS_NEW / expected]
    assert robot.srdf is not None and robot.srdf.path == WS_NEW / expected
    tip = _tip_by_regex((WS_NEW / expected).read_text())
    assert robot.frame("ee_link") == tip and (WS_NEW / expected).name in robot.ee_reason


def test_example_robot_data_panda_ships_its_srdf():
    robot = manipkit.load("panda")
    assert robot.srdf.path == ERD / "robots" / "panda_description" / "srdf" / "panda.srdf"
    pairs = re.findall(r"<disable_collisions link1=\"([^\"]+)\" link2=\"([^\"]+)\"", robot.srdf.path.read_text())
    assert len(robot.srdf.disabled) == len(pairs) == 35


def test_the_kinova_srdf_tip_is_ee_link_not_the_finger_tip():
    # The ERD Kinova Jaco2 (j2s6s200) by file path: its SRDF's chain and end effector name j2s6s200_end_effector
    robot = manipkit.load(KINOVA)
    assert robot.srdf.path.name == "kinova.srdf"
    assert robot.frame("ee_link") == "j2s6s200_end_effector" and "kinova.srdf" in robot.ee_reason
    # The tool frame is the URDF's fixed joint from link 6 (its origin, read here): 0.16 m further and rotated
    joint = next(j for j in ET.parse(KINOVA).getroot().findall("joint")
                 if j.find("child") is not None and j.find("child").get("link") == "j2s6s200_end_effector")
    origin = joint.find("origin")
    expected = transform_from_xyz_rpy([float(v) for v in origin.get("xyz").split()],
                                      [float(v) for v in origin.get("rpy").split()])
    assert joint.find("parent").get("link") == "j2s6s200_link_6"
    T = robot.transform("j2s6s200_link_6", "ee_link", robot.q())
    np.testing.assert_allclose(T, expected, atol=1e-12)
    assert abs(np.linalg.norm(T[:3, 3]) - 0.16) < 1e-3 and not np.allclose(T[:3, :3], np.eye(3))


def test_the_srdf_tip_comes_before_the_name_rule(tmp_path):
    # A Jaco2-like package whose SRDF ends its arm group at link 6: the SRDF wins over *_end_effector
    (tmp_path / "package.xml").write_text("<package><name>jaco_like</name></package>")
    shutil.copy(KINOVA, tmp_path / "kinova.urdf")
    (tmp_path / "kinova.srdf").write_text('<robot name="kinova"><group name="arm">'
                                          '<chain base_link="base" tip_link="j2s6s200_link_6"/></group></robot>')
    robot = manipkit.load(tmp_path / "kinova.urdf")
    assert robot.frame("ee_link") == "j2s6s200_link_6"
    assert robot.ee_reason == "j2s6s200_link_6, the planning group's tip declared in kinova.srdf"


def test_without_srdf_the_name_rule_chooses_the_end_effector_link(tmp_path):
    shutil.copy(KINOVA, tmp_path / "kinova.urdf")
    robot = manipkit.load(tmp_path / "kinova.urdf")
    assert robot.srdf is None and robot.frame("ee_link") == "j2s6s200_end_effector"
    assert "named like an arm tool frame" in robot.ee_reason


def _workspace(tmp_path: Path, srdf_text: str, config: str = "box_arm_moveit_config") -> Path:
    description = tmp_path / "ws" / "src" / "box_arm_description"
    (description / "urdf").mkdir(parents=True)
    (description / "package.xml").write_text("<package><name>box_arm_description</name></package>")
    shutil.copy(BOX_ARM, description / "urdf" / "arm.urdf")
    moveit = tmp_path / "ws" / "src" / config
    (moveit / "config").mkdir(parents=True)
    (moveit / "package.xml").write_text(f"<package><name>{config}</name></package>")
    (moveit / "config" / "box_arm.srdf").write_text(srdf_text)
    return description / "urdf" / "arm.urdf"


def test_an_srdf_for_another_variant_is_passed_over_and_said(tmp_path):
    urdf = _workspace(tmp_path, '<robot name="box_arm"><disable_collisions link1="upper" link2="forearm"/></robot>')
    robot = manipkit.load(urdf)
    assert robot.srdf is None and len(robot.srdf_notes) == 1 and "'forearm'" in robot.srdf_notes[0]
    out = run_cli("manipkit", "collisions", "--robot", urdf, status=0).stdout
    assert f"SRDF found but not used: {urdf.parents[3] / 'src' / 'box_arm_moveit_config' / 'config'}" in out


def test_an_srdf_of_another_robot_name_is_not_used(tmp_path):
    urdf = _workspace(tmp_path, '<robot name="other_arm"><disable_collisions link1="upper" link2="base_link"/>'
                                "</robot>")
    assert manipkit.load(urdf).srdf is None and manipkit.load(urdf).srdf_notes == ()


def test_a_workspace_srdf_is_found_in_its_moveit_config(tmp_path):
    urdf = _workspace(tmp_path, '<robot name="box_arm"><disable_collisions link1="upper" link2="base_link" '
                                'reason="Adjacent"/></robot>')
    srdf, notes = shipped_srdf(urdf, "box_arm", ["base_link", "upper", "lower"])
    assert srdf.path.parts[-3:] == ("box_arm_moveit_config", "config", "box_arm.srdf") and notes == ()
    assert srdf.pairs() == {("base_link", "upper"): "Adjacent"}


# ----------------------------------------------------------------------
# Hostile SRDFs: one line, status 2, a bounded quote; a hostile shipped file is passed over
# ----------------------------------------------------------------------


def test_a_link_name_of_10_mb_is_quoted_with_a_bounded_prefix(tmp_path):
    srdf = tmp_path / "long.srdf"
    srdf.write_text(f'<robot name="box_arm"><disable_collisions link1="upper" link2="{"x" * 10_000_000}"/></robot>')
    result = run_cli("manipkit", "collisions", "--robot", BOX_ARM, "--srdf", srdf, status=2)
    assert result.stdout == "" and result.stderr.count("\n") == 1 and len(result.stderr) < 600
    assert f"'{'x' * QUOTE_CHARS}...' (10,000,000 characters), which robot 'box_arm' does not have" in result.stderr


def test_a_huge_srdf_is_refused_before_it_is_read(tmp_path):
    srdf = tmp_path / "huge.srdf"
    with open(srdf, "wb") as stream:
        stream.truncate(17 * 1024 * 1024)  # sparse: 17 MB, above the 16 MB limit
    result = run_cli("manipkit", "collisions", "--robot", BOX_ARM, "--srdf", srdf, status=2)
    assert result.stderr.count("\n") == 1 and "above the limit of 16 MB" in result.stderr


def test_entities_are_refused_not_expanded():
    bomb = ('<?xml version="1.0"?><!DOCTYPE robot [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;&a;">]>'
            '<robot name="r"><disable_collisions link1="&b;" link2="c"/></robot>')
    with pytest.raises(CollisionError, match=r"x\.srdf:1: <!DOCTYPE>/<!ENTITY> declarations: an SRDF has none"):
        parse_srdf(bomb, "x.srdf")


def test_a_hostile_srdf_beside_the_description_is_passed_over(tmp_path):
    urdf = _workspace(tmp_path, '<?xml version="1.0"?><!DOCTYPE robot [<!ENTITY a "a">]><robot name="box_arm"/>')
    (urdf.parent / "box_arm.srdf").write_bytes(b"\xff\xfe not text")
    robot = manipkit.load(urdf)
    assert robot.srdf is None and robot.srdf_notes == ()


def test_tf_between_json_names_the_link_and_rule_of_each_alias():
    robot = manipkit.load(KINOVA)
    answer = json.loads(run_cli("tf-between", "base_link", "ee_link", "--robot", KINOVA, "--format", "json",
                                status=0).stdout)
    assert answer["ee_link"] == {"link": "j2s6s200_end_effector", "rule": robot.ee_reason}
    assert answer["base_link"] == {"link": robot.root_link, "rule": f"{robot.root_link}, the root link"}
    np.testing.assert_allclose(answer["matrix"], robot.transform(robot.root_link, "j2s6s200_end_effector", robot.q()),
                               atol=1e-12)
