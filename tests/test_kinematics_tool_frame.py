"""Which link ee_link means (issue 25): the arm's tool frame, never a finger.

The rule is manipkit.kinematics.tool_frame's; here it is checked on hand-built
trees and on every real description in ../shared/realworld, each loaded the
way its users load it (file path and launch-file arguments), with the frame a
user of that arm would name written next to it.
"""

from pathlib import Path

import pytest

import manipkit
from manipkit.kinematics.tool_frame import choose_tool_frame

REALWORLD = next((base / "shared" / "realworld" for base in Path(__file__).resolve().parents[2:4]
                  if (base / "shared" / "realworld").is_dir()), Path("/nonexistent"))
ROS1, MORE = REALWORLD / "ws_ros1" / "src", REALWORLD / "ws_more" / "src"

#: setup -> (file, xacro arguments, the tool frame chosen, why a user would name it)
SETUPS = {
    "ur5e": (ROS1 / "universal_robot/ur_description/urdf/ur5e.xacro", {}, "tool0", "ROS-Industrial's tool frame"),
    "panda with hand": (ROS1 / "franka_ros/franka_description/robots/panda/panda.urdf.xacro", {"hand": "true"},
                        "panda_hand_tcp", "the hand's TCP, not panda_leftfinger"),
    "pr2": (ROS1 / "pr2_common/pr2_description/robots/pr2.urdf.xacro", {}, "l_gripper_tool_frame",
            "the gripper's tool frame (of two arms, the first by name)"),
    "abb irb2400": (ROS1 / "abb/abb_irb2400_support/urdf/irb2400.xacro", {}, "tool0", "ROS-Industrial's tool frame"),
    "xarm7 with gripper": (MORE / "xarm_ros2/xarm_description/urdf/xarm_device.urdf.xacro",
                           {"dof": "7", "robot_type": "xarm", "add_gripper": "true"}, "link_tcp",
                           "the gripper's TCP, not left_finger"),
    "xarm6": (MORE / "xarm_ros2/xarm_description/urdf/xarm_device.urdf.xacro", {"dof": "6", "robot_type": "xarm"},
              "link_eef", "the flange UFactory names"),
    "fr3 with hand": (MORE / "franka_description/robots/fr3/fr3.urdf.xacro", {"hand": "true", "ee_id": "franka_hand"},
                      "fr3_hand_tcp", "the hand's TCP, not fr3_leftfinger"),
    "wx250s": (MORE / "interbotix_ros_manipulators/interbotix_ros_xsarms/interbotix_xsarm_descriptions/urdf/wx250s.urdf.xacro",
               {"robot_name": "wx250s", "use_world_frame": "true"}, "wx250s/ee_gripper_link",
               "Interbotix's end-effector frame between the fingers"),
    "fetch": (MORE / "fetch_ros/fetch_description/robots/fetch.urdf", {}, "gripper_link",
              "the gripper, where the two fingers split (not l_gripper_finger_link)"),
    "sawyer with gripper": (MORE / "sawyer_robot/sawyer_description/urdf/sawyer.urdf.xacro", {"electric_gripper": "true"},
                            "right_gripper_tip", "the electric gripper's tip"),
    "tiago with gripper": (MORE / "tiago_robot/tiago_description/robots/tiago.urdf.xacro", {"end_effector": "pal-gripper"},
                           "gripper_grasping_frame", "PAL's grasping frame"),
    "tiago with hey5": (MORE / "tiago_robot/tiago_description/robots/tiago.urdf.xacro", {}, "hand_grasping_frame",
                        "PAL's grasping frame, not hand_index_flex_3_link"),
}


@pytest.mark.skipif(not REALWORLD.is_dir(), reason=f"the shared real-world workspaces are not here ({REALWORLD})")
@pytest.mark.parametrize("setup", SETUPS)
def test_real_arms_get_their_tool_frame_not_a_finger(setup):
    path, args, expected, _why = SETUPS[setup]
    robot = manipkit.load(path, **args)
    assert robot.frame("ee_link") == expected
    assert robot.ee_reason.startswith(f"{expected}, ")
    assert "finger" not in expected


# Hand-built trees: (names, parent index, movable joint into the link)
ARM = ["base", "l1", "l2", "l3", "flange"]
ARM_PARENTS = [-1, 0, 1, 2, 3]
ARM_MOVES = [False, True, True, True, False]


def test_a_plain_arm_is_its_last_link():
    assert choose_tool_frame(ARM, ARM_PARENTS, [False, True, True, True, True]) == (
        "flange", "flange, named like an arm tool frame (tool0, flange, *_tcp, *_tool_link, link_eef, ...)")
    names = ["base", "l1", "l2", "l3", "tip"]
    assert choose_tool_frame(names, ARM_PARENTS, ARM_MOVES)[0] == "tip"


def test_an_arm_with_unnamed_fingers_gets_the_palm():
    names = [*ARM[:4], "palm", "finger_a", "finger_b"]
    parents = [*ARM_PARENTS[:4], 3, 4, 4]
    moves = [False, True, True, True, False, True, True]
    assert choose_tool_frame(names, parents, moves) == ("palm", "palm, the last link before the tree splits into fingers")


def test_a_base_with_wheels_and_an_arm_is_not_a_palm():
    # base -> wheel (1 joint), base -> l1 -> l2 -> l3 (3 joints): two short branches, but on a base, not an arm
    names = ["base", "wheel", "l1", "l2", "l3"]
    assert choose_tool_frame(names, [-1, 0, 0, 2, 3], [False, True, True, True, True])[0] == "l3"


def test_a_tcp_beyond_the_flange_wins_and_ee_link_wins_over_everything():
    names = [*ARM, "gripper_tcp"]
    assert choose_tool_frame(names, [*ARM_PARENTS, 4], [*ARM_MOVES, False])[0] == "gripper_tcp"
    assert choose_tool_frame([*names, "ee_link"], [*ARM_PARENTS, 4, 1], [*ARM_MOVES, False, False])[0] == "ee_link"
    assert choose_tool_frame(names, [*ARM_PARENTS, 4], [*ARM_MOVES, False], declared="l2")[0] == "l2"


def test_two_arms_tie_by_name_and_say_so():
    names = ["torso", "l_a", "l_tool_frame", "r_a", "r_tool_frame"]
    name, reason = choose_tool_frame(names, [-1, 0, 1, 0, 3], [False, True, False, True, False])
    assert name == "l_tool_frame" and "also r_tool_frame at the same depth (--tip chooses)" in reason


def test_an_srdf_end_effector_comes_first_then_the_deepest_chain_tip():
    # base - link1 - link6 (arm, 2 joints) - end_effector (fixed) ; link6 - finger (1 joint)
    names = ["base", "link1", "link6", "j2_end_effector", "finger"]
    parents, movable = [-1, 0, 1, 2, 2], [False, True, True, False, True]
    assert choose_tool_frame(names, parents, movable)[0] == "j2_end_effector"  # *_end_effector joins the name rule
    tips = ("link6", "finger", "link1")  # one <end_effector parent_link>, then two chain tips
    assert choose_tool_frame(names, parents, movable, srdf_tips=tips, srdf_ends=1, srdf="a.srdf") == (
        "link6", "link6, the end effector declared in a.srdf")
    chains = choose_tool_frame(names, parents, movable, srdf_tips=("link1", "link6"), srdf="a.srdf")
    assert chains == ("link6", "link6, the planning group's tip declared in a.srdf")  # 2 joints above beat 1
    # a link named ee_link is the name itself, never overridden
    assert choose_tool_frame([*names, "ee_link"], [*parents, 0], [*movable, False], srdf_tips=tips, srdf_ends=1)[0] \
        == "ee_link"
