"""Mimic, floating and planar joints (manipkit.kinematics.joints), checked against yourdfpy and chains composed by hand."""

from __future__ import annotations

import io
import math

import numpy as np
import pinocchio as pin
import pytest
import yourdfpy

from manipkit.errors import DescriptionError, IKOptionError, JointValueError
from manipkit.ik.numerical import ik
from manipkit.kinematics.robot import Robot

LIMIT = '<limit lower="-2" upper="2" effort="1" velocity="1"/>'


def _urdf(body: str, links: str) -> str:
    link_xml = "".join(f'<link name="{name}"/>' for name in links.split())
    return f'<robot name="t">{link_xml}{body}</robot>'


# A 2R arm whose second joint mimics the first (2 q1 + 0.1), then a prismatic slide, a prismatic mimic of it
# (-1 x + 0.05), and a revolute mimic of the first mimic (a mimic of a mimic: 0.5 (2 q1 + 0.1) - 0.2).
MIMIC = _urdf(
    f"""
<joint name="j1" type="revolute"><parent link="base_link"/><child link="a"/><axis xyz="0 0 1"/>{LIMIT}</joint>
<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/>{LIMIT}
  <mimic joint="j1" multiplier="2" offset="0.1"/></joint>
<joint name="slide" type="prismatic"><parent link="b"/><child link="c"/><origin xyz="0.5 0 0" rpy="0 0.3 0"/>
  <axis xyz="1 0 0"/>{LIMIT}</joint>
<joint name="slide_mimic" type="prismatic"><parent link="c"/><child link="d"/><origin xyz="0 0.2 0"/><axis xyz="0 1 0"/>{LIMIT}
  <mimic joint="slide" multiplier="-1" offset="0.05"/></joint>
<joint name="j3" type="revolute"><parent link="d"/><child link="e"/><origin xyz="0.3 0 0"/><axis xyz="0 1 1"/>{LIMIT}
  <mimic joint="j2" multiplier="0.5" offset="-0.2"/></joint>
<joint name="tip_joint" type="fixed"><parent link="e"/><child link="tip"/><origin xyz="0.1 0.2 0.3"/></joint>
""",
    "base_link a b c d e tip",
)


def _rot(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    T = np.eye(4)
    T[:3, :3] = pin.AngleAxis(angle, axis).matrix()
    return T


def _trans(x, y, z):
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def _rpy(roll, pitch, yaw):
    return _rot([0, 0, 1], yaw) @ _rot([0, 1, 0], pitch) @ _rot([1, 0, 0], roll)


def mimic_by_hand(q1, s):
    """T_base_tip composed joint by joint from the URDF above (origin, then the joint's motion)."""
    j2 = 2 * q1 + 0.1
    slide_mimic = -s + 0.05
    j3 = 0.5 * j2 - 0.2  # mimic of a mimic: follows j2's value
    return (_rot([0, 0, 1], q1) @ _trans(1, 0, 0) @ _rot([0, 0, 1], j2)
            @ _trans(0.5, 0, 0) @ _rpy(0, 0.3, 0) @ _trans(s, 0, 0)
            @ _trans(0, 0.2, 0) @ _trans(0, slide_mimic, 0)
            @ _trans(0.3, 0, 0) @ _rot([0, 1, 1], j3) @ _trans(0.1, 0.2, 0.3))


@pytest.fixture(scope="module")
def mimic_robot():
    return Robot.from_urdf(MIMIC)


def test_mimic_joints_have_no_entry_in_q(mimic_robot):
    assert mimic_robot.joint_names == ("j1", "slide")
    assert list(mimic_robot.mimic_joints) == ["j2", "slide_mimic", "j3"]
    j3 = mimic_robot.mimic_joints["j3"]
    assert (j3.leader, j3.declared) == ("j1", "j2")
    assert j3.multiplier == pytest.approx(1.0) and j3.offset == pytest.approx(0.05 - 0.2)


@pytest.mark.parametrize("q1, s", [(0.0, 0.0), (0.4, -0.3), (-1.1, 1.5), (1.9, 0.7)])
def test_mimic_fk_matches_the_chain_composed_by_hand(mimic_robot, q1, s):
    expected = mimic_by_hand(q1, s)
    np.testing.assert_allclose(mimic_robot.transform("base_link", "tip", [q1, s]), expected, atol=1e-12)
    np.testing.assert_allclose(mimic_robot.fk(np.array([q1, s]), tip="tip"), expected, atol=1e-12)


def test_mimic_fk_matches_yourdfpy_for_one_level_mimics():
    # yourdfpy follows a mimic of an independent joint (it takes a mimic of a mimic as 0 + offset, so j3 is left out)
    urdf = MIMIC.replace('<mimic joint="j2" multiplier="0.5" offset="-0.2"/>', "")
    robot = Robot.from_urdf(urdf)
    reference = yourdfpy.URDF.load(io.StringIO(urdf), build_scene_graph=True, load_meshes=False)
    assert set(reference.actuated_joint_names) == set(robot.joint_names)
    rng = np.random.default_rng(3)
    for q in rng.uniform(-2, 2, size=(5, 3)):
        reference.update_cfg({name: q[robot.joint_names.index(name)] for name in reference.actuated_joint_names})
        Q = np.array([q[robot.joint_names.index(n)] for n in robot.joint_names])
        for link in ("b", "c", "d", "e", "tip"):
            np.testing.assert_allclose(robot.transform("base_link", link, Q),
                                       reference.get_transform(link, "base_link"), atol=1e-12)


def test_batched_kernel_equals_the_single_path_with_mimics(mimic_robot):
    Q = mimic_robot.sample_q(200, seed=4)
    T = mimic_robot.fk(Q, tip="tip")
    for k in range(0, 200, 37):
        np.testing.assert_allclose(T[k], mimic_robot.transform("base_link", "tip", Q[k]), atol=1e-12)
    # from an intermediate link above the tip: one chain starting below the root
    T_c_tip = mimic_robot.fk(Q, base="c", tip="tip")
    np.testing.assert_allclose(T_c_tip[5], mimic_robot.transform("c", "tip", Q[5]), atol=1e-12)


def test_a_value_for_a_mimic_joint_names_its_leader(mimic_robot):
    with pytest.raises(JointValueError, match="'j2' mimics 'j1'.*give a value to 'j1'"):
        mimic_robot.q(j2=0.3)


def test_mimic_chain_contributes_its_leader_once(mimic_robot):
    assert mimic_robot.chain_joints("base_link", "tip") == ("j1", "slide")
    assert mimic_robot.chain_joints("b", "tip") == ("slide", "j1")  # j3 below b mimics j1 through j2


def test_ik_solves_through_mimic_joints_confirmed_by_fk(mimic_robot):
    q_true = np.array([0.3, 0.4])
    T = mimic_robot.transform("base_link", "tip", q_true)
    result = ik(mimic_robot, T, tip="tip", mode="position", q0=[0.0, 0.0], restarts=20)
    assert result.success
    np.testing.assert_allclose(mimic_robot.transform("base_link", "tip", result.q)[:3, 3], T[:3, 3], atol=1e-9)


def test_mimic_of_a_continuous_leader(tmp_path):
    urdf = _urdf(
        f"""<joint name="spin" type="continuous"><parent link="base_link"/><child link="a"/><axis xyz="0 0 1"/></joint>
<joint name="follow" type="revolute"><parent link="a"/><child link="b"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/>{LIMIT}
  <mimic joint="spin" multiplier="-1"/></joint>
<joint name="tipj" type="fixed"><parent link="b"/><child link="tip"/><origin xyz="1 0 0"/></joint>""",
        "base_link a b tip",
    )
    robot = Robot.from_urdf(urdf)
    q = 2.5
    # hand: the tip turns back by the same angle: T = Rz(q) Tx(1) Rz(-q) Tx(1): position (cos q + 1, sin q), no rotation
    T = robot.transform("base_link", "tip", [q])
    np.testing.assert_allclose(T[:3, 3], [math.cos(q) + 1, math.sin(q), 0], atol=1e-12)
    np.testing.assert_allclose(T[:3, :3], np.eye(3), atol=1e-12)
    np.testing.assert_allclose(robot.fk(np.array([q]), tip="tip"), T, atol=1e-12)


@pytest.mark.parametrize(
    "mimic, message",
    [
        ('<mimic joint="nope"/>', "<mimic joint=\"nope\">: no such joint"),
        ('<mimic joint="j1" multiplier="abc"/>', "multiplier=\"abc\": 'abc' is not a number"),
        ('<mimic joint="fixed_one"/>', "mimics 'fixed_one', a fixed joint"),
    ],
)
def test_bad_mimic_tags_are_one_line_errors(mimic, message):
    urdf = _urdf(
        f"""<joint name="j1" type="revolute"><parent link="base_link"/><child link="a"/><axis xyz="0 0 1"/>{LIMIT}</joint>
<joint name="fixed_one" type="fixed"><parent link="a"/><child link="b"/></joint>
<joint name="j2" type="revolute"><parent link="b"/><child link="c"/><axis xyz="0 0 1"/>{LIMIT}{mimic}</joint>""",
        "base_link a b c",
    )
    with pytest.raises(DescriptionError, match=message):
        Robot.from_urdf(urdf)


def test_mimics_in_a_circle_are_refused():
    urdf = _urdf(
        f"""<joint name="j1" type="revolute"><parent link="base_link"/><child link="a"/><axis xyz="0 0 1"/>{LIMIT}
<mimic joint="j2"/></joint>
<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>{LIMIT}<mimic joint="j1"/></joint>""",
        "base_link a b",
    )
    with pytest.raises(DescriptionError, match="in a circle"):
        Robot.from_urdf(urdf)


# --------------------------------------------------------------------------
# Floating and planar joints

MOBILE = _urdf(
    f"""
<joint name="base_joint" type="floating"><parent link="world"/><child link="base_link"/><origin xyz="0 0 0.1" rpy="0 0 0.2"/></joint>
<joint name="j1" type="revolute"><parent link="base_link"/><child link="a"/><origin xyz="0 0 0.5"/><axis xyz="0 1 0"/>{LIMIT}</joint>
<joint name="tipj" type="fixed"><parent link="a"/><child link="tip"/><origin xyz="0 0 0.7"/></joint>
<joint name="cart" type="planar"><parent link="world"/><child link="cart_link"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/></joint>
<joint name="arm2" type="revolute"><parent link="cart_link"/><child link="b"/><origin xyz="0.2 0 0"/><axis xyz="0 0 1"/>{LIMIT}</joint>
""",
    "world base_link a tip cart_link b",
)


@pytest.fixture(scope="module")
def mobile():
    return Robot.from_urdf(MOBILE)


def test_floating_and_planar_joints_load_with_named_coordinates(mobile):
    assert mobile.joint_names == (
        "base_joint.x", "base_joint.y", "base_joint.z", "base_joint.roll", "base_joint.pitch", "base_joint.yaw",
        "j1", "cart.x", "cart.y", "cart.yaw", "arm2",
    )
    np.testing.assert_array_equal(mobile.q(), np.zeros(11))  # identity by default
    assert mobile.base_link == "base_link"


def test_floating_base_fk_matches_the_chain_composed_by_hand(mobile):
    pose = [0.3, -0.2, 0.4, 0.5, -0.6, 1.2]
    q = mobile.q(base_joint=pose, j1=0.7, cart=[0.5, -1.0, 2.0], arm2=-0.4)
    # world -> base_link: origin, then Trans(x, y, z) Rz(yaw) Ry(pitch) Rx(roll); then j1 about y, then the tip
    T_world_base = _trans(0, 0, 0.1) @ _rot([0, 0, 1], 0.2) @ _trans(*pose[:3]) @ _rpy(*pose[3:])
    T_world_tip = T_world_base @ _trans(0, 0, 0.5) @ _rot([0, 1, 0], 0.7) @ _trans(0, 0, 0.7)
    np.testing.assert_allclose(mobile.transform("world", "tip", q), T_world_tip, atol=1e-12)
    np.testing.assert_allclose(mobile.fk(q, base="world", tip="tip"), T_world_tip, atol=1e-12)
    # planar: origin, then Trans(x, y, 0) Rz(yaw), then arm2
    T_world_b = _trans(1, 0, 0) @ _trans(0.5, -1.0, 0) @ _rot([0, 0, 1], 2.0) @ _trans(0.2, 0, 0) @ _rot([0, 0, 1], -0.4)
    np.testing.assert_allclose(mobile.transform("world", "b", q), T_world_b, atol=1e-12)
    np.testing.assert_allclose(mobile.fk(q, base="world", tip="b"), T_world_b, atol=1e-12)
    # frames on the same side of the floating joint do not see it
    np.testing.assert_allclose(mobile.transform("base_link", "tip", q), mobile.transform("base_link", "tip", mobile.q(j1=0.7)),
                               atol=1e-15)


def test_batched_floating_fk_equals_the_single_path(mobile):
    Q = np.random.default_rng(5).uniform(-1.5, 1.5, size=(50, len(mobile.joint_names)))
    T = mobile.fk(Q, base="world", tip="tip")
    for k in (0, 17, 49):
        np.testing.assert_allclose(T[k], mobile.transform("world", "tip", Q[k], check_limits=False), atol=1e-12)


def test_floating_values_by_coordinate_and_errors(mobile):
    q = mobile.q({"base_joint.z": 2.0})
    assert q[2] == 2.0
    with pytest.raises(JointValueError, match="floating: give 6 values"):
        mobile.q(base_joint=[1, 2, 3])


def test_ik_leaves_the_floating_base_alone_unless_freed(mobile):
    q_true = mobile.q(base_joint=[0.2, 0.1, 0.0, 0.0, 0.0, 0.3], j1=0.5)
    target = mobile.transform("world", "tip", q_true)
    fixed = ik(mobile, target, "world", "tip", mode="position", restarts=5)
    assert not fixed.success  # only j1 moves: the base stays at the identity
    freed = ik(mobile, target, "world", "tip", mode="pose", free=["base_joint"], restarts=20)
    assert freed.success
    np.testing.assert_allclose(mobile.transform("world", "tip", freed.q, check_limits=False), target, atol=1e-9)
    with pytest.raises(IKOptionError, match="'j1' is not one"):
        ik(mobile, target, "world", "tip", free=["j1"])


def test_a_planar_joint_with_another_axis_is_refused():
    with pytest.raises(DescriptionError, match="planar joint 'cart' has axis \"1 0 0\""):
        Robot.from_urdf(MOBILE.replace('<origin xyz="1 0 0"/><axis xyz="0 0 1"/>', '<origin xyz="1 0 0"/><axis xyz="1 0 0"/>'))


# --------------------------------------------------------------------------
# The joint vector API


def test_q_takes_a_sequence_a_dict_or_keywords(course_arm):
    values = [0, -1.34, -2.56, -1.15, -0.06]
    np.testing.assert_array_equal(course_arm.q(values), values)
    by_name = dict(zip(course_arm.joint_names, values))
    np.testing.assert_array_equal(course_arm.q(by_name), values)
    np.testing.assert_array_equal(course_arm.q(**by_name), values)
    np.testing.assert_allclose(course_arm.q(np.degrees(values), degrees=True), values, atol=1e-15)
    with pytest.raises(JointValueError, match="needs 5 joint values"):
        course_arm.q([1, 2])


def test_transform_takes_a_dict_and_checks_limits_by_default(iiwa14):
    course_arm = iiwa14
    name = next(j.name for j in course_arm.joints if np.isfinite(j.upper))
    T = course_arm.transform("base_link", "ee_link", {name: -1.34})
    np.testing.assert_allclose(T, course_arm.transform("base_link", "ee_link", course_arm.q(**{name: -1.34})), atol=0)
    joint = course_arm.joints[course_arm.joint_names.index(name)]
    with pytest.raises(Exception, match="above its upper limit"):
        course_arm.transform("base_link", "ee_link", {name: joint.upper + 1})
    course_arm.transform("base_link", "ee_link", {name: joint.upper + 1}, check_limits=False)


def test_robot_html_lists_every_joint_and_the_mimic_joints(mimic_robot):
    import xml.etree.ElementTree as ET

    html = mimic_robot._repr_html_()
    table = ET.fromstring(html[html.index("<table>"):].replace("&rarr;", "->").replace("&times;", "x")
                          .replace("&deg;", " deg"))
    cells = [[td.text or "" for td in tr] for tr in table.iter("tr")][1:]
    assert [row[0] for row in cells] == ["j1", "slide", "j2", "slide_mimic", "j3"]
    assert cells[0][4:] == ["-114.592 deg", "114.592 deg"]  # limits of +-2 rad in degrees
    assert cells[2][2] == "mimics j1: 2 x j1 + 0.1"


def test_the_package_root_lists_its_api_without_importing_pinocchio():
    import subprocess
    import sys

    code = ("import manipkit, sys; names = dir(manipkit); "
            "assert {'load', 'Robot', 'ik', 'load_dh', 'check_dh', 'matrix_from_euler_zyx', 'manipulability', "
            "'reachmap'} <= set(names), names; print('pinocchio' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_ik_from_a_base_that_a_solved_leader_moves_solves_the_chain_below_it():
    # j1 (above link a) is the leader of j2 (below it): T_a_tip depends on q1 through the mimic j2 only (j1 moves a
    # and everything below it alike), so the chain a -> tip solves for q1 (its one entry for j2) and q3
    urdf = _urdf(
        f"""<joint name="j1" type="revolute"><parent link="base_link"/><child link="a"/><axis xyz="0 0 1"/>{LIMIT}</joint>
<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/>{LIMIT}
  <mimic joint="j1"/></joint>
<joint name="j3" type="revolute"><parent link="b"/><child link="tip"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/>{LIMIT}</joint>""",
        "base_link a b tip",
    )
    robot = Robot.from_urdf(urdf)
    assert robot.chain("a", "tip").joint_names == ("j1", "j3")
    # hand: in a, j2's origin is (1, 0, 0) and the tip (1 + cos q1, sin q1, 0) (j3 only turns the tip)
    T = robot.transform("a", "tip", [0.3, 0.2])
    np.testing.assert_allclose(T[:3, 3], [1 + math.cos(0.3), math.sin(0.3), 0], atol=1e-12)
    result = ik(robot, T, "a", "tip", mode="position", restarts=20)
    assert result.success
    np.testing.assert_allclose(robot.transform("a", "tip", result.q)[:3, 3], T[:3, 3], atol=1e-9)
    # from base_link (above j1): j2's origin at angle q1, the tip's at 2 q1
    target = robot.transform("base_link", "tip", [0.3, 0.2])
    np.testing.assert_allclose(target[:3, 3], [math.cos(0.3) + math.cos(0.6), math.sin(0.3) + math.sin(0.6), 0],
                               atol=1e-12)
    result = ik(robot, target, tip="tip", mode="position", restarts=20)
    assert result.success
    np.testing.assert_allclose(robot.transform("base_link", "tip", result.q)[:3, 3], target[:3, 3], atol=1e-9)


def test_a_mimic_chain_whose_multipliers_overflow_is_refused():
    # each multiplier within the bound of one (1e6, description.validate.MAX_MAGNITUDE); 60 of them compose to 1e360
    joints = [f'<joint name="j1" type="revolute"><parent link="base_link"/><child link="l1"/><axis xyz="0 0 1"/>{LIMIT}'
              "</joint>"]
    joints += [f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/><axis xyz="0 0 1"/>'
               f'{LIMIT}<mimic joint="j{i - 1}" multiplier="1e6"/></joint>' for i in range(2, 62)]
    urdf = _urdf("\n".join(joints), " ".join(["base_link"] + [f"l{i}" for i in range(1, 62)]))
    with pytest.raises(DescriptionError, match="composes to multiplier inf"):
        Robot.from_urdf(urdf)


def test_a_mimic_multiplier_beyond_the_bound_of_one_is_refused_where_it_is_written():
    urdf = _urdf(
        f"""<joint name="j1" type="revolute"><parent link="base_link"/><child link="a"/><axis xyz="0 0 1"/>{LIMIT}</joint>
<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>{LIMIT}<mimic joint="j1" multiplier="1e200"/></joint>""",
        "base_link a b",
    )
    with pytest.raises(DescriptionError, match=r"joint 'j2' <mimic> multiplier=\"1e200\": 1e200 is out of range"):
        Robot.from_urdf(urdf)
