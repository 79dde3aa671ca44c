"""manipkit.dh.to_urdf: a URDF whose chain equals a DH table's.

Independent sources: ``dh_fk`` against Pinocchio and yourdfpy on the URDF
that ``urdf_from_dh`` writes, and the bundled iiwa14 URDF.
"""

import math
from io import BytesIO

import numpy as np
import pytest
from test_dh_table import DH_DIR, random_q, random_table, rot_x, samples_within_limits, trans_x

import manipkit
from manipkit.dh import DHRow, DHTable, dh_fk, load_dh, save_urdf, urdf_from_dh
from manipkit.errors import DHTableError, OutputError
from manipkit.kinematics.robot import Robot

# --------------------------------------------------------------------------
# URDF export


def yourdfpy_fk(text, joint_names, Q, frame="ee_link"):
    import yourdfpy

    urdf = yourdfpy.URDF.load(BytesIO(text.encode()), build_scene_graph=True, load_meshes=False,
                              build_collision_scene_graph=False, load_collision_meshes=False)
    out = []
    for q in Q:
        urdf.update_cfg(dict(zip(joint_names, q)))
        out.append(urdf.get_transform(frame_to=frame, frame_from="base_link"))
    return np.array(out)


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_urdf_chain_equals_dh_fk_in_pinocchio_at_200_configurations(convention):
    # Revolute and prismatic rows, random twists and offsets, non-identity base and tool.
    rng = np.random.default_rng(17)
    table = random_table(rng, convention)
    robot = Robot.from_urdf(urdf_from_dh(table))
    assert robot.joint_names == tuple(f"joint_{i}" for i in range(1, 6))
    Q = random_q(table, rng, 200)
    assert np.abs(robot.fk(Q, tip="ee_link") - dh_fk(table, Q)).max() < 1e-12


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_urdf_chain_equals_dh_fk_in_yourdfpy_at_200_configurations(convention):
    rng = np.random.default_rng(23)
    table = random_table(rng, convention)
    Q = random_q(table, rng, 200)
    T = yourdfpy_fk(urdf_from_dh(table), [f"joint_{i}" for i in range(1, 6)], Q)
    assert np.abs(T - dh_fk(table, Q)).max() < 1e-12


def test_modified_urdf_links_are_the_dh_frames():
    rng = np.random.default_rng(5)
    table = random_table(rng, "modified")
    robot = Robot.from_urdf(urdf_from_dh(table))
    Q = random_q(table, rng, 50)
    for i in range(table.n + 1):
        assert np.abs(robot.fk(Q, tip=f"link_{i}") - dh_fk(table, Q, upto=i)).max() < 1e-12, i


def test_standard_urdf_link_i_is_dh_frame_i_before_its_common_normal():
    # Standard DH: A_i = Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i). URDF joint i turns about z_{i-1},
    # so link_i = frame_{i-1} Rz(theta_i + q_i) Tz(d_i) and frame_i = link_i Tx(a_i) Rx(alpha_i).
    rng = np.random.default_rng(6)
    table = random_table(rng, "standard")
    robot = Robot.from_urdf(urdf_from_dh(table))
    Q = random_q(table, rng, 50)
    assert np.abs(robot.fk(Q, tip="link_0") - dh_fk(table, Q, upto=0)).max() < 1e-12
    for i, row in enumerate(table.rows, start=1):
        T_frame_i = robot.fk(Q, tip=f"link_{i}") @ trans_x(row.a) @ rot_x(row.alpha)
        assert np.abs(T_frame_i - dh_fk(table, Q, upto=i)).max() < 1e-12, i


def test_urdf_from_the_iiwa_table_agrees_with_the_bundled_iiwa():
    table = load_dh(DH_DIR / "iiwa14.yaml")
    exported, bundled = Robot.from_urdf(urdf_from_dh(table)), manipkit.load("iiwa14")
    assert exported.joint_names == bundled.joint_names  # the rows' names
    Q = samples_within_limits(bundled, 200, seed=9)
    assert np.abs(exported.fk(Q, tip="ee_link") - bundled.fk(Q, tip="ee_link")).max() < 1e-12


def test_urdf_joint_limits_are_the_rows_or_the_defaults():
    table = DHTable([DHRow(0, 0, 0, 0, qlim=(-1.0, 2.0)), DHRow(0, 0, 0, 0), DHRow(0, 0, 0, 0, "prismatic")], "standard")
    robot = Robot.from_urdf(urdf_from_dh(table))
    assert [(j.type, j.lower, j.upper) for j in robot.joints] == [
        ("revolute", -1.0, 2.0), ("revolute", -math.pi, math.pi), ("prismatic", -1.0, 1.0)]


def test_urdf_links_have_visuals_and_positive_masses():
    text = urdf_from_dh(load_dh(DH_DIR / "iiwa14.yaml"))
    robot = Robot.from_urdf(text)
    assert all(inertia.mass > 0 for inertia in robot.model.inertias[1:])
    assert text.count("<cylinder ") >= 7 + 4  # a joint marker per moving link and the d segments
    assert {"base_link", "link_0", "link_7", "ee_link"} <= set(robot.frame_names)


def test_urdf_robot_name_defaults_to_the_table_name():
    assert '<robot name="planar_2r">' in urdf_from_dh(load_dh(DH_DIR / "planar_2r.yaml"))
    assert '<robot name="other">' in urdf_from_dh(load_dh(DH_DIR / "planar_2r.yaml"), name="other")


# --------------------------------------------------------------------------
# S2: names cannot change the URDF's structure (issue 15)

INJECTION = 'a --> <link name="extra"/><joint name="j" type="fixed"><parent link="ee_link"/><child link="extra"/></joint> <!-- b'


def structure(text):
    """(robot name, link names, joint names, comments) of URDF text, parsed by ElementTree."""
    import xml.etree.ElementTree as ET

    parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
    parser.feed(text.encode())
    root = parser.close()
    comments = [element.text for element in root.iter() if element.tag is ET.Comment]
    return (root.get("name"), [link.get("name") for link in root.iter("link")],
            [joint.get("name") for joint in root.iter("joint")], comments)


def injected_table():
    rows = [DHRow(0.5, math.pi / 2, 0.1, 0, name=INJECTION), DHRow(0.3, 0, 0, 0.2, "prismatic", (0, 0.4), name="<&>\"'")]
    return DHTable(rows, "standard", INJECTION)


def test_names_with_markup_do_not_change_the_urdf_structure():
    table = injected_table()
    text = urdf_from_dh(table)
    name, links, joints, comments = structure(text)
    assert name == INJECTION  # the table's name survives as text
    assert links == ["base_link", "link_0", "link_1", "link_2", "ee_link"]
    assert joints == ["base_joint", INJECTION, "<&>\"'", "tool_joint"]
    assert len(comments) == 1 and "--" not in comments[0] and "a - -> <link" in comments[0]
    robot = Robot.from_urdf(text)  # Pinocchio sees the same chain: the table's FK
    assert robot.joint_names == (INJECTION, "<&>\"'")
    Q = np.array([[0.3, 0.1], [-1.0, 0.35]])
    assert np.abs(robot.fk(Q, tip="ee_link") - dh_fk(table, Q)).max() < 1e-12


def test_dh_to_urdf_command_writes_the_table_s_structure_only(tmp_path):
    from cli_helper import run_cli

    from manipkit.dh import save_dh

    save_dh(injected_table(), tmp_path / "injected.yaml")
    result = run_cli("manipkit", "dh", "to-urdf", tmp_path / "injected.yaml")
    assert result.returncode == 0, result.stderr
    name, links, joints, _ = structure(result.stdout)
    assert name == INJECTION and links == ["base_link", "link_0", "link_1", "link_2", "ee_link"]
    assert joints == ["base_joint", INJECTION, "<&>\"'", "tool_joint"]


def test_two_rows_naming_one_joint_are_refused():
    rows = [DHRow(1, 0, 0, 0, name="elbow"), DHRow(1, 0, 0, 0, name="elbow")]
    with pytest.raises(DHTableError, match="rows 1 and 2 would both be joint 'elbow'"):
        urdf_from_dh(DHTable(rows, "standard", "twice"))
    with pytest.raises(DHTableError, match="rows 1 and 2 would both be joint 'joint_2'"):
        urdf_from_dh(DHTable([DHRow(1, 0, 0, 0, name="joint_2"), DHRow(1, 0, 0, 0)], "standard"))
    with pytest.raises(DHTableError, match="the name of the URDF's fixed base joint"):
        urdf_from_dh(DHTable([DHRow(1, 0, 0, 0, name="base_joint")], "standard"))


def test_a_name_xml_cannot_hold_is_refused():
    with pytest.raises(DHTableError, match="U\\+FFFE, which XML cannot hold"):
        urdf_from_dh(DHTable([DHRow(1, 0, 0, 0, name="j\ufffe")], "standard"))


def test_save_urdf_writes_the_file_and_creates_no_folder(tmp_path):
    table = load_dh(DH_DIR / "planar_2r.yaml")
    path = save_urdf(table, tmp_path / "planar_2r.urdf")
    assert path.read_text() == urdf_from_dh(table)
    with pytest.raises(OutputError, match="no such folder"):
        save_urdf(table, tmp_path / "missing" / "planar_2r.urdf")
    assert not (tmp_path / "missing").exists()
    with pytest.raises(OutputError, match="it is a folder"):
        save_urdf(table, tmp_path)
