"""manipkit.description.validate: each invalid description gets one message naming the file, line, element and fix.

Descriptions here are written one element a line, so the line in each
expected message can be counted by eye: line 1 is ``<robot name="t">``.
"""

import math

import numpy as np
import pytest

import manipkit
from manipkit.description.packages import PackageResolver
from manipkit.description.validate import check_urdf, package_uri_warnings
from manipkit.errors import DescriptionError, JointLimitError, PackageNotFoundError
from manipkit.kinematics.joints import build_model
from manipkit.kinematics.robot import Robot

LIMIT = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'
BOX = '<visual><geometry><box size="1 1 1"/></geometry></visual>'


def joint(kind="revolute", parent="base", child="arm", axis="0 0 1", limit=LIMIT, origin="0 0 0", name="j1", extra=""):
    """One joint on one line."""
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{origin}" rpy="0 0 0"/><axis xyz="{axis}"/>{limit or ""}{extra}</joint>')


def urdf(*lines):
    """A robot named t, one element a line after line 1."""
    return "\n".join(['<robot name="t">', *lines, "</robot>"])


LINKS = ('<link name="base"/>', '<link name="arm"/>')  # lines 2 and 3; a joint after them is on line 4


def arm_link(body):
    return f'<link name="arm">{body}</link>'


def test_valid_description_passes_without_warnings():
    checked = check_urdf(urdf(*LINKS, joint()), "t.urdf")
    assert checked.robot.get("name") == "t" and checked.warnings == []


CASES = {
    # name: (description text, fragment of the message)
    "malformed_xml": ('<robot name="t">\n<link name="a">\n</robot>',
                      "t.urdf:3:9: malformed XML: Opening and ending tag mismatch: link line 2 and robot"),
    "empty": ("", "t.urdf: empty file; a URDF is XML with a <robot name=\"...\"> root element"),
    "not_xml": ("just some words", "t.urdf:1:1: malformed XML: Start tag expected, '<' not found (this is not an XML file)"),
    "root_not_robot": ('<?xml version="1.0"?>\n<model/>', "t.urdf:2: root element is <model>, expected <robot name=\"...\">"),
    "sdf": ('<sdf version="1.6"><model name="m"/></sdf>', "root element is <sdf>, expected <robot name=\"...\"> (this looks like an SDF model"),
    "robot_without_name": ("<robot>\n<link name=\"a\"/>\n</robot>", "t.urdf:1: <robot> has no name attribute"),
    "xacro_in_plain_urdf": ('<robot name="t" xmlns:xacro="http://www.ros.org/wiki/xacro">\n<xacro:property name="l" value="1"/>\n<link name="a"/>\n</robot>',
                            "t.urdf:2: <xacro:property> in a plain URDF; this file needs xacro expansion: name it .urdf.xacro"),
    "xacro_expression_in_plain_urdf": (urdf(*LINKS, joint(origin="0 0 ${l}")),
                                       "t.urdf:4: joint 'j1' <origin> xyz=\"0 0 ${l}\" is an unexpanded xacro expression"),
    "no_links": (urdf(), "t.urdf:1: robot 't' has no <link> elements"),
    "link_without_name": (urdf('<link name="a"/>', "<link/>"), "t.urdf:3: <link> number 2 has no name attribute"),
    "duplicate_link": (urdf('<link name="a"/>', '<link name="a"/>'), "t.urdf:3: two <link> elements are named 'a' (the first is at line 2); names must be unique"),
    "duplicate_joint": (urdf(*LINKS, '<link name="c"/>', joint(), joint(child="c")), "t.urdf:6: two <joint> elements are named 'j1' (the first is at line 5)"),
    "joint_without_type": (urdf(*LINKS, '<joint name="j1"><parent link="base"/><child link="arm"/></joint>'),
                           "t.urdf:4: joint 'j1' has no type attribute; valid types: revolute, continuous, prismatic, fixed, floating, planar"),
    "unknown_joint_type": (urdf(*LINKS, joint(kind="revolut")), "t.urdf:4: joint 'j1' has type 'revolut'; did you mean revolute? valid types: revolute, continuous, prismatic, fixed, floating, planar"),
    "missing_parent_element": (urdf(*LINKS, '<joint name="j1" type="fixed"><child link="arm"/></joint>'), "t.urdf:4: joint 'j1' has no <parent link=\"...\"/>"),
    "missing_parent_link": (urdf(*LINKS, joint(parent="bsae")), "t.urdf:4: joint 'j1' parent link 'bsae' does not exist; did you mean base? links are: base, arm"),
    "missing_child_link": (urdf(*LINKS, joint(child="nope")), "t.urdf:4: joint 'j1' child link 'nope' does not exist; links are: base, arm"),
    "self_loop": (urdf(*LINKS, joint(child="base")), "t.urdf:4: joint 'j1' has link 'base' as both parent and child"),
    "two_parents": (urdf(*LINKS, joint(), joint(name="j2")), "t.urdf:5: link 'arm' is the child of two joints ('j1' and 'j2'); a URDF is a tree"),
    "two_roots": (urdf(*LINKS, '<link name="c"/>', joint()), "t.urdf:4: 2 root links (base, c); a URDF has exactly one root: connect the others (e.g. 'c')"),
    "cycle_without_root": (urdf(*LINKS, joint(), joint(name="j2", parent="arm", child="base")), "t.urdf:1: every link has a parent joint, so the joints form a cycle"),
    "cycle_beside_root": (urdf(*LINKS, '<link name="c"/>', '<link name="d"/>', joint(), joint(name="j2", parent="c", child="d"), joint(name="j3", parent="d", child="c")),
                          "t.urdf:8: links c, d form a cycle (c -> d -> c) not connected to root 'base'"),
    "zero_axis": (urdf(*LINKS, joint(axis="0 0 0")), "t.urdf:4: joint 'j1' has axis '0 0 0'; an axis must be a non-zero vector such as '0 0 1'"),
    "nan_axis": (urdf(*LINKS, joint(axis="0 nan 1")), "t.urdf:4: joint 'j1' <axis> xyz=\"0 nan 1\": 'nan' is not finite; expected 3 finite numbers"),
    "short_axis": (urdf(*LINKS, joint(axis="0 1")), "t.urdf:4: joint 'j1' <axis> xyz=\"0 1\" has 2 values; expected 3 finite numbers"),
    "text_axis": (urdf(*LINKS, joint(axis="z")), "t.urdf:4: joint 'j1' <axis> xyz=\"z\" has 1 value; expected 3 finite numbers"),
    "nan_origin": (urdf(*LINKS, joint(origin="0 nan 0")), "t.urdf:4: joint 'j1' <origin> xyz=\"0 nan 0\": 'nan' is not finite; expected 3 finite numbers (m)"),
    "overflowing_origin": (urdf(*LINKS, joint(origin="0 0 1e400")), "'1e400' overflows to infinity"),
    "python_only_number": (urdf(*LINKS, joint(origin="0 0 1_0")), "joint 'j1' <origin> xyz=\"0 0 1_0\": '1_0' is not a number"),
    "short_origin": (urdf(*LINKS, joint(origin="0 0")), "joint 'j1' <origin> xyz=\"0 0\" has 2 values; expected 3 finite numbers (m)"),
    "no_limit": (urdf(*LINKS, joint(limit=None)), "t.urdf:4: revolute joint 'j1' has no <limit>; add <limit lower=... upper=... effort=... velocity=...> or make it continuous"),
    "limit_without_effort": (urdf(*LINKS, joint(limit='<limit lower="-1" upper="1" velocity="1"/>')), "t.urdf:4: joint 'j1' <limit> has no effort attribute; URDF requires it"),
    "inf_limit": (urdf(*LINKS, joint(limit='<limit lower="-1" upper="inf" effort="1" velocity="1"/>')), "t.urdf:4: joint 'j1' <limit> upper=\"inf\": 'inf' is not finite; expected 1 finite number (rad)"),
    "lower_above_upper": (urdf(*LINKS, joint(limit='<limit lower="1" upper="-1" effort="1" velocity="1"/>')), "t.urdf:4: joint 'j1' has lower limit 1 above upper limit -1 (rad); swap them"),
    "prismatic_limits_in_metres": (urdf(*LINKS, joint(kind="prismatic", limit='<limit lower="0.5" upper="0.1" effort="1" velocity="1"/>')), "lower limit 0.5 above upper limit 0.1 (m)"),
    "bad_dynamics": (urdf(*LINKS, joint(extra='<dynamics damping="lots"/>')), "t.urdf:4: joint 'j1' <dynamics> damping=\"lots\": 'lots' is not a number"),
    "negative_mass": (urdf(LINKS[0], arm_link('<inertial><mass value="-2"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'), joint()),
                      "t.urdf:3: link 'arm' has mass -2 kg; a mass must be >= 0"),
    "nan_mass": (urdf(LINKS[0], arm_link('<inertial><mass value="nan"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'), joint()),
                 "t.urdf:3: link 'arm' <mass> value=\"nan\": 'nan' is not finite; expected 1 finite number (kg)"),
    "missing_mass": (urdf(LINKS[0], arm_link('<inertial><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'), joint()),
                     "link 'arm' <inertial> has no <mass value=\"...\"/>"),
    "inf_inertia": (urdf(LINKS[0], arm_link('<inertial><mass value="1"/><inertia ixx="inf" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'), joint()),
                    "link 'arm' <inertia> ixx=\"inf\": 'inf' is not finite"),
    "missing_inertia_entry": (urdf(LINKS[0], arm_link('<inertial><mass value="1"/><inertia ixx="1" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'), joint()),
                              "link 'arm' <inertia> has no ixy attribute; give all of ixx, ixy, ixz, iyy, iyz, izz"),
    "nan_inertial_origin": (urdf(LINKS[0], arm_link('<inertial><origin xyz="nan 0 0"/><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'), joint()),
                            "link 'arm' <inertial> <origin> xyz=\"nan 0 0\": 'nan' is not finite"),
    "box_without_size": (urdf(LINKS[0], arm_link("<visual><geometry><box/></geometry></visual>"), joint()), "t.urdf:3: link 'arm' <visual> <box> has no size attribute"),
    "negative_radius": (urdf(LINKS[0], arm_link('<collision><geometry><sphere radius="-1"/></geometry></collision>'), joint()), "link 'arm' <collision> <sphere> radius=\"-1\": -1 is negative"),
    "unknown_shape": (urdf(LINKS[0], arm_link('<visual><geometry><cone radius="1"/></geometry></visual>'), joint()), "link 'arm' <visual> <geometry> has <cone>; valid shapes: box, cylinder, sphere, mesh"),
    "no_geometry": (urdf(LINKS[0], arm_link("<visual/>"), joint()), "link 'arm' <visual> has no <geometry>"),
    "mesh_without_filename": (urdf(LINKS[0], arm_link("<visual><geometry><mesh/></geometry></visual>"), joint()), "link 'arm' <visual> <mesh> has no filename attribute"),
    "entity_declarations": ('<!DOCTYPE robot [<!ENTITY v "j1">]>\n' + urdf(*LINKS, joint(name="&v;")),
                            "t.urdf:1: <!ENTITY> declarations: URDF parsers do not expand them"),
    "joint_named_universe": (urdf(*LINKS, joint(name="universe")), "t.urdf:4: joint 'universe': the name 'universe' is reserved by Pinocchio"),
    "link_named_universe": (urdf(LINKS[0], '<link name="universe"/>', joint(child="universe")), "t.urdf:3: link 'universe': the name 'universe' is reserved"),
    "axis_without_xyz": (urdf(*LINKS, joint().replace('<axis xyz="0 0 1"/>', "<axis/>")),
                         "t.urdf:4: joint 'j1' <axis> has no xyz attribute; give xyz=\"1 0 0\""),
    "origin_beyond_any_robot": (urdf(*LINKS, joint(origin="1.7e308 0 0")),
                                "joint 'j1' <origin> xyz=\"1.7e308 0 0\": 1.7e308 m is out of range for a robot; expected |value| <= 1e+06 m"),
    "commas_in_a_vector": (urdf(*LINKS, joint(origin="0,0,1")), "has 1 value; expected 3 finite numbers (m) separated by spaces, not commas"),
    "bad_colour": (urdf(LINKS[0], arm_link('<visual><geometry><box size="1 1 1"/></geometry><material name="m"><color rgba="1 0 0"/></material></visual>'), joint()),
                   "link 'arm' <visual> <material> <color> rgba=\"1 0 0\" has 3 values; expected 4 finite numbers"),
    # issue 26: names that would forge or drive the output, and numbers beyond any robot (one bound: 1e6)
    "link_name_with_a_line_break": (urdf(LINKS[0], '<link name="arm&#10;- Translation: [0 0 0]"/>',
                                         joint(child="arm&#10;- Translation: [0 0 0]")),
                                    "t.urdf:3: link name 'arm\\x0a- Translation: [0 0 0]': character 4 is U+000A, "
                                    "a control, line-separator or bidirectional character; a name is one line"),
    "joint_name_with_a_bidi_override": (urdf(*LINKS, joint(name="j\u202e1")),
                                        "t.urdf:4: joint name 'j\\u202e1': character 2 is U+202E"),
    "robot_name_with_a_c1_control": ('<robot name="t&#x9b;2J">\n<link name="a"/>\n</robot>',
                                     "t.urdf:1: robot name 't\\x9b2J': character 2 is U+009B"),
    "rpy_beyond_any_angle": (urdf(*LINKS, joint().replace('rpy="0 0 0"', 'rpy="0 0 5e299"')),
                             "joint 'j1' <origin> rpy=\"0 0 5e299\": 5e299 rad is out of range for a robot; "
                             "expected |value| <= 1e+06 rad"),
    "revolute_limit_beyond_any_angle": (urdf(*LINKS, joint(limit='<limit lower="0" upper="5e299" effort="1" velocity="1"/>')),
                                        "joint 'j1' <limit> upper=\"5e299\": 5e299 rad is out of range"),
    "mesh_scale_beyond_any_robot": (urdf(LINKS[0], arm_link('<visual><geometry><mesh filename="a.stl" scale="1e300 1 1"/>'
                                                            '</geometry></visual>'), joint()),
                                    "link 'arm' <visual> <mesh> scale=\"1e300 1 1\": 1e300 is out of range"),
    "mimic_multiplier_beyond_any_robot": (urdf(*LINKS, '<link name="c"/>', joint(),
                                               joint(child="c", name="j2", extra='<mimic joint="j1" multiplier="1e308"/>')),
                                          "joint 'j2' <mimic> multiplier=\"1e308\": 1e308 is out of range for a robot; "
                                          "expected |value| <= 1e+06"),
    "mimic_offset_beyond_any_robot": (urdf(*LINKS, '<link name="c"/>', joint(),
                                           joint(child="c", name="j2", extra='<mimic joint="j1" offset="1e308"/>')),
                                      "joint 'j2' <mimic> offset=\"1e308\": 1e308 is out of range"),
}


@pytest.mark.parametrize("text, fragment", list(CASES.values()), ids=list(CASES))
def test_invalid_description_message_names_file_line_element_and_fix(text, fragment):
    with pytest.raises(DescriptionError) as info:
        check_urdf(text, "t.urdf")
    message = str(info.value)
    assert fragment in message
    assert "\n" not in message


def test_pinocchio_accepts_what_the_checks_refuse():
    # The reason for the checks: each of these loads in Pinocchio without a word, and would be a wrong or untrustworthy model.
    for name in ("zero_axis", "lower_above_upper", "negative_mass"):
        model, messages = build_model(CASES[name][0])
        assert model is not None and messages == [], name


def test_zero_axis_is_refused_before_pinocchio_accepts_it(tmp_path):
    path = tmp_path / "zero_axis.urdf"
    path.write_text(urdf(*LINKS, joint(kind="continuous", axis="0 0 0", limit=None)))
    with pytest.raises(DescriptionError, match="zero_axis.urdf:4: joint 'j1' has axis '0 0 0'"):
        manipkit.load(path)


# --------------------------------------------------------------------------
# Warnings: problems that leave the kinematics right
# --------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["revolute", "prismatic", "continuous"])
def test_non_unit_axis_is_normalised_with_a_warning(tmp_path, kind):
    path = tmp_path / "long_axis.urdf"
    path.write_text(urdf(*LINKS, joint(kind=kind, axis="0 0 2", limit=None if kind == "continuous" else LIMIT)))
    robot = manipkit.load(path)
    assert robot.warnings == ("long_axis.urdf:4: joint 'j1' axis '0 0 2' (length 2) normalised to '0 0 1'",)
    assert 'xyz="0.0 0.0 1.0"' in robot.urdf  # every reader of robot.urdf (tree, viewer) sees a unit axis
    # Hand value: 0.5 about (or along) z moves the child by 0.5 rad (or 0.5 m), not by twice that.
    T = robot.transform("base", "arm", [0.5])
    if kind == "prismatic":
        assert T[:3, 3] == pytest.approx([0, 0, 0.5], abs=1e-12)
    else:
        assert math.atan2(T[1, 0], T[0, 0]) == pytest.approx(0.5, abs=1e-12)


def test_hand_rounded_unit_axis_is_normalised_silently():
    checked = check_urdf(urdf(*LINKS, joint(axis="0.7071 0.7071 0")), "t.urdf")
    assert checked.warnings == []
    assert "0.7071067811865476" in checked.text


def test_joint_that_cannot_move_gets_a_warning():
    checked = check_urdf(urdf(*LINKS, joint(limit='<limit effort="1" velocity="1"/>')), "t.urdf")
    assert checked.warnings == [
        "t.urdf:4: joint 'j1' has limits [0, 0] rad (lower and upper not given: URDF's default is 0): it cannot move; "
        "give lower= and upper= or make it continuous"
    ]


def test_mimic_of_a_missing_joint_is_an_error():
    # a mimic joint follows its leader (manipkit.kinematics.joints): without one its value is unknown
    with pytest.raises(DescriptionError) as error:
        check_urdf(urdf(*LINKS, joint(extra='<mimic joint="j11"/>')), "t.urdf")
    assert str(error.value) == ("t.urdf:4: joint 'j1' <mimic joint=\"j11\">: no such joint (did you mean j1?); "
                                "a mimic names the joint 'j1' follows")


def test_unresolved_package_mesh_is_a_warning_naming_the_uri_and_the_places_searched(tmp_path):
    mesh = '<visual><geometry><mesh filename="package://no_such_pkg/meshes/arm.stl"/></geometry></visual>'
    # In a workspace of its own (tmp_path/src): another test's package in the shared temporary folder
    # would otherwise make that folder the workspace searched (PackageResolver's order, place 2).
    (tmp_path / "src").mkdir()
    path = tmp_path / "src" / "meshy.urdf"
    path.write_text(urdf(LINKS[0], arm_link(mesh), joint()))
    robot = manipkit.load(path)
    assert len(robot.warnings) == 1
    warning = robot.warnings[0]
    assert warning.startswith("meshy.urdf:3: link 'arm' mesh package://no_such_pkg/meshes/arm.stl: package 'no_such_pkg' not found")
    assert f"the workspace {tmp_path / 'src'}" in warning and "--package-dir no_such_pkg=DIR" in warning
    assert "kinematics do not need meshes; the viewer does" in warning
    assert robot.transform("base", "arm", [0.3]).shape == (4, 4)  # kinematics still answer


def test_package_mesh_file_missing_inside_a_found_package(tmp_path):
    (tmp_path / "my_pkg" / "meshes").mkdir(parents=True)
    (tmp_path / "my_pkg" / "meshes" / "here.stl").write_text("solid x\nendsolid x\n")
    meshes = "".join(f'<visual><geometry><mesh filename="package://my_pkg/meshes/{n}.stl"/></geometry></visual>' for n in ("here", "gone"))
    checked = check_urdf(urdf(LINKS[0], arm_link(meshes), joint()), "t.urdf")
    warnings = package_uri_warnings(checked.robot, PackageResolver({"my_pkg": tmp_path / "my_pkg"}), "t.urdf")
    assert warnings == [f"t.urdf:3: link 'arm' mesh package://my_pkg/meshes/gone.stl: no such file "
                        f"{tmp_path / 'my_pkg' / 'meshes' / 'gone.stl'} (kinematics do not need meshes; the viewer does)"]


def test_bundled_and_example_robot_data_arms_load_without_warnings():
    for name in ("course_arm", "iiwa14", "mobile_manipulator", "panda", "ur5"):
        assert manipkit.load(name).warnings == (), name


def test_cpp_parser_complaints_are_captured_not_printed(capfd):
    # urdfdom writes to file descriptor 2 directly; _build_model hands its lines back instead.
    text = urdf(LINKS[0], arm_link('<inertial><mass value="nan"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'), joint())
    model, messages = build_model(text)
    assert any("mass" in m for m in messages)
    assert capfd.readouterr().err == ""


# --------------------------------------------------------------------------
# xacro: errors name the xacro file and line
# --------------------------------------------------------------------------

XACRO_HEAD = '<?xml version="1.0"?>\n<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'


def _xacro(tmp_path, *lines, name="arm.urdf.xacro"):
    path = tmp_path / name
    path.write_text("\n".join([XACRO_HEAD, *lines, "</robot>"]))  # line 3 is the first of `lines`
    return path


@pytest.mark.parametrize(
    "lines, fragment",
    [
        (['<xacro:arg name="l1"/>', '<link name="$(arg l1)"/>'],
         'arm.urdf.xacro:3: <xacro:arg name="l1"> has no default, so xacro argument \'l1\' is required; '
         "give it with --arg l1:=VALUE"),
        (['<xacro:arg name="l1" default="1"/>', '<link name="a"/>', '<link name="$(arg l2)"/>'],
         'arm.urdf.xacro:5: $(arg l2): no such xacro argument; declare <xacro:arg name="l2" default="..."/> (declared: l1)'),
        (['<xacro:property name="width" value="2"/>', '<link name="${width + widht}"/>'],
         "arm.urdf.xacro:4: xacro expression ${width + widht}: name 'widht' is not defined"),
        (['<link name="a"/>', '<link name="${1 +* 2}"/>'], "arm.urdf.xacro:4: xacro expression ${1 +* 2}: invalid syntax"),
        (['<link name="${1 + 2"/>'], "arm.urdf.xacro:3: xacro: invalid expression ${1 + 2 (unclosed ${...}?)"),
        (["", '<xacro:include filename="gone.xacro"/>'], "arm.urdf.xacro:4: xacro:include: file not found: "),
        (['<xacro:macro name="arm" params="len"><link name="${len}"/></xacro:macro>', "<xacro:armm/>"],
         "arm.urdf.xacro:4: unknown xacro macro 'armm'; did you mean arm? macros: arm"),
        (['<xacro:macro name="arm" params="len"><link name="${len}"/></xacro:macro>', "<xacro:arm/>"],
         "arm.urdf.xacro:4: xacro macro 'arm' called without parameter(s) len"),
        (['<link name="a">', "</robot>"], "arm.urdf.xacro:4:2: malformed XML: mismatched tag"),
        (['<xacro:include filename="$(find no_such_pkg)/urdf/arm.xacro"/>'], "arm.urdf.xacro:3: $(find no_such_pkg): package 'no_such_pkg' not found"),
    ],
    ids=["arg_without_default", "undeclared_arg", "undefined_name", "syntax", "unclosed", "missing_include",
         "unknown_macro", "macro_parameter", "malformed", "find_unknown_package"],
)
def test_xacro_error_names_the_xacro_file_and_line(tmp_path, lines, fragment):
    path = _xacro(tmp_path, *lines)
    with pytest.raises(DescriptionError) as info:
        manipkit.load(path)
    assert fragment in str(info.value)
    assert "\n" not in str(info.value)


def test_xacro_error_inside_an_included_file_names_that_file(tmp_path):
    (tmp_path / "parts.xacro").write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro">\n\n<link name="${2/0}"/>\n</robot>')
    path = _xacro(tmp_path, '<xacro:include filename="parts.xacro"/>')
    with pytest.raises(DescriptionError, match=r"^parts.xacro:3: xacro expression \$\{2/0\}: division by zero"):
        manipkit.load(path)


def test_unknown_package_in_find_is_a_package_error(tmp_path):
    path = _xacro(tmp_path, '<xacro:include filename="$(find no_such_pkg)/urdf/arm.xacro"/>')
    with pytest.raises(PackageNotFoundError):
        manipkit.load(path)


def test_invalid_urdf_from_xacro_points_at_the_xacro_line(tmp_path):
    path = _xacro(tmp_path, '<link name="base"/>', '<link name="arm"/>', "", joint(axis="0 0 0"))
    with pytest.raises(DescriptionError, match=r"^arm.urdf.xacro:6: joint 'j1' has axis '0 0 0'"):
        manipkit.load(path)


def test_invalid_urdf_from_a_xacro_macro_says_it_is_the_expanded_line(tmp_path):
    # The joint's name is built by an expression, so it cannot be found written out in the xacro file.
    macro = ('<xacro:macro name="j" params="p"><joint name="${p}_joint" type="continuous"><parent link="base"/>'
             '<child link="arm"/><axis xyz="0 0 0"/></joint></xacro:macro>')
    path = _xacro(tmp_path, '<link name="base"/>', '<link name="arm"/>', macro, '<xacro:j p="elbow"/>')
    with pytest.raises(DescriptionError, match=r"^arm.urdf.xacro \(expanded URDF, line \d+\): joint 'elbow_joint' has axis '0 0 0'"):
        manipkit.load(path)


def test_binary_file_is_not_a_description(tmp_path):
    path = tmp_path / "robot.urdf"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00")
    with pytest.raises(DescriptionError, match=r"robot.urdf: not a text file \(byte 0x89 at offset 0 is not UTF-8\)"):
        manipkit.load(path)


def test_byte_order_mark_and_encoding_declaration_are_fine(tmp_path):
    path = tmp_path / "bom.urdf"
    path.write_bytes(b"\xef\xbb\xbf" + ('<?xml version="1.0" encoding="utf-8"?>\n' + urdf(*LINKS, joint())).encode())
    assert manipkit.load(path).joint_names == ("j1",)


# --------------------------------------------------------------------------
# Joint values against the limits (the API is permissive, check_limits is strict)
# --------------------------------------------------------------------------


def test_robot_q_is_permissive_and_check_limits_is_strict():
    robot = manipkit.load("iiwa14")
    q = robot.q(iiwa_joint_2=2.5)  # no error: transform() computes the pose the joint would have
    with pytest.raises(JointLimitError) as info:
        robot.check_limits(q)
    assert str(info.value) == "joint 'iiwa_joint_2' = 2.5 is above its upper limit 2.0944 (limits [-2.0944, 2.0944] rad)"
    assert (info.value.joint, info.value.value, info.value.unit) == ("iiwa_joint_2", 2.5, "rad")
    assert robot.check_limits(robot.q(iiwa_joint_2=2.0)) is not None


def test_check_limits_names_a_lower_limit_and_metres_for_prismatic_joints():
    robot = manipkit.load("scara")
    prismatic = next(j for j in robot.joints if j.type == "prismatic")
    with pytest.raises(JointLimitError, match=rf"joint '{prismatic.name}' = -0.5 is below its lower limit .* m\)$"):
        robot.check_limits(robot.q({prismatic.name: -0.5}))


def test_clamp_moves_values_to_the_nearest_limit():
    robot = manipkit.load("iiwa14")
    upper = robot.joints[1].upper
    clamped = robot.clamp(robot.q(iiwa_joint_2=2.5, iiwa_joint_4=-3, iiwa_joint_1=0.25))
    assert clamped[1] == upper == pytest.approx(math.radians(120))
    assert clamped[3] == pytest.approx(-math.radians(120)) and clamped[0] == 0.25
    assert robot.limit_violations(clamped) == []
    Q = robot.clamp(np.full((3, 7), 10.0))  # many rows at once
    assert Q.shape == (3, 7) and np.all(Q == np.array([j.upper for j in robot.joints]))


def test_continuous_joints_are_never_outside_their_limits():
    robot = manipkit.load("course_arm")
    assert robot.limit_violations(robot.q(elbow_joint=100.0)) == []


def test_too_many_joints_is_refused_before_pinocchio_allocates(tmp_path):
    # Pinocchio's Data holds nv^3 tensors: 1000 joints would take about 64 GB and get the process killed.
    n = 1000
    links = [f'<link name="l{i}"/>' for i in range(n + 1)]
    joints = [joint(parent=f"l{i}", child=f"l{i + 1}", name=f"j{i}") for i in range(n)]
    path = tmp_path / "snake.urdf"
    path.write_text(urdf(*links, *joints))
    with pytest.raises(DescriptionError, match=r"snake.urdf: 1000 degrees of freedom; manipkit handles up to 200 \(.*about 64 GB here\)"):
        manipkit.load(path)


def test_huge_axis_is_normalised_without_overflow():
    # x * x overflows for 1e200; the axis must still come out as 1 0 0, not 0 0 0.
    checked = check_urdf(urdf(*LINKS, joint(axis="1e200 0 0")), "t.urdf")
    assert checked.warnings == ["t.urdf:4: joint 'j1' axis '1e200 0 0' (length 1e+200) normalised to '1 0 0'"]
    robot = Robot.from_urdf(urdf(*LINKS, joint(axis="1e200 0 0")))
    assert robot.joints[0].axis == pytest.approx([1, 0, 0])


def test_robot_without_movable_joints_has_batched_fk():
    robot = Robot.from_urdf(urdf(*LINKS, joint(kind="fixed", origin="1 0 0", limit=None)))
    T = robot.fk(np.zeros((3, 0)), tip="arm")
    assert T.shape == (3, 4, 4) and np.all(T[:, :3, 3] == [1, 0, 0])


def test_prismatic_limits_of_1e308_are_refused_before_fk_turns_them_into_inf_and_nan():
    limit = '<limit lower="-1e308" upper="1e308" effort="1" velocity="1"/>'
    with pytest.raises(DescriptionError, match=r"joint 'j1' <limit> lower=\"-1e308\": -1e308 m is out of range "
                       r"for a robot; expected \|value\| <= 1e\+06 m"):
        Robot.from_urdf(urdf(*LINKS, joint(kind="prismatic", limit=limit)))


def test_sample_q_with_the_largest_limits_stays_finite_and_inside():
    limit = '<limit lower="-1e6" upper="1e6" effort="1" velocity="1"/>'
    robot = Robot.from_urdf(urdf(*LINKS, joint(kind="prismatic", limit=limit)))
    Q = robot.sample_q(100)
    assert np.all(np.isfinite(Q)) and np.all(np.abs(Q) <= 1e6)
    T = robot.transform("base_link", "arm", [1e6])
    assert np.all(np.isfinite(T))


def test_mimic_of_itself_is_an_error():
    with pytest.raises(DescriptionError) as error:
        check_urdf(urdf(*LINKS, joint(extra='<mimic joint="j1" multiplier="2"/>')), "t.urdf")
    assert str(error.value) == ("t.urdf:4: joint 'j1' <mimic joint=\"j1\">: a joint cannot mimic itself; "
                                "name the joint 'j1' follows, or remove the <mimic>")


def fixed_chain(depth: int) -> str:
    """Links l0 ... l<depth> joined by fixed joints: the root l0 and ``depth`` joints down to the tip."""
    lines = ['<link name="l0"/>']
    for i in range(1, depth + 1):
        lines.append(f'<link name="l{i}"/>{joint("fixed", f"l{i - 1}", f"l{i}", limit=None, name=f"j{i}")}')
    return urdf(*lines)


def test_tree_deeper_than_the_limit_is_refused_before_pinocchio_sees_it():
    from manipkit.description.validate import MAX_TREE_DEPTH

    assert MAX_TREE_DEPTH == 2000  # Pinocchio's recursive parser crashes near 3,800 joints (8 MB stack)
    check_urdf(fixed_chain(MAX_TREE_DEPTH), "ok.urdf")
    with pytest.raises(DescriptionError) as raised:
        check_urdf(fixed_chain(MAX_TREE_DEPTH + 1), "deep.urdf")
    # Line 1 is <robot>, line 2 the root l0, line k + 2 link l<k> and its joint.
    assert str(raised.value) == ("deep.urdf:2003: link 'l2001' is 2001 joints below root 'l0'; manipkit loads trees up "
                                 "to 2000 joints deep (Pinocchio's URDF parser recurses once per joint and crashes near 3,800)")


def test_depth_is_measured_without_recursion_on_a_tree_of_4999_links():
    import sys

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(200)  # a recursive walk would fail here long before 4,999 levels
    try:
        with pytest.raises(DescriptionError, match="link 'l4999' is 4999 joints below root 'l0'"):
            check_urdf(fixed_chain(4999), "deep.urdf")
    finally:
        sys.setrecursionlimit(limit)


def test_a_mimic_that_leaves_its_own_limits_is_named_in_a_warning():
    follower = joint(child="c", name="j2", extra='<mimic joint="j1" multiplier="2" offset="0.5"/>')
    warnings = check_urdf(urdf(*LINKS, '<link name="c"/>', joint(), follower), "t.urdf").warnings
    assert warnings == ["t.urdf:6: joint 'j2' mimics 'j1' (j2 = 2 * j1 + 0.5): over the leader's limits [-1, 1] it "
                        "moves over [-1.5, 2.5] rad, outside its own limits [-1, 1] rad (they are not applied: it "
                        "follows its leader); widen its <limit> to hold that range, or fix the multiplier and offset"]


def test_a_mimic_within_its_own_limits_loads_and_follows_its_leader():
    follower = joint(child="c", name="j2", limit='<limit lower="-1" upper="1" effort="1" velocity="1"/>',
                     extra='<mimic joint="j1" multiplier="-0.25" offset="0.2"/>')
    robot = Robot.from_urdf(urdf(*LINKS, '<link name="c"/>', joint(), follower))
    assert robot.joint_names == ("j1",) and robot.mimic_joints["j2"].multiplier == -0.25 and robot.warnings == ()


def test_links_beyond_the_width_bound_are_refused_with_the_numbers_before_pinocchio():
    from manipkit.description.validate import MAX_LINKS

    lines = ['<link name="l0"/>'] + [f'<link name="l{i}"/>{joint("fixed", "l0", f"l{i}", limit=None, name=f"j{i}")}'
                                      for i in range(1, MAX_LINKS + 1)]
    with pytest.raises(DescriptionError, match=f"robot 't' has {MAX_LINKS + 1} links; manipkit loads descriptions "
                       f"of up to {MAX_LINKS} links and {MAX_LINKS} joints"):
        Robot.from_urdf(urdf(*lines))
    assert MAX_LINKS >= 10 * 89  # the largest real description in shared/realworld (TIAGo with its hand) has 89


def test_a_flood_of_warnings_is_cut_to_a_count():
    from manipkit.description.validate import MAX_WARNINGS

    lines = ['<link name="l0"/>'] + [f'<link name="l{i}"/>{joint("revolute", "l0", f"l{i}", axis="0 0 2", name=f"j{i}")}'
                                      for i in range(1, 51)]
    warnings = check_urdf(urdf(*lines), "t.urdf").warnings
    assert len(warnings) == MAX_WARNINGS + 1 and warnings[0].startswith("t.urdf:3: joint 'j1' axis '0 0 2'")
    assert warnings[-1] == f"t.urdf: ... and {50 - MAX_WARNINGS} more warnings"


def test_names_of_printable_unicode_load():
    robot = Robot.from_urdf(urdf('<link name="Basis_ü"/>', '<link name="アーム/1"/>',
                                 joint(parent="Basis_ü", child="アーム/1", name="Gelenk 1")))
    assert robot.joint_names == ("Gelenk 1",)
